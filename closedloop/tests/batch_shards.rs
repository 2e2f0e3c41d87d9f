//! Property test: a batch run in N slices and merged equals the batch run in one process — the same
//! `results.csv`, `results.parquet` and `summary.json`, byte for byte, and the same plan — for random plans (factors, rows,
//! controllers) and slice counts. The closed loop is a cheap deterministic fake (metrics computed from
//! the scenario's factors and the controller), so the property is about the batch machinery (plan,
//! slicing, records, merge, tables, summary), not the simulation; it goes through the public API only.
//!
//! Rerun: `cargo test -p millcomp-closedloop --test main batch_shards` (a few seconds).

use std::path::Path;

use millcomp_closedloop::ClosedLoopError;
use millcomp_closedloop::batch::exec::{ClosedLoop, RunMetrics, read_plan, run_shard};
use millcomp_closedloop::batch::factors::{FactorValue, ScenarioSpec};
use millcomp_closedloop::batch::plan::{Plan, Shard};
use millcomp_closedloop::batch::results::{merge, new_summary, write_summary, write_tables};
use millcomp_datasets::{Column, ColumnData, Table};
use proptest::prelude::*;

/// Metrics as a function of the scenario's numbers and the controller, nothing else.
struct Fake;

impl ClosedLoop for Fake {
    fn run(
        &self,
        scenario: &ScenarioSpec,
        controller: &str,
    ) -> Result<(RunMetrics, f64), ClosedLoopError> {
        let sum: f64 = scenario
            .factors
            .values()
            .map(|v| match v {
                FactorValue::Num(x) => *x,
                FactorValue::Text(t) => t.len() as f64,
            })
            .sum();
        let c = controller.bytes().map(f64::from).sum::<f64>() / 100.0;
        let pp = (sum * 0.37 + c).rem_euclid(17.0) + 0.5;
        let odd = scenario.index % 2 == 1;
        Ok((
            RunMetrics {
                pp_error_um: pp,
                rms_error_um: pp / 3.0,
                max_error_um: pp / 2.0,
                min_error_um: -pp / 2.0,
                actuator_travel_um: sum / 7.0 + c,
                solver_fallbacks: (scenario.index + controller.len()) % 3,
                change_excess_um: odd.then_some(pp / 5.0),
                stroke_bound_um: Some(0.0),
                optimum_pp_um: Some(pp / 4.0),
                change_bound_um: odd.then_some(pp / 9.0),
                solve_median_us: Some(c),
                solve_p99_us: Some(2.0 * c),
                solve_max_us: Some(3.0 * c),
                deadline_misses: Some(0),
            },
            0.25 * (scenario.index + 1) as f64,
        ))
    }
}

/// Runs the whole of `plan` in `out` (as `batch` does: run, tables, summary).
fn one_process(plan: &Plan, out: &Path) {
    let done = run_shard(plan, Shard::ALL, out, &Fake, false).unwrap();
    let summary = new_summary(plan, done.records.len(), None);
    let summary = write_tables(plan, &done.records, out, summary).unwrap();
    write_summary(out, summary).unwrap();
}

/// Runs `plan` in `n` slices under `root`, merges them into `out` (as `batch --shard` then `batch
/// merge` do).
fn sliced(plan: &Plan, n: usize, root: &Path, out: &Path) {
    let dirs: Vec<_> = (0..n).map(|k| root.join(format!("slice-{k}"))).collect();
    for (k, d) in dirs.iter().enumerate() {
        let shard = Shard::new(k, n, "test").unwrap();
        run_shard(plan, shard, d, &Fake, false).unwrap();
    }
    let m = merge(&dirs, out).unwrap();
    assert_eq!(m.plan, *plan);
    let summary = write_tables(&m.plan, &m.records, out, m.summary).unwrap();
    write_summary(out, summary).unwrap();
}

fn plan_strategy() -> impl Strategy<Value = (Table, Vec<String>)> {
    let rows = 1usize..=6;
    rows.prop_flat_map(|n| {
        (
            prop::collection::vec(prop::sample::select(vec![15.0, 20.0, 30.0, 40.0]), n),
            prop::option::of(prop::collection::vec(
                prop::sample::select(vec![40.0, 60.0, 80.0]),
                n,
            )),
            prop::option::of(prop::collection::vec(
                prop::sample::select(vec![8.0, 10.0, 12.0]),
                n,
            )),
            prop::option::of(prop::collection::vec(
                prop::sample::select(vec!["S7", "6061"]),
                n,
            )),
            prop::sample::subsequence(vec!["none", "open-loop", "pid", "mpc"], 1..=4),
        )
    })
    .prop_map(|(tilt, depth, upfeed, material, controllers)| {
        let mut cols = vec![Column {
            name: "tilt_deg".into(),
            data: ColumnData::Float(tilt),
        }];
        if let Some(v) = depth {
            cols.push(Column {
                name: "depth_um".into(),
                data: ColumnData::Float(v),
            });
        }
        if let Some(v) = upfeed {
            cols.push(Column {
                name: "upfeed_um".into(),
                data: ColumnData::Float(v),
            });
        }
        if let Some(v) = material {
            cols.push(Column {
                name: "material".into(),
                data: ColumnData::Text(v.into_iter().map(str::to_string).collect()),
            });
        }
        let t = Table::from_columns("random plan", cols).unwrap();
        (t, controllers.into_iter().map(str::to_string).collect())
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn shards_merged_equal_one_process((table, controllers) in plan_strategy(), slices in 1usize..=5) {
        let plan = Plan::from_table(&table, controllers).unwrap();
        let root = tempfile::tempdir().unwrap();
        let single = root.path().join("single");
        let merged = root.path().join("merged");
        one_process(&plan, &single);
        sliced(&plan, slices, root.path(), &merged);
        for name in ["results.csv", "results.parquet", "summary.json"] {
            let a = std::fs::read(single.join(name)).unwrap();
            let b = std::fs::read(merged.join(name)).unwrap();
            prop_assert!(a == b, "{name} differs with {slices} slices of {} runs", plan.n_runs());
        }
        // plan.json: the same plan (the single run's also records its shard, 0 of 1)
        prop_assert_eq!(read_plan(&single).unwrap(), read_plan(&merged).unwrap());
    }
}
