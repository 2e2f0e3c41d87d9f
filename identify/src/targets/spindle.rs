//! `identify spindle`: the PZT-actuated spindle plant (`000_…txt` §5.2.4) from step-response data
//! (columns `t_s, u_v, y_um`).
//!
//! Forward model: the physics crate's [`PztSpindle`] (`G(s) = K ωn² [p/(s+p)] e^{−sTd} /
//! (s² + 2ζωn s + ωn²)`, dead time as a Padé approximant) turned into state space
//! ([`PztSpindle::to_lti`]) and discretised by zero-order hold
//! ([`ContinuousLti::discretize_zoh`](millcomp_sim::lti::ContinuousLti::discretize_zoh)) at the
//! data's own sample intervals: the input `u_v[k]` is held over `[t_k, t_{k+1})`, the output
//! `y_um[k] = offset_um + C x[k]`, and the plant starts in equilibrium with `u_v[0]`. Non-uniform
//! sampling is simulated exactly (one discretisation per distinct interval, cached).
//!
//! Parameters: `gain_um_per_v`, `zeta`, `wn_rad_s`, optionally `pole_rad_s` and `dead_time_s`,
//! and `offset_um` (the capacitance gauge's zero, "an initial offset of 0.25 µm", §5.2.5).
//!
//! Jacobian: central finite differences of the whole simulation (2p simulations per Jacobian). An
//! analytic sensitivity would need derivatives of the matrix exponential with respect to the
//! transfer-function coefficients; the simulation is cheap (≈ 3 flops·states² per sample), the
//! central difference is accurate to ~1e-10 relative, and it is tested against an independent
//! forward-difference estimate in `tests/jacobians.rs`.

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_sim::lti::{DiscreteLti, step_figures};
use millcomp_sim::spindle::{DeadTimeModel, PztSpindle};
use nalgebra::{DMatrix, DVector};

use super::Identified;
use super::thermal::CommonOptions;
use crate::error::{IdentifyError, Result};
use crate::jacobian_check::fd_jacobian_within;
use crate::nonlinear::{ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;

/// Step-response data (columns `t_s`, `u_v`, `y_um`).
#[derive(Debug, Clone, Copy)]
pub struct SpindleData<'a> {
    /// Sample times, s (strictly increasing).
    pub t_s: &'a [f64],
    /// Amplifier command, V (held between samples).
    pub u_v: &'a [f64],
    /// Measured tool-tip displacement (capacitance gauge), µm.
    pub y_um: &'a [f64],
}

/// Model structure and options of [`identify_spindle`].
#[derive(Debug, Clone)]
pub struct SpindleOptions {
    /// Common options.
    pub common: CommonOptions,
    /// Fit the extra real pole `pole_rad_s` (the third pole of the thesis' root locus, Fig. 5-11).
    pub extra_pole: bool,
    /// Fit a dead time `dead_time_s`.
    pub dead_time: bool,
    /// Padé order of the dead time (`Pade1` or `Pade2`; `SampleDelay` is not differentiable and
    /// is rejected).
    pub dead_time_model: DeadTimeModel,
    /// Optional starting values by parameter name (others are estimated from the data).
    pub initial: BTreeMap<String, f64>,
}

impl Default for SpindleOptions {
    fn default() -> Self {
        SpindleOptions {
            common: CommonOptions::default(),
            extra_pole: false,
            dead_time: false,
            dead_time_model: DeadTimeModel::Pade2,
            initial: BTreeMap::new(),
        }
    }
}

/// Residual operator of the spindle fit (see the module docs). Parameter order:
/// `gain_um_per_v, zeta, wn_rad_s, [pole_rad_s], [dead_time_s], offset_um`.
pub struct SpindleResponse<'a> {
    u_v: &'a [f64],
    y_um: &'a [f64],
    extra_pole: bool,
    dead_time: bool,
    dead_time_model: DeadTimeModel,
    reps: Vec<f64>,
    class: Vec<usize>,
}

impl<'a> SpindleResponse<'a> {
    /// Builds the operator (data must already be validated).
    pub fn new(
        data: &SpindleData<'a>,
        extra_pole: bool,
        dead_time: bool,
        dead_time_model: DeadTimeModel,
    ) -> Self {
        let (reps, class) = interval_classes(data.t_s);
        SpindleResponse {
            u_v: data.u_v,
            y_um: data.y_um,
            extra_pole,
            dead_time,
            dead_time_model,
            reps,
            class,
        }
    }

