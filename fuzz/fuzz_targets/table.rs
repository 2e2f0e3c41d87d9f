#![no_main]
//! Fuzz target `table`: see `millcomp_fuzz::table`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::table(data);
});
