//! The ideal observer of the study: what the session's data could tell at all.
//!
//! `diagnose` must find a hidden effect among seven families of shapes, with the scatter
//! estimated from the data. An observer that is *given* the hidden effect's exact offsets at
//! every point (its shape, with the amplitude free), the true measurement noise and groove
//! scatter, and the nominal model's priors, can do no better than a likelihood-ratio test of
//! "those offsets are there" against "the nominal model, recalibrated within its priors, explains
//! the data" (Neyman–Pearson: for a simple alternative that test is the most powerful at its
//! level). The rate at which it detects a hidden effect at the level `diagnose` tests at (α = 0.01,
//! before any correction for the shapes it must try) is a ceiling on every "named" rate of the
//! study: where the ideal observer cannot tell the effect from the recalibrated nominal model, no
//! method can name it except by chance. It uses the truth, so it lives here, in the study — never
//! in `diagnose`.
//!
//! The fit: Gauss–Newton on the nuisance parameters (the exact closed-form deflection of
//! `millcomp_diagnose::nuisance`, not linearised — a 10 % stiffness error moves the deflection's
//! second-order term by ≈ 0.15 µm) and the effects' amplitudes, whitened by the true random-groove
//! covariance, with the priors as extra rows. χ² of the model without an effect minus χ² with it
//! is the likelihood-ratio statistic (σ known), χ²₁ under the null.

use millcomp_diagnose::SessionModel;
use millcomp_diagnose::nuisance::{NuisanceModel, prior_sd};
use millcomp_diagnose::scatter::Whitening;
use millcomp_synthetic::variants::{DEPTH_NOISE_UM, GROOVE_SCATTER_UM, Variant};
use nalgebra::{DMatrix, DVector};

/// χ²₁'s upper 1 % point: the ideal observer's critical value at `diagnose`'s α = 0.01.
pub const CRITICAL_CHI2_1: f64 = 6.634_896_601_021_214;

/// The ideal observer for one nominal session.
pub struct IdealObserver {
    nuisance: NuisanceModel,
    prior_sd: [f64; 5],
    whitening: Whitening,
    base_um: Vec<f64>,
}

impl IdealObserver {
    /// For the nominal model `sm` (its `[uncertainty]` priors) with the study's true noise and
    /// groove scatter.
    pub fn new(sm: &SessionModel) -> Self {
        let groups: Vec<(usize, usize)> = sm.facts.grooves.iter().map(|g| (g.1, g.2)).collect();
        IdealObserver {
            nuisance: NuisanceModel::new(&sm.deflection),
            prior_sd: prior_sd(&sm.session.uncertainty),
            whitening: Whitening::new(&groups, DEPTH_NOISE_UM, GROOVE_SCATTER_UM),
            base_um: sm.base_um.clone(),
        }
    }

    /// The likelihood-ratio statistic of each of `patterns` (offsets in µm at every point),
    /// dropped from the model that holds the recalibrated nominal model and all of `patterns`, on
    /// the measured points of `v`. With `v`'s own hidden offsets as the patterns this is the
    /// evidence for each hidden effect; with a pattern `v` does not hide, a draw from χ²₁.
    pub fn statistics(&self, v: &Variant, patterns: &[Vec<f64>]) -> Vec<f64> {
        let y: Vec<f64> = v
            .points
            .iter()
            .zip(&self.base_um)
            .map(|(p, b)| p.depth_meas_um - b)
            .collect();
        let all: Vec<&[f64]> = patterns.iter().map(Vec::as_slice).collect();
        let full = self.chi2(&y, &all);
        (0..all.len())
            .map(|j| {
                let without: Vec<&[f64]> = all
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| *k != j)
                    .map(|(_, c)| *c)
                    .collect();
                (self.chi2(&y, &without) - full).max(0.0)
            })
            .collect()
    }

    /// Minimum χ² of `y` (depth − base) over the nuisance parameters within their priors and a
    /// free amplitude per pattern.
    fn chi2(&self, y: &[f64], patterns: &[&[f64]]) -> f64 {
        let n = y.len();
        // nuisance parameters held at nominal (prior SD 0) are not fitted
        let free: Vec<usize> = (0..5).filter(|&k| self.prior_sd[k] != 0.0).collect();
        let priors: Vec<(usize, f64)> = free
            .iter()
            .enumerate()
            .filter(|(_, k)| self.prior_sd[**k].is_finite())
            .map(|(col, k)| (col, self.prior_sd[*k]))
            .collect();
        let p = free.len() + patterns.len();
        let rows = n + priors.len();
        let mut nu = [0.0; 5];
        let mut beta = vec![0.0; patterns.len()];
        let objective = |nu: &[f64; 5], beta: &[f64]| -> (DVector<f64>, f64) {
            let mut r: Vec<f64> = (0..n)
                .map(|i| {
                    y[i] - self.nuisance.shift_um(i, nu)
                        - patterns
                            .iter()
                            .zip(beta)
                            .map(|(c, b)| b * c[i])
                            .sum::<f64>()
                })
                .collect();
            self.whitening.apply(&mut r);
            r.extend(priors.iter().map(|(col, sd)| -nu[free[*col]] / sd));
            let v = DVector::from_vec(r);
            let c = v.norm_squared();
            (v, c)
        };
        let (mut r, mut c) = objective(&nu, &beta);
        for _ in 0..30 {
            let mut j = DMatrix::zeros(rows, p);
            let mut col = vec![0.0; n];
            let grad: Vec<[f64; 5]> = (0..n).map(|i| self.nuisance.gradient(i, &nu)).collect();
            for (fc, &k) in free.iter().enumerate() {
                for (x, g) in col.iter_mut().zip(&grad) {
                    *x = g[k];
                }
                self.whitening.apply(&mut col);
                j.view_mut((0, fc), (n, 1)).copy_from_slice(&col);
            }
            for (pc, pat) in patterns.iter().enumerate() {
                col.copy_from_slice(pat);
                self.whitening.apply(&mut col);
                j.view_mut((0, free.len() + pc), (n, 1))
                    .copy_from_slice(&col);
            }
            for (row, (fc, sd)) in priors.iter().enumerate() {
                j[(n + row, *fc)] = 1.0 / sd;
            }
            // r = data − model, so the step solves J·δ ≈ r
            let Ok(step) = j.svd(true, true).solve(&r, 1e-12) else {
                break;
            };
            let (mut nu2, mut beta2) = (nu, beta.clone());
            for (fc, &k) in free.iter().enumerate() {
                nu2[k] += step[fc];
            }
            for (pc, b) in beta2.iter_mut().enumerate() {
                *b += step[free.len() + pc];
            }
            let (r2, c2) = objective(&nu2, &beta2);
            if !c2.is_finite() || c2 > c {
                break;
            }
            let gain = c - c2;
            (nu, beta, r, c) = (nu2, beta2, r2, c2);
            if gain <= 1e-10 * c.max(1.0) {
                break;
            }
        }
        c
    }
}
