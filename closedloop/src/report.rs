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
    pub nc_axis: Option<crate::nc_axis::NcAxisReport>,
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
