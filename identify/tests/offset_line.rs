//! A straight line through data with large offsets in both x (1e6 + i) and y (1e12 + d, d to four
//! decimals), against the exact answer: `fit_linear` centres before its QR, so it must come within
//! half a digit of the float64 limit.
//!
//! The float64 limit is the LRE (`−log₁₀|x − c|/|c|`) of the exact answer computed from the
//! f64-rounded inputs against the exact answer from the decimal data: the digits left once the
//! data are in float64. Reference values: `bench/peers/exact_anova.py` (Python `fractions`, exact
//! rational arithmetic), section "offset straight line".

use millcomp_identify::{LinearMethod, fit_linear};
use nalgebra::DMatrix;

fn lre(x: f64, c: f64) -> f64 {
    let err = ((x - c) / c).abs();
    if err == 0.0 {
        15.0
    } else {
        (-err.log10()).min(15.0)
    }
}

#[test]
fn offset_line_within_half_a_digit_of_the_float64_limit() {
    let y = [
        1000000000000.4440,
        1000000000001.4242,
        1000000000000.5059,
        1000000000001.5332,
        1000000000000.1188,
        1000000000001.2292,
        1000000000000.4354,
        1000000000001.5451,
        1000000000000.2726,
        1000000000001.2805,
        1000000000000.5109,
        1000000000001.1832,
        1000000000000.2099,
        1000000000000.8184,
        1000000000001.1097,
        1000000000001.0621,
    ];
    let a = DMatrix::from_fn(16, 2, |i, j| if j == 0 { 1.0 } else { 1e6 + i as f64 });
    let names = ["intercept".to_string(), "slope".to_string()];
    let fit = fit_linear(&names, &a, &y, None, LinearMethod::Qr, "line", "y").unwrap();
    // (quantity, estimate, exact on the decimal data, exact on the f64 inputs): exact_anova.py
    let checks = [
        (
            "slope",
            fit.report.param("slope"),
            2.69544117647058839e-3,
            2.69847196691176466e-3,
        ),
        (
            "rss",
            fit.report.rss,
            3.67819923230882351e0,
            3.67825694662683134e0,
        ),
    ];
    for (what, got, decimal, f64_exact) in checks {
        let limit = lre(f64_exact, decimal);
        let digits = lre(got, decimal);
        eprintln!(
            "OFFSET line {what}: {got:.15e}  LRE {digits:.2}  float64 limit {limit:.2}  vs exact-on-f64 {:.2}",
            lre(got, f64_exact)
        );
        assert!(
            digits >= limit - 0.5,
            "{what}: {digits:.2} digits, limit {limit:.2}"
        );
        assert!(
            lre(got, f64_exact) >= 9.0,
            "{what}: {:.2} digits vs exact on the f64 inputs",
            lre(got, f64_exact)
        );
    }
}
