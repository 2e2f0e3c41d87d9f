//! Controllers compared scenario by scenario: every controller of a batch ran on the same scenarios, so
//! its difference to a reference controller on each scenario removes what the conditions do to both —
//! the test the factorial ANOVA cannot make when the conditions' own interactions fill its residual.
//!
//! For each metric where smaller is better (`pp_error_um`, `change_excess_um`) and each controller
//! against the reference (`pid-tuned` when it ran, else the first controller): the differences
//! `controller − reference` over the scenarios both have, their median with the distribution-free 95 %
//! interval ([`crate::stats::median_ci95`]), the paired t-test and the sign test (two-sided), and the
//! median difference at each level of each varying factor — which names the conditions where the
//! controller does not help; the pseudo-factor `stroke` (`limited` / `covers`) splits the scenarios by
//! whether the reference run met more deflection than the PZT's range (its stroke bound).

use std::collections::BTreeMap;

use serde::Serialize;
use statrs::distribution::{Binomial, ContinuousCDF, DiscreteCDF, StudentsT};

use super::factors::FactorValue;
use super::plan::Plan;
use super::store::RunRecord;
use crate::stats::{median, median_ci95};

/// Metrics compared (smaller is better).
pub const PAIRED_METRICS: [&str; 2] = ["pp_error_um", "change_excess_um"];

/// The reference controller when it ran.
pub const REFERENCE: &str = "pid-tuned";

/// The median difference at one level of one factor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelDiff {
    /// Factor.
    pub factor: String,
    /// Level.
    pub level: String,
    /// Scenarios at this level.
    pub n: usize,
    /// Median of `controller − reference` (µm; < 0: the controller is better).
    pub median_diff: f64,
}

/// One controller against the reference on one metric.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairedEntry {
    /// Metric.
    pub metric: String,
    /// Controller.
    pub controller: String,
    /// Reference controller.
    pub reference: String,
    /// Scenarios both have the metric for.
    pub n: usize,
    /// Median of `controller − reference` (µm; < 0: the controller is better).
    pub median_diff: f64,
    /// Distribution-free 95 % interval of that median (NaN below 6 scenarios).
    pub ci95: [f64; 2],
    /// Mean difference (µm).
    pub mean_diff: f64,
    /// Paired t-test, two-sided (None below 2 scenarios or with no spread).
    pub t_p_value: Option<f64>,
    /// Sign test, two-sided (ties dropped).
    pub sign_p_value: Option<f64>,
    /// Scenarios where the controller is better (smaller).
    pub better: usize,
    /// Scenarios where it is worse.
    pub worse: usize,
    /// Median difference per level of each varying factor.
    pub by_level: Vec<LevelDiff>,
}

/// Factors that vary over the scenarios of these records.
pub fn varying_factors(plan: &Plan, records: &[RunRecord]) -> Vec<String> {
    plan.factor_names
        .iter()
        .filter(|f| {
            let mut vals: Vec<String> = records
                .iter()
                .filter_map(|r| plan.scenarios[r.scenario].factors.get(*f))
                .map(FactorValue::text)
                .collect();
            vals.sort();
            vals.dedup();
            vals.len() > 1
        })
        .cloned()
        .collect()
}

