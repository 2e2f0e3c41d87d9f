//! Shared helpers: the test data and a closed loop on sim's groove stage, the machine a controller is
//! stepped against here (the controller itself sees only the bundle, the program and the readings).

use std::path::PathBuf;

use millcomp_runtime::{Controller, ControllerKind, Measurement, Program, load_bundle};
use millcomp_sim::groove::{GrooveConfig, GrooveStage};

/// A file of `runtime/tests/data/`.
pub fn data(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/")).join(name)
}

/// `cut_40um.toml` (the 20° program constant 40 µm deep after a 0.3 mm approach in air and the ball's
/// entry: a cut reached within 10 000 cycles) with its controller set to `kind`.
pub fn program(kind: ControllerKind) -> Program {
    let mut p = Program::load(&data("cut_40um.toml")).unwrap();
    p.controller.kind = kind;
    p
}

/// `kind` on the test bundle (commissioned from `groove_s7_20deg_commissioned.toml`: it has the
/// stack's hysteresis and the sensors' noise) with the program of [`program`].
pub fn controller(kind: ControllerKind, compensate_hysteresis: bool) -> Controller {
    let bundle = load_bundle(&data("bundle_s7.toml")).unwrap();
    let mut p = program(kind);
    p.controller.compensate_hysteresis = compensate_hysteresis;
    Controller::from_bundle(&bundle, &p).unwrap()
}

/// The machine: sim's 20° stage cutting `program`'s groove, with sensor noise.
pub fn machine(p: &Program, dt_s: f64) -> GrooveStage {
    let mut truth = GrooveConfig::thesis(p.program.tilt_deg, 8.0).unwrap();
    truth.program = p.program.groove_program();
    truth.force_noise = Some(millcomp_sim::sensors::NoiseSpec {
        seed: 7,
        sigma: 0.04,
    });
    truth.gauge_noise = Some(millcomp_sim::sensors::NoiseSpec {
        seed: 8,
        sigma: 0.01,
    });
    GrooveStage::new(truth, dt_s).unwrap()
}

/// What the machine gives after a step: its position and the sensors' readings.
pub fn reading(o: &millcomp_sim::groove::GrooveStepOutput) -> Measurement {
    Measurement {
        x_mm: o.x_mm,
        force_n: o.force_meas_n,
        gauge_um: o.gauge_um,
    }
}
