//! The long calls: `simulate` (a closed-loop scenario), `simulate_session`, `commission`, `diagnose`
//! and `batch` — each the library call `millcomp simulate|commission|diagnose|batch` makes, with the
//! GIL released while it runs, and results as the CLI's `--json` documents plus frames.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use anyhow::{Context, bail};
use millcomp_closedloop::batch::{
    BatchRequest, ProgressMode, ProgressUpdate, ScenarioSource, run_batch,
};
use millcomp_closedloop::commissioning::{CommissioningPlant, commission as commission_plant};
use millcomp_closedloop::groove::groove_truth;
use millcomp_closedloop::scenario::StageKind;
use millcomp_closedloop::{ClosedLoopError, ControllerKind, RunOutput, Scenario};
use millcomp_diagnose::{DiagnoseOptions, Measured, Multiplicity, diagnose as diagnose_session};
use millcomp_models::{InputFile, ModelBundle, ModelFile};
use millcomp_sim::sensors::{NoiseSpec, PROFILOMETER_SIGMA_UM};
use millcomp_sim::session::{Session, SimOptions, groove_summaries, simulate_session};
use polars::prelude::{Column, DataFrame, NamedFrom, PlSmallStr, Series};
use pyo3::prelude::*;
use serde_json::json;

use crate::arrow::to_polars;
use crate::errors::{ArgumentError, exception, raise};
use crate::input::{Source, input_of, provenance};
use crate::json::to_py;

/// A closed-loop run (`simulate`) or a simulated session (`simulate_session`): the report and the
/// trace.
#[pyclass(name = "Simulation", module = "millcomp._core", frozen)]
pub struct PySimulation {
    report: serde_json::Value,
    trace: DataFrame,
}

#[pymethods]
impl PySimulation {
    /// The report, as `millcomp --json simulate` prints it.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The run's metrics (`pp_error_um`, `rms_error_um`, …); for a session, the per-groove summary.
    #[getter]
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match self.report.get("metrics") {
            Some(m) => to_py(py, m),
            None => to_py(py, &self.report["grooves"]),
        }
    }

    /// The trace (a closed-loop run: one row per controller cycle, the columns of `simulate --out`;
    /// a session: the measured-groove table).
    #[getter]
    fn trace<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_polars(py, self.trace.clone())
    }

    fn __repr__(&self) -> String {
        match self.report.get("metrics") {
            Some(m) => format!(
                "<millcomp Simulation {} / {}: pp error {:.3} um, {} trace rows>",
                self.report["scenario"].as_str().unwrap_or("?"),
                self.report["controller"].as_str().unwrap_or("?"),
                m["pp_error_um"].as_f64().unwrap_or(f64::NAN),
                self.trace.height()
            ),
            None => format!(
                "<millcomp Simulation of session {}: {} points>",
                self.report["session"].as_str().unwrap_or("?"),
                self.trace.height()
            ),
        }
    }
}

fn trace_frame(out: &RunOutput) -> anyhow::Result<DataFrame> {
    let t = &out.trace;
    let columns: Vec<Column> = t
        .columns
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let v: Vec<f64> = t
                .rows
                .iter()
                .map(|r| r.get(j).copied().unwrap_or(f64::NAN))
                .collect();
            Series::new(PlSmallStr::from(name.as_str()), v).into()
        })
        .collect();
    Ok(DataFrame::new(t.rows.len(), columns)?)
}

/// One closed-loop run of a scenario file, as `millcomp simulate SCENARIO --controller K`.
#[pyfunction]
#[pyo3(signature = (scenario, controller = "none".to_string(), realtime = false,
    budget_fraction = None))]
