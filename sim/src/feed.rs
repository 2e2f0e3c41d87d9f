//! Feed motion along a cut: the programmed feed with its changes, executed by a feed axis with a finite
//! acceleration (`003_…txt` §3.2: "the feed axes carry out their nominal values only in a delayed
//! manner"; the reference acceleration is non-zero while the feed changes), and the workpiece edge where
//! the tool leaves the material (`003_…txt` §3.3, the cutter exiting the workpiece).
//!
//! The motion is piecewise: cruise at the programmed feed until the next change's position, then a
//! constant-acceleration segment to the new feed, then cruise again. A change whose position lies inside
//! the previous change's acceleration segment starts when that segment ends.

use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_positive};

/// A programmed feed change at a position along the cut.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedChange {
    /// Position (mm) where the NC block with the new feed starts.
    pub x_mm: f64,
    /// New upfeed (µm/rev); doubling 10 µm/rev as in `003_…txt` §3.1 is 20.
    pub upfeed_um: f64,
}

/// The workpiece edge where the tool leaves the material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkpieceExit {
    /// Position of the edge (mm): no material beyond it.
    pub x_mm: f64,
    /// Length (mm) before the edge over which the engagement falls linearly from 1 to 0 (the part of the
    /// tool's contact zone that is already past the edge).
    pub length_mm: f64,
}

impl WorkpieceExit {
    /// Engagement (0…1) of the tool with the material at tool position `x_mm`.
    ///
    /// ```
    /// use millcomp_sim::feed::WorkpieceExit;
    /// let e = WorkpieceExit { x_mm: 10.0, length_mm: 0.2 };
    /// assert_eq!(e.engagement(9.0), 1.0);
    /// assert!((e.engagement(9.9) - 0.5).abs() < 1e-12);
    /// assert_eq!(e.engagement(10.5), 0.0);
    /// ```
    pub fn engagement(&self, x_mm: f64) -> f64 {
        if self.length_mm <= 0.0 {
            return if x_mm < self.x_mm { 1.0 } else { 0.0 };
        }
        ((self.x_mm - x_mm) / self.length_mm).clamp(0.0, 1.0)
    }

    /// Validate against a cut of `length_mm`.
    pub fn validate(&self, cut_length_mm: f64) -> Result<(), SimError> {
        if !(self.x_mm > 0.0 && self.x_mm <= cut_length_mm) {
            return Err(SimError::InvalidParameter {
                name: "exit.x_mm",
                value: self.x_mm,
                allowed: "0 < exit.x_mm <= length_mm",
            });
        }
        if !(self.length_mm >= 0.0 && self.length_mm < self.x_mm) {
            return Err(SimError::InvalidParameter {
                name: "exit.length_mm",
                value: self.length_mm,
                allowed: "0 <= exit.length_mm < exit.x_mm",
            });
        }
        Ok(())
    }
}

/// One segment of the motion: from `t0_s` at `x0_mm` with velocity `v0_mm_s` and acceleration `a_mm_s2`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    t0_s: f64,
    x0_mm: f64,
    v0_mm_s: f64,
    a_mm_s2: f64,
}

impl Segment {
    fn x(&self, t_s: f64) -> f64 {
        let tau = t_s - self.t0_s;
        self.x0_mm + self.v0_mm_s * tau + 0.5 * self.a_mm_s2 * tau * tau
    }
    fn v(&self, t_s: f64) -> f64 {
        self.v0_mm_s + self.a_mm_s2 * (t_s - self.t0_s)
    }
    /// Time at which the segment reaches `x_mm` (assumes it does, with v > 0 throughout).
    fn t_at(&self, x_mm: f64) -> f64 {
        let dx = (x_mm - self.x0_mm).max(0.0);
        let a = self.a_mm_s2;
        let v = self.v0_mm_s;
        let tau = if a.abs() < 1e-15 {
            dx / v
        } else {
            // the root with the smaller τ ≥ 0: (−v + √(v² + 2 a dx)) / a, written stably
            2.0 * dx / (v + (v * v + 2.0 * a * dx).max(0.0).sqrt())
        };
        self.t0_s + tau
    }
}

/// The feed motion of a cut: position, velocity and upfeed against time.
#[derive(Debug, Clone, PartialEq)]
pub struct FeedProfile {
    segments: Vec<Segment>,
    /// Position at t = 0 (mm): 0, or −approach.
    start_mm: f64,
    length_mm: f64,
    mm_s_per_um_rev: f64,
    duration_s: f64,
}

