//! Where the tool is touched off: with the stack at rest (0 V) or held at a bias, so that the tip can
//! later retract below the depth's zero (scenario key `control.touch_off_bias`).
//!
//! A 0–1000 V amplifier cannot pull a PZT stack below where it stands at 0 V. After a deep cut the
//! stack's remanence holds the tip out there (`exit_floor_tip_um`; 4.4–4.8 µm of tip on the
//! commissioned 20° exit, docs/studies/process-changes.md), so where the cutter leaves the workpiece and the deflection it must
//! cancel vanishes, no controller can follow: the command sits at 0 V and the exit is cut too deep.
//! Touching off with the stack at a bias puts the depth's zero higher up the stroke; the stack then has
//! the travel down from the bias to spend at the exit, and the deep end has that much less.
//!
//! [`auto_bias`] is the rule an engineer holding the NC program and the commissioned models applies;
//! it reads nothing from the truth.

use millcomp_mpc::groove::DeflectionPlan;
use millcomp_mpc::identified::{IdentifiedHysteresis, IdentifiedSpindle};
use serde::{Deserialize, Serialize};

/// How the tool is touched off (`control.touch_off_bias`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TouchOffBias {
    /// With the stack at rest, 0 V (the default; the thesis' procedure).
    #[default]
    Rest,
    /// With the stack held at the voltage [`auto_bias`] chooses from the program and the models.
    Auto,
    /// With the stack held at this voltage (V; within the amplifier's range).
    Volts(f64),
}

/// The share of the planned peak tip kept free at the top of the stroke for a deflection larger than
/// planned (force-model, stiffness and force-gain errors the commissioning cannot see): 10 %, a stated
/// allowance.
pub const TOP_MARGIN: f64 = 0.10;

/// The headroom [`auto_bias`] asks for below the touch-off, as a multiple of the identified hysteresis
/// model's remanence: 2. The Prandtl–Ishlinskii model is fitted to a sweep in air at 500 V/s; the creep a
/// cut of seconds adds it cannot represent, and on the commissioned 20° exit it predicts 3.29 µm where the
/// stack stood at 4.4–4.8 µm (`examples/exit_remanence.rs`). The factor is that allowance, stated, not
/// fitted to a bound: `examples/exit_remanence.rs --allowance` shows what others give.
pub const REMANENCE_ALLOWANCE: f64 = 2.0;

/// What [`auto_bias`] chose and why (µm of tip, V).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasChoice {
    /// The bias (V); 0 when the stack needs none or the stroke has no room for one.
    pub bias_v: f64,
    /// The tip the bias is meant to put the touch-off at, on the model's first rise from rest (µm).
    pub tip_um: f64,
    /// The planned peak tip (µm) and the voltage the hysteresis model's first rise from rest reaches
    /// it at (V).
    pub peak_tip_um: f64,
    /// See [`Self::peak_tip_um`].
    pub peak_v: f64,
    /// The identified hysteresis model's tip at 0 V after a rise to `peak_v` and back (µm).
    pub remanence_um: f64,
    /// The stroke the program leaves above the planned peak, less [`TOP_MARGIN`] (µm of tip; the stroke
    /// is the hysteresis model's tip at the amplifier's maximum on its first rise, or the gauge's range
    /// where that is less).
    pub slack_um: f64,
}

/// The identified hysteresis model's tip (µm) at 0 V after the stack rose from rest to `peak_v` and came
/// back (the model's plays are rate independent: a monotone move is one step).
pub fn model_remanence_um(h: &IdentifiedHysteresis, peak_v: f64) -> f64 {
    let mut op = h.operator().clone();
    op.step(peak_v.max(0.0));
    op.step(0.0)
}