pub fn simulate(
    py: Python<'_>,
    scenario: PathBuf,
    controller: String,
    realtime: bool,
    budget_fraction: Option<f64>,
) -> PyResult<PySimulation> {
    py.detach(|| -> anyhow::Result<PySimulation> {
        let mut s = Scenario::load(&scenario)?;
        s.control.realtime = realtime;
        if budget_fraction.is_some() {
            s.control.budget_fraction = budget_fraction;
        }
        let kind: ControllerKind = controller.parse().map_err(|e: ClosedLoopError| {
            anyhow::Error::new(e).context(ArgumentError("argument `controller`".to_string()))
        })?;
        let out = millcomp_closedloop::run_scenario_with_trace(&s, kind).with_context(|| {
            format!(
                "{}: closed-loop run with `{controller}`",
                scenario.display()
            )
        })?;
        Ok(PySimulation {
            report: serde_json::to_value(&out.report)?,
            trace: trace_frame(&out)?,
        })
    })
    .map_err(raise)
}

/// A groove session simulated, as `millcomp simulate SESSION` (the measured-groove table; noise with
/// `noise_seed`).
#[pyfunction]
#[pyo3(signature = (session, noise_seed = None))]
pub fn simulate_session_file(
    py: Python<'_>,
    session: PathBuf,
    noise_seed: Option<u64>,
) -> PyResult<PySimulation> {
    py.detach(|| -> anyhow::Result<PySimulation> {
        let s = Session::from_path(&session)
            .with_context(|| format!("reading session {}", session.display()))?;
        let options = SimOptions {
            noise: noise_seed.map(|seed| NoiseSpec {
                seed,
                sigma: PROFILOMETER_SIGMA_UM,
            }),
        };
        let points = simulate_session(&s, &options)
            .with_context(|| format!("simulating {}", session.display()))?;
        if points.is_empty() {
            bail!("{}: the session plan measures no points", session.display());
        }
        let table = millcomp_datasets::contracts::measured_groove_table(&s.name, &points)?;
        Ok(PySimulation {
            report: json!({
                "session": s.name,
                "n_points": points.len(),
                "noise_sigma_um": options.noise.map(|n| n.sigma),
                "grooves": groove_summaries(&points),
                "out": null,
                "plot": null,
            }),
            trace: table.to_dataframe()?,
        })
    })
    .map_err(raise)
}

/// A commissioning: the model bundle the controllers are built from.
#[pyclass(name = "Commissioning", module = "millcomp._core", frozen)]
pub struct PyCommissioning {
    report: serde_json::Value,
    bundle: ModelBundle,
    inputs: Vec<InputFile>,
}

#[pymethods]
impl PyCommissioning {
    /// The report, as `millcomp --json commission` prints it.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The bundle (its `[model]` table).
    #[getter]
    fn bundle<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.bundle)
    }

    /// Writes the bundle (kind `bundle`) as `commission --out` does, atomically; a scenario's
    /// `control.bundle` can name it.
    #[pyo3(signature = (path, command = "millcomp.commission(...)".to_string()))]
    fn save(&self, py: Python<'_>, path: PathBuf, command: String) -> PyResult<()> {
        py.detach(|| -> anyhow::Result<()> {
            ModelFile::new(
                "bundle",
                self.bundle.clone(),
                provenance(&command, self.inputs.clone()),
            )
            .save(&path)
            .with_context(|| format!("writing {}", path.display()))?;
            Ok(())
        })
        .map_err(raise)
    }

    fn __repr__(&self) -> String {
        format!(
            "<millcomp Commissioning (material {})>",
            self.bundle.material
        )
    }
}

/// A scenario's machine commissioned through its instruments, or a bundle from your own model files,
/// as `millcomp commission`.
#[pyfunction]
#[pyo3(signature = (scenario = None, seed = None, spindle = None, force = None, stiffness = None,
    material = None))]
