//! A DOE design and analysis as text (what `doe design` and `doe analyze` print without `--json`), and the
//! SVG plots of an analysis (plotters' SVG backend; no fonts needed): half-normal plot of effects, Pareto
//! chart, main-effects and interaction plots, residual plots. Each file is written atomically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};

use anyhow::{Context, Result};
use millcomp_doe::{Analysis, Design, EliminationStep, FactorCoding, resolution_roman};

use super::plot::write_svg;

/// A design's summary and run table: family, run count, resolution, blocks, replicates, seed; factors and
/// their letters; generators and defining relation; CCD axial distance; block generators; aliases up to
/// order 3; notes; then one row per run in run order with the actual levels.
pub fn design_text(d: &Design) -> String {
    let mut s = String::new();
    let _ = write!(s, "Design: {}   runs: {}", d.design, d.n_runs());
    if let Some(r) = d.resolution {
        let _ = write!(s, "   resolution: {}", resolution_roman(r));
    }
    if d.blocks > 1 {
        let _ = write!(s, "   blocks per replicate: {}", d.blocks);
    }
    if d.replicates > 1 {
        let _ = write!(s, "   replicates: {}", d.replicates);
    }
    let _ = writeln!(
        s,
        "   seed: {}{}",
        d.seed,
        if d.randomized {
            ""
        } else {
            " (not randomised)"
        }
    );
    let letters: Vec<String> = d
        .factors
        .iter()
        .map(|f| format!("{}={}", f.letter, f.name))
        .collect();
    let _ = writeln!(s, "Factors: {}", letters.join(", "));
    if !d.generators.is_empty() {
        let _ = writeln!(s, "Generators: {}", d.generators.join(", "));
        let _ = writeln!(s, "Defining relation: {}", d.defining_relation.join(" "));
    }
    if let Some(a) = d.alpha {
        let _ = writeln!(
            s,
            "Axial distance alpha: {a:.6} ({})",
            d.variant.unwrap_or("")
        );
    }
    if !d.block_generators.is_empty() {
        let _ = writeln!(
            s,
            "Block generators: {}   confounded with blocks: {}",
            d.block_generators.join(", "),
            d.confounded_with_blocks.join(", ")
        );
    }
    if !d.alias_structure.is_empty() {
        let _ = writeln!(s, "Aliases (up to order 3):");
        for a in &d.alias_structure {
            let _ = writeln!(s, "  {} = {}", a.term, a.aliases.join(" = "));
        }
    }
    for n in &d.notes {
        let _ = writeln!(s, "Note: {n}");
    }
    let w: Vec<usize> = d
        .factors
        .iter()
        .map(|f| f.name.chars().count().max(8))
        .collect();
    let _ = write!(s, "{:>5} {:>5} {:>5}", "run", "std", "block");
    for (f, w) in d.factors.iter().zip(&w) {
        let _ = write!(s, " {}", pad_left(&f.name, *w));
    }
    let _ = writeln!(s);
    for r in &d.runs {
        let _ = write!(s, "{:>5} {:>5} {:>5}", r.run_order, r.std_order, r.block);
        for (v, w) in r.actual.iter().zip(&w) {
            let _ = write!(s, " {}", pad_left(&v.to_string(), *w));
        }
        let _ = writeln!(s);
    }
    s
}

/// `text` right-aligned in `width` characters. Padding is built here rather than by `format!`'s width,
/// which panics beyond 65 535 (a user's 70 000-character column name).
fn pad_left(text: &str, width: usize) -> String {
    let n = text.chars().count();
    format!("{}{text}", " ".repeat(width.saturating_sub(n)))
}

/// `text` left-aligned in `width` characters (see [`pad_left`]).
fn pad_right(text: &str, width: usize) -> String {
    let n = text.chars().count();
    format!("{text}{}", " ".repeat(width.saturating_sub(n)))
}

/// The steps of a backward elimination, one line per removed term with its p-value (`-` when it was pooled
/// from a saturated model), followed by an empty line.
pub fn elimination_text(steps: &[EliminationStep]) -> String {
    let mut s = String::new();
    for step in steps {
        let _ = writeln!(
            s,
            "removed {:<16} p = {}",
            step.removed,
            step.p_value.map_or("-".to_string(), |p| format!("{p:.4}"))
        );
    }
    let _ = writeln!(s);
    s
}

