//! The whole batch in one call ([`run_batch`]): the plan from a scenario table, a file or a design,
//! the runs of a slice (resumed, in parallel, each scenario prepared once, the commissioned bundles
//! from a cache on disk), the analysis (medians, ANOVA, the paired comparison), the tables, the plots,
//! `summary.json` and `invocation.json`. The CLI (`millcomp batch`) and the Python package are faces
//! over it; [`merge_batch`] joins the slices of a cluster and [`estimate`] says what a plan will
//! cost before it runs (`--dry-run`).
//!
//! The files of a batch appear in this order: `runs/` as the runs finish, then `results.csv`,
//! `results.parquet`, `plots/`, and `summary.json` last of the results — its presence says they are
//! complete — then `invocation.json` (how this call ran). A batch killed on the way leaves its runs;
//! the same command resumes and writes the same results byte for byte.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use millcomp_datasets::Table;
use millcomp_doe::DesignRequest;
use serde::Serialize;

use super::exec::{ClosedLoop, MpcClosedLoop, ShardOptions, ShardOutcome, run_shard_with};
use super::factors::build_scenario;
use super::plan::{Plan, Shard, parse_controllers};
use super::plots::plots;
use super::progress::ProgressMode;
use super::results::{BatchSummary, CacheUse, merge, new_summary, write_summary, write_tables};
use super::signals::SignalGuard;
use super::store::{FailedRun, RunOutcome, RunRecord, load_outcome, remove_partials};
use crate::cache::{CommissioningCache, CommissioningKey};
use crate::commissioning::CommissioningPlant;
use crate::error::ClosedLoopError;
use crate::groove::groove_truth;
use crate::profile::{Stage, timed};
use crate::scenario::StageKind;

/// Where a batch's scenarios come from.
#[derive(Debug, Clone)]
pub enum ScenarioSource {
    /// A CSV or Parquet file, one row per scenario; `columns` maps its columns to factor names
    /// (`factor=column,…`, as `--columns`).
    File {
        /// The file.
        path: PathBuf,
        /// The column mapping, if any.
        columns: Option<String>,
    },
    /// A table already read (one row per scenario, one column per factor).
    Table(Table),
    /// A design `millcomp_doe` generates (as `doe design`).
    Design(DesignRequest),
}

impl ScenarioSource {
    /// The scenario table.
    ///
    /// # Errors
    /// [`ClosedLoopError::Dataset`] for a file that cannot be read or mapped; the design's errors.
    pub fn table(&self) -> Result<Table, ClosedLoopError> {
        match self {
            ScenarioSource::Table(t) => Ok(t.clone()),
            ScenarioSource::File { path, columns } => {
                let table = millcomp_datasets::read_any(path)?;
                match columns {
                    None => Ok(table),
                    Some(c) => {
                        let map = millcomp_datasets::mapping::ColumnMap::parse(c)?;
                        Ok(millcomp_datasets::mapping::map_table(table, &map)?.table)
                    }
                }
            }
            ScenarioSource::Design(req) => {
                let design =
                    millcomp_doe::generate(req).map_err(|source| ClosedLoopError::Design {
                        source: Box::new(source),
                    })?;
                Ok(millcomp_datasets::adapters::table_from_doe(
                    "--doe design",
                    design.columns(),
                )?)
            }
        }
    }
}

