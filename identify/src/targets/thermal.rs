//! `identify thermal`: drift models of `002_…txt` from a drift time series.
//!
//! Both drift models are the physics crate's effects (`millcomp_sim::effects`), so `identify
//! thermal` and `diagnose` fit the same formulas and parameters:
//!
//! * [`ThermalModel::Exponential`] — first-order settling after an event at `t = 0` (coolant on,
//!   spindle start; 002 §7.1: +8.5 µm, settled after ~45 min):
//!   `drift_um(t) = offset_um + amplitude_um·(1 − exp(−t/tau_s))` — sim's `CoolantThermalDrift`
//!   (`amplitude_um`, `time_constant_s` = `tau_s`) with the coolant switched on at t = 0, plus an
//!   offset (test `exponential_is_sims_coolant_drift`; the name `tau_s` is kept for the saved models
//!   and the scipy golden).
//! * [`ThermalModel::LinearTemperature`] — the calibration `Δl = m·ΔT` (002 §7.6, eq. 2):
//!   `drift_um = offset_um + m_um_per_k·(temp_c − temp_ref_c)`, `temp_ref_c` = first temperature
//!   (held fixed and recorded).
//! * [`ThermalModel::SpeedDependent`] — sim's `SpindleThermalGrowth` (002 §7.6, Fig. 25:
//!   "temperature increase is small below 16 000 rpm … highly affected by the rotational speed"
//!   above; growth up to ~20 µm, Tab. 5, with a time constant of minutes), a first-order lag driven
//!   by the speed history (the speed of row k holds until row k+1, the spindle starts cold):
//!   `g(t₀) = 0`, `g_{k+1} = a_k + (g_k − a_k)·exp(−Δt_k/τ)`, `drift_um = offset_um + g`, with the
//!   steady state `a(n) = max_growth_um·((n − rpm_onset)/(rpm_max − rpm_onset))₊`; parameters
//!   `max_growth_um, rpm_onset, time_constant_s, offset_um`, `rpm_max` = 50 000 rpm held fixed
//!   (only the slope `max_growth/(rpm_max − rpm_onset)` and the onset are visible). The onset needs
//!   at least two distinct non-zero speeds; with one it is held at sim's 16 000 rpm and a warning
//!   says so (test `speed_model_is_sims_spindle_growth`).
//!
//! ```
//! use millcomp_identify::targets::thermal::speed_drift_um;
//! // 20 µm at 50 000 rpm, onset 16 000 rpm (sim's defaults): after 10 τ at 33 000 rpm the growth
//! // is 20·(17 000/34 000) = 10 µm
//! let t = [0.0, 6000.0];
//! let g = speed_drift_um(&t, &[33_000.0, 33_000.0], 20.0, 16_000.0, 600.0, 0.0);
//! assert!((g[1] - 10.0 * (1.0 - (-10.0f64).exp())).abs() < 1e-9);
//! ```

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_sim::effects::SpindleThermalGrowth;
use nalgebra::{DMatrix, DVector};

use super::Identified;
use crate::error::{IdentifyError, Result};
use crate::linear::{LinearMethod, fit_linear};
use crate::nonlinear::{NlsOptions, ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;
use std::collections::BTreeMap;

/// Which drift model to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ThermalModel {
    /// `offset + a(1 − e^{−t/τ})`.
    #[default]
    Exponential,
    /// `offset + m·(T − T_ref)` (needs `temp_c`).
    LinearTemperature,
    /// First-order lag to the speed-dependent steady state `a(n)` (needs `speed_rpm`).
    SpeedDependent,
}

impl std::str::FromStr for ThermalModel {
    type Err = crate::IdentifyError;

