//! Bad input gives a clear `DoeError` naming the thing at fault (issue 4, "Bad input").

use crate::common::*;
use millcomp_doe::{
    AnalysisInput, CcdAlpha, CcdVariant, DesignKind, DesignRequest, DoeError, FactorSpec,
    ModelSpec, Values, analyze, generate,
};

fn frac(factors: &str, generators: &str) -> Result<millcomp_doe::Design, DoeError> {
    let mut r = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list(factors).unwrap(),
    );
    r.generators = Some(generators.into());
    r.seed = Some(1);
    generate(&r)
}

#[test]
fn duplicated_generators() {
    let e = frac("A,B,C,D,E", "D=AB,E=AB").unwrap_err();
    assert!(
        matches!(&e, DoeError::DuplicateGenerator { first_factor, second_factor, .. } if first_factor == "D" && second_factor == "E")
    );
    assert!(
        e.to_string().contains("D=AB") && e.to_string().contains("E=AB"),
        "{e}"
    );
    // Same column up to sign.
    assert!(matches!(
        frac("A,B,C,D,E", "D=ABC,E=-ABC"),
        Err(DoeError::DuplicateGenerator { .. })
    ));
    // The same factor generated twice.
    assert!(matches!(
        frac("A,B,C,D", "D=AB,D=AC"),
        Err(DoeError::InvalidGenerator { .. })
    ));
}

#[test]
fn aliased_generators() {
    let e = frac("A,B,C,D", "D=A").unwrap_err();
    assert!(
        matches!(&e, DoeError::AliasedGenerators { factor, aliased_with, .. } if factor == "D" && aliased_with == "A")
    );
    assert!(e.to_string().contains("I = AD"), "{e}");
    // Words over generated factors are refused with the factor named.
    let e = frac("A,B,C,D,E", "D=AB,E=AD").unwrap_err();
    assert!(
        matches!(&e, DoeError::InvalidGenerator { generator, .. } if generator == "E=AD"),
        "{e}"
    );
    // Unknown letter.
    let e = frac("A,B,C,D", "D=AZ").unwrap_err();
    assert!(e.to_string().contains("`Z`"), "{e}");
    // A requested resolution the generators do not reach.
    let mut r = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list("A,B,C,D,E").unwrap(),
    );
    r.generators = Some("D=AB,E=AC".into());
    r.resolution = Some(4);
    assert!(matches!(
        generate(&r),
        Err(DoeError::InvalidGenerator { .. })
    ));
}

fn col(v: &[f64]) -> Values {
    Values::F64(v.to_vec())
}

