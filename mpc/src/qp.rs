//! The condensed MPC quadratic program, built once and solved with Clarabel every cycle.
//!
//! Decision `z = [v; s]`: `v` holds the input value of each move block (absolute inputs, `n_blocks · n_u`),
//! `s ≥ 0` one slack per softly bounded output. With `U = M v` (block expansion) and the predicted outputs
//! over the horizon `Y = F ξ̂ + G M v + W` (k = 1..N; F, G from the augmented model, W the known offsets):
//!
//! ```text
//! min ½ zᵀ P z + qᵀ z
//!   P = 2·blkdiag(GbᵀQ̄Gb + EᵀR̄E + MᵀS̄M, ρ₂ I),   Gb = G M
//!   q = [2 GbᵀQ̄ (F ξ̂ + W − Rref) − 2 EᵀR̄ e₀ u_prev − 2 MᵀS̄ 1 u_target;  ρ₁ 1]
//! s.t.  max(u_min, u_prev − Δu_max) ≤ v₀ ≤ min(u_max, u_prev + Δu_max)   (hard: bounds and first slew)
//!       u_min ≤ v_j ≤ u_max                             (hard, j ≥ 1)
//!       |v_j − v_{j−1}| ≤ Δu_max                        (hard slew, j ≥ 1, `limits.slew_rows =
//!                                                       "every_block"`; a block boundary is one step)
//!       y_min − s ≤ (F ξ̂ + Gb v + W)_k ≤ y_max + s       (soft, every k, exact L∞ penalty;
//!                                                       + Rref_k where the bound is about the reference)
//!       s ≥ 0
//! ```
//!
//! P and A never change; per cycle only `q` and `b` are rewritten with Clarabel's `update_q`/`update_b`
//! (presolve is off — it would drop rows and forbid data updates — and zero dropping is off).
//!
//! A cycle's deadline ([`CondensedQp::solve_by`]) is enforced through Clarabel's termination callback,
//! checked once per interior-point iteration. Clarabel's own `time_limit` cannot serve as a per-cycle
//! budget: in 0.11 the time it checks includes the solver's one-time setup ("solve time so far (includes
//! setup)", `info.rs`), so it is left unlimited.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DataUpdateError, DefaultInfo, DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver,
    NonnegativeConeT, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::config::{MpcConfig, SlewRows, SolverConfig};
use crate::error::MpcError;
use crate::kalman::AugmentedModel;

/// One soft-bound row: `sign · (c_row + Gb_row v) − s_j ≤ sign · bound`.
#[derive(Debug, Clone, Copy)]
struct SoftRow {
    /// Row in A/b.
    row: usize,
    /// Row of the stacked output vector (k·ny + output).
    y_row: usize,
    /// +1 for an upper bound, −1 for a lower bound.
    sign: f64,
    /// The bound.
    bound: f64,
    /// The bound is on the deviation from the reference.
    about_reference: bool,
}

/// (output, min, max, checked 0-based steps, about the reference) of one soft-bounded output.
type SoftSpec = (usize, Option<f64>, Option<f64>, Vec<usize>, bool);

/// Outcome of one QP solve (status only; the solution is read with [`CondensedQp::solution`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QpStatus {
    /// Clarabel: Solved.
    Solved,
    /// Clarabel: AlmostSolved (reduced accuracy, accepted).
    AlmostSolved,
    /// Iteration limit.
    MaxIterations,
    /// Stopped at the cycle's deadline (the time budget), or Clarabel's time limit.
    MaxTime,
    /// Numerical error / insufficient progress.
    NumericalError,
    /// (Almost) primal or dual infeasible — cannot happen with the slack formulation unless data are broken.
    Infeasible,
    /// The per-cycle data contained NaN/inf; the solver was not called.
    NonFiniteData,
    /// A solution was reported but contained NaN/inf.
    NonFiniteSolution,
    /// Anything else.
    Other,
}

impl QpStatus {
    /// Accepted statuses: `Solved` and `AlmostSolved`.
    pub fn is_ok(self) -> bool {
        matches!(self, QpStatus::Solved | QpStatus::AlmostSolved)
    }

