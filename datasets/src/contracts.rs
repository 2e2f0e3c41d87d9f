//! The contracts: schemas of the files other tools exchange with millcomp (DESIGN.md "Contracts"),
//! defined once here, and their adapters to the row types of `millcomp-sim`.
//!
//! * The **measured-groove CSV** (one row per measured point, [`MEASURED_GROOVE_COLUMNS`] plus the
//!   optional `spindle_temp_c`): what `millcomp simulate SESSION` writes and `millcomp diagnose`
//!   reads, as [`GroovePoint`]s. Its columns and rules are defined once, beside the row type, in
//!   `millcomp_sim::session` (`MEASURED_GROOVE`, `check_groove_points`: the one validator, which
//!   diagnose also applies to points from any source); this module reads and writes files by them.
//! * The **flute force trace** (`NAME.forces.csv`, [`FORCE_TRACE_COLUMNS`]): per measured point the
//!   peak z-force of each flute, as [`FluteForcePoint`]s; every row must match a measured point by
//!   `groove_id` and `x_mm`.
//!
//! * The **sensor log** ([`SENSOR_LOG_COLUMNS`]): one row per control period of a cut, what a
//!   machine's controller read — the NC's position and the force and gauge readings — as a
//!   [`SensorLog`]; `millcomp replay` steps a commissioned controller through it (docs/replay.md).
//!
//! All are read through the one table reader ([`read_table`], polars), so errors name the file, the
//! column and the 1-based data row, and written through [`write_table`] / [`write_csv_to`].
//!
//! ```
//! use millcomp_datasets::contracts::{MEASURED_GROOVE_COLUMNS, read_measured_groove_str};
//! let csv = format!(
//!     "{}\n0,0,0,0,10000,100,10,20,1,0,0.1\n0,0.6,1,1,10000,100,10,20,1,4,2.05\n",
//!     MEASURED_GROOVE_COLUMNS.join(",")
//! );
//! let m = read_measured_groove_str("m.csv", &csv).unwrap();
//! assert_eq!(m.points.len(), 2);
//! assert_eq!(m.points[1].depth_meas_um, 2.05);
//! assert_eq!(m.points[1].coolant_on, 1);
//! ```
//!
//! [`write_table`]: crate::write_table
//! [`write_csv_to`]: crate::table::write_csv_to

use std::path::Path;

use millcomp_sim::SimError;
use millcomp_sim::session::{
    FluteForcePoint, GroovePoint, MEASURED_GROOVE, MeasuredKind, check_groove_points,
};

use crate::error::DatasetError;
use crate::table::{
    Column, ColumnData, ColumnKind, ColumnSpec, Schema, Table, read_csv_str, read_dataframe,
    read_table,
};

/// Columns renamed since version 1 of the measured-groove contract: (version-1 name, current name).
pub use millcomp_sim::session::MEASURED_GROOVE_V1_NAMES;
/// Version of the measured-groove contract this build writes (version 2 renamed `spindle_rpm` to
/// `speed_rpm`; files of version 1 are still read).
pub use millcomp_sim::session::MEASURED_GROOVE_VERSION;
/// The optional measured-groove column (written when a point has a spindle temperature).
pub use millcomp_sim::session::SPINDLE_TEMP_COLUMN;

/// The cell type a measured-groove column of the contract has (`millcomp_sim::session::MEASURED_GROOVE`).
fn kind_of(k: MeasuredKind) -> ColumnKind {
    match k {
        MeasuredKind::Int => ColumnKind::Int,
        MeasuredKind::Float => ColumnKind::Float,
        MeasuredKind::Flag => ColumnKind::Flag,
    }
}

/// Name, kind and meaning of every force-trace column, in contract order.
const FORCE_TRACE: [(&str, ColumnKind, &str); 4] = [
    (
        "groove_id",
        ColumnKind::Int,
        "groove, as in the measured-groove CSV",
    ),
    (
        "x_mm",
        ColumnKind::Float,
        "position along the groove (matches a measured point)",
    ),
    (
        "fz_peak_flute1_n",
        ColumnKind::Float,
        "peak z-force of flute 1 (the flute closer to the axis, smaller chip)",
    ),
    (
        "fz_peak_flute2_n",
        ColumnKind::Float,
        "peak z-force of flute 2 (the flute that runout makes cut more)",
    ),
];

