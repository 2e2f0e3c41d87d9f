//! Identified models in the common model-file format (`models/MODEL.md`): round trip, required keys,
//! readers' checks.

use std::path::Path;

use millcomp_identify::targets::spindle::*;
use millcomp_identify::targets::stiffness::*;
use millcomp_models::{IdentifiedModel, ModelFile, Provenance, SpindleModel};

fn provenance() -> Provenance {
    Provenance::now(
        "millcomp 0.1.0",
        "millcomp identify spindle step.csv --save m.toml",
    )
}

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
    let opts = SpindleOptions::default();
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
    let fit = spindle_model();
    assert_eq!(fit.kind, "spindle");
    let file = ModelFile::new(&fit.kind, fit.model.clone(), provenance());
    let text = file.to_toml().unwrap();
    assert!(text.starts_with("[header]"), "{text}");
    for key in [
        "format = \"millcomp-model\"",
        "version = 1",
        "kind = \"spindle\"",
        "[model.params]",
        "[model.std_err]",
        "[model.covariance]",
        "gain_um_per_v",
    ] {
        assert!(text.contains(key), "missing {key} in\n{text}");
    }
    let back =
        ModelFile::<IdentifiedModel>::from_toml(&text, Path::new("m.toml"), &["spindle"]).unwrap();
    assert_eq!(back, file);
    let m = &back.model;
    assert!((m.get("wn_rad_s").unwrap() - 1302.0).abs() < 5.0);
    let e =
        ModelFile::<IdentifiedModel>::from_toml(&text, Path::new("m.toml"), &["wall"]).unwrap_err();
    assert!(e.to_string().contains("header.kind"), "{e}");
    let e = m
        .require("nonexistent", Path::new("m.toml"), "spindle")
        .unwrap_err()
        .to_string();
    assert!(e.contains("gain_um_per_v") && e.contains("m.toml"), "{e}");
    // Readers get the typed spindle view back.
    let s = SpindleModel::from_identified(m, Path::new("m.toml")).unwrap();
    assert_eq!(s.zeta, m.params["zeta"]);
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
    let text = ModelFile::new(&r.kind, r.model.clone(), provenance())
        .to_toml()
        .unwrap();
    let back = ModelFile::<IdentifiedModel>::from_toml(&text, Path::new("k.toml"), &["stiffness"])
        .unwrap();
    assert_eq!(back.model.derived, r.derived);
    assert_eq!(back.header.kind, "stiffness");
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
    let p = Path::new("bad.toml");
    let e = ModelFile::<IdentifiedModel>::from_toml("[model]\nkind = 3", p, &[]).unwrap_err();
    assert!(e.to_string().contains("bad.toml"), "{e}");
    let fit = spindle_model();
    let text = ModelFile::new(&fit.kind, fit.model, provenance())
        .to_toml()
        .unwrap()
        .replace("version = 1", "version = 99");
    let e = ModelFile::<IdentifiedModel>::from_toml(&text, p, &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("header.version") && e.contains("99"), "{e}");
}
