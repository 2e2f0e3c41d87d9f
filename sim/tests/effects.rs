//! Each effect changes the simulated groove profile the way its seed describes (sign, magnitude, what it
//! depends on), and analytic gradients agree with finite differences.
use crate::common;

use approx::assert_relative_eq;
use millcomp_sim::effects::{EFFECT_NAMES, EffectContext, default_effect, fd_gradient};
use millcomp_sim::session::{
    EffectSpec, GroovePoint, PlanItem, Session, SimOptions, simulate_session,
};
use std::collections::BTreeMap;

/// One S7 groove plan helper: `(start_s, rpm, coolant, x_offset, depth kind)`.
fn base_session(plan: &str, effects: &[(&str, &[(&str, f64)])]) -> Session {
    let mut s = Session::from_toml_str(&format!(
        r#"
[tool]
wearland_um = 8.0
[material]
name = "S7"
[force_model]
force_scale = 3.7396
{plan}
"#
    ))
    .unwrap();
    for (name, params) in effects {
        let mut m = BTreeMap::new();
        for (k, v) in params.iter() {
            m.insert(k.to_string(), *v);
        }
        s.effects.push(EffectSpec {
            name: name.to_string(),
            enabled: true,
            params: m,
        });
    }
    s
}

fn groove(start: f64, rpm: f64, coolant: bool, x_off: f64, depth: &str) -> String {
    format!(
        r#"
[[plan]]
kind = "groove"
start_s = {start}
speed_rpm = {rpm}
upfeed_um = 10.0
tilt_deg = 20.0
coolant = {coolant}
length_mm = 20.0
x_offset_mm = {x_off}
measure_every_mm = 1.0
depth = {depth}
"#
    )
}

const RAMP: &str = r#"{ kind = "ramp", from_um = 0.0, to_um = 80.0 }"#;
const CONST40: &str = r#"{ kind = "constant", depth_um = 40.0 }"#;

/// Offset (with − without the effect) per point.
fn offsets(plan: &str, name: &str, params: &[(&str, f64)]) -> (Vec<GroovePoint>, Vec<f64>) {
    let base = simulate_session(&base_session(plan, &[]), &SimOptions::default()).unwrap();
    let with = simulate_session(
        &base_session(plan, &[(name, params)]),
        &SimOptions::default(),
    )
    .unwrap();
    let d = base
        .iter()
        .zip(&with)
        .map(|(a, b)| b.depth_meas_um - a.depth_meas_um)
        .collect();
    (with, d)
}

#[test]
fn coolant_drift_deepens_by_8_5_um_settling_in_45_min() {
    // 002 §7.1: +8.5 µm, stable after ≈ 45 min; zero while the coolant is off
    let plan = groove(0.0, 10_000.0, true, 0.0, CONST40)
        + &groove(2700.0, 10_000.0, true, 0.0, CONST40)
        + &groove(7200.0, 10_000.0, true, 0.0, CONST40);
    let (pts, d) = offsets(&plan, "coolant_thermal_drift", &[]);
    let first = d[0];
    let at45 = d[pts.iter().position(|p| p.groove_id == 1).unwrap()];
    let at120 = *d.last().unwrap();
    assert!(first.abs() < 0.1, "{first}");
    // 3τ: 8.5·(1 − e⁻³) = 8.08 µm; "stable at ≈ 8.5 µm after 45 min": within 0.5 µm
    assert!((at45 - 8.5).abs() < 0.5, "{at45}");
    assert_relative_eq!(at120, 8.5, max_relative = 0.01);
    let off =
        groove(0.0, 10_000.0, false, 0.0, CONST40) + &groove(2700.0, 10_000.0, false, 0.0, CONST40);
    let (_, d_off) = offsets(&off, "coolant_thermal_drift", &[]);
    assert!(d_off.iter().all(|v| v.abs() < 1e-12));
}

