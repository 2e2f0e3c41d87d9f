//! Every export runs inside the panic boundary; bad input gives NULL and a message naming the path;
//! NULL arguments are refused, not dereferenced.

use std::ffi::{CString, c_char};

use millcomp_ffi::*;

use crate::common;

/// Every `extern "C"` function of `src/lib.rs` starts its body with `ffi_guard(`: a panic never
/// unwinds into C. (Read from the source: a new export without the wrapper fails here.)
#[test]
fn every_export_goes_through_the_panic_boundary() {
    let src = include_str!("../src/lib.rs");
    let mut exports = 0;
    for (i, _) in src.match_indices("extern \"C\" fn ") {
        exports += 1;
        let rest = &src[i..];
        let name: String = rest["extern \"C\" fn ".len()..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let body = &rest[rest.find('{').unwrap() + 1..];
        assert!(
            body.trim_start().starts_with("ffi_guard("),
            "`{name}` does not run inside ffi_guard"
        );
    }
    assert_eq!(exports, 5, "the five functions of the ABI");
}

/// `millcomp_controller_new` on `bundle`/`program`: NULL and the message, through a buffer of `len`.
fn new_error(bundle: &str, program: &str, len: usize) -> String {
    let (b, p) = (
        CString::new(bundle).unwrap(),
        CString::new(program).unwrap(),
    );
    let mut buf = vec![b'#' as c_char; len + 1];
    // SAFETY: NUL-terminated strings; the buffer holds `len` bytes (one more as a guard)
    let ctl = unsafe { millcomp_controller_new(b.as_ptr(), p.as_ptr(), buf.as_mut_ptr(), len) };
    assert!(ctl.is_null(), "built from {bundle} and {program}");
    assert_eq!(buf[len], b'#' as c_char, "wrote past the buffer");
    let end = buf.iter().position(|&c| c == 0).expect("NUL-terminated");
    assert!(end < len.max(1));
    String::from_utf8(buf[..end].iter().map(|&c| c as u8).collect()).unwrap()
}

#[test]
fn bad_input_names_the_file_and_the_key() {
    let program = common::data("ramp_20deg.toml");
    let program = program.to_str().unwrap();
    let bundle = common::data("bundle_s7.toml");
    let bundle = bundle.to_str().unwrap();
    let msg = new_error("no/such/bundle.toml", program, 512);
    assert!(msg.contains("no/such/bundle.toml"), "{msg}");
    let msg = new_error(bundle, "no/such/job.toml", 512);
    assert!(msg.contains("no/such/job.toml"), "{msg}");
    // a program with a value out of range: the file and the key
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(program).unwrap();
    std::fs::write(&bad, text.replace("dt_s = 5e-5", "dt_s = -1.0")).unwrap();
    let msg = new_error(bundle, bad.to_str().unwrap(), 512);
    assert!(
        msg.contains("bad.toml") && msg.contains("controller.dt_s"),
        "{msg}"
    );
    // truncated to the buffer, NUL-terminated; a 1-byte buffer holds the NUL only
    assert_eq!(new_error("no/such/bundle.toml", program, 8).len(), 7);
    assert_eq!(new_error("no/such/bundle.toml", program, 1), "");
    // no buffer at all: NULL, nothing written
    let (b, p) = (CString::new("x").unwrap(), CString::new("y").unwrap());
    // SAFETY: a NULL buffer of length 0
    assert!(
        unsafe { millcomp_controller_new(b.as_ptr(), p.as_ptr(), std::ptr::null_mut(), 0) }
            .is_null()
    );
}

#[test]
fn null_arguments_are_refused() {
    let mut buf = [0 as c_char; 128];
    // SAFETY: NULL paths are allowed (refused with a message)
    let ctl = unsafe {
        millcomp_controller_new(std::ptr::null(), std::ptr::null(), buf.as_mut_ptr(), 128)
    };
    assert!(ctl.is_null());
    // SAFETY: the buffer is NUL-terminated
    let msg = unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) }
        .to_string_lossy()
        .into_owned();
    assert!(msg.contains("bundle_path"), "{msg}");
    let m = MillcompMeasurement {
        x_mm: 0.0,
        force_n: 0.0,
        gauge_um: 0.0,
    };
    let mut c = MillcompCommand {
        voltage_v: 0.0,
        flags: 0,
        iterations: 0,
    };
    // SAFETY: NULL controllers are allowed (refused)
    unsafe {
        assert_eq!(
            millcomp_controller_step(std::ptr::null_mut(), &m, &mut c),
            MILLCOMP_ERR_NULL
        );
        assert_eq!(
            millcomp_controller_reset(std::ptr::null_mut()),
            MILLCOMP_ERR_NULL
        );
        millcomp_controller_free(std::ptr::null_mut());
    }
    assert_eq!(millcomp_abi_version(), MILLCOMP_ABI_VERSION);
}

#[test]
fn the_guard_catches_a_panic() {
    assert_eq!(ffi_guard(-2, || -> i32 { panic!("inside") }), -2);
    assert_eq!(ffi_guard(-2, || 7), 7);
}
