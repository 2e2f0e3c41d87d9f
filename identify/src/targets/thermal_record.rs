//! `identify thermal` on a measured record: the thermal models a machine-tool engineer would try,
//! their structure chosen by blocked cross-validation inside a training range, then predicting the
//! rest of the record.
//!
//! # Model families
//! The drift `y(t)` (µm) of one channel is modelled as
//!
//! * **speed-driven growth** (`speed-1tau`, `speed-2tau`; the speed dependence of 002 §7.6):
//!   `y = c + Σₖ gₖ·Lτₖ[u]`, `u(t) = (n(t)/1000 rpm)^e`, where `Lτ` is the first-order lag of the
//!   record's speed history (the speed of row i holds until row i + 1, the lag starts at 0 at the
//!   record's start: `s_{i+1} = u_i + (s_i − u_i)·exp(−Δtᵢ/τ)`). `gₖ` is the steady growth at 1000 rpm
//!   of the k-th path, `e` the **speed-dependent gain**: the steady growth goes as `n^e` (e = 1 a
//!   constant µm per rpm; e ≈ 2 for bearing friction heat). Fitted by nonlinear least squares (the
//!   identify engine, bounded trust region), from the best point of the grid below, with standard
//!   errors and 95 % intervals.
//! * **temperature-based** `y = c + Σᵢ mᵢ·ΔTᵢ` (002's calibration Δl = m·ΔT on many sensors), the
//!   sensors chosen by a stated criterion: `temperature-stepwise` — stepwise selection by BIC
//!   (forward with backward elimination, [`crate::regress::stepwise_bic`]); `temperature-ridge` —
//!   every sensor, ridge penalty `λ·n·‖β‖²` on standardised columns, λ by the cross-validation below.
//! * **combined** `y = c + Σₖ gₖ·Lτₖ[u] + Σᵢ mᵢ·ΔTᵢ` with one or two lags (`combined-1tau-…`,
//!   `combined-2tau-…`) and the sensors by stepwise BIC (the lags always in) or ridge (lags and
//!   sensors penalised alike).
//!
//! # Structure by cross-validation inside the training range
//! The training rows are split into `folds` contiguous blocks ([`crate::regress::blocked_folds`]):
//! each block is predicted by the model fitted on the others. The score is the RMS over all training
//! rows of the **zeroed** prediction error in each held-out block — `(y − y₀) − (ŷ − ŷ₀)`, `₀` the
//! block's first row — which is what a machine zeroed at the start of the block would see. Every
//! family is scored over a grid: time constants [`TAU_GRID_S`] (one, or two distinct), exponents
//! [`EXPONENT_GRID`], ridge λ [`LAMBDA_GRID`]; the speed-only families are refined by nonlinear least
//! squares in every fold from their best grid point. The structure with the smallest score is refitted
//! on all training rows. Sensor selection (stepwise) is redone inside every fold, so its cost is in
//! the score. The test range is never looked at until the chosen model predicts it.
//!
//! # Test metrics
//! `drift = y − y(t_test,0)` (what a machine zeroed at the start of the test range sees), the
//! prediction zeroed the same way, `residual = drift − predicted drift`; RMS and max |residual|, and
//! the share of drift removed `1 − RMS(residual)/RMS(drift)`. The same for the baseline: plain least
//! squares on every temperature (no selection, no penalty) fitted on the same training rows.
//!
//! # Uncertainty
//! Residuals of a drift record are strongly autocorrelated: the speed-driven and stepwise models
//! report Newey–West intervals (autocorrelation-consistent, `crate::hac`), as does the baseline. Ridge
//! coefficients are shrunk and have no honest interval of their own: their uncertainty is stated as
//! the cross-validated prediction error, the number the structure was chosen by.

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{IdentifyError, Result};
use crate::linear::{LinearMethod, fit_linear};
use crate::nonlinear::{NlsOptions, ParamSpec, ResidualModel, fit_nonlinear};
use crate::regress::{Gram, blocked_folds, complement, stepwise_bic};
use crate::report::FitReport;
use crate::validate;

/// Time constants tried (s): 10 min to 8 h in steps of about 2 — the record's speed cycles are
/// hours long, and a machine's structural paths range from the spindle (minutes) to the column
/// (hours).
pub const TAU_GRID_S: [f64; 6] = [600.0, 1800.0, 3600.0, 7200.0, 14_400.0, 28_800.0];
/// Speed exponents tried: steady growth ∝ speed (1) to ∝ speed² (bearing friction heat).
pub const EXPONENT_GRID: [f64; 3] = [1.0, 1.5, 2.0];
/// Ridge penalties tried (per standardised sample), 1e-6 … 10.
pub const LAMBDA_GRID: [f64; 8] = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0];
/// Speed of the gains' reference (rpm): `gₖ` is the steady growth at 1000 rpm.
pub const SPEED_REF_RPM: f64 = 1000.0;
/// Fewest rows a cross-validation block may have.
pub const MIN_FOLD_ROWS: usize = 20;

/// How the temperature sensors enter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Sensors {
    /// Stepwise selection by BIC.
    Stepwise,
    /// Every sensor, ridge penalty by cross-validation.
    Ridge,
}

/// A model structure of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Structure {
    /// Speed lags (0, 1 or 2).
    pub n_tau: usize,
    /// Temperatures, if any.
    pub sensors: Option<Sensors>,
}

impl Structure {
    /// Every structure, in the order they are reported.
    pub const ALL: [Structure; 8] = [
        Structure::new(1, None),
        Structure::new(2, None),
        Structure::new(0, Some(Sensors::Stepwise)),
        Structure::new(0, Some(Sensors::Ridge)),
        Structure::new(1, Some(Sensors::Stepwise)),
        Structure::new(1, Some(Sensors::Ridge)),
        Structure::new(2, Some(Sensors::Stepwise)),
        Structure::new(2, Some(Sensors::Ridge)),
    ];

    const fn new(n_tau: usize, sensors: Option<Sensors>) -> Self {
        Structure { n_tau, sensors }
    }

    /// The name `--model` takes: `speed-1tau`, `temperature-ridge`, `combined-2tau-stepwise`, ….
    pub fn name(&self) -> String {
        let s = |s: Sensors| match s {
            Sensors::Stepwise => "stepwise",
            Sensors::Ridge => "ridge",
        };
        match (self.n_tau, self.sensors) {
            (k, None) => format!("speed-{k}tau"),
            (0, Some(x)) => format!("temperature-{}", s(x)),
            (k, Some(x)) => format!("combined-{k}tau-{}", s(x)),
        }
    }

