//! `identify flutes`: the peak force of each flute from a raw force record at a known spindle speed,
//! and whether the flutes differ (flute runout: one flute cuts more, `000_…txt` §4).
//!
//! The record is cut into tooth periods of `P = f_s·60/(n·z)` samples (`f_s` the sample rate, `n` the
//! speed, `z` the flutes). The periods are placed so that their boundaries fall where the force is
//! lowest (the phase in `[0, P)` whose boundary samples have the smallest mean force): the peak of a
//! tooth is then inside its period. Period k belongs to flute `k mod z` (which flute is "1" is not
//! known without a once-per-revolution mark: the numbering is relative). For each flute: its peaks,
//! their mean and standard deviation. The asymmetry is `(largest − smallest flute mean) / mean of the
//! flute means`, and a one-way ANOVA F-test (flute as the factor, the tooth peaks as replicates) says
//! whether the flutes differ by more than tooth-to-tooth scatter; `flute_runout` is named when its
//! p-value is below `alpha`. A short record has few teeth per flute, so the test has little power:
//! the report gives the counts.
//!
//! The tooth period is checked against the record: the autocorrelation's highest peak between 0.5·P
//! and 1.5·P gives the measured period. Unless it is within 5 % of P with an autocorrelation ≥ 0.5
//! (a record at another speed, or one whose force is mostly noise, fails), the record does not show
//! its teeth and nothing is named, whatever the F-test says.
//!
//! ```
//! use millcomp_identify::targets::flutes::flute_peaks;
//! // 3 flutes at 10 400 rpm sampled at 50 kHz (96.15 samples per tooth), flute 2 cuts 20 % more
//! let p = 50_000.0 * 60.0 / (10_400.0 * 3.0);
//! let f: Vec<f64> = (0..2000).map(|i| {
//!     let tooth = (i as f64 / p).floor() as usize;
//!     let ph = (i as f64 / p).fract();
//!     let amp = if tooth % 3 == 1 { 60.0 } else { 50.0 };
//!     amp * (std::f64::consts::PI * ph).sin().powi(2)
//! }).collect();
//! let r = flute_peaks("force_x_N", &f, 50_000.0, 10_400.0, 3, 0.01).unwrap();
//! assert!((r.tooth_period_samples - 96.15).abs() < 0.01);
//! assert!((r.asymmetry - 10.0 / (160.0 / 3.0)).abs() < 0.02, "{}", r.asymmetry);
//! assert_eq!(r.named, "flute_runout");
//! ```

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use crate::error::{IdentifyError, Result};
use crate::validate;

/// One flute's peaks.
#[derive(Debug, Clone, Serialize)]
pub struct FlutePeaks {
    /// Flute number (1-based, relative: see the module documentation).
    pub flute: usize,
    /// The peak of each of its teeth in the record (N).
    pub peaks_n: Vec<f64>,
    /// Their mean (N).
    pub mean_n: f64,
    /// Their sample standard deviation (N; NaN with one tooth).
    pub sd_n: f64,
}

/// Per-flute peaks of one force channel.
#[derive(Debug, Clone, Serialize)]
pub struct FluteReport {
    /// The channel, as the file names it.
    pub channel: String,
    /// Expected tooth period (samples).
    pub tooth_period_samples: f64,
    /// Measured period: the autocorrelation's highest peak in [0.5, 1.5] tooth periods (samples).
    pub measured_period_samples: f64,
    /// Autocorrelation at the measured period (near 1 for a clean periodic cut).
    pub period_autocorrelation: f64,
    /// Whether the record shows the tooth period: measured within 5 % (at least 2 samples) of the
    /// expected one with an autocorrelation ≥ 0.5. Without it the teeth cannot be told apart and
    /// nothing is named.
    pub period_confirmed: bool,
    /// Whole tooth periods in the record.
    pub teeth: usize,
    /// Each flute.
    pub flutes: Vec<FlutePeaks>,
    /// `(max − min)/mean` of the flute means.
    pub asymmetry: f64,
    /// One-way ANOVA F statistic (flutes as the factor).
    pub f_statistic: f64,
    /// Its degrees of freedom.
    pub df: [usize; 2],
    /// Its p-value.
    pub p_value: f64,
    /// Significance level used.
    pub alpha: f64,
    /// `flute_runout` when the period is confirmed and `p_value < alpha`, else `none`.
    pub named: String,
}

