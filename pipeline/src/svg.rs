//! The report's pictures as SVG text (plotters' SVG backend): charts of points, lines, bands and error
//! bars with reference lines, and the picture of the pipeline's flow. Each is a self-contained `<svg>`
//! element with a `viewBox`, so it scales inline in `report.html` and opens alone from its file.

use plotters::prelude::*;

use crate::error::{PipelineError, Result};

/// Colours of the series, in order: the batch plots' palette, so a controller keeps its colour.
pub use millcomp_closedloop::plot::PALETTE;

/// How a series is drawn.
#[derive(Debug, Clone, PartialEq)]
pub enum Mark {
    /// A line through the points.
    Line,
    /// A dashed-looking thin line (drawn thinner and lighter).
    ThinLine,
    /// Filled circles.
    Points,
    /// A band between `lo` and `hi` at each x (the points' y ignored), shaded.
    Band {
        /// Lower edge.
        lo: Vec<f64>,
        /// Upper edge.
        hi: Vec<f64>,
    },
    /// Points with vertical error bars from `lo` to `hi`.
    ErrorBars {
        /// Lower ends.
        lo: Vec<f64>,
        /// Upper ends.
        hi: Vec<f64>,
    },
}

/// One series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label (empty: not in the legend).
    pub label: String,
    /// x values.
    pub x: Vec<f64>,
    /// y values.
    pub y: Vec<f64>,
    /// How it is drawn.
    pub mark: Mark,
    /// Colour index into [`PALETTE`].
    pub colour: usize,
}

impl Series {
    /// A series.
    pub fn new(label: &str, x: Vec<f64>, y: Vec<f64>, mark: Mark, colour: usize) -> Self {
        Self {
            label: label.to_string(),
            x,
            y,
            mark,
            colour,
        }
    }
}

/// A reference line: horizontal (`y`) or vertical (`x`), with a label.
#[derive(Debug, Clone, PartialEq)]
pub enum RefLine {
    /// Horizontal at y.
    H(f64, String),
    /// Vertical at x.
    V(f64, String),
}

/// A chart.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chart {
    /// Title.
    pub title: String,
    /// x-axis label with unit.
    pub x_label: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// Series, drawn in order.
    pub series: Vec<Series>,
    /// Reference lines.
    pub lines: Vec<RefLine>,
    /// Category names for x = 0, 1, 2, … (the x axis then shows them instead of numbers).
    pub categories: Vec<String>,
    /// Text labels at points `(x, y, text)`.
    pub labels: Vec<(f64, f64, String)>,
    /// Where the legend goes (default: upper right).
    pub legend_lower_right: bool,
}

fn plot_err(name: &str, e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Plot {
        name: name.to_string(),
        message: e.to_string(),
    }
}

