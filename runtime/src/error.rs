//! The runtime's one error type: every variant names the file, the key or the argument at fault.

use std::path::PathBuf;

/// What went wrong building a controller (a step never fails: see [`crate::Controller::step`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RuntimeError {
    /// A file could not be read or written.
    #[error("{}: {action}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A program file is not TOML of the program schema (the parser names the line and the key).
    #[error("{}: not a valid program file", path.display())]
    ProgramToml {
        /// The file.
        path: PathBuf,
        /// The TOML parser's error.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A program could not be written as TOML.
    #[error("the program cannot be written as TOML")]
    ProgramSerialize {
        /// The serialiser's error.
        #[source]
        source: Box<toml::ser::Error>,
    },
    /// A value out of its range.
    #[error("{}: key `{key}` = {value}: allowed {allowed}", path.display())]
    InvalidValue {
        /// The file (a program file, or the bundle).
        path: PathBuf,
        /// The key, e.g. `controller.dt_s`.
        key: String,
        /// The value found.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A controller name this runtime does not know.
    #[error("unknown controller `{name}`: one of {allowed}")]
    UnknownController {
        /// The name given.
        name: String,
        /// The names known.
        allowed: String,
    },
    /// The bundle (or a model in it) cannot give what the controller needs; the model crate's error
    /// names the file and the key.
    #[error(transparent)]
    Model(Box<millcomp_models::ModelError>),
    /// The controller could not be built from the bundle's models and the program.
    #[error("building `{controller}` from {} and {}", bundle.display(), program.display())]
    Build {
        /// The controller.
        controller: &'static str,
        /// The bundle.
        bundle: PathBuf,
        /// The program file.
        program: PathBuf,
        /// The controllers' error (it names the key or the model).
        #[source]
        source: Box<millcomp_mpc::MpcError>,
    },
}

impl From<millcomp_models::ModelError> for RuntimeError {
    fn from(e: millcomp_models::ModelError) -> Self {
        RuntimeError::Model(Box::new(e))
    }
}

impl RuntimeError {
    /// The error with its causes, `: `-separated (what a command line or a C caller prints).
    pub fn chain(&self) -> String {
        let mut out = self.to_string();
        let mut cause = std::error::Error::source(self);
        while let Some(c) = cause {
            out.push_str(": ");
            out.push_str(&c.to_string());
            cause = c.source();
        }
        out
    }
}
