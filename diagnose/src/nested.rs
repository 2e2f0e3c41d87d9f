//! The nested F-test and BIC comparison that decide whether a candidate effect is added — one
//! rule for the depth channel (forward selection) and the force channel.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

/// The test of one candidate in one round.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decision {
    /// Candidate effect.
    pub effect: String,
    /// Nested F statistic.
    pub f_statistic: f64,
    /// Numerator dof (the candidate's free parameters).
    pub df1: usize,
    /// Denominator dof (n − parameters of the augmented model).
    pub df2: usize,
    /// p-value of the F-test.
    pub p_value: f64,
    /// α / m of the round.
    pub threshold: f64,
    /// BIC of the current model.
    pub bic_before: f64,
    /// BIC of the augmented model.
    pub bic_after: f64,
    /// RSS of the augmented model (µm² or N²).
    pub rss_after: f64,
    /// The augmented fit's Jacobian has full rank (all its parameters are determined by the data;
    /// a candidate whose parameters trade off against the model's cannot be named).
    pub identifiable: bool,
    /// `p < threshold`, BIC decreased and the augmented model is identifiable.
    pub significant: bool,
}

/// The nested F-test and BIC comparison of a model with `p0` free parameters (RSS `rss0`) against
/// one with `q` more (RSS `rss1`) on `n` points, at threshold `alpha / m`:
/// `F = ((RSS₀ − RSS₁)/q) / (RSS₁/(n − p₀ − q))` against FisherSnedecor(q, n − p₀ − q), and
/// `BIC = n·ln(RSS/n) + k·ln n`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn nested_test(
    effect: &str,
    n: usize,
    p0: usize,
    q: usize,
    rss0: f64,
    rss1: f64,
    alpha: f64,
    m: usize,
) -> Decision {
    let df2 = n.saturating_sub(p0 + q).max(1);
    let nf = n as f64;
    let f = if rss1 > 0.0 {
        ((rss0 - rss1).max(0.0) / q as f64) / (rss1 / df2 as f64)
    } else {
        f64::INFINITY
    };
    let p = FisherSnedecor::new(q as f64, df2 as f64)
        .map(|d| if f.is_finite() { d.sf(f) } else { 0.0 })
        .unwrap_or(f64::NAN);
    let bic = |rss: f64, k: usize| nf * (rss.max(1e-300) / nf).ln() + k as f64 * nf.ln();
    let threshold = alpha / m.max(1) as f64;
    let (b0, b1) = (bic(rss0, p0), bic(rss1, p0 + q));
    Decision {
        effect: effect.to_string(),
        f_statistic: f,
        df1: q,
        df2,
        p_value: p,
        threshold,
        bic_before: b0,
        bic_after: b1,
        rss_after: rss1,
        identifiable: true,
        significant: p < threshold && b1 < b0,
    }
}
