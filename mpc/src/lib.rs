//! # millcomp-mpc — deflection compensation controllers
//!
//! The controllers only: a linear, offset-free model-predictive controller with preview of the planned
//! process, solved every control cycle with [Clarabel](https://clarabel.org) (QP built once, only
//! `q`/`b` updated per cycle), and the published baselines it is compared against (PID with the
//! thesis' signal chain, open-loop compensation, the thin wall's 0.5 µm threshold compensation, none).
//! They are built from the controllers' own models — the types of [`identified`], which only
//! identified models and the catalogue can make (identified stiffness, force predictor, spindle model) and the planned process, and read the measured signals through sim's filters
//! (`millcomp_sim::filters`: the 500 Hz low-pass, the nested peak-and-hold, the one sliding peak
//! detector). They never see the truth plant: running them against it is `millcomp-closedloop`'s job.
//!
//! Core pieces:
//! - [`MpcConfig`] (serde; keys documented in `mpc/CONFIG.md`), validated with errors naming the key;
//! - [`kalman::AugmentedModel`] / [`kalman::KalmanFilter`]: disturbance-augmented model and steady-state
//!   Kalman filter;
//! - [`qp::CondensedQp`]: the condensed QP and its persistent Clarabel solver;
//! - [`MpcController`]: one call per cycle, [`MpcController::step`], with fallback and clamping;
//! - [`SolverStats`]: `solves`, `median_us`, `p99_us`, `fallbacks`;
//! - [`replay`]: a recorded QP sequence and its replay with Clarabel (`bench/mpc-vs-casadi`).
//!
//! Controllers per stage:
//! - [`groove`] (PZT spindle, `000_…txt` ch. 6–7): [`groove::GrooveController`] with
//!   [`groove::NoneController`], [`groove::OpenLoopController`], [`groove::PidController`] and
//!   [`groove::MpcGrooveController`], previewing a [`groove::DeflectionPlan`] computed from the program
//!   (sim's `GrooveProgram`), the [`predictor::ForcePredictor`] and the controllers' stiffness;
//!   [`spindle_mpc`] is the spindle MPC design, [`pid`] the published PID, [`stroke`] the whole-cut
//!   plan within the actuator's reach;
//! - [`nc_axis`] (NC feed axes, `003_…txt`): [`nc_axis::NcController`] with the none, reactive (notch
//!   chain), proactive (6 Hz low-pass + offset curve) and MPC controllers, built from the identified
//!   Kienzle model, feed axes and stiffness of a commissioning, previewing [`nc_axis::NcPlan`];
//! - [`thin_wall`] (linear-motor stage, `004_…txt`): [`thin_wall::ThinWallController`] with the none,
//!   open-loop, threshold, PI and MPC controllers on the controllers' [`thin_wall::WallPlan`].
//!
//! ```
//! use millcomp_models::{ForceModelParams, SpindleModel, StiffnessModel};
//! use millcomp_mpc::groove::{GrooveController, OpenLoopController, DeflectionPlan};
//! use millcomp_mpc::identified::{
//!     IdentifiedForceModel, IdentifiedSpindle, IdentifiedStiffness, NominalTool,
//! };
//! use millcomp_mpc::predictor::ForcePredictor;
//! use millcomp_sim::groove::GrooveProgram;
//! // the controllers' models, identified (here typed in: a commissioning bundle gives them) on the
//! // catalogue tool; the thesis' 20° program
//! let program = GrooveProgram::thesis(20.0);
//! let tool = NominalTool::thesis_ball_end("S7");
//! let p = ForceModelParams {
//!     fitted: [("wearland_um".to_string(), 8.0)].into(),
//!     fixed: Default::default(),
//!     covariance: Default::default(),
//! };
//! let force = ForcePredictor::Mechanistic(IdentifiedForceModel::new(&p, &tool).unwrap());
//! let stiffness = IdentifiedStiffness::new(&StiffnessModel {
//!     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
//! }).unwrap();
//! let plan = DeflectionPlan::new(&program, &force, &stiffness, tool.radius_um, 0.01).unwrap();
//! let spindle = IdentifiedSpindle::new(&SpindleModel {
//!     gain_um_per_v: 0.05, zeta: 0.46, wn_rad_s: 1302.0, pole_rad_s: None, dead_time_s: None,
//!     dead_time_pade_order: None, covariance: Default::default(),
//! }).unwrap();
//! let mut open_loop = OpenLoopController::new(plan.clone(), &program, &spindle, 1000.0);
//! // half-way (6 s, x = 10 mm, 40 µm programmed depth) it drives the tip to the planned deflection
//! let v = open_loop.command(None, 6.0);
//! let tip_um = v * spindle.plant().gain_um_per_v;
//! let dz = plan.deflection_at(10.0);
//! assert!((tip_um * 20f64.to_radians().sin() - dz).abs() < 1e-9);
//! assert!(dz > 0.0 && v < 1000.0);
//! ```
#![warn(missing_docs)]

pub mod config;
pub mod controller;
pub mod error;
pub mod groove;
pub mod identified;
pub mod kalman;
pub mod nc_axis;
pub mod pid;
pub mod predictor;
pub mod qp;
pub mod replay;
pub mod spindle_mpc;
pub mod stats;
pub mod stroke;
pub mod thin_wall;
pub mod tuning;

pub use config::MpcConfig;
pub use controller::{MpcController, MpcCycle, MpcStep, PreviewWindow};
pub use error::MpcError;
pub use stats::SolverStats;
