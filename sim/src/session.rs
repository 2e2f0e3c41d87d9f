//! Groove sessions: a TOML file describing tool, material, stiffness, effects and a plan of grooves and
//! pauses (schema in `sim/SESSION.md`); the plan played out once ([`Session::timeline`],
//! [`Session::contexts`]: the nominal context of every measured point); and [`simulate_session`], which
//! predicts every measured point as a [`GroovePoint`] — one row of the measured-groove contract, whose
//! columns and file adapters live in `millcomp-datasets` (`contracts`). [`FluteForcePoint`] is one row of
//! the per-flute force trace.
//!
//! Prediction per point (quasi-static, per-revolution peak force as in `000_…txt` §6.2):
//! `depth_meas = depth_cmd − δz + Σ effect offsets (+ noise)`, with `δz = Fz,peak(depth_cmd − δz)·(1/kz)`
//! solved by fixed-point iteration on a per-groove table of peak z-force vs actual depth. Effect offsets do
//! not feed back into the force (second order).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

use crate::effects::{AMBIENT_C, Effect, EffectContext, effect_from_params};
use crate::error::SimError;
use crate::force::{BallEndForceModel, CutConditions, FlankLaw, ForceParams};
use crate::groove::DepthProfile;
use crate::material::Material;
use crate::sensors::{NoiseSource, NoiseSpec};
use crate::stiffness::TiltedToolStiffness;
use crate::tool::BallEndTool;

/// `[tool]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    /// Ball radius (µm), default 400.
    #[serde(default = "d_radius")]
    pub radius_um: f64,
    /// Wearland (µm), default 8.
    #[serde(default = "d_wearland")]
    pub wearland_um: f64,
    /// Runout (µm), default 10.
    #[serde(default = "d_runout")]
    pub runout_um: f64,
}
fn d_radius() -> f64 {
    400.0
}
fn d_wearland() -> f64 {
    8.0
}
fn d_runout() -> f64 {
    10.0
}

/// `[material]` table: a named material with optional overrides.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// `S7`, `1018`, `6061`, `H59`, `C45`.
    pub name: String,
    /// Override of W (MPa).
    pub w_mpa: Option<f64>,
    /// Override of E (GPa).
    pub e_gpa: Option<f64>,
    /// Override of µ.
    pub mu_rake: Option<f64>,
    /// Override of µf.
    pub mu_flank: Option<f64>,
}

/// `[force_model]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceModelSpec {
    /// Multiplier on all forces (default 1).
    #[serde(default = "d_one")]
    pub force_scale: f64,
    /// Shear angle (deg), default 50.
    #[serde(default = "d_shear")]
    pub shear_angle_deg: f64,
    /// `flow_stress` (default) or `elastic_recovery`.
    #[serde(default = "d_law")]
    pub flank_law: String,
    /// Factor for `flow_stress` (default π/4).
    #[serde(default = "d_factor")]
    pub flank_factor: f64,
    /// Constant for `elastic_recovery` (default 9.24).
    #[serde(default = "d_c")]
    pub flank_c: f64,
}
fn d_one() -> f64 {
    1.0
}
fn d_shear() -> f64 {
    50.0
}
fn d_law() -> String {
    "flow_stress".into()
}
fn d_factor() -> f64 {
    PI / 4.0
}
fn d_c() -> f64 {
    9.24
}

impl Default for ForceModelSpec {
    fn default() -> Self {
        Self {
            force_scale: 1.0,
            shear_angle_deg: 50.0,
            flank_law: d_law(),
            flank_factor: d_factor(),
            flank_c: d_c(),
        }
    }
}

/// `[stiffness]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StiffnessSpec {
    /// Axial (spindle) stiffness (N/µm), default 1.220.
    #[serde(default = "d_axial")]
    pub axial_n_per_um: f64,
    /// Radial (tool) stiffness (N/µm), default 0.114.
    #[serde(default = "d_radial")]
    pub radial_n_per_um: f64,
}
fn d_axial() -> f64 {
    1.220
}
fn d_radial() -> f64 {
    0.114
}
impl Default for StiffnessSpec {
    fn default() -> Self {
        Self {
            axial_n_per_um: d_axial(),
            radial_n_per_um: d_radial(),
        }
    }
}

/// `[[effects]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    /// Effect name (see `effects::EFFECT_NAMES`).
    pub name: String,
    /// Whether it is applied (default true).
    #[serde(default = "d_true")]
    pub enabled: bool,
    /// Parameters (missing ones take the seed defaults).
    #[serde(default)]
    pub params: BTreeMap<String, f64>,
}
fn d_true() -> bool {
    true
}

/// One groove of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GrooveSpec {
    /// Session time at which the cut starts (s); default: when the previous item ends.
    pub start_s: Option<f64>,
    /// Spindle speed (rpm).
    pub speed_rpm: f64,
    /// Upfeed (µm/rev); give this or `feed_mm_min`.
    pub upfeed_um: Option<f64>,
    /// Feed rate (mm/min); give this or `upfeed_um`.
    pub feed_mm_min: Option<f64>,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Coolant state from the start of this groove on (default: unchanged; initially off).
    pub coolant: Option<bool>,
    /// Groove length (mm).
    pub length_mm: f64,
    /// Machine X of the groove start (mm), default 0.
    #[serde(default)]
    pub x_offset_mm: f64,
    /// Spacing of the measured points (mm).
    pub measure_every_mm: f64,
    /// Programmed depth profile.
    pub depth: DepthProfile,
}

/// A pause of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PauseSpec {
    /// Duration (s).
    pub duration_s: f64,
    /// Spindle speed during the pause (rpm), default 0.
    #[serde(default)]
    pub speed_rpm: f64,
    /// Coolant state during the pause (default: unchanged).
    pub coolant: Option<bool>,
}

/// A plan item.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum PlanItem {
    /// A groove.
    Groove(GrooveSpec),
    /// A pause.
    Pause(PauseSpec),
}

