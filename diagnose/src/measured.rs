//! The measured data `diagnose` takes — the measured-groove points and, optionally, the per-flute
//! force trace, as sim's row types — and the check that both belong to the session.
//!
//! Files are read by `millcomp-datasets` (`contracts::read_measured_groove`,
//! `contracts::read_force_trace`), which validates the contract and names file, column and row.
//!
//! # Force trace
//! Flute runout acts on the force asymmetry between the two flutes (`000_…txt` §4: one flute cuts
//! more), which a depth profile barely shows. A force trace is one row per measured point, the
//! peak z-force of each flute over the revolution in which the point was cut
//! ([`FluteForcePoint`]); every row must match a measured point by `groove_id` and `x_mm`.

use millcomp_sim::session::{FluteForcePoint, GroovePoint, check_groove_points};

use crate::error::{DiagnoseError, Result};
use crate::nominal::SessionModel;
use crate::thresholds;

/// The measured data of one session.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Measured {
    /// File name or label used in messages.
    pub source: String,
    /// One point per measured row, in the session's plan order.
    pub points: Vec<GroovePoint>,
    /// Optional per-flute force trace.
    pub forces: Option<ForceTrace>,
}

/// Per-flute peak z-forces at measured points (module documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ForceTrace {
    /// File name or label used in messages and the report.
    pub source: String,
    /// The rows.
    pub rows: Vec<FluteForcePoint>,
}

impl Measured {
    /// Measured points without a force trace.
    pub fn new(source: impl Into<String>, points: Vec<GroovePoint>) -> Self {
        Measured {
            source: source.into(),
            points,
            forces: None,
        }
    }

    /// Adds a force trace.
    pub fn with_forces(mut self, source: impl Into<String>, rows: Vec<FluteForcePoint>) -> Self {
        self.forces = Some(ForceTrace {
            source: source.into(),
            rows,
        });
        self
    }

