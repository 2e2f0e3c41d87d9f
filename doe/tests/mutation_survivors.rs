//! Tests written for the mutants cargo-mutants found surviving (docs/reliability-mutants.md): each
//! asserts what the code must do where the mutated line decides, and names the mutant it kills.

use millcomp_doe::{DesignKind, DesignRequest, DoeError, FactorSpec, generate};

/// `k` coded factors named A, B, C, … (the letters `doe design` gives them).
fn coded(k: usize) -> Vec<FactorSpec> {
    (0..k)
        .map(|i| FactorSpec::coded(&millcomp_doe::factor_letter(i)))
        .collect()
}

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
    // no adjusted R² either (kills `analysis/mod.rs:860:31: replace && with || in analyze`)
    assert_eq!(flat.adj_r_squared, None);
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

/// The bound on a guessed factor's distinct values is half the runs: in a 3² factorial of 9 runs
/// (levels −1, 0, 1) the two three-level columns are factors (3 ≤ max(2, ⌊9/2⌋) = 4), the response (9
/// distinct values) is not. Kills `analysis/mod.rs:124:47: replace / with % in
/// AnalysisInput::from_table` (found by the draw of seed 53), whose bound max(2, 9 % 2) = 2 leaves
/// both factors out and refuses the table.
#[test]
fn three_level_columns_of_a_nine_run_table_are_factors() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values};
    let a = [-1.0, 0.0, 1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0];
    let b = [-1.0, -1.0, -1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    let y: Vec<f64> = (0..9)
        .map(|i| 10.0 + i as f64 * 1.5 + (i % 2) as f64)
        .collect();
    let table = vec![
        ("A".to_string(), Values::F64(a.to_vec())),
        ("B".to_string(), Values::F64(b.to_vec())),
        ("y".to_string(), Values::F64(y)),
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
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(9));
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
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, coded(5));
    req.runs = Some(20);
    assert_eq!(generate(&req).unwrap().n_runs(), 20);
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, coded(5));
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
    // and the response as given (kills `analysis/mod.rs:961:9: replace Analysis::response_values`)
    assert_eq!(a.response_values(), [1.0, 2.0, 2.0, 3.5]);
}

// ---- survivors of the second campaign (docs/reliability-mutants.md, seed 51 on the tree of 8e854ec) ----

/// `doe design --design ccd` with the defaults of the CLI (`DesignOptions::new`: variant
/// `circumscribed`, α rotatable): on two factors a=100:200, b=10:20 the CCD is the 2² factorial, 4
/// axial points and 4 centre points (the default of `generate` for a CCD: 12 runs), α = (2²)^(1/4) = √2 (Box & Hunter's rotatable α =
/// F^(1/4), F = 4 factorial runs), and the axial points of `a` lie at 150 ± 50·√2 (mid ± α·half
/// range, by hand: 79.289…, 220.710…); the design names its variant. Kills `design/mod.rs:49:13:
/// delete match arm "circumscribed" | "ccc" | "c" in <impl FromStr for CcdVariant>::from_str` (the
/// default variant would be refused) and `rsm.rs:142:9: delete field variant from struct BasePoints
/// expression in ccd` (the design would name no variant) and `rsm.rs:126:50: replace > with >= in
/// ccd` (which notes axial points "outside" the range at α = 1).
#[test]
fn the_default_ccd_is_circumscribed_and_says_so() {
    use millcomp_doe::{CcdVariant, DesignOptions, Level};
    for spelling in ["circumscribed", "CCC", " c "] {
        assert_eq!(
            spelling.parse::<CcdVariant>().unwrap(),
            CcdVariant::Circumscribed
        );
    }
    let mut o = DesignOptions::new("ccd", "a=100:200,b=10:20");
    o.randomize = false;
    let d = generate(&o.request().unwrap()).unwrap();
    assert_eq!(d.variant, Some("circumscribed"));
    assert_eq!(d.n_runs(), 12);
    let alpha = d.alpha.unwrap();
    assert!((alpha - 2f64.sqrt()).abs() < 1e-12, "{alpha}");
    let a: Vec<f64> = d
        .runs
        .iter()
        .map(|r| match &r.actual[0] {
            Level::Num(x) => *x,
            other => panic!("{other:?}"),
        })
        .collect();
    let lo = a.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = a.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    assert!((lo - (150.0 - 50.0 * 2f64.sqrt())).abs() < 1e-9, "{lo}");
    assert!((hi - (150.0 + 50.0 * 2f64.sqrt())).abs() < 1e-9, "{hi}");
    // axial points outside the given low/high are noted; at α = 1 they are not outside
    let outside =
        |d: &millcomp_doe::Design| d.notes.iter().any(|n| n.starts_with("axial points lie at"));
    assert!(outside(&d));
    o.alpha = "1".into();
    let d = generate(&o.request().unwrap()).unwrap();
    assert_eq!(d.alpha, Some(1.0));
    assert!(!outside(&d), "{:?}", d.notes);
}

/// A coded factor's range is −1 … +1: the design lists it with low −1 and high +1, and its runs'
/// coded levels of a 2² are ±1. Kills `factor.rs:254:42: delete - in FactorSpec::range` (which makes
/// the range 1 … 1).
#[test]
fn a_coded_factor_ranges_from_minus_one_to_one() {
    let f = FactorSpec::coded("A");
    assert_eq!(f.range(), Some((-1.0, 1.0)));
    let req = DesignRequest::new(DesignKind::Full, vec![f, FactorSpec::coded("B")]);
    let d = generate(&req).unwrap();
    assert_eq!(
        (d.factors[0].low, d.factors[0].high),
        (Some(-1.0), Some(1.0))
    );
}

/// A response read as text (a CSV column with a non-numeric cell elsewhere is text) whose cell is
/// `inf` is refused naming the column and the 1-based row (3), not analysed. Kills
/// `analysis/mod.rs:469:26: replace match guard x.is_finite() with true in response_values`.
#[test]
fn an_infinite_response_cell_in_a_text_column_is_refused_naming_its_row() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let input = AnalysisInput {
        factors: vec![("x".into(), Values::F64(vec![-1.0, 1.0, -1.0, 1.0]))],
        response_name: "force_n".into(),
        response: Values::Str(vec!["1.0".into(), "2.0".into(), "inf".into(), "4.0".into()]),
        model: ModelSpec::Main,
    };
    match analyze(&input) {
        Err(DoeError::NonFiniteValue { column, row, value }) => {
            assert_eq!((column.as_str(), row), ("force_n", 3));
            assert_eq!(value, f64::INFINITY);
        }
        other => panic!("{other:?}"),
    }
}

/// `Design::factor_names` lists the factors in order. Kills `design/mod.rs:546:9: replace
/// Design::factor_names -> Vec<String> with vec![String::new()]`.
#[test]
fn a_design_lists_its_factor_names_in_order() {
    let req = DesignRequest::new(
        DesignKind::Full,
        FactorSpec::parse_list("depth_um=100:200,upfeed_um=10:20,speed_rpm=1:2:3").unwrap(),
    );
    let d = generate(&req).unwrap();
    assert_eq!(d.factor_names(), ["depth_um", "upfeed_um", "speed_rpm"]);
    assert_eq!(d.n_runs(), 2 * 2 * 3);
}

/// A Latin hypercube without `--runs` has 10 runs per factor (3 factors: 30), each factor's levels
/// being the 30 stratum midpoints −1 + (2i + 1)/30, once each. Kills `spacefilling.rs:47:35:
/// replace * with / in lhs` (which gives 10/3 = 3 runs).
#[test]
fn a_latin_hypercube_has_ten_runs_per_factor_by_default() {
    let mut req = DesignRequest::new(DesignKind::Lhs, coded(3));
    req.seed = Some(7);
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 30);
    for j in 0..3 {
        let mut col: Vec<f64> = d.runs.iter().map(|r| r.coded[j]).collect();
        col.sort_by(f64::total_cmp);
        for (i, x) in col.iter().enumerate() {
            assert!(
                (x - (-1.0 + (2 * i + 1) as f64 / 30.0)).abs() < 1e-12,
                "{x}"
            );
        }
    }
}

/// A run whose leverage is 1 (the only run at x = +1 of a line fitted to x = −1, −1, +1) has no
/// studentized residual and no Cook's distance (its residual is 0 whatever it measured, 1 − h = 0);
/// the two others have h = 1/2 and, with y = 1, 3, 10 (fit: 2 at x = −1, 10 at x = +1; residuals
/// −1, +1, 0; SSE 2 on 1 df, MSE 2), studentized residuals ∓1/√(2·(1 − 1/2)) = ∓1 and Cook's D
/// r²·h/(p·(1 − h)) = 1·0.5/(2·0.5) = 0.5 (by hand); no PRESS (predicted R²), Durbin–Watson 2.5 and
/// the slope's t and p-value (closed form for 1 df) by hand. Kills `analysis/mod.rs:822:35: replace -
/// with + in analyze` (which lets h = 1 through the guard and divides by 0), `analysis/mod.rs:856:29:
/// replace - with + in analyze` (PRESS with h = 1), `analysis/mod.rs:848:19: replace > with < / ==
/// in analyze` (no Durbin–Watson) and `analysis/mod.rs:585:22: replace * with + in t_pvalue`.
#[test]
fn a_run_of_leverage_one_has_no_studentized_residual() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let input = AnalysisInput {
        factors: vec![("x".into(), Values::F64(vec![-1.0, -1.0, 1.0]))],
        response_name: "y".into(),
        response: Values::F64(vec![1.0, 3.0, 10.0]),
        model: ModelSpec::Main,
    };
    let a = analyze(&input).unwrap();
    let d = &a.diagnostics.runs;
    assert!((d[2].leverage - 1.0).abs() < 1e-12, "{}", d[2].leverage);
    assert_eq!((d[2].studentized, d[2].cooks_d), (None, None));
    for (run, r) in [(0, -1.0), (1, 1.0)] {
        assert!((d[run].leverage - 0.5).abs() < 1e-12);
        assert!((d[run].studentized.unwrap() - r).abs() < 1e-12);
        assert!((d[run].cooks_d.unwrap() - 0.5).abs() < 1e-12);
    }
    // PRESS needs every 1 − h > 0: no predicted R² here
    assert_eq!(a.pred_r_squared, None);
    // Durbin–Watson Σ(eᵢ − eᵢ₋₁)²/Σe² = ((1 − (−1))² + (0 − 1)²)/2 = 2.5
    assert!((a.diagnostics.durbin_watson.unwrap() - 2.5).abs() < 1e-12);
    // slope 4 (means 2 and 10), (XᵀX)⁻¹ = [[3, 1], [1, 3]]/8, SE = √(2·3/8), t = 4/√0.75 on 1 df:
    // Student's t with 1 df is Cauchy, two-sided p = 1 − (2/π)·atan(t)
    let slope = &a.coefficients[1];
    let t = 4.0 / 0.75f64.sqrt();
    assert!((slope.t.unwrap() - t).abs() < 1e-12);
    let p = 1.0 - 2.0 / std::f64::consts::PI * t.atan();
    assert!(
        (slope.p_value.unwrap() - p).abs() < 1e-12,
        "{:?} vs {p}",
        slope.p_value
    );
}

