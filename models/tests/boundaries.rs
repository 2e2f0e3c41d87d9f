//! Boundary tests of the model files, bundles and atomic writes: each guard and branch exactly where it
//! switches, written in a pass over the mutants of `models/src` that no campaign had run
//! (docs/reliability-mutants.md, "A hardening pass before the seed-54 draw").

use std::path::Path;

use millcomp_models::file::{check_numbers, rfc3339_from_unix};
use millcomp_models::{
    FORMAT, Level, ModelError, ModelFile, Provenance, ResponseSurface, VERSION, read_header,
};

/// f = 1 + 0.01·d + 1e-4·d² + 2·[B = p] + 0.5·[B = q] (B sum coded over p, q, r; r is −1 in both
/// columns), fitted on d ∈ [100, 200], with a covariance holding off-diagonal terms.
fn surface() -> ResponseSurface {
    toml::from_str(
        r#"
response = "f"
model = "d + d^2 + B"
n_runs = 12
residual_df = 7
r_squared = 0.9
factors = [{ kind = "numeric", name = "d", low = 100.0, high = 200.0, levels = 3 },
           { kind = "label", name = "B", levels = ["p", "q", "r"] }]
terms = [{ name = "intercept", coef = 1.0 },
         { name = "d", coef = 0.01, powers = { d = 1 } },
         { name = "d^2", coef = 0.0001, powers = { d = 2 } },
         { name = "B[p]", coef = 2.0, labels = { B = "p" } },
         { name = "B[q]", coef = 0.5, labels = { B = "q" } }]
covariance = [[0.04, 0.001, 0.0, 0.002, 0.0],
              [0.001, 0.0001, 0.0, 0.0, 0.0],
              [0.0, 0.0, 1e-8, 0.0, 0.0],
              [0.002, 0.0, 0.0, 0.09, -0.01],
              [0.0, 0.0, 0.0, -0.01, 0.16]]
coded = { terms = ["intercept", "d", "d^2", "B[p]", "B[q]"], coef = [1.0, 1.0, 1.0, 1.0, 1.0] }
"#,
    )
    .unwrap()
}

fn lab(s: &str) -> Level {
    Level::Label(s.into())
}

/// Predictions of the surface at each level of the three-level label (sum coding: the last level r is
/// −1 in both columns) with a squared numeric term, and their standard errors xᵀCx. By hand:
/// d = 100, p: 1 + 1 + 1 + 2 = 5, xᵀCx = 0.04 + 2·0.1 + 1 + 1 + 2·0.002 + 0.09 = 2.334;
/// d = 200, r: 1 + 2 + 4 − 2 − 0.5 = 4.5, xᵀCx = 20.666; d = 150, q: 1 + 1.5 + 2.25 + 0.5 = 5.25,
/// xᵀCx = 7.8125. Targets surface.rs term_row (195, 197, 199, the `-> Ok(vec![..])`), predict_levels
/// (245, 250) and `predict -> Ok(0.0 | -1.0)`.
#[test]
fn a_surface_predicts_each_label_level_and_the_quadratic_form_of_its_row() {
    let m = surface();
    let cases = [
        (100.0, "p", 5.0, 2.334),
        (200.0, "r", 4.5, 20.666),
        (150.0, "q", 5.25, 7.8125),
    ];
    for (d, b, mean, var) in cases {
        let p = m
            .predict_levels(&[("B", lab(b)), ("d", Level::Num(d))])
            .unwrap();
        assert!((p.mean - mean).abs() < 1e-9, "{d} {b}: {}", p.mean);
        let se = p.std_err.unwrap();
        assert!((se * se - var).abs() < 1e-9, "{d} {b}: {se}");
    }
    // a model with only the numeric factor: predict in actual units (by hand: 1 + 1.5 + 2.25 = 4.75)
    let mut n = surface();
    n.terms.truncate(3);
    n.factors.truncate(1);
    n.covariance = None;
    assert!((n.predict(&[("d", 150.0)]).unwrap() - 4.75).abs() < 1e-12);
    assert!((n.predict(&[("d", 100.0)]).unwrap() - 3.0).abs() < 1e-12);
}