    /// The CLI's `--model` names (and Python's `model=`).
    ///
    /// ```
    /// use millcomp_identify::targets::thermal::ThermalModel;
    /// assert_eq!("speed-dependent".parse::<ThermalModel>().unwrap(), ThermalModel::SpeedDependent);
    /// assert!("linear".parse::<ThermalModel>().unwrap_err().to_string().contains("allowed exponential"));
    /// ```
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        match s {
            "exponential" => Ok(ThermalModel::Exponential),
            "linear-temperature" => Ok(ThermalModel::LinearTemperature),
            "speed-dependent" => Ok(ThermalModel::SpeedDependent),
            other => Err(crate::IdentifyError::UnknownModel {
                name: other.to_string(),
                allowed: "exponential, linear-temperature, speed-dependent".to_string(),
            }),
        }
    }
}

impl ThermalModel {
    /// Saved-model kind string.
    pub fn kind(&self) -> &'static str {
        match self {
            ThermalModel::Exponential => "thermal_exponential",
            ThermalModel::LinearTemperature => "thermal_linear_temp",
            ThermalModel::SpeedDependent => "thermal_speed",
        }
    }
}

/// Drift time series (columns `t_s`, `drift_um`, optional `speed_rpm`, `temp_c`).
#[derive(Debug, Clone, Copy)]
pub struct ThermalData<'a> {
    /// Time since the event (coolant on, spindle start), s; strictly increasing.
    pub t_s: &'a [f64],
    /// Measured drift (e.g. apparent tool elongation), µm.
    pub drift_um: &'a [f64],
    /// Spindle speed per row, rpm (speed-dependent model).
    pub speed_rpm: Option<&'a [f64]>,
    /// Spindle temperature per row, °C (linear-temperature model).
    pub temp_c: Option<&'a [f64]>,
}

/// Options shared by the targets.
#[derive(Debug, Clone, Default)]
pub struct CommonOptions {
    /// Nonlinear solver options.
    pub nls: NlsOptions,
}

/// Residual operator of the exponential model, parameters
/// `[amplitude_um, tau_s, offset_um]`, residual `model − drift_um`.
#[derive(Debug, Clone)]
pub struct ExponentialDrift<'a> {
    /// Times, s.
    pub t_s: &'a [f64],
    /// Data, µm.
    pub drift_um: &'a [f64],
}

/// `offset + a(1 − e^{−t/τ})` (the formula of [`ThermalModel::Exponential`]).
pub fn exponential_drift_um(t_s: f64, amplitude_um: f64, tau_s: f64, offset_um: f64) -> f64 {
    offset_um + amplitude_um * (1.0 - (-t_s / tau_s).exp())
}

impl Operator for ExponentialDrift<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        Ok(DVector::from_iterator(
            self.t_s.len(),
            self.t_s
                .iter()
                .zip(self.drift_um)
                .map(|(&t, &y)| exponential_drift_um(t, p[0], p[1], p[2]) - y),
        ))
    }
}

impl Jacobian for ExponentialDrift<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let (a, tau) = (p[0], p[1]);
        Ok(DMatrix::from_fn(self.t_s.len(), 3, |i, j| {
            let t = self.t_s[i];
            let e = (-t / tau).exp();
            match j {
                0 => 1.0 - e,
                1 => -a * e * t / (tau * tau),
                _ => 1.0,
            }
        }))
    }
}

impl ResidualModel for ExponentialDrift<'_> {}

/// Starting values `[a, τ, offset]` from the data: offset = first value, a = last − first, τ = time
/// to 63 % of the change (or a third of the record).
fn exponential_start(t: &[f64], y: &[f64]) -> [f64; 3] {
    let n = y.len();
    let k = (n / 10).max(1);
    let y0 = y[..k].iter().sum::<f64>() / k as f64;
    let y1 = y[n - k..].iter().sum::<f64>() / k as f64;
    let a = y1 - y0;
    let span = t[n - 1] - t[0];
    let target = y0 + 0.632 * a;
    let tau = t
        .iter()
        .zip(y)
        .find(|(_, y)| {
            if a >= 0.0 {
                **y >= target
            } else {
                **y <= target
            }
        })
        .map(|(t, _)| *t - t.min(0.0))
        .filter(|tau| *tau > 0.0)
        .unwrap_or(span / 3.0);
    let tau = if tau > 0.0 { tau } else { 1.0 };
    let a = if a != 0.0 { a } else { 1.0 };
    // offset: back-extrapolate the first value to t = 0.
    let off = y0 - a * (1.0 - (-t[0].max(0.0) / tau).exp());
    [a, tau, off]
}

