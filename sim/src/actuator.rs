//! What a linear model of the PZT actuator misses: rate-independent hysteresis and creep.
//!
//! * [`BoucWen`] — the Bouc–Wen hysteresis of a piezo stack in its rate-independent form (Low & Guo 1995;
//!   Goldfarb & Celanovic 1997), acting on the drive voltage before the stack's linear dynamics
//!   (a Hammerstein structure): `v_eff = s·(v − h)`, `dh = α·dv − β·|dv|·h − γ·dv·|h|`, with the scale `s`
//!   chosen so that the first rise from 0 to the amplifier's full voltage still reaches it (the published
//!   stroke at 1000 V stays the stroke). With β = γ the loop
//!   is symmetric; the defaults give a loop whose largest width over a full 0 → 1000 V → 0 cycle is
//!   [`BoucWen::DEFAULT_WIDTH_PCT`] = 12 % of the stroke, inside the 10–15 % typical of PZT stacks driven
//!   over their full range (issue 13; e.g. Physik Instrumente's "hysteresis 10–15 % of the travel" for
//!   open-loop stacks). The parameters are set from that figure, not from any controller result.
//! * [`LogCreep`] — the slow drift of a piezo after a step, `x(t) ≈ x₁(1 + γ_c·log₁₀(t/t₁))` with
//!   γ_c ≈ 1–2 % per decade (Jung & Gweon 2000), approximated over 1 ms … 100 s by first-order lags one
//!   decade apart, each adding γ_c·ln 10 ≈ γ_c per decade of the input's recent change.
//!
//! Both are rate independent or slow: at the groove's time scales they act as a gain that depends on the
//! drive history (hysteresis) and a small slow gain increase (creep).

use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_nonneg, check_positive};

/// Bouc–Wen hysteresis parameters (volts in, volts out).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoucWenParams {
    /// α: the hysteretic state's initial slope (dimensionless).
    pub alpha: f64,
    /// β (1/V): shapes the loop (with γ; β = γ gives a symmetric loop).
    pub beta_per_v: f64,
    /// γ (1/V).
    pub gamma_per_v: f64,
}

impl BoucWenParams {
    /// The defaults: 12 % loop width over a 1000 V full-range cycle (module documentation).
    pub const DEFAULT: BoucWenParams = BoucWenParams {
        alpha: 0.25,
        beta_per_v: 1.1e-3,
        gamma_per_v: 1.1e-3,
    };

    /// Checks the parameters (α in [0, 1), β, γ ≥ 0).
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.alpha.is_finite() && (0.0..1.0).contains(&self.alpha)) {
            return Err(SimError::InvalidParameter {
                name: "hysteresis.alpha",
                value: self.alpha,
                allowed: "0 <= alpha < 1",
            });
        }
        check_nonneg("hysteresis.beta_per_v", self.beta_per_v)?;
        check_nonneg("hysteresis.gamma_per_v", self.gamma_per_v)?;
        Ok(())
    }
}

impl Default for BoucWenParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The hysteresis operator with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct BoucWen {
    p: BoucWenParams,
    h: f64,
    last_v: f64,
    scale: f64,
}

impl BoucWen {
    /// Largest loop width of the defaults over a full 0 → 1000 V → 0 cycle, % of the stroke (tested).
    pub const DEFAULT_WIDTH_PCT: f64 = 12.0;

    /// A fresh (demagnetised, h = 0) operator for an amplifier of `v_max_v` (its first rise from 0 V to
    /// `v_max_v` ends at `v_max_v`).
    pub fn new(p: BoucWenParams, v_max_v: f64) -> Result<Self, SimError> {
        p.validate()?;
        check_positive("voltage_max_v", v_max_v)?;
        let mut probe = Self {
            p,
            h: 0.0,
            last_v: 0.0,
            scale: 1.0,
        };
        let top = probe.step(v_max_v);
        Ok(Self {
            p,
            h: 0.0,
            last_v: 0.0,
            scale: if top > 0.0 { v_max_v / top } else { 1.0 },
        })
    }

    /// The effective voltage for drive voltage `v_v` (rate independent: depends only on the path of `v`).
    /// Large increments are integrated in 1 V sub-steps so the result does not depend on the sample rate.
    pub fn step(&mut self, v_v: f64) -> f64 {
        let dv_total = v_v - self.last_v;
        let n = (dv_total.abs().ceil() as usize).clamp(1, 10_000);
        let dv = dv_total / n as f64;
        for _ in 0..n {
            let h = self.h;
            self.h += self.p.alpha * dv
                - self.p.beta_per_v * dv.abs() * h
                - self.p.gamma_per_v * dv * h.abs();
        }
        self.last_v = v_v;
        self.scale * (v_v - self.h)
    }
}

/// Creep parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogCreepParams {
    /// γ_c: relative creep per decade of time after a step (0.01–0.02 typical; Jung & Gweon 2000).
    pub per_decade: f64,
    /// Time constant of the fastest lag (s); the lags are one decade apart.
    pub first_tau_s: f64,
    /// Number of lags (decades covered).
    pub decades: usize,
}

