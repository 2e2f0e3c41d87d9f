//! Deliberate errors laid on the controllers' identified force model, for robustness studies
//! (documented in `closedloop/SCENARIOS.md`).
//!
//! * **Force model**: the identified model's volumetric work W, rake friction µ, flank friction µf and
//!   wearland each scaled by `1 + εᵢ` (seeded draws within a bound, or given). The identified model is
//!   already wrong by what the commissioning could not resolve; these errors come on top.
//! * **Sensors** (applied in the stage): force σ = resolution = 0.04 N (`000_…txt` §5.2.2); gauge σ in µm.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

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

    /// The errors as `(parameter, ε)` for
    /// [`millcomp_mpc::identified::IdentifiedForceModel::perturbed`].
    pub fn relative(&self) -> [(&'static str, f64); 4] {
        [
            ("w_mpa", self.w_mpa),
            ("mu_rake", self.mu_rake),
            ("mu_flank", self.mu_flank),
            ("wearland_um", self.wearland_um),
        ]
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
