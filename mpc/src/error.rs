//! The one error type of `millcomp-mpc`.
//!
//! Every variant names what is at fault (a configuration key such as `limits.u_min[0]`, a scenario key, a
//! matrix, a file) and, where it makes sense, what is allowed — so the CLI can print it verbatim.
//! A solver that did not converge is *not* an error: it is an outcome counted in
//! [`crate::stats::SolverStats::fallbacks`].

use thiserror::Error;

/// Errors of the MPC crate (bad configuration, bad scenario, inconsistent models, I/O).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MpcError {
    /// A configuration or scenario value is out of its allowed range.
    #[error("invalid value for `{key}` = {value}: allowed {allowed}")]
    InvalidConfig {
        /// Dotted key path, e.g. `limits.u_min[0]` or `mpc.horizon`.
        key: String,
        /// The offending value as written.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// Matrix/vector dimensions disagree (model vs. configuration, preview length, measurements).
    #[error("dimension mismatch in `{what}`: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was being checked.
        what: String,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
    /// A numerical construction failed (Riccati iteration did not converge, singular matrix, NaN).
    #[error("numerical failure in `{what}`: {detail}")]
    Numerical {
        /// The operation.
        what: &'static str,
        /// Details.
        detail: String,
    },
    /// Clarabel refused the problem data at set-up (not a per-cycle solve failure).
    #[error("QP solver set-up failed in `{what}`: {detail}")]
    SolverSetup {
        /// Where.
        what: &'static str,
        /// Clarabel's message.
        detail: String,
    },
    /// Unknown controller name.
    #[error("unknown controller `{name}`: allowed {allowed}")]
    UnknownController {
        /// The name given.
        name: String,
        /// Allowed names, comma separated.
        allowed: String,
    },
    /// A scenario file key is missing, has the wrong type or an invalid value.
    #[error("scenario `{path}`: {message}")]
    Scenario {
        /// File (or `<string>`).
        path: String,
        /// Parser/validator message naming the key.
        message: String,
    },
    /// A file could not be read or written.
    #[error("cannot access `{path}`: {message}")]
    Io {
        /// The path.
        path: String,
        /// The OS message.
        message: String,
    },
    /// An error from the physics crate (bad plant parameter).
    #[error(transparent)]
    Sim(#[from] millcomp_sim::SimError),
}

/// Shorthand used inside the crate.
pub(crate) fn invalid(
    key: impl Into<String>,
    value: impl ToString,
    allowed: impl Into<String>,
) -> MpcError {
    MpcError::InvalidConfig {
        key: key.into(),
        value: value.to_string(),
        allowed: allowed.into(),
    }
}
