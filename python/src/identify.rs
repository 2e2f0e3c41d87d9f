//! `millcomp.identify`: `fit(kind, frame, **options)` (as `millcomp identify KIND FILE`) and
//! `load(path)`; a [`PyModel`] saves in the one model-file format the CLI reads.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Context;
use millcomp_identify::targets::force::ForceParam;
use millcomp_identify::targets::thermal::ThermalModel;
use millcomp_identify::targets::wall::WallGeometry;
use millcomp_identify::{Identified, IdentifiedModel, IdentifyOptions, Target, identify_columns};
use millcomp_models::{Header, InputFile, ModelFile};
use pyo3::prelude::*;
use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::errors::{ArgumentError, raise};
use crate::input::{Source, provenance, read};
use crate::json::to_py;

/// The kinds `identify.load` reads: every identified model `millcomp identify --save` writes
/// (`models/MODEL.md`).
const IDENTIFIED_KINDS: [&str; 13] = [
    "spindle",
    "stiffness",
    "force",
    "thermal_exponential",
    "thermal_linear_temp",
    "thermal_speed",
    "wall",
    "part_scale",
    "part_compliance",
    "kienzle",
    "feed_axis",
    "hysteresis",
    "sensor_noise",
];

/// An identified model: estimates with their uncertainty, from a fit or a model file.
#[pyclass(name = "Model", module = "millcomp._core", frozen)]
pub struct PyModel {
    kind: String,
    model: IdentifiedModel,
    fit: Option<Identified>,
    inputs: Vec<InputFile>,
    header: Option<Header>,
    /// Notes on reading the input (columns ignored or renamed), which the CLI prints on stderr.
    input_notes: Vec<String>,
}

/// The options of `identify.fit`, as the CLI's flags.
#[derive(Debug, Default)]
pub struct FitOptions {
    model: Option<String>,
    extra_pole: bool,
    dead_time: bool,
    tilt_deg: Vec<f64>,
    machine_stiffness_n_per_um: Option<f64>,
    free: Vec<String>,
    material: Option<String>,
    relative_errors: bool,
    wall_geometry: Option<Vec<f64>>,
}

fn arg(message: String) -> anyhow::Error {
    ArgumentError(message).into()
}

impl FitOptions {
    fn to_options(&self) -> anyhow::Result<IdentifyOptions> {
        let thermal_model: ThermalModel = self
            .model
            .as_deref()
            .unwrap_or("exponential")
            .parse()
            .map_err(|e: millcomp_identify::IdentifyError| {
                anyhow::Error::new(e).context(ArgumentError("argument `model`".to_string()))
            })?;
        let force_free = self
            .free
            .iter()
            .map(|n| {
                ForceParam::parse(n).map_err(|e| {
                    anyhow::Error::new(e).context(ArgumentError(format!("argument `free`: {n}")))
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let wall_geometry = match self.wall_geometry.as_deref() {
            None | Some([]) => None,
            Some([height_um, thickness_um, length_um]) => Some(WallGeometry {
                height_um: *height_um,
                thickness_um: *thickness_um,
                length_um: *length_um,
            }),
            Some(other) => {
                return Err(arg(format!(
                    "argument `wall_geometry` takes (height_um, thickness_um, length_um), 3 numbers, got {}",
                    other.len()
                )));
            }
        };
        Ok(IdentifyOptions {
            thermal_model,
            spindle_extra_pole: self.extra_pole,
            spindle_dead_time: self.dead_time,
            tilt_deg: self.tilt_deg.clone(),
            machine_stiffness_n_per_um: self.machine_stiffness_n_per_um,
            force_free,
            material: self.material.clone(),
            relative_errors: self.relative_errors,
            wall_geometry,
            ..Default::default()
        })
    }
}

/// Fits `kind` to `source` (a path or a table), as `millcomp identify KIND FILE`.
#[pyfunction]
#[pyo3(signature = (kind, source, columns = None, model = None, extra_pole = false,
    dead_time = false, tilt_deg = None, machine_stiffness_n_per_um = None, free = None,
    material = None, relative_errors = false, wall_geometry = None))]
#[allow(clippy::too_many_arguments)]
pub fn fit(
    py: Python<'_>,
    kind: String,
    source: &Bound<'_, PyAny>,
    columns: Option<String>,
    model: Option<String>,
    extra_pole: bool,
    dead_time: bool,
    tilt_deg: Option<Vec<f64>>,
    machine_stiffness_n_per_um: Option<f64>,
    free: Option<Vec<String>>,
    material: Option<String>,
    relative_errors: bool,
    wall_geometry: Option<Vec<f64>>,
) -> PyResult<PyModel> {
    let target: Target = match kind.as_str() {
        "wear" | "flutes" => {
            return Err(raise(arg(format!(
                "argument `kind`: `{kind}` is a study of a measured record with no model-file kind \
                 yet; run `millcomp identify {kind}` (the package fits spindle, stiffness, force, \
                 thermal, wall, part, kienzle, feed-axis, hysteresis)"
            ))));
        }
        k => k.parse().map_err(|e| {
            raise(anyhow::Error::new(e).context(ArgumentError("argument `kind`".to_string())))
        })?,
    };
    let options = FitOptions {
        model,
        extra_pole,
        dead_time,
        tilt_deg: tilt_deg.unwrap_or_default(),
        machine_stiffness_n_per_um,
        free: free.unwrap_or_default(),
        material,
        relative_errors,
        wall_geometry,
    };
    let source = Source::of(source, "frame")?;
    py.detach(|| -> anyhow::Result<PyModel> {
        let opts = options.to_options()?;
        let read = read(source, "frame", columns.as_deref())?;
        let cols = millcomp_datasets::adapters::identify_columns(&read.table);
        let mut fit = identify_columns(target, &cols, &opts)
            .with_context(|| format!("{}: identify {}", read.origin, target.name()))?;
        // as the CLI: one unit's intervals do not cover another unit's
        fit.notes
            .push(millcomp_identify::units::one_unit_note(None));
        Ok(PyModel {
            input_notes: read.notes.clone(),
            kind: fit.kind.clone(),
            model: fit.model.clone(),
            inputs: vec![read.input_file()?],
            fit: Some(fit),
            header: None,
        })
    })
    .map_err(raise)
}

/// Reads a model file `millcomp identify --save` (or `Model.save`) wrote.
#[pyfunction]
pub fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyModel> {
    py.detach(|| -> anyhow::Result<PyModel> {
        let file = ModelFile::<IdentifiedModel>::load(&path, &IDENTIFIED_KINDS)?;
        Ok(PyModel {
            kind: file.header.kind.clone(),
            inputs: file.header.provenance.inputs.clone(),
            model: file.model,
            input_notes: Vec::new(),
            fit: None,
            header: Some(file.header),
        })
    })
    .map_err(raise)
}

impl PyModel {
    /// The 95 % intervals: the fit's, or for a loaded model `θ ± t₀.₉₇₅(dof)·SE` (models/MODEL.md).
    fn ci95(&self) -> BTreeMap<String, (f64, f64)> {
        if let Some(f) = &self.fit {
            return f
                .report
                .ci95
                .iter()
                .map(|(k, v)| (k.clone(), (v[0], v[1])))
                .collect();
        }
        let t = StudentsT::new(0.0, 1.0, self.model.dof as f64)
            .map(|d| d.inverse_cdf(0.975))
            .unwrap_or(f64::NAN);
        self.model
            .params
            .iter()
            .map(|(k, v)| {
                let se = self.model.std_err.get(k).copied().unwrap_or(f64::NAN);
                (k.clone(), (v - t * se, v + t * se))
            })
            .collect()
    }
}

#[pymethods]
impl PyModel {
    /// The model-file kind (`spindle`, `force`, `thermal_exponential`, …).
    #[getter]
    fn kind(&self) -> String {
        self.kind.clone()
    }