pub fn commission(
    py: Python<'_>,
    scenario: Option<PathBuf>,
    seed: Option<u64>,
    spindle: Option<PathBuf>,
    force: Option<PathBuf>,
    stiffness: Option<PathBuf>,
    material: Option<String>,
) -> PyResult<PyCommissioning> {
    py.detach(|| -> anyhow::Result<PyCommissioning> {
        let files = [&spindle, &force, &stiffness];
        let Some(path) = scenario else {
            if files.iter().all(|f| f.is_none()) {
                return Err(ArgumentError(
                    "give `scenario`, or `spindle`/`force`/`stiffness` model files with `material`"
                        .to_string(),
                )
                .into());
            }
            if seed.is_some() {
                return Err(ArgumentError("argument `seed` needs `scenario`".to_string()).into());
            }
            let material = material.as_deref().ok_or_else(|| {
                ArgumentError(
                    "argument `material`: give the workpiece material the force model was identified on"
                        .to_string(),
                )
            })?;
            let bundle = ModelBundle::from_files(
                material,
                spindle.as_deref(),
                force.as_deref(),
                stiffness.as_deref(),
            )?;
            let inputs = files
                .into_iter()
                .flatten()
                .map(|p| input_of(p))
                .collect::<anyhow::Result<Vec<_>>>()?;
            return Ok(PyCommissioning {
                report: json!({ "bundle": bundle, "out": null }),
                bundle,
                inputs,
            });
        };
        if files.iter().any(|f| f.is_some()) {
            return Err(ArgumentError(
                "`scenario` commissions a simulated machine; `spindle`/`force`/`stiffness` assemble \
                 your own models: give one or the other"
                    .to_string(),
            )
            .into());
        }
        let s = Scenario::load(&path)?;
        if s.stage != StageKind::Groove {
            bail!(
                "{}: stage: commissioning is implemented for groove scenarios (the thin wall is not commissioned yet)",
                path.display()
            );
        }
        let truth = groove_truth(&s)?;
        let seed = seed.unwrap_or(s.seed);
        let plant = CommissioningPlant::of_scenario(&s, &truth);
        let c = commission_plant(&plant, &s.commissioning, seed)?;
        Ok(PyCommissioning {
            report: json!({
                "scenario": s.name,
                "seed": seed,
                "bundle": c.bundle,
                "spindle_bic": c.spindle_bic,
                "out": null,
            }),
            bundle: c.bundle,
            inputs: vec![input_of(&path)?],
        })
    })
    .map_err(raise)
}

/// A diagnosis: the named effects and the gap before and after.
#[pyclass(name = "Diagnosis", module = "millcomp._core", frozen)]
pub struct PyDiagnosis {
    report: serde_json::Value,
}

#[pymethods]
impl PyDiagnosis {
    /// The report, as `millcomp --json diagnose` prints it.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The physical effects named, in the order they were added.
    #[getter]
    fn named<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["named"])
    }

    /// The gap between model and measurement: RMS residual (µm) of the nominal model, after the
    /// nuisance step, and with the named effects.
    #[getter]
    fn gap<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(
            py,
            &json!({
                "nominal_rms_um": self.report["initial_rms_um"],
                "nuisance_rms_um": self.report["nuisance_rms_um"],
                "final_rms_um": self.report["final_rms_um"],
            }),
        )
    }

    /// The verdict in words.
    #[getter]
    fn verdict(&self) -> String {
        self.report["verdict"]
            .as_str()
            .unwrap_or_default()
            .to_string()
    }

    fn __repr__(&self) -> String {
        format!(
            "<millcomp Diagnosis of {}: named {}; RMS {:.3} -> {:.3} um>",
            self.report["session"].as_str().unwrap_or("?"),
            self.report["named"],
            self.report["initial_rms_um"].as_f64().unwrap_or(f64::NAN),
            self.report["final_rms_um"].as_f64().unwrap_or(f64::NAN)
        )
    }
}

/// Diagnoses a measured groove session (a measured-groove file or frame) against its session file,
/// as `millcomp diagnose SESSION MEASURED`.
#[pyfunction]
#[pyo3(signature = (session, measured, alpha = 0.01, candidates = None, free_offset = false,
    bonferroni = false, forces = None, columns = None))]
