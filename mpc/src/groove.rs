//! The groove controllers (`000_…txt` ch. 6–7, the PZT-actuated spindle), stepped at the stage rate.
//!
//! Every controller sees only what a machine offers: the measured force and the gauge reading
//! ([`GrooveMeasurement`]), the planned process (sim's [`GrooveProgram`] and the [`DeflectionPlan`] the
//! controllers compute from it with their *own* models) and their own models (force predictor,
//! identified stiffness, spindle). None of them is built from the truth plant.
//!
//! Sign conventions (sim's stage): depth cut `d = d_cmd − δz + tip·sin α`, + = deeper; the PZT moves the
//! tip radially, so a z-correction δz needs a tip travel δz / sin α (eq. 26).
//!
//! - [`NoneController`]: 0 V (the touch-off's bias, [`TouchOff`]);
//! - [`OpenLoopController`] (ch. 6): predicted per-revolution peak z-force of the planned cut × the
//!   controllers' z-compliance = predicted deflection; the tip is driven to it open loop through the
//!   spindle's static gain. The thesis pre-shifted the machine path; sim's groove stage has no
//!   programmable path table yet, so the pre-shift is applied through the actuator (the same
//!   quasi-static correction; the 20 kHz actuator is far faster than the 12 s ramp);
//! - [`PidController`] (ch. 7): measured force → 500 Hz 2nd-order filter → nested peak-and-hold →
//!   first-order 0.0005/0.9995 filter → × compliance / sin α = wanted tip; gauge → 500 Hz filter; PID on
//!   the difference (eq. 25) at the 20 kHz stage rate;
//! - [`MpcGrooveController`]: every `mpc_every` steps (2 kHz), the [`crate::spindle_mpc`] design with
//!   preview of the planned deflection, measured deflection = one-revolution sliding peak
//!   ([`SlidingMax`]) of the 2 kHz-low-passed force × compliance; a sensor reading that stays
//!   bit-identical too long is left out of the measurement update.

use crate::identified::{HysteresisCompensator, IdentifiedSpindle, IdentifiedStiffness};
use millcomp_sim::DiscreteLti;
use millcomp_sim::SimError;
use millcomp_sim::feed::FeedProfile;
use millcomp_sim::filters::{Biquad, FirstOrderFilter, PeakHold, SlidingMax};
use millcomp_sim::force::CutConditions;
use millcomp_sim::groove::{GrooveProgram, PathOffset};
use nalgebra::DMatrix;

use crate::config::CycleBudget;
use crate::config::{DisturbanceCoupling, Intersample, MpcConfig};
use crate::controller::{MpcController, MpcCycle, PreviewWindow};
use crate::error::MpcError;
use crate::pid::{AntiWindup, Pid, PidGains};
use crate::predictor::ForcePredictor;
use crate::spindle_mpc::{OUT_ERROR, OUT_GAUGE, default_spindle_config};
use crate::stats::SolverStats;
use crate::stroke::StrokeBand;

/// Cut-off of the force pre-filter every force-fed controller reads through (Hz): a critically damped
/// 2nd-order low-pass, well above the 333 Hz flute frequency so the per-revolution peak is kept, low
/// enough to take the 0.04 N sensor noise down by ~2× (the filtered noise's σ is 0.475 of the sensor's).
/// It does not overshoot, unlike the [`BUTTERWORTH_PREFILTER_HZ`] Butterworth it replaced
/// ([`ForcePeakChain::butterworth`]).
pub const FORCE_PREFILTER_HZ: f64 = 3000.0;

/// Cut-off of the Butterworth force pre-filter of [`ForcePeakChain::butterworth`] (Hz), the chain the
/// controllers read through before the critically damped one: the same noise reduction (σ × 0.463).
pub const BUTTERWORTH_PREFILTER_HZ: f64 = 2000.0;

/// Samples of `dt_s` in a revolution at `speed_rpm` (at least 1).
fn samples_per_rev(speed_rpm: f64, dt_s: f64) -> usize {
    ((60.0 / speed_rpm / dt_s).round() as usize).max(1)
}

/// Whether `x_mm` lies in one of the spans `[x₀, x₁)` (mm) — e.g. the plan's rubbing spans
/// ([`DeflectionPlan::rubbing_spans_mm`]).
fn within_spans(spans: &[(f64, f64)], x_mm: f64) -> bool {
    spans.iter().any(|&(a, b)| (a..b).contains(&x_mm))
}

/// The force chain the MPC, `pid-tuned` and `pid-ff` read through: the measured force through the
/// critically damped [`FORCE_PREFILTER_HZ`] 2nd-order low-pass, then the one-revolution sliding peak
/// ([`SlidingMax`]).
#[derive(Debug, Clone)]
pub struct ForcePeakChain {
    low_pass: Biquad,
    peak: SlidingMax,
    /// The pre-filter as built and the peak's window (samples): what [`Self::reset`] returns to.
    initial: Biquad,
    window: usize,
}

impl ForcePeakChain {
    /// The chain for a spindle at `speed_rpm`, sampled every `dt_s`.
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a pre-filter above Nyquist.
    pub fn new(speed_rpm: f64, dt_s: f64) -> Result<Self, MpcError> {
        let low_pass = Biquad::low_pass(FORCE_PREFILTER_HZ, 1.0, dt_s)?;
        Ok(Self::with_low_pass(low_pass, speed_rpm, dt_s))
    }

    /// `low_pass`, then the one-revolution sliding peak at `speed_rpm`, sampled every `dt_s`.
    fn with_low_pass(low_pass: Biquad, speed_rpm: f64, dt_s: f64) -> Self {
        let window = samples_per_rev(speed_rpm, dt_s);
        Self {
            low_pass,
            peak: SlidingMax::new(window),
            initial: low_pass,
            window,
        }
    }

    /// Back to the state as built: the filter at rest, the peak's window empty.
    pub fn reset(&mut self) {
        self.low_pass = self.initial;
        self.peak = SlidingMax::new(self.window);
    }

    /// The chain with the [`BUTTERWORTH_PREFILTER_HZ`] Butterworth (damping 0.707) instead of the
    /// critically damped pre-filter — the chain before. At 40° the z-force of a tooth pass ends abruptly
    /// at its peak; the Butterworth's 4 % overshoot rings off that edge, so its peak reads up to 1.7 %
    /// above the force's, by an amount that jumps whenever the edge crosses a sample (on the 40° ramp at
    /// ≈ 20 and ≈ 60 µm of depth: the revolution's samples fall at the same angles every revolution), a
    /// saw-tooth of ≈ 0.1 µm in every force-fed controller's error. The critically damped filter reads
    /// the peak within 0.1 % of it.
    ///
    /// # Errors
    /// As [`Self::new`].
    ///
    /// ```
    /// use millcomp_mpc::groove::ForcePeakChain;
    /// use millcomp_sim::force::BallEndForceModel;
    /// use millcomp_sim::groove::GrooveProgram;
    /// // the z-force of the 40° ramp's tool at 19.50 and 19.75 µm of depth, 120 samples a revolution
    /// // (10 000 rpm, 20 kHz); each chain's reading over the largest sample
    /// let (model, program) = (BallEndForceModel::default(), GrooveProgram::thesis(40.0));
    /// let ratio = |mut chain: ForcePeakChain, depth_um: f64| {
    ///     let rev = model.revolution(&program.conditions_at(depth_um, 10.0), 120).unwrap();
    ///     let top = rev.iter().map(|f| f[2]).fold(f64::MIN, f64::max);
    ///     let mut y = 0.0;
    ///     for _ in 0..8 {
    ///         for f in &rev {
    ///             y = chain.step(f[2]);
    ///         }
    ///     }
    ///     y / top
    /// };
    /// let (rpm, dt) = (10_000.0, 5e-5);
    /// let jump = |make: &dyn Fn() -> ForcePeakChain| ratio(make(), 19.75) - ratio(make(), 19.5);
    /// let butterworth = jump(&|| ForcePeakChain::butterworth(rpm, dt).unwrap());
    /// let damped = jump(&|| ForcePeakChain::new(rpm, dt).unwrap());
    /// // the Butterworth's reading drops by 1.2 % of the peak there; the damped one's moves by 0.01 %
    /// assert!(butterworth < -0.01 && damped.abs() < 0.001, "{butterworth} {damped}");
    /// ```
    pub fn butterworth(speed_rpm: f64, dt_s: f64) -> Result<Self, MpcError> {
        let low_pass = Biquad::low_pass(
            BUTTERWORTH_PREFILTER_HZ,
            std::f64::consts::FRAC_1_SQRT_2,
            dt_s,
        )?;
        Ok(Self::with_low_pass(low_pass, speed_rpm, dt_s))
    }

    /// One force sample (N) in, the filtered per-revolution peak (N) out.
    pub fn step(&mut self, force_n: f64) -> f64 {
        self.peak.step(self.low_pass.step(force_n))
    }
}

/// The force chain's noise bias, calibrated: the mean reading of a [`ForcePeakChain`] against the true
/// per-revolution peak `A` of a force `A·w(angle)` seen with Gaussian noise of the commissioned σ, and
/// its inverse ([`GrooveMpcFeatures::unbiased_peak`]).
///
/// The largest of a revolution's noisy samples is biased up: with no force the chain reads the noise's
/// own maximum, and the bias falls as the force's peak rises above the noise. The table is built once
/// by running the chain itself on the waveform `w` (the force model's; flat without one) with noise from
/// a fixed seed, at peaks 0, σ/2, … 40σ, [`PeakNoiseBias::REVOLUTIONS`] revolutions each; above 40σ the
/// last offset is kept.
///
/// ```
/// use millcomp_mpc::groove::PeakNoiseBias;
/// // 10 000 rpm at 20 kHz, σ 0.04 N, a flat force
/// let b = PeakNoiseBias::calibrate(10_000.0, 5e-5, 0.04, &[]).unwrap();
/// // no force: the filtered noise's largest of a revolution's 120 samples, 0.046 N (≈ 2.4 of the
/// // filtered noise's σ of 0.019 N)
/// assert!((0.042..0.050).contains(&b.floor_n()), "{}", b.floor_n());
/// assert_eq!(b.unbiased(b.floor_n()), 0.0);
/// // a flat 1 N reads ≈ 1 N plus the same maximum; the inverse takes it off
/// assert!((b.unbiased(1.0 + b.floor_n()) - 1.0).abs() < 0.01);
/// // no noise: nothing to take off
/// let exact = PeakNoiseBias::calibrate(10_000.0, 5e-5, 0.0, &[]).unwrap();
/// assert_eq!(exact.unbiased(0.7), 0.7);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PeakNoiseBias {
    peaks_n: Vec<f64>,
    means_n: Vec<f64>,
}

impl PeakNoiseBias {
    /// Revolutions averaged per tabulated peak.
    pub const REVOLUTIONS: usize = 100;

    /// Calibrate the chain of [`ForcePeakChain::new`]`(speed_rpm, dt_s)` against noise σ
    /// `noise_sigma_n` (N) on the per-revolution `waveform` (relative to its peak, starting anywhere;
    /// empty: flat).
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a negative or non-finite σ or a pre-filter above Nyquist.
    pub fn calibrate(
        speed_rpm: f64,
        dt_s: f64,
        noise_sigma_n: f64,
        waveform: &[f64],
    ) -> Result<Self, MpcError> {
        let steps = samples_per_rev(speed_rpm, dt_s);
        let w: Vec<f64> = (0..steps)
            .map(|k| match waveform.len() {
                0 => 1.0,
                n => waveform[k * n / steps % n],
            })
            .collect();
        let grid = if noise_sigma_n > 0.0 { 81 } else { 1 };
        let (mut peaks_n, mut means_n) = (Vec::with_capacity(grid), Vec::with_capacity(grid));
        for j in 0..grid {
            let a = j as f64 * 0.5 * noise_sigma_n;
            let mut chain = ForcePeakChain::new(speed_rpm, dt_s)?;
            // the same draws at every peak: the table is smooth in it
            let mut noise = millcomp_sim::sensors::NoiseSource::new(0x5eed_b1a5, noise_sigma_n)?;
            let (mut sum, mut n) = (0.0, 0usize);
            for r in 0..Self::REVOLUTIONS + 2 {
                for &wk in &w {
                    let y = chain.step(a * wk + noise.sample());
                    // two revolutions to fill the filter and the window
                    if r >= 2 {
                        sum += y;
                        n += 1;
                    }
                }
            }
            peaks_n.push(a);
            means_n.push(sum / n as f64);
        }
        // the mean reading rises with the peak; keep it strictly so against the draws' residual noise
        for j in 1..means_n.len() {
            means_n[j] = means_n[j].max(means_n[j - 1] + 1e-12);
        }
        Ok(Self { peaks_n, means_n })
    }

    /// The chain's mean reading with no force (N): the noise's per-revolution maximum.
    pub fn floor_n(&self) -> f64 {
        self.means_n[0]
    }

    /// The per-revolution peak (N) whose mean reading is `reading_n`: 0 at or below the noise's floor,
    /// interpolated in the table, the last offset taken off above it.
    pub fn unbiased(&self, reading_n: f64) -> f64 {
        let (p, m) = (&self.peaks_n, &self.means_n);
        let last = m.len() - 1;
        if last == 0 {
            return (reading_n - (m[0] - p[0])).max(0.0);
        }
        if reading_n <= m[0] {
            return 0.0;
        }
        if reading_n >= m[last] {
            return reading_n - (m[last] - p[last]);
        }
        let j = m.partition_point(|&v| v <= reading_n).max(1);
        let t = (reading_n - m[j - 1]) / (m[j] - m[j - 1]);
        p[j - 1] + t * (p[j] - p[j - 1])
    }
}

/// What the groove controllers measure at each stage step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrooveMeasurement {
    /// Measured force (N): the workpiece z-force of the stage's force channel.
    pub force_meas_n: f64,
    /// Capacitance-gauge reading of the tool-tip displacement (µm).
    pub gauge_um: f64,
}

