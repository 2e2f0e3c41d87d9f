//! Controllers of the NC feed-axis stage (`003_…txt`): deflection compensation in the NC kernel, a
//! correction superimposed on the y axis' position reference every position cycle (2 ms).
//!
//! Every controller reads the same sensors — the force platform's orthogonal force at its sampling
//! rate ([`NcController::force_sample`]) and, every cycle, the NC's own data (cycle index, reference
//! acceleration, the y axis' encoder; [`NcCycle`]) — and is built only from what a commissioning
//! measured ([`IdentifiedNcStiffness`], [`IdentifiedFeedAxis`], [`IdentifiedKienzle`] on a catalogue
//! [`NominalEndMill`]; private fields, made only from identified models) and the NC program
//! (`millcomp_sim::nc_axis::NcProgram`, which the NC holds anyway):
//!
//! * [`NoneNc`]: no compensation.
//! * [`ReactiveNc`] (003 §2.3): the measured force through the notch chain (sim's [`NotchChain`]: the
//!   spindle harmonics `n/60·i`, i = 1..Z of eq. 6 and the tooth-passing harmonics up to the force
//!   channel's Nyquist frequency, bandwidth f0/4 each, eq. 7) and the first-order 120 Hz low-pass, run at
//!   the force rate; the NC reads the filtered value every cycle: `u = −F/k`.
//! * [`ProactiveNc`] (003 §2.3, Fig. 3): the force through the 6 Hz, D = 1 second-order low-pass, plus an
//!   offset curve ([`OffsetCurve`]) recorded once in a reference run and superimposed from the cycle at
//!   which the reference acceleration becomes non-zero ([`OffsetWindow`]). Untuned: the curve follows
//!   from the reference run by a fixed rule.
//! * [`MpcNc`]: Clarabel every cycle (the crate's [`MpcController`]: QP built once, `update_q`/`update_b`
//!   per cycle) on the identified y axis, previewing the planned deflection ([`NcPlan`]: the NC
//!   program's *reference* feed and the engagement on the blank through the identified x axis and the
//!   force model, 003 §4's proposal) scaled by [`ScaleEstimator`], which blends the measured force with
//!   the prediction — the measurement at constant conditions, the prediction while the planned force is
//!   changing (003 §4: "rely more on the measurement when the feed rate is constant and more on the
//!   simulation when the feed rate changes").
//!
//! ```compile_fail
//! // the truth's force model handed to a controller does not compile: not an IdentifiedKienzle
//! use millcomp_sim::kienzle::{EndMill, KienzleCoefficients, KienzleMillingModel};
//! let truth = KienzleMillingModel::new(KienzleCoefficients::c45_handbook(), EndMill::brecher_003()).unwrap();
//! let _ = millcomp_mpc::nc_axis::IdentifiedKienzle(truth);
//! ```

use millcomp_models::IdentifiedModel;
use millcomp_sim::DiscreteLti;
use millcomp_sim::filters::{Biquad, NotchChain};
use millcomp_sim::kienzle::{CutState, EndMill, KienzleCoefficients, KienzleMillingModel};
use millcomp_sim::nc_axis::{
    NcInterpolator, NcProgram, dead_time_lag_coefficients, dead_time_lag_response,
};
use std::f64::consts::PI;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::config::{DisturbanceKind, MpcConfig};
use crate::controller::{MpcController, PreviewWindow};
use crate::error::{MpcError, invalid};
use crate::stats::SolverStats;

/// The tool as catalogued (what a user knows before any measurement).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NominalEndMill {
    /// Diameter (mm).
    pub diameter_mm: f64,
    /// Teeth.
    pub teeth: u32,
    /// Helix angle (deg).
    pub helix_deg: f64,
}

impl NominalEndMill {
    /// 003's tool as ordered: Ø16 mm, 5 teeth, 30° helix (`millcomp_sim::kienzle::EndMill::brecher_003`).
    pub fn brecher_003() -> Self {
        let t = EndMill::brecher_003();
        Self {
            diameter_mm: t.diameter_mm,
            teeth: t.teeth,
            helix_deg: t.helix_deg,
        }
    }

    fn end_mill(&self) -> EndMill {
        EndMill {
            diameter_mm: self.diameter_mm,
            teeth: self.teeth,
            helix_deg: self.helix_deg,
            runout_um: 0.0,
            runout_phase_deg: 0.0,
        }
    }
}

fn param(m: &IdentifiedModel, key: &str, name: &str) -> Result<f64, MpcError> {
    m.get(name)
        .filter(|v| v.is_finite())
        .ok_or_else(|| invalid(format!("{key}.{name}"), "missing", "an identified value"))
}

/// The controllers' force model: Kienzle's law with identified coefficients on the catalogue tool (no
/// edge forces, no runout).
#[derive(Debug, Clone)]
pub struct IdentifiedKienzle(KienzleMillingModel);

impl IdentifiedKienzle {
    /// From a `kienzle` fit (`identify kienzle`: `kc11_n_mm2`, `mc`, `kr11_n_mm2`, `mr`, each fitted or
    /// held fixed) on the catalogue tool.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`kienzle.<name>`) for a missing parameter,
    /// [`MpcError::IdentifiedModel`] (`kienzle`) for values the physics crate rejects.
    pub fn new(m: &IdentifiedModel, tool: &NominalEndMill) -> Result<Self, MpcError> {
        let c = KienzleCoefficients {
            kc11_n_mm2: param(m, "kienzle", "kc11_n_mm2")?,
            mc: param(m, "kienzle", "mc")?,
            kr11_n_mm2: param(m, "kienzle", "kr11_n_mm2")?,
            mr: param(m, "kienzle", "mr")?,
        };
        KienzleMillingModel::new(c, tool.end_mill())
            .map(Self)
            .map_err(|source| MpcError::IdentifiedModel {
                key: "kienzle".into(),
                value: format!("{c:?}"),
                source,
            })
    }

    /// This model with kc1.1 and kr1.1 times `factor` (a deliberate model error for a study).
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] for a factor that is not finite and > 0.
    pub fn rescaled(&self, factor: f64) -> Result<Self, MpcError> {
        let mut m = self.0.clone();
        m.coefficients = m.coefficients.scaled(factor);
        m.validate()
            .map(|_| Self(m.clone()))
            .map_err(|source| MpcError::IdentifiedModel {
                key: "kienzle".into(),
                value: format!("factor {factor}"),
                source,
            })
    }

    /// The coefficients (read only).
    pub fn coefficients(&self) -> KienzleCoefficients {
        self.0.coefficients
    }
}

/// The controllers' model of a feed axis: dead time + first-order lag (`identify feed-axis`), and —
/// where the commissioning recorded one ([`Self::with_step_response`]) — the axis' measured step
/// response at the position cycle, a non-parametric (DMC-style) model that the MPC and its plan use
/// instead ([`Self::discrete`], [`Self::respond`]).
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifiedFeedAxis {
    dead_time_s: f64,
    lag_s: f64,
    step: Option<MeasuredStep>,
}

/// A step response measured at the start of each position cycle after a reference step latched at
/// cycle 0, normalised to a unit step.
#[derive(Debug, Clone, PartialEq)]
struct MeasuredStep {
    cycle_s: f64,
    s: Vec<f64>,
}

/// Shortest step response [`IdentifiedFeedAxis::step_response_from_trace`] accepts (cycles).
pub const MIN_STEP_RESPONSE_CYCLES: usize = 20;

