//! Results of a batch: the table (one row per run), the per-controller summary, the DOE analysis of each
//! metric with the controller as a factor, and the merge of slices. Every file is written atomically.
//! Plots are the caller's: write the tables ([`write_tables`]), add the plot files to the summary, then
//! write it ([`write_summary`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use millcomp_datasets::{Column, ColumnData, Table};
use millcomp_doe::{AnalysisInput, DoeError, ModelSpec, TermRow};
use serde::Serialize;

use super::factors::FactorValue;
pub use super::paired::varying_factors;
use super::paired::{PairedEntry, paired};
use super::plan::{Plan, Shard};
use super::store::{
    FailedRun, METRICS, RunOutcome, RunRecord, load_outcome, read_plan, read_shard, write_text,
};
use crate::cache::CacheCounts;
use crate::error::{ClosedLoopError, error_chain};
use crate::profile::{Stage, StageTimes, timed};
use crate::stats::median;

/// The ANOVA of one metric.
#[derive(Debug, Clone, Serialize)]
pub struct AnovaEntry {
    /// The model fitted (`controller + tilt_deg + … + controller:tilt_deg + …`).
    pub model: String,
    /// Runs used.
    pub n_runs: usize,
    /// R².
    pub r_squared: f64,
    /// The terms table of the DOE contract (`term`, `effect`, `coef`, `std_err`, `df`, `sum_sq`, `f`,
    /// `p_value`).
    pub terms: Vec<TermRow>,
}

/// The batch summary (the `--json` output): the results ([`BatchResults`], `DIR/summary.json`) and how
/// this call ran ([`BatchInvocation`], `DIR/invocation.json`), flattened into one object.
#[derive(Debug, Clone, Serialize)]
pub struct BatchSummary {
    /// What the runs say: the same however the batch was run (one process or merged slices, any
    /// number of threads, resumed or not) — byte for byte in `summary.json`.
    #[serde(flatten)]
    pub results: BatchResults,
    /// How this call ran: wall-clock times, threads, what ran now, the files written.
    #[serde(flatten)]
    pub invocation: BatchInvocation,
}

/// The results of a batch (`DIR/summary.json`). Nothing here depends on the machine, the clock, the
/// threads or the output directory, so a merge of slices writes the same file as one process.
#[derive(Debug, Clone, Serialize)]
pub struct BatchResults {
    /// Plan fingerprint.
    pub fingerprint: String,
    /// Runs in these results.
    pub n_runs: usize,
    /// Runs in the whole plan.
    pub n_runs_planned: usize,
    /// Scenarios in the plan.
    pub n_scenarios: usize,
    /// Controllers.
    pub controllers: Vec<String>,
    /// The slice these results cover (absent for a whole batch or a merge).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shard: Option<Shard>,
    /// Medians of each metric per controller.
    pub by_controller: BTreeMap<String, BTreeMap<String, f64>>,
    /// Per metric, the analysis with the controller as a factor.
    pub anova: BTreeMap<String, AnovaEntry>,
    /// Each controller against the reference, scenario by scenario ([`super::paired`]).
    pub paired: Vec<PairedEntry>,
    /// Notes (analyses that could not be made, and why).
    pub notes: Vec<String>,
    /// Runs that failed, with their reasons (not in the tables; absent when none failed).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub failed: Vec<FailedRun>,
}

/// How one call of a batch ran (`DIR/invocation.json`): wall-clock and machine-dependent, so kept apart
/// from the results.
#[derive(Debug, Clone, Serialize)]
pub struct BatchInvocation {
    /// MPC controllers: the median over the runs of each run's median QP solve time and the largest
    /// run's 99th percentile (µs; wall-clock, on the machine each run ran on).
    pub solve_times_us: BTreeMap<String, SolveTimes>,
    /// Runs executed by this call (0 for a merge).
    pub n_ran: usize,
    /// Runs found finished and not run again.
    pub n_resumed: usize,
    /// Simulated machining seconds of the runs executed now.
    pub simulated_s: f64,
    /// Wall-clock seconds.
    pub wall_clock_s: f64,
    /// Simulated machining seconds per wall-clock second per thread, for the runs executed now.
    pub throughput_per_core: Option<f64>,
    /// Worker threads.
    pub threads: usize,
    /// Where this call's time went (seconds summed over the threads, by stage; `waiting`: the
    /// threads' time without work, `threads × wall-clock −` the rest).
    pub profile_s: StageTimes,
    /// The commissioning cache: its directory and how the bundles were found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cache: Option<CacheUse>,
    /// Files written (paths as given with `--out`).
    pub files: Vec<String>,
}

