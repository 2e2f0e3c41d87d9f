//! The designed comparison through the batch engine — the one place the pipeline calls
//! `millcomp_closedloop::batch` ([`compare`]: `run_plan_with` for runs on a closed loop, `write_results`
//! for runs measured elsewhere), so that its API can change in one place.

use std::collections::BTreeMap;
use std::path::Path;

use millcomp_closedloop::batch::exec::{ClosedLoop, RunMetrics, RunRecord};
use millcomp_closedloop::batch::factors::{FactorValue, ScenarioSpec};
use millcomp_closedloop::batch::paired::PairedEntry;
use millcomp_closedloop::batch::plan::Plan as BatchPlan;
use millcomp_closedloop::batch::results::{AnovaEntry, new_summary, results_table};
use millcomp_closedloop::batch::{BatchRequest, ProgressMode, ScenarioSource, run_plan_with};
use millcomp_datasets::{ColumnData, Table};

use crate::error::{PipelineError, Result};

/// Where the runs of a comparison come from.
pub enum Runs<'a> {
    /// Run every condition of the table × controller on a closed loop (the simulated machine).
    Machine {
        /// The conditions (batch factor names, one row each).
        conditions: &'a Table,
        /// The closed loop.
        runner: &'a dyn ClosedLoop,
    },
    /// Runs measured elsewhere: one record per condition × controller ([`records_from_table`]).
    Measured(BatchPlan, Vec<RunRecord>),
}

/// What a comparison found.
#[derive(Debug, Clone)]
pub struct Compared {
    /// The plan (conditions × controllers), as read back from `results.csv`.
    pub plan: BatchPlan,
    /// Every run's metrics, as read back from `results.csv`.
    pub records: Vec<RunRecord>,
    /// Medians of every metric per controller.
    pub by_controller: BTreeMap<String, BTreeMap<String, f64>>,
    /// The ANOVA of each metric with the controller as a factor.
    pub anova: BTreeMap<String, AnovaEntry>,
    /// Each controller against the reference (`pid-tuned` when it ran, else the first), condition by
    /// condition.
    pub paired: Vec<PairedEntry>,
    /// Notes of the analysis (failed runs among them).
    pub notes: Vec<String>,
    /// Files written.
    pub files: Vec<std::path::PathBuf>,
}

/// Runs (or takes) the comparison of `controllers` and writes `results.csv`, `results.parquet`,
/// `summary.json` and `invocation.json` into `dir`; returns the analysis: per-controller medians, the
/// ANOVA with the controller as a factor, the paired differences, and the runs read back from
/// `results.csv`. A machine run starts afresh (`dir/runs` is cleared: the bundles may have changed
/// under the same plan). Controller names are not checked against the published controllers: a
/// closed loop may know variants (`mpc+diagnosed`).
///
/// # Errors
/// The batch engine's errors (bad factor values naming the row, writing); a run that failed is a note.
pub fn compare(
    controllers: &[String],
    runs: Runs<'_>,
    dir: &Path,
    progress: bool,
) -> Result<Compared> {
    let summary = match runs {
        Runs::Machine { conditions, runner } => {
            for stale in [dir.join("runs"), dir.join("plan.json")] {
                if stale.is_dir() {
                    std::fs::remove_dir_all(&stale).map_err(|e| {
                        PipelineError::io(&stale, "clearing an earlier call's runs", e)
                    })?;
                } else if stale.exists() {
                    std::fs::remove_file(&stale)
                        .map_err(|e| PipelineError::io(&stale, "clearing", e))?;
                }
            }
            let mut req = BatchRequest::new(
                ScenarioSource::Table(conditions.clone()),
                &controllers.join(","),
                dir,
            );
            req.progress = if progress {
                ProgressMode::Auto
            } else {
                ProgressMode::Quiet
            };
            req.plots = false;
            let plan = BatchPlan::from_table(conditions, controllers.to_vec())?;
            run_plan_with(&plan, &req, runner)?
        }
        Runs::Measured(plan, records) => {
            std::fs::create_dir_all(dir).map_err(|e| PipelineError::io(dir, "creating", e))?;
            let summary = new_summary(&plan, records.len(), None);
            millcomp_closedloop::batch::engine::write_results(
                &plan,
                &records,
                &[],
                dir,
                summary,
                false,
            )?
        }
    };
    let results = dir.join("results.csv");
    let (plan, records) = records_from_table(&millcomp_datasets::read_any(&results)?, &results)?;
    let r = summary.results;
    let mut notes = r.notes;
    notes.extend(
        r.failed
            .iter()
            .map(|f| format!("run {} ({}) failed: {}", f.run, f.controller, f.reason)),
    );
    Ok(Compared {
        files: summary
            .invocation
            .files
            .iter()
            .map(std::path::PathBuf::from)
            .collect(),
        plan,
        records,
        by_controller: r.by_controller,
        anova: r.anova,
        paired: r.paired,
        notes,
    })
}

/// The paired comparison of every controller of `records` against `reference` (condition by condition,
/// conditions matched by index): the plan is `reference` first, then the others.
pub fn paired_against(
    plan: &BatchPlan,
    records: &[RunRecord],
    reference: &str,
) -> Vec<PairedEntry> {
    let mut controllers = vec![reference.to_string()];
    for r in records {
        if !controllers.contains(&r.controller) {
            controllers.push(r.controller.clone());
        }
    }
    let mut p = plan.clone();
    // the reference is first and `pid-tuned` absent unless it is the reference: the engine pairs each
    // controller with the first
    controllers.retain(|c| c == reference || c != "pid-tuned");
    p.controllers = controllers;
    let kept: Vec<RunRecord> = records
        .iter()
        .filter(|r| p.controllers.contains(&r.controller))
        .cloned()
        .collect();
    millcomp_closedloop::batch::paired::paired(&p, &kept)
}

