//! Across units: what one tool's, part's or machine's fit says of the next one.
//!
//! An interval from one unit's record is honest for that unit only: the next cutter of the same type,
//! on the same machine under the same conditions, has its own parameters. When a record holds several
//! units (a `unit` column: tool, part or machine), each unit is fitted on its own rows with the target's
//! own method, and every quantity the units share (parameters, derived quantities such as the force at a
//! stated wear) is combined by a **random-effects meta-analysis of the per-unit estimates** — unit `i`
//! gives `θ̂ᵢ` with standard error `sᵢ`, and `θ̂ᵢ ~ N(θᵢ, sᵢ²)`, `θᵢ ~ N(μ, τ²)`:
//!
//! * `τ²`, the **between-unit variance**, by DerSimonian & Laird (1986, the method of moments on
//!   Cochran's Q, truncated at 0; the default) or Paule & Mandel (1982, the generalised Q set to its
//!   expectation k − 1), with a 95 % Q-profile interval for τ (Viechtbauer 2007); Cochran's Q with its
//!   χ²(k − 1) p-value and I² = (Q − (k − 1))/Q (Higgins & Thompson 2002) say how much of the spread the
//!   units' own errors cannot explain;
//! * `μ`, the mean over units, weighted by `1/(sᵢ² + τ²)`, with the **Hartung–Knapp–Sidik–Jonkman**
//!   interval `μ ± t(k − 1)·√(q*/Σwᵢ)`, `q = Σwᵢ(θ̂ᵢ − μ)²/(k − 1)` — with the truncation `q* = max(q, 1)`
//!   (Knapp & Hartung 2003; Röver, Knapp & Friede 2015), so the interval is never narrower than the
//!   plain random-effects one;
//! * `new_unit`: the **prediction interval for a new unit's value** (Higgins, Thompson & Spiegelhalter
//!   2009), `μ ± t(df)·√(τ² + SE(μ)²)`, on df = k − 1. HTS use k − 2, undefined with 2 units; k − 1 is
//!   what `metafor`'s `predict()` uses with the Knapp–Hartung test, and what the interval becomes when the
//!   units' own errors are negligible: then it is exactly the classical prediction interval of a new draw
//!   from a normal sample of k, `x̄ ± t(k − 1)·s·√(1 + 1/k)`. **With 2 units t(1) = 12.71**, 6.5 times the
//!   normal 1.96: two tools say little about a third (`t(2) = 4.30`, `t(4) = 2.78`, `t(9) = 2.26`).
//!
//! Each quantity is combined on its own (a univariate meta-analysis per parameter; the correlation of a
//! unit's parameters is not carried across). The per-unit standard errors are taken as known, as meta-
//! analysis does; where a unit's own interval rests on few effective degrees of freedom (Newey–West with
//! strongly autocorrelated residuals) that is an approximation the report's per-unit warnings state.
//! `statsmodels.stats.meta_analysis.combine_effects` is the independent peer
//! (`bench/peers/meta_goldens.py`, `identify/tests/units.rs`); the coverage of the prediction interval is
//! measured on simulated units with a known between-unit scatter (`identify/examples/unit_coverage.rs`).
//!
//! ```
//! use millcomp_identify::units::*;
//! // four units' slopes with their standard errors
//! let m = meta_analyse(&[0.157, 0.092, 0.12, 0.14], &[0.013, 0.010, 0.02, 0.015], &MetaOptions::default()).unwrap();
//! assert_eq!(m.k, 4);
//! assert!(m.tau > 0.0 && m.i2 > 0.5);
//! let pi = m.new_unit.pi95;
//! // the new unit's interval is wider than the mean's and holds every unit seen
//! assert!(pi[0] < m.ci95[0] && m.ci95[1] < pi[1] && pi[0] < 0.092 && 0.157 < pi[1]);
//! ```

use std::collections::BTreeMap;

use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

