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

/// One play operator's next output: `max(v − r, min(v + r, p))` for input `v_v`, threshold `r_v` and
/// present output `p`.
fn play(v_v: f64, r_v: f64, p: f64) -> f64 {
    (v_v - r_v).max((v_v + r_v).min(p))
}

/// A Prandtl–Ishlinskii operator, the hysteresis model a controller can *identify* and invert (the
/// truth's is [`BoucWen`]; a fitted model never has the truth's form): `y = Σᵢ wᵢ · Fᵣᵢ[v]`, a weighted
/// sum of play operators `Fᵣ[v]ₖ = max(vₖ − r, min(vₖ + r, Fᵣ[v]ₖ₋₁))` with thresholds
/// `0 = r₀ < r₁ < …` (Krasnosel'skii & Pokrovskii 1989; Kuhnen 2003). With `w₀ > 0` and every other
/// `wᵢ ≥ 0` each branch is strictly increasing in `v`, so the input that brings the operator from its
/// present state to any output is unique ([`Self::input_for`]): the inverse a compensator needs, taken
/// from the state the forward model holds, so the two never drift apart.
///
/// # Examples
/// ```
/// use millcomp_sim::actuator::PrandtlIshlinskii;
/// // 0.04 µm/V of linear gain plus 0.01 µm/V behind a 100 V play, from rest at 0 V
/// let mut p = PrandtlIshlinskii::new(vec![0.0, 100.0], vec![0.04, 0.01], 0.0).unwrap();
/// assert!((p.step(500.0) - (0.04 * 500.0 + 0.01 * 400.0)).abs() < 1e-12); // rising: 24 µm
/// // coming down the play holds until the input is 200 V below its top: the loop
/// assert!((p.step(300.0) - (0.04 * 300.0 + 0.01 * 400.0)).abs() < 1e-12);
/// // the input that takes it back up to 20 µm from here, and stepping it there gives 20 µm
/// let v = p.input_for(20.0);
/// assert!((p.step(v) - 20.0).abs() < 1e-9, "{v}");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PrandtlIshlinskii {
    thresholds_v: Vec<f64>,
    weights: Vec<f64>,
    plays: Vec<f64>,
}

