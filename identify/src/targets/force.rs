//! `identify force`: material and friction parameters of the ball-end cutting-force model
//! (`000_…txt` ch. 2, 4) from measured forces.
//!
//! Forward model: the physics crate's [`BallEndForceModel`] (eqs 4–10 as reconstructed there).
//! Two kinds of data:
//! * **peak forces per condition** ([`PeakForceData`], like Table 3-3): per row a cut
//!   (`depth_um`, `upfeed_um`, optional `speed_rpm`, `tilt_deg`) and any of `max_fx_n`,
//!   `max_fy_n`, `max_fz_n` = "the largest positive force per flute … averaged" (§3.5.1), i.e. the
//!   physics crate's [`BallEndForceModel::table33_response`] (per-flute maxima on a 3600-point
//!   revolution grid, averaged over the two flutes);
//! * **per-revolution traces** ([`ForceTraceData`]): per row a tool rotation angle `rot_deg`
//!   (θ = 0 at the start of chip formation of the first, lighter flute, §4) with the cut and any of
//!   `fx_n`, `fy_n`, `fz_n`; the model is [`BallEndForceModel::forces_at`].
//!
//! Free parameters (any subset of [`ForceParam`]): `w_mpa` (the material parameter W, Table 4-1
//! "modeled parameter", used by the physics crate in MPa), `mu_rake`, `mu_flank`, `wearland_um`,
//! `runout_um`; the others stay at the values of the base model in [`ForceOptions`].
//!
//! Jacobian: analytic from the physics crate ([`BallEndForceModel::forces_jacobian`]) for W, µ, µf
//! and WL — for peaks evaluated at the per-flute arg-max angle (envelope theorem: the derivative
//! of a maximum over a fixed grid is the derivative of the maximising sample) — and a central
//! difference at fixed angle for the runout, whose effect passes through the clamp `ξ ≤ 1`.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_sim::force::{BallEndForceModel, CutConditions};
use nalgebra::{DMatrix, DVector};

use super::Identified;
use super::thermal::CommonOptions;
use crate::error::{IdentifyError, Result};
use crate::nonlinear::{ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;

/// Grid of the peak search: the physics crate's `table33_response` samples 3600 angles.
pub const PEAK_GRID: usize = 3600;

/// A force-model parameter that can be identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ForceParam {
    /// Material parameter W (`w_mpa`).
    W,
    /// Rake-face friction µ (`mu_rake`).
    MuRake,
    /// Flank-face friction µf (`mu_flank`).
    MuFlank,
    /// Flank wearland WL (`wearland_um`).
    Wearland,
    /// Tool/spindle runout (`runout_um`).
    Runout,
}

impl ForceParam {
    /// Parameter name in reports (the physics crate's field name).
    pub fn name(&self) -> &'static str {
        match self {
            ForceParam::W => "w_mpa",
            ForceParam::MuRake => "mu_rake",
            ForceParam::MuFlank => "mu_flank",
            ForceParam::Wearland => "wearland_um",
            ForceParam::Runout => "runout_um",
        }
    }

    /// Parse a name as printed by [`ForceParam::name`] (for the CLI's `--free` option).
    ///
    /// # Errors
    /// [`IdentifyError::MissingColumn`] with the unknown name as `column` and the allowed names in
    /// the reason.
    pub fn parse(name: &str) -> Result<Self> {
        Ok(match name {
            "w_mpa" | "w" => ForceParam::W,
            "mu_rake" | "mu" => ForceParam::MuRake,
            "mu_flank" | "mu_f" => ForceParam::MuFlank,
            "wearland_um" => ForceParam::Wearland,
            "runout_um" => ForceParam::Runout,
            _ => {
                return Err(IdentifyError::MissingColumn {
                    column: name.into(),
                    reason: "unknown force parameter; allowed w_mpa, mu_rake, mu_flank, wearland_um, runout_um".into(),
                });
            }
        })
    }

    fn get(&self, m: &BallEndForceModel) -> f64 {
        match self {
            ForceParam::W => m.material.w_mpa,
            ForceParam::MuRake => m.material.mu_rake,
            ForceParam::MuFlank => m.material.mu_flank,
            ForceParam::Wearland => m.tool.wearland_um,
            ForceParam::Runout => m.tool.runout_um,
        }
    }

    fn set(&self, m: &mut BallEndForceModel, v: f64) {
        match self {
            ForceParam::W => m.material.w_mpa = v,
            ForceParam::MuRake => m.material.mu_rake = v,
            ForceParam::MuFlank => m.material.mu_flank = v,
            ForceParam::Wearland => m.tool.wearland_um = v,
            ForceParam::Runout => m.tool.runout_um = v,
        }
    }

    /// Column of the physics crate's analytic force Jacobian, `None` for runout.
    fn sim_column(&self) -> Option<usize> {
        match self {
            ForceParam::W => Some(0),
            ForceParam::MuRake => Some(1),
            ForceParam::MuFlank => Some(2),
            ForceParam::Wearland => Some(3),
            ForceParam::Runout => None,
        }
    }

    fn spec(&self, start: f64, m: &BallEndForceModel) -> ParamSpec {
        match self {
            ForceParam::W => ParamSpec::positive(self.name(), start),
            ForceParam::MuRake | ForceParam::MuFlank => {
                ParamSpec::bounded(self.name(), start, 0.0, 3.0)
            }
            ForceParam::Wearland => ParamSpec::bounded(self.name(), start, 0.0, m.tool.radius_um),
            ForceParam::Runout => ParamSpec::positive(self.name(), start),
        }
    }
}

