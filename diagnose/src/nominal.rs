//! The nominal model of a session, point by point: the noise-free prediction of every measured
//! point, everything an effect needs to evaluate its offset there, and how the prediction moves
//! when the nominal model's uncertain parameters move ([`crate::nuisance`]).
//!
//! The session's plan is played out once, by sim ([`Session::contexts`]: its time line, groove
//! start times, engaged length, static deflection and peak-force table — the same contexts
//! `simulate_session` adds its effects on). The nominal prediction is sim's nominal depth plus the
//! offsets of the effects listed (enabled) in the session file, whose parameters are fixed.
//!
//! For the nuisance step each point also carries the slope of the peak z-force with depth and with
//! wearland and their cross derivative (central differences of sim's force model at the point's
//! actual depth, ± [`FORCE_STEP_UM`] and ± [`WEARLAND_STEP_UM`]), so that the static deflection can be re-solved for another force scale,
//! stiffness or wearland without re-running sim ([`crate::nuisance`]).

use millcomp_sim::effects::{Effect, EffectContext};
use millcomp_sim::force::CutConditions;
use millcomp_sim::session::{GroovePoint, PointContext, Session, SessionContexts};

use crate::error::{DiagnoseError, Result};

/// Depth step (µm) of the force slope: sim's peak-force table has a 0.25 µm grid, so ± 0.25 µm
/// spans two of its cells.
pub const FORCE_STEP_UM: f64 = 0.25;
/// Wearland step (µm) of the force's derivatives in wearland: half the ±2 µm a wearland reading
/// may be off.
pub const WEARLAND_STEP_UM: f64 = 1.0;

/// Per-point quantities of the nominal static deflection `δ = c·F(d_cmd − δ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeflectionPoint {
    /// `cos²α / k_axial` (µm/N).
    pub axial_compliance_um_per_n: f64,
    /// `sin²α / k_radial` (µm/N).
    pub radial_compliance_um_per_n: f64,
    /// Peak z-force at the nominal actual depth (N).
    pub force_n: f64,
    /// dF/d(depth) at the nominal actual depth (N/µm).
    pub dforce_ddepth_n_per_um: f64,
    /// dF/d(wearland) at the nominal actual depth (N/µm).
    pub dforce_dwearland_n_per_um: f64,
    /// d²F/(d depth d wearland) at the nominal actual depth (N/µm²): the force's slope with
    /// depth grows with the wearland (by 40 % from 6 to 10 µm at 30° tilt; without it ±2 µm of
    /// wearland would leave 0.08 µm of depth error).
    pub d2force_ddepth_dwearland_n_per_um2: f64,
    /// Nominal static deflection (µm) = programmed − nominal depth.
    pub deflection_um: f64,
}

/// Facts of the session that shapes and the plan analysis read.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionFacts {
    /// Coolant events as (t, 0/1).
    pub coolant_events: Vec<(f64, f64)>,
    /// Spindle events (t, rpm).
    pub spindle_events: Vec<(f64, f64)>,
    /// Smallest machine X of the points (mm).
    pub x_start_mm: f64,
    /// Largest machine X of the points (mm).
    pub x_end_mm: f64,
    /// Engaged length at the last point (mm).
    pub end_mm: f64,
    /// Largest nominal peak z-force of the points (N).
    pub max_force_n: f64,
    /// Points of each groove: `(groove_id, first index, end index)` in plan order.
    pub grooves: Vec<(i64, usize, usize)>,
}

impl SessionFacts {
    /// Width of the X range (mm), at least 1 µm.
    pub fn x_span_mm(&self) -> f64 {
        (self.x_end_mm - self.x_start_mm).max(1e-3)
    }