impl IdentifiedFeedAxis {
    /// From a `feed_axis` fit (`dead_time_s`, `lag_s`).
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`feed_axis.<name>`) for a missing, negative or zero value.
    pub fn new(m: &IdentifiedModel) -> Result<Self, MpcError> {
        let dead_time_s = param(m, "feed_axis", "dead_time_s")?;
        let lag_s = param(m, "feed_axis", "lag_s")?;
        if dead_time_s < 0.0 {
            return Err(invalid("feed_axis.dead_time_s", dead_time_s, ">= 0"));
        }
        if lag_s <= 0.0 {
            return Err(invalid("feed_axis.lag_s", lag_s, "> 0"));
        }
        Ok(Self {
            dead_time_s,
            lag_s,
            step: None,
        })
    }

    /// The unit step response at the cycle starts from an NC servo trace (the reference and the
    /// encoder at the start of each cycle, the reference held over its cycle): every jump of the
    /// reference from a value held for at least [`MIN_STEP_RESPONSE_CYCLES`] cycles (the axis at
    /// rest) and followed by at least as many cycles at the new value gives
    /// `(p[i+k] − p[i]) / (r[i] − r[i−1])`, k = 0 … until the reference changes again; the responses
    /// are averaged over the common length.
    ///
    /// ```
    /// use millcomp_mpc::nc_axis::IdentifiedFeedAxis;
    /// // a trace of an axis that follows one cycle late: a step up and back, 30 cycles each
    /// let r: Vec<f64> = (0..90).map(|i| if (25..55).contains(&i) { 100.0 } else { 0.0 }).collect();
    /// let p: Vec<f64> = (0..90).map(|i| if i == 0 { 0.0 } else { r[i - 1] }).collect();
    /// let s = IdentifiedFeedAxis::step_response_from_trace(&r, &p).unwrap();
    /// assert_eq!(s.len(), 30);
    /// assert_eq!((s[0], s[1], s[29]), (0.0, 1.0, 1.0));
    /// ```
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`feed_axis.trace`) for traces of different lengths, non-finite
    /// values, or no step held long enough.
    pub fn step_response_from_trace(
        reference_um: &[f64],
        position_um: &[f64],
    ) -> Result<Vec<f64>, MpcError> {
        let n = reference_um.len();
        if position_um.len() != n
            || reference_um
                .iter()
                .chain(position_um)
                .any(|v| !v.is_finite())
        {
            return Err(invalid(
                "feed_axis.trace",
                format!("{n} references, {} positions", position_um.len()),
                "as many finite positions as references",
            ));
        }
        let mut steps: Vec<Vec<f64>> = Vec::new();
        for i in 1..n {
            let a = reference_um[i] - reference_um[i - 1];
            if a.abs() <= 1e-9 * reference_um[i].abs().max(1.0) {
                continue;
            }
            let held = reference_um[i..]
                .iter()
                .take_while(|r| **r == reference_um[i])
                .count();
            // from rest: the reference held before the jump as long (the axis settled)
            let rest = reference_um[..i]
                .iter()
                .rev()
                .take_while(|r| **r == reference_um[i - 1])
                .count();
            if held >= MIN_STEP_RESPONSE_CYCLES && rest >= MIN_STEP_RESPONSE_CYCLES {
                steps.push(
                    (0..held)
                        .map(|k| (position_um[i + k] - position_um[i]) / a)
                        .collect(),
                );
            }
        }
        let len = steps.iter().map(Vec::len).min().ok_or_else(|| {
            invalid(
                "feed_axis.trace",
                "no step",
                format!("a reference step held for at least {MIN_STEP_RESPONSE_CYCLES} cycles"),
            )
        })?;
        Ok((0..len)
            .map(|k| steps.iter().map(|s| s[k]).sum::<f64>() / steps.len() as f64)
            .collect())
    }

    /// This model with the measured unit step response `step` at the cycle `cycle_s` (from
    /// [`Self::step_response_from_trace`]): [`Self::discrete`] and [`Self::respond`] use it, the
    /// response held at its last value beyond its length.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`feed_axis.step_response`) for fewer than
    /// [`MIN_STEP_RESPONSE_CYCLES`] values, non-finite values or a non-positive cycle.
    pub fn with_step_response(mut self, step: Vec<f64>, cycle_s: f64) -> Result<Self, MpcError> {
        if step.len() < MIN_STEP_RESPONSE_CYCLES
            || step.iter().any(|v| !v.is_finite())
            || !(cycle_s.is_finite() && cycle_s > 0.0)
        {
            return Err(invalid(
                "feed_axis.step_response",
                format!("{} values at {cycle_s} s", step.len()),
                format!("at least {MIN_STEP_RESPONSE_CYCLES} finite values, cycle > 0"),
            ));
        }
        self.step = Some(MeasuredStep { cycle_s, s: step });
        Ok(self)
    }

    /// This model without a measured step response (the dead time + lag alone).
    pub fn without_step_response(mut self) -> Self {
        self.step = None;
        self
    }

    /// Whether a measured step response is used.
    pub fn has_step_response(&self) -> bool {
        self.step.is_some()
    }

    /// The measured step response at `cycle_s`, if one is held at that cycle.
    fn step_at(&self, cycle_s: f64) -> Option<&[f64]> {
        self.step
            .as_ref()
            .filter(|m| (m.cycle_s - cycle_s).abs() <= 1e-9 * cycle_s)
            .map(|m| m.s.as_slice())
    }

    /// Dead time (s).
    pub fn dead_time_s(&self) -> f64 {
        self.dead_time_s
    }

    /// Lag (s).
    pub fn lag_s(&self) -> f64 {
        self.lag_s
    }

    /// The lag of a ramp behind its reference (s): `T_d + τ`.
    pub fn equivalent_delay_s(&self) -> f64 {
        self.dead_time_s + self.lag_s
    }

    /// The axis as a discrete model at the position cycle `cycle_s` (reference held over each cycle):
    /// states `[p, u_{k−1}, …, u_{k−n−1}]`, output `p` (strictly proper), exact for a dead time that is
    /// not a whole number of cycles (the `identify feed-axis` recursion).
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a non-positive cycle.
    pub fn discrete(&self, cycle_s: f64) -> Result<DiscreteLti, MpcError> {
        if let Some(st) = self.step_at(cycle_s) {
            // FIR on the past references u_{k−1} … u_{k−n}, n = N − 1: y_k = Σ_j (S_j − S_{j−1})
            // u_{k−j} (S_0 = 0: the position at a cycle's start has not seen that cycle's reference);
            // beyond N the response is taken as settled at S_{N−1}
            let n = st.len() - 1;
            let mut am = DMatrix::zeros(n, n);
            let mut bm = DMatrix::zeros(n, 1);
            let mut cm = DMatrix::zeros(1, n);
            bm[(0, 0)] = 1.0;
            for i in 1..n {
                am[(i, i - 1)] = 1.0;
            }
            for j in 1..=n {
                cm[(0, j - 1)] = st[j] - st[j - 1];
            }
            return Ok(DiscreteLti::new(am, bm, cm, DMatrix::zeros(1, 1), cycle_s)?);
        }
        let (n, a, b1, b2) = dead_time_lag_coefficients(cycle_s, self.dead_time_s, self.lag_s);
        // state: p, then d_1..d_{n+1} with d_i = u_{k−i}
        let nx = n + 2;
        let mut am = DMatrix::zeros(nx, nx);
        let mut bm = DMatrix::zeros(nx, 1);
        am[(0, 0)] = a;
        // p⁺ = a p + b1 u_{k−n} + b2 u_{k−n−1}
        if n == 0 {
            bm[(0, 0)] = b1;
        } else {
            am[(0, n)] += b1;
        }
        am[(0, n + 1)] += b2;
        bm[(1, 0)] = 1.0;
        for i in 2..nx {
            am[(i, i - 1)] = 1.0;
        }
        let mut cm = DMatrix::zeros(1, nx);
        cm[(0, 0)] = 1.0;
        Ok(DiscreteLti::new(am, bm, cm, DMatrix::zeros(1, 1), cycle_s)?)
    }

    /// The response at the start of each cycle to references held over each cycle, from `p0` at rest.
    pub fn respond(&self, reference: &[f64], cycle_s: f64) -> Vec<f64> {
        let p0 = reference.first().copied().unwrap_or(0.0);
        if let Some(st) = self.step_at(cycle_s) {
            // p_k = p0 + Σ_{m ≤ k} (r_m − r_{m−1}) S_{k−m} with r_{−1} = p0 and S held at S_{N−1}
            // beyond its end: the references older than N − 1 cycles enter at the settled gain
            let n = st.len() - 1;
            let last = st[n];
            return (0..reference.len())
                .map(|k| {
                    let mut pk = p0;
                    let lo = k.saturating_sub(n - 1);
                    if k >= n {
                        pk += last * (reference[k - n] - p0);
                    }
                    for m in lo..=k {
                        let prev = if m == 0 { p0 } else { reference[m - 1] };
                        pk += (reference[m] - prev) * st[k - m];
                    }
                    pk
                })
                .collect();
        }
        dead_time_lag_response(reference, p0, cycle_s, self.dead_time_s, self.lag_s)
    }
}

/// The controllers' static stiffness at the tool: load–deflection tests (`identify stiffness`) at one
/// or more positions along the feed axis, the compliance interpolated linearly between them and held
/// beyond the outermost (003 eqs. 1–5: the machine's stiffness changes along the axis by ΔkM; one
/// test sees none of that).
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifiedNcStiffness {
    /// Test positions (mm), increasing.
    x_mm: Vec<f64>,
    /// Compliance at each (µm/N).
    compliance_um_per_n: Vec<f64>,
}

impl IdentifiedNcStiffness {
    /// From one `stiffness` fit (`stiffness_n_per_um`): the same stiffness everywhere.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`stiffness.stiffness_n_per_um`) for a missing or non-positive value.
    pub fn new(m: &IdentifiedModel) -> Result<Self, MpcError> {
        Self::along(&[(0.0, m)])
    }

    /// From `stiffness` fits at positions `x_mm` along the feed axis.
    ///
    /// ```
    /// use millcomp_models::{FitStatus, IdentifiedModel, NamedMatrix};
    /// use millcomp_mpc::nc_axis::IdentifiedNcStiffness;
    /// let fit = |k: f64| IdentifiedModel {
    ///     status: FitStatus::Converged,
    ///     n_obs: 18,
    ///     dof: 17,
    ///     rms_residual: 0.3,
    ///     residual_unit: "um".into(),
    ///     warnings: vec![],
    ///     params: [("stiffness_n_per_um".to_string(), k)].into(),
    ///     std_err: Default::default(),
    ///     fixed: Default::default(),
    ///     derived: Default::default(),
    ///     covariance: NamedMatrix::default(),
    /// };
    /// let (a, b) = (fit(10.0), fit(20.0));
    /// let k = IdentifiedNcStiffness::along(&[(0.0, &a), (100.0, &b)]).unwrap();
    /// // the compliance is interpolated: 0.075 µm/N half-way, held beyond the ends
    /// assert!((k.n_per_um_at(50.0) - 1.0 / 0.075).abs() < 1e-9);
    /// assert_eq!(k.n_per_um_at(-5.0), 10.0);
    /// assert_eq!(k.n_per_um_at(150.0), 20.0);
    /// ```
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`]: no fit, a missing or non-positive stiffness
    /// (`stiffness.stiffness_n_per_um`), positions not finite and increasing (`stiffness.x_mm`).
    pub fn along(fits: &[(f64, &IdentifiedModel)]) -> Result<Self, MpcError> {
        if fits.is_empty() {
            return Err(invalid(
                "stiffness",
                "[]",
                "at least one load–deflection test",
            ));
        }
        let mut x_mm = Vec::with_capacity(fits.len());
        let mut compliance_um_per_n = Vec::with_capacity(fits.len());
        for (x, m) in fits {
            let k = param(m, "stiffness", "stiffness_n_per_um")?;
            if !(k > 0.0 && k.is_finite()) {
                return Err(invalid("stiffness.stiffness_n_per_um", k, "> 0"));
            }
            if !x.is_finite() || x_mm.last().is_some_and(|l| x <= l) {
                return Err(invalid("stiffness.x_mm", x, "finite and increasing"));
            }
            x_mm.push(*x);
            compliance_um_per_n.push(1.0 / k);
        }
        Ok(Self {
            x_mm,
            compliance_um_per_n,
        })
    }

    /// This stiffness times `factor` everywhere (a deliberate error for a study).
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] for a product that is not finite and > 0.
    pub fn scaled(&self, factor: f64) -> Result<Self, MpcError> {
        if !(factor.is_finite() && factor > 0.0) {
            return Err(invalid("stiffness.scale", factor, "finite, > 0 product"));
        }
        Ok(Self {
            x_mm: self.x_mm.clone(),
            compliance_um_per_n: self
                .compliance_um_per_n
                .iter()
                .map(|c| c / factor)
                .collect(),
        })
    }

    /// The stiffness (N/µm) at `x_mm` along the feed axis; not finite: at the middle of the tests.
    pub fn n_per_um_at(&self, x_mm: f64) -> f64 {
        let (xs, cs) = (&self.x_mm, &self.compliance_um_per_n);
        let x = if x_mm.is_finite() {
            x_mm
        } else {
            0.5 * (xs[0] + xs[xs.len() - 1])
        };
        let i = xs.partition_point(|v| *v <= x);
        let c = if i == 0 {
            cs[0]
        } else if i == xs.len() {
            cs[xs.len() - 1]
        } else {
            let w = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
            cs[i - 1] + w * (cs[i] - cs[i - 1])
        };
        1.0 / c
    }
}

/// The measured-force channel every compensating controller reads through (same for all).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NcChannel {
    /// The force platform's sampling interval (s).
    pub force_dt_s: f64,
    /// Notch centre frequencies (Hz) of the reactive chain.
    pub notch_hz: Vec<f64>,
    /// The first-order low-pass after the notches (Hz), 120 in 003.
    pub lowpass_hz: f64,
}

impl NcChannel {
    /// 003's chain on a channel sampled every `force_dt_s` at `speed_rpm` with `teeth`: the notch
    /// frequencies of [`NotchChain::harmonics_003`] and 120 Hz.
    pub fn brecher_003(speed_rpm: f64, teeth: u32, force_dt_s: f64) -> Self {
        Self {
            force_dt_s,
            notch_hz: NotchChain::harmonics_003(speed_rpm, teeth, force_dt_s),
            lowpass_hz: 120.0,
        }
    }

    /// The notch chain.
    ///
    /// # Errors
    /// [`MpcError::Sim`] naming `f0_hz` for a notch at or above Nyquist, `cutoff_hz` for the low-pass.
    pub fn chain(&self) -> Result<NotchChain, MpcError> {
        Ok(NotchChain::at_frequencies(
            &self.notch_hz,
            self.lowpass_hz,
            self.force_dt_s,
        )?)
    }
}

/// What the NC gives the controllers every cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NcCycle {
    /// Cycle index from the program start.
    pub index: usize,
    /// The reference acceleration of this cycle (mm/s²).
    pub a_cmd_mm_s2: f64,
    /// The y axis' encoder (µm).
    pub y_axis_um: f64,
    /// The x axis' encoder (mm): where the tool is along the feed. Not finite: unknown.
    pub x_axis_mm: f64,
    /// The spindle's angle at the cycle's start (rad, accumulated; the NC's spindle encoder — an
    /// NC-internal datum like the reference acceleration). Not finite: unknown.
    pub spindle_angle_rad: f64,
}

/// A compensating controller in the position-control cycle.
pub trait NcController: Send {
    /// The controller's name (`none`, `reactive`, `proactive`, `mpc`).
    fn name(&self) -> &'static str;
    /// One force sample (N) of the platform, at its rate (NaN: a lost sample, ignored).
    fn force_sample(&mut self, fy_measured_n: f64);
    /// One position cycle: the correction (µm) to add to the y reference.
    ///
    /// # Errors
    /// [`MpcError`] for an inconsistent controller (not for a solver that did not converge).
    fn cycle(&mut self, c: &NcCycle) -> Result<f64, MpcError>;
    /// QP statistics (the MPC's).
    fn solver_stats(&self) -> Option<SolverStats> {
        None
    }
}

/// The correction actuator's limits: range (µm) and slew per cycle (µm), the same for every controller.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CorrectionLimits {
    /// Largest |correction| (µm).
    pub range_um: f64,
    /// Largest change per cycle (µm).
    pub slew_um_per_cycle: f64,
}

impl Default for CorrectionLimits {
    /// ±2 mm, 200 µm per 2 ms cycle (100 mm/s): an NC's limits on a superimposed correction (assumed).
    fn default() -> Self {
        Self {
            range_um: 2000.0,
            slew_um_per_cycle: 200.0,
        }
    }
}

impl CorrectionLimits {
    /// `u` made safe for the axis: a non-finite value holds `prev`; clamped to the slew around `prev`
    /// and to the range.
    ///
    /// ```
    /// use millcomp_mpc::nc_axis::CorrectionLimits;
    /// let l = CorrectionLimits::default();
    /// assert_eq!(l.apply(f64::NAN, 12.0), 12.0);
    /// assert_eq!(l.apply(-900.0, -10.0), -210.0);
    /// assert_eq!(l.apply(5000.0, 1950.0), 2000.0);
    /// ```
    pub fn apply(&self, u: f64, prev: f64) -> f64 {
        let v = if u.is_finite() { u } else { prev };
        v.clamp(prev - self.slew_um_per_cycle, prev + self.slew_um_per_cycle)
            .clamp(-self.range_um, self.range_um)
    }
}

