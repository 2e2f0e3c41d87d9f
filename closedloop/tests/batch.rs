//! The batch engine as a library: a failed run is recorded and the others go on; the commissioning
//! cache gives the bundle a fresh commissioning gives, value for value, and its key holds what the
//! commissioning sees; one call writes the whole batch.

use std::sync::atomic::{AtomicBool, Ordering};

use millcomp_closedloop::ClosedLoopError;
use millcomp_closedloop::batch::exec::{ClosedLoop, RunMetrics, ShardOptions, run_shard_with};
use millcomp_closedloop::batch::factors::{FactorValue, ScenarioSpec, build_scenario};
use millcomp_closedloop::batch::plan::{Plan, Shard};
use millcomp_closedloop::batch::store::{FailedRun, RunOutcome, load_outcome};
use millcomp_closedloop::batch::{
    BatchRequest, ProgressMode, ProgressUpdate, ScenarioSource, run_batch,
};
use millcomp_closedloop::cache::{CommissioningCache, CommissioningKey};
use millcomp_closedloop::commissioning::{CommissioningPlant, commission};
use millcomp_closedloop::groove::groove_truth;
use millcomp_datasets::{Column, ColumnData, Table};
use millcomp_models::{ModelBundle, ModelFile};

fn specs(n: usize) -> Vec<ScenarioSpec> {
    (0..n)
        .map(|index| ScenarioSpec {
            index,
            factors: [(
                "tilt_deg".to_string(),
                FactorValue::Num(20.0 + index as f64),
            )]
            .into_iter()
            .collect(),
        })
        .collect()
}

/// Scenario 1 fails with an error, scenario 2 panics with `mpc`; the rest give metrics from the
/// factors.
struct Flaky;

impl ClosedLoop for Flaky {
    fn run(
        &self,
        scenario: &ScenarioSpec,
        controller: &str,
    ) -> Result<(RunMetrics, f64), ClosedLoopError> {
        match (scenario.index, controller) {
            (1, _) => Err(ClosedLoopError::NoControllers),
            (2, "mpc") => panic!("a bug met on one run"),
            _ => {
                let pp = 1.0 + scenario.index as f64;
                Ok((
                    RunMetrics {
                        pp_error_um: pp,
                        rms_error_um: pp / 3.0,
                        max_error_um: pp / 2.0,
                        min_error_um: -pp / 2.0,
                        actuator_travel_um: 10.0,
                        solver_fallbacks: 0,
                        change_excess_um: None,
                        stroke_bound_um: None,
                        optimum_pp_um: None,
                        change_bound_um: None,
                        solve_median_us: None,
                        solve_p99_us: None,
                        solve_max_us: None,
                        deadline_misses: None,
                    },
                    0.5,
                ))
            }
        }
    }
}

