//! The nominal model of a session, point by point: the noise-free prediction of every measured point
//! and everything an effect needs to evaluate its offset there ([`EffectContext`]).
//!
//! `millcomp_sim::session::simulate_session` computes these contexts internally but does not return
//! them, so [`SessionModel::new`] rebuilds them from public sim API (a request to expose them is in
//! `/tmp/team/requests-to-sim.md`):
//! * the nominal prediction is `simulate_session` of the session with its effects removed;
//! * the coolant and spindle time lines replay the plan exactly as `simulate_session` does
//!   (sim/SESSION.md "Semantics");
//! * the actual depth is `d_act = max(nominal, 0)`, the peak z-force `Fz(d_act)` from sim's
//!   `peak_z_force_n` interpolated on sim's 0.25 µm table grid exactly as `simulate_session` does
//!   (not `δz/c_z`: at the start of a ramp sim's fixed-point iteration for δz need not converge);
//! * the chip force per µm² is `scale·µ·Kc·cos(φ/2)` as in sim.
//!
//! The test `contexts_reproduce_simulate_session` checks that nominal + Σ effect offsets over these
//! contexts equals `simulate_session` with all seven effects switched on to 1e-9 µm, so a change in
//! sim's semantics cannot go unnoticed.

use millcomp_sim::effects::{Effect, EffectContext};
use millcomp_sim::force::CutConditions;
use millcomp_sim::session::{
    GroovePoint, GrooveSpec, PlanItem, Session, SimOptions, simulate_session,
};

use crate::error::{IdentifyError, Result};

/// Everything known about one planned point before any effect is added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointContext {
    /// Groove index (0-based, grooves only).
    pub groove_id: i64,
    /// Session clock when the point is cut (s).
    pub t_s: f64,
    /// Position along the groove (mm).
    pub x_mm: f64,
    /// Machine X of the point (mm) = groove `x_offset_mm` + `x_mm`.
    pub machine_x_mm: f64,
    /// Cumulative engaged length of the tool (mm).
    pub cut_length_mm: f64,
    /// Spindle speed (rpm).
    pub spindle_rpm: f64,
    /// Feed rate (mm/min).
    pub feed_mm_min: f64,
    /// Upfeed (µm/rev).
    pub upfeed_um: f64,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Coolant flowing at this point.
    pub coolant_on: bool,
    /// Programmed depth (µm).
    pub depth_cmd_um: f64,
    /// Nominal noise-free depth prediction without any effect (µm).
    pub nominal_um: f64,
    /// Nominal actual depth `max(nominal, 0)` (µm).
    pub depth_actual_um: f64,
    /// Nominal per-revolution peak z-force (N).
    pub force_z_n: f64,
    /// z-force per µm² of extra chip on the peak flute (N/µm²).
    pub chip_force_z_n_per_um2: f64,
    /// z-compliance of the tilted tool (µm/N).
    pub z_compliance_um_per_n: f64,
    n_coolant: usize,
    n_spindle: usize,
}

/// A session's nominal model, ready for effect evaluation at every planned point.
#[derive(Debug, Clone)]
pub struct SessionModel {
    /// Session name.
    pub name: String,
    /// One context per planned point, in plan order (the order of `simulate_session`).
    pub points: Vec<PointContext>,
    /// Coolant switch history `(t_s, on)`.
    pub coolant_events: Vec<(f64, bool)>,
    /// Spindle speed history `(t_s, rpm)`.
    pub spindle_events: Vec<(f64, f64)>,
    /// Effects listed (enabled) in the session file: part of the nominal model, parameters fixed.
    pub known_effects: Vec<Box<dyn Effect>>,
    /// Base prediction (µm): nominal + the known effects' offsets.
    pub base_um: Vec<f64>,
    /// The session (as read).
    pub session: Session,
}

/// Depth grid of sim's peak-force table (µm), sim/src/session.rs `PeakTable::new`.
const PEAK_TABLE_STEP_UM: f64 = 0.25;

fn sim_err(what: &str, e: impl std::fmt::Display) -> IdentifyError {
    IdentifyError::ModelEvaluation {
        model: format!("session ({what})"),
        cause: e.to_string(),
    }
}

/// Coolant switch events `(t_s, on)` and spindle speed events `(t_s, rpm)`.
pub type Timeline = (Vec<(f64, bool)>, Vec<(f64, f64)>);

