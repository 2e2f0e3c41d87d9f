//! Identified models: the estimates of a least-squares fit with their uncertainty ([`IdentifiedModel`],
//! the `[model]` table of every kind `millcomp identify` saves), and the typed views the controllers
//! consume ([`SpindleModel`], [`ForceModelParams`]). They carry no truth: only what was estimated from
//! measurements, with covariances.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, Result};

/// Outcome of a fit (an outcome, not an error: every status comes with a full report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitStatus {
    /// Converged (a tolerance was met) or solved exactly (linear, full rank).
    Converged,
    /// Stopped because no step reduces the cost any more (the model predicts a reduction below the
    /// cost's rounding, or every step longer than the step tolerance fails: MINPACK's "no further
    /// reduction possible") while a reduction the residuals could show is still left — a stop at the
    /// residuals' own resolution is `Converged` (identify's nonlinear module). Counted a success (the
    /// estimate is the best point found), but the steps failed for a reason the arithmetic does not
    /// explain: a Jacobian that is not the residuals' derivative, for one.
    StalledAtRoundingLevel,
    /// Not converged: the iteration limit was reached before any tolerance was met (files
    /// written before this status was named carry `max_iter`, read as this).
    #[serde(alias = "max_iter")]
    NotConverged,
    /// The data do not determine all parameters (the Jacobian is numerically rank deficient);
    /// the estimate is the minimum-norm one along the unseen directions named in `warnings`.
    RankDeficient,
}

impl FitStatus {
    /// Whether the estimate is usable as a minimum: converged or stalled at rounding level.
    pub fn is_success(self) -> bool {
        matches!(
            self,
            FitStatus::Converged | FitStatus::StalledAtRoundingLevel
        )
    }
}

/// A square matrix indexed by parameter name (serialised as `{"names": [...], "values": [[...]]}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct NamedMatrix {
    /// Row/column names, in parameter order.
    pub names: Vec<String>,
    /// Row-major values.
    pub values: Vec<Vec<f64>>,
}

impl NamedMatrix {
    /// Entry by names, `None` when a name is unknown.
    pub fn get(&self, row: &str, col: &str) -> Option<f64> {
        let i = self.names.iter().position(|n| n == row)?;
        let j = self.names.iter().position(|n| n == col)?;
        self.values.get(i)?.get(j).copied()
    }

    /// As an nalgebra matrix (parameter order of `names`; missing entries NaN).
    pub fn to_matrix(&self) -> DMatrix<f64> {
        let n = self.names.len();
        DMatrix::from_fn(n, n, |i, j| {
            self.values
                .get(i)
                .and_then(|r| r.get(j))
                .copied()
                .unwrap_or(f64::NAN)
        })
    }

    /// From an nalgebra matrix whose rows and columns are `names`.
    pub fn from_matrix(names: &[String], m: &DMatrix<f64>) -> Self {
        NamedMatrix {
            names: names.to_vec(),
            values: (0..m.nrows())
                .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
                .collect(),
        }
    }

    /// The sub-matrix of `names` (in that order), `None` when a name is unknown.
    pub fn sub(&self, names: &[&str]) -> Option<NamedMatrix> {
        let values = names
            .iter()
            .map(|r| names.iter().map(|c| self.get(r, c)).collect())
            .collect::<Option<Vec<Vec<f64>>>>()?;
        Some(NamedMatrix {
            names: names.iter().map(|s| s.to_string()).collect(),
            values,
        })
    }
}

/// A derived quantity (function of fitted parameters) with delta-method uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Derived {
    /// Value.
    pub value: f64,
    /// Standard error by the delta method (gradient of the function at the estimate, through the
    /// parameter covariance).
    pub std_err: f64,
    /// 95 % interval `value ± t·SE` with the fit's degrees of freedom.
    pub ci95: [f64; 2],
    /// The formula, for the record (e.g. `1/(cos²α/k_axial + sin²α/k_radial)`).
    pub formula: String,
}

