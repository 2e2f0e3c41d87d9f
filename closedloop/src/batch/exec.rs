//! Running the plan: one closed-loop run per scenario × controller, in parallel (rayon), each result
//! written atomically to `DIR/runs/run-NNNNNN.json` as soon as it finishes, so an interrupted batch
//! resumes where it stopped and a partial file is never taken for a result.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::factors::{ScenarioSpec, build_scenario};
use super::plan::{Plan, RunId, Shard};
use crate::error::{ClosedLoopError, error_chain};
use crate::report::RunReport;
use crate::runner::run_scenario;
use crate::scenario::ControllerKind;

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
    /// The metrics of a run's report.
    pub fn from_report(r: &RunReport) -> Self {
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

/// A closed-loop simulation of one scenario with one controller.
pub trait ClosedLoop: Sync {
    /// Runs `scenario` with `controller` and returns its metrics plus the simulated seconds.
    ///
    /// # Errors
    /// Whatever keeps the run from completing (a bad scenario, an unknown controller).
    fn run(
        &self,
        scenario: &ScenarioSpec,
        controller: &str,
    ) -> Result<(RunMetrics, f64), ClosedLoopError>;
}

/// The real closed loop: [`run_scenario`] on the published scenario with the factors applied.
#[derive(Debug, Clone, Copy, Default)]
pub struct MpcClosedLoop;

impl ClosedLoop for MpcClosedLoop {
    fn run(
        &self,
        scenario: &ScenarioSpec,
        controller: &str,
    ) -> Result<(RunMetrics, f64), ClosedLoopError> {
        let s = build_scenario(scenario)?;
        let kind: ControllerKind = controller.parse()?;
        let r = run_scenario(&s, kind)?;
        Ok((RunMetrics::from_report(&r), r.simulated_s))
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

/// What [`run_shard`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShardOutcome {
    /// Runs of this shard.
    pub n_runs: usize,
    /// Runs executed now.
    pub n_ran: usize,
    /// Runs found finished from an earlier attempt and not run again.
    pub n_resumed: usize,
    /// Records of every run of the shard, in run order.
    #[serde(skip)]
    pub records: Vec<RunRecord>,
    /// Simulated machining seconds of the runs executed now.
    pub simulated_s: f64,
    /// Wall-clock seconds of this call.
    pub wall_clock_s: f64,
    /// Threads used.
    pub threads: usize,
}

/// `DIR/runs`.
pub fn runs_dir(out: &Path) -> PathBuf {
    out.join("runs")
}

fn run_file(out: &Path, run: usize) -> PathBuf {
    runs_dir(out).join(format!("run-{run:06}.json"))
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
    millcomp_datasets::write_text_atomic(path, text).map_err(|source| ClosedLoopError::Write {
        path: path.to_path_buf(),
        source,
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

/// Runs every run of `shard` not already finished in `out`, in parallel (the current rayon pool), with
/// a progress bar on stderr when `progress` is true. Each finished run is stored at once in
/// `out/runs/run-NNNNNN.json`; a second call resumes.
///
/// # Errors
/// Those of [`claim_dir`], and [`ClosedLoopError::RunsFailed`] listing every run that failed (the
/// others are kept and not run again).
///
/// # Examples
/// ```
/// use millcomp_closedloop::batch::exec::{MpcClosedLoop, run_shard};
/// use millcomp_closedloop::batch::plan::{Plan, Shard};
/// use millcomp_datasets::{Column, ColumnData, Table};
/// // one very short groove (0.3 mm of the published 20° groove), PID and MPC
/// let col = |name: &str, v: f64| Column { name: name.into(), data: ColumnData::Float(vec![v]) };
/// let t = Table::from_columns("example", vec![col("length_mm", 0.3)]).unwrap();
/// let plan = Plan::from_table(&t, vec!["pid".into(), "mpc".into()]).unwrap();
/// let dir = std::env::temp_dir().join(format!("millcomp-run-shard-doc-{}", std::process::id()));
/// let first = run_shard(&plan, Shard::ALL, &dir, &MpcClosedLoop, false).unwrap();
/// assert_eq!((first.n_runs, first.n_ran, first.n_resumed), (2, 2, 0));
/// // 0.3 mm at 1.667 mm/s: 0.18 s of machining per run
/// assert!((first.simulated_s - 2.0 * 0.18).abs() < 1e-3, "{}", first.simulated_s);
/// // a second call finds both runs finished: it resumes, nothing runs again
/// let again = run_shard(&plan, Shard::ALL, &dir, &MpcClosedLoop, false).unwrap();
/// assert_eq!((again.n_ran, again.n_resumed), (0, 2));
/// assert_eq!(again.records, first.records);
/// std::fs::remove_dir_all(&dir).ok();
/// ```
pub fn run_shard(
    plan: &Plan,
    shard: Shard,
    out: &Path,
    runner: &dyn ClosedLoop,
    progress: bool,
) -> Result<ShardOutcome, ClosedLoopError> {
    let start = std::time::Instant::now();
    claim_dir(out, plan, shard)?;
    let runs = plan.shard_runs(shard);
    let mut done: Vec<RunRecord> = Vec::new();
    let mut todo: Vec<RunId> = Vec::new();
    for r in &runs {
        match load_record(out, plan, *r) {
            Some(rec) => done.push(rec),
            None => todo.push(*r),
        }
    }
    let n_resumed = done.len();
    let bar = if progress {
        let b =
            ProgressBar::with_draw_target(Some(runs.len() as u64), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs (eta {eta}) {msg}",
        ) {
            b.set_style(style);
        }
        b.set_position(n_resumed as u64);
        b
    } else {
        ProgressBar::hidden()
    };
    let errors: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let fresh: Vec<RunRecord> = todo
        .par_iter()
        .filter_map(|r| {
            let controller = &plan.controllers[r.controller];
            let scenario = &plan.scenarios[r.scenario];
            let t0 = std::time::Instant::now();
            let result = runner
                .run(scenario, controller)
                .and_then(|(metrics, sim_s)| {
                    let rec = RunRecord {
                        fingerprint: plan.fingerprint.clone(),
                        run: r.index,
                        scenario: r.scenario,
                        controller: controller.clone(),
                        metrics,
                        simulated_s: sim_s,
                        wall_clock_s: t0.elapsed().as_secs_f64(),
                    };
                    let path = run_file(out, r.index);
                    write_text(&path, &serde_json::to_string_pretty(&rec)?)?;
                    Ok(rec)
                });
            bar.inc(1);
            match result {
                Ok(rec) => Some(rec),
                Err(e) => {
                    let msg = format!(
                        "scenario {} (row {}), controller {controller}: {}",
                        r.scenario,
                        r.scenario + 1,
                        error_chain(&e)
                    );
                    if let Ok(mut v) = errors.lock() {
                        v.push(msg);
                    }
                    None
                }
            }
        })
        .collect();
    bar.finish_and_clear();
    let errors = errors.into_inner().unwrap_or_default();
    if !errors.is_empty() {
        return Err(ClosedLoopError::RunsFailed {
            failed: errors.len(),
            attempted: todo.len(),
            dir: runs_dir(out),
            errors,
        });
    }
    let simulated_s = fresh.iter().map(|r| r.simulated_s).sum();
    let n_ran = fresh.len();
    done.extend(fresh);
    done.sort_by_key(|r| r.run);
    Ok(ShardOutcome {
        n_runs: runs.len(),
        n_ran,
        n_resumed,
        records: done,
        simulated_s,
        wall_clock_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
    })
}