/// One batch: what to run, where the results go, and how.
#[derive(Debug, Clone)]
pub struct BatchRequest {
    /// The scenarios.
    pub scenarios: ScenarioSource,
    /// The controllers, comma separated (`pid-tuned,mpc`).
    pub controllers: String,
    /// The output directory (`runs/`, the tables, `plots/`, `summary.json`, `invocation.json`).
    pub out: PathBuf,
    /// The slice to run ([`Shard::ALL`]: the whole batch).
    pub shard: Shard,
    /// Worker threads (none: the current rayon pool — every core, or `RAYON_NUM_THREADS`).
    pub threads: Option<usize>,
    /// The commissioning cache's directory (none: `out/cache`). Slices on a cluster may share one.
    pub cache: Option<PathBuf>,
    /// Where the progress goes.
    pub progress: ProgressMode,
    /// Draw the plots.
    pub plots: bool,
    /// Stop cleanly on SIGTERM and SIGINT ([`super::signals`]): for a program's own batch, not a
    /// library caller's.
    pub stop_on_signals: bool,
    /// The caller's stop request (set from another thread, a notebook's interrupt): once set, the
    /// runs under way finish and are stored, no new one starts, and the call returns
    /// [`ClosedLoopError::Interrupted`]; the same request with the flag cleared resumes.
    pub stop: Option<Arc<AtomicBool>>,
}

impl BatchRequest {
    /// The whole batch of `scenarios` × `controllers` into `out`, on every core, the cache in
    /// `out/cache`, progress on stderr, with plots.
    pub fn new(scenarios: ScenarioSource, controllers: &str, out: impl Into<PathBuf>) -> Self {
        Self {
            scenarios,
            controllers: controllers.to_string(),
            out: out.into(),
            shard: Shard::ALL,
            threads: None,
            cache: None,
            progress: ProgressMode::Auto,
            plots: true,
            stop_on_signals: false,
            stop: None,
        }
    }

    /// The commissioning cache's directory.
    pub fn cache_dir(&self) -> PathBuf {
        self.cache.clone().unwrap_or_else(|| self.out.join("cache"))
    }

    /// The plan.
    ///
    /// # Errors
    /// As [`ScenarioSource::table`], [`parse_controllers`] and [`Plan::from_table`].
    pub fn plan(&self) -> Result<Plan, ClosedLoopError> {
        let controllers = parse_controllers(&self.controllers)?;
        Plan::from_table(&self.scenarios.table()?, controllers)
    }
}

/// Runs a batch (or its slice) and writes its results: [`BatchRequest::plan`], then [`run_plan`].
///
/// # Errors
/// As [`BatchRequest::plan`] and [`run_plan`].
///
/// # Examples
/// ```
/// use millcomp_closedloop::batch::{BatchRequest, ProgressMode, ScenarioSource, run_batch};
/// use millcomp_datasets::{Column, ColumnData, Table};
/// // two very short grooves (0.3 mm at 20° and 40°), PID and MPC: 4 runs
/// let col = |name: &str, v: Vec<f64>| Column { name: name.into(), data: ColumnData::Float(v) };
/// let t = Table::from_columns(
///     "example",
///     vec![col("length_mm", vec![0.3, 0.3]), col("tilt_deg", vec![20.0, 40.0])],
/// )
/// .unwrap();
/// let dir = std::env::temp_dir().join(format!("millcomp-run-batch-doc-{}", std::process::id()));
/// let mut req = BatchRequest::new(ScenarioSource::Table(t), "pid,mpc", &dir);
/// req.progress = ProgressMode::Quiet;
/// let s = run_batch(&req).unwrap();
/// assert_eq!((s.results.n_runs, s.invocation.n_ran), (4, 4));
/// // one commissioning per scenario, shared by its two controllers
/// assert_eq!(s.invocation.cache.as_ref().unwrap().counts.computed, 2);
/// let summary = std::fs::read(dir.join("summary.json")).unwrap();
/// assert!(dir.join("results.csv").exists());
/// // the same call again: every run resumed, the same results byte for byte
/// let again = run_batch(&req).unwrap();
/// assert_eq!((again.invocation.n_ran, again.invocation.n_resumed), (0, 4));
/// assert_eq!(std::fs::read(dir.join("summary.json")).unwrap(), summary);
/// std::fs::remove_dir_all(&dir).ok();
/// ```
pub fn run_batch(req: &BatchRequest) -> Result<BatchSummary, ClosedLoopError> {
    let plan = req.plan()?;
    run_plan(&plan, req)
}

