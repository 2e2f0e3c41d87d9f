//! End-to-end tests of the `millcomp` binary: one test binary, one module per verb, one shared helper
//! module.

mod common;

mod batch;
mod commission;
mod datasets;
mod demo;
mod diagnose;
mod doe;
mod forces;
mod identify;
mod manners;
mod parts;
mod readme;
mod real;
mod reliability;
mod replay;
mod report_html;
mod simulate;
mod units;
