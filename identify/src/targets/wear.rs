//! `identify wear`: how the cutting force of a tool grows as it wears, from a per-cut record (one
//! row per cut: a force statistic, and optionally the flank wear VB of each flute).
//!
//! Two questions, each fitted on the training cuts and checked on the test cuts:
//!
//! * **Force against flank wear** — `F = F₀ + k·VB`, VB the mean of the flutes' flank wear (µm).
//!   This is the form of the force model's wearland term (`000_…txt` ch. 2: the flank contact force is
//!   proportional to the wearland area, so linear in its width, summed over the flutes); whether it
//!   applies to a full-record force statistic of another cutter is what the test cuts say. Ordinary
//!   least squares with Newey–West intervals (neighbouring cuts share their errors).
//! * **Force against cumulative cut length** (the cut number; one cut is one pass at constant
//!   conditions, so cut count, cutting time and engaged length move together) — a stated empirical
//!   law, chosen among
//!   - `linear`      `F = a + b·n`,
//!   - `power`       `F = a + b·(n/100)^c` (the classic wear curve's steady and accelerating parts),
//!   - `saturating`  `F = a + b·(1 − e^{−n/n₀})` (the `tool_wear` family of `diagnose`, 002 §7.5),
//!   - `exponential` `F = a + b·(e^{n/n₀} − 1)` (accelerating wear),
//!
//!   each fitted by nonlinear least squares (the identify engine, bounded), by **rolling-origin
//!   cross-validation** inside the training cuts: the training cuts are cut into `folds + 1` blocks
//!   and block j is predicted from blocks 0..j — the law is for extrapolation in cut count, so it is
//!   scored on extrapolation. The law with the smallest score is refitted on every training cut and
//!   predicts the test cuts; the report gives the RMS and largest error in N and relative to the mean
//!   test force, beside the naive prediction "the force stays at its last training level".
//!
//! ```
//! use millcomp_identify::targets::wear::*;
//! // a force that grows as 2 + 0.04·n^1.3 (N) over 300 cuts, fitted on 1..199
//! let n: Vec<f64> = (1..=300).map(f64::from).collect();
//! let f: Vec<f64> = n.iter().enumerate().map(|(i, n)| 2.0 + 0.04 * n.powf(1.3) + 0.05 * ((i * 13 % 7) as f64 - 3.0)).collect();
//! let opts = WearOptions::new(CutRange::parse("--train", "1:199").unwrap(), Some(CutRange::parse("--test", "200:300").unwrap()));
//! let s = study_wear(&n, None, "force_n", &f, &opts).unwrap();
//! assert_eq!(s.chosen.law, WearLaw::Power);
//! let m = s.test_metrics.unwrap();
//! assert!(m.rms_n < 0.5 && m.rms_n < m.naive_rms_n / 5.0);
//! ```

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{IdentifyError, Result};
use crate::linear::{LinearMethod, fit_linear};
use crate::nonlinear::{NlsOptions, ParamSpec, ResidualModel, fit_nonlinear};
use crate::report::FitReport;
use crate::units::{AcrossUnits, MetaOptions, across_units};
use crate::validate;

/// Reference cut count of the power law (`(n/100)^c`, so `b` is the growth at cut 100).
pub const POWER_REF_CUTS: f64 = 100.0;

/// An empirical law of force against cut count (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WearLaw {
    /// `a + b·n`.
    Linear,
    /// `a + b·(n/100)^c`.
    Power,
    /// `a + b·(1 − e^{−n/n₀})`.
    Saturating,
    /// `a + b·(e^{n/n₀} − 1)`.
    Exponential,
}

