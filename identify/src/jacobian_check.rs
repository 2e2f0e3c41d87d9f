//! Finite-difference checks and finite-difference Jacobians.
//!
//! Every analytic Jacobian in this crate is tested against [`check_jacobian`]; models whose
//! Jacobian is itself a finite difference (documented where used) call [`fd_jacobian`].

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};

/// Outcome of [`check_jacobian`].
#[derive(Debug, Clone, PartialEq)]
pub struct JacobianCheck {
    /// Largest relative discrepancy found.
    pub max_rel_err: f64,
    /// Row of the worst entry.
    pub worst_row: usize,
    /// Column (parameter) of the worst entry.
    pub worst_col: usize,
    /// Analytic value there.
    pub analytic: f64,
    /// Central-difference value there.
    pub numeric: f64,
    /// `max_rel_err <= rel_tol`.
    pub ok: bool,
}

/// Central-difference step for parameter value `x`: `ε^{1/3}·|x|` (`ε^{1/3}` at 0), the step that
/// balances truncation (∝ h²) and round-off (∝ ε/h) error of a central difference.
fn step(x: f64) -> f64 {
    let h0 = f64::EPSILON.cbrt();
    if x != 0.0 { h0 * x.abs() } else { h0 }
}

/// Central-difference Jacobian of `f` at `x` (2p evaluations).
pub fn fd_jacobian<F>(f: F, x: &DVector<f64>) -> Result<DMatrix<f64>, ArgminError>
where
    F: Fn(&DVector<f64>) -> Result<DVector<f64>, ArgminError>,
{
    let mut cols = Vec::with_capacity(x.len());
    for j in 0..x.len() {
        let h = step(x[j]);
        let mut xp = x.clone();
        let mut xm = x.clone();
        xp[j] += h;
        xm[j] -= h;
        let d = (f(&xp)? - f(&xm)?) / (xp[j] - xm[j]);
        cols.push(d);
    }
    let n = cols.first().map(|c| c.len()).unwrap_or(0);
    Ok(DMatrix::from_fn(n, x.len(), |i, j| cols[j][i]))
}

/// [`fd_jacobian`] for parameters with bounds (`bounds[j] = (lower, upper)`, either may be infinite):
/// a parameter within a step of a bound is differenced one-sidedly, away from it, with the second-order
/// formula `(∓3f(x) ± 4f(x ± h) ∓ f(x ± 2h)) / 2h`, so that `f` is never evaluated outside the bounds —
/// the model the bounds protect (a spindle with ζ > 10, a negative time constant) may refuse such a
/// point. `bounds` shorter than `x` leaves the rest unbounded.
///
/// ```
/// use nalgebra::DVector;
/// use millcomp_identify::fd_jacobian_within;
/// // f(x) = x², refused beyond x = 1: at the bound the derivative 2 is still found
/// let f = |x: &DVector<f64>| {
///     if x[0] > 1.0 { Err(argmin::core::Error::msg("past the bound")) } else { Ok(x.map(|v| v * v)) }
/// };
/// let j = fd_jacobian_within(f, &DVector::from_element(1, 1.0), &[(0.0, 1.0)]).unwrap();
/// assert!((j[(0, 0)] - 2.0).abs() < 1e-8);
/// ```
///
/// # Errors
/// The first error of `f`.
pub fn fd_jacobian_within<F>(
    f: F,
    x: &DVector<f64>,
    bounds: &[(f64, f64)],
) -> Result<DMatrix<f64>, ArgminError>
where
    F: Fn(&DVector<f64>) -> Result<DVector<f64>, ArgminError>,
{
    let mut f0: Option<DVector<f64>> = None;
    let mut cols = Vec::with_capacity(x.len());
    for j in 0..x.len() {
        let (lo, hi) = bounds
            .get(j)
            .copied()
            .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let mut h = step(x[j]);
        let up_room = hi - x[j];
        let down_room = x[j] - lo;
        // a bounded interval narrower than two steps: shrink the step to fit a central difference
        if up_room < h && down_room < h {
            h = up_room.min(down_room).max(f64::MIN_POSITIVE);
        }
        let at = |k: f64| {
            let mut xp = x.clone();
            xp[j] += k * h;
            f(&xp)
        };
        let d = if x[j] + h > hi && down_room >= 2.0 * h {
            // backward, second order
            let base = match &f0 {
                Some(v) => v.clone(),
                None => f0.insert(f(x)?).clone(),
            };
            (base * 3.0 - at(-1.0)? * 4.0 + at(-2.0)?) / (2.0 * h)
        } else if x[j] - h < lo && up_room >= 2.0 * h {
            // forward, second order
            let base = match &f0 {
                Some(v) => v.clone(),
                None => f0.insert(f(x)?).clone(),
            };
            (at(1.0)? * 4.0 - base * 3.0 - at(2.0)?) / (2.0 * h)
        } else {
            let mut xp = x.clone();
            let mut xm = x.clone();
            xp[j] += h;
            xm[j] -= h;
            (f(&xp)? - f(&xm)?) / (xp[j] - xm[j])
        };
        cols.push(d);
    }
    let n = cols.first().map(|c| c.len()).unwrap_or(0);
    Ok(DMatrix::from_fn(n, x.len(), |i, j| cols[j][i]))
}

