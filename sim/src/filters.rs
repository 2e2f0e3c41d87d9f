//! Discrete filters of the signal chains (`000_…txt` §6.2, §7.2; `003_…txt` §2.3).
//!
//! * [`Biquad`]: second-order sections discretised with the bilinear transform, pre-warped at the
//!   characteristic frequency (exact gain/phase there at any sample time below Nyquist): the 2nd-order
//!   500 Hz low-pass of the force and gauge signals (§7.2.1; damping not given → ζ = 1/√2 by default),
//!   the 6 Hz, D = 1 low-pass of the proactive controller and the notches of the reactive one (`003`).
//! * [`FirstOrderFilter`]: `y ← a·x + b·y`; the thesis' `0.0005 / 0.9995` (§7.2.2) per sample at the
//!   controller rate, generalised by its time constant `τ = −Δt/ln b` (the loop rate is not stated; we assume
//!   [`THESIS_LOOP_RATE_HZ`], giving τ ≈ 0.1 s).
//! * [`PeakHold`]: two nested maxima reset every 2 and 4 revolutions, out of phase (§6.2).
//! * [`NotchChain`]: notches at the tooth-passing harmonics `f0,i = n/60·i`, bandwidth `f0,i/4`, plus a
//!   first-order 120 Hz low-pass (`003_…txt` eqs. 6–7).
//! * [`SlidingMax`]: the one sliding peak detector — the maximum over the last `window` samples (one
//!   revolution: the groove stage's per-revolution peak force, §6.2, and the MPC's force measurement).

use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::f64::consts::PI;

use crate::error::{SimError, check_positive, check_range};

/// Assumed controller sample rate of the thesis (dSpace DS1104 loop; not stated in the seed), Hz.
pub const THESIS_LOOP_RATE_HZ: f64 = 20_000.0;

/// A second-order IIR section `y = (b0 x + b1 x₁ + b2 x₂ − a1 y₁ − a2 y₂)` (direct form II transposed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Biquad {
    /// Numerator coefficients (b0, b1, b2).
    pub b: [f64; 3],
    /// Denominator coefficients (a1, a2) with a0 = 1.
    pub a: [f64; 2],
    s1: f64,
    s2: f64,
}

fn check_freq(name: &'static str, f_hz: f64, dt_s: f64) -> Result<(), SimError> {
    check_positive("dt_s", dt_s)?;
    check_positive(name, f_hz)?;
    if f_hz >= 0.5 / dt_s {
        return Err(SimError::InvalidParameter {
            name,
            value: f_hz,
            allowed: "0 < frequency < Nyquist (0.5/dt_s)",
        });
    }
    Ok(())
}

impl Biquad {
    /// Tustin discretisation of `(n2 s² + n1 s + n0)/(s² + d1 s + d0)` pre-warped at `w_warp` rad/s.
    fn from_analog(n: [f64; 3], d: [f64; 2], w_warp: f64, dt_s: f64) -> Self {
        // s = k (1 − z⁻¹)/(1 + z⁻¹), k = w/tan(w dt/2)
        let k = w_warp / (0.5 * w_warp * dt_s).tan();
        let k2 = k * k;
        let (n2, n1, n0) = (n[0], n[1], n[2]);
        let (d1, d0) = (d[0], d[1]);
        let a0 = k2 + d1 * k + d0;
        let b0 = (n2 * k2 + n1 * k + n0) / a0;
        let b1 = (2.0 * n0 - 2.0 * n2 * k2) / a0;
        let b2 = (n2 * k2 - n1 * k + n0) / a0;
        let a1 = (2.0 * d0 - 2.0 * k2) / a0;
        let a2 = (k2 - d1 * k + d0) / a0;
        Self {
            b: [b0, b1, b2],
            a: [a1, a2],
            s1: 0.0,
            s2: 0.0,
        }
    }

