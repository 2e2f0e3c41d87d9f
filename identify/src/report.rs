//! The fit report: estimates, honest uncertainty, identifiability and residual diagnostics.
//!
//! Uncertainty is the classical linearised one (e.g. Seber & Wild, *Nonlinear Regression*, §2.1;
//! what `scipy.optimize.curve_fit` and statsmodels report):
//! `Cov = s² (JᵀJ)⁻¹` with `s² = RSS / (n − p)`, `J` the (weighted) Jacobian of the residuals with
//! respect to the natural parameters at the estimate, standard errors `√diag(Cov)`, and 95 %
//! intervals `θ̂ ± t₀.₉₇₅(n − p)·SE` with the Student-t quantile from statrs.
//!
//! `(JᵀJ)⁻¹` is formed from the SVD of the column-scaled Jacobian (each column divided by its
//! norm), which makes the condition number independent of parameter units and lets a rank
//! deficiency be named by parameter: the right singular vectors of the near-zero singular values are
//! the parameter combinations the data cannot see.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize, Serializer, ser::SerializeMap};
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

/// Thresholds of the identifiability and diagnostics warnings (one place, each argued).
pub mod thresholds {
    /// Singular values of the column-scaled Jacobian below `RANK_RTOL · σ_max` count as zero.
    /// 1e-10 is ~1e6 × machine epsilon: far above round-off in `J` for the problem sizes here
    /// (≤ 10⁵ rows), far below any genuine (if weak) information.
    pub const RANK_RTOL: f64 = 1e-10;
    /// Scaled condition number above which a "weakly identifiable" warning names the weakest
    /// direction. For two parameters cond² = (1+|ρ|)/(1−|ρ|), so 1e3 ⇔ |ρ| ≈ 0.999998: the data
    /// constrain only a combination, individual SEs are inflated ~10³-fold relative to it.
    pub const COND_WARN: f64 = 1e3;
    /// Pairwise |correlation| above which the pair is named in a warning.
    pub const CORR_WARN: f64 = 0.995;
    /// p-value below which the Ljung–Box / Jarque–Bera diagnostics produce a warning (1 %: one
    /// false alarm per hundred correctly specified fits).
    pub const DIAG_P_WARN: f64 = 0.01;
    /// Minimum residuals for the residual diagnostics to be computed (their asymptotic χ²
    /// distributions are useless below ~20 points).
    pub const DIAG_MIN_N: usize = 20;
}

pub use millcomp_models::{FitStatus, NamedMatrix};

/// RMS of the unweighted residuals (model − data), serialised as one key carrying the unit,
/// e.g. `"rms_residual_um": 0.21`.
#[derive(Debug, Clone, PartialEq)]
pub struct RmsResidual {
    /// The value.
    pub value: f64,
    /// Unit suffix of the key (`um`, `n`, ...).
    pub unit: String,
}

impl Serialize for RmsResidual {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(1))?;
        m.serialize_entry(&format!("rms_residual_{}", self.unit), &self.value)?;
        m.end()
    }
}

/// Residual diagnostics in data order (meaningful for time series; for other data the order of the
/// rows). `None` when there are fewer than [`thresholds::DIAG_MIN_N`] residuals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ResidualDiagnostics {
    /// Lag-1 sample autocorrelation of the residuals (0 for white noise).
    pub lag1_autocorrelation: Option<f64>,
    /// Durbin–Watson statistic (≈ 2(1 − ρ₁); 2 for white noise).
    pub durbin_watson: Option<f64>,
    /// Number of lags `h` in the Ljung–Box test (`min(10, n/5)`).
    pub ljung_box_lags: usize,
    /// Ljung–Box p-value for "no autocorrelation up to lag h" (χ²ₕ reference).
    pub ljung_box_p: Option<f64>,
    /// Sample skewness of the residuals.
    pub skewness: Option<f64>,
    /// Sample excess kurtosis of the residuals.
    pub excess_kurtosis: Option<f64>,
    /// Jarque–Bera p-value for normality (χ²₂ reference).
    pub jarque_bera_p: Option<f64>,
}

