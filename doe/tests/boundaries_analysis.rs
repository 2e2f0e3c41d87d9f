//! Boundary tests of the analysis: each limit, guard and branch exactly where it switches, written in a
//! pass over the mutants of `doe/src/analysis` that no campaign had run (docs/reliability-mutants.md,
//! "A hardening pass before the seed-54 draw").

#[allow(unused_imports)]
use crate::common::*;

use millcomp_doe::{
    AnalysisInput, AnalyzeOptions, DoeError, FactorCoding, ModelSpec, Values, analyze,
    f_test_power, lenth, noncentral_f_cdf, noncentral_f_sf,
};

fn f64col(name: &str, v: &[f64]) -> (String, Values) {
    (name.to_string(), Values::F64(v.to_vec()))
}

fn strcol(name: &str, v: &[&str]) -> (String, Values) {
    (
        name.to_string(),
        Values::Str(v.iter().map(|s| s.to_string()).collect()),
    )
}

fn names(input: &AnalysisInput) -> Vec<&str> {
    input.factors.iter().map(|(n, _)| n.as_str()).collect()
}

/// Every argument the noncentral F refuses, each alone (the others valid), gives NaN from both the
/// CDF and the survival function; the valid neighbour (d1 = 2, d2 = 10, λ = 4 at x = 3) gives scipy's
/// value (scipy.stats.ncf.cdf(3, 2, 10, 4) = 0.5489678908785349, tests/golden/noncentral_f.json).
/// Targets power.rs `valid` (each `>`/`>=`, `&&`->`||`, `delete !`, `-> true/false`) and the `delete !`
/// of both callers.
#[test]
fn each_invalid_noncentral_f_argument_alone_gives_nan_and_the_valid_neighbour_a_number() {
    let ok = (3.0, 2.0, 10.0, 4.0);
    let c = noncentral_f_cdf(ok.0, ok.1, ok.2, ok.3);
    let s = noncentral_f_sf(ok.0, ok.1, ok.2, ok.3);
    assert!((c - 0.5489678908785349).abs() < 1e-10, "{c}");
    assert!((s - 0.4510321091214649).abs() < 1e-10, "{s}");
    let bad = [
        (f64::NAN, 2.0, 10.0, 4.0),
        (3.0, 0.0, 10.0, 4.0),
        (3.0, -1.0, 10.0, 4.0),
        (3.0, f64::INFINITY, 10.0, 4.0),
        (3.0, 2.0, 0.0, 4.0),
        (3.0, 2.0, -1.0, 4.0),
        (3.0, 2.0, f64::INFINITY, 4.0),
        (3.0, 2.0, 10.0, -1.0),
        (3.0, 2.0, 10.0, f64::INFINITY),
    ];
    for (x, d1, d2, l) in bad {
        assert!(
            noncentral_f_cdf(x, d1, d2, l).is_nan(),
            "cdf({x},{d1},{d2},{l})"
        );
        assert!(
            noncentral_f_sf(x, d1, d2, l).is_nan(),
            "sf({x},{d1},{d2},{l})"
        );
    }
    // λ = 0 is accepted (λ ≥ 0): the central F, scipy.stats.f.cdf(0.5, 1, 4) = 0.48148148148148157.
    assert!((noncentral_f_cdf(0.5, 1.0, 4.0, 0.0) - 0.48148148148148157).abs() < 1e-12);
    // x at and below 0 and at +∞: the ends of the distribution (by definition).
    assert_eq!(noncentral_f_cdf(0.0, 2.0, 10.0, 4.0), 0.0);
    assert_eq!(noncentral_f_sf(-1.0, 2.0, 10.0, 4.0), 1.0);
    assert_eq!(noncentral_f_cdf(f64::INFINITY, 2.0, 10.0, 4.0), 1.0);
    assert_eq!(noncentral_f_sf(f64::INFINITY, 2.0, 10.0, 4.0), 0.0);
}

