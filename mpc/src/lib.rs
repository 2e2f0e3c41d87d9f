//! # millcomp-mpc — deflection compensation controllers
//!
//! A linear, offset-free model-predictive controller with preview of the planned process, solved every
//! control cycle with [Clarabel](https://clarabel.org) (QP built once, only `q`/`b` updated per cycle), and
//! the published baselines it is compared against (PID with the thesis' signal chain, open-loop
//! path pre-shifting, thin-wall iterative compensation with a 0.5 µm threshold).
//!
//! Core pieces:
//! - [`MpcConfig`] (serde; keys documented in `mpc/CONFIG.md`), validated with errors naming the key;
//! - [`kalman::AugmentedModel`] / [`kalman::KalmanFilter`]: disturbance-augmented model and steady-state
//!   Kalman filter;
//! - [`qp::CondensedQp`]: the condensed QP and its persistent Clarabel solver;
//! - [`MpcController`]: one call per cycle, [`MpcController::step`], with fallback and clamping;
//! - [`SolverStats`]: `solves`, `median_us`, `p99_us`, `fallbacks`.
//!
//! Closed loop (what `millcomp simulate SCENARIO --controller …` calls):
//! - [`Scenario::load`] (TOML in `datasets/scenarios/`, schema and truth-vs-model in `mpc/SCENARIOS.md`);
//! - [`ControllerKind`] (`"none" | "open-loop" | "pid" | "pid-aw" | "pid-design" | "threshold" | "mpc"`,
//!   `FromStr`);
//! - [`run_scenario`] → [`RunReport`] (`stage`, `controller`, `metrics{pp_error_um, rms_error_um,
//!   max_error_um, min_error_um, actuator_travel_um[, thickness_um, thickness_error_pct]}`, `solver`
//!   for MPC), [`run_scenario_with_trace`] adds the time trace for `--out run.csv`;
//! - [`stiffness_sweep`]: residual error vs stiffness error.
//!
//! Benchmarks: `benches/solve.rs` (criterion, per-cycle solve at horizon 20/40) and
//! `bash bench/mpc-vs-casadi` (Clarabel vs CasADi qpOASES/DAQP on a recorded QP sequence,
//! [`replay`]).
#![warn(missing_docs)]

pub mod config;
pub mod controller;
pub mod error;
pub mod groove;
pub mod groove_run;
pub mod kalman;
pub mod pid;
pub mod predictor;
pub mod qp;
pub mod replay;
pub mod report;
pub mod runner;
pub mod scenario;
pub mod spindle_mpc;
pub mod stats;
pub mod thin_wall;
pub mod thinwall_run;
pub mod truth;

pub use config::MpcConfig;
pub use controller::{MpcController, MpcStep, PreviewWindow};
pub use error::MpcError;
pub use report::{Metrics, RunOutput, RunReport, WallReport};
pub use runner::{run_scenario, run_scenario_with_trace, stiffness_sweep};
pub use scenario::{ControllerKind, Scenario};
pub use stats::SolverStats;