impl WearLaw {
    /// Every law, in report order.
    pub const ALL: [WearLaw; 4] = [
        WearLaw::Linear,
        WearLaw::Power,
        WearLaw::Saturating,
        WearLaw::Exponential,
    ];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            WearLaw::Linear => "linear",
            WearLaw::Power => "power",
            WearLaw::Saturating => "saturating",
            WearLaw::Exponential => "exponential",
        }
    }

    /// The formula, for reports.
    pub fn formula(self) -> &'static str {
        match self {
            WearLaw::Linear => "F = a + b·n",
            WearLaw::Power => "F = a + b·(n/100)^c",
            WearLaw::Saturating => "F = a + b·(1 − exp(−n/n0))",
            WearLaw::Exponential => "F = a + b·(exp(n/n0) − 1)",
        }
    }

    /// Parses a [`WearLaw::name`].
    ///
    /// # Errors
    /// [`IdentifyError::UnknownModel`].
    pub fn parse(s: &str) -> Result<Self> {
        WearLaw::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| IdentifyError::UnknownModel {
                name: s.into(),
                allowed: WearLaw::ALL.map(WearLaw::name).join(", "),
            })
    }

    fn shape(self, n: f64, q: f64) -> f64 {
        match self {
            WearLaw::Linear => n,
            WearLaw::Power => (n / POWER_REF_CUTS).powf(q),
            WearLaw::Saturating => 1.0 - (-n / q).exp(),
            WearLaw::Exponential => (n / q).exp() - 1.0,
        }
    }

    fn dshape(self, n: f64, q: f64) -> f64 {
        match self {
            WearLaw::Linear => 0.0,
            WearLaw::Power => {
                let r = n / POWER_REF_CUTS;
                if r > 0.0 { r.powf(q) * r.ln() } else { 0.0 }
            }
            WearLaw::Saturating => -(-n / q).exp() * n / (q * q),
            WearLaw::Exponential => -(n / q).exp() * n / (q * q),
        }
    }

    /// Starting values and bounds of its shape parameter (none for `linear`).
    fn shape_param(self) -> Option<(&'static str, &'static [f64], f64, f64)> {
        match self {
            WearLaw::Linear => None,
            WearLaw::Power => Some(("c", &[0.5, 1.0, 1.5, 2.0, 3.0], 0.05, 6.0)),
            WearLaw::Saturating => Some(("n0_cuts", &[10.0, 30.0, 100.0, 300.0, 1000.0], 1.0, 1e5)),
            WearLaw::Exponential => Some(("n0_cuts", &[30.0, 100.0, 300.0, 1000.0], 5.0, 1e5)),
        }
    }
}

/// An inclusive range of cut numbers `A:B` (`end` for the last cut).
#[derive(Debug, Clone, PartialEq)]
pub struct CutRange {
    /// The option it came from.
    pub flag: String,
    /// As written.
    pub text: String,
    /// First cut.
    pub first: f64,
    /// Last cut (`+inf`: the record's last).
    pub last: f64,
}

impl CutRange {
    /// Parses `A:B` (inclusive cut numbers; `B` may be `end`).
    ///
    /// # Errors
    /// [`IdentifyError::BadRange`] naming the flag and the text.
    pub fn parse(flag: &str, text: &str) -> Result<Self> {
        let bad = |m: &str| IdentifyError::BadRange {
            flag: flag.into(),
            range: text.into(),
            message: m.into(),
        };
        let (a, b) = text
            .split_once(':')
            .ok_or_else(|| bad("expected FIRST:LAST cut numbers (e.g. 1:199, 200:end)"))?;
        let num = |s: &str| -> Result<f64> {
            match s.trim() {
                "end" => Ok(f64::INFINITY),
                s => s
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad(&format!("`{s}` is not a cut number"))),
            }
        };
        let (first, last) = (num(a)?, num(b)?);
        if first.is_infinite() || last < first {
            return Err(bad("the last cut must not come before the first"));
        }
        Ok(CutRange {
            flag: flag.into(),
            text: text.into(),
            first,
            last,
        })
    }

    /// The rows whose cut number lies in the range.
    ///
    /// # Errors
    /// [`IdentifyError::BadRange`] when the range starts before the first or after the last cut of
    /// the record, ends after its last cut, or holds no row.
    pub fn resolve(&self, cut: &[f64]) -> Result<Vec<usize>> {
        let (c0, c1) = (cut[0], cut[cut.len() - 1]);
        let bad = |m: String| IdentifyError::BadRange {
            flag: self.flag.clone(),
            range: self.text.clone(),
            message: format!("{m}: the record has cuts {c0} to {c1}"),
        };
        if self.first < c0 || self.first > c1 {
            return Err(bad(format!(
                "starts at cut {}, outside the record",
                self.first
            )));
        }
        if self.last.is_finite() && self.last > c1 {
            return Err(bad(format!(
                "ends at cut {}, after the record's last",
                self.last
            )));
        }
        let rows: Vec<usize> = (0..cut.len())
            .filter(|&i| cut[i] >= self.first && cut[i] <= self.last)
            .collect();
        if rows.is_empty() {
            return Err(bad("holds no cut".into()));
        }
        Ok(rows)
    }
}

