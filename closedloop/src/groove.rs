//! Closed-loop runs on sim's groove stage (`millcomp_sim::groove::GrooveStage`, PZT spindle,
//! `000_…txt` ch. 6–7) with every controller of [`millcomp_mpc::groove`].
//!
//! The truth plant is sim's stage configured from the scenario; the controllers get the program, their
//! own models — identified from a commissioning of the plant or a bundle ([`groove_setup`]) — and the
//! measured signals only. Error = depth cut − programmed depth.

use std::path::PathBuf;
use std::time::Instant;

use millcomp_sim::actuator::{BoucWenParams, LogCreepParams};
use millcomp_sim::groove::{GrooveConfig, GrooveProgram, GrooveStage, GrooveStepOutput};
use millcomp_sim::material::Material;
use millcomp_sim::sensors::{CapacitanceGauge, InstrumentErrors, NoiseSpec};

use millcomp_models::SensorNoise;
use millcomp_mpc::groove::{
    Compensated, DeflectionPlan, FeedforwardPidController, ForcePeakChain, GrooveController,
    GrooveMpcSettings, MpcGrooveController, NoneController, OpenLoopController, PidController,
    TouchOff, TunedPidController,
};
use millcomp_mpc::identified::{
    HysteresisCompensator, IdentifiedForceModel, IdentifiedHysteresis, IdentifiedSpindle,
    IdentifiedStiffness, NominalTool,
};
use millcomp_mpc::pid::{AntiWindup, PidGains};
use millcomp_mpc::predictor::ForcePredictor;

use crate::cache::{CommissioningCache, CommissioningKey};
use crate::changes::{ChangeKind, bound_window, excess, level_before, program_changes};
use crate::commissioning::CommissioningPlant;
use crate::error::{ClosedLoopError, invalid};
use crate::faults::{SolverFailures, groove_measurement};
use crate::model_errors::ForceErrors;
use crate::model_files::{load_bundle, load_force_params, load_response_surface, load_spindle};
use crate::optimum::{certainty_equivalent_pp, excess_lower_bound};
use crate::profile::{Stage, timed};
use crate::report::{Metrics, ModelSummary, RunOutput, RunReport, Trace};
use crate::scenario::{ControllerKind, GrooveScenario, Scenario};
use crate::touch_off::{REMANENCE_ALLOWANCE, TouchOffBias, auto_bias};

/// Window around a process change in which its peak error is taken: from 0.5 mm before (preview, early
/// moves) to 2 mm after (≈ 1.2 s: many filter time constants of the PID chain).
pub const CHANGE_WINDOW_BEFORE_MM: f64 = 0.5;
/// See [`CHANGE_WINDOW_BEFORE_MM`].
pub const CHANGE_WINDOW_AFTER_MM: f64 = 2.0;

