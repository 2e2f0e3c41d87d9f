//! Groove-to-groove scatter as a random per-groove offset (a mixed model fitted by GLS), and the
//! split of the information into strata that the tests use.
//!
//! # Variance model
//! `depth = model + u_g + e`, `u_g ~ N(0, σ_g²)` one per groove, `e ~ N(0, σ_e²)` per point. Its
//! covariance is block-diagonal, `V_g = σ_e²·I + σ_g²·11ᵀ`, and `V_g^{-1/2}` is a quasi-demeaning:
//! `w_i = (e_i − c_g·ē_g)/σ_e` with `c_g = 1 − σ_e/√(σ_e² + n_g σ_g²)` ([`Whitening`]). Whitened,
//! the data split into two orthogonal strata — within grooves (deviations from the groove mean,
//! variance σ_e²) and between grooves (the groove means, variance σ_e² + n_g σ_g²) — as in a
//! split-plot design: an effect that is constant within each groove (a thermal drift) is seen only
//! against the between-groove scatter, with the few degrees of freedom the grooves have.
//!
//! # Estimating σ_e and σ_g
//! From the residual of the current model: `σ̂_e² = SS_within / (n − G − tr_W(H))`, and the
//! between mean square `SS_between / (G − tr_B(H))` estimates `σ_e² + n̄σ_g²` (method of moments;
//! `tr_W`, `tr_B` are the hat matrix's traces in each stratum). Because G is small (14 grooves in the
//! committed plan), σ̂_g² is pooled with the session's stated `groove_scatter_um` worth
//! [`PRIOR_SCATTER_DOF`] degrees of freedom (a scaled inverse-χ² prior); with one groove the stated
//! value is used alone.

/// Degrees of freedom of the stated groove scatter in the pooled estimate (a weak prior: two
/// grooves' worth).
pub const PRIOR_SCATTER_DOF: f64 = 2.0;

/// The GLS whitening of the random-groove-offset model.
#[derive(Debug, Clone, PartialEq)]
pub struct Whitening {
    /// Measurement noise σ_e (µm).
    pub sigma_e_um: f64,
    /// Groove scatter σ_g (µm).
    pub sigma_g_um: f64,
    /// `(first, end)` point index of each groove.
    pub groups: Vec<(usize, usize)>,
    c: Vec<f64>,
}

impl Whitening {
    /// The whitening for σ_e, σ_g over the grooves `groups`.
    pub fn new(groups: &[(usize, usize)], sigma_e_um: f64, sigma_g_um: f64) -> Self {
        let se = sigma_e_um.max(1e-9);
        let c = groups
            .iter()
            .map(|(a, b)| {
                let n = (b - a) as f64;
                1.0 - se / (se * se + n * sigma_g_um * sigma_g_um).sqrt()
            })
            .collect();
        Whitening {
            sigma_e_um: se,
            sigma_g_um,
            groups: groups.to_vec(),
            c,
        }
    }

    /// Whitens a data vector in place.
    pub fn apply(&self, v: &mut [f64]) {
        for ((a, b), c) in self.groups.iter().zip(&self.c) {
            let m = v[*a..*b].iter().sum::<f64>() / (b - a).max(1) as f64;
            for x in &mut v[*a..*b] {
                *x = (*x - c * m) / self.sigma_e_um;
            }
        }
    }

    /// The raw values (µm) of groove `k`'s whitened values `v` ([`Self::apply`] undone: the
    /// whitening subtracts `c·mean` and divides by σ_e, with `c < 1`, so the groove mean is
    /// `σ_e·mean(v)/(1 − c)`).
    pub fn unapply_group(&self, k: usize, v: &[f64]) -> Vec<f64> {
        let c = self.c[k];
        let mw = v.iter().sum::<f64>() / v.len().max(1) as f64;
        let m = self.sigma_e_um * mw / (1.0 - c).max(1e-300);
        v.iter().map(|x| self.sigma_e_um * x + c * m).collect()
    }

    /// Squared norms of the within-groove and between-groove parts of a (whitened) data vector.
    pub fn strata(&self, v: &[f64]) -> (f64, f64) {
        let (mut w, mut bt) = (0.0, 0.0);
        for (a, b) in &self.groups {
            let n = (b - a) as f64;
            let m = v[*a..*b].iter().sum::<f64>() / n.max(1.0);
            bt += n * m * m;
            w += v[*a..*b].iter().map(|x| (x - m) * (x - m)).sum::<f64>();
        }
        (w, bt)
    }

    /// Number of grooves.
    pub fn n_groups(&self) -> usize {
        self.groups.len()
    }

    /// Number of data points.
    pub fn n_points(&self) -> usize {
        self.groups.last().map_or(0, |g| g.1)
    }
}

