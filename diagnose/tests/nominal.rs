//! The nominal model reproduces `simulate_session` (moved from the unit tests of the former
//! `context` module, which replayed the plan; the contexts are now sim's own).

use millcomp_diagnose::SessionModel;
use millcomp_sim::effects::EFFECT_NAMES;
use millcomp_sim::session::{EffectSpec, SimOptions, simulate_session};

/// Nominal + Σ effect offsets over the contexts equals `simulate_session`, with no effect and with
/// all seven effects switched on (at their seed parameters) in the session file.
#[test]
fn contexts_reproduce_simulate_session() {
    let mut s = millcomp_synthetic::base_session("t", "test");
    let truth = simulate_session(&s, &SimOptions::default()).unwrap();
    let sm0 = SessionModel::new(&s).unwrap();
    for (a, b) in truth.iter().zip(&sm0.base_um) {
        assert!((a.depth_meas_um - b).abs() < 1e-12);
    }
    s.effects = EFFECT_NAMES
        .iter()
        .map(|n| EffectSpec {
            name: n.to_string(),
            enabled: true,
            params: Default::default(),
        })
        .collect();
    let truth = simulate_session(&s, &SimOptions::default()).unwrap();
    let sm = SessionModel::new(&s).unwrap();
    assert_eq!(truth.len(), sm.len());
    let mut worst = 0.0f64;
    for (i, p) in truth.iter().enumerate() {
        worst = worst.max((p.depth_meas_um - sm.base_um[i]).abs());
        assert_eq!(p.groove_id, sm.points()[i].groove_id);
        assert_eq!(p.coolant_on != 0, sm.points()[i].coolant_on);
    }
    // 1e-9 µm (the bound from when diagnose replayed the plan itself: sim's fixed-point tolerance
    // 1e-10 µm on δz); with sim's own contexts the two agree to round-off of the offset sums.
    assert!(worst < 1e-9, "worst difference {worst} µm");
}
