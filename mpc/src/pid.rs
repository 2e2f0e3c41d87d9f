//! The published PID (`000_…txt` §5.2.4–5.2.5, §7.2): error in µm, output in controller units, converted
//! to amplifier volts by the spindle's `loop_v_per_unit` (sim's fitted scale that makes the P-only critical
//! gain 3000), clamped to the amplifier range.
//!
//! Gains: tuned on the machine P = 400, I = 800 000, D = 0 ([`PidGains::tuned`]); root-locus design
//! P = 844, I = 130 820, D = 0.4 ([`PidGains::design`]). The derivative acts on the error through a
//! first-order roll-off (τ_d = 1/(2π·2 kHz), our choice: the thesis dropped D because of "the harshness of
//! the output signal").
//!
//! Anti-windup (the thesis had none and saw integral windup at the start of the cut, §7.2.2):
//! - [`AntiWindup::None`]: the integrator integrates regardless of saturation;
//! - [`AntiWindup::Clamping`]: conditional integration — the integrator is frozen while the output is
//!   saturated and the error would drive it further into saturation;
//! - [`AntiWindup::BackCalculation`]: `İ += e + (u_sat − u)/(T_t·K_i)`-style feedback of the saturation
//!   excess with tracking time constant `tracking_s`.

use serde::{Deserialize, Serialize};

/// PID gains (error in µm → controller units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PidGains {
    /// Proportional gain.
    pub p: f64,
    /// Integral gain (per s).
    pub i: f64,
    /// Derivative gain (s).
    pub d: f64,
}

impl PidGains {
    /// Machine-tuned gains P 400, I 800 000, D 0 (`000_…txt` §5.2.5).
    pub const fn tuned() -> Self {
        Self {
            p: 400.0,
            i: 800_000.0,
            d: 0.0,
        }
    }
    /// Root-locus design P 844, I 130 820, D 0.4 (`000_…txt` §5.2.4).
    pub const fn design() -> Self {
        Self {
            p: 844.0,
            i: 130_820.0,
            d: 0.4,
        }
    }
}

/// Anti-windup scheme.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum AntiWindup {
    /// No anti-windup (as published).
    #[default]
    None,
    /// Conditional integration.
    Clamping,
    /// Back-calculation with tracking time constant (s).
    BackCalculation {
        /// Tracking time constant T_t (s).
        tracking_s: f64,
    },
}

/// Discrete PID with output scaling and saturation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pid {
    /// Gains.
    pub gains: PidGains,
    /// Anti-windup scheme.
    pub anti_windup: AntiWindup,
    /// Controller units → volts.
    pub v_per_unit: f64,
    /// Output range (V).
    pub v_min: f64,
    /// Output range (V).
    pub v_max: f64,
    dt_s: f64,
    integral: f64,
    d_state: f64,
    prev_e: f64,
    started: bool,
    /// Cycles in which the output was saturated.
    pub saturated_cycles: usize,
}

/// Derivative roll-off frequency (Hz).
const D_ROLLOFF_HZ: f64 = 2000.0;

impl Pid {
    /// A PID at sample time `dt_s` with output `v_per_unit · u` clamped to `[v_min, v_max]`.
    ///
    /// ```
    /// use millcomp_mpc::pid::{AntiWindup, Pid, PidGains};
    /// let mut pid = Pid::new(PidGains::tuned(), AntiWindup::Clamping, 0.18, 0.0, 1000.0, 5e-5);
    /// // a constant error of 1 µm: P·e·scale = 72 V at once, then the integral ramps (800 000·0.18 V/s)
    /// let v0 = pid.step(1.0);
    /// assert!((v0 - (400.0 + 800_000.0 * 5e-5) * 0.18).abs() < 1e-9);
    /// ```
    pub fn new(
        gains: PidGains,
        anti_windup: AntiWindup,
        v_per_unit: f64,
        v_min: f64,
        v_max: f64,
        dt_s: f64,
    ) -> Self {
        Self {
            gains,
            anti_windup,
            v_per_unit,
            v_min,
            v_max,
            dt_s,
            integral: 0.0,
            d_state: 0.0,
            prev_e: 0.0,
            started: false,
            saturated_cycles: 0,
        }
    }

    /// One step with error `e` (µm): returns the clamped voltage. A non-finite error is treated as 0
    /// (the integrator holds) so NaN never reaches the amplifier.
    pub fn step(&mut self, e: f64) -> f64 {
        self.step_with_feedforward(e, 0.0)
    }

