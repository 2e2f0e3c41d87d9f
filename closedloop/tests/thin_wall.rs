//! Thin walls (004_…txt): 80/100/120 µm H59 brass walls. Published (Table 5): uncompensated
//! 85.9/106.7/127.8 µm (6.86 % mean), iterative compensation 81.9/102.1/122.5 µm (2.38/2.10/2.08 %, mean
//! 2.19 %). sim's K_r and tool fluted length are calibrated jointly on 106.7 µm and 2.19 %
//! (`millcomp_sim::thinwall::calibrate_kr_and_flute`); the scenario adds what the ideal calibration lacks:
//! the controllers' force coefficient off by up to 15 %, the identified tool stiffness, 0.001 N force noise
//! and the stage's ±0.5 µm positioning accuracy.

use crate::common::*;
use millcomp_closedloop::{ControllerKind, RunReport, run_scenario};

/// Published values, 004 Table 5.
const NOMINAL_UM: [f64; 3] = [80.0, 100.0, 120.0];
/// 004 Table 5, thickness without compensation (µm).
const UNCOMPENSATED_UM: [f64; 3] = [85.9, 106.7, 127.8];
/// 004 Table 5, mean relative error with compensation: (2.38 + 2.10 + 2.08)/3 = 2.19 %.
const THRESHOLD_MEAN_PCT: f64 = 2.19;

/// Uncompensated walls vs Table 5: the 2 µm (sim's own test, ideal stage) plus the stage's 0.5 µm
/// positioning accuracy (004 §2.2), which the scenario draws once per wall even at a zero command.
const UNCOMPENSATED_ABS_UM: f64 = 2.5;

/// "Near the published 2.19 %" (issue 6): ±0.5 percentage points. The ideal calibration hits 2.19 %
/// exactly; the scenario's stage accuracy (±0.5 µm per move, ≈ ±0.4 % of the 120 µm wall at worst, less on
/// the mean of many moves) and force noise move it by a few tenths at most.
const THRESHOLD_MEAN_RANGE_PCT: (f64, f64) = (THRESHOLD_MEAN_PCT - 0.49, THRESHOLD_MEAN_PCT + 0.51);

/// Issue 6: MPC ≤ 1 % on every wall.
const MPC_MAX_PCT: f64 = 1.0;

/// Open loop follows the plan of the perturbed model: its residual is bounded by the force-coefficient
/// error (≤ 15 %) × the uncompensated excess (≈ 7 %) ≈ 1.05 %, plus the stage accuracy 0.5 µm on the
/// 80 µm wall (0.63 %): 1.7 %.
const OPEN_LOOP_MAX_PCT: f64 = 1.7;

/// PID measures the force, so the force-coefficient error drops out; what remains is the stage accuracy
/// (0.63 % of 80 µm) and the lag at layer changes: the 1 % bound for the model-based controllers.
const PID_MAX_PCT: f64 = 1.0;

fn pct(r: &RunReport) -> Vec<f64> {
    r.metrics.thickness_error_pct.clone().unwrap()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn thin_walls_all_controllers_against_table_5() {
    let s = scenario("thin_wall_h59.toml");
    let run = |k| run_scenario(&s, k).unwrap();
    let (none, thr, mpc) = (
        run(ControllerKind::None),
        run(ControllerKind::Threshold),
        run(ControllerKind::Mpc),
    );
    let (ol, pid) = (run(ControllerKind::OpenLoop), run(ControllerKind::Pid));
    for r in [&none, &thr, &mpc, &ol, &pid] {
        eprintln!(
            "{:10} {:?} µm, {:?} %",
            r.controller,
            r.metrics.thickness_um.as_ref().unwrap(),
            pct(r)
        );
        assert_eq!(r.walls.as_ref().unwrap().len(), 3);
        assert!(r.commands_finite && r.commands_in_limits);
    }

    // uncompensated: per wall within 2.5 µm of Table 5, mean within ±1.5 % of the published 6.86 %
    let t_none = none.metrics.thickness_um.clone().unwrap();
    for ((t, published), nominal) in t_none.iter().zip(UNCOMPENSATED_UM).zip(NOMINAL_UM) {
        assert!(
            (t - published).abs() <= UNCOMPENSATED_ABS_UM,
            "wall {nominal}: {t} µm"
        );
    }
    assert!((mean(&pct(&none)) - 6.86).abs() < 1.5, "{:?}", pct(&none));

    // the faithful 004 threshold baseline lands near the published 2.19 % mean (Table 5), every wall
    // thinner than uncompensated and still over nominal (it never compensates the tool deflection)
    let m = mean(&pct(&thr));
    assert!(
        m >= THRESHOLD_MEAN_RANGE_PCT.0 && m <= THRESHOLD_MEAN_RANGE_PCT.1,
        "threshold mean {m} %"
    );
    for (i, p) in pct(&thr).iter().enumerate() {
        assert!(*p > 0.0 && *p < pct(&none)[i] - 2.0, "wall {i}: {p} %");
    }

    // MPC ≤ 1 % on every wall (issue 6), no fallbacks; PID and open loop within their bounds
    for (i, p) in pct(&mpc).iter().enumerate() {
        assert!(p.abs() <= MPC_MAX_PCT, "mpc wall {i}: {p} %");
    }
    assert_eq!(mpc.solver.as_ref().unwrap().fallbacks, 0);
    for (i, p) in pct(&pid).iter().enumerate() {
        assert!(p.abs() <= PID_MAX_PCT, "pid wall {i}: {p} %");
    }
    for (i, p) in pct(&ol).iter().enumerate() {
        assert!(p.abs() <= OPEN_LOOP_MAX_PCT, "open-loop wall {i}: {p} %");
    }
    // MPC is at least as good as the published method on every wall
    for (m, t) in pct(&mpc).iter().zip(pct(&thr)) {
        assert!(m.abs() < t.abs(), "mpc {m} % vs threshold {t} %");
    }
}
