//! `millcomp identify force TABLE --material M --diagnose`: the force disagreements of a peak-force
//! table diagnosed (`millcomp_diagnose::forces`), and the S7 groove's deep-end force predicted
//! without a scale factor. The table is read through `millcomp-datasets` (errors name the file,
//! column and row); this module only builds the inputs and prints.

use anyhow::{Context, bail};
use millcomp_datasets::table::Table;
use millcomp_diagnose::forces::{
    Cited, ForceDiagnoseOptions, ForceDiagnosis, PredictCase, Prediction, diagnose_forces,
    predict_peak_z,
};
use millcomp_identify::targets::force::{ForceConditions, PeakForceData};
use millcomp_sim::force::CutConditions;
use serde::Serialize;

use crate::cli::IdentifyArgs;
use crate::cmd::print_json;

#[derive(Serialize)]
struct Output<'a> {
    diagnosis: &'a ForceDiagnosis,
    predictions: &'a [Prediction],
}

fn opt_col(t: &Table, name: &str) -> anyhow::Result<Option<Vec<f64>>> {
    Ok(match t.column(name) {
        Some(_) => Some(t.f64s(name)?),
        None => None,
    })
}

pub fn run(args: &IdentifyArgs, json: bool) -> anyhow::Result<()> {
    let files = crate::cmd::units::read_files(args)?;
    let [file] = files.as_slice() else {
        bail!("--diagnose reads one table");
    };
    let t = &file.m.table;
    let origin = file.path.display().to_string();
    let depth = t.f64s("depth_um")?;
    let upfeed = t.f64s("upfeed_um")?;
    let speed = opt_col(t, "speed_rpm")?;
    let tilt = opt_col(t, "tilt_deg")?;
    let fx = opt_col(t, "max_fx_n")?;
    let fy = opt_col(t, "max_fy_n")?;
    let fz = opt_col(t, "max_fz_n")?;
    let data = PeakForceData {
        conditions: ForceConditions {
            depth_um: &depth,
            upfeed_um: &upfeed,
            speed_rpm: speed.as_deref(),
            tilt_deg: tilt.as_deref(),
        },
        max_fx_n: fx.as_deref(),
        max_fy_n: fy.as_deref(),
        max_fz_n: fz.as_deref(),
    };
    let material = args.material.clone().unwrap_or_else(|| "6061".into());
    let opts = ForceDiagnoseOptions::new(&material);
    let diag = diagnose_forces(&origin, &data, &opts)?;
    let case = millcomp_pipeline::published::s7_groove_case(&material)?;
    // the 30° groove's end force measured by the workpiece transducer (000 §7.3.1, Fig. 7-20)
    let (f30, f30_src) = {
        let g = millcomp_datasets::load("clayton_groove_conditions")?;
        let i = g
            .strings("parameter")?
            .iter()
            .position(|p| p == "spindle_end_force_workpiece")
            .context("clayton_groove_conditions: no `spindle_end_force_workpiece`")?;
        (g.f64s("value")?[i], g.strings("source")?[i].clone())
    };
    let case30 = PredictCase {
        name: "S7 groove end at 30 deg (80 um, 10 um/rev, 10 000 rpm)".into(),
        cut: CutConditions::new(
            case.cut.depth_um,
            case.cut.upfeed_um,
            case.cut.speed_rpm,
            30.0,
        )?,
        measured: Cited {
            name: "end-of-cut Fz, workpiece transducer".into(),
            value: f30,
            unit: "N".into(),
            source: f30_src,
        },
        ..case.clone()
    };
    let mut predictions = Vec::new();
    for c in [&case, &case30] {
        for m in &diag.models {
            predictions.push(predict_peak_z(m, c, &opts)?);
        }
    }
    if json {
        return print_json(&Output {
            diagnosis: &diag,
            predictions: &predictions,
        });
    }
    print!("{}", text(&diag, &predictions));
    Ok(())
}

fn pct(x: f64) -> String {
    format!("{:+.0} %", 100.0 * x)
}

fn opt(x: Option<f64>, prec: usize) -> String {
    x.map(|v| format!("{v:.prec$}"))
        .unwrap_or_else(|| "-".into())
}

