//! Batch results for people: the plots of a batch (each metric by controller, the peak-to-peak error by
//! each varying factor) and the text summary `millcomp batch` prints. The numbers come from
//! `millcomp_closedloop::batch`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use millcomp_closedloop::batch::exec::{METRICS, RunRecord};
use millcomp_closedloop::batch::factors::FactorValue;
use millcomp_closedloop::batch::plan::Plan;
use millcomp_closedloop::batch::results::{
    BatchSummary, is_label, varying_factors, write_summary, write_tables,
};

use crate::present::plot::{Series, line_plot};

/// Writes the results of a batch into `out`: the tables, the plots (`out/plots/`), `summary.json` and
/// `invocation.json`, whose `files` lists them in that order.
pub fn write_results(
    plan: &Plan,
    records: &[RunRecord],
    out: &Path,
    summary: BatchSummary,
) -> anyhow::Result<BatchSummary> {
    let mut summary = write_tables(plan, records, out, summary)?;
    for p in plots(plan, records, &out.join("plots"))? {
        summary.invocation.files.push(p.display().to_string());
    }
    Ok(write_summary(out, summary)?)
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
        if series.iter().all(|s| s.points.is_empty()) {
            continue; // no run has this metric (a change excess without a change)
        }
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

/// Prints the summary of a batch (`what`: `batch`, `shard K/N`, `merged N slices`): runs, throughput,
/// the medians by controller, the ANOVA of the peak-to-peak error, notes and the files written.
pub fn print_summary(summary: &BatchSummary, what: &str) {
    let (s, i) = (&summary.results, &summary.invocation);
    println!(
        "{what}: {} runs ({} run now, {} resumed) of {} planned   fingerprint {}",
        s.n_runs, i.n_ran, i.n_resumed, s.n_runs_planned, s.fingerprint
    );
    if let Some(t) = i.throughput_per_core {
        println!(
            "simulated {:.1} s of machining in {:.1} s on {} threads: {:.2} simulated s per wall s per core",
            i.simulated_s, i.wall_clock_s, i.threads, t
        );
    }
    println!("\nmedians by controller");
    let metrics = METRICS;
    print!("{:<12}", "controller");
    for m in metrics {
        print!(" {m:>19}");
    }
    println!();
    for (c, m) in &s.by_controller {
        print!("{c:<12}");
        for k in metrics {
            print!(" {:>19.4}", m.get(k).copied().unwrap_or(f64::NAN));
        }
        println!();
    }
    for (c, t) in &i.solve_times_us {
        println!(
            "{c:<12} QP solve: median {:.1} us over {} runs, largest p99 {:.1} us",
            t.median_us, t.runs, t.p99_max_us
        );
    }
    for (metric, a) in ["pp_error_um", "change_excess_um"]
        .iter()
        .filter_map(|m| s.anova.get(*m).map(|a| (m, a)))
    {
        println!(
            "\nANOVA of {metric}   model: {}   R² = {:.4}",
            a.model, a.r_squared
        );
        println!(
            "{:<32} {:>12} {:>4} {:>14} {:>10} {:>10}",
            "term", "effect", "df", "sum sq", "F", "p-value"
        );
        for t in &a.terms {
            let opt = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |x| format!("{x:.p$}"));
            let star = match t.p_value {
                Some(p) if p < 0.001 => " ***",
                Some(p) if p < 0.01 => " **",
                Some(p) if p < 0.05 => " *",
                _ => "",
            };
            println!(
                "{:<32} {:>12} {:>4} {:>14.6} {:>10} {:>10}{star}",
                t.term,
                opt(t.effect, 5),
                t.df,
                t.sum_sq,
                opt(t.f, 3),
                opt(t.p_value, 6)
            );
        }
    }
    for p in &s.paired {
        let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.2e}"));
        println!(
            "\n{} − {} on {} ({} scenarios): median {:+.3} um [{:+.3}, {:+.3}], mean {:+.3} um, better in {}, worse in {}; paired t p = {}, sign test p = {}",
            p.controller,
            p.reference,
            p.metric,
            p.n,
            p.median_diff,
            p.ci95[0],
            p.ci95[1],
            p.mean_diff,
            p.better,
            p.worse,
            opt(p.t_p_value),
            opt(p.sign_p_value)
        );
        let no_help: Vec<String> = p
            .by_level
            .iter()
            .filter(|l| l.median_diff >= 0.0)
            .map(|l| {
                format!(
                    "{}={} ({:+.3}, n {})",
                    l.factor, l.level, l.median_diff, l.n
                )
            })
            .collect();
        let split: Vec<String> = p
            .by_level
            .iter()
            .filter(|l| l.factor == "stroke")
            .map(|l| {
                format!(
                    "stroke {} ({} scenarios) {:+.3}",
                    l.level, l.n, l.median_diff
                )
            })
            .collect();
        if !split.is_empty() {
            println!(
                "  median difference where the reference's {}",
                split.join(", ")
            );
        }
        if !no_help.is_empty() {
            println!(
                "  does not help (median difference >= 0) at: {}",
                no_help.join(", ")
            );
        }
    }
    for n in &s.notes {
        println!("note: {n}");
    }
    println!();
    for f in &i.files {
        println!("written: {f}");
    }
}