    /// Second-order low-pass `ωc²/(s² + 2ζωc s + ωc²)`, cutoff `cutoff_hz`, damping `zeta`.
    ///
    /// ```
    /// use millcomp_sim::filters::Biquad;
    /// let mut f = Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, 1e-4).unwrap();
    /// let mut y = 0.0;
    /// for _ in 0..2000 { y = f.step(1.0); }
    /// assert!((y - 1.0).abs() < 1e-9); // unit DC gain
    /// ```
    pub fn low_pass(cutoff_hz: f64, zeta: f64, dt_s: f64) -> Result<Self, SimError> {
        check_freq("cutoff_hz", cutoff_hz, dt_s)?;
        check_range("zeta", zeta, 1e-3, 10.0, "0.001 <= zeta <= 10")?;
        let w = 2.0 * PI * cutoff_hz;
        Ok(Self::from_analog(
            [0.0, 0.0, w * w],
            [2.0 * zeta * w, w * w],
            w,
            dt_s,
        ))
    }

    /// Notch `(s² + ω0²)/(s² + ωb s + ω0²)` at `f0_hz` with −3 dB bandwidth `bandwidth_hz`.
    pub fn notch(f0_hz: f64, bandwidth_hz: f64, dt_s: f64) -> Result<Self, SimError> {
        check_freq("f0_hz", f0_hz, dt_s)?;
        check_positive("bandwidth_hz", bandwidth_hz)?;
        let w0 = 2.0 * PI * f0_hz;
        let wb = 2.0 * PI * bandwidth_hz;
        Ok(Self::from_analog(
            [1.0, 0.0, w0 * w0],
            [wb, w0 * w0],
            w0,
            dt_s,
        ))
    }

    /// Filter one sample.
    #[inline]
    pub fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.s1;
        self.s1 = self.b[1] * x - self.a[0] * y + self.s2;
        self.s2 = self.b[2] * x - self.a[1] * y;
        y
    }

    /// Reset the state so that a constant input `x` is in equilibrium.
    pub fn reset_to(&mut self, x: f64) {
        let g = (self.b[0] + self.b[1] + self.b[2]) / (1.0 + self.a[0] + self.a[1]);
        let y = g * x;
        self.s2 = self.b[2] * x - self.a[1] * y;
        self.s1 = y - self.b[0] * x;
    }

    /// Magnitude of the frequency response at `f_hz` for sample time `dt_s`.
    pub fn gain_at(&self, f_hz: f64, dt_s: f64) -> f64 {
        let w = 2.0 * PI * f_hz * dt_s;
        let (c1, s1) = (w.cos(), -w.sin());
        let (c2, s2) = ((2.0 * w).cos(), -(2.0 * w).sin());
        let num_re = self.b[0] + self.b[1] * c1 + self.b[2] * c2;
        let num_im = self.b[1] * s1 + self.b[2] * s2;
        let den_re = 1.0 + self.a[0] * c1 + self.a[1] * c2;
        let den_im = self.a[0] * s1 + self.a[1] * s2;
        (num_re.hypot(num_im)) / (den_re.hypot(den_im))
    }
}

/// First-order recursive filter `y ← a·x + b·y`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FirstOrderFilter {
    /// Input coefficient a.
    pub a: f64,
    /// Feedback coefficient b.
    pub b: f64,
    y: f64,
}

impl FirstOrderFilter {
    /// From explicit coefficients (`0 ≤ b < 1`, `a > 0`).
    pub fn from_coeffs(a: f64, b: f64) -> Result<Self, SimError> {
        check_range("b", b, 0.0, 0.999_999_999, "0 <= b < 1")?;
        check_positive("a", a)?;
        Ok(Self { a, b, y: 0.0 })
    }

    /// Unit-DC-gain filter with time constant `tau_s` at sample time `dt_s`: `b = e^{−Δt/τ}`, `a = 1 − b`.
    pub fn from_time_constant(tau_s: f64, dt_s: f64) -> Result<Self, SimError> {
        check_positive("tau_s", tau_s)?;
        check_positive("dt_s", dt_s)?;
        let b = (-dt_s / tau_s).exp();
        Self::from_coeffs(1.0 - b, b)
    }