/// An analysis as text: the effects/ANOVA table (`*` p < 0.05, `**` p < 0.01), fit statistics, lack of fit,
/// Lenth's margins and active effects, outlying runs and notes.
pub fn analysis_text(a: &Analysis) -> String {
    let opt = |v: Option<f64>, w: usize, p: usize| match v {
        Some(x) => format!("{x:>w$.p$}"),
        None => format!("{:>w$}", "-"),
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Response: {}   runs: {}   model: {}",
        a.response, a.n_runs, a.model
    );
    let tw = a
        .terms
        .iter()
        .map(|t| t.term.chars().count())
        .max()
        .unwrap_or(4)
        .max(9);
    let _ = writeln!(
        s,
        "{} {:>11} {:>11} {:>10} {:>3} {:>12} {:>10} {:>10}",
        pad_right("Term", tw),
        "Effect",
        "Coef",
        "SE Coef",
        "DF",
        "Sum Sq",
        "F",
        "p-value"
    );
    for t in &a.terms {
        let star = match t.p_value {
            Some(p) if p < 0.01 => " **",
            Some(p) if p < 0.05 => " *",
            _ => "",
        };
        let _ = writeln!(
            s,
            "{} {} {} {} {:>3} {:>12.6} {} {}{star}",
            pad_right(&t.term, tw),
            opt(t.effect, 11, 5),
            opt(t.coef, 11, 5),
            opt(t.std_err, 10, 5),
            t.df,
            t.sum_sq,
            opt(t.f, 10, 3),
            opt(t.p_value, 10, 6),
        );
    }
    let _ = writeln!(
        s,
        "{} {:>11} {:>11} {:>10} {:>3} {:>12.6}",
        pad_right("Residual", tw),
        "",
        "",
        "",
        a.residual_df,
        a.residual_sum_sq
    );
    let _ = writeln!(
        s,
        "S = {}   R² = {:.4}   adj R² = {}   pred R² = {}",
        opt(a.sigma, 0, 5).trim(),
        a.r_squared,
        opt(a.adj_r_squared, 0, 4).trim(),
        opt(a.pred_r_squared, 0, 4).trim()
    );
    if let Some(l) = &a.lack_of_fit {
        let _ = writeln!(
            s,
            "Lack of fit: F({}, {}) = {:.4}, p = {:.4}   (pure error SS {:.6})",
            l.lack_of_fit_df, l.pure_error_df, l.f, l.p_value, l.pure_error_ss
        );
    }
    if let Some(l) = &a.lenth {
        let _ = writeln!(
            s,
            "Lenth: PSE = {:.5}, ME = {:.5}, SME = {:.5} (d = {:.2})",
            l.pse, l.me, l.sme, l.df
        );
        for t in l.terms.iter().filter(|t| t.exceeds_me) {
            let _ = writeln!(
                s,
                "  active: {} (effect {:.5}{})",
                t.term,
                t.effect,
                if t.exceeds_sme { ", > SME" } else { "" }
            );
        }
    }
    if !a.diagnostics.outliers.is_empty() {
        let _ = writeln!(
            s,
            "Runs with |studentised residual| > 3: {:?}",
            a.diagnostics.outliers
        );
    }
    for n in &a.notes {
        let _ = writeln!(s, "Note: {n}");
    }
    s
}

fn perr<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> anyhow::Error + '_ {
    move |e| anyhow::anyhow!("plot {}: {e}", path.display())
}

fn pad(lo: f64, hi: f64) -> (f64, f64) {
    if hi.is_nan() || lo.is_nan() || hi <= lo {
        return (lo - 1.0, hi + 1.0);
    }
    let d = 0.08 * (hi - lo);
    (lo - d, hi + d)
}

fn std_normal() -> Normal {
    Normal::standard()
}

/// Effects of single-df, non-square terms: (name, effect).
fn effects(a: &Analysis) -> Vec<(String, f64)> {
    a.terms
        .iter()
        .filter_map(|t| t.effect.map(|e| (t.term.clone(), e)))
        .collect()
}

