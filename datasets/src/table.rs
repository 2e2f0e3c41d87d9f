//! Typed tables at the edges: read a CSV or Parquet file, check it against a [`Schema`], hand the
//! numerical cores plain vectors, and write results back atomically.
//!
//! Reading goes through polars with every column read as text, so that each cell is parsed here and
//! an error can name the file, the column and the 1-based data row.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use polars::prelude::*;

use crate::error::DatasetError;

/// The type a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ColumnKind {
    /// A finite floating-point number.
    Float,
    /// An integer.
    Int,
    /// A 0/1 flag, kept as an integer column.
    Flag,
    /// Free text.
    Text,
    /// A sensor reading: a number, or an empty cell or `NaN` for "no reading in this sample" (read as
    /// NaN; ±inf is still an error).
    Reading,
}

impl ColumnKind {
    fn describe(self) -> &'static str {
        match self {
            ColumnKind::Float => "a number",
            ColumnKind::Int => "an integer",
            ColumnKind::Flag => "0 or 1",
            ColumnKind::Text => "text",
            ColumnKind::Reading => "a number, NaN or empty",
        }
    }
}

/// One column a schema expects.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ColumnSpec {
    /// Column name, units in the name (`depth_um`).
    pub name: String,
    /// The type of its cells.
    pub kind: ColumnKind,
    /// Whether the column must be present.
    pub required: bool,
    /// One line saying what it holds.
    pub description: String,
}

impl ColumnSpec {
    /// A required column.
    pub fn required(name: &str, kind: ColumnKind, description: &str) -> Self {
        Self {
            name: name.to_string(),
            kind,
            required: true,
            description: description.to_string(),
        }
    }

    /// An optional column.
    pub fn optional(name: &str, kind: ColumnKind, description: &str) -> Self {
        Self {
            required: false,
            ..Self::required(name, kind, description)
        }
    }
}

/// What a table must look like.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Schema {
    /// Name used in messages.
    pub name: String,
    /// Expected columns, in their documented order.
    pub columns: Vec<ColumnSpec>,
    /// Whether columns not in the schema are kept (as text) rather than dropped with a note.
    pub keep_extra: bool,
}

impl Schema {
    /// A schema with the given columns; extra columns are ignored with a note.
    pub fn new(name: &str, columns: Vec<ColumnSpec>) -> Self {
        Self {
            name: name.to_string(),
            columns,
            keep_extra: false,
        }
    }

    /// Keep columns the schema does not name, as text.
    pub fn keeping_extra(mut self) -> Self {
        self.keep_extra = true;
        self
    }
}

/// The cells of one column.
#[derive(Debug, Clone, PartialEq)]
pub enum ColumnData {
    /// Finite floats.
    Float(Vec<f64>),
    /// Integers (also 0/1 flags).
    Int(Vec<i64>),
    /// Text.
    Text(Vec<String>),
}

impl ColumnData {
    /// Number of cells.
    pub fn len(&self) -> usize {
        match self {
            ColumnData::Float(v) => v.len(),
            ColumnData::Int(v) => v.len(),
            ColumnData::Text(v) => v.len(),
        }
    }

    /// True when the column has no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn type_name(&self) -> &'static str {
        match self {
            ColumnData::Float(_) => "numbers",
            ColumnData::Int(_) => "integers",
            ColumnData::Text(_) => "text",
        }
    }

    /// The cell at `row` (0-based) as JSON.
    pub fn json_value(&self, row: usize) -> serde_json::Value {
        match self {
            ColumnData::Float(v) => serde_json::Value::from(v[row]),
            ColumnData::Int(v) => serde_json::Value::from(v[row]),
            ColumnData::Text(v) => serde_json::Value::from(v[row].clone()),
        }
    }

    /// The cell at `row` (0-based) as display text.
    pub fn display(&self, row: usize) -> String {
        match self {
            ColumnData::Float(v) => format_float(v[row]),
            ColumnData::Int(v) => v[row].to_string(),
            ColumnData::Text(v) => v[row].clone(),
        }
    }
}

/// Shortest text that reads back as the same float (so tables round-trip and print cleanly).
fn format_float(x: f64) -> String {
    let s = format!("{x}");
    if s.contains('e') || s.len() <= 12 {
        s
    } else {
        format!("{x:.6}")
    }
}

/// A named column.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Column name.
    pub name: String,
    /// Its cells.
    pub data: ColumnData,
}

/// A validated table: typed columns of equal length.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Where it came from (file path or dataset name), used in messages.
    pub origin: String,
    /// The columns, in schema order followed by kept extras.
    pub columns: Vec<Column>,
    /// Columns present in the file but not in the schema, which were ignored.
    pub ignored_columns: Vec<String>,
    /// How the file was read, when not as plain UTF-8 CSV with commas and decimal points (its encoding,
    /// delimiter, decimal commas: [`crate::decode`]), for the reader to print.
    pub notes: Vec<String>,
}

