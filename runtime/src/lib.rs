//! # millcomp-runtime — the controller a machine calls
//!
//! A groove controller of `millcomp-mpc` (none, open loop, the PIDs, the MPC) packaged for a real
//! control loop: built once from what a user has — a commissioned model bundle (`millcomp commission
//! --out`, [`millcomp_models::ModelBundle`]) and a program file ([`Program`]: the NC program the MPC
//! previews and the controller's settings) — then one [`Controller::step`] per control period, the
//! [`Measurement`] (the NC's position, the force and gauge readings) in and the [`Command`] (the PZT
//! amplifier's voltage and what happened in the cycle) out.
//!
//! - no heap allocation, lock, I/O or system call in `step` (a test steps every controller 10 000
//!   times under a counting allocator: `tests/alloc.rs`);
//! - the MPC's cycle [`Budget`]: an iteration cap (deterministic: replays and tests give the same
//!   commands on any machine) or the wall clock (on the machine: Clarabel stopped at the deadline, a
//!   late plan replaced by the fallback);
//! - the state between cycles is the controller's filters, integrators, estimators and last plan, and
//!   the runtime's cycle index and last readings; [`Controller::reset`] returns it to the state right
//!   after construction;
//! - [`replay`]: a recorded sensor log through a controller, with every step timed;
//! - [`export`]: the MPC's prediction model, weights, constraints and horizon, and one cycle's QP, as
//!   a JSON document another toolchain (CasADi, do-mpc, acados) can rebuild the problem from.
//!
//! The truth stays hidden: a controller is built from a bundle and a program, nothing else. The
//! closed-loop simulation (`millcomp-closedloop`), `millcomp replay`, the C ABI (`millcomp-ffi`) and the
//! Python package all build and step their controllers here, so a simulated run's sensor log replayed
//! through the same bundle and program gives the simulation's commands bit for bit.
//!
//! ```
//! use millcomp_runtime::{Controller, ControllerKind, Measurement, Program, flags};
//! # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
//! # let bundle_path = std::path::PathBuf::from(format!("{dir}bundle_s7.toml"));
//! # let program_path = std::path::PathBuf::from(format!("{dir}ramp_20deg.toml"));
//! let bundle = millcomp_runtime::load_bundle(&bundle_path).unwrap();
//! let mut program = Program::load(&program_path).unwrap();
//! program.controller.kind = ControllerKind::PidTuned;
//! let mut pid = Controller::from_bundle(&bundle, &program).unwrap();
//! // before the first reading the PI holds the touch-off's voltage
//! assert_eq!(pid.step(&Measurement::NONE).voltage_v, 0.0);
//! // a gauge below the tip the measured force asks for: the PI drives the stack up
//! let c = pid.step(&Measurement { x_mm: f64::NAN, force_n: 2.0, gauge_um: 0.0 });
//! assert!(c.voltage_v > 0.0 && c.flags & flags::PLANNED == 0);
//! ```
#![warn(missing_docs)]

pub mod controller;
pub mod error;
pub mod export;
pub mod kind;
pub mod program;
pub mod replay;

pub use controller::{
    Command, Controller, CycleCounts, Measurement, Models, Origins, PLAN_DX_MM, Parts, flags,
    load_bundle,
};
pub use error::RuntimeError;
pub use kind::ControllerKind;
pub use program::{Budget, ControllerSettings, NcProgram, Program};
