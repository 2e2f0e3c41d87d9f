//! Known process changes (issue 6): a feed doubling, a depth step and the cutter exiting the workpiece.
//! Seed 003_…txt §3.2–3.3: proactive compensation 43 µm vs reactive 74 µm peak at a feed step; at the exit
//! a reactive compensation cuts undersize because its actuating value is not reduced fast enough.
//! Issue 6: MPC's peak error at most half of PID's, and no undersize at the exit beyond 1 µm.

use crate::common::*;
use millcomp_closedloop::changes::ChangeKind;
use millcomp_closedloop::{ControllerKind, RunReport, run_scenario};

fn run(s: &millcomp_closedloop::Scenario, k: ControllerKind) -> RunReport {
    let r = run_scenario(s, k).unwrap();
    assert!(r.commands_finite && r.commands_in_limits, "{k}: commands");
    r
}

/// The run's excess over the settled error at its change of `kind` (µm).
fn excess_at(r: &RunReport, kind: ChangeKind) -> f64 {
    r.changes
        .iter()
        .find(|c| c.kind == kind)
        .unwrap_or_else(|| panic!("{kind:?} in {:?}", r.changes))
        .excess_um
}

/// Shorten a scenario around its change at x = 10 mm to keep the debug test fast: the cut from 7 mm on
/// is what the change window (9.5–12 mm) needs after the MPC/PID transients of the start (< 1 s) decay.
fn around_change(mut s: millcomp_closedloop::Scenario) -> millcomp_closedloop::Scenario {
    if let Some(g) = s.groove.as_mut() {
        g.length_mm = g.length_mm.min(13.0);
    }
    s
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn feed_doubling_mpc_peak_at_most_half_of_pid() {
    let s = around_change(scenario("groove_s7_20deg_feed_step.toml"));
    let none = run(&s, ControllerKind::None);
    let pid = run(&s, ControllerKind::Pid);
    let mpc = run(&s, ControllerKind::Mpc);
    let (n, p, m) = (
        none.process_change_peak_um.unwrap(),
        pid.process_change_peak_um.unwrap(),
        mpc.process_change_peak_um.unwrap(),
    );
    // the doubling raises the deflection by several µm (chip thickness ×2, 000 eq. 2)
    assert!(n > 8.0, "uncompensated peak {n}");
    assert!(m <= 0.5 * p, "feed step: mpc {m} pid {p}");
    assert_eq!(mpc.solver.unwrap().fallbacks, 0);
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn depth_plunge_mpc_peak_at_most_half_of_pid() {
    let s = around_change(scenario("groove_s7_20deg_depth_step.toml"));
    let pid = run(&s, ControllerKind::Pid).process_change_peak_um.unwrap();
    let mpc = run(&s, ControllerKind::Mpc).process_change_peak_um.unwrap();
    assert!(mpc <= 0.5 * pid, "depth step: mpc {mpc} pid {pid}");
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn exit_mpc_no_undersize_and_half_of_pid() {
    let s = scenario("groove_s7_20deg_exit.toml");
    let none = run(&s, ControllerKind::None);
    let pid = run(&s, ControllerKind::Pid);
    let mpc = run(&s, ControllerKind::Mpc);
    // uncompensated: the deflection falls to 0 but never below (003 §3.3: "always remains positive")
    assert!(none.metrics.exit_overcut_um.unwrap() <= 1e-9);
    // a reactive PID keeps pushing the tip in as the force drops: overcut (003's undersize)
    let pid_over = pid.metrics.exit_overcut_um.unwrap();
    let mpc_over = mpc.metrics.exit_overcut_um.unwrap();
    assert!(pid_over > 1.0, "pid exit overcut {pid_over}");
    // issue 6: no undersize at the exit beyond 1 µm
    assert!(mpc_over <= 1.0, "mpc exit overcut {mpc_over}");
    let (p, m) = (
        pid.process_change_peak_um.unwrap(),
        mpc.process_change_peak_um.unwrap(),
    );
    assert!(m <= 0.5 * p, "exit: mpc {m} pid {p}");
}

/// The response-surface force predictor (`doe analyze --save`) in the MPC's preview: a quadratic in depth
/// and upfeed fitted to the controllers' own mechanistic predictions on a 4 × 3 grid gives the same
/// closed-loop result as the mechanistic predictor it approximates, and still halves PID's peak at the
/// feed step.
#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn response_surface_predictor_drives_the_preview() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze, response_surface};

    let mut s = around_change(scenario("groove_s7_20deg_feed_step.toml"));
    s.truth.force_errors = Some(millcomp_closedloop::model_errors::ForceErrors {
        w_mpa: 0.05,
        mu_rake: 0.0,
        mu_flank: 0.0,
        wearland_um: 0.0,
    });
    // the controllers' own mechanistic model (commissioned, W + 5 % on top) tabulated on the grid
    let setup = millcomp_closedloop::groove::groove_setup(&s).unwrap();
    let millcomp_mpc::predictor::ForcePredictor::Mechanistic(model) = &setup.model_force else {
        panic!("a mechanistic predictor");
    };
    let program = &setup.truth.program;
    let (mut d, mut u, mut f) = (Vec::new(), Vec::new(), Vec::new());
    for depth in [20.0, 40.0, 60.0, 80.0] {
        for upfeed in [5.0, 12.5, 20.0] {
            d.push(depth);
            u.push(upfeed);
            f.push(
                model
                    .model()
                    .peak_z_force_n(&program.conditions_at(depth, upfeed))
                    .unwrap(),
            );
        }
    }
    let fitted = response_surface(
        &analyze(&AnalysisInput {
            factors: vec![
                ("depth_um".into(), Values::F64(d)),
                ("upfeed_um".into(), Values::F64(u)),
            ],
            response_name: "max_fz_n".into(),
            response: Values::F64(f),
            model: ModelSpec::Quadratic,
        })
        .unwrap(),
    )
    .unwrap();
    assert!(fitted.r_squared > 0.99, "R² {}", fitted.r_squared);
    let dir = std::env::temp_dir().join(format!("millcomp-rs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fz_surface.toml");
    millcomp_models::ModelFile::new(
        "response_surface",
        fitted,
        millcomp_models::Provenance::now("test", "response_surface_predictor_drives_the_preview"),
    )
    .save(&path)
    .unwrap();

    // a response surface predicts the peak force, not its waveform over a revolution: compare the two
    // predictors with the plan timed without the waveform (no spindle angle, every tooth alike)
    s.control.groove_mpc.spindle_phase = false;
    s.control.groove_mpc.flute_phase = false;
    let mech = run(&s, ControllerKind::Mpc);
    let mut rs = s.clone();
    rs.control.force_response_surface = Some(path.display().to_string());
    let surf = run(&rs, ControllerKind::Mpc);
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        surf.notes.iter().any(|n| n.contains("response surface")),
        "{:?}",
        surf.notes
    );
    // the same closed loop within a quarter of a µm: the surface reproduces the model it was fitted to.
    // With the approach in air the groove's peak-to-peak is set at the feed change, where the surface's
    // few-% misfit of the jump shows (measured: 1.06 vs 0.85 µm); before it, the entry at full depth set
    // both at ≈ 7.6 µm and hid the difference.
    assert!(
        (surf.metrics.pp_error_um - mech.metrics.pp_error_um).abs() < 0.25,
        "pp: surface {} mechanistic {}",
        surf.metrics.pp_error_um,
        mech.metrics.pp_error_um
    );
    let (ps, pm) = (
        surf.process_change_peak_um.unwrap(),
        mech.process_change_peak_um.unwrap(),
    );
    // at the change the surface's few-% misfit of the force jump shows (measured: 0.71 vs 0.58 µm); it
    // must still meet issue 6's process-change bound against PID
    let pid = run(&s, ControllerKind::Pid).process_change_peak_um.unwrap();
    assert!(
        ps <= 0.5 * pid && (ps - pm).abs() < 0.25,
        "change peak: surface {ps} mechanistic {pm} pid {pid}"
    );
}

/// Issue 14's harsh form: the depth steps 20 µm at once (over 1 µm of travel), after an approach in air
/// and an entry at depth. The excess over each controller's own settled error
/// (`millcomp_closedloop::changes`): the MPC's preview leaves less than pid-tuned's reaction (measured
/// over seeds 1–10: 1.81 [1.74, 1.99] vs 3.15 [3.09, 3.21] µm; `examples/compare.rs --changes`), and
/// with the approach no controller's entry excess reaches 1 µm (without one the MPC's was 5.1 µm: the
/// 570 V step at t = 0).
#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn depth_at_once_and_the_entry_after_an_approach() {
    let s = scenario("groove_s7_20deg_depth_at_once.toml");
    let pid = run(&s, ControllerKind::PidTuned);
    let mpc = run(&s, ControllerKind::Mpc);
    let (p, m) = (
        excess_at(&pid, ChangeKind::Depth),
        excess_at(&mpc, ChangeKind::Depth),
    );
    assert!(m < 0.75 * p, "depth at once: mpc {m} pid-tuned {p}");
    for r in [&pid, &mpc] {
        let e = excess_at(r, ChangeKind::Entry);
        assert!(e < 1.0, "{}: entry excess {e}", r.controller);
    }
    // the metric is the largest excess over the changes
    assert_eq!(
        mpc.metrics.change_excess_um,
        Some(excess_at(&mpc, ChangeKind::Depth).max(excess_at(&mpc, ChangeKind::Entry)))
    );
}

/// The entry at depth: the deflection rises a step per revolution as the ball engages (0.3–0.6 µm a
/// step at 40 µm), at an instant set by the spindle's angle. The MPC and `pid-ff` take the angle from
/// the first revolution whose force peak stands 6 σ above the channel's noise, matched against the plan's
/// force waveform (`millcomp_mpc::groove::SpindlePhase`); when they waited for three revolutions' force
/// peaks (before 2026-11-28) the first steps were planned at the midpoint over the unknown angle and the
/// MPC's entry excess was 0.38 µm on this seed, 0.54× `pid-tuned`'s 0.70 (`millcomp simulate`, the
/// depth-step scenario at seed 3, whose commissioned model settles within 0.01 µm of the truth, so the
/// excess is the transient's, not a level change; now 0.26 µm against 0.70, shortened to the 4.5 mm
/// the entry's windows need).
#[test]
fn the_entry_is_timed_from_the_first_revolution_with_a_cut() {
    let mut s = scenario("groove_s7_20deg_depth_step.toml");
    s.seed = 3;
    if let Some(g) = s.groove.as_mut() {
        g.length_mm = 4.5;
    }
    let pid = run(&s, ControllerKind::PidTuned);
    let mpc = run(&s, ControllerKind::Mpc);
    let settled = mpc
        .changes
        .iter()
        .find(|c| c.kind == ChangeKind::Entry)
        .unwrap()
        .settled_um;
    assert!(settled.abs() < 0.05, "the seed's settled level {settled}");
    let (p, m) = (
        excess_at(&pid, ChangeKind::Entry),
        excess_at(&mpc, ChangeKind::Entry),
    );
    assert!(m <= 0.5 * p, "entry: mpc {m} pid-tuned {p}");
}

/// On a hysteretic stack the tip departs from the linear stack model while the stack climbs ≈ 600 V
/// at the entry. The gauge sees it at once (0.01 µm noise); the depth-error channel only through the
/// force's noise. With the gauge's disturbance taken as the stack's (`stack_disturbance`: it enters the
/// error through sin(tilt) and walks as fast as the gauge reads) the MPC's error prediction has the
/// misfit within cycles, and the entry's excess falls (commissioned depth step, seeds 1–10: 0.51 →
/// 0.39 µm, the coupling alone 0.46; here seed 7 over 4.5 mm: 0.52 → 0.34 µm).
#[test]
fn the_stacks_lag_seen_by_the_gauge_reaches_the_error_prediction() {
    use millcomp_closedloop::compare::commissioned;

    let mut s = commissioned(&scenario("groove_s7_20deg_depth_step.toml"));
    s.seed = 7;
    if let Some(g) = s.groove.as_mut() {
        g.length_mm = 4.5;
    }
    let with = excess_at(&run(&s, ControllerKind::Mpc), ChangeKind::Entry);
    s.control.groove_mpc.stack_disturbance = false;
    let without = excess_at(&run(&s, ControllerKind::Mpc), ChangeKind::Entry);
    assert!(with < 0.8 * without, "entry: with {with} without {without}");
}

/// The open-loop compensation follows the plan in time (midpoint over the spindle's unmeasured angle),
/// so a step made at once costs it no more than the uncompensated step: before, it stepped its command at
/// the program's corner one revolution before the deflection arrived and left 4.35 µm against the
/// uncompensated 3.30 µm (seed 1).
#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn open_loop_does_not_step_ahead_of_a_step_made_at_once() {
    let mut s = scenario("groove_s7_20deg_depth_at_once.toml");
    if let Some(g) = s.groove.as_mut() {
        g.length_mm = g.length_mm.min(10.5);
    }
    let excess = |r: &RunReport| excess_at(r, ChangeKind::Depth);
    let none = excess(&run(&s, ControllerKind::None));
    let ol = excess(&run(&s, ControllerKind::OpenLoop));
    assert!(ol < none, "open-loop {ol} uncompensated {none}");
}