    /// Parses a name of [`Structure::name`].
    ///
    /// # Errors
    /// [`IdentifyError::UnknownModel`] naming the allowed names.
    pub fn parse(name: &str) -> Result<Self> {
        Structure::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| IdentifyError::UnknownModel {
                name: name.into(),
                allowed: Structure::ALL.map(|s| s.name()).join(", "),
            })
    }
}

impl std::fmt::Display for Structure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// One end of a time range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// Seconds on the record's clock.
    Seconds(f64),
    /// A fraction of the record's time span from its first sample (`50%` → 0.5).
    Fraction(f64),
    /// The record's last sample.
    End,
}

/// A time range `START:END` of `--train` / `--test`: each end in seconds (`83340`, `83340s`), minutes
/// (`90min`), hours (`23.15h`), a percentage of the record's span (`50%`) or `end` / `start`.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeRange {
    /// The option it came from, for messages.
    pub flag: String,
    /// As written.
    pub text: String,
    /// Start.
    pub start: Bound,
    /// End.
    pub end: Bound,
}

/// A range resolved against a record: its times and the rows inside.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Window {
    /// As written.
    pub range: String,
    /// First time (s).
    pub start_s: f64,
    /// Last time (s).
    pub end_s: f64,
    /// Rows inside.
    pub rows: usize,
    /// First row (0-based).
    pub first_row: usize,
}

fn parse_bound(flag: &str, text: &str, s: &str) -> Result<Bound> {
    let bad = |m: &str| IdentifyError::BadRange {
        flag: flag.into(),
        range: text.into(),
        message: m.into(),
    };
    let s = s.trim();
    match s {
        "end" => return Ok(Bound::End),
        "start" => return Ok(Bound::Seconds(f64::NEG_INFINITY)),
        _ => {}
    }
    let (num, scale, frac) = if let Some(v) = s.strip_suffix('%') {
        (v, 0.01, true)
    } else if let Some(v) = s.strip_suffix("min") {
        (v, 60.0, false)
    } else if let Some(v) = s.strip_suffix('h') {
        (v, 3600.0, false)
    } else if let Some(v) = s.strip_suffix('s') {
        (v, 1.0, false)
    } else {
        (s, 1.0, false)
    };
    let x: f64 = num.trim().parse().map_err(|_| {
        bad(&format!(
            "`{s}` is not a time (seconds, `90min`, `23.15h`, `50%`, `start` or `end`)"
        ))
    })?;
    if !x.is_finite() {
        return Err(bad("a bound must be finite"));
    }
    Ok(if frac {
        Bound::Fraction(x * scale)
    } else {
        Bound::Seconds(x * scale)
    })
}

impl TimeRange {
    /// Parses `START:END` given to `flag`.
    ///
    /// # Errors
    /// [`IdentifyError::BadRange`] naming the flag and the text.
    ///
    /// ```
    /// use millcomp_identify::targets::thermal_record::{Bound, TimeRange};
    /// let r = TimeRange::parse("--train", "0:23.15h").unwrap();
    /// assert_eq!((r.start, r.end), (Bound::Seconds(0.0), Bound::Seconds(83_340.0)));
    /// assert_eq!(TimeRange::parse("--test", "50%:end").unwrap().start, Bound::Fraction(0.5));
    /// assert!(TimeRange::parse("--train", "0-5h").unwrap_err().to_string().contains("--train 0-5h"));
    /// ```
    pub fn parse(flag: &str, text: &str) -> Result<Self> {
        let Some((a, b)) = text.split_once(':') else {
            return Err(IdentifyError::BadRange {
                flag: flag.into(),
                range: text.into(),
                message: "expected START:END (e.g. 0:23.15h, 50%:end)".into(),
            });
        };
        Ok(TimeRange {
            flag: flag.into(),
            text: text.into(),
            start: parse_bound(flag, text, a)?,
            end: parse_bound(flag, text, b)?,
        })
    }

    /// The rows of `t_s` inside the range (`start ≤ t < end`, the record's last sample included when
    /// the end is `end` or at/after it).
    ///
    /// # Errors
    /// [`IdentifyError::BadRange`] when the range is empty, reversed, or starts or ends outside the
    /// record (the message gives the record's first and last time).
    pub fn resolve(&self, t_s: &[f64]) -> Result<(Window, Vec<usize>)> {
        let (t0, t1) = (t_s[0], t_s[t_s.len() - 1]);
        let at = |b: Bound, is_end: bool| match b {
            Bound::Seconds(x) if x == f64::NEG_INFINITY => t0,
            Bound::Seconds(x) => x,
            Bound::Fraction(p) => t0 + p * (t1 - t0),
            Bound::End => {
                if is_end {
                    f64::INFINITY
                } else {
                    t1
                }
            }
        };
        let (a, b) = (at(self.start, false), at(self.end, true));
        let bad = |m: String| IdentifyError::BadRange {
            flag: self.flag.clone(),
            range: self.text.clone(),
            message: m,
        };
        let span = format!("the record runs from t_s = {t0} s to {t1} s");
        if b <= a {
            return Err(bad(format!(
                "the end ({b} s) is not after the start ({a} s)"
            )));
        }
        let tol = 1e-9 * (t1 - t0).abs().max(1.0);
        if a < t0 - tol || a > t1 {
            return Err(bad(format!("starts at {a} s, outside the record: {span}")));
        }
        if b.is_finite()
            && b > t1 + tol
            && !matches!(self.end, Bound::Fraction(p) if p <= 1.0 + 1e-12)
        {
            return Err(bad(format!(
                "ends at {b} s, after the record's end: {span}"
            )));
        }
        let last_included = b >= t1 - tol;
        let rows: Vec<usize> = (0..t_s.len())
            .filter(|&i| {
                t_s[i] >= a - tol && (t_s[i] < b - tol || (last_included && i == t_s.len() - 1))
            })
            .collect();
        let (Some(&f), Some(&l)) = (rows.first(), rows.last()) else {
            return Err(bad(format!("holds no sample: {span}")));
        };
        Ok((
            Window {
                range: self.text.clone(),
                start_s: t_s[f],
                end_s: t_s[l],
                rows: rows.len(),
                first_row: f,
            },
            rows,
        ))
    }
}

/// A record: time, and the inputs the models may use.
#[derive(Debug, Clone)]
pub struct ThermalRecord<'a> {
    /// Time (s), strictly increasing.
    pub t_s: &'a [f64],
    /// Spindle speed per row (rpm), if recorded.
    pub speed_rpm: Option<&'a [f64]>,
    /// Temperatures (°C), named as in the user's file.
    pub temps_c: Vec<(String, &'a [f64])>,
}

