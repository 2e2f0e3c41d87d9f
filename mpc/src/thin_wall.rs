//! The thin-wall controllers (`004_…txt`): the linear-motor stage moves the work towards the tool by the
//! estimated deflection, one command per stage step (one grid cell, ≈ 94 ms, ≈ 31 revolutions at the
//! assumed 20 000 rpm: time for the 004 "peak of several successive cycles" force value). The command of
//! step k is computed from the measurement of step k − 1 ([`ThinWallMeasurement`]).
//!
//! The controllers' deflection models (never the truth's internals) come as a [`WallPlan`] made by
//! [`plan_wall`] from the controllers' own wall model (sim's stage equations run as a digital twin with
//! the controllers' parameters):
//! - **wall**: eq. 18 at the cutting height with `I_ave` (eq. 17) of the *planned* geometry;
//! - **tool**: `F / k_tool` with the controllers' (identified) tool stiffness.
//!
//! Controllers:
//! - [`ThresholdController`] (004 §3.2, faithful; sim's [`ThresholdCompensator`], the one
//!   implementation): deformation from the *published* model — eq. 18 as printed (cantilever of height
//!   l loaded at its free end, evaluated at the cutting height; the wall only) — `w = F_meas · c_eq18`;
//!   if the increment `w − u` exceeds 0.5 µm, the stage moves by it;
//! - [`OpenLoopController`]: the planned deflection (force model ÷ stiffness along the planned cut) as
//!   the stage path;
//! - [`PiController`]: discrete PI (velocity form, kp 0.3, ki 0.7 per cycle; the thesis gains belong to
//!   the PZT spindle and do not apply to a static stage) on `F_meas·(c_wall + 1/k_tool) − stage`;
//! - [`MpcThinWallController`]: the offset-free MPC with preview of the planned deflection (the known
//!   process changes here are the layer transitions, where the cutting height and compliance jump),
//!   model `x⁺ = u` (stage), outputs (stage position, thickness excess `δ − x`).

use millcomp_sim::DiscreteLti;
pub use millcomp_sim::thinwall::WallPlan;
use millcomp_sim::thinwall::{THRESHOLD_004_UM, ThresholdCompensator, plan_compensated_wall};
use nalgebra::DMatrix;

use crate::config::{
    CycleBudget, DisturbanceConfig, DisturbanceKind, KalmanConfig, Limits, MpcConfig, SlewRows,
    SoftOutput, SolverConfig, Weights,
};
use crate::controller::{MpcController, PreviewWindow};
use crate::error::MpcError;
use crate::identified::WallModel;
use crate::stats::SolverStats;

/// The 004 compensation threshold (µm), sim's [`millcomp_sim::thinwall::THRESHOLD_004_UM`].
pub const THRESHOLD_UM: f64 = THRESHOLD_004_UM;
/// Stage travel used as the command limits (µm; assumed, 004 does not give the stroke).
pub const STAGE_MIN_UM: f64 = -20.0;
/// Upper end of the stage travel (µm).
pub const STAGE_MAX_UM: f64 = 60.0;
/// Proportional gain of the thin-wall PI (per cycle, velocity form).
pub const PI_KP: f64 = 0.3;
/// Integral gain of the thin-wall PI (per cycle).
pub const PI_KI: f64 = 0.7;

/// What the thin-wall controllers measure after each stage step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThinWallMeasurement {
    /// Measured force (N).
    pub force_meas_n: f64,
    /// Stage position read on the grating ruler (µm, 0.1 µm resolution). The ruler reports where the
    /// stage was sent; the stage's ±0.5 µm positioning accuracy error (004 §2.2) is not in it.
    pub encoder_um: f64,
}

/// Plan a wall with the controllers' model ([`WallModel`]: the programmed geometry, the published
/// material and force coefficient, the identified tool stiffness): sim's [`plan_compensated_wall`] run as
/// a digital twin compensating perfectly.
///
/// # Errors
/// [`MpcError::Sim`] for an invalid wall configuration.
pub fn plan_wall(model: &WallModel) -> Result<WallPlan, MpcError> {
    Ok(plan_compensated_wall(model.config())?)
}

/// Index of the plan step whose measurement arrives at step `k` (`k − 1`, clamped to the plan).
fn measured_step(plan: &WallPlan, k: usize) -> usize {
    k.saturating_sub(1)
        .min(plan.deflection_um.len().saturating_sub(1))
}

