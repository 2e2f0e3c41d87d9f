//! Every shipped scenario (datasets/scenarios, faults excluded) with none, open-loop, pid, pid-tuned, mpc
//! (and threshold on the thin wall) over N seeds: medians with distribution-free 95 % intervals, as a
//! markdown table.
//!
//! `cargo run --release -p millcomp-closedloop --example compare -- [--seeds N] [--commissioned] [--ablations]`
//!
//! `--ablations`: the groove scenarios only, with the controllers that say what the MPC's parts buy —
//! `pid-tuned`, `pid-ff` (pid-tuned plus the plan fed forward), `mpc-nopreview` (no preview) and `mpc`.
//!
//! `--changes`: the ablation controllers on the scenarios with process changes only (feed and depth
//! steps, slowed and at once, and the exit), with the excess at each change (`millcomp_closedloop::changes`).
//!
//! `--levels`: as `--changes`, showing only each change's excess, the level change it holds (from the
//! error's level before the change to its settled error after: in air before the entry) and what the
//! transient adds to it (`millcomp_closedloop::changes`).
//!
//! `--features`: the groove scenarios with the MPC's planning and estimation features switched off one at
//! a time (`control.groove_mpc`: `stroke_aware`, `adapt_plan_scale`, `spindle_phase`, `flute_phase`,
//! `gauge_disturbance`, `stack_disturbance`, `intersample`), all off, beside `pid-ff` — what each
//! feature buys; and the MPC and `pid-ff` driving the stack through the inverse of its identified
//! hysteresis (`control.compensate_hysteresis`, off by default).
//!
//! `--rates`: the scenarios with process changes, the MPC at 2 kHz (horizon 20 = 10 ms, shipped), at
//! 5 kHz with the same 20 steps (4 ms) and at 5 kHz with 50 steps (10 ms), beside `pid-ff` — what the
//! faster cycle buys (issue 18).
//!
//! `--start`: the groove scenarios with `pid-ff`, `pid-ff-read` (`pid-ff` given the MPC's
//! `unbiased_peak` and `flank_rubbing`: the fairness ablation), the shipped `mpc`, `mpc -quiet` (`control.groove_mpc.
//! quiet_revolutions` off) and `mpc -start -quiet` (and `unbiased_peak` and `flank_rubbing` off: the
//! ramp's rubbing start not known) — what the three features do beyond the ramps' start (`bash
//! bench/ramp-start-noise`).
//!
//! `--commissioned`: the hard form (`millcomp_closedloop::compare::commissioned`) — each groove scenario
//! with instrument errors and a tool drawn from the seed and controllers built only from its own
//! commissioning; each thin wall a part drawn from the seed; no deliberate force-model errors.

use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use millcomp_closedloop::compare::{CompareRow, commissioned, compare};
use millcomp_closedloop::scenario::StageKind;
use millcomp_closedloop::{ControllerKind, Scenario};
use millcomp_mpc::groove::GrooveMpcFeatures;

/// The MPC variants of `--features`: a label and the features it runs with.
/// Each variant is "every feature on" with one switched off, so `-stroke` is the shipped default
/// (`stroke_aware` is off by default).
fn feature_variants() -> Vec<(&'static str, GrooveMpcFeatures)> {
    let all = GrooveMpcFeatures {
        stroke_aware: true,
        ..GrooveMpcFeatures::default()
    };
    vec![
        ("all on", all),
        (
            "-stroke",
            GrooveMpcFeatures {
                stroke_aware: false,
                ..all
            },
        ),
        (
            "-scale",
            GrooveMpcFeatures {
                adapt_plan_scale: false,
                ..all
            },
        ),
        (
            "-phase",
            GrooveMpcFeatures {
                spindle_phase: false,
                ..all
            },
        ),
        (
            "-flute",
            GrooveMpcFeatures {
                flute_phase: false,
                ..all
            },
        ),
        (
            "-gauge_dist",
            GrooveMpcFeatures {
                gauge_disturbance: false,
                ..all
            },
        ),
        (
            "-stack_dist",
            GrooveMpcFeatures {
                stack_disturbance: false,
                ..all
            },
        ),
        (
            "-intersample",
            GrooveMpcFeatures {
                intersample: false,
                ..all
            },
        ),
        (
            "-all",
            GrooveMpcFeatures {
                stroke_aware: false,
                adapt_plan_scale: false,
                spindle_phase: false,
                flute_phase: false,
                gauge_disturbance: false,
                stack_disturbance: false,
                intersample: false,
                unbiased_peak: false,
                flank_rubbing: false,
                quiet_revolutions: false,
            },
        ),
    ]
}

