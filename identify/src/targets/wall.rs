//! `identify wall`: the thin wall's effective stiffness from force and deflection (`004_…txt` §3.1).
//!
//! The wall is a cantilever loaded by the cutting force normal to it (eqs 1–18): the deflection
//! at the load point is proportional to the force, `deflection_um = offset_um + force_n /
//! wall_stiffness_n_per_um`, fitted like a stiffness (the same residual operator). When the wall
//! geometry is known, the effective modulus is derived with its delta-method interval from the
//! tip deflection of eq. (18) at `z = l` with a constant section: `w = F l³/(3 E I)`,
//! `I = b h³/12` (eq. 14) ⇒ `E = k l³/(3 I)` — a check on the model (H59 brass: E = 100 GPa,
//! `004_…txt` Table 4).

use std::collections::BTreeMap;

use nalgebra::DMatrix;

use super::stiffness::LoadDeflection;
use super::thermal::CommonOptions;
use super::{Identified, derive};
use crate::error::{IdentifyError, Result};
use crate::linear::{LinearMethod, fit_linear};
use crate::nonlinear::{ParamSpec, fit_nonlinear};
use crate::validate;

/// Force–deflection data of a thin wall (columns `force_n`, `deflection_um`).
#[derive(Debug, Clone, Copy)]
pub struct WallData<'a> {
    /// Force normal to the wall, N.
    pub force_n: &'a [f64],
    /// Wall deflection at the load point, µm.
    pub deflection_um: &'a [f64],
}

/// Wall geometry (`004_…txt` Fig. 5: height l, thickness h, length b).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallGeometry {
    /// Height l of the wall above the clamp (load at the top), µm.
    pub height_um: f64,
    /// Thickness h, µm.
    pub thickness_um: f64,
    /// Length b along the wall, µm.
    pub length_um: f64,
}

/// Options of [`identify_wall`].
#[derive(Debug, Clone, Default)]
pub struct WallOptions {
    /// Common options.
    pub common: CommonOptions,
    /// Geometry, to derive the effective modulus `e_gpa`.
    pub geometry: Option<WallGeometry>,
}

/// Cantilever tip stiffness `3EI/l³` with `I = b h³/12` (eqs 14, 18 at z = l), N/µm.
pub fn cantilever_tip_stiffness_n_per_um(e_gpa: f64, g: &WallGeometry) -> f64 {
    let e = e_gpa * 1e3; // N/mm² → work in mm: N/mm
    let (l, h, b) = (
        g.height_um * 1e-3,
        g.thickness_um * 1e-3,
        g.length_um * 1e-3,
    );
    let i = b * h.powi(3) / 12.0;
    3.0 * e * i / l.powi(3) * 1e-3 // N/mm → N/µm
}