/// The largest |det X| over the saturated designs (as many runs as coefficients, p) on `points`, by
/// enumerating every p-subset of distinct points (a saturated design with a repeated point is
/// singular) depth first: |det X| is the product of the norms of X's rows after Gram–Schmidt, so a
/// subset is extended only while its rows stay independent. The reference the D-optimal search is held
/// to, found without it.
fn best_saturated_abs_det(rows: &[Vec<f64>]) -> f64 {
    fn extend(rows: &[Vec<f64>], from: usize, basis: &mut Vec<Vec<f64>>, det: f64, best: &mut f64) {
        let p = rows[0].len();
        if basis.len() == p {
            *best = best.max(det);
            return;
        }
        for i in from..rows.len() {
            if rows.len() - i < p - basis.len() {
                break;
            }
            let mut r = rows[i].clone();
            for q in basis.iter() {
                let c: f64 = r.iter().zip(q).map(|(a, b)| a * b).sum();
                r.iter_mut().zip(q).for_each(|(a, b)| *a -= c * b);
            }
            let norm = r.iter().map(|a| a * a).sum::<f64>().sqrt();
            if norm < 1e-9 {
                continue;
            }
            basis.push(r.iter().map(|a| a / norm).collect());
            extend(rows, i + 1, basis, det * norm, best);
            basis.pop();
        }
    }
    let mut best = 0.0;
    extend(rows, 0, &mut Vec::new(), 1.0, &mut best);
    best
}

/// The full quadratic model row [1, a, b, ab, a², b²] (the order does not change |det X|).
fn quadratic_row_2(x: &[f64]) -> Vec<f64> {
    vec![1.0, x[0], x[1], x[0] * x[1], x[0] * x[0], x[1] * x[1]]
}

/// A main-effects D-optimal design in 8 runs on the triangle a − b ≥ 1 (coded): no point of the
/// square's diagonal is feasible (a − b = 0 there), so the candidate grid must hold off-diagonal
/// points. The optimum puts the runs on the triangle's vertices (0, −1), (1, −1), (1, 0) as evenly as
/// 8 allows (3, 3, 2): det XᵀX = n₁·n₂·n₃·det(V)² with V the vertices' model rows [1, a, b], det V =
/// 1, so 18 (by hand; Kiefer's equal-weight vertex design for a first-order model on a simplex). Kills
/// `doptimal.rs:242:25: replace /= with %= in d_optimal` (whose grid holds only diagonal points, so it
/// reports the constraints as infeasible).
#[test]
fn a_d_optimal_design_on_a_triangle_off_the_diagonal_puts_its_runs_on_the_vertices() {
    use millcomp_doe::{LinearConstraint, ModelSpec};
    let f = FactorSpec::parse_list("a,b").unwrap();
    let mut req = DesignRequest::new(DesignKind::DOptimal, f.clone());
    req.model = Some(ModelSpec::Main);
    req.runs = Some(8);
    req.seed = Some(1);
    req.constraints = LinearConstraint::parse_list("a - b >= 1", &f).unwrap();
    let d = generate(&req).unwrap();
    let ld = d.criteria.log_det_xtx.unwrap();
    assert!((ld - 18f64.ln()).abs() < 1e-9, "{ld}");
    let mut count = [0; 3];
    for r in &d.runs {
        let v = [[0.0, -1.0], [1.0, -1.0], [1.0, 0.0]]
            .iter()
            .position(|v| v[..] == r.coded[..])
            .unwrap_or_else(|| panic!("{:?} is not a vertex", r.coded));
        count[v] += 1;
    }
    count.sort_unstable();
    assert_eq!(count, [2, 3, 3]);
}

/// The full quadratic in 2 factors and 6 runs (saturated) on the square with its corner cut,
/// a + b ≤ 1 (coded), over the 5 × 5 grid of levels −1, −0.5, 0, 0.5, 1 that the search uses with
/// constraints (22 points feasible): the best of all C(22, 6) = 74 613 six-point designs, enumerated
/// here, has |det X| = 12, ln det XᵀX = ln 144; the search reaches it from every seed tried. Kills
/// `doptimal.rs:320:53: replace > with == in d_optimal` (which keeps the first of the 10 random starts,
/// not the best: seeds 2, 8 and 9 then end at ln det 4.39 or 3.82).
#[test]
fn a_d_optimal_design_keeps_the_best_of_its_starts() {
    use millcomp_doe::{LinearConstraint, ModelSpec};
    let lv = [-1.0, -0.5, 0.0, 0.5, 1.0];
    let grid: Vec<Vec<f64>> = lv
        .iter()
        .flat_map(|&b| lv.iter().map(move |&a| vec![a, b]))
        .filter(|x| x[0] + x[1] <= 1.0)
        .collect();
    assert_eq!(grid.len(), 22);
    let rows: Vec<Vec<f64>> = grid.iter().map(|x| quadratic_row_2(x)).collect();
    let best = best_saturated_abs_det(&rows);
    assert!((best - 12.0).abs() < 1e-9, "{best}");
    let f = FactorSpec::parse_list("a,b").unwrap();
    for seed in 0..10 {
        let mut req = DesignRequest::new(DesignKind::DOptimal, f.clone());
        req.model = Some(ModelSpec::Quadratic);
        req.runs = Some(6);
        req.seed = Some(seed);
        req.constraints = LinearConstraint::parse_list("a + b <= 1", &f).unwrap();
        let ld = generate(&req).unwrap().criteria.log_det_xtx.unwrap();
        assert!((ld - 144f64.ln()).abs() < 1e-9, "seed {seed}: {ld}");
    }
}

/// The full quadratic in 3 factors and 10 runs (saturated) on the 3³ grid (no constraints): the best
/// of all C(27, 10) ten-point designs, enumerated here, has |det X| = 1152 = 2⁷·3², ln det XᵀX =
/// ln(2¹⁴·3⁴); the search reaches it from each of 20 seeds. Kills `doptimal.rs:179:22: replace * with /
/// in info_inverse` (a ridge 10⁴ times smaller, 1e-9 instead of 1e-7, with which seeds 4 and 6 end at
/// ln det 13.86).
#[test]
fn a_saturated_three_factor_quadratic_design_reaches_the_grids_best() {
    let lv = [-1.0, 0.0, 1.0];
    let mut rows = Vec::new();
    for &c in &lv {
        for &b in &lv {
            for &a in &lv {
                rows.push(vec![1.0, a, b, c, a * b, a * c, b * c, a * a, b * b, c * c]);
            }
        }
    }
    let best = best_saturated_abs_det(&rows);
    assert!((best - 1152.0).abs() < 1e-6, "{best}");
    let f = FactorSpec::parse_list("a,b,c").unwrap();
    for seed in 0..20 {
        let mut req = DesignRequest::new(DesignKind::DOptimal, f.clone());
        req.runs = Some(10);
        req.seed = Some(seed);
        let ld = generate(&req).unwrap().criteria.log_det_xtx.unwrap();
        assert!(
            (ld - 1152f64.powi(2).ln()).abs() < 1e-9,
            "seed {seed}: {ld}"
        );
    }
}

/// The three-factor Box–Behnken design in standard order, as the NIST/SEMATECH e-Handbook tabulates
/// it (§5.3.3.6.2, "Box-Behnken design for 3 factors"): each pair of factors run as a 2² in
/// standard order (−−, +−, −+, ++) with the third at its centre, pairs AB, AC, BC, then the centre
/// points (3 by default). Kills `rsm.rs:200:38: replace == with != in box_behnken` (which runs each
/// 2² in reverse order: ++, −+, +−, −−).
#[test]
fn a_box_behnken_design_comes_in_the_handbooks_standard_order() {
    let mut req = DesignRequest::new(DesignKind::BoxBehnken, coded(3));
    req.randomize = false;
    let d = generate(&req).unwrap();
    let nist = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [-1.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 0.0, -1.0],
        [1.0, 0.0, -1.0],
        [-1.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [0.0, -1.0, -1.0],
        [0.0, 1.0, -1.0],
        [0.0, -1.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
    ];
    assert_eq!(d.coded_matrix(), nist.map(|r| r.to_vec()).to_vec());
}

/// A design's actual levels are the levels as written, not their round trip through the coded
/// scale: for x = −1.2 : 0.7 : 1.2 the middle level codes to (0.7 − 0)/1.2 and back to
/// 0 + 0.58333…·1.2 = 0.7000000000000001 in double precision (Python gives the same), which is
/// snapped to the listed 0.7 (within 1e-9 of the range 2.4). Kills `factor.rs:290:62: replace -
/// with + in FactorSpec::actual` (whose tolerance 1e-9·|1.2 + (−1.2)| is 0 here, so
/// 0.7000000000000001 is kept).
#[test]
fn a_designs_actual_levels_are_the_levels_as_written() {
    use millcomp_doe::Level;
    let f = FactorSpec::parse_list("x=-1.2:0.7:1.2").unwrap();
    let coded = f[0].coded_levels();
    assert_ne!(0.0 + coded[1] * 0.5 * (1.2 - -1.2), 0.7);
    assert_eq!(f[0].actual(coded[1]), Level::Num(0.7));
    let mut req = DesignRequest::new(DesignKind::Full, f);
    req.randomize = false;
    let d = generate(&req).unwrap();
    let actual: Vec<Level> = d.runs.iter().map(|r| r.actual[0].clone()).collect();
    assert_eq!(actual, [Level::Num(-1.2), Level::Num(0.7), Level::Num(1.2)]);
}

/// A constraint that names a factor twice adds its coefficients: `a + 2*b - b + a <= 1` is
/// 2·a + 1·b ≤ 1 (by hand), so (0.5, 0) is on the bound and (0.5, 0.5) outside. Kills
/// `doptimal.rs:143:36: replace += with -= in LinearConstraint::parse` (which makes it 0·a + 3·b).
#[test]
fn a_factor_named_twice_in_a_constraint_adds_its_coefficients() {
    use millcomp_doe::LinearConstraint;
    let f = FactorSpec::parse_list("a,b").unwrap();
    let c = LinearConstraint::parse_list("a + 2*b - b + a <= 1", &f).unwrap();
    assert_eq!(c[0].coefs, [(0, 2.0), (1, 1.0)]);
    assert_eq!(c[0].rhs, 1.0);
    assert!(c[0].satisfied(&[0.5, 0.0]));
    assert!(!c[0].satisfied(&[0.5, 0.5]));
}

/// The face-centred CCD asked by its variant name (`doe design --design ccd --ccd-variant
/// face-centred`, and the spellings `face-centered`, `faced`, `CCF`, `f`) puts its axial points on the
/// faces: α = 1, so `a` = 100:200 only takes 100, 150 and 200. Kills `design/mod.rs:51:13: delete
/// match arm "face-centred" | … in <impl FromStr for CcdVariant>::from_str` and `rsm.rs:88:12: delete
/// ! in ccd` (which notes "alpha set to 1" when the default α was asked, and not when 1.5 was).
#[test]
fn a_face_centred_ccd_is_asked_by_its_variant_name() {
    use millcomp_doe::{CcdVariant, DesignOptions, Level};
    for spelling in ["face-centred", "face-centered", "faced", "CCF", "f"] {
        assert_eq!(
            spelling.parse::<CcdVariant>().unwrap(),
            CcdVariant::FaceCentred
        );
    }
    let mut o = DesignOptions::new("ccd", "a=100:200,b=10:20");
    o.ccd_variant = "face-centred".into();
    let d = generate(&o.request().unwrap()).unwrap();
    assert_eq!((d.variant, d.alpha), (Some("face-centred"), Some(1.0)));
    let mut a: Vec<f64> = d
        .runs
        .iter()
        .map(|r| match r.actual[0] {
            Level::Num(x) => x,
            ref other => panic!("{other:?}"),
        })
        .collect();
    a.sort_by(f64::total_cmp);
    a.dedup();
    assert_eq!(a, [100.0, 150.0, 200.0]);
    // α is 1 whatever is asked; only an α asked other than the default (rotatable) is noted as changed
    let note = "face-centred CCD: alpha set to 1";
    assert!(!d.notes.iter().any(|n| n == note), "{:?}", d.notes);
    o.alpha = "1.5".into();
    let d = generate(&o.request().unwrap()).unwrap();
    assert_eq!(d.alpha, Some(1.0));
    assert!(d.notes.iter().any(|n| n == note), "{:?}", d.notes);
}

/// The largest Plackett–Burman design built, 4096 runs (Sylvester's Hadamard matrix of order 2¹²),
/// is taken: each of its 5 columns has 2048 runs at each level. Kills `screening.rs:76:45: replace >
/// with == in plackett_burman` (which refuses exactly 4096).
#[test]
fn a_plackett_burman_design_of_4096_runs_is_built() {
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, coded(5));
    req.runs = Some(4096);
    req.randomize = false;
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 4096);
    for j in 0..5 {
        assert_eq!(d.runs.iter().filter(|r| r.coded[j] == 1.0).count(), 2048);
    }
}

