//! End-to-end tests of the verbs on measured records (issue 17): the real records in `datasets
//! list`, `--columns`, the record verbs' JSON, and bad input (a mapping to a column that is not there,
//! a time column that goes backwards, a training range outside the record, units that disagree).

use crate::common::*;

use predicates::prelude::*;

const THERMAL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/real/fl_thermal/thermal_drift.csv"
);
const PHM_FORCES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/real/phm2010_c1/per_cut_force_features_c1.csv"
);
const PHM_WEAR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/real/phm2010_c1/per_cut_wear_c1.csv"
);

/// A small drift record: 200 rows every 60 s, speed steps, two temperatures, a drift that follows
/// the first one (2 µm/K) plus a speed-driven lag.
fn small_record(dir: &std::path::Path, backwards_at: Option<usize>) -> std::path::PathBuf {
    let name = if backwards_at.is_some() {
        "backwards.csv"
    } else {
        "record.csv"
    };
    let mut s = String::from("time_s,spindle_rpm,temp_a_C,temp_b_C,disp_um\n");
    let mut lag = 0.0;
    for i in 0..200 {
        let mut t = 60.0 * i as f64;
        if backwards_at == Some(i) {
            t -= 90.0;
        }
        let n = [0.0, 2000.0, 0.0, 3000.0][(i / 50) % 4];
        let a = 22.0 + 3.0 * (i as f64 / 60.0).sin();
        let b = 21.0 + 0.5 * (i as f64 / 13.0).cos();
        let y = 2.0 * (a - 22.0) + 0.8 * lag + 0.02 * ((i * 7 % 5) as f64 - 2.0);
        s.push_str(&format!("{t},{n},{a},{b},{y}\n"));
        lag += ((n / 1000.0) - lag) * (1.0 - (-60.0f64 / 1800.0).exp());
    }
    write(dir, name, &s)
}

#[test]
fn list_shows_the_real_records_apart() {
    let v = run_json(&["datasets", "list"]);
    let kinds: Vec<(&str, &str)> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|d| (d["name"].as_str().unwrap(), d["kind"].as_str().unwrap()))
        .collect();
    for name in [
        "fl_thermal_drift",
        "phm2010_c1_cut001_raw",
        "phm2010_c1_cut315_raw",
        "phm2010_c1_per_cut_forces",
        "phm2010_c1_per_cut_wear",
    ] {
        assert!(kinds.contains(&(name, "real")), "{name}: {kinds:?}");
    }
    assert!(kinds.contains(&("clayton_doe", "published")));
    assert!(kinds.contains(&("tool_wear", "synthetic")));
    millcomp()
        .args(["datasets", "list"])
        .assert()
        .success()
        .stdout(predicate::str::contains("REAL measured records"))
        .stdout(predicate::str::contains("fl_thermal_drift"));
    millcomp()
        .args(["datasets", "show", "fl_thermal_drift"])
        .assert()
        .success()
        .stdout(predicate::str::contains("CAIVIAC/FL_THERMAL"))
        .stdout(predicate::str::contains("MIT"));
}

#[test]
fn thermal_study_of_a_users_record_through_columns() {
    let dir = tempfile::tempdir().unwrap();
    let f = small_record(dir.path(), None);
    let plots = dir.path().join("plots");
    let v = run_json(&[
        "identify",
        "thermal",
        s(&f),
        "--columns",
        "t_s=time_s,speed_rpm=spindle_rpm,temp_c=temp_*_C,drift_um=disp_um",
        "--train",
        "0:60%",
        "--test",
        "60%:end",
        "--model",
        "temperature-stepwise,combined-1tau-stepwise",
        "--plots",
        s(&plots),
    ]);
    assert!(v["input"]["path"].as_str().unwrap().ends_with("record.csv"));
    assert!(v["input"].get("real").is_none());
    let ch = &v["channels"][0];
    assert_eq!(ch["channel"], "disp_um");
    assert_eq!(ch["chosen"]["model"], "combined-1tau-stepwise");
    assert!(ch["test_metrics"]["removed"].as_f64().unwrap() > 0.9);
    assert!(plots.join("thermal_disp_um_test.svg").exists());
    assert!(plots.join("thermal_disp_um_record.svg").exists());
}

#[test]
fn the_real_record_is_named_in_the_output() {
    // one channel, the cheapest structure: the point is the provenance line
    millcomp()
        .args([
            "identify",
            "thermal",
            THERMAL,
            "--columns",
            "t_s=time_s,temp_c=temp_t1_C+temp_t5_C,drift_um=disp_ch1_um",
            "--train",
            "0:50%",
            "--test",
            "50%:end",
            "--model",
            "temperature-stepwise",
        ])
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "REAL measured record `fl_thermal_drift`",
        ))
        .stdout(predicate::str::contains("MIT"));
}

