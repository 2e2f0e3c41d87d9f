//! Force predictors for the controllers' preview: what peak z-force the planned cut will produce.
//!
//! Two kinds, chosen per scenario (`closedloop/SCENARIOS.md`):
//! - **mechanistic** — the ball-end force model of `millcomp-sim` with the controllers' parameters (the
//!   perturbed truth, or a model identified by `millcomp identify force`);
//! - **response surface** — a polynomial in the process parameters fitted to measured peak forces by
//!   `millcomp doe analyze --save model.toml` (e.g. Table 3-3's `max_fz_n` over depth, speed and upfeed).
//!   Its factor names must be process parameters the plan knows: `depth_um`, `upfeed_um`, `speed_rpm`, `tilt_deg`; its response must be the per-revolution peak z-force on
//!   the workpiece in N. Points outside the fitted ranges are extrapolated and counted; a negative
//!   prediction (a polynomial below its data) is taken as 0 N.

use millcomp_models::FactorCoding;
use millcomp_sim::force::CutConditions;

use crate::identified::IdentifiedForceModel;

use crate::error::{MpcError, invalid};

/// Process parameters a response surface may use.
pub const PROCESS_FACTORS: [&str; 4] = ["depth_um", "upfeed_um", "speed_rpm", "tilt_deg"];

/// A response-surface force predictor loaded from a `doe analyze --save` model.
#[derive(Debug, Clone)]
pub struct ResponseSurface {
    model: millcomp_models::ResponseSurface,
    path: String,
    factors: Vec<String>,
}

impl ResponseSurface {
    /// Wrap an in-memory model (`path` is only used in messages).
    pub fn new(model: millcomp_models::ResponseSurface, path: &str) -> Result<Self, MpcError> {
        let mut factors = Vec::new();
        for f in &model.factors {
            match f {
                FactorCoding::Numeric { name, .. } if PROCESS_FACTORS.contains(&name.as_str()) => {
                    factors.push(name.clone())
                }
                other => {
                    return Err(invalid(
                        "control.force_response_surface",
                        format!("{path}: factor `{}`", other.name()),
                        format!(
                            "numeric factors named {} (the plan knows only these)",
                            PROCESS_FACTORS.join(", ")
                        ),
                    ));
                }
            }
        }
        Ok(Self {
            model,
            path: path.to_string(),
            factors,
        })
    }

    /// The model's response name.
    pub fn response(&self) -> &str {
        &self.model.response
    }

    /// The point (factor, value) for cut conditions.
    fn point(&self, c: &CutConditions) -> Vec<(&str, f64)> {
        self.factors
            .iter()
            .map(|n| {
                let v = match n.as_str() {
                    "depth_um" => c.depth_um,
                    "upfeed_um" => c.upfeed_um,
                    "speed_rpm" => c.speed_rpm,
                    _ => c.tilt_deg,
                };
                (n.as_str(), v)
            })
            .collect()
    }

    /// Whether `c` lies outside the ranges the model was fitted on.
    pub fn extrapolates(&self, c: &CutConditions) -> bool {
        !self.model.out_of_range(&self.point(c)).is_empty()
    }

    /// Predicted peak z-force (N), at least 0.
    pub fn peak_z_force_n(&self, c: &CutConditions) -> Result<f64, MpcError> {
        let f = self
            .model
            .predict(&self.point(c))
            .map_err(|source| MpcError::Predictor {
                path: self.path.clone(),
                source: Box::new(source),
            })?;
        Ok(if f.is_finite() { f.max(0.0) } else { 0.0 })
    }
}

/// The controllers' force predictor.
#[derive(Debug, Clone)]
pub enum ForcePredictor {
    /// Mechanistic ball-end model with identified parameters.
    Mechanistic(IdentifiedForceModel),
    /// Response surface from a DOE.
    ResponseSurface(ResponseSurface),
}