/// The paired comparisons of a batch (empty with fewer than two controllers or no reference).
pub fn paired(plan: &Plan, records: &[RunRecord]) -> Vec<PairedEntry> {
    let reference = if plan.controllers.iter().any(|c| c == REFERENCE) {
        REFERENCE.to_string()
    } else {
        match plan.controllers.first() {
            Some(c) => c.clone(),
            None => return Vec::new(),
        }
    };
    let factors = varying_factors(plan, records);
    // the reference run's stroke bound per scenario (grooves)
    let stroke: BTreeMap<usize, f64> = records
        .iter()
        .filter(|r| r.controller == reference)
        .filter_map(|r| r.metrics.stroke_bound_um.map(|b| (r.scenario, b)))
        .collect();
    let mut out = Vec::new();
    for metric in PAIRED_METRICS {
        let value = |c: &str| -> BTreeMap<usize, f64> {
            records
                .iter()
                .filter(|r| r.controller == c)
                .filter_map(|r| {
                    r.metrics
                        .get(metric)
                        .filter(|v| v.is_finite())
                        .map(|v| (r.scenario, v))
                })
                .collect()
        };
        let base = value(&reference);
        for c in plan.controllers.iter().filter(|c| **c != reference) {
            let diffs: Vec<(usize, f64)> = value(c)
                .into_iter()
                .filter_map(|(s, v)| base.get(&s).map(|b| (s, v - b)))
                .collect();
            if diffs.is_empty() {
                continue;
            }
            let d: Vec<f64> = diffs.iter().map(|x| x.1).collect();
            let mut sorted = d.clone();
            let median_diff = median(&mut sorted); // sorts `sorted`, as median_ci95 needs
            let by_level = factors
                .iter()
                .flat_map(|f| {
                    let mut levels: BTreeMap<String, Vec<f64>> = BTreeMap::new();
                    for (s, x) in &diffs {
                        if let Some(v) = plan.scenarios[*s].factors.get(f) {
                            levels.entry(FactorValue::text(v)).or_default().push(*x);
                        }
                    }
                    levels.into_iter().map(move |(level, mut v)| LevelDiff {
                        factor: f.clone(),
                        level,
                        n: v.len(),
                        median_diff: median(&mut v),
                    })
                })
                .chain(stroke_levels(&diffs, &stroke))
                .collect();
            out.push(PairedEntry {
                metric: metric.to_string(),
                controller: c.clone(),
                reference: reference.clone(),
                n: d.len(),
                median_diff,
                ci95: median_ci95(&sorted),
                mean_diff: d.iter().sum::<f64>() / d.len() as f64,
                t_p_value: paired_t(&d),
                sign_p_value: sign_test(&d),
                better: d.iter().filter(|x| **x < 0.0).count(),
                worse: d.iter().filter(|x| **x > 0.0).count(),
                by_level,
            });
        }
    }
    out
}

/// The median difference where the reference run was stroke-limited (its stroke bound above
/// [`STROKE_LIMITED_UM`]: the deflection met exceeds the PZT's range, no controller can follow) and where
/// the stroke covered the deflection — as the pseudo-factor `stroke` with levels `limited` / `covers`.
fn stroke_levels(diffs: &[(usize, f64)], stroke: &BTreeMap<usize, f64>) -> Vec<LevelDiff> {
    let mut out = Vec::new();
    for (level, limited) in [("limited", true), ("covers", false)] {
        let mut v: Vec<f64> = diffs
            .iter()
            .filter(|(s, _)| {
                stroke
                    .get(s)
                    .is_some_and(|b| (*b > STROKE_LIMITED_UM) == limited)
            })
            .map(|x| x.1)
            .collect();
        if !v.is_empty() {
            out.push(LevelDiff {
                factor: "stroke".into(),
                level: level.into(),
                n: v.len(),
                median_diff: median(&mut v),
            });
        }
    }
    out
}

/// A reference run whose stroke bound exceeds this (µm) was stroke-limited.
pub const STROKE_LIMITED_UM: f64 = 0.1;

/// Two-sided p-value of the paired t-test of differences `d` (mean 0 under the null).
///
/// ```
/// use millcomp_closedloop::batch::paired::paired_t;
/// // Student (1908) sleep data, drug 2 − drug 1: t = 4.062, df = 9, p = 0.002833 (R: t.test(paired = TRUE))
/// let d = [1.2, 2.4, 1.3, 1.3, 0.0, 1.0, 1.8, 0.8, 4.6, 1.4];
/// assert!((paired_t(&d).unwrap() - 0.002833).abs() < 1e-5);
/// ```
pub fn paired_t(d: &[f64]) -> Option<f64> {
    let n = d.len();
    if n < 2 {
        return None;
    }
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    if var <= 0.0 {
        return None;
    }
    let t = mean / (var / n as f64).sqrt();
    let dist = StudentsT::new(0.0, 1.0, (n - 1) as f64).ok()?;
    Some((2.0 * (1.0 - dist.cdf(t.abs()))).min(1.0))
}

