//! The study's ideal observer (`examples/real_data_study/ideal_observer.rs`, included here by
//! path): the ceiling it reports is only as good as its calibration. Development seeds only.

use millcomp_diagnose::SessionModel;
use millcomp_synthetic::variants::{DEV_SEED_BASE, Row, VariantSpec, draw, study_session};

use crate::ideal_observer_impl::{CRITICAL_CHI2_1, IdealObserver};

fn variant(row: Row, effects: &[&'static str], seed: u64) -> millcomp_synthetic::variants::Variant {
    draw(
        &study_session(),
        &VariantSpec {
            row,
            effects: effects.to_vec(),
            seed,
        },
    )
    .unwrap()
}

/// Where nothing is hidden, the statistic of a shape drawn for another session is χ²₁: mean 1,
/// 1 % above the critical value (40 sessions: the mean's SD is 0.22).
#[test]
fn where_nothing_is_hidden_the_statistic_is_chi_squared_with_one_dof() {
    let session = study_session();
    let observer = IdealObserver::new(&SessionModel::new(&session).unwrap());
    let effects = millcomp_synthetic::variants::EFFECTS;
    let stats: Vec<f64> = (0..40u64)
        .map(|k| {
            let seed = DEV_SEED_BASE + 700_000 + k;
            let nothing = variant(Row::None, &[], seed);
            let decoy = variant(
                Row::Single,
                &[effects[k as usize % effects.len()]],
                seed + 1,
            );
            observer.statistics(&nothing, &decoy.hidden_offsets_um)[0]
        })
        .collect();
    let mean = stats.iter().sum::<f64>() / stats.len() as f64;
    let detected = stats.iter().filter(|&&s| s > CRITICAL_CHI2_1).count();
    assert!((0.5..1.6).contains(&mean), "mean {mean}: {stats:?}");
    assert!(detected <= 2, "{detected} of 40 detected: {stats:?}");
}

/// Only the shape is given: scaling the hidden offsets leaves the statistic unchanged, and a
/// straightness of the study's size is seen far beyond the critical value.
#[test]
fn the_amplitude_is_free_and_a_large_effect_is_seen() {
    let session = study_session();
    let observer = IdealObserver::new(&SessionModel::new(&session).unwrap());
    let v = variant(
        Row::Single,
        &["slideway_straightness"],
        DEV_SEED_BASE + 700_100,
    );
    let own = observer.statistics(&v, &v.hidden_offsets_um)[0];
    let scaled: Vec<Vec<f64>> = v
        .hidden_offsets_um
        .iter()
        .map(|o| o.iter().map(|x| -2.5 * x).collect())
        .collect();
    let again = observer.statistics(&v, &scaled)[0];
    assert!(own > 100.0 * CRITICAL_CHI2_1, "{own}");
    assert!((own - again).abs() < 1e-6 * own, "{own} vs {again}");
}