/// The results table of a comparison (one row per run).
///
/// # Errors
/// The table's errors.
pub fn table_of(c: &Compared) -> Result<Table> {
    Ok(results_table(&c.plan, &c.records)?)
}

/// Runs measured elsewhere, from a results table: `scenario` (the condition, an integer), the factors,
/// `controller`, `pp_error_um` and optionally the other metrics of `millcomp batch`'s `results.csv`
/// (`change_excess_um`, `rms_error_um`, …). Columns `run` and unknown metrics are ignored; every other
/// column is a factor. Conditions keep their factor values from their first row.
///
/// # Errors
/// [`PipelineError::Data`] naming the file, column and row: a missing column, a condition whose
/// factors differ between its rows, a non-finite `pp_error_um`.
pub fn records_from_table(table: &Table, path: &Path) -> Result<(BatchPlan, Vec<RunRecord>)> {
    let need = |c: &str| {
        table.column(c).ok_or_else(|| {
            PipelineError::data(
                path,
                format!(
                    "no column `{c}` (a results table needs scenario, the factors, controller and pp_error_um)"
                ),
            )
        })
    };
    need("scenario")?;
    need("controller")?;
    need("pp_error_um")?;
    let scen = table.i64s("scenario").or_else(|_| {
        table
            .f64s("scenario")
            .map(|v| v.into_iter().map(|x| x as i64).collect())
    })?;
    let ctrl = table.strings("controller")?;
    let metrics = millcomp_closedloop::batch::exec::METRICS;
    let factor_names: Vec<String> = table
        .columns
        .iter()
        .map(|c| c.name.clone())
        .filter(|n| {
            !matches!(n.as_str(), "run" | "scenario" | "controller")
                && !metrics.contains(&n.as_str())
                && !n.ends_with("_coded")
        })
        .collect();
    let mut index: BTreeMap<i64, usize> = BTreeMap::new();
    let mut scenarios: Vec<ScenarioSpec> = Vec::new();
    let mut records = Vec::new();
    let metric = |name: &str, row: usize| -> Option<f64> {
        table
            .column(name)
            .and_then(|c| match &c.data {
                ColumnData::Float(v) => Some(v[row]),
                ColumnData::Int(v) => Some(v[row] as f64),
                ColumnData::Text(v) => v[row].trim().parse().ok(),
            })
            .filter(|x| x.is_finite())
    };
    for row in 0..table.n_rows() {
        let mut factors = BTreeMap::new();
        for f in &factor_names {
            let c = table
                .column(f)
                .ok_or_else(|| PipelineError::data(path, f.clone()))?;
            let v = match &c.data {
                ColumnData::Float(v) => FactorValue::Num(v[row]),
                ColumnData::Int(v) => FactorValue::Num(v[row] as f64),
                ColumnData::Text(v) => FactorValue::Text(v[row].trim().to_string()),
            };
            factors.insert(f.clone(), v);
        }
        let k = match index.get(&scen[row]) {
            Some(&k) => {
                if scenarios[k].factors != factors {
                    return Err(PipelineError::data(
                        path,
                        format!(
                            "row {}: condition {} has other factor values than in its first row",
                            row + 1,
                            scen[row]
                        ),
                    ));
                }
                k
            }
            None => {
                let k = scenarios.len();
                index.insert(scen[row], k);
                scenarios.push(ScenarioSpec { index: k, factors });
                k
            }
        };
        let pp = metric("pp_error_um", row).ok_or_else(|| {
            PipelineError::data(
                path,
                format!("column pp_error_um, row {}: not a finite number", row + 1),
            )
        })?;
        records.push(RunRecord {
            fingerprint: String::new(),
            run: row,
            scenario: k,
            controller: ctrl[row].trim().to_string(),
            metrics: RunMetrics {
                pp_error_um: pp,
                rms_error_um: metric("rms_error_um", row).unwrap_or(f64::NAN),
                max_error_um: metric("max_error_um", row).unwrap_or(f64::NAN),
                min_error_um: metric("min_error_um", row).unwrap_or(f64::NAN),
                actuator_travel_um: metric("actuator_travel_um", row).unwrap_or(f64::NAN),
                solver_fallbacks: metric("solver_fallbacks", row).map_or(0, |x| x as usize),
                change_excess_um: metric("change_excess_um", row),
                stroke_bound_um: metric("stroke_bound_um", row),
                optimum_pp_um: metric("optimum_pp_um", row),
                change_bound_um: metric("change_bound_um", row),
                solve_median_us: None,
                solve_p99_us: None,
                solve_max_us: None,
                deadline_misses: None,
            },
            simulated_s: 0.0,
            wall_clock_s: 0.0,
        });
    }
    let mut controllers: Vec<String> = Vec::new();
    for r in &records {
        if !controllers.contains(&r.controller) {
            controllers.push(r.controller.clone());
        }
    }
    let plan = BatchPlan::new(factor_names, scenarios, controllers)?;
    for r in &mut records {
        r.fingerprint = plan.fingerprint.clone();
    }
    Ok((plan, records))
}
