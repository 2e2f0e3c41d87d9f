//! The MPC core against independent references: Riccati LQ, constraints, slack, fallbacks.

use crate::common::*;
use approx::assert_relative_eq;
use millcomp_mpc::config::{DisturbanceKind, SoftOutput};
use millcomp_mpc::qp::QpStatus;
use millcomp_mpc::{MpcConfig, MpcController, PreviewWindow};
use millcomp_sim::{DiscreteLti, PztSpindle};
use nalgebra::{DMatrix, DVector};

/// PZT spindle of `000_…txt` §5.2.4 (ζ = 0.46, ωn = 1302 rad/s, 50 µm / 1000 V) with an extra real pole
/// at 37 000 rad/s (sim's provisional fit), volts → tool-tip µm, sampled at 0.5 ms.
fn spindle() -> DiscreteLti {
    PztSpindle::new(0.05, 0.46, 1302.0, Some(37_000.0), None)
        .unwrap()
        .to_lti()
        .unwrap()
        .discretize_zoh(5e-4)
        .unwrap()
}

/// Apply `u` for one sample and return the output *after* it (the next cycle's measurement).
fn advance(m: &DiscreteLti, x: &mut DVector<f64>, u: f64) -> f64 {
    m.step_siso(x, u);
    (&m.c * &*x)[0]
}

fn cfg(horizon: usize) -> MpcConfig {
    let mut c = MpcConfig::siso(horizon, 0.0, 1000.0, 100.0);
    c.weights.output = vec![1.0];
    c.weights.input_rate = vec![1e-5];
    c
}

/// Finite-horizon LQ by backward Riccati recursion on ξ = [x; u_{k−1}] with input Δu:
/// minimises Σ_{k=1..N} y_kᵀQy_k + Σ_{k=0..N−1} Δu_kᵀRΔu_k. Returns the first move u₀ = u₋₁ + Δu₀.
fn riccati_first_move(
    m: &DiscreteLti,
    n: usize,
    q: f64,
    r: f64,
    x0: &DVector<f64>,
    u_prev: f64,
) -> f64 {
    let nx = m.n_states();
    let mut at = DMatrix::zeros(nx + 1, nx + 1);
    at.view_mut((0, 0), (nx, nx)).copy_from(&m.a);
    at.view_mut((0, nx), (nx, 1)).copy_from(&m.b);
    at[(nx, nx)] = 1.0;
    let mut bt = DMatrix::zeros(nx + 1, 1);
    bt.view_mut((0, 0), (nx, 1)).copy_from(&m.b);
    bt[(nx, 0)] = 1.0;
    let mut ct = DMatrix::zeros(1, nx + 1);
    ct.view_mut((0, 0), (1, nx)).copy_from(&m.c);
    let qt = ct.transpose() * &ct * q;
    let rm = DMatrix::from_element(1, 1, r);
    let mut p = qt.clone();
    let mut k0 = DMatrix::zeros(1, nx + 1);
    for _ in (0..n).rev() {
        let s = &rm + bt.transpose() * &p * &bt;
        let k = s.try_inverse().unwrap() * bt.transpose() * &p * &at;
        p = &qt + at.transpose() * &p * &at - at.transpose() * &p * &bt * &k;
        k0 = k;
    }
    let mut xi = DVector::zeros(nx + 1);
    xi.rows_mut(0, nx).copy_from(x0);
    xi[nx] = u_prev;
    u_prev - (k0 * xi)[0]
}

#[test]
fn unconstrained_first_move_equals_riccati_lq() {
    let m = spindle();
    for &n in &[5usize, 20, 40] {
        let mut c = cfg(n);
        c.disturbance.kind = DisturbanceKind::None;
        // limits far away: the constrained QP has the unconstrained solution
        c.limits.u_min = vec![-1e7];
        c.limits.u_max = vec![1e7];
        c.limits.du_max = vec![1e7];
        c.solver.tol_gap = 1e-10;
        c.solver.tol_feas = 1e-10;
        let mut mpc = MpcController::new(&m, &c).unwrap();
        // a physical state: the equilibrium at 300 V, moving (half of it in each derivative state)
        let mut x0 = m.steady_state(&DVector::from_element(1, 300.0)).unwrap();
        x0[0] = 0.5 * x0[2] * 1302.0 * 1302.0;
        x0[1] = -0.5 * x0[2] * 1302.0;
        mpc.set_state_estimate(&x0).unwrap();
        mpc.set_previous_input(&[150.0]);
        // the exact measurement leaves the estimate unchanged (zero innovation)
        let y0 = (&m.c * &x0)[0];
        let step = mpc.step(&[y0], &PreviewWindow::zeros(n, 1)).unwrap();
        assert_eq!(step.status, QpStatus::Solved);
        let u_lq = riccati_first_move(&m, n, 1.0, 1e-5, &x0, 150.0);
        let scale = (u_lq - 150.0).abs().max(1.0);
        assert!(
            (step.u[0] - u_lq).abs() <= LQ_FIRST_MOVE_REL * scale,
            "N={n}: mpc {} vs riccati {u_lq}",
            step.u[0]
        );
    }
}

