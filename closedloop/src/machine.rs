//! The simulated machine of `millcomp demo`: one machine — its spindle, its tool, its instruments and its
//! guideway — drawn once from a seed and then only *measured*, as a user measures a real one: the force
//! calibration on the dynamometer, the spindle's step test and hysteresis sweep on the capacitance gauge,
//! the load–deflection test on the dial indicator, the sensors at rest, grooves on the profilometer, and
//! closed-loop cuts whose controllers are built from the model bundles a user commissioned.
//!
//! What the machine is stays here (private fields, no getters): a pipeline that drives it sees the
//! records its instruments return and the part errors of the cuts, nothing else. The one exception is
//! [`SimulatedMachine::reveal`], a sentence for the end of a report ("what was hidden"), and the
//! *oracle* controller variant of [`MachineRuns`] — an MPC given the true path offset, which no user can
//! build and which measures how much of the ideal a diagnosis recovers.
//!
//! The machine: the thesis' groove plant (`000_…txt` ch. 5–7: PZT spindle, Ø0.8 mm ball-end mill on a
//! 4 mm shank, the groove force scale) with a hysteretic, creeping PZT stack (Bouc–Wen, log creep:
//! `millcomp_sim::actuator`); a fresh tool that is not the catalogue's ([`ToolVariation::draw`]);
//! instruments with the documented errors ([`InstrumentErrors::draw`]: the force sensor's gain and the
//! gauge's zero belong to the machine, the drift and the touch-off to each set-up); and a guideway that
//! is not straight: a Gaussian bump in machine X ([`HIDDEN_EFFECT`]) — an effect the nominal model
//! lacks, in a shape none of `millcomp diagnose`'s candidate families has (their straightness shapes
//! are a bow, a cubic and a spline with knots at sixths of the range).

use std::collections::BTreeMap;
use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use millcomp_sim::force::CutConditions;
use millcomp_sim::groove::{GrooveConfig, PathOffset};
use millcomp_sim::sensors::{InstrumentErrors, PROFILOMETER_SIGMA_UM, TOUCH_OFF_SIGMA_UM};
use millcomp_sim::session::{
    ForceModelSpec, GroovePoint, MaterialSpec, Session, StiffnessSpec, ToolSpec,
};
use millcomp_sim::tool_variation::ToolVariation;

use crate::batch::exec::{ClosedLoop, Condition, RunContext, RunMetrics};
use crate::batch::factors::{ScenarioSpec, build_scenario};
use crate::calibration::StiffnessCalibration;
use crate::commissioning::{
    CommissioningPlan, CommissioningPlant, ForceTraces, LoadRecord, RestRecord, StepRecord,
    SweepRecord, record_force_calibration, record_hysteresis_sweep, record_load_deflection,
    record_sensors_at_rest, record_step_test,
};
use crate::error::{ClosedLoopError, invalid};
use crate::groove::{RunOptions, deflection_plan, groove_setup, groove_truth, run_groove_opts};
use crate::scenario::{ControllerKind, Scenario, StageKind};

/// The effect the nominal model lacks, by its `diagnose` name (DESIGN.md's effect names).
pub const HIDDEN_EFFECT: &str = "slideway_straightness";

/// A condition without a `seed` factor is cut with the seed `CONDITION_SEED_BASE + its index` (its noise,
/// the set-up's drift and touch-off): one seed per condition, the same for every controller.
pub const CONDITION_SEED_BASE: u64 = 1000;

/// Machine X (mm) where the workpieces of closed-loop cuts are clamped: each groove starts here.
pub const FIXTURE_X_MM: f64 = 40.0;

/// The catalogue wearland of the machine's tool before its own deviation (µm): the thesis' groove tool
/// (`000_…txt` §6.2).
pub const TOOL_WEARLAND_UM: f64 = 8.0;

/// Force-sensor noise σ (N) and quantisation: `000_…txt` §5.2.2 (0.04 N).
pub const FORCE_NOISE_N: f64 = 0.04;
/// Capacitance-gauge noise σ (µm): assumed, as in the published scenarios.
pub const GAUGE_NOISE_UM: f64 = 0.01;
/// σ of the random depth offset of each groove of a measured session (µm): `002_…txt` §7.9, 60 grooves
/// of 50 µm measured 52.7 ± 1 µm, half of it taken as groove-to-groove scatter.
pub const GROOVE_SCATTER_UM: f64 = 0.5;

