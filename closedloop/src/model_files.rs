//! The model files a scenario names (`control.spindle_model`, `control.force_model`,
//! `control.force_response_surface`), read into the types the controllers take.

use std::path::Path;

use millcomp_doe::FittedModel;
use millcomp_identify::SavedModel;
use millcomp_mpc::predictor::ResponseSurface;

use crate::error::ClosedLoopError;

/// Read an identified model saved by `millcomp identify --save` (TOML).
///
/// # Errors
/// [`ClosedLoopError::Io`] when the file cannot be read, [`ClosedLoopError::Scenario`] when it is not
/// a saved model.
pub fn load_saved(path: &str) -> Result<SavedModel, ClosedLoopError> {
    let text = std::fs::read_to_string(path).map_err(|e| ClosedLoopError::Io {
        path: path.to_string(),
        message: e.to_string(),
    })?;
    SavedModel::from_toml(&text).map_err(|e| ClosedLoopError::Scenario {
        path: path.to_string(),
        message: e.to_string(),
    })
}

/// Read a response surface saved by `millcomp doe analyze --save` and check it can drive the
/// controllers' preview (numeric factors, each a process parameter the plan knows).
///
/// # Errors
/// [`ClosedLoopError::Scenario`] when the file is not a saved response surface, the controllers'
/// error (naming `control.force_response_surface`) when a factor is not a process parameter.
pub fn load_response_surface(path: &str) -> Result<ResponseSurface, ClosedLoopError> {
    let model = FittedModel::load_toml(Path::new(path)).map_err(|e| ClosedLoopError::Scenario {
        path: path.to_string(),
        message: format!("not a `doe analyze --save` model: {e}"),
    })?;
    Ok(ResponseSurface::new(model, path)?)
}
