//! `diagnose` on data as a user has them (issue 15): the failures the issue reports, each as a
//! seeded case, and a few variants drawn from the study's distribution (`synthetic/VARIANTS.md`,
//! development seeds — never the study's). The full study is `examples/real_data_study.rs`
//! (results in `docs/studies/diagnose.md`); these are the small cases that can fail in CI.

use std::sync::OnceLock;

use millcomp_diagnose::{
    DiagnoseOptions, DiagnoseReport, Diagnoser, Measured, Multiplicity, SessionModel,
};
use millcomp_sim::session::Session;
use millcomp_synthetic::variants::{
    DEV_SEED_BASE, Row, SeedBlock, Variant, VariantSpec, draw, normal_draws, row_specs, score,
    study_session,
};

use crate::common::{opts, show};

/// One diagnoser of the study's nominal session for the whole test binary.
fn diagnoser() -> &'static Diagnoser {
    static D: OnceLock<Diagnoser> = OnceLock::new();
    D.get_or_init(|| Diagnoser::new(&study_session(), &opts()).unwrap())
}

/// Measured points of `truth` (a changed copy of the study's nominal session) with a constant
/// depth offset, the given groove offsets and 0.1 µm of profilometer noise (seeded).
fn measure(truth: &Session, offset_um: f64, groove_offsets_um: &[f64], seed: u64) -> Measured {
    let sm = SessionModel::new(truth).unwrap();
    let extra: Vec<f64> = sm
        .points()
        .iter()
        .map(|p| {
            offset_um
                + groove_offsets_um
                    .get(p.groove_id as usize)
                    .copied()
                    .unwrap_or(0.0)
        })
        .collect();
    Measured::new(
        format!("seed {seed}"),
        millcomp_synthetic::resample(
            &sm.points_with(&[]),
            &extra,
            millcomp_synthetic::DEPTH_NOISE_UM,
            seed,
        ),
    )
}

fn run(m: &Measured) -> DiagnoseReport {
    diagnoser().run(m).unwrap()
}

fn assert_none(rep: &DiagnoseReport) {
    assert_eq!(rep.named, vec!["none"], "{}", show(rep));
    // the recalibration took the misfit: what is left is scatter and noise
    assert!(rep.unexplained.is_empty(), "{:?}", rep.unexplained);
}

/// Issue 15: "with nothing hidden but a nominal model that is 5 % off in force scale,
/// flute_runout (p = 6e-189) or tool_wear is named".
#[test]
fn a_force_scale_5_percent_off_is_recalibrated_not_blamed() {
    let mut truth = study_session();
    truth.force_model.force_scale *= 1.05;
    let rep = run(&measure(&truth, 0.0, &[], 9_100_001));
    assert_none(&rep);
    // the deflection moved ≈ 5 %: recalibrating takes the RMS from ~0.5 µm to the noise
    assert!(rep.initial_rms_um > 0.3, "{}", rep.initial_rms_um);
    assert!(rep.nuisance_rms_um < 0.13, "{}", rep.nuisance_rms_um);
}

/// Issue 15: "a wearland of 7 instead of 8 µm names flute_runout + probe_tilt_offset".
#[test]
fn a_wearland_of_7_instead_of_8_um_is_recalibrated() {
    let mut truth = study_session();
    truth.tool.wearland_um = 7.0;
    let rep = run(&measure(&truth, 0.0, &[], 9_100_002));
    assert_none(&rep);
    let wl = rep
        .nuisance
        .params
        .iter()
        .find(|p| p.name == "wearland_um")
        .unwrap();
    assert!(wl.estimate < 0.0, "{wl:?}");
}

/// Issue 15: "per-groove offsets of σ = 0.5 µm (002 reports 52.7 ± 1 µm over 60 grooves) name
/// three effects".
#[test]
fn groove_scatter_is_not_taken_for_an_effect() {
    let offsets = normal_draws(9_100_003, 14, 0.5).unwrap();
    let rep = run(&measure(&study_session(), 0.0, &offsets, 9_100_004));
    assert_none(&rep);
    // σ_g estimated from 14 grooves (pooled with the stated 0.5 µm): within a factor 2
    assert!(
        (0.25..1.0).contains(&rep.scatter.groove_sd_um),
        "{:?}",
        rep.scatter
    );
}