    /// First-order low-pass with cutoff `cutoff_hz` (τ = 1/(2π f)).
    pub fn low_pass(cutoff_hz: f64, dt_s: f64) -> Result<Self, SimError> {
        check_positive("cutoff_hz", cutoff_hz)?;
        Self::from_time_constant(1.0 / (2.0 * PI * cutoff_hz), dt_s)
    }

    /// The thesis' `y = 0.0005·x + 0.9995·y` (§7.2.2) carried to sample time `dt_s` through its time constant
    /// at [`THESIS_LOOP_RATE_HZ`].
    ///
    /// ```
    /// use millcomp_sim::filters::{FirstOrderFilter, THESIS_LOOP_RATE_HZ};
    /// let f = FirstOrderFilter::thesis(1.0 / THESIS_LOOP_RATE_HZ).unwrap();
    /// assert!((f.a - 0.0005).abs() < 1e-7 && (f.b - 0.9995).abs() < 1e-7);
    /// ```
    pub fn thesis(dt_s: f64) -> Result<Self, SimError> {
        Self::from_time_constant(Self::thesis_time_constant_s(), dt_s)
    }

    /// Time constant of the thesis' filter: `−Δt/ln(0.9995)` at [`THESIS_LOOP_RATE_HZ`] (≈ 0.1 s).
    pub fn thesis_time_constant_s() -> f64 {
        -(1.0 / THESIS_LOOP_RATE_HZ) / 0.9995f64.ln()
    }

    /// Filter one sample.
    #[inline]
    pub fn step(&mut self, x: f64) -> f64 {
        self.y = self.a * x + self.b * self.y;
        self.y
    }

    /// Current output.
    pub fn value(&self) -> f64 {
        self.y
    }

    /// Set the state.
    pub fn reset_to(&mut self, y: f64) {
        self.y = y;
    }
}

/// Nested peak-and-hold (`000_…txt` §6.2): an inner maximum reset every `inner_period_s` (2 revolutions),
/// an outer maximum of the inner one reset every `outer_period_s` (4 revolutions) with a phase offset so
/// both never reset together; on an outer reset the output restarts from the inner maximum (no drop to 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PeakHold {
    inner_period_s: f64,
    outer_period_s: f64,
    outer_phase_s: f64,
    t_s: f64,
    inner: f64,
    outer: f64,
    next_inner_reset_s: f64,
    next_outer_reset_s: f64,
}

impl PeakHold {
    /// Build with explicit periods and outer phase offset (s).
    pub fn new(
        inner_period_s: f64,
        outer_period_s: f64,
        outer_phase_s: f64,
    ) -> Result<Self, SimError> {
        check_positive("inner_period_s", inner_period_s)?;
        check_positive("outer_period_s", outer_period_s)?;
        check_range(
            "outer_phase_s",
            outer_phase_s,
            0.0,
            outer_period_s,
            "0 <= outer_phase_s <= outer_period_s",
        )?;
        Ok(Self {
            inner_period_s,
            outer_period_s,
            outer_phase_s,
            t_s: 0.0,
            inner: f64::NEG_INFINITY,
            outer: f64::NEG_INFINITY,
            next_inner_reset_s: inner_period_s,
            next_outer_reset_s: outer_period_s + outer_phase_s,
        })
    }

    /// The thesis' setting at `speed_rpm`: resets every 2 and 4 revolutions (12/24 ms at 10 000 rpm), the
    /// outer one offset by one revolution.
    pub fn thesis(speed_rpm: f64) -> Result<Self, SimError> {
        check_positive("speed_rpm", speed_rpm)?;
        let rev = 60.0 / speed_rpm;
        Self::new(2.0 * rev, 4.0 * rev, rev)
    }

