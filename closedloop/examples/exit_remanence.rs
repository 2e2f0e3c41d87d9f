//! What sets the commissioned exit's overcut (issue 14): for each seed, the MPC (or `--controller`) on the commissioned
//! `groove_s7_20deg_exit` with its hysteretic stack and with a linear stack (the same drawn instruments
//! and tool) — the settled error before the exit, the largest error over the drop (where the cutter
//! leaves, 9.79–10 mm), their difference, where the tip stays when the command is at the amplifier's
//! 0 V floor, and the run's exit excess and overcut; beside it, what the controllers' identified
//! hysteresis model (the Prandtl–Ishlinskii fit of the commissioning sweep) predicts the tip to be at
//! 0 V after a rise to 800 V and back.
//!
//! `cargo run --release -p millcomp-closedloop --example exit_remanence -- [--seeds N] [--controller NAME]`

use millcomp_closedloop::changes::ChangeKind;
use millcomp_closedloop::compare::commissioned;
use millcomp_closedloop::groove::groove_setup;
use millcomp_closedloop::{ControllerKind, Scenario, run_scenario_with_trace};

/// The exit's figures of one run (µm).
struct ExitFigures {
    /// Median error 7.5–9.5 mm (before the drop at 9.79 mm).
    settled: f64,
    /// Largest error over the drop (9.79 mm to the edge at 10 mm).
    after: f64,
    /// The run's `exit_floor_tip_um`, exit excess and overcut (its report).
    tip_at_floor: f64,
    excess: f64,
    overcut: f64,
}

/// Where the engagement starts to fall and the workpiece edge (mm): the scenario's exit.
const DROP_MM: f64 = 9.79;
const EDGE_MM: f64 = 10.0;

fn exit_figures(
    s: &Scenario,
    kind: ControllerKind,
) -> Result<ExitFigures, Box<dyn std::error::Error>> {
    let out = run_scenario_with_trace(s, kind)?;
    let col = |name: &str| {
        out.trace
            .columns
            .iter()
            .position(|c| c == name)
            .ok_or(format!("no trace column {name}"))
    };
    let (x, e) = (col("x_mm")?, col("error_um")?);
    let between = |a: f64, b: f64| {
        out.trace
            .rows
            .iter()
            .filter(move |r| r[x] >= a && r[x] < b)
            .map(move |r| r[e])
    };
    let mut settled: Vec<f64> = between(7.5, 9.5).collect();
    settled.sort_by(f64::total_cmp);
    let m = &out.report.metrics;
    Ok(ExitFigures {
        settled: settled.get(settled.len() / 2).copied().unwrap_or(f64::NAN),
        after: between(DROP_MM, EDGE_MM).fold(f64::NEG_INFINITY, f64::max),
        tip_at_floor: m.exit_floor_tip_um.unwrap_or(f64::NAN),
        excess: out
            .report
            .changes
            .iter()
            .find(|c| c.kind == ChangeKind::Exit)
            .map_or(f64::NAN, |c| c.excess_um),
        overcut: m.exit_overcut_um.unwrap_or(f64::NAN),
    })
}

/// The tip (µm) the controllers' identified hysteresis model predicts at 0 V after the stack rose to
/// 800 V (about the deep cut's command) and came back, in 1 V steps (`NaN` without a model).
fn predicted_remanence_um(s: &Scenario) -> Result<f64, Box<dyn std::error::Error>> {
    let setup = groove_setup(s)?;
    let Some(h) = setup.model_hysteresis.as_ref() else {
        return Ok(f64::NAN);
    };
    let mut op = h.operator().clone();
    for v in (0..=800).chain((0..800).rev()) {
        op.step(f64::from(v));
    }
    Ok(op.output())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut seeds = 10u64;
    let mut kind = ControllerKind::Mpc;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seeds" => seeds = args.next().ok_or("--seeds needs a value")?.parse()?,
            "--controller" => kind = args.next().ok_or("--controller needs a name")?.parse()?,
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    let base = commissioned(&Scenario::load(
        "datasets/scenarios/groove_s7_20deg_exit.toml",
    )?);
    let sin_a = 20f64.to_radians().sin();
    println!("controller {kind}\n");
    println!(
        "| seed | settled before the exit (µm) | largest in the drop | jump | tip at 0 V (µm) | of depth | identified model's tip at 0 V | exit excess | exit overcut | linear stack: jump | excess | overcut |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for seed in 1..=seeds {
        let mut s = base.clone();
        s.seed = seed;
        let h = exit_figures(&s, kind)?;
        let predicted = predicted_remanence_um(&s)?;
        s.truth.pzt_nonlinear = false;
        let l = exit_figures(&s, kind)?;
        println!(
            "| {seed} | {:+.2} | {:+.2} | {:+.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:+.2} | {:.2} | {:.2} |",
            h.settled,
            h.after,
            h.after - h.settled,
            h.tip_at_floor,
            h.tip_at_floor * sin_a,
            predicted,
            h.excess,
            h.overcut,
            l.after - l.settled,
            l.excess,
            l.overcut
        );
    }
    Ok(())
}
