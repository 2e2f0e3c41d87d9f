//! Across units (issue 50): each unit's estimate, the between-unit scatter and the new unit's
//! prediction interval, as text and drawn.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use millcomp_identify::targets::wear::ChannelAcross;
use millcomp_identify::units::AcrossUnits;

use crate::cmd::record::WearUnit;
use crate::present::plot::{Series, line_plot};

/// `x` to 4 significant digits (scientific beyond 1e5 or below 1e-3).
pub fn sig(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        return format!("{x:.3e}");
    }
    let d = if a == 0.0 {
        3
    } else {
        (3 - a.log10().floor() as i32).max(0) as usize
    };
    format!("{x:.d$}")
}

fn interval(ci: [f64; 2]) -> String {
    format!("[{}, {}]", sig(ci[0]), sig(ci[1]))
}

/// The across-units tables of one analysis.
pub fn across_text(a: &AcrossUnits) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "across {} units — {}", a.units.len(), a.method);
    let w = a
        .quantities
        .iter()
        .map(|q| q.name.len())
        .max()
        .unwrap_or(8)
        .max(8)
        + 2;
    let _ = write!(s, "{:<w$}", "per unit (± its own SE)");
    for u in &a.units {
        let _ = write!(s, " {:>22}", format!("unit {u}"));
    }
    let _ = writeln!(s);
    for q in &a.quantities {
        let _ = write!(s, "{:<w$}", q.name);
        for e in &q.per_unit {
            let _ = write!(
                s,
                " {:>22}",
                format!("{} ± {}", sig(e.value), sig(e.std_err))
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "{:<w$} {:>28} {:>30} {:>7} {:>9} {:>30}",
        "quantity",
        "mean [95 % HKSJ]",
        "τ between units [95 % Q-prof.]",
        "I²",
        "p(Q)",
        "NEW UNIT [95 % prediction]"
    );
    for q in &a.quantities {
        let m = &q.meta;
        let _ = writeln!(
            s,
            "{:<w$} {:>28} {:>30} {:>7} {:>9} {:>30}",
            q.name,
            format!("{} {}", sig(m.mean), interval(m.ci95)),
            format!("{} {}", sig(m.tau), interval(m.tau_ci95)),
            format!("{:.1} %", 100.0 * m.i2),
            format!("{:.2e}", m.q_p),
            interval(m.new_unit.pi95),
        );
    }
    for n in &a.notes {
        let _ = writeln!(s, "note: {n}");
    }
    s
}

/// The wear run's across-units section: the units' wear ranges, then each channel's analysis.
pub fn wear_across_text(
    vb_ranges: &[(&str, Option<[f64; 2]>)],
    channels: &[ChannelAcross],
) -> String {
    let mut s = String::new();
    let Some(first) = channels.first() else {
        return s;
    };
    let ranges: Vec<String> = vb_ranges
        .iter()
        .map(|(u, r)| match r {
            Some(r) => format!("unit {u} {:.0}–{:.0} µm", r[0], r[1]),
            None => format!("unit {u} –"),
        })
        .collect();
    let _ = writeln!(
        s,
        "ACROSS UNITS: force against flank wear F = F0 + k·VB, unit by unit, and the force at VB = {} µm \
         (--at-vb-um; by default the middle of the wear range every unit covers, rounded to 10 µm); mean VB \
         {}",
        first.at_vb_um,
        ranges.join(", ")
    );
    for c in channels {
        let _ = writeln!(s, "\n[{}]", c.channel);
        s.push_str(&across_text(&c.across));
    }
    let _ = writeln!(s);
    s
}

/// Per channel: each unit's force against its mean flank wear, its fitted line, and the new unit's
/// 95 % prediction interval of the force at the stated wear (`wear_units_CHANNEL.svg`).
///
/// # Errors
/// A plot that cannot be written.
pub fn wear_units_plots(
    dir: &Path,
    units: &[WearUnit],
    channels: &[ChannelAcross],
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut out = Vec::new();
    for c in channels {
        let mut series = Vec::new();
        for u in units {
            let Some(st) = u.studies.iter().find(|s| s.channel == c.channel) else {
                continue;
            };
            let n = u.cut.len();
            let vb: Vec<f64> = (0..n)
                .map(|i| u.vb.iter().map(|v| v.1[i]).sum::<f64>() / u.vb.len().max(1) as f64)
                .collect();
            series.push(Series {
                label: format!("unit {}: measured", u.unit),
                points: vb
                    .iter()
                    .copied()
                    .zip(st.measured_n.iter().copied())
                    .collect(),
            });
            if let Some(fw) = &st.force_vs_wear {
                let (lo, hi) = vb
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                let line = |v: f64| fw.report.param("f0_n") + fw.report.param("k_n_per_um") * v;
                series.push(Series {
                    label: format!("unit {}: F0 + k·VB", u.unit),
                    points: vec![(lo, line(lo)), (hi, line(hi))],
                });
            }
        }
        let name = millcomp_identify::targets::wear::force_at_vb_name(c.at_vb_um);
        if let Some(q) = c.across.quantities.iter().find(|q| q.name == name) {
            let pi = q.meta.new_unit.pi95;
            series.push(Series {
                label: format!(
                    "new unit at VB {} µm: 95 % prediction [{}, {}] N",
                    c.at_vb_um,
                    sig(pi[0]),
                    sig(pi[1])
                ),
                points: vec![(c.at_vb_um, pi[0]), (c.at_vb_um, pi[1])],
            });
        }
        let p = dir.join(format!("wear_units_{}.svg", c.channel));
        line_plot(
            &p,
            &format!(
                "{}: force against flank wear, {} units",
                c.channel,
                c.across.units.len()
            ),
            "mean flank wear VB (µm)",
            "force (N)",
            &series,
        )?;
        out.push(p);
    }
    Ok(out)
}
