//! Tables as aligned plain text (what `datasets list` and `datasets show` print). The tables, their cells
//! and the cells' display text are `millcomp-datasets`' data; the layout is here.

use std::fmt::Write as _;

use millcomp_datasets::{ColumnData, Dataset, Table};

/// `datasets list`: the published tables, the real measured records and the synthetic runs, each under
/// its own heading so that none is mistaken for another.
pub fn dataset_sections_text(
    published: &[(&Dataset, usize)],
    real: &[(&millcomp_datasets::real::RealRecord, usize)],
    synthetic: &[millcomp_datasets::synthetic_runs::SyntheticRun],
) -> String {
    let width = published
        .iter()
        .map(|(d, _)| d.name.len())
        .chain(real.iter().map(|(r, _)| r.name.len()))
        .chain(synthetic.iter().map(|s| s.name.len()))
        .max()
        .unwrap_or(0);
    let mut s = String::from("published tables (the seed documents' figures, datasets/data/)\n");
    for (d, n) in published {
        let _ = writeln!(s, "{:<width$}  {:>5} rows  {}", d.name, n, d.title);
    }
    s.push_str("\nREAL measured records (measured on real machines by others, datasets/real/)\n");
    for (r, n) in real {
        let _ = writeln!(s, "{:<width$}  {:>5} rows  {}", r.name, n, r.title);
    }
    s.push_str(
        "\nsynthetic runs (made by millcomp's seeded generators, datasets/synthetic/ and datasets/runs/)\n",
    );
    for r in synthetic {
        let _ = writeln!(s, "{:<width$}  {:>5} rows  {}", r.name, r.n_rows(), r.title);
    }
    s
}

/// A real record: its provenance, then its first `head` rows.
pub fn real_record_text(
    r: &millcomp_datasets::real::RealRecord,
    table: &Table,
    head: usize,
) -> String {
    let shown = Table::from_columns(
        &table.origin,
        table
            .columns
            .iter()
            .map(|c| millcomp_datasets::Column {
                name: c.name.clone(),
                data: match &c.data {
                    ColumnData::Float(v) => {
                        ColumnData::Float(v.iter().take(head).copied().collect())
                    }
                    ColumnData::Int(v) => ColumnData::Int(v.iter().take(head).copied().collect()),
                    ColumnData::Text(v) => ColumnData::Text(v.iter().take(head).cloned().collect()),
                },
            })
            .collect(),
    )
    .unwrap_or_else(|_| table.clone());
    format!(
        "{} — {} (REAL measured record)\nfile: {}\nsource: {}\nlicence: {}\nunits: {}\nsha256: {}\n{} rows, {} columns; the first {}:\n\n{}",
        r.name,
        r.title,
        r.path(),
        r.source,
        r.licence,
        r.units,
        r.sha256,
        table.n_rows(),
        table.columns.len(),
        head.min(table.n_rows()),
        table_text(&shown)
    )
}

/// A shipped dataset: its name and title, the seed document it comes from, then the whole table.
pub fn dataset_text(d: &Dataset, table: &Table) -> String {
    format!(
        "{} — {}\nsource: {}\n\n{}",
        d.name,
        d.title,
        d.seed,
        table_text(table)
    )
}

/// The whole table (no truncation): the header, a rule of dashes, one line per row. Numeric columns are
/// right-aligned, text columns left-aligned, columns are two spaces apart and lines carry no trailing
/// spaces.
pub fn table_text(table: &Table) -> String {
    let headers: Vec<String> = table.columns.iter().map(|c| c.name.clone()).collect();
    let cells: Vec<Vec<String>> = (0..table.n_rows())
        .map(|i| table.columns.iter().map(|c| c.data.display(i)).collect())
        .collect();
    let mut widths: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for row in &cells {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let numeric: Vec<bool> = table
        .columns
        .iter()
        .map(|c| !matches!(c.data, ColumnData::Text(_)))
        .collect();
    let line = |row: &[String]| -> String {
        let parts: Vec<String> = row
            .iter()
            .zip(&widths)
            .zip(&numeric)
            .map(|((cell, &w), &num)| {
                if num {
                    format!("{cell:>w$}")
                } else {
                    format!("{cell:<w$}")
                }
            })
            .collect();
        parts.join("  ").trim_end().to_string()
    };
    let mut out = line(&headers);
    out.push('\n');
    let rule: Vec<String> = widths.iter().map(|&w| "-".repeat(w)).collect();
    out.push_str(&rule.join("  "));
    out.push('\n');
    for row in &cells {
        out.push_str(&line(row));
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_datasets::{ColumnKind, ColumnSpec, Schema, read_csv_str};

    #[test]
    fn numbers_right_text_left_no_trailing_spaces() {
        let schema = Schema::new(
            "t",
            vec![
                ColumnSpec::required("material", ColumnKind::Text, "m"),
                ColumnSpec::required("depth_um", ColumnKind::Float, "d"),
                ColumnSpec::required("n", ColumnKind::Int, "n"),
                ColumnSpec::required("note", ColumnKind::Text, "note"),
            ],
        );
        let t = read_csv_str(
            "mem.csv",
            "material,depth_um,n,note\nS7,100.5,2,a\n6061,20,10,\n",
            &schema,
        )
        .unwrap();
        assert_eq!(
            table_text(&t),
            "material  depth_um   n  note\n\
             --------  --------  --  ----\n\
             S7           100.5   2  a\n\
             6061            20  10\n"
        );
    }

    #[test]
    fn shipped_dataset_as_text() {
        // 000_…txt Table 3-3 trial 1 (Clayton thesis): 200 µm, 10 000 rpm, 20 µm/rev, max X force 3.34 N;
        // the line as `millcomp datasets show clayton_doe` prints it (README command `datasets-show`).
        let t = table_text(&millcomp_datasets::load("clayton_doe").unwrap());
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 2 + 8);
        assert!(
            lines[0].starts_with("trial  depth_um  speed_rpm  upfeed_um  max_fx_n"),
            "{t}"
        );
        assert!(
            lines[2].starts_with("    1       200      10000         20      3.34"),
            "{t}"
        );
    }

    #[test]
    fn dataset_list_and_header() {
        // The first lines of the README commands `datasets-list` and `datasets-show` as printed before
        // the layout moved here (the 8 trials of 000_…txt Table 3-3, 3 materials of Table 3-1).
        let d = millcomp_datasets::dataset("clayton_doe").unwrap();
        let t = dataset_text(d, &d.load().unwrap());
        assert!(
            t.starts_with(
                "clayton_doe — 2^3 DOE in 6061: depth, speed, upfeed and the max X/Y/Z force per trial\n\
                 source: 000_367e180efde69d0c.txt (Clayton, Force modeling and deflection compensation of \
                 miniature ball end mills)\n\ntrial  depth_um"
            ),
            "{t}"
        );
        let materials = millcomp_datasets::dataset("clayton_material_properties").unwrap();
        let list = dataset_sections_text(&[(d, 8), (materials, 3)], &[], &[]);
        assert!(
            list.starts_with(
                "published tables (the seed documents' figures, datasets/data/)\n\
                 clayton_doe                      8 rows  2^3 DOE in 6061: depth, speed, upfeed and the max \
                 X/Y/Z force per trial\n\
                 clayton_material_properties      3 rows  Hardness, modulus, strength and elongation of S7, \
                 1018 and 6061\n\nREAL measured records"
            ),
            "{list}"
        );
    }
}