impl LogCreepParams {
    /// 1.5 % per decade over 1 ms … 100 s (5 decades).
    pub const DEFAULT: LogCreepParams = LogCreepParams {
        per_decade: 0.015,
        first_tau_s: 1e-3,
        decades: 5,
    };

    /// Checks the parameters.
    pub fn validate(&self) -> Result<(), SimError> {
        check_nonneg("creep.per_decade", self.per_decade)?;
        check_positive("creep.first_tau_s", self.first_tau_s)?;
        if self.decades == 0 || self.decades > 12 {
            return Err(SimError::InvalidParameter {
                name: "creep.decades",
                value: self.decades as f64,
                allowed: "1 ..= 12",
            });
        }
        Ok(())
    }
}

impl Default for LogCreepParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The creep operator: `y = x + γ_c·Σᵢ lagᵢ(x)`, lag i with time constant `first_tau·10ⁱ`.
#[derive(Debug, Clone, PartialEq)]
pub struct LogCreep {
    gain: f64,
    coef: Vec<f64>,
    state: Vec<f64>,
}

impl LogCreep {
    /// Operator stepped every `dt_s`.
    pub fn new(p: LogCreepParams, dt_s: f64) -> Result<Self, SimError> {
        p.validate()?;
        check_positive("dt_s", dt_s)?;
        let coef = (0..p.decades)
            .map(|i| (-dt_s / (p.first_tau_s * 10f64.powi(i as i32))).exp())
            .collect();
        Ok(Self {
            gain: p.per_decade,
            coef,
            state: vec![0.0; p.decades],
        })
    }

    /// Output for input `x` (e.g. the stack's linear displacement).
    pub fn step(&mut self, x: f64) -> f64 {
        let mut extra = 0.0;
        for (s, a) in self.state.iter_mut().zip(&self.coef) {
            *s = a * *s + (1.0 - a) * x;
            extra += *s;
        }
        x + self.gain * extra
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Largest width of the loop between the rising and falling branch over a 0 → 1000 → 0 V cycle, in % of
    /// the output range.
    fn loop_width_pct(p: BoucWenParams, step_v: f64) -> f64 {
        let mut bw = BoucWen::new(p, 1000.0).unwrap();
        let n = (1000.0 / step_v) as usize;
        let up: Vec<f64> = (0..=n).map(|k| bw.step(k as f64 * step_v)).collect();
        let down: Vec<f64> = (0..=n).rev().map(|k| bw.step(k as f64 * step_v)).collect();
        let down: Vec<f64> = down.into_iter().rev().collect();
        let range = up[n] - up[0];
        // the first rise ends at the full voltage: the stroke is kept
        assert!((up[n] - 1000.0).abs() < 1e-9 * 1000.0 || step_v > 1.0);
        let width = up
            .iter()
            .zip(&down)
            .map(|(a, b)| (b - a).abs())
            .fold(0.0, f64::max);
        100.0 * width / range
    }

    #[test]
    fn default_loop_is_twelve_percent_of_the_stroke() {
        let w = loop_width_pct(BoucWenParams::DEFAULT, 1.0);
        assert!(
            (w - BoucWen::DEFAULT_WIDTH_PCT).abs() < 0.5,
            "loop width {w:.2} %"
        );
    }

    #[test]
    fn hysteresis_is_rate_independent() {
        // the same path sampled at 1 V and at 50 V increments gives the same loop (sub-stepping)
        let a = loop_width_pct(BoucWenParams::DEFAULT, 1.0);
        let b = loop_width_pct(BoucWenParams::DEFAULT, 50.0);
        assert!((a - b).abs() < 0.05, "{a} vs {b}");
        // no hysteresis with α = 0
        let p = BoucWenParams {
            alpha: 0.0,
            ..BoucWenParams::DEFAULT
        };
        assert!(loop_width_pct(p, 1.0) < 1e-12);
    }

    #[test]
    fn creep_grows_by_about_gamma_per_decade() {
        // a unit step held for 10 s, sampled at 50 µs: between 10 ms and 100 ms and between 0.1 s and 1 s the
        // output grows by ≈ γ_c (log creep), and it never exceeds 1 + decades·γ_c
        let dt = 5e-5;
        let mut c = LogCreep::new(LogCreepParams::DEFAULT, dt).unwrap();
        let mut at = std::collections::BTreeMap::new();
        for k in 1..=200_000 {
            let y = c.step(1.0);
            let t = k as f64 * dt;
            for mark in [0.01, 0.1, 1.0, 10.0] {
                if (t - mark).abs() < dt / 2.0 {
                    at.insert((mark * 1000.0) as i64, y);
                }
            }
        }
        let d1 = at[&100] - at[&10];
        let d2 = at[&1000] - at[&100];
        for d in [d1, d2] {
            assert!((d - 0.015).abs() < 0.006, "growth per decade {d}");
        }
        assert!(at[&10_000] <= 1.0 + 5.0 * 0.015 + 1e-12);
    }

    #[test]
    fn bad_parameters_name_the_key() {
        let e = BoucWen::new(
            BoucWenParams {
                alpha: 1.5,
                ..BoucWenParams::DEFAULT
            },
            1000.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("hysteresis.alpha"), "{e}");
    }
}