    /// Position `x_mm` as a fraction of the X range, clamped to 0 … 1.
    pub fn along_x(&self, x_mm: f64) -> f64 {
        ((x_mm - self.x_start_mm) / self.x_span_mm()).clamp(0.0, 1.0)
    }
}

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
    /// The static deflection's ingredients at every point.
    pub deflection: Vec<DeflectionPoint>,
    /// Facts the shapes read.
    pub facts: SessionFacts,
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
        let deflection = deflection_points(session, &contexts.points)?;
        let facts = facts(&contexts);
        Ok(SessionModel {
            name: session.name.clone(),
            contexts,
            known_effects,
            base_um,
            deflection,
            facts,
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

    /// Number of grooves with measured points.
    pub fn n_grooves(&self) -> usize {
        self.facts.grooves.len()
    }

    /// The planned points as measured-groove points with `depth_meas_um` = base prediction +
    /// `extra_um` (missing entries count as 0; e.g. hidden offsets plus noise for synthetic data).
    pub fn points_with(&self, extra_um: &[f64]) -> Vec<GroovePoint> {
        self.points()
            .iter()
            .zip(&self.base_um)
            .zip(extra_um.iter().chain(std::iter::repeat(&0.0)))
            .map(|((p, b), e)| p.measured(b + e))
            .collect()
    }
}

fn facts(c: &SessionContexts) -> SessionFacts {
    let pts = &c.points;
    let mut grooves: Vec<(i64, usize, usize)> = Vec::new();
    for (i, p) in pts.iter().enumerate() {
        match grooves.last_mut() {
            Some(g) if g.0 == p.groove_id => g.2 = i + 1,
            _ => grooves.push((p.groove_id, i, i + 1)),
        }
    }
    SessionFacts {
        coolant_events: c
            .timeline
            .coolant_events
            .iter()
            .map(|(t, on)| (*t, if *on { 1.0 } else { 0.0 }))
            .collect(),
        spindle_events: c.timeline.spindle_events.clone(),
        x_start_mm: pts
            .iter()
            .map(|p| p.machine_x_mm)
            .fold(f64::INFINITY, f64::min),
        x_end_mm: pts
            .iter()
            .map(|p| p.machine_x_mm)
            .fold(f64::NEG_INFINITY, f64::max),
        end_mm: pts.iter().map(|p| p.cut_length_mm).fold(0.0, f64::max),
        max_force_n: pts.iter().map(|p| p.force_z_n).fold(0.0, f64::max),
        grooves,
    }
}

/// The deflection's ingredients at every point: compliance split, force and its slopes.
fn deflection_points(session: &Session, pts: &[PointContext]) -> Result<Vec<DeflectionPoint>> {
    let err = |source| DiagnoseError::Session {
        what: "force model",
        source,
    };
    let model = session.force_model().map_err(err)?;
    let stiffness = session.stiffness().map_err(err)?;
    let wl = model.tool.wearland_um;
    let h = FORCE_STEP_UM;
    // a wearland below the step is differenced forwards (the flank needs WL ≥ 0)
    let hw = WEARLAND_STEP_UM;
    let w0 = wl.max(hw);
    let worn = |v: f64| model.with_param("wearland_um", v).map_err(err);
    let (worn_minus, worn_plus) = (worn(w0 - hw)?, worn(w0 + hw)?);
    // the slope with depth at the nominal wearland itself
    let worn_mid = worn(wl)?;
    let radius = model.tool.radius_um;
    // points of a groove often share a depth (constant grooves): cache by conditions and depth
    let mut cache: std::collections::HashMap<[u64; 4], (f64, f64, f64)> = Default::default();
    pts.iter()
        .map(|p| {
            let a = p.tilt_deg.to_radians();
            let cond = |d: f64| CutConditions {
                depth_um: d.clamp(0.0, radius),
                upfeed_um: p.upfeed_um,
                speed_rpm: p.speed_rpm,
                tilt_deg: p.tilt_deg,
            };
            let d = p.depth_actual_um;
            let key = [
                p.upfeed_um.to_bits(),
                p.speed_rpm.to_bits(),
                p.tilt_deg.to_bits(),
                d.to_bits(),
            ];
            let (fd, fw, fdw) = match cache.get(&key) {
                Some(v) => *v,
                None => {
                    let (lo, hi) = ((d - h).max(0.0), (d + h).min(radius));
                    let slope = |m: &millcomp_sim::force::BallEndForceModel| -> Result<f64> {
                        Ok(if hi > lo {
                            (m.peak_z_force_n(&cond(hi)).map_err(err)?
                                - m.peak_z_force_n(&cond(lo)).map_err(err)?)
                                / (hi - lo)
                        } else {
                            0.0
                        })
                    };
                    let fd = slope(&worn_mid)?;
                    let fdw = (slope(&worn_plus)? - slope(&worn_minus)?) / (2.0 * hw);
                    let fw = (worn_plus.peak_z_force_n(&cond(d)).map_err(err)?
                        - worn_minus.peak_z_force_n(&cond(d)).map_err(err)?)
                        / (2.0 * hw);
                    cache.insert(key, (fd, fw, fdw));
                    (fd, fw, fdw)
                }
            };
            Ok(DeflectionPoint {
                axial_compliance_um_per_n: a.cos().powi(2) / stiffness.axial_n_per_um,
                radial_compliance_um_per_n: a.sin().powi(2) / stiffness.radial_n_per_um,
                force_n: p.force_z_n,
                dforce_ddepth_n_per_um: fd,
                dforce_dwearland_n_per_um: fw,
                d2force_ddepth_dwearland_n_per_um2: fdw,
                deflection_um: p.depth_cmd_um - p.depth_nominal_um,
            })
        })
        .collect()
}
