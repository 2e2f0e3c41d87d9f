//! Effects a nominal groove model may lack (`002_…txt`, `003_…txt`, `000_…txt`), each a parametrised
//! component implementing [`Effect`]: a depth offset in µm (**+ = deeper groove**) as a function of an
//! [`EffectContext`], with named parameters that identification can fit (analytic gradients where easy,
//! finite differences otherwise — both tested against each other).
//!
//! | name | seed figure | model |
//! |---|---|---|
//! | `coolant_thermal_drift` | +8.5 µm, stable ≈ 45 min after coolant on (002 §7.1) | first-order lag on the coolant state, A·s(t), τ = 900 s (3τ = 45 min) |
//! | `spindle_thermal_growth` | up to +20 µm, speed dependent, small (minutes) time constant, Δl = m·ΔT (002 §7.6, Table 5) | ΔT follows ΔT_ss(rpm) = (G/m)·((rpm − 16 000)/(50 000 − 16 000))₊ with τ = 600 s; Δl = m·ΔT |
//! | `probe_tilt_offset` | Δl = (D1 − D2)/2·tan α, α = 0.107° → 4.67 µm (002 §7.3–7.4) | constant |
//! | `tool_wear` | tool shortens ≈ 8 µm over a test, grows with engaged length (002 §7.5) | −W(1 − e^{−L/L0}) |
//! | `slideway_straightness` | 5 µm over 90 mm (002 §4.5) | parabolic bow a·4u(1 − u), u = (X − x0)/span |
//! | `machine_compliance` | machine and tool in series, position-dependent machine stiffness (003 eqs 1–5) | −Fz/k(X), k(X) = k + (Δk/2)cos(2πX/P) |
//! | `flute_runout` | one flute cuts more than the other (000 §4) | extra chip on the larger flute: −C·kc,z·d·(f/2)·min(r/f, 1) |

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;

use crate::error::SimError;

/// Effect names (the `diagnose` contract; DESIGN.md).
pub const EFFECT_NAMES: [&str; 7] = [
    "coolant_thermal_drift",
    "spindle_thermal_growth",
    "probe_tilt_offset",
    "tool_wear",
    "slideway_straightness",
    "machine_compliance",
    "flute_runout",
];

/// Ambient temperature used for the optional `spindle_temp_c` column (°C).
pub const AMBIENT_C: f64 = 20.0;

/// Everything an effect may depend on at one measured point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectContext<'a> {
    /// Session clock when the point was cut (s).
    pub t_s: f64,
    /// Position along the groove (mm).
    pub x_mm: f64,
    /// Absolute machine X of the point (mm) = groove x-offset + x.
    pub machine_x_mm: f64,
    /// Cumulative engaged length of this tool (mm).
    pub cut_length_mm: f64,
    /// Spindle speed now (rpm).
    pub speed_rpm: f64,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Upfeed (µm/rev).
    pub upfeed_um: f64,
    /// Programmed depth (µm).
    pub depth_cmd_um: f64,
    /// Nominal actual depth (after deflection) (µm).
    pub depth_actual_um: f64,
    /// Nominal peak z-force (N).
    pub force_z_n: f64,
    /// z-force per µm² of extra chip area on the peak flute (N/µm²): µ·Kc·cos(φ/2)·scale.
    pub chip_force_z_n_per_um2: f64,
    /// z-compliance of the tool (µm/N).
    pub z_compliance_um_per_n: f64,
    /// Coolant switch history `(t_s, on)`, sorted; the coolant is off before the first event.
    pub coolant_events: &'a [(f64, bool)],
    /// Spindle speed history `(t_s, rpm)`, sorted; 0 rpm before the first event.
    pub spindle_events: &'a [(f64, f64)],
}

impl Default for EffectContext<'_> {
    fn default() -> Self {
        Self {
            t_s: 0.0,
            x_mm: 0.0,
            machine_x_mm: 0.0,
            cut_length_mm: 0.0,
            speed_rpm: 0.0,
            tilt_deg: 0.0,
            upfeed_um: 10.0,
            depth_cmd_um: 0.0,
            depth_actual_um: 0.0,
            force_z_n: 0.0,
            chip_force_z_n_per_um2: 0.0,
            z_compliance_um_per_n: 0.0,
            coolant_events: &[],
            spindle_events: &[],
        }
    }
}