impl Table {
    /// Builds a table from columns, checking that they all have the same length.
    ///
    /// ```
    /// use millcomp_datasets::{Column, ColumnData, DatasetError, Table};
    /// let depth = Column { name: "depth_um".into(), data: ColumnData::Float(vec![100.0, 200.0]) };
    /// let run = Column { name: "run".into(), data: ColumnData::Int(vec![1, 2]) };
    /// let t = Table::from_columns("mine", vec![depth.clone(), run]).unwrap();
    /// assert_eq!((t.n_rows(), t.names()), (2, vec!["depth_um", "run"]));
    /// let short = Column { name: "short".into(), data: ColumnData::Int(vec![1]) };
    /// let e = Table::from_columns("mine", vec![depth, short]).unwrap_err();
    /// assert!(matches!(e, DatasetError::RaggedColumns { len: 1, expected: 2, .. }));
    /// ```
    ///
    /// # Errors
    /// [`DatasetError::RaggedColumns`] naming the first column whose length differs from the first's.
    pub fn from_columns(origin: &str, columns: Vec<Column>) -> Result<Self, DatasetError> {
        if let Some(first) = columns.first() {
            let expected = first.data.len();
            for c in &columns {
                if c.data.len() != expected {
                    return Err(DatasetError::RaggedColumns {
                        table: origin.to_string(),
                        column: c.name.clone(),
                        len: c.data.len(),
                        expected,
                    });
                }
            }
        }
        Ok(Self {
            origin: origin.to_string(),
            columns,
            ignored_columns: Vec::new(),
            notes: Vec::new(),
        })
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.data.len())
    }

    /// Column names in order.
    pub fn names(&self) -> Vec<&str> {
        self.columns.iter().map(|c| c.name.as_str()).collect()
    }

    /// The column called `name`, if present.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.name == name)
    }

    fn need(&self, name: &str) -> Result<&Column, DatasetError> {
        self.column(name).ok_or_else(|| DatasetError::NoSuchColumn {
            table: self.origin.clone(),
            column: name.to_string(),
        })
    }

    /// A numeric column as floats (integer columns are converted).
    ///
    /// ```
    /// let t = millcomp_datasets::load("clayton_doe").unwrap();
    /// // 000_…txt Table 3-3: depth of trials 1 and 2 (µm); `trial` is an integer column
    /// assert_eq!(t.f64s("depth_um").unwrap()[..2], [200.0, 100.0]);
    /// assert_eq!(t.f64s("trial").unwrap()[7], 8.0);
    /// assert!(t.f64s("source").is_err()); // text
    /// ```
    ///
    /// # Errors
    /// [`DatasetError::NoSuchColumn`], or [`DatasetError::WrongColumnType`] for a text column.
    pub fn f64s(&self, name: &str) -> Result<Vec<f64>, DatasetError> {
        let c = self.need(name)?;
        match &c.data {
            ColumnData::Float(v) => Ok(v.clone()),
            ColumnData::Int(v) => Ok(v.iter().map(|&x| x as f64).collect()),
            other => Err(DatasetError::WrongColumnType {
                table: self.origin.clone(),
                column: name.to_string(),
                expected: "numbers",
                actual: other.type_name(),
            }),
        }
    }

    /// An integer column.
    ///
    /// # Errors
    /// [`DatasetError::NoSuchColumn`], or [`DatasetError::WrongColumnType`] for a float or text column.
    pub fn i64s(&self, name: &str) -> Result<Vec<i64>, DatasetError> {
        let c = self.need(name)?;
        match &c.data {
            ColumnData::Int(v) => Ok(v.clone()),
            other => Err(DatasetError::WrongColumnType {
                table: self.origin.clone(),
                column: name.to_string(),
                expected: "integers",
                actual: other.type_name(),
            }),
        }
    }

    /// Any column as text (numbers as [`ColumnData::display`] writes them).
    ///
    /// # Errors
    /// [`DatasetError::NoSuchColumn`].
    pub fn strings(&self, name: &str) -> Result<Vec<String>, DatasetError> {
        let c = self.need(name)?;
        Ok((0..c.data.len()).map(|i| c.data.display(i)).collect())
    }

    /// Rows as JSON objects keyed by column name.
    pub fn to_json_rows(&self) -> Vec<serde_json::Value> {
        (0..self.n_rows())
            .map(|i| {
                let mut m = serde_json::Map::new();
                for c in &self.columns {
                    m.insert(c.name.clone(), c.data.json_value(i));
                }
                serde_json::Value::Object(m)
            })
            .collect()
    }

    /// The table as a polars `DataFrame`.
    ///
    /// # Errors
    /// [`DatasetError::Encode`] with polars' error when the frame cannot be built (columns of different
    /// lengths in a table whose fields were set by hand).
    pub fn to_dataframe(&self) -> Result<DataFrame, DatasetError> {
        let cols: Vec<polars::prelude::Column> = self
            .columns
            .iter()
            .map(|c| {
                let name = PlSmallStr::from(c.name.as_str());
                match &c.data {
                    ColumnData::Float(v) => Series::new(name, v).into(),
                    ColumnData::Int(v) => Series::new(name, v).into(),
                    ColumnData::Text(v) => Series::new(name, v).into(),
                }
            })
            .collect();
        DataFrame::new(self.n_rows(), cols).map_err(|source| DatasetError::Encode {
            file: PathBuf::from(&self.origin),
            format: "a data frame",
            source,
        })
    }
}

/// Reads `path` (`.csv`, or `.parquet`/`.pq`) and validates it against `schema`.
///
/// Required columns must be present; every cell of a schema column must parse as its kind, and
/// numbers must be finite. Columns the schema does not name are listed in
/// [`Table::ignored_columns`] (or kept as text with [`Schema::keeping_extra`]).
///
/// # Examples
/// ```
/// use millcomp_datasets::{read_table, ColumnKind, ColumnSpec, DatasetError, Schema};
/// let schema = Schema::new("cuts", vec![
///     ColumnSpec::required("depth_um", ColumnKind::Float, "depth of cut"),
///     ColumnSpec::required("pass", ColumnKind::Int, "pass number"),
/// ]);
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("cuts.csv");
/// std::fs::write(&path, "pass,depth_um,operator\n1,40.5,ann\n2,80,ann\n").unwrap();
/// let t = read_table(&path, &schema).unwrap();
/// assert_eq!(t.f64s("depth_um").unwrap(), [40.5, 80.0]);
/// assert_eq!(t.ignored_columns, ["operator"]);
/// // A bad cell is named by column, 1-based data row and the file's line.
/// std::fs::write(&path, "pass,depth_um\n1,40.5\n2,deep\n").unwrap();
/// let e = read_table(&path, &schema).unwrap_err();
/// assert!(matches!(&e, DatasetError::BadCell { row: 2, .. }));
/// assert!(e.to_string().contains("column `depth_um`, row 2 (line 3): `deep` is not a number"), "{e}");
/// ```
///
/// # Errors
/// [`DatasetError::Io`] (cannot open), [`DatasetError::Empty`] (no header or no data rows),
/// [`DatasetError::Parse`] (not CSV/Parquet), [`DatasetError::UnreadableColumn`],
/// [`DatasetError::DuplicateColumn`], [`DatasetError::MissingColumn`] (a required column),
/// [`DatasetError::EmptyCell`], [`DatasetError::BadCell`] and [`DatasetError::NonFinite`] (a cell,
/// with its column and row).
pub fn read_table(path: &Path, schema: &Schema) -> Result<Table, DatasetError> {
    let raw = read_raw(path)?;
    validate(path, raw, schema)
}

/// Reads `path` (`.csv` or `.parquet`) without a schema: a column whose cells all parse as finite
/// numbers becomes a float column, any other column is kept as text (so a later consumer can name
/// the offending cell). Used where the columns are chosen by the user (`doe analyze --response`).
///
/// # Examples
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("runs.csv");
/// std::fs::write(&path, "depth_um,fx_n,note\n100,1.78,ok\n200,n/a,redo\n").unwrap();
/// let t = millcomp_datasets::read_any(&path).unwrap();
/// assert_eq!(t.f64s("depth_um").unwrap(), [100.0, 200.0]);
/// assert_eq!(t.strings("fx_n").unwrap(), ["1.78", "n/a"]); // kept as text: `n/a` is not a number
/// ```
///
/// # Errors
/// [`DatasetError::Io`], [`DatasetError::Empty`], [`DatasetError::Parse`],
/// [`DatasetError::UnreadableColumn`], [`DatasetError::DuplicateColumn`].
pub fn read_any(path: &Path) -> Result<Table, DatasetError> {
    typed(path, read_raw(path)?)
}

