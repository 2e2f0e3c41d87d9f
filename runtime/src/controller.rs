//! The controller a real loop calls: built once from a commissioned bundle and a program, then one
//! [`Controller::step`] per control period.

use std::path::{Path, PathBuf};

use millcomp_models::{ModelBundle, ModelFile, SensorNoise};
use millcomp_mpc::groove::{
    Compensated, DeflectionPlan, FeedforwardPidController, GrooveController, GrooveMeasurement,
    GrooveMpcSettings, MpcGrooveController, NoneController, OpenLoopController, PidController,
    TouchOff, TunedPidController,
};
use millcomp_mpc::identified::{
    HysteresisCompensator, IdentifiedForceModel, IdentifiedHysteresis, IdentifiedSpindle,
    IdentifiedStiffness, NominalTool,
};
use millcomp_mpc::pid::{AntiWindup, PidGains};
use millcomp_mpc::predictor::ForcePredictor;
use millcomp_mpc::{MpcError, SolverStats};
use millcomp_sim::feed::FeedProfile;
use millcomp_sim::groove::GrooveProgram;

use crate::error::RuntimeError;
use crate::kind::ControllerKind;
use crate::program::{ControllerSettings, Program};

/// The spacing of the controllers' plan along the groove (mm): the table the preview, the open loop
/// and the feedforward read (`closedloop`'s runs use the same).
pub const PLAN_DX_MM: f64 = 0.01;

/// What the machine gives the controller at the start of a cycle: the NC's position and the sensors'
/// last readings. A NaN means "no reading in this cycle".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// The NC's position along the groove when the sensors were read (mm; NaN: not available, not
    /// checked).
    pub x_mm: f64,
    /// The measured workpiece z-force (N; NaN: no reading).
    pub force_n: f64,
    /// The capacitance gauge's reading of the tool tip (µm; NaN: no reading).
    pub gauge_um: f64,
}

impl Measurement {
    /// No reading at all (the first cycle of a cut, before the sensors have sampled).
    pub const NONE: Measurement = Measurement {
        x_mm: f64::NAN,
        force_n: f64::NAN,
        gauge_um: f64::NAN,
    };
}

/// The bits of [`Command::flags`].
pub mod flags {
    /// The MPC planned in this cycle (it solves every `mpc_every` cycles and holds its command in
    /// between).
    pub const PLANNED: u32 = 1;
    /// The MPC's plan was not accepted (the solver did not converge within its budget): the fallback
    /// went out — the last plan shifted, then the held command.
    pub const FALLBACK: u32 = 1 << 1;
    /// The plan was not ready within the cycle's wall-clock budget (set only under the wall-clock
    /// budget, which acts on it; under the iteration budget the clock is not part of the command, so
    /// a replay gives the same commands on any machine — its overruns are still counted in
    /// [`super::Controller::solver_stats`]).
    pub const DEADLINE_MISS: u32 = 1 << 2;
    /// No reading yet: neither channel has read since the start (or the last reset).
    pub const NO_READING: u32 = 1 << 3;
    /// A channel had no reading in this cycle; its last reading was used.
    pub const READING_HELD: u32 = 1 << 4;
    /// The NC's position is further than `position_tolerance_mm` from where the program puts the tool
    /// at the sample's time: the preview no longer matches the cut (a feed override, a hold).
    pub const POSITION_MISMATCH: u32 = 1 << 5;
    /// The controller's command was not finite; the last command was held (never seen in the tests:
    /// the last line of defence).
    pub const COMMAND_HELD: u32 = 1 << 6;
}

/// What the controller sends back in a cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// The voltage for the PZT amplifier (V): finite, within 0 ..= the amplifier's maximum.
    pub voltage_v: f64,
    /// What happened in the cycle: the bits of [`flags`].
    pub flags: u32,
    /// The interior-point iterations of the cycle's QP (0 when none was solved).
    pub iterations: u32,
}

impl Command {
    /// Whether `flag` (one of [`flags`]) is set.
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag != 0
    }
}

