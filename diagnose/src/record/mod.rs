//! `diagnose` beyond grooves: a measured **record** — one signal (a thermal displacement, a per-cut
//! force, …) with its context (time, speed, temperatures, coolant, cumulative cut length or cut
//! count, per-flute channels) — against a nominal model that says the signal stays where it started
//! (no drift; a fresh tool). The workflow is the groove's: recalibrate the nuisance, then add candidate
//! effects one at a time by forward selection, each named with its DESIGN.md effect name, and show the
//! gap shrink; the report has the same contract (`initial_rms_<unit>`, `final_rms_<unit>`, `steps`
//! with `effect`, `p_value`, `rms_before_<unit>`, `rms_after_<unit>`, `params`, and `named`; for a
//! signal in µm exactly DESIGN.md's keys).
//!
//! # Algorithm
//! 1. **Nominal**: the signal's first value, held. `initial_rms` is the RMS of the signal about it.
//! 2. **Nuisance step**: the nominal's level is recalibrated (a free constant — the record's zero is
//!    not trusted any more than a probe's), `nuisance.rms_after`.
//! 3. **Forward selection** over the candidate families of [`crate::families`] (the groove candidates'
//!    shapes on the record's own context): each is fitted jointly with the level and the effects
//!    already added (bounded nonlinear least squares on the identify engine, from a grid of starts),
//!    tested with the nested F-test and BIC. A dense record's residuals are strongly autocorrelated
//!    (neighbouring samples share their error), which would make every test significant: both the
//!    F-test's denominator degrees of freedom and BIC use the **effective sample size**
//!    `n_eff = n·(1 − r)/(1 + r)`, r the lag-1 autocorrelation of the residual of the *richest* model
//!    the record offers (the level and every testable family at once, every temperature sensor) —
//!    the closest thing to the record's noise; a model that still misses an effect has the missing
//!    effect in its residual, whose autocorrelation says nothing about the noise. The most
//!    significant candidate is added if `p < α/m` (Bonferroni over the m tried), BIC decreases and the
//!    augmented fit is identifiable. Repeat until none passes.
//! 4. **Aliasing**: a candidate of the round that fits as well as the one added (RSS within 2 %) with
//!    a contribution correlated > 0.99 with it is named in the step's `aliases`: the record cannot
//!    tell the two apart (e.g. a time-driven drift and tool wear when cut count and time move
//!    together). A record with a cut count but no time says so in the notes.
//! 5. With per-flute channels, `flute_runout` is tested on the flute-to-flute differences (two-way
//!    ANOVA without interaction: rows and flutes as factors).
//!
//! # Examples
//! A drift that follows one temperature sensor (plus a sensor that does not matter):
//! ```
//! use millcomp_diagnose::record::{Record, RecordContext, RecordOptions, diagnose_record};
//! let t: Vec<f64> = (0..400).map(|i| 60.0 * i as f64).collect();
//! let hot: Vec<f64> = t.iter().map(|t| 25.0 + 5.0 * (t / 8000.0).sin()).collect();
//! let other: Vec<f64> = t.iter().map(|t| 22.0 + 0.3 * (t / 1300.0).cos()).collect();
//! let y: Vec<f64> = hot.iter().enumerate().map(|(i, h)| 2.0 * (h - 25.0) + 0.05 * ((i * 31 % 17) as f64 / 17.0 - 0.5)).collect();
//! let rec = Record {
//!     origin: "drift.csv".into(), signal: "drift_um".into(), unit: "um".into(), values: y,
//!     context: RecordContext { t_s: Some(t), temps_c: vec![("hot_C".into(), hot), ("other_C".into(), other)], ..Default::default() },
//! };
//! let rep = diagnose_record(&rec, &RecordOptions::default()).unwrap();
//! assert_eq!(rep.named, ["spindle_thermal_growth"]);
//! assert!(rep.steps[0].family.starts_with("temperature-driven"));
//! assert!((rep.steps[0].params["m_hot_C_um_per_k"] - 2.0).abs() < 0.01);
//! assert!(rep.final_rms < 0.1 * rep.nuisance.rms_after);
//! ```

mod families;
mod report;

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_identify::regress::{effective_n, lag1_autocorrelation};
use millcomp_identify::{NlsOptions, ParamSpec, ResidualModel, fit_nonlinear};
use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ContinuousCDF, FisherSnedecor, StudentsT};

pub use families::RecordContext;
pub use report::{FluteChannel, Nuisance, RecordDecision, RecordReport, RecordRound, RecordStep};

