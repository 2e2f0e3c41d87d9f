//! Batch throughput: simulated machining seconds per wall-clock second with MPC at the loop rate, on one
//! and on two cores (issue 8). The work is what `millcomp batch` does per run — `millcomp_closedloop::run_scenario`
//! of the published 20° S7 groove (2 kHz MPC, 20 kHz stage), the full 20 mm (12 s of machining, issue 18's
//! measure) replicated over 4 seeds — distributed over a rayon pool of 1 or 2 threads.
//!
//! `bash bench/batch-throughput` runs this and prints the medians, the throughput per core and the
//! 1 → 2 core speed-up side by side.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use millcomp_closedloop::{ControllerKind, Scenario, run_scenario};
use rayon::prelude::*;

const BASE: &str = include_str!("../datasets/scenarios/groove_s7_20deg.toml");
/// Scenarios per iteration (a multiple of the core counts measured).
const RUNS: u64 = 4;
/// Groove length per run (mm): the whole groove.
const LENGTH_MM: f64 = 20.0;

fn scenarios() -> Vec<Scenario> {
    (0..RUNS)
        .map(|i| {
            let mut s =
                Scenario::from_toml_str(BASE, "groove_s7_20deg.toml").expect("shipped scenario");
            s.seed = 100 + i;
            if let Some(g) = s.groove.as_mut() {
                g.length_mm = LENGTH_MM;
            }
            s
        })
        .collect()
}

fn run_all(pool: &rayon::ThreadPool, scs: &[Scenario]) -> f64 {
    pool.install(|| {
        scs.par_iter()
            .map(|s| {
                run_scenario(s, ControllerKind::Mpc)
                    .expect("published scenario runs")
                    .simulated_s
            })
            .sum()
    })
}

fn throughput(c: &mut Criterion) {
    let scs = scenarios();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    // simulated machining per iteration, in ms (criterion reports elements/s = simulated ms per second)
    let sim_s = run_all(&one, &scs);
    let mut g = c.benchmark_group("batch_throughput");
    g.sample_size(10);
    g.throughput(Throughput::Elements((sim_s * 1e3).round() as u64));
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        g.bench_function(format!("mpc_{threads}_core"), |b| {
            b.iter(|| run_all(&pool, &scs))
        });
    }
    g.finish();
}

criterion_group!(benches, throughput);
criterion_main!(benches);
