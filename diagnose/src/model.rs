//! The depth model the diagnosis fits — nominal + nuisance + the terms (family shapes) added so
//! far — as a whitened residual operator with prior rows, its least-squares fit on the identify
//! engine, and the linear algebra of the tests (strata of the information, hat traces, linearised
//! candidate fits).
//!
//! Parameters `θ = [free nuisance…, term₁ coefficients…, term₁ nonlinear…, term₂ …]`.
//! Prediction `base + shift(ν) + Σ_terms offsets`; residual rows: the whitened data
//! `W·(prediction − measured)` ([`Whitening`]) and one prior row `ν_k/σ_k` per nuisance with a
//! finite prior. Jacobian: nuisance analytic ([`NuisanceModel::gradient`]), coefficients the shape
//! columns, nonlinear parameters central differences of the shape's offsets.

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_identify::{IdentifyError, NlsOptions, ParamSpec, ResidualModel, fit_nonlinear};
use nalgebra::{DMatrix, DVector};

use crate::families::Shape;
use crate::nominal::SessionModel;
use crate::nuisance::{self, NuisanceModel};
use crate::scatter::Whitening;

/// One effect in a model: a family's shape.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Term {
    /// Effect name.
    pub family: &'static str,
    /// The shape.
    pub shape: Shape,
}

/// Which nuisance parameters are free and their priors.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NuisanceSet {
    /// Indices into [`nuisance::NAMES`] of the free ones (prior SD > 0).
    pub free: Vec<usize>,
    /// Prior SDs of all five.
    pub sd: [f64; 5],
}

impl NuisanceSet {
    pub fn new(sd: [f64; 5]) -> Self {
        NuisanceSet {
            free: (0..5).filter(|&k| sd[k] > 0.0).collect(),
            sd,
        }
    }

    /// Free nuisance parameters with a finite prior (one prior row each).
    pub fn prior_rows(&self) -> Vec<usize> {
        self.free
            .iter()
            .copied()
            .filter(|&k| self.sd[k].is_finite())
            .collect()
    }
}

/// The whitened residual operator of one model.
pub(crate) struct Problem<'a> {
    pub sm: &'a SessionModel,
    pub nm: &'a NuisanceModel,
    pub y: &'a [f64],
    pub terms: &'a [Term],
    pub w: &'a Whitening,
    pub nuis: &'a NuisanceSet,
}

