//! Boundary tests of the design generators: each limit, guard and keyword exactly where it switches
//! (the largest accepted and the smallest refused value), written in a pass over the mutants of
//! `doe/src/design`, `factor.rs`, `model.rs` and `surface.rs` that no campaign had run
//! (docs/reliability-mutants.md, "A hardening pass before the seed-54 draw").

#[allow(unused_imports)]
use crate::common::*;
use millcomp_doe::{
    CcdAlpha, CcdVariant, DesignKind, DesignOptions, DesignRequest, DoeError, FactorSpec, Level,
    generate,
};

fn coded(k: usize) -> Vec<FactorSpec> {
    (0..k)
        .map(|i| FactorSpec::coded(&millcomp_doe::factor_letter(i)))
        .collect()
}

fn unsupported(r: millcomp_doe::Result<millcomp_doe::Design>) -> String {
    match r {
        Err(DoeError::Unsupported { what }) => what,
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

fn invalid(r: millcomp_doe::Result<millcomp_doe::Design>) -> (&'static str, String, String) {
    match r {
        Err(DoeError::InvalidParameter {
            name,
            value,
            allowed,
        }) => (name, value, allowed),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// MAX_FACTORS = 4095 is itself accepted: a 2-run Latin hypercube of 4095 coded factors is built
/// (4096 is refused by `a_design_takes_at_most_4095_factors`). Targets `mod.rs:650 > with >=`.
#[test]
fn a_latin_hypercube_of_exactly_4095_factors_is_built() {
    let mut req = DesignRequest::new(DesignKind::Lhs, coded(4095));
    req.runs = Some(2);
    req.seed = Some(1);
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 2);
    assert_eq!(d.factors.len(), 4095);
    assert_eq!(d.runs[0].coded.len(), 4095);
}

/// Every documented spelling of a design family names that family, and `name` gives the CLI name.
/// Targets the deleted match arms of `DesignKind::from_str` (mod.rs:171–180), its `Ok(Default)`
/// body, and `DesignKind::name -> "xyzzy"`.
#[test]
fn every_spelling_of_a_design_family_parses_to_that_family() {
    let ccd = |variant| DesignKind::Ccd {
        variant,
        alpha: CcdAlpha::Rotatable,
    };
    let cases: Vec<(&str, DesignKind, &str)> = vec![
        ("full", DesignKind::Full, "full"),
        ("full-factorial", DesignKind::Full, "full"),
        ("Factorial", DesignKind::Full, "full"),
        ("fractional", DesignKind::Fractional, "fractional"),
        ("frac", DesignKind::Fractional, "fractional"),
        ("fractional-factorial", DesignKind::Fractional, "fractional"),
        (
            "plackett-burman",
            DesignKind::PlackettBurman,
            "plackett-burman",
        ),
        ("pb", DesignKind::PlackettBurman, "plackett-burman"),
        (
            "plackett_burman",
            DesignKind::PlackettBurman,
            "plackett-burman",
        ),
        ("ccd", ccd(CcdVariant::Circumscribed), "ccd"),
        ("ccc", ccd(CcdVariant::Circumscribed), "ccd"),
        ("central-composite", ccd(CcdVariant::Circumscribed), "ccd"),
        ("ccf", ccd(CcdVariant::FaceCentred), "ccd"),
        ("ccd-face", ccd(CcdVariant::FaceCentred), "ccd"),
        ("ccd-face-centred", ccd(CcdVariant::FaceCentred), "ccd"),
        ("ccd-face-centered", ccd(CcdVariant::FaceCentred), "ccd"),
        ("cci", ccd(CcdVariant::Inscribed), "ccd"),
        ("ccd-inscribed", ccd(CcdVariant::Inscribed), "ccd"),
        ("box-behnken", DesignKind::BoxBehnken, "box-behnken"),
        ("bbd", DesignKind::BoxBehnken, "box-behnken"),
        ("box_behnken", DesignKind::BoxBehnken, "box-behnken"),
        ("lhs", DesignKind::Lhs, "lhs"),
        ("latin-hypercube", DesignKind::Lhs, "lhs"),
        ("dsd", DesignKind::Dsd, "dsd"),
        ("definitive-screening", DesignKind::Dsd, "dsd"),
        (" d-optimal ", DesignKind::DOptimal, "d-optimal"),
        ("doptimal", DesignKind::DOptimal, "d-optimal"),
        ("d_optimal", DesignKind::DOptimal, "d-optimal"),
    ];
    for (text, kind, name) in cases {
        let k: DesignKind = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
        assert_eq!(k, kind, "{text}");
        assert_eq!(k.name(), name, "{text}");
    }
    match "taguchi".parse::<DesignKind>() {
        Err(DoeError::InvalidParameter { name, value, .. }) => {
            assert_eq!((name, value.as_str()), ("design", "taguchi"))
        }
        other => panic!("{other:?}"),
    }
}

/// Every spelling of a CCD variant and alpha rule; `as_str` names the variant. Targets mod.rs:50
/// (deleted "inscribed" arm), `CcdVariant::as_str -> "xyzzy"` and `CcdAlpha::from_str -> Ok(Default)`.
#[test]
fn every_spelling_of_a_ccd_variant_and_alpha_parses() {
    for (text, v, s) in [
        ("circumscribed", CcdVariant::Circumscribed, "circumscribed"),
        ("ccc", CcdVariant::Circumscribed, "circumscribed"),
        ("c", CcdVariant::Circumscribed, "circumscribed"),
        ("inscribed", CcdVariant::Inscribed, "inscribed"),
        ("CCI", CcdVariant::Inscribed, "inscribed"),
        ("i", CcdVariant::Inscribed, "inscribed"),
        ("face-centred", CcdVariant::FaceCentred, "face-centred"),
        ("face-centered", CcdVariant::FaceCentred, "face-centred"),
        ("faced", CcdVariant::FaceCentred, "face-centred"),
        ("ccf", CcdVariant::FaceCentred, "face-centred"),
        ("f", CcdVariant::FaceCentred, "face-centred"),
    ] {
        let got: CcdVariant = text.parse().unwrap();
        assert_eq!(got, v, "{text}");
        assert_eq!(got.as_str(), s);
    }
    assert!("hexagonal".parse::<CcdVariant>().is_err());
    for (text, a) in [
        ("rotatable", CcdAlpha::Rotatable),
        ("r", CcdAlpha::Rotatable),
        ("orthogonal", CcdAlpha::Orthogonal),
        ("o", CcdAlpha::Orthogonal),
        ("orthogonal-blocking", CcdAlpha::OrthogonalBlocking),
        ("blocking", CcdAlpha::OrthogonalBlocking),
        ("1.5", CcdAlpha::Value(1.5)),
    ] {
        assert_eq!(text.parse::<CcdAlpha>().unwrap(), a, "{text}");
    }
    for bad in ["0", "-1", "inf", "nan", "wide"] {
        assert!(bad.parse::<CcdAlpha>().is_err(), "{bad}");
    }
}

/// An inscribed CCD of 2 factors puts its axial points at ±1 and shrinks the cube to ±1/√2 (by hand:
/// rotatable α = 4^{1/4} = √2, inscribed divides by α). Targets the deleted "inscribed" arm through
/// `DesignOptions` (ccd_variant = "inscribed").
#[test]
fn an_inscribed_ccd_asked_by_its_variant_name_has_its_cube_inside() {
    let mut o = DesignOptions::new("ccd", "a,b");
    o.ccd_variant = "inscribed".into();
    o.center_points = Some(0);
    o.randomize = false;
    let d = generate(&o.request().unwrap()).unwrap();
    assert_eq!(d.variant, Some("inscribed"));
    let max = d
        .coded_matrix()
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    assert!((max - 1.0).abs() < 1e-12, "{max}");
    let h = std::f64::consts::FRAC_1_SQRT_2;
    assert!(
        d.coded_matrix()
            .iter()
            .any(|r| (r[0] - h).abs() < 1e-12 && (r[1] - h).abs() < 1e-12)
    );
}

/// `DesignOptions::request` carries every option into the request. Targets
/// `DesignOptions::request -> Ok(Default::default())`.
#[test]
fn design_options_carry_every_option_into_the_request() {
    let mut o = DesignOptions::new("d-optimal", "a=1:2,b");
    o.runs = Some(9);
    o.replicates = 2;
    o.center_points = Some(1);
    o.blocks = 1;
    o.seed = Some(42);
    o.randomize = false;
    o.model = Some("main".into());
    o.constraints = Some("a + b <= 1.5".into());
    let r = o.request().unwrap();
    assert_eq!(r.kind, DesignKind::DOptimal);
    assert_eq!(r.factors.len(), 2);
    assert_eq!(r.factors[0].name, "a");
    assert_eq!(r.runs, Some(9));
    assert_eq!(r.replicates, 2);
    assert_eq!(r.center_points, Some(1));
    assert_eq!(r.seed, Some(42));
    assert!(!r.randomize);
    assert_eq!(r.model.as_ref().unwrap().as_str(), "main");
    assert_eq!(r.constraints.len(), 1);
}

/// A Box–Behnken design has 3 centre points by default (the table's `None` → 3): 3 factors give
/// 12 + 3 = 15 runs (Box & Behnken 1960). Targets `mod.rs:702 delete match arm BoxBehnken`.
#[test]
fn a_box_behnken_design_has_three_centre_points_by_default() {
    let d = generate(&DesignRequest::new(DesignKind::BoxBehnken, coded(3))).unwrap();
    assert_eq!(d.center_points, 3);
    assert_eq!(d.n_runs(), 15);
    let zeros = d
        .runs
        .iter()
        .filter(|r| r.coded.iter().all(|&c| c == 0.0))
        .count();
    assert_eq!(zeros, 3);
}

/// Blocks a family does not take are refused: a Latin hypercube, a Plackett–Burman and a DSD in 2
/// blocks. A CCD in 2 blocks is built. Targets `mod.rs:723` (`delete !`, `&& with ||`, `!= with ==`).
#[test]
fn blocks_are_refused_by_a_family_that_takes_none_but_not_by_a_ccd() {
    for kind in [DesignKind::Lhs, DesignKind::PlackettBurman, DesignKind::Dsd] {
        let mut req = DesignRequest::new(kind, coded(3));
        req.blocks = 2;
        let what = unsupported(generate(&req));
        assert_eq!(
            what,
            format!(
                "2 blocks with the {} design (two-level factorials take a power of two, CCD 1 or 2; others 1)",
                kind.name()
            )
        );
    }
    let mut req = DesignRequest::new("ccd".parse().unwrap(), coded(2));
    req.blocks = 2;
    req.center_points = Some(1);
    let d = generate(&req).unwrap();
    assert_eq!(d.blocks, 2);
    // by hand: 4 cube + 4 axial + 1 centre in each of the 2 blocks
    assert_eq!(d.n_runs(), 10);
}

/// Centre points need numeric factors: a full factorial with a label factor and 1 centre point is
/// refused naming the label; with numeric factors the centre point is added once per block (2² in 2
/// blocks + 1 centre each = 6 runs). Targets `mod.rs:750 > with ==`, `mod.rs:751 delete !`.
#[test]
fn centre_points_are_refused_with_a_label_factor_and_added_per_block() {
    let mut req = DesignRequest::new(
        DesignKind::Full,
        FactorSpec::parse_list("a=1:2,tool=x:y").unwrap(),
    );
    req.center_points = Some(1);
    assert_eq!(
        unsupported(generate(&req)),
        "centre points with the label factor `tool` (centre points need numeric factors)"
    );
    let mut req = DesignRequest::new(DesignKind::Full, coded(2));
    req.center_points = Some(1);
    req.blocks = 2;
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 6);
    for b in 1..=2 {
        assert_eq!(
            d.runs
                .iter()
                .filter(|r| r.block == b && r.coded == [0.0, 0.0])
                .count(),
            1
        );
    }
}

/// A randomised design in blocks takes its run orders 1..n, blocks in order: every run of block 1
/// comes before every run of block 2, and `run_order` is a permutation. Targets `mod.rs:792 == with !=`.
#[test]
fn a_randomised_blocked_design_runs_its_blocks_in_order() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(3));
    req.blocks = 2;
    req.replicates = 2;
    req.seed = Some(3);
    let d = generate(&req).unwrap();
    let orders: Vec<usize> = d.runs.iter().map(|r| r.run_order).collect();
    assert_eq!(orders, (1..=16).collect::<Vec<_>>());
    let blocks: Vec<usize> = d.runs.iter().map(|r| r.block).collect();
    assert_eq!(blocks, [1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4]);
    let mut std: Vec<usize> = d.runs.iter().map(|r| r.std_order).collect();
    std.sort();
    assert_eq!(std, (1..=16).collect::<Vec<_>>());
}

