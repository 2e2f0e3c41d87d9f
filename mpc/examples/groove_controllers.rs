//! The groove controllers of millcomp-mpc on sim's groove stage: the thesis' 20° S7 groove (0 → 80 µm
//! over 20 mm), cut uncompensated, with open-loop compensation, the published PID and the MPC. The
//! controllers are built from the program and models of their own — here sim's force model with W 10 %
//! high, the Table 5-1 stiffness and the nominal spindle — and see only the measured force and gauge.
//! (`millcomp-closedloop` does the same from scenario files, with identified models and faults.)
//!
//! ```text
//! cargo run --release -p millcomp-mpc --example groove_controllers [LENGTH_MM]
//! ```

use std::process::ExitCode;

use millcomp_mpc::MpcError;
use millcomp_mpc::groove::{
    DeflectionPlan, GrooveController, GrooveMeasurement, GrooveMpcSettings, MpcGrooveController,
    NoneController, OpenLoopController, PidController,
};
use millcomp_mpc::pid::{AntiWindup, PidGains};
use millcomp_mpc::predictor::ForcePredictor;
use millcomp_sim::groove::{GrooveConfig, GrooveStage};

/// Stage step (s): 20 kHz, the PID's and the signal chain's rate; the MPC runs every 10th step.
const DT_S: f64 = 5e-5;

/// Peak-to-peak depth error (µm) of one cut with `ctl`.
fn cut(truth: &GrooveConfig, ctl: &mut dyn GrooveController) -> Result<f64, MpcError> {
    let mut stage = GrooveStage::new(truth.clone(), DT_S)?;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut last: Option<GrooveMeasurement> = None;
    let mut k = 0usize;
    loop {
        let v = ctl.command(last.as_ref(), k as f64 * DT_S);
        let o = stage.step(v);
        let e = o.depth_cut_um - o.depth_cmd_um;
        (lo, hi) = (lo.min(e), hi.max(e));
        last = Some(GrooveMeasurement {
            force_meas_n: o.force_meas_n,
            gauge_um: o.gauge_um,
        });
        k += 1;
        if o.done {
            return Ok(hi - lo);
        }
    }
}

fn run() -> Result<(), MpcError> {
    let length_mm: f64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20.0);
    // the truth: the thesis' groove (sim), the first `length_mm` of it
    let mut truth = GrooveConfig::thesis(20.0, 8.0)?;
    truth.program.depth_profile = millcomp_sim::groove::DepthProfile::Ramp {
        from_um: 0.0,
        to_um: 80.0 * length_mm / 20.0,
    };
    truth.program.length_mm = length_mm;
    let program = truth.program.clone();
    // the controllers' models: W 10 % high, the published stiffness, the nominal spindle
    let mut force = truth.force_model.clone();
    force.material.w_mpa *= 1.1;
    let predictor = ForcePredictor::Mechanistic(force);
    let stiffness = millcomp_sim::stiffness::TiltedToolStiffness::default();
    let spindle = millcomp_sim::PztSpindle::default();
    let v_max = spindle.voltage_max_v;
    let plan = DeflectionPlan::new(
        &program,
        &predictor,
        &stiffness,
        truth.force_model.tool.radius_um,
        0.01,
    )?;
    let settings = GrooveMpcSettings {
        dt_s: DT_S,
        mpc_every: 10,
        horizon: 20,
        slew_v_per_cycle: 100.0,
        voltage_max_v: v_max,
        config: None,
        force_noise_n: 0.0,
        gauge_noise_um: 0.0,
    };
    let mut controllers: Vec<(&str, Box<dyn GrooveController>)> = vec![
        ("none", Box::new(NoneController)),
        (
            "open-loop",
            Box::new(OpenLoopController::new(
                plan.clone(),
                &program,
                &spindle,
                v_max,
            )),
        ),
        (
            "pid",
            Box::new(PidController::new(
                PidGains::tuned(),
                AntiWindup::None,
                &program,
                &spindle,
                &stiffness,
                v_max,
                DT_S,
            )?),
        ),
        (
            "mpc",
            Box::new(MpcGrooveController::new(
                plan,
                &program,
                &spindle,
                &stiffness,
                truth.force_model.tool.flutes,
                &settings,
            )?),
        ),
    ];
    println!("20° S7 groove, {length_mm} mm: peak-to-peak depth error");
    for (name, ctl) in &mut controllers {
        let pp = cut(&truth, ctl.as_mut())?;
        let solver = ctl
            .solver_stats()
            .map(|s| format!("   ({} QP solves, {} fallbacks)", s.solves, s.fallbacks))
            .unwrap_or_default();
        println!("{name:>10} {pp:8.3} µm{solver}");
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