/// A variant of the study's distribution hiding `effects` (development seed `DEV_SEED_BASE + k`)
/// and the report on it.
fn diagnose_variant(effects: Vec<&'static str>, k: u64) -> (Variant, DiagnoseReport) {
    let spec = VariantSpec {
        row: match effects.len() {
            0 => Row::None,
            1 => Row::Single,
            _ => Row::Two,
        },
        effects,
        seed: DEV_SEED_BASE + k,
    };
    let v = draw(&study_session(), &spec).unwrap();
    let rep = run(&Measured::new(
        format!("seed {}", spec.seed),
        v.points.clone(),
    ));
    (v, rep)
}

/// A variant of the study's distribution (development seeds): what it hides is named first.
/// The variant spec of development seed `seed` in `row` (the row's development block: `seed` is
/// its base plus the variant's index).
fn dev_spec(row: Row, seed: u64) -> VariantSpec {
    let base = row.seed_base(SeedBlock::Dev);
    let spec = row_specs(row, 210, base)[(seed - base) as usize].clone();
    assert_eq!(spec.seed, seed);
    spec
}

fn named_first(effects: Vec<&'static str>, k: u64) -> DiagnoseReport {
    let (v, rep) = diagnose_variant(effects, k);
    let hidden: Vec<&str> = v.hidden.iter().map(|h| h.effect).collect();
    let o = score(&hidden, &rep.named);
    assert!(
        o.first_right,
        "hidden {:?} ({:?}) named {:?}\n{}",
        hidden,
        v.hidden.iter().map(|h| h.shape).collect::<Vec<_>>(),
        rep.named,
        show(&rep)
    );
    rep
}

#[test]
fn coolant_drift_of_another_shape_is_named() {
    named_first(vec!["coolant_thermal_drift"], 11);
}

#[test]
fn spindle_growth_of_another_shape_is_named() {
    let rep = named_first(vec!["spindle_thermal_growth"], 12);
    assert_eq!(rep.named, vec!["spindle_thermal_growth"], "{}", show(&rep));
}

#[test]
fn wear_of_another_shape_is_named() {
    named_first(vec!["tool_wear"], 13);
}

#[test]
fn straightness_of_another_shape_is_named() {
    named_first(vec!["slideway_straightness"], 14);
}

#[test]
fn two_effects_of_other_shapes_are_both_named() {
    let rep = named_first(vec!["coolant_thermal_drift", "tool_wear"], 15);
    let mut n = rep.named.clone();
    n.sort();
    assert_eq!(
        n,
        vec!["coolant_thermal_drift", "tool_wear"],
        "{}",
        show(&rep)
    );
}

#[test]
fn nothing_hidden_names_none_after_recalibration() {
    let (_, rep) = diagnose_variant(vec![], 16);
    assert_eq!(rep.named, vec!["none"], "{}", show(&rep));
    assert!(rep.nuisance_rms_um < rep.initial_rms_um);
}

/// A flexible family must not be named for the misfit of a named effect's shape (issue 15: "in
/// five sessions 1–3 spurious effects are added after the right one to soak up the misfit"). A
/// logistic (accelerating) wear, none of the wear family's shapes, leaves a misfit along the
/// engaged length that a straightness cubic in machine X fits significantly (the plan's first
/// grooves move along X as the engaged length grows); it is not significant beyond a flexible
/// shape of the wear in its own driver (a spline in engaged length), so it is not named.
/// Development seed found in the development runs (`docs/studies/diagnose.md`).
#[test]
fn the_misfit_of_a_named_effect_is_not_named_as_another() {
    let (v, rep) = diagnose_variant(vec!["tool_wear"], 31);
    assert_eq!(v.hidden[0].shape, "logistic");
    assert_eq!(rep.named, vec!["tool_wear"], "{}", show(&rep));
    let rejected: Vec<_> = rep
        .rounds
        .iter()
        .flat_map(|r| r.tested.iter().map(move |t| (r.threshold, t)))
        .filter(|(thr, t)| {
            t.effect == "slideway_straightness"
                && t.significant
                && t.beyond_named.is_some_and(|b| b.p_value >= *thr)
        })
        .collect();
    assert!(!rejected.is_empty(), "{}", show(&rep));
}

