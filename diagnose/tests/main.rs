//! The integration tests of `millcomp-diagnose` (one test binary; modules by topic, shared helpers
//! and tolerances in `common`).
//!
//! * `named`: the committed synthetic sessions name their hidden effects (issue 7, Must show).
//! * `bad_input`: data that do not belong to the session, too few points, untestable candidates,
//!   bad options.
//! * `sweeps`: seeded false-alarm rate and power/coverage studies (the full ones `#[ignore]`d).
//! * `nominal`: the nominal model reproduces `simulate_session`.
//! * `candidates`: the standard candidate registry.
//! * `record`: measured records (issue 17) — the real thermal record and PHM 2010 per-cut forces.

mod bad_input;
mod candidates;
mod common;
mod named;
mod nominal;
mod record;
mod sweeps;
