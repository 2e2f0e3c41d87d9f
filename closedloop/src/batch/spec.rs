//! One scenario of a batch as its factor values ([`ScenarioSpec`]), and the checks every factor
//! builder shares.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::ClosedLoopError;

/// One factor value: a number or a label.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FactorValue {
    /// A numeric level.
    Num(f64),
    /// A label (`material`, `stage`).
    Text(String),
}

impl FactorValue {
    /// Display text (numbers in their shortest round-trip form).
    pub fn text(&self) -> String {
        match self {
            FactorValue::Num(x) => format!("{x}"),
            FactorValue::Text(s) => s.clone(),
        }
    }
}

/// One scenario of a batch: its factor values (name → value, in the plan's factor order).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioSpec {
    /// 0-based scenario index in the plan.
    pub index: usize,
    /// Factor values by name.
    pub factors: BTreeMap<String, FactorValue>,
}

/// The error of a factor value the scenario cannot take.
pub(crate) fn bad(factor: &str, message: String) -> ClosedLoopError {
    ClosedLoopError::InvalidFactor {
        factor: factor.to_string(),
        message,
    }
}

pub(crate) fn num(spec: &ScenarioSpec, name: &str) -> Result<Option<f64>, ClosedLoopError> {
    match spec.factors.get(name) {
        None => Ok(None),
        Some(FactorValue::Num(x)) if x.is_finite() => Ok(Some(*x)),
        Some(v) => Err(bad(name, format!("`{}` is not a finite number", v.text()))),
    }
}