/// The MPC rates of `--rates`: label, stage steps per MPC cycle (20 kHz stage), horizon in cycles.
const RATE_VARIANTS: [(&str, usize, usize); 3] = [
    ("mpc 2 kHz h20", 10, 20),
    ("mpc 5 kHz h20", 4, 20),
    ("mpc 5 kHz h50", 4, 50),
];

/// What a variant changes in a scenario.
type Setter = Box<dyn Fn(&mut Scenario)>;
/// A labelled variant: the controller and what it changes in the scenarios.
type Variant = (String, ControllerKind, Setter);

/// `pid-ff` once, then each variant's controller once (on the scenarios changed by its setter), its rows
/// labelled with the variant: the rows and the column labels.
fn mpc_variants(
    scenarios: &[Scenario],
    seeds: u64,
    tick: &(dyn Fn() + Sync),
    variants: &[Variant],
) -> Result<(Vec<CompareRow>, Vec<String>), Box<dyn std::error::Error>> {
    let mut rows = compare(
        scenarios,
        &[ControllerKind::PidFeedforward],
        1..1 + seeds,
        tick,
    )?;
    let mut cols = vec![ControllerKind::PidFeedforward.name().to_string()];
    for (label, kind, set) in variants {
        let variant: Vec<Scenario> = scenarios
            .iter()
            .map(|s| {
                let mut s = s.clone();
                set(&mut s);
                s
            })
            .collect();
        let mut r = compare(&variant, &[*kind], 1..1 + seeds, tick)?;
        r.iter_mut().for_each(|row| row.controller = label.clone());
        rows.extend(r);
        cols.push(label.clone());
    }
    rows.sort_by(|a, b| (&a.scenario, &a.metric).cmp(&(&b.scenario, &b.metric)));
    Ok((rows, cols))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut seeds, mut comm, mut ablations, mut changes, mut features, mut rates) =
        (10u64, false, false, false, false, false);
    let (mut levels, mut start) = (false, false);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--commissioned" => comm = true,
            "--features" => {
                ablations = true;
                features = true;
            }
            "--ablations" => ablations = true,
            "--start" => start = true,
            "--rates" => {
                ablations = true;
                changes = true;
                rates = true;
            }
            "--changes" => {
                ablations = true;
                changes = true;
            }
            "--levels" => {
                ablations = true;
                changes = true;
                levels = true;
            }
            "--seeds" => {
                seeds = args
                    .next()
                    .ok_or("--seeds needs a number")?
                    .parse()
                    .map_err(|e| format!("--seeds: {e}"))?;
            }
            other => {
                return Err(format!(
                    "unknown argument `{other}`: allowed --seeds N, --commissioned, --ablations, --changes, --levels, --features, --rates, --start"
                )
                .into());
            }
        }
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets/scenarios");
    let mut names: Vec<_> = std::fs::read_dir(&dir)?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml") && !n.contains("faults") && !n.contains("commissioned"))
        .collect();
    names.sort();
    let mut scenarios = Vec::new();
    for n in &names {
        let s = Scenario::load(dir.join(n))?;
        // the NC stage (003) has its own study: examples/nc_axis_study.rs
        if s.stage == StageKind::NcAxis {
            continue;
        }
        if (ablations || start) && !ControllerKind::PidFeedforward.runs_on(s.stage) {
            continue;
        }
        let has_changes = s.groove.as_ref().is_some_and(|g| {
            g.exit.is_some() || !g.feed_steps.is_empty() || !g.depth.change_points_mm().is_empty()
        });
        if changes && !has_changes {
            continue;
        }
        scenarios.push(if comm { commissioned(&s) } else { s });
    }
    let controllers: Vec<ControllerKind> = if features {
        vec![ControllerKind::PidFeedforward, ControllerKind::Mpc]
    } else if ablations {
        vec![
            ControllerKind::PidTuned,
            ControllerKind::PidFeedforward,
            ControllerKind::MpcNoPreview,
            ControllerKind::Mpc,
        ]
    } else {
        vec![
            ControllerKind::None,
            ControllerKind::OpenLoop,
            ControllerKind::Pid,
            ControllerKind::PidTuned,
            ControllerKind::Threshold,
            ControllerKind::Mpc,
        ]
    };
    let bar = ProgressBar::new(0);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos} runs {elapsed}") {
        bar.set_style(style);
    }
    let t0 = std::time::Instant::now();
    let (rows, cols): (Vec<CompareRow>, Vec<String>) = if rates {
        let variants: Vec<Variant> = RATE_VARIANTS
            .iter()
            .map(|&(label, every, horizon)| {
                let set: Setter = Box::new(move |s: &mut Scenario| {
                    s.control.mpc_every = every;
                    s.control.horizon = horizon;
                    // the amplifier's slew per cycle scales with the period (the same V/s)
                    s.control.slew_v_per_cycle *= every as f64 / 10.0;
                });
                (label.to_string(), ControllerKind::Mpc, set)
            })
            .collect();
        mpc_variants(&scenarios, seeds, &|| bar.inc(1), &variants)?
    } else if features {
        let variants: Vec<Variant> = feature_variants()
            .into_iter()
            .map(|(label, f)| {
                let set: Setter = Box::new(move |s: &mut Scenario| s.control.groove_mpc = f);
                (label.to_string(), ControllerKind::Mpc, set)
            })
            .chain(
                [ControllerKind::Mpc, ControllerKind::PidFeedforward].map(|k| {
                    // the stack driven through the inverse of its identified hysteresis (off by default)
                    let set: Setter =
                        Box::new(|s: &mut Scenario| s.control.compensate_hysteresis = true);
                    (format!("{} +hyst-inverse", k.name()), k, set)
                }),
            )
            .collect();
        mpc_variants(&scenarios, seeds, &|| bar.inc(1), &variants)?
    } else if start {
        let as_shipped = || -> Setter { Box::new(|_: &mut Scenario| {}) };
        let loud: Setter = Box::new(|s: &mut Scenario| {
            s.control.groove_mpc.quiet_revolutions = false;
        });
        let unknown: Setter = Box::new(|s: &mut Scenario| {
            s.control.groove_mpc.unbiased_peak = false;
            s.control.groove_mpc.flank_rubbing = false;
            s.control.groove_mpc.quiet_revolutions = false;
        });
        let variants: Vec<Variant> = vec![
            // pid-ff given the two read features: the fairness ablation
            (
                "pid-ff-read".into(),
                ControllerKind::PidFeedforwardRead,
                as_shipped(),
            ),
            ("mpc".into(), ControllerKind::Mpc, as_shipped()),
            ("mpc -quiet".into(), ControllerKind::Mpc, loud),
            ("mpc -start -quiet".into(), ControllerKind::Mpc, unknown),
        ];
        mpc_variants(&scenarios, seeds, &|| bar.inc(1), &variants)?
    } else {
        let rows = compare(&scenarios, &controllers, 1..1 + seeds, &|| bar.inc(1))?;
        let cols = controllers.iter().map(|c| c.name().to_string()).collect();
        (rows, cols)
    };
    bar.finish_and_clear();
    println!(
        "{} seeds (1..={seeds}){}{}; median [95 % interval of the median]; {:.0} s",
        seeds,
        if comm { ", commissioned" } else { "" },
        if rates {
            ", MPC rates"
        } else if start {
            ", the MPC's read features"
        } else if features {
            ", MPC features"
        } else if levels {
            ", process changes, the excess's level change"
        } else if changes {
            ", process changes"
        } else if ablations {
            ", ablations"
        } else {
            ""
        },
        t0.elapsed().as_secs_f64()
    );
    println!("| scenario | metric | {} |", cols.join(" | "));
    println!("|---|---|{}", "---|".repeat(cols.len()));
    let mut keys: Vec<(String, String)> = rows
        .iter()
        .map(|r| (r.scenario.clone(), r.metric.clone()))
        .collect();
    keys.dedup();
    // the level change and what the transient adds to it only with --levels, which shows each change's
    // excess, its level change and the rest side by side
    keys.retain(|(_, m)| {
        if levels {
            m.starts_with("excess_") && !m.ends_with("_bound_um")
        } else {
            !m.ends_with("_level_um")
        }
    });
    for (s, m) in keys {
        // the stroke bound only where the stroke does not cover the deflection for some controller
        if m == "stroke_bound_um"
            && rows
                .iter()
                .filter(|r| r.scenario == s && r.metric == m)
                .all(|r| r.median == 0.0 && r.ci95[1] == 0.0)
        {
            continue;
        }
        let cells: Vec<String> = cols
            .iter()
            .map(|c| {
                rows.iter()
                    .find(|r| r.scenario == s && r.metric == m && r.controller == **c)
                    .map(|r| format!("{:.2} [{:.2}, {:.2}]", r.median, r.ci95[0], r.ci95[1]))
                    .unwrap_or_else(|| "—".into())
            })
            .collect();
        println!("| {s} | {m} | {} |", cells.join(" | "));
    }
    Ok(())
}
