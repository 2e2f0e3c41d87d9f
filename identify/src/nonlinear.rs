//! Bounded nonlinear least squares on argmin.
//!
//! # Model
//! A model is a residual operator `r(θ) = (f(θ) − y)·√w` implementing argmin's
//! [`Operator`] (θ ↦ r) and [`Jacobian`] (θ ↦ ∂r/∂θ) on `DVector<f64>` (see [`ResidualModel`]).
//!
//! # Solver
//! A Levenberg–Marquardt trust region run by argmin 0.11's [`Executor`] ([`TrustRegionLsq`], an
//! argmin [`Solver`]), the method of MINPACK's `lmder` (J. J. Moré, "The Levenberg–Marquardt
//! algorithm: implementation and theory", *Numerical Analysis*, LNM 630, 1978): each iteration
//! solves `min ‖r + J p‖` subject to `‖D p‖ ≤ Δ`, `D` the largest column norms of `J` seen so far,
//! exactly from the SVD of `J D⁻¹` — never from `JᵀJ`, whose condition number is the square of
//! `J`'s (argmin's own `TrustRegion` with the Steihaug-CG subproblem ran CG on `JᵀJ`, could not
//! move on Bennett5 or MGH09-like problems, and stopped only on its iteration limit). A step is
//! accepted when the actual reduction of `½‖r‖²` is more than 1e-4 of the predicted one. Both are
//! computed without cancellation: the predicted reduction term by term from the SVD, the actual one
//! as `½Σ(r − r₊)(r + r₊)` — so near the optimum their ratio is never 0/0.
//!
//! # When it is done
//! The status says how a fit ended ([`FitStatus`]):
//! * `converged` — one of the classical tests (MINPACK, `scipy.optimize.least_squares`):
//!   * `ftol`: actual and predicted reductions both below `ftol·cost` (and their ratio ≤ 2);
//!   * `xtol`: an accepted step below `xtol·‖D θ‖` (natural parameters, scaled);
//!   * `gtol`: the cosine between the residuals and the range of `J`, `‖Uᵀr‖/‖r‖`, below `gtol` —
//!     scale-free (it does not change with the units of data or parameters) and 0 exactly at a
//!     stationary point. The test is never asked to resolve a cosine the arithmetic cannot: the
//!     cosine's square is the share of the cost the Gauss–Newton step could still remove
//!     (`½‖Uᵀr‖² / ½‖r‖²`), and once that share is below the cost's rounding (`4ε`), no step can show
//!     a reduction — the point is the minimum as far as float64 can tell. So the threshold is
//!     `max(gtol, √(4ε) ≈ 3.0e-8)`: a tighter `gtol` would leave every fit to end on its iteration
//!     limit or stalled at rounding level, which is what 1 300-point fits did. The estimate then lies
//!     within `cosine·√(n − p)` standard errors of the exact minimum (≤ 1.1e-6 SE at 1 300 points);
//!   * at the residuals' resolution: a step was rejected while the model predicted a reduction below
//!     the cost's rounding (`4ε·cost`), or the trust radius shrank below `xtol·‖D θ‖` because no
//!     longer step reduced the cost (MINPACK's `info` 6 and 7, "no further reduction possible"), and
//!     the Gauss–Newton reduction left is below what the residuals' own rounding noise resolves
//!     (measured at that point by a second difference): the minimum as far as the arithmetic can tell,
//!     as on NIST's Lanczos and Misra problems;
//! * `stalled_at_rounding_level` — the same stop with a reduction left that the residuals could
//!   show: the steps fail for another reason. A wrong analytic Jacobian makes them fail;
//!   [`check_jacobian`](crate::check_jacobian) is the test for that;
//! * `not_converged` — the iteration limit was reached first (a report with a warning, not an error).
//!
//! Tested on the NIST StRD nonlinear regression suite (27 problems, both certified starts; see
//! `identify/tests/nist_strd.rs`).
//!
//! # Bounds and scaling
//! The solver works on internal, unbounded and roughly unit-scaled coordinates `z`, mapped to the
//! natural parameters by the MINUIT transforms (F. James, *MINUIT Reference Manual*, CERN D506,
//! §1.2.1 "Parameter limits"):
//! * free: `θ = θ₀ + s·z`, `s = |θ₀|` (1 when θ₀ = 0);
//! * lower bound only: `θ = lo + s(√(z²+1) − 1)`, `s = θ₀ − lo`;
//! * upper bound only: `θ = hi − s(√(z²+1) − 1)`, `s = hi − θ₀`;
//! * both: `θ = lo + (hi − lo)(sin z + 1)/2`.
//!
//! The minimum in `z` maps to the minimum in `θ` when it is interior. A parameter that ends on a
//! bound gets a warning (its linearised interval is not valid there). Uncertainty is always
//! computed from the Jacobian in the *natural* parameters at the estimate.

use argmin::core::{
    Error as ArgminError, Executor, IterState, Jacobian, KV, Operator, Problem, Solver, State,
    TerminationReason, TerminationStatus,
};
use argmin::kv;
use nalgebra::{DMatrix, DVector};

