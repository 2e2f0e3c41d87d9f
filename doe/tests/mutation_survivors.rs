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

/// Lenth's PSE is 1.5 × the median of the effects below 2.5·s0; when that median is 0 there is no
/// scale to judge the effects by and the result is `None` (effects 0, 0, 0, 1, 100, 100, 100: s0 =
/// 1.5, the trimmed effects 0, 0, 0, 1 have median 0), while 0, 0, 1, 1, 100, 100 keep a PSE of
/// 1.5 × 0.5 = 0.75 (by hand). Kills `lenth.rs: replace || with && in lenth` (which returns a PSE of 0
/// and infinite t ratios).
#[test]
fn lenth_has_no_pse_when_the_trimmed_median_is_zero() {
    let names = |m: usize| (0..m).map(|i| format!("e{i}")).collect::<Vec<_>>();
    let e = [0.0, 0.0, 0.0, 1.0, 100.0, 100.0, 100.0];
    assert!(millcomp_doe::lenth(&names(7), &e).is_none());
    let e = [0.0, 0.0, 1.0, 1.0, 100.0, 100.0];
    let l = millcomp_doe::lenth(&names(6), &e).unwrap();
    assert_eq!((l.s0, l.pse, l.df), (1.5, 0.75, 2.0));
    assert_eq!(l.terms[4].t_pse, 100.0 / 0.75);
}

/// A two-level label factor is one ±1 column named by the factor alone, also inside an interaction
/// with a three-level label factor (sum coding: `B[x]`, `B[y]`): the coefficients of `A*B` on a
/// replicated 2×3 table are named `A`, `B[x]`, `B[y]`, `A:B[x]`, `A:B[y]`, and the intercept is the
/// mean of the six cell means (balanced data, sum coding; by hand: 21). Kills
/// `analysis/mod.rs: replace match guard levels.len() > 2 with true in build_matrix` (which names them
/// `A[p]:B[x]`).
#[test]
fn a_two_level_label_keeps_its_name_inside_an_interaction() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let mut a = Vec::new();
    let mut b = Vec::new();
    let mut y = Vec::new();
    // cell means: p: x 10, y 20, z 30; q: x 12, y 22, z 32 (mean 21); replicates ±0.5
    for noise in [0.5, -0.5] {
        for (la, base) in [("p", 10.0), ("q", 12.0)] {
            for (k, lb) in ["x", "y", "z"].iter().enumerate() {
                a.push(la.to_string());
                b.push(lb.to_string());
                y.push(base + 10.0 * k as f64 + noise);
            }
        }
    }
    let input = AnalysisInput {
        factors: vec![("A".into(), Values::Str(a)), ("B".into(), Values::Str(b))],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::parse("A*B").unwrap(),
    };
    let fit = analyze(&input).unwrap();
    let names: Vec<&str> = fit.coefficients.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        ["intercept", "A", "B[x]", "B[y]", "A:B[x]", "A:B[y]"]
    );
    assert!(
        (fit.coefficients[0].coef - 21.0).abs() < 1e-12,
        "{}",
        fit.coefficients[0].coef
    );
}

/// A constant response is analysed (every effect 0) with a note that R² is undefined, and R² is
/// NaN; a response that varies gets no such note (its R² here is 1 − 0.5/40.5 by hand: SSE 0.5
/// from the ±0.25 replicate pairs, SST 40.5). Kills `analysis/mod.rs: replace == with != in analyze`
/// (which notes a constant response exactly when it is not).
#[test]
fn only_a_constant_response_is_noted_as_constant() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let x = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0];
    let z = [-1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0];
    let input = |y: Vec<f64>| AnalysisInput {
        factors: vec![
            ("x".into(), Values::F64(x.to_vec())),
            ("z".into(), Values::F64(z.to_vec())),
        ],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::Main,
    };
    let note = "the response is constant: R² is undefined";
    let flat = analyze(&input(vec![5.0; 8])).unwrap();
    assert!(flat.notes.iter().any(|n| n == note), "{:?}", flat.notes);
    assert!(flat.r_squared.is_nan());
    assert!(flat.coefficients[1..].iter().all(|c| c.coef == 0.0));
    // y = 5 + 2x + z ± 0.25 (first replicate +, second −)
    let y: Vec<f64> = (0..8)
        .map(|i| 5.0 + 2.0 * x[i] + z[i] + if i < 4 { 0.25 } else { -0.25 })
        .collect();
    let varied = analyze(&input(y)).unwrap();
    assert!(
        !varied.notes.iter().any(|n| n == note),
        "{:?}",
        varied.notes
    );
    let r2 = varied.r_squared;
    assert!((r2 - (1.0 - 0.5 / 40.5)).abs() < 1e-12, "{r2}");
}