/// A session file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Session {
    /// Name.
    #[serde(default)]
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Tool.
    pub tool: ToolSpec,
    /// Material.
    pub material: MaterialSpec,
    /// Force-model constants.
    #[serde(default)]
    pub force_model: ForceModelSpec,
    /// Stiffness.
    #[serde(default)]
    pub stiffness: StiffnessSpec,
    /// How far the nominal model may be off (1σ), and the measuring instrument: the priors of
    /// `diagnose`'s nuisance step. Not used by the simulation; omitted from a written file when it
    /// holds the defaults.
    #[serde(default, skip_serializing_if = "UncertaintySpec::is_default")]
    pub uncertainty: UncertaintySpec,
    /// Effects present in the simulated truth.
    #[serde(default)]
    pub effects: Vec<EffectSpec>,
    /// Plan of grooves and pauses, in time order.
    pub plan: Vec<PlanItem>,
}

/// `[uncertainty]` table: the stated uncertainty (one standard deviation) of the session's nominal
/// model and of the depth measurement — what a user knows about how far the force model,
/// stiffness, wearland and tool-length reference (touch-off) may be off (`sim/SESSION.md`). Each
/// default reads a range of the seeds as a uniform distribution (SD = half-range/√3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertaintySpec {
    /// Force scale (%), default 3: ±5 % (000 §6.1: 17 µm deflection predicted, 16 µm measured).
    #[serde(default = "d_force_scale_pct")]
    pub force_scale_pct: f64,
    /// Axial (spindle) stiffness (%), default 6: ±10 %.
    #[serde(default = "d_stiffness_pct")]
    pub axial_stiffness_pct: f64,
    /// Radial (tool) stiffness (%), default 6: ±10 % (000 Tab. 5-1: 0.141 modelled, 0.114 measured).
    #[serde(default = "d_stiffness_pct")]
    pub radial_stiffness_pct: f64,
    /// Wearland (µm), default 1.2: ±2 µm (a wearland read as 7 instead of 8 µm).
    #[serde(default = "d_wearland_sd")]
    pub wearland_um: f64,
    /// Tool-length reference, touch-off (µm), default 1: 002 §4, positioning repeatability "in
    /// the order of 1 µm". `inf` leaves the offset free.
    #[serde(default = "d_touch_off_sd")]
    pub touch_off_um: f64,
    /// Depth measurement noise (µm), default 0.1 (002 §7.9 profilometer).
    #[serde(default = "d_measurement_sd")]
    pub measurement_sd_um: f64,
    /// Groove-to-groove scatter (µm), default 0.5 (002 §7.9: 60 grooves of 50 µm measured
    /// 52.7 ± 1 µm). Used where the data cannot estimate it (few grooves, the plan's analysis).
    #[serde(default = "d_groove_scatter")]
    pub groove_scatter_um: f64,
    /// Smallest depth change the measurement resolves (µm), default 0.15 (002 §7.9: profilometer
    /// repeatability ±2σ < 0.15 µm).
    #[serde(default = "d_resolution")]
    pub resolution_um: f64,
}
fn d_force_scale_pct() -> f64 {
    3.0
}
fn d_stiffness_pct() -> f64 {
    6.0
}
fn d_wearland_sd() -> f64 {
    1.2
}
fn d_touch_off_sd() -> f64 {
    1.0
}
fn d_measurement_sd() -> f64 {
    0.1
}
fn d_groove_scatter() -> f64 {
    0.5
}
fn d_resolution() -> f64 {
    0.15
}

impl Default for UncertaintySpec {
    fn default() -> Self {
        Self {
            force_scale_pct: d_force_scale_pct(),
            axial_stiffness_pct: d_stiffness_pct(),
            radial_stiffness_pct: d_stiffness_pct(),
            wearland_um: d_wearland_sd(),
            touch_off_um: d_touch_off_sd(),
            measurement_sd_um: d_measurement_sd(),
            groove_scatter_um: d_groove_scatter(),
            resolution_um: d_resolution(),
        }
    }
}

impl UncertaintySpec {
    /// Whether every value is the default (the table is then not written).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Checks every value: a standard deviation ≥ 0 (`inf` allowed for the priors, a free
    /// parameter), the measurement's noise and resolution finite and > 0.
    ///
    /// # Errors
    /// [`SimError::Session`] naming the key `uncertainty.<field>`.
    pub fn validate(&self) -> Result<(), SimError> {
        for (k, v) in [
            ("force_scale_pct", self.force_scale_pct),
            ("axial_stiffness_pct", self.axial_stiffness_pct),
            ("radial_stiffness_pct", self.radial_stiffness_pct),
            ("wearland_um", self.wearland_um),
            ("touch_off_um", self.touch_off_um),
            ("groove_scatter_um", self.groove_scatter_um),
        ] {
            if v.is_nan() || v < 0.0 {
                return Err(sess_err(
                    format!("uncertainty.{k}"),
                    format!("= {v} out of range: allowed >= 0 (inf: free)"),
                ));
            }
        }
        for (k, v) in [
            ("measurement_sd_um", self.measurement_sd_um),
            ("resolution_um", self.resolution_um),
        ] {
            in_range(format!("uncertainty.{k}"), v, 1e-9, 1e6, "0 < value <= 1e6")?;
        }
        if self.groove_scatter_um.is_infinite() {
            return Err(sess_err(
                "uncertainty.groove_scatter_um",
                "= inf out of range: allowed a finite value >= 0",
            ));
        }
        Ok(())
    }
}

/// Options of [`simulate_session`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct SimOptions {
    /// Gaussian measurement noise on `depth_meas_um` (σ in µm), seeded; `None` = noise-free.
    pub noise: Option<NoiseSpec>,
}

/// One measured point: exactly the DESIGN.md measured-groove CSV columns.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GroovePoint {
    /// Groove index in the plan (0-based, grooves only).
    pub groove_id: i64,
    /// Session clock when this point was cut (s).
    pub t_s: f64,
    /// Position along the groove (mm).
    pub x_mm: f64,
    /// Cumulative engaged length of the tool at this point (mm).
    pub cut_length_mm: f64,
    /// Spindle speed (rpm).
    pub speed_rpm: f64,
    /// Feed rate (mm/min).
    pub feed_mm_min: f64,
    /// Upfeed (µm/rev).
    pub upfeed_um: f64,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Coolant on (1) or off (0).
    pub coolant_on: u8,
    /// Programmed depth (µm).
    pub depth_cmd_um: f64,
    /// Predicted (or measured) depth (µm).
    pub depth_meas_um: f64,
    /// Spindle temperature (°C), present when a spindle thermal model is active.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub spindle_temp_c: Option<f64>,
}

