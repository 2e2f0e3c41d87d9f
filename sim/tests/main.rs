//! The integration tests of millcomp-sim, one binary: a module per subject, the shared helpers in
//! `common`.

mod common;

mod bad_input;
mod effects;
mod force_model;
mod groove;
mod session;
mod spindle_figures;
mod stiffness;
mod thinwall;