/// Blocks of later replicates continue the numbering: a 2³ in 2 blocks, replicated twice, has blocks
/// 1 and 2 in the first replicate and 3 and 4 in the second, 4 runs each, in standard order.
/// Kills `design/mod.rs:773:28: replace * with / in generate` (which numbers both replicates' blocks
/// 1 and 2).
#[test]
fn blocks_of_a_second_replicate_are_numbered_on() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(3));
    req.blocks = 2;
    req.replicates = 2;
    req.randomize = false;
    let d = generate(&req).unwrap();
    let blocks: Vec<usize> = d.runs.iter().map(|r| r.block).collect();
    assert_eq!(blocks, [1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4]);
}

/// A definitive screening design of 2 factors is built from the conference matrix of order 4 (the
/// smallest built, with 2 "fake factor" columns dropped, Jones & Nachtsheim 2011): 2·4 + 1 = 9 runs,
/// each factor at −1, 0, +1 three times each (rows C, −C and the centre run); 1 factor is refused
/// naming the 2 needed. Kills `screening.rs:257:10: replace < with == in dsd` (which refuses 2).
#[test]
fn a_definitive_screening_design_of_two_factors_has_nine_runs() {
    let d = generate(&DesignRequest::new(DesignKind::Dsd, coded(2))).unwrap();
    assert_eq!(d.n_runs(), 9);
    for j in 0..2 {
        for level in [-1.0, 0.0, 1.0] {
            assert_eq!(d.runs.iter().filter(|r| r.coded[j] == level).count(), 3);
        }
    }
    match generate(&DesignRequest::new(DesignKind::Dsd, coded(1))) {
        Err(DoeError::NotEnoughData { needed, have, .. }) => assert_eq!((needed, have), (2, 1)),
        other => panic!("{other:?}"),
    }
}

/// A design's size counts the centre points of every block: a 2³ in 4 blocks with 1000 centre points
/// per block has 8 + 4·1000 = 4008 runs a replicate, so 989 replicates (3 963 912 runs) are refused,
/// the message giving that size (by hand). Kills `design/mod.rs:727:21: replace * with + in generate`
/// (which counts 8 + 1000 + 4 = 1012 runs a replicate).
#[test]
fn a_designs_size_counts_the_centre_points_of_every_block() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(3));
    req.blocks = 4;
    req.center_points = Some(1000);
    req.replicates = 989;
    match generate(&req) {
        Err(DoeError::InvalidParameter { name, allowed, .. }) => {
            assert_eq!(name, "replicates");
            assert_eq!(
                allowed,
                "a design of at most 1000000 runs (this one would have 3963912: 4008 runs × 989 replicates)"
            );
        }
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// Power is reported per one-degree-of-freedom term: a three-level label factor (two effect-coded
/// columns `B[x]`, `B[y]`) is skipped. On A (±1) × B (x, y, z) replicated twice (12 runs, main
/// effects: 4 coefficients, 8 residual df), A alone is reported, with λ = (effect/2)²/(σ²·(XᵀX)⁻¹_AA) =
/// 1²/(1/12) = 12 for effect 2, σ 1 (A is balanced and orthogonal to B, by hand) and power
/// 0.8572901105252035 (scipy 1.17.1: `ncf.sf(f.ppf(0.95, 1, 8), 1, 8, 12)`). Kills
/// `analysis/mod.rs:1183:57: replace == with != in power` (which reports `B[x]` and `B[y]` too); with
/// effect 4 and σ 2, λ is 12 again, which kills `analysis/mod.rs:1196:54: replace * with / in power`.
#[test]
fn power_skips_the_columns_of_a_three_level_label_factor() {
    use millcomp_doe::{ModelSpec, Values, power};
    let mut a = Vec::new();
    let mut b = Vec::new();
    for _ in 0..2 {
        for lb in ["x", "y", "z"] {
            for la in [-1.0, 1.0] {
                a.push(la);
                b.push(lb.to_string());
            }
        }
    }
    let f = vec![
        ("A".to_string(), Values::F64(a)),
        ("B".to_string(), Values::Str(b)),
    ];
    let r = power(&f, &ModelSpec::Main, 2.0, 1.0, 0.05).unwrap();
    assert_eq!(r.residual_df, 8);
    let names: Vec<&str> = r.terms.iter().map(|t| t.term.as_str()).collect();
    assert_eq!(names, ["A"]);
    assert!((r.terms[0].noncentrality - 12.0).abs() < 1e-9);
    assert!((r.terms[0].power - 0.8572901105252035).abs() < 1e-9);
    // twice the effect against twice the noise: the same λ = 2²/(2²/12) = 12
    let r = power(&f, &ModelSpec::Main, 4.0, 2.0, 0.05).unwrap();
    assert!((r.terms[0].noncentrality - 12.0).abs() < 1e-9);
}

/// Generators that alias two main effects are refused naming both: `C=A` on three factors makes the
/// defining word AC (I = AC), so C is aliased with A. This is the first check of `check_generators`
/// (a generator word of one letter); the later scan of the whole defining subgroup for words of
/// length ≤ 2 can never find one this check and the duplicate check let through (a product of r
/// generator words has its r generated letters plus the base letters of the XOR of their words), so
/// `fractional.rs:273:70: replace == with != in check_generators`, inside that scan, is equivalent
/// (docs/reliability-mutants.md).
#[test]
fn generators_that_alias_two_factors_are_refused_naming_them() {
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(3));
    req.generators = Some("C=A".into());
    match generate(&req) {
        Err(DoeError::AliasedGenerators {
            factor,
            aliased_with,
            ..
        }) => assert_eq!((factor.as_str(), aliased_with.as_str()), ("C", "A")),
        other => panic!("{other:?}"),
    }
}

/// A column is empty when it has no rows, whatever its type. Kills `factor.rs:50:9: replace
/// Values::is_empty -> bool with false`.
#[test]
fn a_column_without_rows_is_empty() {
    use millcomp_doe::Values;
    assert!(Values::F64(vec![]).is_empty());
    assert!(Values::I64(vec![]).is_empty());
    assert!(Values::Str(vec![]).is_empty());
    assert!(!Values::Str(vec!["S7".into()]).is_empty());
    assert_eq!(Values::F64(vec![1.0, 2.0]).len(), 2);
}

/// The lack-of-fit test needs pure error: x = −1, 0, 1 each run twice, a line fitted (2 coefficients,
/// 4 residual df, 3 pure-error df). With y = 1, 1.2, 0, 0.2, 1, 1.2: pure error SS = 3·(0.1² + 0.1²)
/// = 0.06, the line is flat at the mean 4.6/6 (x is symmetric), SSE = 4.92 − 4.6²/6 = 1.39333…, so
/// lack of fit SS = 4/3 on 1 df and F = (4/3)/(0.06/3) = 200/3 (by hand), p = 0.003842724144709933
/// (scipy 1.17.1: `f.sf(200/3, 1, 3)`). With exact replicates (y = 1, 1, 0, 0, 1, 1) there is no pure
/// error and no test. Kills `analysis/mod.rs:889:22: replace && with || in analyze` (which reports F =
/// ∞ there).
#[test]
fn lack_of_fit_is_tested_only_against_some_pure_error() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let input = |y: Vec<f64>| AnalysisInput {
        factors: vec![(
            "x".into(),
            Values::F64(vec![-1.0, -1.0, 0.0, 0.0, 1.0, 1.0]),
        )],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::Main,
    };
    let a = analyze(&input(vec![1.0, 1.2, 0.0, 0.2, 1.0, 1.2])).unwrap();
    let lof = a.lack_of_fit.unwrap();
    assert_eq!((lof.lack_of_fit_df, lof.pure_error_df), (1, 3));
    assert!((lof.pure_error_ss - 0.06).abs() < 1e-12);
    assert!((lof.lack_of_fit_ss - 4.0 / 3.0).abs() < 1e-12);
    assert!((lof.f - 200.0 / 3.0).abs() < 1e-9);
    assert!((lof.p_value - 0.003842724144709933).abs() < 1e-9);
    let exact = analyze(&input(vec![1.0, 1.0, 0.0, 0.0, 1.0, 1.0])).unwrap();
    assert!(exact.lack_of_fit.is_none(), "{:?}", exact.lack_of_fit);
}

