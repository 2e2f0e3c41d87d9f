//! Issue 16's study of the NC feed-axis stage (003): every "Must show" figure, medians with
//! distribution-free 95 % intervals over seeds, next to the stage's references
//! (`millcomp_closedloop::nc_axis_bound`: the physical limit of any controller correcting the y
//! reference once per NC cycle, and the certainty-equivalent wall of one that knows the measured force
//! in advance but the stiffness only as commissioned).
//!
//! `cargo run --release -p millcomp-closedloop --example nc_axis_study -- [--seeds N] [--band-seeds M]
//! [--out DIR] [--sections 1,2,…]` (default: all seven sections below, the figure in `nc_axis_study/`)
//!
//! 1. The published groove (`nc_c45_feed_step.toml`: feed 500 → 1000 mm/min at 90 mm, exit at 185 mm)
//!    with `none`, `reactive`, `proactive`, `mpc` over seeds 1..=N (default 10): static error removed,
//!    the feed step's peak and excess, the ringing of the correction, the exit's undersize, the
//!    deflection step (a model output), per seed the ratios proactive/reactive and mpc/proactive, and
//!    the references.
//! 2. The band: machine stiffness 20 / 30 / 50 N/µm × overhang 3 / 3.5 / 4 D, seeds 1..=M (default 3)
//!    at each point; per point the median of each figure; the band is their range.
//! 3. The exit alone (`nc_c45_exit.toml`) over seeds 1..=N.
//! 4. Ablation: the proactive offset curve superimposed only while the reference acceleration is
//!    non-zero (the literal reading of 003 Fig. 3's caption) on the published groove.
//! 5. What each of the MPC's parts buys: the shipped MPC against it without planning for the wall
//!    instants, with the dead time + lag axis model instead of the measured step response, and with
//!    each tooth's offset planned times the wall's engagement instead of through its chip, on the
//!    groove and the exit, seeds 1..=N.
//! 6. The NC's feed change: the published groove with the feed change limited in acceleration only
//!    (no jerk limit, 4.2 ms instead of 25.8 ms) — 003 names neither; seeds 1..=N — and the reactive
//!    controller's actuating value after the step under both, normalised, beside the notch chain's
//!    own response to a force step (`DIR/ringing.csv`, `DIR/ringing.svg`, seed 1).
//! 7. Convergence of the truth's force model at the exit: the groove with the cutting edge in 8 axial
//!    elements (the default before) instead of 32, seeds 1..=N.
//! 8. Only with `--sections 8` (not in the default): 003's two disagreements (the proactive peak, the
//!    notch chain's oscillation; docs/studies/published-nc.md) — the published groove on candidate
//!    machines: the feed axes' split of 003's 16 ms into dead time and position-loop lag, the NC's
//!    path dynamics of the feed change (jerk and acceleration limits) and the tool's runout; reactive
//!    and proactive over seeds 1..=N, the reactive actuating value's ringing and the x axis' feed
//!    rise on seed 1.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use millcomp_closedloop::compare::median_ci95;
use millcomp_closedloop::nc_axis::NcAxisModel;
use millcomp_closedloop::{
    ControllerKind, RunReport, Scenario, run_scenario, run_scenario_with_trace,
};
use millcomp_mpc::nc_axis::{OffsetWindow, ToothOffsets};
use millcomp_sim::nc_axis::AxisDynamics;
use rayon::prelude::*;

const KINDS: [ControllerKind; 4] = [
    ControllerKind::None,
    ControllerKind::Reactive,
    ControllerKind::Proactive,
    ControllerKind::Mpc,
];

type Figures = BTreeMap<&'static str, f64>;

fn figures(r: &RunReport) -> Figures {
    let w = &r.nc_axis.as_ref().expect("an nc_axis run").wall;
    let mut f = Figures::new();
    f.insert("static_removed_pct", w.static_removed_pct);
    f.insert("static_error_um", w.static_error_um);
    f.insert("exit_undersize_um", w.exit_undersize_um);
    f.insert("exit_min_um", w.exit_min_um);
    f.insert("exit_max_um", w.exit_max_um);
    let ce = w.certainty_equivalent;
    for (k, v) in [
        ("feed_step_peak_um", w.feed_step_peak_um),
        ("feed_step_excess_um", w.feed_step_excess_um),
        ("ringing_um", w.feed_step_oscillation_um),
        ("deflection_step_um", w.deflection_step_um),
        ("feed_step_peak_bound_um", w.feed_step_peak_bound_um),
        ("feed_step_excess_bound_um", w.feed_step_excess_bound_um),
        ("exit_bound_um", w.exit_bound_um),
        ("ce_static_error_um", ce.map(|c| c.static_error_um)),
        ("ce_feed_step_peak_um", ce.and_then(|c| c.feed_step_peak_um)),
        (
            "ce_feed_step_excess_um",
            ce.and_then(|c| c.feed_step_excess_um),
        ),
        ("ce_exit_undersize_um", ce.map(|c| c.exit_undersize_um)),
        ("ce_exit_max_um", ce.map(|c| c.exit_max_um)),
    ] {
        if let Some(v) = v {
            f.insert(k, v);
        }
    }
    f
}

