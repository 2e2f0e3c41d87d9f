//! The pipeline's one error type.

use std::path::PathBuf;

/// What can stop a pipeline. Each variant names the file, key or stage at fault; causes are kept as
/// `#[source]`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// A file could not be read or written.
    #[error("{path}: {action}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The plan file is not valid TOML or breaks its schema (`docs/pipeline.md`).
    #[error("{path}: {message}")]
    Plan {
        /// The plan file.
        path: PathBuf,
        /// What is wrong, naming the key.
        message: String,
    },
    /// A plan value is out of range.
    #[error("{path}: {key} = {value}: {allowed}")]
    PlanValue {
        /// The plan file.
        path: PathBuf,
        /// The key, dotted (`batch.tolerance_pp_um`).
        key: String,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A measured file does not hold what its stage needs.
    #[error("{path}: {message}")]
    Data {
        /// The file.
        path: PathBuf,
        /// What is wrong (column, row).
        message: String,
    },
    /// A material not in the thesis's Table 4-1 (`clayton_force_materials`), where a prediction
    /// needs its published properties.
    #[error(
        "--material {material}: not in Table 4-1 (clayton_force_materials: {known}); the groove prediction needs its published properties"
    )]
    UnknownMaterial {
        /// The material asked for.
        material: String,
        /// The materials the table holds, comma-separated.
        known: String,
    },
    /// A stage failed.
    #[error("stage `{stage}`")]
    Stage {
        /// The stage.
        stage: &'static str,
        /// The cause.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A table could not be read or written.
    #[error(transparent)]
    Dataset(#[from] millcomp_datasets::DatasetError),
    /// A model file could not be read or written.
    #[error(transparent)]
    Model(#[from] millcomp_models::ModelError),
    /// The harness (simulated machine, commissioning fits, batch) failed.
    #[error(transparent)]
    ClosedLoop(#[from] millcomp_closedloop::ClosedLoopError),
    /// A design or analysis failed.
    #[error(transparent)]
    Doe(#[from] millcomp_doe::DoeError),
    /// The diagnosis failed.
    #[error(transparent)]
    Diagnose(#[from] millcomp_diagnose::DiagnoseError),
    /// A controller could not be built.
    #[error(transparent)]
    Mpc(#[from] millcomp_mpc::MpcError),
    /// The physics rejected a value.
    #[error(transparent)]
    Sim(#[from] millcomp_sim::SimError),
    /// An identification failed.
    #[error(transparent)]
    Identify(#[from] millcomp_identify::IdentifyError),
    /// A plot could not be drawn.
    #[error("plot {name}: {message}")]
    Plot {
        /// The plot.
        name: String,
        /// The drawing backend's message.
        message: String,
    },
    /// JSON (de)serialisation.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

impl PipelineError {
    /// An I/O error on `path`.
    pub(crate) fn io(path: &std::path::Path, action: &str, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            action: action.to_string(),
            source,
        }
    }

    /// A data error on `path`.
    pub(crate) fn data(path: &std::path::Path, message: impl Into<String>) -> Self {
        Self::Data {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

/// The pipeline's result type.
pub type Result<T, E = PipelineError> = std::result::Result<T, E>;
