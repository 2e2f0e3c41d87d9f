//! Tolerances and helpers of the `diagnose` tests (issue 7), each argued.

use std::path::PathBuf;

use millcomp_identify::diagnose::{ForceTrace, MeasuredGroove};
use millcomp_sim::session::Session;

/// Significance level of the tests = the CLI default `--alpha 0.01` (issue 7).
pub const ALPHA: f64 = 0.01;
/// "The residual RMS shrinks by ≥ 50 %" (issue 7, Must show): final ≤ 0.5 · initial.
pub const RMS_SHRINK: f64 = 0.5;
/// With the candidate's functional form equal to the truth's, the final residual must be the
/// profilometer noise: RMS ≤ 1.3 σ (σ = 0.1 µm, `synthetic::DEPTH_NOISE_UM`). The sample RMS of
/// 294 N(0, σ²) points has a relative sd of 1/√(2·294) = 4 %, so 1.3 σ is 7 sd above σ while any
/// leftover systematic error of 0.08 µm RMS or more would exceed it.
pub const NOISE_RMS_MAX_UM: f64 = 0.13;
/// Clean sessions in the quick (debug) false-alarm test. 12 keeps it at a few seconds; it can only
/// catch a grossly broken test (P(≥ 3 false alarms in 12 | rate 0.05) = 2 %, at rate 0.5 ≈ 1).
pub const CLEAN_QUICK: usize = 12;
/// Clean sessions in the full (ignored, release) false-alarm study: 200 gives the rate at α = 0.05
/// a binomial sd of 1.5 %.
pub const CLEAN_FULL: usize = 200;
/// Data sets per case in the full (ignored) coverage/power study.
pub const COVERAGE_SETS: usize = 100;

/// `datasets/synthetic/` of the workspace.
pub fn synthetic_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../datasets/synthetic")
}

/// Reads a committed synthetic case (session, measured CSV and force trace if present).
pub fn load_case(name: &str) -> (Session, MeasuredGroove) {
    let dir = synthetic_dir();
    let session = Session::from_path(dir.join(format!("{name}.toml"))).unwrap();
    let mut measured = MeasuredGroove::from_path(&dir.join(format!("{name}.csv"))).unwrap();
    let f = dir.join(format!("{name}.forces.csv"));
    if f.exists() {
        measured.forces = Some(ForceTrace::from_path(&f).unwrap());
    }
    (session, measured)
}
