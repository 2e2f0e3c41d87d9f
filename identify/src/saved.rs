//! The saved-model file (`--save model.toml`) that `simulate`, `mpc` and `diagnose` read.
//!
//! Format (documented with an example in `identify/MODEL.md`):
//! ```toml
//! [model]
//! kind = "spindle"
//! format_version = 1
//! source_file = "step.csv"
//! date = "2025-01-31T12:00:00Z"
//! created_by = "millcomp-identify 0.1.0"
//! status = "converged"
//! n_obs = 400
//! dof = 397
//! rms_residual = 0.01
//! residual_unit = "um"
//! warnings = []
//!
//! [model.params]
//! gain_um_per_v = 0.05
//! [model.std_err]
//! gain_um_per_v = 0.0001
//! [model.fixed]       # known inputs held fixed in the fit
//! [model.derived]     # functions of the parameters (e.g. tilted-tool stiffness), with SEs
//! [model.covariance]
//! names = ["gain_um_per_v", "wn_rad_s", "zeta"]
//! values = [[...], [...], [...]]
//! ```

use std::collections::BTreeMap;
use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::error::{IdentifyError, Result};
use crate::report::{FitReport, FitStatus, NamedMatrix};

/// Current `format_version` of the file.
pub const FORMAT_VERSION: u32 = 1;

/// A derived quantity (function of fitted parameters) with delta-method uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Derived {
    /// Value.
    pub value: f64,
    /// Standard error by the delta method (gradient of the function at the estimate, through the
    /// parameter covariance).
    pub std_err: f64,
    /// 95 % interval `value ± t·SE` with the report's degrees of freedom.
    pub ci95: [f64; 2],
    /// The formula, for the record (e.g. `1/(cos²α/k_axial + sin²α/k_radial)`).
    pub formula: String,
}

/// The identified model as stored on disk (the `[model]` table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedModel {
    /// Model kind: `spindle`, `stiffness`, `thermal_exponential`, `thermal_linear_temp`,
    /// `thermal_speed`, `force`, `wall`.
    pub kind: String,
    /// File format version ([`FORMAT_VERSION`]).
    pub format_version: u32,
    /// Data file the model was identified from (as given by the caller).
    pub source_file: String,
    /// UTC time of identification, RFC 3339 (`YYYY-MM-DDThh:mm:ssZ`).
    pub date: String,
    /// Producer and version.
    pub created_by: String,
    /// Fit status.
    pub status: FitStatus,
    /// Observations used.
    pub n_obs: usize,
    /// Residual degrees of freedom.
    pub dof: usize,
    /// RMS residual in `residual_unit`.
    pub rms_residual: f64,
    /// Unit of the residuals (`um`, `n`).
    pub residual_unit: String,
    /// Fit warnings, for the record.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// Estimates (names carry units).
    pub params: BTreeMap<String, f64>,
    /// Standard errors.
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

#[derive(Serialize, Deserialize)]
struct SavedFile {
    model: SavedModel,
}

impl SavedModel {
    /// Builds the saved model from a report (date = now).
    pub fn from_report(
        kind: &str,
        report: &FitReport,
        derived: BTreeMap<String, Derived>,
        source_file: &str,
    ) -> Self {
        SavedModel {
            kind: kind.to_string(),
            format_version: FORMAT_VERSION,
            source_file: source_file.to_string(),
            date: utc_now_rfc3339(),
            created_by: format!("millcomp-identify {}", env!("CARGO_PKG_VERSION")),
            status: report.status,
            n_obs: report.n_obs,
            dof: report.dof,
            rms_residual: report.rms_residual.value,
            residual_unit: report.rms_residual.unit.clone(),
            warnings: report.warnings.clone(),
            params: report.params.clone(),
            std_err: report.std_err.clone(),
            fixed: report.fixed.clone(),
            derived,
            covariance: report.covariance.clone(),
        }
    }