use crate::error::{DiagnoseError, Result};
use families::{EFFECTS, Family, families};

/// A measured record: one signal and its context.
#[derive(Debug, Clone)]
pub struct Record {
    /// The file (or label) it came from.
    pub origin: String,
    /// The signal's name as the file names it (e.g. `disp_ch1_um`, `force_y__rms`).
    pub signal: String,
    /// The signal's unit suffix (`um`, `n`, …): the report's keys carry it.
    pub unit: String,
    /// The signal, one value per row.
    pub values: Vec<f64>,
    /// Its context.
    pub context: RecordContext,
}

/// Options of [`diagnose_record`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecordOptions {
    /// Family-wise significance level per round (Bonferroni), default 0.01.
    pub alpha: f64,
    /// Effect names to try (`None`: all).
    pub candidates: Option<Vec<String>>,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            alpha: 0.01,
            candidates: None,
        }
    }
}

/// Largest lag-1 autocorrelation used for the effective sample size.
const MAX_LAG1: f64 = 0.999;
/// Candidates within this relative RSS of the one added, with correlated contributions, are aliases.
const ALIAS_RSS: f64 = 0.02;
/// Correlation of two contributions above which they are aliases.
const ALIAS_CORR: f64 = 0.99;

fn nls() -> NlsOptions {
    NlsOptions {
        max_iter: 200,
        ftol: 1e-10,
        xtol: 1e-10,
        gtol: 1e-10,
        initial_radius: 1.0,
    }
}

/// The joint model: `level + Σ families`, residual `model − y`.
struct Joint<'a> {
    y: &'a [f64],
    fams: Vec<&'a Family>,
}

impl Joint<'_> {
    fn split<'p>(&self, p: &'p [f64]) -> Vec<&'p [f64]> {
        let mut out = Vec::new();
        let mut k = 1;
        for f in &self.fams {
            out.push(&p[k..k + f.params.len()]);
            k += f.params.len();
        }
        out
    }
    fn predict(&self, p: &[f64]) -> Vec<f64> {
        let mut m = vec![p[0]; self.y.len()];
        for (f, q) in self.fams.iter().zip(self.split(p)) {
            for (a, b) in m.iter_mut().zip(f.eval(q)) {
                *a += b;
            }
        }
        m
    }
}

impl Operator for Joint<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let m = self.predict(p.as_slice());
        Ok(DVector::from_iterator(
            m.len(),
            m.iter().zip(self.y).map(|(a, b)| a - b),
        ))
    }
}

impl Jacobian for Joint<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let n = self.y.len();
        let mut j = DMatrix::zeros(n, p.len());
        j.column_mut(0).fill(1.0);
        let mut col = 1;
        for (f, q) in self.fams.iter().zip(self.split(p.as_slice())) {
            for c in f.jacobian(q) {
                for (i, v) in c.into_iter().enumerate() {
                    j[(i, col)] = v;
                }
                col += 1;
            }
        }
        Ok(j)
    }
}

impl ResidualModel for Joint<'_> {}

/// A joint fit.
#[derive(Debug, Clone)]
struct JointFit {
    theta: Vec<f64>,
    rss: f64,
    pred: Vec<f64>,
    report: millcomp_identify::FitReport,
}

fn specs(fams: &[&Family], start: &[f64]) -> Vec<ParamSpec> {
    let mut out = vec![ParamSpec::free("level", start[0])];
    let mut k = 1;
    for f in fams {
        for p in &f.params {
            let v = start[k];
            out.push(if p.linear {
                ParamSpec::free(&p.name, v)
            } else {
                let w = 1e-6 * (p.upper - p.lower);
                ParamSpec::bounded(&p.name, v.clamp(p.lower + w, p.upper - w), p.lower, p.upper)
            });
            k += 1;
        }
    }
    out
}

