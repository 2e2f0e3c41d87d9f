//! The program file: the NC program the controller previews (`[program]`) and how the controller runs
//! it (`[controller]`). Schema and an example: `docs/runtime.md`.
//!
//! The `[program]` keys are those of a scenario's `[groove]` table that the NC program and the part
//! drawing state (`closedloop/SCENARIOS.md`); the truth's keys (`wearland_um`,
//! `calibrate_uncompensated_um`) have no place here. The `[controller]` keys are those of a scenario's
//! `[control]` table that set up a controller, plus the controller's `kind`, its cycle `budget`, the
//! `touch_off` it starts from and the NC position's `position_tolerance_mm`.

use std::path::Path;

use millcomp_mpc::MpcConfig;
use millcomp_mpc::config::CycleBudget;
use millcomp_mpc::groove::{GrooveMpcFeatures, TouchOff};
use millcomp_sim::feed::{FeedChange, WorkpieceExit};
use millcomp_sim::groove::{DEFAULT_FEED_ACCEL_MM_S2, DepthProfile, GrooveProgram};
use serde::{Deserialize, Serialize};

use crate::error::RuntimeError;
use crate::kind::ControllerKind;

/// A program file: the NC program and the controller's settings.
///
/// # Examples
/// ```
/// use millcomp_runtime::{ControllerKind, Program};
/// let text = r#"
/// [program]
/// tilt_deg = 20.0
/// speed_rpm = 10000.0
/// upfeed_um = 10.0
/// length_mm = 20.0
/// depth = { kind = "ramp", from_um = 0.0, to_um = 80.0 }
///
/// [controller]
/// kind = "pid-tuned"
/// "#;
/// let p = Program::from_toml_str(text, "job.toml".as_ref()).unwrap();
/// assert_eq!(p.controller.kind, ControllerKind::PidTuned);
/// assert_eq!(p.controller.dt_s, 5e-5); // the defaults of a scenario's [control]
/// // 20 mm at 10 µm/rev and 10 000 rpm: 12 s of cut
/// assert!((p.program.groove_program().duration_s() - 12.0).abs() < 1e-9);
/// // a key the schema does not know is an error naming it and the file
/// let err = Program::from_toml_str(&text.replace("kind =", "knid ="), "job.toml".as_ref());
/// let msg = err.unwrap_err().chain();
/// assert!(msg.contains("job.toml") && msg.contains("knid"), "{msg}");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Program {
    /// The NC program (`[program]`).
    pub program: NcProgram,
    /// The controller's settings (`[controller]`; every key has a default).
    #[serde(default)]
    pub controller: ControllerSettings,
}

/// The NC program of a groove: what the NC will cut.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NcProgram {
    /// Workpiece material (`S7`, `6061`, …); checked against the bundle's when given (the bundle's
    /// otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Spindle speed (rpm).
    pub speed_rpm: f64,
    /// Upfeed (µm/rev).
    pub upfeed_um: f64,
    /// Groove length (mm).
    pub length_mm: f64,
    /// Programmed depth profile (sim's `DepthProfile`: `{kind = "ramp", from_um, to_um}`,
    /// `{kind = "constant", depth_um}`, `{kind = "steps", steps = [[x_mm, depth_um], …]}`,
    /// `{kind = "points", points = [[x_mm, depth_um], …]}`).
    pub depth: DepthProfile,
    /// Programmed feed changes (`[{x_mm, upfeed_um}, …]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub feed_steps: Vec<FeedChange>,
    /// Feed-axis acceleration of the feed changes (mm/s², default 100).
    #[serde(default = "default_feed_accel")]
    pub feed_accel_mm_s2: f64,
    /// Where the tool leaves the workpiece (`{x_mm, length_mm}`; none: material over the whole length).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exit: Option<WorkpieceExit>,
    /// Approach in air before the entry (mm, default 0).
    #[serde(default)]
    pub approach_mm: f64,
    /// Length after the entry over which the engagement rises from 0 to 1 (mm, default 0).
    #[serde(default)]
    pub entry_length_mm: f64,
}

fn default_feed_accel() -> f64 {
    DEFAULT_FEED_ACCEL_MM_S2
}

impl NcProgram {
    /// The program as sim's [`GrooveProgram`] (what the controllers plan with).
    pub fn groove_program(&self) -> GrooveProgram {
        GrooveProgram {
            speed_rpm: self.speed_rpm,
            upfeed_um: self.upfeed_um,
            tilt_deg: self.tilt_deg,
            length_mm: self.length_mm,
            depth_profile: self.depth.clone(),
            feed_changes: self.feed_steps.clone(),
            feed_accel_mm_s2: self.feed_accel_mm_s2,
            exit: self.exit,
            approach_mm: self.approach_mm,
            entry_length_mm: self.entry_length_mm,
        }
    }
}

