//! Part-to-part variation of the thin wall: how a real H59 brass part differs from the handbook wall.
//!
//! The thin-wall truth ([`crate::thinwall::ThinWallConfig::paper`]) is the published wall: E = 100 GPa
//! (`004_…txt` Table 4) and the force coefficient K_r calibrated on 004 Table 5
//! ([`crate::thinwall::THINWALL_KR_N_PER_MM2`]). Real parts are not the handbook: the modulus of a
//! CuZn40 blank depends on its temper and texture, and its cutting-force coefficient on its lot's
//! strength. [`WallVariation`] holds one part's deviations, as factors on the two material parameters the
//! thin-wall model has (`e_gpa`, `kr_n_per_mm2`; the geometry is the NC program's, the tool stiffness is
//! the tool's and is identified), and [`WallVariation::draw`] draws them from the spreads below. Both are
//! centred on 1: K_r was calibrated on Table 5 *with* E = 100 GPa (only the pair reproduces the published
//! walls), so the part scatters around the calibrated wall instead of shifting it.
//!
//! | deviation | draw | source |
//! |---|---|---|
//! | Young's modulus (× `e_gpa`) | 1 + uniform ±[`E_HALF_RANGE`] = ±8 % | handbook range of CuZn40 (H59's international equivalent): 99–115 GPa cold formed (KMW CuZn40 / C28000 datasheet), 103–117 GPa for wrought non-leaded brass flat products (15–17 × 10⁶ psi, handbook table of non-ferrous moduli); 004 Table 4 and MakeItFrom (every C28000 temper) give 100 GPa — a 16 GPa wide range, ±8 % of 100 GPa |
//! | force coefficient (× `kr_n_per_mm2`) | 1 + N(0, [`KR_FACTOR_SIGMA`] = 4 %) | assumption: lot-to-lot strength/hardness of one temper; no seed document gives a spread (see the constant) |

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_positive};
use crate::thinwall::ThinWallConfig;

/// Half-width (relative) of the part's Young's modulus spread, drawn uniform in `1 ± E_HALF_RANGE` around
/// the published 100 GPa (`004_…txt` Table 4). Source: the handbook values for CuZn40 (CW509L, UNS
/// C28000, the international equivalent of the Chinese grade H59) span 99–115 GPa for cold-formed
/// material (KMW CuZn40 datasheet, "Modulus of elasticity cold formed 99 … 115 GPa"), 103–117 GPa for
/// wrought non-leaded brass flat products (15–17 × 10⁶ psi in the handbook table of non-ferrous moduli
/// reproduced at tubingchina.com), and 100 GPa for every one of the eight C28000 tempers on
/// MakeItFrom.com — as does 004 Table 4. The range is about 16 GPa wide: ±8 % of 100 GPa
/// (σ = 8/√3 ≈ 4.6 %). Centred on the published value, not on the range's middle, because the truth's
/// K_r is calibrated with E = 100 GPa (module documentation). A handbook range is a spread over tempers,
/// products and sources; as the spread of one shop's blanks it is an upper bound. (An 80 µm wall is only
/// a few grains thick, so its texture could move its effective modulus further; nothing here models
/// that.)
pub const E_HALF_RANGE: f64 = 0.08;

/// σ of the part's relative force-coefficient factor — an **assumption**, "a few %": no seed document
/// gives a lot-to-lot spread of the cutting force in brass. What it stands for: the strength of the
/// blank's lot within one temper (the thesis' force model scales with the material's volumetric work,
/// the area under its stress–strain curve, `000_…txt` §4 Table 4-1), which a handbook K_r does not
/// know. One σ = 4 % keeps the draw inside ±12 % at 3 σ, below the ±15 % the shipped scenario lays on the
/// controllers' coefficient deliberately. The same-material, same-tool repeatability of the thesis
/// (≈ 0.1 N, 000 Fig. 4-17) is within one part and is not used.
pub const KR_FACTOR_SIGMA: f64 = 0.04;

/// Seed stream of [`WallVariation::draw`]: XORed into the seed so that one seed gives part deviations
/// independent of the other draws made with it (`ToolVariation::draw` uses `0x7001_5eed_0000_0000`,
/// `InstrumentErrors::draw` `0x0001_a572`).
const WALL_SEED_STREAM: u64 = 0x3a11_5eed_0000_0000;