/// Options of the study.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Training range.
    pub train: TimeRange,
    /// Test range (none: only the training fit and its cross-validation).
    pub test: Option<TimeRange>,
    /// Cross-validation blocks inside the training range.
    pub folds: usize,
    /// Structures to try (default all that the record's columns allow).
    pub structures: Vec<Structure>,
    /// Time constants (s).
    pub tau_grid_s: Vec<f64>,
    /// Speed exponents.
    pub exponent_grid: Vec<f64>,
    /// Ridge penalties.
    pub lambda_grid: Vec<f64>,
    /// Nonlinear solver options.
    pub nls: NlsOptions,
}

impl StudyOptions {
    /// The defaults of the module documentation with these ranges.
    pub fn new(train: TimeRange, test: Option<TimeRange>) -> Self {
        StudyOptions {
            train,
            test,
            folds: 3,
            structures: Structure::ALL.to_vec(),
            tau_grid_s: TAU_GRID_S.to_vec(),
            exponent_grid: EXPONENT_GRID.to_vec(),
            lambda_grid: LAMBDA_GRID.to_vec(),
            nls: NlsOptions::default(),
        }
    }
}

/// The best configuration of one structure and its cross-validated score.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateScore {
    /// The structure (`--model` name).
    pub model: String,
    /// Cross-validated RMS of the zeroed prediction error over the training rows (µm).
    pub cv_rms_um: f64,
    /// The same per held-out block (µm).
    pub fold_rms_um: Vec<f64>,
    /// Time constants of its best grid point (s); for the speed-only structures, the grid start
    /// (each fold refines it).
    pub taus_s: Vec<f64>,
    /// Speed exponent of its best grid point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exponent: Option<f64>,
    /// Ridge penalty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda: Option<f64>,
}

/// Test (or training) metrics of a prediction, zeroed at the range's first row.
#[derive(Debug, Clone, Serialize)]
pub struct Metrics {
    /// Rows.
    pub rows: usize,
    /// RMS of `drift − predicted drift` (µm).
    pub rms_um: f64,
    /// Largest |drift − predicted drift| (µm).
    pub max_abs_um: f64,
    /// RMS of the drift itself (µm).
    pub drift_rms_um: f64,
    /// `1 − rms/drift_rms`: the share of the drift a compensation by this model removes.
    pub removed: f64,
}

/// The zeroed metrics of `pred` against `y` over `rows` (module documentation).
///
/// ```
/// use millcomp_identify::targets::thermal_record::zeroed_metrics;
/// let y = [5.0, 6.0, 8.0, 9.0];
/// let p = [0.0, 1.0, 3.5, 4.0]; // off by a constant 5 (ignored) and 0.5 µm at row 2
/// let m = zeroed_metrics(&y, &p, &[0, 1, 2, 3]);
/// assert!((m.rms_um - 0.25).abs() < 1e-12 && (m.max_abs_um - 0.5).abs() < 1e-12);
/// // drift 0, 1, 3, 4 µm: RMS √6.5
/// assert!((m.drift_rms_um - 6.5f64.sqrt()).abs() < 1e-12);
/// assert!((m.removed - (1.0 - 0.25 / 6.5f64.sqrt())).abs() < 1e-12);
/// ```
pub fn zeroed_metrics(y: &[f64], pred: &[f64], rows: &[usize]) -> Metrics {
    let (Some(&f), n) = (rows.first(), rows.len()) else {
        return Metrics {
            rows: 0,
            rms_um: f64::NAN,
            max_abs_um: f64::NAN,
            drift_rms_um: f64::NAN,
            removed: f64::NAN,
        };
    };
    let (mut ss, mut sd, mut mx) = (0.0, 0.0, 0.0f64);
    for &i in rows {
        let d = y[i] - y[f];
        let r = d - (pred[i] - pred[f]);
        ss += r * r;
        sd += d * d;
        mx = mx.max(r.abs());
    }
    let rms = (ss / n as f64).sqrt();
    let drift = (sd / n as f64).sqrt();
    Metrics {
        rows: n,
        rms_um: rms,
        max_abs_um: mx,
        drift_rms_um: drift,
        removed: 1.0 - rms / drift,
    }
}

/// The chosen (or baseline) model, fitted on all training rows.
#[derive(Debug, Clone, Serialize)]
pub struct FittedModel {
    /// Structure name (`plain-lsq-all-temperatures` for the baseline).
    pub model: String,
    /// Time constants (s).
    pub taus_s: Vec<f64>,
    /// Speed exponent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exponent: Option<f64>,
    /// Ridge penalty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda: Option<f64>,
    /// The sensors in the model (selected, or all for ridge and the baseline), as the file names them.
    pub sensors: Vec<String>,
    /// Coefficients in their units: `offset_um`, `gain<k>_um` (steady growth at 1000 rpm of lag k),
    /// `m_<sensor>_um_per_k`.
    pub coefficients: BTreeMap<String, f64>,
    /// The fit report with intervals (speed-driven: the engine's; stepwise and baseline: Newey–West);
    /// none for ridge (module documentation).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<FitReport>,
    /// RMS of the fit residual over the training rows (µm).
    pub train_rms_um: f64,
}

/// The study of one channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelStudy {
    /// The channel (as the file names it).
    pub channel: String,
    /// Training range.
    pub train: Window,
    /// Test range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test: Option<Window>,
    /// Cross-validation blocks.
    pub folds: usize,
    /// Every structure tried, best configuration each, by cross-validated score.
    pub candidates: Vec<CandidateScore>,
    /// The structure with the smallest score, refitted on the training rows.
    pub chosen: FittedModel,
    /// Cross-validated score of the chosen structure (µm).
    pub chosen_cv_rms_um: f64,
    /// The baseline: plain least squares on every temperature.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline: Option<FittedModel>,
    /// Chosen model on the test range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test_metrics: Option<Metrics>,
    /// Baseline on the test range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline_test_metrics: Option<Metrics>,
    /// Structures not tried, and why; other notes.
    pub notes: Vec<String>,
    /// The channel's values (µm), for plots.
    #[serde(skip)]
    pub measured_um: Vec<f64>,
    /// Prediction of the chosen model at every row (µm).
    #[serde(skip)]
    pub prediction_um: Vec<f64>,
    /// Prediction of the baseline at every row (µm).
    #[serde(skip)]
    pub baseline_prediction_um: Vec<f64>,
}

// ---- speed lags --------------------------------------------------------------------------------