/// Response at `t` of the first-order lag `τ ds/dt = u(t) − s`, `s(−∞) = 0`, to a piecewise-constant input
/// given as `(t_start, u)` events (u = 0 before the first).
pub fn first_order_response(events: &[(f64, f64)], t: f64, tau_s: f64) -> f64 {
    let mut s = 0.0;
    let mut t_prev: Option<f64> = None;
    let mut u_prev = 0.0;
    for &(te, ue) in events {
        if te > t {
            break;
        }
        if let Some(tp) = t_prev {
            s = u_prev + (s - u_prev) * (-(te - tp) / tau_s).exp();
        }
        t_prev = Some(te);
        u_prev = ue;
    }
    if let Some(tp) = t_prev {
        s = u_prev + (s - u_prev) * (-(t - tp) / tau_s).exp();
    }
    s
}

/// A depth-offset effect.
pub trait Effect: std::fmt::Debug + Send + Sync {
    /// Contract name (one of [`EFFECT_NAMES`]).
    fn name(&self) -> &'static str;
    /// Parameter names and current values, in a fixed order.
    fn params(&self) -> Vec<(&'static str, f64)>;
    /// Set all parameters (same order as [`Effect::params`]); validates.
    fn set_params(&mut self, values: &[f64]) -> Result<(), SimError>;
    /// Depth offset (µm, + = deeper) at a point.
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64;
    /// Boxed clone.
    fn clone_box(&self) -> Box<dyn Effect>;
    /// Whether [`Effect::param_gradient`] is analytic (otherwise central finite differences).
    fn has_analytic_gradient(&self) -> bool {
        false
    }
    /// Gradient of the offset w.r.t. the parameters (same order as [`Effect::params`]).
    fn param_gradient(&self, ctx: &EffectContext<'_>) -> Vec<f64> {
        fd_gradient(self, ctx)
    }
    /// Spindle temperature rise (K) this effect implies, if it models one.
    fn spindle_temp_rise_c(&self, _ctx: &EffectContext<'_>) -> Option<f64> {
        None
    }
}

impl Clone for Box<dyn Effect> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// Central finite-difference gradient of an effect's offset w.r.t. its parameters.
pub fn fd_gradient<E: Effect + ?Sized>(e: &E, ctx: &EffectContext<'_>) -> Vec<f64> {
    let p: Vec<f64> = e.params().iter().map(|(_, v)| *v).collect();
    let mut g = vec![0.0; p.len()];
    for k in 0..p.len() {
        let h = 1e-6 * p[k].abs().max(1.0);
        let mut a = e.clone_box();
        let mut b = e.clone_box();
        let mut pp = p.clone();
        pp[k] += h;
        let mut pm = p.clone();
        pm[k] -= h;
        if a.set_params(&pp).is_err() || b.set_params(&pm).is_err() {
            // one-sided at a bound
            let mut c = e.clone_box();
            if c.set_params(&pp).is_ok() {
                g[k] = (c.depth_offset_um(ctx) - e.depth_offset_um(ctx)) / h;
            } else if c.set_params(&pm).is_ok() {
                g[k] = (e.depth_offset_um(ctx) - c.depth_offset_um(ctx)) / h;
            }
            continue;
        }
        g[k] = (a.depth_offset_um(ctx) - b.depth_offset_um(ctx)) / (2.0 * h);
    }
    g
}

fn expect_len(effect: &'static str, values: &[f64], n: usize) -> Result<(), SimError> {
    if values.len() != n {
        return Err(SimError::EffectParameter {
            effect,
            param: format!("<{} values>", values.len()),
            message: format!("expected {n} parameter values"),
        });
    }
    Ok(())
}

fn check_param(
    effect: &'static str,
    name: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
    allowed: &str,
) -> Result<f64, SimError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(SimError::EffectParameter {
            effect,
            param: name.into(),
            message: format!("= {v} out of range: allowed {allowed}"),
        })
    }
}