const fn names<const N: usize>(
    spec: &[(&'static str, ColumnKind, &'static str); N],
) -> [&'static str; N] {
    let mut out = [""; N];
    let mut i = 0;
    while i < N {
        out[i] = spec[i].0;
        i += 1;
    }
    out
}

/// Columns of the measured-groove CSV, in contract order (what `diagnose` reads and `simulate`
/// writes), without the optional [`SPINDLE_TEMP_COLUMN`].
pub const MEASURED_GROOVE_COLUMNS: [&str; 11] = {
    let mut out = [""; 11];
    let mut i = 0;
    while i < 11 {
        out[i] = MEASURED_GROOVE[i].0;
        i += 1;
    }
    out
};

/// Columns of the flute force trace, in contract order.
pub const FORCE_TRACE_COLUMNS: [&str; 4] = names(&FORCE_TRACE);

/// The measured-groove session schema: one row per measured point. A renamed column may come under its
/// version-1 name ([`MEASURED_GROOVE_V1_NAMES`]): both names are optional here and the readers require one
/// of them.
pub fn measured_groove_schema() -> Schema {
    let mut columns: Vec<ColumnSpec> = MEASURED_GROOVE
        .iter()
        .map(|(name, kind, what)| {
            if MEASURED_GROOVE_V1_NAMES.iter().any(|(_, new)| new == name) {
                ColumnSpec::optional(name, kind_of(*kind), what)
            } else {
                ColumnSpec::required(name, kind_of(*kind), what)
            }
        })
        .collect();
    for (old, new) in MEASURED_GROOVE_V1_NAMES {
        let kind = MEASURED_GROOVE
            .iter()
            .find(|(n, ..)| *n == new)
            .map_or(ColumnKind::Float, |(_, k, _)| kind_of(*k));
        columns.push(ColumnSpec::optional(
            old,
            kind,
            &format!("version-1 name of `{new}`"),
        ));
    }
    columns.push(ColumnSpec::optional(
        SPINDLE_TEMP_COLUMN,
        ColumnKind::Float,
        "spindle temperature",
    ));
    Schema::new("measured_groove", columns)
}

/// Renames version-1 columns to their current names (with a note); a renamed column missing under both
/// names is the missing-column error naming the current name.
fn upgrade_v1(path: &Path, table: &mut Table) -> Result<Vec<String>, DatasetError> {
    let mut notes = Vec::new();
    for (old, new) in MEASURED_GROOVE_V1_NAMES {
        if table.column(new).is_some() {
            continue;
        }
        match table.columns.iter_mut().find(|c| c.name == old) {
            Some(c) => {
                c.name = new.to_string();
                notes.push(format!(
                    "column `{old}` read as `{new}` (its name in version 1 of the measured-groove contract)"
                ));
            }
            None => {
                return Err(DatasetError::MissingColumn {
                    file: path.to_path_buf(),
                    column: new.to_string(),
                    present: table.names().join(", "),
                });
            }
        }
    }
    Ok(notes)
}

/// The flute force-trace schema: one row per measured point.
pub fn force_trace_schema() -> Schema {
    Schema::new(
        "force_trace",
        FORCE_TRACE
            .iter()
            .map(|(name, kind, what)| ColumnSpec::required(name, *kind, what))
            .collect(),
    )
}

/// Name, kind and meaning of every sensor-log column, in contract order.
const SENSOR_LOG: [(&str, ColumnKind, &str); 4] = [
    (
        "t_s",
        ColumnKind::Float,
        "time of the sample since the first (s): one row per control period, no row left out",
    ),
    (
        "x_mm",
        ColumnKind::Reading,
        "the NC's position along the groove when the sensors were read (mm; NaN or empty: not available)",
    ),
    (
        "force_n",
        ColumnKind::Reading,
        "the measured workpiece z-force (N; NaN or empty: no reading, the last one holds)",
    ),
    (
        "gauge_um",
        ColumnKind::Reading,
        "the capacitance gauge's reading of the tool tip (um; NaN or empty: no reading, the last one holds)",
    ),
];

/// Columns of the sensor log, in contract order.
pub const SENSOR_LOG_COLUMNS: [&str; 4] = names(&SENSOR_LOG);

/// The sensor-log schema: one row per control period.
pub fn sensor_log_schema() -> Schema {
    Schema::new(
        "sensor_log",
        SENSOR_LOG
            .iter()
            .map(|(name, kind, what)| ColumnSpec::required(name, *kind, what))
            .collect(),
    )
}

