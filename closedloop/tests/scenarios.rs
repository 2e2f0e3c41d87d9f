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
    // a touch-off bias below 0 V, and one that is neither rest, auto nor volts
    let bias = |v: &str| {
        base.replace(
            "horizon = 20",
            &format!("horizon = 20\ntouch_off_bias = {v}"),
        )
    };
    assert!(Scenario::from_toml_str(&bias("{ volts = 120.0 }"), "t").is_ok());
    assert_eq!(
        key_of(Scenario::from_toml_str(&bias("{ volts = -5.0 }"), "t").unwrap_err()),
        "control.touch_off_bias.volts"
    );
    // above the amplifier: refused when the run starts (the amplifier's range is the bundle's)
    let high = Scenario::from_toml_str(&bias("{ volts = 1200.0 }"), "t").unwrap();
    assert_eq!(
        key_of(millcomp_closedloop::run_scenario(&high, ControllerKind::None).unwrap_err()),
        "control.touch_off_bias.volts"
    );
    // the thin wall has no PZT touch-off
    let wall = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../datasets/scenarios/thin_wall_h59.toml"),
    )
    .unwrap()
    .replace("[control]", "[control]\ntouch_off_bias = \"auto\"");
    assert_eq!(
        key_of(Scenario::from_toml_str(&wall, "t").unwrap_err()),
        "control.touch_off_bias"
    );
    let e = Scenario::from_toml_str(&bias("\"sometimes\""), "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("touch_off_bias") && e.contains("sometimes"),
        "{e}"
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

/// `truth.draw_tool` draws a different fresh tool per seed; `truth.tool = {…}` is applied as given and
/// wins over `draw_tool`; neither leaves the catalogue tool (`millcomp_sim::tool_variation`).
#[test]
fn truth_tool_variation_keys_reach_the_truth_force_model() {
    use millcomp_closedloop::groove::groove_truth;
    use millcomp_sim::force::S7_GROOVE_FORCE_SCALE;
    let base = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../datasets/scenarios/groove_s7_20deg.toml"),
    )
    .unwrap();
    let with = |seed: u64, truth_keys: &str| {
        let t = base
            .replace("seed = 20", &format!("seed = {seed}"))
            .replace("[truth]\n", &format!("[truth]\n{truth_keys}\n"));
        let s = Scenario::from_toml_str(&t, "t").unwrap();
        groove_truth(&s)
    };
    let catalogue = with(1, "").unwrap().force_model;
    assert_eq!(
        (catalogue.tool.wearland_um, catalogue.tool.runout_um),
        (8.0, 10.0)
    );
    assert_eq!(catalogue.params.force_scale, S7_GROOVE_FORCE_SCALE);

    // drawn: one tool per seed, each differing from the catalogue tool, within the documented spreads
    let a = with(1, "draw_tool = true").unwrap().force_model;
    let b = with(2, "draw_tool = true").unwrap().force_model;
    assert_ne!(a, b);
    for m in [&a, &b] {
        assert_ne!(*m, catalogue);
        assert!((m.tool.wearland_um - 8.0).abs() <= 1.0);
        assert!((m.tool.runout_um - 10.0).abs() <= 2.0);
        assert_eq!(m.material, catalogue.material);
    }
    assert_eq!(a, with(1, "draw_tool = true").unwrap().force_model);

    // explicit: applied as given, and it wins over draw_tool
    let keys = "tool = { wearland_offset_um = -1.0, runout_offset_um = -2.0, force_factor = 1.1 }";
    for extra in ["", "\ndraw_tool = true"] {
        let m = with(1, &format!("{keys}{extra}")).unwrap().force_model;
        assert_eq!((m.tool.wearland_um, m.tool.runout_um), (7.0, 8.0));
        assert!((m.params.force_scale - 1.1 * S7_GROOVE_FORCE_SCALE).abs() < 1e-12);
    }
    // a partial table keeps the other deviations at the catalogue's
    let m = with(1, "tool = { runout_offset_um = 1.5 }")
        .unwrap()
        .force_model;
    assert_eq!((m.tool.wearland_um, m.tool.runout_um), (8.0, 11.5));
    assert_eq!(m.params.force_scale, S7_GROOVE_FORCE_SCALE);
    // a tool with no wearland left is refused, naming the tool parameter
    let e = with(1, "tool = { wearland_offset_um = -9.0 }").unwrap_err();
    assert!(
        millcomp_closedloop::error_chain(&e).contains("wearland_um"),
        "{}",
        millcomp_closedloop::error_chain(&e)
    );
}
