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

/// The shapes added in the second round of development contain simpler shapes of their family
/// as special cases: a dead time of 0 is the one lag, a speed gain of 0 the constant runout, a
/// steady wear of 0 the saturating wear — so the family did not lose what it could represent.
#[test]
fn added_shapes_contain_their_family_s_simpler_ones() {
    let sm = SessionModel::new(&millcomp_synthetic::base_session("t", "test")).unwrap();
    let fams = families::standard();
    let shape = |fam: &str, name: &str| {
        fams.iter()
            .find(|f| f.name == fam)
            .unwrap()
            .shapes
            .iter()
            .find(|s| s.name == name)
            .unwrap()
            .clone()
    };
    let same = |a: Vec<f64>, b: Vec<f64>, what: &str| {
        let worst = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        let scale = b.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(scale > 0.1, "{what}: {scale}");
        assert!(worst < 1e-9 * scale, "{what}: worst difference {worst} µm");
    };
    same(
        shape("coolant_thermal_drift", "dead_time_lag").offsets(&sm, &[8.5, 900.0, 0.0]),
        shape("coolant_thermal_drift", "one_lag").offsets(&sm, &[8.5, 900.0]),
        "coolant dead time 0",
    );
    same(
        shape("flute_runout", "speed_dependent").offsets(&sm, &[3.0, 0.0]),
        shape("flute_runout", "constant").offsets(&sm, &[3.0]),
        "runout without speed gain",
    );
    same(
        shape("tool_wear", "running_in_linear").offsets(&sm, &[8.0, 0.0, 100.0]),
        shape("tool_wear", "saturating").offsets(&sm, &[8.0, 100.0]),
        "wear without steady part",
    );
    // a dead time delays the drift: 10 min after the coolant is switched on it has not begun
    let t_on = sm
        .facts
        .coolant_events
        .iter()
        .find(|e| e.1 > 0.5)
        .unwrap()
        .0;
    let late = shape("coolant_thermal_drift", "dead_time_lag").offsets(&sm, &[8.5, 900.0, 600.0]);
    for (p, v) in sm.points().iter().zip(&late) {
        if p.t_s < t_on + 600.0 {
            assert_eq!(*v, 0.0, "t = {} s", p.t_s);
        }
    }
}

/// Every family but the probe tilt has a flexible basis in its own driver, and the basis
/// represents the family's own shapes (what it is for: a named effect whose shape is none of
/// the family's is still inside it): the reference shape at 002's size lies in the span of its
/// family's basis to 2 % of its norm.
#[test]
fn driver_bases_span_their_family_s_reference_shape() {
    let sm = SessionModel::new(&millcomp_synthetic::base_session("t", "test")).unwrap();
    let refs: [(&str, Vec<f64>); 6] = [
        ("coolant_thermal_drift", vec![8.5, 900.0]),
        ("spindle_thermal_growth", vec![20.0, 16_000.0, 600.0]),
        ("tool_wear", vec![8.0, 100.0]),
        ("slideway_straightness", vec![5.0]),
        ("machine_compliance", vec![0.1]),
        ("flute_runout", vec![3.0]),
    ];
    for f in families::standard() {
        let basis = f.driver_basis(&sm, 3.0);
        if f.name == "probe_tilt_offset" {
            assert!(basis.is_empty());
            continue;
        }
        let theta = &refs.iter().find(|(n, _)| *n == f.name).unwrap().1;
        let mut target = f.shapes[0].offsets(&sm, theta);
        if f.name == "flute_runout" {
            // the runout basis is the change of the runout column around 3 µm: its constant
            // direction is the column's derivative; compare with a small change of the runout
            let up = f.shapes[0].offsets(&sm, &[3.3]);
            target = up.iter().zip(&target).map(|(a, b)| a - b).collect();
        }
        let n = target.len();
        let x = nalgebra::DMatrix::from_fn(n, basis.len(), |i, j| basis[j][i]);
        let yv = nalgebra::DVector::from_vec(target.clone());
        let fit = x.clone().svd(true, true).solve(&yv, 1e-12).unwrap();
        let rest = (&x * fit - &yv).norm();
        assert!(
            rest < 0.02 * yv.norm(),
            "{}: {:.3} of the reference shape outside its driver basis",
            f.name,
            rest / yv.norm()
        );
    }
}