#[test]
fn hard_input_limits_and_slew_hold_every_cycle() {
    let m = spindle();
    let mut c = cfg(20);
    c.limits.du_max = vec![25.0];
    let mut mpc = MpcController::new(&m, &c).unwrap();
    let mut win = PreviewWindow::zeros(20, 1);
    // 80 µm is beyond the 50 µm stroke: the input must saturate at 1000 V, never beyond
    win.reference.iter_mut().for_each(|r| *r = 80.0);
    let (mut x, mut y, mut u_prev) = (m.zero_state(), 0.0, 0.0);
    let mut saturated = 0;
    for _ in 0..400 {
        let s = mpc.step(&[y], &win).unwrap();
        let u = s.u[0];
        assert!(u.is_finite());
        assert!(
            (0.0 - LIMIT_ABS..=1000.0 + LIMIT_ABS).contains(&u),
            "u = {u}"
        );
        assert!(
            (u - u_prev).abs() <= 25.0 + LIMIT_ABS,
            "slew {}",
            u - u_prev
        );
        if (u - 1000.0).abs() < 1e-6 {
            saturated += 1;
        }
        u_prev = u;
        y = advance(&m, &mut x, u);
    }
    assert!(
        saturated > 300,
        "input should sit at its limit, saturated {saturated} cycles"
    );
    assert_eq!(mpc.stats().fallbacks, 0);
}

#[test]
fn unreachable_soft_bound_is_handled_by_the_slack() {
    let m = spindle();
    let mut c = cfg(20);
    c.limits.du_max = vec![5.0]; // slow: the bound cannot be met in the next steps
    c.soft_outputs = vec![SoftOutput {
        output: 0,
        stride: 1,
        from_step: 1,
        min: None,
        max: Some(10.0),
        about_reference: false,
    }];
    let mut mpc = MpcController::new(&m, &c).unwrap();
    // start at 1000 V equilibrium (50 µm), bound y ≤ 10 µm: infeasible as a hard constraint
    let x_eq = m.steady_state(&DVector::from_element(1, 1000.0)).unwrap();
    let mut xa = DVector::zeros(x_eq.len() + 1);
    xa.rows_mut(0, x_eq.len()).copy_from(&x_eq);
    mpc.set_state_estimate(&xa).unwrap();
    mpc.set_previous_input(&[1000.0]);
    let mut x = x_eq.clone();
    let mut y = (&m.c * &x)[0];
    let win = PreviewWindow::zeros(20, 1); // reference 0 would pull further down; bound is active above
    let mut ys = Vec::new();
    for _ in 0..600 {
        let s = mpc.step(&[y], &win).unwrap();
        assert!(s.status.is_ok(), "status {:?}", s.status);
        y = advance(&m, &mut x, s.u[0]);
        ys.push(y);
    }
    assert_eq!(mpc.stats().fallbacks, 0);
    // after the slew-limited descent the bound holds
    assert!(ys[500..].iter().all(|&v| v <= 10.0 + SOFT_BOUND_ABS));
}

