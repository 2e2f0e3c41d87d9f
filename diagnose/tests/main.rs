//! The integration tests of `millcomp-diagnose` (one test binary; modules by topic, shared helpers
//! and tolerances in `common`).
//!
//! * `named`: the committed synthetic sessions name their hidden effects (issue 7, Must show).
//! * `bad_input`: data that do not belong to the session, too few points, untestable candidates,
//!   bad options.
//! * `sweeps`: seeded false-alarm rate and power/coverage studies (the full ones `#[ignore]`d).
//! * `nominal`: the nominal model reproduces `simulate_session`.
//! * `candidates`: the standard candidate registry.

mod bad_input;
mod candidates;
mod common;
mod named;
mod nominal;
mod sweeps;
