//! Controllers compared over scenarios and seeds: every (scenario, seed) run with every controller, the
//! metrics summarised as medians with distribution-free 95 % intervals (order statistics of the binomial,
//! no normality assumed).
//!
//! A *seed* replaces the scenario's `seed`: the sensor noise, the instrument draw
//! (`truth.draw_instruments`), the tool and thin-wall part draws (`truth.draw_tool`, `truth.draw_wall`),
//! the force-model errors of the uncommissioned scenarios and, for commissioned ones, the
//! commissioning's own noise. All controllers of one (scenario, seed) see the same
//! truth, the same noise and — commissioned — the same bundle.

use rayon::prelude::*;
use serde::Serialize;

use crate::error::ClosedLoopError;
use crate::report::RunReport;
use crate::runner::run_scenario;
pub use crate::scenario::commissioned;
use crate::scenario::{ControllerKind, Scenario, StageKind};
use crate::stats::median;
pub use crate::stats::median_ci95;

/// One metric of one controller on one scenario, over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompareRow {
    /// Scenario name.
    pub scenario: String,
    /// Metric (`pp_error_um`, `stroke_bound_um` and `optimum_pp_um` (grooves, [`crate::optimum`]),
    /// `change_peak_um`, `excess_<kind>_um` (the excess at the entry, a depth or feed change, the exit:
    /// [`crate::changes`]), `excess_<kind>_bound_um` (the smallest any controller could leave there),
    /// `excess_<kind>_level_um` (the level change it holds) and `excess_<kind>_beyond_level_um` (what
    /// the transient adds to it),
    /// `exit_overcut_um`, `wall_<nominal>um_error_pct`).
    pub metric: String,
    /// Controller name.
    pub controller: String,
    /// Seeds run.
    pub n: usize,
    /// Median over the seeds.
    pub median: f64,
    /// Distribution-free interval of the median (coverage ≥ 95 %; NaN below 6 seeds).
    pub ci95: [f64; 2],
}

/// One run's scenario index, controller and metrics.
type RunMetrics = (usize, ControllerKind, Vec<(String, f64)>);

/// The metrics of one run that the comparison reports.
pub fn metrics_of(s: &Scenario, r: &RunReport) -> Vec<(String, f64)> {
    match s.stage {
        StageKind::Groove => {
            let mut m = vec![("pp_error_um".to_string(), r.metrics.pp_error_um)];
            if let Some(b) = r.metrics.stroke_bound_um {
                m.push(("stroke_bound_um".to_string(), b));
            }
            if let Some(b) = r.metrics.optimum_pp_um {
                m.push(("optimum_pp_um".to_string(), b));
            }
            if let Some(p) = r.process_change_peak_um {
                m.push(("change_peak_um".to_string(), p));
            }
            // the excess at each kind of change (the largest where a kind occurs twice)
            let mut kinds: Vec<(String, f64)> = Vec::new();
            for c in &r.changes {
                let excess = (format!("excess_{}_um", c.kind.name()), c.excess_um);
                let bound = c
                    .bound_um
                    .map(|b| (format!("excess_{}_bound_um", c.kind.name()), b));
                let level = c
                    .level_change_um()
                    .map(|l| (format!("excess_{}_level_um", c.kind.name()), l));
                let beyond = c
                    .beyond_level_um()
                    .map(|b| (format!("excess_{}_beyond_level_um", c.kind.name()), b));
                let all = std::iter::once(excess)
                    .chain(bound)
                    .chain(level)
                    .chain(beyond);
                for (name, value) in all {
                    match kinds.iter_mut().find(|(n, _)| *n == name) {
                        Some((_, v)) => *v = v.max(value),
                        None => kinds.push((name, value)),
                    }
                }
            }
            m.extend(kinds);
            if let Some(p) = r.metrics.exit_overcut_um {
                m.push(("exit_overcut_um".to_string(), p));
            }
            m
        }
        StageKind::NcAxis => {
            let Some(w) = r.nc_axis.as_ref().map(|n| &n.wall) else {
                return Vec::new();
            };
            let mut m = vec![
                ("static_error_um".to_string(), w.static_error_um),
                ("static_removed_pct".to_string(), w.static_removed_pct),
                ("exit_undersize_um".to_string(), w.exit_undersize_um),
            ];
            for (name, v) in [
                ("feed_step_peak_um", w.feed_step_peak_um),
                ("feed_step_excess_um", w.feed_step_excess_um),
                ("feed_step_oscillation_um", w.feed_step_oscillation_um),
                ("deflection_step_um", w.deflection_step_um),
            ] {
                if let Some(v) = v {
                    m.push((name.to_string(), v));
                }
            }
            m
        }
        StageKind::ThinWall => {
            let nominal = s
                .thin_wall
                .as_ref()
                .map(|t| t.walls_um.clone())
                .unwrap_or_default();
            r.metrics
                .thickness_error_pct
                .clone()
                .unwrap_or_default()
                .into_iter()
                .enumerate()
                .map(|(i, e)| {
                    let w = nominal.get(i).copied().unwrap_or(f64::NAN);
                    (format!("wall_{w}um_error_pct"), e)
                })
                .collect()
        }
    }
}

/// Run every scenario with every controller its stage has, for each seed of `seeds`, in parallel
/// (rayon); `progress` is called after each run.
///
/// # Errors
/// [`ClosedLoopError::CompareRun`] naming the scenario, seed and controller of the first run that failed
/// (scenario validation, model files, construction), its error as the source.
pub fn compare(
    scenarios: &[Scenario],
    controllers: &[ControllerKind],
    seeds: std::ops::Range<u64>,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<CompareRow>, ClosedLoopError> {
    let mut jobs = Vec::new();
    for (i, s) in scenarios.iter().enumerate() {
        for seed in seeds.clone() {
            for &c in controllers {
                if c.runs_on(s.stage) {
                    jobs.push((i, seed, c));
                }
            }
        }
    }
    let results: Vec<Result<RunMetrics, ClosedLoopError>> = jobs
        .par_iter()
        .map(|&(i, seed, c)| {
            let mut s = scenarios[i].clone();
            s.seed = seed;
            let r = run_scenario(&s, c).map_err(|e| ClosedLoopError::CompareRun {
                scenario: s.name.clone(),
                seed,
                controller: c.name().to_string(),
                source: Box::new(e),
            })?;
            progress();
            Ok((i, c, metrics_of(&s, &r)))
        })
        .collect();
    let mut values: std::collections::BTreeMap<(usize, String, usize), Vec<f64>> =
        Default::default();
    for r in results {
        let (i, c, metrics) = r?;
        let ci = controllers.iter().position(|k| *k == c).unwrap_or(0);
        for (m, v) in metrics {
            values.entry((i, m, ci)).or_default().push(v);
        }
    }
    Ok(values
        .into_iter()
        .map(|((i, metric, ci), mut v)| {
            let median = median(&mut v);
            CompareRow {
                scenario: scenarios[i].name.clone(),
                metric,
                controller: controllers[ci].name().to_string(),
                n: v.len(),
                median,
                ci95: median_ci95(&v),
            }
        })
        .collect())
}
