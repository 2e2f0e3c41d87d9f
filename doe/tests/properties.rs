//! Property tests: every two-level design has balanced columns and orthogonal main effects; blocks are
//! orthogonal to main effects; DSD main effects are orthogonal to 2FIs and squares; run orders are
//! permutations and reproducible from the seed.

use millcomp_doe::{Design, DesignKind, DesignRequest, FactorSpec, factor_letter, generate};
use proptest::prelude::*;

fn factors(k: usize) -> Vec<FactorSpec> {
    (0..k)
        .map(|i| FactorSpec::coded(&factor_letter(i)))
        .collect()
}

fn col(d: &Design, j: usize) -> Vec<f64> {
    d.runs.iter().map(|r| r.coded[j]).collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Exact arithmetic on ±1/0 entries: sums are integers, so equality is exact.
fn assert_balanced_orthogonal(d: &Design) {
    let k = d.factors.len();
    for i in 0..k {
        let c = col(d, i);
        assert_eq!(c.iter().sum::<f64>(), 0.0, "column {i} unbalanced");
        assert!(c.iter().all(|v| *v == 1.0 || *v == -1.0 || *v == 0.0));
        for j in 0..i {
            assert_eq!(dot(&c, &col(d, j)), 0.0, "columns {j},{i} not orthogonal");
        }
    }
    // Blocks orthogonal to main effects: every block has as many + as − in each column.
    let nb = d.runs.iter().map(|r| r.block).max().unwrap_or(1);
    for b in 1..=nb {
        for i in 0..k {
            let s: f64 = d
                .runs
                .iter()
                .filter(|r| r.block == b)
                .map(|r| r.coded[i])
                .sum();
            assert_eq!(s, 0.0, "block {b} column {i}");
        }
    }
}

fn assert_run_order_is_permutation(d: &Design) {
    let n = d.n_runs();
    let mut s: Vec<usize> = d.runs.iter().map(|r| r.std_order).collect();
    s.sort();
    assert_eq!(s, (1..=n).collect::<Vec<_>>());
    assert_eq!(
        d.runs.iter().map(|r| r.run_order).collect::<Vec<_>>(),
        (1..=n).collect::<Vec<_>>()
    );
    assert!(
        d.runs.windows(2).all(|w| w[0].block <= w[1].block),
        "blocks run in order"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn fractional_by_resolution(k in 3usize..=11, res in 3u32..=5, reps in 1usize..=2, cp in 0usize..=2,
                                blocks_pow in 0u32..=2, seed in any::<u64>()) {
        let mut r = DesignRequest::new(DesignKind::Fractional, factors(k));
        r.resolution = Some(res);
        r.replicates = reps;
        r.center_points = Some(cp);
        r.blocks = 1 << blocks_pow;
        r.seed = Some(seed);
        match generate(&r) {
            Ok(d) => {
                assert_balanced_orthogonal(&d);
                assert_run_order_is_permutation(&d);
                prop_assert!(d.resolution.is_none_or(|x| x >= res));
                // Main effects are never confounded with blocks.
                prop_assert!(d.confounded_with_blocks.iter().all(|t| t.contains(':')));
            }
            // Too many blocks for a small design is a clean error.
            Err(e) => prop_assert!(blocks_pow > 0, "{e}"),
        }
    }

    #[test]
    fn fractional_from_random_generators(n in 2usize..=5, words in prop::collection::vec(1u32..64, 1..5),
                                         seed in any::<u64>()) {
        let k = n + words.len();
        let gens: Vec<String> = words
            .iter()
            .enumerate()
            .map(|(j, w)| {
                let mask = w & ((1 << n) - 1);
                let word: String = (0..n).filter(|i| mask >> i & 1 == 1).map(factor_letter).collect();
                format!("{}={}", factor_letter(n + j), word)
            })
            .collect();
        let mut r = DesignRequest::new(DesignKind::Fractional, factors(k));
        r.generators = Some(gens.join(","));
        r.seed = Some(seed);
        // Invalid sets (empty, one-letter, duplicated or aliasing words) must be rejected, valid ones balanced.
        if let Ok(d) = generate(&r) {
            prop_assert_eq!(d.n_runs(), 1 << n);
            assert_balanced_orthogonal(&d);
            prop_assert!(d.resolution.unwrap() >= 3);
        }
    }

    #[test]
    fn full_two_level_and_plackett_burman(k in 1usize..=7, kp in 2usize..=30, seed in any::<u64>()) {
        let mut r = DesignRequest::new(DesignKind::Full, factors(k));
        r.seed = Some(seed);
        let d = generate(&r).unwrap();
        prop_assert_eq!(d.n_runs(), 1 << k);
        assert_balanced_orthogonal(&d);
        let mut p = DesignRequest::new(DesignKind::PlackettBurman, factors(kp));
        p.seed = Some(seed);
        let d = generate(&p).unwrap();
        prop_assert!(d.n_runs() > kp && d.n_runs() % 4 == 0);
        assert_balanced_orthogonal(&d);
    }

    #[test]
    fn dsd_orthogonality(k in 3usize..=14, seed in any::<u64>()) {
        let mut r = DesignRequest::new(DesignKind::Dsd, factors(k));
        r.seed = Some(seed);
        let d = generate(&r).unwrap();
        let n = d.n_runs();
        prop_assert!(n == 2 * k + 1 || n == 2 * k + 3 || n > 2 * k);
        let cols: Vec<Vec<f64>> = (0..k).map(|j| col(&d, j)).collect();
        for i in 0..k {
            prop_assert_eq!(cols[i].iter().sum::<f64>(), 0.0);
            for j in 0..k {
                if i != j {
                    prop_assert_eq!(dot(&cols[i], &cols[j]), 0.0);
                }
                // Main effect ⟂ square of any factor and ⟂ any 2FI (fold-over).
                let sq: Vec<f64> = cols[j].iter().map(|v| v * v).collect();
                prop_assert_eq!(dot(&cols[i], &sq), 0.0);
                for l in 0..j {
                    let inter: Vec<f64> = cols[j].iter().zip(&cols[l]).map(|(a, b)| a * b).collect();
                    prop_assert_eq!(dot(&cols[i], &inter), 0.0);
                }
            }
        }
    }
}

#[test]
fn same_seed_same_order_different_seed_different_order() {
    let mk = |seed| {
        let mut r = DesignRequest::new(DesignKind::Full, factors(4));
        r.seed = Some(seed);
        generate(&r)
            .unwrap()
            .runs
            .iter()
            .map(|r| r.std_order)
            .collect::<Vec<_>>()
    };
    assert_eq!(mk(11), mk(11));
    assert_ne!(mk(11), mk(12));
    let mut r = DesignRequest::new(DesignKind::Full, factors(3));
    r.randomize = false;
    let d = generate(&r).unwrap();
    assert!(d.runs.iter().all(|r| r.run_order == r.std_order));
}
