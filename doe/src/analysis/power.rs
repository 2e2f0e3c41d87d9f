//! Noncentral F distribution and the power of F tests in two-level designs.

use statrs::distribution::{ContinuousCDF, FisherSnedecor};
use statrs::function::beta::beta_reg;
use statrs::function::gamma::ln_gamma;

/// Poisson weights w_j = e^{−μ} μ^j / j! for the terms of the mixture, j = 0, 1, … until the remaining mass
/// is below 1e-17 (returns the weights; their sum is 1 to that accuracy).
fn poisson_weights(mu: f64) -> Vec<f64> {
    if mu <= 0.0 {
        return vec![1.0];
    }
    let upper = (mu + 12.0 * mu.sqrt() + 40.0).ceil() as usize;
    let mut w = Vec::with_capacity(upper + 1);
    let mut total = 0.0;
    for j in 0..=upper {
        let lw = -mu + j as f64 * mu.ln() - ln_gamma(j as f64 + 1.0);
        let v = lw.exp();
        w.push(v);
        total += v;
        if j as f64 > mu && v < 1e-17 * total.max(1e-300) {
            break;
        }
    }
    w
}

/// Arguments statrs' incomplete beta accepts (it panics otherwise): d1, d2 > 0 finite, λ ≥ 0 finite, x not NaN.
fn valid(x: f64, d1: f64, d2: f64, lambda: f64) -> bool {
    !x.is_nan()
        && d1 > 0.0
        && d1.is_finite()
        && d2 > 0.0
        && d2.is_finite()
        && lambda >= 0.0
        && lambda.is_finite()
}

/// CDF of the noncentral F distribution F'(d1, d2, λ) at `x`.
///
/// Uses the Poisson mixture of central beta distributions (Johnson, Kotz & Balakrishnan, *Continuous
/// Univariate Distributions* vol. 2, 2nd ed., §30.3, eq. 30.4; Abramowitz & Stegun 26.6.20):
/// P(F' ≤ x) = Σ_j e^{−λ/2} (λ/2)^j / j! · I_y(d1/2 + j, d2/2), with y = d1·x/(d1·x + d2) and I the
/// regularised incomplete beta function (statrs' `beta_reg`). statrs has no noncentral F.
/// Returns NaN for invalid arguments (d1 or d2 ≤ 0, λ < 0, non-finite parameters).
///
/// ```
/// use millcomp_doe::noncentral_f_cdf;
/// // scipy 1.17.1: scipy.stats.ncf.cdf(3.0, 2, 10, 4.0) = 0.548967890878535
/// // (more points, to 1e-10, in tests/golden/noncentral_f.json)
/// assert!((noncentral_f_cdf(3.0, 2.0, 10.0, 4.0) - 0.548967890878535).abs() < 1e-10);
/// // λ = 0 is the central F: scipy.stats.f.cdf(4.0, 1, 4) = 0.883883476483184
/// assert!((noncentral_f_cdf(4.0, 1.0, 4.0, 0.0) - 0.883883476483184).abs() < 1e-10);
/// ```
pub fn noncentral_f_cdf(x: f64, d1: f64, d2: f64, lambda: f64) -> f64 {
    if !valid(x, d1, d2, lambda) {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return 1.0;
    }
    let y = d1 * x / (d1 * x + d2);
    poisson_weights(lambda / 2.0)
        .iter()
        .enumerate()
        .map(|(j, w)| w * beta_reg(d1 / 2.0 + j as f64, d2 / 2.0, y))
        .sum::<f64>()
        .clamp(0.0, 1.0)
}

