//! Run reports (the `simulate --json` contract) and run traces (the CLI writes them with `--out run.csv`).

use millcomp_mpc::SolverStats;
use serde::{Deserialize, Serialize};

/// Error metrics of one run. Error = actual − desired (µm; groove: depth cut − programmed depth, + = deeper
/// than programmed; thin wall: measured − nominal thickness).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Metrics {
    /// Peak-to-peak error (µm).
    pub pp_error_um: f64,
    /// RMS error (µm).
    pub rms_error_um: f64,
    /// Largest error (µm).
    pub max_error_um: f64,
    /// Smallest error (µm).
    pub min_error_um: f64,
    /// Total actuator travel Σ|Δposition| (µm; groove: PZT tool-tip, thin wall: stage).
    pub actuator_travel_um: f64,
    /// Thin walls: measured thickness per wall (µm), in scenario order.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub thickness_um: Option<Vec<f64>>,
    /// Thin walls: relative thickness error per wall (%), `(t − t_nom)/t_nom · 100`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub thickness_error_pct: Option<Vec<f64>>,
    /// Groove with a workpiece exit: largest overcut (µm, error > 0 = deeper than programmed; 003 §3.3's
    /// "undersize") from the start of the engagement drop to the edge.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub exit_overcut_um: Option<f64>,
    /// Groove with a workpiece exit: where the PZT tip was (µm along the stack, the smallest value) while
    /// the command sat at the amplifier's floor (below 1 V) during the engagement drop — what the
    /// stack's remanence leaves out that no command can retract (absent when the command never reached
    /// the floor there). Its z-part, `sin α ·` it, is cut deeper than planned.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub exit_floor_tip_um: Option<f64>,
    /// Groove: the smallest peak-to-peak error any controller could reach against the deflection this run
    /// met, with the PZT's tip range (µm): `max(0, δ_max − δ_min − range · sin α)` — static (no dynamics),
    /// so a lower bound; 0 where the stroke covers the deflection.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub stroke_bound_um: Option<f64>,
    /// Groove: the whole cut's optimum (µm) — the peak-to-peak error of the best static plan within the
    /// true actuator's reach for a controller that sees the deflection through the commissioned
    /// deflection model (compliance × force-channel gain against the truth's); noise-free
    /// ([`crate::optimum::certainty_equivalent_pp`]). The stroke bound when the model is exact.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub optimum_pp_um: Option<f64>,
    /// Groove: the largest transient excess over the settled error at the program's changes (entry at
    /// depth, depth and feed changes, exit; [`crate::changes`]), µm; absent without a change.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub change_excess_um: Option<f64>,
}

impl Metrics {
    /// Metrics of an error series and an actuator travel.
    pub fn from_errors(errors: &[f64], actuator_travel_um: f64) -> Self {
        let n = errors.len().max(1) as f64;
        let max = errors.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = errors.iter().copied().fold(f64::INFINITY, f64::min);
        let (max, min) = if errors.is_empty() {
            (0.0, 0.0)
        } else {
            (max, min)
        };
        Self {
            pp_error_um: max - min,
            rms_error_um: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
            max_error_um: max,
            min_error_um: min,
            actuator_travel_um,
            thickness_um: None,
            thickness_error_pct: None,
            exit_overcut_um: None,
            exit_floor_tip_um: None,
            stroke_bound_um: None,
            optimum_pp_um: None,
            change_excess_um: None,
        }
    }
}

/// One wall of a thin-wall run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WallReport {
    /// Nominal thickness (µm).
    pub nominal_um: f64,
    /// Measured (simulated) thickness, mean over the wall (µm).
    pub thickness_um: f64,
    /// `(thickness − nominal)/nominal · 100`.
    pub thickness_error_pct: f64,
}

/// What the truth/model setup was (for the record in the JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelSummary {
    /// Controllers' z-stiffness (N/µm) and the truth's.
    pub kz_model_n_per_um: f64,
    /// Truth z-stiffness (N/µm).
    pub kz_truth_n_per_um: f64,
    /// Relative stiffness error of the controllers' model.
    pub stiffness_error_rel: f64,
    /// Largest relative force-parameter error.
    pub force_error_max_rel: f64,
    /// Truth force scale (after calibration to the published uncompensated error, if requested).
    pub truth_force_scale: f64,
}

