//! Property tests: a model file round-trips every field. Random identified models (every field,
//! including `inf` standard errors — the one infinity a file may hold —, subnormal and extreme numbers, keys and texts with quotes, dots,
//! backslashes, newlines and non-ASCII), response surfaces and bundles are written as a model file,
//! saved, loaded back and compared field by field — floats by their bits, so `-0.0` or a last-digit
//! change is caught — and the text written again is the same text.
//!
//! Rerun: `cargo test -p millcomp-models --test main round_trip` (a few seconds).

use std::collections::BTreeMap;
use std::path::Path;

use millcomp_models::{
    ActualTerm, CodedFit, Derived, FactorCoding, FitStatus, IdentifiedModel, InputFile, Level,
    ModelBundle, ModelFile, NamedMatrix, Provenance, ResponseSurface,
};
use proptest::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Any number a model file may hold (the file refuses NaN and infinity, but `std_err = inf`: see
/// [`std_err`]): normal, subnormal, zero of either sign, and the extremes.
fn float() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO,
        1 => prop::sample::select(vec![f64::MAX, f64::MIN, f64::MIN_POSITIVE, f64::EPSILON, -0.0, 0.1, 1e-300]),
    ]
}

/// A standard error: a number, or `inf` for a parameter the data do not determine (the one infinity a
/// model file holds, `models/MODEL.md`).
fn std_err() -> impl Strategy<Value = f64> {
    prop_oneof![4 => float(), 1 => Just(f64::INFINITY)]
}

/// A finite f64 (fields a consumer needs finite).
fn finite() -> impl Strategy<Value = f64> {
    prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO
}

/// Text with the characters a TOML writer must escape or quote.
fn text() -> impl Strategy<Value = String> {
    prop_oneof![
        "[a-z_]{1,12}",
        "\\PC{0,16}",
        prop::sample::select(vec![
            String::new(),
            "a.b".to_string(),
            "quote\"d".to_string(),
            "back\\slash".to_string(),
            "two\nlines".to_string(),
            "tab\there".to_string(),
            "µm °C".to_string(),
            "'single'".to_string(),
            "[header]".to_string(),
            "= 1".to_string(),
        ]),
    ]
}

fn count() -> impl Strategy<Value = usize> {
    prop_oneof![0usize..1000, Just(i64::MAX as usize)]
}

fn status() -> impl Strategy<Value = FitStatus> {
    prop::sample::select(vec![
        FitStatus::Converged,
        FitStatus::StalledAtRoundingLevel,
        FitStatus::NotConverged,
        FitStatus::RankDeficient,
    ])
}

fn map() -> impl Strategy<Value = BTreeMap<String, f64>> {
    prop::collection::btree_map(text(), float(), 0..5)
}

fn std_err_map() -> impl Strategy<Value = BTreeMap<String, f64>> {
    prop::collection::btree_map(text(), std_err(), 0..5)
}

fn derived() -> impl Strategy<Value = Derived> {
    (float(), float(), float(), float(), text()).prop_map(|(value, std_err, lo, hi, formula)| {
        Derived {
            value,
            std_err,
            ci95: [lo, hi],
            formula,
        }
    })
}

fn matrix() -> impl Strategy<Value = NamedMatrix> {
    (0usize..4).prop_flat_map(|n| {
        (
            prop::collection::vec(text(), n),
            prop::collection::vec(prop::collection::vec(float(), n), n),
        )
            .prop_map(|(names, values)| NamedMatrix { names, values })
    })
}

fn identified() -> impl Strategy<Value = IdentifiedModel> {
    (
        (
            status(),
            count(),
            count(),
            float(),
            // the units a model file knows (`um`, `n`, or `none` for no residuals)
            prop::sample::select(vec!["um".to_string(), "n".to_string(), "none".to_string()]),
        ),
        prop::collection::vec(text(), 0..3),
        (map(), std_err_map(), map()),
        prop::collection::btree_map(text(), derived(), 0..3),
        matrix(),
    )
        .prop_map(
            |(
                (status, n_obs, dof, rms_residual, residual_unit),
                warnings,
                (params, std_err, fixed),
                derived,
                covariance,
            )| IdentifiedModel {
                status,
                n_obs,
                dof,
                rms_residual,
                residual_unit,
                warnings,
                params,
                std_err,
                fixed,
                derived,
                covariance,
            },
        )
}

fn provenance() -> impl Strategy<Value = Provenance> {
    (
        text(),
        text(),
        text(),
        prop::collection::vec((text(), "[0-9a-f]{64}"), 0..3),
    )
        .prop_map(|(program, command, created_utc, inputs)| Provenance {
            program,
            command,
            created_utc,
            inputs: inputs
                .into_iter()
                .map(|(path, sha256)| InputFile { path, sha256 })
                .collect(),
        })
}