/// How many cycles had each event since the start (or the last reset).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct CycleCounts {
    /// Cycles stepped.
    pub cycles: u64,
    /// Cycles in which the MPC planned.
    pub planned: u64,
    /// Cycles that emitted the MPC's fallback.
    pub fallbacks: u64,
    /// Cycles whose plan missed the wall-clock budget.
    pub deadline_misses: u64,
    /// Cycles before the first reading.
    pub no_reading: u64,
    /// Cycles in which a channel's last reading stood in.
    pub readings_held: u64,
    /// Cycles whose NC position did not match the program's.
    pub position_mismatches: u64,
    /// Cycles whose command was held (not finite).
    pub commands_held: u64,
}

/// The runtime's own state between cycles (each controller's filters, integrators, estimators and
/// plans are its own, reset with it): the cycle index, the channels' last readings and the last
/// command.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CycleState {
    cycle: u64,
    force_n: f64,
    gauge_um: f64,
    last_v: f64,
    counts: CycleCounts,
}

impl CycleState {
    fn new(touch_off: TouchOff) -> Self {
        Self {
            cycle: 0,
            force_n: f64::NAN,
            gauge_um: f64::NAN,
            last_v: touch_off.bias_v,
            counts: CycleCounts::default(),
        }
    }
}

/// The controllers' models: what a commissioning identified (a bundle), on the catalogue tool.
#[derive(Debug, Clone)]
pub struct Models {
    /// The catalogue tool the force model starts from (radius, flutes).
    pub tool: NominalTool,
    /// The PZT spindle.
    pub spindle: IdentifiedSpindle,
    /// The tool/spindle stiffness.
    pub stiffness: IdentifiedStiffness,
    /// The force predictor of the plan.
    pub force: ForcePredictor,
    /// The stack's hysteresis (a bundle from a commissioning has one).
    pub hysteresis: Option<IdentifiedHysteresis>,
    /// The sensors' noise levels the MPC's Kalman filter and the force-peak readers assume, or why the
    /// bundle has none.
    pub sensor_noise: Result<SensorNoise, String>,
}

impl Models {
    /// The models of `bundle` (read from `origin`, which errors name) for `material` (the catalogue
    /// tool's).
    ///
    /// # Errors
    /// [`RuntimeError::Model`] naming the file and the key of a model the bundle lacks or holds out of
    /// range; [`RuntimeError::Build`] when the controllers refuse a model.
    pub fn from_bundle(
        bundle: &ModelBundle,
        origin: &Path,
        material: &str,
    ) -> Result<Self, RuntimeError> {
        let build = |source: MpcError| RuntimeError::Build {
            controller: "the controllers' models",
            bundle: origin.to_path_buf(),
            program: PathBuf::from("<no program>"),
            source: Box::new(source),
        };
        let tool = NominalTool::thesis_ball_end(material);
        let spindle =
            IdentifiedSpindle::new(&bundle.spindle(origin, "the controllers")?).map_err(build)?;
        let force = ForcePredictor::Mechanistic(
            IdentifiedForceModel::new(
                &bundle.force(origin, "the controllers' force predictor")?,
                &tool,
            )
            .map_err(build)?,
        );
        let stiffness = IdentifiedStiffness::new(
            &bundle.stiffness(origin, "the controllers' deflection model")?,
        )
        .map_err(build)?;
        let hysteresis = bundle
            .hysteresis(origin)?
            .map(|h| IdentifiedHysteresis::new(&h))
            .transpose()
            .map_err(build)?;
        let sensor_noise = bundle
            .sensor_noise(origin, "the MPC's Kalman filter")
            .map(|(n, _)| n)
            .map_err(|e| e.to_string());
        Ok(Self {
            tool,
            spindle,
            stiffness,
            force,
            hysteresis,
            sensor_noise,
        })
    }

    /// The controllers' plan of `program`: the planned deflection along the groove, every
    /// [`PLAN_DX_MM`].
    ///
    /// # Errors
    /// The predictor's and the program's errors.
    pub fn plan(&self, program: &GrooveProgram) -> Result<DeflectionPlan, MpcError> {
        DeflectionPlan::new(
            program,
            &self.force,
            &self.stiffness,
            self.tool.radius_um,
            PLAN_DX_MM,
        )
    }
}