/// Result of one closed-loop run: `{"scenario", "stage", "controller", "metrics", "solver"?, "walls"?, …}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    /// Scenario name.
    pub scenario: String,
    /// `groove` or `thin_wall`.
    pub stage: String,
    /// Controller name.
    pub controller: String,
    /// Error metrics.
    pub metrics: Metrics,
    /// MPC only: `{solves, median_us, p99_us, max_us, fallbacks, budget_us, deadline_misses}`
    /// (per-cycle wall time, [`SolverStats`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub solver: Option<SolverStats>,
    /// Thin walls: per-wall results.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub walls: Option<Vec<WallReport>>,
    /// Every emitted command was finite.
    pub commands_finite: bool,
    /// Every emitted command was within the actuator limits.
    pub commands_in_limits: bool,
    /// Largest error in the window after the first process change (feed/depth step, exit), µm (absolute).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub process_change_peak_um: Option<f64>,
    /// Groove: the excess at each change of the program ([`crate::changes`]).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub changes: Vec<crate::changes::ChangeExcess>,
    /// Model vs truth.
    pub model: ModelSummary,
    /// Groove touched off at a bias (`control.touch_off_bias`): the bias (V) and the gauge's reading
    /// there (µm); absent for a touch-off at rest.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub touch_off: Option<millcomp_mpc::groove::TouchOff>,
    /// NC stage: the wall's metrics, the commissioned models against the truth, the seed's draw.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub nc_axis: Option<NcAxisReport>,
    /// Simulated duration (s).
    pub simulated_s: f64,
    /// The run's thread had real-time priority (`[control] realtime`, [`crate::realtime`]).
    #[serde(default)]
    pub realtime: bool,
    /// Wall-clock time of the run (s).
    pub wall_clock_s: f64,
    /// Notes (assumptions in force for this run).
    pub notes: Vec<String>,
}

/// A decimated time trace of a run (for `--out run.csv` and plots).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Trace {
    /// Column names.
    pub columns: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<f64>>,
}

impl Trace {
    /// Empty trace with columns.
    pub fn new(columns: &[&str]) -> Self {
        Self {
            columns: columns.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Column values by name.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[i]).collect())
    }
}

/// A report with its trace.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOutput {
    /// The report.
    pub report: RunReport,
    /// The trace.
    pub trace: Trace,
}

// ---- The NC feed-axis stage's part (`crate::nc_axis`) ------------------------------------------

/// The NC stage's part of a run report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NcAxisReport {
    /// The wall's metrics.
    pub wall: NcWallMetrics,
    /// What the commissioning identified (estimate ± SE) and the truth's values, for the record.
    pub models: Vec<NcModelLine>,
    /// The truth's draw of this seed.
    pub draw: NcTruthDraw,
}

/// One identified quantity against the truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NcModelLine {
    /// Name.
    pub name: String,
    /// Estimate.
    pub estimate: f64,
    /// Standard error.
    pub std_err: f64,
    /// The truth's value where it has one of the same structure (NaN otherwise).
    pub truth: f64,
}

