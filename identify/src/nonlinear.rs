//! Bounded nonlinear least squares on argmin.
//!
//! # Model
//! A model is a residual operator `r(θ) = (f(θ) − y)·√w` implementing argmin's
//! [`Operator`] (θ ↦ r) and [`Jacobian`] (θ ↦ ∂r/∂θ) on `DVector<f64>` (see [`ResidualModel`]).
//!
//! # Solver
//! argmin 0.11's [`TrustRegion`] with the [`Steihaug`] (truncated conjugate gradient) subproblem,
//! fed the Gauss–Newton model of `½‖r‖²`: gradient `Jᵀr`, Hessian `JᵀJ`. (argmin 0.11's `Dogleg`
//! subproblem is not used: when the Cauchy point lies outside the trust region it returns steps
//! longer than the radius — e.g. ‖p‖ = 0.18 for radius 0.05 with g = (1, 0.2),
//! H = diag(1, 100) — and the trust region can then cycle forever on a rejected step whose
//! length is four times the radius. Steihaug–Toint CG respects the radius, needs no inverse of
//! `JᵀJ` and so also copes with a singular one.) argmin's trust-region loop has no
//! convergence test of its own (it stops only on `max_iters` or a target cost), so a thin wrapper
//! solver ([`TrustRegionLsq`]) delegates every iteration to it and adds the three classical
//! least-squares tests, as in MINPACK / `scipy.optimize.least_squares`:
//! * `ftol`: an accepted step reduced the cost by less than `ftol·cost`;
//! * `xtol`: an accepted step (or the trust radius after a rejection) is below `xtol·(xtol + ‖z‖)`;
//! * `gtol`: `max_j |J_jᵀ r| / (‖J_j‖‖r‖) ≤ gtol` (the cosine between residual and each column).
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

use std::cell::RefCell;

use argmin::core::{
    CostFunction, Error as ArgminError, Executor, Gradient, Hessian, IterState, Jacobian, KV,
    Operator, Problem, Solver, State, TerminationReason, TerminationStatus,
};
use argmin::solver::trustregion::{Steihaug, TrustRegion};
use nalgebra::{DMatrix, DVector};

use crate::error::{IdentifyError, Result};
use crate::report::{FitReport, FitStatus, ReportInputs, build_report};

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
    /// Iteration limit (accepted and rejected trust-region steps).
    pub max_iter: u64,
    /// Relative cost-reduction tolerance.
    pub ftol: f64,
    /// Relative step tolerance (internal coordinates).
    pub xtol: f64,
    /// Gradient (cosine) tolerance.
    pub gtol: f64,
    /// Initial trust radius in internal (unit-scaled) coordinates.
    pub initial_radius: f64,
}

