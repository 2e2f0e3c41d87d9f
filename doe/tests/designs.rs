//! Response-surface, screening, space-filling and optimal designs; the JSON contract of `doe design`.

use crate::common::*;
use millcomp_doe::{
    CcdAlpha, CcdVariant, DesignKind, DesignRequest, FactorSpec, Level, LinearConstraint,
    ModelSpec, Values, generate,
};

fn sorted_points(mut p: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    for r in p.iter_mut() {
        for v in r.iter_mut() {
            *v = (*v * 1e9).round() / 1e9;
        }
    }
    p.sort_by(|a, b| a.partial_cmp(b).unwrap());
    p
}

fn letters(k: usize) -> Vec<FactorSpec> {
    (0..k)
        .map(|i| FactorSpec::coded(&millcomp_doe::factor_letter(i)))
        .collect()
}

#[test]
fn ccd_matches_pydoe3_ccdesign() {
    // pyDOE3 1.6.2 ccdesign(k, center=(4, 4), alpha='o'|'r', face='ccc'): its 'orthogonal' is the
    // orthogonal-blocking α with 4 centre runs in the factorial and 4 in the axial block.
    let g = golden("rsm.json");
    for e in g["ccd"].as_array().unwrap() {
        let k = e["k"].as_u64().unwrap() as usize;
        let alpha = if e["alpha_rule"] == "o" {
            CcdAlpha::OrthogonalBlocking
        } else {
            CcdAlpha::Rotatable
        };
        let mut r = DesignRequest::new(
            DesignKind::Ccd {
                variant: CcdVariant::Circumscribed,
                alpha,
            },
            letters(k),
        );
        r.blocks = if alpha == CcdAlpha::OrthogonalBlocking {
            2
        } else {
            1
        };
        r.center_points = Some(if r.blocks == 2 { 4 } else { 8 });
        r.seed = Some(5);
        let d = generate(&r).unwrap();
        assert!(
            (d.alpha.unwrap() - e["alpha"].as_f64().unwrap()).abs() < 1e-12,
            "k={k} {}",
            e["alpha_rule"]
        );
        let want: Vec<Vec<f64>> = e["points"].as_array().unwrap().iter().map(f64s).collect();
        assert_eq!(
            sorted_points(d.coded_matrix()),
            sorted_points(want),
            "k={k}"
        );
    }
}

#[test]
fn box_behnken_matches_pydoe3_bbdesign() {
    let g = golden("rsm.json");
    for e in g["bbd"].as_array().unwrap() {
        let k = e["k"].as_u64().unwrap() as usize;
        let mut r = DesignRequest::new(DesignKind::BoxBehnken, letters(k));
        r.center_points = Some(3);
        r.seed = Some(5);
        let d = generate(&r).unwrap();
        let want: Vec<Vec<f64>> = e["points"].as_array().unwrap().iter().map(f64s).collect();
        assert_eq!(
            sorted_points(d.coded_matrix()),
            sorted_points(want),
            "k={k}"
        );
    }
    // k = 6 (Box & Behnken 1960): 48 runs + centre points, each factor at ±1 in 24 runs.
    let mut r = DesignRequest::new(DesignKind::BoxBehnken, letters(6));
    r.center_points = Some(6);
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 54);
    for j in 0..6 {
        assert_eq!(d.runs.iter().filter(|r| r.coded[j] != 0.0).count(), 24);
    }
}