/// Reads embedded CSV text (a shipped record) as [`read_any`] reads a file; `origin` names it in
/// errors.
///
/// ```
/// let t = millcomp_datasets::read_any_str("rec.csv", "time_s,note\n0,a\n15,b\n").unwrap();
/// assert_eq!(t.f64s("time_s").unwrap(), [0.0, 15.0]);
/// assert_eq!(t.strings("note").unwrap(), ["a", "b"]);
/// ```
///
/// # Errors
/// As [`read_any`], without [`DatasetError::Io`].
pub fn read_any_str(origin: &str, text: &str) -> Result<Table, DatasetError> {
    let path = PathBuf::from(origin);
    let raw = read_csv_bytes(&path, text.as_bytes())?;
    typed(&path, raw)
}

/// Types every column of a raw table: all-finite-number columns as floats, the others as text.
fn typed(path: &Path, raw: RawTable) -> Result<Table, DatasetError> {
    let RawTable {
        names,
        cells,
        notes,
    } = raw;
    if names.is_empty() {
        return Err(DatasetError::Empty {
            file: path.to_path_buf(),
            what: "header",
        });
    }
    if cells.first().is_none_or(Vec::is_empty) {
        return Err(DatasetError::Empty {
            file: path.to_path_buf(),
            what: "data rows",
        });
    }
    let columns = names
        .into_iter()
        .zip(cells)
        .map(|(name, cells)| typed_column(name, cells))
        .collect();
    Ok(Table {
        origin: path.display().to_string(),
        columns,
        ignored_columns: Vec::new(),
        notes,
    })
}

/// One column typed as [`read_any`] types it: all finite numbers → floats, anything else text.
fn typed_column(name: String, cells: Vec<Option<String>>) -> Column {
    let numbers: Option<Vec<f64>> = cells
        .iter()
        .map(|c| {
            c.as_deref()
                .and_then(|t| t.parse::<f64>().ok())
                .filter(|x| x.is_finite())
        })
        .collect();
    let data = match numbers {
        Some(v) => ColumnData::Float(v),
        None => ColumnData::Text(cells.into_iter().map(Option::unwrap_or_default).collect()),
    };
    Column { name, data }
}

/// A data frame in memory (a Python caller's, through Arrow) typed as [`read_any`] types a file with
/// the same cells: a numeric column without nulls and with finite values only becomes a float column
/// directly (no text in between); any other column is typed from its cells as text, by the same rule
/// as a file's (a text column whose cells all read as finite numbers becomes floats, a number column
/// with a null or NaN stays text, so the consumer names the cell). `origin` names the frame in errors
/// (`frame`, the argument's name).
///
/// ```
/// use polars::prelude::*;
/// let df = df!("depth_um" => [100i64, 200], "fx_n" => [1.5, f64::NAN], "note" => ["a", "b"]).unwrap();
/// let t = millcomp_datasets::table::from_dataframe("frame", &df).unwrap();
/// assert_eq!(t.f64s("depth_um").unwrap(), [100.0, 200.0]);
/// assert_eq!(t.strings("fx_n").unwrap(), ["1.5", "NaN"]); // kept as text: NaN is not a number
/// assert!(millcomp_datasets::table::from_dataframe("frame", &DataFrame::empty()).is_err());
/// ```
///
/// # Errors
/// [`DatasetError::Empty`] (no columns, no rows), [`DatasetError::DuplicateColumn`],
/// [`DatasetError::UnreadableColumn`] (a column polars cannot show as text).
pub fn from_dataframe(origin: &str, df: &DataFrame) -> Result<Table, DatasetError> {
    let path = PathBuf::from(origin);
    let mut columns: Vec<Column> = Vec::with_capacity(df.width());
    for col in df.columns() {
        let name = col.name().to_string();
        if columns.iter().any(|c| c.name == name) {
            return Err(DatasetError::DuplicateColumn {
                file: path,
                column: name,
            });
        }
        let floats = col
            .dtype()
            .is_primitive_numeric()
            .then(|| col.cast(&DataType::Float64).ok())
            .flatten()
            .filter(|c| c.null_count() == 0)
            .and_then(|c| {
                c.f64()
                    .ok()
                    .map(|ca| ca.into_no_null_iter().collect::<Vec<f64>>())
            })
            .filter(|v| v.iter().all(|x| x.is_finite()));
        match floats {
            Some(v) => columns.push(Column {
                name,
                data: ColumnData::Float(v),
            }),
            None => {
                let one = DataFrame::new(col.len(), vec![col.clone()]).map_err(|source| {
                    DatasetError::UnreadableColumn {
                        file: path.clone(),
                        column: name.clone(),
                        source,
                    }
                })?;
                let mut raw = raw_from_dataframe(&path, &one, Vec::new())?;
                columns.push(typed_column(name, raw.cells.remove(0)));
            }
        }
    }
    if columns.is_empty() {
        return Err(DatasetError::Empty {
            file: path,
            what: "header",
        });
    }
    if df.height() == 0 {
        return Err(DatasetError::Empty {
            file: path,
            what: "data rows",
        });
    }
    Ok(Table {
        origin: origin.to_string(),
        columns,
        ignored_columns: Vec::new(),
        notes: Vec::new(),
    })
}

/// A data frame in memory validated against `schema` as [`read_table`] validates a file with the
/// same cells (every cell read as text, then parsed by the schema's kind); `origin` names the frame in
/// errors.
///
/// # Errors
/// As [`read_table`], without [`DatasetError::Io`].
pub fn read_dataframe(
    origin: &str,
    df: &DataFrame,
    schema: &Schema,
) -> Result<Table, DatasetError> {
    let path = PathBuf::from(origin);
    let raw = raw_from_dataframe(&path, df, Vec::new())?;
    validate(&path, raw, schema)
}

/// Reads embedded CSV text (a shipped dataset) and validates it against `schema`; `origin` names it in
/// errors.
///
/// # Examples
/// ```
/// use millcomp_datasets::{read_csv_str, ColumnKind, ColumnSpec, DatasetError, Schema};
/// let schema = Schema::new("walls", vec![ColumnSpec::required("nominal_um", ColumnKind::Float, "wall")]);
/// // 004_…txt Table 5: nominal wall thicknesses
/// let t = read_csv_str("walls.csv", "nominal_um\n80\n100\n120\n", &schema).unwrap();
/// assert_eq!(t.f64s("nominal_um").unwrap(), [80.0, 100.0, 120.0]);
/// let e = read_csv_str("walls.csv", "thickness_um\n80\n", &schema).unwrap_err();
/// assert!(matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "nominal_um"));
/// ```
///
/// # Errors
/// As [`read_table`], without [`DatasetError::Io`].
pub fn read_csv_str(origin: &str, text: &str, schema: &Schema) -> Result<Table, DatasetError> {
    let path = PathBuf::from(origin);
    let raw = read_csv_bytes(&path, text.as_bytes())?;
    validate(&path, raw, schema)
}

/// Renames of a file's header before validation: `(file column, new name)` pairs, constant columns
/// `(name, value)` added on every row, and file columns to drop.
pub(crate) type HeaderRenames = (Vec<(String, String)>, Vec<(String, f64)>, Vec<String>);

