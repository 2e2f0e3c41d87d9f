//! A batch directory on disk: `plan.json` (the plan and the slice), `runs/run-NNNNNN.json` (one
//! record per finished run, written atomically as it finishes), and the run records' contract.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::plan::{Plan, RunId, Shard};
use crate::error::ClosedLoopError;

/// The error metrics of one closed-loop run (µm), as the runner reports them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetrics {
    /// Peak-to-peak error.
    pub pp_error_um: f64,
    /// RMS error.
    pub rms_error_um: f64,
    /// Largest error.
    pub max_error_um: f64,
    /// Smallest error.
    pub min_error_um: f64,
    /// Total actuator travel.
    pub actuator_travel_um: f64,
    /// MPC only: QP solves that fell back (did not converge); 0 for other controllers.
    pub solver_fallbacks: usize,
    /// The largest transient excess at the program's changes (`crate::changes`); absent without one.
    #[serde(default)]
    pub change_excess_um: Option<f64>,
    /// Grooves: the stroke bound (`Metrics::stroke_bound_um`): > 0 where the PZT's range cannot cover the
    /// deflection met — no controller can get below it.
    #[serde(default)]
    pub stroke_bound_um: Option<f64>,
    /// Grooves: the whole cut's optimum (`Metrics::optimum_pp_um`, `crate::optimum`).
    #[serde(default)]
    pub optimum_pp_um: Option<f64>,
    /// The smallest excess any controller could leave at the change where this run's excess is largest
    /// (`crate::optimum::excess_lower_bound`); absent without a change. NC rows: the smallest feed-step
    /// peak any controller could leave (`crate::nc_axis_bound`), a lower bound of their
    /// `change_excess_um` (the larger of the feed step's peak and the exit's undersize).
    #[serde(default)]
    pub change_bound_um: Option<f64>,
    /// MPC only: median QP solve time of the run (µs) — wall-clock, so informative: not in the results
    /// table ([`METRICS`]), whose rows must not depend on the machine.
    #[serde(default)]
    pub solve_median_us: Option<f64>,
    /// MPC only: 99th-percentile QP solve time of the run (µs), informative as above.
    #[serde(default)]
    pub solve_p99_us: Option<f64>,
    /// MPC only: the run's longest cycle (µs), informative as above.
    #[serde(default)]
    pub solve_max_us: Option<f64>,
    /// MPC only: cycles over the budget (timed, not enforced in a batch), informative as above.
    #[serde(default)]
    pub deadline_misses: Option<usize>,
}

/// Metric names, in table order (the numeric result columns).
pub const METRICS: [&str; 10] = [
    "pp_error_um",
    "change_excess_um",
    "stroke_bound_um",
    "optimum_pp_um",
    "change_bound_um",
    "rms_error_um",
    "max_error_um",
    "min_error_um",
    "actuator_travel_um",
    "solver_fallbacks",
];

impl RunMetrics {
    /// The metrics of a run's report: its errors, the QP statistics of an MPC, and its references —
    /// `change_bound_um` of the change where the excess is largest (NC rows: the feed step's peak
    /// bound).
    pub fn from_report(r: &crate::report::RunReport) -> Self {
        let m = &r.metrics;
        RunMetrics {
            pp_error_um: m.pp_error_um,
            rms_error_um: m.rms_error_um,
            max_error_um: m.max_error_um,
            min_error_um: m.min_error_um,
            actuator_travel_um: m.actuator_travel_um,
            solver_fallbacks: r.solver.map_or(0, |s| s.fallbacks),
            change_excess_um: m.change_excess_um,
            stroke_bound_um: m.stroke_bound_um,
            optimum_pp_um: m.optimum_pp_um,
            change_bound_um: r
                .changes
                .iter()
                .max_by(|a, b| a.excess_um.total_cmp(&b.excess_um))
                .and_then(|c| c.bound_um)
                .or_else(|| {
                    r.nc_axis
                        .as_ref()
                        .and_then(|n| n.wall.feed_step_peak_bound_um)
                }),
            solve_median_us: r.solver.map(|s| s.median_us),
            solve_p99_us: r.solver.map(|s| s.p99_us),
            solve_max_us: r.solver.map(|s| s.max_us),
            deadline_misses: r.solver.map(|s| s.deadline_misses),
        }
    }

