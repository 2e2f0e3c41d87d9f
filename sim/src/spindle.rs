//! PZT-actuated spindle plant (`000_…txt` §5.2).
//!
//! Plant (amplifier volts → tool-tip displacement in µm, positive = tool moves *deeper* into the work):
//!
//! ```text
//!            gain_um_per_v · ωn² · [p/(s+p)] · e^{-s·Td}
//! G(s) = ---------------------------------------------------
//!                   s² + 2 ζ ωn s + ωn²
//! ```
//!
//! The thesis models a 2nd-order system (ζ = 0.46 from 20 % overshoot, ωn = 1.8/1.38 ms = 1302 rad/s —
//! the text says "1,302 Hz", but 1.8/t_r is in rad/s) and its P-only root locus has *three* poles
//! (Fig. 5-11, unstable at kc = 3000), so a third (real) pole `p` — amplifier or the 500 Hz filter — is
//! optional here; an optional dead time `Td` can be represented by a Padé approximant in [`PztSpindle::to_lti`]
//! or by an exact sample delay in [`DiscretePztSpindle`].
//!
//! Stroke: PZT 0–20 µm at 0–1000 V (§5.2.2), ≈ 50 µm at the tool tip by the flexure lever ratio, hence the
//! default DC gain 50/1000 = 0.05 µm/V at the tool tip. The fitted dynamic constants and their provenance are
//! in [`crate::spindle_figures`].
//!
//! **Capacitance gauge** (Lion Precision RD20-1, 50 µm range, 2.5 µm/V, §5.2.2): mounted between the
//! actuators in line with the spindle centre-line; here it is taken as calibrated to tool-tip µm
//! (assumption: the thesis compares the gauge reading directly with the estimated tool deflection, §7.3).
//!
//! **Controller units.** The thesis' gains (kc = 3000, P 844, I 130 820, P 400, I 800 000) act on an error in
//! µm and produce a controller output `u` whose scale to amplifier volts is not given. We define
//! `volts = loop_v_per_unit · u`; `loop_v_per_unit` is fitted with the dynamics (see [`crate::spindle_figures`])
//! so that the P-only critical gain is 3000.

use nalgebra::DVector;
use serde::{Deserialize, Serialize};

use crate::actuator::{BoucWen, BoucWenParams, LogCreep, LogCreepParams};
use crate::error::{SimError, check_nonneg, check_positive, check_range};
use crate::lti::{ContinuousLti, DiscreteLti};

/// How a dead time is represented.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DeadTimeModel {
    /// Padé approximant of the given order (1..=3) inside the continuous model.
    #[default]
    Pade1,
    /// 2nd-order Padé approximant.
    Pade2,
    /// Exact delay of `round(Td/dt)` samples in the discrete model (not in `to_lti`).
    SampleDelay,
}

/// PZT-actuated spindle parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PztSpindle {
    /// DC gain, tool-tip µm per amplifier volt (default 50 µm / 1000 V, §5.2.2).
    pub gain_um_per_v: f64,
    /// Damping ratio ζ of the dominant 2nd-order pair (0.46, §5.2.4).
    pub zeta: f64,
    /// Natural frequency ωn (rad/s).
    pub wn_rad_s: f64,
    /// Optional extra real pole (rad/s), `None` for a pure 2nd-order plant.
    pub pole_rad_s: Option<f64>,
    /// Optional dead time (s).
    pub dead_time_s: Option<f64>,
    /// Representation of the dead time.
    pub dead_time_model: DeadTimeModel,
    /// Maximum amplifier voltage (1000 V, §5.2.2); commands are clamped to `[0, voltage_max_v]`.
    pub voltage_max_v: f64,
    /// PZT stack stroke at `voltage_max_v` (20 µm, §5.2.2).
    pub actuator_stroke_um: f64,
    /// Force seen by the spindle force sensor per µm of actuator (tool-tip) displacement (0.44 N/µm, §7.3.1).
    pub force_coupling_n_per_um: f64,
    /// Controller-output-to-volts scale: `volts = loop_v_per_unit · u` (see module docs).
    pub loop_v_per_unit: f64,
    /// Rate-independent hysteresis of the stack on the drive voltage ([`crate::actuator::BoucWen`]);
    /// none in a linear model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hysteresis: Option<BoucWenParams>,
    /// Creep of the stack after a voltage change ([`crate::actuator::LogCreep`]); none in a linear model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub creep: Option<LogCreepParams>,
}

