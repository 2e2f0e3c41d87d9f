//! The plant-agnostic MPC controller: Kalman filter on the disturbance-augmented state, condensed QP
//! solved by Clarabel every cycle, status check, fallback, and a last-line clamp.
//!
//! Cycle k ([`MpcController::step`]):
//! 1. measurement update of the augmented state with `y_k` and the known offset `w_k`
//!    (non-finite measurements are skipped);
//! 2. `update_q`/`update_b` from the estimate, the previous command and the preview window;
//! 3. Clarabel solve — with `solver.enforce_budget`, stopped at the cycle's deadline
//!    (`solver.budget_fraction` of the period after the cycle started, less a guard of one iteration);
//!    accepted only if the status is `Solved`/`AlmostSolved`, the solution is finite and (enforced) the
//!    cycle is still within its budget; a cycle over its budget is counted as a deadline miss either way;
//! 4. otherwise **fallback**: the last accepted plan shifted by the number of cycles since it was computed,
//!    and once it runs out, hold the previous command (counted in [`SolverStats::fallbacks`]; a plan not
//!    ready within the budget also in [`SolverStats::deadline_misses`]);
//! 5. last line of defence: a non-finite command holds the previous one; clamp to `[u_min, u_max]` and to
//!    the slew limit around the previous command;
//! 6. time update of the filter with the command actually emitted.

use std::time::{Duration, Instant};

use nalgebra::DVector;
use serde::{Deserialize, Serialize};

use crate::config::MpcConfig;
use crate::error::MpcError;
use crate::kalman::{AugmentedModel, KalmanFilter};
use crate::qp::{CondensedQp, QpStatus};
use crate::stats::SolverStats;
use millcomp_sim::DiscreteLti;

/// Time kept after the solver for the rest of a cycle (plan expansion, clamp, filter time update), s.
const TAIL_GUARD_S: f64 = 5e-6;
/// Per-cycle decay of the remembered longest time per solver iteration.
const ITERATION_MEMORY: f64 = 0.98;

/// The known future over the horizon, supplied every cycle by the caller (the planned process).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PreviewWindow {
    /// Known additive output offset of the current cycle, `w_k` (n_outputs).
    pub offset_now: Vec<f64>,
    /// Known additive output offsets `w_{k+1} … w_{k+N}` (N·n_outputs, step-major).
    pub offsets: Vec<f64>,
    /// References `r_{k+1} … r_{k+N}` (N·n_outputs, step-major).
    pub reference: Vec<f64>,
    /// Known offsets between the cycles, when the controller weighs them
    /// ([`crate::config::Intersample`]): for cycle `k = 1..=cycles` and sub-step `s = 1..substeps−1`
    /// the offset `s` sub-steps after cycle `k − 1` (cycle-major, then sub-step, then output); empty
    /// otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub intersample_offsets: Vec<f64>,
    /// References between the cycles, as [`Self::intersample_offsets`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub intersample_reference: Vec<f64>,
}

impl PreviewWindow {
    /// All-zero window (regulation to zero, no known offsets).
    pub fn zeros(horizon: usize, n_outputs: usize) -> Self {
        Self {
            offset_now: vec![0.0; n_outputs],
            offsets: vec![0.0; horizon * n_outputs],
            reference: vec![0.0; horizon * n_outputs],
            intersample_offsets: Vec::new(),
            intersample_reference: Vec::new(),
        }
    }

    /// All-zero window for a controller configured by `cfg` (with its intersample rows).
    pub fn zeros_for(cfg: &MpcConfig, n_outputs: usize) -> Self {
        let rows = cfg.intersample_rows() * n_outputs;
        Self {
            intersample_offsets: vec![0.0; rows],
            intersample_reference: vec![0.0; rows],
            ..Self::zeros(cfg.horizon, n_outputs)
        }
    }
}

