//! The transient at a known process change, as issue 14 defines it: the *excess* a controller leaves
//! over its own settled error, so the stiffness floor every controller shares does not count.
//!
//! For a change at `c` (mm along the groove):
//! - `e_settled` is the controller's median error from [`SETTLED_FROM_MM`] to [`SETTLED_TO_MM`] after
//!   `c`;
//! - the *excess* is the largest `|error − e_settled|` from [`EXCESS_BEFORE_MM`] before `c` (the preview
//!   lead of every controller here is shorter: the MPC's horizon is ≈ 17 µm of travel) to
//!   [`EXCESS_AFTER_MM`] after it.
//!
//! Where the error sits at another level before a change than after it — in air before the entry the
//! error is the actuator's alone, in the cut it carries the deflection the commissioned model misjudges —
//! the excess holds that *level change* `|level_before − e_settled|` whatever the transient (the window
//! starts before the change), so a controller that learns its settled error only in the cut cannot
//! leave less. `level_before_um` is the median error from [`EXCESS_BEFORE_MM`] to [`BOUND_BEFORE_MM`]
//! before the change; [`ChangeExcess::beyond_level_um`] what the transient adds to the level change.
//!
//! The changes are the program's own: the entry when the tool enters at depth (`depth_at(0) > 0`), each
//! depth change (point-list corners closer than [`MERGE_MM`] are one change, e.g. a 50 µm plunge), each
//! feed change, and the exit. The exit has no groove after it, so there `e_settled` is taken from 4 to
//! 2 mm *before* the engagement starts to drop and the window runs from 1 mm before the drop to the edge
//! (this module's extension of the definition).

use millcomp_sim::groove::GrooveProgram;
use serde::{Deserialize, Serialize};

/// The excess window starts this far before the change (mm).
pub const EXCESS_BEFORE_MM: f64 = 1.0;
/// The excess window ends this far after the change (mm).
pub const EXCESS_AFTER_MM: f64 = 2.0;
/// The settled error is taken from this far after the change (mm) …
pub const SETTLED_FROM_MM: f64 = 2.0;
/// … to this far (mm).
pub const SETTLED_TO_MM: f64 = 4.0;
/// Depth-profile corners closer than this (mm) are one change.
pub const MERGE_MM: f64 = 0.5;
/// The lower bound of the excess ([`crate::optimum::excess_lower_bound`]) is computed over this much
/// before a change (mm) …
pub const BOUND_BEFORE_MM: f64 = 0.1;
/// … to this much after it (mm): the deflection's transition at the shipped changes (a feed ramp of
/// 17 ms, a 50 µm plunge, the ball's 0.17 mm entry) lies inside, and a shorter window than the excess's
/// can only lower the bound.
pub const BOUND_AFTER_MM: f64 = 0.3;

/// The stage-step index range `[lo, hi)` of the samples at `x_mm` (non-decreasing) in which a change at
/// `c` (mm) is bounded: [`BOUND_BEFORE_MM`] before to [`BOUND_AFTER_MM`] after (an exit: to the edge).
pub fn bound_window(kind: ChangeKind, c: f64, x_mm: &[f64]) -> std::ops::Range<usize> {
    let to = if kind == ChangeKind::Exit {
        f64::INFINITY
    } else {
        c + BOUND_AFTER_MM
    };
    span(x_mm, c - BOUND_BEFORE_MM, to)
}

/// The index range of the samples at `x_mm` (non-decreasing) with `a ≤ x ≤ b`.
fn span(x_mm: &[f64], a: f64, b: f64) -> std::ops::Range<usize> {
    let lo = x_mm.partition_point(|x| *x < a);
    let hi = x_mm.partition_point(|x| *x <= b);
    lo..hi.max(lo)
}

/// The errors of the samples with `a ≤ x ≤ b` (see [`span`]).
fn errors_between<'a>(x_mm: &[f64], error_um: &'a [f64], a: f64, b: f64) -> &'a [f64] {
    error_um.get(span(x_mm, a, b)).unwrap_or(&[])
}

/// The median of `v`, `None` when it is empty.
fn median_of(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| crate::stats::median(&mut v.to_vec()))
}

