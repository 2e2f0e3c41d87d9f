//! Schemas of the files other tools exchange with millcomp (DESIGN.md "Contracts").

use std::path::Path;

use crate::error::DatasetError;
use crate::table::{ColumnKind, ColumnSpec, Schema, Table, read_table};

/// Columns of the measured-groove CSV, in contract order (what `diagnose` reads and `simulate`
/// writes).
pub const MEASURED_GROOVE_COLUMNS: [&str; 11] = [
    "groove_id",
    "t_s",
    "x_mm",
    "cut_length_mm",
    "spindle_rpm",
    "feed_mm_min",
    "upfeed_um",
    "tilt_deg",
    "coolant_on",
    "depth_cmd_um",
    "depth_meas_um",
];

/// The measured-groove session schema: one row per measured point.
pub fn measured_groove_schema() -> Schema {
    use ColumnKind::{Flag, Float, Int};
    Schema::new(
        "measured_groove",
        vec![
            ColumnSpec::required("groove_id", Int, "groove number"),
            ColumnSpec::required("t_s", Float, "session clock when this point was cut"),
            ColumnSpec::required("x_mm", Float, "position along the groove"),
            ColumnSpec::required(
                "cut_length_mm",
                Float,
                "cumulative engaged length of the tool",
            ),
            ColumnSpec::required("spindle_rpm", Float, "spindle speed"),
            ColumnSpec::required("feed_mm_min", Float, "feed rate"),
            ColumnSpec::required("upfeed_um", Float, "feed per revolution"),
            ColumnSpec::required("tilt_deg", Float, "tool tilt"),
            ColumnSpec::required("coolant_on", Flag, "coolant flowing (0/1)"),
            ColumnSpec::required("depth_cmd_um", Float, "programmed depth"),
            ColumnSpec::required("depth_meas_um", Float, "measured groove depth"),
            ColumnSpec::optional("spindle_temp_c", Float, "spindle temperature"),
        ],
    )
}

/// Reads and validates a measured-groove CSV: the schema, plus `t_s` strictly increasing within
/// each groove.
pub fn read_measured_groove(path: &Path) -> Result<Table, DatasetError> {
    let table = read_table(path, &measured_groove_schema())?;
    check_time_monotone(path, &table)?;
    Ok(table)
}

fn check_time_monotone(path: &Path, table: &Table) -> Result<(), DatasetError> {
    let ids = table.i64s("groove_id")?;
    let t = table.f64s("t_s")?;
    let mut last: std::collections::HashMap<i64, f64> = std::collections::HashMap::new();
    for (i, (&id, &ti)) in ids.iter().zip(&t).enumerate() {
        if let Some(&prev) = last.get(&id) {
            if ti <= prev {
                return Err(DatasetError::Invalid {
                    file: path.to_path_buf(),
                    column: "t_s".to_string(),
                    row: i + 1,
                    message: format!(
                        "time {ti} s is not after the previous point of groove {id} ({prev} s); \
                         t_s must increase within a groove"
                    ),
                });
            }
        }
        last.insert(id, ti);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &tempfile::TempDir, text: &str) -> std::path::PathBuf {
        let p = dir.path().join("m.csv");
        std::fs::write(&p, text).unwrap();
        p
    }

    const HEADER: &str = "groove_id,t_s,x_mm,cut_length_mm,spindle_rpm,feed_mm_min,upfeed_um,tilt_deg,coolant_on,depth_cmd_um,depth_meas_um";

    #[test]
    fn accepts_contract_file_and_notes_unknown_columns() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            &format!(
                "{HEADER},operator\n1,0,0,0,10000,100,10,20,1,0,0.1,ann\n1,1,0.1,0.1,10000,100,10,20,1,1,1.2,ann\n"
            ),
        );
        let t = read_measured_groove(&p).unwrap();
        assert_eq!(t.n_rows(), 2);
        assert_eq!(t.ignored_columns, vec!["operator".to_string()]);
    }

    #[test]
    fn rejects_time_going_backwards_within_a_groove() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            &format!(
                "{HEADER}\n1,5,0,0,10000,100,10,20,1,0,0\n2,1,0,0,10000,100,10,20,1,0,0\n1,4,0.1,0.1,10000,100,10,20,1,1,1\n"
            ),
        );
        let e = read_measured_groove(&p).unwrap_err();
        assert!(
            matches!(e, DatasetError::Invalid { row: 3, ref column, .. } if column == "t_s"),
            "{e}"
        );
    }
}