/// Everything a fit found out. Serialises with the contract's key names (`params`, `std_err`,
/// `ci95`, `rms_residual_<unit>`, `status`, `warnings`, ...). Non-finite numbers (e.g. the standard
/// error of an unidentifiable parameter, which is infinite) serialise as JSON `null`.
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// Model kind, e.g. `spindle`, `thermal_exponential`.
    pub model: String,
    /// Solver used, e.g. `linear_qr`, `argmin_trust_region_lm_svd`.
    pub method: String,
    /// Outcome.
    pub status: FitStatus,
    /// Human-readable termination message (which tolerance was met, ...).
    pub message: String,
    /// Estimates by name (in the units their names carry).
    pub params: BTreeMap<String, f64>,
    /// Standard errors by name (∞ → `null` for unidentifiable parameters).
    pub std_err: BTreeMap<String, f64>,
    /// 95 % confidence intervals `[lo, hi]` from the t distribution with `dof` degrees of freedom.
    pub ci95: BTreeMap<String, [f64; 2]>,
    /// Parameter covariance `s²(JᵀJ)⁻¹`.
    pub covariance: NamedMatrix,
    /// Parameter correlation matrix.
    pub correlation: NamedMatrix,
    /// Condition number of the column-scaled Jacobian (unit independent).
    pub condition_number: f64,
    /// Numerical rank of the Jacobian (= number of parameters when identifiable).
    pub rank: usize,
    /// RMS of the unweighted residuals, key `rms_residual_<unit>`.
    #[serde(flatten)]
    pub rms_residual: RmsResidual,
    /// Residual sum of squares `RSS = Σ r²` of the weighted residuals at the estimate (the
    /// quantity minimised).
    pub rss: f64,
    /// Residual standard deviation `s = √(RSS/dof)` of the weighted residuals.
    pub residual_std: f64,
    /// Number of observations (residuals).
    pub n_obs: usize,
    /// Degrees of freedom `n − p`.
    pub dof: usize,
    /// Solver iterations (0 for linear fits).
    pub iterations: u64,
    /// Residual diagnostics.
    pub diagnostics: ResidualDiagnostics,
    /// Identifiability, bound and diagnostics warnings, each naming the parameter(s) or test.
    pub warnings: Vec<String>,
    /// Known inputs held fixed during the fit (e.g. `tilt_deg`), for the record.
    pub fixed: BTreeMap<String, f64>,
}

impl FitReport {
    /// Estimate of a parameter (`NaN` when the name is unknown).
    pub fn param(&self, name: &str) -> f64 {
        self.params.get(name).copied().unwrap_or(f64::NAN)
    }

    /// Standard error of a parameter (`NaN` when the name is unknown).
    pub fn se(&self, name: &str) -> f64 {
        self.std_err.get(name).copied().unwrap_or(f64::NAN)
    }
}

/// Inputs of [`build_report`] (internal plumbing shared by the linear and nonlinear fits).
pub(crate) struct ReportInputs<'a> {
    pub model: &'a str,
    pub method: &'a str,
    pub names: &'a [String],
    pub theta: &'a DVector<f64>,
    /// Weighted residual Jacobian w.r.t. the natural parameters at the estimate.
    pub jac: &'a DMatrix<f64>,
    /// Weighted residuals (model − data)·√w.
    pub resid_w: &'a DVector<f64>,
    /// Unweighted residuals in the data unit.
    pub resid_raw: &'a DVector<f64>,
    pub unit: &'a str,
    pub status: FitStatus,
    pub message: String,
    pub iterations: u64,
    pub extra_warnings: Vec<String>,
}