/// The planned deflection seen by the controllers: `δ̂(x) = Fz,peak(predictor, d_cmd(x), f(x)) · e(x) ·
/// c_z,model` with the programmed depth `d_cmd`, the upfeed `f` of the planned feed motion (feed changes
/// with the axis acceleration) and the engagement `e` (workpiece exit), tabulated along x.
#[derive(Debug, Clone)]
pub struct DeflectionPlan {
    xs_mm: Vec<f64>,
    values_um: Vec<f64>,
    /// The planned deflection without the cap at the depth (µm), at the same points.
    flank_um: Vec<f64>,
    /// The loop gain `c·∂F/∂d` where the deflection exceeds the depth, 0 elsewhere, at the same points.
    loop_gain: Vec<f64>,
    feed: FeedProfile,
    /// The smaller flute's peak z-force over the larger's (1 without runout; one flute per revolution
    /// sets the deflection where it is well below 1).
    flute_ratio: f64,
    /// The z-force over one revolution relative to its peak, [`WAVEFORM_SAMPLES`] angles starting at
    /// the peak, from the force model (empty for a predictor without a waveform).
    waveform: Vec<f64>,
    /// Tabulated points where the force predictor extrapolated beyond its fitted range.
    pub extrapolated_points: usize,
    /// A depth offset along the path the controllers were told of (µm, + = deeper; empty: none):
    /// an identified effect the deflection model lacks ([`Self::with_path_offset`]).
    path_offset: PathOffset,
}

impl DeflectionPlan {
    /// Tabulate the plan every `dx_mm` along the programmed groove and at its corners (depth-profile
    /// points and steps, the ends of feed accelerations, the entry and the exit: a step made at once is
    /// a step in the plan, not a `dx_mm` ramp), with the controllers' force
    /// predictor and stiffness, for a tool of ball radius `tool_radius_um` (programmed depths are
    /// clamped to it).
    ///
    /// # Errors
    /// [`MpcError::Sim`] for an invalid program (feed motion) or a tilt the stiffness cannot take; a
    /// predictor error.
    ///
    /// ```
    /// use millcomp_models::{ForceModelParams, StiffnessModel};
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_mpc::identified::{IdentifiedForceModel, IdentifiedStiffness, NominalTool};
    /// use millcomp_mpc::predictor::ForcePredictor;
    /// use millcomp_sim::groove::GrooveProgram;
    /// // the thesis' 20° groove, predicted with a force model whose W was identified at 3× the
    /// // published S7 value, and a calibrated stiffness
    /// let program = GrooveProgram::thesis(20.0);
    /// let tool = NominalTool::thesis_ball_end("S7");
    /// let w = 3.0 * tool.force_model().unwrap().material.w_mpa;
    /// let p = ForceModelParams {
    ///     fitted: [("w_mpa".to_string(), w)].into(),
    ///     fixed: Default::default(),
    ///     covariance: Default::default(),
    /// };
    /// let predictor = ForcePredictor::Mechanistic(IdentifiedForceModel::new(&p, &tool).unwrap());
    /// let k = IdentifiedStiffness::new(&StiffnessModel {
    ///     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
    /// }).unwrap();
    /// let plan = DeflectionPlan::new(&program, &predictor, &k, tool.radius_um, 0.01).unwrap();
    /// assert_eq!(plan.n_points(), 2001); // 20 mm every 10 µm, both ends
    /// assert_eq!(plan.deflection_at(0.0), 0.0); // the ramp starts at 0 µm
    /// // at the deep end: the peak force of the full programmed 80 µm times the z-compliance
    /// let f = predictor.peak_z_force_n(&program.conditions_at(80.0, 10.0)).unwrap();
    /// let c = k.stiffness().z_compliance_um_per_n(20.0).unwrap();
    /// let end = plan.deflection_at(20.0);
    /// assert!((end - f * c).abs() < 1e-9 && end > 5.0, "{end}");
    /// ```
    pub fn new(
        program: &GrooveProgram,
        force: &ForcePredictor,
        model_stiffness: &IdentifiedStiffness,
        tool_radius_um: f64,
        dx_mm: f64,
    ) -> Result<Self, MpcError> {
        let c = model_stiffness
            .stiffness()
            .z_compliance_um_per_n(program.tilt_deg)?;
        let mut extrapolated = 0;
        let mut plan = Self::tabulate(program, tool_radius_um, dx_mm, c, |cond| {
            if force
                .response_surface()
                .is_some_and(|r| r.extrapolates(cond))
            {
                extrapolated += 1;
            }
            force.peak_z_force_n(cond)
        })?;
        plan.extrapolated_points = extrapolated;
        if let Some(m) = force.mechanistic() {
            plan.flute_ratio = flute_ratio(m.model(), program, tool_radius_um)?;
            plan.waveform = waveform(m.model(), program, tool_radius_um)?;
        }
        Ok(plan)
    }

    /// The smaller flute's peak z-force over the larger's, at the program's deepest point (1 for a
    /// predictor without flutes, a response surface): how strongly one flute dominates the deflection.
    pub fn flute_ratio(&self) -> f64 {
        self.flute_ratio
    }

    /// A plan from a force the caller computes (`peak_z_force_n` of the programmed conditions, N) and a
    /// z-compliance (µm/N), tabulated as [`Self::new`] does. For reference studies only — the plan of a
    /// model no user holds, such as the truth's in a comparison against "an MPC given the true model";
    /// controllers a user builds take [`Self::new`] with identified models.
    ///
    /// # Errors
    /// As [`Self::new`]; the force function's errors.
    ///
    /// ```
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_sim::groove::GrooveProgram;
    /// // a force of 0.1 N per µm of depth and 0.5 µm/N: 0.05 µm of deflection per µm of the 0–80 µm ramp
    /// let program = GrooveProgram::thesis(30.0);
    /// let plan =
    ///     DeflectionPlan::reference(&program, 400.0, 0.01, 0.5, |c| Ok(0.1 * c.depth_um)).unwrap();
    /// assert!((plan.deflection_at(20.0) - 0.05 * 80.0).abs() < 1e-9);
    /// assert_eq!(plan.extrapolated_points, 0);
    /// ```
    pub fn reference(
        program: &GrooveProgram,
        tool_radius_um: f64,
        dx_mm: f64,
        compliance_um_per_n: f64,
        peak_z_force_n: impl FnMut(&CutConditions) -> Result<f64, SimError>,
    ) -> Result<Self, MpcError> {
        let mut f = peak_z_force_n;
        Self::tabulate(program, tool_radius_um, dx_mm, compliance_um_per_n, |c| {
            Ok(f(c)?)
        })
    }

    fn tabulate(
        program: &GrooveProgram,
        tool_radius_um: f64,
        dx_mm: f64,
        c: f64,
        mut force: impl FnMut(&CutConditions) -> Result<f64, MpcError>,
    ) -> Result<Self, MpcError> {
        let feed = program.feed_profile()?;
        let xs = plan_nodes(program, &feed, dx_mm);
        let (mut values, mut flank) = (Vec::with_capacity(xs.len()), Vec::with_capacity(xs.len()));
        let mut gains = Vec::with_capacity(xs.len());
        for &x in &xs {
            let depth_um = program.depth_at(x);
            let p = point(program, &feed, tool_radius_um, c, x, depth_um, &mut force)?;
            // where the deflection exceeds the depth, how much of a push turns into deflection:
            // c·∂F/∂d by a forward difference of 1 % of the depth
            let d = depth_um.clamp(0.0, tool_radius_um);
            let gain = if p.full_um > d {
                let step = (0.01 * d).max(1e-4);
                let ahead = point(program, &feed, tool_radius_um, c, x, d + step, &mut force)?;
                (ahead.full_um - p.full_um) / step
            } else {
                0.0
            };
            values.push(p.capped_um);
            flank.push(p.full_um);
            gains.push(gain);
        }
        Ok(Self {
            xs_mm: xs,
            values_um: values,
            flank_um: flank,
            loop_gain: gains,
            feed,
            flute_ratio: 1.0,
            waveform: Vec::new(),
            extrapolated_points: 0,
            path_offset: PathOffset::default(),
        })
    }

    /// The plan's deflection (µm) at `x_mm` for a groove of depth `depth_um` there instead of the
    /// programmed one — e.g. the depth a profilometer measured, which the force followed — with the
    /// same force predictor, stiffness and tool as [`Self::new`].
    ///
    /// # Errors
    /// A tilt the stiffness cannot take; a predictor error.
    pub fn deflection_at_depth(
        &self,
        program: &GrooveProgram,
        force: &ForcePredictor,
        model_stiffness: &IdentifiedStiffness,
        tool_radius_um: f64,
        x_mm: f64,
        depth_um: f64,
    ) -> Result<f64, MpcError> {
        let c = model_stiffness
            .stiffness()
            .z_compliance_um_per_n(program.tilt_deg)?;
        point(
            program,
            &self.feed,
            tool_radius_um,
            c,
            x_mm,
            depth_um,
            &mut |cond| force.peak_z_force_n(cond),
        )
        .map(|p| p.capped_um)
    }

    /// Where the tool rides on its wear land (the first micrometres of a ramp): the spans `[x₀, x₁)` (mm)
    /// between tabulated points at which the planned deflection exceeds the depth *and* the tool–workpiece
    /// loop gain `c·∂F/∂d` exceeds 1 — a push of the stack there turns mostly into deflection, not depth,
    /// so feedback on the measured force cannot take the tool into the cut. (For the flank force's
    /// `F ∝ √d` the gain is `c·F/(2d)`: the first quarter of the depths whose deflection exceeds them.)
    ///
    /// ```
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_sim::groove::GrooveProgram;
    /// // a force ∝ √depth on a 40 µm-per-mm ramp (0 → 80 µm over 2 mm), 2 µm of deflection per √µm:
    /// // above the depth below 4 µm, a loop gain 1/√d above 1 below 1 µm of depth (0.025 mm)
    /// let mut program = GrooveProgram::thesis(40.0);
    /// program.length_mm = 2.0;
    /// let plan = DeflectionPlan::reference(&program, 400.0, 0.005, 1.0, |c| Ok(2.0 * c.depth_um.sqrt()))
    ///     .unwrap();
    /// let spans = plan.rubbing_spans_mm();
    /// assert_eq!(spans.len(), 1);
    /// // from the first point with a depth (0.005 mm) to the first past 1 µm, on the 0.005 mm grid
    /// assert!((spans[0].0 - 0.005).abs() < 1e-9 && (spans[0].1 - 0.025).abs() < 1e-9, "{spans:?}");
    /// ```
    pub fn rubbing_spans_mm(&self) -> Vec<(f64, f64)> {
        let mut spans: Vec<(f64, f64)> = Vec::new();
        for i in 0..self.xs_mm.len() {
            // (a NaN gain is not above 1)
            if self.loop_gain[i].is_nan() || self.loop_gain[i] <= 1.0 {
                continue;
            }
            let (x0, x1) = (
                self.xs_mm[i],
                self.xs_mm.get(i + 1).copied().unwrap_or(self.xs_mm[i]),
            );
            match spans.last_mut() {
                Some(last) if last.1 >= x0 => last.1 = x1,
                _ => spans.push((x0, x1)),
            }
        }
        spans
    }

    /// The plan with the deflection not capped at the depth: where the flank force would push the tool
    /// out of a shallow cut, the full planned deflection, which is what a compensating push must give
    /// for the tool to cut at the depth ([`GrooveMpcFeatures::flank_rubbing`]).
    pub fn with_flank_push(mut self) -> Self {
        self.values_um.clone_from(&self.flank_um);
        self
    }

    /// Number of tabulated points.
    pub fn n_points(&self) -> usize {
        self.values_um.len()
    }

    /// Planned position at time `t_s` (mm).
    pub fn x_at(&self, t_s: f64) -> f64 {
        self.feed.x_at(t_s)
    }

    /// Planned z-deflection (µm) at time `t_s` as the stage produces it: the deflection follows the peak
    /// force of the last revolution (`000_…txt` §6.2), and the force peaks once per tooth, at a phase of
    /// the spindle the controllers do not know. With runout one flute cuts more than the others (the
    /// force model's [`Self::flute_ratio`] < 1), so the deflection steps once per revolution, when that
    /// flute passes. For each of `8 × teeth` phases φ of that flute across a revolution, the deflection is
    /// the largest of the flutes' last passes — the larger flute's planned value at `t − φ`, each other
    /// flute's times the flute ratio at its own pass — and the plan is the midpoint of the smallest and
    /// largest over the phases. Where the process is steady the phases agree; at a change the deflection
    /// steps at an unknown instant, and the midpoint is the reference whose worst error over that
    /// instant is smallest (half the step, where tracking either guess risks all of it).
    ///
    /// ```
    /// use millcomp_models::{ForceModelParams, StiffnessModel};
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_mpc::identified::{IdentifiedForceModel, IdentifiedStiffness, NominalTool};
    /// use millcomp_mpc::predictor::ForcePredictor;
    /// use millcomp_sim::feed::FeedChange;
    /// use millcomp_sim::groove::{DepthProfile, GrooveProgram};
    /// // a constant 40 µm groove whose feed doubles at once at x = 6 mm (t = 3.6 s)
    /// let mut program = GrooveProgram::thesis(20.0);
    /// program.depth_profile = DepthProfile::Constant { depth_um: 40.0 };
    /// program.feed_changes = vec![FeedChange { x_mm: 6.0, upfeed_um: 20.0 }];
    /// program.feed_accel_mm_s2 = 1e5;
    /// let tool = NominalTool::thesis_ball_end("S7");
    /// let p = ForceModelParams {
    ///     fitted: Default::default(), fixed: Default::default(), covariance: Default::default(),
    /// };
    /// let predictor = ForcePredictor::Mechanistic(IdentifiedForceModel::new(&p, &tool).unwrap());
    /// let k = IdentifiedStiffness::new(&StiffnessModel {
    ///     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
    /// }).unwrap();
    /// let plan = DeflectionPlan::new(&program, &predictor, &k, tool.radius_um, 0.01).unwrap();
    /// // the catalogue tool's 10 µm of runout against 5 µm of feed per tooth: one flute cuts far more
    /// assert!(plan.flute_ratio() < 0.8, "{}", plan.flute_ratio());
    /// let (rev, tooth) = (6e-3, 3e-3);
    /// let (before, after) = (plan.deflection_at(5.9), plan.deflection_at(6.1));
    /// assert!(after > before);
    /// // steady before and a revolution after (the 10 µm table itself spreads the step over
    /// // 10 µm / 3.33 mm/s = 3 ms); in between the midpoint over the larger flute's unknown phase
    /// assert!((plan.deflection_at_time(3.59, rev, tooth) - before).abs() < 1e-9);
    /// assert!((plan.deflection_at_time(3.62, rev, tooth) - after).abs() < 1e-9);
    /// let mid = plan.deflection_at_time(3.6 + 3e-3, rev, tooth);
    /// assert!(before < mid && mid < after, "{before} {mid} {after}");
    /// ```
    pub fn deflection_at_time(&self, t_s: f64, rev_s: f64, tooth_s: f64) -> f64 {
        let teeth = ((rev_s / tooth_s).round() as usize).max(1);
        let phases = 8 * teeth;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        // the look-backs of all phases lie within one revolution: each table search starts where
        // the last one ended
        let mut hint = self.table_index_at(t_s);
        for j in 0..phases {
            let phi = (j as f64 + 0.5) / phases as f64 * rev_s;
            let d = self.at_phase_from(t_s, rev_s, tooth_s, phi, &mut hint);
            lo = lo.min(d);
            hi = hi.max(d);
        }
        0.5 * (lo + hi)
    }

