//! Scenario files (TOML, `datasets/scenarios/*.toml`): which stage, the planned process, how the truth
//! differs from the controllers' models, controller settings, injected faults. Schema in
//! `closedloop/SCENARIOS.md`. Unknown keys and invalid values are errors naming the key.

use std::path::Path;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use millcomp_sim::feed::{FeedChange, WorkpieceExit};
use millcomp_sim::groove::{DEFAULT_FEED_ACCEL_MM_S2, DepthProfile};
use millcomp_sim::sensors::InstrumentErrors;
use millcomp_sim::thinwall::WallGeometry;

use millcomp_mpc::config::MAX_HORIZON;
use millcomp_mpc::{MpcConfig, MpcError};

use crate::calibration::StiffnessCalibration;
use crate::commissioning_plan::CommissioningPlan;
use crate::error::{ClosedLoopError, invalid};
use crate::model_errors::ForceErrors;
use crate::touch_off::TouchOffBias;

/// The controllers the runner knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ControllerKind {
    /// No compensation.
    #[serde(rename = "none")]
    None,
    /// Open-loop compensation: force model ÷ stiffness, pre-shifted path (`000_…txt` ch. 6).
    #[serde(rename = "open-loop")]
    OpenLoop,
    /// The published PID (P 400, I 800 000, D 0) with the thesis' signal chain, no anti-windup (as published).
    #[serde(rename = "pid")]
    Pid,
    /// The published PID with back-calculation anti-windup.
    #[serde(rename = "pid-aw")]
    PidAntiWindup,
    /// The root-locus design PID (P 844, I 130 820, D 0.4), no anti-windup.
    #[serde(rename = "pid-design")]
    PidDesign,
    /// The strongest feedback PI a control engineer would build today: the MPC's signal chain, gains from
    /// a fixed rule on the controllers' spindle model (largest integral gain with Ms ≤ 1.6,
    /// `millcomp_mpc::tuning`), conditional-integration anti-windup.
    #[serde(rename = "pid-tuned")]
    PidTuned,
    /// `pid-tuned` plus the planned deflection fed forward one spindle mean delay ahead (the ablation an
    /// engineer holding the NC program would build; `millcomp_mpc::groove::FeedforwardPidController`).
    #[serde(rename = "pid-ff")]
    PidFeedforward,
    /// `pid-ff` reading what the MPC's read features read (`GrooveMpcFeatures::unbiased_peak` and
    /// `flank_rubbing`): the per-revolution peak's noise bias taken off, the ramp's rubbing start known
    /// (the flank push fed forward, the plan's tip wanted where the tool rides on its wear land) — the
    /// fairness ablation (`FeedforwardPidController::with_read_features`).
    #[serde(rename = "pid-ff-read")]
    PidFeedforwardRead,
    /// Thin-wall iterative compensation with a 0.5 µm threshold (`004_…txt` §3.2).
    #[serde(rename = "threshold")]
    Threshold,
    /// Model-predictive control solved with Clarabel every cycle.
    #[serde(rename = "mpc")]
    Mpc,
    /// The MPC without preview: the planned deflection of *now* held over the horizon (ablation).
    #[serde(rename = "mpc-nopreview")]
    MpcNoPreview,
    /// NC stage: 003's reactive compensation (notch chain + 120 Hz low-pass on the measured force).
    #[serde(rename = "reactive")]
    Reactive,
    /// NC stage: 003's proactive compensation (6 Hz, D = 1 low-pass + the recorded offset curve).
    #[serde(rename = "proactive")]
    Proactive,
}

/// All controller names, in CLI order.
pub const CONTROLLER_NAMES: [&str; 13] = [
    "none",
    "open-loop",
    "pid",
    "pid-aw",
    "pid-design",
    "pid-tuned",
    "pid-ff",
    "pid-ff-read",
    "threshold",
    "mpc",
    "mpc-nopreview",
    "reactive",
    "proactive",
];

impl ControllerKind {
    /// All kinds, in [`CONTROLLER_NAMES`] order.
    pub const ALL: [ControllerKind; 13] = [
        ControllerKind::None,
        ControllerKind::OpenLoop,
        ControllerKind::Pid,
        ControllerKind::PidAntiWindup,
        ControllerKind::PidDesign,
        ControllerKind::PidTuned,
        ControllerKind::PidFeedforward,
        ControllerKind::PidFeedforwardRead,
        ControllerKind::Threshold,
        ControllerKind::Mpc,
        ControllerKind::MpcNoPreview,
        ControllerKind::Reactive,
        ControllerKind::Proactive,
    ];

    /// Whether the stage has this controller: `threshold` is the thin wall's (004) baseline only;
    /// `pid-aw`, `pid-design`, `pid-tuned`, `pid-ff`, `pid-ff-read` and `mpc-nopreview` are the PZT
    /// spindle's only;
    /// the NC stage (003) has `none`, `reactive`, `proactive` and `mpc`, and only it has the first two.
    pub fn runs_on(self, stage: StageKind) -> bool {
        if matches!(self, ControllerKind::Reactive | ControllerKind::Proactive) {
            return stage == StageKind::NcAxis;
        }
        match stage {
            StageKind::NcAxis => matches!(self, ControllerKind::None | ControllerKind::Mpc),
            StageKind::Groove => self != ControllerKind::Threshold,
            StageKind::ThinWall => !matches!(
                self,
                ControllerKind::PidAntiWindup
                    | ControllerKind::PidDesign
                    | ControllerKind::PidTuned
                    | ControllerKind::PidFeedforward
                    | ControllerKind::PidFeedforwardRead
                    | ControllerKind::MpcNoPreview
            ),
        }
    }

