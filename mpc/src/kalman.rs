//! Disturbance-augmented prediction model and its steady-state Kalman filter.
//!
//! Offset-free MPC (Muske & Badgwell 2002; Pannocchia & Rawlings 2003): the plant model
//! `x⁺ = A x + B u`, `y = C x + w` (w: a *known* output offset, the preview of the planned process) is
//! augmented with integrating disturbances `d⁺ = d`:
//!
//! ```text
//! ξ = [x; d],   ξ⁺ = [[A, B_d], [0, I]] ξ + [B; 0] u,   y = [C, C_d] ξ + w.
//! ```
//!
//! Output disturbances: `B_d = 0`, `C_d` selects the disturbed outputs. Input disturbances: `B_d = B` columns,
//! `C_d = 0`. The filter is the *current* (measurement-update-first) form with the steady-state gain of the
//! filter Riccati equation, found by plain fixed-point iteration of the DARE (converges for a detectable
//! augmented pair, which holds when the plant has no pole at z = 1 for output disturbances).

use nalgebra::{DMatrix, DVector};

use crate::config::{DisturbanceKind, MpcConfig};
use crate::error::MpcError;
use millcomp_sim::DiscreteLti;

/// The plant model augmented with integrating disturbance states, in *scaled* plant coordinates.
///
/// The plant state is rescaled, `x = T x̃` with `T = diag(t)`, `tᵢ` the largest `|xᵢ|` of the unit-step
/// responses of all inputs (a realisation-independent conditioning step: a controllable-canonical model of
/// the PZT spindle has states that differ by 10⁹ in scale). Outputs, inputs and disturbances keep their
/// units; use [`AugmentedModel::to_internal`] / [`AugmentedModel::to_original`] to convert states.
#[derive(Debug, Clone, PartialEq)]
pub struct AugmentedModel {
    /// Augmented state matrix `[[Ã, B̃_d], [0, I]]`.
    pub a: DMatrix<f64>,
    /// Augmented input matrix `[B̃; 0]`.
    pub b: DMatrix<f64>,
    /// Augmented output matrix `[C̃, C_d]`.
    pub c: DMatrix<f64>,
    /// Number of plant states.
    pub n_plant: usize,
    /// Number of disturbance states.
    pub n_dist: usize,
    /// Sample time (s).
    pub dt_s: f64,
    /// State scale `t` (`x = diag(t) x̃`).
    pub state_scale: DVector<f64>,
}

/// Largest |xᵢ| over the unit-step responses of every input (at most 2000 steps), 1 where that is 0 or
/// not finite.
fn step_scales(model: &DiscreteLti) -> DVector<f64> {
    let (nx, nu) = (model.n_states(), model.n_inputs());
    let mut scale = DVector::<f64>::zeros(nx);
    for i in 0..nu {
        let mut x = DVector::<f64>::zeros(nx);
        let bi = model.b.column(i).into_owned();
        for _ in 0..2000 {
            x = &model.a * &x + &bi;
            if !x.iter().all(|v| v.is_finite() && v.abs() < 1e150) {
                break;
            }
            for j in 0..nx {
                scale[j] = scale[j].max(x[j].abs());
            }
        }
    }
    scale.map(|v| if v.is_finite() && v > 1e-300 { v } else { 1.0 })
}

impl AugmentedModel {
    /// Build from a strictly proper discrete model (`D = 0`: the measurement of cycle k is taken before the
    /// command of cycle k is applied) and the disturbance part of `cfg`.
    pub fn new(model: &DiscreteLti, cfg: &MpcConfig) -> Result<Self, MpcError> {
        Self::with_scale(model, cfg, step_scales(model))
    }

    /// The same augmentation of another realisation of the plant — `model` sampled at a sub-step of
    /// this one's cycle — in this one's scaled coordinates, so that states carry over between the two.
    ///
    /// # Errors
    /// As [`Self::new`]; [`MpcError::DimensionMismatch`] when `model` has another number of states.
    pub fn same_coordinates(&self, model: &DiscreteLti, cfg: &MpcConfig) -> Result<Self, MpcError> {
        if model.n_states() != self.n_plant {
            return Err(MpcError::DimensionMismatch {
                what: "states of the sub-step model".into(),
                expected: self.n_plant,
                found: model.n_states(),
            });
        }
        Self::with_scale(model, cfg, self.state_scale.clone())
    }

