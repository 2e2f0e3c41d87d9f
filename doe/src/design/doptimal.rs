//! D-optimal designs by coordinate exchange (Meyer & Nachtsheim 1995, Technometrics 37:60–69) over a grid of
//! candidate levels, with linear constraints on the coded factors.

use nalgebra::{DMatrix, DVector};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::{BasePoints, DesignCriteria, DesignRequest, require_two_levels};
use crate::error::{DoeError, Result};
use crate::factor::FactorSpec;
use crate::model::{FactorMeta, ModelSpec, Term, expand};

/// The most runs of a D-optimal design (`--runs`).
pub const MAX_DOPTIMAL_RUNS: usize = 10_000;

/// A linear constraint on coded factor levels, `Σ cᵢ·xᵢ ≤ rhs` (a `>=` constraint is stored negated).
///
/// Syntax (one or more separated by `;`): `[coef*]name (+|-) [coef*]name … (<=|>=) number`, where names are
/// factor names (or letters A, B, …) and values are in **coded** units (−1 = low, +1 = high). Examples:
/// `depth_um + upfeed_um <= 1.5`, `2*A - B >= -1`, `depth_um <= 0.5`.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearConstraint {
    /// (factor index, coefficient).
    pub coefs: Vec<(usize, f64)>,
    /// Right-hand side of `Σ cᵢ·xᵢ ≤ rhs`.
    pub rhs: f64,
    /// The constraint as written.
    pub text: String,
}

impl LinearConstraint {
    /// Whether a coded point satisfies the constraint (with 1e-9 slack).
    pub fn satisfied(&self, x: &[f64]) -> bool {
        self.coefs.iter().map(|&(i, c)| c * x[i]).sum::<f64>() <= self.rhs + 1e-9
    }

    /// Parses a `;`-separated list of constraints against the factors.
    ///
    /// ```
    /// use millcomp_doe::{FactorSpec, LinearConstraint};
    /// let f = FactorSpec::parse_list("depth_um=100:200,upfeed_um=10:20").unwrap();
    /// let c = LinearConstraint::parse_list("depth_um + upfeed_um <= 1.5; depth_um >= -0.5", &f).unwrap();
    /// assert_eq!(c.len(), 2);
    /// assert!(c[0].satisfied(&[1.0, 0.5]));
    /// assert!(!c[0].satisfied(&[1.0, 1.0]));
    /// assert!(!c[1].satisfied(&[-1.0, 0.0]));
    /// ```
    ///
    /// # Errors
    /// [`DoeError::InvalidConstraint`] for a constraint that does not parse (no `<=`/`>=`, an empty term,
    /// a coefficient or bound that is not a number); [`DoeError::UnknownFactor`] for a name that is not a
    /// factor.
    pub fn parse_list(s: &str, factors: &[FactorSpec]) -> Result<Vec<LinearConstraint>> {
        s.split(';')
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(|c| Self::parse(c, factors))
            .collect()
    }

