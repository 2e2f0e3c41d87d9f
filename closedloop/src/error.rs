//! The one error type of `millcomp-closedloop`, and [`error_chain`] to put an error and its causes on
//! one line.
//!
//! Scenario errors name the key at fault (`groove.tilt_deg`, `control.mpc.limits.u_min[0]`) and what is
//! allowed; batch errors name the file, the row, the factor or the directory. A run that completes with
//! a large error is an outcome (the report), not an error; so is a QP that did not converge (counted in
//! the solver statistics).

use std::num::ParseIntError;
use std::path::PathBuf;

use millcomp_datasets::DatasetError;
use millcomp_mpc::MpcError;
use millcomp_sim::SimError;
use thiserror::Error;

/// Errors of the closed-loop harness: bad scenario, bad batch input, unreadable or unwritable files,
/// and the controllers' and the plant's own errors.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ClosedLoopError {
    /// A published figure could not be computed (`figures`): the figure's name and the cause.
    #[error("published figure `{name}`")]
    Figure {
        /// The figure's name in the registry.
        name: &'static str,
        /// The cause (a table, an analysis, a fit or a run).
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A scenario value (or the controller asked for) is out of its allowed range.
    #[error("invalid value for `{key}` = {value}: allowed {allowed}")]
    InvalidConfig {
        /// Dotted key path, e.g. `groove.tilt_deg` or `control.mpc.limits.u_min[0]`.
        key: String,
        /// The offending value as written.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// Unknown controller name.
    #[error("unknown controller `{name}`: allowed {allowed}")]
    UnknownController {
        /// The name given.
        name: String,
        /// Allowed names, comma separated.
        allowed: String,
    },
    /// A scenario file (or a model file it names) is not valid: the parser's or checker's message
    /// naming the key.
    #[error("scenario `{path}`: {message}")]
    Scenario {
        /// File (or `<string>`).
        path: String,
        /// Parser/validator message naming the key.
        message: String,
    },
    /// A scenario or model file could not be read.
    #[error("cannot access `{path}`: {message}")]
    Io {
        /// The path.
        path: String,
        /// The OS message.
        message: String,
    },
    /// A model file a scenario names is not a valid model of the kind needed (the file and key are named).
    #[error(transparent)]
    ModelFile(#[from] millcomp_models::ModelError),
    /// The simulated stiffness calibration could not draw its indicator noise.
    #[error("numerical failure in `stiffness calibration`")]
    CalibrationNoise {
        /// The noise distribution's complaint.
        #[source]
        source: rand_distr::NormalError,
    },
    /// A commissioning experiment could not be designed or identified (bad data, not a poor fit: a poor fit
    /// is a warning in the bundle).
    #[error("commissioning: the {experiment} failed")]
    Commissioning {
        /// Which experiment (`force calibration`, `spindle step test`, `load-deflection test`, …).
        experiment: &'static str,
        /// The design's or identification's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
    /// The least-squares fit of the simulated stiffness calibration failed.
    #[error("numerical failure in `stiffness calibration fit`")]
    CalibrationFit {
        /// The fit's error.
        #[source]
        source: millcomp_identify::IdentifyError,
    },
    /// The simulated calibration identified a compliance that is not positive.
    #[error(
        "numerical failure in `stiffness calibration fit`: {what} compliance {compliance} not positive"
    )]
    CalibrationNotPositive {
        /// Which stiffness (`radial`, `axial`, `tool`).
        what: String,
        /// The identified compliance (µm/N).
        compliance: f64,
    },
    /// An error of the controllers (configuration, dimensions, solver set-up).
    #[error(transparent)]
    Mpc(#[from] MpcError),
    /// An error of the physics crate (bad plant parameter).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A table could not be built, read or written without more context.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// JSON (de)serialisation failed without more context.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The batch's controller list is not valid.
    #[error("--controllers")]
    Controllers {
        /// Why.
        #[source]
        source: Box<ClosedLoopError>,
    },
    /// A controller appears twice in the batch's controller list.
    #[error("--controllers: `{name}` is listed twice")]
    ControllerListedTwice {
        /// The name.
        name: String,
    },
    /// The batch's controller list is empty.
    #[error("--controllers: give at least one controller, e.g. pid,mpc")]
    NoControllers,
    /// `threshold` (the thin-wall baseline) was asked for on a groove scenario of the batch.
    #[error(
        "--controllers: `threshold` (the 004 thin-wall baseline) runs only on thin-wall scenarios, but \
         scenario row {row} is a groove (set factor stage = thin_wall)"
    )]
    ThresholdOnGroove {
        /// 1-based scenario row.
        row: usize,
    },
    /// A shard count of 0.
    #[error("{what}: the number of shards must be at least 1")]
    NoShards {
        /// Where the numbers came from (`--shard 0/0`, the environment variables).
        what: String,
    },
    /// A shard index at or beyond the shard count.
    #[error(
        "{what}: shard index {index} is out of range for {count} shards (allowed 0..={})",
        .count - 1
    )]
    ShardOutOfRange {
        /// Where the numbers came from.
        what: String,
        /// The 0-based index.
        index: usize,
        /// The number of shards (≥ 1).
        count: usize,
    },
    /// `--shard` is not of the form `K/N`.
    #[error("--shard `{text}`: expected K/N, e.g. 0/4")]
    ShardSyntax {
        /// The text given.
        text: String,
    },
    /// A number of `--shard K/N` is not a non-negative integer.
    #[error("--shard `{text}`: {which} is not a {kind} integer")]
    ShardNumber {
        /// The text given.
        text: String,
        /// `K` or `N`.
        which: &'static str,
        /// `non-negative` or `positive`.
        kind: &'static str,
        /// The parser's error.
        #[source]
        source: ParseIntError,
    },
    /// An array-job environment variable is not a non-negative integer.
    #[error("environment variable {name}=`{value}` is not a non-negative integer")]
    ShardEnvNumber {
        /// The variable.
        name: String,
        /// Its value.
        value: String,
        /// The parser's error.
        #[source]
        source: ParseIntError,
    },
    /// The array-job environment variables are inconsistent (a count missing, an index below the
    /// minimum).
    #[error("{message}")]
    ShardEnv {
        /// What is wrong and what to do.
        message: String,
    },
    /// A column of a batch's scenario table is not a factor.
    #[error("{origin}: unknown factor `{name}` (allowed: {allowed})")]
    UnknownFactor {
        /// The table (file name or `--doe design`).
        origin: String,
        /// The column.
        name: String,
        /// The factor names, comma separated.
        allowed: String,
    },
    /// A batch's scenario table has no factor column.
    #[error("{origin}: no factor columns")]
    NoFactors {
        /// The table.
        origin: String,
    },
    /// A batch's scenario table has no rows.
    #[error("{origin}: no scenarios (no data rows)")]
    NoScenarios {
        /// The table.
        origin: String,
    },
    /// A numeric factor's cell is not a number.
    #[error("{origin}: factor `{factor}`, row {row}: `{value}` is not a number")]
    FactorNotNumber {
        /// The table.
        origin: String,
        /// The factor.
        factor: String,
        /// 1-based row.
        row: usize,
        /// The cell.
        value: String,
    },
    /// A factor value the scenario cannot take.
    #[error("factor `{factor}`: {message}")]
    InvalidFactor {
        /// The factor.
        factor: String,
        /// The value and what is allowed.
        message: String,
    },
    /// A run of a comparison failed (`closedloop::compare`).
    #[error("{scenario} (seed {seed}, controller {controller})")]
    CompareRun {
        /// Scenario name.
        scenario: String,
        /// The seed it ran with.
        seed: u64,
        /// The controller.
        controller: String,
        /// Why.
        #[source]
        source: Box<ClosedLoopError>,
    },
    /// A row of a batch's scenario table does not make a valid scenario.
    #[error("{origin}: row {row}")]
    Row {
        /// The table.
        origin: String,
        /// 1-based row.
        row: usize,
        /// Why.
        #[source]
        source: Box<ClosedLoopError>,
    },
    /// The batch's base scenario has no groove.
    #[error("{file}: the base scenario has no [groove] table")]
    NoGrooveInBase {
        /// The base scenario's file name.
        file: String,
    },
    /// A batch directory could not be created.
    #[error("creating {}", .path.display())]
    CreateDir {
        /// The directory.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A batch file could not be read.
    #[error("reading {}", .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A batch file could not be written.
    #[error("writing {}", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The table writer's error.
        #[source]
        source: DatasetError,
    },
    /// `DIR/plan.json` could not be read: not a batch output directory.
    #[error("reading {} (is it a batch output directory?)", .path.display())]
    ReadPlan {
        /// The plan file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// `DIR/plan.json` is not a plan.
    #[error("parsing {}", .path.display())]
    ParsePlan {
        /// The plan file.
        path: PathBuf,
        /// The JSON error.
        #[source]
        source: serde_json::Error,
    },
    /// `DIR/plan.json` was edited after it was written.
    #[error(
        "{}: the plan was edited (its fingerprint {stored} does not match its content {computed})",
        .path.display()
    )]
    PlanEdited {
        /// The plan file.
        path: PathBuf,
        /// The fingerprint it carries.
        stored: String,
        /// The fingerprint of its content.
        computed: String,
    },
    /// `DIR/plan.json` has no valid `shard`.
    #[error("{}: no valid `shard`", .path.display())]
    NoShard {
        /// The plan file.
        path: PathBuf,
        /// The JSON error.
        #[source]
        source: serde_json::Error,
    },
    /// The output directory holds another batch.
    #[error(
        "{} belongs to another batch (fingerprint {old} ≠ {new}): use another --out directory",
        .path.display()
    )]
    AnotherBatch {
        /// The plan file found.
        path: PathBuf,
        /// Its fingerprint.
        old: String,
        /// This batch's fingerprint.
        new: String,
    },
    /// Some runs of a shard failed (the finished ones are kept).
    #[error(
        "{failed} of {attempted} runs failed (finished runs are kept in {} and are not run again):\n  {}",
        .dir.display(),
        .errors.join("\n  ")
    )]
    RunsFailed {
        /// Runs that failed.
        failed: usize,
        /// Runs attempted.
        attempted: usize,
        /// Where the finished runs are.
        dir: PathBuf,
        /// One line per failed run: the run and its error chain.
        errors: Vec<String>,
    },
    /// An error met once and shared by everyone who needed the same result (the commissioning of a
    /// key several runs share, [`crate::cache`]): its message and causes are the original's.
    #[error(transparent)]
    Shared(std::sync::Arc<ClosedLoopError>),
    /// A batch was stopped by a signal (SIGTERM, SIGINT) before its runs were done: the runs finished
    /// are kept and the same command resumes.
    #[error(
        "stopped by {signal} after {done} of {planned} runs of this slice: the finished runs are kept in {}; \
         run the same command to resume",
        .dir.display()
    )]
    Interrupted {
        /// The signal's name.
        signal: String,
        /// Runs finished (now or before).
        done: usize,
        /// Runs of the slice.
        planned: usize,
        /// The runs' directory.
        dir: PathBuf,
    },
    /// A plot could not be drawn or written.
    #[error("plot {}: {message}", .path.display())]
    Plot {
        /// The plot file.
        path: PathBuf,
        /// The drawing library's or the writer's message.
        message: String,
    },
    /// The scenarios' design could not be generated.
    #[error("generating the design")]
    Design {
        /// The design generator's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
    /// `batch merge` without directories.
    #[error("batch merge: give the slice directories to merge")]
    MergeNoDirs,
    /// `batch merge` of slices of different batches.
    #[error(
        "batch merge: {} is a slice of a different batch (fingerprint {fingerprint}) than {} (fingerprint \
         {first_fingerprint}): merge only slices of one plan",
        .dir.display(),
        .first.display()
    )]
    MergeDifferentBatch {
        /// The odd slice.
        dir: PathBuf,
        /// Its fingerprint.
        fingerprint: String,
        /// The first slice.
        first: PathBuf,
        /// Its fingerprint.
        first_fingerprint: String,
    },
    /// `batch merge` with runs missing.
    #[error(
        "batch merge: {missing} of {planned} runs are missing (e.g. runs {examples:?}); run the missing \
         shards (they resume) and merge again"
    )]
    MergeMissing {
        /// Runs missing.
        missing: usize,
        /// Runs planned.
        planned: usize,
        /// The first few missing run indices.
        examples: Vec<usize>,
    },
}