/// A prediction is refused naming the factor for: a factor the model does not have (the message lists
/// the model's factor names), a missing factor, a NaN or a label given for a numeric factor (quoting
/// it), and an unknown label level (listing the levels). Targets surface.rs:137 (`delete !`, `==`),
/// :154, :166 (guard `-> true`), :189 (`delete !`), Level's Display and FactorCoding::name.
#[test]
fn a_prediction_is_refused_for_each_bad_factor_naming_it() {
    let m = surface();
    let err = |pt: &[(&str, Level)]| match m.predict_levels(pt) {
        Err(ModelError::Prediction { factor, reason }) => (factor, reason),
        other => panic!("{other:?}"),
    };
    let (f, r) = err(&[
        ("d", Level::Num(150.0)),
        ("B", lab("p")),
        ("z", Level::Num(1.0)),
    ]);
    assert_eq!(f, "z");
    assert!(r.contains("(factors: d, B)"), "{r}");
    let (f, r) = err(&[("B", lab("p"))]);
    assert_eq!((f.as_str(), r.as_str()), ("d", "no value given"));
    let (f, r) = err(&[("d", Level::Num(f64::NAN)), ("B", lab("p"))]);
    assert_eq!(f, "d");
    assert_eq!(r, "`NaN` is not a finite number");
    let (_, r) = err(&[("d", lab("abc")), ("B", lab("p"))]);
    assert_eq!(r, "`abc` is not a finite number");
    let (f, r) = err(&[("d", Level::Num(150.0)), ("B", lab("s"))]);
    assert_eq!(f, "B");
    assert_eq!(r, "unknown level `s` (levels: p, q, r)");
    // the order of the given pairs does not matter (the lookup is by name)
    let a = m
        .predict_levels(&[("d", Level::Num(150.0)), ("B", lab("q"))])
        .unwrap();
    assert!((a.mean - 5.25).abs() < 1e-9);
}

/// The fitted range's ends and a margin of 1e-9 of its width (100 on [100, 200]: 1e-7) are inside;
/// 2e-7 beyond either end, and far outside, are extrapolations. Targets surface.rs:298 (each
/// comparison and the margin's arithmetic).
#[test]
fn the_fitted_range_ends_at_a_margin_of_a_billionth_of_its_width() {
    let m = surface();
    let out = |d: f64| !m.out_of_range(&[("d", d)]).is_empty();
    for d in [100.0, 200.0, 150.0, 100.0 - 5e-8, 200.0 + 5e-8] {
        assert!(!out(d), "{d} is inside");
    }
    for d in [50.0, 99.9, 100.0 - 2e-7, 200.0 + 2e-7, 200.1, 1e6] {
        assert!(out(d), "{d} is outside");
    }
    assert_eq!(m.out_of_range(&[("d", 99.0)]), vec!["d".to_string()]);
}

/// Unix seconds to RFC 3339 UTC across leap days, the century rule, the epoch, before it and far after
/// (references: GNU coreutils `date -u -d @SECONDS +%Y-%m-%dT%H:%M:%SZ`). Targets file.rs:546–557
/// (the civil-from-days arithmetic, `-> String::new()`).
#[test]
fn unix_seconds_are_dated_like_gnu_date_across_leap_days_and_centuries() {
    let cases = [
        (0, "1970-01-01T00:00:00Z"),
        (-1, "1969-12-31T23:59:59Z"),
        (68_169_600, "1972-02-29T00:00:00Z"),
        (946_684_799, "1999-12-31T23:59:59Z"),
        (951_868_799, "2000-02-29T23:59:59Z"),
        (1_000_000_000, "2001-09-09T01:46:40Z"),
        (1_700_000_000, "2023-11-14T22:13:20Z"),
        (1_709_208_000, "2024-02-29T12:00:00Z"),
        (4_102_444_800, "2100-01-01T00:00:00Z"),
        (253_402_300_799, "9999-12-31T23:59:59Z"),
    ];
    for (s, want) in cases {
        assert_eq!(rfc3339_from_unix(s), want, "{s}");
    }
    let p = Provenance::now("millcomp", "doe fit");
    assert_eq!(
        (p.program.as_str(), p.command.as_str()),
        ("millcomp", "doe fit")
    );
    assert_eq!(p.created_utc.len(), 20, "{}", p.created_utc);
    assert!(p.created_utc.ends_with('Z') && p.created_utc.as_bytes()[10] == b'T');
    assert!(p.created_utc.as_str() > "2024-01-01");
}

fn numbers(text: &str) -> Result<(), String> {
    let doc: toml::Table = toml::from_str(text).unwrap();
    check_numbers(&doc, Path::new("m.toml")).map_err(|e| match e {
        ModelError::InvalidValue { key, .. } => key,
        other => panic!("{other:?}"),
    })
}

