//! Commission the thesis' 20° groove plant (S7, 5 µm wearland) through drawn instrument errors and print
//! every identified parameter with its 95 % interval and the value the truth implies for it.
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
    let wl: f64 = std::env::var("WL")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5.0);
    let truth = GrooveConfig::thesis(20.0, wl)?;
    let instruments = if std::env::var("EXACT").is_ok() {
        InstrumentErrors::default()
    } else {
        InstrumentErrors::draw(seed)
    };
    let plant = CommissioningPlant {
        truth: &truth,
        instruments,
        force_noise_n: 0.04,
        gauge_noise_um: 0.01,
        material: "S7",
    };
    if let Some(n) = std::env::args().nth(2) {
        let n: u64 = n.parse()?;
        let rows = millcomp_closedloop::commissioning::coverage_study(
            &truth,
            "S7",
            0.04,
            0.01,
            &CommissioningPlan::default(),
            seed..seed + n,
            || {},
        )?;
        for r in rows {
            println!(
                "{:<42} {:>4}/{:<4} p={:.4} median|z|={:.3}",
                r.parameter, r.covered, r.n, r.p_value, r.median_abs_z
            );
        }
        return Ok(());
    }
    let t0 = std::time::Instant::now();
    let c = commission(&plant, &CommissioningPlan::default(), seed)?;
    println!("instruments: {instruments:?}");
    println!("spindle BIC: {:?}", c.spindle_bic);
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
    println!("took {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}
