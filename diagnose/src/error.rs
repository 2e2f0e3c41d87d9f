//! The one error type of the crate.
//!
//! Errors are for input that cannot be diagnosed at all: a session sim cannot evaluate, measured
//! points that are not a measurement or do not belong to the session, bad options. A diagnosis that
//! ran is a [`DiagnoseReport`](crate::DiagnoseReport) — candidates that could not be tested or
//! fitted are listed there with a note — not an error.
//!
//! Row numbers are 0-based indices into the measured points (the first data row below a CSV
//! header is row 0).

use millcomp_identify::IdentifyError;
use millcomp_sim::SimError;

/// Everything that makes a diagnosis impossible, each variant naming what is at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DiagnoseError {
    /// sim could not evaluate the session (its plan, force model or effects).
    #[error("the session's {what} could not be evaluated")]
    Session {
        /// What was being evaluated (`plan`, `effects`, `force model`).
        what: &'static str,
        /// sim's error.
        #[source]
        source: SimError,
    },
    /// The measured points are not a measurement: a non-finite value, `coolant_on` not 0 or 1, or
    /// time going backwards within a groove.
    #[error("{origin}: invalid measured points")]
    InvalidPoints {
        /// The measured file or label.
        origin: String,
        /// sim's check of the points, naming the point and the field.
        #[source]
        source: SimError,
    },
    /// A force-trace value is NaN or infinite.
    #[error("{origin}: column `{column}`, row {}: value {value} is not finite (NaN or infinite)", row + 1)]
    NonFinite {
        /// The force-trace file or label.
        origin: String,
        /// Offending column.
        column: &'static str,
        /// 0-based index of the row (messages count rows from 1, as `millcomp-datasets` does).
        row: usize,
        /// The value found.
        value: f64,
    },
    /// The measured data do not belong to the session (different grooves, points or conditions).
    /// `row` is the 0-based index of the data row, `None` when the whole file is at fault; the message
    /// counts rows from 1, as `millcomp-datasets` does (row 1 is the first data row).
    #[error("measured data do not match the session: {}column `{column}`: {message}", row.map(|r| format!("row {}, ", r + 1)).unwrap_or_default())]
    SessionMismatch {
        /// Offending column (`rows` when the row counts differ).
        column: String,
        /// 0-based index of the data row, if one row is at fault.
        row: Option<usize>,
        /// What differs, with both values.
        message: String,
    },
    /// A candidate effect name that is not registered.
    #[error("unknown candidate effect `{name}`; allowed {allowed}")]
    UnknownCandidate {
        /// The name given.
        name: String,
        /// Registered names.
        allowed: String,
    },
    /// An option outside its allowed range.
    #[error("{name} = {value} is out of range: allowed {allowed}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// Human-readable allowed range.
        allowed: &'static str,
    },
    /// A model could not be fitted at all (the identify engine failed from every start).
    #[error("{what} could not be fitted")]
    Fit {
        /// What was being fitted.
        what: String,
        /// The identify engine's error.
        #[source]
        source: IdentifyError,
    },
    /// A material the physics crate does not know (force diagnosis).
    #[error("unknown material `{name}`")]
    UnknownMaterial {
        /// The name given.
        name: String,
        /// sim's error, listing the known materials.
        #[source]
        source: SimError,
    },
    /// A force table with too few runs to hold one out.
    #[error(
        "{origin}: {runs} runs; the force diagnosis needs at least 3 (one is held out at a time)"
    )]
    TooFewRuns {
        /// The table's name.
        origin: String,
        /// Runs found.
        runs: usize,
    },
    /// The force model could not be evaluated at the table's conditions or the predicted cut.
    #[error("{origin}: the force model could not be evaluated: {message}")]
    Evaluation {
        /// The table or the predicted case.
        origin: String,
        /// The physics crate's message.
        message: String,
    },
}

/// Result alias of the crate.
pub type Result<T> = std::result::Result<T, DiagnoseError>;