    /// Value of metric `name` (one of [`METRICS`]).
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "pp_error_um" => self.pp_error_um,
            "rms_error_um" => self.rms_error_um,
            "max_error_um" => self.max_error_um,
            "min_error_um" => self.min_error_um,
            "actuator_travel_um" => self.actuator_travel_um,
            "solver_fallbacks" => self.solver_fallbacks as f64,
            "change_excess_um" => return self.change_excess_um,
            "stroke_bound_um" => return self.stroke_bound_um,
            "optimum_pp_um" => return self.optimum_pp_um,
            "change_bound_um" => return self.change_bound_um,
            _ => return None,
        })
    }
}

/// The stored result of one run (`DIR/runs/run-NNNNNN.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Fingerprint of the plan it belongs to.
    pub fingerprint: String,
    /// Global run index.
    pub run: usize,
    /// Scenario index.
    pub scenario: usize,
    /// Controller name.
    pub controller: String,
    /// Metrics.
    pub metrics: RunMetrics,
    /// Simulated machining time (s).
    pub simulated_s: f64,
    /// Wall-clock time of the run (s) — informative, not part of the results table.
    pub wall_clock_s: f64,
}

/// `DIR/runs`.
pub fn runs_dir(out: &Path) -> PathBuf {
    out.join("runs")
}

pub(crate) fn run_file(out: &Path, run: usize) -> PathBuf {
    runs_dir(out).join(format!("run-{run:06}.json"))
}

/// `DIR/runs/run-NNNNNN.failed.json`: the record of a run that failed.
pub(crate) fn failed_file(out: &Path, run: usize) -> PathBuf {
    runs_dir(out).join(format!("run-{run:06}.failed.json"))
}

/// `DIR/plan.json` — writes it, or checks that an existing one is the same batch.
///
/// # Errors
/// [`ClosedLoopError::AnotherBatch`] when `out` holds a different batch; I/O errors naming the file.
pub fn claim_dir(out: &Path, plan: &Plan, shard: Shard) -> Result<(), ClosedLoopError> {
    std::fs::create_dir_all(runs_dir(out)).map_err(|source| ClosedLoopError::CreateDir {
        path: runs_dir(out),
        source,
    })?;
    let path = out.join("plan.json");
    if path.exists() {
        let old = read_plan(out)?;
        if old.fingerprint != plan.fingerprint {
            return Err(ClosedLoopError::AnotherBatch {
                path,
                old: old.fingerprint,
                new: plan.fingerprint.clone(),
            });
        }
    }
    #[derive(Serialize)]
    struct PlanFile<'a> {
        #[serde(flatten)]
        plan: &'a Plan,
        shard: Shard,
    }
    let text = serde_json::to_string_pretty(&PlanFile { plan, shard })?;
    write_text(&path, &text)
}

