//! Several units in one `identify` (issue 50, "across tools"): the files of one run (FILE, each
//! `--also`, each with its `--join`), and the unit of each row — the `unit` column when the mapping
//! names one (`--columns unit=case`), else the file.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use millcomp_datasets::mapping::MappedTable;
use millcomp_datasets::{Column, ColumnData};
use millcomp_identify::units::{MetaOptions, Tau2Method, UNIT_ROLE, group_rows, label_of};

use crate::cli::IdentifyArgs;
use crate::cmd::record::{InputInfo, read_mapped_full};

/// One input file of a run, read through `--columns` (and joined to its `--join` file).
pub struct FileIn {
    /// The file.
    pub path: PathBuf,
    /// Its identity (hash, provenance).
    pub info: InputInfo,
    /// The file joined onto it, if any.
    pub joined: Option<InputInfo>,
    /// The mapped table.
    pub m: MappedTable,
}

/// The rows of one unit in one file.
pub struct UnitRows {
    /// The unit's label.
    pub unit: String,
    /// Index of its file in the run's files.
    pub file: usize,
    /// Its rows in that file (0-based).
    pub rows: Vec<usize>,
}

/// The meta-analysis options of `--tau2`.
pub fn meta_options(args: &IdentifyArgs) -> anyhow::Result<MetaOptions> {
    Ok(MetaOptions {
        tau2: Tau2Method::parse(&args.tau2).context("--tau2")?,
    })
}

/// FILE and each `--also`, each joined to its `--join` (one per file, in order) on `--on`.
pub fn read_files(args: &IdentifyArgs) -> anyhow::Result<Vec<FileIn>> {
    let mut paths = vec![args.file.clone()];
    paths.extend(args.also.iter().cloned());
    if !args.join.is_empty() && args.join.len() != paths.len() {
        bail!(
            "--join: {} file(s) for {} input file(s): give one --join per file, in order (FILE's first, then each --also's)",
            args.join.len(),
            paths.len()
        );
    }
    let mut out = Vec::with_capacity(paths.len());
    for (i, path) in paths.into_iter().enumerate() {
        let join = args.join.get(i).map(PathBuf::as_path);
        let on = args.on.as_deref().unwrap_or_default();
        // the table first: its reader names a directory, a missing file or a bad cell plainly; the
        // hashes (provenance) only of files it could read
        let mut m = read_mapped_full(&path, join.map(|j| (j, on)), args.columns.as_deref())?;
        let info = InputInfo::of(&path)?;
        let joined = join.map(InputInfo::of).transpose()?;
        keep_unit_source(&mut m);
        out.push(FileIn {
            path,
            info,
            joined,
            m,
        });
    }
    Ok(out)
}

/// `--columns unit=part` renames the file's `part` to `unit`; a target that reads `part` itself (the
/// part target) still finds it: the source column is put back beside the unit.
fn keep_unit_source(m: &mut MappedTable) {
    let Some(g) = m.group(UNIT_ROLE) else { return };
    let [src] = g.sources.as_slice() else { return };
    if src == UNIT_ROLE || m.table.column(src).is_some() {
        return;
    }
    if let Some(c) = m.table.column(UNIT_ROLE) {
        let copy = Column {
            name: src.clone(),
            data: c.data.clone(),
        };
        m.table.columns.push(copy);
    }
}

/// The unit column's file name and the unit of each row, when the mapped table has a `unit` column.
///
/// # Errors
/// `unit` mapped to several columns; a non-finite numeric unit (naming the file, column and row).
pub fn unit_labels(m: &MappedTable) -> anyhow::Result<Option<(String, Vec<String>)>> {
    let Some(g) = m.group(UNIT_ROLE) else {
        return Ok(None);
    };
    if g.columns.len() != 1 {
        bail!(
            "{}: --columns unit={}: `unit` takes one column (the tool, part or machine of each row), not {}",
            m.table.origin,
            g.sources.join("+"),
            g.columns.len()
        );
    }
    let c = m
        .table
        .column(&g.columns[0])
        .with_context(|| format!("{}: no column `{}`", m.table.origin, g.columns[0]))?;
    let labels = match &c.data {
        ColumnData::Text(v) => {
            if let Some(row) = v.iter().position(|x| x.trim().is_empty()) {
                bail!(
                    "{}: column `{}` read as `unit`, row {}: the cell is empty — every row needs its unit (tool, part or machine)",
                    m.table.origin,
                    g.sources[0],
                    row + 1
                );
            }
            v.clone()
        }
        ColumnData::Int(v) => v.iter().map(|x| x.to_string()).collect(),
        ColumnData::Float(v) => {
            if let Some(row) = v.iter().position(|x| !x.is_finite()) {
                bail!(
                    "{}: column `{}` read as `unit`, row {}: {} is not a unit label",
                    m.table.origin,
                    g.sources[0],
                    row + 1,
                    v[row]
                );
            }
            v.iter().map(|x| label_of(*x)).collect()
        }
    };
    Ok(Some((g.sources[0].clone(), labels)))
}

/// The file's name without its extension: the unit of a file without a unit column.
pub fn file_unit(path: &Path) -> String {
    path.file_stem().map_or_else(
        || path.display().to_string(),
        |s| s.to_string_lossy().into(),
    )
}

/// The units of a run: the unit column's values file by file, else one unit per file. Returns the
/// unit column's name in the files (`None`: the files are the units) and the units in order of first
/// appearance.
///
/// # Errors
/// Those of [`unit_labels`]; a unit found in two files; some files with a unit column and some without.
pub fn units_of(files: &[FileIn]) -> anyhow::Result<(Option<String>, Vec<UnitRows>)> {
    let labels: Vec<Option<(String, Vec<String>)>> = files
        .iter()
        .map(|f| unit_labels(&f.m))
        .collect::<anyhow::Result<_>>()?;
    let with = labels.iter().filter(|l| l.is_some()).count();
    if with != 0 && with != files.len() {
        bail!(
            "--columns unit=…: some files have the unit column and some do not; map it in every file, or in none (then each file is one unit)"
        );
    }
    let mut out: Vec<UnitRows> = Vec::new();
    let mut column = None;
    for (i, (f, l)) in files.iter().zip(labels).enumerate() {
        let groups = match l {
            Some((col, labels)) => {
                column = Some(col);
                group_rows(&labels)
            }
            None => vec![(file_unit(&f.path), (0..f.m.table.n_rows()).collect())],
        };
        for (unit, rows) in groups {
            if let Some(prev) = out.iter().find(|u| u.unit == unit) {
                bail!(
                    "unit `{unit}` is in {} and in {}: a unit's rows must come from one file (name the units apart)",
                    files[prev.file].path.display(),
                    f.path.display()
                );
            }
            out.push(UnitRows {
                unit,
                file: i,
                rows,
            });
        }
    }
    Ok((column, out))
}

/// `values` at `rows`.
pub fn take(values: &[f64], rows: &[usize]) -> Vec<f64> {
    rows.iter().map(|&i| values[i]).collect()
}