/// Where a model file may hold a non-finite number: `std_err = inf` (not NaN, not −inf), and NaN in a
/// covariance cell whose row or column is an undetermined parameter (not inf there, not NaN in the
/// cell of two determined ones); nowhere else, nested or in arrays. Each refusal names its key.
/// Targets file.rs walk_table (318, the `covariance`/`values` arms, 338 `&&`/`||`), walk_value and
/// check_float (`-> Ok(())`, the guard, `&&`->`||`) and `undetermined`.
#[test]
fn non_finite_numbers_are_allowed_only_where_the_format_says_and_refused_by_key() {
    let fit = |se_m: &str, cells: &str| {
        format!(
            "[fit]\nvalue = {{ k = 1.0, m = 2.0 }}\nstd_err = {{ k = inf, m = {se_m} }}\n\
             [fit.covariance]\nnames = [\"k\", \"m\"]\nvalues = {cells}\n"
        )
    };
    assert_eq!(numbers(&fit("0.5", "[[nan, nan], [nan, 0.25]]")), Ok(()));
    assert_eq!(numbers(&fit("0.5", "[[1.0, 0.0], [0.0, 0.25]]")), Ok(()));
    assert_eq!(
        numbers(&fit("0.5", "[[1.0, 0.0], [0.0, nan]]")),
        Err("fit.covariance.values[1][1]".into())
    );
    assert_eq!(
        numbers(&fit("0.5", "[[inf, 0.0], [0.0, 0.25]]")),
        Err("fit.covariance.values[0][0]".into())
    );
    assert_eq!(
        numbers(&fit("nan", "[[1.0, 0.0], [0.0, 0.25]]")),
        Err("fit.std_err.m".into())
    );
    assert_eq!(
        numbers(&fit("-inf", "[[1.0, 0.0], [0.0, 0.25]]")),
        Err("fit.std_err.m".into())
    );
    // no undetermined parameter: no NaN anywhere in the covariance
    let text = "[fit]\nstd_err = { k = 0.1, m = 0.5 }\n[fit.covariance]\nnames = [\"k\", \"m\"]\n\
                values = [[1.0, nan], [nan, 0.25]]\n";
    assert_eq!(numbers(text), Err("fit.covariance.values[0][1]".into()));
    // elsewhere: nested tables and arrays
    assert_eq!(numbers("[a.b]\nc = [1.0, nan]\n"), Err("a.b.c[1]".into()));
    assert_eq!(numbers("x = inf\n"), Err("x".into()));
    assert_eq!(numbers("x = 1.0\ny = [1, 2]\nz = \"nan\"\n"), Ok(()));
}

/// A saved response surface loads back equal and its header reads back (format, version, kind);
/// the right kind is accepted, another refused, and a version other than VERSION is refused.
/// Targets file.rs to_toml/load/save (`-> Ok(..)`), check_header (the version guard, 462 `&&`->`||`,
/// `delete !`).
#[test]
fn a_saved_surface_loads_back_and_its_header_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    let f = ModelFile::new(
        "response_surface",
        surface(),
        Provenance::now("millcomp", "t"),
    );
    f.save(&path).unwrap();
    let g: ModelFile<ResponseSurface> = ModelFile::load(&path, &ResponseSurface::KINDS).unwrap();
    assert_eq!(g, f);
    let any: ModelFile<ResponseSurface> = ModelFile::load(&path, &[]).unwrap();
    assert_eq!(any.model, f.model);
    let h = read_header(&path).unwrap();
    assert_eq!(
        (h.format.as_str(), h.version, h.kind.as_str()),
        (FORMAT, VERSION, "response_surface")
    );
    match ModelFile::<ResponseSurface>::load(&path, &["force"]) {
        Err(ModelError::Kind { found, .. }) => assert_eq!(found, "response_surface"),
        other => panic!("{other:?}"),
    }
    let text = f.to_toml().unwrap();
    assert!(text.contains("kind = \"response_surface\""), "{text}");
    let bumped = text.replace("version = 1", "version = 2");
    assert_ne!(bumped, text);
    match ModelFile::<ResponseSurface>::from_toml(&bumped, &path, &[]) {
        Err(ModelError::Header { key, found, .. }) => {
            assert_eq!((key.as_str(), found.as_str()), ("header.version", "2"))
        }
        other => panic!("{other:?}"),
    }
}

use millcomp_models::{IdentifiedModel, NamedMatrix, SensorNoise, SpindleModel};

