//! `millcomp batch`: every scenario × controller closed-loop run, in parallel, resumable and shardable;
//! `millcomp batch merge DIR...` joins the slices. The engine is in `src/batch/`.

use std::io::IsTerminal;

use anyhow::Context;

use crate::cli::{BatchArgs, BatchCommand};
use crate::cmd::print_json;

#[path = "../batch/mod.rs"]
pub mod engine;

use engine::exec::{MpcClosedLoop, run_shard};
use engine::output::{BatchSummary, merge, new_summary, write_results};
use engine::plan::Shard;

/// Runs the verb.
pub fn run(args: BatchArgs, json: bool) -> anyhow::Result<()> {
    if let Some(BatchCommand::Merge(m)) = &args.command {
        let summary = merge(&m.dirs, &m.out)?;
        return show(&summary, json, &format!("merged {} slices", m.dirs.len()));
    }
    let shard = match &args.shard {
        Some(s) => Shard::parse(s)?,
        None => Shard::from_env(|k| std::env::var(k).ok())?.unwrap_or(Shard::ALL),
    };
    let plan = engine::make_plan(
        args.scenarios.as_deref(),
        args.doe.as_deref(),
        &args.controllers,
    )?;
    let progress = !json && std::io::stderr().is_terminal();
    let outcome = with_threads(args.threads, || {
        run_shard(&plan, shard, &args.out, &MpcClosedLoop, progress)
    })?;
    let mut summary = new_summary(
        &plan,
        outcome.records.len(),
        (shard != Shard::ALL).then_some(shard),
    );
    summary.n_ran = outcome.n_ran;
    summary.n_resumed = outcome.n_resumed;
    summary.simulated_s = outcome.simulated_s;
    summary.threads = outcome.threads;
    summary.wall_clock_s = outcome.wall_clock_s;
    summary.throughput_per_core = (outcome.n_ran > 0 && outcome.wall_clock_s > 0.0)
        .then(|| outcome.simulated_s / outcome.wall_clock_s / outcome.threads.max(1) as f64);
    let summary = write_results(&plan, &outcome.records, &args.out, summary)?;
    let what = if shard == Shard::ALL {
        "batch".to_string()
    } else {
        format!("shard {}/{}", shard.index, shard.count)
    };
    show(&summary, json, &what)
}

/// Runs `f` on a rayon pool of `threads` workers (the global pool when `None`).
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> anyhow::Result<T> + Send,
) -> anyhow::Result<T> {
    match threads {
        None => f(),
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("building the worker pool")?
            .install(f),
    }
}

fn show(s: &BatchSummary, json: bool, what: &str) -> anyhow::Result<()> {
    if json {
        return print_json(s);
    }
    println!(
        "{what}: {} runs ({} run now, {} resumed) of {} planned   fingerprint {}",
        s.n_runs, s.n_ran, s.n_resumed, s.n_runs_planned, s.fingerprint
    );
    if let Some(t) = s.throughput_per_core {
        println!(
            "simulated {:.1} s of machining in {:.1} s on {} threads: {:.2} simulated s per wall s per core",
            s.simulated_s, s.wall_clock_s, s.threads, t
        );
    }
    println!("\nmedians by controller");
    let metrics = engine::exec::METRICS;
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
    if let Some(a) = s.anova.get("pp_error_um") {
        println!(
            "\nANOVA of pp_error_um   model: {}   R² = {:.4}",
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
    for n in &s.notes {
        println!("note: {n}");
    }
    println!();
    for f in &s.files {
        println!("written: {f}");
    }
    Ok(())
}