/// A sensor log: what a controller read, one entry per control period (the columns of
/// [`SENSOR_LOG_COLUMNS`]; NaN: no reading in that period).
///
/// The rate is the controller's: the rows are consecutive control periods (`t_s` rises by the
/// program's `controller.dt_s` from row to row, within 1 %: [`SensorLog::check_rate`]); a sample the
/// machine did not get is a row with NaN (or empty) readings, not a missing row. A NaN force or gauge
/// reading holds the channel's last reading; a NaN position is not checked against the program.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SensorLog {
    /// Sample times (s).
    pub t_s: Vec<f64>,
    /// The NC's positions (mm).
    pub x_mm: Vec<f64>,
    /// The force readings (N).
    pub force_n: Vec<f64>,
    /// The gauge readings (µm).
    pub gauge_um: Vec<f64>,
}

impl SensorLog {
    /// Samples in the log.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Whether the log has no sample.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Checks the rows are consecutive periods of `dt_s` (each step of `t_s` within 1 % of it);
    /// `origin` names the file.
    ///
    /// ```
    /// use millcomp_datasets::contracts::{SENSOR_LOG_COLUMNS, read_sensor_log_str};
    /// let csv = format!("{}\n0,0,0.1,\n5e-5,NaN,0.2,0.01\n2e-4,0,0.2,0.01\n", SENSOR_LOG_COLUMNS.join(","));
    /// let log = read_sensor_log_str("log.csv", &csv).unwrap();
    /// assert!(log.gauge_um[0].is_nan() && log.x_mm[1].is_nan());
    /// let e = log.check_rate("log.csv", 5e-5).unwrap_err().to_string();
    /// assert!(e.contains("log.csv") && e.contains("row 3") && e.contains("t_s"), "{e}");
    /// assert!(e.contains("a step of 1.500e-4 s; the period is 5e-5 s"), "{e}");
    /// ```
    ///
    /// # Errors
    /// [`DatasetError::Empty`] for a log without rows; [`DatasetError::BadCell`] naming the file,
    /// `t_s` and the 1-based data row of the first step that is not one period.
    pub fn check_rate(&self, origin: &str, dt_s: f64) -> Result<(), DatasetError> {
        if self.is_empty() {
            return Err(DatasetError::Empty {
                file: origin.into(),
                what: "data rows",
            });
        }
        for (i, w) in self.t_s.windows(2).enumerate() {
            if ((w[1] - w[0]) - dt_s).abs() > 0.01 * dt_s {
                return Err(DatasetError::BadCell {
                    file: origin.into(),
                    column: "t_s".into(),
                    row: i + 2,
                    value: format!(
                        "{} after {} (a step of {:.3e} s; the period is {dt_s:e} s)",
                        w[1],
                        w[0],
                        w[1] - w[0]
                    ),
                    expected: "one control period after the row before (no row left out: a missed sample is a row of NaN readings)",
                });
            }
        }
        Ok(())
    }
}

/// Reads a sensor log (CSV or Parquet).
///
/// # Errors
/// [`DatasetError`] naming the file, the column and the 1-based data row (a missing column, a cell
/// that is not a number, NaN or empty, an infinite reading, a non-finite `t_s`).
pub fn read_sensor_log(path: &Path) -> Result<SensorLog, DatasetError> {
    sensor_log(&read_table(path, &sensor_log_schema())?)
}

/// Reads sensor-log CSV text; `origin` names it in messages.
///
/// # Errors
/// As [`read_sensor_log`].
pub fn read_sensor_log_str(origin: &str, text: &str) -> Result<SensorLog, DatasetError> {
    sensor_log(&read_csv_str(origin, text, &sensor_log_schema())?)
}

/// Reads a sensor log from a data frame in memory (the Python package's tables), validated as a file
/// with the same cells; `origin` names it in messages.
///
/// # Errors
/// As [`read_sensor_log`].
pub fn read_sensor_log_frame(
    origin: &str,
    df: &polars::prelude::DataFrame,
) -> Result<SensorLog, DatasetError> {
    sensor_log(&read_dataframe(origin, df, &sensor_log_schema())?)
}

fn sensor_log(t: &Table) -> Result<SensorLog, DatasetError> {
    Ok(SensorLog {
        t_s: t.f64s("t_s")?,
        x_mm: t.f64s("x_mm")?,
        force_n: t.f64s("force_n")?,
        gauge_um: t.f64s("gauge_um")?,
    })
}

