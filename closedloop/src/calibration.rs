//! The simulated stiffness calibration: how the controllers get their stiffness — *identified* from a
//! calibration of the truth plant, the way reality does (documented in `closedloop/SCENARIOS.md`).
//!
//! * **Stiffness** is identified from a simulated calibration like the thesis' (`000_…txt` §5.2.3:
//!   hanging masses 50–1000 g on the tool tip, three trials per mass, deflection read with an electronic
//!   indicator; axial: masses 100–1000 g). The indicator reading is quantised to
//!   `indicator_resolution_um` and carries Gaussian noise `noise_um` (the thesis does not state the
//!   indicator; 1 µm resolution / 0.5 µm noise is a typical dial/electronic indicator — an assumption).
//!   The compliance is fitted by least squares through the origin with `millcomp_identify::fit_linear`.
//!
//! The controllers' force-parameter errors are in [`crate::model_errors`].

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use millcomp_identify::{LinearMethod, fit_linear};
use millcomp_sim::stiffness::TiltedToolStiffness;

use crate::error::ClosedLoopError;

/// Standard gravity (m/s²), to turn calibration masses into forces.
pub const G_N_PER_KG: f64 = 9.806_65;

/// Simulated stiffness calibration settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StiffnessCalibration {
    /// Indicator resolution (µm); readings are rounded to it.
    #[serde(default = "default_resolution")]
    pub indicator_resolution_um: f64,
    /// Indicator noise σ (µm).
    #[serde(default = "default_noise")]
    pub noise_um: f64,
    /// Trials per mass (the thesis: three).
    #[serde(default = "default_trials")]
    pub trials: usize,
}

fn default_resolution() -> f64 {
    1.0
}
fn default_noise() -> f64 {
    0.5
}
fn default_trials() -> usize {
    3
}

impl StiffnessCalibration {
    /// The indicator's noise distribution.
    ///
    /// # Errors
    /// [`ClosedLoopError::CalibrationNoise`] for a non-finite `noise_um`.
    pub fn noise(&self) -> Result<Normal<f64>, ClosedLoopError> {
        Normal::new(0.0, self.noise_um.max(0.0))
            .map_err(|source| ClosedLoopError::CalibrationNoise { source })
    }

    /// The indicator's reading (µm) of a true deflection: plus one draw of `noise`, rounded to
    /// `indicator_resolution_um`.
    pub fn reading_um(&self, true_um: f64, noise: &Normal<f64>, rng: &mut ChaCha8Rng) -> f64 {
        let r = true_um + noise.sample(rng);
        if self.indicator_resolution_um > 0.0 {
            (r / self.indicator_resolution_um).round() * self.indicator_resolution_um
        } else {
            r
        }
    }
}

/// The thesis' radial calibration masses (g): 50, then 100 … 1000 in 100 g steps (`000_…txt` §5.2.3).
pub fn radial_masses_g() -> Vec<f64> {
    std::iter::once(50.0)
        .chain((1..=10).map(|i| 100.0 * i as f64))
        .collect()
}

/// The thesis' axial calibration masses (g): 100 … 1000 in 100 g steps (`000_…txt` §5.2.3).
pub fn axial_masses_g() -> Vec<f64> {
    (1..=10).map(|i| 100.0 * i as f64).collect()
}

impl Default for StiffnessCalibration {
    fn default() -> Self {
        Self {
            indicator_resolution_um: default_resolution(),
            noise_um: default_noise(),
            trials: default_trials(),
        }
    }
}

/// Result of the simulated calibration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CalibratedStiffness {
    /// Identified axial stiffness (N/µm).
    pub axial_n_per_um: f64,
    /// Identified radial stiffness (N/µm).
    pub radial_n_per_um: f64,
    /// Standard error of the axial stiffness (N/µm), delta method from the compliance fit.
    pub axial_std_err: f64,
    /// Standard error of the radial stiffness (N/µm).
    pub radial_std_err: f64,
}

impl CalibratedStiffness {
    /// As a sim stiffness.
    pub fn stiffness(&self) -> Result<TiltedToolStiffness, ClosedLoopError> {
        Ok(TiltedToolStiffness::new(
            self.axial_n_per_um,
            self.radial_n_per_um,
        )?)
    }
}

