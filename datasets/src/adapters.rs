//! The one place where a table becomes the column types of the analysis libraries, and back (one
//! adapter per consumer). Integers stay integers for doe (a design's run order prints as an integer) and
//! become floats for identify (every identification column is a measurement).

use crate::error::DatasetError;
use crate::table::{Column, ColumnData, Table};

/// The table's columns as doe's named columns.
pub fn doe_columns(table: &Table) -> Vec<(String, millcomp_doe::Values)> {
    table
        .columns
        .iter()
        .map(|c| {
            let col = match &c.data {
                ColumnData::Float(v) => millcomp_doe::Values::F64(v.clone()),
                ColumnData::Int(v) => millcomp_doe::Values::I64(v.clone()),
                ColumnData::Text(v) => millcomp_doe::Values::Str(v.clone()),
            };
            (c.name.clone(), col)
        })
        .collect()
}

/// doe's named columns (e.g. a generated design) as a table for writing or for `batch`.
///
/// # Errors
/// [`DatasetError`] when the columns have different lengths or repeat a name.
pub fn table_from_doe(
    origin: &str,
    columns: Vec<(String, millcomp_doe::Values)>,
) -> Result<Table, DatasetError> {
    let cols = columns
        .into_iter()
        .map(|(name, c)| Column {
            name,
            data: match c {
                millcomp_doe::Values::F64(v) => ColumnData::Float(v),
                millcomp_doe::Values::I64(v) => ColumnData::Int(v),
                millcomp_doe::Values::Str(v) => ColumnData::Text(v),
            },
        })
        .collect();
    Table::from_columns(origin, cols)
}

/// The table's columns as identify's named data columns (integers as floats).
pub fn identify_columns(table: &Table) -> millcomp_identify::Columns {
    let mut cols = millcomp_identify::Columns::new();
    for c in &table.columns {
        match &c.data {
            ColumnData::Float(v) => cols.insert(&c.name, v.clone()),
            ColumnData::Int(v) => cols.insert(&c.name, v.iter().map(|&x| x as f64).collect()),
            ColumnData::Text(v) => cols.insert_text(&c.name, v.clone()),
        };
    }
    cols
}
