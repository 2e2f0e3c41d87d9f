#![no_main]
//! Fuzz target `pipeline_plan`: see `fuzz/src/pipeline_plan.rs` (a file of its own, outside the
//! library that closedloop's tests compile, since the pipeline depends on closedloop).
#[path = "../src/pipeline_plan.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    harness::pipeline_plan(data);
});
