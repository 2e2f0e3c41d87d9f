//! A depth offset along the path the nominal model lacks (a guideway bump), in the truth, and the
//! controllers told of it (`DeflectionPlan::with_path_offset`): told, the MPC and open-loop take it out;
//! not told, they cannot see it. And the simulated machine's instruments.

use crate::common::*;
use millcomp_closedloop::groove::{deflection_plan, groove_setup, run_groove_with};
use millcomp_closedloop::machine::SimulatedMachine;
use millcomp_closedloop::ControllerKind;
use millcomp_sim::groove::{DepthProfile, PathOffset};

/// A 4 mm groove at a constant 40 µm (its deflection steady after the first revolutions) on a guideway
/// that raises the tool by 3 µm over the groove (a smooth rise: the groove shallower, + = deeper).
/// Without the offset in its plan the MPC leaves about those 3 µm peak to peak; with it, less than
/// 1 µm — the test fails if the controller does not use what it was told. Open-loop likewise.
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
            (x, -3.0 * (0.5 - 0.5 * (std::f64::consts::PI * x / 4.0).cos()))
        })
        .collect();
    let offset = PathOffset::new(rise).unwrap();
    setup.truth.path_offset = offset.clone();
    let plan = deflection_plan(&setup, 0.01).unwrap();
    for kind in [ControllerKind::Mpc, ControllerKind::OpenLoop] {
        let blind = run_groove_with(&s, &setup, &plan, kind).unwrap().report;
        let told = run_groove_with(&s, &setup, &plan.clone().with_path_offset(offset.clone()), kind)
            .unwrap()
            .report;
        let (b, t) = (blind.metrics.pp_error_um, told.metrics.pp_error_um);
        eprintln!("{kind}: pp {b:.3} µm blind, {t:.3} µm told of the offset");
        assert!(b > 2.5, "{kind}: the 3 µm rise shows without the offset: {b}");
        assert!(t < 1.0 && t < 0.4 * b, "{kind}: told of it, it is taken out: {t} vs {b}");
        assert!(told.commands_finite && told.commands_in_limits);
    }
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
