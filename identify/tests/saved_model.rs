//! The saved-model TOML (documented in `identify/MODEL.md`): round trip, required keys, readers'
//! checks.

use millcomp_identify::verbs::spindle::*;
use millcomp_identify::verbs::stiffness::*;
use millcomp_identify::{IdentifyError, SavedModel};

fn spindle_model() -> millcomp_identify::Identified {
    let s = millcomp_sim::spindle::PztSpindle::new(0.05, 0.46, 1302.0, None, None).unwrap();
    let t: Vec<f64> = (0..300).map(|k| k as f64 * 2e-5).collect();
    let u: Vec<f64> = (0..300).map(|k| if k >= 20 { 10.0 } else { 0.0 }).collect();
    let y0 = simulate_spindle_um(&s, &t, &u, 0.25).unwrap();
    let y: Vec<f64> = y0
        .iter()
        .enumerate()
        .map(|(i, y)| y + 0.002 * ((i * 7 % 5) as f64 - 2.0))
        .collect();
    let opts = SpindleOptions {
        common: millcomp_identify::verbs::thermal::VerbOptions {
            source_file: "step.csv".into(),
            ..Default::default()
        },
        ..Default::default()
    };
    identify_spindle(
        &SpindleData {
            t_s: &t,
            u_v: &u,
            y_um: &y,
        },
        &opts,
    )
    .unwrap()
}

#[test]
fn round_trip_preserves_everything() {
    let m = spindle_model().model;
    let text = m.to_toml().unwrap();
    assert!(text.starts_with("[model]"), "{text}");
    for key in [
        "kind = \"spindle\"",
        "format_version = 1",
        "source_file = \"step.csv\"",
        "[model.params]",
        "[model.std_err]",
        "[model.covariance]",
        "gain_um_per_v",
    ] {
        assert!(text.contains(key), "missing {key} in\n{text}");
    }
    let back = SavedModel::from_toml(&text).unwrap();
    assert_eq!(back, m);
    back.expect_kind("spindle").unwrap();
    assert!((back.param("wn_rad_s").unwrap() - 1302.0).abs() < 5.0);
    assert!(matches!(
        back.expect_kind("wall"),
        Err(IdentifyError::SavedModel(_))
    ));
    assert!(
        back.param("nonexistent")
            .unwrap_err()
            .to_string()
            .contains("gain_um_per_v")
    );
    // Readers get the physics crate's spindle back.
    let s = back.to_spindle().unwrap();
    assert_eq!(s.zeta, back.params["zeta"]);
    assert!(s.pole_rad_s.is_none() && s.dead_time_s.is_none());
}

#[test]
fn derived_quantities_are_saved() {
    let load: Vec<f64> = (1..=10)
        .map(|i| i as f64 * 0.981)
        .chain((1..=10).map(|i| i as f64 * 0.981))
        .collect();
    let dir: Vec<String> = (0..20)
        .map(|i| if i < 10 { "radial" } else { "axial" }.to_string())
        .collect();
    let defl: Vec<f64> = load
        .iter()
        .zip(&dir)
        .enumerate()
        .map(|(i, (f, d))| {
            f / if d == "radial" { 0.114 } else { 1.22 } + 0.05 * ((i % 3) as f64 - 1.0)
        })
        .collect();
    let opts = StiffnessOptions {
        tilt_deg: vec![20.0],
        ..Default::default()
    };
    let r = identify_stiffness(
        &StiffnessData {
            load_n: &load,
            deflection_um: &defl,
            direction: Some(&dir),
        },
        &opts,
    )
    .unwrap();
    let d = &r.derived["z_stiffness_tilt_20deg_n_per_um"];
    // 1/(cos²20°/1.22 + sin²20°/0.114) = 0.571 N/µm (000 §5.2.3 eq. 21 reconstruction, sim docs).
    assert!((d.value - 0.571).abs() < 0.01, "{d:?}");
    assert!(d.ci95[0] < d.value && d.value < d.ci95[1]);
    let back = SavedModel::from_toml(&r.model.to_toml().unwrap()).unwrap();
    assert_eq!(back.derived, r.derived);
    assert_eq!(back.kind, "stiffness");
    // JSON for the CLI: contract keys at top level.
    let json = serde_json::to_value(&r).unwrap();
    for k in [
        "params",
        "std_err",
        "ci95",
        "rms_residual_um",
        "status",
        "warnings",
        "derived",
        "groups",
    ] {
        assert!(json.get(k).is_some(), "missing {k}");
    }
    assert_eq!(json["status"], "converged");
}

#[test]
fn bad_files_are_errors() {
    assert!(matches!(
        SavedModel::from_toml("[model]\nkind = 3"),
        Err(IdentifyError::SavedModel(_))
    ));
    let m = spindle_model().model;
    let text = m
        .to_toml()
        .unwrap()
        .replace("format_version = 1", "format_version = 99");
    assert!(
        SavedModel::from_toml(&text)
            .unwrap_err()
            .to_string()
            .contains("format_version 99")
    );
}
