#![no_main]
//! Fuzz target `session`: see `millcomp_fuzz::session`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::session(data);
});