/// Fits the wall's effective stiffness (and the effective modulus when the geometry is given).
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] when `deflection_um` is not as long as `force_n`;
/// * [`IdentifyError::NonFinite`] naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::TooFewPoints`] for fewer than 3 rows;
/// * [`IdentifyError::ConstantInput`] when `force_n` does not vary;
/// * [`IdentifyError::InvalidParameter`] for a geometry dimension that is not a finite positive
///   number, or a deflection that does not grow with the force (slope ≤ 0);
/// * the errors of [`fit_nonlinear`] (not expected once the checks above have passed).
///
/// # Examples
/// ```
/// use millcomp_identify::targets::wall::*;
/// let g = WallGeometry { height_um: 800.0, thickness_um: 100.0, length_um: 5000.0 };
/// let k = cantilever_tip_stiffness_n_per_um(100.0, &g); // H59 brass, 004 Table 4
/// let f: Vec<f64> = (1..=12).map(|i| 0.1 * i as f64).collect();
/// let d: Vec<f64> = f.iter().enumerate().map(|(i, f)| f / k + 0.01 * ((i % 3) as f64 - 1.0)).collect();
/// let fit = identify_wall(&WallData { force_n: &f, deflection_um: &d },
///                         &WallOptions { geometry: Some(g), ..Default::default() }).unwrap();
/// assert!((fit.derived["e_gpa"].value - 100.0).abs() < 2.0);
/// // 3EI/l³ by hand: 3 · 1e5 N/mm² · (5 · 0.1³/12) mm⁴ / 0.8³ mm³ = 244.14 N/mm
/// assert!((k - 0.244140625).abs() < 1e-12);
/// // the fitted modulus's interval covers the 100 GPa the data were made with
/// let ci = fit.derived["e_gpa"].ci95;
/// assert!(ci[0] < 100.0 && 100.0 < ci[1]);
/// assert!((fit.derived["e_gpa"].value - 99.864).abs() < 1e-3);
/// ```
pub fn identify_wall(data: &WallData<'_>, opts: &WallOptions) -> Result<Identified> {
    let n = data.force_n.len();
    validate::same_len("deflection_um", data.deflection_um, "force_n", n)?;
    validate::finite("force_n", data.force_n)?;
    validate::finite("deflection_um", data.deflection_um)?;
    validate::enough_points(n, 2, "wall")?;
    validate::not_constant("force_n", data.force_n, "wall_stiffness_n_per_um")?;
    if let Some(g) = &opts.geometry {
        for (name, v) in [
            ("height_um", g.height_um),
            ("thickness_um", g.thickness_um),
            ("length_um", g.length_um),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(IdentifyError::InvalidParameter {
                    name: name.into(),
                    value: v,
                    allowed: "> 0 and finite",
                });
            }
        }
    }
    let x = DMatrix::from_fn(n, 2, |i, j| if j == 0 { data.force_n[i] } else { 1.0 });
    let names = ["compliance_um_per_n".to_string(), "offset_um".to_string()];
    let lin = fit_linear(
        &names,
        &x,
        data.deflection_um,
        None,
        LinearMethod::Qr,
        "wall",
        "um",
    )?;
    if lin.theta[0].is_nan() || lin.theta[0] <= 0.0 {
        return Err(IdentifyError::InvalidParameter {
            name: "slope of deflection_um over force_n".into(),
            value: lin.theta[0],
            allowed: "> 0 (deflection must grow with force; check signs/units)",
        });
    }
    let specs = [
        ParamSpec::positive("wall_stiffness_n_per_um", 1.0 / lin.theta[0]),
        ParamSpec::free("offset_um", lin.theta[1]),
    ];
    let op = LoadDeflection {
        load_n: data.force_n.to_vec(),
        deflection_um: data.deflection_um.to_vec(),
    };
    let mut report = fit_nonlinear(op, &specs, &opts.common.nls, "wall", "um")?.report;
    let mut derived = BTreeMap::new();
    if let Some(g) = opts.geometry {
        let k1 = cantilever_tip_stiffness_n_per_um(1.0, &g);
        if let Some(d) = derive(
            &report,
            &["wall_stiffness_n_per_um"],
            "E = k l³/(3 b h³/12)",
            |x| x[0] / k1,
        ) {
            derived.insert("e_gpa".to_string(), d);
        }
        report.fixed.insert("height_um".into(), g.height_um);
        report.fixed.insert("thickness_um".into(), g.thickness_um);
        report.fixed.insert("length_um".into(), g.length_um);
    }
    Ok(Identified::new("wall", report, derived, BTreeMap::new()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tip_stiffness_formula() {
        // 3EI/l³ by hand: E = 100 GPa = 1e5 N/mm², b = 5 mm, h = 0.1 mm → I = 5·1e-3/12 mm⁴,
        // l = 0.8 mm → k = 3·1e5·4.1667e-4/0.512 = 244.14 N/mm = 0.24414 N/µm.
        let g = WallGeometry {
            height_um: 800.0,
            thickness_um: 100.0,
            length_um: 5000.0,
        };
        assert!((cantilever_tip_stiffness_n_per_um(100.0, &g) - 0.244140625).abs() < 1e-9);
    }
}