#[test]
fn bad_input_names_the_column_or_the_range() {
    let dir = tempfile::tempdir().unwrap();
    let f = small_record(dir.path(), None);
    let base = [
        "identify",
        "thermal",
        s(&f),
        "--train",
        "0:50%",
        "--model",
        "temperature-stepwise",
        "--columns",
    ];
    // a mapping to a column that is not there
    let mut a = base.to_vec();
    a.push("t_s=time_s,temp_c=temp_*_C,drift_um=disp_ch9_um");
    millcomp()
        .args(&a)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("no column `disp_ch9_um`"))
        .stderr(predicate::str::contains("record.csv"));
    // units that disagree
    let mut a = base.to_vec();
    a.push("t_s=time_s,temp_c=temp_*_C,drift_um=temp_a_C");
    millcomp()
        .args(&a)
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "`drift_um` is in um but column `temp_a_C` is in c",
        ));
    // a time column that goes backwards: the file's column and the 1-based row
    let g = small_record(dir.path(), Some(17));
    millcomp()
        .args([
            "identify",
            "thermal",
            s(&g),
            "--columns",
            "t_s=time_s,temp_c=temp_*_C,drift_um=disp_um",
            "--train",
            "0:50%",
            "--model",
            "temperature-stepwise",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "column `time_s` read as `t_s`, row 18",
        ))
        .stderr(predicate::str::contains("backwards.csv"));
    // a training range outside the record
    millcomp()
        .args([
            "identify",
            "thermal",
            s(&f),
            "--columns",
            "t_s=time_s,temp_c=temp_*_C,drift_um=disp_um",
            "--train",
            "0:60h",
            "--model",
            "temperature-stepwise",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("--train 0:60h"))
        .stderr(predicate::str::contains("after the record's end"));
    // wear: a test range beyond the last cut
    millcomp()
        .args([
            "identify",
            "wear",
            PHM_FORCES,
            "--columns",
            "cut=run,force_n=force_y__rms",
            "--train",
            "1:199",
            "--test",
            "200:400",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("--test 200:400"))
        .stderr(predicate::str::contains("cuts 1 to 315"));
}

#[test]
fn wear_and_flutes_on_the_phm_records() {
    let v = run_json(&[
        "identify",
        "wear",
        PHM_FORCES,
        "--join",
        PHM_WEAR,
        "--on",
        "run",
        "--columns",
        "cut=run,force_n=force_z__rms,vb_um=VB_flute_*",
        "--train",
        "1:199",
        "--test",
        "200:315",
    ]);
    assert_eq!(v["input"]["real"]["name"], "phm2010_c1_per_cut_forces");
    assert_eq!(v["joined"]["real"]["name"], "phm2010_c1_per_cut_wear");
    let ch = &v["channels"][0];
    assert_eq!(ch["test_cuts"][2].as_f64().unwrap(), 116.0);
    assert!(ch["test_metrics"]["rms_n"].as_f64().unwrap().is_finite());
    assert!(ch["force_vs_wear"]["report"]["params"]["k_n_per_um"].is_f64());
    let raw = |f: &str| {
        format!(
            "{}/datasets/real/phm2010_c1/{f}",
            env!("CARGO_MANIFEST_DIR")
        )
    };
    let v = run_json(&[
        "identify",
        "flutes",
        &raw("c1_cut001_mid.csv"),
        "--also",
        &raw("c1_cut315_mid.csv"),
        "--columns",
        "force_n=force_x_N",
        "--flutes",
        "3",
        "--speed-rpm",
        "10400",
        "--sample-rate-hz",
        "50000",
    ]);
    assert_eq!(v["files"][0]["channels"][0]["named"], "none");
    assert_eq!(v["files"][1]["channels"][0]["named"], "flute_runout");
}

#[test]
fn diagnose_record_prints_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let f = small_record(dir.path(), None);
    let v = run_json(&[
        "diagnose",
        "--record",
        s(&f),
        "--columns",
        "t_s=time_s,speed_rpm=spindle_rpm,temp_c=temp_*_C,drift_um=disp_um",
    ]);
    for k in ["initial_rms_um", "final_rms_um", "steps", "named"] {
        assert!(v.get(k).is_some(), "{k}");
    }
    assert_eq!(v["named"][0], "spindle_thermal_growth");
    // a record without the signal's role
    millcomp()
        .args(["diagnose", "--record", s(&f), "--columns", "t_s=time_s"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("no signal"));
}
