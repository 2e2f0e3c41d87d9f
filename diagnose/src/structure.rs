//! Residual structure: how the residual depends on the session variables that the candidate effects
//! depend on (time, engaged length, position, machine X, spindle speed, coolant, predicted force,
//! spindle temperature when measured).
//!
//! Per variable: the Pearson correlation with its t-test (`t = r√((n−2)/(1−r²))`, Student t with
//! n − 2 dof) and binned means (distinct values when there are at most [`MAX_DISCRETE`], else
//! [`N_BINS`] equal-count bins) with a one-way ANOVA F-test across the bins (FisherSnedecor with
//! k − 1, n − k dof), which also sees non-monotone structure such as a bow along X that has zero
//! correlation. Both p-values treat points as independent: they describe the residual, the
//! decisions are made by the nested F-tests of the forward selection.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor, StudentsT};

use crate::nominal::SessionModel;

/// Variables with at most this many distinct values are binned by value.
pub const MAX_DISCRETE: usize = 6;
/// Number of equal-count bins for continuous variables (6: ≥ 30 points per bin in a few-hundred
/// point session, so each bin mean has a standard error ≤ σ/5).
pub const N_BINS: usize = 6;

/// Mean residual over a range of one variable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bin {
    /// Smallest value of the variable in the bin.
    pub from: f64,
    /// Largest value of the variable in the bin.
    pub to: f64,
    /// Points in the bin.
    pub n: usize,
    /// Mean residual (measured − model) in the bin (µm).
    pub mean_um: f64,
}

/// Structure of the residual against one variable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureItem {
    /// Variable name (with unit).
    pub variable: String,
    /// Pearson correlation of residual and variable (`None` when the variable is constant).
    pub correlation: Option<f64>,
    /// Two-sided p-value of the correlation.
    pub correlation_p: Option<f64>,
    /// Binned means.
    pub bins: Vec<Bin>,
    /// One-way ANOVA p-value of "all bin means equal" (`None` with fewer than two bins).
    pub bins_p: Option<f64>,
}

fn pearson(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let n = x.len();
    if n < 3 {
        return None;
    }
    let mx = x.iter().sum::<f64>() / n as f64;
    let my = y.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    if sxx <= 1e-300 || syy <= 1e-300 {
        return None;
    }
    let r = (sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0);
    let dof = (n - 2) as f64;
    let p = if r.abs() >= 1.0 {
        0.0
    } else {
        let t = r * (dof / (1.0 - r * r)).sqrt();
        StudentsT::new(0.0, 1.0, dof)
            .map(|d| 2.0 * d.sf(t.abs()))
            .unwrap_or(f64::NAN)
    };
    Some((r, p))
}

fn bins(x: &[f64], y: &[f64]) -> (Vec<Bin>, Option<f64>) {
    let n = x.len();
    let mut idx: Vec<usize> = (0..n).filter(|&i| x[i].is_finite()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut distinct: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
    distinct.dedup();
    let groups: Vec<Vec<usize>> = if distinct.len() <= MAX_DISCRETE {
        distinct
            .iter()
            .map(|v| idx.iter().copied().filter(|&i| x[i] == *v).collect())
            .collect()
    } else {
        let k = N_BINS.min(idx.len());
        let mut out: Vec<Vec<usize>> = Vec::new();
        let mut start = 0;
        for b in 0..k {
            let mut end = (idx.len() * (b + 1)) / k;
            // keep equal values in one bin
            while end < idx.len() && end > 0 && x[idx[end]] == x[idx[end - 1]] {
                end += 1;
            }
            if end > start {
                out.push(idx[start..end].to_vec());
                start = end;
            }
        }
        out
    };
    let bins: Vec<Bin> = groups
        .iter()
        .filter(|g| !g.is_empty())
        .map(|g| Bin {
            from: x[g[0]],
            to: x[*g.last().unwrap_or(&g[0])],
            n: g.len(),
            mean_um: g.iter().map(|&i| y[i]).sum::<f64>() / g.len() as f64,
        })
        .collect();
    let k = bins.len();
    let p = if k >= 2 && n > k {
        let grand = y.iter().sum::<f64>() / n as f64;
        let ssb: f64 = bins
            .iter()
            .map(|b| b.n as f64 * (b.mean_um - grand).powi(2))
            .sum();
        let ssw: f64 = groups
            .iter()
            .zip(&bins)
            .map(|(g, b)| g.iter().map(|&i| (y[i] - b.mean_um).powi(2)).sum::<f64>())
            .sum();
        if ssw <= 0.0 {
            Some(0.0)
        } else {
            let f = (ssb / (k - 1) as f64) / (ssw / (n - k) as f64);
            FisherSnedecor::new((k - 1) as f64, (n - k) as f64)
                .ok()
                .map(|d| d.sf(f))
        }
    } else {
        None
    };
    (bins, p)
}

/// Structure of `resid` (measured − model, µm) against the session variables.
pub fn residual_structure(
    sm: &SessionModel,
    resid: &[f64],
    spindle_temp_c: Option<&[f64]>,
) -> Vec<StructureItem> {
    let pts = sm.points();
    let mut vars: Vec<(&str, Vec<f64>)> = vec![
        ("t_s", pts.iter().map(|p| p.t_s).collect()),
        (
            "cut_length_mm",
            pts.iter().map(|p| p.cut_length_mm).collect(),
        ),
        ("x_mm", pts.iter().map(|p| p.x_mm).collect()),
        ("machine_x_mm", pts.iter().map(|p| p.machine_x_mm).collect()),
        ("speed_rpm", pts.iter().map(|p| p.speed_rpm).collect()),
        (
            "coolant_on",
            pts.iter()
                .map(|p| f64::from(u8::from(p.coolant_on)))
                .collect(),
        ),
        ("force_z_n", pts.iter().map(|p| p.force_z_n).collect()),
        ("tilt_deg", pts.iter().map(|p| p.tilt_deg).collect()),
    ];
    if let Some(t) = spindle_temp_c {
        vars.push(("spindle_temp_c", t.to_vec()));
    }
    vars.into_iter()
        .map(|(name, x)| {
            let c = pearson(&x, resid);
            let (b, bp) = bins(&x, resid);
            StructureItem {
                variable: name.to_string(),
                correlation: c.map(|c| c.0),
                correlation_p: c.map(|c| c.1),
                bins: b,
                bins_p: bp,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pearson_and_bins_on_known_data() {
        // y = x exactly: r = 1, p = 0; a bow y = (x − 5)² has r = 0 but unequal bin means
        let x: Vec<f64> = (0..=60).map(|i| f64::from(i) / 6.0).collect();
        let (r, p) = pearson(&x, &x).unwrap();
        assert!((r - 1.0).abs() < 1e-12 && p == 0.0);
        let y: Vec<f64> = x.iter().map(|v| (v - 5.0) * (v - 5.0)).collect();
        let (r, _) = pearson(&x, &y).unwrap();
        assert!(r.abs() < 1e-12);
        let (b, p) = bins(&x, &y);
        assert_eq!(b.iter().map(|b| b.n).sum::<usize>(), 61);
        assert!(p.unwrap() < 1e-6, "{p:?}");
        // discrete variable: one bin per value
        let d = [0.0, 0.0, 1.0, 1.0, 1.0];
        let (b, _) = bins(&d, &[1.0, 3.0, 0.0, 0.0, 3.0]);
        assert_eq!(b.len(), 2);
        assert!((b[0].mean_um - 2.0).abs() < 1e-12 && (b[1].mean_um - 1.0).abs() < 1e-12);
    }
}