/// Why the commissioned exit's overcut exceeds 1 µm for every controller (issue 14's bound): after
/// the deep cut held the hysteretic stack near 800 V, the stack at the amplifier's floor (0 V) still
/// holds its tip ≈ 4.7–5.4 µm out (Bouc–Wen remanence, `sim::actuator`), ≈ 1.6–1.9 µm of depth at
/// 20°. As the cutter leaves (the engagement falls over the last 0.21 mm) the MPC reaches 0 V and the
/// part of the ball still engaged cuts that much deeper than the settled level: the exit's excess. On
/// a linear stack with the same drawn instruments and tool the excess is a fraction of it. Seed 1
/// (seeds 1–10: `examples/exit_remanence.rs`, in docs/studies/process-changes.md).
#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn the_commissioned_exit_overcut_is_the_stacks_remanence_at_zero_volts() {
    use millcomp_closedloop::compare::commissioned;
    use millcomp_closedloop::touch_off::TouchOffBias;

    let mut s = commissioned(&scenario("groove_s7_20deg_exit.toml"));
    s.seed = 1;
    s.control.touch_off_bias = TouchOffBias::Rest;
    let exit_excess = |r: &RunReport| excess_at(r, ChangeKind::Exit);
    let hysteretic = run(&s, ControllerKind::Mpc);
    let tip = hysteretic.metrics.exit_floor_tip_um;
    assert!(tip.is_some_and(|t| t > 4.0), "tip at the floor {tip:?}");
    assert!(
        exit_excess(&hysteretic) > 1.0,
        "{}",
        exit_excess(&hysteretic)
    );
    s.truth.pzt_nonlinear = false;
    let linear = run(&s, ControllerKind::Mpc);
    assert!(
        linear.metrics.exit_floor_tip_um.is_none_or(|t| t < 0.5),
        "{:?}",
        linear.metrics.exit_floor_tip_um
    );
    assert!(exit_excess(&linear) < 0.5, "{}", exit_excess(&linear));
}