impl Default for NlsOptions {
    /// Tight defaults: the fits here are small and cheap, and a cost-based stop (`ftol`) leaves a
    /// parameter error of order `√(ftol·n)·SE`; with `ftol = 1e-14` that is ≤ 1e-5 SE even for
    /// weakly identified parameters (e.g. a dead time), so the estimate is the minimum to well
    /// inside its uncertainty (and the scipy goldens agree to 1e-6 relative). `xtol`, `gtol` at
    /// 1e-12 stop a converged fit as soon as steps or gradient vanish.
    fn default() -> Self {
        NlsOptions {
            max_iter: 200,
            ftol: 1e-14,
            xtol: 1e-12,
            gtol: 1e-12,
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

struct Cache {
    z: DVector<f64>,
    r: DVector<f64>,
    jz: Option<DMatrix<f64>>,
}

/// The least-squares problem in internal coordinates, as argmin sees it (cost ½‖r‖², gradient
/// `J_zᵀr`, Gauss–Newton Hessian `J_zᵀJ_z`). Residuals and Jacobian are cached per point, so a
/// trust-region iteration evaluates the model once and its Jacobian once per accepted step.
pub struct LsqProblem<M> {
    model: M,
    tf: Vec<Transform>,
    cache: RefCell<Option<Cache>>,
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
        if let Some(c) = self.cache.borrow().as_ref() {
            if &c.z == z {
                return Some(c.r.clone());
            }
        }
        let r = self.model.apply(&self.theta(z)).ok()?;
        if r.iter().any(|v| !v.is_finite()) {
            return None;
        }
        *self.cache.borrow_mut() = Some(Cache {
            z: z.clone(),
            r: r.clone(),
            jz: None,
        });
        Some(r)
    }

    /// Makes sure the cache holds residuals and Jacobian (internal coordinates) at `z`.
    fn ensure_jz(&self, z: &DVector<f64>) -> std::result::Result<(), ArgminError> {
        if let Some(c) = self.cache.borrow().as_ref() {
            if &c.z == z && c.jz.is_some() {
                return Ok(());
            }
        }
        let r = self
            .residuals(z)
            .ok_or_else(|| argmin::core::ArgminError::InvalidParameter {
                text: "model not finite at an accepted point".into(),
            })?;
        let mut j = self.model.jacobian(&self.theta(z))?;
        for (k, t) in self.tf.iter().enumerate() {
            let d = t.dtheta(z[k]);
            j.column_mut(k).scale_mut(d);
        }
        *self.cache.borrow_mut() = Some(Cache {
            z: z.clone(),
            r,
            jz: Some(j),
        });
        Ok(())
    }

    /// Applies `f(r, J_z)` to the cached residuals and Jacobian at `z` (no copies).
    fn with_rj<T>(
        &self,
        z: &DVector<f64>,
        f: impl FnOnce(&DVector<f64>, &DMatrix<f64>) -> T,
    ) -> std::result::Result<T, ArgminError> {
        self.ensure_jz(z)?;
        let c = self.cache.borrow();
        match c.as_ref() {
            Some(Cache { r, jz: Some(j), .. }) => Ok(f(r, j)),
            _ => Err(ArgminError::msg("jacobian cache empty")),
        }
    }

    /// `max_j |J_jᵀr| / (‖J_j‖‖r‖)` at a cached point (MINPACK's gtol measure).
    fn gradient_cosine(&self, z: &DVector<f64>) -> Option<f64> {
        let c = self.cache.borrow();
        let c = c.as_ref()?;
        if &c.z != z {
            return None;
        }
        let j = c.jz.as_ref()?;
        let rn = c.r.norm();
        if rn == 0.0 {
            return Some(0.0);
        }
        Some(
            (0..j.ncols())
                .map(|k| {
                    let cn = j.column(k).norm();
                    if cn == 0.0 {
                        0.0
                    } else {
                        j.column(k).dot(&c.r).abs() / (cn * rn)
                    }
                })
                .fold(0.0, f64::max),
        )
    }
}

impl<M: ResidualModel> CostFunction for LsqProblem<M> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, z: &DVector<f64>) -> std::result::Result<f64, ArgminError> {
        Ok(self
            .residuals(z)
            .map(|r| 0.5 * r.norm_squared())
            .unwrap_or(f64::INFINITY))
    }
}

impl<M: ResidualModel> Gradient for LsqProblem<M> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, z: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        self.with_rj(z, |r, j| j.tr_mul(r))
    }
}

impl<M: ResidualModel> Hessian for LsqProblem<M> {
    type Param = DVector<f64>;
    type Hessian = DMatrix<f64>;
    fn hessian(&self, z: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        self.with_rj(z, |_, j| j.tr_mul(j))
    }
}

type LsqState = IterState<DVector<f64>, DVector<f64>, (), DMatrix<f64>, (), f64>;

/// argmin's `TrustRegion<Steihaug>` plus the MINPACK-style convergence tests (see module docs).
pub struct TrustRegionLsq {
    inner: TrustRegion<Steihaug<DVector<f64>, f64>, f64>,
    ftol: f64,
    xtol: f64,
    gtol: f64,
    converged: Option<String>,
}