impl FeedProfile {
    /// Build the motion of a cut of `length_mm` at `speed_rpm`, starting at `upfeed_um`, with the
    /// feed `changes` executed at `accel_mm_s2`.
    ///
    /// ```
    /// use millcomp_sim::feed::{FeedChange, FeedProfile};
    /// // 10 µm/rev at 10 000 rpm = 1.667 mm/s, doubling at x = 10 mm with 100 mm/s²
    /// let p = FeedProfile::new(20.0, 10_000.0, 10.0,
    ///     &[FeedChange { x_mm: 10.0, upfeed_um: 20.0 }], 100.0).unwrap();
    /// let t_change = 10.0 / (10.0 * 10_000.0 / 60.0 * 1e-3);
    /// assert!((p.x_at(t_change) - 10.0).abs() < 1e-9);
    /// assert!((p.upfeed_at(t_change + 1.0) - 20.0).abs() < 1e-9);
    /// // the acceleration takes (3.333 − 1.667)/100 = 16.7 ms; halfway the upfeed is 15 µm/rev
    /// assert!((p.upfeed_at(t_change + 0.5 * 1.6667 / 100.0) - 15.0).abs() < 1e-3);
    /// ```
    pub fn new(
        length_mm: f64,
        speed_rpm: f64,
        upfeed_um: f64,
        changes: &[FeedChange],
        accel_mm_s2: f64,
    ) -> Result<Self, SimError> {
        Self::with_approach(length_mm, speed_rpm, upfeed_um, changes, accel_mm_s2, 0.0)
    }

    /// As [`FeedProfile::new`], with the tool starting `approach_mm` before the cut (at x = −approach, in
    /// air) at the programmed feed: the NC program's approach, during which a controller that knows the
    /// program can pre-position its actuator before the entry.
    ///
    /// ```
    /// use millcomp_sim::feed::FeedProfile;
    /// // 0.5 mm of approach at 1.667 mm/s: the tool reaches x = 0 at 0.3 s and the end 12 s later
    /// let p = FeedProfile::with_approach(20.0, 10_000.0, 10.0, &[], 100.0, 0.5).unwrap();
    /// assert!((p.x_at(0.0) + 0.5).abs() < 1e-12);
    /// assert!((p.time_at_x(0.0) - 0.3).abs() < 1e-9);
    /// assert!((p.duration_s() - 12.3).abs() < 1e-9);
    /// ```
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `approach_mm` for a negative or non-finite approach, and
    /// those of [`FeedProfile::new`].
    pub fn with_approach(
        length_mm: f64,
        speed_rpm: f64,
        upfeed_um: f64,
        changes: &[FeedChange],
        accel_mm_s2: f64,
        approach_mm: f64,
    ) -> Result<Self, SimError> {
        if !(approach_mm.is_finite() && approach_mm >= 0.0) {
            return Err(SimError::InvalidParameter {
                name: "approach_mm",
                value: approach_mm,
                allowed: "finite, >= 0",
            });
        }
        check_positive("length_mm", length_mm)?;
        check_positive("speed_rpm", speed_rpm)?;
        check_positive("upfeed_um", upfeed_um)?;
        check_positive("feed_accel_mm_s2", accel_mm_s2)?;
        let k = speed_rpm / 60.0 * 1e-3; // mm/s per µm/rev
        let mut segments = vec![Segment {
            t0_s: 0.0,
            x0_mm: -approach_mm,
            v0_mm_s: upfeed_um * k,
            a_mm_s2: 0.0,
        }];
        let mut last_x = f64::NEG_INFINITY;
        for c in changes {
            if !(c.x_mm.is_finite() && c.x_mm >= 0.0 && c.x_mm <= length_mm) || c.x_mm < last_x {
                return Err(SimError::InvalidParameter {
                    name: "feed_changes.x_mm",
                    value: c.x_mm,
                    allowed: "0 <= x_mm <= length_mm, non-decreasing",
                });
            }
            last_x = c.x_mm;
            check_positive("feed_changes.upfeed_um", c.upfeed_um)?;
            let cruise = *segments.last().expect("at least one segment");
            let x_start = c.x_mm.max(cruise.x0_mm);
            let t_start = cruise.t_at(x_start);
            let v_old = cruise.v(t_start);
            let v_new = c.upfeed_um * k;
            if (v_new - v_old).abs() < 1e-12 {
                continue;
            }
            let a = accel_mm_s2.copysign(v_new - v_old);
            let dur = (v_new - v_old) / a;
            let acc = Segment {
                t0_s: t_start,
                x0_mm: x_start,
                v0_mm_s: v_old,
                a_mm_s2: a,
            };
            segments.push(acc);
            segments.push(Segment {
                t0_s: t_start + dur,
                x0_mm: acc.x(t_start + dur),
                v0_mm_s: v_new,
                a_mm_s2: 0.0,
            });
        }
        let mut p = Self {
            segments,
            start_mm: -approach_mm,
            length_mm,
            mm_s_per_um_rev: k,
            duration_s: 0.0,
        };
        p.duration_s = p.time_at_x(length_mm);
        Ok(p)
    }

