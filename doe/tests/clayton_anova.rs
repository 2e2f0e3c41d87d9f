//! Seed 000 (Clayton thesis), §3.5, Table 3-3: the 2³ DOE in 6061 aluminium, analysed with the main-effects
//! (and 2FI) model and compared with statsmodels (golden: tests/golden/anova_clayton.json, made by
//! bench/peers/doe_goldens.py with statsmodels 0.15.0 `anova_lm(ols(...).fit(), typ=2)`).

use crate::common::*;
use millcomp_doe::{Analysis, AnalysisInput, ModelSpec, analyze};

const FIXTURE: &str = "tests/fixtures/clayton_table_3_3.csv";

fn run(response: &str, model: ModelSpec) -> Analysis {
    let table = read_fixture(FIXTURE);
    let factors: Vec<String> = ["depth_um", "speed_rpm", "upfeed_um"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let input = AnalysisInput::from_table(&table, response, Some(&factors), model).unwrap();
    analyze(&input).unwrap()
}

#[test]
fn thesis_conclusion_main_effects_model() {
    // Seed 000 §3.5: "the huge statistical significance of depth and upfeed on the x-force response and the
    // large effect of upfeed on the z-force response … surface speed alone does not affect the machining forces"
    // (5 % level, §3.5 text).
    let x = run("fx_n", ModelSpec::Main);
    let p = |a: &Analysis, t: &str| {
        a.terms
            .iter()
            .find(|r| r.term == t)
            .unwrap()
            .p_value
            .unwrap()
    };
    assert!(p(&x, "depth_um") < 0.05);
    assert!(p(&x, "upfeed_um") < 0.05);
    assert!(p(&x, "speed_rpm") > 0.05);
    let z = run("fz_n", ModelSpec::Main);
    assert!(p(&z, "upfeed_um") < 0.05);
    assert!(p(&z, "speed_rpm") > 0.05);
    // Upfeed is the strongest effect on Z (largest F), depth on X.
    let f = |a: &Analysis, t: &str| a.terms.iter().find(|r| r.term == t).unwrap().f.unwrap();
    assert!(f(&z, "upfeed_um") > f(&z, "depth_um"));
    assert!(f(&x, "depth_um") > f(&x, "upfeed_um"));
}

#[test]
fn default_factor_detection_picks_the_three_factors() {
    let table = read_fixture(FIXTURE);
    let input = AnalysisInput::from_table(&table, "fx_n", None, ModelSpec::Main).unwrap();
    let names: Vec<&str> = input.factors.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, vec!["depth_um", "speed_rpm", "upfeed_um"]);
}