    fn parse(text: &str, factors: &[FactorSpec]) -> Result<LinearConstraint> {
        let bad = |reason: String| DoeError::InvalidConstraint {
            constraint: text.to_string(),
            reason,
        };
        let (lhs, rhs, ge) = if let Some((l, r)) = text.split_once("<=") {
            (l, r, false)
        } else if let Some((l, r)) = text.split_once(">=") {
            (l, r, true)
        } else if let Some((l, r)) = text.split_once('<') {
            (l, r, false)
        } else if let Some((l, r)) = text.split_once('>') {
            (l, r, true)
        } else {
            return Err(bad("expected `<=` or `>=`".into()));
        };
        let rhs: f64 = rhs
            .trim()
            .parse()
            .map_err(|_| bad(format!("right-hand side `{}` is not a number", rhs.trim())))?;
        // Tokenise the left side into signed terms.
        let mut terms: Vec<(f64, String)> = Vec::new();
        let mut cur = String::new();
        let mut sign = 1.0;
        let flush = |cur: &mut String, sign: f64, terms: &mut Vec<(f64, String)>| -> Result<()> {
            let t = cur.trim().to_string();
            cur.clear();
            if t.is_empty() {
                return Err(DoeError::InvalidConstraint {
                    constraint: text.to_string(),
                    reason: "empty term".into(),
                });
            }
            terms.push((sign, t));
            Ok(())
        };
        let lhs = lhs.trim();
        for (i, ch) in lhs.char_indices() {
            if (ch == '+' || ch == '-') && i > 0 && !lhs[..i].trim_end().ends_with(['e', 'E', '*'])
            {
                flush(&mut cur, sign, &mut terms)?;
                sign = if ch == '-' { -1.0 } else { 1.0 };
            } else if (ch == '+' || ch == '-') && i == 0 {
                sign = if ch == '-' { -1.0 } else { 1.0 };
            } else {
                cur.push(ch);
            }
        }
        flush(&mut cur, sign, &mut terms)?;
        let mut coefs: Vec<(usize, f64)> = Vec::new();
        let mut constant = 0.0;
        for (sgn, t) in terms {
            let (c, name) = match t.split_once('*') {
                Some((c, n)) => {
                    let c: f64 = c
                        .trim()
                        .parse()
                        .map_err(|_| bad(format!("coefficient `{}` is not a number", c.trim())))?;
                    (c, n.trim().to_string())
                }
                None => match t.parse::<f64>() {
                    Ok(v) => {
                        constant += sgn * v;
                        continue;
                    }
                    Err(_) => (1.0, t.clone()),
                },
            };
            let idx = factors
                .iter()
                .position(|f| f.name == name)
                .or_else(|| (0..factors.len()).find(|&i| crate::factor::factor_letter(i) == name))
                .ok_or_else(|| DoeError::UnknownFactor {
                    name: name.clone(),
                    context: "constraints",
                    available: factors
                        .iter()
                        .map(|f| f.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })?;
            match coefs.iter_mut().find(|(i, _)| *i == idx) {
                Some((_, v)) => *v += sgn * c,
                None => coefs.push((idx, sgn * c)),
            }
        }
        let mut rhs = rhs - constant;
        if ge {
            for (_, c) in coefs.iter_mut() {
                *c = -*c;
            }
            rhs = -rhs;
        }
        if !rhs.is_finite() || coefs.iter().any(|(_, c)| !c.is_finite()) {
            return Err(bad("non-finite number".into()));
        }
        Ok(LinearConstraint {
            coefs,
            rhs,
            text: text.to_string(),
        })
    }
}

/// Model row f(x) = [1, term values…] for coded x (continuous factors only).
pub(crate) fn model_row(terms: &[Term], x: &[f64]) -> Vec<f64> {
    let mut r = Vec::with_capacity(terms.len() + 1);
    r.push(1.0);
    for t in terms {
        r.push(t.parts.iter().map(|&(i, p)| x[i].powi(p as i32)).product());
    }
    r
}

fn info_inverse(rows: &[Vec<f64>], p: usize) -> Option<(DMatrix<f64>, f64)> {
    let n = rows.len();
    let x = DMatrix::from_fn(n, p, |i, j| rows[i][j]);
    let mut xtx = x.transpose() * &x;
    let ridge = 1e-8 * n as f64;
    for i in 0..p {
        xtx[(i, i)] += ridge;
    }
    let chol = xtx.clone().cholesky()?;
    let logdet = 2.0 * chol.l().diagonal().iter().map(|v| v.ln()).sum::<f64>();
    Some((chol.inverse(), logdet))
}

/// Coordinate-exchange D-optimal design.
pub(crate) fn d_optimal(req: &DesignRequest, rng: &mut ChaCha8Rng) -> Result<BasePoints> {
    let factors = &req.factors;
    require_two_levels(factors, "d-optimal", false)?;
    let k = factors.len();
    let spec = req.model.clone().unwrap_or(ModelSpec::Quadratic);
    let metas: Vec<FactorMeta> = factors
        .iter()
        .map(|f| FactorMeta {
            name: f.name.clone(),
            n_levels: 3,
            label: false,
        })
        .collect();
    let terms = expand(&spec, &metas)?;
    let p = terms.len() + 1;
    let n = req.runs.unwrap_or(p + 5);
    if n > MAX_DOPTIMAL_RUNS {
        return Err(DoeError::InvalidParameter {
            name: "runs",
            value: n.to_string(),
            allowed: format!(
                "at most {MAX_DOPTIMAL_RUNS} for a D-optimal design (its exchange search grows with the \
                 square of the runs)"
            ),
        });
    }
    if n < p {
        return Err(DoeError::InvalidParameter {
            name: "runs",
            value: n.to_string(),
            allowed: format!(
                "at least {p}, the number of coefficients of the model `{}`",
                spec.as_str()
            ),
        });
    }
    let levels: Vec<f64> = if !req.constraints.is_empty() {
        vec![-1.0, -0.5, 0.0, 0.5, 1.0]
    } else if terms.iter().any(|t| t.has_square()) {
        vec![-1.0, 0.0, 1.0]
    } else {
        vec![-1.0, 1.0]
    };
    let feasible = |x: &[f64]| req.constraints.iter().all(|c| c.satisfied(x));
    let nl = levels.len();
    let grid = (nl as f64).powi(k as i32);
    let mut cands: Vec<Vec<f64>> = Vec::new();
    if grid <= 200_000.0 {
        for r in 0..grid as usize {
            let mut rem = r;
            let x: Vec<f64> = (0..k)
                .map(|_| {
                    let v = levels[rem % nl];
                    rem /= nl;
                    v
                })
                .collect();
            if feasible(&x) {
                cands.push(x);
            }
        }
    } else {
        for _ in 0..50_000 {
            let x: Vec<f64> = (0..k).map(|_| levels[rng.random_range(0..nl)]).collect();
            if feasible(&x) {
                cands.push(x);
            }
        }
    }
    if cands.is_empty() {
        return Err(DoeError::InfeasibleConstraints {
            constraints: req
                .constraints
                .iter()
                .map(|c| c.text.as_str())
                .collect::<Vec<_>>()
                .join("; "),
        });
    }
    let starts = 10;
    let mut best: Option<(f64, Vec<Vec<f64>>)> = None;
    for _ in 0..starts {
        let mut pts: Vec<Vec<f64>> = (0..n)
            .map(|_| cands[rng.random_range(0..cands.len())].clone())
            .collect();
        let mut rows: Vec<Vec<f64>> = pts.iter().map(|x| model_row(&terms, x)).collect();
        let Some((mut minv, _)) = info_inverse(&rows, p) else {
            continue;
        };
        for _pass in 0..50 {
            let mut improved = false;
            for i in 0..n {
                for j in 0..k {
                    let fx = DVector::from_vec(rows[i].clone());
                    let mfx = &minv * &fx;
                    let d_old = fx.dot(&mfx);
                    let mut best_move: Option<(f64, f64)> = None;
                    for &l in &levels {
                        if l == pts[i][j] {
                            continue;
                        }
                        let mut y = pts[i].clone();
                        y[j] = l;
                        if !feasible(&y) {
                            continue;
                        }
                        let fy = DVector::from_vec(model_row(&terms, &y));
                        let mfy = &minv * &fy;
                        let d_new = fy.dot(&mfy);
                        let cross = fx.dot(&mfy);
                        // Fedorov's determinant ratio for exchanging row f(x) with f(y).
                        let ratio = (1.0 + d_new) * (1.0 - d_old) + cross * cross;
                        if ratio > 1.0 + 1e-9 && best_move.is_none_or(|(r, _)| ratio > r) {
                            best_move = Some((ratio, l));
                        }
                    }
                    if let Some((_, l)) = best_move {
                        pts[i][j] = l;
                        rows[i] = model_row(&terms, &pts[i]);
                        if let Some((m, _)) = info_inverse(&rows, p) {
                            minv = m;
                            improved = true;
                        }
                    }
                }
            }
            if !improved {
                break;
            }
        }
        if let Some((_, ld)) = info_inverse(&rows, p)
            && best.as_ref().is_none_or(|(b, _)| ld > *b)
        {
            best = Some((ld, pts));
        }
    }
    let (_, pts) = best.ok_or_else(|| DoeError::Unsupported {
        what: format!(
            "a D-optimal design for `{}` in {n} runs (every start was singular)",
            spec.as_str()
        ),
    })?;
    // Exact log det without the ridge.
    let rows: Vec<Vec<f64>> = pts.iter().map(|x| model_row(&terms, x)).collect();
    let x = DMatrix::from_fn(n, p, |i, j| rows[i][j]);
    let xtx = x.transpose() * &x;
    let logdet = xtx
        .clone()
        .cholesky()
        .map(|c| 2.0 * c.l().diagonal().iter().map(|v| v.ln()).sum::<f64>());
    let names: Vec<String> = factors.iter().map(|f| f.name.clone()).collect();
    let mut bp = BasePoints::unblocked(pts);
    bp.criteria = DesignCriteria {
        model: Some(
            terms
                .iter()
                .map(|t| t.name(&names))
                .collect::<Vec<_>>()
                .join(" + "),
        ),
        log_det_xtx: logdet,
        d_efficiency_pct: logdet.map(|ld| 100.0 * (ld / p as f64).exp() / n as f64),
        min_distance: None,
    };
    if logdet.is_none() {
        bp.notes.push(
            "the best design found is singular for this model: add runs or relax constraints"
                .into(),
        );
    }
    bp.notes.push(format!(
        "coordinate exchange over coded levels {levels:?}, {starts} random starts; {} candidate points satisfy the constraints",
        cands.len()
    ));
    Ok(bp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_constraints() {
        let f = FactorSpec::parse_list("a,b,c").unwrap();
        let c = LinearConstraint::parse_list("2*a - b + 0.5 >= -1; c <= 0.5", &f).unwrap();
        // 2a − b + 0.5 ≥ −1  ⇔  −2a + b ≤ 1.5
        assert_eq!(c[0].coefs, vec![(0, -2.0), (1, 1.0)]);
        assert!((c[0].rhs - 1.5).abs() < 1e-15);
        assert!(matches!(
            LinearConstraint::parse_list("a + z <= 1", &f),
            Err(DoeError::UnknownFactor { name, .. }) if name == "z"
        ));
        assert!(LinearConstraint::parse_list("a + b = 1", &f).is_err());
    }
}