/// What `millcomp identify` saves: the estimates of one fit with their uncertainty (the `[model]` table
/// of kinds `spindle`, `stiffness`, `force`, `thermal_*`, `wall`; `models/MODEL.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentifiedModel {
    /// How the fit ended.
    pub status: FitStatus,
    /// Observations used.
    pub n_obs: usize,
    /// Residual degrees of freedom.
    pub dof: usize,
    /// RMS residual in `residual_unit`.
    pub rms_residual: f64,
    /// Unit of the residuals: one of [`IdentifiedModel::RESIDUAL_UNITS`] (a file with another is
    /// refused on load, naming the key).
    #[serde(deserialize_with = "residual_unit")]
    pub residual_unit: String,
    /// Fit warnings, for the record.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// Estimates (names carry units).
    pub params: BTreeMap<String, f64>,
    /// Standard errors (`inf` for a parameter the data do not determine).
    pub std_err: BTreeMap<String, f64>,
    /// Known inputs held fixed in the fit (e.g. `tilt_deg`, `temp_ref_c`).
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    /// Derived quantities with uncertainty.
    #[serde(default)]
    pub derived: BTreeMap<String, Derived>,
    /// Parameter covariance (names in parameter order).
    pub covariance: NamedMatrix,
}

/// Reads `residual_unit`, refusing a unit millcomp does not write: the residual RMS of a model is compared
/// with sensor noise levels in µm and N, so `mm` or `kN` would silently be read 1000× off.
fn residual_unit<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<String, D::Error> {
    let unit = String::deserialize(d)?;
    if IdentifiedModel::RESIDUAL_UNITS.contains(&unit.as_str()) {
        Ok(unit)
    } else {
        Err(serde::de::Error::custom(format!(
            "residual_unit `{unit}`: allowed {} (µm, newtons, or none for a model fitted to no residuals)",
            IdentifiedModel::RESIDUAL_UNITS
                .map(|u| format!("`{u}`"))
                .join(", ")
        )))
    }
}

impl IdentifiedModel {
    /// The units `residual_unit` may hold: `um` (every displacement fit), `n` (force fits) and `none`
    /// (a sensor-noise record, which fits nothing).
    pub const RESIDUAL_UNITS: [&'static str; 3] = ["um", "n", "none"];

    /// A parameter or fixed input by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.params
            .get(name)
            .or_else(|| self.fixed.get(name))
            .copied()
    }

