//! `millcomp datasets list|show|check|figures`.

use anyhow::Context;
use serde_json::json;

use crate::cli::DatasetsCommand;
use crate::cmd::print_json;

pub fn run(cmd: DatasetsCommand, json: bool) -> anyhow::Result<()> {
    match cmd {
        DatasetsCommand::List => list(json),
        DatasetsCommand::Show(args) => show(&args.name, json),
        DatasetsCommand::Check(args) => {
            check(&args.file, &args.schema, args.columns.as_deref(), json)
        }
        DatasetsCommand::Figures(args) => figures(args.markdown, json),
    }
}

/// The published figures, computed now (the simulations take a few seconds: on a terminal, each
/// figure's name on stderr as it is computed).
fn figures(markdown: bool, json: bool) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    if markdown && json {
        anyhow::bail!("--markdown and --json: choose one");
    }
    let tty = std::io::stderr().is_terminal();
    let figs = millcomp_closedloop::figures::published_figures(&|name| {
        if tty {
            eprintln!("figures: {name}");
        }
    })?;
    if json {
        return print_json(&figs);
    }
    if markdown {
        print!("{}", crate::present::figures::markdown(&figs));
    } else {
        print!("{}", crate::present::figures::text(&figs));
    }
    Ok(())
}

fn check(
    file: &std::path::Path,
    schema: &str,
    columns: Option<&str>,
    json: bool,
) -> anyhow::Result<()> {
    let map = columns
        .map(millcomp_datasets::mapping::ColumnMap::parse)
        .transpose()?;
    let (table, notes) = if schema == "measured-groove" || schema == "measured_groove" {
        match &map {
            Some(m) => millcomp_datasets::contracts::read_measured_groove_table_mapped(file, m)?,
            None => (
                millcomp_datasets::contracts::read_measured_groove_table(file)?,
                Vec::new(),
            ),
        }
    } else {
        let d = millcomp_datasets::dataset(schema)
            .context("--as takes `measured-groove` or a dataset name")?;
        match &map {
            Some(m) => millcomp_datasets::mapping::read_table_mapped(file, &d.schema(), m)?,
            None => (
                millcomp_datasets::read_table(file, &d.schema())?,
                Vec::new(),
            ),
        }
    };
    for n in table.notes.iter().chain(&notes) {
        eprintln!("note: {}: {n}", file.display());
    }
    if json {
        return print_json(&json!({
            "file": file.display().to_string(),
            "schema": schema,
            "valid": true,
            "n_rows": table.n_rows(),
            "columns": table.names(),
            "ignored_columns": table.ignored_columns,
        }));
    }
    println!(
        "{}: valid {schema} table, {} rows, columns: {}",
        file.display(),
        table.n_rows(),
        table.names().join(", ")
    );
    for c in &table.ignored_columns {
        println!("note: unknown column `{c}` ignored");
    }
    Ok(())
}

fn list(json: bool) -> anyhow::Result<()> {
    let mut rows = Vec::new();
    for d in millcomp_datasets::DATASETS {
        let table = d
            .load()
            .with_context(|| format!("loading dataset `{}`", d.name))?;
        rows.push((d, table.n_rows()));
    }
    let mut real = Vec::new();
    for r in millcomp_datasets::real::REAL_RECORDS {
        let table = r
            .load()
            .with_context(|| format!("loading real record `{}`", r.name))?;
        real.push((r, table.n_rows()));
    }
    let synthetic = millcomp_datasets::synthetic_runs::SYNTHETIC_RUNS;
    if json {
        let mut docs: Vec<_> = rows
            .iter()
            .map(|(d, n)| {
                json!({"name": d.name, "kind": "published", "file": format!("datasets/data/{}", d.file),
                       "title": d.title, "seed": d.seed, "n_rows": n})
            })
            .collect();
        docs.extend(real.iter().map(|(r, n)| {
            json!({"name": r.name, "kind": "real", "file": r.path(), "title": r.title,
                   "source": r.source, "licence": r.licence, "sha256": r.sha256, "n_rows": n})
        }));
        docs.extend(synthetic.iter().map(|s| {
            json!({"name": s.name, "kind": "synthetic", "file": format!("datasets/{}", s.file),
                   "title": s.title, "n_rows": s.n_rows()})
        }));
        return print_json(&docs);
    }
    print!(
        "{}",
        crate::present::table::dataset_sections_text(&rows, &real, synthetic)
    );
    Ok(())
}

fn show(name: &str, json: bool) -> anyhow::Result<()> {
    if let Ok(r) = millcomp_datasets::real::record(name) {
        let table = r.load()?;
        if json {
            let head: Vec<_> = table.to_json_rows().into_iter().take(10).collect();
            return print_json(&json!({
                "name": r.name, "kind": "real", "title": r.title, "file": r.path(),
                "source": r.source, "licence": r.licence, "units": r.units, "sha256": r.sha256,
                "columns": table.names(), "n_rows": table.n_rows(), "head": head,
            }));
        }
        print!("{}", crate::present::table::real_record_text(r, &table, 10));
        return Ok(());
    }
    let d = millcomp_datasets::dataset(name).map_err(|e| {
        anyhow::anyhow!(
            "{e}; real records: {}",
            millcomp_datasets::real::REAL_RECORDS
                .iter()
                .map(|r| r.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    let table = d.load()?;
    if json {
        let columns: Vec<_> = d
            .schema()
            .columns
            .iter()
            .map(|c| json!({"name": c.name, "kind": c.kind, "description": c.description}))
            .collect();
        return print_json(&json!({
            "name": d.name,
            "title": d.title,
            "file": format!("datasets/data/{}", d.file),
            "seed": d.seed,
            "columns": columns,
            "n_rows": table.n_rows(),
            "rows": table.to_json_rows(),
        }));
    }
    print!("{}", crate::present::table::dataset_text(d, &table));
    Ok(())
}
