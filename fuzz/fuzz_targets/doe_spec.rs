#![no_main]
//! Fuzz target `doe_spec`: see `millcomp_fuzz::doe_spec`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::doe_spec(data);
});