/// Constraints are taken only by the D-optimal family: a full factorial with a constraint is
/// refused naming the family. Targets `mod.rs:690` (`&& with ||`, `!= with ==`, `delete !`).
#[test]
fn constraints_are_refused_outside_the_d_optimal_family() {
    let mut o = DesignOptions::new("full", "a,b");
    o.constraints = Some("a + b <= 1".into());
    assert_eq!(
        unsupported(generate(&o.request().unwrap())),
        "constraints with the full design (use --design d-optimal)"
    );
    let mut o = DesignOptions::new("d-optimal", "a,b");
    o.constraints = Some("a + b <= 1".into());
    o.model = Some("main".into());
    o.seed = Some(1);
    let d = generate(&o.request().unwrap()).unwrap();
    assert!(d.runs.iter().all(|r| r.coded[0] + r.coded[1] <= 1.0 + 1e-9));
}

/// A design serialises with its summary and its runs: each run's `std_order`, `run_order`, `block`,
/// the factor's actual level and `<name>_coded`; `n_runs`, `columns`, `coded_matrix`,
/// `factor_names` agree. Targets the `Serialize` bodies (mod.rs:435, 449), `n_runs -> 0`,
/// `columns -> vec![]`, `coded_matrix -> vec![vec![]]`, `factor_names -> vec![]`.
#[test]
fn a_design_serialises_its_runs_and_lists_its_columns() {
    let mut req = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list("a=10:20").unwrap());
    req.randomize = false;
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 2);
    assert_eq!(d.factor_names(), ["a"]);
    assert_eq!(d.coded_matrix(), [vec![-1.0], vec![1.0]]);
    assert_eq!(d.runs[1].actual, [Level::Num(20.0)]);
    let cols = d.columns();
    let names: Vec<&str> = cols.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["std_order", "run_order", "block", "a", "a_coded"]);
    let v = serde_json::to_value(&d).unwrap();
    assert_eq!(v["design"], "full");
    assert_eq!(v["n_runs"], 2);
    assert_eq!(v["replicates"], 1);
    let run = &v["runs"][1];
    assert_eq!(run["std_order"], 2);
    assert_eq!(run["run_order"], 2);
    assert_eq!(run["block"], 1);
    assert_eq!(run["a"], 20.0);
    assert_eq!(run["a_coded"], 1.0);
}

/// A two-level family refuses a three-level factor naming it: a fractional factorial with
/// `c=1:2:3`. Targets `require_two_levels -> Ok(())` and `mod.rs:594 delete !`.
#[test]
fn a_three_level_factor_is_refused_by_a_two_level_family() {
    let mut req = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list("a,b,c=1:2:3,d").unwrap(),
    );
    req.resolution = Some(4);
    match generate(&req) {
        Err(DoeError::LevelsNotAllowed {
            name,
            levels,
            design,
            ..
        }) => {
            assert_eq!((name.as_str(), levels), ("c", 3));
            assert!(design.contains("fractional"), "{design}");
        }
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
    let _ = invalid;
}

fn fractional(
    k: usize,
    set: impl FnOnce(&mut DesignRequest),
) -> millcomp_doe::Result<millcomp_doe::Design> {
    let mut req = DesignRequest::new(DesignKind::Fractional, coded(k));
    req.randomize = false;
    set(&mut req);
    generate(&req)
}

