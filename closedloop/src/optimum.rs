//! What no controller could do better: the physical limits a groove run is measured against (issue 14).
//!
//! Both are computed by the harness from the truth of the run — the deflection it met, the true
//! actuator — so they are references for a report, never inputs to a controller.
//!
//! - [`certainty_equivalent_pp`], the *optimum* of a whole cut: the peak-to-peak error left by the best
//!   static plan ([`StrokeBand`]) within the actuator's true reach, for a controller that sees the
//!   deflection through the commissioned deflection model — the deflection per measured newton of the
//!   controllers (their compliance times the force channel's gain) against the truth's. With an exact
//!   model it is the stroke bound `max(0, δ_max − δ_min − Z)`; where the stroke covers the deflection it
//!   is the model's error times the deflection range. Static: the actuator settles in milliseconds, a
//!   ramp takes seconds. Noise-free: what the sensors add is the controllers' own.
//! - [`excess_lower_bound`], the smallest transient excess at a process change any controller could
//!   leave: a linear programme over the commands of every 50 µs stage step in a window around the
//!   change, through the true actuator's linear dynamics (its hysteresis and creep left out) within
//!   0 V … `voltage_max`, knowing the truth's deflection exactly — its tooth phase included — and
//!   starting from any state. The dynamics enter in input–output form (the actuator's difference
//!   equation), one equality per step instead of one per state and step. It minimises `max |e − c|`
//!   over the window for the best constant `c`; the issue's excess measures `|e − e_settled|` over a
//!   longer window for one particular `c`, so no controller's excess can be smaller. A deflection that
//!   jumps within one stage step (the per-revolution peak of a step made at once) leaves at least half
//!   the jump, since the tip cannot jump.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
    SupportedConeT, ZeroConeT,
};
use millcomp_mpc::stroke::StrokeBand;
use millcomp_sim::DiscreteLti;

/// The whole cut's optimum (µm): the peak-to-peak of `z − δ` where `z` is the [`StrokeBand`] plan of a
/// controller seeing `κ·δ` (`knowledge_factor` κ: the controllers' deflection per measured newton over
/// the truth's) within the true reach `reach_um`, and `δ` the deflection the run met. 0 for an empty
/// cut.
///
/// # Examples
/// ```
/// use millcomp_closedloop::optimum::certainty_equivalent_pp;
/// let ramp: Vec<f64> = (0..=200).map(|i| 0.1 * i as f64).collect(); // 0–20 µm
/// // an exact model: the stroke bound alone
/// assert!((certainty_equivalent_pp(&ramp, 18.5, 1.0) - 1.5).abs() < 1e-12);
/// assert_eq!(certainty_equivalent_pp(&ramp, 50.0, 1.0), 0.0);
/// // a model 1 % too compliant: 1 % of the 20 µm range is left where the stroke covers
/// assert!((certainty_equivalent_pp(&ramp, 50.0, 1.01) - 0.2).abs() < 1e-9);
/// ```
pub fn certainty_equivalent_pp(deflection_um: &[f64], reach_um: f64, knowledge_factor: f64) -> f64 {
    let seen: Vec<f64> = deflection_um.iter().map(|d| knowledge_factor * d).collect();
    let band = StrokeBand::new(&seen, reach_um);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (&d, &s) in deflection_um.iter().zip(&seen) {
        if !d.is_finite() {
            continue;
        }
        let e = band.correction_um(s) - d;
        lo = lo.min(e);
        hi = hi.max(e);
    }
    if hi >= lo { hi - lo } else { 0.0 }
}

