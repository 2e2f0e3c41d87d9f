//! The plots of a batch (`DIR/plots/`): each metric by controller (its values sorted over the
//! scenarios), and the peak-to-peak error by each varying factor (the mean per level and controller).

use std::path::{Path, PathBuf};

use super::factors::FactorValue;
use super::paired::varying_factors;
use super::plan::Plan;
use super::results::is_label;
use super::store::{METRICS, RunRecord};
use crate::error::ClosedLoopError;
use crate::plot::{Series, line_plot};

/// Plots: each metric by controller (sorted values over the scenarios), and the peak-to-peak error by
/// each varying factor (mean per level and controller).
///
/// # Errors
/// [`ClosedLoopError::CreateDir`] and [`ClosedLoopError::Plot`] naming the file.
pub fn plots(
    plan: &Plan,
    records: &[RunRecord],
    dir: &Path,
) -> Result<Vec<PathBuf>, ClosedLoopError> {
    std::fs::create_dir_all(dir).map_err(|source| ClosedLoopError::CreateDir {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::new();
    for metric in METRICS.iter().filter(|m| **m != "solver_fallbacks") {
        let series: Vec<Series> = plan
            .controllers
            .iter()
            .map(|c| {
                let mut v: Vec<f64> = records
                    .iter()
                    .filter(|r| &r.controller == c)
                    .filter_map(|r| r.metrics.get(metric))
                    .collect();
                v.sort_by(f64::total_cmp);
                let n = v.len().max(1) as f64;
                Series {
                    label: c.clone(),
                    points: v
                        .iter()
                        .enumerate()
                        .map(|(i, y)| ((i as f64 + 0.5) / n, *y))
                        .collect(),
                }
            })
            .collect();
        if series.iter().all(|s| s.points.is_empty()) {
            continue; // no run has this metric (a change excess without a change)
        }
        let path = dir.join(format!("{metric}_by_controller.svg"));
        line_plot(
            &path,
            &format!("{metric} by controller (sorted over scenarios)"),
            "fraction of scenarios",
            metric,
            &series,
        )?;
        files.push(path);
    }
    for f in varying_factors(plan, records) {
        let label = is_label(plan, &f);
        let mut levels: Vec<FactorValue> = Vec::new();
        for s in &plan.scenarios {
            if let Some(v) = s.factors.get(&f)
                && !levels.contains(v)
            {
                levels.push(v.clone());
            }
        }
        levels.sort_by(|a, b| match (a, b) {
            (FactorValue::Num(x), FactorValue::Num(y)) => x.total_cmp(y),
            _ => a.text().cmp(&b.text()),
        });
        let x_of = |v: &FactorValue, i: usize| match v {
            FactorValue::Num(x) if !label => *x,
            _ => i as f64,
        };
        let series: Vec<Series> = plan
            .controllers
            .iter()
            .map(|c| Series {
                label: c.clone(),
                points: levels
                    .iter()
                    .enumerate()
                    .filter_map(|(i, lv)| {
                        let v: Vec<f64> = records
                            .iter()
                            .filter(|r| {
                                &r.controller == c
                                    && plan.scenarios[r.scenario].factors.get(&f) == Some(lv)
                            })
                            .map(|r| r.metrics.pp_error_um)
                            .collect();
                        (!v.is_empty())
                            .then(|| (x_of(lv, i), v.iter().sum::<f64>() / v.len() as f64))
                    })
                    .collect(),
            })
            .collect();
        let x_label = if label {
            format!(
                "{f} ({})",
                levels
                    .iter()
                    .enumerate()
                    .map(|(i, l)| format!("{i}={}", l.text()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        } else {
            f.clone()
        };
        let path = dir.join(format!("pp_error_um_by_{f}.svg"));
        line_plot(
            &path,
            &format!("mean pp_error_um by {f}"),
            &x_label,
            "pp_error_um",
            &series,
        )?;
        files.push(path);
    }
    Ok(files)
}