/// A regular fraction asked by its run count: 3 factors in 8 runs is the full 2³; in 16 runs it is
/// refused naming `runs` (at most 2³ = 8, replicate for more); a Plackett–Burman design of 3 factors
/// without `--runs` has 4 (the smallest Hadamard order above 3). Kills `fractional.rs:602:28: replace
/// << with >> in by_runs`, `fractional.rs:605:23: replace > with == in by_runs` and `screening.rs:89:24:
/// replace * with + in plackett_burman` (which starts its search at 5 and gives 8).
#[test]
fn run_counts_at_and_past_the_full_factorial() {
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(3));
    req.runs = Some(8);
    let d = generate(&req).unwrap();
    assert_eq!((d.n_runs(), d.resolution), (8, None));
    req.runs = Some(16);
    match generate(&req) {
        Err(DoeError::InvalidParameter {
            name,
            value,
            allowed,
        }) => {
            assert_eq!((name, value.as_str()), ("runs", "16"));
            assert_eq!(
                allowed,
                "at most 2^3 = 8 for 3 factors (use --replicates for more)"
            );
        }
        other => panic!("{other:?}"),
    }
    let pb = generate(&DesignRequest::new(DesignKind::PlackettBurman, coded(3))).unwrap();
    assert_eq!(pb.n_runs(), 4);
}

/// Lenth's trimming keeps the effects strictly below 2.5·s0: effects 1, 2, 3, 4, 5, 15, 100 have
/// median 4, s0 = 1.5·4 = 6, so 15 = 2.5·s0 is dropped with 100: the trimmed 1…5 have median 3 and
/// PSE = 1.5·3 = 4.5 (by hand; keeping 15 would give 1.5·3.5 = 5.25). Kills `lenth.rs:80:61: replace
/// < with <= in lenth`.
#[test]
fn lenth_drops_an_effect_of_exactly_two_and_a_half_s0() {
    let names: Vec<String> = (0..7).map(|i| format!("e{i}")).collect();
    let l = millcomp_doe::lenth(&names, &[1.0, 2.0, 3.0, 4.0, 5.0, 15.0, 100.0]).unwrap();
    assert_eq!((l.s0, l.pse), (6.0, 4.5));
}

/// A label factor crossed with a numeric one names the product by both (`A:x`, the numeric part
/// without a power), and its square term by the numeric factor's power (`A:x^2`); for a three-level
/// label, by each of its sum-coded columns (`B[r]:x`, `B[r]:x^2`, as `B[x]` in the tests above). Kills
/// `analysis/mod.rs:529:46: replace == with != in build_matrix` (which names them `B[r]:x^1` and
/// `B[r]:x`; the two-level names come from the terms and do not see it).
#[test]
fn a_label_by_numeric_interaction_is_named_by_both() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let mut a = Vec::new();
    let mut x = Vec::new();
    let mut y = Vec::new();
    for (la, base) in [("p", 10.0), ("q", 14.0)] {
        for xv in [-1.0, 0.0, 1.0] {
            for noise in [0.1, -0.1] {
                a.push(la.to_string());
                x.push(xv);
                y.push(base + 2.0 * xv + xv * xv + noise);
            }
        }
    }
    let input = AnalysisInput {
        factors: vec![("A".into(), Values::Str(a)), ("x".into(), Values::F64(x))],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::parse("A + x + A:x + x^2 + A:x^2").unwrap(),
    };
    let fit = analyze(&input).unwrap();
    let names: Vec<&str> = fit.coefficients.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["intercept", "A", "x", "A:x", "x^2", "A:x^2"]);
    // a three-level label factor: one column per level but the last (sum coding), each crossed
    // with x and x²
    let mut b = Vec::new();
    let mut x = Vec::new();
    let mut y = Vec::new();
    for (lb, base) in [("r", 10.0), ("s", 14.0), ("t", 11.0)] {
        for xv in [-1.0, 0.0, 1.0] {
            for noise in [0.1, -0.1] {
                b.push(lb.to_string());
                x.push(xv);
                y.push(base + 2.0 * xv + xv * xv + noise);
            }
        }
    }
    let input = AnalysisInput {
        factors: vec![("B".into(), Values::Str(b)), ("x".into(), Values::F64(x))],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::parse("B + x + B:x + x^2 + B:x^2").unwrap(),
    };
    let fit = analyze(&input).unwrap();
    let names: Vec<&str> = fit.coefficients.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "intercept",
            "B[r]",
            "B[s]",
            "x",
            "B[r]:x",
            "B[s]:x",
            "x^2",
            "B[r]:x^2",
            "B[s]:x^2"
        ]
    );
}

/// A D-optimal design of more than 10 000 runs is refused naming `runs` (its exchange search grows
/// with the square of the runs). Kills `doptimal.rs:205:10: replace > with == in d_optimal` (which
/// refuses exactly 10 000 and lets 10 001 through).
#[test]
fn a_d_optimal_design_past_ten_thousand_runs_is_refused() {
    use millcomp_doe::ModelSpec;
    let mut req = DesignRequest::new(DesignKind::DOptimal, vec![FactorSpec::coded("A")]);
    req.model = Some(ModelSpec::Main);
    req.runs = Some(10_001);
    match generate(&req) {
        Err(DoeError::InvalidParameter { name, value, .. }) => {
            assert_eq!((name, value.as_str()), ("runs", "10001"))
        }
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// The maximin Latin hypercube of 6 runs in 2 factors: the search reaches the largest smallest
/// distance between runs of all 6! = 720 Latin hypercubes on the same levels (enumerated here), from
/// each of 5 seeds. Written for `spacefilling.rs:93:77: replace - with / in lhs`, which it does NOT
/// kill: the mutant turns one of four differences of d⁻¹⁵ terms into a ratio near 1, small beside the
/// others, and the search still reaches the maximin here (docs/reliability-mutants.md).
#[test]
fn a_small_latin_hypercube_reaches_the_maximin_of_all() {
    fn permutations(v: &mut Vec<usize>, k: usize, out: &mut Vec<Vec<usize>>) {
        if k == v.len() {
            out.push(v.clone());
            return;
        }
        for i in k..v.len() {
            v.swap(k, i);
            permutations(v, k + 1, out);
            v.swap(k, i);
        }
    }
    let min_dist = |pts: &[[f64; 2]]| {
        let mut m = f64::INFINITY;
        for i in 0..pts.len() {
            for j in i + 1..pts.len() {
                m = m.min((pts[i][0] - pts[j][0]).powi(2) + (pts[i][1] - pts[j][1]).powi(2));
            }
        }
        m
    };
    let n = 6;
    let level = |i: usize| -1.0 + (2 * i + 1) as f64 / n as f64;
    let mut all = Vec::new();
    permutations(&mut (0..n).collect(), 0, &mut all);
    let best = all
        .iter()
        .map(|p| min_dist(&(0..n).map(|i| [level(i), level(p[i])]).collect::<Vec<_>>()))
        .fold(0.0, f64::max);
    for seed in 1..=5 {
        let mut req = DesignRequest::new(
            DesignKind::Lhs,
            vec![FactorSpec::coded("A"), FactorSpec::coded("B")],
        );
        req.runs = Some(n);
        req.seed = Some(seed);
        let d = generate(&req).unwrap();
        let pts: Vec<[f64; 2]> = d.runs.iter().map(|r| [r.coded[0], r.coded[1]]).collect();
        assert!(
            (min_dist(&pts) - best).abs() < 1e-12,
            "seed {seed}: {} vs {best}",
            min_dist(&pts)
        );
    }
}

/// Generators may name factors by letter when the factors have names: on depth_um, upfeed_um,
/// speed_rpm, tool, `D=ABC` is the 2⁴⁻¹ of resolution IV with I = ABCD, 8 runs. Kills
/// `fractional.rs:87:68: replace == with != in resolve_factor` (which resolves a letter to another
/// factor).
#[test]
fn generators_name_named_factors_by_letter() {
    let f =
        FactorSpec::parse_list("depth_um=100:200,upfeed_um=10:20,speed_rpm=20000:40000,tool=1:2")
            .unwrap();
    let mut req = DesignRequest::new(DesignKind::Fractional, f);
    req.generators = Some("D=ABC".into());
    let d = generate(&req).unwrap();
    assert_eq!((d.n_runs(), d.resolution), (8, Some(4)));
    assert_eq!(d.defining_relation, ["I=ABCD"]);
}

/// A coded value between a factor's levels maps to its actual value, not to a level: for x = 0 : 10
/// the centre (coded 0) is 5 by hand, and the levels 0 and 10 are 5 away, far beyond the snapping
/// tolerance 1e-9·(10 − 0). Kills `factor.rs:289:38: replace - with / in FactorSpec::actual` (found by
/// the fresh draw of seed 52), whose tolerance 1e-9·|10 / 0| is infinite and snaps every value to the
/// first level, 0.
#[test]
fn a_coded_value_between_the_levels_is_not_snapped_to_one() {
    use millcomp_doe::Level;
    let f = FactorSpec::parse_list("x=0:10").unwrap();
    assert_eq!(f[0].actual(0.0), Level::Num(5.0));
    assert_eq!(f[0].actual(0.5), Level::Num(7.5));
    assert_eq!(f[0].actual(1.0), Level::Num(10.0));
}

/// Only a resolution III fraction warns that its main effects are aliased with two-factor
/// interactions: 2^(5−2) with D = AB, E = −AC has I = ABD = −ACE = −BCDE, resolution III (Montgomery,
/// Design and Analysis of Experiments, 8th ed., §8.3), and carries the note; 2^(4−1) with D = ABC has
/// I = ABCD, resolution IV, and does not. Kills `factorial.rs:267:14: replace == with != in
/// fractional` (found by the fresh draw of seed 52), which notes it for every resolution but III.
#[test]
fn only_a_resolution_three_fraction_warns_of_aliased_main_effects() {
    let warns = |d: &millcomp_doe::Design| d.notes.iter().any(|n| n.starts_with("resolution III"));
    let mut r = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list("a,b,c,d,e").unwrap(),
    );
    r.generators = Some("D=AB,E=-AC".into());
    let d = generate(&r).unwrap();
    assert_eq!(d.resolution, Some(3));
    assert!(warns(&d), "{:?}", d.notes);
    let mut r = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list("a,b,c,d").unwrap(),
    );
    r.generators = Some("D=ABC".into());
    let d = generate(&r).unwrap();
    assert_eq!(d.resolution, Some(4));
    assert!(!warns(&d), "{:?}", d.notes);
}