/// Cut conditions per row.
#[derive(Debug, Clone, Copy)]
pub struct ForceConditions<'a> {
    /// Axial depth of cut, µm.
    pub depth_um: &'a [f64],
    /// Feed per revolution ("upfeed"), µm/rev.
    pub upfeed_um: &'a [f64],
    /// Spindle speed, rpm (does not enter the force model; default 10 000).
    pub speed_rpm: Option<&'a [f64]>,
    /// Tool tilt, deg (default [`ForceOptions::default_tilt_deg`]).
    pub tilt_deg: Option<&'a [f64]>,
}

/// Peak forces per condition (Table 3-3 style).
#[derive(Debug, Clone, Copy)]
pub struct PeakForceData<'a> {
    /// Conditions per row.
    pub conditions: ForceConditions<'a>,
    /// Max x force per flute, averaged, N.
    pub max_fx_n: Option<&'a [f64]>,
    /// Max y force, N.
    pub max_fy_n: Option<&'a [f64]>,
    /// Max z force, N.
    pub max_fz_n: Option<&'a [f64]>,
}

/// Per-revolution force traces.
#[derive(Debug, Clone, Copy)]
pub struct ForceTraceData<'a> {
    /// Conditions per row.
    pub conditions: ForceConditions<'a>,
    /// Tool rotation angle, deg.
    pub rot_deg: &'a [f64],
    /// Force x, N.
    pub fx_n: Option<&'a [f64]>,
    /// Force y, N.
    pub fy_n: Option<&'a [f64]>,
    /// Force z, N.
    pub fz_n: Option<&'a [f64]>,
}

