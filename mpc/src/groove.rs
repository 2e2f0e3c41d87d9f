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
//! - [`NoneController`]: 0 V;
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

use crate::identified::{IdentifiedSpindle, IdentifiedStiffness};
use millcomp_sim::DiscreteLti;
use millcomp_sim::SimError;
use millcomp_sim::feed::FeedProfile;
use millcomp_sim::filters::{Biquad, FirstOrderFilter, PeakHold, SlidingMax};
use millcomp_sim::force::CutConditions;
use millcomp_sim::groove::GrooveProgram;
use nalgebra::DMatrix;

use crate::config::MpcConfig;
use crate::controller::{MpcController, PreviewWindow};
use crate::error::MpcError;
use crate::pid::{AntiWindup, Pid, PidGains};
use crate::predictor::ForcePredictor;
use crate::spindle_mpc::{OUT_ERROR, OUT_GAUGE, default_spindle_config};
use crate::stats::SolverStats;

/// Cut-off of the MPC's force pre-filter (Hz): well above the 333 Hz flute frequency so the per-revolution
/// peak is kept, low enough to take the 0.04 N sensor noise down by ~2×.
pub const MPC_FORCE_PREFILTER_HZ: f64 = 2000.0;

/// The force chain the MPC and `pid-tuned` read through: the measured force through the
/// [`MPC_FORCE_PREFILTER_HZ`] 2nd-order low-pass, then the one-revolution sliding peak ([`SlidingMax`]).
#[derive(Debug, Clone)]
pub struct ForcePeakChain {
    low_pass: Biquad,
    peak: SlidingMax,
}

impl ForcePeakChain {
    /// The chain for a spindle at `speed_rpm`, sampled every `dt_s`.
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a pre-filter above Nyquist.
    pub fn new(speed_rpm: f64, dt_s: f64) -> Result<Self, MpcError> {
        let steps_per_rev = (60.0 / speed_rpm / dt_s).round() as usize;
        Ok(Self {
            low_pass: Biquad::low_pass(
                MPC_FORCE_PREFILTER_HZ,
                std::f64::consts::FRAC_1_SQRT_2,
                dt_s,
            )?,
            peak: SlidingMax::new(steps_per_rev.max(1)),
        })
    }