/// One row of a flute force trace: the peak z-force of each flute over the revolution in which a
/// measured point was cut (the per-flute peak-and-hold of `000_…txt` §6.2). Flute runout shows in the
/// asymmetry between the two flutes (§4), which a depth profile barely shows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FluteForcePoint {
    /// Groove index, as in the measured-groove points.
    pub groove_id: i64,
    /// Position along the groove (mm); matches a measured point.
    pub x_mm: f64,
    /// Peak z-force of flute 1, the flute closer to the axis (smaller chip) (N).
    pub fz_peak_flute1_n: f64,
    /// Peak z-force of flute 2, the flute that runout makes cut more (N).
    pub fz_peak_flute2_n: f64,
}

/// The type of a measured-groove column's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeasuredKind {
    /// An integer (`groove_id`).
    Int,
    /// A finite number.
    Float,
    /// 0 or 1 (`coolant_on`).
    Flag,
}

/// **The measured-groove contract** (DESIGN.md "Measured groove session"), defined once, here beside its
/// row type [`GroovePoint`]: every required column in contract order with the type of its cells and
/// what it holds. The rules a file of it must keep are [`check_groove_points`]; `millcomp-datasets`
/// reads and writes files by both (its `contracts` module), `millcomp-diagnose` checks points from any
/// source by the same function.
pub const MEASURED_GROOVE: [(&str, MeasuredKind, &str); 11] = [
    ("groove_id", MeasuredKind::Int, "groove number"),
    (
        "t_s",
        MeasuredKind::Float,
        "session clock when this point was cut",
    ),
    ("x_mm", MeasuredKind::Float, "position along the groove"),
    (
        "cut_length_mm",
        MeasuredKind::Float,
        "cumulative engaged length of the tool",
    ),
    ("speed_rpm", MeasuredKind::Float, "spindle speed"),
    ("feed_mm_min", MeasuredKind::Float, "feed rate"),
    ("upfeed_um", MeasuredKind::Float, "feed per revolution"),
    ("tilt_deg", MeasuredKind::Float, "tool tilt"),
    ("coolant_on", MeasuredKind::Flag, "coolant flowing (0/1)"),
    ("depth_cmd_um", MeasuredKind::Float, "programmed depth"),
    (
        "depth_meas_um",
        MeasuredKind::Float,
        "measured groove depth",
    ),
];

/// The optional measured-groove column (written when a point has a spindle temperature).
pub const SPINDLE_TEMP_COLUMN: &str = "spindle_temp_c";

/// Version of the measured-groove contract this build writes. Version 2 renamed `spindle_rpm` to
/// `speed_rpm` (one name per quantity across millcomp); files of version 1 are still read.
pub const MEASURED_GROOVE_VERSION: u32 = 2;

/// Columns renamed since version 1 of the measured-groove contract: (version-1 name, current name).
pub const MEASURED_GROOVE_V1_NAMES: [(&str, &str); 1] = [("spindle_rpm", "speed_rpm")];

/// The rules of the measured-groove contract — the one validator, whether the points were read from a
/// file or built by a program: every value finite; `coolant_on` 0 or 1; a cut's `speed_rpm`,
/// `feed_mm_min` and `upfeed_um` > 0 (a negative speed or feed is a sign error, not a cut);
/// 0 ≤ `tilt_deg` < 90; `cut_length_mm` and `depth_cmd_um` ≥ 0; and `t_s` strictly increasing within
/// each groove. The error ([`SimError::Point`]) names the row — counted from 1, the first point being
/// row 1 (in a file, the first data row: `millcomp-datasets` numbers rows so) — and the column.
///
/// ```
/// use millcomp_sim::SimError;
/// use millcomp_sim::session::{check_groove_points, GroovePoint};
/// let p = GroovePoint {
///     groove_id: 0, t_s: 0.0, x_mm: 0.0, cut_length_mm: 0.0, speed_rpm: 10_000.0,
///     feed_mm_min: 100.0, upfeed_um: 10.0, tilt_deg: 20.0, coolant_on: 1,
///     depth_cmd_um: 0.0, depth_meas_um: 0.1, spindle_temp_c: None,
/// };
/// let later = GroovePoint { t_s: 0.6, x_mm: 1.0, ..p };
/// assert!(check_groove_points(&[p, later]).is_ok());
/// let reversed = GroovePoint { speed_rpm: -10_000.0, ..later };
/// let e = check_groove_points(&[p, reversed]).unwrap_err();
/// assert!(matches!(e, SimError::Point { row: 2, column: "speed_rpm", .. }), "{e}");
/// ```
///
/// # Errors
/// [`SimError::Point`] for the first row and column that break a rule.
pub fn check_groove_points(points: &[GroovePoint]) -> Result<(), SimError> {
    let mut last: std::collections::HashMap<i64, f64> = std::collections::HashMap::new();
    for (i, p) in points.iter().enumerate() {
        let row = i + 1;
        let fail = |column: &'static str, message: String| SimError::Point {
            row,
            column,
            message,
        };
        let fields = [
            ("t_s", p.t_s),
            ("x_mm", p.x_mm),
            ("cut_length_mm", p.cut_length_mm),
            ("speed_rpm", p.speed_rpm),
            ("feed_mm_min", p.feed_mm_min),
            ("upfeed_um", p.upfeed_um),
            ("tilt_deg", p.tilt_deg),
            ("depth_cmd_um", p.depth_cmd_um),
            ("depth_meas_um", p.depth_meas_um),
            (SPINDLE_TEMP_COLUMN, p.spindle_temp_c.unwrap_or(0.0)),
        ];
        for (column, v) in fields {
            if !v.is_finite() {
                return Err(fail(column, format!("{v} is not a finite number")));
            }
        }
        if p.coolant_on > 1 {
            return Err(fail(
                "coolant_on",
                format!("{} is not 0 or 1", p.coolant_on),
            ));
        }
        for (column, v, what) in [
            ("speed_rpm", p.speed_rpm, "a spindle speed"),
            ("feed_mm_min", p.feed_mm_min, "a feed rate"),
            ("upfeed_um", p.upfeed_um, "a feed per revolution"),
        ] {
            if v <= 0.0 {
                return Err(fail(
                    column,
                    format!("{v}: {what} of a cut is > 0 (a sign or unit error?)"),
                ));
            }
        }
        if !(0.0..90.0).contains(&p.tilt_deg) {
            return Err(fail(
                "tilt_deg",
                format!("{}: allowed 0 <= tilt_deg < 90", p.tilt_deg),
            ));
        }
        for (column, v) in [
            ("cut_length_mm", p.cut_length_mm),
            ("depth_cmd_um", p.depth_cmd_um),
        ] {
            if v < 0.0 {
                return Err(fail(column, format!("{v}: allowed >= 0")));
            }
        }
        if let Some(&prev) = last.get(&p.groove_id)
            && p.t_s <= prev
        {
            return Err(fail(
                "t_s",
                format!(
                    "time {} s is not after the previous point of groove {} ({prev} s); \
                     t_s must increase within a groove",
                    p.t_s, p.groove_id
                ),
            ));
        }
        last.insert(p.groove_id, p.t_s);
    }
    Ok(())
}