fn bad_generator(r: millcomp_doe::Result<millcomp_doe::Design>) -> (String, String) {
    match r {
        Err(DoeError::InvalidGenerator { generator, reason }) => (generator, reason),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// Every resolution has its Roman numeral, 3 → III … 10 → X, others `high`. Targets the deleted
/// match arms of `resolution_roman` (fractional.rs:651, 652, 658) and its `"xyzzy"` body.
#[test]
fn every_resolution_from_three_to_ten_has_its_roman_numeral() {
    let want = [
        (2, "high"),
        (3, "III"),
        (4, "IV"),
        (5, "V"),
        (6, "VI"),
        (7, "VII"),
        (8, "VIII"),
        (9, "IX"),
        (10, "X"),
        (11, "high"),
    ];
    for (r, s) in want {
        assert_eq!(millcomp_doe::resolution_roman(r), s, "{r}");
    }
}

/// Generators are taken for at most 63 factors: 64 are refused naming the limit. Targets
/// `fractional.rs:156 > with ==` (which refuses only 63).
#[test]
fn generators_for_sixty_four_factors_are_refused_naming_sixty_three() {
    let r = fractional(64, |r| r.generators = Some("F63=AB".into()));
    assert_eq!(
        unsupported(r),
        "64 factors in a fractional factorial (at most 63)"
    );
}

/// Generators may be separated by spaces (`D=AB E=AC`), and a single generator may have spaces around
/// its `=` (`D = ABC`, `D =ABC`, `D= ABC`): each gives its 2^(k−p) (by hand: 8 runs for 5 factors, 8
/// for 4). Targets fractional.rs:172 `&& with ||`, 174 `&& with ||` (twice) and `delete !` (twice).
#[test]
fn generators_separated_by_spaces_and_spaced_around_the_sign_are_read() {
    let d = fractional(5, |r| r.generators = Some("D=AB E=AC".into())).unwrap();
    assert_eq!(d.n_runs(), 8);
    assert_eq!(d.generators, ["D=AB", "E=AC"]);
    for text in ["D = ABC", "D =ABC", "D= ABC"] {
        let d = fractional(4, |r| r.generators = Some(text.into())).unwrap();
        assert_eq!(d.n_runs(), 8, "{text}");
        assert_eq!(d.resolution, Some(4), "{text}");
    }
}

/// A generator whose word uses a generated factor is refused naming that factor: `D=AB,E=AD` (D is
/// generated). Targets fractional.rs:217 `!= with ==` and 219 (`>> with <<`, `== with !=`).
#[test]
fn a_generator_over_a_generated_factor_is_refused_naming_it() {
    let (g, reason) = bad_generator(fractional(5, |r| r.generators = Some("D=AB,E=AD".into())));
    assert_eq!(g, "E=AD");
    assert_eq!(
        reason,
        "the word uses `D` (D), which is itself generated; write words over the base factors only"
    );
    // the factor named is the generated one in the word, wherever it stands: before stop 58 the test
    // read `mask & generated >> i & 1` (`>>` binds first), true only for a word with A and a
    // generated factor i, so `E=AC,D=AE` named D and `D=BC,E=BD` fell back to A
    let (g, reason) = bad_generator(fractional(5, |r| r.generators = Some("E=AC,D=AE".into())));
    assert_eq!(g, "D=AE");
    assert!(reason.starts_with("the word uses `E` (E)"), "{reason}");
    let (g, reason) = bad_generator(fractional(5, |r| r.generators = Some("D=BC,E=BD".into())));
    assert_eq!(g, "E=BD");
    assert!(reason.starts_with("the word uses `D` (D)"), "{reason}");
    // a word with two generated factors names the first: `F=DE` names D. Kills
    // `fractional.rs:219:59: replace & with | in parse_generators` (found by the draw of seed 54):
    // `(m >> i | 1) == 1` first holds at the highest bit of m, so the mutant names E
    let (g, reason) = bad_generator(fractional(6, |r| {
        r.generators = Some("D=AB,E=AC,F=DE".into())
    }));
    assert_eq!(g, "F=DE");
    assert!(reason.starts_with("the word uses `D` (D)"), "{reason}");
}

/// A one-letter word aliases two main effects: `D=A` is refused naming A (word I = AD), and `A=E`
/// names A aliased with E, whichever letter comes first (the generator's own reading: the defining
/// subgroup's check lists letters in order and would call E the factor aliased with A); `D=AB,E=AB`
/// is refused as a duplicate. Targets fractional.rs:248 (`|| with &&`: killed, found by the draw of
/// seed 54, which leaves `A=E` to the subgroup's check), 249 (`== with !=`), 261.
#[test]
fn a_one_letter_generator_and_a_repeated_word_are_refused() {
    for (k, generators, want) in [
        (4, "D=A", ("D", "A", "I = AD")),
        (5, "A=E", ("A", "E", "I = AE")),
    ] {
        match fractional(k, |r| r.generators = Some(generators.into())) {
            Err(DoeError::AliasedGenerators {
                factor,
                aliased_with,
                word,
            }) => assert_eq!(
                (factor.as_str(), aliased_with.as_str(), word.as_str()),
                want
            ),
            other => panic!("{generators}: {:?}", other.map(|d| d.n_runs())),
        }
    }
    match fractional(5, |r| r.generators = Some("D=AB,E=AB".into())) {
        Err(DoeError::DuplicateGenerator {
            first_factor,
            second_factor,
            ..
        }) => assert_eq!((first_factor.as_str(), second_factor.as_str()), ("D", "E")),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// A generator naming an unknown factor is refused listing the factors by letter and name. Targets
/// `available -> String::new()/"xyzzy"` and `resolve_factor -> Ok(1)`.
#[test]
fn an_unknown_factor_in_a_generator_is_refused_listing_the_factors() {
    let (_, reason) = bad_generator(fractional(4, |r| r.generators = Some("D=AZ".into())));
    assert_eq!(
        reason,
        "`Z` is neither a factor name nor a factor letter (A=A, B=B, C=C, D=D)"
    );
    // by name: `a*c` over factors named depth, speed, feed, tool
    let mut req = DesignRequest::new(
        DesignKind::Fractional,
        FactorSpec::parse_list("depth,speed,feed,tool").unwrap(),
    );
    req.generators = Some("tool=depth*speed*feed".into());
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 8);
    assert_eq!(d.defining_relation, ["I=ABCD"]);
}

/// The 2^(5−2) with D=AB, E=AC (Montgomery 9th ed. Table 8.9 design): defining relation I = ABD =
/// ACE = BCDE, word length pattern (2, 1, 0) over lengths 3, 4, 5 (by hand), resolution III, and
/// A aliased with BD and CE. Targets `defining_subgroup -> vec![]`, `word_length_pattern -> vec![0|1]`,
/// `resolution` (`!= with ==`), `alias_structure -> vec![]`, `Word::len -> 1`, `letters`.
#[test]
fn a_two_to_the_five_minus_two_reports_its_defining_relation_and_aliases() {
    let d = fractional(5, |r| r.generators = Some("D=AB,E=AC".into())).unwrap();
    assert_eq!(d.resolution, Some(3));
    assert_eq!(d.defining_relation, ["I=ABD", "I=ACE", "I=BCDE"]);
    assert_eq!(d.word_length_pattern, [2, 1, 0]);
    let v = serde_json::to_value(&d.alias_structure).unwrap();
    let text = v.to_string();
    assert!(text.contains("B:D") && text.contains("C:E"), "{text}");
    assert!(!d.alias_structure.is_empty());
}

/// The resolution is 3 to 8: 2 and 9 are refused naming the range; resolution VIII of 5 factors
/// is the full 2^5 (no catalogued fraction reaches it, k ≤ 7), as is resolution VI of 5 factors.
/// Targets fractional.rs:566 `delete !`, 576, 580, 581 `<= with >`.
#[test]
fn a_resolution_from_three_to_eight_is_taken_and_its_full_factorial_when_no_fraction_reaches_it() {
    for res in [2, 9] {
        let (name, value, allowed) = invalid(fractional(5, |r| r.resolution = Some(res)));
        assert_eq!(
            (name, value.as_str(), allowed.as_str()),
            (
                "resolution",
                res.to_string().as_str(),
                "3 to 8 (III to VIII)"
            )
        );
    }
    for res in [6, 8] {
        let d = fractional(5, |r| r.resolution = Some(res)).unwrap();
        assert_eq!(d.n_runs(), 32, "{res}");
        assert!(d.generators.is_empty());
    }
    // by catalogue: 2^(5−1)_V with E=ABCD, 16 runs
    let d = fractional(5, |r| r.resolution = Some(5)).unwrap();
    assert_eq!((d.n_runs(), d.resolution), (16, Some(5)));
    let d = fractional(7, |r| r.resolution = Some(3)).unwrap();
    assert_eq!(d.n_runs(), 8);
}

/// The run count of a fraction is a power of two of at least 4, at most 2^k: 4 runs of 3 factors is
/// the 2^(3−1) (I = ABC), 8 runs of 3 the full 2^3, 16 runs of 3 refused naming 2^3 = 8, 2 and 6 refused
/// as not a power of two ≥ 4, 5 factors in 8 runs the catalogue's D=AB, E=AC. Targets fractional.rs:595
/// (`|| with &&`, `< with ==/>`), 602 (`< with ==/>`), 605 (`< with >`, `&& with ||`), 622 (`== with !=`).
#[test]
fn a_fraction_by_run_count_takes_powers_of_two_from_four_to_the_full_factorial() {
    let d = fractional(3, |r| r.runs = Some(4)).unwrap();
    assert_eq!(d.n_runs(), 4);
    assert_eq!(d.defining_relation.len(), 1);
    let d = fractional(3, |r| r.runs = Some(8)).unwrap();
    assert_eq!(d.n_runs(), 8);
    assert!(d.generators.is_empty());
    let (name, value, allowed) = invalid(fractional(3, |r| r.runs = Some(16)));
    assert_eq!(
        (name, value.as_str(), allowed.as_str()),
        (
            "runs",
            "16",
            "at most 2^3 = 8 for 3 factors (use --replicates for more)"
        )
    );
    for runs in [2, 6] {
        let (name, value, allowed) = invalid(fractional(3, |r| r.runs = Some(runs)));
        assert_eq!(
            (name, value.as_str(), allowed.as_str()),
            (
                "runs",
                runs.to_string().as_str(),
                "a power of two for a regular fractional factorial"
            )
        );
    }
    let d = fractional(5, |r| r.runs = Some(8)).unwrap();
    assert_eq!(d.n_runs(), 8);
    assert_eq!(d.generators.len(), 2);
    assert_eq!(d.factors.len(), 5);
    assert_eq!(d.resolution, Some(3));
}

/// Blocking a 2^2: 2 blocks confound AB; 4 blocks would confound a main effect and are refused naming
/// the run size. Targets fractional.rs:407 (`< with <=/==/>`), 504 (`< with <=/==`), 512 (`> with ==`).
#[test]
fn a_two_by_two_factorial_takes_two_blocks_but_not_four() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(2));
    req.blocks = 2;
    req.randomize = false;
    let d = generate(&req).unwrap();
    assert_eq!(d.blocks, 2);
    assert_eq!(d.confounded_with_blocks.len(), 1);
    assert_eq!(d.confounded_with_blocks, ["A:B"]);
    for r in &d.runs {
        // by hand: block 1 holds AB = −1 or +1 consistently
        let ab = r.coded[0] * r.coded[1];
        let other = d.runs.iter().find(|s| s.block != r.block).unwrap();
        assert_ne!(ab, other.coded[0] * other.coded[1]);
    }
    req.blocks = 4;
    let (name, value, allowed) = invalid(generate(&req));
    assert_eq!(
        (name, value.as_str(), allowed.as_str()),
        ("blocks", "4", "fewer than the 4 runs of the design")
    );
    // the 2^(3−1) with I = ABC: every column of its 4 runs is a main effect's alias
    let r = fractional(3, |r| {
        r.runs = Some(4);
        r.blocks = 2;
    });
    assert_eq!(
        unsupported(r),
        "2 blocks in a 4-run two-level design of 3 factors"
    );
}

/// A 2^3 in 4 blocks confounds the three two-factor interactions AB, AC, BC (Montgomery 9th ed.
/// §7.7: no choice avoids a 2fi, and ABC with a 2fi would confound a main effect); a 2^5 in 4 blocks
/// confounds no two-factor interaction (Montgomery 9th ed. Table 7.8: ABC, CDE and ABDE). Targets
/// fractional.rs:436 (`< with <=/==`), 443 (`< with ==`), 451.
#[test]
fn blocking_confounds_the_highest_order_interactions_it_can() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(3));
    req.blocks = 4;
    let d = generate(&req).unwrap();
    let mut c = d.confounded_with_blocks.clone();
    c.sort();
    assert_eq!(c.len(), 3);
    for w in &c {
        assert_eq!(
            w.chars().filter(|ch| ch.is_ascii_uppercase()).count(),
            2,
            "{c:?}"
        );
    }
    let mut req = DesignRequest::new(DesignKind::Full, coded(5));
    req.blocks = 4;
    let d = generate(&req).unwrap();
    assert_eq!(d.confounded_with_blocks.len(), 3);
    let mut orders: Vec<usize> = d
        .confounded_with_blocks
        .iter()
        .map(|w| w.chars().filter(|ch| ch.is_ascii_uppercase()).count())
        .collect();
    orders.sort();
    assert_eq!(orders, [3, 3, 4], "{:?}", d.confounded_with_blocks);
}

