//! `identify kienzle`: Kienzle's coefficients of a flat end mill (`003_…txt`'s system) from the
//! revolution-mean forces of calibration cuts.
//!
//! Forward model: the physics crate's [`KienzleMillingModel::mean_forces_with_jacobian`] (Kienzle's law
//! per edge element, helix, down-milling engagement `ae`; no edge forces, no runout), evaluated for
//! each cut's feed per tooth `fz_mm`, axial depth `ap_mm` and radial depth `ae_mm`. Data: any of the
//! mean feed-direction force `mean_fx_n` and the mean force orthogonal to the feed `mean_fy_n` (on the
//! tool, `crate` sign convention of the physics crate). Free parameters: `kc11_n_mm2`, `mc`,
//! `kr11_n_mm2`, `mr` (any subset; the others at the base model's values). In a full slot `mean_fy_n`
//! sees kc1.1 and mc only and `mean_fx_n` kr1.1 and mr only; the feed per tooth must vary for an
//! exponent to be identifiable.

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_sim::kienzle::{EndMill, KienzleCoefficients, KienzleMillingModel};
use nalgebra::{DMatrix, DVector};

use super::Identified;
use super::thermal::CommonOptions;
use crate::error::{IdentifyError, Result};
use crate::nonlinear::{ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;

/// The parameter names, in the physics crate's Jacobian order.
pub const KIENZLE_PARAMS: [&str; 4] = ["kc11_n_mm2", "mc", "kr11_n_mm2", "mr"];

/// Calibration cuts: conditions per row and the measured mean forces.
#[derive(Debug, Clone, Copy)]
pub struct KienzleData<'a> {
    /// Feed per tooth (mm).
    pub fz_mm: &'a [f64],
    /// Axial depth of cut (mm).
    pub ap_mm: &'a [f64],
    /// Radial depth of cut (mm).
    pub ae_mm: &'a [f64],
    /// Revolution-mean force along the feed (N), optional.
    pub mean_fx_n: Option<&'a [f64]>,
    /// Revolution-mean force orthogonal to the feed (N), optional.
    pub mean_fy_n: Option<&'a [f64]>,
}

/// Options of [`identify_kienzle`].
#[derive(Debug, Clone)]
pub struct KienzleOptions {
    /// Common options.
    pub common: CommonOptions,
    /// The tool (catalogue: diameter, teeth, helix).
    pub tool: EndMill,
    /// Starting values and the values of the parameters held fixed (the handbook's).
    pub start: KienzleCoefficients,
    /// Parameters to estimate (names of [`KIENZLE_PARAMS`]; empty: those the data can see — kc1.1 and
    /// mc with `mean_fy_n`, kr1.1 and mr with `mean_fx_n`).
    pub free: Vec<String>,
}

impl Default for KienzleOptions {
    /// 003's tool, C45's handbook values, the parameters the data can see free.
    fn default() -> Self {
        Self {
            common: CommonOptions::default(),
            tool: EndMill::brecher_003(),
            start: KienzleCoefficients::c45_handbook(),
            free: Vec::new(),
        }
    }
}

/// Residual operator: `model − measured` for each (row, force) observed, parameters in the order of
/// `free` (indices into [`KIENZLE_PARAMS`]).
#[derive(Debug, Clone)]
pub struct KienzleResiduals {
    model: KienzleMillingModel,
    free: Vec<usize>,
    rows: Vec<(f64, f64, f64)>,
    /// (row, force index 0 = x / 1 = y, measured)
    obs: Vec<(usize, usize, f64)>,
}

impl KienzleResiduals {
    fn with(&self, p: &DVector<f64>) -> KienzleMillingModel {
        let mut m = self.model.clone();
        for (k, &i) in self.free.iter().enumerate() {
            let c = &mut m.coefficients;
            match i {
                0 => c.kc11_n_mm2 = p[k],
                1 => c.mc = p[k],
                2 => c.kr11_n_mm2 = p[k],
                _ => c.mr = p[k],
            }
        }
        m
    }

