//! End-to-end tests of `millcomp datasets` and of the CLI's handling of bad input files.

use crate::common::*;

use predicates::prelude::*;

#[test]
fn show_clayton_doe_prints_the_eight_trials_of_table_3_3() {
    let out = millcomp()
        .args(["datasets", "show", "clayton_doe", "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let doc: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 8);
    // 000_…txt Table 3-3: (depth, speed, upfeed) -> (max X, Y, Z force) per trial.
    let published = [
        (200.0, 10000.0, 20.0, 3.34, 1.75, 2.17),
        (100.0, 10000.0, 20.0, 1.78, 1.33, 1.24),
        (100.0, 20000.0, 10.0, 0.94, 0.93, 0.59),
        (200.0, 20000.0, 10.0, 1.91, 1.64, 0.83),
        (200.0, 20000.0, 20.0, 3.60, 2.30, 2.00),
        (100.0, 20000.0, 20.0, 2.20, 1.75, 1.50),
        (200.0, 10000.0, 10.0, 2.20, 2.10, 1.40),
        (100.0, 10000.0, 10.0, 1.00, 1.10, 0.82),
    ];
    for (row, p) in rows.iter().zip(published) {
        let got = (
            row["depth_um"].as_f64().unwrap(),
            row["speed_rpm"].as_f64().unwrap(),
            row["upfeed_um"].as_f64().unwrap(),
            row["max_fx_n"].as_f64().unwrap(),
            row["max_fy_n"].as_f64().unwrap(),
            row["max_fz_n"].as_f64().unwrap(),
        );
        assert_eq!(got, p);
        assert!(row["source"].as_str().unwrap().contains("Table 3-3"));
    }
}

#[test]
fn show_human_table_has_a_header_and_eight_rows() {
    millcomp()
        .args(["datasets", "show", "clayton_doe"])
        .assert()
        .success()
        .stdout(predicate::str::contains("max_fx_n"))
        .stdout(predicate::str::contains("3.34"))
        .stdout(predicate::str::contains("0.59"));
}

#[test]
fn list_names_every_dataset() {
    let out = millcomp()
        .args(["datasets", "list", "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let doc: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let names: Vec<&str> = doc
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["name"].as_str().unwrap())
        .collect();
    for want in [
        "clayton_doe",
        "clayton_spindle",
        "thin_wall_results",
        "depth_error_budget",
        "nc_feed_step",
    ] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
}

#[test]
fn unknown_dataset_fails_naming_it() {
    millcomp()
        .args(["datasets", "show", "nonesuch"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("nonesuch"))
        .stderr(predicate::str::contains("clayton_doe"));
}

/// Writes `text` to a file in a fresh directory and runs `datasets check` on it.
fn check(text: &str, schema: &str) -> (assert_cmd::assert::Assert, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("input.csv");
    std::fs::write(&path, text).unwrap();
    let a = millcomp()
        .args(["datasets", "check"])
        .arg(&path)
        .args(["--as", schema])
        .assert();
    (a, dir)
}

fn assert_nothing_written(dir: &tempfile::TempDir) {
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        vec!["input.csv".to_string()],
        "unexpected files: {names:?}"
    );
}

#[test]
fn valid_measured_groove_passes_and_notes_unknown_columns() {
    let (a, dir) = check(
        &format!(
            "{},operator\n1,0,0,0,10000,100,10,20,1,0,0.2,ann\n1,0.6,1,1,10000,100,10,20,1,4,3.1,ann\n",
            groove_header()
        ),
        "measured-groove",
    );
    a.success()
        .stdout(predicate::str::contains("2 rows"))
        .stdout(predicate::str::contains(
            "unknown column `operator` ignored",
        ));
    assert_nothing_written(&dir);
}

#[test]
fn missing_required_column_names_file_and_column() {
    let header = groove_header().replace(",depth_meas_um", "");
    let (a, dir) = check(
        &format!("{header}\n1,0,0,0,10000,100,10,20,1,0\n"),
        "measured-groove",
    );
    a.code(1)
        .stderr(predicate::str::contains("input.csv"))
        .stderr(predicate::str::contains(
            "missing required column `depth_meas_um`",
        ));
    assert_nothing_written(&dir);
}

#[test]
fn non_numeric_cell_names_file_column_and_row() {
    let (a, dir) = check(
        &format!(
            "{}\n1,0,0,0,10000,100,10,20,1,0,0.2\n1,0.6,1,1,10000,100,ten,20,1,4,3.1\n",
            groove_header()
        ),
        "measured-groove",
    );
    a.code(1)
        .stderr(predicate::str::contains("input.csv"))
        .stderr(predicate::str::contains("column `upfeed_um`, row 2"))
        .stderr(predicate::str::contains("`ten` is not a number"));
    assert_nothing_written(&dir);
}

#[test]
fn nan_cell_names_file_column_and_row() {
    let (a, dir) = check(
        &format!(
            "{}\n1,0,0,0,10000,100,10,20,1,0,0.2\n1,0.6,1,1,10000,100,10,20,1,4,NaN\n",
            groove_header()
        ),
        "measured-groove",
    );
    a.code(1)
        .stderr(predicate::str::contains("column `depth_meas_um`, row 2"))
        .stderr(predicate::str::contains("not a finite number"));
    assert_nothing_written(&dir);
}

#[test]
fn empty_file_is_a_clear_error() {
    let (a, dir) = check("", "measured-groove");
    a.code(1)
        .stderr(predicate::str::contains("input.csv"))
        .stderr(predicate::str::contains("empty"));
    assert_nothing_written(&dir);
    let (a, _dir) = check(&format!("{}\n", groove_header()), "measured-groove");
    a.code(1).stderr(predicate::str::contains("no data rows"));
}

#[test]
fn time_going_backwards_within_a_groove_is_rejected() {
    let (a, _dir) = check(
        &format!(
            "{}\n1,5,0,0,10000,100,10,20,1,0,0.2\n1,4,1,1,10000,100,10,20,1,4,3.1\n",
            groove_header()
        ),
        "measured-groove",
    );
    a.code(1)
        .stderr(predicate::str::contains("column `t_s`, row 2"));
}

#[test]
fn user_copy_of_a_shipped_table_validates_against_its_schema() {
    let (a, _dir) = check(millcomp_datasets_csv(), "clayton_doe");
    a.success().stdout(predicate::str::contains("8 rows"));
}

fn millcomp_datasets_csv() -> &'static str {
    include_str!("../datasets/data/clayton_doe.csv")
}

#[test]
fn usage_errors_exit_2_and_help_documents_exit_codes() {
    millcomp().args(["datasets", "frobnicate"]).assert().code(2);
    millcomp()
        .arg("--help")
        .assert()
        .success()
        .stdout(predicate::str::contains("Exit status"));
}

/// `datasets figures --json`: a list of objects with name, published, millcomp, label, fitted_on, and
/// a reason exactly where the figure disagrees; every name unique, every fitted_on name a figure, and
/// a figure in its own fitted_on "calibrated to".
#[test]
fn figures_json_lists_each_figure_with_its_label_and_what_it_was_fitted_on() {
    let doc = run_json(&["datasets", "figures"]);
    let figs = doc.as_array().expect("a list");
    let names: std::collections::BTreeSet<&str> =
        figs.iter().map(|f| f["name"].as_str().unwrap()).collect();
    assert_eq!(names.len(), figs.len(), "names unique");
    for f in figs {
        let name = f["name"].as_str().unwrap();
        for key in ["published", "millcomp", "computed", "command", "source"] {
            assert!(!f[key].is_null(), "{name}: {key}");
        }
        assert!(f["published"]["text"].is_string() && f["millcomp"]["text"].is_string());
        let label = f["label"].as_str().unwrap();
        assert!(
            ["predicted", "calibrated to", "disagrees"].contains(&label),
            "{name}: {label}"
        );
        assert_eq!(f["reason"].is_string(), label == "disagrees", "{name}");
        let fitted: Vec<&str> = f["fitted_on"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_str().unwrap())
            .collect();
        for n in &fitted {
            assert!(names.contains(n), "{name}: fitted_on {n}");
        }
        if fitted.contains(&name) {
            assert_eq!(label, "calibrated to", "{name}");
        }
        let computed = f["computed"].as_str().unwrap();
        assert!(
            computed == "live" || computed.contains("checked by `recorded_"),
            "{name}: {computed}"
        );
    }
    // fitting data are calibrated by definition (issue 50): the Table 3-3 analysis too; W disagrees
    let by = |n: &str| figs.iter().find(|f| f["name"] == n).unwrap();
    assert_eq!(by("table_3_3_x_force_terms")["label"], "calibrated to");
    assert_eq!(by("w_6061")["label"], "disagrees");
    assert_eq!(by("groove_20deg_uncompensated")["label"], "calibrated to");
}

#[test]
fn figures_markdown_and_json_together_is_an_error() {
    millcomp()
        .args(["datasets", "figures", "--markdown", "--json"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "--markdown and --json: choose one",
        ));
}
