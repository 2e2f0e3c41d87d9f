#![no_main]
//! Fuzz target `column_map`: see `millcomp_fuzz::column_map`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::column_map(data);
});