/// Coolant thermal drift (002 §4.7, §7.1): `A·s(t)` with `s` the first-order lag (τ) of the coolant state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoolantThermalDrift {
    /// Final drift (µm), +8.5 (002 §7.1).
    pub amplitude_um: f64,
    /// Time constant (s): 900 s so that 3τ = 45 min (002 §7.1, "stable ... after 45 minutes").
    pub time_constant_s: f64,
}

impl Default for CoolantThermalDrift {
    fn default() -> Self {
        Self {
            amplitude_um: 8.5,
            time_constant_s: 900.0,
        }
    }
}

impl Effect for CoolantThermalDrift {
    fn name(&self) -> &'static str {
        "coolant_thermal_drift"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("amplitude_um", self.amplitude_um),
            ("time_constant_s", self.time_constant_s),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        expect_len(self.name(), v, 2)?;
        let a = check_param(
            self.name(),
            "amplitude_um",
            v[0],
            -1e3,
            1e3,
            "|amplitude_um| <= 1000",
        )?;
        let t = check_param(
            self.name(),
            "time_constant_s",
            v[1],
            1.0,
            1e6,
            "1 <= time_constant_s <= 1e6",
        )?;
        self.amplitude_um = a;
        self.time_constant_s = t;
        Ok(())
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        let ev: Vec<(f64, f64)> = ctx
            .coolant_events
            .iter()
            .map(|(t, on)| (*t, if *on { 1.0 } else { 0.0 }))
            .collect();
        self.amplitude_um * first_order_response(&ev, ctx.t_s, self.time_constant_s)
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
}

/// High-speed spindle thermal growth (002 §4.6, §7.6, Table 5): temperature rise follows a speed-dependent
/// steady value with a first-order lag; growth Δl = m·ΔT.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpindleThermalGrowth {
    /// Growth at `rpm_max` in steady state (µm), +20 (002 Table 5, worst case).
    pub max_growth_um: f64,
    /// Speed below which heating is negligible (rpm), 16 000 (002 §7.6, Fig. 25).
    pub rpm_onset: f64,
    /// Speed of maximum growth (rpm), 50 000 (spindle maximum, 002 §5.2).
    pub rpm_max: f64,
    /// Thermal time constant (s), 600 ("small time constant", > 4.5 °C after 10 min at 30 000 rpm and still
    /// rising, 002 §7.6).
    pub time_constant_s: f64,
    /// Calibration slope m (µm/K) of Δl = m·ΔT (002 §7.6, Fig. 26), 1.0.
    pub um_per_c: f64,
}

impl Default for SpindleThermalGrowth {
    fn default() -> Self {
        Self {
            max_growth_um: 20.0,
            rpm_onset: 16_000.0,
            rpm_max: 50_000.0,
            time_constant_s: 600.0,
            um_per_c: 1.0,
        }
    }
}

impl SpindleThermalGrowth {
    /// Steady-state growth (µm) at `rpm`.
    pub fn steady_growth_um(&self, rpm: f64) -> f64 {
        self.max_growth_um * ((rpm - self.rpm_onset) / (self.rpm_max - self.rpm_onset)).max(0.0)
    }
}

impl Effect for SpindleThermalGrowth {
    fn name(&self) -> &'static str {
        "spindle_thermal_growth"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("max_growth_um", self.max_growth_um),
            ("rpm_onset", self.rpm_onset),
            ("rpm_max", self.rpm_max),
            ("time_constant_s", self.time_constant_s),
            ("um_per_c", self.um_per_c),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        let n = self.name();
        expect_len(n, v, 5)?;
        let g = check_param(
            n,
            "max_growth_um",
            v[0],
            -1e3,
            1e3,
            "|max_growth_um| <= 1000",
        )?;
        let r0 = check_param(n, "rpm_onset", v[1], 0.0, 1e6, "0 <= rpm_onset < rpm_max")?;
        let r1 = check_param(n, "rpm_max", v[2], 1.0, 1e6, "rpm_onset < rpm_max <= 1e6")?;
        if r1 <= r0 {
            return Err(SimError::EffectParameter {
                effect: n,
                param: "rpm_max".into(),
                message: format!("= {r1} must exceed rpm_onset = {r0}"),
            });
        }
        let tau = check_param(
            n,
            "time_constant_s",
            v[3],
            1.0,
            1e6,
            "1 <= time_constant_s <= 1e6",
        )?;
        let m = check_param(n, "um_per_c", v[4], 1e-3, 1e3, "0.001 <= um_per_c <= 1000")?;
        *self = Self {
            max_growth_um: g,
            rpm_onset: r0,
            rpm_max: r1,
            time_constant_s: tau,
            um_per_c: m,
        };
        Ok(())
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        let ev: Vec<(f64, f64)> = ctx
            .spindle_events
            .iter()
            .map(|(t, rpm)| (*t, self.steady_growth_um(*rpm)))
            .collect();
        first_order_response(&ev, ctx.t_s, self.time_constant_s)
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn spindle_temp_rise_c(&self, ctx: &EffectContext<'_>) -> Option<f64> {
        Some(self.depth_offset_um(ctx) / self.um_per_c)
    }
}