    /// One step with a feedforward voltage `v_ff` added to the PID's output before the saturation, so the
    /// anti-windup sees the sum (a non-finite `v_ff` counts as 0).
    pub fn step_with_feedforward(&mut self, e: f64, v_ff: f64) -> f64 {
        let e = if e.is_finite() { e } else { 0.0 };
        let v_ff = if v_ff.is_finite() { v_ff } else { 0.0 };
        if !self.started {
            self.prev_e = e;
            self.started = true;
        }
        // derivative of the error through a first-order roll-off
        let alpha = {
            let tau = 1.0 / (2.0 * std::f64::consts::PI * D_ROLLOFF_HZ);
            self.dt_s / (tau + self.dt_s)
        };
        let raw_d = (e - self.prev_e) / self.dt_s;
        self.d_state += alpha * (raw_d - self.d_state);
        self.prev_e = e;
        let g = self.gains;
        let integral_try = self.integral + g.i * e * self.dt_s;
        let u_try = g.p * e + integral_try + g.d * self.d_state;
        let v_try = self.v_per_unit * u_try + v_ff;
        let v_sat = v_try.clamp(self.v_min, self.v_max);
        let saturated = v_sat != v_try;
        if saturated {
            self.saturated_cycles += 1;
        }
        match self.anti_windup {
            AntiWindup::None => self.integral = integral_try,
            AntiWindup::Clamping => {
                let pushes_further =
                    (v_try > self.v_max && e > 0.0) || (v_try < self.v_min && e < 0.0);
                if !(saturated && pushes_further) {
                    self.integral = integral_try;
                }
            }
            AntiWindup::BackCalculation { tracking_s } => {
                let excess_units = (v_sat - v_try) / self.v_per_unit;
                self.integral =
                    integral_try + excess_units * (self.dt_s / tracking_s.max(self.dt_s));
            }
        }
        if !self.integral.is_finite() {
            self.integral = 0.0;
        }
        v_sat
    }

    /// Start bumplessly at `v_v` volts: the integrator is set so that a zero error holds `v_v` (a
    /// controller taking over a stack held at a bias). A non-finite `v_v` leaves the integrator alone.
    ///
    /// ```
    /// use millcomp_mpc::pid::{AntiWindup, Pid, PidGains};
    /// let mut pid = Pid::new(PidGains::tuned(), AntiWindup::Clamping, 0.18, 0.0, 1000.0, 5e-5);
    /// pid.start_at(120.0);
    /// assert!((pid.step(0.0) - 120.0).abs() < 1e-9);
    /// ```
    pub fn start_at(&mut self, v_v: f64) {
        if v_v.is_finite() && self.v_per_unit != 0.0 {
            self.integral = v_v / self.v_per_unit;
        }
    }

    /// Back to the state after construction: the integrator, the derivative's filter and the
    /// saturation count at zero, the next step the first.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.d_state = 0.0;
        self.prev_e = 0.0;
        self.started = false;
        self.saturated_cycles = 0;
    }

    /// Current integrator state (controller units).
    pub fn integral(&self) -> f64 {
        self.integral
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windup_and_its_cure() {
        // 0.5 s of a small negative error while the output sits at 0 V (the approach before contact),
        // then a positive error: without anti-windup the output stays at 0 V for a long time.
        let dt = 5e-5;
        let run = |aw: AntiWindup| {
            let mut pid = Pid::new(PidGains::tuned(), aw, 0.18, 0.0, 1000.0, dt);
            for _ in 0..10_000 {
                pid.step(-0.25);
            }
            let mut k_release = None;
            for k in 0..20_000 {
                if pid.step(1.0) > 1.0 && k_release.is_none() {
                    k_release = Some(k);
                }
            }
            k_release.unwrap_or(usize::MAX)
        };
        let none = run(AntiWindup::None);
        let clamp = run(AntiWindup::Clamping);
        let back = run(AntiWindup::BackCalculation { tracking_s: 1e-3 });
        // without anti-windup the integrator must first unwind 800 000·0.25·0.5 = 100 000 units at
        // 800 000 units/s per µm → ≈ 0.125 s = 2 500 samples
        assert!(none > 2000, "none released after {none}");
        assert!(clamp <= 1 && back <= 1, "clamp {clamp}, back {back}");
    }

    #[test]
    fn the_feedforward_is_inside_the_saturation_and_the_anti_windup_sees_it() {
        let dt = 5e-5;
        let mut pid = Pid::new(
            PidGains::tuned(),
            AntiWindup::Clamping,
            0.18,
            0.0,
            1000.0,
            dt,
        );
        // a feedforward alone, no error: passed through
        assert_eq!(pid.step_with_feedforward(0.0, 300.0), 300.0);
        // a feedforward beyond the range saturates the sum, and a positive error then does not wind up
        for _ in 0..1000 {
            assert_eq!(pid.step_with_feedforward(1.0, 1200.0), 1000.0);
        }
        assert_eq!(pid.integral(), 0.0);
        // NaN feedforward counts as 0
        let v = pid.step_with_feedforward(0.0, f64::NAN);
        assert!(v.is_finite() && (0.0..=1000.0).contains(&v));
    }

    #[test]
    fn nan_error_never_reaches_the_amplifier() {
        let mut pid = Pid::new(
            PidGains::design(),
            AntiWindup::None,
            0.18,
            0.0,
            1000.0,
            5e-5,
        );
        for k in 0..100 {
            let v = pid.step(if k % 3 == 0 { f64::NAN } else { 0.5 });
            assert!(v.is_finite() && (0.0..=1000.0).contains(&v));
        }
    }
}