fn text(d: &ForceDiagnosis, preds: &[Prediction]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let n = &d.nominal;
    let _ = writeln!(
        s,
        "force diagnosis of {} ({}): {} runs, {} peaks",
        d.origin, d.material, d.n_runs, d.n_obs
    );
    let _ = writeln!(
        s,
        "nominal model (identify force, W free; {}): W = {:.0} MPa [{:.0}, {:.0}] (published {:.0}), RSS {:.3} N²",
        serde_json::to_value(n.status)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default(),
        n.w_mpa,
        n.w_ci95[0],
        n.w_ci95[1],
        n.w_published_mpa,
        n.rss
    );
    let _ = writeln!(
        s,
        "  fixed: wearland {} um, runout {} um, mu {} / mu_f {} (Table 3-3's tool was not published)",
        n.fixed.get("wearland_um").copied().unwrap_or(f64::NAN),
        n.fixed.get("runout_um").copied().unwrap_or(f64::NAN),
        n.fixed.get("mu_rake").copied().unwrap_or(f64::NAN),
        n.fixed.get("mu_flank").copied().unwrap_or(f64::NAN),
    );
    let _ = writeln!(
        s,
        "  response  RMS (N)  bias    model - measured per run (N)"
    );
    for r in &n.responses {
        let runs: Vec<String> = r.per_run_n.iter().map(|v| format!("{v:+.2}")).collect();
        let _ = writeln!(
            s,
            "  {:<8}  {:>7.3}  {:>5}   {}",
            r.axis,
            r.rms_n,
            pct(r.relative_bias),
            runs.join(" ")
        );
    }
    let _ = writeln!(
        s,
        "  leave-one-run-out RMS {:.3} N (each run predicted by the model refitted on the other runs)",
        n.loo_rms_n
    );
    let _ = writeln!(
        s,
        "noise for the detectable sizes: sigma = {:.3} N ({} dof), {}",
        d.noise.sigma_n, d.noise.dof, d.noise.method
    );
    for (i, r) in d.rounds.iter().enumerate() {
        let dof = r.candidates.first().map(|c| c.dof).unwrap_or([1, 0]);
        let given = if r.given.is_empty() {
            "the nominal model".to_string()
        } else {
            format!("nominal + {}", r.given.join(" + "))
        };
        let _ = writeln!(
            s,
            "round {}: each candidate added to {given} (one parameter each, fitted with W and the effects already added); F test dof ({}, {}) at {:.4} = {} / {} candidates; detectable = the change that test finds with power {}:",
            i + 1,
            dof[0],
            dof[1],
            r.alpha_each,
            d.alpha,
            r.candidates.len(),
            d.power
        );
        let _ = writeln!(
            s,
            "  {:<14} {:<18} {:>8} {:>26} {:>6} {:>7} {:>8} {:>8}  {:<12} {:<15} status",
            "candidate",
            "parameter",
            "nominal",
            "fitted [95 %]",
            "W MPa",
            "F",
            "p",
            "LOO RMS",
            "detectable",
            "bias x/y/z"
        );
        for c in &r.candidates {
            let fitted = match (c.value, c.ci95) {
                (Some(v), Some(ci)) => format!("{} [{}, {}]", sig(v), sig(ci[0]), sig(ci[1])),
                _ => "-".into(),
            };
            let b: Vec<String> = c
                .responses
                .iter()
                .map(|r| format!("{:+.0}", 100.0 * r.relative_bias))
                .collect();
            let _ = writeln!(
                s,
                "  {:<14} {:<18} {:>8} {:>26} {:>6} {:>7} {:>8} {:>8}  {:<12} {:<15} {}{}",
                c.name,
                c.param,
                sig(c.nominal_value),
                fitted,
                opt(c.w_mpa, 0),
                opt(c.f, 2),
                c.p.map(|p| format!("{p:.1e}"))
                    .unwrap_or_else(|| "-".into()),
                opt(c.loo_rms_n, 3),
                c.detectable
                    .map(|v| format!("+/-{}", sig(v)))
                    .unwrap_or_else(|| "-".into()),
                format!("{} %", b.join("/")),
                c.status,
                if c.supported { ", supported" } else { "" }
            );
        }
        let _ = writeln!(
            s,
            "  added: {}{}",
            r.added.as_deref().unwrap_or(
                "none (no candidate is significant and predicts the held-out runs better)"
            ),
            r.look_alike
                .as_ref()
                .map(|l| format!(" (look-alike: {l} fits as well)"))
                .unwrap_or_default()
        );
    }
    let _ = writeln!(
        s,
        "named: {}",
        if d.named.is_empty() {
            "none".to_string()
        } else {
            d.named.join(", ")
        }
    );
    for v in &d.verdicts {
        let (b, a) = if v.unit == "1" {
            (pct(v.before), pct(v.after))
        } else {
            (
                format!("{:+.0} {}", v.before, v.unit),
                format!("{:+.0} {}", v.after, v.unit),
            )
        };
        let _ = writeln!(
            s,
            "  {}: before {b}, after {a}; named {}: {}",
            v.disagreement, v.named, v.reason
        );
    }
    let mut last = String::new();
    for p in preds {
        if p.name != last {
            last = p.name.clone();
            let _ = writeln!(
                s,
                "prediction, no scale factor: {} (wearland {} um, runout {} um); measured {} N ({})",
                p.name, p.tool[0].value, p.tool[1].value, p.measured.value, p.measured.source
            );
            let _ = writeln!(
                s,
                "  {:<26} {:<40} {:>6} {:>9} {:>12} {:>11}",
                "model", "W carried by", "ratio", "W S7 MPa", "predicted N", "scale left"
            );
        }
        for t in &p.transfers {
            let _ = writeln!(
                s,
                "  {:<26} {:<40} {:>6.2} {:>9.0} {:>12.2} {:>11.2}",
                p.model, t.transfer.name, t.transfer.value, t.w_mpa, t.predicted_n, t.scale_left
            );
        }
    }
    let _ = writeln!(s, "sources:");
    for c in d
        .rounds
        .first()
        .map(|r| r.candidates.as_slice())
        .unwrap_or_default()
    {
        let _ = writeln!(s, "  {}: {}", c.name, c.source);
        for u in &c.uses {
            let _ = writeln!(s, "    {} = {} {} ({})", u.name, u.value, u.unit, u.source);
        }
    }
    s
}

/// Three significant digits.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    let prec = (2 - mag).max(0) as usize;
    format!("{v:.prec$}")
}
