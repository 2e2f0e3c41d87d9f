//! `millcomp simulate SESSION`: the groove session's profiles as the measured-groove CSV
//! (DESIGN.md contract), noise-free unless `--noise-seed` is given, plus an SVG plot.

use anyhow::{Context, bail};
use millcomp_datasets::contracts::measured_groove_table;
use millcomp_sim::sensors::NoiseSpec;
use millcomp_sim::session::{GroovePoint, Session, SimOptions, groove_summaries, simulate_session};
use serde_json::json;

use std::path::Path;

use millcomp_closedloop::{ControllerKind, Scenario, run_scenario_with_trace};

use millcomp_datasets::contracts::{SensorLog, sensor_log_table};
use millcomp_datasets::{TableFormat, write_table};
use millcomp_runtime::record::{SimulatedMachine, record};
use millcomp_runtime::{Controller, Origins, Program, load_bundle};

use crate::cli::SimulateArgs;
use crate::cmd::guard::{Inputs, same_file, with_scenario_models};
use crate::cmd::print_json;
use crate::cmd::replay::{command_columns, write_commands};
use crate::present::plot::{Series, line_plot};

// profilometer noise used with `--noise-seed` (sim's, 002_…txt §7.2/§7.9)
use millcomp_sim::sensors::PROFILOMETER_SIGMA_UM;

pub fn run(args: SimulateArgs, json: bool) -> anyhow::Result<()> {
    if let Some(bundle) = &args.bundle {
        return run_program(&args, bundle, json);
    }
    if args.controller.is_some() || is_scenario(&args.file)? {
        return run_scenario(&args, json);
    }
    check_outputs(&args, Inputs::new().add("FILE", &args.file))?;
    let session = Session::from_path(&args.file)
        .with_context(|| format!("reading session {}", args.file.display()))?;
    let options = SimOptions {
        noise: args.noise_seed.map(|seed| NoiseSpec {
            seed,
            sigma: PROFILOMETER_SIGMA_UM,
        }),
    };
    let points = simulate_session(&session, &options)
        .with_context(|| format!("simulating {}", args.file.display()))?;
    if points.is_empty() {
        bail!(
            "{}: the session plan measures no points",
            args.file.display()
        );
    }
    let table = measured_groove_table(&session.name, &points)?;
    if let Some(out) = &args.out {
        // always CSV (the help's "Output CSV"), whatever the extension
        millcomp_datasets::write_atomic(out, |f| {
            millcomp_datasets::write_csv_to(&table, f).map_err(|e| e.to_string())
        })
        .with_context(|| format!("writing {}", out.display()))?;
    }
    if let Some(plot) = &args.plot {
        plot_profiles(plot, &session.name, &points)?;
    }
    let summary = groove_summaries(&points);
    if json {
        return print_json(&json!({
            "session": session.name,
            "n_points": points.len(),
            "noise_sigma_um": options.noise.map(|n| n.sigma),
            "grooves": summary,
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "plot": args.plot.as_ref().map(|p| p.display().to_string()),
        }));
    }
    if args.out.is_none() {
        millcomp_datasets::write_csv_to(&table, std::io::stdout().lock())?;
        return Ok(());
    }
    println!("session {}: {} points", session.name, points.len());
    println!(
        "{:>6} {:>7} {:>12} {:>16} {:>16}",
        "groove", "points", "t_start_s", "max_error_um", "mean_error_um"
    );
    for g in &summary {
        println!(
            "{:>6} {:>7} {:>12.1} {:>16.3} {:>16.3}",
            g.groove_id, g.n_points, g.t_start_s, g.max_error_um, g.mean_error_um
        );
    }
    if let Some(out) = &args.out {
        println!("written: {}", out.display());
    }
    if let Some(plot) = &args.plot {
        println!("plot: {}", plot.display());
    }
    Ok(())
}

