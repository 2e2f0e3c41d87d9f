#![no_main]
//! Fuzz target `batch_plan`: see `millcomp_fuzz::batch_plan`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::batch_plan(data);
});