/// Without `--factors`, the factors are the columns with 2 to max(2, n/2) distinct values other than
/// the response and the bookkeeping columns: on 8 runs, the two-level columns `A` and `B` are chosen;
/// a column of 8 distinct values (a measured temperature), the `block` column and the response (4
/// distinct values here) are not. Kills `analysis/mod.rs:120:33: replace && with || in
/// AnalysisInput::from_table` (which lets the response and `block` through).
#[test]
fn factors_are_not_guessed_from_columns_of_distinct_values() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values};
    let col = |v: [f64; 8]| Values::F64(v.to_vec());
    let table = vec![
        (
            "A".to_string(),
            col([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0]),
        ),
        (
            "B".to_string(),
            col([-1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0]),
        ),
        (
            "temp_c".to_string(),
            col([20.1, 20.4, 20.2, 20.9, 21.3, 20.0, 20.7, 21.1]),
        ),
        (
            "block".to_string(),
            col([1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0]),
        ),
        (
            "y".to_string(),
            col([1.0, 3.0, 2.0, 4.0, 1.0, 3.0, 2.0, 4.0]),
        ),
    ];
    let input = AnalysisInput::from_table(&table, "y", None, ModelSpec::Main).unwrap();
    let names: Vec<&str> = input.factors.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["A", "B"]);
}

/// Nine factors at resolution VII: the catalogue's best for nine factors is resolution VI (128 runs)
/// and the full factorial (512 runs) is past what a fraction request falls back to (up to 7
/// factors), so the request is refused naming the factors and the resolution. Kills
/// `fractional.rs: replace match guard k <= 7 with true in by_resolution` (which returns the 512-run
/// full factorial).
#[test]
fn nine_factors_at_resolution_seven_are_refused_not_run_in_full() {
    let factors = (0..9)
        .map(|i| FactorSpec::coded(&millcomp_doe::factor_letter(i)))
        .collect();
    let mut req = DesignRequest::new(DesignKind::Fractional, factors);
    req.resolution = Some(7);
    match generate(&req) {
        Err(DoeError::NoCatalogueDesign {
            factors, request, ..
        }) => assert_eq!((factors, request.as_str()), (9, "at resolution VII")),
        other => panic!("{other:?}"),
    }
}

/// A CCD's α given as a number must be finite and > 0: `1.5` is taken, `-1.5`, `0` and `inf` are
/// refused naming `alpha`. Kills `mod.rs: replace && with || in <impl FromStr for CcdAlpha>::from_str`.
#[test]
fn a_ccd_alpha_must_be_a_positive_finite_number() {
    use millcomp_doe::CcdAlpha;
    assert_eq!("1.5".parse::<CcdAlpha>().unwrap(), CcdAlpha::Value(1.5));
    for bad in ["-1.5", "0", "inf"] {
        match bad.parse::<CcdAlpha>() {
            Err(DoeError::InvalidParameter { name, value, .. }) => {
                assert_eq!((name, value.as_str()), ("alpha", bad))
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}

/// A Plackett–Burman design with its run count given: 5 factors in 20 runs (Hadamard order 20) has
/// 20 runs; 4100 runs (past the 4096 built here) is refused naming `runs`. Kills `screening.rs:
/// replace > with < in plackett_burman` (which refuses every run count up to 4096).
#[test]
fn a_plackett_burman_run_count_is_taken_up_to_its_bound() {
    let factors = || {
        (0..5)
            .map(|i| FactorSpec::coded(&millcomp_doe::factor_letter(i)))
            .collect()
    };
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, factors());
    req.runs = Some(20);
    assert_eq!(generate(&req).unwrap().n_runs(), 20);
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, factors());
    req.runs = Some(4100);
    match generate(&req) {
        Err(DoeError::InvalidParameter { name, value, .. }) => {
            assert_eq!((name, value.as_str()), ("runs", "4100"))
        }
        other => panic!("{other:?}"),
    }
}

/// `coded_factor` gives each run's coded level, in input order (what the CLI's effect plots draw):
/// on a 2^2 in standard order, −1, 1, −1, 1 for the first factor and −1, −1, 1, 1 for the second,
/// coded from actual levels 100/200 and 10/20. Kills `analysis/mod.rs: replace Analysis::coded_factor
/// -> &[f64] with Vec::leak(vec![-1.0])`.
#[test]
fn coded_factor_gives_each_runs_coded_level_in_input_order() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let input = AnalysisInput {
        factors: vec![
            ("d".into(), Values::F64(vec![100.0, 200.0, 100.0, 200.0])),
            ("u".into(), Values::F64(vec![10.0, 10.0, 20.0, 20.0])),
        ],
        response_name: "f".into(),
        response: Values::F64(vec![1.0, 2.0, 2.0, 3.5]),
        model: ModelSpec::Main,
    };
    let a = analyze(&input).unwrap();
    assert_eq!(a.coded_factor(0), [-1.0, 1.0, -1.0, 1.0]);
    assert_eq!(a.coded_factor(1), [-1.0, -1.0, 1.0, 1.0]);
}