/// Everything a groove run needs: the truth stage configuration and the controllers' models — typed so
/// that only identified models and the catalogue can make them ([`millcomp_mpc::identified`]).
#[derive(Debug, Clone)]
pub struct GrooveSetup {
    /// Truth plant.
    pub truth: GrooveConfig,
    /// The catalogue tool and material the controllers' force model starts from.
    pub nominal_tool: NominalTool,
    /// Controllers' force predictor (identified mechanistic model or response surface).
    pub model_force: ForcePredictor,
    /// Controllers' stiffness (identified, times `1 + truth.stiffness_error`).
    pub model_stiffness: IdentifiedStiffness,
    /// Controllers' spindle model (identified).
    pub model_spindle: IdentifiedSpindle,
    /// The stack's hysteresis (identified; a bundle from a commissioning has one).
    pub model_hysteresis: Option<IdentifiedHysteresis>,
    /// The deliberate force-parameter errors laid on the identified force model.
    pub force_errors: ForceErrors,
    /// Truth force scale (calibrated or sim's default).
    pub truth_force_scale: f64,
    /// The sensors' noise levels the MPC's Kalman filter assumes (from the bundle: its record at rest or
    /// its fits' residuals), or why the bundle has none.
    pub sensor_noise: Result<SensorNoise, String>,
    /// Where the controllers' models came from, for the run notes.
    pub models_from: String,
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

/// The program a groove scenario cuts — what the NC program says (speed, feed and its changes, tilt,
/// length, depth profile, approach, entry and exit) — from which the controllers plan. Not validated
/// (the stage validates it against the tool).
///
/// ```
/// use millcomp_closedloop::groove::groove_program;
/// use millcomp_closedloop::Scenario;
/// let s = Scenario::from_toml_str(
///     include_str!("../../datasets/scenarios/groove_s7_20deg.toml"),
///     "groove_s7_20deg.toml",
/// )
/// .unwrap();
/// let p = groove_program(s.groove.as_ref().unwrap());
/// assert_eq!((p.tilt_deg, p.length_mm, p.upfeed_um), (20.0, 20.0, 10.0));
/// ```
pub fn groove_program(g: &GrooveScenario) -> GrooveProgram {
    let mut p = GrooveProgram::thesis(g.tilt_deg);
    p.speed_rpm = g.speed_rpm;
    p.upfeed_um = g.upfeed_um;
    p.length_mm = g.length_mm;
    p.depth_profile = g.depth.clone();
    p.feed_changes = g.feed_steps.clone();
    p.feed_accel_mm_s2 = g.feed_accel_mm_s2;
    p.exit = g.exit;
    p.approach_mm = g.approach_mm;
    p.entry_length_mm = g.entry_length_mm;
    p
}

/// The truth plant of a groove scenario: thesis plant, the scenario's program and material, the tool's
/// deviations from the catalogue tool (`truth.tool` / `truth.draw_tool`), sensor noise, instrument errors
/// and (when asked) the force scale calibrated to the uncompensated deflection.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] without a `[groove]` table; the physics crate's errors.
pub fn groove_truth(s: &Scenario) -> Result<GrooveConfig, ClosedLoopError> {
    let g = s
        .groove
        .as_ref()
        .ok_or_else(|| invalid("groove", "missing", "a [groove] table"))?;
    let mut truth = GrooveConfig::thesis(g.tilt_deg, g.wearland_um)?;
    truth.force_model.material = Material::by_name(&g.material)?;
    truth.program = groove_program(g);
    match (s.truth.tool, s.truth.draw_tool) {
        (Some(t), _) => t.apply(&mut truth.force_model)?,
        (None, true) => millcomp_sim::tool_variation::ToolVariation::draw(s.seed)
            .apply(&mut truth.force_model)?,
        (None, false) => {}
    }
    truth.force_noise = (s.truth.force_noise_n > 0.0).then_some(NoiseSpec {
        seed: s.seed.wrapping_mul(31).wrapping_add(1),
        sigma: s.truth.force_noise_n,
    });
    truth.gauge_noise = (s.truth.gauge_noise_um > 0.0).then_some(NoiseSpec {
        seed: s.seed.wrapping_mul(31).wrapping_add(2),
        sigma: s.truth.gauge_noise_um,
    });
    truth.instruments = match (s.truth.instruments, s.truth.draw_instruments) {
        (Some(i), _) => i,
        (None, true) => InstrumentErrors::draw(s.seed),
        (None, false) => InstrumentErrors::default(),
    };
    if s.truth.pzt_nonlinear {
        truth.spindle.hysteresis = Some(BoucWenParams::DEFAULT);
        truth.spindle.creep = Some(LogCreepParams::DEFAULT);
    }
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
    Ok(truth)
}

/// Build the truth plant and the controllers' models for a groove scenario (see `closedloop/SCENARIOS.md`).
///
/// The controllers' models come from a bundle: the one `control.bundle` names, or else a commissioning of
/// the truth plant (`[commissioning]`, the scenario's seed). Saved models (`control.spindle_model`,
/// `control.force_model`, `control.force_response_surface`) replace the bundle's piece; the deliberate
/// errors of `[truth]` (`force_errors` / `force_error_max`, `stiffness_error`) are laid on top. Nothing
/// of the truth reaches a controller but what these experiments measured.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] without a `[groove]` table or with two force predictors; bundle and
/// model-file errors naming the file and key; commissioning and physics errors.
pub fn groove_setup(s: &Scenario) -> Result<GrooveSetup, ClosedLoopError> {
    groove_setup_with(s, None)
}

/// [`groove_setup`], the commissioning's bundle taken from `cache` when given (computed once per
/// commissioning key and shared, [`crate::cache`]) — the same setup, value for value.
///
/// # Errors
/// As [`groove_setup`].
pub fn groove_setup_with(
    s: &Scenario,
    cache: Option<&CommissioningCache>,
) -> Result<GrooveSetup, ClosedLoopError> {
    let g = s
        .groove
        .as_ref()
        .ok_or_else(|| invalid("groove", "missing", "a [groove] table"))?;
    let truth = timed(Stage::Scenario, || groove_truth(s))?;
    let nominal_tool = NominalTool::thesis_ball_end(&g.material);
    let (bundle, origin) = match &s.control.bundle {
        Some(path) => (
            std::sync::Arc::new(timed(Stage::CacheRead, || load_bundle(path))?),
            PathBuf::from(path),
        ),
        None => {
            let plant = CommissioningPlant::of_scenario(s, &truth);
            let key = CommissioningKey::new(&plant, &s.commissioning, s.seed.wrapping_add(11));
            let bundle = match cache {
                Some(c) => c.bundle(&key)?,
                None => std::sync::Arc::new(timed(Stage::Commission, || key.commission())?),
            };
            (bundle, PathBuf::from("<commissioned>"))
        }
    };
    bundle.check_material(&g.material, &origin)?;
    let mut from = vec![if s.control.bundle.is_some() {
        format!("bundle {}", origin.display())
    } else {
        "a commissioning of the plant".to_string()
    }];
    let model_spindle = match &s.control.spindle_model {
        Some(path) => {
            from.push(format!("spindle from {path}"));
            IdentifiedSpindle::new(&load_spindle(path)?)?
        }
        None => IdentifiedSpindle::new(&bundle.spindle(&origin, "the controllers")?)?,
    };
    let force_errors = s
        .truth
        .force_errors
        .unwrap_or_else(|| ForceErrors::draw(s.truth.force_error_max, s.seed));
    let model_force = match (&s.control.force_model, &s.control.force_response_surface) {
        (Some(_), Some(_)) => {
            return Err(invalid(
                "control.force_response_surface",
                "given together with control.force_model",
                "one force predictor: either an identified model or a response surface",
            ));
        }
        (None, Some(path)) => {
            from.push(format!("force response surface from {path}"));
            ForcePredictor::ResponseSurface(load_response_surface(path)?)
        }
        (Some(path), None) => {
            from.push(format!("force model from {path}"));
            ForcePredictor::Mechanistic(
                IdentifiedForceModel::new(&load_force_params(path)?, &nominal_tool)?
                    .perturbed(&force_errors.relative())?,
            )
        }
        (None, None) => ForcePredictor::Mechanistic(
            IdentifiedForceModel::new(
                &bundle.force(&origin, "the controllers' force predictor")?,
                &nominal_tool,
            )?
            .perturbed(&force_errors.relative())?,
        ),
    };
    let model_stiffness =
        IdentifiedStiffness::new(&bundle.stiffness(&origin, "the controllers' deflection model")?)?
            .scaled(1.0 + s.truth.stiffness_error)?;
    let model_hysteresis = bundle
        .hysteresis(&origin)?
        .map(|h| IdentifiedHysteresis::new(&h))
        .transpose()?;
    if model_hysteresis.is_some() {
        from.push("stack hysteresis from its sweep in air".into());
    }
    let sensor_noise = match bundle.sensor_noise(&origin, "the MPC's Kalman filter") {
        Ok((noise, source)) => {
            from.push(format!("sensor noise from {source}"));
            Ok(noise)
        }
        Err(e) => Err(e.to_string()),
    };
    Ok(GrooveSetup {
        truth_force_scale: truth.force_model.params.force_scale,
        truth,
        nominal_tool,
        model_force,
        model_stiffness,
        model_spindle,
        model_hysteresis,
        force_errors,
        sensor_noise,
        models_from: from.join("; "),
    })
}

/// The controllers' preview of a groove setup, tabulated every `dx_mm`.
pub fn deflection_plan(setup: &GrooveSetup, dx_mm: f64) -> Result<DeflectionPlan, ClosedLoopError> {
    Ok(DeflectionPlan::new(
        &setup.truth.program,
        &setup.model_force,
        &setup.model_stiffness,
        setup.nominal_tool.radius_um,
        dx_mm,
    )?)
}

/// The groove MPC's settings from a scenario: its `[control]` table, the amplifier limit and the
/// sensors' noise levels the bundle measured (never the truth's).
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] naming `control.bundle` when the bundle has neither a record at rest nor
/// the fits whose residuals stand in for it.
pub fn mpc_settings(
    setup: &GrooveSetup,
    s: &Scenario,
) -> Result<GrooveMpcSettings, ClosedLoopError> {
    let noise = setup
        .sensor_noise
        .as_ref()
        .map_err(|e| ClosedLoopError::InvalidConfig {
            key: "control.bundle".into(),
            value: "a bundle without the sensors' noise levels".into(),
            allowed: e.clone(),
        })?;
    Ok(GrooveMpcSettings {
        dt_s: s.control.dt_s,
        mpc_every: s.control.mpc_every,
        horizon: s.control.horizon,
        slew_v_per_cycle: s.control.slew_v_per_cycle,
        voltage_max_v: setup.model_spindle.plant().voltage_max_v,
        config: s.control.mpc.clone(),
        force_noise_n: noise.force_noise_n,
        gauge_noise_um: noise.gauge_noise_um,
        features: s.control.groove_mpc,
        budget: s.control.cycle_budget(),
    })
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

/// A command below this (V) sits at the amplifier's floor (`Metrics::exit_floor_tip_um`).
const EXIT_FLOOR_V: f64 = 1.0;

/// The exit zone (mm): from [`CHANGE_WINDOW_BEFORE_MM`] before the engagement starts to drop to the edge.
fn exit_window(t: &GrooveConfig) -> Option<(f64, f64)> {
    t.program
        .exit
        .map(|e| (e.x_mm - e.length_mm - CHANGE_WINDOW_BEFORE_MM, e.x_mm))
}

/// What the truth's actuator can do, for the run's references (never for a controller): its linear
/// model at the stage step, its z-reach and sin α.
struct TruthLimits {
    actuator: millcomp_sim::DiscreteLti,
    /// The z-correction the stack reaches at the amplifier's maximum (µm): driven there over 10 ms and
    /// held 40 ms, hysteresis and creep included when the stack has them.
    reach_z_um: f64,
    sin_a: f64,
}

impl TruthLimits {
    fn of(t: &GrooveConfig, dt: f64) -> Result<Self, ClosedLoopError> {
        let sin_a = t.program.tilt_deg.to_radians().sin();
        let mut stack = t.spindle.discretize(dt)?;
        let (ramp, hold) = ((0.01 / dt) as usize, (0.04 / dt) as usize);
        let v_max = t.spindle.voltage_max_v;
        let mut tip = 0.0;
        for k in 0..ramp + hold {
            let v = v_max * ((k + 1) as f64 / ramp as f64).min(1.0);
            tip = stack.step(v).tip_um;
        }
        Ok(Self {
            actuator: t.spindle.to_lti()?.discretize_zoh(dt)?,
            reach_z_um: tip * sin_a,
            sin_a,
        })
    }
}

/// How long the stack is held at the bias before the touch-off's gauge reading (s). Its creep goes as
/// the logarithm of time, so its rate falls as 1/t: after 0.5 s it creeps at a fiftieth of its rate 10 ms
/// after the rise.
const TOUCH_OFF_HOLD_S: f64 = 0.5;

/// Touch the tool off as the scenario says (`control.touch_off_bias`): at rest nothing happens; with a
/// bias the stage's stack is raised and held there and the gauge read (the report's `touch_off`);
/// an `auto` choice is explained in the notes.
fn touch_off(
    s: &Scenario,
    setup: &GrooveSetup,
    plan: &DeflectionPlan,
    stage: &mut GrooveStage,
    notes: &mut Vec<String>,
) -> Result<TouchOff, ClosedLoopError> {
    let bias_v = match s.control.touch_off_bias {
        TouchOffBias::Rest => return Ok(TouchOff::default()),
        TouchOffBias::Volts(v) => {
            let v_max = setup.model_spindle.plant().voltage_max_v;
            if !(0.0..=v_max).contains(&v) {
                return Err(invalid(
                    "control.touch_off_bias.volts",
                    v,
                    format!("0 ..= {v_max} (the amplifier's range)"),
                ));
            }
            v
        }
        TouchOffBias::Auto => {
            let sin_a = setup.truth.program.tilt_deg.to_radians().sin();
            match auto_bias(
                plan,
                sin_a,
                &setup.model_spindle,
                setup.model_hysteresis.as_ref(),
                CapacitanceGauge::rd20().range_um,
                REMANENCE_ALLOWANCE,
            ) {
                None => {
                    notes.push(
                        "touch-off at rest: no hysteresis model, so no remanence to make room for"
                            .into(),
                    );
                    return Ok(TouchOff::default());
                }
                Some(c) => {
                    notes.push(format!(
                        "touch-off bias (auto): {:.0} V for {:.2} um of tip below the touch-off = min({REMANENCE_ALLOWANCE} x the hysteresis model's remanence {:.2} um after the planned peak {:.1} um at {:.0} V, the stroke's slack above it {:.2} um)",
                        c.bias_v, c.tip_um, c.remanence_um, c.peak_tip_um, c.peak_v, c.slack_um
                    ));
                    c.bias_v
                }
            }
        }
    };
    if bias_v <= 0.0 {
        return Ok(TouchOff::default());
    }
    let gauge_um = stage.touch_off_at(bias_v, TOUCH_OFF_HOLD_S)?;
    Ok(TouchOff { bias_v, gauge_um })
}

/// Run a groove scenario with one controller.
///
/// # Errors
/// Those of [`groove_setup`] and [`run_groove_with`].
pub fn run_groove(s: &Scenario, kind: ControllerKind) -> Result<RunOutput, ClosedLoopError> {
    let wall = Instant::now();
    let setup = groove_setup(s)?;
    let plan = timed(Stage::Setup, || deflection_plan(&setup, 0.01))?;
    let mut out = run_groove_with(s, &setup, &plan, kind)?;
    out.report.wall_clock_s = wall.elapsed().as_secs_f64();
    Ok(out)
}

/// Which process changes get their lower bound ([`crate::optimum::excess_lower_bound`], a linear
/// programme each — the costliest reference of a run).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BoundScope {
    /// Every change (`simulate`, `compare`: the report lists each change with its bound).
    #[default]
    EveryChange,
    /// Only the change where the run's excess is largest — the one a batch's `change_bound_um`
    /// reports ([`crate::batch::store::RunMetrics::from_report`]); the others' `bound_um` stay empty.
    LargestExcess,
}

