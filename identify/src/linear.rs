//! Weighted linear least squares `min ‖W^½(Aθ − y)‖²` by QR (default) or SVD, with rank
//! deficiency detected and reported by parameter.
//!
//! With an intercept (a constant column) the other columns and the data are first centred on
//! their (weighted) means, so that data sharing a large offset keep all their digits; columns are
//! scaled to unit norm before factorising (so that a column in N and one in µN are judged alike); the QR is nalgebra's column-pivoted Householder QR, whose `|R_kk|/|R_00|`
//! reveals the numerical rank. A rank-deficient problem is not an error: the minimum-norm SVD
//! solution is returned with status `rank_deficient` and a warning naming the unseen combination.

use nalgebra::{DMatrix, DVector};

use crate::error::{IdentifyError, Result};
use crate::report::{FitReport, FitStatus, ReportInputs, build_report, thresholds};
use crate::validate;

/// Factorisation used by [`fit_linear`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinearMethod {
    /// Column-pivoted Householder QR (falls back to SVD when rank deficient).
    #[default]
    Qr,
    /// Singular value decomposition (minimum-norm solution).
    Svd,
}

/// Result of a linear fit: the report and the estimate vector in parameter order.
#[derive(Debug, Clone)]
pub struct LinearFit {
    /// The report.
    pub report: FitReport,
    /// Estimates in the order of the names passed in.
    pub theta: DVector<f64>,
}