/// How a batch used its commissioning cache.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CacheUse {
    /// The directory (`--cache`, or `DIR/cache`).
    pub dir: String,
    /// How the bundles were found.
    #[serde(flatten)]
    pub counts: CacheCounts,
}

/// QP solve times of one controller over a batch (µs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SolveTimes {
    /// Runs with solver statistics.
    pub runs: usize,
    /// Median over the runs of each run's median solve time.
    pub median_us: f64,
    /// Largest 99th-percentile solve time of any run.
    pub p99_max_us: f64,
    /// Longest cycle of any run.
    pub max_us: f64,
    /// Cycles over their budget, all runs (timed only: a batch always uses the fresh plan, so its
    /// results do not depend on the machine's load).
    pub deadline_misses: usize,
}

/// Solve times per controller that reports them (the MPCs).
pub fn solve_times(plan: &Plan, records: &[RunRecord]) -> BTreeMap<String, SolveTimes> {
    let mut out = BTreeMap::new();
    for c in &plan.controllers {
        let rs: Vec<&RunRecord> = records.iter().filter(|r| &r.controller == c).collect();
        let mut med: Vec<f64> = rs
            .iter()
            .filter_map(|r| r.metrics.solve_median_us)
            .collect();
        if med.is_empty() {
            continue;
        }
        let p99 = rs
            .iter()
            .filter_map(|r| r.metrics.solve_p99_us)
            .fold(0.0, f64::max);
        let max_us = rs
            .iter()
            .filter_map(|r| r.metrics.solve_max_us)
            .fold(0.0, f64::max);
        let deadline_misses = rs.iter().filter_map(|r| r.metrics.deadline_misses).sum();
        out.insert(
            c.clone(),
            SolveTimes {
                runs: med.len(),
                median_us: median(&mut med),
                p99_max_us: p99,
                max_us,
                deadline_misses,
            },
        );
    }
    out
}

/// Whether factor `name` holds labels (text) rather than numbers in this plan.
pub fn is_label(plan: &Plan, name: &str) -> bool {
    plan.scenarios
        .iter()
        .any(|s| matches!(s.factors.get(name), Some(FactorValue::Text(_))))
}

/// The results table: `run`, `scenario`, the factors, `controller`, every metric; rows in run order.
///
/// # Errors
/// [`ClosedLoopError::Dataset`] if the columns do not make a table (they always do).
pub fn results_table(plan: &Plan, records: &[RunRecord]) -> Result<Table, ClosedLoopError> {
    let mut cols = vec![
        Column {
            name: "run".into(),
            data: ColumnData::Int(records.iter().map(|r| r.run as i64).collect()),
        },
        Column {
            name: "scenario".into(),
            data: ColumnData::Int(records.iter().map(|r| r.scenario as i64).collect()),
        },
    ];
    for f in &plan.factor_names {
        let vals = records
            .iter()
            .map(|r| plan.scenarios[r.scenario].factors.get(f).cloned());
        let data = if is_label(plan, f) {
            ColumnData::Text(
                vals.map(|v| v.map(|v| v.text()).unwrap_or_default())
                    .collect(),
            )
        } else {
            ColumnData::Float(
                vals.map(|v| match v {
                    Some(FactorValue::Num(x)) => x,
                    _ => f64::NAN,
                })
                .collect(),
            )
        };
        cols.push(Column {
            name: f.clone(),
            data,
        });
    }
    cols.push(Column {
        name: "controller".into(),
        data: ColumnData::Text(records.iter().map(|r| r.controller.clone()).collect()),
    });
    for m in METRICS {
        let data = if m == "solver_fallbacks" {
            ColumnData::Int(
                records
                    .iter()
                    .map(|r| r.metrics.solver_fallbacks as i64)
                    .collect(),
            )
        } else {
            ColumnData::Float(
                records
                    .iter()
                    .map(|r| r.metrics.get(m).unwrap_or(f64::NAN))
                    .collect(),
            )
        };
        cols.push(Column {
            name: m.to_string(),
            data,
        });
    }
    Ok(Table::from_columns("batch results", cols)?)
}