    /// Parameter names in operator order.
    pub fn param_names(&self) -> Vec<String> {
        let mut v = vec!["gain_um_per_v", "zeta", "wn_rad_s"];
        if self.extra_pole {
            v.push("pole_rad_s");
        }
        if self.dead_time {
            v.push("dead_time_s");
        }
        v.push("offset_um");
        v.into_iter().map(String::from).collect()
    }

    /// Each parameter's bounds, in operator order: ζ in [0, 10] (the physics crate's range), a dead time
    /// in [0, 0.1] s, the offset free, the others > 0. The fit keeps to them and so does the
    /// finite-difference Jacobian ([`fd_jacobian_within`]): a parameter on its bound is differenced
    /// one-sidedly, never evaluated past it.
    pub fn param_bounds(&self) -> Vec<(f64, f64)> {
        self.param_names()
            .iter()
            .map(|name| match name.as_str() {
                "offset_um" => (f64::NEG_INFINITY, f64::INFINITY),
                "zeta" => (0.0, 10.0),
                "dead_time_s" => (0.0, 0.1),
                _ => (0.0, f64::INFINITY),
            })
            .collect()
    }

    /// The physics crate's spindle for a parameter vector, and the output offset.
    pub fn spindle(&self, p: &DVector<f64>) -> std::result::Result<(PztSpindle, f64), ArgminError> {
        let mut k = 3;
        let pole = if self.extra_pole {
            k += 1;
            Some(p[k - 1])
        } else {
            None
        };
        let td = if self.dead_time {
            k += 1;
            Some(p[k - 1])
        } else {
            None
        };
        let mut s = PztSpindle::new(p[0], p[1], p[2], pole, td)?;
        s.dead_time_model = self.dead_time_model;
        Ok((s, p[k]))
    }

    /// Simulated output (µm, including the offset) at the data's sample times.
    pub fn simulate(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let (s, offset) = self.spindle(p)?;
        simulate_classes(&s, &self.reps, &self.class, self.u_v, offset)
    }
}

/// Classes of sample intervals: intervals equal to within 1e-9 relative share one
/// discretisation (CSV round-off makes "uniform" intervals differ in the last bits; a 1e-9
/// relative change of `dt` changes the simulated output by far less than any gauge resolution).
/// Returns the representative interval of each class and the class of each interval.
fn interval_classes(t_s: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut reps: Vec<f64> = Vec::new();
    let mut class = Vec::with_capacity(t_s.len().saturating_sub(1));
    for w in t_s.windows(2) {
        let dt = w[1] - w[0];
        let c = match reps.iter().position(|&r| (dt - r).abs() <= 1e-9 * r) {
            Some(c) => c,
            None => {
                reps.push(dt);
                reps.len() - 1
            }
        };
        class.push(c);
    }
    (reps, class)
}

/// Simulates `spindle` (ZOH input held over each interval, equilibrium start with `u_v[0]`) at
/// sample times `t_s`; `y[k] = offset + C x(t_k) + D u_v[k]`.
pub fn simulate_spindle_um(
    spindle: &PztSpindle,
    t_s: &[f64],
    u_v: &[f64],
    offset_um: f64,
) -> std::result::Result<DVector<f64>, ArgminError> {
    let (reps, class) = interval_classes(t_s);
    simulate_classes(spindle, &reps, &class, u_v, offset_um)
}

fn simulate_classes(
    spindle: &PztSpindle,
    reps: &[f64],
    class: &[usize],
    u_v: &[f64],
    offset: f64,
) -> std::result::Result<DVector<f64>, ArgminError> {
    let n = u_v.len();
    if reps.is_empty() || class.len() + 1 != n {
        return Err(ArgminError::msg(
            "the spindle simulation needs at least two samples",
        ));
    }
    let lti = spindle.to_lti()?;
    let models: Vec<DiscreteLti> = reps
        .iter()
        .map(|&dt| lti.discretize_zoh(dt))
        .collect::<std::result::Result<_, _>>()?;
    let mut y = DVector::zeros(n);
    let mut x = models[0].steady_state(&DVector::from_element(1, u_v[0]))?;
    for k in 0..n {
        if k + 1 < n {
            y[k] = offset + models[class[k]].step_siso(&mut x, u_v[k]);
        } else {
            // Output only (the state after the last sample is not needed).
            let mut xx = x.clone();
            y[k] = offset + models[class[k - 1]].step_siso(&mut xx, u_v[k]);
        }
    }
    Ok(y)
}