/// The controllers' estimate of the deflection (wall + tool, µm) at step `k` from the measurement of
/// step `k − 1`: measured force × the planned compliance of that step; 0 before the first measurement.
pub fn estimated_deflection_um(
    plan: &WallPlan,
    k: usize,
    last: Option<&ThinWallMeasurement>,
) -> f64 {
    let c_full = plan.wall_compliance[measured_step(plan, k)] + plan.tool_compliance;
    last.map(|m| m.force_meas_n * c_full).unwrap_or(0.0)
}

/// The MPC of the thin-wall stage (model `x⁺ = u`, outputs [stage, excess]) with control period `dt_s`
/// (it sets the cycle's time budget) and the harness's `budget`.
///
/// # Errors
/// Configuration errors of [`MpcController::new`] (e.g. a horizon of 0, a period ≤ 0).
pub fn thin_wall_mpc(
    horizon: usize,
    dt_s: f64,
    budget: CycleBudget,
) -> Result<MpcController, MpcError> {
    let a = DMatrix::from_element(1, 1, 0.0);
    let b = DMatrix::from_element(1, 1, 1.0);
    let c = DMatrix::from_column_slice(2, 1, &[1.0, -1.0]);
    let model = DiscreteLti::new(a, b, c, DMatrix::zeros(2, 1), dt_s)?;
    let mut cfg = MpcConfig {
        horizon,
        control_horizon: None,
        move_blocking: None,
        weights: Weights {
            output: vec![0.0, 1.0],
            input_rate: vec![1e-3],
            input: vec![0.0],
            input_target: vec![0.0],
            slack_linear: 1e3,
            slack_quadratic: 1e2,
        },
        limits: Limits {
            u_min: vec![STAGE_MIN_UM],
            u_max: vec![STAGE_MAX_UM],
            du_max: vec![20.0],
            slew_rows: SlewRows::EveryBlock,
        },
        soft_outputs: vec![SoftOutput {
            output: 1,
            stride: (horizon / 2).max(1),
            from_step: 1,
            min: Some(-1.0),
            max: Some(1.0),
            about_reference: false,
        }],
        disturbance: DisturbanceConfig {
            kind: DisturbanceKind::Output,
            channels: Some(vec![1]),
            coupling: Vec::new(),
        },
        kalman: KalmanConfig {
            input_noise: 1e-2,
            disturbance_noise: 1e-2,
            disturbance_noise_per_state: Vec::new(),
            // grating ruler 0.1 µm resolution; excess channel: force noise × compliance + model scatter
            measurement_noise: vec![1e-3, 1e-2],
            innovation_gate: vec![2.0, 5.0],
            gate_max_skips: 2,
        },
        solver: SolverConfig {
            max_iter: 50,
            tol_gap: 1e-10,
            tol_feas: 1e-10,
            iterative_refinement: false,
            ..SolverConfig::default()
        },
        intersample: None,
    };
    budget.apply(&mut cfg.solver);
    MpcController::new(&model, &cfg)
}

/// A thin-wall controller, one command per stage step.
pub trait ThinWallController {
    /// Stage command (µm) for step `k`, from the measurement of step `k − 1` (None at the first step).
    fn command(&mut self, k: usize, last: Option<&ThinWallMeasurement>) -> f64;
    /// Make the next `cycles` QP solves fail (fault injection; MPC only, a no-op for the others).
    fn inject_solver_failures(&mut self, _cycles: usize) {}
    /// Per-cycle QP times so far (µs; MPC only, empty for the others).
    fn solve_times_us(&self) -> &[f64] {
        &[]
    }
    /// QP statistics (MPC only).
    fn solver_stats(&self) -> Option<SolverStats> {
        None
    }
}

/// No compensation: the stage stays at 0 µm.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoneController;

impl ThinWallController for NoneController {
    fn command(&mut self, _: usize, _: Option<&ThinWallMeasurement>) -> f64 {
        0.0
    }
}

/// The planned deflection as the stage path.
#[derive(Debug, Clone)]
pub struct OpenLoopController {
    plan: WallPlan,
}

impl OpenLoopController {
    /// From the controllers' plan of the wall.
    pub fn new(plan: WallPlan) -> Self {
        Self { plan }
    }
}

impl ThinWallController for OpenLoopController {
    fn command(&mut self, k: usize, _: Option<&ThinWallMeasurement>) -> f64 {
        self.plan.deflection_um[k.min(self.plan.deflection_um.len() - 1)]
    }
}

