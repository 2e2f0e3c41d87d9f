//! Issue 14's references — the whole cut's optimum and the smallest excess at a change any controller
//! could leave — against what the controllers do, and what the MPC's spindle angle buys at a step made
//! at once.

use crate::common::*;
use millcomp_closedloop::changes::ChangeKind;
use millcomp_closedloop::{ControllerKind, RunReport, Scenario, run_scenario};

fn run(s: &Scenario, k: ControllerKind) -> RunReport {
    let r = run_scenario(s, k).unwrap();
    assert!(r.commands_finite && r.commands_in_limits, "{k}: commands");
    r
}

fn excess_at(r: &RunReport, kind: ChangeKind) -> (f64, f64) {
    let c = r
        .changes
        .iter()
        .find(|c| c.kind == kind)
        .unwrap_or_else(|| panic!("{}: no {kind:?} change", r.controller));
    (c.excess_um, c.bound_um.expect("a bound at every change"))
}

/// The 20 µm depth step made at once at 6 mm, cut to 10.5 mm (the settled window ends 4 mm after it).
fn depth_at_once() -> Scenario {
    let mut s = scenario("groove_s7_20deg_depth_at_once.toml");
    s.groove.as_mut().unwrap().length_mm = 10.5;
    s
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn no_controller_leaves_less_than_the_bound_and_the_bound_is_not_half_the_step() {
    let s = depth_at_once();
    let none = run(&s, ControllerKind::None);
    let (step, _) = excess_at(&none, ChangeKind::Depth);
    for k in [ControllerKind::PidTuned, ControllerKind::Mpc] {
        let r = run(&s, k);
        for c in &r.changes {
            let b = c.bound_um.unwrap();
            assert!(
                c.excess_um >= b,
                "{k} {:?}: excess {} < bound {b}",
                c.kind,
                c.excess_um
            );
        }
    }
    // knowing the deflection in advance — its tooth phase included — the true actuator could follow the
    // step almost entirely: the limit is not half the step (as a controller blind to the phase is held
    // to), but a small part of it
    let (_, bound) = excess_at(&none, ChangeKind::Depth);
    assert!(step > 3.0, "uncompensated step {step}");
    assert!(bound < 0.1 * step, "bound {bound} against a step of {step}");
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn the_spindle_angle_seen_in_the_force_times_the_step() {
    let s = depth_at_once();
    let with = run(&s, ControllerKind::Mpc);
    let mut blind = s.clone();
    blind.control.groove_mpc.spindle_phase = false;
    let without = run(&blind, ControllerKind::Mpc);
    let (e_with, _) = excess_at(&with, ChangeKind::Depth);
    let (e_without, _) = excess_at(&without, ChangeKind::Depth);
    // measured 1.03 against 1.85 µm (seed 24): a step the plan times to the flute that cuts it is
    // pre-moved for; one spread over the unknown phase is met late
    assert!(
        e_with <= 0.75 * e_without,
        "with the angle {e_with}, without {e_without}"
    );
    let pid = run(&s, ControllerKind::PidTuned);
    let (e_pid, _) = excess_at(&pid, ChangeKind::Depth);
    // issue 14: at most half of pid-tuned's
    assert!(e_with <= 0.5 * e_pid, "mpc {e_with}, pid-tuned {e_pid}");
}

#[test]
fn the_optimum_is_the_stroke_bound_with_an_exact_model_and_below_every_controller() {
    let mut s = scenario("groove_s7_20deg.toml");
    s.groove.as_mut().unwrap().length_mm = 20.0;
    // the 20° ramp needs more z than the stroke gives at its deep end: the optimum is at least the
    // stroke bound, and a noise-free plan reaches it up to the model's error
    for k in [ControllerKind::Pid, ControllerKind::Mpc] {
        let r = run(&s, k);
        let m = &r.metrics;
        let (opt, stroke) = (m.optimum_pp_um.unwrap(), m.stroke_bound_um.unwrap());
        assert!(stroke > 1.0, "stroke bound {stroke}");
        assert!(
            opt >= stroke - 1e-9,
            "{k}: optimum {opt} < stroke bound {stroke}"
        );
        assert!(
            opt <= stroke + 0.5,
            "{k}: optimum {opt} vs stroke bound {stroke}"
        );
        assert!(
            m.pp_error_um >= opt - RESOLUTION_20DEG_UM,
            "{k}: {} < {opt}",
            m.pp_error_um
        );
    }
}