    /// Planned z-deflection (µm) at time `t_s` when the spindle's angle is known: the larger flute
    /// passed (its force peaked) at `pass_s` (any of its passes; [`SpindlePhase`] estimates one from the
    /// measured force). The deflection is the largest of the flutes' last passes, as in
    /// [`Self::deflection_at_time`], at that one phase — a step made at once then arrives in the plan when
    /// the flute that cuts it passes.
    ///
    /// ```
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_sim::groove::{DepthProfile, GrooveProgram};
    /// // 40 µm deep, 60 µm from x = 5 mm on (a step at once; 0.1 N/µm of depth, 0.5 µm/N)
    /// let mut program = GrooveProgram::thesis(20.0);
    /// program.depth_profile = DepthProfile::Steps { steps: vec![(0.0, 40.0), (5.0, 60.0)] };
    /// let plan =
    ///     DeflectionPlan::reference(&program, 400.0, 0.01, 0.5, |c| Ok(0.1 * c.depth_um)).unwrap();
    /// // the tool reaches 5 mm at t = 3 s (1.667 mm/s); the larger flute passes at 3.0004 s + k·6 ms
    /// let (rev, tooth) = (6e-3, 3e-3);
    /// let at = |t: f64| plan.deflection_at_time_phased(t, rev, tooth, 3.0004);
    /// assert!((at(3.0003) - 2.0).abs() < 1e-9); // 40 µm × 0.05 until the pass …
    /// assert!((at(3.0005) - 3.0).abs() < 1e-9); // … 60 µm × 0.05 from it on: a step, not a ramp
    /// ```
    pub fn deflection_at_time_phased(
        &self,
        t_s: f64,
        rev_s: f64,
        tooth_s: f64,
        pass_s: f64,
    ) -> f64 {
        let mut hint = self.table_index_at(t_s);
        self.at_phase_from(
            t_s,
            rev_s,
            tooth_s,
            (t_s - pass_s).rem_euclid(rev_s),
            &mut hint,
        )
    }

    /// The planned deflection (µm) at each of `times_s` (ascending) with the spindle's angle known (the
    /// force peaked at `pass_s`), from the force model's waveform over a revolution: the stage's
    /// deflection follows the largest force of the last revolution, and a step rises on the flank of
    /// the first pulse that exceeds the old peak — before that pulse's own peak. Each planned pulse is
    /// the waveform times the planned peak deflection where the tool was then; the deflection at `t` is
    /// the largest over `(t − rev, t]`. Without a waveform (a response surface),
    /// [`Self::deflection_at_time_phased`] for each time.
    ///
    /// ```
    /// use millcomp_models::{ForceModelParams, StiffnessModel};
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_mpc::identified::{IdentifiedForceModel, IdentifiedStiffness, NominalTool};
    /// use millcomp_mpc::predictor::ForcePredictor;
    /// use millcomp_sim::groove::{DepthProfile, GrooveProgram};
    /// // 40 µm deep, 60 µm from x = 5 mm on (t = 3 s): a step made at once
    /// let mut program = GrooveProgram::thesis(20.0);
    /// program.depth_profile = DepthProfile::Steps { steps: vec![(0.0, 40.0), (5.0, 60.0)] };
    /// let tool = NominalTool::thesis_ball_end("S7");
    /// let p = ForceModelParams {
    ///     fitted: Default::default(), fixed: Default::default(), covariance: Default::default(),
    /// };
    /// let predictor = ForcePredictor::Mechanistic(IdentifiedForceModel::new(&p, &tool).unwrap());
    /// let k = IdentifiedStiffness::new(&StiffnessModel {
    ///     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
    /// }).unwrap();
    /// let plan = DeflectionPlan::new(&program, &predictor, &k, tool.radius_um, 0.01).unwrap();
    /// let (rev, tooth, pass) = (6e-3, 3e-3, 3.0004);
    /// let times: Vec<f64> = (0..200).map(|i| 2.999 + i as f64 * 5e-5).collect();
    /// let d = plan.deflections_phased(&times, rev, tooth, pass);
    /// let (old, new) = (plan.deflection_at(4.9), plan.deflection_at(5.1));
    /// assert!((d[0] - old).abs() < 1e-6 * old && (d[199] - new).abs() < 1e-6 * new);
    /// // the rise is over by the pulse's peak, and has begun before it
    /// let at = |t: f64| d[((t - 2.999) / 5e-5).round() as usize];
    /// assert!((at(pass) - new).abs() < 1e-6 * new);
    /// assert!(at(pass - 1e-4) > old + 1e-3);
    /// // nothing rises before the tool reaches the step
    /// assert!((at(2.9995) - old).abs() < 1e-9);
    /// ```
    pub fn deflections_phased(
        &self,
        times_s: &[f64],
        rev_s: f64,
        tooth_s: f64,
        pass_s: f64,
    ) -> Vec<f64> {
        self.deflections_phased_cached(&mut PulseCache::default(), times_s, rev_s, tooth_s, pass_s)
    }

    /// [`Self::deflections_phased`] keeping the planned pulses in `cache` for the next call: a
    /// controller's successive windows overlap, so only the pulses that entered the window are
    /// computed (the cache is dropped when the spindle's angle estimate or the speed changes). The
    /// result is the same, bit for bit.
    pub fn deflections_phased_cached(
        &self,
        cache: &mut PulseCache,
        times_s: &[f64],
        rev_s: f64,
        tooth_s: f64,
        pass_s: f64,
    ) -> Vec<f64> {
        let mut out = vec![0.0; times_s.len()];
        self.deflections_phased_into(cache, times_s, rev_s, tooth_s, pass_s, &mut out);
        out
    }

    /// [`Self::deflections_phased_cached`] written into `out` (as long as `times_s`): with the cache's
    /// storage reserved ([`PulseCache::with_capacity`]) and `times_s` ascending, nothing is allocated.
    pub fn deflections_phased_into(
        &self,
        cache: &mut PulseCache,
        times_s: &[f64],
        rev_s: f64,
        tooth_s: f64,
        pass_s: f64,
        out: &mut [f64],
    ) {
        let (Some(&first), Some(&last)) = (times_s.first(), times_s.last()) else {
            return;
        };
        let n = self.waveform.len();
        if n == 0 {
            for (o, &t) in out.iter_mut().zip(times_s) {
                *o = self.deflection_at_time_phased(t, rev_s, tooth_s, pass_s);
            }
            return;
        }
        let dt = rev_s / n as f64;
        // pulse samples τ_i = pass + i·dt, waveform index i mod n (index 0 = the peak)
        let i0 = ((first - rev_s - pass_s) / dt).floor() as i64;
        let i1 = ((last - pass_s) / dt).floor() as i64;
        let key = (pass_s.to_bits(), rev_s.to_bits());
        if cache.key != key || cache.first > i0 {
            cache.key = key;
            cache.first = i0;
            cache.pulses.clear();
        }
        while cache.first < i0 && !cache.pulses.is_empty() {
            cache.pulses.pop_front();
            cache.first += 1;
        }
        if cache.pulses.is_empty() {
            cache.first = i0;
        }
        let have = cache.first + cache.pulses.len() as i64;
        for i in have..=i1 {
            let tau = pass_s + i as f64 * dt;
            let w = self.waveform[i.rem_euclid(n as i64) as usize];
            let d = if tau < 0.0 {
                0.0
            } else {
                self.deflection_at(self.x_at(tau))
            };
            cache.pulses.push_back((tau, w * d));
        }
        let pulses = cache.pulses.make_contiguous();
        let pulses = &pulses[..((i1 - i0 + 1).max(0) as usize).min(pulses.len())];
        window_maxima_into(pulses, times_s, rev_s, &mut cache.best, out);
    }

    /// The deflection at `t_s` when the larger flute last passed `phi_s` ago; `hint` is where the
    /// table search starts (from [`Self::table_index_at`]) and is left where it ended.
    fn at_phase_from(
        &self,
        t_s: f64,
        rev_s: f64,
        tooth_s: f64,
        phi_s: f64,
        hint: &mut usize,
    ) -> f64 {
        let teeth = ((rev_s / tooth_s).round() as usize).max(1);
        (0..teeth)
            .map(|m| {
                // flute m passes m tooth periods after the larger one
                let ago = (phi_s - m as f64 * tooth_s).rem_euclid(rev_s);
                let r = if m == 0 { 1.0 } else { self.flute_ratio };
                r * self.deflection_from(self.x_at((t_s - ago).max(0.0)), hint)
            })
            .fold(0.0, f64::max)
    }

    /// Planned z-deflection (µm) at `x_mm` (linear interpolation; 0 on the approach in air, x < 0).
    pub fn deflection_at(&self, x_mm: f64) -> f64 {
        if x_mm < 0.0 {
            return 0.0;
        }
        self.interpolate(x_mm, self.xs_mm.partition_point(|x| *x <= x_mm))
    }

    /// The index in the table of the first tabulated x beyond where the tool is at `t_s` (a binary
    /// search; where look-ups near that time start).
    fn table_index_at(&self, t_s: f64) -> usize {
        let x = self.x_at(t_s);
        self.xs_mm.partition_point(|v| *v <= x)
    }

    /// [`Self::deflection_at`], the table searched from `hint` (the same index as the binary
    /// search: the first tabulated x beyond `x_mm`) — a few steps where successive look-ups are
    /// close, as over one revolution; `hint` is left at the index found.
    fn deflection_from(&self, x_mm: f64, hint: &mut usize) -> f64 {
        if x_mm < 0.0 {
            return 0.0;
        }
        let xs = &self.xs_mm;
        let mut i = (*hint).min(xs.len());
        while i > 0 && xs[i - 1] > x_mm {
            i -= 1;
        }
        while i < xs.len() && xs[i] <= x_mm {
            i += 1;
        }
        *hint = i;
        self.interpolate(x_mm, i)
    }

    /// The linear interpolation at `x_mm` between table entries `i − 1` and `i` (`i` the first
    /// tabulated x beyond `x_mm`).
    fn interpolate(&self, x_mm: f64, i: usize) -> f64 {
        if i >= self.xs_mm.len() {
            return *self.values_um.last().unwrap_or(&0.0);
        }
        if i == 0 {
            return self.values_um[0];
        }
        let (x0, x1) = (self.xs_mm[i - 1], self.xs_mm[i]);
        let f = if x1 > x0 {
            (x_mm - x0) / (x1 - x0)
        } else {
            1.0
        };
        self.values_um[i - 1] * (1.0 - f) + self.values_um[i] * f
    }

    /// The smallest and largest planned deflection over the cut (µm).
    pub fn range_um(&self) -> (f64, f64) {
        self.values_um
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            })
    }

    /// The plan with an additive depth offset along the path (µm, + = deeper) that the deflection model
    /// lacks — an identified effect tabulated along this program (e.g. a guideway's straightness that
    /// `millcomp diagnose` named, evaluated at the groove's machine X). The controllers that follow the
    /// plan take it into account: the open-loop compensation (and `pid-ff`'s feedforward) subtract it
    /// from the correction they command, the MPC adds it to its error channel's prediction, preview,
    /// measurement and stroke band. The deflection itself (and the MPC's online plan scale, which
    /// compares it with the measured force) is unchanged.
    ///
    /// ```
    /// use millcomp_mpc::groove::DeflectionPlan;
    /// use millcomp_sim::groove::{GrooveProgram, PathOffset};
    /// let program = GrooveProgram::thesis(30.0);
    /// let plan = DeflectionPlan::reference(&program, 400.0, 0.01, 0.5, |c| Ok(0.1 * c.depth_um))
    ///     .unwrap()
    ///     .with_path_offset(PathOffset::new(vec![(0.0, 0.0), (20.0, -2.0)]).unwrap());
    /// assert!((plan.path_offset_at(10.0) + 1.0).abs() < 1e-12);
    /// // the deflection is the model's alone; what the actuator must make up is the deflection less
    /// // the offset: 4 µm + 2 µm at the deep end
    /// assert!((plan.deflection_at(20.0) - 4.0).abs() < 1e-9);
    /// assert!((plan.range_um().1 - 4.0).abs() < 1e-9);
    /// assert!((plan.required_range_um(1.0).1 - 6.0).abs() < 1e-9);
    /// ```
    pub fn with_path_offset(mut self, offset: PathOffset) -> Self {
        self.path_offset = offset;
        self
    }

    /// The path offset the plan was given (empty: none).
    pub fn path_offset(&self) -> &PathOffset {
        &self.path_offset
    }

    /// The path offset (µm, + = deeper) at `x_mm`; 0 without one.
    pub fn path_offset_at(&self, x_mm: f64) -> f64 {
        self.path_offset.at(x_mm)
    }

    /// The smallest and largest correction the actuator must make over the cut (µm): the planned
    /// deflection scaled by `scale` less the path offset, at every tabulated point (the deflection's
    /// range times `scale` without an offset).
    pub fn required_range_um(&self, scale: f64) -> (f64, f64) {
        if self.path_offset.is_empty() {
            let (a, b) = self.range_um();
            return (scale * a, scale * b);
        }
        self.xs_mm.iter().zip(&self.values_um).fold(
            (f64::INFINITY, f64::NEG_INFINITY),
            |(a, b), (&x, &v)| {
                let r = scale * v - self.path_offset.at(x);
                (a.min(r), b.max(r))
            },
        )
    }
}