/// Per-flute peaks of `force` (module documentation).
///
/// # Errors
/// [`IdentifyError::NonFinite`] naming the channel and row; [`IdentifyError::InvalidParameter`] for a
/// non-positive sample rate, speed or flute count, or `alpha` outside (0, 1);
/// [`IdentifyError::TooFewPoints`] when the record holds fewer than two teeth per flute.
pub fn flute_peaks(
    channel: &str,
    force: &[f64],
    sample_rate_hz: f64,
    speed_rpm: f64,
    flutes: usize,
    alpha: f64,
) -> Result<FluteReport> {
    validate::finite(channel, force)?;
    for (name, v, ok) in [
        ("sample_rate_hz", sample_rate_hz, sample_rate_hz > 0.0),
        ("speed_rpm", speed_rpm, speed_rpm > 0.0),
        ("flutes", flutes as f64, flutes >= 2),
        ("alpha", alpha, alpha > 0.0 && alpha < 1.0),
    ] {
        if !ok || !v.is_finite() {
            return Err(IdentifyError::InvalidParameter {
                name: name.into(),
                value: v,
                allowed: "> 0 (flutes >= 2, 0 < alpha < 1)",
            });
        }
    }
    let p = sample_rate_hz * 60.0 / (speed_rpm * flutes as f64);
    let n = force.len();
    let teeth = if p > 0.0 {
        (n as f64 / p).floor() as usize
    } else {
        0
    };
    if teeth < 2 * flutes || p < 4.0 {
        return Err(IdentifyError::TooFewPoints {
            got: n,
            n_params: flutes,
            needed: (2.0 * flutes as f64 * p).ceil() as usize,
            what: format!(
                "per-flute peaks of `{channel}`: two tooth periods of {p:.2} samples per flute"
            ),
        });
    }
    // the phase whose boundaries sit at the lowest force
    let at = |x: f64| force[(x.round() as usize).min(n - 1)];
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..p.ceil() as usize {
        let phi = k as f64;
        let mut m = 0;
        let mut s = 0.0;
        let mut b = phi;
        while b < n as f64 {
            s += at(b);
            m += 1;
            b += p;
        }
        let mean = s / m.max(1) as f64;
        if mean < best.0 {
            best = (mean, phi);
        }
    }
    let phi = best.1;
    let whole = ((n as f64 - phi) / p).floor() as usize;
    let mut per: Vec<Vec<f64>> = vec![Vec::new(); flutes];
    for k in 0..whole {
        let a = (phi + k as f64 * p).round() as usize;
        let b = ((phi + (k + 1) as f64 * p).round() as usize).min(n);
        if b > a {
            let peak = force[a..b]
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            per[k % flutes].push(peak);
        }
    }
    let stats = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
        let sd = if v.len() > 1 {
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        } else {
            f64::NAN
        };
        (m, sd)
    };
    let flutes_out: Vec<FlutePeaks> = per
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (m, sd) = stats(v);
            FlutePeaks {
                flute: i + 1,
                peaks_n: v.clone(),
                mean_n: m,
                sd_n: sd,
            }
        })
        .collect();
    let means: Vec<f64> = flutes_out.iter().map(|f| f.mean_n).collect();
    let grand_mean = means.iter().sum::<f64>() / means.len() as f64;
    let (lo, hi) = means
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| {
            (a.min(m), b.max(m))
        });
    // one-way ANOVA
    let all: Vec<f64> = per.iter().flatten().copied().collect();
    let overall = all.iter().sum::<f64>() / all.len() as f64;
    let ssb: f64 = per
        .iter()
        .zip(&means)
        .map(|(v, m)| v.len() as f64 * (m - overall).powi(2))
        .sum();
    let ssw: f64 = per
        .iter()
        .zip(&means)
        .map(|(v, m)| v.iter().map(|x| (x - m).powi(2)).sum::<f64>())
        .sum();
    let (df1, df2) = (flutes - 1, all.len() - flutes);
    let f_stat = if ssw > 0.0 {
        (ssb / df1 as f64) / (ssw / df2 as f64)
    } else {
        f64::INFINITY
    };
    let p_value = match FisherSnedecor::new(df1 as f64, df2.max(1) as f64) {
        Ok(d) if f_stat.is_finite() => d.sf(f_stat),
        Ok(_) => 0.0,
        Err(_) => f64::NAN,
    };
    // the record's own period: highest normalised autocorrelation in [0.5P, 1.5P]
    let mean = force.iter().sum::<f64>() / n as f64;
    let c: Vec<f64> = force.iter().map(|x| x - mean).collect();
    let c0: f64 = c.iter().map(|x| x * x).sum();
    let (mut best_lag, mut best_r) = (0usize, f64::NEG_INFINITY);
    for lag in (0.5 * p).floor() as usize..=((1.5 * p).ceil() as usize).min(n - 1) {
        let r: f64 = (0..n - lag).map(|i| c[i] * c[i + lag]).sum::<f64>() / c0.max(1e-300);
        if r > best_r {
            best_r = r;
            best_lag = lag;
        }
    }
    let period_confirmed = (best_lag as f64 - p).abs() <= (0.05 * p).max(2.0) && best_r >= 0.5;
    Ok(FluteReport {
        channel: channel.to_string(),
        tooth_period_samples: p,
        measured_period_samples: best_lag as f64,
        period_autocorrelation: best_r,
        period_confirmed,
        teeth: all.len(),
        flutes: flutes_out,
        asymmetry: (hi - lo) / grand_mean,
        f_statistic: f_stat,
        df: [df1, df2],
        p_value,
        alpha,
        named: if period_confirmed && p_value < alpha {
            "flute_runout".into()
        } else {
            "none".into()
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_flutes_with_noise_are_not_named_and_short_records_are_refused() {
        let p = 50_000.0 * 60.0 / (10_400.0 * 3.0);
        let f: Vec<f64> = (0..2000)
            .map(|i| {
                let ph = (i as f64 / p).fract();
                50.0 * (std::f64::consts::PI * ph).sin().powi(2)
                    + 2.0 * (((i * 7919) % 97) as f64 / 97.0 - 0.5)
            })
            .collect();
        let r = flute_peaks("f", &f, 50_000.0, 10_400.0, 3, 0.01).unwrap();
        assert_eq!(r.named, "none");
        assert!(r.asymmetry < 0.05 && (r.measured_period_samples - 96.0).abs() <= 1.0);
        let e = flute_peaks("f", &f[..300], 50_000.0, 10_400.0, 3, 0.01).unwrap_err();
        assert!(matches!(e, IdentifyError::TooFewPoints { .. }), "{e}");
        let mut bad = f.clone();
        bad[17] = f64::NAN;
        let e = flute_peaks("force_x_N", &bad, 50_000.0, 10_400.0, 3, 0.01).unwrap_err();
        assert!(e.to_string().contains("force_x_N") && e.to_string().contains("row 18"));
    }
}
