//! Reports cross as the JSON documents the CLI prints with `--json`, parsed by Python's `json`
//! into dicts and lists (so a test can compare them with the CLI's output as they are).

use pyo3::prelude::*;
use serde::Serialize;

use crate::errors::raise;

/// `value` as Python objects, through its JSON text (NaN and infinities become `None`, as in the
/// CLI's JSON).
pub fn to_py<'py, T: Serialize + ?Sized>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| raise(anyhow::Error::new(e)))?;
    py.import("json")?.call_method1("loads", (text,))
}