/// Where a controller's inputs came from, for its errors.
#[derive(Debug, Clone)]
pub struct Origins {
    /// The bundle's file (or a description).
    pub bundle: PathBuf,
    /// The program's file (or a description).
    pub program: PathBuf,
}

impl Default for Origins {
    fn default() -> Self {
        Self {
            bundle: PathBuf::from("<bundle>"),
            program: PathBuf::from("<program>"),
        }
    }
}

/// What a controller is built from: the models, the program and the plan computed from them (built
/// once and shared by every controller of a program).
#[derive(Debug, Clone, Copy)]
pub struct Parts<'a> {
    /// The controllers' models.
    pub models: &'a Models,
    /// The NC program.
    pub program: &'a GrooveProgram,
    /// The plan of the program on the models ([`Models::plan`]).
    pub plan: &'a DeflectionPlan,
    /// Where they came from.
    pub origins: &'a Origins,
}

/// A groove controller ready for a real-time loop: built once from a commissioned bundle and a
/// program ([`Controller::from_files`], [`Controller::from_bundle`]), then stepped once per control
/// period ([`Controller::step`]).
///
/// `step` allocates nothing, takes no lock and makes no system call (the MPC's cycle reads the
/// monotonic clock for its budget and its statistics — on Linux through the vDSO). Its state between
/// cycles is the controller's filters, integrators, estimators and last plan, and the runtime's cycle
/// index and last readings; [`Controller::reset`] returns all of it to the state right after
/// construction (and the touch-off). One controller is driven from one thread.
///
/// # Examples
/// ```
/// use millcomp_runtime::{Controller, ControllerKind, Measurement, Program};
/// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
/// # let bundle = std::path::PathBuf::from(format!("{dir}bundle_s7.toml"));
/// # let program_path = std::path::PathBuf::from(format!("{dir}ramp_20deg.toml"));
/// // a commissioned bundle and the program of the cut
/// let mut ctl = Controller::from_files(&bundle, &program_path).unwrap();
/// assert_eq!(ctl.kind(), ControllerKind::Mpc);
/// assert_eq!(ctl.period_s(), 5e-5);
/// // the first cycle has no reading yet; then the sensors' readings come in, one per cycle
/// let c = ctl.step(&Measurement::NONE);
/// assert!(c.has(millcomp_runtime::flags::NO_READING) && c.has(millcomp_runtime::flags::PLANNED));
/// for k in 1..2000 {
///     let x = 1.667e-3 * (k as f64 - 1.0) * 5e-5 * 1e3 / 1e3; // the NC's position (mm)
///     let c = ctl.step(&Measurement { x_mm: x, force_n: 0.0, gauge_um: 0.0 });
///     assert!(c.voltage_v.is_finite() && (0.0..=1000.0).contains(&c.voltage_v));
/// }
/// assert_eq!(ctl.counts().cycles, 2000);
/// ```
pub struct Controller {
    kind: ControllerKind,
    inner: Box<dyn GrooveController + Send>,
    dt_s: f64,
    feed: FeedProfile,
    position_tolerance_mm: f64,
    touch_off: TouchOff,
    /// The amplifier's top (V, the bundle's spindle): a touch-off voltage lies in 0 ..= it.
    voltage_max_v: f64,
    notes: Vec<String>,
    state: CycleState,
    /// The budget is the wall clock (deadline misses are acted on and flagged).
    wall_clock: bool,
}

/// For a touch-off voltage outside the amplifier's 0 ..= `v_max` (NaN included), what is allowed, as
/// an error names it; `None` inside. The program's touch-off at construction and a later
/// [`Controller::touched_off`] are checked by it alike.
fn bias_outside(bias_v: f64, v_max: f64) -> Option<String> {
    (!(0.0..=v_max).contains(&bias_v))
        .then(|| format!("0 ..= {v_max} V, the amplifier's range (the bundle's spindle)"))
}

