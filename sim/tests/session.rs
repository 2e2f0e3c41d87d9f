//! Session files and the measured-groove CSV contract (DESIGN.md).
mod common;

use millcomp_sim::SimError;
use millcomp_sim::sensors::NoiseSpec;
use millcomp_sim::session::{CSV_COLUMNS, Session, SimOptions, simulate_session, write_csv};

const EXAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../datasets/sessions/example.toml"
);

#[test]
fn example_session_parses_and_simulates() {
    let s = Session::from_path(EXAMPLE).unwrap();
    let pts = simulate_session(&s, &SimOptions::default()).unwrap();
    // 4 grooves × (20 mm / 0.5 mm + 1) points
    assert_eq!(pts.len(), 4 * 41);
    // t_s monotone within each groove, groove ids 0..3
    for g in 0..4 {
        let ts: Vec<f64> = pts
            .iter()
            .filter(|p| p.groove_id == g)
            .map(|p| p.t_s)
            .collect();
        assert!(ts.windows(2).all(|w| w[1] > w[0]));
    }
    // feed = upfeed·rpm: 100 mm/min; groove 1 starts after groove 0 (12 s) + 600 s pause
    assert_eq!(pts[0].feed_mm_min, 100.0);
    let g1 = pts.iter().find(|p| p.groove_id == 1).unwrap();
    assert!((g1.t_s - 612.0).abs() < 1e-9);
    // the last groove starts at 3000 s as planned
    assert!((pts.iter().find(|p| p.groove_id == 3).unwrap().t_s - 3000.0).abs() < 1e-9);
    let mut buf = Vec::new();
    write_csv(&pts, &mut buf).unwrap();
    let text = String::from_utf8(buf).unwrap();
    assert_eq!(text.lines().next().unwrap(), CSV_COLUMNS.join(","));
    assert_eq!(text.lines().count(), pts.len() + 1);
}

#[test]
fn noise_free_is_the_nominal_prediction_and_noise_is_seeded() {
    let s = Session::from_path(EXAMPLE).unwrap();
    let a = simulate_session(&s, &SimOptions::default()).unwrap();
    let b = simulate_session(&s, &SimOptions::default()).unwrap();
    assert_eq!(a, b);
    let n = SimOptions {
        noise: Some(NoiseSpec {
            seed: 3,
            sigma: 0.2,
        }),
    };
    let c = simulate_session(&s, &n).unwrap();
    let d = simulate_session(&s, &n).unwrap();
    assert_eq!(c, d);
    let rms = (a
        .iter()
        .zip(&c)
        .map(|(x, y)| (x.depth_meas_um - y.depth_meas_um).powi(2))
        .sum::<f64>()
        / a.len() as f64)
        .sqrt();
    assert!((rms - 0.2).abs() < 0.05, "{rms}");
}

#[test]
fn uncompensated_groove_error_in_session_matches_the_stage() {
    // A single 0–80 µm groove with no effects: the deep-end error is the ≈ 16 µm deflection (000 §6.3)
    let s = Session::from_toml_str(
        r#"
[tool]
wearland_um = 8.0
[material]
name = "S7"
[force_model]
force_scale = 3.7396
[[plan]]
kind = "groove"
spindle_rpm = 10000
upfeed_um = 10
tilt_deg = 20
length_mm = 20
measure_every_mm = 1
depth = { kind = "ramp", from_um = 0, to_um = 80 }
"#,
    )
    .unwrap();
    let p = simulate_session(&s, &SimOptions::default()).unwrap();
    let last = p.last().unwrap();
    let err = last.depth_cmd_um - last.depth_meas_um;
    assert!(
        (err - 17.0).abs() / 17.0 < common::GROOVE_DEFLECTION_REL,
        "{err}"
    );
    assert_eq!(last.coolant_on, 0);
    assert!((last.cut_length_mm - 20.0).abs() < 0.05);
}

fn err_key(text: &str) -> String {
    match Session::from_toml_str(text) {
        Err(SimError::Session { key, .. }) => key,
        other => panic!("expected a session error, got {other:?}"),
    }
}

const HEAD: &str = "[tool]\n[material]\nname = \"S7\"\n";

#[test]
fn errors_name_the_key() {
    let g = |extra: &str| {
        format!(
            "{HEAD}[[plan]]\nkind = \"groove\"\nspindle_rpm = 10000\nupfeed_um = 10\ntilt_deg = 20\nlength_mm = 20\nmeasure_every_mm = 1\ndepth = {{ kind = \"constant\", depth_um = 40 }}\n{extra}"
        )
    };
    assert_eq!(
        err_key(&g("").replace("tilt_deg = 20", "tilt_deg = 90")),
        "plan[0].tilt_deg"
    );
    assert_eq!(
        err_key(&g("").replace("spindle_rpm = 10000", "spindle_rpm = 0")),
        "plan[0].spindle_rpm"
    );
    assert_eq!(
        err_key(&g("").replace("depth_um = 40", "depth_um = 500")),
        "plan[0].depth.depth_um"
    );
    assert_eq!(err_key(&g("bogus = 1")), "bogus");
    assert_eq!(err_key(&g("").replace("length_mm = 20\n", "")), "length_mm");
    assert_eq!(
        err_key(&g("[[effects]]\nname = \"gremlins\"")),
        "effects[0].name"
    );
    assert_eq!(
        err_key(&g(
            "[[effects]]\nname = \"tool_wear\"\n[effects.params]\nwear = 3"
        )),
        "effects[0].params.wear"
    );
    assert_eq!(
        err_key(&format!(
            "[tool]\nwearland_um = -1\n[material]\nname = \"S7\"\n{}",
            &g("")[HEAD.len()..]
        )),
        "tool.wearland_um"
    );
    assert_eq!(
        err_key(&format!("{}[stiffness]\nradial_n_per_um = -0.1\n", g(""))),
        "stiffness.radial_n_per_um"
    );
    assert!(matches!(
        Session::from_path("/nonexistent/x.toml"),
        Err(SimError::Io { .. })
    ));
}
