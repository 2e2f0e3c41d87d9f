//! Running the plan: every run of a slice not finished yet, in parallel (rayon). The runs of one
//! scenario share what does not depend on the controller — the scenario, its truth, the commissioning
//! (from a cache, [`crate::cache`]) and the controllers' preview ([`ClosedLoop::prepare`]) — and each
//! run's result is written atomically to `DIR/runs/run-NNNNNN.json` as soon as it finishes, so an
//! interrupted batch resumes where it stopped and a partial file is never taken for a result. A run
//! that fails (an error, a panic) is recorded with its reason (`run-NNNNNN.failed.json`) and the
//! others go on.

use std::panic::AssertUnwindSafe;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::factors::{ScenarioSpec, build_scenario};
use super::plan::{Plan, RunId, Shard};
use super::progress::{Progress, ProgressMode};
pub use super::store::{
    FailedRun, METRICS, RunMetrics, RunOutcome, RunRecord, claim_dir, load_outcome, load_record,
    read_plan, read_shard, runs_dir,
};
use super::store::{failed_file, remove_partials, run_file, write_text};
use crate::cache::{CacheCounts, CommissioningCache};
use crate::error::{ClosedLoopError, error_chain};
use crate::groove::{PreparedGroove, RunOptions};
use crate::profile::{Stage, StageTimes, timed};
use crate::runner::run_scenario;
use crate::scenario::{ControllerKind, Scenario, StageKind};

/// What the runs of a batch share besides the plan: the commissioning cache.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunContext<'a> {
    /// Where commissioned bundles are kept (none: every scenario commissions its own).
    pub cache: Option<&'a CommissioningCache>,
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

    /// Prepares `scenario` for its controllers' runs: what they share is done once here. The default
    /// prepares nothing and calls [`ClosedLoop::run`] for each.
    ///
    /// # Errors
    /// Whatever keeps every run of the scenario from completing (its errors are each run's failure).
    fn prepare<'a>(
        &'a self,
        scenario: &'a ScenarioSpec,
        cx: &RunContext<'a>,
    ) -> Result<Box<dyn Condition + 'a>, ClosedLoopError> {
        let _ = cx;
        Ok(Box::new(RunByRun {
            runner: self,
            scenario,
        }))
    }
}

/// A scenario prepared for its controllers ([`ClosedLoop::prepare`]).
pub trait Condition: Sync {
    /// Runs `controller` on the prepared scenario: its metrics and the simulated seconds.
    ///
    /// # Errors
    /// As [`ClosedLoop::run`].
    fn run(&self, controller: &str) -> Result<(RunMetrics, f64), ClosedLoopError>;
}

/// [`ClosedLoop::prepare`]'s default: nothing shared.
struct RunByRun<'a, T: ?Sized> {
    runner: &'a T,
    scenario: &'a ScenarioSpec,
}

impl<T: ClosedLoop + ?Sized> Condition for RunByRun<'_, T> {
    fn run(&self, controller: &str) -> Result<(RunMetrics, f64), ClosedLoopError> {
        self.runner.run(self.scenario, controller)
    }
}

/// The real closed loop: the published scenario with the factors applied, run as `simulate` runs it
/// ([`run_scenario`]); prepared once per scenario for its controllers ([`PreparedGroove`]: one
/// commissioning, one preview), with the same metrics value for value.
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

    fn prepare<'a>(
        &'a self,
        scenario: &'a ScenarioSpec,
        cx: &RunContext<'a>,
    ) -> Result<Box<dyn Condition + 'a>, ClosedLoopError> {
        let s = timed(Stage::Scenario, || build_scenario(scenario))?;
        Ok(match s.stage {
            StageKind::Groove => Box::new(GrooveCondition(PreparedGroove::new(s, cx.cache)?)),
            StageKind::ThinWall | StageKind::NcAxis => Box::new(OtherCondition(s)),
        })
    }
}

/// A groove scenario prepared once for its controllers.
struct GrooveCondition(PreparedGroove);

impl Condition for GrooveCondition {
    fn run(&self, controller: &str) -> Result<(RunMetrics, f64), ClosedLoopError> {
        let kind: ControllerKind = controller.parse()?;
        let r = self.0.run(kind, RunOptions::BATCH)?.report;
        Ok((RunMetrics::from_report(&r), r.simulated_s))
    }
}

/// A thin-wall or NC scenario: each controller's run sets itself up (the profile counts its loop as the
/// controller's, its QP solves apart).
struct OtherCondition(Scenario);

