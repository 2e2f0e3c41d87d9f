//! `identify hysteresis`: the PZT stack's rate-independent hysteresis from a quasi-static voltage sweep
//! in air, as a Prandtl–Ishlinskii model (sim's [`PrandtlIshlinskii`]).
//!
//! The gauge reads the tip `y = Σᵢ wᵢ · Fᵣᵢ[v] + offset` with play operators `Fᵣ` of fixed thresholds
//! `rᵢ` (every play at rest at the sweep's first voltage): linear in the weights, so the fit is
//! [`fit_linear`] on the play paths as regressors. The model is invertible only with `w₀ > 0` and every
//! other weight ≥ 0 (each branch increasing): an operator whose weight comes out negative is dropped and
//! the fit repeated, and the report says which. The sweep must be slow against the stack's dynamics
//! (quasi-static) and reverse direction: without a reversal there is no loop to see.
//!
//! What the model does not have — creep, the truth's own loop shape — stays in the residuals, which are
//! then correlated along the sweep: the standard errors are optimistic and the report's residual
//! diagnostics say so.

use nalgebra::DMatrix;

use super::Identified;
use crate::error::{IdentifyError, Result};
use crate::linear::{LinearMethod, fit_linear};
use crate::validate;
use millcomp_sim::actuator::PrandtlIshlinskii;

/// A sweep: the drive voltage and the gauge reading at each sample.
#[derive(Debug, Clone, Copy)]
pub struct HysteresisData<'a> {
    /// Drive voltage, V.
    pub u_v: &'a [f64],
    /// Tip displacement read by the gauge, µm.
    pub y_um: &'a [f64],
}

/// Options of [`identify_hysteresis`].
#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisOptions {
    /// Play thresholds (V), ascending from 0 ([`quadratic_thresholds`] by default).
    pub thresholds_v: Vec<f64>,
}

impl Default for HysteresisOptions {
    /// 12 thresholds from 0 to 756 V, quadratically spaced ([`quadratic_thresholds`] over 900 V):
    /// fine steps for the small reversals of a controller, coarse ones for the major loop.
    fn default() -> Self {
        Self {
            thresholds_v: quadratic_thresholds(12, 900.0),
        }
    }
}

/// `n` thresholds `range_v · (i/n)²`, `i = 0..n` (the first 0).
///
/// ```
/// use millcomp_identify::targets::hysteresis::quadratic_thresholds;
/// assert_eq!(quadratic_thresholds(4, 800.0), vec![0.0, 50.0, 200.0, 450.0]);
/// ```
pub fn quadratic_thresholds(n: usize, range_v: f64) -> Vec<f64> {
    (0..n)
        .map(|i| range_v * (i as f64 / n as f64).powi(2))
        .collect()
}

/// The name of weight `i` (`w00_um_per_v`, …) and of its threshold, a fixed input (`r00_v`, …).
pub fn weight_name(i: usize) -> (String, String) {
    (format!("w{i:02}_um_per_v"), format!("r{i:02}_v"))
}

