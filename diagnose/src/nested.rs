//! The nested F-test and BIC comparison that decide whether a candidate effect is added — one
//! rule for the depth channel (forward selection) and the force channel.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor, StudentsT};

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

/// The GLS test of a candidate against the current model with the information split by strata
/// (`crate::scatter`): `F = (ΔRSS/q) / s_c²`, where ΔRSS is the drop of the whitened RSS (data and
/// prior rows), `s_c² = ω_W s_W² + ω_B s_B² + ω_P` weighs the within-groove, between-groove and
/// prior strata's residual variances (each ≈ 1 when the variance model holds) by the shares ω of
/// the candidate's information in each, and the denominator degrees of freedom are
/// Welch–Satterthwaite's for that combination (the prior stratum has a known variance). For an
/// effect constant within grooves this is the split-plot whole-plot F-test against the grooves'
/// scatter with `G − p_B` degrees of freedom; for one that varies only within grooves, the test
/// against the profilometer noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StrataTest {
    /// F statistic.
    pub f_statistic: f64,
    /// Numerator dof (the candidate's free parameters).
    pub df1: usize,
    /// Satterthwaite's denominator dof.
    pub df2: f64,
    /// p-value.
    pub p_value: f64,
    /// ln p (finite where p underflows; for ranking).
    pub ln_p: f64,
    /// Shares of the candidate's information: within grooves, between grooves, prior.
    pub shares: [f64; 3],
}

/// Residual variances of the alternative per stratum and their dof, `[within, between]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StrataVariance {
    pub s2: [f64; 2],
    pub df: [f64; 2],
}

impl StrataVariance {
    /// `ω`-weighted variance and its Satterthwaite dof.
    pub fn combine(&self, shares: [f64; 3]) -> (f64, f64) {
        let a = shares[0] * self.s2[0];
        let b = shares[1] * self.s2[1];
        let s2 = a + b + shares[2];
        let den = a * a / self.df[0].max(1e-9) + b * b / self.df[1].max(1e-9);
        let df = if den > 0.0 { s2 * s2 / den } else { 1e9 };
        (s2.max(1e-300), df.clamp(1.0, 1e9))
    }
}

pub(crate) fn strata_test(drop: f64, q: usize, shares: [f64; 3], v: &StrataVariance) -> StrataTest {
    let (s2, df2) = v.combine(shares);
    let q = q.max(1);
    let f = (drop.max(0.0) / q as f64) / s2;
    let ln_p = ln_sf_f(f, q as f64, df2);
    StrataTest {
        f_statistic: f,
        df1: q,
        df2,
        p_value: ln_p.exp(),
        ln_p,
        shares,
    }
}

/// The F statistic at which the upper tail of F(d1, d2) is `alpha` (bisection in ln f on
/// [`ln_sf_f`], which is monotone; statrs' inverse CDF does not return for very large dof).
pub(crate) fn f_critical(d1: f64, d2: f64, alpha: f64) -> f64 {
    let target = alpha.ln();
    let (mut lo, mut hi) = (-20.0f64, 20.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if ln_sf_f(mid.exp(), d1, d2) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// The 97.5 % point of Student's t with `df` degrees of freedom; the normal's 1.959964 beyond
/// 10⁴ dof (statrs' inverse CDF does not return for df ~ 1e9, and the two differ by < 2e-4 there).
pub(crate) fn t975(df: f64) -> f64 {
    const Z975: f64 = 1.959_963_984_540_054;
    if !(df.is_finite() && df <= 1e4) {
        return Z975;
    }
    StudentsT::new(0.0, 1.0, df.max(0.5))
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(Z975)
}

/// ln of the upper tail of F(d1, d2) at `f`: statrs where it does not underflow, else the series
/// `I_x(a, b) = xᵃ(1 − x)ᵇ/(a·B(a, b))·Σₖ (a+b)ₖ/(a+1)ₖ xᵏ` (Abramowitz & Stegun 26.5.4 with
/// 15.1.1), `x = d2/(d2 + d1 f)`, `a = d2/2`, `b = d1/2`, in logs.
pub fn ln_sf_f(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 0.0;
    }
    if f.is_infinite() {
        return f64::NEG_INFINITY;
    }
    if let Ok(d) = FisherSnedecor::new(d1, d2) {
        let p = d.sf(f);
        if p > 1e-250 {
            return p.ln();
        }
    }
    let x = d2 / (d2 + d1 * f);
    let (a, b) = (d2 / 2.0, d1 / 2.0);
    let mut term = 1.0;
    let mut sum = 1.0;
    for k in 0..10_000 {
        let kf = k as f64;
        term *= x * (a + b + kf) / (a + 1.0 + kf);
        sum += term;
        if term < 1e-16 * sum {
            break;
        }
    }
    a * x.ln() + b * (1.0 - x).ln() - a.ln() - statrs::function::beta::ln_beta(a, b) + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f_critical_inverts_the_upper_tail() {
        // F(1, 10) at its 1 % point: 10.044 (tables, e.g. NIST/SEMATECH e-Handbook §1.3.6.7.3)
        assert!((f_critical(1.0, 10.0, 0.01) - 10.044).abs() < 1e-3);
        for (d1, d2, a) in [(2.0, 19.3, 5.56e-4), (3.0, 1e6, 1e-3), (1.0, 4.0, 0.05)] {
            let f = f_critical(d1, d2, a);
            assert!((ln_sf_f(f, d1, d2) - a.ln()).abs() < 1e-9, "{d1} {d2} {a}");
        }
    }

    #[test]
    fn ln_sf_matches_statrs_and_continues_below_underflow() {
        for (f, d1, d2) in [(3.0, 2.0, 10.0), (40.0, 1.0, 200.0), (120.0, 3.0, 9.5)] {
            let p = FisherSnedecor::new(d1, d2).unwrap().sf(f);
            assert!((ln_sf_f(f, d1, d2) - p.ln()).abs() < 1e-9 * p.ln().abs().max(1.0));
        }
        // F(1, 280) at 1e5: far beyond f64; ln p must be finite, large negative and keep growing
        let a = ln_sf_f(1e5, 1.0, 280.0);
        let b = ln_sf_f(2e5, 1.0, 280.0);
        assert!(a.is_finite() && a < -600.0 && b < a, "{a} {b}");
    }

    #[test]
    fn satterthwaite_reduces_to_one_stratum() {
        let v = StrataVariance {
            s2: [1.0, 1.0],
            df: [280.0, 9.0],
        };
        let (_, df) = v.combine([0.0, 1.0, 0.0]);
        assert!((df - 9.0).abs() < 1e-9);
        let (_, df) = v.combine([1.0, 0.0, 0.0]);
        assert!((df - 280.0).abs() < 1e-9);
        // all information from the prior: known variance
        let (s2, df) = v.combine([0.0, 0.0, 1.0]);
        assert!((s2 - 1.0).abs() < 1e-12 && df >= 1e8);
    }
}
