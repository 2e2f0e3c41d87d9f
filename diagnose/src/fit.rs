//! The augmented depth model as a residual operator, and its multi-start least-squares fit on the
//! identify engine ([`fit_nonlinear`]).
//!
//! Model: `depth(θ) = base + Σ_terms offset_term(θ_term; ctx)` (sim's effects are additive depth
//! offsets that do not feed back into the force, sim/src/session.rs), residual `model − measured`.
//! Jacobian: each effect's `param_gradient` (analytic where sim has one, central differences
//! otherwise), restricted to its free parameters — checked against finite differences of the
//! residual in the module tests.

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use millcomp_identify::{
    FitReport, IdentifyError, NlsOptions, ParamSpec, ResidualModel, fit_nonlinear,
};
use millcomp_sim::effects::Effect;
use nalgebra::{DMatrix, DVector};

use crate::candidates::CandidateSpec;
use crate::nominal::SessionModel;

/// One effect in a model: the effect (fixed values) and the indices of its free parameters.
#[derive(Debug, Clone)]
pub(crate) struct Term {
    pub spec: CandidateSpec,
    pub free_idx: Vec<usize>,
}

impl Term {
    pub fn new(spec: CandidateSpec) -> Result<Self, String> {
        let free_idx = spec.free_indices()?;
        Ok(Term { spec, free_idx })
    }

    pub fn n_free(&self) -> usize {
        self.free_idx.len()
    }

    /// The effect with its free parameters set to `theta`.
    pub fn configured(&self, theta: &[f64]) -> Result<Box<dyn Effect>, ArgminError> {
        let mut e = self.spec.effect.clone();
        let mut p: Vec<f64> = e.params().iter().map(|(_, v)| *v).collect();
        for (k, &i) in self.free_idx.iter().enumerate() {
            p[i] = theta[k];
        }
        e.set_params(&p)
            .map_err(|err| ArgminError::msg(err.to_string()))?;
        Ok(e)
    }

    pub fn param_specs(&self, values: &[f64]) -> Vec<ParamSpec> {
        self.spec
            .free
            .iter()
            .zip(values)
            .map(|(f, &v)| {
                ParamSpec::bounded(
                    &format!("{}.{}", self.spec.name(), f.name),
                    inside(v, f.lower, f.upper),
                    f.lower,
                    f.upper,
                )
            })
            .collect()
    }
}

/// `v` moved strictly inside `[lo, hi]` (a previous estimate may sit on a bound).
fn inside(v: f64, lo: f64, hi: f64) -> f64 {
    let w = if lo.is_finite() && hi.is_finite() {
        1e-6 * (hi - lo)
    } else {
        1e-6 * v.abs().max(1.0)
    };
    if v <= lo {
        lo + w
    } else if v >= hi {
        hi - w
    } else {
        v
    }
}

/// Residual operator of base + Σ terms against the measured depths.
pub(crate) struct DepthModel<'a> {
    pub sm: &'a SessionModel,
    pub y: &'a [f64],
    pub terms: &'a [Term],
}

impl DepthModel<'_> {
    fn configured(&self, theta: &DVector<f64>) -> Result<Vec<Box<dyn Effect>>, ArgminError> {
        let mut out = Vec::with_capacity(self.terms.len());
        let mut k = 0;
        for t in self.terms {
            let n = t.n_free();
            out.push(t.configured(&theta.as_slice()[k..k + n])?);
            k += n;
        }
        Ok(out)
    }

    /// Model prediction (µm) at `theta`.
    pub fn predict(&self, theta: &DVector<f64>) -> Result<Vec<f64>, ArgminError> {
        let effects = self.configured(theta)?;
        Ok((0..self.sm.len())
            .map(|i| {
                let ctx = self.sm.ctx(i);
                self.sm.base_um[i] + effects.iter().map(|e| e.depth_offset_um(&ctx)).sum::<f64>()
            })
            .collect())
    }
}

impl Operator for DepthModel<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, theta: &DVector<f64>) -> Result<DVector<f64>, ArgminError> {
        let pred = self.predict(theta)?;
        Ok(DVector::from_iterator(
            pred.len(),
            pred.iter().zip(self.y).map(|(p, y)| p - y),
        ))
    }
}

impl Jacobian for DepthModel<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, theta: &DVector<f64>) -> Result<DMatrix<f64>, ArgminError> {
        let effects = self.configured(theta)?;
        let n = self.sm.len();
        let mut jac = DMatrix::zeros(n, theta.len());
        for i in 0..n {
            let ctx = self.sm.ctx(i);
            let mut col = 0;
            for (t, e) in self.terms.iter().zip(&effects) {
                let g = e.param_gradient(&ctx);
                for (k, &pi) in t.free_idx.iter().enumerate() {
                    jac[(i, col + k)] = g[pi];
                }
                col += t.n_free();
            }
        }
        Ok(jac)
    }
}