/// With λ = 0 the power of an F test is its level α (by definition of the critical value), at
/// α = 0.1 and d1 = 2, d2 = 10; a negative λ, α = 0 and α = 1 give none. Targets power.rs
/// `f_test_power` (`-> Some((±1, ±1))`, the α bounds, `1.0 - alpha`) and `poisson_weights -> vec![..]`.
#[test]
fn the_power_at_zero_noncentrality_is_the_level_and_the_level_bounds_are_refused() {
    let (crit, p) = f_test_power(2.0, 10.0, 0.0, 0.1).unwrap();
    assert!((p - 0.1).abs() < 1e-10, "{p}");
    // by hand: F_{0.9}(2, 10) = 2.924466 (statistical tables)
    assert!((crit - 2.924466).abs() < 1e-5, "{crit}");
    assert!(f_test_power(2.0, 10.0, -1.0, 0.1).is_none());
    assert!(f_test_power(2.0, 10.0, 4.0, 0.0).is_none());
    assert!(f_test_power(2.0, 10.0, 4.0, 1.0).is_none());
    let (_, p) = f_test_power(2.0, 10.0, 4.0, 0.999_999).unwrap();
    assert!(p > 0.999_999 && p <= 1.0);
}

/// `doe analyze`'s α must lie strictly in (0, 1): exactly 0 and exactly 1 are refused naming alpha,
/// a level just inside either end is accepted. Targets options.rs:68 (`>`->`>=`/`==`/`<`, `<`->`==`).
#[test]
fn an_analyze_alpha_of_exactly_zero_or_one_is_refused_and_just_inside_is_accepted() {
    let table = vec![
        f64col("a", &[-1.0, 1.0, -1.0, 1.0]),
        f64col("b", &[-1.0, -1.0, 1.0, 1.0]),
        f64col("y", &[1.0, 3.0, 2.0, 4.5]),
    ];
    let mut o = AnalyzeOptions::new("y");
    for a in [0.0, 1.0, -0.5] {
        o.alpha = a;
        match o.run("t.csv", &table) {
            Err(DoeError::BadOption { option, .. }) => assert_eq!(option, "alpha"),
            other => panic!("α = {a}: {other:?}"),
        }
    }
    for a in [1e-9, 0.5, 1.0 - 1e-9] {
        o.alpha = a;
        let out = o.run("t.csv", &table).unwrap();
        assert_eq!(out.analysis.residual_df, 1, "α = {a}");
    }
}

/// An empty factor list means "every other column" (as none), and a non-empty list is taken as given.
/// Targets options.rs:89 `delete !` (which drops the given list and passes the empty one on).
#[test]
fn an_empty_factor_list_means_every_column_and_a_given_list_is_kept() {
    let table = vec![
        f64col("a", &[-1.0, 1.0, -1.0, 1.0]),
        f64col("b", &[-1.0, -1.0, 1.0, 1.0]),
        f64col("y", &[1.0, 3.0, 2.0, 4.5]),
    ];
    let mut o = AnalyzeOptions::new("y");
    o.factors = Some(vec![]);
    let out = o.run("t.csv", &table).unwrap();
    assert_eq!(out.analysis.factor_names(), vec!["a", "b"]);
    o.factors = Some(vec!["b".to_string()]);
    let out = o.run("t.csv", &table).unwrap();
    assert_eq!(out.analysis.factor_names(), vec!["b"]);
    assert_eq!(out.analysis.residual_df, 2);
}