/// Medians of every metric per controller.
pub fn by_controller(
    plan: &Plan,
    records: &[RunRecord],
) -> BTreeMap<String, BTreeMap<String, f64>> {
    let mut out = BTreeMap::new();
    for c in &plan.controllers {
        let rs: Vec<&RunRecord> = records.iter().filter(|r| &r.controller == c).collect();
        if rs.is_empty() {
            continue;
        }
        let mut m = BTreeMap::new();
        for name in METRICS {
            let mut v: Vec<f64> = rs.iter().filter_map(|r| r.metrics.get(name)).collect();
            m.insert(name.to_string(), median(&mut v));
        }
        out.insert(c.clone(), m);
    }
    out
}

/// The DOE analysis of each metric with the controller as a factor: main effects of the varying
/// factors and the controller, plus controller × factor interactions (where the controller's advantage
/// depends on the condition). Falls back to main effects when the interactions do not fit; an analysis
/// that cannot be made is a note, not an error.
pub fn anova(
    plan: &Plan,
    records: &[RunRecord],
    notes: &mut Vec<String>,
) -> BTreeMap<String, AnovaEntry> {
    let mut out = BTreeMap::new();
    let mut factors = varying_factors(plan, records);
    let n_ctrl = {
        let mut c: Vec<&str> = records.iter().map(|r| r.controller.as_str()).collect();
        c.sort_unstable();
        c.dedup();
        c.len()
    };
    if n_ctrl > 1 {
        factors.insert(0, "controller".to_string());
    }
    if factors.is_empty() {
        notes.push("analysis skipped: no factor varies".into());
        return out;
    }
    let mut full = factors.join(" + ");
    if n_ctrl > 1 {
        for f in factors.iter().skip(1) {
            full.push_str(&format!(" + controller:{f}"));
        }
    }
    let main = factors.join(" + ");
    for metric in METRICS {
        // the runs that have this metric (a run without a process change has no change excess)
        let with: Vec<RunRecord> = records
            .iter()
            .filter(|r| r.metrics.get(metric).is_some_and(f64::is_finite))
            .cloned()
            .collect();
        if with.is_empty() {
            continue; // a metric no run has (a change excess without changes): nothing to analyse
        }
        if with.len() < records.len() {
            notes.push(format!(
                "{metric}: {} of {} runs have it (the others have no such event)",
                with.len(),
                records.len()
            ));
        }
        let table = match results_table(plan, &with) {
            Ok(t) => t,
            Err(e) => {
                notes.push(format!("{metric}: no analysis ({})", error_chain(&e)));
                continue;
            }
        };
        let columns = millcomp_datasets::adapters::doe_columns(&table);
        let attempt = |formula: &str| -> Result<AnovaEntry, DoeError> {
            let input = AnalysisInput::from_table(
                &columns,
                metric,
                Some(factors.as_slice()),
                ModelSpec::Formula(formula.to_string()),
            )?;
            let a = millcomp_doe::analyze(&input)?;
            Ok(AnovaEntry {
                model: a.model.clone(),
                n_runs: a.n_runs,
                r_squared: a.r_squared,
                terms: a.terms.clone(),
            })
        };
        match attempt(&full) {
            Ok(e) => {
                out.insert(metric.to_string(), e);
            }
            Err(e1) => match attempt(&main) {
                Ok(e) => {
                    notes.push(format!(
                        "{metric}: controller interactions not estimable ({}); main effects only",
                        error_chain(&e1)
                    ));
                    out.insert(metric.to_string(), e);
                }
                Err(e2) => notes.push(format!("{metric}: no analysis ({})", error_chain(&e2))),
            },
        }
    }
    out
}