    /// A parameter or fixed input a consumer needs; `origin` and `kind` name the file in the error.
    ///
    /// ```
    /// use std::path::Path;
    /// use millcomp_models::{IdentifiedModel, ModelError};
    /// let m: IdentifiedModel = toml::from_str(r#"
    /// status = "converged"
    /// n_obs = 8
    /// dof = 7
    /// rms_residual = 0.2
    /// residual_unit = "n"
    /// params = { w_mpa = 1500.0 }
    /// std_err = { w_mpa = 40.0 }
    /// fixed = { tilt_deg = 20.0 }
    /// covariance = { names = ["w_mpa"], values = [[1600.0]] }
    /// "#).unwrap();
    /// let at = Path::new("force.toml");
    /// assert_eq!(m.require("w_mpa", at, "force").unwrap(), 1500.0);
    /// assert_eq!(m.require("tilt_deg", at, "force").unwrap(), 20.0);
    /// let e = m.require("mu_rake", at, "force").unwrap_err();
    /// assert!(matches!(&e, ModelError::MissingKey { key, .. } if key == "model.params.mu_rake"));
    /// assert!(e.to_string().contains("(it has: w_mpa, tilt_deg)"));
    /// ```
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.params.<name>` and what the model has.
    pub fn require(&self, name: &str, origin: &Path, kind: &str) -> Result<f64> {
        self.get(name).ok_or_else(|| ModelError::MissingKey {
            path: origin.to_path_buf(),
            kind: kind.to_string(),
            key: format!("model.params.{name}"),
            available: self
                .params
                .keys()
                .chain(self.fixed.keys())
                .cloned()
                .collect::<Vec<_>>()
                .join(", "),
        })
    }

    /// [`Self::require`], and the value must pass `valid` (`allowed` says what passes, for the message).
    ///
    /// # Errors
    /// As [`Self::require`]; [`ModelError::InvalidValue`] naming `model.params.<name>` when `valid`
    /// refuses the value.
    pub fn require_valid(
        &self,
        name: &str,
        origin: &Path,
        kind: &str,
        valid: fn(f64) -> bool,
        allowed: &str,
    ) -> Result<f64> {
        let v = self.require(name, origin, kind)?;
        if valid(v) {
            Ok(v)
        } else {
            Err(ModelError::InvalidValue {
                path: origin.to_path_buf(),
                key: format!("model.params.{name}"),
                value: v.to_string(),
                allowed: allowed.into(),
            })
        }
    }
}

/// Finite and > 0 (a gain, a frequency, a stiffness).
fn finite_positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// The model's residuals must be in `unit` (a spindle's in µm, a force model's in N): a model of the right
/// kind fitted in another unit is refused naming `model.residual_unit`.
fn require_unit(m: &IdentifiedModel, origin: &Path, unit: &str, kind: &str) -> Result<()> {
    if m.residual_unit == unit {
        Ok(())
    } else {
        Err(ModelError::InvalidValue {
            path: origin.to_path_buf(),
            key: "model.residual_unit".into(),
            value: format!("`{}`", m.residual_unit),
            allowed: format!("`{unit}` for a `{kind}` model"),
        })
    }
}

/// The PZT-actuated spindle as identified from a step response (kind `spindle`):
/// `G(s) = K ωn² [p/(s+p)] e^{−sTd} / (s² + 2ζωn s + ωn²)`, volts → tool-tip µm (`000_…txt` §5.2.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpindleModel {
    /// Static gain K (µm at the tool tip per V).
    pub gain_um_per_v: f64,
    /// Damping ratio ζ.
    pub zeta: f64,
    /// Natural frequency ωn (rad/s).
    pub wn_rad_s: f64,
    /// Extra real pole p (rad/s), when it was fitted.
    pub pole_rad_s: Option<f64>,
    /// Dead time Td (s), when it was fitted.
    pub dead_time_s: Option<f64>,
    /// Order of the Padé approximant the dead time was fitted with (1 or 2), when there is one.
    pub dead_time_pade_order: Option<u32>,
    /// Covariance of the estimates.
    pub covariance: NamedMatrix,
}

impl SpindleModel {
    /// Kinds this view reads.
    pub const KINDS: [&'static str; 1] = ["spindle"];

    /// The typed view of an identified `spindle` model (`origin` names the file in errors).
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] when `gain_um_per_v`, `zeta` or `wn_rad_s` is absent;
    /// [`ModelError::InvalidValue`] for a non-finite or non-positive one.
    ///
    /// # Examples
    /// ```
    /// use std::path::Path;
    /// use millcomp_models::{IdentifiedModel, SpindleModel};
    /// let text = r#"
    /// status = "converged"
    /// n_obs = 500
    /// dof = 496
    /// rms_residual = 0.005
    /// residual_unit = "um"
    /// [params]
    /// gain_um_per_v = 0.05
    /// zeta = 0.46
    /// wn_rad_s = 1302.0
    /// [std_err]
    /// [covariance]
    /// names = []
    /// values = []
    /// "#;
    /// let m: IdentifiedModel = toml::from_str(text).unwrap();
    /// let s = SpindleModel::from_identified(&m, Path::new("spindle.toml")).unwrap();
    /// assert_eq!(s.wn_rad_s, 1302.0);
    /// assert_eq!(s.pole_rad_s, None);
    /// ```
    pub fn from_identified(m: &IdentifiedModel, origin: &Path) -> Result<Self> {
        require_unit(m, origin, "um", "spindle")?;
        let need = |name: &str| {
            m.require_valid(name, origin, "spindle", finite_positive, "finite and > 0")
        };
        Ok(Self {
            gain_um_per_v: need("gain_um_per_v")?,
            zeta: need("zeta")?,
            wn_rad_s: need("wn_rad_s")?,
            pole_rad_s: m.params.get("pole_rad_s").copied(),
            dead_time_s: m.params.get("dead_time_s").copied(),
            dead_time_pade_order: m.fixed.get("dead_time_pade_order").map(|&o| o as u32),
            covariance: m.covariance.clone(),
        })
    }
}

