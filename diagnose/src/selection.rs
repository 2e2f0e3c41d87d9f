//! `millcomp diagnose`: find where simulation and measurement disagree, name the missing effect, add
//! it, show the gap shrink (issue 7; the manual loop of `002_…txt` §7, automated).
//!
//! # Algorithm
//! 1. Simulate the session's nominal model ([`SessionModel`]); check that the measured CSV is that
//!    session's plan point by point ([`MeasuredGroove::check_against`]); residual = measured −
//!    nominal; its structure against time, engaged length, position, machine X, speed, coolant,
//!    predicted force and tilt ([`structure`]).
//! 2. Forward selection. In each round, every candidate effect not yet in the model is added to
//!    it and the augmented model — the candidate's free parameters *jointly* with those of the
//!    effects already added (and the nominal offset if [`DiagnoseOptions::free_offset`]) — is
//!    fitted by bounded nonlinear least squares on the identify engine, from a small grid of
//!    starting values ([`candidates`]). Each is tested against the current model with the nested
//!    F-test `F = ((RSS₀ − RSS₁)/q) / (RSS₁/(n − p₁))` (FisherSnedecor(q, n − p₁), statrs).
//! 3. The candidate with the smallest p-value is added if `p < α/m` — **Bonferroni** over the m
//!    candidates tried in that round (this is also Holm's first, most stringent comparison; the
//!    remaining candidates are not tested at Holm's relaxed levels because after adding one effect
//!    they are refitted and retested in the next round) — **and** BIC
//!    (`n·ln(RSS/n) + k·ln n`) decreases, and the augmented fit is identifiable (full-rank
//!    Jacobian; a candidate trading off against the model cannot be named). Repeat until no
//!    candidate passes.
//! 4. With a force trace ([`measured::ForceTrace`]), `flute_runout` is also tested on the
//!    flute-to-flute force asymmetry ([`force_channel`]).
//!
//! # Nominal model: no free parameters by default
//! The nominal model (force model, stiffness, effects listed in the session file) is taken as
//! identified beforehand (`millcomp identify …`), as 002 took the machine's tool-length reference as
//! given. A free constant depth offset is *not* part of it by default: a constant offset is exactly
//! what `probe_tilt_offset` (and the ±3 µm axial runout of the reference tool, 002 Tab. 5) predicts,
//! so a free offset would make that effect untestable; a free stiffness scale would likewise absorb
//! `machine_compliance`. [`DiagnoseOptions::free_offset`] adds the offset for data whose zero is not
//! trusted; `probe_tilt_offset` is then skipped with a note.
//!
//! # Why the F-test is honest enough here
//! Time constants and length scales are not identified when their amplitude is zero (Davies'
//! problem), so the F reference with q = the candidate's free-parameter count is approximate; the
//! false-alarm rate over clean seeded sessions is measured in `tests/diagnose_sweeps.rs` (report).
//!
//! ```
//! use millcomp_identify::diagnose::{DiagnoseOptions, diagnose, synthetic};
//! // the committed `probe_tilt_offset` synthetic session, regenerated in memory
//! let case = synthetic::cases().into_iter().find(|c| c.name == "probe_tilt_offset").unwrap();
//! let data = synthetic::generate(&case).unwrap();
//! let rep = diagnose(&data.session, &data.measured, &DiagnoseOptions::default()).unwrap();
//! assert_eq!(rep.named, vec!["probe_tilt_offset".to_string()]);
//! // the hidden tilt is 0.107° (002 §7.3); its 95 % interval covers it
//! let ci = rep.steps[0].ci95["alpha_deg"];
//! assert!(ci[0] < 0.107 && 0.107 < ci[1]);
//! assert!(rep.final_rms_um < 0.5 * rep.initial_rms_um);
//! ```

pub mod candidates;
pub mod context;
mod fit;
pub mod force_channel;
pub mod measured;
mod plots;
pub mod structure;
pub mod synthetic;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use millcomp_sim::session::Session;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

pub use candidates::{CandidateSpec, FreeParam, Registry};
pub use context::SessionModel;
pub use force_channel::ForceChannelReport;
pub use measured::{ForceTrace, MeasuredGroove};
pub use structure::StructureItem;

use crate::error::{IdentifyError, Result};
use fit::{Term, fit_terms};