/// Run `kinds` × `seeds` on `s` in parallel: (kind, seed) → figures.
fn runs(
    s: &Scenario,
    kinds: &[ControllerKind],
    seeds: &[u64],
    done: &AtomicUsize,
) -> Result<BTreeMap<(usize, u64), Figures>, String> {
    let jobs: Vec<(usize, u64)> = (0..kinds.len())
        .flat_map(|k| seeds.iter().map(move |&sd| (k, sd)))
        .collect();
    jobs.par_iter()
        .map(|&(k, sd)| {
            let mut sc = s.clone();
            sc.seed = sd;
            let r = run_scenario(&sc, kinds[k])
                .map_err(|e| format!("{} {} seed {sd}: {e}", s.name, kinds[k]))?;
            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
            if n % 20 == 0 {
                eprintln!("  {n} runs");
            }
            Ok(((k, sd), figures(&r)))
        })
        .collect()
}

fn med_ci(mut v: Vec<f64>) -> (f64, [f64; 2]) {
    v.retain(|x| x.is_finite());
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return (f64::NAN, [f64::NAN; 2]);
    }
    let n = v.len();
    let m = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    (m, median_ci95(&v))
}

fn cell(v: Vec<f64>) -> String {
    let (m, ci) = med_ci(v);
    if ci.iter().all(|c| c.is_finite()) {
        format!("{m:.2} [{:.2}, {:.2}]", ci[0], ci[1])
    } else {
        // too few seeds for an interval of the median
        format!("{m:.2}")
    }
}

fn column(r: &BTreeMap<(usize, u64), Figures>, k: usize, seeds: &[u64], name: &str) -> Vec<f64> {
    seeds
        .iter()
        .filter_map(|sd| r.get(&(k, *sd)).and_then(|f| f.get(name)).copied())
        .collect()
}

fn ratio(
    r: &BTreeMap<(usize, u64), Figures>,
    num: usize,
    den: usize,
    seeds: &[u64],
    name: &str,
) -> Vec<f64> {
    seeds
        .iter()
        .filter_map(|sd| {
            let a = r.get(&(num, *sd))?.get(name)?;
            let b = r.get(&(den, *sd))?.get(name)?;
            Some(a / b)
        })
        .collect()
}

