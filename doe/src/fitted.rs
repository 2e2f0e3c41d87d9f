//! A fitted response-surface model in actual units, saved as TOML (schema in `doe/MODEL.md`), usable as a
//! predictor elsewhere (e.g. the MPC's force preview).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::analysis::{Analysis, FactorCoding};
use crate::error::{DoeError, Result};
use crate::factor::Level;

/// Current schema identifier written to `format`.
pub const MODEL_FORMAT: &str = "millcomp-doe-model";
/// Current schema version.
pub const MODEL_VERSION: u32 = 1;

/// One term of the model in actual units: coef × Π factor^power × Π label indicator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActualTerm {
    /// Readable name: `intercept`, `depth_um`, `depth_um*upfeed_um`, `depth_um^2`, `material[1018]`.
    pub name: String,
    /// Coefficient in actual units.
    pub coef: f64,
    /// Numeric factor → power (empty for the intercept).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub powers: BTreeMap<String, u32>,
    /// Label factor → level: contributes +1 at that level, −1 at the factor's last level, 0 otherwise
    /// (effect coding; a two-level label factor contributes −1 at its first level, +1 at its second, and is
    /// written with its second level here).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub labels: BTreeMap<String, String>,
}

/// The coded-unit fit, kept for reference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CodedFit {
    /// Column names (intercept first).
    pub terms: Vec<String>,
    /// Coded coefficients.
    pub coef: Vec<f64>,
    /// Covariance of the coded coefficients (σ²(XᵀX)⁻¹); absent when the model is saturated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance: Option<Vec<Vec<f64>>>,
}

/// A fitted model: terms and coefficients in actual units, their covariance and the factor ranges.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedModel {
    /// Always `millcomp-doe-model`.
    pub format: String,
    /// Schema version (1).
    pub version: u32,
    /// Response name.
    pub response: String,
    /// Model in coded terms, as analysed.
    pub model: String,
    /// Runs used in the fit.
    pub n_runs: usize,
    /// Residual degrees of freedom.
    pub residual_df: usize,
    /// Residual standard deviation (response units); absent when saturated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<f64>,
    /// R² of the fit.
    pub r_squared: f64,
    /// Factors and their ranges (numeric) or levels (labels).
    pub factors: Vec<FactorCoding>,
    /// Terms in actual units.
    pub terms: Vec<ActualTerm>,
    /// Covariance of the actual-unit coefficients (order of `terms`); absent when saturated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance: Option<Vec<Vec<f64>>>,
    /// The coded fit.
    pub coded: CodedFit,
}

/// A prediction with its standard error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Predicted mean response.
    pub mean: f64,
    /// Standard error of the predicted mean (None when the model is saturated).
    pub std_err: Option<f64>,
}

type MonoKey = (Vec<(String, u32)>, Vec<(String, String)>);
/// A monomial being built: powers, label levels, coefficient.
type Mono = (BTreeMap<String, u32>, BTreeMap<String, String>, f64);

