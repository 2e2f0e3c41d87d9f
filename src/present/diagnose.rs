//! The diagnose report for people: the text report (`millcomp diagnose`, `--report DIR/diagnose.txt`)
//! and the SVG plots of `--report DIR` — measured vs simulated depth, and the residual before/after
//! each step, against the point index (grooves in plan order, separated by gaps; pauses between
//! grooves would make a time axis mostly empty).

use std::path::{Path, PathBuf};

use anyhow::Context;
use millcomp_diagnose::{DiagnoseReport, StructureItem, UnlistedTerm};

use crate::present::plot::{GRAY, IndexCurve, Mark, index_plot};

/// p-value as printed: `<1e-300`, `1.2e-5` below 1e-3, else 4 decimals.
pub fn fmt_p(p: f64) -> String {
    if p < 1e-300 {
        "<1e-300".into()
    } else if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}

/// The human-readable report.
pub fn text(rep: &DiagnoseReport) -> String {
    let mut s = String::new();
    let w = |s: &mut String, t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    w(
        &mut s,
        format!(
            "diagnose: session `{}`, {} points, alpha {} ({})",
            rep.session, rep.n_points, rep.alpha, rep.correction
        ),
    );
    w(
        &mut s,
        format!("RMS residual: nominal {:.3} µm", rep.initial_rms_um),
    );
    w(
        &mut s,
        format!(
            "nuisance step (the nominal model recalibrated within its priors): RMS {:.3} → {:.3} µm; its parameters in the final model:",
            rep.nuisance.rms_before_um, rep.nuisance.rms_after_um
        ),
    );
    for p in &rep.nuisance.params {
        if p.determined_by == "held" {
            w(&mut s, format!("  {:<22} held at nominal", p.name));
            continue;
        }
        w(
            &mut s,
            format!(
                "  {:<22} {:>+9.3} ± {:<7.3} prior SD {:<6} ({:+.1} prior SD, determined by the {})",
                p.name,
                p.estimate,
                p.sd,
                if p.prior_sd.is_finite() {
                    format!("{}", p.prior_sd)
                } else {
                    "free".into()
                },
                p.z_prior,
                p.determined_by
            ),
        );
    }
    w(
        &mut s,
        format!(
            "groove-to-groove scatter: σ_g = {:.3} µm (random offset per groove), σ_e = {:.3} µm within grooves",
            rep.scatter.groove_sd_um, rep.scatter.measurement_sd_um
        ),
    );
    let top: Vec<&StructureItem> = {
        let mut v: Vec<&StructureItem> = rep.residual_structure.nominal.iter().collect();
        v.sort_by(|a, b| a.bins_p.unwrap_or(1.0).total_cmp(&b.bins_p.unwrap_or(1.0)));
        v.into_iter().take(3).collect()
    };
    w(
        &mut s,
        "nominal residual structure (strongest first):".into(),
    );
    for it in top {
        w(
            &mut s,
            format!(
                "  {:<15} r = {:>6}  binned means {}",
                it.variable,
                it.correlation
                    .map(|r| format!("{r:+.2}"))
                    .unwrap_or("-".into()),
                it.bins
                    .iter()
                    .map(|b| format!("{:+.2}", b.mean_um))
                    .collect::<Vec<_>>()
                    .join(" "),
            ),
        );
    }
    for (i, r) in rep.rounds.iter().enumerate() {
        w(
            &mut s,
            if r.threshold == r.bonferroni_threshold {
                format!("round {} (threshold p < {:.2e}):", i + 1, r.threshold)
            } else {
                format!(
                    "round {} (threshold p < {:.2e}; Bonferroni's would be {:.2e}):",
                    i + 1,
                    r.threshold,
                    r.bonferroni_threshold
                )
            },
        );
        let mut t = r.tested.clone();
        t.sort_by(|a, b| a.test.ln_p.total_cmp(&b.test.ln_p));
        for d in &t {
            w(
                &mut s,
                format!(
                    "  {:<23} {:<19} F({},{:.1}) = {:>10.2}  p = {:<9}  RMS {:.3} µm  amplitude {:>6.2} µm  {}",
                    d.effect,
                    d.shape,
                    d.test.df1,
                    d.test.df2,
                    d.test.f_statistic,
                    fmt_p(d.test.p_value),
                    d.rms_after_um,
                    d.amplitude_um,
                    if d.decision == "added" {
                        "<- added".to_string()
                    } else if d.significant {
                        d.decision.clone()
                    } else {
                        String::new()
                    }
                ),
            );
        }
    }
    for st in &rep.steps {
        w(
            &mut s,
            format!(
                "step: {} [{} shape] (p = {}), RMS {:.3} → {:.3} µm; held-out grooves {:.1} → {:.1}{}",
                st.effect,
                st.shape,
                fmt_p(st.p_value),
                st.rms_before_um,
                st.rms_after_um,
                st.logo.before,
                st.logo.after,
                if st.beyond_prior {
                    "; aliased with the nominal model, named beyond its prior"
                } else {
                    ""
                }
            ),
        );
    }
    if !rep.final_params.is_empty() {
        w(&mut s, "final joint estimates (95 % interval):".into());
    }
    for (e, ps) in &rep.final_params {
        for (k, v) in ps {
            let ci = rep
                .final_ci95
                .get(e)
                .and_then(|c| c.get(k))
                .map(|c| format!("[{:.4}, {:.4}]", c[0], c[1]))
                .unwrap_or("-".into());
            w(&mut s, format!("  {e}.{k} = {v:.4}  {ci}"));
        }
    }
    for u in &rep.unexplained {
        w(
            &mut s,
            format!(
                "unexplained: the residual still correlates with {} (r = {:+.2}, p = {}, {} grooves)",
                u.variable,
                u.correlation,
                fmt_p(u.p_value),
                u.stratum
            ),
        );
    }
    for u in &rep.unlisted {
        unlisted_text(&mut s, u);
    }
    for x in &rep.within_nominal_uncertainty {
        w(&mut s, format!("{}: {}", x.effect, x.note));
    }
    for l in &rep.look_alikes {
        w(&mut s, format!("look-alike: {}", l.note));
    }
    for a in &rep.aliasing {
        w(&mut s, format!("plan: {}", a.note));
    }
    for sk in &rep.skipped {
        w(&mut s, format!("skipped {}: {}", sk.effect, sk.note));
    }
    if let Some(fc) = &rep.force_channel {
        w(
            &mut s,
            format!(
                "force channel ({} rows): RMS asymmetry residual {:.4} → {:.4} N",
                fc.n_rows, fc.initial_rms_n, fc.final_rms_n
            ),
        );
        for d in &fc.tested {
            w(
                &mut s,
                format!(
                    "  {:<24} F({},{}) = {:.2}  p = {}  {}",
                    d.effect,
                    d.df1,
                    d.df2,
                    d.f_statistic,
                    fmt_p(d.p_value),
                    if d.significant {
                        "named"
                    } else {
                        "not significant"
                    }
                ),
            );
        }
        for st in &fc.steps {
            for (k, v) in &st.params {
                let ci = st.ci95.get(k).copied().unwrap_or([f64::NAN; 2]);
                w(
                    &mut s,
                    format!("  flute_runout.{k} = {v:.4}  [{:.4}, {:.4}]", ci[0], ci[1]),
                );
            }
        }
        for n in &fc.notes {
            w(&mut s, format!("  note: {n}"));
        }
    }
    for n in &rep.notes {
        w(&mut s, format!("note: {n}"));
    }
    w(
        &mut s,
        format!(
            "named: {}{}   RMS {:.3} (nominal) → {:.3} (nuisance) → {:.3} µm{}",
            rep.named.join(", "),
            unlisted_names(rep),
            rep.initial_rms_um,
            rep.nuisance_rms_um,
            rep.final_rms_um,
            rep.final_rms_with_unlisted_um
                .map(|r| format!(" → {r:.3} µm with the unlisted term"))
                .unwrap_or_default()
        ),
    );
    s
}