/// A 2^10 in 8 blocks (over 400 000 candidate sets, so the greedy search) is built: 1024 runs, 128 per
/// block, 7 confounded effects, none a main effect. Targets fractional.rs:468, 478 (`== with !=`) and
/// `binomial` (`-> 0.0`, `-> -1.0`, `> with >=`).
#[test]
fn a_two_to_the_ten_in_eight_blocks_is_blocked_by_the_greedy_search() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(10));
    req.blocks = 8;
    req.randomize = false;
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 1024);
    for b in 1..=8 {
        assert_eq!(d.runs.iter().filter(|r| r.block == b).count(), 128);
    }
    assert_eq!(d.confounded_with_blocks.len(), 7);
    eprintln!("{:?} {:?}", d.block_generators, d.confounded_with_blocks);
}

fn pb(k: usize, runs: Option<usize>) -> millcomp_doe::Result<millcomp_doe::Design> {
    let mut req = DesignRequest::new(DesignKind::PlackettBurman, coded(k));
    req.runs = runs;
    req.randomize = false;
    generate(&req)
}

/// The Plackett–Burman run count: a multiple of 4, more than the factors, with a Hadamard matrix
/// built here. 12 runs take 11 factors, not 12; 14 (not a multiple of 4) and 28 (no Hadamard matrix
/// built) are refused naming the range from k + 1; 40 = 2·20 and 48 = 2·24 are built. Targets
/// screening.rs:76 (`< with ==/>`, `|| with &&` twice, `!= with ==`), 23–25 (`hadamard_supported`).
#[test]
fn a_plackett_burman_run_count_is_a_supported_multiple_of_four_past_the_factors() {
    assert_eq!(pb(11, Some(12)).unwrap().n_runs(), 12);
    let allowed = |k: usize| {
        format!(
            "a multiple of 4 from {} to 4096 for which a Hadamard matrix is built here (4·2^a, 12·2^a, 20·2^a, 24·2^a, 36·2^a, 44·2^a)",
            k + 1
        )
    };
    for (k, runs) in [(12, 12), (3, 14), (3, 28), (3, 52), (3, 4100)] {
        let (name, value, a) = invalid(pb(k, Some(runs)));
        assert_eq!((name, value.as_str()), ("runs", runs.to_string().as_str()));
        assert_eq!(a, allowed(k));
    }
    for runs in [4, 8, 12, 20, 24, 36, 40, 44, 48] {
        let d = pb(3, Some(runs)).unwrap();
        assert_eq!(d.n_runs(), runs);
        // balanced, orthogonal columns (a Hadamard matrix's)
        for j in 0..3 {
            assert_eq!(
                d.runs.iter().filter(|r| r.coded[j] == 1.0).count(),
                runs / 2
            );
            for l in 0..j {
                let dot: f64 = d.runs.iter().map(|r| r.coded[j] * r.coded[l]).sum();
                assert_eq!(dot, 0.0, "{runs} ({j},{l})");
            }
        }
    }
}

/// The default Plackett–Burman size is the smallest supported N > k: 3 factors → 4, 4 → 8, 8 → 12,
/// 11 → 12, 12 → 16, 27 → 32 (28 has no Hadamard matrix here). Targets screening.rs:90 (`> with ==/>=`).
#[test]
fn the_default_plackett_burman_size_is_the_smallest_supported_past_the_factors() {
    for (k, n) in [(3, 4), (4, 8), (8, 12), (11, 12), (12, 16), (27, 32)] {
        assert_eq!(pb(k, None).unwrap().n_runs(), n, "k={k}");
    }
}

