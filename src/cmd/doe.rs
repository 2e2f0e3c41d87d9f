//! `millcomp doe design|analyze`: the CLI glue around `millcomp-doe`; tables in and out through
//! `millcomp-datasets` (polars), written atomically.

use std::path::Path;

use anyhow::{Context, bail};
use millcomp_doe::{AnalyzeOptions, AnalyzeOutcome, DesignOptions, DesignRequest};

use crate::cli::{DoeAnalyzeArgs, DoeCommand, DoeDesignArgs};
use crate::cmd::guard::Inputs;
use crate::cmd::print_json;

pub fn run(cmd: DoeCommand, json: bool) -> anyhow::Result<()> {
    match cmd {
        DoeCommand::Design(args) => design(&args, json),
        DoeCommand::Analyze(args) => analyze(&args, json),
    }
}

/// The design request of `doe design` arguments (also used by `batch --doe`): the library's
/// [`DesignOptions`] (one place, shared with the Python package).
pub fn design_request(args: &DoeDesignArgs) -> anyhow::Result<DesignRequest> {
    let options = DesignOptions {
        design: args.design.clone(),
        factors: args.factors.clone(),
        resolution: args.resolution,
        generators: args.generators.clone(),
        runs: args.runs,
        replicates: args.replicates,
        center_points: args.center_points,
        blocks: args.blocks,
        seed: args.seed,
        randomize: !args.no_randomize,
        ccd_variant: args.ccd_variant.clone(),
        alpha: args.alpha.clone(),
        model: args.model.clone(),
        constraints: args.constraints.clone(),
    };
    Ok(options.request()?)
}

fn design(args: &DoeDesignArgs, json: bool) -> anyhow::Result<()> {
    let req = design_request(args)?;
    let design = millcomp_doe::generate(&req)?;
    // everything that is printed is made before anything is written: a failure leaves no file
    let report = if json {
        serde_json::to_string_pretty(&design)?
    } else {
        crate::present::doe::design_text(&design)
    };
    if let Some(out) = &args.out {
        let table = millcomp_datasets::adapters::table_from_doe("design", design.columns())?;
        millcomp_datasets::write_table(&table, out)
            .with_context(|| format!("writing the design to {}", out.display()))?;
    }
    if json {
        println!("{report}");
    } else {
        print!("{report}");
        if let Some(out) = &args.out {
            println!("\nwritten: {}", out.display());
        }
    }
    Ok(())
}

/// A fit whose numbers are not finite is refused where it is made, before it is printed as a table of
/// `inf` or saved as a model that would drive a controller: the first non-finite quantity is named.
fn check_finite(a: &millcomp_doe::Analysis, file: &Path) -> anyhow::Result<()> {
    let mut checks: Vec<(String, f64)> = vec![
        ("the residual sum of squares".into(), a.residual_sum_sq),
        ("R²".into(), a.r_squared),
    ];
    if let Some(s) = a.sigma {
        checks.push(("S".into(), s));
    }
    for t in &a.terms {
        checks.push((format!("the sum of squares of `{}`", t.term), t.sum_sq));
        if let Some(c) = t.coef {
            checks.push((format!("the coefficient of `{}`", t.term), c));
        }
    }
    for c in &a.coefficients {
        checks.push((format!("the coefficient `{}`", c.name), c.coef));
        if let Some(se) = c.std_err {
            checks.push((format!("the standard error of `{}`", c.name), se));
        }
    }
    let Some((what, v)) = checks.into_iter().find(|(_, v)| !v.is_finite()) else {
        return Ok(());
    };
    if a.r_squared.is_nan() && a.residual_sum_sq == 0.0 {
        bail!(
            "{}: `{}` has the same value in every run: there is no effect to analyse",
            file.display(),
            a.response
        );
    }
    bail!(
        "{}: the fit of `{}` is not finite ({what} = {v}): its values are too large to square in double \
         precision; rescale the column (another unit) and analyse again",
        file.display(),
        a.response
    )
}

fn analyze(args: &DoeAnalyzeArgs, json: bool) -> anyhow::Result<()> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        bail!("--alpha must be in (0, 1), got {}", args.alpha);
    }
    let inputs = Inputs::new().add("FILE", &args.file);
    inputs.check_opt("--save", args.save.as_deref())?;
    if let Some(dir) = &args.plots {
        inputs.check_dir("--plots", dir, |rel| {
            crate::present::doe::DOE_PLOTS
                .iter()
                .any(|n| rel == Path::new(n))
        })?;
    }
    let (table, notes) = crate::cmd::record::read_mapped(&args.file, args.columns.as_deref())?;
    for n in &notes {
        eprintln!("note: {}: {n}", args.file.display());
    }
    let columns = millcomp_datasets::adapters::doe_columns(&table);
    let options = AnalyzeOptions {
        response: args.response.clone(),
        factors: Some(args.factors.clone()),
        model: args.model.clone(),
        alpha: args.alpha,
        reduce: args.reduce,
    };
    let AnalyzeOutcome {
        analysis,
        elimination,
    } = options.run(&args.file.display().to_string(), &columns)?;
    check_finite(&analysis, &args.file)?;
    if let Some(path) = &args.save {
        save_model(&analysis, &args.file, path)?;
    }
    let plots = match &args.plots {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("creating plot directory {}", dir.display()))?;
            crate::present::doe::write_doe_plots(&analysis, dir)
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
        print!("{}", crate::present::doe::elimination_text(&e.steps));
    }
    print!("{}", crate::present::doe::analysis_text(&analysis));
    for p in &plots {
        println!("plot: {}", p.display());
    }
    if let Some(path) = &args.save {
        println!("model: {}", path.display());
    }
    Ok(())
}

/// Saves the response surface of the analysis in the common model-file format (atomic: a failure leaves
/// nothing behind), with the data file and its SHA-256 as provenance.
fn save_model(analysis: &millcomp_doe::Analysis, input: &Path, path: &Path) -> anyhow::Result<()> {
    let surface = millcomp_doe::response_surface(analysis)?;
    let inputs = vec![millcomp_models::InputFile::from_path(input)?];
    millcomp_models::ModelFile::new("response_surface", surface, crate::cmd::provenance(inputs))
        .save(path)?;
    Ok(())
}