/// No compensation.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoneNc;

impl NcController for NoneNc {
    fn name(&self) -> &'static str {
        "none"
    }
    fn force_sample(&mut self, _: f64) {}
    fn cycle(&mut self, _: &NcCycle) -> Result<f64, MpcError> {
        Ok(0.0)
    }
}

/// 003's reactive compensation (module doc).
#[derive(Debug, Clone)]
pub struct ReactiveNc {
    chain: NotchChain,
    k: IdentifiedNcStiffness,
    filtered: f64,
}

impl ReactiveNc {
    /// The chain of `channel` and the identified stiffness.
    ///
    /// # Errors
    /// Those of [`NcChannel::chain`].
    pub fn new(channel: &NcChannel, k: &IdentifiedNcStiffness) -> Result<Self, MpcError> {
        Ok(Self {
            chain: channel.chain()?,
            k: k.clone(),
            filtered: 0.0,
        })
    }
}

impl NcController for ReactiveNc {
    fn name(&self) -> &'static str {
        "reactive"
    }
    fn force_sample(&mut self, f: f64) {
        if f.is_finite() {
            self.filtered = self.chain.step(f);
        }
    }
    fn cycle(&mut self, c: &NcCycle) -> Result<f64, MpcError> {
        Ok(-self.filtered / self.k.n_per_um_at(c.x_axis_mm))
    }
}

/// When the proactive controller's offset curve is superimposed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OffsetWindow {
    /// From the cycle the reference acceleration becomes non-zero, for the curve's recorded length (003
    /// §2.3: "superimposed … for a short period at the feed rate step", "at the time when the reference
    /// acceleration … is unequal to zero").
    #[default]
    Recorded,
    /// Only while the reference acceleration is non-zero (the literal reading of Fig. 3's caption).
    Acceleration,
}

/// A recorded reference run: the platform's force samples and the NC's reference acceleration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NcReferenceRun {
    /// Force samples (N) at the platform's rate.
    pub force_n: Vec<f64>,
    /// Reference acceleration per cycle (mm/s²).
    pub a_cmd_mm_s2: Vec<f64>,
    /// The x axis' encoder per cycle (mm; empty or not finite: unknown).
    pub x_axis_mm: Vec<f64>,
    /// Force samples per cycle.
    pub samples_per_cycle: usize,
}

/// 003's offset curves: one per episode of non-zero reference acceleration in the reference run.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct OffsetCurve {
    /// Per episode, the offset (µm) per cycle from its first cycle.
    pub episodes: Vec<Vec<f64>>,
}

impl OffsetCurve {
    /// The fixed rule (no tuning): the *desired* actuating value is `−F̄(t + T_eq)/k`, the reference
    /// run's force averaged over one spindle revolution centred on each instant (zero phase) and read
    /// one identified axis delay `T_eq` ahead, so that the axis delivers it on time; the 6 Hz low-pass
    /// controller's actuating value on the same run is `−LP(F)/k`; the curve is their difference from
    /// the first cycle of each non-zero-acceleration episode until it stays below 2 % of its largest
    /// magnitude (at most 0.5 s), or — [`OffsetWindow::Acceleration`] — while the acceleration lasts.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`proactive.reference_run`) for an empty run or a zero sample count.
    pub fn from_reference_run(
        run: &NcReferenceRun,
        k: &IdentifiedNcStiffness,
        axis: &IdentifiedFeedAxis,
        speed_rpm: f64,
        cycle_s: f64,
        window: OffsetWindow,
    ) -> Result<Self, MpcError> {
        let spc = run.samples_per_cycle;
        if spc == 0 || run.force_n.is_empty() || run.a_cmd_mm_s2.is_empty() {
            return Err(invalid(
                "proactive.reference_run",
                "empty",
                "a recorded run with force samples and the NC's acceleration",
            ));
        }
        let dt = cycle_s / spc as f64;
        let f: Vec<f64> = run
            .force_n
            .iter()
            .map(|v| if v.is_finite() { *v } else { 0.0 })
            .collect();
        // one revolution, centred (prefix sums)
        let w = ((60.0 / speed_rpm) / dt).round().max(1.0) as usize;
        let mut prefix = vec![0.0; f.len() + 1];
        for (i, v) in f.iter().enumerate() {
            prefix[i + 1] = prefix[i] + v;
        }
        let mean_at = |i: usize| {
            let lo = i.saturating_sub(w / 2);
            let hi = (i + w / 2 + 1).min(f.len());
            (prefix[hi] - prefix[lo]) / (hi - lo).max(1) as f64
        };
        let mut lp = proactive_lowpass(dt)?;
        let mut lp_at_cycle = Vec::with_capacity(run.a_cmd_mm_s2.len());
        let mut last = 0.0;
        for c in 0..run.a_cmd_mm_s2.len() {
            // the value the NC reads at the start of cycle c: the samples of the cycles before it
            lp_at_cycle.push(last);
            for v in f.iter().take(((c + 1) * spc).min(f.len())).skip(c * spc) {
                last = lp.step(*v);
            }
        }
        let ahead = (axis.equivalent_delay_s() / dt).round() as usize;
        let kk = |c: usize| k.n_per_um_at(run.x_axis_mm.get(c).copied().unwrap_or(f64::NAN));
        let desired = |c: usize| -mean_at((c * spc + ahead).min(f.len().saturating_sub(1))) / kk(c);
        let n_cycles = run.a_cmd_mm_s2.len();
        let max_len = (0.5 / cycle_s).ceil() as usize;
        let mut episodes = Vec::new();
        let mut c = 0;
        while c < n_cycles {
            if run.a_cmd_mm_s2[c] == 0.0 {
                c += 1;
                continue;
            }
            let start = c;
            let mut end = c;
            while end < n_cycles && run.a_cmd_mm_s2[end] != 0.0 {
                end += 1;
            }
            let len = match window {
                OffsetWindow::Acceleration => end - start,
                OffsetWindow::Recorded => max_len.min(n_cycles - start),
            };
            let mut curve: Vec<f64> = (0..len)
                .map(|j| desired(start + j) - (-lp_at_cycle[start + j] / kk(start + j)))
                .collect();
            if window == OffsetWindow::Recorded {
                let peak = curve.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let last = curve
                    .iter()
                    .rposition(|v| v.abs() >= 0.02 * peak)
                    .map_or(0, |i| i + 1);
                curve.truncate(last.max(end - start));
            }
            episodes.push(curve);
            c = end;
        }
        Ok(Self { episodes })
    }
}

fn proactive_lowpass(dt_s: f64) -> Result<Biquad, MpcError> {
    Ok(millcomp_sim::filters::proactive_lowpass_003(dt_s)?)
}

/// 003's proactive compensation (module doc).
#[derive(Debug, Clone)]
pub struct ProactiveNc {
    lp: Biquad,
    filtered: f64,
    k: IdentifiedNcStiffness,
    curve: OffsetCurve,
    window: OffsetWindow,
    episode: usize,
    playing: Option<usize>,
    last_a: f64,
}

impl ProactiveNc {
    /// The 6 Hz, D = 1 low-pass at the force rate, the identified stiffness and the recorded curve.
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a force interval the low-pass cannot take.
    pub fn new(
        force_dt_s: f64,
        k: &IdentifiedNcStiffness,
        curve: OffsetCurve,
        window: OffsetWindow,
    ) -> Result<Self, MpcError> {
        Ok(Self {
            lp: proactive_lowpass(force_dt_s)?,
            filtered: 0.0,
            k: k.clone(),
            curve,
            window,
            episode: 0,
            playing: None,
            last_a: 0.0,
        })
    }
}