use crate::error::{IdentifyError, Result};
use crate::report::{FitReport, FitStatus, ReportInputs, build_report};

/// The `method` of a nonlinear fit's report.
const METHOD: &str = "argmin_trust_region_lm_svd";

/// A residual operator with its Jacobian, both in natural parameters.
///
/// `apply(θ)` returns the weighted residuals `(model − data)·√w`; `jacobian(θ)` their derivative
/// (n × p). Weights default to 1; a model with weights returns their square roots from
/// [`ResidualModel::sqrt_weights`] so that the report's RMS can be given in the data unit.
pub trait ResidualModel:
    Operator<Param = DVector<f64>, Output = DVector<f64>>
    + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>
{
    /// Square roots of the weights applied to the residuals (`None`: all 1).
    fn sqrt_weights(&self) -> Option<&[f64]> {
        None
    }
}

/// A parameter to estimate: name, starting value and (possibly infinite) bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Name (with unit, e.g. `tau_s`).
    pub name: String,
    /// Starting value, strictly inside the bounds.
    pub initial: f64,
    /// Lower bound (`-inf` for none).
    pub lower: f64,
    /// Upper bound (`+inf` for none).
    pub upper: f64,
}

impl ParamSpec {
    /// Unbounded parameter.
    pub fn free(name: &str, initial: f64) -> Self {
        ParamSpec {
            name: name.into(),
            initial,
            lower: f64::NEG_INFINITY,
            upper: f64::INFINITY,
        }
    }
    /// Parameter bounded below by 0 (time constants, frequencies, stiffnesses).
    pub fn positive(name: &str, initial: f64) -> Self {
        ParamSpec {
            lower: 0.0,
            ..Self::free(name, initial)
        }
    }
    /// Parameter in `[lower, upper]` (either may be infinite).
    pub fn bounded(name: &str, initial: f64, lower: f64, upper: f64) -> Self {
        ParamSpec {
            name: name.into(),
            initial,
            lower,
            upper,
        }
    }
}

/// Options of [`fit_nonlinear`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NlsOptions {
    /// Iteration limit (accepted and rejected trust-region steps; one residual evaluation each).
    pub max_iter: u64,
    /// Relative cost-reduction tolerance.
    pub ftol: f64,
    /// Relative step tolerance (scaled natural parameters, `‖D p‖ ≤ xtol·‖D θ‖`).
    pub xtol: f64,
    /// Gradient tolerance: the cosine between residuals and the range of the Jacobian.
    pub gtol: f64,
    /// Initial trust radius as a multiple of the scaled size of the starting point `‖D θ₀‖`
    /// (MINPACK's `factor`).
    pub initial_radius: f64,
}

impl Default for NlsOptions {
    /// Tight defaults: the fits here are small and cheap, and a cost-based stop (`ftol`) leaves a
    /// parameter error of order `√(ftol·n)·SE`; with `ftol = 1e-15` that is ≤ 1e-6 SE even for
    /// weakly identified parameters (e.g. a dead time), so the estimate is the minimum to well
    /// inside its uncertainty (and the scipy goldens agree to 1e-6 relative); on NIST's StRD
    /// suite it leaves ≥ 6.6 correct digits (ENSO: 1e-14 left 6.1, where a parameter is 0.4 SE
    /// from zero). Where rounding hides reductions of `ftol·cost` the fit ends stalled at rounding
    /// level instead. `xtol` at 1e-12 stops a fit as soon as steps vanish; `gtol` is the finest cosine
    /// the gradient test resolves, [`GTOL_FLOOR`] (a smaller one means the same).
    /// 3000 iterations: twice the most the suite needs (Bennett5 from NIST's far start, 1410).
    /// `initial_radius` 1: MINPACK's 100 sent BoxBOD's and MGH10's far starts onto plateaus.
    fn default() -> Self {
        NlsOptions {
            max_iter: 3000,
            ftol: 1e-15,
            xtol: 1e-12,
            gtol: GTOL_FLOOR,
            initial_radius: 1.0,
        }
    }
}

/// Result of a nonlinear fit.
#[derive(Debug, Clone)]
pub struct NonlinearFit {
    /// The report.
    pub report: FitReport,
    /// Estimates in parameter order.
    pub theta: DVector<f64>,
}

#[derive(Debug, Clone, Copy)]
enum Transform {
    Free { c: f64, s: f64 },
    Lower { lo: f64, s: f64 },
    Upper { hi: f64, s: f64 },
    Both { lo: f64, hi: f64 },
}