/// First-order lag of the input `u` (held from row i to i + 1) with time constant `tau_s`, from 0
/// at the first row.
pub fn first_order_lag(t_s: &[f64], u: &[f64], tau_s: f64) -> Vec<f64> {
    let mut s = 0.0;
    let mut out = Vec::with_capacity(t_s.len());
    for i in 0..t_s.len() {
        out.push(s);
        if i + 1 < t_s.len() {
            let phi = (-(t_s[i + 1] - t_s[i]) / tau_s).exp();
            s = u[i] + (s - u[i]) * phi;
        }
    }
    out
}

/// `(n/1000 rpm)^e` (0 at standstill).
fn speed_input(speed_rpm: &[f64], e: f64) -> Vec<f64> {
    speed_rpm
        .iter()
        .map(|&n| {
            if n > 0.0 {
                (n / SPEED_REF_RPM).powf(e)
            } else {
                0.0
            }
        })
        .collect()
}

/// Residual operator of the speed-driven model on `rows`, parameters
/// `[g_1..g_k, tau_1..tau_k, exponent, offset_um]`.
struct SpeedModel<'a> {
    t_s: &'a [f64],
    speed_rpm: &'a [f64],
    y: &'a [f64],
    rows: &'a [usize],
    n_tau: usize,
}

impl SpeedModel<'_> {
    fn predict_all(&self, p: &[f64]) -> Vec<f64> {
        let k = self.n_tau;
        let u = speed_input(self.speed_rpm, p[2 * k]);
        let mut out = vec![p[2 * k + 1]; self.t_s.len()];
        for j in 0..k {
            let l = first_order_lag(self.t_s, &u, p[k + j]);
            for (o, v) in out.iter_mut().zip(&l) {
                *o += p[j] * v;
            }
        }
        out
    }
}

impl Operator for SpeedModel<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let m = self.predict_all(p.as_slice());
        Ok(DVector::from_iterator(
            self.rows.len(),
            self.rows.iter().map(|&i| m[i] - self.y[i]),
        ))
    }
}

impl Jacobian for SpeedModel<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let k = self.n_tau;
        let e = p[2 * k];
        let u = speed_input(self.speed_rpm, e);
        // ∂u/∂e = u·ln(n/1000); the lag is linear in its input, so ∂L[u]/∂e = L[∂u/∂e]
        let du: Vec<f64> = self
            .speed_rpm
            .iter()
            .zip(&u)
            .map(|(&n, &u)| {
                if n > 0.0 {
                    u * (n / SPEED_REF_RPM).ln()
                } else {
                    0.0
                }
            })
            .collect();
        let n = self.t_s.len();
        let mut full = DMatrix::zeros(n, p.len());
        for j in 0..k {
            let tau = p[k + j];
            let l = first_order_lag(self.t_s, &u, tau);
            let le = first_order_lag(self.t_s, &du, tau);
            // ∂s/∂τ by the recursion's sensitivity
            let mut sens = 0.0;
            let mut s = 0.0;
            for i in 0..n {
                full[(i, j)] = l[i];
                full[(i, k + j)] = p[j] * sens;
                full[(i, 2 * k)] += p[j] * le[i];
                full[(i, 2 * k + 1)] = 1.0;
                if i + 1 < n {
                    let dt = self.t_s[i + 1] - self.t_s[i];
                    let phi = (-dt / tau).exp();
                    sens = sens * phi + (s - u[i]) * phi * dt / (tau * tau);
                    s = u[i] + (s - u[i]) * phi;
                }
            }
        }
        Ok(DMatrix::from_fn(self.rows.len(), p.len(), |r, c| {
            full[(self.rows[r], c)]
        }))
    }
}

impl ResidualModel for SpeedModel<'_> {}

/// The time-constant sets of the grid: one each, or every distinct pair.
fn tau_sets(grid: &[f64], n_tau: usize) -> Vec<Vec<f64>> {
    match n_tau {
        0 => vec![vec![]],
        1 => grid.iter().map(|&t| vec![t]).collect(),
        _ => {
            let mut out = Vec::new();
            for (a, &ta) in grid.iter().enumerate() {
                for &tb in &grid[a + 1..] {
                    out.push(vec![ta, tb]);
                }
            }
            out
        }
    }
}

/// Lags of the grid, computed once per (τ, e) over the whole record.
struct LagBank {
    lags: BTreeMap<(u64, u64), Vec<f64>>,
}

impl LagBank {
    fn new(t_s: &[f64], speed_rpm: Option<&[f64]>, taus: &[f64], exps: &[f64]) -> Self {
        let mut lags = BTreeMap::new();
        if let Some(n) = speed_rpm {
            for &e in exps {
                let u = speed_input(n, e);
                for &tau in taus {
                    lags.insert((tau.to_bits(), e.to_bits()), first_order_lag(t_s, &u, tau));
                }
            }
        }
        LagBank { lags }
    }
    fn get(&self, tau: f64, e: f64) -> &[f64] {
        &self.lags[&(tau.to_bits(), e.to_bits())]
    }
}

// ---- fitting one configuration ------------------------------------------------------------------

/// A linear configuration: lags (τ set, e) and the sensor rule.
#[derive(Debug, Clone)]
struct LinearConfig {
    taus: Vec<f64>,
    exponent: Option<f64>,
    sensors: Option<Sensors>,
    lambda: f64,
}

/// Columns of a linear configuration: the lags, then every temperature (as ΔT from row 0).
fn linear_columns<'b>(
    bank: &'b LagBank,
    temps: &'b [Vec<f64>],
    cfg: &LinearConfig,
) -> (Vec<&'b [f64]>, usize) {
    let mut cols: Vec<&[f64]> = Vec::new();
    if let Some(e) = cfg.exponent {
        for &tau in &cfg.taus {
            cols.push(bank.get(tau, e));
        }
    }
    let n_lag = cols.len();
    if cfg.sensors.is_some() {
        for t in temps {
            cols.push(t);
        }
    }
    (cols, n_lag)
}

/// The columns a configuration uses: the `n_lag` lags always, then the sensors — chosen by stepwise
/// BIC, or every one (ridge, and no sensors at all when there are none).
fn select_columns(g: &Gram, n_lag: usize, n_cols: usize, sensors: Option<Sensors>) -> Vec<usize> {
    match sensors {
        Some(Sensors::Stepwise) => {
            let forced: Vec<usize> = (0..n_lag).collect();
            let cand: Vec<usize> = (n_lag..n_cols).collect();
            let picked = stepwise_bic(g, &forced, &cand);
            forced.into_iter().chain(picked).collect()
        }
        _ => (0..n_cols).collect(),
    }
}