    /// One force sample (N) in, the filtered per-revolution peak (N) out.
    pub fn step(&mut self, force_n: f64) -> f64 {
        self.peak.step(self.low_pass.step(force_n))
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
    dx_mm: f64,
    values_um: Vec<f64>,
    feed: FeedProfile,
    /// Tabulated points where the force predictor extrapolated beyond its fitted range.
    pub extrapolated_points: usize,
}

impl DeflectionPlan {
    /// Tabulate the plan every `dx_mm` along the programmed groove, with the controllers' force
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
        Ok(plan)
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
        let n = (program.length_mm / dx_mm).ceil() as usize + 1;
        let mut values = Vec::with_capacity(n);
        for i in 0..n {
            let x = (i as f64 * dx_mm).min(program.length_mm);
            values.push(point(
                program,
                &feed,
                tool_radius_um,
                c,
                x,
                program.depth_at(x),
                &mut force,
            )?);
        }
        Ok(Self {
            dx_mm,
            values_um: values,
            feed,
            extrapolated_points: 0,
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
    /// the spindle the controllers do not know. For each of 8 phases φ across a tooth period the
    /// deflection is the largest planned value at the tooth peaks of the last revolution,
    /// `t − φ − k·T_tooth`; the plan is the midpoint of the smallest and largest over the phases. Where
    /// the process is steady the phases agree; at a change that happens at once the deflection steps at
    /// an unknown instant within a tooth period, and the midpoint is the reference whose worst error over
    /// that instant is smallest (half the step, where tracking either guess risks all of it).
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
    /// let (rev, tooth) = (6e-3, 3e-3);
    /// let (before, after) = (plan.deflection_at(5.9), plan.deflection_at(6.1));
    /// assert!(after > before);
    /// // steady before and a revolution after; in between within the tooth period after the change (the
    /// // 10 µm table itself spreads the step over 10 µm / 3.33 mm/s = 3 ms)
    /// assert!((plan.deflection_at_time(3.59, rev, tooth) - before).abs() < 1e-9);
    /// assert!((plan.deflection_at_time(3.62, rev, tooth) - after).abs() < 1e-9);
    /// let mid = plan.deflection_at_time(3.6 + 1.5e-3, rev, tooth);
    /// assert!(before < mid && mid < after, "{before} {mid} {after}");
    /// ```
    pub fn deflection_at_time(&self, t_s: f64, rev_s: f64, tooth_s: f64) -> f64 {
        let teeth = ((rev_s / tooth_s).round() as usize).max(1);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in 0..8 {
            let phi = (j as f64 + 0.5) / 8.0 * tooth_s;
            let d = (0..teeth)
                .map(|k| {
                    let t = t_s - phi - k as f64 * tooth_s;
                    self.deflection_at(self.x_at(t.max(0.0)))
                })
                .fold(0.0, f64::max);
            lo = lo.min(d);
            hi = hi.max(d);
        }
        0.5 * (lo + hi)
    }

    /// Planned z-deflection (µm) at `x_mm` (linear interpolation; 0 on the approach in air, x < 0).
    pub fn deflection_at(&self, x_mm: f64) -> f64 {
        if x_mm < 0.0 {
            return 0.0;
        }
        let u = x_mm / self.dx_mm;
        let i = u.floor() as usize;
        if i + 1 >= self.values_um.len() {
            return *self.values_um.last().unwrap_or(&0.0);
        }
        let f = u - i as f64;
        self.values_um[i] * (1.0 - f) + self.values_um[i + 1] * f
    }
}

/// One planned deflection (µm): the peak z-force at depth `depth_um` (clamped to the ball) and the planned
/// upfeed at `x_mm`, times the engagement there and the compliance `c`.
fn point(
    program: &GrooveProgram,
    feed: &FeedProfile,
    tool_radius_um: f64,
    c: f64,
    x_mm: f64,
    depth_um: f64,
    force: &mut impl FnMut(&CutConditions) -> Result<f64, MpcError>,
) -> Result<f64, MpcError> {
    let d = depth_um.clamp(0.0, tool_radius_um);
    let e = program.engagement(x_mm);
    let f = if d > 0.0 && e > 0.0 {
        force(&program.conditions_at(d, feed.upfeed_at_x(x_mm)))? * e
    } else {
        0.0
    };
    // a tool cannot be pushed out of the cut by more than it is engaged: at the first few µm of a ramp
    // the flank force alone would predict more deflection than depth
    Ok((f * c).min(d))
}

/// A groove controller stepped at the stage rate.
pub trait GrooveController {
    /// Command (V) for the step starting at `t_s`, given the last measurement (None at the start).
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64;
    /// QP statistics (MPC only).
    fn solver_stats(&self) -> Option<SolverStats> {
        None
    }
    /// Make the next `cycles` QP solves fail (fault injection; MPC only, a no-op for the others).
    fn inject_solver_failures(&mut self, _cycles: usize) {}
}

/// No compensation: 0 V.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoneController;

impl GrooveController for NoneController {
    fn command(&mut self, _: Option<&GrooveMeasurement>, _: f64) -> f64 {
        0.0
    }
}

/// Open-loop compensation (ch. 6): the planned deflection, driven through the spindle's static gain.
#[derive(Debug, Clone)]
pub struct OpenLoopController {
    plan: DeflectionPlan,
    tip_per_z: f64,
    v_per_um: f64,
    v_max: f64,
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
        }
    }
}

impl OpenLoopController {
    /// The voltage that puts the tip where the plan's deflection at `t_s` wants it (unclamped).
    fn volts_at(&self, t_s: f64) -> f64 {
        self.plan.deflection_at(self.plan.x_at(t_s)) * self.tip_per_z * self.v_per_um
    }
}

impl GrooveController for OpenLoopController {
    fn command(&mut self, _: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        self.volts_at(t_s).clamp(0.0, self.v_max)
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
        Ok(Self {
            force_lp: Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt_s)?,
            gauge_lp: Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt_s)?,
            peak: PeakHold::thesis(program.speed_rpm)?,
            smooth: FirstOrderFilter::thesis(dt_s)?,
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
        })
    }
}

