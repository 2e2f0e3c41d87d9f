//! Tool-to-tool variation: how a fresh tool of the catalogue type really differs from the catalogue tool.
//!
//! The truth plants use one exact tool ([`crate::tool::BallEndTool`], e.g. Ø0.8 mm, wearland 8 µm, runout
//! 10 µm in [`crate::groove::GrooveConfig::thesis`]). Real tools of the same type are not that tool: the
//! thesis measured every tool's wearland and runout because they differed (`000_…txt` §4), and its 30° and
//! 40° grooves, cut with different tools, deflected alike where the tilt alone predicts more (§7.2.2).
//! [`ToolVariation`] holds one tool's deviations from the catalogue tool and [`ToolVariation::draw`] draws
//! them from the spreads below. Each spread is the *tool-to-tool* spread of fresh tools; wear during a cut
//! is a separate effect ([`crate::effects`]).
//!
//! | deviation | draw | source |
//! |---|---|---|
//! | wearland | uniform ±[`WEARLAND_HALF_RANGE_UM`] = ±1 µm | `000_…txt` §4: "the wearland of a new tool was consistently measured at 4-6 µm" |
//! | runout | uniform ±[`RUNOUT_HALF_RANGE_UM`] = ±2 µm | `000_…txt` §4: after re-seating the tool in the collet "runout could be reduced from 16-20 µm to 6-10 µm" |
//! | force factor | 1 + N(0, [`FORCE_FACTOR_SIGMA`] = 5 %) | assumption (edge radius, coating; see the constant) |

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_finite, check_positive};
use crate::force::BallEndForceModel;

/// Half-width (µm) of the fresh-tool wearland spread, drawn uniform in ±this around the catalogue
/// wearland: `000_…txt` §4 "The wearland of a new tool was consistently measured at 4-6 µm" — a 2 µm wide
/// range, so ±1 µm (σ = 1/√3 ≈ 0.58 µm). The range includes the light-microscope measurement's own
/// scatter ("the most difficult parameter to measure", §4 summary), so it bounds the true spread from
/// above. The 5 µm vs "typical ≈ 8 µm" (§4) and the 12–14 µm after the experiments are wear states,
/// not tool-to-tool variation of fresh tools.
pub const WEARLAND_HALF_RANGE_UM: f64 = 1.0;

/// Half-width (µm) of the runout spread, drawn uniform in ±this around the catalogue runout:
/// `000_…txt` §4, the tool was rotated in the collet until the indicator showed the least runout;
/// "Runout could be reduced from 16-20 µm to 6-10 µm in this manner" — a 4 µm wide range, so ±2 µm
/// (σ = 2/√3 ≈ 1.15 µm). The thesis' tables (4-2 to 4-4) list runouts of 4–10 µm for its force cuts.
/// Only the shank runout was measured; the flute runout "is an unknown factor" (§4) and is not in
/// this spread.
pub const RUNOUT_HALF_RANGE_UM: f64 = 2.0;

/// σ of the relative force factor of a fresh tool — an **assumption**: no seed document gives a
/// tool-to-tool force spread for fresh tools of one type. What it stands for: what wearland and runout
/// do not describe, mainly the ground cutting edge (edge radius, coating). That edge matters at this
/// scale — a fresh micro mill's edge radius is a few µm (`004_…txt` Table 3: 5 µm for a Ø1 mm
/// TiAlN-coated carbide mill), the order of the 0–10 µm feed per tooth of the thesis' grooves — but
/// nothing measured its scatter. The assumption: it moves the force about as much as the two sourced
/// spreads do, not more. In the thesis' 20° groove at its 80 µm end (wearland 8 µm, runout 10 µm) the
/// model's peak z-force moves +6.7 % for +1 µm of wearland and −4.6 % for −2 µm of runout, hence one
/// σ = 5 %. The thesis' same-tool repeatability (≈ 0.1 N, Fig. 4-17) is far below this; its 31 % mean
/// force-model error (Table 3-3) is model error, not tool scatter, and is not used.
pub const FORCE_FACTOR_SIGMA: f64 = 0.05;

/// Seed stream of [`ToolVariation::draw`]: XORed into the seed so that one scenario seed gives tool
/// deviations independent of its instrument errors (`InstrumentErrors::draw` uses `0x0001_a572`).
const TOOL_SEED_STREAM: u64 = 0x7001_5eed_0000_0000;

