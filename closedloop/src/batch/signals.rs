//! Stopping a batch cleanly on SIGTERM (a cluster's pre-emption, `scancel`) and SIGINT (Ctrl-C): the
//! first signal lets the runs under way finish and be stored, starts no new one, and the batch ends
//! with [`crate::ClosedLoopError::Interrupted`] (the same command resumes); a second signal of either
//! kind ends the process at once, as without a handler. SIGKILL cannot be caught: a killed batch
//! resumes from the runs stored before it.
//!
//! The handlers are installed only for the call that asks ([`SignalGuard::install`]) and the previous
//! ones restored after it; a library caller with its own handling passes its own stop flag instead.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

static STOP: AtomicBool = AtomicBool::new(false);
static RECEIVED: AtomicI32 = AtomicI32::new(0);

/// The flag the handlers set.
pub fn stop_flag() -> &'static AtomicBool {
    &STOP
}

/// The signal that set the flag (`SIGTERM`, `SIGINT`), if one did.
pub fn received() -> Option<&'static str> {
    match RECEIVED.load(Ordering::SeqCst) {
        #[cfg(unix)]
        libc::SIGTERM => Some("SIGTERM"),
        #[cfg(unix)]
        libc::SIGINT => Some("SIGINT"),
        _ => None,
    }
}

/// The exit status a shell gives a process ended by the signal received (128 + its number).
pub fn exit_status() -> Option<u8> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        n => u8::try_from(128 + n).ok(),
    }
}

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    if STOP.swap(true, Ordering::SeqCst) {
        // the second signal: the default action, now
        // SAFETY: signal() and raise() are async-signal-safe; SIG_DFL is a valid disposition.
        unsafe {
            libc::signal(sig, libc::SIG_DFL);
            libc::raise(sig);
        }
    }
    RECEIVED.store(sig, Ordering::SeqCst);
}

/// The handlers of SIGTERM and SIGINT while it lives; the previous ones restored when dropped.
#[derive(Debug)]
pub struct SignalGuard {
    #[cfg(unix)]
    previous: Vec<(libc::c_int, libc::sighandler_t)>,
}

impl SignalGuard {
    /// Installs the handlers (the flag cleared first).
    pub fn install() -> Self {
        STOP.store(false, Ordering::SeqCst);
        RECEIVED.store(0, Ordering::SeqCst);
        #[cfg(unix)]
        {
            let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            let previous = [libc::SIGTERM, libc::SIGINT]
                .into_iter()
                // SAFETY: installing a handler that only touches atomics and async-signal-safe calls.
                .map(|sig| (sig, unsafe { libc::signal(sig, handler) }))
                .collect();
            Self { previous }
        }
        #[cfg(not(unix))]
        Self {}
    }
}

impl Drop for SignalGuard {
    fn drop(&mut self) {
        #[cfg(unix)]
        for &(sig, old) in &self.previous {
            if old != libc::SIG_ERR {
                // SAFETY: restoring the disposition signal() returned for this signal.
                unsafe {
                    libc::signal(sig, old);
                }
            }
        }
    }
}
