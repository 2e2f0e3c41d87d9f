//! What a diagnosis returns: the report data (serialisable; the CLI turns it into text and plots).
//! The DESIGN.md `--json` contract keys come first (`initial_rms_um`, `final_rms_um`, `steps` with
//! `effect`, `p_value`, `rms_before_um`, `rms_after_um`, `params`, and `named`); everything else is
//! added to it.

use std::collections::BTreeMap;

use serde::Serialize;

pub use crate::aliasing::{AliasPair, FamilyPlan, Proposal};
use crate::force_channel::ForceChannelReport;
use crate::nested::StrataTest;
pub use crate::nuisance::NuisanceEstimate;
use crate::structure::StructureItem;

/// Leave-one-groove-out scores (whitened squared prediction errors, summed over grooves) of the
/// model without and with a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Logo {
    /// Without the candidate.
    pub before: f64,
    /// With it.
    pub after: f64,
}

/// One accepted step of the forward selection (the DESIGN.md contract keys first).
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Effect added (its family).
    pub effect: String,
    /// p-value of its GLS test beyond the nuisance model.
    pub p_value: f64,
    /// RMS residual before the step (µm; the first step's is after the nuisance step).
    pub rms_before_um: f64,
    /// RMS residual after the step (µm).
    pub rms_after_um: f64,
    /// Its fitted parameters (the shape's, names with unit).
    pub params: BTreeMap<String, f64>,
    /// The family (= `effect`).
    pub family: String,
    /// The shape chosen within the family.
    pub shape: String,
    /// What drives the family.
    pub driver: String,
    /// Linearised 95 % intervals of `params` (t with Satterthwaite dof per parameter; the final
    /// model's are in [`DiagnoseReport::final_ci95`], profile-likelihood for nonlinear ones).
    pub ci95: BTreeMap<String, [f64; 2]>,
    /// Standard errors of `params`.
    pub std_err: BTreeMap<String, f64>,
    /// The test.
    pub test: StrataTest,
    /// α / shapes tried in this round.
    pub threshold: f64,
    /// Shapes tried in this round.
    pub candidates_tried: usize,
    /// Leave-one-groove-out scores.
    pub logo: Logo,
    /// Largest depth change the effect makes at a measured point (range including 0, µm).
    pub amplitude_um: f64,
    /// More than half of the evidence comes from the nuisance's prior: the effect is aliased with
    /// the nominal model's uncertainty and named because it lies beyond it.
    pub beyond_prior: bool,
    /// Still in the final model (false when a later step made it unnecessary and it was removed;
    /// the notes say why).
    pub kept: bool,
}

/// One family tried in a round.
#[derive(Debug, Clone, Serialize)]
pub struct Tested {
    /// Effect (family).
    pub effect: String,
    /// The shape whose fit was tested (the family's best by GLS-BIC).
    pub shape: String,
    /// Every shape's linearised GLS-BIC, `(shape, value)`.
    pub shapes: Vec<(String, f64)>,
    /// The test.
    pub test: StrataTest,
    /// Whitened RSS of the model with it.
    pub rss_after: f64,
    /// RMS residual with it (µm).
    pub rms_after_um: f64,
    /// p < α/m.
    pub significant: bool,
    /// Leave-one-groove-out scores of the model without and with it.
    pub logo: Option<Logo>,
    /// Amplitude (µm).
    pub amplitude_um: f64,
    /// The shape's fitted parameters (names with unit).
    pub params: BTreeMap<String, f64>,
    /// Its test with a flexible shape of every named effect in its own driver added to both
    /// models (`Family::driver_basis`); `null` in the first round. A candidate that is not
    /// significant beyond them fits the named effects' misfit and is not added.
    pub beyond_named: Option<StrataTest>,
    /// Why it was or was not added.
    pub decision: String,
}

/// A candidate that was not tested, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    /// Effect name.
    pub effect: String,
    /// Why.
    pub note: String,
}

/// One round of the forward selection: every family tried.
#[derive(Debug, Clone, Serialize)]
pub struct Round {
    /// The threshold on a family's p: the α quantile of the round's smallest p under the null
    /// (simulated, the default) or Bonferroni's.
    pub threshold: f64,
    /// α / m over the m shapes tried (Bonferroni's threshold, for comparison).
    pub bonferroni_threshold: f64,
    /// Families, in candidate order.
    pub tested: Vec<Tested>,
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

/// The nuisance step: the nominal model's uncertain parameters refitted within their priors.
#[derive(Debug, Clone, Serialize)]
pub struct NuisanceStep {
    /// Every nuisance parameter (held ones with SD 0).
    pub params: Vec<NuisanceEstimate>,
    /// RMS of measured − nominal (µm).
    pub rms_before_um: f64,
    /// RMS after the recalibration (µm).
    pub rms_after_um: f64,
}

/// Groove-to-groove scatter as estimated (random per-groove offset).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScatterReport {
    /// σ_g (µm), pooled with the stated value.
    pub groove_sd_um: f64,
    /// σ_e (µm).
    pub measurement_sd_um: f64,
    /// Residual dof within grooves.
    pub df_within: f64,
    /// Residual dof between grooves.
    pub df_between: f64,
}

/// A residual correlation the final model leaves unexplained.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unexplained {
    /// Session variable.
    pub variable: String,
    /// Partial correlation of the whitened residual with it (model columns projected out).
    pub correlation: f64,
    /// p-value of the GLS test of a linear term in it.
    pub p_value: f64,
    /// Where its information lies: `within` or `between` grooves.
    pub stratum: String,
}

