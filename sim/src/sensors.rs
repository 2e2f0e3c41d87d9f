//! Sensors (`000_…txt` §3.2, §5.2.2, §7.3; `004_…txt` Table 1).
//!
//! * [`ForceSensor`]: Kistler 9251 + 5004 charge amplifier, "sensitivity of 0.04 N" (§5.2.2) — taken as the
//!   white-noise standard deviation *and* the quantisation step of the force channel; optional, seeded.
//!   The thin-wall sensor of `004` has 0.001 N resolution.
//! * [`CapacitanceGauge`]: Lion Precision RD20-1, 50 µm range, 2.5 µm/V (§5.2.2); the reading saturates at
//!   the ends of its range.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_finite, check_nonneg, check_positive};

/// Seeded Gaussian noise source (`None` sigma → exact).
#[derive(Debug, Clone)]
pub struct NoiseSource {
    rng: ChaCha8Rng,
    normal: Option<Normal<f64>>,
}

impl NoiseSource {
    /// Noise with standard deviation `sigma` (0 → none) from `seed`.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] (`noise_sigma`) when `sigma` is negative or not finite. (The
    /// distribution's own refusal, [`SimError::NoiseDistribution`], is kept for completeness; after
    /// that check it has nothing left to refuse.)
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::SimError;
    /// use millcomp_sim::sensors::NoiseSource;
    /// // the thesis' force channel: σ = 0.04 N (000 §5.2.2)
    /// let mut a = NoiseSource::new(7, 0.04).unwrap();
    /// let xs: Vec<f64> = (0..10_000).map(|_| a.sample()).collect();
    /// // seeded: the same seed replays the same samples
    /// let mut b = NoiseSource::new(7, 0.04).unwrap();
    /// assert!(xs.iter().all(|&x| x == b.sample()));
    /// // mean within 4 standard errors (4 · 0.04/√10 000 = 0.0016) of 0, σ within 3 %
    /// let mean = xs.iter().sum::<f64>() / 1e4;
    /// let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 9999.0).sqrt();
    /// assert!(mean.abs() < 0.0016 && (sd - 0.04).abs() / 0.04 < 0.03);
    /// // σ = 0: exact
    /// assert_eq!(NoiseSource::new(7, 0.0).unwrap().sample(), 0.0);
    /// let e = NoiseSource::new(7, -0.04).unwrap_err();
    /// assert!(matches!(e, SimError::InvalidParameter { name: "noise_sigma", .. }));
    /// ```
    pub fn new(seed: u64, sigma: f64) -> Result<Self, SimError> {
        check_nonneg("noise_sigma", sigma)?;
        let normal = if sigma > 0.0 {
            Some(
                Normal::new(0.0, sigma)
                    .map_err(|source| SimError::NoiseDistribution { sigma, source })?,
            )
        } else {
            None
        };
        Ok(Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            normal,
        })
    }

    /// No noise.
    pub fn none() -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(0),
            normal: None,
        }
    }

    /// One sample (0 when noise-free).
    #[inline]
    pub fn sample(&mut self) -> f64 {
        match &self.normal {
            Some(n) => n.sample(&mut self.rng),
            None => 0.0,
        }
    }
}

/// Quantise `x` to steps of `q` (no quantisation for `q == 0`).
#[inline]
pub fn quantize(x: f64, q: f64) -> f64 {
    if q > 0.0 { (x / q).round() * q } else { x }
}

/// A force channel with noise and resolution.
#[derive(Debug, Clone)]
pub struct ForceSensor {
    /// Quantisation step (N).
    pub resolution_n: f64,
    noise: NoiseSource,
}

impl ForceSensor {
    /// Ideal sensor (no noise, no quantisation).
    pub fn ideal() -> Self {
        Self {
            resolution_n: 0.0,
            noise: NoiseSource::none(),
        }
    }

    /// Sensor with noise σ `noise_sigma_n`, resolution `resolution_n`, seeded.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `resolution_n` or `noise_sigma` when it is negative or
    /// not finite.
    pub fn new(noise_sigma_n: f64, resolution_n: f64, seed: u64) -> Result<Self, SimError> {
        check_nonneg("resolution_n", resolution_n)?;
        Ok(Self {
            resolution_n,
            noise: NoiseSource::new(seed, noise_sigma_n)?,
        })
    }