impl Default for PztSpindle {
    /// The fitted plant of [`crate::spindle_figures::FITTED`] (2nd order + real pole).
    fn default() -> Self {
        crate::spindle_figures::FITTED.spindle()
    }
}

impl PztSpindle {
    /// Build and validate a spindle (Padé dead time, the §5.2.2 voltage, stroke and force coupling,
    /// and the fitted `loop_v_per_unit`).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming the parameter out of range: `gain_um_per_v` or
    /// `wn_rad_s` not a finite positive number, `zeta` outside `[1e-6, 10]`, `pole_rad_s` (if
    /// given) not > 0, `dead_time_s` (if given) outside `[0, 0.1]` s.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::SimError;
    /// use millcomp_sim::lti::step_figures;
    /// use millcomp_sim::spindle::PztSpindle;
    /// // the thesis' 2nd-order plant (000 §5.2.4): ζ = 0.46 (from the 20 % open-loop overshoot) and
    /// // ωn = 1302 rad/s; 0.05 µm/V = 50 µm tool-tip stroke at 1000 V (§5.2.2)
    /// let s = PztSpindle::new(0.05, 0.46, 1302.0, None, None).unwrap();
    /// assert_eq!(s.tip_stroke_um(), 50.0);
    /// // a 10 V step (0.5 µm at the tip), stepped at 10 µs for 20 ms
    /// let mut d = s.discretize(1e-5).unwrap();
    /// let y: Vec<f64> = (0..2000).map(|_| d.step(10.0).tip_um).collect();
    /// let f = step_figures(&y, d.dt_s()).unwrap();
    /// assert!((f.final_value - 0.5).abs() < 1e-4);
    /// // overshoot of a 2nd-order step: 100·exp(−πζ/√(1 − ζ²)) = 19.64 % (published: 20 %)
    /// assert!((f.overshoot_pct - 19.64).abs() < 0.01);
    ///
    /// let e = PztSpindle::new(0.05, 0.0, 1302.0, None, None).unwrap_err();
    /// assert!(matches!(e, SimError::InvalidParameter { name: "zeta", .. }));
    /// ```
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        gain_um_per_v: f64,
        zeta: f64,
        wn_rad_s: f64,
        pole_rad_s: Option<f64>,
        dead_time_s: Option<f64>,
    ) -> Result<Self, SimError> {
        let s = Self {
            gain_um_per_v,
            zeta,
            wn_rad_s,
            pole_rad_s,
            dead_time_s,
            dead_time_model: DeadTimeModel::Pade1,
            voltage_max_v: 1000.0,
            actuator_stroke_um: 20.0,
            force_coupling_n_per_um: 0.44,
            loop_v_per_unit: crate::spindle_figures::FITTED.loop_v_per_unit,
            hysteresis: None,
            creep: None,
        };
        s.validate()?;
        Ok(s)
    }

    /// Check every parameter; error names the parameter and its allowed range.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`]: the ranges of [`Self::new`], and `voltage_max_v`,
    /// `actuator_stroke_um`, `loop_v_per_unit` not a finite positive number,
    /// `force_coupling_n_per_um` negative or not finite.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("gain_um_per_v", self.gain_um_per_v)?;
        check_range("zeta", self.zeta, 1e-6, 10.0, "0 < zeta <= 10")?;
        check_positive("wn_rad_s", self.wn_rad_s)?;
        if let Some(p) = self.pole_rad_s {
            check_positive("pole_rad_s", p)?;
        }
        if let Some(td) = self.dead_time_s {
            check_range("dead_time_s", td, 0.0, 0.1, "0 <= dead_time_s <= 0.1")?;
        }
        check_positive("voltage_max_v", self.voltage_max_v)?;
        check_positive("actuator_stroke_um", self.actuator_stroke_um)?;
        check_nonneg("force_coupling_n_per_um", self.force_coupling_n_per_um)?;
        if let Some(h) = &self.hysteresis {
            h.validate()?;
        }
        if let Some(c) = &self.creep {
            c.validate()?;
        }
        check_positive("loop_v_per_unit", self.loop_v_per_unit)?;
        Ok(())
    }

    /// Tool-tip stroke (µm) at `voltage_max_v`: `gain_um_per_v · voltage_max_v` (≈ 50 µm, §5.2.2).
    pub fn tip_stroke_um(&self) -> f64 {
        self.gain_um_per_v * self.voltage_max_v
    }

    /// Transfer-function coefficients (descending powers of s) of the plant without dead time.
    pub fn transfer_function(&self) -> (Vec<f64>, Vec<f64>) {
        let wn2 = self.wn_rad_s * self.wn_rad_s;
        let mut num = vec![self.gain_um_per_v * wn2];
        let mut den = vec![1.0, 2.0 * self.zeta * self.wn_rad_s, wn2];
        if let Some(p) = self.pole_rad_s {
            num[0] *= p;
            den = poly_mul(&den, &[1.0, p]);
        }
        (num, den)
    }

    /// Continuous state-space model (volts → tool-tip µm). A dead time is included as a Padé approximant
    /// when `dead_time_model` is `Pade1`/`Pade2`, omitted for `SampleDelay`.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] when [`Self::validate`] fails.
    pub fn to_lti(&self) -> Result<ContinuousLti, SimError> {
        self.validate()?;
        let (mut num, mut den) = self.transfer_function();
        if let Some(td) = self.dead_time_s.filter(|t| *t > 0.0) {
            let (pn, pd) = match self.dead_time_model {
                DeadTimeModel::Pade1 => (vec![-td / 2.0, 1.0], vec![td / 2.0, 1.0]),
                DeadTimeModel::Pade2 => (
                    vec![td * td / 12.0, -td / 2.0, 1.0],
                    vec![td * td / 12.0, td / 2.0, 1.0],
                ),
                DeadTimeModel::SampleDelay => (vec![1.0], vec![1.0]),
            };
            num = poly_mul(&num, &pn);
            den = poly_mul(&den, &pd);
        }
        ContinuousLti::from_transfer_function(&num, &den)
    }

    /// Discretise for stepping at `dt_s` (ZOH; dead time per `dead_time_model`).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] when [`Self::validate`] fails or `dt_s` is not a finite
    /// positive number; [`SimError::Numerical`] when the discretised matrices are not finite.
    pub fn discretize(&self, dt_s: f64) -> Result<DiscretePztSpindle, SimError> {
        let lti = self.to_lti()?;
        let model = lti.discretize_zoh(dt_s)?;
        let delay_samples = match (self.dead_time_model, self.dead_time_s) {
            (DeadTimeModel::SampleDelay, Some(td)) => (td / dt_s).round() as usize,
            _ => 0,
        };
        Ok(DiscretePztSpindle {
            state: model.zero_state(),
            model,
            delay: vec![0.0; delay_samples],
            delay_pos: 0,
            voltage_max_v: self.voltage_max_v,
            last_v: 0.0,
            force_coupling_n_per_um: self.force_coupling_n_per_um,
            hysteresis: self
                .hysteresis
                .map(|p| BoucWen::new(p, self.voltage_max_v))
                .transpose()?,
            creep: self.creep.map(|p| LogCreep::new(p, dt_s)).transpose()?,
            at_rest: (None, None),
        })
        .map(|mut d: DiscretePztSpindle| {
            d.at_rest = (d.hysteresis.clone(), d.creep.clone());
            d
        })
    }
}

