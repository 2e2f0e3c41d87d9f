//! Reading a user's own records: a column mapping from the names a verb reads (its *roles*, e.g.
//! `t_s`, `drift_um`, `temp_c`) to the columns of the user's file (`--columns
//! t_s=time_s,drift_um=disp_ch1_um,speed_rpm=spindle_rpm`), applied right after the table is read.
//!
//! * `role=column` — the file's column is read under the role's name;
//! * `role=a+b+c` — several columns for one role (e.g. temperatures), in the order given;
//! * `role=prefix*suffix` — every column matching the pattern (`*` matches any text), in file order;
//! * `role=3500` — a constant column (a condition the file does not record, e.g. `speed_rpm=10400`).
//!
//! **Units are checked**: where both the role and the file's column end in a unit millcomp knows
//! (`_um`, `_s`, `_c`, `_rpm`, `_n`, …; case ignored, so `temp_t1_C` is in °C), they must agree:
//! `drift_um=force_x_N` is an error naming both units. A file column without a unit suffix is accepted
//! and a note says which unit it is taken to be in. Every error names the file, the role and the
//! column.
//!
//! ```
//! use millcomp_datasets::mapping::{ColumnMap, read_any_mapped};
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("record.csv");
//! std::fs::write(&path, "time_s,disp_ch1_um,temp_t1_C,temp_t2_C\n0,0.1,20,21\n15,0.3,20.5,21.1\n").unwrap();
//! let map = ColumnMap::parse("t_s=time_s,drift_um=disp_ch1_um,temp_c=temp_t*_C").unwrap();
//! let m = read_any_mapped(&path, &map).unwrap();
//! assert_eq!(m.table.f64s("drift_um").unwrap(), [0.1, 0.3]);
//! assert_eq!(m.group("temp_c").unwrap().sources, ["temp_t1_C", "temp_t2_C"]);
//! // a unit that does not match is refused, naming both
//! let e = read_any_mapped(&path, &ColumnMap::parse("t_s=disp_ch1_um").unwrap()).unwrap_err();
//! assert!(e.to_string().contains("`t_s` is in s but column `disp_ch1_um` is in um"), "{e}");
//! // so is a column that is not there
//! let e = read_any_mapped(&path, &ColumnMap::parse("drift_um=disp_ch9_um").unwrap()).unwrap_err();
//! assert!(e.to_string().contains("no column `disp_ch9_um`"), "{e}");
//! ```

use std::path::Path;

use crate::error::DatasetError;
use crate::table::{Column, ColumnData, Schema, Table, read_any, read_table_renamed};

/// Where a role's values come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// One column of the file.
    Column(String),
    /// Several columns, in the order given (`a+b+c`).
    List(Vec<String>),
    /// Every column matching a pattern with `*` wildcards, in file order.
    Pattern(String),
    /// A constant value on every row.
    Constant(f64),
}

/// One `role=source` of a mapping.
#[derive(Debug, Clone, PartialEq)]
pub struct MapEntry {
    /// The name the verb reads (a contract column name, unit suffix included).
    pub role: String,
    /// The file's column(s) or a constant.
    pub source: Source,
}

/// A column mapping (`--columns`), in the order given.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColumnMap {
    /// The entries.
    pub entries: Vec<MapEntry>,
}

/// The columns a role was mapped to.
#[derive(Debug, Clone, PartialEq)]
pub struct RoleGroup {
    /// The role.
    pub role: String,
    /// The file's column names (for a constant, its value as text).
    pub sources: Vec<String>,
    /// The names of those columns in the mapped table: the role itself when it maps one column (or
    /// a constant), else the file's names.
    pub columns: Vec<String>,
}

/// A table read through a mapping.
#[derive(Debug, Clone, PartialEq)]
pub struct MappedTable {
    /// The table: single-column roles under the role's name, every other column under its own.
    pub table: Table,
    /// Every mapped role, in mapping order.
    pub groups: Vec<RoleGroup>,
    /// How the file was read (columns without a unit suffix, shadowed columns).
    pub notes: Vec<String>,
}