/// Human-readable parameter combination `+0.71·a −0.70·b` from a (scaled) direction vector.
fn describe_direction(names: &[String], v: &[f64]) -> String {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[b].abs().total_cmp(&v[a].abs()));
    let sign = if v[idx[0]] < 0.0 { -1.0 } else { 1.0 };
    idx.iter()
        .filter(|&&j| v[j].abs() >= 0.1)
        .map(|&j| format!("{:+.2}·{}", sign * v[j], names[j]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Computes covariance, intervals, identifiability and diagnostics and assembles the report.
pub(crate) fn build_report(inp: ReportInputs<'_>) -> FitReport {
    let n = inp.resid_w.len();
    let p = inp.names.len();
    let dof = n.saturating_sub(p).max(1);
    let rss = inp.resid_w.norm_squared();
    let s2 = rss / dof as f64;
    let mut warnings = inp.extra_warnings;

    // Column scaling: unit-norm columns make the SVD and condition number unit-free. Columns that
    // are exactly zero (or not finite) are parameters without any effect: named on their own and
    // kept out of the SVD, so that its null directions name genuine trade-offs.
    let col_norm: Vec<f64> = (0..p).map(|j| inp.jac.column(j).norm()).collect();
    let active: Vec<usize> = (0..p)
        .filter(|&j| col_norm[j] > 0.0 && col_norm[j].is_finite())
        .collect();
    let mut unseen = vec![false; p];
    for j in (0..p).filter(|j| !active.contains(j)) {
        unseen[j] = true;
        warnings.push(format!(
            "not identifiable: parameter {} has no effect on the residuals at the estimate (zero Jacobian column); \
             fix it or add data that depend on it",
            inp.names[j]
        ));
    }
    let pa = active.len();
    let js = DMatrix::from_fn(n, pa, |i, k| inp.jac[(i, active[k])] / col_norm[active[k]]);
    let (sv, vt) = if pa > 0 {
        let svd = js.svd(false, true);
        let vt = svd.v_t.unwrap_or_else(|| DMatrix::identity(pa, pa));
        (svd.singular_values, vt)
    } else {
        (DVector::zeros(0), DMatrix::zeros(0, 0))
    };
    // Right singular vector k expanded to all p parameters (0 for inactive ones).
    let full = |k: usize| -> Vec<f64> {
        let mut v = vec![0.0; p];
        for (m, &j) in active.iter().enumerate() {
            v[j] = vt[(k, m)];
        }
        v
    };
    let smax = sv.iter().cloned().fold(0.0, f64::max);
    let smin = sv.iter().cloned().fold(f64::INFINITY, f64::min);
    let condition_number = if smin > 0.0 && pa == p {
        smax / smin
    } else {
        f64::INFINITY
    };
    let mut rank = 0;
    let mut inv_scaled = DMatrix::<f64>::zeros(p, p);
    for k in 0..sv.len() {
        let v = full(k);
        if sv[k] > thresholds::RANK_RTOL * smax {
            rank += 1;
            let vv = DVector::from_vec(v);
            inv_scaled += (&vv * vv.transpose()) / (sv[k] * sv[k]);
        } else {
            for (j, &c) in v.iter().enumerate() {
                if c.abs() >= 0.1 {
                    unseen[j] = true;
                }
            }
            warnings.push(format!(
                "not identifiable: the data do not determine the combination {} (singular value ratio {:.1e}); \
                 fix one of these parameters or add data that separates them",
                describe_direction(inp.names, &v),
                sv[k] / smax.max(f64::MIN_POSITIVE)
            ));
        }
    }
    if rank == p && condition_number > thresholds::COND_WARN {
        let v = full(sv.len() - 1);
        warnings.push(format!(
            "weakly identifiable: condition number {:.3e} > {:.0e}; the data barely see the combination {}",
            condition_number,
            thresholds::COND_WARN,
            describe_direction(inp.names, &v)
        ));
    }

    let mut cov = DMatrix::<f64>::zeros(p, p);
    for i in 0..p {
        for j in 0..p {
            let ci = if col_norm[i] > 0.0 { col_norm[i] } else { 1.0 };
            let cj = if col_norm[j] > 0.0 { col_norm[j] } else { 1.0 };
            cov[(i, j)] = if unseen[i] || unseen[j] {
                f64::NAN
            } else {
                s2 * inv_scaled[(i, j)] / (ci * cj)
            };
        }
    }
    let se: Vec<f64> = (0..p)
        .map(|i| {
            if unseen[i] {
                f64::INFINITY
            } else {
                cov[(i, i)].max(0.0).sqrt()
            }
        })
        .collect();
    let corr = DMatrix::from_fn(p, p, |i, j| {
        if i == j && !unseen[i] {
            1.0
        } else {
            cov[(i, j)] / (se[i] * se[j])
        }
    });
    for i in 0..p {
        for j in (i + 1)..p {
            let r = corr[(i, j)];
            if r.is_finite() && r.abs() > thresholds::CORR_WARN {
                warnings.push(format!(
                    "parameters {} and {} are strongly correlated (ρ = {:+.4}); their individual intervals are wide",
                    inp.names[i], inp.names[j], r
                ));
            }
        }
    }
    let t = StudentsT::new(0.0, 1.0, dof as f64)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(f64::NAN);

    let mut params = BTreeMap::new();
    let mut std_err = BTreeMap::new();
    let mut ci95 = BTreeMap::new();
    for (i, name) in inp.names.iter().enumerate() {
        let v = inp.theta[i];
        params.insert(name.clone(), v);
        std_err.insert(name.clone(), se[i]);
        ci95.insert(name.clone(), [v - t * se[i], v + t * se[i]]);
    }

    let diagnostics = residual_diagnostics(inp.resid_w.as_slice());
    if let Some(pv) = diagnostics.ljung_box_p {
        if pv < thresholds::DIAG_P_WARN {
            warnings.push(format!(
                "residuals are autocorrelated (Ljung–Box p = {pv:.2e}, lag-1 ρ = {:.3}): the model may miss an effect \
                 and the standard errors are optimistic",
                diagnostics.lag1_autocorrelation.unwrap_or(f64::NAN)
            ));
        }
    }
    if let Some(pv) = diagnostics.jarque_bera_p {
        if pv < thresholds::DIAG_P_WARN {
            warnings.push(format!(
                "residuals are not normal (Jarque–Bera p = {pv:.2e}): outliers or a missing effect; t intervals assume normal errors"
            ));
        }
    }
    let status = if rank < p {
        FitStatus::RankDeficient
    } else {
        inp.status
    };
    let nraw = inp.resid_raw.len().max(1) as f64;
    FitReport {
        model: inp.model.to_string(),
        method: inp.method.to_string(),
        status,
        message: inp.message,
        params,
        std_err,
        ci95,
        covariance: NamedMatrix::from_matrix(inp.names, &cov),
        correlation: NamedMatrix::from_matrix(inp.names, &corr),
        condition_number,
        rank,
        rms_residual: RmsResidual {
            value: (inp.resid_raw.norm_squared() / nraw).sqrt(),
            unit: inp.unit.to_string(),
        },
        rss,
        residual_std: s2.sqrt(),
        n_obs: n,
        dof: n.saturating_sub(p),
        iterations: inp.iterations,
        diagnostics,
        warnings,
        fixed: BTreeMap::new(),
    }
}

/// Residual diagnostics of a residual series (see [`ResidualDiagnostics`]).
pub fn residual_diagnostics(r: &[f64]) -> ResidualDiagnostics {
    let n = r.len();
    let h = (n / 5).clamp(1, 10);
    if n < thresholds::DIAG_MIN_N {
        return ResidualDiagnostics {
            ljung_box_lags: h,
            ..Default::default()
        };
    }
    let nf = n as f64;
    let mean = r.iter().sum::<f64>() / nf;
    let c: Vec<f64> = r.iter().map(|x| x - mean).collect();
    let c0: f64 = c.iter().map(|x| x * x).sum();
    if c0 <= 0.0 {
        return ResidualDiagnostics {
            ljung_box_lags: h,
            ..Default::default()
        };
    }
    let acf = |k: usize| -> f64 { (k..n).map(|t| c[t] * c[t - k]).sum::<f64>() / c0 };
    let rho1 = acf(1);
    // Durbin–Watson on the raw residuals (as statsmodels.stats.stattools.durbin_watson).
    let ss: f64 = r.iter().map(|x| x * x).sum();
    let dw = (1..n).map(|t| (r[t] - r[t - 1]).powi(2)).sum::<f64>() / ss.max(f64::MIN_POSITIVE);
    let q = nf
        * (nf + 2.0)
        * (1..=h)
            .map(|k| acf(k).powi(2) / (nf - k as f64))
            .sum::<f64>();
    let lb_p = ChiSquared::new(h as f64).map(|d| d.sf(q)).ok();
    let m2 = c0 / nf;
    let m3 = c.iter().map(|x| x.powi(3)).sum::<f64>() / nf;
    let m4 = c.iter().map(|x| x.powi(4)).sum::<f64>() / nf;
    let skew = m3 / m2.powf(1.5);
    let exkurt = m4 / (m2 * m2) - 3.0;
    let jb = nf / 6.0 * (skew * skew + exkurt * exkurt / 4.0);
    let jb_p = ChiSquared::new(2.0).map(|d| d.sf(jb)).ok();
    ResidualDiagnostics {
        lag1_autocorrelation: Some(rho1),
        durbin_watson: Some(dw),
        ljung_box_lags: h,
        ljung_box_p: lb_p,
        skewness: Some(skew),
        excess_kurtosis: Some(exkurt),
        jarque_bera_p: jb_p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rms_key_carries_unit() {
        let r = RmsResidual {
            value: 0.5,
            unit: "um".into(),
        };
        let j = serde_json_like(&r);
        assert_eq!(j, "rms_residual_um=0.5");
    }

    // Minimal serializer-free check: use toml (a dependency) to serialise a wrapper table.
    fn serde_json_like(r: &RmsResidual) -> String {
        #[derive(Serialize)]
        struct W<'a> {
            #[serde(flatten)]
            r: &'a RmsResidual,
        }
        toml::to_string(&W { r }).unwrap().trim().replace(' ', "")
    }

    #[test]
    fn diagnostics_of_alternating_series() {
        // r = (+1, −1, +1, ...): lag-1 autocorrelation → −1, DW → 4 (exact for this series:
        // Σ(Δr)² = 4(n−1), Σr² = n).
        let r: Vec<f64> = (0..40)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let d = residual_diagnostics(&r);
        assert_relative_eq!(d.durbin_watson.unwrap(), 4.0 * 39.0 / 40.0, epsilon = 1e-12);
        assert_relative_eq!(
            d.lag1_autocorrelation.unwrap(),
            -39.0 / 40.0,
            epsilon = 1e-12
        );
        assert!(d.ljung_box_p.unwrap() < 1e-6);
    }

    #[test]
    fn describe_direction_names_parameters() {
        let names = vec!["a".to_string(), "b".to_string(), "c".to_string()];
        let s = describe_direction(
            &names,
            &[
                -std::f64::consts::FRAC_1_SQRT_2,
                std::f64::consts::FRAC_1_SQRT_2,
                0.01,
            ],
        );
        assert_eq!(s, "+0.71·a -0.71·b");
    }
}