/// A touch-off at a bias gives the stack the travel below the depth's zero that the exit needs: on the
/// commissioned exit of seed 8 the program leaves room above its planned peak, `auto` touches off at a
/// bias, the MPC's command never reaches the amplifier's 0 V floor as the cutter leaves, and the exit's
/// excess falls to well under half of the touch-off at rest's (seeds 1–10: `examples/exit_remanence.rs
/// --touch-off auto`, in docs/studies/process-changes.md). The shipped exit (a linear stack, no hysteresis model) is touched
/// off at rest whatever the key says.
#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn a_touch_off_at_a_bias_leaves_the_stack_room_to_retract_at_the_exit() {
    use millcomp_closedloop::compare::commissioned;
    use millcomp_closedloop::touch_off::TouchOffBias;

    let exit_excess = |r: &RunReport| excess_at(r, ChangeKind::Exit);
    let mut s = commissioned(&scenario("groove_s7_20deg_exit.toml"));
    assert_eq!(s.control.touch_off_bias, TouchOffBias::Auto);
    s.seed = 8;
    let biased = run(&s, ControllerKind::Mpc);
    let t = biased.touch_off.expect("touched off at a bias");
    assert!(t.bias_v > 0.0 && t.gauge_um > 0.0, "{t:?}");
    assert!(
        biased.metrics.exit_floor_tip_um.is_none(),
        "the command reached 0 V: tip {:?}",
        biased.metrics.exit_floor_tip_um
    );
    s.control.touch_off_bias = TouchOffBias::Rest;
    let rest = run(&s, ControllerKind::Mpc);
    let (b, r) = (exit_excess(&biased), exit_excess(&rest));
    assert!(b < 0.5 * r, "exit excess {b} at the bias, {r} at rest");

    let shipped = run(&scenario("groove_s7_20deg_exit.toml"), ControllerKind::None);
    assert_eq!(shipped.touch_off, None);
}