/// Fits level + `fams` (the last one new) from `current` (level and the others' estimates) and every
/// start of the new family's nonlinear parameters (its linear ones by least squares on the residual).
fn fit_joint(y: &[f64], fams: &[&Family], current: &[f64]) -> Option<JointFit> {
    let new = *fams.last()?;
    let joint_old = Joint {
        y,
        fams: fams[..fams.len() - 1].to_vec(),
    };
    let resid: Vec<f64> = y
        .iter()
        .zip(joint_old.predict(current))
        .map(|(a, b)| a - b)
        .collect();
    // grid of the new family's nonlinear starts
    let mut grid: Vec<Vec<f64>> = vec![Vec::new()];
    for p in &new.params {
        let mut next = Vec::new();
        for g in &grid {
            for &s in if p.linear { &[0.0][..] } else { &p.starts[..] } {
                let mut v = g.clone();
                v.push(s);
                next.push(v);
            }
        }
        grid = next;
    }
    let mut best: Option<JointFit> = None;
    for g in grid {
        // linear parameters: least squares of the residual on their columns at this start
        let cols = new.jacobian(&g);
        let lin: Vec<usize> = (0..g.len()).filter(|&k| new.params[k].linear).collect();
        let a = DMatrix::from_fn(y.len(), lin.len() + 1, |i, c| {
            if c < lin.len() { cols[lin[c]][i] } else { 1.0 }
        });
        let Some(sol) = (a.transpose() * &a)
            .cholesky()
            .map(|ch| ch.solve(&(a.transpose() * DVector::from_column_slice(&resid))))
        else {
            continue;
        };
        let mut start = current.to_vec();
        start[0] += sol[lin.len()];
        let mut gg = g.clone();
        for (c, &k) in lin.iter().enumerate() {
            gg[k] = sol[c];
        }
        start.extend(gg);
        let joint = Joint {
            y,
            fams: fams.to_vec(),
        };
        let Ok(fit) = fit_nonlinear(
            joint,
            &specs(fams, &start),
            &nls(),
            "diagnose_record",
            "signal",
        ) else {
            continue;
        };
        let theta: Vec<f64> = fit.theta.iter().copied().collect();
        let joint = Joint {
            y,
            fams: fams.to_vec(),
        };
        let pred = joint.predict(&theta);
        let rss: f64 = pred.iter().zip(y).map(|(a, b)| (a - b).powi(2)).sum();
        if rss.is_finite() && best.as_ref().is_none_or(|b| rss < b.rss) {
            best = Some(JointFit {
                theta,
                rss,
                pred,
                report: fit.report,
            });
        }
    }
    best
}

/// The nested F-test and BIC on the effective sample size `n_eff` (module documentation).
#[allow(clippy::too_many_arguments)]
fn test(
    effect: &str,
    family: &str,
    n: usize,
    n_eff: f64,
    p0: usize,
    q: usize,
    rss0: f64,
    fit: &JointFit,
    y: &[f64],
) -> RecordDecision {
    let resid: Vec<f64> = y.iter().zip(&fit.pred).map(|(a, b)| a - b).collect();
    let r = lag1_autocorrelation(&resid);
    let n_eff = n_eff.max((p0 + q + 2) as f64);
    let df2 = (n_eff - (p0 + q) as f64).max(1.0);
    let rss1 = fit.rss;
    let f = if rss1 > 0.0 {
        ((rss0 - rss1).max(0.0) / q as f64) / (rss1 / df2)
    } else {
        f64::INFINITY
    };
    let p = FisherSnedecor::new(q as f64, df2)
        .map(|d| if f.is_finite() { d.sf(f) } else { 0.0 })
        .unwrap_or(f64::NAN);
    let bic =
        |rss: f64, k: usize| n_eff * (rss.max(1e-300) / n as f64).ln() + k as f64 * n_eff.ln();
    RecordDecision {
        effect: effect.to_string(),
        family: family.to_string(),
        f_statistic: f,
        df1: q,
        df2,
        n_eff,
        lag1_autocorrelation: r,
        p_value: p,
        threshold: f64::NAN,
        bic_before: bic(rss0, p0),
        bic_after: bic(rss1, p0 + q),
        rms_after: (rss1 / n as f64).sqrt(),
        identifiable: fit.report.rank == fit.theta.len(),
        significant: false,
    }
}

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
}

fn rms(v: impl Iterator<Item = f64>, n: usize) -> f64 {
    (v.map(|x| x * x).sum::<f64>() / n.max(1) as f64).sqrt()
}