    /// Number of measured points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no measured points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The measured depths (µm).
    pub fn depth_meas_um(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.depth_meas_um).collect()
    }

    /// The spindle temperatures (°C) when every point has one.
    pub fn spindle_temp_c(&self) -> Option<Vec<f64>> {
        if self.points.is_empty() || self.points.iter().any(|p| p.spindle_temp_c.is_none()) {
            return None;
        }
        Some(
            self.points
                .iter()
                .map(|p| p.spindle_temp_c.unwrap_or(f64::NAN))
                .collect(),
        )
    }

    /// Checks that the points are a measurement (sim's `check_groove_points`: finite values,
    /// `coolant_on` 0/1, time increasing within each groove) and that every measured row is the
    /// planned point of the session in the same order: same groove, position, time, engaged length
    /// and cut conditions (tolerances in [`thresholds`]).
    ///
    /// # Errors
    /// [`DiagnoseError::InvalidPoints`], or [`DiagnoseError::SessionMismatch`] naming the row, the
    /// column and both values.
    pub fn check_against(&self, sm: &SessionModel) -> Result<()> {
        check_groove_points(&self.points).map_err(|source| DiagnoseError::InvalidPoints {
            origin: self.source.clone(),
            source,
        })?;
        let n = self.len();
        if n != sm.len() {
            let grooves = |ids: &mut dyn Iterator<Item = i64>| {
                let mut v: Vec<i64> = ids.collect();
                v.dedup();
                format!("{v:?}")
            };
            return Err(DiagnoseError::SessionMismatch {
                column: "rows".into(),
                row: None,
                message: format!(
                    "{} has {n} measured points but the session `{}` plans {} (grooves measured {}, planned {})",
                    self.source,
                    sm.name,
                    sm.len(),
                    grooves(&mut self.points.iter().map(|p| p.groove_id)),
                    grooves(&mut sm.points().iter().map(|p| p.groove_id)),
                ),
            });
        }
        for (row, (m, p)) in self.points.iter().zip(sm.points()).enumerate() {
            if m.groove_id != p.groove_id {
                return Err(DiagnoseError::SessionMismatch {
                    column: "groove_id".into(),
                    row: Some(row),
                    message: format!(
                        "measured groove {} but the session plans groove {} here",
                        m.groove_id, p.groove_id
                    ),
                });
            }
            if m.coolant_on != u8::from(p.coolant_on) {
                return Err(DiagnoseError::SessionMismatch {
                    column: "coolant_on".into(),
                    row: Some(row),
                    message: format!(
                        "measured {} but the session has the coolant {} (groove {}, x = {} mm)",
                        m.coolant_on,
                        if p.coolant_on { "on" } else { "off" },
                        p.groove_id,
                        p.x_mm
                    ),
                });
            }
            let checks: [(&str, f64, f64, f64); 8] = [
                ("x_mm", m.x_mm, p.x_mm, thresholds::MATCH_ABS_MM),
                ("t_s", m.t_s, p.t_s, thresholds::MATCH_ABS_S),
                (
                    "cut_length_mm",
                    m.cut_length_mm,
                    p.cut_length_mm,
                    thresholds::MATCH_ABS_MM,
                ),
                ("speed_rpm", m.speed_rpm, p.speed_rpm, 0.5),
                (
                    "feed_mm_min",
                    m.feed_mm_min,
                    p.feed_mm_min,
                    thresholds::MATCH_ABS_MM,
                ),
                (
                    "upfeed_um",
                    m.upfeed_um,
                    p.upfeed_um,
                    thresholds::MATCH_ABS_UM,
                ),
                (
                    "tilt_deg",
                    m.tilt_deg,
                    p.tilt_deg,
                    thresholds::MATCH_ABS_DEG,
                ),
                (
                    "depth_cmd_um",
                    m.depth_cmd_um,
                    p.depth_cmd_um,
                    thresholds::MATCH_ABS_UM,
                ),
            ];
            for (col, m, s, abs) in checks {
                let tol = abs + thresholds::MATCH_REL * m.abs().max(s.abs());
                if (m - s).abs() > tol {
                    return Err(DiagnoseError::SessionMismatch {
                        column: col.into(),
                        row: Some(row),
                        message: format!(
                            "measured {m} but the session plans {s} (groove {}, point x = {} mm; tolerance {tol:.3e})",
                            p.groove_id, p.x_mm
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

impl ForceTrace {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether the trace is empty.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// For each row, the index of the session point it belongs to (by groove and position).
    ///
    /// # Errors
    /// [`DiagnoseError::NonFinite`] for a NaN or infinite value, [`DiagnoseError::SessionMismatch`]
    /// for a row that matches no planned point.
    pub fn match_points(&self, sm: &SessionModel) -> Result<Vec<usize>> {
        type Field = fn(&FluteForcePoint) -> f64;
        let columns: [(&'static str, Field); 3] = [
            ("x_mm", |r| r.x_mm),
            ("fz_peak_flute1_n", |r| r.fz_peak_flute1_n),
            ("fz_peak_flute2_n", |r| r.fz_peak_flute2_n),
        ];
        for (column, value) in columns {
            if let Some((row, r)) = self
                .rows
                .iter()
                .enumerate()
                .find(|(_, r)| !value(r).is_finite())
            {
                return Err(DiagnoseError::NonFinite {
                    origin: self.source.clone(),
                    column,
                    row,
                    value: value(r),
                });
            }
        }
        self.rows
            .iter()
            .enumerate()
            .map(|(row, r)| {
                sm.points()
                    .iter()
                    .position(|p| {
                        p.groove_id == r.groove_id
                            && (p.x_mm - r.x_mm).abs() <= thresholds::MATCH_ABS_MM
                    })
                    .ok_or_else(|| DiagnoseError::SessionMismatch {
                        column: "x_mm".into(),
                        row: Some(row),
                        message: format!(
                            "{}: no planned point of groove {} at x = {} mm",
                            self.source, r.groove_id, r.x_mm
                        ),
                    })
            })
            .collect()
    }
}
