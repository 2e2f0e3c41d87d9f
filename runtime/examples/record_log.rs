//! Record a sensor log from a simulated machine (sim's 20° stage, sensor noise) while the program's
//! controller drives it ([`millcomp_runtime::record`]): what `millcomp replay` takes, as CSV (the
//! sensor-log contract's columns, `millcomp_datasets::contracts`; docs/replay.md). `millcomp simulate
//! PROGRAM --bundle BUNDLE --sensor-log OUT` does the same through the table writer.
//!
//! ```text
//! cargo run -p millcomp-runtime --example record_log -- BUNDLE PROGRAM OUT.csv [STEPS]
//! ```

use millcomp_runtime::record::{SimulatedMachine, record};
use millcomp_runtime::{Controller, Program, load_bundle};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [bundle, program, out, rest @ ..] = args.as_slice() else {
        return Err("usage: record_log BUNDLE PROGRAM OUT.csv [STEPS]".into());
    };
    let steps: usize = rest.first().map(|s| s.parse()).transpose()?.unwrap_or(4000);
    let p = Program::load(program.as_ref())?;
    let mut ctl = Controller::from_bundle(&load_bundle(bundle.as_ref())?, &p)?;
    let run = record(&mut ctl, &p, &SimulatedMachine::default(), steps)?;
    // Rust's shortest round-trip form; NaN (no reading) as an empty cell
    let cell = |x: f64| {
        if x.is_nan() {
            String::new()
        } else {
            x.to_string()
        }
    };
    let mut text = String::from("t_s,x_mm,force_n,gauge_um\n");
    for (k, m) in run.log.iter().enumerate() {
        text.push_str(&format!(
            "{},{},{},{}\n",
            k as f64 * run.period_s,
            cell(m.x_mm),
            cell(m.force_n),
            cell(m.gauge_um)
        ));
    }
    std::fs::write(out, text)?;
    eprintln!("{out}: {steps} samples");
    Ok(())
}
