//! `millcomp datasets figures`: the published figures as an aligned text table and as README's
//! markdown table.

use millcomp_closedloop::figures::{Computed, Label, PublishedFigure};

fn label_cell(f: &PublishedFigure) -> String {
    match f.note {
        Some(n) => format!("{} ({n})", f.label.as_str()),
        None => f.label.as_str().to_string(),
    }
}

fn fitted_on(f: &PublishedFigure) -> String {
    if f.fitted_on.is_empty() {
        "—".to_string()
    } else {
        f.fitted_on.join(", ")
    }
}

/// The aligned table: one row per figure, then each disagreement's reason and each recorded value's
/// test.
pub fn text(figs: &[PublishedFigure]) -> String {
    let head = [
        "name",
        "source",
        "published",
        "millcomp",
        "label",
        "computed",
    ];
    let rows: Vec<[String; 6]> = figs
        .iter()
        .map(|f| {
            [
                f.name.to_string(),
                f.source.to_string(),
                f.published.text.to_string(),
                f.millcomp.text.clone(),
                f.label.as_str().to_string(),
                match f.computed {
                    Computed::Live => "live",
                    Computed::LiveAndRecorded { .. } => "live + recorded",
                    _ => "recorded",
                }
                .to_string(),
            ]
        })
        .collect();
    let mut width = head.map(|h| h.chars().count());
    for r in &rows {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: &[String]| {
        let mut s = String::new();
        for (i, (c, w)) in cells.iter().zip(width).enumerate() {
            if i + 1 == cells.len() {
                s.push_str(c);
            } else {
                s.push_str(c);
                s.push_str(&" ".repeat(w - c.chars().count() + 2));
            }
        }
        s.push('\n');
        s
    };
    let mut out = line(&head.map(String::from));
    for r in &rows {
        out.push_str(&line(r));
    }
    out.push_str(
        "\nfitted on (the published figures whose values set a parameter it depends on):\n",
    );
    for f in figs {
        out.push_str(&format!("  {}: {}\n", f.name, fitted_on(f)));
    }
    let disagree: Vec<_> = figs
        .iter()
        .filter(|f| f.label == Label::Disagrees)
        .collect();
    if !disagree.is_empty() {
        out.push_str("\ndisagrees:\n");
        for f in disagree {
            if let Some(r) = &f.reason {
                out.push_str(&format!("  {}: {r}\n", f.name));
            }
        }
    }
    out.push_str("\nrecorded (the slow suite recomputes them: closedloop/tests/figures.rs):\n");
    for f in figs {
        if f.computed != Computed::Live {
            out.push_str(&format!("  {}: {}\n", f.name, f.computed));
        }
    }
    out
}

/// README's table: figure (source), published, millcomp, label, fitted on, computed, shown by.
pub fn markdown(figs: &[PublishedFigure]) -> String {
    let mut out = String::from(
        "| figure (source) | published | millcomp | label | fitted on | computed | shown by |\n|---|---|---|---|---|---|---|\n",
    );
    let mut last_command = "";
    for f in figs {
        let shown = if f.command == last_command {
            "the same".to_string()
        } else {
            format!("`{}`", f.command)
        };
        last_command = f.command;
        out.push_str(&format!(
            "| {} ({}) | {} | {} | {} | {} | {} | {} |\n",
            f.figure,
            f.source,
            f.published.text,
            f.millcomp.text,
            label_cell(f),
            fitted_on(f),
            f.computed,
            shown
        ));
    }
    out
}
