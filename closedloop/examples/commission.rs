//! Commission the thesis' 20° groove plant (S7, 5 µm wearland) through drawn instrument errors and print
//! every identified parameter with its 95 % interval and the value the truth implies for it (what
//! `millcomp commission --coverage N` counts over many seeds).
//!
//! `cargo run -p millcomp-closedloop --example commission --release -- [SEED]`

use millcomp_closedloop::commissioning::{CommissioningPlan, CommissioningPlant, commission};
use millcomp_sim::groove::GrooveConfig;
use millcomp_sim::sensors::InstrumentErrors;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seed: u64 = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(1);
    let truth = GrooveConfig::thesis(20.0, 5.0)?;
    let instruments = InstrumentErrors::draw(seed);
    let plant = CommissioningPlant {
        truth: &truth,
        instruments,
        force_noise_n: 0.04,
        gauge_noise_um: 0.01,
        material: "S7",
    };
    let c = commission(&plant, &CommissioningPlan::default(), seed)?;
    println!("instruments: {instruments:?}");
    println!(
        "{:<42} {:>12} {:>26} {:>12} {:>7}",
        "parameter", "estimate", "95 % interval", "pseudo-true", "covers"
    );
    for (name, est, ci, t) in c.intervals() {
        println!(
            "{name:<42} {est:>12.5} [{:>11.5}, {:>11.5}] {t:>12.5} {:>7}",
            ci[0],
            ci[1],
            ci[0] <= t && t <= ci[1]
        );
    }
    for w in &c.bundle.warnings {
        println!("warning: {w}");
    }
    println!(
        "force fit: {} iterations, {}",
        c.force.fit.report.iterations, c.force.fit.report.message
    );
    Ok(())
}
