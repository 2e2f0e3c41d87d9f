//! `millcomp doe design|analyze`: the CLI glue around `millcomp-doe`; tables in and out through
//! `millcomp-datasets` (polars), written atomically.

use std::path::Path;

use anyhow::{Context, bail};
use millcomp_datasets::{ColumnData, Table};
use millcomp_doe::{
    AnalysisInput, CcdAlpha, CcdVariant, Column, DesignKind, DesignRequest, FactorSpec,
    LinearConstraint, ModelSpec,
};

use crate::cli::{DoeAnalyzeArgs, DoeCommand, DoeDesignArgs};
use crate::cmd::print_json;

pub fn run(cmd: DoeCommand, json: bool) -> anyhow::Result<()> {
    match cmd {
        DoeCommand::Design(args) => design(&args, json),
        DoeCommand::Analyze(args) => analyze(&args, json),
    }
}

/// The design request of `doe design` arguments (also used by `batch --doe`).
pub fn design_request(args: &DoeDesignArgs) -> anyhow::Result<DesignRequest> {
    let factors = FactorSpec::parse_list(&args.factors).context("--factors")?;
    let mut kind: DesignKind = args.design.parse().context("--design")?;
    if let DesignKind::Ccd { variant, alpha } = &mut kind {
        if args.design == "ccd" {
            *variant = args
                .ccd_variant
                .parse::<CcdVariant>()
                .context("--ccd-variant")?;
        }
        *alpha = args.alpha.parse::<CcdAlpha>().context("--alpha")?;
    }
    let mut req = DesignRequest::new(kind, factors);
    req.resolution = args.resolution;
    req.generators = args.generators.clone();
    req.runs = args.runs;
    req.replicates = args.replicates;
    req.center_points = args.center_points;
    req.blocks = args.blocks;
    req.seed = args.seed;
    req.randomize = !args.no_randomize;
    if let Some(m) = &args.model {
        req.model = Some(ModelSpec::parse(m).context("--model")?);
    }
    if let Some(c) = &args.constraints {
        req.constraints = LinearConstraint::parse_list(c, &req.factors).context("--constraints")?;
    }
    Ok(req)
}

fn design(args: &DoeDesignArgs, json: bool) -> anyhow::Result<()> {
    let req = design_request(args)?;
    let design = millcomp_doe::generate(&req)?;
    if let Some(out) = &args.out {
        let table = table_from_doe("design", design.columns())?;
        millcomp_datasets::write_table(&table, out)
            .with_context(|| format!("writing the design to {}", out.display()))?;
    }
    if json {
        print_json(&design)
    } else {
        print!("{}", design.human());
        if let Some(out) = &args.out {
            println!("\nwritten: {}", out.display());
        }
        Ok(())
    }
}

fn analyze(args: &DoeAnalyzeArgs, json: bool) -> anyhow::Result<()> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        bail!("--alpha must be in (0, 1), got {}", args.alpha);
    }
    let table = millcomp_datasets::read_any(&args.file)?;
    let columns = doe_columns(&table);
    let model = ModelSpec::parse(&args.model).context("--model")?;
    let factors = (!args.factors.is_empty()).then_some(args.factors.as_slice());
    let input = AnalysisInput::from_table(&columns, &args.response, factors, model)
        .with_context(|| format!("{}: preparing the analysis", args.file.display()))?;
    let (analysis, elimination) = if args.reduce {
        let e = millcomp_doe::backward_eliminate(&input, args.alpha)
            .with_context(|| format!("{}: backward elimination", args.file.display()))?;
        (e.analysis.clone(), Some(e))
    } else {
        let a = millcomp_doe::analyze(&input)
            .with_context(|| format!("{}: analysing `{}`", args.file.display(), args.response))?;
        (a, None)
    };
    if let Some(path) = &args.save {
        save_model(&analysis, path)?;
    }
    let plots = match &args.plots {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("creating plot directory {}", dir.display()))?;
            millcomp_doe::write_plots(&analysis, dir)
                .with_context(|| format!("writing plots to {}", dir.display()))?
        }
        None => Vec::new(),
    };
    if json {
        let mut doc = serde_json::to_value(&analysis)?;
        if let Some(e) = &elimination {
            doc["elimination"] = serde_json::to_value(&e.steps)?;
        }
        return print_json(&doc);
    }
    if let Some(e) = &elimination {
        for step in &e.steps {
            println!(
                "removed {:<16} p = {}",
                step.removed,
                step.p_value.map_or("-".to_string(), |p| format!("{p:.4}"))
            );
        }
        println!();
    }
    print!("{}", analysis.human());
    for p in &plots {
        println!("plot: {}", p.display());
    }
    if let Some(path) = &args.save {
        println!("model: {}", path.display());
    }
    Ok(())
}

/// Saves the fitted model through a temporary file in the destination directory, so a failure
/// leaves nothing behind.
fn save_model(analysis: &millcomp_doe::Analysis, path: &Path) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".millcomp-")
        .suffix(".partial.toml")
        .tempfile_in(&dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    millcomp_doe::save_model_toml(analysis, tmp.path())
        .with_context(|| format!("writing the model to {}", path.display()))?;
    tmp.persist(path)
        .with_context(|| format!("moving the model into place at {}", path.display()))?;
    Ok(())
}

fn doe_columns(table: &Table) -> Vec<(String, Column)> {
    table
        .columns
        .iter()
        .map(|c| {
            let col = match &c.data {
                ColumnData::Float(v) => Column::F64(v.clone()),
                ColumnData::Int(v) => Column::I64(v.clone()),
                ColumnData::Text(v) => Column::Str(v.clone()),
            };
            (c.name.clone(), col)
        })
        .collect()
}

/// A design's columns (`Design::columns`) as a table for writing or for `batch`.
pub fn table_from_doe(origin: &str, columns: Vec<(String, Column)>) -> anyhow::Result<Table> {
    let cols = columns
        .into_iter()
        .map(|(name, c)| millcomp_datasets::Column {
            name,
            data: match c {
                Column::F64(v) => ColumnData::Float(v),
                Column::I64(v) => ColumnData::Int(v),
                Column::Str(v) => ColumnData::Text(v),
            },
        })
        .collect();
    Ok(Table::from_columns(origin, cols)?)
}
