//! Curve fitting with closures: `y ≈ f(x, θ)` by the nonlinear least squares of
//! [`fit_nonlinear`], without implementing any trait.
//!
//! The model is a closure `f(&x, θ) → ŷ` over the points `x` (any type: a number, an array of
//! predictors, a struct); the Jacobian `∂ŷ/∂θ` is an optional second closure writing one row,
//! otherwise central differences are used. Parameters are named `b1, b2, …` unless named, and are
//! unbounded unless given as [`ParamSpec`]s. The report's `rss` is the residual sum of squares.

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};

use crate::error::{IdentifyError, Result};
use crate::jacobian_check::fd_jacobian;
use crate::nonlinear::{NlsOptions, NonlinearFit, ParamSpec, ResidualModel, fit_nonlinear};
use crate::validate;

type ModelFn<'a, T> = Box<dyn Fn(&T, &[f64]) -> f64 + 'a>;
type JacobianFn<'a, T> = Box<dyn Fn(&T, &[f64], &mut [f64]) + 'a>;

/// A curve fit `y ≈ f(x, θ)` set up from closures (see the module docs).
///
/// # Examples
/// ```
/// use millcomp_identify::{CurveFit, FitStatus};
/// // NIST StRD Misra1a, y = b1·(1 − exp(−b2·x)), from NIST's start 1 (500, 1e-4)
/// let x = [77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1, 689.1, 760.0];
/// let y = [10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.4, 75.47, 81.78];
/// let fit = CurveFit::new(&x, &y, |x: &f64, b: &[f64]| b[0] * (1.0 - (-b[1] * x).exp()))
///     .jacobian(|x: &f64, b: &[f64], d: &mut [f64]| {
///         let e = (-b[1] * x).exp();
///         d[0] = 1.0 - e;
///         d[1] = b[0] * x * e;
///     })
///     .fit(&[500.0, 1e-4])
///     .unwrap();
/// assert!(fit.report.status.is_success());
/// // NIST's certified values: b1 = 2.3894212918E+02, b2 = 5.5015643181E-04, RSS = 1.2455138894E-01
/// assert!((fit.report.param("b1") / 2.3894212918e2 - 1.0).abs() < 1e-8);
/// assert!((fit.report.param("b2") / 5.5015643181e-4 - 1.0).abs() < 1e-8);
/// assert!((fit.report.rss / 1.2455138894e-1 - 1.0).abs() < 1e-8);
/// // the same fit without a Jacobian (central differences)
/// let fd = CurveFit::new(&x, &y, |x: &f64, b: &[f64]| b[0] * (1.0 - (-b[1] * x).exp()))
///     .fit(&[500.0, 1e-4])
///     .unwrap();
/// assert!((fd.report.param("b1") / 2.3894212918e2 - 1.0).abs() < 1e-6);
/// ```
pub struct CurveFit<'a, T> {
    x: &'a [T],
    y: &'a [f64],
    f: ModelFn<'a, T>,
    jac: Option<JacobianFn<'a, T>>,
    weights: Option<&'a [f64]>,
    names: Option<Vec<String>>,
    model: String,
    unit: String,
    opts: NlsOptions,
}

impl<'a, T> CurveFit<'a, T> {
    /// A fit of `y[i] ≈ f(&x[i], θ)`.
    pub fn new(x: &'a [T], y: &'a [f64], f: impl Fn(&T, &[f64]) -> f64 + 'a) -> Self {
        CurveFit {
            x,
            y,
            f: Box::new(f),
            jac: None,
            weights: None,
            names: None,
            model: "curve_fit".into(),
            unit: "y".into(),
            opts: NlsOptions::default(),
        }
    }

    /// The analytic Jacobian: `d(&x, θ, row)` writes `∂f(x, θ)/∂θ_k` into `row[k]`.
    pub fn jacobian(mut self, d: impl Fn(&T, &[f64], &mut [f64]) + 'a) -> Self {
        self.jac = Some(Box::new(d));
        self
    }

    /// Weights (inverse variances, > 0), one per point.
    pub fn weights(mut self, w: &'a [f64]) -> Self {
        self.weights = Some(w);
        self
    }

    /// Parameter names (with units), one per parameter; default `b1, b2, …`.
    pub fn names(mut self, names: &[&str]) -> Self {
        self.names = Some(names.iter().map(|s| s.to_string()).collect());
        self
    }