/// Options of [`study_wear`].
#[derive(Debug, Clone)]
pub struct WearOptions {
    /// Training cuts.
    pub train: CutRange,
    /// Test cuts.
    pub test: Option<CutRange>,
    /// Laws to try.
    pub laws: Vec<WearLaw>,
    /// Rolling-origin folds inside the training cuts.
    pub folds: usize,
    /// Nonlinear solver options.
    pub nls: NlsOptions,
}

impl WearOptions {
    /// All laws, 3 folds.
    pub fn new(train: CutRange, test: Option<CutRange>) -> Self {
        WearOptions {
            train,
            test,
            laws: WearLaw::ALL.to_vec(),
            folds: 3,
            nls: NlsOptions::default(),
        }
    }
}

/// A law's cross-validated score.
#[derive(Debug, Clone, Serialize)]
pub struct LawScore {
    /// The law.
    pub law: WearLaw,
    /// Its formula.
    pub formula: &'static str,
    /// RMS of the rolling-origin prediction errors (N).
    pub cv_rms_n: f64,
}

/// A law fitted on the training cuts.
#[derive(Debug, Clone, Serialize)]
pub struct LawFit {
    /// The law.
    pub law: WearLaw,
    /// Its formula.
    pub formula: &'static str,
    /// The fit (parameters `a_n`, `b_n`, and `c` or `n0_cuts`) with intervals.
    pub report: FitReport,
}

/// Prediction errors on the test cuts.
#[derive(Debug, Clone, Serialize)]
pub struct WearMetrics {
    /// Cuts.
    pub cuts: usize,
    /// RMS error (N).
    pub rms_n: f64,
    /// Largest |error| (N).
    pub max_abs_n: f64,
    /// Mean error, predicted − measured (N).
    pub bias_n: f64,
    /// RMS error relative to the mean measured force of the test cuts.
    pub rms_relative: f64,
    /// RMS error of the naive prediction: the mean force of the last 10 training cuts, held (N).
    pub naive_rms_n: f64,
}

/// `F = F₀ + k·VB` on the training cuts, with its test error.
#[derive(Debug, Clone, Serialize)]
pub struct ForceWearFit {
    /// The fit (`f0_n`, `k_n_per_um`), Newey–West intervals.
    pub report: FitReport,
    /// On the test cuts, with the measured VB.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test_metrics: Option<WearMetrics>,
    /// Its prediction at every cut (N).
    #[serde(skip)]
    pub prediction_n: Vec<f64>,
}