impl Transform {
    fn new(p: &ParamSpec) -> Result<(Self, f64)> {
        let (lo, hi, x0) = (p.lower, p.upper, p.initial);
        if lo.is_nan() || hi.is_nan() || lo >= hi || lo == f64::INFINITY || hi == f64::NEG_INFINITY
        {
            return Err(IdentifyError::BadBounds {
                name: p.name.clone(),
                lower: lo,
                upper: hi,
            });
        }
        if !x0.is_finite() || x0 <= lo || x0 >= hi {
            return Err(IdentifyError::InitialOutsideBounds {
                name: p.name.clone(),
                value: x0,
                lower: lo,
                upper: hi,
            });
        }
        Ok(match (lo.is_finite(), hi.is_finite()) {
            (false, false) => {
                let s = if x0 != 0.0 { x0.abs() } else { 1.0 };
                (Transform::Free { c: x0, s }, 0.0)
            }
            (true, false) => (Transform::Lower { lo, s: x0 - lo }, 3f64.sqrt()),
            (false, true) => (Transform::Upper { hi, s: hi - x0 }, 3f64.sqrt()),
            (true, true) => {
                let z0 = (2.0 * (x0 - lo) / (hi - lo) - 1.0).clamp(-1.0, 1.0).asin();
                (Transform::Both { lo, hi }, z0)
            }
        })
    }

    fn theta(&self, z: f64) -> f64 {
        match *self {
            Transform::Free { c, s } => c + s * z,
            Transform::Lower { lo, s } => lo + s * ((z * z + 1.0).sqrt() - 1.0),
            Transform::Upper { hi, s } => hi - s * ((z * z + 1.0).sqrt() - 1.0),
            Transform::Both { lo, hi } => lo + (hi - lo) * (z.sin() + 1.0) / 2.0,
        }
    }

    fn dtheta(&self, z: f64) -> f64 {
        match *self {
            Transform::Free { s, .. } => s,
            Transform::Lower { s, .. } => s * z / (z * z + 1.0).sqrt(),
            Transform::Upper { s, .. } => -s * z / (z * z + 1.0).sqrt(),
            Transform::Both { lo, hi } => (hi - lo) * z.cos() / 2.0,
        }
    }

    /// `Some("lower"/"upper")` when θ sits on a bound (within 1e-7 of its scale).
    fn at_bound(&self, theta: f64) -> Option<&'static str> {
        match *self {
            Transform::Free { .. } => None,
            Transform::Lower { lo, s } => ((theta - lo) <= 1e-7 * s).then_some("lower"),
            Transform::Upper { hi, s } => ((hi - theta) <= 1e-7 * s).then_some("upper"),
            Transform::Both { lo, hi } => {
                if theta - lo <= 1e-7 * (hi - lo) {
                    Some("lower")
                } else if hi - theta <= 1e-7 * (hi - lo) {
                    Some("upper")
                } else {
                    None
                }
            }
        }
    }
}

/// The least-squares problem in internal coordinates `z`: the model, the parameter transforms and
/// a one-point cache of residuals and Jacobian (a rejected step re-uses the current point's).
pub struct LsqProblem<M> {
    model: M,
    tf: Vec<Transform>,
}

impl<M: ResidualModel> LsqProblem<M> {
    fn theta(&self, z: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            z.len(),
            self.tf.iter().zip(z.iter()).map(|(t, &z)| t.theta(z)),
        )
    }

    /// Residuals at `z`, `None` when the model fails or returns a non-finite value (the trust
    /// region then treats the point as infinitely bad and shrinks).
    fn residuals(&self, z: &DVector<f64>) -> Option<DVector<f64>> {
        let r = self.model.apply(&self.theta(z)).ok()?;
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    /// The Jacobian in internal coordinates, `J_z = J_θ · diag(dθ/dz)`.
    fn jacobian_z(&self, z: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let mut j = self.model.jacobian(&self.theta(z))?;
        for (k, t) in self.tf.iter().enumerate() {
            let d = t.dtheta(z[k]);
            j.column_mut(k).scale_mut(d);
        }
        if j.iter().any(|v| !v.is_finite()) {
            return Err(ArgminError::msg(
                "the model's Jacobian is not finite at an accepted point",
            ));
        }
        Ok(j)
    }

    /// The share of the cost a change can be resolved at, set by the rounding noise of the residuals'
    /// evaluation at `z` (`r` there): the residuals at `z ± δ`, `δ` a few units in the last place of
    /// each coordinate, have the same first-order change with opposite signs, so the second
    /// difference `r(z+δ) + r(z−δ) − 2r(z)` is their noise (standard deviation √6 σ per residual);
    /// a reduction is then known to `±2‖σ‖‖r‖`, i.e. `4‖σ‖/‖r‖` of the cost. 0 when the residuals
    /// cannot be evaluated there.
    fn evaluation_floor(&self, z: &DVector<f64>, r: &DVector<f64>) -> f64 {
        let delta = z.map(|v| 16.0 * f64::EPSILON * v.abs().max(1.0));
        let (Some(up), Some(down)) = (self.residuals(&(z + &delta)), self.residuals(&(z - &delta)))
        else {
            return 0.0;
        };
        let noise = (up + down - r * 2.0).norm() / 6f64.sqrt();
        let rn = r.norm();
        if rn > 0.0 { 4.0 * noise / rn } else { 0.0 }
    }

    /// `|θ_k| / |dθ_k/dz|`: the size of parameter k in internal units (the `‖D x‖` of MINPACK's
    /// relative step test is taken in natural parameters).
    fn natural_size(&self, z: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            z.len(),
            self.tf.iter().zip(z.iter()).map(|(t, &zk)| {
                let d = t.dtheta(zk).abs();
                if d > 0.0 {
                    t.theta(zk).abs() / d
                } else {
                    zk.abs()
                }
            }),
        )
    }
}

