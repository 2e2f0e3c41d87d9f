//! `millcomp diagnose SESSION MEASURED.csv`: find where the nominal model and the measurement
//! disagree, name the missing physical effect, add it and show the gap shrink
//! (`millcomp_identify::diagnose`). The measured CSV is validated against the DESIGN contract by
//! `millcomp-datasets` first, so errors name the file, column and row.

use anyhow::{Context, bail};
use millcomp_identify::diagnose::{DiagnoseOptions, ForceTrace, MeasuredGroove, diagnose};
use millcomp_sim::session::Session;

use crate::cli::DiagnoseArgs;
use crate::cmd::print_json;

pub fn run(args: DiagnoseArgs, json: bool) -> anyhow::Result<()> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        bail!("--alpha must be in (0, 1), got {}", args.alpha);
    }
    let session = Session::from_path(&args.session)
        .with_context(|| format!("reading session {}", args.session.display()))?;
    let file = millcomp_datasets::contracts::read_measured_groove(&args.measured)?;
    let mut measured =
        MeasuredGroove::from_points(&args.measured.display().to_string(), &file.points);
    if let Some(path) = &args.forces {
        measured.forces = Some(ForceTrace::from_path(path)?);
    }
    let options = DiagnoseOptions {
        alpha: args.alpha,
        candidates: (!args.candidates.is_empty()).then(|| args.candidates.clone()),
        free_offset: args.free_offset,
    };
    let report = diagnose(&session, &measured, &options).with_context(|| {
        format!(
            "diagnosing {} against {}",
            args.measured.display(),
            args.session.display()
        )
    })?;
    let plots = match &args.report {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("creating report directory {}", dir.display()))?;
            let mut files = report
                .write_report(dir)
                .with_context(|| format!("writing the report to {}", dir.display()))?;
            let text = dir.join("diagnose.txt");
            millcomp_datasets::write_text_atomic(&text, &report.human())?;
            files.push(text);
            files
        }
        None => Vec::new(),
    };
    if json {
        return print_json(&report);
    }
    print!("{}", report.human());
    for f in &plots {
        println!("report: {}", f.display());
    }
    for c in &file.ignored_columns {
        println!(
            "note: unknown column `{c}` in {} ignored",
            args.measured.display()
        );
    }
    Ok(())
}