    /// Serialises as the documented TOML (`[model]` table).
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string(&SavedFile {
            model: self.clone(),
        })
        .map_err(|e| IdentifyError::SavedModel(format!("cannot write TOML: {e}")))
    }

    /// Parses the documented TOML; rejects unknown format versions.
    pub fn from_toml(text: &str) -> Result<Self> {
        let f: SavedFile = toml::from_str(text)
            .map_err(|e| IdentifyError::SavedModel(format!("cannot parse TOML: {e}")))?;
        if f.model.format_version != FORMAT_VERSION {
            return Err(IdentifyError::SavedModel(format!(
                "format_version {} is not supported (this build reads {FORMAT_VERSION})",
                f.model.format_version
            )));
        }
        Ok(f.model)
    }

    /// Fails unless the model is of `kind` (readers call this first).
    pub fn expect_kind(&self, kind: &str) -> Result<()> {
        if self.kind == kind {
            Ok(())
        } else {
            Err(IdentifyError::SavedModel(format!(
                "expected a `{kind}` model, found `{}`",
                self.kind
            )))
        }
    }

    /// A parameter (or fixed input) by name.
    pub fn param(&self, name: &str) -> Result<f64> {
        self.params
            .get(name)
            .or_else(|| self.fixed.get(name))
            .copied()
            .ok_or_else(|| {
                IdentifyError::SavedModel(format!(
                    "model `{}` has no parameter `{name}` (has: {})",
                    self.kind,
                    self.params.keys().cloned().collect::<Vec<_>>().join(", ")
                ))
            })
    }
}

impl SavedModel {
    /// The identified spindle as the physics crate's [`PztSpindle`](millcomp_sim::spindle::PztSpindle)
    /// (kind `spindle`; the extra pole and dead time when they were fitted, the dead time as a
    /// Padé approximant of the recorded order; the other fields at the physics crate's defaults).
    pub fn to_spindle(&self) -> Result<millcomp_sim::spindle::PztSpindle> {
        use millcomp_sim::spindle::{DeadTimeModel, PztSpindle};
        self.expect_kind("spindle")?;
        let mut s = PztSpindle::new(
            self.param("gain_um_per_v")?,
            self.param("zeta")?,
            self.param("wn_rad_s")?,
            self.params.get("pole_rad_s").copied(),
            self.params.get("dead_time_s").copied(),
        )
        .map_err(|e| {
            IdentifyError::SavedModel(format!(
                "spindle parameters rejected by the physics crate: {e}"
            ))
        })?;
        s.dead_time_model = match self.fixed.get("dead_time_pade_order").copied() {
            Some(1.0) => DeadTimeModel::Pade1,
            _ => DeadTimeModel::Pade2,
        };
        Ok(s)
    }

    /// `base` with the identified force-model parameters (kind `force`) substituted.
    pub fn apply_to_force_model(
        &self,
        base: &millcomp_sim::force::BallEndForceModel,
    ) -> Result<millcomp_sim::force::BallEndForceModel> {
        self.expect_kind("force")?;
        let mut m = base.clone();
        for (name, v) in &self.params {
            match name.as_str() {
                "w_mpa" => m.material.w_mpa = *v,
                "mu_rake" => m.material.mu_rake = *v,
                "mu_flank" => m.material.mu_flank = *v,
                "wearland_um" => m.tool.wearland_um = *v,
                "runout_um" => m.tool.runout_um = *v,
                other => {
                    return Err(IdentifyError::SavedModel(format!(
                        "force model has unknown parameter `{other}`"
                    )));
                }
            }
        }
        m.validate().map_err(|e| {
            IdentifyError::SavedModel(format!(
                "force parameters rejected by the physics crate: {e}"
            ))
        })?;
        Ok(m)
    }
}

/// Current UTC time as `YYYY-MM-DDThh:mm:ssZ`.
pub fn utc_now_rfc3339() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    rfc3339_from_unix(secs)
}

/// Formats Unix seconds as `YYYY-MM-DDThh:mm:ssZ` (proleptic Gregorian; H. Hinnant's
/// `civil_from_days` algorithm).
pub fn rfc3339_from_unix(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        sod / 3600,
        (sod % 3600) / 60,
        sod % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates() {
        // Reference: `date -u -d @0` and `date -u -d @951782400` (GNU coreutils).
        assert_eq!(rfc3339_from_unix(0), "1970-01-01T00:00:00Z");
        assert_eq!(rfc3339_from_unix(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(rfc3339_from_unix(1_700_000_000), "2023-11-14T22:13:20Z");
    }
}