/// Coolant and spindle event time lines of a plan, replayed as `simulate_session` does.
pub fn timeline(session: &Session) -> Timeline {
    let mut coolant_events: Vec<(f64, bool)> = Vec::new();
    let mut spindle_events: Vec<(f64, f64)> = Vec::new();
    let mut t = 0.0f64;
    let mut coolant = false;
    for item in &session.plan {
        match item {
            PlanItem::Groove(g) => {
                let t0 = g.start_s.unwrap_or(t).max(t);
                if let Some(c) = g.coolant {
                    if c != coolant || coolant_events.is_empty() {
                        coolant_events.push((t0, c));
                        coolant = c;
                    }
                }
                spindle_events.push((t0, g.spindle_rpm));
                t = t0 + g.duration_s();
            }
            PlanItem::Pause(p) => {
                if let Some(c) = p.coolant {
                    if c != coolant || coolant_events.is_empty() {
                        coolant_events.push((t, c));
                        coolant = c;
                    }
                }
                spindle_events.push((t, p.spindle_rpm));
                t += p.duration_s;
            }
        }
    }
    (coolant_events, spindle_events)
}

impl SessionModel {
    /// Simulates the nominal model of `session` and builds the per-point contexts.
    pub fn new(session: &Session) -> Result<Self> {
        let mut nominal_session = session.clone();
        nominal_session.effects.clear();
        let nominal = simulate_session(&nominal_session, &SimOptions::default())
            .map_err(|e| sim_err("simulate", e))?;
        let model = session
            .force_model()
            .map_err(|e| sim_err("force model", e))?;
        let stiffness = session.stiffness().map_err(|e| sim_err("stiffness", e))?;
        let known_effects = session.effects().map_err(|e| sim_err("effects", e))?;
        let grooves: Vec<&GrooveSpec> = session
            .plan
            .iter()
            .filter_map(|i| match i {
                PlanItem::Groove(g) => Some(g),
                PlanItem::Pause(_) => None,
            })
            .collect();
        let (coolant_events, spindle_events) = timeline(session);
        let kc = model.specific_cutting_pressure_mpa() * 1e-6;
        let mut points = Vec::with_capacity(nominal.len());
        for p in &nominal {
            let g = usize::try_from(p.groove_id)
                .ok()
                .and_then(|i| grooves.get(i))
                .ok_or_else(|| {
                    sim_err("plan", format!("groove {} not in the plan", p.groove_id))
                })?;
            let compliance = stiffness
                .z_compliance_um_per_n(g.tilt_deg)
                .map_err(|e| sim_err("stiffness", e))?;
            let d_act = p.depth_meas_um.max(0.0);
            // sim's peak-force table: peak_z_force_n on a 0.25 µm depth grid, linearly
            // interpolated (sim/src/session.rs `PeakTable`); evaluated at the same d_act as sim
            // (which need not be a converged fixed point at the start of a ramp)
            let base = CutConditions {
                depth_um: 0.0,
                upfeed_um_per_rev: p.upfeed_um,
                speed_rpm: p.spindle_rpm,
                tilt_deg: p.tilt_deg,
            };
            let peak = |d: f64| -> Result<f64> {
                let mut c = base;
                c.depth_um = d.min(model.tool.radius_um);
                model.peak_z_force_n(&c).map_err(|e| sim_err("force", e))
            };
            let xg = d_act / PEAK_TABLE_STEP_UM;
            let k = xg.floor();
            let w = xg - k;
            let force_z_n = if w == 0.0 {
                peak(k * PEAK_TABLE_STEP_UM)?
            } else {
                peak(k * PEAK_TABLE_STEP_UM)? * (1.0 - w)
                    + peak((k + 1.0) * PEAK_TABLE_STEP_UM)? * w
            };
            let phi = model.contact_angle_rad(d_act);
            points.push(PointContext {
                groove_id: p.groove_id,
                t_s: p.t_s,
                x_mm: p.x_mm,
                machine_x_mm: g.x_offset_mm + p.x_mm,
                cut_length_mm: p.cut_length_mm,
                spindle_rpm: p.spindle_rpm,
                feed_mm_min: p.feed_mm_min,
                upfeed_um: p.upfeed_um,
                tilt_deg: p.tilt_deg,
                coolant_on: p.coolant_on != 0,
                depth_cmd_um: p.depth_cmd_um,
                nominal_um: p.depth_meas_um,
                depth_actual_um: d_act,
                force_z_n,
                chip_force_z_n_per_um2: model.params.force_scale
                    * model.material.mu_rake
                    * kc
                    * (0.5 * phi).cos(),
                z_compliance_um_per_n: compliance,
                n_coolant: coolant_events.partition_point(|e| e.0 <= p.t_s),
                n_spindle: spindle_events.partition_point(|e| e.0 <= p.t_s),
            });
        }
        let mut sm = SessionModel {
            name: session.name.clone(),
            points,
            coolant_events,
            spindle_events,
            known_effects,
            base_um: Vec::new(),
            session: session.clone(),
        };
        sm.base_um = (0..sm.points.len())
            .map(|i| {
                let ctx = sm.ctx(i);
                sm.points[i].nominal_um
                    + sm.known_effects
                        .iter()
                        .map(|e| e.depth_offset_um(&ctx))
                        .sum::<f64>()
            })
            .collect();
        Ok(sm)
    }