fn compare(a: &Analysis, g: &serde_json::Value, max_df: &mut f64, max_dp: &mut f64) {
    for gt in g["terms"].as_array().unwrap() {
        let name = gt["term"].as_str().unwrap();
        let t = a
            .terms
            .iter()
            .find(|r| r.term == name)
            .unwrap_or_else(|| panic!("term {name}"));
        assert!(
            close(t.sum_sq, gt["sum_sq"].as_f64().unwrap(), TOL_LINALG),
            "{name} SS"
        );
        assert_eq!(t.df as f64, gt["df"].as_f64().unwrap());
        match (t.f, num(&gt["f"])) {
            (Some(f), Some(gf)) => {
                let d = (f - gf).abs();
                *max_df = max_df.max(d);
                assert!(
                    d <= TOL_F * gf.abs().max(1.0),
                    "{name}: F {f} vs statsmodels {gf}"
                );
            }
            (None, None) => {}
            other => panic!("{name}: F {other:?}"),
        }
        if let (Some(p), Some(gp)) = (t.p_value, num(&gt["p_value"])) {
            let d = (p - gp).abs();
            *max_dp = max_dp.max(d);
            assert!(d <= TOL_P, "{name}: p {p} vs statsmodels {gp}");
        }
        // statsmodels' parameter names are the coded columns, e.g. depth_um_c:upfeed_um_c.
        let pname = name
            .split(':')
            .map(|f| format!("{f}_c"))
            .collect::<Vec<_>>()
            .join(":");
        let gcoef = g["params"][&pname].as_f64().unwrap();
        assert!(close(t.coef.unwrap(), gcoef, TOL_LINALG), "{name} coef");
        assert!(
            close(t.effect.unwrap(), 2.0 * gcoef, TOL_LINALG),
            "{name} effect"
        );
        if let Some(bse) = g["bse"].as_object() {
            assert!(
                close(
                    t.std_err.unwrap(),
                    bse[&pname].as_f64().unwrap(),
                    TOL_LINALG
                ),
                "{name} se"
            );
        }
    }
    assert!(close(
        a.coefficients[0].coef,
        g["params"]["Intercept"].as_f64().unwrap(),
        TOL_LINALG
    ));
    assert_eq!(a.residual_df as f64, g["residual_df"].as_f64().unwrap());
    assert!(close(
        a.residual_sum_sq,
        g["ssr"].as_f64().unwrap(),
        TOL_LINALG
    ));
    assert!(close(
        a.r_squared,
        g["r_squared"].as_f64().unwrap(),
        TOL_LINALG
    ));
    if let Some(adj) = num(&g["adj_r_squared"]) {
        assert!(close(a.adj_r_squared.unwrap(), adj, TOL_LINALG));
    }
    if let Some(pr) = g.get("pred_r_squared").and_then(num) {
        assert!(close(a.pred_r_squared.unwrap(), pr, TOL_LINALG));
    }
    if let Some(h) = g.get("hat") {
        for ((d, h), (s, c)) in a
            .diagnostics
            .runs
            .iter()
            .zip(f64s(h))
            .zip(f64s(&g["studentized"]).into_iter().zip(f64s(&g["cooks_d"])))
        {
            assert!(close(d.leverage, h, TOL_LINALG));
            assert!(close(d.studentized.unwrap(), s, TOL_LINALG));
            assert!(close(d.cooks_d.unwrap(), c, TOL_LINALG));
        }
    }
}

#[test]
fn matches_statsmodels_anova_lm_typ2() {
    let gold = golden("anova_clayton.json");
    let (mut max_df, mut max_dp) = (0.0f64, 0.0f64);
    for resp in ["fx_n", "fy_n", "fz_n"] {
        for (key, model) in [("main", ModelSpec::Main), ("2fi", ModelSpec::TwoFi)] {
            let a = run(resp, model);
            compare(&a, &gold["responses"][resp][key], &mut max_df, &mut max_dp);
        }
        // Coding does not change F: statsmodels on actual units gives the same F.
        let a = run(resp, ModelSpec::Main);
        for (t, gf) in gold["responses"][resp]["main_actual_units_F"]
            .as_object()
            .unwrap()
        {
            let f = a.terms.iter().find(|r| &r.term == t).unwrap().f.unwrap();
            assert!(close(f, gf.as_f64().unwrap(), TOL_F));
        }
    }
    eprintln!("Table 3-3 vs statsmodels: max |dF| = {max_df:.3e}, max |dp| = {max_dp:.3e}");
}

#[test]
fn saturated_full_model_reports_lenth_not_f() {
    let a = run("fx_n", ModelSpec::Full);
    assert_eq!(a.residual_df, 0);
    assert!(a.terms.iter().all(|t| t.f.is_none() && t.p_value.is_none()));
    let l = a.lenth.as_ref().expect("lenth for a saturated model");
    assert_eq!(l.terms.len(), 7);
    // PSE from the 7 effects: 1.5·median of the |effects| below 2.5·s0 (computed independently here).
    let mut e: Vec<f64> = a.terms.iter().map(|t| t.effect.unwrap().abs()).collect();
    e.sort_by(f64::total_cmp);
    let s0 = 1.5 * e[3];
    let small: Vec<f64> = e.iter().copied().filter(|v| *v < 2.5 * s0).collect();
    let med = if small.len() % 2 == 1 {
        small[small.len() / 2]
    } else {
        0.5 * (small[small.len() / 2 - 1] + small[small.len() / 2])
    };
    assert!((l.pse - 1.5 * med).abs() < 1e-12);
}