#[test]
fn orthogonal_ccd_has_orthogonal_quadratic_columns() {
    // Box & Hunter (1957): with α = √((√(N·n_F) − n_F)/2) the centred square columns are orthogonal.
    for (k, c) in [(2usize, 4usize), (3, 6), (4, 3), (5, 6)] {
        let mut r = DesignRequest::new(
            DesignKind::Ccd {
                variant: CcdVariant::Circumscribed,
                alpha: CcdAlpha::Orthogonal,
            },
            letters(k),
        );
        r.center_points = Some(c);
        let d = generate(&r).unwrap();
        let n = d.n_runs() as f64;
        let sq: Vec<Vec<f64>> = (0..k)
            .map(|j| d.runs.iter().map(|r| r.coded[j] * r.coded[j]).collect())
            .collect();
        let centred: Vec<Vec<f64>> = sq
            .iter()
            .map(|c| {
                let m = c.iter().sum::<f64>() / n;
                c.iter().map(|v| v - m).collect()
            })
            .collect();
        let dot: f64 = centred[0].iter().zip(&centred[1]).map(|(a, b)| a * b).sum();
        assert!(dot.abs() < 1e-9, "k={k}: {dot}");
    }
    // k = 5 uses the 2^(5-1)_V half fraction: 16 + 10 + centre runs.
    let mut r = DesignRequest::new(
        DesignKind::Ccd {
            variant: CcdVariant::FaceCentred,
            alpha: CcdAlpha::Rotatable,
        },
        letters(5),
    );
    r.center_points = Some(1);
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 27);
    assert_eq!(d.generators, vec!["E=ABCD"]);
    assert_eq!(d.alpha, Some(1.0));
}

#[test]
fn inscribed_ccd_stays_inside_the_given_range() {
    let f = FactorSpec::parse_list("depth_um=100:200,upfeed_um=10:20").unwrap();
    let mut r = DesignRequest::new(
        DesignKind::Ccd {
            variant: CcdVariant::Inscribed,
            alpha: CcdAlpha::Rotatable,
        },
        f,
    );
    r.center_points = Some(2);
    let d = generate(&r).unwrap();
    for run in &d.runs {
        let Level::Num(dep) = run.actual[0] else {
            panic!()
        };
        assert!((100.0 - 1e-9..=200.0 + 1e-9).contains(&dep));
    }
    // Axial points at the given low/high; factorial points at mid ± half/α (α = √2 for k = 2).
    assert!(d.runs.iter().any(|r| r.actual[0] == Level::Num(200.0)));
    let inner = 150.0 + 50.0 / 2f64.sqrt();
    assert!(
        d.runs
            .iter()
            .any(|r| matches!(r.actual[0], Level::Num(v) if (v - inner).abs() < 1e-9))
    );
}

#[test]
fn latin_hypercube_is_a_maximin_lhs() {
    let f =
        FactorSpec::parse_list("depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20").unwrap();
    let mut r = DesignRequest::new(DesignKind::Lhs, f);
    r.runs = Some(12);
    r.seed = Some(42);
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 12);
    for j in 0..3 {
        let mut c: Vec<f64> = d.runs.iter().map(|r| r.coded[j]).collect();
        c.sort_by(f64::total_cmp);
        for (i, v) in c.iter().enumerate() {
            assert!(
                (v - (-1.0 + (2 * i + 1) as f64 / 12.0)).abs() < 1e-12,
                "one run per stratum"
            );
        }
    }
    let dmin = d.criteria.min_distance.unwrap();
    // A random LHS of 12 runs in 3-D typically has a min distance ≈ 0.3–0.5 (coded); maximin does better.
    assert!(dmin > 0.6, "min distance {dmin}");
    let again = generate(&r).unwrap();
    assert_eq!(again.coded_matrix(), d.coded_matrix());
}

#[test]
fn d_optimal_unconstrained_finds_an_orthogonal_design() {
    // Main effects of 3 two-level factors in 8 runs: the 2^3 (D-efficiency 100 %) is D-optimal.
    let mut r = DesignRequest::new(DesignKind::DOptimal, letters(3));
    r.model = Some(ModelSpec::Main);
    r.runs = Some(8);
    r.seed = Some(9);
    let d = generate(&r).unwrap();
    assert!((d.criteria.d_efficiency_pct.unwrap() - 100.0).abs() < 1e-9);
    assert!((d.criteria.log_det_xtx.unwrap() - 4.0 * 8f64.ln()).abs() < 1e-9);
}

