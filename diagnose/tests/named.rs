//! `diagnose` on the committed synthetic sessions of `datasets/synthetic/` (issue 7's cases: the
//! nominal model exact, white profilometer noise, the effects in sim's own forms): every
//! single-effect session names its hidden effect in its family's reference shape, whose 95 %
//! intervals cover the truth, and the RMS shrinks by ≥ 50 % — except `machine_compliance`, which is
//! aliased with the stiffness nuisance (issue 15) and is reported within the nominal model's
//! uncertainty; the two-effect session names both; `clean` names `none`; the robustness variants
//! name the right effect first; the force trace names `flute_runout`. Truth values come from
//! `millcomp_synthetic::cases()` (each citing its seed section) — the generator of the committed
//! files, which the synthetic crate's `committed_files_are_up_to_date` checks.

use millcomp_diagnose::{DiagnoseReport, diagnose, families};
use millcomp_synthetic::SyntheticCase;

use crate::common::{
    NOISE_RMS_MAX_UM, RMS_SHRINK, case, load_case, measured_of, opts, show, truth_in_family,
};

fn run(name: &str) -> DiagnoseReport {
    let (s, m) = load_case(name);
    diagnose(&s, &m, &opts()).unwrap()
}

/// Committed (seed-fixed) intervals that miss the truth. A 95 % interval misses 1 time in 20; the
/// seeds were fixed before the first run (7001 + case index) and are not re-drawn to hide a miss:
/// the miss must be a chance one — within 3 standard errors — and the coverage over many seeds is
/// the study's (`examples/real_data_study.rs`, row `matched`, docs/studies/diagnose.md).
const KNOWN_MISSES: [(&str, &str); 1] = [("slideway_straightness", "amplitude_um")];

/// Every parameter of every hidden effect fitted in its family's reference shape: the final joint
/// 95 % interval covers the truth.
fn assert_covers(rep: &DiagnoseReport, c: &SyntheticCase) {
    let fams = families::standard();
    for h in &c.hidden {
        let reference = fams.iter().find(|f| f.name == h.expect).unwrap().shapes[0].name;
        assert_eq!(rep.shapes[h.expect], reference, "{}: {}", c.name, show(rep));
        let ci = &rep.final_ci95[h.expect];
        for (name, t) in truth_in_family(h) {
            let iv = ci[name];
            if KNOWN_MISSES.contains(&(c.name.as_str(), name)) {
                let est = rep.final_params[h.expect][name];
                // the interval is ± t·SE with t ≈ 2
                let se = (iv[1] - iv[0]) / 4.0;
                assert!(
                    (est - t).abs() <= 3.0 * se,
                    "{}: {name} is {} SE off",
                    c.name,
                    (est - t) / se
                );
                continue;
            }
            assert!(
                iv[0] <= t && t <= iv[1],
                "{}: {}.{name} truth {t} outside 95 % interval {iv:?} (estimate {})",
                c.name,
                h.expect,
                rep.final_params[h.expect][name]
            );
        }
    }
}

fn single(name: &str) {
    let c = case(name);
    let rep = run(name);
    assert_eq!(
        rep.named,
        vec![c.hidden[0].expect.to_string()],
        "{}",
        show(&rep)
    );
    assert_eq!(rep.verdict, "named");
    assert_covers(&rep, &c);
    // the nominal model is exact here: the shrink from the nominal RMS (the flute runout is
    // nearly aliased with a force-scale change, so the nuisance step already takes most of it)
    assert!(
        rep.final_rms_um <= RMS_SHRINK * rep.initial_rms_um,
        "{name}: RMS {} -> {}",
        rep.initial_rms_um,
        rep.final_rms_um
    );
    assert!(
        rep.final_rms_um <= NOISE_RMS_MAX_UM,
        "{name}: {}",
        rep.final_rms_um
    );
    let st = &rep.steps[0];
    assert!(st.p_value < st.threshold);
    assert!(st.logo.after < st.logo.before || st.beyond_prior);
}

#[test]
fn coolant_thermal_drift_is_named() {
    single("coolant_thermal_drift");
}