    /// The CLI/JSON name.
    pub fn name(self) -> &'static str {
        CONTROLLER_NAMES[Self::ALL.iter().position(|k| *k == self).unwrap_or(0)]
    }
}

impl FromStr for ControllerKind {
    type Err = ClosedLoopError;
    /// ```
    /// use millcomp_closedloop::scenario::ControllerKind;
    /// assert_eq!("open-loop".parse::<ControllerKind>().unwrap(), ControllerKind::OpenLoop);
    /// assert!("lqr".parse::<ControllerKind>().is_err());
    /// ```
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        CONTROLLER_NAMES
            .iter()
            .position(|n| *n == s)
            .map(|i| Self::ALL[i])
            .ok_or_else(|| ClosedLoopError::UnknownController {
                name: s.to_string(),
                allowed: CONTROLLER_NAMES.join(", "),
            })
    }
}

impl std::fmt::Display for ControllerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which stage a scenario runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StageKind {
    /// PZT-spindle groove stage (`000_…txt` ch. 6–7).
    Groove,
    /// Thin-wall linear-motor compensation stage (`004_…txt`).
    ThinWall,
    /// NC feed-axis compensation of a full slot (`003_…txt`; `crate::nc_axis`).
    NcAxis,
}

impl StageKind {
    /// JSON name.
    pub fn name(self) -> &'static str {
        match self {
            StageKind::Groove => "groove",
            StageKind::ThinWall => "thin_wall",
            StageKind::NcAxis => "nc_axis",
        }
    }
}

/// A feed-rate change at a position along the groove (sim's [`FeedChange`]).
pub type FeedStep = FeedChange;

/// The tool leaves the workpiece (sim's [`WorkpieceExit`]).
pub type ExitSpec = WorkpieceExit;

/// Groove-stage scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GrooveScenario {
    /// Material name (`S7`, `1018`, `6061`, `H59`, `C45`).
    #[serde(default = "default_material")]
    pub material: String,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Tool wearland (µm) of the truth tool.
    #[serde(default = "default_wearland")]
    pub wearland_um: f64,
    /// Spindle speed (rpm).
    #[serde(default = "default_speed")]
    pub speed_rpm: f64,
    /// Upfeed (µm/rev) at the start.
    #[serde(default = "default_upfeed")]
    pub upfeed_um: f64,
    /// Groove length (mm).
    #[serde(default = "default_length")]
    pub length_mm: f64,
    /// Programmed depth profile (sim's `DepthProfile`: `{kind = "ramp", from_um, to_um}`, …).
    pub depth: DepthProfile,
    /// Feed-rate changes (`[[x_mm, upfeed_um]]` as tables `{x_mm, upfeed_um}`).
    #[serde(default)]
    pub feed_steps: Vec<FeedStep>,
    /// Feed-axis acceleration (mm/s²) for the feed changes (default: sim's
    /// [`DEFAULT_FEED_ACCEL_MM_S2`], ≈ 003's 16 ms feed-axis delay for a doubling).
    #[serde(default = "default_feed_accel")]
    pub feed_accel_mm_s2: f64,
    /// Workpiece exit: `{x_mm, length_mm}` (edge position and the length over which the engagement falls).
    #[serde(default)]
    pub exit: Option<ExitSpec>,
    /// Approach in air before the entry (mm, default 0): the tool starts at x = −approach at the
    /// programmed feed and depth (sim's `GrooveProgram::approach_mm`).
    #[serde(default)]
    pub approach_mm: f64,
    /// Length (mm) after the entry over which the engagement rises from 0 to 1 (default 0: at once;
    /// sim's `GrooveProgram::entry_length_mm`) — for a ball end entering at depth d, the half-length of
    /// its contact, √(2·R·d − d²).
    #[serde(default)]
    pub entry_length_mm: f64,
    /// If set, the truth force scale is calibrated so that the uncompensated error at the deepest
    /// programmed point equals this (µm) — used where the thesis reports the measured uncompensated error
    /// for a tool whose condition was not measured (30°, 40°).
    #[serde(default)]
    pub calibrate_uncompensated_um: Option<f64>,
}

fn default_material() -> String {
    "S7".into()
}
fn default_wearland() -> f64 {
    8.0
}
fn default_speed() -> f64 {
    10_000.0
}
fn default_upfeed() -> f64 {
    10.0
}
fn default_length() -> f64 {
    20.0
}
fn default_feed_accel() -> f64 {
    DEFAULT_FEED_ACCEL_MM_S2
}