/// Fits the weights and the gauge offset (kind `hysteresis`).
///
/// # Errors
/// * [`IdentifyError::LengthMismatch`] when `y_um` is not as long as `u_v`;
/// * [`IdentifyError::NonFinite`] naming the column and row of a NaN or infinite value;
/// * [`IdentifyError::TooFewPoints`] for fewer rows than weights + 2;
/// * [`IdentifyError::ConstantInput`] when `u_v` does not vary;
/// * [`IdentifyError::InvalidParameter`] naming `u_v` for a sweep that never reverses, `thresholds_v`
///   for thresholds that do not start at 0 or do not increase, and `w00_um_per_v` when the linear
///   part comes out ≤ 0 (the gauge reads against the voltage: check signs and units).
///
/// # Examples
/// ```
/// use millcomp_identify::targets::hysteresis::*;
/// use millcomp_sim::actuator::PrandtlIshlinskii;
/// // a sweep 0 → 800 → 100 → 600 → 300 V in 2 V steps through a known operator, gauge offset 0.3 µm
/// let r = quadratic_thresholds(6, 900.0);
/// let w = [0.04, 0.002, 0.004, 0.0, 0.003, 0.002];
/// let mut truth = PrandtlIshlinskii::new(r.clone(), w.to_vec(), 0.0).unwrap();
/// let mut u = vec![0.0];
/// for (a, b) in [(0.0, 800.0), (800.0, 100.0), (100.0, 600.0), (600.0, 300.0)] {
///     let n = ((b - a) as f64 / 2.0).abs() as usize;
///     u.extend((1..=n).map(|k| a + (b - a) * k as f64 / n as f64));
/// }
/// let y: Vec<f64> = u.iter().map(|&v| truth.step(v) + 0.3).collect();
/// let fit = identify_hysteresis(
///     &HysteresisData { u_v: &u, y_um: &y },
///     &HysteresisOptions { thresholds_v: r },
/// ).unwrap();
/// assert!((fit.report.param("w00_um_per_v") - 0.04).abs() < 1e-9);
/// assert!((fit.report.param("w02_um_per_v") - 0.004).abs() < 1e-9);
/// assert!((fit.report.param("offset_um") - 0.3).abs() < 1e-9);
/// assert_eq!(fit.kind, "hysteresis");
/// ```
pub fn identify_hysteresis(
    data: &HysteresisData<'_>,
    opts: &HysteresisOptions,
) -> Result<Identified> {
    let n = data.u_v.len();
    validate::same_len("y_um", data.y_um, "u_v", n)?;
    validate::finite("u_v", data.u_v)?;
    validate::finite("y_um", data.y_um)?;
    let r = &opts.thresholds_v;
    if r.first() != Some(&0.0) || r.windows(2).any(|w| w[1] <= w[0] || !w[1].is_finite()) {
        return Err(IdentifyError::InvalidParameter {
            name: "thresholds_v".into(),
            value: r.first().copied().unwrap_or(f64::NAN),
            allowed: "0 = r0 < r1 < ... (finite)",
        });
    }
    validate::enough_points(n, r.len() + 1, "hysteresis")?;
    validate::not_constant("u_v", data.u_v, "the hysteresis weights")?;
    if !reverses(data.u_v) {
        return Err(IdentifyError::InvalidParameter {
            name: "u_v".into(),
            value: data.u_v[n - 1],
            allowed: "a sweep that reverses direction at least once (no loop without a reversal)",
        });
    }
    let plays = PrandtlIshlinskii::play_paths(r, data.u_v);
    // operators kept: all at first; the most negative weight (never the linear part) dropped per round
    let mut kept: Vec<usize> = (0..r.len()).collect();
    let mut dropped: Vec<f64> = Vec::new();
    loop {
        let p = kept.len() + 1;
        let design = DMatrix::from_fn(n, p, |i, j| {
            if j < kept.len() {
                plays[kept[j]][i]
            } else {
                1.0
            }
        });
        let mut names: Vec<String> = kept.iter().map(|&k| weight_name(k).0).collect();
        names.push("offset_um".into());
        let lin = fit_linear(
            &names,
            &design,
            data.y_um,
            None,
            LinearMethod::Qr,
            "hysteresis",
            "um",
        )?;
        if lin.theta[0].is_nan() || lin.theta[0] <= 0.0 {
            return Err(IdentifyError::InvalidParameter {
                name: "w00_um_per_v".into(),
                value: lin.theta[0],
                allowed: "> 0 (the tip must rise with the voltage: check signs and units)",
            });
        }
        let worst = (1..kept.len())
            .filter(|&j| lin.theta[j] < 0.0)
            .min_by(|&a, &b| lin.theta[a].total_cmp(&lin.theta[b]));
        if let Some(j) = worst {
            dropped.push(r[kept[j]]);
            kept.remove(j);
            continue;
        }
        let mut report = lin.report;
        for &k in &kept {
            report.fixed.insert(weight_name(k).1, r[k]);
        }
        if !dropped.is_empty() {
            dropped.sort_by(f64::total_cmp);
            report.warnings.push(format!(
                "plays at {} V dropped: their weights came out negative (a branch must rise with the \
                 voltage to be invertible)",
                dropped
                    .iter()
                    .map(|v| format!("{v:.0}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        return Ok(Identified::new(
            "hysteresis",
            report,
            Default::default(),
            Default::default(),
        ));
    }
}

/// Whether the path changes direction at least once.
fn reverses(u: &[f64]) -> bool {
    let mut dir = 0.0f64;
    for w in u.windows(2) {
        let d = (w[1] - w[0]).signum();
        if w[1] == w[0] {
            continue;
        }
        if dir != 0.0 && d != dir {
            return true;
        }
        dir = d;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sweep_without_a_reversal_or_with_a_falling_gauge_is_refused() {
        let u: Vec<f64> = (0..100).map(|k| k as f64 * 5.0).collect();
        let y: Vec<f64> = u.iter().map(|v| 0.05 * v).collect();
        let e = identify_hysteresis(
            &HysteresisData { u_v: &u, y_um: &y },
            &HysteresisOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("u_v"), "{e}");
        let mut u2 = u.clone();
        u2.extend(u.iter().rev());
        let y2: Vec<f64> = u2.iter().map(|v| -0.05 * v).collect();
        let e = identify_hysteresis(
            &HysteresisData {
                u_v: &u2,
                y_um: &y2,
            },
            &HysteresisOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("w00_um_per_v"), "{e}");
    }
}