/// A soft bound about the reference follows it; the same bound on the output itself holds the output
/// near the bound against the reference's pull (the exact penalty outweighs the tracking cost).
#[test]
fn a_soft_bound_about_the_reference_moves_with_it() {
    let m = spindle();
    let run = |about_reference: bool| {
        let mut c = cfg(20);
        c.soft_outputs = vec![SoftOutput {
            output: 0,
            stride: 1,
            from_step: 3,
            min: Some(-0.5),
            max: Some(0.5),
            about_reference,
        }];
        let mut mpc = MpcController::new(&m, &c).unwrap();
        let mut win = PreviewWindow::zeros(20, 1);
        win.reference.iter_mut().for_each(|r| *r = 20.0);
        let (mut x, mut y) = (m.zero_state(), 0.0);
        for _ in 0..400 {
            let s = mpc.step(&[y], &win).unwrap();
            assert!(s.status.is_ok(), "status {:?}", s.status);
            y = advance(&m, &mut x, s.u[0]);
        }
        y
    };
    // about the reference: the output reaches the 20 µm reference
    assert!((run(true) - 20.0).abs() < 0.05, "{}", run(true));
    // about 0: the output stays near the 0.5 µm bound, far from the reference
    assert!(run(false) < 2.0, "{}", run(false));
}

#[test]
#[allow(clippy::needless_range_loop)] // k is both the cycle count and the plan index
fn injected_solver_failure_uses_shifted_plan_then_hold() {
    let m = spindle();
    let c = cfg(10);
    let mut mpc = MpcController::new(&m, &c).unwrap();
    let mut win = PreviewWindow::zeros(10, 1);
    win.reference.iter_mut().for_each(|r| *r = 20.0);
    let (mut x, mut y) = (m.zero_state(), 0.0);
    for _ in 0..5 {
        let s = mpc.step(&[y], &win).unwrap();
        y = advance(&m, &mut x, s.u[0]);
    }
    let plan = mpc.plan().to_vec();
    mpc.inject_solver_failures(15);
    let mut prev = *plan.first().unwrap();
    for k in 1..=15 {
        let s = mpc.step(&[y], &win).unwrap();
        assert!(s.fallback);
        assert_eq!(s.status, QpStatus::MaxIterations);
        assert!(s.u[0].is_finite() && (0.0..=1000.0).contains(&s.u[0]));
        if k < 10 {
            // the previous plan, shifted (then clamped to the slew limit around the previous command)
            let expect = plan[k].clamp(prev - 100.0, prev + 100.0);
            assert_relative_eq!(s.u[0], expect, epsilon = 1e-12);
        } else {
            assert_relative_eq!(s.u[0], prev, epsilon = 1e-12); // hold
        }
        prev = s.u[0];
        y = advance(&m, &mut x, s.u[0]);
    }
    assert_eq!(mpc.stats().fallbacks, 15);
    // recovery: the next cycle solves again
    let s = mpc.step(&[y], &win).unwrap();
    assert_eq!(s.status, QpStatus::Solved);
    assert_eq!(mpc.stats().fallbacks, 15);
}

#[test]
fn offset_free_under_gain_mismatch_and_output_disturbance() {
    let model = spindle();
    // truth: 30 % more gain and a 3 µm output offset
    let truth = PztSpindle::new(0.065, 0.46, 1302.0, Some(37_000.0), None)
        .unwrap()
        .to_lti()
        .unwrap()
        .discretize_zoh(5e-4)
        .unwrap();
    // a robust tuning: moves cost more and the disturbance observer is slower than the plant
    let mut c = cfg(20);
    c.weights.input_rate = vec![1e-3];
    c.kalman.measurement_noise = vec![1e-3];
    c.kalman.disturbance_noise = 1e-4;
    let mut mpc = MpcController::new(&model, &c).unwrap();
    let mut win = PreviewWindow::zeros(20, 1);
    win.reference.iter_mut().for_each(|r| *r = 12.0);
    let (mut x, mut y) = (truth.zero_state(), 3.0);
    for _ in 0..3000 {
        let s = mpc.step(&[y], &win).unwrap();
        y = advance(&truth, &mut x, s.u[0]) + 3.0;
    }
    assert!((y - 12.0).abs() < OFFSET_FREE_ABS, "y = {y}");
    // the disturbance estimate carries the mismatch
    assert!(mpc.disturbance_estimate()[0].abs() > 1.0);
}