fn sess_err(key: impl Into<String>, message: impl Into<String>) -> SimError {
    SimError::Session {
        key: key.into(),
        message: message.into(),
    }
}

fn in_range(key: String, v: f64, lo: f64, hi: f64, allowed: &str) -> Result<f64, SimError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(sess_err(
            key,
            format!("= {v} out of range: allowed {allowed}"),
        ))
    }
}

/// Re-key a parameter error under a session key path.
fn rekey(prefix: &str, e: SimError) -> SimError {
    match e {
        SimError::InvalidParameter {
            name,
            value,
            allowed,
        } => sess_err(
            format!("{prefix}.{name}"),
            format!("= {value} out of range: allowed {allowed}"),
        ),
        other => other,
    }
}

impl Session {
    /// Parse and validate a session from TOML text; errors name the key.
    ///
    /// # Errors
    /// * [`SimError::SessionToml`] when the text is not TOML or not a session: a required key is
    ///   missing, a key is unknown (anywhere) or of the wrong type; `key` is the key the parser
    ///   names (`<toml>` when it names none), the parser's error (with the line) is the source.
    /// * [`SimError::Session`] when [`Self::validate`] rejects a value, with its key path: a
    ///   number out of range (`plan[2].tilt_deg`, `tool.wearland_um`, …), an unknown material,
    ///   flank law, effect or effect parameter, an empty `plan`, or a groove giving both or neither
    ///   of `upfeed_um` and `feed_mm_min`.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::SimError;
    /// use millcomp_sim::session::{PlanItem, Session};
    /// let text = r#"
    /// name = "one groove"
    /// [tool]
    /// wearland_um = 8.0
    /// [material]
    /// name = "S7"
    /// [[plan]]
    /// kind = "groove"
    /// speed_rpm = 10000.0
    /// upfeed_um = 10.0
    /// tilt_deg = 20.0
    /// length_mm = 2.0
    /// measure_every_mm = 1.0
    /// depth = { kind = "constant", depth_um = 80.0 }
    /// "#;
    /// let s = Session::from_toml_str(text).unwrap();
    /// // omitted keys take their defaults: runout 10 µm, Table 5-1 measured stiffness (000 §5.2.3)
    /// assert_eq!(s.tool.runout_um, 10.0);
    /// let kz = s.stiffness().unwrap().z_stiffness_n_per_um(20.0).unwrap();
    /// assert!((kz - 0.5715).abs() < 1e-4);
    /// // 10 µm/rev at 10 000 rpm is 100 mm/min: the 2 mm groove takes 1.2 s
    /// let PlanItem::Groove(g) = &s.plan[0] else { unreachable!() };
    /// assert!((g.duration_s() - 1.2).abs() < 1e-12);
    ///
    /// // a value out of range is named by its key path ...
    /// let e = Session::from_toml_str(&text.replace("tilt_deg = 20.0", "tilt_deg = 95.0")).unwrap_err();
    /// assert!(matches!(&e, SimError::Session { key, .. } if key == "plan[0].tilt_deg"));
    /// // ... and an unknown key by the parser
    /// let e = Session::from_toml_str(&text.replace("upfeed_um", "upfeed")).unwrap_err();
    /// assert!(matches!(&e, SimError::SessionToml { key, .. } if key == "upfeed"));
    /// ```
    pub fn from_toml_str(text: &str) -> Result<Self, SimError> {
        let s: Session = toml::from_str(text).map_err(|source| SimError::SessionToml {
            key: extract_backticked(source.message()).unwrap_or_else(|| "<toml>".into()),
            source: Box::new(source),
        })?;
        s.validate()?;
        Ok(s)
    }