/// Product of two polynomials in descending powers.
pub fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, ai) in a.iter().enumerate() {
        for (j, bj) in b.iter().enumerate() {
            out[i + j] += ai * bj;
        }
    }
    out
}

/// The spindle discretised at a fixed sample time, with voltage clamping and optional sample delay.
#[derive(Debug, Clone)]
pub struct DiscretePztSpindle {
    /// Discrete model (volts → tool-tip µm).
    pub model: DiscreteLti,
    state: DVector<f64>,
    delay: Vec<f64>,
    delay_pos: usize,
    voltage_max_v: f64,
    last_v: f64,
    force_coupling_n_per_um: f64,
    hysteresis: Option<BoucWen>,
    creep: Option<LogCreep>,
    /// The nonlinear elements at rest, for [`DiscretePztSpindle::reset`].
    at_rest: (Option<BoucWen>, Option<LogCreep>),
}

/// One step of the spindle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpindleStep {
    /// Voltage actually applied after clamping to `[0, voltage_max_v]` (NaN commands hold the last value).
    pub applied_v: f64,
    /// Tool-tip displacement (µm, + = deeper).
    pub tip_um: f64,
    /// Force added to the spindle force sensor by the actuator displacement (N).
    pub coupling_force_n: f64,
}

impl DiscretePztSpindle {
    /// Sample time (s).
    pub fn dt_s(&self) -> f64 {
        self.model.dt_s
    }

