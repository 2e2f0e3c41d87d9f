//! # millcomp-ffi — the controller runtime's C ABI
//!
//! A machine's real-time task (C, C++, a PLC runtime, anything that calls C) builds a controller from
//! a commissioned bundle and a program file and steps it once per control period, exactly as
//! [`millcomp_runtime::Controller`] does in Rust — the same code, so the same commands bit for bit.
//! The header `include/millcomp.h` is generated from this file by cbindgen and kept in the repository
//! (a test checks it is current); `examples/replay.c` drives a controller through a recorded sensor
//! log; `docs/runtime.md` describes the runtime.
//!
//! Every exported function runs inside [`ffi_guard`]: a panic never unwinds into C (a test checks that
//! every `extern "C"` function of this file goes through it). Errors are return codes and, for
//! construction, a message naming the file and the key in the caller's buffer (NUL-terminated,
//! truncated to the buffer).
//!
//! ```
//! use millcomp_ffi::*;
//! let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../runtime/tests/data/");
//! let bundle = std::ffi::CString::new(format!("{dir}bundle_s7.toml")).unwrap();
//! let program = std::ffi::CString::new(format!("{dir}ramp_20deg.toml")).unwrap();
//! let mut err = [0 as std::ffi::c_char; 256];
//! // SAFETY: NUL-terminated paths, a buffer of `err.len()` bytes
//! let ctl = unsafe {
//!     millcomp_controller_new(bundle.as_ptr(), program.as_ptr(), err.as_mut_ptr(), err.len())
//! };
//! assert!(!ctl.is_null());
//! let m = MillcompMeasurement { x_mm: f64::NAN, force_n: f64::NAN, gauge_um: f64::NAN };
//! let mut c = MillcompCommand { voltage_v: -1.0, flags: 0, iterations: 0 };
//! // SAFETY: a live controller and valid pointers
//! assert_eq!(unsafe { millcomp_controller_step(ctl, &m, &mut c) }, MILLCOMP_OK);
//! // the MPC planned (1) before any reading (8), its command within the amplifier's range
//! assert_eq!(c.flags & (1 | 8), 1 | 8);
//! assert!((0.0..=1000.0).contains(&c.voltage_v));
//! // SAFETY: the controller is not used after this
//! unsafe { millcomp_controller_free(ctl) };
//! ```
#![warn(missing_docs)]

use std::ffi::{CStr, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use millcomp_runtime::{Command, Controller, Measurement};

/// The version of this ABI: the layout of the structs and the functions' signatures. Bumped on any
/// incompatible change; a caller checks `millcomp_abi_version() == MILLCOMP_ABI_VERSION` of its header.
pub const MILLCOMP_ABI_VERSION: u32 = 1;

/// Success.
pub const MILLCOMP_OK: i32 = 0;
/// A pointer argument was NULL.
pub const MILLCOMP_ERR_NULL: i32 = -1;
/// The call panicked inside the library (a bug: please report it); the controller should be
/// discarded.
pub const MILLCOMP_ERR_PANIC: i32 = -2;
/// The controller could not be reset (its solver refused its settings back).
pub const MILLCOMP_ERR_RESET: i32 = -3;

/// What the machine gives the controller at the start of a cycle. NaN: no reading in this cycle.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MillcompMeasurement {
    /// The NC's position along the groove when the sensors were read (mm; NaN: not available).
    pub x_mm: f64,
    /// The measured workpiece z-force (N; NaN: no reading).
    pub force_n: f64,
    /// The capacitance gauge's reading of the tool tip (µm; NaN: no reading).
    pub gauge_um: f64,
}

/// What the controller sends back in a cycle.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MillcompCommand {
    /// The voltage for the PZT amplifier (V): finite, within 0 ..= the amplifier's maximum.
    pub voltage_v: f64,
    /// What happened in the cycle: 1 planned, 2 fallback, 4 deadline miss, 8 no reading yet,
    /// 16 a reading held, 32 NC position mismatch, 64 command held (`docs/runtime.md`).
    pub flags: u32,
    /// The interior-point iterations of the cycle's QP (0 when none was solved).
    pub iterations: u32,
}

/// A controller (opaque): made by [`millcomp_controller_new`], freed by [`millcomp_controller_free`].
/// One controller is driven from one thread at a time.
pub struct MillcompController {
    inner: Controller,
}

/// The panic boundary every exported function runs in: `f`'s result, or `on_panic` if it panicked
/// (the panic is caught here and never unwinds into the caller).
pub fn ffi_guard<R>(on_panic: R, f: impl FnOnce() -> R) -> R {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(on_panic)
}

/// Copy `msg` into the caller's buffer `buf` of `len` bytes: truncated to `len − 1` bytes (at a
/// character boundary) and always NUL-terminated; nothing when `buf` is NULL or `len` is 0.
///
/// # Safety
/// `buf` is NULL or valid for `len` bytes of writes.
unsafe fn write_message(buf: *mut c_char, len: usize, msg: &str) {
    if buf.is_null() || len == 0 {
        return;
    }
    let mut n = msg.len().min(len - 1);
    while !msg.is_char_boundary(n) {
        n -= 1;
    }
    // SAFETY: `buf` is valid for `len` bytes (caller) and `n + 1 <= len`; `msg` and `buf` do not
    // overlap (`msg` is Rust-owned).
    unsafe {
        std::ptr::copy_nonoverlapping(msg.as_ptr(), buf.cast::<u8>(), n);
        *buf.add(n) = 0;
    }
}

