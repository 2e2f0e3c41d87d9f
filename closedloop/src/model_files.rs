//! The model files a scenario names (`control.spindle_model`, `control.force_model`,
//! `control.force_response_surface`), read through the common model-file format (`models/MODEL.md`) into
//! the types the controllers take.

use std::path::Path;

use millcomp_models::{
    ForceModelParams, IdentifiedModel, ModelBundle, ModelError, ModelFile, ResponseSurface,
    SpindleModel,
};
use millcomp_mpc::predictor::ResponseSurface as SurfacePredictor;

use crate::error::ClosedLoopError;

/// Reads a model file of one of `kinds`; an unreadable file is [`ClosedLoopError::Io`] naming the path.
fn load<B: serde::Serialize + serde::de::DeserializeOwned>(
    path: &str,
    kinds: &[&str],
) -> Result<ModelFile<B>, ClosedLoopError> {
    ModelFile::load(Path::new(path), kinds).map_err(|e| match e {
        ModelError::Io { source, .. } => ClosedLoopError::Io {
            path: path.to_string(),
            message: source.to_string(),
        },
        other => ClosedLoopError::ModelFile(other),
    })
}

/// An identified spindle saved by `millcomp identify spindle --save` (kind `spindle`).
///
/// # Errors
/// [`ClosedLoopError::Io`] when the file cannot be read, [`ClosedLoopError::ModelFile`] naming the key when
/// it is not a `spindle` model of this format.
pub fn load_spindle(path: &str) -> Result<SpindleModel, ClosedLoopError> {
    let file: ModelFile<IdentifiedModel> = load(path, &SpindleModel::KINDS)?;
    Ok(SpindleModel::from_identified(&file.model, Path::new(path))?)
}

/// Identified force-model parameters saved by `millcomp identify force --save` (kind `force`).
///
/// # Errors
/// As [`load_spindle`], for kind `force`.
pub fn load_force_params(path: &str) -> Result<ForceModelParams, ClosedLoopError> {
    let file: ModelFile<IdentifiedModel> = load(path, &ForceModelParams::KINDS)?;
    Ok(ForceModelParams::from_identified(
        &file.model,
        Path::new(path),
    )?)
}

/// A response surface saved by `millcomp doe analyze --save` (kind `response_surface`), checked to be able
/// to drive the controllers' preview (numeric factors, each a process parameter the plan knows).
///
/// # Errors
/// As [`load_spindle`]; the controllers' error (naming `control.force_response_surface`) when a factor is
/// not a process parameter.
pub fn load_response_surface(path: &str) -> Result<SurfacePredictor, ClosedLoopError> {
    let file: ModelFile<ResponseSurface> = load(path, &ResponseSurface::KINDS)?;
    Ok(SurfacePredictor::new(file.model, path)?)
}

/// A model bundle written by `millcomp commission --out` (kind `bundle`).
///
/// # Errors
/// As [`load_spindle`], for kind `bundle`.
pub fn load_bundle(path: &str) -> Result<ModelBundle, ClosedLoopError> {
    let file: ModelFile<ModelBundle> = load(path, &ModelBundle::KINDS)?;
    Ok(file.model)
}
