//! Tests written for the mutants of `linear.rs` cargo-mutants found surviving
//! (docs/reliability-mutants.md): each asserts a number, worked by hand, where the mutated line decides.

use millcomp_identify::{LinearMethod, fit_linear};
use nalgebra::DMatrix;

/// A weighted line: the estimates solve the weighted normal equations (by hand: Σw = 11, Σwx = 22,
/// Σwx² = 60, Σwy = 39, Σwxy = 92, so a = 316/176, b = 154/176), and the RMS residual is that of the
/// *unweighted* residuals y − a − b·x (its documented meaning), for both factorisations. Kills
/// `linear.rs: replace / with * in fit_linear` (raw residuals from the weighted ones multiplied by
/// √w instead of divided).
#[test]
fn a_weighted_fit_reports_the_rms_of_its_unweighted_residuals() {
    let x: [f64; 5] = [0.0, 1.0, 2.0, 3.0, 4.0];
    let y: [f64; 5] = [1.0, 3.0, 2.0, 5.0, 4.0];
    let w = [1.0, 4.0, 1.0, 4.0, 1.0];
    let a = DMatrix::from_fn(5, 2, |i, j| if j == 0 { 1.0 } else { x[i] });
    let names = ["intercept".to_string(), "slope".to_string()];
    let (ia, ib): (f64, f64) = (316.0 / 176.0, 154.0 / 176.0);
    let rms = (x
        .iter()
        .zip(&y)
        .map(|(x, y)| (y - ia - ib * x).powi(2))
        .sum::<f64>()
        / 5.0)
        .sqrt();
    assert!((rms - 1.014283).abs() < 1e-6, "{rms}"); // √(5.143853 / 5), by hand
    for method in [LinearMethod::Qr, LinearMethod::Svd] {
        let fit = fit_linear(&names, &a, &y, Some(&w), method, "line", "um").unwrap();
        let r = &fit.report;
        assert!((r.param("intercept") - ia).abs() < 1e-12, "{method:?}");
        assert!((r.param("slope") - ib).abs() < 1e-12, "{method:?}");
        assert!(
            (r.rms_residual.value - rms).abs() < 1e-12,
            "{method:?}: {}",
            r.rms_residual.value
        );
    }
}

/// A line through the origin (no intercept column: the uncentred path), y = b·x on x = 1, 2, 3 and
/// y = 2, 4.5, 5.5: b = Σxy/Σx² = 27.5/14, RSS = Σy² − (Σxy)²/Σx² = 54.5 − 756.25/14 = 27/56, s² =
/// RSS/2 = 27/112, SE(b) = √(s²/Σx²) = √(27/1568) (by hand), for both factorisations. Kills
/// `linear.rs:156:40: replace - with + in fit_linear` (residuals A·θ + y instead of A·θ − y on this
/// path).
#[test]
fn a_line_through_the_origin_has_the_rss_of_its_residuals() {
    let x = [1.0, 2.0, 3.0];
    let y = [2.0, 4.5, 5.5];
    let a = DMatrix::from_fn(3, 1, |i, _| x[i]);
    let names = ["gain".to_string()];
    for method in [LinearMethod::Qr, LinearMethod::Svd] {
        let fit = fit_linear(&names, &a, &y, None, method, "proportional", "um").unwrap();
        let r = &fit.report;
        assert!((r.param("gain") - 27.5 / 14.0).abs() < 1e-12, "{method:?}");
        assert!((r.rss - 27.0 / 56.0).abs() < 1e-12, "{method:?}: {}", r.rss);
        assert!(
            (r.se("gain") - (27.0f64 / 1568.0).sqrt()).abs() < 1e-12,
            "{method:?}: {}",
            r.se("gain")
        );
    }
}
