//! Measured data `diagnose` reads: the measured-groove CSV contract (DESIGN.md) as columns, an
//! optional per-revolution force trace, and the check that both belong to the session.
//!
//! The CLI reads the CSV with `millcomp_datasets::contracts::read_measured_groove` (which validates
//! the contract) and fills [`MeasuredGroove`]; [`MeasuredGroove::from_csv_str`] is a small reader of
//! the same contract for tests, examples and library users without the datasets crate.
//!
//! # Force trace (`NAME.forces.csv`)
//! Flute runout acts on the force asymmetry between the two flutes (`000_…txt` §4: one flute cuts
//! more), which a depth profile barely shows. A force trace is one row per measured point, the
//! peak z-force of each flute over the revolution in which the point was cut (the quantity the
//! thesis' peak-and-hold captures per flute, §6.2):
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `groove_id` | – | groove, as in the measured-groove CSV |
//! | `x_mm` | mm | position along the groove (matches a measured point) |
//! | `fz_peak_flute1_n` | N | peak z-force of flute 1 (the flute closer to the axis, smaller chip) |
//! | `fz_peak_flute2_n` | N | peak z-force of flute 2 (the flute that runout makes cut more) |
//!
//! Every row must match a measured point by `groove_id` and `x_mm`.

use std::collections::HashMap;

use super::context::SessionModel;
use super::thresholds;
use crate::error::{IdentifyError, Result};

/// The measured-groove CSV as columns (one entry per measured point).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeasuredGroove {
    /// File name or label used in messages.
    pub source: String,
    /// `groove_id`.
    pub groove_id: Vec<i64>,
    /// `t_s` (s).
    pub t_s: Vec<f64>,
    /// `x_mm` (mm).
    pub x_mm: Vec<f64>,
    /// `cut_length_mm` (mm).
    pub cut_length_mm: Vec<f64>,
    /// `spindle_rpm`.
    pub spindle_rpm: Vec<f64>,
    /// `feed_mm_min`.
    pub feed_mm_min: Vec<f64>,
    /// `upfeed_um` (µm/rev).
    pub upfeed_um: Vec<f64>,
    /// `tilt_deg`.
    pub tilt_deg: Vec<f64>,
    /// `coolant_on` (0/1).
    pub coolant_on: Vec<i64>,
    /// `depth_cmd_um` (µm).
    pub depth_cmd_um: Vec<f64>,
    /// `depth_meas_um` (µm).
    pub depth_meas_um: Vec<f64>,
    /// Optional `spindle_temp_c` (°C).
    pub spindle_temp_c: Option<Vec<f64>>,
    /// Optional per-revolution flute force trace.
    pub forces: Option<ForceTrace>,
}

/// Per-flute peak z-forces at measured points (module documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ForceTrace {
    /// File name or label used in messages.
    pub source: String,
    /// `groove_id`.
    pub groove_id: Vec<i64>,
    /// `x_mm`.
    pub x_mm: Vec<f64>,
    /// `fz_peak_flute1_n` (N).
    pub fz_peak_flute1_n: Vec<f64>,
    /// `fz_peak_flute2_n` (N).
    pub fz_peak_flute2_n: Vec<f64>,
}

/// Required columns of the measured-groove contract.
pub const MEASURED_COLUMNS: [&str; 11] = millcomp_sim::session::CSV_COLUMNS;
/// Columns of the force trace.
pub const FORCE_COLUMNS: [&str; 4] = ["groove_id", "x_mm", "fz_peak_flute1_n", "fz_peak_flute2_n"];

/// A parsed numeric CSV: header names and rows of numbers; `ignored` lists unknown columns.
struct NumCsv {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
}