impl Chart {
    fn bounds(&self) -> (f64, f64, f64, f64) {
        let (mut x0, mut x1, mut y0, mut y1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        let mut take = |x: f64, y: f64| {
            if x.is_finite() && y.is_finite() {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        };
        for s in &self.series {
            match &s.mark {
                Mark::Band { lo, hi } | Mark::ErrorBars { lo, hi } => {
                    for i in 0..s.x.len() {
                        take(s.x[i], lo[i]);
                        take(s.x[i], hi[i]);
                    }
                }
                _ => {}
            }
            for (x, y) in s.x.iter().zip(&s.y) {
                take(*x, *y);
            }
        }
        for l in &self.lines {
            match l {
                RefLine::H(y, _) if y.is_finite() && x0.is_finite() => {
                    y0 = y0.min(*y);
                    y1 = y1.max(*y);
                }
                RefLine::V(x, _) if x.is_finite() && y0.is_finite() => {
                    x0 = x0.min(*x);
                    x1 = x1.max(*x);
                }
                _ => {}
            }
        }
        if !x0.is_finite() {
            return (0.0, 1.0, 0.0, 1.0);
        }
        if !self.categories.is_empty() {
            x0 = -0.5;
            x1 = self.categories.len() as f64 - 0.5;
        }
        let pad = |a: f64, b: f64| {
            let span = (b - a).abs().max(1e-9);
            (a - 0.06 * span, b + 0.06 * span)
        };
        let (x0, x1) = if self.categories.is_empty() {
            pad(x0, x1)
        } else {
            (x0, x1)
        };
        let (y0, y1) = pad(y0, y1);
        (x0, x1, y0, y1)
    }

    /// The chart as an SVG document of `width` × `height` px (scalable: it carries a `viewBox`).
    ///
    /// # Errors
    /// [`PipelineError::Plot`] when the backend fails.
    pub fn render(&self, width: u32, height: u32) -> Result<String> {
        let name = self.title.as_str();
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot_err(name, e))?;
            let (x0, x1, y0, y1) = self.bounds();
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 20))
                .margin(14)
                .x_label_area_size(44)
                .y_label_area_size(64)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| plot_err(name, e))?;
            let cats = self.categories.clone();
            let fmt_x = move |v: &f64| {
                if cats.is_empty() {
                    format!("{v}")
                } else {
                    let i = v.round();
                    if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < cats.len() {
                        cats[i as usize].clone()
                    } else {
                        String::new()
                    }
                }
            };
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(self.x_label.as_str())
                .y_desc(self.y_label.as_str())
                .x_label_formatter(&fmt_x)
                .light_line_style(RGBColor(235, 235, 235));
            if !self.categories.is_empty() {
                mesh.x_labels(self.categories.len() * 2 + 1);
                if self.categories.len() > 6 {
                    mesh.x_label_style(("sans-serif", 10));
                }
            }
            mesh.draw().map_err(|e| plot_err(name, e))?;
            for s in &self.series {
                let c = PALETTE[s.colour % PALETTE.len()];
                let pts: Vec<(f64, f64)> =
                    s.x.iter()
                        .zip(&s.y)
                        .map(|(a, b)| (*a, *b))
                        .filter(|(a, b)| a.is_finite() && b.is_finite())
                        .collect();
                let legend = !s.label.is_empty();
                match &s.mark {
                    Mark::Line | Mark::ThinLine => {
                        let w = if s.mark == Mark::Line { 2 } else { 1 };
                        let style = c.stroke_width(w);
                        let a = chart
                            .draw_series(LineSeries::new(pts, style))
                            .map_err(|e| plot_err(name, e))?;
                        if legend {
                            a.label(s.label.as_str()).legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                            });
                        }
                    }
                    Mark::Points => {
                        let a = chart
                            .draw_series(
                                pts.iter().map(|&p| Circle::new(p, 3, c.mix(0.85).filled())),
                            )
                            .map_err(|e| plot_err(name, e))?;
                        if legend {
                            a.label(s.label.as_str())
                                .legend(move |(x, y)| Circle::new((x + 9, y), 3, c.filled()));
                        }
                    }
                    Mark::Band { lo, hi } => {
                        let finite = |(&x, &y): (&f64, &f64)| {
                            (x.is_finite() && y.is_finite()).then_some((x, y))
                        };
                        let mut poly: Vec<(f64, f64)> =
                            s.x.iter().zip(lo.iter()).filter_map(finite).collect();
                        let upper: Vec<(f64, f64)> =
                            s.x.iter().zip(hi.iter()).filter_map(finite).collect();
                        poly.extend(upper.into_iter().rev());
                        let a = chart
                            .draw_series(std::iter::once(Polygon::new(poly, c.mix(0.2).filled())))
                            .map_err(|e| plot_err(name, e))?;
                        if legend {
                            a.label(s.label.as_str()).legend(move |(x, y)| {
                                Rectangle::new([(x, y - 5), (x + 18, y + 5)], c.mix(0.2).filled())
                            });
                        }
                    }
                    Mark::ErrorBars { lo, hi } => {
                        let bars: Vec<(f64, f64, f64, f64)> = (0..s.x.len())
                            .filter(|&i| {
                                s.x[i].is_finite() && lo[i].is_finite() && hi[i].is_finite()
                            })
                            .map(|i| (s.x[i], s.y[i], lo[i], hi[i]))
                            .collect();
                        let _ = &bars;
                        chart
                            .draw_series(bars.iter().map(|&(x, _, l, h)| {
                                PathElement::new(vec![(x, l), (x, h)], c.stroke_width(2))
                            }))
                            .map_err(|e| plot_err(name, e))?;
                        let a = chart
                            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                            .map_err(|e| plot_err(name, e))?;
                        if legend {
                            a.label(s.label.as_str())
                                .legend(move |(x, y)| Circle::new((x + 9, y), 3, c.filled()));
                        }
                    }
                }
            }
            for l in &self.lines {
                let grey = RGBColor(90, 90, 90);
                match l {
                    RefLine::H(y, label) => {
                        chart
                            .draw_series(LineSeries::new(
                                vec![(x0, *y), (x1, *y)],
                                grey.stroke_width(1),
                            ))
                            .map_err(|e| plot_err(name, e))?;
                        chart
                            .draw_series(std::iter::once(Text::new(
                                label.clone(),
                                (x0 + 0.01 * (x1 - x0), *y),
                                ("sans-serif", 13).into_font().color(&grey),
                            )))
                            .map_err(|e| plot_err(name, e))?;
                    }
                    RefLine::V(x, label) => {
                        chart
                            .draw_series(LineSeries::new(
                                vec![(*x, y0), (*x, y1)],
                                grey.stroke_width(1),
                            ))
                            .map_err(|e| plot_err(name, e))?;
                        chart
                            .draw_series(std::iter::once(Text::new(
                                label.clone(),
                                (*x, y1 - 0.04 * (y1 - y0)),
                                ("sans-serif", 13).into_font().color(&grey),
                            )))
                            .map_err(|e| plot_err(name, e))?;
                    }
                }
            }
            chart
                .draw_series(self.labels.iter().map(|(x, y, t)| {
                    Text::new(
                        t.clone(),
                        (*x, *y),
                        ("sans-serif", 12).into_font().color(&BLACK),
                    )
                }))
                .map_err(|e| plot_err(name, e))?;
            if self.series.iter().any(|s| !s.label.is_empty()) {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(RGBColor(200, 200, 200))
                    .position(if self.legend_lower_right {
                        SeriesLabelPosition::LowerRight
                    } else {
                        SeriesLabelPosition::UpperRight
                    })
                    .draw()
                    .map_err(|e| plot_err(name, e))?;
            }
            root.present().map_err(|e| plot_err(name, e))?;
        }
        Ok(with_view_box(&svg, width, height))
    }
}

