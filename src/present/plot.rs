//! The CLI's plots, written atomically: the SVG line plots (groove profiles, residuals, batch results)
//! of `millcomp_closedloop::plot`, and the plots over the point index (diagnose) and the DOE's.

use std::path::Path;

use anyhow::Context;
use plotters::prelude::*;

pub use millcomp_closedloop::plot::{PALETTE, Series};

/// Draws the series as lines on one chart and writes the SVG to `path` atomically
/// (`millcomp_closedloop::plot::line_plot`, the batch's plots' too).
pub fn line_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> anyhow::Result<()> {
    Ok(millcomp_closedloop::plot::line_plot(
        path, title, x_label, y_label, series,
    )?)
}

/// Writes an SVG document to `path` atomically (temporary file + rename).
pub fn write_svg(path: &Path, svg: &str) -> anyhow::Result<()> {
    millcomp_datasets::write_text_atomic(path, svg)
        .with_context(|| format!("writing plot {}", path.display()))
}

// ---- Plots over the point index (diagnose) ------------------------------------------------------

/// Palette index of the gray used for measured data.
pub const GRAY: usize = 7;

/// How a curve over the point index is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// A line per segment (broken where the segment changes).
    Line,
    /// A dot per point.
    Dots,
}

/// One curve over the point index: `values[i]` is drawn at x = i.
pub struct IndexCurve<'a> {
    /// Legend label.
    pub label: String,
    /// One value per point.
    pub values: &'a [f64],
    /// Lines or dots.
    pub mark: Mark,
    /// Palette index of its colour.
    pub color: usize,
}

/// y range of the finite values of all curves, padded by 5 % (at least 1e-6).
fn index_range(curves: &[IndexCurve<'_>]) -> (f64, f64) {
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

/// Draws curves against the point index (960 × 480), lines broken wherever `segment` changes
/// (e.g. one line per groove; `segment` has one entry per point), and writes the SVG to `path`
/// atomically.
pub fn index_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    segment: &[i64],
    curves: &[IndexCurve<'_>],
) -> anyhow::Result<()> {
    let e = |e: &dyn std::fmt::Display| anyhow::anyhow!("plot {}: {e}", path.display());
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (960, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let n = segment.len().max(2);
        let (y0, y1) = index_range(curves);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..(n - 1) as f64, y0..y1)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()
            .map_err(|x| e(&x))?;
        for c in curves {
            let color = PALETTE[c.color % PALETTE.len()];
            match c.mark {
                Mark::Dots => {
                    chart
                        .draw_series(
                            c.values
                                .iter()
                                .enumerate()
                                .map(|(i, &v)| Circle::new((i as f64, v), 2, color.filled())),
                        )
                        .map_err(|x| e(&x))?
                        .label(c.label.clone())
                        .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
                }
                Mark::Line => {
                    let mut start = 0;
                    let mut first = true;
                    while start < c.values.len() {
                        let mut end = start + 1;
                        while end < c.values.len() && segment[end] == segment[start] {
                            end += 1;
                        }
                        let pts: Vec<(f64, f64)> =
                            (start..end).map(|i| (i as f64, c.values[i])).collect();
                        let s = chart
                            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                            .map_err(|x| e(&x))?;
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
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    millcomp_datasets::write_text_atomic(path, &svg)
        .with_context(|| format!("writing plot {}", path.display()))
}
