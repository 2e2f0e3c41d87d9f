//! The standard families: their reference shapes are sim's effect forms (so the committed
//! sessions, made by sim's effects, are fitted exactly by the reference shape).

use millcomp_diagnose::{SessionModel, families};
use millcomp_sim::effects::default_effect;

/// Each family's reference shape at the seed parameters (SESSION.md defaults) reproduces sim's
/// effect with its default parameters at every point of the common plan.
#[test]
fn reference_shapes_are_sims_effect_forms() {
    let sm = SessionModel::new(&millcomp_synthetic::base_session("t", "test")).unwrap();
    // (coefficients, nonlinear) in the families' parameters for sim's defaults
    let seeds: [(&str, Vec<f64>); 7] = [
        ("coolant_thermal_drift", vec![8.5, 900.0]),
        ("spindle_thermal_growth", vec![20.0, 16_000.0, 600.0]),
        // (6 − 1)/2·tan 0.107° (002 §7.4)
        (
            "probe_tilt_offset",
            vec![2.5 * 0.107f64.to_radians().tan() * 1e3],
        ),
        ("tool_wear", vec![8.0, 100.0]),
        // the common plan covers machine X 0–90 mm, sim's default span
        ("slideway_straightness", vec![5.0]),
        // k_M = 10 N/µm
        ("machine_compliance", vec![0.1]),
        ("flute_runout", vec![3.0]),
    ];
    let fams = families::standard();
    for (name, theta) in seeds {
        let f = fams.iter().find(|f| f.name == name).unwrap();
        let ours = f.shapes[0].offsets(&sm, &theta);
        let sims = sm.offsets_um(default_effect(name).unwrap().as_ref());
        let worst = ours
            .iter()
            .zip(&sims)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let scale = sims.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(scale > 0.1, "{name}: sim's effect is {scale} µm at most");
        assert!(
            worst < 1e-9 * scale.max(1.0),
            "{name}: worst difference {worst} µm"
        );
    }
}
