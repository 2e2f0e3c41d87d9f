//! Across units (issue 50, "across tools"): `identify … --columns unit=COLUMN` and `--also` with two or
//! more units — each unit's fit, the between-unit scatter, the new unit's prediction interval (JSON
//! `new_unit`) — the one-unit statement, and bad input.

use crate::common::*;

use predicates::prelude::*;

fn phm(cutter: &str, what: &str) -> String {
    repo(&format!(
        "datasets/real/phm2010_{cutter}/per_cut_{what}_{cutter}.csv"
    ))
}

/// `identify wear` of the PHM cutters `cutters` (FILE, then `--also`), each file joined to its wear file,
/// the cutter read from the `case` column.
fn wear_args(cutters: &[&str], channel: &str) -> Vec<String> {
    let mut a = vec![
        "identify".to_string(),
        "wear".into(),
        phm(cutters[0], "force_features"),
        "--join".into(),
        phm(cutters[0], "wear"),
    ];
    for c in &cutters[1..] {
        a.extend([
            "--also".into(),
            phm(c, "force_features"),
            "--join".into(),
            phm(c, "wear"),
        ]);
    }
    a.extend([
        "--on".into(),
        "run".into(),
        "--columns".into(),
        format!("cut=run,force_n={channel},vb_um=VB_flute_*,unit=case"),
        "--laws".into(),
        "linear".into(),
    ]);
    a
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn quantity<'a>(across: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    across["quantities"]
        .as_array()
        .unwrap()
        .iter()
        .find(|q| q["name"] == name)
        .unwrap_or_else(|| panic!("{name} in {across}"))
}

#[test]
fn two_cutters_give_each_fit_the_scatter_and_a_new_cutter_interval() {
    let v = run_json(&strs(&wear_args(&["c1", "c4"], "force_y__rms")));
    assert_eq!(v["unit_column"], "case");
    let units = v["units"].as_array().unwrap();
    assert_eq!(units.len(), 2);
    assert_eq!(units[0]["unit"], "1");
    assert_eq!(units[1]["unit"], "4");
    let a = &v["across_units"][0];
    assert_eq!(a["channel"], "force_y__rms");
    // the force is predicted in the middle of the wear both cutters saw (40–165 and 24–203 µm)
    assert_eq!(a["at_vb_um"].as_f64().unwrap(), 100.0);
    let k = quantity(a, "k_n_per_um");
    // each cutter's slope as identify/tests/golden/meta_phm_c1_c4.json has it (statsmodels OLS with
    // its Newey–West covariance on the same files: 0.157117 and 0.092415)
    let per: Vec<f64> = k["per_unit"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["value"].as_f64().unwrap())
        .collect();
    assert!((per[0] - 0.157_116_851).abs() < 1e-8, "{per:?}");
    assert!((per[1] - 0.092_414_615).abs() < 1e-8, "{per:?}");
    assert_eq!(k["tau2_method"], "der_simonian_laird");
    assert!(k["tau"].as_f64().unwrap() > 0.03, "{k}");
    let nu = &v["new_unit"]["force_y__rms"]["k_n_per_um"];
    let pi = nu["pi95"].as_array().unwrap();
    let (lo, hi) = (pi[0].as_f64().unwrap(), pi[1].as_f64().unwrap());
    assert!(lo < per[1] && per[0] < hi, "{nu}");
    assert_eq!(nu["df"], 1);
    assert!(v["new_unit"]["force_y__rms"]["force_at_vb_100um_n"].is_object());
    // the text report: each unit's section, then the across-units table
    let out = millcomp()
        .args(strs(&wear_args(&["c1", "c4"], "force_y__rms")))
        .assert()
        .success();
    let text = String::from_utf8_lossy(&out.get_output().stdout).to_string();
    for want in [
        "=== unit `1` (case = 1): 315 cuts ===",
        "=== unit `4` (case = 4): 315 cuts ===",
        "ACROSS UNITS",
        "DerSimonian–Laird",
        "NEW UNIT [95 % prediction]",
        "2 units: the new unit's interval uses t(1 df) = 12.71",
    ] {
        assert!(text.contains(want), "{want} not in\n{text}");
    }
}

