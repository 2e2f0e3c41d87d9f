//! The one error type of `millcomp-mpc`.
//!
//! Every variant names what is at fault (a configuration key such as `limits.u_min[0]`, a matrix, the
//! force predictor) and, where it makes sense, what is allowed — so the CLI can print it verbatim.
//! A solver that did not converge is *not* an error: it is an outcome counted in
//! [`crate::stats::SolverStats::fallbacks`].

use thiserror::Error;

/// Errors of the controllers (bad configuration, inconsistent models, solver set-up).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MpcError {
    /// A configuration value is out of its allowed range.
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
    /// An MPC configuration in TOML does not parse (the parser's message names the key).
    #[error("MPC configuration (TOML): {message}")]
    ConfigToml {
        /// The parser's message.
        message: String,
    },
    /// The response-surface force predictor could not evaluate a point.
    #[error("force predictor `{path}`: {message}")]
    Predictor {
        /// Where the response surface came from (a file, or `<test>`).
        path: String,
        /// The response surface's message.
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
