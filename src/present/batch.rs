//! Batch results for people: the text summary `millcomp batch` prints and its `--dry-run` estimate.
//! The numbers, the tables and the plots come from `millcomp_closedloop::batch`.

use millcomp_closedloop::batch::Estimate;
use millcomp_closedloop::batch::exec::METRICS;
use millcomp_closedloop::batch::plan::{Plan, Shard};
use millcomp_closedloop::batch::progress::duration;
use millcomp_closedloop::batch::results::BatchSummary;

/// Prints what a plan will cost (`batch --dry-run`).
pub fn print_estimate(plan: &Plan, e: &Estimate, shard: Shard) {
    let what = if shard == Shard::ALL {
        "batch".to_string()
    } else {
        format!("shard {}/{}", shard.index, shard.count)
    };
    println!(
        "{what}: {} runs ({} scenarios × {} controllers in the plan), {} finished already   fingerprint {}",
        e.runs,
        plan.scenarios.len(),
        plan.controllers.len(),
        e.finished,
        plan.fingerprint
    );
    println!(
        "to run: {} runs on {} scenarios, {:.0} s of machining; {} commissionings ({} in the cache)",
        e.runs - e.finished,
        e.scenarios,
        e.simulated_s,
        e.commissionings,
        e.commissionings_cached
    );
    println!(
        "estimate: {:.0} core-s, about {} on {} threads (from the per-controller costs measured on the reference machine: 2 cores, AMD EPYC)",
        e.core_s,
        duration(e.wall_s),
        e.threads
    );
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
    for f in &s.failed {
        println!(
            "failed: run {} (scenario {}, row {}), controller {}: {}",
            f.run,
            f.scenario,
            f.scenario + 1,
            f.controller,
            f.reason
        );
    }
    println!();
    for f in &i.files {
        println!("written: {f}");
    }
}