/// The guideway's deviation under the path: `a·exp(−½((X − c)/w)²)` (µm, + = deeper) — a worn or bent
/// stretch of the slideway (`002_…txt` §4.5 gives 5 µm over 90 mm for a straightness error).
#[derive(Debug, Clone, Copy, PartialEq)]
struct GuidewayBump {
    amplitude_um: f64,
    centre_mm: f64,
    width_mm: f64,
}

impl GuidewayBump {
    /// Drawn from `rng`: a raised stretch (the groove shallower) of 3–5 µm, 5–8 mm wide (one standard
    /// deviation), centred 7–12 mm past the fixture — so a groove cut there rises over its flank.
    fn draw(rng: &mut ChaCha8Rng) -> Self {
        Self {
            amplitude_um: -rng.random_range(3.0..5.0),
            centre_mm: FIXTURE_X_MM + rng.random_range(7.0..12.0),
            width_mm: rng.random_range(5.0..8.0),
        }
    }

    fn at(&self, x_mm: f64) -> f64 {
        let u = (x_mm - self.centre_mm) / self.width_mm;
        self.amplitude_um * (-0.5 * u * u).exp()
    }
}

/// One simulated machine (see the module documentation).
#[derive(Debug, Clone)]
pub struct SimulatedMachine {
    seed: u64,
    tool: ToolVariation,
    instruments: InstrumentErrors,
    guideway: GuidewayBump,
}

/// Every material the machine may cut, for messages.
fn check_material(material: &str) -> Result<(), ClosedLoopError> {
    millcomp_sim::material::Material::by_name(material)?;
    Ok(())
}

