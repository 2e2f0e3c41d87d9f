//! Tolerances for the sim integration tests, each argued once here.
#![allow(dead_code)]

/// Table 3-3 peak forces (6061): mean |relative error| over the 24 x/y/z maxima. The issue sets 35 %:
/// the thesis itself reports the y-force under-predicted "by about 200 %" in 6061 (000 §4.2.3, Fig. 4-14),
/// and wearland/runout of the DOE tools were not published (we use Table 4-4 typical values).
pub const TABLE33_MEAN_REL: f64 = 0.35;

/// 0°-tilt S7 z-force offset "approximately 1.5 N" (000 §4.2.1): the text gives one significant figure
/// after the point, so ±0.1 N (≈ 7 %).
pub const OFFSET_ABS_N: f64 = 0.1;

/// Duty cycle "90 %"/"75 %" (000 §4.2.1) are rounded to 5 %: ±2.5 percentage points.
pub const DUTY_ABS: f64 = 0.025;

/// z-stiffness at 20° vs 0.597 N/µm (000 §6.1): issue tolerance 5 %.
pub const KZ_REL: f64 = 0.05;

/// Modelled radial stiffness 0.141 N/µm is given to 3 digits (Table 5-1): ±0.5 %.
pub const RADIAL_MODEL_REL: f64 = 0.005;

/// Eq. (28) effective PZT compliances 5.17/5.75/6.57 (000 §7.2.1): reconstructed with the measured radial
/// stiffness (the thesis probably used an unrounded value): ±5 %.
pub const PZT_COMPLIANCE_REL: f64 = 0.05;

/// Groove deflection at the 80 µm end vs the published prediction 17 µm (000 §6.1): issue tolerance 15 %.
pub const GROOVE_DEFLECTION_REL: f64 = 0.15;

/// Spindle open-loop overshoot and rise time after the least-squares fit: issue tolerance 5 %.
pub const SPINDLE_OL_REL: f64 = 0.05;

/// Thin-wall thicknesses vs 004 Table 5: issue tolerance 2 µm absolute.
pub const THINWALL_ABS_UM: f64 = 2.0;

/// Finite-difference vs analytic derivative checks: central differences with a relative step 1e-6 on
/// smooth functions have truncation error O(h²) ≈ 1e-12 and round-off ≈ 1e-10/h ≈ 1e-4 of the scale in
/// the worst case; 1e-5 relative with a small absolute floor is comfortably above both.
pub const FD_REL: f64 = 1e-5;
/// Absolute floor for FD comparisons of quantities that may be ≈ 0.
pub const FD_ABS: f64 = 1e-7;
