//! The diagnosis (the algorithm of the crate documentation): the nuisance step, then forward
//! selection of candidate families, each added only when significant beyond the nuisance model,
//! better at predicting held-out grooves and larger than the measurement resolves.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use nalgebra::{DMatrix, DVector};

use millcomp_sim::session::Session;

use crate::aliasing::{self, PlanAnalysis};
use crate::error::{DiagnoseError, Result};
use crate::families::{self, Family, Shape};
use crate::familywise::{self, NullBlock, NullShape};
use crate::logo;
use crate::measured::Measured;
use crate::model::{
    Fitted, NuisanceSet, Problem, Term, evaluate, fit, fit_held, orthonormal_basis, project_out,
    strata_of_columns, strata_of_residual,
};
use crate::nested::{StrataTest, StrataVariance, f_critical, strata_test, t975};
use crate::nominal::SessionModel;
use crate::nuisance::{self, NuisanceEstimate, NuisanceModel};
use crate::report::{
    DiagnoseReport, Logo, LookAlike, NuisanceStep, Proposal, Round, ScatterReport, Series, Skipped,
    Step, StructureReport, Tested, Unexplained, WithinNominal,
};
use crate::scatter::{self, Components, PRIOR_SCATTER_DOF, Whitening};
use crate::unlisted::{self, UnlistedTerm};
use crate::{force_channel, structure, thresholds};

/// The issue's words for a candidate aliased with the nominal model and not beyond its prior.
pub const WITHIN_NOMINAL: &str = "within the nominal model's uncertainty";

/// How a round's family-wise level α becomes the threshold on each family's p.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Multiplicity {
    /// α / m over the m shapes tried: valid for any dependence, conservative when the shapes of a
    /// family test nearly the same thing.
    Bonferroni,
    /// The α quantile of the round's smallest family p under the null, from `draws` seeded draws
    /// of the current model's whitened residual ([`familywise`](crate::familywise)); at least
    /// 20/α draws whatever `draws` says.
    Simulated {
        /// Draws of the null per round.
        draws: usize,
    },
}

impl Multiplicity {
    /// The words of the report's `correction` at level `alpha`.
    pub fn describe(&self, alpha: f64) -> String {
        match self {
            Multiplicity::Bonferroni => {
                "bonferroni over the family shapes tried in each round".into()
            }
            Multiplicity::Simulated { draws } => format!(
                "family-wise over the shapes tried in each round, simulated from {} draws of the round's null",
                Self::draws_at(*draws, alpha)
            ),
        }
    }

    /// The draws a round makes at level `alpha`: `draws`, and at least 20/α (20 draws below the
    /// quantile).
    fn draws_at(draws: usize, alpha: f64) -> usize {
        draws.max((MIN_DRAWS_BEYOND / alpha).ceil() as usize)
    }
}

/// Draws of the null per round by default: the 0.01 quantile is the 21st smallest of 2 000.
pub const NULL_DRAWS: usize = 2000;

/// A round draws at least this many over α (20 draws below its quantile: 2 000 at α = 0.01).
const MIN_DRAWS_BEYOND: f64 = 20.0;

/// Seed of the first round's null draws (a round adds its index): the threshold is reproducible.
const NULL_SEED: u64 = 0x5eed_0015;

/// Seed of the unlisted search's null draws (the second term's adds 1).
const UNLISTED_SEED: u64 = 0x5eed_0050;

/// Options of [`diagnose`](crate::diagnose).
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseOptions {
    /// Family-wise significance level per round, default 0.01.
    pub alpha: f64,
    /// How α becomes each round's threshold (default: simulated, [`NULL_DRAWS`] draws).
    pub multiplicity: Multiplicity,
    /// Candidate effect names to try (`None`: all families).
    pub candidates: Option<Vec<String>>,
    /// Leave the touch-off free (an infinite prior SD) whatever the session states.
    pub free_offset: bool,
    /// At most this many effects are added (default [`thresholds::MAX_EFFECTS`]).
    pub max_effects: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            alpha: 0.01,
            multiplicity: Multiplicity::Simulated { draws: NULL_DRAWS },
            candidates: None,
            free_offset: false,
            max_effects: thresholds::MAX_EFFECTS,
        }
    }
}

/// A prepared diagnosis of one session: nominal model simulated and the plan analysed once; reuse
/// it for many measured files of the same plan (seeded studies).
///
/// # Examples
/// ```
/// use millcomp_diagnose::{DiagnoseOptions, Diagnoser, Measured};
/// use millcomp_synthetic::variants::{Row, VariantSpec, draw, study_session};
/// let session = study_session();
/// let d = Diagnoser::new(&session, &DiagnoseOptions::default()).unwrap();
/// assert_eq!(d.session_model().len(), 294);
/// // a measured session of the study's distribution: the nominal model off (force scale,
/// // stiffness, wearland, touch-off), 0.5 µm groove scatter, a tool wear with a logistic,
/// // load-driven or running-in shape hidden (dev seed, not the study's)
/// let v = draw(&session, &VariantSpec { row: Row::Single, effects: vec!["tool_wear"], seed: 9_000_004 })
///     .unwrap();
/// let rep = d.run(&Measured::new("wear.csv", v.points)).unwrap();
/// assert_eq!(rep.named, vec!["tool_wear".to_string()]);
/// // the nominal model was recalibrated first (RMS 10.4 → 3.0 µm), then the wear named
/// // (→ 0.8 µm: the groove scatter of 0.5 µm and what the family's shapes miss of this
/// // running-in-then-linear wear)
/// assert_eq!(rep.nuisance.params.len(), 5);
/// assert!(rep.nuisance_rms_um < 0.5 * rep.initial_rms_um);
/// assert!(rep.final_rms_um < 0.5 * rep.nuisance_rms_um);
/// ```
#[derive(Debug, Clone)]
pub struct Diagnoser {
    sm: SessionModel,
    nm: NuisanceModel,
    families: Vec<Family>,
    skipped: Vec<Skipped>,
    opts: DiagnoseOptions,
    nuis: NuisanceSet,
    plan: PlanAnalysis,
    /// The plan with each standard change appended ([`aliasing::changed_plans`]), for the
    /// look-alikes' proposals: played out by sim the first time a look-alike needs it.
    changed: OnceLock<Vec<(String, SessionModel)>>,
}

/// The leave-one-groove-out criterion: the held-out grooves are predicted better with the
/// candidate — or, when most of its evidence is the nuisance's prior (it is aliased with the
/// nominal model: the nuisance absorbs the same shape, so no prediction changes), not worse by
/// more than one whitened χ² unit per parameter, what a parameter fitted to noise costs.
fn logo_accepts(test: &StrataTest, l: Logo, q: usize) -> bool {
    if test.shares[2] > 0.5 {
        l.after <= l.before + q as f64
    } else {
        l.after < l.before
    }
}

