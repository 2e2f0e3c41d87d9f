//! The compiled part of the Python package `millcomp` (`millcomp._core`): thin faces over the
//! libraries, one module per area; the package's Python modules (`python/millcomp/`) turn arguments
//! into these calls and frames into Arrow streams. Registered in one place, below.

use pyo3::prelude::*;

mod arrow;
mod controller;
mod doe;
mod errors;
mod identify;
mod input;
mod json;
mod run;

/// `millcomp._core`.
#[pymodule]
#[pyo3(name = "_core")]
fn core_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<arrow::PyArrowTable>()?;
    m.add_function(wrap_pyfunction!(doe::design, m)?)?;
    m.add_function(wrap_pyfunction!(doe::analyze, m)?)?;
    m.add_function(wrap_pyfunction!(doe::time_analyze, m)?)?;
    m.add_class::<doe::PyAnalysis>()?;
    m.add_function(wrap_pyfunction!(identify::fit, m)?)?;
    m.add_function(wrap_pyfunction!(identify::load, m)?)?;
    m.add_class::<identify::PyModel>()?;
    m.add_function(wrap_pyfunction!(run::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(run::simulate_session_file, m)?)?;
    m.add_class::<run::PySimulation>()?;
    m.add_function(wrap_pyfunction!(run::commission, m)?)?;
    m.add_class::<run::PyCommissioning>()?;
    m.add_function(wrap_pyfunction!(run::diagnose, m)?)?;
    m.add_class::<run::PyDiagnosis>()?;
    m.add_function(wrap_pyfunction!(run::batch, m)?)?;
    m.add_class::<run::PyBatch>()?;
    m.add_class::<controller::PyController>()?;
    m.add_class::<controller::PyCommand>()?;
    m.add_function(wrap_pyfunction!(controller::_time_step, m)?)?;
    Ok(())
}