/// Reads `path`, lets `renames` rename its header (the column mapping, [`crate::mapping`]), then
/// validates against `schema` as [`read_table`] does.
pub(crate) fn read_table_renamed(
    path: &Path,
    schema: &Schema,
    renames: impl FnOnce(&[String]) -> Result<HeaderRenames, DatasetError>,
) -> Result<Table, DatasetError> {
    let mut raw = read_raw(path)?;
    let (pairs, constants, drop) = renames(&raw.names)?;
    let n_rows = raw.cells.first().map_or(0, Vec::len);
    let keep: Vec<bool> = raw.names.iter().map(|n| !drop.contains(n)).collect();
    let mut names = Vec::new();
    let mut cells = Vec::new();
    let mut copies = Vec::new();
    for ((name, col), k) in raw.names.into_iter().zip(raw.cells).zip(keep) {
        if !k {
            continue;
        }
        // a column read under a second role is copied
        for (_, new) in pairs.iter().filter(|(old, _)| *old == name).skip(1) {
            copies.push((new.clone(), col.clone()));
        }
        let name = pairs
            .iter()
            .find(|(old, _)| *old == name)
            .map_or(name, |(_, new)| new.clone());
        names.push(name);
        cells.push(col);
    }
    for (name, col) in copies {
        names.push(name);
        cells.push(col);
    }
    for (name, x) in constants {
        if let Some(i) = names.iter().position(|n| *n == name) {
            names.remove(i);
            cells.remove(i);
        }
        names.push(name);
        cells.push(vec![Some(x.to_string()); n_rows]);
    }
    raw = RawTable {
        names,
        cells,
        notes: raw.notes,
    };
    validate(path, raw, schema)
}

/// Every column of a file as text cells (`None` = empty/null), in file order, and how the file was read.
struct RawTable {
    names: Vec<String>,
    cells: Vec<Vec<Option<String>>>,
    notes: Vec<String>,
}

fn is_parquet(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()),
        Some(ref e) if e == "parquet" || e == "pq"
    )
}

fn read_raw(path: &Path) -> Result<RawTable, DatasetError> {
    let io = |source| DatasetError::Io {
        file: path.to_path_buf(),
        source,
    };
    if std::fs::metadata(path).map_err(io)?.is_dir() {
        return Err(DatasetError::NotAFile {
            file: path.to_path_buf(),
        });
    }
    if is_parquet(path) {
        guarded(path, "Parquet", || read_parquet(path))
    } else {
        // read whole (also from a pipe, whose size the file system does not know), then decoded
        let bytes = std::fs::read(path).map_err(io)?;
        read_csv_bytes(path, &bytes)
    }
}

/// The table reader's boundary around polars: a panic inside it (a dependency's bug on some input)
/// becomes [`DatasetError::Parse`] naming the file, the panic's message kept as the error's source,
/// rather than unwinding through whatever called the reader (a CLI verb, a batch worker, a Python
/// session). The panic hook still prints where it happened, for the bug report.
fn guarded<T>(
    path: &Path,
    format: &'static str,
    read: impl FnOnce() -> Result<T, DatasetError>,
) -> Result<T, DatasetError> {
    let run = || {
        #[cfg(test)]
        tests::injected_panic();
        read()
    };
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)).unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".to_string());
        Err(DatasetError::Parse {
            file: path.to_path_buf(),
            format,
            source: PolarsError::ComputeError(
                format!(
                    "the {format} reader panicked on this file ({what}): a bug in the reader, \
                     not necessarily in the file; please report it with the file"
                )
                .into(),
            ),
        })
    })
}