fn parse_csv(origin: &str, text: &str, required: &[&str]) -> Result<NumCsv> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = lines.next().ok_or_else(|| IdentifyError::MissingColumn {
        column: required.join(","),
        reason: format!("{origin}: the file is empty (no header)"),
    })?;
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    for r in required {
        if !names.iter().any(|n| n == r) {
            return Err(IdentifyError::MissingColumn {
                column: r.to_string(),
                reason: format!("{origin}: required by the contract (header: {header})"),
            });
        }
    }
    let mut rows = Vec::new();
    for (row, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != names.len() {
            return Err(IdentifyError::LengthMismatch {
                column: format!("{origin} row {row}"),
                len: cells.len(),
                reference: "header".into(),
                expected: names.len(),
            });
        }
        let mut vals = Vec::with_capacity(cells.len());
        for (c, cell) in cells.iter().enumerate() {
            let t = cell.trim();
            let v = if t.is_empty() {
                f64::NAN
            } else {
                t.parse::<f64>()
                    .map_err(|_| IdentifyError::InvalidParameter {
                        name: format!("{origin}: column `{}` row {row} (`{t}`)", names[c]),
                        value: f64::NAN,
                        allowed: "a number",
                    })?
            };
            vals.push(v);
        }
        rows.push(vals);
    }
    Ok(NumCsv { names, rows })
}

impl NumCsv {
    fn col(&self, name: &str) -> Option<Vec<f64>> {
        let j = self.names.iter().position(|n| n == name)?;
        Some(self.rows.iter().map(|r| r[j]).collect())
    }
    fn req(&self, name: &str) -> Result<Vec<f64>> {
        let v = self.col(name).unwrap_or_default();
        crate::validate::finite(name, &v)?;
        Ok(v)
    }
    fn ints(&self, name: &str) -> Result<Vec<i64>> {
        let v = self.req(name)?;
        v.iter()
            .enumerate()
            .map(|(row, &x)| {
                if x.fract() == 0.0 && x.abs() < 9e15 {
                    Ok(x as i64)
                } else {
                    Err(IdentifyError::InvalidParameter {
                        name: format!("column `{name}` row {row}"),
                        value: x,
                        allowed: "an integer",
                    })
                }
            })
            .collect()
    }
}

impl MeasuredGroove {
    /// Parses a measured-groove CSV (header + rows); errors name the column and 0-based data row.
    /// Unknown columns are ignored (the CLI's contract reader notes them).
    pub fn from_csv_str(origin: &str, text: &str) -> Result<Self> {
        let csv = parse_csv(origin, text, &MEASURED_COLUMNS)?;
        let coolant = csv.ints("coolant_on")?;
        if let Some(row) = coolant.iter().position(|&c| c != 0 && c != 1) {
            return Err(IdentifyError::InvalidParameter {
                name: format!("column `coolant_on` row {row}"),
                value: coolant[row] as f64,
                allowed: "0 or 1",
            });
        }
        let m = MeasuredGroove {
            source: origin.to_string(),
            groove_id: csv.ints("groove_id")?,
            t_s: csv.req("t_s")?,
            x_mm: csv.req("x_mm")?,
            cut_length_mm: csv.req("cut_length_mm")?,
            spindle_rpm: csv.req("spindle_rpm")?,
            feed_mm_min: csv.req("feed_mm_min")?,
            upfeed_um: csv.req("upfeed_um")?,
            tilt_deg: csv.req("tilt_deg")?,
            coolant_on: coolant,
            depth_cmd_um: csv.req("depth_cmd_um")?,
            depth_meas_um: csv.req("depth_meas_um")?,
            spindle_temp_c: match csv.col("spindle_temp_c") {
                Some(v) => {
                    crate::validate::finite("spindle_temp_c", &v)?;
                    Some(v)
                }
                None => None,
            },
            forces: None,
        };
        m.validate()?;
        Ok(m)
    }

