//! # millcomp-sim — micro-milling physics
//!
//! Cutting forces of miniature ball-end mills, tool/spindle stiffness, the PZT-actuated spindle, sensors and
//! filters, the groove and thin-wall compensation stages as steppable plants, the effects a nominal model may
//! lack, and groove sessions. Sources: the seed documents in `shared/seeds/` (cited per item as
//! `000_…txt` §x.y etc.). Units are SI inside; public names carry units (`depth_um`, `force_n`, `dt_s`).
//!
//! | module | what | checked against |
//! |---|---|---|
//! | [`force`], [`material`], [`tool`] | ball-end force model (reconstructed eqs. 2–14) | Table 3-3 (31 % mean error), 1.49 N S7 offset, duty cycle 90/75 % |
//! | [`stiffness`] | two-section cantilever, tilted z-stiffness, machine in series | 0.141 N/µm, 0.571 vs 0.597 N/µm, eq. 28 |
//! | [`spindle`], [`spindle_figures`], [`lti`] | PZT spindle plant, ZOH discretisation, figure evaluation | 20 %/1.38 ms open loop (< 1 %) |
//! | [`filters`], [`sensors`] | 500 Hz low-pass, peak-and-hold, 0.0005/0.9995, notch chain; force/gauge | unit tests |
//! | [`groove`], [`feed`] | steppable groove plant; feed changes with axis acceleration, workpiece exit | 16.0 µm deflection at 80 µm (published 17) |
//! | [`kienzle`], [`nc_axis`] | flat end-mill Kienzle force (C45), the NC feed-axis stage of 003: interpolator, axes, machine + tool stiffness, force platform, wall contour | Z·ap·fz·kc/4 full-slot mean; 16 ms ramp lag |
//! | [`thinwall`] | steppable thin-wall plant (004), the 004 threshold rule, joint K_r/tool calibration | 87.6/106.7/126.1 vs 85.9/106.7/127.8 µm; threshold 2.19 % (published 2.19 %) |
//! | [`tool_variation`] | tool-to-tool variation of fresh tools (wearland, runout, force factor), seeded draws | 000 §4 ranges; unit tests |
//! | [`wall_variation`] | part-to-part variation of the thin wall (modulus and force-coefficient factors), seeded draws | CuZn40 handbook E range; unit tests |
//! | [`effects`], [`session`] | the seven named effects; TOML sessions, their timeline and per-point contexts → measured-groove points | seed figures |
//!
//! ```
//! use millcomp_sim::groove::GrooveConfig;
//! // the thesis' 20° S7 groove deflects ≈ 16 µm at its 80 µm end (000 §6.1: predicted 17, measured 16)
//! let d = GrooveConfig::thesis(20.0, 8.0).unwrap().static_deflection_um(80.0).unwrap();
//! assert!((d - 17.0).abs() / 17.0 < 0.15);
//! ```
#![warn(missing_docs)]

pub mod actuator;
pub mod effects;
pub mod error;
pub mod feed;
pub mod filters;
pub mod force;
pub mod groove;
pub mod kienzle;
pub mod lti;
pub mod material;
pub mod nc_axis;
pub mod sensors;
pub mod session;
pub mod spindle;
pub mod spindle_figures;
pub mod stiffness;
pub mod thinwall;
pub mod tool;
pub mod tool_variation;
pub mod wall_variation;

pub use error::SimError;
pub use lti::{ContinuousLti, DiscreteLti};
pub use spindle::{DiscretePztSpindle, PztSpindle};

#[cfg(test)]
mod test_support {
    /// Sample mean and standard deviation (n − 1) of `xs`.
    pub(crate) fn mean_sd(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let m = xs.iter().sum::<f64>() / n;
        let sd = (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        (m, sd)
    }
}