/// Two-sided p-value of the sign test of differences `d` (zeros dropped).
///
/// ```
/// use millcomp_closedloop::batch::paired::sign_test;
/// // 9 of 10 positive: 2·P(Bin(10, ½) ≤ 1) = 2·11/1024 = 0.021484
/// let d = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, -1.0];
/// assert!((sign_test(&d).unwrap() - 22.0 / 1024.0).abs() < 1e-12);
/// ```
pub fn sign_test(d: &[f64]) -> Option<f64> {
    let pos = d.iter().filter(|x| **x > 0.0).count() as u64;
    let neg = d.iter().filter(|x| **x < 0.0).count() as u64;
    let n = pos + neg;
    if n == 0 {
        return None;
    }
    let b = Binomial::new(0.5, n).ok()?;
    Some((2.0 * b.cdf(pos.min(neg))).min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::batch::exec::RunMetrics;
    use crate::batch::factors::ScenarioSpec;

    fn record(scenario: usize, controller: &str, pp: f64, stroke: f64) -> RunRecord {
        RunRecord {
            fingerprint: "f".into(),
            run: 0,
            scenario,
            controller: controller.into(),
            metrics: RunMetrics {
                pp_error_um: pp,
                rms_error_um: 0.0,
                max_error_um: 0.0,
                min_error_um: 0.0,
                actuator_travel_um: 0.0,
                solver_fallbacks: 0,
                change_excess_um: None,
                stroke_bound_um: Some(stroke),
                optimum_pp_um: None,
                change_bound_um: None,
                solve_median_us: None,
                solve_p99_us: None,
                solve_max_us: None,
                deadline_misses: None,
            },
            simulated_s: 1.0,
            wall_clock_s: 0.0,
        }
    }

    /// Eight scenarios, tilt 20/40: the MPC is 0.5 µm better than pid-tuned where the stroke covers
    /// (tilt 20) and 1 µm worse where the reference was stroke-limited (tilt 40).
    #[test]
    fn differences_by_scenario_level_and_stroke() {
        let scenarios: Vec<ScenarioSpec> = (0..8)
            .map(|i| ScenarioSpec {
                index: i,
                factors: [(
                    "tilt_deg".to_string(),
                    FactorValue::Num(if i < 4 { 20.0 } else { 40.0 }),
                )]
                .into(),
            })
            .collect();
        let plan = Plan {
            format: "x".into(),
            base_scenario: "x".into(),
            factor_names: vec!["tilt_deg".into()],
            scenarios,
            controllers: vec!["pid-tuned".into(), "mpc".into()],
            fingerprint: "f".into(),
        };
        let mut records = Vec::new();
        for s in 0..8 {
            let (base, stroke) = (2.0 + s as f64, if s < 4 { 0.0 } else { 3.0 });
            records.push(record(s, "pid-tuned", base, stroke));
            records.push(record(
                s,
                "mpc",
                base + if s < 4 { -0.5 } else { 1.0 },
                stroke,
            ));
        }
        let p = paired(&plan, &records);
        assert_eq!(p.len(), 1, "{p:?}"); // no change excess in these records
        let p = &p[0];
        assert_eq!(
            (p.reference.as_str(), p.n, p.better, p.worse),
            ("pid-tuned", 8, 4, 4)
        );
        assert!((p.mean_diff - 0.25).abs() < 1e-12);
        let level = |f: &str, l: &str| {
            p.by_level
                .iter()
                .find(|x| x.factor == f && x.level == l)
                .unwrap()
                .median_diff
        };
        assert_eq!(level("tilt_deg", "20"), -0.5);
        assert_eq!(level("tilt_deg", "40"), 1.0);
        assert_eq!(level("stroke", "covers"), -0.5);
        assert_eq!(level("stroke", "limited"), 1.0);
        // 4 of 8 each way: the sign test sees nothing
        assert_eq!(p.sign_p_value, Some(1.0));
    }
}
