//! The integration tests of `millcomp-diagnose` (one test binary; modules by topic, shared helpers
//! and tolerances in `common`).
//!
//! * `named`: the committed synthetic sessions name their hidden effects (issue 7's cases).
//! * `variants`: the failures issue 15 reports (a nominal model off, groove scatter) and a few
//!   variants of the study's distribution (the full study: `examples/real_data_study.rs`).
//! * `bad_input`: data that do not belong to the session, too few points, untestable candidates,
//!   a plan that separates nothing, bad options.
//! * `nominal`: the nominal model reproduces `simulate_session`, the nuisance model sim's truth.
//! * `families`: the families' reference shapes are sim's effect forms.
//! * `record`: measured records (issue 17) — the real thermal record and PHM 2010 per-cut forces.
//! * `ideal_observer`: the study's ideal observer (its ceiling on every named rate) is calibrated.

mod bad_input;
mod common;
mod families;
mod ideal_observer;
#[path = "../examples/real_data_study/ideal_observer.rs"]
mod ideal_observer_impl;
mod named;
mod nominal;
mod record;
mod unlisted;
mod variants;