    fn from_clarabel(s: SolverStatus) -> Self {
        match s {
            SolverStatus::Solved => QpStatus::Solved,
            SolverStatus::AlmostSolved => QpStatus::AlmostSolved,
            SolverStatus::MaxIterations => QpStatus::MaxIterations,
            SolverStatus::MaxTime | SolverStatus::CallbackTerminated => QpStatus::MaxTime,
            SolverStatus::NumericalError | SolverStatus::InsufficientProgress => {
                QpStatus::NumericalError
            }
            SolverStatus::PrimalInfeasible
            | SolverStatus::DualInfeasible
            | SolverStatus::AlmostPrimalInfeasible
            | SolverStatus::AlmostDualInfeasible => QpStatus::Infeasible,
            _ => QpStatus::Other,
        }
    }
}

/// The condensed QP with its persistent Clarabel solver.
pub struct CondensedQp {
    horizon: usize,
    nu: usize,
    blocks: Vec<usize>,
    nv: usize,
    ns: usize,
    /// F: stacked free response of the outputs (N·ny × n_aug).
    f: DMatrix<f64>,
    /// Gb = G M (N·ny × nv).
    gb: DMatrix<f64>,
    /// 2 Gbᵀ Q̄ (nv × N·ny).
    q_map: DMatrix<f64>,
    /// −2 Eᵀ R̄ e₀ (nv × nu).
    q_uprev: DMatrix<f64>,
    /// −2 Mᵀ S̄ 1 u_target (nv).
    q_const: DVector<f64>,
    slack_linear: f64,
    p: CscMatrix<f64>,
    a: CscMatrix<f64>,
    b_const: Vec<f64>,
    /// Bound rows of the first block, which also carry its slew limit: (row of +, row of −, input,
    /// u_min, u_max, du_max).
    first_rows: Vec<(usize, usize, usize, f64, f64, f64)>,
    soft_rows: Vec<SoftRow>,
    q: Vec<f64>,
    b: Vec<f64>,
    c_buf: DVector<f64>,
    /// A cycle's scratch for q: the deviation `c − r` and the two products (no allocation per cycle).
    dev_buf: DVector<f64>,
    qdev_buf: DVector<f64>,
    qup_buf: DVector<f64>,
    solver: DefaultSolver<f64>,
    settings: DefaultSettings<f64>,
    /// Origin of [`Self::deadline_ns`].
    epoch: Instant,
    /// The current solve's deadline, ns after `epoch` (`u64::MAX`: none); read by the termination callback.
    deadline_ns: Arc<AtomicU64>,
}

impl std::fmt::Debug for CondensedQp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CondensedQp")
            .field("horizon", &self.horizon)
            .field("n_variables", &(self.nv + self.ns))
            .field("n_constraints", &self.b.len())
            .finish()
    }
}

