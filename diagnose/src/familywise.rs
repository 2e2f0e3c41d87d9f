//! The round's family-wise threshold, simulated (a single-step min-p adjustment in the manner of
//! Westfall & Young, *Resampling-Based Multiple Testing*, 1993, §2.6): the α quantile of the
//! round's smallest p-value when the current model is right.
//!
//! Bonferroni's α/m over the m shapes tried is valid whatever the tests' dependence, but the
//! shapes of one family (a saturating wear and a power-law wear, one lag and two) are nearly the
//! same test, so it spends the level many times over: on the study's plan, in 210 development
//! sessions with nothing hidden, the first round's smallest p fell below Bonferroni's 0.01/22 =
//! 4.5e-4 in none; its 1 % quantile there is about 2e-3, and this simulation puts the threshold at
//! 1.0–1.4e-3 (`docs/studies/diagnose.md`, "Each round's threshold"). The simulation draws the whitened
//! residual of the current model under the null — `e ~ N(0, I)` in the GLS metric, data and prior
//! rows, projected off the current model's Jacobian — and repeats the round's linearised search on
//! it: every shape at every point of its grid of nonlinear parameters, the family's shape chosen
//! by the same GLS-BIC, its p from the drop against χ² with the shape's parameters as degrees of
//! freedom. The threshold is the largest `t` with at most a fraction α of draws whose smallest
//! family p is below `t`.
//!
//! Approximations, each stated: the variance model is taken as known (the real test's F with
//! Satterthwaite's dof has the same uniform null marginally); a shape whose coefficients must be
//! non-negative is searched without that constraint (a larger null drop: a lower, so
//! conservative, threshold); the nonlinear refinement after the search is not repeated.

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// What one grid point of a shape adds to the current model, in the whitened metric and
/// projected off the current model's Jacobian.
#[derive(Debug, Clone)]
pub(crate) enum NullBlock {
    /// Orthonormal columns of the shape's free coefficients: the null drop is `‖Qᵀe‖²`.
    Free(DMatrix<f64>),
    /// The column of a shape without a free coefficient (added as it is): the drop is
    /// `−2bᵀe − ‖b‖²`.
    Fixed(DMatrix<f64>),
}

impl NullBlock {
    fn columns(&self) -> &DMatrix<f64> {
        match self {
            NullBlock::Free(m) | NullBlock::Fixed(m) => m,
        }
    }
}

/// One shape of one family as the round searched it.
#[derive(Debug, Clone)]
pub(crate) struct NullShape {
    /// Index of the family (shapes of one family compete by GLS-BIC, as in the round).
    pub family: usize,
    /// Free parameters (the χ² degrees of freedom and the BIC penalty).
    pub params: usize,
    /// One block per grid point of the shape's nonlinear parameters.
    pub blocks: Vec<NullBlock>,
}

/// Draws per call are generated in chunks of this many columns (bounds the memory of `Qᵀe`).
const CHUNK: usize = 500;

