//! `millcomp diagnose SESSION MEASURED.csv`: find where the nominal model and the measurement
//! disagree, name the missing physical effect, add it and show the gap shrink
//! (`millcomp_identify::diagnose`). The measured CSV is validated against the DESIGN contract by
//! `millcomp-datasets` first, so errors name the file, column and row.

use anyhow::{Context, bail};
use millcomp_identify::diagnose::{DiagnoseOptions, ForceTrace, MeasuredGroove, diagnose};
use millcomp_sim::session::{GroovePoint, Session};

use crate::cli::DiagnoseArgs;
use crate::cmd::print_json;

pub fn run(args: DiagnoseArgs, json: bool) -> anyhow::Result<()> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        bail!("--alpha must be in (0, 1), got {}", args.alpha);
    }
    let session = Session::from_path(&args.session)
        .with_context(|| format!("reading session {}", args.session.display()))?;
    let table = millcomp_datasets::contracts::read_measured_groove(&args.measured)?;
    let points = groove_points(&table)?;
    let mut measured = MeasuredGroove::from_points(&args.measured.display().to_string(), &points);
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
    for c in &table.ignored_columns {
        println!(
            "note: unknown column `{c}` in {} ignored",
            args.measured.display()
        );
    }
    Ok(())
}

fn groove_points(t: &millcomp_datasets::Table) -> anyhow::Result<Vec<GroovePoint>> {
    let ids = t.i64s("groove_id")?;
    let f = |name: &str| t.f64s(name);
    let (ts, x, cut, rpm, feed, up, tilt) = (
        f("t_s")?,
        f("x_mm")?,
        f("cut_length_mm")?,
        f("spindle_rpm")?,
        f("feed_mm_min")?,
        f("upfeed_um")?,
        f("tilt_deg")?,
    );
    let coolant = t.i64s("coolant_on")?;
    let (cmd, meas) = (f("depth_cmd_um")?, f("depth_meas_um")?);
    let temp = t
        .column("spindle_temp_c")
        .map(|_| f("spindle_temp_c"))
        .transpose()?;
    Ok((0..t.n_rows())
        .map(|i| GroovePoint {
            groove_id: ids[i],
            t_s: ts[i],
            x_mm: x[i],
            cut_length_mm: cut[i],
            spindle_rpm: rpm[i],
            feed_mm_min: feed[i],
            upfeed_um: up[i],
            tilt_deg: tilt[i],
            coolant_on: coolant[i] as u8,
            depth_cmd_um: cmd[i],
            depth_meas_um: meas[i],
            spindle_temp_c: temp.as_ref().map(|v| v[i]),
        })
        .collect())
}
