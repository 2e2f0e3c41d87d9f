//! Regression on many candidate regressors with a stated selection rule, for records (the thermal
//! study, the wear laws): the standardised columns over a subset of rows factorised once by QR,
//! ordinary least squares on a subset of columns, ridge, stepwise selection by BIC, and contiguous
//! folds for blocked cross-validation.
//!
//! Columns are standardised over the fitting rows (mean 0, standard deviation 1) before they are
//! factorised, so that a temperature in °C and a speed lag in (krpm)^e are judged alike and
//! the ridge penalty `λ·n·‖β‖²` means the same for every column; the intercept is never penalised.
//!
//! ```
//! use millcomp_identify::regress::{Gram, stepwise_bic};
//! // y = 2·x0 + noise-free; x1 is unrelated: stepwise BIC keeps x0 only
//! let x0: Vec<f64> = (0..50).map(|i| i as f64).collect();
//! let x1: Vec<f64> = (0..50).map(|i| ((i * 7) % 11) as f64).collect();
//! let y: Vec<f64> = x0.iter().zip(&x1).map(|(a, b)| 2.0 * a + 1e-3 * (b - 5.0)).collect();
//! let rows: Vec<usize> = (0..50).collect();
//! let g = Gram::new(&[&x0, &x1], &y, &rows);
//! assert_eq!(stepwise_bic(&g, &[], &[0, 1]), vec![0, 1]); // x1 explains the 1e-3 wiggle exactly
//! let (beta, rss) = g.solve(&[0], 0.0).unwrap();
//! assert!((g.slope(0, beta[0]) - 2.0).abs() < 1e-3 && rss < 1e-3);
//! ```

use nalgebra::{DMatrix, DVector};

/// The standardised least-squares problem of `y` on columns `x` over `rows`, factorised once:
/// `Z = Q R` (Householder QR of the standardised columns), so that a fit on any subset `s` of the
/// columns solves the small problem `min ‖Qᵀy − R_s β‖` by its own QR — never the normal
/// equations `ZᵀZ β = Zᵀy`, whose condition number is the square of `Z`'s.
#[derive(Debug, Clone)]
pub struct Gram {
    mean: Vec<f64>,
    sd: Vec<f64>,
    ymean: f64,
    /// `R` of `Z = Q R` (min(n, p) × p).
    r: DMatrix<f64>,
    /// `Qᵀ(y − ȳ)`.
    qty: DVector<f64>,
    /// `‖(I − QQᵀ)(y − ȳ)‖²`: what no combination of the columns explains, computed directly.
    perp: f64,
    yy: f64,
    n: usize,
}

impl Gram {
    /// Factorises `Z` over `rows`, `Z` the columns standardised over those rows (a constant column
    /// keeps standard deviation 1 and is all zeros).
    pub fn new(x: &[&[f64]], y: &[f64], rows: &[usize]) -> Self {
        let p = x.len();
        let n = rows.len();
        let nf = n.max(1) as f64;
        // two-pass means: the second pass removes the rounding of the first
        let mean_of = |v: &dyn Fn(usize) -> f64| -> f64 {
            let m0 = rows.iter().map(|&i| v(i)).sum::<f64>() / nf;
            m0 + rows.iter().map(|&i| v(i) - m0).sum::<f64>() / nf
        };
        let mean: Vec<f64> = x.iter().map(|c| mean_of(&|i| c[i])).collect();
        let sd: Vec<f64> = x
            .iter()
            .zip(&mean)
            .map(|(c, m)| {
                let v = rows.iter().map(|&i| (c[i] - m).powi(2)).sum::<f64>() / nf;
                if v > 0.0 { v.sqrt() } else { 1.0 }
            })
            .collect();
        let ymean = mean_of(&|i| y[i]);
        let mut z = DMatrix::<f64>::zeros(n, p);
        for (j, c) in x.iter().enumerate() {
            for (k, &i) in rows.iter().enumerate() {
                z[(k, j)] = (c[i] - mean[j]) / sd[j];
            }
        }
        let yc = DVector::from_iterator(n, rows.iter().map(|&i| y[i] - ymean));
        let qr = z.qr();
        let q = qr.q();
        let qty = q.tr_mul(&yc);
        let perp = (&yc - &q * &qty).norm_squared();
        Gram {
            r: qr.r(),
            qty,
            perp,
            yy: yc.norm_squared(),
            mean,
            sd,
            ymean,
            n,
        }
    }

    /// Rows the problem was formed over.
    pub fn n(&self) -> usize {
        self.n
    }

    /// `Σ(y − ȳ)²` over the rows (the RSS of the intercept alone).
    pub fn total_ss(&self) -> f64 {
        self.yy
    }