/// The study of one force channel.
#[derive(Debug, Clone, Serialize)]
pub struct WearStudy {
    /// The force channel, as the file names it.
    pub channel: String,
    /// Training cuts (first, last, count).
    pub train_cuts: [f64; 3],
    /// Test cuts (first, last, count).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test_cuts: Option<[f64; 3]>,
    /// Every law tried, by cross-validated score.
    pub laws: Vec<LawScore>,
    /// The law with the smallest score, refitted on the training cuts.
    pub chosen: LawFit,
    /// Its errors on the test cuts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test_metrics: Option<WearMetrics>,
    /// Force against flank wear (when VB is in the record).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_vs_wear: Option<ForceWearFit>,
    /// Notes.
    pub notes: Vec<String>,
    /// The measured force (N), for plots.
    #[serde(skip)]
    pub measured_n: Vec<f64>,
    /// The chosen law's prediction at every cut (N).
    #[serde(skip)]
    pub prediction_n: Vec<f64>,
}

/// Residual operator of a law on `rows`, parameters `[a, b]` or `[a, b, q]`.
struct LawModel<'a> {
    law: WearLaw,
    cut: &'a [f64],
    f: &'a [f64],
    rows: &'a [usize],
}

impl LawModel<'_> {
    fn q(&self, p: &DVector<f64>) -> f64 {
        if p.len() > 2 { p[2] } else { 0.0 }
    }
}

impl Operator for LawModel<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let q = self.q(p);
        Ok(DVector::from_iterator(
            self.rows.len(),
            self.rows
                .iter()
                .map(|&i| p[0] + p[1] * self.law.shape(self.cut[i], q) - self.f[i]),
        ))
    }
}

impl Jacobian for LawModel<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let q = self.q(p);
        Ok(DMatrix::from_fn(self.rows.len(), p.len(), |r, c| {
            let n = self.cut[self.rows[r]];
            match c {
                0 => 1.0,
                1 => self.law.shape(n, q),
                _ => p[1] * self.law.dshape(n, q),
            }
        }))
    }
}

impl ResidualModel for LawModel<'_> {}

/// Fits `law` on `rows`: the best of its starting grid (linear in a, b for each start), then
/// nonlinear least squares.
fn fit_law(
    law: WearLaw,
    cut: &[f64],
    f: &[f64],
    rows: &[usize],
    nls: &NlsOptions,
) -> Result<(Vec<f64>, FitReport)> {
    let n = rows.len();
    let starts: Vec<f64> = law
        .shape_param()
        .map_or(vec![0.0], |(_, s, _, _)| s.to_vec());
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for q in starts {
        let x: Vec<f64> = rows.iter().map(|&i| law.shape(cut[i], q)).collect();
        let (mx, my) = (
            x.iter().sum::<f64>() / n as f64,
            rows.iter().map(|&i| f[i]).sum::<f64>() / n as f64,
        );
        let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
        if sxx.is_nan() || sxx <= 0.0 {
            continue;
        }
        let sxy: f64 = x
            .iter()
            .zip(rows)
            .map(|(v, &i)| (v - mx) * (f[i] - my))
            .sum();
        let b = sxy / sxx;
        let a = my - b * mx;
        let rss: f64 = x
            .iter()
            .zip(rows)
            .map(|(v, &i)| (f[i] - a - b * v).powi(2))
            .sum();
        if rss.is_finite() && best.is_none_or(|bb| rss < bb.0) {
            best = Some((rss, a, b, q));
        }
    }
    let (_, a, b, q) = best.ok_or_else(|| IdentifyError::ConstantInput {
        column: "cut".into(),
        value: cut[rows[0]],
        parameters: "the wear law".into(),
    })?;
    let kind = format!("wear_{}", law.name());
    let mut names = vec!["a_n".to_string(), "b_n".to_string()];
    let (theta, mut report) = if law == WearLaw::Linear {
        // linear in its parameters: least squares directly
        let design = DMatrix::from_fn(n, 2, |r, c| if c == 0 { 1.0 } else { cut[rows[r]] });
        let yy: Vec<f64> = rows.iter().map(|&i| f[i]).collect();
        let fit = fit_linear(&names, &design, &yy, None, LinearMethod::Qr, &kind, "n")?;
        (fit.theta, fit.report)
    } else {
        let mut specs = vec![ParamSpec::free("a_n", a), ParamSpec::free("b_n", b)];
        if let Some((name, _, lo, hi)) = law.shape_param() {
            specs.push(ParamSpec::bounded(name, q, lo, hi));
            names.push(name.to_string());
        }
        let model = LawModel { law, cut, f, rows };
        let fit = fit_nonlinear(model, &specs, nls, &kind, "n")?;
        (fit.theta, fit.report)
    };
    // neighbouring cuts share their errors: Newey–West intervals
    let model = LawModel { law, cut, f, rows };
    let jac = model
        .jacobian(&theta)
        .map_err(|source| IdentifyError::ModelEvaluation {
            model: kind.clone(),
            what: "Jacobian at the estimate".into(),
            source,
        })?;
    let u = -model
        .apply(&theta)
        .map_err(|source| IdentifyError::ModelEvaluation {
            model: kind,
            what: "residuals at the estimate".into(),
            source,
        })?;
    let nw = crate::hac::apply_residuals(&mut report, &names, &jac, &u, None);
    report.warnings.push(format!(
        "residuals autocorrelated (lag-1 r = {:.3}): Newey–West intervals over {} lags on {:.0} effective degrees of freedom",
        nw.r, nw.lags, nw.dof_eff
    ));
    Ok((theta.iter().copied().collect(), report))
}