#[test]
fn spindle_growth_is_speed_dependent_and_minutes_slow() {
    // 002 §7.6/Table 5: up to +20 µm at the highest speed, negligible below 16 000 rpm, small time constant
    let slow =
        groove(0.0, 10_000.0, true, 0.0, CONST40) + &groove(1800.0, 10_000.0, true, 0.0, CONST40);
    let (_, d_slow) = offsets(&slow, "spindle_thermal_growth", &[]);
    assert!(d_slow.iter().all(|v| v.abs() < 1e-12));
    let fast = groove(0.0, 50_000.0, true, 0.0, CONST40)
        + &groove(600.0, 50_000.0, true, 0.0, CONST40)
        + &groove(3600.0, 50_000.0, true, 0.0, CONST40);
    let (pts, d) = offsets(&fast, "spindle_thermal_growth", &[]);
    let i1 = pts.iter().position(|p| p.groove_id == 1).unwrap();
    assert!(d[0] < 1.0, "{}", d[0]); // starts cold
    assert!(d[i1] > 10.0 && d[i1] < 15.0, "{}", d[i1]); // 10 min = 1τ → 63 % of 20 µm
    assert_relative_eq!(*d.last().unwrap(), 20.0, max_relative = 0.01);
    // Δl = m·ΔT: temperature column reports the rise
    let t = pts.last().unwrap().spindle_temp_c.unwrap();
    assert_relative_eq!(t - 20.0, 20.0, max_relative = 0.01);
}

#[test]
fn probe_tilt_is_a_constant_plus_4_67_um() {
    // 002 §7.4: formula (1) gives Δl = 4.67 µm (+ = deeper)
    let (_, d) = offsets(
        &groove(0.0, 10_000.0, true, 0.0, RAMP),
        "probe_tilt_offset",
        &[],
    );
    for v in d {
        assert_relative_eq!(v, 4.67, max_relative = 0.01);
    }
}

#[test]
fn tool_wear_grows_with_engaged_length_not_time() {
    // 002 §7.5: tool shortens ≈ 8 µm over a test (shallower groove); depends on engaged length
    let plan_a: String = (0..20)
        .map(|k| groove(k as f64 * 20.0, 10_000.0, true, 0.0, CONST40))
        .collect();
    let plan_b: String = (0..20)
        .map(|k| groove(k as f64 * 500.0, 10_000.0, true, 0.0, CONST40))
        .collect();
    let (pa, da) = offsets(&plan_a, "tool_wear", &[]);
    let (pb, db) = offsets(&plan_b, "tool_wear", &[]);
    assert!(pa.last().unwrap().t_s < pb.last().unwrap().t_s / 10.0);
    for (a, b) in da.iter().zip(&db) {
        assert_relative_eq!(a, b, epsilon = 1e-12);
    }
    assert!(da.windows(2).all(|w| w[1] <= w[0] + 1e-12)); // monotone shallower
    // 400 mm engaged: −8(1 − e⁻⁴) = −7.85 µm ≈ "8 µm over a test"
    assert!(
        (da.last().unwrap() + 8.0).abs() < 0.5,
        "{}",
        da.last().unwrap()
    );
}

#[test]
fn straightness_bows_5_um_over_90_mm() {
    // 002 §4.5: 5 µm over 90 mm, depends on machine X
    let plan = groove(0.0, 10_000.0, true, 35.0, CONST40);
    let (pts, d) = offsets(&plan, "slideway_straightness", &[]);
    let mid = pts
        .iter()
        .position(|p| (p.x_mm - 10.0).abs() < 1e-9)
        .unwrap();
    assert_relative_eq!(d[mid], 5.0, max_relative = 1e-9); // X = 45 mm = mid-span
    assert!(d[0] < d[mid] && *d.last().unwrap() < d[mid]);
    let (_, d_end) = offsets(
        &groove(0.0, 10_000.0, true, 90.0, CONST40),
        "slideway_straightness",
        &[],
    );
    assert!(d_end[0].abs() < 1e-9);
}