/// Issue 15: an effect aliased with the nominal model "is named only when it lies beyond the
/// nuisance's prior; otherwise it is reported as 'within the nominal model's uncertainty'". A
/// probe tilt of 3.4 µm with a touch-off error of −0.2 µm moves the touch-off by ≈ 3.2 prior SDs:
/// not beyond the round's threshold, so not named — reported within the nominal model's
/// uncertainty, and the data point to it (p < α). Development seed.
#[test]
fn a_probe_tilt_within_the_touch_off_prior_is_reported_within_the_nominal_uncertainty() {
    let (v, rep) = diagnose_variant(vec!["probe_tilt_offset"], 30);
    assert_eq!(rep.named, vec!["none"], "{}", show(&rep));
    let w = rep
        .within_nominal_uncertainty
        .iter()
        .find(|w| w.effect == "probe_tilt_offset")
        .unwrap();
    assert_eq!(w.status, "within the nominal model's uncertainty");
    assert!(w.note.starts_with("within the nominal model's uncertainty"));
    assert!(w.indicated, "{w:?}");
    let (p, thr) = (w.p_value.unwrap(), w.threshold.unwrap());
    assert!(thr <= p && p < 0.01, "{w:?}");
    assert_eq!(w.nuisance, vec!["touch_off_um"]);
    // the offset it would have: the tilt plus the touch-off error, within the noise
    let truth = 4.67 * v.hidden[0].amplitude_factor + v.errors.touch_off_um;
    assert!(
        (w.params["offset_um"] - truth).abs() < 0.5,
        "{w:?} vs {truth}"
    );
    // the machine compliance, not hidden, is listed too, without the data pointing to it
    let mc = rep
        .within_nominal_uncertainty
        .iter()
        .find(|w| w.effect == "machine_compliance")
        .unwrap();
    assert!(!mc.indicated, "{mc:?}");
}

/// With the tool's stiffness measured by a load–deflection test (the session states 1 % priors,
/// row `measured_stiffness` of VARIANTS.md), a machine compliance is no longer within the nominal
/// model's uncertainty: it is named. With the default 6 % priors the same measured points name it
/// only through what a stiffness change cannot do — the hidden compliance grows faster than the
/// force (`progressive`), which the family's `preload` shape fits — and on far weaker evidence.
/// Development seed.
#[test]
fn a_stated_stiffness_prior_separates_the_machine_compliance() {
    let session = millcomp_synthetic::variants::measured_stiffness_session();
    let spec = VariantSpec {
        row: Row::MeasuredStiffness,
        effects: vec!["machine_compliance"],
        seed: Row::MeasuredStiffness.seed_base(SeedBlock::Dev),
    };
    let v = draw(&session, &spec).unwrap();
    assert_eq!(v.hidden[0].shape, "progressive");
    let tight = Diagnoser::new(&session, &opts()).unwrap();
    let rep = tight.run(&Measured::new("mc", v.points.clone())).unwrap();
    assert_eq!(rep.named, vec!["machine_compliance"], "{}", show(&rep));
    let loose = run(&Measured::new("mc", v.points));
    let p_loose = match loose.named.iter().position(|n| n == "machine_compliance") {
        Some(i) => {
            assert_eq!(loose.steps[i].shape, "preload", "{}", show(&loose));
            loose.steps[i].p_value
        }
        None => {
            assert!(
                loose
                    .within_nominal_uncertainty
                    .iter()
                    .any(|w| w.effect == "machine_compliance"),
                "{}",
                show(&loose)
            );
            1.0
        }
    };
    assert!(
        rep.steps[0].p_value < 1e-3 * p_loose,
        "stated prior p = {:.1e}, default priors p = {p_loose:.1e}",
        rep.steps[0].p_value
    );
}

