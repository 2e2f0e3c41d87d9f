//! The groove controllers of millcomp-mpc on sim's groove stage: the thesis' 20° S7 groove (0 → 80 µm
//! over 20 mm), cut uncompensated, with open-loop compensation, the published PID and the MPC. The
//! controllers are built from the program and identified models only — here the values a commissioning
//! of this plant gave, with W 10 % high — and see only the measured force and gauge.
//! (`millcomp-closedloop` does the same from scenario files, with identified models and faults.)
//!
//! ```text
//! cargo run --release -p millcomp-mpc --example groove_controllers [LENGTH_MM]
//! ```

use std::process::ExitCode;

use millcomp_models::{ForceModelParams, SpindleModel, StiffnessModel};
use millcomp_mpc::MpcError;
use millcomp_mpc::groove::{
    DeflectionPlan, GrooveController, GrooveMeasurement, GrooveMpcSettings, MpcGrooveController,
    NoneController, OpenLoopController, PidController,
};
use millcomp_mpc::identified::{
    IdentifiedForceModel, IdentifiedSpindle, IdentifiedStiffness, NominalTool,
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
    // the controllers' models: what `millcomp commission` identified on this plant (the 20° groove
    // scenario with `commission = true`, seed 20: W 22 444 MPa, wearland 8.00 µm, spindle 0.0499 µm/V,
    // ζ 0.336, ωn 2824 rad/s, pole 2996 rad/s, dead time 0.378 ms, stiffness 1.101 / 0.1144 N/µm), with
    // W 10 % high on top
    let tool = NominalTool::thesis_ball_end("S7");
    let force = IdentifiedForceModel::new(
        &ForceModelParams {
            fitted: [
                ("w_mpa".to_string(), 1.1 * 22_443.9),
                ("wearland_um".to_string(), 8.0),
            ]
            .into(),
            fixed: Default::default(),
            covariance: Default::default(),
        },
        &tool,
    )?;
    let predictor = ForcePredictor::Mechanistic(force);
    let stiffness = IdentifiedStiffness::new(&StiffnessModel {
        axial_n_per_um: 1.101,
        radial_n_per_um: 0.1144,
        covariance: Default::default(),
    })?;
    let spindle = IdentifiedSpindle::new(&SpindleModel {
        gain_um_per_v: 0.0499,
        zeta: 0.336,
        wn_rad_s: 2824.0,
        pole_rad_s: Some(2996.0),
        dead_time_s: Some(3.78e-4),
        dead_time_pade_order: Some(2),
        covariance: Default::default(),
    })?;
    let v_max = spindle.plant().voltage_max_v;
    let plan = DeflectionPlan::new(&program, &predictor, &stiffness, tool.radius_um, 0.01)?;
    let settings = GrooveMpcSettings {
        dt_s: DT_S,
        mpc_every: 10,
        horizon: 20,
        slew_v_per_cycle: 100.0,
        voltage_max_v: v_max,
        config: None,
        force_noise_n: 0.0,
        gauge_noise_um: 0.0,
        features: Default::default(),
        budget: Default::default(),
    };
    let mut controllers: Vec<(&str, Box<dyn GrooveController>)> = vec![
        ("none", Box::new(NoneController::default())),
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
                tool.flutes,
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
