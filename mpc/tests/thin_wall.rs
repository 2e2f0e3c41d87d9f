//! Thin walls (004_…txt): 80/100/120 µm H59 brass walls. Published (Table 5): uncompensated
//! 85.9/106.7/127.8 µm (6.86 % mean), iterative compensation 81.9/102.1/122.5 µm (2.19 % mean).

mod common;

use common::*;
use millcomp_mpc::{ControllerKind, run_scenario};

#[test]
fn thin_walls_uncompensated_threshold_and_mpc() {
    let s = scenario("thin_wall_h59.toml");
    let none = run_scenario(&s, ControllerKind::None).unwrap();
    let thr = run_scenario(&s, ControllerKind::Threshold).unwrap();
    let mpc = run_scenario(&s, ControllerKind::Mpc).unwrap();
    let pct = |r: &millcomp_mpc::RunReport| r.metrics.thickness_error_pct.clone().unwrap();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    // uncompensated: sim's stage is calibrated on the 100 µm wall (106.7 µm); mean within ±1.5 % of the
    // published 6.86 % (noise, stage accuracy, length grid)
    assert!((mean(&pct(&none)) - 6.86).abs() < 1.5, "{:?}", pct(&none));
    // MPC ≤ 1 % on every wall (issue 6)
    for (i, p) in pct(&mpc).iter().enumerate() {
        assert!(p.abs() <= 1.0, "wall {i}: {p} %");
    }
    // the faithful 004 baseline (deformation from eq. 18, the wall only) removes part of the error: it
    // must land between the published compensated 2.19 % and the uncompensated level. Measured 5.2 %:
    // sim's tool deflection (k_tool 1.035 N/µm, assumed) is ~2/3 of the total and eq. 18 has no tool term.
    let m = mean(&pct(&thr));
    assert!(
        m > 2.19 - 0.5 && m < mean(&pct(&none)),
        "threshold mean {m} %"
    );
    assert!(thr.walls.as_ref().unwrap().len() == 3);
    assert!(mpc.solver.unwrap().fallbacks == 0);
}