/// The metrics of the measured wall (µm; + = material left, − = undersize).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct NcWallMetrics {
    /// Mean |wall error| over the constant-condition windows (measured contour).
    pub static_error_um: f64,
    /// Mean of the deflection part over the same windows: what the same run's wall would show
    /// uncompensated (a model output of the truth, for the record).
    pub static_uncompensated_um: f64,
    /// `100·(1 − static_error/static_uncompensated)`.
    pub static_removed_pct: f64,
    /// The deflection step at the first feed change (model output): mean deflection part after it minus
    /// before it (its constant windows).
    pub deflection_step_um: Option<f64>,
    /// Largest |error| from 2 mm before to 15 mm after the first feed change (003 Fig. 6's peak).
    pub feed_step_peak_um: Option<f64>,
    /// Its sign: the error at that point.
    pub feed_step_peak_signed_um: Option<f64>,
    /// Largest |error − settled error| over the same span, the settled error being the wall's mean
    /// over 7–2 mm before the change (before it) and 10–20 mm after it (after it): the transient a
    /// controller adds over its own static error (issue 14's excess).
    pub feed_step_excess_um: Option<f64>,
    /// RMS of the executed correction (the y axis' encoder) about its 60 ms centred moving average from
    /// 40 to 340 ms after the feed change starts (after the rise): the oscillation a controller cuts
    /// into the wall (003 §3.2: the notch chain's "decaying oscillation … also found in the actuating
    /// values"); 0 without compensation.
    pub feed_step_oscillation_um: Option<f64>,
    /// Largest undersize (−error, ≥ 0) over the exit: from one radius plus 1 mm before the edge to it.
    pub exit_undersize_um: f64,
    /// Smallest and largest error over the exit.
    pub exit_min_um: f64,
    /// Largest error over the exit.
    pub exit_max_um: f64,
    /// The windows of constant conditions used (mm).
    pub windows_mm: Vec<[f64; 2]>,
    /// The physical limit of [`Self::feed_step_peak_um`]: the smallest peak |error| over the same
    /// window of this run's measured contour any controller correcting the y reference once per NC
    /// cycle could leave, through the true axis, knowing the truth's deflection in advance
    /// ([`crate::nc_axis_bound`]); a lower bound of every controller's peak on this seed.
    #[serde(default)]
    pub feed_step_peak_bound_um: Option<f64>,
    /// The same for [`Self::feed_step_excess_um`]: about a free settled level before and one after
    /// the change.
    #[serde(default)]
    pub feed_step_excess_bound_um: Option<f64>,
    /// The smallest largest |error| over the exit window any controller could leave: no controller
    /// keeps the exit's wall within ± less than this (a lower bound of `max(exit_undersize_um,
    /// exit_max_um)`).
    #[serde(default)]
    pub exit_bound_um: Option<f64>,
    /// The certainty-equivalent reference of the same run (module doc of [`crate::nc_axis_bound`]):
    /// the wall of a controller that cancels, at every tooth pass, the deflection it sees — the
    /// orthogonal force known in advance exactly as the platform measures it, noise-free, over the
    /// commissioned stiffness. The axis allows it (the physical limit is ≈ 0); what is left is what no
    /// force feedback sees: the load–deflection tests' errors, the machine stiffness between them and
    /// the platform gain's error. Not a lower bound (a controller can be wrong the other way).
    #[serde(default)]
    pub certainty_equivalent: Option<NcReferenceWall>,
}

/// The figures of a reference wall ([`NcWallMetrics::certainty_equivalent`]), as
/// [`NcWallMetrics`] measures a controller's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct NcReferenceWall {
    /// Mean |error| over the constant-condition windows (µm).
    pub static_error_um: f64,
    /// The feed step's peak |error| (µm).
    pub feed_step_peak_um: Option<f64>,
    /// The feed step's excess over the settled wall (µm).
    pub feed_step_excess_um: Option<f64>,
    /// The exit's undersize (µm).
    pub exit_undersize_um: f64,
    /// The largest error over the exit window (µm).
    pub exit_max_um: f64,
    /// Peak-to-peak of the measured contour over the blank (µm).
    pub pp_um: f64,
}

/// What a seed draws for the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NcTruthDraw {
    /// Force factor (material lot, tool).
    pub force_factor: f64,
    /// Platform gain.
    pub platform_gain: f64,
    /// Runout angle (deg).
    pub runout_phase_deg: f64,
    /// Spindle angle at the start (rad).
    pub spindle_phase_rad: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_a_series() {
        let m = Metrics::from_errors(&[-1.0, 0.0, 3.0], 2.0);
        assert_eq!(m.pp_error_um, 4.0);
        assert_eq!(m.max_error_um, 3.0);
        assert_eq!(m.min_error_um, -1.0);
        assert!((m.rms_error_um - (10.0f64 / 3.0).sqrt()).abs() < 1e-12);
        let json = serde_json::to_value(&m).unwrap();
        assert!(json.get("thickness_um").is_none());
    }
}
