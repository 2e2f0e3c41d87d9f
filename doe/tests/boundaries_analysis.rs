//! Boundary tests of the analysis: each limit, guard and branch exactly where it switches, written in a
//! pass over the mutants of `doe/src/analysis` that no campaign had run (docs/reliability-mutants.md,
//! "A hardening pass before the seed-54 draw").

#[allow(unused_imports)]
use crate::common::*;
