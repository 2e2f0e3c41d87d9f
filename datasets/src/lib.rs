//! Published tables from the seed documents as validated CSV, and the table I/O at millcomp's edges.
//!
//! * [`registry`]: every shipped table (embedded in the binary), with its schema and provenance.
//! * [`contracts`]: the files exchanged with other tools (the measured-groove CSV, the flute force
//!   trace), defined once, with adapters to and from `millcomp-sim`'s row types.
//! * [`table`]: reading a user's CSV/Parquet file against a schema with errors that name the file,
//!   column and 1-based row; writing tables and text atomically (temporary file + rename).
//! * [`real`]: records measured on real machines by others (`datasets/real/`), with provenance and
//!   licences, listed apart from the published tables.
//! * [`synthetic_runs`]: the runs made by millcomp's seeded generators, listed apart as synthetic.
//! * [`mapping`]: `--columns role=column,…`, reading a user's own record under the names a verb reads,
//!   with unit suffixes checked.
//!
//! ```
//! let doe = millcomp_datasets::load("clayton_doe").unwrap();
//! assert_eq!(doe.n_rows(), 8);
//! // 000_…txt Table 3-3, trial 1: max X force 3.34 N.
//! assert_eq!(doe.f64s("max_fx_n").unwrap()[0], 3.34);
//! ```
#![warn(missing_docs)]

pub mod adapters;
pub mod contracts;
pub mod decode;
pub mod error;
pub mod mapping;
pub mod real;
pub mod registry;
pub mod synthetic_runs;
pub mod table;

pub use error::DatasetError;
pub use registry::{DATASETS, Dataset, dataset, load};
pub use table::{
    Column, ColumnData, ColumnKind, ColumnSpec, Schema, Table, TableFormat, read_any, read_any_str,
    read_csv_str, read_table, write_atomic, write_csv_to, write_table, write_text_atomic,
};