fn check_common(data: &ThermalData<'_>) -> Result<()> {
    let n = data.t_s.len();
    validate::same_len("drift_um", data.drift_um, "t_s", n)?;
    validate::finite("t_s", data.t_s)?;
    validate::finite("drift_um", data.drift_um)?;
    validate::strictly_increasing("t_s", data.t_s)?;
    Ok(())
}

/// Fits a thermal drift model (see the module docs for the formulas).
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] when `drift_um` (or the `temp_c` / `speed_rpm` the model
///   reads) is not as long as `t_s`;
/// * [`IdentifyError::NonFinite`] naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::NonMonotoneTime`] when `t_s` does not strictly increase;
/// * [`IdentifyError::MissingColumn`] for `temp_c` (linear-temperature model) or `speed_rpm`
///   (speed-dependent model) when the model needs it and it is absent;
/// * [`IdentifyError::ConstantInput`] for a constant `drift_um` (exponential and speed-dependent
///   models), a constant `temp_c` (linear-temperature model), or a `speed_rpm` that is never > 0;
/// * [`IdentifyError::InvalidParameter`] for a negative `speed_rpm`;
/// * [`IdentifyError::TooFewPoints`] unless there are more rows than parameters (2 to 4);
/// * the errors of [`fit_nonlinear`] / [`fit_linear`].
///
/// # Examples
/// ```
/// use millcomp_identify::targets::thermal::*;
/// // 002 §7.1: coolant drift +8.5 µm settling in ~45 min → τ ≈ 15 min = 900 s.
/// let t: Vec<f64> = (0..60).map(|i| i as f64 * 65.0).collect();
/// let y: Vec<f64> = t.iter().enumerate()
///     .map(|(i, &t)| exponential_drift_um(t, 8.5, 900.0, 0.0) + 0.05 * ((i * 37 % 11) as f64 - 5.0) / 5.0)
///     .collect();
/// let fit = identify_thermal(&ThermalData { t_s: &t, drift_um: &y, speed_rpm: None, temp_c: None },
///                            ThermalModel::Exponential, &CommonOptions::default()).unwrap();
/// assert!((fit.report.param("amplitude_um") - 8.5).abs() < 0.1);
/// assert!((fit.report.param("tau_s") - 900.0).abs() < 30.0);
/// // the 95 % intervals cover the values the data were made with
/// let (a, tau) = (fit.report.ci95["amplitude_um"], fit.report.ci95["tau_s"]);
/// assert!(a[0] < 8.5 && 8.5 < a[1] && tau[0] < 900.0 && 900.0 < tau[1]);
/// assert!((fit.report.param("tau_s") - 896.86).abs() < 0.01);
/// assert_eq!(fit.kind, "thermal_exponential");
/// // the linear-temperature model needs the spindle temperature
/// let e = identify_thermal(&ThermalData { t_s: &t, drift_um: &y, speed_rpm: None, temp_c: None },
///                          ThermalModel::LinearTemperature, &CommonOptions::default());
/// assert!(matches!(e, Err(millcomp_identify::IdentifyError::MissingColumn { ref column, .. }) if column == "temp_c"));
/// ```
pub fn identify_thermal(
    data: &ThermalData<'_>,
    model: ThermalModel,
    opts: &CommonOptions,
) -> Result<Identified> {
    check_common(data)?;
    let kind = model.kind();
    match model {
        ThermalModel::Exponential => {
            validate::enough_points(data.t_s.len(), 3, kind)?;
            validate::not_constant("drift_um", data.drift_um, "amplitude_um and tau_s")?;
            let [a0, tau0, off0] = exponential_start(data.t_s, data.drift_um);
            let specs = [
                ParamSpec::free("amplitude_um", a0),
                ParamSpec::positive("tau_s", tau0),
                ParamSpec::free("offset_um", off0),
            ];
            let op = ExponentialDrift {
                t_s: data.t_s,
                drift_um: data.drift_um,
            };
            let mut fit = fit_nonlinear(op, &specs, &opts.nls, kind, "um")?;
            let span = data.t_s[data.t_s.len() - 1];
            let tau = fit.report.param("tau_s");
            if tau > span {
                fit.report.warnings.push(format!(
                    "tau_s = {tau:.4e} s exceeds the record (last t_s = {span:.4e} s): the steady state is extrapolated; record longer"
                ));
            }
            Ok(Identified::new(
                kind,
                fit.report,
                BTreeMap::new(),
                BTreeMap::new(),
            ))
        }
        ThermalModel::LinearTemperature => {
            let temp = data.temp_c.ok_or_else(|| IdentifyError::MissingColumn {
                column: "temp_c".into(),
                reason: "the linear-temperature model Δl = m·ΔT needs the spindle temperature"
                    .into(),
            })?;
            validate::same_len("temp_c", temp, "t_s", data.t_s.len())?;
            validate::finite("temp_c", temp)?;
            validate::not_constant("temp_c", temp, "m_um_per_k")?;
            let tref = temp[0];
            let n = temp.len();
            let x = DMatrix::from_fn(n, 2, |i, j| if j == 0 { temp[i] - tref } else { 1.0 });
            let names = ["m_um_per_k".to_string(), "offset_um".to_string()];
            let mut fit = fit_linear(
                &names,
                &x,
                data.drift_um,
                None,
                LinearMethod::Qr,
                kind,
                "um",
            )?;
            fit.report.fixed.insert("temp_ref_c".into(), tref);
            Ok(Identified::new(
                kind,
                fit.report,
                BTreeMap::new(),
                BTreeMap::new(),
            ))
        }
        ThermalModel::SpeedDependent => {
            let speed = data.speed_rpm.ok_or_else(|| IdentifyError::MissingColumn {
                column: "speed_rpm".into(),
                reason: "the speed-dependent thermal model needs the spindle speed per row".into(),
            })?;
            validate::same_len("speed_rpm", speed, "t_s", data.t_s.len())?;
            validate::finite("speed_rpm", speed)?;
            if let Some(i) = speed.iter().position(|&n| n < 0.0) {
                return Err(IdentifyError::InvalidParameter {
                    name: format!("speed_rpm, row {}", i + 1),
                    value: speed[i],
                    allowed: ">= 0 rpm",
                });
            }
            validate::not_constant(
                "drift_um",
                data.drift_um,
                "max_growth_um and time_constant_s",
            )?;
            let mut levels: Vec<f64> = speed.iter().copied().filter(|&n| n > 0.0).collect();
            levels.sort_by(f64::total_cmp);
            levels.dedup();
            let Some(&top) = levels.last() else {
                return Err(IdentifyError::ConstantInput {
                    column: "speed_rpm".into(),
                    value: 0.0,
                    parameters:
                        "max_growth_um, rpm_onset and time_constant_s (the spindle never runs)"
                            .into(),
                });
            };
            let fit_onset = levels.len() >= 2;
            // the onset must stay below the top speed (else nothing grows) and below rpm_max
            let onset_hi = top.min(RPM_MAX) * (1.0 - 1e-3);
            let onset0 = if DEFAULT_RPM_ONSET < onset_hi {
                DEFAULT_RPM_ONSET
            } else {
                0.5 * levels[0].min(onset_hi)
            };
            let op = SpeedDrift {
                t_s: data.t_s,
                speed_rpm: speed,
                drift_um: data.drift_um,
                fixed_onset: (!fit_onset).then_some(onset0),
            };
            let n_par = if fit_onset { 4 } else { 3 };
            validate::enough_points(data.t_s.len(), n_par, kind)?;
            // Start: offset = first value; max_growth from the largest excursion at the speed that
            // produced it through a(n) with the starting onset; τ = time to 63 % of that excursion
            // (a third of the record when not found).
            let y0 = data.drift_um[0];
            let (kpk, _) =
                data.drift_um
                    .iter()
                    .enumerate()
                    .fold((0, 0.0f64), |(kb, vb), (k, y)| {
                        if (y - y0).abs() > vb {
                            (k, (y - y0).abs())
                        } else {
                            (kb, vb)
                        }
                    });
            let peak = data.drift_um[kpk] - y0;
            let n_pk = (0..=kpk)
                .rev()
                .map(|k| speed[k])
                .find(|&n| n > onset0)
                .unwrap_or(top);
            let r_pk = steady_growth_um(n_pk, 1.0, onset0);
            let g0 = if peak != 0.0 && r_pk > 0.0 {
                peak / r_pk
            } else {
                1.0
            };
            let t0 = data.t_s[0];
            let span = data.t_s[data.t_s.len() - 1] - t0;
            let tau0 = data
                .drift_um
                .iter()
                .zip(data.t_s)
                .find(|(y, _)| ((*y - y0) / peak) >= 0.632)
                .map(|(_, t)| t - t0)
                .filter(|tau| *tau > 0.0)
                .unwrap_or(span / 3.0);
            let mut specs = vec![ParamSpec::free("max_growth_um", g0)];
            if fit_onset {
                specs.push(ParamSpec::bounded("rpm_onset", onset0, 0.0, onset_hi));
            }
            specs.push(ParamSpec::positive("time_constant_s", tau0));
            specs.push(ParamSpec::free("offset_um", y0));
            let mut fit = fit_nonlinear(op, &specs, &opts.nls, kind, "um")?;
            fit.report.fixed.insert("rpm_max".into(), RPM_MAX);
            if !fit_onset {
                fit.report.fixed.insert("rpm_onset".into(), onset0);
                fit.report.warnings.push(format!(
                    "only one non-zero speed ({} rpm): the growth onset cannot be identified and is held at {onset0} rpm; max_growth_um is the growth extrapolated to {RPM_MAX} rpm",
                    levels[0]
                ));
            }
            Ok(Identified::new(
                kind,
                fit.report,
                BTreeMap::new(),
                BTreeMap::new(),
            ))
        }
    }
}

/// Growth onset speed held when it cannot be identified (rpm): sim's `SpindleThermalGrowth`
/// default (002 §7.6, Fig. 25 knee).
pub const DEFAULT_RPM_ONSET: f64 = 16_000.0;
/// Speed of `max_growth_um` (rpm), held fixed: sim's `SpindleThermalGrowth` default (002 §5.2
/// spindle maximum).
pub const RPM_MAX: f64 = 50_000.0;

/// Steady-state spindle growth (µm) at `speed_rpm`: sim's
/// `SpindleThermalGrowth::steady_growth_um` with `rpm_max` = [`RPM_MAX`].
pub fn steady_growth_um(speed_rpm: f64, max_growth_um: f64, rpm_onset: f64) -> f64 {
    SpindleThermalGrowth {
        max_growth_um,
        rpm_onset,
        rpm_max: RPM_MAX,
        ..SpindleThermalGrowth::default()
    }
    .steady_growth_um(speed_rpm)
}

/// Drift of the speed-dependent model at the sample times (µm), see the module docs.
pub fn speed_drift_um(
    t_s: &[f64],
    speed_rpm: &[f64],
    max_growth_um: f64,
    rpm_onset: f64,
    time_constant_s: f64,
    offset_um: f64,
) -> Vec<f64> {
    let a: Vec<f64> = speed_rpm
        .iter()
        .map(|&n| steady_growth_um(n, max_growth_um, rpm_onset))
        .collect();
    super::thermal_record::first_order_lag(t_s, &a, time_constant_s)
        .into_iter()
        .map(|g| offset_um + g)
        .collect()
}

/// Residual operator of the speed-dependent model, parameters
/// `[max_growth_um, rpm_onset, time_constant_s, offset_um]` (`rpm_onset` omitted when fixed).
/// Jacobian by forward sensitivities of the recursion (exact away from the onset kink).
#[derive(Debug, Clone)]
pub struct SpeedDrift<'a> {
    /// Times, s.
    pub t_s: &'a [f64],
    /// Speeds, rpm (held from one row to the next).
    pub speed_rpm: &'a [f64],
    /// Data, µm.
    pub drift_um: &'a [f64],
    /// `Some(o)`: the onset is held at `o` rpm and not a parameter.
    pub fixed_onset: Option<f64>,
}

