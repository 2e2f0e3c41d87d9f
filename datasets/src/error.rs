//! The one error type of this crate.

use std::path::{Path, PathBuf};

use millcomp_models::ModelError;
use polars::error::PolarsError;

/// How every millcomp message numbers the rows of a user's table: **row 1 is the first data row**, the
/// one under the header, counted from 1 whatever the format; in a CSV file, row `n` is line `n + 1` (the
/// header is line 1), which messages about a CSV file say too: `row 3 (line 4)`. The libraries that see
/// columns rather than files (identify, doe, diagnose) count their rows the same way, from 1.
///
/// ```
/// use std::path::Path;
/// assert_eq!(millcomp_datasets::error::row_at(Path::new("step.csv"), &3), "row 3 (line 4)");
/// assert_eq!(millcomp_datasets::error::row_at(Path::new("step.parquet"), &3), "row 3");
/// ```
pub fn row_at(file: &Path, row: &usize) -> String {
    let parquet = file
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet") || e.eq_ignore_ascii_case("pq"));
    if parquet {
        format!("row {row}")
    } else {
        format!("row {row} (line {})", row + 1)
    }
}

/// What to change about a cell that is not a number, when it looks like something else that means one.
fn hint(value: &str) -> &'static str {
    if crate::decode::is_missing_marker(value) {
        " (a missing value: every row needs a number here; fill it in or delete the row)"
    } else if value.contains(',') && value.replace(',', ".").parse::<f64>().is_ok() {
        " (a decimal comma among decimal points: write the column with one decimal mark)"
    } else {
        ""
    }
}