    /// Feed one sample taken at the end of an interval `dt_s`; returns the held peak.
    #[inline]
    pub fn step(&mut self, x: f64, dt_s: f64) -> f64 {
        self.t_s += dt_s;
        if self.t_s >= self.next_inner_reset_s {
            self.inner = f64::NEG_INFINITY;
            self.next_inner_reset_s += self.inner_period_s;
        }
        self.inner = self.inner.max(x);
        if self.t_s >= self.next_outer_reset_s {
            self.outer = self.inner;
            self.next_outer_reset_s += self.outer_period_s;
        }
        self.outer = self.outer.max(self.inner);
        self.outer
    }

    /// Current held value (NEG_INFINITY before the first sample).
    pub fn value(&self) -> f64 {
        self.outer
    }
}

/// Reactive filter of `003_…txt` §2.3: notches at `n/60·i` (i = 1..=teeth, bandwidth f0/4) followed by a
/// first-order 120 Hz low-pass. Harmonics at or above Nyquist are skipped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotchChain {
    /// The notch sections.
    pub notches: Vec<Biquad>,
    /// The final low-pass.
    pub lowpass: FirstOrderFilter,
}

impl NotchChain {
    /// Build for `speed_rpm`, `teeth` cutting edges, low-pass cutoff `lowpass_hz`, sample time `dt_s`.
    pub fn new(speed_rpm: f64, teeth: u32, lowpass_hz: f64, dt_s: f64) -> Result<Self, SimError> {
        check_positive("speed_rpm", speed_rpm)?;
        check_positive("dt_s", dt_s)?;
        if teeth == 0 {
            return Err(SimError::InvalidParameter {
                name: "teeth",
                value: 0.0,
                allowed: ">= 1",
            });
        }
        let mut notches = Vec::new();
        for i in 1..=teeth {
            let f0 = speed_rpm / 60.0 * i as f64;
            if f0 < 0.5 / dt_s * 0.98 {
                notches.push(Biquad::notch(f0, f0 / 4.0, dt_s)?);
            }
        }
        Ok(Self {
            notches,
            lowpass: FirstOrderFilter::low_pass(lowpass_hz, dt_s)?,
        })
    }

    /// `003_…txt`: 1990 rpm, 5 teeth, 120 Hz low-pass at the 500 Hz position-control rate.
    pub fn reactive_003() -> Result<Self, SimError> {
        Self::new(1990.0, 5, 120.0, 1.0 / 500.0)
    }

    /// Notches at the given centre frequencies (bandwidth f0/4 each, eq. 7) and the first-order low-pass,
    /// at sample time `dt_s`. Unlike [`NotchChain::new`], a frequency at or above Nyquist is an error,
    /// not skipped.
    ///
    /// ```
    /// use millcomp_sim::filters::NotchChain;
    /// let c = NotchChain::at_frequencies(&[33.2, 165.8], 120.0, 1e-4).unwrap();
    /// assert_eq!(c.notches.len(), 2);
    /// // 6 kHz is above the 5 kHz Nyquist frequency of a 10 kHz channel
    /// assert!(NotchChain::at_frequencies(&[6000.0], 120.0, 1e-4).is_err());
    /// ```
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `f0_hz` for a frequency that is not finite, not positive or
    /// not below Nyquist (`0.5/dt_s`), and those of the low-pass (`cutoff_hz`, `dt_s`).
    pub fn at_frequencies(f0_hz: &[f64], lowpass_hz: f64, dt_s: f64) -> Result<Self, SimError> {
        let notches = f0_hz
            .iter()
            .map(|&f0| Biquad::notch(f0, f0 / 4.0, dt_s))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            notches,
            lowpass: FirstOrderFilter::low_pass(lowpass_hz, dt_s)?,
        })
    }

    /// The frequencies the reactive chain notches on a force channel sampled every `dt_s`: the spindle
    /// harmonics `n/60·i`, i = 1..=teeth (`003_…txt` eq. 6; a runout puts force at them), and the
    /// tooth-passing frequency's harmonics above them, all below 0.98 × Nyquist (the upper band edge of a
    /// notch closer to Nyquist would fold back).
    ///
    /// ```
    /// use millcomp_sim::filters::NotchChain;
    /// // 003: 1990 rpm, 5 teeth; a 10 kHz force channel (Nyquist 5 kHz): 33.2 … 165.8 Hz, then
    /// // 331.7 Hz … up to 29 × 165.8 = 4809 Hz
    /// let f = NotchChain::harmonics_003(1990.0, 5, 1e-4);
    /// assert_eq!(f.len(), 5 + 28);
    /// assert!((f[4] - 165.833).abs() < 1e-3 && (f[32] - 4809.17).abs() < 1e-2);
    /// ```
    pub fn harmonics_003(speed_rpm: f64, teeth: u32, dt_s: f64) -> Vec<f64> {
        let limit = 0.98 * 0.5 / dt_s;
        let fs = speed_rpm / 60.0;
        let mut out: Vec<f64> = (1..=teeth)
            .map(|i| fs * i as f64)
            .filter(|f| *f < limit)
            .collect();
        let ft = fs * teeth as f64;
        let mut k = 2.0;
        while ft * k < limit && teeth > 0 {
            out.push(ft * k);
            k += 1.0;
        }
        out
    }

    /// Filter one sample.
    pub fn step(&mut self, x: f64) -> f64 {
        let mut y = x;
        for n in &mut self.notches {
            y = n.step(y);
        }
        self.lowpass.step(y)
    }
}