    fn with_scale(model: &DiscreteLti, cfg: &MpcConfig, t: DVector<f64>) -> Result<Self, MpcError> {
        let (nx, nu, ny) = (model.n_states(), model.n_inputs(), model.n_outputs());
        if model.d.iter().any(|v| *v != 0.0) {
            return Err(MpcError::InvalidConfig {
                key: "model.d".into(),
                value: "non-zero feed-through".into(),
                allowed: "D = 0 (strictly proper: the measurement precedes the command)".into(),
            });
        }
        if nx == 0 || nu == 0 || ny == 0 {
            return Err(MpcError::DimensionMismatch {
                what: "model states/inputs/outputs (all must be >= 1)".into(),
                expected: 1,
                found: nx.min(nu).min(ny),
            });
        }
        // Ã = T⁻¹ A T, B̃ = T⁻¹ B, C̃ = C T
        let mut at = model.a.clone();
        let mut bt = model.b.clone();
        let mut ct = model.c.clone();
        for i in 0..nx {
            for j in 0..nx {
                at[(i, j)] *= t[j] / t[i];
            }
            for j in 0..nu {
                bt[(i, j)] /= t[i];
            }
        }
        for r in 0..ny {
            for j in 0..nx {
                ct[(r, j)] *= t[j];
            }
        }
        let kind = cfg.disturbance.kind;
        let channels: Vec<usize> = match (&cfg.disturbance.channels, kind) {
            (_, DisturbanceKind::None) => Vec::new(),
            (Some(c), _) => c.clone(),
            (None, DisturbanceKind::Output) => (0..ny).collect(),
            (None, DisturbanceKind::Input) => (0..nu).collect(),
        };
        let nd = channels.len();
        let n = nx + nd;
        let mut a = DMatrix::zeros(n, n);
        a.view_mut((0, 0), (nx, nx)).copy_from(&at);
        let mut b = DMatrix::zeros(n, nu);
        b.view_mut((0, 0), (nx, nu)).copy_from(&bt);
        let mut c = DMatrix::zeros(ny, n);
        c.view_mut((0, 0), (ny, nx)).copy_from(&ct);
        for (j, &ch) in channels.iter().enumerate() {
            a[(nx + j, nx + j)] = 1.0;
            match kind {
                DisturbanceKind::Output => {
                    if ch >= ny {
                        return Err(crate::error::invalid(
                            format!("disturbance.channels[{j}]"),
                            ch,
                            format!("0 ..= {}", ny - 1),
                        ));
                    }
                    c[(ch, nx + j)] = 1.0;
                }
                DisturbanceKind::Input => {
                    if ch >= nu {
                        return Err(crate::error::invalid(
                            format!("disturbance.channels[{j}]"),
                            ch,
                            format!("0 ..= {}", nu - 1),
                        ));
                    }
                    for i in 0..nx {
                        a[(i, nx + j)] = bt[(i, ch)];
                    }
                }
                DisturbanceKind::None => {}
            }
        }
        if kind == DisturbanceKind::Output {
            for (j, cp) in cfg.disturbance.coupling.iter().enumerate() {
                if cp.state >= nd || cp.output >= ny {
                    return Err(crate::error::invalid(
                        format!("disturbance.coupling[{j}]"),
                        format!("state {}, output {}", cp.state, cp.output),
                        format!(
                            "state 0 ..= {}, output 0 ..= {}",
                            nd.saturating_sub(1),
                            ny.saturating_sub(1)
                        ),
                    ));
                }
                c[(cp.output, nx + cp.state)] += cp.gain;
            }
        }
        Ok(Self {
            a,
            b,
            c,
            n_plant: nx,
            n_dist: nd,
            dt_s: model.dt_s,
            state_scale: t,
        })
    }

    /// Augmented state dimension.
    pub fn n(&self) -> usize {
        self.n_plant + self.n_dist
    }
    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }
    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.c.nrows()
    }

    /// Original-coordinate augmented state `[x; d]` → internal `[x̃; d]`.
    pub fn to_internal(&self, xa: &DVector<f64>) -> DVector<f64> {
        let mut v = xa.clone();
        for i in 0..self.n_plant.min(v.len()) {
            v[i] /= self.state_scale[i];
        }
        v
    }

    /// Internal `[x̃; d]` → original-coordinate `[x; d]`.
    pub fn to_original(&self, xi: &DVector<f64>) -> DVector<f64> {
        let mut v = xi.clone();
        for i in 0..self.n_plant.min(v.len()) {
            v[i] *= self.state_scale[i];
        }
        v
    }
}