#[allow(clippy::too_many_arguments)]
pub fn diagnose(
    py: Python<'_>,
    session: PathBuf,
    measured: &Bound<'_, PyAny>,
    alpha: f64,
    candidates: Option<Vec<String>>,
    free_offset: bool,
    bonferroni: bool,
    forces: Option<PathBuf>,
    columns: Option<String>,
) -> PyResult<PyDiagnosis> {
    let measured = Source::of(measured, "measured")?;
    py.detach(|| -> anyhow::Result<PyDiagnosis> {
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(
                ArgumentError(format!("argument `alpha` must be in (0, 1), got {alpha}")).into(),
            );
        }
        let s = Session::from_path(&session)
            .with_context(|| format!("reading session {}", session.display()))?;
        let (origin, file) = match measured {
            Source::Path(p) => {
                let file = match &columns {
                    Some(c) => millcomp_datasets::contracts::read_measured_groove_mapped(
                        &p,
                        &millcomp_datasets::mapping::ColumnMap::parse(c)?,
                    )?,
                    None => millcomp_datasets::contracts::read_measured_groove(&p)?,
                };
                (p.display().to_string(), file)
            }
            Source::Frame(df) => {
                if columns.is_some() {
                    return Err(ArgumentError(
                        "argument `columns` applies to a file; rename a frame's columns in the frame"
                            .to_string(),
                    )
                    .into());
                }
                let file =
                    millcomp_datasets::contracts::measured_groove_from_dataframe("measured", &df)?;
                ("measured".to_string(), file)
            }
        };
        let mut m = Measured::new(origin.clone(), file.points);
        if let Some(path) = &forces {
            m = m.with_forces(
                path.display().to_string(),
                millcomp_datasets::contracts::read_force_trace(path)?,
            );
        }
        let options = DiagnoseOptions {
            alpha,
            candidates: candidates.filter(|c| !c.is_empty()),
            free_offset,
            multiplicity: if bonferroni {
                Multiplicity::Bonferroni
            } else {
                DiagnoseOptions::default().multiplicity
            },
            ..DiagnoseOptions::default()
        };
        let report = diagnose_session(&s, &m, &options).with_context(|| {
            format!("diagnosing {origin} against {}", session.display())
        })?;
        Ok(PyDiagnosis {
            report: serde_json::to_value(&report)?,
        })
    })
    .map_err(raise)
}

/// A batch's outcome: its summary (`summary.json`) and where its files are.
#[pyclass(name = "BatchSummary", module = "millcomp._core", frozen)]
pub struct PyBatch {
    summary: serde_json::Value,
    out: PathBuf,
}

#[pymethods]
impl PyBatch {
    /// The summary, as `millcomp --json batch` prints it (results, the ANOVA with the controller as
    /// a factor, the paired comparisons; and the invocation).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary)
    }

    /// The output directory (`results.parquet`, `summary.json`, `plots/`, `runs/`).
    #[getter]
    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    /// The results frame: one row per run (scenario, controller, factors, metrics, status), the
    /// batch's own `results.parquet` (read through polars, no CSV).
    #[getter]
    fn results<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let path = self.out.join("results.parquet");
        let df = py
            .detach(|| -> anyhow::Result<DataFrame> {
                use polars::prelude::{ParquetReader, SerReader};
                let file = std::fs::File::open(&path)
                    .with_context(|| format!("reading {}", path.display()))?;
                ParquetReader::new(file)
                    .finish()
                    .with_context(|| format!("reading {}", path.display()))
            })
            .map_err(raise)?;
        to_polars(py, df)
    }

    fn __repr__(&self) -> String {
        format!(
            "<millcomp BatchSummary: {} runs of {} planned, in {}>",
            self.summary["n_runs"],
            self.summary["n_runs_planned"],
            self.out.display()
        )
    }
}

/// Runs a batch (`run_batch`): `scenarios` a table (path or frame) or `design` the `doe.design`
/// arguments as one `DesignOptions`-like dict; `progress` `None`/`False` (quiet), `True` (a line on
/// stderr) or a callable taking a dict per update.
#[pyfunction]
#[pyo3(signature = (out, controllers = "pid,mpc".to_string(), scenarios = None, design = None,
    columns = None, threads = None, cache = None, progress = None, plots = true))]