/// What a groove run computes besides its errors and metrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunOptions {
    /// Keep the decimated time trace (`simulate --out`, plots); a batch does not.
    pub trace: bool,
    /// Which changes get their bound.
    pub bounds: BoundScope,
}

impl Default for RunOptions {
    /// The trace and every change's bound, as `simulate` reports them.
    fn default() -> Self {
        Self {
            trace: true,
            bounds: BoundScope::EveryChange,
        }
    }
}

impl RunOptions {
    /// What a batch keeps of a run: its metrics, and the bound of the change where its excess is largest.
    pub const BATCH: RunOptions = RunOptions {
        trace: false,
        bounds: BoundScope::LargestExcess,
    };
}

/// Run one controller on a prepared setup (truth plant and the controllers' models) with the
/// controllers' plan — the run-to-run loop's entry, where each part's models come from the parts before.
/// The trace logs what the machine records (gauge, measured force and its per-revolution peak through
/// the controllers' force chain) beside what only the simulation knows (depth cut, deflection).
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] for `threshold` (a thin-wall controller); controller construction
/// and physics errors.
pub fn run_groove_with(
    s: &Scenario,
    setup: &GrooveSetup,
    plan: &DeflectionPlan,
    kind: ControllerKind,
) -> Result<RunOutput, ClosedLoopError> {
    run_groove_opts(s, setup, plan, kind, RunOptions::default())
}