fn half_normal(a: &Analysis, path: &Path) -> Result<bool> {
    let mut e = effects(a);
    if e.len() < 2 {
        return Ok(false);
    }
    e.sort_by(|x, y| x.1.abs().total_cmp(&y.1.abs()));
    let m = e.len();
    let nrm = std_normal();
    let pts: Vec<(f64, f64, String)> = e
        .iter()
        .enumerate()
        .map(|(i, (n, v))| {
            (
                v.abs(),
                nrm.inverse_cdf(0.5 + 0.5 * (i as f64 + 0.5) / m as f64),
                n.clone(),
            )
        })
        .collect();
    let xmax = pts.iter().map(|p| p.0).fold(0.0, f64::max);
    let ymax = pts.iter().map(|p| p.1).fold(0.0, f64::max);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 600)).into_drawing_area();
        root.fill(&WHITE).map_err(perr(path))?;
        let mut ch = ChartBuilder::on(&root)
            .caption(
                format!("Half-normal plot of effects: {}", a.response),
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..xmax * 1.25 + 1e-12, 0.0..ymax * 1.1 + 0.1)
            .map_err(perr(path))?;
        ch.configure_mesh()
            .x_desc("|effect|")
            .y_desc("half-normal quantile")
            .draw()
            .map_err(perr(path))?;
        ch.draw_series(
            pts.iter()
                .map(|(x, y, _)| Circle::new((*x, *y), 4, BLUE.filled())),
        )
        .map_err(perr(path))?;
        ch.draw_series(
            pts.iter()
                .map(|(x, y, n)| Text::new(n.clone(), (*x, *y), ("sans-serif", 12))),
        )
        .map_err(perr(path))?;
        if let Some(l) = &a.lenth {
            ch.draw_series(LineSeries::new(
                vec![(l.me, 0.0), (l.me, ymax * 1.1)],
                RED.stroke_width(1),
            ))
            .map_err(perr(path))?
            .label("Lenth ME");
            ch.draw_series(LineSeries::new(
                vec![(l.sme, 0.0), (l.sme, ymax * 1.1)],
                MAGENTA.stroke_width(1),
            ))
            .map_err(perr(path))?
            .label("Lenth SME");
        }
        root.present().map_err(perr(path))?;
    }
    write_svg(path, &svg)?;
    Ok(true)
}

fn pareto(a: &Analysis, path: &Path) -> Result<bool> {
    // Standardised effects |t| when there is error df, otherwise |effect| with Lenth's margins.
    type Bars = (Vec<(String, f64)>, Vec<(f64, &'static str)>, &'static str);
    let (mut bars, reference, xdesc): Bars = if a.residual_df > 0 {
        let b = a
            .terms
            .iter()
            .filter_map(|t| match (t.coef, t.std_err) {
                (Some(c), Some(s)) if s > 0.0 => Some((t.term.clone(), (c / s).abs())),
                _ => t.f.map(|f| (t.term.clone(), f.sqrt())),
            })
            .collect();
        let tcrit = statrs::distribution::StudentsT::new(0.0, 1.0, a.residual_df as f64)
            .map(|t| t.inverse_cdf(0.975))
            .unwrap_or(2.0);
        (b, vec![(tcrit, "t(0.975)")], "|standardised effect| (t)")
    } else {
        let r = a
            .lenth
            .as_ref()
            .map(|l| vec![(l.me, "ME"), (l.sme, "SME")])
            .unwrap_or_default();
        (
            effects(a).into_iter().map(|(n, e)| (n, e.abs())).collect(),
            r,
            "|effect|",
        )
    };
    if bars.is_empty() {
        return Ok(false);
    }
    bars.sort_by(|x, y| x.1.total_cmp(&y.1));
    let m = bars.len() as f64;
    let xmax = bars
        .iter()
        .map(|b| b.1)
        .chain(reference.iter().map(|r| r.0))
        .fold(0.0, f64::max)
        * 1.15
        + 1e-12;
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (800, (120.0 + 28.0 * m) as u32)).into_drawing_area();
        root.fill(&WHITE).map_err(perr(path))?;
        let mut ch = ChartBuilder::on(&root)
            .caption(
                format!("Pareto chart of effects: {}", a.response),
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(10)
            .build_cartesian_2d(0.0..xmax, 0.0..m)
            .map_err(perr(path))?;
        ch.configure_mesh()
            .disable_y_mesh()
            .y_labels(0)
            .x_desc(xdesc)
            .draw()
            .map_err(perr(path))?;
        ch.draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
            Rectangle::new(
                [(0.0, i as f64 + 0.15), (*v, i as f64 + 0.85)],
                BLUE.mix(0.6).filled(),
            )
        }))
        .map_err(perr(path))?;
        ch.draw_series(bars.iter().enumerate().map(|(i, (n, _))| {
            Text::new(
                n.clone(),
                (xmax * 0.01, i as f64 + 0.75),
                ("sans-serif", 12),
            )
        }))
        .map_err(perr(path))?;
        for (v, label) in &reference {
            ch.draw_series(LineSeries::new(
                vec![(*v, 0.0), (*v, m)],
                RED.stroke_width(1),
            ))
            .map_err(perr(path))?;
            ch.draw_series(std::iter::once(Text::new(
                label.to_string(),
                (*v, m - 0.1),
                ("sans-serif", 12),
            )))
            .map_err(perr(path))?;
        }
        root.present().map_err(perr(path))?;
    }
    write_svg(path, &svg)?;
    Ok(true)
}

