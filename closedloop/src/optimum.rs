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
//!   starting from any state. It minimises `max |e − c|` over the window for the best constant `c`;
//!   the issue's excess measures `|e − e_settled|` over a longer window for one particular `c`, so no
//!   controller's excess can be smaller. A deflection that jumps within one stage step (the per-revolution
//!   peak of a step made at once) leaves at least half the jump, since the tip cannot jump.

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
    let n_steps = deflection_um.len();
    if n_steps == 0 || deflection_um.iter().any(|d| !d.is_finite()) {
        return None;
    }
    let nx = actuator.n_states();
    // a companion-form realisation spans 20 orders of magnitude (C ~ 1e12, B ~ 1e-19 at 50 µs): scale
    // each state by its largest value in a step response to the full voltage, so the programme's
    // coefficients are of order one (commands in units of the full voltage)
    let scale = state_scales(actuator, voltage_max_v);
    let a_s = |i: usize, j: usize| actuator.a[(i, j)] * scale[i] / scale[j];
    let b_s = |i: usize| actuator.b[(i, 0)] * scale[i] * voltage_max_v;
    let c_s = |j: usize| actuator.c[(0, j)] / scale[j];
    let d_s = actuator.d[(0, 0)] * voltage_max_v;
    // variables: u_0..u_{N-1} (fractions of the full voltage), x_0..x_N, c, h
    let iu = |k: usize| k;
    let ix = |k: usize, j: usize| n_steps + k * nx + j;
    let ic = n_steps + (n_steps + 1) * nx;
    let ih = ic + 1;
    let mut lp = LinearProgramme::new(ih + 1);
    let mut row = Vec::with_capacity(2 * nx + 3);
    // dynamics: x_{k+1} − A x_k − B u_k = 0
    for k in 0..n_steps {
        for i in 0..nx {
            row.clear();
            row.push((ix(k + 1, i), 1.0));
            for j in 0..nx {
                row.push((ix(k, j), -a_s(i, j)));
            }
            row.push((iu(k), -b_s(i)));
            lp.eq(&row, 0.0);
        }
    }
    // inequalities: 0 ≤ u_k ≤ 1, ±(sin α (C x_k + D u_k) − δ_k − c) ≤ h
    for (k, &delta_um) in deflection_um.iter().enumerate().take(n_steps) {
        lp.le(&[(iu(k), 1.0)], 1.0);
        lp.le(&[(iu(k), -1.0)], 0.0);
        for sign in [1.0, -1.0] {
            row.clear();
            for j in 0..nx {
                row.push((ix(k, j), sign * sin_a * c_s(j)));
            }
            row.push((iu(k), sign * sin_a * d_s));
            row.push((ic, -sign));
            row.push((ih, -1.0));
            lp.le(&row, sign * delta_um);
        }
    }
    let z = lp.minimise(ih, 200)?;
    let h = z[ih];
    h.is_finite().then_some(h.max(0.0))
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
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(max_iter)
            .build()
            .ok()?;
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
