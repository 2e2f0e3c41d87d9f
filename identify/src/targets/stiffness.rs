//! `identify stiffness`: static stiffness from load–deflection data (`000_…txt` §5.2.3, Table 5-1:
//! hanging masses 50–1000 g, deflection by indicator, "the slope of the curve yields the stiffness").
//!
//! Per direction the model is `deflection_um = offset_um + load_n / stiffness_n_per_um` (a line
//! with intercept, parametrised by the stiffness itself so that its standard error and interval
//! come straight from the fit). Directions are fitted independently (they share no data); the
//! combined report has a block-diagonal covariance. Derived, with delta-method uncertainty:
//! * tilted tool (needs directions `radial` and `axial`, and `tilt_deg`): the physics crate's
//!   z-stiffness of a tilted tool (§5.2.3 eqs 18–21);
//! * machine and tool in series (`003_…txt` eqs 1–5): every direction combined with a `machine`
//!   direction in the data, or with a known machine stiffness given as an option.

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};

use super::combine::{combine, prefixed};
use super::thermal::CommonOptions;
use super::{Identified, derive};
use crate::error::{IdentifyError, Result};
use crate::linear::{LinearMethod, fit_linear};
use crate::nonlinear::{ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;
use millcomp_sim::stiffness::{TiltedToolStiffness, series_n_per_um};

/// Load–deflection data (columns `load_n`, `deflection_um`, optional `direction`).
#[derive(Debug, Clone, Copy)]
pub struct StiffnessData<'a> {
    /// Applied load, N.
    pub load_n: &'a [f64],
    /// Measured deflection, µm.
    pub deflection_um: &'a [f64],
    /// Direction label per row (`radial`, `axial`, `z`, `machine`, ...); `None`: one direction.
    pub direction: Option<&'a [String]>,
}

/// Options of [`identify_stiffness`].
#[derive(Debug, Clone, Default)]
pub struct StiffnessOptions {
    /// Common options.
    pub common: CommonOptions,
    /// Tilt angles (deg) at which to derive the tilted-tool z-stiffness.
    pub tilt_deg: Vec<f64>,
    /// Known machine stiffness (N/µm) to put in series with each fitted direction.
    pub machine_stiffness_n_per_um: Option<f64>,
}

/// Residual operator of one direction, parameters `[stiffness_n_per_um, offset_um]`.
#[derive(Debug, Clone)]
pub struct LoadDeflection {
    /// Loads, N.
    pub load_n: Vec<f64>,
    /// Deflections, µm.
    pub deflection_um: Vec<f64>,
}

impl Operator for LoadDeflection {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        Ok(DVector::from_iterator(
            self.load_n.len(),
            self.load_n
                .iter()
                .zip(&self.deflection_um)
                .map(|(f, d)| p[1] + f / p[0] - d),
        ))
    }
}

impl Jacobian for LoadDeflection {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        Ok(DMatrix::from_fn(self.load_n.len(), 2, |i, j| {
            if j == 0 {
                -self.load_n[i] / (p[0] * p[0])
            } else {
                1.0
            }
        }))
    }
}

impl ResidualModel for LoadDeflection {}

/// z-stiffness of a tilted tool from its axial and radial stiffness, N/µm: the physics crate's
/// [`TiltedToolStiffness::z_stiffness_n_per_um`] (`1/kz = cos²α/k_axial + sin²α/k_radial`,
/// `000_…txt` §5.2.3 eq. 21). `NaN` for inputs the physics crate rejects (tilt ≥ 90°, k ≤ 0).
pub fn tilted_z_stiffness_n_per_um(k_axial: f64, k_radial: f64, tilt_deg: f64) -> f64 {
    TiltedToolStiffness::new(k_axial, k_radial)
        .and_then(|t| t.z_stiffness_n_per_um(tilt_deg))
        .unwrap_or(f64::NAN)
}

/// Two springs in series, N/µm: the physics crate's [`series_n_per_um`] (`003_…txt` eqs 1–5).
/// `NaN` for non-positive inputs.
pub fn series_stiffness_n_per_um(k1: f64, k2: f64) -> f64 {
    series_n_per_um(k1, k2).unwrap_or(f64::NAN)
}