/// Weighted linear least squares.
///
/// * `names` — one per column of `design`;
/// * `design` — n × p regressor matrix `A`;
/// * `y` — n observations (unit `unit`, used in the `rms_residual_<unit>` key);
/// * `weights` — optional inverse variances (> 0), one per row.
///
/// A rank-deficient design is not an error: the report's status is `rank_deficient` and a warning
/// names the combination the data cannot see.
///
/// # Errors
/// * [`IdentifyError::InvalidParameter`] (`names.len()`) unless there is one name per design
///   column, or (`weights[row]`) for a weight that is not > 0;
/// * [`IdentifyError::LengthMismatch`] when `y` or `weights` does not have one value per design row;
/// * [`IdentifyError::NonFinite`] naming the column (`y`, `weights` or the design column's name)
///   and the row of the first NaN or infinite value;
/// * [`IdentifyError::TooFewPoints`] unless there are more rows than columns;
/// * [`IdentifyError::SolverState`] if the triangular solve of a full-rank QR fails (a broken
///   invariant, not bad input).
///
/// # Examples
/// ```
/// use millcomp_identify::{IdentifyError, LinearMethod, fit_linear};
/// use nalgebra::DMatrix;
/// // y = [1, 3, 2, 5, 4] at x = 0..4; by hand (Σx = 10, Σx² = 30, Sxx = 10): slope 0.8,
/// // intercept 1.4, RSS 3.6, s² = 1.2, SE(slope) = √(1.2/10), SE(intercept) = √(1.2·30/(5·10))
/// let x = [0.0, 1.0, 2.0, 3.0, 4.0];
/// let y = [1.0, 3.0, 2.0, 5.0, 4.0];
/// let a = DMatrix::from_fn(5, 2, |i, j| if j == 0 { 1.0 } else { x[i] });
/// let names = ["intercept".to_string(), "slope".to_string()];
/// let fit = fit_linear(&names, &a, &y, None, LinearMethod::Qr, "line", "um").unwrap();
/// let r = &fit.report;
/// assert_eq!((r.rank, r.dof), (2, 3));
/// assert!((r.param("slope") - 0.8).abs() < 1e-12 && (r.param("intercept") - 1.4).abs() < 1e-12);
/// assert!((r.se("slope") - 0.12f64.sqrt()).abs() < 1e-12);
/// assert!((r.se("intercept") - 0.72f64.sqrt()).abs() < 1e-12);
/// // 95 % interval: ± t₀.₉₇₅(3)·SE, t₀.₉₇₅(3) = 3.1824463 (scipy.stats.t.ppf(0.975, 3))
/// assert!((r.ci95["slope"][1] - (0.8 + 3.1824463 * 0.12f64.sqrt())).abs() < 1e-6);
///
/// // two rows cannot determine a line with an uncertainty
/// let e = fit_linear(&names, &a.rows(0, 2).into_owned(), &y[..2], None, LinearMethod::Qr, "line", "um");
/// assert!(matches!(e, Err(IdentifyError::TooFewPoints { got: 2, needed: 3, .. })));
/// ```
pub fn fit_linear(
    names: &[String],
    design: &DMatrix<f64>,
    y: &[f64],
    weights: Option<&[f64]>,
    method: LinearMethod,
    model: &str,
    unit: &str,
) -> Result<LinearFit> {
    let (n, p) = design.shape();
    if names.len() != p {
        return Err(IdentifyError::InvalidParameter {
            name: "names.len()".into(),
            value: names.len() as f64,
            allowed: "one name per design column",
        });
    }
    validate::same_len("y", y, "design rows", n)?;
    validate::finite("y", y)?;
    for (j, name) in names.iter().enumerate() {
        let col: Vec<f64> = design.column(j).iter().copied().collect();
        validate::finite(name, &col)?;
    }
    let sw = validate::sqrt_weights(weights, n)?;
    validate::enough_points(n, p, model)?;

    let mut aw = design.clone();
    for (i, s) in sw.iter().enumerate() {
        aw.row_mut(i).scale_mut(*s);
    }
    // Centre on the (weighted) means when the design has an intercept: the slopes are fitted to
    // deviations, which keep every digit of data that share a large offset (a year, 1e12 + small
    // differences), and the intercept follows from the means. Same least-squares problem.
    let intercept = (p > 1)
        .then(|| {
            (0..p).find(|&j| {
                let v = design[(0, j)];
                v != 0.0 && design.column(j).iter().all(|&x| x == v)
            })
        })
        .flatten();
    let w2: Vec<f64> = sw.iter().map(|s| s * s).collect();
    let wsum: f64 = w2.iter().sum();
    let wmean = |v: &dyn Fn(usize) -> f64| -> f64 {
        let m0 = (0..n).map(|i| w2[i] * v(i)).sum::<f64>() / wsum;
        m0 + (0..n).map(|i| w2[i] * (v(i) - m0)).sum::<f64>() / wsum
    };
    let (theta, used, extra, resid_w) = match intercept {
        Some(c0) => {
            // The intercept column stays in the solve: it absorbs what the rounded means leave
            // (ȳ in f64 is off by up to half an ulp of the offset, which would otherwise add n·δ²
            // to the RSS); the centred columns are orthogonal to it up to rounding.
            let means: Vec<f64> = (0..p)
                .map(|j| {
                    if j == c0 {
                        0.0
                    } else {
                        wmean(&|i| design[(i, j)])
                    }
                })
                .collect();
            let my = wmean(&|i| y[i]);
            let ac = DMatrix::from_fn(n, p, |i, j| (design[(i, j)] - means[j]) * sw[i]);
            let yc = DVector::from_iterator(n, (0..n).map(|i| (y[i] - my) * sw[i]));
            let (mut theta, used, extra) = solve_scaled(&ac, &yc, method)?;
            let resid_w = &ac * &theta - &yc;
            theta[c0] += (my
                - means
                    .iter()
                    .zip(theta.iter())
                    .map(|(m, t)| m * t)
                    .sum::<f64>())
                / design[(0, c0)];
            (theta, used, extra, resid_w)
        }
        None => {
            let yw = DVector::from_iterator(n, y.iter().zip(&sw).map(|(y, s)| y * s));
            let (theta, used, extra) = solve_scaled(&aw, &yw, method)?;
            let resid_w = &aw * &theta - &yw;
            (theta, used, extra, resid_w)
        }
    };
    let resid_raw = DVector::from_iterator(n, resid_w.iter().zip(&sw).map(|(r, s)| r / s));
    let report = build_report(ReportInputs {
        model,
        method: used,
        names,
        theta: &theta,
        jac: &aw,
        resid_w: &resid_w,
        resid_raw: &resid_raw,
        unit,
        status: FitStatus::Converged,
        message: "solved exactly (linear least squares)".into(),
        iterations: 0,
        extra_warnings: extra,
    });
    Ok(LinearFit { report, theta })
}