/// Thin-wall scenario (`004_…txt` Tables 2–4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThinWallScenario {
    /// Nominal wall thicknesses (µm).
    #[serde(default = "default_walls")]
    pub walls_um: Vec<f64>,
    /// Wall height (µm).
    #[serde(default = "default_wall_height")]
    pub height_um: f64,
    /// Radial depth of cut ae (µm).
    #[serde(default = "default_ae")]
    pub ae_um: f64,
    /// Axial depth per layer ap (µm).
    #[serde(default = "default_ap")]
    pub ap_um: f64,
    /// Feed per tooth (µm).
    #[serde(default = "default_fz")]
    pub fz_um: f64,
    /// Wall length (mm).
    #[serde(default = "default_wall_length")]
    pub length_mm: f64,
}

impl ThinWallScenario {
    /// The programmed geometry of the wall of nominal thickness `nominal_um`.
    pub fn geometry(&self, nominal_um: f64) -> WallGeometry {
        WallGeometry {
            nominal_thickness_um: nominal_um,
            height_um: self.height_um,
            length_um: self.length_mm * 1000.0,
            ae_um: self.ae_um,
            ap_um: self.ap_um,
            fz_um: self.fz_um,
        }
    }
}

fn default_walls() -> Vec<f64> {
    vec![80.0, 100.0, 120.0]
}
fn default_wall_height() -> f64 {
    800.0
}
fn default_ae() -> f64 {
    50.0
}
fn default_ap() -> f64 {
    200.0
}
fn default_fz() -> f64 {
    1.6
}
fn default_wall_length() -> f64 {
    5.0
}

/// How the truth differs from the controllers' models.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthSpec {
    /// Bound of the seeded force-parameter errors laid on the controllers' identified force model
    /// (relative, ≤ 0.5; 0 = none). Ignored if `force_errors` is given.
    #[serde(default)]
    pub force_error_max: f64,
    /// Explicit force-parameter errors (relative) laid on the controllers' identified force model.
    #[serde(default)]
    pub force_errors: Option<ForceErrors>,
    /// Simulated stiffness calibration.
    #[serde(default)]
    pub stiffness_calibration: StiffnessCalibration,
    /// Extra multiplicative error on the controllers' identified stiffness (sweeps): `k_model = k_id·(1+e)`.
    #[serde(default)]
    pub stiffness_error: f64,
    /// Force-sensor noise σ (N); quantisation is the same value (`000_…txt` §5.2.2: 0.04 N).
    #[serde(default = "default_force_noise")]
    pub force_noise_n: f64,
    /// Gauge noise σ (µm).
    #[serde(default = "default_gauge_noise")]
    pub gauge_noise_um: f64,
    /// Explicit instrument and set-up errors of the truth (force-sensor gain and drift, touch-off, gauge
    /// zero; `millcomp_sim::sensors::InstrumentErrors`). Exact when neither this nor `draw_instruments`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instruments: Option<InstrumentErrors>,
    /// Draw the instrument errors from their documented spreads with the scenario's seed
    /// (`InstrumentErrors::draw`); ignored when `instruments` is given.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub draw_instruments: bool,
    /// Explicit deviations of the truth's tool from the catalogue tool (wearland and runout offsets, force
    /// factor; `millcomp_sim::tool_variation::ToolVariation`). The catalogue tool when neither this nor
    /// `draw_tool`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool: Option<millcomp_sim::tool_variation::ToolVariation>,
    /// Draw the truth's tool deviations from their documented fresh-tool spreads with the scenario's seed
    /// (`ToolVariation::draw`); ignored when `tool` is given.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub draw_tool: bool,
    /// Explicit deviations of the thin-wall truth's part from the published wall (factors on its Young's
    /// modulus and force coefficient; `millcomp_sim::wall_variation::WallVariation`), the same for every
    /// wall. The published wall when neither this nor `draw_wall`. Thin-wall scenarios only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall: Option<millcomp_sim::wall_variation::WallVariation>,
    /// Draw each wall's part deviations from their documented spreads (`WallVariation::draw`), one part
    /// per wall on the wall's own seed; ignored when `wall` is given. Thin-wall scenarios only.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub draw_wall: bool,
    /// Give the truth's PZT stack its hysteresis (Bouc–Wen, 12 % of the stroke over a full cycle) and
    /// creep (1.5 % per decade) — `millcomp_sim::actuator`; linear when false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub pzt_nonlinear: bool,
}

fn default_force_noise() -> f64 {
    0.04
}
fn default_gauge_noise() -> f64 {
    0.01
}

impl Default for TruthSpec {
    fn default() -> Self {
        Self {
            force_error_max: 0.0,
            force_errors: None,
            stiffness_calibration: StiffnessCalibration::default(),
            stiffness_error: 0.0,
            force_noise_n: default_force_noise(),
            gauge_noise_um: default_gauge_noise(),
            instruments: None,
            draw_instruments: false,
            tool: None,
            draw_tool: false,
            wall: None,
            draw_wall: false,
            pzt_nonlinear: false,
        }
    }
}

