//! `millcomp parts SCENARIO`: successive parts on each of N machines, each part measured and the
//! controllers' deflection model re-identified before the next (`millcomp_closedloop::parts`).

use anyhow::Context;
use millcomp_closedloop::Scenario;
use millcomp_closedloop::batch::plan::parse_controllers;
use millcomp_closedloop::parts::{PartsPlan, rows_table, run_parts, summarize};
use millcomp_closedloop::scenario::ControllerKind;
use rayon::prelude::*;
use serde_json::json;

use crate::cli::PartsArgs;
use crate::cmd::batch::with_threads;
use crate::cmd::guard::{Inputs, with_scenario_models};
use crate::cmd::{print_json, progress_bar};
use crate::present::parts::{parts_plot, parts_text};

pub fn run(args: PartsArgs, json: bool) -> anyhow::Result<()> {
    let s = Scenario::load(&args.scenario)?;
    with_scenario_models(Inputs::new().add("SCENARIO", &args.scenario), &s).check_dir(
        "--out",
        &args.out,
        |rel| {
            ["parts.csv", "summary.json", "parts.svg"]
                .iter()
                .any(|n| rel == std::path::Path::new(n))
        },
    )?;
    let controllers: Vec<ControllerKind> = parse_controllers(&args.controllers)?
        .iter()
        .map(|n| n.parse())
        .collect::<Result<_, _>>()?;
    if args.seeds == 0 {
        anyhow::bail!("--seeds: give at least 1 machine");
    }
    let plan = PartsPlan {
        parts: args.parts,
        force_error_rel: args.force_error,
        stiffness_error_rel: args.stiffness_error,
        part_force_scatter: args.part_scatter,
        ..PartsPlan::default()
    };
    plan.validate()?;
    let total = args.seeds * (controllers.len() as u64 + 1) * args.parts as u64;
    let bar = progress_bar(total, "parts", json);
    let runs = with_threads(args.threads, || {
        (1..=args.seeds)
            .into_par_iter()
            .map(|seed| run_parts(&s, &controllers, &plan, seed, &|| bar.inc(1)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::from)
    })?;
    bar.finish_and_clear();
    let summary = summarize(&runs);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let csv = args.out.join("parts.csv");
    millcomp_datasets::write_table(&rows_table(&runs)?, &csv)
        .with_context(|| format!("writing {}", csv.display()))?;
    let doc = json!({
        "scenario": s.name,
        "machines": args.seeds,
        "plan": plan,
        "summary": summary,
        "runs": runs,
    });
    millcomp_datasets::write_text_atomic(
        &args.out.join("summary.json"),
        &serde_json::to_string_pretty(&doc)?,
    )?;
    parts_plot(&args.out.join("parts.svg"), &s.name, &summary)?;
    if json {
        return print_json(&doc);
    }
    print!("{}", parts_text(&s.name, args.seeds, &summary));
    println!(
        "wrote {} (every part), {} and {}",
        csv.display(),
        args.out.join("summary.json").display(),
        args.out.join("parts.svg").display()
    );
    Ok(())
}