    /// Read, parse and validate a session file.
    ///
    /// # Errors
    /// [`SimError::Io`] (with the path, the OS error as source) when the file cannot be read;
    /// otherwise as [`Self::from_toml_str`].
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self, SimError> {
        let p = path.as_ref();
        let text = std::fs::read_to_string(p).map_err(|source| SimError::Io {
            path: p.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text)
    }

    /// The material with overrides applied.
    ///
    /// # Errors
    /// [`SimError::Session`]: key `material.name` for an unknown material, `material.<field>` for
    /// an override out of range.
    pub fn material(&self) -> Result<Material, SimError> {
        let mut m = Material::by_name(&self.material.name)?;
        if let Some(v) = self.material.w_mpa {
            m.w_mpa = v;
        }
        if let Some(v) = self.material.e_gpa {
            m.e_gpa = v;
        }
        if let Some(v) = self.material.mu_rake {
            m.mu_rake = v;
        }
        if let Some(v) = self.material.mu_flank {
            m.mu_flank = v;
        }
        m.validate().map_err(|e| rekey("material", e))?;
        Ok(m)
    }

    /// The force model described by the session.
    ///
    /// # Errors
    /// [`SimError::Session`] naming the key: `tool.<field>` or `force_model.<field>` out of range,
    /// `force_model.flank_law` unknown, or as [`Self::material`].
    pub fn force_model(&self) -> Result<BallEndForceModel, SimError> {
        let tool = BallEndTool::new(
            self.tool.radius_um,
            self.tool.wearland_um,
            self.tool.runout_um,
        )
        .map_err(|e| rekey("tool", e))?;
        let law = match self.force_model.flank_law.as_str() {
            "flow_stress" => FlankLaw::FlowStress {
                factor: self.force_model.flank_factor,
            },
            "elastic_recovery" => FlankLaw::ElasticRecovery {
                c: self.force_model.flank_c,
            },
            other => {
                return Err(sess_err(
                    "force_model.flank_law",
                    format!("unknown law `{other}`; allowed flow_stress, elastic_recovery"),
                ));
            }
        };
        BallEndForceModel::new(
            self.material()?,
            tool,
            ForceParams {
                shear_angle_deg: self.force_model.shear_angle_deg,
                flank_law: law,
                force_scale: self.force_model.force_scale,
            },
        )
        .map_err(|e| rekey("force_model", e))
    }

    /// The stiffness described by the session.
    ///
    /// # Errors
    /// [`SimError::Session`] (`stiffness.axial_n_per_um` or `stiffness.radial_n_per_um`) for a
    /// stiffness that is not a finite positive number.
    pub fn stiffness(&self) -> Result<TiltedToolStiffness, SimError> {
        TiltedToolStiffness::new(
            self.stiffness.axial_n_per_um,
            self.stiffness.radial_n_per_um,
        )
        .map_err(|e| rekey("stiffness", e))
    }

    /// The enabled effects.
    ///
    /// # Errors
    /// [`SimError::Session`]: `effects[i].name` for an unknown effect, `effects[i].params.<name>`
    /// for an unknown or out-of-range parameter (disabled effects are checked too).
    pub fn effects(&self) -> Result<Vec<Box<dyn Effect>>, SimError> {
        let mut out = Vec::new();
        for (i, e) in self.effects.iter().enumerate() {
            let eff = effect_from_params(&e.name, &e.params).map_err(|err| match err {
                SimError::UnknownEffect { name, allowed } => sess_err(
                    format!("effects[{i}].name"),
                    format!("unknown effect `{name}`; allowed {allowed}"),
                ),
                SimError::EffectParameter { param, message, .. } => {
                    sess_err(format!("effects[{i}].params.{param}"), message)
                }
                other => other,
            })?;
            if e.enabled {
                out.push(eff);
            }
        }
        Ok(out)
    }

    /// Validate everything; errors name the key (`plan[2].tilt_deg`, …).
    ///
    /// # Errors
    /// [`SimError::Session`]: as [`Self::force_model`], [`Self::stiffness`], [`Self::effects`] and
    /// [`UncertaintySpec::validate`];
    /// `plan` when the plan is empty; `plan[i].<field>` for a groove or pause value out of range
    /// (`start_s`, `speed_rpm`, `tilt_deg`, `length_mm`, `measure_every_mm`, `x_offset_mm`,
    /// `upfeed_um` / `feed_mm_min` — exactly one of them —, `duration_s`, `depth.<field>` deeper
    /// than the ball radius or unsorted).
    pub fn validate(&self) -> Result<(), SimError> {
        let fm = self.force_model()?;
        self.stiffness()?;
        self.effects()?;
        self.uncertainty.validate()?;
        if self.plan.is_empty() {
            return Err(sess_err("plan", "the plan has no items"));
        }
        let r = fm.tool.radius_um;
        for (i, item) in self.plan.iter().enumerate() {
            match item {
                PlanItem::Groove(g) => {
                    let k = |f: &str| format!("plan[{i}].{f}");
                    if let Some(t) = g.start_s {
                        in_range(k("start_s"), t, 0.0, 1e9, "0 <= start_s")?;
                    }
                    in_range(
                        k("speed_rpm"),
                        g.speed_rpm,
                        1e-9,
                        1e6,
                        "0 < speed_rpm <= 1e6",
                    )?;
                    in_range(
                        k("tilt_deg"),
                        g.tilt_deg,
                        0.0,
                        89.999_999,
                        "0 <= tilt_deg < 90",
                    )?;
                    in_range(
                        k("length_mm"),
                        g.length_mm,
                        1e-9,
                        1e4,
                        "0 < length_mm <= 1e4",
                    )?;
                    in_range(
                        k("measure_every_mm"),
                        g.measure_every_mm,
                        1e-4,
                        g.length_mm.max(1e-4),
                        "0.0001 <= measure_every_mm <= length_mm",
                    )?;
                    in_range(
                        k("x_offset_mm"),
                        g.x_offset_mm,
                        -1e5,
                        1e5,
                        "|x_offset_mm| <= 1e5",
                    )?;
                    match (g.upfeed_um, g.feed_mm_min) {
                        (Some(u), None) => {
                            in_range(k("upfeed_um"), u, 1e-9, 1e3, "0 < upfeed_um <= 1000")?;
                        }
                        (None, Some(f)) => {
                            in_range(k("feed_mm_min"), f, 1e-9, 1e6, "0 < feed_mm_min")?;
                        }
                        _ => {
                            return Err(sess_err(
                                k("upfeed_um"),
                                "give exactly one of upfeed_um or feed_mm_min",
                            ));
                        }
                    }
                    g.depth
                        .validate(r)
                        .map_err(|e| rekey(&format!("plan[{i}].depth"), e))?;
                }
                PlanItem::Pause(p) => {
                    in_range(
                        format!("plan[{i}].duration_s"),
                        p.duration_s,
                        0.0,
                        1e9,
                        "0 <= duration_s",
                    )?;
                    in_range(
                        format!("plan[{i}].speed_rpm"),
                        p.speed_rpm,
                        0.0,
                        1e6,
                        "0 <= speed_rpm <= 1e6",
                    )?;
                }
            }
        }
        Ok(())
    }
}

fn extract_backticked(msg: &str) -> Option<String> {
    let a = msg.find('`')?;
    let b = msg[a + 1..].find('`')?;
    Some(msg[a + 1..a + 1 + b].to_string())
}

impl GrooveSpec {
    /// Upfeed (µm/rev), from `upfeed_um` or `feed_mm_min`.
    pub fn upfeed(&self) -> f64 {
        match (self.upfeed_um, self.feed_mm_min) {
            (Some(u), _) => u,
            (None, Some(f)) => f * 1e3 / self.speed_rpm,
            _ => 0.0,
        }
    }