/// Controller timing and MPC settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlSpec {
    /// Run as a real-time controller: its cycles at real-time priority where permitted
    /// (`crate::realtime`; the report's `realtime` says whether they were) and the MPC's cycle budget
    /// enforced (a plan not ready in time is replaced by the fallback). Off (the default; batches and
    /// tests), cycles are timed and misses counted but the fresh plan is always used, so results do not
    /// depend on the machine's load. `millcomp simulate` sets it unless `--no-realtime`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub realtime: bool,
    /// The MPC cycle's time budget as a fraction of its period (0 < f ≤ 1), overriding the MPC
    /// configuration's `solver.budget_fraction` (default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget_fraction: Option<f64>,
    /// Stage step (s); PID and the signal chain run every step.
    #[serde(default = "default_dt")]
    pub dt_s: f64,
    /// MPC period in stage steps.
    #[serde(default = "default_mpc_every")]
    pub mpc_every: usize,
    /// MPC horizon (used when `mpc` is not given).
    #[serde(default = "default_horizon")]
    pub horizon: usize,
    /// Amplifier slew limit per MPC cycle (V).
    #[serde(default = "default_slew")]
    pub slew_v_per_cycle: f64,
    /// Full MPC configuration override (keys as in `mpc/CONFIG.md`).
    #[serde(default)]
    pub mpc: Option<MpcConfig>,
    /// Identified spindle (`millcomp identify` saved model, kind `spindle`, TOML path) used as the
    /// controllers' spindle model instead of sim's fitted one.
    #[serde(default)]
    pub spindle_model: Option<String>,
    /// Identified force model (saved model, kind `force`, TOML path) used as the controllers' force
    /// predictor instead of the perturbed truth (`truth.force_errors` is then ignored).
    #[serde(default)]
    pub force_model: Option<String>,
    /// Response-surface force predictor (a model saved by `millcomp doe analyze --save`, TOML path) used
    /// in the controllers' preview; its factors must be process parameters (`closedloop/SCENARIOS.md`).
    #[serde(default)]
    pub force_response_surface: Option<String>,
    /// A model bundle (`millcomp commission --out`, kind `bundle`): the controllers' spindle, force model
    /// and stiffness all come from it (with the nominal material and tool for what the force fit held
    /// fixed); not together with `spindle_model` or `force_model`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bundle: Option<String>,
    /// Commission the truth plant (the scenario's `[commissioning]` plan, its seed) and build the
    /// controllers from the resulting bundle; not together with `bundle`, `spindle_model` or `force_model`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub commission: bool,
    /// The groove MPC's planning and estimation features (`stroke_aware`, `adapt_plan_scale`,
    /// `flute_phase`; all on by default — switched off one at a time for the ablations).
    #[serde(default)]
    pub groove_mpc: millcomp_mpc::groove::GrooveMpcFeatures,
    /// Drive the PZT stack through the inverse of the bundle's hysteresis model (a commissioning's sweep
    /// in air; `mpc::identified::HysteresisCompensator`) for every controller built from the bundle —
    /// `open-loop`, `pid-tuned`, `pid-ff`, `pid-ff-read`, `mpc`, `mpc-nopreview` — when the bundle has one. The
    /// published `pid` (and `pid-aw`, `pid-design`) stay as published. Off by default: on the
    /// commissioned grooves it bought nothing (docs/studies/mpc-parts.md, `compare --features --commissioned`): the
    /// identified Prandtl–Ishlinskii model takes the stack's static error from 3.5–5 µm to about 1 µm
    /// of tip, but at a change what matters is the stack's slope, which the gauge channel's
    /// disturbance estimate follows already.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub compensate_hysteresis: bool,
    /// How the tool is touched off (groove stage): `"rest"` (0 V, the default), `"auto"` (a bias chosen
    /// from the program and the bundle's hysteresis model, so the tip can retract below the depth's zero
    /// where the cutter leaves the workpiece) or `{ volts = … }`. Every controller, `none` included,
    /// starts from it and holds the bias for no correction ([`crate::touch_off`]).
    #[serde(default, skip_serializing_if = "is_rest")]
    pub touch_off_bias: TouchOffBias,
}

fn is_rest(b: &TouchOffBias) -> bool {
    *b == TouchOffBias::Rest
}

fn default_dt() -> f64 {
    5e-5
}
fn default_mpc_every() -> usize {
    10
}
fn default_horizon() -> usize {
    20
}
fn default_slew() -> f64 {
    100.0
}

impl ControlSpec {
    /// The MPC's cycle budget for this run: `budget_fraction` if given, enforced when `realtime`.
    pub fn cycle_budget(&self) -> millcomp_mpc::config::CycleBudget {
        millcomp_mpc::config::CycleBudget {
            fraction: self.budget_fraction,
            enforced: self.realtime,
            max_iter: None,
        }
    }
}

impl Default for ControlSpec {
    fn default() -> Self {
        Self {
            realtime: false,
            budget_fraction: None,
            dt_s: default_dt(),
            mpc_every: default_mpc_every(),
            horizon: default_horizon(),
            slew_v_per_cycle: default_slew(),
            mpc: None,
            spindle_model: None,
            force_model: None,
            force_response_surface: None,
            bundle: None,
            commission: false,
            groove_mpc: Default::default(),
            compensate_hysteresis: false,
            touch_off_bias: TouchOffBias::Rest,
        }
    }
}