/// What one control cycle did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MpcStep {
    /// The command emitted (finite, within limits and slew).
    pub u: Vec<f64>,
    /// QP status of this cycle.
    pub status: QpStatus,
    /// True if the fallback was used.
    pub fallback: bool,
    /// Time for update + solve, µs (0 if the solver was not called).
    pub solve_us: f64,
    /// Wall time of the whole cycle, from its start (the measurement) to the emitted command, µs.
    pub cycle_us: f64,
    /// The fresh plan was not ready within the cycle's budget (with the budget enforced, the fallback
    /// was emitted instead).
    pub deadline_miss: bool,
    /// Interior-point iterations.
    pub iterations: u32,
}

/// What one control cycle did, without its command: what [`MpcController::step_into`] returns (no
/// allocation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MpcCycle {
    /// QP status of this cycle.
    pub status: QpStatus,
    /// True if the fallback was used.
    pub fallback: bool,
    /// Time for update + solve, µs (0 if the solver was not called).
    pub solve_us: f64,
    /// Wall time of the whole cycle, from its start (the measurement) to the emitted command, µs.
    pub cycle_us: f64,
    /// The fresh plan was not ready within the cycle's budget.
    pub deadline_miss: bool,
    /// Interior-point iterations.
    pub iterations: u32,
}

/// The QP statuses a controller counts (room reserved for all of them: counting a new one does not
/// allocate).
const N_STATUSES: usize = 9;

/// Linear offset-free MPC with preview, solved by Clarabel.
#[derive(Debug)]
pub struct MpcController {
    cfg: MpcConfig,
    model: AugmentedModel,
    kf: KalmanFilter,
    qp: CondensedQp,
    nu: usize,
    u_prev: Vec<f64>,
    plan: Vec<f64>,
    plan_buf: Vec<f64>,
    plan_age: usize,
    times_us: Vec<f64>,
    fallbacks: usize,
    deadline_misses: usize,
    budget_s: f64,
    /// Decaying maximum of the time per interior-point iteration (s): the guard kept before the deadline.
    iteration_s: f64,
    status_counts: Vec<(QpStatus, usize)>,
    inject_failures: usize,
    injecting: bool,
    /// The horizon's and the intersample rows' offsets and references, stacked for the QP (used only
    /// with intersample outputs).
    offsets_buf: Vec<f64>,
    reference_buf: Vec<f64>,
}

