//! Session files and the measured-groove CSV contract (DESIGN.md).
use crate::common;

use millcomp_sim::SimError;
use millcomp_sim::sensors::NoiseSpec;
use millcomp_sim::session::{Session, SimOptions, check_groove_points, simulate_session};

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
    // (the CSV text of these points is the datasets crate's: `contracts` tests)
}

#[test]
fn timeline_and_contexts_of_the_example_plan() {
    let s = Session::from_path(EXAMPLE).unwrap();
    let tl = s.timeline();
    // example.toml: groove 0 (20 mm at 100 mm/min = 12 s) from 0 s, pause 600 s, groove 1 at 612 s
    // (12 s), pause 1200 s, groove 2 at 1824 s (12 s), groove 3 at start_s = 3000 s
    let expected = [0.0, 12.0, 612.0, 624.0, 1824.0, 3000.0];
    assert_eq!(tl.item_start_s.len(), expected.len());
    for (t, e) in tl.item_start_s.iter().zip(expected) {
        // 1e-9 s: the durations are 20 mm / (100/60 mm/s), exact up to round-off
        assert!((t - e).abs() < 1e-9, "{:?}", tl.item_start_s);
    }
    // coolant switched on with groove 0 and never again; the spindle runs 10 000 rpm throughout
    assert_eq!(tl.coolant_events, vec![(0.0, true)]);
    assert_eq!(tl.spindle_events.len(), 6);
    assert!(tl.spindle_events.iter().all(|e| e.1 == 10_000.0));
    let ctx = s.contexts().unwrap();
    assert_eq!(ctx.timeline, tl);
    assert_eq!(ctx.len(), 4 * 41);
    // the simulated points are the contexts plus the session's effects (noise-free)
    let pts = simulate_session(&s, &SimOptions::default()).unwrap();
    let effects = s.effects().unwrap();
    for (i, (p, c)) in pts.iter().zip(&ctx.points).enumerate() {
        assert_eq!((p.groove_id, p.t_s, p.x_mm), (c.groove_id, c.t_s, c.x_mm));
        assert_eq!(p.coolant_on, u8::from(c.coolant_on));
        let e = ctx.effect_context(i);
        assert_eq!(e.coolant_events.len(), c.n_coolant_events);
        let offset: f64 = effects.iter().map(|f| f.depth_offset_um(&e)).sum();
        assert_eq!(p.depth_meas_um, c.depth_nominal_um + offset);
        assert_eq!(c.depth_actual_um, c.depth_nominal_um.max(0.0));
    }
    let wear = &effects[1];
    assert_eq!(wear.name(), "tool_wear");
    assert_eq!(ctx.offsets_um(wear.as_ref()).len(), ctx.len());
}

/// A switch made by the item after a groove happens at the groove's end, after its last point:
/// that point (cut at the end, x = length) keeps the state the groove was cut in. A groove's own
/// switch, at its start, counts from its first point.
#[test]
fn a_switch_after_a_groove_is_not_seen_by_its_last_point() {
    use millcomp_sim::session::PlanItem;
    let mut s = Session::from_path(EXAMPLE).unwrap();
    // example.toml: groove 0 switches the coolant on at 0 s; the 600 s pause after it now switches
    // it off and stops the spindle at 12 s, the end of groove 0
    let PlanItem::Pause(p) = &mut s.plan[1] else {
        panic!("example.toml's second item is a pause")
    };
    p.coolant = Some(false);
    p.speed_rpm = 0.0;
    let ctx = s.contexts().unwrap();
    assert_eq!(
        ctx.timeline.coolant_events,
        vec![(0.0, true), (ctx.timeline.item_start_s[1], false)]
    );
    let groove0: Vec<_> = ctx.points.iter().filter(|p| p.groove_id == 0).collect();
    let (first, last) = (groove0[0], groove0[groove0.len() - 1]);
    assert_eq!(last.t_s, ctx.timeline.item_start_s[1]);
    // the groove's own switch at its first point; not the pause's at its last
    assert!(first.coolant_on && last.coolant_on);
    assert_eq!((first.n_coolant_events, last.n_coolant_events), (1, 1));
    assert_eq!((first.n_spindle_events, last.n_spindle_events), (1, 1));
    // the next groove is cut after the switch
    let next = ctx.points.iter().find(|p| p.groove_id == 1).unwrap();
    assert!(!next.coolant_on);
    assert_eq!(next.n_coolant_events, 2);
}

