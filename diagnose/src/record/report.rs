//! What a record diagnosis returns. It serialises to the groove diagnosis' contract (DESIGN.md
//! `diagnose --json`): `initial_rms_<unit>`, `final_rms_<unit>`, `steps` (`effect`, `p_value`,
//! `rms_before_<unit>`, `rms_after_<unit>`, `params`, …) and `named` — with the record signal's unit in
//! the keys (`um` for a displacement: exactly the contract's; `n` for a force) — plus the record's own
//! keys.

use std::collections::BTreeMap;

use serde::Serialize;
use serde::ser::{SerializeMap, Serializer};
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use super::families::RecordContext;

/// The nuisance step: the nominal's level recalibrated.
#[derive(Debug, Clone, Serialize)]
pub struct Nuisance {
    /// The recalibrated level (the signal's mean), in the signal's unit.
    pub level: f64,
    /// RMS residual after it, in the signal's unit.
    pub rms_after: f64,
}

/// One candidate's test in one round.
#[derive(Debug, Clone, Serialize)]
pub struct RecordDecision {
    /// Effect (DESIGN.md name).
    pub effect: String,
    /// Which family of it (its shape and drive).
    pub family: String,
    /// Nested F statistic.
    pub f_statistic: f64,
    /// Numerator dof.
    pub df1: usize,
    /// Denominator dof (effective sample size − parameters).
    pub df2: f64,
    /// Effective sample size the test counts (from the richest model's residual).
    pub n_eff: f64,
    /// Lag-1 autocorrelation of the augmented model's own residual (for the record).
    pub lag1_autocorrelation: f64,
    /// p-value.
    pub p_value: f64,
    /// α / m.
    pub threshold: f64,
    /// BIC of the current model (on n_eff).
    pub bic_before: f64,
    /// BIC of the augmented model.
    pub bic_after: f64,
    /// RMS residual of the augmented model, in the signal's unit.
    pub rms_after: f64,
    /// Full-rank Jacobian of the augmented fit.
    pub identifiable: bool,
    /// `p < threshold`, BIC decreased, identifiable.
    pub significant: bool,
}

/// One round of the forward selection.
#[derive(Debug, Clone, Serialize)]
pub struct RecordRound {
    /// α / m.
    pub threshold: f64,
    /// Every candidate's test.
    pub tested: Vec<RecordDecision>,
    /// The effect added, if any.
    pub added: Option<String>,
    /// Its family.
    pub added_family: Option<String>,
}

/// An accepted step.
#[derive(Debug, Clone)]
pub struct RecordStep {
    /// Effect added (DESIGN.md name).
    pub effect: String,
    /// Its family.
    pub family: String,
    /// p-value of its F-test.
    pub p_value: f64,
    /// RMS before (signal's unit).
    pub rms_before: f64,
    /// RMS after (signal's unit).
    pub rms_after: f64,
    /// Its fitted parameters.
    pub params: BTreeMap<String, f64>,
    /// Their 95 % intervals: the engine's standard errors widened by `√((n − p)/(n_eff − p))` and
    /// Student's t on `n_eff − p` degrees of freedom (the record's neighbouring rows are not
    /// independent: n_eff counts the independent ones).
    pub ci95: BTreeMap<String, [f64; 2]>,
    /// Sensors (temperature-driven family).
    pub sensors: Vec<String>,
    /// F statistic.
    pub f_statistic: f64,
    /// Numerator dof.
    pub df1: usize,
    /// Denominator dof.
    pub df2: f64,
    /// Effective sample size.
    pub n_eff: f64,
    /// α / m.
    pub threshold: f64,
    /// BIC before.
    pub bic_before: f64,
    /// BIC after.
    pub bic_after: f64,
    /// Candidates the record cannot tell apart from this one.
    pub aliases: Vec<String>,
    /// Warnings of the joint fit.
    pub warnings: Vec<String>,
}

/// `flute_runout` tested on per-flute channels.
#[derive(Debug, Clone, Serialize)]
pub struct FluteChannel {
    /// The channels.
    pub channels: Vec<String>,
    /// Mean of each.
    pub means: Vec<f64>,
    /// `(max − min)/mean` of the means.
    pub asymmetry: f64,
    /// F of the flute factor (two-way ANOVA, rows and flutes).
    pub f_statistic: f64,
    /// Its dof.
    pub df: [usize; 2],
    /// p-value.
    pub p_value: f64,
    /// `p < alpha`.
    pub significant: bool,
}

/// The record diagnosis.
#[derive(Debug, Clone)]
pub struct RecordReport {
    /// Unit suffix of the signal (the contract keys carry it).
    pub unit: String,
    /// RMS of the signal about the nominal (its first value held).
    pub initial_rms: f64,
    /// RMS after the last step.
    pub final_rms: f64,
    /// Accepted steps in order.
    pub steps: Vec<RecordStep>,
    /// Effects named in the order added (each once); `["none"]` if none.
    pub named: Vec<String>,
    /// The record's file.
    pub record: String,
    /// The signal's name.
    pub signal: String,
    /// Rows.
    pub n_rows: usize,
    /// α.
    pub alpha: f64,
    /// The multiple-testing rule.
    pub correction: String,
    /// What the nominal model says.
    pub nominal: String,
    /// The nuisance step.
    pub nuisance: Nuisance,
    /// `1 − final_rms / nuisance.rms_after`: how much of the gap left after the nuisance step the named
    /// effects close.
    pub shrink_after_nuisance: f64,
    /// Final joint estimates per effect.
    pub final_params: BTreeMap<String, BTreeMap<String, f64>>,
    /// Every round.
    pub rounds: Vec<RecordRound>,
    /// Candidates not testable on this record, and why.
    pub skipped: Vec<(String, String)>,
    /// The flute channel, when per-flute channels were given.
    pub flute_channel: Option<FluteChannel>,
    /// Notes.
    pub notes: Vec<String>,
    /// Prediction after the nuisance step and after each step (for plots).
    pub predictions: Vec<Vec<f64>>,
    /// The signal (for plots).
    pub measured: Vec<f64>,
}

