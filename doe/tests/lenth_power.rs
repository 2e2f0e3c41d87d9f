//! Lenth's method on Montgomery's Example 6.2 and the noncentral F against scipy.

use crate::common::*;
use millcomp_doe::{
    AnalysisInput, ModelSpec, Values, analyze, f_test_power, lenth, noncentral_f_cdf,
    noncentral_f_sf, power,
};

#[test]
fn montgomery_example_6_2_effects_and_lenth() {
    // Montgomery, Design and Analysis of Experiments, 8th ed. (2013), Example 6.2 (pilot-plant filtration
    // rate, unreplicated 2^4): data Table 6.10 (fixture), effect estimates Table 6.11 (golden "published").
    let table = read_fixture("tests/fixtures/montgomery_example_6_2.csv");
    let input =
        AnalysisInput::from_table(&table, "filtration_rate", None, ModelSpec::Full).unwrap();
    let a = analyze(&input).unwrap();
    assert_eq!(a.residual_df, 0);
    let g = golden("lenth.json");
    for (term, e) in g["published"]["effects"].as_object().unwrap() {
        let t = a
            .terms
            .iter()
            .find(|t| &t.term == term)
            .unwrap_or_else(|| panic!("{term}"));
        assert!(
            (t.effect.unwrap() - e.as_f64().unwrap()).abs() < TOL_PUBLISHED_EXACT,
            "{term}"
        );
    }
    let l = a.lenth.as_ref().unwrap();
    // Published PSE 2.625 (Montgomery, §6.5 discussion of Example 6.2 / Lenth's method).
    assert!((l.pse - g["published"]["pse"].as_f64().unwrap()).abs() < TOL_PUBLISHED_EXACT);
    // ME = t_{0.975, 5}·PSE and SME = t_{γ, 5}·PSE (scipy 1.17.1 quantiles, golden "computed").
    let c = &g["computed"];
    assert!(
        close(l.me, c["me"].as_f64().unwrap(), TOL_QUANTILE),
        "ME {} vs {}",
        l.me,
        c["me"]
    );
    assert!(
        close(l.sme, c["sme"].as_f64().unwrap(), TOL_QUANTILE),
        "SME {} vs {}",
        l.sme,
        c["sme"]
    );
    assert!((l.df - 5.0).abs() < 1e-15);
    // Active at ME: A, C, D, AC, AD (Montgomery's conclusion for this example); at SME: A, D, AC, AD.
    let mut active: Vec<&str> = l
        .terms
        .iter()
        .filter(|t| t.exceeds_me)
        .map(|t| t.term.as_str())
        .collect();
    active.sort();
    assert_eq!(active, vec!["A", "A:C", "A:D", "C", "D"]);
    let mut strong: Vec<&str> = l
        .terms
        .iter()
        .filter(|t| t.exceeds_sme)
        .map(|t| t.term.as_str())
        .collect();
    strong.sort();
    assert_eq!(strong, vec!["A", "A:C", "A:D", "D"]);
}

#[test]
fn lenth_needs_two_nonzero_effects() {
    let n = vec!["a".to_string()];
    assert!(lenth(&n, &[1.0]).is_none());
    let n2 = vec!["a".to_string(), "b".to_string()];
    assert!(lenth(&n2, &[0.0, 0.0]).is_none());
}

#[test]
fn noncentral_f_matches_scipy() {
    let g = golden("noncentral_f.json");
    let mut max = 0.0f64;
    for p in g["points"].as_array().unwrap() {
        let (x, d1, d2, lam) = (
            p["x"].as_f64().unwrap(),
            p["d1"].as_f64().unwrap(),
            p["d2"].as_f64().unwrap(),
            p["lambda"].as_f64().unwrap(),
        );
        let c = noncentral_f_cdf(x, d1, d2, lam);
        let s = noncentral_f_sf(x, d1, d2, lam);
        let (gc, gs) = (p["cdf"].as_f64().unwrap(), p["sf"].as_f64().unwrap());
        max = max.max((c - gc).abs()).max((s - gs).abs());
        assert!(
            (c - gc).abs() < TOL_NCF,
            "cdf({x},{d1},{d2},{lam}) = {c} vs scipy {gc}"
        );
        assert!(
            (s - gs).abs() < TOL_NCF,
            "sf({x},{d1},{d2},{lam}) = {s} vs scipy {gs}"
        );
    }
    for p in g["power"].as_array().unwrap() {
        let (crit, pw) = f_test_power(
            p["d1"].as_f64().unwrap(),
            p["d2"].as_f64().unwrap(),
            p["lambda"].as_f64().unwrap(),
            p["alpha"].as_f64().unwrap(),
        )
        .unwrap();
        assert!(close(crit, p["f_crit"].as_f64().unwrap(), TOL_QUANTILE));
        assert!((pw - p["power"].as_f64().unwrap()).abs() < 1e-8);
    }
    eprintln!("noncentral F vs scipy.stats.ncf: max |d| = {max:.3e}");
}

#[test]
fn power_of_the_thesis_design() {
    // The 2^3 of Table 3-3 with the main-effects model (4 residual df): λ = n·(Δ/2σ)² = 8·(Δ/2σ)².
    let col = |v: &[f64]| Values::F64(v.to_vec());
    let f = vec![
        (
            "depth_um".to_string(),
            col(&[200., 100., 100., 200., 200., 100., 200., 100.]),
        ),
        (
            "speed_rpm".to_string(),
            col(&[1e4, 1e4, 2e4, 2e4, 2e4, 2e4, 1e4, 1e4]),
        ),
        (
            "upfeed_um".to_string(),
            col(&[20., 20., 10., 10., 20., 20., 10., 10.]),
        ),
    ];
    let r = power(&f, &ModelSpec::Main, 4.0, 1.0, 0.05).unwrap();
    assert_eq!(r.residual_df, 4);
    assert_eq!(r.terms.len(), 3);
    let g = golden("noncentral_f.json");
    // golden power entry d1 = 1, d2 = 4, λ = 32, α = 0.05 (scipy)
    let gp = g["power"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["lambda"].as_f64() == Some(32.0))
        .unwrap();
    for t in &r.terms {
        assert!((t.noncentrality - 32.0).abs() < 1e-10);
        assert!((t.power - gp["power"].as_f64().unwrap()).abs() < 1e-8);
    }
}
