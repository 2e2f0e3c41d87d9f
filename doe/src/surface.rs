//! The response surface of an analysis in actual units (`millcomp_models::ResponseSurface`, saved as kind
//! `response_surface`, schema in `models/MODEL.md`), usable as a predictor elsewhere (e.g. the MPC's force
//! preview).

use std::collections::BTreeMap;

use millcomp_models::{ActualTerm, CodedFit, FactorCoding, ResponseSurface};

use crate::analysis::Analysis;
use crate::error::Result;

type MonoKey = (Vec<(String, u32)>, Vec<(String, String)>);
/// A monomial being built: powers, label levels, coefficient.
type Mono = (BTreeMap<String, u32>, BTreeMap<String, String>, f64);

/// Builds the actual-unit model from an analysis.
///
/// Each coded column is a product of parts x_f^p (x_f = (v_f − m_f)/h_f, m the mid-range, h the
/// half-range) and label indicators; expanding the products gives monomials in the actual values, and the
/// actual coefficients are β_act = T·β_coded with covariance T·Σ·Tᵀ.
///
/// # Examples
/// ```
/// use millcomp_doe::{analyze, response_surface, AnalysisInput, Values, ModelSpec};
/// let col = |v: &[f64]| Values::F64(v.to_vec());
/// let input = AnalysisInput {
///     factors: vec![("d".into(), col(&[100., 200., 100., 200.])), ("u".into(), col(&[10., 10., 20., 20.]))],
///     response_name: "f".into(),
///     response: col(&[1.0, 2.0, 2.0, 3.0]), // f = 0.01·d + 0.1·u − 1 exactly
///     model: ModelSpec::Main,
/// };
/// let m = response_surface(&analyze(&input).unwrap()).unwrap();
/// assert!((m.predict(&[("d", 150.0), ("u", 15.0)]).unwrap() - 2.0).abs() < 1e-12);
/// assert!((m.terms[1].coef - 0.01).abs() < 1e-14); // coefficient of d in N/µm
/// ```
///
/// # Errors
/// None in practice (the analysis already checked its inputs); the `Result` keeps room for checks.
pub fn response_surface(a: &Analysis) -> Result<ResponseSurface> {
    let d = &a.data;
    let p = d.beta.len();
    let mut keys: Vec<MonoKey> = Vec::new();
    let mut t: Vec<Vec<f64>> = Vec::new(); // rows: monomials, cols: coded columns
    for (c, parts) in d.col_parts.iter().enumerate() {
        // Expand the product of this column's parts into monomials.
        let mut monos: Vec<Mono> = vec![(BTreeMap::new(), BTreeMap::new(), 1.0)];
        for &(f, j, pow) in parts {
            let coding = &a.factors[f];
            match coding {
                FactorCoding::Numeric {
                    name, low, high, ..
                } => {
                    let h = 0.5 * (high - low);
                    let m = 0.5 * (high + low);
                    // x = a·v + b
                    let (sa, sb) = (1.0 / h, -m / h);
                    let poly: Vec<(u32, f64)> = if pow == 1 {
                        vec![(1, sa), (0, sb)]
                    } else {
                        vec![(2, sa * sa), (1, 2.0 * sa * sb), (0, sb * sb)]
                    };
                    let mut next = Vec::new();
                    for (pw, lb, cf) in &monos {
                        for &(e, k) in &poly {
                            let mut pw = pw.clone();
                            if e > 0 {
                                *pw.entry(name.clone()).or_insert(0) += e;
                            }
                            next.push((pw, lb.clone(), cf * k));
                        }
                    }
                    monos = next;
                }
                FactorCoding::Label { name, levels } => {
                    let level = if levels.len() == 2 {
                        levels[1].clone()
                    } else {
                        levels[j].clone()
                    };
                    for (_, lb, _) in monos.iter_mut() {
                        lb.insert(name.clone(), level.clone());
                    }
                }
            }
        }
        for (pw, lb, cf) in monos {
            let key: MonoKey = (pw.into_iter().collect(), lb.into_iter().collect());
            let row = match keys.iter().position(|k| *k == key) {
                Some(r) => r,
                None => {
                    keys.push(key);
                    t.push(vec![0.0; p]);
                    keys.len() - 1
                }
            };
            t[row][c] += cf;
        }
    }
    // Order monomials: intercept first, then by degree, then name.
    let mut order: Vec<usize> = (0..keys.len()).collect();
    let degree = |k: &MonoKey| k.0.iter().map(|(_, e)| *e).sum::<u32>() + k.1.len() as u32;
    order.sort_by(|&i, &j| {
        degree(&keys[i])
            .cmp(&degree(&keys[j]))
            .then(keys[i].cmp(&keys[j]))
    });
    let keys: Vec<MonoKey> = order.iter().map(|&i| keys[i].clone()).collect();
    let t: Vec<Vec<f64>> = order.iter().map(|&i| t[i].clone()).collect();
    let coef: Vec<f64> = t
        .iter()
        .map(|row| row.iter().zip(&d.beta).map(|(a, b)| a * b).sum())
        .collect();
    let coded_cov: Option<Vec<Vec<f64>>> = d.mse.map(|m| {
        d.xtx_inv
            .iter()
            .map(|r| r.iter().map(|v| v * m).collect())
            .collect()
    });
    let covariance = coded_cov.as_ref().map(|s| {
        let q = t.len();
        let ts: Vec<Vec<f64>> = (0..q)
            .map(|i| {
                (0..p)
                    .map(|k| (0..p).map(|l| t[i][l] * s[l][k]).sum())
                    .collect()
            })
            .collect();
        (0..q)
            .map(|i| {
                (0..q)
                    .map(|j| (0..p).map(|k| ts[i][k] * t[j][k]).sum())
                    .collect()
            })
            .collect()
    });
    let terms = keys
        .iter()
        .zip(&coef)
        .map(|((pw, lb), &c)| {
            let mut parts: Vec<String> = pw
                .iter()
                .map(|(n, e)| {
                    if *e == 1 {
                        n.clone()
                    } else {
                        format!("{n}^{e}")
                    }
                })
                .collect();
            parts.extend(lb.iter().map(|(n, l)| format!("{n}[{l}]")));
            ActualTerm {
                name: if parts.is_empty() {
                    "intercept".into()
                } else {
                    parts.join("*")
                },
                coef: c,
                powers: pw.iter().cloned().collect(),
                labels: lb.iter().cloned().collect(),
            }
        })
        .collect();
    Ok(ResponseSurface {
        response: a.response.clone(),
        model: a.model.clone(),
        n_runs: a.n_runs,
        residual_df: a.residual_df,
        sigma: a.sigma,
        r_squared: a.r_squared,
        factors: a.factors.clone(),
        terms,
        covariance,
        coded: CodedFit {
            terms: d.col_names.clone(),
            coef: d.beta.clone(),
            covariance: coded_cov,
        },
    })
}