/// A markdown table: one row per figure, one column per controller of `kinds` (named `labels`).
fn table(r: &BTreeMap<(usize, u64), Figures>, labels: &[&str], seeds: &[u64], names: &[&str]) {
    println!("| figure | {} |", labels.join(" | "));
    println!("|---|{}", "---|".repeat(labels.len()));
    for name in names {
        let cells: Vec<String> = (0..labels.len())
            .map(|k| cell(column(r, k, seeds, name)))
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}

/// The references of a run set (the same for every controller of a seed: taken from `kind`'s runs).
fn references(r: &BTreeMap<(usize, u64), Figures>, kind: usize, seeds: &[u64], names: &[&str]) {
    let cells: Vec<String> = names
        .iter()
        .map(|n| format!("{n} {}", cell(column(r, kind, seeds, n))))
        .collect();
    println!("references: {}", cells.join("; "));
}

/// The reactive controller's actuating value (the correction it commands, per NC cycle) from 10 ms
/// before to 200 ms after the first feed change starts, on `s` seed 1, normalised: 0 before the
/// change (its mean over the 10 ms), 1 after it (its mean from 150 to 200 ms).
fn actuating_after_step(s: &Scenario) -> Result<Vec<(f64, f64)>, Box<dyn std::error::Error>> {
    Ok(step_traces(s)?.0)
}

/// [`actuating_after_step`] and the x axis' actual feed over the same window (from its encoder,
/// per cycle), normalised the same way, with its 10–90 % rise time (ms).
type StepTraces = (Vec<(f64, f64)>, Vec<(f64, f64)>, f64);

fn step_traces(s: &Scenario) -> Result<StepTraces, Box<dyn std::error::Error>> {
    let mut sc = s.clone();
    sc.seed = 1;
    let out = run_scenario_with_trace(&sc, ControllerKind::Reactive)?;
    let col = |name: &str| {
        out.trace
            .columns
            .iter()
            .position(|c| c == name)
            .ok_or(format!("no {name} column"))
    };
    let (ia, iu) = (col("a_cmd_mm_s2")?, col("correction_um")?);
    let cycle = sc.nc_axis.as_ref().ok_or("no [nc_axis]")?.program.cycle_s;
    let c = |t: f64| (t / cycle).round() as usize;
    let start = out
        .trace
        .rows
        .iter()
        .position(|r| r[ia] != 0.0)
        .ok_or("no feed change")?;
    let rows = out
        .trace
        .rows
        .get(start - c(0.01)..start + c(0.2))
        .ok_or("trace too short")?;
    let u: Vec<f64> = rows.iter().map(|r| r[iu]).collect();
    // the actual feed from the x encoder: the difference to the next cycle
    let ix = col("x_mm")?;
    let all = &out.trace.rows;
    let v: Vec<f64> = (start - c(0.01)..start + c(0.2))
        .map(|k| (all[k + 1][ix] - all[k][ix]) / cycle)
        .collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let norm = |u: &[f64]| {
        let (u0, u1) = (mean(&u[..c(0.01)]), mean(&u[c(0.16)..]));
        u.iter()
            .enumerate()
            .map(|(i, v)| {
                (
                    (i as f64 - c(0.01) as f64) * cycle * 1e3,
                    (v - u0) / (u1 - u0),
                )
            })
            .collect::<Vec<_>>()
    };
    let feed = norm(&v);
    let cross = |level: f64| {
        feed.iter()
            .position(|p| p.1 >= level)
            .map_or(f64::NAN, |i| feed[i].0)
    };
    let rise = cross(0.9) - cross(0.1);
    Ok((norm(&u), feed, rise))
}

/// The notch chain + low-pass of 003 (the reactive controller's filter) fed a force step at t = 0,
/// read every NC cycle, from −10 to 200 ms.
fn chain_step(s: &Scenario) -> Result<Vec<(f64, f64)>, Box<dyn std::error::Error>> {
    let nc = s.nc_axis.as_ref().ok_or("no [nc_axis]")?;
    let mut chain = nc.channel().chain()?;
    let per_cycle = (nc.program.cycle_s / nc.control.dt_s).round() as usize;
    let mut out = Vec::new();
    let mut last = 0.0;
    for k in 0..105 {
        let t_ms = (k as f64 - 5.0) * nc.program.cycle_s * 1e3;
        out.push((t_ms, last));
        for _ in 0..per_cycle {
            last = chain.step(if t_ms >= 0.0 { 1.0 } else { 0.0 });
        }
    }
    Ok(out)
}

/// The first overshoot beyond 1 and the undershoot after it of a normalised step response.
fn swing(v: &[(f64, f64)]) -> (f64, f64) {
    let Some(i) = v.iter().position(|p| p.1 >= 1.0) else {
        return (0.0, 0.0);
    };
    let (mut hi, mut at) = (1.0f64, i);
    for (j, p) in v.iter().enumerate().skip(i) {
        if p.1 > hi {
            hi = p.1;
            at = j;
        }
        if p.1 < 1.0 {
            break;
        }
    }
    let lo = v[at..].iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    (hi - 1.0, 1.0 - lo)
}

/// A line plot of `series` (label, points).
fn lines_svg(series: &[(String, Vec<(f64, f64)>)], title: &str, x_label: &str) -> String {
    let (w, h, l, r, t, b) = (900.0, 420.0, 70.0, 20.0, 40.0, 50.0);
    let all = || series.iter().flat_map(|s| s.1.iter().copied());
    let (x0, x1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y0, y1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let pad = 0.05 * (y1 - y0).max(1e-9);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let px = |x: f64| l + (w - l - r) * (x - x0) / (x1 - x0).max(1e-9);
    let py = |y: f64| h - b - (h - t - b) * (y - y0) / (y1 - y0);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(svg, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="14">{title}</text>"#,
        w / 2.0
    );
    for yv in [0.0, 1.0] {
        let _ = writeln!(
            svg,
            r##"<line x1="{l}" y1="{0:.1}" x2="{1}" y2="{0:.1}" stroke="#bbb" stroke-dasharray="4 3"/>"##,
            py(yv),
            w - r
        );
    }
    let _ = writeln!(
        svg,
        r#"<line x1="{l}" y1="{0}" x2="{1}" y2="{0}" stroke="black"/><line x1="{l}" y1="{t}" x2="{l}" y2="{0}" stroke="black"/>"#,
        h - b,
        w - r
    );
    for k in 0..=5 {
        let xv = x0 + (x1 - x0) * k as f64 / 5.0;
        let yv = y0 + (y1 - y0) * k as f64 / 5.0;
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{}" text-anchor="middle">{xv:.0}</text><text x="{}" y="{:.1}" text-anchor="end">{yv:.2}</text>"#,
            px(xv),
            h - b + 16.0,
            l - 6.0,
            py(yv) + 4.0
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">{x_label}</text>"#,
        (l + w - r) / 2.0,
        h - 12.0
    );
    for (i, (label, v)) in series.iter().enumerate() {
        let color = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd"][i % 4];
        let pts: Vec<String> = v
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .map(|p| format!("{:.1},{:.1}", px(p.0), py(p.1)))
            .collect();
        let _ = writeln!(
            svg,
            r#"<polyline fill="none" stroke="{color}" stroke-width="1.5" points="{}"/>"#,
            pts.join(" ")
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" fill="{color}" text-anchor="end">{label}</text>"#,
            w - r - 8.0,
            h - b - 16.0 * (series.len() - i) as f64
        );
    }
    svg.push_str("</svg>\n");
    svg
}

/// One candidate machine for section 8: the feed axes' structure behind 003's 16 ms, the NC's path
/// dynamics of the feed change and the tool's runout.
struct Candidate {
    label: &'static str,
    /// Dead time (ms).
    dead_ms: f64,
    /// 1/kv (ms).
    lag_ms: f64,
    /// Velocity-loop time constant (ms).
    tv_ms: f64,
    /// Path acceleration (m/s²).
    accel_m_s2: f64,
    /// Path jerk (m/s³; infinite: acceleration-limited only).
    jerk_m_s3: f64,
    /// Runout (µm).
    runout_um: f64,
    /// Fine interpolation of the set-points over the NC cycle.
    fipo: bool,
}

impl Candidate {
    fn scenario(&self, base: &Scenario) -> Result<Scenario, String> {
        let mut s = base.clone();
        let nc = s.nc_axis.as_mut().ok_or("no [nc_axis]")?;
        nc.machine.axis.dead_time_s = self.dead_ms * 1e-3;
        nc.machine.axis.kv_per_s = 1e3 / self.lag_ms;
        nc.machine.axis.velocity_loop_s = self.tv_ms * 1e-3;
        nc.machine.axis.fine_interpolation = self.fipo;
        nc.program.path_accel_mm_s2 = self.accel_m_s2 * 1e3;
        nc.program.path_jerk_mm_s3 = if self.jerk_m_s3.is_finite() {
            self.jerk_m_s3 * 1e3
        } else {
            1e12
        };
        nc.machine.runout_um = self.runout_um;
        Ok(s)
    }
}

/// Section 8: every candidate machine on the published groove, `reactive` and `proactive` over
/// `seeds`, beside the reactive actuating value's ringing and the x axis' feed rise (seed 1).
fn candidates(
    groove: &Scenario,
    seeds: &[u64],
    band_seeds: &[u64],
    done: &AtomicUsize,
) -> Result<(), Box<dyn std::error::Error>> {
    let inf = f64::INFINITY;
    // the candidates of the diagnosis hold their set-points over the cycle (as it was run); the
    // shipped axis (the last two rows) fine-interpolates them
    let c = |label, dead_ms, lag_ms, tv_ms, accel_m_s2, jerk_m_s3, runout_um| Candidate {
        label,
        dead_ms,
        lag_ms,
        tv_ms,
        accel_m_s2,
        jerk_m_s3,
        runout_um,
        fipo: false,
    };
    let ff = AxisDynamics::speed_feedforward_003();
    let shipped = |label, runout_um| Candidate {
        label,
        dead_ms: ff.dead_time_s * 1e3,
        lag_ms: 1e3 / ff.kv_per_s,
        tv_ms: ff.velocity_loop_s * 1e3,
        accel_m_s2: 2.0,
        jerk_m_s3: 50.0,
        runout_um,
        fipo: ff.fine_interpolation,
    };
    let list = [
        c(
            "P loop 4 + 12 ms (shipped before), 2 m/s^2, 50 m/s^3",
            4.0,
            12.0,
            2.0,
            2.0,
            50.0,
            3.0,
        ),
        c("axis 8 + 8 ms", 8.0, 8.0, 2.0, 2.0, 50.0, 3.0),
        c("axis 10 + 6 ms", 10.0, 6.0, 1.5, 2.0, 50.0, 3.0),
        c(
            "axis 12 + 4 ms (feedforward)",
            12.0,
            4.0,
            1.0,
            2.0,
            50.0,
            3.0,
        ),
        c("axis 14 + 2 ms", 14.0, 2.0, 0.5, 2.0, 50.0, 3.0),
        c("jerk 200 m/s^3", 4.0, 12.0, 2.0, 2.0, 200.0, 3.0),
        c("no jerk limit, 1 m/s^2", 4.0, 12.0, 2.0, 1.0, inf, 3.0),
        c("no jerk limit, 2 m/s^2", 4.0, 12.0, 2.0, 2.0, inf, 3.0),
        c("no jerk limit, 5 m/s^2", 4.0, 12.0, 2.0, 5.0, inf, 3.0),
        c(
            "axis 12 + 4 ms, no jerk limit, 1 m/s^2",
            12.0,
            4.0,
            1.0,
            1.0,
            inf,
            3.0,
        ),
        c(
            "axis 12 + 4 ms, no jerk limit, 2 m/s^2",
            12.0,
            4.0,
            1.0,
            2.0,
            inf,
            3.0,
        ),
        c(
            "axis 12 + 4 ms, no jerk limit, 5 m/s^2",
            12.0,
            4.0,
            1.0,
            5.0,
            inf,
            3.0,
        ),
        c("runout 10 um", 4.0, 12.0, 2.0, 2.0, 50.0, 10.0),
        c(
            "axis 12 + 4 ms, runout 6 um",
            12.0,
            4.0,
            1.0,
            2.0,
            50.0,
            6.0,
        ),
        c(
            "axis 12 + 4 ms, runout 10 um",
            12.0,
            4.0,
            1.0,
            2.0,
            50.0,
            10.0,
        ),
        shipped("shipped: fine interpolation + 11 + 4 ms", 3.0),
        shipped("shipped, runout 10 um", 10.0),
    ];
    let n = seeds.len();
    println!(
        "\n## 8. 003's feed step: candidate machines, reactive and proactive over seeds 1..={n}; ringing and feed rise on seed 1"
    );
    println!(
        "| candidate | feed rise 10-90 % ms | reactive overshoot / undershoot % | reactive peak um | proactive peak um | proactive/reactive per seed | reactive excess um | reactive removed % | exit undersize r / p um |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let kinds = [ControllerKind::Reactive, ControllerKind::Proactive];
    for cand in &list {
        let s = cand.scenario(groove)?;
        let r = runs(&s, &kinds, seeds, done)?;
        let (u, _, rise) = step_traces(&s)?;
        let (over, under) = swing(&u);
        let med = |k: usize, name: &str| med_ci(column(&r, k, seeds, name)).0;
        println!(
            "| {} | {rise:.1} | {:.1} / {:.1} | {} | {} | {} | {:.1} | {:.2} | {:.0} / {:.0} |",
            cand.label,
            100.0 * over,
            100.0 * under,
            cell(column(&r, 0, seeds, "feed_step_peak_um")),
            cell(column(&r, 1, seeds, "feed_step_peak_um")),
            cell(ratio(&r, 1, 0, seeds, "feed_step_peak_um")),
            med(0, "feed_step_excess_um"),
            med(0, "static_removed_pct"),
            med(0, "exit_undersize_um"),
            med(1, "exit_undersize_um"),
        );
    }
    println!(
        "published (003): reactive peak 74 um, proactive 43 um (ratio 0.58), the notch chain's oscillation visible (here: overshoot >= 5 %), 95 % removed, both undersize at the exit"
    );
    // the band's corners (the peaks rise as the machine softens: the band's ends) for the P loop
    // shipped before, the feedforward candidate, an acceleration-limited one and the shipped axis
    let nb = band_seeds.len();
    for i in [0, 3, 10, 15] {
        let cand = &list[i];
        let mut ends = [[f64::NAN; 2]; 2];
        for (j, (k, o)) in [(50.0, 3.0), (20.0, 4.0)].into_iter().enumerate() {
            let mut s = cand.scenario(groove)?;
            let nc = s.nc_axis.as_mut().ok_or("no [nc_axis]")?;
            nc.machine.machine_stiffness_n_per_um = k;
            nc.machine.overhang_d = o;
            let r = runs(&s, &kinds, band_seeds, done)?;
            for (kind, end) in ends.iter_mut().enumerate() {
                end[j] = med_ci(column(&r, kind, band_seeds, "feed_step_peak_um")).0;
            }
        }
        println!(
            "band ({}), 50 N/um x 3 D .. 20 N/um x 4 D, seeds 1..={nb}: reactive peak {:.1} .. {:.1} (74: {}), proactive {:.1} .. {:.1} (43: {})",
            cand.label,
            ends[0][0],
            ends[0][1],
            if (ends[0][0]..=ends[0][1]).contains(&74.0) {
                "inside"
            } else {
                "outside"
            },
            ends[1][0],
            ends[1][1],
            if (ends[1][0]..=ends[1][1]).contains(&43.0) {
                "inside"
            } else {
                "outside"
            },
        );
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut n_seeds, mut band_seeds) = (10u64, 3u64);
    let mut out_dir = PathBuf::from("nc_axis_study");
    let mut sections: Vec<u32> = (1..=7).collect();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seeds" | "--band-seeds" => {
                let v: u64 = args
                    .next()
                    .ok_or(format!("{a} needs a number"))?
                    .parse()
                    .map_err(|e| format!("{a}: {e}"))?;
                if a == "--seeds" {
                    n_seeds = v;
                } else {
                    band_seeds = v;
                }
            }
            "--out" => out_dir = PathBuf::from(args.next().ok_or("--out needs a directory")?),
            "--sections" => {
                sections = args
                    .next()
                    .ok_or("--sections needs a list, e.g. 1,3")?
                    .split(',')
                    .map(|v| {
                        v.trim()
                            .parse::<u32>()
                            .map_err(|e| format!("--sections: {e}"))
                    })
                    .collect::<Result<_, _>>()?;
            }
            other => {
                return Err(format!(
                    "unknown argument `{other}`: allowed --seeds N, --band-seeds M, --out DIR, --sections 1,2,…"
                )
                .into());
            }
        }
    }
    let t0 = std::time::Instant::now();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets/scenarios");
    let groove = Scenario::load(dir.join("nc_c45_feed_step.toml"))?;
    let exit = Scenario::load(dir.join("nc_c45_exit.toml"))?;
    let seeds: Vec<u64> = (1..=n_seeds).collect();
    let done = AtomicUsize::new(0);
    let labels: Vec<&str> = KINDS.iter().map(|k| k.name()).collect();

    // 1. the published groove
    if sections.contains(&1) {
        let r = runs(&groove, &KINDS, &seeds, &done)?;
        println!(
            "## 1. nc_c45_feed_step (k_M 30 N/um, 3.5 D), seeds 1..={n_seeds}: median [95 % interval of the median]"
        );
        table(
            &r,
            &labels,
            &seeds,
            &[
                "static_removed_pct",
                "static_error_um",
                "deflection_step_um",
                "feed_step_peak_um",
                "feed_step_excess_um",
                "ringing_um",
                "exit_undersize_um",
                "exit_max_um",
            ],
        );
        references(
            &r,
            0,
            &seeds,
            &[
                "feed_step_peak_bound_um",
                "feed_step_excess_bound_um",
                "exit_bound_um",
            ],
        );
        references(
            &r,
            0,
            &seeds,
            &[
                "ce_static_error_um",
                "ce_feed_step_peak_um",
                "ce_feed_step_excess_um",
                "ce_exit_undersize_um",
                "ce_exit_max_um",
            ],
        );
        for name in ["feed_step_peak_um", "feed_step_excess_um"] {
            println!(
                "per seed, {name}: proactive/reactive {} (003: 43/74 = 0.58); mpc/proactive {}",
                cell(ratio(&r, 2, 1, &seeds, name)),
                cell(ratio(&r, 3, 2, &seeds, name))
            );
        }
    }

    // 2. the band
    if sections.contains(&2) {
        let km = [20.0, 30.0, 50.0];
        let od = [3.0, 3.5, 4.0];
        let bseeds: Vec<u64> = (1..=band_seeds).collect();
        println!(
            "\n## 2. band: machine stiffness x overhang, medians over seeds 1..={band_seeds} at each point"
        );
        println!(
            "| k_M N/um | overhang D | deflection step | reactive peak | proactive peak | mpc peak | mpc/proactive | peak bound / CE | reactive excess | proactive excess | mpc excess | exit undersize r/p/m (CE) |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
        let mut band: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for &k in &km {
            for &o in &od {
                let mut s = groove.clone();
                let nc = s.nc_axis.as_mut().ok_or("no [nc_axis]")?;
                nc.machine.machine_stiffness_n_per_um = k;
                nc.machine.overhang_d = o;
                let rb = runs(&s, &KINDS, &bseeds, &done)?;
                let m = |kind: usize, name: &str| med_ci(column(&rb, kind, &bseeds, name)).0;
                let ratio_m = med_ci(ratio(&rb, 3, 2, &bseeds, "feed_step_peak_um")).0;
                let vals = [
                    ("deflection_step", m(0, "deflection_step_um")),
                    ("reactive_peak", m(1, "feed_step_peak_um")),
                    ("proactive_peak", m(2, "feed_step_peak_um")),
                    ("mpc_peak", m(3, "feed_step_peak_um")),
                    ("mpc_over_proactive_peak", ratio_m),
                    ("peak_bound", m(0, "feed_step_peak_bound_um")),
                    ("ce_peak", m(0, "ce_feed_step_peak_um")),
                    ("reactive_excess", m(1, "feed_step_excess_um")),
                    ("proactive_excess", m(2, "feed_step_excess_um")),
                    ("mpc_excess", m(3, "feed_step_excess_um")),
                    (
                        "proactive_over_reactive_peak",
                        m(2, "feed_step_peak_um") / m(1, "feed_step_peak_um"),
                    ),
                    ("reactive_exit", m(1, "exit_undersize_um")),
                    ("proactive_exit", m(2, "exit_undersize_um")),
                    ("mpc_exit", m(3, "exit_undersize_um")),
                    ("ce_exit", m(0, "ce_exit_undersize_um")),
                ];
                for (n, v) in vals {
                    band.entry(n).or_default().push(v);
                }
                let v = |n: &str| vals.iter().find(|x| x.0 == n).map_or(f64::NAN, |x| x.1);
                println!(
                    "| {k} | {o} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} / {:.1} | {:.1} | {:.1} | {:.1} | {:.1} / {:.1} / {:.1} ({:.1}) |",
                    v("deflection_step"),
                    v("reactive_peak"),
                    v("proactive_peak"),
                    v("mpc_peak"),
                    v("mpc_over_proactive_peak"),
                    v("peak_bound"),
                    v("ce_peak"),
                    v("reactive_excess"),
                    v("proactive_excess"),
                    v("mpc_excess"),
                    v("reactive_exit"),
                    v("proactive_exit"),
                    v("mpc_exit"),
                    v("ce_exit")
                );
            }
        }
        let range = |n: &str| {
            let v = &band[n];
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        };
        for (n, published) in [
            ("reactive_peak", Some(74.0)),
            ("proactive_peak", Some(43.0)),
            ("reactive_excess", Some(74.0)),
            ("proactive_excess", Some(43.0)),
            ("proactive_over_reactive_peak", Some(0.58)),
            ("mpc_over_proactive_peak", None),
            ("mpc_exit", None),
            ("ce_exit", None),
            ("deflection_step", None),
        ] {
            let (lo, hi) = range(n);
            match published {
                Some(p) => println!(
                    "band {n}: {lo:.2} .. {hi:.2}; published {p}: {}",
                    if p >= lo && p <= hi {
                        "inside"
                    } else {
                        "outside"
                    }
                ),
                None => println!("band {n}: {lo:.2} .. {hi:.2}"),
            }
        }
    }

    // 3. the exit alone
    if sections.contains(&3) {
        let re = runs(&exit, &KINDS, &seeds, &done)?;
        println!("\n## 3. nc_c45_exit (1000 mm/min), seeds 1..={n_seeds}");
        table(
            &re,
            &labels,
            &seeds,
            &[
                "exit_undersize_um",
                "exit_min_um",
                "exit_max_um",
                "static_removed_pct",
            ],
        );
        references(
            &re,
            0,
            &seeds,
            &["exit_bound_um", "ce_exit_undersize_um", "ce_exit_max_um"],
        );
    }

    // 4. the literal proactive window
    if sections.contains(&4) {
        let mut lit = groove.clone();
        lit.nc_axis
            .as_mut()
            .ok_or("no [nc_axis]")?
            .control
            .proactive_window = OffsetWindow::Acceleration;
        let rl = runs(&lit, &[ControllerKind::Proactive], &seeds, &done)?;
        println!(
            "\n## 4. proactive, offset only while a_cmd != 0: feed_step_peak_um {}, excess {}",
            cell(column(&rl, 0, &seeds, "feed_step_peak_um")),
            cell(column(&rl, 0, &seeds, "feed_step_excess_um"))
        );
    }

    // 5. what the MPC's parts buy
    if sections.contains(&5) {
        println!(
            "\n## 5. the MPC's parts, seeds 1..={n_seeds}: shipped / without planning for the wall instants / dead time + lag axis model / tooth offsets times the engagement"
        );
        let variants = |s: &Scenario| -> Result<Vec<Scenario>, String> {
            let mut a = s.clone();
            a.nc_axis
                .as_mut()
                .ok_or("no [nc_axis]")?
                .control
                .mpc_wall_instants = false;
            let mut b = s.clone();
            b.nc_axis
                .as_mut()
                .ok_or("no [nc_axis]")?
                .control
                .mpc_axis_model = NcAxisModel::DeadTimeLag;
            let mut c = s.clone();
            c.nc_axis
                .as_mut()
                .ok_or("no [nc_axis]")?
                .control
                .mpc_tooth_offsets = ToothOffsets::Engagement;
            Ok(vec![s.clone(), a, b, c])
        };
        for (name, base, names) in [
            (
                "nc_c45_feed_step",
                &groove,
                &[
                    "static_error_um",
                    "feed_step_peak_um",
                    "feed_step_excess_um",
                    "exit_undersize_um",
                    "exit_max_um",
                ][..],
            ),
            (
                "nc_c45_exit",
                &exit,
                &["static_error_um", "exit_undersize_um", "exit_max_um"][..],
            ),
        ] {
            let mut merged: BTreeMap<(usize, u64), Figures> = BTreeMap::new();
            for (i, v) in variants(base)?.iter().enumerate() {
                for ((_, sd), f) in runs(v, &[ControllerKind::Mpc], &seeds, &done)? {
                    merged.insert((i, sd), f);
                }
            }
            println!("{name}:");
            table(
                &merged,
                &[
                    "mpc",
                    "no wall instants",
                    "dead time + lag",
                    "offsets x engagement",
                ],
                &seeds,
                names,
            );
        }
    }

    // 6. the NC's feed change: jerk-limited (shipped) against acceleration-limited
    if sections.contains(&6) {
        let mut brisk = groove.clone();
        brisk
            .nc_axis
            .as_mut()
            .ok_or("no [nc_axis]")?
            .program
            .path_jerk_mm_s3 = 1e12;
        let rbk = runs(&brisk, &KINDS[1..], &seeds, &done)?;
        println!(
            "\n## 6. the feed change limited in acceleration only (2 m/s^2, no jerk limit: 4.2 ms), seeds 1..={n_seeds}"
        );
        table(
            &rbk,
            &labels[1..],
            &seeds,
            &[
                "feed_step_peak_um",
                "feed_step_excess_um",
                "ringing_um",
                "feed_step_peak_bound_um",
                "ce_feed_step_peak_um",
            ],
        );
        println!(
            "per seed, feed_step_peak_um: proactive/reactive {}; mpc/proactive {}",
            cell(ratio(&rbk, 1, 0, &seeds, "feed_step_peak_um")),
            cell(ratio(&rbk, 2, 1, &seeds, "feed_step_peak_um"))
        );
        std::fs::create_dir_all(&out_dir)?;
        let mut series = vec![(
            "the chain alone, a force step at 0 ms".to_string(),
            chain_step(&groove)?,
        )];
        for (label, s) in [
            ("reactive, jerk-limited change (shipped)", &groove),
            ("reactive, acceleration-limited change", &brisk),
        ] {
            series.push((label.to_string(), actuating_after_step(s)?));
        }
        let mut csv = String::from("series,t_ms,normalised\n");
        for (label, v) in &series {
            for (t, y) in v {
                let _ = writeln!(csv, "\"{label}\",{t:.1},{y:.5}");
            }
            let (over, under) = swing(v);
            println!(
                "ringing, {label}: first overshoot {:.1} % of the step, the undershoot after it {:.1} %",
                100.0 * over,
                100.0 * under
            );
        }
        std::fs::write(out_dir.join("ringing.csv"), csv)?;
        std::fs::write(
            out_dir.join("ringing.svg"),
            lines_svg(
                &series,
                "the notch chain's ringing: the reactive actuating value after the feed change (seed 1), normalised to the step",
                "time after the feed change starts (ms; the chain alone: after the force step)",
            ),
        )?;
        println!(
            "written: {}, {}",
            out_dir.join("ringing.csv").display(),
            out_dir.join("ringing.svg").display()
        );
    }

    // 7. the truth's force model at 8 axial elements
    if sections.contains(&7) {
        let mut coarse = groove.clone();
        coarse
            .nc_axis
            .as_mut()
            .ok_or("no [nc_axis]")?
            .truth
            .axial_slices = 8;
        let rf = runs(&coarse, &KINDS, &seeds, &done)?;
        println!(
            "\n## 7. the truth's cutting edge in 8 axial elements (shipped: 32), seeds 1..={n_seeds}"
        );
        table(
            &rf,
            &labels,
            &seeds,
            &[
                "static_error_um",
                "feed_step_peak_um",
                "feed_step_excess_um",
                "exit_undersize_um",
                "exit_max_um",
            ],
        );
        references(
            &rf,
            0,
            &seeds,
            &[
                "feed_step_peak_bound_um",
                "exit_bound_um",
                "ce_feed_step_peak_um",
                "ce_exit_undersize_um",
            ],
        );
        println!(
            "per seed, feed_step_peak_um: mpc/proactive {}",
            cell(ratio(&rf, 3, 2, &seeds, "feed_step_peak_um"))
        );
    }

    // 8. 003's two disagreements (docs/studies/published-nc.md): the candidates
    if sections.contains(&8) {
        let bseeds: Vec<u64> = (1..=band_seeds).collect();
        candidates(&groove, &seeds, &bseeds, &done)?;
    }

    println!(
        "\n{} runs in {:.0} s",
        done.load(Ordering::Relaxed),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
