//! Text and plot of `millcomp parts`: per controller and part, the median peak-to-peak error, the gap to
//! the MPC given the true model, how often the identified intervals cover the truth; the shrink of each
//! controller's gap from part 1.

use std::fmt::Write;
use std::path::Path;

use millcomp_closedloop::parts::{PartSummary, REFERENCE};

use crate::present::plot::{Series, line_plot};

fn est(v: f64, ci: [f64; 2]) -> String {
    if ci[0].is_finite() {
        format!("{v:.2} [{:.2}, {:.2}]", ci[0], ci[1])
    } else {
        format!("{v:.2}")
    }
}

/// The table of a run-to-run study over `machines` seeds.
pub fn parts_text(scenario: &str, machines: u64, rows: &[PartSummary]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "run-to-run: `{scenario}` commissioned, {machines} machines; medians with 95 % intervals"
    );
    let _ = writeln!(
        s,
        "{:<16} {:>4} {:>22} {:>22} {:>9} {:>9} {:>9}",
        "controller",
        "part",
        "pp error um",
        "gap to true-model um",
        "rho cov",
        "c cov",
        "|rho err|"
    );
    for r in rows {
        let learner = r.controller != REFERENCE;
        let _ = writeln!(
            s,
            "{:<16} {:>4} {:>22} {:>22} {:>9} {:>9} {:>9}",
            r.controller,
            r.part,
            est(r.pp_error_um.value, r.pp_error_um.ci95),
            if learner {
                est(r.gap_um.value, r.gap_um.ci95)
            } else {
                "-".into()
            },
            if learner {
                format!("{}/{}", r.scale_covered, r.n)
            } else {
                "-".into()
            },
            if learner {
                format!("{}/{}", r.compliance_covered, r.n)
            } else {
                "-".into()
            },
            if learner && r.scale_error_rel.is_finite() {
                format!("{:.1} %", 100.0 * r.scale_error_rel)
            } else {
                "-".into()
            },
        );
    }
    let _ = writeln!(s);
    for name in controllers(rows) {
        if name == REFERENCE {
            continue;
        }
        let gaps: Vec<&PartSummary> = rows.iter().filter(|r| r.controller == name).collect();
        if let (Some(first), Some(last)) = (gaps.first(), gaps.last())
            && last.part > 1
        {
            let g1 = first.gap_um.value;
            let _ = writeln!(
                s,
                "{name}: gap to the true-model MPC {:.2} um at part 1 -> {:.2} um at part {} ({})",
                g1,
                last.gap_um.value,
                last.part,
                if g1 > 0.0 {
                    format!("shrunk {:.0} %", 100.0 * (1.0 - last.gap_um.value / g1))
                } else {
                    "no gap at part 1".into()
                }
            );
        }
    }
    let _ = writeln!(
        s,
        "rho = force scale / stiffness over the part-1 model (the groove sees only this ratio); c = \
         compliance per measured newton (tool compliance / force-sensor gain); cov = machines whose \
         interval after the part covers the truth"
    );
    s
}

fn controllers(rows: &[PartSummary]) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in rows {
        if !v.contains(&r.controller) {
            v.push(r.controller.clone());
        }
    }
    v
}

/// Median pp error per part, one line per controller (`parts.svg`).
///
/// # Errors
/// Drawing or writing the file.
pub fn parts_plot(path: &Path, scenario: &str, rows: &[PartSummary]) -> anyhow::Result<()> {
    let series: Vec<Series> = controllers(rows)
        .into_iter()
        .map(|name| Series {
            points: rows
                .iter()
                .filter(|r| r.controller == name)
                .map(|r| (r.part as f64, r.pp_error_um.value))
                .collect(),
            label: name,
        })
        .collect();
    line_plot(
        path,
        &format!("{scenario}: peak-to-peak error per part (median over machines)"),
        "part",
        "pp error (um)",
        &series,
    )
}