use crate::columns::{Columns, IdentifyOptions, Target, identify_columns};
use crate::error::{IdentifyError, Result};
use crate::targets::Identified;

/// The role a unit column is read under (`--columns unit=COLUMN`).
pub const UNIT_ROLE: &str = "unit";

/// How the between-unit variance τ² is estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tau2Method {
    /// DerSimonian & Laird's method of moments (truncated at 0).
    #[default]
    DerSimonianLaird,
    /// Paule & Mandel: the generalised Q statistic set to its expectation k − 1.
    PauleMandel,
}

impl Tau2Method {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Tau2Method::DerSimonianLaird => "DerSimonian–Laird",
            Tau2Method::PauleMandel => "Paule–Mandel",
        }
    }

    /// Parses `dl` or `pm`.
    ///
    /// # Errors
    /// [`IdentifyError::UnknownModel`] listing the two.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "dl" => Ok(Tau2Method::DerSimonianLaird),
            "pm" => Ok(Tau2Method::PauleMandel),
            other => Err(IdentifyError::UnknownModel {
                name: other.into(),
                allowed: "dl (DerSimonian–Laird), pm (Paule–Mandel)".into(),
            }),
        }
    }
}

/// Options of the meta-analysis.
#[derive(Debug, Clone, Copy, Default)]
pub struct MetaOptions {
    /// Estimator of τ².
    pub tau2: Tau2Method,
}

/// The prediction for a new unit.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct NewUnit {
    /// Its expected value (the mean over units, μ).
    pub value: f64,
    /// Its predictive standard deviation `√(τ² + SE(μ)²)`.
    pub sd: f64,
    /// The 95 % prediction interval `value ± t(df)·sd`.
    pub pi95: [f64; 2],
    /// Degrees of freedom of the t quantile (k − 1).
    pub df: usize,
    /// The t quantile used (0.975).
    pub t_quantile: f64,
}

/// A random-effects meta-analysis of k per-unit estimates of one quantity (module documentation).
#[derive(Debug, Clone, Serialize)]
pub struct MetaAnalysis {
    /// Number of units.
    pub k: usize,
    /// The τ² estimator.
    pub tau2_method: Tau2Method,
    /// Inverse-variance (fixed-effect) mean: what pooling the units as one would say.
    pub fixed_mean: f64,
    /// Its standard error `1/√Σ(1/sᵢ²)`.
    pub fixed_se: f64,
    /// Cochran's Q.
    pub q: f64,
    /// Its p-value, χ²(k − 1): small when the units differ by more than their own errors.
    pub q_p: f64,
    /// I² = max(0, (Q − (k − 1))/Q): the share of the spread that is between units.
    pub i2: f64,
    /// Between-unit variance τ².
    pub tau2: f64,
    /// Between-unit standard deviation τ (the scatter of the parameter from unit to unit).
    pub tau: f64,
    /// 95 % Q-profile interval of τ.
    pub tau_ci95: [f64; 2],
    /// Random-effects mean μ.
    pub mean: f64,
    /// Its plain random-effects standard error `1/√Σwᵢ`.
    pub se_random: f64,
    /// The Hartung–Knapp scale q (before truncation at 1).
    pub hksj_q: f64,
    /// The Hartung–Knapp–Sidik–Jonkman standard error of μ, `√(max(q, 1)/Σwᵢ)`.
    pub se: f64,
    /// 95 % interval of μ, `μ ± t(k − 1)·se`.
    pub ci95: [f64; 2],
    /// The prediction for a new unit.
    pub new_unit: NewUnit,
}

fn t975(df: f64) -> f64 {
    StudentsT::new(0.0, 1.0, df)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(f64::NAN)
}

/// The `p` quantile of `d` by bisection on its CDF to full precision (statrs' own `inverse_cdf` stops
/// after a few Newton steps, which at 1 degree of freedom and p = 0.025 — the density is infinite at
/// 0 — does not reach the quantile 9.82e-4).
fn chi2_quantile(d: &ChiSquared, p: f64) -> f64 {
    let mut hi = 1.0;
    while d.cdf(hi) < p {
        hi *= 2.0;
    }
    bisect(0.0, hi, 300, |x| d.cdf(x) < p)
}

