//! The NC stage's physical-limit references (issue 16): the smallest wall error *any* controller that
//! corrects the y axis' position reference once per NC cycle could leave, given the true axis and the
//! truth's deflection known in advance — what [`crate::optimum`] is for the PZT groove.
//!
//! The programme ([`crate::optimum::LinearProgramme`], Clarabel): one correction `u_m` per NC cycle
//! within the correction limits (range, slew per cycle; the same [`CorrectionLimits`] every controller
//! is held to), the true y axis (sim's [`FeedAxis`]: its dead time and its position loop) turning the
//! held corrections into the axis position `y` at the stage step each wall point is generated in, the
//! wall point's error `y + δ` with `δ` the deflection the run met there (controller-independent: the
//! deflection depends on the x axis and the spindle only), and the contour device's noise-free linear
//! map ([`ContourDevice::linear_map`]) from wall points to the measured contour, plus this run's own
//! contour noise (the deflection-only wall measured with the run's seed). It minimises the largest
//! error over a window of the measured contour — about 0, or about a free constant per segment — so it
//! is a lower bound of the same run's measured figure for every controller: a controller is one
//! particular correction sequence. Before the window the axis may be in any state: the programme's
//! corrections start one axis settling time (to 1e-12 of a step) before the first wall point that
//! matters, at rest at a free level.
//!
//! What the bound does *not* hold a controller to: information. It knows the deflection at every
//! tooth pass — the runout's ripple, the tooth phase, the force model's true shape — which a
//! controller can only estimate; a gap between a controller and the bound is information or control
//! design, not the axis.

use millcomp_mpc::nc_axis::CorrectionLimits;
use millcomp_sim::nc_axis::{AxisDynamics, ContourDevice, FeedAxis, WallPoint};

use crate::error::{ClosedLoopError, invalid};
use crate::optimum::LinearProgramme;

/// Largest number of interior-point iterations of one bound.
const MAX_ITER: u32 = 200;

/// How the error of a segment is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// About 0 (a peak, a wall within ±h).
    Zero,
    /// About a constant of the segment's own, free (an excess over a settled level).
    Free,
}

/// A stretch of the measured contour the bound covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// From (mm).
    pub from_mm: f64,
    /// To (mm), inclusive.
    pub to_mm: f64,
    /// About 0 or a free constant.
    pub level: Level,
}

/// What one run gives the bound: its wall, the truth's y axis and the measurement.
#[derive(Debug, Clone, Copy)]
pub struct NcBoundSetup<'a> {
    /// The run's wall points (deflection and the time of the step that generated each).
    pub wall: &'a [WallPoint],
    /// The true y axis.
    pub axis: &'a AxisDynamics,
    /// The stage step (s).
    pub dt_s: f64,
    /// Stage steps per NC cycle.
    pub steps_per_cycle: usize,
    /// The correction's limits.
    pub limits: &'a CorrectionLimits,
    /// The contour device.
    pub device: &'a ContourDevice,
    /// The measured range (mm): where the run's contour starts.
    pub from_mm: f64,
    /// The measured range's end (mm).
    pub to_mm: f64,
    /// The contour of the deflection alone, measured with the run's seed (`(x_mm, error_um)`, the same
    /// grid): the uncompensated wall including this measurement's noise.
    pub uncompensated: &'a [(f64, f64)],
}

/// The axis' response at each stage step to a unit set-point latched at step 0 from rest (a cycle
/// start: with fine interpolation it reaches the loop over the cycle's `steps_per_cycle` steps), until
/// it is within 1e-12 of 1 (at most 60 s of steps).
fn step_response(
    axis: &AxisDynamics,
    dt_s: f64,
    steps_per_cycle: usize,
) -> Result<Vec<f64>, ClosedLoopError> {
    let mut ax = FeedAxis::new(axis, dt_s, 0.0, steps_per_cycle)?;
    let mut s = Vec::new();
    let max = (60.0 / dt_s).ceil() as usize;
    let mut settled = 0usize;
    while s.len() < max {
        let y = ax.step(1.0);
        s.push(y);
        if (y - 1.0).abs() < 1e-12 {
            settled += 1;
            // a few cycles' worth within 1e-12: the position loop has settled
            if settled > 200 {
                break;
            }
        } else {
            settled = 0;
        }
    }
    Ok(s)
}