/// Dense → CSC, dropping exact zeros (A and P never change, so the pattern is fixed); `upper` keeps only
/// the upper triangle (Clarabel's P convention).
fn dense_to_csc(m: &DMatrix<f64>, upper: bool) -> CscMatrix<f64> {
    let (nr, nc) = m.shape();
    let mut colptr = Vec::with_capacity(nc + 1);
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    colptr.push(0);
    for j in 0..nc {
        let last = if upper { (j + 1).min(nr) } else { nr };
        for i in 0..last {
            let v = m[(i, j)];
            if v != 0.0 {
                rowval.push(i);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(nr, nc, colptr, rowval, nzval)
}

/// Prediction matrices of the augmented model: F (N·ny × n) and G (N·ny × N·nu), outputs k = 1..N.
pub fn prediction_matrices(model: &AugmentedModel, horizon: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, nu, ny) = (model.n(), model.n_inputs(), model.n_outputs());
    let mut f = DMatrix::zeros(horizon * ny, n);
    let mut g = DMatrix::zeros(horizon * ny, horizon * nu);
    // markov[i] = C A^i B
    let mut ca_pow = model.c.clone(); // C A^0
    let mut markov = Vec::with_capacity(horizon);
    for k in 1..=horizon {
        markov.push(&ca_pow * &model.b); // C A^{k-1} B
        ca_pow = &ca_pow * &model.a; // C A^k
        f.view_mut(((k - 1) * ny, 0), (ny, n)).copy_from(&ca_pow);
    }
    for k in 1..=horizon {
        for j in 0..k {
            g.view_mut(((k - 1) * ny, j * nu), (ny, nu))
                .copy_from(&markov[k - 1 - j]);
        }
    }
    (f, g)
}

/// Prediction rows of the outputs between the cycles ([`crate::config::Intersample`]): for cycles
/// `k = 1..=cycles` and sub-steps `s = 1..substeps−1`, the output `s` sub-steps after cycle `k − 1`,
/// `C A_f^s ξ_{k−1} + C (Σ_{i<s} A_f^i B_f) u_{k−1}` with `ξ_{k−1} = A^{k−1} ξ + Σ_j A^{k−2−j} B u_j`.
/// `model` is the cycle's augmented model, `fine` the sub-step's in the same coordinates
/// ([`AugmentedModel::same_coordinates`]). Rows are cycle-major, then sub-step, then output:
/// F (cycles·(substeps−1)·ny × n) and G (… × N·nu).
pub fn intersample_matrices(
    model: &AugmentedModel,
    fine: &AugmentedModel,
    horizon: usize,
    substeps: usize,
    cycles: usize,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, nu, ny) = (model.n(), model.n_inputs(), model.n_outputs());
    let per = substeps.saturating_sub(1);
    let rows = cycles * per * ny;
    let mut f = DMatrix::zeros(rows, n);
    let mut g = DMatrix::zeros(rows, horizon * nu);
    // C A_f^s and C Σ_{i<s} A_f^i B_f for s = 1..substeps−1
    let (mut af, mut bf) = (DMatrix::<f64>::identity(n, n), DMatrix::<f64>::zeros(n, nu));
    let mut ca_f = Vec::with_capacity(per);
    let mut cb_f = Vec::with_capacity(per);
    for _ in 0..per {
        bf = &fine.a * &bf + &fine.b;
        af = &fine.a * &af;
        ca_f.push(&fine.c * &af);
        cb_f.push(&fine.c * &bf);
    }
    // A^i and A^i B of the cycle model
    let mut a_pow = vec![DMatrix::<f64>::identity(n, n)];
    for i in 1..cycles.max(1) {
        a_pow.push(&model.a * &a_pow[i - 1]);
    }
    let ab: Vec<DMatrix<f64>> = a_pow.iter().map(|a| a * &model.b).collect();
    for k in 1..=cycles {
        for s in 1..=per {
            let r = ((k - 1) * per + (s - 1)) * ny;
            let cas = &ca_f[s - 1];
            f.view_mut((r, 0), (ny, n))
                .copy_from(&(cas * &a_pow[k - 1]));
            for j in 0..k - 1 {
                g.view_mut((r, j * nu), (ny, nu))
                    .copy_from(&(cas * &ab[k - 2 - j]));
            }
            g.view_mut((r, (k - 1) * nu), (ny, nu))
                .copy_from(&cb_f[s - 1]);
        }
    }
    (f, g)
}

/// The Clarabel settings for a solver configuration (presolve and zero dropping off so q/b can be
/// updated; single-threaded QDLDL; quiet; no time limit — see the module docs).
pub fn clarabel_settings(cfg: &SolverConfig) -> DefaultSettings<f64> {
    DefaultSettingsBuilder::default()
        .verbose(false)
        .presolve_enable(false)
        .input_sparse_dropzeros(false)
        .max_iter(cfg.max_iter)
        .tol_gap_abs(cfg.tol_gap)
        .tol_gap_rel(cfg.tol_gap)
        .tol_feas(cfg.tol_feas)
        .direct_solve_method("qdldl".to_string())
        .iterative_refinement_enable(cfg.iterative_refinement)
        .equilibrate_enable(cfg.equilibrate)
        .max_threads(1)
        // unlimited: the deadline is the termination callback's (`keep_timer_tree` on what it would read)
        .time_limit(f64::INFINITY)
        .build()
        .expect("static Clarabel settings are valid")
}

impl CondensedQp {
    /// Build P, A, the constant parts of q and b, and the Clarabel solver (once). With
    /// `cfg.intersample`, `fine` is the sub-step's augmented model in `model`'s coordinates, and the
    /// outputs between the cycles are rows after the horizon's.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] for a configuration the model cannot take, or intersample outputs
    /// without the sub-step model; [`MpcError::SolverSetup`] when Clarabel refuses the data.
    pub fn new(
        model: &AugmentedModel,
        cfg: &MpcConfig,
        fine: Option<&AugmentedModel>,
    ) -> Result<Self, MpcError> {
        let (nu, ny) = (model.n_inputs(), model.n_outputs());
        cfg.validate(nu, ny)?;
        let horizon = cfg.horizon;
        let blocks = cfg.blocks();
        let nb = blocks.len();
        let nv = nb * nu;
        let (f, g) = prediction_matrices(model, horizon);
        // the outputs between the cycles, appended after the horizon's rows
        let (f, g, is_cycles, substeps) = match (cfg.intersample, fine) {
            (None, _) => (f, g, 0, 1),
            (Some(i), Some(fine)) => {
                let (fi, gi) = intersample_matrices(model, fine, horizon, i.substeps, i.cycles);
                let stack = |a: DMatrix<f64>, b: DMatrix<f64>| {
                    let mut m = DMatrix::zeros(a.nrows() + b.nrows(), a.ncols());
                    m.view_mut((0, 0), a.shape()).copy_from(&a);
                    m.view_mut((a.nrows(), 0), b.shape()).copy_from(&b);
                    m
                };
                (stack(f, fi), stack(g, gi), i.cycles, i.substeps)
            }
            (Some(_), None) => {
                return Err(crate::error::invalid(
                    "intersample",
                    "set without a model sampled at the sub-step",
                    "MpcController::new with the sub-step model",
                ));
            }
        };
        let n_rows = f.nrows();
        // block expansion M (N·nu × nv)
        let mut mexp = DMatrix::zeros(horizon * nu, nv);
        let mut k = 0;
        for (j, &len) in blocks.iter().enumerate() {
            for _ in 0..len {
                for i in 0..nu {
                    mexp[(k * nu + i, j * nu + i)] = 1.0;
                }
                k += 1;
            }
        }
        let gb = &g * &mexp;
        // Q per row; a cycle seen at its sub-steps too weighs Q / substeps at each of its samples
        let qdiag = DVector::from_iterator(
            n_rows,
            (0..n_rows).map(|r| {
                let w = cfg.weights.output[r % ny];
                if r >= horizon * ny || r / ny < is_cycles {
                    w / substeps as f64
                } else {
                    w
                }
            }),
        );
        let rw = &cfg.weights.input_rate;
        let sw: Vec<f64> = if cfg.weights.input.is_empty() {
            vec![0.0; nu]
        } else {
            cfg.weights.input.clone()
        };
        let ut: Vec<f64> = if cfg.weights.input_target.is_empty() {
            vec![0.0; nu]
        } else {
            cfg.weights.input_target.clone()
        };
        // E (block differencing) and R̄
        let mut e = DMatrix::<f64>::identity(nv, nv);
        for j in 1..nb {
            for i in 0..nu {
                e[(j * nu + i, (j - 1) * nu + i)] = -1.0;
            }
        }
        let rdiag = DVector::from_iterator(nv, (0..nv).map(|r| rw[r % nu]));
        // Mᵀ S̄ M = blkdiag(len_j S)
        let ms_diag =
            DVector::from_iterator(nv, (0..nv).map(|r| blocks[r / nu] as f64 * sw[r % nu]));
        let gq = gb.transpose() * DMatrix::from_diagonal(&qdiag); // Gbᵀ Q̄
        let hv = &gq * &gb
            + e.transpose() * DMatrix::from_diagonal(&rdiag) * &e
            + DMatrix::from_diagonal(&ms_diag);
        let q_map = &gq * 2.0;
        // −2 Eᵀ R̄ e₀ : e₀ selects the first block
        let mut e0 = DMatrix::zeros(nv, nu);
        for i in 0..nu {
            e0[(i, i)] = 1.0;
        }
        let q_uprev = -2.0 * e.transpose() * DMatrix::from_diagonal(&rdiag) * e0;
        let q_const = DVector::from_iterator(nv, (0..nv).map(|r| -2.0 * ms_diag[r] * ut[r % nu]));

        // soft-bounded outputs: one slack each
        let mut soft_outputs: Vec<SoftSpec> = Vec::new();
        for so in &cfg.soft_outputs {
            if so.min.is_some() || so.max.is_some() {
                // checked steps k = from_step, from_step + stride, … and N (0-based rows k−1)
                let first = so.from_step.clamp(1, horizon) - 1;
                let mut steps: Vec<usize> = (first..horizon).step_by(so.stride.max(1)).collect();
                if steps.last() != Some(&(horizon - 1)) {
                    steps.push(horizon - 1);
                }
                soft_outputs.push((so.output, so.min, so.max, steps, so.about_reference));
            }
        }
        let ns = soft_outputs.len();
        let nz = nv + ns;
        let mut pd = DMatrix::zeros(nz, nz);
        pd.view_mut((0, 0), (nv, nv)).copy_from(&(&hv * 2.0));
        for j in 0..ns {
            // a strictly positive diagonal keeps the pattern fixed even for ρ₂ = 0
            pd[(nv + j, nv + j)] = (2.0 * cfg.weights.slack_quadratic).max(1e-9);
        }
        // symmetrise numerically
        let pd = (&pd + pd.transpose()) * 0.5;

        // constraints
        let n_soft_rows: usize = soft_outputs
            .iter()
            .map(|(_, lo, hi, steps, _)| {
                steps.len() * (lo.is_some() as usize + hi.is_some() as usize)
            })
            .sum();
        let slew_blocks = match cfg.limits.slew_rows {
            SlewRows::EveryBlock => nb - 1,
            SlewRows::FirstBlock => 0,
        };
        let m = 2 * nv + 2 * slew_blocks * nu + n_soft_rows + ns;
        let mut ad = DMatrix::zeros(m, nz);
        let mut b_const = vec![0.0; m];
        let mut row = 0;
        let mut first_rows = Vec::new();
        for j in 0..nb {
            for i in 0..nu {
                let c = j * nu + i;
                ad[(row, c)] = 1.0;
                b_const[row] = cfg.limits.u_max[i];
                ad[(row + 1, c)] = -1.0;
                b_const[row + 1] = -cfg.limits.u_min[i];
                if j == 0 {
                    let l = &cfg.limits;
                    first_rows.push((row, row + 1, i, l.u_min[i], l.u_max[i], l.du_max[i]));
                }
                row += 2;
            }
        }
        for j in 1..=slew_blocks {
            for i in 0..nu {
                let c = j * nu + i;
                let du = cfg.limits.du_max[i];
                ad[(row, c)] = 1.0;
                ad[(row + 1, c)] = -1.0;
                ad[(row, c - nu)] = -1.0;
                ad[(row + 1, c - nu)] = 1.0;
                b_const[row] = du;
                b_const[row + 1] = du;
                row += 2;
            }
        }
        let mut soft_rows = Vec::new();
        for (sj, (o, lo, hi, steps, about_reference)) in soft_outputs.iter().enumerate() {
            let o = *o;
            for (bound, sign) in [(*hi, 1.0), (*lo, -1.0)] {
                let Some(bound) = bound else { continue };
                for &k in steps {
                    let y_row = k * ny + o;
                    for c in 0..nv {
                        ad[(row, c)] = sign * gb[(y_row, c)];
                    }
                    ad[(row, nv + sj)] = -1.0;
                    soft_rows.push(SoftRow {
                        row,
                        y_row,
                        sign,
                        bound,
                        about_reference: *about_reference,
                    });
                    row += 1;
                }
            }
        }
        for sj in 0..ns {
            ad[(row, nv + sj)] = -1.0;
            row += 1;
        }
        debug_assert_eq!(row, m);
        let p = dense_to_csc(&pd, true);
        let a = dense_to_csc(&ad, false);
        let mut q = vec![0.0; nz];
        for j in 0..ns {
            q[nv + j] = cfg.weights.slack_linear;
        }
        let b = b_const.clone();
        let cones: Vec<SupportedConeT<f64>> = vec![NonnegativeConeT(m)];
        let settings = clarabel_settings(&cfg.solver);
        let mut solver =
            DefaultSolver::new(&p, &q, &a, &b, &cones, settings.clone()).map_err(|e| {
                MpcError::SolverSetup {
                    what: "DefaultSolver::new",
                    source: Box::new(e),
                }
            })?;
        let epoch = Instant::now();
        let deadline_ns = Arc::new(AtomicU64::new(u64::MAX));
        let shared = Arc::clone(&deadline_ns);
        solver.set_termination_callback(move |_info: &DefaultInfo<f64>| {
            // no deadline: no clock read (a solve reads it once per iteration otherwise)
            let deadline = shared.load(Ordering::Relaxed);
            deadline != u64::MAX
                && epoch.elapsed().as_nanos().min(u64::MAX as u128) as u64 >= deadline
        });
        keep_timer_tree(&mut solver);
        if !solver.is_data_update_allowed() {
            return Err(MpcError::SolverSetup {
                what: "data updating",
                source: Box::new(DataUpdateError::PresolveIsActive),
            });
        }
        Ok(Self {
            horizon,
            nu,
            blocks,
            nv,
            ns,
            f,
            gb,
            q_map,
            q_uprev,
            q_const,
            slack_linear: cfg.weights.slack_linear,
            p,
            a,
            b_const,
            first_rows,
            soft_rows,
            q,
            b,
            c_buf: DVector::zeros(n_rows),
            dev_buf: DVector::zeros(n_rows),
            qdev_buf: DVector::zeros(nv),
            qup_buf: DVector::zeros(nv),
            solver,
            settings,
            epoch,
            deadline_ns,
        })
    }

    /// Number of decision variables (block inputs + slacks).
    pub fn n_variables(&self) -> usize {
        self.nv + self.ns
    }
    /// Number of constraint rows.
    pub fn n_constraints(&self) -> usize {
        self.b.len()
    }
    /// Horizon N.
    pub fn horizon(&self) -> usize {
        self.horizon
    }
    /// Move-block lengths.
    pub fn blocks(&self) -> &[usize] {
        &self.blocks
    }

    /// Rewrite q and b for the current augmented estimate `xa`, previous input `u_prev`, known output offsets
    /// `offsets` (w₁..w_N, N·ny, step-major, then the intersample rows' if configured) and reference
    /// `reference` (the same rows). Returns `false` if any of the resulting data is not finite (the caller
    /// must then fall back without solving).
    ///
    /// # Errors
    /// [`MpcError::DimensionMismatch`] for vectors of the wrong length.
    pub fn update(
        &mut self,
        xa: &DVector<f64>,
        u_prev: &[f64],
        offsets: &[f64],
        reference: &[f64],
    ) -> Result<bool, MpcError> {
        let nyn = self.c_buf.len();
        if offsets.len() != nyn || reference.len() != nyn {
            return Err(MpcError::DimensionMismatch {
                what: "preview window (offsets/reference: horizon × outputs, then the intersample rows)"
                    .into(),
                expected: nyn,
                found: if offsets.len() != nyn {
                    offsets.len()
                } else {
                    reference.len()
                },
            });
        }
        if u_prev.len() != self.nu || xa.len() != self.f.ncols() {
            return Err(MpcError::DimensionMismatch {
                what: "u_prev / state estimate".into(),
                expected: self.nu,
                found: u_prev.len(),
            });
        }
        // c = F ξ̂ + W  (free response of the outputs)
        self.c_buf.gemv(1.0, &self.f, xa, 0.0);
        for (ci, wi) in self.c_buf.iter_mut().zip(offsets) {
            *ci += wi;
        }
        // q_v = 2 GbᵀQ̄ (c − r) − 2EᵀR̄e₀ u_prev + q_const
        // (the products into the scratch: the same arithmetic as `a * x + b * u + q_const`)
        self.dev_buf.copy_from(&self.c_buf);
        for (di, ri) in self.dev_buf.iter_mut().zip(reference) {
            *di -= ri;
        }
        let up = nalgebra::DVectorView::from_slice(u_prev, u_prev.len());
        self.q_map.mul_to(&self.dev_buf, &mut self.qdev_buf);
        self.q_uprev.mul_to(&up, &mut self.qup_buf);
        for (((qi, a), b), c) in self.q[..self.nv]
            .iter_mut()
            .zip(self.qdev_buf.iter())
            .zip(self.qup_buf.iter())
            .zip(self.q_const.iter())
        {
            *qi = (a + b) + c;
        }
        for j in 0..self.ns {
            self.q[self.nv + j] = self.slack_linear;
        }
        self.b.copy_from_slice(&self.b_const);
        for &(rp, rm, i, lo, hi, du) in &self.first_rows {
            self.b[rp] = hi.min(u_prev[i] + du);
            self.b[rm] = -lo.max(u_prev[i] - du);
        }
        for sr in &self.soft_rows {
            let r = if sr.about_reference {
                reference[sr.y_row]
            } else {
                0.0
            };
            self.b[sr.row] = sr.sign * (sr.bound + r - self.c_buf[sr.y_row]);
        }
        let finite = self.q.iter().chain(self.b.iter()).all(|v| v.is_finite());
        if finite {
            self.solver
                .update_q(&self.q)
                .map_err(|e| MpcError::SolverSetup {
                    what: "update_q",
                    source: Box::new(e),
                })?;
            self.solver
                .update_b(&self.b)
                .map_err(|e| MpcError::SolverSetup {
                    what: "update_b",
                    source: Box::new(e),
                })?;
        }
        Ok(finite)
    }

    /// Solve with the current data; checks the status and the finiteness of the solution.
    pub fn solve(&mut self) -> QpStatus {
        self.solve_by(None)
    }

    /// Solve, stopping at `deadline` if given (Clarabel's termination callback, checked once per
    /// iteration: the solve ends at most one iteration after it, with [`QpStatus::MaxTime`]).
    pub fn solve_by(&mut self, deadline: Option<Instant>) -> QpStatus {
        let ns = deadline.map_or(u64::MAX, |d| {
            d.saturating_duration_since(self.epoch)
                .as_nanos()
                .min(u64::MAX as u128) as u64
        });
        self.deadline_ns.store(ns, Ordering::Relaxed);
        let t0 = Instant::now();
        self.solver.solve();
        crate::stats::add_qp_solve(t0.elapsed());
        let st = QpStatus::from_clarabel(self.solver.solution.status);
        if st.is_ok() && !self.solver.solution.x.iter().all(|v| v.is_finite()) {
            return QpStatus::NonFiniteSolution;
        }
        st
    }

    /// Interior-point iterations of the last solve.
    pub fn iterations(&self) -> u32 {
        self.solver.solution.iterations
    }

    /// Decision vector of the last solve (`[v; s]`).
    pub fn solution(&self) -> &[f64] {
        &self.solver.solution.x
    }

    /// Expand the block inputs of a decision vector into the per-step plan (N·nu, step-major).
    pub fn expand(&self, z: &[f64], plan: &mut Vec<f64>) {
        plan.clear();
        for (j, &len) in self.blocks.iter().enumerate() {
            for _ in 0..len {
                plan.extend_from_slice(&z[j * self.nu..(j + 1) * self.nu]);
            }
        }
    }

    /// Predicted outputs (N·ny, then the intersample rows if configured) for the decision `z` given the
    /// last [`Self::update`] data.
    pub fn predicted_outputs(&self, z: &[f64]) -> DVector<f64> {
        let v = DVector::from_column_slice(&z[..self.nv]);
        &self.c_buf + &self.gb * v
    }

    /// Temporarily change the iteration cap (fault injection: `Some(1)` makes the next solves stop at
    /// `MaxIterations`; `None` restores the configured value).
    pub fn set_max_iter_override(&mut self, max_iter: Option<u32>) -> Result<(), MpcError> {
        let mut s = self.settings.clone();
        if let Some(m) = max_iter {
            s.max_iter = m;
        }
        self.solver
            .update_settings(s)
            .map_err(|e| MpcError::SolverSetup {
                what: "update_settings",
                source: Box::new(e),
            })
    }

    /// The fixed problem data and the current vectors, for export/benchmarks.
    pub fn snapshot(&self) -> QpData {
        QpData {
            n: self.nv + self.ns,
            m: self.b.len(),
            p_colptr: self.p.colptr.clone(),
            p_rowval: self.p.rowval.clone(),
            p_nzval: self.p.nzval.clone(),
            a_colptr: self.a.colptr.clone(),
            a_rowval: self.a.rowval.clone(),
            a_nzval: self.a.nzval.clone(),
            nonneg_rows: self.b.len(),
            q: self.q.clone(),
            b: self.b.clone(),
        }
    }

    /// Current q (after the last update).
    pub fn q(&self) -> &[f64] {
        &self.q
    }
    /// Current b (after the last update).
    pub fn b(&self) -> &[f64] {
        &self.b
    }
}

/// A QP in Clarabel's form `min ½zᵀPz + qᵀz s.t. Az + s = b, s ∈ R₊^m` (P upper triangle, CSC).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QpData {
    /// Number of variables.
    pub n: usize,
    /// Number of constraint rows (all in the nonnegative cone).
    pub m: usize,
    /// P column pointers (upper triangle).
    pub p_colptr: Vec<usize>,
    /// P row indices.
    pub p_rowval: Vec<usize>,
    /// P values.
    pub p_nzval: Vec<f64>,
    /// A column pointers.
    pub a_colptr: Vec<usize>,
    /// A row indices.
    pub a_rowval: Vec<usize>,
    /// A values.
    pub a_nzval: Vec<f64>,
    /// Rows in the nonnegative cone (= m).
    pub nonneg_rows: usize,
    /// Linear cost.
    pub q: Vec<f64>,
    /// Right-hand side.
    pub b: Vec<f64>,
}