/// Compares `op.jacobian(x)` with a central difference of `op.apply` at `x`.
///
/// The error of entry (i, j) is `|J_a − J_fd| / max(|J_fd|, 1e-6·max_i|J_fd(·, j)|)`: relative,
/// with a floor at a millionth of the column's largest entry so that entries that should be 0 are
/// judged against the column's scale rather than against 0.
pub fn check_jacobian<O>(
    op: &O,
    x: &DVector<f64>,
    rel_tol: f64,
) -> Result<JacobianCheck, ArgminError>
where
    O: Operator<Param = DVector<f64>, Output = DVector<f64>>
        + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>,
{
    let ja = op.jacobian(x)?;
    let jn = fd_jacobian(|p| op.apply(p), x)?;
    let mut worst = JacobianCheck {
        max_rel_err: 0.0,
        worst_row: 0,
        worst_col: 0,
        analytic: f64::NAN,
        numeric: f64::NAN,
        ok: true,
    };
    if ja.shape() != jn.shape() {
        worst.max_rel_err = f64::INFINITY;
        worst.ok = false;
        return Ok(worst);
    }
    for j in 0..jn.ncols() {
        let colmax = jn.column(j).amax();
        let floor = (1e-6 * colmax).max(f64::MIN_POSITIVE);
        for i in 0..jn.nrows() {
            let e = (ja[(i, j)] - jn[(i, j)]).abs() / jn[(i, j)].abs().max(floor);
            if e > worst.max_rel_err || e.is_nan() {
                worst.max_rel_err = e;
                worst.worst_row = i;
                worst.worst_col = j;
                worst.analytic = ja[(i, j)];
                worst.numeric = jn[(i, j)];
            }
        }
    }
    worst.ok = worst.max_rel_err <= rel_tol;
    Ok(worst)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Quad {
        wrong: bool,
    }
    impl Operator for Quad {
        type Param = DVector<f64>;
        type Output = DVector<f64>;
        fn apply(&self, p: &DVector<f64>) -> Result<DVector<f64>, ArgminError> {
            Ok(DVector::from_vec(vec![p[0] * p[0] * p[1], p[1].sin()]))
        }
    }
    impl Jacobian for Quad {
        type Param = DVector<f64>;
        type Jacobian = DMatrix<f64>;
        fn jacobian(&self, p: &DVector<f64>) -> Result<DMatrix<f64>, ArgminError> {
            let k = if self.wrong { 1.01 } else { 1.0 };
            Ok(DMatrix::from_row_slice(
                2,
                2,
                &[2.0 * p[0] * p[1], p[0] * p[0], 0.0, k * p[1].cos()],
            ))
        }
    }

    #[test]
    fn detects_right_and_wrong() {
        let x = DVector::from_vec(vec![1.3, 0.4]);
        let good = check_jacobian(&Quad { wrong: false }, &x, 1e-6).unwrap();
        assert!(good.ok, "{good:?}");
        let bad = check_jacobian(&Quad { wrong: true }, &x, 1e-6).unwrap();
        assert!(!bad.ok);
        assert_eq!((bad.worst_row, bad.worst_col), (1, 1));
    }
}