impl NcController for ProactiveNc {
    fn name(&self) -> &'static str {
        "proactive"
    }
    fn force_sample(&mut self, f: f64) {
        if f.is_finite() {
            self.filtered = self.lp.step(f);
        }
    }
    fn cycle(&mut self, c: &NcCycle) -> Result<f64, MpcError> {
        let accelerating = c.a_cmd_mm_s2 != 0.0;
        if accelerating && self.last_a == 0.0 {
            // a new episode starts: play its curve
            if self.episode < self.curve.episodes.len() {
                self.playing = Some(0);
            }
        }
        self.last_a = c.a_cmd_mm_s2;
        let mut u = -self.filtered / self.k.n_per_um_at(c.x_axis_mm);
        if let Some(j) = self.playing {
            let ep = &self.curve.episodes[self.episode];
            let stop =
                j >= ep.len() || (self.window == OffsetWindow::Acceleration && !accelerating);
            if stop {
                self.playing = None;
                self.episode += 1;
            } else {
                u += ep[j];
                self.playing = Some(j + 1);
            }
        }
        Ok(u)
    }
}

/// Grid step (mm) of the wall's engagement tables of [`NcPlan`]: at the exit the wall's engagement
/// falls by a third within a few hundredths of a millimetre (the front of the edge leaving).
const WALL_STEP_MM: f64 = 0.005;
/// Axial elements of the plan's cutter model: enough that the wall's engagement at the exit is
/// converged (a few µm; sim's default of 8 leaves steps of ≈ 25 µm there).
const PLAN_AXIAL_SLICES: usize = 32;
/// Grid step (mm) of the engagement tables of [`NcPlan`].
const ENGAGEMENT_STEP_MM: f64 = 0.05;
/// Angles per revolution of the engagement tables.
const ENGAGEMENT_SAMPLES: usize = 180;

/// The controllers' preview: the revolution-mean orthogonal force (N) and deflection (µm) planned for
/// every position cycle of the program — the NC's reference path through the identified x axis (the
/// position and feed the tool will actually have), the engagement on the programmed blank and the
/// identified Kienzle model, over the identified stiffness. Kienzle's law factorises,
/// `F̄_y = kc1.1·fz^(1−mc)·S_t(x) + kr1.1·fz^(1−mr)·S_r(x)`, with the engagement sums `S` tabulated
/// once near the blank's start and end (constant in between).
///
/// Two forces are planned: the revolution mean (what the force platform's filtered channel shows, for
/// the estimator) and the force at the instants the teeth generate the wall at `wall_height_mm` above
/// the floor (the NC knows its spindle angle; sim's `KienzleMillingModel::wall_forces_at`, the static
/// surface-error model) — the deflection the preview plans to cancel.
#[derive(Debug, Clone, PartialEq)]
pub struct NcPlan {
    force_n: Vec<f64>,
    deflection_um: Vec<f64>,
    wall: WallForcePlan,
}

/// What [`NcPlan::wall_force_n_at`] needs: the predicted path at the cycle starts and the engagement
/// tables of the wall's generation.
#[derive(Debug, Clone, PartialEq)]
struct WallForcePlan {
    xp: Vec<f64>,
    cycle_s: f64,
    per_mm_s: f64,
    coefficients: KienzleCoefficients,
    /// The engagement sums near the blank's start: `[(S_t, S_r) every ENGAGEMENT_STEP_MM, (S_t, S_r)
    /// at the wall every WALL_STEP_MM]`.
    start_tab: [Vec<[f64; 2]>; 2],
    /// The same near the blank's end.
    end_tab: [Vec<[f64; 2]>; 2],
    /// The wall force's sensitivity to each tooth's chip on the wall grid near the blank's start
    /// (sim's `KienzleMillingModel::wall_chip_sensitivity_at` of the unit laws, fz = 1 mm): per grid
    /// point, `teeth` pairs `(G_t, G_r)`, tooth `i` counted from the tooth at the wall in the
    /// direction of rotation.
    chip_start: Vec<[f64; 2]>,
    /// The same near the blank's end.
    chip_end: Vec<[f64; 2]>,
    blank_start_mm: f64,
    blank_end_mm: f64,
    radius_mm: f64,
    k: IdentifiedNcStiffness,
    teeth: usize,
    /// The spindle angle at which a tooth generates the wall at the plan's height (rad): π + the
    /// helix' lag over the height (the stage's convention).
    pass_angle_rad: f64,
    omega_rad_s: f64,
}

/// Where a tool centre is against the blank ([`WallForcePlan::zone`]).
enum Zone {
    Air,
    Inside,
    /// Over the start's tables, which begin at this position (mm).
    Start(f64),
    /// Over the end's tables, which begin at this position (mm).
    End(f64),
}

/// Row `col` of a table of `stride` pairs per grid point, interpolated linearly at the grid
/// coordinate `u` (clamped to the table).
fn lerp_row(tab: &[[f64; 2]], stride: usize, col: usize, u: f64) -> [f64; 2] {
    let n = tab.len() / stride;
    let u = u.clamp(0.0, (n - 1) as f64);
    let k = (u.floor() as usize).min(n - 2);
    let w = u - k as f64;
    let (a, b) = (tab[k * stride + col], tab[(k + 1) * stride + col]);
    std::array::from_fn(|j| a[j] * (1.0 - w) + b[j] * w)
}

impl WallForcePlan {
    /// Where the tool centre `x` is against the blank: in air, over the start's or the end's
    /// engagement tables (with the tables' first position), or inside (the full engagement).
    fn zone(&self, x: f64) -> Zone {
        let r = self.radius_mm;
        if x <= self.blank_start_mm - r || x >= self.blank_end_mm {
            Zone::Air
        } else if x < self.blank_start_mm {
            Zone::Start(self.blank_start_mm - r)
        } else if x > self.blank_end_mm - r {
            Zone::End(self.blank_end_mm - r)
        } else {
            Zone::Inside
        }
    }

    /// Engagement sums `(S_t, S_r, S_t at the wall, S_r at the wall)` at the tool centre `x`.
    fn sums(&self, x: f64) -> [f64; 4] {
        let both = |t: &[Vec<[f64; 2]>; 2], x0: f64| -> [f64; 4] {
            let m = lerp_row(&t[0], 1, 0, (x - x0) / ENGAGEMENT_STEP_MM);
            let w = lerp_row(&t[1], 1, 0, (x - x0) / WALL_STEP_MM);
            [m[0], m[1], w[0], w[1]]
        };
        match self.zone(x) {
            Zone::Air => [0.0; 4],
            Zone::Start(x0) => both(&self.start_tab, x0),
            Zone::End(x0) => both(&self.end_tab, x0),
            Zone::Inside => {
                let (m, w) = (&self.start_tab[0], &self.start_tab[1]);
                let (m, w) = (m[m.len() - 1], w[w.len() - 1]);
                [m[0], m[1], w[0], w[1]]
            }
        }
    }

    /// Tooth `i`'s `(G_t, G_r)` chip sensitivity at the tool centre `x` (see `chip_start`).
    fn chip_sums(&self, x: f64, i: usize) -> [f64; 2] {
        let z = self.teeth;
        match self.zone(x) {
            Zone::Air => [0.0; 2],
            Zone::Start(x0) => lerp_row(&self.chip_start, z, i, (x - x0) / WALL_STEP_MM),
            Zone::End(x0) => lerp_row(&self.chip_end, z, i, (x - x0) / WALL_STEP_MM),
            Zone::Inside => self.chip_start[self.chip_start.len() - z + i],
        }
    }

    /// Kienzle's two factors at feed per tooth `fz` (mm), `kc1.1·fz^(order−mc)` and
    /// `kr1.1·fz^(order−mr)`: order 1 the law's (the force), order 0 its derivative in the chip
    /// (`h = fz·sin φ`: the chip sensitivities'); 0 without a chip.
    fn law_factors(&self, fz: f64, order: f64) -> (f64, f64) {
        let c = &self.coefficients;
        if fz > 0.0 {
            (
                c.kc11_n_mm2 * fz.powf(order - c.mc),
                c.kr11_n_mm2 * fz.powf(order - c.mr),
            )
        } else {
            (0.0, 0.0)
        }
    }

    /// Kienzle's two factors at feed per tooth `fz` (mm).
    fn factors(&self, fz: f64) -> (f64, f64) {
        self.law_factors(fz, 1.0)
    }

    /// The chip sensitivities' two factors at feed per tooth `fz` (mm).
    fn chip_factors(&self, fz: f64) -> (f64, f64) {
        self.law_factors(fz, 0.0)
    }

    /// The path at time `t_s` from the program's start: position (mm) and feed per tooth (mm),
    /// linear between the cycle starts.
    fn path_at(&self, t_s: f64) -> (f64, f64) {
        let n = self.xp.len();
        let u = (t_s / self.cycle_s).clamp(0.0, (n - 1) as f64);
        let i = (u.floor() as usize).min(n.saturating_sub(2));
        let j = (i + 1).min(n - 1);
        let w = u - i as f64;
        let v = ((self.xp[j] - self.xp[i]) / self.cycle_s).max(0.0);
        (
            self.xp[i] + w * (self.xp[j] - self.xp[i]),
            v * self.per_mm_s,
        )
    }
}