/// Distinct coded levels of factor `f` and the mean response at each.
fn level_means(a: &Analysis, f: usize, rows: &[usize]) -> Vec<(f64, f64)> {
    let x = a.coded_factor(f);
    let mut lv: Vec<f64> = rows.iter().map(|&i| x[i]).collect();
    lv.sort_by(|a, b| a.total_cmp(b));
    lv.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    lv.iter()
        .map(|&l| {
            let sel: Vec<f64> = rows
                .iter()
                .filter(|&&i| (x[i] - l).abs() < 1e-9)
                .map(|&i| a.response_values()[i])
                .collect();
            (l, sel.iter().sum::<f64>() / sel.len().max(1) as f64)
        })
        .collect()
}

fn factor_axis_label(c: &FactorCoding) -> String {
    match c {
        FactorCoding::Numeric {
            name, low, high, ..
        } => format!("{name} (coded; −1 = {low}, +1 = {high})"),
        FactorCoding::Label { name, levels } => format!("{name} ({})", levels.join(" → ")),
    }
}

fn main_effects(a: &Analysis, path: &Path) -> Result<bool> {
    let k = a.factors.len();
    let n = a.n_runs;
    let all: Vec<usize> = (0..n).collect();
    let ymin = a
        .response_values()
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min);
    let ymax = a
        .response_values()
        .iter()
        .cloned()
        .fold(f64::NEG_INFINITY, f64::max);
    let (y0, y1) = pad(ymin, ymax);
    let cols = k.min(3);
    let rows = k.div_ceil(cols);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (360 * cols as u32, 300 * rows as u32 + 40))
            .into_drawing_area();
        root.fill(&WHITE).map_err(perr(path))?;
        let (title, body) = root.split_vertically(40);
        title
            .draw(&Text::new(
                format!("Main effects: mean of {}", a.response),
                (10, 10),
                ("sans-serif", 20),
            ))
            .map_err(perr(path))?;
        let panels = body.split_evenly((rows, cols));
        for (f, panel) in panels.iter().enumerate().take(k) {
            let pts = level_means(a, f, &all);
            let mut ch = ChartBuilder::on(panel)
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(45)
                .build_cartesian_2d(-1.2..1.2, y0..y1)
                .map_err(perr(path))?;
            ch.configure_mesh()
                .x_desc(factor_axis_label(&a.factors[f]))
                .x_labels(5)
                .draw()
                .map_err(perr(path))?;
            line_with_markers(&mut ch, &pts, BLUE, path)?;
        }
        root.present().map_err(perr(path))?;
    }
    write_svg(path, &svg)?;
    Ok(true)
}

