//! The worst-case step time of every controller over a replay (a benchmark, not a test).
//!
//! Each controller runs 0.5 s (10 000 cycles at 20 kHz: the approach in air, the entry and 40 µm of
//! cut) in closed loop with sim's 20° stage — the machine — and its sensor log is recorded; the
//! controller is then reset and the log replayed through it, each step timed around the call. The
//! table gives the median, the 99th percentile and the longest step side by side, and the cycle of the
//! longest (the MPC plans every 10th cycle: its median is a hold, its p99 a solve).
//!
//! ```text
//! cargo run --release -p millcomp-runtime --example step_times [-- REPEATS]
//! ```

use millcomp_runtime::record::{SimulatedMachine, record};
use millcomp_runtime::{Controller, ControllerKind, Program, load_bundle, replay};

fn data(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/")).join(name)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let repeats: usize = std::env::args()
        .nth(1)
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(3);
    let bundle = load_bundle(&data("bundle_s7.toml"))?;
    println!(
        "{:<14} {:>7} {:>11} {:>11} {:>11} {:>9}",
        "controller", "steps", "median_us", "p99_us", "max_us", "max_at"
    );
    for kind in ControllerKind::ALL {
        let mut p = Program::load(&data("cut_40um.toml"))?;
        p.controller.kind = kind;
        let mut ctl = Controller::from_bundle(&bundle, &p)?;
        // the machine: sim's stage with sensor noise, only to record a sensor log
        let log = record(&mut ctl, &p, &SimulatedMachine::default(), 10_000)?.log;
        // the replay, `repeats` times: the worst over all of them
        let mut all_ns = Vec::with_capacity(repeats * log.len());
        for _ in 0..repeats {
            ctl.reset()?;
            all_ns.extend(replay::replay(&mut ctl, &log).step_ns);
        }
        let t = replay::step_times(&all_ns);
        println!(
            "{:<14} {:>7} {:>11.2} {:>11.2} {:>11.2} {:>9}",
            kind.name(),
            t.steps,
            t.median_ns as f64 / 1e3,
            t.p99_ns as f64 / 1e3,
            t.max_ns as f64 / 1e3,
            t.max_cycle % log.len()
        );
    }
    Ok(())
}