impl Problem<'_> {
    pub fn n_params(&self) -> usize {
        self.nuis.free.len() + self.terms.iter().map(|t| t.shape.n_params()).sum::<usize>()
    }

    pub fn n_rows(&self) -> usize {
        self.y.len() + self.nuis.prior_rows().len()
    }

    /// The full nuisance vector from θ.
    pub fn nu(&self, theta: &[f64]) -> [f64; 5] {
        let mut nu = [0.0; 5];
        for (j, &k) in self.nuis.free.iter().enumerate() {
            nu[k] = theta[j];
        }
        nu
    }

    /// Start index of term `k`'s parameters in θ.
    pub fn term_start(&self, k: usize) -> usize {
        self.nuis.free.len()
            + self.terms[..k]
                .iter()
                .map(|t| t.shape.n_params())
                .sum::<usize>()
    }

    /// Offsets (µm) of term `k` at θ.
    pub fn term_offsets(&self, theta: &[f64], k: usize) -> Vec<f64> {
        let a = self.term_start(k);
        let t = &self.terms[k];
        t.shape.offsets(self.sm, &theta[a..a + t.shape.n_params()])
    }

    /// The nuisance shift (µm) at every point.
    pub fn nuisance_shift(&self, theta: &[f64]) -> Vec<f64> {
        let nu = self.nu(theta);
        (0..self.y.len())
            .map(|i| self.nm.shift_um(i, &nu))
            .collect()
    }

    /// Raw prediction (µm).
    pub fn predict(&self, theta: &[f64]) -> Vec<f64> {
        let mut p: Vec<f64> = self
            .sm
            .base_um
            .iter()
            .zip(self.nuisance_shift(theta))
            .map(|(b, s)| b + s)
            .collect();
        for k in 0..self.terms.len() {
            for (a, o) in p.iter_mut().zip(self.term_offsets(theta, k)) {
                *a += o;
            }
        }
        p
    }

    /// Whitened residual with prior rows.
    pub fn residual(&self, theta: &[f64]) -> DVector<f64> {
        let mut r: Vec<f64> = self
            .predict(theta)
            .iter()
            .zip(self.y)
            .map(|(p, y)| p - y)
            .collect();
        self.w.apply(&mut r);
        let nu = self.nu(theta);
        for k in self.nuis.prior_rows() {
            r.push(nu[k] / self.nuis.sd[k]);
        }
        DVector::from_vec(r)
    }

    /// Whitened Jacobian with prior rows.
    pub fn jacobian_matrix(&self, theta: &[f64]) -> DMatrix<f64> {
        let n = self.y.len();
        let p = self.n_params();
        let rows = self.n_rows();
        let mut jac = DMatrix::zeros(rows, p);
        let nu = self.nu(theta);
        let mut col = vec![0.0; n];
        for (j, &k) in self.nuis.free.iter().enumerate() {
            for (i, c) in col.iter_mut().enumerate() {
                *c = self.nm.gradient(i, &nu)[k];
            }
            self.w.apply(&mut col);
            jac.column_mut(j).rows_mut(0, n).copy_from_slice(&col);
        }
        for (r, k) in self.nuis.prior_rows().into_iter().enumerate() {
            let j = self.nuis.free.iter().position(|&f| f == k).unwrap_or(0);
            jac[(n + r, j)] = 1.0 / self.nuis.sd[k];
        }
        for (k, t) in self.terms.iter().enumerate() {
            let a = self.term_start(k);
            let np = t.shape.n_params();
            let th = &theta[a..a + np];
            let nl = t.shape.linear.len();
            if nl > 0 {
                let cols = t.shape.columns(self.sm, &th[nl..]);
                for (m, mut c) in cols.into_iter().enumerate() {
                    self.w.apply(&mut c);
                    jac.column_mut(a + m).rows_mut(0, n).copy_from_slice(&c);
                }
            }
            for m in nl..np {
                let h = fd_step(th[m]);
                let mut tp = th.to_vec();
                let mut tm = th.to_vec();
                tp[m] += h;
                tm[m] -= h;
                let op = t.shape.offsets(self.sm, &tp);
                let om = t.shape.offsets(self.sm, &tm);
                let mut c: Vec<f64> = op
                    .iter()
                    .zip(&om)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect();
                self.w.apply(&mut c);
                jac.column_mut(a + m).rows_mut(0, n).copy_from_slice(&c);
            }
        }
        jac
    }

    /// Parameter names, `family.param` for terms.
    pub fn param_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .nuis
            .free
            .iter()
            .map(|&k| format!("nominal.{}", nuisance::NAMES[k]))
            .collect();
        for t in self.terms {
            for n in t.shape.param_names() {
                v.push(format!("{}.{n}", t.family));
            }
        }
        v
    }

    /// Bounds of every parameter, for the identify engine: nuisance within ±95 % (stiffness and
    /// force scale cannot change sign), coefficients free, nonlinear parameters the shape's.
    pub fn param_specs(&self, theta: &[f64]) -> Vec<ParamSpec> {
        let names = self.param_names();
        let mut specs = Vec::with_capacity(theta.len());
        let mut j = 0;
        for &k in &self.nuis.free {
            let (lo, hi) = match k {
                0..=2 => (-95.0, 1900.0),
                3 => (-1e4, 1e4),
                _ => (f64::NEG_INFINITY, f64::INFINITY),
            };
            specs.push(bounded(&names[j], theta[j], lo, hi));
            j += 1;
        }
        for t in self.terms {
            for _ in &t.shape.linear {
                specs.push(bounded(
                    &names[j],
                    theta[j],
                    f64::NEG_INFINITY,
                    f64::INFINITY,
                ));
                j += 1;
            }
            for p in &t.shape.nonlinear {
                specs.push(bounded(&names[j], theta[j], p.lower, p.upper));
                j += 1;
            }
        }
        specs
    }
}

