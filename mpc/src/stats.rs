//! Per-run solver statistics (the `solver` object of the simulate JSON contract).

use std::cell::Cell;
use std::time::Duration;

use serde::{Deserialize, Serialize};

thread_local! {
    /// Nanoseconds this thread spent inside Clarabel's QP solves ([`take_qp_solve_s`]).
    static QP_SOLVE_NS: Cell<u64> = const { Cell::new(0) };
}

/// Adds one QP solve's duration to this thread's total.
pub(crate) fn add_qp_solve(d: Duration) {
    let ns = u64::try_from(d.as_nanos()).unwrap_or(u64::MAX);
    QP_SOLVE_NS.with(|c| c.set(c.get().saturating_add(ns)));
}

/// Seconds this thread spent inside QP solves (every controller's, [`crate::qp::CondensedQp`]) since the
/// last call, and starts counting again from 0 — for a harness's profile of where a run's time went
/// (a run executes on one thread).
///
/// ```
/// // nothing solved on this thread yet
/// assert_eq!(millcomp_mpc::stats::take_qp_solve_s(), 0.0);
/// ```
pub fn take_qp_solve_s() -> f64 {
    QP_SOLVE_NS.with(|c| c.replace(0)) as f64 * 1e-9
}

/// Solver statistics of one controller run: `{"solves", "median_us", "p99_us", "max_us", "fallbacks",
/// "budget_us", "deadline_misses", "budget_enforced"}`. Times are wall time per control cycle, from the cycle's start (the
/// measurement) to the emitted command, over the cycles that called the solver.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct SolverStats {
    /// Number of QP solves attempted (cycles where Clarabel was called).
    pub solves: usize,
    /// Median per-cycle time, µs.
    pub median_us: f64,
    /// 99th percentile of the per-cycle time, µs.
    pub p99_us: f64,
    /// Longest cycle, µs.
    #[serde(default)]
    pub max_us: f64,
    /// Cycles that used the fallback (previous plan shifted, then hold) instead of a fresh solution.
    pub fallbacks: usize,
    /// The per-cycle time budget, µs (0: none recorded).
    #[serde(default)]
    pub budget_us: f64,
    /// Cycles whose fresh plan was not ready within the budget (the solver stopped at the deadline, or
    /// the cycle ended late); each also counts as a fallback.
    #[serde(default)]
    pub deadline_misses: usize,
    /// The budget was enforced (a late plan replaced by the fallback), not only timed.
    #[serde(default)]
    pub budget_enforced: bool,
}

/// Percentile by the nearest-rank method on a copy of `samples` (`p` in 0..=100); 0 for an empty slice.
///
/// ```
/// use millcomp_mpc::stats::percentile;
/// let v = [5.0, 1.0, 3.0, 2.0, 4.0];
/// assert_eq!(percentile(&v, 50.0), 3.0);
/// assert_eq!(percentile(&v, 100.0), 5.0);
/// ```
pub fn percentile(samples: &[f64], p: f64) -> f64 {
    let mut v: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

impl SolverStats {
    /// Summarise raw per-cycle times.
    pub fn from_times(times_us: &[f64], fallbacks: usize) -> Self {
        Self {
            solves: times_us.len(),
            median_us: percentile(times_us, 50.0),
            p99_us: percentile(times_us, 99.0),
            max_us: percentile(times_us, 100.0),
            fallbacks,
            budget_us: 0.0,
            deadline_misses: 0,
            budget_enforced: false,
        }
    }

    /// The same statistics with the cycle budget (µs), the deadline misses against it and whether it
    /// was enforced.
    pub fn with_budget(self, budget_us: f64, deadline_misses: usize, enforced: bool) -> Self {
        Self {
            budget_us,
            deadline_misses,
            budget_enforced: enforced,
            ..self
        }
    }
}
