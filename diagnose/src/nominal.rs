//! The nominal model of a session, point by point: the noise-free prediction of every measured
//! point and everything an effect needs to evaluate its offset there.
//!
//! The session's plan is played out once, by sim ([`Session::contexts`]: its time line, groove
//! start times, engaged length, static deflection and peak-force table — the same contexts
//! `simulate_session` adds its effects on). The nominal prediction is sim's nominal depth plus the
//! offsets of the effects listed (enabled) in the session file, whose parameters are fixed.

use millcomp_sim::effects::{Effect, EffectContext};
use millcomp_sim::session::{GroovePoint, PointContext, Session, SessionContexts};

use crate::error::{DiagnoseError, Result};

/// A session's nominal model, ready for effect evaluation at every planned point.
#[derive(Debug, Clone)]
pub struct SessionModel {
    /// Session name.
    pub name: String,
    /// sim's nominal context of every planned point, in plan order (the order of
    /// `simulate_session`), with the session's time line.
    pub contexts: SessionContexts,
    /// Effects listed (enabled) in the session file: part of the nominal model, parameters fixed.
    pub known_effects: Vec<Box<dyn Effect>>,
    /// Base prediction (µm): nominal depth + the known effects' offsets.
    pub base_um: Vec<f64>,
    /// The session (as read).
    pub session: Session,
}

impl SessionModel {
    /// Plays the plan of `session` out (sim) and builds the nominal model.
    ///
    /// # Errors
    /// [`DiagnoseError::Session`] when sim rejects the session (its plan, force model or effects).
    pub fn new(session: &Session) -> Result<Self> {
        let contexts = session
            .contexts()
            .map_err(|source| DiagnoseError::Session {
                what: "plan",
                source,
            })?;
        let known_effects = session.effects().map_err(|source| DiagnoseError::Session {
            what: "effects",
            source,
        })?;
        let base_um = (0..contexts.len())
            .map(|i| {
                let ctx = contexts.effect_context(i);
                contexts.points[i].depth_nominal_um
                    + known_effects
                        .iter()
                        .map(|e| e.depth_offset_um(&ctx))
                        .sum::<f64>()
            })
            .collect();
        Ok(SessionModel {
            name: session.name.clone(),
            contexts,
            known_effects,
            base_um,
            session: session.clone(),
        })
    }

    /// The planned points (sim's nominal contexts), in plan order.
    pub fn points(&self) -> &[PointContext] {
        &self.contexts.points
    }

    /// Number of planned points.
    pub fn len(&self) -> usize {
        self.contexts.len()
    }

    /// Whether the plan has no measured points.
    pub fn is_empty(&self) -> bool {
        self.contexts.is_empty()
    }

    /// The effect context of point `i` (panics if `i` is out of range: an internal index).
    pub fn ctx(&self, i: usize) -> EffectContext<'_> {
        self.contexts.effect_context(i)
    }

    /// Offsets (µm) of `effect` at every point.
    pub fn offsets_um(&self, effect: &dyn Effect) -> Vec<f64> {
        self.contexts.offsets_um(effect)
    }

    /// The planned points as measured-groove points with `depth_meas_um` = base prediction +
    /// `extra_um` (missing entries count as 0; e.g. hidden offsets plus noise for synthetic data).
    pub fn points_with(&self, extra_um: &[f64]) -> Vec<GroovePoint> {
        self.points()
            .iter()
            .zip(&self.base_um)
            .zip(extra_um.iter().chain(std::iter::repeat(&0.0)))
            .map(|((p, b), e)| GroovePoint {
                groove_id: p.groove_id,
                t_s: p.t_s,
                x_mm: p.x_mm,
                cut_length_mm: p.cut_length_mm,
                speed_rpm: p.speed_rpm,
                feed_mm_min: p.feed_mm_min,
                upfeed_um: p.upfeed_um,
                tilt_deg: p.tilt_deg,
                coolant_on: u8::from(p.coolant_on),
                depth_cmd_um: p.depth_cmd_um,
                depth_meas_um: b + e,
                spindle_temp_c: None,
            })
            .collect()
    }
}