/// A machine compliance with a dead band (no deflection below a preload force, `VARIANTS.md`) is,
/// on this plan's points, nearly the function of a flute runout whose chip force grows with the
/// depth: the runout's constant shape fits it best and is named (p = 2e-5). The report must not
/// leave it there: the compliance, in a flexible shape of the force, explains the same offsets
/// (the runout is not significant beyond it), so it is listed as the runout's look-alike, with
/// the force trace that would separate them. Development seed.
#[test]
fn a_dead_band_compliance_is_named_or_listed_as_a_look_alike() {
    let (v, rep) = diagnose_variant(vec!["machine_compliance"], 124);
    assert_eq!(v.hidden[0].shape, "deadband");
    let named = rep.named.iter().any(|n| n == "machine_compliance");
    let look_alike = rep
        .look_alikes
        .iter()
        .find(|l| l.other == "machine_compliance");
    assert!(named || look_alike.is_some(), "{}", show(&rep));
    if let Some(l) = look_alike {
        assert!(rep.named.contains(&l.effect));
        assert!(l.p_beyond >= l.threshold, "{l:?}");
        assert!(l.note.contains("--forces"), "{}", l.note);
    }
}

/// A straightness bump is named with no look-alike: nothing else's flexible shape explains a
/// function of machine X on this plan. Development seed.
#[test]
fn a_straightness_bump_has_no_look_alike() {
    let rep = named_first(vec!["slideway_straightness"], 4);
    assert!(rep.look_alikes.is_empty(), "{:?}", rep.look_alikes);
}

/// The study's plan switches the coolant on at a speed change, so a coolant drift hidden beside a
/// spindle growth is taken by the spindle's lags and not named (development seed, two-effect row,
/// k = 126: both at 1.4–1.5× the 002 magnitudes). The same draw on the extended plan — the
/// study's plan with `diagnose`'s eight standard changes appended, the coolant switched with the
/// spindle running among them (`aliasing::extended_session`) — names both.
#[test]
fn the_extended_plan_separates_a_coolant_drift_from_a_spindle_growth() {
    let spec = dev_spec(Row::Two, 9_100_126);
    let mut hidden = spec.effects.clone();
    hidden.sort_unstable();
    assert_eq!(hidden, ["coolant_thermal_drift", "spindle_thermal_growth"]);
    let base = study_session();
    let on_base = run(&Measured::new("base", draw(&base, &spec).unwrap().points));
    assert!(
        on_base.named.iter().any(|n| n == "spindle_thermal_growth")
            && !on_base.named.iter().any(|n| n == "coolant_thermal_drift"),
        "{}",
        show(&on_base)
    );
    let (ext, changes) = millcomp_diagnose::aliasing::extended_session(&base);
    assert!(
        changes.iter().any(|c| c.contains("spindle running")),
        "{changes:?}"
    );
    let on_ext = Diagnoser::new(&ext, &opts())
        .unwrap()
        .run(&Measured::new(
            "extended",
            draw(&ext, &spec).unwrap().points,
        ))
        .unwrap();
    let mut named = on_ext.named.clone();
    named.sort_unstable();
    assert_eq!(named, hidden, "{}", show(&on_ext));
}

/// Each standard change repeats the first groove as it was cut, its coolant too (saying so when
/// that switches the coolant), except after a coolant switch, which the repeated groove keeps. The
/// study's first groove is cut dry and its plan ends with the coolant on: the first version
/// repeated the groove dry after the coolant switches too, so "the coolant switched on for 45 min,
/// then the first groove" switched it off again as the groove started.
#[test]
fn a_change_repeats_the_first_groove_and_keeps_a_coolant_switch() {
    use millcomp_diagnose::aliasing::{CHANGES, Change};
    let base = study_session();
    let base_ctx = base.contexts().unwrap();
    // the premise: the first groove is cut dry and the plan ends with the coolant on
    assert!(!base_ctx.points[0].coolant_on);
    assert!(base.timeline().coolant_events.last().unwrap().1);
    for c in CHANGES {
        let Some((changed, what)) = c.apply(&base) else {
            continue;
        };
        let ctx = changed.contexts().unwrap();
        let last = ctx.points.last().unwrap();
        let groove_start = ctx
            .points
            .iter()
            .find(|p| p.groove_id == last.groove_id)
            .unwrap()
            .t_s;
        let switches_in_groove = ctx
            .timeline
            .coolant_events
            .iter()
            .filter(|e| e.0 >= groove_start - 30.0 && e.0 <= last.t_s)
            .count();
        if matches!(c, Change::CoolantSwitch | Change::CoolantSwitchRunning) {
            // switched off in the pause, and kept off through the groove
            assert!(what.contains("coolant switched off"), "{what}");
            assert!(!last.coolant_on, "{c:?}: {what}");
            assert_eq!(switches_in_groove, 0, "{c:?}: {:?}", ctx.timeline);
        } else {
            // dry, as the first groove was cut, and the description says the coolant is switched
            assert!(!last.coolant_on, "{c:?}: {what}");
            assert_eq!(switches_in_groove, 1, "{c:?}: {:?}", ctx.timeline);
            assert!(
                what.ends_with(
                    "(with the coolant off, as the first groove was cut; it is switched as the groove starts)"
                ),
                "{what}"
            );
        }
    }
    // in the extended plan the two coolant changes each switch the coolant, and stay switched
    let (ext, changes) = millcomp_diagnose::aliasing::extended_session(&base);
    let switched: Vec<&String> = changes
        .iter()
        .filter(|w| w.starts_with("the coolant"))
        .collect();
    assert_eq!(switched.len(), 2);
    assert!(switched[0].contains("switched on") && switched[1].contains("switched off"));
    let ext_ctx = ext.contexts().unwrap();
    let last_of = |g: i64| ext_ctx.points.iter().rfind(|p| p.groove_id == g).unwrap();
    let n_base = base_ctx.points.last().unwrap().groove_id;
    // grooves n+3 and n+4 follow the coolant changes
    let on: Vec<bool> = (n_base + 1..=n_base + 8)
        .map(|g| last_of(g).coolant_on)
        .collect();
    assert_eq!(
        on,
        [false, false, true, false, false, false, false, false],
        "{changes:?}"
    );
}