/// Definitive screening designs of 2m + 1 runs, m the smallest conference order ≥ k (even): 4 → 9,
/// 5 → 13, 10 → 21 (GF(9)), 16 → 37 (no order 16: 18), 26 → 53 (GF(25)); main-effect columns are
/// orthogonal with 3 zeros each (Jones & Nachtsheim 2011). Targets the `Gf` methods, `prime_power`,
/// `conference`, `dsd` (screening.rs:150–264).
#[test]
fn definitive_screening_designs_have_two_m_plus_one_orthogonal_runs() {
    for (k, n) in [(4, 9), (5, 13), (10, 21), (16, 37), (26, 53)] {
        let mut req = DesignRequest::new(DesignKind::Dsd, coded(k));
        req.randomize = false;
        let d = generate(&req).unwrap();
        assert_eq!(d.n_runs(), n, "k={k}");
        for j in 0..k {
            assert_eq!(
                d.runs.iter().filter(|r| r.coded[j] == 0.0).count(),
                3,
                "k={k}"
            );
            for l in 0..j {
                let dot: f64 = d.runs.iter().map(|r| r.coded[j] * r.coded[l]).sum();
                assert_eq!(dot, 0.0, "k={k} ({j},{l})");
            }
        }
    }
    match generate(&DesignRequest::new(DesignKind::Dsd, coded(1))) {
        Err(DoeError::NotEnoughData { needed, have, .. }) => assert_eq!((needed, have), (2, 1)),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

fn ccd_req(k: usize, variant: CcdVariant, alpha: CcdAlpha) -> DesignRequest {
    let mut req = DesignRequest::new(DesignKind::Ccd { variant, alpha }, coded(k));
    req.randomize = false;
    req
}

/// CCD axial distances by hand: rotatable k=3 → 8^{1/4} = 1.681793; orthogonal k=2 with 4 centre
/// points (N = 12, n_F = 4) → √((√48 − 4)/2) = 1.209683; orthogonal blocking k=3, 2 blocks with 2
/// centres each → √(3·(1 + 2/6)/(1 + 2/8)) = √3.2 = 1.788854 (Montgomery eq. 11.22). Targets
/// `ccd_alpha -> ±1.0`, rsm.rs:80 and 105 (`== with !=`).
#[test]
fn ccd_axial_distances_follow_their_rules() {
    let d = generate(&ccd_req(3, CcdVariant::Circumscribed, CcdAlpha::Rotatable)).unwrap();
    assert!((d.alpha.unwrap() - 8f64.powf(0.25)).abs() < 1e-12);
    let mut r = ccd_req(2, CcdVariant::Circumscribed, CcdAlpha::Orthogonal);
    r.center_points = Some(4);
    let d = generate(&r).unwrap();
    let want = ((48f64.sqrt() - 4.0) / 2.0).sqrt();
    assert!((d.alpha.unwrap() - want).abs() < 1e-12, "{:?}", d.alpha);
    let mut r = ccd_req(3, CcdVariant::Circumscribed, CcdAlpha::OrthogonalBlocking);
    r.blocks = 2;
    r.center_points = Some(2);
    let d = generate(&r).unwrap();
    assert!(
        (d.alpha.unwrap() - 3.2f64.sqrt()).abs() < 1e-12,
        "{:?}",
        d.alpha
    );
    assert_eq!(d.n_runs(), 8 + 6 + 4);
    // axial points in block 2, cube points in block 1
    for run in &d.runs {
        let nonzero = run.coded.iter().filter(|&&c| c != 0.0).count();
        if nonzero == 3 {
            assert_eq!(run.block, 1);
        } else if nonzero == 1 {
            assert_eq!(run.block, 2);
        }
    }
}

/// CCD guards: 1 factor refused (2 needed), 3 blocks refused naming "1 or 2", orthogonal blocking in
/// one block refused, an explicit α of 0, −1 or NaN refused, 0.5 taken. Targets rsm.rs:43, 50, 58, 93.
#[test]
fn a_ccd_refuses_one_factor_three_blocks_and_a_non_positive_alpha() {
    match generate(&ccd_req(1, CcdVariant::Circumscribed, CcdAlpha::Rotatable)) {
        Err(DoeError::NotEnoughData { needed, have, .. }) => assert_eq!((needed, have), (2, 1)),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
    assert_eq!(
        generate(&ccd_req(2, CcdVariant::Circumscribed, CcdAlpha::Rotatable))
            .unwrap()
            .n_runs(),
        4 + 4 + 4
    );
    let mut r = ccd_req(2, CcdVariant::Circumscribed, CcdAlpha::Rotatable);
    r.blocks = 3;
    let (name, value, allowed) = invalid(generate(&r));
    assert_eq!(
        (name, value.as_str(), allowed.as_str()),
        (
            "blocks",
            "3",
            "1 or 2 for a central composite design (2 = factorial block + axial block)"
        )
    );
    let (name, value, allowed) = invalid(generate(&ccd_req(
        2,
        CcdVariant::Circumscribed,
        CcdAlpha::OrthogonalBlocking,
    )));
    assert_eq!(
        (name, value.as_str(), allowed.as_str()),
        (
            "alpha",
            "orthogonal-blocking",
            "only with --blocks 2 (factorial and axial blocks)"
        )
    );
    for a in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let (name, _, allowed) = invalid(generate(&ccd_req(
            2,
            CcdVariant::Circumscribed,
            CcdAlpha::Value(a),
        )));
        assert_eq!(
            (name, allowed.as_str()),
            ("alpha", "a positive finite axial distance"),
            "{a}"
        );
    }
    let d = generate(&ccd_req(2, CcdVariant::Circumscribed, CcdAlpha::Value(0.5))).unwrap();
    assert_eq!(d.alpha, Some(0.5));
    assert!(
        d.notes.iter().all(|n| !n.contains("axial points lie")),
        "{:?}",
        d.notes
    );
}

/// The notes of a CCD: a circumscribed α > 1 warns the axial points lie outside the cube (±1.4142 for
/// k = 2, rotatable); a face-centred CCD notes α set to 1 only when another rule asked otherwise.
/// Targets rsm.rs:88 (`&& with ||`, `> with <`) and 126 (`> with <`).
#[test]
fn a_ccd_notes_axial_points_outside_the_cube_and_a_face_centred_alpha() {
    let d = generate(&ccd_req(2, CcdVariant::Circumscribed, CcdAlpha::Rotatable)).unwrap();
    assert!(
        d.notes.iter().any(|n| n
            == "axial points lie at ±1.4142 coded units, outside the given low/high: check they are feasible"),
        "{:?}",
        d.notes
    );
    let face = "face-centred CCD: alpha set to 1";
    let d = generate(&ccd_req(2, CcdVariant::FaceCentred, CcdAlpha::Rotatable)).unwrap();
    assert!(!d.notes.iter().any(|n| n == face), "{:?}", d.notes);
    assert_eq!(d.alpha, Some(1.0));
    let d = generate(&ccd_req(2, CcdVariant::FaceCentred, CcdAlpha::Orthogonal)).unwrap();
    assert!(d.notes.iter().any(|n| n == face), "{:?}", d.notes);
    let d = generate(&ccd_req(2, CcdVariant::FaceCentred, CcdAlpha::Value(1.0))).unwrap();
    assert!(!d.notes.iter().any(|n| n == face), "{:?}", d.notes);
    assert!(d.notes.iter().all(|n| !n.contains("axial points lie")));
}

/// Two-level factorial guards: 63 coded factors reach the 2^20 base limit (naming 2^63), 64 are refused
/// naming 63; 3 blocks are refused as not a power of two; a mixed-level full factorial refuses 2
/// blocks. Targets factorial.rs:43 (`> with ==/>=`), 80 (`delete !`), 172 (`> with <`).
#[test]
fn two_level_factorial_limits_on_factors_and_blocks() {
    assert_eq!(
        unsupported(generate(&DesignRequest::new(DesignKind::Full, coded(63)))),
        "a two-level design with 2^63 runs (at most 2^20)"
    );
    assert_eq!(
        unsupported(generate(&DesignRequest::new(DesignKind::Full, coded(64)))),
        "64 factors in a two-level factorial (at most 63)"
    );
    let mut req = DesignRequest::new(DesignKind::Full, coded(3));
    req.blocks = 3;
    let (name, value, allowed) = invalid(generate(&req));
    assert_eq!(
        (name, value.as_str(), allowed.as_str()),
        (
            "blocks",
            "3",
            "a power of two (2, 4, 8, …) for a two-level factorial"
        )
    );
    let mut req = DesignRequest::new(
        DesignKind::Full,
        FactorSpec::parse_list("a=1:2:3,b").unwrap(),
    );
    req.blocks = 2;
    assert_eq!(
        unsupported(generate(&req)),
        "2 blocks in a mixed-level full factorial (blocking by confounding needs two-level factors; use --replicates)"
    );
    req.blocks = 1;
    assert_eq!(generate(&req).unwrap().n_runs(), 6);
}

/// A 2^2 in 2 blocks puts AB = −1 in block 1 and AB = +1 in block 2 (block = 1 + [word > 0]); a 2^3 in
/// 4 blocks notes the confounded two-factor interactions. Targets factorial.rs:104 (`> with <`),
/// 114, 117, 130 (`== with !=`).
#[test]
fn a_blocked_factorial_numbers_its_blocks_by_the_sign_of_the_block_word() {
    let mut req = DesignRequest::new(DesignKind::Full, coded(2));
    req.blocks = 2;
    req.randomize = false;
    let d = generate(&req).unwrap();
    for r in &d.runs {
        let ab = r.coded[0] * r.coded[1];
        assert_eq!(r.block, if ab > 0.0 { 2 } else { 1 }, "{:?}", r.coded);
    }
    assert_eq!(d.block_generators, ["AB"]);
    assert_eq!(d.confounded_with_blocks, ["A:B"]);
    assert!(
        d.notes
            .iter()
            .any(|n| n.contains("confound two-factor interaction(s) A:B")),
        "{:?}",
        d.notes
    );
    let mut req = DesignRequest::new(DesignKind::Full, coded(4));
    req.blocks = 2;
    let d = generate(&req).unwrap();
    assert_eq!(d.confounded_with_blocks, ["A:B:C:D"]);
    assert!(
        d.notes.iter().all(|n| !n.contains("confound two-factor")),
        "{:?}",
        d.notes
    );
}

/// Generators that fall short of a requested resolution are refused naming both: `D=AB` gives III, IV
/// was asked. Targets factorial.rs:195 (`< with ==/>`).
#[test]
fn generators_below_the_requested_resolution_are_refused() {
    let (_, reason) = bad_generator(fractional(4, |r| {
        r.generators = Some("D=AB".into());
        r.resolution = Some(4);
    }));
    assert_eq!(
        reason,
        "these generators give resolution III but IV was requested"
    );
    let d = fractional(4, |r| {
        r.generators = Some("D=ABC".into());
        r.resolution = Some(4);
    })
    .unwrap();
    assert_eq!(d.resolution, Some(4));
    let d = fractional(4, |r| {
        r.generators = Some("D=ABC".into());
        r.resolution = Some(3);
    })
    .unwrap();
    assert_eq!(d.n_runs(), 8);
}

fn dopt(
    factors: &str,
    model: &str,
    runs: Option<usize>,
) -> millcomp_doe::Result<millcomp_doe::Design> {
    let mut o = DesignOptions::new("d-optimal", factors);
    o.model = Some(model.into());
    o.runs = runs;
    o.seed = Some(11);
    o.randomize = false;
    generate(&o.request().unwrap())
}

/// A D-optimal main-effects design of 2 factors in 4 runs is the 2²: XᵀX = 4·I₃, so ln det = 3 ln 4
/// and the D-efficiency 100·det^{1/3}/n = 100 % (by hand). 3 runs (= p) are taken, 2 refused naming 3.
/// Targets `info_inverse` (all its replacements), `model_row`, doptimal.rs:215 (`< with ==/>`),
/// 301, 320, and the `main` keyword arm (model.rs:176).
#[test]
fn a_d_optimal_main_effects_design_in_four_runs_is_the_two_by_two() {
    let d = dopt("a,b", "main", Some(4)).unwrap();
    assert_eq!(d.n_runs(), 4);
    assert_eq!(d.criteria.model.as_deref(), Some("a + b"));
    let ld = d.criteria.log_det_xtx.unwrap();
    assert!((ld - 3.0 * 4f64.ln()).abs() < 1e-9, "{ld}");
    assert!((d.criteria.d_efficiency_pct.unwrap() - 100.0).abs() < 1e-9);
    let mut pts = d.coded_matrix();
    pts.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(
        pts,
        [
            vec![-1.0, -1.0],
            vec![-1.0, 1.0],
            vec![1.0, -1.0],
            vec![1.0, 1.0]
        ]
    );
    let d = dopt("a,b", "main", Some(3)).unwrap();
    assert_eq!(d.n_runs(), 3);
    // by hand: the best 3 of the 4 corners, det XᵀX = 16 (|det X| = 4)
    assert!((d.criteria.log_det_xtx.unwrap() - 16f64.ln()).abs() < 1e-9);
    let (name, value, allowed) = invalid(dopt("a,b", "main", Some(2)));
    assert_eq!(
        (name, value.as_str(), allowed.as_str()),
        (
            "runs",
            "2",
            "at least 3, the number of coefficients of the model `main`"
        )
    );
}

/// Model keywords and formulas as a D-optimal design lists them, in the order main effects,
/// interactions by order, squares: `2fi` of 3 → a + b + c + a:b + a:c + b:c; `full` of 3 → 7 terms up
/// to a:b:c; `a*b` → a + b + a:b; `quadratic` of 2 → a + b + a:b + a^2 + b^2 (squares on 3 levels).
/// Targets `keyword_terms` (model.rs:156, 176, 193), `expand` (209, 228, 230, 247), `Term::name`
/// (109, 112), `has_square` (127), `degree` (130).
#[test]
fn a_d_optimal_design_lists_the_terms_of_its_model_in_order() {
    let cases = [
        ("a,b,c", "2fi", "a + b + c + a:b + a:c + b:c"),
        ("a,b,c", "interactions", "a + b + c + a:b + a:c + b:c"),
        ("a,b,c", "full", "a + b + c + a:b + a:c + b:c + a:b:c"),
        ("a,b,c", "saturated", "a + b + c + a:b + a:c + b:c + a:b:c"),
        ("a,b", "a*b", "a + b + a:b"),
        ("a,b", "quadratic", "a + b + a:b + a^2 + b^2"),
        ("a,b", "b^2 + a + a:b + b", "a + b + a:b + b^2"),
        ("a,b", "a^1 + linear", "a + b"),
    ];
    for (f, m, want) in cases {
        let d = dopt(f, m, None).unwrap_or_else(|e| panic!("{m}: {e}"));
        assert_eq!(d.criteria.model.as_deref(), Some(want), "{m}");
        assert!(d.criteria.log_det_xtx.is_some(), "{m}");
    }
    // a square puts the runs on three levels
    let d = dopt("a,b", "quadratic", None).unwrap();
    assert!(d.runs.iter().any(|r| r.coded.contains(&0.0)));
    for bad in ["a^3", "a:a", "z"] {
        assert!(dopt("a,b", bad, None).is_err(), "{bad}");
    }
}

/// A crossing `a*b*…` takes at most 16 factors: 16 expand (2¹⁶ − 1 terms, then refused for needing more
/// than 10 000 runs), 17 are refused naming the limit. Targets model.rs:222 (`> with ==/<`).
#[test]
fn a_crossing_of_sixteen_factors_expands_and_seventeen_is_refused() {
    let names = |k: usize| (0..k).map(|i| format!("x{i}")).collect::<Vec<_>>();
    let (name, value, _) = invalid(dopt(&names(16).join(","), &names(16).join("*"), None));
    assert_eq!((name, value.as_str()), ("runs", "65541"));
    match dopt(&names(17).join(","), &names(17).join("*"), None) {
        Err(DoeError::InvalidModel { reason, .. }) => assert_eq!(
            reason,
            format!(
                "`{}` crosses 17 factors: at most 16 (2¹⁶ − 1 terms)",
                names(17).join("*")
            )
        ),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
}

/// Every model keyword spelling parses to its model and prints as its canonical keyword. Targets
/// model.rs:40 (deleted `main` arm), `as_str` (`""`, `"xyzzy"`) and `from_str -> Ok(Default)`.
#[test]
fn every_model_keyword_spelling_parses_to_its_model() {
    use millcomp_doe::ModelSpec;
    for (text, m, s) in [
        ("main", ModelSpec::Main, "main"),
        ("Linear", ModelSpec::Main, "main"),
        ("main-effects", ModelSpec::Main, "main"),
        ("2fi", ModelSpec::TwoFi, "2fi"),
        ("interactions", ModelSpec::TwoFi, "2fi"),
        ("two-factor", ModelSpec::TwoFi, "2fi"),
        ("quadratic", ModelSpec::Quadratic, "quadratic"),
        ("rsm", ModelSpec::Quadratic, "quadratic"),
        ("full-quadratic", ModelSpec::Quadratic, "quadratic"),
        ("full", ModelSpec::Full, "full"),
        ("saturated", ModelSpec::Full, "full"),
    ] {
        assert_eq!(ModelSpec::parse(text).unwrap(), m, "{text}");
        let p: ModelSpec = text.parse().unwrap();
        assert_eq!(p, m, "{text}");
        assert_eq!(p.as_str(), s);
    }
    let f: ModelSpec = "a + b:c".parse().unwrap();
    assert_eq!(f, ModelSpec::Formula("a + b:c".into()));
    assert_eq!(f.as_str(), "a + b:c");
}

/// Constraints: a leading sign, `-` between terms, an exponent's sign inside a number, coefficients,
/// letters for names, `>=` stored negated, several separated by `;` (empty pieces skipped). Targets
/// doptimal.rs:54, 56, 62, 99 (all seven), 103, 104, 131, 132, 142.
#[test]
fn constraints_are_read_term_by_term_with_their_signs() {
    use millcomp_doe::LinearConstraint;
    let f = FactorSpec::parse_list("depth,feed").unwrap();
    let c = LinearConstraint::parse_list("-depth + feed <= 1", &f).unwrap();
    assert_eq!(
        (c[0].coefs.clone(), c[0].rhs),
        (vec![(0, -1.0), (1, 1.0)], 1.0)
    );
    let c = LinearConstraint::parse_list("depth - 2*feed >= -1", &f).unwrap();
    assert_eq!(
        (c[0].coefs.clone(), c[0].rhs),
        (vec![(0, -1.0), (1, 2.0)], 1.0)
    );
    let c = LinearConstraint::parse_list("1e-1*A + B <= 0.5", &f).unwrap();
    assert_eq!(
        (c[0].coefs.clone(), c[0].rhs),
        (vec![(0, 0.1), (1, 1.0)], 0.5)
    );
    let c = LinearConstraint::parse_list("depth + 0.5 + feed <= 1", &f).unwrap();
    assert_eq!(
        (c[0].coefs.clone(), c[0].rhs),
        (vec![(0, 1.0), (1, 1.0)], 0.5)
    );
    let c = LinearConstraint::parse_list("; depth <= 0.5;; feed >= -0.5 ;", &f).unwrap();
    assert_eq!(c.len(), 2);
    assert_eq!((c[0].coefs.clone(), c[0].rhs), (vec![(0, 1.0)], 0.5));
    assert_eq!((c[1].coefs.clone(), c[1].rhs), (vec![(1, -1.0)], 0.5));
    assert_eq!(c[1].text, "feed >= -0.5");
    match LinearConstraint::parse_list("depth + speed <= 1", &f) {
        Err(DoeError::UnknownFactor {
            name, available, ..
        }) => {
            assert_eq!(
                (name.as_str(), available.as_str()),
                ("speed", "depth, feed")
            )
        }
        other => panic!("{other:?}"),
    }
    match LinearConstraint::parse_list("depth + + feed <= 1", &f) {
        Err(DoeError::InvalidConstraint { reason, .. }) => assert_eq!(reason, "empty term"),
        other => panic!("{other:?}"),
    }
}

/// A constrained D-optimal design searches five levels per factor (−1, −0.5, 0, 0.5, 1): under
/// `a + b <= 0.5` a main-effects design uses the vertices (1, −0.5) and (−0.5, 1) of the cut corner, and
/// every run is feasible. Targets doptimal.rs:225 and 292 (`delete !`).
#[test]
fn a_constrained_d_optimal_design_reaches_the_cut_corner_on_half_levels() {
    let mut o = DesignOptions::new("d-optimal", "a,b");
    o.model = Some("main".into());
    o.constraints = Some("a + b <= 0.5".into());
    o.runs = Some(6);
    o.seed = Some(2);
    let d = generate(&o.request().unwrap()).unwrap();
    assert!(
        d.runs
            .iter()
            .all(|r| r.coded[0] + r.coded[1] <= 0.5 + 1e-12)
    );
    assert!(
        d.runs
            .iter()
            .any(|r| r.coded.iter().any(|c| c.abs() == 0.5)),
        "{:?}",
        d.coded_matrix()
    );
}

/// Factor letters skip I (Montgomery Table 8.14 convention): 0 → A, 7 → H, 8 → J, 24 → Z, 25 → F26.
/// Targets `factor_letter -> String::new()`.
#[test]
fn factor_letters_skip_i_and_continue_as_numbered_names() {
    let l = millcomp_doe::factor_letter;
    assert_eq!(
        [l(0), l(7), l(8), l(24), l(25), l(30)],
        ["A", "H", "J", "Z", "F26", "F31"]
    );
}

/// A column's length and emptiness. Targets `Values::len -> 0` and `is_empty` (`== with !=`).
#[test]
fn a_column_counts_its_rows() {
    use millcomp_doe::Values;
    assert_eq!(Values::F64(vec![1.0, 2.0]).len(), 2);
    assert_eq!(Values::I64(vec![1, 2, 3]).len(), 3);
    assert_eq!(Values::Str(vec!["a".into()]).len(), 1);
    assert!(!Values::F64(vec![1.0]).is_empty());
    assert!(Values::Str(vec![]).is_empty());
}

/// Factor names: a letter or `_` first, then letters, digits, `_` or `.`. Targets `valid_name`
/// (`-> true/false`, `|| with &&`, `== with !=`).
#[test]
fn a_factor_name_starts_with_a_letter_or_underscore() {
    for ok in ["a", "_x", "depth_um", "x.y", "x1", "Tiefe"] {
        assert_eq!(FactorSpec::parse(ok).unwrap().name, ok);
    }
    for bad in ["1x", ".x", "a-b", "a b", "a/b"] {
        match FactorSpec::parse(bad) {
            Err(DoeError::InvalidFactorSpec { reason, .. }) => assert_eq!(
                reason,
                "a factor name uses letters, digits, `_` or `.` and does not start with a digit",
                "{bad}"
            ),
            other => panic!("{bad}: {other:?}"),
        }
    }
}

/// What a factor spec says of itself: kind, level count, continuity, range, coded levels (by hand:
/// 100:130:200 → −1, −0.4, +1; 200:100 → +1, −1; three labels → −1, 0, +1). Targets `FactorSpec::coded`,
/// `numeric`, `parse`, `n_levels`, `kind`, `is_continuous`, `range`, `coded_levels` and `code_value`
/// (every replacement listed in factor.rs:87–317).
#[test]
fn a_factor_reports_its_kind_levels_range_and_coded_levels() {
    use millcomp_doe::FactorLevels;
    let c = FactorSpec::coded("a");
    assert_eq!((c.name.as_str(), &c.levels), ("a", &FactorLevels::Coded));
    assert_eq!(
        (c.kind(), c.n_levels(), c.is_continuous()),
        ("coded", 2, true)
    );
    assert_eq!(c.range(), Some((-1.0, 1.0)));
    assert_eq!(c.coded_levels(), [-1.0, 1.0]);
    let n = FactorSpec::numeric("d", 100.0, 200.0);
    assert_eq!(n.levels, FactorLevels::Numeric(vec![100.0, 200.0]));
    assert_eq!(
        (n.kind(), n.n_levels(), n.is_continuous()),
        ("numeric", 2, true)
    );
    assert_eq!(n.range(), Some((100.0, 200.0)));
    let p = FactorSpec::parse("d = 100:130:200").unwrap();
    assert_eq!(p.name, "d");
    assert_eq!(p.n_levels(), 3);
    assert_eq!(p.range(), Some((100.0, 200.0)));
    let cl = p.coded_levels();
    assert_eq!(cl[0], -1.0);
    assert!((cl[1] + 0.4).abs() < 1e-12, "{cl:?}");
    assert_eq!(cl[2], 1.0);
    let r = FactorSpec::parse("d=200:100").unwrap();
    assert_eq!(r.coded_levels(), [1.0, -1.0]);
    assert_eq!(
        FactorSpec::parse("v=-3:-1").unwrap().range(),
        Some((-3.0, -1.0))
    );
    let m = FactorSpec::parse("tool=x:y:z").unwrap();
    assert_eq!(
        (m.kind(), m.n_levels(), m.is_continuous()),
        ("label", 3, false)
    );
    assert_eq!(m.range(), None);
    assert_eq!(m.coded_levels(), [-1.0, 0.0, 1.0]);
    let f = FactorSpec::parse_list("a=1:2, b").unwrap();
    assert_eq!(f.len(), 2);
    assert_eq!(f[1].name, "b");
}

/// The actual level of a coded value: snapped to a listed level within rounding, interpolated
/// between (by hand: 100:150:200 at +1 → 200, at 0 → 150, at 0.5 → 175; labels x:y:z at 0.4 → y).
/// Targets factor.rs:290 (`<= with >`).
#[test]
fn a_coded_value_maps_to_its_actual_level() {
    let p = FactorSpec::parse("d=100:150:200").unwrap();
    assert_eq!(p.actual(1.0), Level::Num(200.0));
    assert_eq!(p.actual(-1.0), Level::Num(100.0));
    assert_eq!(p.actual(0.0), Level::Num(150.0));
    assert_eq!(p.actual(0.5), Level::Num(175.0));
    let m = FactorSpec::parse("tool=x:y:z").unwrap();
    assert_eq!(m.actual(0.4), Level::Label("y".into()));
    assert_eq!(m.actual(1.0), Level::Label("z".into()));
}

/// A level that is not a finite number (`inf`, `nan`) is refused, a single level too. Targets
/// factor.rs:141, 156.
#[test]
fn a_factor_of_one_level_or_a_non_finite_level_is_refused() {
    for bad in ["d=1:inf", "d=nan:2"] {
        assert!(
            matches!(
                FactorSpec::parse(bad),
                Err(DoeError::InvalidFactorSpec { .. })
            ),
            "{bad}"
        );
    }
    for one in ["d=5", "d=5:5"] {
        match FactorSpec::parse(one) {
            Err(DoeError::SingleLevelFactor { name, level }) => {
                assert_eq!((name.as_str(), level.as_str()), ("d", "5"))
            }
            other => panic!("{one}: {other:?}"),
        }
    }
}

/// A Latin hypercube has 2 to 5000 runs: 1 and 5001 are refused naming the range; 2 runs of 2 factors
/// sit at the stratum midpoints ±0.5 on a diagonal, √2 apart (by hand). Targets spacefilling.rs:48
/// (`delete !`), `sq_dists` (`vec![vec![0.0|1.0]]`), the `min_distance` criterion.
#[test]
fn a_latin_hypercube_takes_two_to_five_thousand_runs() {
    for runs in [1, 5001] {
        let mut req = DesignRequest::new(DesignKind::Lhs, coded(2));
        req.runs = Some(runs);
        let (name, value, allowed) = invalid(generate(&req));
        assert_eq!(
            (name, value.as_str(), allowed.as_str()),
            (
                "runs",
                runs.to_string().as_str(),
                "2 to 5000 for a Latin hypercube"
            )
        );
    }
    let mut req = DesignRequest::new(DesignKind::Lhs, coded(2));
    req.runs = Some(2);
    req.seed = Some(4);
    let d = generate(&req).unwrap();
    assert!((d.criteria.min_distance.unwrap() - 2f64.sqrt()).abs() < 1e-12);
    for j in 0..2 {
        let mut col: Vec<f64> = d.runs.iter().map(|r| r.coded[j]).collect();
        col.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(col, [-0.5, 0.5]);
    }
    // 4 runs of 2 factors: a maximin LHS on the 4×4 grid of midpoints ±0.25, ±0.75 reaches a smallest
    // distance of √(0.5² + 1²) = 1.118 (by hand: a knight's-move permutation 2,4,1,3)
    req.runs = Some(4);
    let d = generate(&req).unwrap();
    assert!(
        (d.criteria.min_distance.unwrap() - 1.25f64.sqrt()).abs() < 1e-12,
        "{:?}",
        d.criteria.min_distance
    );
}

/// A D-optimal design of exactly 10 000 runs (`MAX_DOPTIMAL_RUNS`) is built: one coded factor, main
/// effects, half the runs at each level (by hand: det XᵀX = n² − (Σx)² is largest when Σx = 0, so
/// ln det = 2 ln 10⁴). Targets doptimal.rs:205 (`> with >=`).
#[test]
fn a_d_optimal_design_of_exactly_ten_thousand_runs_is_built() {
    let d = dopt("a", "main", Some(10_000)).unwrap();
    assert_eq!(d.n_runs(), 10_000);
    assert_eq!(d.runs.iter().filter(|r| r.coded[0] == 1.0).count(), 5_000);
    assert!((d.criteria.log_det_xtx.unwrap() - 2.0 * 1e4f64.ln()).abs() < 1e-9);
}

/// The alias structure of the 2^(5−2) with D = AB, E = AC (words ABD, ACE, BCDE), by hand: each main
/// effect and two-factor interaction with its aliases of order ≤ 3, sorted by order then factors.
/// Targets `alias_structure` (fractional.rs:336–353: `-> vec![]`, `<<`/`>>` swaps, `<= with >`,
/// `&& with ||`, `!= with ==`).
#[test]
fn the_aliases_of_a_two_to_the_five_minus_two_are_those_worked_by_hand() {
    let d = fractional(5, |r| r.generators = Some("D=AB,E=AC".into())).unwrap();
    let got: Vec<(String, Vec<String>)> = d
        .alias_structure
        .iter()
        .map(|e| (e.term.clone(), e.aliases.clone()))
        .collect();
    let want: Vec<(&str, Vec<&str>)> = vec![
        ("A", vec!["B:D", "C:E"]),
        ("B", vec!["A:D", "C:D:E"]),
        ("C", vec!["A:E", "B:D:E"]),
        ("D", vec!["A:B", "B:C:E"]),
        ("E", vec!["A:C", "B:C:D"]),
        ("A:B", vec!["D", "B:C:E"]),
        ("A:C", vec!["E", "B:C:D"]),
        ("A:D", vec!["B", "C:D:E"]),
        ("A:E", vec!["C", "B:D:E"]),
        ("B:C", vec!["D:E", "A:B:E", "A:C:D"]),
        ("B:D", vec!["A", "C:E"]),
        ("B:E", vec!["C:D", "A:B:C", "A:D:E"]),
        ("C:D", vec!["B:E", "A:B:C", "A:D:E"]),
        ("C:E", vec!["A", "B:D"]),
        ("D:E", vec!["B:C", "A:B:E", "A:C:D"]),
    ];
    let want: Vec<(String, Vec<String>)> = want
        .into_iter()
        .map(|(t, a)| (t.to_string(), a.into_iter().map(String::from).collect()))
        .collect();
    assert_eq!(got, want);
}

/// A run count with a resolution: 5 factors in 8 runs reach resolution III (the catalogue's 2^(5−2)_III)
/// and are refused at IV naming the best 8-run design's III; 5 factors in 16 runs reach V. Targets
/// factorial.rs:234 (`< with <=/>`).
#[test]
fn a_run_count_with_a_resolution_is_refused_only_below_that_resolution() {
    let d = fractional(5, |r| {
        r.runs = Some(8);
        r.resolution = Some(3);
    })
    .unwrap();
    assert_eq!((d.n_runs(), d.resolution), (8, Some(3)));
    match fractional(5, |r| {
        r.runs = Some(8);
        r.resolution = Some(4);
    }) {
        Err(DoeError::NoCatalogueDesign {
            factors,
            request,
            reason,
        }) => assert_eq!(
            (factors, request.as_str(), reason.as_str()),
            (
                5,
                "in 8 runs at resolution IV",
                "the best 8-run design has resolution III; use more runs"
            )
        ),
        other => panic!("{:?}", other.map(|d| d.n_runs())),
    }
    let d = fractional(5, |r| {
        r.runs = Some(16);
        r.resolution = Some(5);
    })
    .unwrap();
    assert_eq!((d.n_runs(), d.resolution), (16, Some(5)));
}

/// A D-optimal design takes p + 5 runs by default (main effects of 2 factors: p = 3 → 8 runs), and
/// under `a + b <= 0.5` 19 of the 25 points of the 5-level grid are candidates (by hand: 5 + 5 + 4 + 3
/// + 2 for a = −1, −0.5, 0, 0.5, 1). Targets doptimal.rs:203, 204, 241, 242.
#[test]
fn a_d_optimal_design_takes_p_plus_five_runs_and_counts_its_candidates() {
    let d = dopt("a,b", "main", None).unwrap();
    assert_eq!(d.n_runs(), 8);
    let mut o = DesignOptions::new("d-optimal", "a,b");
    o.model = Some("main".into());
    o.constraints = Some("a + b <= 0.5".into());
    o.seed = Some(2);
    let d = generate(&o.request().unwrap()).unwrap();
    assert!(
        d.notes
            .iter()
            .any(|n| n.ends_with("; 19 candidate points satisfy the constraints")),
        "{:?}",
        d.notes
    );
}

/// An orthogonal CCD in 2 blocks counts the centre points of both blocks: k = 2, 2 centres per block,
/// N = 4 + 4 + 4 = 12, α = √((√48 − 4)/2) (by hand, Box & Hunter 1957). Targets rsm.rs:22 (`+ with -`).
#[test]
fn an_orthogonal_ccd_in_two_blocks_counts_the_centre_points_of_both() {
    let mut r = ccd_req(2, CcdVariant::Circumscribed, CcdAlpha::Orthogonal);
    r.blocks = 2;
    r.center_points = Some(2);
    let d = generate(&r).unwrap();
    let want = ((48f64.sqrt() - 4.0) / 2.0).sqrt();
    assert!((d.alpha.unwrap() - want).abs() < 1e-12, "{:?}", d.alpha);
    assert_eq!(d.n_runs(), 12);
}

/// A CCD of 5 factors is built on the 2^(5−1)_V (E = ABCD): its alias structure pairs each two-factor
/// interaction with the complementary three-factor one (by hand: A:B with C:D:E). Targets rsm.rs:140
/// (delete field alias_structure).
#[test]
fn a_ccd_on_a_half_fraction_reports_its_aliases() {
    let d = generate(&ccd_req(5, CcdVariant::Circumscribed, CcdAlpha::Rotatable)).unwrap();
    assert_eq!(d.n_runs(), 16 + 10 + 4);
    let ab = d.alias_structure.iter().find(|e| e.term == "A:B").unwrap();
    assert_eq!(ab.aliases, ["C:D:E"]);
    assert_eq!(d.alias_structure.len(), 10);
}

/// A Box–Behnken design of 8 factors (past Box & Behnken's table) is built from all 28 pairs, each a
/// 2² with the others at 0: 112 runs before centre points (by hand). Targets rsm.rs:174 (`+ with */-`).
#[test]
fn a_box_behnken_design_of_eight_factors_has_all_twenty_eight_pairs() {
    let mut req = DesignRequest::new(DesignKind::BoxBehnken, coded(8));
    req.center_points = Some(0);
    req.randomize = false;
    let d = generate(&req).unwrap();
    assert_eq!(d.n_runs(), 112);
    assert!(
        d.runs
            .iter()
            .all(|r| r.coded.iter().filter(|&&c| c != 0.0).count() == 2)
    );
}

/// A design of two factors serialises each run with both factors' actual and coded levels. Targets
/// mod.rs:435 (`+ with -`: the size hint underflows from two factors on).
#[test]
fn a_two_factor_design_serialises_both_factors_of_each_run() {
    let mut req = DesignRequest::new(
        DesignKind::Full,
        FactorSpec::parse_list("a=1:2,tool=x:y").unwrap(),
    );
    req.randomize = false;
    let v = serde_json::to_value(generate(&req).unwrap()).unwrap();
    let run = &v["runs"][3];
    assert_eq!(run["a"], 2.0);
    assert_eq!(run["tool"], "y");
    assert_eq!(run["tool_coded"], 1.0);
    assert_eq!(v["runs"].as_array().unwrap().len(), 4);
}

/// A negative generator `D=-ABC` gives the other half fraction: every run has D = −A·B·C and the
/// defining relation I = −ABCD. Targets factorial.rs:23 (`delete -`).
#[test]
fn a_negative_generator_gives_the_other_half_fraction() {
    let d = fractional(4, |r| r.generators = Some("D=-ABC".into())).unwrap();
    assert_eq!(d.n_runs(), 8);
    assert_eq!(d.defining_relation, ["I=-ABCD"]);
    for r in &d.runs {
        assert_eq!(
            r.coded[3],
            -r.coded[0] * r.coded[1] * r.coded[2],
            "{:?}",
            r.coded
        );
    }
}

/// A mixed-level full factorial lists every combination once: 3 × 2 levels → 6 distinct runs, each
/// level of the 3-level factor twice. Targets factorial.rs:164, 165.
#[test]
fn a_mixed_level_full_factorial_lists_every_combination_once() {
    let mut req = DesignRequest::new(
        DesignKind::Full,
        FactorSpec::parse_list("d=1:2:3,tool=x:y").unwrap(),
    );
    req.randomize = false;
    let d = generate(&req).unwrap();
    let mut rows: Vec<String> = d
        .runs
        .iter()
        .map(|r| format!("{}/{}", r.actual[0], r.actual[1]))
        .collect();
    rows.sort();
    rows.dedup();
    assert_eq!(rows.len(), 6, "{rows:?}");
    for l in [1.0, 2.0, 3.0] {
        assert_eq!(
            d.runs
                .iter()
                .filter(|r| r.actual[0] == Level::Num(l))
                .count(),
            2
        );
    }
}

/// A coded value past the ends of a label factor is its nearest label: −2 → x, +2 → z. Targets
/// factor.rs:295, 297.
#[test]
fn a_coded_value_past_the_ends_of_a_label_factor_is_its_end_label() {
    let m = FactorSpec::parse("tool=x:y:z").unwrap();
    assert_eq!(m.actual(2.0), Level::Label("z".into()));
    assert_eq!(m.actual(-2.0), Level::Label("x".into()));
    assert_eq!(m.actual(-1.0), Level::Label("x".into()));
}