impl<M: ResidualModel> Solver<LsqProblem<M>, LsqState> for TrustRegionLsq {
    fn name(&self) -> &str {
        "trust region (Steihaug CG) with least-squares convergence tests"
    }

    fn init(
        &mut self,
        problem: &mut Problem<LsqProblem<M>>,
        state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        self.inner.init(problem, state)
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<LsqProblem<M>>,
        state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let z_old = state.get_param().cloned();
        let f_old = state.get_cost();
        let (state, kv) = self.inner.next_iter(problem, state)?;
        let z_new = state.get_param().cloned();
        let f_new = state.get_cost();
        let radius = kv
            .as_ref()
            .and_then(|k| k.get("radius"))
            .and_then(|v| v.get_float())
            .unwrap_or(f64::INFINITY);
        if let (Some(z0), Some(z1)) = (z_old, z_new) {
            let accepted = z0 != z1;
            let zn = z1.norm();
            if accepted {
                let dz = (&z1 - &z0).norm();
                if f_new == 0.0 {
                    self.converged = Some("zero residual".into());
                } else if (f_old - f_new) <= self.ftol * f_old {
                    self.converged = Some(format!(
                        "ftol {:e}: relative cost reduction below tolerance",
                        self.ftol
                    ));
                } else if dz <= self.xtol * (self.xtol + zn) {
                    self.converged = Some(format!("xtol {:e}: step below tolerance", self.xtol));
                }
            } else if 0.25 * radius <= self.xtol * (self.xtol + zn) {
                self.converged = Some(format!(
                    "xtol {:e}: trust radius below tolerance",
                    self.xtol
                ));
            }
            if self.converged.is_none() {
                let cosine = problem.problem("gtol", |p| Ok(p.gradient_cosine(&z1)))?;
                if let Some(c) = cosine {
                    if c <= self.gtol {
                        self.converged = Some(format!(
                            "gtol {:e}: gradient orthogonal to residuals",
                            self.gtol
                        ));
                    }
                }
            }
        }
        Ok((state, kv))
    }

    fn terminate(&mut self, _state: &LsqState) -> TerminationStatus {
        if self.converged.is_some() {
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
/// `max_iter` and a warning.
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
        cache: RefCell::new(None),
    };
    // CG solves the p×p model exactly in ≤ p steps; the relative residual 1e-12 and the cap of
    // 2p + 10 iterations only guard against round-off stalling it.
    let sub = Steihaug::new()
        .with_epsilon(1e-12)
        .map_err(|source| IdentifyError::Solver { source })?
        .with_max_iters(2 * specs.len() as u64 + 10);
    let inner = TrustRegion::new(sub)
        .with_radius(opts.initial_radius)
        .map_err(|source| IdentifyError::Solver { source })?;
    let solver = TrustRegionLsq {
        inner,
        ftol: opts.ftol,
        xtol: opts.xtol,
        gtol: opts.gtol,
        converged: None,
    };
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
    let (status, message) = match &res.solver.converged {
        Some(m) => (FitStatus::Converged, m.clone()),
        None => (
            FitStatus::MaxIter,
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
    if status == FitStatus::MaxIter {
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
        method: "argmin_trust_region_steihaug",
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
    fn bad_bounds_and_start() {
        let e = Transform::new(&ParamSpec::bounded("x", 1.0, 2.0, 1.0)).unwrap_err();
        assert!(matches!(e, IdentifyError::BadBounds { .. }));
        let e = Transform::new(&ParamSpec::positive("tau_s", 0.0)).unwrap_err();
        assert!(matches!(e, IdentifyError::InitialOutsideBounds { .. }));
        let e = Transform::new(&ParamSpec::free("x", f64::NAN)).unwrap_err();
        assert!(matches!(e, IdentifyError::InitialOutsideBounds { .. }));
    }
}
