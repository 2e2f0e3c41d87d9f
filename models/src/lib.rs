//! # millcomp-models — the model-file format and the identified-model types
//!
//! The bottom crate every millcomp consumer shares. It owns:
//! * [`ModelFile`]: the **one** model-file format — a `[header]` (format `millcomp-model`, version, kind,
//!   [`Provenance`]: the program, the command, the time and every input file with its SHA-256) and a
//!   `[model]` table; one [`ModelFile::load`] that checks format, version and kind before reading the body
//!   (errors name the file and the key), one atomic [`ModelFile::save`]. Schema: `models/MODEL.md`.
//! * the identified-model types the controllers consume — estimated from measurements, never taken from
//!   the simulator's truth: [`IdentifiedModel`] (any least-squares fit with covariance), its typed views
//!   [`SpindleModel`] and [`ForceModelParams`], and [`ResponseSurface`] (a DOE-fitted polynomial).
//!
//! It depends on no other millcomp crate, so doe, identify, mpc and the harness can all use it, and a
//! controller can take identified models without seeing the truth.
//!
//! ```
//! use millcomp_models::{ModelFile, Provenance, ResponseSurface};
//! # let dir = tempfile::tempdir().unwrap();
//! # let path = dir.path().join("rs.toml");
//! # let text = r#"
//! # response = "max_fz_n"
//! # model = "depth_um"
//! # n_runs = 2
//! # residual_df = 0
//! # r_squared = 1.0
//! # [[factors]]
//! # kind = "numeric"
//! # name = "depth_um"
//! # low = 40.0
//! # high = 80.0
//! # levels = 2
//! # [[terms]]
//! # name = "intercept"
//! # coef = 0.2
//! # [[terms]]
//! # name = "depth_um"
//! # coef = 0.01
//! # [terms.powers]
//! # depth_um = 1
//! # [coded]
//! # terms = ["intercept", "depth_um"]
//! # coef = [0.8, 0.2]
//! # "#;
//! # let surface: ResponseSurface = toml::from_str(text).unwrap();
//! // save a response surface with its provenance, load it back as that kind, evaluate it
//! ModelFile::new("response_surface", surface, Provenance::now("millcomp 0.1.0", "doc example"))
//!     .save(&path)
//!     .unwrap();
//! let back: ModelFile<ResponseSurface> = ModelFile::load(&path, &ResponseSurface::KINDS).unwrap();
//! // 0.2 N + 0.01 N/µm · 60 µm
//! assert!((back.model.predict(&[("depth_um", 60.0)]).unwrap() - 0.8).abs() < 1e-12);
//! ```
#![warn(missing_docs)]

pub mod atomic;
pub mod bundle;
pub mod error;
pub mod file;
pub mod identified;
pub mod surface;

pub use bundle::ModelBundle;
pub use error::{ModelError, Result};
pub use file::{
    FORMAT, Header, InputFile, ModelFile, Provenance, VERSION, read_header, sha256_hex,
    utc_now_rfc3339, write_atomic,
};
pub use identified::{
    Derived, FitStatus, ForceModelParams, HysteresisModel, IdentifiedModel, NamedMatrix,
    SensorNoise, SpindleModel, StiffnessModel,
};
pub use surface::{ActualTerm, CodedFit, FactorCoding, Level, Prediction, ResponseSurface};