#[test]
fn one_cutter_says_its_interval_does_not_cover_other_cutters() {
    let v = run_json(&strs(&wear_args(&["c1"], "force_y__rms")));
    let notes: Vec<&str> = v["notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("one unit (`1`)") && n.contains("do not cover another unit")),
        "{notes:?}"
    );
    assert!(v.get("new_unit").is_none());
    // and so does a fit without a unit column
    millcomp()
        .args(["identify", "force", CLAYTON, "--material", "6061"])
        .assert()
        .success()
        .stdout(predicate::str::contains("note: one unit: these intervals"));
}

/// Three walls' load–deflection tests in one file, the wall in a text column: the generic path
/// (`identify_units`) of every target but the record studies.
#[test]
fn walls_in_one_file_are_fitted_one_by_one_and_combined() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("wall,force_n,deflection_um\n");
    for (w, k) in [("A", 0.24), ("B", 0.26), ("C", 0.25)] {
        for i in 1..=10 {
            let f = 0.1 * i as f64;
            let d = 0.5 + f / k + 0.02 * wiggle(i + 31 * w.len() + (k * 1000.0) as usize);
            csv.push_str(&format!("{w},{f},{d}\n"));
        }
    }
    let f = write(dir.path(), "walls.csv", &csv);
    let v = run_json(&["identify", "wall", s(&f), "--columns", "unit=wall"]);
    assert_eq!(v["target"], "wall");
    assert_eq!(v["unit_column"], "wall");
    assert_eq!(v["units"].as_array().unwrap().len(), 3);
    let q = quantity(&v["across_units"], "wall_stiffness_n_per_um");
    let m = q["mean"].as_f64().unwrap();
    assert!((m - 0.25).abs() < 0.01, "{q}");
    let pi = v["new_unit"]["wall_stiffness_n_per_um"]["pi95"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect::<Vec<_>>();
    assert!(pi[0] < 0.24 && 0.26 < pi[1], "{pi:?}");
    assert_eq!(v["new_unit"]["wall_stiffness_n_per_um"]["df"], 2);
    // Paule–Mandel on request
    let v = run_json(&[
        "identify",
        "wall",
        s(&f),
        "--columns",
        "unit=wall",
        "--tau2",
        "pm",
    ]);
    assert_eq!(
        quantity(&v["across_units"], "wall_stiffness_n_per_um")["tau2_method"],
        "paule_mandel"
    );
    // a model file holds one unit's fit
    millcomp()
        .args([
            "identify",
            "wall",
            s(&f),
            "--columns",
            "unit=wall",
            "--save",
            s(&dir.path().join("m.toml")),
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("3 units were fitted"));
    assert!(!dir.path().join("m.toml").exists());
}

/// Deterministic zero-mean pseudo-noise in [-1, 1].
fn wiggle(i: usize) -> f64 {
    let x = (i as f64 * 12.9898).sin() * 43758.5453;
    2.0 * (x - x.floor()) - 1.0
}

#[test]
fn bad_unit_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(
        dir.path(),
        "walls.csv",
        "wall,force_n,deflection_um\n1,0.1,0.9\n1,0.2,1.3\n,0.3,1.7\n2,0.1,0.9\n",
    );
    millcomp()
        .args(["identify", "wall", s(&f), "--columns", "unit=wall"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("walls.csv"))
        .stderr(predicate::str::contains(
            "column `wall` read as `unit`, row 3: the cell is empty",
        ));
    let g = write(
        dir.path(),
        "ok.csv",
        "wall,force_n,deflection_um\n1,0.1,0.9\n1,0.2,1.3\n1,0.3,1.7\n",
    );
    millcomp()
        .args([
            "identify",
            "wall",
            s(&g),
            "--columns",
            "unit=wall",
            "--tau2",
            "reml",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--tau2"))
        .stderr(predicate::str::contains("dl (DerSimonian–Laird)"));
    // one --join per file
    let mut a = wear_args(&["c1", "c4"], "force_y__rms");
    let j = a.iter().rposition(|x| x == "--join").unwrap();
    a.drain(j..j + 2);
    millcomp()
        .args(strs(&a))
        .assert()
        .failure()
        .stderr(predicate::str::contains("one --join per file"));
    // the same unit in two files
    millcomp()
        .args([
            "identify",
            "wall",
            s(&g),
            "--also",
            s(&g),
            "--columns",
            "unit=wall",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("unit `1` is in"));
    // a force at a stated wear for a new unit needs two units
    let mut a = wear_args(&["c1"], "force_y__rms");
    a.extend(["--at-vb-um".into(), "100".into()]);
    millcomp()
        .args(strs(&a))
        .assert()
        .failure()
        .stderr(predicate::str::contains("two or more units"));
}
