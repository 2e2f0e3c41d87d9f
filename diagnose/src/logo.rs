//! Leave-one-groove-out prediction (issue 15: an effect is added only if it also predicts grooves
//! it was not fitted to).
//!
//! For each groove g the model is refitted without g's points — one Gauss–Newton step from the
//! full-data estimate, `Δ = −(XᵀX − X_gᵀX_g)⁻¹(Xᵀr − X_gᵀr_g)` on the whitened rows (the prior rows
//! stay) — and g is predicted. Its score is the whitened squared prediction error `‖r_g + X_gΔ‖²`,
//! i.e. `e_gᵀV_g⁻¹e_g` with the random-groove-offset covariance: the held-out groove's own offset
//! is unknown to every model alike. The sum over grooves is compared between the model with and
//! without the candidate, in the same whitening.

use nalgebra::{DMatrix, DVector};

use crate::scatter::Whitening;

/// Sum over grooves of the whitened leave-one-groove-out prediction error of the model with
/// whitened Jacobian `x` and residual `r` (n data rows first) at its estimate.
///
/// A parameter that only the held-out groove informs (the time constant of a drift that starts
/// inside that groove) is not moved: the step is the minimum-norm one, directions of the
/// column-scaled `XᵀX − X_gᵀX_g` with eigenvalues below 1e-9 of the largest are left out.
pub(crate) fn score(w: &Whitening, x: &DMatrix<f64>, r: &DVector<f64>) -> f64 {
    let p = x.ncols();
    // scale the columns to unit norm so the threshold is unit-free
    let d = DVector::from_iterator(
        p,
        (0..p).map(|j| {
            let c = x.column(j).norm();
            if c > 0.0 { 1.0 / c } else { 0.0 }
        }),
    );
    let xs = DMatrix::from_fn(x.nrows(), p, |i, j| x[(i, j)] * d[j]);
    let a = xs.transpose() * &xs;
    let b = xs.transpose() * r;
    let mut total = 0.0;
    for &(s, e) in &w.groups {
        let xg = xs.rows(s, e - s);
        let rg = r.rows(s, e - s);
        let ag = &a - xg.transpose() * xg;
        let bg = &b - xg.transpose() * rg;
        let delta = min_norm_step(&ag, &bg);
        let pred = rg + xg * delta;
        total += pred.norm_squared();
    }
    total
}

/// `−A⁺b` for a symmetric positive semi-definite A: its eigen-decomposition without the
/// directions whose eigenvalue is below 1e-9 of the largest (those are not moved).
fn min_norm_step(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let p = a.ncols();
    if p == 0 {
        return DVector::zeros(0);
    }
    let eig = a.clone().symmetric_eigen();
    let lmax = eig.eigenvalues.iter().fold(0.0f64, |m, v| m.max(*v));
    let mut step = DVector::zeros(p);
    for k in 0..p {
        let l = eig.eigenvalues[k];
        if l > 1e-9 * lmax && l > 0.0 {
            let v = eig.eigenvectors.column(k);
            step -= v * (v.dot(b) / l);
        }
    }
    step
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_step_is_exact_for_a_linear_model() {
        // a line fitted to 3 grooves of 4 points (σ_g = 0): leaving a groove out by the update must
        // equal refitting without it
        let groups = [(0usize, 4usize), (4, 8), (8, 12)];
        let w = Whitening::new(&groups, 1.0, 0.0);
        let xs: Vec<f64> = (0..12).map(|i| i as f64).collect();
        let y: Vec<f64> = xs.iter().map(|x| 1.0 + 0.5 * x + (x * 1.7).sin()).collect();
        let x = DMatrix::from_fn(12, 2, |i, j| if j == 0 { 1.0 } else { xs[i] });
        let yv = DVector::from_vec(y.clone());
        let theta = (x.transpose() * &x)
            .cholesky()
            .unwrap()
            .solve(&(x.transpose() * &yv));
        let r = &x * &theta - &yv;
        let s = score(&w, &x, &r);
        let mut direct = 0.0;
        for &(a, b) in &groups {
            let keep: Vec<usize> = (0..12).filter(|i| *i < a || *i >= b).collect();
            let xk = DMatrix::from_fn(keep.len(), 2, |i, j| x[(keep[i], j)]);
            let yk = DVector::from_fn(keep.len(), |i, _| y[keep[i]]);
            let th = (xk.transpose() * &xk)
                .cholesky()
                .unwrap()
                .solve(&(xk.transpose() * yk));
            for i in a..b {
                let e = x[(i, 0)] * th[0] + x[(i, 1)] * th[1] - y[i];
                direct += e * e;
            }
        }
        assert!((s - direct).abs() < 1e-9 * direct, "{s} vs {direct}");
    }
}