/// `--out` and `--plot` are neither an input nor each other.
fn check_outputs(args: &SimulateArgs, inputs: Inputs) -> anyhow::Result<()> {
    inputs.check_opt("--out", args.out.as_deref())?;
    inputs.check_opt("--plot", args.plot.as_deref())?;
    if let (Some(o), Some(p)) = (&args.out, &args.plot)
        && same_file(o, p)
    {
        bail!("--out and --plot name the same file {}", o.display());
    }
    Ok(())
}

fn plot_profiles(path: &std::path::Path, name: &str, points: &[GroovePoint]) -> anyhow::Result<()> {
    let mut ids: Vec<i64> = points.iter().map(|p| p.groove_id).collect();
    ids.sort_unstable();
    ids.dedup();
    let mut series = Vec::new();
    for id in ids {
        let g: Vec<&GroovePoint> = points.iter().filter(|p| p.groove_id == id).collect();
        series.push(Series {
            label: format!("groove {id} programmed"),
            points: g.iter().map(|p| (p.x_mm, -p.depth_cmd_um)).collect(),
        });
        series.push(Series {
            label: format!("groove {id} simulated"),
            points: g.iter().map(|p| (p.x_mm, -p.depth_meas_um)).collect(),
        });
    }
    line_plot(
        path,
        &format!("Groove profiles — session {name}"),
        "x along the groove (mm)",
        "groove bottom (um, 0 = surface)",
        &series,
    )
}

/// A closed-loop scenario file has a top-level `stage` key (`closedloop/SCENARIOS.md`); a session has a
/// `plan` (`sim/SESSION.md`).
fn is_scenario(path: &Path) -> anyhow::Result<bool> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let doc: toml::Table =
        toml::from_str(&text).with_context(|| format!("{}: not valid TOML", path.display()))?;
    Ok(doc.contains_key("stage"))
}