/// Writes `results.csv` and `results.parquet` into `out` (listed in the invocation's `files`) and fills
/// the summary's medians and analysis. Add further files (plots) to `summary.invocation.files`, then
/// call [`write_summary`].
///
/// # Errors
/// [`ClosedLoopError::CreateDir`], [`ClosedLoopError::Write`] naming the file.
pub fn write_tables(
    plan: &Plan,
    records: &[RunRecord],
    out: &Path,
    mut summary: BatchSummary,
) -> Result<BatchSummary, ClosedLoopError> {
    let t0 = std::time::Instant::now();
    create_dir(out)?;
    let table = results_table(plan, records)?;
    for name in ["results.csv", "results.parquet"] {
        let path = out.join(name);
        millcomp_datasets::write_table(&table, &path).map_err(|source| ClosedLoopError::Write {
            path: path.clone(),
            source,
        })?;
        summary.invocation.files.push(path.display().to_string());
    }
    let t1 = std::time::Instant::now();
    let r = &mut summary.results;
    r.by_controller = by_controller(plan, records);
    r.anova = anova(plan, records, &mut r.notes);
    r.paired = paired(plan, records);
    summary.invocation.solve_times_us = solve_times(plan, records);
    let p = &mut summary.invocation.profile_s;
    p.add(Stage::Writing, (t1 - t0).as_secs_f64());
    p.add(Stage::Analysis, t1.elapsed().as_secs_f64());
    Ok(summary)
}

/// Writes `summary.json` (the results) and `invocation.json` (how this call ran) into `out`, and lists
/// them last in `files`.
///
/// # Errors
/// [`ClosedLoopError::Write`].
pub fn write_summary(
    out: &Path,
    mut summary: BatchSummary,
) -> Result<BatchSummary, ClosedLoopError> {
    let results = out.join("summary.json");
    let invocation = out.join("invocation.json");
    for p in [&results, &invocation] {
        summary.invocation.files.push(p.display().to_string());
    }
    timed(Stage::Writing, || {
        write_text(&results, &serde_json::to_string_pretty(&summary.results)?)
    })?;
    write_text(
        &invocation,
        &serde_json::to_string_pretty(&summary.invocation)?,
    )?;
    Ok(summary)
}

fn create_dir(dir: &Path) -> Result<(), ClosedLoopError> {
    std::fs::create_dir_all(dir).map_err(|source| ClosedLoopError::CreateDir {
        path: dir.to_path_buf(),
        source,
    })
}

/// An empty summary for `plan`.
pub fn new_summary(plan: &Plan, n_runs: usize, shard: Option<Shard>) -> BatchSummary {
    BatchSummary {
        results: BatchResults {
            fingerprint: plan.fingerprint.clone(),
            n_runs,
            n_runs_planned: plan.n_runs(),
            n_scenarios: plan.scenarios.len(),
            controllers: plan.controllers.clone(),
            shard,
            by_controller: BTreeMap::new(),
            anova: BTreeMap::new(),
            paired: Vec::new(),
            notes: Vec::new(),
            failed: Vec::new(),
        },
        invocation: BatchInvocation {
            solve_times_us: BTreeMap::new(),
            n_ran: 0,
            n_resumed: 0,
            simulated_s: 0.0,
            wall_clock_s: 0.0,
            throughput_per_core: None,
            threads: rayon::current_num_threads(),
            profile_s: StageTimes::default(),
            cache: None,
            files: Vec::new(),
        },
    }
}

/// The slices of one batch joined ([`merge`]): its plan, every run's record in run order, and an
/// empty summary to fill with [`write_tables`] and [`write_summary`].
#[derive(Debug, Clone)]
pub struct MergedBatch {
    /// The plan.
    pub plan: Plan,
    /// Every run's record, in run order.
    pub records: Vec<RunRecord>,
    /// The summary of the merged results (nothing filled in yet).
    pub summary: BatchSummary,
}

