//! `millcomp replay`: a commissioned bundle + a program + a recorded sensor log → the commands each
//! controller would have sent (docs/replay.md). The loop is the runtime's
//! ([`millcomp_runtime::replay::replay`]), the one the Python package calls and the C ABI's program is
//! checked against. Not `millcomp_mpc::replay`, which re-solves recorded QPs for the solver bench.

use std::path::Path;

use anyhow::Context;
use millcomp_datasets::contracts::read_sensor_log;
use millcomp_datasets::contracts::{CommandColumns, commands_table};
use millcomp_datasets::table::TableFormat;
use millcomp_runtime::replay::{StepTimes, columns, measurements, replay};
use millcomp_runtime::{Command, Controller, ControllerKind, CycleCounts, Origins, Program, flags};
use serde_json::json;

use crate::cli::ReplayArgs;
use crate::cmd::guard::Inputs;
use crate::cmd::print_json;

/// One controller's replay.
struct Run {
    kind: ControllerKind,
    commands: Vec<Command>,
    times: StepTimes,
    counts: CycleCounts,
}

pub fn run(args: ReplayArgs, json: bool) -> anyhow::Result<()> {
    Inputs::new()
        .add("BUNDLE", &args.bundle)
        .add("PROGRAM", &args.program)
        .add("LOG", &args.log)
        .check_opt("--out", args.out.as_deref())?;
    if let Some(out) = &args.out {
        format_of(out)?;
    }
    let program = Program::load(&args.program)?;
    let bundle = millcomp_runtime::load_bundle(&args.bundle)?;
    let log = read_sensor_log(&args.log)?;
    log.check_rate(&args.log.display().to_string(), program.controller.dt_s)?;
    let kinds: Vec<ControllerKind> = match &args.controllers {
        None => vec![program.controller.kind],
        Some(list) => list
            .split(',')
            .map(|s| s.trim().parse::<ControllerKind>())
            .collect::<Result<_, _>>()
            .map_err(|e| anyhow::anyhow!("--controllers: {e}"))?,
    };
    let measurements = measurements(&log.x_mm, &log.force_n, &log.gauge_um);
    let origins = Origins {
        bundle: args.bundle.clone(),
        program: args.program.clone(),
    };
    let mut runs = Vec::with_capacity(kinds.len());
    for kind in kinds {
        let mut p = program.clone();
        p.controller.kind = kind;
        let mut ctl = Controller::from_bundle_at(&bundle, &p, &origins)?;
        let r = replay(&mut ctl, &measurements);
        runs.push(Run {
            kind,
            times: r.step_times(),
            commands: r.commands,
            counts: ctl.counts(),
        });
    }
    if let Some(out) = &args.out {
        let runs: Vec<CommandColumns> = runs
            .iter()
            .map(|r| command_columns(r.kind.name(), &r.commands))
            .collect();
        write_commands(out, &log.t_s, &runs)?;
    }
    if json {
        return print_json(&json!({
            "bundle": args.bundle.display().to_string(),
            "program": args.program.display().to_string(),
            "log": args.log.display().to_string(),
            "samples": log.len(),
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "controllers": runs.iter().map(|r| json!({
                "controller": r.kind.name(),
                "counts": r.counts,
                "step_times_ns": r.times,
                "voltage_v": { "min": min(&r.commands), "max": max(&r.commands), "last": r.commands.last().map(|c| c.voltage_v) },
            })).collect::<Vec<_>>(),
        }));
    }
    println!(
        "{}: {} samples at {} s through {} ({})",
        args.log.display(),
        log.len(),
        program.controller.dt_s,
        args.bundle.display(),
        args.program.display()
    );
    println!(
        "{:<14} {:>8} {:>9} {:>7} {:>8} {:>10} {:>10} {:>11} {:>11} {:>11}",
        "controller",
        "planned",
        "fallback",
        "held",
        "pos_mis",
        "v_min",
        "v_max",
        "step_med_us",
        "step_p99_us",
        "step_max_us"
    );
    for r in &runs {
        println!(
            "{:<14} {:>8} {:>9} {:>7} {:>8} {:>10.3} {:>10.3} {:>11.2} {:>11.2} {:>11.2}",
            r.kind.name(),
            r.counts.planned,
            r.counts.fallbacks,
            r.counts.readings_held,
            r.counts.position_mismatches,
            min(&r.commands),
            max(&r.commands),
            r.times.median_ns as f64 / 1e3,
            r.times.p99_ns as f64 / 1e3,
            r.times.max_ns as f64 / 1e3,
        );
    }
    if let Some(out) = &args.out {
        println!("commands: {}", out.display());
    }
    Ok(())
}

fn min(c: &[Command]) -> f64 {
    c.iter().map(|c| c.voltage_v).fold(f64::INFINITY, f64::min)
}

fn max(c: &[Command]) -> f64 {
    c.iter()
        .map(|c| c.voltage_v)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The format `--out` names: `.json`, or a table format (`.csv`, `.parquet`).
fn format_of(out: &Path) -> anyhow::Result<Option<TableFormat>> {
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    {
        return Ok(None);
    }
    TableFormat::from_path(out).map(Some).with_context(|| {
        format!(
            "--out {}: the extension says the format (.csv, .parquet or .json)",
            out.display()
        )
    })
}

/// One controller's commands as the commands table's columns.
pub fn command_columns(controller: &str, commands: &[Command]) -> CommandColumns {
    let (voltage_v, flags, iterations) = columns(commands);
    CommandColumns {
        controller: controller.to_string(),
        voltage_v,
        flags,
        iterations,
    }
}

/// The commands, one row per controller and sample (the contract's `COMMANDS_COLUMNS`): CSV or
/// Parquet (the table writer, by the extension) or JSON (`.json`: an array of rows, with `planned`);
/// written whole or not at all. `t_s` holds the samples' times. `millcomp simulate PROGRAM --bundle`
/// writes its commands here too.
pub fn write_commands(out: &Path, t_s: &[f64], runs: &[CommandColumns]) -> anyhow::Result<()> {
    let format = format_of(out)?;
    let table = commands_table(&out.display().to_string(), t_s, runs)?;
    if format.is_some() {
        millcomp_datasets::write_table(&table, out)?;
        return Ok(());
    }
    let mut doc: Vec<serde_json::Value> = Vec::with_capacity(table.n_rows());
    for r in runs {
        let rows = t_s
            .iter()
            .zip(&r.voltage_v)
            .zip(&r.flags)
            .zip(&r.iterations);
        for (k, (((t, v), f), i)) in rows.enumerate() {
            doc.push(json!({
                "controller": r.controller, "cycle": k, "t_s": t,
                "voltage_v": v, "flags": f, "iterations": i,
                "planned": f & flags::PLANNED != 0,
            }));
        }
    }
    millcomp_datasets::write_atomic(out, |f| serde_json::to_writer_pretty(f, &doc))?;
    Ok(())
}
