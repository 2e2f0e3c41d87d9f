//! Shared helpers: the runtime's test data, and a sensor log recorded from a closed loop on sim's stage
//! (the machine; the controller sees only the bundle, the program and the readings).

use std::path::PathBuf;

use millcomp_runtime::{Controller, Measurement, Program, load_bundle};
use millcomp_sim::groove::{GrooveConfig, GrooveStage};
use millcomp_sim::sensors::NoiseSpec;

/// A file of `runtime/tests/data/`.
pub fn data(name: &str) -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../runtime/tests/data/"
    ))
    .join(name)
}

/// `steps` cycles of the controller of `program` in closed loop with sim's 20° stage: the sensor log
/// the machine recorded (one measurement per cycle, the first before any reading).
pub fn record(program: &std::path::Path, steps: usize) -> Vec<Measurement> {
    let bundle = load_bundle(&data("bundle_s7.toml")).unwrap();
    let p = Program::load(program).unwrap();
    let mut ctl = Controller::from_bundle(&bundle, &p).unwrap();
    let mut truth = GrooveConfig::thesis(p.program.tilt_deg, 8.0).unwrap();
    truth.program = p.program.groove_program();
    truth.force_noise = Some(NoiseSpec {
        seed: 7,
        sigma: 0.04,
    });
    truth.gauge_noise = Some(NoiseSpec {
        seed: 8,
        sigma: 0.01,
    });
    let mut stage = GrooveStage::new(truth, ctl.period_s()).unwrap();
    let mut log = Vec::with_capacity(steps);
    let mut m = Measurement::NONE;
    for k in 0..steps {
        // a gap in each channel: the log says NaN
        if (4_000..4_004).contains(&k) {
            m.force_n = f64::NAN;
        }
        log.push(m);
        let c = ctl.step(&m);
        let o = stage.step(c.voltage_v);
        m = Measurement {
            x_mm: o.x_mm,
            force_n: o.force_meas_n,
            gauge_um: o.gauge_um,
        };
    }
    log
}