    /// The thesis' spindle/workpiece force channel: σ = resolution = 0.04 N (§5.2.2).
    ///
    /// # Errors
    /// As [`Self::new`]; with the thesis' constants it does not fail.
    pub fn thesis(seed: u64) -> Result<Self, SimError> {
        Self::new(0.04, 0.04, seed)
    }

    /// Measure a true force (N).
    #[inline]
    pub fn measure(&mut self, force_n: f64) -> f64 {
        quantize(force_n + self.noise.sample(), self.resolution_n)
    }
}

/// Capacitance gauge: position (µm) ↔ volts with a finite range.
#[derive(Debug, Clone)]
pub struct CapacitanceGauge {
    /// Measuring range (µm), reading clamped to `[0, range_um]`.
    pub range_um: f64,
    /// Sensitivity (µm/V).
    pub sensitivity_um_per_v: f64,
    /// Offset (µm) added to the reading (the thesis' gauge showed 0.25 µm initial offset, Fig. 5-15).
    pub offset_um: f64,
    noise: NoiseSource,
}

impl CapacitanceGauge {
    /// RD20-1: 50 µm range, 2.5 µm/V, no noise, no offset.
    pub fn rd20() -> Self {
        Self {
            range_um: 50.0,
            sensitivity_um_per_v: 2.5,
            offset_um: 0.0,
            noise: NoiseSource::none(),
        }
    }

    /// Custom gauge.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `range_um` or `sensitivity_um_per_v` (not a finite
    /// positive number), `offset_um` (not finite) or `noise_sigma` (negative or not finite).
    pub fn new(
        range_um: f64,
        sensitivity_um_per_v: f64,
        offset_um: f64,
        noise_sigma_um: f64,
        seed: u64,
    ) -> Result<Self, SimError> {
        check_positive("range_um", range_um)?;
        check_positive("sensitivity_um_per_v", sensitivity_um_per_v)?;
        check_finite("offset_um", offset_um)?;
        Ok(Self {
            range_um,
            sensitivity_um_per_v,
            offset_um,
            noise: NoiseSource::new(seed, noise_sigma_um)?,
        })
    }

    /// Reading in µm of a true position (µm), saturating at the range ends.
    #[inline]
    pub fn measure_um(&mut self, position_um: f64) -> f64 {
        (position_um + self.offset_um + self.noise.sample()).clamp(0.0, self.range_um)
    }

    /// Reading in volts of a true position.
    pub fn measure_v(&mut self, position_um: f64) -> f64 {
        self.measure_um(position_um) / self.sensitivity_um_per_v
    }
}

/// Serializable noise option `{ seed, sigma }` used by sessions and stages.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NoiseSpec {
    /// RNG seed.
    pub seed: u64,
    /// Standard deviation (unit of the signal it is applied to).
    pub sigma: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_sensor_noise_statistics_and_resolution() {
        let mut s = ForceSensor::thesis(7).unwrap();
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| s.measure(3.0)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        // mean within 4 standard errors (σ/√n ≈ 3e-4 N)
        assert!((mean - 3.0).abs() < 0.0015, "{mean}");
        // σ² of noise + uniform quantisation q²/12 = 0.0016 + 0.000133
        assert!((var - 0.001733).abs() < 0.0002, "{var}");
        for x in xs {
            assert!(((x / 0.04).round() * 0.04 - x).abs() < 1e-12);
        }
        assert_eq!(ForceSensor::ideal().measure(1.234), 1.234);
    }

    #[test]
    fn gauge_saturates_and_converts() {
        let mut g = CapacitanceGauge::rd20();
        assert_eq!(g.measure_um(60.0), 50.0);
        assert_eq!(g.measure_um(-1.0), 0.0);
        assert_eq!(g.measure_v(25.0), 10.0);
    }
}

/// Errors of the instruments and of the set-up that no model of the plant contains: what a commissioning
/// measures *through* and a controller cannot see. Exact (gain 1, everything else 0) by default; a
/// realistic set is drawn by [`InstrumentErrors::draw`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentErrors {
    /// Force-sensor gain: the reading is `force_gain · force` (1 = exactly calibrated).
    #[serde(default = "crate::error::one")]
    pub force_gain: f64,
    /// Force-sensor drift (N/s): the charge amplifier's zero wanders by this much per second of cut.
    #[serde(default)]
    pub force_drift_n_per_s: f64,
    /// Touch-off error (µm): the depth zero was set this much too deep, so every groove is cut this much
    /// deeper than programmed (a negative value: shallower).
    #[serde(default)]
    pub touch_off_um: f64,
    /// Capacitance-gauge zero offset (µm), added to every reading.
    #[serde(default)]
    pub gauge_offset_um: f64,
}