impl NcPlan {
    /// The plan of `program` (its interpolator `interp`) with the controllers' models.
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] if the force model rejects the tables' unit coefficients (not
    /// expected for a validated model).
    pub fn new(
        program: &NcProgram,
        interp: &NcInterpolator,
        force: &IdentifiedKienzle,
        x_axis: &IdentifiedFeedAxis,
        k: &IdentifiedNcStiffness,
        wall_height_mm: f64,
    ) -> Result<Self, MpcError> {
        let ts = interp.cycle_s();
        let xr: Vec<f64> = (0..interp.len())
            .map(|c| interp.reference(c).x_mm)
            .collect();
        let xp = x_axis.respond(&xr, ts);
        let c = force.coefficients();
        let tool = force.0.tool;
        let r = tool.radius_mm();
        let unit = |kr: f64| -> Result<KienzleMillingModel, MpcError> {
            KienzleMillingModel::new(
                KienzleCoefficients {
                    kc11_n_mm2: 1.0,
                    mc: c.mc,
                    kr11_n_mm2: kr,
                    mr: c.mr,
                },
                tool,
            )
            .map_err(|source| MpcError::IdentifiedModel {
                key: "kienzle".into(),
                value: format!("{c:?}"),
                source,
            })
        };
        let (mt, mtr) = (unit(0.0)?, unit(1.0)?);
        // the wall's engagement with the catalogue cutter's edge integrated finely: a real edge
        // leaves the blank continuously (the revolution mean is smooth at the default resolution)
        let fine = |m: &KienzleMillingModel| KienzleMillingModel {
            axial_slices: PLAN_AXIAL_SLICES,
            ..m.clone()
        };
        let (mt_fine, mtr_fine) = (fine(&mt), fine(&mtr));
        // (S_t, S_r) at x_c = edge − r + i·step for the start (edge = blank start) and end tables,
        // on the revolution mean's grid; (S_t, S_r at the wall) on the finer wall grid: the wall's
        // engagement changes in steps as the edge's elements leave the blank
        let cut_at = |x: f64| CutState {
            x_center_mm: x,
            fz_mm: 1.0,
            ap_mm: program.ap_mm,
            ae_mm: program.ae_mm,
            blank_start_mm: program.blank_start_mm,
            blank_end_mm: program.blank_end_mm,
        };
        let mean_table = |x0: f64| -> Vec<[f64; 2]> {
            let n = (r / ENGAGEMENT_STEP_MM).round() as usize + 1;
            (0..n)
                .map(|i| {
                    let cut = cut_at(x0 + i as f64 * ENGAGEMENT_STEP_MM);
                    let st = mt.mean_forces_at(&cut, ENGAGEMENT_SAMPLES)[1];
                    let str_ = mtr.mean_forces_at(&cut, ENGAGEMENT_SAMPLES)[1];
                    [st, str_ - st]
                })
                .collect()
        };
        let wall_table = |x0: f64| -> Vec<[f64; 2]> {
            let n = (r / WALL_STEP_MM).round() as usize + 1;
            (0..n)
                .map(|i| {
                    let cut = cut_at(x0 + i as f64 * WALL_STEP_MM);
                    let wt = mt_fine.wall_forces_at(&cut, wall_height_mm)[1];
                    let wtr = mtr_fine.wall_forces_at(&cut, wall_height_mm)[1];
                    [wt, wtr - wt]
                })
                .collect()
        };
        // the chip sensitivities on the wall grid, `teeth` (G_t, G_r) pairs per point
        let chip_table = |x0: f64| -> Vec<[f64; 2]> {
            let n = (r / WALL_STEP_MM).round() as usize + 1;
            (0..n)
                .flat_map(|i| {
                    let cut = cut_at(x0 + i as f64 * WALL_STEP_MM);
                    let gt = mt_fine.wall_chip_sensitivity_at(&cut, wall_height_mm);
                    let gtr = mtr_fine.wall_chip_sensitivity_at(&cut, wall_height_mm);
                    gt.into_iter()
                        .zip(gtr)
                        .map(|(a, b)| [a, b - a])
                        .collect::<Vec<_>>()
                })
                .collect()
        };
        let wall = WallForcePlan {
            chip_start: chip_table(program.blank_start_mm - r),
            chip_end: chip_table(program.blank_end_mm - r),
            start_tab: [
                mean_table(program.blank_start_mm - r),
                wall_table(program.blank_start_mm - r),
            ],
            end_tab: [
                mean_table(program.blank_end_mm - r),
                wall_table(program.blank_end_mm - r),
            ],
            xp,
            cycle_s: ts,
            per_mm_s: 60.0 / (program.speed_rpm * tool.teeth as f64),
            coefficients: c,
            blank_start_mm: program.blank_start_mm,
            blank_end_mm: program.blank_end_mm,
            radius_mm: r,
            k: k.clone(),
            teeth: tool.teeth as usize,
            pass_angle_rad: PI + wall_height_mm * tool.helix_deg.to_radians().tan() / r,
            omega_rad_s: 2.0 * PI * program.speed_rpm / 60.0,
        };
        let xp = &wall.xp;
        let mut force_n = Vec::with_capacity(xp.len());
        let mut deflection_um = Vec::with_capacity(xp.len());
        for i in 0..xp.len() {
            let x1 = xp[(i + 1).min(xp.len() - 1)];
            let v = ((x1 - xp[i]) / ts).max(0.0);
            let (gt, gr) = wall.factors(v * wall.per_mm_s);
            let xm = 0.5 * (xp[i] + x1);
            let s4 = wall.sums(xm);
            force_n.push(gt * s4[0] + gr * s4[1]);
            deflection_um.push((gt * s4[2] + gr * s4[3]) / wall.k.n_per_um_at(xm));
        }
        Ok(Self {
            force_n,
            deflection_um,
            wall,
        })
    }

    /// The planned orthogonal force (N) at the instant `t_s` after the program's start if a tooth
    /// generated the wall then: the predicted path interpolated between the cycle starts, its feed per
    /// tooth, the engagement at the wall's generation.
    pub fn wall_force_n_at(&self, t_s: f64) -> f64 {
        let (x, fz) = self.wall.path_at(t_s);
        let (gt, gr) = self.wall.factors(fz);
        let s4 = self.wall.sums(x);
        gt * s4[2] + gr * s4[3]
    }

    /// The runout's force (N) at the instant `t_s` if the tooth labelled `label` generated the wall
    /// then: `Σ_i G_i · chip_mm[(label − i) mod Z]`, with `G_i` the planned wall force's sensitivity to
    /// the chip of the tooth `i` pitches on from the one at the wall (the predicted path's position
    /// and feed per tooth) and `chip_mm` each tooth's chip increment (mm; labels as the passes count
    /// them: pass `p` is generated by tooth `p mod Z`, the tooth after it by `p − 1`).
    pub fn chip_force_n_at(&self, t_s: f64, chip_mm: &[f64], label: usize) -> f64 {
        let (x, fz) = self.wall.path_at(t_s);
        let (gt, gr) = self.wall.chip_factors(fz);
        let z = self.wall.teeth;
        if chip_mm.len() != z || (gt == 0.0 && gr == 0.0) {
            return 0.0;
        }
        (0..z)
            .map(|i| {
                let s = self.wall.chip_sums(x, i);
                (gt * s[0] + gr * s[1]) * chip_mm[(label + z - i) % z]
            })
            .sum()
    }

    /// The chip sensitivities `G_i` (N/mm) of the full engagement at feed per tooth `fz_mm` (see
    /// [`Self::chip_force_n_at`]), into `out` (`teeth` values).
    fn full_chip_sensitivity(&self, fz_mm: f64, out: &mut [f64]) {
        let (gt, gr) = self.wall.chip_factors(fz_mm);
        let z = self.wall.teeth;
        let full = &self.wall.chip_start[self.wall.chip_start.len() - z..];
        for (o, s) in out.iter_mut().zip(full) {
            *o = gt * s[0] + gr * s[1];
        }
    }

    /// The wall's engagement at the instant `t_s` after the program's start: the planned wall force
    /// ([`Self::wall_force_n_at`]) over the wall force of the full engagement (inside the blank) at the
    /// same feed per tooth — 1 inside the blank, falling to 0 as the cutter leaves it (rising at the
    /// entry), 0 in air.
    pub fn wall_engagement_at(&self, t_s: f64) -> f64 {
        let (x, fz) = self.wall.path_at(t_s);
        let (gt, gr) = self.wall.factors(fz);
        let full = self.wall.start_tab[1]
            .last()
            .map_or(0.0, |w| gt * w[0] + gr * w[1]);
        if full <= 0.0 {
            return 0.0;
        }
        let s4 = self.wall.sums(x);
        ((gt * s4[2] + gr * s4[3]) / full).clamp(0.0, 1.0)
    }

    /// The predicted position (mm) of the tool at the start of cycle `k` (the last beyond the end).
    pub fn position_mm(&self, k: usize) -> f64 {
        self.wall.xp[k.min(self.wall.xp.len() - 1)]
    }

    /// The stiffness (N/µm) the plan's deflection of cycle `k` is over: the identified stiffness at
    /// the cycle's predicted position.
    pub fn stiffness_n_per_um_at(&self, k: usize) -> f64 {
        self.wall.k.n_per_um_at(self.position_mm(k))
    }

    /// The position cycle (s).
    pub fn cycle_s(&self) -> f64 {
        self.wall.cycle_s
    }

    /// Planned revolution-mean orthogonal force (N) of cycle `k` (the last beyond the end).
    pub fn force_n(&self, k: usize) -> f64 {
        self.force_n[k.min(self.force_n.len() - 1)]
    }

    /// Planned deflection (µm) of cycle `k`: the force at the wall's generation over the stiffness.
    pub fn deflection_um(&self, k: usize) -> f64 {
        self.deflection_um[k.min(self.deflection_um.len() - 1)]
    }

    /// Number of cycles.
    pub fn len(&self) -> usize {
        self.force_n.len()
    }

    /// Whether the plan is empty (never for a valid program).
    pub fn is_empty(&self) -> bool {
        self.force_n.is_empty()
    }

    /// The range (max − min) of the planned wall force (N; deflection × stiffness) over cycles
    /// `from ..= to`.
    pub fn wall_force_range_n(&self, from: usize, to: usize) -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in from..=to {
            let f = self.deflection_um(k) * self.stiffness_n_per_um_at(k);
            lo = lo.min(f);
            hi = hi.max(f);
        }
        if hi >= lo { hi - lo } else { 0.0 }
    }

    /// The range (max − min) of the planned force over cycles `from ..= to`.
    pub fn force_range_n(&self, from: usize, to: usize) -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in from..=to {
            let f = self.force_n(k);
            lo = lo.min(f);
            hi = hi.max(f);
        }
        if hi >= lo { hi - lo } else { 0.0 }
    }
}

/// The blend of measured and predicted force (003 §4): a scalar Kalman filter on the ratio `s` of the
/// true to the planned force, `z = s·h + v`, with `z` the measured force and `h` the planned force, both
/// through the same filter chain (so a delay of the chain is not read as a model error). Its
/// measurement variance is the chain's noise plus the square of the range the planned force swept
/// over the chain's settling window: while the plan is changing — a feed change, the entry, the exit —
/// the filtered measurement says little about `s` and the filter keeps its estimate (the prediction
/// leads); at constant conditions it follows the measurement with a time constant of about
/// `σ_rel/√q` cycles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScaleEstimator {
    /// The estimate of `s`.
    pub s: f64,
    /// Its variance.
    pub p: f64,
    /// Random-walk variance of `s` per cycle.
    pub q: f64,
    /// Variance of the filtered measurement at rest (N²).
    pub r0_n2: f64,
    /// Relative floor of the measurement's error (tooth ripple the chain leaves, model shape).
    pub rel_floor: f64,
    /// Below this planned force (N) nothing is learnt (the tool in air).
    pub min_force_n: f64,
}

impl ScaleEstimator {
    /// Start at `s = 1` with a 10 % prior; q = (5·10⁻⁴)² per cycle, a 0.5 % floor (a time constant of
    /// about 10 cycles, 20 ms, at constant conditions); learn above 50 N.
    pub fn new(r0_n2: f64) -> Self {
        Self {
            s: 1.0,
            p: 0.01,
            q: 2.5e-7,
            r0_n2,
            rel_floor: 0.005,
            min_force_n: 50.0,
        }
    }

    /// One cycle: measured `z`, planned `h` (both filtered), the planned force's recent range (N).
    pub fn update(&mut self, z: f64, h: f64, recent_range_n: f64) {
        self.p += self.q;
        if !(z.is_finite() && h.is_finite()) || h.abs() < self.min_force_n {
            return;
        }
        let r = self.r0_n2 + (self.rel_floor * h).powi(2) + recent_range_n.powi(2);
        let k = self.p * h / (h * h * self.p + r);
        self.s = (self.s + k * (z - self.s * h)).clamp(0.5, 2.0);
        self.p *= 1.0 - k * h;
    }
}