    /// Feed rate (mm/min).
    pub fn feed(&self) -> f64 {
        self.upfeed() * self.speed_rpm * 1e-3
    }

    /// Cut duration (s).
    pub fn duration_s(&self) -> f64 {
        self.length_mm / (self.feed() / 60.0)
    }
}

/// Peak z-force vs actual depth on a grid (linear interpolation).
struct PeakTable {
    step_um: f64,
    f: Vec<f64>,
}

impl PeakTable {
    fn new(
        model: &BallEndForceModel,
        base: CutConditions,
        max_depth: f64,
    ) -> Result<Self, SimError> {
        let step = 0.25;
        let n = (max_depth / step).ceil() as usize + 2;
        let mut f = Vec::with_capacity(n);
        for k in 0..n {
            let mut c = base;
            c.depth_um = (k as f64 * step).min(model.tool.radius_um);
            f.push(model.peak_z_force_n(&c)?);
        }
        Ok(Self { step_um: step, f })
    }
    fn at(&self, d: f64) -> f64 {
        let x = (d.max(0.0) / self.step_um).min((self.f.len() - 1) as f64);
        let i = (x.floor() as usize).min(self.f.len() - 2);
        let w = x - i as f64;
        self.f[i] * (1.0 - w) + self.f[i + 1] * w
    }
}

/// The static deflection δ solving `δ = c·F(d_cmd − δ)` (F the peak z-force table, c the
/// z-compliance): the fixed-point iteration, and — where it does not settle, which happens at
/// shallow depths where F jumps from 0 at first contact and the iteration oscillates between 0 and
/// c·F(d_cmd) — bisection on `g(δ) = δ − c·F(d_cmd − δ)`, which increases strictly in δ (F does not
/// decrease with depth), so its root in `[0, c·F(d_cmd)]` is unique.
fn static_deflection(table: &PeakTable, d_cmd: f64, compliance: f64) -> f64 {
    let mut delta = 0.0;
    for _ in 0..200 {
        let next = table.at(d_cmd - delta) * compliance;
        if (next - delta).abs() < 1e-10 {
            return next;
        }
        delta = next;
    }
    let g = |d: f64| d - table.at(d_cmd - d) * compliance;
    let (mut lo, mut hi) = (0.0, (table.at(d_cmd) * compliance).max(0.0));
    if g(lo) >= 0.0 {
        return lo;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-10 {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The session's time line, replayed once from the plan (`sim/SESSION.md` "Semantics"): when each
/// plan item starts, and the coolant and spindle events that effects read ([`EffectContext`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Timeline {
    /// Start of each plan item (s), in plan order (grooves and pauses).
    pub item_start_s: Vec<f64>,
    /// Coolant switch events `(t_s, on)`, sorted; the coolant is off before the first.
    pub coolant_events: Vec<(f64, bool)>,
    /// Spindle speed events `(t_s, rpm)`, sorted; 0 rpm before the first.
    pub spindle_events: Vec<(f64, f64)>,
}

/// One planned measured point before any effect and without noise: where and when it is cut, its cut
/// conditions, and the nominal depth, force and compliance at which effects are evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointContext {
    /// Groove index in the plan (0-based, grooves only).
    pub groove_id: i64,
    /// Session clock when the point is cut (s).
    pub t_s: f64,
    /// Position along the groove (mm).
    pub x_mm: f64,
    /// Machine X of the point (mm) = groove `x_offset_mm` + `x_mm`.
    pub machine_x_mm: f64,
    /// Cumulative engaged length of the tool (mm).
    pub cut_length_mm: f64,
    /// Spindle speed (rpm).
    pub speed_rpm: f64,
    /// Feed rate (mm/min).
    pub feed_mm_min: f64,
    /// Upfeed (µm/rev).
    pub upfeed_um: f64,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Coolant flowing at this point.
    pub coolant_on: bool,
    /// Programmed depth (µm).
    pub depth_cmd_um: f64,
    /// Nominal depth: programmed depth minus the static z-deflection `δz` (µm), noise-free and
    /// without effects (may be negative where the tool does not reach the surface).
    pub depth_nominal_um: f64,
    /// Nominal actual depth `max(depth_nominal_um, 0)` (µm).
    pub depth_actual_um: f64,
    /// Nominal per-revolution peak z-force at the actual depth (N).
    pub force_z_n: f64,
    /// z-force per µm² of extra chip on the peak flute (N/µm²): scale·µ·Kc·cos(φ/2).
    pub chip_force_z_n_per_um2: f64,
    /// z-compliance of the tilted tool (µm/N).
    pub z_compliance_um_per_n: f64,
    /// Number of [`Timeline::coolant_events`] at or before `t_s`.
    pub n_coolant_events: usize,
    /// Number of [`Timeline::spindle_events`] at or before `t_s`.
    pub n_spindle_events: usize,
}

impl PointContext {
    /// The measured-groove row of this planned point with the given measured depth (no spindle
    /// temperature).
    pub fn measured(&self, depth_meas_um: f64) -> GroovePoint {
        GroovePoint {
            groove_id: self.groove_id,
            t_s: self.t_s,
            x_mm: self.x_mm,
            cut_length_mm: self.cut_length_mm,
            speed_rpm: self.speed_rpm,
            feed_mm_min: self.feed_mm_min,
            upfeed_um: self.upfeed_um,
            tilt_deg: self.tilt_deg,
            coolant_on: u8::from(self.coolant_on),
            depth_cmd_um: self.depth_cmd_um,
            depth_meas_um,
            spindle_temp_c: None,
        }
    }
}

/// A session's plan played out once: the time line and the nominal context of every planned
/// measured point, in plan order. [`simulate_session`] adds the effects and the noise to it; a
/// nominal model of the session (e.g. `millcomp-diagnose`) evaluates candidate effects on it.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionContexts {
    /// The time line.
    pub timeline: Timeline,
    /// One context per planned measured point, in plan order.
    pub points: Vec<PointContext>,
}

impl SessionContexts {
    /// Number of planned measured points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the plan measures no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// What an effect sees at point `i` (panics if `i` is out of range).
    pub fn effect_context(&self, i: usize) -> EffectContext<'_> {
        let p = &self.points[i];
        EffectContext {
            t_s: p.t_s,
            x_mm: p.x_mm,
            machine_x_mm: p.machine_x_mm,
            cut_length_mm: p.cut_length_mm,
            speed_rpm: p.speed_rpm,
            tilt_deg: p.tilt_deg,
            upfeed_um: p.upfeed_um,
            depth_cmd_um: p.depth_cmd_um,
            depth_actual_um: p.depth_actual_um,
            force_z_n: p.force_z_n,
            chip_force_z_n_per_um2: p.chip_force_z_n_per_um2,
            z_compliance_um_per_n: p.z_compliance_um_per_n,
            coolant_events: &self.timeline.coolant_events[..p.n_coolant_events],
            spindle_events: &self.timeline.spindle_events[..p.n_spindle_events],
        }
    }

