//! The integration tests of millcomp-doe, one binary: a module per subject, the shared helpers and
//! tolerances in `common`.

mod common;

mod boundaries_analysis;
mod boundaries_design;
mod clayton_anova;
mod design_claims;
mod designs;
mod errors;
mod fractional;
mod golden_anova;
mod lenth_power;
mod mutation_survivors;
mod offset_anova;
mod offset_data;
mod properties;
mod surface_and_elimination;
