//! The real-data study of `diagnose` (issue 15): seeded sessions drawn from the fixed distribution
//! of `synthetic/VARIANTS.md` — the nominal model off in force scale, stiffness, wearland and
//! touch-off, 0.5 µm groove scatter, effects hidden with shapes other than the candidates' — are
//! diagnosed against their nominal session, and what is named is compared with what was hidden.
//!
//! ```text
//! cargo run -p millcomp-diagnose --example real_data_study --release -- [--n 210] [--rows single,two,none,matched] [--dev] [--out DIR]
//! ```
//! `--n` sessions per row (stratified: the single and matched rows cycle through the seven effects,
//! the two-effect row through the 21 pairs), `--dev` uses the development seeds (9 000 000 + k)
//! instead of the study's, `--out` writes `sessions.jsonl` (one line per session) and
//! `summary.md`. Rates come with their one-sided 95 % Clopper–Pearson lower bounds. The results
//! of the recorded run are in `diagnose/STUDY.md`. `RAYON_NUM_THREADS` sets the threads.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use millcomp_diagnose::{DiagnoseOptions, DiagnoseReport, Diagnoser, Measured};
use millcomp_synthetic::variants::{
    DEV_SEED_BASE, EFFECTS, Row, SPEC_VERSION, Variant, draw, row_specs, score, study_session,
};
use rayon::prelude::*;
use serde_json::json;
use statrs::distribution::{Beta, ContinuousCDF};

/// One-sided 95 % Clopper–Pearson lower bound of a binomial rate k/n.
fn lower_bound(k: usize, n: usize) -> f64 {
    if k == 0 || n == 0 {
        return 0.0;
    }
    Beta::new(k as f64, (n - k + 1) as f64)
        .map(|b| b.inverse_cdf(0.05))
        .unwrap_or(f64::NAN)
}

fn rate(k: usize, n: usize) -> String {
    format!(
        "{k}/{n} = {:.1} % (95 % lower bound {:.1} %)",
        100.0 * k as f64 / n.max(1) as f64,
        100.0 * lower_bound(k, n)
    )
}

struct Done {
    variant: Variant,
    report: Result<DiagnoseReport, String>,
    seconds: f64,
}