/// Lenth on Montgomery 8th ed. Example 6.2 (Table 6.11): ME = 6.7478 (tests/golden/lenth.json), so A
/// (21.625) exceeds the margin and AB (0.125) does not; t_PSE = effect / PSE (2.625, by hand).
/// Targets lenth.rs:100 `>`->`<` and the `t_pse` division.
#[test]
fn lenths_margin_flags_the_large_effects_only() {
    let e = [
        21.625, 3.125, 9.875, 14.625, 0.125, -18.125, 16.625, 2.375, -0.375, -1.125, 1.875, 4.125,
        -1.625, -2.625, 1.375,
    ];
    let n: Vec<String> = (0..15).map(|i| format!("e{i}")).collect();
    let l = lenth(&n, &e).unwrap();
    assert!(l.terms[0].exceeds_me && !l.terms[4].exceeds_me && !l.terms[1].exceeds_me);
    assert!(l.terms[5].exceeds_me && l.terms[5].exceeds_sme);
    assert!((l.terms[0].t_pse - 21.625 / 2.625).abs() < 1e-12);
    // by hand: the median of the 15 |effects| is 2.625, s0 = 1.5 · 2.625
    assert!((l.s0 - 1.5 * 2.625).abs() < 1e-12, "{}", l.s0);
    // names and effects of different lengths: none
    assert!(lenth(&n[..14], &e).is_none());
    // two effects (the minimum): 1 and 2 → s0 = 1.5·1.5 = 2.25, both below 2.5·s0, PSE = 2.25 (by hand)
    let l = lenth(&n[..2], &[1.0, 2.0]).unwrap();
    assert_eq!((l.s0, l.pse), (2.25, 2.25));
}

/// Automatic factor choice with `_coded` columns: the bases that exist in the table (a), not a
/// `_coded` column without its base (c_coded) and not the response's own (y_coded). Targets
/// analysis/mod.rs:108 (`==`->`!=`, `&&`->`||`, `!=`->`==`).
#[test]
fn coded_columns_choose_their_existing_bases_but_never_the_response() {
    let t = vec![
        f64col("a", &[10.0, 20.0, 10.0, 20.0]),
        f64col("a_coded", &[-1.0, 1.0, -1.0, 1.0]),
        f64col("c_coded", &[-1.0, -1.0, 1.0, 1.0]),
        f64col("y", &[1.0, 2.0, 3.0, 4.0]),
        f64col("y_coded", &[-1.0, -1.0 / 3.0, 1.0 / 3.0, 1.0]),
    ];
    let i = AnalysisInput::from_table(&t, "y", None, ModelSpec::Main).unwrap();
    assert_eq!(names(&i), vec!["a"]);
}

/// Automatic factor choice without usable `_coded` columns: a column qualifies with 2 up to n/2
/// distinct values (8 runs: 4 yes, 5 no, 1 no); the response, bookkeeping columns and `_coded`
/// columns never. Targets analysis/mod.rs:119 (`&&`->`||`), :124 (`>=`->`<`, `/`->`*`) and
/// `distinct_count -> 1`.
#[test]
fn automatic_factors_have_two_to_half_the_runs_distinct_values() {
    let t = vec![
        f64col("four", &[1.0, 2.0, 3.0, 4.0, 1.0, 2.0, 3.0, 4.0]),
        f64col("five", &[1.0, 2.0, 3.0, 4.0, 5.0, 1.0, 2.0, 3.0]),
        f64col("one", &[7.0; 8]),
        f64col("two", &[0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]),
        f64col("run_order", &[1.0, 2.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0]),
        f64col("z_coded", &[-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0]),
        f64col("y", &[1.0, 2.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0]),
        strcol("lab", &["p", "q", "p", "q", "p", "q", "p", "q"]),
    ];
    let i = AnalysisInput::from_table(&t, "y", None, ModelSpec::Main).unwrap();
    assert_eq!(names(&i), vec!["four", "two", "lab"]);
    // no qualifying column: NotEnoughData
    let t = vec![f64col("one", &[7.0; 4]), f64col("y", &[1.0, 2.0, 3.0, 4.0])];
    assert!(matches!(
        AnalysisInput::from_table(&t, "y", None, ModelSpec::Main),
        Err(DoeError::NotEnoughData {
            needed: 1,
            have: 0,
            ..
        })
    ));
}