/// The published 004 iterative compensation with the 0.5 µm threshold (sim's [`ThresholdCompensator`])
/// on the published deformation model (eq. 18 as printed, the wall only).
#[derive(Debug, Clone)]
pub struct ThresholdController {
    plan: WallPlan,
    compensator: ThresholdCompensator,
}

impl ThresholdController {
    /// From the controllers' plan of the wall (its `eq18_compliance`).
    pub fn new(plan: WallPlan) -> Self {
        Self {
            plan,
            compensator: ThresholdCompensator::paper(),
        }
    }
}

impl ThinWallController for ThresholdController {
    fn command(&mut self, k: usize, last: Option<&ThinWallMeasurement>) -> f64 {
        match last {
            // the published model: eq. 18 as printed, the wall only (sim's one implementation)
            Some(m) => self
                .compensator
                .update(m.force_meas_n * self.plan.eq18_compliance[measured_step(&self.plan, k)]),
            None => self.compensator.command_um(),
        }
    }
}

/// Discrete PI (velocity form, [`PI_KP`], [`PI_KI`]) on the estimated deflection minus the stage
/// position.
#[derive(Debug, Clone)]
pub struct PiController {
    plan: WallPlan,
    u: f64,
    e_prev: f64,
}

impl PiController {
    /// From the controllers' plan of the wall (its compliances).
    pub fn new(plan: WallPlan) -> Self {
        Self {
            plan,
            u: 0.0,
            e_prev: 0.0,
        }
    }
}

impl ThinWallController for PiController {
    fn command(&mut self, k: usize, last: Option<&ThinWallMeasurement>) -> f64 {
        if let Some(m) = last {
            let e = estimated_deflection_um(&self.plan, k, last) - m.encoder_um;
            if e.is_finite() {
                self.u += PI_KP * (e - self.e_prev) + PI_KI * e;
                self.e_prev = e;
            }
        }
        self.u
    }
}

/// The offset-free MPC of [`thin_wall_mpc`] with preview of the planned deflection.
#[derive(Debug)]
pub struct MpcThinWallController {
    plan: WallPlan,
    mpc: MpcController,
    window: PreviewWindow,
}

impl MpcThinWallController {
    /// From the controllers' plan of the wall and the wanted horizon, shortened to the plan's length
    /// (at least 2 cycles); the harness's cycle `budget`.
    ///
    /// # Errors
    /// Those of [`thin_wall_mpc`].
    pub fn new(plan: WallPlan, horizon: usize, budget: CycleBudget) -> Result<Self, MpcError> {
        let h = horizon.min(plan.deflection_um.len().max(2)).max(2);
        Ok(Self {
            mpc: thin_wall_mpc(h, plan.dt_s, budget)?,
            plan,
            window: PreviewWindow::zeros(h, 2),
        })
    }

    /// The MPC inside.
    pub fn mpc(&self) -> &MpcController {
        &self.mpc
    }
}

impl ThinWallController for MpcThinWallController {
    fn command(&mut self, k: usize, last: Option<&ThinWallMeasurement>) -> f64 {
        let cycle_start = std::time::Instant::now();
        let n_steps = self.plan.deflection_um.len();
        let h = self.mpc.config().horizon;
        // y_k = [x_k, δ_{k−1} − x_k]: the excess channel's known offset at cycle k is the planned
        // deflection of step k − 1, at cycle k + j that of step k + j − 1
        self.window.offset_now[1] = self.plan.deflection_um[measured_step(&self.plan, k)];
        for j in 0..h {
            self.window.offsets[j * 2 + 1] = self.plan.deflection_um[(k + j).min(n_steps - 1)];
        }
        let stage_meas = last.map_or(0.0, |m| m.encoder_um);
        let y = match last {
            Some(_) => [
                stage_meas,
                estimated_deflection_um(&self.plan, k, last) - stage_meas,
            ],
            None => [f64::NAN, f64::NAN],
        };
        self.mpc
            .step_from(cycle_start, &y, &self.window)
            .map(|s| s.u[0])
            .unwrap_or(stage_meas)
    }

    fn inject_solver_failures(&mut self, cycles: usize) {
        self.mpc.inject_solver_failures(cycles);
    }

    fn solve_times_us(&self) -> &[f64] {
        self.mpc.solve_times_us()
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        Some(self.mpc.stats())
    }
}