/// Shorthand for an [`ClosedLoopError::InvalidConfig`].
pub(crate) fn invalid(
    key: impl Into<String>,
    value: impl ToString,
    allowed: impl Into<String>,
) -> ClosedLoopError {
    ClosedLoopError::InvalidConfig {
        key: key.into(),
        value: value.to_string(),
        allowed: allowed.into(),
    }
}

/// An error and its causes on one line, `error: cause: cause …` — how failed runs and analyses that
/// could not be made are reported in a batch.
///
/// ```
/// use millcomp_closedloop::{ClosedLoopError, ControllerKind, error_chain};
/// let cause = "lqr".parse::<ControllerKind>().unwrap_err();
/// let e = ClosedLoopError::Controllers { source: Box::new(cause) };
/// assert_eq!(e.to_string(), "--controllers");
/// assert_eq!(
///     error_chain(&e),
///     "--controllers: unknown controller `lqr`: allowed none, open-loop, pid, pid-aw, pid-design, pid-tuned, \
///      pid-ff, pid-ff-read, threshold, mpc, mpc-nopreview, reactive, proactive"
/// );
/// ```
pub fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}

/// Checks that scenario key `key` holds a finite value > 0.
pub(crate) fn finite_pos(key: &str, v: f64) -> Result<(), ClosedLoopError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "finite and > 0"))
    }
}

/// Checks that scenario key `key` holds a finite value >= 0.
pub(crate) fn finite_nonneg(key: &str, v: f64) -> Result<(), ClosedLoopError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "finite and >= 0"))
    }
}

/// Sim's own check of a scenario table, its parameter names turned into scenario keys under `prefix`
/// (`exit.x_mm` → `groove.exit.x_mm`, `e_factor` → `truth.wall.e_factor`).
pub(crate) fn sim_keyed(
    prefix: &'static str,
) -> impl Fn(millcomp_sim::SimError) -> ClosedLoopError {
    move |err| match err {
        millcomp_sim::SimError::InvalidParameter {
            name,
            value,
            allowed,
        } => invalid(format!("{prefix}{name}"), value, allowed),
        other => other.into(),
    }
}