/// The sensor-log table of `log`, for [`write_table`](crate::write_table).
///
/// # Errors
/// As [`measured_groove_table`].
pub fn sensor_log_table(origin: &str, log: &SensorLog) -> Result<Table, DatasetError> {
    named_table(
        origin,
        &SENSOR_LOG_COLUMNS,
        [&log.t_s, &log.x_mm, &log.force_n, &log.gauge_um].map(|v| ColumnData::Float(v.clone())),
    )
}

/// A table of `data`'s columns under a contract's `names`, in order.
fn named_table<const N: usize>(
    origin: &str,
    names: &[&str; N],
    data: [ColumnData; N],
) -> Result<Table, DatasetError> {
    Table::from_columns(
        origin,
        names
            .iter()
            .zip(data)
            .map(|(name, data)| Column {
                name: name.to_string(),
                data,
            })
            .collect(),
    )
}

/// Columns of a replay's commands table (`millcomp replay --out`, the Python `Controller.replay`), in
/// order: the controller's name, the cycle (0-based), the sample's `t_s` (s), the voltage sent (V),
/// the command's flag bits and the QP's iterations.
pub const COMMANDS_COLUMNS: [&str; 6] = [
    "controller",
    "cycle",
    "t_s",
    "voltage_v",
    "flags",
    "iterations",
];

/// One controller's commands over a sensor log, column by column.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CommandColumns {
    /// The controller's name.
    pub controller: String,
    /// The voltages sent (V), one per sample.
    pub voltage_v: Vec<f64>,
    /// The flag bits.
    pub flags: Vec<u32>,
    /// The QP's iterations.
    pub iterations: Vec<u32>,
}

/// The commands table ([`COMMANDS_COLUMNS`]): one row per controller and sample, the controllers one
/// after the other; `t_s` holds the samples' times.
///
/// ```
/// use millcomp_datasets::contracts::{COMMANDS_COLUMNS, CommandColumns, commands_table};
/// let run = CommandColumns { controller: "pid".into(), voltage_v: vec![0.0, 1.5],
///                            flags: vec![8, 0], iterations: vec![0, 0] };
/// let t = commands_table("out.csv", &[0.0, 5e-5], &[run]).unwrap();
/// assert_eq!(t.names(), COMMANDS_COLUMNS);
/// assert_eq!(t.f64s("voltage_v").unwrap(), [0.0, 1.5]);
/// ```
///
/// # Errors
/// As [`Table::from_columns`]; a run longer than `t_s` (or with columns of unequal lengths) is
/// refused naming `t_s`.
pub fn commands_table(
    origin: &str,
    t_s: &[f64],
    runs: &[CommandColumns],
) -> Result<Table, DatasetError> {
    let rows: usize = runs.iter().map(|r| r.voltage_v.len()).sum();
    let mut controller = Vec::with_capacity(rows);
    let (mut cycle, mut time, mut v, mut flags, mut it) = (
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
    );
    for r in runs {
        if r.voltage_v.len() > t_s.len()
            || r.flags.len() != r.voltage_v.len()
            || r.iterations.len() != r.voltage_v.len()
        {
            return Err(DatasetError::BadCell {
                file: origin.into(),
                column: "t_s".into(),
                row: t_s.len() + 1,
                value: format!(
                    "{} samples for {} commands of `{}`",
                    t_s.len(),
                    r.voltage_v.len(),
                    r.controller
                ),
                expected: "one sample time per command",
            });
        }
        let n = r.voltage_v.len();
        controller.extend(std::iter::repeat_n(r.controller.clone(), n));
        cycle.extend((0..n).map(|k| k as i64));
        time.extend_from_slice(&t_s[..n]);
        v.extend_from_slice(&r.voltage_v);
        flags.extend(r.flags.iter().map(|&f| i64::from(f)));
        it.extend(r.iterations.iter().map(|&i| i64::from(i)));
    }
    let data = [
        ColumnData::Text(controller),
        ColumnData::Int(cycle),
        ColumnData::Float(time),
        ColumnData::Float(v),
        ColumnData::Int(flags),
        ColumnData::Int(it),
    ];
    named_table(origin, &COMMANDS_COLUMNS, data)
}