/// [`run_groove_with`], computing what `opts` asks for: the same errors, metrics and bounds (of the
/// changes it bounds) value for value.
///
/// # Errors
/// As [`run_groove_with`].
pub fn run_groove_opts(
    s: &Scenario,
    setup: &GrooveSetup,
    plan: &DeflectionPlan,
    kind: ControllerKind,
    opts: RunOptions,
) -> Result<RunOutput, ClosedLoopError> {
    let wall = Instant::now();
    let t = &setup.truth;
    let dt = s.control.dt_s;
    // the amplifier's rated maximum (a catalogue value, carried by the identified spindle's defaults)
    let v_max = setup.model_spindle.plant().voltage_max_v;
    let mut notes = vec![format!("controllers' models from {}", setup.models_from)];
    let mut ctl: Box<dyn GrooveController> = match kind {
        ControllerKind::None => Box::new(NoneController::default()),
        ControllerKind::OpenLoop => {
            notes.push(
                "open-loop pre-shift applied through the PZT (sim's stage has no path table yet)"
                    .into(),
            );
            Box::new(
                OpenLoopController::new(plan.clone(), &t.program, &setup.model_spindle, v_max)
                    .with_spindle(t.program.speed_rpm, setup.nominal_tool.flutes),
            )
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
            Box::new(PidController::new(
                gains,
                aw,
                &t.program,
                &setup.model_spindle,
                &setup.model_stiffness,
                v_max,
                dt,
            )?)
        }
        ControllerKind::PidTuned
        | ControllerKind::PidFeedforward
        | ControllerKind::PidFeedforwardRead => {
            let c = TunedPidController::new(
                &t.program,
                &setup.model_spindle,
                &setup.model_stiffness,
                v_max,
                dt,
            )?;
            let d = c.design();
            notes.push(format!(
                "pid-tuned: kp {:.3} V/um, ki {:.1} V/(um s) (Ms {:.2}, crossover {:.0} rad/s) on the controllers' spindle model",
                d.kp_v_per_um, d.ki_v_per_um_s, d.ms, d.crossover_rad_s
            ));
            if kind != ControllerKind::PidTuned {
                let sigma = mpc_settings(setup, s)?.force_noise_n;
                let ff = FeedforwardPidController::new(
                    c,
                    plan.clone(),
                    &t.program,
                    &setup.model_spindle,
                    v_max,
                    setup.nominal_tool.flutes,
                    sigma,
                );
                notes.push(format!(
                    "pid-ff: pid-tuned's PI plus the plan fed forward {:.2} ms ahead (the spindle model's mean delay)",
                    1e3 * ff.lead_s()
                ));
                let ff = if kind == ControllerKind::PidFeedforwardRead {
                    notes.push(format!(
                        "pid-ff-read: the peak's noise bias taken off (σ {sigma:.3} N) and the ramp's rubbing start known, as the MPC reads"
                    ));
                    ff.with_read_features(t.program.speed_rpm, sigma)?
                } else {
                    ff
                };
                Box::new(ff)
            } else {
                Box::new(c)
            }
        }
        ControllerKind::Threshold => {
            return Err(ClosedLoopError::InvalidConfig {
                key: "controller".into(),
                value: "threshold".into(),
                allowed: "the thin-wall stage (threshold is the 004 thin-wall baseline)".into(),
            });
        }
        ControllerKind::Reactive | ControllerKind::Proactive => {
            return Err(ClosedLoopError::InvalidConfig {
                key: "controller".into(),
                value: kind.name().into(),
                allowed: "the nc_axis stage (003's NC compensations)".into(),
            });
        }
        ControllerKind::Mpc | ControllerKind::MpcNoPreview => {
            let c = MpcGrooveController::new(
                plan.clone(),
                &t.program,
                &setup.model_spindle,
                &setup.model_stiffness,
                setup.nominal_tool.flutes,
                &mpc_settings(setup, s)?,
            )?;
            if kind == ControllerKind::MpcNoPreview {
                notes.push(
                    "mpc-nopreview: the planned deflection of now held over the horizon (no preview)"
                        .into(),
                );
                Box::new(c.without_preview())
            } else {
                Box::new(c)
            }
        }
    };
    // every controller built from the bundle drives the stack through the inverse of its hysteresis
    // model; the published PID and `none` do not
    let compensated = !matches!(
        kind,
        ControllerKind::None
            | ControllerKind::Pid
            | ControllerKind::PidAntiWindup
            | ControllerKind::PidDesign
    );
    if let (true, true, Some(h)) = (
        s.control.compensate_hysteresis,
        compensated,
        &setup.model_hysteresis,
    ) {
        notes.push("the stack driven through the inverse of its identified hysteresis".into());
        ctl = Box::new(Compensated::new(
            ctl,
            HysteresisCompensator::new(h, &setup.model_spindle),
        ));
    }
    let mut pending_failures = SolverFailures::new(s);
    // process changes inside the groove: depth steps / plunges, feed changes, the exit
    let windows = change_windows(t);
    let exit_window = exit_window(t);
    let mut change_peak: f64 = 0.0;
    let mut exit_overcut: f64 = 0.0;
    // the tip while the command sits at the amplifier's floor during the engagement drop
    let drop_from = t.program.exit.map(|e| e.x_mm - e.length_mm);
    let mut floor_tip = f64::INFINITY;
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
    let touch_off = touch_off(s, setup, plan, &mut stage, &mut notes)?;
    ctl.touched_off(touch_off);
    let mut last: Option<GrooveStepOutput> = None;
    let mut stuck = None;
    let mut errors = Vec::with_capacity((t.duration_s() / dt) as usize + 2);
    let mut error_x = Vec::with_capacity(errors.capacity());
    let (mut approach_x, mut approach_errors) = (Vec::new(), Vec::new());
    let mut deflections = Vec::with_capacity(errors.capacity());
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
        "force_peak_n",
    ]);
    let mut force_log = ForcePeakChain::new(t.program.speed_rpm, dt)?;
    let decimate = 20usize;
    let mut k = 0usize;
    // the profile: everything before the loop is the run's set-up; the truth's steps are timed every
    // `TRUTH_SAMPLE`th step (a prime: no aliasing with the MPC's cycle)
    crate::profile::add(Stage::Setup, wall.elapsed().as_secs_f64());
    crate::profile::add(Stage::Solve, millcomp_mpc::stats::take_qp_solve_s());
    let loop_start = Instant::now();
    let mut truth_sampled_s = 0.0;
    loop {
        let obs = last
            .as_ref()
            .map(|o| groove_measurement(o, &s.faults, &mut stuck));
        let t_now = k as f64 * dt;
        pending_failures.inject_due(t_now, |n| ctl.inject_solver_failures(n));
        let v = crate::realtime::cycle(|| ctl.command(obs.as_ref(), t_now));
        if !v.is_finite() {
            finite = false;
        }
        if !(0.0..=v_max).contains(&v) {
            in_limits = false;
        }
        let force_peak = force_log.step(obs.map(|x| x.force_meas_n).unwrap_or(0.0));
        let o = if k % TRUTH_SAMPLE == 0 {
            let t0 = Instant::now();
            let o = stage.step(v);
            truth_sampled_s += t0.elapsed().as_secs_f64();
            o
        } else {
            stage.step(v)
        };
        // the approach in air: where the tool tip is against the programmed depth before it enters
        // (the entry's level before, `changes::level_before`)
        if o.engagement == 0.0 && o.x_mm < 0.0 {
            approach_x.push(o.x_mm);
            approach_errors.push(o.depth_cut_um - o.depth_cmd_um);
        }
        // the groove exists only where the tool is engaged (before the workpiece edge)
        if o.engagement > 0.0 {
            let err = o.depth_cut_um - o.depth_cmd_um;
            errors.push(err);
            error_x.push(o.x_mm);
            deflections.push(o.deflection_um);
            if windows.iter().any(|(a, b)| o.x_mm >= *a && o.x_mm <= *b) {
                change_peak = change_peak.max(err.abs());
            }
            if let Some((a, b)) = exit_window
                && o.x_mm >= a
                && o.x_mm <= b
            {
                exit_overcut = exit_overcut.max(err);
                if drop_from.is_some_and(|d| o.x_mm >= d) && v < EXIT_FLOOR_V {
                    floor_tip = floor_tip.min(o.pzt_tip_um);
                }
            }
        }
        travel += (o.pzt_tip_um - prev_tip).abs();
        prev_tip = o.pzt_tip_um;
        if opts.trace && k % decimate == 0 {
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
                force_peak,
            ]);
        }
        k += 1;
        let done = o.done;
        last = Some(o);
        if done {
            break;
        }
    }
    {
        let loop_s = loop_start.elapsed().as_secs_f64();
        let solve_s = millcomp_mpc::stats::take_qp_solve_s();
        let truth_s = (TRUTH_SAMPLE as f64 * truth_sampled_s).min(loop_s - solve_s);
        crate::profile::add(Stage::Solve, solve_s);
        crate::profile::add(Stage::Truth, truth_s.max(0.0));
        crate::profile::add(Stage::Controller, (loop_s - solve_s - truth_s).max(0.0));
    }
    let after_loop = Instant::now();
    let kz_model = setup
        .model_stiffness
        .stiffness()
        .z_stiffness_n_per_um(t.program.tilt_deg)?;
    let kz_truth = t.stiffness.z_stiffness_n_per_um(t.program.tilt_deg)?;
    let mut changes = excess(&program_changes(&t.program), &error_x, &errors);
    for c in &mut changes {
        if c.kind == ChangeKind::Entry {
            c.level_before_um = level_before(c.kind, c.x_mm, &approach_x, &approach_errors);
        }
    }
    // the change a batch reports the bound of: the largest excess (the last of equals, as `max_by`)
    let largest = changes
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.excess_um.total_cmp(&b.1.excess_um))
        .map(|(i, _)| i);
    let bounds_start = Instant::now();
    let limits = TruthLimits::of(t, dt)?;
    for (i, c) in changes.iter_mut().enumerate() {
        if opts.bounds == BoundScope::LargestExcess && Some(i) != largest {
            continue;
        }
        let w = bound_window(c.kind, c.x_mm, &error_x);
        c.bound_um = excess_lower_bound(
            &deflections[w],
            &limits.actuator,
            t.spindle.voltage_max_v,
            limits.sin_a,
        );
    }
    let (defl_min, defl_max) = deflections
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| {
            (a.min(d), b.max(d))
        });
    // the controllers' deflection per measured newton over the truth's deflection per newton
    let knowledge = kz_truth / kz_model * t.instruments.force_gain;
    let stroke_bound_um =
        (defl_max >= defl_min).then(|| (defl_max - defl_min - limits.reach_z_um).max(0.0));
    let optimum_pp_um = (!deflections.is_empty())
        .then(|| certainty_equivalent_pp(&deflections, limits.reach_z_um, knowledge));
    let bounds_s = bounds_start.elapsed().as_secs_f64();
    crate::profile::add(Stage::Bounds, bounds_s);
    let report = RunReport {
        scenario: s.name.clone(),
        stage: "groove".into(),
        controller: kind.name().into(),
        metrics: Metrics {
            exit_overcut_um: exit_window.map(|_| exit_overcut),
            exit_floor_tip_um: floor_tip.is_finite().then_some(floor_tip),
            stroke_bound_um,
            optimum_pp_um,
            change_excess_um: changes.iter().map(|c| c.excess_um).reduce(f64::max),
            ..Metrics::from_errors(&errors, travel)
        },
        solver: ctl.solver_stats(),
        walls: None,
        commands_finite: finite,
        commands_in_limits: in_limits,
        process_change_peak_um: (!windows.is_empty()).then_some(change_peak),
        changes,
        model: ModelSummary {
            kz_model_n_per_um: kz_model,
            kz_truth_n_per_um: kz_truth,
            stiffness_error_rel: kz_model / kz_truth - 1.0,
            force_error_max_rel: setup.force_errors.max_abs(),
            truth_force_scale: setup.truth_force_scale,
        },
        touch_off: (touch_off.bias_v > 0.0).then_some(touch_off),
        nc_axis: None,
        simulated_s: k as f64 * dt,
        realtime: false,
        wall_clock_s: wall.elapsed().as_secs_f64(),
        notes,
    };
    crate::profile::add(
        Stage::Metrics,
        (after_loop.elapsed().as_secs_f64() - bounds_s).max(0.0),
    );
    Ok(RunOutput { report, trace })
}

