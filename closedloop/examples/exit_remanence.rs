//! What sets the commissioned exit's overcut (issue 14): for each seed, the MPC (or `--controller`) on
//! the commissioned `groove_s7_20deg_exit` with its hysteretic stack and with a linear stack (the same
//! drawn instruments and tool) — from each run's report: the settled error before the exit, the exit's
//! excess over it (the largest |error − settled| from 1 mm before the engagement drops), the overcut,
//! and where the tip stayed while the command sat at the amplifier's 0 V floor during the drop
//! (`exit_floor_tip_um`); beside it, what the controllers' identified hysteresis model (the
//! Prandtl–Ishlinskii fit of the commissioning sweep) predicts the tip to be at 0 V after a rise to
//! 800 V and back.
//!
//! `cargo run --release -p millcomp-closedloop --example exit_remanence -- [--seeds N] [--controller NAME]`

use millcomp_closedloop::changes::ChangeKind;
use millcomp_closedloop::compare::commissioned;
use millcomp_closedloop::groove::groove_setup;
use millcomp_closedloop::{ControllerKind, Scenario, run_scenario};

/// The exit's figures of one run, from its report (µm; `NaN` where the report has none).
struct ExitFigures {
    /// The exit's settled error and its excess over it (`changes`).
    settled: f64,
    excess: f64,
    /// `exit_overcut_um` and `exit_floor_tip_um`.
    overcut: f64,
    tip_at_floor: f64,
}

fn exit_figures(
    s: &Scenario,
    kind: ControllerKind,
) -> Result<ExitFigures, Box<dyn std::error::Error>> {
    let r = run_scenario(s, kind)?;
    let exit = r.changes.iter().find(|c| c.kind == ChangeKind::Exit);
    Ok(ExitFigures {
        settled: exit.map_or(f64::NAN, |c| c.settled_um),
        excess: exit.map_or(f64::NAN, |c| c.excess_um),
        overcut: r.metrics.exit_overcut_um.unwrap_or(f64::NAN),
        tip_at_floor: r.metrics.exit_floor_tip_um.unwrap_or(f64::NAN),
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
        "| seed | settled before the exit (µm) | exit excess over it | exit overcut | tip at 0 V (µm) | of depth | identified model's tip at 0 V | linear stack: excess | overcut |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for seed in 1..=seeds {
        let mut s = base.clone();
        s.seed = seed;
        let h = exit_figures(&s, kind)?;
        let predicted = predicted_remanence_um(&s)?;
        s.truth.pzt_nonlinear = false;
        let l = exit_figures(&s, kind)?;
        println!(
            "| {seed} | {:+.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            h.settled,
            h.excess,
            h.overcut,
            h.tip_at_floor,
            h.tip_at_floor * sin_a,
            predicted,
            l.excess,
            l.overcut
        );
    }
    Ok(())
}
