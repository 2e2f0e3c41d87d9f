//! Bad input names the file and the key, and builds nothing.

use std::path::Path;

use millcomp_runtime::{Controller, Program, RuntimeError};

use crate::common;

fn program_text() -> String {
    std::fs::read_to_string(common::data("ramp_20deg.toml")).unwrap()
}

/// The error (with its causes) of building from the test bundle and `program` written to a file.
fn error_with_program(program: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("job.toml");
    std::fs::write(&path, program).unwrap();
    Controller::from_files(&common::data("bundle_s7.toml"), &path)
        .unwrap_err()
        .chain()
}

#[test]
fn a_bad_program_names_the_file_and_the_key() {
    let base = program_text();
    for (edit, key) in [
        (base.replace("dt_s = 5e-5", "dt_s = 0.0"), "controller.dt_s"),
        (
            base.replace("horizon = 20", "horizon = 0"),
            "controller.horizon",
        ),
        (base.replace("kind = \"mpc\"", "kind = \"lqr\""), "lqr"),
        (base.replace("tilt_deg", "tilt"), "tilt"),
        (
            base.replace(
                "budget = { kind = \"iterations\" }",
                "budget = { kind = \"wall_clock\", fraction = 1.5 }",
            ),
            "controller.budget.fraction",
        ),
        (
            base.replace(
                "budget = { kind = \"iterations\" }",
                "budget = { kind = \"iterations\", max_iter = 0 }",
            ),
            "controller.budget.max_iter",
        ),
        (base.replace("to_um = 80.0", "to_um = 900.0"), "program"),
        (base.replace("S7", "6061"), "model.material"),
        // above the bundle's amplifier (1000 V): the none controller sent 5000 V (fuzz target
        // `program`, fuzz/regressions/program/)
        (
            format!("{base}touch_off = {{ bias_v = 5000.0, gauge_um = 0.0 }}\n"),
            "controller.touch_off.bias_v",
        ),
    ] {
        let msg = error_with_program(&edit);
        // the material is the bundle's key: its error names the bundle's file
        let file = if key == "model.material" {
            "bundle_s7.toml"
        } else {
            "job.toml"
        };
        assert!(
            msg.contains(file) && msg.contains(key),
            "`{key}` not named: {msg}"
        );
    }
}

#[test]
fn a_missing_or_wrong_bundle_names_the_file() {
    let program = common::data("ramp_20deg.toml");
    let err = Controller::from_files(Path::new("no/such/bundle.toml"), &program).unwrap_err();
    assert!(
        err.chain().contains("no/such/bundle.toml"),
        "{}",
        err.chain()
    );
    // a program file given as the bundle: not a model file
    let err = Controller::from_files(&program, &program).unwrap_err();
    assert!(matches!(err, RuntimeError::Model(_)));
    assert!(err.chain().contains("ramp_20deg.toml"), "{}", err.chain());
    // a bundle without the force model the plan needs: the key is named
    let text = std::fs::read_to_string(common::data("bundle_s7.toml")).unwrap();
    let mut doc: toml::Table = toml::from_str(&text).unwrap();
    doc["model"].as_table_mut().unwrap().remove("force");
    let cut = toml::to_string(&doc).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no_force.toml");
    std::fs::write(&path, cut).unwrap();
    let err = Controller::from_files(&path, &program).unwrap_err().chain();
    assert!(
        err.contains("no_force.toml") && err.contains("model.force"),
        "{err}"
    );
}

#[test]
fn a_program_round_trips_through_its_text() {
    let p = Program::load(&common::data("ramp_20deg.toml")).unwrap();
    let again = Program::from_toml_str(&p.to_toml().unwrap(), Path::new("again.toml")).unwrap();
    assert_eq!(p, again);
}

/// A touch-off given after construction (`Controller::touched_off`) is checked as the program's is:
/// the controller holds its voltage until the first reading, so a NaN or out-of-range one would reach
/// the amplifier. Refused naming the key; the controller keeps the touch-off it had.
#[test]
fn a_touch_off_outside_the_amplifiers_range_is_refused_and_the_old_one_kept() {
    use millcomp_mpc::groove::TouchOff;
    use millcomp_runtime::{ControllerKind, Measurement};
    let bundle = millcomp_runtime::load_bundle(&common::data("bundle_s7.toml")).unwrap();
    let mut program = Program::load(&common::data("ramp_20deg.toml")).unwrap();
    program.controller.kind = ControllerKind::PidTuned;
    let mut c = Controller::from_bundle(&bundle, &program).unwrap();
    c.touched_off(TouchOff {
        bias_v: 150.0,
        gauge_um: 2.0,
    })
    .unwrap();
    // the bundle's amplifier reaches 1000 V (tests/data/bundle_s7.toml): its top is allowed
    c.touched_off(TouchOff {
        bias_v: 1000.0,
        gauge_um: 2.0,
    })
    .unwrap();
    c.touched_off(TouchOff {
        bias_v: 150.0,
        gauge_um: 2.0,
    })
    .unwrap();
    for (bias_v, gauge_um, key) in [
        (f64::NAN, 0.0, "touch_off.bias_v"),
        (-1.0, 0.0, "touch_off.bias_v"),
        (1000.5, 0.0, "touch_off.bias_v"),
        (f64::INFINITY, 0.0, "touch_off.bias_v"),
        (100.0, f64::NAN, "touch_off.gauge_um"),
        (100.0, f64::NEG_INFINITY, "touch_off.gauge_um"),
    ] {
        let e = c.touched_off(TouchOff { bias_v, gauge_um }).unwrap_err();
        assert!(
            matches!(&e, RuntimeError::InvalidValue { key: k, .. } if k == key),
            "{bias_v} V, {gauge_um} µm: {e}"
        );
        if key == "touch_off.bias_v" {
            assert!(e.to_string().contains("0 ..= 1000 V"), "{e}");
        }
        assert_eq!(c.touch_off().bias_v, 150.0);
        assert_eq!(c.touch_off().gauge_um, 2.0);
    }
    // before the first reading the PI holds the touch-off it kept
    assert_eq!(c.step(&Measurement::NONE).voltage_v, 150.0);
}
