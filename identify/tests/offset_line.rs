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

#[path = "../../doe/tests/offset_data.rs"]
mod offset_data;
use offset_data::{lre, offset_responses};

#[test]
fn offset_line_within_half_a_digit_of_the_float64_limit() {
    let y = offset_responses();
    let a = DMatrix::from_fn(16, 2, |i, j| if j == 0 { 1.0 } else { 1e6 + i as f64 });
    let names = ["intercept".to_string(), "slope".to_string()];
    let fit = fit_linear(&names, &a, &y, None, LinearMethod::Qr, "line", "y").unwrap();
    // (quantity, estimate, exact on the decimal data, exact on the f64 inputs): exact_anova.py
    let checks = [
        (
            "slope",
            fit.report.param("slope"),
            0.0026954411764705884,
            0.0026984719669117647,
        ),
        (
            "rss",
            fit.report.rss,
            3.6781992323088235,
            3.6782569466268313,
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
