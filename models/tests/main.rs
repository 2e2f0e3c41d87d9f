//! The integration tests of millcomp-models, one binary: a module per subject.

mod boundaries;
mod mutation_survivors;
mod round_trip;