/// The smallest `max |e_k − c|` (µm) over a window of stage steps, `e_k = sin α · tip_k − δ_k`, any
/// controller could reach: commands `0 ≤ v_k ≤ voltage_max_v` at every step through `actuator` (the
/// true actuator's linear model sampled at the stage step, volts → tip µm), any initial state, the
/// deflection `deflection_um` (one value per step, as the stage applies it) known in advance. `None` when
/// the window is empty or the programme does not solve (reported, not an error).
///
/// # Examples
/// ```
/// use millcomp_closedloop::optimum::excess_lower_bound;
/// use millcomp_sim::ContinuousLti;
/// // a first-order actuator, 1 µm/V, 1 ms, sampled at 50 µs, tip along z (sin α = 1)
/// let a = ContinuousLti::from_transfer_function(&[1.0], &[1e-3, 1.0]).unwrap()
///     .discretize_zoh(5e-5).unwrap();
/// // a ramp it can follow leaves nothing; a jump of 2 µm within one step leaves half of it
/// let ramp: Vec<f64> = (0..200).map(|k| 1.0 + 0.001 * k as f64).collect();
/// assert!(excess_lower_bound(&ramp, &a, 10.0, 1.0).unwrap() < 1e-6);
/// let jump: Vec<f64> = (0..200).map(|k| if k < 100 { 1.0 } else { 3.0 }).collect();
/// let b = excess_lower_bound(&jump, &a, 3.0, 1.0).unwrap();
/// // in the one step the jump takes the tip rises by at most (1 − e^(−0.05))·(3 − tip), the most from
/// // rest at 0 V: the errors then spread over 2 − 0.0488·3 = 1.854 µm, half of it is left
/// assert!((b - 0.927).abs() < 1e-3, "{b}");
/// // a 12 µm jump against 3 µm of reach: about half the jump
/// let big: Vec<f64> = (0..200).map(|k| if k < 100 { 1.0 } else { 13.0 }).collect();
/// assert!(excess_lower_bound(&big, &a, 3.0, 1.0).unwrap() > 5.9);
/// ```
pub fn excess_lower_bound(
    deflection_um: &[f64],
    actuator: &DiscreteLti,
    voltage_max_v: f64,
    sin_a: f64,
) -> Option<f64> {
    input_output_bound(deflection_um, actuator, voltage_max_v, sin_a, None)
}

/// [`excess_lower_bound`] solved to the relative tolerance `tol` (`None`: Clarabel's default, 1e-8, as
/// the state-space form was solved before issue 48). The input–output form's accuracy has a floor: on
/// the tests' jump beyond the stack's reach it stops 1.5e-7 (relative) from the optimum at 1e-10 and
/// 1e-9 alike, 4e-7 at 1e-8, where the state-space form stops at 2e-9; on the 128-run batch's windows
/// the default moves the bound ≤ 8e-8 µm (2e-8 relative) from its 1e-10 value for a quarter less time
/// (`docs/batch.md`). Without iterative refinement another third faster, but 1e-6 off: not kept.
fn input_output_bound(
    deflection_um: &[f64],
    actuator: &DiscreteLti,
    voltage_max_v: f64,
    sin_a: f64,
    tol: Option<f64>,
) -> Option<f64> {
    let n_steps = deflection_um.len();
    if n_steps == 0 || deflection_um.iter().any(|d| !d.is_finite()) {
        return None;
    }
    let (den, num) = difference_equation(actuator, voltage_max_v);
    if den.iter().chain(&num).any(|v| !v.is_finite()) {
        return None;
    }
    let n = den.len() - 1;
    // The actuator as its difference equation: y_k + a_1 y_(k−1) + … + a_n y_(k−n) = b_0 u_k + … +
    // b_n u_(k−n), y the tip (µm), u the command as a fraction of the full voltage. The n outputs and
    // commands before the window are free (the commands there unbounded): they reach every initial
    // state of an observable realisation, as the state-space form's free x_0 does (for one that is
    // not observable the set is larger and the bound can only be lower). One equality per step
    // instead of one per state and step: 0.35–0.5 of the state-space form's time on recorded
    // windows (issue 48), the same optimum within the solver's tolerance (tests).
    // variables: u_(−n) … u_(N−1), y_(−n) … y_(N−1), c, h
    let len = n_steps + n;
    let iu = |k: usize| k;
    let iy = |k: usize| len + k;
    let ic = 2 * len;
    let ih = ic + 1;
    let mut lp = LinearProgramme::new(ih + 1);
    if let Some(tol) = tol {
        lp = lp.with_tolerance(tol);
    }
    let mut row = Vec::with_capacity(2 * n + 2);
    for k in n..len {
        row.clear();
        for i in 0..=n {
            row.push((iy(k - i), den[i]));
            row.push((iu(k - i), -num[i]));
        }
        lp.eq(&row, 0.0);
    }
    // inequalities: 0 ≤ u_k ≤ 1, ±(sin α · y_k − δ_k − c) ≤ h
    for (s, &delta_um) in deflection_um.iter().enumerate() {
        let k = s + n;
        lp.le(&[(iu(k), 1.0)], 1.0);
        lp.le(&[(iu(k), -1.0)], 0.0);
        for sign in [1.0, -1.0] {
            lp.le(
                &[(iy(k), sign * sin_a), (ic, -sign), (ih, -1.0)],
                sign * delta_um,
            );
        }
    }
    let z = lp.minimise(ih, 200)?;
    let h = z[ih];
    h.is_finite().then_some(h.max(0.0))
}