fn first_named(r: &DiagnoseReport) -> String {
    if r.verdict == "plan_cannot_separate" {
        "cannot_separate".into()
    } else {
        r.named.first().cloned().unwrap_or_else(|| "none".into())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut n = 210usize;
    let mut rows = vec![Row::Single, Row::Two, Row::None, Row::Matched];
    let mut dev = false;
    let mut out: Option<PathBuf> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--n" => n = args.next().ok_or("--n needs a value")?.parse()?,
            "--dev" => dev = true,
            "--out" => out = Some(args.next().ok_or("--out needs a directory")?.into()),
            "--rows" => {
                rows = args
                    .next()
                    .ok_or("--rows needs a list")?
                    .split(',')
                    .map(|r| match r {
                        "single" => Ok(Row::Single),
                        "two" => Ok(Row::Two),
                        "none" => Ok(Row::None),
                        "matched" => Ok(Row::Matched),
                        other => Err(format!("unknown row `{other}`")),
                    })
                    .collect::<Result<_, _>>()?
            }
            other => return Err(format!("unknown argument `{other}`").into()),
        }
    }
    let session = study_session();
    let diagnoser = Diagnoser::new(&session, &DiagnoseOptions::default())?;
    let mut specs = Vec::new();
    for &row in &rows {
        let base = if dev {
            DEV_SEED_BASE + 100_000 * (row as u64)
        } else {
            row.study_seed_base()
        };
        specs.extend(row_specs(row, n, base));
    }
    let bar = ProgressBar::new(specs.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} sessions  {elapsed_precise} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t0 = Instant::now();
    let done: Vec<Done> = specs
        .par_iter()
        .map(|spec| {
            let t = Instant::now();
            let variant = draw(&session, spec).expect("the study's variants are valid");
            let report = diagnoser
                .run(&Measured::new(
                    format!("seed {}", spec.seed),
                    variant.points.clone(),
                ))
                .map_err(|e| e.to_string());
            bar.inc(1);
            Done {
                variant,
                report,
                seconds: t.elapsed().as_secs_f64(),
            }
        })
        .collect();
    bar.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();

    let mut md = String::new();
    let _ = writeln!(
        md,
        "Variant distribution version {SPEC_VERSION} (synthetic/VARIANTS.md), {} seeds, {n} sessions per row, \
         {} sessions in {:.0} s wall ({:.2} s per session on one core on average).\n",
        if dev { "development" } else { "study" },
        done.len(),
        wall,
        done.iter().map(|d| d.seconds).sum::<f64>() / done.len().max(1) as f64
    );
    let errors: Vec<&Done> = done.iter().filter(|d| d.report.is_err()).collect();
    if !errors.is_empty() {
        let _ = writeln!(md, "**{} sessions failed to diagnose:**", errors.len());
        for d in &errors {
            let _ = writeln!(
                md,
                "- seed {}: {}",
                d.variant.spec.seed,
                d.report.as_ref().err().cloned().unwrap_or_default()
            );
        }
    }
    for &row in &rows {
        let of_row: Vec<(&Done, &DiagnoseReport)> = done
            .iter()
            .filter(|d| d.variant.spec.row == row)
            .filter_map(|d| d.report.as_ref().ok().map(|r| (d, r)))
            .collect();
        let total = of_row.len();
        let hidden =
            |d: &Done| -> Vec<&str> { d.variant.hidden.iter().map(|h| h.effect).collect() };
        let count = |f: &dyn Fn(&Done, &DiagnoseReport) -> bool| {
            of_row.iter().filter(|(d, r)| f(d, r)).count()
        };
        let shrink = |r: &DiagnoseReport| 1.0 - r.final_rms_um / r.nuisance_rms_um.max(1e-12);
        let _ = writeln!(md, "### Row `{}` ({total} sessions)\n", row.name());
        match row {
            Row::Single | Row::Matched => {
                let first = count(&|d, r| score(&hidden(d), &r.named).first_right);
                let alone = count(&|d, r| score(&hidden(d), &r.named).exact);
                let shrunk = count(&|_, r| shrink(r) >= 0.5);
                let mut s: Vec<f64> = of_row.iter().map(|(_, r)| shrink(r)).collect();
                s.sort_by(f64::total_cmp);
                let med = s.get(s.len() / 2).copied().unwrap_or(f64::NAN);
                let _ = writeln!(md, "| measure | rate |\n|---|---|");
                let _ = writeln!(md, "| hidden effect named first | {} |", rate(first, total));
                let _ = writeln!(md, "| named alone | {} |", rate(alone, total));
                let _ = writeln!(
                    md,
                    "| RMS after the nuisance step shrinks ≥ 50 % | {} (median shrink {:.0} %) |\n",
                    rate(shrunk, total),
                    100.0 * med
                );
                let _ = writeln!(
                    md,
                    "| hidden | sessions | named first | named alone | shrink ≥ 50 % | median RMS after nuisance → final (µm) |\n|---|---|---|---|---|---|"
                );
                for e in EFFECTS {
                    let sub: Vec<&(&Done, &DiagnoseReport)> =
                        of_row.iter().filter(|(d, _)| hidden(d) == [e]).collect();
                    let k = sub.len();
                    let f = sub
                        .iter()
                        .filter(|(d, r)| score(&hidden(d), &r.named).first_right)
                        .count();
                    let a = sub
                        .iter()
                        .filter(|(d, r)| score(&hidden(d), &r.named).exact)
                        .count();
                    let sh = sub.iter().filter(|(_, r)| shrink(r) >= 0.5).count();
                    let mut b: Vec<f64> = sub.iter().map(|(_, r)| r.nuisance_rms_um).collect();
                    let mut fi: Vec<f64> = sub.iter().map(|(_, r)| r.final_rms_um).collect();
                    b.sort_by(f64::total_cmp);
                    fi.sort_by(f64::total_cmp);
                    let _ = writeln!(
                        md,
                        "| {e} | {k} | {f} | {a} | {sh} | {:.2} → {:.2} |",
                        b.get(k / 2).copied().unwrap_or(f64::NAN),
                        fi.get(k / 2).copied().unwrap_or(f64::NAN)
                    );
                }
                // confusion matrix: hidden × first named
                let mut cols: Vec<String> = EFFECTS.iter().map(|e| e.to_string()).collect();
                cols.push("none".into());
                cols.push("cannot_separate".into());
                let _ = writeln!(
                    md,
                    "\nConfusion matrix, hidden (rows) × first named (columns):\n\n| hidden \\ named | {} |\n|---|{}",
                    cols.iter()
                        .map(|c| abbrev(c))
                        .collect::<Vec<_>>()
                        .join(" | "),
                    "---|".repeat(cols.len())
                );
                for e in EFFECTS {
                    let mut line = format!("| {e} |");
                    for c in &cols {
                        let k = of_row
                            .iter()
                            .filter(|(d, r)| hidden(d) == [e] && &first_named(r) == c)
                            .count();
                        let _ = write!(line, " {k} |");
                    }
                    let _ = writeln!(md, "{line}");
                }
                // every name given, by hidden effect
                let _ = writeln!(
                    md,
                    "\nEvery effect named (any position), hidden (rows) × named (columns):\n\n| hidden \\ named | {} |\n|---|{}",
                    EFFECTS
                        .iter()
                        .map(|c| abbrev(c))
                        .collect::<Vec<_>>()
                        .join(" | "),
                    "---|".repeat(EFFECTS.len())
                );
                for e in EFFECTS {
                    let mut line = format!("| {e} |");
                    for c in EFFECTS {
                        let k = of_row
                            .iter()
                            .filter(|(d, r)| hidden(d) == [e] && r.named.iter().any(|n| n == c))
                            .count();
                        let _ = write!(line, " {k} |");
                    }
                    let _ = writeln!(md, "{line}");
                }
                // shapes: which shape was hidden, what was named first
                let mut by_shape: BTreeMap<(String, String), (usize, usize, usize)> =
                    BTreeMap::new();
                for (d, r) in &of_row {
                    let h = &d.variant.hidden[0];
                    let e = by_shape
                        .entry((h.effect.to_string(), h.shape.to_string()))
                        .or_default();
                    e.0 += 1;
                    let o = score(&hidden(d), &r.named);
                    e.1 += usize::from(o.first_right);
                    e.2 += usize::from(o.exact);
                }
                let _ = writeln!(
                    md,
                    "\n| hidden effect | hidden shape | sessions | named first | named alone |\n|---|---|---|---|---|"
                );
                for ((e, s), (k, f, a)) in &by_shape {
                    let _ = writeln!(md, "| {e} | {s} | {k} | {f} | {a} |");
                }
                if row == Row::Matched {
                    coverage(&mut md, &of_row);
                }
            }
            Row::Two => {
                let both = count(&|d, r| score(&hidden(d), &r.named).all_named);
                let clean = count(&|d, r| score(&hidden(d), &r.named).nothing_else);
                let exact = count(&|d, r| score(&hidden(d), &r.named).exact);
                let shrunk = count(&|_, r| shrink(r) >= 0.5);
                let _ = writeln!(md, "| measure | rate |\n|---|---|");
                let _ = writeln!(md, "| both hidden effects named | {} |", rate(both, total));
                let _ = writeln!(md, "| nothing else named | {} |", rate(clean, total));
                let _ = writeln!(md, "| exactly the two | {} |", rate(exact, total));
                let _ = writeln!(
                    md,
                    "| RMS after the nuisance step shrinks ≥ 50 % | {} |\n",
                    rate(shrunk, total)
                );
                let _ = writeln!(
                    md,
                    "| effect | sessions hiding it | it is named | sessions not hiding it | it is named anyway |\n|---|---|---|---|---|"
                );
                for e in EFFECTS {
                    let with: Vec<_> = of_row
                        .iter()
                        .filter(|(d, _)| hidden(d).contains(&e))
                        .collect();
                    let named = with
                        .iter()
                        .filter(|(_, r)| r.named.iter().any(|n| n == e))
                        .count();
                    let without: Vec<_> = of_row
                        .iter()
                        .filter(|(d, _)| !hidden(d).contains(&e))
                        .collect();
                    let spurious = without
                        .iter()
                        .filter(|(_, r)| r.named.iter().any(|n| n == e))
                        .count();
                    let _ = writeln!(
                        md,
                        "| {e} | {} | {named} | {} | {spurious} |",
                        with.len(),
                        without.len()
                    );
                }
            }
            Row::None => {
                let none = count(&|_, r| r.named == ["none"]);
                let _ = writeln!(md, "| measure | rate |\n|---|---|");
                let _ = writeln!(md, "| `none` named | {} |\n", rate(none, total));
                let mut wrong: BTreeMap<String, usize> = BTreeMap::new();
                for (_, r) in &of_row {
                    for nm in r.named.iter().filter(|n| *n != "none") {
                        *wrong.entry(nm.clone()).or_default() += 1;
                    }
                }
                if !wrong.is_empty() {
                    let _ = writeln!(md, "Named although nothing was hidden: {wrong:?}\n");
                }
            }
        }
        let _ = writeln!(md);
    }
    print!("{md}");
    if let Some(dir) = out {
        std::fs::create_dir_all(&dir)?;
        let mut lines = String::new();
        for d in &done {
            let v = &d.variant;
            let rec = match &d.report {
                Ok(r) => json!({
                    "row": v.spec.row.name(), "seed": v.spec.seed,
                    "hidden": v.hidden.iter().map(|h| json!({"effect": h.effect, "shape": h.shape, "amplitude_factor": h.amplitude_factor})).collect::<Vec<_>>(),
                    "errors": {"force_scale": v.errors.force_scale_factor, "axial": v.errors.axial_stiffness_factor, "radial": v.errors.radial_stiffness_factor, "wearland_um": v.errors.wearland_delta_um, "touch_off_um": v.errors.touch_off_um},
                    "named": r.named, "verdict": r.verdict, "shapes": r.shapes,
                    "initial_rms_um": r.initial_rms_um, "nuisance_rms_um": r.nuisance_rms_um, "final_rms_um": r.final_rms_um,
                    "groove_sd_um": r.scatter.groove_sd_um, "seconds": d.seconds,
                    "p_values": r.steps.iter().map(|s| s.p_value).collect::<Vec<_>>(),
                }),
                Err(e) => json!({"row": v.spec.row.name(), "seed": v.spec.seed, "error": e}),
            };
            lines.push_str(&rec.to_string());
            lines.push('\n');
        }
        millcomp_datasets::write_text_atomic(&dir.join("sessions.jsonl"), &lines)?;
        millcomp_datasets::write_text_atomic(&dir.join("summary.md"), &md)?;
        println!("written: {}", dir.display());
    }
    Ok(())
}