    /// The estimates, by name (names carry their unit).
    #[getter]
    fn params(&self) -> BTreeMap<String, f64> {
        self.model.params.clone()
    }

    /// Standard errors (`inf` for a parameter the data do not determine).
    #[getter]
    fn std_err(&self) -> BTreeMap<String, f64> {
        self.model.std_err.clone()
    }

    /// 95 % intervals `(low, high)` by name.
    #[getter]
    fn intervals(&self) -> BTreeMap<String, (f64, f64)> {
        self.ci95()
    }

    /// Known inputs held fixed in the fit.
    #[getter]
    fn fixed(&self) -> BTreeMap<String, f64> {
        self.model.fixed.clone()
    }

    /// How the fit ended: `converged`, `stalled_at_rounding_level`, `not_converged`,
    /// `rank_deficient` (an outcome, not an error).
    #[getter]
    fn status(&self) -> PyResult<String> {
        let v =
            serde_json::to_value(self.model.status).map_err(|e| raise(anyhow::Error::new(e)))?;
        Ok(v.as_str().unwrap_or_default().to_string())
    }

    /// The fit's warnings (identifiability, bounds, residual diagnostics).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.model.warnings.clone()
    }

    /// Notes on the input (columns ignored or renamed); empty for a loaded model.
    #[getter]
    fn notes(&self) -> Vec<String> {
        let fit = self
            .fit
            .as_ref()
            .map(|f| f.notes.clone())
            .unwrap_or_default();
        self.input_notes.iter().cloned().chain(fit).collect()
    }

    /// The fit report as `millcomp --json identify` prints it; for a loaded model, the file's
    /// `[model]` table.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.fit {
            Some(f) => to_py(py, f),
            None => to_py(py, &self.model),
        }
    }

    /// The `[header]` of a loaded file (format, version, kind, provenance), `None` for a fit.
    #[getter]
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.header.as_ref().map(|h| to_py(py, h)).transpose()
    }

    /// Writes the model in the model-file format (`models/MODEL.md`) the CLI reads, atomically;
    /// `command` goes into the provenance with the inputs' SHA-256.
    #[pyo3(signature = (path, command = "millcomp.identify.fit(...)".to_string()))]
    fn save(&self, py: Python<'_>, path: PathBuf, command: String) -> PyResult<()> {
        py.detach(|| -> anyhow::Result<()> {
            let prov = match &self.header {
                Some(h) => {
                    let mut p = h.provenance.clone();
                    p.command = command.clone();
                    p
                }
                None => provenance(&command, self.inputs.clone()),
            };
            ModelFile::new(&self.kind, self.model.clone(), prov)
                .save(&path)
                .with_context(|| format!("saving the model to {}", path.display()))?;
            Ok(())
        })
        .map_err(raise)
    }

    fn __repr__(&self) -> String {
        let params: Vec<String> = self
            .model
            .params
            .iter()
            .map(|(k, v)| format!("{k}={v:.6}"))
            .collect();
        format!(
            "<millcomp Model {} [{:?}]: {}>",
            self.kind,
            self.model.status,
            params.join(", ")
        )
    }
}
