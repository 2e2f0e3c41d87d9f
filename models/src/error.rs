//! The one error type of `millcomp-models`. Every variant names the file (or `<memory>` for text that
//! was never on disk) and, where one is at fault, the key.

use std::path::PathBuf;

/// What can go wrong reading, checking, writing or using a model file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// The file could not be read or written.
    #[error("{}: {action}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done (`reading`, `creating a temporary file in …`, …).
        action: String,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not TOML, or a table does not have the shape of its kind.
    #[error("{}: not a valid model file", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The TOML parser's error (it names the key and line).
        #[source]
        source: toml::de::Error,
    },
    /// The model could not be written as TOML.
    #[error("{}: cannot write the model as TOML", path.display())]
    Serialize {
        /// The file.
        path: PathBuf,
        /// The serialiser's error.
        #[source]
        source: toml::ser::Error,
    },
    /// A header key has a value this build does not read (format, version) or is missing.
    #[error("{}: key `{key}` = {found}: {expected}", path.display())]
    Header {
        /// The file.
        path: PathBuf,
        /// The key, e.g. `header.version`.
        key: String,
        /// What the file holds.
        found: String,
        /// What this build reads.
        expected: String,
    },
    /// The file holds another kind of model than the reader needs.
    #[error("{}: key `header.kind` = `{found}`: expected {expected}", path.display())]
    Kind {
        /// The file.
        path: PathBuf,
        /// The kind in the file.
        found: String,
        /// The kinds the reader accepts.
        expected: String,
    },
    /// A parameter the consumer needs is not in the model.
    #[error("{}: model `{kind}` has no `{key}` (it has: {available})", path.display())]
    MissingKey {
        /// The file.
        path: PathBuf,
        /// The model kind.
        kind: String,
        /// The missing key, e.g. `model.params.zeta`.
        key: String,
        /// What the model has.
        available: String,
    },
    /// A value is outside what the model allows (e.g. a non-finite estimate, an unknown parameter).
    #[error("{}: key `{key}` = {value}: {allowed}", path.display())]
    InvalidValue {
        /// The file.
        path: PathBuf,
        /// The key.
        key: String,
        /// The value found.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A prediction was asked for at a point the model cannot evaluate.
    #[error("prediction: factor `{factor}`: {reason}")]
    Prediction {
        /// The factor at fault.
        factor: String,
        /// Why.
        reason: String,
    },
}

/// `Result` with [`ModelError`].
pub type Result<T> = std::result::Result<T, ModelError>;