/// Least squares `min ‖a·x − b‖` by the normal equations with a ridge of 1e-12 of the mean
/// diagonal (a start value or the coefficients of a full-rank block; `None` if they fail).
fn lstsq(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let p = a.ncols();
    let mut ata = a.transpose() * a;
    let ridge = 1e-12 * ata.trace().max(1e-300) / p.max(1) as f64;
    for k in 0..p {
        ata[(k, k)] += ridge;
    }
    let x = ata.cholesky()?.solve(&(a.transpose() * b));
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The smallest `‖r + B·β‖²` over β ≥ 0 (B with at most a few columns: every subset of
/// columns is solved by least squares and the best one with all coefficients ≥ 0 is kept; the
/// non-negative least-squares optimum is one of them). `None` when only β = 0 is feasible.
fn nonnegative_rss(b: &DMatrix<f64>, r: &DMatrix<f64>) -> Option<f64> {
    let k = b.ncols();
    let mut best: Option<f64> = None;
    for mask in 1u32..(1u32 << k) {
        let cols: Vec<usize> = (0..k).filter(|j| mask & (1 << j) != 0).collect();
        let bs = b.select_columns(&cols);
        let Some(beta) = lstsq(&bs, &(-r)) else {
            continue;
        };
        if beta.iter().any(|v| *v < 0.0) {
            continue;
        }
        let rss = (r + &bs * &beta).norm_squared();
        if best.is_none_or(|b| rss < b) {
            best = Some(rss);
        }
    }
    best
}

/// Whether a fitted term (its parameters `theta`, coefficients first) breaks its shape's sign
/// constraint (every coefficient ≥ 0 for a non-negative shape).
fn sign_violated(shape: &Shape, theta: &[f64]) -> bool {
    shape.nonnegative && theta.iter().take(shape.linear.len()).any(|v| *v < 0.0)
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

fn resid(y: &[f64], p: &[f64]) -> Vec<f64> {
    y.iter().zip(p).map(|(a, b)| a - b).collect()
}

/// A candidate shape fitted in a round.
struct Candidate {
    family: usize,
    term: Term,
    shapes: Vec<(String, f64)>,
    alt: Fitted,
    test: StrataTest,
    /// Raw RMS residual of the model with it (µm).
    rms_after: f64,
}

impl Diagnoser {
    /// Prepares a diagnosis with the standard families ([`families::standard`]).
    ///
    /// # Errors
    /// As [`Diagnoser::with_families`].
    pub fn new(session: &Session, opts: &DiagnoseOptions) -> Result<Self> {
        Self::with_families(session, &families::standard(), opts)
    }

    /// Prepares a diagnosis with the given candidate families: simulates the nominal model and
    /// analyses the plan once.
    ///
    /// # Errors
    /// [`DiagnoseError::InvalidOption`] for `alpha` outside (0, 1) or `max_effects` 0,
    /// [`DiagnoseError::UnknownCandidate`] for a name in `opts.candidates` that is no family,
    /// [`DiagnoseError::Session`] when sim cannot evaluate the session.
    pub fn with_families(
        session: &Session,
        families: &[Family],
        opts: &DiagnoseOptions,
    ) -> Result<Self> {
        if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
            return Err(DiagnoseError::InvalidOption {
                name: "alpha",
                value: opts.alpha,
                allowed: "0 < alpha < 1",
            });
        }
        if opts.max_effects == 0 {
            return Err(DiagnoseError::InvalidOption {
                name: "max_effects",
                value: 0.0,
                allowed: ">= 1",
            });
        }
        let names: Vec<String> = match &opts.candidates {
            Some(c) => c.clone(),
            None => families.iter().map(|f| f.name.to_string()).collect(),
        };
        let sm = SessionModel::new(session)?;
        let nm = NuisanceModel::new(&sm.deflection);
        let mut sd = nuisance::prior_sd(&session.uncertainty);
        if opts.free_offset {
            sd[nuisance::TOUCH_OFF] = f64::INFINITY;
        }
        let nuis = NuisanceSet::new(sd);
        let known: Vec<&str> = sm.known_effects.iter().map(|e| e.name()).collect();
        let mut chosen: Vec<Family> = Vec::new();
        let mut skipped = Vec::new();
        for name in &names {
            let fam = families.iter().find(|f| f.name == name).ok_or_else(|| {
                DiagnoseError::UnknownCandidate {
                    name: name.clone(),
                    allowed: families
                        .iter()
                        .map(|f| f.name)
                        .collect::<Vec<_>>()
                        .join(", "),
                }
            })?;
            if chosen.iter().any(|c| c.name == fam.name) {
                continue;
            }
            if known.contains(&fam.name) {
                skipped.push(Skipped {
                    effect: name.clone(),
                    note:
                        "already in the session's nominal model ([[effects]] of the session file)"
                            .into(),
                });
            } else {
                chosen.push(fam.clone());
            }
        }
        let plan = aliasing::analyse(&sm, &chosen, &nuis);
        for f in &plan.families {
            if !f.testable {
                skipped.push(Skipped {
                    effect: f.effect.clone(),
                    note: f.note.clone(),
                });
            }
        }
        Ok(Diagnoser {
            sm,
            nm,
            families: chosen,
            skipped,
            opts: opts.clone(),
            nuis,
            plan,
            changed: OnceLock::new(),
        })
    }

    /// The nominal model.
    pub fn session_model(&self) -> &SessionModel {
        &self.sm
    }

    /// The plan analysis (what the plan cannot separate, and the proposed changes).
    pub fn plan(&self) -> &PlanAnalysis {
        &self.plan
    }

    fn problem<'a>(&'a self, y: &'a [f64], terms: &'a [Term], w: &'a Whitening) -> Problem<'a> {
        Problem {
            sm: &self.sm,
            nm: &self.nm,
            y,
            terms,
            w,
            nuis: &self.nuis,
        }
    }

    fn groups(&self) -> Vec<(usize, usize)> {
        self.sm.facts.grooves.iter().map(|g| (g.1, g.2)).collect()
    }

    /// Re-estimates the variance components from `cur` and refits in the new whitening (twice).
    ///
    /// With `cap`, the groove scatter that weights the fits is at most the stated one: while an
    /// effect is still missing from the model, the scatter estimated from its residual holds that
    /// effect's groove-to-groove part, and weighting by it would hide exactly the between-groove
    /// discrepancy the selection must explain. The tests do not depend on the weights (each
    /// stratum's variance is re-estimated from the alternative's residual), only the efficiency
    /// does; the final model is refitted with the estimate itself.
    fn reweight(
        &self,
        y: &[f64],
        terms: &[Term],
        mut cur: Fitted,
        mut w: Whitening,
        cap: bool,
    ) -> Result<(Fitted, Whitening, Components)> {
        let groups = self.groups();
        let stated = self.sm.session.uncertainty.groove_scatter_um;
        let mut comps = None;
        for _ in 0..2 {
            let p = self.problem(y, terms, &w);
            let e = resid(y, &p.predict(&cur.theta));
            let q = orthonormal_basis(&cur.x);
            let tr = strata_of_columns(&w, &q, y.len());
            let c = scatter::estimate(&groups, &e, tr[0], tr[1], stated);
            let sg = if cap {
                c.sigma_g_um.min(stated)
            } else {
                c.sigma_g_um
            };
            w = Whitening::new(&groups, c.sigma_e_um, sg);
            let p = self.problem(y, terms, &w);
            cur = fit(&p, &cur.theta).map_err(|source| DiagnoseError::Fit {
                what: "the model in the re-estimated groove scatter".into(),
                source,
            })?;
            comps = Some(c);
        }
        let comps = comps.unwrap_or(Components {
            sigma_e_um: w.sigma_e_um,
            sigma_g_um: w.sigma_g_um,
            df_within: 0.0,
            df_between: 0.0,
        });
        Ok((cur, w, comps))
    }

    /// The model without term `k`, refitted from the current estimate: its terms, its starting
    /// θ and its fit (`None` when the fit fails).
    fn without(
        &self,
        y: &[f64],
        terms: &[Term],
        cur: &Fitted,
        w: &Whitening,
        k: usize,
    ) -> Option<(Vec<Term>, Vec<f64>, Fitted)> {
        let a = self.problem(y, terms, w).term_start(k);
        let q = terms[k].shape.n_params();
        let mut theta_wo = cur.theta[..a].to_vec();
        theta_wo.extend_from_slice(&cur.theta[a + q..]);
        let others: Vec<Term> = terms
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != k)
            .map(|(_, t)| t.clone())
            .collect();
        let base = fit(&self.problem(y, &others, w), &theta_wo).ok()?;
        Some((others, theta_wo, base))
    }

    /// The model without term `k` ([`Self::without`]) and the full model with term `k` moved last,
    /// at the joint estimate `cur` — its columns are then the candidate's, as [`Self::test`] and
    /// [`Self::test_beyond`] expect. `None` when the fit without it fails.
    fn without_and_last(
        &self,
        y: &[f64],
        terms: &[Term],
        cur: &Fitted,
        w: &Whitening,
        k: usize,
    ) -> Option<(Fitted, Fitted)> {
        let a = self.problem(y, terms, w).term_start(k);
        let q = terms[k].shape.n_params();
        let (mut last, mut theta, base) = self.without(y, terms, cur, w, k)?;
        last.push(terms[k].clone());
        theta.extend_from_slice(&cur.theta[a..a + q]);
        let full = evaluate(&self.problem(y, &last, w), &theta, cur.converged);
        Some((base, full))
    }

    /// Backward elimination: after an effect is added, every effect in the model is tested for
    /// removal (the GLS test of the model without it, at the round's threshold, its amplitude and
    /// the held-out grooves); the least needed one that fails is removed, and the check repeats.
    /// A removed effect is not tried again.
    fn eliminate(
        &self,
        y: &[f64],
        terms: &mut Vec<Term>,
        mut cur: Fitted,
        w: &Whitening,
        threshold: f64,
        notes: &mut Vec<String>,
    ) -> Fitted {
        let resolution = self.sm.session.uncertainty.resolution_um;
        while terms.len() >= 2 {
            let mut worst: Option<(f64, usize, Fitted, String)> = None;
            for k in 0..terms.len() {
                let p_all = self.problem(y, terms, w);
                let q = terms[k].shape.n_params();
                let Some((base, full)) = self.without_and_last(y, terms, &cur, w, k) else {
                    continue;
                };
                let test = self.test(w, &base, &full, q);
                let offsets = p_all.term_offsets(&cur.theta, k);
                let amp = offsets.iter().fold(0.0f64, |m, v| m.max(*v))
                    - offsets.iter().fold(0.0f64, |m, v| m.min(*v));
                let logo_with = logo::score(w, &cur.x, &cur.r);
                let logo_without = logo::score(w, &base.x, &base.r);
                let why = if test.p_value >= threshold {
                    Some(format!("no longer significant (p = {:.2e})", test.p_value))
                } else if amp <= resolution {
                    Some(format!("its amplitude fell to {amp:.3} µm"))
                } else if !logo_accepts(
                    &test,
                    Logo {
                        before: logo_without,
                        after: logo_with,
                    },
                    q,
                ) {
                    Some("the held-out grooves are predicted as well without it".into())
                } else {
                    None
                };
                if let Some(why) = why {
                    if worst.as_ref().is_none_or(|b| test.p_value > b.0) {
                        worst = Some((test.p_value, k, base, why));
                    }
                }
            }
            let Some((_, k, base, why)) = worst else {
                break;
            };
            notes.push(format!(
                "{} removed once the later effects were added: {why}",
                terms[k].family
            ));
            terms.remove(k);
            cur = base;
        }
        cur
    }

    /// Re-chooses the shape of every effect in the model once the groove scatter has been
    /// re-estimated (the round chose it in the previous model's whitening, where an unmodelled
    /// effect inflates the between-groove variance and hides the shapes' differences there): each
    /// other shape of the family is fitted in its place and kept if its GLS-BIC is lower.
    fn refine_shapes(
        &self,
        y: &[f64],
        terms: &mut Vec<Term>,
        mut cur: Fitted,
        w: &Whitening,
        notes: &mut Vec<String>,
    ) -> Fitted {
        let n = y.len();
        let ln_n = (n as f64).ln();
        let names: Vec<&'static str> = terms.iter().map(|t| t.family).collect();
        for name in names {
            let Some(fam) = self.families.iter().find(|f| f.name == name) else {
                continue;
            };
            if fam.shapes.len() < 2 {
                continue;
            }
            let Some(k) = terms.iter().position(|t| t.family == name) else {
                continue;
            };
            let Some((others, _, base)) = self.without(y, terms, &cur, w, k) else {
                continue;
            };
            let q0 = orthonormal_basis(&base.x);
            let crit_cur = cur.rss + cur.theta.len() as f64 * ln_n;
            let mut best: Option<(f64, Shape, Fitted)> = None;
            for s in &fam.shapes {
                if s.name == terms[k].shape.name
                    || n < base.theta.len() + s.n_params() + thresholds::MIN_RESIDUAL_DOF
                {
                    continue;
                }
                let Some((_, phi)) = self.linear_search(s, w, &base, &q0, None) else {
                    continue;
                };
                let mut t2 = others.clone();
                t2.push(Term {
                    family: fam.name,
                    shape: s.clone(),
                });
                let Ok(f) = self.fit_added(&self.problem(y, &t2, w), s, &phi, w, &base) else {
                    continue;
                };
                if sign_violated(s, &f.theta[base.theta.len()..]) {
                    continue;
                }
                let crit = f.rss + f.theta.len() as f64 * ln_n;
                if crit < crit_cur && best.as_ref().is_none_or(|b| crit < b.0) {
                    best = Some((crit, s.clone(), f));
                }
            }
            if let Some((_, s, f)) = best {
                notes.push(format!(
                    "{}: shape `{}` replaced by `{}` once the groove scatter was re-estimated (lower GLS-BIC)",
                    fam.name, terms[k].shape.name, s.name
                ));
                let mut t2 = others;
                t2.push(Term {
                    family: fam.name,
                    shape: s,
                });
                *terms = t2;
                cur = f;
            }
        }
        cur
    }

    /// Residual variances per stratum of a fitted model and their dof.
    fn strata_variance(&self, w: &Whitening, f: &Fitted, n: usize) -> StrataVariance {
        Self::strata_variance_of(w, &orthonormal_basis(&f.x), &f.r, n)
    }

    /// Residual variances per stratum of a model with orthonormal basis `q` and whitened
    /// residual `r`, and their dof.
    fn strata_variance_of(
        w: &Whitening,
        q: &DMatrix<f64>,
        r: &DVector<f64>,
        n: usize,
    ) -> StrataVariance {
        let tr = strata_of_columns(w, q, n);
        let rs = strata_of_residual(w, r, n);
        let g = w.n_groups() as f64;
        let df_w = (n as f64 - g - tr[0]).max(1.0);
        let df_b = g - tr[1];
        let (s2_b, df_b) = if df_b >= 1.0 {
            (
                (rs[1] + PRIOR_SCATTER_DOF) / (df_b + PRIOR_SCATTER_DOF),
                df_b + PRIOR_SCATTER_DOF,
            )
        } else {
            (1.0, PRIOR_SCATTER_DOF)
        };
        StrataVariance {
            s2: [rs[0] / df_w, s2_b],
            df: [df_w, df_b],
        }
    }

    /// The linearised fit of `shape` added to the current model over its grid: the best
    /// nonlinear parameters, their coefficients and the step of the current parameters.
    /// With `null` given, each grid point's projected columns are pushed to it (the round's
    /// simulated threshold repeats this search on draws of the null, [`familywise`]).
    fn linear_search(
        &self,
        shape: &Shape,
        w: &Whitening,
        cur: &Fitted,
        q0: &DMatrix<f64>,
        mut null: Option<&mut Vec<NullBlock>>,
    ) -> Option<(f64, Vec<f64>)> {
        let rows = cur.r.len();
        let r_perp = project_out(q0, &DMatrix::from_column_slice(rows, 1, cur.r.as_slice()));
        let base_rss = r_perp.norm_squared();
        let mut best: Option<(f64, Vec<f64>)> = None;
        for phi in shape.grid() {
            // every shape has a column (a fixed one its offsets): `stack` is `None` for none
            let Some(b) = self.stack(whitened(w, shape.columns(&self.sm, &phi)), rows) else {
                continue;
            };
            let rss = if shape.is_fixed() {
                let bp = project_out(q0, &b);
                let rss = (&r_perp + &bp).norm_squared();
                if let Some(v) = null.as_deref_mut() {
                    v.push(NullBlock::Fixed(bp));
                }
                rss
            } else {
                let bp = project_out(q0, &b);
                let q = orthonormal_basis(&bp);
                if q.ncols() < bp.ncols() {
                    continue;
                }
                if let Some(v) = null.as_deref_mut() {
                    v.push(NullBlock::Free(q.clone()));
                }
                // coefficients: least squares of −r⊥ on B⊥ (full column rank: checked above),
                // non-negative ones by the best subset with every coefficient ≥ 0
                if shape.nonnegative {
                    nonnegative_rss(&bp, &r_perp).unwrap_or(base_rss)
                } else {
                    let Some(beta) = lstsq(&bp, &(-&r_perp)) else {
                        continue;
                    };
                    (&r_perp + &bp * &beta).norm_squared()
                }
            };
            if best.as_ref().is_none_or(|b| rss < b.0) {
                best = Some((rss, phi));
            }
        }
        best
    }

    /// Starting θ for the model `terms + [shape at phi]` from the current estimate: the
    /// coefficients and the current parameters' step of the linearised fit.
    fn start_for(&self, shape: &Shape, phi: &[f64], w: &Whitening, cur: &Fitted) -> Vec<f64> {
        let n = self.sm.len();
        let rows = cur.r.len();
        let cols = shape.columns(&self.sm, phi);
        let mut x = DMatrix::zeros(rows, cur.x.ncols() + shape.linear.len());
        x.columns_mut(0, cur.x.ncols()).copy_from(&cur.x);
        let mut rhs = -cur.r.clone();
        for (j, mut c) in cols.into_iter().enumerate() {
            w.apply(&mut c);
            if shape.is_fixed() {
                for (i, v) in c.iter().enumerate() {
                    rhs[i] -= v;
                }
            } else {
                x.column_mut(cur.x.ncols() + j)
                    .rows_mut(0, n)
                    .copy_from_slice(&c);
            }
        }
        let rhs = DMatrix::from_column_slice(rhs.len(), 1, rhs.as_slice());
        let step = lstsq(&x, &rhs)
            .map(|m| DVector::from_column_slice(m.as_slice()))
            .unwrap_or_else(|| DVector::zeros(cur.x.ncols() + shape.linear.len()));
        let mut theta: Vec<f64> = cur
            .theta
            .iter()
            .zip(step.iter())
            .map(|(t, d)| t + d)
            .collect();
        theta.extend(step.iter().skip(cur.x.ncols()));
        theta.extend_from_slice(phi);
        theta
    }

    /// Starting θ for the model `terms + [shape at phi]` that cannot fit worse than `cur`: the
    /// current estimate unchanged, the new term's coefficients regressed on the current residual
    /// (zero for a non-negative shape whose regression breaks its sign, and for a fixed shape).
    fn nested_start(&self, shape: &Shape, phi: &[f64], w: &Whitening, cur: &Fitted) -> Vec<f64> {
        let n = self.sm.len();
        let mut coef = vec![0.0; shape.linear.len()];
        let r = DMatrix::from_column_slice(n, 1, &cur.r.as_slice()[..n]);
        if !shape.is_fixed()
            && let Some(b) = self.stack(whitened(w, shape.columns(&self.sm, phi)), n)
            && let Some(beta) = lstsq(&b, &(-r))
            && !sign_violated(shape, beta.as_slice())
        {
            coef.copy_from_slice(beta.as_slice());
        }
        let mut theta = cur.theta.clone();
        theta.extend(coef);
        theta.extend_from_slice(phi);
        theta
    }

    /// Fits `p`, the model of `cur` plus one term (`shape` at `phi` from the linear search), from
    /// the linearised start ([`Self::start_for`]). A nested model cannot fit worse than `cur`: when
    /// that fit ends above `cur`'s RSS — the linearised step sent a nonlinear parameter where the
    /// trust region cannot come back from, or out of the residual's finite range — it is fitted
    /// again from [`Self::nested_start`], and if that also ends above, the model at the nested
    /// start is returned unconverged. An error when the fit from the nested start fails.
    fn fit_added(
        &self,
        p: &Problem<'_>,
        shape: &Shape,
        phi: &[f64],
        w: &Whitening,
        cur: &Fitted,
    ) -> std::result::Result<Fitted, millcomp_identify::IdentifyError> {
        let tol = 1e-9 * cur.rss.max(1.0);
        let start = self.start_for(shape, phi, w, cur);
        let mut first_err = None;
        if start.iter().all(|v| v.is_finite()) {
            match fit(p, &start) {
                Ok(f) if f.rss <= cur.rss + tol => return Ok(f),
                Ok(_) => {}
                Err(e) => first_err = Some(e),
            }
        }
        let safe = self.nested_start(shape, phi, w, cur);
        match fit(p, &safe) {
            Ok(f) if f.rss <= cur.rss + tol => Ok(f),
            Ok(_) => Ok(evaluate(p, &safe, false)),
            Err(e) => Err(first_err.unwrap_or(e)),
        }
    }

    /// The whitened flexible driver bases ([`Family::driver_basis`]) of the effects in the model
    /// (data rows; the prior rows are zero), or `None` when no named effect has one.
    fn named_driver_basis(
        &self,
        terms: &[Term],
        theta: &[f64],
        w: &Whitening,
        rows: usize,
    ) -> Option<DMatrix<f64>> {
        let mut cols: Vec<Vec<f64>> = Vec::new();
        let mut a = self.nuis.free.len();
        for t in terms {
            // the runout the term was fitted with (its first nonlinear parameter)
            let runout = theta.get(a + t.shape.linear.len()).copied();
            cols.extend(self.term_basis(t, runout, w));
            a += t.shape.n_params();
        }
        self.stack(cols, rows)
    }

    /// The whitened flexible driver basis of one term's family (data rows).
    fn term_basis(&self, t: &Term, runout_um: Option<f64>, w: &Whitening) -> Vec<Vec<f64>> {
        let Some(fam) = self.families.iter().find(|f| f.name == t.family) else {
            return Vec::new();
        };
        let runout = if t.shape.nonlinear.is_empty() {
            3.0
        } else {
            runout_um.unwrap_or(3.0)
        };
        whitened(w, fam.driver_basis(&self.sm, runout))
    }

    /// Columns (data rows) as a matrix with `rows` rows (prior rows zero), `None` when empty.
    fn stack(&self, cols: Vec<Vec<f64>>, rows: usize) -> Option<DMatrix<f64>> {
        if cols.is_empty() {
            return None;
        }
        let n = self.sm.len();
        let mut e = DMatrix::zeros(rows, cols.len());
        for (j, c) in cols.iter().enumerate() {
            e.column_mut(j).rows_mut(0, n).copy_from_slice(c);
        }
        Some(e)
    }

    /// The test of a candidate (fitted as `alt`, `q` parameters) against the current model `cur`
    /// with the flexible driver bases `e` of the named effects added to both (linearised at each
    /// fit): what the candidate explains that no shape in the named effects' own drivers could.
    fn test_beyond(
        &self,
        w: &Whitening,
        cur: &Fitted,
        alt: &Fitted,
        q: usize,
        e: &DMatrix<f64>,
    ) -> StrataTest {
        let n = self.sm.len();
        let p0 = cur.x.ncols();
        let hstack = |a: &DMatrix<f64>, b: &DMatrix<f64>| {
            let mut m = DMatrix::zeros(a.nrows(), a.ncols() + b.ncols());
            m.columns_mut(0, a.ncols()).copy_from(a);
            m.columns_mut(a.ncols(), b.ncols()).copy_from(b);
            m
        };
        let col = |r: &DVector<f64>| DMatrix::from_column_slice(r.len(), 1, r.as_slice());
        let q0 = orthonormal_basis(&hstack(&cur.x, e));
        let rss0 = project_out(&q0, &col(&cur.r)).norm_squared();
        let q1 = orthonormal_basis(&hstack(&alt.x, e));
        let r1 = project_out(&q1, &col(&alt.r));
        let rss1 = r1.norm_squared();
        let qa = orthonormal_basis(&hstack(&alt.x.columns(0, p0).into_owned(), e));
        let qc = orthonormal_basis(&project_out(&qa, &alt.x.columns(p0, q).into_owned()));
        let s = strata_of_columns(w, &qc, n);
        let tot = (s[0] + s[1] + s[2]).max(1e-300);
        let shares = [s[0] / tot, s[1] / tot, s[2] / tot];
        let r1v = DVector::from_column_slice(r1.as_slice());
        let v = Self::strata_variance_of(w, &q1, &r1v, n);
        strata_test(rss0 - rss1, q.min(qc.ncols()).max(1), shares, &v)
    }

    /// Tests one candidate term fitted as `alt` against the current model `cur`.
    fn test(&self, w: &Whitening, cur: &Fitted, alt: &Fitted, q: usize) -> StrataTest {
        let n = self.sm.len();
        let p0 = cur.x.ncols();
        let x0 = alt.x.columns(0, p0).into_owned();
        let xc = alt.x.columns(p0, q).into_owned();
        let q0 = orthonormal_basis(&x0);
        let qc = orthonormal_basis(&project_out(&q0, &xc));
        let s = strata_of_columns(w, &qc, n);
        let tot = (s[0] + s[1] + s[2]).max(1e-300);
        let shares = [s[0] / tot, s[1] / tot, s[2] / tot];
        let v = self.strata_variance(w, alt, n);
        strata_test(cur.rss - alt.rss, q, shares, &v)
    }

    /// Parameter estimates, SEs and 95 % intervals of a fitted model, by parameter index.
    fn intervals(&self, w: &Whitening, f: &Fitted) -> Vec<(f64, f64, [f64; 2])> {
        self.interval_parts(w, f)
            .into_iter()
            .map(|(est, se, t, _)| (est, se, [est - t * se, est + t * se]))
            .collect()
    }

    /// Profile-likelihood 95 % intervals of the terms' nonlinear parameters (time constants,
    /// onsets, runouts, …), in place of the linearised ones in `iv`: `{v : RSS(θ_j = v) − RSS ≤
    /// s²·t²}` with every other parameter refitted at each v, s² and the t quantile as the
    /// linearised interval's (the strata's combined variance and its Satterthwaite dof). Where
    /// the model is nearly linear in the parameter both agree; where it is not (the onset of a
    /// speed-dependent growth between two of the plan's speeds, a runout interacting with the
    /// force scale) the linearised interval was too narrow (`docs/studies/diagnose.md`). A side whose
    /// profile never reaches the level within the parameter's bounds ends at the bound; a side
    /// whose constrained fits fail keeps the linearised end.
    fn profile_intervals(
        &self,
        y: &[f64],
        terms: &[Term],
        w: &Whitening,
        f: &Fitted,
        iv: &mut [(f64, f64, [f64; 2])],
    ) {
        let parts = self.interval_parts(w, f);
        let p = self.problem(y, terms, w);
        let specs = p.param_specs(&f.theta);
        for (k, t) in terms.iter().enumerate() {
            let a = p.term_start(k) + t.shape.linear.len();
            for j in a..a + t.shape.nonlinear.len() {
                let (_, se, tq, s2) = parts[j];
                let crit = s2 * tq * tq;
                if !(crit.is_finite() && se.is_finite() && se > 0.0) {
                    continue;
                }
                let (lo_b, hi_b) = (specs[j].lower, specs[j].upper);
                for (side, end) in [(-1.0, 0usize), (1.0, 1usize)] {
                    let limit = if side < 0.0 { lo_b } else { hi_b };
                    if let Some(b) = self.profile_end(&p, f, j, side, limit, tq * se, crit) {
                        iv[j].2[end] = b;
                    }
                }
            }
        }
    }

    /// One end of a profile interval (see [`Self::profile_intervals`]): steps out from the
    /// estimate (first step the linearised half-width, then doubling) until the constrained RSS
    /// rises by `crit`, then regula falsi on √ΔRSS; `None` when a constrained fit fails before
    /// the level is bracketed.
    #[allow(clippy::too_many_arguments)]
    fn profile_end(
        &self,
        p: &Problem<'_>,
        f: &Fitted,
        j: usize,
        side: f64,
        limit: f64,
        half_width: f64,
        crit: f64,
    ) -> Option<f64> {
        let est = f.theta[j];
        let range = if limit.is_finite() {
            (limit - est).abs()
        } else {
            f64::INFINITY
        };
        // stay a hair inside the bound (the bounded transform is singular on it)
        let max_step = if range.is_finite() {
            range * (1.0 - 1e-6)
        } else {
            f64::INFINITY
        };
        let delta = |v: f64, start: &[f64]| -> Option<(f64, Vec<f64>)> {
            fit_held(p, start, j, v)
                .ok()
                .map(|(theta, rss)| ((rss - f.rss).max(0.0), theta))
        };
        let g = |d: f64| d.sqrt() - crit.sqrt();
        let mut inside = (0.0f64, f.theta.clone(), 0.0f64); // (distance, θ, ΔRSS)
        let mut step = half_width.max(1e-9 * est.abs().max(1.0));
        let mut outside: Option<(f64, f64)> = None;
        for _ in 0..10 {
            let dist = (inside.0 + step).min(max_step);
            let (d, theta) = delta(est + side * dist, &inside.1)?;
            if d >= crit {
                outside = Some((dist, d));
                break;
            }
            inside = (dist, theta, d);
            if dist >= max_step {
                return Some(est + side * dist);
            }
            step *= 2.0;
        }
        let (mut d_out, mut delta_out) = outside?;
        for _ in 0..6 {
            let (d_in, ref th_in, delta_in) = inside;
            let (g_in, g_out) = (g(delta_in), g(delta_out));
            let dist = d_in + (d_out - d_in) * (-g_in) / (g_out - g_in).max(1e-300);
            let Some((d, theta)) = delta(est + side * dist, th_in) else {
                break;
            };
            if g(d).abs() < 0.01 * crit.sqrt() {
                return Some(est + side * dist);
            }
            if d < crit {
                inside = (dist, theta, d);
            } else {
                d_out = dist;
                delta_out = d;
            }
        }
        Some(est + side * 0.5 * (inside.0 + d_out))
    }

    /// Estimate, SE, t quantile and combined stratum variance of every parameter of a fitted
    /// model (the linearised interval is estimate ± t·SE).
    fn interval_parts(&self, w: &Whitening, f: &Fitted) -> Vec<(f64, f64, f64, f64)> {
        let n = self.sm.len();
        let p = f.x.ncols();
        let v = self.strata_variance(w, f, n);
        let xtx = f.x.transpose() * &f.x;
        let inv = xtx
            .try_inverse()
            .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
        (0..p)
            .map(|j| {
                let others: Vec<usize> = (0..p).filter(|&k| k != j).collect();
                let x0 = f.x.select_columns(&others);
                let q0 = orthonormal_basis(&x0);
                let xj = project_out(&q0, &f.x.columns(j, 1).into_owned());
                let nrm = xj.norm_squared().max(1e-300);
                let qj = xj / nrm.sqrt();
                let s = strata_of_columns(w, &qj, n);
                let tot = (s[0] + s[1] + s[2]).max(1e-300);
                let (s2, df) = v.combine([s[0] / tot, s[1] / tot, s[2] / tot]);
                let se = (inv[(j, j)] * s2).sqrt();
                (f.theta[j], se, t975(df), s2)
            })
            .collect()
    }

    /// Diagnoses one measured file of this session.
    ///
    /// # Errors
    /// [`DiagnoseError::InvalidPoints`] when the points are not a measurement,
    /// [`DiagnoseError::SessionMismatch`] when they (or the force-trace rows) are not this session's
    /// plan point by point, [`DiagnoseError::Fit`] when the nominal model cannot be recalibrated;
    /// with a force trace also [`DiagnoseError::NonFinite`] for a NaN or infinite force value and
    /// [`DiagnoseError::Session`] when sim cannot evaluate the force model at the measured
    /// conditions ([`force_channel::diagnose_forces`]). Example at [`Diagnoser`].
    pub fn run(&self, measured: &Measured) -> Result<DiagnoseReport> {
        let sm = &self.sm;
        measured.check_against(sm)?;
        let y = measured.depth_meas_um();
        let spindle_temp_c = measured.spindle_temp_c();
        let n = y.len();
        let alpha = self.opts.alpha;
        let u = &sm.session.uncertainty;
        let mut notes = Vec::new();
        let mut skipped = self.skipped.clone();
        let groups = self.groups();
        let ln_n = (n as f64).ln();

        // nuisance step
        let initial_rms = rms(&resid(&y, &sm.base_um));
        let w0 = Whitening::new(&groups, u.measurement_sd_um, u.groove_scatter_um);
        let mut terms: Vec<Term> = Vec::new();
        let start = vec![0.0; self.nuis.free.len()];
        let first =
            fit(&self.problem(&y, &terms, &w0), &start).map_err(|source| DiagnoseError::Fit {
                what: "the nominal model's nuisance parameters".into(),
                source,
            })?;
        let (mut cur, mut w, nuisance_comps) = self.reweight(&y, &terms, first, w0, true)?;
        let nuisance_pred = self.problem(&y, &terms, &w).predict(&cur.theta);
        let nuisance_rms = rms(&resid(&y, &nuisance_pred));
        let structure_nominal =
            structure::residual_structure(sm, &resid(&y, &sm.base_um), spindle_temp_c.as_deref());
        let mut series = Series {
            groove_id: measured.points.iter().map(|p| p.groove_id).collect(),
            measured_um: y.clone(),
            predictions_um: vec![sm.base_um.clone(), nuisance_pred.clone()],
        };

        let mut steps: Vec<Step> = Vec::new();
        let mut rounds: Vec<Round> = Vec::new();
        let mut remaining: Vec<usize> = (0..self.families.len())
            .filter(|&k| self.plan.families[k].testable)
            .collect();
        if self.plan.cannot_separate_any {
            remaining.clear();
            notes.push(
                "the session plan cannot separate any candidate from the nominal model's uncertainty: \
                 nothing is named (see `aliasing` for what to change)"
                    .into(),
            );
        }
        let mut rms_now = nuisance_rms;
        while !remaining.is_empty() && terms.len() < self.opts.max_effects {
            let p0 = cur.theta.len();
            let q0 = orthonormal_basis(&cur.x);
            let mut shapes_tried = 0usize;
            // the shapes as searched, for the round's simulated threshold
            let simulated = matches!(self.opts.multiplicity, Multiplicity::Simulated { .. });
            let mut null_shapes: Vec<NullShape> = Vec::new();
            let mut cands: Vec<Candidate> = Vec::new();
            for &k in &remaining {
                let fam = &self.families[k];
                let mut ranked: Vec<(f64, usize, Vec<f64>)> = Vec::new();
                let mut tried: Vec<(String, f64)> = Vec::new();
                for (si, shape) in fam.shapes.iter().enumerate() {
                    let q = shape.n_params();
                    if n < p0 + q + thresholds::MIN_RESIDUAL_DOF {
                        let note = format!(
                            "shape `{}`: too few points: {n} measured points, the model with it has {} free parameters and needs ≥ {} points ({} residual dof)",
                            shape.name,
                            p0 + q,
                            p0 + q + thresholds::MIN_RESIDUAL_DOF,
                            thresholds::MIN_RESIDUAL_DOF
                        );
                        if !skipped
                            .iter()
                            .any(|k| k.effect == fam.name && k.note == note)
                        {
                            skipped.push(Skipped {
                                effect: fam.name.into(),
                                note,
                            });
                        }
                        continue;
                    }
                    shapes_tried += 1;
                    let mut blocks = Vec::new();
                    let null = simulated.then_some(&mut blocks);
                    let found = self.linear_search(shape, &w, &cur, &q0, null);
                    if simulated {
                        null_shapes.push(NullShape {
                            family: k,
                            params: q,
                            blocks,
                        });
                    }
                    let Some((rss, phi)) = found else {
                        continue;
                    };
                    let crit = rss + q as f64 * ln_n;
                    tried.push((shape.name.to_string(), crit));
                    ranked.push((crit, si, phi));
                }
                // the family's best shape by the linearised GLS-BIC; when its fit breaks the
                // shape's sign constraint, the next one
                ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut chosen: Option<(Shape, Fitted)> = None;
                let mut violated: Option<(Shape, Fitted)> = None;
                for (_, si, phi) in ranked {
                    let shape = fam.shapes[si].clone();
                    let mut all = terms.clone();
                    all.push(Term {
                        family: fam.name,
                        shape: shape.clone(),
                    });
                    let p = self.problem(&y, &all, &w);
                    let alt = match self.fit_added(&p, &shape, &phi, &w, &cur) {
                        Ok(f) => f,
                        Err(e) => {
                            notes.push(format!(
                                "{} ({}): no fit in round {} ({e})",
                                fam.name,
                                shape.name,
                                rounds.len() + 1
                            ));
                            continue;
                        }
                    };
                    if sign_violated(&shape, &alt.theta[p0..]) {
                        violated.get_or_insert((shape, alt));
                        continue;
                    }
                    chosen = Some((shape, alt));
                    break;
                }
                // every shape's fit broke its sign: reported with p = 1
                let no_sign = chosen.is_none();
                let Some((shape, alt)) = chosen.or(violated) else {
                    continue;
                };
                let mut all = terms.clone();
                all.push(Term {
                    family: fam.name,
                    shape: shape.clone(),
                });
                let p = self.problem(&y, &all, &w);
                let mut test = self.test(&w, &cur, &alt, shape.n_params());
                if no_sign {
                    test.p_value = 1.0;
                    test.ln_p = 0.0;
                }
                let rms_after = rms(&resid(&y, &p.predict(&alt.theta)));
                cands.push(Candidate {
                    family: k,
                    term: Term {
                        family: fam.name,
                        shape,
                    },
                    shapes: tried,
                    alt,
                    test,
                    rms_after,
                });
            }
            if cands.is_empty() {
                break;
            }
            let bonferroni = alpha / shapes_tried.max(1) as f64;
            let threshold = match self.opts.multiplicity {
                Multiplicity::Bonferroni => bonferroni,
                Multiplicity::Simulated { draws } => familywise::simulated_threshold(
                    &null_shapes,
                    cur.r.len(),
                    ln_n,
                    alpha,
                    Multiplicity::draws_at(draws, alpha),
                    NULL_SEED + rounds.len() as u64,
                )
                .unwrap_or(bonferroni),
            };
            // significant candidates first, ranked by dominance (below), then by how well the
            // model with each predicts held-out grooves (the leave-one-groove-out score, the
            // quantity the acceptance checks): the raw RMS alone (the first version) favours the
            // most flexible family, whose extra parameters also fit the misfit of another
            // effect's shape; p alone favours a pattern within grooves (hundreds of dof) over one
            // between them (a dozen groove means); the BIC of the raw residual (the second to
            // fourth rounds) favours a pattern between grooves that soaks up groove scatter (a
            // compliance in the force over a runout). The others by p.
            let sig = |c: &Candidate| c.test.p_value < threshold && cur.rss > c.alt.rss;
            let held_out: Vec<f64> = cands
                .iter()
                .map(|c| logo::score(&w, &c.alt.x, &c.alt.r))
                .collect();
            let named_basis = self.named_driver_basis(&terms, &cur.theta, &w, cur.r.len());
            // which significant candidate explains what another cannot: a candidate is
            // dominated by another when the other is significant beyond a flexible shape of the
            // candidate in its own driver and the candidate is not beyond the other's
            let significant: Vec<usize> = (0..cands.len()).filter(|&k| sig(&cands[k])).collect();
            let bases: Vec<Vec<Vec<f64>>> = cands
                .iter()
                .map(|c| {
                    let runout = c.alt.theta.get(p0 + c.term.shape.linear.len()).copied();
                    self.term_basis(&c.term, runout, &w)
                })
                .collect();
            let beyond = |a: usize, b: usize| -> bool {
                let mut cols = bases[b].clone();
                if let Some(e) = &named_basis {
                    for j in 0..e.ncols() {
                        cols.push(e.column(j).rows(0, n).iter().copied().collect());
                    }
                }
                let Some(e) = self.stack(cols, cur.r.len()) else {
                    return true;
                };
                let c = &cands[a];
                self.test_beyond(&w, &cur, &c.alt, c.term.shape.n_params(), &e)
                    .p_value
                    < threshold
            };
            let mut dominated = vec![0usize; cands.len()];
            for &a in &significant {
                for &b in &significant {
                    if a != b && beyond(b, a) && !beyond(a, b) {
                        dominated[a] += 1;
                    }
                }
            }
            let mut order: Vec<usize> = (0..cands.len()).collect();
            order.sort_by(|&a, &b| {
                let (ca, cb) = (&cands[a], &cands[b]);
                sig(cb).cmp(&sig(ca)).then(if sig(ca) && sig(cb) {
                    dominated[a]
                        .cmp(&dominated[b])
                        .then(held_out[a].total_cmp(&held_out[b]))
                } else {
                    ca.test.ln_p.total_cmp(&cb.test.ln_p)
                })
            });
            let logo_null = logo::score(&w, &cur.x, &cur.r);
            let mut tested: Vec<Tested> = Vec::new();
            let mut accepted: Option<usize> = None;
            for &ci in &order {
                let c = &cands[ci];
                let all: Vec<Term> = terms.iter().cloned().chain([c.term.clone()]).collect();
                let pa = self.problem(&y, &all, &w);
                let offsets = pa.term_offsets(&c.alt.theta, all.len() - 1);
                let amplitude = offsets.iter().fold(0.0f64, |a, v| a.max(*v))
                    - offsets.iter().fold(0.0f64, |a, v| a.min(*v));
                let significant = c.test.p_value < threshold && cur.rss > c.alt.rss;
                let l = Logo {
                    before: logo_null,
                    after: held_out[ci],
                };
                let logo_s = Some(l);
                let beyond_named = named_basis
                    .as_ref()
                    .map(|e| self.test_beyond(&w, &cur, &c.alt, c.term.shape.n_params(), e));
                let decision = if !significant {
                    format!("not significant (p ≥ {threshold:.2e})")
                } else if accepted.is_some() {
                    "significant; another candidate was added first".to_string()
                } else if let Some(b) = beyond_named.filter(|b| b.p_value >= threshold) {
                    format!(
                        "significant, but not beyond a flexible shape of the named effects in their own drivers (p = {:.1e}): what it fits is their shapes' misfit",
                        b.p_value
                    )
                } else if !logo_accepts(&c.test, l, c.term.shape.n_params()) {
                    "significant but does not improve the prediction of held-out grooves".into()
                } else if amplitude <= u.resolution_um {
                    format!(
                        "significant but its amplitude {amplitude:.3} µm is within the measurement resolution ({} µm)",
                        u.resolution_um
                    )
                } else {
                    accepted = Some(ci);
                    "added".into()
                };
                let a0 = pa.term_start(all.len() - 1);
                let params = c
                    .term
                    .shape
                    .param_names()
                    .into_iter()
                    .enumerate()
                    .map(|(j, name)| (name.to_string(), c.alt.theta[a0 + j]))
                    .collect();
                tested.push(Tested {
                    effect: c.term.family.into(),
                    shape: c.term.shape.name.into(),
                    shapes: c.shapes.clone(),
                    test: c.test,
                    rss_after: c.alt.rss,
                    rms_after_um: c.rms_after,
                    significant,
                    logo: logo_s,
                    amplitude_um: amplitude,
                    params,
                    beyond_named,
                    decision,
                });
            }
            rounds.push(Round {
                threshold,
                bonferroni_threshold: bonferroni,
                tested,
                added: accepted.map(|ci| cands[ci].term.family.to_string()),
            });
            let Some(ci) = accepted else { break };
            let c = cands.swap_remove(ci);
            let fam = &self.families[c.family];
            if !c.alt.converged {
                notes.push(format!(
                    "{} ({}): the fit that added it stopped before converging; its test is provisional",
                    fam.name, c.term.shape.name
                ));
            }
            terms.push(c.term.clone());
            let pa = self.problem(&y, &terms, &w);
            let pred = pa.predict(&c.alt.theta);
            let rms_after = rms(&resid(&y, &pred));
            let iv = self.intervals(&w, &c.alt);
            let k0 = pa.term_start(terms.len() - 1);
            let mut params = BTreeMap::new();
            let mut ci95 = BTreeMap::new();
            let mut se = BTreeMap::new();
            for (j, name) in c.term.shape.param_names().into_iter().enumerate() {
                let (e, s, i) = iv[k0 + j];
                params.insert(name.to_string(), e);
                se.insert(name.to_string(), s);
                ci95.insert(name.to_string(), i);
            }
            let logo_s = rounds
                .last()
                .and_then(|r| r.tested.iter().find(|t| t.decision == "added"))
                .and_then(|t| t.logo)
                .unwrap_or(Logo {
                    before: f64::NAN,
                    after: f64::NAN,
                });
            let amplitude = rounds
                .last()
                .and_then(|r| r.tested.iter().find(|t| t.decision == "added"))
                .map_or(f64::NAN, |t| t.amplitude_um);
            steps.push(Step {
                effect: fam.name.into(),
                p_value: c.test.p_value,
                rms_before_um: rms_now,
                rms_after_um: rms_after,
                params,
                family: fam.name.into(),
                shape: c.term.shape.name.into(),
                driver: fam.driver.into(),
                ci95,
                std_err: se,
                test: c.test,
                threshold,
                candidates_tried: shapes_tried,
                logo: logo_s,
                amplitude_um: amplitude,
                beyond_prior: c.test.shares[2] > 0.5,
                kept: true,
            });
            rms_now = rms_after;
            remaining.retain(|&k| k != c.family);
            let (f2, w2, _) = self.reweight(&y, &terms, c.alt, w, true)?;
            w = w2;
            cur = self.refine_shapes(&y, &mut terms, f2, &w, &mut notes);
            cur = self.eliminate(&y, &mut terms, cur, &w, threshold, &mut notes);
            for st in steps.iter_mut() {
                st.kept = terms.iter().any(|t| t.family == st.effect);
            }
            series
                .predictions_um
                .push(self.problem(&y, &terms, &w).predict(&cur.theta));
        }

        // beyond the candidate list: a term built from the data where structure remains
        // (`unlisted`). It is reported with the model it is added to (its RMS and held-out gap
        // before and after, the series' last prediction); the final model of the `final_*` keys
        // stays the candidates' — the named effects' estimates are not fitted beside a term that
        // is no physical effect, and `final_rms_um` is what the named effects explain.
        let mut unlisted_rejected = None;
        let (unlisted, with_unlisted, extra_um) =
            self.unlisted_step(&y, &terms, cur.clone(), &w, &mut unlisted_rejected);
        if !unlisted.is_empty() {
            let y2: Vec<f64> = y.iter().zip(&extra_um).map(|(a, b)| a - b).collect();
            let pred = self.problem(&y2, &terms, &w).predict(&with_unlisted.theta);
            series
                .predictions_um
                .push(pred.iter().zip(&extra_um).map(|(a, b)| a + b).collect());
        }
        let final_rms_with_unlisted = unlisted.last().map(|u| u.rms_after_um);

        // final model, weighted by the scatter as estimated (with nothing ever added, the
        // nuisance step's fit is the final one)
        let comps = if steps.is_empty() {
            nuisance_comps
        } else {
            let (f2, w2, comps) = self.reweight(&y, &terms, cur, w, false)?;
            cur = f2;
            w = w2;
            comps
        };
        let pf = self.problem(&y, &terms, &w);
        let pred = pf.predict(&cur.theta);
        let final_rms = rms(&resid(&y, &pred));
        let mut iv = self.intervals(&w, &cur);
        let linearised = iv.clone();
        self.profile_intervals(&y, &terms, &w, &cur, &mut iv);
        let mut final_params = BTreeMap::new();
        let mut final_ci95 = BTreeMap::new();
        let mut final_ci95_linearised = BTreeMap::new();
        let mut shapes = BTreeMap::new();
        for (k, t) in terms.iter().enumerate() {
            let a = pf.term_start(k);
            let mut pm = BTreeMap::new();
            let mut cm = BTreeMap::new();
            let mut lm = BTreeMap::new();
            for (j, name) in t.shape.param_names().into_iter().enumerate() {
                pm.insert(name.to_string(), iv[a + j].0);
                cm.insert(name.to_string(), iv[a + j].2);
                lm.insert(name.to_string(), linearised[a + j].2);
            }
            final_params.insert(t.family.to_string(), pm);
            final_ci95.insert(t.family.to_string(), cm);
            final_ci95_linearised.insert(t.family.to_string(), lm);
            shapes.insert(t.family.to_string(), t.shape.name.to_string());
        }
        let nu = pf.nu(&cur.theta);
        let mut nuisance_params = Vec::new();
        let mut nominal_free_params = BTreeMap::new();
        for (k, name) in nuisance::NAMES.iter().enumerate() {
            let j = self.nuis.free.iter().position(|&f| f == k);
            let (est, sd) = match j {
                Some(j) => (iv[j].0, iv[j].1),
                None => (0.0, 0.0),
            };
            let prior = self.nuis.sd[k];
            nominal_free_params.insert(name.to_string(), nu[k]);
            nuisance_params.push(NuisanceEstimate {
                name: name.to_string(),
                estimate: est,
                sd,
                prior_sd: prior,
                z_prior: if prior > 0.0 && prior.is_finite() {
                    est / prior
                } else {
                    0.0
                },
                determined_by: if j.is_none() {
                    "held".into()
                } else if sd < thresholds::DATA_DETERMINED * prior {
                    "data".into()
                } else {
                    "prior".into()
                },
            });
        }
        let structure_final =
            structure::residual_structure(sm, &resid(&y, &pred), spindle_temp_c.as_deref());
        let unexplained = self.unexplained(&w, &cur);
        let look_alikes = self.look_alikes(&y, &terms, &cur, &w, &steps);
        let mut named: Vec<String> = steps
            .iter()
            .filter(|s| s.kept)
            .map(|s| s.effect.clone())
            .collect();
        let within: Vec<WithinNominal> = self
            .plan
            .families
            .iter()
            .filter(|f| f.testable && f.aliased && !named.contains(&f.effect))
            .map(|f| self.within_nominal(f, &rounds, &nuisance_params, alpha))
            .collect();
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
        let verdict = if !named.is_empty() {
            "named"
        } else if !unlisted.is_empty() {
            "unlisted"
        } else if self.plan.cannot_separate_any {
            "plan_cannot_separate"
        } else {
            "none"
        };
        if named.is_empty() {
            named.push("none".into());
        }
        if spindle_temp_c.is_some() {
            notes.push(
                "spindle_temp_c is used in the residual structure only (the depth fits do not need it)"
                    .into(),
            );
        }
        Ok(DiagnoseReport {
            initial_rms_um: initial_rms,
            final_rms_um: final_rms,
            steps,
            named,
            verdict: verdict.into(),
            session: sm.name.clone(),
            n_points: n,
            alpha,
            correction: self.opts.multiplicity.describe(alpha),
            nuisance: NuisanceStep {
                params: nuisance_params,
                rms_before_um: initial_rms,
                rms_after_um: nuisance_rms,
            },
            nuisance_rms_um: nuisance_rms,
            nominal_free_params,
            scatter: ScatterReport {
                groove_sd_um: comps.sigma_g_um,
                measurement_sd_um: comps.sigma_e_um,
                df_within: comps.df_within,
                df_between: comps.df_between,
            },
            final_params,
            final_ci95,
            final_ci95_linearised,
            shapes,
            rounds,
            skipped,
            unexplained,
            unlisted,
            unlisted_rejected,
            final_rms_with_unlisted_um: final_rms_with_unlisted,
            within_nominal_uncertainty: within,
            look_alikes,
            aliasing: self.plan.aliasing.clone(),
            plan: self.plan.families.clone(),
            residual_structure: StructureReport {
                nominal: structure_nominal,
                final_: structure_final,
            },
            force_channel,
            notes,
            series,
        })
    }

    /// How a candidate aliased with the nominal model and not named is reported: within the
    /// nominal model's uncertainty, with what its last test found ([`WithinNominal`]).
    fn within_nominal(
        &self,
        f: &aliasing::FamilyPlan,
        rounds: &[Round],
        nuisance_params: &[NuisanceEstimate],
        alpha: f64,
    ) -> WithinNominal {
        let last = rounds.iter().rev().find_map(|r| {
            r.tested
                .iter()
                .find(|t| t.effect == f.effect)
                .map(|t| (r.threshold, t))
        });
        let moved: Vec<(String, f64, f64)> = f
            .aliased_with
            .iter()
            .filter_map(|a| nuisance_params.iter().find(|p| &p.name == a))
            .map(|p| (p.name.clone(), p.estimate, p.z_prior))
            .collect();
        let moved_text = moved
            .iter()
            .map(|(n, e, z)| format!("{n} {e:+.3} ({z:+.1} prior SD)"))
            .collect::<Vec<_>>()
            .join(", ");
        let indicated = last.is_some_and(|(_, t)| t.test.p_value < alpha);
        let evidence = match last {
            Some((thr, t)) if indicated => format!(
                "the data point to it (p = {:.1e} < α = {alpha} beyond the recalibrated nominal model, not below the round's threshold {thr:.1e}; as `{}` it would be {}), but a nominal model off by more than its prior looks the same",
                t.test.p_value,
                t.shape,
                t.params
                    .iter()
                    .map(|(k, v)| format!("{k} = {v:.4}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Some((_, t)) => format!(
                "the data do not point to it (p = {:.2} beyond the recalibrated nominal model)",
                t.test.p_value
            ),
            None if self.plan.cannot_separate_any => {
                "it was not tested (this plan separates no candidate from the nominal model)".into()
            }
            None => "it was not tested".into(),
        };
        WithinNominal {
            effect: f.effect.clone(),
            status: WITHIN_NOMINAL.into(),
            nuisance: f.aliased_with.clone(),
            indicated,
            p_value: last.map(|(_, t)| t.test.p_value),
            threshold: last.map(|(thr, _)| thr),
            shape: last.map(|(_, t)| t.shape.clone()),
            params: last.map(|(_, t)| t.params.clone()).unwrap_or_default(),
            nuisance_moved: moved,
            note: format!(
                "{WITHIN_NOMINAL}: this plan cannot separate it from {}, and it is not named since it does not lie beyond their prior; the nuisance step moved {moved_text}; {evidence}",
                f.aliased_with.join(", ")
            ),
        }
    }

    /// The named effects another family could also be ([`LookAlike`]): each named term is tested
    /// beyond the flexible driver basis of every family not named ([`Self::test_beyond`], the
    /// other named effects kept as fitted), at the level it was named at; where it is not
    /// significant, the standard session change that separates the two most is proposed.
    fn look_alikes(
        &self,
        y: &[f64],
        terms: &[Term],
        cur: &Fitted,
        w: &Whitening,
        steps: &[Step],
    ) -> Vec<LookAlike> {
        let mut out = Vec::new();
        for (k, term) in terms.iter().enumerate() {
            let Some(threshold) = steps
                .iter()
                .find(|s| s.effect == term.family)
                .map(|s| s.threshold)
            else {
                continue;
            };
            let Some((base, alt)) = self.without_and_last(y, terms, cur, w, k) else {
                continue;
            };
            let q = term.shape.n_params();
            let a = self.problem(y, terms, w).term_start(k);
            let own = &cur.theta[a..a + q];
            let offsets = term.shape.offsets(&self.sm, own);
            for fam in &self.families {
                if terms.iter().any(|t| t.family == fam.name)
                    || !self
                        .plan
                        .families
                        .iter()
                        .any(|f| f.effect == fam.name && f.testable)
                {
                    continue;
                }
                // the other family's flexible shape (a runout's at the driver basis's 3 µm: the
                // runout is not known when the family is not named)
                let raw = |m: &SessionModel| fam.driver_basis(m, 3.0);
                let basis = raw(&self.sm);
                let Some(e) = self.stack(whitened(w, basis.clone()), cur.r.len()) else {
                    continue;
                };
                let t = self.test_beyond(w, &base, &alt, q, &e);
                if t.p_value < threshold {
                    continue;
                }
                let unique_sd = aliasing::unique_beyond(&self.sm, &self.nuis, &offsets, &basis);
                // how much the effect's evidence beyond the other must grow for the test to
                // pass at its level, the effect and the residual variance staying as fitted: its
                // χ² beyond the other (∝ unique_sd²) must grow by F_crit / F
                let need = f_critical(t.df1 as f64, t.df2, threshold) / t.f_statistic.max(1e-300);
                let best = self
                    .changed
                    .get_or_init(|| aliasing::changed_plans(&self.sm))
                    .iter()
                    .map(|(what, m)| {
                        let off = term.shape.offsets(m, own);
                        (what, aliasing::unique_beyond(m, &self.nuis, &off, &raw(m)))
                    })
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .filter(|b| {
                        b.1 >= thresholds::MIN_UNIQUE_SD && (b.1 / unique_sd).powi(2) >= need
                    })
                    .map(|(what, after)| Proposal {
                        change: what.clone(),
                        after,
                    });
                let p = if t.p_value < 0.01 {
                    format!("{:.1e}", t.p_value)
                } else {
                    format!("{:.2}", t.p_value)
                };
                let head = format!(
                    "{} is named (its shape fits best), but a {} in a flexible shape of its own driver ({}) explains the same offsets on this plan: {} is not significant beyond it (p = {p}; named at p < {:.2e})",
                    term.family, fam.name, fam.driver, term.family, threshold
                );
                let note = match &best {
                    Some(b) => format!(
                        "{head}; add {}: it would make the part of {} that no such {} explains {}, enough for the test to pass if the effect is as fitted",
                        b.change,
                        term.family,
                        fam.name,
                        if unique_sd >= 0.1 {
                            format!("{:.1}× larger", b.after / unique_sd)
                        } else {
                            format!("grow from ≈ 0 to {:.1} noise SDs", b.after)
                        }
                    ),
                    None => format!(
                        "{head}; none of the standard session changes would make the test pass: run a session in which their drivers vary independently{}",
                        if term.family == "flute_runout" || fam.name == "flute_runout" {
                            ", or measure the per-flute peak forces (`--forces`: a runout shows as the asymmetry between the two flutes)"
                        } else {
                            ""
                        }
                    ),
                };
                out.push(LookAlike {
                    effect: term.family.into(),
                    other: fam.name.into(),
                    p_beyond: t.p_value,
                    threshold,
                    unique_sd,
                    proposal: best,
                    note,
                });
            }
        }
        out
    }

    /// Beyond the candidate list ([`unlisted`]): while the residual of `cur` follows a session
    /// variable significantly at the search's family-wise level, better on held-out grooves and
    /// beyond the resolution, a cross-validated spline (or level) term in it is added, and the
    /// model refitted to the measured depth less its offsets. Returns the terms, the model and
    /// the terms' summed offsets (µm); `rejected` says why the search's last best basis was not
    /// added. The refits alternate twice between the term's
    /// coefficients (linearised jointly with the model) and the model's nonlinear fit.
    fn unlisted_step(
        &self,
        y: &[f64],
        terms: &[Term],
        mut cur: Fitted,
        w: &Whitening,
        rejected: &mut Option<String>,
    ) -> (Vec<UnlistedTerm>, Fitted, Vec<f64>) {
        let n = y.len();
        let alpha = self.opts.alpha;
        let resolution = self.sm.session.uncertainty.resolution_um;
        let mut extra = vec![0.0; n];
        let mut out: Vec<UnlistedTerm> = Vec::new();
        let mut used: Vec<usize> = Vec::new();
        let variance = |q: &DMatrix<f64>, r: &DVector<f64>| Self::strata_variance_of(w, q, r, n);
        while out.len() < unlisted::MAX_TERMS {
            let ctx = unlisted::Context {
                pts: self.sm.points(),
                w,
                rows: cur.r.len(),
                variance: &variance,
            };
            let (cands, null) = unlisted::search(&ctx, &cur, &used);
            let Some((best, flex)) = cands
                .into_iter()
                .min_by(|a, b| a.0.test.ln_p.total_cmp(&b.0.test.ln_p))
            else {
                break;
            };
            let name = unlisted::VARIABLES[best.var].0;
            let bonferroni = alpha / null.len().max(1) as f64;
            // the threshold is at most α: simulate it only when the smallest p could pass
            let threshold = match self.opts.multiplicity {
                Multiplicity::Simulated { draws } if best.test.p_value < alpha => {
                    familywise::simulated_threshold(
                        &null,
                        cur.r.len(),
                        (n as f64).ln(),
                        alpha,
                        Multiplicity::draws_at(draws, alpha),
                        UNLISTED_SEED + out.len() as u64,
                    )
                    .unwrap_or(bonferroni)
                }
                Multiplicity::Simulated { .. } => alpha,
                Multiplicity::Bonferroni => bonferroni,
            };
            let l = Logo {
                before: logo::score(w, &cur.x, &cur.r),
                after: best.logo,
            };
            let (s, beta) = unlisted::offsets(&best, &cur);
            let amplitude = s.iter().fold(f64::NEG_INFINITY, |a, v| a.max(*v))
                - s.iter().fold(f64::INFINITY, |a, v| a.min(*v));
            if let Err(why) = unlisted::accepts(&best.test, threshold, l, amplitude, resolution) {
                *rejected = Some(format!(
                    "the residual's strongest follow-up beyond the candidates, a {} in {name} ({} dof), was not added: {why}",
                    best.basis_name(),
                    best.dof
                ));
                break;
            }
            let held_out = [
                logo::rms_um(w, &cur.x, &cur.r),
                logo::rms_um(w, &best.xa, &best.r1),
            ];
            let rms_before = rms(&resid(
                &resid(y, &extra),
                &self.problem(y, terms, w).predict(&cur.theta),
            ));
            // add it: fit the model to y − extra − s, then the term's coefficients again on the
            // refitted model's residual (linearised jointly), then the model once more
            let mut beta_total = beta;
            let mut s_total = s;
            for pass in 0..2 {
                let y2: Vec<f64> = (0..n).map(|i| y[i] - extra[i] - s_total[i]).collect();
                if let Ok(f) = fit(&self.problem(&y2, terms, w), &cur.theta) {
                    cur = f;
                }
                if pass == 1 {
                    break;
                }
                let redo = best.rebased(&cur);
                let (ds, db) = unlisted::offsets(&redo, &cur);
                for (a, b) in s_total.iter_mut().zip(ds) {
                    *a += b;
                }
                for (a, b) in beta_total.iter_mut().zip(db) {
                    *a += b;
                }
            }
            for (a, b) in extra.iter_mut().zip(&s_total) {
                *a += b;
            }
            let y_now: Vec<f64> = (0..n).map(|i| y[i] - extra[i]).collect();
            let rms_after = rms(&resid(
                &y_now,
                &self.problem(&y_now, terms, w).predict(&cur.theta),
            ));
            let mean = s_total.iter().sum::<f64>() / n.max(1) as f64;
            let amplitude = s_total.iter().fold(f64::NEG_INFINITY, |a, v| a.max(*v))
                - s_total.iter().fold(f64::INFINITY, |a, v| a.min(*v));
            out.push(UnlistedTerm {
                variable: name.into(),
                basis: best.basis_name(),
                dof: best.dof,
                flexibility: flex,
                test: best.test,
                p_value: best.test.p_value,
                threshold,
                bonferroni_threshold: bonferroni,
                bases_tried: null.len(),
                between_share: best.test.shares[1],
                logo: l,
                held_out_rms_um: held_out,
                rms_before_um: rms_before,
                rms_after_um: rms_after,
                amplitude_um: amplitude,
                shape: unlisted::shape_table(&best.basis, &beta_total, mean),
                driver_of: unlisted::driver_of(
                    name,
                    &terms.iter().map(|t| t.family).collect::<Vec<_>>(),
                ),
            });
            used.push(best.var);
        }
        (out, cur, extra)
    }

    /// Residual correlations with the session's variables beyond the final model.
    fn unexplained(&self, w: &Whitening, f: &Fitted) -> Vec<Unexplained> {
        let n = self.sm.len();
        let rows = f.r.len();
        // the model's columns on the data rows only: a variable is tested for what the model
        // cannot follow in the data, not for the pull of the nuisance priors (a variable constant
        // over the session, e.g. the speed of a one-speed plan, then drops out with the touch-off)
        let mut xd = f.x.clone();
        xd.rows_mut(n, rows - n).fill(0.0);
        let q = orthonormal_basis(&xd);
        let v = self.strata_variance(w, f, n);
        let pts = self.sm.points();
        let r = DMatrix::from_column_slice(rows, 1, f.r.as_slice());
        let mut out = Vec::new();
        for (name, get) in unlisted::VARIABLES {
            let mut c: Vec<f64> = pts.iter().map(get).collect();
            w.apply(&mut c);
            let mut col = DMatrix::zeros(rows, 1);
            col.rows_mut(0, n).copy_from_slice(&c);
            let cp = project_out(&q, &col);
            let nrm = cp.norm();
            if nrm < 1e-9 * col.norm().max(1e-300) || nrm == 0.0 {
                continue;
            }
            let cu = &cp / nrm;
            let proj = (cu.transpose() * &r)[(0, 0)];
            let s = strata_of_columns(w, &cu, n);
            let tot = (s[0] + s[1] + s[2]).max(1e-300);
            let t = strata_test(proj * proj, 1, [s[0] / tot, s[1] / tot, s[2] / tot], &v);
            if t.p_value < thresholds::UNEXPLAINED_P {
                out.push(Unexplained {
                    variable: name.into(),
                    correlation: proj / f.r.norm().max(1e-300),
                    p_value: t.p_value,
                    stratum: if s[1] > s[0] { "between" } else { "within" }.into(),
                });
            }
        }
        out
    }
}

/// Columns (data rows) in the whitening `w`.
fn whitened(w: &Whitening, mut cols: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    for c in &mut cols {
        w.apply(c);
    }
    cols
}