impl PrandtlIshlinskii {
    /// An operator with `thresholds_v` (ascending, the first 0) and `weights` (output units per V: the
    /// first > 0, the others ≥ 0), every play at rest at the input `v0_v`.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `hysteresis.thresholds_v` or `hysteresis.weights` for lists
    /// of different or zero length, thresholds not starting at 0 or not increasing, weights that are
    /// negative, a first weight that is not positive, or a non-finite value.
    pub fn new(thresholds_v: Vec<f64>, weights: Vec<f64>, v0_v: f64) -> Result<Self, SimError> {
        let bad = |name: &'static str, value: f64, allowed: &'static str| {
            Err(SimError::InvalidParameter {
                name,
                value,
                allowed,
            })
        };
        if thresholds_v.is_empty() || thresholds_v.len() != weights.len() {
            return bad(
                "hysteresis.thresholds_v",
                thresholds_v.len() as f64,
                "one threshold per weight, at least one",
            );
        }
        if thresholds_v[0] != 0.0
            || thresholds_v
                .windows(2)
                .any(|w| w[1] <= w[0] || w[1].is_nan())
        {
            return bad(
                "hysteresis.thresholds_v",
                thresholds_v[0],
                "0 = r0 < r1 < ... (finite)",
            );
        }
        if let Some(r) = thresholds_v.iter().find(|r| !r.is_finite()) {
            return bad("hysteresis.thresholds_v", *r, "finite");
        }
        if !(weights[0].is_finite() && weights[0] > 0.0) {
            return bad("hysteresis.weights", weights[0], "w0 finite and > 0");
        }
        if let Some(w) = weights.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
            return bad("hysteresis.weights", *w, "finite and >= 0");
        }
        crate::error::check_finite("v0_v", v0_v)?;
        let plays = vec![v0_v; thresholds_v.len()];
        Ok(Self {
            thresholds_v,
            weights,
            plays,
        })
    }

    /// The play outputs of `thresholds_v` along the input path `v_v`, every play at rest at `v_v[0]`:
    /// one column per threshold, one row per sample — the regressors of a least-squares fit of the
    /// weights.
    pub fn play_paths(thresholds_v: &[f64], v_v: &[f64]) -> Vec<Vec<f64>> {
        let v0 = v_v.first().copied().unwrap_or(0.0);
        thresholds_v
            .iter()
            .map(|&r| {
                let mut p = v0;
                v_v.iter()
                    .map(|&v| {
                        p = play(v, r, p);
                        p
                    })
                    .collect()
            })
            .collect()
    }

    /// Thresholds (V).
    pub fn thresholds_v(&self) -> &[f64] {
        &self.thresholds_v
    }

    /// Weights (output units per V).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The output for the plays' present state.
    pub fn output(&self) -> f64 {
        self.weights
            .iter()
            .zip(&self.plays)
            .map(|(w, p)| w * p)
            .sum()
    }

    /// Advance to input `v_v` and return the output.
    pub fn step(&mut self, v_v: f64) -> f64 {
        for (p, r) in self.plays.iter_mut().zip(&self.thresholds_v) {
            *p = play(v_v, *r, *p);
        }
        self.output()
    }

    /// The output the next input `v_v` would give, without moving the state.
    pub fn output_at(&self, v_v: f64) -> f64 {
        self.weights
            .iter()
            .zip(self.plays.iter().zip(&self.thresholds_v))
            .map(|(w, (p, r))| w * play(v_v, *r, *p))
            .sum()
    }

    /// The input that takes the operator from its present state to output `y` (unique: the branch is
    /// strictly increasing). The branch is piecewise linear with corners where a play starts or stops
    /// moving (`v = p ± r`); the corner segment holding `y` is found and solved exactly.
    pub fn input_for(&self, y: f64) -> f64 {
        self.input_for_with(y, &mut Vec::new())
    }

    /// [`Self::input_for`] with the corner list kept in `corners` (cleared and refilled), so a
    /// compensator that inverts every control cycle does not allocate in the cycle.
    pub fn input_for_with(&self, y: f64, corners: &mut Vec<f64>) -> f64 {
        corners.clear();
        corners.extend(
            self.plays
                .iter()
                .zip(&self.thresholds_v)
                .flat_map(|(p, r)| [p - r, p + r]),
        );
        corners.sort_by(f64::total_cmp);
        corners.dedup();
        // below the lowest and above the highest corner every play moves: slope Σw
        let total: f64 = self.weights.iter().sum();
        let (lo, hi) = (corners[0], corners[corners.len() - 1]);
        let (y_lo, y_hi) = (self.output_at(lo), self.output_at(hi));
        if y <= y_lo {
            return lo - (y_lo - y) / total;
        }
        if y >= y_hi {
            return hi + (y - y_hi) / total;
        }
        let mut a = lo;
        let mut ya = y_lo;
        for &b in &corners[1..] {
            let yb = self.output_at(b);
            if y <= yb {
                return if yb > ya {
                    a + (b - a) * (y - ya) / (yb - ya)
                } else {
                    a
                };
            }
            a = b;
            ya = yb;
        }
        hi
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

    #[test]
    fn prandtl_ishlinskii_input_for_inverts_every_branch_along_a_path() {
        // quadratic thresholds as identify fits them, uneven weights, a path with reversals of every size
        let r: Vec<f64> = (0..8).map(|i| 900.0 * (i as f64 / 8.0).powi(2)).collect();
        let w = vec![0.03, 0.004, 0.0, 0.006, 0.002, 0.005, 0.001, 0.003];
        let mut p = PrandtlIshlinskii::new(r.clone(), w.clone(), 0.0).unwrap();
        for k in 0..400 {
            // a wandering input: a slow sine plus a faster one
            let target = 450.0 + 400.0 * (0.013 * k as f64).sin() + 60.0 * (0.31 * k as f64).sin();
            // the output a step to `target` gives, reached again through input_for
            let want = p.output_at(target);
            let u = p.input_for(want);
            assert!((u - target).abs() < 1e-6, "k {k}: {u} vs {target}");
            p.step(target);
            // outputs off every branch's corner list are reached too
            for y in [p.output() - 3.0, p.output() + 0.7, p.output() + 30.0] {
                let u = p.input_for(y);
                assert!((p.output_at(u) - y).abs() < 1e-9, "k {k}, y {y}");
            }
        }
        // the regressor paths are the plays' states
        let path: Vec<f64> = (0..50)
            .map(|k| 300.0 * (0.2 * k as f64).sin().abs())
            .collect();
        let cols = PrandtlIshlinskii::play_paths(&r, &path);
        let mut q = PrandtlIshlinskii::new(r, w.clone(), path[0]).unwrap();
        for (k, &x) in path.iter().enumerate() {
            let y = q.step(x);
            let from_cols: f64 = w.iter().zip(&cols).map(|(wi, c)| wi * c[k]).sum();
            assert!((y - from_cols).abs() < 1e-12);
        }
    }

    #[test]
    fn prandtl_ishlinskii_refuses_a_model_it_cannot_invert() {
        for (r, w) in [
            (vec![0.0, 100.0], vec![0.0, 0.01]), // no linear part: flat branches
            (vec![0.0, 100.0], vec![0.04, -0.01]), // a falling branch
            (vec![10.0, 100.0], vec![0.04, 0.01]), // no r = 0 play
            (vec![0.0, 100.0, 50.0], vec![0.04, 0.01, 0.01]),
            (vec![0.0], vec![0.04, 0.01]),
        ] {
            let e = PrandtlIshlinskii::new(r, w, 0.0).unwrap_err();
            assert!(e.to_string().contains("hysteresis."), "{e}");
        }
    }
}