impl std::fmt::Debug for Controller {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Controller")
            .field("kind", &self.kind)
            .field("period_s", &self.dt_s)
            .field("cycle", &self.state.cycle)
            .finish()
    }
}

impl Controller {
    /// The controller the program file names (`[controller] kind`), built from the bundle file (a model
    /// file of kind `bundle`, `millcomp commission --out`) and the program file (`docs/runtime.md`).
    ///
    /// # Errors
    /// Every error names the file and the key: [`RuntimeError::Io`], [`RuntimeError::Model`] for the
    /// bundle, [`RuntimeError::ProgramToml`] / [`RuntimeError::InvalidValue`] for the program,
    /// [`RuntimeError::Build`] when the controller refuses its models or settings.
    pub fn from_files(bundle_path: &Path, program_path: &Path) -> Result<Self, RuntimeError> {
        let program = Program::load(program_path)?;
        let bundle = load_bundle(bundle_path)?;
        Self::from_bundle_at(
            &bundle,
            &program,
            &Origins {
                bundle: bundle_path.to_path_buf(),
                program: program_path.to_path_buf(),
            },
        )
    }

    /// The controller `program` names, built from `bundle` (in memory; errors call it `<bundle>`).
    ///
    /// # Errors
    /// As [`Self::from_files`].
    pub fn from_bundle(bundle: &ModelBundle, program: &Program) -> Result<Self, RuntimeError> {
        Self::from_bundle_at(bundle, program, &Origins::default())
    }

    /// [`Self::from_bundle`] with the inputs' origins named in errors.
    ///
    /// # Errors
    /// As [`Self::from_files`].
    pub fn from_bundle_at(
        bundle: &ModelBundle,
        program: &Program,
        origins: &Origins,
    ) -> Result<Self, RuntimeError> {
        program.validate(&origins.program)?;
        let material = match &program.program.material {
            Some(m) => {
                bundle.check_material(m, &origins.bundle)?;
                m.clone()
            }
            None => bundle.material.clone(),
        };
        let models = Models::from_bundle(bundle, &origins.bundle, &material)?;
        let nc = program.program.groove_program();
        let plan = models.plan(&nc).map_err(|source| RuntimeError::Build {
            controller: program.controller.kind.name(),
            bundle: origins.bundle.clone(),
            program: origins.program.clone(),
            source: Box::new(source),
        })?;
        Self::from_parts(
            Parts {
                models: &models,
                program: &nc,
                plan: &plan,
                origins,
            },
            &program.controller,
        )
    }

    /// The controller `settings` name from prepared parts (a harness that runs several controllers on
    /// one program builds the plan once).
    ///
    /// # Errors
    /// [`RuntimeError::Build`] when the controller refuses its models or settings;
    /// [`RuntimeError::InvalidValue`] naming `model.sensor_noise` when the MPC or a feedforward PID
    /// needs the sensors' noise levels and the bundle has none, or `controller.touch_off.bias_v` (and
    /// the program) for a touch-off voltage outside the amplifier's 0 ..= `voltage_max_v`.
    pub fn from_parts(
        parts: Parts<'_>,
        settings: &ControllerSettings,
    ) -> Result<Self, RuntimeError> {
        let kind = settings.kind;
        // the program checks the touch-off voltage is >= 0; its top is the bundle's amplifier's
        let v_max = parts.models.spindle.plant().voltage_max_v;
        let bias_v = settings.touch_off.bias_v;
        if let Some(allowed) = bias_outside(bias_v, v_max) {
            return Err(RuntimeError::InvalidValue {
                path: parts.origins.program.clone(),
                key: "controller.touch_off.bias_v".into(),
                value: bias_v.to_string(),
                allowed,
            });
        }
        let (inner, notes) = build(kind, parts, settings).map_err(|e| match e {
            Built::Mpc(source) => RuntimeError::Build {
                controller: kind.name(),
                bundle: parts.origins.bundle.clone(),
                program: parts.origins.program.clone(),
                source: Box::new(source),
            },
            Built::Runtime(e) => e,
        })?;
        let feed = parts
            .program
            .feed_profile()
            .map_err(|e| RuntimeError::Build {
                controller: kind.name(),
                bundle: parts.origins.bundle.clone(),
                program: parts.origins.program.clone(),
                source: Box::new(MpcError::Sim(e)),
            })?;
        let mut c = Self {
            kind,
            inner,
            dt_s: settings.dt_s,
            feed,
            position_tolerance_mm: settings.position_tolerance_mm,
            touch_off: TouchOff::default(),
            voltage_max_v: v_max,
            notes,
            state: CycleState::new(TouchOff::default()),
            wall_clock: settings.budget.cycle_budget().enforced,
        };
        c.set_touch_off(settings.touch_off);
        Ok(c)
    }

