//! Property tests of what a design and an analysis claim, checked against the numbers themselves:
//! a regular fraction's resolution, defining relation and alias structure hold on its matrix (found
//! here by brute force over every product of columns), and the ANOVA sums of squares of a balanced
//! design partition the total sum of squares (with lack of fit + pure error = residual).
//!
//! Rerun: `cargo test -p millcomp-doe --test main design_claims` (a few seconds).

use millcomp_doe::{
    AnalysisInput, Design, DesignKind, DesignRequest, FactorSpec, ModelSpec, Values, analyze,
    factor_letter, generate,
};
use proptest::prelude::*;

fn factors(k: usize) -> Vec<FactorSpec> {
    (0..k)
        .map(|i| FactorSpec::coded(&factor_letter(i)))
        .collect()
}

/// The factor mask of a word written in factor names joined by `:` (`A:C`) or as letters (`ACD`).
fn mask_of(word: &str, k: usize) -> u64 {
    let letters: Vec<String> = (0..k).map(factor_letter).collect();
    let parts: Vec<String> = if word.contains(':') {
        word.split(':').map(str::to_string).collect()
    } else {
        word.chars().map(|c| c.to_string()).collect()
    };
    parts.iter().fold(0, |m, p| {
        let i = letters
            .iter()
            .position(|l| l == p)
            .unwrap_or_else(|| panic!("`{p}` of `{word}` is no factor"));
        m | 1 << i
    })
}

/// The product column of the factors in `mask` over the factorial runs (centre points dropped).
fn product(points: &[Vec<f64>], mask: u64) -> Vec<f64> {
    points
        .iter()
        .map(|r| {
            r.iter()
                .enumerate()
                .filter(|(i, _)| mask >> i & 1 == 1)
                .map(|(_, v)| *v)
                .product()
        })
        .collect()
}

/// +1 or −1 when the two columns are equal or opposite, None otherwise (entries are ±1: exact).
fn sign_between(a: &[f64], b: &[f64]) -> Option<f64> {
    if a == b {
        Some(1.0)
    } else if a.iter().zip(b).all(|(x, y)| *x == -*y) {
        Some(-1.0)
    } else {
        None
    }
}

/// Checks a regular two-level fraction's claims against its matrix.
fn check_claims(d: &Design, k: usize) {
    let points: Vec<Vec<f64>> = d
        .runs
        .iter()
        .filter(|r| r.coded.iter().all(|c| *c != 0.0))
        .map(|r| r.coded.clone())
        .collect();
    assert!(points.iter().flatten().all(|v| *v == 1.0 || *v == -1.0));
    let ones = vec![1.0; points.len()];
    // The defining relation found by brute force: every product of columns that is constant.
    let mut found: Vec<(u64, f64)> = Vec::new();
    for mask in 1..(1u64 << k) {
        if let Some(s) = sign_between(&product(&points, mask), &ones) {
            found.push((mask, s));
        }
    }
    let mut claimed: Vec<(u64, f64)> = d
        .defining_relation
        .iter()
        .map(|w| {
            let w = w.strip_prefix("I=").expect("a word starts with I=");
            match w.strip_prefix('-') {
                Some(rest) => (mask_of(rest, k), -1.0),
                None => (mask_of(w, k), 1.0),
            }
        })
        .collect();
    claimed.sort_by_key(|(m, _)| *m);
    assert_eq!(
        claimed, found,
        "defining relation {:?}",
        d.defining_relation
    );
    let shortest = found.iter().map(|(m, _)| m.count_ones()).min();
    assert_eq!(d.resolution, shortest, "resolution");
    // Word-length pattern A3, A4, …: counts of words of each length.
    for (i, a) in d.word_length_pattern.iter().enumerate() {
        let len = i as u32 + 3;
        let n = found.iter().filter(|(m, _)| m.count_ones() == len).count();
        assert_eq!(*a, n, "A{len}");
    }
    // Aliases of every main effect and 2FI among the effects of order ≤ 3: found vs claimed.
    let mut terms: Vec<u64> = (0..k).map(|i| 1u64 << i).collect();
    for i in 0..k {
        for j in i + 1..k {
            terms.push(1 << i | 1 << j);
        }
    }
    for t in terms {
        let col = product(&points, t);
        let mut aliases: Vec<(u64, f64)> = (1..(1u64 << k))
            .filter(|m| *m != t && m.count_ones() <= 3)
            .filter_map(|m| sign_between(&product(&points, m), &col).map(|s| (m, s)))
            .collect();
        aliases.sort_by_key(|(m, _)| *m);
        let entry = d.alias_structure.iter().find(|e| mask_of(&e.term, k) == t);
        let mut claimed: Vec<(u64, f64)> = entry
            .map(|e| {
                e.aliases
                    .iter()
                    .map(|a| match a.strip_prefix('-') {
                        Some(rest) => (mask_of(rest, k), -1.0),
                        None => (mask_of(a, k), 1.0),
                    })
                    .collect()
            })
            .unwrap_or_default();
        claimed.sort_by_key(|(m, _)| *m);
        assert_eq!(claimed, aliases, "aliases of {:?}", entry.map(|e| &e.term));
    }
}

