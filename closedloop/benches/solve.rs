//! Per-cycle QP solve of the spindle MPC (update_q + update_b + Clarabel solve), horizon 20 and 40,
//! cycling through a recorded closed-loop sequence (`recording::record_spindle_sequence`).
use criterion::{Criterion, criterion_group, criterion_main};
use millcomp_closedloop::recording::record_spindle_sequence;
use millcomp_mpc::replay::ReplaySolver;

fn per_cycle_solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("mpc_per_cycle_solve");
    group.sample_size(30);
    group.measurement_time(std::time::Duration::from_secs(3));
    for horizon in [20usize, 40] {
        let seq = record_spindle_sequence(horizon, 400, 1).expect("recording");
        let mut solver = ReplaySolver::new(&seq).expect("solver");
        let mut k = 0usize;
        group.bench_function(format!("horizon_{horizon}"), |b| {
            b.iter(|| {
                let r = solver.solve_cycle(k).expect("solve");
                k += 1;
                std::hint::black_box(r)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, per_cycle_solve);
criterion_main!(benches);
