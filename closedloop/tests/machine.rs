//! A depth offset along the path the nominal model lacks (a guideway bump), in the truth, and the
//! controllers told of it (`DeflectionPlan::with_path_offset`): told, the MPC and open-loop take it out;
//! not told, they cannot see it. And the simulated machine's instruments.

use crate::common::*;
use millcomp_closedloop::ControllerKind;
use millcomp_closedloop::groove::{deflection_plan, groove_setup, run_groove_with};
use millcomp_closedloop::machine::SimulatedMachine;
use millcomp_sim::groove::{DepthProfile, PathOffset};

/// A 4 mm groove at a constant 40 µm (its deflection steady after the first revolutions) on a guideway
/// that raises the tool by 3 µm over the groove (a smooth rise: the groove shallower, + = deeper).
/// Inside the groove (0.3 mm after the entry to 0.3 mm before the end: the entry's and the exit's
/// transients, which the offset does not touch, set the whole groove's peak to peak), the MPC not told
/// of the offset drifts with it by about 2.8 µm; told, its error stays flat (about 0.2 µm) — the test
/// fails if the controller does not use what it was told. Open-loop likewise (blind about 2.4 µm).
#[test]
fn a_controller_told_of_a_path_offset_takes_it_out() {
    let mut s = scenario("groove_s7_20deg.toml");
    let g = s.groove.as_mut().unwrap();
    g.length_mm = 4.0;
    g.depth = DepthProfile::Constant { depth_um: 40.0 };
    let mut setup = groove_setup(&s).unwrap();
    let rise: Vec<(f64, f64)> = (0..=40)
        .map(|i| {
            let x = 0.1 * i as f64;
            (
                x,
                -3.0 * (0.5 - 0.5 * (std::f64::consts::PI * x / 4.0).cos()),
            )
        })
        .collect();
    let offset = PathOffset::new(rise).unwrap();
    setup.truth.path_offset = offset.clone();
    let plan = deflection_plan(&setup, 0.01).unwrap();
    for kind in [ControllerKind::Mpc, ControllerKind::OpenLoop] {
        let blind = run_groove_with(&s, &setup, &plan, kind).unwrap();
        let told = run_groove_with(
            &s,
            &setup,
            &plan.clone().with_path_offset(offset.clone()),
            kind,
        )
        .unwrap();
        let (b, t) = (inside_pp(&blind), inside_pp(&told));
        eprintln!("{kind}: pp inside the groove {b:.3} µm blind, {t:.3} µm told of the offset");
        assert!(
            b > 2.0,
            "{kind}: the 3 µm rise shows without the offset: {b}"
        );
        assert!(
            t < 0.6 && t < 0.25 * b,
            "{kind}: told of it, it is taken out: {t} vs {b}"
        );
        assert!(told.report.commands_finite && told.report.commands_in_limits);
    }
}

/// Peak to peak of the depth error (µm) from 0.3 mm into the groove to 0.3 mm before its end (the
/// trace's `x_mm`), away from the entry's and the exit's transients.
fn inside_pp(out: &millcomp_closedloop::RunOutput) -> f64 {
    let col = |n: &str| out.trace.columns.iter().position(|c| c == n).unwrap();
    let (ix, ie) = (col("x_mm"), col("error_um"));
    let e: Vec<f64> = out
        .trace
        .rows
        .iter()
        .filter(|r| (0.3..=3.7).contains(&r[ix]))
        .map(|r| r[ie])
        .collect();
    assert!(e.len() > 100, "trace inside the groove: {} rows", e.len());
    e.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - e.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The machine is one machine: the same seed measures the same records; what it returns has the
/// instruments' shapes; it refuses a material it has no bundle for, naming it.
#[test]
fn the_simulated_machine_measures_through_its_instruments() {
    let m = SimulatedMachine::new(7);
    let plan = millcomp_closedloop::commissioning::CommissioningPlan::default();
    let a = m.step_test(&plan, 1).unwrap();
    let b = SimulatedMachine::new(7).step_test(&plan, 1).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.t_s.len(), a.y_um.len());
    // 5 ms before and 30 ms after the step at 20 kHz
    assert_eq!(a.t_s.len(), 700);
    let c = SimulatedMachine::new(8).step_test(&plan, 1).unwrap();
    assert_ne!(a, c, "another seed, another machine");
    let rest = m.sensors_at_rest(100, 5e-5, 2).unwrap();
    assert_eq!(rest.force_n.len(), 100);
    let runs = m.runs(Default::default());
    let spec = millcomp_closedloop::batch::factors::ScenarioSpec {
        index: 0,
        factors: [(
            "material".to_string(),
            millcomp_closedloop::batch::factors::FactorValue::Text("6061".into()),
        )]
        .into_iter()
        .collect(),
    };
    let e = millcomp_closedloop::batch::exec::ClosedLoop::run(&runs, &spec, "mpc").unwrap_err();
    let msg = millcomp_closedloop::error_chain(&e);
    assert!(msg.contains("material") && msg.contains("6061"), "{msg}");
}