/// A measured-groove file read into points.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredGroove {
    /// One point per data row, in file order.
    pub points: Vec<GroovePoint>,
    /// Columns present in the file but not in the contract, which were ignored.
    pub ignored_columns: Vec<String>,
    /// Notes on how the file was read (e.g. a version-1 column name).
    pub notes: Vec<String>,
}

/// Reads and validates a measured-groove file (CSV or Parquet) as a table: the schema, plus `t_s`
/// strictly increasing within each groove.
///
/// # Errors
/// [`DatasetError`] naming the file, the column and the 1-based data row.
pub fn read_measured_groove_table(path: &Path) -> Result<Table, DatasetError> {
    let mut table = read_table(path, &measured_groove_schema())?;
    upgrade_v1(path, &mut table)?;
    groove_points(path, &table)?;
    Ok(table)
}

/// [`read_measured_groove_table`] of a file whose columns are read under the contract's names by
/// `map` (`--columns`); returns the table and the mapping's notes.
///
/// # Errors
/// As [`read_measured_groove_table`], and those of [`crate::mapping::read_table_mapped`].
pub fn read_measured_groove_table_mapped(
    path: &Path,
    map: &crate::mapping::ColumnMap,
) -> Result<(Table, Vec<String>), DatasetError> {
    let (mut table, notes) =
        crate::mapping::read_table_mapped(path, &measured_groove_schema(), map)?;
    upgrade_v1(path, &mut table)?;
    groove_points(path, &table)?;
    Ok((table, notes))
}

/// [`read_measured_groove`] of a file whose columns are read under the contract's names by `map`
/// (`--columns`); the mapping's notes join the file's.
///
/// # Errors
/// As [`read_measured_groove`], and those of [`crate::mapping::read_table_mapped`].
pub fn read_measured_groove_mapped(
    path: &Path,
    map: &crate::mapping::ColumnMap,
) -> Result<MeasuredGroove, DatasetError> {
    let (table, notes) = crate::mapping::read_table_mapped(path, &measured_groove_schema(), map)?;
    let mut m = measured_groove_from(path, table)?;
    m.notes.splice(0..0, notes);
    Ok(m)
}

/// Reads and validates a measured-groove file (CSV or Parquet) into points.
///
/// # Errors
/// [`DatasetError`] naming the file, the column and the 1-based data row: a missing column, a cell
/// that is not a finite number (or not 0/1 for `coolant_on`), time going backwards within a groove.
pub fn read_measured_groove(path: &Path) -> Result<MeasuredGroove, DatasetError> {
    let table = read_table(path, &measured_groove_schema())?;
    measured_groove_from(path, table)
}

/// A measured-groove table held in memory (a Python caller's frame) into points, validated as
/// [`read_measured_groove`] validates a file; `origin` names it in messages.
///
/// # Errors
/// As [`read_measured_groove`].
pub fn measured_groove_from_dataframe(
    origin: &str,
    df: &polars::prelude::DataFrame,
) -> Result<MeasuredGroove, DatasetError> {
    let table = crate::table::read_dataframe(origin, df, &measured_groove_schema())?;
    measured_groove_from(Path::new(origin), table)
}

/// Reads measured-groove CSV text (embedded data, tests) into points; `origin` names it in messages.
///
/// # Errors
/// As [`read_measured_groove`].
pub fn read_measured_groove_str(origin: &str, text: &str) -> Result<MeasuredGroove, DatasetError> {
    let table = read_csv_str(origin, text, &measured_groove_schema())?;
    measured_groove_from(Path::new(origin), table)
}

fn measured_groove_from(path: &Path, mut table: Table) -> Result<MeasuredGroove, DatasetError> {
    let mut notes = std::mem::take(&mut table.notes);
    notes.extend(upgrade_v1(path, &mut table)?);
    Ok(MeasuredGroove {
        points: groove_points(path, &table)?,
        ignored_columns: table.ignored_columns,
        notes,
    })
}

