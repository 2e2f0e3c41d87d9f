//! Miniature ball-end mill (`000_…txt` §1.1.1, §2.3, §4): radius, wearland, runout, two flutes.

use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_nonneg, check_positive, check_range};

/// A two-flute ball-end mill.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallEndTool {
    /// Ball radius (µm); the thesis tools are Ø0.8 mm → 400 µm.
    pub radius_um: f64,
    /// Flank wearland WL (µm); new tools 4–6 µm, worn 12–14 µm, typical 8 µm (`000_…txt` §4).
    pub wearland_um: f64,
    /// Measured tool/spindle runout (µm); entered in the model as a percentage of the upfeed (§4).
    pub runout_um: f64,
    /// Number of flutes (only 2 is modelled).
    pub flutes: u32,
    /// Tilt (deg) above which the flat tool centre (≈ 56 µm transition area) leaves the work and the flank
    /// area halves (3.5°, `000_…txt` §4.2.1).
    pub center_clear_tilt_deg: f64,
    /// Factor on the flank area once the centre has cleared (0.5, §4.2.1).
    pub tilted_flank_factor: f64,
}

impl Default for BallEndTool {
    /// Ø0.8 mm, wearland 8 µm ("typical", §4), runout 10 µm (Table 4-2 typical for S7).
    fn default() -> Self {
        Self {
            radius_um: 400.0,
            wearland_um: 8.0,
            runout_um: 10.0,
            flutes: 2,
            center_clear_tilt_deg: 3.5,
            tilted_flank_factor: 0.5,
        }
    }
}

impl BallEndTool {
    /// A Ø0.8 mm two-flute tool with the given wearland and runout.
    pub fn new(radius_um: f64, wearland_um: f64, runout_um: f64) -> Result<Self, SimError> {
        let t = Self {
            radius_um,
            wearland_um,
            runout_um,
            ..Self::default()
        };
        t.validate()?;
        Ok(t)
    }

    /// Validate all parameters.
    pub fn validate(&self) -> Result<(), SimError> {
        check_range(
            "radius_um",
            self.radius_um,
            1.0,
            5000.0,
            "1 <= radius_um <= 5000",
        )?;
        check_range(
            "wearland_um",
            self.wearland_um,
            0.0,
            self.radius_um,
            "0 <= wearland_um <= radius_um",
        )?;
        check_nonneg("runout_um", self.runout_um)?;
        if self.flutes != 2 {
            return Err(SimError::InvalidParameter {
                name: "flutes",
                value: self.flutes as f64,
                allowed: "2 (only two-flute ball-end mills are modelled)",
            });
        }
        check_range(
            "center_clear_tilt_deg",
            self.center_clear_tilt_deg,
            0.0,
            90.0,
            "0 <= center_clear_tilt_deg <= 90",
        )?;
        check_range(
            "tilted_flank_factor",
            self.tilted_flank_factor,
            0.0,
            1.0,
            "0 <= tilted_flank_factor <= 1",
        )?;
        check_positive("radius_um", self.radius_um)?;
        Ok(())
    }

    /// Runout as a fraction of the upfeed, ξ = runout/upfeed, clamped to [0, 1] (ξ = 1: one flute removes
    /// all material, `000_…txt` §4).
    pub fn runout_fraction(&self, upfeed_um: f64) -> f64 {
        if upfeed_um <= 0.0 {
            return 0.0;
        }
        (self.runout_um / upfeed_um).clamp(0.0, 1.0)
    }
}
