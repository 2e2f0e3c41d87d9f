//! What a diagnosis returns: the report data (serialisable; the CLI turns it into text and plots).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::force_channel::ForceChannelReport;
use crate::nested::Decision;
use crate::structure::StructureItem;

/// One accepted step of the forward selection (the DESIGN.md contract keys first).
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Effect added.
    pub effect: String,
    /// p-value of its nested F-test.
    pub p_value: f64,
    /// RMS residual before the step (µm).
    pub rms_before_um: f64,
    /// RMS residual after the step (µm).
    pub rms_after_um: f64,
    /// Its fitted free parameters (names as in sim's `Effect::params`).
    pub params: BTreeMap<String, f64>,
    /// 95 % intervals of `params` (Student t, linearised; identify's `FitReport`).
    pub ci95: BTreeMap<String, [f64; 2]>,
    /// Standard errors of `params`.
    pub std_err: BTreeMap<String, f64>,
    /// The effect's parameters held fixed.
    pub fixed: BTreeMap<String, f64>,
    /// F statistic.
    pub f_statistic: f64,
    /// Numerator dof.
    pub df1: usize,
    /// Denominator dof.
    pub df2: usize,
    /// α / candidates tried in this round.
    pub threshold: f64,
    /// Candidates tried in this round.
    pub candidates_tried: usize,
    /// BIC before.
    pub bic_before: f64,
    /// BIC after.
    pub bic_after: f64,
    /// Warnings of the joint fit (identifiability, bounds, residual diagnostics).
    pub warnings: Vec<String>,
}

/// A candidate that was not tested, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    /// Effect name.
    pub effect: String,
    /// Why.
    pub note: String,
}

/// One round of the forward selection: every candidate tried.
#[derive(Debug, Clone, Serialize)]
pub struct Round {
    /// α / m.
    pub threshold: f64,
    /// Tests, in candidate order.
    pub tested: Vec<Decision>,
    /// The effect added in this round, if any.
    pub added: Option<String>,
}

/// Residual structure before and after the diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct StructureReport {
    /// Residual of the nominal model.
    pub nominal: Vec<StructureItem>,
    /// Residual of the final model.
    #[serde(rename = "final")]
    pub final_: Vec<StructureItem>,
}

/// Series kept for the plots of the report (not serialised).
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Groove of each point.
    pub groove_id: Vec<i64>,
    /// Measured depth (µm).
    pub measured_um: Vec<f64>,
    /// Prediction of the nominal model, then after each step (µm).
    pub predictions_um: Vec<Vec<f64>>,
}

/// What `diagnose` found. Serialises to the DESIGN.md contract (`initial_rms_um`, `final_rms_um`,
/// `steps[{effect, p_value, rms_before_um, rms_after_um, params}]`, `named`) plus extra keys.
#[derive(Debug, Clone, Serialize)]
pub struct DiagnoseReport {
    /// RMS of measured − nominal (µm).
    pub initial_rms_um: f64,
    /// RMS of measured − final model (µm).
    pub final_rms_um: f64,
    /// Accepted steps, in order.
    pub steps: Vec<Step>,
    /// Effects named, in the order added (force channel after depth channel); `["none"]` if none.
    pub named: Vec<String>,
    /// Session name.
    pub session: String,
    /// Measured points.
    pub n_points: usize,
    /// α.
    pub alpha: f64,
    /// Multiple-testing correction used.
    pub correction: String,
    /// Free parameters of the nominal model (empty by default).
    pub nominal_free_params: BTreeMap<String, f64>,
    /// Final joint estimates per effect.
    pub final_params: BTreeMap<String, BTreeMap<String, f64>>,
    /// Final joint 95 % intervals per effect.
    pub final_ci95: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
    /// Every round, with every candidate's test.
    pub rounds: Vec<Round>,
    /// Candidates not tested, with notes.
    pub skipped: Vec<Skipped>,
    /// Residual structure before/after.
    pub residual_structure: StructureReport,
    /// Force channel (when a force trace was given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_channel: Option<ForceChannelReport>,
    /// Notes.
    pub notes: Vec<String>,
    /// Plot series.
    #[serde(skip)]
    pub series: Series,
}