/// The positions (mm) the plan is tabulated at: every `dx_mm` from 0 to the end, and the program's
/// corners — depth-profile points (a step: just before it and at it), the start and end of every feed
/// acceleration, the end of the entry and the exit's drop — sorted, without duplicates.
fn plan_nodes(program: &GrooveProgram, feed: &FeedProfile, dx_mm: f64) -> Vec<f64> {
    let len = program.length_mm;
    let n = (len / dx_mm).ceil() as usize + 1;
    let mut xs: Vec<f64> = (0..n).map(|i| (i as f64 * dx_mm).min(len)).collect();
    const JUST_BEFORE_MM: f64 = 1e-6;
    match &program.depth_profile {
        millcomp_sim::groove::DepthProfile::Points { points } => {
            xs.extend(points.iter().map(|p| p.0));
        }
        millcomp_sim::groove::DepthProfile::Steps { steps } => {
            xs.extend(steps.iter().flat_map(|p| [p.0 - JUST_BEFORE_MM, p.0]));
        }
        _ => {}
    }
    for (t0, t1) in feed.accelerations() {
        xs.push(feed.x_at(t0));
        xs.push(feed.x_at(t1));
    }
    xs.push(program.entry_length_mm);
    if let Some(e) = program.exit {
        xs.push(e.x_mm - e.length_mm);
        xs.push(e.x_mm);
    }
    xs.retain(|x| x.is_finite() && (0.0..=len).contains(x));
    xs.sort_by(f64::total_cmp);
    xs.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    xs
}

/// One planned deflection (µm): the peak z-force at depth `depth_um` (clamped to the ball) and the planned
/// upfeed at `x_mm`, times the engagement there and the compliance `c` — capped at the depth, and
/// without the cap.
fn point(
    program: &GrooveProgram,
    feed: &FeedProfile,
    tool_radius_um: f64,
    c: f64,
    x_mm: f64,
    depth_um: f64,
    force: &mut impl FnMut(&CutConditions) -> Result<f64, MpcError>,
) -> Result<PlanPoint, MpcError> {
    let d = depth_um.clamp(0.0, tool_radius_um);
    let e = program.engagement(x_mm);
    let f = if d > 0.0 && e > 0.0 {
        force(&program.conditions_at(d, feed.upfeed_at_x(x_mm)))? * e
    } else {
        0.0
    };
    // a tool cannot be pushed out of the cut by more than it is engaged: at the first few µm of a ramp
    // the flank force alone would predict more deflection than depth
    Ok(PlanPoint {
        capped_um: (f * c).min(d),
        full_um: f * c,
    })
}

/// One tabulated point of a [`DeflectionPlan`].
struct PlanPoint {
    /// The planned deflection capped at the depth (µm).
    capped_um: f64,
    /// The planned deflection (µm).
    full_um: f64,
}

/// The smaller flute's peak z-force over the larger's at the program's deepest point (clamped to the
/// ball) and base upfeed, from the controllers' force model.
fn flute_ratio(
    model: &millcomp_sim::force::BallEndForceModel,
    program: &GrooveProgram,
    tool_radius_um: f64,
) -> Result<f64, MpcError> {
    let deepest = deepest_um(program, tool_radius_um);
    if deepest <= 0.0 {
        return Ok(1.0);
    }
    let p = model.per_flute_peaks(&program.conditions_at(deepest, program.upfeed_um), 720)?;
    let (a, b) = (p[0][2].max(0.0), p[1][2].max(0.0));
    let big = a.max(b);
    Ok(if big > 0.0 { a.min(b) / big } else { 1.0 })
}

/// The largest planned pulse (and at least 0) in the revolution before each of `times_s` (ascending):
/// `max(0, max{d : (τ, d) ∈ pulses, t − rev < τ ≤ t})`, `pulses` ascending in τ. A sliding-window
/// maximum (a deque of the pulses that can still be a window's largest), so each pulse is pushed and
/// popped once: linear in pulses + times, where searching every window was times × pulses per revolution
/// (a third of the preview's time at 57 times and 120 pulses per revolution). `best` is the deque's
/// storage, kept by the caller so a cycle does not allocate it; the maxima go into `out` (as long as
/// `times_s`).
fn window_maxima_into(
    pulses: &[(f64, f64)],
    times_s: &[f64],
    rev_s: f64,
    best: &mut std::collections::VecDeque<usize>,
    out: &mut [f64],
) {
    if !times_s.is_sorted() {
        for (o, &t) in out.iter_mut().zip(times_s) {
            let mut one = [0.0];
            window_maxima_into(pulses, &[t], rev_s, best, &mut one);
            *o = one[0];
        }
        return;
    }
    best.clear();
    let mut next = 0;
    for (o, &t) in out.iter_mut().zip(times_s) {
        while next < pulses.len() && pulses[next].0 <= t {
            while best.back().is_some_and(|&j| pulses[j].1 <= pulses[next].1) {
                best.pop_back();
            }
            best.push_back(next);
            next += 1;
        }
        let start = t - rev_s;
        while best.front().is_some_and(|&j| pulses[j].0 <= start) {
            best.pop_front();
        }
        *o = best.front().map_or(0.0, |&j| pulses[j].1.max(0.0));
    }
}

/// The planned pulses of the last window of [`DeflectionPlan::deflections_phased_cached`].
#[derive(Debug, Clone, Default)]
pub struct PulseCache {
    /// (spindle pass, revolution) the pulses were computed for, as bits.
    key: (u64, u64),
    /// Index of the first pulse kept.
    first: i64,
    /// (time, planned deflection) of the pulses `first, first + 1, …`.
    pulses: std::collections::VecDeque<(f64, f64)>,
    /// Storage of [`window_maxima`]'s deque (its content does not outlive a call).
    best: std::collections::VecDeque<usize>,
}

impl PulseCache {
    /// A cache with room for `pulses` planned pulses (the pulses of a window: one revolution before
    /// its first time to its last), so that a controller's cycle does not allocate.
    pub fn with_capacity(pulses: usize) -> Self {
        Self {
            pulses: std::collections::VecDeque::with_capacity(pulses),
            best: std::collections::VecDeque::with_capacity(pulses),
            ..Self::default()
        }
    }

    /// Empty, as new (the storage kept).
    pub fn reset(&mut self) {
        self.key = (0, 0);
        self.first = 0;
        self.pulses.clear();
        self.best.clear();
    }
}

/// Angles per revolution of the plan's force waveform: 120, the samples of a revolution at 10 000 rpm
/// and the 20 kHz stage rate.
pub const WAVEFORM_SAMPLES: usize = 120;

/// The z-force over a revolution relative to its peak, starting at the peak, from the controllers'
/// force model at the program's deepest point (clamped to the ball) and base upfeed; negative forces
/// are 0 (they never set a peak).
fn waveform(
    model: &millcomp_sim::force::BallEndForceModel,
    program: &GrooveProgram,
    tool_radius_um: f64,
) -> Result<Vec<f64>, MpcError> {
    let deepest = deepest_um(program, tool_radius_um);
    if deepest <= 0.0 {
        return Ok(Vec::new());
    }
    let rev = model.revolution(
        &program.conditions_at(deepest, program.upfeed_um),
        WAVEFORM_SAMPLES,
    )?;
    let z: Vec<f64> = rev.iter().map(|f| f[2].max(0.0)).collect();
    let (peak_i, peak) = z
        .iter()
        .enumerate()
        .fold((0, 0.0), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
    if peak <= 0.0 {
        return Ok(Vec::new());
    }
    Ok((0..WAVEFORM_SAMPLES)
        .map(|k| z[(peak_i + k) % WAVEFORM_SAMPLES] / peak)
        .collect())
}

/// The program's deepest programmed depth (µm), clamped to the ball.
fn deepest_um(program: &GrooveProgram, tool_radius_um: f64) -> f64 {
    let n = 400;
    (0..=n)
        .map(|i| program.depth_at(program.length_mm * i as f64 / n as f64))
        .fold(0.0, f64::max)
        .clamp(0.0, tool_radius_um)
}

/// Where the tool was touched off: the stack held at `bias_v` and the gauge reading `gauge_um` there
/// (scenario key `control.touch_off_bias`). The depth's zero is that tip. A controller then holds
/// `bias_v` for no correction, wants the tip at `gauge_um` plus the correction's travel, and can
/// retract the tip below the touch-off by as much as the stack goes down from the bias — the headroom a
/// 0–1000 V amplifier otherwise lacks where the cutter leaves the workpiece after a deep cut and the
/// stack's remanence holds the tip out at 0 V. The default (0 V, 0 µm) is a touch-off with the stack at
/// rest and the gauge taken as read.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TouchOff {
    /// The stack's voltage at the touch-off (V).
    pub bias_v: f64,
    /// The gauge's reading there (µm): the tip the depth's zero corresponds to.
    pub gauge_um: f64,
}

/// A groove controller stepped at the stage rate.
pub trait GrooveController {
    /// Command (V) for the step starting at `t_s`, given the last measurement (None at the start).
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64;
    /// The tool was touched off at `at` (before the first [`Self::command`]).
    fn touched_off(&mut self, at: TouchOff);
    /// Back to the state right after construction, before the touch-off: every filter, integrator,
    /// estimator and plan of the controller (what construction computed — models, plan, gains — stays).
    /// A runtime touches the tool off again after it.
    ///
    /// # Errors
    /// [`MpcError::SolverSetup`] when the MPC's solver refuses its settings back (after a fault
    /// injection).
    fn reset(&mut self) -> Result<(), MpcError>;
    /// What the MPC did in the last [`Self::command`], when it planned in it (`None` for the steps it
    /// holds its command in, and for controllers without a QP).
    fn last_cycle(&self) -> Option<MpcCycle> {
        None
    }
    /// QP statistics (MPC only).
    fn solver_stats(&self) -> Option<SolverStats> {
        None
    }
    /// Make the next `cycles` QP solves fail (fault injection; MPC only, a no-op for the others).
    fn inject_solver_failures(&mut self, _cycles: usize) {}
}

impl<C: GrooveController + ?Sized> GrooveController for Box<C> {
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        (**self).command(last, t_s)
    }

    fn touched_off(&mut self, at: TouchOff) {
        (**self).touched_off(at);
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        (**self).reset()
    }

    fn last_cycle(&self) -> Option<MpcCycle> {
        (**self).last_cycle()
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        (**self).solver_stats()
    }

    fn inject_solver_failures(&mut self, cycles: usize) {
        (**self).inject_solver_failures(cycles);
    }
}

/// Any groove controller designed on the linear spindle model, driving the stack through the inverse of
/// its identified hysteresis ([`HysteresisCompensator`]): the controller's command is the voltage the
/// linear model would need, the compensator emits the one the hysteretic stack needs for the same tip.
#[derive(Debug)]
pub struct Compensated<C> {
    inner: C,
    compensator: HysteresisCompensator,
}

impl<C: GrooveController> Compensated<C> {
    /// `inner` through `compensator`.
    pub fn new(inner: C, compensator: HysteresisCompensator) -> Self {
        Self { inner, compensator }
    }
}

impl<C: GrooveController> GrooveController for Compensated<C> {
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        let u = self.inner.command(last, t_s);
        self.compensator.drive_v(u)
    }

    /// The inner controller holds the bias in its linear model's volts.
    fn touched_off(&mut self, at: TouchOff) {
        let bias_v = self.compensator.hold_at(at.bias_v);
        self.inner.touched_off(TouchOff { bias_v, ..at });
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        self.compensator.reset();
        self.inner.reset()
    }

    fn last_cycle(&self) -> Option<MpcCycle> {
        self.inner.last_cycle()
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        self.inner.solver_stats()
    }

    fn inject_solver_failures(&mut self, cycles: usize) {
        self.inner.inject_solver_failures(cycles);
    }
}

/// No compensation: the stack stays where the tool was touched off (0 V, or the touch-off's bias).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoneController {
    hold_v: f64,
}

impl GrooveController for NoneController {
    fn command(&mut self, _: Option<&GrooveMeasurement>, _: f64) -> f64 {
        self.hold_v
    }

    fn touched_off(&mut self, at: TouchOff) {
        self.hold_v = at.bias_v;
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        self.hold_v = 0.0;
        Ok(())
    }
}

/// Open-loop compensation (ch. 6): the planned deflection, driven through the spindle's static gain.
///
/// With [`Self::with_spindle`] the plan is followed in time as the deflection arrives — once per tooth
/// pass, at the midpoint over the spindle's angle, which an open-loop compensation cannot measure
/// ([`DeflectionPlan::deflection_at_time`]); without it, along the path (`deflection_at`), which steps
/// the command at the program's corner one revolution before a step made at once reaches the tool.
#[derive(Debug, Clone)]
pub struct OpenLoopController {
    plan: DeflectionPlan,
    tip_per_z: f64,
    v_per_um: f64,
    v_max: f64,
    /// (revolution, tooth period) in s, when the plan is followed in time.
    timing: Option<(f64, f64)>,
    /// The touch-off's bias (V): the command for no correction.
    bias_v: f64,
}

impl OpenLoopController {
    /// From the plan, the program's tilt, the controllers' spindle model (static gain) and the
    /// amplifier's maximum voltage.
    pub fn new(
        plan: DeflectionPlan,
        program: &GrooveProgram,
        model_spindle: &IdentifiedSpindle,
        voltage_max_v: f64,
    ) -> Self {
        Self {
            plan,
            tip_per_z: 1.0 / program.tilt_deg.to_radians().sin(),
            v_per_um: 1.0 / model_spindle.plant().gain_um_per_v,
            v_max: voltage_max_v,
            timing: None,
            bias_v: 0.0,
        }
    }

    /// The same compensation following the plan in time for a spindle at `speed_rpm` with `flutes`
    /// (the catalogue tool's): the deflection of the flutes' last passes, midpoint over the angle.
    pub fn with_spindle(mut self, speed_rpm: f64, flutes: u32) -> Self {
        let rev_s = 60.0 / speed_rpm;
        self.timing = Some((rev_s, rev_s / flutes.max(1) as f64));
        self
    }
}

impl OpenLoopController {
    /// The voltage that puts the tip where the plan's deflection at `t_s` wants it (unclamped).
    fn volts_at(&self, t_s: f64) -> f64 {
        let d = match self.timing {
            Some((rev_s, tooth_s)) => self.plan.deflection_at_time(t_s, rev_s, tooth_s),
            None => self.plan.deflection_at(self.plan.x_at(t_s)),
        };
        self.volts_for(d)
    }

    /// The voltage that corrects a z-deflection of `deflection_um` (unclamped).
    fn volts_for(&self, deflection_um: f64) -> f64 {
        deflection_um * self.tip_per_z * self.v_per_um
    }