impl SimulatedMachine {
    /// The machine drawn from `seed` (the same seed, the same machine).
    ///
    /// # Examples
    /// ```
    /// use millcomp_closedloop::machine::SimulatedMachine;
    /// let m = SimulatedMachine::new(7);
    /// assert_eq!(m.seed(), 7);
    /// // what it is shows only in the sentence for the end of a report
    /// assert!(m.reveal().contains("slideway_straightness"));
    /// assert_eq!(m.reveal(), SimulatedMachine::new(7).reveal());
    /// ```
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6d61_6368);
        Self {
            seed,
            tool: ToolVariation::draw(seed ^ 0x746f_6f6c),
            instruments: InstrumentErrors::draw(seed ^ 0x696e_7374),
            guideway: GuidewayBump::draw(&mut rng),
        }
    }

    /// The seed the machine was drawn from.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// What the machine is, in words, without its hidden values.
    pub fn describe(&self) -> String {
        format!(
            "simulated machine (seed {}): the thesis' PZT-actuated spindle with a hysteretic, creeping stack, \
             a fresh Ø0.8 mm ball-end mill that is not the catalogue's, a force sensor, capacitance gauge, \
             dial indicator and profilometer with their errors, workpieces clamped at machine X = {FIXTURE_X_MM} mm; \
             what it is exactly is hidden until the end of the report",
            self.seed
        )
    }

    /// The hidden truth in one sentence, for the end of a report — after everything was measured,
    /// identified, diagnosed and compared: nothing may read it before.
    pub fn reveal(&self) -> String {
        let b = &self.guideway;
        format!(
            "hidden in the simulated machine (seed {}): {HIDDEN_EFFECT} as a Gaussian bump of {:+.2} µm \
             (+ = deeper) centred at machine X = {:.1} mm, {:.1} mm wide (1 SD) — not a shape of diagnose's \
             straightness family (bow, cubic, spline with knots at sixths of the range); the tool's wearland \
             {:+.2} µm and runout {:+.2} µm off the catalogue's, its forces ×{:.3}; the force sensor's gain \
             {:.4}, the gauge's zero {:+.3} µm",
            self.seed,
            b.amplitude_um,
            b.centre_mm,
            b.width_mm,
            self.tool.wearland_offset_um,
            self.tool.runout_offset_um,
            self.tool.force_factor,
            self.instruments.force_gain,
            self.instruments.gauge_offset_um
        )
    }

    /// The truth plant for `material` at `tilt_deg` (its program otherwise the thesis groove's).
    fn truth(&self, material: &str, tilt_deg: f64) -> Result<GrooveConfig, ClosedLoopError> {
        check_material(material)?;
        let mut s = Scenario::from_toml_str(
            crate::batch::factors::BASE_SCENARIO_TOML,
            crate::batch::factors::BASE_SCENARIO_FILE,
        )?;
        if let Some(g) = s.groove.as_mut() {
            g.material = material.to_string();
            g.tilt_deg = tilt_deg;
            g.wearland_um = TOOL_WEARLAND_UM;
        }
        self.overlay(&mut s, self.seed);
        groove_truth(&s)
    }

    /// This machine's truth in a scenario: its tool, its instruments (the sensor's gain and the gauge's
    /// zero the machine's, the drift and the touch-off drawn for the set-up `setup_seed`), its
    /// hysteretic stack and its sensors' noise; no deliberate model errors.
    fn overlay(&self, s: &mut Scenario, setup_seed: u64) {
        let mut instruments = InstrumentErrors::draw(setup_seed ^ self.seed.rotate_left(17));
        instruments.force_gain = self.instruments.force_gain;
        instruments.gauge_offset_um = self.instruments.gauge_offset_um;
        s.truth.tool = Some(self.tool);
        s.truth.draw_tool = false;
        s.truth.instruments = Some(instruments);
        s.truth.draw_instruments = false;
        s.truth.pzt_nonlinear = true;
        s.truth.force_error_max = 0.0;
        s.truth.force_errors = None;
        s.truth.force_noise_n = FORCE_NOISE_N;
        s.truth.gauge_noise_um = GAUGE_NOISE_UM;
        s.control.commission = false;
    }

    fn plant<'a>(&self, truth: &'a GrooveConfig, material: &'a str) -> CommissioningPlant<'a> {
        CommissioningPlant {
            truth,
            instruments: truth.instruments,
            force_noise_n: FORCE_NOISE_N,
            gauge_noise_um: GAUGE_NOISE_UM,
            material,
        }
    }

    /// Calibration cuts of `material` on the dynamometer: each cut for `revolutions` revolutions, the
    /// sensor zeroed before it and sampled `samples_per_rev` times a revolution, averaged synchronously.
    ///
    /// # Errors
    /// An unknown material; cut conditions the force model rejects.
    pub fn force_calibration(
        &self,
        material: &str,
        cuts: &[CutConditions],
        revolutions: usize,
        samples_per_rev: usize,
        seed: u64,
    ) -> Result<ForceTraces, ClosedLoopError> {
        let tilt = cuts.first().map_or(20.0, |c| c.tilt_deg);
        let truth = self.truth(material, tilt)?;
        record_force_calibration(
            &self.plant(&truth, material),
            cuts,
            revolutions,
            samples_per_rev,
            seed,
            true,
        )
    }

    /// The spindle's step test in air (the plan's bias, step, duration and sampling), read by the gauge.
    ///
    /// # Errors
    /// The spindle's discretisation errors.
    pub fn step_test(
        &self,
        plan: &CommissioningPlan,
        seed: u64,
    ) -> Result<StepRecord, ClosedLoopError> {
        let truth = self.truth("S7", 20.0)?;
        record_step_test(&self.plant(&truth, "S7"), plan, seed, true)
    }

    /// The stack's quasi-static sweep in air (the plan's turning points and rate), read by the gauge.
    ///
    /// # Errors
    /// The spindle's discretisation errors.
    pub fn hysteresis_sweep(
        &self,
        plan: &CommissioningPlan,
        seed: u64,
    ) -> Result<SweepRecord, ClosedLoopError> {
        let truth = self.truth("S7", 20.0)?;
        record_hysteresis_sweep(&self.plant(&truth, "S7"), plan, seed)
    }

    /// The load–deflection test: masses hung on the tool, read by the dial indicator.
    ///
    /// # Errors
    /// A bad indicator noise level.
    pub fn load_deflection(
        &self,
        cal: &StiffnessCalibration,
        seed: u64,
    ) -> Result<LoadRecord, ClosedLoopError> {
        let truth = self.truth("S7", 20.0)?;
        record_load_deflection(&self.plant(&truth, "S7"), cal, seed)
    }

    /// The force channel and the gauge recorded at rest, `samples` samples every `dt_s`.
    ///
    /// # Errors
    /// A bad noise level.
    pub fn sensors_at_rest(
        &self,
        samples: usize,
        dt_s: f64,
        seed: u64,
    ) -> Result<RestRecord, ClosedLoopError> {
        let truth = self.truth("S7", 20.0)?;
        record_sensors_at_rest(&self.plant(&truth, "S7"), samples, dt_s, seed)
    }

    /// Cuts the grooves of a session's plan (uncompensated, the PZT at rest) in the session's material
    /// and measures them on the profilometer: per point the depth this machine cuts — its tool, its
    /// stiffness, its guideway — plus the session's touch-off error, each groove's random offset
    /// ([`GROOVE_SCATTER_UM`]) and the profilometer's noise ([`PROFILOMETER_SIGMA_UM`]). Only the plan and
    /// the material of `session` are read; its tool, force model, stiffness and effects (the user's
    /// nominal model) are not the machine's.
    ///
    /// # Errors
    /// An unknown material; the plan's validation errors (naming the key).
    pub fn cut_session(
        &self,
        session: &Session,
        seed: u64,
    ) -> Result<Vec<GroovePoint>, ClosedLoopError> {
        let truth = self.truth(&session.material.name, 20.0)?;
        let fm = &truth.force_model;
        let m = &fm.material;
        let plan_only = Session {
            name: session.name.clone(),
            description: String::new(),
            tool: ToolSpec {
                radius_um: fm.tool.radius_um,
                wearland_um: fm.tool.wearland_um,
                runout_um: fm.tool.runout_um,
            },
            material: MaterialSpec {
                name: session.material.name.clone(),
                w_mpa: Some(m.w_mpa),
                e_gpa: Some(m.e_gpa),
                mu_rake: Some(m.mu_rake),
                mu_flank: Some(m.mu_flank),
            },
            force_model: ForceModelSpec {
                force_scale: fm.params.force_scale,
                ..ForceModelSpec::default()
            },
            stiffness: StiffnessSpec {
                axial_n_per_um: truth.stiffness.axial_n_per_um,
                radial_n_per_um: truth.stiffness.radial_n_per_um,
            },
            uncertainty: Default::default(),
            effects: Vec::new(),
            plan: session.plan.clone(),
        };
        plan_only.validate()?;
        let ctx = plan_only.contexts()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7072_6f66);
        let normal = |sd: f64| Normal::new(0.0, sd).map_err(|_| invalid("sigma", sd, "finite"));
        let touch_off = normal(TOUCH_OFF_SIGMA_UM)?.sample(&mut rng);
        let scatter = normal(GROOVE_SCATTER_UM)?;
        let noise = normal(PROFILOMETER_SIGMA_UM)?;
        let mut groove_offset: BTreeMap<i64, f64> = BTreeMap::new();
        Ok(ctx
            .points
            .iter()
            .map(|p| {
                let g = *groove_offset
                    .entry(p.groove_id)
                    .or_insert_with(|| scatter.sample(&mut rng));
                let depth = p.depth_nominal_um
                    + self.guideway.at(p.machine_x_mm)
                    + touch_off
                    + g
                    + noise.sample(&mut rng);
                p.measured(depth)
            })
            .collect())
    }

    /// The guideway's offset along a groove of `length_mm` clamped at [`FIXTURE_X_MM`], relative to where
    /// the tool is touched off (the groove's start), every 0.05 mm.
    fn path_offset(&self, length_mm: f64) -> Result<PathOffset, ClosedLoopError> {
        let n = (length_mm / 0.05).ceil().max(1.0) as usize;
        let zero = self.guideway.at(FIXTURE_X_MM);
        let pts = (0..=n)
            .map(|i| {
                let x = length_mm * i as f64 / n as f64;
                (x, self.guideway.at(FIXTURE_X_MM + x) - zero)
            })
            .collect();
        Ok(PathOffset::new(pts)?)
    }

    /// Closed-loop cuts on this machine, the controllers built from the bundle of each material
    /// (`material → model-bundle file`).
    pub fn runs(&self, bundles: BTreeMap<String, PathBuf>) -> MachineRuns<'_> {
        MachineRuns {
            machine: self,
            bundles,
            corrections: BTreeMap::new(),
        }
    }
}

