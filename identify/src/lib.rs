//! # millcomp-identify
//!
//! Least-squares identification with honest uncertainty for the millcomp models.
//!
//! * Engine: weighted linear least squares ([`fit_linear`], QR/SVD, rank deficiency named by
//!   parameter) and bounded nonlinear least squares on argmin ([`fit_nonlinear`], trust region
//!   with Levenberg–Marquardt steps solved by SVD, statuses `converged`, `stalled_at_rounding_level`
//!   and `not_converged`; [`CurveFit`] fits `y ≈ f(x, θ)` from closures), both returning a
//!   [`FitReport`] with the residual sum of squares, standard
//!   errors, t-based 95 % intervals, covariance, correlation, condition number, identifiability
//!   warnings and residual diagnostics.
//! * Models are residual operators with Jacobians ([`ResidualModel`] = argmin `Operator` +
//!   `Jacobian`); [`check_jacobian`] is the finite-difference test every analytic Jacobian has.
//! * Errors ([`IdentifyError`]) are for input that cannot be fitted; a fit that ran always gives a
//!   report whose `status` says how it ended.
//! * The discrepancy workflow built on this engine is its own crate, `millcomp-diagnose`.
#![warn(missing_docs)]

pub mod columns;
pub mod curve;
pub mod error;
mod hac;
pub mod jacobian_check;
pub mod linear;
pub mod nonlinear;
pub mod regress;
pub mod report;
pub mod units;
pub mod validate;

pub use columns::{Columns, IdentifyOptions, Target, identify_columns};
pub use curve::CurveFit;
pub use error::{IdentifyError, Result};
pub use jacobian_check::{JacobianCheck, check_jacobian, fd_jacobian, fd_jacobian_within};
pub use linear::{LinearFit, LinearMethod, fit_linear};
pub use nonlinear::{NlsOptions, NonlinearFit, ParamSpec, ResidualModel, fit_nonlinear};
pub use report::{FitReport, FitStatus, NamedMatrix, ResidualDiagnostics, RmsResidual};
pub mod targets;

pub use millcomp_models::{Derived, IdentifiedModel};
pub use targets::Identified;