/// Steady-state (current-form) Kalman filter on the augmented state.
#[derive(Debug, Clone)]
pub struct KalmanFilter {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    /// Steady-state filter gain `L = P Cᵀ (C P Cᵀ + R)⁻¹` (n × ny), P the a-priori covariance.
    pub gain: DMatrix<f64>,
    /// A-priori steady-state covariance (internal coordinates).
    pub covariance: DMatrix<f64>,
    /// Number of doubling iterations used.
    pub iterations: usize,
    x_pred: DVector<f64>,
    x_filt: DVector<f64>,
    r: DMatrix<f64>,
    gate: Vec<f64>,
    gate_max_skips: usize,
    consecutive_skips: Vec<usize>,
    reacquire: Vec<bool>,
    /// Cycles in which at least one output was skipped (not finite, or gated as an outlier).
    pub skipped_measurements: usize,
    /// Output-cycles rejected by the innovation gate.
    pub gated_outputs: usize,
    /// The gain of each proper subset of the outputs (indexed by the bit mask of the outputs used;
    /// `None`: the subset's innovation covariance is singular), computed once for up to
    /// [`SUBSET_GAINS_MAX_OUTPUTS`] outputs so a cycle with a skipped output does not allocate.
    subset_gains: Vec<Option<DMatrix<f64>>>,
    /// A cycle's scratch: the predicted outputs, the innovations, the correction and the next state.
    yhat_buf: DVector<f64>,
    innov_buf: DVector<f64>,
    used_buf: Vec<usize>,
    dx_buf: DVector<f64>,
    next_buf: DVector<f64>,
    bu_buf: DVector<f64>,
}

/// Up to this many outputs, the gains of the output subsets are computed at construction.
pub const SUBSET_GAINS_MAX_OUTPUTS: usize = 6;

/// Iteration cap and relative tolerance of the structured doubling algorithm.
const SDA_MAX_ITER: usize = 100;
const SDA_REL_TOL: f64 = 1e-13;

/// Solve the filter DARE `X = A X Aᵀ − A X Cᵀ (C X Cᵀ + R)⁻¹ C X Aᵀ + Q` by the structured doubling
/// algorithm (Chu, Fan, Lin & Wang 2004), applied to the dual control DARE with `(Aᵀ, Cᵀ)`:
/// `A₀ = Aᵀ, G₀ = Cᵀ R⁻¹ C, H₀ = Q`; `W = I + G H`; `A ← A W⁻¹ A`, `G ← G + A W⁻¹ G Aᵀ`,
/// `H ← H + Aᵀ H W⁻¹ A`; `H → X` quadratically.
pub fn filter_dare(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, usize), MpcError> {
    let n = a.nrows();
    let r_inv = r.clone().try_inverse().ok_or(MpcError::Numerical {
        what: "kalman DARE",
        detail: "measurement covariance singular".into(),
    })?;
    let mut ak = a.transpose();
    let mut gk = c.transpose() * r_inv * c;
    let mut hk = q.clone();
    let eye = DMatrix::<f64>::identity(n, n);
    for it in 0..SDA_MAX_ITER {
        let w = &eye + &gk * &hk;
        let w_lu = w.lu();
        let wa = w_lu.solve(&ak).ok_or(MpcError::Numerical {
            what: "kalman DARE",
            detail: "I + G H singular in the doubling iteration".into(),
        })?;
        let wg = w_lu.solve(&gk).ok_or(MpcError::Numerical {
            what: "kalman DARE",
            detail: "I + G H singular in the doubling iteration".into(),
        })?;
        let a_next = &ak * &wa;
        let mut g_next = &gk + &ak * wg * ak.transpose();
        let mut h_next = &hk + ak.transpose() * &hk * &wa;
        g_next = (&g_next + g_next.transpose()) * 0.5;
        h_next = (&h_next + h_next.transpose()) * 0.5;
        if !h_next.iter().all(|v| v.is_finite()) {
            break;
        }
        let diff = (&h_next - &hk).norm();
        let scale = h_next.norm().max(1e-300);
        ak = a_next;
        gk = g_next;
        hk = h_next;
        if diff <= SDA_REL_TOL * scale {
            return Ok((hk, it + 1));
        }
    }
    Err(MpcError::Numerical {
        what: "kalman DARE",
        detail: format!(
            "no convergence after {SDA_MAX_ITER} doubling steps: the augmented model is not detectable \
             (output disturbance on a plant with an integrator?) or the noise covariances are extreme"
        ),
    })
}

