//! What sets the commissioned exit's overcut (issue 14): for each seed, the MPC (or `--controller`) on
//! the commissioned `groove_s7_20deg_exit` with its hysteretic stack and with a linear stack (the same
//! drawn instruments and tool) — from each run's report: the settled error before the exit, the exit's
//! excess over it (the largest |error − settled| from 1 mm before the engagement drops), the overcut,
//! and where the tip stayed while the command sat at the amplifier's 0 V floor during the drop
//! (`exit_floor_tip_um`); beside it, what the controllers' identified hysteresis model (the
//! Prandtl–Ishlinskii fit of the commissioning sweep) predicts the tip to be at 0 V after a rise to
//! 800 V and back.
//!
//!
//! `--touch-off rest|auto|VOLTS` (default `rest`) touches the tool off with the stack at rest, at the
//! bias `touch_off::auto_bias` chooses, or at a given voltage; `--allowance F` runs `auto` with another
//! remanence allowance than [`REMANENCE_ALLOWANCE`] (the bias it gives is printed per seed).
//!
//! `cargo run --release -p millcomp-closedloop --example exit_remanence -- [--seeds N] [--controller NAME] [--touch-off rest|auto|VOLTS] [--allowance F]`

use millcomp_closedloop::changes::ChangeKind;
use millcomp_closedloop::compare::commissioned;
use millcomp_closedloop::groove::{deflection_plan, groove_setup, run_groove_with};
use millcomp_closedloop::touch_off::{
    REMANENCE_ALLOWANCE, TouchOffBias, auto_bias, model_remanence_um,
};
use millcomp_closedloop::{ControllerKind, Scenario};
use millcomp_sim::sensors::CapacitanceGauge;

/// The exit's figures of one run, from its report (µm; `NaN` where the report has none).
struct ExitFigures {
    /// The touch-off's bias (V; 0 at rest).
    bias_v: f64,
    /// The exit's settled error and its excess over it (`changes`).
    settled: f64,
    excess: f64,
    /// `exit_overcut_um` and `exit_floor_tip_um`.
    overcut: f64,
    tip_at_floor: f64,
    /// The tip the controllers' identified hysteresis model predicts at 0 V after the stack rose to
    /// 800 V (about the deep cut's command) and came back (`NaN` without a model).
    predicted_remanence: f64,
}

/// One run of `s` with `kind` on its commissioned set-up; with `allowance`, an `auto` touch-off is
/// made at the bias `auto_bias` chooses with that allowance instead of the shipped one.
fn exit_figures(
    s: &Scenario,
    kind: ControllerKind,
    allowance: Option<f64>,
) -> Result<ExitFigures, Box<dyn std::error::Error>> {
    let setup = groove_setup(s)?;
    let plan = deflection_plan(&setup, 0.01)?;
    let mut s = s.clone();
    if let (TouchOffBias::Auto, Some(allowance)) = (s.control.touch_off_bias, allowance) {
        let sin_a = setup.truth.program.tilt_deg.to_radians().sin();
        s.control.touch_off_bias = auto_bias(
            &plan,
            sin_a,
            &setup.model_spindle,
            setup.model_hysteresis.as_ref(),
            CapacitanceGauge::rd20().range_um,
            allowance,
        )
        .map_or(TouchOffBias::Rest, |c| TouchOffBias::Volts(c.bias_v));
    }
    let r = run_groove_with(&s, &setup, &plan, kind)?.report;
    let exit = r.changes.iter().find(|c| c.kind == ChangeKind::Exit);
    Ok(ExitFigures {
        bias_v: r.touch_off.map_or(0.0, |t| t.bias_v),
        settled: exit.map_or(f64::NAN, |c| c.settled_um),
        excess: exit.map_or(f64::NAN, |c| c.excess_um),
        overcut: r.metrics.exit_overcut_um.unwrap_or(f64::NAN),
        tip_at_floor: r.metrics.exit_floor_tip_um.unwrap_or(f64::NAN),
        predicted_remanence: setup
            .model_hysteresis
            .as_ref()
            .map_or(f64::NAN, |h| model_remanence_um(h, 800.0)),
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut seeds = 10u64;
    let mut kind = ControllerKind::Mpc;
    let mut touch = TouchOffBias::Rest;
    let mut allowance = REMANENCE_ALLOWANCE;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seeds" => seeds = args.next().ok_or("--seeds needs a value")?.parse()?,
            "--controller" => kind = args.next().ok_or("--controller needs a name")?.parse()?,
            "--touch-off" => {
                touch = match args
                    .next()
                    .ok_or("--touch-off needs rest, auto or volts")?
                    .as_str()
                {
                    "rest" => TouchOffBias::Rest,
                    "auto" => TouchOffBias::Auto,
                    v => TouchOffBias::Volts(v.parse()?),
                }
            }
            "--allowance" => allowance = args.next().ok_or("--allowance needs a value")?.parse()?,
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    let base = commissioned(&Scenario::load(
        "datasets/scenarios/groove_s7_20deg_exit.toml",
    )?);
    let sin_a = 20f64.to_radians().sin();
    println!("controller {kind}, touch-off {touch:?}, allowance {allowance}\n");
    println!(
        "| seed | bias (V) | settled before the exit (µm) | exit excess over it | exit overcut | tip at 0 V (µm) | of depth | identified model's tip at 0 V | linear stack: excess | overcut |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    // the shipped allowance is the scenario's own `auto`
    let allowance = (allowance != REMANENCE_ALLOWANCE).then_some(allowance);
    for seed in 1..=seeds {
        let mut s = base.clone();
        s.seed = seed;
        s.control.touch_off_bias = touch;
        let h = exit_figures(&s, kind, allowance)?;
        s.truth.pzt_nonlinear = false;
        let l = exit_figures(&s, kind, allowance)?;
        println!(
            "| {seed} | {:.0} | {:+.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            h.bias_v,
            h.settled,
            h.excess,
            h.overcut,
            h.tip_at_floor,
            h.tip_at_floor * sin_a,
            h.predicted_remanence,
            l.excess,
            l.overcut
        );
    }
    Ok(())
}
