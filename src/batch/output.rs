//! Results of a batch: the table (one row per run), the per-controller summary, the DOE analysis of each
//! metric with the controller as a factor, and the plots. Every file is written atomically.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use millcomp_datasets::{Column, ColumnData, Table};
use millcomp_doe::{AnalysisInput, ModelSpec, TermRow};
use serde::Serialize;

use super::exec::{METRICS, RunRecord, load_record, read_plan, read_shard};
use super::factors::FactorValue;
use super::plan::{Plan, Shard};
use crate::present::plot::{Series, line_plot};

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

/// The batch summary (`--json` output and `DIR/summary.json`).
#[derive(Debug, Clone, Serialize)]
pub struct BatchSummary {
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
    /// Files written.
    pub files: Vec<String>,
    /// Notes (analyses that could not be made, and why).
    pub notes: Vec<String>,
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn is_label(plan: &Plan, name: &str) -> bool {
    plan.scenarios
        .iter()
        .any(|s| matches!(s.factors.get(name), Some(FactorValue::Text(_))))
}

/// The results table: `run`, `scenario`, the factors, `controller`, every metric; rows in run order.
pub fn results_table(plan: &Plan, records: &[RunRecord]) -> anyhow::Result<Table> {
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

/// Factors that vary over the scenarios of these records.
fn varying_factors(plan: &Plan, records: &[RunRecord]) -> Vec<String> {
    plan.factor_names
        .iter()
        .filter(|f| {
            let mut vals: Vec<String> = records
                .iter()
                .filter_map(|r| plan.scenarios[r.scenario].factors.get(*f))
                .map(FactorValue::text)
                .collect();
            vals.sort();
            vals.dedup();
            vals.len() > 1
        })
        .cloned()
        .collect()
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
    let table = match results_table(plan, records) {
        Ok(t) => t,
        Err(e) => {
            notes.push(format!("analysis skipped: {e:#}"));
            return out;
        }
    };
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
    let columns: Vec<(String, millcomp_doe::Column)> = table
        .columns
        .iter()
        .map(|c| {
            let col = match &c.data {
                ColumnData::Float(v) => millcomp_doe::Column::F64(v.clone()),
                ColumnData::Int(v) => {
                    millcomp_doe::Column::F64(v.iter().map(|&x| x as f64).collect())
                }
                ColumnData::Text(v) => millcomp_doe::Column::Str(v.clone()),
            };
            (c.name.clone(), col)
        })
        .collect();
    let mut full = factors.join(" + ");
    if n_ctrl > 1 {
        for f in factors.iter().skip(1) {
            full.push_str(&format!(" + controller:{f}"));
        }
    }
    let main = factors.join(" + ");
    for metric in METRICS {
        let attempt = |formula: &str| -> anyhow::Result<AnovaEntry> {
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
                        "{metric}: controller interactions not estimable ({e1:#}); main effects only"
                    ));
                    out.insert(metric.to_string(), e);
                }
                Err(e2) => notes.push(format!("{metric}: no analysis ({e2:#})")),
            },
        }
    }
    out
}