/// Either kind of force data.
#[derive(Debug, Clone, Copy)]
pub enum ForceData<'a> {
    /// Peak forces per condition.
    Peaks(PeakForceData<'a>),
    /// Per-revolution traces.
    Traces(ForceTraceData<'a>),
}

/// Options of [`identify_force`].
#[derive(Debug, Clone)]
pub struct ForceOptions {
    /// Common options.
    pub common: CommonOptions,
    /// Model providing the fixed parameters and the starting values (material, tool, constants).
    pub base: BallEndForceModel,
    /// Parameters to estimate (default: W only, the thesis' own procedure — "the material parameter
    /// was manually adjusted to match the force data", §4.1).
    pub free: Vec<ForceParam>,
    /// Tilt when the data have no `tilt_deg` column.
    pub default_tilt_deg: f64,
    /// Weight residuals by 1/measured² (relative errors) instead of equally.
    pub relative_errors: bool,
}

impl Default for ForceOptions {
    /// 6061 aluminium (Table 4-1), the physics crate's default Ø0.8 mm tool, W free.
    fn default() -> Self {
        ForceOptions {
            common: CommonOptions::default(),
            base: BallEndForceModel {
                material: millcomp_sim::material::Material::al6061(),
                ..BallEndForceModel::default()
            },
            free: vec![ForceParam::W],
            default_tilt_deg: 0.0,
            relative_errors: false,
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Obs {
    /// Peak of component `comp` for condition index `cond`.
    Peak { cond: usize, comp: usize },
    /// Force component `comp` at angle `rot` for condition index `cond`.
    Trace { cond: usize, comp: usize, rot: f64 },
}

/// Residual operator of the force fit (parameters: the free [`ForceParam`]s in order).
pub struct ForceResidual {
    base: BallEndForceModel,
    free: Vec<ForceParam>,
    conds: Vec<CutConditions>,
    obs: Vec<Obs>,
    y: Vec<f64>,
    sw: Vec<f64>,
    weighted: bool,
}

impl ForceResidual {
    /// The physics model at parameter vector `p`.
    pub fn model(&self, p: &DVector<f64>) -> std::result::Result<BallEndForceModel, ArgminError> {
        let mut m = self.base.clone();
        for (k, par) in self.free.iter().enumerate() {
            par.set(&mut m, p[k]);
        }
        m.validate()?;
        Ok(m)
    }

    /// Model predictions (N) and optionally the Jacobian of the predictions.
    fn predict(
        &self,
        p: &DVector<f64>,
        want_jac: bool,
    ) -> std::result::Result<(Vec<f64>, Option<DMatrix<f64>>), ArgminError> {
        let m = self.model(p)?;
        let nf = self.free.len();
        // Per condition: revolution and per-flute arg-max angles of each component (peaks only).
        let need_peaks = self.obs.iter().any(|o| matches!(o, Obs::Peak { .. }));
        let mut argmax: Vec<[[f64; 2]; 3]> = Vec::new();
        let mut peakval: Vec<[f64; 3]> = Vec::new();
        if need_peaks {
            for c in &self.conds {
                let rev = m.revolution(c, PEAK_GRID)?;
                let mut best = [[(f64::NEG_INFINITY, 0usize); 2]; 3];
                for (k, f) in rev.iter().enumerate() {
                    let flute = if 2 * k < PEAK_GRID { 0 } else { 1 };
                    for i in 0..3 {
                        if f[i] > best[i][flute].0 {
                            best[i][flute] = (f[i], k);
                        }
                    }
                }
                let ang = |k: usize| 2.0 * PI * k as f64 / PEAK_GRID as f64;
                argmax.push([
                    [ang(best[0][0].1), ang(best[0][1].1)],
                    [ang(best[1][0].1), ang(best[1][1].1)],
                    [ang(best[2][0].1), ang(best[2][1].1)],
                ]);
                peakval.push([
                    0.5 * (best[0][0].0 + best[0][1].0),
                    0.5 * (best[1][0].0 + best[1][1].0),
                    0.5 * (best[2][0].0 + best[2][1].0),
                ]);
            }
        }
        let prepared: Vec<_> = self.conds.iter().map(|c| m.prepare(c)).collect();
        let mut out = Vec::with_capacity(self.obs.len());
        let mut jac = want_jac.then(|| DMatrix::zeros(self.obs.len(), nf));
        // d(force comp at angle)/d(params) for one angle.
        let grad_at = |c: &CutConditions,
                       rot: f64,
                       comp: usize|
         -> std::result::Result<Vec<f64>, ArgminError> {
            let js = m.forces_jacobian(c, rot);
            let mut g = vec![0.0; nf];
            for (k, par) in self.free.iter().enumerate() {
                g[k] = match par.sim_column() {
                    Some(col) => js[comp][col],
                    None => {
                        let v = par.get(&m);
                        let h = 1e-6 * v.abs().max(1.0);
                        let mut mp = m.clone();
                        let mut mm = m.clone();
                        par.set(&mut mp, v + h);
                        par.set(&mut mm, (v - h).max(0.0));
                        let d = par.get(&mp) - par.get(&mm);
                        (mp.forces_at(c, rot)[comp] - mm.forces_at(c, rot)[comp]) / d
                    }
                };
            }
            Ok(g)
        };
        for (row, o) in self.obs.iter().enumerate() {
            match *o {
                Obs::Peak { cond, comp } => {
                    out.push(peakval[cond][comp]);
                    if let Some(j) = jac.as_mut() {
                        let g0 = grad_at(&self.conds[cond], argmax[cond][comp][0], comp)?;
                        let g1 = grad_at(&self.conds[cond], argmax[cond][comp][1], comp)?;
                        for k in 0..nf {
                            j[(row, k)] = 0.5 * (g0[k] + g1[k]);
                        }
                    }
                }
                Obs::Trace { cond, comp, rot } => {
                    out.push(prepared[cond].forces(rot)[comp]);
                    if let Some(j) = jac.as_mut() {
                        let g = grad_at(&self.conds[cond], rot, comp)?;
                        for k in 0..nf {
                            j[(row, k)] = g[k];
                        }
                    }
                }
            }
        }
        Ok((out, jac))
    }
}

impl Operator for ForceResidual {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let (f, _) = self.predict(p, false)?;
        Ok(DVector::from_iterator(
            f.len(),
            f.iter()
                .zip(&self.y)
                .zip(&self.sw)
                .map(|((f, y), s)| (f - y) * s),
        ))
    }
}

impl Jacobian for ForceResidual {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let (_, j) = self.predict(p, true)?;
        let mut j = j.ok_or_else(|| ArgminError::msg("jacobian not computed"))?;
        for (i, s) in self.sw.iter().enumerate() {
            j.row_mut(i).scale_mut(*s);
        }
        Ok(j)
    }
}

impl ResidualModel for ForceResidual {
    fn sqrt_weights(&self) -> Option<&[f64]> {
        self.weighted.then_some(self.sw.as_slice())
    }
}

fn conditions(
    c: &ForceConditions<'_>,
    n: usize,
    opts: &ForceOptions,
) -> Result<Vec<CutConditions>> {
    validate::same_len("depth_um", c.depth_um, "rows", n)?;
    validate::same_len("upfeed_um", c.upfeed_um, "rows", n)?;
    validate::finite("depth_um", c.depth_um)?;
    validate::finite("upfeed_um", c.upfeed_um)?;
    if let Some(s) = c.speed_rpm {
        validate::same_len("speed_rpm", s, "rows", n)?;
        validate::finite("speed_rpm", s)?;
    }
    if let Some(t) = c.tilt_deg {
        validate::same_len("tilt_deg", t, "rows", n)?;
        validate::finite("tilt_deg", t)?;
    }
    (0..n)
        .map(|i| {
            let cond = CutConditions {
                depth_um: c.depth_um[i],
                upfeed_um: c.upfeed_um[i],
                speed_rpm: c.speed_rpm.map(|s| s[i]).unwrap_or(10_000.0),
                tilt_deg: c.tilt_deg.map(|t| t[i]).unwrap_or(opts.default_tilt_deg),
            };
            opts.base
                .check_conditions(&cond)
                .map_err(|source| IdentifyError::RejectedConditions { row: i + 1, source })?;
            Ok(cond)
        })
        .collect()
}

/// A force column with its name, if present.
type NamedColumn<'a> = Option<(&'static str, &'a [f64])>;

/// Identifies force-model parameters from peak forces or per-revolution traces.
///
/// # Errors
/// * [`IdentifyError::MissingColumn`] for an empty `opts.free` (`free`) or data without any force
///   component;
/// * [`IdentifyError::LengthMismatch`] when a condition or force column is not as long as the
///   rows (`depth_um` for peaks, `rot_deg` for traces);
/// * [`IdentifyError::NonFinite`] naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::RejectedConditions`] naming the row whose cut the physics crate rejects
///   (depth beyond the ball radius or negative, upfeed or speed ≤ 0, tilt outside `[0, 90)`);
///   sim's error is the source;
/// * [`IdentifyError::TooFewPoints`] unless there are more observations than free parameters
///   and, for peaks, at least as many distinct cut conditions as free parameters;
/// * [`IdentifyError::InvalidParameter`] for a zero force observation with
///   `opts.relative_errors` (weight 1/|F|);
/// * [`IdentifyError::ModelEvaluation`] when the base model cannot be evaluated (e.g. a base
///   material outside sim's ranges);
/// * the errors of [`fit_nonlinear`], e.g. [`IdentifyError::InitialOutsideBounds`] for a base
///   friction coefficient outside `(0, 3)` when it is free.
///
/// # Examples
/// ```
/// use millcomp_identify::targets::force::*;
/// // 000 Table 3-3: 6061, 2³ DOE in depth (µm), speed (rpm) and upfeed (µm/rev), max X/Y/Z force (N)
/// let depth = [200.0, 100.0, 100.0, 200.0, 200.0, 100.0, 200.0, 100.0];
/// let speed = [1e4, 1e4, 2e4, 2e4, 2e4, 2e4, 1e4, 1e4];
/// let upfeed = [20.0, 20.0, 10.0, 10.0, 20.0, 20.0, 10.0, 10.0];
/// let fx = [3.34, 1.78, 0.94, 1.91, 3.60, 2.20, 2.20, 1.00];
/// let fy = [1.75, 1.33, 0.93, 1.64, 2.30, 1.75, 2.10, 1.10];
/// let fz = [2.17, 1.24, 0.59, 0.83, 2.00, 1.50, 1.40, 0.82];
/// let conditions = ForceConditions { depth_um: &depth, upfeed_um: &upfeed, speed_rpm: Some(&speed), tilt_deg: None };
/// let data = ForceData::Peaks(PeakForceData { conditions, max_fx_n: Some(&fx), max_fy_n: Some(&fy), max_fz_n: Some(&fz) });
/// // W free (the thesis' own procedure, §4.1), everything else 6061 and the default tool
/// let fit = identify_force(&data, &ForceOptions::default()).unwrap();
/// let r = &fit.report;
/// assert_eq!((r.n_obs, r.dof), (24, 23));
/// // least squares on the 24 peaks: W = 2049 MPa, SE 173, 95 % interval [1691, 2407]; the thesis
/// // set W = 2500 by hand (Table 4-1), outside that interval
/// assert!((r.param("w_mpa") - 2049.0).abs() < 1.0 && (r.se("w_mpa") - 173.0).abs() < 1.0);
/// let ci = r.ci95["w_mpa"];
/// assert!((ci[0] - 1691.1).abs() < 1.0 && (ci[1] - 2406.9).abs() < 1.0);
/// // the residuals in row order are correlated (the model's shape, not noise): the report says so
/// assert!(r.warnings.iter().any(|w| w.contains("autocorrelated")));
///
/// // 450 µm is deeper than the Ø0.8 mm ball: the row is named
/// let deep = [450.0, 100.0, 100.0, 200.0, 200.0, 100.0, 200.0, 100.0];
/// let conditions = ForceConditions { depth_um: &deep, ..conditions };
/// let data = ForceData::Peaks(PeakForceData { conditions, max_fx_n: Some(&fx), max_fy_n: None, max_fz_n: None });
/// let e = identify_force(&data, &ForceOptions::default());
/// assert!(matches!(e, Err(millcomp_identify::IdentifyError::RejectedConditions { row: 1, .. })));
/// ```
pub fn identify_force(data: &ForceData<'_>, opts: &ForceOptions) -> Result<Identified> {
    if opts.free.is_empty() {
        return Err(IdentifyError::MissingColumn {
            column: "free".into(),
            reason: "no force parameter to identify".into(),
        });
    }
    let mut free = opts.free.clone();
    free.sort();
    free.dedup();
    let (n, conds_in, comps): (usize, ForceConditions<'_>, [NamedColumn<'_>; 3]) = match data {
        ForceData::Peaks(d) => (
            d.conditions.depth_um.len(),
            d.conditions,
            [
                d.max_fx_n.map(|v| ("max_fx_n", v)),
                d.max_fy_n.map(|v| ("max_fy_n", v)),
                d.max_fz_n.map(|v| ("max_fz_n", v)),
            ],
        ),
        ForceData::Traces(d) => (
            d.rot_deg.len(),
            d.conditions,
            [
                d.fx_n.map(|v| ("fx_n", v)),
                d.fy_n.map(|v| ("fy_n", v)),
                d.fz_n.map(|v| ("fz_n", v)),
            ],
        ),
    };
    if comps.iter().all(|c| c.is_none()) {
        return Err(IdentifyError::MissingColumn {
            column: "max_fx_n/max_fy_n/max_fz_n (or fx_n/fy_n/fz_n)".into(),
            reason: "at least one force component is needed".into(),
        });
    }
    for (name, v) in comps.iter().flatten() {
        validate::same_len(name, v, "depth_um", n)?;
        validate::finite(name, v)?;
        // a peak is the largest force over a revolution: a negative one is a sign error, which the
        // fit would otherwise answer with W pinned at 0
        if matches!(data, ForceData::Peaks(_))
            && let Some(i) = v.iter().position(|&f| f < 0.0)
        {
            return Err(IdentifyError::InvalidParameter {
                name: format!("{name}, row {}", i + 1),
                value: v[i],
                allowed: ">= 0 N (a peak force over a revolution; a sign error?)",
            });
        }
    }
    if let ForceData::Traces(d) = data {
        validate::finite("rot_deg", d.rot_deg)?;
    }
    let rows = conditions(&conds_in, n, opts)?;
    // Distinct conditions (bitwise) → shared revolution per condition.
    let mut conds: Vec<CutConditions> = Vec::new();
    let mut cond_of_row = Vec::with_capacity(n);
    for r in &rows {
        let idx = conds.iter().position(|c| c == r).unwrap_or_else(|| {
            conds.push(*r);
            conds.len() - 1
        });
        cond_of_row.push(idx);
    }
    let mut obs = Vec::new();
    let mut y = Vec::new();
    for (comp, c) in comps.iter().enumerate() {
        if let Some((_, v)) = c {
            for i in 0..n {
                obs.push(match data {
                    ForceData::Peaks(_) => Obs::Peak {
                        cond: cond_of_row[i],
                        comp,
                    },
                    ForceData::Traces(d) => Obs::Trace {
                        cond: cond_of_row[i],
                        comp,
                        rot: d.rot_deg[i].to_radians(),
                    },
                });
                y.push(v[i]);
            }
        }
    }
    validate::enough_points(y.len(), free.len(), "force")?;
    if matches!(data, ForceData::Peaks(_)) && conds.len() < free.len() {
        return Err(IdentifyError::TooFewPoints {
            got: conds.len(),
            n_params: free.len(),
            needed: free.len(),
            what: "force: distinct cut conditions".into(),
        });
    }
    let sw: Vec<f64> = if opts.relative_errors {
        y.iter()
            .enumerate()
            .map(|(i, v)| {
                if v.abs() > 0.0 {
                    Ok(1.0 / v.abs())
                } else {
                    Err(IdentifyError::InvalidParameter {
                        name: format!("force observation {i}"),
                        value: *v,
                        allowed: "non-zero with relative_errors (weight 1/|F|)",
                    })
                }
            })
            .collect::<Result<_>>()?
    } else {
        vec![1.0; y.len()]
    };
    let op = ForceResidual {
        base: opts.base.clone(),
        free: free.clone(),
        conds,
        obs,
        y: y.clone(),
        sw,
        weighted: opts.relative_errors,
    };
    // Start: base values; W rescaled by the least-squares factor (forces are proportional to W
    // under the flow-stress flank law, so this is the exact W-only solution then).
    let p_base = DVector::from_iterator(free.len(), free.iter().map(|f| f.get(&opts.base)));
    let (f0, _) = op
        .predict(&p_base, false)
        .map_err(|source| IdentifyError::ModelEvaluation {
            model: "force".into(),
            what: "forces at the base parameters".into(),
            source,
        })?;
    let w2: Vec<f64> = op.sw.iter().map(|s| s * s).collect();
    let num: f64 = f0
        .iter()
        .zip(&y)
        .zip(&w2)
        .map(|((f, y), w)| f * y * w)
        .sum();
    let den: f64 = f0.iter().zip(&w2).map(|(f, w)| f * f * w).sum();
    let scale = if den > 0.0 && num > 0.0 {
        num / den
    } else {
        1.0
    };
    let specs: Vec<ParamSpec> = free
        .iter()
        .map(|f| {
            let v = f.get(&opts.base);
            let v = if *f == ForceParam::W { v * scale } else { v };
            let v = match f {
                // strictly inside the bounds for the transforms
                ForceParam::Runout | ForceParam::Wearland if v <= 0.0 => 0.5,
                _ => v,
            };
            f.spec(v, &opts.base)
        })
        .collect();
    let fit = fit_nonlinear(op, &specs, &opts.common.nls, "force", "n")?;
    let mut report = fit.report;
    let b = &opts.base;
    for (name, v) in [
        ("w_mpa", b.material.w_mpa),
        ("mu_rake", b.material.mu_rake),
        ("mu_flank", b.material.mu_flank),
        ("wearland_um", b.tool.wearland_um),
        ("runout_um", b.tool.runout_um),
    ] {
        if !report.params.contains_key(name) {
            report.fixed.insert(name.into(), v);
        }
    }
    report.fixed.insert("e_gpa".into(), b.material.e_gpa);
    report.fixed.insert("radius_um".into(), b.tool.radius_um);
    report
        .fixed
        .insert("shear_angle_deg".into(), b.params.shear_angle_deg);
    report
        .fixed
        .insert("force_scale".into(), b.params.force_scale);
    if conds_in.tilt_deg.is_none() {
        report
            .fixed
            .insert("tilt_deg".into(), opts.default_tilt_deg);
    }
    Ok(Identified::new(
        "force",
        report,
        BTreeMap::new(),
        BTreeMap::new(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobian_check::check_jacobian;

    fn doe_conditions() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        // 000 Table 3-3 design (depth, speed, upfeed).
        let d = vec![200.0, 100.0, 100.0, 200.0, 200.0, 100.0, 200.0, 100.0];
        let s = vec![1e4, 1e4, 2e4, 2e4, 2e4, 2e4, 1e4, 1e4];
        let f = vec![20.0, 20.0, 10.0, 10.0, 20.0, 20.0, 10.0, 10.0];
        (d, s, f)
    }

    fn peak_op(free: Vec<ForceParam>) -> ForceResidual {
        let (d, s, f) = doe_conditions();
        let opts = ForceOptions::default();
        let c = ForceConditions {
            depth_um: &d,
            upfeed_um: &f,
            speed_rpm: Some(&s),
            tilt_deg: None,
        };
        let conds = conditions(&c, 8, &opts).unwrap();
        let mut obs = Vec::new();
        for comp in 0..3 {
            for i in 0..8 {
                obs.push(Obs::Peak { cond: i, comp });
            }
        }
        ForceResidual {
            base: opts.base,
            free,
            conds,
            obs,
            y: vec![0.0; 24],
            sw: vec![1.0; 24],
            weighted: false,
        }
    }

    #[test]
    fn peaks_equal_the_physics_crates_table33_response() {
        let op = peak_op(vec![ForceParam::W]);
        let p = DVector::from_vec(vec![2500.0]);
        let (f, _) = op.predict(&p, false).unwrap();
        let m = op.model(&p).unwrap();
        for (i, c) in op.conds.iter().enumerate() {
            let r = m.table33_response(c).unwrap();
            for comp in 0..3 {
                assert_eq!(f[comp * 8 + i], r[comp]);
            }
        }
    }

    #[test]
    fn peak_jacobian_matches_fd() {
        let op = peak_op(vec![
            ForceParam::W,
            ForceParam::MuRake,
            ForceParam::MuFlank,
            ForceParam::Wearland,
        ]);
        let c = check_jacobian(&op, &DVector::from_vec(vec![2500.0, 0.5, 0.5, 8.0]), 1e-5).unwrap();
        assert!(c.ok, "{c:?}");
    }

    #[test]
    fn trace_jacobian_matches_fd() {
        let opts = ForceOptions::default();
        let cond = CutConditions::new(100.0, 20.0, 1e4, 10.0).unwrap();
        let obs: Vec<Obs> = (0..60)
            .flat_map(|k| {
                (0..3).map(move |comp| Obs::Trace {
                    cond: 0,
                    comp,
                    rot: 0.05 + k as f64 * 0.1,
                })
            })
            .collect();
        let n = obs.len();
        let op = ForceResidual {
            base: opts.base,
            free: vec![
                ForceParam::W,
                ForceParam::MuRake,
                ForceParam::MuFlank,
                ForceParam::Wearland,
                ForceParam::Runout,
            ],
            conds: vec![cond],
            obs,
            y: vec![0.0; n],
            sw: vec![1.0; n],
            weighted: false,
        };
        let c = check_jacobian(
            &op,
            &DVector::from_vec(vec![2500.0, 0.5, 0.5, 8.0, 5.0]),
            1e-5,
        )
        .unwrap();
        assert!(c.ok, "{c:?}");
    }
}