fn coding() -> impl Strategy<Value = FactorCoding> {
    prop_oneof![
        (text(), finite(), finite(), count()).prop_map(|(name, low, high, levels)| {
            FactorCoding::Numeric {
                name,
                low,
                high,
                levels,
            }
        }),
        (text(), prop::collection::vec(text(), 0..4))
            .prop_map(|(name, levels)| FactorCoding::Label { name, levels }),
    ]
}

fn term() -> impl Strategy<Value = ActualTerm> {
    (
        text(),
        float(),
        prop::collection::btree_map(text(), 0u32..4, 0..3),
        prop::collection::btree_map(text(), text(), 0..2),
    )
        .prop_map(|(name, coef, powers, labels)| ActualTerm {
            name,
            coef,
            powers,
            labels,
        })
}

fn square() -> impl Strategy<Value = Option<Vec<Vec<f64>>>> {
    prop::option::of(
        (0usize..4).prop_flat_map(|n| prop::collection::vec(prop::collection::vec(float(), n), n)),
    )
}

fn surface() -> impl Strategy<Value = ResponseSurface> {
    (
        (
            text(),
            text(),
            count(),
            count(),
            prop::option::of(float()),
            float(),
        ),
        prop::collection::vec(coding(), 0..4),
        prop::collection::vec(term(), 0..4),
        square(),
        (
            prop::collection::vec(text(), 0..4),
            prop::collection::vec(float(), 0..4),
            square(),
        ),
    )
        .prop_map(
            |(
                (response, model, n_runs, residual_df, sigma, r_squared),
                factors,
                terms,
                covariance,
                (cterms, coef, ccov),
            )| ResponseSurface {
                response,
                model,
                n_runs,
                residual_df,
                sigma,
                r_squared,
                factors,
                terms,
                covariance,
                coded: CodedFit {
                    terms: cterms,
                    coef,
                    covariance: ccov,
                },
            },
        )
}

fn bundle() -> impl Strategy<Value = ModelBundle> {
    (
        text(),
        prop::collection::vec(text(), 0..3),
        prop::collection::vec(text(), 0..3),
        prop::option::of(identified()),
        prop::option::of(identified()),
        prop::option::of(identified()),
        prop::option::of(identified()),
        prop::option::of(identified()),
    )
        .prop_map(
            |(
                material,
                experiments,
                warnings,
                spindle,
                force,
                stiffness,
                sensor_noise,
                hysteresis,
            )| {
                ModelBundle {
                    material,
                    experiments,
                    warnings,
                    spindle,
                    force,
                    stiffness,
                    sensor_noise,
                    hysteresis,
                }
            },
        )
}

/// Saves `model` of `kind`, loads it back, and checks equality of every field (by `PartialEq`, then
/// by the text written again, which shows every float's bits: `-0.0` is not `0.0`).
fn round_trip<B>(kind: &str, model: B, provenance: Provenance)
where
    B: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug + Clone,
{
    let file = ModelFile::new(kind, model, provenance);
    let text = file.to_toml().unwrap();
    let back = ModelFile::<B>::from_toml(&text, Path::new("m.toml"), &[kind]).unwrap();
    assert_eq!(back, file, "{text}");
    assert_eq!(back.to_toml().unwrap(), text);
    // and through a file on disk
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.toml");
    file.save(&path).unwrap();
    let loaded = ModelFile::<B>::load(&path, &[kind]).unwrap();
    assert_eq!(loaded, file);
    let header = millcomp_models::read_header(&path).unwrap();
    assert_eq!(header, file.header);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn identified_model_round_trips(m in identified(), p in provenance(),
                                    kind in prop::sample::select(vec!["spindle", "force", "stiffness", "thermal_speed", "wall"])) {
        round_trip(kind, m, p);
    }

    #[test]
    fn response_surface_round_trips(s in surface(), p in provenance()) {
        round_trip("response_surface", s, p);
    }

    #[test]
    fn bundle_round_trips(b in bundle(), p in provenance()) {
        round_trip("bundle", b, p);
    }

    /// A level read back is the level written: numbers stay numbers, text that looks like a number
    /// stays text.
    #[test]
    fn levels_round_trip(x in float(), s in text()) {
        #[derive(Serialize, serde::Deserialize, PartialEq, Debug, Clone)]
        struct Point { levels: Vec<Level> }
        let p = Point { levels: vec![Level::Num(x), Level::Label(s), Level::Label("1.5".into())] };
        round_trip("point", p, Provenance::default());
    }
}
