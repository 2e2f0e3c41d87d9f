//! `millcomp identify force TABLE --diagnose` (issue 50): the force disagreements diagnosed on the
//! published Table 3-3, and the library's workflow on synthetic Table-3-3-shaped data with and
//! without a known ploughing force.

use crate::common::{CLAYTON, json_of, millcomp, s, write};

#[test]
fn table_3_3_diagnosis_reports_nominal_candidates_and_groove_prediction() {
    let v = json_of(&[
        "--json", "identify", "force", CLAYTON, "--material", "6061", "--diagnose",
    ]);
    let d = &v["diagnosis"];
    // the nominal fit is `identify force`'s own (its doc example: W = 2049 MPa [1691, 2407])
    let w = d["nominal"]["w_mpa"].as_f64().unwrap();
    assert!((w - 2049.0).abs() < 1.0, "{w}");
    assert_eq!(d["n_obs"], 24);
    assert_eq!(d["candidates"].as_array().unwrap().len(), 7);
    for c in d["candidates"].as_array().unwrap() {
        assert_eq!(c["dof"], serde_json::json!([1, 22]), "{c}");
        assert!(!c["source"].as_str().unwrap().is_empty());
    }
    let p = &v["predictions"][0];
    assert_eq!(p["measured"]["value"], 8.53);
    assert_eq!(p["transfers"].as_array().unwrap().len(), 3);
}

#[test]
fn a_bad_table_names_file_column_and_row() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(
        dir.path(),
        "peaks.csv",
        "depth_um,upfeed_um,speed_rpm,max_fx_n\n100,10,10000,1.0\n200,20,10000,nan\n100,20,20000,2.0\n200,10,20000,2.0\n",
    );
    let out = millcomp()
        .args(["identify", "force", s(&f), "--material", "6061", "--diagnose"])
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("max_fx_n") && err.contains("row 2"), "{err}");
    // --diagnose is for `identify force`
    millcomp()
        .args(["identify", "stiffness", s(&f), "--diagnose"])
        .assert()
        .failure();
}
