//! A model bundle (kind `bundle`): everything a machine's commissioning identified — the PZT spindle, the
//! force model, the tool/spindle stiffness — in one file, each with its covariance, plus the material the
//! force model was commissioned on and the identification's warnings. Controllers are built from a bundle
//! and nothing else; a controller that needs a model the bundle lacks, or a bundle of another material,
//! is an error naming the file and the key.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{ModelError, Result};
use crate::identified::{
    ForceModelParams, HysteresisModel, IdentifiedModel, SensorNoise, SpindleModel, StiffnessModel,
};

/// The `[model]` table of a bundle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelBundle {
    /// Workpiece material the force model was commissioned on (`S7`, `6061`, …).
    pub material: String,
    /// How each model was obtained (e.g. `force: 2^2 DOE with 2 centre points, 10 cuts, profilometer
    /// depths`), in the order of the experiments.
    #[serde(default)]
    pub experiments: Vec<String>,
    /// Warnings of the identifications (identifiability, residual structure, structure selection).
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The PZT spindle (kind `spindle` of `millcomp identify`).
    #[serde(default)]
    pub spindle: Option<IdentifiedModel>,
    /// The force model (kind `force`).
    #[serde(default)]
    pub force: Option<IdentifiedModel>,
    /// The tool/spindle stiffness (kind `stiffness`, directions `axial` and `radial`).
    #[serde(default)]
    pub stiffness: Option<IdentifiedModel>,
    /// The sensors' noise levels from a record at rest (kind `sensor_noise`); absent in bundles assembled
    /// from separate calibration files and in bundles written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_noise: Option<IdentifiedModel>,
    /// The PZT stack's hysteresis from a quasi-static sweep in air (kind `hysteresis`); absent in bundles
    /// written before it existed and in bundles assembled from files without one: the controllers then
    /// take the stack as linear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hysteresis: Option<IdentifiedModel>,
}

