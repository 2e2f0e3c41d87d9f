//! The integration tests of millcomp-models, one binary: a module per subject.

mod round_trip;