impl KalmanFilter {
    /// Steady-state filter for `model` with input-referred plant noise `q_input · B̃ B̃ᵀ` (plus 1e-9 of its
    /// trace on the diagonal, for definiteness), disturbance random-walk variances `q_dist` (one for
    /// every disturbance state, or one per state), and measurement noise variances `r` (one per output).
    pub fn steady_state(
        model: &AugmentedModel,
        q_input: f64,
        q_dist: &[f64],
        r: &[f64],
    ) -> Result<Self, MpcError> {
        let n = model.n();
        let np = model.n_plant;
        let ny = model.n_outputs();
        if r.len() != ny {
            return Err(MpcError::DimensionMismatch {
                what: "kalman.measurement_noise".into(),
                expected: ny,
                found: r.len(),
            });
        }
        if !(q_dist.len() == 1 || q_dist.len() == model.n_dist) {
            return Err(MpcError::DimensionMismatch {
                what: "kalman.disturbance_noise_per_state".into(),
                expected: model.n_dist,
                found: q_dist.len(),
            });
        }
        let q_state = |j: usize| q_dist[if q_dist.len() == 1 { 0 } else { j }];
        let bp = model.b.rows(0, np).into_owned();
        let qp = &bp * bp.transpose() * q_input;
        let eps = 1e-9 * qp.trace().max(1e-300) / np as f64;
        let mut q = DMatrix::zeros(n, n);
        q.view_mut((0, 0), (np, np)).copy_from(&qp);
        for i in 0..n {
            q[(i, i)] += if i < np { eps } else { q_state(i - np) };
        }
        let rm = DMatrix::from_diagonal(&DVector::from_column_slice(r));
        let (p, iterations) = filter_dare(&model.a, &model.c, &q, &rm)?;
        let c = &model.c;
        let s = c * &p * c.transpose() + &rm;
        let s_inv = s.try_inverse().ok_or(MpcError::Numerical {
            what: "kalman gain",
            detail: "innovation covariance singular".into(),
        })?;
        let gain = &p * c.transpose() * s_inv;
        if !gain.iter().all(|v| v.is_finite()) {
            return Err(MpcError::Numerical {
                what: "kalman gain",
                detail: "not finite".into(),
            });
        }
        let mut kf = Self {
            a: model.a.clone(),
            b: model.b.clone(),
            c: model.c.clone(),
            gain,
            covariance: p,
            iterations,
            x_pred: DVector::zeros(n),
            x_filt: DVector::zeros(n),
            r: rm,
            gate: Vec::new(),
            gate_max_skips: 0,
            consecutive_skips: vec![0; ny],
            reacquire: vec![false; ny],
            skipped_measurements: 0,
            gated_outputs: 0,
            subset_gains: Vec::new(),
            yhat_buf: DVector::zeros(ny),
            innov_buf: DVector::zeros(ny),
            used_buf: Vec::with_capacity(ny),
            dx_buf: DVector::zeros(n),
            next_buf: DVector::zeros(n),
            bu_buf: DVector::zeros(n),
        };
        if ny <= SUBSET_GAINS_MAX_OUTPUTS {
            let mut used = Vec::with_capacity(ny);
            kf.subset_gains = (0..(1usize << ny))
                .map(|mask| {
                    used.clear();
                    used.extend((0..ny).filter(|i| mask & (1 << i) != 0));
                    if used.is_empty() || used.len() == ny {
                        None
                    } else {
                        kf.subset_gain(&used)
                    }
                })
                .collect();
        }
        Ok(kf)
    }