#[test]
fn machine_compliance_makes_the_deep_end_shallower_in_proportion_to_force() {
    // 003 §2.2: machine in series with the tool — more deflection, ∝ force
    let (pts, d) = offsets(
        &groove(0.0, 10_000.0, true, 0.0, RAMP),
        "machine_compliance",
        &[],
    );
    assert!(d.iter().all(|v| *v <= 0.0));
    assert!(d.last().unwrap() < &(-0.5));
    let i40 = pts
        .iter()
        .position(|p| (p.x_mm - 10.0).abs() < 1e-9)
        .unwrap();
    assert!(d.last().unwrap().abs() > 1.5 * d[i40].abs());
}

#[test]
fn flute_runout_is_shallower_proportional_to_depth() {
    // 000 §4: one flute cutting more raises the peak force → more deflection
    let (pts, d) = offsets(&groove(0.0, 10_000.0, true, 0.0, RAMP), "flute_runout", &[]);
    assert!(d.iter().all(|v| *v <= 0.0));
    let i = pts
        .iter()
        .position(|p| (p.x_mm - 10.0).abs() < 1e-9)
        .unwrap();
    let r = d.last().unwrap() / d[i];
    assert!(r > 1.7 && r < 2.5, "{r}"); // ≈ ratio of actual depths (80−δ)/(40−δ)
    // saturates once the runout exceeds the upfeed
    let (_, d_big) = offsets(
        &groove(0.0, 10_000.0, true, 0.0, RAMP),
        "flute_runout",
        &[("runout_um", 20.0)],
    );
    let (_, d_sat) = offsets(
        &groove(0.0, 10_000.0, true, 0.0, RAMP),
        "flute_runout",
        &[("runout_um", 10.0)],
    );
    assert_relative_eq!(
        d_big.last().unwrap(),
        d_sat.last().unwrap(),
        max_relative = 1e-12
    );
}

#[test]
fn analytic_gradients_match_finite_differences() {
    let coolant = [(0.0, true)];
    let spindle = [(0.0, 30_000.0)];
    for x in [3.0, 40.0, 70.0] {
        let ctx = EffectContext {
            t_s: 1000.0,
            x_mm: x,
            machine_x_mm: x + 5.0,
            cut_length_mm: 10.0 * x,
            speed_rpm: 30_000.0,
            tilt_deg: 20.0,
            upfeed_um: 10.0,
            depth_cmd_um: 60.0,
            depth_actual_um: 48.0,
            force_z_n: 6.0,
            chip_force_z_n_per_um2: 0.0015,
            z_compliance_um_per_n: 1.75,
            coolant_events: &coolant,
            spindle_events: &spindle,
        };
        for name in EFFECT_NAMES {
            let mut e = default_effect(name).unwrap();
            if name == "machine_compliance" {
                e.set_params(&[10.0, 4.0, 150.0]).unwrap();
            }
            if name == "flute_runout" {
                e.set_params(&[3.0]).unwrap();
            }
            let g = e.param_gradient(&ctx);
            let fd = fd_gradient(e.as_ref(), &ctx);
            assert_eq!(g.len(), e.params().len());
            if e.has_analytic_gradient() {
                for (a, b) in g.iter().zip(&fd) {
                    assert!(
                        (a - b).abs() <= common::FD_ABS + common::FD_REL * b.abs(),
                        "{name}: analytic {a} vs fd {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn all_seven_names_constructible_from_a_session() {
    let mut s = base_session(&groove(0.0, 10_000.0, true, 0.0, CONST40), &[]);
    for n in EFFECT_NAMES {
        s.effects.push(EffectSpec {
            name: n.into(),
            enabled: true,
            params: BTreeMap::new(),
        });
    }
    assert_eq!(s.effects().unwrap().len(), 7);
    assert!(matches!(s.plan[0], PlanItem::Groove(_)));
}