impl MappedTable {
    /// The columns of `role` (mapped, or present under that name without a mapping).
    pub fn group(&self, role: &str) -> Option<RoleGroup> {
        if let Some(g) = self.groups.iter().find(|g| g.role == role) {
            return Some(g.clone());
        }
        self.table.column(role).map(|_| RoleGroup {
            role: role.to_string(),
            sources: vec![role.to_string()],
            columns: vec![role.to_string()],
        })
    }

    /// `role` as the user's file names it: `t_s` or `t_s (file column time_s)`.
    pub fn describe(&self, role: &str) -> String {
        match self.groups.iter().find(|g| g.role == role) {
            Some(g) if g.sources.len() == 1 && g.sources[0] != role => {
                format!("`{role}` (file column `{}`)", g.sources[0])
            }
            _ => format!("`{role}`"),
        }
    }

    /// The file column behind a column of the mapped table (itself when not renamed).
    pub fn file_column(&self, name: &str) -> String {
        self.groups
            .iter()
            .find(|g| g.columns.len() == 1 && g.columns[0] == name)
            .map_or_else(|| name.to_string(), |g| g.sources[0].clone())
    }

    /// Checks that column `name` of the mapped table strictly increases (a time or cut counter).
    ///
    /// # Errors
    /// [`DatasetError::Invalid`] naming the file, the file's column (and the role) and the 1-based
    /// row where the value does not exceed the one before; [`DatasetError::NoSuchColumn`] /
    /// [`DatasetError::WrongColumnType`] when the column is absent or not numeric.
    pub fn strictly_increasing(&self, name: &str) -> Result<(), DatasetError> {
        let v = self.table.f64s(name)?;
        if let Some(i) = (1..v.len()).find(|&i| v[i] <= v[i - 1]) {
            let file_col = self.file_column(name);
            let column = if file_col == name {
                name.to_string()
            } else {
                format!("{file_col}` read as `{name}")
            };
            return Err(DatasetError::Invalid {
                file: self.table.origin.clone().into(),
                column,
                row: i + 1,
                message: format!(
                    "{} is not after the previous row's {} (it must strictly increase)",
                    v[i],
                    v[i - 1]
                ),
            });
        }
        Ok(())
    }
}

/// Unit suffixes millcomp's column names use (lower case); `n_per_um` style compounds are matched
/// whole.
const UNITS: [&str; 28] = [
    "um", "mm", "m", "nm", "s", "ms", "us", "min", "h", "n", "kn", "v", "mv", "c", "k", "rpm",
    "deg", "rad", "g", "pct", "hz", "khz", "w", "mpa", "gpa", "a", "n_per_um", "um_per_n",
];

/// The unit suffix of a column name (lower case), if it ends in one millcomp knows.
///
/// ```
/// use millcomp_datasets::mapping::unit_suffix;
/// assert_eq!(unit_suffix("temp_t1_C").as_deref(), Some("c"));
/// assert_eq!(unit_suffix("stiffness_n_per_um").as_deref(), Some("n_per_um"));
/// assert_eq!(unit_suffix("force_x__rms"), None);
/// assert_eq!(unit_suffix("run"), None);
/// ```
pub fn unit_suffix(name: &str) -> Option<String> {
    let lower = name.to_ascii_lowercase();
    let parts: Vec<&str> = lower.split('_').collect();
    if parts.len() < 2 {
        return None;
    }
    if parts.len() >= 4 && parts[parts.len() - 2] == "per" {
        let compound = parts[parts.len() - 3..].join("_");
        if UNITS.contains(&compound.as_str()) {
            return Some(compound);
        }
    }
    let last = parts[parts.len() - 1];
    UNITS.contains(&last).then(|| last.to_string())
}

fn bad_map(spec: &str, message: impl Into<String>) -> DatasetError {
    DatasetError::BadColumnMap {
        spec: spec.to_string(),
        message: message.into(),
    }
}

fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '_' | '.' | '-' | '°'))
}

