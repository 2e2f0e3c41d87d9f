//! The one place where a table becomes the column types of the analysis libraries, and back (one
//! adapter per consumer). Integers stay integers for doe (a design's run order prints as an integer) and
//! become floats for identify (every identification column is a measurement).

use crate::error::DatasetError;
use crate::table::{Column, ColumnData, Table};

/// The table's columns as doe's named values, in table order (floats, integers and text kept as
/// [`Values::F64`](millcomp_doe::Values::F64), `I64` and `Str`).
///
/// ```
/// use millcomp_doe::{analyze, AnalysisInput, ModelSpec, Values};
/// let t = millcomp_datasets::load("clayton_doe").unwrap();
/// let cols = millcomp_datasets::adapters::doe_columns(&t);
/// assert!(matches!(&cols[0], (name, Values::I64(v)) if name == "trial" && v.len() == 8));
/// let factors: Vec<String> = ["depth_um", "speed_rpm", "upfeed_um"].map(String::from).to_vec();
/// let input = AnalysisInput::from_table(&cols, "max_fx_n", Some(&factors), ModelSpec::Main).unwrap();
/// // 000_…txt Table 3-3 analysed as `millcomp doe analyze` does; statsmodels 0.15.0
/// // anova_lm(typ=2) gives F(depth) = 57.1485…
/// assert!((analyze(&input).unwrap().terms[0].f.unwrap() - 57.148534).abs() < 1e-5);
/// ```
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

/// doe's named values (e.g. a generated design's [`columns`](millcomp_doe::Design::columns)) as a table
/// for writing or for `batch`; `origin` names it in errors.
///
/// ```
/// use millcomp_doe::{generate, DesignKind, DesignRequest, FactorSpec};
/// let mut req = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list("depth_um=100:200,A").unwrap());
/// req.seed = Some(1);
/// let design = generate(&req).unwrap();
/// let t = millcomp_datasets::adapters::table_from_doe("design", design.columns()).unwrap();
/// assert_eq!(t.names(), ["std_order", "run_order", "block", "depth_um", "depth_um_coded", "A", "A_coded"]);
/// assert_eq!(t.i64s("run_order").unwrap(), [1, 2, 3, 4]);
/// ```
///
/// # Errors
/// [`DatasetError::RaggedColumns`] when the columns have different lengths.
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

/// The table's columns as identify's named data columns (integers as floats, text kept as text).
///
/// ```
/// let t = millcomp_datasets::load("clayton_doe").unwrap();
/// let cols = millcomp_datasets::adapters::identify_columns(&t);
/// // the integer column `trial` arrives as floats
/// assert!(format!("{cols:?}").contains(r#""trial": [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]"#));
/// ```
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
