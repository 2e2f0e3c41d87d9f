//! Running the plan: one closed-loop run per scenario × controller, in parallel (rayon), each result
//! written atomically to `DIR/runs/run-NNNNNN.json` as soon as it finishes, so an interrupted batch
//! resumes where it stopped and a partial file is never taken for a result.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use millcomp_closedloop::ControllerKind;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::factors::{ScenarioSpec, build_scenario};
use super::plan::{Plan, RunId, Shard};

/// The error metrics of one closed-loop run (µm), as the MPC crate reports them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetrics {
    /// Peak-to-peak error.
    pub pp_error_um: f64,
    /// RMS error.
    pub rms_error_um: f64,
    /// Largest error.
    pub max_error_um: f64,
    /// Smallest error.
    pub min_error_um: f64,
    /// Total actuator travel.
    pub actuator_travel_um: f64,
    /// MPC only: QP solves that fell back (did not converge); 0 for other controllers.
    pub solver_fallbacks: usize,
}

/// Metric names, in table order (the numeric result columns).
pub const METRICS: [&str; 6] = [
    "pp_error_um",
    "rms_error_um",
    "max_error_um",
    "min_error_um",
    "actuator_travel_um",
    "solver_fallbacks",
];

impl RunMetrics {
    /// Value of metric `name` (one of [`METRICS`]).
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "pp_error_um" => self.pp_error_um,
            "rms_error_um" => self.rms_error_um,
            "max_error_um" => self.max_error_um,
            "min_error_um" => self.min_error_um,
            "actuator_travel_um" => self.actuator_travel_um,
            "solver_fallbacks" => self.solver_fallbacks as f64,
            _ => return None,
        })
    }
}

/// A closed-loop simulation of one scenario with one controller.
pub trait ClosedLoop: Sync {
    /// Runs `scenario` with `controller` and returns its metrics plus the simulated seconds.
    fn run(&self, scenario: &ScenarioSpec, controller: &str) -> anyhow::Result<(RunMetrics, f64)>;
}

/// The real closed loop: `millcomp_closedloop::run_scenario` on the published scenario with the factors applied.
#[derive(Debug, Clone, Copy, Default)]
pub struct MpcClosedLoop;

impl ClosedLoop for MpcClosedLoop {
    fn run(&self, scenario: &ScenarioSpec, controller: &str) -> anyhow::Result<(RunMetrics, f64)> {
        let s = build_scenario(scenario)?;
        let kind: ControllerKind = controller.parse()?;
        let r = millcomp_closedloop::run_scenario(&s, kind)?;
        let m = &r.metrics;
        let metrics = RunMetrics {
            pp_error_um: m.pp_error_um,
            rms_error_um: m.rms_error_um,
            max_error_um: m.max_error_um,
            min_error_um: m.min_error_um,
            actuator_travel_um: m.actuator_travel_um,
            solver_fallbacks: r.solver.map_or(0, |s| s.fallbacks),
        };
        Ok((metrics, r.simulated_s))
    }
}

/// The stored result of one run (`DIR/runs/run-NNNNNN.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Fingerprint of the plan it belongs to.
    pub fingerprint: String,
    /// Global run index.
    pub run: usize,
    /// Scenario index.
    pub scenario: usize,
    /// Controller name.
    pub controller: String,
    /// Metrics.
    pub metrics: RunMetrics,
    /// Simulated machining time (s).
    pub simulated_s: f64,
    /// Wall-clock time of the run (s) — informative, not part of the results table.
    pub wall_clock_s: f64,
}

/// What [`run_shard`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShardOutcome {
    /// Runs of this shard.
    pub n_runs: usize,
    /// Runs executed now.
    pub n_ran: usize,
    /// Runs found finished from an earlier attempt and not run again.
    pub n_resumed: usize,
    /// Records of every run of the shard, in run order.
    #[serde(skip)]
    pub records: Vec<RunRecord>,
    /// Simulated machining seconds of the runs executed now.
    pub simulated_s: f64,
    /// Wall-clock seconds of this call.
    pub wall_clock_s: f64,
    /// Threads used.
    pub threads: usize,
}

/// `DIR/runs`.
pub fn runs_dir(out: &Path) -> PathBuf {
    out.join("runs")
}

fn run_file(out: &Path, run: usize) -> PathBuf {
    runs_dir(out).join(format!("run-{run:06}.json"))
}

/// `DIR/plan.json` — writes it, or checks that an existing one is the same batch.
pub fn claim_dir(out: &Path, plan: &Plan, shard: Shard) -> anyhow::Result<()> {
    std::fs::create_dir_all(runs_dir(out))
        .with_context(|| format!("creating {}", runs_dir(out).display()))?;
    let path = out.join("plan.json");
    if path.exists() {
        let old = read_plan(out)?;
        if old.fingerprint != plan.fingerprint {
            bail!(
                "{} belongs to another batch (fingerprint {} ≠ {}): use another --out directory",
                path.display(),
                old.fingerprint,
                plan.fingerprint
            );
        }
    }
    #[derive(Serialize)]
    struct PlanFile<'a> {
        #[serde(flatten)]
        plan: &'a Plan,
        shard: Shard,
    }
    let text = serde_json::to_string_pretty(&PlanFile { plan, shard })?;
    millcomp_datasets::write_text_atomic(&path, &text)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Reads `DIR/plan.json` and checks its fingerprint against its content.