/// `003_…txt` proactive filter: second-order low-pass 6 Hz, D = 1, at sample time `dt_s`.
pub fn proactive_lowpass_003(dt_s: f64) -> Result<Biquad, SimError> {
    Biquad::low_pass(6.0, 1.0, dt_s)
}

/// Maximum over a sliding window of the last `window` samples (monotone deque, O(1) amortised).
///
/// ```
/// use millcomp_sim::filters::SlidingMax;
/// let mut m = SlidingMax::new(2);
/// assert_eq!(m.step(3.0), 3.0);
/// assert_eq!(m.step(1.0), 3.0);
/// assert_eq!(m.step(2.0), 2.0); // 3.0 has left the two-sample window
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SlidingMax {
    window: usize,
    k: usize,
    q: VecDeque<(usize, f64)>,
}

impl SlidingMax {
    /// Window length in samples (≥ 1).
    pub fn new(window: usize) -> Self {
        Self {
            window: window.max(1),
            k: 0,
            q: VecDeque::with_capacity(window.max(1) + 1),
        }
    }

    /// Feed one sample (non-finite samples are ignored), get the window maximum (0 before any sample).
    #[inline]
    pub fn step(&mut self, x: f64) -> f64 {
        if x.is_finite() {
            while self.q.back().is_some_and(|&(_, v)| v <= x) {
                self.q.pop_back();
            }
            self.q.push_back((self.k, x));
        }
        while self
            .q
            .front()
            .is_some_and(|&(i, _)| i + self.window <= self.k)
        {
            self.q.pop_front();
        }
        self.k += 1;
        self.q.front().map(|&(_, v)| v).unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn notch_kills_its_frequency_and_passes_dc() {
        let dt = 1.0 / 500.0;
        let n = Biquad::notch(33.17, 33.17 / 4.0, dt).unwrap();
        assert!(n.gain_at(33.17, dt) < 1e-9);
        assert_relative_eq!(n.gain_at(0.0, dt), 1.0, epsilon = 1e-12);
        // −3 dB at f0 ± bw/2 (analog definition, preserved near f0 by pre-warping): within 5 %
        let g = n.gain_at(33.17 + 33.17 / 8.0, dt);
        assert!((g - std::f64::consts::FRAC_1_SQRT_2).abs() < 0.05, "{g}");
    }

    #[test]
    fn lowpass_gain_at_cutoff() {
        // Butterworth (ζ = 1/√2): |H(fc)| = 1/√2 exactly with pre-warping
        let dt = 5e-5;
        let f = Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt).unwrap();
        assert_relative_eq!(
            f.gain_at(500.0, dt),
            std::f64::consts::FRAC_1_SQRT_2,
            epsilon = 1e-9
        );
    }