/// The MPC's settings (fixed here; `mpc/CONFIG.md` keys for [`MpcConfig`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NcMpcSettings {
    /// The QP's configuration.
    pub mpc: MpcConfig,
    /// Cycles over which a change of the plan keeps the estimator on the prediction (the chain's
    /// settling).
    pub estimator_window_cycles: usize,
    /// Plan for the instants the teeth generate the wall ([`WallInstants`]) when the NC gives the
    /// spindle's angle: the preview's deflection at each tooth pass, the force measured at the passes
    /// scaling it per tooth. Off (or no angle): the plan at the cycle starts scaled by the
    /// revolution-mean force.
    pub wall_instants: bool,
    /// Cycles back over which a change of the planned wall force keeps the wall-instant estimator on
    /// the prediction: its samples are raw (no filter to settle), so only the sweep itself.
    pub wall_window_cycles: usize,
    /// How the wall instants plan each tooth's offset where the engagement or the feed changes.
    pub tooth_offsets: ToothOffsets,
}

impl NcMpcSettings {
    /// The same settings with the harness's cycle `budget` applied.
    pub fn with_budget(mut self, budget: crate::config::CycleBudget) -> Self {
        budget.apply(&mut self.mpc.solver);
        self
    }

    /// Horizon 25 cycles (50 ms: three axis delays), moves blocked 1,1,1,2,2,3,3,4,4,4; tracking weight
    /// 1/µm², 10⁻³ per µm² of move (at 10⁻⁴ the command chattered, ≈ 13 µm per cycle, at 133 Hz and
    /// above, which the axis does not pass: twice the travel for the same wall); the correction
    /// limits of [`CorrectionLimits::default`]; an output disturbance on the axis position (what the
    /// axis model misses); the encoder's noise 10⁻⁴ µm²; the estimator's window 40 cycles (80 ms);
    /// planning for the wall instants with a 2-cycle window, each tooth's offset through its chip.
    pub fn default_nc() -> Self {
        let l = CorrectionLimits::default();
        let mut mpc = MpcConfig::siso(25, -l.range_um, l.range_um, l.slew_um_per_cycle);
        mpc.move_blocking = Some(vec![1, 1, 1, 2, 2, 3, 3, 4, 4, 4]);
        mpc.weights.output = vec![1.0];
        mpc.weights.input_rate = vec![1e-3];
        mpc.disturbance.kind = DisturbanceKind::Output;
        mpc.kalman.input_noise = 1.0;
        mpc.kalman.disturbance_noise = 1e-2;
        mpc.kalman.measurement_noise = vec![1e-4];
        Self {
            mpc,
            estimator_window_cycles: 40,
            wall_instants: true,
            wall_window_cycles: 2,
            tooth_offsets: ToothOffsets::Chip,
        }
    }
}

/// How [`WallInstants`] plans each tooth's offset (the runout's force) where the engagement changes —
/// the entry and the exit — from the offsets it learnt at full engagement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ToothOffsets {
    /// As learnt, whatever the engagement.
    Constant,
    /// Times the wall's engagement ([`NcPlan::wall_engagement_at`]): the runout's force taken to fall
    /// as the whole force does.
    Engagement,
    /// Through each tooth's chip: the offsets at full engagement are the chip increments of the teeth
    /// (a runout's radius steps) seen through the plan's chip sensitivities; those increments are
    /// solved for and planned through the sensitivities of the engagement and feed ahead
    /// ([`NcPlan::chip_force_n_at`]). As the cutter leaves the blank the teeth that carry the runout's
    /// force leave one by one, and the tooth at the wall — whose chip is thin there — keeps a larger
    /// share of its own runout than of the force.
    Chip,
}

/// The wall's generation in time, for [`MpcNc`] (`NcMpcSettings::wall_instants`): the wall is cut
/// at the instants a tooth passes it (the static surface-error model; the stage's convention), so the
/// preview's deflection is planned at the tooth passes — from the spindle's angle at the cycle start
/// and the programmed speed — and interpolated in time between them to the cycle starts (a
/// deflection that changes between two passes is met at the passes, not in between). The force the
/// platform measures at a pass is the force that generates the wall there: every pass updates the
/// scale of the planned wall force ([`ScaleEstimator`], raw samples: no filter delay) and, at
/// constant conditions and full engagement, an additive offset per tooth (the runout: a few per cent
/// of the force per tooth), kept with zero mean over the teeth; at the entry, the exit and another feed
/// it is planned through each tooth's chip ([`ToothOffsets::Chip`]).
#[derive(Debug, Clone, PartialEq)]
pub struct WallInstants {
    /// The scale of the planned wall force.
    pub scale: ScaleEstimator,
    /// Additive force per tooth (N), in the order the passes count them.
    pub tooth_offsets_n: Vec<f64>,
    /// The offsets' gain per pass of their tooth.
    pub offset_gain: f64,
    /// How the offsets are planned where the engagement or the feed changes.
    pub offsets: ToothOffsets,
    /// Each tooth's chip increment (mm) behind the offsets ([`ToothOffsets::Chip`]).
    chip_mm: Vec<f64>,
    /// The full engagement's chip sensitivities at the feed the offsets were learnt at, and the
    /// discrete Fourier transform's work space (real, imaginary) of the solve for `chip_mm`.
    sens: Vec<f64>,
    dft: Vec<[f64; 2]>,
    force_dt_s: f64,
    theta0: f64,
    t0: f64,
    n: usize,
    last_pass: Option<i64>,
}

impl WallInstants {
    fn new(teeth: usize, force_dt_s: f64, r0_n2: f64) -> Self {
        let mut scale = ScaleEstimator::new(r0_n2);
        // one update per pass (≈ 166 Hz here): a time constant of about 3 passes at constant
        // conditions
        scale.q = 2.5e-6;
        Self {
            scale,
            tooth_offsets_n: vec![0.0; teeth],
            offset_gain: 0.2,
            offsets: ToothOffsets::Chip,
            chip_mm: vec![0.0; teeth],
            sens: vec![0.0; teeth],
            dft: vec![[0.0; 2]; teeth],
            force_dt_s,
            theta0: f64::NAN,
            t0: 0.0,
            n: 0,
            last_pass: None,
        }
    }

    /// The pass index at angle `theta` (a pass `p` happens at `pass_angle + 2πp/Z`).
    fn pass_index(plan: &WallForcePlan, theta: f64) -> i64 {
        ((theta - plan.pass_angle_rad) * plan.teeth as f64 / (2.0 * PI)).floor() as i64
    }

    /// The time of pass `p` from this cycle's start angle and time.
    fn pass_time(&self, plan: &WallForcePlan, p: i64) -> f64 {
        let angle = plan.pass_angle_rad + 2.0 * PI * p as f64 / plan.teeth as f64;
        self.t0 + (angle - self.theta0) / plan.omega_rad_s
    }

    /// The planned deflection (µm) a pass `p` at time `t` generates the wall with.
    fn deflection_at_pass(&self, plan: &NcPlan, p: i64, t: f64) -> f64 {
        let tooth = p.rem_euclid(plan.wall.teeth as i64) as usize;
        let h = plan.wall_force_n_at(t);
        if h <= 0.0 {
            return 0.0;
        }
        (self.scale.s * h + self.offset_n(plan, tooth, t))
            / plan.wall.k.n_per_um_at(plan.wall.path_at(t).0)
    }

    /// Tooth `tooth`'s additive force (N) at time `t` ([`ToothOffsets`]).
    fn offset_n(&self, plan: &NcPlan, tooth: usize, t: f64) -> f64 {
        match self.offsets {
            ToothOffsets::Constant => self.tooth_offsets_n[tooth],
            ToothOffsets::Engagement => self.tooth_offsets_n[tooth] * plan.wall_engagement_at(t),
            ToothOffsets::Chip => plan.chip_force_n_at(t, &self.chip_mm, tooth),
        }
    }

    /// Solve for the teeth's chip increments behind the offsets learnt at feed per tooth `fz_mm` and
    /// full engagement: the offsets are the circular convolution of the increments with the chip
    /// sensitivities (`o_a = Σ_i G_i·Δh_(a−i)`), so each Fourier mode is divided by the
    /// sensitivities' — Tikhonov-damped at 10⁻³ of the largest mode, the mean mode (the scale's)
    /// left out. No allocation.
    fn solve_chips(&mut self, plan: &NcPlan, fz_mm: f64) {
        let z = self.sens.len();
        plan.full_chip_sensitivity(fz_mm, &mut self.sens);
        let w = 2.0 * PI / z as f64;
        let transform = |v: &[f64], k: usize| -> [f64; 2] {
            v.iter().enumerate().fold([0.0, 0.0], |acc, (n, x)| {
                let a = w * (k * n) as f64;
                [acc[0] + x * a.cos(), acc[1] - x * a.sin()]
            })
        };
        let largest = (1..z)
            .map(|k| {
                let g = transform(&self.sens, k);
                g[0].hypot(g[1])
            })
            .fold(0.0, f64::max);
        let eps = (1e-3 * largest).powi(2);
        self.dft[0] = [0.0; 2];
        for k in 1..z {
            let g = transform(&self.sens, k);
            let o = transform(&self.tooth_offsets_n, k);
            let d = g[0] * g[0] + g[1] * g[1] + eps;
            // o · conj(g) / (|g|² + ε)
            self.dft[k] = if d > 0.0 {
                [
                    (o[0] * g[0] + o[1] * g[1]) / d,
                    (o[1] * g[0] - o[0] * g[1]) / d,
                ]
            } else {
                [0.0; 2]
            };
        }
        for (n, c) in self.chip_mm.iter_mut().enumerate() {
            *c = self
                .dft
                .iter()
                .enumerate()
                .map(|(k, h)| {
                    let a = w * (k * n) as f64;
                    h[0] * a.cos() - h[1] * a.sin()
                })
                .sum::<f64>()
                / z as f64;
        }
    }

    /// The planned deflection (µm) at time `t`: between the passes around it, linear in time.
    fn deflection_at(&self, plan: &NcPlan, t: f64) -> f64 {
        let theta = self.theta0 + plan.wall.omega_rad_s * (t - self.t0);
        let pa = Self::pass_index(&plan.wall, theta);
        let (ta, tb) = (
            self.pass_time(&plan.wall, pa),
            self.pass_time(&plan.wall, pa + 1),
        );
        let (da, db) = (
            self.deflection_at_pass(plan, pa, ta),
            self.deflection_at_pass(plan, pa + 1, tb),
        );
        let w = ((t - ta) / (tb - ta)).clamp(0.0, 1.0);
        da + w * (db - da)
    }

    /// A new cycle `k` at spindle angle `theta` (rad).
    fn start_cycle(&mut self, plan: &NcPlan, k: usize, theta: f64) {
        self.t0 = k as f64 * plan.wall.cycle_s;
        self.theta0 = theta;
        self.n = 0;
        if self.last_pass.is_none() {
            self.last_pass = Some(Self::pass_index(&plan.wall, theta));
        }
    }