/// A factor with one level (numeric or label) is refused naming it; two levels are enough. Targets
/// analysis/mod.rs:383 and :411 (`<`->`<=`/`>`/`==`).
#[test]
fn a_single_level_factor_is_refused_and_two_levels_are_analysed() {
    let y = f64col("y", &[1.0, 2.0, 3.0, 4.0]);
    let run = |f: (String, Values)| {
        analyze(&AnalysisInput {
            factors: vec![f],
            response_name: "y".into(),
            response: y.1.clone(),
            model: ModelSpec::Main,
        })
    };
    for f in [f64col("a", &[5.0; 4]), strcol("a", &["p"; 4])] {
        match run(f) {
            Err(DoeError::SingleLevelFactor { name, .. }) => assert_eq!(name, "a"),
            other => panic!("{other:?}"),
        }
    }
    // two levels: the coefficient is half the difference of the level means (by hand: (3.5 − 1.5)/2 = 1)
    for f in [
        f64col("a", &[0.0, 0.0, 1.0, 1.0]),
        strcol("a", &["p", "p", "q", "q"]),
    ] {
        let a = run(f).unwrap();
        assert_eq!(a.coefficients.len(), 2);
        assert!((a.coefficients[1].coef - 1.0).abs() < 1e-12);
        assert!((a.coefficients[0].coef - 2.5).abs() < 1e-12);
    }
}

/// A three-level label factor is sum coded: coefficients `B[p]`, `B[q]` equal each level's mean less
/// the grand mean (by hand: level means 2, 6, 13, grand mean 7: −5 and −1), and its plotted coded
/// value is the level index spread over [−1, 1] (−1, 0, 1). Targets analysis/mod.rs:424–436 (sum
/// coding and the even spacing).
#[test]
fn a_three_level_label_factor_is_sum_coded_against_its_last_level() {
    let b = strcol("B", &["p", "p", "q", "q", "r", "r"]);
    let a = analyze(&AnalysisInput {
        factors: vec![b],
        response_name: "y".into(),
        response: Values::F64(vec![1.0, 3.0, 5.0, 7.0, 12.0, 14.0]),
        model: ModelSpec::Main,
    })
    .unwrap();
    let c: Vec<(&str, f64)> = a
        .coefficients
        .iter()
        .map(|r| (r.name.as_str(), r.coef))
        .collect();
    assert_eq!(c.len(), 3);
    assert_eq!((c[1].0, c[2].0), ("B[p]", "B[q]"));
    assert!((c[0].1 - 7.0).abs() < 1e-12);
    assert!((c[1].1 + 5.0).abs() < 1e-12);
    assert!((c[2].1 + 1.0).abs() < 1e-12);
    assert_eq!(a.coded_factor(0), &[-1.0, -1.0, 0.0, 0.0, 1.0, 1.0]);
    match &a.factors[0] {
        FactorCoding::Label { levels, .. } => assert_eq!(levels, &["p", "q", "r"]),
        other => panic!("{other:?}"),
    }
    assert_eq!(a.terms[0].df, 2);
}

fn one_factor(f: (String, Values), y: &[f64], model: ModelSpec) -> AnalysisInput {
    AnalysisInput {
        factors: vec![f],
        response_name: "y".into(),
        response: Values::F64(y.to_vec()),
        model,
    }
}

/// A constant response (sse = sst = 0 exactly) leaves R² NaN and adjusted R², predicted R², the
/// Durbin–Watson statistic and every studentized residual and Cook's distance undefined, with a note.
/// Targets analysis/mod.rs:822 (`m > 0.0` -> `>=`), :848 (`sse > 0.0` -> `>=`), :860, :862 and :917.
#[test]
fn a_constant_response_leaves_every_ratio_to_its_variation_undefined() {
    let a = analyze(&one_factor(
        f64col("a", &[-1.0, 1.0, -1.0, 1.0]),
        &[5.0; 4],
        ModelSpec::Main,
    ))
    .unwrap();
    assert_eq!(a.residual_sum_sq, 0.0);
    assert!(a.r_squared.is_nan());
    assert_eq!(a.adj_r_squared, None);
    assert_eq!(a.pred_r_squared, None);
    assert_eq!(a.diagnostics.durbin_watson, None);
    assert!(
        a.diagnostics
            .runs
            .iter()
            .all(|r| r.studentized.is_none() && r.cooks_d.is_none())
    );
    assert_eq!(a.diagnostics.max_abs_studentized, None);
    assert!(
        a.notes
            .iter()
            .any(|n| n == "the response is constant: R² is undefined")
    );
}