/// The direction labels of a stiffness test (`direction` column): the axial (spindle) and the radial
/// (tool bending) stiffness, the two a bundle and the controllers read (`000_…txt` §5.2.3).
pub const DIRECTIONS: [&str; 2] = ["axial", "radial"];

fn key(label: &str) -> String {
    label
        .trim()
        .to_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// Fits the stiffness of each direction and the derived combinations.
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] when `deflection_um` or `direction` is not as long as
///   `load_n`;
/// * [`IdentifyError::NonFinite`] naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::MissingColumn`] (`direction`) for a row with an empty direction label;
/// * [`IdentifyError::InvalidParameter`] for a `tilt_deg` option outside `[0, 90)`, a
///   `machine_stiffness_n_per_um` that is not a finite positive number, or a direction whose
///   deflection does not grow with the load (slope ≤ 0: signs or units);
/// * [`IdentifyError::TooFewPoints`] for a direction with fewer than 3 rows (or no rows at all);
/// * [`IdentifyError::ConstantInput`] when the load of a direction does not vary;
/// * the errors of [`fit_nonlinear`] (not expected once the checks above have passed).
///
/// # Examples
/// ```
/// use millcomp_identify::targets::stiffness::*;
/// // 000 §5.2.3: radial 0.114 N/µm measured; masses 50..1000 g.
/// let load: Vec<f64> = (1..=20).map(|i| i as f64 * 0.05 * 9.81).collect();
/// let defl: Vec<f64> = load.iter().enumerate().map(|(i, f)| f / 0.114 + 0.02 * ((i % 3) as f64 - 1.0)).collect();
/// let fit = identify_stiffness(&StiffnessData { load_n: &load, deflection_um: &defl, direction: None },
///                              &StiffnessOptions::default()).unwrap();
/// assert!((fit.report.param("stiffness_n_per_um") - 0.114).abs() < 1e-3);
/// // the ±0.02 µm perturbation leaves a standard error of 1.7e-5 N/µm; the interval covers 0.114
/// let ci = fit.report.ci95["stiffness_n_per_um"];
/// assert!(ci[0] < 0.114 && 0.114 < ci[1] && ci[1] - ci[0] < 1e-4);
///
/// // Two directions (Table 5-1 measured: radial 0.114, axial 1.220 N/µm) and the tilted tool's
/// // z-stiffness derived at 20°: 000 §6.1 publishes 0.597 N/µm, the reconstruction gives 0.571
/// let mut load = Vec::new();
/// let mut defl = Vec::new();
/// let mut direction = Vec::new();
/// for (label, k) in [("radial", 0.114), ("axial", 1.220)] {
///     for i in 1..=10 {
///         let f = i as f64 * 0.1 * 9.81;
///         load.push(f);
///         defl.push(f / k + 0.01 * ((i % 3) as f64 - 1.0));
///         direction.push(label.to_string());
///     }
/// }
/// let data = StiffnessData { load_n: &load, deflection_um: &defl, direction: Some(&direction) };
/// let opts = StiffnessOptions { tilt_deg: vec![20.0], ..Default::default() };
/// let fit = identify_stiffness(&data, &opts).unwrap();
/// assert!((fit.report.param("axial_stiffness_n_per_um") - 1.220).abs() < 2e-3);
/// let kz = &fit.derived["z_stiffness_tilt_20deg_n_per_um"];
/// assert!((kz.value - 0.597).abs() / 0.597 < 0.05);
/// assert!((kz.value - 0.5716).abs() < 1e-4 && kz.std_err < 1e-3);
/// ```
pub fn identify_stiffness(data: &StiffnessData<'_>, opts: &StiffnessOptions) -> Result<Identified> {
    let n = data.load_n.len();
    validate::same_len("deflection_um", data.deflection_um, "load_n", n)?;
    validate::finite("load_n", data.load_n)?;
    validate::finite("deflection_um", data.deflection_um)?;
    if let Some(d) = data.direction {
        if d.len() != n {
            return Err(IdentifyError::LengthMismatch {
                column: "direction".into(),
                len: d.len(),
                reference: "load_n".into(),
                expected: n,
            });
        }
        if let Some(i) = d.iter().position(|s| key(s).is_empty()) {
            return Err(IdentifyError::MissingColumn {
                column: "direction".into(),
                reason: format!("row {} has an empty direction label", i + 1),
            });
        }
        // the directions a stiffness model has: a bundle, the controllers and the tilted-tool
        // z-stiffness read `axial` and `radial`; another label is a typo, not a third direction
        if let Some(i) = d
            .iter()
            .position(|s| !DIRECTIONS.contains(&key(s).as_str()))
        {
            return Err(IdentifyError::InvalidLabel {
                column: "direction".into(),
                row: i + 1,
                value: d[i].clone(),
                allowed: DIRECTIONS.join(", "),
            });
        }
    }
    for &t in &opts.tilt_deg {
        if !(0.0..90.0).contains(&t) {
            return Err(IdentifyError::InvalidParameter {
                name: "tilt_deg".into(),
                value: t,
                allowed: "0 <= tilt_deg < 90",
            });
        }
    }
    if let Some(km) = opts.machine_stiffness_n_per_um {
        if !(km > 0.0 && km.is_finite()) {
            return Err(IdentifyError::InvalidParameter {
                name: "machine_stiffness_n_per_um".into(),
                value: km,
                allowed: "> 0 and finite",
            });
        }
    }
    // Group rows by direction (BTreeMap: deterministic order).
    let mut groups: BTreeMap<String, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for i in 0..n {
        let g = data.direction.map(|d| key(&d[i])).unwrap_or_default();
        let e = groups.entry(g).or_default();
        e.0.push(data.load_n[i]);
        e.1.push(data.deflection_um[i]);
    }
    if groups.is_empty() {
        validate::enough_points(0, 2, "stiffness")?;
    }
    let mut reports = BTreeMap::new();
    for (g, (f, d)) in &groups {
        let what = if g.is_empty() {
            "stiffness".to_string()
        } else {
            format!("stiffness, direction `{g}`")
        };
        validate::enough_points(f.len(), 2, &what)?;
        let col = if g.is_empty() {
            "load_n".to_string()
        } else {
            format!("load_n (direction `{g}`)")
        };
        validate::not_constant(&col, f, "the stiffness (slope)")?;
        // Start from the linear fit of deflection on load (compliance), then refit in k.
        let x = DMatrix::from_fn(f.len(), 2, |i, j| if j == 0 { f[i] } else { 1.0 });
        let names = ["compliance_um_per_n".to_string(), "offset_um".to_string()];
        let lin = fit_linear(&names, &x, d, None, LinearMethod::Qr, "stiffness", "um")?;
        let c = lin.theta[0];
        if c.is_nan() || c <= 0.0 {
            return Err(IdentifyError::InvalidParameter {
                name: format!(
                    "slope of deflection_um over load_n{}",
                    if g.is_empty() {
                        String::new()
                    } else {
                        format!(" (direction `{g}`)")
                    }
                ),
                value: c,
                allowed: "> 0 (deflection must grow with load; check signs/units)",
            });
        }
        let specs = [
            ParamSpec::positive("stiffness_n_per_um", 1.0 / c),
            ParamSpec::free("offset_um", lin.theta[1]),
        ];
        let op = LoadDeflection {
            load_n: f.clone(),
            deflection_um: d.clone(),
        };
        let fit = fit_nonlinear(op, &specs, &opts.common.nls, "stiffness", "um")?;
        let prefix = if g.is_empty() {
            String::new()
        } else {
            format!("{g}_")
        };
        let label = if g.is_empty() {
            "all".to_string()
        } else {
            g.clone()
        };
        reports.insert(label, prefixed(fit.report, &prefix));
    }
    let mut report = if reports.len() == 1 {
        reports
            .values()
            .next()
            .cloned()
            .ok_or(IdentifyError::SolverState { what: "no group" })?
    } else {
        combine("stiffness", &reports)
    };

    let mut derived = BTreeMap::new();
    let has = |g: &str| {
        report
            .params
            .contains_key(&format!("{g}_stiffness_n_per_um"))
    };
    if has("radial") && has("axial") {
        for &t in &opts.tilt_deg {
            if let Some(d) = derive(
                &report,
                &["axial_stiffness_n_per_um", "radial_stiffness_n_per_um"],
                "1/(cos²α/k_axial + sin²α/k_radial)",
                |x| tilted_z_stiffness_n_per_um(x[0], x[1], t),
            ) {
                derived.insert(format!("z_stiffness_tilt_{}deg_n_per_um", fmt_num(t)), d);
            }
        }
    }
    let ks: Vec<String> = report
        .params
        .keys()
        .filter(|k| k.ends_with("stiffness_n_per_um") && !k.starts_with("machine_"))
        .cloned()
        .collect();
    if has("machine") {
        for k in &ks {
            if let Some(d) = derive(
                &report,
                &[k.as_str(), "machine_stiffness_n_per_um"],
                "1/(1/k_tool + 1/k_machine)",
                |x| series_stiffness_n_per_um(x[0], x[1]),
            ) {
                derived.insert(
                    format!(
                        "{}_with_machine_n_per_um",
                        k.trim_end_matches("_stiffness_n_per_um")
                    ),
                    d,
                );
            }
        }
    } else if let Some(km) = opts.machine_stiffness_n_per_um {
        report.fixed.insert("machine_stiffness_n_per_um".into(), km);
        for k in &ks {
            if let Some(d) = derive(
                &report,
                &[k.as_str()],
                "1/(1/k_tool + 1/k_machine), k_machine known",
                |x| series_stiffness_n_per_um(x[0], km),
            ) {
                let base = k
                    .trim_end_matches("stiffness_n_per_um")
                    .trim_end_matches('_');
                let base = if base.is_empty() { "tool" } else { base };
                derived.insert(format!("{base}_with_machine_n_per_um"), d);
            }
        }
    }
    for &t in &opts.tilt_deg {
        report.fixed.insert(format!("tilt_{}deg", fmt_num(t)), t);
    }
    let groups_out = if reports.len() > 1 {
        reports
    } else {
        BTreeMap::new()
    };
    Ok(Identified::new("stiffness", report, derived, groups_out))
}