    /// The tool was touched off at `at` (the stack's voltage and the gauge's reading there); called
    /// before the first step — the program's `controller.touch_off` does it at construction. Kept
    /// across [`Self::reset`]. Until the first reading the controller holds this voltage, so it is
    /// checked as the program's is.
    ///
    /// # Errors
    /// [`RuntimeError::InvalidValue`] naming `touch_off.bias_v` for a voltage outside the amplifier's
    /// 0 ..= `voltage_max_v` (NaN included), or `touch_off.gauge_um` for a reading that is not finite;
    /// the controller then keeps the touch-off it had.
    pub fn touched_off(&mut self, at: TouchOff) -> Result<(), RuntimeError> {
        let invalid = |key: &str, value: f64, allowed: String| RuntimeError::InvalidValue {
            path: PathBuf::from("<touched_off>"),
            key: key.into(),
            value: value.to_string(),
            allowed,
        };
        if let Some(allowed) = bias_outside(at.bias_v, self.voltage_max_v) {
            return Err(invalid("touch_off.bias_v", at.bias_v, allowed));
        }
        if !at.gauge_um.is_finite() {
            return Err(invalid(
                "touch_off.gauge_um",
                at.gauge_um,
                "a finite gauge reading".into(),
            ));
        }
        self.set_touch_off(at);
        Ok(())
    }

    fn set_touch_off(&mut self, at: TouchOff) {
        self.touch_off = at;
        self.inner.touched_off(at);
        self.state.last_v = at.bias_v;
    }

    /// One control cycle: the measurement in, the command out. Never fails and never panics on the
    /// measurement's values: a NaN reading holds the channel's last reading (the MPC leaves a channel
    /// out of its estimate after 2 ms (force) or 1 ms (gauge) of an unchanged reading), no reading yet
    /// is the first cycle's "nothing measured"; what happened is in [`Command::flags`].
    pub fn step(&mut self, m: &Measurement) -> Command {
        let s = &mut self.state;
        let t_s = s.cycle as f64 * self.dt_s;
        let mut flags = 0;
        let (force_ok, gauge_ok) = (m.force_n.is_finite(), m.gauge_um.is_finite());
        if force_ok {
            s.force_n = m.force_n;
        }
        if gauge_ok {
            s.gauge_um = m.gauge_um;
        }
        let last = if s.force_n.is_finite() && s.gauge_um.is_finite() {
            if !(force_ok && gauge_ok) {
                flags |= flags::READING_HELD;
            }
            Some(GrooveMeasurement {
                force_meas_n: s.force_n,
                gauge_um: s.gauge_um,
            })
        } else {
            flags |= flags::NO_READING;
            None
        };
        // the readings were sampled at the end of the last cycle
        if m.x_mm.is_finite()
            && (m.x_mm - self.feed.x_at(t_s - self.dt_s)).abs() > self.position_tolerance_mm
        {
            flags |= flags::POSITION_MISMATCH;
        }
        let v = self.inner.command(last.as_ref(), t_s);
        let s = &mut self.state;
        let v = if v.is_finite() {
            v
        } else {
            flags |= flags::COMMAND_HELD;
            s.last_v
        };
        let mut iterations = 0;
        if let Some(c) = self.inner.last_cycle() {
            flags |= flags::PLANNED;
            if c.fallback {
                flags |= flags::FALLBACK;
            }
            if c.deadline_miss && self.wall_clock {
                flags |= flags::DEADLINE_MISS;
            }
            iterations = c.iterations;
        }
        s.last_v = v;
        s.cycle += 1;
        let n = &mut s.counts;
        n.cycles += 1;
        let count = |bit: u32| u64::from(flags & bit != 0);
        n.planned += count(flags::PLANNED);
        n.fallbacks += count(flags::FALLBACK);
        n.deadline_misses += count(flags::DEADLINE_MISS);
        n.no_reading += count(flags::NO_READING);
        n.readings_held += count(flags::READING_HELD);
        n.position_mismatches += count(flags::POSITION_MISMATCH);
        n.commands_held += count(flags::COMMAND_HELD);
        Command {
            voltage_v: v,
            flags,
            iterations,
        }
    }