/// Development seed `seed` of the single row hides a `position_dependent` machine compliance
/// (`VARIANTS.md`: −F/k(X), k(X) = k + (Δk/2)·cos(2πX/P)); `diagnose` names it alone, in the
/// `x_spline` shape.
fn assert_position_dependent_compliance_named_alone(seed: u64) {
    let v = draw(&study_session(), &dev_spec(Row::Single, seed)).unwrap();
    assert_eq!(
        (v.hidden[0].effect, v.hidden[0].shape),
        ("machine_compliance", "position_dependent")
    );
    let rep = run(&Measured::new("position-dependent compliance", v.points));
    assert_eq!(rep.named, ["machine_compliance"], "{}", show(&rep));
    assert_eq!(
        rep.shapes.get("machine_compliance").map(String::as_str),
        Some("x_spline"),
        "{}",
        show(&rep)
    );
}

/// A machine whose stiffness varies along X (development seed 9 000 096, 0.63× the 002 size) was
/// named `slideway_straightness` alone until the sixth round: `x_linear` could not follow it, and
/// the straightness was significant beyond the compliance's driver basis while the compliance was
/// not beyond the straightness's. With the `x_spline` shape, and the basis containing it, the
/// compliance is named, alone, in that shape.
#[test]
fn a_compliance_that_varies_along_x_is_named_compliance_not_straightness() {
    assert_position_dependent_compliance_named_alone(9_000_096);
}

/// Another such machine (development seed 9 000 089, 0.97× the 002 size): until the seventh round
/// the `x_spline` shape had knots at thirds of the X range, while the straightness's `spline` has
/// them at sixths, so what the compliance's spline could not follow of k(X) was named
/// `slideway_straightness`, first, beside it. With the compliance's spline as flexible along X as
/// the straightness's, the compliance is named alone.
#[test]
fn a_compliance_as_flexible_along_x_as_the_straightness_leaves_it_no_residue() {
    assert_position_dependent_compliance_named_alone(9_000_089);
}

/// A coolant drift with a wear that sets in late (development seed 9 100 149: `VARIANTS.md`'s
/// `logistic` wear) on the extended plan. None of the wear's parametric shapes has a late onset:
/// until the eighth round a straightness cubic took the wear's rise within the grooves, the
/// coolant's lags the rest, and the wear was not significant beyond both. With a non-decreasing
/// spline among the wear's shapes — the "wear monotone in cut length", of any onset — both
/// are named, and nothing else.
#[test]
fn a_wear_that_sets_in_late_is_named_wear_not_straightness() {
    let spec = dev_spec(Row::Two, 9_100_149);
    let mut hidden = spec.effects.clone();
    hidden.sort_unstable();
    assert_eq!(hidden, ["coolant_thermal_drift", "tool_wear"]);
    let (ext, _) = millcomp_diagnose::aliasing::extended_session(&study_session());
    let v = draw(&ext, &spec).unwrap();
    assert!(v.hidden.iter().any(|h| h.shape == "logistic"));
    let rep = Diagnoser::new(&ext, &opts())
        .unwrap()
        .run(&Measured::new("extended", v.points))
        .unwrap();
    let mut named = rep.named.clone();
    named.sort_unstable();
    assert_eq!(named, hidden, "{}", show(&rep));
}

