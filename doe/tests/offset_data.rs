//! The offset data shared by the float64-limit tests of two crates: doe's `offset_anova` and
//! identify's `offset_line` (which includes this file with `#[path]`), so that both read the same
//! responses and measure digits the same way.

/// Log relative error `−log₁₀|x − c|/|c|`, capped at 15 (a perfect match of float64 numbers).
pub fn lre(x: f64, c: f64) -> f64 {
    let err = ((x - c) / c).abs();
    if err == 0.0 {
        15.0
    } else {
        (-err.log10()).min(15.0)
    }
}

/// The responses of `fixtures/offset_responses.txt` (1e12 + d, d to four decimals), each parsed
/// from its decimal text: correctly rounded, as the exact references' `float()` of the same text.
pub fn offset_responses() -> Vec<f64> {
    let text = include_str!("fixtures/offset_responses.txt");
    let rows = text.lines().filter(|l| !l.starts_with('#'));
    rows.map(|l| l.trim().parse().unwrap()).collect()
}
