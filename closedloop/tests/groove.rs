//! Closed loop on sim's groove stage: the must-show figures of issue 6 for the S7 grooves.
//!
//! Published references (000_…txt): uncompensated ≈ 16–17 µm (§6.3, §7.2.2); open loop 16 → 5 µm pp
//! (70 %, §6.3); closed-loop PID 65–80 % (§7.2.2, §7.3.4).

use crate::common::*;
use millcomp_closedloop::{ControllerKind, RunReport, run_scenario};

fn run(s: &millcomp_closedloop::Scenario, k: ControllerKind) -> RunReport {
    let r = run_scenario(s, k).unwrap();
    assert!(r.commands_finite && r.commands_in_limits, "{k}: commands");
    r
}

fn removal(none: &RunReport, r: &RunReport) -> f64 {
    1.0 - r.metrics.pp_error_um / none.metrics.pp_error_um
}

#[test]
fn grooves_20_30_40_deg_uncompensated_open_loop_pid_mpc() {
    for file in [
        "groove_s7_20deg.toml",
        "groove_s7_30deg.toml",
        "groove_s7_40deg.toml",
    ] {
        let s = scenario(file);
        let none = run(&s, ControllerKind::None);
        let ol = run(&s, ControllerKind::OpenLoop);
        let pid = run(&s, ControllerKind::Pid);
        let mpc = run(&s, ControllerKind::Mpc);
        let (lo, hi) = UNCOMPENSATED_RANGE_UM;
        assert!(
            (lo..=hi).contains(&none.metrics.pp_error_um),
            "{file}: uncompensated {}",
            none.metrics.pp_error_um
        );
        // the uncompensated groove is shallower (error ≤ 0 everywhere)
        assert!(none.metrics.max_error_um <= 1e-9);
        // issue 6: open loop and PID each remove ≥ 65 % (published 65–80 %)
        assert!(
            removal(&none, &ol) >= 0.65,
            "{file}: open loop {}",
            ol.metrics.pp_error_um
        );
        assert!(
            removal(&none, &pid) >= 0.65,
            "{file}: pid {}",
            pid.metrics.pp_error_um
        );
        // MPC removes ≥ 90 %
        assert!(
            removal(&none, &mpc) >= 0.90,
            "{file}: mpc {}",
            mpc.metrics.pp_error_um
        );
        // … and is no worse than PID: lower RMS everywhere, peak-to-peak no worse beyond the force-sensor
        // resolution (at 20° both are stroke-limited at the deep end: the PZT's 50 µm tip stroke gives
        // 17.1 µm z, the compensated deflection there is 18.5 µm, so both share the same minimum error;
        // the MPC's maximum is a small overcut just before the stroke runs out — it compensates the
        // deflection computed with the *identified* stiffness, ≈ 1 % off, which PID's filter lag hides.
        // Over seeds 1–6 that overcut is 0.09–0.23 µm; at the shipped seed 0.055 µm)
        assert!(
            mpc.metrics.rms_error_um < pid.metrics.rms_error_um,
            "{file}: rms mpc {} pid {}",
            mpc.metrics.rms_error_um,
            pid.metrics.rms_error_um
        );
        assert!(
            mpc.metrics.pp_error_um <= pid.metrics.pp_error_um + RESOLUTION_20DEG_UM,
            "{file}: pp mpc {} pid {}",
            mpc.metrics.pp_error_um,
            pid.metrics.pp_error_um
        );
        // the stroke bound (static: δ range − tip range · sin α) is a lower bound no controller beats; at
        // 20° the stroke does not cover the compensated deflection (bound > 0), at 30° and 40° it does
        for r in [&none, &ol, &pid, &mpc] {
            let b = r
                .metrics
                .stroke_bound_um
                .expect("grooves report the stroke bound");
            assert!(
                r.metrics.pp_error_um >= b - 1e-9,
                "{file} {}: pp {} below the bound {b}",
                r.controller,
                r.metrics.pp_error_um
            );
        }
        let b = mpc.metrics.stroke_bound_um.unwrap_or(0.0);
        if file.contains("20deg") {
            assert!(b > 1.0, "{file}: bound {b}");
            // the MPC ends within 0.2 µm of the physical limit
            assert!(
                mpc.metrics.pp_error_um - b < 0.2,
                "{file}: mpc {} vs {b}",
                mpc.metrics.pp_error_um
            );
        } else {
            assert_eq!(b, 0.0, "{file}");
        }
        let st = mpc.solver.expect("mpc reports solver stats");
        assert_eq!(st.fallbacks, 0);
        // 12 s of cut at 2 kHz
        assert!(st.solves >= 23_000, "{}", st.solves);
    }
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn residual_error_follows_the_stiffness_error() {
    // sweep (SCENARIOS.md): a controller stiffness 20 % too low makes every force-feedback controller
    // over-compensate by ≈ 20 % of the 16–18 µm deflection; at 0 the MPC is at its ≈ 1.4 µm floor
    let s = scenario("groove_s7_20deg.toml");
    let pts =
        millcomp_closedloop::stiffness_sweep(&s, &[-0.2, 0.0], &[ControllerKind::Mpc]).unwrap();
    assert_eq!(pts.len(), 2);
    assert!(
        (pts[0].kz_error_rel + 0.19).abs() < 0.02,
        "{}",
        pts[0].kz_error_rel
    );
    assert!(
        pts[0].pp_error_um > pts[1].pp_error_um + 2.5,
        "{} vs {}",
        pts[0].pp_error_um,
        pts[1].pp_error_um
    );
    assert!(pts[1].removal_pct >= 90.0);
}

#[test]
fn pid_tuned_is_stable_and_removes_most_of_the_deflection_on_a_commissioned_30deg_groove() {
    // the 30° groove (the PZT has stroke to spare there), commissioned: instrument errors drawn from the
    // seed, every controller built from the commissioning's bundle
    let s = millcomp_closedloop::compare::commissioned(&scenario("groove_s7_30deg.toml"));
    let none = run(&s, ControllerKind::None);
    let tuned = run(&s, ControllerKind::PidTuned);
    assert!(
        tuned
            .notes
            .iter()
            .any(|n| n.starts_with("pid-tuned: kp") && n.contains("Ms 1.60")),
        "{:?}",
        tuned.notes
    );
    // a loop designed for Ms ≤ 1.6 must not ring: the tip travel stays within a few strokes of the
    // 24 µm correction (an oscillating loop travels metres — the first, unchecked design did)
    assert!(
        tuned.metrics.actuator_travel_um < 500.0,
        "travel {}",
        tuned.metrics.actuator_travel_um
    );
    // the published closed-loop band is 65–80 % removal (000 §7.2.2); a modern PI must reach it
    assert!(
        removal(&none, &tuned) >= 0.65,
        "pid-tuned {} vs none {}",
        tuned.metrics.pp_error_um,
        none.metrics.pp_error_um
    );
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn the_mpc_does_not_limit_cycle_on_a_hysteretic_stack_and_its_ablations_run() {
    // the commissioned 30° groove: a stack with hysteresis and creep that no linear model follows. With
    // a disturbance state on the error channel only, the MPC limit-cycled here (seed 3: 3.39 µm
    // peak-to-peak, 2789 µm of actuator travel); with the gauge's own disturbance state it does not.
    let s = millcomp_closedloop::compare::commissioned(&scenario("groove_s7_30deg.toml"));
    let none = run(&s, ControllerKind::None);
    let mpc = run(&s, ControllerKind::Mpc);
    assert!(
        mpc.metrics.actuator_travel_um < 500.0,
        "travel {}",
        mpc.metrics.actuator_travel_um
    );
    assert!(
        removal(&none, &mpc) >= 0.8,
        "mpc {} vs none {}",
        mpc.metrics.pp_error_um,
        none.metrics.pp_error_um
    );
    // the ablations: the same MPC without preview, pid-tuned with the plan fed forward
    let nopreview = run(&s, ControllerKind::MpcNoPreview);
    assert!(
        nopreview
            .notes
            .iter()
            .any(|n| n.starts_with("mpc-nopreview")),
        "{:?}",
        nopreview.notes
    );
    assert_ne!(nopreview.metrics.pp_error_um, mpc.metrics.pp_error_um);
    let ff = run(&s, ControllerKind::PidFeedforward);
    assert!(
        ff.notes
            .iter()
            .any(|n| n.starts_with("pid-ff") && n.contains("ms ahead")),
        "{:?}",
        ff.notes
    );
    assert!(
        removal(&none, &ff) >= 0.65,
        "pid-ff {} vs none {}",
        ff.metrics.pp_error_um,
        none.metrics.pp_error_um
    );
}

/// The MPC on the 40° ramp at `seed`, with the force channel's σ `force_noise_n` (N) and the groove MPC's
/// shipped features changed by `set`.
fn forty_degree_ramp(
    seed: u64,
    force_noise_n: f64,
    set: impl Fn(&mut millcomp_mpc::groove::GrooveMpcFeatures),
) -> RunReport {
    let mut s = scenario("groove_s7_40deg.toml");
    s.seed = seed;
    s.truth.force_noise_n = force_noise_n;
    set(&mut s.control.groove_mpc);
    run(&s, ControllerKind::Mpc)
}

/// The ramp's rubbing start not known: the groove MPC's `unbiased_peak`, `flank_rubbing` and
/// `quiet_revolutions` off (the MPC before they were shipped, on the same force chain).
fn start_unknown(f: &mut millcomp_mpc::groove::GrooveMpcFeatures) {
    f.unbiased_peak = false;
    f.flank_rubbing = false;
    f.quiet_revolutions = false;
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn a_quieter_force_channel_does_not_leave_the_ramp_start_uncut_with_the_rubbing_start_known() {
    // the 40° ramp with a 4× quieter force channel (σ 0.01 N), seed 4. Without the three features the
    // MPC takes the noise's per-revolution maximum for a deflection, and without it the first 0.2 mm,
    // where the tool rides on its wear land, stay uncut (`bash bench/ramp-start-noise`). With the peak's
    // noise bias taken off and the rubbing start known (shipped), the preview pushes the tool in.
    let unknown = forty_degree_ramp(4, 0.01, start_unknown);
    let shipped = forty_degree_ramp(4, 0.01, |_| {});
    assert!(
        unknown.metrics.min_error_um < -0.6,
        "rubbing not known: min {}",
        unknown.metrics.min_error_um
    );
    assert!(
        shipped.metrics.min_error_um > -0.2 && shipped.metrics.pp_error_um < 0.5,
        "shipped: min {} pp {}",
        shipped.metrics.min_error_um,
        shipped.metrics.pp_error_um
    );
}

#[test]
fn the_forty_degree_ramps_peak_read_without_a_pre_filter_overshoot_leaves_no_saw_tooth() {
    // the 40° ramp, seed 3, a noise-free force channel: the tooth pass's z-force ends abruptly at its
    // peak, and the Butterworth pre-filter the controllers read through before overshot off that edge,
    // which made the MPC's error a saw-tooth (resets at ≈ 20 and ≈ 60 µm of depth; pp 0.33 µm against an
    // optimum of 0.02 µm; `ForcePeakChain::butterworth` shows the jump). Through the critically damped
    // pre-filter, with the rubbing start known: 0.13 µm.
    let shipped = forty_degree_ramp(3, 0.0, |_| {});
    assert!(
        shipped.metrics.pp_error_um < 0.18,
        "shipped {}",
        shipped.metrics.pp_error_um
    );
}

#[test]
#[ignore = "slow suite (a long study): cargo test --workspace --test main -- --ignored"]
fn reading_the_force_once_a_revolution_away_from_the_changes_lets_less_noise_through() {
    // the 40° ramp at the shipped force noise (σ 0.04 N), seed 8: the error channel's reading is a
    // one-revolution sliding peak, and taking it as a new measurement every cycle lets the noise through
    // at the disturbance estimate's full speed (pp 0.29 µm); read once a revolution where the preview
    // sees no change (shipped), 0.15 µm.
    let every_cycle = forty_degree_ramp(8, 0.04, |f| f.quiet_revolutions = false);
    let once = forty_degree_ramp(8, 0.04, |_| {});
    assert!(
        every_cycle.metrics.pp_error_um > 0.25 && once.metrics.pp_error_um < 0.2,
        "every cycle {} once a revolution {}",
        every_cycle.metrics.pp_error_um,
        once.metrics.pp_error_um
    );
}

#[test]
fn pid_ff_given_the_mpcs_read_features_cuts_the_ramp_start() {
    // the fairness ablation: `pid-ff` reading what the MPC reads (the peak's noise bias off, the rubbing
    // start known). On the 30° ramp plain `pid-ff` leaves the first ≈ 0.2 mm uncut on every one of the
    // seeds 1–10 of `bash bench/ramp-start-noise` (docs/studies/ramp-start.md) (error −cmd, about 0.8 µm of its 1.2 µm above the
    // optimum); with the features it cuts there, as the MPC does. Seed 1, the bench's first (seed 1:
    // 1.16 → 0.40 µm; on the scenario's own seed 30 plain `pid-ff` cuts the start, 0.24 against 0.30).
    let mut s = scenario("groove_s7_30deg.toml");
    s.seed = 1;
    let above = |r: &RunReport| {
        r.metrics.pp_error_um - r.metrics.optimum_pp_um.expect("a ramp has an optimum")
    };
    let plain = run(&s, ControllerKind::PidFeedforward);
    let read = run(&s, ControllerKind::PidFeedforwardRead);
    assert!(
        read.notes.iter().any(|n| n.starts_with("pid-ff-read")),
        "{:?}",
        read.notes
    );
    assert!(
        above(&read) < above(&plain) - 0.4,
        "pid-ff-read {} vs pid-ff {} µm above the optimum",
        above(&read),
        above(&plain)
    );
}
