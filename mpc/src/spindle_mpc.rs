//! MPC design for the PZT-actuated spindle (groove stage, `000_…txt` §5.2, ch. 7).
//!
//! Prediction model: the spindle plant (volts → tool-tip µm, the identified or nominal
//! `PztSpindle` as an [`IdentifiedSpindle`]) sampled at the control period, with **two outputs** built from the same tip row of C:
//!
//! - output 0, *gauge*: the tip displacement measured by the capacitance gauge (weight 0). It carries an
//!   integrating output disturbance of its own: what the linear spindle model cannot explain on the gauge
//!   — a real stack's hysteresis and creep, the gauge zero — goes there instead of into the spindle
//!   states. Without it, on a hysteretic stack the gauge's innovations (≫ its 0.01 µm noise) are gated,
//!   then accepted in bursts, and the estimate and the command limit-cycle (30° groove, seed 3, commissioned
//!   form: 3.39 µm peak-to-peak and 2789 µm of actuator travel without, 0.84 µm and 97 µm with);
//! - output 1, *depth error*: `e = tip − δ` where δ is the z-deflection of the tool. This is the thesis'
//!   eq. (25) error (desired − actual + force/k with desired = 0). It carries the integrating output
//!   disturbance `d` and the known offset `w = −δ̂_plan` — the deflection the planned process will cause
//!   (programmed depth and feed schedule → force predictor → ÷ stiffness). Measured as
//!   `gauge − F_meas/k_z`. `d` absorbs the difference between planned and measured deflection, so the
//!   controller is offset-free with respect to force-model and stiffness errors seen by the force sensor.
//!
//! The QP minimises `Σ e²` with a move penalty, keeps the command in `[0, voltage_max]` and within the slew
//! limit, and softly bounds `|e| ≤ e_max` (over- and under-size) with an exact penalty.

use millcomp_sim::DiscreteLti;

use crate::identified::IdentifiedSpindle;
use nalgebra::DMatrix;

use crate::config::{
    DisturbanceConfig, DisturbanceKind, KalmanConfig, Limits, MpcConfig, SlewRows, SoftOutput,
    SolverConfig, Weights,
};
use crate::error::MpcError;

/// Output index of the gauge channel.
pub const OUT_GAUGE: usize = 0;
/// Output index of the depth-error channel.
pub const OUT_ERROR: usize = 1;

/// Two-output discrete prediction model of the spindle (see the module docs). Dead time, if any, is kept
/// as the Padé approximant of `PztSpindle::to_lti`.
pub fn spindle_prediction_model(
    spindle: &IdentifiedSpindle,
    dt_s: f64,
) -> Result<DiscreteLti, MpcError> {
    let single = spindle.plant().to_lti()?.discretize_zoh(dt_s)?;
    let n = single.n_states();
    let mut c = DMatrix::zeros(2, n);
    for j in 0..n {
        c[(0, j)] = single.c[(0, j)];
        c[(1, j)] = single.c[(0, j)];
    }
    Ok(DiscreteLti::new(
        single.a,
        single.b,
        c,
        DMatrix::zeros(2, 1),
        dt_s,
    )?)
}

