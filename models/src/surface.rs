//! Response surfaces: polynomial models of a response in actual units, fitted on a designed experiment by
//! `millcomp-doe` and saved as kind `response_surface` (`models/MODEL.md`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::{ModelError, Result};

/// One level of a factor, or one value of a point: a number or a label.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Level {
    /// A numeric level (actual units).
    Num(f64),
    /// A categorical level.
    Label(String),
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Level::Num(v) => write!(f, "{v}"),
            Level::Label(s) => f.write_str(s),
        }
    }
}

/// How a factor was coded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum FactorCoding {
    /// Numeric: coded = (x − (low + high)/2) / ((high − low)/2).
    Numeric {
        /// Factor name.
        name: String,
        /// Minimum in the data (coded −1).
        low: f64,
        /// Maximum in the data (coded +1).
        high: f64,
        /// Number of distinct levels in the data.
        levels: usize,
    },
    /// Label: levels sorted; two levels → −1/+1; L > 2 levels → L − 1 effect-coded (sum-to-zero) columns,
    /// column j = +1 at `levels[j]`, −1 at the last level, 0 otherwise.
    Label {
        /// Factor name.
        name: String,
        /// Sorted levels.
        levels: Vec<String>,
    },
}

impl FactorCoding {
    /// Factor name.
    pub fn name(&self) -> &str {
        match self {
            FactorCoding::Numeric { name, .. } | FactorCoding::Label { name, .. } => name,
        }
    }
}

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

/// A response surface fitted on a designed experiment (kind `response_surface`): terms and coefficients
/// in actual units, their covariance and the factor ranges, so a consumer (e.g. the MPC's force preview)
/// can evaluate it without knowing how the factors were coded. Built by `millcomp_doe::response_surface`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseSurface {
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

impl ResponseSurface {
    /// Kinds this type reads.
    pub const KINDS: [&'static str; 1] = ["response_surface"];

    fn term_row(&self, point: &[(&str, Level)]) -> Result<Vec<f64>> {
        for (name, _) in point {
            if !self.factors.iter().any(|f| f.name() == *name) {
                return Err(ModelError::Prediction {
                    factor: name.to_string(),
                    reason: format!(
                        "not a factor of the model (factors: {})",
                        self.factors
                            .iter()
                            .map(|f| f.name())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                });
            }
        }
        let get = |name: &str| -> Result<&Level> {
            point
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v)
                .ok_or_else(|| ModelError::Prediction {
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
                        return Err(ModelError::Prediction {
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
                    return Err(ModelError::Prediction {
                        factor: name.clone(),
                        reason: "a term uses this label factor, but the model does not list it"
                            .into(),
                    });
                };
                let given = match get(name)? {
                    Level::Label(s) => s.clone(),
                    Level::Num(x) => format!("{x}"),
                };
                if !levels.contains(&given) {
                    return Err(ModelError::Prediction {
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

    /// Predicted mean and its standard error at a point given as (factor, level) pairs; label factors
    /// take [`Level::Label`].
    ///
    /// ```
    /// use millcomp_models::{Level, ResponseSurface};
    /// // f = 1 + 0.5·[material = S7] on two materials, residual variance of the mean 0.01 at each level
    /// let m: ResponseSurface = toml::from_str(r#"
    /// response = "f"
    /// model = "material"
    /// n_runs = 4
    /// residual_df = 2
    /// r_squared = 0.9
    /// factors = [{ kind = "label", name = "material", levels = ["6061", "S7"] }]
    /// terms = [{ name = "intercept", coef = 1.0 },
    ///          { name = "material[S7]", coef = 0.5, labels = { material = "S7" } }]
    /// covariance = [[0.01, 0.0], [0.0, 0.01]]
    /// coded = { terms = ["intercept", "material"], coef = [1.0, 0.5] }
    /// "#).unwrap();
    /// let p = m.predict_levels(&[("material", Level::Label("S7".into()))]).unwrap();
    /// // S7 is the +1 level: 1 + 0.5, SE = √(0.01 + 0.01)
    /// assert!((p.mean - 1.5).abs() < 1e-12);
    /// assert!((p.std_err.unwrap() - 0.02f64.sqrt()).abs() < 1e-12);
    /// let q = m.predict_levels(&[("material", Level::Label("6061".into()))]).unwrap();
    /// assert!((q.mean - 0.5).abs() < 1e-12); // the −1 level
    /// assert!(m.predict_levels(&[("material", Level::Label("C45".into()))]).is_err());
    /// ```
    ///
    /// # Errors
    /// [`ModelError::Prediction`] naming a factor that is not the model's, a missing one, a numeric value
    /// that is not finite, or a label level the model does not know.
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
    /// use millcomp_models::ResponseSurface;
    /// // f = −1 + 0.01·d + 0.1·u, fitted on d ∈ [100, 200], u ∈ [10, 20]
    /// let m: ResponseSurface = toml::from_str(r#"
    /// response = "f"
    /// model = "d + u"
    /// n_runs = 4
    /// residual_df = 1
    /// r_squared = 1.0
    /// factors = [{ kind = "numeric", name = "d", low = 100.0, high = 200.0, levels = 2 },
    ///            { kind = "numeric", name = "u", low = 10.0, high = 20.0, levels = 2 }]
    /// terms = [{ name = "intercept", coef = -1.0 },
    ///          { name = "d", coef = 0.01, powers = { d = 1 } },
    ///          { name = "u", coef = 0.1, powers = { u = 1 } }]
    /// coded = { terms = ["intercept", "d", "u"], coef = [2.0, 0.5, 0.5] }
    /// "#).unwrap();
    /// assert!((m.predict(&[("d", 150.0), ("u", 15.0)]).unwrap() - 2.0).abs() < 1e-12);
    /// // outside the fitted range the prediction is an extrapolation
    /// assert_eq!(m.out_of_range(&[("d", 250.0), ("u", 15.0)]), vec!["d".to_string()]);
    /// ```
    ///
    /// # Errors
    /// [`ModelError::Prediction`] naming a factor that is not the model's, missing, or not finite.
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
