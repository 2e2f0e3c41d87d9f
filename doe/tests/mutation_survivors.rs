//! Tests written for the mutants cargo-mutants found surviving (docs/reliability-mutants.md): each
//! asserts what the code must do where the mutated line decides, and names the mutant it kills.

use millcomp_doe::{DesignKind, DesignRequest, DoeError, FactorSpec, generate};

/// A mixed-level full factorial above 1e6 runs is refused before anything is allocated, naming its
/// size (10 factors of 10 levels: 10^10 runs). Kills `factorial.rs: replace > with == in full`
/// (which would go on to allocate 10^10 rows).
#[test]
fn a_mixed_level_full_factorial_beyond_a_million_runs_is_refused_naming_its_size() {
    let levels = (1..=10)
        .map(|l| l.to_string())
        .collect::<Vec<_>>()
        .join(":");
    let spec = (0..10)
        .map(|i| format!("f{i}={levels}"))
        .collect::<Vec<_>>()
        .join(",");
    let req = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list(&spec).unwrap());
    match generate(&req) {
        Err(DoeError::Unsupported { what }) => {
            assert_eq!(what, "a full factorial of 10000000000 runs (at most 1e6)")
        }
        other => panic!("{other:?}"),
    }
}