/// The factorised linear model at the current point: `J_z D⁻¹ = U Σ Vᵀ`, `c = Uᵀ r`.
struct Linearised {
    z: DVector<f64>,
    r: DVector<f64>,
    cost: f64,
    sv: DVector<f64>,
    v: DMatrix<f64>,
    c: DVector<f64>,
}

type LsqState = IterState<DVector<f64>, (), (), (), (), f64>;

/// `4ε`: a predicted reduction at most this fraction of the cost is below the cost's rounding.
const ROUNDING: f64 = 4.0 * f64::EPSILON;

/// `√(4ε)` ≈ 2.98e-8: the smallest cosine the gradient test can resolve — a cosine below it promises a
/// reduction below the cost's rounding (`4ε` of the cost).
pub const GTOL_FLOOR: f64 = 2.9802322387695312e-8;

/// A Levenberg–Marquardt trust-region solver for argmin (see the module docs): the step solves
/// `min ‖r + J_z p‖` subject to `‖D p‖ ≤ Δ` exactly from the SVD of the scaled Jacobian.
pub struct TrustRegionLsq {
    ftol: f64,
    xtol: f64,
    gtol: f64,
    factor: f64,
    radius: f64,
    diag: Option<DVector<f64>>,
    lin: Option<Linearised>,
    outcome: Option<(FitStatus, String)>,
}

impl TrustRegionLsq {
    fn new(opts: &NlsOptions) -> Self {
        TrustRegionLsq {
            ftol: opts.ftol,
            xtol: opts.xtol,
            gtol: opts.gtol,
            factor: opts.initial_radius,
            radius: f64::NAN,
            diag: None,
            lin: None,
            outcome: None,
        }
    }

    /// Factorises the model at `z` (or re-uses the factorisation when `z` is the current point).
    fn linearise<M: ResidualModel>(
        &mut self,
        problem: &mut Problem<LsqProblem<M>>,
        z: &DVector<f64>,
        r: DVector<f64>,
    ) -> std::result::Result<(), ArgminError> {
        let j = problem.problem("jacobian_count", |p| p.jacobian_z(z))?;
        // MINPACK's scaling: D_k = the largest column norm seen so far (1 for a zero column).
        let norms = DVector::from_iterator(j.ncols(), j.column_iter().map(|c| c.norm()));
        let diag = match self.diag.take() {
            Some(d) => d.zip_map(&norms, f64::max),
            None => norms.map(|v| if v > 0.0 { v } else { 1.0 }),
        };
        let mut js = j;
        for (k, d) in diag.iter().enumerate() {
            js.column_mut(k).scale_mut(1.0 / d);
        }
        let svd = js.svd(true, true);
        let (u, vt) = match (svd.u, svd.v_t) {
            (Some(u), Some(vt)) => (u, vt),
            _ => return Err(ArgminError::msg("SVD without singular vectors")),
        };
        let c = u.tr_mul(&r);
        let cost = 0.5 * r.norm_squared();
        if !self.radius.is_finite() {
            let size = problem.problem("size", |p| Ok(p.natural_size(z)))?;
            let xnorm = size.component_mul(&diag).norm();
            self.radius = if xnorm > 0.0 {
                self.factor * xnorm
            } else {
                self.factor
            };
        }
        self.diag = Some(diag);
        self.lin = Some(Linearised {
            z: z.clone(),
            r,
            cost,
            sv: svd.singular_values,
            v: vt.transpose(),
            c,
        });
        Ok(())
    }
}

