//! The integration tests of millcomp-datasets, one binary: a module per subject.

mod never_nan;
mod sensor_log;
