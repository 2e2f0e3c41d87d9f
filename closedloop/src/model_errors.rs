//! The controllers' force-parameter errors: how the controllers' force predictor differs from the
//! truth's (documented in `closedloop/SCENARIOS.md`).
//!
//! * **Force model**: the controllers' force predictor is the truth model with volumetric work W, rake
//!   friction µ, flank friction µf and wearland each scaled by `1 + εᵢ`, |εᵢ| ≤ 15 % (seeded draws, or
//!   given).
//! * **Sensors** (applied in the stage): force σ = resolution = 0.04 N (`000_…txt` §5.2.2); gauge σ in µm.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use millcomp_sim::force::BallEndForceModel;

use crate::error::ClosedLoopError;

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
    pub fn apply(&self, truth: &BallEndForceModel) -> Result<BallEndForceModel, ClosedLoopError> {
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
}