/// A linear configuration fitted on some rows.
struct LinearConfigFit {
    /// Prediction at every row of the record.
    pred: Vec<f64>,
    /// Columns used (indices into the configuration's columns).
    sel: Vec<usize>,
    /// The standardised normal equations.
    gram: Gram,
    /// Standardised coefficients of `sel`.
    beta: DVector<f64>,
}

/// Fits a linear configuration on `rows` and predicts every row of the record.
fn fit_linear_config(
    bank: &LagBank,
    temps: &[Vec<f64>],
    y: &[f64],
    rows: &[usize],
    cfg: &LinearConfig,
) -> Option<LinearConfigFit> {
    let (cols, n_lag) = linear_columns(bank, temps, cfg);
    let g = Gram::new(&cols, y, rows);
    let sel = select_columns(&g, n_lag, cols.len(), cfg.sensors);
    let lambda = if cfg.sensors == Some(Sensors::Ridge) {
        cfg.lambda
    } else {
        0.0
    };
    let (beta, _) = g.solve(&sel, lambda)?;
    let pred = (0..y.len())
        .map(|i| g.predict(&cols, &sel, &beta, i))
        .collect();
    Some(LinearConfigFit {
        pred,
        sel,
        gram: g,
        beta,
    })
}

/// The speed-driven fit on `rows`: grid start, then nonlinear least squares. Returns the prediction
/// at every row, the estimates `[g.., tau.., e, offset]` and the report.
fn fit_speed(
    rec: &ThermalRecord<'_>,
    bank: &LagBank,
    y: &[f64],
    rows: &[usize],
    n_tau: usize,
    opts: &StudyOptions,
) -> Result<(Vec<f64>, Vec<f64>, FitReport)> {
    let speed = rec.speed_rpm.ok_or_else(|| IdentifyError::MissingColumn {
        column: "speed_rpm".into(),
        reason: "the speed-driven models need the spindle speed per row".into(),
    })?;
    // grid start: the (τ set, e) whose linear fit has the smallest RSS
    type GridPoint = (f64, Vec<f64>, f64, DVector<f64>, Gram);
    let mut best: Option<GridPoint> = None;
    for taus in tau_sets(&opts.tau_grid_s, n_tau) {
        for &e in &opts.exponent_grid {
            let cols: Vec<&[f64]> = taus.iter().map(|&t| bank.get(t, e)).collect();
            let g = Gram::new(&cols, y, rows);
            let s: Vec<usize> = (0..cols.len()).collect();
            if let Some((beta, rss)) = g.solve(&s, 0.0) {
                if best.as_ref().is_none_or(|b| rss < b.0) {
                    best = Some((rss, taus.clone(), e, beta, g));
                }
            }
        }
    }
    let (_, taus, e, beta, g) = best.ok_or(IdentifyError::SolverState {
        what: "no grid point of the speed-driven model could be fitted",
    })?;
    let s: Vec<usize> = (0..n_tau).collect();
    let mut specs = Vec::new();
    for (j, b) in beta.iter().enumerate() {
        specs.push(ParamSpec::free(
            &format!("gain{}_um", j + 1),
            g.slope(j, *b),
        ));
    }
    for (j, &tau) in taus.iter().enumerate() {
        specs.push(ParamSpec::bounded(
            &format!("tau{}_s", j + 1),
            tau,
            30.0,
            1e6,
        ));
    }
    specs.push(ParamSpec::bounded("exponent", e, 0.25, 4.0));
    specs.push(ParamSpec::free("offset_um", g.intercept(&s, &beta)));
    let model = SpeedModel {
        t_s: rec.t_s,
        speed_rpm: speed,
        y,
        rows,
        n_tau,
    };
    let kind = format!("thermal_speed_{n_tau}tau");
    let fit = fit_nonlinear(model, &specs, &opts.nls, &kind, "um")?;
    let p: Vec<f64> = fit.theta.iter().copied().collect();
    let model = SpeedModel {
        t_s: rec.t_s,
        speed_rpm: speed,
        y,
        rows,
        n_tau,
    };
    Ok((model.predict_all(&p), p, fit.report))
}

fn zeroed_ss(y: &[f64], pred: &[f64], rows: &[usize]) -> f64 {
    let Some(&f) = rows.first() else { return 0.0 };
    rows.iter()
        .map(|&i| ((y[i] - y[f]) - (pred[i] - pred[f])).powi(2))
        .sum()
}

