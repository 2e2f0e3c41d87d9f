//! Batches: controllers compared over designed conditions (`millcomp batch`), in one call
//! ([`run_batch`]).
//!
//! The modules, from the bottom up:
//! - [`spec`]: one scenario as its factor values; [`factors`] (and [`nc_factors`] for `stage =
//!   nc_axis` rows): the names a batch accepts and how each changes the published scenario
//!   `datasets/scenarios/groove_s7_20deg.toml`;
//! - [`plan`]: scenarios × controllers ([`plan::Plan`]), fingerprinted so slices of one batch can be
//!   recognised, and its deterministic slices ([`plan::Shard`]: whole scenarios, so a scenario's runs
//!   share its preparation);
//! - [`store`]: the batch directory — `plan.json`, one record per finished run in `runs/` (a result or a
//!   failure with its reason);
//! - [`exec`]: the runs of a slice in parallel, each scenario prepared once for its controllers (one
//!   commissioning from [`crate::cache`], one preview), resumable, stoppable ([`signals`]), with a
//!   progress line ([`progress`]);
//! - [`paired`], [`results`], [`plots`]: the analysis (medians, ANOVA of every metric with the
//!   controller as a factor, the controllers paired scenario by scenario), the tables, the summary, the
//!   plots, and the merge of slices;
//! - [`engine`]: the whole batch in one call — plan, runs, analysis, tables, plots, `summary.json`,
//!   `invocation.json` — [`run_batch`]; [`merge_batch`]; [`estimate`] (`--dry-run`).
//!
//! The results are deterministic: a merge of slices writes the same bytes as one process, whatever the
//! threads, the cache or the interruptions (`bench/cluster/slurm-selftest` checks it under Slurm); what
//! depends on the clock or the machine (wall-clock, threads, QP solve times, the profile, the cache's
//! counts) goes to `invocation.json`.
//!
//! ```no_run
//! use millcomp_closedloop::batch::{BatchRequest, ScenarioSource, run_batch};
//! let scenarios = ScenarioSource::File { path: "scenarios.csv".into(), columns: None };
//! let summary = run_batch(&BatchRequest::new(scenarios, "pid-tuned,mpc", "results"))?;
//! println!("{:?}", summary.results.by_controller);
//! # Ok::<(), millcomp_closedloop::ClosedLoopError>(())
//! ```

pub mod engine;
pub mod exec;
pub mod factors;
pub mod nc_factors;
pub mod paired;
pub mod plan;
pub mod plots;
pub mod progress;
pub mod results;
pub mod signals;
pub mod spec;
pub mod store;

pub use engine::{
    BatchRequest, Estimate, ScenarioSource, estimate, estimate_request, merge_batch, run_batch,
    run_plan, run_plan_with,
};
pub use progress::{ProgressMode, ProgressUpdate};
pub use results::BatchSummary;