#[test]
fn more_model_terms_than_runs() {
    let input = AnalysisInput {
        factors: vec![
            ("a".into(), col(&[-1., 1., -1., 1.])),
            ("b".into(), col(&[-1., -1., 1., 1.])),
            ("c".into(), col(&[1., -1., -1., 1.])),
        ],
        response_name: "y".into(),
        response: col(&[1., 2., 3., 4.]),
        model: ModelSpec::TwoFi,
    };
    let e = analyze(&input).unwrap_err();
    assert!(
        matches!(
            &e,
            DoeError::TooManyTerms {
                coefficients: 7,
                runs: 4,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("a:b"), "{e}");
}

#[test]
fn aliased_model_terms_are_named() {
    // 2^(3-1) with C = AB, replicated: the interaction a:b is the column c.
    let input = AnalysisInput {
        factors: vec![
            ("a".into(), col(&[-1., 1., -1., 1., -1., 1., -1., 1.])),
            ("b".into(), col(&[-1., -1., 1., 1., -1., -1., 1., 1.])),
            ("c".into(), col(&[1., -1., -1., 1., 1., -1., -1., 1.])),
        ],
        response_name: "y".into(),
        response: col(&[1., 2., 3., 5., 1.1, 2.2, 2.9, 5.3]),
        model: ModelSpec::parse("a+b+c+a:b").unwrap(),
    };
    let e = analyze(&input).unwrap_err();
    assert!(
        matches!(&e, DoeError::AliasedTerms { term, aliased_with } if term == "a:b" && aliased_with == "`c`"),
        "{e}"
    );
}

#[test]
fn factor_with_one_level() {
    let input = AnalysisInput {
        factors: vec![
            ("a".into(), col(&[-1., 1., -1., 1.])),
            ("tilt_deg".into(), col(&[20., 20., 20., 20.])),
        ],
        response_name: "y".into(),
        response: col(&[1., 2., 3., 4.]),
        model: ModelSpec::Main,
    };
    let e = analyze(&input).unwrap_err();
    assert!(
        matches!(&e, DoeError::SingleLevelFactor { name, .. } if name == "tilt_deg"),
        "{e}"
    );
    assert!(matches!(
        FactorSpec::parse_list("a=1:1"),
        Err(DoeError::SingleLevelFactor { .. })
    ));
    let labels = AnalysisInput {
        factors: vec![
            ("m".into(), Values::Str(vec!["S7".into(); 4])),
            ("a".into(), col(&[-1., 1., -1., 1.])),
        ],
        response_name: "y".into(),
        response: col(&[1., 2., 3., 4.]),
        model: ModelSpec::Main,
    };
    assert!(
        matches!(analyze(&labels), Err(DoeError::SingleLevelFactor { name, level }) if name == "m" && level == "S7")
    );
}

#[test]
fn non_numeric_response() {
    let input = AnalysisInput {
        factors: vec![("a".into(), col(&[-1., 1., -1., 1.]))],
        response_name: "fx_n".into(),
        response: Values::Str(vec!["1.0".into(), "2.5".into(), "n/a".into(), "4".into()]),
        model: ModelSpec::Main,
    };
    let e = analyze(&input).unwrap_err();
    assert!(
        matches!(&e, DoeError::NonNumericResponse { column, row: 3, value } if column == "fx_n" && value == "n/a"),
        "{e}"
    );
    let nan = AnalysisInput {
        response: col(&[1., f64::NAN, 2., 3.]),
        ..input.clone()
    };
    assert!(matches!(
        analyze(&nan),
        Err(DoeError::NonFiniteValue { row: 2, .. })
    ));
    // A text column that holds numbers is accepted.
    let ok = AnalysisInput {
        response: Values::Str(vec!["1".into(), "2".into(), "3".into(), "5".into()]),
        ..input
    };
    assert!(analyze(&ok).is_ok());
}

#[test]
fn unknown_factor_names() {
    let table = read_fixture("tests/fixtures/clayton_table_3_3.csv");
    let f = vec!["depth_um".to_string(), "feed_mm_min".to_string()];
    let e = AnalysisInput::from_table(&table, "fx_n", Some(&f), ModelSpec::Main).unwrap_err();
    assert!(
        matches!(&e, DoeError::UnknownColumn { name, .. } if name == "feed_mm_min"),
        "{e}"
    );
    assert!(
        e.to_string().contains("upfeed_um"),
        "lists available columns: {e}"
    );
    let e = AnalysisInput::from_table(&table, "f_x", None, ModelSpec::Main).unwrap_err();
    assert!(matches!(&e, DoeError::UnknownColumn { name, .. } if name == "f_x"));
    let f = vec!["depth_um".to_string(), "upfeed_um".to_string()];
    let input = AnalysisInput::from_table(
        &table,
        "fx_n",
        Some(&f),
        ModelSpec::parse("depth_um + speed_rpm").unwrap(),
    )
    .unwrap();
    let e = analyze(&input).unwrap_err();
    assert!(
        matches!(&e, DoeError::UnknownFactor { name, context: "model", .. } if name == "speed_rpm"),
        "{e}"
    );
}

#[test]
fn design_input_errors() {
    let mut r = DesignRequest::new(
        DesignKind::Ccd {
            variant: CcdVariant::Circumscribed,
            alpha: CcdAlpha::Rotatable,
        },
        FactorSpec::parse_list("depth_um=100:200,material=S7:6061").unwrap(),
    );
    assert!(
        matches!(generate(&r), Err(DoeError::LevelsNotAllowed { name, .. }) if name == "material")
    );
    r.kind = DesignKind::Fractional;
    r.factors = FactorSpec::parse_list("a,b,m=S7:1018:6061").unwrap();
    r.resolution = Some(3);
    assert!(
        matches!(generate(&r), Err(DoeError::LevelsNotAllowed { name, levels: 3, .. }) if name == "m")
    );
    let mut full = DesignRequest::new(
        DesignKind::Full,
        FactorSpec::parse_list("a=1:2,m=S7:6061").unwrap(),
    );
    full.center_points = Some(2);
    assert!(matches!(generate(&full), Err(DoeError::Unsupported { what }) if what.contains("`m`")));
    let mut blocks = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list("a,b,c").unwrap());
    blocks.blocks = 3;
    assert!(matches!(
        generate(&blocks),
        Err(DoeError::InvalidParameter { name: "blocks", .. })
    ));
    let mut fr = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list("a,b,c,d,e").unwrap(),
    );
    fr.runs = Some(12);
    assert!(matches!(
        generate(&fr),
        Err(DoeError::InvalidParameter { name: "runs", .. })
    ));
    let mut pb = DesignRequest::new(
        DesignKind::PlackettBurman,
        FactorSpec::parse_list("a,b,c,d,e").unwrap(),
    );
    pb.runs = Some(28);
    assert!(matches!(
        generate(&pb),
        Err(DoeError::InvalidParameter { name: "runs", .. })
    ));
    assert!("ccx".parse::<DesignKind>().is_err());
    let e = FactorSpec::parse_list("depth_um=100:abc:100").unwrap_err();
    assert!(e.to_string().contains("depth_um"), "{e}");
}

#[test]
fn mismatched_lengths() {
    let input = AnalysisInput {
        factors: vec![("a".into(), col(&[-1., 1., -1.]))],
        response_name: "y".into(),
        response: col(&[1., 2., 3., 4.]),
        model: ModelSpec::Main,
    };
    assert!(
        matches!(analyze(&input), Err(DoeError::LengthMismatch { column, len: 3, expected: 4, .. }) if column == "a")
    );
}
