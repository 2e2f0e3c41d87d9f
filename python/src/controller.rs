//! `millcomp.Controller`: the controller runtime (`millcomp_runtime::Controller`) from Python — built
//! from a commissioned bundle and a program file, stepped one measurement at a time, reset, or run
//! through a recorded sensor log by the runtime's own replay loop (`millcomp_runtime::replay`, what
//! `millcomp replay` calls).

use std::path::PathBuf;
use std::sync::Mutex;

use millcomp_datasets::contracts::{
    CommandColumns, SensorLog, commands_table, read_sensor_log, read_sensor_log_frame,
};
use millcomp_runtime::replay::{columns, measurements, replay};
use millcomp_runtime::{
    Budget, Command, Controller, ControllerKind, Measurement, Origins, Program, flags, load_bundle,
};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::arrow::to_polars;
use crate::errors::{ArgumentError, argument_error, raise};
use crate::input::Source;
use crate::json::to_py;

/// What a controller sent in one cycle.
#[pyclass(name = "Command", module = "millcomp._core", frozen, eq)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PyCommand {
    /// The voltage for the PZT amplifier (V).
    #[pyo3(get)]
    voltage_v: f64,
    /// The cycle's flag bits (docs/runtime.md).
    #[pyo3(get)]
    flags: u32,
    /// The QP's interior-point iterations (0 when none was solved).
    #[pyo3(get)]
    iterations: u32,
}

impl From<Command> for PyCommand {
    fn from(c: Command) -> Self {
        Self {
            voltage_v: c.voltage_v,
            flags: c.flags,
            iterations: c.iterations,
        }
    }
}

#[pymethods]
impl PyCommand {
    /// The MPC planned in this cycle.
    #[getter]
    fn planned(&self) -> bool {
        self.flags & flags::PLANNED != 0
    }

    /// The MPC's fallback went out (its plan was not accepted).
    #[getter]
    fn fallback(&self) -> bool {
        self.flags & flags::FALLBACK != 0
    }

    fn __repr__(&self) -> String {
        format!(
            "Command(voltage_v={}, flags={}, iterations={})",
            self.voltage_v, self.flags, self.iterations
        )
    }
}

/// A controller ready for a control loop: built once from a commissioned bundle and a program file
/// (`Controller.from_bundle`), then `step` once per control period, `reset` between cuts, or `replay`
/// a recorded sensor log (the runtime's replay, as `millcomp replay`).
///
/// Example::
///
///     >>> ctl = millcomp.Controller.from_bundle("runtime/tests/data/bundle_s7.toml",
///     ...                                       "runtime/tests/data/ramp_20deg.toml", budget=50)
///     >>> c = ctl.step()                      # no reading yet
///     >>> (ctl.kind, c.planned, 0.0 <= c.voltage_v <= 1000.0)
///     ('mpc', True, True)
///     >>> ctl.step(x_mm=0.0, force_n=0.1, gauge_um=0.0).voltage_v >= 0.0
///     True
#[pyclass(name = "Controller", module = "millcomp._core", frozen)]
pub struct PyController {
    // one controller is driven from one thread; the lock makes the object shareable in Python
    inner: Mutex<Controller>,
    kind: ControllerKind,
    period_s: f64,
    origin: String,
}