/// The bias for a program whose deflection plan is `plan` at tilt `sin_a`, on the controllers' spindle
/// model (the amplifier's maximum) and identified hysteresis, with a gauge of `gauge_range_um` (the
/// controllers' feedback: a tip beyond its range is not seen): headroom below the touch-off of
/// `allowance` ([`REMANENCE_ALLOWANCE`]) × the model's remanence after the planned peak, as far as the
/// stroke and the gauge's range above the planned peak (less [`TOP_MARGIN`]) allow; the voltage is where the model's first
/// rise from rest reaches that tip. The hysteresis model, not the spindle's small-signal gain, maps tips
/// to volts here: it was fitted over the whole stroke. `None` without a hysteresis model: a linear stack
/// has no remanence to make room for.
///
/// # Examples
/// ```
/// use millcomp_closedloop::touch_off::auto_bias;
/// use millcomp_models::{HysteresisModel, NamedMatrix, SpindleModel};
/// use millcomp_mpc::groove::DeflectionPlan;
/// use millcomp_mpc::identified::{IdentifiedHysteresis, IdentifiedSpindle};
/// use millcomp_sim::groove::GrooveProgram;
/// // the 30° ramp to 80 µm at 0.05 µm of deflection per µm of depth: 4 µm of z, 8 µm of tip at the end
/// let program = GrooveProgram::thesis(30.0);
/// let plan = DeflectionPlan::reference(&program, 400.0, 0.01, 0.5, |c| Ok(0.1 * c.depth_um)).unwrap();
/// // a stack reading 0.04 µm/V plus 0.01 µm/V behind a 100 V play (49 µm at 1000 V)
/// let h = HysteresisModel { thresholds_v: vec![0.0, 100.0], weights_um_per_v: vec![0.04, 0.01], offset_um: 0.0 };
/// let sp = SpindleModel { gain_um_per_v: 0.045, zeta: 0.46, wn_rad_s: 1302.0, pole_rad_s: None,
///     dead_time_s: None, dead_time_pade_order: None, covariance: NamedMatrix::default() };
/// let (h, sp) = (IdentifiedHysteresis::new(&h).unwrap(), IdentifiedSpindle::new(&sp).unwrap());
/// let c = auto_bias(&plan, 0.5, &sp, Some(&h), 50.0, 2.0).unwrap();
/// // 8 µm of tip at 180 V; back at 0 V the 100 V play holds 80 V × 0.01 = 0.8 µm
/// assert!((c.peak_v - 180.0).abs() < 1e-6 && (c.remanence_um - 0.8).abs() < 1e-9);
/// // twice that below the touch-off, well inside the 49 − 1.1 × 8 µm the stroke leaves: 40 V
/// assert!((c.tip_um - 1.6).abs() < 1e-9 && (c.bias_v - 40.0).abs() < 1e-6);
/// // no hysteresis model, no bias
/// assert!(auto_bias(&plan, 0.5, &sp, None, 50.0, 2.0).is_none());
/// ```
pub fn auto_bias(
    plan: &DeflectionPlan,
    sin_a: f64,
    spindle: &IdentifiedSpindle,
    hysteresis: Option<&IdentifiedHysteresis>,
    gauge_range_um: f64,
    allowance: f64,
) -> Option<BiasChoice> {
    let h = hysteresis?;
    let v_max = spindle.plant().voltage_max_v;
    if sin_a <= 0.0 {
        return None;
    }
    let rest = h.operator();
    let stroke_um = rest.clone().step(v_max).min(gauge_range_um);
    let peak_tip_um = plan.range_um().1.max(0.0) / sin_a;
    let peak_v = rest.input_for(peak_tip_um).clamp(0.0, v_max);
    let remanence_um = model_remanence_um(h, peak_v).max(0.0);
    let slack_um = (stroke_um - (1.0 + TOP_MARGIN) * peak_tip_um).max(0.0);
    let tip_um = (allowance.max(0.0) * remanence_um).min(slack_um);
    let bias_v = if tip_um > 0.0 {
        rest.input_for(tip_um).clamp(0.0, v_max)
    } else {
        0.0
    };
    Some(BiasChoice {
        bias_v,
        tip_um,
        peak_tip_um,
        peak_v,
        remanence_um,
        slack_um,
    })
}
