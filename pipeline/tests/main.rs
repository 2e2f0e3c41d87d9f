//! Integration tests of the pipeline library (one binary; modules below).

mod plan_files;