/// Thresholds of the workflow, each argued.
pub mod thresholds {
    /// A candidate is fitted only if at least this many residual degrees of freedom remain
    /// (`n − p₁ ≥ 5`). Below it the F reference is heavy-tailed (F(1, 4) has its 99 % point at
    /// 21.2) and s² has a relative standard error √(2/dof) > 63 %: a test would have almost no
    /// power and the intervals would be meaningless, so the candidate is skipped with a note.
    pub const MIN_RESIDUAL_DOF: usize = 5;
    /// Candidate Jacobian columns with max |∂r/∂θ| at or below this are "no sensitivity": sim's
    /// effects return exact zeros where they are inactive (no coolant event, speeds below the
    /// growth onset, X outside the slideway span), so any genuine sensitivity is many orders above.
    pub const ZERO_SENSITIVITY: f64 = 1e-12;
    /// Positions, engaged lengths and feed must match the session to 1 µm (mm columns): far below
    /// the 0.1–1 mm spacing of measured points, above the rounding of any CSV writer.
    pub const MATCH_ABS_MM: f64 = 1e-3;
    /// Times must match to 10 ms (a point is cut in well under a second at these feeds;
    /// rounding of t_s to 2 decimals still matches).
    pub const MATCH_ABS_S: f64 = 1e-2;
    /// Programmed depth and upfeed must match to 1 nm (µm columns; the profilometer resolves 1 nm,
    /// 002 §7.2).
    pub const MATCH_ABS_UM: f64 = 1e-3;
    /// Tilt must match to 0.001°.
    pub const MATCH_ABS_DEG: f64 = 1e-3;
    /// A note warns that the final residual is still structured when a binned-means ANOVA p-value
    /// (`structure`) is below 1e-4: with ~8 variables examined, white residuals trigger it with
    /// probability < 1e-3, while a mis-specified form (e.g. a skewed bow fitted by a parabola)
    /// leaves p-values many orders smaller.
    pub const STRUCTURE_WARN_P: f64 = 1e-4;
    /// Relative part of every match tolerance (round-off of printed values).
    pub const MATCH_REL: f64 = 1e-6;
}

/// Options of [`diagnose`].
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseOptions {
    /// Family-wise significance level per round (Bonferroni over the candidates tried), default 0.01.
    pub alpha: f64,
    /// Candidate effect names to try (`None`: all registered ones).
    pub candidates: Option<Vec<String>>,
    /// Add a free constant depth offset `offset_um` to the nominal model (default false; module
    /// documentation).
    pub free_offset: bool,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            alpha: 0.01,
            candidates: None,
            free_offset: false,
        }
    }
}

/// The test of one candidate in one round.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decision {
    /// Candidate effect.
    pub effect: String,
    /// Nested F statistic.
    pub f_statistic: f64,
    /// Numerator dof (the candidate's free parameters).
    pub df1: usize,
    /// Denominator dof (n − parameters of the augmented model).
    pub df2: usize,
    /// p-value of the F-test.
    pub p_value: f64,
    /// α / m of the round.
    pub threshold: f64,
    /// BIC of the current model.
    pub bic_before: f64,
    /// BIC of the augmented model.
    pub bic_after: f64,
    /// RSS of the augmented model (µm² or N²).
    pub rss_after: f64,
    /// The augmented fit's Jacobian has full rank (all its parameters are determined by the data;
    /// a candidate whose parameters trade off against the model's cannot be named).
    pub identifiable: bool,
    /// `p < threshold`, BIC decreased and the augmented model is identifiable.
    pub significant: bool,
}

/// The nested F-test and BIC comparison of a model with `p0` free parameters (RSS `rss0`) against
/// one with `q` more (RSS `rss1`) on `n` points, at threshold `alpha / m`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn nested_test(
    effect: &str,
    n: usize,
    p0: usize,
    q: usize,
    rss0: f64,
    rss1: f64,
    alpha: f64,
    m: usize,
) -> Decision {
    let df2 = n.saturating_sub(p0 + q).max(1);
    let nf = n as f64;
    let f = if rss1 > 0.0 {
        ((rss0 - rss1).max(0.0) / q as f64) / (rss1 / df2 as f64)
    } else {
        f64::INFINITY
    };
    let p = FisherSnedecor::new(q as f64, df2 as f64)
        .map(|d| if f.is_finite() { d.sf(f) } else { 0.0 })
        .unwrap_or(f64::NAN);
    let bic = |rss: f64, k: usize| nf * (rss.max(1e-300) / nf).ln() + k as f64 * nf.ln();
    let threshold = alpha / m.max(1) as f64;
    let (b0, b1) = (bic(rss0, p0), bic(rss1, p0 + q));
    Decision {
        effect: effect.to_string(),
        f_statistic: f,
        df1: q,
        df2,
        p_value: p,
        threshold,
        bic_before: b0,
        bic_after: b1,
        rss_after: rss1,
        identifiable: true,
        significant: p < threshold && b1 < b0,
    }
}

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
    /// 95 % intervals of `params` (Student t, linearised; identify's [`crate::FitReport`]).
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

