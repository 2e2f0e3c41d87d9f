//! The integration tests of millcomp-mpc (the controller core), one binary.

mod common;
mod golden_casadi;
mod mpc_core;
