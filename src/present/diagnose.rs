//! SVG plots of a diagnosis (plotters, SVG backend only): measured vs simulated depth, and the
//! residual before/after each step, against the point index (grooves in plan order, separated by
//! gaps; pauses between grooves would make a time axis mostly empty).

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::DiagnoseReport;
use crate::error::{IdentifyError, Result};

const PALETTE: [RGBColor; 4] = [
    RGBColor(127, 127, 127),
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
];

/// A curve drawn as one line per groove (broken between grooves) or as dots.
struct Curve<'a> {
    label: String,
    values: &'a [f64],
    dots: bool,
    color: RGBColor,
}

fn io(what: &Path, e: impl std::fmt::Display) -> IdentifyError {
    IdentifyError::Io {
        what: what.display().to_string(),
        message: e.to_string(),
    }
}

fn range(curves: &[Curve<'_>]) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in curves {
        for &v in c.values.iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = 0.05 * (hi - lo).max(1e-6);
    (lo - pad, hi + pad)
}

fn plot(
    path: &Path,
    title: &str,
    y_label: &str,
    groove: &[i64],
    curves: &[Curve<'_>],
) -> Result<()> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (960, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| io(path, e))?;
        let n = groove.len().max(2);
        let (y0, y1) = range(curves);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..(n - 1) as f64, y0..y1)
            .map_err(|e| io(path, e))?;
        chart
            .configure_mesh()
            .x_desc("measured point (plan order; grooves separated)")
            .y_desc(y_label)
            .draw()
            .map_err(|e| io(path, e))?;
        for c in curves {
            let color = c.color;
            if c.dots {
                chart
                    .draw_series(
                        c.values
                            .iter()
                            .enumerate()
                            .map(|(i, &v)| Circle::new((i as f64, v), 2, color.filled())),
                    )
                    .map_err(|e| io(path, e))?
                    .label(c.label.clone())
                    .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
            } else {
                let mut start = 0;
                let mut first = true;
                while start < c.values.len() {
                    let mut end = start + 1;
                    while end < c.values.len() && groove[end] == groove[start] {
                        end += 1;
                    }
                    let pts: Vec<(f64, f64)> =
                        (start..end).map(|i| (i as f64, c.values[i])).collect();
                    let s = chart
                        .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                        .map_err(|e| io(path, e))?;
                    if first {
                        s.label(c.label.clone()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                        });
                        first = false;
                    }
                    start = end;
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| io(path, e))?;
        root.present().map_err(|e| io(path, e))?;
    }
    std::fs::write(path, svg).map_err(|e| io(path, e))
}

/// Writes all plots of `rep` into `dir`.
pub(crate) fn write_all(rep: &DiagnoseReport, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let s = &rep.series;
    let mut out = Vec::new();
    let nominal = s.predictions_um.first().cloned().unwrap_or_default();
    let last = s.predictions_um.last().cloned().unwrap_or_default();
    let p = dir.join("measured_vs_simulated.svg");
    let final_label = if rep.steps.is_empty() {
        "final model (= nominal)".to_string()
    } else {
        format!("nominal + {}", rep.named.join(" + "))
    };
    plot(
        &p,
        &format!("{}: measured vs simulated depth", rep.session),
        "depth (µm)",
        &s.groove_id,
        &[
            Curve {
                label: "nominal model".into(),
                values: &nominal,
                dots: false,
                color: PALETTE[1],
            },
            Curve {
                label: final_label,
                values: &last,
                dots: false,
                color: PALETTE[2],
            },
            Curve {
                label: "measured".into(),
                values: &s.measured_um,
                dots: true,
                color: PALETTE[0],
            },
        ],
    )?;
    out.push(p);
    let resid =
        |pred: &[f64]| -> Vec<f64> { s.measured_um.iter().zip(pred).map(|(m, p)| m - p).collect() };
    if rep.steps.is_empty() {
        let r = resid(&nominal);
        let p = dir.join("residual_step0_nominal.svg");
        plot(
            &p,
            &format!(
                "{}: residual of the nominal model (RMS {:.3} µm), nothing significant",
                rep.session, rep.initial_rms_um
            ),
            "measured − model (µm)",
            &s.groove_id,
            &[Curve {
                label: "residual".into(),
                values: &r,
                dots: true,
                color: PALETTE[1],
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
        plot(
            &p,
            &format!(
                "step {}: add {} (p = {}), RMS {:.3} → {:.3} µm",
                k + 1,
                st.effect,
                super::fmt_p(st.p_value),
                st.rms_before_um,
                st.rms_after_um
            ),
            "measured − model (µm)",
            &s.groove_id,
            &[
                Curve {
                    label: "before".into(),
                    values: &rb,
                    dots: true,
                    color: PALETTE[0],
                },
                Curve {
                    label: format!("after adding {}", st.effect),
                    values: &ra,
                    dots: true,
                    color: PALETTE[1],
                },
            ],
        )?;
        out.push(p);
    }
    Ok(out)
}
