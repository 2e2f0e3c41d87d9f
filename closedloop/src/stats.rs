//! Order statistics the harness reports with: the median and its distribution-free 95 % interval.

/// The order-statistic interval of the median of `sorted` (ascending): ranks `k` and `n + 1 − k` with the
/// largest `k` such that `P(Bin(n, ½) < k) ≤ 2.5 %`; NaN when no such `k ≥ 1` exists (n < 6).
///
/// # Examples
/// ```
/// use millcomp_closedloop::stats::median_ci95;
/// let x: Vec<f64> = (1..=10).map(f64::from).collect();
/// // n = 10: ranks 2 and 9 (coverage 97.9 %)
/// assert_eq!(median_ci95(&x), [2.0, 9.0]);
/// assert!(median_ci95(&x[..5])[0].is_nan());
/// ```
pub fn median_ci95(sorted: &[f64]) -> [f64; 2] {
    let n = sorted.len();
    // P(Bin(n, ½) ≤ j) by summing the probabilities
    let mut cdf = 0.0;
    let mut choose = 1.0f64; // C(n, j)
    let mut k = 0usize;
    for j in 0..n {
        cdf += choose * 0.5f64.powi(n as i32);
        if cdf <= 0.025 {
            k = j + 1; // P(X ≤ j) = P(X < j + 1) ≤ 2.5 %: rank j + 1 is admissible
        } else {
            break;
        }
        choose *= (n - j) as f64 / (j + 1) as f64;
    }
    if k == 0 {
        return [f64::NAN, f64::NAN];
    }
    [sorted[k - 1], sorted[n - k]]
}

/// Median of `v` (sorted in place; NaN when empty).
pub fn median(v: &mut [f64]) -> f64 {
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