/// Every how many stage steps the profile times the truth's step (a prime, so no controller's cycle
/// aliases with it).
const TRUTH_SAMPLE: usize = 7;

/// A groove scenario prepared once for the controllers that run on it: its truth plant, the
/// controllers' models (one commissioning, or its bundle from a cache) and their preview — what
/// [`run_groove`] builds for every run, shared.
#[derive(Debug, Clone)]
pub struct PreparedGroove {
    /// The scenario (validated).
    pub scenario: Scenario,
    /// The truth plant and the controllers' models.
    pub setup: GrooveSetup,
    /// The controllers' preview.
    pub plan: DeflectionPlan,
}

impl PreparedGroove {
    /// Validates `scenario` and prepares it, the commissioning's bundle from `cache` when given.
    ///
    /// # Errors
    /// The scenario's validation errors and those of [`groove_setup`] and [`deflection_plan`].
    pub fn new(
        scenario: Scenario,
        cache: Option<&CommissioningCache>,
    ) -> Result<Self, ClosedLoopError> {
        scenario.validate()?;
        let setup = groove_setup_with(&scenario, cache)?;
        let plan = timed(Stage::Setup, || deflection_plan(&setup, 0.01))?;
        Ok(Self {
            scenario,
            setup,
            plan,
        })
    }

    /// One controller's run: [`crate::run_scenario_with_trace`]'s report, value for value, with what
    /// `opts` asks for (the real-time scope as the scenario says).
    ///
    /// # Errors
    /// As [`run_groove_with`].
    pub fn run(
        &self,
        kind: ControllerKind,
        opts: RunOptions,
    ) -> Result<RunOutput, ClosedLoopError> {
        let wall = Instant::now();
        let rt = crate::realtime::Scope::enter(self.scenario.control.realtime);
        let mut out = run_groove_opts(&self.scenario, &self.setup, &self.plan, kind, opts)?;
        out.report.realtime = rt.active();
        out.report.wall_clock_s = wall.elapsed().as_secs_f64();
        Ok(out)
    }
}
