//! `doe analyze`'s request as the CLI's flags and Python's `doe.analyze` arguments give it: one place
//! that turns them into an analysis (the front ends read the table and show the result).

use super::{Analysis, AnalysisInput, Elimination, analyze, backward_eliminate};
use crate::error::{DoeError, Result};
use crate::factor::Values;
use crate::model::ModelSpec;

/// What to analyse, as text and numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyzeOptions {
    /// The response column.
    pub response: String,
    /// The factor columns (`None` or empty: every other numeric column).
    pub factors: Option<Vec<String>>,
    /// `main | 2fi | quadratic | a formula`.
    pub model: String,
    /// Significance level of backward elimination, in (0, 1).
    pub alpha: f64,
    /// Eliminate terms backwards at `alpha`.
    pub reduce: bool,
}

/// An analysis, and the elimination that led to it when one was asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyzeOutcome {
    /// The (final) analysis.
    pub analysis: Analysis,
    /// The elimination's steps (`reduce`).
    pub elimination: Option<Elimination>,
}

impl AnalyzeOptions {
    /// `response` with the defaults of `doe analyze`: main effects, α = 0.05, no elimination.
    pub fn new(response: &str) -> Self {
        Self {
            response: response.to_string(),
            factors: None,
            model: "main".to_string(),
            alpha: 0.05,
            reduce: false,
        }
    }

    /// Analyses the columns of a table `origin` names in messages.
    ///
    /// ```
    /// use millcomp_doe::{AnalyzeOptions, DoeError, Values};
    /// let col = |v: &[f64]| Values::F64(v.to_vec());
    /// let table = vec![
    ///     ("a".to_string(), col(&[-1.0, 1.0, -1.0, 1.0])),
    ///     ("b".to_string(), col(&[-1.0, -1.0, 1.0, 1.0])),
    ///     ("y".to_string(), col(&[1.0, 3.0, 2.0, 4.5])),
    /// ];
    /// let out = AnalyzeOptions::new("y").run("t.csv", &table).unwrap();
    /// assert_eq!(out.analysis.residual_df, 1);
    /// let mut o = AnalyzeOptions::new("z");
    /// let e = o.run("t.csv", &table).unwrap_err();
    /// assert_eq!(e.to_string(), "t.csv: preparing the analysis");
    /// o.alpha = 2.0;
    /// assert!(matches!(o.run("t.csv", &table), Err(DoeError::BadOption { option: "alpha", .. })));
    /// ```
    ///
    /// # Errors
    /// [`DoeError::BadOption`] for `alpha` or `model`; [`DoeError::AnalysisStep`] naming `origin` and
    /// the step (preparing, eliminating, analysing) with the cause below it.
    pub fn run(&self, origin: &str, table: &[(String, Values)]) -> Result<AnalyzeOutcome> {
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(DoeError::BadOption {
                option: "alpha",
                source: Box::new(DoeError::InvalidParameter {
                    name: "alpha",
                    value: self.alpha.to_string(),
                    allowed: "a level in (0, 1)".to_string(),
                }),
            });
        }
        let model = ModelSpec::parse(&self.model).map_err(|e| DoeError::BadOption {
            option: "model",
            source: Box::new(e),
        })?;
        let step = |step: String| {
            move |e: DoeError| DoeError::AnalysisStep {
                origin: origin.to_string(),
                step,
                source: Box::new(e),
            }
        };
        let factors = self.factors.as_deref().filter(|f| !f.is_empty());
        let input = AnalysisInput::from_table(table, &self.response, factors, model)
            .map_err(step("preparing the analysis".to_string()))?;
        if self.reduce {
            let e = backward_eliminate(&input, self.alpha)
                .map_err(step("backward elimination".to_string()))?;
            Ok(AnalyzeOutcome {
                analysis: e.analysis.clone(),
                elimination: Some(e),
            })
        } else {
            let analysis =
                analyze(&input).map_err(step(format!("analysing `{}`", self.response)))?;
            Ok(AnalyzeOutcome {
                analysis,
                elimination: None,
            })
        }
    }
}