impl GrooveController for PidController {
    fn command(&mut self, last: Option<&GrooveMeasurement>, _: f64) -> f64 {
        let Some(o) = last else { return 0.0 };
        let f = self.force_lp.step(o.force_meas_n);
        let p = self.peak.step(f, self.dt_s);
        let p = if p.is_finite() { p } else { 0.0 };
        let fs = self.smooth.step(p);
        let g = self.gauge_lp.step(o.gauge_um);
        let e = fs * self.tip_per_n - g;
        self.pid.step(e)
    }
}

/// `pid-tuned`: the strongest feedback PID a control engineer would build today on the commissioned plant,
/// reading exactly what the MPC reads — force through the [`MPC_FORCE_PREFILTER_HZ`] low-pass and the
/// one-revolution sliding peak, times the controllers' tip compliance = wanted tip; the raw gauge — with
/// PI gains from the fixed rule of [`crate::tuning`] (largest integral gain with `Ms ≤ 1.6` on the
/// controllers' spindle model) and conditional-integration anti-windup, at the stage rate.
#[derive(Debug, Clone)]
pub struct TunedPidController {
    force: ForcePeakChain,
    pid: Pid,
    tip_per_n: f64,
    design: crate::tuning::PiDesign,
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
        })
    }

    /// The PI design in use.
    pub fn design(&self) -> crate::tuning::PiDesign {
        self.design
    }
}

impl TunedPidController {
    /// One step with `v_ff` volts fed forward (inside the saturation). Before the first measurement the
    /// error is 0: the output is `v_ff` clamped (0 without feedforward).
    fn step_with_feedforward(&mut self, last: Option<&GrooveMeasurement>, v_ff: f64) -> f64 {
        let Some(o) = last else {
            return self.pid.step_with_feedforward(0.0, v_ff);
        };
        let fpk = self.force.step(o.force_meas_n);
        let wanted_tip = if fpk.is_finite() {
            fpk * self.tip_per_n
        } else {
            0.0
        };
        self.pid
            .step_with_feedforward(wanted_tip - o.gauge_um, v_ff)
    }
}

