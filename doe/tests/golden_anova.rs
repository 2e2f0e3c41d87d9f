//! Non-orthogonal models against statsmodels 0.15.0 (golden: tests/golden/anova_more.json, from
//! bench/peers/doe_goldens.py): a face-centred CCD with the quadratic model (type II SS differ from
//! sequential SS there), lack of fit from centre runs, the actual-unit coefficients and covariance of the
//! fitted model, and an unbalanced 3-level label × numeric data set with multi-df terms.

use crate::common::*;
use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze, response_surface};

fn ccd_input() -> (AnalysisInput, serde_json::Value) {
    let g = golden("anova_more.json")["ccd"].clone();
    let d = &g["data"];
    let input = AnalysisInput {
        factors: vec![
            ("depth_um".into(), Values::F64(f64s(&d["depth_um"]))),
            ("upfeed_um".into(), Values::F64(f64s(&d["upfeed_um"]))),
        ],
        response_name: "force_n".into(),
        response: Values::F64(f64s(&d["force_n"])),
        model: ModelSpec::Quadratic,
    };
    (input, g)
}

#[test]
fn ccd_quadratic_type2_anova_matches_statsmodels() {
    let (input, g) = ccd_input();
    let a = analyze(&input).unwrap();
    assert_eq!(
        a.model,
        "depth_um + upfeed_um + depth_um:upfeed_um + depth_um^2 + upfeed_um^2"
    );
    let (mut max_df, mut max_dp) = (0.0f64, 0.0f64);
    for gt in g["terms"].as_array().unwrap() {
        let name = gt["term"].as_str().unwrap();
        let t = a.terms.iter().find(|r| r.term == name).unwrap();
        assert!(
            close(t.sum_sq, gt["sum_sq"].as_f64().unwrap(), TOL_LINALG),
            "{name}"
        );
        let (f, gf) = (t.f.unwrap(), gt["f"].as_f64().unwrap());
        let (p, gp) = (t.p_value.unwrap(), gt["p_value"].as_f64().unwrap());
        max_df = max_df.max((f - gf).abs());
        max_dp = max_dp.max((p - gp).abs());
        assert!(close(f, gf, TOL_F), "{name}: F {f} vs {gf}");
        assert!((p - gp).abs() <= TOL_P, "{name}: p {p} vs {gp}");
    }
    eprintln!("CCD quadratic vs statsmodels: max |dF| = {max_df:.3e}, max |dp| = {max_dp:.3e}");
    assert!(close(
        a.r_squared,
        g["r_squared"].as_f64().unwrap(),
        TOL_LINALG
    ));
    assert!(close(
        a.adj_r_squared.unwrap(),
        g["adj_r_squared"].as_f64().unwrap(),
        TOL_LINALG
    ));
    assert!(close(
        a.pred_r_squared.unwrap(),
        g["pred_r_squared"].as_f64().unwrap(),
        TOL_LINALG
    ));
    for (d, h) in a.diagnostics.runs.iter().zip(f64s(&g["hat"])) {
        assert!(close(d.leverage, h, TOL_LINALG));
    }
    let lof = a
        .lack_of_fit
        .as_ref()
        .expect("3 centre runs give pure error");
    let gl = &g["lack_of_fit"];
    assert_eq!(lof.pure_error_df as f64, gl["df_pe"].as_f64().unwrap());
    assert_eq!(lof.lack_of_fit_df as f64, gl["df_lof"].as_f64().unwrap());
    assert!(close(
        lof.pure_error_ss,
        gl["ss_pe"].as_f64().unwrap(),
        TOL_LINALG
    ));
    assert!(close(lof.f, gl["f"].as_f64().unwrap(), TOL_F));
    assert!((lof.p_value - gl["p_value"].as_f64().unwrap()).abs() <= TOL_P);
}

