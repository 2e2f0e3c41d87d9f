//! No heap allocation in a step: every controller stepped 10 000 times (0.5 s at 20 kHz: the approach in
//! air, the entry and the cut) in closed loop with sim's stage, with gaps in the readings and an NC
//! position off the program's, under an allocator that counts this thread's allocations — inside the
//! steps only (the stage's own allocations are not the controller's).
//!
//! Clarabel 0.11.1 would allocate inside every QP solve (its timers: `Timers::reset_timer("solve")`
//! clears the nested sub-timer maps that the solve's first timed blocks then re-create — one allocation
//! and one free per solve); the MPC keeps that timer tree between solves (`keep_timer_tree`,
//! mpc/src/qp.rs), so the count here is 0 for every controller, the MPC's solves included.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use millcomp_runtime::{ControllerKind, Measurement, flags};

use crate::common;

/// Counts the calls of the current thread into the allocator (alloc, zeroed alloc, realloc, free).
struct Counting;

thread_local! {
    static CALLS: Cell<u64> = const { Cell::new(0) };
}

fn bump() {
    // `try_with`: the slot may already be gone while the thread shuts down
    let _ = CALLS.try_with(|c| c.set(c.get() + 1));
}

fn calls() -> u64 {
    CALLS.with(Cell::get)
}

// SAFETY: every call forwards to the system allocator with the caller's arguments unchanged; the count
// is a thread-local `Cell` of a `const` initialiser (no allocation, no destructor).
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        bump();
        // SAFETY: the caller's contract for `alloc`.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        bump();
        // SAFETY: the caller's contract for `alloc_zeroed`.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        bump();
        // SAFETY: the caller's contract for `realloc`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        bump();
        // SAFETY: the caller's contract for `dealloc`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

/// Allocator calls inside 10 000 steps of `kind`, and what the steps did.
fn allocations_in_steps(kind: ControllerKind, compensate_hysteresis: bool) -> (u64, u64, u64) {
    let mut ctl = common::controller(kind, compensate_hysteresis);
    let p = common::program(kind);
    let mut stage = common::machine(&p, ctl.period_s());
    let mut m = Measurement::NONE;
    let mut in_steps = 0;
    let mut planned = 0;
    for k in 0..10_000u64 {
        // a gap in the force channel, then in the gauge's; the NC 1 mm off the program for a while
        if (4_000..4_005).contains(&k) {
            m.force_n = f64::NAN;
        }
        if (6_000..6_003).contains(&k) {
            m.gauge_um = f64::NAN;
        }
        if (8_000..8_010).contains(&k) {
            m.x_mm += 1.0;
        }
        let before = calls();
        let c = ctl.step(&m);
        in_steps += calls() - before;
        planned += u64::from(c.has(flags::PLANNED));
        assert!(c.voltage_v.is_finite());
        m = common::reading(&stage.step(c.voltage_v));
    }
    let n = ctl.counts();
    assert_eq!(n.cycles, 10_000);
    assert!(n.readings_held >= 8, "{n:?}");
    assert!(n.position_mismatches >= 10, "{n:?}");
    (in_steps, planned, n.cycles)
}

#[test]
fn no_controller_allocates_in_a_step() {
    let mut report = Vec::new();
    for kind in ControllerKind::ALL {
        let (allocs, planned, cycles) = allocations_in_steps(kind, false);
        report.push(format!(
            "{:<16} {cycles} steps, {planned} MPC cycles: {allocs} allocator calls",
            kind.name()
        ));
        assert_eq!(
            allocs, 0,
            "{kind}: {allocs} allocator calls in 10 000 steps"
        );
    }
    // the stack driven through the inverse of the bundle's hysteresis model
    for kind in [
        ControllerKind::OpenLoop,
        ControllerKind::PidTuned,
        ControllerKind::PidFeedforward,
        ControllerKind::Mpc,
    ] {
        let (allocs, planned, cycles) = allocations_in_steps(kind, true);
        report.push(format!(
            "{:<16} {cycles} steps, {planned} MPC cycles: {allocs} allocator calls (hysteresis compensated)",
            kind.name()
        ));
        assert_eq!(allocs, 0, "{kind} (compensated): {allocs} allocator calls");
    }
    println!("{}", report.join("\n"));
}