/// One tool's deviations from the catalogue tool of its type (module documentation: the spreads and
/// their sources). [`ToolVariation::NONE`] is the catalogue tool itself; a realistic set is drawn by
/// [`ToolVariation::draw`]. In TOML every key is optional (`{ wearland_offset_um = 1.0 }`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolVariation {
    /// Added to the catalogue wearland (µm). Source: `000_…txt` §4, new tools 4–6 µm
    /// ([`WEARLAND_HALF_RANGE_UM`]).
    #[serde(default)]
    pub wearland_offset_um: f64,
    /// Added to the catalogue tool/spindle runout (µm). Source: `000_…txt` §4, 6–10 µm after
    /// re-seating ([`RUNOUT_HALF_RANGE_UM`]).
    #[serde(default)]
    pub runout_offset_um: f64,
    /// Multiplies the force model's `force_scale` (1 = catalogue). Assumption: edge-radius/coating
    /// scatter ([`FORCE_FACTOR_SIGMA`]).
    #[serde(default = "crate::error::one")]
    pub force_factor: f64,
}

impl Default for ToolVariation {
    fn default() -> Self {
        Self::NONE
    }
}

impl ToolVariation {
    /// The exact catalogue tool: no deviation.
    pub const NONE: Self = Self {
        wearland_offset_um: 0.0,
        runout_offset_um: 0.0,
        force_factor: 1.0,
    };

