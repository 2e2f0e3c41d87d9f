//! Real-time priority for the controller's cycles, where the machine permits it.
//!
//! A real controller runs its cycle at a real-time priority so that other work on the machine cannot
//! preempt it in the middle of a cycle, and sleeps between cycles. The simulator runs the plant and the
//! controller in one thread as fast as it can, so only the controller's calls are raised: a run enables
//! it for its thread ([`Scope::enter`]) and the stage loops wrap each controller call in [`cycle`], which
//! switches the thread to `SCHED_FIFO` at [`PRIORITY`] for the call and back afterwards. Raising the
//! whole run instead would keep a CPU-bound thread at real-time priority for seconds, and the kernel's
//! real-time throttling (`/proc/sys/kernel/sched_rt_runtime_us`: 0.95 s per 1 s by default) would stop
//! it for 50 ms once a second — measured: one 52 ms cycle per run on the 20° groove.
//!
//! Linux only, and only when the process may (root or `CAP_SYS_NICE`, an `RLIMIT_RTPRIO` ≥ the
//! priority); elsewhere, or when refused, runs go on at normal priority and the report says so
//! (`realtime: false`).

use std::cell::Cell;

/// The `SCHED_FIFO` priority used (1–99; 50 is the usual level of a control loop, below the kernel's
/// interrupt threads).
pub const PRIORITY: i32 = 50;

thread_local! {
    /// The policy and priority to return to after a cycle, when this thread's cycles are raised.
    static NORMAL: Cell<Option<(i32, i32)>> = const { Cell::new(None) };
}

/// Real-time cycles enabled for the calling thread until dropped.
#[derive(Debug)]
pub struct Scope {
    outer: Option<(i32, i32)>,
}

impl Scope {
    /// Enable real-time cycles on this thread if `wanted` and permitted (tried once: raise, restore);
    /// never fails.
    ///
    /// # Examples
    /// ```
    /// use millcomp_closedloop::realtime::{Scope, cycle};
    /// let s = Scope::enter(false);
    /// assert!(!s.active()); // not asked for: normal priority
    /// assert_eq!(cycle(|| 2 + 2), 4); // a cycle runs either way
    /// ```
    pub fn enter(wanted: bool) -> Self {
        let outer = NORMAL.with(Cell::get);
        let normal = if wanted { probe() } else { None };
        if normal.is_some() {
            lock_memory();
        }
        NORMAL.with(|n| n.set(normal));
        Self { outer }
    }

    /// True when this thread's cycles run at real-time priority.
    pub fn active(&self) -> bool {
        NORMAL.with(Cell::get).is_some()
    }
}

impl Drop for Scope {
    fn drop(&mut self) {
        NORMAL.with(|n| n.set(self.outer));
    }
}

/// Run one controller cycle `f`, at real-time priority if this thread's [`Scope`] enabled it.
pub fn cycle<R>(f: impl FnOnce() -> R) -> R {
    match NORMAL.with(Cell::get) {
        Some((policy, priority)) => {
            let raised = set(FIFO, PRIORITY);
            let r = f();
            if raised {
                set(policy, priority);
            }
            r
        }
        None => f(),
    }
}

#[cfg(target_os = "linux")]
const FIFO: i32 = libc::SCHED_FIFO;
#[cfg(not(target_os = "linux"))]
const FIFO: i32 = 0;

/// The thread's current (policy, priority) if it may be raised to `SCHED_FIFO` (tried and undone).
#[cfg(target_os = "linux")]
fn probe() -> Option<(i32, i32)> {
    let mut policy = 0;
    // SAFETY: pthread_self() is always valid for the calling thread; the out-pointers point to live
    // locals; sched_param is plain data.
    let priority = unsafe {
        let mut old = std::mem::zeroed::<libc::sched_param>();
        if libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut old) != 0 {
            return None;
        }
        old.sched_priority
    };
    if !set(FIFO, PRIORITY) {
        return None;
    }
    set(policy, priority);
    Some((policy, priority))
}

#[cfg(target_os = "linux")]
fn set(policy: i32, priority: i32) -> bool {
    // SAFETY: as in `probe`.
    unsafe {
        let mut p = std::mem::zeroed::<libc::sched_param>();
        p.sched_priority = priority;
        libc::pthread_setschedparam(libc::pthread_self(), policy, &p) == 0
    }
}

/// Keep the process's pages resident (`mlockall`), once: a page fault inside a cycle can stall it for
/// hundreds of µs when the machine is busy. Best effort.
#[cfg(target_os = "linux")]
fn lock_memory() {
    static LOCKED: std::sync::Once = std::sync::Once::new();
    LOCKED.call_once(|| {
        // SAFETY: mlockall has no memory-safety preconditions.
        unsafe {
            libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE);
        }
    });
}

#[cfg(not(target_os = "linux"))]
fn lock_memory() {}

#[cfg(not(target_os = "linux"))]
fn probe() -> Option<(i32, i32)> {
    None
}

#[cfg(not(target_os = "linux"))]
fn set(_: i32, _: i32) -> bool {
    false
}