/// Series kept for the plots (not serialised).
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

/// A prepared diagnosis of one session (nominal model simulated once; reuse for many measured
/// files of the same plan, e.g. seeded sweeps).
#[derive(Debug, Clone)]
pub struct Diagnoser {
    sm: SessionModel,
    candidates: Vec<CandidateSpec>,
    skipped: Vec<Skipped>,
    opts: DiagnoseOptions,
}

/// The nominal offset as an effect (used with [`DiagnoseOptions::free_offset`]).
#[derive(Debug, Clone, PartialEq)]
struct NominalOffset {
    offset_um: f64,
}

impl millcomp_sim::effects::Effect for NominalOffset {
    fn name(&self) -> &'static str {
        "nominal_offset"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![("offset_um", self.offset_um)]
    }
    fn set_params(&mut self, v: &[f64]) -> std::result::Result<(), millcomp_sim::SimError> {
        self.offset_um = v.first().copied().unwrap_or(0.0);
        Ok(())
    }
    fn depth_offset_um(&self, _ctx: &millcomp_sim::effects::EffectContext<'_>) -> f64 {
        self.offset_um
    }
    fn clone_box(&self) -> Box<dyn millcomp_sim::effects::Effect> {
        Box::new(self.clone())
    }
    fn has_analytic_gradient(&self) -> bool {
        true
    }
    fn param_gradient(&self, _ctx: &millcomp_sim::effects::EffectContext<'_>) -> Vec<f64> {
        vec![1.0]
    }
}

fn offset_spec() -> CandidateSpec {
    CandidateSpec {
        effect: Box::new(NominalOffset { offset_um: 0.0 }),
        free: vec![FreeParam::new("offset_um", -1e4, 1e4, &[0.0])],
        description: "free constant depth offset of the nominal model",
    }
}

fn rms(rss: f64, n: usize) -> f64 {
    (rss / n.max(1) as f64).sqrt()
}

impl Diagnoser {
    /// Prepares a diagnosis with the standard candidates ([`Registry::standard`]).
    pub fn new(session: &Session, opts: &DiagnoseOptions) -> Result<Self> {
        Self::with_registry(session, &Registry::standard(), opts)
    }