/// Adds a `viewBox` to plotters' root `<svg>` (it writes width and height only), so the picture scales.
fn with_view_box(svg: &str, width: u32, height: u32) -> String {
    match svg.find("<svg") {
        Some(i) if !svg[i..].split('>').next().unwrap_or("").contains("viewBox") => {
            let mut s = svg.to_string();
            s.insert_str(i + 4, &format!(" viewBox=\"0 0 {width} {height}\""));
            s
        }
        _ => svg.to_string(),
    }
}

/// Escapes text for XML and HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The picture of the pipeline's flow: the stages as boxes in order, with the files between them —
/// `(stage, what it writes)`; a skipped stage is drawn grey.
pub fn flow(stages: &[(String, String, bool)]) -> String {
    let (bw, bh, gap, per_row) = (190.0, 64.0, 36.0, 4usize);
    let rows = stages.len().div_ceil(per_row).max(1);
    let width = per_row as f64 * (bw + gap) + gap;
    let height = rows as f64 * (bh + 56.0) + 30.0;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width:.0}\" height=\"{height:.0}\" viewBox=\"0 0 {width:.0} {height:.0}\" font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<defs><marker id=\"arrow\" markerWidth=\"10\" markerHeight=\"8\" refX=\"9\" refY=\"4\" orient=\"auto\"><path d=\"M0,0 L10,4 L0,8 z\" fill=\"#555\"/></marker></defs>\n"
    );
    let pos = |i: usize| {
        let row = i / per_row;
        // left to right, then right to left (a snake), so each arrow is short
        let col = if row % 2 == 0 {
            i % per_row
        } else {
            per_row - 1 - i % per_row
        };
        (
            gap + col as f64 * (bw + gap),
            20.0 + row as f64 * (bh + 56.0),
        )
    };
    for (i, (name, writes, ran)) in stages.iter().enumerate() {
        let (x, y) = pos(i);
        let (fill, stroke) = if *ran {
            ("#e8f1fb", "#1f77b4")
        } else {
            ("#f2f2f2", "#999999")
        };
        s.push_str(&format!(
            "<rect x=\"{x:.0}\" y=\"{y:.0}\" width=\"{bw:.0}\" height=\"{bh:.0}\" rx=\"8\" fill=\"{fill}\" stroke=\"{stroke}\" stroke-width=\"1.5\"/>\n<text x=\"{:.0}\" y=\"{:.0}\" font-size=\"15\" font-weight=\"bold\" text-anchor=\"middle\">{}. {}</text>\n<text x=\"{:.0}\" y=\"{:.0}\" font-size=\"11\" text-anchor=\"middle\" fill=\"#444\">{}</text>\n",
            x + bw / 2.0,
            y + 26.0,
            i + 1,
            escape(name),
            x + bw / 2.0,
            y + 46.0,
            escape(&truncate(writes, 30))
        ));
        if i + 1 < stages.len() {
            let (nx, ny) = pos(i + 1);
            let (x1, y1, x2, y2) = if (ny - y).abs() < 1.0 {
                if nx > x {
                    (x + bw, y + bh / 2.0, nx, ny + bh / 2.0)
                } else {
                    (x, y + bh / 2.0, nx + bw, ny + bh / 2.0)
                }
            } else {
                (x + bw / 2.0, y + bh, nx + bw / 2.0, ny)
            };
            s.push_str(&format!(
                "<line x1=\"{x1:.0}\" y1=\"{y1:.0}\" x2=\"{x2:.0}\" y2=\"{y2:.0}\" stroke=\"#555\" stroke-width=\"1.5\" marker-end=\"url(#arrow)\"/>\n"
            ));
        }
    }
    s.push_str("</svg>\n");
    s
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let t: String = s.chars().take(n - 1).collect();
        format!("{t}…")
    }
}
