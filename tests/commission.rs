//! `millcomp commission`: a bundle written with its provenance, a scenario run on it, the coverage study,
//! and bad input named.

use predicates::str::contains;

use crate::common::{millcomp, repo, s, write};

const SCENARIO: &str = "datasets/scenarios/groove_s7_20deg_commissioned.toml";

#[test]
fn commission_writes_a_bundle_that_a_scenario_runs_on() {
    let tmp = tempfile::tempdir().unwrap();
    let bundle = tmp.path().join("models.toml");
    millcomp()
        .args(["commission", &repo(SCENARIO), "--out", s(&bundle)])
        .assert()
        .success()
        .stdout(contains("force.w_mpa"))
        .stdout(contains("spindle structures (BIC, smallest kept)"))
        .stdout(contains("stiffness.radial_stiffness_n_per_um"));
    let text = std::fs::read_to_string(&bundle).unwrap();
    assert!(text.contains("kind = \"bundle\""), "{text}");
    assert!(text.contains("sha256"), "{text}");
    // the same scenario, its controllers built from the saved bundle instead of commissioning itself
    let scenario = std::fs::read_to_string(repo(SCENARIO))
        .unwrap()
        .replace("commission = true", &format!("bundle = \"{}\"", s(&bundle)));
    let file = write(tmp.path(), "on_bundle.toml", &scenario);
    millcomp()
        .args(["simulate", s(&file), "--controller", "mpc"])
        .assert()
        .success()
        .stdout(contains("peak-to-peak error"));
}

#[test]
fn coverage_study_prints_a_row_per_parameter() {
    millcomp()
        .args(["commission", &repo(SCENARIO), "--coverage", "5"])
        .assert()
        .success()
        .stdout(contains("force.w_mpa"))
        .stdout(contains("/5"));
}

#[test]
fn bad_input_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario =
        std::fs::read_to_string(repo(SCENARIO)).unwrap() + "\n[commissioning]\nreplicates = 0\n";
    let file = write(tmp.path(), "bad.toml", &scenario);
    millcomp()
        .args(["commission", s(&file)])
        .assert()
        .code(1)
        .stderr(contains("commissioning.replicates"));
    millcomp()
        .args(["commission", &repo("datasets/scenarios/thin_wall_h59.toml")])
        .assert()
        .code(1)
        .stderr(contains("groove scenarios"));
    let out = tmp.path().join("no/such/dir/models.toml");
    millcomp()
        .args(["commission", &repo(SCENARIO), "--out", s(&out)])
        .assert()
        .code(1)
        .stderr(contains("models.toml"));
}