    /// Model name in the report (default `curve_fit`) and the unit of `y` (default `y`, giving the
    /// report key `rms_residual_y`).
    pub fn label(mut self, model: &str, unit: &str) -> Self {
        self.model = model.into();
        self.unit = unit.into();
        self
    }

    /// Solver options (iteration limit, tolerances).
    pub fn options(mut self, opts: NlsOptions) -> Self {
        self.opts = opts;
        self
    }

    /// Fits from the starting values `initial` (unbounded parameters).
    ///
    /// # Errors
    /// As [`CurveFit::fit_specs`].
    pub fn fit(self, initial: &[f64]) -> Result<NonlinearFit> {
        let names: Vec<String> = match &self.names {
            Some(n) => n.clone(),
            None => (1..=initial.len()).map(|k| format!("b{k}")).collect(),
        };
        if names.len() != initial.len() {
            return Err(IdentifyError::InvalidParameter {
                name: "names.len()".into(),
                value: names.len() as f64,
                allowed: "one name per starting value",
            });
        }
        let specs: Vec<ParamSpec> = names
            .iter()
            .zip(initial)
            .map(|(n, &v)| ParamSpec::free(n, v))
            .collect();
        self.fit_specs(&specs)
    }

    /// Fits with named, possibly bounded parameters (the names of `specs` win over
    /// [`CurveFit::names`]).
    ///
    /// # Errors
    /// [`IdentifyError::LengthMismatch`] when `x`, `y` or the weights differ in length;
    /// [`IdentifyError::NonFinite`] for a NaN or infinite `y` or weight (naming the row);
    /// [`IdentifyError::InvalidParameter`] for a weight that is not > 0; and every error of
    /// [`fit_nonlinear`] (bounds, starting values, too few points, a model that is not finite at
    /// the start).
    pub fn fit_specs(self, specs: &[ParamSpec]) -> Result<NonlinearFit> {
        let n = self.y.len();
        if self.x.len() != n {
            return Err(IdentifyError::LengthMismatch {
                column: "x".into(),
                len: self.x.len(),
                reference: "y".into(),
                expected: n,
            });
        }
        validate::finite("y", self.y)?;
        let sw = match self.weights {
            Some(_) => Some(validate::sqrt_weights(self.weights, n)?),
            None => None,
        };
        let model = ClosureModel {
            x: self.x,
            y: self.y,
            f: self.f,
            jac: self.jac,
            sw,
        };
        fit_nonlinear(model, specs, &self.opts, &self.model, &self.unit)
    }
}

/// The residual operator `(f(x_i, θ) − y_i)·√w_i` built from the closures.
struct ClosureModel<'a, T> {
    x: &'a [T],
    y: &'a [f64],
    f: ModelFn<'a, T>,
    jac: Option<JacobianFn<'a, T>>,
    sw: Option<Vec<f64>>,
}

impl<T> ClosureModel<'_, T> {
    fn sw(&self, i: usize) -> f64 {
        self.sw.as_ref().map_or(1.0, |s| s[i])
    }
}

impl<T> Operator for ClosureModel<'_, T> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let b = p.as_slice();
        Ok(DVector::from_iterator(
            self.y.len(),
            (0..self.y.len()).map(|i| ((self.f)(&self.x[i], b) - self.y[i]) * self.sw(i)),
        ))
    }
}

impl<T> Jacobian for ClosureModel<'_, T> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        let (n, k) = (self.y.len(), p.len());
        match &self.jac {
            Some(d) => {
                let b = p.as_slice();
                let mut j = DMatrix::zeros(n, k);
                let mut row = vec![0.0; k];
                for i in 0..n {
                    row.iter_mut().for_each(|v| *v = 0.0);
                    d(&self.x[i], b, &mut row);
                    for (c, v) in row.iter().enumerate() {
                        j[(i, c)] = v * self.sw(i);
                    }
                }
                Ok(j)
            }
            None => fd_jacobian(|q| self.apply(q), p),
        }
    }
}

impl<T> ResidualModel for ClosureModel<'_, T> {
    fn sqrt_weights(&self) -> Option<&[f64]> {
        self.sw.as_deref()
    }
}
