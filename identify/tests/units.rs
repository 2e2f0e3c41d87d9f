//! Across units (issue 50): the meta-analysis against an independent peer, the real two-cutter case
//! end to end, and the coverage of the new unit's prediction interval on simulated units whose true
//! between-unit scatter is known.
//!
//! Golden values: `tests/golden/meta_*.json`, written by `bench/peers/meta_goldens.py` (statsmodels
//! `combine_effects`, which records its call and versions); the BCG case also carries the values the
//! metafor documentation prints (Viechtbauer 2010), a second, published reference.

use millcomp_datasets::Table;
use millcomp_datasets::mapping::join_on;
use millcomp_identify::targets::wear::{
    CutRange, WearLaw, WearOptions, WearStudy, force_wear_quantities, study_wear, wear_across_units,
};
use millcomp_identify::units::{
    MetaAnalysis, MetaOptions, QuantityAcross, Tau2Method, meta_analyse,
};
use serde_json::Value;

use crate::unit_sim::{Family, Setting, coverage};

fn golden(case: &str) -> Value {
    crate::common::golden_json(&format!("meta_{case}"))
}

use crate::common::nums;

fn close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs().max(1e-12),
        "{what}: millcomp {got} vs peer {want} (rel {:.2e})",
        (got - want).abs() / want.abs()
    );
}

/// Compares one meta-analysis with statsmodels' `combine_effects` output `p`. `rel`: 1e-10 where both
/// compute closed forms; Paule–Mandel is iterated by both (statsmodels to |Q − (k − 1)| < 1e-12), so
/// its τ² agrees to ~1e-9.
fn compare(m: &MetaAnalysis, p: &Value, rel: f64) {
    let g = |k: &str| p[k].as_f64().expect(k);
    if g("tau2") == 0.0 && g("q") > (m.k - 1) as f64 && g("hksj_q") > 1.5 {
        // the peer's Paule–Mandel iteration stopped at τ² = 0 where its own equation is not met (its
        // generalised Q, hksj_q·(k − 1), is still 20.2 ≠ k − 1: statsmodels 0.15 on the c1/c4 slope,
        // whose variances are ~1e-4): millcomp's τ² must solve the equation instead
        assert!((m.hksj_q - 1.0).abs() < 1e-9 && m.tau2 > 0.0, "{m:?}");
        return;
    }
    close("mean_fe", m.fixed_mean, g("mean_fe"), rel);
    close("se_fe", m.fixed_se, g("se_fe"), rel);
    close("q", m.q, g("q"), rel);
    close("q_p", m.q_p, g("q_p"), rel.max(1e-8));
    if g("tau2") < 0.0 {
        // Q < k − 1: statsmodels' DerSimonian–Laird τ² and I² go negative; millcomp truncates both at
        // 0 (DerSimonian & Laird 1986; Higgins & Thompson 2002), and the random-effects mean is then
        // the fixed-effect one
        assert_eq!(m.tau2, 0.0);
        assert_eq!(m.i2, 0.0);
        assert!(g("i2") < 0.0);
        close("mean_re (τ² = 0)", m.mean, g("mean_fe"), rel);
        close("se_re (τ² = 0)", m.se_random, g("se_fe"), rel);
        close("hksj_q (τ² = 0)", m.hksj_q, g("q") / (m.k - 1) as f64, rel);
        return;
    }
    close("tau2", m.tau2, g("tau2"), rel);
    close("mean_re", m.mean, g("mean_re"), rel);
    close("se_re", m.se_random, g("se_re"), rel);
    close("hksj_q", m.hksj_q, g("hksj_q"), rel);
    // I² truncated at 0 (statsmodels' is negative where Q < k − 1, whatever the τ² estimator)
    close("i2", m.i2, g("i2").max(0.0), rel);
    // statsmodels does not truncate the Hartung–Knapp scale at 1: where q ≥ 1 the intervals agree
    if m.hksj_q >= 1.0 {
        close("se_hksj", m.se, g("se_hksj"), rel);
        let ci = nums(&p["ci_hksj"]);
        close("ci_hksj lower", m.ci95[0], ci[0], rel);
        close("ci_hksj upper", m.ci95[1], ci[1], rel);
    }
}

const PM: MetaOptions = MetaOptions {
    tau2: Tau2Method::PauleMandel,
};

#[test]
fn bcg_trials_match_statsmodels_and_metafor() {
    let g = golden("bcg");
    let (y, s) = (nums(&g["estimate"]), nums(&g["std_err"]));
    let dl = meta_analyse(&y, &s, &MetaOptions::default()).unwrap();
    compare(&dl, &g["peer"]["dl"], 1e-10);
    let pm = meta_analyse(&y, &s, &PM).unwrap();
    compare(&pm, &g["peer"]["pm"], 1e-8);
    // metafor's printed DL values (4 decimals): a published reference beside the peer
    let mf = &g["metafor_dl"];
    let r4 = |x: f64| (x * 1e4).round() / 1e4;
    assert_eq!(r4(dl.tau2), mf["tau2"].as_f64().unwrap());
    assert_eq!(r4(dl.q), mf["q"].as_f64().unwrap());
    assert_eq!(r4(dl.i2), mf["i2"].as_f64().unwrap());
    assert_eq!(r4(dl.mean), mf["mean"].as_f64().unwrap());
    assert_eq!(r4(dl.se_random), mf["se"].as_f64().unwrap());
}

