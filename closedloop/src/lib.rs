//! # millcomp-closedloop — the experiment harness
//!
//! Runs the controllers of `millcomp-mpc` against the truth plant of `millcomp-sim` — the only place
//! that sees both:
//! - [`scenario`]: scenario files (TOML in `datasets/scenarios/`, schema and truth-vs-model in
//!   `closedloop/SCENARIOS.md`), [`Scenario::load`], [`ControllerKind`] (`"none" | "open-loop" | "pid" |
//!   "pid-aw" | "pid-design" | "pid-tuned" | "pid-ff" | "pid-ff-read" | "threshold" | "mpc" | "mpc-nopreview" |
//!   "reactive" | "proactive"`,
//!   `FromStr`);
//! - the truth-vs-model set-up: [`calibration`] (the controllers' stiffness identified from a simulated
//!   calibration of the truth), [`model_errors`] (the controllers' force-parameter errors),
//!   [`model_files`] (identified models and response surfaces a scenario names);
//! - the closed-loop runners: [`run_scenario`] → [`RunReport`] (`stage`, `controller`,
//!   `metrics{pp_error_um, rms_error_um, max_error_um, min_error_um, actuator_travel_um[, thickness_um,
//!   thickness_error_pct]}`, `solver` for MPC), [`run_scenario_with_trace`] adds the time trace,
//!   [`stiffness_sweep`]: residual error vs stiffness error ([`groove`], [`thin_wall`], [`report`]);
//! - [`nc_axis`]: the NC feed-axis stage of `003_…txt` — its `[nc_axis]` scenario table, truth, the
//!   commissioning of the NC plant, the `none | reactive | proactive | mpc` runs and the wall's metrics;
//!   [`nc_axis_bound`]: its physical limits (the smallest wall error any controller could leave);
//! - [`changes`]: the transient a controller adds at a process change (entry, depth, feed, exit);
//! - [`touch_off`]: the tool touched off at rest or with the stack at a bias, and the bias a program
//!   and the commissioned models leave room for;
//! - [`faults`]: force spikes, stuck sensors and solver failures injected into what the controllers see;
//! - [`recording`]: the spindle MPC's QPs recorded in closed loop (`bench/mpc-vs-casadi`,
//!   `benches/solve.rs`);
//! - [`machine`]: the simulated machine of `millcomp demo`, drawn once from a seed and only measured
//!   (its calibration records, profilometer sessions and closed-loop cuts with controllers from a
//!   user's bundle); the truth stays inside;
//! - [`batch`]: controllers compared over designed conditions — plan and fingerprint, shards, resume,
//!   the results table, the ANOVA of every metric with the controller as a factor, and the controllers
//!   paired scenario by scenario.
//!
//! ```
//! use millcomp_closedloop::{ControllerKind, Scenario, run_scenario};
//! // the published 20° S7 groove, shortened to its first 2 mm (1.2 s of cut)
//! let text = include_str!("../../datasets/scenarios/groove_s7_20deg.toml");
//! let mut s = Scenario::from_toml_str(text, "groove_s7_20deg.toml").unwrap();
//! s.groove.as_mut().unwrap().length_mm = 2.0;
//! let none = run_scenario(&s, ControllerKind::None).unwrap();
//! let mpc = run_scenario(&s, ControllerKind::Mpc).unwrap();
//! // 1.2 s simulated at the 20 kHz stage rate; the MPC solved at 2 kHz, never falling back
//! assert!((none.simulated_s - 1.2).abs() < 1e-3);
//! assert_eq!(mpc.solver.unwrap().fallbacks, 0);
//! // the uncompensated groove is shallower everywhere; the MPC removes most of its error
//! assert!(none.metrics.max_error_um <= 1e-9);
//! assert!(mpc.metrics.pp_error_um < 0.5 * none.metrics.pp_error_um);
//! ```
#![warn(missing_docs)]

pub mod batch;
pub mod cache;
pub mod calibration;
pub mod changes;
pub mod commissioning;
pub mod commissioning_plan;
pub mod compare;
pub mod error;
pub mod faults;
pub mod figures;
pub mod groove;
pub mod machine;
pub mod model_errors;
pub mod model_files;
pub mod nc_axis;
pub mod nc_axis_bound;
pub mod nc_axis_scenario;
pub mod optimum;
pub mod parts;
pub mod plot;
pub mod profile;
pub mod realtime;
pub mod recording;
pub mod report;
pub mod runner;
pub mod scenario;
pub mod stats;
pub mod thin_wall;
pub mod touch_off;

pub use error::{ClosedLoopError, error_chain};
pub use report::{Metrics, RunOutput, RunReport, WallReport};
pub use runner::{run_scenario, run_scenario_with_trace, stiffness_sweep};
pub use scenario::{ControllerKind, Scenario};