impl ModelBundle {
    /// Kinds this type reads.
    pub const KINDS: [&'static str; 1] = ["bundle"];

    fn need<'a>(
        m: &'a Option<IdentifiedModel>,
        key: &str,
        origin: &Path,
        needed_by: &str,
    ) -> Result<&'a IdentifiedModel> {
        m.as_ref().ok_or_else(|| ModelError::MissingKey {
            path: origin.to_path_buf(),
            kind: "bundle".into(),
            key: format!("model.{key} (needed by {needed_by})"),
            available: "see the bundle's [model.*] tables".into(),
        })
    }

    /// The spindle, which `needed_by` (a controller's name, for the message) needs.
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.spindle` when the bundle has none; the view's errors.
    pub fn spindle(&self, origin: &Path, needed_by: &str) -> Result<SpindleModel> {
        SpindleModel::from_identified(
            Self::need(&self.spindle, "spindle", origin, needed_by)?,
            origin,
        )
    }

    /// The force-model parameters, which `needed_by` needs.
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.force`; the view's errors.
    pub fn force(&self, origin: &Path, needed_by: &str) -> Result<ForceModelParams> {
        ForceModelParams::from_identified(
            Self::need(&self.force, "force", origin, needed_by)?,
            origin,
        )
    }

    /// The stiffness, which `needed_by` needs.
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.stiffness`; the view's errors.
    pub fn stiffness(&self, origin: &Path, needed_by: &str) -> Result<StiffnessModel> {
        StiffnessModel::from_identified(
            Self::need(&self.stiffness, "stiffness", origin, needed_by)?,
            origin,
        )
    }

    /// The sensors' noise levels a Kalman filter assumes, and where they come from: the bundle's record at
    /// rest, or else the RMS residuals of its spindle step test and force calibration
    /// ([`SensorNoise::from_residuals`]).
    ///
    /// # Errors
    /// [`ModelError::MissingKey`] naming `model.sensor_noise` when the bundle has neither a record nor a
    /// spindle and a force model; the view's errors.
    pub fn sensor_noise(
        &self,
        origin: &Path,
        needed_by: &str,
    ) -> Result<(SensorNoise, &'static str)> {
        if let Some(m) = &self.sensor_noise {
            return Ok((SensorNoise::from_identified(m, origin)?, "a record at rest"));
        }
        match (&self.spindle, &self.force) {
            (Some(s), Some(f)) => Ok((
                SensorNoise::from_residuals(s, f, origin)?,
                "the spindle and force fits' RMS residuals (the bundle has no record at rest)",
            )),
            _ => Err(ModelError::MissingKey {
                path: origin.to_path_buf(),
                kind: "bundle".into(),
                key: format!("model.sensor_noise (needed by {needed_by})"),
                available:
                    "a sensor_noise record, or a spindle and a force model whose residuals stand in"
                        .into(),
            }),
        }
    }

    /// A bundle assembled from models identified separately from the user's own calibration records
    /// (`millcomp identify spindle|force|stiffness FILE --save MODEL.toml`): each file is loaded as its
    /// kind and checked through its typed view, so a file of the wrong kind, another format version or
    /// one missing a parameter is refused here, naming the file and the key. The experiments record each
    /// file with the command that made it; the models' warnings are kept, prefixed by their part.
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] naming `model` when no file is given; the loading and view errors of
    /// each file (I/O, format, version, kind, missing or invalid parameters).
    ///
    /// # Examples
    /// ```
    /// use millcomp_models::{ModelBundle, ModelFile, Provenance, IdentifiedModel};
    /// # let dir = tempfile::tempdir().unwrap();
    /// # let path = dir.path().join("k.toml");
    /// let k: IdentifiedModel = toml::from_str(r#"
    /// status = "converged"
    /// n_obs = 60
    /// dof = 56
    /// rms_residual = 0.3
    /// residual_unit = "um"
    /// [params]
    /// axial_stiffness_n_per_um = 1.21
    /// radial_stiffness_n_per_um = 0.115
    /// [std_err]
    /// axial_stiffness_n_per_um = 0.03
    /// radial_stiffness_n_per_um = 0.001
    /// [covariance]
    /// names = []
    /// values = []
    /// "#).unwrap();
    /// ModelFile::new("stiffness", k, Provenance::now("millcomp", "identify stiffness cal.csv"))
    ///     .save(&path)
    ///     .unwrap();
    /// let b = ModelBundle::from_files("S7", None, None, Some(&path)).unwrap();
    /// assert_eq!(b.stiffness(&path, "pid").unwrap().radial_n_per_um, 0.115);
    /// assert!(b.experiments[0].contains("identify stiffness cal.csv"));
    /// assert!(b.spindle.is_none());
    /// ```
    pub fn from_files(
        material: &str,
        spindle: Option<&Path>,
        force: Option<&Path>,
        stiffness: Option<&Path>,
    ) -> Result<Self> {
        if spindle.is_none() && force.is_none() && stiffness.is_none() {
            return Err(ModelError::InvalidValue {
                path: Path::new("<bundle>").to_path_buf(),
                key: "model".into(),
                value: "no model file".into(),
                allowed: "at least one of a spindle, force or stiffness model".into(),
            });
        }
        let mut experiments = Vec::new();
        let mut warnings = Vec::new();
        // each part: loaded as its kind, checked through its typed view, recorded with its command
        let mut load = |part: &str,
                        path: Option<&Path>,
                        check: fn(&IdentifiedModel, &Path) -> Result<()>|
         -> Result<Option<IdentifiedModel>> {
            let Some(path) = path else { return Ok(None) };
            let f = crate::ModelFile::<IdentifiedModel>::load(path, &[part])?;
            check(&f.model, path)?;
            experiments.push(format!(
                "{part}: {} (`{}`, {} observations, {:?})",
                path.display(),
                f.header.provenance.command,
                f.model.n_obs,
                f.model.status
            ));
            warnings.extend(f.model.warnings.iter().map(|w| format!("{part}: {w}")));
            Ok(Some(f.model))
        };
        let spindle = load("spindle", spindle, |m, p| {
            SpindleModel::from_identified(m, p).map(drop)
        })?;
        let force = load("force", force, |m, p| {
            ForceModelParams::from_identified(m, p).map(drop)
        })?;
        let stiffness = load("stiffness", stiffness, |m, p| {
            StiffnessModel::from_identified(m, p).map(drop)
        })?;
        Ok(ModelBundle {
            material: material.to_string(),
            experiments,
            warnings,
            spindle,
            force,
            stiffness,
            sensor_noise: None,
            hysteresis: None,
        })
    }

    /// The stack's hysteresis, when the bundle has one (a commissioning's sweep in air).
    ///
    /// # Errors
    /// The view's errors ([`HysteresisModel::from_identified`]).
    pub fn hysteresis(&self, origin: &Path) -> Result<Option<HysteresisModel>> {
        self.hysteresis
            .as_ref()
            .map(|m| HysteresisModel::from_identified(m, origin))
            .transpose()
    }

    /// Checks that the force model was commissioned on `material` (the material a scenario cuts).
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] naming `model.material` and both materials.
    pub fn check_material(&self, material: &str, origin: &Path) -> Result<()> {
        if self.material.trim().eq_ignore_ascii_case(material.trim()) {
            Ok(())
        } else {
            Err(ModelError::InvalidValue {
                path: origin.to_path_buf(),
                key: "model.material".into(),
                value: format!("`{}`", self.material),
                allowed: format!(
                    "the material the scenario cuts, `{material}` (a force model commissioned on another \
                     material does not predict this one: commission again)"
                ),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identified::{FitStatus, NamedMatrix};
    use crate::{ModelFile, Provenance};

    fn identified(params: &[(&str, f64)]) -> IdentifiedModel {
        IdentifiedModel {
            status: FitStatus::Converged,
            n_obs: 20,
            dof: 18,
            rms_residual: 0.1,
            residual_unit: "um".into(),
            warnings: vec![],
            params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            std_err: Default::default(),
            fixed: Default::default(),
            derived: Default::default(),
            covariance: NamedMatrix::default(),
        }
    }

    fn bundle() -> ModelBundle {
        ModelBundle {
            material: "S7".into(),
            experiments: vec![],
            warnings: vec![],
            spindle: None,
            force: Some(identified(&[("w_mpa", 6100.0)])),
            stiffness: Some(identified(&[
                ("axial_stiffness_n_per_um", 1.2),
                ("radial_stiffness_n_per_um", 0.114),
            ])),
            sensor_noise: None,
            hysteresis: None,
        }
    }

    #[test]
    fn a_missing_model_names_the_file_and_the_key() {
        let e = bundle()
            .spindle(Path::new("models.toml"), "mpc")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("models.toml") && e.contains("model.spindle") && e.contains("mpc"),
            "{e}"
        );
        let k = bundle().stiffness(Path::new("m"), "pid-tuned").unwrap();
        assert_eq!(k.radial_n_per_um, 0.114);
    }

    #[test]
    fn the_noise_levels_come_from_the_record_else_from_the_residuals_else_an_error() {
        let origin = Path::new("models.toml");
        // no record and no spindle: nothing measured the gauge
        let e = bundle()
            .sensor_noise(origin, "mpc")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("models.toml") && e.contains("model.sensor_noise") && e.contains("mpc"),
            "{e}"
        );
        // a spindle (residuals in µm) and a force model (residuals in N) stand in
        let mut b = bundle();
        b.spindle = Some(identified(&[("gain_um_per_v", 0.044)]));
        b.force.as_mut().unwrap().residual_unit = "n".into();
        b.force.as_mut().unwrap().rms_residual = 0.02;
        let (n, from) = b.sensor_noise(origin, "mpc").unwrap();
        assert_eq!((n.force_noise_n, n.gauge_noise_um), (0.02, 0.1));
        assert!(from.contains("residuals"), "{from}");
        // a force model whose residuals are not in N cannot stand in for the force channel
        b.force.as_mut().unwrap().residual_unit = "um".into();
        let e = b.sensor_noise(origin, "mpc").unwrap_err().to_string();
        assert!(e.contains("model.force.rms_residual"), "{e}");
        // the record wins, and a negative level is refused naming the key
        b.sensor_noise = Some(identified(&[
            ("force_noise_n", 0.0416),
            ("gauge_noise_um", 0.0101),
        ]));
        let (n, from) = b.sensor_noise(origin, "mpc").unwrap();
        assert_eq!((n.force_noise_n, from), (0.0416, "a record at rest"));
        b.sensor_noise = Some(identified(&[
            ("force_noise_n", -0.1),
            ("gauge_noise_um", 0.0101),
        ]));
        let e = b.sensor_noise(origin, "mpc").unwrap_err().to_string();
        assert!(e.contains("model.params.force_noise_n"), "{e}");
    }

    #[test]
    fn another_material_is_refused_naming_the_key() {
        let e = bundle()
            .check_material("6061", Path::new("models.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("model.material") && e.contains("6061"), "{e}");
        bundle().check_material("s7", Path::new("m")).unwrap();
    }

    #[test]
    fn round_trips_as_a_model_file() {
        let f = ModelFile::new("bundle", bundle(), Provenance::now("test", "test"));
        let text = f.to_toml().unwrap();
        let back =
            ModelFile::<ModelBundle>::from_toml(&text, Path::new("b.toml"), &ModelBundle::KINDS)
                .unwrap();
        assert_eq!(back, f);
        assert!(text.contains("[model.force.params]"), "{text}");
    }
}