/// Plots: each metric by controller (sorted values over the scenarios), and the peak-to-peak error by
/// each varying factor (mean per level and controller).
pub fn plots(plan: &Plan, records: &[RunRecord], dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut files = Vec::new();
    for metric in METRICS.iter().filter(|m| **m != "solver_fallbacks") {
        let series: Vec<Series> = plan
            .controllers
            .iter()
            .map(|c| {
                let mut v: Vec<f64> = records
                    .iter()
                    .filter(|r| &r.controller == c)
                    .filter_map(|r| r.metrics.get(metric))
                    .collect();
                v.sort_by(f64::total_cmp);
                let n = v.len().max(1) as f64;
                Series {
                    label: c.clone(),
                    points: v
                        .iter()
                        .enumerate()
                        .map(|(i, y)| ((i as f64 + 0.5) / n, *y))
                        .collect(),
                }
            })
            .collect();
        let path = dir.join(format!("{metric}_by_controller.svg"));
        line_plot(
            &path,
            &format!("{metric} by controller (sorted over scenarios)"),
            "fraction of scenarios",
            metric,
            &series,
        )?;
        files.push(path);
    }
    for f in varying_factors(plan, records) {
        let label = is_label(plan, &f);
        let mut levels: Vec<FactorValue> = Vec::new();
        for s in &plan.scenarios {
            if let Some(v) = s.factors.get(&f)
                && !levels.contains(v)
            {
                levels.push(v.clone());
            }
        }
        levels.sort_by(|a, b| match (a, b) {
            (FactorValue::Num(x), FactorValue::Num(y)) => x.total_cmp(y),
            _ => a.text().cmp(&b.text()),
        });
        let x_of = |v: &FactorValue, i: usize| match v {
            FactorValue::Num(x) if !label => *x,
            _ => i as f64,
        };
        let series: Vec<Series> = plan
            .controllers
            .iter()
            .map(|c| Series {
                label: c.clone(),
                points: levels
                    .iter()
                    .enumerate()
                    .filter_map(|(i, lv)| {
                        let v: Vec<f64> = records
                            .iter()
                            .filter(|r| {
                                &r.controller == c
                                    && plan.scenarios[r.scenario].factors.get(&f) == Some(lv)
                            })
                            .map(|r| r.metrics.pp_error_um)
                            .collect();
                        (!v.is_empty())
                            .then(|| (x_of(lv, i), v.iter().sum::<f64>() / v.len() as f64))
                    })
                    .collect(),
            })
            .collect();
        let x_label = if label {
            format!(
                "{f} ({})",
                levels
                    .iter()
                    .enumerate()
                    .map(|(i, l)| format!("{i}={}", l.text()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        } else {
            f.clone()
        };
        let path = dir.join(format!("pp_error_um_by_{f}.svg"));
        line_plot(
            &path,
            &format!("mean pp_error_um by {f}"),
            &x_label,
            "pp_error_um",
            &series,
        )?;
        files.push(path);
    }
    Ok(files)
}

/// Writes `results.csv`, `results.parquet`, `summary.json` and `plots/` into `out`; returns the summary.
pub fn write_results(
    plan: &Plan,
    records: &[RunRecord],
    out: &Path,
    mut summary: BatchSummary,
) -> anyhow::Result<BatchSummary> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let table = results_table(plan, records)?;
    for name in ["results.csv", "results.parquet"] {
        let path = out.join(name);
        millcomp_datasets::write_table(&table, &path)
            .with_context(|| format!("writing {}", path.display()))?;
        summary.files.push(path.display().to_string());
    }
    summary.by_controller = by_controller(plan, records);
    summary.anova = anova(plan, records, &mut summary.notes);
    for p in plots(plan, records, &out.join("plots"))? {
        summary.files.push(p.display().to_string());
    }
    let path = out.join("summary.json");
    summary.files.push(path.display().to_string());
    millcomp_datasets::write_text_atomic(&path, &serde_json::to_string_pretty(&summary)?)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(summary)
}

/// An empty summary for `plan`.
pub fn new_summary(plan: &Plan, n_runs: usize, shard: Option<Shard>) -> BatchSummary {
    BatchSummary {
        fingerprint: plan.fingerprint.clone(),
        n_runs,
        n_runs_planned: plan.n_runs(),
        n_scenarios: plan.scenarios.len(),
        controllers: plan.controllers.clone(),
        shard,
        by_controller: BTreeMap::new(),
        anova: BTreeMap::new(),
        n_ran: 0,
        n_resumed: 0,
        simulated_s: 0.0,
        wall_clock_s: 0.0,
        throughput_per_core: None,
        threads: rayon::current_num_threads(),
        files: Vec::new(),
        notes: Vec::new(),
    }
}

/// `batch merge DIR... --out OUT`: joins the slices of one batch. Errors when the slices come from
/// different batches (fingerprints differ) or runs are missing.
pub fn merge(dirs: &[PathBuf], out: &Path) -> anyhow::Result<BatchSummary> {
    let start = std::time::Instant::now();
    let Some(first) = dirs.first() else {
        bail!("batch merge: give the slice directories to merge");
    };
    let plan = read_plan(first)?;
    let mut records: BTreeMap<usize, RunRecord> = BTreeMap::new();
    for d in dirs {
        let p = read_plan(d)?;
        if p.fingerprint != plan.fingerprint {
            bail!(
                "batch merge: {} is a slice of a different batch (fingerprint {}) than {} (fingerprint {}): \
                 merge only slices of one plan",
                d.display(),
                p.fingerprint,
                first.display(),
                plan.fingerprint
            );
        }
        let shard = read_shard(d).unwrap_or(Shard::ALL);
        for r in plan.shard_runs(shard) {
            if let Some(rec) = load_record(d, &plan, r) {
                records.entry(rec.run).or_insert(rec);
            }
        }
    }
    let missing: Vec<usize> = (0..plan.n_runs())
        .filter(|i| !records.contains_key(i))
        .collect();
    if !missing.is_empty() {
        bail!(
            "batch merge: {} of {} runs are missing (e.g. runs {:?}); run the missing shards (they resume) and merge again",
            missing.len(),
            plan.n_runs(),
            &missing[..missing.len().min(8)]
        );
    }
    let records: Vec<RunRecord> = records.into_values().collect();
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut summary = new_summary(&plan, records.len(), None);
    let plan_text = serde_json::to_string_pretty(&plan)?;
    millcomp_datasets::write_text_atomic(&out.join("plan.json"), &plan_text)?;
    summary = write_results(&plan, &records, out, summary)?;
    summary.wall_clock_s = start.elapsed().as_secs_f64();
    Ok(summary)
}