/// Total, model and residual sums of squares of an analysis on `y`.
fn assert_partition(y: &[f64], a: &millcomp_doe::Analysis) {
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let total: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let terms: f64 = a.terms.iter().map(|t| t.sum_sq).sum();
    let scale = total.max(1.0);
    assert!(
        (terms + a.residual_sum_sq - total).abs() <= 1e-9 * scale,
        "terms {terms} + residual {} != total {total}",
        a.residual_sum_sq
    );
    let df: usize = a.terms.iter().map(|t| t.df).sum();
    assert_eq!(df + a.residual_df, y.len() - 1, "degrees of freedom");
    assert!((a.r_squared - (1.0 - a.residual_sum_sq / total)).abs() <= 1e-9);
    if let Some(l) = &a.lack_of_fit {
        assert!(
            (l.lack_of_fit_ss + l.pure_error_ss - a.residual_sum_sq).abs() <= 1e-9 * scale,
            "lack of fit {} + pure error {} != residual {}",
            l.lack_of_fit_ss,
            l.pure_error_ss,
            a.residual_sum_sq
        );
        assert_eq!(l.lack_of_fit_df + l.pure_error_df, a.residual_df);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Fractions chosen by resolution or run count, replicated, blocked and with centre points.
    #[test]
    fn fraction_by_resolution_holds_on_its_matrix(k in 3usize..=9, res in 3u32..=5, by_runs in any::<bool>(),
                                                  reps in 1usize..=2, cp in 0usize..=2, blocks_pow in 0u32..=1,
                                                  seed in any::<u64>()) {
        let mut r = DesignRequest::new(DesignKind::Fractional, factors(k));
        if by_runs {
            r.runs = Some(1 << (k.saturating_sub(res as usize - 1)).clamp(2, 6));
        } else {
            r.resolution = Some(res);
        }
        r.replicates = reps;
        r.center_points = Some(cp);
        r.blocks = 1 << blocks_pow;
        r.seed = Some(seed);
        if let Ok(d) = generate(&r) {
            check_claims(&d, k);
        }
    }

    /// Fractions from generators the user writes, with signs.
    #[test]
    fn fraction_from_generators_holds_on_its_matrix(n in 2usize..=5, words in prop::collection::vec((1u32..64, any::<bool>()), 1..5),
                                                    seed in any::<u64>()) {
        let k = n + words.len();
        let gens: Vec<String> = words
            .iter()
            .enumerate()
            .map(|(j, (w, neg))| {
                let mask = w & ((1 << n) - 1);
                let word: String = (0..n).filter(|i| mask >> i & 1 == 1).map(factor_letter).collect();
                format!("{}={}{}", factor_letter(n + j), if *neg { "-" } else { "" }, word)
            })
            .collect();
        let mut r = DesignRequest::new(DesignKind::Fractional, factors(k));
        r.generators = Some(gens.join(","));
        r.seed = Some(seed);
        if let Ok(d) = generate(&r) {
            check_claims(&d, k);
        }
    }

    /// Balanced designs (two-level full factorials and regular fractions, replicated, with centre
    /// points; mixed-level full factorials with labels) and any response: the terms' sums of squares and
    /// the residual add up to the total.
    #[test]
    fn anova_partitions_the_total(k in 2usize..=4, reps in 1usize..=3, cp in 0usize..=3, frac in any::<bool>(),
                                  two_fi in any::<bool>(), ys in prop::collection::vec(-100.0f64..100.0, 80),
                                  seed in any::<u64>()) {
        let mut r = if frac && k >= 3 {
            let mut r = DesignRequest::new(DesignKind::Fractional, factors(k + 1));
            r.resolution = Some(3);
            r
        } else {
            DesignRequest::new(DesignKind::Full, factors(k))
        };
        r.replicates = reps;
        r.center_points = Some(cp);
        r.seed = Some(seed);
        let d = generate(&r).unwrap();
        let cols = d.columns();
        let y: Vec<f64> = (0..d.n_runs()).map(|i| ys[i % ys.len()] + i as f64 * 0.01).collect();
        let factors: Vec<(String, Values)> = d
            .factors
            .iter()
            .map(|f| cols.iter().find(|(n, _)| *n == f.name).unwrap().clone())
            .collect();
        let model = if two_fi && d.resolution.is_none_or(|x| x >= 5) { ModelSpec::TwoFi } else { ModelSpec::Main };
        let input = AnalysisInput {
            factors,
            response_name: "y".into(),
            response: Values::F64(y.clone()),
            model,
        };
        let a = analyze(&input).unwrap();
        assert_partition(&y, &a);
    }

    #[test]
    fn anova_partitions_the_total_with_labels(levels in 2usize..=4, reps in 2usize..=3,
                                              ys in prop::collection::vec(-10.0f64..10.0, 48)) {
        let labels: Vec<String> = (0..levels).map(|i| format!("l{i}")).collect();
        let spec = format!("tool={},depth_um=100:200", labels.join(":"));
        let mut r = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list(&spec).unwrap());
        r.replicates = reps;
        r.seed = Some(3);
        let d = generate(&r).unwrap();
        let cols = d.columns();
        let y: Vec<f64> = (0..d.n_runs()).map(|i| ys[i % ys.len()]).collect();
        let factors: Vec<(String, Values)> = ["tool", "depth_um"]
            .iter()
            .map(|f| cols.iter().find(|(n, _)| n == f).unwrap().clone())
            .collect();
        for model in [ModelSpec::Main, ModelSpec::TwoFi] {
            let input = AnalysisInput {
                factors: factors.clone(),
                response_name: "y".into(),
                response: Values::F64(y.clone()),
                model,
            };
            assert_partition(&y, &analyze(&input).unwrap());
        }
    }
}