/// Variance components estimated from a raw residual (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Components {
    /// σ̂_e (µm).
    pub sigma_e_um: f64,
    /// σ̂_g (µm), pooled with the stated value.
    pub sigma_g_um: f64,
    /// Residual degrees of freedom within grooves.
    pub df_within: f64,
    /// Residual degrees of freedom between grooves (without the prior's).
    pub df_between: f64,
}

/// Estimates σ_e and σ_g from the raw residual `e` of a model whose hat matrix has traces
/// `tr_within`, `tr_between` in the two strata; `stated_sigma_g_um` is the session's stated scatter.
pub fn estimate(
    groups: &[(usize, usize)],
    e: &[f64],
    tr_within: f64,
    tr_between: f64,
    stated_sigma_g_um: f64,
) -> Components {
    let n = e.len() as f64;
    let g = groups.len() as f64;
    let (mut ssw, mut ssb) = (0.0, 0.0);
    for (a, b) in groups {
        let k = (b - a) as f64;
        let m = e[*a..*b].iter().sum::<f64>() / k.max(1.0);
        ssb += k * m * m;
        ssw += e[*a..*b].iter().map(|x| (x - m) * (x - m)).sum::<f64>();
    }
    let df_w = (n - g - tr_within).max(1.0);
    let se2 = (ssw / df_w).max(1e-12);
    let df_b = (g - tr_between).max(0.0);
    let nbar = n / g.max(1.0);
    let sg2_data = if df_b > 0.0 {
        ((ssb / df_b - se2) / nbar).max(0.0)
    } else {
        0.0
    };
    let s0 = stated_sigma_g_um * stated_sigma_g_um;
    let sg2 = (df_b * sg2_data + PRIOR_SCATTER_DOF * s0) / (df_b + PRIOR_SCATTER_DOF);
    Components {
        sigma_e_um: se2.sqrt(),
        sigma_g_um: sg2.sqrt(),
        df_within: df_w,
        df_between: df_b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unapply_undoes_the_whitening() {
        // two grooves of 3 and 4 points, σ_e = 0.1, σ_g = 0.5: whitening then unwhitening each
        // groove returns the raw values (reference: the identity, to round-off)
        let groups = [(0usize, 3usize), (3, 7)];
        let w = Whitening::new(&groups, 0.1, 0.5);
        let raw = [1.0, -2.0, 0.5, 3.0, 3.5, 2.0, -1.0];
        let mut v = raw.to_vec();
        w.apply(&mut v);
        for (k, &(a, b)) in groups.iter().enumerate() {
            let back = w.unapply_group(k, &v[a..b]);
            for (x, y) in back.iter().zip(&raw[a..b]) {
                assert!((x - y).abs() < 1e-12, "{x} vs {y}");
            }
        }
    }

    #[test]
    fn whitening_makes_the_groove_model_white() {
        // V_g = σe² I + σg² 11ᵀ; W V Wᵀ must be the identity: check on the two basis directions
        // (a groove mean and a within-groove contrast)
        let groups = [(0usize, 4usize), (4, 10)];
        let (se, sg) = (0.1, 0.5);
        let w = Whitening::new(&groups, se, sg);
        for (a, b) in groups {
            let n = (b - a) as f64;
            // the mean direction: variance σe² + nσg² along 1/√n
            let mut v = vec![0.0; 10];
            for x in &mut v[a..b] {
                *x = (se * se + n * sg * sg).sqrt() / n.sqrt();
            }
            w.apply(&mut v);
            let norm2: f64 = v.iter().map(|x| x * x).sum();
            assert!((norm2 - 1.0).abs() < 1e-12, "{norm2}");
            // a contrast: variance σe²
            let mut c = vec![0.0; 10];
            c[a] = se / 2f64.sqrt();
            c[a + 1] = -se / 2f64.sqrt();
            w.apply(&mut c);
            let norm2: f64 = c.iter().map(|x| x * x).sum();
            assert!((norm2 - 1.0).abs() < 1e-12, "{norm2}");
        }
    }

    #[test]
    fn moments_recover_the_components() {
        // deterministic residual: within ±0.1 around groove means of ±0.5 (14 grooves × 21)
        let groups: Vec<(usize, usize)> = (0..14).map(|g| (g * 21, g * 21 + 21)).collect();
        let e: Vec<f64> = (0..294)
            .map(|i| {
                let g = i / 21;
                let m = if g % 2 == 0 { 0.5 } else { -0.5 };
                m + if i % 2 == 0 { 0.1 } else { -0.1 }
            })
            .collect();
        let c = estimate(&groups, &e, 0.0, 0.0, 0.5);
        // SS_within = 294·0.01 (minus the odd-groove means' shift), df 280
        assert!((c.sigma_e_um - 0.1).abs() < 0.005, "{c:?}");
        assert!((c.sigma_g_um - 0.5).abs() < 0.02, "{c:?}");
    }
}
