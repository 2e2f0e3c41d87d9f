//! The runtime's integration tests (one binary; its global allocator counts this thread's allocations,
//! `alloc.rs`).

mod alloc;
mod common;
mod errors;
mod export;
mod reset;
