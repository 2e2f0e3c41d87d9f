//! The MPC's problem as a JSON document another toolchain can rebuild and compare against: the
//! prediction model, the configuration (weights, limits, horizon, blocking), and the first cycle of a
//! program — its state estimate, preview window, the QP in Clarabel's form and the plan Clarabel found
//! (docs/export-mpc.md).

use millcomp_models::ModelBundle;
use millcomp_mpc::groove::{GrooveController, MpcGrooveController, TouchOff};
use millcomp_mpc::qp::{QpData, QpStatus};
use millcomp_mpc::{MpcConfig, PreviewWindow};
use serde::Serialize;

use crate::controller::{Models, Origins, mpc_settings_for};
use crate::error::RuntimeError;
use crate::program::Program;

/// The format's name and version (bumped on an incompatible change).
pub const FORMAT: &str = "millcomp-mpc-export";
/// See [`FORMAT`].
pub const VERSION: u32 = 1;

/// A dense matrix, row by row.
pub type Rows = Vec<Vec<f64>>;

/// The augmented prediction model `ξ⁺ = A ξ + B u`, `y = C ξ + w` (internal coordinates: the plant's
/// states scaled, then the disturbance states).
#[derive(Debug, Clone, Serialize)]
pub struct ExportedModel {
    /// Sample time of the MPC (s).
    pub dt_s: f64,
    /// State matrix (n × n).
    pub a: Rows,
    /// Input matrix (n × n_inputs).
    pub b: Rows,
    /// Output matrix (n_outputs × n).
    pub c: Rows,
    /// Plant states (the first), then disturbance states.
    pub n_plant: usize,
    /// Disturbance states.
    pub n_dist: usize,
}

/// The first cycle: the data of its QP and Clarabel's answer.
#[derive(Debug, Clone, Serialize)]
pub struct FirstCycle {
    /// The filtered augmented state estimate the QP starts from (internal coordinates).
    pub state_estimate: Vec<f64>,
    /// The previous command (the touch-off's voltage).
    pub u_prev: Vec<f64>,
    /// The preview window (known output offsets and references over the horizon).
    pub window: PreviewWindow,
    /// The QP: `min ½zᵀPz + qᵀz s.t. Az + s = b, s ≥ 0` (P upper triangle, CSC).
    pub qp: QpData,
    /// Clarabel's status.
    pub status: QpStatus,
    /// Clarabel's decision vector `[v; s]`.
    pub solution: Vec<f64>,
    /// The plan: the inputs per MPC period over the horizon (the blocks expanded).
    pub plan: Vec<f64>,
}

/// The document.
#[derive(Debug, Clone, Serialize)]
pub struct MpcExport {
    /// [`FORMAT`].
    pub format: &'static str,
    /// [`VERSION`].
    pub version: u32,
    /// The MPC's horizon (MPC periods).
    pub horizon: usize,
    /// The prediction model.
    pub model: ExportedModel,
    /// The MPC's configuration: weights, limits, blocking, soft outputs, solver settings
    /// (`mpc/CONFIG.md`).
    pub config: MpcConfig,
    /// The first cycle of the program.
    pub first_cycle: FirstCycle,
}

fn rows(m: &nalgebra::DMatrix<f64>) -> Rows {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// The MPC of `program` (whatever its `[controller] kind`) built from `bundle` and stepped once before
/// any reading, as a document.
///
/// # Errors
/// As [`crate::Controller::from_bundle_at`].
pub fn export_mpc(
    bundle: &ModelBundle,
    program: &Program,
    origins: &Origins,
) -> Result<MpcExport, RuntimeError> {
    program.validate(&origins.program)?;
    let material = program
        .program
        .material
        .clone()
        .unwrap_or_else(|| bundle.material.clone());
    let models = Models::from_bundle(bundle, &origins.bundle, &material)?;
    let nc = program.program.groove_program();
    let build = |source| RuntimeError::Build {
        controller: "mpc",
        bundle: origins.bundle.clone(),
        program: origins.program.clone(),
        source: Box::new(source),
    };
    let plan = models.plan(&nc).map_err(build)?;
    let settings = mpc_settings_for(&models, origins, &program.controller)?;
    let mut c = MpcGrooveController::new(
        plan,
        &nc,
        &models.spindle,
        &models.stiffness,
        models.tool.flutes,
        &settings,
    )
    .map_err(build)?;
    let at: TouchOff = program.controller.touch_off;
    c.touched_off(at);
    let u_prev = c.mpc().previous_input().to_vec();
    c.command(None, 0.0);
    let mpc = c.mpc();
    let m = mpc.model();
    Ok(MpcExport {
        format: FORMAT,
        version: VERSION,
        horizon: mpc.config().horizon,
        model: ExportedModel {
            dt_s: m.dt_s,
            a: rows(&m.a),
            b: rows(&m.b),
            c: rows(&m.c),
            n_plant: m.n_plant,
            n_dist: m.n_dist,
        },
        config: mpc.config().clone(),
        first_cycle: FirstCycle {
            state_estimate: mpc.kalman().estimate().iter().copied().collect(),
            u_prev,
            window: c.window().clone(),
            qp: mpc.qp().snapshot(),
            status: c.last_cycle().map_or(QpStatus::Other, |l| l.status),
            solution: mpc.qp().solution().to_vec(),
            plan: mpc.plan().to_vec(),
        },
    })
}
