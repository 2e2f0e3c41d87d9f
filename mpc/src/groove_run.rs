//! Closed-loop runs on sim's groove stage (`millcomp_sim::groove::GrooveStage`, PZT spindle,
//! `000_…txt` ch. 6–7) with every controller.
//!
//! Stage sign conventions (sim): depth cut `d = d_cmd − δz + tip·sin α`, + = deeper; the PZT moves the tip
//! radially, so a z-correction δz needs a tip travel δz / sin α (eq. 26). Error = d − d_cmd.
//!
//! Controllers (all see only the measured force, the gauge, the plan and their *own* models):
//! - `none`: 0 V;
//! - `open-loop` (ch. 6): predicted per-revolution peak z-force of the planned cut (controller's force model
//!   at the programmed depth and feed) × the controller's z-compliance = predicted deflection; the tip is
//!   driven to it open loop through the spindle's static gain. The thesis pre-shifted the machine path; sim's
//!   groove stage has no programmable path table yet, so the pre-shift is applied through the actuator (the
//!   same quasi-static correction; the 20 kHz actuator is far faster than the 12 s ramp);
//! - `pid`, `pid-aw`, `pid-design` (ch. 7): measured force → 500 Hz 2nd-order filter → nested peak-and-hold
//!   → first-order 0.0005/0.9995 filter → × compliance / sin α = wanted tip; gauge → 500 Hz filter; PID on the
//!   difference (eq. 25) at the 20 kHz stage rate;
//! - `mpc`: every `mpc_every` steps (2 kHz), [`crate::spindle_mpc`] design with preview of the planned
//!   deflection, measured deflection = one-revolution sliding peak of the 2 kHz-low-passed force ×
//!   compliance.

use std::time::Instant;

use millcomp_sim::feed::FeedProfile;
use millcomp_sim::filters::{Biquad, FirstOrderFilter, PeakHold, SlidingMax};
use millcomp_sim::groove::{GrooveConfig, GrooveStage, GrooveStepOutput};
use millcomp_sim::material::Material;
use millcomp_sim::sensors::NoiseSpec;
use millcomp_sim::spindle::PztSpindle;
use millcomp_sim::stiffness::TiltedToolStiffness;

use crate::controller::{MpcController, PreviewWindow};
use crate::error::MpcError;
use crate::pid::{AntiWindup, Pid, PidGains};
use crate::predictor::{ForcePredictor, ResponseSurface};
use crate::report::{Metrics, ModelSummary, RunOutput, RunReport, Trace};
use crate::scenario::{ControllerKind, Fault, GrooveScenario, Scenario};
use crate::spindle_mpc::{OUT_ERROR, OUT_GAUGE, default_spindle_config};
use crate::stats::SolverStats;
use crate::truth::{CalibratedStiffness, ForceErrors, calibrate_stiffness};

/// Cut-off of the MPC's force pre-filter (Hz): well above the 333 Hz flute frequency so the per-revolution
/// peak is kept, low enough to take the 0.04 N sensor noise down by ~2×.
pub const MPC_FORCE_PREFILTER_HZ: f64 = 2000.0;

/// Window around a process change in which its peak error is taken: from 0.5 mm before (preview, early
/// moves) to 2 mm after (≈ 1.2 s: many filter time constants of the PID chain).
pub const CHANGE_WINDOW_BEFORE_MM: f64 = 0.5;
/// See [`CHANGE_WINDOW_BEFORE_MM`].
pub const CHANGE_WINDOW_AFTER_MM: f64 = 2.0;

/// Everything a groove run needs: the truth stage configuration and the controllers' models.
#[derive(Debug, Clone)]
pub struct GrooveSetup {
    /// Truth plant.
    pub truth: GrooveConfig,
    /// Controllers' force predictor (mechanistic or response surface).
    pub model_force: ForcePredictor,
    /// Controllers' stiffness (identified, times `1 + stiffness_error`).
    pub model_stiffness: TiltedToolStiffness,
    /// Controllers' spindle model.
    pub model_spindle: PztSpindle,
    /// The simulated calibration.
    pub calibration: CalibratedStiffness,
    /// The force-parameter errors used.
    pub force_errors: ForceErrors,
    /// Truth force scale (calibrated or sim's default).
    pub truth_force_scale: f64,
}

fn deepest(g: &GrooveScenario) -> f64 {
    let n = 400;
    (0..=n)
        .map(|i| {
            g.depth
                .depth_at(g.length_mm * i as f64 / n as f64, g.length_mm)
        })
        .fold(0.0, f64::max)
}