/// A named effect that another family could also be, on this session's data: the named effect is
/// not significant beyond a flexible shape of the other family in its own driver
/// ([`crate::families::Family::driver_basis`]) at the level it was named at. The name stands (its
/// shape fits best), but the data do not exclude the other; `proposal` is the standard session
/// change that would separate them best (issue 15: "say what the plan cannot separate … and
/// propose the session change").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LookAlike {
    /// The named effect.
    pub effect: String,
    /// The family whose flexible shape explains what the named effect explains.
    pub other: String,
    /// p-value of the named effect beyond the other family's flexible shape.
    pub p_beyond: f64,
    /// The level the effect was named at (α / shapes tried in its round).
    pub threshold: f64,
    /// How far the named effect, as fitted, lies from the other family's flexible shape and the
    /// nominal model (whitened norm of the part they do not explain, noise SDs; the plan alone,
    /// priors left out).
    pub unique_sd: f64,
    /// The standard session change that separates them most, with `unique_sd` after it.
    pub proposal: Option<Proposal>,
    /// One sentence for people.
    pub note: String,
}

/// A candidate the plan cannot separate from the nominal model's uncertainty, not named (issue
/// 15: "named only when it lies beyond the nuisance's prior; otherwise it is reported as within
/// the nominal model's uncertainty").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WithinNominal {
    /// Effect.
    pub effect: String,
    /// Always `within the nominal model's uncertainty` (the words).
    pub status: String,
    /// The nuisance parameters it is aliased with.
    pub nuisance: Vec<String>,
    /// The data point to it: its test beyond the recalibrated nominal model (in the last round
    /// it was tried) has p < α, though not below the round's threshold — the nominal model had
    /// to move further than its prior makes likely, in this effect's direction. Not a name:
    /// a nominal model off by more than its stated prior looks the same.
    pub indicated: bool,
    /// p-value of that test (`null` when it was not tried).
    pub p_value: Option<f64>,
    /// The round's threshold it did not reach.
    pub threshold: Option<f64>,
    /// Its shape and parameters in that test: the size it would have if it were present.
    pub shape: Option<String>,
    /// The parameters of that shape.
    pub params: BTreeMap<String, f64>,
    /// The aliased nuisance parameters as recalibrated: `(name, estimate, prior SDs)`.
    pub nuisance_moved: Vec<(String, f64, f64)>,
    /// One sentence for people.
    pub note: String,
}

/// Series kept for the plots of the report (not serialised).
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Groove of each point.
    pub groove_id: Vec<i64>,
    /// Measured depth (µm).
    pub measured_um: Vec<f64>,
    /// Prediction of the nominal model, after the nuisance step, then after each step (µm).
    pub predictions_um: Vec<Vec<f64>>,
}

/// What `diagnose` found (module documentation for the keys).
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
    /// `named`, `unlisted` (no candidate named, but a term built from the data is significant:
    /// [`DiagnoseReport::unlisted`]), `none`, or `plan_cannot_separate` (no candidate is
    /// separable from the nominal model's uncertainty by this plan: nothing is named, the report
    /// says why and what to change).
    pub verdict: String,
    /// Session name.
    pub session: String,
    /// Measured points.
    pub n_points: usize,
    /// α.
    pub alpha: f64,
    /// Multiple-testing correction used.
    pub correction: String,
    /// The nuisance step.
    pub nuisance: NuisanceStep,
    /// RMS after the nuisance step (µm): the reference of the effects' shrink.
    pub nuisance_rms_um: f64,
    /// The nominal model's parameters as recalibrated (estimates by name).
    pub nominal_free_params: BTreeMap<String, f64>,
    /// Groove-to-groove scatter.
    pub scatter: ScatterReport,
    /// Final joint estimates per effect.
    pub final_params: BTreeMap<String, BTreeMap<String, f64>>,
    /// Final joint 95 % intervals per effect: t-based (linearised) for the coefficients,
    /// profile-likelihood for the nonlinear parameters (time constants, onsets, runouts, …).
    pub final_ci95: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
    /// The linearised 95 % intervals of every parameter (estimate ± t·SE), for comparison.
    pub final_ci95_linearised: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
    /// Family and shape of each named effect.
    pub shapes: BTreeMap<String, String>,
    /// Every round, with every family's test.
    pub rounds: Vec<Round>,
    /// Candidates not tested, with notes.
    pub skipped: Vec<Skipped>,
    /// Residual correlations the final model leaves unexplained.
    pub unexplained: Vec<Unexplained>,
    /// Terms built from the data when structure remains that no candidate explains (issue 50,
    /// [`crate::unlisted`]): empty when none is significant.
    pub unlisted: Vec<crate::unlisted::UnlistedTerm>,
    /// The strongest follow-up of the residual beyond the candidates (and beyond the unlisted
    /// terms added) and why it was not added; `null` when no variable was left to try.
    pub unlisted_rejected: Option<String>,
    /// RMS of measured − (final model + the unlisted terms) (µm); `null` without one.
    /// `final_rms_um` is the final model's without them.
    pub final_rms_with_unlisted_um: Option<f64>,
    /// Candidates within the nominal model's uncertainty (aliased with the nuisance, not named).
    pub within_nominal_uncertainty: Vec<WithinNominal>,
    /// Named effects another family could also be on these data ([`LookAlike`]).
    pub look_alikes: Vec<LookAlike>,
    /// What the plan cannot separate, with the proposed session change.
    pub aliasing: Vec<AliasPair>,
    /// The plan analysis per family.
    pub plan: Vec<FamilyPlan>,
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
