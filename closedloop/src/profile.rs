//! Where a run's time goes, by stage: each thread adds the seconds it spends in a stage to its own
//! tally ([`timed`], [`add`]), and whoever ran the work takes the tally when it is done ([`take`]) — a
//! batch sums them over its runs into `invocation.json`. Wall-clock seconds on the thread that did the
//! work, so informative (they depend on the machine and its load), never part of a result.

use std::cell::RefCell;
use std::time::Instant;

use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

/// A stage of a closed-loop run or of a batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Stage {
    /// The scenario built from its factors, the truth plant configured (force scale calibrated).
    Scenario,
    /// The commissioning experiments and their fits (a bundle computed, not found in a cache).
    Commission,
    /// A commissioned bundle read from the cache on disk.
    CacheRead,
    /// The controllers' models and preview (the deflection plan, the touch-off, the controller built).
    Setup,
    /// The truth plant's steps (sampled: every 7th step timed and scaled).
    Truth,
    /// The controllers' own work each step, outside their QP solves.
    Controller,
    /// The MPC's QP solves (Clarabel).
    Solve,
    /// The run's physical limits: the optimum, the stroke bound and the linear programmes of the change
    /// bounds.
    Bounds,
    /// The run's metrics from its errors.
    Metrics,
    /// Run records and the batch's files written.
    Writing,
    /// Medians, ANOVA and the paired comparisons.
    Analysis,
    /// The plots.
    Plots,
    /// A batch's threads without work: threads × wall-clock − the stages above (the end of a batch,
    /// when fewer runs are left than threads, or a thread waiting for a commissioning another runs).
    Waiting,
}

impl Stage {
    /// Every stage, in the order a run meets them.
    pub const ALL: [Stage; 13] = [
        Stage::Scenario,
        Stage::Commission,
        Stage::CacheRead,
        Stage::Setup,
        Stage::Truth,
        Stage::Controller,
        Stage::Solve,
        Stage::Bounds,
        Stage::Metrics,
        Stage::Writing,
        Stage::Analysis,
        Stage::Plots,
        Stage::Waiting,
    ];

    /// The stage's name in `invocation.json`.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Scenario => "scenario",
            Stage::Commission => "commission",
            Stage::CacheRead => "cache_read",
            Stage::Setup => "setup",
            Stage::Truth => "truth",
            Stage::Controller => "controller",
            Stage::Solve => "solve",
            Stage::Bounds => "bounds",
            Stage::Metrics => "metrics",
            Stage::Writing => "writing",
            Stage::Analysis => "analysis",
            Stage::Plots => "plots",
            Stage::Waiting => "waiting",
        }
    }
}

/// Seconds per stage.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimes([f64; Stage::ALL.len()]);

impl StageTimes {
    /// Seconds spent in `stage`.
    pub fn get(&self, stage: Stage) -> f64 {
        self.0[stage as usize]
    }

    /// Adds `seconds` to `stage`.
    pub fn add(&mut self, stage: Stage, seconds: f64) {
        self.0[stage as usize] += seconds;
    }

    /// Adds every stage of `other`.
    pub fn absorb(&mut self, other: &StageTimes) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }

    /// The sum over the stages.
    pub fn total(&self) -> f64 {
        self.0.iter().sum()
    }

    /// `(name, seconds)` of every stage, in [`Stage::ALL`]'s order.
    pub fn entries(&self) -> Vec<(&'static str, f64)> {
        Stage::ALL
            .iter()
            .map(|s| (s.name(), self.get(*s)))
            .collect()
    }
}

impl Serialize for StageTimes {
    /// A map from each stage's name to its seconds, in [`Stage::ALL`]'s order.
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut m = serializer.serialize_map(Some(Stage::ALL.len()))?;
        for (name, seconds) in self.entries() {
            m.serialize_entry(name, &seconds)?;
        }
        m.end()
    }
}

thread_local! {
    static TALLY: RefCell<StageTimes> = RefCell::new(StageTimes::default());
}

/// Adds `seconds` to this thread's tally of `stage`.
pub fn add(stage: Stage, seconds: f64) {
    TALLY.with(|t| t.borrow_mut().add(stage, seconds));
}

/// Runs `f`, adding its wall-clock time to this thread's tally of `stage`.
///
/// ```
/// use millcomp_closedloop::profile::{Stage, take, timed};
/// take(); // start from an empty tally
/// let x = timed(Stage::Bounds, || (1..=10).sum::<u32>());
/// assert_eq!(x, 55);
/// let t = take();
/// assert!(t.get(Stage::Bounds) >= 0.0 && t.get(Stage::Solve) == 0.0);
/// assert_eq!(take().total(), 0.0); // taken: the tally starts again
/// ```
pub fn timed<R>(stage: Stage, f: impl FnOnce() -> R) -> R {
    let t0 = Instant::now();
    let r = f();
    add(stage, t0.elapsed().as_secs_f64());
    r
}

/// This thread's tally since the last call (the QP solves of `millcomp-mpc` included), and starts it
/// again from zero.
pub fn take() -> StageTimes {
    let mut t = TALLY.with(|t| std::mem::take(&mut *t.borrow_mut()));
    t.add(Stage::Solve, millcomp_mpc::stats::take_qp_solve_s());
    t
}