    fn segment_at_t(&self, t_s: f64) -> &Segment {
        let i = self.segments.partition_point(|s| s.t0_s <= t_s);
        &self.segments[i.saturating_sub(1)]
    }

    /// Position (mm) at `t_s`, clamped to `[start, length]` (start: 0, or −approach).
    pub fn x_at(&self, t_s: f64) -> f64 {
        if t_s <= 0.0 {
            return self.start_mm;
        }
        self.segment_at_t(t_s)
            .x(t_s)
            .clamp(self.start_mm, self.length_mm)
    }

    /// Feed velocity (mm/s) at `t_s`.
    pub fn velocity_at(&self, t_s: f64) -> f64 {
        self.segment_at_t(t_s.max(0.0)).v(t_s.max(0.0))
    }

    /// Upfeed (µm/rev) at `t_s`: the velocity over the spindle's revolutions per second.
    pub fn upfeed_at(&self, t_s: f64) -> f64 {
        self.velocity_at(t_s) / self.mm_s_per_um_rev
    }

    /// Time (s) at which the tool reaches `x_mm` (0 for x at or before the start).
    pub fn time_at_x(&self, x_mm: f64) -> f64 {
        if x_mm <= self.start_mm {
            return 0.0;
        }
        // the last segment starting at or before x
        let i = self.segments.partition_point(|s| s.x0_mm <= x_mm);
        self.segments[i.saturating_sub(1)].t_at(x_mm)
    }

    /// Upfeed (µm/rev) when the tool is at `x_mm`.
    pub fn upfeed_at_x(&self, x_mm: f64) -> f64 {
        self.upfeed_at(self.time_at_x(x_mm))
    }

    /// Duration of the cut (s).
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Time intervals `(start_s, end_s)` in which the feed axis accelerates.
    pub fn accelerations(&self) -> Vec<(f64, f64)> {
        self.segments
            .windows(2)
            .filter(|w| w[0].a_mm_s2 != 0.0)
            .map(|w| (w[0].t0_s, w[1].t0_s))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn constant_feed_is_linear() {
        let p = FeedProfile::new(20.0, 10_000.0, 10.0, &[], 100.0).unwrap();
        // 10 µm/rev × 10 000 rpm / 60 = 1.6667 mm/s → 12 s for 20 mm
        assert_relative_eq!(p.duration_s(), 12.0, epsilon = 1e-12);
        assert_relative_eq!(p.x_at(6.0), 10.0, epsilon = 1e-12);
        assert_relative_eq!(p.time_at_x(5.0), 3.0, epsilon = 1e-12);
    }

    #[test]
    fn doubling_and_back_conserves_distance() {
        let ch = [
            FeedChange {
                x_mm: 5.0,
                upfeed_um: 20.0,
            },
            FeedChange {
                x_mm: 15.0,
                upfeed_um: 10.0,
            },
        ];
        let p = FeedProfile::new(20.0, 10_000.0, 10.0, &ch, 50.0).unwrap();
        // time_at_x inverts x_at everywhere, also inside the acceleration segments
        for i in 0..=200 {
            let x = 20.0 * i as f64 / 200.0;
            assert_relative_eq!(p.x_at(p.time_at_x(x)), x, epsilon = 1e-9);
        }
        let v1 = 10.0 * 10_000.0 / 60.0 * 1e-3;
        let dur_acc = v1 / 50.0;
        // the acceleration covers v1·τ + a τ²/2 = 1.5 v1 τ; the deceleration the same
        let expect = 5.0 / v1
            + dur_acc
            + (10.0 - 1.5 * v1 * dur_acc) / (2.0 * v1)
            + dur_acc
            + (5.0 - 1.5 * v1 * dur_acc) / v1;
        assert_relative_eq!(p.duration_s(), expect, epsilon = 1e-9);
        assert_eq!(p.accelerations().len(), 2);
        assert_relative_eq!(p.upfeed_at_x(10.0), 20.0, epsilon = 1e-9);
    }

    #[test]
    fn bad_changes_are_named() {
        let e = FeedProfile::new(
            20.0,
            10_000.0,
            10.0,
            &[FeedChange {
                x_mm: 25.0,
                upfeed_um: 20.0,
            }],
            100.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("feed_changes.x_mm"), "{e}");
        let e = FeedProfile::new(20.0, 10_000.0, 10.0, &[], 0.0).unwrap_err();
        assert!(e.to_string().contains("feed_accel_mm_s2"), "{e}");
        let x = WorkpieceExit {
            x_mm: 10.0,
            length_mm: 12.0,
        };
        assert!(
            x.validate(20.0)
                .unwrap_err()
                .to_string()
                .contains("exit.length_mm")
        );
    }
}