/// Tool-length probe tip tilt (002 §7.3, eq. 1): Δl = (D1 − D2)/2 · tan α (+ = deeper).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProbeTiltOffset {
    /// Reference (roughing) tool diameter D1 (mm).
    pub d1_mm: f64,
    /// Finishing tool diameter D2 (mm). 1.0 mm reproduces the seed's 4.67 µm (§7.4) with D1 = 6 mm.
    pub d2_mm: f64,
    /// Probe tip inclination α (deg), 0.107° (§7.3).
    pub alpha_deg: f64,
}

impl Default for ProbeTiltOffset {
    fn default() -> Self {
        Self {
            d1_mm: 6.0,
            d2_mm: 1.0,
            alpha_deg: 0.107,
        }
    }
}

impl Effect for ProbeTiltOffset {
    fn name(&self) -> &'static str {
        "probe_tilt_offset"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("d1_mm", self.d1_mm),
            ("d2_mm", self.d2_mm),
            ("alpha_deg", self.alpha_deg),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        let n = self.name();
        expect_len(n, v, 3)?;
        self.d1_mm = check_param(n, "d1_mm", v[0], 0.0, 100.0, "0 <= d1_mm <= 100")?;
        self.d2_mm = check_param(n, "d2_mm", v[1], 0.0, 100.0, "0 <= d2_mm <= 100")?;
        self.alpha_deg = check_param(n, "alpha_deg", v[2], -10.0, 10.0, "|alpha_deg| <= 10")?;
        Ok(())
    }
    fn depth_offset_um(&self, _ctx: &EffectContext<'_>) -> f64 {
        (self.d1_mm - self.d2_mm) / 2.0 * self.alpha_deg.to_radians().tan() * 1e3
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn has_analytic_gradient(&self) -> bool {
        true
    }
    fn param_gradient(&self, _ctx: &EffectContext<'_>) -> Vec<f64> {
        let a = self.alpha_deg.to_radians();
        let t = a.tan();
        vec![
            0.5 * t * 1e3,
            -0.5 * t * 1e3,
            (self.d1_mm - self.d2_mm) / 2.0 * (1.0 + t * t) * PI / 180.0 * 1e3,
        ]
    }
}

/// Tool wear (002 §4.2, §7.5): the tool shortens with engaged length, `−W(1 − e^{−L/L0})`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ToolWear {
    /// Asymptotic shortening (µm), 8 (002 §7.5: "difference between initial and final error is 8 µm").
    pub max_wear_um: f64,
    /// Engaged length scale (mm), 100 (not published; a test of a few hundred mm reaches ≈ 8 µm).
    pub length_scale_mm: f64,
}

impl Default for ToolWear {
    fn default() -> Self {
        Self {
            max_wear_um: 8.0,
            length_scale_mm: 100.0,
        }
    }
}

impl Effect for ToolWear {
    fn name(&self) -> &'static str {
        "tool_wear"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("max_wear_um", self.max_wear_um),
            ("length_scale_mm", self.length_scale_mm),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        let n = self.name();
        expect_len(n, v, 2)?;
        self.max_wear_um = check_param(n, "max_wear_um", v[0], -1e3, 1e3, "|max_wear_um| <= 1000")?;
        self.length_scale_mm = check_param(
            n,
            "length_scale_mm",
            v[1],
            1e-3,
            1e7,
            "0.001 <= length_scale_mm <= 1e7",
        )?;
        Ok(())
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        -self.max_wear_um * (1.0 - (-ctx.cut_length_mm.max(0.0) / self.length_scale_mm).exp())
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn has_analytic_gradient(&self) -> bool {
        true
    }
    fn param_gradient(&self, ctx: &EffectContext<'_>) -> Vec<f64> {
        let l = ctx.cut_length_mm.max(0.0);
        let e = (-l / self.length_scale_mm).exp();
        vec![
            -(1.0 - e),
            self.max_wear_um * e * l / (self.length_scale_mm * self.length_scale_mm),
        ]
    }
}