/// Runs the slice `req.shard` of `plan` into `req.out` and writes its results (the tables, the
/// plots, `summary.json`, `invocation.json`); the scenarios of `req` are not read again.
///
/// # Errors
/// Those of [`run_shard_with`] (a batch stopped by a signal is [`ClosedLoopError::Interrupted`]),
/// and of writing the results. A run that failed is not an error: it is listed in the summary's
/// `failed`.
pub fn run_plan(plan: &Plan, req: &BatchRequest) -> Result<BatchSummary, ClosedLoopError> {
    run_plan_with(plan, req, &MpcClosedLoop)
}

/// [`run_plan`] on another closed loop than the published scenario's — a simulated machine's
/// (`crate::machine::MachineRuns`), whose controllers come from a user's bundles.
///
/// # Errors
/// As [`run_plan`].
pub fn run_plan_with(
    plan: &Plan,
    req: &BatchRequest,
    runner: &dyn ClosedLoop,
) -> Result<BatchSummary, ClosedLoopError> {
    let _signals = req.stop_on_signals.then(SignalGuard::install);
    with_threads(req.threads, || {
        let start = Instant::now();
        let cache_dir = req.cache_dir();
        let cache = CommissioningCache::on_disk(&cache_dir);
        let opts = ShardOptions {
            progress: req.progress.clone(),
            cache: Some(&cache),
            stop: req
                .stop_on_signals
                .then(super::signals::stop_flag)
                .into_iter()
                .chain(req.stop.as_deref())
                .collect(),
            stop_reason: Some(super::signals::received),
        };
        let outcome = run_shard_with(plan, req.shard, &req.out, runner, &opts)?;
        let shard = (req.shard != Shard::ALL).then_some(req.shard);
        let mut summary = outcome_summary(plan, &outcome, shard);
        summary.invocation.cache = Some(CacheUse {
            dir: cache_dir.display().to_string(),
            counts: outcome.cache,
        });
        summary.invocation.throughput_per_core = (outcome.n_ran > 0 && outcome.wall_clock_s > 0.0)
            .then(|| outcome.simulated_s / outcome.wall_clock_s / outcome.threads.max(1) as f64);
        let mut summary = write_results(
            plan,
            &outcome.records,
            &outcome.failed,
            &req.out,
            summary,
            req.plots,
        )?;
        finish_profile(&mut summary, start);
        Ok(summary)
    })
}

/// Joins the slices of one batch (`dirs`) into `out` and writes its results there ([`merge`]).
///
/// # Errors
/// Those of [`merge`] and of writing the results.
pub fn merge_batch(
    dirs: &[PathBuf],
    out: &Path,
    plots: bool,
) -> Result<BatchSummary, ClosedLoopError> {
    let start = Instant::now();
    let merged = merge(dirs, out)?;
    let failed = merged.summary.results.failed.clone();
    let mut summary = write_results(
        &merged.plan,
        &merged.records,
        &failed,
        out,
        merged.summary,
        plots,
    )?;
    finish_profile(&mut summary, start);
    Ok(summary)
}

/// The summary of a shard's run: its records, what ran now and what was resumed, the simulated and
/// wall-clock time, the threads, the profile of the runs.
pub fn outcome_summary(plan: &Plan, outcome: &ShardOutcome, shard: Option<Shard>) -> BatchSummary {
    let mut summary = new_summary(plan, outcome.records.len(), shard);
    summary.results.failed = outcome.failed.clone();
    let i = &mut summary.invocation;
    i.n_ran = outcome.n_ran;
    i.n_resumed = outcome.n_resumed;
    i.simulated_s = outcome.simulated_s;
    i.threads = outcome.threads;
    i.wall_clock_s = outcome.wall_clock_s;
    i.profile_s = outcome.profile;
    summary
}

