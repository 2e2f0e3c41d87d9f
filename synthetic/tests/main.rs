//! The generator against the committed files of `datasets/synthetic/` (one integration-test binary).

use std::path::PathBuf;

use millcomp_sim::session::Session;

/// `datasets/synthetic/` of the workspace.
fn synthetic_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../datasets/synthetic")
}

#[test]
fn session_toml_round_trips() {
    let c = millcomp_synthetic::cases()
        .into_iter()
        .find(|c| c.name == "clean")
        .unwrap();
    let d = millcomp_synthetic::generate(&c).unwrap();
    let back = Session::from_toml_str(&d.session_toml).unwrap();
    assert_eq!(back, d.session);
    // the common plan: 14 grooves × 21 points (crate documentation)
    assert_eq!(d.points.len(), 294);
}

#[test]
fn committed_files_are_up_to_date() {
    let dir = synthetic_dir();
    let cases = millcomp_synthetic::cases();
    for c in &cases {
        let d = millcomp_synthetic::generate(c).unwrap();
        let files = d.files().unwrap();
        assert_eq!(files.len(), if c.force_trace { 3 } else { 2 }, "{}", c.name);
        for (name, text) in files {
            let committed = std::fs::read_to_string(dir.join(&name)).unwrap();
            assert!(
                committed == text,
                "{name} differs from the generator: rerun gen_synthetic"
            );
        }
    }
    let mut drawn = Vec::new();
    for v in millcomp_synthetic::variants::committed_variants() {
        let (data, variant) = millcomp_synthetic::committed_variant_data(&v).unwrap();
        for (name, text) in data.files().unwrap() {
            let committed = std::fs::read_to_string(dir.join(&name)).unwrap();
            assert!(
                committed == text,
                "{name} differs from the generator: rerun gen_synthetic"
            );
        }
        drawn.push((v, variant));
    }
    for (name, text) in millcomp_synthetic::cannot_separate_case()
        .unwrap()
        .files()
        .unwrap()
    {
        let committed = std::fs::read_to_string(dir.join(&name)).unwrap();
        assert!(
            committed == text,
            "{name} differs from the generator: rerun gen_synthetic"
        );
    }
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap();
    assert_eq!(readme, millcomp_synthetic::readme(&cases, &drawn));
}

mod variants {
    //! The variant generator of the study (`synthetic/VARIANTS.md`): seeded, stratified, and each
    //! shape scaled to its stated magnitude.

    use millcomp_synthetic::variants::{
        DEV_SEED_BASE, EFFECTS, Row, VariantSpec, draw, reference_magnitude, row_specs,
        study_session,
    };

    #[test]
    fn rows_are_stratified_and_seeded() {
        let single = row_specs(Row::Single, 14, Row::Single.study_seed_base());
        assert_eq!(single[9].effects, vec![EFFECTS[2]]);
        assert_eq!(single[9].seed, 1_000_009);
        let two = row_specs(Row::Two, 21, 0);
        let mut pairs: Vec<_> = two.iter().map(|s| s.effects.clone()).collect();
        pairs.dedup();
        assert_eq!(pairs.len(), 21);
        assert!(two.iter().all(|s| s.effects[0] != s.effects[1]));
        let s = study_session();
        let spec = VariantSpec {
            row: Row::Two,
            effects: vec!["tool_wear", "coolant_thermal_drift"],
            seed: DEV_SEED_BASE + 1,
        };
        let a = draw(&s, &spec).unwrap();
        assert_eq!(a.points, draw(&s, &spec).unwrap().points);
        let b = draw(
            &s,
            &VariantSpec {
                seed: DEV_SEED_BASE + 2,
                ..spec.clone()
            },
        )
        .unwrap();
        assert_ne!(a.points, b.points);
        assert_eq!(a.groove_offsets_um.len(), 14);
    }