impl NcBoundSetup<'_> {
    /// The smallest largest error (µm) over `segments` of the measured contour any controller could
    /// leave (module doc): `None` when no contour point or wall point falls in the segments, or the
    /// programme did not solve (reported, not an error).
    ///
    /// # Errors
    /// [`ClosedLoopError::InvalidConfig`] naming `steps_per_cycle`, `dt_s` or `uncompensated` for an
    /// inconsistent set-up; the axis' and the contour device's errors.
    pub fn bound(&self, segments: &[Segment]) -> Result<Option<f64>, ClosedLoopError> {
        let l = self.steps_per_cycle;
        if l == 0 {
            return Err(invalid("steps_per_cycle", 0, ">= 1"));
        }
        if !(self.dt_s.is_finite() && self.dt_s > 0.0) {
            return Err(invalid("dt_s", self.dt_s, "> 0"));
        }
        let map = self
            .device
            .linear_map(self.wall, self.from_mm, self.to_mm)?;
        if map.len() != self.uncompensated.len() {
            return Err(invalid(
                "uncompensated",
                self.uncompensated.len(),
                format!("the contour of the measured range ({} points)", map.len()),
            ));
        }
        // the contour rows in the segments, with their segment
        let rows: Vec<(usize, usize)> = (0..map.len())
            .filter_map(|i| {
                let x = self.uncompensated[i].0;
                segments
                    .iter()
                    .position(|s| x >= s.from_mm && x <= s.to_mm)
                    .map(|g| (i, g))
            })
            .filter(|&(i, _)| !map[i].is_empty())
            .collect();
        if rows.is_empty() {
            return Ok(None);
        }
        // the wall points they use, each with its stage step
        let mut points: Vec<usize> = rows
            .iter()
            .flat_map(|&(i, _)| map[i].iter().map(|&(p, _)| p))
            .collect();
        points.sort_unstable();
        points.dedup();
        // a wall point's instant lies in a stage step: the step `k` whose end is at or after it, and
        // how far into it (`w` in (0, 1]; the axis' position interpolated between the steps' ends)
        let step_at = |p: usize| {
            let q = self.wall[p].t_s / self.dt_s;
            let k = (q.ceil() as i64 - 1).max(0);
            (k, (q - k as f64).clamp(0.0, 1.0))
        };
        let step_of = |p: usize| step_at(p).0;
        let s_resp = step_response(self.axis, self.dt_s, l)?;
        let settle_cycles = s_resp.len().div_ceil(l) as i64 + 1;
        let cycle_of = |s: i64| s.div_euclid(l as i64);
        let first = points.iter().map(|&p| cycle_of(step_of(p))).min();
        let last = points.iter().map(|&p| cycle_of(step_of(p))).max();
        let (Some(first), Some(last)) = (first, last) else {
            return Ok(None);
        };
        let m0 = first - settle_cycles;
        let n_u = (last - m0 + 1) as usize;
        let s_at = |k: i64| {
            if k < 0 {
                0.0
            } else {
                s_resp.get(k as usize).copied().unwrap_or(1.0)
            }
        };
        // variables: u_{m0..=last}, y_p, one constant per free segment, h
        let iu = |m: i64| (m - m0) as usize;
        let iy = |j: usize| n_u + j;
        let n_free = segments.iter().filter(|s| s.level == Level::Free).count();
        let ic0 = n_u + points.len();
        let ih = ic0 + n_free;
        let mut free_index = vec![None; segments.len()];
        let mut next = 0;
        for (g, s) in segments.iter().enumerate() {
            if s.level == Level::Free {
                free_index[g] = Some(ic0 + next);
                next += 1;
            }
        }
        let mut lp = LinearProgramme::new(ih + 1);
        let mut row: Vec<(usize, f64)> = Vec::new();
        // y_p = Σ_m u_m g(s_p − m L) (the corrections held over their cycles through the true axis);
        // before m0 the axis rests at u_{m0}
        // −a × (y at the end of step s) into `row`
        let end_of = |s: i64, a: f64, row: &mut Vec<(usize, f64)>| {
            if a == 0.0 {
                return;
            }
            let big_m = cycle_of(s);
            row.push((iu(m0), -a * (1.0 - s_at(s - (m0 + 1) * l as i64))));
            for m in (m0 + 1).max(big_m - settle_cycles - 1)..=big_m {
                let g = s_at(s - m * l as i64) - s_at(s - (m + 1) * l as i64);
                if g.abs() > 1e-15 {
                    row.push((iu(m), -a * g));
                }
            }
        };
        for (j, &p) in points.iter().enumerate() {
            let (k, w) = step_at(p);
            row.clear();
            row.push((iy(j), 1.0));
            end_of(k, w, &mut row);
            end_of((k - 1).max(0), 1.0 - w, &mut row);
            lp.eq(&row, 0.0);
        }
        // the correction's limits
        let (range, slew) = (self.limits.range_um, self.limits.slew_um_per_cycle);
        for m in m0..=last {
            lp.le(&[(iu(m), 1.0)], range);
            lp.le(&[(iu(m), -1.0)], range);
            if m > m0 {
                lp.le(&[(iu(m), 1.0), (iu(m - 1), -1.0)], slew);
                lp.le(&[(iu(m), -1.0), (iu(m - 1), 1.0)], slew);
            }
        }
        // the measured contour: e_i = Σ_p W_ip y_p + d_i
        let col: std::collections::HashMap<usize, usize> =
            points.iter().enumerate().map(|(j, &p)| (p, j)).collect();
        for &(i, g) in &rows {
            let d = self.uncompensated[i].1;
            if !d.is_finite() {
                continue;
            }
            let base: Vec<(usize, f64)> = map[i].iter().map(|&(p, w)| (iy(col[&p]), w)).collect();
            for sign in [1.0, -1.0] {
                row.clear();
                row.extend(base.iter().map(|&(c, w)| (c, sign * w)));
                if let Some(ic) = free_index[g] {
                    row.push((ic, -sign));
                }
                row.push((ih, -1.0));
                // sign·(W y + d − c) ≤ h
                lp.le(&row, -sign * d);
            }
        }
        Ok(lp
            .minimise(ih, MAX_ITER)
            .map(|z| z[ih])
            .filter(|h| h.is_finite())
            .map(|h| h.max(0.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall point at every 1 ms stage step, 0.01 mm apart, deflection `delta(k)`; a contour device
    /// whose filter is (almost) the identity on that grid (cut-off = spacing: the neighbours weigh
    /// 7e-7); an axis without dead time that follows its set-point within 1.3e-5 in one step (kv =
    /// 10⁴ 1/s, Tv = 10 µs at 1 ms); 4 steps per cycle.
    fn case(delta: impl Fn(usize) -> f64, slew: f64, segments: &[Segment]) -> Option<f64> {
        let dt = 1e-3;
        let wall: Vec<WallPoint> = (0..400)
            .map(|k| WallPoint {
                x_mm: 0.01 * k as f64,
                error_um: delta(k),
                deflection_um: delta(k),
                t_s: (k + 1) as f64 * dt,
            })
            .collect();
        let device = ContourDevice {
            spacing_mm: 0.01,
            noise_um: 0.0,
            cutoff_mm: 0.01,
        };
        let uncompensated = device.measure(&wall, 0.0, 3.99, 0).unwrap();
        let axis = AxisDynamics {
            dead_time_s: 0.0,
            kv_per_s: 1e4,
            velocity_loop_s: 1e-5,
            max_feed_mm_min: 1e4,
            fine_interpolation: false,
        };
        let limits = CorrectionLimits {
            range_um: 100.0,
            slew_um_per_cycle: slew,
        };
        NcBoundSetup {
            wall: &wall,
            axis: &axis,
            dt_s: dt,
            steps_per_cycle: 4,
            limits: &limits,
            device: &device,
            from_mm: 0.0,
            to_mm: 3.99,
            uncompensated: &uncompensated,
        }
        .bound(segments)
        .unwrap()
    }

    const ALL: [Segment; 1] = [Segment {
        from_mm: 0.5,
        to_mm: 3.5,
        level: Level::Zero,
    }];

    #[test]
    fn a_jump_within_a_cycle_leaves_half_of_it_and_one_on_the_cycle_grid_nothing() {
        // the axis position changes one step after each cycle start (steps 4m + 1): a 10 µm jump of
        // the deflection at step 203 falls inside the held stretch 201..=204 — half of it is left
        let b = case(|k| if k >= 203 { 10.0 } else { 0.0 }, 100.0, &ALL).unwrap();
        assert!((b - 5.0).abs() < 1e-4, "{b}");
        // the same jump at step 205, where the held position changes: followed (the axis' 1.3e-5 lag)
        let b = case(|k| if k >= 205 { 10.0 } else { 0.0 }, 100.0, &ALL).unwrap();
        assert!(b < 1e-3, "{b}");
        // about a free level on each side of 1.5 mm: the jump, inside the second, leaves the same;
        // split exactly at the jump (2.02 | 2.03 mm) each side is held level: nothing is left
        let seg = |from_mm, to_mm| Segment {
            from_mm,
            to_mm,
            level: Level::Free,
        };
        let jump = |k| if k >= 203 { 10.0 } else { 0.0 };
        let b = case(jump, 100.0, &[seg(0.5, 1.5), seg(1.51, 3.5)]).unwrap();
        assert!((b - 5.0).abs() < 1e-4, "{b}");
        let b = case(jump, 100.0, &[seg(0.5, 2.02), seg(2.03, 3.5)]).unwrap();
        assert!(b < 1e-3, "{b}");
    }

    #[test]
    fn the_slew_limit_spreads_a_step() {
        // 1 µm per cycle against a 10 µm step: the held position moves by at most 1 across it, so
        // |y| ≤ h before and |y + 10| ≤ h after need 10 − 2h ≤ 1: h = 4.5
        let b = case(|k| if k >= 205 { 10.0 } else { 0.0 }, 1.0, &ALL).unwrap();
        assert!((b - 4.5).abs() < 1e-4, "{b}");
    }
}
