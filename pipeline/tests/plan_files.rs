//! The plan's schema and the measured files' readers: clear errors naming the file and key.

use millcomp_pipeline::plan::Plan;

#[test]
fn a_plan_names_its_bad_key_and_value() {
    let p = std::path::Path::new("/tmp/plan.toml");
    let e = Plan::from_toml_str("[compare]\ntolerance_pp_um = -1\n", p).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("/tmp/plan.toml") && msg.contains("compare.tolerance_pp_um"),
        "{msg}"
    );
    let e = Plan::from_toml_str("[measure]\nspindle = \"s.csv\"\n", p).unwrap_err();
    assert!(e.to_string().contains("spindle"), "{e}");
    let e = Plan::from_toml_str("seed = \"one\"\n", p).unwrap_err();
    assert!(e.to_string().contains("seed"), "{e}");
    // relative paths are the plan's directory's
    let ok = Plan::from_toml_str("[diagnose]\nsession = \"s.toml\"\n", p).unwrap();
    assert_eq!(
        ok.diagnose.session.unwrap(),
        std::path::Path::new("/tmp/s.toml")
    );
}

#[test]
fn a_measured_file_error_names_file_column_and_row() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("step.csv");
    std::fs::write(&f, "t_s,u_v,y_um\n0,20,0.1\n0.001,abc,0.2\n").unwrap();
    let e = millcomp_pipeline::files::read_step(&f).unwrap_err();
    let msg = format!("{e}");
    assert!(msg.contains("step.csv") && msg.contains("u_v"), "{msg}");
}