/// Slideway straightness (002 §4.5): parabolic bow of `amplitude_um` at mid-span, zero at the span ends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SlidewayStraightness {
    /// Mid-span deviation (µm), 5 (002 §4.5; sign + = deeper in the middle).
    pub amplitude_um: f64,
    /// Span (mm), 90.
    pub span_mm: f64,
    /// Machine X of the span start (mm).
    pub x0_mm: f64,
}

impl Default for SlidewayStraightness {
    fn default() -> Self {
        Self {
            amplitude_um: 5.0,
            span_mm: 90.0,
            x0_mm: 0.0,
        }
    }
}

impl Effect for SlidewayStraightness {
    fn name(&self) -> &'static str {
        "slideway_straightness"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("amplitude_um", self.amplitude_um),
            ("span_mm", self.span_mm),
            ("x0_mm", self.x0_mm),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        let n = self.name();
        expect_len(n, v, 3)?;
        self.amplitude_um =
            check_param(n, "amplitude_um", v[0], -1e3, 1e3, "|amplitude_um| <= 1000")?;
        self.span_mm = check_param(n, "span_mm", v[1], 1e-3, 1e5, "0.001 <= span_mm <= 1e5")?;
        self.x0_mm = check_param(n, "x0_mm", v[2], -1e5, 1e5, "|x0_mm| <= 1e5")?;
        Ok(())
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        let u = (ctx.machine_x_mm - self.x0_mm) / self.span_mm;
        if (0.0..=1.0).contains(&u) {
            4.0 * self.amplitude_um * u * (1.0 - u)
        } else {
            0.0
        }
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn has_analytic_gradient(&self) -> bool {
        true
    }
    fn param_gradient(&self, ctx: &EffectContext<'_>) -> Vec<f64> {
        let u = (ctx.machine_x_mm - self.x0_mm) / self.span_mm;
        if !(0.0..=1.0).contains(&u) {
            return vec![0.0; 3];
        }
        let dg_du = 4.0 * self.amplitude_um * (1.0 - 2.0 * u);
        vec![
            4.0 * u * (1.0 - u),
            dg_du * (-u / self.span_mm),
            dg_du * (-1.0 / self.span_mm),
        ]
    }
}

/// Machine compliance in series with the tool (003 eqs. 1–5): extra deflection `Fz/k(X)` makes the groove
/// shallower; the machine stiffness varies with position by `Δk` over a period `P`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MachineCompliance {
    /// Mean machine stiffness k_M (N/µm), 10 (not published in 003; a stiff precision machine).
    pub stiffness_n_per_um: f64,
    /// Stiffness span Δk_M (N/µm), 0 by default (003 eq. 1–4).
    pub span_n_per_um: f64,
    /// Period of the position dependence (mm).
    pub period_mm: f64,
}

impl Default for MachineCompliance {
    fn default() -> Self {
        Self {
            stiffness_n_per_um: 10.0,
            span_n_per_um: 0.0,
            period_mm: 200.0,
        }
    }
}

impl MachineCompliance {
    fn k_at(&self, x_mm: f64) -> f64 {
        self.stiffness_n_per_um
            + 0.5 * self.span_n_per_um * (2.0 * PI * x_mm / self.period_mm).cos()
    }
}

