//! How the controllers' models differ from the truth plant — the way reality does (documented in
//! `mpc/SCENARIOS.md`).
//!
//! * **Stiffness** is *identified* from a simulated calibration like the thesis' (`000_…txt` §5.2.3:
//!   hanging masses 50–1000 g on the tool tip, three trials per mass, deflection read with an electronic
//!   indicator; axial: masses 100–1000 g). The indicator reading is quantised to
//!   `indicator_resolution_um` and carries Gaussian noise `noise_um` (the thesis does not state the
//!   indicator; 1 µm resolution / 0.5 µm noise is a typical dial/electronic indicator — an assumption).
//!   The compliance is fitted by least squares through the origin with `millcomp_identify::fit_linear`.
//! * **Force model**: the controllers' force predictor is the truth model with volumetric work W, rake
//!   friction µ, flank friction µf and wearland each scaled by `1 + εᵢ`, |εᵢ| ≤ 15 % (seeded draws, or given).
//! * **Sensors** (applied in the stage): force σ = resolution = 0.04 N (`000_…txt` §5.2.2); gauge σ in µm.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use millcomp_identify::{LinearMethod, fit_linear};
use millcomp_sim::force::BallEndForceModel;
use millcomp_sim::stiffness::TiltedToolStiffness;

use crate::error::MpcError;

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
    pub fn stiffness(&self) -> Result<TiltedToolStiffness, MpcError> {
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
) -> Result<(f64, f64), MpcError> {
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
) -> Result<(f64, f64), MpcError> {
    let noise = Normal::new(0.0, cal.noise_um.max(0.0)).map_err(|e| MpcError::Numerical {
        what: "stiffness calibration",
        detail: e.to_string(),
    })?;
    let mut f = Vec::new();
    let mut d = Vec::new();
    for &force in forces_n {
        for _ in 0..cal.trials.max(1) {
            let mut reading = force / truth_k + noise.sample(rng);
            if cal.indicator_resolution_um > 0.0 {
                reading =
                    (reading / cal.indicator_resolution_um).round() * cal.indicator_resolution_um;
            }
            f.push(force);
            d.push(reading);
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
    .map_err(|e| MpcError::Numerical {
        what: "stiffness calibration fit",
        detail: e.to_string(),
    })?;
    let c = fit.theta[0];
    if !(c.is_finite() && c > 0.0) {
        return Err(MpcError::Numerical {
            what: "stiffness calibration fit",
            detail: format!("{what} compliance {c} not positive"),
        });
    }
    let se_c = fit.report.se(&names[0]);
    Ok((1.0 / c, se_c / (c * c)))
}

/// Simulate the thesis' calibration of the truth stiffness and identify it (seeded).
///
/// ```
/// use millcomp_mpc::truth::{StiffnessCalibration, calibrate_stiffness};
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
) -> Result<CalibratedStiffness, MpcError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let radial_masses: Vec<f64> = std::iter::once(50.0)
        .chain((1..=10).map(|i| 100.0 * i as f64))
        .collect();
    let axial_masses: Vec<f64> = (1..=10).map(|i| 100.0 * i as f64).collect();
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

/// Relative errors of the controllers' force-model parameters (`model = truth · (1 + ε)`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ForceErrors {
    /// ε of the volumetric work W.
    #[serde(default)]
    pub w_mpa: f64,
    /// ε of the rake friction µ.
    #[serde(default)]
    pub mu_rake: f64,
    /// ε of the flank friction µf.
    #[serde(default)]
    pub mu_flank: f64,
    /// ε of the wearland.
    #[serde(default)]
    pub wearland_um: f64,
}

impl ForceErrors {
    /// Seeded draw with every εᵢ uniform in `[−max_rel, max_rel]`.
    pub fn draw(max_rel: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_f0ce);
        let m = max_rel.abs();
        let mut d = || {
            if m > 0.0 {
                rng.random_range(-m..=m)
            } else {
                0.0
            }
        };
        Self {
            w_mpa: d(),
            mu_rake: d(),
            mu_flank: d(),
            wearland_um: d(),
        }
    }

    /// Largest |ε|.
    pub fn max_abs(&self) -> f64 {
        [self.w_mpa, self.mu_rake, self.mu_flank, self.wearland_um]
            .iter()
            .fold(0.0f64, |a, b| a.max(b.abs()))
    }

    /// The controllers' force model: the truth with the errors applied.
    pub fn apply(&self, truth: &BallEndForceModel) -> Result<BallEndForceModel, MpcError> {
        let mut m = truth.clone();
        m.material.w_mpa *= 1.0 + self.w_mpa;
        m.material.mu_rake *= 1.0 + self.mu_rake;
        m.material.mu_flank *= 1.0 + self.mu_flank;
        m.tool.wearland_um *= 1.0 + self.wearland_um;
        m.validate()?;
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_error_draw_is_bounded_and_seeded() {
        let a = ForceErrors::draw(0.15, 3);
        let b = ForceErrors::draw(0.15, 3);
        assert_eq!(a, b);
        assert!(a.max_abs() <= 0.15);
        assert_ne!(a, ForceErrors::draw(0.15, 4));
        assert_eq!(ForceErrors::draw(0.0, 3), ForceErrors::default());
    }

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
