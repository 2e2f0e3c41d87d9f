//! Record a sensor log from a simulated machine (sim's 20° stage, sensor noise) while the program's
//! controller drives it: what `millcomp replay` takes (the sensor-log contract,
//! `millcomp_datasets::contracts`; docs/replay.md). The machine here is a simulation; on a real
//! machine the log comes from its control task.
//!
//! ```text
//! cargo run -p millcomp-runtime --example record_log -- BUNDLE PROGRAM OUT.csv [STEPS]
//! ```

use millcomp_runtime::{Controller, Measurement, Program, load_bundle};
use millcomp_sim::groove::{GrooveConfig, GrooveStage};
use millcomp_sim::sensors::NoiseSpec;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [bundle, program, out, rest @ ..] = args.as_slice() else {
        return Err("usage: record_log BUNDLE PROGRAM OUT.csv [STEPS]".into());
    };
    let steps: usize = rest.first().map(|s| s.parse()).transpose()?.unwrap_or(4000);
    let p = Program::load(program.as_ref())?;
    let mut ctl = Controller::from_bundle(&load_bundle(bundle.as_ref())?, &p)?;
    let mut truth = GrooveConfig::thesis(p.program.tilt_deg, 8.0)?;
    truth.program = p.program.groove_program();
    truth.force_noise = Some(NoiseSpec {
        seed: 7,
        sigma: 0.04,
    });
    truth.gauge_noise = Some(NoiseSpec {
        seed: 8,
        sigma: 0.01,
    });
    let mut stage = GrooveStage::new(truth, ctl.period_s())?;
    let mut text = String::from("t_s,x_mm,force_n,gauge_um\n");
    let mut m = Measurement::NONE;
    for k in 0..steps {
        // Rust's shortest round-trip form; NaN (no reading) as an empty cell
        let cell = |x: f64| {
            if x.is_nan() {
                String::new()
            } else {
                x.to_string()
            }
        };
        text.push_str(&format!(
            "{},{},{},{}\n",
            k as f64 * ctl.period_s(),
            cell(m.x_mm),
            cell(m.force_n),
            cell(m.gauge_um)
        ));
        let c = ctl.step(&m);
        let o = stage.step(c.voltage_v);
        m = Measurement {
            x_mm: o.x_mm,
            force_n: o.force_meas_n,
            gauge_um: o.gauge_um,
        };
    }
    std::fs::write(out, text)?;
    eprintln!("{out}: {steps} samples");
    Ok(())
}