/// A 2-px line through `pts` with a filled circle on each point (the main-effect and interaction plots).
fn line_with_markers(
    ch: &mut ChartContext<'_, SVGBackend<'_>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    pts: &[(f64, f64)],
    color: RGBColor,
    path: &Path,
) -> Result<()> {
    ch.draw_series(LineSeries::new(pts.to_vec(), color.stroke_width(2)))
        .map_err(perr(path))?;
    ch.draw_series(
        pts.iter()
            .map(|&(x, y)| Circle::new((x, y), 4, color.filled())),
    )
    .map_err(perr(path))?;
    Ok(())
}

fn interactions(a: &Analysis, path: &Path) -> Result<bool> {
    let k = a.factors.len();
    if k < 2 {
        return Ok(false);
    }
    let mut pairs = Vec::new();
    for i in 0..k {
        for j in i + 1..k {
            pairs.push((i, j));
        }
    }
    pairs.truncate(15);
    let n = a.n_runs;
    let ymin = a
        .response_values()
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min);
    let ymax = a
        .response_values()
        .iter()
        .cloned()
        .fold(f64::NEG_INFINITY, f64::max);
    let (y0, y1) = pad(ymin, ymax);
    let cols = pairs.len().min(3);
    let rows = pairs.len().div_ceil(cols);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (360 * cols as u32, 300 * rows as u32 + 40))
            .into_drawing_area();
        root.fill(&WHITE).map_err(perr(path))?;
        let (title, body) = root.split_vertically(40);
        title
            .draw(&Text::new(
                format!(
                    "Interactions: mean of {} (red: second factor low, blue: high)",
                    a.response
                ),
                (10, 10),
                ("sans-serif", 18),
            ))
            .map_err(perr(path))?;
        let panels = body.split_evenly((rows, cols));
        for (&(i, j), panel) in pairs.iter().zip(panels.iter()) {
            let xj = a.coded_factor(j);
            let lo = xj.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = xj.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let mut ch = ChartBuilder::on(panel)
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(45)
                .build_cartesian_2d(-1.2..1.2, y0..y1)
                .map_err(perr(path))?;
            ch.configure_mesh()
                .x_desc(format!("{} × {}", a.factors[i].name(), a.factors[j].name()))
                .x_labels(5)
                .draw()
                .map_err(perr(path))?;
            for (level, color) in [(lo, RED), (hi, BLUE)] {
                let rows_at: Vec<usize> =
                    (0..n).filter(|&r| (xj[r] - level).abs() < 1e-9).collect();
                if rows_at.is_empty() {
                    continue;
                }
                let pts = level_means(a, i, &rows_at);
                line_with_markers(&mut ch, &pts, color, path)?;
            }
        }
        root.present().map_err(perr(path))?;
    }
    write_svg(path, &svg)?;
    Ok(true)
}

