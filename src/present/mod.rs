//! Presentation: the one place where results become text tables and plots. Libraries return data; the
//! verbs in `cmd/` hand it here to be printed or drawn.

pub mod batch;
pub mod commission;
pub mod diagnose;
pub mod doe;
pub mod figures;
pub mod nc_axis;
pub mod parts;
pub mod plot;
pub mod record;
pub mod table;
pub mod units;