    /// Back to the state right after construction and the touch-off: every filter, integrator,
    /// estimator, plan scale, spindle-phase estimate and fallback plan, the cycle index, the last
    /// readings and the counts. What the construction computed stays (models, plan, gains, the QP's
    /// fixed data). Not for the control loop (it may allocate): between cuts.
    ///
    /// # Errors
    /// [`RuntimeError::Build`] if the MPC's solver refuses its settings back after a fault injection.
    pub fn reset(&mut self) -> Result<(), RuntimeError> {
        self.inner.reset().map_err(|source| RuntimeError::Build {
            controller: self.kind.name(),
            bundle: PathBuf::from("<reset>"),
            program: PathBuf::from("<reset>"),
            source: Box::new(source),
        })?;
        self.inner.touched_off(self.touch_off);
        self.state = CycleState::new(self.touch_off);
        Ok(())
    }

    /// Make the next `cycles` QP solves fail (Clarabel's iteration cap set to 1): fault injection for
    /// tests and a harness. A no-op for controllers without a QP.
    pub fn inject_solver_failures(&mut self, cycles: usize) {
        self.inner.inject_solver_failures(cycles);
    }

    /// The controller's kind.
    pub fn kind(&self) -> ControllerKind {
        self.kind
    }

    /// The control period (s): `step` is called once per period.
    pub fn period_s(&self) -> f64 {
        self.dt_s
    }

    /// The index of the next cycle (the cycles stepped since the start or the last reset).
    pub fn cycle(&self) -> u64 {
        self.state.cycle
    }

    /// How many cycles had each event.
    pub fn counts(&self) -> CycleCounts {
        self.state.counts
    }

    /// The touch-off the controller starts from.
    pub fn touch_off(&self) -> TouchOff {
        self.touch_off
    }

    /// The QP solver's statistics (MPC only): solves, the cycle time's median, p99 and maximum,
    /// fallbacks, the budget and its misses.
    pub fn solver_stats(&self) -> Option<SolverStats> {
        self.inner.solver_stats()
    }

    /// What the construction chose, one line each (the PI's design, the feedforward's lead, the
    /// hysteresis compensation): what a run's notes say.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }
}

/// A bundle file (kind `bundle`).
///
/// # Errors
/// [`RuntimeError::Model`] naming the file (unreadable, not a model file, another kind or version).
pub fn load_bundle(path: &Path) -> Result<ModelBundle, RuntimeError> {
    Ok(ModelFile::<ModelBundle>::load(path, &ModelBundle::KINDS)?.model)
}

enum Built {
    Mpc(MpcError),
    Runtime(RuntimeError),
}

impl From<MpcError> for Built {
    fn from(e: MpcError) -> Self {
        Built::Mpc(e)
    }
}

/// The groove MPC's settings: the program's controller settings, the amplifier's limit and the sensors'
/// noise levels the bundle measured.
fn mpc_settings(parts: Parts<'_>, s: &ControllerSettings) -> Result<GrooveMpcSettings, Built> {
    mpc_settings_for(parts.models, parts.origins, s).map_err(Built::Runtime)
}