#[test]
fn fitted_model_actual_units_match_statsmodels_on_raw_columns() {
    let (input, g) = ccd_input();
    let a = analyze(&input).unwrap();
    let m = response_surface(&a).unwrap();
    // statsmodels parameter name → our actual-unit term name.
    let map = [
        ("Intercept", "intercept"),
        ("depth_um", "depth_um"),
        ("upfeed_um", "upfeed_um"),
        ("depth_um:upfeed_um", "depth_um*upfeed_um"),
        ("I(depth_um ** 2)", "depth_um^2"),
        ("I(upfeed_um ** 2)", "upfeed_um^2"),
    ];
    let order: Vec<String> = g["actual_param_order"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    let cov = g["actual_cov"].as_array().unwrap();
    let cov_m = m.covariance.as_ref().unwrap();
    for (sm_i, (sm_name, ours)) in map.iter().enumerate() {
        assert_eq!(order[sm_i], *sm_name);
        let i = m
            .terms
            .iter()
            .position(|t| t.name == *ours)
            .unwrap_or_else(|| panic!("{ours}"));
        let gv = g["actual_params"][sm_name].as_f64().unwrap();
        // Relative tolerance: the actual-unit transform multiplies coded values by powers of 1/50 and 1/5.
        assert!(
            (m.terms[i].coef - gv).abs() <= 1e-9 * gv.abs().max(1e-6),
            "{ours}: {} vs {gv}",
            m.terms[i].coef
        );
        for (sm_j, (_, ours_j)) in map.iter().enumerate() {
            let j = m.terms.iter().position(|t| t.name == *ours_j).unwrap();
            let gc = cov[sm_i].as_array().unwrap()[sm_j].as_f64().unwrap();
            assert!(
                (cov_m[i][j] - gc).abs() <= 1e-8 * gc.abs().max(1e-12),
                "cov {ours},{ours_j}"
            );
        }
    }
    // Prediction at a design point equals the fitted value.
    let d = &a.diagnostics.runs[0];
    let dep = f64s(&g["data"]["depth_um"])[0];
    let up = f64s(&g["data"]["upfeed_um"])[0];
    let p = m.predict(&[("depth_um", dep), ("upfeed_um", up)]).unwrap();
    assert!((p - d.fitted).abs() < 1e-10);
}

#[test]
fn multi_df_label_terms_match_statsmodels() {
    let g = golden("anova_more.json")["mixed"].clone();
    let d = &g["data"];
    let mats: Vec<String> = d["material"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().into())
        .collect();
    let input = AnalysisInput {
        factors: vec![
            ("material".into(), Values::Str(mats)),
            ("depth_um".into(), Values::F64(f64s(&d["depth_um"]))),
        ],
        response_name: "fz_n".into(),
        response: Values::F64(f64s(&d["fz_n"])),
        model: ModelSpec::parse("material*depth_um").unwrap(),
    };
    let a = analyze(&input).unwrap();
    for gt in g["terms"].as_array().unwrap() {
        let name = gt["term"].as_str().unwrap();
        let t = a
            .terms
            .iter()
            .find(|r| r.term == name)
            .unwrap_or_else(|| panic!("{name}"));
        assert_eq!(t.df as f64, gt["df"].as_f64().unwrap(), "{name} df");
        assert!(
            close(t.sum_sq, gt["sum_sq"].as_f64().unwrap(), TOL_LINALG),
            "{name} SS"
        );
        assert!(
            close(t.f.unwrap(), gt["f"].as_f64().unwrap(), TOL_F),
            "{name} F"
        );
        assert!(
            (t.p_value.unwrap() - gt["p_value"].as_f64().unwrap()).abs() <= TOL_P,
            "{name} p"
        );
    }
    assert_eq!(a.terms[0].df, 2);
    assert!(a.terms[0].coef.is_none());
    // Sum-coded coefficients equal statsmodels' C(material, Sum)[S.1018] etc. (sorted levels: 1018, 6061, S7).
    let c = a
        .coefficients
        .iter()
        .find(|c| c.name == "material[1018]")
        .unwrap();
    assert!(close(
        c.coef,
        g["params"]["C(material, Sum)[S.1018]"].as_f64().unwrap(),
        TOL_LINALG
    ));
    // The fitted model predicts label levels.
    let m = response_surface(&a).unwrap();
    let p = m
        .predict_levels(&[
            ("material", millcomp_doe::Level::Label("S7".into())),
            ("depth_um", millcomp_doe::Level::Num(200.0)),
        ])
        .unwrap();
    let fitted_s7_200 = a.diagnostics.runs[3].fitted; // row 4: S7 at 200 µm
    assert!((p.mean - fitted_s7_200).abs() < 1e-10);
}
