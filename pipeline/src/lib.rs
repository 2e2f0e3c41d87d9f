//! # millcomp-pipeline — the main job end to end
//!
//! The pipeline a user runs on a machine, as a library that `millcomp demo`, `millcomp pipeline` (and
//! later the Python package) call. Each stage reads only the files the stages before it wrote and
//! records them, with their SHA-256, in the chain ([`chain`]; `pipeline.json`):
//!
//! | stage | reads | writes |
//! |---|---|---|
//! | `design` | the plan | `design/calibration_doe.csv`, `.json` (resolution, aliases) |
//! | `measure` | the design (simulated machine) or the plan's files | `measured/*.csv` |
//! | `analyse` | `measured/calibration_forces.csv` | `analysis/*.csv`, the half-normal plot |
//! | `identify` | `measured/*.csv` | `models/*.toml` (provenance: each measured file's SHA-256) |
//! | `commission` | `models/*.toml` | `bundles/bundle_<material>.toml` |
//! | `build` | the bundles | `build/controllers.json`, the controllers at a change |
//! | `design-comparison` | the plan | `batch/conditions.csv` |
//! | `batch` | conditions and bundles (simulated machine) or measured results | `batch/results.csv`, `summary.json`, plots |
//! | `design-session` | a bundle (its nominal model) or the plan's session | `session/session.toml` |
//! | `measure-session` | the session (simulated machine, profilometer) or the plan's file | `measured/session.csv` |
//! | `diagnose` | session and measurement | `diagnose/diagnose.json`, `models/effect_*.toml` |
//! | `rerun` | conditions, bundles, effects, the batch's results (or measured results) | `rerun/*` |
//!
//! and the report: `report.md`, a self-contained `report.html` and the SVG files in `plots/` ([`report`],
//! [`svg`]). On the simulated machine ([`millcomp_closedloop::machine`]) the truth stays inside the
//! harness: the stages see the records its instruments return, nothing else.
//!
//! ```no_run
//! use millcomp_pipeline::{Options, plan::Plan, run};
//! let opts = Options::new("millcomp-demo".into());
//! let outcome = run(&Plan::demo(7), &opts, &|stage| eprintln!("{stage}")).unwrap();
//! println!("{}", outcome.headline);
//! ```
#![warn(missing_docs)]

pub mod batch;
mod calibration;
pub mod chain;
mod control;
mod ctx;
mod diagnosis;
pub mod error;
pub mod files;
pub mod plan;
pub mod published;
pub mod report;
pub mod svg;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

pub use chain::{FileRef, StageRecord, StageStatus};
pub use error::{PipelineError, Result};

use ctx::{Ctx, f, fp};
use plan::Plan;
use report::Figure;

/// How a pipeline runs.
#[derive(Debug, Clone)]
pub struct Options {
    /// Output directory (created).
    pub out: PathBuf,
    /// Worker threads of the comparison's runs (default: rayon's, all cores).
    pub threads: Option<usize>,
    /// The program and version, for provenance and the report (`millcomp 0.1.0`).
    pub program: String,
    /// The command that made this run, for provenance and the report.
    pub command: String,
    /// Show the batch engine's progress bar (on a terminal).
    pub progress_bar: bool,
}

impl Options {
    /// Options writing into `out`, this crate's version as the program, no command.
    pub fn new(out: PathBuf) -> Self {
        Self {
            out,
            threads: None,
            program: format!("millcomp {}", env!("CARGO_PKG_VERSION")),
            command: String::new(),
            progress_bar: false,
        }
    }
}

/// What a run produced.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    /// The answer in one paragraph (the first line of stdout and of the report).
    pub headline: String,
    /// The stage chain.
    pub stages: Vec<StageRecord>,
    /// `report.md`.
    pub report_md: PathBuf,
    /// `report.html`.
    pub report_html: PathBuf,
    /// `pipeline.json` (the chain, as `demo --json` prints it).
    pub chain_json: PathBuf,
    /// Wall-clock seconds.
    pub wall_clock_s: f64,
}