/// One part's deviations from the published thin wall (module documentation: the spreads and their
/// sources). [`WallVariation::NONE`] is the published wall itself; a realistic part is drawn by
/// [`WallVariation::draw`]. In TOML every key is optional (`{ e_factor = 1.05 }`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallVariation {
    /// Multiplies the wall material's Young's modulus `e_gpa` (1 = published 100 GPa). Source: CuZn40
    /// handbook range 99–117 GPa ([`E_HALF_RANGE`]).
    #[serde(default = "crate::error::one")]
    pub e_factor: f64,
    /// Multiplies the radial force coefficient `kr_n_per_mm2` (1 = calibrated K_r). Assumption: lot
    /// strength ([`KR_FACTOR_SIGMA`]).
    #[serde(default = "crate::error::one")]
    pub kr_factor: f64,
}

impl Default for WallVariation {
    fn default() -> Self {
        Self::NONE
    }
}

impl WallVariation {
    /// The published wall: no deviation.
    pub const NONE: Self = Self {
        e_factor: 1.0,
        kr_factor: 1.0,
    };

    /// A seeded draw of one part: modulus factor uniform in `1 ± E_HALF_RANGE`, force-coefficient factor
    /// `1 + N(0, KR_FACTOR_SIGMA)`. The seed stream is distinct from the tool's and the instruments', so
    /// the same seed may drive all three.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::wall_variation::WallVariation;
    /// let a = WallVariation::draw(7);
    /// assert_eq!(a, WallVariation::draw(7)); // seeded
    /// assert_ne!(a, WallVariation::draw(8));
    /// assert!((a.e_factor - 1.0).abs() <= 0.08);
    /// assert!((a.kr_factor - 1.0).abs() < 0.2); // 5 σ
    /// ```
    pub fn draw(seed: u64) -> Self {
        use rand::Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ WALL_SEED_STREAM);
        Self {
            e_factor: 1.0 + rng.random_range(-E_HALF_RANGE..=E_HALF_RANGE),
            kr_factor: 1.0 + KR_FACTOR_SIGMA * rng.sample::<f64, _>(StandardNormal),
        }
    }

    /// Validate the factors themselves (errors name the field).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `e_factor` or `kr_factor` when it is not a finite positive
    /// number.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("e_factor", self.e_factor)?;
        check_positive("kr_factor", self.kr_factor)?;
        Ok(())
    }

    /// Make `cfg`'s wall this part: `e_gpa` and `kr_n_per_mm2` multiplied by the factors. On error `cfg`
    /// is left unchanged.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`]: from [`Self::validate`], or from [`ThinWallConfig::validate`] on
    /// the varied wall (a factor so large that a value overflows).
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::SimError;
    /// use millcomp_sim::thinwall::{THINWALL_KR_N_PER_MM2, ThinWallConfig};
    /// use millcomp_sim::wall_variation::WallVariation;
    /// let mut c = ThinWallConfig::paper(100.0).unwrap();
    /// // a part 5 % stiffer than the handbook, cut 3 % more easily than the calibrated lot
    /// WallVariation { e_factor: 1.05, kr_factor: 0.97 }.apply(&mut c).unwrap();
    /// assert!((c.e_gpa - 105.0).abs() < 1e-12);
    /// assert!((c.kr_n_per_mm2 - 0.97 * THINWALL_KR_N_PER_MM2).abs() < 1e-9);
    /// // NONE is the published wall
    /// let before = c.clone();
    /// WallVariation::NONE.apply(&mut c).unwrap();
    /// assert_eq!(c, before);
    /// // a non-positive factor is refused, naming it, and the wall is untouched
    /// let e = WallVariation { e_factor: 0.0, ..WallVariation::NONE }.apply(&mut c).unwrap_err();
    /// assert!(matches!(e, SimError::InvalidParameter { name: "e_factor", .. }));
    /// assert_eq!(c, before);
    /// ```
    pub fn apply(&self, cfg: &mut ThinWallConfig) -> Result<(), SimError> {
        self.validate()?;
        let mut varied = cfg.clone();
        varied.e_gpa *= self.e_factor;
        varied.kr_n_per_mm2 *= self.kr_factor;
        varied.validate()?;
        *cfg = varied;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::mean_sd;
    use crate::thinwall::uncompensated_thickness_for;

    #[test]
    fn draw_is_deterministic_per_seed_and_differs_between_seeds() {
        for seed in [0, 1, 4000, u64::MAX] {
            assert_eq!(WallVariation::draw(seed), WallVariation::draw(seed));
        }
        assert_ne!(WallVariation::draw(1000), WallVariation::draw(1001));
    }

    #[test]
    fn spread_over_2000_draws_matches_the_stated_sigma() {
        let n = 2000;
        let draws: Vec<WallVariation> = (0..n).map(|s| WallVariation::draw(s as u64)).collect();
        // σ of a uniform in ±h is h/√3; of a normal, σ. The sample σ's standard error is about
        // σ·√((κ − 1)/(4n)) with kurtosis κ = 1.8 (uniform) or 3 (normal): 1.0 % or 1.6 % of σ at
        // n = 2000, so 4 standard errors are 4.0 % / 6.3 %. The mean: within 4 σ/√n.
        let cases = [
            (
                "e_factor",
                draws.iter().map(|d| d.e_factor).collect::<Vec<_>>(),
                E_HALF_RANGE / 3f64.sqrt(),
                0.040,
            ),
            (
                "kr_factor",
                draws.iter().map(|d| d.kr_factor).collect(),
                KR_FACTOR_SIGMA,
                0.063,
            ),
        ];
        for (name, xs, sigma, rel_tol) in cases {
            let (m, sd) = mean_sd(&xs);
            assert!(
                (m - 1.0).abs() < 4.0 * sigma / (n as f64).sqrt(),
                "{name}: mean {m}"
            );
            assert!(
                (sd - sigma).abs() / sigma < rel_tol,
                "{name}: σ {sd} vs {sigma}"
            );
        }
        // the uniform draw stays inside its range
        assert!(
            draws
                .iter()
                .all(|d| (d.e_factor - 1.0).abs() <= E_HALF_RANGE)
        );
    }

    #[test]
    fn none_changes_nothing() {
        let cfg = ThinWallConfig::paper(80.0).unwrap();
        let mut c = cfg.clone();
        WallVariation::NONE.apply(&mut c).unwrap();
        assert_eq!(c, cfg);
        assert_eq!(WallVariation::default(), WallVariation::NONE);
    }

    #[test]
    fn a_stiffer_part_or_a_weaker_lot_leaves_a_thinner_uncompensated_wall() {
        let base = ThinWallConfig::paper(100.0).unwrap();
        let t0 = uncompensated_thickness_for(&base).unwrap();
        for v in [
            WallVariation {
                e_factor: 1.08,
                ..WallVariation::NONE
            },
            WallVariation {
                kr_factor: 0.92,
                ..WallVariation::NONE
            },
        ] {
            let mut c = base.clone();
            v.apply(&mut c).unwrap();
            let t = uncompensated_thickness_for(&c).unwrap();
            // less deflection, less excess; but never more than the whole excess
            assert!(t < t0 && t > 100.0, "{v:?}: {t} vs {t0}");
        }
    }

    #[test]
    fn apply_rejects_bad_values_and_leaves_the_wall() {
        let mut c = ThinWallConfig::paper(120.0).unwrap();
        let before = c.clone();
        for (bad, name) in [
            (
                WallVariation {
                    e_factor: -1.0,
                    ..WallVariation::NONE
                },
                "e_factor",
            ),
            (
                WallVariation {
                    kr_factor: f64::NAN,
                    ..WallVariation::NONE
                },
                "kr_factor",
            ),
            (
                WallVariation {
                    kr_factor: 0.0,
                    ..WallVariation::NONE
                },
                "kr_factor",
            ),
            (
                WallVariation {
                    e_factor: f64::MAX,
                    ..WallVariation::NONE
                },
                "e_gpa",
            ),
        ] {
            match bad.apply(&mut c) {
                Err(SimError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
            assert_eq!(c, before);
        }
    }

    #[test]
    fn toml_keys_are_optional_and_unknown_keys_refused() {
        let v: WallVariation = toml::from_str("kr_factor = 1.1").unwrap();
        assert_eq!(
            v,
            WallVariation {
                kr_factor: 1.1,
                ..WallVariation::NONE
            }
        );
        assert!(toml::from_str::<WallVariation>("e_gpa = 90.0").is_err());
    }
}
