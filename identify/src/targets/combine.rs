//! Combining independent group fits (e.g. one per stiffness direction) into one report with a
//! block-diagonal covariance (the groups share no data, so their estimates are independent).

use std::collections::BTreeMap;

use nalgebra::DMatrix;

use crate::report::{FitReport, FitStatus, NamedMatrix, ResidualDiagnostics, RmsResidual};

/// Prefixes every parameter of `r` with `prefix` (no-op for an empty prefix).
pub(crate) fn prefixed(mut r: FitReport, prefix: &str) -> FitReport {
    if prefix.is_empty() {
        return r;
    }
    let pre = |m: BTreeMap<String, f64>| -> BTreeMap<String, f64> {
        m.into_iter()
            .map(|(k, v)| (format!("{prefix}{k}"), v))
            .collect()
    };
    r.params = pre(r.params);
    r.std_err = pre(r.std_err);
    r.ci95 = r
        .ci95
        .into_iter()
        .map(|(k, v)| (format!("{prefix}{k}"), v))
        .collect();
    for m in [&mut r.covariance, &mut r.correlation] {
        m.names = m.names.iter().map(|n| format!("{prefix}{n}")).collect();
    }
    r
}

/// One report from independent group reports (already prefixed).
pub(crate) fn combine(model: &str, groups: &BTreeMap<String, FitReport>) -> FitReport {
    let mut names = Vec::new();
    for g in groups.values() {
        names.extend(g.covariance.names.iter().cloned());
    }
    let p = names.len();
    let mut cov = DMatrix::<f64>::zeros(p, p);
    let mut corr = DMatrix::<f64>::zeros(p, p);
    let mut off = 0;
    let mut params = BTreeMap::new();
    let mut std_err = BTreeMap::new();
    let mut ci95 = BTreeMap::new();
    let mut warnings = Vec::new();
    let mut fixed = BTreeMap::new();
    let (mut n_obs, mut dof, mut rank, mut iterations) = (0, 0, 0, 0);
    let mut ss = 0.0;
    let mut rss_w = 0.0;
    let mut cond: f64 = 0.0;
    let mut status = FitStatus::Converged;
    let mut unit = String::new();
    let mut method = String::new();
    for (gname, g) in groups {
        let k = g.covariance.names.len();
        let c = g.covariance.to_matrix();
        let r = g.correlation.to_matrix();
        for i in 0..k {
            for j in 0..k {
                cov[(off + i, off + j)] = c[(i, j)];
                corr[(off + i, off + j)] = r[(i, j)];
            }
        }
        off += k;
        params.extend(g.params.clone());
        std_err.extend(g.std_err.clone());
        ci95.extend(g.ci95.clone());
        fixed.extend(g.fixed.clone());
        warnings.extend(g.warnings.iter().map(|w| format!("[{gname}] {w}")));
        n_obs += g.n_obs;
        dof += g.dof;
        rank += g.rank;
        iterations += g.iterations;
        ss += g.rms_residual.value.powi(2) * g.n_obs as f64;
        rss_w += g.rss;
        cond = cond.max(g.condition_number);
        unit = g.rms_residual.unit.clone();
        method = g.method.clone();
        status = match (status, g.status) {
            (FitStatus::RankDeficient, _) | (_, FitStatus::RankDeficient) => {
                FitStatus::RankDeficient
            }
            (FitStatus::NotConverged, _) | (_, FitStatus::NotConverged) => FitStatus::NotConverged,
            (FitStatus::StalledAtRoundingLevel, _) | (_, FitStatus::StalledAtRoundingLevel) => {
                FitStatus::StalledAtRoundingLevel
            }
            _ => FitStatus::Converged,
        };
    }
    let to_named = |m: &DMatrix<f64>| NamedMatrix {
        names: names.clone(),
        values: (0..p)
            .map(|i| (0..p).map(|j| m[(i, j)]).collect())
            .collect(),
    };
    FitReport {
        model: model.to_string(),
        method,
        status,
        message: format!(
            "{} independent group fits: {}",
            groups.len(),
            groups.keys().cloned().collect::<Vec<_>>().join(", ")
        ),
        params,
        std_err,
        ci95,
        covariance: to_named(&cov),
        correlation: to_named(&corr),
        condition_number: cond,
        rank,
        rms_residual: RmsResidual {
            value: (ss / n_obs.max(1) as f64).sqrt(),
            unit,
        },
        rss: rss_w,
        residual_std: (rss_w / dof.max(1) as f64).sqrt(),
        n_obs,
        dof,
        iterations,
        diagnostics: ResidualDiagnostics::default(),
        warnings,
        fixed,
    }
}