/// Writes the results of a batch into `out`: `results.csv` and `results.parquet`, the plots
/// (`out/plots/`, when `with_plots`), `summary.json` and `invocation.json`, whose `files` lists them in
/// that order. `summary.json` is written after the tables and plots: its presence says they are
/// complete. Temporary files a killed writer left in `out` and `out/plots` are removed first.
///
/// # Errors
/// [`ClosedLoopError::Write`], [`ClosedLoopError::CreateDir`] and [`ClosedLoopError::Plot`] naming
/// the file.
pub fn write_results(
    plan: &Plan,
    records: &[RunRecord],
    failed: &[FailedRun],
    out: &Path,
    mut summary: BatchSummary,
    with_plots: bool,
) -> Result<BatchSummary, ClosedLoopError> {
    remove_partials(out);
    remove_partials(&out.join("plots"));
    summary.results.failed = failed.to_vec();
    if !failed.is_empty() {
        summary.results.notes.push(format!(
            "{} of {} runs failed (their reasons under `failed`); they are not in the tables",
            failed.len(),
            failed.len() + records.len()
        ));
    }
    let mut summary = write_tables(plan, records, out, summary)?;
    if with_plots {
        let t0 = Instant::now();
        for p in plots(plan, records, &out.join("plots"))? {
            summary.invocation.files.push(p.display().to_string());
        }
        summary
            .invocation
            .profile_s
            .add(Stage::Plots, t0.elapsed().as_secs_f64());
    }
    write_summary(out, summary)
}

/// The call's wall clock and its threads' idle time, then `invocation.json` rewritten with them.
fn finish_profile(summary: &mut BatchSummary, start: Instant) {
    let i = &mut summary.invocation;
    let wall = start.elapsed().as_secs_f64();
    let busy = i.profile_s.total();
    i.profile_s.add(
        Stage::Waiting,
        (i.threads.max(1) as f64 * wall - busy).max(0.0),
    );
    i.wall_clock_s = wall;
    if let Some(path) = i.files.iter().find(|f| f.ends_with("invocation.json")) {
        let path = PathBuf::from(path);
        if let Ok(text) = serde_json::to_string_pretty(&*i) {
            // informative only: a failure leaves the first version
            let _ = super::store::write_text(&path, &text);
        }
    }
}

/// Runs `f` on a rayon pool of `threads` workers (the current pool when `None`).
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] (`threads`) for 0 or a pool that cannot be built; `f`'s errors.
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> Result<T, ClosedLoopError> + Send,
) -> Result<T, ClosedLoopError> {
    match threads {
        None => f(),
        Some(0) => Err(crate::error::invalid("threads", 0, "at least 1")),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| crate::error::invalid("threads", n, e.to_string()))?
            .install(f),
    }
}

/// What a plan will cost before it runs (`millcomp batch --dry-run`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// Runs of the slice.
    pub runs: usize,
    /// Runs already finished in the output directory (resumed, not run again).
    pub finished: usize,
    /// Scenarios with runs left.
    pub scenarios: usize,
    /// Distinct commissionings the runs left need, and how many of them the cache already holds.
    pub commissionings: usize,
    /// Of [`Self::commissionings`], those already in the cache.
    pub commissionings_cached: usize,
    /// Simulated machining seconds of the runs left.
    pub simulated_s: f64,
    /// Estimated core-seconds ([`COST_CORE_S_PER_SIMULATED_S`], [`COMMISSION_CORE_S`]).
    pub core_s: f64,
    /// Worker threads.
    pub threads: usize,
    /// Estimated wall-clock seconds on them.
    pub wall_s: f64,
}