/// The actuator's difference equation with the command as a fraction of `voltage_max_v`:
/// `(den, num)`, `den = [1, a_1, …, a_n]` the characteristic polynomial of `A` and `num = [b_0, …, b_n]`
/// with `b_k = Σ_(i≤k) a_i h_(k−i)` from the Markov parameters `h_0 = D`, `h_k = C A^(k−1) B`.
/// Computed in the realisation scaled by [`state_scales`] (a companion form spans 20 orders of
/// magnitude), where Faddeev–LeVerrier's recursion is well conditioned for the few states an actuator
/// has.
fn difference_equation(actuator: &DiscreteLti, voltage_max_v: f64) -> (Vec<f64>, Vec<f64>) {
    use nalgebra::DMatrix;
    let n = actuator.n_states();
    let scale = state_scales(actuator, voltage_max_v);
    let a = DMatrix::from_fn(n, n, |i, j| actuator.a[(i, j)] * scale[i] / scale[j]);
    let b = DMatrix::from_fn(n, 1, |i, _| actuator.b[(i, 0)] * scale[i] * voltage_max_v);
    let c = DMatrix::from_fn(1, n, |_, j| actuator.c[(0, j)] / scale[j]);
    let mut den = vec![1.0; n + 1];
    let mut m = DMatrix::<f64>::identity(n, n);
    for (k, coef) in den.iter_mut().enumerate().skip(1) {
        let am = &a * &m;
        *coef = -am.trace() / k as f64;
        m = am + DMatrix::<f64>::identity(n, n) * *coef;
    }
    let mut markov = Vec::with_capacity(n + 1);
    markov.push(actuator.d[(0, 0)] * voltage_max_v);
    let mut x = b;
    for _ in 0..n {
        markov.push((&c * &x)[(0, 0)]);
        x = &a * x;
    }
    let num = (0..=n)
        .map(|k| (0..=k).map(|i| den[i] * markov[k - i]).sum())
        .collect();
    (den, num)
}

/// A sparse linear programme `minimise z[objective] subject to E z = f, G z ≤ g`, built row by row and
/// solved with Clarabel — the machinery of the references in this crate ([`excess_lower_bound`], the NC
/// stage's `crate::nc_axis_bound`). Zero coefficients are left out; rows keep the order they were added
/// in (equality rows first in the solver).
///
/// ```
/// use millcomp_closedloop::optimum::LinearProgramme;
/// // minimise h subject to |z0 − 3| ≤ h, |z0 − 1| ≤ h: z0 = 2, h = 1
/// let mut lp = LinearProgramme::new(2);
/// for d in [3.0, 1.0] {
///     lp.le(&[(0, 1.0), (1, -1.0)], d);
///     lp.le(&[(0, -1.0), (1, -1.0)], -d);
/// }
/// let z = lp.minimise(1, 100).unwrap();
/// assert!((z[0] - 2.0).abs() < 1e-6 && (z[1] - 1.0).abs() < 1e-6);
/// ```
#[derive(Debug, Clone, Default)]
pub struct LinearProgramme {
    n_var: usize,
    tolerance: Option<f64>,
    eq: (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>),
    le: (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>),
}

impl LinearProgramme {
    /// A programme over `n_var` variables, no rows yet.
    pub fn new(n_var: usize) -> Self {
        Self {
            n_var,
            ..Self::default()
        }
    }

    /// Solve to the relative gap and feasibility tolerance `tol` instead of Clarabel's default (1e-8).
    pub fn with_tolerance(mut self, tol: f64) -> Self {
        self.tolerance = Some(tol);
        self
    }

    /// Number of variables.
    pub fn n_var(&self) -> usize {
        self.n_var
    }

    fn push(
        rows: &mut (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>),
        coeffs: &[(usize, f64)],
        rhs: f64,
    ) {
        let r = rows.3.len();
        for &(c, v) in coeffs {
            if v != 0.0 {
                rows.0.push(r);
                rows.1.push(c);
                rows.2.push(v);
            }
        }
        rows.3.push(rhs);
    }

    /// Add the row `Σ v·z[c] = rhs` over `coeffs` = `(c, v)`.
    pub fn eq(&mut self, coeffs: &[(usize, f64)], rhs: f64) {
        Self::push(&mut self.eq, coeffs, rhs);
    }