/// A candidate's fit in a later round extends the model of the round before, so it cannot fit
/// worse. On development seeds 9 000 014 (single row: coolant drift) five of the six candidates of
/// round 2 once ended at a NaN residual, and on 9 100 084 (two: coolant drift and spindle growth)
/// the coolant drift at an RMS of 5.9e8 µm — the linearised start had sent a named effect's time
/// constant where the trust region could not come back from — so they were not tested (p = 1).
/// Now such a fit is repeated from the model it extends.
#[test]
fn a_later_rounds_candidate_never_fits_worse_than_the_model_it_extends() {
    for (row, seed) in [(Row::Single, 9_000_014), (Row::Two, 9_100_084)] {
        let spec = dev_spec(row, seed);
        let v = draw(&study_session(), &spec).unwrap();
        let rep = run(&Measured::new(format!("seed {}", spec.seed), v.points));
        assert!(rep.rounds.len() >= 2, "{}", show(&rep));
        for (i, round) in rep.rounds.iter().enumerate() {
            for t in &round.tested {
                assert!(
                    t.rms_after_um.is_finite() && t.rms_after_um <= rep.nuisance_rms_um,
                    "seed {} round {i}: {} ({}) rms {} against {} after the nuisance step",
                    spec.seed,
                    t.effect,
                    t.shape,
                    t.rms_after_um,
                    rep.nuisance_rms_um
                );
            }
        }
    }
}

/// Ninth round (`docs/studies/diagnose.md`, "Each round's threshold"): each round's threshold is the level made exact for that round
/// (simulated), not Bonferroni's bound over the 22 shapes. Development seed 9 100 130 hides a
/// coolant drift and a machine compliance: after the coolant drift, the compliance's test beyond
/// the coolant drift's flexible shapes (p = 1.4e-3) lies between Bonferroni's threshold and the
/// simulated one, so Bonferroni's rule names the coolant drift alone and the simulated one both. The threshold is reproducible (seeded draws) and lies between
/// Bonferroni's and α.
#[test]
fn a_second_effect_bonferroni_spent_the_level_on_is_named() {
    let spec = dev_spec(Row::Two, 9_100_130);
    let v = draw(&study_session(), &spec).unwrap();
    let m = Measured::new(format!("seed {}", spec.seed), v.points);
    let rep = run(&m);
    let mut named = rep.named.clone();
    named.sort();
    assert_eq!(
        named,
        ["coolant_thermal_drift", "machine_compliance"],
        "{}",
        show(&rep)
    );
    for r in &rep.rounds {
        assert!(
            r.threshold > r.bonferroni_threshold && r.threshold < rep.alpha,
            "{} {}",
            r.threshold,
            r.bonferroni_threshold
        );
    }
    let again = run(&m);
    let thresholds = |r: &DiagnoseReport| r.rounds.iter().map(|x| x.threshold).collect::<Vec<_>>();
    assert_eq!(thresholds(&rep), thresholds(&again));

    let bonferroni = Diagnoser::new(
        &study_session(),
        &DiagnoseOptions {
            multiplicity: Multiplicity::Bonferroni,
            ..opts()
        },
    )
    .unwrap()
    .run(&m)
    .unwrap();
    assert_eq!(
        bonferroni.named,
        ["coolant_thermal_drift"],
        "{}",
        show(&bonferroni)
    );
    let beyond = bonferroni.rounds[1]
        .tested
        .iter()
        .find(|t| t.effect == "machine_compliance")
        .and_then(|t| t.beyond_named)
        .unwrap()
        .p_value;
    assert!(
        beyond > bonferroni.rounds[1].threshold && beyond < rep.rounds[1].threshold,
        "{beyond} not between {} and {}",
        bonferroni.rounds[1].threshold,
        rep.rounds[1].threshold
    );
}
