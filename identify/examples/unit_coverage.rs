//! The coverage study of the across-units analysis (`identify::units`, issue 50): simulated units whose
//! true between-unit scatter τ is known (thin walls whose stiffness varies; cutters whose force-against-
//! wear slope varies, with AR(1) errors as the PHM records have), fitted unit by unit through the crate's
//! own targets and combined; how often the new unit's true value lies inside its 95 % prediction
//! interval, the mean inside its HKSJ interval, τ inside its Q-profile interval.
//!
//! Run: `cargo run --release -p millcomp-identify --example unit_coverage -- [SETS] [SEED]`
//! (default 4000 data sets per setting from seed 1). The table is in docs/identify.md.

#[path = "../tests/unit_sim.rs"]
mod unit_sim;

use millcomp_identify::units::Tau2Method;
use unit_sim::{Family, Setting, coverage};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let sets: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(4000);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    println!(
        "coverage of the 95 % intervals over {sets} simulated data sets per setting (seeds {seed}..{}); \
         binomial sd of a 95 % rate: {:.1} %",
        seed + sets as u64 - 1,
        100.0 * (0.95f64 * 0.05 / sets as f64).sqrt()
    );
    println!(
        "{:<6} {:>5} {:>7} {:>6} {:>4} {:>9} {:>10} {:>8} {:>7} {:>11}",
        "family",
        "units",
        "tau/k",
        "noise",
        "tau2",
        "SE/tau",
        "new unit",
        "mean",
        "tau",
        "PI width"
    );
    let mut settings = Vec::new();
    for units in [2usize, 3, 5, 10] {
        for (family, noise) in [
            (Family::Wall, 0.05),
            (Family::Wall, 0.5),
            (Family::Wear, 1.0),
            (Family::Wear, 6.0),
        ] {
            for tau2 in [Tau2Method::DerSimonianLaird, Tau2Method::PauleMandel] {
                settings.push(Setting {
                    family,
                    units,
                    tau_rel: 0.1,
                    noise,
                    tau2,
                });
            }
        }
    }
    for s in &settings {
        let c = coverage(s, sets, seed);
        let pct = |n: usize| format!("{:.1} %", 100.0 * n as f64 / c.sets as f64);
        println!(
            "{:<6} {:>5} {:>7} {:>6} {:>4} {:>9.2} {:>10} {:>8} {:>7} {:>11.2}",
            format!("{:?}", s.family).to_lowercase(),
            s.units,
            s.tau_rel,
            s.noise,
            match s.tau2 {
                Tau2Method::DerSimonianLaird => "dl",
                Tau2Method::PauleMandel => "pm",
            },
            c.median_se_over_tau,
            pct(c.new_unit),
            pct(c.mean),
            pct(c.tau),
            c.median_width_ratio
        );
    }
    println!(
        "(SE/tau: median per-unit standard error over the true τ; PI width: median prediction-interval \
         width over 2·1.96·τ, the interval μ ± 1.96 τ one would draw knowing μ and τ)"
    );
}