impl FittedModel {
    /// Builds the actual-unit model from an analysis.
    ///
    /// Each coded column is a product of parts x_f^p (x_f = (v_f − m_f)/h_f, m the mid-range, h the
    /// half-range) and label indicators; expanding the products gives monomials in the actual values, and the
    /// actual coefficients are β_act = T·β_coded with covariance T·Σ·Tᵀ.
    pub fn from_analysis(a: &Analysis) -> Result<FittedModel> {
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
        Ok(FittedModel {
            format: MODEL_FORMAT.into(),
            version: MODEL_VERSION,
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

    /// TOML text of the model.
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| DoeError::ModelFile {
            path: "<memory>".into(),
            reason: e.to_string(),
        })
    }

    /// Parses a model from TOML text (checks `format` and `version`).
    pub fn from_toml_str(s: &str) -> Result<FittedModel> {
        let m: FittedModel = toml::from_str(s).map_err(|e| DoeError::ModelFile {
            path: "<memory>".into(),
            reason: e.to_string(),
        })?;
        if m.format != MODEL_FORMAT || m.version != MODEL_VERSION {
            return Err(DoeError::ModelFile {
                path: "<memory>".into(),
                reason: format!(
                    "format `{}` version {} (expected `{MODEL_FORMAT}` version {MODEL_VERSION})",
                    m.format, m.version
                ),
            });
        }
        Ok(m)
    }

    /// Writes the model as TOML.
    pub fn save_toml(&self, path: &Path) -> Result<()> {
        let s = self.to_toml_string().map_err(|e| match e {
            DoeError::ModelFile { reason, .. } => DoeError::ModelFile {
                path: path.to_path_buf(),
                reason,
            },
            o => o,
        })?;
        std::fs::write(path, s).map_err(|source| DoeError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Reads a model written by [`FittedModel::save_toml`].
    pub fn load_toml(path: &Path) -> Result<FittedModel> {
        let s = std::fs::read_to_string(path).map_err(|source| DoeError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        FittedModel::from_toml_str(&s).map_err(|e| match e {
            DoeError::ModelFile { reason, .. } => DoeError::ModelFile {
                path: path.to_path_buf(),
                reason,
            },
            o => o,
        })
    }

    fn term_row(&self, point: &[(&str, Level)]) -> Result<Vec<f64>> {
        for (name, _) in point {
            if !self.factors.iter().any(|f| f.name() == *name) {
                return Err(DoeError::UnknownFactor {
                    name: name.to_string(),
                    context: "prediction",
                    available: self
                        .factors
                        .iter()
                        .map(|f| f.name())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
        let get = |name: &str| -> Result<&Level> {
            point
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v)
                .ok_or_else(|| DoeError::InvalidPredictionPoint {
                    factor: name.to_string(),
                    reason: "no value given".into(),
                })
        };
        let mut row = Vec::with_capacity(self.terms.len());
        for t in &self.terms {
            let mut v = 1.0;
            for (name, &e) in &t.powers {
                match get(name)? {
                    Level::Num(x) if x.is_finite() => v *= x.powi(e as i32),
                    other => {
                        return Err(DoeError::InvalidPredictionPoint {
                            factor: name.clone(),
                            reason: format!("`{other}` is not a finite number"),
                        });
                    }
                }
            }
            for (name, level) in &t.labels {
                let Some(FactorCoding::Label { levels, .. }) =
                    self.factors.iter().find(|f| f.name() == name)
                else {
                    return Err(DoeError::ModelFile {
                        path: "<model>".into(),
                        reason: format!("label factor `{name}` missing"),
                    });
                };
                let given = match get(name)? {
                    Level::Label(s) => s.clone(),
                    Level::Num(x) => format!("{x}"),
                };
                if !levels.contains(&given) {
                    return Err(DoeError::InvalidPredictionPoint {
                        factor: name.clone(),
                        reason: format!("unknown level `{given}` (levels: {})", levels.join(", ")),
                    });
                }
                let last = &levels[levels.len() - 1];
                let first = &levels[0];
                v *= if levels.len() == 2 {
                    if &given == level { 1.0 } else { -1.0 }
                } else if &given == level {
                    1.0
                } else if &given == last {
                    -1.0
                } else {
                    let _ = first;
                    0.0
                };
            }
            row.push(v);
        }
        Ok(row)
    }

    /// Predicted mean and its standard error at a point given as (factor, level) pairs.
    pub fn predict_levels(&self, point: &[(&str, Level)]) -> Result<Prediction> {
        let row = self.term_row(point)?;
        let mean: f64 = row.iter().zip(&self.terms).map(|(r, t)| r * t.coef).sum();
        let std_err = self.covariance.as_ref().map(|c| {
            let mut s = 0.0;
            for i in 0..row.len() {
                for j in 0..row.len() {
                    s += row[i] * c[i][j] * row[j];
                }
            }
            s.max(0.0).sqrt()
        });
        Ok(Prediction { mean, std_err })
    }

    /// Predicted mean at a point of numeric factors in actual units.
    ///
    /// ```
    /// use millcomp_doe::{analyze, AnalysisInput, Column, FittedModel, ModelSpec};
    /// let col = |v: &[f64]| Column::F64(v.to_vec());
    /// let input = AnalysisInput {
    ///     factors: vec![("d".into(), col(&[100., 200., 100., 200.])), ("u".into(), col(&[10., 10., 20., 20.]))],
    ///     response_name: "f".into(),
    ///     response: col(&[1.0, 2.0, 2.0, 3.0]), // f = 0.01·d + 0.1·u − 1 exactly
    ///     model: ModelSpec::Main,
    /// };
    /// let m = FittedModel::from_analysis(&analyze(&input).unwrap()).unwrap();
    /// assert!((m.predict(&[("d", 150.0), ("u", 15.0)]).unwrap() - 2.0).abs() < 1e-12);
    /// assert!((m.terms[1].coef - 0.01).abs() < 1e-14); // coefficient of d in N/µm
    /// ```
    pub fn predict(&self, point: &[(&str, f64)]) -> Result<f64> {
        let p: Vec<(&str, Level)> = point.iter().map(|&(n, v)| (n, Level::Num(v))).collect();
        Ok(self.predict_levels(&p)?.mean)
    }

    /// Numeric factors of `point` that lie outside the range the model was fitted on (extrapolation).
    pub fn out_of_range(&self, point: &[(&str, f64)]) -> Vec<String> {
        point
            .iter()
            .filter(|(n, v)| {
                self.factors.iter().any(|f| match f {
                    FactorCoding::Numeric {
                        name, low, high, ..
                    } => {
                        name == n
                            && (*v < low - 1e-9 * (high - low) || *v > high + 1e-9 * (high - low))
                    }
                    _ => false,
                })
            })
            .map(|(n, _)| n.to_string())
            .collect()
    }
}

/// Builds the fitted model of an analysis and writes it as TOML (`doe analyze --save model.toml`).
pub fn save_model_toml(a: &Analysis, path: &Path) -> Result<FittedModel> {
    let m = FittedModel::from_analysis(a)?;
    m.save_toml(path)?;
    Ok(m)
}