/// A run alone at its level of a label factor has leverage 1: no studentized residual, Cook's distance
/// or PRESS (so no predicted R²); the other runs have theirs. By hand (levels p, p, q, q, r; y = 1, 3,
/// 5, 8, 20): residuals −1, 1, −1.5, 1.5, 0; SSE = 6.5 on 2 df, MSE = 3.25; h = ½ for the replicated
/// runs; r₁ = −1/√(3.25·½) = −0.78446…, D₁ = r₁²·h/(p(1−h)) = 0.20513, max |r| = 1.5/√1.625,
/// DW = (4 + 6.25 + 9 + 2.25)/6.5. The model saturates the 3 settings (df_e = df_pe = 2): no lack of
/// fit; not saturated: no Lenth. Targets analysis/mod.rs:822–829, :848–862, :907.
#[test]
fn a_run_of_leverage_one_has_no_studentized_residual_and_the_others_have_theirs() {
    let a = analyze(&one_factor(
        strcol("B", &["p", "p", "q", "q", "r"]),
        &[1.0, 3.0, 5.0, 8.0, 20.0],
        ModelSpec::Main,
    ))
    .unwrap();
    let runs = &a.diagnostics.runs;
    assert_eq!(a.residual_df, 2);
    assert!((a.residual_sum_sq - 6.5).abs() < 1e-12);
    for (r, h) in runs.iter().zip([0.5, 0.5, 0.5, 0.5, 1.0]) {
        assert!((r.leverage - h).abs() < 1e-12, "{r:?}");
    }
    assert_eq!((runs[4].studentized, runs[4].cooks_d), (None, None));
    let r1 = runs[0].studentized.unwrap();
    assert!((r1 + 0.7844645405527362).abs() < 1e-12, "{r1}");
    assert!((runs[0].cooks_d.unwrap() - 0.20512820512820515).abs() < 1e-12);
    assert!((runs[3].studentized.unwrap() - 1.1766968108291043).abs() < 1e-12);
    let m = a.diagnostics.max_abs_studentized.unwrap();
    assert!((m - 1.1766968108291043).abs() < 1e-12);
    assert!(a.diagnostics.outliers.is_empty());
    let dw = a.diagnostics.durbin_watson.unwrap();
    assert!((dw - 3.3076923076923075).abs() < 1e-12, "{dw}");
    assert_eq!(a.pred_r_squared, None);
    // by hand: SST = 225.2 (mean 7.4), R² = 1 − 6.5/225.2, adj = 1 − 3.25/(225.2/4)
    assert!((a.r_squared - (1.0 - 6.5 / 225.2)).abs() < 1e-12);
    assert!((a.adj_r_squared.unwrap() - (1.0 - 3.25 / 56.3)).abs() < 1e-12);
    assert_eq!(a.lack_of_fit, None);
    assert_eq!(a.lenth, None);
}