    /// The voltage by which the plan's path offset at `t_s` reduces the correction (0 without one).
    fn offset_volts_at(&self, t_s: f64) -> f64 {
        if self.plan.path_offset.is_empty() {
            return 0.0;
        }
        self.volts_for(self.plan.path_offset_at(self.plan.x_at(t_s)))
    }
}

impl GrooveController for OpenLoopController {
    fn command(&mut self, _: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        (self.bias_v + self.volts_at(t_s) - self.offset_volts_at(t_s)).clamp(0.0, self.v_max)
    }

    fn touched_off(&mut self, at: TouchOff) {
        self.bias_v = at.bias_v;
    }

    /// Stateless but for the touch-off's bias.
    fn reset(&mut self) -> Result<(), MpcError> {
        self.bias_v = 0.0;
        Ok(())
    }
}

/// The published PID with the thesis' signal chain (ch. 7), at the stage rate.
#[derive(Debug, Clone)]
pub struct PidController {
    force_lp: Biquad,
    gauge_lp: Biquad,
    peak: PeakHold,
    smooth: FirstOrderFilter,
    pid: Pid,
    tip_per_n: f64,
    dt_s: f64,
    touch_off: TouchOff,
    /// The signal chain as built (at rest): what a reset returns to.
    initial: (Biquad, Biquad, PeakHold, FirstOrderFilter),
}

impl PidController {
    /// The signal chain for the program's speed and tilt, the PID with `gains` and `anti_windup` scaled
    /// by the controllers' spindle model (`loop_v_per_unit`), output 0–`voltage_max_v`, at `dt_s`.
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a filter frequency above Nyquist, a non-positive speed or a tilt the
    /// stiffness cannot take.
    pub fn new(
        gains: PidGains,
        anti_windup: AntiWindup,
        program: &GrooveProgram,
        model_spindle: &IdentifiedSpindle,
        model_stiffness: &IdentifiedStiffness,
        voltage_max_v: f64,
        dt_s: f64,
    ) -> Result<Self, MpcError> {
        let force_lp = Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt_s)?;
        let gauge_lp = Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt_s)?;
        let peak = PeakHold::thesis(program.speed_rpm)?;
        let smooth = FirstOrderFilter::thesis(dt_s)?;
        Ok(Self {
            force_lp,
            gauge_lp,
            peak,
            smooth,
            initial: (force_lp, gauge_lp, peak, smooth),
            pid: Pid::new(
                gains,
                anti_windup,
                model_spindle.plant().loop_v_per_unit,
                0.0,
                voltage_max_v,
                dt_s,
            ),
            tip_per_n: model_stiffness
                .stiffness()
                .pzt_compliance_um_per_n(program.tilt_deg)?,
            dt_s,
            touch_off: TouchOff::default(),
        })
    }
}

impl GrooveController for PidController {
    fn touched_off(&mut self, at: TouchOff) {
        self.touch_off = at;
        self.pid.start_at(at.bias_v);
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        (self.force_lp, self.gauge_lp, self.peak, self.smooth) = self.initial;
        self.pid.reset();
        self.touch_off = TouchOff::default();
        Ok(())
    }

    fn command(&mut self, last: Option<&GrooveMeasurement>, _: f64) -> f64 {
        let Some(o) = last else {
            return self.touch_off.bias_v;
        };
        let f = self.force_lp.step(o.force_meas_n);
        let p = self.peak.step(f, self.dt_s);
        let p = if p.is_finite() { p } else { 0.0 };
        let fs = self.smooth.step(p);
        let g = self.gauge_lp.step(o.gauge_um);
        let e = fs * self.tip_per_n + self.touch_off.gauge_um - g;
        self.pid.step(e)
    }
}

/// `pid-tuned`: the strongest feedback PID a control engineer would build today on the commissioned plant,
/// reading exactly what the MPC reads — force through the [`ForcePeakChain`]'s low-pass and the
/// one-revolution sliding peak, times the controllers' tip compliance = wanted tip; the raw gauge — with
/// PI gains from the fixed rule of [`crate::tuning`] (largest integral gain with `Ms ≤ 1.6` on the
/// controllers' spindle model) and conditional-integration anti-windup, at the stage rate.
#[derive(Debug, Clone)]
pub struct TunedPidController {
    force: ForcePeakChain,
    pid: Pid,
    tip_per_n: f64,
    design: crate::tuning::PiDesign,
    dt_s: f64,
    /// The gauge's reading at the touch-off (µm).
    tip_zero_um: f64,
}

impl TunedPidController {
    /// The controller for the program's speed and tilt, designed on `model_spindle`, output
    /// 0–`voltage_max_v`, at `dt_s`.
    ///
    /// # Errors
    /// Those of [`crate::tuning::pi_max_sensitivity`]; [`MpcError::Sim`] for a pre-filter above Nyquist or
    /// a tilt the stiffness cannot take.
    pub fn new(
        program: &GrooveProgram,
        model_spindle: &IdentifiedSpindle,
        model_stiffness: &IdentifiedStiffness,
        voltage_max_v: f64,
        dt_s: f64,
    ) -> Result<Self, MpcError> {
        let design = crate::tuning::pi_max_sensitivity(model_spindle, crate::tuning::MS_MAX, dt_s)?;
        Ok(Self {
            force: ForcePeakChain::new(program.speed_rpm, dt_s)?,
            pid: Pid::new(
                PidGains {
                    p: design.kp_v_per_um,
                    i: design.ki_v_per_um_s,
                    d: 0.0,
                },
                AntiWindup::Clamping,
                1.0,
                0.0,
                voltage_max_v,
                dt_s,
            ),
            tip_per_n: model_stiffness
                .stiffness()
                .pzt_compliance_um_per_n(program.tilt_deg)?,
            design,
            dt_s,
            tip_zero_um: 0.0,
        })
    }

    /// The PI design in use.
    pub fn design(&self) -> crate::tuning::PiDesign {
        self.design
    }
}

impl TunedPidController {
    /// One step with `v_ff` volts fed forward (inside the saturation). Before the first measurement the
    /// error is 0: the output is `v_ff` clamped (0 without feedforward). Returns the command and the
    /// wanted tip (µm) the measured force asked for (NaN before the first measurement).
    fn step_with_feedforward(&mut self, last: Option<&GrooveMeasurement>, v_ff: f64) -> (f64, f64) {
        self.step_reading(last, v_ff, None, None)
    }

    /// [`Self::step_with_feedforward`] with the peak's noise bias taken off (`bias`) and, where
    /// `wanted_tip_um` is given, that tip wanted instead of the measured force's (the chain still
    /// steps, so its window stays current; the tip returned is still the measured force's).
    fn step_reading(
        &mut self,
        last: Option<&GrooveMeasurement>,
        v_ff: f64,
        bias: Option<&PeakNoiseBias>,
        wanted_tip_um: Option<f64>,
    ) -> (f64, f64) {
        let Some(o) = last else {
            return (self.pid.step_with_feedforward(0.0, v_ff), f64::NAN);
        };
        let fpk = self.force.step(o.force_meas_n);
        let fpk = bias.map_or(fpk, |b| b.unbiased(fpk));
        let measured_tip = if fpk.is_finite() {
            fpk * self.tip_per_n
        } else {
            0.0
        };
        let wanted_tip = wanted_tip_um.unwrap_or(measured_tip);
        let v = self
            .pid
            .step_with_feedforward(wanted_tip + self.tip_zero_um - o.gauge_um, v_ff);
        (v, measured_tip)
    }
}

impl GrooveController for TunedPidController {
    fn command(&mut self, last: Option<&GrooveMeasurement>, _: f64) -> f64 {
        self.step_with_feedforward(last, 0.0).0
    }

    fn touched_off(&mut self, at: TouchOff) {
        self.tip_zero_um = at.gauge_um;
        self.pid.start_at(at.bias_v);
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        self.force.reset();
        self.pid.reset();
        self.tip_zero_um = 0.0;
        Ok(())
    }
}

/// The spindle's mean delay (s): the first moment of its identified impulse response, `2ζ/ωn` of the
/// second-order pair plus `1/p` of the extra pole plus the dead time — how far ahead a feedforward must
/// act for the tip to arrive on time.
pub fn spindle_mean_delay_s(model_spindle: &IdentifiedSpindle) -> f64 {
    let p = model_spindle.plant();
    2.0 * p.zeta / p.wn_rad_s + p.pole_rad_s.map_or(0.0, |w| 1.0 / w) + p.dead_time_s.unwrap_or(0.0)
}

/// `pid-tuned` plus the feedforward an engineer holding the NC program would add: the planned deflection
/// (the same [`DeflectionPlan`] the open-loop and the MPC use), taken [`spindle_mean_delay_s`] ahead and
/// turned into volts through the identified spindle gain, added to the PI's output before the saturation.
/// The plan is scaled online by the ratio of measured to planned deflection ([`PlanScale`], as the MPC's
/// preview is), so the feedforward carries what the measurements have taught. The PI gains are
/// `pid-tuned`'s (not retuned); the PI corrects what the plan gets wrong.
#[derive(Debug, Clone)]
pub struct FeedforwardPidController {
    feedback: TunedPidController,
    plan: OpenLoopController,
    lead_s: f64,
    scale: Option<PlanScale>,
    phase: SpindlePhase,
    sin_a: f64,
    rev_s: f64,
    tooth_s: f64,
    /// The peak's noise bias ([`Self::with_read_features`]).
    peak_bias: Option<PeakNoiseBias>,
    /// Where the tool rides on its wear land ([`Self::with_read_features`]; empty otherwise).
    rubbing_mm: Vec<(f64, f64)>,
    /// The planned pulses of the last revolution, kept between steps (the plan is read every stage
    /// step; [`DeflectionPlan::deflections_phased_cached`], the same values bit for bit).
    pulses: PulseCache,
}

impl FeedforwardPidController {
    /// `feedback` (a [`TunedPidController`], not retuned) plus `plan` turned into volts as the
    /// open-loop controller does, [`spindle_mean_delay_s`] of `model_spindle` ahead, timed by the
    /// spindle's angle as the MPC's plan is ([`SpindlePhase`] on a force channel with noise σ
    /// `force_noise_n`, N).
    pub fn new(
        feedback: TunedPidController,
        plan: DeflectionPlan,
        program: &GrooveProgram,
        model_spindle: &IdentifiedSpindle,
        voltage_max_v: f64,
        flutes: u32,
        force_noise_n: f64,
    ) -> Self {
        let dt_s = feedback.dt_s;
        let mut phase = SpindlePhase::new(program.speed_rpm, &plan.waveform, force_noise_n);
        phase.reserve_samples(samples_per_rev(program.speed_rpm, dt_s) + 2);
        Self {
            feedback,
            plan: OpenLoopController::new(plan, program, model_spindle, voltage_max_v),
            lead_s: spindle_mean_delay_s(model_spindle),
            scale: Some(PlanScale::new(dt_s, PLAN_SCALE_TIME_CONSTANT_S)),
            phase,
            sin_a: program.tilt_deg.to_radians().sin(),
            rev_s: 60.0 / program.speed_rpm,
            tooth_s: 60.0 / program.speed_rpm / flutes.max(1) as f64,
            peak_bias: None,
            rubbing_mm: Vec::new(),
            // the plan is read one revolution back from one time a step
            pulses: PulseCache::with_capacity(WAVEFORM_SAMPLES + 4),
        }
    }

    /// The same controller reading what the MPC's read features read: the peak's noise bias taken off
    /// ([`GrooveMpcFeatures::unbiased_peak`], calibrated on the force noise σ `force_noise_n` and the
    /// plan's waveform through the same chain) and the ramp's rubbing start known
    /// ([`GrooveMpcFeatures::flank_rubbing`]: the flank push fed forward, and where a push turns mostly
    /// into deflection the PI wants the plan's tip instead of the measured force's).
    ///
    /// # Errors
    /// Those of [`PeakNoiseBias::calibrate`].
    pub fn with_read_features(
        mut self,
        speed_rpm: f64,
        force_noise_n: f64,
    ) -> Result<Self, MpcError> {
        self.peak_bias = Some(PeakNoiseBias::calibrate(
            speed_rpm,
            self.feedback.dt_s,
            force_noise_n,
            &self.plan.plan.waveform,
        )?);
        self.rubbing_mm = self.plan.plan.rubbing_spans_mm();
        self.plan.plan = self.plan.plan.clone().with_flank_push();
        self.pulses.reset();
        Ok(self)
    }

    /// The same controller with the plan as commissioned (no online scale): the ablation.
    pub fn without_plan_scale(mut self) -> Self {
        self.scale = None;
        self
    }

    /// The feedback part's PI design.
    pub fn design(&self) -> crate::tuning::PiDesign {
        self.feedback.design
    }

    /// How far ahead the plan is taken (s).
    pub fn lead_s(&self) -> f64 {
        self.lead_s
    }
}

impl GrooveController for FeedforwardPidController {
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        if let Some(o) = last {
            self.phase.update(t_s, o.force_meas_n);
        }
        let rho = self.scale.map_or(1.0, |s| s.ratio());
        let t_ff = t_s + self.lead_s;
        // the plan timed by the spindle's angle once the force shows it, as the MPC's is
        let v_ff = rho
            * match self.phase.pass_s() {
                Some(p) => {
                    let mut d = [0.0];
                    self.plan.plan.deflections_phased_into(
                        &mut self.pulses,
                        &[t_ff],
                        self.rev_s,
                        self.tooth_s,
                        p,
                        &mut d,
                    );
                    self.plan.volts_for(d[0])
                }
                None => self.plan.volts_at(t_ff),
            };
        let v_ff = v_ff - self.plan.offset_volts_at(t_ff) + self.plan.bias_v;
        let x_now = self.plan.plan.x_at(t_s);
        let rubbing = within_spans(&self.rubbing_mm, x_now);
        let plan_tip = rubbing.then(|| rho * self.plan.plan.deflection_at(x_now) / self.sin_a);
        // the scale learns from the measured force everywhere, as the MPC's does
        let (v, measured_tip) =
            self.feedback
                .step_reading(last, v_ff, self.peak_bias.as_ref(), plan_tip);
        if let Some(s) = &mut self.scale {
            let planned = self.plan.plan.deflection_at(x_now);
            s.update(planned, measured_tip * self.sin_a);
        }
        v
    }

    /// The bias goes with the feedforward; the PI's integrator starts at 0 as without one.
    fn touched_off(&mut self, at: TouchOff) {
        self.plan.bias_v = at.bias_v;
        self.feedback.tip_zero_um = at.gauge_um;
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        self.feedback.reset()?;
        self.plan.reset()?;
        if let Some(s) = &mut self.scale {
            s.reset();
        }
        self.phase.reset();
        self.pulses.reset();
        Ok(())
    }
}