    /// A seeded draw of a fresh tool: wearland offset uniform in `±WEARLAND_HALF_RANGE_UM`, runout
    /// offset uniform in `±RUNOUT_HALF_RANGE_UM`, force factor `1 + N(0, FORCE_FACTOR_SIGMA)`. The seed
    /// stream is distinct from `InstrumentErrors::draw`'s, so the same scenario seed may drive both.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::tool_variation::ToolVariation;
    /// let a = ToolVariation::draw(7);
    /// assert_eq!(a, ToolVariation::draw(7)); // seeded
    /// assert_ne!(a, ToolVariation::draw(8));
    /// assert!(a.wearland_offset_um.abs() <= 1.0 && a.runout_offset_um.abs() <= 2.0);
    /// assert!((a.force_factor - 1.0).abs() < 0.25); // 5 σ
    /// ```
    pub fn draw(seed: u64) -> Self {
        use rand::Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ TOOL_SEED_STREAM);
        Self {
            wearland_offset_um: rng.random_range(-WEARLAND_HALF_RANGE_UM..=WEARLAND_HALF_RANGE_UM),
            runout_offset_um: rng.random_range(-RUNOUT_HALF_RANGE_UM..=RUNOUT_HALF_RANGE_UM),
            force_factor: 1.0 + FORCE_FACTOR_SIGMA * rng.sample::<f64, _>(StandardNormal),
        }
    }

    /// Validate the deviations themselves (errors name the field).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `wearland_offset_um` or `runout_offset_um` (not finite) or
    /// `force_factor` (not a finite positive number).
    pub fn validate(&self) -> Result<(), SimError> {
        check_finite("wearland_offset_um", self.wearland_offset_um)?;
        check_finite("runout_offset_um", self.runout_offset_um)?;
        check_positive("force_factor", self.force_factor)?;
        Ok(())
    }

    /// Make `model`'s catalogue tool this tool: wearland and runout offset, `force_scale` multiplied by
    /// the force factor. On error `model` is left unchanged.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`]: from [`Self::validate`], or naming `wearland_um` / `runout_um` /
    /// `force_scale` when the varied tool fails [`BallEndForceModel::validate`] (e.g. an offset that
    /// makes the wearland negative).
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::SimError;
    /// use millcomp_sim::force::{BallEndForceModel, CutConditions};
    /// use millcomp_sim::groove::GrooveConfig;
    /// use millcomp_sim::tool_variation::ToolVariation;
    /// // the thesis' 20° groove tool (wearland 8 µm, runout 10 µm) at the 80 µm deep end
    /// let mut m = GrooveConfig::thesis(20.0, 8.0).unwrap().force_model;
    /// let c = CutConditions::new(80.0, 10.0, 10_000.0, 20.0).unwrap();
    /// let f0 = m.peak_z_force_n(&c).unwrap();
    /// assert!((f0 - 10.6803).abs() < 1e-4);
    /// // a fresh tool 1 µm sharper, seated 2 µm truer, with a 5 % stronger edge
    /// let v = ToolVariation { wearland_offset_um: -1.0, runout_offset_um: -2.0, force_factor: 1.05 };
    /// v.apply(&mut m).unwrap();
    /// assert_eq!((m.tool.wearland_um, m.tool.runout_um), (7.0, 8.0));
    /// assert!((m.peak_z_force_n(&c).unwrap() - 9.9421).abs() < 1e-4);
    /// // NONE is the catalogue tool
    /// let before = m.clone();
    /// ToolVariation::NONE.apply(&mut m).unwrap();
    /// assert_eq!(m, before);
    /// // an offset that leaves no wearland is refused, and the model is untouched
    /// let e = ToolVariation { wearland_offset_um: -9.0, ..ToolVariation::NONE }.apply(&mut m).unwrap_err();
    /// assert!(matches!(e, SimError::InvalidParameter { name: "wearland_um", .. }));
    /// assert_eq!(m, before);
    /// ```
    pub fn apply(&self, model: &mut BallEndForceModel) -> Result<(), SimError> {
        self.validate()?;
        let mut varied = model.clone();
        varied.tool.wearland_um += self.wearland_offset_um;
        varied.tool.runout_um += self.runout_offset_um;
        varied.params.force_scale *= self.force_factor;
        varied.validate()?;
        *model = varied;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groove::GrooveConfig;
    use crate::test_support::mean_sd;

    #[test]
    fn draw_is_deterministic_per_seed_and_differs_between_seeds() {
        for seed in [0, 1, 20, u64::MAX] {
            assert_eq!(ToolVariation::draw(seed), ToolVariation::draw(seed));
        }
        assert_ne!(ToolVariation::draw(1), ToolVariation::draw(2));
    }

    #[test]
    fn spread_over_2000_draws_matches_the_stated_sigma() {
        let n = 2000;
        let draws: Vec<ToolVariation> = (0..n).map(|s| ToolVariation::draw(s as u64)).collect();
        // σ of a uniform in ±h is h/√3; of a normal, σ. The sample σ's standard error is about
        // σ·√((κ − 1)/(4n)) with kurtosis κ = 1.8 (uniform) or 3 (normal): 1.0 % or 1.6 % of σ at
        // n = 2000, so 4 standard errors are 4.0 % / 6.3 %. The mean: within 4 σ/√n.
        let cases = [
            (
                "wearland",
                draws
                    .iter()
                    .map(|d| d.wearland_offset_um)
                    .collect::<Vec<_>>(),
                0.0,
                WEARLAND_HALF_RANGE_UM / 3f64.sqrt(),
                0.040,
            ),
            (
                "runout",
                draws.iter().map(|d| d.runout_offset_um).collect(),
                0.0,
                RUNOUT_HALF_RANGE_UM / 3f64.sqrt(),
                0.040,
            ),
            (
                "force_factor",
                draws.iter().map(|d| d.force_factor).collect(),
                1.0,
                FORCE_FACTOR_SIGMA,
                0.063,
            ),
        ];
        for (name, xs, mean0, sigma, rel_tol) in cases {
            let (m, sd) = mean_sd(&xs);
            assert!(
                (m - mean0).abs() < 4.0 * sigma / (n as f64).sqrt(),
                "{name}: mean {m} vs {mean0}"
            );
            assert!(
                (sd - sigma).abs() / sigma < rel_tol,
                "{name}: σ {sd} vs {sigma}"
            );
        }
        // the uniform draws stay inside their ranges
        assert!(
            draws
                .iter()
                .all(|d| d.wearland_offset_um.abs() <= 1.0 && d.runout_offset_um.abs() <= 2.0)
        );
    }

    #[test]
    fn none_changes_nothing() {
        let cfg = GrooveConfig::thesis(30.0, 5.0).unwrap();
        let mut m = cfg.force_model.clone();
        ToolVariation::NONE.apply(&mut m).unwrap();
        assert_eq!(m, cfg.force_model);
        assert_eq!(ToolVariation::default(), ToolVariation::NONE);
    }

    #[test]
    fn apply_offsets_and_scales_and_rejects_bad_values() {
        let mut m = GrooveConfig::thesis(20.0, 8.0).unwrap().force_model;
        let scale = m.params.force_scale;
        let v = ToolVariation {
            wearland_offset_um: 0.5,
            runout_offset_um: 1.5,
            force_factor: 0.9,
        };
        v.apply(&mut m).unwrap();
        assert_eq!(m.tool.wearland_um, 8.5);
        assert_eq!(m.tool.runout_um, 11.5);
        assert!((m.params.force_scale - 0.9 * scale).abs() < 1e-12);

        let before = m.clone();
        for (bad, name) in [
            (
                ToolVariation {
                    force_factor: 0.0,
                    ..ToolVariation::NONE
                },
                "force_factor",
            ),
            (
                ToolVariation {
                    wearland_offset_um: f64::NAN,
                    ..ToolVariation::NONE
                },
                "wearland_offset_um",
            ),
            (
                ToolVariation {
                    runout_offset_um: -20.0,
                    ..ToolVariation::NONE
                },
                "runout_um",
            ),
        ] {
            match bad.apply(&mut m) {
                Err(SimError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
            assert_eq!(m, before);
        }
    }

    #[test]
    fn toml_keys_are_optional_and_unknown_keys_refused() {
        let v: ToolVariation = toml::from_str("wearland_offset_um = -1.0").unwrap();
        assert_eq!(
            v,
            ToolVariation {
                wearland_offset_um: -1.0,
                ..ToolVariation::NONE
            }
        );
        assert!(toml::from_str::<ToolVariation>("wearland_um = 1.0").is_err());
    }
}