/// Lack of fit of a straight line to three replicated settings (x = −1, 0, 1 twice; y = 1, 3, 6, 8, 5,
/// 7). By hand: fitted 3, 5, 7; SSE = 18 on 4 df; pure error 6 on 3 df; lack of fit 12 on 1 df,
/// F = 12/(6/3) = 6, p = P(|t₃| > √6) = 0.0917211133 (closed-form t₃ CDF). Identical replicates
/// (no pure error) give none. Targets analysis/mod.rs:889 (each comparison), :892, and the pure
/// error's centring.
#[test]
fn lack_of_fit_needs_replicates_that_differ_and_is_the_textbook_f() {
    let x = f64col("x", &[-1.0, -1.0, 0.0, 0.0, 1.0, 1.0]);
    let a = analyze(&one_factor(
        x.clone(),
        &[1.0, 3.0, 6.0, 8.0, 5.0, 7.0],
        ModelSpec::Main,
    ))
    .unwrap();
    let l = a.lack_of_fit.unwrap();
    assert_eq!((l.lack_of_fit_df, l.pure_error_df), (1, 3));
    assert!((l.lack_of_fit_ss - 12.0).abs() < 1e-9);
    assert!((l.pure_error_ss - 6.0).abs() < 1e-9);
    assert!((l.f - 6.0).abs() < 1e-9);
    assert!(
        (l.p_value - 0.09172111331157184).abs() < 1e-9,
        "{}",
        l.p_value
    );
    let a = analyze(&one_factor(
        x,
        &[2.0, 2.0, 7.0, 7.0, 6.0, 6.0],
        ModelSpec::Main,
    ))
    .unwrap();
    assert_eq!(a.lack_of_fit, None);
    // no replicates: none
    let a = analyze(&one_factor(
        f64col("x", &[-1.0, 0.0, 1.0, 2.0]),
        &[1.0, 4.0, 2.0, 8.0],
        ModelSpec::Main,
    ))
    .unwrap();
    assert_eq!(a.lack_of_fit, None);
}

/// A saturated model (2² with its interaction, 4 runs) has no residual df: Lenth's method instead, and
/// a note. Targets analysis/mod.rs:907 (`==` -> `!=`).
#[test]
fn a_saturated_model_is_judged_by_lenth() {
    let a = analyze(&AnalysisInput {
        factors: vec![
            f64col("A", &[-1.0, 1.0, -1.0, 1.0]),
            f64col("B", &[-1.0, -1.0, 1.0, 1.0]),
        ],
        response_name: "y".into(),
        response: Values::F64(vec![1.0, 5.0, 2.0, 9.0]),
        model: ModelSpec::parse("2fi").unwrap(),
    })
    .unwrap();
    assert_eq!(a.residual_df, 0);
    let l = a.lenth.unwrap();
    assert_eq!(l.terms.len(), 3);
    // by hand: effects A = (5 + 9 − 1 − 2)/2 = 5.5, B = 2.5, AB = (1 + 9 − 5 − 2)/2 = 1.5
    assert!((l.terms[0].effect - 5.5).abs() < 1e-12);
    assert!((l.terms[2].effect - 1.5).abs() < 1e-12);
    assert!(a.notes.iter().any(|n| n.starts_with("saturated model")));
}

/// 2² replicated twice: A strong, B and AB weak.
fn two_by_two() -> AnalysisInput {
    AnalysisInput {
        factors: vec![
            f64col("A", &[-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0]),
            f64col("B", &[-1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0]),
        ],
        response_name: "y".into(),
        response: Values::F64(vec![5.0, 15.0, 6.0, 14.0, 4.5, 15.5, 5.0, 15.2]),
        model: ModelSpec::parse("2fi").unwrap(),
    }
}

/// Backward elimination removes the interaction first (only a term contained in no other may go), then
/// B, and keeps A; α must lie strictly in (0, 1). Targets analysis/mod.rs:1030 (each comparison),
/// :1046 (`delete !`: hierarchy), :1071.
#[test]
fn elimination_keeps_the_hierarchy_and_refuses_an_alpha_of_zero_or_one() {
    let e = millcomp_doe::backward_eliminate(&two_by_two(), 0.05).unwrap();
    let removed: Vec<&str> = e.steps.iter().map(|s| s.removed.as_str()).collect();
    assert_eq!(removed, vec!["A:B", "B"]);
    assert_eq!(e.analysis.model, "A");
    assert!(e.steps.iter().all(|s| s.p_value.unwrap() > 0.05));
    for a in [0.0, 1.0, -0.1, 1.5] {
        match millcomp_doe::backward_eliminate(&two_by_two(), a) {
            Err(DoeError::InvalidParameter { name, .. }) => assert_eq!(name, "alpha"),
            other => panic!("α = {a}: {other:?}"),
        }
    }
    let e = millcomp_doe::backward_eliminate(&two_by_two(), 1.0 - 1e-12).unwrap();
    assert!(e.steps.is_empty());
}

