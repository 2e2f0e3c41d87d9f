//! What a call reads: a file path (read as the CLI reads it: `read_any`, then `--columns`) or a table
//! from Python (an Arrow stream, typed by the same rule), and the provenance of a model saved from it.

use std::path::{Path, PathBuf};

use anyhow::Context;
use millcomp_datasets::Table;
use millcomp_datasets::mapping::{ColumnMap, map_table};
use millcomp_models::{InputFile, Provenance};
use pyo3::prelude::*;
use pyo3::types::{PyCapsule, PyString};

use crate::errors::argument_error;

/// A table argument: a path, or a frame from Python.
#[derive(Clone)]
pub enum Source {
    /// A CSV or Parquet file.
    Path(PathBuf),
    /// A table handed over as an Arrow stream.
    Frame(polars::prelude::DataFrame),
}

impl Source {
    /// `obj` (a `str` path or the capsule of `__arrow_c_stream__()`) as a source; `argument` names it.
    pub fn of(obj: &Bound<'_, PyAny>, argument: &str) -> PyResult<Self> {
        if let Ok(s) = obj.cast::<PyString>() {
            return Ok(Source::Path(PathBuf::from(s.to_str()?)));
        }
        if obj.cast::<PyCapsule>().is_ok() {
            return Ok(Source::Frame(crate::arrow::from_capsule(obj, argument)?));
        }
        Err(argument_error(format!(
            "argument `{argument}`: expected a file path or a table, got {}",
            obj.get_type().name()?
        )))
    }
}

/// A table read for a call.
pub struct Read {
    /// The table, roles renamed by `columns`.
    pub table: Table,
    /// Notes of the mapping.
    pub notes: Vec<String>,
    /// The file, when it came from one.
    pub path: Option<PathBuf>,
    /// What errors call it: the path, or the argument's name.
    pub origin: String,
}

impl Read {
    /// The input as it goes into a model's provenance: the file and its SHA-256, or for a frame its
    /// cells (as CSV, the table writer's) hashed, under `(frame: ARGUMENT)`.
    pub fn input_file(&self) -> anyhow::Result<InputFile> {
        match &self.path {
            Some(p) => Ok(InputFile::from_path(p)?),
            None => {
                let mut bytes = Vec::new();
                millcomp_datasets::write_csv_to(&self.table, &mut bytes)?;
                Ok(InputFile::from_bytes(
                    &format!("(frame: {})", self.origin),
                    &bytes,
                ))
            }
        }
    }
}

/// Reads `source` as the CLI reads its FILE argument with `--columns` (`columns`, `role=column,…`).
pub fn read(source: Source, argument: &str, columns: Option<&str>) -> anyhow::Result<Read> {
    let map = match columns {
        Some(c) => ColumnMap::parse(c)?,
        None => ColumnMap::default(),
    };
    let (table, path, origin) = match source {
        Source::Path(p) => {
            let t = millcomp_datasets::read_any(&p)?;
            let origin = p.display().to_string();
            (t, Some(p), origin)
        }
        Source::Frame(df) => (
            millcomp_datasets::table::from_dataframe(argument, &df)?,
            None,
            argument.to_string(),
        ),
    };
    let m = map_table(table, &map)?;
    Ok(Read {
        table: m.table,
        notes: m.notes,
        path,
        origin,
    })
}

/// The provenance of a model the package saves: `millcomp-python VERSION`, the call as given by the
/// Python side, the time and the inputs.
pub fn provenance(command: &str, inputs: Vec<InputFile>) -> Provenance {
    let mut p = Provenance::now(
        &format!("millcomp-python {}", env!("CARGO_PKG_VERSION")),
        command,
    );
    p.inputs = inputs;
    p
}

/// The input file of a path given to a call (hashed for the provenance).
pub fn input_of(path: &Path) -> anyhow::Result<InputFile> {
    InputFile::from_path(path).with_context(|| format!("reading {}", path.display()))
}
