//! The identification targets of `millcomp identify <what>`: each takes named data columns, validates them, fits the
//! physics crate's model and returns an [`Identified`] (report + saveable model).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::report::FitReport;
use millcomp_models::{Derived, IdentifiedModel};

pub(crate) mod combine;
pub mod feed_axis;
pub mod flutes;
pub mod force;
pub mod hysteresis;
pub mod kienzle;
pub mod part;
pub mod spindle;
pub mod stiffness;
pub mod thermal;
pub mod thermal_record;
pub mod wall;
pub mod wear;

/// What a target returns. Serialises as the report's keys at top level (`params`, `std_err`,
/// `ci95`, `rms_residual_<unit>`, `status`, `warnings`, ...) plus `derived` and `groups` when not
/// empty; `model` (the saveable form) is not serialised — save it as kind [`Identified::kind`] in a
/// `millcomp_models::ModelFile`.
///
/// # Examples
/// Save a fit in the common model-file format (`models/MODEL.md`) and load it back:
/// ```
/// use millcomp_identify::IdentifiedModel;
/// use millcomp_identify::targets::wall::*;
/// use millcomp_models::{ModelFile, Provenance};
/// // a wall of 0.25 N/µm, deflections perturbed by ±0.01 µm
/// let f: Vec<f64> = (1..=12).map(|i| 0.1 * i as f64).collect();
/// let d: Vec<f64> = f.iter().enumerate().map(|(i, f)| f / 0.25 + 0.01 * ((i % 3) as f64 - 1.0)).collect();
/// let fit = identify_wall(&WallData { force_n: &f, deflection_um: &d }, &WallOptions::default()).unwrap();
/// let k = fit.report.param("wall_stiffness_n_per_um");
/// assert!((k - 0.25).abs() < 2.0 * fit.report.se("wall_stiffness_n_per_um"));
///
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("wall.toml");
/// let provenance = Provenance::now("millcomp 0.1.0", "millcomp identify wall wall.csv --save wall.toml");
/// ModelFile::new(&fit.kind, fit.model.clone(), provenance).save(&path).unwrap();
/// let back = ModelFile::<IdentifiedModel>::load(&path, &["wall"]).unwrap();
/// assert_eq!(back.header.kind, "wall");
/// assert_eq!(back.model, fit.model); // estimates, standard errors and covariance, bit for bit
/// assert_eq!(back.model.params["wall_stiffness_n_per_um"], k);
/// // a reader that needs another kind refuses the file
/// assert!(ModelFile::<IdentifiedModel>::load(&path, &["spindle"]).is_err());
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct Identified {
    /// The fit report (all parameters of the model).
    #[serde(flatten)]
    pub report: FitReport,
    /// Functions of the parameters with delta-method uncertainty (e.g. tilted-tool stiffness).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub derived: BTreeMap<String, Derived>,
    /// Per-group reports when the target fits independent groups (e.g. stiffness directions).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub groups: BTreeMap<String, FitReport>,
    /// Notes about the input (e.g. columns that were ignored).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// The model kind to save it as: `spindle`, `stiffness`, `force`, `thermal_exponential`,
    /// `thermal_linear_temp`, `thermal_speed`, `wall`.
    #[serde(skip)]
    pub kind: String,
    /// The saveable model (`--save`).
    #[serde(skip)]
    pub model: IdentifiedModel,
}

impl Identified {
    pub(crate) fn new(
        kind: &str,
        report: FitReport,
        derived: BTreeMap<String, Derived>,
        groups: BTreeMap<String, FitReport>,
    ) -> Self {
        let model = IdentifiedModel {
            status: report.status,
            n_obs: report.n_obs,
            dof: report.dof,
            rms_residual: report.rms_residual.value,
            residual_unit: report.rms_residual.unit.clone(),
            warnings: report.warnings.clone(),
            params: report.params.clone(),
            std_err: report.std_err.clone(),
            fixed: report.fixed.clone(),
            derived: derived.clone(),
            covariance: report.covariance.clone(),
        };
        Identified {
            report,
            derived,
            groups,
            notes: Vec::new(),
            kind: kind.to_string(),
            model,
        }
    }
}

/// Delta-method derived quantity `g(θ)` from the parameters named `inputs` of `report`
/// (gradient by central differences, relative step 1e-6, then `SE² = ∇gᵀ Σ ∇g`).
pub(crate) fn derive(
    report: &FitReport,
    inputs: &[&str],
    formula: &str,
    g: impl Fn(&[f64]) -> f64,
) -> Option<Derived> {
    let x: Vec<f64> = inputs
        .iter()
        .map(|n| report.params.get(*n).copied())
        .collect::<Option<Vec<f64>>>()?;
    let cov = report.covariance.to_matrix();
    let idx: Vec<usize> = inputs
        .iter()
        .map(|n| report.covariance.names.iter().position(|m| m == n))
        .collect::<Option<Vec<usize>>>()?;
    let value = g(&x);
    let mut grad = DVector::zeros(x.len());
    for j in 0..x.len() {
        let h = 1e-6 * x[j].abs().max(1e-12);
        let mut xp = x.clone();
        let mut xm = x.clone();
        xp[j] += h;
        xm[j] -= h;
        grad[j] = (g(&xp) - g(&xm)) / (2.0 * h);
    }
    let sub = DMatrix::from_fn(x.len(), x.len(), |i, j| cov[(idx[i], idx[j])]);
    let var = (grad.transpose() * sub * &grad)[(0, 0)];
    let se = var.max(0.0).sqrt();
    let t = StudentsT::new(0.0, 1.0, report.dof.max(1) as f64)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(f64::NAN);
    Some(Derived {
        value,
        std_err: se,
        ci95: [value - t * se, value + t * se],
        formula: formula.to_string(),
    })
}
