//! Tests written for the mutants of `millcomp-models` cargo-mutants found surviving
//! (docs/reliability-mutants.md): each asserts what the code must do where the mutated line decides.

use std::path::Path;

use millcomp_models::{HysteresisModel, IdentifiedModel, ModelError};

/// An identified model of `n_obs` points with the given `[params]` (and `[fixed]`) sections, residuals
/// in µm, no covariance.
fn identified(n_obs: usize, n_params: usize, sections: &str) -> IdentifiedModel {
    toml::from_str(&format!(
        r#"
status = "converged"
n_obs = {n_obs}
dof = {}
rms_residual = 0.05
residual_unit = "um"
{sections}
[std_err]
[covariance]
names = []
values = []
"#,
        n_obs - n_params
    ))
    .unwrap()
}

fn hysteresis(w03: &str) -> IdentifiedModel {
    identified(
        900,
        3,
        &format!(
            "[params]\nw00_um_per_v = 0.04\nw03_um_per_v = {w03}\noffset_um = 0.2\n\
             [fixed]\nr00_v = 0.0\nr03_v = 56.25"
        ),
    )
}

/// A play-operator weight below 0 is refused naming its key and value, 0 is accepted. Kills `identified.rs: replace && with || in HysteresisModel::from_identified`
/// (which lets any finite weight through).
#[test]
fn a_negative_hysteresis_weight_is_refused_naming_its_key() {
    let at = Path::new("hysteresis.toml");
    match HysteresisModel::from_identified(&hysteresis("-0.006"), at) {
        Err(ModelError::InvalidValue { key, value, .. }) => {
            assert_eq!(
                (key.as_str(), value.as_str()),
                ("model.params.w03_um_per_v", "-0.006")
            );
        }
        other => panic!("{other:?}"),
    }
    let h = HysteresisModel::from_identified(&hysteresis("0.0"), at).unwrap();
    assert_eq!(h.weights_um_per_v, vec![0.04, 0.0]);
}

/// A label factor of three levels is effect coded (sum to zero): each of its columns is +1 at its
/// level, −1 at the last level and 0 at the other. With f = 10 + 2·[material = 1018] −
/// 0.5·[material = 6061] over 1018, 6061, S7, the predictions are (by hand) 10 + 2 = 12 at 1018,
/// 10 − 0.5 = 9.5 at 6061 and 10 − 2 + 0.5 = 8.5 at S7; their mean is the intercept, 10. Kills
/// `surface.rs:201:34: replace == with != in ResponseSurface::term_row` (which codes a three-level
/// factor as two-level ones, ±1 only: 12.5 and 7.5 at 1018 and 6061).
#[test]
fn a_three_level_label_factor_is_effect_coded() {
    use millcomp_models::{Level, ResponseSurface};
    let m: ResponseSurface = toml::from_str(
        r#"
response = "force_n"
model = "material"
n_runs = 6
residual_df = 3
r_squared = 0.9
factors = [{ kind = "label", name = "material", levels = ["1018", "6061", "S7"] }]
terms = [{ name = "intercept", coef = 10.0 },
         { name = "material[1018]", coef = 2.0, labels = { material = "1018" } },
         { name = "material[6061]", coef = -0.5, labels = { material = "6061" } }]
coded = { terms = ["intercept", "material[1018]", "material[6061]"], coef = [10.0, 2.0, -0.5] }
"#,
    )
    .unwrap();
    let at = |l: &str| {
        m.predict_levels(&[("material", Level::Label(l.into()))])
            .unwrap()
            .mean
    };
    assert_eq!((at("1018"), at("6061"), at("S7")), (12.0, 9.5, 8.5));
}

/// A numeric value within 1e-9 of the fitted range (relative to its width) is inside it, not an
/// extrapolation: on d ∈ [100, 200], 100 − 5e-8 and 200 + 5e-8 are inside (the margin is 1e-9·100 =
/// 1e-7), 100 − 2e-7 and 200 + 2e-7 are not. Kills `surface.rs:298:57: replace - with / in
/// ResponseSurface::out_of_range` and `surface.rs:298:92: replace - with / in
/// ResponseSurface::out_of_range` (whose margins below and above the range are 1e-9·200/100 = 2e-9).
#[test]
fn a_value_within_rounding_of_the_range_is_not_an_extrapolation() {
    let m = line_over(100.0, 200.0);
    assert!(m.out_of_range(&[("d", 100.0 - 5e-8)]).is_empty());
    assert!(m.out_of_range(&[("d", 200.0 + 5e-8)]).is_empty());
    assert_eq!(m.out_of_range(&[("d", 100.0 - 2e-7)]), ["d"]);
    assert_eq!(m.out_of_range(&[("d", 200.0 + 2e-7)]), ["d"]);
    assert!((m.predict(&[("d", 150.0)]).unwrap() - 0.5).abs() < 1e-12);
}