/// Writes `text` to `path` atomically.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), ClosedLoopError> {
    millcomp_datasets::write_atomic(path, |f| {
        use std::io::Write;
        match slow_write_ms() {
            // the tests' way to kill a batch in the middle of a write: half the file, a pause
            Some(ms) => {
                let half = text.len() / 2;
                let half = (0..=half)
                    .rev()
                    .find(|&i| text.is_char_boundary(i))
                    .unwrap_or(0);
                f.write_all(&text.as_bytes()[..half])?;
                f.flush()?;
                std::thread::sleep(std::time::Duration::from_millis(ms));
                f.write_all(&text.as_bytes()[half..])
            }
            None => f.write_all(text.as_bytes()),
        }
    })
    .map_err(|source| ClosedLoopError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// `MILLCOMP_TEST_SLOW_WRITE_MS`: a pause (ms) in the middle of every batch file written as text —
/// for the tests that kill a batch during a write; unset in use.
fn slow_write_ms() -> Option<u64> {
    static MS: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
    *MS.get_or_init(|| {
        std::env::var("MILLCOMP_TEST_SLOW_WRITE_MS")
            .ok()
            .and_then(|v| v.parse().ok())
    })
}

/// Reads `DIR/plan.json` and checks its fingerprint against its content.
///
/// # Errors
/// [`ClosedLoopError::ReadPlan`], [`ClosedLoopError::ParsePlan`], and
/// [`ClosedLoopError::PlanEdited`] when the fingerprint does not match the content.
pub fn read_plan(dir: &Path) -> Result<Plan, ClosedLoopError> {
    let path = dir.join("plan.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(source) => return Err(ClosedLoopError::ReadPlan { path, source }),
    };
    let plan: Plan = match serde_json::from_str(&text) {
        Ok(p) => p,
        Err(source) => return Err(ClosedLoopError::ParsePlan { path, source }),
    };
    let fp = plan.compute_fingerprint()?;
    if fp != plan.fingerprint {
        return Err(ClosedLoopError::PlanEdited {
            path,
            stored: plan.fingerprint,
            computed: fp,
        });
    }
    Ok(plan)
}

/// Reads the shard number stored in `DIR/plan.json`.
///
/// # Errors
/// [`ClosedLoopError::Read`], [`ClosedLoopError::Json`], [`ClosedLoopError::NoShard`].
pub fn read_shard(dir: &Path) -> Result<Shard, ClosedLoopError> {
    let path = dir.join("plan.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(source) => return Err(ClosedLoopError::Read { path, source }),
    };
    let v: serde_json::Value = serde_json::from_str(&text)?;
    serde_json::from_value(v.get("shard").cloned().unwrap_or_default())
        .map_err(|source| ClosedLoopError::NoShard { path, source })
}

/// The finished record of run `run` in `dir`, if there is a valid one for this plan.
pub fn load_record(dir: &Path, plan: &Plan, run: RunId) -> Option<RunRecord> {
    let text = std::fs::read_to_string(run_file(dir, run.index)).ok()?;
    let r: RunRecord = serde_json::from_str(&text).ok()?;
    (r.fingerprint == plan.fingerprint
        && r.run == run.index
        && r.scenario == run.scenario
        && r.controller == plan.controllers[run.controller])
        .then_some(r)
}

/// The stored record of a run that failed (`DIR/runs/run-NNNNNN.failed.json`): which run, and why. A
/// failure is final for the plan, as a result is (a resumed batch does not run it again; delete the
/// file to retry it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailedRun {
    /// Fingerprint of the plan it belongs to.
    pub fingerprint: String,
    /// Global run index.
    pub run: usize,
    /// Scenario index.
    pub scenario: usize,
    /// Controller name.
    pub controller: String,
    /// The error and its causes on one line (a panic's message for a run that panicked).
    pub reason: String,
}

/// What a batch directory holds for one run.
#[derive(Debug, Clone, PartialEq)]
pub enum RunOutcome {
    /// Finished with a result.
    Done(RunRecord),
    /// Finished with a failure.
    Failed(FailedRun),
}

/// The finished outcome of run `run` in `dir` (a result, else a failure), if there is a valid one for
/// this plan.
pub fn load_outcome(dir: &Path, plan: &Plan, run: RunId) -> Option<RunOutcome> {
    if let Some(r) = load_record(dir, plan, run) {
        return Some(RunOutcome::Done(r));
    }
    let text = std::fs::read_to_string(failed_file(dir, run.index)).ok()?;
    let f: FailedRun = serde_json::from_str(&text).ok()?;
    (f.fingerprint == plan.fingerprint
        && f.run == run.index
        && f.scenario == run.scenario
        && f.controller == plan.controllers[run.controller])
        .then_some(RunOutcome::Failed(f))
}

/// Removes the temporary files a killed writer left in `dir` (`.millcomp-*.partial`, the atomic
/// writer's); returns how many. Only for directories this batch alone writes (never a shared cache).
pub fn remove_partials(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .filter_map(Result::ok)
        .filter(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.starts_with(".millcomp-") && name.ends_with(".partial")
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}
