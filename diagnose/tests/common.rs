//! Tolerances and helpers shared by the test modules, each argued.

use std::path::PathBuf;

use millcomp_datasets::contracts::{read_force_trace, read_measured_groove};
use millcomp_diagnose::{DiagnoseOptions, DiagnoseReport, Measured, SessionModel};
use millcomp_sim::session::Session;
use millcomp_synthetic::{Hidden, SyntheticCase, SyntheticData};

/// Significance level of the tests = the CLI default `--alpha 0.01` (issue 7).
pub const ALPHA: f64 = 0.01;
/// "The residual RMS shrinks by ≥ 50 %" (issue 7, Must show): final ≤ 0.5 · initial.
pub const RMS_SHRINK: f64 = 0.5;
/// With the candidate's functional form equal to the truth's, the final residual must be the
/// profilometer noise: RMS ≤ 1.3 σ (σ = 0.1 µm, `millcomp_synthetic::DEPTH_NOISE_UM`). The sample
/// RMS of 294 N(0, σ²) points has a relative sd of 1/√(2·294) = 4 %, so 1.3 σ is 7 sd above σ while
/// any leftover systematic error of 0.08 µm RMS or more would exceed it.
pub const NOISE_RMS_MAX_UM: f64 = 0.13;
/// `datasets/synthetic/` of the workspace.
pub fn synthetic_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../datasets/synthetic")
}

/// Reads a committed synthetic case (session, measured CSV and force trace if present) through
/// the measured-groove contract's adapters (`millcomp-datasets`), as the CLI does.
pub fn load_case(name: &str) -> (Session, Measured) {
    let dir = synthetic_dir();
    let session = Session::from_path(dir.join(format!("{name}.toml"))).unwrap();
    let csv = dir.join(format!("{name}.csv"));
    let mut measured = Measured::new(
        csv.display().to_string(),
        read_measured_groove(&csv).unwrap().points,
    );
    let f = dir.join(format!("{name}.forces.csv"));
    if f.exists() {
        measured = measured.with_forces(f.display().to_string(), read_force_trace(&f).unwrap());
    }
    (session, measured)
}

/// The synthetic case of that name (`millcomp_synthetic::cases()`).
pub fn case(name: &str) -> SyntheticCase {
    millcomp_synthetic::cases()
        .into_iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no synthetic case {name}"))
}

/// Generated data of a case as `diagnose` input (named as the committed files).
pub fn measured_of(d: &SyntheticData) -> Measured {
    let mut m = Measured::new(format!("{}.csv", d.name), d.points.clone());
    if let Some(rows) = &d.forces {
        m = m.with_forces(format!("{}.forces.csv", d.name), rows.clone());
    }
    m
}

/// Options at the tests' α.
pub fn opts() -> DiagnoseOptions {
    DiagnoseOptions {
        alpha: ALPHA,
        ..DiagnoseOptions::default()
    }
}

/// Noise-free nominal predictions of every planned point (the base `resample` adds to).
pub fn nominal_points(sm: &SessionModel) -> Vec<millcomp_sim::session::GroovePoint> {
    sm.points_with(&[])
}

/// Resampled measured data: nominal + `offsets_um` + seeded N(0, σ²) noise
/// (`millcomp_synthetic::resample`), labelled by its seed.
pub fn resampled(sm: &SessionModel, offsets_um: &[f64], seed: u64) -> Measured {
    Measured::new(
        format!("seed {seed}"),
        millcomp_synthetic::resample(
            &nominal_points(sm),
            offsets_um,
            millcomp_synthetic::DEPTH_NOISE_UM,
            seed,
        ),
    )
}

/// The report as JSON text, for assertion messages.
pub fn show(rep: &DiagnoseReport) -> String {
    serde_json::to_string_pretty(rep).unwrap_or_default()
}

/// A committed case's hidden effect in its family's reference parameters (`families`): the same
/// names as sim's for all but the probe tilt (the offset (D1 − D2)/2·tan α, 002 eq. 1) and the
/// machine compliance (1/k_M).
pub fn truth_in_family(h: &Hidden) -> Vec<(&'static str, f64)> {
    let p = h.params();
    let get = |k: &str| p.iter().find(|(n, _)| *n == k).map(|(_, v)| *v).unwrap();
    match h.expect {
        "coolant_thermal_drift" => vec![
            ("amplitude_um", get("amplitude_um")),
            ("time_constant_s", get("time_constant_s")),
        ],
        "spindle_thermal_growth" => vec![
            ("max_growth_um", get("max_growth_um")),
            ("rpm_onset", get("rpm_onset")),
            ("time_constant_s", get("time_constant_s")),
        ],
        "probe_tilt_offset" => vec![(
            "offset_um",
            (get("d1_mm") - get("d2_mm")) / 2.0 * get("alpha_deg").to_radians().tan() * 1e3,
        )],
        "tool_wear" => vec![
            ("max_wear_um", get("max_wear_um")),
            ("length_scale_mm", get("length_scale_mm")),
        ],
        "slideway_straightness" => vec![("amplitude_um", get("amplitude_um"))],
        "machine_compliance" => vec![("compliance_um_per_n", 1.0 / get("stiffness_n_per_um"))],
        _ => vec![("runout_um", get("runout_um"))],
    }
}