    /// One force sample (N); at a pass, learn from it (`range_n`: the planned wall force's range over
    /// the estimator's window).
    fn sample(&mut self, plan: &NcPlan, f: f64, range_n: f64) {
        if !self.theta0.is_finite() {
            return;
        }
        self.n += 1;
        let t = self.t0 + self.n as f64 * self.force_dt_s;
        let theta = self.theta0 + plan.wall.omega_rad_s * (t - self.t0);
        let p = Self::pass_index(&plan.wall, theta);
        if self.last_pass == Some(p) {
            return;
        }
        self.last_pass = Some(p);
        if !f.is_finite() {
            return;
        }
        let tooth = p.rem_euclid(plan.wall.teeth as i64) as usize;
        let h = plan.wall_force_n_at(t);
        let offset = self.offset_n(plan, tooth, t);
        self.scale.update(f - offset, h, range_n);
        // the offsets only at constant conditions (1 % of the force) — at full engagement, or (the
        // engagement-scaled offsets) referred to it
        let e = plan.wall_engagement_at(t);
        let (learn, refer) = match self.offsets {
            ToothOffsets::Engagement => (e > 0.5, e),
            ToothOffsets::Constant => (true, 1.0),
            ToothOffsets::Chip => (e > 0.999, 1.0),
        };
        if h.abs() >= self.scale.min_force_n && range_n < 0.01 * h.abs() && learn {
            let a = &mut self.tooth_offsets_n[tooth];
            *a += self.offset_gain * ((f - self.scale.s * h) / refer - *a);
            let mean = self.tooth_offsets_n.iter().sum::<f64>() / self.tooth_offsets_n.len() as f64;
            for a in &mut self.tooth_offsets_n {
                *a -= mean;
            }
            if self.offsets == ToothOffsets::Chip {
                self.solve_chips(plan, plan.wall.path_at(t).1);
            }
        }
    }
}

/// The MPC in the NC (module doc).
#[derive(Debug)]
pub struct MpcNc {
    mpc: MpcController,
    plan: NcPlan,
    meas_chain: NotchChain,
    plan_chain: NotchChain,
    meas: f64,
    planned: f64,
    cycle: usize,
    estimator: ScaleEstimator,
    window: usize,
    horizon: usize,
    preview: PreviewWindow,
    wall: Option<WallInstants>,
    wall_window: usize,
}

impl MpcNc {
    /// Build on the identified y axis at the program's cycle, with the plan, the shared channel and the
    /// force channel's noise level at rest (σ, N, from the commissioning).
    ///
    /// # Errors
    /// The MPC's construction errors ([`MpcController::new`]), those of the channel, and
    /// [`MpcError::InvalidConfig`] (`force_noise_n`) for a negative or non-finite noise level.
    pub fn new(
        y_axis: &IdentifiedFeedAxis,
        cycle_s: f64,
        plan: NcPlan,
        channel: &NcChannel,
        force_noise_n: f64,
        settings: &NcMpcSettings,
    ) -> Result<Self, MpcError> {
        if !(force_noise_n.is_finite() && force_noise_n >= 0.0) {
            return Err(invalid("force_noise_n", force_noise_n, "finite, >= 0"));
        }
        let model = y_axis.discrete(cycle_s)?;
        let mpc = MpcController::new(&model, &settings.mpc)?;
        let meas_chain = channel.chain()?;
        // the chain's noise gain: the energy of its impulse response
        let mut probe = channel.chain()?;
        let mut gain2 = 0.0;
        for i in 0..20_000 {
            let y = probe.step(if i == 0 { 1.0 } else { 0.0 });
            gain2 += y * y;
        }
        let horizon = settings.mpc.horizon;
        Ok(Self {
            mpc,
            plan_chain: meas_chain.clone(),
            meas_chain,
            meas: 0.0,
            planned: 0.0,
            cycle: 0,
            estimator: ScaleEstimator::new(force_noise_n * force_noise_n * gain2),
            window: settings.estimator_window_cycles,
            horizon,
            preview: PreviewWindow::zeros(horizon, 1),
            wall: settings.wall_instants.then(|| {
                let mut w = WallInstants::new(
                    plan.wall.teeth,
                    channel.force_dt_s,
                    force_noise_n * force_noise_n,
                );
                w.offsets = settings.tooth_offsets;
                w
            }),
            wall_window: settings.wall_window_cycles,
            plan,
        })
    }

    /// The wall-instant planning's state (`None` when off).
    pub fn wall_instants(&self) -> Option<&WallInstants> {
        self.wall.as_ref()
    }

    /// The estimator's current state.
    pub fn estimator(&self) -> &ScaleEstimator {
        &self.estimator
    }
}

