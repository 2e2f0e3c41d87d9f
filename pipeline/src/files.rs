//! The measured files of the pipeline's stages: their schemas (one each, defined here; the columns are
//! those of the `millcomp identify` verbs, so a file made for one reads in the other) and the records
//! they hold. Read through the one table reader (errors name the file, column and row).

use std::path::Path;

use millcomp_closedloop::commissioning::{
    ForceTraces, LoadRecord, RestRecord, StepRecord, SweepRecord,
};
use millcomp_datasets::{Column, ColumnData, ColumnKind, ColumnSpec, Schema, Table};

use crate::error::{PipelineError, Result};

fn float(name: &str, what: &str) -> ColumnSpec {
    ColumnSpec::required(name, ColumnKind::Float, what)
}

/// Force calibration traces.
pub fn forces_schema() -> Schema {
    Schema::new(
        "force calibration traces",
        vec![
            ColumnSpec::required("run", ColumnKind::Int, "calibration cut (0-based)"),
            ColumnSpec::required(
                "material",
                ColumnKind::Text,
                "workpiece material (S7, 6061, …)",
            ),
            float("depth_um", "programmed depth (µm)"),
            float("upfeed_um", "upfeed (µm/rev)"),
            float("speed_rpm", "spindle speed (rpm)"),
            float("tilt_deg", "tool tilt (deg)"),
            float("rot_deg", "rotation angle of the sample (deg)"),
            float("fz_n", "z-force averaged over the cut's revolutions (N)"),
        ],
    )
}

/// Spindle step test.
pub fn step_schema() -> Schema {
    Schema::new(
        "spindle step test",
        vec![
            float("t_s", "time (s)"),
            float("u_v", "amplifier command (V)"),
            float("y_um", "gauge reading of the tool tip (µm)"),
        ],
    )
}

/// Hysteresis sweep.
pub fn sweep_schema() -> Schema {
    Schema::new(
        "hysteresis sweep",
        vec![
            float("u_v", "drive voltage (V)"),
            float("y_um", "gauge reading of the tool tip (µm)"),
        ],
    )
}

/// Load–deflection test.
pub fn load_schema() -> Schema {
    Schema::new(
        "load-deflection test",
        vec![
            float("load_n", "hanging load (N)"),
            float("deflection_um", "dial-indicator reading (µm)"),
            ColumnSpec::required("direction", ColumnKind::Text, "axial or radial"),
        ],
    )
}

/// Sensors at rest.
pub fn rest_schema() -> Schema {
    Schema::new(
        "sensors at rest",
        vec![
            float("t_s", "time (s)"),
            float("force_n", "force channel, zeroed, spindle in air (N)"),
            float("gauge_um", "gauge, PZT held (µm)"),
        ],
    )
}

fn col_f(name: &str, v: &[f64]) -> Column {
    Column {
        name: name.into(),
        data: ColumnData::Float(v.to_vec()),
    }
}

fn write(path: &Path, origin: &str, cols: Vec<Column>) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| PipelineError::io(dir, "creating", e))?;
    }
    let t = Table::from_columns(origin, cols)?;
    millcomp_datasets::write_table(&t, path)?;
    Ok(())
}

/// Force traces of several materials, one table.
pub fn write_forces(path: &Path, per_material: &[(String, ForceTraces)]) -> Result<()> {
    let (mut run, mut mat) = (Vec::new(), Vec::new());
    let mut cols: [Vec<f64>; 6] = Default::default();
    let mut offset = 0usize;
    for (m, t) in per_material {
        let n_runs = t.run.iter().max().map_or(0, |r| r + 1);
        for i in 0..t.fz_n.len() {
            run.push((offset + t.run[i]) as i64);
            mat.push(m.clone());
            for (c, v) in cols.iter_mut().zip([
                t.depth_um[i],
                t.upfeed_um[i],
                t.speed_rpm[i],
                t.tilt_deg[i],
                t.rot_deg[i],
                t.fz_n[i],
            ]) {
                c.push(v);
            }
        }
        offset += n_runs;
    }
    let names = [
        "depth_um",
        "upfeed_um",
        "speed_rpm",
        "tilt_deg",
        "rot_deg",
        "fz_n",
    ];
    let mut columns = vec![
        Column {
            name: "run".into(),
            data: ColumnData::Int(run),
        },
        Column {
            name: "material".into(),
            data: ColumnData::Text(mat),
        },
    ];
    columns.extend(names.iter().zip(&cols).map(|(n, v)| col_f(n, v)));
    write(path, "force calibration traces", columns)
}

