//! The closed-loop runner: the entry points the CLI (`millcomp simulate SCENARIO --controller …`) calls.
//!
//! ```no_run
//! use millcomp_closedloop::runner::{run_scenario, ControllerKind, Scenario};
//! let s = Scenario::load("datasets/scenarios/groove_s7_20deg.toml").unwrap();
//! let report = run_scenario(&s, "mpc".parse::<ControllerKind>().unwrap()).unwrap();
//! println!("{}", serde_json::to_string_pretty(&report).unwrap());
//! ```

use serde::{Deserialize, Serialize};

use crate::error::ClosedLoopError;
use crate::groove::run_groove;
use crate::realtime::Scope;
use crate::report::{RunOutput, RunReport};
pub use crate::scenario::{ControllerKind, Scenario, StageKind};
use crate::thin_wall::run_thin_wall;

/// Run a scenario with one controller; the report of the `simulate --json` contract.
///
/// # Errors
/// The scenario's validation errors; [`ClosedLoopError::InvalidConfig`] for a controller the stage does
/// not have (`threshold` on a groove, `pid-aw`/`pid-design` on the thin wall); unreadable or invalid
/// model files the scenario names ([`ClosedLoopError::Io`], [`ClosedLoopError::Scenario`]); the
/// controllers' and the plant's construction errors.
///
/// # Examples
/// ```
/// use millcomp_closedloop::{ControllerKind, Scenario, run_scenario};
/// let text = include_str!("../../datasets/scenarios/groove_s7_20deg.toml");
/// let mut s = Scenario::from_toml_str(text, "groove_s7_20deg.toml").unwrap();
/// s.groove.as_mut().unwrap().length_mm = 1.0; // the first 1 mm (0.6 s) of the 20° groove
/// let r = run_scenario(&s, ControllerKind::Pid).unwrap();
/// assert_eq!((r.stage.as_str(), r.controller.as_str()), ("groove", "pid"));
/// assert!(r.commands_finite && r.commands_in_limits);
/// assert!(r.solver.is_none()); // QP statistics are the MPC's
/// // 0.6 s of cut at 20 kHz: 12 000 stage steps of 50 µs
/// assert!((r.simulated_s - 0.6).abs() < 1e-3, "{}", r.simulated_s);
/// assert!(run_scenario(&s, ControllerKind::Threshold).is_err());
/// ```
pub fn run_scenario(s: &Scenario, kind: ControllerKind) -> Result<RunReport, ClosedLoopError> {
    Ok(run_scenario_with_trace(s, kind)?.report)
}

/// Run a scenario with one controller, keeping the decimated time trace (for `--out run.csv` / plots).
///
/// # Errors
/// As [`run_scenario`].
pub fn run_scenario_with_trace(
    s: &Scenario,
    kind: ControllerKind,
) -> Result<RunOutput, ClosedLoopError> {
    s.validate()?;
    let rt = Scope::enter(s.control.realtime);
    let mut out = match s.stage {
        StageKind::Groove => run_groove(s, kind),
        StageKind::ThinWall => run_thin_wall(s, kind),
        StageKind::NcAxis => crate::nc_axis::run_nc_axis(s, kind),
    }?;
    out.report.realtime = rt.active();
    Ok(out)
}

/// One point of a stiffness-error sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepPoint {
    /// Relative error of the controllers' stiffness on top of the identified one (`k_model = k_id·(1+e)`).
    pub stiffness_error: f64,
    /// Resulting relative error of the controllers' z-stiffness against the truth.
    pub kz_error_rel: f64,
    /// Controller.
    pub controller: String,
    /// Peak-to-peak error (µm).
    pub pp_error_um: f64,
    /// RMS error (µm).
    pub rms_error_um: f64,
    /// Error removed relative to no compensation (%), `100·(1 − pp/pp_none)`.
    pub removal_pct: f64,
}

/// Residual error vs stiffness error: run `kinds` with the controllers' stiffness scaled by `1 + e` for each
/// `e` in `errors` (everything else as in the scenario).
///
/// # Errors
/// As [`run_scenario`].
pub fn stiffness_sweep(
    s: &Scenario,
    errors: &[f64],
    kinds: &[ControllerKind],
) -> Result<Vec<SweepPoint>, ClosedLoopError> {
    let none = run_scenario(s, ControllerKind::None)?.metrics.pp_error_um;
    let mut out = Vec::new();
    for &e in errors {
        let mut se = s.clone();
        se.truth.stiffness_error = e;
        for &k in kinds {
            let r = run_scenario(&se, k)?;
            out.push(SweepPoint {
                stiffness_error: e,
                kz_error_rel: r.model.stiffness_error_rel,
                controller: k.name().into(),
                pp_error_um: r.metrics.pp_error_um,
                rms_error_um: r.metrics.rms_error_um,
                removal_pct: 100.0 * (1.0 - r.metrics.pp_error_um / none.max(1e-12)),
            });
        }
    }
    Ok(out)
}