/// The PZT stack's rate-independent hysteresis identified from a quasi-static sweep in air (kind
/// `hysteresis`): a Prandtl–Ishlinskii operator `tip = Σᵢ wᵢ · Fᵣᵢ[v] + offset`, weights `wNN_um_per_v`
/// on the play thresholds `rNN_v` (fixed inputs of the fit), `NN` the operator's index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HysteresisModel {
    /// Play thresholds (V), ascending from 0.
    pub thresholds_v: Vec<f64>,
    /// Weights (µm of tip per V), one per threshold.
    pub weights_um_per_v: Vec<f64>,
    /// The gauge's reading at rest (µm) during the sweep.
    pub offset_um: f64,
}

impl HysteresisModel {
    /// Kinds this view reads.
    pub const KINDS: [&'static str; 1] = ["hysteresis"];

    /// The typed view of an identified `hysteresis` model (`origin` names the file in errors).
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] for a weight without its threshold (or none at all), or without
    /// `offset_um`; [`ModelError::InvalidValue`] for a non-finite value, a first threshold that is not 0,
    /// thresholds out of order, a weight below 0 or a first weight that is not > 0.
    ///
    /// # Examples
    /// ```
    /// use std::path::Path;
    /// use millcomp_models::{HysteresisModel, IdentifiedModel};
    /// let m: IdentifiedModel = toml::from_str(r#"
    /// status = "converged"
    /// n_obs = 900
    /// dof = 897
    /// rms_residual = 0.05
    /// residual_unit = "um"
    /// [params]
    /// w00_um_per_v = 0.04
    /// w03_um_per_v = 0.006
    /// offset_um = 0.2
    /// [fixed]
    /// r00_v = 0.0
    /// r03_v = 56.25
    /// [std_err]
    /// [covariance]
    /// names = []
    /// values = []
    /// "#).unwrap();
    /// let h = HysteresisModel::from_identified(&m, Path::new("hysteresis.toml")).unwrap();
    /// assert_eq!(h.thresholds_v, vec![0.0, 56.25]);
    /// assert_eq!(h.weights_um_per_v, vec![0.04, 0.006]);
    /// ```
    pub fn from_identified(m: &IdentifiedModel, origin: &Path) -> Result<Self> {
        let invalid = |key: &str, value: f64, allowed: &str| ModelError::InvalidValue {
            path: origin.to_path_buf(),
            key: key.to_string(),
            value: format!("{value}"),
            allowed: allowed.to_string(),
        };
        let mut pairs = Vec::new();
        for (name, &w) in &m.params {
            let Some(idx) = name
                .strip_prefix('w')
                .and_then(|r| r.strip_suffix("_um_per_v"))
            else {
                continue;
            };
            let r_key = format!("r{idx}_v");
            let r = m
                .fixed
                .get(&r_key)
                .copied()
                .ok_or_else(|| ModelError::MissingKey {
                    path: origin.to_path_buf(),
                    kind: "hysteresis".into(),
                    key: format!("model.fixed.{r_key} (the threshold of model.params.{name})"),
                    available: m.fixed.keys().cloned().collect::<Vec<_>>().join(", "),
                })?;
            if !(w.is_finite() && w >= 0.0) {
                return Err(invalid(
                    &format!("model.params.{name}"),
                    w,
                    "finite and >= 0",
                ));
            }
            if !r.is_finite() {
                return Err(invalid(&format!("model.fixed.{r_key}"), r, "finite"));
            }
            pairs.push((r, w));
        }
        if pairs.is_empty() {
            return Err(ModelError::MissingKey {
                path: origin.to_path_buf(),
                kind: "hysteresis".into(),
                key: "model.params.w00_um_per_v".into(),
                available: m.params.keys().cloned().collect::<Vec<_>>().join(", "),
            });
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pairs[0].0 != 0.0 {
            return Err(invalid(
                "model.fixed.r00_v",
                pairs[0].0,
                "0 (the linear play)",
            ));
        }
        if pairs[0].1 <= 0.0 {
            return Err(invalid("model.params.w00_um_per_v", pairs[0].1, "> 0"));
        }
        if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
            return Err(invalid(
                "model.fixed.rNN_v",
                w[1].0,
                "thresholds all different",
            ));
        }
        let offset_um = m.require_valid(
            "offset_um",
            origin,
            "hysteresis",
            |v: f64| v.is_finite(),
            "finite",
        )?;
        Ok(Self {
            thresholds_v: pairs.iter().map(|p| p.0).collect(),
            weights_um_per_v: pairs.iter().map(|p| p.1).collect(),
            offset_um,
        })
    }
}

