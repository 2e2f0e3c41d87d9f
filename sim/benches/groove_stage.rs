//! Groove stage speed: simulated machining seconds per wall-clock second at a 20 kHz step, no controller.
//! Throughput is reported in steps; simulated-seconds/wall-second = (steps/s) / 20 000.
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use millcomp_sim::groove::{GrooveConfig, GrooveStage};
use std::hint::black_box;

fn bench_groove(c: &mut Criterion) {
    let dt = 1.0 / 20_000.0;
    let cfg = GrooveConfig::thesis(20.0, 8.0).expect("thesis groove");
    // 0.5 s of machining = 10 000 steps per iteration
    let steps = 10_000u64;
    let mut g = c.benchmark_group("groove_stage_20khz");
    g.throughput(Throughput::Elements(steps));
    g.sample_size(30);
    g.bench_function("step_no_controller", |b| {
        b.iter_batched(
            || GrooveStage::new(cfg.clone(), dt).expect("stage"),
            |mut st| {
                let mut acc = 0.0;
                for _ in 0..steps {
                    acc += st.step(0.0).depth_cut_um;
                }
                black_box(acc)
            },
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench_groove);
criterion_main!(benches);