fn fit_one(
    truth_k: f64,
    masses_g: &[f64],
    cal: &StiffnessCalibration,
    rng: &mut ChaCha8Rng,
    what: &str,
) -> Result<(f64, f64), ClosedLoopError> {
    let forces: Vec<f64> = masses_g.iter().map(|m| m * 1e-3 * G_N_PER_KG).collect();
    fit_compliance(truth_k, &forces, cal, rng, what)
}

/// Load the truth spring `truth_k` (N/µm) with `forces_n` (each `cal.trials` times), read the deflection
/// quantised to `cal.indicator_resolution_um` with noise `cal.noise_um`, fit the compliance through the
/// origin (`millcomp_identify::fit_linear`); returns (stiffness, its standard error) in N/µm.
pub fn fit_compliance(
    truth_k: f64,
    forces_n: &[f64],
    cal: &StiffnessCalibration,
    rng: &mut ChaCha8Rng,
    what: &str,
) -> Result<(f64, f64), ClosedLoopError> {
    let noise = cal.noise()?;
    let mut f = Vec::new();
    let mut d = Vec::new();
    for &force in forces_n {
        for _ in 0..cal.trials.max(1) {
            f.push(force);
            d.push(cal.reading_um(force / truth_k, &noise, rng));
        }
    }
    let a = DMatrix::from_column_slice(f.len(), 1, &f);
    let names = vec![format!("{what}_compliance_um_per_n")];
    let fit = fit_linear(
        &names,
        &a,
        &d,
        None,
        LinearMethod::Qr,
        &format!("{what} stiffness calibration"),
        "um",
    )
    .map_err(|source| ClosedLoopError::CalibrationFit { source })?;
    let c = fit.theta[0];
    if !(c.is_finite() && c > 0.0) {
        return Err(ClosedLoopError::CalibrationNotPositive {
            what: what.to_string(),
            compliance: c,
        });
    }
    let se_c = fit.report.se(&names[0]);
    Ok((1.0 / c, se_c / (c * c)))
}

/// Simulate the thesis' calibration of the truth stiffness and identify it (seeded).
///
/// ```
/// use millcomp_closedloop::calibration::{StiffnessCalibration, calibrate_stiffness};
/// use millcomp_sim::stiffness::TiltedToolStiffness;
/// let truth = TiltedToolStiffness::default(); // Table 5-1: 1.220 axial, 0.114 radial
/// let id = calibrate_stiffness(&truth, &StiffnessCalibration::default(), 1).unwrap();
/// assert!((id.radial_n_per_um / 0.114 - 1.0).abs() < 0.02);
/// assert!((id.axial_n_per_um / 1.220 - 1.0).abs() < 0.08);
/// ```
pub fn calibrate_stiffness(
    truth: &TiltedToolStiffness,
    cal: &StiffnessCalibration,
    seed: u64,
) -> Result<CalibratedStiffness, ClosedLoopError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let radial_masses = radial_masses_g();
    let axial_masses = axial_masses_g();
    let (kr, ser) = fit_one(
        truth.radial_n_per_um,
        &radial_masses,
        cal,
        &mut rng,
        "radial",
    )?;
    let (ka, sea) = fit_one(truth.axial_n_per_um, &axial_masses, cal, &mut rng, "axial")?;
    Ok(CalibratedStiffness {
        axial_n_per_um: ka,
        radial_n_per_um: kr,
        axial_std_err: sea,
        radial_std_err: ser,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calibration_recovers_the_truth_without_noise() {
        let truth = TiltedToolStiffness::default();
        let cal = StiffnessCalibration {
            indicator_resolution_um: 0.0,
            noise_um: 0.0,
            trials: 1,
        };
        let id = calibrate_stiffness(&truth, &cal, 0).unwrap();
        approx::assert_relative_eq!(id.radial_n_per_um, 0.114, max_relative = 1e-10);
        approx::assert_relative_eq!(id.axial_n_per_um, 1.220, max_relative = 1e-10);
    }
}