fn read_parquet(path: &Path) -> Result<RawTable, DatasetError> {
    let io = |source| DatasetError::Io {
        file: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(io)?;
    if file.metadata().map(|m| m.len()).unwrap_or(0) == 0 {
        return Err(DatasetError::Empty {
            file: path.to_path_buf(),
            what: "header",
        });
    }
    let df = ParquetReader::new(file)
        .finish()
        .map_err(|source| DatasetError::Parse {
            file: path.to_path_buf(),
            format: "Parquet",
            source,
        })?;
    raw_from_dataframe(path, &df, Vec::new())
}

/// A CSV file's bytes as text cells: decoded ([`crate::decode::decode_text`]), split on the delimiter
/// of its header line ([`crate::decode::sniff_delimiter`]) by polars, every cell read as text, then the
/// numbers of each column normalised ([`crate::decode::normalise_columns`]). What was not plain UTF-8 with
/// commas and decimal points is noted.
fn read_csv_bytes(path: &Path, bytes: &[u8]) -> Result<RawTable, DatasetError> {
    guarded(path, "CSV", || read_csv_unguarded(path, bytes))
}

fn read_csv_unguarded(path: &Path, bytes: &[u8]) -> Result<RawTable, DatasetError> {
    let empty = || DatasetError::Empty {
        file: path.to_path_buf(),
        what: "header",
    };
    let (text, encoding) =
        crate::decode::decode_text(bytes).map_err(|e| DatasetError::NotText {
            file: path.to_path_buf(),
            message: e.message,
        })?;
    if text.trim().is_empty() {
        return Err(empty());
    }
    let delimiter = crate::decode::sniff_delimiter(&text);
    let mut notes: Vec<String> = encoding.note().into_iter().collect();
    if delimiter != b',' {
        notes.push(format!(
            "columns separated by {}",
            crate::decode::delimiter_name(delimiter)
        ));
    }
    let df = CsvReadOptions::default()
        .with_has_header(true)
        .with_infer_schema_length(Some(0))
        .map_parse_options(|o| o.with_separator(delimiter))
        .into_reader_with_file_handle(std::io::Cursor::new(text.as_bytes()))
        .finish()
        .map_err(|source| {
            if let Some((row, fields, expected)) = ragged_row(&text, delimiter) {
                return DatasetError::RaggedRow {
                    file: path.to_path_buf(),
                    row,
                    fields,
                    expected,
                    delimiter: crate::decode::delimiter_name(delimiter),
                };
            }
            if source.to_string().contains("empty") {
                empty()
            } else {
                DatasetError::Parse {
                    file: path.to_path_buf(),
                    format: "CSV",
                    source,
                }
            }
        })?;
    // polars renames a repeated header name (`a`, `a_duplicated_0`): the header as written decides
    if let Some(column) = repeated_header(&text, delimiter) {
        return Err(DatasetError::DuplicateColumn {
            file: path.to_path_buf(),
            column,
        });
    }
    let mut raw = raw_from_dataframe(path, &df, notes)?;
    let comma_by_default = delimiter != b',';
    // on a contradiction nothing is changed: the cells are still as written
    match crate::decode::normalise_columns(&mut raw.cells, comma_by_default) {
        Ok(marks) => {
            for (name, mark) in raw.names.iter().zip(marks) {
                if let Some(mark) = mark {
                    raw.notes.push(crate::decode::number_note(name, mark));
                }
            }
        }
        Err((j, i)) => {
            let cells = &raw.cells[j];
            let other = cells
                .iter()
                .take(i)
                .filter_map(|c| c.as_deref())
                .find(|c| c.contains([',', '.']))
                .unwrap_or("")
                .to_string();
            return Err(DatasetError::Invalid {
                file: path.to_path_buf(),
                column: raw.names[j].clone(),
                row: i + 1,
                message: format!(
                    "`{}` uses the other decimal mark than `{other}` above it: write every number \
                     of the column with the same decimal mark (and no digit groups)",
                    cells[i].as_deref().unwrap_or("")
                ),
            });
        }
    }
    Ok(raw)
}

/// The first name the header line repeats, read as written (polars renames repeats).
fn repeated_header(text: &str, delimiter: u8) -> Option<String> {
    let df = CsvReadOptions::default()
        .with_has_header(false)
        .with_n_rows(Some(1))
        .with_infer_schema_length(Some(0))
        .map_parse_options(|o| o.with_separator(delimiter).with_truncate_ragged_lines(true))
        .into_reader_with_file_handle(std::io::Cursor::new(text.as_bytes()))
        .finish()
        .ok()?;
    let mut seen = std::collections::HashSet::with_capacity(df.width());
    for col in df.columns() {
        let name = col.str().ok()?.get(0).unwrap_or("").trim().to_string();
        if !seen.insert(name.clone()) {
            return Some(name);
        }
    }
    None
}

/// The first data row (1-based) with more fields than the header, with its field count and the header's,
/// read by polars with room for one more column; `None` when no row has more (the parse error was
/// something else).
fn ragged_row(text: &str, delimiter: u8) -> Option<(usize, usize, usize)> {
    let header = crate::decode::header_fields(text, delimiter);
    // generous room: a row may have many more fields (a decimal comma in every cell)
    let width = header * 2 + 1;
    let schema: polars::prelude::Schema = (0..width)
        .map(|i| Field::new(format!("c{i}").into(), DataType::String))
        .collect();
    let df = CsvReadOptions::default()
        .with_has_header(false)
        .with_skip_rows(1)
        .with_schema(Some(std::sync::Arc::new(schema)))
        .map_parse_options(|o| o.with_separator(delimiter).with_truncate_ragged_lines(true))
        .into_reader_with_file_handle(std::io::Cursor::new(text.as_bytes()))
        .finish()
        .ok()?;
    let extra = df.column(&format!("c{header}")).ok()?.str().ok()?.clone();
    let row = extra.iter().position(|v| v.is_some())?;
    let fields = (0..width)
        .rev()
        .find(|&c| {
            df.column(&format!("c{c}"))
                .ok()
                .and_then(|col| col.str().ok().map(|ca| ca.get(row).is_some()))
                .unwrap_or(false)
        })
        .map_or(header + 1, |c| c + 1);
    Some((row + 1, fields, header))
}

fn raw_from_dataframe(
    path: &Path,
    df: &DataFrame,
    notes: Vec<String>,
) -> Result<RawTable, DatasetError> {
    let mut names = Vec::with_capacity(df.width());
    let mut cells = Vec::with_capacity(df.width());
    let mut notes = notes;
    // a set, not a scan of the names so far: a file of 100 000 columns is read in linear time
    let mut seen = std::collections::HashSet::with_capacity(df.width());
    let given: std::collections::HashSet<&str> =
        df.columns().iter().map(|c| c.name().as_str()).collect();
    for col in df.columns() {
        let mut name = col.name().to_string();
        // `y_µm` as millcomp spells it, `y_um` (unless the file has both)
        if let Some(ascii) = crate::decode::ascii_unit_name(&name)
            && !given.contains(ascii.as_str())
        {
            notes.push(format!("column `{name}` read as `{ascii}`"));
            name = ascii;
        }
        if !seen.insert(name.clone()) {
            return Err(DatasetError::DuplicateColumn {
                file: path.to_path_buf(),
                column: name,
            });
        }
        let unreadable = |source| DatasetError::UnreadableColumn {
            file: path.to_path_buf(),
            column: name.clone(),
            source,
        };
        let as_text = col.cast(&DataType::String).map_err(unreadable)?;
        let ca = as_text.str().map_err(unreadable)?;
        cells.push(
            ca.iter()
                .map(|v| v.map(|s| s.trim().to_string()).filter(|s| !s.is_empty()))
                .collect(),
        );
        names.push(name);
    }
    Ok(RawTable {
        names,
        cells,
        notes,
    })
}

fn parse_cell(
    path: &Path,
    column: &str,
    row: usize,
    text: &str,
    kind: ColumnKind,
) -> Result<CellValue, DatasetError> {
    let bad = || DatasetError::BadCell {
        file: path.to_path_buf(),
        column: column.to_string(),
        row,
        value: text.to_string(),
        expected: kind.describe(),
    };
    match kind {
        ColumnKind::Float => {
            let x: f64 = text.parse().map_err(|_| bad())?;
            if x.is_finite() {
                Ok(CellValue::Float(x))
            } else {
                Err(DatasetError::NonFinite {
                    file: path.to_path_buf(),
                    column: column.to_string(),
                    row,
                    value: text.to_string(),
                })
            }
        }
        ColumnKind::Int => {
            if let Ok(i) = text.parse::<i64>() {
                return Ok(CellValue::Int(i));
            }
            // Accept "3.0" written by spreadsheet tools, not "3.5".
            match text.parse::<f64>() {
                Ok(x) if x.is_finite() && x.fract() == 0.0 && x.abs() < 9.0e15 => {
                    Ok(CellValue::Int(x as i64))
                }
                _ => Err(bad()),
            }
        }
        ColumnKind::Flag => match text {
            "0" | "0.0" | "false" | "FALSE" | "False" => Ok(CellValue::Int(0)),
            "1" | "1.0" | "true" | "TRUE" | "True" => Ok(CellValue::Int(1)),
            _ => Err(bad()),
        },
        ColumnKind::Text => Ok(CellValue::Text(text.to_string())),
        ColumnKind::Reading => {
            let x: f64 = text.parse().map_err(|_| bad())?;
            if x.is_infinite() {
                Err(DatasetError::NonFinite {
                    file: path.to_path_buf(),
                    column: column.to_string(),
                    row,
                    value: text.to_string(),
                })
            } else {
                Ok(CellValue::Float(x))
            }
        }
    }
}

enum CellValue {
    Float(f64),
    Int(i64),
    Text(String),
}

fn validate(path: &Path, raw: RawTable, schema: &Schema) -> Result<Table, DatasetError> {
    if raw.names.is_empty() {
        return Err(DatasetError::Empty {
            file: path.to_path_buf(),
            what: "header",
        });
    }
    let n_rows = raw.cells.first().map_or(0, Vec::len);
    for spec in schema.columns.iter().filter(|s| s.required) {
        if !raw.names.iter().any(|n| n == &spec.name) {
            return Err(DatasetError::MissingColumn {
                file: path.to_path_buf(),
                column: spec.name.clone(),
                present: raw.names.join(", "),
            });
        }
    }
    if n_rows == 0 {
        return Err(DatasetError::Empty {
            file: path.to_path_buf(),
            what: "data rows",
        });
    }
    let mut columns = Vec::new();
    for spec in &schema.columns {
        let Some(idx) = raw.names.iter().position(|n| n == &spec.name) else {
            continue;
        };
        let mut data = match spec.kind {
            ColumnKind::Float | ColumnKind::Reading => {
                ColumnData::Float(Vec::with_capacity(n_rows))
            }
            ColumnKind::Int | ColumnKind::Flag => ColumnData::Int(Vec::with_capacity(n_rows)),
            ColumnKind::Text => ColumnData::Text(Vec::with_capacity(n_rows)),
        };
        for (i, cell) in raw.cells[idx].iter().enumerate() {
            let row = i + 1;
            let value = match cell {
                Some(text) => parse_cell(path, &spec.name, row, text, spec.kind)?,
                None if spec.kind == ColumnKind::Text => CellValue::Text(String::new()),
                None if spec.kind == ColumnKind::Reading => CellValue::Float(f64::NAN),
                None => {
                    return Err(DatasetError::EmptyCell {
                        file: path.to_path_buf(),
                        column: spec.name.clone(),
                        row,
                    });
                }
            };
            match (&mut data, value) {
                (ColumnData::Float(v), CellValue::Float(x)) => v.push(x),
                (ColumnData::Int(v), CellValue::Int(x)) => v.push(x),
                (ColumnData::Text(v), CellValue::Text(x)) => v.push(x),
                _ => unreachable!("parse_cell returns the kind it was asked for"),
            }
        }
        columns.push(Column {
            name: spec.name.clone(),
            data,
        });
    }
    let mut ignored = Vec::new();
    for (name, cells) in raw.names.iter().zip(&raw.cells) {
        if schema.columns.iter().any(|s| &s.name == name) {
            continue;
        }
        if schema.keep_extra {
            columns.push(Column {
                name: name.clone(),
                data: ColumnData::Text(
                    cells
                        .iter()
                        .map(|c| c.clone().unwrap_or_default())
                        .collect(),
                ),
            });
        } else {
            ignored.push(name.clone());
        }
    }
    Ok(Table {
        origin: path.display().to_string(),
        columns,
        ignored_columns: ignored,
        notes: raw.notes,
    })
}

/// Output formats for [`write_table`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    /// Comma-separated text with a header.
    Csv,
    /// Apache Parquet.
    Parquet,
}