fn bounded(name: &str, v: f64, lo: f64, hi: f64) -> ParamSpec {
    let w = if lo.is_finite() && hi.is_finite() {
        1e-6 * (hi - lo)
    } else {
        1e-6 * v.abs().max(1.0)
    };
    let v = if v <= lo {
        lo + w
    } else if v >= hi {
        hi - w
    } else {
        v
    };
    ParamSpec::bounded(name, v, lo, hi)
}

/// Central-difference step for a nonlinear shape parameter.
fn fd_step(v: f64) -> f64 {
    1e-5 * v.abs().max(1.0)
}

impl Operator for Problem<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, theta: &DVector<f64>) -> Result<DVector<f64>, ArgminError> {
        let r = self.residual(theta.as_slice());
        if r.iter().any(|v| !v.is_finite()) {
            return Err(ArgminError::msg("non-finite residual"));
        }
        Ok(r)
    }
}

impl Jacobian for Problem<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, theta: &DVector<f64>) -> Result<DMatrix<f64>, ArgminError> {
        Ok(self.jacobian_matrix(theta.as_slice()))
    }
}

impl ResidualModel for Problem<'_> {}

/// Tolerances of the inner fits: the F-tests need the whitened RSS to ~1e-8 relative.
pub(crate) fn nls_options() -> NlsOptions {
    NlsOptions {
        max_iter: 100,
        ftol: 1e-10,
        xtol: 1e-10,
        gtol: 1e-10,
        initial_radius: 1.0,
    }
}

/// A fitted model: estimate, whitened residual and Jacobian at it.
#[derive(Debug, Clone)]
pub(crate) struct Fitted {
    pub theta: Vec<f64>,
    /// Whitened residual with prior rows.
    pub r: DVector<f64>,
    /// Whitened Jacobian with prior rows.
    pub x: DMatrix<f64>,
    /// Total whitened RSS (data + prior).
    pub rss: f64,
    /// Whether the engine reported convergence.
    pub converged: bool,
}

/// Fits `p` from `start` on the identify engine (bounded trust region).
pub(crate) fn fit(p: &Problem<'_>, start: &[f64]) -> Result<Fitted, IdentifyError> {
    let specs = p.param_specs(start);
    let fit = fit_nonlinear(
        Problem {
            sm: p.sm,
            nm: p.nm,
            y: p.y,
            terms: p.terms,
            w: p.w,
            nuis: p.nuis,
        },
        &specs,
        &nls_options(),
        "diagnose",
        "um",
    )?;
    let theta: Vec<f64> = fit.theta.iter().copied().collect();
    Ok(evaluate(p, &theta, fit.report.status.is_success()))
}

/// The model `p` with parameter `j` held at `value`: the free parameters are the others.
struct Held<'a, 'b> {
    p: &'a Problem<'b>,
    j: usize,
    value: f64,
}

impl Held<'_, '_> {
    fn full(&self, free: &[f64]) -> Vec<f64> {
        let mut t = free.to_vec();
        t.insert(self.j, self.value);
        t
    }
}

impl Operator for Held<'_, '_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, theta: &DVector<f64>) -> Result<DVector<f64>, ArgminError> {
        let r = self.p.residual(&self.full(theta.as_slice()));
        if r.iter().any(|v| !v.is_finite()) {
            return Err(ArgminError::msg("non-finite residual"));
        }
        Ok(r)
    }
}

impl Jacobian for Held<'_, '_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, theta: &DVector<f64>) -> Result<DMatrix<f64>, ArgminError> {
        Ok(self
            .p
            .jacobian_matrix(&self.full(theta.as_slice()))
            .remove_column(self.j))
    }
}

impl ResidualModel for Held<'_, '_> {}

