//! A recorded sensor log through a controller: the commands it would have sent, and how long each
//! step took. (Not to be confused with `millcomp_mpc::replay`, which re-solves recorded QPs for the
//! solver bench.)

use std::time::Instant;

use crate::controller::{Command, Controller, Measurement};

/// The commands of a replay and its step times.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// One command per measurement.
    pub commands: Vec<Command>,
    /// The wall time of each step (ns), measured around the call.
    pub step_ns: Vec<u64>,
}

/// The distribution of a replay's step times (ns): the median, the 99th percentile and the longest
/// step, and the cycle it happened in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct StepTimes {
    /// Steps timed.
    pub steps: usize,
    /// Median (ns).
    pub median_ns: u64,
    /// 99th percentile, nearest rank (ns).
    pub p99_ns: u64,
    /// The longest step (ns).
    pub max_ns: u64,
    /// The cycle of the longest step.
    pub max_cycle: usize,
}

impl Replay {
    /// The step times' distribution (all zero for an empty replay).
    pub fn step_times(&self) -> StepTimes {
        step_times(&self.step_ns)
    }
}

/// The distribution of `step_ns` (nearest-rank percentiles).
///
/// ```
/// use millcomp_runtime::replay::step_times;
/// let t = step_times(&[5, 1, 3, 2, 4, 100]);
/// assert_eq!((t.median_ns, t.p99_ns, t.max_ns, t.max_cycle), (3, 100, 100, 5));
/// ```
pub fn step_times(step_ns: &[u64]) -> StepTimes {
    let mut sorted = step_ns.to_vec();
    sorted.sort_unstable();
    let rank = |p: f64| {
        if sorted.is_empty() {
            0
        } else {
            let r = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
            sorted[r.clamp(1, sorted.len()) - 1]
        }
    };
    let (max_cycle, max_ns) = step_ns
        .iter()
        .copied()
        .enumerate()
        .max_by_key(|&(_, t)| t)
        .unwrap_or((0, 0));
    StepTimes {
        steps: step_ns.len(),
        median_ns: rank(50.0),
        p99_ns: rank(99.0),
        max_ns,
        max_cycle,
    }
}

/// Step `controller` through `log` from its current state, one measurement per cycle; each step timed.
///
/// # Examples
/// ```
/// use millcomp_runtime::{Controller, Measurement, Program, replay::replay};
/// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
/// # let bundle = std::path::PathBuf::from(format!("{dir}bundle_s7.toml"));
/// # let program = std::path::PathBuf::from(format!("{dir}ramp_20deg.toml"));
/// let mut ctl = Controller::from_files(&bundle, &program).unwrap();
/// let log = vec![Measurement { x_mm: f64::NAN, force_n: 0.1, gauge_um: 0.0 }; 500];
/// let r = replay(&mut ctl, &log);
/// assert_eq!(r.commands.len(), 500);
/// // the same log from a reset controller gives the same commands, bit for bit
/// ctl.reset().unwrap();
/// let again = replay(&mut ctl, &log);
/// assert_eq!(r.commands, again.commands);
/// ```
pub fn replay(controller: &mut Controller, log: &[Measurement]) -> Replay {
    let mut commands = Vec::with_capacity(log.len());
    let mut step_ns = Vec::with_capacity(log.len());
    for m in log {
        let t0 = Instant::now();
        let c = controller.step(m);
        step_ns.push(u64::try_from(t0.elapsed().as_nanos()).unwrap_or(u64::MAX));
        commands.push(c);
    }
    Replay { commands, step_ns }
}