    /// Number of planned points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the plan has no measured points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The effect context of point `i` (panics if `i` is out of range: an internal index).
    pub fn ctx(&self, i: usize) -> EffectContext<'_> {
        let p = &self.points[i];
        EffectContext {
            t_s: p.t_s,
            x_mm: p.x_mm,
            machine_x_mm: p.machine_x_mm,
            cut_length_mm: p.cut_length_mm,
            spindle_rpm: p.spindle_rpm,
            tilt_deg: p.tilt_deg,
            upfeed_um: p.upfeed_um,
            depth_cmd_um: p.depth_cmd_um,
            depth_actual_um: p.depth_actual_um,
            force_z_n: p.force_z_n,
            chip_force_z_n_per_um2: p.chip_force_z_n_per_um2,
            z_compliance_um_per_n: p.z_compliance_um_per_n,
            coolant_events: &self.coolant_events[..p.n_coolant],
            spindle_events: &self.spindle_events[..p.n_spindle],
        }
    }

    /// Offsets (µm) of `effect` at every point.
    pub fn offsets_um(&self, effect: &dyn Effect) -> Vec<f64> {
        (0..self.len())
            .map(|i| effect.depth_offset_um(&self.ctx(i)))
            .collect()
    }

    /// The planned points as measured-groove rows with `depth_meas_um` = base prediction + `extra_um`
    /// (same length as the plan; e.g. hidden offsets plus noise for synthetic data).
    pub fn points_with(&self, extra_um: &[f64]) -> Vec<GroovePoint> {
        self.points
            .iter()
            .zip(&self.base_um)
            .zip(extra_um.iter().chain(std::iter::repeat(&0.0)))
            .map(|((p, b), e)| GroovePoint {
                groove_id: p.groove_id,
                t_s: p.t_s,
                x_mm: p.x_mm,
                cut_length_mm: p.cut_length_mm,
                spindle_rpm: p.spindle_rpm,
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

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_sim::effects::EFFECT_NAMES;
    use millcomp_sim::session::EffectSpec;

    #[test]
    fn contexts_reproduce_simulate_session() {
        let mut s = crate::diagnose::synthetic::base_session("t", "test");
        let truth = simulate_session(&s, &SimOptions::default()).unwrap();
        let sm0 = SessionModel::new(&s).unwrap();
        for (a, b) in truth.iter().zip(&sm0.base_um) {
            assert!((a.depth_meas_um - b).abs() < 1e-12);
        }
        s.effects = EFFECT_NAMES
            .iter()
            .map(|n| EffectSpec {
                name: n.to_string(),
                enabled: true,
                params: Default::default(),
            })
            .collect();
        let truth = simulate_session(&s, &SimOptions::default()).unwrap();
        let sm = SessionModel::new(&s).unwrap();
        assert_eq!(truth.len(), sm.len());
        let mut worst = 0.0f64;
        for (i, p) in truth.iter().enumerate() {
            worst = worst.max((p.depth_meas_um - sm.base_um[i]).abs());
            assert_eq!(p.groove_id, sm.points[i].groove_id);
            assert_eq!(p.coolant_on != 0, sm.points[i].coolant_on);
        }
        // 1e-9 µm: the only difference is sim's fixed-point tolerance 1e-10 µm on δz, which enters
        // machine_compliance through Fz = δz/c_z (c_z ≈ 2 µm/N) — far below the 0.1 µm noise.
        assert!(worst < 1e-9, "worst difference {worst} µm");
    }
}
