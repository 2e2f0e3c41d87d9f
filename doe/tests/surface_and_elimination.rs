//! The response surface in the common model-file format (models/MODEL.md) and backward elimination.
//! (The SVG plots of an analysis are the CLI's: `src/present/doe.rs`.)

use crate::common::*;
use millcomp_doe::{AnalysisInput, ModelSpec, analyze, backward_eliminate, response_surface};
use millcomp_models::{ModelError, ModelFile, Provenance, ResponseSurface};

fn clayton(response: &str, model: ModelSpec) -> AnalysisInput {
    let table = read_fixture("tests/fixtures/clayton_table_3_3.csv");
    let f: Vec<String> = ["depth_um", "speed_rpm", "upfeed_um"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    AnalysisInput::from_table(&table, response, Some(&f), model).unwrap()
}

#[test]
fn model_toml_round_trip_and_prediction() {
    let a = analyze(&clayton("fx_n", ModelSpec::Main)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fx_model.toml");
    let m = response_surface(&a).unwrap();
    ModelFile::new(
        "response_surface",
        m.clone(),
        Provenance::now("test", "test"),
    )
    .save(&path)
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("format = \"millcomp-model\""));
    assert!(text.contains("kind = \"response_surface\""));
    assert!(text.contains("[[model.terms]]") && text.contains("[[model.factors]]"));
    let back = ModelFile::<ResponseSurface>::load(&path, &ResponseSurface::KINDS)
        .unwrap()
        .model;
    assert_eq!(back, m);
    // Prediction at trial 1 (200 µm, 10 000 rpm, 20 µm/rev) equals the fitted value of row 1.
    let p = back
        .predict(&[
            ("depth_um", 200.0),
            ("speed_rpm", 10000.0),
            ("upfeed_um", 20.0),
        ])
        .unwrap();
    assert!((p - a.diagnostics.runs[0].fitted).abs() < 1e-12);
    // Actual-unit slope of depth: effect / range = 2·coef / 100 µm (N per µm of depth).
    let coef_depth = a.terms[0].coef.unwrap();
    let t = back.terms.iter().find(|t| t.name == "depth_um").unwrap();
    assert!((t.coef - 2.0 * coef_depth / 100.0).abs() < 1e-14);
    // Standard error of the mean prediction at the centre: σ/√n for an orthogonal design.
    let se = back
        .predict_levels(&[
            ("depth_um", millcomp_doe::Level::Num(150.0)),
            ("speed_rpm", millcomp_doe::Level::Num(15000.0)),
            ("upfeed_um", millcomp_doe::Level::Num(15.0)),
        ])
        .unwrap()
        .std_err
        .unwrap();
    assert!((se - a.sigma.unwrap() / 8f64.sqrt()).abs() < 1e-12);
    assert_eq!(
        back.out_of_range(&[("depth_um", 250.0), ("upfeed_um", 15.0)]),
        vec!["depth_um".to_string()]
    );
    assert!(matches!(
        back.predict(&[("depth_um", 150.0), ("speed_rpm", 1e4)]),
        Err(ModelError::Prediction { factor, .. }) if factor == "upfeed_um"
    ));
    assert!(matches!(
        back.predict(&[("depth_um", 150.0), ("speed_rpm", 1e4), ("upfeed_um", 10.0), ("tilt_deg", 3.0)]),
        Err(ModelError::Prediction { factor, .. }) if factor == "tilt_deg"
    ));
    assert!(
        ModelFile::<ResponseSurface>::from_toml(
            &text.replace("millcomp-model", "other"),
            &path,
            &ResponseSurface::KINDS
        )
        .is_err()
    );
}

#[test]
fn backward_elimination_on_table_3_3() {
    // Start from the 2FI model (1 residual df) of the X force; at α = 0.05 the interactions and speed go and
    // depth + upfeed remain (seed 000 §3.5 conclusion).
    let e = backward_eliminate(&clayton("fx_n", ModelSpec::TwoFi), 0.05).unwrap();
    assert_eq!(e.analysis.model, "depth_um + upfeed_um");
    assert!(e.steps.iter().any(|s| s.removed == "speed_rpm"));
    // Hierarchy: speed_rpm is removed only after every interaction containing it.
    let pos = |t: &str| e.steps.iter().position(|s| s.removed == t).unwrap();
    assert!(
        pos("speed_rpm") > pos("depth_um:speed_rpm")
            && pos("speed_rpm") > pos("speed_rpm:upfeed_um")
    );
    assert!(e.analysis.terms.iter().all(|t| t.p_value.unwrap() < 0.05));
    // From the saturated model the smallest effects are pooled first.
    let s = backward_eliminate(&clayton("fx_n", ModelSpec::Full), 0.05).unwrap();
    assert!(s.steps[0].p_value.is_none());
    assert_eq!(s.analysis.model, "depth_um + upfeed_um");
}