impl SpeedDrift<'_> {
    fn unpack(&self, p: &DVector<f64>) -> (f64, f64, f64, f64) {
        match self.fixed_onset {
            Some(o) => (p[0], o, p[1], p[2]),
            None => (p[0], p[1], p[2], p[3]),
        }
    }
}

impl Operator for SpeedDrift<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let (g, o, tau, off) = self.unpack(p);
        let m = speed_drift_um(self.t_s, self.speed_rpm, g, o, tau, off);
        Ok(DVector::from_iterator(
            m.len(),
            m.iter().zip(self.drift_um).map(|(m, y)| m - y),
        ))
    }
}

impl Jacobian for SpeedDrift<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let (gmax, o, tau, _) = self.unpack(p);
        let n = self.t_s.len();
        // sensitivities of g to (max_growth, onset, tau)
        let mut j = DMatrix::zeros(n, p.len());
        let (mut g, mut sg, mut so, mut st) = (0.0, 0.0, 0.0, 0.0);
        let (cg, co, ct) = match self.fixed_onset {
            Some(_) => (0, None, 1),
            None => (0, Some(1), 2),
        };
        for k in 0..n {
            j[(k, cg)] = sg;
            if let Some(co) = co {
                j[(k, co)] = so;
            }
            j[(k, ct)] = st;
            j[(k, p.len() - 1)] = 1.0;
            if k + 1 < n {
                let nk = self.speed_rpm[k];
                let span = RPM_MAX - o;
                let (a, da_dg, da_do) = if nk > o {
                    let r = (nk - o) / span;
                    (gmax * r, r, gmax * (nk - RPM_MAX) / (span * span))
                } else {
                    (0.0, 0.0, 0.0)
                };
                let dt = self.t_s[k + 1] - self.t_s[k];
                let phi = (-dt / tau).exp();
                let dphi_dtau = phi * dt / (tau * tau);
                sg = (1.0 - phi) * da_dg + phi * sg;
                so = (1.0 - phi) * da_do + phi * so;
                st = phi * st + (g - a) * dphi_dtau;
                g = a + (g - a) * phi;
            }
        }
        Ok(j)
    }
}

