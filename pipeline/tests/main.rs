//! Integration tests of the pipeline library (one binary; modules below).

mod fuzz_regressions;
mod plan_files;