impl Condition for OtherCondition {
    fn run(&self, controller: &str) -> Result<(RunMetrics, f64), ClosedLoopError> {
        let kind: ControllerKind = controller.parse()?;
        let t0 = Instant::now();
        let r = run_scenario(&self.0, kind)?;
        let solve = millcomp_mpc::stats::take_qp_solve_s();
        crate::profile::add(Stage::Solve, solve);
        crate::profile::add(
            Stage::Controller,
            (t0.elapsed().as_secs_f64() - solve).max(0.0),
        );
        Ok((RunMetrics::from_report(&r), r.simulated_s))
    }
}

/// How [`run_shard_with`] reports and shares.
#[derive(Debug, Default)]
pub struct ShardOptions<'a> {
    /// Where the progress goes.
    pub progress: ProgressMode,
    /// The commissioning cache the runs share.
    pub cache: Option<&'a CommissioningCache>,
    /// Any of these set (by a signal handler, another thread): stop — runs not started are left for
    /// the next call, runs under way finish and are stored.
    pub stop: Vec<&'a AtomicBool>,
    /// How to name the stop in [`ClosedLoopError::Interrupted`] (`SIGTERM`, …).
    pub stop_reason: Option<fn() -> Option<&'static str>>,
}

/// What [`run_shard`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShardOutcome {
    /// Runs of this shard.
    pub n_runs: usize,
    /// Runs executed now (failed ones included).
    pub n_ran: usize,
    /// Runs found finished (or failed) from an earlier attempt and not run again.
    pub n_resumed: usize,
    /// Records of every run of the shard that finished with a result, in run order.
    #[serde(skip)]
    pub records: Vec<RunRecord>,
    /// Every run of the shard that failed (now or before), in run order.
    pub failed: Vec<FailedRun>,
    /// Simulated machining seconds of the runs executed now.
    pub simulated_s: f64,
    /// Wall-clock seconds of this call.
    pub wall_clock_s: f64,
    /// Threads used.
    pub threads: usize,
    /// Where this call's time went, summed over the threads (seconds).
    #[serde(skip)]
    pub profile: StageTimes,
    /// How the commissioned bundles were found.
    pub cache: CacheCounts,
}

/// Runs every run of `shard` not already finished in `out` ([`run_shard_with`]) with a progress line
/// on stderr when `progress` is true and the commissioning cache in `out/cache`.
///
/// # Errors
/// As [`run_shard_with`].
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
/// // one commissioning for both controllers
/// assert_eq!(first.cache.computed, 1);
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
    let cache = CommissioningCache::on_disk(&out.join("cache"));
    let opts = ShardOptions {
        progress: if progress {
            ProgressMode::Auto
        } else {
            ProgressMode::Quiet
        },
        cache: Some(&cache),
        ..ShardOptions::default()
    };
    run_shard_with(plan, shard, out, runner, &opts)
}