fn phm(cutter: &str) -> Table {
    let load = |name: String| {
        millcomp_datasets::real::record(&name)
            .expect("shipped")
            .load()
            .expect("loads")
    };
    let f = load(format!("phm2010_{cutter}_per_cut_forces"));
    let w = load(format!("phm2010_{cutter}_per_cut_wear"));
    join_on(&f, &w, "run").expect("joins").0
}

fn wear_study(t: &Table) -> WearStudy {
    let col = |n: &str| t.f64s(n).expect("numeric");
    let cut = col("run");
    let vb: Vec<(String, Vec<f64>)> = (1..=3)
        .map(|i| {
            let n = format!("VB_flute_{i}");
            (n.clone(), col(&n))
        })
        .collect();
    let refs: Vec<(String, &[f64])> = vb.iter().map(|(n, v)| (n.clone(), v.as_slice())).collect();
    let mut o = WearOptions::new(CutRange::parse("--train", "1:end").unwrap(), None);
    o.laws = vec![WearLaw::Linear];
    study_wear(&cut, Some(&refs), "force_y__rms", &col("force_y__rms"), &o).unwrap()
}

/// Per cutter, in the golden's order: the unit, its estimate (to 1e-9) and its Newey–West SE (to 1e-7;
/// the peer's lag-1 r and lags are the same rule).
fn per_cutter_equals_the_peer(q: &QuantityAcross, g: &Value) {
    for (e, pu) in q.per_unit.iter().zip(g["units"].as_array().unwrap()) {
        assert_eq!(e.unit, pu["unit"].as_str().unwrap());
        let want = nums(&pu[&q.name]);
        close(
            &format!("{} unit {} estimate", q.name, e.unit),
            e.value,
            want[0],
            1e-9,
        );
        close(
            &format!("{} unit {} SE", q.name, e.unit),
            e.std_err,
            want[1],
            1e-7,
        );
    }
}

#[test]
fn cutters_c1_and_c4_match_the_peer_end_to_end() {
    // the whole path of `identify wear … --columns unit=case`: each cutter's Newey–West fit of the
    // force against its mean flank wear, then the two combined — against statsmodels OLS(HAC) and
    // combine_effects on the same shipped files
    let g = golden("phm_c1_c4");
    let units = vec![
        ("1".to_string(), vec![wear_study(&phm("c1"))]),
        ("4".to_string(), vec![wear_study(&phm("c4"))]),
    ];
    for (tau2, key, rel) in [
        (Tau2Method::DerSimonianLaird, "dl", 1e-7),
        (Tau2Method::PauleMandel, "pm", 1e-7),
    ] {
        let a = wear_across_units(&units, 100.0, &MetaOptions { tau2 }).unwrap();
        assert_eq!(a.len(), 1);
        for q in &a[0].across.quantities {
            per_cutter_equals_the_peer(q, &g);
            compare(&q.meta, &g["peer"][&q.name][key], rel);
        }
    }
    // the point, on the shipped data: c4's slope lies far outside c1's own interval
    let a = wear_across_units(&units, 100.0, &MetaOptions::default()).unwrap();
    let k = a[0]
        .across
        .quantities
        .iter()
        .find(|q| q.name == "k_n_per_um")
        .unwrap();
    let (c1, c4) = (&k.per_unit[0], &k.per_unit[1]);
    assert!(c1.value - 3.0 * c1.std_err > c4.value, "{c1:?} {c4:?}");
    // and the new cutter's interval holds both, on t(1) = 12.71
    let pi = k.meta.new_unit.pi95;
    assert!(pi[0] < c4.value && c1.value < pi[1]);
    assert!((k.meta.new_unit.t_quantile - 12.706_204_736_174_7).abs() < 1e-9);
}

/// Coverage of the new unit's 95 % prediction interval, 300 data sets per setting (the binomial
/// standard deviation of a 95 % rate is 1.3 %; the example `unit_coverage` runs more).
///
/// Two walls with errors small beside the scatter (SE/τ ≈ 0.1): nominal, required in [0.91, 0.99].
/// Five walls whose own errors are half the scatter (SE/τ ≈ 0.55): the interval **under-covers** —
/// 268 of 300 = 89.3 % measured here, and 90.3 % in an independent simplified simulation (per-unit
/// estimates drawn directly, numpy, 4000 sets, the same interval), the known behaviour of
/// DerSimonian–Laird prediction intervals with few units and moderate heterogeneity (Partlett & Riley
/// 2017, Stat. Med. 36:301). The test pins that shortfall ([0.85, 0.93]) so a change of method shows.
#[test]
fn the_new_unit_interval_covers_new_units() {
    for (s, band) in [
        (
            Setting {
                family: Family::Wall,
                units: 2,
                tau_rel: 0.10,
                noise: 0.05,
                tau2: Tau2Method::DerSimonianLaird,
            },
            0.91..=0.99,
        ),
        (
            Setting {
                family: Family::Wall,
                units: 5,
                tau_rel: 0.10,
                noise: 0.3,
                tau2: Tau2Method::DerSimonianLaird,
            },
            0.85..=0.93,
        ),
    ] {
        let c = coverage(&s, 300, 50_000);
        let rate = c.new_unit_rate();
        assert!(band.contains(&rate), "{s:?}: {c:?}");
        assert!(c.median_se_over_tau < 1.5, "{s:?}: {c:?}");
    }
}