/// What changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum ChangeKind {
    /// The tool enters the workpiece at depth.
    Entry,
    /// The programmed depth changes.
    Depth,
    /// The programmed feed changes.
    Feed,
    /// The tool leaves the workpiece.
    Exit,
}

impl ChangeKind {
    /// Lower-case name (`entry`, `depth`, `feed`, `exit`), as serialised.
    pub fn name(self) -> &'static str {
        match self {
            ChangeKind::Entry => "entry",
            ChangeKind::Depth => "depth",
            ChangeKind::Feed => "feed",
            ChangeKind::Exit => "exit",
        }
    }
}

/// One change of a run and the excess the controller left there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ChangeExcess {
    /// What changes.
    pub kind: ChangeKind,
    /// Where (mm).
    pub x_mm: f64,
    /// The controller's settled error there (µm).
    pub settled_um: f64,
    /// Largest `|error − settled|` in the window (µm).
    pub excess_um: f64,
    /// The smallest excess any controller could leave there ([`crate::optimum::excess_lower_bound`]:
    /// the true actuator, the truth's deflection known in advance), µm; absent where it was not computed.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub bound_um: Option<f64>,
    /// The controller's median error from [`EXCESS_BEFORE_MM`] to [`BOUND_BEFORE_MM`] before the change
    /// (µm): the level it leaves (in air before an entry). Absent at an exit, whose settled error is
    /// taken before it, and where the window holds no sample.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub level_before_um: Option<f64>,
}

impl ChangeExcess {
    /// The level change `|level_before − settled|` (µm), part of every excess the window holds.
    pub fn level_change_um(&self) -> Option<f64> {
        self.level_before_um.map(|b| (b - self.settled_um).abs())
    }

    /// What the transient adds to the level change: `excess − |level_before − settled|` (µm, ≥ 0).
    ///
    /// ```
    /// use millcomp_closedloop::changes::{ChangeKind, excess};
    /// // 0 in air before an entry at 1 mm, −0.4 µm settled in the cut, one −0.7 µm dip after the entry
    /// let x: Vec<f64> = (0..600).map(|i| i as f64 * 0.01).collect();
    /// let e: Vec<f64> = x
    ///     .iter()
    ///     .map(|&x| if x < 1.0 { 0.0 } else if (x - 1.1).abs() < 0.005 { -0.7 } else { -0.4 })
    ///     .collect();
    /// let c = excess(&[(ChangeKind::Entry, 1.0)], &x, &e)[0];
    /// assert!((c.excess_um - 0.4).abs() < 1e-12); // |0 − (−0.4)| outweighs the dip's 0.3
    /// assert!((c.level_change_um().unwrap() - 0.4).abs() < 1e-12);
    /// assert!(c.beyond_level_um().unwrap().abs() < 1e-12);
    /// ```
    pub fn beyond_level_um(&self) -> Option<f64> {
        self.level_change_um()
            .map(|l| (self.excess_um - l).max(0.0))
    }
}

/// The program's process changes, in order of position.
///
/// ```
/// use millcomp_closedloop::changes::{ChangeKind, program_changes};
/// use millcomp_sim::feed::FeedChange;
/// use millcomp_sim::groove::{DepthProfile, GrooveProgram};
/// let mut p = GrooveProgram::thesis(20.0);
/// assert!(program_changes(&p).is_empty()); // a ramp from 0 µm: nothing changes at once
/// p.depth_profile = DepthProfile::Constant { depth_um: 40.0 };
/// p.feed_changes = vec![FeedChange { x_mm: 10.0, upfeed_um: 20.0 }];
/// assert_eq!(program_changes(&p), vec![(ChangeKind::Entry, 0.0), (ChangeKind::Feed, 10.0)]);
/// ```
pub fn program_changes(p: &GrooveProgram) -> Vec<(ChangeKind, f64)> {
    let mut out = Vec::new();
    if p.depth_at(0.0) > 0.0 {
        out.push((ChangeKind::Entry, 0.0));
    }
    let mut last = f64::NEG_INFINITY;
    for x in p.depth_profile.change_points_mm() {
        if x - last >= MERGE_MM {
            out.push((ChangeKind::Depth, x));
        }
        last = x;
    }
    out.extend(p.feed_changes.iter().map(|f| (ChangeKind::Feed, f.x_mm)));
    if let Some(e) = p.exit {
        out.push((ChangeKind::Exit, e.x_mm - e.length_mm));
    }
    out.sort_by(|a, b| a.1.total_cmp(&b.1));
    out
}