/// How a controller runs: which one, its rates and horizon, its cycle budget, where the tool was
/// touched off, and the MPC's configuration and features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSettings {
    /// Which controller (default `mpc`).
    #[serde(default)]
    pub kind: ControllerKind,
    /// The control period (s): every controller is stepped at it; the PID and the signal chains run
    /// every period (default 5e-5: 20 kHz).
    #[serde(default = "default_dt")]
    pub dt_s: f64,
    /// The MPC's period in control periods (default 10: 2 kHz).
    #[serde(default = "default_mpc_every")]
    pub mpc_every: usize,
    /// The MPC's horizon in MPC periods (default 20; used when `mpc` is not given).
    #[serde(default = "default_horizon")]
    pub horizon: usize,
    /// The amplifier's slew limit per MPC period (V, default 100).
    #[serde(default = "default_slew")]
    pub slew_v_per_cycle: f64,
    /// The MPC's cycle budget (default: the configuration's iteration cap, deterministic).
    #[serde(default)]
    pub budget: Budget,
    /// A full MPC configuration (keys in `mpc/CONFIG.md`) instead of the groove MPC's default design.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mpc: Option<MpcConfig>,
    /// The groove MPC's features (`closedloop/SCENARIOS.md`, `[control.groove_mpc]`).
    #[serde(default)]
    pub groove_mpc: GrooveMpcFeatures,
    /// Drive the stack through the inverse of the bundle's hysteresis model (every controller but the
    /// published PID; off by default).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub compensate_hysteresis: bool,
    /// Where the tool was touched off: the stack's voltage and the gauge's reading there (default 0 V,
    /// 0 µm: at rest).
    #[serde(default)]
    pub touch_off: TouchOff,
    /// How far the NC's position may be from where the program puts the tool at that time before a
    /// cycle is flagged (mm, default 0.01: the plan's table spacing).
    #[serde(default = "default_position_tolerance")]
    pub position_tolerance_mm: f64,
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
fn default_position_tolerance() -> f64 {
    0.01
}

impl Default for ControllerSettings {
    fn default() -> Self {
        Self {
            kind: ControllerKind::default(),
            dt_s: default_dt(),
            mpc_every: default_mpc_every(),
            horizon: default_horizon(),
            slew_v_per_cycle: default_slew(),
            budget: Budget::default(),
            mpc: None,
            groove_mpc: GrooveMpcFeatures::default(),
            compensate_hysteresis: false,
            touch_off: TouchOff::default(),
            position_tolerance_mm: default_position_tolerance(),
        }
    }
}

/// The MPC's budget for one cycle.
///
/// ```
/// use millcomp_runtime::Budget;
/// // on the machine: the solver stopped at 40 % of the MPC's period, a late plan replaced by the
/// // fallback
/// let b: Budget = toml::from_str("kind = \"wall_clock\"\nfraction = 0.4").unwrap();
/// let c = b.cycle_budget();
/// assert_eq!((c.fraction, c.enforced, c.max_iter), (Some(0.4), true, None));
/// // for replays and tests: at most 30 interior-point iterations, the same commands on any machine
/// let b: Budget = toml::from_str("kind = \"iterations\"\nmax_iter = 30").unwrap();
/// assert_eq!(b.cycle_budget().max_iter, Some(30));
/// assert!(!b.cycle_budget().enforced);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Budget {
    /// Deterministic: the solver stops after `max_iter` interior-point iterations (the configuration's
    /// `solver.max_iter`, 50 by default, when not given) and a plan that did not converge is replaced
    /// by the fallback. The cycles are still timed against `fraction` of the period (the
    /// configuration's `solver.budget_fraction`, 0.5, when not given) and the misses counted, but a
    /// late plan is used: the commands do not depend on the machine's load — for replays, tests and
    /// simulations.
    Iterations {
        /// The iteration cap (1 ..= 500).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_iter: Option<u32>,
        /// The timed budget as a fraction of the MPC's period (0 < f ≤ 1).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fraction: Option<f64>,
    },
    /// On the machine: the solver is stopped (Clarabel's termination callback) when one more
    /// iteration would not fit in `fraction` of the MPC's period, and a plan not ready in time is
    /// replaced by the fallback (the last plan shifted, then the held command). The iteration cap
    /// still applies.
    WallClock {
        /// The budget as a fraction of the MPC's period (0 < f ≤ 1; the configuration's, 0.5, when
        /// not given).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fraction: Option<f64>,
    },
}

impl Default for Budget {
    fn default() -> Self {
        Budget::Iterations {
            max_iter: None,
            fraction: None,
        }
    }
}

impl Budget {
    /// The budget as the MPC's [`CycleBudget`].
    pub fn cycle_budget(&self) -> CycleBudget {
        match *self {
            Budget::Iterations { max_iter, fraction } => CycleBudget {
                fraction,
                enforced: false,
                max_iter,
            },
            Budget::WallClock { fraction } => CycleBudget {
                fraction,
                enforced: true,
                max_iter: None,
            },
        }
    }
}