/// Reads force traces, split by material (in order of first appearance).
///
/// # Errors
/// The reader's errors (file, column, row); [`PipelineError::Data`] for an empty file.
pub fn read_forces(path: &Path) -> Result<Vec<(String, ForceTraces)>> {
    let t = millcomp_datasets::read_table(path, &forces_schema())?;
    let run: Vec<i64> = t.f64s("run")?.into_iter().map(|r| r as i64).collect();
    let mat = t.strings("material")?;
    let f = |n: &str| t.f64s(n);
    let (d, u, s, a, r, z) = (
        f("depth_um")?,
        f("upfeed_um")?,
        f("speed_rpm")?,
        f("tilt_deg")?,
        f("rot_deg")?,
        f("fz_n")?,
    );
    if z.is_empty() {
        return Err(PipelineError::data(path, "no rows"));
    }
    let mut out: Vec<(String, ForceTraces)> = Vec::new();
    for i in 0..z.len() {
        let k = match out.iter().position(|(m, _)| *m == mat[i]) {
            Some(k) => k,
            None => {
                out.push((mat[i].clone(), ForceTraces::default()));
                out.len() - 1
            }
        };
        let tr = &mut out[k].1;
        if run[i] < 0 {
            return Err(PipelineError::data(
                path,
                format!("column run, row {}: {} is negative", i + 1, run[i]),
            ));
        }
        tr.run.push(run[i] as usize);
        tr.depth_um.push(d[i]);
        tr.upfeed_um.push(u[i]);
        tr.speed_rpm.push(s[i]);
        tr.tilt_deg.push(a[i]);
        tr.rot_deg.push(r[i]);
        tr.fz_n.push(z[i]);
    }
    Ok(out)
}

/// Writes a step record.
pub fn write_step(path: &Path, r: &StepRecord) -> Result<()> {
    write(
        path,
        "spindle step test",
        vec![
            col_f("t_s", &r.t_s),
            col_f("u_v", &r.u_v),
            col_f("y_um", &r.y_um),
        ],
    )
}

/// Reads a step record.
///
/// # Errors
/// The reader's errors.
pub fn read_step(path: &Path) -> Result<StepRecord> {
    let t = millcomp_datasets::read_table(path, &step_schema())?;
    Ok(StepRecord {
        t_s: t.f64s("t_s")?,
        u_v: t.f64s("u_v")?,
        y_um: t.f64s("y_um")?,
    })
}

/// Writes a sweep record.
pub fn write_sweep(path: &Path, r: &SweepRecord) -> Result<()> {
    write(
        path,
        "hysteresis sweep",
        vec![col_f("u_v", &r.u_v), col_f("y_um", &r.y_um)],
    )
}

/// Reads a sweep record.
///
/// # Errors
/// The reader's errors.
pub fn read_sweep(path: &Path) -> Result<SweepRecord> {
    let t = millcomp_datasets::read_table(path, &sweep_schema())?;
    Ok(SweepRecord {
        u_v: t.f64s("u_v")?,
        y_um: t.f64s("y_um")?,
    })
}

/// Writes a load–deflection record.
pub fn write_load(path: &Path, r: &LoadRecord) -> Result<()> {
    write(
        path,
        "load-deflection test",
        vec![
            col_f("load_n", &r.load_n),
            col_f("deflection_um", &r.deflection_um),
            Column {
                name: "direction".into(),
                data: ColumnData::Text(r.direction.clone()),
            },
        ],
    )
}

/// Reads a load–deflection record.
///
/// # Errors
/// The reader's errors.
pub fn read_load(path: &Path) -> Result<LoadRecord> {
    let t = millcomp_datasets::read_table(path, &load_schema())?;
    Ok(LoadRecord {
        load_n: t.f64s("load_n")?,
        deflection_um: t.f64s("deflection_um")?,
        direction: t.strings("direction")?,
    })
}

/// Writes a record at rest.
pub fn write_rest(path: &Path, r: &RestRecord) -> Result<()> {
    let t: Vec<f64> = (0..r.force_n.len()).map(|k| k as f64 * r.dt_s).collect();
    write(
        path,
        "sensors at rest",
        vec![
            col_f("t_s", &t),
            col_f("force_n", &r.force_n),
            col_f("gauge_um", &r.gauge_um),
        ],
    )
}

/// Reads a record at rest (its interval from the first two times).
///
/// # Errors
/// The reader's errors; [`PipelineError::Data`] for fewer than two rows or times not increasing.
pub fn read_rest(path: &Path) -> Result<RestRecord> {
    let t = millcomp_datasets::read_table(path, &rest_schema())?;
    let ts = t.f64s("t_s")?;
    if ts.len() < 2 || ts[1] <= ts[0] {
        return Err(PipelineError::data(
            path,
            "column t_s: at least two rows with increasing times",
        ));
    }
    Ok(RestRecord {
        dt_s: ts[1] - ts[0],
        force_n: t.f64s("force_n")?,
        gauge_um: t.f64s("gauge_um")?,
    })
}

/// Writes a text file atomically, creating its directory.
///
/// # Errors
/// [`PipelineError::Io`], [`PipelineError::Dataset`].
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| PipelineError::io(dir, "creating", e))?;
    }
    millcomp_datasets::write_text_atomic(path, text)?;
    Ok(())
}

/// A table from named columns, written.
///
/// # Errors
/// As [`write_text`].
pub fn write_columns(path: &Path, origin: &str, cols: Vec<Column>) -> Result<()> {
    write(path, origin, cols)
}