/// `batch merge DIR... --out OUT`: joins the slices of one batch and writes its `plan.json` into `out`.
///
/// # Errors
/// [`ClosedLoopError::MergeNoDirs`], [`ClosedLoopError::MergeDifferentBatch`] when the slices come from
/// different batches (fingerprints differ), [`ClosedLoopError::MergeMissing`] when runs are missing,
/// and the errors of [`read_plan`] and of writing `out`.
///
/// # Examples
/// ```
/// use millcomp_closedloop::batch::exec::{MpcClosedLoop, run_shard};
/// use millcomp_closedloop::batch::plan::{Plan, Shard};
/// use millcomp_closedloop::batch::results::merge;
/// use millcomp_datasets::{Column, ColumnData, Table};
/// // two very short grooves (0.3 mm at 20° and 40°) with PID and MPC: 4 runs in two slices
/// let col = |name: &str, v: Vec<f64>| Column { name: name.into(), data: ColumnData::Float(v) };
/// let t = Table::from_columns(
///     "example",
///     vec![col("length_mm", vec![0.3, 0.3]), col("tilt_deg", vec![20.0, 40.0])],
/// )
/// .unwrap();
/// let plan = Plan::from_table(&t, vec!["pid".into(), "mpc".into()]).unwrap();
/// let dir = std::env::temp_dir().join(format!("millcomp-merge-doc-{}", std::process::id()));
/// let slices: Vec<_> = (0..2).map(|k| dir.join(format!("shard-{k}"))).collect();
/// for (k, d) in slices.iter().enumerate() {
///     let shard = Shard::new(k, 2, "example").unwrap();
///     // whole scenarios: slice k runs scenario k with both controllers
///     assert_eq!(run_shard(&plan, shard, d, &MpcClosedLoop, false).unwrap().n_ran, 2);
/// }
/// let merged = merge(&slices, &dir.join("merged")).unwrap();
/// assert_eq!(merged.records.iter().map(|r| r.run).collect::<Vec<_>>(), [0, 1, 2, 3]);
/// assert_eq!((merged.summary.results.n_runs, merged.summary.results.n_runs_planned), (4, 4));
/// // one slice alone leaves runs missing
/// let e = merge(&slices[..1], &dir.join("bad")).unwrap_err();
/// assert!(e.to_string().contains("2 of 4 runs are missing"), "{e}");
/// std::fs::remove_dir_all(&dir).ok();
/// ```
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergedBatch, ClosedLoopError> {
    let Some(first) = dirs.first() else {
        return Err(ClosedLoopError::MergeNoDirs);
    };
    let plan = read_plan(first)?;
    let mut records: BTreeMap<usize, RunRecord> = BTreeMap::new();
    let mut failed: BTreeMap<usize, FailedRun> = BTreeMap::new();
    for d in dirs {
        let p = read_plan(d)?;
        if p.fingerprint != plan.fingerprint {
            return Err(ClosedLoopError::MergeDifferentBatch {
                dir: d.clone(),
                fingerprint: p.fingerprint,
                first: first.clone(),
                first_fingerprint: plan.fingerprint,
            });
        }
        let shard = read_shard(d).unwrap_or(Shard::ALL);
        for r in plan.shard_runs(shard) {
            match load_outcome(d, &plan, r) {
                Some(RunOutcome::Done(rec)) => {
                    records.entry(rec.run).or_insert(rec);
                }
                Some(RunOutcome::Failed(f)) => {
                    failed.entry(f.run).or_insert(f);
                }
                None => {}
            }
        }
    }
    // a run another slice finished with a result is not a failure
    failed.retain(|run, _| !records.contains_key(run));
    let missing: Vec<usize> = (0..plan.n_runs())
        .filter(|i| !records.contains_key(i) && !failed.contains_key(i))
        .collect();
    if !missing.is_empty() {
        return Err(ClosedLoopError::MergeMissing {
            missing: missing.len(),
            planned: plan.n_runs(),
            examples: missing[..missing.len().min(8)].to_vec(),
        });
    }
    let records: Vec<RunRecord> = records.into_values().collect();
    create_dir(out)?;
    let mut summary = new_summary(&plan, records.len(), None);
    summary.results.failed = failed.into_values().collect();
    let plan_text = serde_json::to_string_pretty(&plan)?;
    millcomp_datasets::write_text_atomic(&out.join("plan.json"), &plan_text)?;
    Ok(MergedBatch {
        plan,
        records,
        summary,
    })
}