impl Effect for MachineCompliance {
    fn name(&self) -> &'static str {
        "machine_compliance"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("stiffness_n_per_um", self.stiffness_n_per_um),
            ("span_n_per_um", self.span_n_per_um),
            ("period_mm", self.period_mm),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        let n = self.name();
        expect_len(n, v, 3)?;
        let k = check_param(
            n,
            "stiffness_n_per_um",
            v[0],
            1e-6,
            1e6,
            "0 < stiffness_n_per_um <= 1e6",
        )?;
        let s = check_param(
            n,
            "span_n_per_um",
            v[1],
            0.0,
            2.0 * k * 0.999_999,
            "0 <= span_n_per_um < 2*stiffness_n_per_um",
        )?;
        let p = check_param(n, "period_mm", v[2], 1e-3, 1e6, "0.001 <= period_mm <= 1e6")?;
        *self = Self {
            stiffness_n_per_um: k,
            span_n_per_um: s,
            period_mm: p,
        };
        Ok(())
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        -ctx.force_z_n / self.k_at(ctx.machine_x_mm)
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn has_analytic_gradient(&self) -> bool {
        true
    }
    fn param_gradient(&self, ctx: &EffectContext<'_>) -> Vec<f64> {
        let k = self.k_at(ctx.machine_x_mm);
        let f = ctx.force_z_n;
        let arg = 2.0 * PI * ctx.machine_x_mm / self.period_mm;
        let dk_dp = 0.5 * self.span_n_per_um * (-arg.sin()) * (-arg / self.period_mm);
        let d_dk = f / (k * k);
        vec![d_dk, d_dk * 0.5 * arg.cos(), d_dk * dk_dp]
    }
}

/// Flute runout (000 §4): one flute cuts `min(r/f, 1)·f/2` more chip than nominal; the extra peak z-force
/// deflects the tool (shallower groove): `−C·kc,z·d·(f/2)·min(r/f, 1)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluteRunout {
    /// Extra (flute-to-flute) runout not in the nominal model (µm), 3.
    pub runout_um: f64,
}

impl Default for FluteRunout {
    fn default() -> Self {
        Self { runout_um: 3.0 }
    }
}

impl Effect for FluteRunout {
    fn name(&self) -> &'static str {
        "flute_runout"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![("runout_um", self.runout_um)]
    }
    fn set_params(&mut self, v: &[f64]) -> Result<(), SimError> {
        expect_len(self.name(), v, 1)?;
        self.runout_um = check_param(
            self.name(),
            "runout_um",
            v[0],
            0.0,
            1e3,
            "0 <= runout_um <= 1000",
        )?;
        Ok(())
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        if ctx.upfeed_um <= 0.0 {
            return 0.0;
        }
        let xi = (self.runout_um / ctx.upfeed_um).min(1.0);
        -ctx.z_compliance_um_per_n
            * ctx.chip_force_z_n_per_um2
            * ctx.depth_actual_um
            * 0.5
            * ctx.upfeed_um
            * xi
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn has_analytic_gradient(&self) -> bool {
        true
    }
    fn param_gradient(&self, ctx: &EffectContext<'_>) -> Vec<f64> {
        if ctx.upfeed_um <= 0.0 || self.runout_um >= ctx.upfeed_um {
            return vec![0.0];
        }
        vec![-ctx.z_compliance_um_per_n * ctx.chip_force_z_n_per_um2 * ctx.depth_actual_um * 0.5]
    }
}

/// An effect with its default (seed) parameters.
///
/// # Errors
/// [`SimError::UnknownEffect`] for a name not in [`EFFECT_NAMES`] (the message lists them).
///
/// # Examples
/// ```
/// use millcomp_sim::SimError;
/// use millcomp_sim::effects::{EffectContext, default_effect};
/// // 002 §7.3–7.4: probe tip tilted 0.107°, reference tool Ø6 mm, finishing tool Ø1 mm:
/// // Δl = (6 − 1)/2 · tan 0.107° = 4.67 µm, the same at every point
/// let probe = default_effect("probe_tilt_offset").unwrap();
/// assert!((probe.depth_offset_um(&EffectContext::default()) - 4.67).abs() < 0.005);
/// assert!(matches!(default_effect("gremlins"), Err(SimError::UnknownEffect { .. })));
/// ```
pub fn default_effect(name: &str) -> Result<Box<dyn Effect>, SimError> {
    Ok(match name {
        "coolant_thermal_drift" => Box::new(CoolantThermalDrift::default()),
        "spindle_thermal_growth" => Box::new(SpindleThermalGrowth::default()),
        "probe_tilt_offset" => Box::new(ProbeTiltOffset::default()),
        "tool_wear" => Box::new(ToolWear::default()),
        "slideway_straightness" => Box::new(SlidewayStraightness::default()),
        "machine_compliance" => Box::new(MachineCompliance::default()),
        "flute_runout" => Box::new(FluteRunout::default()),
        _ => {
            return Err(SimError::UnknownEffect {
                name: name.into(),
                allowed: EFFECT_NAMES.join(", "),
            });
        }
    })
}