/// The scaled step `q = D p` of `min ‖r + J p‖, ‖D p‖ ≤ Δ`, its Levenberg–Marquardt parameter λ and
/// the predicted reduction of ½‖r‖², from the SVD of `J D⁻¹`:
/// `q(λ) = −Σ_k v_k σ_k c_k / (σ_k² + λ)`, λ = 0 when the Gauss–Newton step fits in the region,
/// otherwise the λ with `‖q(λ)‖ = Δ` (Moré's Newton iteration on `1/Δ − 1/‖q(λ)‖`, safeguarded
/// by bisection). The predicted reduction `½ Σ c_k² σ_k²(σ_k² + 2λ)/(σ_k² + λ)²` is summed
/// term by term, so it is never the difference of two nearly equal costs.
fn lm_step(
    sv: &DVector<f64>,
    v: &DMatrix<f64>,
    c: &DVector<f64>,
    radius: f64,
) -> (DVector<f64>, f64, f64) {
    let smax = sv.iter().cloned().fold(0.0, f64::max);
    let cut = f64::EPSILON * (v.nrows().max(c.len()) as f64) * smax;
    let coef = |lambda: f64| -> Vec<f64> {
        (0..sv.len())
            .map(|k| {
                let s = sv[k];
                if lambda == 0.0 {
                    if s > cut { c[k] / s } else { 0.0 }
                } else {
                    s * c[k] / (s * s + lambda)
                }
            })
            .collect()
    };
    let norm = |w: &[f64]| w.iter().map(|x| x * x).sum::<f64>().sqrt();
    let pred = |lambda: f64| -> f64 {
        0.5 * (0..sv.len())
            .map(|k| {
                let s2 = sv[k] * sv[k];
                if lambda == 0.0 {
                    if sv[k] > cut { c[k] * c[k] } else { 0.0 }
                } else {
                    c[k] * c[k] * s2 * (s2 + 2.0 * lambda) / ((s2 + lambda) * (s2 + lambda))
                }
            })
            .sum::<f64>()
    };
    let step = |w: &[f64]| -> DVector<f64> {
        let mut q = DVector::zeros(v.nrows());
        for (k, wk) in w.iter().enumerate() {
            q.axpy(-wk, &v.column(k), 1.0);
        }
        q
    };
    let w0 = coef(0.0);
    if norm(&w0) <= radius {
        return (step(&w0), 0.0, pred(0.0));
    }
    // ‖q(λ)‖ decreases from ‖q(0)‖ > Δ to 0; bracket: ‖q(hi)‖ ≤ ‖Jᵀr‖/hi ≤ Δ.
    let gnorm = (0..sv.len())
        .map(|k| (sv[k] * c[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let (mut lo, mut hi) = (0.0, gnorm / radius);
    let mut lambda = 0.0;
    for _ in 0..60 {
        if !(lambda > lo && lambda < hi) {
            lambda = if lo > 0.0 {
                (lo * hi).sqrt().max(0.5 * (lo + hi) * 1e-3)
            } else {
                1e-3 * hi
            };
        }
        let w = coef(lambda);
        let qn = norm(&w);
        if (qn - radius).abs() <= 1e-3 * radius {
            break;
        }
        if qn > radius {
            lo = lambda;
        } else {
            hi = lambda;
        }
        // Newton on ψ(λ) = 1/Δ − 1/‖q(λ)‖: ψ' = −Σ σ²c²/(σ²+λ)³ / ‖q‖³.
        let dq2 = (0..sv.len())
            .map(|k| {
                let s2 = sv[k] * sv[k];
                s2 * c[k] * c[k] / (s2 + lambda).powi(3)
            })
            .sum::<f64>();
        if dq2 > 0.0 {
            lambda -= (1.0 / radius - 1.0 / qn) * qn.powi(3) / (-dq2);
        }
        if hi - lo <= 1e-15 * hi {
            break;
        }
    }
    let w = coef(lambda);
    (step(&w), lambda, pred(lambda))
}

impl<M: ResidualModel> Solver<LsqProblem<M>, LsqState> for TrustRegionLsq {
    fn name(&self) -> &str {
        "Levenberg–Marquardt trust region (SVD subproblem) with least-squares convergence tests"
    }

    fn init(
        &mut self,
        problem: &mut Problem<LsqProblem<M>>,
        mut state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let z = state
            .take_param()
            .ok_or_else(|| ArgminError::msg("no starting point"))?;
        let r = problem
            .problem("cost_count", |p| Ok(p.residuals(&z)))?
            .ok_or_else(|| ArgminError::msg("model not finite at the starting point"))?;
        self.linearise(problem, &z, r)?;
        let cost = self.lin.as_ref().map_or(f64::NAN, |l| l.cost);
        Ok((state.param(z).cost(cost), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<LsqProblem<M>>,
        mut state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let z = state
            .take_param()
            .ok_or_else(|| ArgminError::msg("no parameter in state"))?;
        let lin = self
            .lin
            .as_ref()
            .filter(|l| l.z == z)
            .ok_or_else(|| ArgminError::msg("linearisation lost"))?;
        let cost = lin.cost;
        if cost == 0.0 {
            self.outcome = Some((FitStatus::Converged, "zero residual".into()));
            return Ok((state.param(z).cost(cost), None));
        }
        // Scale-free gradient test: the cosine between r and the range of J (MINPACK's gtol uses
        // the cosine with each column; this one is also invariant to reparametrisation), at no less
        // than its resolution: cos² is the share of the cost a Gauss–Newton step could remove, which
        // the cost cannot show below its rounding (module docs).
        let cosine = lin.c.norm() / lin.r.norm();
        if cosine <= self.gtol.max(GTOL_FLOOR) {
            let why = if self.gtol >= GTOL_FLOOR {
                format!("gtol {:.1e}", self.gtol)
            } else {
                format!(
                    "gtol at its resolution {GTOL_FLOOR:.1e} (the reduction left, {:.1e} of the cost, \
                     is below the cost's rounding)",
                    cosine * cosine
                )
            };
            self.outcome = Some((
                FitStatus::Converged,
                format!("{why}: residuals orthogonal to the Jacobian (cosine {cosine:.1e})"),
            ));
            return Ok((state.param(z).cost(cost), None));
        }
        let diag = self
            .diag
            .clone()
            .unwrap_or_else(|| DVector::from_element(z.len(), 1.0));
        let (q, lambda, pred) = lm_step(&lin.sv, &lin.v, &lin.c, self.radius);
        let p = q.component_div(&diag);
        let qn = q.norm();
        let z_new = &z + &p;
        let r_new = problem.problem("cost_count", |pr| Ok(pr.residuals(&z_new)))?;
        // Actual reduction ½(‖r‖² − ‖r₊‖²) = ½ Σ (r − r₊)(r + r₊): no difference of two costs.
        let actual = match &r_new {
            Some(rn) => {
                0.5 * lin
                    .r
                    .iter()
                    .zip(rn.iter())
                    .map(|(a, b)| (a - b) * (a + b))
                    .sum::<f64>()
            }
            None => f64::NEG_INFINITY,
        };
        // pred > 0 here (c ≠ 0 because the cosine test failed); a zero one would be at rounding.
        let rho = if pred > 0.0 { actual / pred } else { 0.0 };
        let cur_radius = self.radius;
        if rho < 0.25 {
            self.radius = 0.25 * qn.min(self.radius);
        } else if rho > 0.75 || lambda == 0.0 {
            self.radius = self.radius.max(2.0 * qn);
        }
        let size = problem.problem("size", |pr| Ok(pr.natural_size(&z)))?;
        let xnorm = size.component_mul(&diag).norm();
        let kv = kv!("radius" => cur_radius; "lambda" => lambda; "rho" => rho;);
        let accepted = rho > 1e-4;
        // MINPACK's tests, in its order: ftol holds whether or not the step is taken (the model
        // and the function agree that less than ftol·cost is left to gain); xtol needs a step.
        if actual.abs() <= self.ftol * cost && pred <= self.ftol * cost && rho <= 2.0 {
            self.outcome = Some((
                FitStatus::Converged,
                format!(
                    "ftol {:e}: actual and predicted relative reductions below tolerance",
                    self.ftol
                ),
            ));
        } else if accepted && qn <= self.xtol * (self.xtol + xnorm) {
            self.outcome = Some((
                FitStatus::Converged,
                format!("xtol {:e}: relative step below tolerance", self.xtol),
            ));
        } else if !accepted
            && (pred <= ROUNDING * cost || self.radius <= self.xtol * (self.xtol + xnorm))
        {
            // MINPACK's "no further reduction possible" (lmder info 6 and 7): the model predicts a
            // reduction below the cost's rounding, or no step longer than the parameters'
            // xtol-scale reduces the cost. At the minimum, as far as the residuals' own rounding can
            // tell, that is convergence: the Gauss–Newton reduction left (cos²) is below the
            // reduction the residuals resolve (their evaluation noise, measured here). Otherwise the
            // steps fail for another reason (a wrong Jacobian): stalled.
            let cos2 = (lin.c.norm() / lin.r.norm()).powi(2);
            let resolved = problem.problem("cost_count", |p| Ok(p.evaluation_floor(&z, &lin.r)))?;
            self.outcome = Some(if cos2 <= resolved.max(ROUNDING) {
                (
                    FitStatus::Converged,
                    format!(
                        "at the residuals' resolution: the reduction left ({cos2:.1e} of the cost) is \
                         below what their rounding resolves ({:.1e})",
                        resolved.max(ROUNDING)
                    ),
                )
            } else if pred <= ROUNDING * cost {
                (
                    FitStatus::StalledAtRoundingLevel,
                    format!(
                        "the predicted reduction ({:.1e} of the cost) is at rounding level, though \
                         {cos2:.1e} of it is left",
                        pred / cost
                    ),
                )
            } else {
                (
                    FitStatus::StalledAtRoundingLevel,
                    format!(
                        "no step longer than xtol {:e} of the parameters reduces the cost: \
                         the cost is flat to rounding here",
                        self.xtol
                    ),
                )
            });
        }
        if accepted {
            let rn = r_new.unwrap_or_else(|| lin.r.clone());
            let cost_new = 0.5 * rn.norm_squared();
            self.linearise(problem, &z_new, rn)?;
            return Ok((state.param(z_new).cost(cost_new), Some(kv)));
        }
        Ok((state.param(z).cost(cost), Some(kv)))
    }

    fn terminate(&mut self, _state: &LsqState) -> TerminationStatus {
        if self.outcome.is_some() {
            TerminationStatus::Terminated(TerminationReason::SolverConverged)
        } else {
            TerminationStatus::NotTerminated
        }
    }
}

/// Fits `model` by bounded nonlinear least squares (see the module docs for the method).
///
/// `kind` names the model in the report; `unit` is the data unit of the residuals (the
/// `rms_residual_<unit>` key). Non-convergence is not an error: it is a report with status
/// `not_converged` and a warning. For a plain curve `y ≈ f(x, θ)`, [`CurveFit`](crate::CurveFit)
/// builds the model from closures.
///
/// # Errors
/// * [`IdentifyError::BadBounds`] for a parameter whose bounds are NaN, not `lower < upper`, or
///   `lower = +∞` / `upper = −∞`;
/// * [`IdentifyError::InitialOutsideBounds`] for a starting value that is not finite or not
///   strictly inside its bounds;
/// * [`IdentifyError::InvalidParameter`] for an option out of range: `ftol`, `xtol`,
///   `initial_radius` not a finite positive number, `gtol` negative or not finite;
/// * [`IdentifyError::ModelEvaluation`] when the model fails at the starting point, or its
///   residuals or Jacobian fail at the estimate (the model's error is the source);
/// * [`IdentifyError::NonFiniteResidual`] when a residual is NaN or infinite at the starting point;
/// * [`IdentifyError::TooFewPoints`] unless there are more residuals than parameters;
/// * [`IdentifyError::Solver`] / [`IdentifyError::SolverState`] when argmin fails internally or
///   ends without a parameter vector.
///
/// # Examples
/// ```
/// use argmin::core::{Error, Jacobian, Operator};
/// use millcomp_identify::{fit_nonlinear, NlsOptions, ParamSpec, ResidualModel};
/// use nalgebra::{DMatrix, DVector};
/// // y = a·exp(−b t) sampled without noise except a tiny alternating term.
/// struct Decay { t: Vec<f64>, y: Vec<f64> }
/// impl Operator for Decay {
///     type Param = DVector<f64>; type Output = DVector<f64>;
///     fn apply(&self, p: &DVector<f64>) -> Result<DVector<f64>, Error> {
///         Ok(DVector::from_iterator(self.t.len(), self.t.iter().zip(&self.y).map(|(t, y)| p[0] * (-p[1] * t).exp() - y)))
///     }
/// }
/// impl Jacobian for Decay {
///     type Param = DVector<f64>; type Jacobian = DMatrix<f64>;
///     fn jacobian(&self, p: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
///         Ok(DMatrix::from_fn(self.t.len(), 2, |i, j| {
///             let e = (-p[1] * self.t[i]).exp();
///             if j == 0 { e } else { -p[0] * self.t[i] * e }
///         }))
///     }
/// }
/// impl ResidualModel for Decay {}
/// let t: Vec<f64> = (0..30).map(|i| i as f64 * 0.1).collect();
/// let y: Vec<f64> = t.iter().enumerate().map(|(i, t)| 5.0 * (-1.5 * t).exp() + if i % 2 == 0 { 1e-4 } else { -1e-4 }).collect();
/// let fit = fit_nonlinear(Decay { t: t.clone(), y: y.clone() }, &[ParamSpec::positive("a", 1.0), ParamSpec::positive("b", 0.5)],
///                         &NlsOptions::default(), "decay", "um").unwrap();
/// assert_eq!(fit.report.status, millcomp_identify::FitStatus::Converged);
/// assert!((fit.report.param("b") - 1.5).abs() < 1e-3);
/// // the ±1e-4 perturbation leaves a residual RMS of 1.0e-4 and moves a, b by less than 3e-5;
/// // the standard errors (≈ 7e-5, 3e-5) cover that
/// assert!((fit.report.rms_residual.value - 1.0e-4).abs() < 1e-6);
/// assert!((fit.report.param("a") - 5.0).abs() < 3e-5 && (fit.report.param("b") - 1.5).abs() < 1e-5);
/// assert!((fit.report.param("a") - 5.0).abs() < 2.0 * fit.report.se("a"));
/// // a start on the bound (b ≥ 0) is refused before anything is evaluated
/// let e = fit_nonlinear(Decay { t, y }, &[ParamSpec::positive("a", 1.0), ParamSpec::positive("b", 0.0)],
///                       &NlsOptions::default(), "decay", "um").unwrap_err();
/// assert!(matches!(e, millcomp_identify::IdentifyError::InitialOutsideBounds { .. }));
/// ```
pub fn fit_nonlinear<M: ResidualModel>(
    model: M,
    specs: &[ParamSpec],
    opts: &NlsOptions,
    kind: &str,
    unit: &str,
) -> Result<NonlinearFit> {
    let mut tf = Vec::with_capacity(specs.len());
    let mut z0 = Vec::with_capacity(specs.len());
    for s in specs {
        let (t, z) = Transform::new(s)?;
        tf.push(t);
        z0.push(z);
    }
    for (name, v, allowed) in [
        ("ftol", opts.ftol, "> 0"),
        ("xtol", opts.xtol, "> 0"),
        ("gtol", opts.gtol, ">= 0"),
        ("initial_radius", opts.initial_radius, "> 0"),
    ] {
        if v.is_nan() || v < 0.0 || (v == 0.0 && name != "gtol") || !v.is_finite() {
            return Err(IdentifyError::InvalidParameter {
                name: name.into(),
                value: v,
                allowed,
            });
        }
    }
    let names: Vec<String> = specs.iter().map(|s| s.name.clone()).collect();
    let theta0 = DVector::from_iterator(specs.len(), specs.iter().map(|s| s.initial));
    let r0 = model
        .apply(&theta0)
        .map_err(|source| IdentifyError::ModelEvaluation {
            model: kind.into(),
            what: "residuals at the starting point".into(),
            source,
        })?;
    if let Some(index) = r0.iter().position(|v| !v.is_finite()) {
        return Err(IdentifyError::NonFiniteResidual {
            model: kind.into(),
            index,
        });
    }
    crate::validate::enough_points(r0.len(), specs.len(), kind)?;

    let problem = LsqProblem {
        model,
        tf: tf.clone(),
    };
    let solver = TrustRegionLsq::new(opts);
    let z0 = DVector::from_vec(z0);
    let res = Executor::new(problem, solver)
        .configure(|s| s.param(z0).max_iters(opts.max_iter))
        .run()
        .map_err(|source| IdentifyError::Solver { source })?;
    let iterations = res.state.get_iter();
    let zhat = res
        .state
        .get_best_param()
        .cloned()
        .ok_or(IdentifyError::SolverState {
            what: "no parameter in final state",
        })?;
    let (status, message) = match &res.solver.outcome {
        Some((status, m)) => (*status, m.clone()),
        None => (
            FitStatus::NotConverged,
            format!("no tolerance met within {} iterations", opts.max_iter),
        ),
    };
    let model = res
        .problem
        .get_problem()
        .ok_or(IdentifyError::SolverState {
            what: "problem lost by the executor",
        })?
        .model;
    let theta = DVector::from_iterator(
        zhat.len(),
        tf.iter().zip(zhat.iter()).map(|(t, &z)| t.theta(z)),
    );
    let eval = |what: &str, source: ArgminError| IdentifyError::ModelEvaluation {
        model: kind.into(),
        what: format!("{what} at the estimate"),
        source,
    };
    let resid_w = model.apply(&theta).map_err(|e| eval("residuals", e))?;
    let jac = model.jacobian(&theta).map_err(|e| eval("jacobian", e))?;
    let resid_raw = match model.sqrt_weights() {
        Some(sw) => DVector::from_iterator(
            resid_w.len(),
            resid_w
                .iter()
                .zip(sw)
                .map(|(r, s)| if *s > 0.0 { r / s } else { 0.0 }),
        ),
        None => resid_w.clone(),
    };
    let mut warnings = Vec::new();
    if status == FitStatus::NotConverged {
        warnings.push(format!(
            "did not converge in {} iterations: estimates and intervals are provisional",
            opts.max_iter
        ));
    }
    for (k, t) in tf.iter().enumerate() {
        if let Some(side) = t.at_bound(theta[k]) {
            warnings.push(format!(
                "parameter {} = {:.6e} is at its {side} bound [{}, {}]: its interval is not reliable",
                names[k], theta[k], specs[k].lower, specs[k].upper
            ));
        }
    }
    let report = build_report(ReportInputs {
        model: kind,
        method: METHOD,
        names: &names,
        theta: &theta,
        jac: &jac,
        resid_w: &resid_w,
        resid_raw: &resid_raw,
        unit,
        status,
        message,
        iterations,
        extra_warnings: warnings,
    });
    Ok(NonlinearFit { report, theta })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn transforms_round_trip_and_derivative() {
        let specs = [
            ParamSpec::free("a", -2.0),
            ParamSpec::positive("b", 3.0),
            ParamSpec::bounded("c", -1.0, f64::NEG_INFINITY, 4.0),
            ParamSpec::bounded("d", 0.3, 0.0, 1.0),
        ];
        for s in &specs {
            let (t, z0) = Transform::new(s).unwrap();
            assert_relative_eq!(t.theta(z0), s.initial, epsilon = 1e-12);
            for z in [z0 - 0.7, z0, z0 + 0.4] {
                let h = 1e-6;
                let fd = (t.theta(z + h) - t.theta(z - h)) / (2.0 * h);
                assert_relative_eq!(t.dtheta(z), fd, epsilon = 1e-7, max_relative = 1e-7);
            }
        }
    }

    #[test]
    fn the_gradient_floor_is_the_root_of_the_cost_rounding() {
        assert_eq!(GTOL_FLOOR, ROUNDING.sqrt());
    }

    #[test]
    fn bad_bounds_and_start() {
        let e = Transform::new(&ParamSpec::bounded("x", 1.0, 2.0, 1.0)).unwrap_err();
        assert!(matches!(e, IdentifyError::BadBounds { .. }));
        let e = Transform::new(&ParamSpec::positive("tau_s", 0.0)).unwrap_err();
        assert!(matches!(e, IdentifyError::InitialOutsideBounds { .. }));
        let e = Transform::new(&ParamSpec::free("x", f64::NAN)).unwrap_err();
        assert!(matches!(e, IdentifyError::InitialOutsideBounds { .. }));
    }
}