    /// The gain of the outputs `used` (a proper subset): `L_s = P C_sᵀ (C_s P C_sᵀ + R_s)⁻¹`; `None`
    /// when the subset's innovation covariance is singular.
    fn subset_gain(&self, used: &[usize]) -> Option<DMatrix<f64>> {
        let cs = DMatrix::from_fn(used.len(), self.c.ncols(), |r, j| self.c[(used[r], j)]);
        let rs = DMatrix::from_fn(used.len(), used.len(), |r, q| self.r[(used[r], used[q])]);
        let s = &cs * &self.covariance * cs.transpose() + rs;
        s.try_inverse()
            .map(|s_inv| &self.covariance * cs.transpose() * s_inv)
    }

    /// Back to the state after construction: the estimate at zero, the gate's counts cleared.
    pub fn restart(&mut self) {
        self.x_pred.fill(0.0);
        self.x_filt.fill(0.0);
        self.consecutive_skips.fill(0);
        self.reacquire.fill(false);
        self.skipped_measurements = 0;
        self.gated_outputs = 0;
    }

    /// Enable innovation gating: per-output absolute gates (empty: off) and the maximum number of
    /// consecutive cycles an output may be rejected before it is accepted again.
    pub fn set_gate(&mut self, gate: &[f64], max_skips: usize) {
        self.gate = gate.to_vec();
        self.gate_max_skips = max_skips;
    }

    /// Set the state estimate (internal coordinates).
    pub fn reset(&mut self, x: &DVector<f64>) {
        self.x_pred.copy_from(x);
        self.x_filt.copy_from(x);
    }

    /// Measurement update with `y` (measured outputs) and the known output offset `w` of this cycle:
    /// `ξ̂ = ξ̂⁻ + L (y − w − C ξ̂⁻)`. Outputs that are not finite, or whose innovation exceeds the gate (for
    /// at most `gate_max_skips` consecutive cycles; after that the output is accepted every cycle until its
    /// innovation is back inside the gate), are left out: the update then uses the gain of the
    /// remaining outputs, `L_s = P C_sᵀ (C_s P C_sᵀ + R_s)⁻¹` with the steady-state a-priori covariance P.
    /// Returns the filtered estimate.
    pub fn correct(&mut self, y: &[f64], w: &[f64]) -> &DVector<f64> {
        let ny = self.c.nrows();
        self.x_filt.copy_from(&self.x_pred);
        if y.len() != ny || w.len() != ny {
            self.skipped_measurements += 1;
            return &self.x_filt;
        }
        // no allocation: the products go into the filter's scratch (the same arithmetic as `*`)
        self.c.mul_to(&self.x_pred, &mut self.yhat_buf);
        let mut used = std::mem::take(&mut self.used_buf);
        used.clear();
        let mut k = 0;
        for i in 0..ny {
            let v = y[i] - w[i] - self.yhat_buf[i];
            if !v.is_finite() {
                continue;
            }
            if let Some(&g) = self.gate.get(i) {
                if v.abs() <= g {
                    self.reacquire[i] = false;
                } else if !self.reacquire[i] {
                    if self.consecutive_skips[i] < self.gate_max_skips {
                        self.consecutive_skips[i] += 1;
                        self.gated_outputs += 1;
                        continue;
                    }
                    // persisted longer than a glitch: accept it (and keep accepting until it is back
                    // inside the gate)
                    self.reacquire[i] = true;
                }
            }
            self.consecutive_skips[i] = 0;
            used.push(i);
            self.innov_buf[k] = v;
            k += 1;
        }
        if used.len() < ny {
            self.skipped_measurements += 1;
        }
        if used.is_empty() {
            self.used_buf = used;
            return &self.x_filt;
        }
        let innov = self.innov_buf.rows(0, k);
        if used.len() == ny {
            self.gain.mul_to(&innov, &mut self.dx_buf);
            self.x_filt += &self.dx_buf;
        } else if !self.subset_gains.is_empty() {
            let mask = used.iter().fold(0usize, |m, &i| m | (1 << i));
            if let Some(l) = &self.subset_gains[mask] {
                l.mul_to(&innov, &mut self.dx_buf);
                self.x_filt += &self.dx_buf;
            }
        } else if let Some(l) = self.subset_gain(&used) {
            l.mul_to(&innov, &mut self.dx_buf);
            self.x_filt += &self.dx_buf;
        }
        self.used_buf = used;
        if !self.x_filt.iter().all(|v| v.is_finite()) {
            self.x_filt.copy_from(&self.x_pred);
        }
        &self.x_filt
    }