    /// Standardised coefficients of columns `s` (with a free intercept) under the ridge penalty
    /// `lambda·n·‖β‖²` (0: ordinary least squares), and the residual sum of squares; `None` when the
    /// columns are linearly dependent (without a penalty). Solved by the QR of `[R_s; √(λn)·I]`;
    /// the RSS is `‖Qᵀy − R_s β‖² + λ-free remainder`, a sum of squares, never a difference.
    pub fn solve(&self, s: &[usize], lambda: f64) -> Option<(DVector<f64>, f64)> {
        if s.is_empty() {
            return Some((DVector::zeros(0), self.yy));
        }
        let k = s.len();
        let m = self.r.nrows();
        let sl = (lambda * self.n as f64).sqrt();
        let a = DMatrix::from_fn(m + k, k, |i, j| {
            if i < m {
                self.r[(i, s[j])]
            } else if i - m == j {
                sl
            } else {
                0.0
            }
        });
        let b = DVector::from_fn(m + k, |i, _| if i < m { self.qty[i] } else { 0.0 });
        let qr = a.qr();
        let rs = qr.r();
        let d0 = (0..k).map(|j| rs[(j, j)].abs()).fold(0.0, f64::max);
        if (0..k).any(|j| rs[(j, j)].abs() <= 1e-12 * d0) || d0 == 0.0 {
            return None;
        }
        let qtb = qr.q().tr_mul(&b);
        let beta = rs.solve_upper_triangular(&qtb.rows(0, k).into_owned())?;
        let fit = DVector::from_fn(m, |i, _| {
            self.qty[i] - (0..k).map(|j| self.r[(i, s[j])] * beta[j]).sum::<f64>()
        });
        let rss = fit.norm_squared() + self.perp;
        (rss.is_finite() && beta.iter().all(|b| b.is_finite())).then_some((beta, rss))
    }

    /// The prediction at row `i` of the fit `beta` on columns `s`.
    pub fn predict(&self, x: &[&[f64]], s: &[usize], beta: &DVector<f64>, i: usize) -> f64 {
        self.ymean
            + s.iter()
                .zip(beta.iter())
                .map(|(&j, b)| b * (x[j][i] - self.mean[j]) / self.sd[j])
                .sum::<f64>()
    }

    /// The coefficient of column `j` in its own units, from its standardised coefficient.
    pub fn slope(&self, j: usize, beta_std: f64) -> f64 {
        beta_std / self.sd[j]
    }

    /// The intercept in the data's units of the fit `beta` on columns `s`.
    pub fn intercept(&self, s: &[usize], beta: &DVector<f64>) -> f64 {
        self.ymean
            - s.iter()
                .zip(beta.iter())
                .map(|(&j, b)| b * self.mean[j] / self.sd[j])
                .sum::<f64>()
    }
}

/// BIC `n·ln(RSS/n) + k·ln n` of a least-squares fit with `k` coefficients (intercept included).
pub fn bic(rss: f64, n: usize, k: usize) -> f64 {
    let nf = n as f64;
    nf * (rss.max(1e-300) / nf).ln() + k as f64 * nf.ln()
}

/// Stepwise selection by BIC: the columns `forced` are always in; from `candidates`, the one that
/// lowers BIC most is added, then any whose removal lowers BIC is removed, until neither step
/// lowers it. Returns the selected candidates in the order they entered.
pub fn stepwise_bic(g: &Gram, forced: &[usize], candidates: &[usize]) -> Vec<usize> {
    let n = g.n();
    stepwise_by(forced, candidates, |s| {
        g.solve(s, 0.0).map(|(_, rss)| bic(rss, n, 1 + s.len()))
    })
}

/// Stepwise selection under any score of a column set (lower is better; `None`: cannot be fitted),
/// the rule of [`stepwise_bic`]: `score` gets `forced` followed by the selected candidates.
pub fn stepwise_by(
    forced: &[usize],
    candidates: &[usize],
    score: impl Fn(&[usize]) -> Option<f64>,
) -> Vec<usize> {
    let score_of = |sel: &[usize]| -> Option<f64> {
        let s: Vec<usize> = forced.iter().chain(sel).copied().collect();
        score(&s)
    };
    let mut sel: Vec<usize> = Vec::new();
    let Some(mut current) = score_of(&sel) else {
        return sel;
    };
    // each pass adds or removes one column; a score that strictly decreases cannot cycle, the cap
    // only guards against round-off ties
    for _ in 0..4 * candidates.len() + 1 {
        let mut best: Option<(f64, usize)> = None;
        for &j in candidates.iter().filter(|j| !sel.contains(j)) {
            let mut trial = sel.clone();
            trial.push(j);
            if let Some(b) = score_of(&trial) {
                if b < current && best.is_none_or(|(bb, _)| b < bb) {
                    best = Some((b, j));
                }
            }
        }
        let Some((b, j)) = best else { break };
        sel.push(j);
        current = b;
        loop {
            let mut drop: Option<(f64, usize)> = None;
            for k in 0..sel.len() {
                let mut trial = sel.clone();
                trial.remove(k);
                if let Some(b) = score_of(&trial) {
                    if b < current && drop.is_none_or(|(bb, _)| b < bb) {
                        drop = Some((b, k));
                    }
                }
            }
            match drop {
                Some((b, k)) => {
                    sel.remove(k);
                    current = b;
                }
                None => break,
            }
        }
    }
    sel
}

