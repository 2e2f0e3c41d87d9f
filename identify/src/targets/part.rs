//! `part`: what a cut part says about the deflection model — run-to-run identification from measured
//! grooves.
//!
//! After a part is cut, a profilometer measures its groove error `e(x)` (depth cut − programmed) and the
//! machine's log holds the capacitance gauge (the PZT's tip extension, `g(x)`) and the measured force's
//! per-revolution peak `F(x)` at the same positions. The tool's z-deflection is then measured along the
//! groove: `δ(x) = g(x)·sin α − e(x)` (the tip moved down by `g·sin α`, the cut came out `e` deeper than
//! programmed, the difference is what the tool gave way). Two lines through it, each with one offset per
//! part (touch-off and gauge zero differ from part to part):
//!
//! * against the controllers' planned deflection `δ̂(x)` (their force model ÷ their stiffness):
//!   `δ = a_p + ρ·δ̂` — `deflection_scale` ρ is the model's force scale ÷ stiffness error. The groove's
//!   depth sees only this ratio: a force model 10 % high and a stiffness 10 % high plan the same groove;
//! * against the measured force peak: `δ = a_p + c·F` — `compliance_um_per_n` c is the z-compliance per
//!   *measured* newton, the tool's compliance divided by the force sensor's gain (which it cannot
//!   separate either).
//!
//! Neighbouring points of a groove share the model's shape error, so residuals are correlated along x.
//! The covariance is Newey–West's (1987; Bartlett kernel, lags within a part only) with Andrews' (1991)
//! AR(1) plug-in bandwidth `1.1447·(α n)^⅓`, `α = 4r²/(1 − r)⁴` for the residuals' lag-1
//! autocorrelation r (clamped to [0, 0.98], at most n/2 lags), and the interval uses the effective
//! degrees of freedom `n·(1 − r)/(1 + r)`; the report says so.

use std::collections::BTreeMap;

use nalgebra::DMatrix;

use super::Identified;
use crate::error::Result;
use crate::linear::{LinearMethod, fit_linear};
use crate::validate;

/// What the measured deflection is regressed on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartRegressor {
    /// The controllers' planned deflection (µm): fits `deflection_scale`, kind `part_scale`.
    PlannedDeflection,
    /// The measured force's per-revolution peak (N): fits `compliance_um_per_n`, kind
    /// `part_compliance`.
    MeasuredForce,
}

impl PartRegressor {
    /// The fitted parameter's name.
    pub fn parameter(self) -> &'static str {
        match self {
            PartRegressor::PlannedDeflection => "deflection_scale",
            PartRegressor::MeasuredForce => "compliance_um_per_n",
        }
    }

    /// The model kind.
    pub fn kind(self) -> &'static str {
        match self {
            PartRegressor::PlannedDeflection => "part_scale",
            PartRegressor::MeasuredForce => "part_compliance",
        }
    }

    fn column(self) -> &'static str {
        match self {
            PartRegressor::PlannedDeflection => "planned_deflection_um",
            PartRegressor::MeasuredForce => "force_peak_n",
        }
    }
}

/// Measured points of one or more cut parts, in order along each groove.
#[derive(Debug, Clone, Copy)]
pub struct PartData<'a> {
    /// Part number of each row (rows of one part contiguous, in order along x).
    pub part: &'a [usize],
    /// Measured deflection `g·sin α − e` (µm).
    pub deflection_um: &'a [f64],
    /// The regressor (µm of planned deflection or N of measured force peak, see [`PartRegressor`]).
    pub regressor: &'a [f64],
}

/// The largest lag-1 autocorrelation the bandwidth and the effective degrees of freedom use (beyond it the
/// effective sample is < 1 %).
pub const MAX_LAG1: f64 = crate::hac::MAX_LAG1;

