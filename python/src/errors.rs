//! Errors as Python exceptions: one class per error family (`millcomp/errors.py` defines them, so a
//! family can also be a `ValueError`), with the message the CLI prints after `error: ` — the error and
//! each cause on a `  caused by:` line.
//!
//! The family: a table or file problem anywhere in the chain is a `DatasetError`, a model file's a
//! `ModelFileError`, a wrong argument an `ArgumentError`; otherwise the outermost library error names
//! it (`IdentifyError`, `ClosedLoopError`, …).

use std::fmt;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyType;

use millcomp_closedloop::ClosedLoopError;
use millcomp_datasets::DatasetError;
use millcomp_diagnose::DiagnoseError;
use millcomp_doe::DoeError;
use millcomp_identify::IdentifyError;
use millcomp_models::ModelError;
use millcomp_sim::SimError;

/// A wrong argument of a Python call (a name, a type, a value out of range), named in the message.
#[derive(Debug)]
pub struct ArgumentError(pub String);

impl fmt::Display for ArgumentError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ArgumentError {}

/// A Python `millcomp.ArgumentError` with `message`.
pub fn argument_error(message: String) -> PyErr {
    Python::attach(|py| exception(py, "ArgumentError", message))
}

/// An `anyhow` error of a call as the Python exception of its family.
pub fn raise(e: anyhow::Error) -> PyErr {
    Python::attach(|py| exception(py, family(&e), message(&e)))
}

/// An exception of `millcomp.errors.<class>` (a `RuntimeError` if the module cannot be imported).
pub fn exception(py: Python<'_>, class: &str, message: String) -> PyErr {
    let cls = py
        .import("millcomp.errors")
        .and_then(|m| m.getattr(class))
        .and_then(|c| c.cast_into::<PyType>().map_err(PyErr::from));
    match cls {
        Ok(t) => PyErr::from_type(t, message),
        Err(_) => PyRuntimeError::new_err(message),
    }
}

/// The class name of the error's family.
pub fn family(e: &anyhow::Error) -> &'static str {
    let chain = || e.chain();
    // a context added with `.context(ArgumentError(..))` is found by `downcast_ref`, not in the chain
    if e.downcast_ref::<ArgumentError>().is_some()
        || chain().any(|c| c.is::<ArgumentError>())
        || matches!(
            e.downcast_ref::<DoeError>(),
            Some(DoeError::BadOption { .. })
        )
    {
        return "ArgumentError";
    }
    if chain().any(|c| c.is::<DatasetError>()) {
        return "DatasetError";
    }
    if chain().any(|c| {
        c.is::<ModelError>()
            || matches!(
                c.downcast_ref::<millcomp_runtime::RuntimeError>(),
                Some(millcomp_runtime::RuntimeError::Model(_))
            )
    }) {
        return "ModelFileError";
    }
    for c in chain() {
        if c.is::<DoeError>() {
            return "DoeError";
        }
        if c.is::<IdentifyError>() {
            return "IdentifyError";
        }
        if c.is::<DiagnoseError>() {
            return "DiagnoseError";
        }
        if c.is::<ClosedLoopError>() {
            return "ClosedLoopError";
        }
        if c.is::<SimError>() {
            return "SimulationError";
        }
        if c.is::<millcomp_runtime::RuntimeError>() {
            return "ControllerError";
        }
        if c.is::<millcomp_mpc::MpcError>() {
            return "ControllerError";
        }
    }
    "MillcompError"
}

/// The CLI's text of the error (without its `error: `): the error, then each cause on its own
/// `  caused by:` line. A design option is named as the Python argument (`argument `factors``), not
/// the CLI flag.
pub fn message(e: &anyhow::Error) -> String {
    let mut lines: Vec<String> = Vec::new();
    for (i, c) in e.chain().enumerate() {
        let text = match c.downcast_ref::<DoeError>() {
            Some(DoeError::BadOption { option, .. }) => format!("argument `{option}`"),
            _ => c.to_string(),
        };
        if i == 0 {
            lines.push(text);
        } else {
            lines.push(format!("  caused by: {text}"));
        }
    }
    lines.join("\n")
}