/// A term goes only when its p-value is strictly above α: at α equal to the interaction's p-value it
/// stays, just below it goes. Targets analysis/mod.rs:1063 (`>` -> `>=`, `==`).
#[test]
fn a_term_whose_p_value_equals_alpha_stays() {
    let a = analyze(&two_by_two()).unwrap();
    let p = a
        .terms
        .iter()
        .find(|t| t.term == "A:B")
        .unwrap()
        .p_value
        .unwrap();
    assert!(p > 0.05 && p < 1.0, "{p}");
    let e = millcomp_doe::backward_eliminate(&two_by_two(), p).unwrap();
    assert!(e.steps.is_empty(), "{:?}", e.steps);
    assert_eq!(e.analysis.terms.len(), 3);
    let e = millcomp_doe::backward_eliminate(&two_by_two(), p * (1.0 - 1e-9)).unwrap();
    assert_eq!(e.steps[0].removed, "A:B");
    assert_eq!(e.steps[0].p_value, Some(p));
}

fn two_cubed() -> Vec<(String, Values)> {
    vec![
        f64col("A", &[-1., 1., -1., 1., -1., 1., -1., 1.]),
        f64col("B", &[-1., -1., 1., 1., -1., -1., 1., 1.]),
        f64col("C", &[-1., -1., -1., -1., 1., 1., 1., 1.]),
    ]
}

/// Power of each main effect of a 2³ (4 residual df) for an effect of 4 at σ = 2: λ = (Δ/2)²/(σ²·1/8)
/// = 8 by hand, power 0.5716094577007155 at α = 0.05 (scipy, tests/golden/noncentral_f.json); each
/// refused argument alone names itself; a saturated model has no residual df. Targets
/// analysis/mod.rs:1144–1196 (the guards, `-> Ok(Default)`, the noncentrality's arithmetic).
#[test]
fn the_power_of_a_two_cubed_main_effect_and_each_refused_argument() {
    let r = millcomp_doe::power(&two_cubed(), &ModelSpec::Main, 4.0, 2.0, 0.05).unwrap();
    assert_eq!((r.residual_df, r.terms.len()), (4, 3));
    for t in &r.terms {
        assert!((t.noncentrality - 8.0).abs() < 1e-12, "{t:?}");
        assert!((t.power - 0.5716094577007155).abs() < 1e-10);
        assert!((t.f_crit - 7.708647422176786).abs() < 1e-7);
    }
    let bad = [
        (f64::NAN, 2.0, 0.05, "effect"),
        (f64::INFINITY, 2.0, 0.05, "effect"),
        (4.0, 0.0, 0.05, "sigma"),
        (4.0, -1.0, 0.05, "sigma"),
        (4.0, f64::INFINITY, 0.05, "sigma"),
        (4.0, 2.0, 0.0, "alpha"),
        (4.0, 2.0, 1.0, "alpha"),
    ];
    for (e, s, a, which) in bad {
        match millcomp_doe::power(&two_cubed(), &ModelSpec::Main, e, s, a) {
            Err(DoeError::InvalidParameter { name, .. }) => assert_eq!(name, which),
            other => panic!("{e} {s} {a}: {other:?}"),
        }
    }
    // an effect of 0 is allowed: the power is the level (by definition)
    let r = millcomp_doe::power(&two_cubed(), &ModelSpec::Main, 0.0, 2.0, 0.05).unwrap();
    assert!((r.terms[0].power - 0.05).abs() < 1e-10);
    let sat = ModelSpec::parse("A + B + C + A:B + A:C + B:C + A:B:C").unwrap();
    assert!(matches!(
        millcomp_doe::power(&two_cubed(), &sat, 4.0, 2.0, 0.05),
        Err(DoeError::NotEnoughData {
            needed: 1,
            have: 0,
            ..
        })
    ));
}
