//! `millcomp demo` and `millcomp pipeline PLAN.toml`: the main job end to end (`millcomp-pipeline`) —
//! on the simulated machine, or on a user's files — and its report. This module only parses, calls the
//! library and prints.

use std::io::IsTerminal;
use std::path::Path;

use anyhow::Context;
use millcomp_pipeline::plan::Plan;
use millcomp_pipeline::{Options, Outcome, StageStatus};
use serde_json::json;

use crate::cli::{DemoArgs, PipelineArgs};
use crate::cmd::print_json;

/// The command line as typed (for the report and the models' provenance).
fn command_line() -> String {
    crate::cmd::provenance(Vec::new()).command
}

fn options(out: &Path, threads: Option<usize>, json: bool) -> Options {
    let mut o = Options::new(out.to_path_buf());
    o.threads = threads;
    o.command = command_line();
    o.progress_bar = !json && std::io::stderr().is_terminal();
    o
}

fn progress(json: bool) -> impl Fn(&str) + Sync {
    let show = !json && std::io::stderr().is_terminal();
    move |stage: &str| {
        if show {
            eprintln!("… {stage}");
        }
    }
}

fn print(out: &Path, o: &Outcome, json: bool) -> anyhow::Result<()> {
    if json {
        return print_json(&json!({
            "headline": o.headline,
            "stages": o.stages,
            "report": "report.md",
            "report_html": "report.html",
            "out": out.display().to_string(),
            "wall_clock_s": o.wall_clock_s,
        }));
    }
    println!("{}", o.headline);
    println!();
    for (i, s) in o.stages.iter().enumerate() {
        let status = match s.status {
            StageStatus::Ok => "ok",
            StageStatus::Skipped => "skipped",
        };
        println!("{:>2} {:<18} {status}", i + 1, s.name);
        println!("   {}", s.summary);
    }
    println!();
    println!(
        "report: {}, {} (stage chain: {}; {:.0} s)",
        o.report_md.display(),
        o.report_html.display(),
        o.chain_json.display(),
        o.wall_clock_s
    );
    Ok(())
}

/// `millcomp demo`.
pub fn run(args: DemoArgs, json: bool) -> anyhow::Result<()> {
    let plan = if args.quick {
        Plan::quick_demo(args.seed)
    } else {
        Plan::demo(args.seed)
    };
    let opts = options(&args.out, args.threads, json);
    let o = millcomp_pipeline::run(&plan, &opts, &progress(json))
        .with_context(|| format!("demo into {}", args.out.display()))?;
    print(&args.out, &o, json)
}

/// `millcomp pipeline PLAN.toml`.
pub fn run_plan(args: PipelineArgs, json: bool) -> anyhow::Result<()> {
    let plan = Plan::load(&args.plan)?;
    let opts = options(&args.out, args.threads, json);
    let o = millcomp_pipeline::run(&plan, &opts, &progress(json))
        .with_context(|| format!("pipeline {}", args.plan.display()))?;
    print(&args.out, &o, json)
}
