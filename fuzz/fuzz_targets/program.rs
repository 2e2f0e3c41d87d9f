#![no_main]
//! Fuzz target `program`: see `millcomp_fuzz::program`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::program(data);
});