impl Serialize for RecordStep {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        // the unit is the report's; a step serialised alone uses the generic suffix
        StepWithUnit(self, "signal").serialize(s)
    }
}

struct StepWithUnit<'a>(&'a RecordStep, &'a str);

impl Serialize for StepWithUnit<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let (st, u) = (self.0, self.1);
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("effect", &st.effect)?;
        m.serialize_entry("p_value", &st.p_value)?;
        m.serialize_entry(&format!("rms_before_{u}"), &st.rms_before)?;
        m.serialize_entry(&format!("rms_after_{u}"), &st.rms_after)?;
        m.serialize_entry("params", &st.params)?;
        m.serialize_entry("family", &st.family)?;
        m.serialize_entry("ci95", &st.ci95)?;
        if !st.sensors.is_empty() {
            m.serialize_entry("sensors", &st.sensors)?;
        }
        m.serialize_entry("f_statistic", &st.f_statistic)?;
        m.serialize_entry("df1", &st.df1)?;
        m.serialize_entry("df2", &st.df2)?;
        m.serialize_entry("n_eff", &st.n_eff)?;
        m.serialize_entry("threshold", &st.threshold)?;
        m.serialize_entry("bic_before", &st.bic_before)?;
        m.serialize_entry("bic_after", &st.bic_after)?;
        m.serialize_entry("aliases", &st.aliases)?;
        m.serialize_entry("warnings", &st.warnings)?;
        m.end()
    }
}

impl Serialize for RecordReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let u = self.unit.as_str();
        let mut m = s.serialize_map(None)?;
        m.serialize_entry(&format!("initial_rms_{u}"), &self.initial_rms)?;
        m.serialize_entry(&format!("final_rms_{u}"), &self.final_rms)?;
        let steps: Vec<StepWithUnit<'_>> =
            self.steps.iter().map(|st| StepWithUnit(st, u)).collect();
        m.serialize_entry("steps", &steps)?;
        m.serialize_entry("named", &self.named)?;
        m.serialize_entry("record", &self.record)?;
        m.serialize_entry("signal", &self.signal)?;
        m.serialize_entry("unit", &self.unit)?;
        m.serialize_entry("n_rows", &self.n_rows)?;
        m.serialize_entry("alpha", &self.alpha)?;
        m.serialize_entry("correction", &self.correction)?;
        m.serialize_entry("nominal", &self.nominal)?;
        m.serialize_entry("nuisance", &self.nuisance)?;
        m.serialize_entry("shrink_after_nuisance", &self.shrink_after_nuisance)?;
        m.serialize_entry("final_params", &self.final_params)?;
        m.serialize_entry("rounds", &self.rounds)?;
        let skipped: Vec<BTreeMap<&str, &str>> = self
            .skipped
            .iter()
            .map(|(e, n)| BTreeMap::from([("effect", e.as_str()), ("note", n.as_str())]))
            .collect();
        m.serialize_entry("skipped", &skipped)?;
        if let Some(f) = &self.flute_channel {
            m.serialize_entry("flute_channel", f)?;
        }
        m.serialize_entry("notes", &self.notes)?;
        m.end()
    }
}

/// Two-way ANOVA of the per-flute channels (rows × flutes, no interaction): does the flute matter
/// beyond the row-to-row change every flute shares?
pub(crate) fn flute_channel(ctx: &RecordContext, alpha: f64) -> Option<FluteChannel> {
    let k = ctx.flutes.len();
    if k < 2 {
        return None;
    }
    let n = ctx.flutes[0].1.len();
    if n < 2 {
        return None;
    }
    let grand = ctx.flutes.iter().flat_map(|(_, v)| v).sum::<f64>() / (n * k) as f64;
    let means: Vec<f64> = ctx
        .flutes
        .iter()
        .map(|(_, v)| v.iter().sum::<f64>() / n as f64)
        .collect();
    let row_means: Vec<f64> = (0..n)
        .map(|i| ctx.flutes.iter().map(|(_, v)| v[i]).sum::<f64>() / k as f64)
        .collect();
    let ss_tot: f64 = ctx
        .flutes
        .iter()
        .flat_map(|(_, v)| v)
        .map(|x| (x - grand).powi(2))
        .sum();
    let ss_flute: f64 = n as f64 * means.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_row: f64 = k as f64 * row_means.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_res = (ss_tot - ss_flute - ss_row).max(0.0);
    let (df1, df2) = (k - 1, (n - 1) * (k - 1));
    let f = if ss_res > 0.0 {
        (ss_flute / df1 as f64) / (ss_res / df2 as f64)
    } else {
        f64::INFINITY
    };
    let p = FisherSnedecor::new(df1 as f64, df2 as f64)
        .map(|d| if f.is_finite() { d.sf(f) } else { 0.0 })
        .unwrap_or(f64::NAN);
    let (lo, hi) = means
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| {
            (a.min(m), b.max(m))
        });
    let mean = means.iter().sum::<f64>() / k as f64;
    Some(FluteChannel {
        channels: ctx.flutes.iter().map(|(n, _)| n.clone()).collect(),
        means,
        asymmetry: (hi - lo) / mean,
        f_statistic: f,
        df: [df1, df2],
        p_value: p,
        significant: p < alpha,
    })
}