/// An injected fault.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Fault {
    /// Add `magnitude_n` to the measured force for `duration_s` from `t_s`.
    ForceSpike {
        /// Start (s).
        t_s: f64,
        /// Added force (N).
        magnitude_n: f64,
        /// Duration (s).
        duration_s: f64,
    },
    /// Sensor dropout: the force and gauge readings stay at their last value for `duration_s`.
    StuckSensor {
        /// Start (s).
        t_s: f64,
        /// Duration (s).
        duration_s: f64,
    },
    /// The MPC's QP solver fails to converge (iteration cap 1) for `cycles` cycles from `t_s`.
    SolverFailure {
        /// Start (s).
        t_s: f64,
        /// Number of failing cycles.
        cycles: usize,
    },
}

/// A complete scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name.
    pub name: String,
    /// What it reproduces, with the seed reference.
    #[serde(default)]
    pub description: String,
    /// Stage.
    pub stage: StageKind,
    /// Seed of every random draw (noise, calibration, force errors).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Groove settings (stage = "groove").
    #[serde(default)]
    pub groove: Option<GrooveScenario>,
    /// Thin-wall settings (stage = "thin_wall").
    #[serde(default)]
    pub thin_wall: Option<ThinWallScenario>,
    /// NC feed-axis settings (stage = "nc_axis", `crate::nc_axis`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nc_axis: Option<crate::nc_axis_scenario::NcAxisScenario>,
    /// Truth vs model.
    #[serde(default)]
    pub truth: TruthSpec,
    /// Controller settings.
    #[serde(default)]
    pub control: ControlSpec,
    /// Controllers this scenario is meant to be run with (validated names; informative).
    #[serde(default)]
    pub controllers: Vec<String>,
    /// Injected faults.
    #[serde(default)]
    pub faults: Vec<Fault>,
    /// The commissioning plan (used by `control.commission` and `millcomp commission`).
    #[serde(default, skip_serializing_if = "is_default_plan")]
    pub commissioning: CommissioningPlan,
}

fn is_default_plan(p: &CommissioningPlan) -> bool {
    *p == CommissioningPlan::default()
}

fn default_seed() -> u64 {
    1
}

impl Scenario {
    /// The injected solver failures as `(t_s, cycles)`, in file order.
    pub fn solver_failures(&self) -> Vec<(f64, usize)> {
        self.faults
            .iter()
            .filter_map(|f| match *f {
                Fault::SolverFailure { t_s, cycles } => Some((t_s, cycles)),
                _ => None,
            })
            .collect()
    }
}

/// The longest groove or thin wall a scenario may cut: 1 m, fifty times the published 20 mm groove and
/// beyond the travel of a micro-milling machine. Checked before anything is allocated (a plan of
/// `length_mm = 1e9` asked for 800 GB).
pub const MAX_LENGTH_MM: f64 = 1000.0;

/// The most control steps one closed-loop groove run may take: 10 million (the published groove is
/// 240 000 steps at 20 kHz; 10 million take about a minute and 0.5 GB of trace).
pub const MAX_RUN_STEPS: f64 = 1e7;

/// Finite, > 0 and at most `max`.
fn finite_pos_at_most(key: &str, v: f64, max: f64) -> Result<(), ClosedLoopError> {
    if v.is_finite() && v > 0.0 && v <= max {
        Ok(())
    } else {
        Err(invalid(key, v, format!("0 < value <= {max}")))
    }
}

pub(crate) use crate::error::{finite_nonneg, finite_pos, sim_keyed};

impl Scenario {
    /// Parse TOML text (`path` is only used in messages) and validate.
    ///
    /// # Errors
    /// [`ClosedLoopError::Scenario`] for TOML that does not parse or an unknown key (the parser's
    /// message names it), and the errors of [`Scenario::validate`].
    pub fn from_toml_str(text: &str, path: &str) -> Result<Self, ClosedLoopError> {
        let s: Scenario = toml::from_str(text).map_err(|e| ClosedLoopError::Scenario {
            path: path.to_string(),
            message: e.to_string(),
        })?;
        s.validate()?;
        Ok(s)
    }