/// The α quantile of the round's smallest family p under the null, from `draws` seeded draws of
/// a `rows`-long whitened residual (`ln_n`: the BIC penalty per parameter, as in the round).
/// `None` when no shape has a block (nothing to calibrate: the caller keeps Bonferroni's).
pub(crate) fn simulated_threshold(
    shapes: &[NullShape],
    rows: usize,
    ln_n: f64,
    alpha: f64,
    draws: usize,
    seed: u64,
) -> Option<f64> {
    let shapes: Vec<&NullShape> = shapes.iter().filter(|s| !s.blocks.is_empty()).collect();
    if shapes.is_empty() || draws == 0 || rows == 0 {
        return None;
    }
    // every block's columns side by side; per block: its first column, its width and, for a
    // fixed column, ‖b‖² (the drop's constant)
    let cols: usize = shapes
        .iter()
        .flat_map(|s| &s.blocks)
        .map(|b| b.columns().ncols())
        .sum();
    let mut all = DMatrix::zeros(rows, cols);
    let mut layout: Vec<Vec<(usize, usize, Option<f64>)>> = Vec::with_capacity(shapes.len());
    let mut c0 = 0usize;
    for s in &shapes {
        let mut v = Vec::with_capacity(s.blocks.len());
        for b in &s.blocks {
            // every block is the round's `stack` of whitened columns: data and prior rows
            let m = b.columns();
            all.columns_mut(c0, m.ncols()).copy_from(m);
            let fixed = matches!(b, NullBlock::Fixed(_)).then(|| m.norm_squared());
            v.push((c0, m.ncols(), fixed));
            c0 += m.ncols();
        }
        layout.push(v);
    }
    let at = all.transpose();
    let chi: Vec<Option<ChiSquared>> = shapes
        .iter()
        .map(|s| ChiSquared::new(s.params.max(1) as f64).ok())
        .collect();
    let n_fam = shapes.iter().map(|s| s.family).max().unwrap_or(0) + 1;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut smallest: Vec<f64> = Vec::with_capacity(draws);
    // per family: (linearised GLS-BIC, drop, shape) of its best shape in the current draw
    let mut best: Vec<Option<(f64, f64, usize)>> = vec![None; n_fam];
    let mut done = 0usize;
    while done < draws {
        let m = CHUNK.min(draws - done);
        let e = DMatrix::from_fn(rows, m, |_, _| StandardNormal.sample(&mut rng));
        let z = &at * &e;
        for d in 0..m {
            // per family: the shape with the lowest linearised GLS-BIC (−drop + params·ln n)
            best.fill(None);
            for (si, (s, st)) in shapes.iter().zip(&layout).enumerate() {
                let mut drop = f64::NEG_INFINITY;
                for &(c0, k, fixed) in st {
                    let v = match fixed {
                        Some(norm2) => -2.0 * z[(c0, d)] - norm2,
                        None => (c0..c0 + k).map(|c| z[(c, d)] * z[(c, d)]).sum(),
                    };
                    drop = drop.max(v);
                }
                let crit = -drop + s.params as f64 * ln_n;
                let slot = &mut best[s.family];
                if slot.is_none_or(|(c, _, _)| crit < c) {
                    *slot = Some((crit, drop, si));
                }
            }
            let p = best
                .iter()
                .flatten()
                .map(|&(_, drop, si)| {
                    chi[si]
                        .as_ref()
                        .map_or(1.0, |c| if drop > 0.0 { c.sf(drop) } else { 1.0 })
                })
                .fold(1.0f64, f64::min);
            smallest.push(p);
        }
        done += m;
    }
    smallest.sort_by(f64::total_cmp);
    // the largest t with #{p < t} ≤ α·draws
    let k = ((alpha * draws as f64).floor() as usize).min(draws - 1);
    Some(smallest[k])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(rows: usize, j: usize) -> DMatrix<f64> {
        DMatrix::from_fn(rows, 1, |i, _| if i == j { 1.0 } else { 0.0 })
    }

    fn one(family: usize, m: DMatrix<f64>) -> NullShape {
        NullShape {
            family,
            params: 1,
            blocks: vec![NullBlock::Free(m)],
        }
    }

    /// Reference: for m independent one-dof tests the exact family-wise threshold is Šidák's
    /// `1 − (1 − α)^{1/m}`; for m copies of the same test it is α. Monte Carlo error with 20 000
    /// draws at α = 0.05: the quantile's relative SE is ≈ √(α(1−α)/N)/α ≈ 3 %.
    #[test]
    fn independent_tests_give_sidak_and_copies_give_alpha() {
        let rows = 40;
        let alpha = 0.05;
        let m = 8;
        let independent: Vec<NullShape> = (0..m).map(|j| one(j, unit(rows, j))).collect();
        let t = simulated_threshold(&independent, rows, 0.0, alpha, 20_000, 7).unwrap();
        let sidak = 1.0 - (1.0 - alpha).powf(1.0 / m as f64);
        assert!((t / sidak - 1.0).abs() < 0.12, "{t} vs Šidák {sidak}");
        let copies: Vec<NullShape> = (0..m).map(|j| one(j, unit(rows, 0))).collect();
        let t = simulated_threshold(&copies, rows, 0.0, alpha, 20_000, 7).unwrap();
        assert!((t / alpha - 1.0).abs() < 0.12, "{t} vs α {alpha}");
    }

    /// Shapes of one family count once: the family's shape is the best by BIC, so eight copies of
    /// one column inside one family are one test.
    #[test]
    fn shapes_of_one_family_are_one_test() {
        let rows = 40;
        let fam: Vec<NullShape> = (0..8).map(|_| one(0, unit(rows, 3))).collect();
        let t = simulated_threshold(&fam, rows, 0.0, 0.05, 20_000, 3).unwrap();
        assert!((t / 0.05 - 1.0).abs() < 0.12, "{t}");
    }

    /// A shape searched over a grid is a larger null drop than one column (Davies' problem):
    /// the threshold falls below α.
    #[test]
    fn a_grid_of_directions_lowers_the_threshold() {
        let rows = 40;
        let grid: Vec<NullBlock> = (0..10).map(|j| NullBlock::Free(unit(rows, j))).collect();
        let s = NullShape {
            family: 0,
            params: 1,
            blocks: grid,
        };
        let t = simulated_threshold(&[s], rows, 0.0, 0.05, 20_000, 5).unwrap();
        let sidak = 1.0 - 0.95f64.powf(0.1);
        assert!((t / sidak - 1.0).abs() < 0.12, "{t} vs {sidak}");
    }
}