impl TableFormat {
    /// The format implied by a file name's extension (`.csv`; `.parquet` or `.pq`; any case).
    ///
    /// ```
    /// use std::path::Path;
    /// use millcomp_datasets::TableFormat;
    /// assert_eq!(TableFormat::from_path(Path::new("out.PQ")).unwrap(), TableFormat::Parquet);
    /// assert!(TableFormat::from_path(Path::new("out.xlsx")).is_err());
    /// ```
    ///
    /// # Errors
    /// [`DatasetError::UnsupportedFormat`] for any other extension.
    pub fn from_path(path: &Path) -> Result<Self, DatasetError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("csv") => Ok(TableFormat::Csv),
            Some("parquet") | Some("pq") => Ok(TableFormat::Parquet),
            _ => Err(DatasetError::UnsupportedFormat {
                file: path.to_path_buf(),
            }),
        }
    }
}

/// Writes `table` to `path` (format from the extension) through a temporary file in the same
/// directory that is renamed into place, so a failure never leaves a half-written file.
///
/// # Examples
/// ```
/// use millcomp_datasets::{read_table, write_table};
/// let t = millcomp_datasets::load("thin_wall_results").unwrap();
/// let dir = tempfile::tempdir().unwrap();
/// for name in ["walls.csv", "walls.parquet"] {
///     let path = dir.path().join(name);
///     write_table(&t, &path).unwrap();
///     let back = read_table(&path, &millcomp_datasets::dataset("thin_wall_results").unwrap().schema()).unwrap();
///     // 004_…txt Table 5: the 80 µm wall measured 85.9 µm uncompensated, 81.9 µm compensated
///     assert_eq!(back.f64s("uncompensated_um").unwrap()[0], 85.9);
///     assert_eq!(back.f64s("compensated_um").unwrap()[0], 81.9);
/// }
/// ```
///
/// # Errors
/// [`DatasetError::UnsupportedFormat`] (nothing is written), [`DatasetError::Encode`] (building the frame),
/// [`DatasetError::Write`] (the atomic write or polars' encoder failed; nothing is left at `path`).
pub fn write_table(table: &Table, path: &Path) -> Result<(), DatasetError> {
    let format = TableFormat::from_path(path)?;
    let mut df = table.to_dataframe()?;
    write_atomic(path, |file| match format {
        TableFormat::Csv => csv_to(&mut df, file),
        TableFormat::Parquet => ParquetWriter::new(file).finish(&mut df).map(|_| ()),
    })
}

/// Writes `table` as CSV (header + rows, the same text [`write_table`] writes to a `.csv` file) to
/// `out`, e.g. standard output.
///
/// ```
/// use millcomp_datasets::{Column, ColumnData, Table};
/// let t = Table::from_columns("mem", vec![
///     Column { name: "tilt_deg".into(), data: ColumnData::Float(vec![20.0, 30.5]) },
///     Column { name: "method".into(), data: ColumnData::Text(vec!["pid".into(), "mpc".into()]) },
/// ]).unwrap();
/// let mut out = Vec::new();
/// millcomp_datasets::write_csv_to(&t, &mut out).unwrap();
/// assert_eq!(String::from_utf8(out).unwrap(), "tilt_deg,method\n20.0,pid\n30.5,mpc\n");
/// ```
///
/// # Errors
/// [`DatasetError::Encode`] when the frame cannot be built or polars' CSV writer fails (its error, e.g.
/// the writer's I/O error, is the source).
pub fn write_csv_to<W: Write>(table: &Table, out: W) -> Result<(), DatasetError> {
    let mut df = table.to_dataframe()?;
    csv_to(&mut df, out).map_err(|source| DatasetError::Encode {
        file: PathBuf::from(&table.origin),
        format: "CSV",
        source,
    })
}

fn csv_to<W: Write>(df: &mut DataFrame, out: W) -> PolarsResult<()> {
    CsvWriter::new(out).include_header(true).finish(df)
}