fn residuals(a: &Analysis, path: &Path) -> Result<bool> {
    let d = &a.diagnostics.runs;
    if d.len() < 2 {
        return Ok(false);
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 450)).into_drawing_area();
        root.fill(&WHITE).map_err(perr(path))?;
        let (left, right) = root.split_horizontally(500);
        let fx: Vec<f64> = d.iter().map(|r| r.fitted).collect();
        let rs: Vec<f64> = d.iter().map(|r| r.residual).collect();
        let (x0, x1) = pad(
            fx.iter().cloned().fold(f64::INFINITY, f64::min),
            fx.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        );
        let rmax = rs.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-12) * 1.2;
        let mut ch = ChartBuilder::on(&left)
            .caption("Residuals vs fitted", ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(x0..x1, -rmax..rmax)
            .map_err(perr(path))?;
        ch.configure_mesh()
            .x_desc("fitted")
            .y_desc("residual")
            .draw()
            .map_err(perr(path))?;
        ch.draw_series(LineSeries::new(
            vec![(x0, 0.0), (x1, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(perr(path))?;
        ch.draw_series(
            fx.iter()
                .zip(&rs)
                .map(|(&x, &y)| Circle::new((x, y), 4, BLUE.filled())),
        )
        .map_err(perr(path))?;
        // Normal probability plot of residuals.
        let mut sorted = rs.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        let m = sorted.len();
        let nrm = std_normal();
        let q: Vec<(f64, f64)> = sorted
            .iter()
            .enumerate()
            .map(|(i, &r)| (r, nrm.inverse_cdf((i as f64 + 0.625) / (m as f64 + 0.25))))
            .collect();
        let qmax = q.iter().map(|p| p.1.abs()).fold(0.0, f64::max) * 1.2;
        let mut ch2 = ChartBuilder::on(&right)
            .caption("Normal probability plot of residuals", ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(-rmax..rmax, -qmax..qmax)
            .map_err(perr(path))?;
        ch2.configure_mesh()
            .x_desc("residual")
            .y_desc("normal quantile")
            .draw()
            .map_err(perr(path))?;
        ch2.draw_series(
            q.iter()
                .map(|&(x, y)| Circle::new((x, y), 4, BLUE.filled())),
        )
        .map_err(perr(path))?;
        root.present().map_err(perr(path))?;
    }
    write_svg(path, &svg)?;
    Ok(true)
}

/// The files [`write_doe_plots`] writes into its directory.
pub const DOE_PLOTS: [&str; 5] = [
    "half_normal.svg",
    "pareto.svg",
    "main_effects.svg",
    "interactions.svg",
    "residuals.svg",
];

/// Writes `half_normal.svg`, `pareto.svg`, `main_effects.svg`, `interactions.svg` and `residuals.svg` into
/// `dir` (created if missing) and returns the paths written (a plot that does not apply is skipped, e.g. the
/// half-normal plot without two-level effects).
pub fn write_doe_plots(a: &Analysis, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    type PlotFn = fn(&Analysis, &Path) -> Result<bool>;
    let plots: [PlotFn; 5] = [half_normal, pareto, main_effects, interactions, residuals];
    let mut out = Vec::new();
    for (name, f) in DOE_PLOTS.into_iter().zip(plots) {
        let p = dir.join(name);
        if f(a, &p)? {
            out.push(p);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_doe::{
        AnalysisInput, DesignKind, DesignRequest, FactorSpec, ModelSpec, analyze,
        backward_eliminate, generate,
    };

    fn clayton(response: &str, model: ModelSpec) -> AnalysisInput {
        let clayton = millcomp_datasets::load("clayton_doe").unwrap();
        let factors: Vec<String> = ["depth_um", "speed_rpm", "upfeed_um"]
            .map(String::from)
            .to_vec();
        AnalysisInput::from_table(
            &millcomp_datasets::adapters::doe_columns(&clayton),
            response,
            Some(&factors),
            model,
        )
        .unwrap()
    }

    #[test]
    fn design_as_text() {
        // Reference: the output of the README command `doe-design` (tools/readme-commands.txt) as printed
        // by `Design::human()` in millcomp-doe before this text moved to the CLI.
        let f = FactorSpec::parse_list(
            "depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20,wearland_um=4:12",
        )
        .unwrap();
        let mut req = DesignRequest::new(DesignKind::Fractional, f);
        req.resolution = Some(4);
        req.seed = Some(3);
        let t = design_text(&generate(&req).unwrap());
        assert!(
            t.starts_with(
                "Design: fractional   runs: 8   resolution: IV   seed: 3\n\
                 Factors: A=depth_um, B=speed_rpm, C=upfeed_um, D=wearland_um\n\
                 Generators: D=ABC\n\
                 Defining relation: I=ABCD\n\
                 Aliases (up to order 3):\n  depth_um = speed_rpm:upfeed_um:wearland_um\n"
            ),
            "{t}"
        );
        assert!(
            t.contains(
                "\n  run   std block depth_um speed_rpm upfeed_um wearland_um\n\
                 \x20   1     3     1      100     20000        10          12\n"
            ),
            "{t}"
        );
        assert!(
            t.ends_with("    8     2     1      200     10000        10          12\n"),
            "{t}"
        );
        // An unrandomised replicated design says so in the header.
        let mut req = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list("A,B").unwrap());
        req.replicates = 2;
        req.randomize = false;
        req.seed = Some(1);
        let t = design_text(&generate(&req).unwrap());
        assert!(
            t.starts_with("Design: full   runs: 8   replicates: 2   seed: 1 (not randomised)\n"),
            "{t}"
        );
    }

    #[test]
    fn analysis_and_elimination_as_text() {
        // Reference: the output of the README command `doe-analyze` (Clayton thesis, seed 000, Table 3-3) as
        // printed by `Analysis::human()` before this text moved to the CLI; F = 57.149 is statsmodels'
        // (doe's golden ANOVA test). The exact sums of squares of speed and upfeed are 0.0136125 and
        // 2.9646125 (8 · (effect/2)²): decimal ties at the sixth place, so that digit follows the last bit
        // of the f64 result — the ANOVA on the centred response (issue 18) prints 0.013612 and 2.964613.
        let t = analysis_text(&analyze(&clayton("max_fx_n", ModelSpec::Main)).unwrap());
        assert_eq!(
            t,
            "Response: max_fx_n   runs: 8   model: depth_um + speed_rpm + upfeed_um\n\
             Term           Effect        Coef    SE Coef  DF       Sum Sq          F    p-value\n\
             depth_um      1.28250     0.64125    0.08483   1     3.289612     57.149   0.001641 **\n\
             speed_rpm     0.08250     0.04125    0.08483   1     0.013612      0.236   0.652199\n\
             upfeed_um     1.21750     0.60875    0.08483   1     2.964613     51.502   0.001997 **\n\
             Residual                                       4     0.230250\n\
             S = 0.23992   R² = 0.9646   adj R² = 0.9380   pred R² = 0.8583\n"
        );
        // `doe analyze … --response max_fy_n --model full --reduce` before the move: the saturated
        // three-factor interaction is pooled first (no p-value), then the two 2FIs with p > 0.05.
        let e = backward_eliminate(&clayton("max_fy_n", ModelSpec::Full), 0.05).unwrap();
        assert_eq!(
            elimination_text(&e.steps),
            "removed depth_um:speed_rpm:upfeed_um p = -\n\
             removed depth_um:speed_rpm p = 0.7683\n\
             removed depth_um:upfeed_um p = 0.1453\n\n"
        );
    }

    #[test]
    fn plots_are_written_as_svg() {
        // Montgomery, Design and Analysis of Experiments, Example 6.2 (the filtration-rate 2^4)
        let table = millcomp_datasets::read_any(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/doe/tests/fixtures/montgomery_example_6_2.csv"
        )))
        .unwrap();
        let table = millcomp_datasets::adapters::doe_columns(&table);
        let a = analyze(
            &AnalysisInput::from_table(&table, "filtration_rate", None, ModelSpec::Full).unwrap(),
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files = write_doe_plots(&a, dir.path()).unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            vec![
                "half_normal.svg",
                "pareto.svg",
                "main_effects.svg",
                "interactions.svg",
                "residuals.svg"
            ]
        );
        for f in &files {
            let s = std::fs::read_to_string(f).unwrap();
            assert!(s.starts_with("<svg"), "{}", f.display());
            assert!(s.len() > 1000);
        }
        let hn = std::fs::read_to_string(&files[0]).unwrap();
        assert!(hn.contains("A:C") && hn.contains("Half-normal"));
        // The saturated model's text shows Lenth's margins (PSE 2.625: Montgomery, Example 6.2; ME and SME
        // as in doe's golden test, tests/golden/lenth.json) and the effects above them.
        let t = analysis_text(&a);
        assert!(
            t.contains(
                "Lenth: PSE = 2.62500, ME = 6.74778, SME = 13.69896 (d = 5.00)\n\
                 \x20 active: A (effect 21.62500, > SME)\n\
                 \x20 active: C (effect 9.87500)\n"
            ),
            "{t}"
        );
        assert!(t.ends_with("see `lenth`\n"), "{t}");
        // A model with error df draws the Pareto of |t|.
        let clayton = millcomp_datasets::load("clayton_doe").unwrap();
        let factors: Vec<String> = ["depth_um", "speed_rpm", "upfeed_um"]
            .map(String::from)
            .to_vec();
        let b = analyze(
            &AnalysisInput::from_table(
                &millcomp_datasets::adapters::doe_columns(&clayton),
                "max_fz_n",
                Some(&factors),
                ModelSpec::Main,
            )
            .unwrap(),
        )
        .unwrap();
        let files = write_doe_plots(&b, &dir.path().join("z")).unwrap();
        assert_eq!(files.len(), 5);
    }
}
