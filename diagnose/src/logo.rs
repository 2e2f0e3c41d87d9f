//! Leave-one-groove-out prediction (issue 15: an effect is added only if it also predicts grooves
//! it was not fitted to).
//!
//! For each groove g the model is refitted without g's points — one Gauss–Newton step from the
//! full-data estimate, `Δ = −(XᵀX − X_gᵀX_g)⁻¹(Xᵀr − X_gᵀr_g)` on the whitened rows (the prior rows
//! stay) — and g is predicted. Its score is the whitened squared prediction error `‖r_g + X_gΔ‖²`,
//! i.e. `e_gᵀV_g⁻¹e_g` with the random-groove-offset covariance: the held-out groove's own offset
//! is unknown to every model alike. The sum over grooves is compared between the model with and
//! without the candidate, in the same whitening.
//!
//! The step does not move along a direction that the held-out groove informs almost alone (the time
//! constant of a drift that starts inside it, a spline coefficient whose interval only it covers):
//! in the metric of the full data's information, directions that keep less than
//! [`KEPT_INFORMATION`] of their information without the groove are left out — a refit along them
//! would extrapolate from almost nothing, by a step of arbitrary size.

use nalgebra::{DMatrix, DVector};

use crate::scatter::Whitening;

/// Sum over grooves of the whitened leave-one-groove-out prediction error of the model with
/// whitened Jacobian `x` and residual `r` (n data rows first) at its estimate.
///
/// A direction of the parameters that the held-out groove informs almost alone (the time constant
/// of a drift that starts inside that groove, a spline coefficient whose interval only that groove
/// covers) is not moved: in the metric of the full data's information `XᵀX`, the directions that
/// keep less than [`KEPT_INFORMATION`] of their information without the groove are left out (a
/// one-step refit along them would be extrapolation from almost nothing — a step of arbitrary size).
pub(crate) fn score(w: &Whitening, x: &DMatrix<f64>, r: &DVector<f64>) -> f64 {
    errors(w, x, r).iter().map(|e| e.norm_squared()).sum()
}

/// The whitened leave-one-groove-out prediction error of every groove (in `w.groups` order), as
/// [`score`] sums them.
pub(crate) fn errors(w: &Whitening, x: &DMatrix<f64>, r: &DVector<f64>) -> Vec<DVector<f64>> {
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
    let t = information_basis(&a);
    w.groups
        .iter()
        .map(|&(s, e)| {
            let xg = xs.rows(s, e - s);
            let rg = r.rows(s, e - s);
            let ag = &a - xg.transpose() * xg;
            let bg = &b - xg.transpose() * rg;
            let delta = kept_step(&t, &ag, &bg);
            rg + xg * delta
        })
        .collect()
}

/// The raw (µm) RMS of the leave-one-groove-out prediction errors ([`errors`], each held-out
/// groove's error unwhitened by [`Whitening::unapply_group`]): the held-out gap in the units of
/// the measurement.
pub(crate) fn rms_um(w: &Whitening, x: &DMatrix<f64>, r: &DVector<f64>) -> f64 {
    let mut ss = 0.0;
    let mut n = 0usize;
    for (k, e) in errors(w, x, r).into_iter().enumerate() {
        let raw = w.unapply_group(k, e.as_slice());
        ss += raw.iter().map(|v| v * v).sum::<f64>();
        n += raw.len();
    }
    (ss / n.max(1) as f64).sqrt()
}

/// The share of a direction's information that must remain without the held-out groove for the
/// leave-one-groove-out refit to move along it (module documentation).
pub const KEPT_INFORMATION: f64 = 0.1;

/// `T = U S^{-1/2}` over the informed directions of the full data's information `A = U S Uᵀ`
/// (those with `s` above 1e-12 of the largest): `TᵀAT = I`, the metric in which [`kept_step`]
/// measures the share of information a direction keeps. The same for every held-out groove.
fn information_basis(a: &DMatrix<f64>) -> DMatrix<f64> {
    let p = a.ncols();
    if p == 0 {
        return DMatrix::zeros(0, 0);
    }
    let full = a.clone().symmetric_eigen();
    let smax = full.eigenvalues.iter().fold(0.0f64, |m, v| m.max(*v));
    let informed: Vec<usize> = (0..p)
        .filter(|&k| full.eigenvalues[k] > 1e-12 * smax && full.eigenvalues[k] > 0.0)
        .collect();
    DMatrix::from_fn(p, informed.len(), |i, j| {
        let k = informed[j];
        full.eigenvectors[(i, k)] / full.eigenvalues[k].sqrt()
    })
}

/// `−A_g⁺b_g` along the directions that keep at least [`KEPT_INFORMATION`] of their information
/// without the held-out groove: with `T` from [`information_basis`] (directions not informed at all
/// are not moved), `M = TᵀA_gT = V Λ Vᵀ`, λ the share kept, and the step
/// `T Σ_{λ ≥ kept} v (vᵀTᵀb_g)/λ`, negated.
fn kept_step(t: &DMatrix<f64>, ag: &DMatrix<f64>, bg: &DVector<f64>) -> DVector<f64> {
    if t.ncols() == 0 {
        return DVector::zeros(t.nrows());
    }
    let m = t.transpose() * ag * t;
    let kept = ((&m + m.transpose()) * 0.5).symmetric_eigen();
    let rhs = t.transpose() * bg;
    let mut z = DVector::zeros(t.ncols());
    for k in 0..t.ncols() {
        let l = kept.eigenvalues[k];
        if l >= KEPT_INFORMATION {
            let v = kept.eigenvectors.column(k);
            z -= v * (v.dot(&rhs) / l);
        }
    }
    t * z
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

    #[test]
    fn a_direction_only_the_held_out_groove_informs_is_not_moved() {
        // a constant and a column that is large on the middle groove only (the onset of a drift
        // inside that groove): leaving that groove out must not extrapolate along the column
        let groups = [(0usize, 4usize), (4, 8), (8, 12)];
        let w = Whitening::new(&groups, 1.0, 0.0);
        let col = |i: usize| {
            if (4..8).contains(&i) {
                1.0
            } else {
                1e-4 * (i as f64 - 5.5)
            }
        };
        let y: Vec<f64> = (0..12)
            .map(|i| 2.0 + 0.3 * (i as f64 * 2.1).sin())
            .collect();
        let yv = DVector::from_vec(y);
        let fit = |x: &DMatrix<f64>| {
            let th = (x.transpose() * x)
                .cholesky()
                .unwrap()
                .solve(&(x.transpose() * &yv));
            x * th - &yv
        };
        let x1 = DMatrix::from_fn(12, 1, |_, _| 1.0);
        let x2 = DMatrix::from_fn(12, 2, |i, j| if j == 0 { 1.0 } else { col(i) });
        let without = score(&w, &x1, &fit(&x1));
        let with = score(&w, &x2, &fit(&x2));
        assert!(with < 2.0 * without, "{with} vs {without}");
    }
}