/// Survival function 1 − CDF of the noncentral F, summed with the complementary betas
/// I_{1−y}(d2/2, d1/2 + j) so that small tail probabilities keep their relative accuracy.
/// Returns NaN for invalid arguments, as [`noncentral_f_cdf`].
///
/// ```
/// use millcomp_doe::noncentral_f_sf;
/// // scipy 1.17.1: scipy.stats.ncf.sf(3.0, 2, 10, 4.0) = 0.4510321091214649 (tests/golden/noncentral_f.json)
/// assert!((noncentral_f_sf(3.0, 2.0, 10.0, 4.0) - 0.4510321091214649).abs() < 1e-10);
/// assert!(noncentral_f_sf(3.0, 0.0, 10.0, 4.0).is_nan());
/// ```
pub fn noncentral_f_sf(x: f64, d1: f64, d2: f64, lambda: f64) -> f64 {
    if !valid(x, d1, d2, lambda) {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    let y1 = d2 / (d1 * x + d2);
    poisson_weights(lambda / 2.0)
        .iter()
        .enumerate()
        .map(|(j, w)| w * beta_reg(d2 / 2.0, d1 / 2.0 + j as f64, y1))
        .sum::<f64>()
        .clamp(0.0, 1.0)
}

/// Power of an F test with (d1, d2) degrees of freedom at level `alpha` against noncentrality `lambda`:
/// P(F'(d1, d2, λ) > F_{1−α}(d1, d2)). Returns (critical F, power), or `None` for invalid arguments.
///
/// ```
/// use millcomp_doe::f_test_power;
/// // One effect of a 2^3 with 4 residual df, λ = 8, α = 0.05 (scipy 1.17.1, tests/golden/noncentral_f.json):
/// // f.ppf(0.95, 1, 4) = 7.708647422176786, ncf.sf(7.708647422176786, 1, 4, 8) = 0.5716094577007155
/// let (f_crit, power) = f_test_power(1.0, 4.0, 8.0, 0.05).unwrap();
/// assert!((f_crit - 7.708647422176786).abs() < 1e-8 * 7.71);
/// assert!((power - 0.5716094577007155).abs() < 1e-10);
/// ```
pub fn f_test_power(d1: f64, d2: f64, lambda: f64, alpha: f64) -> Option<(f64, f64)> {
    let f = FisherSnedecor::new(d1, d2).ok()?;
    if !(alpha > 0.0 && alpha < 1.0 && valid(1.0, d1, d2, lambda)) {
        return None;
    }
    let crit = f.inverse_cdf(1.0 - alpha);
    Some((crit, noncentral_f_sf(crit, d1, d2, lambda)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use statrs::distribution::ContinuousCDF;

    #[test]
    fn zero_noncentrality_is_central_f() {
        let f = FisherSnedecor::new(3.0, 7.0).unwrap();
        for x in [0.1, 0.5, 1.0, 2.5, 8.0] {
            assert!((noncentral_f_cdf(x, 3.0, 7.0, 0.0) - f.cdf(x)).abs() < 1e-14);
            assert!((noncentral_f_sf(x, 3.0, 7.0, 0.0) - f.sf(x)).abs() < 1e-14);
        }
    }

    #[test]
    fn cdf_plus_sf_is_one() {
        for lam in [0.5, 5.0, 50.0, 400.0] {
            let c = noncentral_f_cdf(2.0, 2.0, 9.0, lam);
            let s = noncentral_f_sf(2.0, 2.0, 9.0, lam);
            assert!((c + s - 1.0).abs() < 1e-12, "λ = {lam}: {c} + {s}");
        }
    }

    /// The mixture stops at the first term past the mean whose weight is below 1e-17 of the mass so
    /// far: for μ = 4 that is j = 32 (e^{−4}·4³²/32! = 1.28e-18; computed in Python with
    /// math.lgamma), 33 weights, not the 69 of the hard bound ⌈μ + 12√μ + 40⌉. Kills
    /// `power.rs:21:21: replace > with == in poisson_weights` (found by the draw of seed 53), which
    /// never stops early (the sum is the same to 1e-17, the work twice).
    #[test]
    fn the_poisson_mixture_stops_at_its_documented_tail() {
        let w = poisson_weights(4.0);
        assert_eq!(w.len(), 33);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert_eq!(poisson_weights(0.0), vec![1.0]);
    }

    /// α must lie strictly between 0 and 1: 0 (a critical value of +∞) and 1.5 give none, 0.05 the
    /// documented example's power. Kills `power.rs:116:22: replace && with || in f_test_power` (found
    /// by the draw of seed 53), which takes α = 0 (power 0 at an infinite critical value) and 1.5.
    #[test]
    fn the_significance_level_must_lie_between_zero_and_one() {
        assert!(f_test_power(1.0, 4.0, 8.0, 0.0).is_none());
        assert!(f_test_power(1.0, 4.0, 8.0, 1.5).is_none());
        assert!(f_test_power(1.0, 4.0, 8.0, 1.0).is_none());
        let (_, power) = f_test_power(1.0, 4.0, 8.0, 0.05).unwrap();
        assert!((power - 0.5716094577007155).abs() < 1e-10);
    }
}
