//! The force channel: flute runout from the per-flute peak z-force asymmetry.
//!
//! Observation per force-trace row: `a = Fz,peak(flute 2) − Fz,peak(flute 1)` (N). Prediction: sim's
//! force model ([`BallEndForceModel::per_flute_peaks`], 720 samples per revolution as sim's
//! `peak_z_force_n`) at the measured depth (the depth actually cut, so depth effects need not be
//! known), the row's upfeed, speed and tilt, with tool runout `session runout + runout_um`.
//! Candidates on this channel: `flute_runout` only — every other registered effect shifts the depth
//! and so changes both flutes' forces alike, which cancels in the difference. Nominal model:
//! `runout_um = 0` (the session's tool runout); augmented: `runout_um` free in `[0, 50]` µm. The
//! nested F-test and BIC rule are those of the depth channel (one candidate: threshold = α).
//! Its Jacobian is a central finite difference ([`fd_jacobian`]): the peak over sampled angles has
//! no closed-form derivative.

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_identify::{NonlinearFit, ParamSpec, ResidualModel, fd_jacobian, fit_nonlinear};
use millcomp_sim::SimError;
use millcomp_sim::force::{BallEndForceModel, CutConditions};
use millcomp_sim::session::GroovePoint;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{DiagnoseError, Result};
use crate::measured::ForceTrace;
use crate::nested::{Decision, nested_test};
use crate::nominal::SessionModel;
use crate::{model, thresholds};

/// Samples per revolution for the per-flute peaks (as sim's `peak_z_force_n`).
pub const SAMPLES_PER_REV: usize = millcomp_sim::force::PEAK_SAMPLES_PER_REV;

/// Per-flute peak asymmetry model.
#[derive(Debug, Clone)]
pub struct AsymmetryModel {
    model: BallEndForceModel,
    conds: Vec<CutConditions>,
    y: Vec<f64>,
    base_runout_um: f64,
}

impl AsymmetryModel {
    /// Predicted asymmetry (N) per row with extra runout `extra_um`.
    ///
    /// # Errors
    /// sim's error when the force model cannot be evaluated at a row's conditions.
    pub fn predict(&self, extra_um: f64) -> std::result::Result<Vec<f64>, SimError> {
        let mut m = self.model.clone();
        m.tool.runout_um = (self.base_runout_um + extra_um).max(0.0);
        self.conds
            .iter()
            .map(|c| {
                let p = m.per_flute_peaks(c, SAMPLES_PER_REV)?;
                Ok(p[1][2] - p[0][2])
            })
            .collect()
    }
}

impl Operator for AsymmetryModel {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, theta: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let p = self
            .predict(theta[0])
            .map_err(|e| ArgminError::msg(e.to_string()))?;
        Ok(DVector::from_iterator(
            p.len(),
            p.iter().zip(&self.y).map(|(a, b)| a - b),
        ))
    }
}

impl Jacobian for AsymmetryModel {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, theta: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        fd_jacobian(|t| self.apply(t), theta)
    }
}

impl ResidualModel for AsymmetryModel {}

/// One accepted force-channel step (same meaning as the depth channel's, forces in N).
#[derive(Debug, Clone, Serialize)]
pub struct ForceStep {
    /// Effect name.
    pub effect: String,
    /// Nested F-test p-value.
    pub p_value: f64,
    /// RMS asymmetry residual before (N).
    pub rms_before_n: f64,
    /// RMS asymmetry residual after (N).
    pub rms_after_n: f64,
    /// Estimates.
    pub params: BTreeMap<String, f64>,
    /// 95 % intervals.
    pub ci95: BTreeMap<String, [f64; 2]>,
    /// Standard errors.
    pub std_err: BTreeMap<String, f64>,
    /// F statistic.
    pub f_statistic: f64,
    /// Numerator dof.
    pub df1: usize,
    /// Denominator dof.
    pub df2: usize,
    /// Significance threshold (α / candidates tried).
    pub threshold: f64,
    /// BIC of the nominal model.
    pub bic_before: f64,
    /// BIC with the effect.
    pub bic_after: f64,
    /// Fit warnings.
    pub warnings: Vec<String>,
}

/// What the force channel found.
#[derive(Debug, Clone, Serialize)]
pub struct ForceChannelReport {
    /// Force-trace file.
    pub source: String,
    /// Rows used.
    pub n_rows: usize,
    /// RMS of measured − nominal asymmetry (N).
    pub initial_rms_n: f64,
    /// RMS after the accepted steps (N).
    pub final_rms_n: f64,
    /// Accepted steps (at most one: `flute_runout`).
    pub steps: Vec<ForceStep>,
    /// The tested candidate even when it did not pass: p-value, F, ΔBIC.
    pub tested: Vec<Decision>,
    /// Notes.
    pub notes: Vec<String>,
}