/// Core-seconds per simulated machining second of each controller on the groove stage, measured on the
/// reference machine (2 cores, AMD EPYC, `bash bench/batch-scale`; the run's set-up and bounds
/// included). A machine twice as fast takes half.
pub const COST_CORE_S_PER_SIMULATED_S: &[(&str, f64)] = &[
    ("none", 0.008),
    ("open-loop", 0.010),
    ("pid", 0.010),
    ("pid-aw", 0.010),
    ("pid-design", 0.010),
    ("pid-tuned", 0.012),
    ("pid-ff", 0.020),
    ("pid-ff-read", 0.022),
    ("threshold", 0.010),
    ("mpc", 0.080),
    ("mpc-nopreview", 0.080),
    ("reactive", 0.010),
    ("proactive", 0.010),
];

/// Core-seconds of one groove commissioning on the reference machine.
pub const COMMISSION_CORE_S: f64 = 0.35;

/// The estimate of what the slice `shard` of `plan` still has to run in `out` with the cache in
/// `cache_dir`, on `threads` threads.
///
/// # Errors
/// A scenario that cannot be built (checked when the plan was made, so not expected).
pub fn estimate(
    plan: &Plan,
    shard: Shard,
    out: &Path,
    cache_dir: &Path,
    threads: usize,
) -> Result<Estimate, ClosedLoopError> {
    let runs = plan.shard_runs(shard);
    let left: Vec<_> = runs
        .iter()
        .filter(|r| {
            !matches!(
                load_outcome(out, plan, **r),
                Some(RunOutcome::Done(_) | RunOutcome::Failed(_))
            )
        })
        .copied()
        .collect();
    let cache = CommissioningCache::on_disk(cache_dir);
    let mut keys = BTreeSet::new();
    let mut cached = 0;
    let (mut simulated_s, mut core_s) = (0.0, 0.0);
    let mut scenarios = BTreeSet::new();
    for r in &left {
        let s = build_scenario(&plan.scenarios[r.scenario])?;
        let controller = plan.controllers[r.controller].as_str();
        let duration = match s.stage {
            StageKind::Groove => {
                let truth = groove_truth(&s)?;
                if scenarios.insert(r.scenario) && s.control.bundle.is_none() {
                    let plant = CommissioningPlant::of_scenario(&s, &truth);
                    let key =
                        CommissioningKey::new(&plant, &s.commissioning, s.seed.wrapping_add(11));
                    let address = key.address()?;
                    if keys.insert(address.clone())
                        && cache
                            .bundle_dir()
                            .is_some_and(|d| d.join(format!("{address}.toml")).exists())
                    {
                        cached += 1;
                    }
                }
                truth.duration_s()
            }
            // the NC stage's 185 mm blank and the thin wall's passes: about as long as the groove
            _ => {
                scenarios.insert(r.scenario);
                12.0
            }
        };
        simulated_s += duration;
        let per = COST_CORE_S_PER_SIMULATED_S
            .iter()
            .find(|(c, _)| *c == controller)
            .map_or(0.05, |(_, v)| *v);
        core_s += per * duration;
    }
    core_s += COMMISSION_CORE_S * (keys.len() - cached) as f64;
    let threads = threads.max(1);
    // whole scenarios go to the threads: the last ones leave threads idle
    let tail = if left.is_empty() {
        0.0
    } else {
        core_s / left.len() as f64
    };
    Ok(Estimate {
        runs: runs.len(),
        finished: runs.len() - left.len(),
        scenarios: scenarios.len(),
        commissionings: keys.len(),
        commissionings_cached: cached,
        simulated_s,
        core_s,
        threads,
        wall_s: core_s / threads as f64 + tail,
    })
}

/// The estimate of a request ([`estimate`] of its plan, slice, directory, cache and threads).
///
/// # Errors
/// As [`BatchRequest::plan`] and [`estimate`].
pub fn estimate_request(req: &BatchRequest) -> Result<(Plan, Estimate), ClosedLoopError> {
    let plan = timed(Stage::Scenario, || req.plan())?;
    let threads = req.threads.unwrap_or_else(rayon::current_num_threads);
    let e = estimate(&plan, req.shard, &req.out, &req.cache_dir(), threads)?;
    Ok((plan, e))
}
