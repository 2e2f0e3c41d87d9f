//! The `[commissioning]` table of a groove scenario: what the commissioning's experiments do
//! ([`crate::commissioning`] runs them). Part of the scenario file's schema, so it lives below the
//! scenario, and the experiments above it.

use serde::{Deserialize, Serialize};

use crate::calibration::StiffnessCalibration;

/// The settings of a commissioning (`[commissioning]` of a scenario; every key optional).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CommissioningPlan {
    /// Depth levels of the force DOE (µm).
    pub force_depths_um: Vec<f64>,
    /// Upfeed levels of the force DOE (µm/rev).
    pub force_upfeeds_um: Vec<f64>,
    /// Replicates of the force DOE.
    pub replicates: usize,
    /// Revolutions cut per run (synchronously averaged).
    pub revolutions: usize,
    /// Force samples per revolution.
    pub samples_per_rev: usize,
    /// Force parameters fitted (the rest at the nominal values): names of `identify force --free`.
    pub force_free: Vec<String>,
    /// Bias voltage of the step test (V).
    pub step_bias_v: f64,
    /// Voltage step (V).
    pub step_v: f64,
    /// Duration of the step test after the step (s).
    pub step_duration_s: f64,
    /// Gauge sampling interval of the step test (s).
    pub step_dt_s: f64,
    /// The load–deflection test.
    pub stiffness: StiffnessCalibration,
    /// Samples of each sensor's record at rest (every `step_dt_s`).
    pub noise_samples: usize,
    /// Turning points of the hysteresis sweep (V), from rest at 0 V.
    pub hysteresis_turning_v: Vec<f64>,
    /// Rate of the hysteresis sweep (V/s): slow against the stack's dynamics.
    pub hysteresis_rate_v_per_s: f64,
    /// Gauge sampling interval of the hysteresis sweep (s).
    pub hysteresis_dt_s: f64,
    /// Acceptance: the largest relative standard error of a parameter that sets the deflection prediction
    /// (the fitted force parameters and the two stiffnesses); above it the bundle carries a warning that
    /// the experiment was too small for the model to be trusted.
    pub accept_rel_se: f64,
}

impl Default for CommissioningPlan {
    /// A 3×3 full factorial (depth 20/50/80 µm — the thesis' groove range; upfeed 5/10/15 µm/rev around
    /// its 10 µm/rev), 2 replicates, 20 revolutions at 72 samples each; W, wearland and runout free (a fresh
    /// tool's wearland and runout are not the catalogue's; the averaged traces show both); a 10 V step
    /// from 20 V (≈ 0.5 µm, the thesis' step of Fig. 5-15) for 30 ms sampled at 20 kHz; the thesis'
    /// hanging-mass calibration; a hysteresis sweep at 500 V/s through a major loop 20–900 V (the
    /// gauge's 50 µm range holds ≈ 950 V of tip) and minor loops of 20–700 V amplitude (≈ 13 s, read
    /// every ms); 2000 samples (0.1 s) of each sensor at rest.
    fn default() -> Self {
        Self {
            force_depths_um: vec![20.0, 50.0, 80.0],
            force_upfeeds_um: vec![5.0, 10.0, 15.0],
            replicates: 2,
            revolutions: 20,
            samples_per_rev: 72,
            force_free: vec!["w_mpa".into(), "wearland_um".into(), "runout_um".into()],
            step_bias_v: 20.0,
            step_v: 10.0,
            step_duration_s: 0.03,
            step_dt_s: 5e-5,
            stiffness: StiffnessCalibration::default(),
            noise_samples: 2000,
            hysteresis_turning_v: vec![
                900.0, 20.0, 700.0, 200.0, 600.0, 300.0, 500.0, 400.0, 460.0, 440.0, 900.0, 600.0,
                750.0, 650.0, 700.0, 20.0, 300.0, 100.0, 200.0, 150.0,
            ],
            hysteresis_rate_v_per_s: 500.0,
            hysteresis_dt_s: 1e-3,
            accept_rel_se: 0.05,
        }
    }
}