#[test]
fn spindle_thermal_growth_is_named() {
    single("spindle_thermal_growth");
}

#[test]
fn probe_tilt_offset_is_named_beyond_the_touch_off_prior() {
    single("probe_tilt_offset");
    let rep = run("probe_tilt_offset");
    // a constant is the touch-off's (prior 1 µm): the evidence is the prior's, and 4.67 µm lies
    // beyond it
    assert!(rep.steps[0].beyond_prior, "{}", show(&rep));
}

#[test]
fn tool_wear_is_named() {
    single("tool_wear");
}

#[test]
fn slideway_straightness_is_named() {
    single("slideway_straightness");
}

#[test]
fn flute_runout_is_named_from_depth() {
    single("flute_runout");
}

#[test]
fn machine_compliance_is_within_the_nominal_models_uncertainty() {
    // k_M = 10 N/µm adds 0.1 µm/N at every tilt = a change of both tool stiffnesses
    // (c_M·(cos²α + sin²α)); with 6 % priors on each it is not beyond them
    let rep = run("machine_compliance");
    assert!(
        !rep.named.contains(&"machine_compliance".to_string()),
        "{}",
        show(&rep)
    );
    let w = rep
        .within_nominal_uncertainty
        .iter()
        .find(|w| w.effect == "machine_compliance")
        .unwrap_or_else(|| panic!("{}", show(&rep)));
    assert!(w.nuisance.iter().any(|n| n.contains("stiffness")), "{w:?}");
    // the nuisance step absorbs it: RMS down to the noise
    assert!(
        rep.nuisance_rms_um <= NOISE_RMS_MAX_UM,
        "{}",
        rep.nuisance_rms_um
    );
    let pair = rep
        .aliasing
        .iter()
        .find(|a| a.a == "machine_compliance")
        .unwrap();
    assert!(pair.note.contains("load–deflection"), "{}", pair.note);
}

#[test]
fn two_effect_session_names_both() {
    let name = "coolant_thermal_drift+tool_wear";
    let c = case(name);
    let rep = run(name);
    let mut named = rep.named.clone();
    named.sort();
    assert_eq!(
        named,
        vec!["coolant_thermal_drift", "tool_wear"],
        "{}",
        show(&rep)
    );
    assert_covers(&rep, &c);
    assert!(rep.final_rms_um <= RMS_SHRINK * rep.nuisance_rms_um);
    assert!(rep.final_rms_um <= NOISE_RMS_MAX_UM);
    for s in rep.steps.iter().filter(|s| s.kept) {
        assert!(s.rms_after_um < s.rms_before_um);
    }
}

#[test]
fn clean_session_names_none() {
    let rep = run("clean");
    assert_eq!(rep.named, vec!["none"], "{}", show(&rep));
    assert_eq!(rep.verdict, "none");
    assert!(rep.steps.is_empty());
    // the final refit weighs by the scatter as estimated, the selection by at most the stated one
    assert!((rep.final_rms_um - rep.nuisance_rms_um).abs() < 1e-3 * rep.nuisance_rms_um);
    assert_eq!(rep.rounds.len(), 1);
    assert_eq!(rep.rounds[0].tested.len(), 7);
    assert!(rep.rounds[0].tested.iter().all(|d| d.decision != "added"));
    // the nominal model is exact: every nuisance estimate within 2 prior SDs of 0
    for p in &rep.nuisance.params {
        assert!(p.z_prior.abs() < 2.0, "{p:?}");
    }
    let v = serde_json::to_value(&rep).unwrap();
    assert_eq!(v["named"], serde_json::json!(["none"]));
}

fn robust(name: &str) {
    let c = case(name);
    let rep = run(name);
    assert_eq!(rep.named[0], c.hidden[0].expect, "{}", show(&rep));
    assert!(
        rep.steps[0].rms_after_um <= RMS_SHRINK * rep.nuisance_rms_um,
        "{name}: first step RMS {} -> {}",
        rep.nuisance_rms_um,
        rep.steps[0].rms_after_um
    );
}