/// A central composite design on a fraction reports the fraction's defining relation and word
/// length pattern: the 5-factor CCD's cube is the 2^(5−1) with E = ABCD (resolution V), so I = ABCDE
/// and one word of length 5 (A3, A4, A5 = 0, 0, 1), as Montgomery §8.2 gives for that fraction. Kills
/// `rsm.rs:138:9: delete field defining_relation …` and `rsm.rs:139:9: delete field
/// word_length_pattern from struct BasePoints expression in ccd` (found by the fresh draw of seed 52),
/// which report none.
#[test]
fn a_ccd_on_a_fraction_reports_its_defining_relation() {
    let d = generate(&DesignRequest::new(
        DesignKind::Ccd {
            variant: millcomp_doe::CcdVariant::Circumscribed,
            alpha: millcomp_doe::CcdAlpha::Rotatable,
        },
        FactorSpec::parse_list("a,b,c,d,e").unwrap(),
    ))
    .unwrap();
    assert_eq!(d.resolution, Some(5));
    assert_eq!(d.defining_relation, ["I=ABCDE"]);
    assert_eq!(d.word_length_pattern, [0, 0, 1]);
}

/// Box–Behnken designs are tabulated up to 7 factors (Box & Behnken 1960, Table 1): the 7-factor design
/// carries no note, the 8-factor one, built from all factor pairs, says so. Kills `rsm.rs:206:10:
/// replace > with >= in box_behnken` (found by the fresh draw of seed 52), which notes it for 7 too.
#[test]
fn only_a_box_behnken_design_beyond_the_table_says_it_is_built_from_pairs() {
    let note = |k: usize| {
        let names: Vec<String> = (0..k).map(|i| format!("x{i}")).collect();
        let d = generate(&DesignRequest::new(
            DesignKind::BoxBehnken,
            FactorSpec::parse_list(&names.join(",")).unwrap(),
        ))
        .unwrap();
        d.notes
            .iter()
            .any(|n| n.contains("built from all factor pairs"))
    };
    assert!(!note(7));
    assert!(note(8));
}

// ---- survivors of the fresh draw (seed 52 on the tree of fc72a1f; docs/reliability-mutants.md) ----

/// A Plackett–Burman design needs more runs than factors: 4 factors in 4 runs is refused naming
/// `runs` (the bound is k + 1 = 5: a Hadamard matrix of order 4 has only 3 non-constant columns), 3
/// factors in 4 runs is built. Kills `screening.rs:76:22: replace + with - in plackett_burman` (whose
/// bound k − 1 = 3 lets 4 factors into 4 runs).
#[test]
fn a_plackett_burman_design_needs_more_runs_than_factors() {
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, coded(4));
    req.runs = Some(4);
    match generate(&req) {
        Err(DoeError::InvalidParameter {
            name,
            value,
            allowed,
        }) => {
            assert_eq!((name, value.as_str()), ("runs", "4"));
            assert!(allowed.contains("from 5"), "{allowed}");
        }
        other => panic!("{other:?}"),
    }
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, coded(3));
    req.runs = Some(4);
    assert_eq!(generate(&req).unwrap().n_runs(), 4);
}

/// A power calculation needs 0 < α < 1: 1.5 and 0 are refused naming `alpha`, 0.05 is taken. Kills
/// `analysis/mod.rs:1158:22: replace && with || in power` (which takes any α that is a number).
#[test]
fn power_needs_alpha_between_zero_and_one() {
    use millcomp_doe::{ModelSpec, Values, power};
    let f = vec![(
        "A".to_string(),
        Values::F64(vec![-1.0, 1.0, -1.0, 1.0, -1.0, 1.0]),
    )];
    for alpha in [1.5, 0.0] {
        match power(&f, &ModelSpec::Main, 1.0, 1.0, alpha) {
            Err(DoeError::InvalidParameter { name, .. }) => assert_eq!(name, "alpha"),
            other => panic!("alpha {alpha}: {other:?}"),
        }
    }
    assert!(power(&f, &ModelSpec::Main, 1.0, 1.0, 0.05).is_ok());
}

/// The total sum of squares of responses that share a large offset keeps the digits of their
/// differences: 4000 responses 10¹³ + 0.5·A + a pattern in steps of 10⁻³ (A = ±1). At 10¹³ the f64
/// grid is 2⁻⁹ ≈ 0.002, and the plain running sum's mean is 0.27 off the exact mean (Python's float
/// arithmetic, the same IEEE operations in the same order); the second pass of `centred` brings it
/// back within one grid step. Reference: the exact total sum of squares of the f64 values, computed
/// here in integers of the 2⁻⁹ grid; the analysis's `SSE / (1 − R²)` must equal it to 1e-5 (measured
/// 7.5e-7, the rounding of the mean to the grid). Kills `analysis/mod.rs:604:16: replace + with - in
/// centred` (mean 0.55 off: the total 90 % too large).
#[test]
fn responses_with_a_large_common_offset_keep_their_total_sum_of_squares() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let n = 4000usize;
    let a: Vec<f64> = (0..n)
        .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let y: Vec<f64> = (0..n)
        .map(|i| 1e13 + 0.5 * a[i] + ((i * 7919) % 1000) as f64 * 1e-3)
        .collect();
    // exact: every y is an integer multiple of 2⁻⁹ (10¹³ is in [2⁴³, 2⁴⁴))
    let base = (1e13f64 * 512.0) as i128;
    let d: Vec<i128> = y
        .iter()
        .map(|v| {
            let k = v * 512.0;
            assert_eq!(k.fract(), 0.0);
            k as i128 - base
        })
        .collect();
    let (s1, s2) = d
        .iter()
        .fold((0i128, 0i128), |(s1, s2), &x| (s1 + x, s2 + x * x));
    let n_i = n as i128;
    let sst_exact = (n_i * s2 - s1 * s1) as f64 / n as f64 / (512.0 * 512.0);
    let input = AnalysisInput {
        factors: vec![("A".into(), Values::F64(a))],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::Main,
    };
    let an = analyze(&input).unwrap();
    let sst = an.residual_sum_sq / (1.0 - an.r_squared);
    assert!(
        ((sst - sst_exact) / sst_exact).abs() < 1e-5,
        "{sst} against {sst_exact}"
    );
}

/// A coded value within rounding of a level maps to the level as written: for x = 1000 : 2000 the
/// tolerance is 1e-9·(2000 − 1000) = 1e-6, and coded 1 − 1e-11 gives 1999.999999995 (5e-9 from 2000,
/// by hand), which is the level 2000; coded 1 − 1e-8 gives 1999.999995 (5e-6 away), which is not.
/// Kills `factor.rs:289:32: replace * with / in FactorSpec::actual` (found by the draw of seed 52
/// beyond its first 130), whose tolerance 1e-9 / 1000 = 1e-12 snaps neither.
#[test]
fn a_coded_value_within_rounding_of_a_level_is_that_level() {
    use millcomp_doe::Level;
    let f = FactorSpec::parse_list("x=1000:2000").unwrap();
    assert_eq!(f[0].actual(1.0 - 1e-11), Level::Num(2000.0));
    match f[0].actual(1.0 - 1e-8) {
        Level::Num(x) => assert!((x - 1999.999995).abs() < 1e-9, "{x}"),
        other => panic!("{other:?}"),
    }
}

/// An analysis's significance level must lie strictly inside (0, 1): 1 is refused as the option
/// `alpha`, 0.999 is taken. Kills `analysis/options.rs:68:45: replace < with <= in
/// AnalyzeOptions::run` (found by the draw of seed 52 beyond its first 130), which takes α = 1.
#[test]
fn an_analysis_level_of_one_is_refused() {
    use millcomp_doe::{AnalyzeOptions, Values};
    let table = vec![
        ("a".to_string(), Values::F64(vec![-1.0, 1.0, -1.0, 1.0])),
        ("y".to_string(), Values::F64(vec![1.0, 2.0, 1.5, 2.5])),
    ];
    let mut o = AnalyzeOptions::new("y");
    o.alpha = 1.0;
    assert!(matches!(
        o.run("t.csv", &table),
        Err(DoeError::BadOption {
            option: "alpha",
            ..
        })
    ));
    o.alpha = 0.999;
    assert!(o.run("t.csv", &table).is_ok());
}

/// Five factors in 8 runs is the catalogue's 2^(5−2), resolution III (Montgomery, Design and Analysis
/// of Experiments, 8th ed., Table 8.14): asked at resolution III it is built, asked at resolution IV
/// it is refused naming the runs and the resolution. Kills `factorial.rs:234:41: replace < with == in
/// fractional` (found by the draw of seed 52 beyond its first 130), which refuses the first and
/// builds the second.
#[test]
fn a_fraction_by_runs_holds_the_resolution_asked() {
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(5));
    req.runs = Some(8);
    req.resolution = Some(3);
    let d = generate(&req).unwrap();
    assert_eq!((d.n_runs(), d.resolution), (8, Some(3)));
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(5));
    req.runs = Some(8);
    req.resolution = Some(4);
    match generate(&req) {
        Err(DoeError::NoCatalogueDesign {
            factors, request, ..
        }) => {
            assert_eq!(factors, 5);
            assert!(
                request.contains("8 runs") && request.contains("resolution"),
                "{request}"
            );
        }
        other => panic!("{other:?}"),
    }
}

/// A power calculation reports the terms an effect "high − low" describes — the main effects and the
/// interaction of a quadratic model — and skips the squares: on the 3² factorial (9 runs, residual
/// df 3) the terms are A, B and A:B. For A, λ = (effect/2)² / (σ²·(XᵀX)⁻¹_AA) with (XᵀX)⁻¹_AA = 1/6 (the
/// linear column −1, 0, 1 three times is orthogonal to the others: Σx² = 6), so effect 2, σ 1 give
/// λ = 6. Kills `analysis/mod.rs:1192:66: replace == with != in power` (found by the draw of seed 52
/// beyond its first 130), which skips every term beside a square of another name.
#[test]
fn power_of_a_quadratic_model_skips_only_the_squares() {
    use millcomp_doe::{ModelSpec, Values, power};
    let mut a = Vec::new();
    let mut b = Vec::new();
    for la in [-1.0, 0.0, 1.0] {
        for lb in [-1.0, 0.0, 1.0] {
            a.push(la);
            b.push(lb);
        }
    }
    let f = vec![
        ("A".to_string(), Values::F64(a)),
        ("B".to_string(), Values::F64(b)),
    ];
    let r = power(&f, &ModelSpec::Quadratic, 2.0, 1.0, 0.05).unwrap();
    assert_eq!(r.residual_df, 3);
    let names: Vec<&str> = r.terms.iter().map(|t| t.term.as_str()).collect();
    assert_eq!(names, ["A", "B", "A:B"]);
    assert!(
        (r.terms[0].noncentrality - 6.0).abs() < 1e-9,
        "{}",
        r.terms[0].noncentrality
    );
}

