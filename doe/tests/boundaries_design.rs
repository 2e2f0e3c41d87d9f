//! Boundary tests of the design generators: each limit, guard and keyword exactly where it switches
//! (the largest accepted and the smallest refused value), written in a pass over the mutants of
//! `doe/src/design`, `factor.rs`, `model.rs` and `surface.rs` that no campaign had run
//! (docs/reliability-mutants.md, "A hardening pass before the seed-54 draw").

#[allow(unused_imports)]
use crate::common::*;