/// The excess at each change, from the engaged samples' positions `x_mm` (non-decreasing) and errors
/// `error_um` (same length). A change whose settled window holds no sample is left out.
///
/// ```
/// use millcomp_closedloop::changes::{ChangeKind, excess};
/// // 1 µm settled error everywhere, a 3 µm spike 0.5 mm after a change at 5 mm
/// let x: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
/// let e: Vec<f64> = x.iter().map(|&x| if (x - 5.5).abs() < 0.005 { 4.0 } else { 1.0 }).collect();
/// let r = excess(&[(ChangeKind::Depth, 5.0)], &x, &e);
/// assert_eq!((r[0].settled_um, r[0].excess_um), (1.0, 3.0));
/// ```
pub fn excess(changes: &[(ChangeKind, f64)], x_mm: &[f64], error_um: &[f64]) -> Vec<ChangeExcess> {
    let window = |a: f64, b: f64| errors_between(x_mm, error_um, a, b);
    changes
        .iter()
        .filter_map(|&(kind, c)| {
            let (settled, from, to) = if kind == ChangeKind::Exit {
                (
                    window(c - SETTLED_TO_MM, c - SETTLED_FROM_MM),
                    c - EXCESS_BEFORE_MM,
                    f64::INFINITY,
                )
            } else {
                (
                    window(c + SETTLED_FROM_MM, c + SETTLED_TO_MM),
                    c - EXCESS_BEFORE_MM,
                    c + EXCESS_AFTER_MM,
                )
            };
            let settled_um = median_of(settled)?;
            let excess_um = window(from, to)
                .iter()
                .map(|e| (e - settled_um).abs())
                .fold(0.0, f64::max);
            let level_before_um = level_before(kind, c, x_mm, error_um);
            Some(ChangeExcess {
                kind,
                x_mm: c,
                settled_um,
                excess_um,
                bound_um: None,
                level_before_um,
            })
        })
        .collect()
}

/// The median error from [`EXCESS_BEFORE_MM`] to [`BOUND_BEFORE_MM`] before a change at `c` (mm), from
/// samples at `x_mm` (non-decreasing) with errors `error_um`: [`ChangeExcess::level_before_um`]. `None`
/// at an exit or where no sample lies there. Before the entry the samples are the approach in air
/// (the groove's own samples start at the edge), which the closed loop passes here.
pub fn level_before(kind: ChangeKind, c: f64, x_mm: &[f64], error_um: &[f64]) -> Option<f64> {
    if kind == ChangeKind::Exit {
        return None;
    }
    median_of(errors_between(
        x_mm,
        error_um,
        c - EXCESS_BEFORE_MM,
        c - BOUND_BEFORE_MM,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_sim::feed::WorkpieceExit;
    use millcomp_sim::groove::DepthProfile;

    #[test]
    fn a_plunge_is_one_change_and_the_exit_settles_before() {
        let mut p = GrooveProgram::thesis(20.0);
        p.depth_profile = DepthProfile::Points {
            points: vec![(0.0, 40.0), (10.0, 40.0), (10.05, 60.0), (20.0, 60.0)],
        };
        p.exit = Some(WorkpieceExit {
            x_mm: 18.0,
            length_mm: 0.2,
        });
        assert_eq!(
            program_changes(&p),
            vec![
                (ChangeKind::Entry, 0.0),
                (ChangeKind::Depth, 10.0),
                (ChangeKind::Exit, 17.8)
            ]
        );
        // error −1 µm before 17.8 mm, +2 µm after it: the exit's excess is 3 over the settled −1
        let x: Vec<f64> = (0..1800).map(|i| i as f64 * 0.01).collect();
        let e: Vec<f64> = x
            .iter()
            .map(|&x| if x < 17.8 { -1.0 } else { 2.0 })
            .collect();
        let r = excess(&[(ChangeKind::Exit, 17.8)], &x, &e);
        assert_eq!((r[0].settled_um, r[0].excess_um), (-1.0, 3.0));
        // a change too close to the end to settle is left out
        assert!(excess(&[(ChangeKind::Feed, 16.5)], &x, &e).is_empty());
    }
}