    /// Prepares a diagnosis with a custom candidate registry.
    pub fn with_registry(
        session: &Session,
        registry: &Registry,
        opts: &DiagnoseOptions,
    ) -> Result<Self> {
        if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
            return Err(IdentifyError::InvalidParameter {
                name: "alpha".into(),
                value: opts.alpha,
                allowed: "0 < alpha < 1",
            });
        }
        let names: Vec<String> = match &opts.candidates {
            Some(c) => c.clone(),
            None => registry.names().iter().map(|s| s.to_string()).collect(),
        };
        let sm = SessionModel::new(session)?;
        let known: Vec<&str> = sm.known_effects.iter().map(|e| e.name()).collect();
        let mut candidates = Vec::new();
        let mut skipped = Vec::new();
        for name in &names {
            let spec = registry
                .get(name)
                .ok_or_else(|| IdentifyError::UnknownCandidate {
                    name: name.clone(),
                    allowed: registry.names().join(", "),
                })?;
            if let Err(e) = spec.free_indices() {
                return Err(IdentifyError::UnknownCandidate {
                    name: name.clone(),
                    allowed: e,
                });
            }
            if candidates.iter().any(|c: &CandidateSpec| c.name() == name) {
                continue;
            }
            if known.contains(&spec.name()) {
                skipped.push(Skipped {
                    effect: name.clone(),
                    note:
                        "already in the session's nominal model ([[effects]] of the session file)"
                            .into(),
                });
            } else if opts.free_offset && spec.name() == "probe_tilt_offset" {
                skipped.push(Skipped {
                    effect: name.clone(),
                    note: "a constant offset: not separable from the free nominal offset (free_offset)"
                        .into(),
                });
            } else {
                candidates.push(spec.clone());
            }
        }
        Ok(Diagnoser {
            sm,
            candidates,
            skipped,
            opts: opts.clone(),
        })
    }

    /// The nominal model.
    pub fn session_model(&self) -> &SessionModel {
        &self.sm
    }

    /// Diagnoses one measured file of this session.
    pub fn run(&self, measured: &MeasuredGroove) -> Result<DiagnoseReport> {
        let sm = &self.sm;
        measured.check_against(sm)?;
        let y = &measured.depth_meas_um;
        let n = y.len();
        let alpha = self.opts.alpha;
        let mut notes = Vec::new();
        let mut skipped = self.skipped.clone();

        // nominal model (with its free offset, if asked)
        let mut terms: Vec<Term> = Vec::new();
        let mut theta: Vec<f64> = Vec::new();
        let mut pred: Vec<f64> = sm.base_um.clone();
        let mut report_params = BTreeMap::new();
        let mut last_report: Option<crate::report::FitReport> = None;
        if self.opts.free_offset {
            let t = Term::new(offset_spec()).map_err(|e| IdentifyError::Solver(e.to_string()))?;
            terms.push(t);
            match fit_terms(sm, y, &terms, &[], 1) {
                Ok(f) => {
                    theta = f.theta.clone();
                    pred = f.prediction.clone();
                    report_params.insert("offset_um".to_string(), f.theta[0]);
                    last_report = Some(f.report);
                }
                Err(e) => {
                    return Err(IdentifyError::TooFewPoints {
                        got: n,
                        n_params: 1,
                        needed: 2,
                        what: format!("nominal offset: {}", e.join("; ")),
                    });
                }
            }
        }
        let rss_of = |p: &[f64]| -> f64 { p.iter().zip(y).map(|(a, b)| (b - a).powi(2)).sum() };
        let mut rss0 = rss_of(&pred);
        let initial_rms = rms(rss0, n);
        let resid = |p: &[f64]| -> Vec<f64> { y.iter().zip(p).map(|(a, b)| a - b).collect() };
        let structure_nominal =
            structure::residual_structure(sm, &resid(&pred), measured.spindle_temp_c.as_deref());
        let mut series = Series {
            groove_id: measured.groove_id.clone(),
            measured_um: y.clone(),
            predictions_um: vec![pred.clone()],
        };

        let mut remaining: Vec<CandidateSpec> = self.candidates.clone();
        let mut steps: Vec<Step> = Vec::new();
        let mut rounds: Vec<Round> = Vec::new();
        loop {
            let p0 = theta.len();
            let mut tried: Vec<(Decision, fit::TermsFit, usize)> = Vec::new();
            let mut drop: Vec<usize> = Vec::new();
            for (ci, spec) in remaining.iter().enumerate() {
                let q = spec.free.len();
                if n < p0 + q + thresholds::MIN_RESIDUAL_DOF {
                    skipped.push(Skipped {
                        effect: spec.name().into(),
                        note: format!(
                            "too few points: {n} measured points, the model with this effect has {} free parameters and needs ≥ {} points ({} residual dof)",
                            p0 + q,
                            p0 + q + thresholds::MIN_RESIDUAL_DOF,
                            thresholds::MIN_RESIDUAL_DOF
                        ),
                    });
                    drop.push(ci);
                    continue;
                }
                let term = match Term::new(spec.clone()) {
                    Ok(t) => t,
                    Err(e) => {
                        skipped.push(Skipped {
                            effect: spec.name().into(),
                            note: e,
                        });
                        drop.push(ci);
                        continue;
                    }
                };
                if !has_sensitivity(sm, &term) {
                    skipped.push(Skipped {
                        effect: spec.name().into(),
                        note: no_sensitivity_note(spec.name()),
                    });
                    drop.push(ci);
                    continue;
                }
                let mut all = terms.clone();
                all.push(term);
                match fit_terms(sm, y, &all, &theta, 1) {
                    Ok(f) => {
                        let mut d = nested_test(spec.name(), n, p0, q, rss0, f.rss, alpha, 1);
                        d.identifiable = f.report.rank == f.theta.len();
                        tried.push((d, f, ci));
                    }
                    Err(fails) => notes.push(format!(
                        "{}: no fit converged in round {} ({})",
                        spec.name(),
                        rounds.len() + 1,
                        fails.join("; ")
                    )),
                }
            }
            let m = tried.len();
            if m == 0 {
                remove_indices(&mut remaining, &drop);
                break;
            }
            let threshold = alpha / m as f64;
            for t in tried.iter_mut() {
                t.0.threshold = threshold;
                t.0.significant =
                    t.0.p_value < threshold && t.0.bic_after < t.0.bic_before && t.0.identifiable;
            }
            // the most significant identifiable candidate (ties: smaller RSS)
            let best = (0..m)
                .min_by(|&a, &b| {
                    (!tried[a].0.identifiable)
                        .cmp(&!tried[b].0.identifiable)
                        .then(tried[a].0.p_value.total_cmp(&tried[b].0.p_value))
                        .then(tried[a].1.rss.total_cmp(&tried[b].1.rss))
                })
                .unwrap_or(0);
            let accept = tried[best].0.significant;
            rounds.push(Round {
                threshold,
                tested: tried.iter().map(|t| t.0.clone()).collect(),
                added: accept.then(|| tried[best].0.effect.clone()),
            });
            if !accept {
                remove_indices(&mut remaining, &drop);
                break;
            }
            let (d, f, ci) = tried.swap_remove(best);
            let spec = remaining[ci].clone();
            let term = Term::new(spec.clone()).map_err(IdentifyError::Solver)?;
            let k0 = theta.len();
            let q = term.n_free();
            let mut params = BTreeMap::new();
            let mut ci95 = BTreeMap::new();
            let mut se = BTreeMap::new();
            for (j, fp) in spec.free.iter().enumerate() {
                let key = format!("{}.{}", spec.name(), fp.name);
                params.insert(fp.name.to_string(), f.theta[k0 + j]);
                if let Some(c) = f.report.ci95.get(&key) {
                    ci95.insert(fp.name.to_string(), *c);
                }
                se.insert(fp.name.to_string(), f.report.se(&key));
            }
            debug_assert_eq!(params.len(), q);
            steps.push(Step {
                effect: d.effect.clone(),
                p_value: d.p_value,
                rms_before_um: rms(rss0, n),
                rms_after_um: rms(f.rss, n),
                params,
                ci95,
                std_err: se,
                fixed: spec
                    .fixed()
                    .into_iter()
                    .map(|(k, v)| (k.to_string(), v))
                    .collect(),
                f_statistic: d.f_statistic,
                df1: d.df1,
                df2: d.df2,
                threshold,
                candidates_tried: m,
                bic_before: d.bic_before,
                bic_after: d.bic_after,
                warnings: f.report.warnings.clone(),
            });
            terms.push(term);
            theta = f.theta.clone();
            rss0 = f.rss;
            pred = f.prediction.clone();
            series.predictions_um.push(pred.clone());
            last_report = Some(f.report);
            drop.push(ci);
            remove_indices(&mut remaining, &drop);
        }

        // final joint estimates
        let mut final_params = BTreeMap::new();
        let mut final_ci95 = BTreeMap::new();
        if let Some(r) = &last_report {
            for t in &terms {
                let name = t.spec.name();
                let mut p = BTreeMap::new();
                let mut c = BTreeMap::new();
                for fp in &t.spec.free {
                    let key = format!("{name}.{}", fp.name);
                    p.insert(fp.name.to_string(), r.param(&key));
                    if let Some(ci) = r.ci95.get(&key) {
                        c.insert(fp.name.to_string(), *ci);
                    }
                }
                if name == "nominal_offset" {
                    report_params = p;
                    continue;
                }
                final_params.insert(name.to_string(), p);
                final_ci95.insert(name.to_string(), c);
            }
        }
        let structure_final =
            structure::residual_structure(sm, &resid(&pred), measured.spindle_temp_c.as_deref());
        let mut named: Vec<String> = steps.iter().map(|s| s.effect.clone()).collect();
        let force_channel = match &measured.forces {
            Some(tr) => {
                let fc = force_channel::diagnose_forces(sm, measured, tr, alpha)?;
                for s in &fc.steps {
                    if !named.contains(&s.effect) {
                        named.push(s.effect.clone());
                    }
                }
                Some(fc)
            }
            None => None,
        };
        if named.is_empty() {
            named.push("none".into());
        }
        let worst = structure_final
            .iter()
            .filter_map(|it| it.bins_p.map(|p| (p, it.variable.as_str())))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((p, v)) = worst {
            if p < thresholds::STRUCTURE_WARN_P {
                notes.push(format!(
                    "the final residual is still structured against {v} (binned-means ANOVA p = {p:.1e}): \
                     a named effect may have another functional form than its candidate, or the missing \
                     effect is not among the candidates"
                ));
            }
        }
        if measured.spindle_temp_c.is_some() {
            notes.push(
                "spindle_temp_c is used in the residual structure only (the depth fits do not need it)"
                    .into(),
            );
        }
        Ok(DiagnoseReport {
            initial_rms_um: initial_rms,
            final_rms_um: rms(rss0, n),
            steps,
            named,
            session: sm.name.clone(),
            n_points: n,
            alpha,
            correction: "bonferroni".into(),
            nominal_free_params: report_params,
            final_params,
            final_ci95,
            rounds,
            skipped,
            residual_structure: StructureReport {
                nominal: structure_nominal,
                final_: structure_final,
            },
            force_channel,
            notes,
            series,
        })
    }
}