fn predict(law: WearLaw, p: &[f64], n: f64) -> f64 {
    p[0] + p[1] * law.shape(n, p.get(2).copied().unwrap_or(0.0))
}

fn metrics(f: &[f64], pred: &[f64], rows: &[usize], naive: f64) -> WearMetrics {
    let k = rows.len().max(1) as f64;
    let err: Vec<f64> = rows.iter().map(|&i| pred[i] - f[i]).collect();
    let rms = (err.iter().map(|e| e * e).sum::<f64>() / k).sqrt();
    let mean = rows.iter().map(|&i| f[i]).sum::<f64>() / k;
    WearMetrics {
        cuts: rows.len(),
        rms_n: rms,
        max_abs_n: err.iter().fold(0.0f64, |m, e| m.max(e.abs())),
        bias_n: err.iter().sum::<f64>() / k,
        rms_relative: rms / mean.abs(),
        naive_rms_n: (rows.iter().map(|&i| (naive - f[i]).powi(2)).sum::<f64>() / k).sqrt(),
    }
}

/// Studies one force channel `f` (N) of a per-cut record: the laws against cut number `cut`, and —
/// with `vb_um` (one slice per flute) — the force against the mean flank wear (module
/// documentation).
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] / [`IdentifyError::NonFinite`] naming the column and row;
/// * [`IdentifyError::NonMonotoneTime`] when the cut numbers do not strictly increase;
/// * [`IdentifyError::BadRange`] for a range outside the record, overlapping the other, or a
///   training range too short for its folds (≥ 4 cuts per block);
/// * [`IdentifyError::InvalidParameter`] for fewer than 2 folds.
pub fn study_wear(
    cut: &[f64],
    vb_um: Option<&[(String, &[f64])]>,
    channel: &str,
    f: &[f64],
    opts: &WearOptions,
) -> Result<WearStudy> {
    let n = cut.len();
    validate::finite("cut", cut)?;
    validate::strictly_increasing("cut", cut)?;
    validate::same_len(channel, f, "cut", n)?;
    validate::finite(channel, f)?;
    if let Some(vb) = vb_um {
        for (name, v) in vb {
            validate::same_len(name, v, "cut", n)?;
            validate::finite(name, v)?;
        }
    }
    if opts.folds < 2 {
        return Err(IdentifyError::InvalidParameter {
            name: "folds".into(),
            value: opts.folds as f64,
            allowed: ">= 2",
        });
    }
    let train = opts.train.resolve(cut)?;
    let test = match &opts.test {
        Some(r) => {
            let rows = r.resolve(cut)?;
            if rows.iter().any(|i| train.contains(i)) {
                return Err(IdentifyError::BadRange {
                    flag: r.flag.clone(),
                    range: r.text.clone(),
                    message: format!(
                        "overlaps the training cuts {}: the test must be cuts the fit never saw",
                        opts.train.text
                    ),
                });
            }
            Some(rows)
        }
        None => None,
    };
    let blocks = crate::regress::blocked_folds(&train, opts.folds + 1);
    if blocks.iter().any(|b| b.len() < 4) {
        return Err(IdentifyError::BadRange {
            flag: opts.train.flag.clone(),
            range: opts.train.text.clone(),
            message: format!(
                "holds {} cuts; {} rolling-origin folds need at least {} (4 per block)",
                train.len(),
                opts.folds,
                4 * (opts.folds + 1)
            ),
        });
    }
    let mut notes = Vec::new();
    // rolling-origin cross-validation
    let mut scores: Vec<LawScore> = Vec::new();
    for &law in &opts.laws {
        let (mut ss, mut k) = (0.0, 0usize);
        let mut ok = true;
        for j in 1..blocks.len() {
            let fit_rows: Vec<usize> = blocks[..j].concat();
            match fit_law(law, cut, f, &fit_rows, &opts.nls) {
                Ok((p, _)) => {
                    for &i in &blocks[j] {
                        ss += (predict(law, &p, cut[i]) - f[i]).powi(2);
                        k += 1;
                    }
                }
                Err(e) => {
                    notes.push(format!(
                        "{}: fold {j} could not be fitted ({e})",
                        law.name()
                    ));
                    ok = false;
                }
            }
        }
        if ok {
            scores.push(LawScore {
                law,
                formula: law.formula(),
                cv_rms_n: (ss / k.max(1) as f64).sqrt(),
            });
        }
    }
    scores.sort_by(|a, b| a.cv_rms_n.total_cmp(&b.cv_rms_n));
    let best = scores
        .first()
        .map(|s| s.law)
        .ok_or(IdentifyError::SolverState {
            what: "no wear law could be cross-validated",
        })?;
    let (p, report) = fit_law(best, cut, f, &train, &opts.nls)?;
    let prediction: Vec<f64> = cut.iter().map(|&c| predict(best, &p, c)).collect();
    let last10 = &train[train.len().saturating_sub(10)..];
    let naive = last10.iter().map(|&i| f[i]).sum::<f64>() / last10.len() as f64;
    let test_metrics = test
        .as_ref()
        .map(|rows| metrics(f, &prediction, rows, naive));

    let force_vs_wear = match vb_um {
        Some(vb) if !vb.is_empty() => {
            let mean_vb: Vec<f64> = (0..n)
                .map(|i| vb.iter().map(|(_, v)| v[i]).sum::<f64>() / vb.len() as f64)
                .collect();
            let design =
                DMatrix::from_fn(
                    train.len(),
                    2,
                    |r, c| {
                        if c == 0 { 1.0 } else { mean_vb[train[r]] }
                    },
                );
            let names = ["f0_n".to_string(), "k_n_per_um".to_string()];
            let yy: Vec<f64> = train.iter().map(|&i| f[i]).collect();
            let fit = fit_linear(
                &names,
                &design,
                &yy,
                None,
                LinearMethod::Qr,
                "force_vs_wear",
                "n",
            )?;
            let mut rep = fit.report;
            let nw = crate::hac::apply(&mut rep, &names, &design, &yy, &fit.theta, None);
            rep.warnings.push(format!(
                "residuals autocorrelated (lag-1 r = {:.3}): Newey–West intervals over {} lags on {:.0} effective degrees of freedom",
                nw.r, nw.lags, nw.dof_eff
            ));
            let pred: Vec<f64> = mean_vb
                .iter()
                .map(|v| fit.theta[0] + fit.theta[1] * v)
                .collect();
            let tm = test.as_ref().map(|rows| metrics(f, &pred, rows, naive));
            notes.push(format!(
                "VB = mean of {} flute(s): {}",
                vb.len(),
                vb.iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            Some(ForceWearFit {
                report: rep,
                test_metrics: tm,
                prediction_n: pred,
            })
        }
        _ => None,
    };
    let span = |rows: &[usize]| [cut[rows[0]], cut[rows[rows.len() - 1]], rows.len() as f64];
    Ok(WearStudy {
        channel: channel.to_string(),
        train_cuts: span(&train),
        test_cuts: test.as_deref().map(span),
        laws: scores,
        chosen: LawFit {
            law: best,
            formula: best.formula(),
            report,
        },
        test_metrics,
        force_vs_wear,
        notes,
        measured_n: f.to_vec(),
        prediction_n: prediction,
    })
}

/// The name of the force at flank wear `vb_um` (`force_at_vb_100um_n`).
pub fn force_at_vb_name(vb_um: f64) -> String {
    format!("force_at_vb_{vb_um}um_n")
}

/// The quantities of a force-against-wear fit that carry over to another unit: `f0_n`,
/// `k_n_per_um` and the force at flank wear `at_vb_um` (`F0 + k·VB`, its standard error from the fit's
/// Newey–West covariance), each as (estimate, standard error).
pub fn force_wear_quantities(
    fit: &ForceWearFit,
    at_vb_um: f64,
) -> std::collections::BTreeMap<String, (f64, f64)> {
    let r = &fit.report;
    let mut m: std::collections::BTreeMap<String, (f64, f64)> = ["f0_n", "k_n_per_um"]
        .iter()
        .map(|n| (n.to_string(), (r.param(n), r.se(n))))
        .collect();
    if let Some(d) = super::derive(r, &["f0_n", "k_n_per_um"], "F0 + k·VB", |x| {
        x[0] + at_vb_um * x[1]
    }) {
        m.insert(force_at_vb_name(at_vb_um), (d.value, d.std_err));
    }
    m
}

/// One force channel across units.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelAcross {
    /// The force channel.
    pub channel: String,
    /// The flank wear at which the force is predicted (µm).
    pub at_vb_um: f64,
    /// The meta-analysis of `f0_n`, `k_n_per_um` and the force at `at_vb_um`.
    #[serde(flatten)]
    pub across: AcrossUnits,
}

/// Combines the force-against-wear fits of several units (`units[i] = (unit, its studies)`), channel by
/// channel (a channel every unit has, with a force-against-wear fit in each) — the crate's one
/// across-units analysis ([`crate::units`]). The cut-count laws are each unit's own (the law chosen
/// may differ) and are not combined.
///
/// # Errors
/// [`IdentifyError::TooFewUnits`] for fewer than 2 units; [`IdentifyError::MissingColumn`] when no
/// channel has a force-against-wear fit in every unit (no `vb_um`).
pub fn wear_across_units(
    units: &[(String, Vec<WearStudy>)],
    at_vb_um: f64,
    meta: &MetaOptions,
) -> Result<Vec<ChannelAcross>> {
    if units.len() < 2 {
        return Err(IdentifyError::TooFewUnits { got: units.len() });
    }
    let mut out = Vec::new();
    for s in &units[0].1 {
        let per: Option<Vec<(String, crate::units::Quantities)>> = units
            .iter()
            .map(|(u, studies)| {
                studies
                    .iter()
                    .find(|t| t.channel == s.channel)
                    .and_then(|t| t.force_vs_wear.as_ref())
                    .map(|fw| (u.clone(), force_wear_quantities(fw, at_vb_um)))
            })
            .collect();
        if let Some(per) = per {
            let mut across = across_units(&per, meta)?;
            across.notes.push(
                "the cut-count laws are each unit's own (the law chosen may differ) and are not combined"
                    .into(),
            );
            out.push(ChannelAcross {
                channel: s.channel.clone(),
                at_vb_um,
                across,
            });
        }
    }
    if out.is_empty() {
        return Err(IdentifyError::MissingColumn {
            column: "vb_um".into(),
            reason:
                "the units are combined through their force-against-wear fits: map the flank wear \
                     of every unit (--columns vb_um=…)"
                    .into(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobian_check::check_jacobian;

    #[test]
    fn law_jacobians_match_finite_differences() {
        let cut: Vec<f64> = (1..=60).map(f64::from).collect();
        let f = vec![0.0; 60];
        let rows: Vec<usize> = (0..60).collect();
        for (law, p) in [
            (WearLaw::Linear, vec![1.0, 0.1]),
            (WearLaw::Power, vec![1.0, 2.0, 1.4]),
            (WearLaw::Saturating, vec![1.0, 3.0, 25.0]),
            (WearLaw::Exponential, vec![1.0, 0.5, 40.0]),
        ] {
            let m = LawModel {
                law,
                cut: &cut,
                f: &f,
                rows: &rows,
            };
            let c = check_jacobian(&m, &DVector::from_vec(p), 1e-6).unwrap();
            assert!(c.ok, "{law:?}: {c:?}");
        }
    }

    #[test]
    fn cut_ranges_name_what_is_wrong() {
        let cut: Vec<f64> = (1..=315).map(f64::from).collect();
        assert_eq!(
            CutRange::parse("--train", "1:199")
                .unwrap()
                .resolve(&cut)
                .unwrap()
                .len(),
            199
        );
        assert_eq!(
            CutRange::parse("--test", "200:end")
                .unwrap()
                .resolve(&cut)
                .unwrap()
                .len(),
            116
        );
        let e = CutRange::parse("--train", "1:400")
            .unwrap()
            .resolve(&cut)
            .unwrap_err();
        assert!(
            e.to_string().contains("--train 1:400") && e.to_string().contains("cuts 1 to 315"),
            "{e}"
        );
        assert!(CutRange::parse("--test", "9:3").is_err());
        let f: Vec<f64> = cut.iter().map(|c| 1.0 + 0.01 * c).collect();
        let o = WearOptions::new(
            CutRange::parse("--train", "1:199").unwrap(),
            Some(CutRange::parse("--test", "150:end").unwrap()),
        );
        let e = study_wear(&cut, None, "f_n", &f, &o).unwrap_err();
        assert!(e.to_string().contains("overlaps"), "{e}");
    }

    #[test]
    fn force_against_wear_recovers_the_slope() {
        let cut: Vec<f64> = (1..=120).map(f64::from).collect();
        let vb1: Vec<f64> = cut.iter().map(|c| 30.0 + 0.8 * c).collect();
        let vb2: Vec<f64> = cut.iter().map(|c| 40.0 + 0.6 * c).collect();
        let f: Vec<f64> = (0..120)
            .map(|i| 1.5 + 0.05 * 0.5 * (vb1[i] + vb2[i]) + 0.01 * ((i % 3) as f64 - 1.0))
            .collect();
        let vb = vec![
            ("vb1_um".to_string(), vb1.as_slice()),
            ("vb2_um".to_string(), vb2.as_slice()),
        ];
        let o = WearOptions::new(
            CutRange::parse("--train", "1:80").unwrap(),
            Some(CutRange::parse("--test", "81:end").unwrap()),
        );
        let s = study_wear(&cut, Some(&vb), "f_n", &f, &o).unwrap();
        let fw = s.force_vs_wear.unwrap();
        assert!((fw.report.param("k_n_per_um") - 0.05).abs() < 1e-3);
        assert!(fw.test_metrics.unwrap().rms_n < 0.02);
    }
}