impl ResidualModel for DepthModel<'_> {}

/// Outcome of a multi-start fit.
#[derive(Debug, Clone)]
pub(crate) struct TermsFit {
    pub theta: Vec<f64>,
    pub rss: f64,
    pub report: FitReport,
    pub prediction: Vec<f64>,
}

/// Options of the inner fits: tolerances looser than the engine defaults (the F-test needs the RSS
/// to ~1e-8 relative, not the parameters to 1e-12) to keep a diagnosis of ~20 fits fast.
pub(crate) fn nls_options() -> NlsOptions {
    NlsOptions {
        max_iter: 200,
        ftol: 1e-10,
        xtol: 1e-10,
        gtol: 1e-10,
        initial_radius: 1.0,
    }
}

/// Fits `terms` to `y`: the first terms start at `current` (their previous estimates), the last
/// `n_new` terms at every combination of their specs' starting values. Returns the fit with the
/// smallest RSS, or the engine's error for every start when no start could be fitted.
pub(crate) fn fit_terms(
    sm: &SessionModel,
    y: &[f64],
    terms: &[Term],
    current: &[f64],
    n_new: usize,
) -> Result<TermsFit, Vec<IdentifyError>> {
    let n_old = terms.len() - n_new;
    // starting grid of the new terms' parameters (cartesian product)
    let mut grid: Vec<Vec<f64>> = vec![current.to_vec()];
    for t in &terms[n_old..] {
        for f in &t.spec.free {
            let mut next = Vec::with_capacity(grid.len() * f.starts.len());
            for g in &grid {
                for &s in &f.starts {
                    let mut v = g.clone();
                    v.push(s);
                    next.push(v);
                }
            }
            grid = next;
        }
    }
    let mut best: Option<TermsFit> = None;
    let mut failures = Vec::new();
    for start in grid {
        match fit_once(sm, y, terms, &start) {
            Ok(f) => {
                if best.as_ref().is_none_or(|b| f.rss < b.rss) {
                    best = Some(f);
                }
            }
            Err(e) => failures.push(e),
        }
    }
    best.ok_or(failures)
}

fn fit_once(
    sm: &SessionModel,
    y: &[f64],
    terms: &[Term],
    start: &[f64],
) -> Result<TermsFit, IdentifyError> {
    let mut specs = Vec::new();
    let mut k = 0;
    for t in terms {
        specs.extend(t.param_specs(&start[k..k + t.n_free()]));
        k += t.n_free();
    }
    let model = DepthModel { sm, y, terms };
    let fit = fit_nonlinear(model, &specs, &nls_options(), "diagnose", "um")?;
    let model = DepthModel { sm, y, terms };
    let prediction =
        model
            .predict(&fit.theta)
            .map_err(|source| IdentifyError::ModelEvaluation {
                model: "diagnose".into(),
                what: "depths at the estimate".into(),
                source,
            })?;
    let rss = prediction
        .iter()
        .zip(y)
        .map(|(p, y)| (p - y) * (p - y))
        .sum();
    Ok(TermsFit {
        theta: fit.theta.iter().copied().collect(),
        rss,
        report: fit.report,
        prediction,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::candidates::Registry;
    use millcomp_identify::check_jacobian;

    #[test]
    fn depth_model_jacobian_matches_finite_differences() {
        let s = millcomp_synthetic::base_session("t", "test");
        let sm = SessionModel::new(&s).unwrap();
        let y = vec![0.0; sm.len()];
        let reg = Registry::standard();
        let terms: Vec<Term> = reg
            .specs()
            .iter()
            .map(|c| Term::new(c.clone()).unwrap())
            .collect();
        // a point away from the starting values and bounds, every parameter active
        let theta = DVector::from_vec(vec![
            7.0, 800.0, // coolant
            15.0, 15_000.0, 500.0, // spindle
            0.1,   // probe tilt
            6.0, 120.0, // wear
            4.0,   // straightness
            12.0,  // machine compliance
            2.5,   // flute runout
        ]);
        let m = DepthModel {
            sm: &sm,
            y: &y,
            terms: &terms,
        };
        // 1e-5: sim's own finite-difference gradients (coolant, spindle: h = 1e-6·|p|) have
        // relative errors ~1e-8…1e-6 on these smooth offsets; a wrong column is off by O(1).
        let c = check_jacobian(&m, &theta, 1e-5).unwrap();
        assert!(c.ok, "{c:?}");
    }
}