impl PyController {
    fn lock(&self) -> std::sync::MutexGuard<'_, Controller> {
        // a panic never happens inside `step`; a poisoned lock still holds a usable controller
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The `budget` argument: `None` (the program's), `"iterations"`, an iteration cap (int) or
/// `"wall-clock"`.
fn budget_of(budget: &Bound<'_, PyAny>) -> PyResult<Budget> {
    let bad = || {
        argument_error(
            "argument `budget`: \"iterations\", an iteration cap (1 ..= 500) or \"wall-clock\""
                .to_string(),
        )
    };
    if let Ok(s) = budget.cast::<PyString>() {
        return match s.to_str()? {
            "iterations" => Ok(Budget::Iterations {
                max_iter: None,
                fraction: None,
            }),
            "wall-clock" => Ok(Budget::WallClock { fraction: None }),
            _ => Err(bad()),
        };
    }
    match budget.extract::<i64>() {
        Ok(n) if (1..=500).contains(&n) => Ok(Budget::Iterations {
            max_iter: Some(n as u32),
            fraction: None,
        }),
        _ => Err(bad()),
    }
}

#[pymethods]
impl PyController {
    /// The controller the program file names (or `controller`), built from the bundle file.
    #[staticmethod]
    #[pyo3(signature = (bundle_path, program_path, *, controller = None, budget = None))]
    fn from_bundle(
        py: Python<'_>,
        bundle_path: PathBuf,
        program_path: PathBuf,
        controller: Option<String>,
        budget: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let kind = controller
            .map(|name| {
                name.parse::<ControllerKind>().map_err(|e| {
                    raise(
                        anyhow::Error::new(e)
                            .context(ArgumentError("argument `controller`".to_string())),
                    )
                })
            })
            .transpose()?;
        let budget = budget.as_ref().map(budget_of).transpose()?;
        py.detach(|| -> anyhow::Result<Self> {
            let mut program = Program::load(&program_path)?;
            let bundle = load_bundle(&bundle_path)?;
            if let Some(k) = kind {
                program.controller.kind = k;
            }
            if let Some(b) = budget {
                program.controller.budget = b;
            }
            let origins = Origins {
                bundle: bundle_path.clone(),
                program: program_path.clone(),
            };
            let c = Controller::from_bundle_at(&bundle, &program, &origins)?;
            Ok(Self {
                kind: c.kind(),
                period_s: c.period_s(),
                inner: Mutex::new(c),
                origin: bundle_path.display().to_string(),
            })
        })
        .map_err(raise)
    }

    /// One control cycle: the NC's position (mm) and the force (N) and gauge (µm) readings in — NaN
    /// or omitted: no reading this cycle — the command out.
    #[pyo3(signature = (x_mm = f64::NAN, force_n = f64::NAN, gauge_um = f64::NAN))]
    fn step(&self, x_mm: f64, force_n: f64, gauge_um: f64) -> PyCommand {
        self.lock()
            .step(&Measurement {
                x_mm,
                force_n,
                gauge_um,
            })
            .into()
    }

    /// Back to the state right after construction (between cuts, not in the loop).
    fn reset(&self) -> PyResult<()> {
        self.lock().reset().map_err(|e| raise(e.into()))
    }

    /// A recorded sensor log (a path, or a polars/pandas frame, a dict of columns: the sensor-log
    /// contract's columns) through the controller from its current state: the commands as the
    /// commands table's frame.
    fn replay<'py>(&self, py: Python<'py>, log: Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let log = py
            .import("millcomp._frames")?
            .call_method1("source", (log, "log"))?;
        let source = Source::of(&log, "log")?;
        let table = py
            .detach(|| -> anyhow::Result<polars::prelude::DataFrame> {
                let (log, origin): (SensorLog, String) = match source {
                    Source::Path(p) => (read_sensor_log(&p)?, p.display().to_string()),
                    Source::Frame(df) => (read_sensor_log_frame("log", &df)?, "log".to_string()),
                };
                log.check_rate(&origin, self.period_s)?;
                let m = measurements(&log.x_mm, &log.force_n, &log.gauge_um);
                let r = replay(&mut self.lock(), &m);
                let (voltage_v, flags, iterations) = columns(&r.commands);
                let run = CommandColumns {
                    controller: self.kind.name().to_string(),
                    voltage_v,
                    flags,
                    iterations,
                };
                Ok(commands_table(&origin, &log.t_s, &[run])?.to_dataframe()?)
            })
            .map_err(raise)?;
        to_polars(py, table)
    }

    /// The controller's name (`mpc`, `pid-tuned`, …).
    #[getter]
    fn kind(&self) -> &'static str {
        self.kind.name()
    }

    /// The control period (s).
    #[getter]
    fn period_s(&self) -> f64 {
        self.period_s
    }

    /// The cycles stepped since construction or the last reset.
    #[getter]
    fn cycle(&self) -> u64 {
        self.lock().cycle()
    }

    /// How many cycles had each event (`planned`, `fallbacks`, `readings_held`, …).
    #[getter]
    fn counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let c = self.lock().counts();
        to_py(py, &c)
    }

    fn __repr__(&self) -> String {
        format!(
            "<millcomp Controller {} from {}, period {} s, cycle {}>",
            self.kind.name(),
            self.origin,
            self.period_s,
            self.lock().cycle()
        )
    }
}

/// The Rust step's time (ns per call, median of `repeats` batches of `steps` steps) on a log of
/// `steps` measurements without readings, for the overhead benchmark.
#[pyfunction]
pub fn _time_step(ctl: PyRef<'_, PyController>, steps: usize, repeats: usize) -> Vec<f64> {
    let m = Measurement {
        x_mm: f64::NAN,
        force_n: 0.1,
        gauge_um: 0.0,
    };
    let mut c = ctl.lock();
    (0..repeats)
        .map(|_| {
            let t = std::time::Instant::now();
            for _ in 0..steps {
                std::hint::black_box(c.step(std::hint::black_box(&m)));
            }
            t.elapsed().as_nanos() as f64 / steps.max(1) as f64
        })
        .collect()
}