    /// Reset to rest (zero volts, zero displacement).
    pub fn reset(&mut self) {
        self.state.fill(0.0);
        self.delay.iter_mut().for_each(|v| *v = 0.0);
        self.delay_pos = 0;
        self.last_v = 0.0;
        self.hysteresis = self.at_rest.0.clone();
        self.creep = self.at_rest.1.clone();
    }

    /// Current tool-tip displacement (µm) without advancing (the output for zero feed-through).
    pub fn tip_um(&self) -> f64 {
        let mut y = 0.0;
        for j in 0..self.state.len() {
            y += self.model.c[(0, j)] * self.state[j];
        }
        y
    }

    /// Apply `command_v` for one sample: returns the displacement at the *start* of the sample
    /// (`y[k]`) and advances the state. NaN never reaches the actuator: a non-finite command holds the last
    /// applied voltage.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::lti::step_figures;
    /// use millcomp_sim::spindle::PztSpindle;
    /// // the fitted plant (`spindle_figures::FITTED`) at the thesis' 20 kHz loop rate
    /// let mut d = PztSpindle::default().discretize(5e-5).unwrap();
    /// // commands are clamped to the amplifier's 0..1000 V; a NaN command holds the last voltage
    /// assert_eq!(d.step(2000.0).applied_v, 1000.0);
    /// assert_eq!(d.step(f64::NAN).applied_v, 1000.0);
    /// assert_eq!(d.step(-5.0).applied_v, 0.0);
    /// d.reset();
    /// // open-loop 0.5 µm step (10 V) over 20 ms: 000 §5.2.4 publishes 20 % overshoot and a 1.38 ms
    /// // 0–90 % rise time (the fit: 19.95 %, 1.378 ms)
    /// let y: Vec<f64> = (0..400).map(|_| d.step(10.0).tip_um).collect();
    /// let f = step_figures(&y, d.dt_s()).unwrap();
    /// assert!((f.final_value - 0.5).abs() < 1e-4);
    /// assert!((f.overshoot_pct - 20.0).abs() / 20.0 < 0.01);
    /// assert!((f.rise_time_0_90_s - 1.38e-3).abs() / 1.38e-3 < 0.01);
    /// ```
    pub fn step(&mut self, command_v: f64) -> SpindleStep {
        let v = if command_v.is_finite() {
            command_v.clamp(0.0, self.voltage_max_v)
        } else {
            self.last_v
        };
        self.last_v = v;
        // the stack's nonlinearity acts on the drive voltage before its linear dynamics (Hammerstein)
        let mut v_stack = v;
        if let Some(h) = &mut self.hysteresis {
            v_stack = h.step(v_stack);
        }
        if let Some(c) = &mut self.creep {
            v_stack = c.step(v_stack);
        }
        let u = if self.delay.is_empty() {
            v_stack
        } else {
            let out = self.delay[self.delay_pos];
            self.delay[self.delay_pos] = v_stack;
            self.delay_pos = (self.delay_pos + 1) % self.delay.len();
            out
        };
        let tip = self.model.step_siso(&mut self.state, u);
        SpindleStep {
            applied_v: v,
            tip_um: tip,
            coupling_force_n: self.force_coupling_n_per_um * tip,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn a_stack_with_hysteresis_opens_a_loop_of_its_documented_width_at_the_tip() {
        // a slow (2 s) 0 → 1000 V → 0 triangle: the linear dynamics are quasi-static, so the widest gap
        // between the rising and the falling branch at the tip is the hysteresis loop itself
        let s = PztSpindle {
            hysteresis: Some(BoucWenParams::DEFAULT),
            ..PztSpindle::default()
        };
        let dt = 1e-4;
        let mut d = s.discretize(dt).unwrap();
        let n = 10_000;
        let mut up = vec![0.0; n + 1];
        for (k, u) in up.iter_mut().enumerate() {
            *u = d.step(1000.0 * k as f64 / n as f64).tip_um;
        }
        let mut width: f64 = 0.0;
        for k in (0..=n).rev() {
            let down = d.step(1000.0 * k as f64 / n as f64).tip_um;
            width = width.max(down - up[k]);
        }
        let stroke = s.gain_um_per_v * 1000.0;
        let pct = 100.0 * width / stroke;
        assert!(
            (pct - crate::actuator::BoucWen::DEFAULT_WIDTH_PCT).abs() < 1.0,
            "loop width {pct} % of the stroke"
        );
        // and a linear stack has none
        let mut lin = PztSpindle::default().discretize(dt).unwrap();
        let a: Vec<f64> = (0..=n)
            .map(|k| lin.step(1000.0 * k as f64 / n as f64).tip_um)
            .collect();
        let b = (0..=n)
            .rev()
            .map(|k| lin.step(1000.0 * k as f64 / n as f64).tip_um);
        let lin_width = b.zip(a.iter().rev()).fold(0.0f64, |m, (d, u)| m.max(d - u));
        assert!(lin_width < 0.02 * stroke, "{lin_width}");
    }

    #[test]
    fn dc_gain_and_stroke() {
        let s = PztSpindle::new(0.05, 0.46, 1302.0, Some(5000.0), None).unwrap();
        // 50 µm tip stroke at 1000 V (000 §5.2.2)
        assert_relative_eq!(s.tip_stroke_um(), 50.0, epsilon = 1e-12);
        let g = s.to_lti().unwrap();
        assert_relative_eq!(g.dc_gain().unwrap()[(0, 0)], 0.05, epsilon = 1e-12);
        assert_eq!(g.n_states(), 3);
    }

    #[test]
    fn clamps_and_holds_nan() {
        let s = PztSpindle::new(0.05, 0.46, 1302.0, None, None).unwrap();
        let mut d = s.discretize(5e-5).unwrap();
        assert_eq!(d.step(2000.0).applied_v, 1000.0);
        assert_eq!(d.step(f64::NAN).applied_v, 1000.0);
        assert_eq!(d.step(-5.0).applied_v, 0.0);
        let mut last = 0.0;
        d.reset();
        for _ in 0..4000 {
            last = d.step(1000.0).tip_um;
        }
        assert_relative_eq!(last, 50.0, epsilon = 1e-6);
    }

    #[test]
    fn sample_delay_delays() {
        let mut s = PztSpindle::new(0.05, 0.46, 1302.0, None, Some(1e-3)).unwrap();
        s.dead_time_model = DeadTimeModel::SampleDelay;
        let mut d = s.discretize(1e-4).unwrap();
        // 10 samples of delay: output stays exactly 0 for 11 samples (1 more for the strictly proper plant)
        for _ in 0..11 {
            assert_eq!(d.step(100.0).tip_um, 0.0);
        }
        assert!(d.step(100.0).tip_um > 0.0);
    }

    #[test]
    fn rejects_nonphysical() {
        assert!(matches!(
            PztSpindle::new(0.05, -0.1, 1302.0, None, None),
            Err(SimError::InvalidParameter { name: "zeta", .. })
        ));
        assert!(matches!(
            PztSpindle::new(0.05, 0.46, 0.0, None, None),
            Err(SimError::InvalidParameter {
                name: "wn_rad_s",
                ..
            })
        ));
        assert!(matches!(
            PztSpindle::new(0.05, 0.46, 1302.0, Some(-1.0), None),
            Err(SimError::InvalidParameter {
                name: "pole_rad_s",
                ..
            })
        ));
    }
}
