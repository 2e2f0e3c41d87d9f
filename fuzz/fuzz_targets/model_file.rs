#![no_main]
//! Fuzz target `model_file`: see `millcomp_fuzz::model_file`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::model_file(data);
});