    /// Every non-candidate shape, over many seeds: amplitude factor in [0.5, 2], and the stated
    /// magnitude where VARIANTS.md states one (wear at the end of the session, straightness's
    /// largest deviation and zero at the start of the X range, coolant at 45 min).
    #[test]
    fn shapes_have_their_stated_magnitudes() {
        let s = study_session();
        let ctx = s.contexts().unwrap();
        let end = ctx
            .points
            .iter()
            .map(|p| p.cut_length_mm)
            .fold(0.0, f64::max);
        let mut shapes = std::collections::BTreeSet::new();
        for k in 0..63u64 {
            let e = EFFECTS[(k % 7) as usize];
            let v = draw(
                &s,
                &VariantSpec {
                    row: Row::Single,
                    effects: vec![e],
                    seed: DEV_SEED_BASE + 1000 + k,
                },
            )
            .unwrap();
            let h = &v.hidden[0];
            shapes.insert((h.effect, h.shape));
            assert!((0.5..=2.0).contains(&h.amplitude_factor));
            let m = reference_magnitude(e) * h.amplitude_factor;
            let o = &v.hidden_offsets_um[0];
            match e {
                "tool_wear" => {
                    // the last point is at the session's final engaged length
                    let last = ctx
                        .points
                        .iter()
                        .position(|p| p.cut_length_mm == end)
                        .unwrap();
                    assert!((o[last] + m).abs() < 1e-9 * m, "{} {}", h.shape, o[last]);
                }
                "slideway_straightness" => {
                    let peak = o.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                    assert!((peak - m).abs() < 1e-9 * m, "{}", h.shape);
                    // zero at the start of the X range (groove 0 starts at X = 0)
                    assert!(o[0].abs() < 1e-12, "{} {}", h.shape, o[0]);
                }
                "probe_tilt_offset" => {
                    assert!(o.iter().all(|v| (v - m).abs() < 1e-9 * m));
                }
                _ => {}
            }
            // never one of diagnose's family shapes (probe tilt's constant is the documented
            // exception)
            if e != "probe_tilt_offset" {
                assert!(
                    ![
                        "one_lag",
                        "two_lag",
                        "onset_one_lag",
                        "saturating",
                        "power_law",
                        "bow",
                        "runout"
                    ]
                    .contains(&h.shape),
                    "{}",
                    h.shape
                );
            }
        }
        // three shapes per effect (one for the constant)
        assert_eq!(shapes.len(), 6 * 3 + 1, "{shapes:?}");
    }

    /// The seed blocks do not overlap (variant k < 500 000 of every row and block), the four
    /// version-1 rows keep their study seeds, and the `measured_stiffness` row draws the truth's
    /// stiffness within its stated 1 % prior (± √3 %) and hides machine compliance in every
    /// other variant (VARIANTS.md, "Seeds" and "Row `measured_stiffness`").
    #[test]
    fn seed_blocks_and_the_measured_stiffness_row() {
        use millcomp_synthetic::variants::{SeedBlock, measured_stiffness_session};
        let rows = [
            Row::Single,
            Row::Two,
            Row::None,
            Row::Matched,
            Row::MeasuredStiffness,
        ];
        let mut starts: Vec<u64> = rows
            .iter()
            .flat_map(|r| {
                [
                    SeedBlock::Study,
                    SeedBlock::Fresh,
                    SeedBlock::Third,
                    SeedBlock::Fifth,
                    SeedBlock::Sixth,
                    SeedBlock::Seventh,
                    SeedBlock::Eighth,
                    SeedBlock::Ninth,
                    SeedBlock::Dev,
                ]
                .map(|b| r.seed_base(b))
            })
            .collect();
        assert_eq!(Row::Single.study_seed_base(), 1_000_000);
        assert_eq!(Row::Matched.seed_base(SeedBlock::Study), 4_000_000);
        assert_eq!(Row::Single.seed_base(SeedBlock::Fresh), 5_000_000);
        assert_eq!(Row::Single.seed_base(SeedBlock::Third), 11_000_000);
        assert_eq!(
            Row::MeasuredStiffness.seed_base(SeedBlock::Fifth),
            18_500_000
        );
        assert_eq!(
            Row::MeasuredStiffness.seed_base(SeedBlock::Sixth),
            22_500_000
        );
        assert_eq!(Row::Single.seed_base(SeedBlock::Seventh), 23_000_000);
        assert_eq!(
            Row::MeasuredStiffness.seed_base(SeedBlock::Seventh),
            26_500_000
        );
        assert_eq!(Row::Single.seed_base(SeedBlock::Eighth), 27_000_000);
        assert_eq!(Row::Single.seed_base(SeedBlock::Ninth), 31_000_000);
        assert_eq!(
            Row::MeasuredStiffness.seed_base(SeedBlock::Ninth),
            34_500_000
        );
        starts.sort_unstable();
        for w in starts.windows(2) {
            assert!(w[1] - w[0] >= 100_000, "{starts:?}");
        }
        let s = measured_stiffness_session();
        assert_eq!(s.uncertainty.axial_stiffness_pct, 1.0);
        assert_eq!(s.uncertainty.radial_stiffness_pct, 1.0);
        let specs = row_specs(Row::MeasuredStiffness, 40, DEV_SEED_BASE + 7_000);
        for (k, spec) in specs.iter().enumerate() {
            let hides: Vec<&str> = if k % 2 == 0 {
                vec!["machine_compliance"]
            } else {
                vec![]
            };
            assert_eq!(spec.effects, hides);
            let v = draw(&s, spec).unwrap();
            for f in [
                v.errors.axial_stiffness_factor,
                v.errors.radial_stiffness_factor,
            ] {
                assert!((f - 1.0).abs() <= 0.01 * 3f64.sqrt(), "{f}");
            }
        }
        // the version-1 rows draw what they drew: the stiffness range is still ± 10 %
        assert_eq!(Row::Single.stiffness_range(), 0.10);
    }
}