    /// Depth offsets (µm) of `effect` at every planned point.
    pub fn offsets_um(&self, effect: &dyn Effect) -> Vec<f64> {
        (0..self.len())
            .map(|i| effect.depth_offset_um(&self.effect_context(i)))
            .collect()
    }
}

impl Session {
    /// The time line of the plan: item start times, coolant and spindle events (a groove starts at
    /// `start_s` or when the previous item ends, whichever is later).
    pub fn timeline(&self) -> Timeline {
        let mut coolant_events: Vec<(f64, bool)> = Vec::new();
        let mut spindle_events: Vec<(f64, f64)> = Vec::new();
        let mut item_start_s = Vec::with_capacity(self.plan.len());
        let mut t = 0.0f64;
        let mut coolant = false;
        for item in &self.plan {
            match item {
                PlanItem::Groove(g) => {
                    let t0 = g.start_s.unwrap_or(t).max(t);
                    if let Some(c) = g.coolant {
                        if c != coolant || coolant_events.is_empty() {
                            coolant_events.push((t0, c));
                            coolant = c;
                        }
                    }
                    spindle_events.push((t0, g.speed_rpm));
                    item_start_s.push(t0);
                    t = t0 + g.duration_s();
                }
                PlanItem::Pause(p) => {
                    if let Some(c) = p.coolant {
                        if c != coolant || coolant_events.is_empty() {
                            coolant_events.push((t, c));
                            coolant = c;
                        }
                    }
                    spindle_events.push((t, p.speed_rpm));
                    item_start_s.push(t);
                    t += p.duration_s;
                }
            }
        }
        Timeline {
            item_start_s,
            coolant_events,
            spindle_events,
        }
    }

    /// Validates the session and plays its plan out: the time line and the nominal context of every
    /// measured point (module documentation: `δz` by fixed-point iteration on a per-groove table of
    /// peak z-force vs actual depth).
    ///
    /// # Errors
    /// [`SimError::Session`] as [`Self::validate`] (the force-model evaluations that follow only
    /// see conditions validation has accepted).
    pub fn contexts(&self) -> Result<SessionContexts, SimError> {
        self.validate()?;
        let model = self.force_model()?;
        let stiffness = self.stiffness()?;
        let timeline = self.timeline();
        let mut points = Vec::new();
        let mut cut_length = 0.0f64;
        let mut groove_id = 0i64;
        for (item, &t0) in self.plan.iter().zip(&timeline.item_start_s) {
            let PlanItem::Groove(g) = item else { continue };
            let upfeed = g.upfeed();
            let base = CutConditions {
                depth_um: 0.0,
                upfeed_um: upfeed,
                speed_rpm: g.speed_rpm,
                tilt_deg: g.tilt_deg,
            };
            let compliance = stiffness.z_compliance_um_per_n(g.tilt_deg)?;
            // max programmed depth on a fine grid
            let nfine = 1000usize;
            let mut max_d: f64 = 0.0;
            for k in 0..=nfine {
                max_d = max_d.max(
                    g.depth
                        .depth_at(g.length_mm * k as f64 / nfine as f64, g.length_mm),
                );
            }
            let table = PeakTable::new(&model, base, max_d)?;
            let v_mm_s = g.feed() / 60.0;
            let n_pts = (g.length_mm / g.measure_every_mm + 1e-9).floor() as usize;
            let mut x_prev = 0.0;
            for j in 0..=n_pts {
                let x = (j as f64 * g.measure_every_mm).min(g.length_mm);
                // engaged length between the previous point and this one
                let sub = 20usize;
                for s in 0..sub {
                    let xa = x_prev + (x - x_prev) * (s as f64 + 0.5) / sub as f64;
                    if g.depth.depth_at(xa, g.length_mm) > 0.0 {
                        cut_length += (x - x_prev) / sub as f64;
                    }
                }
                x_prev = x;
                let tp = t0 + x / v_mm_s;
                let d_cmd = g.depth.depth_at(x, g.length_mm);
                let delta = static_deflection(&table, d_cmd, compliance);
                let d_act = (d_cmd - delta).max(0.0);
                let phi = model.contact_angle_rad(d_act);
                // the events up to this point: those before it, and those at the groove's start
                // (its own, or a pause of no length); an event at the end of the groove is the
                // next item's, after the groove's last point
                let seen = |t_event: f64| t_event < tp || t_event <= t0;
                let n_coolant_events = timeline.coolant_events.partition_point(|e| seen(e.0));
                let n_spindle_events = timeline.spindle_events.partition_point(|e| seen(e.0));
                points.push(PointContext {
                    groove_id,
                    t_s: tp,
                    x_mm: x,
                    machine_x_mm: g.x_offset_mm + x,
                    cut_length_mm: cut_length,
                    speed_rpm: g.speed_rpm,
                    feed_mm_min: g.feed(),
                    upfeed_um: upfeed,
                    tilt_deg: g.tilt_deg,
                    coolant_on: timeline.coolant_events[..n_coolant_events]
                        .last()
                        .map(|e| e.1)
                        .unwrap_or(false),
                    depth_cmd_um: d_cmd,
                    depth_nominal_um: d_cmd - delta,
                    depth_actual_um: d_act,
                    force_z_n: table.at(d_act),
                    chip_force_z_n_per_um2: model.params.force_scale
                        * model.material.mu_rake
                        * model.specific_cutting_pressure_mpa()
                        * 1e-6
                        * (0.5 * phi).cos(),
                    z_compliance_um_per_n: compliance,
                    n_coolant_events,
                    n_spindle_events,
                });
            }
            groove_id += 1;
        }
        Ok(SessionContexts { timeline, points })
    }
}