impl MpcController {
    /// Build the controller (validates `cfg` against the model, computes the Kalman gain, builds the QP
    /// and the Clarabel solver once).
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] naming the key for a configuration the model cannot take (weights,
    /// limits, soft outputs, disturbance channels of the wrong size or sign),
    /// [`MpcError::DimensionMismatch`], [`MpcError::Numerical`] when the Kalman gain does not converge,
    /// [`MpcError::SolverSetup`] when Clarabel refuses the problem data.
    ///
    /// # Examples
    /// ```
    /// use millcomp_mpc::{MpcConfig, MpcController, PreviewWindow};
    /// use millcomp_sim::ContinuousLti;
    /// // first-order plant 1/(0.01 s + 1) at 1 kHz; drive the output to 0.5
    /// let plant = ContinuousLti::from_transfer_function(&[1.0], &[0.01, 1.0]).unwrap()
    ///     .discretize_zoh(1e-3).unwrap();
    /// let mut mpc = MpcController::new(&plant, &MpcConfig::siso(20, 0.0, 1.0, 0.2)).unwrap();
    /// let mut win = PreviewWindow::zeros(20, 1);
    /// win.reference.iter_mut().for_each(|r| *r = 0.5);
    /// let (mut x, mut y) = (plant.zero_state(), 0.0);
    /// for _ in 0..300 {
    ///     let step = mpc.step(&[y], &win).unwrap();
    ///     y = plant.step_siso(&mut x, step.u[0]);
    /// }
    /// assert!((y - 0.5).abs() < 1e-3);
    /// assert_eq!(mpc.stats().fallbacks, 0);
    /// ```
    ///
    /// With `cfg.intersample`, `model` is sampled at the sub-step: the controller runs every
    /// `intersample.substeps` of its samples, on the model held over them ([`DiscreteLti::held_over`]),
    /// and weighs the outputs in between.
    pub fn new(model: &DiscreteLti, cfg: &MpcConfig) -> Result<Self, MpcError> {
        let (nu, ny) = (model.n_inputs(), model.n_outputs());
        cfg.validate(nu, ny)?;
        let (aug, fine) = match cfg.intersample {
            None => (AugmentedModel::new(model, cfg)?, None),
            Some(i) => {
                let aug = AugmentedModel::new(&model.held_over(i.substeps)?, cfg)?;
                let fine = aug.same_coordinates(model, cfg)?;
                (aug, Some(fine))
            }
        };
        let r: Vec<f64> = if cfg.kalman.measurement_noise.is_empty() {
            vec![1e-2; ny]
        } else {
            cfg.kalman.measurement_noise.clone()
        };
        let mut kf = KalmanFilter::steady_state(
            &aug,
            cfg.kalman.input_noise,
            if cfg.kalman.disturbance_noise_per_state.is_empty() {
                std::slice::from_ref(&cfg.kalman.disturbance_noise)
            } else {
                &cfg.kalman.disturbance_noise_per_state
            },
            &r,
        )?;
        kf.set_gate(&cfg.kalman.innovation_gate, cfg.kalman.gate_max_skips);
        let qp = CondensedQp::new(&aug, cfg, fine.as_ref())?;
        let budget_s = cfg.solver.budget_fraction * aug.dt_s;
        let u0: Vec<f64> = (0..nu)
            .map(|i| 0.0f64.clamp(cfg.limits.u_min[i], cfg.limits.u_max[i]))
            .collect();
        Ok(Self {
            cfg: cfg.clone(),
            model: aug,
            kf,
            qp,
            nu,
            u_prev: u0.clone(),
            plan: u0.repeat(cfg.horizon),
            plan_buf: Vec::with_capacity(cfg.horizon * nu),
            plan_age: 0,
            times_us: Vec::new(),
            fallbacks: 0,
            deadline_misses: 0,
            budget_s,
            iteration_s: 0.0,
            status_counts: Vec::with_capacity(N_STATUSES),
            inject_failures: 0,
            injecting: false,
            offsets_buf: Vec::with_capacity(
                (cfg.horizon + cfg.intersample_rows())
                    * ny
                    * usize::from(cfg.intersample.is_some()),
            ),
            reference_buf: Vec::with_capacity(
                (cfg.horizon + cfg.intersample_rows())
                    * ny
                    * usize::from(cfg.intersample.is_some()),
            ),
        })
    }

    /// Room for the cycle times of `cycles` solves ([`Self::solve_times_us`]): a run that solves at
    /// most that many QPs does not allocate in its cycles. (A run beyond it still works; a cycle that
    /// outgrows the storage allocates it anew.)
    pub fn reserve_cycle_times(&mut self, cycles: usize) {
        self.times_us
            .reserve_exact(cycles.saturating_sub(self.times_us.len()));
    }

    /// Back to the state right after construction: the estimate at zero, the previous command and the
    /// plan at the limits' zero, the statistics, the fallback's age and a pending fault injection
    /// cleared. The problem data and the solver stay.
    ///
    /// # Errors
    /// [`MpcError::SolverSetup`] when Clarabel refuses the configured settings back (after a fault
    /// injection).
    pub fn reset(&mut self) -> Result<(), MpcError> {
        if self.injecting {
            self.qp.set_max_iter_override(None)?;
            self.injecting = false;
        }
        self.inject_failures = 0;
        self.kf.restart();
        for (i, u) in self.u_prev.iter_mut().enumerate() {
            *u = 0.0f64.clamp(self.cfg.limits.u_min[i], self.cfg.limits.u_max[i]);
        }
        for (k, p) in self.plan.iter_mut().enumerate() {
            *p = self.u_prev[k % self.nu];
        }
        self.plan_age = 0;
        self.times_us.clear();
        self.fallbacks = 0;
        self.deadline_misses = 0;
        self.iteration_s = 0.0;
        self.status_counts.clear();
        Ok(())
    }

    /// Set the previous command (e.g. the actuator's current value before the first cycle); clamped.
    pub fn set_previous_input(&mut self, u: &[f64]) {
        for (i, &ui) in u.iter().enumerate().take(self.nu) {
            if ui.is_finite() {
                self.u_prev[i] = ui.clamp(self.cfg.limits.u_min[i], self.cfg.limits.u_max[i]);
            }
        }
        self.plan = self.u_prev.repeat(self.cfg.horizon);
        self.plan_age = 0;
    }

    /// Set the augmented state estimate `[x; d]` in the model's original state coordinates (default zero).
    pub fn set_state_estimate(&mut self, xa: &DVector<f64>) -> Result<(), MpcError> {
        if xa.len() != self.model.n() {
            return Err(MpcError::DimensionMismatch {
                what: "augmented state estimate".into(),
                expected: self.model.n(),
                found: xa.len(),
            });
        }
        let xi = self.model.to_internal(xa);
        self.kf.reset(&xi);
        Ok(())
    }

    /// Make the next `cycles` solves fail genuinely (Clarabel's iteration cap set to 1 → `MaxIterations`).
    /// Fault injection (tests, injected-fault cases of a harness).
    pub fn inject_solver_failures(&mut self, cycles: usize) {
        self.inject_failures += cycles;
    }

    /// One control cycle. `y` are the measured outputs of this cycle (NaN entries → measurement skipped).
    /// A solver failure is an outcome ([`MpcStep::fallback`]), not an error.
    ///
    /// # Errors
    /// [`MpcError::DimensionMismatch`] when `y` or the window do not have the model's number of outputs
    /// (the window: `horizon × n_outputs` offsets and references).
    ///
    /// # Examples
    /// ```
    /// use millcomp_mpc::{MpcConfig, MpcController, MpcError, PreviewWindow};
    /// use millcomp_sim::ContinuousLti;
    /// // an integrator-like first-order plant at 1 kHz, input 0–1, at most 0.2 per cycle
    /// let plant = ContinuousLti::from_transfer_function(&[1.0], &[0.01, 1.0]).unwrap()
    ///     .discretize_zoh(1e-3).unwrap();
    /// let mut mpc = MpcController::new(&plant, &MpcConfig::siso(10, 0.0, 1.0, 0.2)).unwrap();
    /// let mut win = PreviewWindow::zeros(10, 1);
    /// win.reference.iter_mut().for_each(|r| *r = 0.5);
    /// let s = mpc.step(&[0.0], &win).unwrap();
    /// // from rest the first move is slew-limited: 0.2, the most the configuration allows
    /// assert!((s.u[0] - 0.2).abs() < 1e-9 && !s.fallback);
    /// assert!(matches!(mpc.step(&[0.0, 1.0], &win), Err(MpcError::DimensionMismatch { .. })));
    /// ```
    pub fn step(&mut self, y: &[f64], window: &PreviewWindow) -> Result<MpcStep, MpcError> {
        self.step_from(Instant::now(), y, window)
    }

    /// One control cycle that started at `cycle_start` (when the caller began it: reading the sensors,
    /// building the preview); the budget is counted from there. Otherwise as [`Self::step`].
    ///
    /// # Errors
    /// As [`Self::step`].
    pub fn step_from(
        &mut self,
        cycle_start: Instant,
        y: &[f64],
        window: &PreviewWindow,
    ) -> Result<MpcStep, MpcError> {
        let mut u = vec![0.0; self.nu];
        let c = self.step_into(cycle_start, y, window, &mut u)?;
        Ok(MpcStep {
            u,
            status: c.status,
            fallback: c.fallback,
            solve_us: c.solve_us,
            cycle_us: c.cycle_us,
            deadline_miss: c.deadline_miss,
            iterations: c.iterations,
        })
    }

    /// [`Self::step_from`] with the command written into `u` (n_inputs): with the cycle times' storage
    /// reserved ([`Self::reserve_cycle_times`]), nothing is allocated — what a real-time loop calls.
    ///
    /// # Errors
    /// As [`Self::step`]; [`MpcError::DimensionMismatch`] also when `u` is not n_inputs long.
    pub fn step_into(
        &mut self,
        cycle_start: Instant,
        y: &[f64],
        window: &PreviewWindow,
        u: &mut [f64],
    ) -> Result<MpcCycle, MpcError> {
        let ny = self.model.n_outputs();
        if u.len() != self.nu {
            return Err(MpcError::DimensionMismatch {
                what: "command (n_inputs)".into(),
                expected: self.nu,
                found: u.len(),
            });
        }
        if y.len() != ny || window.offset_now.len() != ny {
            return Err(MpcError::DimensionMismatch {
                what: "measurement / offset_now (n_outputs)".into(),
                expected: ny,
                found: if y.len() != ny {
                    y.len()
                } else {
                    window.offset_now.len()
                },
            });
        }
        let xa = self.kf.correct(y, &window.offset_now);
        // fault injection toggles the real solver setting
        let want_inject = self.inject_failures > 0;
        if want_inject != self.injecting {
            self.qp
                .set_max_iter_override(if want_inject { Some(1) } else { None })?;
            self.injecting = want_inject;
        }
        let budget = Duration::from_secs_f64(self.budget_s);
        // stop the solver while one more iteration and the rest of the cycle still fit in the budget
        let guard =
            Duration::from_secs_f64((self.iteration_s + TAIL_GUARD_S).min(0.25 * self.budget_s));
        let enforced = self.cfg.solver.enforce_budget;
        let deadline = if enforced {
            (cycle_start + budget).checked_sub(guard)
        } else {
            None
        };
        let t0 = Instant::now();
        let finite = if self.cfg.intersample.is_some() {
            let rows = self.cfg.intersample_rows() * ny;
            if window.intersample_offsets.len() != rows
                || window.intersample_reference.len() != rows
            {
                return Err(MpcError::DimensionMismatch {
                    what: "preview window between the cycles (intersample offsets/reference)"
                        .into(),
                    expected: rows,
                    found: window
                        .intersample_offsets
                        .len()
                        .min(window.intersample_reference.len()),
                });
            }
            for (buf, (cycles, between)) in [
                (
                    &mut self.offsets_buf,
                    (&window.offsets, &window.intersample_offsets),
                ),
                (
                    &mut self.reference_buf,
                    (&window.reference, &window.intersample_reference),
                ),
            ] {
                buf.clear();
                buf.extend_from_slice(cycles);
                buf.extend_from_slice(between);
            }
            self.qp
                .update(xa, &self.u_prev, &self.offsets_buf, &self.reference_buf)?
        } else {
            self.qp
                .update(xa, &self.u_prev, &window.offsets, &window.reference)?
        };
        let (status, solve_us, iterations) = if finite {
            let st = self.qp.solve_by(deadline);
            let us = t0.elapsed().as_secs_f64() * 1e6;
            let it = self.qp.iterations();
            if it > 0 {
                // a decaying maximum: one preempted solve does not shrink the budget for good
                let per = us * 1e-6 / f64::from(it);
                self.iteration_s = per.max(ITERATION_MEMORY * self.iteration_s);
            }
            (st, us, it)
        } else {
            (QpStatus::NonFiniteData, 0.0, 0)
        };
        if self.inject_failures > 0 {
            self.inject_failures -= 1;
        }
        self.count_status(status);
        // a plan that is not ready within the budget is not used: the fallback is what went out
        // (not enforced: the miss is counted, the plan used all the same)
        let late = cycle_start.elapsed() > budget;
        let mut deadline_miss = status == QpStatus::MaxTime || (status.is_ok() && late);
        let fallback = !status.is_ok() || (late && enforced);
        if !fallback {
            let mut buf = std::mem::take(&mut self.plan_buf);
            self.qp.expand(self.qp.solution(), &mut buf);
            std::mem::swap(&mut self.plan, &mut buf);
            self.plan_buf = buf;
            self.plan_age = 0;
            u.copy_from_slice(&self.plan[..self.nu]);
        } else {
            self.fallbacks += 1;
            self.plan_age += 1;
            let n = self.cfg.horizon;
            if self.plan_age < n {
                u.copy_from_slice(
                    &self.plan[self.plan_age * self.nu..(self.plan_age + 1) * self.nu],
                );
            } else {
                u.copy_from_slice(&self.u_prev);
            }
        }
        // last line of defence
        for (i, ui) in u.iter_mut().enumerate() {
            let mut v = *ui;
            if !v.is_finite() {
                v = self.u_prev[i];
            }
            let du = self.cfg.limits.du_max[i];
            v = v.clamp(self.u_prev[i] - du, self.u_prev[i] + du);
            v = v.clamp(self.cfg.limits.u_min[i], self.cfg.limits.u_max[i]);
            *ui = v;
        }
        self.kf.predict(u);
        self.u_prev.copy_from_slice(u);
        let cycle_us = cycle_start.elapsed().as_secs_f64() * 1e6;
        // a command that went out after the deadline (the cycle's tail overran) is a miss too
        deadline_miss |= cycle_us > self.budget_s * 1e6;
        if deadline_miss {
            self.deadline_misses += 1;
        }
        if finite {
            self.times_us.push(cycle_us);
        }
        Ok(MpcCycle {
            status,
            fallback,
            solve_us,
            cycle_us,
            deadline_miss,
            iterations,
        })
    }

    fn count_status(&mut self, st: QpStatus) {
        if let Some(e) = self.status_counts.iter_mut().find(|(s, _)| *s == st) {
            e.1 += 1;
        } else {
            self.status_counts.push((st, 1));
        }
    }

    /// Solver statistics so far.
    pub fn stats(&self) -> SolverStats {
        SolverStats::from_times(&self.times_us, self.fallbacks).with_budget(
            self.budget_s * 1e6,
            self.deadline_misses,
            self.cfg.solver.enforce_budget,
        )
    }

    /// The cycle's time budget (µs): `solver.budget_fraction` × the control period.
    pub fn budget_us(&self) -> f64 {
        self.budget_s * 1e6
    }

    /// Raw per-cycle times (µs) of the cycles that called the solver, from the cycle's start to the
    /// emitted command.
    pub fn solve_times_us(&self) -> &[f64] {
        &self.times_us
    }

    /// Count of each QP status seen.
    pub fn status_counts(&self) -> &[(QpStatus, usize)] {
        &self.status_counts
    }

    /// Current filtered augmented state estimate `[x̂; d̂]` (original state coordinates).
    pub fn state_estimate(&self) -> DVector<f64> {
        self.model.to_original(self.kf.estimate())
    }

    /// Current disturbance estimate `d̂` (output or input units).
    pub fn disturbance_estimate(&self) -> Vec<f64> {
        let e = self.kf.estimate();
        e.rows(self.model.n_plant, self.model.n_dist)
            .iter()
            .copied()
            .collect()
    }

    /// Number of disturbance states.
    pub fn n_disturbances(&self) -> usize {
        self.model.n_dist
    }

    /// The previous command (what the next cycle's slew limit is around).
    pub fn previous_input(&self) -> &[f64] {
        &self.u_prev
    }

    /// The last accepted plan (N·n_inputs, step-major).
    pub fn plan(&self) -> &[f64] {
        &self.plan
    }

    /// The configuration.
    pub fn config(&self) -> &MpcConfig {
        &self.cfg
    }

    /// The QP (for export and benchmarks).
    pub fn qp(&self) -> &CondensedQp {
        &self.qp
    }

    /// The augmented model.
    pub fn model(&self) -> &AugmentedModel {
        &self.model
    }

    /// The Kalman filter.
    pub fn kalman(&self) -> &KalmanFilter {
        &self.kf
    }
}
