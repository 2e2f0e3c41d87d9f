//! Maximin Latin hypercube.

use rand::Rng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{BasePoints, DesignCriteria, DesignRequest, require_two_levels};
use crate::error::{DoeError, Result};

/// Largest Latin hypercube built (the search keeps an n × n distance matrix).
const MAX_LHS_RUNS: usize = 5000;
/// Exponent of the Morris–Mitchell criterion.
const PHI_P: i32 = 15;

/// Squared distances between all rows.
fn sq_dists(pts: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = pts.len();
    let mut d = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let s: f64 = pts[i]
                .iter()
                .zip(&pts[j])
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            d[i][j] = s;
            d[j][i] = s;
        }
    }
    d
}

/// d^{−p} from a squared distance (floored so coincident points give a huge but finite penalty).
fn inv_p(sq: f64) -> f64 {
    sq.max(1e-300).sqrt().powi(-PHI_P)
}

/// Maximin Latin hypercube in coded units: each factor's n levels are the stratum midpoints
/// −1 + (2i + 1)/n; several random starts are improved by swapping two runs' levels of one factor, a swap
/// being kept when the Morris–Mitchell criterion φ_p = (Σ_{i<j} d_ij^{−p})^{1/p} (p = 15) decreases
/// (Morris & Mitchell 1995, J. Stat. Plann. Inference 43:381–402; φ_p → 1/min d as p grows). A swap changes
/// only the distances from the two runs involved, so each trial costs O(n·k).
pub(crate) fn lhs(req: &DesignRequest, rng: &mut ChaCha8Rng) -> Result<BasePoints> {
    let factors = &req.factors;
    require_two_levels(factors, "lhs", false)?;
    let k = factors.len();
    let n = req.runs.unwrap_or(10 * k);
    if !(2..=MAX_LHS_RUNS).contains(&n) {
        return Err(DoeError::InvalidParameter {
            name: "runs",
            value: n.to_string(),
            allowed: format!("2 to {MAX_LHS_RUNS} for a Latin hypercube"),
        });
    }
    let level = |i: usize| -1.0 + (2 * i + 1) as f64 / n as f64;
    let restarts = 5;
    let swaps = (100 * n).min(5000);
    let mut best: Option<(f64, Vec<Vec<f64>>)> = None;
    for _ in 0..restarts {
        let cols: Vec<Vec<f64>> = (0..k)
            .map(|_| {
                let mut perm: Vec<usize> = (0..n).collect();
                perm.shuffle(rng);
                perm.into_iter().map(level).collect()
            })
            .collect();
        let mut pts: Vec<Vec<f64>> = (0..n)
            .map(|r| cols.iter().map(|c| c[r]).collect())
            .collect();
        let mut d = sq_dists(&pts);
        let mut sum: f64 = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .map(|(i, j)| inv_p(d[i][j]))
            .sum();
        let mut new_a = vec![0.0; n];
        let mut new_b = vec![0.0; n];
        for _ in 0..swaps {
            let j = rng.random_range(0..k);
            let a = rng.random_range(0..n);
            let b = rng.random_range(0..n);
            if a == b {
                continue;
            }
            let (xa, xb) = (pts[a][j], pts[b][j]);
            let mut delta = 0.0;
            for r in 0..n {
                if r == a || r == b {
                    continue;
                }
                let xr = pts[r][j];
                new_a[r] = d[a][r] - (xa - xr).powi(2) + (xb - xr).powi(2);
                new_b[r] = d[b][r] - (xb - xr).powi(2) + (xa - xr).powi(2);
                delta += inv_p(new_a[r]) - inv_p(d[a][r]) + inv_p(new_b[r]) - inv_p(d[b][r]);
            }
            if delta < 0.0 {
                sum += delta;
                pts[a][j] = xb;
                pts[b][j] = xa;
                for r in 0..n {
                    if r == a || r == b {
                        continue;
                    }
                    d[a][r] = new_a[r];
                    d[r][a] = new_a[r];
                    d[b][r] = new_b[r];
                    d[r][b] = new_b[r];
                }
            }
        }
        let phi = sum.powf(1.0 / PHI_P as f64);
        if best.as_ref().is_none_or(|(bp, _)| phi < *bp) {
            best = Some((phi, pts));
        }
    }
    let (_, pts) = best.unwrap_or((0.0, Vec::new()));
    let dmin = sq_dists(&pts)
        .iter()
        .enumerate()
        .flat_map(|(i, row)| row.iter().skip(i + 1).copied().collect::<Vec<_>>())
        .fold(f64::INFINITY, f64::min)
        .sqrt();
    let mut bp = BasePoints::unblocked(pts);
    bp.criteria = DesignCriteria {
        min_distance: Some(dmin),
        ..Default::default()
    };
    bp.notes.push(format!(
        "maximin Latin hypercube: {restarts} starts × {swaps} swaps (Morris–Mitchell φ_15)"
    ));
    Ok(bp)
}