    #[test]
    fn peak_hold_never_drops_to_zero_and_tracks_decrease() {
        let rpm = 10_000.0;
        let rev = 60.0 / rpm;
        let dt = rev / 120.0;
        let mut ph = PeakHold::thesis(rpm).unwrap();
        let mut min_after_start = f64::INFINITY;
        // force amplitude 5 N for 10 revs then 2 N: the hold follows down within 4 revs + 1
        let mut out = Vec::new();
        for k in 0..(30 * 120) {
            let t = k as f64 * dt;
            let amp = if t < 10.0 * rev { 5.0 } else { 2.0 };
            let x = amp * (2.0 * PI * t / rev * 2.0).sin().max(0.0);
            let y = ph.step(x, dt);
            if k > 120 {
                min_after_start = min_after_start.min(y);
            }
            out.push(y);
        }
        assert!(min_after_start > 1.9);
        assert_relative_eq!(out[9 * 120], 5.0, epsilon = 0.01);
        assert_relative_eq!(*out.last().unwrap(), 2.0, epsilon = 0.01);
        assert_relative_eq!(out[16 * 120], 2.0, epsilon = 0.01);
    }

    #[test]
    fn thesis_first_order_generalises() {
        let tau = FirstOrderFilter::thesis_time_constant_s();
        assert_relative_eq!(tau, 0.09998, epsilon = 1e-4);
        // same time constant at another rate: step response at t = τ is 1 − 1/e
        for dt in [1e-5, 1e-4, 1e-3] {
            let mut f = FirstOrderFilter::thesis(dt).unwrap();
            let n = (tau / dt).round() as usize;
            let mut y = 0.0;
            for _ in 0..n {
                y = f.step(1.0);
            }
            assert_relative_eq!(y, 1.0 - (-1.0f64).exp(), epsilon = 0.01);
        }
    }

    #[test]
    fn notch_chain_removes_tooth_harmonics() {
        let mut c = NotchChain::reactive_003().unwrap();
        assert_eq!(c.notches.len(), 5);
        let dt = 1.0 / 500.0;
        let f0 = 1990.0 / 60.0;
        let mut y = 0.0;
        let mut maxdev: f64 = 0.0;
        for k in 0..5000 {
            let t = k as f64 * dt;
            let x = 10.0 + 3.0 * (2.0 * PI * f0 * t).sin() + 2.0 * (2.0 * PI * 2.0 * f0 * t).sin();
            y = c.step(x);
            if k > 4000 {
                maxdev = maxdev.max((y - 10.0).abs());
            }
        }
        assert!(maxdev < 0.01, "{maxdev}");
        assert_relative_eq!(y, 10.0, epsilon = 0.01);
    }

    #[test]
    fn sliding_max_follows_the_window() {
        let mut m = SlidingMax::new(3);
        let v: Vec<f64> = [1.0, 5.0, 2.0, 1.0, 1.0, 0.5]
            .iter()
            .map(|&x| m.step(x))
            .collect();
        assert_eq!(v, vec![1.0, 5.0, 5.0, 5.0, 2.0, 1.0]);
        // NaN samples are ignored
        assert_eq!(m.step(f64::NAN), 1.0);
    }

    #[test]
    fn sliding_max_window() {
        let mut s = SlidingMax::new(3);
        let xs = [1.0, 5.0, 2.0, 1.0, 0.5, 0.2, 4.0];
        let ys: Vec<f64> = xs.iter().map(|x| s.step(*x)).collect();
        assert_eq!(ys, vec![1.0, 5.0, 5.0, 5.0, 2.0, 1.0, 4.0]);
    }
}