/// Generators that reach exactly the resolution asked are taken: D = ABC gives I = ABCD, resolution
/// IV (Montgomery, 8th ed., §8.2), so a request for resolution 4 with it is built (8 runs) and one
/// for 5 is refused naming the generator. Kills `factorial.rs:195:24: replace < with <= in
/// fractional` (found by the draw of seed 52 beyond its first 130), which refuses the first.
#[test]
fn generators_that_reach_the_asked_resolution_are_taken() {
    let ask = |r: u32| {
        let mut req = DesignRequest::new(
            DesignKind::Fractional,
            FactorSpec::parse_list("a,b,c,d").unwrap(),
        );
        req.generators = Some("D=ABC".into());
        req.resolution = Some(r);
        generate(&req)
    };
    let d = ask(4).unwrap();
    assert_eq!((d.n_runs(), d.resolution), (8, Some(4)));
    match ask(5) {
        Err(DoeError::InvalidGenerator { generator, .. }) => assert_eq!(generator, "D=ABC"),
        other => panic!("{other:?}"),
    }
}

/// Two columns are aliased when the second's part beyond the first (and the intercept) is at most
/// 1e-9 of its norm (modified Gram–Schmidt, `first_dependent_column`): on 8 runs, e = (−1, 0 ×6, 1)
/// has norm √2, and f = e + ε·(0, 1, −1, 0 ×5) keeps f's range and coding, so its part beyond e and the
/// intercept is ε·√2. With ε = 1.5e-9 that is 2.1e-9 > 1e-9·√2: not aliased, analysed; with ε = 5e-10
/// it is 7.1e-10 ≤ 1.4e-9: aliased, refused naming f. Kills the two mutants of
/// `analysis/mod.rs:624:53` in `first_dependent_column` (`*` replaced with `+` and with `/`; found by
/// the draw of seed 52 beyond its first 130), whose floors √8 + 1e-3 and √8 / 1e-3 call the first
/// aliased too.
#[test]
fn columns_are_aliased_only_within_their_tolerance() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let run = |eps: f64| {
        let e = vec![-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let mut f = e.clone();
        f[1] = eps;
        f[2] = -eps;
        analyze(&AnalysisInput {
            factors: vec![("e".into(), Values::F64(e)), ("f".into(), Values::F64(f))],
            response_name: "y".into(),
            response: Values::F64(vec![1.0, 2.0, 1.5, 2.5, 3.0, 2.0, 1.0, 4.0]),
            model: ModelSpec::Main,
        })
    };
    let a = run(1.5e-9).unwrap();
    assert_eq!(a.residual_df, 5);
    match run(5e-10) {
        Err(DoeError::AliasedTerms { term, .. }) => assert_eq!(term, "f"),
        other => panic!("{other:?}"),
    }
}

/// A constraint may start with a sign: `-a + b <= 0.5` is −a + b ≤ 0.5 (coefficients −1 and +1, by
/// hand), satisfied at (a, b) = (0, 0.5) and not at (−0.5, 0.5). Kills `doptimal.rs:99:46: replace >
/// with >= in LinearConstraint::parse` (found by the draw of seed 52 beyond its first 130), which
/// splits before the leading sign and refuses an empty term.
#[test]
fn a_constraint_may_start_with_a_sign() {
    use millcomp_doe::LinearConstraint;
    let f = FactorSpec::parse_list("a,b").unwrap();
    let c = LinearConstraint::parse_list("-a + b <= 0.5", &f).unwrap();
    assert_eq!(c[0].coefs, [(0, -1.0), (1, 1.0)]);
    assert_eq!(c[0].rhs, 0.5);
    assert!(c[0].satisfied(&[0.0, 0.5]));
    assert!(!c[0].satisfied(&[-0.5, 0.5]));
}

/// The model keywords are taken whatever their case: `quadratic`, `rsm`, `full-quadratic` and `RSM`
/// are the quadratic model, `main` the main effects. Kills `model.rs:42:13: delete match arm
/// "quadratic" | "rsm" | "full-quadratic" in ModelSpec::parse` (found by the draw of seed 52 beyond its
/// first 130), which reads them as a formula of one unknown factor.
#[test]
fn the_quadratic_model_is_asked_by_its_keywords() {
    use millcomp_doe::ModelSpec;
    for k in ["quadratic", "rsm", "full-quadratic", "RSM"] {
        assert_eq!(ModelSpec::parse(k).unwrap(), ModelSpec::Quadratic, "{k}");
    }
    assert_eq!(ModelSpec::parse("main").unwrap(), ModelSpec::Main);
}

/// A factor named again with a coefficient other than ±1 adds that coefficient: `b + 3*b - a <= 2`
/// is −a + 4·b ≤ 2 (by hand). Kills `doptimal.rs:143:43: replace * with / in
/// LinearConstraint::parse` (found by the draw of seed 52 beyond its first 300), which adds 1/3.
#[test]
fn a_factor_named_again_adds_its_coefficient() {
    use millcomp_doe::LinearConstraint;
    let f = FactorSpec::parse_list("a,b").unwrap();
    let c = LinearConstraint::parse_list("b + 3*b - a <= 2", &f).unwrap();
    assert_eq!(c[0].coefs, [(1, 4.0), (0, -1.0)]);
    assert_eq!(c[0].rhs, 2.0);
}

/// A factor named twice in a generator's word is refused naming it, whichever factor it is: `D=ABB`
/// (B, the second factor) as well as `D=AAB`. Kills `fractional.rs:142:17: replace >> with << in
/// parse_word` (found by the draw of seed 53), whose `mask << i & 1` sees a repeat of the first
/// factor only and lets `D=ABB` through as D = A.
#[test]
fn a_factor_twice_in_a_generator_word_is_refused_naming_it() {
    for (gens, twice) in [("D=ABB", "B"), ("D=AAB", "A"), ("D=ACC", "C")] {
        let mut req = DesignRequest::new(DesignKind::Fractional, coded(4));
        req.generators = Some(gens.into());
        match generate(&req) {
            Err(DoeError::InvalidGenerator { reason, .. }) => assert_eq!(
                reason,
                format!("factor `{twice}` appears twice in the word"),
                "{gens}"
            ),
            other => panic!("{gens}: {other:?}"),
        }
    }
}

/// Every name `doe design --design` documents for a design parses to it (docs/doe.md lists them).
/// Kills `design/mod.rs:173:13: delete match arm "plackett-burman" | "pb" | "plackett_burman" in
/// <impl FromStr for DesignKind>::from_str` (found by the draw of seed 53), which refuses all three.
#[test]
fn every_documented_design_name_parses() {
    use millcomp_doe::{CcdAlpha, CcdVariant};
    let ccd = |variant| DesignKind::Ccd {
        variant,
        alpha: CcdAlpha::Rotatable,
    };
    let cases = [
        ("full", DesignKind::Full),
        ("Full-Factorial", DesignKind::Full),
        ("frac", DesignKind::Fractional),
        ("plackett-burman", DesignKind::PlackettBurman),
        ("pb", DesignKind::PlackettBurman),
        ("plackett_burman", DesignKind::PlackettBurman),
        (" PB ", DesignKind::PlackettBurman),
        ("ccd", ccd(CcdVariant::Circumscribed)),
        ("ccf", ccd(CcdVariant::FaceCentred)),
        ("cci", ccd(CcdVariant::Inscribed)),
        ("bbd", DesignKind::BoxBehnken),
        ("lhs", DesignKind::Lhs),
        ("dsd", DesignKind::Dsd),
        ("d-optimal", DesignKind::DOptimal),
    ];
    for (name, kind) in cases {
        assert_eq!(name.parse::<DesignKind>().unwrap(), kind, "{name}");
    }
    assert!("pbb".parse::<DesignKind>().is_err());
}

/// A two-level label factor enters the response surface as its second level (+1 in the coded
/// column): coolant dry/wet over 4 runs with y = 10, 14 (dry) and 20, 24 (wet) has the cell means 12
/// and 22 (by hand), and the surface predicts them at each label. Kills `surface.rs:75:49: replace ==
/// with != in response_surface` (found by the draw of seed 53), which files the +1 column under
/// the first level, so that "dry" predicts 22 and "wet" 12.
#[test]
fn a_two_level_label_factor_predicts_each_levels_mean() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze, response_surface};
    use millcomp_models::Level;
    let s = |v: &[&str]| Values::Str(v.iter().map(|s| s.to_string()).collect());
    let input = AnalysisInput {
        factors: vec![("coolant".into(), s(&["dry", "wet", "dry", "wet"]))],
        response_name: "y".into(),
        response: Values::F64(vec![10.0, 20.0, 14.0, 24.0]),
        model: ModelSpec::Main,
    };
    let m = response_surface(&analyze(&input).unwrap()).unwrap();
    for (label, mean) in [("dry", 12.0), ("wet", 22.0)] {
        let p = m
            .predict_levels(&[("coolant", Level::Label(label.into()))])
            .unwrap();
        assert!((p.mean - mean).abs() < 1e-12, "{label}: {}", p.mean);
    }
}

/// The 12-run Plackett–Burman design in standard order is Plackett & Burman's (1946, Biometrika
/// 33:305–325) cyclic construction as Montgomery (*Design and Analysis of Experiments*, 8th ed.,
/// Table 8.23) prints it: the first row `++-+++---+-`, each next row the previous one shifted one
/// position to the right (the last sign moves to the front), a last row of minus signs. Kills
/// `screening.rs:43:48: replace - with + in hadamard` (found by the draw of seed 52), which shifts
/// to the left: the same Hadamard matrix with its rows permuted, so that run 2 reads `+-+++---+-+`.
#[test]
fn the_twelve_run_plackett_burman_rows_are_the_published_cyclic_shifts() {
    let d = generate(&DesignRequest::new(DesignKind::PlackettBurman, coded(11))).unwrap();
    let mut runs: Vec<_> = d.runs.iter().collect();
    runs.sort_by_key(|r| r.std_order);
    let signs = |r: &millcomp_doe::Run| -> String {
        r.coded
            .iter()
            .map(|&x| if x > 0.0 { '+' } else { '-' })
            .collect()
    };
    let got: Vec<String> = runs.iter().map(|r| signs(r)).collect();
    let published = [
        "++-+++---+-",
        "-++-+++---+",
        "+-++-+++---",
        "-+-++-+++--",
        "--+-++-+++-",
        "---+-++-+++",
        "+---+-++-++",
        "++---+-++-+",
        "+++---+-++-",
        "-+++---+-++",
        "+-+++---+-+",
        "-----------",
    ];
    assert_eq!(got, published);
}

