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

/// The controllers' model of a feed axis: dead time + first-order lag (`identify feed-axis`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifiedFeedAxis {
    dead_time_s: f64,
    lag_s: f64,
}

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
        Ok(Self { dead_time_s, lag_s })
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
        dead_time_lag_response(reference, p0, cycle_s, self.dead_time_s, self.lag_s)
    }
}

/// The controllers' static stiffness at the tool (load–deflection test, `identify stiffness`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifiedNcStiffness(f64);

impl IdentifiedNcStiffness {
    /// From a `stiffness` fit (`stiffness_n_per_um`).
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (`stiffness.stiffness_n_per_um`) for a missing or non-positive value.
    pub fn new(m: &IdentifiedModel) -> Result<Self, MpcError> {
        let k = param(m, "stiffness", "stiffness_n_per_um")?;
        if k <= 0.0 {
            return Err(invalid("stiffness.stiffness_n_per_um", k, "> 0"));
        }
        Ok(Self(k))
    }

    /// This stiffness times `factor` (a deliberate error for a study).
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] for a product that is not finite and > 0.
    pub fn scaled(&self, factor: f64) -> Result<Self, MpcError> {
        let k = self.0 * factor;
        if k.is_finite() && k > 0.0 {
            Ok(Self(k))
        } else {
            Err(invalid("stiffness.scale", factor, "finite, > 0 product"))
        }
    }

    /// The stiffness (N/µm).
    pub fn n_per_um(&self) -> f64 {
        self.0
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
    k: f64,
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
            k: k.n_per_um(),
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
    fn cycle(&mut self, _: &NcCycle) -> Result<f64, MpcError> {
        Ok(-self.filtered / self.k)
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
        let kk = k.n_per_um();
        let desired = |c: usize| -mean_at((c * spc + ahead).min(f.len().saturating_sub(1))) / kk;
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
                .map(|j| desired(start + j) - (-lp_at_cycle[start + j] / kk))
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
    k: f64,
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
            k: k.n_per_um(),
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
        let mut u = -self.filtered / self.k;
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
        let n_grid = (r / ENGAGEMENT_STEP_MM).round() as usize + 1;
        // (S_t, S_r, S_t at the wall, S_r at the wall) at x_c = edge − r + i·step for the start
        // (edge = blank start) and end tables
        let table = |x0: f64| -> Vec<[f64; 4]> {
            (0..n_grid)
                .map(|i| {
                    let cut = CutState {
                        x_center_mm: x0 + i as f64 * ENGAGEMENT_STEP_MM,
                        fz_mm: 1.0,
                        ap_mm: program.ap_mm,
                        ae_mm: program.ae_mm,
                        blank_start_mm: program.blank_start_mm,
                        blank_end_mm: program.blank_end_mm,
                    };
                    let st = mt.mean_forces_at(&cut, ENGAGEMENT_SAMPLES)[1];
                    let str_ = mtr.mean_forces_at(&cut, ENGAGEMENT_SAMPLES)[1];
                    let wt = mt.wall_forces_at(&cut, wall_height_mm)[1];
                    let wtr = mtr.wall_forces_at(&cut, wall_height_mm)[1];
                    [st, str_ - st, wt, wtr - wt]
                })
                .collect()
        };
        let start_tab = table(program.blank_start_mm - r);
        let end_tab = table(program.blank_end_mm - r);
        let full = start_tab[n_grid - 1];
        let lookup = |tab: &[[f64; 4]], x0: f64, x: f64| -> [f64; 4] {
            let u = ((x - x0) / ENGAGEMENT_STEP_MM).clamp(0.0, (n_grid - 1) as f64);
            let i = (u.floor() as usize).min(n_grid - 2);
            let w = u - i as f64;
            std::array::from_fn(|j| tab[i][j] * (1.0 - w) + tab[i + 1][j] * w)
        };
        let sums = |x: f64| -> [f64; 4] {
            if x <= program.blank_start_mm - r || x >= program.blank_end_mm {
                [0.0; 4]
            } else if x < program.blank_start_mm {
                lookup(&start_tab, program.blank_start_mm - r, x)
            } else if x > program.blank_end_mm - r {
                lookup(&end_tab, program.blank_end_mm - r, x)
            } else {
                full
            }
        };
        let per_mm_s = 60.0 / (program.speed_rpm * tool.teeth as f64);
        let kk = k.n_per_um();
        let mut force_n = Vec::with_capacity(xp.len());
        let mut deflection_um = Vec::with_capacity(xp.len());
        for i in 0..xp.len() {
            let x1 = xp[(i + 1).min(xp.len() - 1)];
            let v = ((x1 - xp[i]) / ts).max(0.0);
            let fz = v * per_mm_s;
            let s4 = sums(0.5 * (xp[i] + x1));
            let (gt, gr) = if fz > 0.0 {
                (
                    c.kc11_n_mm2 * fz.powf(1.0 - c.mc),
                    c.kr11_n_mm2 * fz.powf(1.0 - c.mr),
                )
            } else {
                (0.0, 0.0)
            };
            force_n.push(gt * s4[0] + gr * s4[1]);
            deflection_um.push((gt * s4[2] + gr * s4[3]) / kk);
        }
        Ok(Self {
            force_n,
            deflection_um,
        })
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
}

impl NcMpcSettings {
    /// The same settings with the harness's cycle `budget` applied.
    pub fn with_budget(mut self, budget: crate::config::CycleBudget) -> Self {
        budget.apply(&mut self.mpc.solver);
        self
    }

    /// Horizon 25 cycles (50 ms: three axis delays), moves blocked 1,1,1,2,2,3,3,4,4,4; tracking weight
    /// 1/µm², 10⁻⁴ per µm² of move; the correction limits of [`CorrectionLimits::default`]; an output
    /// disturbance on the axis position (what the axis model misses); the encoder's noise 10⁻⁴ µm²;
    /// the estimator's window 40 cycles (80 ms).
    pub fn default_nc() -> Self {
        let l = CorrectionLimits::default();
        let mut mpc = MpcConfig::siso(25, -l.range_um, l.range_um, l.slew_um_per_cycle);
        mpc.move_blocking = Some(vec![1, 1, 1, 2, 2, 3, 3, 4, 4, 4]);
        mpc.weights.output = vec![1.0];
        mpc.weights.input_rate = vec![1e-4];
        mpc.disturbance.kind = DisturbanceKind::Output;
        mpc.kalman.input_noise = 1.0;
        mpc.kalman.disturbance_noise = 1e-2;
        mpc.kalman.measurement_noise = vec![1e-4];
        Self {
            mpc,
            estimator_window_cycles: 40,
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
            plan,
            meas: 0.0,
            planned: 0.0,
            cycle: 0,
            estimator: ScaleEstimator::new(force_noise_n * force_noise_n * gain2),
            window: settings.estimator_window_cycles,
            horizon,
            preview: PreviewWindow::zeros(horizon, 1),
        })
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
        let w0 = s * self.plan.deflection_um(k);
        self.preview.offset_now[0] = w0;
        for j in 0..self.horizon {
            self.preview.offsets[j] = s * self.plan.deflection_um(k + 1 + j);
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