/// Force-model parameters identified from measured forces (kind `force`): the fitted subset of
/// [`ForceModelParams::PARAMETERS`] with their covariance, and the values held fixed in the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForceModelParams {
    /// Fitted parameters by name (a subset of [`ForceModelParams::PARAMETERS`]).
    pub fitted: BTreeMap<String, f64>,
    /// Inputs held fixed in the fit (material constants, tool geometry, force scale).
    pub fixed: BTreeMap<String, f64>,
    /// Covariance of the fitted parameters.
    pub covariance: NamedMatrix,
}

impl ForceModelParams {
    /// Kinds this view reads.
    pub const KINDS: [&'static str; 1] = ["force"];

    /// The parameters of the ball-end force model an identification may fit: volumetric work W (MPa),
    /// rake and flank friction, wearland (µm), runout (µm) (`000_…txt` ch. 2, 4).
    pub const PARAMETERS: [&'static str; 5] =
        ["w_mpa", "mu_rake", "mu_flank", "wearland_um", "runout_um"];

    /// The typed view of an identified `force` model (`origin` names the file in errors).
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] for a fitted parameter that is not one of
    /// [`ForceModelParams::PARAMETERS`] or is not finite.
    ///
    /// # Examples
    /// ```
    /// use std::path::Path;
    /// use millcomp_models::{ForceModelParams, IdentifiedModel};
    /// let mut m: IdentifiedModel = toml::from_str(r#"
    /// status = "converged"
    /// n_obs = 8
    /// dof = 7
    /// rms_residual = 0.2
    /// residual_unit = "n"
    /// params = { w_mpa = 1500.0 }
    /// std_err = { w_mpa = 40.0 }
    /// covariance = { names = ["w_mpa"], values = [[1600.0]] }
    /// "#).unwrap();
    /// let f = ForceModelParams::from_identified(&m, Path::new("force.toml")).unwrap();
    /// assert_eq!(f.fitted["w_mpa"], 1500.0);
    /// assert_eq!(f.covariance.get("w_mpa", "w_mpa"), Some(1600.0));
    /// m.params.insert("zeta".into(), 0.46); // a spindle parameter is not a force-model parameter
    /// assert!(ForceModelParams::from_identified(&m, Path::new("force.toml")).is_err());
    /// ```
    pub fn from_identified(m: &IdentifiedModel, origin: &Path) -> Result<Self> {
        require_unit(m, origin, "n", "force")?;
        for (name, v) in &m.params {
            if !Self::PARAMETERS.contains(&name.as_str()) {
                return Err(ModelError::InvalidValue {
                    path: origin.to_path_buf(),
                    key: format!("model.params.{name}"),
                    value: v.to_string(),
                    allowed: format!("a force-model parameter ({})", Self::PARAMETERS.join(", ")),
                });
            }
            if !v.is_finite() {
                return Err(ModelError::InvalidValue {
                    path: origin.to_path_buf(),
                    key: format!("model.params.{name}"),
                    value: v.to_string(),
                    allowed: "a finite number".into(),
                });
            }
        }
        Ok(Self {
            fitted: m.params.clone(),
            fixed: m.fixed.clone(),
            covariance: m.covariance.clone(),
        })
    }
}

/// The tool/spindle stiffness as identified from a load–deflection test (kind `stiffness` with directions
/// `axial` and `radial`: `deflection = offset + load/k` per direction, `000_…txt` §5.2.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessModel {
    /// Axial (spindle) stiffness (N/µm).
    pub axial_n_per_um: f64,
    /// Radial (tool bending) stiffness (N/µm).
    pub radial_n_per_um: f64,
    /// Covariance of the two stiffnesses (names `axial_stiffness_n_per_um`, `radial_stiffness_n_per_um`).
    pub covariance: NamedMatrix,
}