impl ResidualModel for SpeedDrift<'_> {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobian_check::check_jacobian;
    use millcomp_sim::effects::{CoolantThermalDrift, Effect, EffectContext};

    #[test]
    fn exponential_jacobian_matches_fd() {
        let t: Vec<f64> = (0..20).map(|i| i as f64 * 100.0).collect();
        let y = vec![0.0; 20];
        let op = ExponentialDrift {
            t_s: &t,
            drift_um: &y,
        };
        let c = check_jacobian(&op, &DVector::from_vec(vec![8.5, 900.0, 0.3]), 1e-6).unwrap();
        assert!(c.ok, "{c:?}");
    }

    #[test]
    fn speed_jacobian_matches_fd() {
        // warm-up at 30 000 rpm, step to 20 000, stop (002 §7.6 style speed history)
        let t: Vec<f64> = (0..60).map(|i| i as f64 * 30.0).collect();
        let n: Vec<f64> = (0..60)
            .map(|i| match i {
                0..=19 => 30_000.0,
                20..=39 => 20_000.0,
                _ => 0.0,
            })
            .collect();
        let y = vec![0.0; 60];
        let op = SpeedDrift {
            t_s: &t,
            speed_rpm: &n,
            drift_um: &y,
            fixed_onset: None,
        };
        let c = check_jacobian(
            &op,
            &DVector::from_vec(vec![20.0, 15_000.0, 300.0, 0.4]),
            1e-6,
        )
        .unwrap();
        assert!(c.ok, "{c:?}");
        let op = SpeedDrift {
            fixed_onset: Some(16_000.0),
            ..op
        };
        let c = check_jacobian(&op, &DVector::from_vec(vec![20.0, 300.0, 0.4]), 1e-6).unwrap();
        assert!(c.ok, "{c:?}");
    }

    /// The speed model is sim's `SpindleThermalGrowth` evaluated on the same speed history (and
    /// its defaults are the constants used here).
    #[test]
    fn speed_model_is_sims_spindle_growth() {
        let d = SpindleThermalGrowth::default();
        assert_eq!((d.rpm_onset, d.rpm_max), (DEFAULT_RPM_ONSET, RPM_MAX));
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 45.0).collect();
        let n: Vec<f64> = (0..50)
            .map(|i| [36_000.0, 24_000.0, 0.0, 30_000.0][i / 13])
            .collect();
        let e = SpindleThermalGrowth {
            max_growth_um: 17.0,
            rpm_onset: 14_000.0,
            time_constant_s: 420.0,
            ..d
        };
        let events: Vec<(f64, f64)> = t.iter().copied().zip(n.iter().copied()).collect();
        let ours = speed_drift_um(&t, &n, 17.0, 14_000.0, 420.0, 0.3);
        for (k, &tk) in t.iter().enumerate() {
            let ctx = EffectContext {
                t_s: tk,
                spindle_events: &events[..=k],
                ..EffectContext::default()
            };
            assert!(
                (ours[k] - 0.3 - e.depth_offset_um(&ctx)).abs() < 1e-12,
                "row {k}"
            );
        }
    }

    /// The exponential model is sim's `CoolantThermalDrift` with the coolant switched on at t = 0.
    #[test]
    fn exponential_is_sims_coolant_drift() {
        let e = CoolantThermalDrift {
            amplitude_um: 8.5,
            time_constant_s: 900.0,
        };
        for t in [0.0, 10.0, 900.0, 2700.0, 1e4] {
            let ctx = EffectContext {
                t_s: t,
                coolant_events: &[(0.0, true)],
                ..EffectContext::default()
            };
            let ours = exponential_drift_um(t, 8.5, 900.0, 0.0);
            assert!((ours - e.depth_offset_um(&ctx)).abs() < 1e-12, "t = {t}");
        }
    }

    #[test]
    fn errors_name_the_cause() {
        let t = [0.0, 1.0, 1.0, 3.0];
        let y = [0.0, 1.0, 2.0, 3.0];
        let d = ThermalData {
            t_s: &t,
            drift_um: &y,
            speed_rpm: None,
            temp_c: None,
        };
        let e =
            identify_thermal(&d, ThermalModel::Exponential, &CommonOptions::default()).unwrap_err();
        assert!(
            matches!(e, IdentifyError::NonMonotoneTime { row: 3, .. }),
            "{e}"
        );
        let t = [0.0, 1.0, 2.0, 3.0];
        let y = [2.0; 4];
        let d = ThermalData {
            t_s: &t,
            drift_um: &y,
            speed_rpm: None,
            temp_c: None,
        };
        let e =
            identify_thermal(&d, ThermalModel::Exponential, &CommonOptions::default()).unwrap_err();
        assert!(matches!(e, IdentifyError::ConstantInput { .. }), "{e}");
        let e = identify_thermal(
            &d,
            ThermalModel::LinearTemperature,
            &CommonOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("temp_c"), "{e}");
        let y = [0.0, 1.0, 2.0];
        let d = ThermalData {
            t_s: &t[..3],
            drift_um: &y,
            speed_rpm: None,
            temp_c: None,
        };
        let e =
            identify_thermal(&d, ThermalModel::Exponential, &CommonOptions::default()).unwrap_err();
        assert!(
            matches!(
                e,
                IdentifyError::TooFewPoints {
                    got: 3,
                    needed: 4,
                    ..
                }
            ),
            "{e}"
        );
    }
}