impl ColumnMap {
    /// Parses `role=source[,role=source…]` (module documentation).
    ///
    /// # Errors
    /// [`DatasetError::BadColumnMap`] for an entry without `=`, an empty role or source, a role given
    /// twice, or a pattern with more than one `*`-free part missing.
    pub fn parse(spec: &str) -> Result<Self, DatasetError> {
        let mut entries: Vec<MapEntry> = Vec::new();
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let Some((role, source)) = item.split_once('=') else {
                return Err(bad_map(item, "expected role=column (e.g. t_s=time_s)"));
            };
            let (role, source) = (role.trim(), source.trim());
            if !valid_name(role) {
                return Err(bad_map(
                    item,
                    format!("`{role}` is not a column role (letters, digits, `_`)"),
                ));
            }
            if source.is_empty() {
                return Err(bad_map(item, "no column after `=`"));
            }
            if entries.iter().any(|e| e.role == role) {
                return Err(bad_map(item, format!("role `{role}` is mapped twice")));
            }
            let source = if let Ok(x) = source.parse::<f64>() {
                if !x.is_finite() {
                    return Err(bad_map(item, "a constant must be a finite number"));
                }
                Source::Constant(x)
            } else if source.contains('*') {
                Source::Pattern(source.to_string())
            } else if source.contains('+') {
                let list: Vec<String> = source.split('+').map(|s| s.trim().to_string()).collect();
                if list.iter().any(|s| s.is_empty()) {
                    return Err(bad_map(item, "an empty column name in a `+` list"));
                }
                Source::List(list)
            } else {
                Source::Column(source.to_string())
            };
            entries.push(MapEntry {
                role: role.to_string(),
                source,
            });
        }
        Ok(ColumnMap { entries })
    }

    /// Whether the mapping has no entry.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// `*`-wildcard match of a whole name.
fn matches(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !name.starts_with(first) || name.len() < first.len() + last.len() || !name.ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for mid in &parts[1..parts.len() - 1] {
        match rest.find(mid) {
            Some(i) => rest = &rest[i + mid.len()..],
            None => return false,
        }
    }
    true
}

/// The plan of a mapping on a file's header: which file column becomes which name.
struct Plan {
    /// `(file column, new name)` for single-column roles.
    renames: Vec<(String, String)>,
    /// `(role, value)` constant columns.
    constants: Vec<(String, f64)>,
    groups: Vec<RoleGroup>,
    notes: Vec<String>,
    /// File columns dropped because a role takes their name.
    shadowed: Vec<String>,
}

fn plan(map: &ColumnMap, file: &Path, names: &[String]) -> Result<Plan, DatasetError> {
    let mut p = Plan {
        renames: Vec::new(),
        constants: Vec::new(),
        groups: Vec::new(),
        notes: Vec::new(),
        shadowed: Vec::new(),
    };
    let present = || names.join(", ");
    let mut used: Vec<(String, String)> = Vec::new();
    for e in &map.entries {
        let sources: Vec<String> = match &e.source {
            Source::Constant(x) => {
                p.constants.push((e.role.clone(), *x));
                p.groups.push(RoleGroup {
                    role: e.role.clone(),
                    sources: vec![x.to_string()],
                    columns: vec![e.role.clone()],
                });
                p.notes.push(format!(
                    "`{}` is the constant {x} on every row (--columns)",
                    e.role
                ));
                continue;
            }
            Source::Column(c) => vec![c.clone()],
            Source::List(l) => l.clone(),
            Source::Pattern(pat) => {
                let m: Vec<String> = names.iter().filter(|n| matches(pat, n)).cloned().collect();
                if m.is_empty() {
                    return Err(DatasetError::MappedColumnMissing {
                        file: file.to_path_buf(),
                        role: e.role.clone(),
                        column: pat.clone(),
                        present: present().into(),
                    });
                }
                m
            }
        };
        for s in &sources {
            if !names.contains(s) {
                return Err(DatasetError::MappedColumnMissing {
                    file: file.to_path_buf(),
                    role: e.role.clone(),
                    column: s.clone(),
                    present: present().into(),
                });
            }
            if let Some((other, _)) = used.iter().find(|(_, c)| c == s) {
                p.notes.push(format!(
                    "column `{s}` is read both as `{other}` and as `{}` (--columns)",
                    e.role
                ));
            }
            used.push((e.role.clone(), s.clone()));
            match (unit_suffix(&e.role), unit_suffix(s)) {
                (Some(want), Some(got)) if want != got => {
                    return Err(DatasetError::UnitMismatch {
                        file: file.to_path_buf(),
                        role: e.role.clone(),
                        column: s.clone(),
                        units: format!("{want} but column `{s}` is in {got}").into(),
                    });
                }
                (Some(want), None) => p.notes.push(format!(
                    "column `{s}` has no unit suffix: read as `{}` in {want} (--columns)",
                    e.role
                )),
                _ => {}
            }
        }
        let columns = if sources.len() == 1 {
            p.renames.push((sources[0].clone(), e.role.clone()));
            vec![e.role.clone()]
        } else {
            sources.clone()
        };
        p.groups.push(RoleGroup {
            role: e.role.clone(),
            sources,
            columns,
        });
    }
    // a file column that carries a role's name but is not its source is shadowed by the mapping
    for g in &p.groups {
        if g.columns == [g.role.clone()] && names.contains(&g.role) && !g.sources.contains(&g.role)
        {
            p.shadowed.push(g.role.clone());
            p.notes.push(format!(
                "the file's own column `{}` is replaced by the mapping {}={}",
                g.role,
                g.role,
                g.sources.join("+")
            ));
        }
    }
    Ok(p)
}