/// Fits `p` with parameter `j` held at `value`, from `start` (all parameters; `start[j]` is
/// ignored): the full θ and the whitened RSS of the constrained fit.
pub(crate) fn fit_held(
    p: &Problem<'_>,
    start: &[f64],
    j: usize,
    value: f64,
) -> Result<(Vec<f64>, f64), IdentifyError> {
    let mut full = start.to_vec();
    full[j] = value;
    let mut specs = p.param_specs(&full);
    specs.remove(j);
    let held = Held { p, j, value };
    let fit = fit_nonlinear(held, &specs, &nls_options(), "diagnose", "um")?;
    let free: Vec<f64> = fit.theta.iter().copied().collect();
    let mut theta = free;
    theta.insert(j, value);
    let rss = p.residual(&theta).norm_squared();
    Ok((theta, rss))
}

/// The model at θ without fitting.
pub(crate) fn evaluate(p: &Problem<'_>, theta: &[f64], converged: bool) -> Fitted {
    let r = p.residual(theta);
    let x = p.jacobian_matrix(theta);
    Fitted {
        theta: theta.to_vec(),
        rss: r.norm_squared(),
        r,
        x,
        converged,
    }
}

/// Orthonormal basis of the column space of `x`: modified Gram–Schmidt, each column
/// orthogonalised twice ("twice is enough", Giraud et al. 2005) and dropped when less than 1e-9
/// of its own norm is left (a column the others span). (nalgebra's SVD returned a wrong left
/// singular vector for the rank-one 5 × 5 nuisance design of a single constant-depth groove.)
pub(crate) fn orthonormal_basis(x: &DMatrix<f64>) -> DMatrix<f64> {
    let n = x.nrows();
    let mut basis: Vec<DVector<f64>> = Vec::with_capacity(x.ncols());
    for j in 0..x.ncols() {
        let mut v: DVector<f64> = x.column(j).into_owned();
        let norm0 = v.norm();
        if norm0 <= 0.0 || !norm0.is_finite() {
            continue;
        }
        for _ in 0..2 {
            for q in &basis {
                let d = q.dot(&v);
                v.axpy(-d, q, 1.0);
            }
        }
        let nv = v.norm();
        if nv > 1e-9 * norm0 {
            basis.push(v / nv);
        }
    }
    let mut q = DMatrix::zeros(n, basis.len());
    for (j, b) in basis.iter().enumerate() {
        q.set_column(j, b);
    }
    q
}

/// `v − Q Qᵀ v` for every column of `v`.
pub(crate) fn project_out(q: &DMatrix<f64>, v: &DMatrix<f64>) -> DMatrix<f64> {
    if q.ncols() == 0 {
        return v.clone();
    }
    v - q * (q.transpose() * v)
}

/// Shares of the information of the columns of `q` (orthonormal, rows: n data then prior rows)
/// in the within-groove, between-groove and prior strata (sums of squares, total = ncols).
pub(crate) fn strata_of_columns(w: &Whitening, q: &DMatrix<f64>, n: usize) -> [f64; 3] {
    let mut s = [0.0; 3];
    for j in 0..q.ncols() {
        let c = q.column(j);
        let (wi, bt) = w.strata(&c.as_slice()[..n]);
        s[0] += wi;
        s[1] += bt;
        s[2] += c.rows(n, q.nrows() - n).norm_squared();
    }
    s
}

/// `(within, between, prior)` squared norms of a whitened residual with prior rows.
pub(crate) fn strata_of_residual(w: &Whitening, r: &DVector<f64>, n: usize) -> [f64; 3] {
    let (wi, bt) = w.strata(&r.as_slice()[..n]);
    [wi, bt, r.rows(n, r.len() - n).norm_squared()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthonormal_basis_of_a_rank_one_matrix_spans_it() {
        let g = [-0.0734, 0.0304, 0.0431, -0.6976, 1.0];
        let x = DMatrix::from_fn(5, 5, |_, j| g[j] * 0.9);
        let q = orthonormal_basis(&x);
        assert_eq!(q.ncols(), 1, "{q}");
        let b = DMatrix::from_element(5, 1, 3.0);
        let rest = project_out(&q, &b);
        assert!(rest.norm() < 1e-9 * b.norm(), "{rest}");
    }
}