/// `simulate SCENARIO --controller K`: one closed-loop run on the truth plant of the scenario.
fn run_scenario(args: &SimulateArgs, json: bool) -> anyhow::Result<()> {
    let mut scenario = Scenario::load(&args.file)?;
    check_outputs(
        args,
        with_scenario_models(Inputs::new().add("FILE", &args.file), &scenario),
    )?;
    scenario.control.realtime = !args.no_realtime;
    if args.budget_fraction.is_some() {
        scenario.control.budget_fraction = args.budget_fraction;
    }
    let name = args.controller.as_deref().unwrap_or("none");
    let kind: ControllerKind = name.parse().context("--controller")?;
    let out = run_scenario_with_trace(&scenario, kind)
        .with_context(|| format!("{}: closed-loop run with `{name}`", args.file.display()))?;
    if let Some(path) = &args.out {
        let mut text = out.trace.columns.join(",");
        text.push('\n');
        for row in &out.trace.rows {
            let cells: Vec<String> = row.iter().map(|v| format!("{v}")).collect();
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        millcomp_datasets::write_text_atomic(path, &text)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(plot) = &args.plot {
        let x = out.trace.column("x_mm").unwrap_or_default();
        let mut series = Vec::new();
        for col in ["error_um", "depth_error_um", "thickness_error_um"] {
            if let Some(y) = out.trace.column(col) {
                series.push(Series {
                    label: format!("{col} ({name})"),
                    points: x.iter().copied().zip(y).collect(),
                });
            }
        }
        if series.is_empty() {
            bail!(
                "the run's trace has no error column to plot (columns: {})",
                out.trace.columns.join(", ")
            );
        }
        let y_label = if out.report.nc_axis.is_some() {
            "wall displacement (um, + = material left, - = undersize)"
        } else {
            "error (um, + = too deep)"
        };
        line_plot(
            plot,
            &format!("{} — {}", scenario.name, name),
            "x (mm)",
            y_label,
            &series,
        )?;
    }
    if json {
        return print_json(&out.report);
    }
    let m = &out.report.metrics;
    println!(
        "scenario {} ({}), controller {}",
        out.report.scenario, out.report.stage, out.report.controller
    );
    println!(
        "peak-to-peak error {:.3} um   rms {:.3} um   max {:.3} um   min {:.3} um   actuator travel {:.2} um",
        m.pp_error_um, m.rms_error_um, m.max_error_um, m.min_error_um, m.actuator_travel_um
    );
    if let Some(p) = out.report.process_change_peak_um {
        println!(
            "process changes: peak |error| {p:.3} um (0.5 mm before to 2 mm after each change)"
        );
    }
    for c in &out.report.changes {
        let bound = c
            .bound_um
            .map(|b| format!(" (no controller below {b:.3} um)"))
            .unwrap_or_default();
        let level = c
            .level_before_um
            .zip(c.level_change_um())
            .map(|(b, l)| format!(", {l:.3} um of it the level change from {b:.3} um before"))
            .unwrap_or_default();
        println!(
            "change ({} at {:.2} mm): excess {:.3} um over the settled error {:.3} um{level}{bound}",
            c.kind.name(),
            c.x_mm,
            c.excess_um,
            c.settled_um
        );
    }
    if let Some(b) = m.stroke_bound_um.filter(|b| *b > 0.0) {
        println!(
            "stroke bound: {b:.3} um peak-to-peak (the deflection met exceeds the PZT's range in z by this much)"
        );
    }
    // On the NC stage `optimum_pp_um` is the certainty-equivalent wall's peak-to-peak, a reference
    // and not a bound; the wall block below prints it with its own wording.
    if let Some(o) = m.optimum_pp_um.filter(|_| out.report.nc_axis.is_none()) {
        println!(
            "optimum: {o:.3} um peak-to-peak (the best static plan within the stroke, deflection seen through the commissioned model; noise-free)"
        );
    }
    if let Some(t) = &out.report.touch_off {
        println!(
            "touch-off: with the stack held at {:.0} V (gauge {:.2} um), so the tip can retract below the depth's zero",
            t.bias_v, t.gauge_um
        );
    }
    if let Some(o) = m.exit_overcut_um {
        println!("workpiece exit: largest overcut {o:.3} um (+ = deeper than programmed)");
    }
    if let (Some(tip), Some(g)) = (m.exit_floor_tip_um, scenario.groove.as_ref()) {
        let z = tip * g.tilt_deg.to_radians().sin();
        println!(
            "workpiece exit: the command reached the amplifier's floor with the PZT tip still {tip:.2} um out ({z:.2} um of depth no command can retract)"
        );
    }
    if let Some(nc) = &out.report.nc_axis {
        crate::present::nc_axis::print_wall(nc);
    }
    if let Some(s) = &out.report.solver {
        println!(
            "solver: {} solves, cycle time median {:.1} us, p99 {:.1} us, max {:.1} us (budget {:.0} us {}, {} deadline misses), {} fallbacks; {}",
            s.solves,
            s.median_us,
            s.p99_us,
            s.max_us,
            s.budget_us,
            if s.budget_enforced {
                "enforced"
            } else {
                "timed only"
            },
            s.deadline_misses,
            s.fallbacks,
            if out.report.realtime {
                "real-time priority"
            } else {
                "normal priority"
            }
        );
    }
    if let Some(walls) = &out.report.walls {
        for w in walls {
            println!("{}", serde_json::to_string(w)?);
        }
    }
    if let Some(p) = &args.out {
        println!("written: {}", p.display());
    }
    if let Some(p) = &args.plot {
        println!("plot: {}", p.display());
    }
    Ok(())
}

/// `simulate PROGRAM --bundle B`: the program's controller, built from the bundle by the runtime (the
/// code a machine calls), on the simulated machine; the sensor log it read and the commands it sent.
fn run_program(args: &SimulateArgs, bundle_path: &Path, json: bool) -> anyhow::Result<()> {
    if let Some(flag) = [
        ("--controller", args.controller.is_some()),
        ("--plot", args.plot.is_some()),
        ("--budget-fraction", args.budget_fraction.is_some()),
        ("--no-realtime", args.no_realtime),
    ]
    .iter()
    .find_map(|(flag, set)| set.then_some(flag))
    {
        bail!(
            "{flag} does not apply to a program run (--bundle): the program file names the controller and its budget"
        );
    }
    let inputs = Inputs::new()
        .add("FILE", &args.file)
        .add("--bundle", bundle_path);
    inputs.check_opt("--out", args.out.as_deref())?;
    inputs.check_opt("--sensor-log", args.sensor_log.as_deref())?;
    if let (Some(o), Some(l)) = (&args.out, &args.sensor_log)
        && same_file(o, l)
    {
        bail!("--out and --sensor-log name the same file {}", o.display());
    }
    if let Some(log) = &args.sensor_log {
        TableFormat::from_path(log)
            .with_context(|| format!("--sensor-log {}: .csv or .parquet", log.display()))?;
    }
    let program = Program::load(&args.file)?;
    let bundle = load_bundle(bundle_path)?;
    let origins = Origins {
        bundle: bundle_path.to_path_buf(),
        program: args.file.clone(),
    };
    let mut ctl = Controller::from_bundle_at(&bundle, &program, &origins)?;
    let steps = match args.steps {
        Some(n) => n,
        None => (program.program.groove_program().duration_s() / ctl.period_s()).ceil() as usize,
    };
    let machine = SimulatedMachine::with_seed(args.noise_seed.unwrap_or(7));
    let run = record(&mut ctl, &program, &machine, steps)
        .with_context(|| format!("simulating {}", args.file.display()))?;
    let t_s: Vec<f64> = (0..run.log.len())
        .map(|k| k as f64 * run.period_s)
        .collect();
    if let Some(path) = &args.sensor_log {
        let log = SensorLog {
            t_s: t_s.clone(),
            x_mm: run.log.iter().map(|m| m.x_mm).collect(),
            force_n: run.log.iter().map(|m| m.force_n).collect(),
            gauge_um: run.log.iter().map(|m| m.gauge_um).collect(),
        };
        write_table(&sensor_log_table(&path.display().to_string(), &log)?, path)?;
    }
    if let Some(out) = &args.out {
        write_commands(
            out,
            &t_s,
            &[command_columns(ctl.kind().name(), &run.commands)],
        )?;
    }
    let counts = ctl.counts();
    let v_max = run
        .commands
        .iter()
        .map(|c| c.voltage_v)
        .fold(f64::NEG_INFINITY, f64::max);
    if json {
        return print_json(&json!({
            "program": args.file.display().to_string(),
            "bundle": bundle_path.display().to_string(),
            "controller": ctl.kind().name(),
            "samples": run.log.len(),
            "period_s": run.period_s,
            "noise_seed": machine.force_noise.map(|n| n.seed),
            "counts": counts,
            "voltage_max_v": v_max,
            "sensor_log": args.sensor_log.as_ref().map(|p| p.display().to_string()),
            "out": args.out.as_ref().map(|p| p.display().to_string()),
        }));
    }
    println!(
        "{}: {} cycles of {} at {} s on the simulated machine (S7, noise seed {})",
        args.file.display(),
        run.log.len(),
        ctl.kind().name(),
        run.period_s,
        machine.force_noise.map_or(0, |n| n.seed)
    );
    println!(
        "planned {}, fallbacks {}, readings held {}, position mismatches {}, largest command {v_max:.3} V",
        counts.planned, counts.fallbacks, counts.readings_held, counts.position_mismatches
    );
    if let Some(p) = &args.sensor_log {
        println!("sensor log: {}", p.display());
    }
    if let Some(p) = &args.out {
        println!("commands: {}", p.display());
    }
    Ok(())
}
