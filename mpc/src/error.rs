//! The one error type of `millcomp-mpc`.
//!
//! Every variant names what is at fault (a configuration key such as `limits.u_min[0]`, a matrix, the
//! force predictor) and, where it makes sense, what is allowed — so the CLI can print it verbatim.
//! A solver that did not converge is *not* an error: it is an outcome counted in
//! [`crate::stats::SolverStats::fallbacks`]. Where an underlying error exists (Clarabel's, the physics
//! crate's, the TOML parser's, the response surface's) it is kept as the
//! [`std::error::Error::source`] of the variant, not flattened into its message.

use thiserror::Error;

/// The errors Clarabel reports at set-up ([`clarabel::solver::SolverError`]), on a data update
/// ([`clarabel::solver::DataUpdateError`]) or on a settings change (clarabel's `SettingsError`, not public in 0.11).
pub type ClarabelError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Errors of the controllers (bad configuration, inconsistent models, solver set-up).
#[derive(Debug, Error)]
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
    /// Clarabel refused the problem data at set-up, a data update or a settings change (not a per-cycle
    /// solve failure).
    #[error("QP solver set-up failed in `{what}`")]
    SolverSetup {
        /// Where (`DefaultSolver::new`, `update_q`, `update_b`, `update_settings`, `data updating`).
        what: &'static str,
        /// Clarabel's error.
        #[source]
        source: ClarabelError,
    },
    /// An MPC configuration in TOML does not parse (the parser's message names the key).
    #[error("MPC configuration (TOML) does not parse")]
    ConfigToml {
        /// The TOML parser's error.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// An identified model's parameters are not accepted by the physics crate's model equations.
    #[error("invalid value for `{key}` = {value}: the physics crate rejects it")]
    IdentifiedModel {
        /// Which model (`spindle_model`, `force_model`).
        key: String,
        /// The offending parameters as written.
        value: String,
        /// The physics crate's error.
        #[source]
        source: millcomp_sim::SimError,
    },
    /// The response-surface force predictor could not evaluate a point.
    #[error("force predictor `{path}`")]
    Predictor {
        /// Where the response surface came from (a file, or `<test>`).
        path: String,
        /// The response surface's error.
        #[source]
        source: Box<millcomp_models::ModelError>,
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