/// ` + unlisted f(x_mm)` for each unlisted term (empty without one).
fn unlisted_names(rep: &DiagnoseReport) -> String {
    rep.unlisted
        .iter()
        .map(|u| format!(" + unlisted f({})", u.variable))
        .collect()
}

/// The `unlisted` section of one term: the variable, the basis cross-validation chose, the
/// evidence, the held-out gap and the shape table.
fn unlisted_text(s: &mut String, u: &UnlistedTerm) {
    use std::fmt::Write;
    // writing into a String cannot fail: the results are ignored
    let _ = writeln!(
        s,
        "unlisted: a term built from the data follows {} (no candidate family explains it)",
        u.variable
    );
    if !u.driver_of.is_empty() {
        let _ = writeln!(
            s,
            "  {} drives the named {}: the term may be what its shapes miss rather than a further effect",
            u.variable,
            u.driver_of.join(", ")
        );
    }
    let bases: Vec<&str> = u.flexibility.iter().map(|f| f.basis.as_str()).collect();
    let _ = writeln!(
        s,
        "  basis {} ({} dof), chosen by leave-one-groove-out cross-validation over {}",
        u.basis,
        u.dof,
        bases.join(", ")
    );
    let _ = writeln!(
        s,
        "  evidence: F({},{:.0}) = {:.2}  p = {}  threshold p < {:.2e} (family-wise over {} bases; Bonferroni's {:.2e})  between grooves {:.0} %",
        u.test.df1,
        u.test.df2,
        u.test.f_statistic,
        fmt_p(u.p_value),
        u.threshold,
        u.bases_tried,
        u.bonferroni_threshold,
        100.0 * u.between_share
    );
    let _ = writeln!(
        s,
        "  held-out grooves: RMS {:.3} → {:.3} µm   residual RMS {:.3} → {:.3} µm   amplitude {:.3} µm",
        u.held_out_rms_um[0], u.held_out_rms_um[1], u.rms_before_um, u.rms_after_um, u.amplitude_um
    );
    let _ = write!(s, "  {:<14}", u.variable);
    for p in &u.shape {
        let _ = write!(s, "{:>8.4}", p.value);
    }
    let _ = write!(s, "\n  {:<14}", "offset (µm)");
    for p in &u.shape {
        let _ = write!(s, "{:>8.3}", p.offset_um);
    }
    s.push('\n');
}

