//! Issue 16's study of the NC feed-axis stage (003): every "Must show" figure, medians with
//! distribution-free 95 % intervals over seeds.
//!
//! `cargo run --release -p millcomp-closedloop --example nc_axis_study -- [--seeds N] [--band-seeds M]`
//!
//! 1. The published groove (`nc_c45_feed_step.toml`: feed 500 → 1000 mm/min at 90 mm, exit at 185 mm)
//!    with `none`, `reactive`, `proactive`, `mpc` over seeds 1..=N (default 10): static error removed,
//!    the feed step's peak and excess, the ringing of the correction, the exit's undersize, the
//!    deflection step (a model output), and per seed the ratios proactive/reactive and mpc/proactive.
//! 2. The band: machine stiffness 20 / 30 / 50 N/µm × overhang 3 / 3.5 / 4 D, seeds 1..=M (default 3)
//!    at each point; per point the median of each figure; the band is their range.
//! 3. The exit alone (`nc_c45_exit.toml`) over seeds 1..=N.
//! 4. Ablation: the proactive offset curve superimposed only while the reference acceleration is
//!    non-zero (the literal reading of 003 Fig. 3's caption) on the published groove.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use millcomp_closedloop::compare::median_ci95;
use millcomp_closedloop::{ControllerKind, RunReport, Scenario, run_scenario};
use millcomp_mpc::nc_axis::OffsetWindow;
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
    for (k, v) in [
        ("feed_step_peak_um", w.feed_step_peak_um),
        ("feed_step_excess_um", w.feed_step_excess_um),
        ("ringing_um", w.feed_step_oscillation_um),
        ("deflection_step_um", w.deflection_step_um),
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
    format!("{m:.2} [{:.2}, {:.2}]", ci[0], ci[1])
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

/// A markdown table: one row per figure, one column per controller of [`KINDS`].
fn table(r: &BTreeMap<(usize, u64), Figures>, seeds: &[u64], names: &[&str]) {
    println!(
        "| figure | {} |",
        KINDS
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---|".repeat(KINDS.len()));
    for name in names {
        let cells: Vec<String> = (0..KINDS.len())
            .map(|k| cell(column(r, k, seeds, name)))
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut n_seeds, mut band_seeds) = (10u64, 3u64);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut num = |name: &str| -> Result<u64, String> {
            args.next()
                .ok_or(format!("{name} needs a number"))?
                .parse()
                .map_err(|e| format!("{name}: {e}"))
        };
        match a.as_str() {
            "--seeds" => n_seeds = num("--seeds")?,
            "--band-seeds" => band_seeds = num("--band-seeds")?,
            other => {
                return Err(format!(
                    "unknown argument `{other}`: allowed --seeds N, --band-seeds M"
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

    // 1. the published groove
    let r = runs(&groove, &KINDS, &seeds, &done)?;
    println!(
        "## 1. nc_c45_feed_step (k_M 30 N/um, 3.5 D), seeds 1..={n_seeds}: median [95 % interval of the median]"
    );
    let names = [
        "static_removed_pct",
        "static_error_um",
        "deflection_step_um",
        "feed_step_peak_um",
        "feed_step_excess_um",
        "ringing_um",
        "exit_undersize_um",
    ];
    table(&r, &seeds, &names);
    for name in ["feed_step_peak_um", "feed_step_excess_um"] {
        println!(
            "per seed, {name}: proactive/reactive {} (003: 43/74 = 0.58); mpc/proactive {}",
            cell(ratio(&r, 2, 1, &seeds, name)),
            cell(ratio(&r, 3, 2, &seeds, name))
        );
    }

    // 2. the band
    let km = [20.0, 30.0, 50.0];
    let od = [3.0, 3.5, 4.0];
    let bseeds: Vec<u64> = (1..=band_seeds).collect();
    println!(
        "\n## 2. band: machine stiffness x overhang, medians over seeds 1..={band_seeds} at each point"
    );
    println!(
        "| k_M N/um | overhang D | deflection step | reactive peak | proactive peak | mpc peak | mpc/proactive | reactive excess | proactive excess | mpc excess | exit undersize r/p/m |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
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
            ];
            for (n, v) in vals {
                band.entry(n).or_default().push(v);
            }
            println!(
                "| {k} | {o} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} / {:.1} / {:.1} |",
                vals[0].1,
                vals[1].1,
                vals[2].1,
                vals[3].1,
                vals[4].1,
                vals[5].1,
                vals[6].1,
                vals[7].1,
                vals[9].1,
                vals[10].1,
                vals[11].1
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

    // 3. the exit alone
    let re = runs(&exit, &KINDS, &seeds, &done)?;
    println!("\n## 3. nc_c45_exit (1000 mm/min), seeds 1..={n_seeds}");
    table(
        &re,
        &seeds,
        &["exit_undersize_um", "exit_min_um", "static_removed_pct"],
    );

    // 4. the literal proactive window
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
    println!(
        "\n{} runs in {:.0} s",
        done.load(Ordering::Relaxed),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