#[test]
fn three_cutters_match_the_peer() {
    // c6, the challenge's third cutter with measured wear: three units, where DerSimonian–Laird and
    // Paule–Mandel differ and the Hartung–Knapp scale of the slope exceeds 1 (statsmodels, golden file)
    let g = golden("phm_c1_c4_c6");
    let units: Vec<(String, Vec<WearStudy>)> = [("1", "c1"), ("4", "c4"), ("6", "c6")]
        .iter()
        .map(|(u, c)| (u.to_string(), vec![wear_study(&phm(c))]))
        .collect();
    for (tau2, key) in [
        (Tau2Method::DerSimonianLaird, "dl"),
        (Tau2Method::PauleMandel, "pm"),
    ] {
        let a = wear_across_units(&units, 100.0, &MetaOptions { tau2 }).unwrap();
        assert_eq!(a[0].across.quantities.len(), 3);
        for q in &a[0].across.quantities {
            per_cutter_equals_the_peer(q, &g);
            compare(&q.meta, &g["peer"][&q.name][key], 1e-7);
        }
    }
    let a = wear_across_units(&units, 100.0, &MetaOptions::default()).unwrap();
    let k = &a[0]
        .across
        .quantities
        .iter()
        .find(|q| q.name == "k_n_per_um")
        .unwrap()
        .meta;
    // the slope's HKSJ scale is above 1 here, so the truncation does not act (statsmodels: 1.637)
    assert!(k.hksj_q > 1.5, "{k:?}");
    assert!((k.new_unit.t_quantile - 4.302_652_729_749_464).abs() < 1e-9);
}

/// The held-out check of the issue: fit two of the three PHM cutters, predict the third. Each
/// cutter's own 95 % Newey–West interval is what a user would have taken for the tool type's; the
/// new unit's interval from the two is what millcomp reports for the next cutter.
#[test]
fn a_cutter_left_out_lies_in_the_two_others_new_unit_interval() {
    let est: Vec<(&str, WearStudy)> = [("1", "c1"), ("4", "c4"), ("6", "c6")]
        .iter()
        .map(|(u, c)| (*u, wear_study(&phm(c))))
        .collect();
    let slope = |s: &WearStudy| {
        let r = &s.force_vs_wear.as_ref().unwrap().report;
        (r.param("k_n_per_um"), r.ci95["k_n_per_um"])
    };
    let mut own_missed = 0;
    for out in 0..3 {
        let train: Vec<(String, Vec<WearStudy>)> = (0..3)
            .filter(|&i| i != out)
            .map(|i| (est[i].0.to_string(), vec![est[i].1.clone()]))
            .collect();
        let a = wear_across_units(&train, 100.0, &MetaOptions::default()).unwrap();
        let (held, _) = slope(&est[out].1);
        let k = &a[0]
            .across
            .quantities
            .iter()
            .find(|q| q.name == "k_n_per_um")
            .unwrap()
            .meta;
        let pi = k.new_unit.pi95;
        assert!(
            pi[0] <= held && held <= pi[1],
            "cutter {} left out: {held} vs {pi:?}",
            est[out].0
        );
        // so does the force at VB = 100 µm (c6's 8.11 N lies in [7.83, 13.99] from c1 and c4, whose
        // own intervals, 10.74 ± 0.31 and 11.19 ± 0.40 N, agree with each other and miss it)
        let f = &a[0]
            .across
            .quantities
            .iter()
            .find(|q| q.name == "force_at_vb_100um_n")
            .unwrap();
        let held_f = force_wear_quantities(est[out].1.force_vs_wear.as_ref().unwrap(), 100.0)
            ["force_at_vb_100um_n"]
            .0;
        let fpi = f.meta.new_unit.pi95;
        assert!(
            fpi[0] <= held_f && held_f <= fpi[1],
            "cutter {} left out: {held_f} N vs {fpi:?}",
            est[out].0
        );
        for i in (0..3).filter(|&i| i != out) {
            let (_, ci) = slope(&est[i].1);
            own_missed += usize::from(!(ci[0] <= held && held <= ci[1]));
        }
    }
    // six (training cutter, held-out cutter) pairs: the own interval misses the other cutter in five
    // (c4's and c6's slopes, 0.092 and 0.082, agree with each other within c4's interval only)
    assert_eq!(own_missed, 5);
}