    /// Reads a measured-groove CSV file.
    pub fn from_path(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| IdentifyError::Io {
            what: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_csv_str(&path.display().to_string(), &text)
    }

    /// Builds the columns from simulated/measured points.
    pub fn from_points(source: &str, points: &[millcomp_sim::session::GroovePoint]) -> Self {
        let temp = points.iter().all(|p| p.spindle_temp_c.is_some()) && !points.is_empty();
        MeasuredGroove {
            source: source.to_string(),
            groove_id: points.iter().map(|p| p.groove_id).collect(),
            t_s: points.iter().map(|p| p.t_s).collect(),
            x_mm: points.iter().map(|p| p.x_mm).collect(),
            cut_length_mm: points.iter().map(|p| p.cut_length_mm).collect(),
            spindle_rpm: points.iter().map(|p| p.spindle_rpm).collect(),
            feed_mm_min: points.iter().map(|p| p.feed_mm_min).collect(),
            upfeed_um: points.iter().map(|p| p.upfeed_um).collect(),
            tilt_deg: points.iter().map(|p| p.tilt_deg).collect(),
            coolant_on: points.iter().map(|p| i64::from(p.coolant_on)).collect(),
            depth_cmd_um: points.iter().map(|p| p.depth_cmd_um).collect(),
            depth_meas_um: points.iter().map(|p| p.depth_meas_um).collect(),
            spindle_temp_c: temp.then(|| {
                points
                    .iter()
                    .map(|p| p.spindle_temp_c.unwrap_or(f64::NAN))
                    .collect()
            }),
            forces: None,
        }
    }

    /// Number of measured points.
    pub fn len(&self) -> usize {
        self.depth_meas_um.len()
    }

    /// Whether there are no measured points.
    pub fn is_empty(&self) -> bool {
        self.depth_meas_um.is_empty()
    }

    /// Lengths, finiteness and monotone time within each groove (the contract's checks).
    pub fn validate(&self) -> Result<()> {
        let n = self.depth_meas_um.len();
        let float_cols: [(&str, &Vec<f64>); 10] = [
            ("t_s", &self.t_s),
            ("x_mm", &self.x_mm),
            ("cut_length_mm", &self.cut_length_mm),
            ("spindle_rpm", &self.spindle_rpm),
            ("feed_mm_min", &self.feed_mm_min),
            ("upfeed_um", &self.upfeed_um),
            ("tilt_deg", &self.tilt_deg),
            ("depth_cmd_um", &self.depth_cmd_um),
            ("depth_meas_um", &self.depth_meas_um),
            ("t_s", &self.t_s),
        ];
        for (name, v) in float_cols {
            crate::validate::same_len(name, v, "depth_meas_um", n)?;
            crate::validate::finite(name, v)?;
        }
        for (name, len) in [
            ("groove_id", self.groove_id.len()),
            ("coolant_on", self.coolant_on.len()),
        ] {
            if len != n {
                return Err(IdentifyError::LengthMismatch {
                    column: name.into(),
                    len,
                    reference: "depth_meas_um".into(),
                    expected: n,
                });
            }
        }
        if let Some(t) = &self.spindle_temp_c {
            crate::validate::same_len("spindle_temp_c", t, "depth_meas_um", n)?;
            crate::validate::finite("spindle_temp_c", t)?;
        }
        let mut last: HashMap<i64, f64> = HashMap::new();
        for (row, (&g, &t)) in self.groove_id.iter().zip(&self.t_s).enumerate() {
            if let Some(&prev) = last.get(&g) {
                if t <= prev {
                    return Err(IdentifyError::NonMonotoneTime {
                        column: "t_s".into(),
                        row,
                        prev,
                        value: t,
                    });
                }
            }
            last.insert(g, t);
        }
        Ok(())
    }

    /// Checks that every measured row is the planned point of the session in the same order:
    /// same groove, position, time, engaged length and cut conditions (tolerances in
    /// [`thresholds`]). Errors name the row, the column and both values.
    pub fn check_against(&self, sm: &SessionModel) -> Result<()> {
        self.validate()?;
        let n = self.len();
        if n != sm.len() {
            let grooves = |ids: &mut dyn Iterator<Item = i64>| {
                let mut v: Vec<i64> = ids.collect();
                v.dedup();
                format!("{v:?}")
            };
            return Err(IdentifyError::SessionMismatch {
                column: "rows".into(),
                row: None,
                message: format!(
                    "{} has {n} measured points but the session `{}` plans {} (grooves measured {}, planned {})",
                    self.source,
                    sm.name,
                    sm.len(),
                    grooves(&mut self.groove_id.iter().copied()),
                    grooves(&mut sm.points.iter().map(|p| p.groove_id)),
                ),
            });
        }
        for (row, p) in sm.points.iter().enumerate() {
            if self.groove_id[row] != p.groove_id {
                return Err(IdentifyError::SessionMismatch {
                    column: "groove_id".into(),
                    row: Some(row),
                    message: format!(
                        "measured groove {} but the session plans groove {} here",
                        self.groove_id[row], p.groove_id
                    ),
                });
            }
            if self.coolant_on[row] != i64::from(p.coolant_on) {
                return Err(IdentifyError::SessionMismatch {
                    column: "coolant_on".into(),
                    row: Some(row),
                    message: format!(
                        "measured {} but the session has the coolant {} (groove {}, x = {} mm)",
                        self.coolant_on[row],
                        if p.coolant_on { "on" } else { "off" },
                        p.groove_id,
                        p.x_mm
                    ),
                });
            }
            let checks: [(&str, f64, f64, f64); 8] = [
                ("x_mm", self.x_mm[row], p.x_mm, thresholds::MATCH_ABS_MM),
                ("t_s", self.t_s[row], p.t_s, thresholds::MATCH_ABS_S),
                (
                    "cut_length_mm",
                    self.cut_length_mm[row],
                    p.cut_length_mm,
                    thresholds::MATCH_ABS_MM,
                ),
                ("spindle_rpm", self.spindle_rpm[row], p.spindle_rpm, 0.5),
                (
                    "feed_mm_min",
                    self.feed_mm_min[row],
                    p.feed_mm_min,
                    thresholds::MATCH_ABS_MM,
                ),
                (
                    "upfeed_um",
                    self.upfeed_um[row],
                    p.upfeed_um,
                    thresholds::MATCH_ABS_UM,
                ),
                (
                    "tilt_deg",
                    self.tilt_deg[row],
                    p.tilt_deg,
                    thresholds::MATCH_ABS_DEG,
                ),
                (
                    "depth_cmd_um",
                    self.depth_cmd_um[row],
                    p.depth_cmd_um,
                    thresholds::MATCH_ABS_UM,
                ),
            ];
            for (col, m, s, abs) in checks {
                let tol = abs + thresholds::MATCH_REL * m.abs().max(s.abs());
                if (m - s).abs() > tol {
                    return Err(IdentifyError::SessionMismatch {
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
    /// Parses a force-trace CSV (module documentation); errors name column and 0-based row.
    pub fn from_csv_str(origin: &str, text: &str) -> Result<Self> {
        let csv = parse_csv(origin, text, &FORCE_COLUMNS)?;
        let f = ForceTrace {
            source: origin.to_string(),
            groove_id: csv.ints("groove_id")?,
            x_mm: csv.req("x_mm")?,
            fz_peak_flute1_n: csv.req("fz_peak_flute1_n")?,
            fz_peak_flute2_n: csv.req("fz_peak_flute2_n")?,
        };
        Ok(f)
    }

    /// Reads a force-trace CSV file.
    pub fn from_path(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| IdentifyError::Io {
            what: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_csv_str(&path.display().to_string(), &text)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.x_mm.len()
    }

    /// Whether the trace is empty.
    pub fn is_empty(&self) -> bool {
        self.x_mm.is_empty()
    }

    /// CSV text of the trace (header + rows).
    pub fn to_csv(&self) -> String {
        let mut s = FORCE_COLUMNS.join(",");
        s.push('\n');
        for i in 0..self.len() {
            s.push_str(&format!(
                "{},{},{},{}\n",
                self.groove_id[i], self.x_mm[i], self.fz_peak_flute1_n[i], self.fz_peak_flute2_n[i]
            ));
        }
        s
    }

    /// For each row, the index of the session point it belongs to (by groove and position).
    pub fn match_points(&self, sm: &SessionModel) -> Result<Vec<usize>> {
        let n = self.len();
        for (name, v) in [
            ("x_mm", &self.x_mm),
            ("fz_peak_flute1_n", &self.fz_peak_flute1_n),
            ("fz_peak_flute2_n", &self.fz_peak_flute2_n),
        ] {
            crate::validate::same_len(name, v, "x_mm", n)?;
            crate::validate::finite(name, v)?;
        }
        if self.groove_id.len() != n {
            return Err(IdentifyError::LengthMismatch {
                column: "groove_id".into(),
                len: self.groove_id.len(),
                reference: "x_mm".into(),
                expected: n,
            });
        }
        (0..n)
            .map(|row| {
                sm.points
                    .iter()
                    .position(|p| {
                        p.groove_id == self.groove_id[row]
                            && (p.x_mm - self.x_mm[row]).abs() <= thresholds::MATCH_ABS_MM
                    })
                    .ok_or_else(|| IdentifyError::SessionMismatch {
                        column: "x_mm".into(),
                        row: Some(row),
                        message: format!(
                            "{}: no planned point of groove {} at x = {} mm",
                            self.source, self.groove_id[row], self.x_mm[row]
                        ),
                    })
            })
            .collect()
    }
}
