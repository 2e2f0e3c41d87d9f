//! The integration tests of millcomp-closedloop (scenarios, closed-loop runs, faults), one binary.

mod batch;
mod batch_shards;
mod commissioning;
mod common;
mod faults;
mod figures;
mod fuzz_regressions;
mod groove;
mod machine;
mod nc_axis;
mod optimum;
mod parts;
mod process_changes;
mod scenarios;
mod thin_wall;