impl StiffnessModel {
    /// Kinds this view reads.
    pub const KINDS: [&'static str; 1] = ["stiffness"];

    /// The typed view of an identified `stiffness` model with an `axial` and a `radial` direction.
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.params.axial_stiffness_n_per_um` or
    /// `…radial…`; [`ModelError::InvalidValue`] for a non-positive stiffness.
    pub fn from_identified(m: &IdentifiedModel, origin: &Path) -> Result<Self> {
        require_unit(m, origin, "um", "stiffness")?;
        let need = |name: &str| {
            m.require_valid(name, origin, "stiffness", finite_positive, "finite and > 0")
        };
        let names = ["axial_stiffness_n_per_um", "radial_stiffness_n_per_um"];
        Ok(Self {
            axial_n_per_um: need(names[0])?,
            radial_n_per_um: need(names[1])?,
            covariance: m.covariance.sub(&names).unwrap_or_default(),
        })
    }

    /// The same stiffness scaled by `factor` (a sweep of a wrong stiffness measurement).
    pub fn scaled(&self, factor: f64) -> Self {
        let mut c = self.covariance.clone();
        for row in &mut c.values {
            for v in row.iter_mut() {
                *v *= factor * factor;
            }
        }
        Self {
            axial_n_per_um: self.axial_n_per_um * factor,
            radial_n_per_um: self.radial_n_per_um * factor,
            covariance: c,
        }
    }
}

/// The sensors' noise levels a Kalman filter assumes (kind `sensor_noise`, a part of a bundle): the
/// standard deviation of the force channel and of the gauge, each estimated from a record taken at rest
/// (the sample standard deviation, quantisation included; `std_err` σ̂/√(2(n−1))).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SensorNoise {
    /// Force-channel noise σ (N).
    pub force_noise_n: f64,
    /// Gauge noise σ (µm).
    pub gauge_noise_um: f64,
}

impl SensorNoise {
    /// Kinds this view reads.
    pub const KINDS: [&'static str; 1] = ["sensor_noise"];
    /// Parameter names, in order.
    pub const PARAMS: [&'static str; 2] = ["force_noise_n", "gauge_noise_um"];

    /// The typed view of an identified `sensor_noise` model.
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.params.force_noise_n` or `…gauge_noise_um`;
    /// [`ModelError::InvalidValue`] for a negative or non-finite level.
    pub fn from_identified(m: &IdentifiedModel, origin: &Path) -> Result<Self> {
        let need = |name: &str| {
            m.require_valid(
                name,
                origin,
                "sensor_noise",
                |v| v.is_finite() && v >= 0.0,
                "finite and >= 0",
            )
        };
        Ok(Self {
            force_noise_n: need(Self::PARAMS[0])?,
            gauge_noise_um: need(Self::PARAMS[1])?,
        })
    }

    /// A stand-in for a bundle without a record at rest: the RMS residuals of the spindle step test (gauge,
    /// µm) and of the force calibration (N) — measured, but they carry model misfit and the force
    /// calibration's averaging as well as noise.
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] naming `model.rms_residual` of the model whose residuals are not in
    /// the unit needed (`um` for the spindle, `n` for the force model) or not finite.
    pub fn from_residuals(
        spindle: &IdentifiedModel,
        force: &IdentifiedModel,
        origin: &Path,
    ) -> Result<Self> {
        let level = |m: &IdentifiedModel, unit: &str, part: &str| -> Result<f64> {
            if m.residual_unit.eq_ignore_ascii_case(unit)
                && m.rms_residual.is_finite()
                && m.rms_residual >= 0.0
            {
                Ok(m.rms_residual)
            } else {
                Err(ModelError::InvalidValue {
                    path: origin.to_path_buf(),
                    key: format!("model.{part}.rms_residual"),
                    value: format!("{} {}", m.rms_residual, m.residual_unit),
                    allowed: format!("finite and >= 0, in {unit}"),
                })
            }
        };
        Ok(Self {
            force_noise_n: level(force, "n", "force")?,
            gauge_noise_um: level(spindle, "um", "spindle")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(params: &[(&str, f64)]) -> IdentifiedModel {
        IdentifiedModel {
            status: FitStatus::Converged,
            n_obs: 10,
            dof: 8,
            rms_residual: 0.1,
            residual_unit: "um".into(),
            warnings: vec![],
            params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            std_err: BTreeMap::new(),
            fixed: BTreeMap::new(),
            derived: BTreeMap::new(),
            covariance: NamedMatrix::default(),
        }
    }

    #[test]
    fn spindle_view_names_the_missing_key() {
        let m = model(&[("gain_um_per_v", 0.05), ("zeta", 0.46)]);
        let e = SpindleModel::from_identified(&m, Path::new("s.toml")).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("s.toml") && msg.contains("model.params.wn_rad_s"),
            "{msg}"
        );
    }

    fn force(params: &[(&str, f64)]) -> IdentifiedModel {
        IdentifiedModel {
            residual_unit: "n".into(),
            ..model(params)
        }
    }

    #[test]
    fn force_view_refuses_unknown_parameters() {
        let m = force(&[("w_mpa", 2000.0), ("k_c", 1.0)]);
        let e = ForceModelParams::from_identified(&m, Path::new("f.toml")).unwrap_err();
        assert!(e.to_string().contains("model.params.k_c"), "{e}");
        let ok = ForceModelParams::from_identified(&force(&[("w_mpa", 2000.0)]), Path::new("f"))
            .unwrap();
        assert_eq!(ok.fitted["w_mpa"], 2000.0);
    }

    #[test]
    fn a_model_in_another_unit_than_its_kind_is_refused_naming_the_key() {
        // a force model whose residuals are in µm, a spindle in N: read 1000× or unit-confused
        let e = ForceModelParams::from_identified(&model(&[("w_mpa", 2000.0)]), Path::new("f"))
            .unwrap_err();
        assert!(e.to_string().contains("model.residual_unit"), "{e}");
        let e = SpindleModel::from_identified(
            &force(&[
                ("gain_um_per_v", 0.05),
                ("zeta", 0.46),
                ("wn_rad_s", 1302.0),
            ]),
            Path::new("s"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("`um` for a `spindle` model"), "{e}");
    }

    #[test]
    fn a_residual_unit_millcomp_does_not_write_is_refused_on_load() {
        let text = |unit: &str| {
            format!(
                "status = \"converged\"\nn_obs = 8\ndof = 6\nrms_residual = 0.2\nresidual_unit = \"{unit}\"\n\
                 params = {{ k = 1.0 }}\nstd_err = {{ k = 0.1 }}\ncovariance = {{ names = [\"k\"], values = [[0.01]] }}\n"
            )
        };
        for unit in IdentifiedModel::RESIDUAL_UNITS {
            assert!(
                toml::from_str::<IdentifiedModel>(&text(unit)).is_ok(),
                "{unit}"
            );
        }
        let e = toml::from_str::<IdentifiedModel>(&text("mm")).unwrap_err();
        assert!(
            e.to_string()
                .contains("residual_unit `mm`: allowed `um`, `n`, `none`"),
            "{e}"
        );
    }

    #[test]
    fn sub_matrix_keeps_the_named_order() {
        let m = NamedMatrix {
            names: vec!["a".into(), "b".into()],
            values: vec![vec![1.0, 2.0], vec![2.0, 5.0]],
        };
        let s = m.sub(&["b", "a"]).unwrap();
        assert_eq!(s.values, vec![vec![5.0, 2.0], vec![2.0, 1.0]]);
        assert!(m.sub(&["c"]).is_none());
    }
}