/// How the groove MPC is set up: timing, horizon and amplifier limits (the control settings), an
/// optional full configuration, and the sensors' noise levels its Kalman filter assumes.
#[derive(Debug, Clone, PartialEq)]
pub struct GrooveMpcSettings {
    /// Stage step (s).
    pub dt_s: f64,
    /// MPC period in stage steps.
    pub mpc_every: usize,
    /// Horizon (used when `config` is not given).
    pub horizon: usize,
    /// Amplifier slew limit per MPC cycle (V).
    pub slew_v_per_cycle: f64,
    /// Amplifier maximum (V).
    pub voltage_max_v: f64,
    /// Full MPC configuration (keys in `mpc/CONFIG.md`); `None`: [`default_spindle_config`] tuned to
    /// the sensor noise below.
    pub config: Option<MpcConfig>,
    /// Force-sensor noise σ (N).
    pub force_noise_n: f64,
    /// Gauge noise σ (µm).
    pub gauge_noise_um: f64,
    /// Which of the planning and estimation features are on (all by default; the ablations switch them
    /// off one at a time).
    pub features: GrooveMpcFeatures,
    /// The harness's cycle budget (fraction of the MPC period, enforced or only timed).
    pub budget: CycleBudget,
}

/// The groove MPC's planning and estimation features (scenario keys `control.groove_mpc.*`). Each one
/// answers something the commissioning could not pin down or the horizon cannot see; switching one
/// off is an ablation that measures what it buys. All are on by default except `stroke_aware`, which
/// the ablations showed to hurt (docs/studies/mpc-parts.md, `compare --features` and the commissioned 20° groove).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrooveMpcFeatures {
    /// Plan the whole cut within the actuator's reach ([`crate::stroke::StrokeBand`]): where the
    /// deflection the program will cause exceeds the stroke, the error targets are the band's instead of
    /// 0, and the soft error bound follows them. **Off by default**: the band is planned on the
    /// controllers' spindle and force models, and on a commissioned plant with a hysteretic stack its
    /// reach and position are off by the models' errors — at 20° (seeds 1–6) it left 2.3–4.9 µm
    /// peak-to-peak where the MPC without it left 0.5–2.9 µm; on the linear stack it bought nothing
    /// (1.53 against 1.48 µm).
    pub stroke_aware: bool,
    /// Scale the preview's changes by the ratio of the measured to the planned deflection, estimated
    /// online ([`PlanScale`]): a change the plan previews then arrives at the size the measurements say,
    /// not the commissioned model's — its force-model, stiffness and force-gain errors no longer
    /// leave a transient for the disturbance estimate to catch up with. The deflection the plan misses
    /// *now* stays the disturbance estimate's.
    pub adapt_plan_scale: bool,
    /// Time the plan's steps by the force model's flutes: with runout the larger flute sets the
    /// deflection once per revolution ([`DeflectionPlan::deflection_at_time`]); off: every tooth is
    /// taken as equal.
    pub flute_phase: bool,
    /// Estimate the spindle's angle from the measured force ([`SpindlePhase`]) and time the plan by it
    /// ([`DeflectionPlan::deflection_at_time_phased`]); off: the midpoint over the unknown phase.
    pub spindle_phase: bool,
    /// An output disturbance on the gauge channel ([`crate::spindle_mpc`]): what the linear stack model
    /// misses — hysteresis, creep, the gauge zero — goes there instead of into the spindle states. Off:
    /// the error channel's disturbance alone. Only with the default configuration (`control.mpc` unset).
    pub gauge_disturbance: bool,
    /// The gauge's disturbance is the stack's: what the linear stack model misses moves the tip, so it
    /// enters the depth-error channel as well, through the tilt (`sin α`), and the error channel's own
    /// disturbance is left with the deflection the plan misses; and it moves as fast as the stack does
    /// — a random walk of the gauge's own noise variance per cycle, where the error channel's
    /// disturbance walks (0.003 µm)² per cycle to smooth the per-revolution force peak. Off: the
    /// gauge's disturbance stays on the gauge, walks as slowly as the error channel's, and a hysteretic
    /// stack's misfit while it climbs reaches the error prediction only as fast as the error channel's
    /// own disturbance (read through the force's noise) takes it up. With [`Self::gauge_disturbance`]
    /// only.
    pub stack_disturbance: bool,
    /// Weigh the error between the cycles too ([`crate::config::Intersample`]): at every stage step of
    /// the first [`INTERSAMPLE_WINDOW_S`] of the horizon, on the spindle model sampled at the stage step. A
    /// deflection that rises within a fraction of a cycle (the flank of one tooth's force at a change
    /// made at once) is then met where it rises; off: the error at the cycles only. Only with the
    /// default configuration (`control.mpc` unset).
    pub intersample: bool,
    /// Take the per-revolution force peak's noise bias off ([`PeakNoiseBias`], calibrated on the
    /// commissioned force noise σ and the force model's waveform, through the controllers' own
    /// [`ForcePeakChain`]). With no force the sliding peak reads the noise's own maximum (0.046 N at
    /// σ 0.04 N), which the error channel takes for a deflection. On its own it leaves the ramp's rubbing
    /// start uncut, which the noise's bias got the MPC through, so it goes with [`Self::flank_rubbing`]
    /// (docs/studies/ramp-start.md, `bash bench/ramp-start-noise`).
    pub unbiased_peak: bool,
    /// Know the ramp's rubbing start: where the planned deflection exceeds the depth the preview pushes
    /// by the full planned deflection ([`DeflectionPlan::with_flank_push`]) instead of capping it at the
    /// depth, and where moreover a push turns mostly into deflection ([`DeflectionPlan::
    /// rubbing_spans_mm`]: loop gain above 1) the force channel is not read as a deflection — the tool
    /// rides on its wear land, the force is the rubbing's, and the feedback would take the push back.
    /// The gauge is still read.
    pub flank_rubbing: bool,
    /// Away from the changes the preview sees, read the force once per revolution. The error channel's
    /// force reading is a one-revolution sliding peak — the same value for up to a revolution's cycles
    /// (12 at 2 kHz and 10 000 rpm) — and the disturbance estimate takes every cycle's reading as a new
    /// measurement, which lets the force noise through at the estimate's full speed. Where the planned
    /// deflection stays within [`QUIET_CHANGE_UM`] of now over the whole horizon, and has for
    /// [`QUIET_AFTER_REVOLUTIONS`] revolutions, the force is read at one cycle a revolution; around every
    /// change the preview sees (an entry, a step, an exit) it is read every cycle, as before. The gauge is
    /// read every cycle.
    pub quiet_revolutions: bool,
}

/// The change in the planned deflection over the horizon (µm) below which the preview sees no change
/// ([`GrooveMpcFeatures::quiet_revolutions`]): three times what a 10 ms horizon adds on the 40° ramp
/// (0.017 µm), well below any step. Chosen before the runs, the first value tried.
pub const QUIET_CHANGE_UM: f64 = 0.05;

/// Revolutions after the preview last saw a change before the force is read once a revolution
/// ([`GrooveMpcFeatures::quiet_revolutions`]): the disturbance estimate's settling after a change.
pub const QUIET_AFTER_REVOLUTIONS: f64 = 2.0;

/// The stretch at the start of the groove MPC's horizon whose error is weighed at every stage step
/// (with [`GrooveMpcFeatures::intersample`]), in seconds: the time a tooth's force takes to rise and
/// the spindle to follow — 4 cycles at 2 kHz, 10 at 5 kHz (never more than the horizon).
pub const INTERSAMPLE_WINDOW_S: f64 = 2e-3;

/// The groove MPC's move weight (per V²) with the error weighed between the cycles, instead of the
/// default design's 1e-4. Seen at its sub-steps, a move that overdrives the stack for one cycle to
/// make the tip rise with a tooth's force flank shows its benefit; at 1e-4 a 100 V move costs as much
/// as 1 µm of error at one cycle and the MPC spreads a 20 µm depth step's 200 V over 2 ms. Chosen on
/// the development seeds 101–106 (1e-4, 1e-5, 3e-6) of the shipped changes made at once, not on the
/// seeds the studies in docs/studies/ report; without intersample costs a lower weight made the depth step worse
/// (between the cycles the moves overshoot unseen), so it goes with them.
pub const INTERSAMPLE_INPUT_RATE: f64 = 1e-5;

/// The MPC cycle [`INTERSAMPLE_INPUT_RATE`] was chosen at (2 kHz); at a cycle `tc` the weight is
/// scaled by (this / `tc`)², which keeps the continuous-time trade-off between the moves and the error.
pub const INTERSAMPLE_RATE_CYCLE_S: f64 = 5e-4;

impl Default for GrooveMpcFeatures {
    fn default() -> Self {
        Self {
            stroke_aware: false,
            adapt_plan_scale: true,
            flute_phase: true,
            spindle_phase: true,
            gauge_disturbance: true,
            stack_disturbance: true,
            intersample: true,
            unbiased_peak: true,
            flank_rubbing: true,
            quiet_revolutions: true,
        }
    }
}

/// The ratio of the measured to the planned deflection, estimated online by exponentially weighted least
/// squares through the origin: `ρ̂ = (Σ λ^i δ̂_i δ_i + p) / (Σ λ^i δ̂_i² + p)` over the cycles where the
/// plan expects a cut (`δ̂ ≥` [`PlanScale::MIN_PLANNED_UM`]: below, the measured per-revolution peak
/// is mostly the noise's own peak), `λ = exp(−cycle / τ)`, a prior ρ = 1 of weight `p` = 25 µm² (one
/// cycle at 5 µm: it yields to data within milliseconds of cutting), clamped to 0.5–2 (a model that is
/// further off is a commissioning to redo, not a scale to learn). Once the estimate has [`PlanScale::
/// WARM_UM2`] of data behind it, a cycle whose own ratio is more than [`PlanScale::GATE_REL`] off is
/// an outlier (a force spike, a frozen channel) and is left out — unless
/// [`PlanScale::GATE_MAX_SKIPS`] cycles in a row are, which is a real change and is learnt.
///
/// # Examples
/// ```
/// use millcomp_mpc::groove::PlanScale;
/// let mut s = PlanScale::new(5e-4, 0.5);
/// assert_eq!(s.ratio(), 1.0); // nothing measured: the commissioned model as it is
/// for k in 0..2000 {
///     let planned = 5.0 + 0.005 * k as f64; // a ramp 5 → 15 µm the model over-predicts by 10 %
///     s.update(planned, planned / 1.1);
/// }
/// assert!((s.ratio() - 1.0 / 1.1).abs() < 1e-3);
/// s.update(1.0, 100.0); // too little planned there (in air, the start of a ramp): ignored
/// s.update(15.0, 60.0); // a force spike: ignored
/// assert!((s.ratio() - 1.0 / 1.1).abs() < 1e-3);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanScale {
    sxy: f64,
    sxx: f64,
    lambda: f64,
    skips: usize,
}

impl PlanScale {
    /// Planned deflections below this (µm) do not update the estimate (the tool in air, the first µm of a
    /// ramp, where the measured peak is mostly noise).
    pub const MIN_PLANNED_UM: f64 = 2.0;
    /// Weight of data (Σ λ^i δ̂², µm²) after which outliers are gated: 200 cycles at 5 µm.
    pub const WARM_UM2: f64 = 5000.0;
    /// A cycle whose ratio is further than this (relative) from the estimate is an outlier.
    pub const GATE_REL: f64 = 0.25;
    /// Consecutive outliers after which they are taken as real: 20 ms at 2 kHz (three revolutions at
    /// 10 000 rpm, past the one a force spike is held for by the per-revolution peak).
    pub const GATE_MAX_SKIPS: usize = 40;
    const PRIOR_UM2: f64 = 25.0;

    /// An estimator updated every `cycle_s` with a memory of `time_constant_s`.
    pub fn new(cycle_s: f64, time_constant_s: f64) -> Self {
        Self {
            sxy: 0.0,
            sxx: 0.0,
            lambda: (-cycle_s / time_constant_s.max(cycle_s)).exp(),
            skips: 0,
        }
    }

    /// One cycle's planned and measured deflection (µm); non-finite values are ignored.
    pub fn update(&mut self, planned_um: f64, measured_um: f64) {
        if planned_um < Self::MIN_PLANNED_UM || !planned_um.is_finite() || !measured_um.is_finite()
        {
            return;
        }
        let rho = self.ratio();
        if self.sxx >= Self::WARM_UM2
            && (measured_um / planned_um / rho - 1.0).abs() > Self::GATE_REL
            && self.skips < Self::GATE_MAX_SKIPS
        {
            self.skips += 1;
            return;
        }
        self.skips = 0;
        self.sxy = self.lambda * self.sxy + planned_um * measured_um;
        self.sxx = self.lambda * self.sxx + planned_um * planned_um;
    }

    /// Back to nothing measured (the commissioned model as it is).
    pub fn reset(&mut self) {
        self.sxy = 0.0;
        self.sxx = 0.0;
        self.skips = 0;
    }

    /// The estimated ratio, measured over planned.
    pub fn ratio(&self) -> f64 {
        ((self.sxy + Self::PRIOR_UM2) / (self.sxx + Self::PRIOR_UM2)).clamp(0.5, 2.0)
    }
}