/// The point where `left_of_root` turns from true to false within `[lo, hi]`, halving the bracket at
/// most `max_halvings` times or until it is 1e-15 of `hi` wide; its midpoint.
fn bisect(
    mut lo: f64,
    mut hi: f64,
    max_halvings: usize,
    left_of_root: impl Fn(f64) -> bool,
) -> f64 {
    for _ in 0..max_halvings {
        let mid = 0.5 * (lo + hi);
        if left_of_root(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-15 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// `(μ(τ²), Σw, Q_gen(τ²))` with `w = 1/(v + τ²)`.
fn weighted(y: &[f64], v: &[f64], tau2: f64) -> (f64, f64, f64) {
    let w: Vec<f64> = v.iter().map(|v| 1.0 / (v + tau2)).collect();
    let sw: f64 = w.iter().sum();
    let mu = w.iter().zip(y).map(|(w, y)| w * y).sum::<f64>() / sw;
    let q = w.iter().zip(y).map(|(w, y)| w * (y - mu).powi(2)).sum();
    (mu, sw, q)
}

/// The τ² ≥ 0 at which the generalised Q equals `target` (it decreases in τ²); 0 when Q(0) ≤ target.
fn solve_q(y: &[f64], v: &[f64], target: f64) -> f64 {
    let q_at = |t: f64| weighted(y, v, t).2;
    if target.is_nan() || target <= 0.0 || q_at(0.0) <= target {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, v.iter().copied().fold(0.0, f64::max).max(1e-300));
    while q_at(hi) > target {
        lo = hi;
        hi *= 4.0;
        if !hi.is_finite() {
            return f64::INFINITY;
        }
    }
    bisect(lo, hi, 200, |t| q_at(t) > target)
}

/// Combines per-unit estimates `estimate` with standard errors `std_err` (module documentation).
///
/// # Errors
/// [`IdentifyError::TooFewUnits`] for fewer than 2 units; [`IdentifyError::LengthMismatch`];
/// [`IdentifyError::NonFinite`] for a non-finite estimate; [`IdentifyError::InvalidParameter`] for a
/// standard error that is not finite and > 0 (naming its 0-based unit index).
pub fn meta_analyse(estimate: &[f64], std_err: &[f64], opts: &MetaOptions) -> Result<MetaAnalysis> {
    let k = estimate.len();
    if k < 2 {
        return Err(IdentifyError::TooFewUnits { got: k });
    }
    crate::validate::same_len("std_err", std_err, "estimate", k)?;
    crate::validate::finite("estimate", estimate)?;
    if let Some(i) = std_err.iter().position(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(IdentifyError::InvalidParameter {
            name: format!("std_err[{i}]"),
            value: std_err[i],
            allowed: "a finite standard error > 0",
        });
    }
    let y = estimate;
    let v: Vec<f64> = std_err.iter().map(|s| s * s).collect();
    let df = (k - 1) as f64;
    let (fixed_mean, sw0, q) = weighted(y, &v, 0.0);
    let sw2: f64 = v.iter().map(|v| 1.0 / (v * v)).sum();
    let tau2 = match opts.tau2 {
        Tau2Method::DerSimonianLaird => ((q - df) / (sw0 - sw2 / sw0)).max(0.0),
        Tau2Method::PauleMandel => solve_q(y, &v, df),
    };
    let chi = ChiSquared::new(df).ok();
    let q_p = chi.as_ref().map_or(f64::NAN, |d| d.sf(q));
    let tau_ci95 = match &chi {
        Some(d) => [
            solve_q(y, &v, chi2_quantile(d, 0.975)).sqrt(),
            solve_q(y, &v, chi2_quantile(d, 0.025)).sqrt(),
        ],
        None => [f64::NAN; 2],
    };
    let (mean, sw, q_re) = weighted(y, &v, tau2);
    let hksj_q = q_re / df;
    let se = (hksj_q.max(1.0) / sw).sqrt();
    let t = t975(df);
    let sd = (tau2 + se * se).sqrt();
    Ok(MetaAnalysis {
        k,
        tau2_method: opts.tau2,
        fixed_mean,
        fixed_se: (1.0 / sw0).sqrt(),
        q,
        q_p,
        i2: if q > 0.0 {
            ((q - df) / q).max(0.0)
        } else {
            0.0
        },
        tau2,
        tau: tau2.sqrt(),
        tau_ci95,
        mean,
        se_random: (1.0 / sw).sqrt(),
        hksj_q,
        se,
        ci95: [mean - t * se, mean + t * se],
        new_unit: NewUnit {
            value: mean,
            sd,
            pi95: [mean - t * sd, mean + t * sd],
            df: k - 1,
            t_quantile: t,
        },
    })
}

/// A unit's quantities: name → (estimate, standard error).
pub type Quantities = BTreeMap<String, (f64, f64)>;

/// One unit's estimate of a quantity.
#[derive(Debug, Clone, Serialize)]
pub struct UnitEstimate {
    /// The unit.
    pub unit: String,
    /// Its estimate.
    pub value: f64,
    /// Its standard error (the unit's own fit).
    pub std_err: f64,
}

/// One quantity across the units.
#[derive(Debug, Clone, Serialize)]
pub struct QuantityAcross {
    /// The quantity (a parameter or derived quantity, its unit in its name).
    pub name: String,
    /// Each unit's estimate.
    pub per_unit: Vec<UnitEstimate>,
    /// The meta-analysis.
    #[serde(flatten)]
    pub meta: MetaAnalysis,
}

/// Every shared quantity across the units.
#[derive(Debug, Clone, Serialize)]
pub struct AcrossUnits {
    /// The method, in one sentence.
    pub method: String,
    /// The units, in order.
    pub units: Vec<String>,
    /// One entry per quantity every unit has.
    pub quantities: Vec<QuantityAcross>,
    /// What was left out and why; what the number of units implies.
    pub notes: Vec<String>,
}

impl AcrossUnits {
    /// The new-unit predictions by quantity (the JSON key `new_unit`).
    pub fn new_unit(&self) -> BTreeMap<String, NewUnit> {
        self.quantities
            .iter()
            .map(|q| (q.name.clone(), q.meta.new_unit))
            .collect()
    }
}

/// The method sentence of a report.
pub fn method_text(opts: &MetaOptions) -> String {
    format!(
        "random-effects meta-analysis of the per-unit estimates: {} between-unit variance τ² (95 % \
         Q-profile interval of τ), Hartung–Knapp–Sidik–Jonkman interval of the mean (q truncated at 1), \
         Higgins–Thompson–Spiegelhalter prediction interval for a new unit on k − 1 degrees of freedom",
        opts.tau2.name()
    )
}

/// What `k` units make of the t quantile, in words.
pub fn width_note(k: usize) -> String {
    let t = t975((k.max(2) - 1) as f64);
    let more: Vec<String> = [3usize, 5, 10]
        .into_iter()
        .filter(|&m| m > k)
        .map(|m| format!("{m} units {:.2}", t975((m - 1) as f64)))
        .collect();
    format!(
        "{k} units: the new unit's interval uses t({} df) = {t:.2}, {:.1}× the normal 1.96{}{}",
        k - 1,
        t / 1.959_964,
        if k == 2 {
            " — two units say little about a third: the interval is honest, and wide"
        } else {
            ""
        },
        if more.is_empty() {
            String::new()
        } else {
            format!(" (more units narrow it: t = {})", more.join(", "))
        }
    )
}

/// The statement a one-unit report carries.
pub fn one_unit_note(unit: Option<&str>) -> String {
    format!(
        "one unit{}: these intervals are this unit's only (this tool's, part's or machine's) — they do not \
         cover another unit of the same kind (of three PHM 2010 cutters, each one's wear slope lies outside \
         another's interval); a `unit` column (--columns unit=COLUMN) with two or more units gives the \
         between-unit scatter and a prediction interval for a new unit (docs/identify.md#across-units)",
        unit.map_or(String::new(), |u| format!(" (`{u}`)"))
    )
}

/// Combines every quantity all units have: `per_unit[i] = (unit, {quantity: (estimate, std_err)})`.
/// Quantities missing from a unit, or whose standard error is not finite and > 0 in a unit, are left
/// out with a note naming them.
///
/// # Errors
/// [`IdentifyError::TooFewUnits`] for fewer than 2 units.
pub fn across_units(per_unit: &[(String, Quantities)], opts: &MetaOptions) -> Result<AcrossUnits> {
    let k = per_unit.len();
    if k < 2 {
        return Err(IdentifyError::TooFewUnits { got: k });
    }
    let mut names: Vec<&String> = per_unit.iter().flat_map(|(_, m)| m.keys()).collect();
    names.sort();
    names.dedup();
    let (mut quantities, mut partial, mut no_se) = (Vec::new(), Vec::new(), Vec::new());
    for name in names {
        let est: Vec<UnitEstimate> = per_unit
            .iter()
            .filter_map(|(u, m)| {
                m.get(name).map(|&(value, std_err)| UnitEstimate {
                    unit: u.clone(),
                    value,
                    std_err,
                })
            })
            .collect();
        if est.len() < k {
            partial.push(name.clone());
            continue;
        }
        if let Some(bad) = est
            .iter()
            .find(|e| !(e.value.is_finite() && e.std_err.is_finite() && e.std_err > 0.0))
        {
            no_se.push(format!("{name} (unit {})", bad.unit));
            continue;
        }
        let y: Vec<f64> = est.iter().map(|e| e.value).collect();
        let s: Vec<f64> = est.iter().map(|e| e.std_err).collect();
        let meta = meta_analyse(&y, &s, opts)?;
        quantities.push(QuantityAcross {
            name: name.clone(),
            per_unit: est,
            meta,
        });
    }
    let mut notes = vec![width_note(k)];
    if !partial.is_empty() {
        notes.push(format!(
            "not in every unit, so not combined: {}",
            partial.join(", ")
        ));
    }
    if !no_se.is_empty() {
        notes.push(format!(
            "no usable standard error, so not combined: {}",
            no_se.join(", ")
        ));
    }
    Ok(AcrossUnits {
        method: method_text(opts),
        units: per_unit.iter().map(|(u, _)| u.clone()).collect(),
        quantities,
        notes,
    })
}

/// The rows of each unit, in order of first appearance: `labels[i]` is row i's unit.
pub fn group_rows(labels: &[String]) -> Vec<(String, Vec<usize>)> {
    let mut out: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, l) in labels.iter().enumerate() {
        match out.iter_mut().find(|(u, _)| u == l) {
            Some((_, rows)) => rows.push(i),
            None => out.push((l.clone(), vec![i])),
        }
    }
    out
}

/// A numeric unit value as a label (`4`, not `4.0`).
pub fn label_of(v: f64) -> String {
    format!("{v}")
}

/// Splits `cols` by its unit column `column` (numeric or text), in order of first appearance, the unit
/// column removed from each part. `None` when `cols` has no such column.
///
/// # Errors
/// [`IdentifyError::NonFinite`] naming the row of a non-finite numeric unit value.
pub fn split_units(cols: &Columns, column: &str) -> Result<Option<Vec<(String, Columns)>>> {
    let labels: Vec<String> = if let Some(v) = cols.numeric(column) {
        crate::validate::finite(column, v)?;
        v.iter().map(|x| label_of(*x)).collect()
    } else if let Some(t) = cols.text(column) {
        t.to_vec()
    } else {
        return Ok(None);
    };
    let mut rest = cols.clone();
    rest.remove(column);
    Ok(Some(
        group_rows(&labels)
            .into_iter()
            .map(|(u, rows)| (u, rest.rows(&rows)))
            .collect(),
    ))
}

/// One unit's fit.
#[derive(Debug, Clone, Serialize)]
pub struct UnitFit {
    /// The unit.
    pub unit: String,
    /// Its rows.
    pub rows: usize,
    /// The target's fit on them.
    pub fit: Identified,
}

/// A target fitted unit by unit, and combined.
#[derive(Debug, Clone, Serialize)]
pub struct UnitsIdentified {
    /// The target.
    pub target: &'static str,
    /// Each unit's fit.
    pub units: Vec<UnitFit>,
    /// The quantities across units.
    pub across_units: AcrossUnits,
    /// The new-unit prediction of each quantity.
    pub new_unit: BTreeMap<String, NewUnit>,
}

/// The quantities of one fit: its parameters and derived quantities with their standard errors.
pub fn quantities_of(fit: &Identified) -> BTreeMap<String, (f64, f64)> {
    let mut m: BTreeMap<String, (f64, f64)> = fit
        .report
        .params
        .iter()
        .map(|(n, v)| (n.clone(), (*v, fit.report.se(n))))
        .collect();
    for (n, d) in &fit.derived {
        m.insert(n.clone(), (d.value, d.std_err));
    }
    m
}

/// Fits `target` on each unit's columns ([`identify_columns`]) and combines the units
/// ([`across_units`]). With one unit it returns that unit's fit alone, its notes saying that the
/// intervals do not cover other units ([`one_unit_note`]), and `Err` is not used for that case: see
/// [`identify_by_unit`].
///
/// # Errors
/// [`IdentifyError::Unit`] naming the unit whose fit could not run (the cause as its source);
/// [`IdentifyError::TooFewUnits`] for fewer than 2 units.
pub fn identify_units(
    target: Target,
    units: &[(String, Columns)],
    opts: &IdentifyOptions,
    meta: &MetaOptions,
) -> Result<UnitsIdentified> {
    if units.len() < 2 {
        return Err(IdentifyError::TooFewUnits { got: units.len() });
    }
    let mut fits = Vec::with_capacity(units.len());
    for (u, cols) in units {
        let fit = identify_columns(target, cols, opts).map_err(|e| IdentifyError::Unit {
            unit: u.clone(),
            source: Box::new(e),
        })?;
        fits.push(UnitFit {
            unit: u.clone(),
            rows: cols.n_rows(),
            fit,
        });
    }
    let per: Vec<(String, Quantities)> = fits
        .iter()
        .map(|f| (f.unit.clone(), quantities_of(&f.fit)))
        .collect();
    let mut across = across_units(&per, meta)?;
    let unconverged: Vec<&str> = fits
        .iter()
        .filter(|f| !f.fit.report.status.is_success())
        .map(|f| f.unit.as_str())
        .collect();
    if !unconverged.is_empty() {
        across.notes.push(format!(
            "the fit of unit(s) {} did not converge: their estimates are provisional",
            unconverged.join(", ")
        ));
    }
    Ok(UnitsIdentified {
        target: target.name(),
        new_unit: across.new_unit(),
        units: fits,
        across_units: across,
    })
}

/// What [`identify_by_unit`] found.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum ByUnit {
    /// One unit (or no unit column): its fit, with the one-unit note.
    One(Box<Identified>),
    /// Two or more units.
    Several(Box<UnitsIdentified>),
}

/// Runs `target` on `cols`: split by their unit column [`UNIT_ROLE`] when they have one. One unit gives
/// its fit with the note that its intervals do not cover other units; several are fitted one by one
/// and combined ([`identify_units`]).
///
/// # Errors
/// Those of [`split_units`], [`identify_columns`] and [`identify_units`].
///
/// # Examples
/// ```
/// use millcomp_identify::{Columns, IdentifyOptions, Target};
/// use millcomp_identify::units::*;
/// // three tools of stiffness 0.10, 0.12 and 0.11 N/µm, each measured at 8 loads
/// let (mut load, mut defl, mut tool) = (vec![], vec![], vec![]);
/// for (t, k) in [("a", 0.10), ("b", 0.12), ("c", 0.11)] {
///     for i in 1..=8 {
///         let f = i as f64;
///         load.push(f);
///         defl.push(f / k + 0.05 * [1.0, -1.0][i % 2]);
///         tool.push(t.to_string());
///     }
/// }
/// let mut cols = Columns::new();
/// cols.insert("load_n", load).insert("deflection_um", defl).insert_text("unit", tool);
/// let ByUnit::Several(u) = identify_by_unit(Target::Stiffness, &cols, &IdentifyOptions::default(), &MetaOptions::default()).unwrap() else { panic!() };
/// assert_eq!(u.units.len(), 3);
/// let q = &u.new_unit["stiffness_n_per_um"];
/// assert!((q.value - 0.11).abs() < 2e-3 && q.pi95[0] < 0.10 && 0.12 < q.pi95[1]);
/// ```
pub fn identify_by_unit(
    target: Target,
    cols: &Columns,
    opts: &IdentifyOptions,
    meta: &MetaOptions,
) -> Result<ByUnit> {
    match split_units(cols, UNIT_ROLE)? {
        Some(units) if units.len() >= 2 => Ok(ByUnit::Several(Box::new(identify_units(
            target, &units, opts, meta,
        )?))),
        Some(mut units) => {
            let (u, c) = units.remove(0);
            let mut fit = identify_columns(target, &c, opts)?;
            fit.notes.push(one_unit_note(Some(&u)));
            Ok(ByUnit::One(Box::new(fit)))
        }
        None => {
            let mut fit = identify_columns(target, cols, opts)?;
            fit.notes.push(one_unit_note(None));
            Ok(ByUnit::One(Box::new(fit)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_units_give_the_normal_sample_prediction_interval_when_their_errors_vanish() {
        // errors 1e-6 of a spread of 0.065: τ² ≈ s², the interval is x̄ ± t(1)·s·√(1 + 1/2)
        let m = meta_analyse(&[0.157, 0.092], &[1e-6, 1e-6], &MetaOptions::default()).unwrap();
        let s = (0.157f64 - 0.092).abs() / 2f64.sqrt();
        let half = 12.706_204_736 * s * (1.5f64).sqrt();
        assert!((m.new_unit.pi95[1] - (0.1245 + half)).abs() < 1e-6, "{m:?}");
        assert!((m.new_unit.t_quantile - 12.706_204_736).abs() < 1e-8);
        assert!(m.i2 > 0.999);
    }

    #[test]
    fn the_q_profile_interval_of_two_units_has_its_closed_form() {
        // k = 2: Q(τ²) = (y₁ − y₂)²/(v₁ + v₂ + 2τ²), so τ² = ((y₁ − y₂)²/χ² − v₁ − v₂)/2 at each χ²(1)
        // quantile (0.975: 5.023886; 0.025: 9.820691e-4, scipy.stats.chi2.ppf)
        let (y, s) = ([0.157, 0.092], [0.012, 0.008]);
        let m = meta_analyse(&y, &s, &MetaOptions::default()).unwrap();
        let tau = |chi2: f64| {
            ((0.065f64.powi(2) / chi2 - 0.012f64.powi(2) - 0.008f64.powi(2)) / 2.0).sqrt()
        };
        assert!(
            (m.tau_ci95[0] - tau(5.023_886_187)).abs() < 1e-8,
            "{:?}",
            m.tau_ci95
        );
        assert!(
            (m.tau_ci95[1] / tau(9.820_691_171e-4) - 1.0).abs() < 1e-8,
            "{:?}",
            m.tau_ci95
        );
        assert!(m.tau_ci95[0] < m.tau && m.tau < m.tau_ci95[1]);
    }

    #[test]
    fn agreeing_units_have_no_between_unit_variance_and_paule_mandel_solves_its_equation() {
        let m = meta_analyse(
            &[1.0, 1.01, 0.99],
            &[0.1, 0.1, 0.1],
            &MetaOptions::default(),
        )
        .unwrap();
        assert_eq!(m.tau2, 0.0);
        // Q(0) = (0.01² + 0.01²)/0.1² = 0.02 lies below χ²(2)'s 2.5 % point 0.0506, so no τ² ≥ 0 reaches
        // it: the Q-profile interval (Viechtbauer 2007) is {0}, as metafor prints it ([0.0000, 0.0000])
        assert_eq!(m.tau_ci95, [0.0, 0.0], "{:?}", m.tau_ci95);
        // the truncated Hartung–Knapp scale: never narrower than the plain random-effects interval
        assert!(m.hksj_q < 1.0 && (m.se - m.se_random).abs() < 1e-15);
        let y = [1.0, 1.6, 0.7, 1.3];
        let s = [0.1, 0.2, 0.15, 0.1];
        let pm = meta_analyse(
            &y,
            &s,
            &MetaOptions {
                tau2: Tau2Method::PauleMandel,
            },
        )
        .unwrap();
        let v: Vec<f64> = s.iter().map(|s| s * s).collect();
        let (_, _, q) = weighted(&y, &v, pm.tau2);
        assert!((q - 3.0).abs() < 1e-9, "{q}");
        assert!((pm.hksj_q - 1.0).abs() < 1e-9);
    }

    #[test]
    fn bad_input_is_named() {
        let o = MetaOptions::default();
        assert!(matches!(
            meta_analyse(&[1.0], &[0.1], &o),
            Err(IdentifyError::TooFewUnits { got: 1 })
        ));
        let e = meta_analyse(&[1.0, 2.0], &[0.1, 0.0], &o).unwrap_err();
        assert!(e.to_string().contains("std_err[1]"), "{e}");
        let e = meta_analyse(&[1.0, f64::NAN], &[0.1, 0.1], &o).unwrap_err();
        // rows count from 1 (issue 51's one convention): the second estimate is row 2
        assert!(e.to_string().contains("row 2"), "{e}");
        assert!(
            Tau2Method::parse("reml")
                .unwrap_err()
                .to_string()
                .contains("dl")
        );
    }

    #[test]
    fn quantities_missing_from_a_unit_are_named_not_combined() {
        let a: BTreeMap<String, (f64, f64)> = [
            ("k".to_string(), (1.0, 0.1)),
            ("offset_part1_um".to_string(), (0.3, 0.01)),
        ]
        .into();
        let b: BTreeMap<String, (f64, f64)> = [
            ("k".to_string(), (1.2, 0.1)),
            ("offset_part2_um".to_string(), (0.1, 0.01)),
        ]
        .into();
        let r = across_units(&[("1".into(), a), ("2".into(), b)], &MetaOptions::default()).unwrap();
        assert_eq!(r.quantities.len(), 1);
        assert!(
            r.notes
                .iter()
                .any(|n| n.contains("offset_part1_um, offset_part2_um"))
        );
        assert!(r.notes[0].contains("12.71"), "{}", r.notes[0]);
    }

    #[test]
    fn rows_group_by_first_appearance() {
        let l: Vec<String> = ["4", "1", "4", "1", "7"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let g = group_rows(&l);
        assert_eq!(g[0], ("4".to_string(), vec![0, 2]));
        assert_eq!(g[2], ("7".to_string(), vec![4]));
        assert_eq!(label_of(4.0), "4");
    }
}