/// Applies `map` to a table already read (e.g. embedded data): see [`read_any_mapped`].
///
/// # Errors
/// As [`read_any_mapped`], without the reading errors.
pub fn map_table(table: Table, map: &ColumnMap) -> Result<MappedTable, DatasetError> {
    let file = std::path::PathBuf::from(&table.origin);
    let names: Vec<String> = table.names().iter().map(|s| s.to_string()).collect();
    let p = plan(map, &file, &names)?;
    let n = table.n_rows();
    let originals = table.columns;
    let mut columns: Vec<Column> = originals
        .iter()
        .filter(|c| !p.shadowed.contains(&c.name))
        .map(|c| {
            let mut c = c.clone();
            if let Some((_, new)) = p.renames.iter().find(|(old, _)| *old == c.name) {
                c.name = new.clone();
            }
            c
        })
        .collect();
    // a column read under a second role is copied
    for (k, (old, new)) in p.renames.iter().enumerate() {
        if p.renames[..k].iter().any(|(o, _)| o == old) {
            if let Some(c) = originals.iter().find(|c| &c.name == old) {
                columns.push(Column {
                    name: new.clone(),
                    data: c.data.clone(),
                });
            }
        }
    }
    for (role, x) in &p.constants {
        columns.retain(|c| &c.name != role);
        columns.push(Column {
            name: role.clone(),
            data: ColumnData::Float(vec![*x; n]),
        });
    }
    let mut mapped = Table::from_columns(&table.origin, columns)?;
    mapped.ignored_columns = table.ignored_columns;
    Ok(MappedTable {
        table: mapped,
        groups: p.groups,
        notes: p.notes,
    })
}

/// Reads `path` (CSV or Parquet, every column typed as [`read_any`] does) and applies `map`.
///
/// # Errors
/// Those of [`read_any`]; [`DatasetError::MappedColumnMissing`] for a mapped column (or pattern)
/// the file does not have, listing the columns it has; [`DatasetError::UnitMismatch`] naming the
/// role, the column and both units.
pub fn read_any_mapped(path: &Path, map: &ColumnMap) -> Result<MappedTable, DatasetError> {
    map_table(read_any(path)?, map)
}

/// Reads `path` against `schema` after renaming its columns by `map` (a role must map exactly one
/// column or a constant here: a schema names single columns). Returns the table and the notes.
///
/// # Errors
/// Those of [`read_table`](crate::read_table) (named by the role, with the file column in the
/// notes), of [`read_any_mapped`], and [`DatasetError::BadColumnMap`] for a role mapped to several
/// columns.
pub fn read_table_mapped(
    path: &Path,
    schema: &Schema,
    map: &ColumnMap,
) -> Result<(Table, Vec<String>), DatasetError> {
    let mut notes = Vec::new();
    let table = read_table_renamed(path, schema, |names| {
        let p = plan(map, path, names)?;
        if let Some(g) = p.groups.iter().find(|g| g.columns.len() > 1) {
            return Err(bad_map(
                &format!("{}={}", g.role, g.sources.join("+")),
                format!(
                    "`{}` takes one column in the `{}` schema, not {}",
                    g.role,
                    schema.name,
                    g.sources.len()
                ),
            ));
        }
        notes = p.notes.clone();
        Ok((p.renames, p.constants, p.shadowed))
    })?;
    Ok((table, notes))
}