/// Build the groove MPC: the controllers' spindle model sampled at `dt_s · mpc_every` with two outputs
/// (gauge, depth error = gauge · sin α), and `settings.config` if given, else the default spindle design
/// with the measurement noise of the sensors mapped through the controllers' compliance.
///
/// # Errors
/// [`MpcError::Sim`] for an invalid spindle model or tilt; configuration and construction errors of
/// [`MpcController::new`].
pub fn groove_mpc(
    model_spindle: &IdentifiedSpindle,
    model_stiffness: &IdentifiedStiffness,
    tilt_deg: f64,
    settings: &GrooveMpcSettings,
) -> Result<MpcController, MpcError> {
    let tc = settings.dt_s * settings.mpc_every as f64;
    let sin_a = tilt_deg.to_radians().sin();
    let between =
        settings.config.is_none() && settings.features.intersample && settings.mpc_every >= 2;
    // with the error weighed between the cycles the model is the stage step's (the MPC holds its
    // command over `mpc_every` of them)
    let model_dt = if between { settings.dt_s } else { tc };
    let single = model_spindle.plant().to_lti()?.discretize_zoh(model_dt)?;
    let n = single.n_states();
    let mut c = DMatrix::zeros(2, n);
    for j in 0..n {
        c[(OUT_GAUGE, j)] = single.c[(0, j)];
        c[(OUT_ERROR, j)] = sin_a * single.c[(0, j)];
    }
    let model = DiscreteLti::new(single.a, single.b, c, DMatrix::zeros(2, 1), model_dt)?;
    let mut cfg = match &settings.config {
        Some(m) => m.clone(),
        None => {
            let mut c = default_spindle_config(
                settings.horizon,
                settings.voltage_max_v,
                settings.slew_v_per_cycle,
            );
            // measured error channel: σ ≈ compliance × σ of the filtered per-revolution force peak
            let comp = model_stiffness
                .stiffness()
                .z_compliance_um_per_n(tilt_deg)?;
            let sf = (settings.force_noise_n * 0.5).max(0.005);
            let r_gauge = (settings.gauge_noise_um.max(0.005)).powi(2);
            c.kalman.measurement_noise = vec![r_gauge, (comp * sf).powi(2).max(1e-4)];
            // the deflection mismatch (force-model error × planned deflection) changes slowly except at
            // process changes, which the preview already carries: a (0.003 µm)²/cycle random walk gives a
            // ≈ 5 ms (≈ one revolution) disturbance time constant against ≈ 0.035 µm measurement noise,
            // smoothing the per-revolution steps of the measured peak
            c.kalman.disturbance_noise = 1e-5;
            if !settings.features.gauge_disturbance {
                c.disturbance.channels = Some(vec![OUT_ERROR]);
            } else if settings.features.stack_disturbance {
                // the stack's misfit is a displacement of the tip, seen on the error through the
                // tilt, and it moves as fast as the stack does: a random walk of the gauge's own noise
                // per cycle, which the gauge tracks within ≈ 2 cycles
                c.disturbance.coupling = vec![DisturbanceCoupling {
                    state: 0,
                    output: OUT_ERROR,
                    gain: sin_a,
                }];
                c.kalman.disturbance_noise_per_state = vec![r_gauge, c.kalman.disturbance_noise];
            }
            if between {
                c.intersample = Some(Intersample {
                    substeps: settings.mpc_every,
                    cycles: ((INTERSAMPLE_WINDOW_S / tc - 1e-9).ceil() as usize)
                        .clamp(1, c.horizon),
                });
                // per cycle Σ(Δu)² ≈ tc·∫u̇² dt while Σ Q e² ≈ (Q/tc)·∫e² dt: the weight chosen at
                // 2 kHz keeps its trade-off at another rate scaled by (0.5 ms / tc)²
                c.weights.input_rate =
                    vec![INTERSAMPLE_INPUT_RATE * (INTERSAMPLE_RATE_CYCLE_S / tc).powi(2)];
            }
            c
        }
    };
    settings.budget.apply(&mut cfg.solver);
    MpcController::new(&model, &cfg)
}

/// The spindle's angle from the measured force, as a time at which the larger flute passed.
///
/// The force of a milling tool peaks once per tooth; with runout one flute cuts more and its peak is the
/// revolution's. Every revolution (the programmed speed) whose largest force sample stands
/// [`SpindlePhase::CUT_SIGMAS`] noise σ above zero had a cut in it, and that flute's pass is taken
/// from it: with the plan's force waveform, the time at which the waveform laid over the revolution's
/// samples matches them best (a matched filter searched within [`SpindlePhase::MATCH_HALF_WIDTH_REV`]
/// of a revolution around the largest sample, refined between its grid points by a parabola); without
/// one, the largest sample's time. The passes are averaged on the circle with a memory of
/// [`SpindlePhase::MEMORY_REVOLUTIONS`] revolutions. The phase is *known* once
/// [`SpindlePhase::MATCHED_REVOLUTIONS`] such revolutions (with a waveform) or
/// [`SpindlePhase::MIN_REVOLUTIONS`] (without: the largest sample of a small pulse jitters by a tenth
/// of a tooth period) agree (mean resultant length ≥ [`SpindlePhase::MIN_AGREEMENT`]): in air, or with
/// flutes cutting alike, it is not, and the plan stays the midpoint over the unknown phase. The one
/// sensor is the force channel every controller reads; σ is the bundle's.
///
/// # Examples
/// ```
/// use millcomp_mpc::groove::SpindlePhase;
/// // 10 000 rpm sampled every 50 µs; a force peaking at 1.2 ms into every revolution
/// let (rev, dt) = (6e-3, 5e-5);
/// let pulse = |phase: f64| 5.0 * (-((phase - 1.2e-3) / 2e-4).powi(2)).exp(); // one flute's pulse
/// // the same pulse shape, from its peak, over a revolution of 120 angles
/// let waveform: Vec<f64> =
///     (0..120).map(|k| pulse((1.2e-3 + k as f64 * rev / 120.0) % rev) / 5.0).collect();
/// let mut with = SpindlePhase::new(10_000.0, &waveform, 0.04);
/// let mut without = SpindlePhase::new(10_000.0, &[], 0.04);
/// assert_eq!(with.pass_s(), None);
/// let mut known_after = [None, None];
/// for k in 0..1200 {
///     let t = k as f64 * dt;
///     let f = pulse((t / rev).fract() * rev);
///     with.update(t, f);
///     without.update(t, f);
///     for (i, p) in [&with, &without].into_iter().enumerate() {
///         if known_after[i].is_none() && p.pass_s().is_some() {
///             known_after[i] = Some((t / rev).round() as usize);
///         }
///     }
/// }
/// // known from the first revolution's close with the waveform, after three without
/// assert_eq!(known_after, [Some(1), Some(3)]);
/// for p in [with, without] {
///     let pass = p.pass_s().unwrap();
///     assert!(((pass / rev).fract() * rev - 1.2e-3).abs() < 1e-9, "{pass}");
/// }
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SpindlePhase {
    rev_s: f64,
    rev_index: i64,
    best_force: f64,
    best_t: f64,
    sum_cos: f64,
    sum_sin: f64,
    weight: f64,
    revolutions: usize,
    lambda: f64,
    /// A revolution whose largest force sample is not above this (N, ≥ 0) had no cut in it.
    cut_n: f64,
    /// The plan's force waveform from its peak (empty: the largest sample is the pass).
    waveform: Vec<f64>,
    /// The revolution's (time, force) samples, for the matched filter.
    samples: Vec<(f64, f64)>,
}

impl SpindlePhase {
    /// Revolutions the circular mean remembers (1/e).
    pub const MEMORY_REVOLUTIONS: f64 = 20.0;
    /// Revolutions with a cut before the phase is taken as known, without a waveform.
    pub const MIN_REVOLUTIONS: usize = 3;
    /// Revolutions with a cut before the phase is taken as known, with the matched filter.
    pub const MATCHED_REVOLUTIONS: usize = 1;
    /// Mean resultant length of the passes (1 = identical) needed.
    pub const MIN_AGREEMENT: f64 = 0.9;
    /// A revolution had a cut when its largest sample exceeds this many noise σ: the largest of a
    /// revolution's 120 samples of white noise does so with probability ≈ 120 · 10⁻⁹.
    pub const CUT_SIGMAS: f64 = 6.0;
    /// Half-width of the matched filter's search around the largest sample (revolutions): well inside
    /// the half tooth period of a two-flute tool, so it cannot lock on the other flute.
    pub const MATCH_HALF_WIDTH_REV: f64 = 0.125;

    /// The estimator for a spindle at `speed_rpm`, matching the plan's force `waveform` (from its peak
    /// over a revolution, [`DeflectionPlan`]'s; empty for none) on a force channel with noise σ
    /// `force_noise_n` (N).
    pub fn new(speed_rpm: f64, waveform: &[f64], force_noise_n: f64) -> Self {
        Self {
            rev_s: 60.0 / speed_rpm,
            rev_index: i64::MIN,
            best_force: f64::NEG_INFINITY,
            best_t: 0.0,
            sum_cos: 0.0,
            sum_sin: 0.0,
            weight: 0.0,
            revolutions: 0,
            lambda: (-1.0 / Self::MEMORY_REVOLUTIONS).exp(),
            cut_n: Self::CUT_SIGMAS * force_noise_n.max(0.0),
            waveform: waveform.to_vec(),
            samples: Vec::new(),
        }
    }

    /// Room for `samples` force samples a revolution (the samples of a step's period), so that
    /// [`Self::update`] does not allocate.
    pub fn reserve_samples(&mut self, samples: usize) {
        self.samples
            .reserve_exact(samples.saturating_sub(self.samples.len()));
    }

    /// Back to no revolution seen: the phase unknown.
    pub fn reset(&mut self) {
        self.rev_index = i64::MIN;
        self.best_force = f64::NEG_INFINITY;
        self.best_t = 0.0;
        self.sum_cos = 0.0;
        self.sum_sin = 0.0;
        self.weight = 0.0;
        self.revolutions = 0;
        self.samples.clear();
    }

    /// One force sample `force_n` (N) taken at `t_s`.
    pub fn update(&mut self, t_s: f64, force_n: f64) {
        if !force_n.is_finite() || !t_s.is_finite() {
            return;
        }
        let rev = (t_s / self.rev_s).floor() as i64;
        if rev != self.rev_index {
            self.close_revolution();
            self.rev_index = rev;
        }
        if force_n > self.best_force {
            self.best_force = force_n;
            self.best_t = t_s;
        }
        if !self.waveform.is_empty() {
            self.samples.push((t_s, force_n));
        }
    }

    fn close_revolution(&mut self) {
        if self.rev_index != i64::MIN && self.best_force > self.cut_n {
            let pass = self.matched_pass().unwrap_or(self.best_t);
            let theta = std::f64::consts::TAU * (pass / self.rev_s).rem_euclid(1.0);
            self.sum_cos = self.lambda * self.sum_cos + theta.cos();
            self.sum_sin = self.lambda * self.sum_sin + theta.sin();
            self.weight = self.lambda * self.weight + 1.0;
            self.revolutions += 1;
        }
        self.samples.clear();
        self.best_force = f64::NEG_INFINITY;
    }

    /// The pass at which the waveform matches the revolution's samples best (`None` without a
    /// waveform): the correlation on the waveform's grid within [`Self::MATCH_HALF_WIDTH_REV`] of the
    /// largest sample, its peak refined by a parabola through the best grid point and its neighbours.
    fn matched_pass(&self) -> Option<f64> {
        let n = self.waveform.len();
        if n == 0 || self.samples.is_empty() {
            return None;
        }
        let step = self.rev_s / n as f64;
        let half = (n as f64 * Self::MATCH_HALF_WIDTH_REV).round() as i64;
        let score = |pass: f64| -> f64 {
            self.samples
                .iter()
                .map(|&(t, f)| {
                    let k = ((t - pass) / step).round() as i64;
                    f * self.waveform[k.rem_euclid(n as i64) as usize]
                })
                .sum()
        };
        // the best trial pass, then its neighbours again: no buffer in the control cycle
        let mut best = (0_i64, f64::NEG_INFINITY);
        for j in -half..=half {
            let v = score(self.best_t + j as f64 * step);
            if v > best.1 {
                best = (j, v);
            }
        }
        let (jb, b) = best;
        let mut offset = jb as f64;
        if jb > -half && jb < half {
            let a = score(self.best_t + (jb - 1) as f64 * step);
            let c = score(self.best_t + (jb + 1) as f64 * step);
            let curvature = a - 2.0 * b + c;
            if curvature < 0.0 {
                offset += 0.5 * (a - c) / curvature;
            }
        }
        Some(self.best_t + offset * step)
    }

    /// A time (s) at which the larger flute passed, when the phase is known.
    pub fn pass_s(&self) -> Option<f64> {
        let needed = if self.waveform.is_empty() {
            Self::MIN_REVOLUTIONS
        } else {
            Self::MATCHED_REVOLUTIONS
        };
        if self.revolutions < needed || self.weight <= 0.0 {
            return None;
        }
        let r = self.sum_cos.hypot(self.sum_sin) / self.weight;
        if r < Self::MIN_AGREEMENT {
            return None;
        }
        let theta = self
            .sum_sin
            .atan2(self.sum_cos)
            .rem_euclid(std::f64::consts::TAU);
        Some(theta / std::f64::consts::TAU * self.rev_s)
    }
}

/// Memory of the groove MPC's [`PlanScale`] (s): long against a revolution (6 ms at 10 000 rpm), whose
/// per-revolution peaks it averages, short against a 12 s groove along which the force sensor drifts.
pub const PLAN_SCALE_TIME_CONSTANT_S: f64 = 0.5;

/// Flags a sensor whose reading has not changed (bit-identical) for `limit` consecutive samples: with the
/// published sensor noise this cannot happen to a live channel (a dropout / frozen ADC).
#[derive(Debug, Clone, Copy)]
struct StaleDetector {
    last: f64,
    repeats: usize,
    limit: usize,
}

impl StaleDetector {
    fn new(limit: usize) -> Self {
        Self {
            last: f64::NAN,
            repeats: 0,
            limit,
        }
    }

    fn reset(&mut self) {
        *self = Self::new(self.limit);
    }

    fn stale(&mut self, x: f64) -> bool {
        if x == self.last {
            self.repeats += 1;
        } else {
            self.repeats = 0;
            self.last = x;
        }
        self.repeats >= self.limit
    }
}

