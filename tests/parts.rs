//! End-to-end tests of `millcomp parts SCENARIO`.

use crate::common::*;

use predicates::prelude::*;

/// The shipped 30° groove shortened to 6 mm (0–24 µm, calibrated to 4.8 µm uncompensated) so that two
/// parts on one machine take seconds.
fn short_groove(dir: &std::path::Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(repo("datasets/scenarios/groove_s7_30deg.toml"))
        .unwrap()
        .replace("length_mm = 20.0", "length_mm = 6.0")
        .replace("to_um = 80.0", "to_um = 24.0")
        .replace(
            "calibrate_uncompensated_um = 16.0",
            "calibrate_uncompensated_um = 4.8",
        );
    write(dir, "short.toml", &text)
}

#[test]
fn parts_writes_every_part_and_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = short_groove(dir.path());
    let out = dir.path().join("parts");
    millcomp()
        .args(["parts", s(&scenario), "--parts", "2", "--seeds", "1"])
        .args(["--controllers", "mpc", "--out", s(&out)])
        .assert()
        .success()
        .stdout(
            predicate::str::contains("mpc-true-model")
                .and(predicate::str::contains("gap to the true-model MPC")),
        );
    let csv = std::fs::read_to_string(out.join("parts.csv")).unwrap();
    assert!(csv.starts_with("seed,part,controller,pp_error_um"), "{csv}");
    // one machine × (mpc + reference) × 2 parts, plus the header
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(
        std::fs::read_to_string(out.join("parts.svg"))
            .unwrap()
            .contains("<svg")
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        doc["runs"][0]["true_deflection_scale"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
}

#[test]
fn parts_refuses_bad_options_and_stages() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = short_groove(dir.path());
    millcomp()
        .args(["parts", s(&scenario), "--parts", "0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--parts"))
        .stderr(predicate::str::contains("1..=1000"));
    millcomp()
        .args(["parts", s(&scenario), "--stiffness-error", "0.9"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("stiffness_error_rel"));
    // a thin wall has no run-to-run learning: refused before anything is written
    let out = dir.path().join("wall-parts");
    millcomp()
        .args([
            "parts",
            &repo("datasets/scenarios/thin_wall_h59.toml"),
            "--seeds",
            "1",
        ])
        .args(["--out", s(&out)])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("stage"));
    assert!(!out.exists());
}
