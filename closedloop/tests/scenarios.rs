//! Every scenario file in datasets/scenarios parses and validates; bad input gives errors naming the key.

use millcomp_closedloop::{ClosedLoopError, ControllerKind, Scenario};

#[test]
fn all_shipped_scenarios_load() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets/scenarios");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let s = Scenario::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            for c in &s.controllers {
                c.parse::<ControllerKind>().unwrap();
            }
            n += 1;
        }
    }
    assert!(n >= 6, "{n} scenarios");
}

fn key_of(e: ClosedLoopError) -> String {
    match e {
        ClosedLoopError::InvalidConfig { key, .. } => key,
        other => panic!("expected InvalidConfig, got {other:?}"),
    }
}

#[test]
fn bad_input_names_the_key() {
    let base = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../datasets/scenarios/groove_s7_20deg.toml"),
    )
    .unwrap();
    // unknown controller
    let t = base.replace("controllers = [\"none\"", "controllers = [\"lqg\"");
    assert_eq!(
        key_of(Scenario::from_toml_str(&t, "t").unwrap_err()),
        "controllers[0]"
    );
    assert!(matches!(
        "lqg".parse::<ControllerKind>(),
        Err(ClosedLoopError::UnknownController { .. })
    ));
    // horizon 0
    let t = base.replace("horizon = 20", "horizon = 0");
    assert_eq!(
        key_of(Scenario::from_toml_str(&t, "t").unwrap_err()),
        "control.horizon"
    );
    // limits min > max and negative weights in an MPC override
    let mpc = "\n[control.mpc]\nhorizon = 20\n[control.mpc.weights]\noutput = [0.0, 1.0]\ninput_rate = [1e-4]\n[control.mpc.limits]\nu_min = [0.0]\nu_max = [1000.0]\ndu_max = [100.0]\n";
    let t = format!("{base}{mpc}");
    assert!(Scenario::from_toml_str(&t, "t").is_ok());
    let bad = t.replace("u_min = [0.0]", "u_min = [1200.0]");
    assert_eq!(
        key_of(Scenario::from_toml_str(&bad, "t").unwrap_err()),
        "control.mpc.limits.u_min[0]"
    );
    let bad = t.replace("output = [0.0, 1.0]", "output = [0.0, -1.0]");
    assert_eq!(
        key_of(Scenario::from_toml_str(&bad, "t").unwrap_err()),
        "control.mpc.weights.output[1]"
    );
    // unknown key → parser error naming it
    let bad = base.replace("tilt_deg = 20.0", "tilt_deg = 20.0\ntilt = 3");
    assert!(
        Scenario::from_toml_str(&bad, "t")
            .unwrap_err()
            .to_string()
            .contains("tilt")
    );
}

#[test]
fn identified_model_paths_are_checked() {
    let mut s = crate::common::scenario("groove_s7_20deg.toml");
    s.control.spindle_model = Some("/nonexistent/spindle.toml".into());
    match millcomp_closedloop::run_scenario(&s, ControllerKind::Mpc) {
        Err(ClosedLoopError::Io { path, .. }) => assert_eq!(path, "/nonexistent/spindle.toml"),
        other => panic!("{other:?}"),
    }
}
