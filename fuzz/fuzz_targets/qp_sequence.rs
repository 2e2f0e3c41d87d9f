#![no_main]
//! Fuzz target `qp_sequence`: see `millcomp_fuzz::qp_sequence`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::qp_sequence(data);
});
