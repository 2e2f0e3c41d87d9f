//! Bad input: too few points, constant (unidentifiable) input, NaN, non-monotone time — each a
//! clear error naming the column/row/parameter, or (when a fit is possible but not meaningful) a
//! warning naming the parameters; never a silent nonsense fit.

use millcomp_identify::targets::force::*;
use millcomp_identify::targets::spindle::*;
use millcomp_identify::targets::stiffness::*;
use millcomp_identify::targets::thermal::*;
use millcomp_identify::targets::wall::*;
use millcomp_identify::{FitStatus, IdentifyError};

fn thermal(t: &[f64], y: &[f64]) -> Result<millcomp_identify::Identified, IdentifyError> {
    identify_thermal(
        &ThermalData {
            t_s: t,
            drift_um: y,
            speed_rpm: None,
            temp_c: None,
        },
        ThermalModel::Exponential,
        &CommonOptions::default(),
    )
}

#[test]
fn thermal_errors() {
    let t: Vec<f64> = (0..10).map(|i| i as f64 * 60.0).collect();
    let mut y: Vec<f64> = t
        .iter()
        .map(|t| exponential_drift_um(*t, 8.5, 900.0, 0.0))
        .collect();
    y[5] = f64::NAN;
    let e = thermal(&t, &y).unwrap_err();
    assert!(
        matches!(e, IdentifyError::NonFinite { row: 6, ref column, .. } if column == "drift_um"),
        "{e}"
    );
    // rows counted from 1: index 5 is row 6
    assert_eq!(
        e.to_string(),
        "column `drift_um`, row 6: value NaN is not finite (NaN or infinite)"
    );
    let mut t2 = t.clone();
    t2[3] = t2[2];
    let y: Vec<f64> = t
        .iter()
        .map(|t| exponential_drift_um(*t, 8.5, 900.0, 0.0))
        .collect();
    let e = thermal(&t2, &y).unwrap_err();
    assert!(
        matches!(e, IdentifyError::NonMonotoneTime { row: 4, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("`t_s`, row 4"));
    let e = thermal(&t[..3], &y[..3]).unwrap_err();
    assert!(
        e.to_string()
            .contains("too few points: 3 usable rows for 3 free parameters"),
        "{e}"
    );
    let e = thermal(&t, &[1.5; 10]).unwrap_err();
    assert!(
        matches!(e, IdentifyError::ConstantInput { ref column, .. } if column == "drift_um"),
        "{e}"
    );
    let e = thermal(&t, &y[..9]).unwrap_err();
    assert!(matches!(e, IdentifyError::LengthMismatch { .. }), "{e}");
}

#[test]
fn thermal_short_record_warns_by_parameter() {
    // Record of 2 min against τ = 15 min: the curve is nearly a line, a and τ are not separable.
    let t: Vec<f64> = (0..25).map(|i| i as f64 * 5.0).collect();
    let y: Vec<f64> = t
        .iter()
        .enumerate()
        .map(|(i, t)| exponential_drift_um(*t, 8.5, 900.0, 0.0) + 0.01 * ((i * 7 % 5) as f64 - 2.0))
        .collect();
    let r = thermal(&t, &y).unwrap().report;
    let w = r.warnings.join("\n");
    eprintln!(
        "WARN short record: status {:?} cond {:.3e}\n{w}",
        r.status, r.condition_number
    );
    assert!(
        w.contains("amplitude_um") && w.contains("tau_s"),
        "warnings: {w}"
    );
    assert!(r.condition_number > 1e2, "cond {}", r.condition_number);
}

#[test]
fn spindle_errors() {
    let t: Vec<f64> = (0..100).map(|k| k as f64 * 2e-5).collect();
    let u = vec![10.0; 100];
    let y: Vec<f64> = (0..100).map(|k| 0.5 + 1e-3 * (k % 3) as f64).collect();
    let e = identify_spindle(
        &SpindleData {
            t_s: &t,
            u_v: &u,
            y_um: &y,
        },
        &SpindleOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, IdentifyError::ConstantInput { ref column, .. } if column == "u_v"),
        "{e}"
    );
    assert!(e.to_string().contains("no excitation"), "{e}");
    let u: Vec<f64> = (0..100).map(|k| if k >= 10 { 10.0 } else { 0.0 }).collect();
    let mut y2 = y.clone();
    y2[42] = f64::INFINITY;
    let e = identify_spindle(
        &SpindleData {
            t_s: &t,
            u_v: &u,
            y_um: &y2,
        },
        &SpindleOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, IdentifyError::NonFinite { row: 43, .. }), "{e}");
    let mut t2 = t.clone();
    t2[50] = t2[10];
    let e = identify_spindle(
        &SpindleData {
            t_s: &t2,
            u_v: &u,
            y_um: &y,
        },
        &SpindleOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, IdentifyError::NonMonotoneTime { row: 51, .. }),
        "{e}"
    );
    let e = identify_spindle(
        &SpindleData {
            t_s: &t[..4],
            u_v: &u[8..12],
            y_um: &y[..4],
        },
        &SpindleOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            IdentifyError::TooFewPoints {
                got: 4,
                needed: 5,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn stiffness_errors_name_the_direction() {
    let load = [1.0, 2.0, 3.0, 2.0, 2.0, 2.0];
    let defl = [1.0, 2.0, 3.0, 0.5, 0.6, 0.4];
    let dir: Vec<String> = ["radial", "radial", "radial", "axial", "axial", "axial"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let e = identify_stiffness(
        &StiffnessData {
            load_n: &load,
            deflection_um: &defl,
            direction: Some(&dir),
        },
        &StiffnessOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("direction `axial`"), "{e}");
    let dir2: Vec<String> = ["radial", "radial", "radial", "axial", "axial", "radial"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let load2 = [1.0, 2.0, 3.0, 2.0, 3.0, 4.0];
    let e = identify_stiffness(
        &StiffnessData {
            load_n: &load2,
            deflection_um: &defl,
            direction: Some(&dir2),
        },
        &StiffnessOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, IdentifyError::TooFewPoints { got: 2, ref what, .. } if what.contains("axial")),
        "{e}"
    );
    let e = identify_stiffness(
        &StiffnessData {
            load_n: &[1.0, 2.0, f64::NAN],
            deflection_um: &[1.0, 2.0, 3.0],
            direction: None,
        },
        &StiffnessOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, IdentifyError::NonFinite { row: 3, .. }), "{e}");
}

#[test]
fn force_errors() {
    let data = |d: &'static [f64], fx: &'static [f64]| {
        ForceData::Peaks(PeakForceData {
            conditions: ForceConditions {
                depth_um: d,
                upfeed_um: &[10.0, 10.0, 20.0],
                speed_rpm: None,
                tilt_deg: None,
            },
            max_fx_n: Some(fx),
            max_fy_n: None,
            max_fz_n: None,
        })
    };
    // 500 µm depth exceeds the 400 µm ball radius of the default tool.
    let e = identify_force(
        &data(&[100.0, 200.0, 500.0], &[1.0, 2.0, 3.0]),
        &ForceOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            IdentifyError::RejectedConditions {
                row: 3,
                source: millcomp_sim::SimError::InvalidParameter {
                    name: "depth_um",
                    ..
                },
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("row 3"), "{e}");
    let e = identify_force(
        &data(&[100.0, 200.0, 150.0], &[1.0, f64::NAN, 3.0]),
        &ForceOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, IdentifyError::NonFinite { row: 2, ref column, .. } if column == "max_fx_n"),
        "{e}"
    );
    // Three parameters from two distinct conditions: refused.
    let opts = ForceOptions {
        free: vec![ForceParam::W, ForceParam::MuRake, ForceParam::MuFlank],
        ..Default::default()
    };
    let e = identify_force(&data(&[100.0, 100.0, 200.0], &[1.0, 1.1, 2.0]), &opts).unwrap_err();
    assert!(matches!(e, IdentifyError::TooFewPoints { .. }), "{e}");
}

#[test]
fn wall_errors() {
    let e = identify_wall(
        &WallData {
            force_n: &[1.0; 5],
            deflection_um: &[1.0, 2.0, 3.0, 4.0, 5.0],
        },
        &WallOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, IdentifyError::ConstantInput { ref column, .. } if column == "force_n"),
        "{e}"
    );
}

#[test]
fn unidentifiable_nonlinear_fit_is_reported_not_hidden() {
    // Exponential drift with amplitude and offset perfectly confounded: all samples at the same
    // tiny time → 1 − e^{−t/τ} is constant, so amplitude·c + offset is all the data see.
    // (Time strictly increases by 1e-9 s, far below τ.)
    let t: Vec<f64> = (0..20).map(|i| 1000.0 + i as f64 * 1e-9).collect();
    let y: Vec<f64> = (0..20)
        .map(|i| 3.0 + 0.01 * ((i % 3) as f64 - 1.0))
        .collect();
    let r = thermal(&t, &y).unwrap().report;
    eprintln!(
        "WARN confounded: status {:?} cond {:.3e}\n{}",
        r.status,
        r.condition_number,
        r.warnings.join("\n")
    );
    assert!(
        r.status == FitStatus::RankDeficient || r.condition_number > 1e6,
        "{:?} cond {}",
        r.status,
        r.condition_number
    );
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("identifiable") && w.contains("amplitude_um")),
        "{:?}",
        r.warnings
    );
}