/// Runs the force channel on `trace` (rows matched to the session's points), with the depths
/// actually cut taken from the `measured` points (checked against the session beforehand).
///
/// A fit that fails from every start is not an error: it is a note in the report.
///
/// # Errors
/// As [`ForceTrace::match_points`] ([`DiagnoseError::NonFinite`],
/// [`DiagnoseError::SessionMismatch`]); [`DiagnoseError::Session`] when sim cannot build the
/// session's force model or evaluate it at the measured conditions.
///
/// # Examples
/// ```
/// use millcomp_diagnose::{Measured, SessionModel, force_channel::diagnose_forces};
/// // the committed `flute_runout_force` session: 3 µm of runout hidden on top of the session's
/// // tool runout, with a per-flute peak z-force trace (000 §4: one flute cuts more)
/// let case = millcomp_synthetic::cases().into_iter().find(|c| c.name == "flute_runout_force").unwrap();
/// let data = millcomp_synthetic::generate(&case).unwrap();
/// let measured = Measured::new("flute_runout_force.csv", data.points)
///     .with_forces("flute_runout_force.forces.csv", data.forces.unwrap());
/// let sm = SessionModel::new(&data.session).unwrap();
/// measured.check_against(&sm).unwrap();
/// let trace = measured.forces.as_ref().unwrap();
/// let rep = diagnose_forces(&sm, &measured.points, trace, 0.01).unwrap();
/// assert_eq!((rep.n_rows, rep.steps.len()), (294, 1));
/// let step = &rep.steps[0];
/// assert_eq!(step.effect, "flute_runout");
/// let ci = step.ci95["runout_um"];
/// assert!(ci[0] < 3.0 && 3.0 < ci[1] && (step.params["runout_um"] - 3.0).abs() < 0.05);
/// // the flute-to-flute asymmetry residual drops from 0.74 N to 0.055 N
/// assert!((rep.initial_rms_n - 0.736).abs() < 1e-3 && (rep.final_rms_n - 0.0555).abs() < 1e-3);
/// ```
pub fn diagnose_forces(
    sm: &SessionModel,
    measured: &[GroovePoint],
    trace: &ForceTrace,
    alpha: f64,
) -> Result<ForceChannelReport> {
    let idx = trace.match_points(sm)?;
    let force_err = |source| DiagnoseError::Session {
        what: "force model",
        source,
    };
    let model = sm.session.force_model().map_err(force_err)?;
    let radius = model.tool.radius_um;
    let conds: Vec<CutConditions> = idx
        .iter()
        .map(|&i| {
            let p = &sm.points()[i];
            CutConditions {
                depth_um: measured[i].depth_meas_um.clamp(0.0, radius),
                upfeed_um: p.upfeed_um,
                speed_rpm: p.speed_rpm,
                tilt_deg: p.tilt_deg,
            }
        })
        .collect();
    let y: Vec<f64> = trace
        .rows
        .iter()
        .map(|r| r.fz_peak_flute2_n - r.fz_peak_flute1_n)
        .collect();
    let am = AsymmetryModel {
        base_runout_um: model.tool.runout_um,
        model,
        conds,
        y: y.clone(),
    };
    let n = y.len();
    let nominal = am.predict(0.0).map_err(force_err)?;
    let rss0: f64 = nominal.iter().zip(&y).map(|(p, m)| (p - m).powi(2)).sum();
    let rms = |rss: f64| (rss / n.max(1) as f64).sqrt();
    let mut rep = ForceChannelReport {
        source: trace.source.clone(),
        n_rows: n,
        initial_rms_n: rms(rss0),
        final_rms_n: rms(rss0),
        steps: Vec::new(),
        tested: Vec::new(),
        notes: Vec::new(),
    };
    if n < 1 + thresholds::MIN_RESIDUAL_DOF {
        rep.notes.push(format!(
            "flute_runout skipped: {n} force rows, the fit needs at least {}",
            1 + thresholds::MIN_RESIDUAL_DOF
        ));
        return Ok(rep);
    }
    let mut best: Option<NonlinearFit> = None;
    let mut best_rss = f64::INFINITY;
    for start in [0.5, 3.0, 10.0] {
        let spec = [ParamSpec::bounded(
            "flute_runout.runout_um",
            start,
            0.0,
            50.0,
        )];
        match fit_nonlinear(
            am.clone(),
            &spec,
            &model::nls_options(),
            "diagnose_force",
            "n",
        ) {
            Ok(f) => {
                let rss = f.report.rms_residual.value.powi(2) * n as f64;
                if rss < best_rss {
                    best_rss = rss;
                    best = Some(f);
                }
            }
            Err(e) => rep
                .notes
                .push(format!("flute_runout fit from {start} µm failed: {e}")),
        }
    }
    let Some(fit) = best else {
        rep.notes
            .push("flute_runout could not be fitted on the force channel".into());
        return Ok(rep);
    };
    let mut d = nested_test("flute_runout", n, 0, 1, rss0, best_rss, alpha, 1);
    d.identifiable = fit.report.rank == 1;
    d.significant = d.significant && d.identifiable;
    if d.significant {
        let r = &fit.report;
        let key = "flute_runout.runout_um";
        rep.steps.push(ForceStep {
            effect: "flute_runout".into(),
            p_value: d.p_value,
            rms_before_n: rms(rss0),
            rms_after_n: rms(best_rss),
            params: [("runout_um".to_string(), r.param(key))].into(),
            ci95: r
                .ci95
                .get(key)
                .map(|c| [("runout_um".to_string(), *c)].into())
                .unwrap_or_default(),
            std_err: [("runout_um".to_string(), r.se(key))].into(),
            f_statistic: d.f_statistic,
            df1: d.df1,
            df2: d.df2,
            threshold: d.threshold,
            bic_before: d.bic_before,
            bic_after: d.bic_after,
            warnings: r.warnings.clone(),
        });
        rep.final_rms_n = rms(best_rss);
    }
    rep.tested.push(d);
    Ok(rep)
}