/// The path offset a controller variant was told of, after the `+` of its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Correction {
    /// None: the controller as built from its bundle (`mpc`).
    None,
    /// What the user gave for the scenario ([`MachineRuns::with_corrections`]; `mpc+diagnosed`).
    Diagnosed,
    /// The machine's true path offset: an oracle no user can build (`mpc+true-effect`).
    Oracle,
}

/// Suffix of a controller variant told of the diagnosed path offset.
pub const DIAGNOSED: &str = "diagnosed";
/// Suffix of the oracle variant, told of the true path offset.
pub const ORACLE: &str = "true-effect";

/// Splits a controller name of a machine run into the controller and its correction: `mpc`,
/// `mpc+diagnosed`, `open-loop+true-effect`.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] naming `controller` for an unknown suffix; an unknown controller.
///
/// ```
/// use millcomp_closedloop::machine::{Correction, controller_variant};
/// use millcomp_closedloop::ControllerKind;
/// assert_eq!(controller_variant("mpc+diagnosed").unwrap(), (ControllerKind::Mpc, Correction::Diagnosed));
/// assert_eq!(controller_variant("pid-tuned").unwrap(), (ControllerKind::PidTuned, Correction::None));
/// assert!(controller_variant("mpc+guess").is_err());
/// ```
pub fn controller_variant(name: &str) -> Result<(ControllerKind, Correction), ClosedLoopError> {
    let (kind, corr) = match name.split_once('+') {
        None => (name, Correction::None),
        Some((k, DIAGNOSED)) => (k, Correction::Diagnosed),
        Some((k, ORACLE)) => (k, Correction::Oracle),
        Some((_, other)) => {
            return Err(invalid(
                "controller",
                format!("`{name}` (suffix `{other}`)"),
                format!("a controller, optionally +{DIAGNOSED} or +{ORACLE}"),
            ));
        }
    };
    Ok((kind.parse()?, corr))
}