/// Simulate a session: one [`GroovePoint`] per measured point, in plan order — the nominal contexts
/// ([`Session::contexts`]) plus the offsets of the session's effects, plus seeded noise.
///
/// # Errors
/// [`SimError::Session`] as [`Session::validate`]; [`SimError::InvalidParameter`] (`noise_sigma`)
/// when `opts.noise` has a negative or non-finite sigma.
///
/// # Examples
/// ```
/// use millcomp_sim::sensors::NoiseSpec;
/// use millcomp_sim::session::{Session, SimOptions, simulate_session};
/// // the thesis' groove (000 ch. 6): S7, wearland 8 µm, 20° tilt, 10 µm/rev at 10 000 rpm, 80 µm deep,
/// // forces scaled by `force::S7_GROOVE_FORCE_SCALE`
/// let s = Session::from_toml_str(r#"
/// [tool]
/// wearland_um = 8.0
/// [material]
/// name = "S7"
/// [force_model]
/// force_scale = 3.7396
/// [[plan]]
/// kind = "groove"
/// speed_rpm = 10000.0
/// upfeed_um = 10.0
/// tilt_deg = 20.0
/// length_mm = 2.0
/// measure_every_mm = 1.0
/// depth = { kind = "constant", depth_um = 80.0 }
/// "#).unwrap();
/// let pts = simulate_session(&s, &SimOptions::default()).unwrap();
/// assert_eq!(pts.len(), 3); // x = 0, 1, 2 mm
/// assert_eq!((pts[2].x_mm, pts[2].feed_mm_min), (2.0, 100.0));
/// assert!((pts[2].t_s - 1.2).abs() < 1e-12);
/// // the tool deflects 16.0 µm at the 80 µm end: 000 §6.1 predicted 17 µm and measured 16 µm
/// let deflection_um = pts[2].depth_cmd_um - pts[2].depth_meas_um;
/// assert!((deflection_um - 17.0).abs() / 17.0 < 0.15);
/// assert!((deflection_um - 16.022).abs() < 1e-3);
/// // seeded measurement noise: the same seed replays the same points
/// let noisy = SimOptions { noise: Some(NoiseSpec { seed: 1, sigma: 0.2 }) };
/// let a = simulate_session(&s, &noisy).unwrap();
/// assert_eq!(a, simulate_session(&s, &noisy).unwrap());
/// assert!(a.iter().zip(&pts).all(|(a, p)| (a.depth_meas_um - p.depth_meas_um).abs() < 5.0 * 0.2));
/// ```
pub fn simulate_session(
    session: &Session,
    opts: &SimOptions,
) -> Result<Vec<GroovePoint>, SimError> {
    session.validate()?;
    let effects = session.effects()?;
    let mut noise = match opts.noise {
        Some(n) => NoiseSource::new(n.seed, n.sigma)?,
        None => NoiseSource::none(),
    };
    let contexts = session.contexts()?;
    let mut out = Vec::with_capacity(contexts.len());
    for (i, p) in contexts.points.iter().enumerate() {
        let ctx = contexts.effect_context(i);
        let mut offset = 0.0;
        let mut temp = None;
        for e in &effects {
            offset += e.depth_offset_um(&ctx);
            if let Some(r) = e.spindle_temp_rise_c(&ctx) {
                temp = Some(AMBIENT_C + r);
            }
        }
        out.push(GroovePoint {
            spindle_temp_c: temp,
            ..p.measured(p.depth_nominal_um + offset + noise.sample())
        });
    }
    Ok(out)
}

/// One groove of a simulated or measured session in numbers: its points, start time and depth error
/// (measured − commanded). Fields in alphabetical order, as `simulate --json` has always printed them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GrooveSummary {
    /// The groove.
    pub groove_id: i64,
    /// The error of largest magnitude (µm, signed).
    pub max_error_um: f64,
    /// The mean error (µm).
    pub mean_error_um: f64,
    /// Points of the groove.
    pub n_points: usize,
    /// Time of its first point (s).
    pub t_start_s: f64,
}

/// Per groove (by id, ascending): points, start time and the depth error (`simulate SESSION`'s table,
/// the Python package's `simulate_session`).
///
/// ```
/// use millcomp_sim::session::{Session, SimOptions, groove_summaries, simulate_session};
/// let s = Session::from_path(concat!(env!("CARGO_MANIFEST_DIR"), "/../datasets/sessions/example.toml")).unwrap();
/// let pts = simulate_session(&s, &SimOptions::default()).unwrap();
/// let g = groove_summaries(&pts);
/// assert_eq!(g.iter().map(|g| g.n_points).sum::<usize>(), pts.len());
/// assert!(g.windows(2).all(|w| w[0].groove_id < w[1].groove_id));
/// ```
pub fn groove_summaries(points: &[GroovePoint]) -> Vec<GrooveSummary> {
    let mut ids: Vec<i64> = points.iter().map(|p| p.groove_id).collect();
    ids.sort_unstable();
    ids.dedup();
    ids.iter()
        .map(|&id| {
            let g: Vec<&GroovePoint> = points.iter().filter(|p| p.groove_id == id).collect();
            let err: Vec<f64> = g.iter().map(|p| p.depth_meas_um - p.depth_cmd_um).collect();
            let max = err
                .iter()
                .fold(0.0_f64, |m, e| if e.abs() > m.abs() { *e } else { m });
            let mean = err.iter().sum::<f64>() / err.len() as f64;
            GrooveSummary {
                groove_id: id,
                max_error_um: max,
                mean_error_um: mean,
                n_points: g.len(),
                t_start_s: g[0].t_s,
            }
        })
        .collect()
}