/// A seeded Latin hypercube is the same design on every run, and the one the maximin search keeps:
/// 12 runs of 3 factors (levels −1 + (2i + 1)/12, so every squared distance is a multiple of 1/36)
/// reach the smallest distance √m/6 with m = 29, 33, 29, 29, 27, 29 for seeds 1–6 — recorded from
/// this implementation at 809c00d (ChaCha8 from `--seed`; five starts of the Morris–Mitchell swap
/// search, the best φ₁₅ kept). A change of which start is kept or of how a swap updates the
/// distances changes them. Kills `spacefilling.rs:72:30: replace + with * in lhs` (every start's φ
/// infinite, so the first start is kept, not the best) and `spacefilling.rs:93:42: replace - with +
/// in lhs` (a swap's distances updated wrongly, so the search is misled), both found by the draw of
/// seed 52.
#[test]
fn a_seeded_latin_hypercube_keeps_the_best_start() {
    let mut got = Vec::new();
    for seed in 1..=6u64 {
        let mut req = DesignRequest::new(DesignKind::Lhs, coded(3));
        req.seed = Some(seed);
        req.runs = Some(12);
        let d = generate(&req).unwrap();
        let dmin = d.criteria.min_distance.unwrap();
        let m = 36.0 * dmin * dmin;
        assert!((m - m.round()).abs() < 1e-9, "seed {seed}: {m}");
        got.push(m.round() as u32);
    }
    assert_eq!(got, [29, 33, 29, 29, 27, 29]);
}

/// A 2⁴ full factorial in 4 blocks has blocks 1–4 of 4 runs each (two block generators, their
/// product's sign pair numbering the block: Montgomery, 8th ed., §7.6). Kills `factorial.rs:105:30:
/// replace << with >> in regular_two_level` (found by the draw of seed 53), which sets no bit for
/// the second generator and so puts the 16 runs in blocks 1 and 2 only.
#[test]
fn four_blocks_of_a_two_to_the_four_have_four_runs_each() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(4));
    req.blocks = 4;
    let d = generate(&req).unwrap();
    let mut count = [0usize; 4];
    for r in &d.runs {
        count[r.block - 1] += 1;
    }
    assert_eq!(count, [4, 4, 4, 4]);
}

/// A CCD's axial distance must be positive and finite also when a library caller builds
/// `CcdAlpha::Value` directly (the text form is checked where it is parsed): −1.5 and +∞ are refused
/// naming `alpha`, 1.5 is taken (axial points at ±1.5). Kills `rsm.rs:93:24: replace && with || in
/// ccd` (found by the draw of seed 53), which takes any finite or any positive α.
#[test]
fn a_ccd_refuses_a_negative_or_infinite_alpha_given_as_a_value() {
    use millcomp_doe::{CcdAlpha, CcdVariant};
    let req = |a: f64| {
        let kind = DesignKind::Ccd {
            variant: CcdVariant::Circumscribed,
            alpha: CcdAlpha::Value(a),
        };
        let mut r = DesignRequest::new(kind, coded(2));
        r.randomize = false;
        r
    };
    for a in [-1.5, f64::INFINITY] {
        match generate(&req(a)) {
            Err(DoeError::InvalidParameter { name, .. }) => assert_eq!(name, "alpha", "{a}"),
            other => panic!("{a}: {other:?}"),
        }
    }
    let d = generate(&req(1.5)).unwrap();
    let widest = d
        .runs
        .iter()
        .flat_map(|r| r.coded.iter().map(|x| x.abs()))
        .fold(0.0, f64::max);
    assert!((widest - 1.5).abs() < 1e-12, "{widest}");
}

/// A design takes at most 4095 factors (`MAX_FACTORS`, the largest Plackett–Burman design's): 4096
/// coded factors are refused naming `factors` before anything is built (a definitive screening design of
/// 20 000 factors asked for 8 GB or more and aborted). With that bound the Plackett–Burman search can
/// no longer run past 4096 runs, so `screening.rs:88:34: replace / with * in plackett_burman` (found by
/// the draw of seed 53, which this test killed before the bound) is now equivalent.
#[test]
fn a_design_takes_at_most_4095_factors() {
    for kind in [DesignKind::PlackettBurman, DesignKind::Dsd, DesignKind::Lhs] {
        match generate(&DesignRequest::new(kind, coded(4096))) {
            Err(DoeError::InvalidParameter { name, value, .. }) => {
                assert_eq!((name, value.as_str()), ("factors", "4096"), "{kind:?}")
            }
            other => panic!("{kind:?}: {:?}", other.map(|d| d.n_runs())),
        }
    }
    assert_eq!(millcomp_doe::MAX_FACTORS, 4095);
}

/// A mixed-level full factorial of exactly 1e6 runs (6 factors of 10 levels) is built — the limit is
/// "at most 1e6" (10^10 is refused by the test above). Kills `factorial.rs:152:14: replace > with >=
/// in full` (found by the draw of seed 53), which refuses the limit itself.
#[test]
fn a_full_factorial_of_exactly_a_million_runs_is_built() {
    let spec = (0..6)
        .map(|i| format!("{}=1:2:3:4:5:6:7:8:9:10", millcomp_doe::factor_letter(i)))
        .collect::<Vec<_>>()
        .join(",");
    let factors = FactorSpec::parse_list(&spec).unwrap();
    let mut req = DesignRequest::new(DesignKind::Full, factors);
    req.randomize = false;
    assert_eq!(generate(&req).unwrap().n_runs(), 1_000_000);
}

/// A bound that overflows to infinity is refused as a non-finite number, with finite coefficients:
/// `a + b <= 1e999` (1e999 parses to +∞). Kills `doptimal.rs:154:29: replace || with && in
/// LinearConstraint::parse` (found by the draw of seed 53), which refuses only when a coefficient is
/// non-finite as well.
#[test]
fn a_constraint_whose_bound_overflows_is_refused() {
    use millcomp_doe::LinearConstraint;
    let f = FactorSpec::parse_list("a,b").unwrap();
    for text in ["a + b <= 1e999", "a - b >= -1e999"] {
        match LinearConstraint::parse_list(text, &f) {
            Err(DoeError::InvalidConstraint { constraint, reason }) => {
                assert_eq!(
                    (constraint.as_str(), reason.as_str()),
                    (text, "non-finite number")
                )
            }
            other => panic!("{text}: {other:?}"),
        }
    }
    assert!(LinearConstraint::parse_list("a + b <= 1e300", &f).is_ok());
}

