//! The crate's single error type.

/// Everything that can go wrong when generating or analysing a design.
///
/// Every variant names the thing at fault (factor, generator, column, row, term, parameter) so
/// the CLI can print a message the user can act on.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DoeError {
    /// The factor list was empty.
    #[error(
        "no factors given: expected a list such as `depth_um=100:200,speed_rpm=10000:20000` or `A,B,C`"
    )]
    NoFactors,

    /// One entry of a factor list could not be parsed.
    #[error("factor `{spec}`: {reason}")]
    InvalidFactorSpec {
        /// The offending entry as written.
        spec: String,
        /// What is wrong with it.
        reason: String,
    },

    /// The same factor name appears twice.
    #[error("factor `{name}` is listed more than once")]
    DuplicateFactor {
        /// The repeated name.
        name: String,
    },

    /// A factor has a single distinct level (in a specification or in a data file).
    #[error(
        "factor `{name}` has only one level ({level}); a factor needs at least two distinct levels"
    )]
    SingleLevelFactor {
        /// Factor name.
        name: String,
        /// The one level found.
        level: String,
    },

    /// A factor's number or kind of levels does not suit the requested design.
    #[error(
        "factor `{name}` has {levels} level(s) of kind {kind}; the {design} design needs {allowed}"
    )]
    LevelsNotAllowed {
        /// Factor name.
        name: String,
        /// Design that was requested.
        design: &'static str,
        /// Number of levels given.
        levels: usize,
        /// `numeric`, `coded` or `label`.
        kind: &'static str,
        /// What the design accepts.
        allowed: &'static str,
    },

    /// A generator string could not be parsed or refers to something invalid.
    #[error("generator `{generator}`: {reason}")]
    InvalidGenerator {
        /// The offending generator as written.
        generator: String,
        /// What is wrong with it.
        reason: String,
    },

    /// Two generators define the same column (or one is the negative of the other).
    #[error(
        "generators `{first}` and `{second}` define the same column, so factors `{first_factor}` and `{second_factor}` would be indistinguishable"
    )]
    DuplicateGenerator {
        /// First generator.
        first: String,
        /// Second generator.
        second: String,
        /// Factor defined by the first generator.
        first_factor: String,
        /// Factor defined by the second generator.
        second_factor: String,
    },

    /// The generators alias two main effects with each other (a defining word of length 1 or 2).
    #[error(
        "generators alias main effect `{factor}` with `{aliased_with}` (defining word {word}); choose generators whose words all have three or more letters"
    )]
    AliasedGenerators {
        /// One of the aliased factors.
        factor: String,
        /// What it is aliased with (another factor or the mean).
        aliased_with: String,
        /// The short defining word, e.g. `I = DE`.
        word: String,
    },

    /// The built-in catalogue has no design for the request.
    #[error("no catalogued regular fraction for {factors} factors {request}: {reason}")]
    NoCatalogueDesign {
        /// Number of factors.
        factors: usize,
        /// What was asked, e.g. `at resolution V`.
        request: String,
        /// Why, and what to do instead.
        reason: String,
    },

    /// A numeric or enumerated parameter is out of its allowed range.
    #[error("invalid {name} = {value}: allowed {allowed}")]
    InvalidParameter {
        /// Parameter name (CLI spelling).
        name: &'static str,
        /// Value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },

    /// A linear constraint could not be parsed.
    #[error("constraint `{constraint}`: {reason}")]
    InvalidConstraint {
        /// The constraint as written.
        constraint: String,
        /// What is wrong with it.
        reason: String,
    },

    /// No candidate point satisfies the constraints.
    #[error("no candidate point satisfies the constraints {constraints}")]
    InfeasibleConstraints {
        /// The constraints as written.
        constraints: String,
    },

    /// A column named by the user is not in the table.
    #[error("unknown column `{name}`; available columns: {available}")]
    UnknownColumn {
        /// Name given.
        name: String,
        /// Comma-separated list of the columns present.
        available: String,
    },

    /// A factor name used in a model, generator or constraint is not a factor.
    #[error("unknown factor `{name}` in {context}; factors are: {available}")]
    UnknownFactor {
        /// Name given.
        name: String,
        /// Where it was used (`model`, `generators`, `constraints`, `prediction`).
        context: &'static str,
        /// Comma-separated list of the factors.
        available: String,
    },

    /// A model formula could not be parsed.
    #[error("model `{spec}`: {reason}")]
    InvalidModel {
        /// The model as written.
        spec: String,
        /// What is wrong with it.
        reason: String,
    },

    /// More coefficients than runs.
    #[error(
        "model `{model}` has {coefficients} coefficients (intercept included) but the data have only {runs} runs; use a smaller model, e.g. `main`"
    )]
    TooManyTerms {
        /// The expanded model.
        model: String,
        /// Number of coefficients.
        coefficients: usize,
        /// Number of runs.
        runs: usize,
    },

    /// A model term cannot be estimated separately from others (linear dependence).
    #[error(
        "term `{term}` is aliased with {aliased_with} in these runs and cannot be estimated; drop one of them from the model"
    )]
    AliasedTerms {
        /// The term that is a linear combination of earlier ones.
        term: String,
        /// The earlier terms (or `the intercept`).
        aliased_with: String,
    },

    /// A response cell is not a number.
    #[error("response column `{column}` row {row}: `{value}` is not a number")]
    NonNumericResponse {
        /// Response column.
        column: String,
        /// 1-based data row.
        row: usize,
        /// The cell as found.
        value: String,
    },

    /// A numeric cell is NaN or infinite.
    #[error("column `{column}` row {row}: value {value} is not finite")]
    NonFiniteValue {
        /// Column.
        column: String,
        /// 1-based data row.
        row: usize,
        /// The value.
        value: f64,
    },

    /// Columns of different lengths.
    #[error("column `{column}` has {len} rows but `{reference}` has {expected}")]
    LengthMismatch {
        /// Column at fault.
        column: String,
        /// Its length.
        len: usize,
        /// Column used as reference.
        reference: String,
        /// Reference length.
        expected: usize,
    },

    /// Not enough data for the requested computation.
    #[error("{what}: need at least {needed}, have {have}")]
    NotEnoughData {
        /// What was attempted.
        what: &'static str,
        /// Minimum required.
        needed: usize,
        /// Available.
        have: usize,
    },

    /// A combination of options that this crate does not implement.
    #[error("unsupported: {what}")]
    Unsupported {
        /// Description, with the alternative when there is one.
        what: String,
    },

    /// One option of a [`crate::DesignOptions`] or [`crate::AnalyzeOptions`] is wrong: shown as the CLI flag (`--factors`), the
    /// cause below it. A face with other spellings (Python's `factors=`) renders `option` itself.
    #[error("--{}", option.replace('_', "-"))]
    BadOption {
        /// The option's name, `snake_case` (`factors`, `ccd_variant`).
        option: &'static str,
        /// What is wrong with it.
        #[source]
        source: Box<DoeError>,
    },

    /// A step of an analysis of a named table failed (`FILE: preparing the analysis`), the cause
    /// below it.
    #[error("{origin}: {step}")]
    AnalysisStep {
        /// The table (its file, or the argument it came from).
        origin: String,
        /// The step: `preparing the analysis`, `backward elimination`, ``analysing `y` ``.
        step: String,
        /// What went wrong.
        #[source]
        source: Box<DoeError>,
    },
}

/// Shorthand result type.
pub type Result<T> = std::result::Result<T, DoeError>;