/// An identified model with residuals in `unit` and the given sections (no covariance).
fn fitted(unit: &str, rms: f64, sections: &str) -> IdentifiedModel {
    toml::from_str(&format!(
        "status = \"converged\"\nn_obs = 100\ndof = 98\nrms_residual = {rms}\n\
         residual_unit = \"{unit}\"\n{sections}\n[std_err]\n[covariance]\nnames = []\nvalues = []\n"
    ))
    .unwrap()
}

/// Each documented residual unit (`um`, `n`, `none`) is read and kept as spelled; another is refused.
/// A parameter is looked up in `params`, then `fixed`; a missing one is refused naming its key and
/// the available ones. Targets identified.rs:149 (`residual_unit -> Ok(..)`), get/require/require_valid
/// (`-> None`, `Ok(-1.0)`, `Ok(0.0)`).
#[test]
fn each_residual_unit_is_read_and_a_parameter_is_found_in_params_then_fixed() {
    for unit in IdentifiedModel::RESIDUAL_UNITS {
        assert_eq!(fitted(unit, 0.1, "[params]").residual_unit, unit);
    }
    let bad: Result<IdentifiedModel, _> = toml::from_str(
        "status = \"converged\"\nn_obs = 3\ndof = 1\nrms_residual = 0.1\nresidual_unit = \"mm\"\n\
         [params]\n[std_err]\n[covariance]\nnames = []\nvalues = []\n",
    );
    assert!(bad.is_err());
    let m = fitted("um", 0.1, "[params]\na = 0.25\n[fixed]\nb = 3.5");
    assert_eq!(
        (m.get("a"), m.get("b"), m.get("c")),
        (Some(0.25), Some(3.5), None)
    );
    let at = Path::new("m.toml");
    assert_eq!(m.require("b", at, "k").unwrap(), 3.5);
    assert_eq!(
        m.require_valid("a", at, "k", |v| v > 0.0, "> 0").unwrap(),
        0.25
    );
    match m.require("c", at, "k") {
        Err(ModelError::MissingKey { key, available, .. }) => {
            assert_eq!(
                (key.as_str(), available.as_str()),
                ("model.params.c", "a, b")
            )
        }
        other => panic!("{other:?}"),
    }
}

/// A spindle model needs residuals in µm: the same parameters with residuals in N are refused.
/// Targets identified.rs:251 (`==` -> `!=`) and SpindleModel::from_identified (`-> Ok(Default)`).
#[test]
fn a_spindle_model_needs_residuals_in_micrometres() {
    let p = "[params]\ngain_um_per_v = 0.05\nzeta = 0.46\nwn_rad_s = 1302.0";
    let at = Path::new("s.toml");
    let s = SpindleModel::from_identified(&fitted("um", 0.1, p), at).unwrap();
    assert_eq!((s.gain_um_per_v, s.zeta, s.wn_rad_s), (0.05, 0.46, 1302.0));
    assert!(matches!(
        SpindleModel::from_identified(&fitted("n", 0.1, p), at),
        Err(ModelError::InvalidValue { .. })
    ));
}

/// Sensor noise levels must be finite and ≥ 0: exactly 0 is taken, −0.1 and +∞ are refused naming the
/// key. Targets identified.rs:616 (`&&` -> `||`, `>=` -> `<`).
#[test]
fn a_sensor_noise_of_zero_is_taken_and_negative_or_infinite_is_refused() {
    let at = Path::new("n.toml");
    let n = |f: &str, g: &str| {
        SensorNoise::from_identified(
            &fitted(
                "none",
                0.0,
                &format!("[params]\nforce_noise_n = {f}\ngauge_noise_um = {g}"),
            ),
            at,
        )
    };
    let s = n("0.0", "0.02").unwrap();
    assert_eq!((s.force_noise_n, s.gauge_noise_um), (0.0, 0.02));
    for (f, g, key) in [
        ("-0.1", "0.02", "model.params.force_noise_n"),
        ("0.3", "inf", "model.params.gauge_noise_um"),
    ] {
        match n(f, g) {
            Err(ModelError::InvalidValue { key: k, .. }) => assert_eq!(k, key),
            other => panic!("{other:?}"),
        }
    }
}