/// The margin's edge itself is inside the range: on d ∈ [100, 200] the lower edge is computed as
/// 100 − 1e-9·(200 − 100), and that very value is no extrapolation (the comparisons are strict), nor
/// is the upper edge 200 + 1e-9·100. Kills `surface.rs:298:36: replace < with <= in
/// ResponseSurface::out_of_range` (found by the draw of seed 53), which calls the lower edge outside.
#[test]
fn the_edge_of_the_margin_is_inside_the_range() {
    let m = line_over(100.0, 200.0);
    let (low, high) = (100.0_f64, 200.0_f64);
    assert!(
        m.out_of_range(&[("d", low - 1e-9 * (high - low))])
            .is_empty()
    );
    assert!(
        m.out_of_range(&[("d", high + 1e-9 * (high - low))])
            .is_empty()
    );
}

fn spindle(zeta: &str, gain: &str) -> IdentifiedModel {
    identified(
        500,
        4,
        &format!("[params]\ngain_um_per_v = {gain}\nzeta = {zeta}\nwn_rad_s = 1302.0"),
    )
}

/// A spindle's gain, damping ratio and natural frequency must be finite and > 0: a damping ratio of
/// −0.46 or a gain of 0 is refused naming its key and value; 0.46 and 0.05 µm/V are taken. Kills
/// `identified.rs:245:19: replace && with || in finite_positive` (which takes any finite number).
#[test]
fn a_spindle_parameter_must_be_positive() {
    use millcomp_models::SpindleModel;
    let at = Path::new("spindle.toml");
    for (zeta, gain, key, value) in [
        ("-0.46", "0.05", "model.params.zeta", "-0.46"),
        ("0.46", "0.0", "model.params.gain_um_per_v", "0"),
    ] {
        match SpindleModel::from_identified(&spindle(zeta, gain), at) {
            Err(ModelError::InvalidValue {
                key: k, value: v, ..
            }) => {
                assert_eq!((k.as_str(), v.as_str()), (key, value))
            }
            other => panic!("{other:?}"),
        }
    }
    let s = SpindleModel::from_identified(&spindle("0.46", "0.05"), at).unwrap();
    assert_eq!((s.gain_um_per_v, s.zeta, s.wn_rad_s), (0.05, 0.46, 1302.0));
}

/// A fit is usable as a minimum when it converged or stalled at rounding level, not when it ran out
/// of iterations or the data do not determine its parameters. Kills `identified.rs:39:9: replace
/// FitStatus::is_success -> bool with true`.
#[test]
fn only_a_converged_or_stalled_fit_is_a_success() {
    use millcomp_models::FitStatus;
    assert!(FitStatus::Converged.is_success());
    assert!(FitStatus::StalledAtRoundingLevel.is_success());
    assert!(!FitStatus::NotConverged.is_success());
    assert!(!FitStatus::RankDeficient.is_success());
}

/// Timestamps as RFC 3339 in UTC, checked against GNU date (`date -u -d @1709164800 +%FT%TZ`): the
/// last day of February of a leap year, the last second of a year, and 1 March of 2100 (not a leap
/// year). Kills `file.rs:551:33: replace + with - in rfc3339_from_unix` (the `+` before `doe /
/// 36_524`: it dates 2100-03-01 "2100-02-29").
#[test]
fn timestamps_near_the_end_of_a_year_are_dated_right() {
    use millcomp_models::file::rfc3339_from_unix;
    assert_eq!(rfc3339_from_unix(1_709_164_800), "2024-02-29T00:00:00Z");
    assert_eq!(rfc3339_from_unix(1_704_067_199), "2023-12-31T23:59:59Z");
    // 2100 is not a leap year (divisible by 100, not by 400): the day after 2100-02-28 is 1 March
    assert_eq!(rfc3339_from_unix(4_107_542_400), "2100-03-01T00:00:00Z");
}