/// An invalid value of the program file: [`RuntimeError::InvalidValue`] naming the file and the key.
fn invalid(path: &Path, key: &str, value: impl std::fmt::Display, allowed: &str) -> RuntimeError {
    RuntimeError::InvalidValue {
        path: path.to_path_buf(),
        key: key.to_string(),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

impl Program {
    /// Parse and validate a program file's text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`RuntimeError::ProgramToml`] when the text is not TOML of this schema (the parser names the line
    /// and the key), [`RuntimeError::InvalidValue`] naming the key of a value out of its range.
    pub fn from_toml_str(text: &str, origin: &Path) -> Result<Self, RuntimeError> {
        let p: Program = toml::from_str(text).map_err(|source| RuntimeError::ProgramToml {
            path: origin.to_path_buf(),
            source: Box::new(source),
        })?;
        p.validate(origin)?;
        Ok(p)
    }

    /// Read and validate a program file.
    ///
    /// # Errors
    /// [`RuntimeError::Io`] naming the file when it cannot be read; those of [`Self::from_toml_str`].
    pub fn load(path: &Path) -> Result<Self, RuntimeError> {
        let text = std::fs::read_to_string(path).map_err(|source| RuntimeError::Io {
            path: path.to_path_buf(),
            action: "reading the program file",
            source,
        })?;
        Self::from_toml_str(&text, path)
    }

    /// The program file's text (TOML).
    ///
    /// # Errors
    /// [`RuntimeError::ProgramSerialize`] when a value cannot be written (a non-finite number).
    pub fn to_toml(&self) -> Result<String, RuntimeError> {
        toml::to_string(self).map_err(|source| RuntimeError::ProgramSerialize {
            source: Box::new(source),
        })
    }

    /// Validate every value; errors name `origin` and the key (`program.tilt_deg`,
    /// `controller.budget.fraction`, `controller.mpc.limits.u_min[0]`, …).
    ///
    /// # Errors
    /// [`RuntimeError::InvalidValue`].
    pub fn validate(&self, origin: &Path) -> Result<(), RuntimeError> {
        // the catalogue ball's radius: no program may cut deeper than the ball (sim checks the rest of
        // the program and names the parameter)
        const BALL_RADIUS_UM: f64 = 400.0;
        self.program
            .groove_program()
            .validate(BALL_RADIUS_UM)
            .map_err(|e| invalid(origin, "program", e, "a program sim's groove stage can cut"))?;
        let c = &self.controller;
        if !(c.dt_s.is_finite() && c.dt_s > 0.0 && c.dt_s <= 0.01) {
            return Err(invalid(
                origin,
                "controller.dt_s",
                c.dt_s,
                "0 < dt_s <= 0.01 s",
            ));
        }
        if c.mpc_every == 0 {
            return Err(invalid(origin, "controller.mpc_every", 0, "at least 1"));
        }
        if c.horizon == 0 || c.horizon > millcomp_mpc::config::MAX_HORIZON {
            return Err(invalid(
                origin,
                "controller.horizon",
                c.horizon,
                "1 ..= 500 MPC periods",
            ));
        }
        if !(c.slew_v_per_cycle.is_finite() && c.slew_v_per_cycle > 0.0) {
            return Err(invalid(
                origin,
                "controller.slew_v_per_cycle",
                c.slew_v_per_cycle,
                "a positive voltage",
            ));
        }
        if !(c.position_tolerance_mm.is_finite() && c.position_tolerance_mm > 0.0) {
            return Err(invalid(
                origin,
                "controller.position_tolerance_mm",
                c.position_tolerance_mm,
                "a positive distance",
            ));
        }
        if !(c.touch_off.bias_v.is_finite() && c.touch_off.bias_v >= 0.0) {
            return Err(invalid(
                origin,
                "controller.touch_off.bias_v",
                c.touch_off.bias_v,
                "a voltage >= 0 within the amplifier's range",
            ));
        }
        if !c.touch_off.gauge_um.is_finite() {
            return Err(invalid(
                origin,
                "controller.touch_off.gauge_um",
                c.touch_off.gauge_um,
                "a finite gauge reading",
            ));
        }
        let fraction = match c.budget {
            Budget::Iterations { max_iter, fraction } => {
                if let Some(m) = max_iter
                    && !(1..=500).contains(&m)
                {
                    return Err(invalid(
                        origin,
                        "controller.budget.max_iter",
                        m,
                        "1 ..= 500 iterations",
                    ));
                }
                fraction
            }
            Budget::WallClock { fraction } => fraction,
        };
        if let Some(f) = fraction
            && !(f.is_finite() && f > 0.0 && f <= 1.0)
        {
            return Err(invalid(
                origin,
                "controller.budget.fraction",
                f,
                "0 < fraction <= 1 of the MPC's period",
            ));
        }
        if let Some(m) = &c.mpc {
            m.validate_keys().map_err(|e| match e {
                millcomp_mpc::MpcError::InvalidConfig {
                    key,
                    value,
                    allowed,
                } => invalid(origin, &format!("controller.mpc.{key}"), value, &allowed),
                other => invalid(origin, "controller.mpc", other, "a valid MPC configuration"),
            })?;
        }
        Ok(())
    }
}