#[test]
fn measured_points_are_checked_as_a_measurement() {
    let s = Session::from_path(EXAMPLE).unwrap();
    let pts = simulate_session(&s, &SimOptions::default()).unwrap();
    check_groove_points(&pts).unwrap();
    let point_err = |pts: &[millcomp_sim::session::GroovePoint]| match check_groove_points(pts) {
        Err(SimError::Point { row, column, .. }) => (row, column),
        other => panic!("expected a point error, got {other:?}"),
    };
    // rows are counted from 1: index 5 is row 6
    let mut back = pts.clone();
    back[5].t_s = back[4].t_s;
    assert_eq!(point_err(&back), (6, "t_s"));
    let mut nan = pts.clone();
    nan[7].depth_meas_um = f64::NAN;
    assert_eq!(point_err(&nan), (8, "depth_meas_um"));
    let mut flag = pts.clone();
    flag[0].coolant_on = 2;
    assert_eq!(point_err(&flag), (1, "coolant_on"));
    // a negative speed or feed is not a cut
    let mut speed = pts.clone();
    speed[3].speed_rpm = -speed[3].speed_rpm;
    assert_eq!(point_err(&speed), (4, "speed_rpm"));
    let mut feed = pts.clone();
    feed[2].feed_mm_min = 0.0;
    assert_eq!(point_err(&feed), (3, "feed_mm_min"));
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

/// One 20 mm groove, programmed 0–80 µm, in S7 at the thesis' force scale (wearland 8 µm,
/// 10 µm/rev), measured every mm, at `speed_rpm` and `tilt_deg`.
fn ramp_session(speed_rpm: f64, tilt_deg: f64) -> Session {
    Session::from_toml_str(&format!(
        r#"
[tool]
wearland_um = 8.0
[material]
name = "S7"
[force_model]
force_scale = 3.7396
[[plan]]
kind = "groove"
speed_rpm = {speed_rpm}
upfeed_um = 10
tilt_deg = {tilt_deg}
length_mm = 20
measure_every_mm = 1
depth = {{ kind = "ramp", from_um = 0, to_um = 80 }}
"#
    ))
    .unwrap()
}

#[test]
fn uncompensated_groove_error_in_session_matches_the_stage() {
    // A single 0–80 µm groove with no effects: the deep-end error is the ≈ 16 µm deflection (000 §6.3)
    let s = ramp_session(10_000.0, 20.0);
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

/// The key of a session that does not parse (unknown or missing key): the parser's error is the cause.
fn parse_err_key(text: &str) -> String {
    match Session::from_toml_str(text) {
        Err(SimError::SessionToml { key, .. }) => key,
        other => panic!("expected a session parse error, got {other:?}"),
    }
}

const HEAD: &str = "[tool]\n[material]\nname = \"S7\"\n";

#[test]
fn errors_name_the_key() {
    let g = |extra: &str| {
        format!(
            "{HEAD}[[plan]]\nkind = \"groove\"\nspeed_rpm = 10000\nupfeed_um = 10\ntilt_deg = 20\nlength_mm = 20\nmeasure_every_mm = 1\ndepth = {{ kind = \"constant\", depth_um = 40 }}\n{extra}"
        )
    };
    assert_eq!(
        err_key(&g("").replace("tilt_deg = 20", "tilt_deg = 90")),
        "plan[0].tilt_deg"
    );
    assert_eq!(
        err_key(&g("").replace("speed_rpm = 10000", "speed_rpm = 0")),
        "plan[0].speed_rpm"
    );
    assert_eq!(
        err_key(&g("").replace("depth_um = 40", "depth_um = 500")),
        "plan[0].depth.depth_um"
    );
    assert_eq!(parse_err_key(&g("bogus = 1")), "bogus");
    assert_eq!(
        parse_err_key(&g("").replace("length_mm = 20\n", "")),
        "length_mm"
    );
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
        Err(SimError::Io { ref path, ref source })
            if path == "/nonexistent/x.toml" && source.kind() == std::io::ErrorKind::NotFound
    ));
}

/// The static deflection solves `δ = c·F(d_cmd − δ)` at every point — also at the shallow start
/// of a 30° ramp, where the peak force jumps from 0 at first contact and the plain fixed-point
/// iteration oscillated between 0 and c·F(d_cmd) (it returned δ = 0 at 4 µm programmed depth).
#[test]
fn static_deflection_solves_its_fixed_point_at_shallow_depths() {
    let mut s = ramp_session(36_000.0, 30.0);
    s.tool.runout_um = 2.0;
    let model = s.force_model().unwrap();
    let c = s.stiffness().unwrap().z_compliance_um_per_n(30.0).unwrap();
    let ctx = s.contexts().unwrap();
    for p in &ctx.points {
        let delta = p.depth_cmd_um - p.depth_nominal_um;
        let f = model
            .peak_z_force_n(&millcomp_sim::force::CutConditions {
                depth_um: (p.depth_cmd_um - delta).max(0.0),
                upfeed_um: 10.0,
                speed_rpm: 36_000.0,
                tilt_deg: 30.0,
            })
            .unwrap();
        // 0.05 µm: sim's peak-force table interpolates linearly on a 0.25 µm grid
        assert!(
            (delta - c * f).abs() < 0.05,
            "x = {} mm: δ = {delta} µm but c·F = {} µm",
            p.x_mm,
            c * f
        );
    }
    // the 4 µm point deflects (it did not before the fix)
    assert!(ctx.points[1].depth_cmd_um - ctx.points[1].depth_nominal_um > 1.0);
}

/// The `[uncertainty]` table: defaults when absent (not written back), checked values, `inf`
/// for a free parameter.
#[test]
fn uncertainty_table_defaults_and_checks() {
    let base = r#"
[tool]
[material]
name = "S7"
[[plan]]
kind = "groove"
speed_rpm = 10000.0
upfeed_um = 10.0
tilt_deg = 20.0
length_mm = 2.0
measure_every_mm = 1.0
depth = { kind = "constant", depth_um = 40.0 }
"#;
    let s = Session::from_toml_str(base).unwrap();
    assert!(s.uncertainty.is_default());
    assert_eq!(s.uncertainty.touch_off_um, 1.0);
    assert!(!toml::to_string(&s).unwrap().contains("uncertainty"));
    let with = base.replace(
        "[material]",
        "[uncertainty]\ntouch_off_um = inf\nforce_scale_pct = 5.0\n[material]",
    );
    let s = Session::from_toml_str(&with).unwrap();
    assert!(s.uncertainty.touch_off_um.is_infinite());
    assert_eq!(s.uncertainty.force_scale_pct, 5.0);
    assert_eq!(s.uncertainty.radial_stiffness_pct, 6.0);
    let bad = base.replace(
        "[material]",
        "[uncertainty]\nwearland_um = -1.0\n[material]",
    );
    let e = Session::from_toml_str(&bad).unwrap_err();
    assert!(
        matches!(&e, SimError::Session { key, .. } if key == "uncertainty.wearland_um"),
        "{e}"
    );
}