fn signed(x: f64) -> String {
    if x.is_finite() {
        format!("{x:+.3}")
    } else {
        "–".into()
    }
}

/// The answer: mpc against pid-tuned over the designed conditions (medians and the paired difference),
/// what the diagnosis named and how far the residual fell, and what the corrected model changed in
/// mpc's part error (the paired median difference to mpc built from the bundle alone) beside the oracle's.
/// The p-value is the sign test's, the test of the median whose distribution-free interval the line
/// shows (the paired t-test of the mean, which one large difference can swamp, is in the report).
fn headline(cx: &Ctx<'_>) -> String {
    let mut parts = Vec::new();
    match &cx.batch {
        Some(b) => parts.push(format!(
            "mpc vs {} over {} designed conditions: median pp {} vs {} µm, difference {:+.3} [{:+.3}, {:+.3}] µm, \
             sign-test p = {}",
            b.reference,
            b.n,
            f(b.mpc_median, 3),
            f(b.ref_median, 3),
            b.diff,
            b.ci[0],
            b.ci[1],
            fp(b.p)
        )),
        None => parts.push("no comparison of mpc and pid-tuned (the batch stage was skipped)".into()),
    }
    match &cx.diagnosis {
        Some(d) => parts.push(format!(
            "diagnosis named {}, rms {:.3} → {:.3} µm",
            d.named.join(" + "),
            d.rms_before,
            d.rms_after
        )),
        None => parts.push("no diagnosis (skipped)".into()),
    }
    match &cx.rerun {
        Some(r) => parts.push(format!(
            "with the corrected model mpc {} µm (ideal {})",
            signed(r.corrected),
            signed(r.ideal)
        )),
        None => parts.push("no rerun with the corrected model (skipped)".into()),
    }
    let mut h = parts.join("; ");
    if cx.machine.is_some() {
        h.push_str(" — simulated machine");
    }
    h
}

/// One stage of the pipeline: it reads the files earlier stages wrote and records its own.
type StageFn = fn(&mut Ctx<'_>) -> Result<()>;

/// Runs the plan's stages in order into `opts.out`, then writes the report and the chain. `progress`
/// is called with each stage's name as it starts.
///
/// # Errors
/// The first stage's error that stops the pipeline (a skipped stage is not an error: it is recorded
/// with what it would need).
pub fn run(plan: &Plan, opts: &Options, progress: &(dyn Fn(&str) + Sync)) -> Result<Outcome> {
    let start = Instant::now();
    std::fs::create_dir_all(&opts.out).map_err(|e| PipelineError::io(&opts.out, "creating", e))?;
    let mut cx = Ctx::new(plan, opts, progress);
    let stages: [(&str, StageFn); 12] = [
        ("design", calibration::design),
        ("measure", calibration::measure),
        ("analyse", calibration::analyse),
        ("identify", calibration::identify),
        ("commission", calibration::commission),
        ("build", control::build),
        ("design-comparison", control::design_comparison),
        ("batch", control::batch),
        ("design-session", diagnosis::design_session),
        ("measure-session", diagnosis::measure_session),
        ("diagnose", diagnosis::diagnose_stage),
        ("rerun", control::rerun),
    ];
    let mut go = || -> Result<()> {
        for (name, stage) in stages {
            stage(&mut cx).map_err(|e| match e {
                PipelineError::Stage { .. } => e,
                other => PipelineError::Stage {
                    stage: name,
                    source: Box::new(other),
                },
            })?;
        }
        Ok(())
    };
    match opts.threads {
        Some(0) => {
            return Err(PipelineError::Stage {
                stage: "batch",
                source: "threads must be at least 1".into(),
            });
        }
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| PipelineError::Stage {
                stage: "batch",
                source: Box::new(e),
            })?
            .install(go)?,
        None => go()?,
    }
    finish(cx, start)
}