/// Diagnoses a record (module documentation).
///
/// # Errors
/// * [`DiagnoseError::InvalidOption`] for `alpha` outside (0, 1);
/// * [`DiagnoseError::UnknownCandidate`] for a candidate name that is not a DESIGN.md effect;
/// * [`DiagnoseError::SessionMismatch`] (column, 0-based row) for a context column of another length,
///   a non-finite value, or time that does not strictly increase;
/// * [`DiagnoseError::InvalidOption`] (`rows`) for fewer than 10 rows.
pub fn diagnose_record(rec: &Record, opts: &RecordOptions) -> Result<RecordReport> {
    if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
        return Err(DiagnoseError::InvalidOption {
            name: "alpha",
            value: opts.alpha,
            allowed: "0 < alpha < 1",
        });
    }
    if let Some(c) = &opts.candidates {
        for name in c {
            if !EFFECTS.contains(&name.as_str()) {
                return Err(DiagnoseError::UnknownCandidate {
                    name: name.clone(),
                    allowed: EFFECTS.join(", "),
                });
            }
        }
    }
    let y = &rec.values;
    let n = y.len();
    if n < 10 {
        return Err(DiagnoseError::InvalidOption {
            name: "rows",
            value: n as f64,
            allowed: "a record of at least 10 rows",
        });
    }
    check_context(rec)?;
    let unit = rec.unit.as_str();
    let ctx = &rec.context;
    let mut notes = Vec::new();
    if ctx.cut.is_some() && ctx.t_s.is_none() {
        notes.push(
            "the record has a cut count but no time: on a per-cut record at constant conditions cut count, \
             cutting time and engaged length move together, so a time-driven drift of the same first-order \
             form would be aliased with tool_wear; time-driven families (coolant, speed-driven growth) \
             cannot be tested here"
                .to_string(),
        );
    }
    // nominal and nuisance
    let y0 = y[0];
    let initial = rms(y.iter().map(|v| v - y0), n);
    let mean = y.iter().sum::<f64>() / n as f64;
    let rss_nuis: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let nuisance = Nuisance {
        level: mean,
        rms_after: (rss_nuis / n as f64).sqrt(),
    };

    // the noise's autocorrelation, from the richest model the record offers
    let resid0: Vec<f64> = y.iter().map(|v| v - mean).collect();
    let (all, _) = families(ctx, &resid0, unit, None);
    let mut rich: Vec<&Family> = Vec::new();
    let mut rich_theta = vec![mean];
    let mut rich_pred = vec![mean; n];
    for f in &all {
        rich.push(f);
        match fit_joint(y, &rich, &rich_theta) {
            Some(fit) => {
                rich_theta = fit.theta;
                rich_pred = fit.pred;
            }
            None => {
                rich.pop();
            }
        }
    }
    let rich_resid: Vec<f64> = y.iter().zip(&rich_pred).map(|(a, b)| a - b).collect();
    let r_noise = lag1_autocorrelation(&rich_resid).clamp(0.0, MAX_LAG1);
    let n_eff = effective_n(n, r_noise);
    notes.push(format!(
        "noise autocorrelation from the richest model (level + {}): lag-1 r = {r_noise:.4}, effective sample size {n_eff:.0} of {n} rows",
        if rich.is_empty() {
            "nothing".to_string()
        } else {
            rich.iter().map(|f| f.family.split(' ').next().unwrap_or("")).collect::<Vec<_>>().join(" + ")
        }
    ));

    let mut added: Vec<Family> = Vec::new();
    let mut theta: Vec<f64> = vec![mean];
    let mut pred: Vec<f64> = vec![mean; n];
    let mut rss0 = rss_nuis;
    let mut steps: Vec<RecordStep> = Vec::new();
    let mut rounds: Vec<RecordRound> = Vec::new();
    let mut skipped: Vec<(String, String)> = Vec::new();
    let mut predictions: Vec<Vec<f64>> = vec![pred.clone()];
    loop {
        let resid: Vec<f64> = y.iter().zip(&pred).map(|(a, b)| a - b).collect();
        let (cands, sk) = families(ctx, &resid, unit, Some(n_eff));
        if rounds.is_empty() {
            skipped = sk;
        }
        let cands: Vec<Family> = cands
            .into_iter()
            .filter(|c| {
                opts.candidates
                    .as_ref()
                    .is_none_or(|l| l.iter().any(|n| n == c.effect))
                    && !added.iter().any(|a| a.family_key() == c.family_key())
            })
            .collect();
        if cands.is_empty() {
            break;
        }
        let p0 = theta.len();
        let mut tried: Vec<(RecordDecision, JointFit, Family)> = Vec::new();
        for c in cands {
            let mut fams: Vec<&Family> = added.iter().collect();
            fams.push(&c);
            match fit_joint(y, &fams, &theta) {
                Some(fit) => {
                    let d = test(
                        c.effect,
                        &c.family,
                        n,
                        n_eff,
                        p0,
                        c.params.len(),
                        rss0,
                        &fit,
                        y,
                    );
                    tried.push((d, fit, c));
                }
                None => notes.push(format!(
                    "{} ({}): no fit converged in round {}",
                    c.effect,
                    c.family,
                    rounds.len() + 1
                )),
            }
        }
        let m = tried.len();
        if m == 0 {
            break;
        }
        let threshold = opts.alpha / m as f64;
        for t in &mut tried {
            t.0.threshold = threshold;
            t.0.significant =
                t.0.p_value < threshold && t.0.bic_after < t.0.bic_before && t.0.identifiable;
        }
        let best = (0..m)
            .min_by(|&a, &b| {
                (!tried[a].0.identifiable)
                    .cmp(&!tried[b].0.identifiable)
                    .then(tried[a].0.p_value.total_cmp(&tried[b].0.p_value))
                    .then(tried[a].1.rss.total_cmp(&tried[b].1.rss))
            })
            .unwrap_or(0);
        let accept = tried[best].0.significant;
        // aliases of the best: fit as well, with a correlated contribution
        let contribution = |k: usize| -> Vec<f64> {
            tried[k]
                .1
                .pred
                .iter()
                .zip(&pred)
                .map(|(a, b)| a - b)
                .collect()
        };
        let cb = contribution(best);
        let aliases: Vec<String> = (0..m)
            .filter(|&k| k != best)
            .filter(|&k| {
                tried[k].1.rss <= tried[best].1.rss * (1.0 + ALIAS_RSS)
                    && corr(&contribution(k), &cb).abs() > ALIAS_CORR
            })
            .map(|k| format!("{} ({})", tried[k].2.effect, tried[k].2.family))
            .collect();
        rounds.push(RecordRound {
            threshold,
            tested: tried.iter().map(|t| t.0.clone()).collect(),
            added: accept.then(|| tried[best].0.effect.clone()),
            added_family: accept.then(|| tried[best].0.family.clone()),
        });
        if !accept {
            break;
        }
        let (d, fit, fam) = tried.swap_remove(best);
        let k0 = theta.len();
        let mut params = BTreeMap::new();
        let mut ci95 = BTreeMap::new();
        // intervals on the effective sample size (the engine's assume n independent rows)
        let p_all = fit.theta.len();
        let widen = ((n - p_all.min(n - 1)) as f64 / (d.n_eff - p_all as f64).max(1.0)).sqrt();
        let t975 = StudentsT::new(0.0, 1.0, (d.n_eff - p_all as f64).max(1.0))
            .map(|t| t.inverse_cdf(0.975))
            .unwrap_or(f64::NAN);
        for (j, p) in fam.params.iter().enumerate() {
            let v = fit.theta[k0 + j];
            params.insert(p.name.clone(), v);
            if let Some(se) = fit.report.std_err.get(&p.name) {
                let se = se * widen;
                ci95.insert(p.name.clone(), [v - t975 * se, v + t975 * se]);
            }
        }
        // a length scale at its upper bound: the growth is a straight line over the record, and only
        // its slope W/L0 is determined
        if let (families::Driver::Length { .. }, Some(lp)) = (&fam.driver, fam.params.get(1)) {
            let (w, l0) = (fit.theta[k0], fit.theta[k0 + 1]);
            if l0 >= 0.99 * lp.upper {
                let shown = match unit {
                    "n" => "N",
                    "um" => "µm",
                    u => u,
                };
                notes.push(format!(
                    "{}: {} = {l0:.4e} is at its upper bound: the growth is linear over the record and only \
                     its slope W/L0 = {:.5} {shown} per {} is determined",
                    fam.effect,
                    lp.name,
                    w / l0,
                    lp.name
                        .trim_start_matches("length_scale_")
                        .trim_end_matches('s')
                ));
            }
        }
        if !aliases.is_empty() {
            notes.push(format!(
                "{} ({}) was added, but {} fit(s) as well with a contribution correlated > {ALIAS_CORR}: \
                 this record cannot tell them apart",
                fam.effect,
                fam.family,
                aliases.join(", ")
            ));
        }
        steps.push(RecordStep {
            effect: fam.effect.to_string(),
            family: fam.family.clone(),
            p_value: d.p_value,
            rms_before: (rss0 / n as f64).sqrt(),
            rms_after: (fit.rss / n as f64).sqrt(),
            params,
            ci95,
            sensors: fam.sensors.clone(),
            f_statistic: d.f_statistic,
            df1: d.df1,
            df2: d.df2,
            n_eff: d.n_eff,
            threshold,
            bic_before: d.bic_before,
            bic_after: d.bic_after,
            aliases,
            warnings: fit
                .report
                .warnings
                .iter()
                .filter(|w| !w.starts_with("residuals are autocorrelated"))
                .cloned()
                .chain(std::iter::once(format!(
                    "intervals on the effective sample size {:.0} of {n} rows (standard errors × {widen:.2}, t on {:.0} dof)",
                    d.n_eff,
                    (d.n_eff - p_all as f64).max(1.0)
                )))
                .collect(),
        });
        theta = fit.theta.clone();
        pred = fit.pred.clone();
        rss0 = fit.rss;
        predictions.push(pred.clone());
        added.push(fam);
    }
    // final joint estimates
    let mut final_params: BTreeMap<String, BTreeMap<String, f64>> = BTreeMap::new();
    let mut k = 1;
    for f in &added {
        let e = final_params.entry(f.effect.to_string()).or_default();
        for p in &f.params {
            e.insert(p.name.clone(), theta[k]);
            k += 1;
        }
    }
    let flute_channel = report::flute_channel(ctx, opts.alpha);
    let mut named: Vec<String> = Vec::new();
    for s in &steps {
        if !named.contains(&s.effect) {
            named.push(s.effect.clone());
        }
    }
    if flute_channel.as_ref().is_some_and(|f| f.significant) {
        named.push("flute_runout".into());
    }
    if named.is_empty() {
        named.push("none".into());
    }
    let final_rms = (rss0 / n as f64).sqrt();
    Ok(RecordReport {
        unit: unit.to_string(),
        initial_rms: initial,
        final_rms,
        steps,
        named,
        record: rec.origin.clone(),
        signal: rec.signal.clone(),
        n_rows: n,
        alpha: opts.alpha,
        correction: "bonferroni over the candidates of each round, plus BIC; F-test and BIC on the effective sample size n(1-r)/(1+r)".into(),
        nominal: format!(
            "constant: the signal's first value ({y0}), held — no drift / a fresh tool"
        ),
        nuisance,
        shrink_after_nuisance: 1.0 - final_rms / ((rss_nuis / n as f64).sqrt()),
        final_params,
        rounds,
        skipped,
        flute_channel,
        notes,
        predictions,
        measured: y.clone(),
    })
}