/// Writes bytes produced by `fill` to `path` atomically (temporary file + rename; the one atomic writer,
/// `millcomp_models::write_atomic`). `fill` may fail with any error (an I/O error, polars' error, a
/// message); it becomes the source of the [`DatasetError::Write`].
///
/// ```
/// use std::io::Write;
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("plan.json");
/// millcomp_datasets::write_atomic(&path, |f| f.write_all(b"{\"runs\": 8}")).unwrap();
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "{\"runs\": 8}");
/// // A failing fill leaves the previous file as it was, and no temporary file.
/// let e = millcomp_datasets::write_atomic(&path, |_| Err("disk full")).unwrap_err();
/// assert!(e.to_string().contains("plan.json"));
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "{\"runs\": 8}");
/// assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
/// ```
///
/// # Errors
/// [`DatasetError::Write`] naming `path`, with the atomic writer's error (which step failed) as source.
pub fn write_atomic<F, E>(path: &Path, fill: F) -> Result<(), DatasetError>
where
    F: FnOnce(&mut File) -> Result<(), E>,
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    millcomp_models::write_atomic(path, |f| fill(f).map_err(std::io::Error::other)).map_err(
        |source| DatasetError::Write {
            file: path.to_path_buf(),
            source: Box::new(source),
        },
    )
}

