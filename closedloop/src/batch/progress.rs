//! The progress of a batch, as one line: runs done of the slice's total, the time left, and the
//! simulated machining seconds per wall-clock second. On a terminal the line is redrawn in place; on
//! anything else (a log file, a cluster's job output) a line is printed every tenth of the runs; a
//! caller can take the updates itself ([`ProgressMode::Callback`]) or have none.

use std::fmt;
use std::io::{IsTerminal, Write};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Where a batch's progress goes (by default nowhere: a library prints only when asked).
#[derive(Clone, Default)]
pub enum ProgressMode {
    /// A redrawn line on a terminal, a line every tenth of the runs otherwise (stderr).
    Auto,
    /// None (`--quiet`, `--json`).
    #[default]
    Quiet,
    /// The redrawn line on stderr.
    Bar,
    /// A line on stderr every tenth of the runs.
    Lines,
    /// Each update handed to the function (a notebook's own progress display).
    Callback(Arc<dyn Fn(&ProgressUpdate) + Send + Sync>),
}

impl fmt::Debug for ProgressMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ProgressMode::Auto => "Auto",
            ProgressMode::Quiet => "Quiet",
            ProgressMode::Bar => "Bar",
            ProgressMode::Lines => "Lines",
            ProgressMode::Callback(_) => "Callback",
        })
    }
}

/// One update: where the slice stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgressUpdate {
    /// Runs finished, now or by an earlier call (failed ones included).
    pub done: usize,
    /// Runs of the slice.
    pub total: usize,
    /// Runs found finished when this call started.
    pub resumed: usize,
    /// Runs that failed (now).
    pub failed: usize,
    /// Seconds since this call started.
    pub elapsed_s: f64,
    /// Estimated seconds to the end (from the pace of this call's runs; none before the first).
    pub eta_s: Option<f64>,
    /// Simulated machining seconds of this call's runs per wall-clock second.
    pub simulated_per_wall_s: f64,
}

impl ProgressUpdate {
    /// The line: `37/128 runs (2 resumed) | 1m12s left | 14.2 simulated s per wall s`.
    ///
    /// ```
    /// use millcomp_closedloop::batch::progress::ProgressUpdate;
    /// let u = ProgressUpdate {
    ///     done: 37, total: 128, resumed: 2, failed: 0, elapsed_s: 30.0, eta_s: Some(72.4),
    ///     simulated_per_wall_s: 14.24,
    /// };
    /// assert_eq!(u.line(), "37/128 runs (2 resumed) | 1m12s left | 14.2 simulated s per wall s");
    /// ```
    pub fn line(&self) -> String {
        let mut extra = Vec::new();
        if self.resumed > 0 {
            extra.push(format!("{} resumed", self.resumed));
        }
        if self.failed > 0 {
            extra.push(format!("{} failed", self.failed));
        }
        let extra = if extra.is_empty() {
            String::new()
        } else {
            format!(" ({})", extra.join(", "))
        };
        let left = if self.done >= self.total {
            format!("done in {}", duration(self.elapsed_s))
        } else {
            match self.eta_s {
                Some(s) => format!("{} left", duration(s)),
                None => "time left unknown yet".to_string(),
            }
        };
        format!(
            "{}/{} runs{extra} | {left} | {:.1} simulated s per wall s",
            self.done, self.total, self.simulated_per_wall_s
        )
    }
}

/// A duration for people: `1h02m`, `4m05s`, `12s`.
///
/// ```
/// use millcomp_closedloop::batch::progress::duration;
/// assert_eq!((duration(12.2), duration(245.0), duration(3725.0)), ("12s".into(), "4m05s".into(), "1h02m".into()));
/// ```
pub fn duration(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match (s / 3600, (s % 3600) / 60, s % 60) {
        (0, 0, sec) => format!("{sec}s"),
        (0, m, sec) => format!("{m}m{sec:02}s"),
        (h, m, _) => format!("{h}h{m:02}m"),
    }
}

#[derive(Debug)]
struct State {
    done: usize,
    ran: usize,
    failed: usize,
    simulated_s: f64,
    last_tenth: usize,
}

/// A batch's progress reporter (one per call).
pub(crate) struct Progress {
    mode: ProgressMode,
    bar: Option<ProgressBar>,
    total: usize,
    resumed: usize,
    start: Instant,
    state: Mutex<State>,
}

impl Progress {
    /// Starts reporting a slice of `total` runs of which `resumed` are already finished.
    pub(crate) fn start(mode: &ProgressMode, total: usize, resumed: usize) -> Self {
        let mode = match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
            ProgressMode::Auto => ProgressMode::Lines,
            m => m.clone(),
        };
        let bar = matches!(mode, ProgressMode::Bar).then(|| {
            let b = ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr());
            if let Ok(style) = ProgressStyle::with_template("batch: {msg}") {
                b.set_style(style);
            }
            b
        });
        let p = Self {
            mode,
            bar,
            total,
            resumed,
            start: Instant::now(),
            state: Mutex::new(State {
                done: resumed,
                ran: 0,
                failed: 0,
                simulated_s: 0.0,
                last_tenth: tenth(resumed, total),
            }),
        };
        let first = p.update(&p.lock());
        p.show(&first, true);
        p
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn update(&self, s: &State) -> ProgressUpdate {
        let elapsed_s = self.start.elapsed().as_secs_f64();
        let left = self.total.saturating_sub(s.done);
        ProgressUpdate {
            done: s.done,
            total: self.total,
            resumed: self.resumed,
            failed: s.failed,
            elapsed_s,
            eta_s: (s.ran > 0).then(|| elapsed_s / s.ran as f64 * left as f64),
            simulated_per_wall_s: if elapsed_s > 0.0 {
                s.simulated_s / elapsed_s
            } else {
                0.0
            },
        }
    }

    fn show(&self, u: &ProgressUpdate, line_now: bool) {
        match &self.mode {
            ProgressMode::Bar => {
                if let Some(b) = &self.bar {
                    b.set_position(u.done as u64);
                    b.set_message(u.line());
                }
            }
            ProgressMode::Lines if line_now => {
                let mut err = std::io::stderr().lock();
                let _ = writeln!(err, "batch: {}", u.line());
            }
            ProgressMode::Callback(f) => f(u),
            _ => {}
        }
    }

    /// One run finished (`simulated_s` of machining; `failed` when it failed).
    pub(crate) fn run_done(&self, simulated_s: f64, failed: bool) {
        let (u, line_now) = {
            let mut s = self.lock();
            s.done += 1;
            s.ran += 1;
            s.simulated_s += simulated_s;
            if failed {
                s.failed += 1;
            }
            let t = tenth(s.done, self.total);
            let line_now = t > s.last_tenth;
            s.last_tenth = t;
            (self.update(&s), line_now)
        };
        self.show(&u, line_now);
    }

    /// The last update; the redrawn line is cleared.
    pub(crate) fn finish(&self) -> ProgressUpdate {
        let u = self.update(&self.lock());
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
        u
    }
}

/// Which tenth of `total` `done` has reached (0–10).
fn tenth(done: usize, total: usize) -> usize {
    (10 * done).checked_div(total).unwrap_or(10)
}