/// Least squares `min ‖A θ − b‖` with the columns scaled to unit norm, by column-pivoted QR (SVD
/// when rank deficient) or SVD; returns θ, the method's name and any warning.
fn solve_scaled(
    aw: &DMatrix<f64>,
    yw: &DVector<f64>,
    method: LinearMethod,
) -> Result<(DVector<f64>, &'static str, Vec<String>)> {
    let p = aw.ncols();
    let col_norm: Vec<f64> = (0..p)
        .map(|j| {
            let c = aw.column(j).norm();
            if c > 0.0 { c } else { 1.0 }
        })
        .collect();
    let mut scaled = aw.clone();
    for (j, c) in col_norm.iter().enumerate() {
        scaled.column_mut(j).scale_mut(1.0 / c);
    }
    let mut extra = Vec::new();
    let (z, used) = match method {
        LinearMethod::Qr => {
            let qr = scaled.clone().col_piv_qr();
            let r = qr.r();
            let r00 = r[(0, 0)].abs();
            let deficient = (0..p).any(|k| r[(k, k)].abs() <= thresholds::RANK_RTOL * r00);
            if deficient {
                extra.push(
                    "QR found the design rank deficient; the minimum-norm SVD solution is reported"
                        .to_string(),
                );
                (svd_solve(&scaled, yw), "linear_svd")
            } else {
                // R z' = Qᵀ y, then undo the pivoting.
                let mut qty = yw.clone();
                qr.q_tr_mul(&mut qty);
                let rp = r.view((0, 0), (p, p)).into_owned();
                let zp = rp
                    .solve_upper_triangular(&qty.rows(0, p).into_owned())
                    .ok_or(IdentifyError::SolverState {
                        what: "triangular solve failed",
                    })?;
                let mut z = zp;
                qr.p().inv_permute_rows(&mut z);
                (z, "linear_qr")
            }
        }
        LinearMethod::Svd => (svd_solve(&scaled, yw), "linear_svd"),
    };
    let theta = DVector::from_iterator(p, z.iter().zip(&col_norm).map(|(z, c)| z / c));
    Ok((theta, used, extra))
}