/// A path argument: `what` names it in the error.
///
/// # Safety
/// `p` is NULL or a NUL-terminated string.
unsafe fn path_arg<'a>(p: *const c_char, what: &str) -> Result<&'a Path, String> {
    if p.is_null() {
        return Err(format!("{what} is NULL"));
    }
    // SAFETY: non-NULL and NUL-terminated (caller)
    let s = unsafe { CStr::from_ptr(p) };
    s.to_str()
        .map(Path::new)
        .map_err(|_| format!("{what} `{}` is not UTF-8", s.to_string_lossy()))
}

/// The ABI version of the library ([`MILLCOMP_ABI_VERSION`] of the header it was built with).
#[unsafe(no_mangle)]
pub extern "C" fn millcomp_abi_version() -> u32 {
    ffi_guard(0, || MILLCOMP_ABI_VERSION)
}

/// A controller built from the bundle file `bundle_path` (`millcomp commission --out`) and the program
/// file `program_path` (`docs/runtime.md`): the controller the program's `[controller] kind` names.
/// Allocates; call it before the control loop.
///
/// Returns NULL on bad input and writes a message naming the file and the key into `err_buf` (`err_len`
/// bytes, always NUL-terminated, truncated to fit; `err_buf` may be NULL).
///
/// # Safety
/// `bundle_path` and `program_path` are NULL or NUL-terminated strings; `err_buf` is NULL or valid for
/// `err_len` bytes of writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn millcomp_controller_new(
    bundle_path: *const c_char,
    program_path: *const c_char,
    err_buf: *mut c_char,
    err_len: usize,
) -> *mut MillcompController {
    ffi_guard(std::ptr::null_mut(), || {
        // SAFETY: the caller's contract for the two paths
        let paths = unsafe { path_arg(bundle_path, "bundle_path") }
            .and_then(|b| unsafe { path_arg(program_path, "program_path") }.map(|p| (b, p)));
        let built = paths.and_then(|(b, p)| Controller::from_files(b, p).map_err(|e| e.chain()));
        match built {
            Ok(inner) => Box::into_raw(Box::new(MillcompController { inner })),
            Err(msg) => {
                // SAFETY: the caller's contract for the buffer
                unsafe { write_message(err_buf, err_len, &msg) };
                std::ptr::null_mut()
            }
        }
    })
}

/// One control cycle: `measurement` in, `command` out. Allocates nothing, takes no lock, makes no
/// system call (`docs/runtime.md`). Returns [`MILLCOMP_OK`], or [`MILLCOMP_ERR_NULL`] (a NULL argument;
/// `command` untouched).
///
/// # Safety
/// `ctrl` is NULL or a live controller of [`millcomp_controller_new`] not used by another thread during
/// the call; `measurement` and `command` are NULL or valid, aligned pointers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn millcomp_controller_step(
    ctrl: *mut MillcompController,
    measurement: *const MillcompMeasurement,
    command: *mut MillcompCommand,
) -> i32 {
    ffi_guard(MILLCOMP_ERR_PANIC, || {
        if ctrl.is_null() || measurement.is_null() || command.is_null() {
            return MILLCOMP_ERR_NULL;
        }
        // SAFETY: non-NULL, live, exclusive and aligned (caller)
        let (ctl, m) = unsafe { (&mut (*ctrl).inner, *measurement) };
        let Command {
            voltage_v,
            flags,
            iterations,
        } = ctl.step(&Measurement {
            x_mm: m.x_mm,
            force_n: m.force_n,
            gauge_um: m.gauge_um,
        });
        // SAFETY: non-NULL and aligned (caller)
        unsafe {
            *command = MillcompCommand {
                voltage_v,
                flags,
                iterations,
            };
        }
        MILLCOMP_OK
    })
}

/// Back to the state right after construction (filters, integrators, estimators, plans, the cycle
/// index): between cuts, not in the control loop. Returns [`MILLCOMP_OK`], [`MILLCOMP_ERR_NULL`] or
/// [`MILLCOMP_ERR_RESET`].
///
/// # Safety
/// `ctrl` is NULL or a live controller not used by another thread during the call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn millcomp_controller_reset(ctrl: *mut MillcompController) -> i32 {
    ffi_guard(MILLCOMP_ERR_PANIC, || {
        if ctrl.is_null() {
            return MILLCOMP_ERR_NULL;
        }
        // SAFETY: non-NULL, live and exclusive (caller)
        match unsafe { (*ctrl).inner.reset() } {
            Ok(()) => MILLCOMP_OK,
            Err(_) => MILLCOMP_ERR_RESET,
        }
    })
}

/// Free a controller (NULL: nothing).
///
/// # Safety
/// `ctrl` is NULL or a controller of [`millcomp_controller_new`] not freed before and not used after.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn millcomp_controller_free(ctrl: *mut MillcompController) {
    ffi_guard((), || {
        if !ctrl.is_null() {
            // SAFETY: made by `Box::into_raw` in `millcomp_controller_new`, freed once (caller)
            drop(unsafe { Box::from_raw(ctrl) });
        }
    });
}