pub fn read_plan(dir: &Path) -> anyhow::Result<Plan> {
    let path = dir.join("plan.json");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "reading {} (is it a batch output directory?)",
            path.display()
        )
    })?;
    let plan: Plan =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let fp = plan.compute_fingerprint()?;
    if fp != plan.fingerprint {
        bail!(
            "{}: the plan was edited (its fingerprint {} does not match its content {fp})",
            path.display(),
            plan.fingerprint
        );
    }
    Ok(plan)
}

/// Reads the shard number stored in `DIR/plan.json`.
pub fn read_shard(dir: &Path) -> anyhow::Result<Shard> {
    let path = dir.join("plan.json");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text)?;
    serde_json::from_value(v.get("shard").cloned().unwrap_or_default())
        .with_context(|| format!("{}: no valid `shard`", path.display()))
}

/// The finished record of run `run` in `dir`, if there is a valid one for this plan.
pub fn load_record(dir: &Path, plan: &Plan, run: RunId) -> Option<RunRecord> {
    let text = std::fs::read_to_string(run_file(dir, run.index)).ok()?;
    let r: RunRecord = serde_json::from_str(&text).ok()?;
    (r.fingerprint == plan.fingerprint
        && r.run == run.index
        && r.scenario == run.scenario
        && r.controller == plan.controllers[run.controller])
        .then_some(r)
}

/// Runs every run of `shard` not already finished in `out`, in parallel, with a progress bar on stderr
/// when `progress` is true.
pub fn run_shard(
    plan: &Plan,
    shard: Shard,
    out: &Path,
    runner: &dyn ClosedLoop,
    progress: bool,
) -> anyhow::Result<ShardOutcome> {
    let start = std::time::Instant::now();
    claim_dir(out, plan, shard)?;
    let runs = plan.shard_runs(shard);
    let mut done: Vec<RunRecord> = Vec::new();
    let mut todo: Vec<RunId> = Vec::new();
    for r in &runs {
        match load_record(out, plan, *r) {
            Some(rec) => done.push(rec),
            None => todo.push(*r),
        }
    }
    let n_resumed = done.len();
    let bar = if progress {
        let b =
            ProgressBar::with_draw_target(Some(runs.len() as u64), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs (eta {eta}) {msg}",
        ) {
            b.set_style(style);
        }
        b.set_position(n_resumed as u64);
        b
    } else {
        ProgressBar::hidden()
    };
    let errors: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let fresh: Vec<RunRecord> = todo
        .par_iter()
        .filter_map(|r| {
            let controller = &plan.controllers[r.controller];
            let scenario = &plan.scenarios[r.scenario];
            let t0 = std::time::Instant::now();
            let result = runner
                .run(scenario, controller)
                .and_then(|(metrics, sim_s)| {
                    let rec = RunRecord {
                        fingerprint: plan.fingerprint.clone(),
                        run: r.index,
                        scenario: r.scenario,
                        controller: controller.clone(),
                        metrics,
                        simulated_s: sim_s,
                        wall_clock_s: t0.elapsed().as_secs_f64(),
                    };
                    let path = run_file(out, r.index);
                    millcomp_datasets::write_text_atomic(
                        &path,
                        &serde_json::to_string_pretty(&rec)?,
                    )
                    .with_context(|| format!("writing {}", path.display()))?;
                    Ok(rec)
                });
            bar.inc(1);
            match result {
                Ok(rec) => Some(rec),
                Err(e) => {
                    let msg = format!(
                        "scenario {} (row {}), controller {controller}: {e:#}",
                        r.scenario,
                        r.scenario + 1
                    );
                    if let Ok(mut v) = errors.lock() {
                        v.push(msg);
                    }
                    None
                }
            }
        })
        .collect();
    bar.finish_and_clear();
    let errors = errors.into_inner().unwrap_or_default();
    if !errors.is_empty() {
        bail!(
            "{} of {} runs failed (finished runs are kept in {} and are not run again):\n  {}",
            errors.len(),
            todo.len(),
            runs_dir(out).display(),
            errors.join("\n  ")
        );
    }
    let simulated_s = fresh.iter().map(|r| r.simulated_s).sum();
    let n_ran = fresh.len();
    done.extend(fresh);
    done.sort_by_key(|r| r.run);
    Ok(ShardOutcome {
        n_runs: runs.len(),
        n_ran,
        n_resumed,
        records: done,
        simulated_s,
        wall_clock_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
    })
}