/// Palette indices of the curves (present::plot): nominal blue, final red, measured gray.
const BLUE: usize = 0;
const RED: usize = 1;

/// Writes the SVG plots of `rep` into `dir` (created if missing): `measured_vs_simulated.svg`,
/// `residual_step0_nuisance.svg` (the residual before and after the nuisance step) and one
/// `residual_step{k}_{effect}.svg` per step (residual before and after it). Returns the files
/// written.
pub fn write_plots(rep: &DiagnoseReport, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let s = &rep.series;
    let x_label = "measured point (plan order; grooves separated)";
    let mut out = Vec::new();
    let nominal = s.predictions_um.first().cloned().unwrap_or_default();
    let last = s.predictions_um.last().cloned().unwrap_or_default();
    let p = dir.join("measured_vs_simulated.svg");
    let final_label = if rep.steps.is_empty() && rep.unlisted.is_empty() {
        "final model (= nominal)".to_string()
    } else if rep.steps.is_empty() {
        format!("nominal{}", unlisted_names(rep))
    } else {
        format!("nominal + {}{}", rep.named.join(" + "), unlisted_names(rep))
    };
    index_plot(
        &p,
        &format!("{}: measured vs simulated depth", rep.session),
        x_label,
        "depth (µm)",
        &s.groove_id,
        &[
            IndexCurve {
                label: "nominal model".into(),
                values: &nominal,
                mark: Mark::Line,
                color: BLUE,
            },
            IndexCurve {
                label: final_label,
                values: &last,
                mark: Mark::Line,
                color: RED,
            },
            IndexCurve {
                label: "measured".into(),
                values: &s.measured_um,
                mark: Mark::Dots,
                color: GRAY,
            },
        ],
    )?;
    out.push(p);
    let resid =
        |pred: &[f64]| -> Vec<f64> { s.measured_um.iter().zip(pred).map(|(m, p)| m - p).collect() };
    if let Some(after) = s.predictions_um.get(1) {
        let p = dir.join("residual_step0_nuisance.svg");
        index_plot(
            &p,
            &format!(
                "{}: the nominal model recalibrated within its priors, RMS {:.3} → {:.3} µm",
                rep.session, rep.initial_rms_um, rep.nuisance_rms_um
            ),
            x_label,
            "measured − model (µm)",
            &s.groove_id,
            &[
                IndexCurve {
                    label: "nominal".into(),
                    values: &resid(&nominal),
                    mark: Mark::Dots,
                    color: GRAY,
                },
                IndexCurve {
                    label: "after the nuisance step".into(),
                    values: &resid(after),
                    mark: Mark::Dots,
                    color: BLUE,
                },
            ],
        )?;
        out.push(p);
    }
    for (k, st) in rep.steps.iter().enumerate() {
        let (Some(before), Some(after)) =
            (s.predictions_um.get(k + 1), s.predictions_um.get(k + 2))
        else {
            continue;
        };
        let rb = resid(before);
        let ra = resid(after);
        let p = dir.join(format!("residual_step{}_{}.svg", k + 1, st.effect));
        index_plot(
            &p,
            &format!(
                "step {}: add {} [{}] (p = {}), RMS {:.3} → {:.3} µm",
                k + 1,
                st.effect,
                st.shape,
                fmt_p(st.p_value),
                st.rms_before_um,
                st.rms_after_um
            ),
            x_label,
            "measured − model (µm)",
            &s.groove_id,
            &[
                IndexCurve {
                    label: "before".into(),
                    values: &rb,
                    mark: Mark::Dots,
                    color: GRAY,
                },
                IndexCurve {
                    label: format!("after adding {}", st.effect),
                    values: &ra,
                    mark: Mark::Dots,
                    color: BLUE,
                },
            ],
        )?;
        out.push(p);
    }
    Ok(out)
}
