#![no_main]
//! Fuzz target `scenario`: see `millcomp_fuzz::scenario`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::scenario(data);
});
