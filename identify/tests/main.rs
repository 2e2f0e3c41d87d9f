//! The integration tests of millcomp-identify, one binary: a module per subject, the shared helpers in
//! `common`.

mod common;

mod bad_input;
mod golden;
mod jacobians;
mod mutation_survivors;
mod nist_strd;
mod offset_line;
mod real_records;
mod recovery;
mod saved_model;
mod table33;
mod unit_sim;
mod units;
