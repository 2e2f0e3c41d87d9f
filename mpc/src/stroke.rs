//! Planning a whole cut within the actuator's reach (issue 14, *stroke-aware*).
//!
//! The depth error of a compensated groove is `e = z − δ`: the actuator's z-correction `z` (the PZT tip
//! travel × sin α, `0 ≤ z ≤ Z`) minus the tool's z-deflection `δ`. Where the deflection over the cut
//! spans more than the reach, `δ_max − δ_min > Z`, no command keeps the error at 0 everywhere; the
//! smallest peak-to-peak error is `W = δ_max − δ_min − Z` (static: the actuator is fast against the
//! process). [`StrokeBand`] is the plan that reaches it from the deflection the whole program will
//! cause: the band `[m, M]` of width `W` that the errors must lie in for every point of the cut to be
//! reachable, placed as close to 0 as the reach allows, and at each point the error target closest to 0
//! inside both the band and that point's own reachable interval `[−δ, Z − δ]`.
//!
//! A controller that only looks a horizon ahead treats the stroke limit as a surprise: it pre-moves
//! against a jump it then cannot follow, and its soft error bounds pull it toward errors it cannot reach.
//! Given the band's targets as its reference, it spends the stroke where the whole cut needs it.
//!
//! The same rule, fed the truth's deflection seen through the controllers' deflection-model error, gives
//! the harness's *certainty-equivalent optimum* (`millcomp_closedloop::optimum`).

/// The error band of a whole cut and the targets inside it (µm, z-direction; + = deeper).
///
/// # Examples
/// ```
/// use millcomp_mpc::stroke::StrokeBand;
/// // a 0–20 µm deflection ramp against a reach of 18.5 µm: 1.5 µm cannot be compensated, and it falls
/// // at the deep end, where the actuator is at the end of its travel
/// let ramp: Vec<f64> = (0..=200).map(|i| 0.1 * i as f64).collect();
/// let band = StrokeBand::new(&ramp, 18.5);
/// assert!((band.width_um() - 1.5).abs() < 1e-12);
/// assert_eq!(band.target_error_um(5.0), 0.0);
/// assert!((band.target_error_um(20.0) + 1.5).abs() < 1e-12);
/// // a constant-depth cut that needs 30–60 µm of z against 50 µm: no width, one constant offset
/// let band = StrokeBand::new(&[30.0, 60.0], 50.0);
/// assert_eq!(band.width_um(), 0.0);
/// assert_eq!(band.target_error_um(60.0), -10.0);
/// assert_eq!(band.target_error_um(30.0), -10.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeBand {
    lo_um: f64,
    hi_um: f64,
    reach_um: f64,
}

impl StrokeBand {
    /// The band for the deflections `deflection_um` the cut will meet (non-finite values ignored; an
    /// empty cut gives the band `[0, 0]`) and the actuator's z-reach `reach_um` (≥ 0).
    pub fn new(deflection_um: &[f64], reach_um: f64) -> Self {
        let (mut dmin, mut dmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for &d in deflection_um.iter().filter(|d| d.is_finite()) {
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
        Self::from_range(dmin, dmax, reach_um)
    }

    /// The band for deflections between `min_um` and `max_um` (an empty range, `min > max`, gives
    /// `[0, 0]`).
    pub fn from_range(min_um: f64, max_um: f64, reach_um: f64) -> Self {
        let reach = reach_um.max(0.0);
        if min_um > max_um || !min_um.is_finite() || !max_um.is_finite() {
            return Self {
                lo_um: 0.0,
                hi_um: 0.0,
                reach_um: reach,
            };
        }
        // every point needs e ∈ [−δ, Z − δ]: the band needs hi ≥ −δ_min and lo ≤ Z − δ_max
        let width = (max_um - min_um - reach).max(0.0);
        // the upper edge, as close to 0 as those two conditions allow with the smallest width
        let hi = 0.0f64.clamp(-min_um, reach - max_um + width);
        Self {
            lo_um: hi - width,
            hi_um: hi,
            reach_um: reach,
        }
    }

    /// Width of the band: the smallest peak-to-peak error reachable (µm).
    pub fn width_um(&self) -> f64 {
        self.hi_um - self.lo_um
    }

    /// The band's edges `(lo, hi)` (µm).
    pub fn edges_um(&self) -> (f64, f64) {
        (self.lo_um, self.hi_um)
    }

    /// The actuator's z-reach the band was planned for (µm).
    pub fn reach_um(&self) -> f64 {
        self.reach_um
    }

    /// The error to aim at where the deflection is `deflection_um`: the value closest to 0 inside the band
    /// and inside that point's reachable `[−δ, Z − δ]`.
    pub fn target_error_um(&self, deflection_um: f64) -> f64 {
        let lo = self.lo_um.max(-deflection_um);
        let hi = self.hi_um.min(self.reach_um - deflection_um);
        if lo > hi {
            // outside the deflections the band was planned for: the nearest reachable error
            return if -deflection_um > self.hi_um {
                -deflection_um
            } else {
                self.reach_um - deflection_um
            };
        }
        0.0f64.clamp(lo, hi)
    }

    /// The correction to command where the deflection is `deflection_um`: `δ + target` (µm, within
    /// `[0, Z]`).
    pub fn correction_um(&self, deflection_um: f64) -> f64 {
        (deflection_um + self.target_error_um(deflection_um)).clamp(0.0, self.reach_um)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_target_is_reachable_and_inside_the_band() {
        // deflections drawn over 0–40 µm against reaches from 0 to 50 µm
        let d: Vec<f64> = (0..400)
            .map(|i| 20.0 + 20.0 * ((i as f64) * 0.37).sin())
            .collect();
        for reach in [0.0, 5.0, 17.3, 39.9, 40.0, 50.0] {
            let b = StrokeBand::new(&d, reach);
            let (lo, hi) = b.edges_um();
            let e: Vec<f64> = d.iter().map(|&x| b.target_error_um(x)).collect();
            for (&x, &ei) in d.iter().zip(&e) {
                let z = x + ei;
                assert!(
                    (-1e-9..=reach + 1e-9).contains(&z),
                    "reach {reach}: z {z} at δ {x}"
                );
                assert!(ei >= lo - 1e-9 && ei <= hi + 1e-9);
            }
            let pp = e.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - e.iter().copied().fold(f64::INFINITY, f64::min);
            let range = d.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - d.iter().copied().fold(f64::INFINITY, f64::min);
            // the plan reaches the smallest pp there is: max(0, range − reach)
            assert!(
                (pp - (range - reach).max(0.0)).abs() < 1e-9,
                "reach {reach}: pp {pp}"
            );
        }
    }

    #[test]
    fn an_empty_cut_plans_nothing() {
        let b = StrokeBand::new(&[], 10.0);
        assert_eq!((b.width_um(), b.target_error_um(0.0)), (0.0, 0.0));
        assert_eq!(b.correction_um(3.0), 3.0);
    }
}