/// The checks above can fail: a wrong sign, a missing word or a wrong resolution is caught.
#[test]
fn a_wrong_claim_is_caught() {
    let mut r = DesignRequest::new(DesignKind::Fractional, factors(5));
    r.generators = Some("D=AB,E=-AC".into());
    r.seed = Some(1);
    let d = generate(&r).unwrap();
    // 2^(5-2) with I = ABD = -ACE = -BCDE: resolution III (Montgomery, Design and Analysis of
    // Experiments, 8th ed., §8.3: the words of the defining relation are the generators' products)
    assert_eq!(d.resolution, Some(3));
    assert_eq!(d.defining_relation, ["I=ABD", "I=-ACE", "I=-BCDE"]);
    check_claims(&d, 5);
    let fails = |d: Design| std::panic::catch_unwind(|| check_claims(&d, 5)).is_err();
    let mut wrong_sign = d.clone();
    let a = &mut wrong_sign.alias_structure[0].aliases[0];
    *a = match a.strip_prefix('-') {
        Some(rest) => rest.to_string(),
        None => format!("-{a}"),
    };
    assert!(fails(wrong_sign));
    let mut missing_word = d.clone();
    missing_word.defining_relation.pop();
    assert!(fails(missing_word));
    let mut wrong_resolution = d.clone();
    wrong_resolution.resolution = Some(4);
    assert!(fails(wrong_resolution));
}