/// The upper edge of the tolerance band is still inside: on d ∈ [0, 1] the margin is 1e-9·(1 − 0),
/// and d = 1 + 1e-9·(1 − 0), computed as `out_of_range` computes its bound, is not an extrapolation;
/// the next double above it is. Kills `surface.rs:298:70: replace > with >= in
/// ResponseSurface::out_of_range` (found by the fresh draw of seed 52), which flags the edge itself.
#[test]
fn the_edge_of_the_margin_above_the_range_is_inside() {
    let m = line_over(0.0, 1.0);
    let (low, high) = (0.0f64, 1.0f64);
    let edge = high + 1e-9 * (high - low);
    assert!(m.out_of_range(&[("d", edge)]).is_empty());
    assert_eq!(
        m.out_of_range(&[("d", f64::from_bits(edge.to_bits() + 1))]),
        ["d"]
    );
}

/// A fitted line `f = −1 + 0.01·d` over d ∈ [low, high] (a 2-level numeric factor), as a model file holds it.
fn line_over(low: f64, high: f64) -> millcomp_models::ResponseSurface {
    toml::from_str(&format!(
        r#"
response = "f"
model = "d"
n_runs = 4
residual_df = 2
r_squared = 1.0
factors = [{{ kind = "numeric", name = "d", low = {low:?}, high = {high:?}, levels = 2 }}]
terms = [{{ name = "intercept", coef = -1.0 }}, {{ name = "d", coef = 0.01, powers = {{ d = 1 }} }}]
coded = {{ terms = ["intercept", "d"], coef = [0.5, 0.5] }}
"#
    ))
    .unwrap()
}

/// A stiffness scaled by 2 doubles both stiffnesses and quadruples their covariance (variance scales
/// with the square): 1.22 → 2.44 and 0.114 → 0.228 N/µm, 1e-4 → 4e-4 (every number a power-of-two
/// multiple, so exact). Kills `identified.rs:582:51: replace * with / in StiffnessModel::scaled`
/// (found by the fresh draw of seed 52), which makes the radial stiffness 0.057.
#[test]
fn a_scaled_stiffness_scales_both_and_the_covariance_by_the_square() {
    use millcomp_models::{NamedMatrix, StiffnessModel};
    let k = StiffnessModel {
        axial_n_per_um: 1.22,
        radial_n_per_um: 0.114,
        covariance: NamedMatrix {
            names: vec![
                "axial_stiffness_n_per_um".into(),
                "radial_stiffness_n_per_um".into(),
            ],
            values: vec![vec![1e-4, 0.0], vec![0.0, 1e-4]],
        },
    };
    let s = k.scaled(2.0);
    assert_eq!((s.axial_n_per_um, s.radial_n_per_um), (2.44, 0.228));
    assert_eq!(s.covariance.values, [[4e-4, 0.0], [0.0, 4e-4]]);
    // by 1.5, where the square (2.25) is not the double (3): variances 2 and 0.5 and covariance 0.25
    // become 4.5, 1.125 and 0.5625 (exact in binary). Kills `identified.rs:577:30: replace * with + in StiffnessModel::scaled` (found
    // by the draw of seed 54), which scales the covariance by 1.5 + 1.5 = 3 — at 2 the two agree.
    let k = StiffnessModel {
        covariance: NamedMatrix {
            names: k.covariance.names.clone(),
            values: vec![vec![2.0, 0.25], vec![0.25, 0.5]],
        },
        ..k
    };
    let s = k.scaled(1.5);
    assert_eq!(s.covariance.values, [[4.5, 0.5625], [0.5625, 1.125]]);
    assert_eq!(s.covariance.names, k.covariance.names);
}

/// A derived quantity may have a NaN uncertainty only in a fit that left a parameter undetermined
/// (`std_err = inf`): in a fit that determined every parameter, `derived.q.std_err = nan` is refused
/// naming its key; beside an undetermined parameter it is accepted. Kills `file.rs:348:51: replace
/// match guard !loose.is_empty() with true in walk_table` (which accepts the first) and `file.rs:348:51:
/// delete ! in walk_table` (which accepts the first and refuses the second).
#[test]
fn a_derived_quantity_is_undetermined_only_beside_an_undetermined_parameter() {
    use millcomp_models::file::check_numbers;
    let doc = |b_err: &str| -> toml::Table {
        toml::from_str(&format!(
            r#"
[model]
params = {{ a = 1.0, b = 2.0 }}
std_err = {{ a = 0.1, b = {b_err} }}
[model.derived.q]
value = 3.0
std_err = nan
"#
        ))
        .unwrap()
    };
    let at = Path::new("m.toml");
    match check_numbers(&doc("0.2"), at) {
        Err(ModelError::InvalidValue { key, .. }) => assert_eq!(key, "model.derived.q.std_err"),
        other => panic!("{other:?}"),
    }
    assert!(check_numbers(&doc("inf"), at).is_ok());
}