/// Runs every run of `shard` not already finished in `out`, in parallel (the current rayon pool):
/// scenario by scenario, each prepared once for its controllers ([`ClosedLoop::prepare`]), its runs
/// then in parallel too. Each finished run is stored at once in `out/runs/`; a second call resumes.
/// Temporary files a killed writer left in `out` and `out/runs` are removed first.
///
/// # Errors
/// Those of [`claim_dir`]; [`ClosedLoopError::Write`] when a run's record cannot be stored (the runs
/// stop); [`ClosedLoopError::Interrupted`] when `opts.stop` was set before every run was done (the
/// finished ones are stored). A failed run is not an error: it is in [`ShardOutcome::failed`].
pub fn run_shard_with(
    plan: &Plan,
    shard: Shard,
    out: &Path,
    runner: &dyn ClosedLoop,
    opts: &ShardOptions<'_>,
) -> Result<ShardOutcome, ClosedLoopError> {
    let start = Instant::now();
    claim_dir(out, plan, shard)?;
    remove_partials(out);
    remove_partials(&runs_dir(out));
    let runs = plan.shard_runs(shard);
    let (mut done, mut failed, mut todo) = (Vec::new(), Vec::new(), Vec::new());
    for r in &runs {
        match load_outcome(out, plan, *r) {
            Some(RunOutcome::Done(rec)) => done.push(rec),
            Some(RunOutcome::Failed(f)) => failed.push(f),
            None => todo.push(*r),
        }
    }
    let n_resumed = done.len() + failed.len();
    // the runs left, by scenario (runs are numbered scenario-major, so a scenario's are adjacent)
    let mut groups: Vec<Vec<RunId>> = Vec::new();
    for r in todo {
        match groups.last_mut() {
            Some(g) if g[0].scenario == r.scenario => g.push(r),
            _ => groups.push(vec![r]),
        }
    }
    let progress = Progress::start(&opts.progress, runs.len(), n_resumed);
    let stopped = || opts.stop.iter().any(|s| s.load(Ordering::Relaxed));
    let cx = RunContext { cache: opts.cache };
    let fresh: Mutex<Vec<RunRecord>> = Mutex::new(Vec::new());
    let fresh_failed: Mutex<Vec<FailedRun>> = Mutex::new(Vec::new());
    let profile: Mutex<StageTimes> = Mutex::new(StageTimes::default());
    let write_error: Mutex<Option<ClosedLoopError>> = Mutex::new(None);
    let absorb = || {
        let t = crate::profile::take();
        lock(&profile).absorb(&t);
    };
    let store = |r: RunId, result: Result<(RunMetrics, f64), String>, wall_s: f64| {
        let controller = plan.controllers[r.controller].clone();
        let stored = match result {
            Ok((metrics, simulated_s)) => {
                let rec = RunRecord {
                    fingerprint: plan.fingerprint.clone(),
                    run: r.index,
                    scenario: r.scenario,
                    controller,
                    metrics,
                    simulated_s,
                    wall_clock_s: wall_s,
                };
                let written = timed(Stage::Writing, || {
                    write_text(
                        &run_file(out, r.index),
                        &serde_json::to_string_pretty(&rec)?,
                    )
                });
                written.map(|()| {
                    progress.run_done(rec.simulated_s, false);
                    lock(&fresh).push(rec);
                })
            }
            Err(reason) => {
                let f = FailedRun {
                    fingerprint: plan.fingerprint.clone(),
                    run: r.index,
                    scenario: r.scenario,
                    controller,
                    reason,
                };
                let written = timed(Stage::Writing, || {
                    write_text(
                        &failed_file(out, r.index),
                        &serde_json::to_string_pretty(&f)?,
                    )
                });
                written.map(|()| {
                    progress.run_done(0.0, true);
                    lock(&fresh_failed).push(f);
                })
            }
        };
        if let Err(e) = stored {
            lock(&write_error).get_or_insert(e);
        }
    };
    let halted = || stopped() || lock(&write_error).is_some();
    groups.par_iter().for_each(|group| {
        if halted() {
            return;
        }
        let spec = &plan.scenarios[group[0].scenario];
        let prepared = caught(|| runner.prepare(spec, &cx));
        absorb();
        match prepared {
            Err(reason) => {
                for r in group {
                    store(*r, Err(format!("preparing the scenario: {reason}")), 0.0);
                }
            }
            Ok(condition) => group.par_iter().for_each(|r| {
                if halted() {
                    return;
                }
                let t0 = Instant::now();
                let result = caught(|| condition.run(&plan.controllers[r.controller]));
                store(*r, result, t0.elapsed().as_secs_f64());
                absorb();
            }),
        }
    });
    progress.finish();
    if let Some(e) = write_error.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    let fresh = fresh.into_inner().unwrap_or_else(|e| e.into_inner());
    let fresh_failed = fresh_failed.into_inner().unwrap_or_else(|e| e.into_inner());
    let n_ran = fresh.len() + fresh_failed.len();
    if stopped() && n_resumed + n_ran < runs.len() {
        return Err(ClosedLoopError::Interrupted {
            signal: opts
                .stop_reason
                .and_then(|f| f())
                .unwrap_or("a stop request")
                .to_string(),
            done: n_resumed + n_ran,
            planned: runs.len(),
            dir: runs_dir(out),
        });
    }
    let simulated_s = fresh.iter().map(|r| r.simulated_s).sum();
    done.extend(fresh);
    done.sort_by_key(|r| r.run);
    failed.extend(fresh_failed);
    failed.sort_by_key(|f| f.run);
    Ok(ShardOutcome {
        n_runs: runs.len(),
        n_ran,
        n_resumed,
        records: done,
        failed,
        simulated_s,
        wall_clock_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
        profile: profile.into_inner().unwrap_or_else(|e| e.into_inner()),
        cache: opts
            .cache
            .map(CommissioningCache::counts)
            .unwrap_or_default(),
    })
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// `f`'s value, or why it has none: its error chain, or the message of a panic (a bug met on one
/// run does not stop the others).
fn caught<T>(f: impl FnOnce() -> Result<T, ClosedLoopError>) -> Result<T, String> {
    match std::panic::catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(error_chain(&e)),
        Err(panic) => Err(format!(
            "panicked: {}",
            panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".to_string())
        )),
    }
}