    /// Add the row `Σ v·z[c] ≤ rhs`.
    pub fn le(&mut self, coeffs: &[(usize, f64)], rhs: f64) {
        Self::push(&mut self.le, coeffs, rhs);
    }

    /// Solve for the smallest `z[objective]` within `max_iter` interior-point iterations: the solution
    /// when Clarabel reports it solved (or almost), `None` otherwise (an infeasible or unbounded
    /// programme, a variable index out of range) — reported, not an error.
    pub fn minimise(&self, objective: usize, max_iter: u32) -> Option<Vec<f64>> {
        let n = self.n_var;
        if objective >= n
            || self.eq.1.iter().chain(&self.le.1).any(|&c| c >= n)
            || self.eq.3.iter().chain(&self.le.3).any(|v| !v.is_finite())
        {
            return None;
        }
        let n_eq = self.eq.3.len();
        let n_rows = n_eq + self.le.3.len();
        let rows: Vec<usize> = self
            .eq
            .0
            .iter()
            .copied()
            .chain(self.le.0.iter().map(|r| r + n_eq))
            .collect();
        let cols: Vec<usize> = self.eq.1.iter().chain(&self.le.1).copied().collect();
        let vals: Vec<f64> = self.eq.2.iter().chain(&self.le.2).copied().collect();
        let b: Vec<f64> = self.eq.3.iter().chain(&self.le.3).copied().collect();
        let a = CscMatrix::new_from_triplets(n_rows, n, rows, cols, vals);
        let p = CscMatrix::zeros((n, n));
        let mut q = vec![0.0; n];
        q[objective] = 1.0;
        let mut cones: Vec<SupportedConeT<f64>> = Vec::with_capacity(2);
        if n_eq > 0 {
            cones.push(ZeroConeT(n_eq));
        }
        if n_rows > n_eq {
            cones.push(NonnegativeConeT(n_rows - n_eq));
        }
        let mut settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(max_iter)
            .build()
            .ok()?;
        if let Some(tol) = self.tolerance {
            settings.tol_gap_abs = tol;
            settings.tol_gap_rel = tol;
            settings.tol_feas = tol;
        }
        let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings).ok()?;
        solver.solve();
        match solver.solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => Some(solver.solution.x.clone()),
            _ => None,
        }
    }
}

