//! `identify feed-axis`: the reference-to-position behaviour of an NC feed axis from a servo trace
//! (`003_…txt` §2.3: "the delay time of the feed axis", 16 ms in Fig. 3).
//!
//! Data: the NC's trace at its position cycle — time `t_s` (equally spaced), the position reference
//! `reference_um` the NC sent in that cycle and the actual position `position_um` the encoder read at
//! its start. Model: a dead time `dead_time_s` followed by a first-order lag `lag_s` with unit gain (a
//! position loop has no steady-state error), the reference held over each cycle (zero-order hold), so a
//! dead time that is not a whole number of cycles is exact:
//!
//! ```text
//! p[i+1] = a p[i] + (1 − e^{−(T−θ)/τ}) r[i−n] + (e^{−(T−θ)/τ} − a) r[i−n−1],   a = e^{−T/τ},
//! T_d = n T + θ, 0 ≤ θ < T,
//! ```
//! started at the first measured position. A ramp's actual position then lags its reference by
//! `T_d + τ` (the *equivalent delay*, derived with its interval). The structure is a model: a real axis'
//! position loop is of higher order (the truth's is a P loop around a velocity loop), and the fit
//! says how well this one describes it in its residuals.

use std::collections::BTreeMap;

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};

use super::thermal::CommonOptions;
use super::{Identified, derive};
use crate::error::{IdentifyError, Result};
use crate::jacobian_check::fd_jacobian;
use crate::nonlinear::{ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;

/// A servo trace.
#[derive(Debug, Clone, Copy)]
pub struct FeedAxisData<'a> {
    /// Time (s), equally spaced (the position cycle).
    pub t_s: &'a [f64],
    /// Position reference sent in each cycle (µm).
    pub reference_um: &'a [f64],
    /// Actual position read at the start of each cycle (µm).
    pub position_um: &'a [f64],
}

/// Options of [`identify_feed_axis`].
#[derive(Debug, Clone, Default)]
pub struct FeedAxisOptions {
    /// Common options.
    pub common: CommonOptions,
}

/// The model's response to `reference` from `p0`, cycle `cycle_s`, parameters `[dead_time_s, lag_s]`:
/// the physics crate's [`dead_time_lag_response`](millcomp_sim::nc_axis::dead_time_lag_response).
pub use millcomp_sim::nc_axis::dead_time_lag_response as response;

/// Residual operator `[dead_time_s, lag_s] ↦ response − position`.
#[derive(Debug, Clone)]
pub struct FeedAxisResiduals<'a> {
    data: FeedAxisData<'a>,
    cycle_s: f64,
}

impl Operator for FeedAxisResiduals<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let y = response(
            self.data.reference_um,
            self.data.position_um[0],
            self.cycle_s,
            p[0],
            p[1],
        );
        Ok(DVector::from_iterator(
            y.len(),
            y.iter().zip(self.data.position_um).map(|(m, d)| m - d),
        ))
    }
}

impl Jacobian for FeedAxisResiduals<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        fd_jacobian(|q| self.apply(q), p)
    }
}

impl ResidualModel for FeedAxisResiduals<'_> {}

/// Fits the dead time and lag of a feed axis to a servo trace.
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`], [`IdentifyError::NonFinite`] naming the column and row;
/// * [`IdentifyError::NonMonotoneTime`] for a time that does not increase, and
///   [`IdentifyError::InvalidParameter`] (`t_s`) when it is not equally spaced (within 0.1 %);
/// * [`IdentifyError::ConstantInput`] when the reference does not move;
/// * [`IdentifyError::TooFewPoints`] below 4 rows.
///
/// # Examples
/// ```
/// use millcomp_identify::targets::feed_axis::*;
/// // a 50 µm step and back through 4 ms + 12 ms, read at 2 ms
/// let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.002).collect();
/// let r: Vec<f64> = (0..100).map(|i| if (10..60).contains(&i) { 50.0 } else { 0.0 }).collect();
/// let p = response(&r, 0.0, 0.002, 0.005, 0.012);
/// let fit = identify_feed_axis(&FeedAxisData { t_s: &t, reference_um: &r, position_um: &p },
///                              &FeedAxisOptions::default()).unwrap();
/// assert!((fit.report.param("dead_time_s") - 0.005).abs() < 1e-7);
/// assert!((fit.derived["equivalent_delay_s"].value - 0.017).abs() < 1e-7);
/// ```
pub fn identify_feed_axis(data: &FeedAxisData<'_>, opts: &FeedAxisOptions) -> Result<Identified> {
    let n = data.t_s.len();
    validate::same_len("reference_um", data.reference_um, "t_s", n)?;
    validate::same_len("position_um", data.position_um, "t_s", n)?;
    validate::finite("t_s", data.t_s)?;
    validate::finite("reference_um", data.reference_um)?;
    validate::finite("position_um", data.position_um)?;
    validate::enough_points(n, 2, "feed-axis")?;
    validate::strictly_increasing("t_s", data.t_s)?;
    validate::not_constant("reference_um", data.reference_um, "dead_time_s, lag_s")?;
    let cycle_s = (data.t_s[n - 1] - data.t_s[0]) / (n - 1) as f64;
    if let Some(i) =
        (1..n).find(|&i| ((data.t_s[i] - data.t_s[i - 1]) - cycle_s).abs() > 1e-3 * cycle_s)
    {
        return Err(IdentifyError::InvalidParameter {
            name: format!("t_s (row {}): spacing", i + 1),
            value: data.t_s[i] - data.t_s[i - 1],
            allowed: "equally spaced samples (the position cycle), within 0.1 %",
        });
    }
    let specs = [
        ParamSpec::bounded("dead_time_s", cycle_s, 0.0, 50.0 * cycle_s),
        ParamSpec::bounded("lag_s", 5.0 * cycle_s, 1e-3 * cycle_s, 500.0 * cycle_s),
    ];
    let op = FeedAxisResiduals {
        data: *data,
        cycle_s,
    };
    let mut report = fit_nonlinear(op, &specs, &opts.common.nls, "feed_axis", "um")?.report;
    report.fixed.insert("cycle_s".into(), cycle_s);
    let mut derived = BTreeMap::new();
    if let Some(d) = derive(
        &report,
        &["dead_time_s", "lag_s"],
        "T_d + tau (a ramp's lag)",
        |x| x[0] + x[1],
    ) {
        derived.insert("equivalent_delay_s".to_string(), d);
    }
    Ok(Identified::new(
        "feed_axis",
        report,
        derived,
        BTreeMap::new(),
    ))
}
