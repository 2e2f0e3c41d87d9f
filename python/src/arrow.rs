//! Tables across the boundary as Arrow C streams (the PyCapsule interface): a polars `DataFrame` in
//! Rust leaves as an object with `__arrow_c_stream__` that Python's `polars.DataFrame(obj)` imports
//! without a copy of the buffers and without pyarrow; a Python table arrives as the capsule of its own
//! `__arrow_c_stream__` and is imported by polars-arrow's FFI. No CSV in between, and no tie between
//! the Rust polars and the user's Python polars beyond the Arrow format.

use std::ffi::CStr;

use polars::prelude::{CompatLevel, DataFrame, PlSmallStr};
use polars_arrow::array::{Array, StructArray};
use polars_arrow::datatypes::{ArrowDataType, Field as ArrowField};
use polars_arrow::ffi::{ArrowArrayStream, ArrowArrayStreamReader, export_iterator};
use pyo3::prelude::*;
use pyo3::types::PyCapsule;

use crate::errors::argument_error;

/// The capsule name the Arrow PyCapsule interface gives a stream.
const STREAM: &CStr = c"arrow_array_stream";

/// A table on its way to Python: `polars.DataFrame(table)` (or any Arrow consumer) reads it through
/// `__arrow_c_stream__`. Each call exports a fresh stream, so it can be read more than once.
#[pyclass(name = "ArrowTable", module = "millcomp._core", frozen)]
pub struct PyArrowTable {
    df: DataFrame,
}

#[pymethods]
impl PyArrowTable {
    /// The Arrow PyCapsule stream protocol; `requested_schema` is accepted and ignored (the table has
    /// one schema).
    #[pyo3(signature = (requested_schema = None))]
    fn __arrow_c_stream__<'py>(
        &self,
        py: Python<'py>,
        requested_schema: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyCapsule>> {
        let _ = requested_schema;
        PyCapsule::new_with_value(py, export_stream(&self.df), STREAM)
    }

    /// Rows, columns.
    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.df.height(), self.df.width())
    }
}

/// The frame as a C stream of struct arrays, one per chunk.
fn export_stream(df: &DataFrame) -> ArrowArrayStream {
    let mut df = df.clone();
    df.rechunk_mut();
    let compat = CompatLevel::newest();
    let fields: Vec<ArrowField> = df
        .columns()
        .iter()
        .map(|c| c.field().to_arrow(compat))
        .collect();
    let dtype = ArrowDataType::Struct(fields);
    let batches: Vec<polars::prelude::PolarsResult<Box<dyn Array>>> = df
        .iter_chunks(compat, false)
        .map(|batch| {
            let len = batch.height();
            StructArray::try_new(dtype.clone(), len, batch.into_arrays(), None).map(|a| a.boxed())
        })
        .collect();
    export_iterator(
        Box::new(batches.into_iter()),
        ArrowField::new(PlSmallStr::EMPTY, dtype, false),
    )
}

/// A Rust frame as a Python `polars.DataFrame`.
pub fn to_polars(py: Python<'_>, df: DataFrame) -> PyResult<Bound<'_, PyAny>> {
    let table = Bound::new(py, PyArrowTable { df })?;
    py.import("polars")?.getattr("DataFrame")?.call1((table,))
}

/// The frame behind the capsule of an `__arrow_c_stream__()` call (the Python side calls it, after
/// turning a pandas frame or numpy arrays into polars). `argument` names the argument in errors.
pub fn from_capsule(capsule: &Bound<'_, PyAny>, argument: &str) -> PyResult<DataFrame> {
    let capsule = capsule.cast::<PyCapsule>().map_err(|_| {
        argument_error(format!(
            "argument `{argument}`: expected a table (a polars or pandas DataFrame, a dict of \
             columns, a numpy structured array or a file path)"
        ))
    })?;
    let ptr = capsule.pointer_checked(Some(STREAM)).map_err(|_| {
        argument_error(format!(
            "argument `{argument}`: the capsule is not an Arrow stream"
        ))
    })?;
    // SAFETY: the capsule named `arrow_array_stream` holds an `ArrowArrayStream` (the PyCapsule
    // interface); moving it out and leaving a released one behind is how a consumer takes ownership.
    let stream = unsafe {
        std::ptr::replace(
            ptr.as_ptr().cast::<ArrowArrayStream>(),
            ArrowArrayStream::empty(),
        )
    };
    let bad = |e: polars::prelude::PolarsError| {
        argument_error(format!(
            "argument `{argument}`: reading its Arrow stream: {e}"
        ))
    };
    // SAFETY: the stream came from a producer of the Arrow C stream interface.
    let mut reader = unsafe { ArrowArrayStreamReader::try_new(Box::new(stream)) }.map_err(bad)?;
    let dtype = reader.field().dtype().clone();
    if !matches!(dtype, ArrowDataType::Struct(_)) {
        return Err(argument_error(format!(
            "argument `{argument}`: the Arrow stream holds {dtype:?}, not a table of columns"
        )));
    }
    let mut out: Option<DataFrame> = None;
    // SAFETY: as above; each array follows the C data interface.
    while let Some(array) = unsafe { reader.next() } {
        let array = array.map_err(bad)?;
        let Some(s) = array.as_any().downcast_ref::<StructArray>() else {
            return Err(argument_error(format!(
                "argument `{argument}`: an Arrow batch is not a struct array"
            )));
        };
        let df = DataFrame::try_from(s.clone()).map_err(bad)?;
        match &mut out {
            None => out = Some(df),
            Some(o) => {
                o.vstack_mut_owned(df).map_err(bad)?;
            }
        }
    }
    match out {
        Some(df) => Ok(df),
        None => DataFrame::try_from(StructArray::new_empty(dtype)).map_err(bad),
    }
}