    /// Read and validate a scenario file.
    ///
    /// # Errors
    /// [`ClosedLoopError::Io`] when the file cannot be read, and those of [`Scenario::from_toml_str`].
    ///
    /// # Examples
    /// ```
    /// use millcomp_closedloop::scenario::{Scenario, StageKind};
    /// let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../datasets/scenarios/");
    /// let s = Scenario::load(format!("{dir}groove_s7_30deg.toml")).unwrap();
    /// assert_eq!(s.stage, StageKind::Groove);
    /// let g = s.groove.as_ref().unwrap();
    /// // the published 30° S7 groove: 0 → 80 µm over 20 mm, calibrated to the ≈ 16 µm uncompensated
    /// // error of 000 §7.2.2
    /// assert_eq!((g.tilt_deg, g.length_mm), (30.0, 20.0));
    /// assert_eq!(g.calibrate_uncompensated_um, Some(16.0));
    /// assert!(Scenario::load(format!("{dir}no_such.toml")).is_err());
    /// ```
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ClosedLoopError> {
        let p = path.as_ref();
        let text = std::fs::read_to_string(p).map_err(|e| ClosedLoopError::Io {
            path: p.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_toml_str(&text, &p.display().to_string())
    }

    /// Validate every value; errors name the key.
    ///
    /// # Errors
    /// [`ClosedLoopError::InvalidConfig`] naming the key (`groove.tilt_deg`, `controllers[1]`,
    /// `control.mpc.limits.u_min[0]`, …) and what is allowed.
    pub fn validate(&self) -> Result<(), ClosedLoopError> {
        for (i, c) in self.controllers.iter().enumerate() {
            c.parse::<ControllerKind>().map_err(|e| match e {
                ClosedLoopError::UnknownController { name, allowed } => invalid(
                    format!("controllers[{i}]"),
                    name,
                    format!("one of {allowed}"),
                ),
                other => other,
            })?;
        }
        let c = &self.control;
        if let Some(f) = c.budget_fraction
            && !(f.is_finite() && f > 0.0 && f <= 1.0)
        {
            return Err(invalid(
                "control.budget_fraction",
                f,
                "0 < fraction <= 1 (of the MPC period)",
            ));
        }
        if c.bundle.is_some() || c.commission {
            let from = if c.bundle.is_some() {
                "control.bundle"
            } else {
                "control.commission"
            };
            for (key, given) in [
                ("control.spindle_model", c.spindle_model.is_some()),
                ("control.force_model", c.force_model.is_some()),
                ("control.commission", c.commission && c.bundle.is_some()),
            ] {
                if given {
                    return Err(invalid(
                        key,
                        "given",
                        format!(
                            "not together with {from}: the bundle provides the controllers' models"
                        ),
                    ));
                }
            }
            if self.stage != StageKind::Groove {
                return Err(invalid(
                    from,
                    "given",
                    "only for stage = \"groove\" (the thin wall is not commissioned yet)",
                ));
            }
        }
        match self.stage {
            StageKind::Groove => {
                let g = self.groove.as_ref().ok_or_else(|| {
                    invalid(
                        "groove",
                        "missing",
                        "a [groove] table for stage = \"groove\"",
                    )
                })?;
                if !(g.tilt_deg.is_finite() && g.tilt_deg > 0.0 && g.tilt_deg < 90.0) {
                    return Err(invalid(
                        "groove.tilt_deg",
                        g.tilt_deg,
                        "0 < tilt_deg < 90 (the PZT moves the tip radially)",
                    ));
                }
                finite_nonneg("groove.wearland_um", g.wearland_um)?;
                finite_pos("groove.speed_rpm", g.speed_rpm)?;
                finite_pos("groove.upfeed_um", g.upfeed_um)?;
                finite_pos_at_most("groove.length_mm", g.length_mm, MAX_LENGTH_MM)?;
                g.depth.validate(400.0).map_err(|e| {
                    invalid(
                        "groove.depth",
                        e,
                        "depths within 0 ..= 400 µm (ball radius), steps sorted",
                    )
                })?;
                let mut last = f64::NEG_INFINITY;
                for (i, fs) in g.feed_steps.iter().enumerate() {
                    if !(fs.x_mm.is_finite() && fs.x_mm >= last && fs.x_mm <= g.length_mm) {
                        return Err(invalid(
                            format!("groove.feed_steps[{i}].x_mm"),
                            fs.x_mm,
                            "sorted, within 0 ..= length_mm",
                        ));
                    }
                    last = fs.x_mm;
                    finite_pos(&format!("groove.feed_steps[{i}].upfeed_um"), fs.upfeed_um)?;
                }
                finite_pos("groove.feed_accel_mm_s2", g.feed_accel_mm_s2)?;
                millcomp_sim::groove::check_entry_length(g.entry_length_mm, g.length_mm)
                    .map_err(sim_keyed("groove."))?;
                finite_nonneg("groove.approach_mm", g.approach_mm)?;
                if let Some(e) = g.exit {
                    // sim's own check; its parameter names (`exit.x_mm`, …) become scenario keys
                    e.validate(g.length_mm).map_err(sim_keyed("groove."))?;
                }
                if let Some(u) = g.calibrate_uncompensated_um {
                    finite_pos("groove.calibrate_uncompensated_um", u)?;
                }
            }
            StageKind::ThinWall => {
                let t = self.thin_wall.as_ref().ok_or_else(|| {
                    invalid(
                        "thin_wall",
                        "missing",
                        "a [thin_wall] table for stage = \"thin_wall\"",
                    )
                })?;
                if t.walls_um.is_empty() {
                    return Err(invalid("thin_wall.walls_um", "[]", "at least one wall"));
                }
                for (i, w) in t.walls_um.iter().enumerate() {
                    finite_pos(&format!("thin_wall.walls_um[{i}]"), *w)?;
                }
                finite_pos("thin_wall.height_um", t.height_um)?;
                finite_pos("thin_wall.ae_um", t.ae_um)?;
                finite_pos("thin_wall.ap_um", t.ap_um)?;
                finite_pos("thin_wall.fz_um", t.fz_um)?;
                finite_pos_at_most("thin_wall.length_mm", t.length_mm, MAX_LENGTH_MM)?;
            }
            StageKind::NcAxis => {
                self.nc()?;
            }
        }
        let tr = &self.truth;
        if !(tr.force_error_max.is_finite() && (0.0..=0.5).contains(&tr.force_error_max)) {
            return Err(invalid(
                "truth.force_error_max",
                tr.force_error_max,
                "0 ..= 0.5",
            ));
        }
        if let Some(fe) = tr.force_errors
            && !(fe.max_abs().is_finite() && fe.max_abs() <= 0.5)
        {
            return Err(invalid(
                "truth.force_errors",
                format!("{fe:?}"),
                "each |error| <= 0.5",
            ));
        }
        if self.stage != StageKind::ThinWall {
            for (key, given) in [
                ("truth.wall", tr.wall.is_some()),
                ("truth.draw_wall", tr.draw_wall),
            ] {
                if given {
                    return Err(invalid(
                        key,
                        "given",
                        "only for stage = \"thin_wall\" (the groove's part is its tool and material)",
                    ));
                }
            }
        }
        if let Some(w) = tr.wall {
            w.validate().map_err(sim_keyed("truth.wall."))?;
        }
        if !(tr.stiffness_error.is_finite()
            && tr.stiffness_error > -0.9
            && tr.stiffness_error < 9.0)
        {
            return Err(invalid(
                "truth.stiffness_error",
                tr.stiffness_error,
                "-0.9 < stiffness_error < 9",
            ));
        }
        let sc = &tr.stiffness_calibration;
        finite_nonneg(
            "truth.stiffness_calibration.indicator_resolution_um",
            sc.indicator_resolution_um,
        )?;
        finite_nonneg("truth.stiffness_calibration.noise_um", sc.noise_um)?;
        if sc.trials == 0 {
            return Err(invalid("truth.stiffness_calibration.trials", 0, ">= 1"));
        }
        finite_nonneg("truth.force_noise_n", tr.force_noise_n)?;
        finite_nonneg("truth.gauge_noise_um", tr.gauge_noise_um)?;
        let c = &self.control;
        if !(c.dt_s.is_finite() && c.dt_s >= 1e-6 && c.dt_s <= 1e-3) {
            return Err(invalid("control.dt_s", c.dt_s, "1e-6 <= dt_s <= 1e-3"));
        }
        if let Some(g) = &self.groove {
            // the run's length in control steps, at its slowest feed, before anything is allocated
            let upfeed = g
                .feed_steps
                .iter()
                .map(|f| f.upfeed_um)
                .fold(g.upfeed_um, f64::min);
            let steps = g.length_mm / (g.speed_rpm / 60.0 * upfeed / 1000.0) / c.dt_s;
            if steps.is_nan() || steps > MAX_RUN_STEPS {
                return Err(invalid(
                    "groove.length_mm",
                    g.length_mm,
                    format!(
                        "a run of at most {MAX_RUN_STEPS:e} control steps: at {} rpm, {upfeed} um/rev and \
                         dt_s = {} s this groove takes {steps:.3e}",
                        g.speed_rpm, c.dt_s
                    ),
                ));
            }
        }
        if c.mpc_every == 0 {
            return Err(invalid("control.mpc_every", 0, ">= 1"));
        }
        if c.horizon == 0 || c.horizon > MAX_HORIZON {
            return Err(invalid(
                "control.horizon",
                c.horizon,
                format!("1 ..= {}", MAX_HORIZON),
            ));
        }
        finite_pos("control.slew_v_per_cycle", c.slew_v_per_cycle)?;
        if let TouchOffBias::Volts(v) = c.touch_off_bias {
            finite_nonneg("control.touch_off_bias.volts", v)?;
        }
        if c.touch_off_bias != TouchOffBias::Rest && self.stage != StageKind::Groove {
            return Err(invalid(
                "control.touch_off_bias",
                format!("{:?}", c.touch_off_bias),
                "rest (only the groove stage's PZT spindle is touched off at a bias)",
            ));
        }
        if let Some(m) = &c.mpc {
            m.validate_keys().map_err(|e| match e {
                MpcError::InvalidConfig {
                    key,
                    value,
                    allowed,
                } => ClosedLoopError::InvalidConfig {
                    key: format!("control.mpc.{key}"),
                    value,
                    allowed,
                },
                other => ClosedLoopError::Mpc(other),
            })?;
        }
        for (i, f) in self.faults.iter().enumerate() {
            let (t, ok) = match *f {
                Fault::ForceSpike {
                    t_s,
                    magnitude_n,
                    duration_s,
                } => (
                    t_s,
                    magnitude_n.is_finite() && duration_s.is_finite() && duration_s > 0.0,
                ),
                Fault::StuckSensor { t_s, duration_s } => {
                    (t_s, duration_s.is_finite() && duration_s > 0.0)
                }
                Fault::SolverFailure { t_s, cycles } => (t_s, cycles > 0),
            };
            if !(t.is_finite() && t >= 0.0 && ok) {
                return Err(invalid(
                    format!("faults[{i}]"),
                    format!("{f:?}"),
                    "t_s >= 0, finite magnitude, duration > 0, cycles > 0",
                ));
            }
        }
        Ok(())
    }
}

/// A scenario turned into its hard form. Grooves: instrument errors and a fresh tool drawn from the seed,
/// a PZT stack with hysteresis and creep, the controllers built from the commissioning of the truth alone
/// (the models it named, if any, dropped). Thin walls: every wall a real part drawn from the seed
/// (`truth.draw_wall`: its modulus and force coefficient off the published wall the controllers' model
/// keeps; the thin wall is not commissioned yet). Both: no deliberate force-model errors on top
/// (`truth.force_error_max` 0, `truth.force_errors` dropped) — what the controllers get wrong comes from
/// the plant, not from a perturbation laid on their model.
pub fn commissioned(s: &Scenario) -> Scenario {
    let mut s = s.clone();
    match s.stage {
        StageKind::Groove => {
            s.truth.draw_instruments = true;
            s.truth.draw_tool = true;
            s.truth.pzt_nonlinear = true;
            s.control.commission = true;
            s.control.bundle = None;
            s.control.spindle_model = None;
            s.control.force_model = None;
        }
        StageKind::ThinWall => {
            s.truth.draw_wall = true;
        }
        // always commissioned; its truth draws per seed
        StageKind::NcAxis => {}
    }
    s.truth.force_error_max = 0.0;
    s.truth.force_errors = None;
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const GROOVE: &str = r#"
name = "g20"
stage = "groove"
[groove]
tilt_deg = 20.0
depth = { kind = "ramp", from_um = 0.0, to_um = 80.0 }
"#;

    fn key(e: ClosedLoopError) -> String {
        match e {
            ClosedLoopError::InvalidConfig { key, .. } => key,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn parses_with_defaults() {
        let s = Scenario::from_toml_str(GROOVE, "g20.toml").unwrap();
        let g = s.groove.unwrap();
        assert_eq!(g.speed_rpm, 10_000.0);
        assert_eq!(s.truth.force_error_max, 0.0);
        assert_eq!(s.control.mpc_every, 10);
    }

    #[test]
    fn bad_values_name_the_key() {
        let t = GROOVE.replace("[groove]", "controllers = [\"pid\", \"lqr\"]\n[groove]");
        let e = Scenario::from_toml_str(&t, "x").unwrap_err();
        assert_eq!(key(e), "controllers[1]");
        let t = GROOVE.replace("[groove]", "[control]\nhorizon = 0\n[groove]");
        assert_eq!(
            key(Scenario::from_toml_str(&t, "x").unwrap_err()),
            "control.horizon"
        );
        let t = GROOVE.replace("tilt_deg = 20.0", "tilt_deg = 0.0");
        assert_eq!(
            key(Scenario::from_toml_str(&t, "x").unwrap_err()),
            "groove.tilt_deg"
        );
        let t = format!(
            "{}\n[control.mpc]\nhorizon = 10\n[control.mpc.weights]\noutput = [0.0, -1.0]\ninput_rate = [1e-5]\n[control.mpc.limits]\nu_min = [0.0]\nu_max = [1000.0]\ndu_max = [10.0]\n",
            GROOVE
        );
        assert_eq!(
            key(Scenario::from_toml_str(&t, "x").unwrap_err()),
            "control.mpc.weights.output[1]"
        );
        let t = t
            .replace("output = [0.0, -1.0]", "output = [0.0, 1.0]")
            .replace("u_min = [0.0]", "u_min = [2000.0]");
        assert_eq!(
            key(Scenario::from_toml_str(&t, "x").unwrap_err()),
            "control.mpc.limits.u_min[0]"
        );
        // process changes: the feed axis, the exit and the feed-change positions name their keys
        for (extra, want) in [
            ("feed_accel_mm_s2 = 0.0", "groove.feed_accel_mm_s2"),
            ("approach_mm = -1.0", "groove.approach_mm"),
            ("entry_length_mm = 25.0", "groove.entry_length_mm"),
            (
                "exit = { x_mm = 30.0, length_mm = 0.2 }",
                "groove.exit.x_mm",
            ),
            (
                "exit = { x_mm = 5.0, length_mm = 6.0 }",
                "groove.exit.length_mm",
            ),
            (
                "feed_steps = [{ x_mm = 25.0, upfeed_um = 20.0 }]",
                "groove.feed_steps[0].x_mm",
            ),
        ] {
            let t = GROOVE.replace("tilt_deg = 20.0", &format!("tilt_deg = 20.0\n{extra}"));
            assert_eq!(key(Scenario::from_toml_str(&t, "x").unwrap_err()), want);
        }
        let t = GROOVE.replace("tilt_deg = 20.0", "tilt_deg = 20.0\nbogus = 1");
        assert!(
            matches!(Scenario::from_toml_str(&t, "x").unwrap_err(), ClosedLoopError::Scenario { message, .. } if message.contains("bogus"))
        );
    }
}