/// Read an identified model saved by `millcomp identify` (TOML).
fn load_saved(path: &str) -> Result<millcomp_identify::SavedModel, MpcError> {
    let text = std::fs::read_to_string(path).map_err(|e| MpcError::Io {
        path: path.to_string(),
        message: e.to_string(),
    })?;
    millcomp_identify::SavedModel::from_toml(&text).map_err(|e| MpcError::Scenario {
        path: path.to_string(),
        message: e.to_string(),
    })
}

/// Build the truth plant and the controllers' models for a groove scenario (see `mpc/SCENARIOS.md`).
pub fn groove_setup(s: &Scenario) -> Result<GrooveSetup, MpcError> {
    let g = s
        .groove
        .as_ref()
        .ok_or_else(|| crate::error::invalid("groove", "missing", "a [groove] table"))?;
    let mut truth = GrooveConfig::thesis(g.tilt_deg, g.wearland_um)?;
    truth.force_model.material = Material::by_name(&g.material)?;
    truth.program.speed_rpm = g.speed_rpm;
    truth.program.upfeed_um_per_rev = g.upfeed_um_per_rev;
    truth.program.length_mm = g.length_mm;
    truth.program.depth_profile = g.depth.clone();
    truth.program.feed_changes = g.feed_steps.clone();
    truth.program.feed_accel_mm_s2 = g.feed_accel_mm_s2;
    truth.program.exit = g.exit;
    truth.force_noise = (s.truth.force_noise_n > 0.0).then_some(NoiseSpec {
        seed: s.seed.wrapping_mul(31).wrapping_add(1),
        sigma: s.truth.force_noise_n,
    });
    truth.gauge_noise = (s.truth.gauge_noise_um > 0.0).then_some(NoiseSpec {
        seed: s.seed.wrapping_mul(31).wrapping_add(2),
        sigma: s.truth.gauge_noise_um,
    });
    truth.validate()?;
    if let Some(target) = g.calibrate_uncompensated_um {
        // the static deflection is proportional to the force scale up to the small depth feedback:
        // a few secant steps on the scale
        let d_max = deepest(g);
        let mut scale = truth.force_model.params.force_scale;
        for _ in 0..30 {
            let d = truth.static_deflection_um(d_max)?;
            if (d - target).abs() < 1e-6 * target {
                break;
            }
            scale *= target / d.max(1e-9);
            truth.force_model.params.force_scale = scale;
        }
        truth.validate()?;
    }
    let force_errors = s
        .truth
        .force_errors
        .unwrap_or_else(|| ForceErrors::draw(s.truth.force_error_max, s.seed));
    let model_force = match (&s.control.force_model, &s.control.force_response_surface) {
        (Some(_), Some(_)) => {
            return Err(crate::error::invalid(
                "control.force_response_surface",
                "given together with control.force_model",
                "one force predictor: either an identified model or a response surface",
            ));
        }
        (Some(path), None) => ForcePredictor::Mechanistic(
            load_saved(path)?
                .apply_to_force_model(&truth.force_model)
                .map_err(|e| {
                    crate::error::invalid(
                        "control.force_model",
                        path,
                        format!("a saved `force` model: {e}"),
                    )
                })?,
        ),
        (None, Some(path)) => ForcePredictor::ResponseSurface(ResponseSurface::load(path)?),
        (None, None) => ForcePredictor::Mechanistic(force_errors.apply(&truth.force_model)?),
    };
    let model_spindle = match &s.control.spindle_model {
        Some(path) => load_saved(path)?.to_spindle().map_err(|e| {
            crate::error::invalid(
                "control.spindle_model",
                path,
                format!("a saved `spindle` model: {e}"),
            )
        })?,
        None => truth.spindle.clone(),
    };
    let calibration = calibrate_stiffness(
        &truth.stiffness,
        &s.truth.stiffness_calibration,
        s.seed.wrapping_add(7),
    )?;
    let f = 1.0 + s.truth.stiffness_error;
    let model_stiffness = TiltedToolStiffness::new(
        calibration.axial_n_per_um * f,
        calibration.radial_n_per_um * f,
    )?;
    Ok(GrooveSetup {
        truth_force_scale: truth.force_model.params.force_scale,
        model_spindle,
        truth,
        model_force,
        model_stiffness,
        calibration,
        force_errors,
    })
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
    /// Tabulate every `dx_mm` along the groove.
    pub fn new(setup: &GrooveSetup, dx_mm: f64) -> Result<Self, MpcError> {
        let t = &setup.truth;
        let c = setup
            .model_stiffness
            .z_compliance_um_per_n(t.program.tilt_deg)?;
        let feed = t.feed_profile()?;
        let radius = t.force_model.tool.radius_um;
        let n = (t.program.length_mm / dx_mm).ceil() as usize + 1;
        let mut values = Vec::with_capacity(n);
        let mut extrapolated = 0;
        for i in 0..n {
            let x = (i as f64 * dx_mm).min(t.program.length_mm);
            let d = t
                .program
                .depth_profile
                .depth_at(x, t.program.length_mm)
                .clamp(0.0, radius);
            let e = t.engagement(x);
            let cond = t.conditions_at(d, feed.upfeed_at_x(x));
            let f = if d > 0.0 && e > 0.0 {
                if setup
                    .model_force
                    .response_surface()
                    .is_some_and(|r| r.extrapolates(&cond))
                {
                    extrapolated += 1;
                }
                setup.model_force.peak_z_force_n(&cond)? * e
            } else {
                0.0
            };
            // a tool cannot be pushed out of the cut by more than it is engaged: at the first few µm of
            // a ramp the flank force alone would predict more deflection than depth
            values.push((f * c).min(d));
        }
        Ok(Self {
            dx_mm,
            values_um: values,
            feed,
            extrapolated_points: extrapolated,
        })
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
    /// force of the last revolution (`000_…txt` §6.2), and the force peaks once per tooth: a rise appears
    /// when the next tooth reaches its peak — on average half a tooth period after the change — and a fall
    /// once the last tooth peak before it has left the one-revolution window — on average a revolution
    /// less half a tooth period after it. Evaluated as the maximum of the planned per-revolution
    /// deflection over `[t − T_rev + T_tooth/2, t − T_tooth/2]` (9 samples, ends included).
    pub fn deflection_at_time(&self, t_s: f64, rev_s: f64, tooth_s: f64) -> f64 {
        let t1 = t_s - 0.5 * tooth_s;
        let t0 = (t_s - rev_s + 0.5 * tooth_s).min(t1);
        (0..=8)
            .map(|i| {
                let t = t0 + (t1 - t0) * i as f64 / 8.0;
                self.deflection_at(self.x_at(t.max(0.0)))
            })
            .fold(0.0, f64::max)
    }

    /// Planned z-deflection (µm) at `x_mm` (linear interpolation).
    pub fn deflection_at(&self, x_mm: f64) -> f64 {
        let u = (x_mm / self.dx_mm).max(0.0);
        let i = u.floor() as usize;
        if i + 1 >= self.values_um.len() {
            return *self.values_um.last().unwrap_or(&0.0);
        }
        let f = u - i as f64;
        self.values_um[i] * (1.0 - f) + self.values_um[i + 1] * f
    }
}

/// A groove controller stepped at the stage rate.
trait GrooveCtl {
    /// Command (V) for the step starting at `t_s`, given the last stage output (None at the start).
    fn command(&mut self, last: Option<&GrooveStepOutput>, t_s: f64) -> f64;
    /// QP statistics (MPC only).
    fn solver_stats(&self) -> Option<SolverStats> {
        None
    }
}

struct NoneCtl;
impl GrooveCtl for NoneCtl {
    fn command(&mut self, _: Option<&GrooveStepOutput>, _: f64) -> f64 {
        0.0
    }
}

struct OpenLoopCtl {
    plan: DeflectionPlan,
    tip_per_z: f64,
    v_per_um: f64,
    v_max: f64,
}
impl GrooveCtl for OpenLoopCtl {
    fn command(&mut self, _: Option<&GrooveStepOutput>, t_s: f64) -> f64 {
        let dz = self.plan.deflection_at(self.plan.x_at(t_s));
        (dz * self.tip_per_z * self.v_per_um).clamp(0.0, self.v_max)
    }
}

struct PidCtl {
    force_lp: Biquad,
    gauge_lp: Biquad,
    peak: PeakHold,
    smooth: FirstOrderFilter,
    pid: Pid,
    tip_per_n: f64,
    dt_s: f64,
}
impl GrooveCtl for PidCtl {
    fn command(&mut self, last: Option<&GrooveStepOutput>, _: f64) -> f64 {
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

struct MpcCtl {
    mpc: MpcController,
    plan: DeflectionPlan,
    force_lp: Biquad,
    peak: SlidingMax,
    compliance: f64,
    sin_a: f64,
    every: usize,
    tc_s: f64,
    rev_s: f64,
    tooth_s: f64,
    k: usize,
    v_hold: f64,
    window: PreviewWindow,
    pending_failures: Vec<(f64, usize)>,
    stale: [StaleDetector; 2],
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

impl GrooveCtl for MpcCtl {
    fn command(&mut self, last: Option<&GrooveStepOutput>, t_s: f64) -> f64 {
        let (force, gauge) = last
            .map(|o| (o.force_meas_n, o.gauge_um))
            .unwrap_or((0.0, 0.0));
        let force_stale = self.stale[0].stale(force);
        let gauge_stale = self.stale[1].stale(gauge);
        let fpk = self.peak.step(self.force_lp.step(force));
        let run_now = self.k % self.every == 0;
        self.k += 1;
        if !run_now {
            return self.v_hold;
        }
        self.pending_failures.retain(|&(t, n)| {
            if t_s >= t {
                self.mpc.inject_solver_failures(n);
                false
            } else {
                true
            }
        });
        let n = self.mpc.config().horizon;
        let (rev, tooth) = (self.rev_s, self.tooth_s);
        self.window.offset_now[OUT_ERROR] = -self.plan.deflection_at_time(t_s, rev, tooth);
        for j in 0..n {
            let t = t_s + (j + 1) as f64 * self.tc_s;
            self.window.offsets[j * 2 + OUT_ERROR] = -self.plan.deflection_at_time(t, rev, tooth);
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
}

/// Build the MPC for a groove setup (the scenario's `control.mpc` if given, else the default spindle design).
pub fn groove_mpc(setup: &GrooveSetup, s: &Scenario) -> Result<MpcController, MpcError> {
    let tc = s.control.dt_s * s.control.mpc_every as f64;
    let sin_a = setup.truth.program.tilt_deg.to_radians().sin();
    let single = setup.model_spindle.to_lti()?.discretize_zoh(tc)?;
    let n = single.n_states();
    let mut c = nalgebra::DMatrix::zeros(2, n);
    for j in 0..n {
        c[(OUT_GAUGE, j)] = single.c[(0, j)];
        c[(OUT_ERROR, j)] = sin_a * single.c[(0, j)];
    }
    let model =
        millcomp_sim::DiscreteLti::new(single.a, single.b, c, nalgebra::DMatrix::zeros(2, 1), tc)?;
    let cfg = match &s.control.mpc {
        Some(m) => m.clone(),
        None => {
            let mut c = default_spindle_config(
                s.control.horizon,
                setup.truth.spindle.voltage_max_v,
                s.control.slew_v_per_cycle,
            );
            // measured error channel: σ ≈ compliance × σ of the filtered per-revolution force peak
            let comp = setup
                .model_stiffness
                .z_compliance_um_per_n(setup.truth.program.tilt_deg)?;
            let sf = (s.truth.force_noise_n * 0.5).max(0.005);
            c.kalman.measurement_noise = vec![
                (s.truth.gauge_noise_um.max(0.005)).powi(2),
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

fn apply_faults(
    o: &GrooveStepOutput,
    faults: &[Fault],
    stuck: &mut Option<(f64, f64)>,
) -> GrooveStepOutput {
    let mut m = *o;
    let t = o.t_s;
    let mut stuck_now = false;
    for f in faults {
        match *f {
            Fault::ForceSpike {
                t_s,
                magnitude_n,
                duration_s,
            } if t >= t_s && t < t_s + duration_s => {
                m.force_meas_n += magnitude_n;
            }
            Fault::StuckSensor { t_s, duration_s } if t >= t_s && t < t_s + duration_s => {
                stuck_now = true
            }
            _ => {}
        }
    }
    if stuck_now {
        let (f, g) = *stuck.get_or_insert((m.force_meas_n, m.gauge_um));
        m.force_meas_n = f;
        m.gauge_um = g;
    } else {
        *stuck = Some((m.force_meas_n, m.gauge_um));
        // keep the last good value as the candidate to freeze at
    }
    m
}

/// The x-windows (mm) around the process changes of a groove in which their peak error is taken: each
/// depth change point and feed change from [`CHANGE_WINDOW_BEFORE_MM`] before to
/// [`CHANGE_WINDOW_AFTER_MM`] after, and the exit zone (from the start of the engagement drop, minus
/// [`CHANGE_WINDOW_BEFORE_MM`], to the edge).
pub fn change_windows(t: &GrooveConfig) -> Vec<(f64, f64)> {
    let mut w: Vec<(f64, f64)> = t
        .program
        .depth_profile
        .change_points_mm()
        .into_iter()
        .chain(t.program.feed_changes.iter().map(|f| f.x_mm))
        .map(|x| (x - CHANGE_WINDOW_BEFORE_MM, x + CHANGE_WINDOW_AFTER_MM))
        .collect();
    w.extend(exit_window(t));
    w
}

/// The exit zone (mm): from [`CHANGE_WINDOW_BEFORE_MM`] before the engagement starts to drop to the edge.
fn exit_window(t: &GrooveConfig) -> Option<(f64, f64)> {
    t.program
        .exit
        .map(|e| (e.x_mm - e.length_mm - CHANGE_WINDOW_BEFORE_MM, e.x_mm))
}

/// Run a groove scenario with one controller.
pub fn run_groove(s: &Scenario, kind: ControllerKind) -> Result<RunOutput, MpcError> {
    let wall = Instant::now();
    let setup = groove_setup(s)?;
    let t = &setup.truth;
    let dt = s.control.dt_s;
    let sin_a = t.program.tilt_deg.to_radians().sin();
    let plan = DeflectionPlan::new(&setup, 0.01)?;
    let v_max = t.spindle.voltage_max_v;
    let mut notes = Vec::new();
    let mut ctl: Box<dyn GrooveCtl> = match kind {
        ControllerKind::None => Box::new(NoneCtl),
        ControllerKind::OpenLoop => {
            notes.push(
                "open-loop pre-shift applied through the PZT (sim's stage has no path table yet)"
                    .into(),
            );
            Box::new(OpenLoopCtl {
                plan: plan.clone(),
                tip_per_z: 1.0 / sin_a,
                v_per_um: 1.0 / setup.model_spindle.gain_um_per_v,
                v_max,
            })
        }
        ControllerKind::Pid | ControllerKind::PidAntiWindup | ControllerKind::PidDesign => {
            let gains = if kind == ControllerKind::PidDesign {
                PidGains::design()
            } else {
                PidGains::tuned()
            };
            let aw = if kind == ControllerKind::PidAntiWindup {
                AntiWindup::BackCalculation { tracking_s: 1e-3 }
            } else {
                AntiWindup::None
            };
            Box::new(PidCtl {
                force_lp: Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt)?,
                gauge_lp: Biquad::low_pass(500.0, std::f64::consts::FRAC_1_SQRT_2, dt)?,
                peak: PeakHold::thesis(t.program.speed_rpm)?,
                smooth: FirstOrderFilter::thesis(dt)?,
                pid: Pid::new(
                    gains,
                    aw,
                    setup.model_spindle.loop_v_per_unit,
                    0.0,
                    v_max,
                    dt,
                ),
                tip_per_n: setup
                    .model_stiffness
                    .pzt_compliance_um_per_n(t.program.tilt_deg)?,
                dt_s: dt,
            })
        }
        ControllerKind::Threshold => {
            return Err(MpcError::InvalidConfig {
                key: "controller".into(),
                value: "threshold".into(),
                allowed: "the thin-wall stage (threshold is the 004 thin-wall baseline)".into(),
            });
        }
        ControllerKind::Mpc => {
            let mpc = groove_mpc(&setup, s)?;
            let n = mpc.config().horizon;
            let steps_per_rev = (60.0 / t.program.speed_rpm / dt).round() as usize;
            Box::new(MpcCtl {
                mpc,
                plan: plan.clone(),
                force_lp: Biquad::low_pass(
                    MPC_FORCE_PREFILTER_HZ,
                    std::f64::consts::FRAC_1_SQRT_2,
                    dt,
                )?,
                peak: SlidingMax::new(steps_per_rev),
                compliance: setup
                    .model_stiffness
                    .z_compliance_um_per_n(t.program.tilt_deg)?,
                sin_a,
                every: s.control.mpc_every,
                tc_s: dt * s.control.mpc_every as f64,
                rev_s: 60.0 / t.program.speed_rpm,
                tooth_s: 60.0 / t.program.speed_rpm / t.force_model.tool.flutes as f64,
                k: 0,
                v_hold: 0.0,
                window: PreviewWindow::zeros(n, 2),
                pending_failures: s.solver_failures(),
                // 1 ms of a bit-identical gauge reading, 2 ms of an identical force reading
                stale: [
                    StaleDetector::new((2e-3 / dt) as usize),
                    StaleDetector::new((1e-3 / dt) as usize),
                ],
            })
        }
    };
    // process changes inside the groove: depth steps / plunges, feed changes, the exit
    let windows = change_windows(t);
    let exit_window = exit_window(t);
    let mut change_peak: f64 = 0.0;
    let mut exit_overcut: f64 = 0.0;
    if plan.extrapolated_points > 0 {
        notes.push(format!(
            "force predictor extrapolated at {} of {} planned points (outside the response surface's fitted ranges)",
            plan.extrapolated_points,
            plan.n_points()
        ));
    }
    if let ForcePredictor::ResponseSurface(_) = &setup.model_force {
        notes.push(format!(
            "controllers' force predictor: {}",
            setup.model_force.describe()
        ));
    }
    let mut stage = GrooveStage::new(t.clone(), dt)?;
    let mut last: Option<GrooveStepOutput> = None;
    let mut stuck = None;
    let mut errors = Vec::with_capacity((t.duration_s() / dt) as usize + 2);
    let mut travel = 0.0;
    let mut prev_tip = 0.0;
    let mut finite = true;
    let mut in_limits = true;
    let mut trace = Trace::new(&[
        "t_s",
        "x_mm",
        "depth_cmd_um",
        "depth_cut_um",
        "error_um",
        "deflection_um",
        "pzt_tip_um",
        "command_v",
        "force_meas_n",
        "gauge_um",
        "planned_deflection_um",
    ]);
    let decimate = 20usize;
    let mut k = 0usize;
    loop {
        let obs = last
            .as_ref()
            .map(|o| apply_faults(o, &s.faults, &mut stuck));
        let t_now = k as f64 * dt;
        let v = ctl.command(obs.as_ref(), t_now);
        if !v.is_finite() {
            finite = false;
        }
        if !(0.0..=v_max).contains(&v) {
            in_limits = false;
        }
        let o = stage.step(v);
        // the groove exists only where the tool is engaged (before the workpiece edge)
        if o.engagement > 0.0 {
            let err = o.depth_cut_um - o.depth_cmd_um;
            errors.push(err);
            if windows.iter().any(|(a, b)| o.x_mm >= *a && o.x_mm <= *b) {
                change_peak = change_peak.max(err.abs());
            }
            if let Some((a, b)) = exit_window
                && o.x_mm >= a
                && o.x_mm <= b
            {
                exit_overcut = exit_overcut.max(err);
            }
        }
        travel += (o.pzt_tip_um - prev_tip).abs();
        prev_tip = o.pzt_tip_um;
        if k % decimate == 0 {
            trace.rows.push(vec![
                o.t_s,
                o.x_mm,
                o.depth_cmd_um,
                o.depth_cut_um,
                o.depth_cut_um - o.depth_cmd_um,
                o.deflection_um,
                o.pzt_tip_um,
                v,
                obs.map(|x| x.force_meas_n).unwrap_or(0.0),
                obs.map(|x| x.gauge_um).unwrap_or(0.0),
                plan.deflection_at(o.x_mm),
            ]);
        }
        k += 1;
        let done = o.done;
        last = Some(o);
        if done {
            break;
        }
    }
    let kz_model = setup
        .model_stiffness
        .z_stiffness_n_per_um(t.program.tilt_deg)?;
    let kz_truth = t.stiffness.z_stiffness_n_per_um(t.program.tilt_deg)?;
    let report = RunReport {
        scenario: s.name.clone(),
        stage: "groove".into(),
        controller: kind.name().into(),
        metrics: Metrics {
            exit_overcut_um: exit_window.map(|_| exit_overcut),
            ..Metrics::from_errors(&errors, travel)
        },
        solver: ctl.solver_stats(),
        walls: None,
        commands_finite: finite,
        commands_in_limits: in_limits,
        process_change_peak_um: (!windows.is_empty()).then_some(change_peak),
        model: ModelSummary {
            kz_model_n_per_um: kz_model,
            kz_truth_n_per_um: kz_truth,
            stiffness_error_rel: kz_model / kz_truth - 1.0,
            force_error_max_rel: setup.force_errors.max_abs(),
            truth_force_scale: setup.truth_force_scale,
        },
        simulated_s: k as f64 * dt,
        wall_clock_s: wall.elapsed().as_secs_f64(),
        notes,
    };
    Ok(RunOutput { report, trace })
}