impl NcController for MpcNc {
    fn name(&self) -> &'static str {
        "mpc"
    }
    fn force_sample(&mut self, f: f64) {
        if f.is_finite() {
            self.meas = self.meas_chain.step(f);
        }
        self.planned = self.plan_chain.step(self.plan.force_n(self.cycle));
        if let Some(w) = self.wall.as_mut() {
            let k = self.cycle;
            let range = self
                .plan
                .wall_force_range_n(k.saturating_sub(self.wall_window), k + 1);
            w.sample(&self.plan, f, range);
        }
    }
    fn cycle(&mut self, c: &NcCycle) -> Result<f64, MpcError> {
        let cycle_start = std::time::Instant::now();
        self.cycle = c.index;
        let k = c.index;
        let range = self
            .plan
            .force_range_n(k.saturating_sub(self.window), k + 1);
        self.estimator.update(self.meas, self.planned, range);
        let s = self.estimator.s;
        let ts = self.plan.cycle_s();
        let w0 = match self.wall.as_mut() {
            Some(w) if c.spindle_angle_rad.is_finite() => {
                w.start_cycle(&self.plan, k, c.spindle_angle_rad);
                for j in 0..self.horizon {
                    self.preview.offsets[j] = w.deflection_at(&self.plan, (k + 1 + j) as f64 * ts);
                }
                w.deflection_at(&self.plan, k as f64 * ts)
            }
            _ => {
                for j in 0..self.horizon {
                    self.preview.offsets[j] = s * self.plan.deflection_um(k + 1 + j);
                }
                s * self.plan.deflection_um(k)
            }
        };
        self.preview.offset_now[0] = w0;
        for j in 0..self.horizon {
            self.preview.reference[j] = 0.0;
        }
        let y = if c.y_axis_um.is_finite() {
            c.y_axis_um + w0
        } else {
            f64::NAN
        };
        let step = self.mpc.step_from(cycle_start, &[y], &self.preview)?;
        Ok(step.u[0])
    }
    fn solver_stats(&self) -> Option<SolverStats> {
        Some(self.mpc.stats())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_models::{FitStatus, NamedMatrix};

    fn fit(params: &[(&str, f64)]) -> IdentifiedModel {
        IdentifiedModel {
            status: FitStatus::Converged,
            n_obs: 10,
            dof: 8,
            rms_residual: 0.0,
            residual_unit: "um".into(),
            warnings: vec![],
            params: params.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
            std_err: Default::default(),
            fixed: Default::default(),
            derived: Default::default(),
            covariance: NamedMatrix::default(),
        }
    }

    #[test]
    fn the_discrete_axis_is_the_identified_recursion() {
        // 5 ms dead time (2.5 cycles) + 12 ms lag at 2 ms
        let ax =
            IdentifiedFeedAxis::new(&fit(&[("dead_time_s", 0.005), ("lag_s", 0.012)])).unwrap();
        let r: Vec<f64> = (0..60).map(|i| if i >= 3 { 100.0 } else { 0.0 }).collect();
        let want = ax.respond(&r, 0.002);
        let lti = ax.discrete(0.002).unwrap();
        let mut x = lti.zero_state();
        for (i, ri) in r.iter().enumerate() {
            let y = (lti.c.clone() * &x)[0];
            assert!((y - want[i]).abs() < 1e-9, "cycle {i}: {y} vs {}", want[i]);
            x = &lti.a * &x + &lti.b * *ri;
        }
        // unit gain: a position loop follows its reference
        assert!((want[59] - 100.0).abs() < 0.2);
        assert!(IdentifiedFeedAxis::new(&fit(&[("dead_time_s", 0.005)])).is_err());
    }

    #[test]
    fn a_measured_step_response_model_reproduces_the_trace() {
        // a trace of the 4 ms + 12 ms dead time + lag recursion: step up at cycle 10, down at 70
        let ax =
            IdentifiedFeedAxis::new(&fit(&[("dead_time_s", 0.004), ("lag_s", 0.012)])).unwrap();
        // then a ramp to 100 and a hold: its last increment is no step from rest
        let r: Vec<f64> = (0..230)
            .map(|i| match i {
                10..70 => 100.0,
                130..180 => 2.0 * (i - 130) as f64,
                180.. => 100.0,
                _ => 0.0,
            })
            .collect();
        let p = ax.respond(&r, 0.002);
        let st = IdentifiedFeedAxis::step_response_from_trace(&r, &p).unwrap();
        // the step down at 70 (from 60 cycles of rest, held 61 cycles); the step up at 10 follows
        // only 10 cycles of rest and is left out
        assert_eq!(st.len(), 61);
        // nothing for the 4 ms (two cycles) of dead time, then the lag: 1 − e^(−2 ms/12 ms) one
        // cycle later (the axis had settled to 6e-5 of the step before it)
        assert!(st[..3].iter().all(|v| v.abs() < 1e-4), "{:?}", &st[..3]);
        assert!(
            (st[3] - (1.0 - (-1.0f64 / 6.0).exp())).abs() < 1e-4,
            "{}",
            st[3]
        );
        let m = ax.clone().with_step_response(st, 0.002).unwrap();
        assert!(m.has_step_response());
        // a ramp and a sine (up to 170 µm) through the FIR and through the recursion: the same within
        // the 60-cycle truncation (e^(−116/12) = 6e-5 of a step) and the down step's start, not quite
        // settled
        let u: Vec<f64> = (0..300)
            .map(|i| 0.5 * i as f64 + 20.0 * (0.3 * i as f64).sin())
            .collect();
        let want = ax.respond(&u, 0.002);
        let got = m.respond(&u, 0.002);
        let lti = m.discrete(0.002).unwrap();
        // the state-space form from rest at u_0 … the FIR's registers hold u_0 before the start
        let mut x = nalgebra::DVector::from_element(lti.n_states(), u[0]);
        for (i, ui) in u.iter().enumerate() {
            let y = (lti.c.clone() * &x)[0];
            assert!(
                (got[i] - want[i]).abs() < 0.02,
                "respond, cycle {i}: {} vs {}",
                got[i],
                want[i]
            );
            assert!(
                (y - want[i]).abs() < 0.02,
                "discrete, cycle {i}: {y} vs {}",
                want[i]
            );
            x = &lti.a * &x + &lti.b * *ui;
        }
        // another cycle than the measured one falls back to the dead time + lag
        assert_eq!(m.respond(&u, 0.001), ax.respond(&u, 0.001));
    }

    /// 003's slot at a constant 500 mm/min over a 40 mm blank, planned with a commissioned-like model
    /// (stiffness 14 N/µm).
    fn slot_40mm_plan() -> (NcInterpolator, NcPlan) {
        let program = NcProgram {
            feed_changes: vec![],
            blank_end_mm: 40.0,
            end_mm: 50.0,
            ..NcProgram::brecher_003()
        };
        let interp = NcInterpolator::new(&program, 10).unwrap();
        let force = IdentifiedKienzle::new(
            &fit(&[
                ("kc11_n_mm2", 1800.0),
                ("mc", 0.25),
                ("kr11_n_mm2", 550.0),
                ("mr", 0.45),
            ]),
            &NominalEndMill::brecher_003(),
        )
        .unwrap();
        let axis =
            IdentifiedFeedAxis::new(&fit(&[("dead_time_s", 0.006), ("lag_s", 0.010)])).unwrap();
        let k = IdentifiedNcStiffness::new(&fit(&[("stiffness_n_per_um", 14.0)])).unwrap();
        let plan = NcPlan::new(&program, &interp, &force, &axis, &k, 1.0).unwrap();
        (interp, plan)
    }

    /// The plan's force model as sim's cutter: its coefficients, the catalogue tool, 32 elements.
    fn plan_force_model(plan: &NcPlan) -> KienzleMillingModel {
        KienzleMillingModel {
            axial_slices: 32,
            ..KienzleMillingModel::new(
                plan.wall.coefficients,
                NominalEndMill::brecher_003().end_mill(),
            )
            .unwrap()
        }
    }

    /// Spindle angle at t = 0 and platform sampling interval of the wall-instant tests.
    const THETA0: f64 = 0.3;
    const PLATFORM_DT_S: f64 = 1e-4;

    /// Feed `w` the platform's force `platform(t, pass)` at 20 samples per NC cycle for the `cycles`
    /// first cycles of `plan`.
    fn learn(
        w: &mut WallInstants,
        plan: &NcPlan,
        cycles: usize,
        platform: impl Fn(f64, i64) -> f64,
    ) {
        let (ts, omega) = (plan.cycle_s(), plan.wall.omega_rad_s);
        for c in 0..cycles {
            let t0 = c as f64 * ts;
            w.start_cycle(plan, c, THETA0 + omega * t0);
            let range = plan.wall_force_range_n(c.saturating_sub(2), c + 1);
            for n in 1..=20 {
                let t = t0 + n as f64 * PLATFORM_DT_S;
                let p = WallInstants::pass_index(&plan.wall, THETA0 + omega * t);
                w.sample(plan, platform(t, p), range);
            }
        }
    }

    #[test]
    fn the_wall_instants_learn_the_force_at_the_passes_per_tooth() {
        // 003's slot at a constant 500 mm/min over a 40 mm blank, a commissioned-like model
        let (interp, plan) = slot_40mm_plan();
        // the platform: 4 % above the plan at the passes, plus a per-tooth pattern (zero mean), and
        // something else between the passes (never used)
        let pattern = [60.0, -20.0, -50.0, 30.0, -20.0];
        let (ts, omega, theta0) = (plan.cycle_s(), plan.wall.omega_rad_s, THETA0);
        let mut w = WallInstants::new(5, PLATFORM_DT_S, 4.0);
        let n_cycles = interp.cycle_at_x(30.0).unwrap();
        learn(&mut w, &plan, n_cycles, |t, p| {
            1.04 * plan.wall_force_n_at(t) + pattern[p.rem_euclid(5) as usize]
        });
        assert!((w.scale.s - 1.04).abs() < 2e-3, "{}", w.scale.s);
        for (a, b) in w.tooth_offsets_n.iter().zip(pattern) {
            assert!((a - b).abs() < 5.0, "{:?}", w.tooth_offsets_n);
        }
        // the preview at a pass instant is that pass' deflection; between passes it lies between
        let c = n_cycles;
        w.start_cycle(&plan, c, theta0 + omega * c as f64 * ts);
        let p = WallInstants::pass_index(&plan.wall, theta0 + omega * c as f64 * ts) + 1;
        let tp = w.pass_time(&plan.wall, p);
        let d = w.deflection_at_pass(&plan, p, tp);
        assert!((w.deflection_at(&plan, tp) - d).abs() < 1e-9);
        let want = (1.04 * plan.wall_force_n_at(tp) + pattern[p.rem_euclid(5) as usize]) / 14.0;
        assert!((d - want).abs() < 0.5, "{d} vs {want}");
    }

    #[test]
    fn the_tooth_offsets_follow_each_teeths_chip_into_the_exit() {
        // the platform at the passes: sim's cutter with a 3 µm runout (its chip `fz·sin φ + R_i −
        // R_(i−1)`, not linearised), 4 % above the plan's coefficients, on the plan's predicted path.
        // In the exit the teeth that carry the runout's force leave one by one: the offsets learnt at
        // full engagement, planned through each tooth's chip, give each pass' deflection there;
        // scaled with the whole force's engagement, or held, they do not
        let (interp, plan) = slot_40mm_plan();
        let ts = plan.cycle_s();
        let at_x = |x: f64| interp.cycle_at_x(x).unwrap() as f64 * ts;
        assert!((plan.wall_engagement_at(at_x(20.0)) - 1.0).abs() < 1e-12);
        assert_eq!(plan.wall_engagement_at(at_x(45.0)), 0.0);
        let mut truth = plan_force_model(&plan);
        truth.coefficients = truth.coefficients.scaled(1.04);
        (truth.tool.runout_um, truth.tool.runout_phase_deg) = (3.0, 70.0);
        let (omega, theta0) = (plan.wall.omega_rad_s, THETA0);
        let platform = |t: f64, p: i64| {
            let (x, fz) = plan.wall.path_at(t);
            let cut = CutState {
                x_center_mm: x,
                fz_mm: fz,
                ap_mm: 8.0,
                ae_mm: 16.0,
                blank_start_mm: 0.0,
                blank_end_mm: 40.0,
            };
            truth.forces(plan.wall.pass_angle_rad + 2.0 * PI * p as f64 / 5.0, &cut)[1]
        };
        let mut rms_by = vec![];
        for offsets in [
            ToothOffsets::Chip,
            ToothOffsets::Engagement,
            ToothOffsets::Constant,
        ] {
            let mut w = WallInstants::new(5, PLATFORM_DT_S, 4.0);
            w.offsets = offsets;
            learn(&mut w, &plan, interp.cycle_at_x(30.0).unwrap(), platform);
            // the runout's force per tooth is tens of N here
            let spread = w
                .tooth_offsets_n
                .iter()
                .fold(0.0, |m: f64, a| m.max(a.abs()));
            assert!(spread > 20.0, "{:?}", w.tooth_offsets_n);
            // the preview over the exit's first 3 mm (the engagement from 1 to ≈ 0.2), pass by pass
            let (c0, c1) = (
                interp.cycle_at_x(32.0).unwrap(),
                interp.cycle_at_x(35.0).unwrap(),
            );
            // each pass once: its error (µm)
            let mut errors = vec![];
            let mut last = None;
            for c in c0..c1 {
                w.start_cycle(&plan, c, theta0 + omega * c as f64 * ts);
                let p = WallInstants::pass_index(&plan.wall, theta0 + omega * c as f64 * ts) + 1;
                if last == Some(p) {
                    continue;
                }
                last = Some(p);
                let tp = w.pass_time(&plan.wall, p);
                errors.push(w.deflection_at_pass(&plan, p, tp) - platform(tp, p) / 14.0);
            }
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
            rms_by.push(rms);
        }

        // rms over the exit's passes: the chip-planned offsets leave a fraction of the others'
        assert!(rms_by[0] < 0.6, "chip: {rms_by:?} um rms in the exit");
        assert!(
            rms_by[1] > 4.0 * rms_by[0] && rms_by[2] > 4.0 * rms_by[0],
            "{rms_by:?}"
        );
    }

    #[test]
    fn the_estimator_trusts_the_measurement_only_at_constant_conditions() {
        let mut e = ScaleEstimator::new(0.1);
        // constant conditions: the measured force is 8 % above the plan → s follows within 100 cycles
        for _ in 0..100 {
            e.update(1080.0, 1000.0, 0.0);
        }
        assert!((e.s - 1.08).abs() < 0.005, "{}", e.s);
        // while the plan sweeps 1000 N, a lagging measurement (−30 %) hardly moves it
        let s0 = e.s;
        for _ in 0..40 {
            e.update(0.7 * 1000.0, 1000.0, 1000.0);
        }
        assert!((e.s - s0).abs() < 0.01, "{} → {}", s0, e.s);
        // in air nothing is learnt
        e.update(5.0, 1.0, 0.0);
        assert!((e.s - s0).abs() < 0.01);
    }

    #[test]
    fn the_offset_curve_leads_the_low_pass() {
        // a reference run: 1000 N stepping to 2000 N 10 cycles after a 5-cycle acceleration starts
        let spc = 20;
        let n_cycles = 400;
        let a: Vec<f64> = (0..n_cycles)
            .map(|c| if (100..105).contains(&c) { 1000.0 } else { 0.0 })
            .collect();
        let f: Vec<f64> = (0..n_cycles * spc)
            .map(|i| if i >= 110 * spc { 2000.0 } else { 1000.0 })
            .collect();
        let run = NcReferenceRun {
            force_n: f,
            a_cmd_mm_s2: a,
            // the x encoder not recorded: the stiffness of the tests' middle
            x_axis_mm: vec![],
            samples_per_cycle: spc,
        };
        let k = IdentifiedNcStiffness::new(&fit(&[("stiffness_n_per_um", 10.0)])).unwrap();
        let ax =
            IdentifiedFeedAxis::new(&fit(&[("dead_time_s", 0.004), ("lag_s", 0.012)])).unwrap();
        let c =
            OffsetCurve::from_reference_run(&run, &k, &ax, 1990.0, 0.002, OffsetWindow::Recorded)
                .unwrap();
        assert_eq!(c.episodes.len(), 1);
        let ep = &c.episodes[0];
        // the desired value (−F/k read 16 ms ahead) leads: the curve is negative (more compensation)
        // and about the step's 100 µm at most (+0.5 µm: the low-pass, started at 0 under 1000 N, has
        // not quite settled 0.2 s later)
        let peak = ep.iter().fold(0.0f64, |m, v| m.min(*v));
        assert!((-100.5..-50.0).contains(&peak), "{peak}");
        // the 6 Hz low-pass settles within ~0.3 s: the curve ends well before 0.5 s
        assert!(ep.len() > 5 && ep.len() < 250, "{}", ep.len());
        let lit = OffsetCurve::from_reference_run(
            &run,
            &k,
            &ax,
            1990.0,
            0.002,
            OffsetWindow::Acceleration,
        )
        .unwrap();
        assert_eq!(lit.episodes[0].len(), 5);
    }
}