/// Lag-1 sample autocorrelation of a series (0 for fewer than 3 values or a constant one).
pub fn lag1_autocorrelation(r: &[f64]) -> f64 {
    let n = r.len();
    if n < 3 {
        return 0.0;
    }
    let m = r.iter().sum::<f64>() / n as f64;
    let c0: f64 = r.iter().map(|x| (x - m).powi(2)).sum();
    if c0 <= 0.0 {
        return 0.0;
    }
    (1..n).map(|i| (r[i] - m) * (r[i - 1] - m)).sum::<f64>() / c0
}

/// The effective number of independent samples of a series of `n` residuals with lag-1
/// autocorrelation `r` (AR(1) approximation): `n·(1 − r)/(1 + r)`, r clamped to [0, 0.999].
pub fn effective_n(n: usize, r: f64) -> f64 {
    let r = r.clamp(0.0, 0.999);
    n as f64 * (1.0 - r) / (1.0 + r)
}

/// `rows` split into `k` contiguous blocks of (nearly) equal size, in order: the folds of blocked
/// cross-validation (neighbouring samples of a time series are not independent, so a fold holds
/// out a whole stretch).
///
/// ```
/// let f = millcomp_identify::regress::blocked_folds(&(0..10).collect::<Vec<_>>(), 3);
/// assert_eq!(f, vec![vec![0, 1, 2, 3], vec![4, 5, 6], vec![7, 8, 9]]);
/// ```
pub fn blocked_folds(rows: &[usize], k: usize) -> Vec<Vec<usize>> {
    let k = k.max(1).min(rows.len().max(1));
    let (q, r) = (rows.len() / k, rows.len() % k);
    let mut out = Vec::with_capacity(k);
    let mut start = 0;
    for f in 0..k {
        let len = q + usize::from(f < r);
        out.push(rows[start..start + len].to_vec());
        start += len;
    }
    out
}

/// The rows of `rows` not in `fold` (both sorted).
pub fn complement(rows: &[usize], fold: &[usize]) -> Vec<usize> {
    let (lo, hi) = (fold.first().copied(), fold.last().copied());
    rows.iter()
        .copied()
        .filter(|&i| match (lo, hi) {
            (Some(a), Some(b)) => i < a || i > b,
            _ => true,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ridge_shrinks_and_ols_matches_the_direct_solution() {
        let x0: Vec<f64> = (0..40).map(|i| (i as f64 * 0.3).sin()).collect();
        let x1: Vec<f64> = (0..40).map(|i| i as f64 / 40.0).collect();
        let y: Vec<f64> = (0..40)
            .map(|i| 1.0 + 3.0 * x0[i] - 2.0 * x1[i] + 0.01 * ((i % 5) as f64 - 2.0))
            .collect();
        let rows: Vec<usize> = (0..40).collect();
        let g = Gram::new(&[&x0, &x1], &y, &rows);
        let (b, rss) = g.solve(&[0, 1], 0.0).unwrap();
        // the same fit by the raw normal equations
        let a = DMatrix::from_fn(40, 3, |i, j| [1.0, x0[i], x1[i]][j]);
        let normal = (a.transpose() * &a)
            .cholesky()
            .unwrap()
            .solve(&(a.transpose() * DVector::from_vec(y.clone())));
        assert!((g.slope(0, b[0]) - normal[1]).abs() < 1e-9);
        assert!((g.slope(1, b[1]) - normal[2]).abs() < 1e-9);
        assert!((g.intercept(&[0, 1], &b) - normal[0]).abs() < 1e-9);
        let direct: f64 = (0..40)
            .map(|i| (y[i] - g.predict(&[&x0, &x1], &[0, 1], &b, i)).powi(2))
            .sum();
        assert!((rss - direct).abs() < 1e-9 * direct.max(1e-12));
        let (br, rssr) = g.solve(&[0, 1], 1.0).unwrap();
        assert!(br.norm() < b.norm() && rssr > rss);
    }

    #[test]
    fn folds_and_complements() {
        let rows: Vec<usize> = (5..15).collect();
        let f = blocked_folds(&rows, 3);
        assert_eq!(f.iter().map(Vec::len).collect::<Vec<_>>(), [4, 3, 3]);
        assert_eq!(complement(&rows, &f[1]), [5, 6, 7, 8, 12, 13, 14]);
    }
}