#[allow(clippy::too_many_arguments)]
pub fn batch(
    py: Python<'_>,
    out: PathBuf,
    controllers: String,
    scenarios: Option<&Bound<'_, PyAny>>,
    design: Option<Bound<'_, pyo3::types::PyDict>>,
    columns: Option<String>,
    threads: Option<usize>,
    cache: Option<PathBuf>,
    progress: Option<Bound<'_, PyAny>>,
    plots: bool,
) -> PyResult<PyBatch> {
    let source = match (scenarios, design) {
        (Some(s), None) => match Source::of(s, "scenarios")? {
            Source::Path(path) => ScenarioSource::File { path, columns },
            Source::Frame(df) => {
                let t = millcomp_datasets::table::from_dataframe("scenarios", &df)
                    .map_err(|e| raise(e.into()))?;
                let t = match &columns {
                    Some(c) => {
                        let map = millcomp_datasets::mapping::ColumnMap::parse(c)
                            .map_err(|e| raise(e.into()))?;
                        millcomp_datasets::mapping::map_table(t, &map)
                            .map_err(|e| raise(e.into()))?
                            .table
                    }
                    None => t,
                };
                ScenarioSource::Table(t)
            }
        },
        (None, Some(d)) => {
            let o = crate::doe::design_options(&d)?;
            ScenarioSource::Design(o.request().map_err(|e| raise(e.into()))?)
        }
        _ => {
            return Err(crate::errors::argument_error(
                "give either `scenarios` (a table or a file) or `design` (one of them)".to_string(),
            ));
        }
    };
    if threads == Some(0) {
        return Err(crate::errors::argument_error(
            "argument `threads` must be at least 1".to_string(),
        ));
    }
    let mut req = BatchRequest::new(source, &controllers, &out);
    req.threads = threads;
    req.cache = cache;
    req.plots = plots;
    let stop = Arc::new(AtomicBool::new(false));
    let failure: Arc<Mutex<Option<PyErr>>> = Arc::new(Mutex::new(None));
    req.stop = Some(stop.clone());
    req.progress = match progress {
        None => ProgressMode::Quiet,
        Some(p) if p.is_truthy()? && !p.is_callable() => ProgressMode::Lines,
        Some(p) if !p.is_callable() => ProgressMode::Quiet,
        Some(p) => {
            let callback = p.unbind();
            let stop = stop.clone();
            let failure = failure.clone();
            ProgressMode::Callback(Arc::new(move |u: &ProgressUpdate| {
                Python::attach(|py| {
                    let r = py.check_signals().and_then(|()| {
                        let d = pyo3::types::PyDict::new(py);
                        d.set_item("done", u.done)?;
                        d.set_item("total", u.total)?;
                        d.set_item("resumed", u.resumed)?;
                        d.set_item("failed", u.failed)?;
                        d.set_item("elapsed_s", u.elapsed_s)?;
                        d.set_item("eta_s", u.eta_s)?;
                        d.set_item("simulated_per_wall_s", u.simulated_per_wall_s)?;
                        d.set_item("line", u.line())?;
                        callback.call1(py, (d,)).map(|_| ())
                    });
                    if let Err(e) = r {
                        stop.store(true, Ordering::Relaxed);
                        let mut f = failure.lock().unwrap_or_else(|p| p.into_inner());
                        if f.is_none() {
                            *f = Some(e);
                        }
                    }
                });
            }))
        }
    };
    let result = py.detach(|| run_batch(&req));
    if let Some(e) = failure.lock().unwrap_or_else(|p| p.into_inner()).take() {
        // the callback raised (or Ctrl-C): the runs finished so far are stored; the same call resumes
        return Err(e);
    }
    match result {
        Ok(summary) => Ok(PyBatch {
            summary: serde_json::to_value(&summary).map_err(|e| raise(e.into()))?,
            out,
        }),
        Err(e @ ClosedLoopError::Interrupted { .. }) => Err(exception(
            py,
            "BatchInterrupted",
            crate::errors::message(&e.into()),
        )),
        Err(e) => Err(raise(e.into())),
    }
}
