//! `millcomp datasets list|show`.

use anyhow::Context;
use serde_json::json;

use crate::cli::DatasetsCommand;
use crate::cmd::print_json;

pub fn run(cmd: DatasetsCommand, json: bool) -> anyhow::Result<()> {
    match cmd {
        DatasetsCommand::List => list(json),
        DatasetsCommand::Show(args) => show(&args.name, json),
        DatasetsCommand::Check(args) => check(&args.file, &args.schema, json),
    }
}

fn check(file: &std::path::Path, schema: &str, json: bool) -> anyhow::Result<()> {
    let table = if schema == "measured-groove" || schema == "measured_groove" {
        millcomp_datasets::contracts::read_measured_groove_table(file)?
    } else {
        let d = millcomp_datasets::dataset(schema)
            .context("--as takes `measured-groove` or a dataset name")?;
        millcomp_datasets::read_table(file, &d.schema())?
    };
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
    if json {
        let docs: Vec<_> = rows
            .iter()
            .map(|(d, n)| {
                json!({"name": d.name, "file": format!("datasets/data/{}", d.file),
                       "title": d.title, "seed": d.seed, "n_rows": n})
            })
            .collect();
        return print_json(&docs);
    }
    print!("{}", crate::present::table::dataset_list_text(&rows));
    Ok(())
}

fn show(name: &str, json: bool) -> anyhow::Result<()> {
    let d = millcomp_datasets::dataset(name)?;
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
