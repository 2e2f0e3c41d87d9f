//! The diagnose report for people: the text report (`millcomp diagnose`, `--report DIR/diagnose.txt`)
//! and the SVG plots of `--report DIR` — measured vs simulated depth, and the residual before/after
//! each step, against the point index (grooves in plan order, separated by gaps; pauses between
//! grooves would make a time axis mostly empty).

use std::path::{Path, PathBuf};

use anyhow::Context;
use millcomp_diagnose::{DiagnoseReport, StructureItem};

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

fn rms(rss: f64, n: usize) -> f64 {
    (rss / n.max(1) as f64).sqrt()
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
            "diagnose: session `{}`, {} points, alpha {} ({} over the candidates of each round, plus BIC)",
            rep.session, rep.n_points, rep.alpha, rep.correction
        ),
    );
    for (k, v) in &rep.nominal_free_params {
        w(&mut s, format!("nominal free parameter {k} = {v:.4}"));
    }
    w(
        &mut s,
        format!("RMS residual: nominal {:.3} µm", rep.initial_rms_um),
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
                "  {:<15} r = {:>6}  binned means {}  (ANOVA p {})",
                it.variable,
                it.correlation
                    .map(|r| format!("{r:+.2}"))
                    .unwrap_or("-".into()),
                it.bins
                    .iter()
                    .map(|b| format!("{:+.2}", b.mean_um))
                    .collect::<Vec<_>>()
                    .join(" "),
                it.bins_p.map(fmt_p).unwrap_or("-".into())
            ),
        );
    }
    for (i, r) in rep.rounds.iter().enumerate() {
        w(
            &mut s,
            format!("round {} (threshold p < {:.2e}):", i + 1, r.threshold),
        );
        let mut t = r.tested.clone();
        t.sort_by(|a, b| a.p_value.total_cmp(&b.p_value));
        for d in &t {
            w(
                &mut s,
                format!(
                    "  {:<24} F({},{}) = {:>10.2}  p = {:<9}  ΔBIC = {:>9.1}  RMS {:.3} µm{}",
                    d.effect,
                    d.df1,
                    d.df2,
                    d.f_statistic,
                    fmt_p(d.p_value),
                    d.bic_after - d.bic_before,
                    rms(d.rss_after, rep.n_points),
                    if r.added.as_deref() == Some(d.effect.as_str()) {
                        "  <- added"
                    } else if !d.identifiable {
                        "  (not identifiable)"
                    } else {
                        ""
                    }
                ),
            );
        }
    }
    for st in &rep.steps {
        w(
            &mut s,
            format!(
                "step: {} (p = {}), RMS {:.3} → {:.3} µm",
                st.effect,
                fmt_p(st.p_value),
                st.rms_before_um,
                st.rms_after_um
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
            "named: {}   RMS {:.3} → {:.3} µm",
            rep.named.join(", "),
            rep.initial_rms_um,
            rep.final_rms_um
        ),
    );
    s
}

/// Palette indices of the curves (present::plot): nominal blue, final red, measured gray.
const BLUE: usize = 0;
const RED: usize = 1;

/// Writes the SVG plots of `rep` into `dir` (created if missing): `measured_vs_simulated.svg` and one
/// `residual_step{k}_{effect}.svg` per step (residual before and after it; `residual_step0_nominal.svg`
/// when no step was taken). Returns the files written.
pub fn write_plots(rep: &DiagnoseReport, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let s = &rep.series;
    let x_label = "measured point (plan order; grooves separated)";
    let mut out = Vec::new();
    let nominal = s.predictions_um.first().cloned().unwrap_or_default();
    let last = s.predictions_um.last().cloned().unwrap_or_default();
    let p = dir.join("measured_vs_simulated.svg");
    let final_label = if rep.steps.is_empty() {
        "final model (= nominal)".to_string()
    } else {
        format!("nominal + {}", rep.named.join(" + "))
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
    if rep.steps.is_empty() {
        let r = resid(&nominal);
        let p = dir.join("residual_step0_nominal.svg");
        index_plot(
            &p,
            &format!(
                "{}: residual of the nominal model (RMS {:.3} µm), nothing significant",
                rep.session, rep.initial_rms_um
            ),
            x_label,
            "measured − model (µm)",
            &s.groove_id,
            &[IndexCurve {
                label: "residual".into(),
                values: &r,
                mark: Mark::Dots,
                color: BLUE,
            }],
        )?;
        out.push(p);
    }
    for (k, st) in rep.steps.iter().enumerate() {
        let (Some(before), Some(after)) = (s.predictions_um.get(k), s.predictions_um.get(k + 1))
        else {
            continue;
        };
        let rb = resid(before);
        let ra = resid(after);
        let p = dir.join(format!("residual_step{}_{}.svg", k + 1, st.effect));
        index_plot(
            &p,
            &format!(
                "step {}: add {} (p = {}), RMS {:.3} → {:.3} µm",
                k + 1,
                st.effect,
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