impl Family {
    /// Identifies a family among those of the same effect (speed- vs temperature-driven growth).
    fn family_key(&self) -> (&'static str, &'static str) {
        let kind = match &self.driver {
            families::Driver::Coolant { .. } => "coolant",
            families::Driver::Speed { .. } => "speed",
            families::Driver::Temperature { .. } => "temperature",
            families::Driver::Length { .. } => "length",
        };
        (self.effect, kind)
    }
}

fn check_context(rec: &Record) -> Result<()> {
    let n = rec.values.len();
    let mismatch =
        |column: &str, row: Option<usize>, message: String| DiagnoseError::SessionMismatch {
            column: column.to_string(),
            row,
            message,
        };
    if let Some(i) = rec.values.iter().position(|v| !v.is_finite()) {
        return Err(mismatch(&rec.signal, Some(i), "not a finite number".into()));
    }
    let c = &rec.context;
    let mut cols: Vec<(String, &Vec<f64>)> = Vec::new();
    for (name, v) in [
        ("t_s", &c.t_s),
        ("speed_rpm", &c.speed_rpm),
        ("coolant_on", &c.coolant_on),
        ("cut_length_mm", &c.cut_length_mm),
        ("cut", &c.cut),
        ("machine_x_mm", &c.machine_x_mm),
    ] {
        if let Some(v) = v {
            cols.push((name.to_string(), v));
        }
    }
    for (name, v) in c.temps_c.iter().chain(&c.flutes) {
        cols.push((name.clone(), v));
    }
    for (name, v) in cols {
        if v.len() != n {
            return Err(mismatch(
                &name,
                None,
                format!("{} rows, the signal has {n}", v.len()),
            ));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(mismatch(&name, Some(i), "not a finite number".into()));
        }
    }
    for (name, v) in [("t_s", &c.t_s), ("cut", &c.cut)] {
        if let Some(v) = v {
            if let Some(i) = (1..n).find(|&i| v[i] <= v[i - 1]) {
                return Err(mismatch(
                    name,
                    Some(i),
                    format!("{} does not increase (previous row {})", v[i], v[i - 1]),
                ));
            }
        }
    }
    Ok(())
}