#[test]
fn move_blocking_gives_piecewise_constant_plan() {
    let m = spindle();
    let mut c = cfg(12);
    c.move_blocking = Some(vec![1, 2, 3, 6]);
    let mut mpc = MpcController::new(&m, &c).unwrap();
    assert_eq!(mpc.qp().n_variables(), 4);
    let mut win = PreviewWindow::zeros(12, 1);
    win.reference.iter_mut().for_each(|r| *r = 10.0);
    mpc.step(&[0.0], &win).unwrap();
    let p = mpc.plan();
    assert_eq!(p.len(), 12);
    assert_eq!(p[1], p[2]);
    assert_eq!(p[3], p[4]);
    assert_eq!(p[4], p[5]);
    assert!(p[6..].iter().all(|v| *v == p[6]));
    let mut c = cfg(12);
    c.control_horizon = Some(3);
    let mpc = MpcController::new(&m, &c).unwrap();
    assert_eq!(mpc.qp().n_variables(), 3);
}

#[test]
fn nan_measurements_never_reach_the_actuator() {
    let m = spindle();
    let mut mpc = MpcController::new(&m, &cfg(20)).unwrap();
    let mut win = PreviewWindow::zeros(20, 1);
    win.reference.iter_mut().for_each(|r| *r = 5.0);
    let (mut x, mut y) = (m.zero_state(), 0.0);
    for k in 0..200 {
        let meas = if k % 7 == 3 { f64::NAN } else { y };
        let s = mpc.step(&[meas], &win).unwrap();
        assert!(s.u[0].is_finite() && (0.0..=1000.0).contains(&s.u[0]));
        y = advance(&m, &mut x, s.u[0]);
    }
    assert!((y - 5.0).abs() < 0.05);
    // non-finite preview data: fallback, not NaN
    win.offsets[3] = f64::NAN;
    let s = mpc.step(&[y], &win).unwrap();
    assert_eq!(s.status, QpStatus::NonFiniteData);
    assert!(s.fallback && s.u[0].is_finite());
}

#[test]
fn preview_acts_before_a_known_step() {
    // a known output offset steps at k = 30; with preview the controller starts moving before it
    let m = spindle();
    let mut mpc = MpcController::new(&m, &cfg(20)).unwrap();
    let (mut x, mut y) = (m.zero_state(), 0.0);
    let w = |k: usize| if k >= 30 { -10.0 } else { 0.0 };
    let mut first_move = None;
    for k in 0..60 {
        let mut win = PreviewWindow::zeros(20, 1);
        win.offset_now[0] = w(k);
        for j in 0..20 {
            win.offsets[j] = w(k + 1 + j);
        }
        let s = mpc.step(&[y + w(k)], &win).unwrap();
        if first_move.is_none() && s.u[0] > 1.0 {
            first_move = Some(k);
        }
        y = advance(&m, &mut x, s.u[0]);
    }
    let k = first_move.expect("controller moved");
    assert!(k < 30, "moved at {k}, after the step");
}

/// Run 40 cycles towards a 20 µm reference with budget fraction `f`, enforced or only timed; returns the
/// commands and the final statistics.
fn run_with_budget(f: f64, enforced: bool) -> (Vec<f64>, millcomp_mpc::SolverStats) {
    let m = spindle();
    let mut c = cfg(10);
    c.solver.budget_fraction = f;
    c.solver.enforce_budget = enforced;
    let mut mpc = MpcController::new(&m, &c).unwrap();
    let mut win = PreviewWindow::zeros(10, 1);
    win.reference.iter_mut().for_each(|r| *r = 20.0);
    let (mut x, mut y, mut us) = (m.zero_state(), 0.0, Vec::new());
    for _ in 0..40 {
        let s = mpc.step(&[y], &win).unwrap();
        assert!(s.u[0].is_finite() && (0.0..=1000.0).contains(&s.u[0]));
        assert!(s.cycle_us >= s.solve_us && s.cycle_us > 0.0);
        us.push(s.u[0]);
        y = advance(&m, &mut x, s.u[0]);
    }
    (us, mpc.stats())
}

#[test]
fn an_impossible_budget_is_missed_every_cycle_and_falls_back_when_enforced() {
    // 1e-6 of the 0.5 ms period is 0.5 ns: no cycle can make it
    let (us, st) = run_with_budget(1e-6, true);
    assert_eq!((st.solves, st.deadline_misses, st.fallbacks), (40, 40, 40));
    assert!(st.budget_enforced && (st.budget_us - 5e-4).abs() < 1e-9);
    // the fallback from rest is the hold: the command never leaves 0 V
    assert!(us.iter().all(|&u| u == 0.0), "{us:?}");
    assert!(st.max_us >= st.p99_us && st.p99_us >= st.median_us);
}