/// Studies one channel `y` of `rec` (module documentation).
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] / [`IdentifyError::NonFinite`] naming the column and row;
/// * [`IdentifyError::NonMonotoneTime`] when `t_s` does not strictly increase;
/// * [`IdentifyError::BadRange`] for a training or test range outside the record, empty, or
///   overlapping the other, or a training range too short for its folds;
/// * [`IdentifyError::MissingColumn`] when no structure can be fitted with the record's columns;
/// * [`IdentifyError::InvalidParameter`] for a negative speed or fewer than 2 folds.
///
/// # Examples
/// A synthetic record (the real one is `millcomp identify thermal` in docs/real-machines.md): a machine whose
/// drift is 3 µm per (krpm)² through a 1 h lag plus 1.5 µm/K of an ambient sensor; the chosen model
/// removes nearly all of the test drift.
/// ```
/// use millcomp_identify::targets::thermal_record::*;
/// let t: Vec<f64> = (0..1200).map(|i| i as f64 * 60.0).collect();
/// let n: Vec<f64> = t.iter().map(|&t| [1000.0, 0.0, 2000.0, 0.0, 3000.0, 0.0][(t / 12_000.0) as usize % 6]).collect();
/// let amb: Vec<f64> = t.iter().map(|&t| 20.0 + 2.0 * (t / 40_000.0).sin()).collect();
/// let noise: Vec<f64> = (0..1200).map(|i| ((i * 37 % 101) as f64 / 101.0 - 0.5) * 0.2).collect();
/// let lag = first_order_lag(&t, &n.iter().map(|n| (n / 1000.0f64).powi(2)).collect::<Vec<_>>(), 3600.0);
/// let y: Vec<f64> = (0..1200).map(|i| 3.0 * lag[i] + 1.5 * (amb[i] - 20.0) + noise[i]).collect();
/// let rec = ThermalRecord { t_s: &t, speed_rpm: Some(&n), temps_c: vec![("amb_C".into(), &amb)] };
/// let opts = StudyOptions::new(TimeRange::parse("--train", "0:50%").unwrap(),
///                              Some(TimeRange::parse("--test", "50%:end").unwrap()));
/// let s = study_channel(&rec, "drift_um", &y, &opts).unwrap();
/// assert!(s.chosen.model.starts_with("combined"), "{}", s.chosen.model);
/// assert!(s.test_metrics.unwrap().removed > 0.95);
/// ```
pub fn study_channel(
    rec: &ThermalRecord<'_>,
    channel: &str,
    y: &[f64],
    opts: &StudyOptions,
) -> Result<ChannelStudy> {
    let n = rec.t_s.len();
    validate::finite("t_s", rec.t_s)?;
    validate::strictly_increasing("t_s", rec.t_s)?;
    validate::same_len(channel, y, "t_s", n)?;
    validate::finite(channel, y)?;
    if let Some(s) = rec.speed_rpm {
        validate::same_len("speed_rpm", s, "t_s", n)?;
        validate::finite("speed_rpm", s)?;
        if let Some(i) = s.iter().position(|&v| v < 0.0) {
            return Err(IdentifyError::InvalidParameter {
                name: format!("speed_rpm, row {}", i + 1),
                value: s[i],
                allowed: ">= 0 rpm",
            });
        }
    }
    for (name, v) in &rec.temps_c {
        validate::same_len(name, v, "t_s", n)?;
        validate::finite(name, v)?;
    }
    if opts.folds < 2 {
        return Err(IdentifyError::InvalidParameter {
            name: "folds".into(),
            value: opts.folds as f64,
            allowed: ">= 2 (cross-validation needs a block to hold out)",
        });
    }
    let (train_w, train) = opts.train.resolve(rec.t_s)?;
    let test = match &opts.test {
        Some(r) => {
            let (w, rows) = r.resolve(rec.t_s)?;
            if rows.iter().any(|i| train.binary_search(i).is_ok()) {
                return Err(IdentifyError::BadRange {
                    flag: r.flag.clone(),
                    range: r.text.clone(),
                    message: format!(
                        "overlaps the training range {} ({} s to {} s): the test must be data the fit never saw",
                        opts.train.text, train_w.start_s, train_w.end_s
                    ),
                });
            }
            Some((w, rows))
        }
        None => None,
    };
    if train.len() < opts.folds * MIN_FOLD_ROWS {
        return Err(IdentifyError::BadRange {
            flag: opts.train.flag.clone(),
            range: opts.train.text.clone(),
            message: format!(
                "holds {} rows; {} cross-validation blocks need at least {} ({MIN_FOLD_ROWS} each)",
                train.len(),
                opts.folds,
                opts.folds * MIN_FOLD_ROWS
            ),
        });
    }

    let mut notes = Vec::new();
    let speed_ok = rec.speed_rpm.is_some_and(|s| s.iter().any(|&v| v > 0.0));
    if rec.speed_rpm.is_some() && !speed_ok {
        notes.push("the spindle never runs in this record: no speed-driven structure".into());
    }
    let temps: Vec<Vec<f64>> = rec
        .temps_c
        .iter()
        .map(|(_, v)| v.iter().map(|x| x - v[0]).collect())
        .collect();
    let structures: Vec<Structure> = opts
        .structures
        .iter()
        .copied()
        .filter(|s| {
            let ok = (s.n_tau == 0 || speed_ok) && (s.sensors.is_none() || !temps.is_empty());
            if !ok {
                notes.push(format!(
                    "{}: not tried ({})",
                    s.name(),
                    if s.n_tau > 0 && !speed_ok {
                        "no spindle speed"
                    } else {
                        "no temperatures"
                    }
                ));
            }
            ok
        })
        .collect();
    if structures.is_empty() {
        return Err(IdentifyError::MissingColumn {
            column: "speed_rpm or temp_c".into(),
            reason: "no thermal structure can be fitted: map the spindle speed and/or temperatures"
                .into(),
        });
    }
    let bank = LagBank::new(
        rec.t_s,
        rec.speed_rpm.filter(|_| speed_ok),
        &opts.tau_grid_s,
        &opts.exponent_grid,
    );
    let folds = blocked_folds(&train, opts.folds);
    let n_train = train.len() as f64;

    // ---- cross-validation of every structure over its grid
    let mut candidates: Vec<(CandidateScore, Structure, LinearConfig)> = Vec::new();
    for s in &structures {
        let mut best: Option<(CandidateScore, LinearConfig)> = None;
        let mut consider = |score: CandidateScore, cfg: LinearConfig| {
            if score.cv_rms_um.is_finite()
                && best
                    .as_ref()
                    .is_none_or(|(b, _)| score.cv_rms_um < b.cv_rms_um)
            {
                best = Some((score, cfg));
            }
        };
        if s.sensors.is_none() {
            let mut fold_ss = Vec::new();
            for f in &folds {
                let fit_rows = complement(&train, f);
                let ss = match fit_speed(rec, &bank, y, &fit_rows, s.n_tau, opts) {
                    Ok((pred, _, _)) => zeroed_ss(y, &pred, f),
                    Err(_) => f64::NAN,
                };
                fold_ss.push((ss, f.len()));
            }
            let total: f64 = fold_ss.iter().map(|x| x.0).sum();
            consider(
                CandidateScore {
                    model: s.name(),
                    cv_rms_um: (total / n_train).sqrt(),
                    fold_rms_um: fold_ss
                        .iter()
                        .map(|(ss, k)| (ss / *k as f64).sqrt())
                        .collect(),
                    taus_s: Vec::new(),
                    exponent: None,
                    lambda: None,
                },
                LinearConfig {
                    taus: Vec::new(),
                    exponent: None,
                    sensors: None,
                    lambda: 0.0,
                },
            );
        } else {
            let exps: Vec<Option<f64>> = if s.n_tau == 0 {
                vec![None]
            } else {
                opts.exponent_grid.iter().map(|&e| Some(e)).collect()
            };
            let lambdas: Vec<f64> = if s.sensors == Some(Sensors::Ridge) {
                opts.lambda_grid.clone()
            } else {
                vec![0.0]
            };
            for taus in tau_sets(&opts.tau_grid_s, s.n_tau) {
                for &e in &exps {
                    // per λ: SS per fold
                    let mut ss = vec![vec![0.0; folds.len()]; lambdas.len()];
                    for (fi, f) in folds.iter().enumerate() {
                        let fit_rows = complement(&train, f);
                        let base = LinearConfig {
                            taus: taus.clone(),
                            exponent: e,
                            sensors: s.sensors,
                            lambda: 0.0,
                        };
                        let (cols, n_lag) = linear_columns(&bank, &temps, &base);
                        let g = Gram::new(&cols, y, &fit_rows);
                        let sel = select_columns(&g, n_lag, cols.len(), s.sensors);
                        for (li, &lam) in lambdas.iter().enumerate() {
                            ss[li][fi] = match g.solve(&sel, lam) {
                                Some((beta, _)) => {
                                    let pred: Vec<f64> = f
                                        .iter()
                                        .map(|&i| g.predict(&cols, &sel, &beta, i))
                                        .collect();
                                    let (y0, p0) = (y[f[0]], pred[0]);
                                    f.iter()
                                        .zip(&pred)
                                        .map(|(&i, p)| ((y[i] - y0) - (p - p0)).powi(2))
                                        .sum()
                                }
                                None => f64::NAN,
                            };
                        }
                    }
                    for (li, &lam) in lambdas.iter().enumerate() {
                        let total: f64 = ss[li].iter().sum();
                        consider(
                            CandidateScore {
                                model: s.name(),
                                cv_rms_um: (total / n_train).sqrt(),
                                fold_rms_um: ss[li]
                                    .iter()
                                    .zip(&folds)
                                    .map(|(ss, f)| (ss / f.len() as f64).sqrt())
                                    .collect(),
                                taus_s: taus.clone(),
                                exponent: e,
                                lambda: (s.sensors == Some(Sensors::Ridge)).then_some(lam),
                            },
                            LinearConfig {
                                taus: taus.clone(),
                                exponent: e,
                                sensors: s.sensors,
                                lambda: lam,
                            },
                        );
                    }
                }
            }
        }
        match best {
            Some((score, cfg)) => candidates.push((score, *s, cfg)),
            None => notes.push(format!(
                "{}: no fold could be fitted (singular in every configuration)",
                s.name()
            )),
        }
    }
    candidates.sort_by(|a, b| a.0.cv_rms_um.total_cmp(&b.0.cv_rms_um));
    let Some((chosen_score, chosen_s, chosen_cfg)) = candidates.first().cloned() else {
        return Err(IdentifyError::SolverState {
            what: "no structure could be cross-validated",
        });
    };

    // ---- refit the chosen structure on every training row
    let names: Vec<String> = rec.temps_c.iter().map(|(n, _)| n.clone()).collect();
    let (chosen, prediction) = if chosen_s.sensors.is_none() {
        let (pred, p, mut report) = fit_speed(rec, &bank, y, &train, chosen_s.n_tau, opts)?;
        // Newey–West intervals: the residuals of a drift record are strongly autocorrelated
        if let Some(speed) = rec.speed_rpm {
            let model = SpeedModel {
                t_s: rec.t_s,
                speed_rpm: speed,
                y,
                rows: &train,
                n_tau: chosen_s.n_tau,
            };
            let theta = DVector::from_column_slice(&p);
            if let (Ok(jac), Ok(r)) = (model.jacobian(&theta), model.apply(&theta)) {
                let names: Vec<String> = report.covariance.names.clone();
                let nw = crate::hac::apply_residuals(&mut report, &names, &jac, &(-r), None);
                report.warnings.push(format!(
                    "residuals autocorrelated (lag-1 r = {:.3}): Newey–West intervals over {} lags on {:.0} effective degrees of freedom",
                    nw.r, nw.lags, nw.dof_eff
                ));
            }
        }
        let k = chosen_s.n_tau;
        let mut coefficients = BTreeMap::new();
        for (j, g) in p[..k].iter().enumerate() {
            coefficients.insert(format!("gain{}_um", j + 1), *g);
        }
        coefficients.insert("offset_um".into(), p[2 * k + 1]);
        (
            FittedModel {
                model: chosen_s.name(),
                taus_s: p[k..2 * k].to_vec(),
                exponent: Some(p[2 * k]),
                lambda: None,
                sensors: Vec::new(),
                coefficients,
                train_rms_um: rms_on(y, &pred, &train),
                report: Some(report),
            },
            pred,
        )
    } else {
        let LinearConfigFit {
            pred,
            sel,
            gram: g,
            beta,
        } = fit_linear_config(&bank, &temps, y, &train, &chosen_cfg).ok_or(
            IdentifyError::SolverState {
                what: "the chosen structure is singular on the training rows",
            },
        )?;
        let n_lag = chosen_cfg.taus.len() * usize::from(chosen_cfg.exponent.is_some());
        let col_name = |j: usize| {
            if j < n_lag {
                format!("gain{}_um", j + 1)
            } else {
                format!("m_{}_um_per_k", names[j - n_lag])
            }
        };
        let mut coefficients = BTreeMap::new();
        for (k, &j) in sel.iter().enumerate() {
            coefficients.insert(col_name(j), g.slope(j, beta[k]));
        }
        coefficients.insert("offset_um".into(), g.intercept(&sel, &beta));
        let sensors: Vec<String> = sel
            .iter()
            .filter(|&&j| j >= n_lag)
            .map(|&j| names[j - n_lag].clone())
            .collect();
        let report = if chosen_cfg.sensors == Some(Sensors::Stepwise) {
            let (cols, _) = linear_columns(&bank, &temps, &chosen_cfg);
            let picked: Vec<&[f64]> = sel.iter().map(|&j| cols[j]).collect();
            let pnames: Vec<String> = sel.iter().map(|&j| col_name(j)).collect();
            Some(hac_linear(
                &format!("thermal_{}", chosen_s.name().replace('-', "_")),
                &pnames,
                &picked,
                y,
                &train,
            )?)
        } else {
            None
        };
        (
            FittedModel {
                model: chosen_s.name(),
                taus_s: chosen_cfg.taus.clone(),
                exponent: chosen_cfg.exponent,
                lambda: (chosen_cfg.sensors == Some(Sensors::Ridge)).then_some(chosen_cfg.lambda),
                sensors,
                coefficients,
                train_rms_um: rms_on(y, &pred, &train),
                report,
            },
            pred,
        )
    };

    // ---- the baseline: plain least squares on every temperature
    let (baseline, baseline_prediction) = if temps.is_empty() {
        (None, Vec::new())
    } else {
        let cols: Vec<&[f64]> = temps.iter().map(Vec::as_slice).collect();
        let pnames: Vec<String> = names.iter().map(|s| format!("m_{s}_um_per_k")).collect();
        let report = hac_linear("thermal_plain_lsq", &pnames, &cols, y, &train)?;
        let pred: Vec<f64> = (0..n)
            .map(|i| {
                report.param("offset_um")
                    + pnames
                        .iter()
                        .zip(&cols)
                        .map(|(p, c)| report.param(p) * c[i])
                        .sum::<f64>()
            })
            .collect();
        let mut coefficients: BTreeMap<String, f64> = report.params.clone();
        coefficients.retain(|_, v| v.is_finite());
        (
            Some(FittedModel {
                model: "plain-lsq-all-temperatures".into(),
                taus_s: Vec::new(),
                exponent: None,
                lambda: None,
                sensors: names.clone(),
                coefficients,
                train_rms_um: rms_on(y, &pred, &train),
                report: Some(report),
            }),
            pred,
        )
    };

    let (test_w, test_metrics, baseline_test_metrics) = match &test {
        Some((w, rows)) => (
            Some(w.clone()),
            Some(zeroed_metrics(y, &prediction, rows)),
            baseline
                .as_ref()
                .map(|_| zeroed_metrics(y, &baseline_prediction, rows)),
        ),
        None => (None, None, None),
    };
    Ok(ChannelStudy {
        channel: channel.to_string(),
        train: train_w,
        test: test_w,
        folds: folds.len(),
        chosen_cv_rms_um: chosen_score.cv_rms_um,
        candidates: candidates.into_iter().map(|c| c.0).collect(),
        chosen,
        baseline,
        test_metrics,
        baseline_test_metrics,
        notes,
        measured_um: y.to_vec(),
        prediction_um: prediction,
        baseline_prediction_um: baseline_prediction,
    })
}