fn fmt_num(x: f64) -> String {
    if x.fract() == 0.0 {
        format!("{}", x as i64)
    } else {
        format!("{x}").replace('.', "p")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobian_check::check_jacobian;

    #[test]
    fn jacobian_matches_fd() {
        let op = LoadDeflection {
            load_n: vec![0.5, 1.0, 5.0],
            deflection_um: vec![0.0; 3],
        };
        let c = check_jacobian(&op, &DVector::from_vec(vec![0.114, 0.3]), 1e-6).unwrap();
        assert!(c.ok, "{c:?}");
    }

    #[test]
    fn tilted_formula() {
        // α = 0 → axial (exact limit of eq. 21's reconstruction); 20° with Table 5-1's measured
        // 1.220 / 0.114 N/µm → 1/(cos²20°/1.22 + sin²20°/0.114) = 0.5710 N/µm (sim docs: 0.571,
        // published 0.597, 000 §6.1).
        assert!((tilted_z_stiffness_n_per_um(1.22, 0.114, 0.0) - 1.22).abs() < 1e-12);
        assert!((tilted_z_stiffness_n_per_um(1.22, 0.114, 20.0) - 0.5710).abs() < 5e-4);
        assert!(tilted_z_stiffness_n_per_um(1.22, 0.114, 90.0).is_nan());
    }

    #[test]
    fn constant_load_is_an_error() {
        let l = [1.0; 5];
        let d = [1.0, 2.0, 3.0, 4.0, 5.0];
        let e = identify_stiffness(
            &StiffnessData {
                load_n: &l,
                deflection_um: &d,
                direction: None,
            },
            &StiffnessOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(e, IdentifyError::ConstantInput { .. }), "{e}");
    }
}
