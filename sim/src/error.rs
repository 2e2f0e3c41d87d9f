//! The one error type of `millcomp-sim`.
//!
//! Every variant names what is at fault (parameter, key, dimension) and, where it makes sense, the allowed
//! range, so that a CLI can print it verbatim. Where an underlying error exists (the OS's, the TOML
//! parser's, the noise distribution's) it is kept as the [`std::error::Error::source`] of the variant,
//! not flattened into its message: print the chain to see it.

use thiserror::Error;

/// Errors raised by the physics crate. Outcomes (e.g. a stage that saturated) are not errors.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SimError {
    /// A physical parameter is outside its allowed range (or not finite).
    #[error("invalid parameter `{name}` = {value}: allowed {allowed}")]
    InvalidParameter {
        /// Parameter name, with its unit suffix (e.g. `tilt_deg`).
        name: &'static str,
        /// The value that was given.
        value: f64,
        /// Human-readable allowed range, e.g. `0 <= tilt_deg < 90`.
        allowed: &'static str,
    },
    /// Matrix/vector dimensions of a model do not agree.
    #[error("dimension mismatch in `{what}`: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Which matrix or vector.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
    /// A numerical operation failed (singular matrix, non-finite result).
    #[error("numerical failure in `{what}`: {detail}")]
    Numerical {
        /// The operation.
        what: &'static str,
        /// Details.
        detail: String,
    },
    /// A session file key has an invalid value (or the plan is empty).
    #[error("session key `{key}`: {message}")]
    Session {
        /// Dotted key path, e.g. `grooves[2].tilt_deg`.
        key: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// A session file is not valid TOML for a session: a key is missing, unknown or of the wrong type.
    #[error("session key `{key}`: the session does not parse")]
    SessionToml {
        /// The key the parser names (`<toml>` when it names none).
        key: String,
        /// The TOML parser's error (its message names the line).
        #[source]
        source: Box<toml::de::Error>,
    },
    /// Unknown effect name (see [`crate::effects::EFFECT_NAMES`]).
    #[error("unknown effect `{name}`: allowed {allowed}")]
    UnknownEffect {
        /// The name that was given.
        name: String,
        /// The allowed names, comma separated.
        allowed: String,
    },
    /// A named parameter of an effect is unknown or missing.
    #[error("effect `{effect}`: parameter `{param}` {message}")]
    EffectParameter {
        /// Effect name.
        effect: &'static str,
        /// Parameter name.
        param: String,
        /// What is wrong.
        message: String,
    },
    /// A measured point is not a valid measurement (non-finite value, flag not 0/1, a value out of its
    /// physical range, time going backwards within a groove).
    #[error("row {row}, column `{column}`: {message}")]
    Point {
        /// The point's row, counted from 1 (the first point is row 1).
        row: usize,
        /// The offending field (the measured-groove column name).
        column: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The noise distribution of a sensor or session could not be built.
    #[error("numerical failure in `noise distribution` (sigma = {sigma})")]
    NoiseDistribution {
        /// The standard deviation asked for.
        sigma: f64,
        /// The distribution's complaint.
        #[source]
        source: rand_distr::NormalError,
    },
    /// A file could not be read.
    #[error("cannot read `{path}`")]
    Io {
        /// The path.
        path: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// Check that `value` is finite and in `[lo, hi]` (use infinities for open sides).
pub(crate) fn check_range(
    name: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    allowed: &'static str,
) -> Result<f64, SimError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value)
    } else {
        Err(SimError::InvalidParameter {
            name,
            value,
            allowed,
        })
    }
}

/// Check that `value` is finite.
pub(crate) fn check_finite(name: &'static str, value: f64) -> Result<f64, SimError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SimError::InvalidParameter {
            name,
            value,
            allowed: "finite",
        })
    }
}

/// `1.0`, for `#[serde(default = "crate::error::one")]` on factors whose neutral value is 1.
pub(crate) fn one() -> f64 {
    1.0
}

/// Check that `value` is finite and strictly positive.
pub(crate) fn check_positive(name: &'static str, value: f64) -> Result<f64, SimError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SimError::InvalidParameter {
            name,
            value,
            allowed: "finite and > 0",
        })
    }
}

/// Check that `value` is finite and non-negative.
pub(crate) fn check_nonneg(name: &'static str, value: f64) -> Result<f64, SimError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(SimError::InvalidParameter {
            name,
            value,
            allowed: "finite and >= 0",
        })
    }
}