#[test]
fn a_budget_only_timed_counts_misses_without_changing_the_commands() {
    // not enforced: the same commands as with the default budget, the misses still counted
    let (tight, st) = run_with_budget(1e-6, false);
    let (normal, _) = run_with_budget(1.0, false);
    assert_eq!(tight, normal);
    assert_eq!((st.deadline_misses, st.fallbacks), (40, 0));
    assert!(!st.budget_enforced);
    assert!(normal[0] > 0.0); // the MPC did act
}

#[test]
fn budget_fraction_outside_0_1_names_the_key() {
    let mut c = cfg(10);
    for bad in [0.0, 1.5, f64::NAN] {
        c.solver.budget_fraction = bad;
        match MpcController::new(&spindle(), &c) {
            Err(millcomp_mpc::MpcError::InvalidConfig { key, .. }) => {
                assert_eq!(key, "solver.budget_fraction")
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}

#[test]
fn cached_phased_plan_equals_the_plan_computed_afresh() {
    use millcomp_models::{ForceModelParams, StiffnessModel};
    use millcomp_mpc::groove::{DeflectionPlan, PulseCache};
    use millcomp_mpc::identified::{IdentifiedForceModel, IdentifiedStiffness, NominalTool};
    use millcomp_mpc::predictor::ForcePredictor;
    use millcomp_sim::groove::{DepthProfile, GrooveProgram};
    // the documented step made at once (40 → 60 µm at x = 5 mm), as the MPC's windows slide over it
    let mut program = GrooveProgram::thesis(20.0);
    program.depth_profile = DepthProfile::Steps {
        steps: vec![(0.0, 40.0), (5.0, 60.0)],
    };
    let tool = NominalTool::thesis_ball_end("S7");
    let p = ForceModelParams {
        fitted: Default::default(),
        fixed: Default::default(),
        covariance: Default::default(),
    };
    let predictor = ForcePredictor::Mechanistic(IdentifiedForceModel::new(&p, &tool).unwrap());
    let k = IdentifiedStiffness::new(&StiffnessModel {
        axial_n_per_um: 1.22,
        radial_n_per_um: 0.114,
        covariance: Default::default(),
    })
    .unwrap();
    let plan = DeflectionPlan::new(&program, &predictor, &k, tool.radius_um, 0.01).unwrap();
    let (rev, tooth) = (6e-3, 3e-3);
    let mut cache = PulseCache::default();
    for c in 0..400 {
        // 2 kHz cycles around the step; the angle estimate moves once, halfway
        let t0 = 2.95 + c as f64 * 5e-4;
        let pass = if c < 200 { 3.0004 } else { 3.0007 };
        let times: Vec<f64> = (0..=20).map(|j| t0 + j as f64 * 5e-4).collect();
        let fresh = plan.deflections_phased(&times, rev, tooth, pass);
        let cached = plan.deflections_phased_cached(&mut cache, &times, rev, tooth, pass);
        assert_eq!(fresh, cached, "cycle {c}");
        // the sliding-window maximum over the window of times against each time's window alone
        let alone: Vec<f64> = times
            .iter()
            .map(|&t| plan.deflections_phased(&[t], rev, tooth, pass)[0])
            .collect();
        assert_eq!(fresh, alone, "cycle {c}");
    }
    // the documented values: the old deflection until the step's pulse, the new one a revolution later
    let at = |t: f64| plan.deflections_phased(&[t], rev, tooth, 3.0004)[0];
    let (old, new) = (plan.deflection_at(4.9), plan.deflection_at(5.1));
    assert!((at(2.9995) - old).abs() < 1e-9);
    assert!((at(3.0004) - new).abs() < 1e-6 * new);
}

/// The spindle of [`spindle`] sampled at the 50 µs stage step (ten per 0.5 ms cycle).
fn spindle_fine() -> DiscreteLti {
    PztSpindle::new(0.05, 0.46, 1302.0, Some(37_000.0), None)
        .unwrap()
        .to_lti()
        .unwrap()
        .discretize_zoh(5e-5)
        .unwrap()
}

fn with_intersample(mut c: MpcConfig, substeps: usize, cycles: usize) -> MpcConfig {
    c.intersample = Some(millcomp_mpc::config::Intersample { substeps, cycles });
    c
}

#[test]
fn intersample_rows_predict_what_the_fine_model_does_between_the_cycles() {
    // the QP's stacked prediction F ξ + G u against a direct simulation of the sub-step model with
    // each cycle's input held over its ten sub-steps
    let fine = spindle_fine();
    let c = with_intersample(cfg(6), 10, 3);
    let mpc = MpcController::new(&fine, &c).unwrap();
    let aug = mpc.model();
    let fine_aug = aug.same_coordinates(&fine, &c).unwrap();
    let (f, g) = millcomp_mpc::qp::intersample_matrices(aug, &fine_aug, 6, 10, 3);
    assert_eq!(f.nrows(), 3 * 9);
    // a state from a few volts of history, and a plan of six different inputs
    let mut x = fine.zero_state();
    for k in 0..37 {
        fine.step_siso(&mut x, 100.0 + 7.0 * k as f64);
    }
    let u = [300.0, 120.0, 640.0, 500.0, 20.0, 800.0];
    let xi = aug.to_internal(&DVector::from_iterator(
        aug.n(),
        x.iter()
            .copied()
            .chain(std::iter::repeat(0.0))
            .take(aug.n()),
    ));
    let pred = &f * &xi + &g * DVector::from_column_slice(&u);
    let mut xs = x.clone();
    for (k, &uk) in u.iter().enumerate().take(3) {
        for s in 1..=10 {
            fine.step_siso(&mut xs, uk);
            if s < 10 {
                let y = (&fine.c * &xs)[0];
                let r = k * 9 + s - 1;
                assert_relative_eq!(pred[r], y, max_relative = 1e-9, epsilon = 1e-9);
            }
        }
    }
}

#[test]
fn intersample_costs_meet_an_offset_that_jumps_between_the_cycles() {
    // a known offset that jumps by 2 µm 0.3 ms into a cycle: weighed at the cycles only, the MPC
    // cannot see where between them it jumps; weighed at every sub-step it tracks it there. Score:
    // the sum of squared errors at every sub-step of a run (what the intersample cost minimises)
    let fine = spindle_fine();
    let run = |c: &MpcConfig| -> f64 {
        let (m, substeps) = (c.intersample.map_or(1, |i| i.substeps), 10usize);
        let model = if m > 1 {
            fine.clone()
        } else {
            fine.held_over(substeps).unwrap()
        };
        let mut mpc = MpcController::new(&model, c).unwrap();
        let n = c.horizon;
        let mut win = PreviewWindow::zeros_for(c, 1);
        let jump_at = 40 * substeps + 3; // sub-step index of the jump
        let offset = |i: usize| if i >= jump_at { -2.0 } else { 0.0 };
        let mut x = fine.zero_state();
        let mut sse = 0.0;
        for k in 0..80 {
            let i0 = k * substeps;
            win.offset_now[0] = offset(i0);
            for j in 0..n {
                win.offsets[j] = offset(i0 + (j + 1) * substeps);
            }
            if let Some(is) = c.intersample {
                for kk in 0..is.cycles {
                    for s in 1..is.substeps {
                        win.intersample_offsets[kk * (is.substeps - 1) + s - 1] =
                            offset(i0 + kk * substeps + s);
                    }
                }
            }
            let y = (&fine.c * &x)[0] + offset(i0);
            let u = mpc.step(&[y], &win).unwrap().u[0];
            for s in 1..=substeps {
                fine.step_siso(&mut x, u);
                let e = (&fine.c * &x)[0] + offset(i0 + s);
                sse += e * e;
            }
        }
        sse
    };
    let mut base = cfg(20);
    base.weights.input_rate = vec![1e-7];
    base.limits.u_max = vec![2000.0];
    base.limits.du_max = vec![2000.0];
    let at_cycles = run(&base);
    let between = run(&with_intersample(base.clone(), 10, 4));
    assert!(
        between < 0.8 * at_cycles,
        "between the cycles {between:.4} µm², at the cycles only {at_cycles:.4} µm²"
    );
}

#[test]
fn intersample_keys_are_checked_and_the_window_must_carry_them() {
    let fine = spindle_fine();
    for (substeps, cycles, key) in [
        (1, 2, "intersample.substeps"),
        (101, 2, "intersample.substeps"),
        (10, 0, "intersample.cycles"),
        (10, 21, "intersample.cycles"),
    ] {
        match MpcController::new(&fine, &with_intersample(cfg(20), substeps, cycles)) {
            Err(millcomp_mpc::MpcError::InvalidConfig { key: k, .. }) => assert_eq!(k, key),
            other => panic!("{substeps}/{cycles}: {other:?}"),
        }
    }
    let c = with_intersample(cfg(20), 10, 2);
    let mut mpc = MpcController::new(&fine, &c).unwrap();
    // a cycle-only window is refused, not silently read as zero offsets
    assert!(matches!(
        mpc.step(&[0.0], &PreviewWindow::zeros(20, 1)),
        Err(millcomp_mpc::MpcError::DimensionMismatch { .. })
    ));
    let s = mpc.step(&[0.0], &PreviewWindow::zeros_for(&c, 1)).unwrap();
    assert!(!s.fallback);
    // the budget is the cycle's (0.5 ms), not the sub-step's
    assert!(
        (mpc.budget_us() - 250.0).abs() < 1e-6,
        "{}",
        mpc.budget_us()
    );
}

/// The spindle's angle at a cut's first revolution (`groove::SpindlePhase`): the entry at depth of
/// the groove scenarios raises the force peak by about 0.36 N per revolution (0.32–0.36 N in the first,
/// `millcomp simulate … --out` at full rate, seeds 3 and 10) on a channel with σ = 0.04 N (the
/// scenarios' `force_noise_n`). Two flutes, the second cutting 0.6× (runout), 50 µs samples at 10 000
/// rpm. With the force waveform the pass is known when the first revolution with a cut closes, within
/// 0.1 ms (a thirtieth of the tooth period) in nearly every trial and closer than that revolution's
/// largest sample puts it; ten revolutions of noise alone before it never make it known.
#[test]
fn the_spindle_angle_is_matched_from_a_cuts_first_revolution() {
    use millcomp_mpc::groove::SpindlePhase;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let (rev, dt, sigma): (f64, f64, f64) = (6e-3, 5e-5, 0.04);
    let samples = (rev / dt).round() as usize;
    // one revolution's force from the larger flute's pass: two Gaussian pulses a tooth apart
    let shape = |phi: f64| {
        let pulse = |c: f64| {
            let d = (phi - c).rem_euclid(rev);
            let d = d.min(rev - d);
            (-(d / 4e-4).powi(2)).exp()
        };
        pulse(0.0) + 0.6 * pulse(rev / 2.0)
    };
    let waveform: Vec<f64> = (0..120).map(|k| shape(k as f64 * rev / 120.0)).collect();
    let noise = Normal::new(0.0, sigma).unwrap();
    let circular = |a: f64, b: f64| {
        let d = (a - b).rem_euclid(rev);
        d.min(rev - d)
    };
    let (mut within, mut sq_matched, mut sq_largest) = (0usize, 0.0, 0.0);
    let trials = 200;
    for trial in 0..trials {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(trial);
        let true_pass = rev * (trial as f64 * 0.618_034).fract();
        let mut phase = SpindlePhase::new(10_000.0, &waveform, sigma);
        let (air, cut) = (10, 2);
        let mut largest = (f64::NEG_INFINITY, 0.0);
        for k in 0..(air + cut) * samples {
            let t = k as f64 * dt;
            let r = k / samples;
            if r < air + 1 {
                assert_eq!(phase.pass_s(), None, "trial {trial}: known in air at {t}");
            }
            let amplitude = if r < air {
                0.0
            } else {
                0.36 * (r - air + 1) as f64
            };
            let f = amplitude * shape(t - true_pass) + noise.sample(&mut rng);
            if r == air && f > largest.0 {
                largest = (f, t);
            }
            phase.update(t, f);
            if k == (air + 1) * samples {
                let pass = phase
                    .pass_s()
                    .expect("known at the first cut revolution's close");
                let e = circular(pass, true_pass);
                within += usize::from(e < 1e-4);
                sq_matched += e * e;
                sq_largest += circular(largest.1, true_pass).powi(2);
            }
        }
    }
    let (rms_matched, rms_largest) = (
        (sq_matched / trials as f64).sqrt(),
        (sq_largest / trials as f64).sqrt(),
    );
    assert!(within >= 190, "within 0.1 ms in {within} of {trials}");
    assert!(
        rms_matched < 0.5 * rms_largest,
        "rms error: matched {rms_matched:e} s, largest sample {rms_largest:e} s"
    );
}