impl QpData {
    /// P as a CSC matrix.
    pub fn p_csc(&self) -> CscMatrix<f64> {
        CscMatrix::new(
            self.n,
            self.n,
            self.p_colptr.clone(),
            self.p_rowval.clone(),
            self.p_nzval.clone(),
        )
    }
    /// A as a CSC matrix.
    pub fn a_csc(&self) -> CscMatrix<f64> {
        CscMatrix::new(
            self.m,
            self.n,
            self.a_colptr.clone(),
            self.a_rowval.clone(),
            self.a_nzval.clone(),
        )
    }
}

/// Keep Clarabel's timer tree between solves, and build it now with one solve of the constant data (its
/// result is not used; every solve starts afresh from Clarabel's default start), so that no later solve
/// allocates.
///
/// Clarabel 0.11.1 times each solve under a root timer "solve" and resets it at the start of every solve
/// (`DefaultInfo::reset` → `Timers::reset_timer("solve")`); the reset clears the timer's map of sub-timers
/// (`InnerTimer::reset` → `subtimers.clear()`, clarabel `src/timers/timers.rs`), which frees the nested
/// maps ("IP iteration" → "kkt update", …) that the solve's first timed blocks then allocate again: one
/// allocation and one free per solve. A timer started here and never stopped makes every later "solve"
/// its child (`Timers::start_as_current` nests under the active timer): the reset then clears only an
/// empty root entry, and the nested timers are found again, not rebuilt. Their durations accumulate
/// instead of restarting, so `DefaultInfo::solve_time` no longer times one solve — millcomp does not use
/// it (a cycle's deadline is the termination callback's, its time [`crate::stats`]'s), and Clarabel's
/// `time_limit`, which reads it, is left unlimited (`clarabel_settings`). Clarabel's public API (`timers`
/// is a public field of [`DefaultSolver`], `Timers` a public type); runtime/tests/alloc.rs counts the
/// allocator calls and fails if a Clarabel release changes this.
fn keep_timer_tree(solver: &mut DefaultSolver<f64>) {
    if let Some(timers) = solver.timers.as_mut() {
        timers.start_as_current("millcomp: kept between solves");
    }
    solver.solve();
}