fn remove_indices<T>(v: &mut Vec<T>, idx: &[usize]) {
    let mut idx = idx.to_vec();
    idx.sort_unstable();
    idx.dedup();
    for &i in idx.iter().rev() {
        if i < v.len() {
            v.remove(i);
        }
    }
}

/// Whether the term's offset responds to its free parameters anywhere, at any of its starts.
fn has_sensitivity(sm: &SessionModel, term: &Term) -> bool {
    let mut starts: Vec<Vec<f64>> = vec![Vec::new()];
    for f in &term.spec.free {
        starts = starts
            .into_iter()
            .flat_map(|s| {
                f.starts.iter().map(move |&x| {
                    let mut v = s.clone();
                    v.push(x);
                    v
                })
            })
            .collect();
    }
    starts.iter().any(|s| {
        let Ok(e) = term.configured(s) else {
            return false;
        };
        (0..sm.len()).any(|i| {
            let g = e.param_gradient(&sm.ctx(i));
            term.free_idx
                .iter()
                .any(|&k| g[k].abs() > thresholds::ZERO_SENSITIVITY)
        })
    })
}

fn no_sensitivity_note(name: &str) -> String {
    let why = match name {
        "coolant_thermal_drift" => "the coolant is never switched in this session",
        "spindle_thermal_growth" => {
            "no spindle speed in this session exceeds the growth onset the fit starts from (16 000 rpm, 002 Fig. 25)"
        }
        "slideway_straightness" => "no measured point lies inside the slideway span",
        "tool_wear" => "the tool never engages (no cut length)",
        "flute_runout" => "no point is engaged with an upfeed above the runout",
        "machine_compliance" => "the predicted force is zero everywhere",
        _ => "its offset does not depend on its free parameters at any measured point",
    };
    format!("not testable on this session: {why} (the effect predicts no change)")
}