fn abbrev(name: &str) -> String {
    match name {
        "coolant_thermal_drift" => "coolant",
        "spindle_thermal_growth" => "spindle",
        "probe_tilt_offset" => "probe",
        "tool_wear" => "wear",
        "slideway_straightness" => "straight.",
        "machine_compliance" => "compl.",
        "flute_runout" => "runout",
        other => other,
    }
    .to_string()
}

/// Coverage of the 95 % intervals of the family's reference parameters, where the reference
/// shape was chosen.
fn coverage(md: &mut String, of_row: &[(&Done, &DiagnoseReport)]) {
    let mut cov: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    let mut reference_chosen = (0usize, 0usize);
    let families = millcomp_diagnose::families::standard();
    for (d, r) in of_row {
        let h = &d.variant.hidden[0];
        let Some(shape) = r.shapes.get(h.effect) else {
            continue;
        };
        reference_chosen.1 += 1;
        let reference = families
            .iter()
            .find(|f| f.name == h.effect)
            .and_then(|f| f.shapes.first())
            .map(|s| s.name)
            .unwrap_or_default();
        if shape != reference {
            continue;
        }
        reference_chosen.0 += 1;
        for (name, truth) in &h.family_params {
            let e = cov.entry(format!("{}.{name}", h.effect)).or_default();
            e.1 += 1;
            if let Some(iv) = r.final_ci95.get(h.effect).and_then(|m| m.get(*name)) {
                if iv[0] <= *truth && *truth <= iv[1] {
                    e.0 += 1;
                }
            }
        }
    }
    let _ = writeln!(
        md,
        "\nReference shape chosen in {} of the {} sessions whose effect was named; coverage of the 95 % intervals there:\n\n| parameter | covered |\n|---|---|",
        reference_chosen.0, reference_chosen.1
    );
    for (k, (hit, tot)) in &cov {
        let _ = writeln!(md, "| {k} | {} |", rate(*hit, *tot));
    }
}