/// Closed-loop groove cuts on a [`SimulatedMachine`] for a batch (`crate::batch::exec::ClosedLoop`): each
/// scenario is the published groove with the batch's factors applied
/// ([`crate::batch::factors::build_scenario`]), cut on this machine at [`FIXTURE_X_MM`] with the set-up
/// drawn from the scenario's seed, its controllers built from the user's bundle for the scenario's
/// material and nothing else. A controller name may carry a correction ([`controller_variant`]): the
/// path offset the user's diagnosis gave for the scenario, or the true one (the oracle).
#[derive(Debug, Clone)]
pub struct MachineRuns<'a> {
    machine: &'a SimulatedMachine,
    bundles: BTreeMap<String, PathBuf>,
    corrections: BTreeMap<usize, PathOffset>,
}

impl MachineRuns<'_> {
    /// The path offset (along each groove, relative to its start) the `+diagnosed` variants are told of,
    /// by scenario index.
    pub fn with_corrections(mut self, corrections: BTreeMap<usize, PathOffset>) -> Self {
        self.corrections = corrections;
        self
    }

    fn scenario(&self, spec: &ScenarioSpec) -> Result<Scenario, ClosedLoopError> {
        let mut s = build_scenario(spec)?;
        if !spec.factors.contains_key("seed") {
            s.seed = CONDITION_SEED_BASE + spec.index as u64;
        }
        if s.stage != StageKind::Groove {
            return Err(invalid(
                "stage",
                s.stage.name(),
                "groove (the simulated machine cuts grooves)",
            ));
        }
        let seed = s.seed;
        self.machine.overlay(&mut s, seed);
        let material = s.groove.as_ref().map_or("", |g| g.material.as_str());
        let bundle = self.bundles.get(material).ok_or_else(|| {
            invalid(
                "material",
                material,
                format!(
                    "a material with a commissioned bundle: {}",
                    self.bundles.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
        s.control.bundle = Some(bundle.display().to_string());
        Ok(s)
    }
}

/// A condition prepared once for its controllers: the scenario on this machine, its set-up (the truth
/// with the guideway under the groove, the controllers' models from the bundle) and the preview.
struct MachineCondition {
    scenario: Scenario,
    setup: crate::groove::GrooveSetup,
    plan: millcomp_mpc::groove::DeflectionPlan,
    truth_offset: PathOffset,
    correction: Option<PathOffset>,
    index: usize,
}

impl MachineCondition {
    fn cut(
        &self,
        controller: &str,
        opts: RunOptions,
    ) -> Result<crate::report::RunOutput, ClosedLoopError> {
        let (kind, correction) = controller_variant(controller)?;
        let plan = match correction {
            Correction::None => self.plan.clone(),
            Correction::Oracle => self
                .plan
                .clone()
                .with_path_offset(self.truth_offset.clone()),
            Correction::Diagnosed => {
                let c = self.correction.as_ref().ok_or_else(|| {
                    invalid(
                        "controller",
                        controller,
                        format!(
                            "a diagnosed path offset for scenario {} (none was given)",
                            self.index + 1
                        ),
                    )
                })?;
                self.plan.clone().with_path_offset(c.clone())
            }
        };
        run_groove_opts(&self.scenario, &self.setup, &plan, kind, opts)
    }
}

impl Condition for MachineCondition {
    fn run(&self, controller: &str) -> Result<(RunMetrics, f64), ClosedLoopError> {
        let out = self.cut(controller, RunOptions::BATCH)?;
        Ok((RunMetrics::from_report(&out.report), out.report.simulated_s))
    }
}

impl MachineRuns<'_> {
    fn condition(&self, spec: &ScenarioSpec) -> Result<MachineCondition, ClosedLoopError> {
        let scenario = self.scenario(spec)?;
        scenario.validate()?;
        let mut setup = groove_setup(&scenario)?;
        let truth_offset = self.machine.path_offset(setup.truth.program.length_mm)?;
        setup.truth.path_offset = truth_offset.clone();
        let plan = deflection_plan(&setup, 0.01)?;
        Ok(MachineCondition {
            scenario,
            setup,
            plan,
            truth_offset,
            correction: self.corrections.get(&spec.index).cloned(),
            index: spec.index,
        })
    }

    /// One cut and the finished part's depth error along the groove — what a profilometer would show:
    /// `(x_mm, error_um)` every millisecond of cut (+ = deeper than programmed).
    ///
    /// # Errors
    /// As the batch runs.
    pub fn profile(
        &self,
        spec: &ScenarioSpec,
        controller: &str,
    ) -> Result<(RunMetrics, Vec<(f64, f64)>), ClosedLoopError> {
        let out = self
            .condition(spec)?
            .cut(controller, RunOptions::default())?;
        let col = |name: &str| out.trace.columns.iter().position(|c| c == name);
        let (Some(ix), Some(ie)) = (col("x_mm"), col("error_um")) else {
            return Err(invalid(
                "trace",
                "without x_mm or error_um",
                "a groove trace",
            ));
        };
        let pts = out
            .trace
            .rows
            .iter()
            .filter(|r| r[ix] >= 0.0)
            .map(|r| (r[ix], r[ie]))
            .collect();
        Ok((RunMetrics::from_report(&out.report), pts))
    }
}

impl ClosedLoop for MachineRuns<'_> {
    fn run(
        &self,
        spec: &ScenarioSpec,
        controller: &str,
    ) -> Result<(RunMetrics, f64), ClosedLoopError> {
        self.condition(spec)?.run(controller)
    }

    fn prepare<'a>(
        &'a self,
        scenario: &'a ScenarioSpec,
        _cx: &RunContext<'a>,
    ) -> Result<Box<dyn Condition + 'a>, ClosedLoopError> {
        Ok(Box::new(self.condition(scenario)?))
    }
}