impl ForcePredictor {
    /// Per-revolution peak z-force (N) of a cut.
    pub fn peak_z_force_n(&self, c: &CutConditions) -> Result<f64, MpcError> {
        match self {
            ForcePredictor::Mechanistic(m) => Ok(m.model().peak_z_force_n(c)?),
            ForcePredictor::ResponseSurface(r) => r.peak_z_force_n(c),
        }
    }

    /// This predictor with every force times `factor` (a force scale identified from cut parts). Only the
    /// mechanistic model has a force scale.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (key `control.force_response_surface`) for a response surface;
    /// those of [`IdentifiedForceModel::rescaled`].
    pub fn rescaled(&self, factor: f64) -> Result<Self, MpcError> {
        match self {
            ForcePredictor::Mechanistic(m) => Ok(ForcePredictor::Mechanistic(m.rescaled(factor)?)),
            ForcePredictor::ResponseSurface(r) => Err(invalid(
                "control.force_response_surface",
                &r.path,
                "the mechanistic force model (a response surface has no force scale to update)",
            )),
        }
    }

    /// Short description for run notes.
    pub fn describe(&self) -> String {
        match self {
            ForcePredictor::Mechanistic(_) => "mechanistic ball-end force model".into(),
            ForcePredictor::ResponseSurface(r) => format!(
                "response surface `{}` from {} ({} runs, R² {:.3})",
                r.model.response, r.path, r.model.n_runs, r.model.r_squared
            ),
        }
    }

    /// The identified mechanistic model, if that is the kind.
    pub fn mechanistic(&self) -> Option<&IdentifiedForceModel> {
        match self {
            ForcePredictor::Mechanistic(m) => Some(m),
            _ => None,
        }
    }

    /// The response surface, if that is the kind.
    pub fn response_surface(&self) -> Option<&ResponseSurface> {
        match self {
            ForcePredictor::ResponseSurface(r) => Some(r),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze, response_surface};

    fn surface(factor: &str) -> millcomp_models::ResponseSurface {
        let col = |v: &[f64]| Values::F64(v.to_vec());
        // f = 0.02·d + 0.05·u exactly on a 2² design
        let input = AnalysisInput {
            factors: vec![
                (factor.into(), col(&[20., 80., 20., 80.])),
                ("upfeed_um".into(), col(&[10., 10., 20., 20.])),
            ],
            response_name: "max_fz_n".into(),
            response: col(&[0.9, 2.1, 1.4, 2.6]),
            model: ModelSpec::Main,
        };
        response_surface(&analyze(&input).unwrap()).unwrap()
    }

    #[test]
    fn predicts_from_plan_conditions() {
        let r = ResponseSurface::new(surface("depth_um"), "<test>").unwrap();
        let c = CutConditions {
            depth_um: 50.0,
            upfeed_um: 15.0,
            speed_rpm: 10_000.0,
            tilt_deg: 20.0,
        };
        // 0.02·50 + 0.05·15 = 1.75 N (the generating plane above)
        assert!((r.peak_z_force_n(&c).unwrap() - 1.75).abs() < 1e-9);
        assert!(!r.extrapolates(&c));
        let shallow = CutConditions {
            depth_um: 0.0,
            upfeed_um: 0.0,
            ..c
        };
        assert!(r.extrapolates(&shallow));
        // the plane's intercept is 0 N up to round-off
        assert!(r.peak_z_force_n(&shallow).unwrap().abs() < 1e-12);
        let negative = CutConditions {
            depth_um: -50.0,
            ..shallow
        };
        assert_eq!(r.peak_z_force_n(&negative).unwrap(), 0.0);
    }

    #[test]
    fn unknown_factor_is_named() {
        let e = ResponseSurface::new(surface("coolant_flow"), "m.toml").unwrap_err();
        let m = e.to_string();
        assert!(m.contains("coolant_flow") && m.contains("depth_um"), "{m}");
    }
}
