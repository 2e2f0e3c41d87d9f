//! What every CLI test shares: the binary, paths in the repository, files in a scratch directory, and the
//! JSON document a verb prints.

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use serde_json::Value;

/// The `millcomp` binary, with no cluster array variables leaking in from the environment and two
/// worker threads.
pub fn millcomp() -> Command {
    let mut c = Command::cargo_bin("millcomp").expect("binary built");
    c.env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .env("RAYON_NUM_THREADS", "2");
    c
}

/// A path in the repository (absolute, so tests may run in any directory).
pub fn repo(rel: &str) -> String {
    format!("{}/{rel}", env!("CARGO_MANIFEST_DIR"))
}

/// Table 3-3 of `000_…txt`, shipped as `datasets/data/clayton_doe.csv`.
pub const CLAYTON: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/datasets/data/clayton_doe.csv");

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

/// The path as `&str` (the tests' scratch paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Runs `millcomp ARGS` (the caller passes `--json`), which must succeed, and parses its stdout as one
/// JSON document.
pub fn json_of(args: &[&str]) -> Value {
    let out = millcomp().args(args).output().expect("run");
    assert!(
        out.status.success(),
        "millcomp {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON document on stdout")
}

/// [`json_of`] with `--json` appended.
pub fn run_json(args: &[&str]) -> Value {
    let mut all = args.to_vec();
    all.push("--json");
    json_of(&all)
}

/// The measured-groove header, from the one column list.
pub fn groove_header() -> String {
    millcomp_datasets::contracts::MEASURED_GROOVE_COLUMNS.join(",")
}
