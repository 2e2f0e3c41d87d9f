//! Forward selection of candidate effects (the algorithm of the crate documentation): the
//! [`Diagnoser`] fits every candidate jointly with the effects already added, tests it with the
//! nested F-test ([`crate::nested`]) and adds the most significant one while Bonferroni, BIC and
//! identifiability agree.

use std::collections::BTreeMap;

use millcomp_identify::{FitReport, IdentifyError};
use millcomp_sim::session::Session;

use crate::candidates::{CandidateSpec, FreeParam, Registry};
use crate::error::{DiagnoseError, Result};
use crate::fit::{Term, TermsFit, fit_terms};
use crate::measured::Measured;
use crate::nested::{Decision, nested_test};
use crate::nominal::SessionModel;
use crate::report::{DiagnoseReport, Round, Series, Skipped, Step, StructureReport};
use crate::{force_channel, structure, thresholds};

/// Options of [`diagnose`](crate::diagnose).
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseOptions {
    /// Family-wise significance level per round (Bonferroni over the candidates tried), default 0.01.
    pub alpha: f64,
    /// Candidate effect names to try (`None`: all registered ones).
    pub candidates: Option<Vec<String>>,
    /// Add a free constant depth offset `offset_um` to the nominal model (default false; crate
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

/// A prepared diagnosis of one session (nominal model simulated once; reuse for many measured
/// files of the same plan, e.g. seeded sweeps).
///
/// # Examples
/// ```
/// use millcomp_diagnose::{DiagnoseOptions, Diagnoser, Measured};
/// // the committed `clean` session (nothing hidden), regenerated in memory
/// let case = millcomp_synthetic::cases().into_iter().find(|c| c.name == "clean").unwrap();
/// let session = millcomp_synthetic::generate(&case).unwrap().session;
/// let d = Diagnoser::new(&session, &DiagnoseOptions::default()).unwrap();
/// let sm = d.session_model();
/// assert_eq!(sm.len(), 294);
/// // two seeded "measurements": the nominal prediction + a constant 4.67 µm (the probe-tilt offset
/// // of 002 §7.4, α = 0.107°) + 0.3 µm of noise
/// let nominal = sm.points_with(&vec![0.0; sm.len()]);
/// for seed in [1, 2] {
///     let points = millcomp_synthetic::resample(&nominal, &vec![4.67; sm.len()], 0.3, seed);
///     let rep = d.run(&Measured::new("probe.csv", points)).unwrap();
///     assert_eq!(rep.named, vec!["probe_tilt_offset".to_string()]);
///     let alpha = rep.final_params["probe_tilt_offset"]["alpha_deg"];
///     let ci = rep.final_ci95["probe_tilt_offset"]["alpha_deg"];
///     assert!(ci[0] < 0.107 && 0.107 < ci[1] && (alpha - 0.107).abs() < 5e-4);
///     // the offset explains 4.7 µm of RMS; what is left is the 0.3 µm noise
///     assert!(rep.initial_rms_um > 4.6 && (rep.final_rms_um - 0.3).abs() < 0.02);
/// }
/// ```
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
    ///
    /// # Errors
    /// As [`Diagnoser::with_registry`].
    pub fn new(session: &Session, opts: &DiagnoseOptions) -> Result<Self> {
        Self::with_registry(session, &Registry::standard(), opts)
    }

    /// Prepares a diagnosis with a custom candidate registry: simulates the nominal model once.
    ///
    /// # Errors
    /// [`DiagnoseError::InvalidOption`] for `alpha` outside (0, 1),
    /// [`DiagnoseError::UnknownCandidate`] / [`DiagnoseError::BadCandidate`] for candidates,
    /// [`DiagnoseError::Session`] when sim cannot evaluate the session.
    pub fn with_registry(
        session: &Session,
        registry: &Registry,
        opts: &DiagnoseOptions,
    ) -> Result<Self> {
        if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
            return Err(DiagnoseError::InvalidOption {
                name: "alpha",
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
                .ok_or_else(|| DiagnoseError::UnknownCandidate {
                    name: name.clone(),
                    allowed: registry.names().join(", "),
                })?;
            if let Err(message) = spec.free_indices() {
                return Err(DiagnoseError::BadCandidate {
                    effect: name.clone(),
                    message,
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
    ///
    /// # Errors
    /// [`DiagnoseError::InvalidPoints`] when the points are not a measurement,
    /// [`DiagnoseError::SessionMismatch`] when they (or the force-trace rows) are not this session's
    /// plan point by point, [`DiagnoseError::NominalOffset`] when the free offset cannot be fitted;
    /// with a force trace also [`DiagnoseError::NonFinite`] for a NaN or infinite force value and
    /// [`DiagnoseError::Session`] when sim cannot evaluate the force model at the measured
    /// conditions ([`force_channel::diagnose_forces`]). Example at [`Diagnoser`].
    pub fn run(&self, measured: &Measured) -> Result<DiagnoseReport> {
        let sm = &self.sm;
        measured.check_against(sm)?;
        let y = &measured.depth_meas_um();
        let spindle_temp_c = measured.spindle_temp_c();
        let n = y.len();
        let alpha = self.opts.alpha;
        let mut notes = Vec::new();
        let mut skipped = self.skipped.clone();

        // nominal model (with its free offset, if asked)
        let mut terms: Vec<Term> = Vec::new();
        let mut theta: Vec<f64> = Vec::new();
        let mut pred: Vec<f64> = sm.base_um.clone();
        let mut report_params = BTreeMap::new();
        let mut last_report: Option<FitReport> = None;
        if self.opts.free_offset {
            let spec = offset_spec();
            let t = Term::new(spec.clone()).map_err(|message| DiagnoseError::BadCandidate {
                effect: spec.name().into(),
                message,
            })?;
            terms.push(t);
            match fit_terms(sm, y, &terms, &[], 1) {
                Ok(f) => {
                    theta = f.theta.clone();
                    pred = f.prediction.clone();
                    report_params.insert("offset_um".to_string(), f.theta[0]);
                    last_report = Some(f.report);
                }
                Err(fails) => {
                    // one starting value: one failure
                    let source = fails
                        .into_iter()
                        .next()
                        .unwrap_or(IdentifyError::SolverState {
                            what: "no starting value was tried",
                        });
                    return Err(DiagnoseError::NominalOffset {
                        n_points: n,
                        source,
                    });
                }
            }
        }
        let rss_of = |p: &[f64]| -> f64 { p.iter().zip(y).map(|(a, b)| (b - a).powi(2)).sum() };
        let mut rss0 = rss_of(&pred);
        let initial_rms = rms(rss0, n);
        let resid = |p: &[f64]| -> Vec<f64> { y.iter().zip(p).map(|(a, b)| a - b).collect() };
        let structure_nominal =
            structure::residual_structure(sm, &resid(&pred), spindle_temp_c.as_deref());
        let mut series = Series {
            groove_id: measured.points.iter().map(|p| p.groove_id).collect(),
            measured_um: y.clone(),
            predictions_um: vec![pred.clone()],
        };

        let mut remaining: Vec<CandidateSpec> = self.candidates.clone();
        let mut steps: Vec<Step> = Vec::new();
        let mut rounds: Vec<Round> = Vec::new();
        loop {
            let p0 = theta.len();
            let mut tried: Vec<(Decision, TermsFit, usize)> = Vec::new();
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
                        fails
                            .iter()
                            .map(ToString::to_string)
                            .collect::<Vec<_>>()
                            .join("; ")
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
            let term = Term::new(spec.clone()).map_err(|message| DiagnoseError::BadCandidate {
                effect: spec.name().into(),
                message,
            })?;
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
            structure::residual_structure(sm, &resid(&pred), spindle_temp_c.as_deref());
        let mut named: Vec<String> = steps.iter().map(|s| s.effect.clone()).collect();
        let force_channel = match &measured.forces {
            Some(tr) => {
                let fc = force_channel::diagnose_forces(sm, &measured.points, tr, alpha)?;
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
        if spindle_temp_c.is_some() {
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
