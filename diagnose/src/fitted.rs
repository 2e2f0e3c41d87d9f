//! A named effect as fitted, to be used beyond the session it was diagnosed on: its family, shape and
//! final parameters, and the facts of the diagnosed session its shape is scaled by (the machine-X range,
//! the engaged length at the end, the largest force) — so that the same curve can be evaluated at the
//! points of another plan: a controller's program, a next session. Saved in the common model-file format
//! as kind [`FittedEffect::KIND`].
//!
//! Shapes in machine X (`slideway_straightness`, the compliance along X), engaged length (`tool_wear`),
//! force (`machine_compliance`) and depth or speed (`flute_runout`) evaluate anywhere on those drivers
//! (outside the diagnosed X range a shape in X holds its value at the nearer end). Shapes in the coolant
//! or spindle history evaluate on the evaluation plan's own history with the fitted time constants.
//!
//! ```
//! use millcomp_diagnose::{DiagnoseOptions, FittedEffect, Measured, SessionModel, diagnose};
//! let case = millcomp_synthetic::cases()
//!     .into_iter()
//!     .find(|c| c.name == "slideway_straightness")
//!     .unwrap();
//! let data = millcomp_synthetic::generate(&case).unwrap();
//! let rep = diagnose(&data.session, &Measured::new("s.csv", data.points), &DiagnoseOptions::default())
//!     .unwrap();
//! let sm = SessionModel::new(&data.session).unwrap();
//! let fitted = FittedEffect::from_report(&rep, &sm).unwrap();
//! assert_eq!(fitted[0].effect, "slideway_straightness");
//! // on the session it was fitted on, it is the report's term
//! let o = fitted[0].offsets_um(&sm).unwrap();
//! assert_eq!(o.len(), sm.len());
//! assert!(o.iter().any(|v| v.abs() > 1.0));
//! ```

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::{DiagnoseError, Result};
use crate::families::{Family, Shape, standard};
use crate::nominal::{SessionFacts, SessionModel};
use crate::report::DiagnoseReport;

/// One named effect as fitted (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedEffect {
    /// The effect (family) name.
    pub effect: String,
    /// The shape chosen within the family.
    pub shape: String,
    /// The final joint estimates, by parameter name (with unit).
    pub params: BTreeMap<String, f64>,
    /// Their 95 % intervals, where the report has them.
    #[serde(default)]
    pub ci95: BTreeMap<String, [f64; 2]>,
    /// Smallest machine X of the diagnosed session's points (mm).
    pub x_start_mm: f64,
    /// Largest machine X of the diagnosed session's points (mm).
    pub x_end_mm: f64,
    /// Engaged length at the diagnosed session's last point (mm).
    pub end_mm: f64,
    /// Largest nominal peak z-force of the diagnosed session's points (N).
    pub max_force_n: f64,
    /// The session it was diagnosed on.
    pub session: String,
}

impl FittedEffect {
    /// The model-file kind.
    pub const KIND: &'static str = "effect";

    /// The effects of the final model of `report`, diagnosed on the session whose nominal model is
    /// `sm` (in the order named).
    ///
    /// # Errors
    /// [`DiagnoseError::UnknownCandidate`] for a family or shape the report names that this version
    /// does not have (a report of another version).
    pub fn from_report(report: &DiagnoseReport, sm: &SessionModel) -> Result<Vec<Self>> {
        let f = &sm.facts;
        let mut out = Vec::new();
        for name in &report.named {
            let (Some(params), Some(shape)) =
                (report.final_params.get(name), report.shapes.get(name))
            else {
                continue;
            };
            let fitted = FittedEffect {
                effect: name.clone(),
                shape: shape.clone(),
                params: params.clone(),
                ci95: report.final_ci95.get(name).cloned().unwrap_or_default(),
                x_start_mm: f.x_start_mm,
                x_end_mm: f.x_end_mm,
                end_mm: f.end_mm,
                max_force_n: f.max_force_n,
                session: report.session.clone(),
            };
            fitted.family_shape()?;
            out.push(fitted);
        }
        Ok(out)
    }

    fn family_shape(&self) -> Result<(Family, Shape)> {
        let unknown = || DiagnoseError::UnknownCandidate {
            name: format!("{} ({} shape)", self.effect, self.shape),
            allowed: standard()
                .iter()
                .map(|f| f.name.to_string())
                .collect::<Vec<_>>()
                .join(", "),
        };
        let family = standard()
            .into_iter()
            .find(|f| f.name == self.effect)
            .ok_or_else(unknown)?;
        let shape = family
            .shapes
            .iter()
            .find(|s| s.name == self.shape)
            .cloned()
            .ok_or_else(unknown)?;
        Ok((family, shape))
    }

    /// The shape's parameters in its order (coefficients, then nonlinear parameters).
    fn theta(&self, shape: &Shape) -> Result<Vec<f64>> {
        shape
            .param_names()
            .into_iter()
            .map(|n| {
                self.params
                    .get(n)
                    .copied()
                    .ok_or_else(|| DiagnoseError::UnknownCandidate {
                        name: format!("{}.{n} (missing)", self.effect),
                        allowed: shape.param_names().join(", "),
                    })
            })
            .collect()
    }

    /// The effect's depth offset (µm, + = deeper) at every planned point of `sm`, the shape scaled by
    /// the diagnosed session's facts and evaluated on `sm`'s drivers (module documentation).
    ///
    /// # Errors
    /// As [`Self::from_report`]; a parameter the shape needs that the file lacks.
    pub fn offsets_um(&self, sm: &SessionModel) -> Result<Vec<f64>> {
        let (_, shape) = self.family_shape()?;
        let theta = self.theta(&shape)?;
        let facts = SessionFacts {
            x_start_mm: self.x_start_mm,
            x_end_mm: self.x_end_mm,
            end_mm: self.end_mm,
            max_force_n: self.max_force_n,
            ..sm.facts.clone()
        };
        Ok(shape.offsets_with(sm, &facts, &theta))
    }
}
