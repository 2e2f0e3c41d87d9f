//! Newey–West (1987) covariance of a linear least-squares fit whose residuals are correlated in data
//! order (along a groove, over a time series), with Andrews' (1991) AR(1) plug-in bandwidth — shared
//! by the targets that fit series (`part`, the thermal record study, the wear laws).
//!
//! `Σ = (XᵀX)⁻¹ · S · (XᵀX)⁻¹ · n/(n − p)` with `S = Σₜ xₜuₜ(xₜuₜ)ᵀ + Σₗ wₗ Σₜ (xₜuₜ(xₜ₋ₗuₜ₋ₗ)ᵀ + ·ᵀ)`,
//! Bartlett weights `wₗ = 1 − l/(L + 1)`, `L = ⌈1.1447·(α n)^⅓⌉` (at most n/2), `α = 4r²/(1 − r)⁴` for
//! the residuals' lag-1 autocorrelation r clamped to [0, [`MAX_LAG1`]]; lags never cross a group
//! boundary (a new part). The interval uses the effective degrees of freedom `n·(1 − r)/(1 + r) − p`.

use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ContinuousCDF, StudentsT};

/// Largest lag-1 autocorrelation used in the bandwidth (r → 1 would ask for every lag).
pub(crate) const MAX_LAG1: f64 = 0.98;

/// The Newey–West covariance of one fit.
#[derive(Debug, Clone)]
pub(crate) struct NeweyWest {
    /// Parameter covariance.
    pub cov: DMatrix<f64>,
    /// Lags used.
    pub lags: usize,
    /// The lag-1 autocorrelation used (clamped).
    pub r: f64,
    /// Effective degrees of freedom of the interval.
    pub dof_eff: f64,
    /// The t quantile (0.975) on `dof_eff`.
    pub t975: f64,
}

/// Newey–West covariance of the fit `y ≈ design·θ` with residuals `u = y − design·θ` and lag-1
/// autocorrelation `lag1`; `group[t]` (if given) stops lags at a change of group.
pub(crate) fn newey_west(
    design: &DMatrix<f64>,
    u: &DVector<f64>,
    lag1: f64,
    group: Option<&[usize]>,
) -> NeweyWest {
    let (n, p) = design.shape();
    let r = lag1.clamp(0.0, MAX_LAG1);
    let alpha = 4.0 * r * r / (1.0 - r).powi(4);
    let lags = ((1.1447 * (alpha * n as f64).cbrt()).ceil() as usize).min(n / 2);
    let mut meat = DMatrix::<f64>::zeros(p, p);
    for t in 0..n {
        let xt = design.row(t).transpose() * u[t];
        meat += &xt * xt.transpose();
        for l in 1..=lags.min(t) {
            if group.is_some_and(|g| g[t - l] != g[t]) {
                break;
            }
            let w = 1.0 - l as f64 / (lags as f64 + 1.0);
            let xl = design.row(t - l).transpose() * u[t - l];
            let c = &xt * xl.transpose();
            meat += (&c + c.transpose()) * w;
        }
    }
    // (XᵀX)⁻¹ = R⁻¹R⁻ᵀ from the QR of X: XᵀX is never formed (it squares X's condition number)
    let bread = (n >= p)
        .then(|| {
            let r = design.clone().qr().r();
            r.solve_upper_triangular(&DMatrix::identity(p, p))
                .map(|ri| &ri * ri.transpose())
        })
        .flatten()
        .filter(|b| b.iter().all(|v| v.is_finite()))
        .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
    let cov = &bread * meat * &bread * (n as f64 / (n - p).max(1) as f64);
    let dof_eff = (n as f64 * (1.0 - r) / (1.0 + r) - p as f64).max(1.0);
    let t975 = StudentsT::new(0.0, 1.0, dof_eff)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(f64::NAN);
    NeweyWest {
        cov,
        lags,
        r,
        dof_eff,
        t975,
    }
}

/// Replaces the standard errors, intervals and covariance of `report` (a linear fit of `design`
/// whose parameters are `names`) by Newey–West's, and drops the engine's autocorrelation warning
/// (the covariance now accounts for it). Returns what was used, for the report's note.
pub(crate) fn apply(
    report: &mut crate::report::FitReport,
    names: &[String],
    design: &DMatrix<f64>,
    y: &[f64],
    theta: &DVector<f64>,
    group: Option<&[usize]>,
) -> NeweyWest {
    let u = DVector::from_column_slice(y) - design * theta;
    apply_residuals(report, names, design, &u, group)
}

/// [`apply`] for a nonlinear fit: `jacobian` of the model at the estimate in place of the design,
/// `u` the residuals (data − model).
pub(crate) fn apply_residuals(
    report: &mut crate::report::FitReport,
    names: &[String],
    jacobian: &DMatrix<f64>,
    u: &DVector<f64>,
    group: Option<&[usize]>,
) -> NeweyWest {
    let design = jacobian;
    let lag1 = report.diagnostics.lag1_autocorrelation.unwrap_or(0.0);
    let nw = newey_west(design, u, lag1, group);
    for (j, name) in names.iter().enumerate() {
        let v = report.param(name);
        let se = nw.cov[(j, j)].max(0.0).sqrt();
        report.std_err.insert(name.clone(), se);
        report
            .ci95
            .insert(name.clone(), [v - nw.t975 * se, v + nw.t975 * se]);
    }
    report.covariance = crate::report::NamedMatrix::from_matrix(names, &nw.cov);
    report
        .warnings
        .retain(|w| !w.starts_with("residuals are autocorrelated"));
    nw
}