#[test]
fn d_optimal_respects_linear_constraints() {
    let f = FactorSpec::parse_list("depth_um=100:200,upfeed_um=10:20").unwrap();
    let c = LinearConstraint::parse_list("depth_um + upfeed_um <= 1", &f).unwrap();
    let mut r = DesignRequest::new(DesignKind::DOptimal, f);
    r.constraints = c.clone();
    r.runs = Some(10);
    r.seed = Some(4);
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 10);
    for run in &d.runs {
        assert!(c[0].satisfied(&run.coded), "{:?}", run.coded);
    }
    // The quadratic model (6 coefficients) is estimable: finite log det.
    assert!(d.criteria.log_det_xtx.unwrap().is_finite());
    // The corner (+1, +1) is cut off; (+1, 0) and (0, +1) are on the constraint and should be used.
    assert!(d.runs.iter().any(|r| r.coded == vec![1.0, 0.0]));
    assert!(d.runs.iter().any(|r| r.coded == vec![0.0, 1.0]));
}

#[test]
fn plackett_burman_12_runs() {
    let mut r = DesignRequest::new(DesignKind::PlackettBurman, letters(11));
    r.randomize = false;
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 12);
    // Plackett & Burman (1946) N = 12 generating row + + − + + + − − − + −, then cyclic shifts; last row all −.
    let first: Vec<f64> = d.runs[0].coded.clone();
    assert_eq!(first, vec![1., 1., -1., 1., 1., 1., -1., -1., -1., 1., -1.]);
    assert!(d.runs[11].coded.iter().all(|v| *v == -1.0));
    assert_eq!(d.resolution, None);
}

#[test]
fn mixed_level_full_factorial_with_labels_and_json_contract() {
    let f = FactorSpec::parse_list("material=S7:1018:6061,depth_um=100:200").unwrap();
    let mut r = DesignRequest::new(DesignKind::Full, f);
    r.replicates = 2;
    r.seed = Some(1);
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 12);
    assert_eq!(d.resolution, None);
    let j = serde_json::to_value(&d).unwrap();
    for key in [
        "design",
        "n_runs",
        "factors",
        "resolution",
        "generators",
        "alias_structure",
        "runs",
    ] {
        assert!(j.get(key).is_some(), "missing key {key}");
    }
    assert_eq!(j["design"], "full");
    assert_eq!(j["n_runs"], 12);
    assert!(j["resolution"].is_null());
    let run = &j["runs"][0];
    for key in [
        "std_order",
        "run_order",
        "block",
        "material",
        "material_coded",
        "depth_um",
        "depth_um_coded",
    ] {
        assert!(run.get(key).is_some(), "run missing {key}");
    }
    assert!(run["material"].is_string() && run["depth_um"].is_number());
    // Each label appears 4 times (2 depths × 2 replicates).
    let cols = d.columns();
    let Values::Str(m) = &cols.iter().find(|(n, _)| n == "material").unwrap().1 else {
        panic!()
    };
    for l in ["S7", "1018", "6061"] {
        assert_eq!(m.iter().filter(|v| v.as_str() == l).count(), 4);
    }
    assert_eq!(cols[1].0, "run_order");
    let Values::I64(ro) = &cols[1].1 else {
        panic!()
    };
    assert_eq!(ro, &(1..=12).collect::<Vec<i64>>());
}

#[test]
fn thesis_design_table_3_2() {
    // Seed 000 Table 3-2: depth 100/200 µm, upfeed 10/20 µm/rev, speed 10 000/20 000 rpm → 2³ = 8 runs.
    let f =
        FactorSpec::parse_list("depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20").unwrap();
    let mut r = DesignRequest::new(DesignKind::Full, f);
    r.center_points = Some(2);
    r.seed = Some(3);
    let d = generate(&r).unwrap();
    assert_eq!(d.n_runs(), 10);
    let centres = d
        .runs
        .iter()
        .filter(|r| r.coded.iter().all(|c| *c == 0.0))
        .count();
    assert_eq!(centres, 2);
    let c = d.runs.iter().find(|r| r.coded[0] == 0.0).unwrap();
    assert_eq!(
        c.actual,
        vec![Level::Num(150.0), Level::Num(15000.0), Level::Num(15.0)]
    );
}