/// A fraction of 64 factors by its run count: 64 is past the factor count whose 2^k fits a u64, so
/// the run-count checks against 2^k are skipped (they would overflow) and 128 runs for 64 factors is
/// refused by the catalogue search, naming the factors. Kills `fractional.rs:605:10: replace < with
/// <= in by_runs` (found by the draw of seed 53), which shifts 1 by 64 (a panic in debug builds).
#[test]
fn a_fraction_of_sixty_four_factors_by_runs_does_not_overflow() {
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(64));
    req.runs = Some(128);
    match generate(&req) {
        Err(DoeError::NoCatalogueDesign {
            factors, request, ..
        }) => assert_eq!((factors, request.as_str()), (64, "in 128 runs")),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// A design lists each factor's levels as written (what `doe design --json` gives under `factors`):
/// `depth_um=100:150:200` → 100, 150, 200; `coolant=dry:wet` → the two labels; a bare name → −1, +1.
/// Kills `factor.rs:305:9: replace FactorSpec::level_values -> Vec<Level> with vec![]` (found by the
/// draw of seed 53), which lists no levels.
#[test]
fn a_designs_factors_list_their_levels_as_written() {
    use millcomp_doe::Level;
    let f = FactorSpec::parse_list("depth_um=100:150:200,coolant=dry:wet,c").unwrap();
    let d = generate(&DesignRequest::new(DesignKind::Full, f)).unwrap();
    let levels: Vec<Vec<Level>> = d.factors.iter().map(|f| f.levels.clone()).collect();
    assert_eq!(
        levels,
        [
            vec![Level::Num(100.0), Level::Num(150.0), Level::Num(200.0)],
            vec![Level::Label("dry".into()), Level::Label("wet".into())],
            vec![Level::Num(-1.0), Level::Num(1.0)],
        ]
    );
}

/// A two-level design's base factors are limited to 20 (2^20 runs) before anything is built, and every
/// design to 10^6 runs: the full 2^20 of 20 coded factors (1 048 576 runs) is refused by the run cap,
/// naming both counts, and 21 factors by the base limit, naming 2^21. Kills
/// `factorial.rs:50:19: replace > with >= in regular_two_level` (found by the draw of seed 53), which
/// refuses 20 factors by the base limit with "2^20 runs (at most 2^20)".
#[test]
fn twenty_two_level_factors_meet_the_run_cap_and_twenty_one_the_base_limit() {
    match generate(&DesignRequest::new(DesignKind::Full, coded(20))) {
        Err(DoeError::InvalidParameter { name, allowed, .. }) => assert_eq!(
            (name, allowed.as_str()),
            (
                "replicates",
                "a design of at most 1000000 runs (this one would have 1048576: 1048576 runs × 1 replicates)"
            )
        ),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
    match generate(&DesignRequest::new(DesignKind::Full, coded(21))) {
        Err(DoeError::Unsupported { what }) => {
            assert_eq!(what, "a two-level design with 2^21 runs (at most 2^20)")
        }
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// A 7-factor Box–Behnken design is Box & Behnken's (1960, Technometrics 2:455–475) balanced
/// incomplete block plan: 7 blocks of 3 factors, each a 2³ with the others at their centre — 56 runs
/// before centre points, each factor at ±1 in 24 of them. Kills `rsm.rs:161:9: delete match arm 7 in
/// bbd_groups` (found by the draw of seed 53), which falls back to all 21 pairs (84 runs).
#[test]
fn a_seven_factor_box_behnken_design_has_fifty_six_edge_runs() {
    let mut req = DesignRequest::new(DesignKind::BoxBehnken, coded(7));
    req.center_points = Some(0);
    req.randomize = false;
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 56);
    for j in 0..7 {
        let at_edge = d.runs.iter().filter(|r| r.coded[j] != 0.0).count();
        assert_eq!(at_edge, 24, "factor {j}");
    }
    assert!(
        d.runs
            .iter()
            .all(|r| r.coded.iter().filter(|x| **x != 0.0).count() == 3)
    );
}

/// The effects confounded with blocks are named by the lowest-order member of their alias set: the
/// 2^(6−1) with F = ABCDE (I = ABCDEF) in 8 blocks has block generators ABC, ABD, ACE, and the product
/// ABD·ACE = BCDE is aliased with AF (BCDE·ABCDEF = AF, by hand), so it is listed as `A:F`. Kills
/// `factorial.rs:123:35: replace ^ with | in regular_two_level` (found by the draw of seed 53), which
/// keeps each product as it is (`B:C:D:E`).
#[test]
fn effects_confounded_with_blocks_are_named_by_their_lowest_order_alias() {
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(6));
    req.generators = Some("F=ABCDE".into());
    req.blocks = 8;
    let d = generate(&req).unwrap();
    assert_eq!(d.block_generators, ["ABC", "ABD", "ACE"]);
    assert_eq!(
        d.confounded_with_blocks,
        ["C:D", "B:E", "A:F", "A:B:C", "A:B:D", "A:C:E", "A:D:E"]
    );
}

/// Lenth's pseudo standard error (Lenth 1989, Technometrics 31:469–473) is computed from two effects
/// on: 1 and 2 give s0 = 1.5·median = 2.25 and, nothing trimmed, PSE = 2.25 (by hand); and it trims
/// effects at or above 2.5·s0 before its second median: 1, 2, 7.5 have s0 = 1.5·2 = 3, so 7.5 is
/// trimmed and PSE = 1.5·median(1, 2) = 2.25. One effect has none. Kills `lenth.rs:75:10: replace <
/// with <= in lenth` (found by the draw of seed 53), which gives none for two effects.
#[test]
fn lenth_is_computed_from_two_effects_and_trims_at_two_and_a_half_s0() {
    let names: Vec<String> = ["A", "B", "C"].iter().map(|s| s.to_string()).collect();
    let two = millcomp_doe::lenth(&names[..2], &[1.0, 2.0]).unwrap();
    assert_eq!((two.s0, two.pse), (2.25, 2.25));
    let l = millcomp_doe::lenth(&names, &[1.0, 2.0, 7.5]).unwrap();
    assert_eq!((l.s0, l.pse), (3.0, 2.25));
    assert!(millcomp_doe::lenth(&names[..1], &[1.0]).is_none());
}

/// A run whose studentised residual exceeds 3 is an outlier, the others are not: a 2⁴ in 16 runs,
/// main effects, y = 10 + 2·A + a ±0.1 pattern and +5 on run 6 — only row 6 is listed. Kills
/// `analysis/mod.rs:845:59: replace > with < in analyze` (found by the draw of seed 53), which lists
/// the fifteen others.
#[test]
fn only_the_run_with_a_large_studentised_residual_is_an_outlier() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let lv = |i: usize, b: usize| if i >> b & 1 == 1 { 1.0 } else { -1.0 };
    let col = |b: usize| Values::F64((0..16).map(|i| lv(i, b)).collect());
    let y: Vec<f64> = (0..16)
        .map(|i| {
            10.0 + 2.0 * lv(i, 0) + [0.1, -0.1, -0.1, 0.1][i % 4] + if i == 5 { 5.0 } else { 0.0 }
        })
        .collect();
    let input = AnalysisInput {
        factors: vec![
            ("A".into(), col(0)),
            ("B".into(), col(1)),
            ("C".into(), col(2)),
            ("D".into(), col(3)),
        ],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::Main,
    };
    let a = analyze(&input).unwrap();
    assert_eq!(a.diagnostics.outliers, [6]);
}

/// `ModelSpec::parse` reads the saturated model's keywords as the keyword, not as a formula naming
/// a factor `full`. Kills `model.rs:43:13: delete match arm "full" | "saturated" in ModelSpec::parse`
/// (found by the draw of seed 53), whose formula `full` expands to the same terms but is another spec.
#[test]
fn the_saturated_model_is_asked_by_its_keywords() {
    use millcomp_doe::ModelSpec;
    for k in ["full", "Saturated", " FULL "] {
        assert_eq!(ModelSpec::parse(k).unwrap(), ModelSpec::Full, "{k}");
    }
}

/// Lack of fit needs residual degrees of freedom beyond pure error: a 2² replicated twice with the
/// saturated model A*B has 4 residual df, all pure error, so there is no lack-of-fit test (its df
/// would be 0). Written for `analysis/mod.rs:889:18: replace > with >= in analyze` (found by the draw
/// of seed 53), which turned out to be the guard `df_pe > 0` — equivalent, since without replicates
/// the pure-error sum of squares is 0 and the next guard refuses; this test holds the `df_e > df_pe`
/// guard beside it.
#[test]
fn a_model_saturated_in_the_cell_means_has_no_lack_of_fit_test() {
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};
    let col = |v: [f64; 8]| Values::F64(v.to_vec());
    let input = AnalysisInput {
        factors: vec![
            (
                "A".into(),
                col([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0]),
            ),
            (
                "B".into(),
                col([-1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0]),
            ),
        ],
        response_name: "y".into(),
        response: col([10.0, 14.0, 12.0, 19.0, 10.4, 13.8, 12.2, 18.6]),
        model: ModelSpec::parse("A*B").unwrap(),
    };
    let a = analyze(&input).unwrap();
    assert_eq!(a.residual_df, 4);
    assert!(a.lack_of_fit.is_none(), "{:?}", a.lack_of_fit);
    // the same on 200 responses of three decimals (a fixed LCG): where rounding leaves SSE a few ulps
    // above the pure-error SS, a test with 0 lack-of-fit df would report F = ∞, p = 0. Kills
    // `mod.rs:889:30: replace > with >= in analyze` (found by the draw of seed 54), which runs it
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) % 20000) as f64 / 1000.0
    };
    for trial in 0..200 {
        let y: [f64; 8] = std::array::from_fn(|_| next());
        let input = AnalysisInput {
            response: col(y),
            ..input.clone()
        };
        let a = analyze(&input).unwrap();
        assert!(
            a.lack_of_fit.is_none(),
            "trial {trial} {y:?}: {:?}",
            a.lack_of_fit
        );
    }
}

/// A label factor's actual level for a coded value is the nearest of its evenly spaced levels, and a
/// coded value beyond ±1 is the end level: dry/mist/wet at −1, 0, +1 are dry, mist, wet; at +1.5 wet
/// and at −1.5 dry. Kills `factor.rs:297:36: replace - with / in FactorSpec::actual` (found by the draw
/// of seed 53), whose clamp to n instead of n − 1 indexes past the last label at +1.5 (a panic).
#[test]
fn a_label_factors_coded_value_past_its_range_is_its_end_level() {
    use millcomp_doe::Level;
    let f = FactorSpec::parse_list("coolant=dry:mist:wet").unwrap();
    let label = |x: f64| match f[0].actual(x) {
        Level::Label(s) => s,
        other => panic!("{other:?}"),
    };
    let got: Vec<String> = [-1.5, -1.0, 0.0, 1.0, 1.5].map(label).to_vec();
    assert_eq!(got, ["dry", "dry", "mist", "wet", "wet"]);
}

/// The response surface lists its monomials by degree, then by name: the intercept, the main effects,
/// then the two-factor products (Clayton's Table 3-3 X force, main effects and the three two-factor
/// interactions). Kills `surface.rs:101:73: replace + with * in response_surface` (found by the draw
/// of seed 54), whose degree is 0 for every monomial of numeric factors, so the products sort among
/// the main effects by name (`depth_um*speed_rpm` right after `depth_um`).
#[test]
fn a_response_surface_lists_its_terms_by_degree_then_name() {
    use millcomp_doe::{AnalysisInput, ModelSpec, analyze, response_surface};
    let table = crate::common::read_fixture("tests/fixtures/clayton_table_3_3.csv");
    let f: Vec<String> = ["depth_um", "speed_rpm", "upfeed_um"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let model = ModelSpec::parse(
        "depth_um + speed_rpm + upfeed_um + depth_um:speed_rpm + depth_um:upfeed_um + speed_rpm:upfeed_um",
    )
    .unwrap();
    let input = AnalysisInput::from_table(&table, "fx_n", Some(&f), model).unwrap();
    let m = response_surface(&analyze(&input).unwrap()).unwrap();
    let names: Vec<&str> = m.terms.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "intercept",
            "depth_um",
            "speed_rpm",
            "upfeed_um",
            "depth_um*speed_rpm",
            "depth_um*upfeed_um",
            "speed_rpm*upfeed_um"
        ]
    );
}

/// Of restarts that tie on φ_p the first is kept: a Latin hypercube of one factor in two runs has the
/// same two points (±½) from every restart, in the order its permutation drew, so its first run is the
/// first restart's, and no swap (each changes φ by exactly 0) is taken; recorded for seeds 0–9 (not
/// randomised). Kills `spacefilling.rs:111:51: replace < with <= in lhs` (found by the draw of seed
/// 54), which keeps the last of the tied restarts, and `spacefilling.rs:95:22: replace < with <= in
/// lhs` (seed 53's, argued equivalent then: a change of exactly 0 is the rule here), which takes the
/// swaps.
#[test]
fn of_latin_hypercube_restarts_that_tie_the_first_is_kept() {
    let first: Vec<f64> = (0..10u64)
        .map(|seed| {
            let mut req = DesignRequest::new(DesignKind::Lhs, coded(1));
            req.seed = Some(seed);
            req.runs = Some(2);
            req.randomize = false;
            let m = generate(&req).unwrap().coded_matrix();
            let mut xs = [m[0][0], m[1][0]];
            xs.sort_by(f64::total_cmp);
            assert_eq!(xs, [-0.5, 0.5], "seed {seed}");
            m[0][0]
        })
        .collect();
    assert_eq!(
        first,
        [0.5, 0.5, 0.5, -0.5, -0.5, -0.5, 0.5, -0.5, 0.5, -0.5]
    );
}

/// A 2⁴ in 8 blocks of 2 runs confounds the 7 block effects with the six two-factor interactions and
/// ABCD, and no main effect — the best possible (blocks of 2 runs cannot avoid the 2FIs; Montgomery,
/// 8th ed., §7.7): generators ABCD, AB, AC. Kills `fractional.rs:428:27: replace & with | in
/// choose_block_generators` (found by the draw of seed 54), whose score combines the wrong generators
/// (it never sees the first one alone) and picks ABCD, ABC, ABD, confounding the main effects C and D.
#[test]
fn a_two_to_the_four_in_eight_blocks_confounds_no_main_effect() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(4));
    req.blocks = 8;
    let d = generate(&req).unwrap();
    assert_eq!(d.block_generators, ["ABCD", "AB", "AC"]);
    assert_eq!(
        d.confounded_with_blocks,
        ["A:B", "A:C", "B:C", "A:D", "B:D", "C:D", "A:B:C:D"]
    );
}