/// A prediction's standard error is √(xᵀ C x) over the model row x: the line f = −1 + 0.01·d with
/// covariance diag(0.01, 0.04) (intercept, d) at d = 0.5 has x = (1, 0.5) and variance 0.01 + 0.25·0.04
/// = 0.02 (by hand), so 0.1414…; the mean is −1 + 0.005 = −0.995. Kills `surface.rs:250:43: replace *
/// with / in ResponseSurface::predict_levels` (found by the draw of seed 52 beyond its first 130),
/// whose x_i·C_ij / x_j gives 0.05.
#[test]
fn a_predictions_standard_error_is_the_rows_quadratic_form() {
    use millcomp_models::Level;
    let mut s = line_over(0.0, 1.0);
    s.covariance = Some(vec![vec![0.01, 0.0], vec![0.0, 0.04]]);
    let p = s.predict_levels(&[("d", Level::Num(0.5))]).unwrap();
    assert!((p.mean - -0.995).abs() < 1e-12, "{}", p.mean);
    assert!(
        (p.std_err.unwrap() - 0.02f64.sqrt()).abs() < 1e-12,
        "{:?}",
        p.std_err
    );
}

/// A bundle's hysteresis is its stack's play-operator model when it has one: weights 0.04 and 0.006
/// µm/V back from `ModelBundle::hysteresis`, none without. Kills `bundle.rs:230:9: replace
/// ModelBundle::hysteresis -> Result<Option<HysteresisModel>> with Ok(None)` (found by the draw of
/// seed 53), which loses a commissioned stack's hysteresis.
#[test]
fn a_bundle_gives_back_its_hysteresis() {
    use millcomp_models::ModelBundle;
    let at = Path::new("bundle.toml");
    let mut b = ModelBundle {
        material: "S7".into(),
        experiments: Vec::new(),
        warnings: Vec::new(),
        spindle: None,
        force: None,
        stiffness: None,
        sensor_noise: None,
        hysteresis: Some(hysteresis("0.006")),
    };
    let h = b.hysteresis(at).unwrap().expect("the bundle's hysteresis");
    assert_eq!(h.weights_um_per_v, vec![0.04, 0.006]);
    b.hysteresis = None;
    assert!(b.hysteresis(at).unwrap().is_none());
}

/// Beside an undetermined parameter a derived quantity may have a NaN `std_err` or `ci95`, but its
/// `value` must still be a number: `value = nan` is refused naming its key, `ci95 = [nan, nan]` is
/// accepted. Kills `file.rs:382:5: replace walk_value_allowing -> Result<()> with Ok(())` (found by the
/// draw of seed 53), which checks none of a derived quantity's numbers there.
#[test]
fn a_derived_quantitys_value_must_be_a_number_even_beside_an_undetermined_parameter() {
    use millcomp_models::file::check_numbers;
    let doc = |value: &str| -> toml::Table {
        toml::from_str(&format!(
            r#"
[model]
params = {{ a = 1.0, b = 2.0 }}
std_err = {{ a = 0.1, b = inf }}
[model.derived.q]
value = {value}
std_err = nan
ci95 = [nan, nan]
"#
        ))
        .unwrap()
    };
    let at = Path::new("m.toml");
    match check_numbers(&doc("nan"), at) {
        Err(ModelError::InvalidValue { key, .. }) => assert_eq!(key, "model.derived.q.value"),
        other => panic!("{other:?}"),
    }
    assert!(check_numbers(&doc("3.0"), at).is_ok());
}

/// A model file's creation time is UTC in RFC 3339 to the second (`YYYY-MM-DDThh:mm:ssZ`), in this
/// century. Kills `file.rs:531:5: replace utc_now_rfc3339 -> String with "xyzzy".into()` (found by the
/// draw of seed 53).
#[test]
fn the_creation_time_is_rfc3339_utc() {
    let t = millcomp_models::utc_now_rfc3339();
    let b = t.as_bytes();
    assert_eq!(t.len(), 20, "{t}");
    assert!(t.starts_with("20") && t.ends_with('Z'), "{t}");
    for (i, c) in b.iter().enumerate() {
        match i {
            4 | 7 => assert_eq!(*c, b'-', "{t}"),
            10 => assert_eq!(*c, b'T', "{t}"),
            13 | 16 => assert_eq!(*c, b':', "{t}"),
            19 => assert_eq!(*c, b'Z', "{t}"),
            _ => assert!(c.is_ascii_digit(), "{t}"),
        }
    }
}