/// Default spindle MPC configuration for `horizon` cycles (documented in `mpc/CONFIG.md`):
/// geometric move blocking (1, 1, 2, 4, 8, … steps), weights `[0, 1]` on (gauge, error) per µm², move
/// weight 1e-4 per V², command 0–`voltage_max_v` V, slew `slew_v_per_cycle`, soft `|e − r| ≤ 1 µm` (about
/// the error's reference: the stroke-aware targets of [`crate::stroke`], 0 where the stroke covers) checked at
/// steps 3, N/2 + 3 and N (step 3 = 1.5 ms, after the spindle's 0.39 ms dead time and lag), output
/// disturbances on both channels (gauge: what the linear model misses on the stack; error: the deflection
/// the plan misses — see the module docs), Kalman noise: gauge 0.01 µm²
/// (≈ 0.1 µm gauge noise), error channel 0.04 µm², disturbance random walk 0.01 µm²/cycle, innovation
/// gates 3 µm (gauge) / 4 µm (error) for at most 24 cycles. The QP for speed (each choice measured in
/// `bench/mpc-vs-casadi`): slew rows on the first move only (`SlewRows::FirstBlock`; the later block
/// boundaries did not move a first move by more than 2e-9 of the input range on the recorded sequence),
/// Clarabel tolerances 1e-6 — tied to the actuator's resolution: first moves within ~1e-5 of the input
/// range (0.01 V of 1000 V), ten times inside the 1e-4 the amplifier can resolve — equilibration and
/// iterative refinement off (fewer iterations, cheaper ones, first moves as accurate).
pub fn default_spindle_config(
    horizon: usize,
    voltage_max_v: f64,
    slew_v_per_cycle: f64,
) -> MpcConfig {
    MpcConfig {
        horizon,
        control_horizon: None,
        move_blocking: Some(MpcConfig::geometric_blocks(horizon)),
        weights: Weights {
            output: vec![0.0, 1.0],
            input_rate: vec![1e-4],
            input: vec![0.0],
            input_target: vec![0.0],
            slack_linear: 1e3,
            slack_quadratic: 1e2,
        },
        limits: Limits {
            u_min: vec![0.0],
            u_max: vec![voltage_max_v],
            du_max: vec![slew_v_per_cycle],
            slew_rows: SlewRows::FirstBlock,
        },
        soft_outputs: vec![SoftOutput {
            output: OUT_ERROR,
            stride: (horizon / 2).max(1),
            from_step: 3.min(horizon),
            min: Some(-1.0),
            max: Some(1.0),
            about_reference: true,
        }],
        disturbance: DisturbanceConfig {
            kind: DisturbanceKind::Output,
            channels: Some(vec![OUT_GAUGE, OUT_ERROR]),
            coupling: Vec::new(),
        },
        kalman: KalmanConfig {
            input_noise: 1.0,
            disturbance_noise: 1e-2,
            disturbance_noise_per_state: Vec::new(),
            measurement_noise: vec![1e-2, 4e-2],
            // outliers (a force spike, a glitching gauge) are skipped for up to 24 cycles (12 ms = two
            // revolutions; a spike is held for one revolution by the per-revolution peak); larger steps
            // persisting longer are accepted as real
            innovation_gate: vec![3.0, 4.0],
            gate_max_skips: 24,
        },
        solver: SolverConfig {
            max_iter: 50,
            tol_gap: 1e-6,
            tol_feas: 1e-6,
            iterative_refinement: false,
            equilibrate: false,
            ..SolverConfig::default()
        },
        intersample: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MpcController, PreviewWindow};

    #[test]
    fn tracks_a_known_deflection_with_preview() {
        // the truth plant and the same spindle as identified (exact, for this design check)
        let sp = millcomp_sim::PztSpindle::new(0.05, 0.46, 1302.0, Some(37_000.0), None).unwrap();
        let id = IdentifiedSpindle::new(&millcomp_models::SpindleModel {
            gain_um_per_v: 0.05,
            zeta: 0.46,
            wn_rad_s: 1302.0,
            pole_rad_s: Some(37_000.0),
            dead_time_s: None,
            dead_time_pade_order: None,
            covariance: Default::default(),
        })
        .unwrap();
        let dt = 5e-4;
        let model = spindle_prediction_model(&id, dt).unwrap();
        let cfg = default_spindle_config(20, 1000.0, 100.0);
        let mut mpc = MpcController::new(&model, &cfg).unwrap();
        let mut plant = sp.discretize(dt).unwrap();
        let delta = |k: usize| if k >= 100 { 10.0 } else { 0.0 }; // known deflection step
        let mut tip = 0.0;
        let mut worst_after = 0.0f64;
        for k in 0..400 {
            let mut win = PreviewWindow::zeros(20, 2);
            win.offset_now[OUT_ERROR] = -delta(k);
            for j in 0..20 {
                win.offsets[j * 2 + OUT_ERROR] = -delta(k + 1 + j);
            }
            let y = [tip, tip - delta(k)];
            let s = mpc.step(&y, &win).unwrap();
            plant.step(s.u[0]);
            tip = plant.tip_um();
            if k > 150 {
                worst_after = worst_after.max((tip - delta(k + 1)).abs());
            }
        }
        assert!(worst_after < 0.05, "residual {worst_after}");
    }
}