#[test]
fn robust_two_time_constant_growth_names_spindle_growth_first() {
    robust("robust_spindle_thermal_growth_two_tau");
}

#[test]
fn robust_power_law_wear_names_tool_wear_first() {
    robust("robust_tool_wear_power_law");
}

#[test]
fn robust_skewed_straightness_names_straightness_first() {
    robust("robust_slideway_straightness_skewed");
}

#[test]
fn force_trace_names_flute_runout() {
    let c = case("flute_runout_force");
    let rep = run("flute_runout_force");
    let fc = rep.force_channel.as_ref().expect("force channel");
    assert_eq!(fc.n_rows, 294);
    assert_eq!(fc.steps.len(), 1);
    let st = &fc.steps[0];
    assert_eq!(st.effect, "flute_runout");
    assert!(st.p_value < crate::common::ALPHA);
    // truth: 3 µm extra runout (synthetic case, 000 §4 runout as % of upfeed)
    let truth = c.hidden[0].params()[0].1;
    let ci = st.ci95["runout_um"];
    assert!(ci[0] <= truth && truth <= ci[1], "{ci:?}");
    assert!(st.rms_after_n <= RMS_SHRINK * st.rms_before_n);
    assert!(rep.named.contains(&"flute_runout".to_string()));
}

#[test]
fn clean_force_trace_names_nothing_on_the_force_channel() {
    let mut c = case("flute_runout_force");
    c.hidden.clear();
    let d = millcomp_synthetic::generate(&c).unwrap();
    let rep = diagnose(&d.session, &measured_of(&d), &opts()).unwrap();
    let fc = rep.force_channel.unwrap();
    assert!(fc.steps.is_empty(), "{:?}", fc.tested);
    assert_eq!(rep.named, vec!["none"]);
}

#[test]
fn json_has_the_contract_keys_and_says_family_and_shape() {
    let rep = run("tool_wear");
    let v = serde_json::to_value(&rep).unwrap();
    for k in ["initial_rms_um", "final_rms_um", "steps", "named"] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert!(v["initial_rms_um"].is_f64() && v["final_rms_um"].is_f64());
    let s = &v["steps"][0];
    assert_eq!(s["effect"], "tool_wear");
    for k in ["p_value", "rms_before_um", "rms_after_um"] {
        assert!(s[k].is_f64(), "{k}");
    }
    assert_eq!(s["family"], "tool_wear");
    assert_eq!(s["shape"], "saturating");
    let p = s["params"].as_object().unwrap();
    assert_eq!(
        p.keys().cloned().collect::<Vec<_>>(),
        vec!["length_scale_mm", "max_wear_um"]
    );
    assert!(p.values().all(|x| x.is_f64()));
    assert_eq!(v["named"], serde_json::json!(["tool_wear"]));
    // the added keys of issue 15
    for k in [
        "nuisance",
        "nuisance_rms_um",
        "scatter",
        "unexplained",
        "within_nominal_uncertainty",
        "aliasing",
        "verdict",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["nuisance"]["params"].as_array().unwrap().len(), 5);
}

/// The committed `real_*` sessions (drawn from the study's distribution, datasets/synthetic/
/// README.md lists their truth) and the plan that separates nothing.
#[test]
fn committed_real_sessions() {
    let rep = run("real_none");
    assert_eq!(rep.named, vec!["none"], "{}", show(&rep));
    let rep = run("real_tool_wear");
    assert_eq!(rep.named, vec!["tool_wear"], "{}", show(&rep));
    assert!(rep.final_rms_um < RMS_SHRINK * rep.nuisance_rms_um);
    let rep = run("real_machine_compliance");
    assert!(
        rep.within_nominal_uncertainty
            .iter()
            .any(|w| w.effect == "machine_compliance"),
        "{}",
        show(&rep)
    );
    let rep = run("plan_cannot_separate");
    assert_eq!(rep.verdict, "plan_cannot_separate", "{}", show(&rep));
    assert_eq!(rep.named, vec!["none"]);
}