impl Operator for SpindleResponse<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let y = self.simulate(p)?;
        Ok(y - DVector::from_column_slice(self.y_um))
    }
}

impl Jacobian for SpindleResponse<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    /// Central differences of the simulation (see the module docs), one-sided at a bound.
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        fd_jacobian_within(|q| self.simulate(q), p, &self.param_bounds())
    }
}

impl ResidualModel for SpindleResponse<'_> {}

/// Starting values from the data: gain = Δy/Δu between the first and last 10 % of the record;
/// ζ from the overshoot `ζ = −ln(OS)/√(π² + ln²OS)` and ωn = 1.8/t_r (0–90 % rise time) — the
/// thesis' own procedure (§5.2.4) — when a single step is found, else the physics crate's default
/// spindle; extra pole 5ωn; dead time one sample.
fn start(data: &SpindleData<'_>, opts: &SpindleOptions) -> BTreeMap<String, f64> {
    let n = data.t_s.len();
    let k = (n / 10).max(1);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let du = mean(&data.u_v[n - k..]) - mean(&data.u_v[..k]);
    let dy = mean(&data.y_um[n - k..]) - mean(&data.y_um[..k]);
    let def = PztSpindle::default();
    let gain = if du != 0.0 && dy / du > 0.0 {
        dy / du
    } else {
        def.gain_um_per_v
    };
    // Single step: find the first sample where u departs from u[0].
    let (mut zeta, mut wn) = (def.zeta, def.wn_rad_s);
    if let Some(k0) = data.u_v.iter().position(|&u| u != data.u_v[0]) {
        let tail = &data.y_um[k0..];
        let dt = (data.t_s[n - 1] - data.t_s[k0]) / (n - k0).max(2) as f64;
        let y0 = if k0 > 0 {
            data.y_um[k0 - 1]
        } else {
            data.y_um[0]
        };
        let rel: Vec<f64> = tail.iter().map(|y| y - y0).collect();
        if let Some(f) = step_figures(&rel, dt) {
            let os = f.overshoot_pct / 100.0;
            if os > 1e-3 {
                let l = os.ln();
                zeta = (-l / (std::f64::consts::PI.powi(2) + l * l).sqrt()).clamp(0.05, 2.0);
            } else {
                zeta = 0.9;
            }
            if f.rise_time_0_90_s > 0.0 {
                wn = 1.8 / f.rise_time_0_90_s;
            }
        }
    }
    let dt_med = {
        let mut d: Vec<f64> = data.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    let mut m = BTreeMap::new();
    m.insert("gain_um_per_v".to_string(), gain);
    m.insert("zeta".to_string(), zeta);
    m.insert("wn_rad_s".to_string(), wn);
    m.insert("pole_rad_s".to_string(), 5.0 * wn);
    m.insert("dead_time_s".to_string(), dt_med);
    m.insert("offset_um".to_string(), data.y_um[0] - gain * data.u_v[0]);
    for (k, v) in &opts.initial {
        m.insert(k.clone(), *v);
    }
    m
}

/// Identifies the spindle plant from step-response data.
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] when `u_v` or `y_um` is not as long as `t_s`;
/// * [`IdentifyError::NonFinite`] naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::NonMonotoneTime`] when `t_s` does not strictly increase;
/// * [`IdentifyError::TooFewPoints`] unless there are more rows than parameters (4 to 6);
/// * [`IdentifyError::ConstantInput`] for a constant `u_v` (no excitation: gain and dynamics
///   unidentifiable) or a constant `y_um` (no response);
/// * [`IdentifyError::InvalidParameter`] (`dead_time_model`) for a dead time with
///   [`DeadTimeModel::SampleDelay`] (not differentiable in `dead_time_s`);
/// * the errors of [`fit_nonlinear`]: e.g. [`IdentifyError::InitialOutsideBounds`] for a start in
///   `opts.initial` outside its bounds (ζ in (0, 10), dead time in (0, 0.1) s, the others > 0).
///
/// # Examples
/// ```
/// use millcomp_identify::targets::spindle::*;
/// use millcomp_sim::spindle::PztSpindle;
/// // the thesis' plant (000 §5.2.4: ζ = 0.46, ωn = 1302 rad/s, 0.05 µm/V) answering a 10 V step,
/// // sampled at 50 kHz for 6 ms, with the gauge's 0.25 µm initial offset (§5.2.5) and a ±4 nm
/// // deterministic perturbation
/// let plant = PztSpindle::new(0.05, 0.46, 1302.0, None, None).unwrap();
/// let t: Vec<f64> = (0..300).map(|k| k as f64 * 2e-5).collect();
/// let u: Vec<f64> = (0..300).map(|k| if k >= 20 { 10.0 } else { 0.0 }).collect();
/// let y: Vec<f64> = simulate_spindle_um(&plant, &t, &u, 0.25).unwrap().iter().enumerate()
///     .map(|(i, y)| y + 0.002 * ((i * 7 % 5) as f64 - 2.0))
///     .collect();
/// let fit = identify_spindle(&SpindleData { t_s: &t, u_v: &u, y_um: &y }, &SpindleOptions::default()).unwrap();
/// let r = &fit.report;
/// assert_eq!(fit.kind, "spindle");
/// // every parameter within 2 standard errors of the plant that made the data
/// for (name, truth) in [("gain_um_per_v", 0.05), ("zeta", 0.46), ("wn_rad_s", 1302.0), ("offset_um", 0.25)] {
///     assert!((r.param(name) - truth).abs() < 2.0 * r.se(name), "{name}");
/// }
/// assert!((r.param("zeta") - 0.4601).abs() < 1e-4 && (r.param("wn_rad_s") - 1302.1).abs() < 0.1);
///
/// let flat = vec![10.0; 300];
/// let e = identify_spindle(&SpindleData { t_s: &t, u_v: &flat, y_um: &y }, &SpindleOptions::default());
/// assert!(matches!(e, Err(millcomp_identify::IdentifyError::ConstantInput { ref column, .. }) if column == "u_v"));
/// ```
pub fn identify_spindle(data: &SpindleData<'_>, opts: &SpindleOptions) -> Result<Identified> {
    let n = data.t_s.len();
    validate::same_len("u_v", data.u_v, "t_s", n)?;
    validate::same_len("y_um", data.y_um, "t_s", n)?;
    validate::finite("t_s", data.t_s)?;
    validate::finite("u_v", data.u_v)?;
    validate::finite("y_um", data.y_um)?;
    validate::strictly_increasing("t_s", data.t_s)?;
    let probe = SpindleResponse::new(data, opts.extra_pole, opts.dead_time, opts.dead_time_model);
    let names = probe.param_names();
    validate::enough_points(n, names.len(), "spindle")?;
    validate::not_constant(
        "u_v",
        data.u_v,
        "gain_um_per_v, zeta and wn_rad_s (no excitation)",
    )?;
    validate::not_constant(
        "y_um",
        data.y_um,
        "gain_um_per_v, zeta and wn_rad_s (no response)",
    )?;
    if opts.dead_time && opts.dead_time_model == DeadTimeModel::SampleDelay {
        return Err(IdentifyError::InvalidParameter {
            name: "dead_time_model".into(),
            value: f64::NAN,
            allowed: "pade1 or pade2 (a whole-sample delay is not differentiable in dead_time_s)",
        });
    }
    let s0 = start(data, opts);
    let specs: Vec<ParamSpec> = names
        .iter()
        .zip(probe.param_bounds())
        .map(|(name, (lo, hi))| ParamSpec::bounded(name, s0[name.as_str()], lo, hi))
        .collect();
    let mut warnings = Vec::new();
    if data.u_v.iter().any(|&u| u < 0.0) {
        warnings.push(
            "u_v has negative values: the amplifier (0..1000 V) would clamp them; the fit assumes the plant saw u_v as given"
                .to_string(),
        );
    }
    let fit = fit_nonlinear(probe, &specs, &opts.common.nls, "spindle", "um")?;
    let mut report = fit.report;
    report.warnings.extend(warnings);
    if opts.dead_time {
        report.fixed.insert(
            "dead_time_pade_order".into(),
            match opts.dead_time_model {
                DeadTimeModel::Pade1 => 1.0,
                DeadTimeModel::Pade2 => 2.0,
                DeadTimeModel::SampleDelay => 0.0,
            },
        );
    }
    Ok(Identified::new(
        "spindle",
        report,
        BTreeMap::new(),
        BTreeMap::new(),
    ))
}