/// The offset-free MPC with preview of the planned deflection, run every `mpc_every` stage steps and
/// holding its command in between.
#[derive(Debug)]
pub struct MpcGrooveController {
    mpc: MpcController,
    plan: DeflectionPlan,
    force: ForcePeakChain,
    /// The peak's noise bias ([`GrooveMpcFeatures::unbiased_peak`]).
    peak_bias: Option<PeakNoiseBias>,
    /// Where the tool rides on its wear land ([`GrooveMpcFeatures::flank_rubbing`]; empty off).
    rubbing_mm: Vec<(f64, f64)>,
    compliance: f64,
    sin_a: f64,
    every: usize,
    tc_s: f64,
    rev_s: f64,
    tooth_s: f64,
    k: usize,
    v_hold: f64,
    window: PreviewWindow,
    stale: [StaleDetector; 2],
    preview: bool,
    features: GrooveMpcFeatures,
    scale: PlanScale,
    phase: SpindlePhase,
    times_buf: Vec<f64>,
    /// The plan at `times_buf` (storage kept between cycles).
    planned_buf: Vec<f64>,
    pulses: PulseCache,
    /// What the MPC did in the last step, when it planned in it.
    last: Option<MpcCycle>,
    /// The plan's deflection range over the cut (µm) and the actuator's z-reach on the controllers'
    /// spindle model (µm), for the stroke band.
    plan_range_um: (f64, f64),
    reach_z_um: f64,
    /// The touch-off's tip in z (µm): sin α × the gauge's reading there.
    z_zero_um: f64,
    /// The last cycle at which the preview saw a change ([`GrooveMpcFeatures::quiet_revolutions`]).
    last_change_s: f64,
    /// The required correction's range over the cut for the last plan scale, with a path offset:
    /// `(scale, (min, max))` ([`DeflectionPlan::required_range_um`]).
    required_range: (f64, (f64, f64)),
    /// MPC cycles in a spindle revolution ([`GrooveMpcFeatures::quiet_revolutions`]).
    cycles_per_rev: usize,
}

impl MpcGrooveController {
    /// The MPC of [`groove_mpc`] with the plan's preview, for the program's speed and tilt, a tool with
    /// `flutes` teeth and the controllers' stiffness; the force channel is judged stale after 2 ms of
    /// bit-identical readings, the gauge after 1 ms.
    ///
    /// # Errors
    /// Those of [`groove_mpc`], and [`MpcError::Sim`] for a pre-filter above Nyquist.
    pub fn new(
        plan: DeflectionPlan,
        program: &GrooveProgram,
        model_spindle: &IdentifiedSpindle,
        model_stiffness: &IdentifiedStiffness,
        flutes: u32,
        settings: &GrooveMpcSettings,
    ) -> Result<Self, MpcError> {
        let mut plan = plan;
        if !settings.features.flute_phase {
            plan.flute_ratio = 1.0;
        }
        let mut rubbing_mm = Vec::new();
        if settings.features.flank_rubbing {
            rubbing_mm = plan.rubbing_spans_mm();
            plan = plan.with_flank_push();
        }
        let peak_bias = if settings.features.unbiased_peak {
            Some(PeakNoiseBias::calibrate(
                program.speed_rpm,
                settings.dt_s,
                settings.force_noise_n,
                &plan.waveform,
            )?)
        } else {
            None
        };
        let mut mpc = groove_mpc(model_spindle, model_stiffness, program.tilt_deg, settings)?;
        let dt = settings.dt_s;
        let n = mpc.config().horizon;
        let tc = dt * settings.mpc_every as f64;
        // the cycles of the program (and its approach) and some to spare: the cycle times' storage
        mpc.reserve_cycle_times((program.duration_s() / tc).ceil() as usize + 1024);
        let window = PreviewWindow::zeros_for(mpc.config(), 2);
        let sp = model_spindle.plant();
        let sin_a = program.tilt_deg.to_radians().sin();
        let plan_range_um = plan.range_um();
        let mut phase =
            SpindlePhase::new(program.speed_rpm, &plan.waveform, settings.force_noise_n);
        phase.reserve_samples(samples_per_rev(program.speed_rpm, dt) + 2);
        // the preview's times: now, the sub-steps of the first cycles, then the cycles
        let (between, substeps) = mpc
            .config()
            .intersample
            .map_or((0, 1), |i| (i.cycles, i.substeps));
        let n_times = 1 + between * substeps + n;
        // the planned pulses from a revolution before now to the horizon's end, at the waveform's
        // spacing
        let rev_s = 60.0 / program.speed_rpm;
        let n_pulses =
            ((n as f64 * tc + rev_s) / (rev_s / WAVEFORM_SAMPLES as f64)).ceil() as usize + 8;
        Ok(Self {
            mpc,
            plan,
            force: ForcePeakChain::new(program.speed_rpm, dt)?,
            peak_bias,
            rubbing_mm,
            compliance: model_stiffness
                .stiffness()
                .z_compliance_um_per_n(program.tilt_deg)?,
            sin_a,
            every: settings.mpc_every,
            tc_s: dt * settings.mpc_every as f64,
            rev_s: 60.0 / program.speed_rpm,
            tooth_s: 60.0 / program.speed_rpm / flutes as f64,
            k: 0,
            v_hold: 0.0,
            window,
            // 1 ms of a bit-identical gauge reading, 2 ms of an identical force reading
            stale: [
                StaleDetector::new((2e-3 / dt) as usize),
                StaleDetector::new((1e-3 / dt) as usize),
            ],
            preview: true,
            features: settings.features,
            scale: PlanScale::new(dt * settings.mpc_every as f64, PLAN_SCALE_TIME_CONSTANT_S),
            phase,
            times_buf: Vec::with_capacity(n_times),
            planned_buf: Vec::with_capacity(n_times),
            pulses: PulseCache::with_capacity(n_pulses),
            last: None,
            plan_range_um,
            reach_z_um: sp.gain_um_per_v * sp.voltage_max_v * sin_a,
            z_zero_um: 0.0,
            last_change_s: f64::NEG_INFINITY,
            required_range: (f64::NAN, plan_range_um),
            cycles_per_rev: samples_per_rev(program.speed_rpm, dt * settings.mpc_every as f64),
        })
    }

    /// The current estimate of the measured over the planned deflection (1 with the feature off).
    pub fn plan_scale(&self) -> f64 {
        if self.features.adapt_plan_scale {
            self.scale.ratio()
        } else {
            1.0
        }
    }

    /// The same MPC without preview (the `mpc-nopreview` ablation): every step of the horizon is given the
    /// planned deflection *now* (a persistence forecast), so the MPC learns of a change ahead only when it
    /// arrives. Estimation, constraints and weights are unchanged.
    pub fn without_preview(mut self) -> Self {
        self.preview = false;
        self
    }

    /// The MPC inside.
    pub fn mpc(&self) -> &MpcController {
        &self.mpc
    }

    /// The preview window of the last cycle (what the QP was given besides the state estimate and
    /// the previous command).
    pub fn window(&self) -> &PreviewWindow {
        &self.window
    }
}

impl GrooveController for MpcGrooveController {
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        // the cycle's budget counts from here: sensor chain, preview and solve
        let cycle_start = std::time::Instant::now();
        self.last = None;
        let (force, gauge) = last
            .map(|o| (o.force_meas_n, o.gauge_um))
            .unwrap_or((0.0, 0.0));
        let force_stale = self.stale[0].stale(force);
        let gauge_stale = self.stale[1].stale(gauge);
        let fpk = self.force.step(force);
        let fpk = self.peak_bias.as_ref().map_or(fpk, |b| b.unbiased(fpk));
        // the sample of the last step: the stage's deflection holds its force peak from now on
        if last.is_some() && !force_stale {
            self.phase.update(t_s, force);
        }
        let run_now = self.k % self.every == 0;
        self.k += 1;
        if !run_now {
            return self.v_hold;
        }
        let n = self.mpc.config().horizon;
        // the first `between` cycles are planned at every stage step (intersample costs), the rest at
        // the cycles
        let (between, m) = self
            .mpc
            .config()
            .intersample
            .map_or((0, 1), |i| (i.cycles, i.substeps));
        let (rev, tooth) = (self.rev_s, self.tooth_s);
        let pass = self
            .features
            .spindle_phase
            .then(|| self.phase.pass_s())
            .flatten();
        // the plan now and over the horizon (with the spindle's angle: from the force waveform)
        let times = &mut self.times_buf;
        times.clear();
        times.push(t_s);
        let sub_s = self.tc_s / m as f64;
        times.extend((1..=between * m).map(|i| t_s + i as f64 * sub_s));
        times.extend((between + 1..=n).map(|j| t_s + j as f64 * self.tc_s));
        // index in `times` of cycle j (1..=n)
        let at_cycle = |j: usize| {
            if j <= between {
                j * m
            } else {
                between * m + j - between
            }
        };
        let planned = &mut self.planned_buf;
        planned.clear();
        planned.resize(times.len(), 0.0);
        match pass {
            Some(p) => {
                self.plan
                    .deflections_phased_into(&mut self.pulses, times, rev, tooth, p, planned)
            }
            None => {
                for (d, &t) in planned.iter_mut().zip(times.iter()) {
                    *d = self.plan.deflection_at_time(t, rev, tooth);
                }
            }
        }
        let planned = &self.planned_buf;
        let planned_now = planned[0];
        // a path offset the plan was given (an identified effect: + = deeper) enters the error channel
        // beside the deflection: the error is z − δ + o
        let offsets: Option<Vec<f64>> = (!self.plan.path_offset.is_empty()).then(|| {
            times
                .iter()
                .map(|&t| self.plan.path_offset_at(self.plan.x_at(t)))
                .collect()
        });
        // away from the changes the preview sees, the force once per revolution
        let mut skip_force = false;
        if self.features.quiet_revolutions {
            if planned
                .iter()
                .any(|&p| (p - planned_now).abs() > QUIET_CHANGE_UM)
            {
                self.last_change_s = t_s;
            }
            let quiet = t_s - self.last_change_s > QUIET_AFTER_REVOLUTIONS * self.rev_s;
            skip_force = quiet && (self.k / self.every) % self.cycles_per_rev != 0;
        }
        if !force_stale && fpk.is_finite() {
            self.scale.update(planned_now, self.compliance * fpk);
        }
        let rho = self.plan_scale();
        let offset = |i: usize| offsets.as_ref().map_or(0.0, |o| o[i]);
        // the z the stack must stand at for a deflection is the deflection above the touch-off's tip
        let z0 = self.z_zero_um;
        let band = if self.features.stroke_aware {
            let (lo, hi) = if offsets.is_some() {
                if (self.required_range.0 - rho).abs() > 1e-4 || self.required_range.0.is_nan() {
                    self.required_range = (rho, self.plan.required_range_um(rho));
                }
                self.required_range.1
            } else {
                (rho * self.plan_range_um.0, rho * self.plan_range_um.1)
            };
            StrokeBand::from_range(lo + z0, hi + z0, self.reach_z_um)
        } else {
            StrokeBand::from_range(0.0, 0.0, f64::INFINITY)
        };
        // the error channel's disturbance carries the deflection the plan misses now; the scale applies
        // to what the plan says will change over the horizon
        self.window.offset_now[OUT_ERROR] = -(planned_now + z0) + offset(0);
        let preview = self.preview;
        let ahead = |i: usize| {
            if preview {
                (planned[i], offset(i))
            } else {
                (planned_now, offset(0))
            }
        };
        for j in 0..n {
            let (a, o) = ahead(at_cycle(j + 1));
            self.window.offsets[j * 2 + OUT_ERROR] =
                -(planned_now + z0 + rho * (a - planned_now)) + o;
            self.window.reference[j * 2 + OUT_ERROR] = band.target_error_um(rho * a + z0 - o);
        }
        // between the cycles: sub-step s after cycle k (0-based)
        for k in 0..between {
            for s in 1..m {
                let (a, o) = ahead(k * m + s);
                let r = (k * (m - 1) + s - 1) * 2 + OUT_ERROR;
                self.window.intersample_offsets[r] =
                    -(planned_now + z0 + rho * (a - planned_now)) + o;
                self.window.intersample_reference[r] = band.target_error_um(rho * a + z0 - o);
            }
        }
        // a stale sensor is left out of the measurement update (prediction from the model and the plan),
        // and so is the force where the tool rides on its wear land
        let rubbing =
            !self.rubbing_mm.is_empty() && within_spans(&self.rubbing_mm, self.plan.x_at(t_s));
        let y = [
            if gauge_stale { f64::NAN } else { gauge },
            if gauge_stale || force_stale || rubbing || skip_force {
                f64::NAN
            } else {
                self.sin_a * gauge - z0 - self.compliance * fpk + offset(0)
            },
        ];
        // dimension errors cannot happen here (window built for this controller); on one, hold
        let mut u = [self.v_hold];
        if let Ok(c) = self.mpc.step_into(cycle_start, &y, &self.window, &mut u) {
            self.v_hold = u[0];
            self.last = Some(c);
        }
        self.v_hold
    }

    fn reset(&mut self) -> Result<(), MpcError> {
        self.mpc.reset()?;
        self.force.reset();
        self.k = 0;
        self.v_hold = 0.0;
        for s in &mut self.stale {
            s.reset();
        }
        self.scale.reset();
        self.phase.reset();
        self.pulses.reset();
        self.last = None;
        self.z_zero_um = 0.0;
        self.last_change_s = f64::NEG_INFINITY;
        Ok(())
    }

    fn last_cycle(&self) -> Option<MpcCycle> {
        self.last
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        Some(self.mpc.stats())
    }

    /// The touch-off's tip becomes the error channel's zero; the stack is at the bias, so the first
    /// move's slew limit counts from there.
    fn touched_off(&mut self, at: TouchOff) {
        self.z_zero_um = self.sin_a * at.gauge_um;
        self.v_hold = at.bias_v;
        if at.bias_v > 0.0 {
            self.mpc.set_previous_input(&[at.bias_v]);
        }
    }

    fn inject_solver_failures(&mut self, cycles: usize) {
        self.mpc.inject_solver_failures(cycles);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_sim::groove::{DepthProfile, GrooveProgram};

    /// The table search from a hint finds what the binary search finds, whatever the hint — on a
    /// plan with steps made at once (tabulated at their corners), at the corners and off both ends.
    #[test]
    fn the_search_from_a_hint_equals_the_binary_search() {
        let mut program = GrooveProgram::thesis(20.0);
        program.depth_profile = DepthProfile::Steps {
            steps: vec![(0.0, 40.0), (5.0, 60.0), (12.0, 30.0)],
        };
        let plan = DeflectionPlan::reference(&program, 400.0, 0.01, 0.5, |c| Ok(0.1 * c.depth_um))
            .unwrap();
        let n = plan.xs_mm.len();
        let xs: Vec<f64> = (0..4000)
            .map(|k| -0.5 + 21.0 * ((k * 7919) % 4000) as f64 / 4000.0)
            .chain([0.0, 5.0, 12.0, 20.0, 25.0])
            .collect();
        for hint0 in [0, 1, n / 3, n - 1, n, n + 5] {
            let mut hint = hint0;
            for &x in &xs {
                let (a, b) = (plan.deflection_at(x), plan.deflection_from(x, &mut hint));
                assert_eq!(a.to_bits(), b.to_bits(), "x = {x}, start {hint0}");
            }
        }
    }
}
