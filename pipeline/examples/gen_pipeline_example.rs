//! The seeded generator of the worked example `datasets/pipeline/`: the demo's pipeline on the simulated
//! machine of seed 7, and the files a user would have measured on it copied out — the calibration
//! records, the session (its nominal model and plan) and its measured grooves, the part errors of the
//! comparison and of the rerun — with a plan that names them. All of it is **synthetic** (made by this
//! generator, not measured on a real machine); `datasets/pipeline/README.md` says so.
//!
//! `cargo run --release -p millcomp-pipeline --example gen_pipeline_example` (about a minute on 2 cores).

use std::path::Path;

use millcomp_pipeline::plan::Plan;
use millcomp_pipeline::{Options, run};

/// The machine's seed.
const MACHINE_SEED: u64 = 7;

const PLAN: &str = r#"# Worked example of `millcomp pipeline` (docs/pipeline.md): every stage supplied by a file.
# SYNTHETIC files: measured on the simulated machine of seed 7 by
# `cargo run --release -p millcomp-pipeline --example gen_pipeline_example` (README.md here).
name = "millcomp pipeline: worked example (synthetic files)"
seed = 1

[measure]
forces = "calibration_forces.csv"
spindle_step = "spindle_step.csv"
hysteresis_sweep = "hysteresis_sweep.csv"
load_deflection = "load_deflection.csv"
sensors_at_rest = "sensors_at_rest.csv"

[compare]
results = "batch_results.csv"
tolerance_pp_um = 4.0

[diagnose]
session = "session.toml"
measured = "session.csv"

[rerun]
results = "rerun_results.csv"
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = repo.join("datasets/pipeline");
    std::fs::create_dir_all(&dir)?;
    let tmp = std::env::temp_dir().join(format!("millcomp-gen-pipeline-{}", std::process::id()));
    let mut opts = Options::new(tmp.clone());
    opts.command = "cargo run --release -p millcomp-pipeline --example gen_pipeline_example".into();
    let o = run(&Plan::demo(MACHINE_SEED), &opts, &|s| eprintln!("… {s}"))?;
    eprintln!("{}", o.headline);
    for (from, to) in [
        ("measured/calibration_forces.csv", "calibration_forces.csv"),
        ("measured/spindle_step.csv", "spindle_step.csv"),
        ("measured/hysteresis_sweep.csv", "hysteresis_sweep.csv"),
        ("measured/load_deflection.csv", "load_deflection.csv"),
        ("measured/sensors_at_rest.csv", "sensors_at_rest.csv"),
        ("session/session.toml", "session.toml"),
        ("measured/session.csv", "session.csv"),
        ("batch/results.csv", "batch_results.csv"),
        ("rerun/results.csv", "rerun_results.csv"),
    ] {
        std::fs::copy(tmp.join(from), dir.join(to))?;
    }
    std::fs::write(dir.join("plan.toml"), PLAN)?;
    std::fs::remove_dir_all(&tmp)?;
    eprintln!("written: {}", dir.display());
    Ok(())
}