fn finish(mut cx: Ctx<'_>, start: Instant) -> Result<Outcome> {
    let out = cx.opts.out.clone();
    let h = headline(&cx);
    cx.report.title = if cx.plan.name.is_empty() {
        "millcomp pipeline".into()
    } else {
        cx.plan.name.clone()
    };
    cx.report.headline = h.clone();
    let mut made = vec![
        ("made by".to_string(), cx.opts.program.clone()),
        (
            "command".to_string(),
            if cx.opts.command.is_empty() {
                "(library call)".into()
            } else {
                format!("`{}`", cx.opts.command)
            },
        ),
        (
            "seeds".to_string(),
            format!(
                "designs and noise {}{}",
                cx.plan.seed,
                cx.machine.as_ref().map_or(String::new(), |m| format!(
                    ", simulated machine {}",
                    m.seed()
                ))
            ),
        ),
        ("measurements".to_string(), cx.source()),
        (
            "stage chain".to_string(),
            "`pipeline.json` (every file each stage read and wrote, with its SHA-256)".into(),
        ),
    ];
    if let Some(m) = &cx.machine {
        made.push(("the machine".into(), m.describe()));
    }
    cx.report.made_by = made;
    let flow_svg = svg::flow(
        &cx.chain
            .stages
            .iter()
            .map(|s| {
                (
                    s.name.clone(),
                    s.outputs
                        .first()
                        .map(|o| o.path.clone())
                        .unwrap_or_else(|| "skipped".into()),
                    s.status == StageStatus::Ok,
                )
            })
            .collect::<Vec<_>>(),
    );
    let flow_path = out.join("plots/flow.svg");
    files::write_text(&flow_path, &flow_svg)?;
    cx.report.flow = Some(Figure {
        file: "plots/flow.svg".into(),
        svg: flow_svg,
        caption:
            "The pipeline: each stage reads only what the stages before it wrote (grey: skipped)."
                .into(),
        source: vec!["pipeline.json".into()],
    });
    if let Some(m) = &cx.machine {
        let mut s = report::Section::new("What was hidden", "hidden");
        s.para(format!(
            "Revealed after every stage above had run — nothing before read it: {}.",
            m.reveal()
        ));
        cx.report.sections.push(s);
    }
    let mut skipped = report::Section::new("Stages", "stages");
    skipped.table(
        &["stage", "status", "what it did or would need", "seconds"],
        cx.chain
            .stages
            .iter()
            .map(|s| {
                vec![
                    format!("`{}`", s.name),
                    format!("{:?}", s.status).to_lowercase(),
                    s.summary.clone(),
                    format!("{:.1}", s.seconds),
                ]
            })
            .collect(),
        &["pipeline.json".into()],
    );
    cx.report.sections.push(skipped);
    let md = out.join("report.md");
    files::write_text(&md, &cx.report.markdown())?;
    let html = out.join("report.html");
    files::write_text(&html, &cx.report.html())?;
    let chain_json = out.join("pipeline.json");
    let wall = start.elapsed().as_secs_f64();
    let doc = ChainDoc {
        headline: &h,
        stages: &cx.chain.stages,
        report: "report.md",
        report_html: "report.html",
    };
    files::write_text(&chain_json, &serde_json::to_string_pretty(&doc)?)?;
    Ok(Outcome {
        headline: h,
        stages: cx.chain.stages,
        report_md: md,
        report_html: html,
        chain_json,
        wall_clock_s: wall,
    })
}

/// `pipeline.json`.
#[derive(Serialize)]
struct ChainDoc<'a> {
    headline: &'a str,
    stages: &'a [StageRecord],
    report: &'a str,
    report_html: &'a str,
}

/// Reads `pipeline.json` back and checks it ([`chain::verify`]): the problems found, empty when every
/// recorded hash holds and every stage read only what an earlier stage wrote.
///
/// # Errors
/// [`PipelineError::Io`] or [`PipelineError::Json`] when the file cannot be read.
pub fn verify_chain(out: &Path) -> Result<Vec<String>> {
    let path = out.join("pipeline.json");
    let text =
        std::fs::read_to_string(&path).map_err(|e| PipelineError::io(&path, "reading", e))?;
    #[derive(serde::Deserialize)]
    struct Doc {
        stages: Vec<StageRecord>,
    }
    let d: Doc = serde_json::from_str(&text)?;
    Ok(chain::verify(out, &d.stages))
}