/// [`mpc_settings`] from the models and their origins.
pub(crate) fn mpc_settings_for(
    models: &Models,
    origins: &Origins,
    s: &ControllerSettings,
) -> Result<GrooveMpcSettings, RuntimeError> {
    let noise = models
        .sensor_noise
        .as_ref()
        .map_err(|e| RuntimeError::InvalidValue {
            path: origins.bundle.clone(),
            key: "model.sensor_noise".into(),
            value: "absent".into(),
            allowed: e.clone(),
        })?;
    Ok(GrooveMpcSettings {
        dt_s: s.dt_s,
        mpc_every: s.mpc_every,
        horizon: s.horizon,
        slew_v_per_cycle: s.slew_v_per_cycle,
        voltage_max_v: models.spindle.plant().voltage_max_v,
        config: s.mpc.clone(),
        force_noise_n: noise.force_noise_n,
        gauge_noise_um: noise.gauge_noise_um,
        features: s.groove_mpc,
        budget: s.budget.cycle_budget(),
    })
}

/// Build `kind` and the notes on what its construction chose.
#[allow(clippy::type_complexity)]
fn build(
    kind: ControllerKind,
    parts: Parts<'_>,
    s: &ControllerSettings,
) -> Result<(Box<dyn GrooveController + Send>, Vec<String>), Built> {
    let Parts {
        models,
        program,
        plan,
        ..
    } = parts;
    let dt = s.dt_s;
    // the amplifier's rated maximum (a catalogue value, carried by the identified spindle's defaults)
    let v_max = models.spindle.plant().voltage_max_v;
    let mut notes = Vec::new();
    let ctl: Box<dyn GrooveController + Send> = match kind {
        ControllerKind::None => Box::new(NoneController::default()),
        ControllerKind::OpenLoop => {
            notes.push(
                "open-loop pre-shift applied through the PZT (sim's stage has no path table yet)"
                    .into(),
            );
            Box::new(
                OpenLoopController::new(plan.clone(), program, &models.spindle, v_max)
                    .with_spindle(program.speed_rpm, models.tool.flutes),
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
                program,
                &models.spindle,
                &models.stiffness,
                v_max,
                dt,
            )?)
        }
        ControllerKind::PidTuned
        | ControllerKind::PidFeedforward
        | ControllerKind::PidFeedforwardRead => {
            let c =
                TunedPidController::new(program, &models.spindle, &models.stiffness, v_max, dt)?;
            let d = c.design();
            notes.push(format!(
                "pid-tuned: kp {:.3} V/um, ki {:.1} V/(um s) (Ms {:.2}, crossover {:.0} rad/s) on the controllers' spindle model",
                d.kp_v_per_um, d.ki_v_per_um_s, d.ms, d.crossover_rad_s
            ));
            if kind == ControllerKind::PidTuned {
                Box::new(c)
            } else {
                let sigma = mpc_settings(parts, s)?.force_noise_n;
                let ff = FeedforwardPidController::new(
                    c,
                    plan.clone(),
                    program,
                    &models.spindle,
                    v_max,
                    models.tool.flutes,
                    sigma,
                );
                notes.push(format!(
                    "pid-ff: pid-tuned's PI plus the plan fed forward {:.2} ms ahead (the spindle model's mean delay)",
                    1e3 * ff.lead_s()
                ));
                if kind == ControllerKind::PidFeedforwardRead {
                    notes.push(format!(
                        "pid-ff-read: the peak's noise bias taken off (σ {sigma:.3} N) and the ramp's rubbing start known, as the MPC reads"
                    ));
                    Box::new(ff.with_read_features(program.speed_rpm, sigma)?)
                } else {
                    Box::new(ff)
                }
            }
        }
        ControllerKind::Mpc | ControllerKind::MpcNoPreview => {
            let c = MpcGrooveController::new(
                plan.clone(),
                program,
                &models.spindle,
                &models.stiffness,
                models.tool.flutes,
                &mpc_settings(parts, s)?,
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
    let ctl = match (
        s.compensate_hysteresis && kind.hysteresis_compensated(),
        &models.hysteresis,
    ) {
        (true, Some(h)) => {
            notes.push("the stack driven through the inverse of its identified hysteresis".into());
            Box::new(Compensated::new(
                ctl,
                HysteresisCompensator::new(h, &models.spindle),
            ))
        }
        _ => ctl,
    };
    Ok((ctl, notes))
}
