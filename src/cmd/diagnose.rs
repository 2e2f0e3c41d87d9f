//! `millcomp diagnose SESSION MEASURED.csv`: find where the nominal model and the measurement
//! disagree, name the missing physical effect, add it and show the gap shrink
//! (`millcomp-diagnose`). The measured CSV (and force trace) are read through the contract adapters
//! of `millcomp-datasets` first, so errors name the file, column and row; the text report and the
//! plots are `present::diagnose`.

use anyhow::{Context, bail};
use millcomp_datasets::contracts::{read_force_trace, read_measured_groove};
use millcomp_diagnose::{DiagnoseOptions, Measured, Multiplicity, diagnose};
use millcomp_sim::session::Session;

use crate::cli::DiagnoseArgs;
use std::path::Path;

use crate::cmd::guard::{Inputs, svg_starting};
use crate::cmd::print_json;
use crate::present;

pub fn run(args: DiagnoseArgs, json: bool) -> anyhow::Result<()> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        bail!("--alpha must be in (0, 1), got {}", args.alpha);
    }
    let inputs = Inputs::new()
        .add_opt("SESSION", args.session.as_deref())
        .add_opt("MEASURED", args.measured.as_deref())
        .add_opt("--record", args.record.as_deref())
        .add_opt("--forces", args.forces.as_deref());
    inputs.check_opt("--next-plan", args.next_plan.as_deref())?;
    if let Some(dir) = &args.report {
        inputs.check_dir("--report", dir, |rel| {
            rel == Path::new("diagnose.txt")
                || svg_starting(
                    rel,
                    &["measured_vs_simulated", "residual_step", "diagnose_"],
                )
        })?;
    }
    if args.record.is_some() {
        return crate::cmd::record::diagnose(args, json);
    }
    let (Some(session_path), Some(measured_path)) = (&args.session, &args.measured) else {
        bail!("diagnose needs SESSION and MEASURED (or --record FILE)");
    };
    let session = Session::from_path(session_path)
        .with_context(|| format!("reading session {}", session_path.display()))?;
    let file = match &args.columns {
        Some(c) => millcomp_datasets::contracts::read_measured_groove_mapped(
            measured_path,
            &millcomp_datasets::mapping::ColumnMap::parse(c)?,
        )?,
        None => read_measured_groove(measured_path)?,
    };
    let mut measured = Measured::new(measured_path.display().to_string(), file.points);
    if let Some(path) = &args.forces {
        measured = measured.with_forces(path.display().to_string(), read_force_trace(path)?);
    }
    let options = DiagnoseOptions {
        alpha: args.alpha,
        candidates: (!args.candidates.is_empty()).then(|| args.candidates.clone()),
        free_offset: args.free_offset,
        multiplicity: if args.bonferroni {
            Multiplicity::Bonferroni
        } else {
            DiagnoseOptions::default().multiplicity
        },
        ..DiagnoseOptions::default()
    };
    let report = diagnose(&session, &measured, &options).with_context(|| {
        format!(
            "diagnosing {} against {}",
            measured_path.display(),
            session_path.display()
        )
    })?;
    let plots = match &args.report {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("creating report directory {}", dir.display()))?;
            let mut files = present::diagnose::write_plots(&report, dir)
                .with_context(|| format!("writing the report to {}", dir.display()))?;
            let text = dir.join("diagnose.txt");
            millcomp_datasets::write_text_atomic(&text, &present::diagnose::text(&report))?;
            files.push(text);
            files
        }
        None => Vec::new(),
    };
    let next = match &args.next_plan {
        Some(path) => Some(write_next_plan(&session, path)?),
        None => None,
    };
    if json {
        return print_json(&report);
    }
    print!("{}", present::diagnose::text(&report));
    for f in &plots {
        println!("report: {}", f.display());
    }
    if let (Some(path), Some((grooves, hours, changes))) = (&args.next_plan, next) {
        println!(
            "next plan: {} — {grooves} grooves, {hours:.1} h: this plan, then",
            path.display()
        );
        for (i, c) in changes.iter().enumerate() {
            println!("  {}. {c}", i + 1);
        }
    }
    for c in &file.ignored_columns {
        println!(
            "note: unknown column `{c}` in {} ignored",
            measured_path.display()
        );
    }
    for n in &file.notes {
        println!("note: {}: {n}", measured_path.display());
    }
    Ok(())
}

/// Write `session` with every standard change appended (`aliasing::extended_session`) to `path`
/// (temp file + rename), after checking that the file reads back as the same session. Returns the
/// number of grooves, the hours to the last measured point and the changes in words.
fn write_next_plan(
    session: &Session,
    path: &std::path::Path,
) -> anyhow::Result<(usize, f64, Vec<String>)> {
    let (mut next, changes) = millcomp_diagnose::aliasing::extended_session(session);
    if changes.is_empty() {
        bail!(
            "--next-plan: no standard change applies to the plan of session `{}`",
            session.name
        );
    }
    next.name = format!("{}_next", session.name);
    next.description = format!(
        "{} Then diagnose's standard changes: {}.",
        session.description.trim_end(),
        changes.join("; ")
    );
    let text = toml::to_string(&next).context("--next-plan: writing the session as TOML")?;
    let back = Session::from_toml_str(&text)
        .context("--next-plan: the written session does not read back")?;
    if back != next {
        bail!("--next-plan: the written session does not read back as the same session");
    }
    let contexts = next
        .contexts()
        .context("--next-plan: playing out the next plan")?;
    let grooves = next
        .plan
        .iter()
        .filter(|p| matches!(p, millcomp_sim::session::PlanItem::Groove(_)))
        .count();
    let hours = contexts.points.iter().map(|p| p.t_s).fold(0.0, f64::max) / 3600.0;
    millcomp_datasets::write_text_atomic(path, &text)
        .with_context(|| format!("writing the next plan {}", path.display()))?;
    Ok((grooves, hours, changes))
}