/// Per-state scale: 1 / the state's largest magnitude over 2000 steps of a step to `voltage_max_v` (1 for
/// a state that stays 0).
fn state_scales(actuator: &DiscreteLti, voltage_max_v: f64) -> Vec<f64> {
    let nx = actuator.n_states();
    let mut x = actuator.zero_state();
    let mut peak = vec![0.0f64; nx];
    for _ in 0..2000 {
        actuator.step_siso(&mut x, voltage_max_v);
        for (p, v) in peak.iter_mut().zip(x.iter()) {
            *p = p.max(v.abs());
        }
    }
    peak.iter()
        .map(|&p| {
            if p > 0.0 && p.is_finite() {
                1.0 / p
            } else {
                1.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_sim::PztSpindle;

    /// The bound's programme in state-space form — the formulation before issue 48 (one equality per
    /// state and step, the initial state free) — as the oracle the input–output form must equal.
    fn state_space_bound(
        deflection_um: &[f64],
        actuator: &DiscreteLti,
        voltage_max_v: f64,
        sin_a: f64,
        tol: f64,
    ) -> Option<f64> {
        let n_steps = deflection_um.len();
        let nx = actuator.n_states();
        let scale = state_scales(actuator, voltage_max_v);
        let a_s = |i: usize, j: usize| actuator.a[(i, j)] * scale[i] / scale[j];
        let b_s = |i: usize| actuator.b[(i, 0)] * scale[i] * voltage_max_v;
        let c_s = |j: usize| actuator.c[(0, j)] / scale[j];
        let d_s = actuator.d[(0, 0)] * voltage_max_v;
        let ix = |k: usize, j: usize| n_steps + k * nx + j;
        let ic = n_steps + (n_steps + 1) * nx;
        let ih = ic + 1;
        let mut lp = LinearProgramme::new(ih + 1).with_tolerance(tol);
        for k in 0..n_steps {
            for i in 0..nx {
                let mut row = vec![(ix(k + 1, i), 1.0), (k, -b_s(i))];
                row.extend((0..nx).map(|j| (ix(k, j), -a_s(i, j))));
                lp.eq(&row, 0.0);
            }
        }
        for (k, &delta_um) in deflection_um.iter().enumerate() {
            lp.le(&[(k, 1.0)], 1.0);
            lp.le(&[(k, -1.0)], 0.0);
            for sign in [1.0, -1.0] {
                let mut row: Vec<(usize, f64)> =
                    (0..nx).map(|j| (ix(k, j), sign * sin_a * c_s(j))).collect();
                row.extend([(k, sign * sin_a * d_s), (ic, -sign), (ih, -1.0)]);
                lp.le(&row, sign * delta_um);
            }
        }
        lp.minimise(ih, 200).map(|z| z[ih].max(0.0))
    }

    /// A groove's deflection at 20°, as the stage applies it every 50 µs: a level, a per-tooth ripple
    /// (2 flutes at 40 000 rpm: 0.75 ms a tooth, 15 steps) and a change — a ramp over `ramp` steps from
    /// `from_um` to `to_um` at step 150.
    fn window(from_um: f64, to_um: f64, ramp: usize) -> Vec<f64> {
        (0..600)
            .map(|k| {
                let s = ((k as f64 - 150.0) / ramp.max(1) as f64).clamp(0.0, 1.0);
                let level = from_um + (to_um - from_um) * s;
                let phase = (k % 15) as f64 / 15.0;
                level * (1.0 + 0.3 * (std::f64::consts::TAU * phase).sin().max(0.0))
            })
            .collect()
    }

    /// The input–output form (the same programme with the dynamics as a difference equation) against
    /// the state-space form: both solved to 1e-12 agree within 1e-8 of the optimum (measured ≤ 5.5e-9),
    /// and the bound as a batch computes it (Clarabel's default tolerance) lies within 1e-6 of it
    /// (measured 2.2e-7 and 4.0e-7 for the jumps beyond the stacks' reach, ≤ 3.4e-8 for the others).
    #[test]
    fn the_input_output_form_equals_the_state_space_form() {
        // the fitted stack (2nd order + real pole) and one with a 2nd-order Padé dead time (5 states)
        let fitted = PztSpindle::default();
        let mut delayed = fitted.clone();
        delayed.dead_time_s = Some(1e-4);
        delayed.dead_time_model = millcomp_sim::spindle::DeadTimeModel::Pade2;
        let sin_a = 20f64.to_radians().sin();
        for spindle in [&fitted, &delayed] {
            let a = spindle.to_lti().unwrap().discretize_zoh(5e-5).unwrap();
            let v_max = spindle.voltage_max_v;
            // a change the stack follows, one made at once, one beyond its reach
            for (from, to, ramp) in [(4.0, 6.0, 340), (4.0, 8.0, 1), (2.0, 40.0, 1)] {
                let d = window(from, to, ramp);
                let what = format!("{} states, {from}→{to} µm over {ramp} steps", a.n_states());
                let exact = state_space_bound(&d, &a, v_max, sin_a, 1e-12).unwrap();
                assert!(exact > 0.5, "{what}: {exact}");
                let batch = excess_lower_bound(&d, &a, v_max, sin_a).unwrap();
                assert!(
                    (batch - exact).abs() <= 1e-6 * exact,
                    "{what}: {batch} against {exact}"
                );
                let io = input_output_bound(&d, &a, v_max, sin_a, Some(1e-12)).unwrap();
                assert!(
                    (io - exact).abs() <= 1e-8 * exact,
                    "{what}: {io} against {exact}"
                );
            }
        }
    }

    #[test]
    fn the_difference_equation_reproduces_the_step_response() {
        let spindle = PztSpindle::default();
        let a = spindle.to_lti().unwrap().discretize_zoh(5e-5).unwrap();
        let v_max = spindle.voltage_max_v;
        let (den, num) = difference_equation(&a, v_max);
        let n = den.len() - 1;
        let mut x = a.zero_state();
        let (mut y, mut u) = (vec![0.0; n], vec![0.0; n]);
        for _ in 0..400 {
            let tip = a.step_siso(&mut x, 0.5 * v_max);
            u.push(0.5);
            let k = u.len() - 1;
            let rhs: f64 = (0..=n).map(|i| num[i] * u[k - i]).sum::<f64>()
                - (1..=n).map(|i| den[i] * y[k - i]).sum::<f64>();
            y.push(rhs);
            assert!(
                (rhs - tip).abs() <= 1e-9 * tip.abs().max(1.0),
                "{rhs} against {tip}"
            );
        }
    }
}