/// Joins `right` onto `left` by the numeric column `key` both have: every row of `left` takes the
/// columns of the row of `right` with the same key (e.g. the flank wear of cut 17 beside its forces).
/// Columns of `right` whose name `left` already has are not repeated (a note lists them). Returns the
/// joined table (named after `left`) and the notes.
///
/// # Errors
/// [`DatasetError::NoSuchColumn`] / [`DatasetError::WrongColumnType`] for a missing or non-numeric
/// key; [`DatasetError::Invalid`] naming the left file, the key and the 1-based row whose key the
/// right file does not have (or has twice).
pub fn join_on(
    left: &Table,
    right: &Table,
    key: &str,
) -> Result<(Table, Vec<String>), DatasetError> {
    let lk = left.f64s(key)?;
    let rk = right.f64s(key)?;
    let mut index = std::collections::BTreeMap::new();
    for (i, k) in rk.iter().enumerate() {
        if index.insert(k.to_bits(), i).is_some() {
            return Err(DatasetError::Invalid {
                file: right.origin.clone().into(),
                column: key.into(),
                row: i + 1,
                message: format!("key {k} appears twice: cannot join on it"),
            });
        }
    }
    let rows: Vec<usize> = lk
        .iter()
        .enumerate()
        .map(|(i, k)| {
            index
                .get(&k.to_bits())
                .copied()
                .ok_or_else(|| DatasetError::Invalid {
                    file: left.origin.clone().into(),
                    column: key.into(),
                    row: i + 1,
                    message: format!("key {k} is not in {}", right.origin),
                })
        })
        .collect::<Result<_, _>>()?;
    let mut columns = left.columns.clone();
    let mut repeated = Vec::new();
    for c in &right.columns {
        if left.column(&c.name).is_some() {
            if c.name != key {
                repeated.push(c.name.clone());
            }
            continue;
        }
        let data = match &c.data {
            ColumnData::Float(v) => ColumnData::Float(rows.iter().map(|&r| v[r]).collect()),
            ColumnData::Int(v) => ColumnData::Int(rows.iter().map(|&r| v[r]).collect()),
            ColumnData::Text(v) => ColumnData::Text(rows.iter().map(|&r| v[r].clone()).collect()),
        };
        columns.push(Column {
            name: c.name.clone(),
            data,
        });
    }
    let mut notes = vec![format!(
        "joined {} onto {} by `{key}` ({} rows)",
        right.origin,
        left.origin,
        rows.len()
    )];
    if !repeated.is_empty() {
        notes.push(format!(
            "columns of {} also in {} kept from the latter: {}",
            right.origin,
            left.origin,
            repeated.join(", ")
        ));
    }
    Ok((Table::from_columns(&left.origin, columns)?, notes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(names: &[&str]) -> Table {
        Table::from_columns(
            "rec.csv",
            names
                .iter()
                .enumerate()
                .map(|(i, n)| Column {
                    name: n.to_string(),
                    data: ColumnData::Float(vec![i as f64, i as f64 + 1.0]),
                })
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn parse_forms_and_errors() {
        let m = ColumnMap::parse("t_s=time_s, temp_c=a_C+b_C,drift_um=disp_*_um,speed_rpm=10400")
            .unwrap();
        assert_eq!(m.entries.len(), 4);
        assert_eq!(
            m.entries[1].source,
            Source::List(vec!["a_C".into(), "b_C".into()])
        );
        assert_eq!(m.entries[3].source, Source::Constant(10400.0));
        for bad in ["t_s", "t_s=", "=x", "t_s=a,t_s=b", "t s=a", "x=a++b"] {
            let e = ColumnMap::parse(bad).unwrap_err();
            assert!(matches!(e, DatasetError::BadColumnMap { .. }), "{bad}: {e}");
        }
    }

    #[test]
    fn patterns_match_whole_names_in_file_order() {
        assert!(matches("temp_t*_C", "temp_t10_C"));
        assert!(!matches("temp_t*_C", "temp_t10_K"));
        assert!(matches("disp_*_um", "disp_ch1_um"));
        assert!(matches("*", "anything"));
        assert!(!matches("a*b*c", "acb"));
        let m = map_table(
            table(&["time_s", "temp_t2_C", "x", "temp_t1_C"]),
            &ColumnMap::parse("temp_c=temp_t*_C").unwrap(),
        )
        .unwrap();
        assert_eq!(
            m.group("temp_c").unwrap().sources,
            ["temp_t2_C", "temp_t1_C"]
        );
    }

    #[test]
    fn renames_constants_units_and_shadowing() {
        let m = map_table(
            table(&["time_s", "t_s", "force_x__rms"]),
            &ColumnMap::parse("t_s=time_s,force_n=force_x__rms,speed_rpm=10400").unwrap(),
        )
        .unwrap();
        assert_eq!(m.table.names(), ["t_s", "force_n", "speed_rpm"]);
        assert_eq!(m.table.f64s("t_s").unwrap(), [0.0, 1.0]);
        assert_eq!(m.table.f64s("speed_rpm").unwrap(), [10400.0; 2]);
        assert!(
            m.notes
                .iter()
                .any(|n| n.contains("`force_x__rms` has no unit suffix"))
        );
        assert!(
            m.notes
                .iter()
                .any(|n| n.contains("own column `t_s` is replaced"))
        );
        assert_eq!(m.describe("t_s"), "`t_s` (file column `time_s`)");
        assert_eq!(m.file_column("force_n"), "force_x__rms");
        let e = map_table(
            table(&["time_s", "f_N"]),
            &ColumnMap::parse("drift_um=f_N").unwrap(),
        )
        .unwrap_err();
        assert!(
            matches!(e, DatasetError::UnitMismatch { ref units, .. } if &**units == "um but column `f_N` is in n"),
            "{e}"
        );
        // one column under two roles: both read it
        let m = map_table(
            table(&["a_s"]),
            &ColumnMap::parse("t_s=a_s,u_s=a_s").unwrap(),
        )
        .unwrap();
        assert_eq!(m.table.f64s("u_s").unwrap(), m.table.f64s("t_s").unwrap());
        assert!(
            m.notes
                .iter()
                .any(|n| n.contains("read both as `t_s` and as `u_s`"))
        );
    }

    #[test]
    fn join_by_key_and_a_missing_key() {
        let l = Table::from_columns(
            "f.csv",
            vec![
                Column {
                    name: "run".into(),
                    data: ColumnData::Float(vec![1.0, 2.0, 3.0]),
                },
                Column {
                    name: "fx".into(),
                    data: ColumnData::Float(vec![0.1, 0.2, 0.3]),
                },
            ],
        )
        .unwrap();
        let r = Table::from_columns(
            "w.csv",
            vec![
                Column {
                    name: "run".into(),
                    data: ColumnData::Float(vec![3.0, 2.0, 1.0]),
                },
                Column {
                    name: "vb_um".into(),
                    data: ColumnData::Float(vec![30.0, 20.0, 10.0]),
                },
            ],
        )
        .unwrap();
        let (j, notes) = join_on(&l, &r, "run").unwrap();
        assert_eq!(j.f64s("vb_um").unwrap(), [10.0, 20.0, 30.0]);
        assert!(notes[0].contains("by `run`"));
        let short = Table::from_columns(
            "w.csv",
            vec![Column {
                name: "run".into(),
                data: ColumnData::Float(vec![1.0, 2.0]),
            }],
        )
        .unwrap();
        let e = join_on(&l, &short, "run").unwrap_err().to_string();
        assert!(
            e.contains("f.csv") && e.contains("row 3") && e.contains("key 3"),
            "{e}"
        );
    }

    #[test]
    fn time_going_backwards_names_the_file_column_and_row() {
        let t = Table::from_columns(
            "rec.csv",
            vec![Column {
                name: "time_s".into(),
                data: ColumnData::Float(vec![0.0, 15.0, 30.0, 20.0]),
            }],
        )
        .unwrap();
        let m = map_table(t, &ColumnMap::parse("t_s=time_s").unwrap()).unwrap();
        let e = m.strictly_increasing("t_s").unwrap_err().to_string();
        assert!(
            e.contains("rec.csv") && e.contains("time_s") && e.contains("row 4"),
            "{e}"
        );
    }
}