fn rms_on(y: &[f64], pred: &[f64], rows: &[usize]) -> f64 {
    (rows.iter().map(|&i| (y[i] - pred[i]).powi(2)).sum::<f64>() / rows.len().max(1) as f64).sqrt()
}

/// Least squares of `y` on `cols` (plus `offset_um`) over `rows`, with Newey–West intervals.
fn hac_linear(
    model: &str,
    names: &[String],
    cols: &[&[f64]],
    y: &[f64],
    rows: &[usize],
) -> Result<FitReport> {
    let p = cols.len() + 1;
    let design = DMatrix::from_fn(rows.len(), p, |r, c| {
        if c < cols.len() {
            cols[c][rows[r]]
        } else {
            1.0
        }
    });
    let mut all: Vec<String> = names.to_vec();
    all.push("offset_um".into());
    let yy: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
    let fit = fit_linear(&all, &design, &yy, None, LinearMethod::Qr, model, "um")?;
    let mut report = fit.report;
    let nw = crate::hac::apply(&mut report, &all, &design, &yy, &fit.theta, None);
    report.warnings.push(format!(
        "residuals autocorrelated (lag-1 r = {:.3}): Newey–West intervals over {} lags on {:.0} effective degrees of freedom",
        nw.r, nw.lags, nw.dof_eff
    ));
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobian_check::check_jacobian;

    #[test]
    fn speed_model_jacobian_matches_finite_differences() {
        let t: Vec<f64> = (0..80).map(|i| i as f64 * 120.0).collect();
        let n: Vec<f64> = (0..80)
            .map(|i| [1250.0, 0.0, 3750.0, 2500.0][i / 20])
            .collect();
        let y = vec![0.0; 80];
        let rows: Vec<usize> = (0..80).filter(|i| i % 3 != 0).collect();
        for (k, p) in [
            (1, vec![2.0, 1800.0, 1.6, 0.3]),
            (2, vec![2.0, -1.0, 900.0, 5400.0, 1.3, 0.3]),
        ] {
            let m = SpeedModel {
                t_s: &t,
                speed_rpm: &n,
                y: &y,
                rows: &rows,
                n_tau: k,
            };
            let c = check_jacobian(&m, &DVector::from_vec(p), 1e-6).unwrap();
            assert!(c.ok, "{k} lags: {c:?}");
        }
    }

    #[test]
    fn ranges_resolve_and_name_what_is_wrong() {
        let t: Vec<f64> = (0..101).map(|i| i as f64 * 10.0).collect();
        let r = TimeRange::parse("--train", "0:50%").unwrap();
        let (w, rows) = r.resolve(&t).unwrap();
        assert_eq!((w.rows, w.end_s), (50, 490.0));
        assert_eq!(rows[49], 49);
        let (w, rows) = TimeRange::parse("--test", "50%:end")
            .unwrap()
            .resolve(&t)
            .unwrap();
        assert_eq!((w.rows, w.start_s, rows[50]), (51, 500.0, 100));
        let e = TimeRange::parse("--train", "0:2000s")
            .unwrap()
            .resolve(&t)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--train 0:2000s")
                && e.contains("after the record's end")
                && e.contains("1000 s"),
            "{e}"
        );
        let e = TimeRange::parse("--test", "5h:6h")
            .unwrap()
            .resolve(&t)
            .unwrap_err();
        assert!(e.to_string().contains("outside the record"), "{e}");
        let e = TimeRange::parse("--test", "600:500")
            .unwrap()
            .resolve(&t)
            .unwrap_err();
        assert!(e.to_string().contains("not after the start"), "{e}");
    }

    #[test]
    fn overlapping_ranges_and_short_training_are_refused() {
        let t: Vec<f64> = (0..200).map(|i| i as f64).collect();
        let y: Vec<f64> = t.iter().map(|t| (t / 30.0).sin()).collect();
        let amb: Vec<f64> = t
            .iter()
            .map(|t| (t / 30.0).sin() + 0.01 * (t / 7.0).cos())
            .collect();
        let rec = ThermalRecord {
            t_s: &t,
            speed_rpm: None,
            temps_c: vec![("a_C".into(), &amb)],
        };
        let opts = StudyOptions::new(
            TimeRange::parse("--train", "0:120").unwrap(),
            Some(TimeRange::parse("--test", "100:end").unwrap()),
        );
        let e = study_channel(&rec, "d_um", &y, &opts)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--test 100:end") && e.contains("overlaps"),
            "{e}"
        );
        let opts = StudyOptions::new(TimeRange::parse("--train", "0:30").unwrap(), None);
        let e = study_channel(&rec, "d_um", &y, &opts)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cross-validation blocks"), "{e}");
        // no speed: the speed structures are not tried, and say so
        let opts = StudyOptions::new(TimeRange::parse("--train", "0:end").unwrap(), None);
        let s = study_channel(&rec, "d_um", &y, &opts).unwrap();
        assert!(
            s.notes
                .iter()
                .any(|n| n.starts_with("speed-1tau: not tried"))
        );
        assert!(s.chosen.model.starts_with("temperature"));
    }
}