impl GrooveController for TunedPidController {
    fn command(&mut self, last: Option<&GrooveMeasurement>, _: f64) -> f64 {
        self.step_with_feedforward(last, 0.0)
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
/// The PI gains are `pid-tuned`'s (not retuned); the PI corrects what the plan gets wrong.
#[derive(Debug, Clone)]
pub struct FeedforwardPidController {
    feedback: TunedPidController,
    plan: OpenLoopController,
    lead_s: f64,
}

impl FeedforwardPidController {
    /// `feedback` (a [`TunedPidController`], not retuned) plus `plan` turned into volts as the
    /// open-loop controller does, [`spindle_mean_delay_s`] of `model_spindle` ahead.
    pub fn new(
        feedback: TunedPidController,
        plan: DeflectionPlan,
        program: &GrooveProgram,
        model_spindle: &IdentifiedSpindle,
        voltage_max_v: f64,
    ) -> Self {
        Self {
            feedback,
            plan: OpenLoopController::new(plan, program, model_spindle, voltage_max_v),
            lead_s: spindle_mean_delay_s(model_spindle),
        }
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
        let v_ff = self.plan.volts_at(t_s + self.lead_s);
        self.feedback.step_with_feedforward(last, v_ff)
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
    let single = model_spindle.plant().to_lti()?.discretize_zoh(tc)?;
    let n = single.n_states();
    let mut c = DMatrix::zeros(2, n);
    for j in 0..n {
        c[(OUT_GAUGE, j)] = single.c[(0, j)];
        c[(OUT_ERROR, j)] = sin_a * single.c[(0, j)];
    }
    let model = DiscreteLti::new(single.a, single.b, c, DMatrix::zeros(2, 1), tc)?;
    let cfg = match &settings.config {
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
            c.kalman.measurement_noise = vec![
                (settings.gauge_noise_um.max(0.005)).powi(2),
                (comp * sf).powi(2).max(1e-4),
            ];
            // the deflection mismatch (force-model error × planned deflection) changes slowly except at
            // process changes, which the preview already carries: a (0.003 µm)²/cycle random walk gives a
            // ≈ 5 ms (≈ one revolution) disturbance time constant against ≈ 0.035 µm measurement noise,
            // smoothing the per-revolution steps of the measured peak
            c.kalman.disturbance_noise = 1e-5;
            c
        }
    };
    MpcController::new(&model, &cfg)
}

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
        let mpc = groove_mpc(model_spindle, model_stiffness, program.tilt_deg, settings)?;
        let dt = settings.dt_s;
        let n = mpc.config().horizon;
        Ok(Self {
            mpc,
            plan,
            force: ForcePeakChain::new(program.speed_rpm, dt)?,
            compliance: model_stiffness
                .stiffness()
                .z_compliance_um_per_n(program.tilt_deg)?,
            sin_a: program.tilt_deg.to_radians().sin(),
            every: settings.mpc_every,
            tc_s: dt * settings.mpc_every as f64,
            rev_s: 60.0 / program.speed_rpm,
            tooth_s: 60.0 / program.speed_rpm / flutes as f64,
            k: 0,
            v_hold: 0.0,
            window: PreviewWindow::zeros(n, 2),
            // 1 ms of a bit-identical gauge reading, 2 ms of an identical force reading
            stale: [
                StaleDetector::new((2e-3 / dt) as usize),
                StaleDetector::new((1e-3 / dt) as usize),
            ],
            preview: true,
        })
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
}

impl GrooveController for MpcGrooveController {
    fn command(&mut self, last: Option<&GrooveMeasurement>, t_s: f64) -> f64 {
        let (force, gauge) = last
            .map(|o| (o.force_meas_n, o.gauge_um))
            .unwrap_or((0.0, 0.0));
        let force_stale = self.stale[0].stale(force);
        let gauge_stale = self.stale[1].stale(gauge);
        let fpk = self.force.step(force);
        let run_now = self.k % self.every == 0;
        self.k += 1;
        if !run_now {
            return self.v_hold;
        }
        let n = self.mpc.config().horizon;
        let (rev, tooth) = (self.rev_s, self.tooth_s);
        self.window.offset_now[OUT_ERROR] = -self.plan.deflection_at_time(t_s, rev, tooth);
        for j in 0..n {
            self.window.offsets[j * 2 + OUT_ERROR] = if self.preview {
                let t = t_s + (j + 1) as f64 * self.tc_s;
                -self.plan.deflection_at_time(t, rev, tooth)
            } else {
                self.window.offset_now[OUT_ERROR]
            };
        }
        // a stale sensor is left out of the measurement update (prediction from the model and the plan)
        let y = [
            if gauge_stale { f64::NAN } else { gauge },
            if gauge_stale || force_stale {
                f64::NAN
            } else {
                self.sin_a * gauge - self.compliance * fpk
            },
        ];
        // dimension errors cannot happen here (window built for this controller); on one, hold
        if let Ok(s) = self.mpc.step(&y, &self.window) {
            self.v_hold = s.u[0];
        }
        self.v_hold
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        Some(self.mpc.stats())
    }

    fn inject_solver_failures(&mut self, cycles: usize) {
        self.mpc.inject_solver_failures(cycles);
    }
}
