//! What the stages share: the plan, the output directory, the simulated machine (if any), the chain of
//! stages so far, the report being written, and the few numbers later stages and the headline need (each
//! read from a file an earlier stage wrote).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use millcomp_closedloop::machine::SimulatedMachine;
use millcomp_models::{InputFile, Provenance};

use crate::Options;
use crate::chain::Chain;
use crate::error::{PipelineError, Result};
use crate::plan::Plan;
use crate::report::{Figure, Report, Section};
use crate::svg::Chart;

/// The batch comparison's answer (mpc against pid-tuned).
#[derive(Debug, Clone, Default)]
pub(crate) struct BatchAnswer {
    pub n: usize,
    pub mpc_median: f64,
    pub ref_median: f64,
    pub diff: f64,
    pub ci: [f64; 2],
    pub p: Option<f64>,
    pub reference: String,
}

/// The diagnosis's answer.
#[derive(Debug, Clone, Default)]
pub(crate) struct DiagnosisAnswer {
    pub named: Vec<String>,
    pub rms_before: f64,
    pub rms_after: f64,
}

/// The rerun's answer: the paired median differences of the corrected MPC and of the oracle against the
/// MPC built from the bundle alone (µm of peak-to-peak part error; < 0: better).
#[derive(Debug, Clone, Default)]
pub(crate) struct RerunAnswer {
    pub corrected: f64,
    pub ideal: f64,
}

/// The shared state of one pipeline run.
pub(crate) struct Ctx<'a> {
    pub plan: &'a Plan,
    pub opts: &'a Options,
    pub machine: Option<SimulatedMachine>,
    pub chain: Chain,
    pub report: Report,
    pub progress: &'a (dyn Fn(&str) + Sync),
    /// Measured calibration files by role (`forces`, `spindle_step`, …), inside the output directory.
    pub measured: BTreeMap<&'static str, PathBuf>,
    /// Identified model files by part (`force_S7`, `spindle`, …).
    pub models: BTreeMap<String, PathBuf>,
    /// Bundles by material.
    pub bundles: BTreeMap<String, PathBuf>,
    /// The comparison's conditions (`batch/conditions.csv`) and results.
    pub conditions: Option<PathBuf>,
    pub batch_results: Option<PathBuf>,
    /// The session and its measurement.
    pub session: Option<PathBuf>,
    pub session_measured: Option<PathBuf>,
    /// Named effects' model files.
    pub effects: Vec<PathBuf>,
    pub batch: Option<BatchAnswer>,
    pub diagnosis: Option<DiagnosisAnswer>,
    pub rerun: Option<RerunAnswer>,
}

impl<'a> Ctx<'a> {
    pub fn new(plan: &'a Plan, opts: &'a Options, progress: &'a (dyn Fn(&str) + Sync)) -> Self {
        Self {
            plan,
            opts,
            machine: plan.machine.as_ref().map(|m| SimulatedMachine::new(m.seed)),
            chain: Chain::new(&opts.out),
            report: Report::default(),
            progress,
            measured: BTreeMap::new(),
            models: BTreeMap::new(),
            bundles: BTreeMap::new(),
            conditions: None,
            batch_results: None,
            session: None,
            session_measured: None,
            effects: Vec::new(),
            batch: None,
            diagnosis: None,
            rerun: None,
        }
    }

    /// `out/rel`.
    pub fn path(&self, rel: &str) -> PathBuf {
        self.opts.out.join(rel)
    }

    /// A path relative to the output directory, for the report.
    pub fn rel(&self, p: &Path) -> String {
        p.strip_prefix(&self.opts.out)
            .unwrap_or(p)
            .display()
            .to_string()
            .replace('\\', "/")
    }

    /// Where measurements come from, for the report: "simulated machine (seed N)" or "your files".
    pub fn source(&self) -> String {
        match &self.machine {
            Some(m) => format!("simulated machine (seed {})", m.seed()),
            None => "measured files".to_string(),
        }
    }

    /// "(simulated machine)" after a figure from the machine, nothing for files.
    pub fn sim_tag(&self) -> &'static str {
        if self.machine.is_some() {
            " (simulated machine)"
        } else {
            ""
        }
    }

    /// A seed for a stage's draws.
    pub fn seed(&self, salt: u64) -> u64 {
        self.plan.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ salt
    }

    /// The provenance of a model this run writes from `inputs` (files inside the output directory).
    ///
    /// # Errors
    /// [`PipelineError::Io`] when an input cannot be read.
    pub fn provenance(&self, inputs: &[&Path]) -> Result<Provenance> {
        let mut p = Provenance::now(&self.opts.program, &self.opts.command);
        for f in inputs {
            let bytes = std::fs::read(f).map_err(|e| PipelineError::io(f, "reading", e))?;
            p = p.with_input(InputFile::from_bytes(&self.rel(f), &bytes));
        }
        Ok(p)
    }

    /// Draws a chart into `plots/<name>.svg` and returns the figure.
    ///
    /// # Errors
    /// Drawing and writing errors.
    pub fn figure(
        &self,
        name: &str,
        chart: &Chart,
        caption: String,
        source: &[&Path],
    ) -> Result<(Figure, PathBuf)> {
        let svg = chart.render(900, 480)?;
        let path = self.path(&format!("plots/{name}.svg"));
        crate::files::write_text(&path, &svg)?;
        Ok((
            Figure {
                file: self.rel(&path),
                svg,
                caption,
                source: source.iter().map(|p| self.rel(p)).collect(),
            },
            path,
        ))
    }

    /// Starts a stage: says so on the progress line.
    pub fn start(&self, stage: &str) -> Instant {
        (self.progress)(stage);
        Instant::now()
    }

    /// Adds a section to the report.
    pub fn section(&mut self, s: Section) {
        self.report.sections.push(s);
    }
}

/// Formats a number with `d` decimals, `–` for NaN.
pub(crate) fn f(x: f64, d: usize) -> String {
    if x.is_finite() {
        format!("{x:.d$}")
    } else {
        "–".to_string()
    }
}

/// Formats a p-value.
pub(crate) fn fp(p: Option<f64>) -> String {
    match p {
        Some(p) if p < 1e-4 => format!("{p:.1e}"),
        Some(p) => format!("{p:.4}"),
        None => "–".into(),
    }
}

/// Median of finite values (NaN when none).
pub(crate) fn median(v: &[f64]) -> f64 {
    let mut v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}
