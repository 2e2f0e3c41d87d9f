//! Golden comparison with `scipy.optimize.least_squares` (files in `tests/golden/`, written by
//! `bench/peers/identify_goldens.py`, which records the scipy version and the exact call): same
//! data, same model, same starting point; parameters must agree to 1e-6 relative.

use crate::common::tol;
use millcomp_identify::targets::thermal::*;
use millcomp_identify::{NlsOptions, ParamSpec, fit_nonlinear};
use nalgebra::DVector;
use serde_json::Value;

fn load(case: &str) -> Value {
    let path = format!("{}/tests/golden/{case}.json", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(&path).expect("golden file")).expect("json")
}

fn vecf(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn names(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap().to_string())
        .collect()
}

/// Largest relative difference between our estimates and scipy's.
fn max_rel(ours: &DVector<f64>, theirs: &[f64], names: &[String]) -> f64 {
    let mut worst: f64 = 0.0;
    for (i, t) in theirs.iter().enumerate() {
        let r = (ours[i] - t).abs() / t.abs();
        eprintln!(
            "GOLDEN {:>16}: ours {:.12e} scipy {:.12e} rel {:.2e}",
            names[i], ours[i], t, r
        );
        worst = worst.max(r);
    }
    worst
}

#[test]
fn thermal_exponential_matches_scipy() {
    let g = load("thermal_exponential");
    let t = vecf(&g["data"]["t_s"]);
    let y = vecf(&g["data"]["drift_um"]);
    let x0 = vecf(&g["x0"]);
    let nm = names(&g["param_names"]);
    let expect = vecf(&g["params"]);
    // Same starting point as scipy, engine level.
    let specs = [
        ParamSpec::free(&nm[0], x0[0]),
        ParamSpec::positive(&nm[1], x0[1]),
        ParamSpec::free(&nm[2], x0[2]),
    ];
    let op = ExponentialDrift {
        t_s: &t,
        drift_um: &y,
    };
    let fit = fit_nonlinear(
        op,
        &specs,
        &NlsOptions::default(),
        "thermal_exponential",
        "um",
    )
    .unwrap();
    let worst = max_rel(&fit.theta, &expect, &nm);
    eprintln!(
        "GOLDEN thermal_exponential max rel diff {worst:.2e} ({} iterations)",
        fit.report.iterations
    );
    assert!(
        worst <= tol::GOLDEN_REL,
        "max relative difference {worst:e}"
    );
    // The verb (its own data-driven start) reaches the same minimum.
    let d = ThermalData {
        t_s: &t,
        drift_um: &y,
        speed_rpm: None,
        temp_c: None,
    };
    let v = identify_thermal(&d, ThermalModel::Exponential, &CommonOptions::default()).unwrap();
    for (i, n) in nm.iter().enumerate() {
        let r = (v.report.param(n) - expect[i]).abs() / expect[i].abs();
        assert!(r <= tol::GOLDEN_REL, "verb {n}: rel diff {r:e}");
    }
}

fn spindle_golden(case: &str) {
    use millcomp_identify::targets::spindle::*;
    use millcomp_sim::spindle::DeadTimeModel;
    let g = load(case);
    let t = vecf(&g["data"]["t_s"]);
    let u = vecf(&g["data"]["u_v"]);
    let y = vecf(&g["data"]["y_um"]);
    let x0 = vecf(&g["x0"]);
    let nm = names(&g["param_names"]);
    let expect = vecf(&g["params"]);
    let pole = g["extra_pole"].as_bool().unwrap();
    let dead = g["dead_time"].as_bool().unwrap();
    let data = SpindleData {
        t_s: &t,
        u_v: &u,
        y_um: &y,
    };
    let specs: Vec<ParamSpec> = nm
        .iter()
        .zip(&x0)
        .map(|(n, &v)| match n.as_str() {
            "offset_um" => ParamSpec::free(n, v),
            "zeta" => ParamSpec::bounded(n, v, 0.0, 10.0),
            "dead_time_s" => ParamSpec::bounded(n, v, 0.0, 0.1),
            _ => ParamSpec::positive(n, v),
        })
        .collect();
    let op = SpindleResponse::new(&data, pole, dead, DeadTimeModel::Pade2);
    let fit = fit_nonlinear(op, &specs, &NlsOptions::default(), "spindle", "um").unwrap();
    let worst = max_rel(&fit.theta, &expect, &nm);
    eprintln!(
        "GOLDEN {case} max rel diff {worst:.2e} ({} iterations, {})",
        fit.report.iterations, fit.report.message
    );
    assert!(
        worst <= tol::GOLDEN_REL,
        "{case}: max relative difference {worst:e}"
    );
    // The verb, from its own data-driven start (rise time / overshoot), reaches the same minimum.
    let opts = SpindleOptions {
        extra_pole: pole,
        dead_time: dead,
        ..Default::default()
    };
    let v = identify_spindle(&data, &opts).unwrap();
    eprintln!(
        "GOLDEN {case} verb: {} in {} iterations; warnings {:?}",
        v.report.message, v.report.iterations, v.report.warnings
    );
    for (i, n) in nm.iter().enumerate() {
        let r = (v.report.param(n) - expect[i]).abs() / expect[i].abs();
        assert!(r <= tol::GOLDEN_REL, "{case} verb {n}: rel diff {r:e}");
    }
}

#[test]
fn spindle_second_order_matches_scipy() {
    spindle_golden("spindle_2nd");
}

#[test]
fn spindle_pole_deadtime_matches_scipy() {
    spindle_golden("spindle_pole_deadtime");
}