    /// Time update with the input actually applied: `ξ̂⁻ ← A ξ̂ + B u`.
    pub fn predict(&mut self, u: &[f64]) {
        let ud = nalgebra::DVectorView::from_slice(u, u.len());
        // no allocation: the products go into the filter's scratch (the same arithmetic as `*`)
        self.a.mul_to(&self.x_filt, &mut self.next_buf);
        self.b.mul_to(&ud, &mut self.bu_buf);
        self.next_buf += &self.bu_buf;
        if self.next_buf.iter().all(|v| v.is_finite()) {
            self.x_pred.copy_from(&self.next_buf);
        }
    }

    /// Current filtered estimate `ξ̂_{k|k}` (internal coordinates).
    pub fn estimate(&self) -> &DVector<f64> {
        &self.x_filt
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use millcomp_sim::ContinuousLti;

    fn first_order() -> DiscreteLti {
        ContinuousLti::from_transfer_function(&[2.0], &[1e-2, 1.0])
            .unwrap()
            .discretize_zoh(1e-3)
            .unwrap()
    }

    /// [`first_order`] read by two sensors, the second through `gain` (the groove MPC's gauge and
    /// depth error: one tip, the second through sin α).
    fn two_outputs(gain: f64) -> DiscreteLti {
        let m = first_order();
        let c = DMatrix::from_row_slice(2, 1, &[m.c[(0, 0)], gain * m.c[(0, 0)]]);
        DiscreteLti::new(m.a.clone(), m.b.clone(), c, DMatrix::zeros(2, 1), m.dt_s).unwrap()
    }

    /// `cycles` measurement updates with `y` at rest (no known offset, zero input).
    fn settle(kf: &mut KalmanFilter, y: &[f64], cycles: usize) {
        let w = vec![0.0; y.len()];
        for _ in 0..cycles {
            kf.correct(y, &w);
            kf.predict(&[0.0]);
        }
    }

    #[test]
    fn scalar_dare_matches_closed_form() {
        // scalar system without disturbance: p = a²p − a²p²/(p + r) + q  ⇒ closed-form positive root
        let m = first_order();
        let mut cfg = MpcConfig::siso(5, -1.0, 1.0, 1.0);
        cfg.disturbance.kind = DisturbanceKind::None;
        let aug = AugmentedModel::new(&m, &cfg).unwrap();
        // internal (scaled) coordinates; process noise q = q_u b² (+1e-9 of it)
        let (a, b, c) = (aug.a[(0, 0)], aug.b[(0, 0)], aug.c[(0, 0)]);
        let (qu, r) = (1e-3, 1e-2);
        let q = qu * b * b * (1.0 + 1e-9);
        let kf = KalmanFilter::steady_state(&aug, qu, &[1.0], &[r]).unwrap();
        // c² p² + (r(1 − a²) − q c²) p − q r = 0
        let (qa, qb, qc) = (c * c, r * (1.0 - a * a) - q * c * c, -q * r);
        let p = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
        assert_relative_eq!(kf.covariance[(0, 0)], p, max_relative = 1e-9);
    }

    #[test]
    fn output_disturbance_estimated_offset_free() {
        let m = first_order();
        let cfg = MpcConfig::siso(5, -1.0, 1.0, 1.0);
        let aug = AugmentedModel::new(&m, &cfg).unwrap();
        assert_eq!(aug.n(), 2);
        let mut kf = KalmanFilter::steady_state(&aug, 1e-6, &[1e-2], &[1e-4]).unwrap();
        // true plant at rest with an output offset of 0.7: the estimate converges to d = 0.7
        settle(&mut kf, &[0.7], 2000);
        assert_relative_eq!(kf.estimate()[1], 0.7, epsilon = 1e-6);
        // a NaN measurement is skipped, not propagated
        kf.correct(&[f64::NAN], &[0.0]);
        assert!(kf.estimate().iter().all(|v| v.is_finite()));
        assert_eq!(kf.skipped_measurements, 1);
    }

    /// A disturbance that is one displacement seen by two sensors (the groove MPC's stack disturbance:
    /// the gauge, and the depth error through the tilt) is one state with a coupling, and the second
    /// output's own state is left with what only that output sees.
    #[test]
    fn coupled_output_disturbance_is_estimated_where_it_enters() {
        let s = 0.342; // sin 20°
        let m = two_outputs(s);
        let mut cfg = MpcConfig::siso(5, -1.0, 1.0, 1.0);
        cfg.weights.output = vec![0.0, 1.0];
        cfg.disturbance.channels = Some(vec![0, 1]);
        cfg.disturbance.coupling = vec![crate::config::DisturbanceCoupling {
            state: 0,
            output: 1,
            gain: s,
        }];
        let aug = AugmentedModel::new(&m, &cfg).unwrap();
        assert_eq!((aug.c[(1, 1)], aug.c[(0, 2)], aug.c[(1, 2)]), (s, 0.0, 1.0));
        // at rest: the stack stands 0.7 off the model (both sensors see it), the second output also
        // carries 0.2 of its own
        let y = [0.7, s * 0.7 + 0.2];
        let mut kf = KalmanFilter::steady_state(&aug, 1e-6, &[1e-2], &[1e-4, 1e-2]).unwrap();
        settle(&mut kf, &y, 4000);
        assert_relative_eq!(kf.estimate()[1], 0.7, epsilon = 1e-6);
        assert_relative_eq!(kf.estimate()[2], 0.2, epsilon = 1e-6);
        // without the coupling the second output's state takes both
        cfg.disturbance.coupling.clear();
        let aug = AugmentedModel::new(&m, &cfg).unwrap();
        let mut kf = KalmanFilter::steady_state(&aug, 1e-6, &[1e-2], &[1e-4, 1e-2]).unwrap();
        settle(&mut kf, &y, 4000);
        assert_relative_eq!(kf.estimate()[2], s * 0.7 + 0.2, epsilon = 1e-6);
        // a coupling must name a state and an output that exist
        cfg.disturbance.coupling = vec![crate::config::DisturbanceCoupling {
            state: 2,
            output: 1,
            gain: s,
        }];
        assert!(matches!(
            cfg.validate(1, 2),
            Err(MpcError::InvalidConfig { key, .. }) if key == "disturbance.coupling[0].state"
        ));
        assert!(matches!(
            AugmentedModel::new(&m, &cfg),
            Err(MpcError::InvalidConfig { key, .. }) if key == "disturbance.coupling[0]"
        ));
        // one random-walk variance per state, or none
        cfg.disturbance.coupling.clear();
        cfg.kalman.disturbance_noise_per_state = vec![1e-4, 1e-5, 1e-5];
        assert!(matches!(
            cfg.validate(1, 2),
            Err(MpcError::InvalidConfig { key, .. }) if key == "kalman.disturbance_noise_per_state"
        ));
    }

    /// A disturbance state given a larger random-walk variance is tracked faster: after a step of the
    /// output, the faster state has taken up more of it after 5 cycles.
    #[test]
    fn per_state_disturbance_noise_sets_each_states_speed() {
        let m = two_outputs(1.0);
        let mut cfg = MpcConfig::siso(5, -1.0, 1.0, 1.0);
        cfg.weights.output = vec![0.0, 1.0];
        cfg.disturbance.channels = Some(vec![0, 1]);
        let aug = AugmentedModel::new(&m, &cfg).unwrap();
        let mut kf = KalmanFilter::steady_state(&aug, 1e-9, &[1e-4, 1e-7], &[1e-4, 1e-4]).unwrap();
        settle(&mut kf, &[1.0, 1.0], 5);
        let (fast, slow) = (kf.estimate()[1], kf.estimate()[2]);
        assert!(fast > 0.9 && slow < 0.2, "fast {fast} slow {slow}");
        assert!(matches!(
            KalmanFilter::steady_state(&aug, 1e-9, &[1e-4, 1e-7, 1e-7], &[1e-4, 1e-4]),
            Err(MpcError::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn rejects_feedthrough() {
        let mut m = first_order();
        m.d[(0, 0)] = 1.0;
        let cfg = MpcConfig::siso(5, -1.0, 1.0, 1.0);
        assert!(
            matches!(AugmentedModel::new(&m, &cfg), Err(MpcError::InvalidConfig { key, .. }) if key == "model.d")
        );
    }
}