/// Sensor noise from the residuals of a spindle fit (µm) and a force fit (N): each is taken when its
/// unit matches (case-insensitively) and its RMS is finite and ≥ 0 (0 included); a wrong unit alone,
/// or an infinite RMS alone, is refused naming the part. Targets identified.rs:638–641.
#[test]
fn sensor_noise_from_residuals_checks_each_condition_alone() {
    let at = Path::new("b.toml");
    let sp = |unit: &str, rms: f64| fitted(unit, rms, "[params]");
    let s = SensorNoise::from_residuals(&sp("um", 0.05), &sp("n", 0.0), at).unwrap();
    assert_eq!((s.force_noise_n, s.gauge_noise_um), (0.0, 0.05));
    let key = |r: millcomp_models::Result<SensorNoise>| match r {
        Err(ModelError::InvalidValue { key, .. }) => key,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        key(SensorNoise::from_residuals(
            &sp("n", 0.05),
            &sp("n", 0.3),
            at
        )),
        "model.spindle.rms_residual"
    );
    let mut inf = sp("n", 0.3);
    inf.rms_residual = f64::INFINITY;
    assert_eq!(
        key(SensorNoise::from_residuals(&sp("um", 0.05), &inf, at)),
        "model.force.rms_residual"
    );
    let mut neg = sp("um", 0.3);
    neg.rms_residual = -0.1;
    assert_eq!(
        key(SensorNoise::from_residuals(&neg, &sp("n", 0.3), at)),
        "model.spindle.rms_residual"
    );
}

/// A named matrix built from a matrix gives each cell back by name and as a matrix; a missing cell
/// reads as NaN and an unknown name as none. Targets identified.rs:58, :65, :77.
#[test]
fn a_named_matrix_gives_back_its_cells_by_name() {
    let names = vec!["a".to_string(), "b".to_string()];
    let m = nalgebra::DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.25, 4.0]);
    let nm = NamedMatrix::from_matrix(&names, &m);
    assert_eq!(nm.names, names);
    assert_eq!(
        (nm.get("a", "b"), nm.get("b", "a"), nm.get("b", "b")),
        (Some(0.5), Some(0.25), Some(4.0))
    );
    assert_eq!(nm.get("a", "z"), None);
    assert_eq!(nm.to_matrix(), m);
    let short = NamedMatrix {
        names: names.clone(),
        values: vec![vec![1.0, 2.0]],
    };
    let t = short.to_matrix();
    assert_eq!((t.nrows(), t.ncols(), t[(0, 1)]), (2, 2, 2.0));
    assert!(t[(1, 0)].is_nan());
}

use millcomp_models::ModelBundle;

fn spindle_fit() -> IdentifiedModel {
    fitted(
        "um",
        0.05,
        "[params]\ngain_um_per_v = 0.05\nzeta = 0.46\nwn_rad_s = 1302.0",
    )
}

/// A bundle from a spindle file alone is made (any one model is enough; none is refused), gives the
/// spindle back, takes its material whatever the case and spaces, and refuses another; sensor noise
/// without a record at rest needs both the spindle and the force fit, whose RMS residuals stand in.
/// Targets bundle.rs:176 (`-> Ok(Default)`, `&&` -> `||`), :72, :116 (the match arm), :241.
#[test]
fn a_bundle_of_one_spindle_file_is_made_and_checks_its_material_and_noise_sources() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("spindle.toml");
    ModelFile::new(
        "spindle",
        spindle_fit(),
        Provenance::now("millcomp", "fit spindle"),
    )
    .save(&path)
    .unwrap();
    let b = ModelBundle::from_files("Al6061", Some(&path), None, None).unwrap();
    assert_eq!(b.material, "Al6061");
    assert_eq!(b.spindle.as_ref(), Some(&spindle_fit()));
    assert_eq!(b.experiments.len(), 1);
    let at = Path::new("b.toml");
    let s = b.spindle(at, "t").unwrap();
    assert_eq!((s.gain_um_per_v, s.zeta, s.wn_rad_s), (0.05, 0.46, 1302.0));
    b.check_material(" al6061 ", at).unwrap();
    match b.check_material("S7", at) {
        Err(ModelError::InvalidValue { key, value, .. }) => {
            assert_eq!(
                (key.as_str(), value.as_str()),
                ("model.material", "`Al6061`")
            )
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        b.sensor_noise(at, "t"),
        Err(ModelError::MissingKey { .. })
    ));
    let mut both = b.clone();
    both.force = Some(fitted("n", 0.3, "[params]"));
    let (n, from) = both.sensor_noise(at, "t").unwrap();
    assert_eq!((n.force_noise_n, n.gauge_noise_um), (0.3, 0.05));
    assert!(from.starts_with("the spindle and force fits'"), "{from}");
    match ModelBundle::from_files("Al6061", None, None, None) {
        Err(ModelError::InvalidValue { key, .. }) => assert_eq!(key, "model"),
        other => panic!("{other:?}"),
    }
}