fn svd_solve(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    svd.solve(b, thresholds::RANK_RTOL * smax)
        .unwrap_or_else(|_| DVector::zeros(a.ncols()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// The textbook line of a hand calculation of simple regression (Σx = 10, Σx² = 30, n = 5,
    /// Sxx = 10, Sxy = 8, ȳ = 3): y = [1, 3, 2, 5, 4] at x = 0..4 is the line 1.4 + 0.8·x, RSS = 3.6,
    /// s² = 1.2. Fitted by QR on a constant column of value `constant` (named `c`) and x (`m`).
    fn textbook_line(constant: f64) -> LinearFit {
        textbook_line_on(&["c", "m"], |i, j| if j == 0 { constant } else { i as f64 })
    }

    /// The textbook line's data fitted by QR on the design `column(i, j)` named `labels`.
    fn textbook_line_on(labels: &[&str], column: impl Fn(usize, usize) -> f64) -> LinearFit {
        let y = [1.0, 3.0, 2.0, 5.0, 4.0];
        let a = DMatrix::from_fn(5, 2, column);
        fit_linear(&names(labels), &a, &y, None, LinearMethod::Qr, "t", "um").unwrap()
    }

    /// A constant column of any value is the intercept: with the constant column 2 instead of 1 the
    /// textbook line's intercept 1.4 is carried by a coefficient of 0.7. Kills `linear.rs:150:17:
    /// replace / with * in fit_linear` (found by the draw of seed 52 beyond its first 300), which
    /// gives 2.8.
    #[test]
    fn a_constant_column_of_two_carries_half_the_intercept() {
        let f = textbook_line(2.0);
        assert_relative_eq!(f.theta[0], 0.7, max_relative = 1e-12);
        assert_relative_eq!(f.theta[1], 0.8, max_relative = 1e-12);
    }

    #[test]
    fn qr_and_svd_agree_on_line() {
        let x: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, x)| 1.0 + 0.5 * x + 0.01 * ((i * 7 % 5) as f64 - 2.0))
            .collect();
        let a = DMatrix::from_fn(10, 2, |i, j| if j == 0 { 1.0 } else { x[i] });
        let n = names(&["b0", "b1"]);
        let q = fit_linear(&n, &a, &y, None, LinearMethod::Qr, "t", "um").unwrap();
        let s = fit_linear(&n, &a, &y, None, LinearMethod::Svd, "t", "um").unwrap();
        assert_relative_eq!(q.theta, s.theta, max_relative = 1e-12);
        assert_eq!(q.report.method, "linear_qr");
    }

    #[test]
    fn textbook_line_standard_errors() {
        // SE(slope) = √(s²/Sxx) = √(1.2/10), SE(intercept) = √(s²·Σx²/(n·Sxx)) = √(1.2·30/(5·10)).
        let f = textbook_line(1.0);
        assert_relative_eq!(f.report.param("m"), 0.8, epsilon = 1e-12);
        assert_relative_eq!(f.report.param("c"), 1.4, epsilon = 1e-12);
        assert_relative_eq!(f.report.se("m"), (1.2f64 / 10.0).sqrt(), epsilon = 1e-12);
        assert_relative_eq!(
            f.report.se("c"),
            (1.2f64 * 30.0 / 50.0).sqrt(),
            epsilon = 1e-12
        );
        // t_{0.975}(3) = 3.1824463052837078 (scipy.stats.t.ppf(0.975, 3), scipy 1.17.1).
        let ci = f.report.ci95["m"];
        assert_relative_eq!(
            ci[1] - 0.8,
            3.1824463052837078 * (0.12f64).sqrt(),
            epsilon = 1e-9
        );
    }

    #[test]
    fn rank_deficiency_named() {
        // Columns b and c are identical: only b + c is identifiable.
        let a = DMatrix::from_fn(6, 3, |i, j| match j {
            0 => 1.0,
            _ => i as f64,
        });
        let y: Vec<f64> = (0..6)
            .map(|i| 1.0 + 2.0 * i as f64 + 0.1 * (i % 2) as f64)
            .collect();
        for m in [LinearMethod::Qr, LinearMethod::Svd] {
            let f = fit_linear(&names(&["a", "b", "c"]), &a, &y, None, m, "t", "um").unwrap();
            assert_eq!(f.report.status, FitStatus::RankDeficient);
            assert_eq!(f.report.rank, 2);
            let w = f.report.warnings.join("\n");
            assert!(
                w.contains("b") && w.contains("c") && w.contains("not identifiable"),
                "{w}"
            );
            // Minimum-norm solution splits the slope equally.
            assert_relative_eq!(f.theta[1], f.theta[2], epsilon = 1e-9);
            assert!(f.report.se("b").is_infinite());
        }
    }

    #[test]
    fn zero_column_named_on_its_own() {
        let a = DMatrix::from_fn(6, 3, |i, j| match j {
            0 => 1.0,
            1 => i as f64,
            _ => 0.0,
        });
        let y: Vec<f64> = (0..6)
            .map(|i| 1.0 + 2.0 * i as f64 + 0.1 * (i % 2) as f64)
            .collect();
        let f = fit_linear(
            &names(&["a", "b", "dead"]),
            &a,
            &y,
            None,
            LinearMethod::Svd,
            "t",
            "um",
        )
        .unwrap();
        assert_eq!(f.report.status, FitStatus::RankDeficient);
        assert_eq!(f.report.rank, 2);
        assert!(
            f.report.warnings[0].contains("parameter dead has no effect"),
            "{:?}",
            f.report.warnings
        );
        assert_eq!(f.report.warnings.len(), 1, "{:?}", f.report.warnings);
        // the identifiable parameters keep finite standard errors
        assert!(f.report.se("b").is_finite() && f.report.se("dead").is_infinite());
    }

    #[test]
    fn weights_downweight_outlier() {
        let x: Vec<f64> = (0..8).map(|i| i as f64).collect();
        let mut y: Vec<f64> = x.iter().map(|x| 2.0 * x).collect();
        y[7] += 10.0;
        let mut w = vec![1.0; 8];
        w[7] = 1e-12;
        let a = DMatrix::from_fn(8, 1, |i, _| x[i]);
        let f = fit_linear(
            &names(&["m"]),
            &a,
            &y,
            Some(&w),
            LinearMethod::Qr,
            "t",
            "um",
        )
        .unwrap();
        assert_relative_eq!(f.report.param("m"), 2.0, epsilon = 1e-6);
        let e = fit_linear(
            &names(&["m"]),
            &a,
            &y,
            Some(&[1.0; 3]),
            LinearMethod::Qr,
            "t",
            "um",
        );
        assert!(matches!(e, Err(IdentifyError::LengthMismatch { .. })));
    }

    #[test]
    fn too_few_and_nan() {
        let a = DMatrix::from_fn(2, 2, |i, j| (i + j) as f64);
        let e = fit_linear(
            &names(&["a", "b"]),
            &a,
            &[1.0, 2.0],
            None,
            LinearMethod::Qr,
            "t",
            "um",
        );
        assert!(matches!(e, Err(IdentifyError::TooFewPoints { got: 2, .. })));
        let a = DMatrix::from_fn(3, 1, |i, _| i as f64);
        let e = fit_linear(
            &names(&["a"]),
            &a,
            &[1.0, f64::NAN, 2.0],
            None,
            LinearMethod::Qr,
            "t",
            "um",
        );
        assert!(matches!(e, Err(IdentifyError::NonFinite { row: 2, .. })));
    }

    /// The intercept is found wherever its column stands, and only a constant column is one: the
    /// textbook line with the columns [x + 1, 1] (x + 1 = 1..5, whose first value is not 0) has slope
    /// 0.8 and intercept 1.4 − 0.8 = 0.6 (by hand). Kills `linear.rs:115:26: replace && with || in
    /// fit_linear` (found by the draw of seed 53), which takes the first column with a non-zero first
    /// value — x + 1 — for the intercept.
    #[test]
    fn the_intercept_column_may_stand_second() {
        let f = textbook_line_on(
            &["m", "c"],
            |i, j| if j == 0 { i as f64 + 1.0 } else { 1.0 },
        );
        assert_relative_eq!(f.theta[0], 0.8, max_relative = 1e-12);
        assert_relative_eq!(f.theta[1], 0.6, max_relative = 1e-12);
    }

    /// A weighted line on a constant column of 2 (by hand, weights w = 1, 2, 2, 1 at x = 0..3, y = 1,
    /// 3, 2, 6: Σw = 6, x̄_w = 1.5, ȳ_w = 17/6, Sxx = 5.5, Sxy = 6.5, slope 13/11, intercept 35/33,
    /// so the constant column's coefficient is 35/66; weighted RSS = Σ w r² = 2·3.5757… = 7.1515…,
    /// SE(slope) = √(s²/Sxx) with s² = RSS/2). Both methods. Targets the weighted centring and the
    /// intercept's recovery: linear.rs:140–150 (`* sw`, `- means`, `/ design[(0, c0)]`).
    #[test]
    fn a_weighted_line_on_a_constant_column_of_two_matches_the_hand_calculation() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [1.0, 3.0, 2.0, 6.0];
        let w = [1.0, 2.0, 2.0, 1.0];
        let a = DMatrix::from_fn(4, 2, |i, j| if j == 0 { 2.0 } else { x[i] });
        for method in [LinearMethod::Qr, LinearMethod::Svd] {
            let f =
                fit_linear(&names(&["c", "m"]), &a, &y, Some(&w), method, "line", "um").unwrap();
            let r = &f.report;
            assert_relative_eq!(r.param("m"), 13.0 / 11.0, max_relative = 1e-12);
            assert_relative_eq!(r.param("c"), 35.0 / 66.0, max_relative = 1e-12);
            let rss = 2.0 * 3.5757575757575757;
            assert_relative_eq!(r.rss, rss, max_relative = 1e-10);
            assert_relative_eq!(r.se("m"), (rss / 2.0 / 5.5).sqrt(), max_relative = 1e-10);
        }
    }

    /// A weighted line through the origin (no constant column; by hand, w = 1, 4, 1 at x = 1, 2, 3,
    /// y = 2, 5, 5: θ = Σwxy/Σwx² = 57/26, weighted RSS = Σ w r² = 2·2.0192307…, SE = √(s²/26)).
    /// Targets the uncentred branch: linear.rs:154 (`y * s`), :156 (`aw θ − yw`).
    #[test]
    fn a_weighted_proportional_fit_matches_the_hand_calculation() {
        let a = DMatrix::from_column_slice(3, 1, &[1.0, 2.0, 3.0]);
        let f = fit_linear(
            &names(&["k"]),
            &a,
            &[2.0, 5.0, 5.0],
            Some(&[1.0, 4.0, 1.0]),
            LinearMethod::Qr,
            "prop",
            "um",
        )
        .unwrap();
        let r = &f.report;
        assert_relative_eq!(r.param("k"), 57.0 / 26.0, max_relative = 1e-12);
        let rss = 2.0 * 2.019230769230769;
        assert_relative_eq!(r.rss, rss, max_relative = 1e-10);
        assert_relative_eq!(r.se("k"), (rss / 2.0 / 26.0).sqrt(), max_relative = 1e-10);
    }

    /// The SVD's rank cut sits at `RANK_RTOL · σ_max` of the column-scaled design: two unit columns
    /// (1, 0, 0, 0) and (1, ε, 0, 0) with ε = √2·10⁻¹⁰ have σ_max ≈ √2 and σ_min ≈ ε/√2 = 10⁻¹⁰, below
    /// the cut 1.41·10⁻¹⁰, so σ_min counts as zero and y = (1, 1, 0, 0) gets the minimum-norm answer
    /// along the dominant direction, θ ≈ (½, ½) (by hand: v₁ = (1, 1)/√2, u₁ᵀy/σ₁ ≈ 1/√2), not the exact
    /// solve's (1 − 1/ε, 1/ε) ≈ (−7·10⁹, 7·10⁹). Kills `linear.rs:233:40: replace * with / in svd_solve`
    /// (found by the draw of seed 54), whose cut 10⁻¹⁰/√2 keeps σ_min.
    #[test]
    fn a_singular_value_below_the_rank_cut_counts_as_zero() {
        let eps = std::f64::consts::SQRT_2 * 1e-10;
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 1.0, 0.0, eps, 0.0, 0.0, 0.0, 0.0]);
        let f = fit_linear(
            &names(&["a", "b"]),
            &a,
            &[1.0, 1.0, 0.0, 0.0],
            None,
            LinearMethod::Svd,
            "cut",
            "um",
        )
        .unwrap();
        assert_relative_eq!(f.theta[0], 0.5, max_relative = 1e-9);
        assert_relative_eq!(f.theta[1], 0.5, max_relative = 1e-9);
    }
}