/// The points of a typed measured-groove table, checked by the contract's rules (the one validator,
/// `millcomp_sim::session::check_groove_points`: finite values, physical ranges, time strictly
/// increasing within a groove).
fn groove_points(path: &Path, t: &Table) -> Result<Vec<GroovePoint>, DatasetError> {
    let ids = t.i64s("groove_id")?;
    let f = |name: &str| t.f64s(name);
    let (ts, x, cut, rpm, feed, up, tilt) = (
        f("t_s")?,
        f("x_mm")?,
        f("cut_length_mm")?,
        f("speed_rpm")?,
        f("feed_mm_min")?,
        f("upfeed_um")?,
        f("tilt_deg")?,
    );
    let coolant = t.i64s("coolant_on")?;
    let (cmd, meas) = (f("depth_cmd_um")?, f("depth_meas_um")?);
    let temp = t
        .column(SPINDLE_TEMP_COLUMN)
        .map(|_| f(SPINDLE_TEMP_COLUMN))
        .transpose()?;
    let points: Vec<GroovePoint> = (0..t.n_rows())
        .map(|i| GroovePoint {
            groove_id: ids[i],
            t_s: ts[i],
            x_mm: x[i],
            cut_length_mm: cut[i],
            speed_rpm: rpm[i],
            feed_mm_min: feed[i],
            upfeed_um: up[i],
            tilt_deg: tilt[i],
            // a Flag column holds only 0 and 1
            coolant_on: u8::from(coolant[i] != 0),
            depth_cmd_um: cmd[i],
            depth_meas_um: meas[i],
            spindle_temp_c: temp.as_ref().map(|v| v[i]),
        })
        .collect();
    check_groove_points(&points).map_err(|e| invalid(path, e))?;
    Ok(points)
}

/// sim's rule error as the reader's, naming the file (rows are counted alike, from 1).
fn invalid(path: &Path, e: SimError) -> DatasetError {
    match e {
        SimError::Point {
            row,
            column,
            message,
        } => DatasetError::Invalid {
            file: path.to_path_buf(),
            column: column.to_string(),
            row,
            message,
        },
        other => DatasetError::Contract {
            file: path.to_path_buf(),
            source: other,
        },
    }
}

/// The measured-groove table of `points` (contract columns; `spindle_temp_c` added when any point
/// has it, empty cells are not allowed so a missing temperature is then NaN), for [`write_table`]
/// or [`write_csv_to`].
///
/// [`write_table`]: crate::write_table
/// [`write_csv_to`]: crate::table::write_csv_to
///
/// # Errors
/// Never for points from one source; [`DatasetError::RaggedColumns`] cannot occur here but is the
/// table builder's error type.
pub fn measured_groove_table(origin: &str, points: &[GroovePoint]) -> Result<Table, DatasetError> {
    let float = |f: fn(&GroovePoint) -> f64| ColumnData::Float(points.iter().map(f).collect());
    let data: [ColumnData; 11] = [
        ColumnData::Int(points.iter().map(|p| p.groove_id).collect()),
        float(|p| p.t_s),
        float(|p| p.x_mm),
        float(|p| p.cut_length_mm),
        float(|p| p.speed_rpm),
        float(|p| p.feed_mm_min),
        float(|p| p.upfeed_um),
        float(|p| p.tilt_deg),
        ColumnData::Int(points.iter().map(|p| i64::from(p.coolant_on)).collect()),
        float(|p| p.depth_cmd_um),
        float(|p| p.depth_meas_um),
    ];
    let mut columns: Vec<Column> = MEASURED_GROOVE_COLUMNS
        .iter()
        .zip(data)
        .map(|(name, data)| Column {
            name: name.to_string(),
            data,
        })
        .collect();
    if points.iter().any(|p| p.spindle_temp_c.is_some()) {
        columns.push(Column {
            name: SPINDLE_TEMP_COLUMN.to_string(),
            data: float(|p| p.spindle_temp_c.unwrap_or(f64::NAN)),
        });
    }
    Table::from_columns(origin, columns)
}

/// Reads a flute force-trace file (CSV or Parquet).
///
/// # Errors
/// [`DatasetError`] naming the file, the column and the 1-based data row.
pub fn read_force_trace(path: &Path) -> Result<Vec<FluteForcePoint>, DatasetError> {
    force_points(&read_table(path, &force_trace_schema())?)
}

/// Reads flute force-trace CSV text; `origin` names it in messages.
///
/// # Errors
/// As [`read_force_trace`].
pub fn read_force_trace_str(
    origin: &str,
    text: &str,
) -> Result<Vec<FluteForcePoint>, DatasetError> {
    force_points(&read_csv_str(origin, text, &force_trace_schema())?)
}

