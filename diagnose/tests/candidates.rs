//! The standard candidate registry (moved from the unit tests of `candidates`).

use millcomp_diagnose::Registry;
use millcomp_sim::effects::EFFECT_NAMES;

#[test]
fn standard_registry_covers_the_contract_names_with_valid_specs() {
    let r = Registry::standard();
    assert_eq!(r.names(), EFFECT_NAMES.to_vec());
    for s in r.specs() {
        let idx = s.free_indices().unwrap();
        assert_eq!(idx.len(), s.free.len());
        for f in &s.free {
            assert!(f.lower < f.upper);
            for &x in &f.starts {
                assert!(x > f.lower && x < f.upper, "{} start {x}", f.name);
            }
            // bounds must be values sim accepts (the fit may reach them)
            for v in [f.lower, f.upper] {
                let mut e = s.effect.clone();
                let mut p: Vec<f64> = e.params().iter().map(|(_, v)| *v).collect();
                p[idx[s.free.iter().position(|g| g.name == f.name).unwrap()]] = v;
                assert!(e.set_params(&p).is_ok(), "{} {} = {v}", s.name(), f.name);
            }
        }
    }
}
