#![no_main]
//! Fuzz target `sensor_log`: see `millcomp_fuzz::sensor_log`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    millcomp_fuzz::init();
    millcomp_fuzz::sensor_log(data);
});