/// Diagnoses `measured` against the nominal model of `session` (module documentation).
pub fn diagnose(
    session: &Session,
    measured: &MeasuredGroove,
    opts: &DiagnoseOptions,
) -> Result<DiagnoseReport> {
    Diagnoser::new(session, opts)?.run(measured)
}

pub(crate) fn fmt_p(p: f64) -> String {
    if p < 1e-300 {
        "<1e-300".into()
    } else if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}

impl DiagnoseReport {
    /// The human-readable report.
    pub fn human(&self) -> String {
        let mut s = String::new();
        let w = |s: &mut String, t: String| {
            s.push_str(&t);
            s.push('\n');
        };
        w(
            &mut s,
            format!(
                "diagnose: session `{}`, {} points, alpha {} ({} over the candidates of each round, plus BIC)",
                self.session, self.n_points, self.alpha, self.correction
            ),
        );
        for (k, v) in &self.nominal_free_params {
            w(&mut s, format!("nominal free parameter {k} = {v:.4}"));
        }
        w(
            &mut s,
            format!("RMS residual: nominal {:.3} µm", self.initial_rms_um),
        );
        let top: Vec<&StructureItem> = {
            let mut v: Vec<&StructureItem> = self.residual_structure.nominal.iter().collect();
            v.sort_by(|a, b| a.bins_p.unwrap_or(1.0).total_cmp(&b.bins_p.unwrap_or(1.0)));
            v.into_iter().take(3).collect()
        };
        w(
            &mut s,
            "nominal residual structure (strongest first):".into(),
        );
        for it in top {
            w(
                &mut s,
                format!(
                    "  {:<15} r = {:>6}  binned means {}  (ANOVA p {})",
                    it.variable,
                    it.correlation
                        .map(|r| format!("{r:+.2}"))
                        .unwrap_or("-".into()),
                    it.bins
                        .iter()
                        .map(|b| format!("{:+.2}", b.mean_um))
                        .collect::<Vec<_>>()
                        .join(" "),
                    it.bins_p.map(fmt_p).unwrap_or("-".into())
                ),
            );
        }
        for (i, r) in self.rounds.iter().enumerate() {
            w(
                &mut s,
                format!("round {} (threshold p < {:.2e}):", i + 1, r.threshold),
            );
            let mut t = r.tested.clone();
            t.sort_by(|a, b| a.p_value.total_cmp(&b.p_value));
            for d in &t {
                w(
                    &mut s,
                    format!(
                        "  {:<24} F({},{}) = {:>10.2}  p = {:<9}  ΔBIC = {:>9.1}  RMS {:.3} µm{}",
                        d.effect,
                        d.df1,
                        d.df2,
                        d.f_statistic,
                        fmt_p(d.p_value),
                        d.bic_after - d.bic_before,
                        rms(d.rss_after, self.n_points),
                        if r.added.as_deref() == Some(d.effect.as_str()) {
                            "  <- added"
                        } else if !d.identifiable {
                            "  (not identifiable)"
                        } else {
                            ""
                        }
                    ),
                );
            }
        }
        for st in &self.steps {
            w(
                &mut s,
                format!(
                    "step: {} (p = {}), RMS {:.3} → {:.3} µm",
                    st.effect,
                    fmt_p(st.p_value),
                    st.rms_before_um,
                    st.rms_after_um
                ),
            );
        }
        if !self.final_params.is_empty() {
            w(&mut s, "final joint estimates (95 % interval):".into());
        }
        for (e, ps) in &self.final_params {
            for (k, v) in ps {
                let ci = self
                    .final_ci95
                    .get(e)
                    .and_then(|c| c.get(k))
                    .map(|c| format!("[{:.4}, {:.4}]", c[0], c[1]))
                    .unwrap_or("-".into());
                w(&mut s, format!("  {e}.{k} = {v:.4}  {ci}"));
            }
        }
        for sk in &self.skipped {
            w(&mut s, format!("skipped {}: {}", sk.effect, sk.note));
        }
        if let Some(fc) = &self.force_channel {
            w(
                &mut s,
                format!(
                    "force channel ({} rows): RMS asymmetry residual {:.4} → {:.4} N",
                    fc.n_rows, fc.initial_rms_n, fc.final_rms_n
                ),
            );
            for d in &fc.tested {
                w(
                    &mut s,
                    format!(
                        "  {:<24} F({},{}) = {:.2}  p = {}  {}",
                        d.effect,
                        d.df1,
                        d.df2,
                        d.f_statistic,
                        fmt_p(d.p_value),
                        if d.significant {
                            "named"
                        } else {
                            "not significant"
                        }
                    ),
                );
            }
            for st in &fc.steps {
                for (k, v) in &st.params {
                    let ci = st.ci95.get(k).copied().unwrap_or([f64::NAN; 2]);
                    w(
                        &mut s,
                        format!("  flute_runout.{k} = {v:.4}  [{:.4}, {:.4}]", ci[0], ci[1]),
                    );
                }
            }
            for n in &fc.notes {
                w(&mut s, format!("  note: {n}"));
            }
        }
        for n in &self.notes {
            w(&mut s, format!("note: {n}"));
        }
        w(
            &mut s,
            format!(
                "named: {}   RMS {:.3} → {:.3} µm",
                self.named.join(", "),
                self.initial_rms_um,
                self.final_rms_um
            ),
        );
        s
    }

    /// Writes SVG plots into `dir` (created if missing): `measured_vs_simulated.svg` and one
    /// `residual_step{k}_{effect}.svg` per step (residual before and after it; `residual_step0_nominal.svg`
    /// when no step was taken). Returns the files written.
    pub fn write_report(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        plots::write_all(self, dir)
    }
}