impl Default for InstrumentErrors {
    fn default() -> Self {
        Self {
            force_gain: 1.0,
            force_drift_n_per_s: 0.0,
            touch_off_um: 0.0,
            gauge_offset_um: 0.0,
        }
    }
}

/// σ of a groove-depth profile measured by the profilometer (µm): `002_…txt` §7.2 (Talysurf) and §7.9,
/// repeatability < 0.15 µm standard deviation over 10 profiles of one groove.
pub const PROFILOMETER_SIGMA_UM: f64 = 0.1;
/// σ of the force-sensor gain error after the thesis' calibration (`000_…txt` §3.4: one 1 kg mass hung
/// three times per direction; the three channels came out 5.649, 5.333 and 4.547 N/V against a nominal
/// 5 N/V, so the calibration corrects ±10 % and leaves "a few %" — 3 % is an assumption within that).
pub const FORCE_GAIN_SIGMA: f64 = 0.03;
/// Largest force-sensor drift (N/s), drawn uniform in ±this: 0.09 N over a 12 s groove, about two
/// resolution steps of the thesis' channel (0.04 N, §5.2.2) — an assumption (the thesis gives no drift).
pub const FORCE_DRIFT_MAX_N_PER_S: f64 = 0.0075;
/// σ of the touch-off / groove-to-groove depth error (µm): `002_…txt` measured 60 grooves at
/// 52.7 µm ± 1 µm.
pub const TOUCH_OFF_SIGMA_UM: f64 = 1.0;
/// Largest gauge zero offset (µm), drawn uniform in ±this: the thesis' capacitance gauge showed "an
/// initial offset of 0.25 µm" (`000_…txt` §5.2.5, Fig. 5-15).
pub const GAUGE_OFFSET_MAX_UM: f64 = 0.25;

impl InstrumentErrors {
    /// A seeded draw with the documented spreads: gain `1 + N(0, FORCE_GAIN_SIGMA)`, drift uniform in
    /// `±FORCE_DRIFT_MAX_N_PER_S`, touch-off `N(0, TOUCH_OFF_SIGMA_UM)`, gauge offset uniform in
    /// `±GAUGE_OFFSET_MAX_UM`.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::sensors::InstrumentErrors;
    /// let a = InstrumentErrors::draw(7);
    /// assert_eq!(a, InstrumentErrors::draw(7)); // seeded
    /// assert!((a.force_gain - 1.0).abs() < 0.15); // 5 σ
    /// assert!(a.gauge_offset_um.abs() <= 0.25);
    /// ```
    pub fn draw(seed: u64) -> Self {
        use rand::Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0001_a572_u64);
        Self {
            force_gain: 1.0 + FORCE_GAIN_SIGMA * rng.sample::<f64, _>(StandardNormal),
            force_drift_n_per_s: rng
                .random_range(-FORCE_DRIFT_MAX_N_PER_S..=FORCE_DRIFT_MAX_N_PER_S),
            touch_off_um: TOUCH_OFF_SIGMA_UM * rng.sample::<f64, _>(StandardNormal),
            gauge_offset_um: rng.random_range(-GAUGE_OFFSET_MAX_UM..=GAUGE_OFFSET_MAX_UM),
        }
    }

    /// The force sensor's reading of a true force `force_n` at time `t_s` (before its noise and
    /// quantisation): `gain · force + drift · t`.
    #[inline]
    pub fn force_reading(&self, force_n: f64, t_s: f64) -> f64 {
        self.force_gain * force_n + self.force_drift_n_per_s * t_s
    }

    /// Validate (errors name the field).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for a non-positive or non-finite gain or a non-finite offset/drift.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("force_gain", self.force_gain)?;
        check_finite("force_drift_n_per_s", self.force_drift_n_per_s)?;
        check_finite("touch_off_um", self.touch_off_um)?;
        check_finite("gauge_offset_um", self.gauge_offset_um)?;
        Ok(())
    }
}