/// Fits `deflection_um = offset_p + θ·regressor` with one offset per part, θ the parameter of `what`,
/// with standard errors and intervals honest for residuals correlated along the groove.
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`](crate::IdentifyError::LengthMismatch) when the columns differ in length;
/// * [`IdentifyError::NonFinite`](crate::IdentifyError::NonFinite) naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::ConstantInput`](crate::IdentifyError::ConstantInput) when the regressor does not vary;
/// * [`IdentifyError::TooFewPoints`](crate::IdentifyError::TooFewPoints) with fewer rows than parameters + 1.
///
/// # Examples
/// ```
/// use millcomp_identify::targets::part::*;
/// // two parts of a 0–8 µm planned ramp; the tool gave way 10 % more than planned, the offsets
/// // (touch-off, gauge zero) are +0.3 and −0.2 µm; ±0.02 µm of measurement scatter
/// let plan: Vec<f64> = (0..50).map(|i| 8.0 * i as f64 / 49.0).collect();
/// let (mut part, mut d, mut r) = (vec![], vec![], vec![]);
/// for (p, a) in [(1, 0.3), (2, -0.2)] {
///     for (i, x) in plan.iter().enumerate() {
///         part.push(p);
///         r.push(*x);
///         d.push(a + 1.1 * x + 0.02 * [1.0, -1.0, 0.5, -0.5][i % 4]);
///     }
/// }
/// let data = PartData { part: &part, deflection_um: &d, regressor: &r };
/// let fit = identify_part(&data, PartRegressor::PlannedDeflection).unwrap();
/// assert_eq!(fit.kind, "part_scale");
/// let (s, ci) = (fit.report.param("deflection_scale"), fit.report.ci95["deflection_scale"]);
/// assert!((s - 1.1).abs() < 2e-3 && ci[0] < 1.1 && 1.1 < ci[1], "{s} {ci:?}");
/// assert!((fit.report.param("offset_part1_um") - 0.3).abs() < 0.02);
/// ```
pub fn identify_part(data: &PartData<'_>, what: PartRegressor) -> Result<Identified> {
    let n = data.part.len();
    validate::same_len("deflection_um", data.deflection_um, "part", n)?;
    validate::same_len(what.column(), data.regressor, "part", n)?;
    validate::finite("deflection_um", data.deflection_um)?;
    validate::finite(what.column(), data.regressor)?;
    validate::not_constant(what.column(), data.regressor, what.parameter())?;
    let mut parts: Vec<usize> = data.part.to_vec();
    parts.sort_unstable();
    parts.dedup();
    validate::enough_points(n, 1 + parts.len(), what.kind())?;
    let mut names = vec![what.parameter().to_string()];
    names.extend(parts.iter().map(|p| format!("offset_part{p}_um")));
    let design = DMatrix::from_fn(n, names.len(), |i, j| {
        if j == 0 {
            data.regressor[i]
        } else if parts[j - 1] == data.part[i] {
            1.0
        } else {
            0.0
        }
    });
    let fit = fit_linear(
        &names,
        &design,
        data.deflection_um,
        None,
        LinearMethod::Qr,
        what.kind(),
        "um",
    )?;
    let mut report = fit.report;
    // Newey–West covariance for residuals correlated along each groove (lags within a part only), the
    // Bartlett kernel with Andrews' AR(1) plug-in bandwidth (crate::hac)
    let nw = crate::hac::apply(
        &mut report,
        &names,
        &design,
        data.deflection_um,
        &fit.theta,
        Some(data.part),
    );
    let (r, lags, dof_eff) = (nw.r, nw.lags, nw.dof_eff);
    let mut out = Identified::new(what.kind(), report, BTreeMap::new(), BTreeMap::new());
    out.notes.push(format!(
        "residuals correlated along the groove (lag-1 r = {r:.2}): Newey–West covariance over {lags} lags \
         within each part, interval on {dof_eff:.0} effective degrees of freedom"
    ));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::IdentifyError;

    #[test]
    fn compliance_from_measured_force_and_bad_input() {
        // δ = 0.8 µm/N · F + 0.1, exactly: the slope comes back with a tight interval
        let f: Vec<f64> = (0..30).map(|i| 0.5 * i as f64).collect();
        let d: Vec<f64> = f.iter().map(|f| 0.1 + 0.8 * f).collect();
        let part = vec![3; 30];
        let data = PartData {
            part: &part,
            deflection_um: &d,
            regressor: &f,
        };
        let fit = identify_part(&data, PartRegressor::MeasuredForce).unwrap();
        assert_eq!(fit.kind, "part_compliance");
        assert!((fit.report.param("compliance_um_per_n") - 0.8).abs() < 1e-9);
        assert!((fit.report.param("offset_part3_um") - 0.1).abs() < 1e-9);
        // a constant regressor cannot give a slope; a NaN is named by column and row
        let c = vec![1.0; 30];
        let e = identify_part(
            &PartData {
                regressor: &c,
                ..data
            },
            PartRegressor::MeasuredForce,
        )
        .unwrap_err();
        assert!(matches!(e, IdentifyError::ConstantInput { .. }), "{e}");
        let mut bad = d.clone();
        bad[7] = f64::NAN;
        let e = identify_part(
            &PartData {
                deflection_um: &bad,
                ..data
            },
            PartRegressor::MeasuredForce,
        )
        .unwrap_err();
        assert!(e.to_string().contains("deflection_um") && e.to_string().contains("row 8"));
    }

    #[test]
    fn correlated_residuals_widen_the_interval() {
        // a shape error the line cannot follow (a slow sine) on top of the slope: lag-1 r near 1,
        // so the interval is much wider than the white-noise one would be
        let x: Vec<f64> = (0..200).map(|i| i as f64 / 20.0).collect();
        let d: Vec<f64> = x.iter().map(|x| 1.2 * x + 0.3 * (x * 0.8).sin()).collect();
        let part = vec![1; 200];
        let fit = identify_part(
            &PartData {
                part: &part,
                deflection_um: &d,
                regressor: &x,
            },
            PartRegressor::PlannedDeflection,
        )
        .unwrap();
        let ci = fit.report.ci95["deflection_scale"];
        let names = ["deflection_scale".to_string(), "offset_um".to_string()];
        let a = DMatrix::from_fn(200, 2, |i, j| if j == 0 { x[i] } else { 1.0 });
        let raw = fit_linear(&names, &a, &d, None, LinearMethod::Qr, "raw", "um").unwrap();
        let ci_raw = raw.report.ci95["deflection_scale"];
        assert!(
            ci[1] - ci[0] > 5.0 * (ci_raw[1] - ci_raw[0]),
            "{ci:?} {ci_raw:?}"
        );
        assert!(fit.notes[0].contains("lag-1"));
    }
}