/// Writes text to `path` atomically (see [`write_atomic`]).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("report.md");
/// millcomp_datasets::write_text_atomic(&path, "# Report\n").unwrap();
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "# Report\n");
/// assert!(millcomp_datasets::write_text_atomic(&dir.path().join("no/dir/x.md"), "x").is_err());
/// ```
///
/// # Errors
/// [`DatasetError::Write`] naming `path`.
pub fn write_text_atomic(path: &Path, text: &str) -> Result<(), DatasetError> {
    write_atomic(path, |f| f.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        /// Set by a test: the next read through [`guarded`] on this thread panics inside the boundary
        /// with this message, as a bug inside polars would.
        static PANIC_INSIDE_READER: std::cell::Cell<Option<&'static str>> =
            const { std::cell::Cell::new(None) };
    }

    /// The test hook of [`guarded`] (test builds only): panics once when a test asked for it.
    pub(super) fn injected_panic() {
        if let Some(message) = PANIC_INSIDE_READER.take() {
            panic!("{message}");
        }
    }

    /// A panic inside the reader (polars) is an error naming the file and the panic, for every way in
    /// (a CSV file with and without a schema, embedded CSV text, a Parquet file), and the next read is
    /// not affected.
    #[test]
    fn a_panic_inside_the_reader_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("forces.csv");
        std::fs::write(&csv, "a_um,n\n1.5,2\n").unwrap();
        let parquet = dir.path().join("forces.parquet");
        write_table(&read_any(&csv).unwrap(), &parquet).unwrap();
        let message = "index out of bounds: the len is 3 but the index is 7";
        type Read<'a> = Box<dyn Fn() -> Result<Table, DatasetError> + 'a>;
        let reads: [(&Path, &str, Read); 4] = [
            (&csv, "CSV", Box::new(|| read_table(&csv, &schema()))),
            (&csv, "CSV", Box::new(|| read_any(&csv))),
            (
                Path::new("embedded.csv"),
                "CSV",
                Box::new(|| read_any_str("embedded.csv", "a_um,n\n1.5,2\n")),
            ),
            (&parquet, "Parquet", Box::new(|| read_any(&parquet))),
        ];
        for (path, format, read) in reads {
            assert_eq!(read().unwrap().n_rows(), 1, "{}", path.display());
            PANIC_INSIDE_READER.set(Some(message));
            let e = read().unwrap_err();
            assert!(
                matches!(&e, DatasetError::Parse { file, format: f, .. } if file == path && *f == format),
                "{e:?}"
            );
            let source = std::error::Error::source(&e).expect("the panic as the source");
            assert_eq!(
                format!("{e}: {source}"),
                format!(
                    "{}: cannot parse as {format}: the {format} reader panicked on this file ({message}): \
                     a bug in the reader, not necessarily in the file; please report it with the file",
                    path.display()
                )
            );
            assert_eq!(
                read().unwrap().n_rows(),
                1,
                "{} after the panic",
                path.display()
            );
        }
    }

    fn schema() -> Schema {
        Schema::new(
            "t",
            vec![
                ColumnSpec::required("a_um", ColumnKind::Float, "a"),
                ColumnSpec::required("n", ColumnKind::Int, "n"),
                ColumnSpec::optional("flag", ColumnKind::Flag, "f"),
            ],
        )
    }

    #[test]
    fn parses_types_and_notes_extra_columns() {
        let t = read_csv_str("mem.csv", "a_um,n,extra\n1.5,2,x\n-3e-1,4,y\n", &schema()).unwrap();
        assert_eq!(t.f64s("a_um").unwrap(), vec![1.5, -0.3]);
        assert_eq!(t.i64s("n").unwrap(), vec![2, 4]);
        assert_eq!(t.ignored_columns, vec!["extra".to_string()]);
        assert!(t.column("flag").is_none());
    }

    #[test]
    fn errors_name_column_and_row() {
        let e = read_csv_str("mem.csv", "a_um,n\n1,2\nabc,3\n", &schema()).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("a_um") && msg.contains("row 2") && msg.contains("abc"),
            "{msg}"
        );
        let e = read_csv_str("mem.csv", "a_um,n\n1,2\nNaN,3\n", &schema()).unwrap_err();
        assert!(matches!(e, DatasetError::NonFinite { row: 2, .. }), "{e}");
        let e = read_csv_str("mem.csv", "a_um\n1\n", &schema()).unwrap_err();
        assert!(matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "n"));
        let e = read_csv_str("mem.csv", "a_um,n\n", &schema()).unwrap_err();
        assert!(matches!(e, DatasetError::Empty { .. }), "{e}");
        let e = read_csv_str("mem.csv", "a_um,n\n1,\n", &schema()).unwrap_err();
        assert!(matches!(e, DatasetError::EmptyCell { row: 1, .. }), "{e}");
        let e = read_csv_str("mem.csv", "a_um,n,flag\n1,2,3\n", &schema()).unwrap_err();
        assert!(matches!(e, DatasetError::BadCell { ref column, .. } if column == "flag"));
    }

    #[test]
    fn round_trips_through_csv_and_parquet() {
        let dir = tempfile::tempdir().unwrap();
        let t = read_csv_str("mem.csv", "a_um,n,flag\n1.25,2,1\n3,4,0\n", &schema()).unwrap();
        for name in ["out.csv", "out.parquet"] {
            let p = dir.path().join(name);
            write_table(&t, &p).unwrap();
            let back = read_table(&p, &schema()).unwrap();
            assert_eq!(back.f64s("a_um").unwrap(), vec![1.25, 3.0]);
            assert_eq!(back.i64s("flag").unwrap(), vec![1, 0]);
        }
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
            .collect();
        assert!(leftovers.is_empty());
    }

    #[test]
    fn read_any_keeps_bad_numeric_columns_as_text() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        std::fs::write(&p, "x,y,label\n1,2,a\n3,NaN,b\n").unwrap();
        let t = read_any(&p).unwrap();
        assert_eq!(t.f64s("x").unwrap(), vec![1.0, 3.0]);
        assert_eq!(t.strings("y").unwrap(), vec!["2", "NaN"]);
        assert!(t.f64s("label").is_err());
    }

    #[test]
    fn causes_are_sources_not_copied_into_the_message() {
        use std::error::Error as _;
        let dir = tempfile::tempdir().unwrap();
        // a missing file: the I/O error is the source
        let e = read_any(&dir.path().join("missing.csv")).unwrap_err();
        assert!(matches!(e, DatasetError::Io { .. }), "{e}");
        let cause = e.source().unwrap().to_string();
        assert!(!e.to_string().contains(&cause), "{e}");
        // a file that is not Parquet: polars' error is the source
        let p = dir.path().join("bad.parquet");
        std::fs::write(&p, "not parquet").unwrap();
        let e = read_any(&p).unwrap_err();
        assert!(
            matches!(
                e,
                DatasetError::Parse {
                    format: "Parquet",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.source().is_some());
        // a destination whose directory does not exist: the atomic writer's error, and under it the I/O error
        let t = read_csv_str("mem.csv", "a_um,n\n1,2\n", &schema()).unwrap();
        let e = write_table(&t, &dir.path().join("no/such/dir/out.csv")).unwrap_err();
        assert!(matches!(e, DatasetError::Write { .. }), "{e}");
        let writer = e.source().unwrap();
        assert!(writer.to_string().contains("temporary file"), "{writer}");
        assert!(writer.source().is_some(), "{writer}");
    }

    /// The step response as written, and the numbers read from it.
    fn plain() -> (String, Vec<f64>) {
        let text = "t_s,u_v,y_um\n0.00000,0,0.239249\n0.00005,100,1.252192\n0.00010,100,1234.5\n"
            .to_string();
        (text, vec![0.239249, 1.252192, 1234.5])
    }

    #[test]
    fn what_european_and_windows_instruments_write_reads_as_the_plain_file() {
        let dir = tempfile::tempdir().unwrap();
        let (text, y) = plain();
        let reference = read_any_str("plain.csv", &text).unwrap();
        assert!(reference.notes.is_empty(), "{:?}", reference.notes);
        let mut utf16le = vec![0xFF, 0xFE];
        utf16le.extend(text.encode_utf16().flat_map(|u| u.to_le_bytes()));
        let mut utf16be = vec![0xFE, 0xFF];
        utf16be.extend(text.encode_utf16().flat_map(|u| u.to_be_bytes()));
        let no_bom: Vec<u8> = text.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
        let mut bom = b"\xEF\xBB\xBF".to_vec();
        bom.extend(text.as_bytes());
        let semicolons = text.replace(',', ";").replace('.', ",");
        // digit groups as a German instrument writes them
        let grouped = semicolons.replace("1234,5", "1.234,5");
        let english = text.replace("1234.5", "\"1,234.5\"");
        let tabs = text.replace(',', "\t").replace('\n', "\r\n");
        for (what, bytes) in [
            ("utf16le", utf16le),
            ("utf16be", utf16be),
            ("utf16-no-bom", no_bom),
            ("bom", bom),
            ("semicolons", semicolons.into_bytes()),
            ("grouped", grouped.into_bytes()),
            ("english-groups", english.into_bytes()),
            ("tabs", tabs.into_bytes()),
        ] {
            let p = dir.path().join(format!("{what}.csv"));
            std::fs::write(&p, bytes).unwrap();
            let t = read_any(&p).unwrap();
            assert_eq!(t.names(), ["t_s", "u_v", "y_um"], "{what}");
            assert_eq!(t.f64s("y_um").unwrap(), y, "{what}");
            assert_eq!(
                t.f64s("t_s").unwrap(),
                reference.f64s("t_s").unwrap(),
                "{what}"
            );
        }
        // a Windows-1252 header: µ is byte B5
        let p = dir.path().join("win.csv");
        std::fs::write(&p, b"t_s,y_\xB5m\n0,1.5\n").unwrap();
        let t = read_any(&p).unwrap();
        assert_eq!(t.names(), ["t_s", "y_um"]);
        assert!(
            t.notes.iter().any(|n| n.contains("Windows-1252")),
            "{:?}",
            t.notes
        );
    }

    #[test]
    fn what_cannot_be_read_is_named_with_what_to_change() {
        let dir = tempfile::tempdir().unwrap();
        // a directory, once
        let e = read_any(dir.path()).unwrap_err();
        assert!(matches!(e, DatasetError::NotAFile { .. }), "{e}");
        // a row with more fields than the header
        let e = read_csv_str("r.csv", "a_um,n\n1,2\n3,4,5\n", &schema()).unwrap_err();
        assert!(
            matches!(
                e,
                DatasetError::RaggedRow {
                    row: 2,
                    fields: 3,
                    expected: 2,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("row 2 (line 3)"), "{e}");
        // a missing-value marker where a number is needed
        let e = read_csv_str("m.csv", "a_um,n\n1,2\nNA,3\n", &schema()).unwrap_err();
        assert!(e.to_string().contains("missing value"), "{e}");
        // one decimal point among decimal commas
        let e = read_csv_str("d.csv", "a_um;n\n1,5;2\n2.5;3\n", &schema()).unwrap_err();
        assert!(
            matches!(&e, DatasetError::Invalid { row: 2, column, .. } if column == "a_um"),
            "{e}"
        );
        // a binary file
        let p = dir.path().join("sheet.csv");
        std::fs::write(&p, b"PK\x03\x04\x14\x00\x06\x00\x08\x00\x00\x00").unwrap();
        let e = read_any(&p).unwrap_err();
        assert!(e.to_string().contains("not a text file"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn a_pipe_is_read_as_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo.csv");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: no mkfifo here");
            return;
        }
        let writer = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::write(fifo, "x_um\n1\n2\n").unwrap())
        };
        let t = read_any(&fifo).unwrap();
        writer.join().unwrap();
        assert_eq!(t.f64s("x_um").unwrap(), [1.0, 2.0]);
    }

    #[test]
    fn a_hundred_thousand_columns_and_their_duplicates() {
        // read once (the duplicate check was quadratic: 29.5 s for this file, issue 51)
        let n = 100_000;
        let header: Vec<String> = (0..n).map(|i| format!("c{i}")).collect();
        let text = format!("{}\n{}\n", header.join(","), vec!["1"; n].join(","));
        let t = read_any_str("wide.csv", &text).unwrap();
        assert_eq!(t.columns.len(), n);
        let e = read_any_str("dup.csv", "a,b,a\n1,2,3\n").unwrap_err();
        assert!(e.to_string().contains("`a`"), "{e}");
    }

    #[test]
    fn unsupported_extension_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let t = read_csv_str("mem.csv", "a_um,n\n1,2\n", &schema()).unwrap();
        let p = dir.path().join("out.xlsx");
        assert!(matches!(
            write_table(&t, &p),
            Err(DatasetError::UnsupportedFormat { .. })
        ));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