fn force_points(t: &Table) -> Result<Vec<FluteForcePoint>, DatasetError> {
    let ids = t.i64s("groove_id")?;
    let (x, f1, f2) = (
        t.f64s("x_mm")?,
        t.f64s("fz_peak_flute1_n")?,
        t.f64s("fz_peak_flute2_n")?,
    );
    Ok((0..t.n_rows())
        .map(|i| FluteForcePoint {
            groove_id: ids[i],
            x_mm: x[i],
            fz_peak_flute1_n: f1[i],
            fz_peak_flute2_n: f2[i],
        })
        .collect())
}

/// The force-trace table of `rows`, for [`write_table`](crate::write_table).
///
/// # Errors
/// As [`measured_groove_table`].
pub fn force_trace_table(origin: &str, rows: &[FluteForcePoint]) -> Result<Table, DatasetError> {
    let data = [
        ColumnData::Int(rows.iter().map(|r| r.groove_id).collect()),
        ColumnData::Float(rows.iter().map(|r| r.x_mm).collect()),
        ColumnData::Float(rows.iter().map(|r| r.fz_peak_flute1_n).collect()),
        ColumnData::Float(rows.iter().map(|r| r.fz_peak_flute2_n).collect()),
    ];
    named_table(origin, &FORCE_TRACE_COLUMNS, data)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &tempfile::TempDir, text: &str) -> std::path::PathBuf {
        let p = dir.path().join("m.csv");
        std::fs::write(&p, text).unwrap();
        p
    }

    fn header() -> String {
        MEASURED_GROOVE_COLUMNS.join(",")
    }

    #[test]
    fn reads_version_1_files_and_requires_the_speed() {
        // a file written against version 1 of the contract (DESIGN.md: `spindle_rpm`)
        let v1 = header().replace("speed_rpm", "spindle_rpm");
        let m = read_measured_groove_str(
            "v1.csv",
            &format!("{v1}\n0,0,0,0,10000,100,10,20,1,0,0.1\n"),
        )
        .unwrap();
        assert_eq!(m.points[0].speed_rpm, 10_000.0);
        assert!(m.notes[0].contains("spindle_rpm"), "{:?}", m.notes);
        // neither name: the error names the current one
        let none = header().replace("speed_rpm,", "");
        let e = read_measured_groove_str("x.csv", &format!("{none}\n0,0,0,0,100,10,20,1,0,0.1\n"))
            .unwrap_err();
        assert!(
            matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "speed_rpm"),
            "{e}"
        );
    }

    #[test]
    fn accepts_contract_file_and_notes_unknown_columns() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            &format!(
                "{},operator\n1,0,0,0,10000,100,10,20,1,0,0.1,ann\n1,1,0.1,0.1,10000,100,10,20,1,1,1.2,ann\n",
                header()
            ),
        );
        let t = read_measured_groove_table(&p).unwrap();
        assert_eq!(t.n_rows(), 2);
        assert_eq!(t.ignored_columns, vec!["operator".to_string()]);
        let m = read_measured_groove(&p).unwrap();
        assert_eq!(m.points.len(), 2);
        assert_eq!(m.ignored_columns, vec!["operator".to_string()]);
        assert_eq!(m.points[1].depth_meas_um, 1.2);
        assert_eq!(m.points[1].spindle_temp_c, None);
    }

    #[test]
    fn rejects_time_going_backwards_within_a_groove() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            &format!(
                "{}\n1,5,0,0,10000,100,10,20,1,0,0\n2,1,0,0,10000,100,10,20,1,0,0\n1,4,0.1,0.1,10000,100,10,20,1,1,1\n",
                header()
            ),
        );
        let e = read_measured_groove_table(&p).unwrap_err();
        assert!(
            matches!(e, DatasetError::Invalid { row: 3, ref column, .. } if column == "t_s"),
            "{e}"
        );
        let e = read_measured_groove(&p).unwrap_err();
        assert!(
            matches!(e, DatasetError::Invalid { row: 3, ref column, .. } if column == "t_s"),
            "{e}"
        );
    }

    /// The measured-groove errors `diagnose` relied on when it had its own reader (moved from
    /// identify's `diagnose_bad_input::contract_csv_errors`; rows are now 1-based data rows).
    #[test]
    fn contract_csv_errors_name_column_and_row() {
        let h = header();
        // missing column
        let e = read_measured_groove_str("m.csv", "groove_id,t_s\n0,0\n").unwrap_err();
        assert!(
            matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "x_mm"),
            "{e}"
        );
        // non-numeric cell, named by column and row (the second data row)
        let e = read_measured_groove_str(
            "m.csv",
            &format!("{h}\n0,0,0,0,10000,100,10,20,0,0,0\n0,1,1,1,10000,100,10,20,0,4,abc\n"),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("depth_meas_um") && msg.contains("row 2"),
            "{msg}"
        );
        // NaN
        let e =
            read_measured_groove_str("m.csv", &format!("{h}\n0,0,0,0,10000,100,10,20,0,0,NaN\n"))
                .unwrap_err();
        assert!(
            matches!(e, DatasetError::NonFinite { ref column, row: 1, .. } if column == "depth_meas_um"),
            "{e}"
        );
        // time going backwards within a groove
        let e = read_measured_groove_str(
            "m.csv",
            &format!("{h}\n0,5,0,0,10000,100,10,20,0,0,0\n1,1,0,0,10000,100,10,20,0,0,0\n0,4,1,1,10000,100,10,20,0,4,4\n"),
        )
        .unwrap_err();
        assert!(
            matches!(e, DatasetError::Invalid { row: 3, ref column, .. } if column == "t_s"),
            "{e}"
        );
        // coolant flag not 0/1
        let e = read_measured_groove_str("m.csv", &format!("{h}\n0,0,0,0,10000,100,10,20,2,0,0\n"))
            .unwrap_err();
        assert!(e.to_string().contains("coolant_on"), "{e}");
        // unknown extra columns are accepted
        let m = read_measured_groove_str(
            "m.csv",
            &format!("{h},operator\n0,0,0,0,10000,100,10,20,0,0,0.1,7\n"),
        )
        .unwrap();
        assert_eq!(m.points.len(), 1);
    }

    #[test]
    fn points_round_trip_through_the_table_writer() {
        let dir = tempfile::tempdir().unwrap();
        let text = format!(
            "{},{SPINDLE_TEMP_COLUMN}\n0,0,0,0,10000,100,10,20,1,0,0.1,21.5\n0,0.6,1,1.0000000000000002,10000,100,10,20,1,4,2.081899070919204,22\n",
            header()
        );
        let m = read_measured_groove_str("m.csv", &text).unwrap();
        assert_eq!(m.points[1].spindle_temp_c, Some(22.0));
        let table = measured_groove_table("out", &m.points).unwrap();
        assert_eq!(
            table.names()[..11],
            MEASURED_GROOVE_COLUMNS[..],
            "contract order"
        );
        for name in ["out.csv", "out.parquet"] {
            let p = dir.path().join(name);
            crate::write_table(&table, &p).unwrap();
            assert_eq!(read_measured_groove(&p).unwrap().points, m.points, "{name}");
        }
        // the CSV text: the contract header, one line per point (moved from sim's session tests
        // when sim's own CSV writer was deleted)
        let mut buf = Vec::new();
        crate::write_csv_to(&table, &mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert_eq!(
            text.lines().next().unwrap(),
            format!("{},{SPINDLE_TEMP_COLUMN}", header())
        );
        assert_eq!(text.lines().count(), m.points.len() + 1);
        // without temperatures there is no temperature column
        let mut cold = m.points.clone();
        for p in &mut cold {
            p.spindle_temp_c = None;
        }
        let t = measured_groove_table("out", &cold).unwrap();
        assert_eq!(t.names(), MEASURED_GROOVE_COLUMNS.to_vec());
    }

    #[test]
    fn force_trace_reads_writes_and_names_missing_columns() {
        let dir = tempfile::tempdir().unwrap();
        let text = format!(
            "{}\n0,0,-0.03152391715589805,0.06310137883878786\n0,1,0.9773717762192433,1.09254431731701\n",
            FORCE_TRACE_COLUMNS.join(",")
        );
        let rows = read_force_trace_str("f.csv", &text).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].fz_peak_flute2_n, 1.09254431731701);
        let p = dir.path().join("f.csv");
        crate::write_table(&force_trace_table("f", &rows).unwrap(), &p).unwrap();
        assert_eq!(read_force_trace(&p).unwrap(), rows);
        // moved from identify's `diagnose_bad_input::force_trace_rows_must_match_points`
        let e =
            read_force_trace_str("f.csv", "groove_id,x_mm,fz_peak_flute1_n\n0,0,1\n").unwrap_err();
        assert!(
            matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "fz_peak_flute2_n"),
            "{e}"
        );
    }
}