/// Build an effect from a name and a parameter map (missing keys keep the seed defaults; unknown keys are
/// errors naming the key).
///
/// # Errors
/// [`SimError::UnknownEffect`] as [`default_effect`]; [`SimError::EffectParameter`] naming the
/// parameter when a key is not one of the effect's parameters or a value is outside its range.
///
/// # Examples
/// ```
/// use std::collections::BTreeMap;
/// use millcomp_sim::SimError;
/// use millcomp_sim::effects::{EffectContext, effect_from_params};
/// // coolant drift of +8.5 µm (002 §7.1) with τ = 900 s: 45 min = 3τ after the coolant is switched
/// // on, 1 − e⁻³ = 95 % of it has appeared
/// let params = BTreeMap::from([("amplitude_um".to_string(), 8.5)]);
/// let drift = effect_from_params("coolant_thermal_drift", &params).unwrap();
/// assert_eq!(drift.params(), vec![("amplitude_um", 8.5), ("time_constant_s", 900.0)]);
/// let on = [(0.0, true)];
/// let ctx = EffectContext { t_s: 2700.0, coolant_events: &on, ..Default::default() };
/// assert!((drift.depth_offset_um(&ctx) - 8.5 * (1.0 - (-3.0f64).exp())).abs() < 1e-12);
///
/// let bad = BTreeMap::from([("tau_s".to_string(), 900.0)]);
/// let e = effect_from_params("coolant_thermal_drift", &bad).unwrap_err();
/// assert!(matches!(&e, SimError::EffectParameter { param, .. } if param == "tau_s"));
/// let bad = BTreeMap::from([("time_constant_s".to_string(), 0.0)]);
/// let e = effect_from_params("coolant_thermal_drift", &bad).unwrap_err();
/// assert!(matches!(&e, SimError::EffectParameter { param, .. } if param == "time_constant_s"));
/// ```
pub fn effect_from_params(
    name: &str,
    params: &BTreeMap<String, f64>,
) -> Result<Box<dyn Effect>, SimError> {
    let mut e = default_effect(name)?;
    let mut values: Vec<f64> = e.params().iter().map(|(_, v)| *v).collect();
    let names: Vec<&'static str> = e.params().iter().map(|(n, _)| *n).collect();
    for (k, v) in params {
        match names.iter().position(|n| n == k) {
            Some(i) => values[i] = *v,
            None => {
                return Err(SimError::EffectParameter {
                    effect: e.name(),
                    param: k.clone(),
                    message: format!("is unknown; allowed {names:?}"),
                });
            }
        }
    }
    e.set_params(&values)?;
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn first_order_response_on_off() {
        let ev = [(0.0, 1.0), (100.0, 0.0)];
        assert_relative_eq!(first_order_response(&ev, 50.0, 50.0), 1.0 - (-1.0f64).exp());
        let s100 = 1.0 - (-2.0f64).exp();
        assert_relative_eq!(
            first_order_response(&ev, 150.0, 50.0),
            s100 * (-1.0f64).exp()
        );
        assert_eq!(first_order_response(&ev, -1.0, 50.0), 0.0);
    }

    #[test]
    fn every_name_has_an_effect() {
        for n in EFFECT_NAMES {
            let e = default_effect(n).unwrap();
            assert_eq!(e.name(), n);
            let vals: Vec<f64> = e.params().iter().map(|(_, v)| *v).collect();
            let mut e2 = e.clone();
            e2.set_params(&vals).unwrap();
        }
        assert!(default_effect("gremlins").is_err());
        let mut m = BTreeMap::new();
        m.insert("bogus".to_string(), 1.0);
        let err = effect_from_params("tool_wear", &m).unwrap_err();
        assert!(err.to_string().contains("bogus"));
    }
}