#[test]
fn a_failed_run_is_recorded_with_its_reason_and_the_batch_goes_on() {
    let plan = Plan::new(
        vec!["tilt_deg".into()],
        specs(4),
        vec!["pid".into(), "mpc".into()],
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let updates = std::sync::Arc::new(std::sync::Mutex::new(Vec::<ProgressUpdate>::new()));
    let seen = updates.clone();
    let opts = ShardOptions {
        progress: ProgressMode::Callback(std::sync::Arc::new(move |u: &ProgressUpdate| {
            seen.lock().unwrap().push(*u)
        })),
        ..ShardOptions::default()
    };
    let out = run_shard_with(&plan, Shard::ALL, dir.path(), &Flaky, &opts).unwrap();
    // 8 runs: scenario 1's two failed (an error), scenario 2's mpc failed (a panic), 5 results
    assert_eq!((out.n_runs, out.n_ran, out.records.len()), (8, 8, 5));
    let failed: Vec<(usize, &str)> = out
        .failed
        .iter()
        .map(|f| (f.run, f.controller.as_str()))
        .collect();
    assert_eq!(failed, [(2, "pid"), (3, "mpc"), (5, "mpc")]);
    assert!(out.failed[0].reason.contains("at least one controller"));
    assert!(
        out.failed[2]
            .reason
            .contains("panicked: a bug met on one run")
    );
    // every run was reported, the failures counted; the last update says all 8 are done
    let updates = updates.lock().unwrap();
    let last = updates.last().unwrap();
    assert_eq!((last.done, last.total, last.failed), (8, 8, 3));
    assert_eq!(updates.len(), 9); // the start and one per run
    // a failure is stored and final: a second call runs nothing
    let id = plan.run_id(5);
    assert!(matches!(
        load_outcome(dir.path(), &plan, id),
        Some(RunOutcome::Failed(FailedRun { run: 5, .. }))
    ));
    let again = run_shard_with(
        &plan,
        Shard::ALL,
        dir.path(),
        &Flaky,
        &ShardOptions::default(),
    )
    .unwrap();
    assert_eq!((again.n_ran, again.n_resumed), (0, 8));
    assert_eq!((again.records, again.failed), (out.records, out.failed));
}

#[test]
fn a_stop_request_leaves_the_runs_not_started_for_the_next_call() {
    let plan = Plan::new(vec!["tilt_deg".into()], specs(3), vec!["pid".into()]).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let stop = AtomicBool::new(true);
    let opts = ShardOptions {
        stop: vec![&stop],
        ..ShardOptions::default()
    };
    let e = run_shard_with(&plan, Shard::ALL, dir.path(), &Flaky, &opts).unwrap_err();
    assert!(
        e.to_string()
            .contains("stopped by a stop request after 0 of 3 runs"),
        "{e}"
    );
    stop.store(false, Ordering::Relaxed);
    let out = run_shard_with(&plan, Shard::ALL, dir.path(), &Flaky, &opts).unwrap();
    assert_eq!((out.n_ran, out.n_resumed, out.failed.len()), (3, 0, 1));
}

/// A groove scenario of the batch, commissioned as its runs commission it.
fn plant_key(tilt_deg: f64, stiffness_error_pct: f64) -> CommissioningKey {
    let spec = ScenarioSpec {
        index: 0,
        factors: [
            ("tilt_deg".to_string(), FactorValue::Num(tilt_deg)),
            (
                "stiffness_error_pct".to_string(),
                FactorValue::Num(stiffness_error_pct),
            ),
            ("length_mm".to_string(), FactorValue::Num(0.5)),
        ]
        .into_iter()
        .collect(),
    };
    let s = build_scenario(&spec).unwrap();
    let truth = groove_truth(&s).unwrap();
    let plant = CommissioningPlant::of_scenario(&s, &truth);
    CommissioningKey::new(&plant, &s.commissioning, s.seed.wrapping_add(11))
}

#[test]
fn the_cache_gives_the_bundle_a_fresh_commissioning_gives() {
    let key = plant_key(30.0, 0.0);
    // what the controllers' models depend on is the key: the controllers' stiffness error and the
    // groove's length are not in it, the tilt is
    assert_eq!(
        key.address().unwrap(),
        plant_key(30.0, 10.0).address().unwrap()
    );
    assert_ne!(
        key.address().unwrap(),
        plant_key(40.0, 0.0).address().unwrap()
    );
    // the bundle of the key's truth is the full commissioning's (its pseudo-true reruns left out)
    let plant = CommissioningPlant {
        truth: &key.truth,
        instruments: key.instruments,
        force_noise_n: key.force_noise_n,
        gauge_noise_um: key.gauge_noise_um,
        material: &key.material,
    };
    let full = commission(&plant, &key.plan, key.seed).unwrap();
    let fresh = key.commission().unwrap();
    let debug = |b: &ModelBundle| format!("{b:?}");
    assert_eq!(debug(&fresh), debug(&full.bundle));
    // through the cache on disk: computed once, then from memory, then (a new process) from disk —
    // the same values to the last bit (the model file's TOML round-trips every f64)
    let dir = tempfile::tempdir().unwrap();
    let cache = CommissioningCache::on_disk(dir.path());
    let a = cache.bundle(&key).unwrap();
    let b = cache.bundle(&key).unwrap();
    let c = CommissioningCache::on_disk(dir.path())
        .bundle(&key)
        .unwrap();
    for x in [&a, &b, &c] {
        assert_eq!(debug(x), debug(&fresh));
    }
    assert_eq!(
        (cache.counts().computed, cache.counts().from_memory),
        (1, 1)
    );
    let file = dir
        .path()
        .join("commissioning")
        .join(format!("{}.toml", key.address().unwrap()));
    let on_disk: ModelFile<ModelBundle> = ModelFile::load(&file, &ModelBundle::KINDS).unwrap();
    assert_eq!(debug(&on_disk.model), debug(&fresh));
}

#[test]
fn one_call_runs_the_batch_and_writes_its_files() {
    let col = |name: &str, v: Vec<f64>| Column {
        name: name.into(),
        data: ColumnData::Float(v),
    };
    let t = Table::from_columns(
        "test",
        vec![
            col("length_mm", vec![0.3, 0.3, 0.3]),
            col("tilt_deg", vec![20.0, 40.0, 20.0]),
            col("stiffness_error_pct", vec![0.0, 0.0, 10.0]),
        ],
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut req = BatchRequest::new(ScenarioSource::Table(t), "pid,pid-tuned", dir.path());
    req.progress = ProgressMode::Quiet;
    req.threads = Some(2);
    // the caller's stop request (BatchRequest::stop), set before the call: no run starts, the call
    // says so and writes no result
    let stop = std::sync::Arc::new(AtomicBool::new(true));
    req.stop = Some(stop.clone());
    let e = run_batch(&req).unwrap_err();
    assert!(
        matches!(
            e,
            ClosedLoopError::Interrupted {
                done: 0,
                planned: 6,
                ..
            }
        ),
        "{e}"
    );
    assert!(!dir.path().join("results.csv").exists());
    // cleared: the same request runs the batch
    stop.store(false, Ordering::SeqCst);
    let s = run_batch(&req).unwrap();
    assert_eq!(s.results.n_runs, 6);
    // scenarios 0 and 2 differ only in the controllers' stiffness error: one commissioning for both
    let counts = s.invocation.cache.as_ref().unwrap().counts;
    assert_eq!(counts.computed, 2, "{counts:?}");
    // the files, summary.json listed after the tables and plots, invocation.json last
    let files = &s.invocation.files;
    assert!(files[0].ends_with("results.csv") && files[1].ends_with("results.parquet"));
    assert!(files[files.len() - 2].ends_with("summary.json"));
    assert!(files[files.len() - 1].ends_with("invocation.json"));
    for f in files {
        assert!(std::path::Path::new(f).exists(), "{f}");
    }
    // the profile covers the call: its stages and the threads' idle time add up to threads × wall
    let p = &s.invocation.profile_s;
    let total = p.total();
    let expected = s.invocation.threads as f64 * s.invocation.wall_clock_s;
    assert!(total >= 0.99 * expected, "{total} vs {expected}");
    assert!(p.get(millcomp_closedloop::profile::Stage::Truth) > 0.0);
}