/// Everything that can go wrong loading, validating or writing a table.
///
/// Every variant names the file and, where there is one, the column and the row, numbered as
/// [`row_at`] says (row 1 is the first data row, line 2 of a CSV file). Where an underlying error
/// (I/O, polars, the atomic writer) is the cause, it is kept as the error's source, not copied into
/// the message.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read")]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The path is a directory (or another thing that is not a file).
    #[error("{file}: is a directory, not a file")]
    NotAFile {
        /// The path.
        file: PathBuf,
    },
    /// The file's bytes are not text in an encoding the reader knows ([`crate::decode`]).
    #[error("{file}: {message}")]
    NotText {
        /// The file.
        file: PathBuf,
        /// What is wrong and what to change.
        message: String,
    },
    /// A CSV row has more fields than the header.
    #[error(
        "{file}: {} has {fields} fields but the header has {expected} (separated by {delimiter}): a \
         cell holding the delimiter must be in double quotes",
        row_at(.file, .row)
    )]
    RaggedRow {
        /// The file.
        file: PathBuf,
        /// 1-based data row.
        row: usize,
        /// The fields of that row (at least).
        fields: usize,
        /// The fields of the header.
        expected: usize,
        /// `commas`, `semicolons` or `tabs`.
        delimiter: &'static str,
    },
    /// The file is empty or holds a header but no data rows.
    #[error("{file}: the file is empty (no {what})")]
    Empty {
        /// The file.
        file: PathBuf,
        /// What is missing: "header" or "data rows".
        what: &'static str,
    },
    /// The file is not valid CSV or Parquet.
    #[error("{file}: cannot parse as {format}")]
    Parse {
        /// The file.
        file: PathBuf,
        /// "CSV" or "Parquet".
        format: &'static str,
        /// The parser's error.
        #[source]
        source: PolarsError,
    },
    /// A column of the file cannot be read as text cells (e.g. a nested Parquet column).
    #[error("{file}: column `{column}` cannot be read as text")]
    UnreadableColumn {
        /// The file.
        file: PathBuf,
        /// The column.
        column: String,
        /// polars' error.
        #[source]
        source: PolarsError,
    },
    /// A required column is absent.
    #[error("{file}: missing required column `{column}` (columns present: {present})")]
    MissingColumn {
        /// The file.
        file: PathBuf,
        /// The column the schema requires.
        column: String,
        /// The columns the file has, comma separated.
        present: String,
    },
    /// The same column name appears twice in the header.
    #[error("{file}: column `{column}` appears more than once in the header")]
    DuplicateColumn {
        /// The file.
        file: PathBuf,
        /// The repeated name.
        column: String,
    },
    /// A cell is empty where a value is required.
    #[error("{file}: column `{column}`, {}: empty cell (a value is required)", row_at(.file, .row))]
    EmptyCell {
        /// The file.
        file: PathBuf,
        /// The column.
        column: String,
        /// 1-based data row.
        row: usize,
    },
    /// A cell does not parse as the column's type.
    #[error("{file}: column `{column}`, {}: `{value}` is not {expected}{}", row_at(.file, .row), hint(.value))]
    BadCell {
        /// The file.
        file: PathBuf,
        /// The column.
        column: String,
        /// 1-based data row.
        row: usize,
        /// The offending text.
        value: String,
        /// What the column holds, e.g. "a number".
        expected: &'static str,
    },
    /// A numeric cell is NaN or infinite.
    #[error("{file}: column `{column}`, {}: `{value}` is not a finite number{}", row_at(.file, .row), hint(.value))]
    NonFinite {
        /// The file.
        file: PathBuf,
        /// The column.
        column: String,
        /// 1-based data row.
        row: usize,
        /// The offending text.
        value: String,
    },
    /// A value breaks a rule of the schema other than its type (range, monotonicity, …).
    #[error("{file}: column `{column}`, {}: {message}", row_at(.file, .row))]
    Invalid {
        /// The file.
        file: PathBuf,
        /// The column.
        column: String,
        /// 1-based data row.
        row: usize,
        /// What rule was broken.
        message: String,
    },
    /// Points that break a rule of their contract other than one of a row (kept as the source).
    #[error("{file}: not a valid measurement")]
    Contract {
        /// The file.
        file: PathBuf,
        /// The contract's error.
        #[source]
        source: millcomp_sim::SimError,
    },
    /// The requested column is not in the table.
    #[error("table `{table}` has no column `{column}`")]
    NoSuchColumn {
        /// The table's name or file.
        table: String,
        /// The column asked for.
        column: String,
    },
    /// The requested column exists but holds another type.
    #[error("table `{table}`: column `{column}` holds {actual}, not {expected}")]
    WrongColumnType {
        /// The table's name or file.
        table: String,
        /// The column.
        column: String,
        /// The type asked for.
        expected: &'static str,
        /// The type it holds.
        actual: &'static str,
    },
    /// No embedded dataset has this name.
    #[error("no dataset named `{name}`; known datasets: {known}")]
    UnknownDataset {
        /// The name asked for.
        name: String,
        /// The known names, comma separated.
        known: String,
    },
    /// The output path's extension is neither `.csv` nor `.parquet`.
    #[error("{file}: unsupported table format (use a .csv or .parquet file name)")]
    UnsupportedFormat {
        /// The file.
        file: PathBuf,
    },
    /// Columns of a table being built have different lengths.
    #[error("table `{table}`: column `{column}` has {len} rows, expected {expected}")]
    RaggedColumns {
        /// The table.
        table: String,
        /// The column.
        column: String,
        /// Its length.
        len: usize,
        /// The length of the first column.
        expected: usize,
    },
    /// The table could not be turned into a polars data frame or encoded as CSV/Parquet.
    #[error("{file}: cannot encode the table as {format}")]
    Encode {
        /// The table's origin or destination.
        file: PathBuf,
        /// "a data frame", "CSV" or "Parquet".
        format: &'static str,
        /// polars' error.
        #[source]
        source: PolarsError,
    },
    /// A `--columns` mapping that cannot be parsed or applied as given.
    #[error("--columns `{spec}`: {message}")]
    BadColumnMap {
        /// The entry at fault.
        spec: String,
        /// What is wrong with it.
        message: String,
    },
    /// A `--columns` mapping names a column (or a pattern matching none) the file does not have.
    #[error(
        "{file}: --columns {role}={column}: no column `{column}` in the file (columns present: {present})"
    )]
    MappedColumnMissing {
        /// The file.
        file: PathBuf,
        /// The role being mapped.
        role: String,
        /// The column or pattern asked for.
        column: String,
        /// The file's columns, comma separated (boxed: keeps the error small).
        present: Box<str>,
    },
    /// A `--columns` mapping joins a role and a column whose unit suffixes differ.
    #[error("{file}: --columns {role}={column}: `{role}` is in {units}")]
    UnitMismatch {
        /// The file.
        file: PathBuf,
        /// The role.
        role: String,
        /// The file's column.
        column: String,
        /// Both units: `um but column `force_x_N` is in n` (boxed: keeps the error small).
        units: Box<str>,
    },
    /// Writing the output failed; nothing was left at the destination.
    #[error("{file}: cannot write")]
    Write {
        /// The destination.
        file: PathBuf,
        /// The atomic writer's error (it names the step: creating the temporary file, writing,
        /// syncing, renaming), whose source is the I/O or encoding error.
        #[source]
        source: Box<ModelError>,
    },
}
