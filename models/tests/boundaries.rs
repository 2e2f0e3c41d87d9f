//! Boundary tests of the model files, bundles and atomic writes: each guard and branch exactly where it
//! switches, written in a pass over the mutants of `models/src` that no campaign had run
//! (docs/reliability-mutants.md, "A hardening pass before the seed-54 draw").
