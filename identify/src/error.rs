//! The one error type of the crate.
//!
//! Errors are for input that cannot be fitted at all (wrong lengths, NaN, non-monotone time, fewer
//! points than parameters, a regressor that does not vary, impossible bounds). A fit that ran but did
//! not converge, or converged to a poorly identifiable point, is *not* an error: it is a
//! [`FitReport`](crate::FitReport) with a `status` and `warnings`.
//!
//! Where an underlying error exists (the physics crate's, the forward model's, argmin's) it is kept as
//! the [`std::error::Error::source`] of the variant rather than flattened into its message: print the
//! chain to see it.
//!
//! Row numbers are 0-based indices into the data columns (the first data row below a CSV header is
//! row 0); the CLI adds its own header offset when it prints them.

use argmin::core::Error as ArgminError;
use millcomp_sim::SimError;

/// Everything that makes identification impossible, each variant naming the offending column, row
/// or parameter and what would have been allowed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IdentifyError {
    /// Fewer usable data points than the fit needs (at least one more than the free parameters,
    /// so that a residual variance and standard errors exist).
    #[error(
        "too few points: {got} usable rows for {n_params} free parameters ({what}); need at least {needed}"
    )]
    TooFewPoints {
        /// Usable rows supplied.
        got: usize,
        /// Free parameters to estimate.
        n_params: usize,
        /// Minimum number of rows required.
        needed: usize,
        /// Which fit (or which group, e.g. one stiffness direction).
        what: String,
    },
    /// Two columns that must be equally long are not.
    #[error("column `{column}` has {len} rows but `{reference}` has {expected}")]
    LengthMismatch {
        /// Offending column.
        column: String,
        /// Its length.
        len: usize,
        /// Column it is compared with.
        reference: String,
        /// Length of the reference column.
        expected: usize,
    },
    /// A NaN or infinite value in the data.
    #[error("column `{column}`, row {row}: value {value} is not finite (NaN or infinite)")]
    NonFinite {
        /// Offending column.
        column: String,
        /// Row, counted from 1.
        row: usize,
        /// The value found.
        value: f64,
    },
    /// Time (or another ordering column) does not strictly increase.
    #[error(
        "column `{column}`, row {row}: value {value} does not increase (previous row: {prev}); time must be strictly increasing"
    )]
    NonMonotoneTime {
        /// Offending column.
        column: String,
        /// Row where the order breaks, counted from 1.
        row: usize,
        /// Value at `row - 1`.
        prev: f64,
        /// Value at `row`.
        value: f64,
    },
    /// An input column that has to vary is constant, so the named parameters cannot be identified.
    #[error("column `{column}` is constant ({value}): {parameters} cannot be identified from it")]
    ConstantInput {
        /// Offending column.
        column: String,
        /// Its (single) value.
        value: f64,
        /// Parameters that would need the column to vary.
        parameters: String,
    },
    /// A value outside the range a column or option allows.
    #[error("{name} = {value} is out of range: allowed {allowed}")]
    InvalidParameter {
        /// Column, option or parameter name.
        name: String,
        /// The value given.
        value: f64,
        /// Human-readable allowed range.
        allowed: &'static str,
    },
    /// Bounds with `lower >= upper` or NaN.
    #[error("parameter `{name}`: bad bounds [{lower}, {upper}] (need lower < upper, not NaN)")]
    BadBounds {
        /// Parameter name.
        name: String,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// A starting value not strictly inside its bounds (or not finite).
    #[error("parameter `{name}`: initial value {value} is not strictly inside [{lower}, {upper}]")]
    InitialOutsideBounds {
        /// Parameter name.
        name: String,
        /// Initial value.
        value: f64,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// A required column (or group of rows) is missing.
    #[error("missing input `{column}`: {reason}")]
    MissingColumn {
        /// Column name.
        column: String,
        /// Why it is needed.
        reason: String,
    },
    /// A time or cut range (`--train`, `--test`) that cannot be read or does not lie in the record.
    #[error("{flag} {range}: {message}")]
    BadRange {
        /// The option it was given to (`--train`, `--test`).
        flag: String,
        /// The range as written.
        range: String,
        /// What is wrong, with the record's own range.
        message: String,
    },
    /// A model name that is not one of the allowed ones.
    #[error("unknown model `{name}`: allowed {allowed}")]
    UnknownModel {
        /// The name given.
        name: String,
        /// The allowed names, comma separated.
        allowed: String,
    },
    /// Unknown identification target name.
    #[error(
        "unknown identify target `{name}`: allowed spindle, stiffness, force, thermal, wall, part, kienzle, feed-axis"
    )]
    UnknownTarget {
        /// The name given.
        name: String,
    },
    /// The forward model could not be evaluated (at the starting point or at the estimate).
    #[error("model `{model}` could not be evaluated: {what}")]
    ModelEvaluation {
        /// Model kind.
        model: String,
        /// What was evaluated where, e.g. `residuals at the estimate`.
        what: String,
        /// The model's error (often the physics crate's [`SimError`] underneath).
        #[source]
        source: ArgminError,
    },
    /// The forward model gave a residual that is not finite at the starting point.
    #[error(
        "model `{model}` could not be evaluated: residual {index} is not finite at the starting point"
    )]
    NonFiniteResidual {
        /// Model kind.
        model: String,
        /// 0-based index of the residual.
        index: usize,
    },
    /// The physics crate rejected a fixed input of the model (e.g. an unknown material name).
    #[error("model `{model}` could not be evaluated: the physics crate rejects its fixed inputs")]
    Physics {
        /// Model kind.
        model: String,
        /// The physics crate's error.
        #[source]
        source: SimError,
    },
    /// A text cell holds a label the target does not know (a stiffness `direction` other than axial or
    /// radial).
    #[error("column `{column}`, row {row}: `{value}` is not one of {allowed}")]
    InvalidLabel {
        /// The column.
        column: String,
        /// Row, counted from 1.
        row: usize,
        /// The label found.
        value: String,
        /// The labels allowed, comma separated.
        allowed: String,
    },
    /// A numeric input column holds a cell that is not a number (a text column where numbers are
    /// needed).
    #[error("column `{column}`, row {row}: `{value}` is not a number ({reason})")]
    NotANumber {
        /// The column.
        column: String,
        /// Row, counted from 1.
        row: usize,
        /// The cell as written (empty for an empty cell).
        value: String,
        /// Why the column is needed (`required by identify spindle`).
        reason: String,
    },
    /// A row's cut conditions are outside what the physics crate's force model accepts (depth beyond the
    /// ball radius, tilt ≥ 90°, …).
    #[error("row {row}: cut conditions the force model does not accept")]
    RejectedConditions {
        /// Row, counted from 1.
        row: usize,
        /// The physics crate's error, naming the parameter and its allowed range.
        #[source]
        source: SimError,
    },
    /// The argmin solver failed internally (not a non-convergence, which is a report status).
    #[error("solver error")]
    Solver {
        /// argmin's error.
        #[source]
        source: ArgminError,
    },
    /// A solver ended without what a result needs (a broken invariant rather than bad input), e.g. no
    /// final parameter vector.
    #[error("solver error: {what}")]
    SolverState {
        /// What was missing.
        what: &'static str,
    },
    /// An across-units analysis needs at least two units.
    #[error("{got} unit(s): a between-unit analysis needs at least 2")]
    TooFewUnits {
        /// Units found.
        got: usize,
    },
    /// One unit's fit could not run (the cause is the source).
    #[error("unit `{unit}`: its fit could not run")]
    Unit {
        /// The unit.
        unit: String,
        /// Why.
        #[source]
        source: Box<IdentifyError>,
    },
}

/// Result alias of the crate.
pub type Result<T> = std::result::Result<T, IdentifyError>;