    fn eval(&self, p: &DVector<f64>, jac: bool) -> (DVector<f64>, DMatrix<f64>) {
        let m = self.with(p);
        let cache: Vec<([f64; 2], [[f64; 4]; 2])> = self
            .rows
            .iter()
            .map(|&(fz, ap, ae)| m.mean_forces_with_jacobian(fz, ap, ae))
            .collect();
        let r = DVector::from_iterator(
            self.obs.len(),
            self.obs.iter().map(|&(row, i, y)| cache[row].0[i] - y),
        );
        let j = if jac {
            DMatrix::from_fn(self.obs.len(), self.free.len(), |o, k| {
                let (row, i, _) = self.obs[o];
                cache[row].1[i][self.free[k]]
            })
        } else {
            DMatrix::zeros(0, 0)
        };
        (r, j)
    }
}

impl Operator for KienzleResiduals {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        Ok(self.eval(p, false).0)
    }
}

impl Jacobian for KienzleResiduals {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        Ok(self.eval(p, true).1)
    }
}

impl ResidualModel for KienzleResiduals {}

/// Fits Kienzle's coefficients to the mean forces of calibration cuts.
///
/// # Errors
/// * [`IdentifyError::MissingColumn`] when neither `mean_fx_n` nor `mean_fy_n` is given, or for an
///   unknown name in `free`;
/// * [`IdentifyError::LengthMismatch`], [`IdentifyError::NonFinite`] naming the column and row;
/// * [`IdentifyError::InvalidParameter`] for a cut whose `fz_mm`, `ap_mm` or `ae_mm` is not positive
///   (or `ae_mm` above the tool diameter), or a tool or start the physics crate rejects;
/// * [`IdentifyError::ConstantInput`] when an exponent is free and `fz_mm` does not vary;
/// * [`IdentifyError::TooFewPoints`].
///
/// # Examples
/// ```
/// use millcomp_identify::targets::kienzle::*;
/// use millcomp_sim::kienzle::{KienzleCoefficients, KienzleMillingModel, EndMill};
/// // full slots of 003's tool in a material 10 % stronger than the handbook's C45, mc 0.20
/// let truth = KienzleCoefficients { kc11_n_mm2: 2442.0, mc: 0.20, kr11_n_mm2: 900.0, mr: 0.14 };
/// let m = KienzleMillingModel::new(truth, EndMill::brecher_003()).unwrap();
/// let fz = [0.03, 0.06, 0.09, 0.12, 0.03, 0.06, 0.09, 0.12];
/// let ap = [4.0, 4.0, 4.0, 4.0, 8.0, 8.0, 8.0, 8.0];
/// let ae = [16.0; 8];
/// let (fx, fy): (Vec<f64>, Vec<f64>) = (0..8)
///     .map(|i| { let f = m.mean_forces(fz[i], ap[i], ae[i]); (f[0], f[1]) })
///     .unzip();
/// let data = KienzleData { fz_mm: &fz, ap_mm: &ap, ae_mm: &ae, mean_fx_n: Some(&fx), mean_fy_n: Some(&fy) };
/// let fit = identify_kienzle(&data, &KienzleOptions::default()).unwrap();
/// assert!((fit.report.param("kc11_n_mm2") - 2442.0).abs() < 1e-3);
/// assert!((fit.report.param("mc") - 0.20).abs() < 1e-6);
/// assert_eq!(fit.kind, "kienzle");
/// ```
pub fn identify_kienzle(data: &KienzleData<'_>, opts: &KienzleOptions) -> Result<Identified> {
    let n = data.fz_mm.len();
    validate::same_len("ap_mm", data.ap_mm, "fz_mm", n)?;
    validate::same_len("ae_mm", data.ae_mm, "fz_mm", n)?;
    for (name, col) in [
        ("fz_mm", data.fz_mm),
        ("ap_mm", data.ap_mm),
        ("ae_mm", data.ae_mm),
    ] {
        validate::finite(name, col)?;
        if let Some(i) = col.iter().position(|v| *v <= 0.0) {
            return Err(IdentifyError::InvalidParameter {
                name: format!("{name} (row {})", i + 1),
                value: col[i],
                allowed: "> 0",
            });
        }
    }
    if let Some(i) = data
        .ae_mm
        .iter()
        .position(|v| *v > opts.tool.diameter_mm + 1e-9)
    {
        return Err(IdentifyError::InvalidParameter {
            name: format!("ae_mm (row {})", i + 1),
            value: data.ae_mm[i],
            allowed: "<= the tool diameter",
        });
    }
    let mut obs = Vec::new();
    for (i, name, col) in [
        (0, "mean_fx_n", data.mean_fx_n),
        (1, "mean_fy_n", data.mean_fy_n),
    ] {
        if let Some(c) = col {
            validate::same_len(name, c, "fz_mm", n)?;
            validate::finite(name, c)?;
            obs.extend(c.iter().enumerate().map(|(row, y)| (row, i, *y)));
        }
    }
    if obs.is_empty() {
        return Err(IdentifyError::MissingColumn {
            column: "mean_fx_n or mean_fy_n".into(),
            reason: "the kienzle target needs at least one measured mean force".into(),
        });
    }
    let free: Vec<usize> = if opts.free.is_empty() {
        let mut f = Vec::new();
        if data.mean_fy_n.is_some() {
            f.extend([0, 1]);
        }
        if data.mean_fx_n.is_some() {
            f.extend([2, 3]);
        }
        f
    } else {
        opts.free
            .iter()
            .map(|name| {
                KIENZLE_PARAMS
                    .iter()
                    .position(|p| p == name)
                    .ok_or_else(|| IdentifyError::MissingColumn {
                        column: name.clone(),
                        reason: format!(
                            "unknown Kienzle parameter; allowed {}",
                            KIENZLE_PARAMS.join(", ")
                        ),
                    })
            })
            .collect::<Result<Vec<_>>>()?
    };
    if free.iter().any(|&i| i == 1 || i == 3) {
        validate::not_constant("fz_mm", data.fz_mm, "the exponents mc, mr")?;
    }
    validate::enough_points(obs.len(), free.len(), "kienzle")?;
    let model = KienzleMillingModel::new(opts.start, opts.tool).map_err(|source| {
        IdentifyError::Physics {
            model: "kienzle".into(),
            source,
        }
    })?;
    let start = [
        opts.start.kc11_n_mm2,
        opts.start.mc,
        opts.start.kr11_n_mm2,
        opts.start.mr,
    ];
    let specs: Vec<ParamSpec> = free
        .iter()
        .map(|&i| match i {
            0 | 2 => ParamSpec::positive(KIENZLE_PARAMS[i], start[i].max(1.0)),
            _ => ParamSpec::bounded(KIENZLE_PARAMS[i], start[i].clamp(0.01, 0.8), 0.0, 0.9),
        })
        .collect();
    let op = KienzleResiduals {
        model,
        free: free.clone(),
        rows: (0..n)
            .map(|i| (data.fz_mm[i], data.ap_mm[i], data.ae_mm[i]))
            .collect(),
        obs,
    };
    let mut report = fit_nonlinear(op, &specs, &opts.common.nls, "kienzle", "n")?.report;
    for (i, name) in KIENZLE_PARAMS.iter().enumerate() {
        if !free.contains(&i) {
            report.fixed.insert((*name).into(), start[i]);
        }
    }
    report
        .fixed
        .insert("diameter_mm".into(), opts.tool.diameter_mm);
    report.fixed.insert("teeth".into(), opts.tool.teeth as f64);
    report.fixed.insert("helix_deg".into(), opts.tool.helix_deg);
    Ok(Identified::new(
        "kienzle",
        report,
        BTreeMap::new(),
        BTreeMap::new(),
    ))
}
