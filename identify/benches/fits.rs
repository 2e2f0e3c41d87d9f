//! Time per fit on the golden problems (the same data, model and starting point that
//! `bench/peers/identify_scipy_bench.py` times with `scipy.optimize.least_squares`).
//!
//! Run: `CARGO_TARGET_DIR=/tmp/target-identify cargo bench -p millcomp-identify --bench fits`,
//! then `/tmp/pyvenv/bin/python bench/peers/identify_scipy_bench.py` prints the side-by-side table
//! (it reads criterion's estimates from `$CARGO_TARGET_DIR/criterion`).

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use millcomp_identify::targets::spindle::{SpindleData, SpindleResponse};
use millcomp_identify::targets::thermal::ExponentialDrift;
use millcomp_identify::{NlsOptions, ParamSpec, fit_nonlinear};
use millcomp_sim::spindle::DeadTimeModel;
use serde_json::Value;

fn load(case: &str) -> Value {
    let path = format!("{}/tests/golden/{case}.json", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(path).expect("golden")).expect("json")
}

fn vecf(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn specs_for(names: &[String], x0: &[f64]) -> Vec<ParamSpec> {
    names
        .iter()
        .zip(x0)
        .map(|(n, &v)| match n.as_str() {
            "offset_um" | "amplitude_um" => ParamSpec::free(n, v),
            "zeta" => ParamSpec::bounded(n, v, 0.0, 10.0),
            "dead_time_s" => ParamSpec::bounded(n, v, 0.0, 0.1),
            _ => ParamSpec::positive(n, v),
        })
        .collect()
}

fn names(g: &Value) -> Vec<String> {
    g["param_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap().to_string())
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("identify_fit");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));

    let g = load("thermal_exponential");
    let (t, y, x0, nm) = (
        vecf(&g["data"]["t_s"]),
        vecf(&g["data"]["drift_um"]),
        vecf(&g["x0"]),
        names(&g),
    );
    let specs = specs_for(&nm, &x0);
    group.bench_function("thermal_exponential", |b| {
        b.iter(|| {
            let op = ExponentialDrift {
                t_s: &t,
                drift_um: &y,
            };
            fit_nonlinear(op, &specs, &NlsOptions::default(), "thermal", "um").unwrap()
        })
    });

    for case in ["spindle_2nd", "spindle_pole_deadtime"] {
        let g = load(case);
        let (t, u, y) = (
            vecf(&g["data"]["t_s"]),
            vecf(&g["data"]["u_v"]),
            vecf(&g["data"]["y_um"]),
        );
        let (x0, nm) = (vecf(&g["x0"]), names(&g));
        let specs = specs_for(&nm, &x0);
        let pole = g["extra_pole"].as_bool().unwrap();
        let dead = g["dead_time"].as_bool().unwrap();
        group.bench_function(case, |b| {
            b.iter(|| {
                let data = SpindleData {
                    t_s: &t,
                    u_v: &u,
                    y_um: &y,
                };
                let op = SpindleResponse::new(&data, pole, dead, DeadTimeModel::Pade2);
                fit_nonlinear(op, &specs, &NlsOptions::default(), "spindle", "um").unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
