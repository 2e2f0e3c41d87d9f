//! The candidate families on a measured record: the groove candidates' physical shapes (their
//! DESIGN.md effect names), driven by the record's own context columns instead of a session's plan,
//! with parameters in the record signal's unit (`<unit>`: `um` for a displacement, `n` for a force;
//! `+` = the signal grows).
//!
//! | effect | family | shape | needs |
//! |---|---|---|---|
//! | `coolant_thermal_drift` | coolant lag | `A·L_τ[coolant_on]` (002 §7.1) | `t_s`, `coolant_on` |
//! | `spindle_thermal_growth` | speed-driven | `G·L_τ[(n/1000 rpm)^e]` (002 §7.6; `identify thermal --model speed-1tau`) | `t_s`, `speed_rpm` |
//! | `spindle_thermal_growth` | temperature-driven | `Σ mᵢ·ΔTᵢ`, sensors by stepwise BIC on the current residual (BIC on the effective sample size, as the tests) (002's Δl = m·ΔT) | `temp_c` |
//! | `tool_wear` | engaged length | `W·(1 − e^{−L/L₀})` (002 §7.5) | `cut_length_mm` or `cut` |
//!
//! `L_τ` is the first-order lag of the input held from one row to the next, from 0 at the record's
//! first row (`identify`'s `first_order_lag`). The other DESIGN effects need what a record does not
//! carry (a constant offset is the nominal's recalibrated level; the slideway needs machine X, the
//! compliance a predicted force, the runout per-flute channels) and are listed as not testable.

use millcomp_identify::regress::{Gram, stepwise_by};
use millcomp_identify::targets::thermal_record::first_order_lag;

/// One parameter of a family.
#[derive(Debug, Clone)]
pub(crate) struct Param {
    pub name: String,
    /// Linear parameters get their start from least squares; nonlinear ones from `starts`.
    pub linear: bool,
    pub lower: f64,
    pub upper: f64,
    pub starts: Vec<f64>,
}

impl Param {
    fn linear(name: String) -> Self {
        Param {
            name,
            linear: true,
            lower: f64::NEG_INFINITY,
            upper: f64::INFINITY,
            starts: vec![0.0],
        }
    }
    fn nonlinear(name: &str, lower: f64, upper: f64, starts: Vec<f64>) -> Self {
        Param {
            name: name.into(),
            linear: false,
            lower,
            upper,
            starts,
        }
    }
}

/// What drives a family.
#[derive(Debug, Clone)]
pub(crate) enum Driver {
    /// `A·L_τ[coolant]`: params `[A, τ]`.
    Coolant { t_s: Vec<f64>, coolant: Vec<f64> },
    /// `G·L_τ[(n/1000)^e]`: params `[G, τ, e]`.
    Speed { t_s: Vec<f64>, speed_rpm: Vec<f64> },
    /// `Σ mᵢ·ΔTᵢ`: params one per selected sensor.
    Temperature { delta_c: Vec<Vec<f64>> },
    /// `W·(1 − e^{−L/L₀})`: params `[W, L₀]`.
    Length { length: Vec<f64> },
}

/// A candidate family on a record.
#[derive(Debug, Clone)]
pub(crate) struct Family {
    pub effect: &'static str,
    pub family: String,
    pub params: Vec<Param>,
    pub driver: Driver,
    /// Sensors of a temperature-driven family, as the file names them.
    pub sensors: Vec<String>,
}

impl Family {
    /// Its contribution at every row for parameters `p`.
    pub fn eval(&self, p: &[f64]) -> Vec<f64> {
        match &self.driver {
            Driver::Coolant { t_s, coolant } => first_order_lag(t_s, coolant, p[1])
                .into_iter()
                .map(|v| p[0] * v)
                .collect(),
            Driver::Speed { t_s, speed_rpm } => {
                let u: Vec<f64> = speed_rpm
                    .iter()
                    .map(|&n| {
                        if n > 0.0 {
                            (n / 1000.0).powf(p[2])
                        } else {
                            0.0
                        }
                    })
                    .collect();
                first_order_lag(t_s, &u, p[1])
                    .into_iter()
                    .map(|v| p[0] * v)
                    .collect()
            }
            Driver::Temperature { delta_c } => {
                let n = delta_c.first().map_or(0, Vec::len);
                (0..n)
                    .map(|i| delta_c.iter().zip(p).map(|(d, m)| m * d[i]).sum())
                    .collect()
            }
            Driver::Length { length } => length
                .iter()
                .map(|&l| p[0] * (1.0 - (-l.max(0.0) / p[1]).exp()))
                .collect(),
        }
    }

    /// Columns of the Jacobian of [`Family::eval`] (one per parameter): linear parameters exactly,
    /// nonlinear ones by central differences (relative step 1e-6).
    pub fn jacobian(&self, p: &[f64]) -> Vec<Vec<f64>> {
        (0..p.len())
            .map(|k| {
                if self.params[k].linear {
                    // every family is linear in its linear parameters: the column is the family
                    // with this one at 1 and the other linear ones at 0
                    let u: Vec<f64> = p
                        .iter()
                        .enumerate()
                        .map(|(j, &v)| match (self.params[j].linear, j == k) {
                            (true, true) => 1.0,
                            (true, false) => 0.0,
                            _ => v,
                        })
                        .collect();
                    self.eval(&u)
                } else {
                    let h = 1e-6 * p[k].abs().max(1e-6);
                    let mut a = p.to_vec();
                    let mut b = p.to_vec();
                    a[k] += h;
                    b[k] -= h;
                    let (ea, eb) = (self.eval(&a), self.eval(&b));
                    ea.iter()
                        .zip(&eb)
                        .map(|(x, y)| (x - y) / (2.0 * h))
                        .collect()
                }
            })
            .collect()
    }
}

/// The record's context, as the families read it.
#[derive(Debug, Clone, Default)]
pub struct RecordContext {
    /// Time (s), strictly increasing.
    pub t_s: Option<Vec<f64>>,
    /// Spindle speed (rpm).
    pub speed_rpm: Option<Vec<f64>>,
    /// Temperatures (°C), named as in the file.
    pub temps_c: Vec<(String, Vec<f64>)>,
    /// Coolant flowing (0/1).
    pub coolant_on: Option<Vec<f64>>,
    /// Cumulative engaged length of the tool (mm).
    pub cut_length_mm: Option<Vec<f64>>,
    /// Cut count (one row per cut), used as the engaged-length coordinate when there is no
    /// `cut_length_mm` (the length of one cut is then the unit).
    pub cut: Option<Vec<f64>>,
    /// Machine X (mm), for the slideway.
    pub machine_x_mm: Option<Vec<f64>>,
    /// Per-flute channels of the signal (e.g. the peak force of each flute per row).
    pub flutes: Vec<(String, Vec<f64>)>,
}

/// The DESIGN.md effects (sim's contract list).
pub(crate) use millcomp_sim::effects::EFFECT_NAMES as EFFECTS;

/// Builds the families the record can test; the others with the reason they cannot be. `residual` is
/// the current residual (the temperature family selects its sensors on it by stepwise BIC on the
/// effective sample size `n_eff`; `None`: every sensor, for the richest model), `unit` the signal's.
pub(crate) fn families(
    ctx: &RecordContext,
    residual: &[f64],
    unit: &str,
    n_eff: Option<f64>,
) -> (Vec<Family>, Vec<(String, String)>) {
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    let amp = |s: &str| format!("{s}_{unit}");
    // coolant
    match (&ctx.t_s, &ctx.coolant_on) {
        (Some(t), Some(c)) if c.iter().any(|&v| v > 0.0) && c.contains(&0.0) => {
            out.push(Family {
                effect: "coolant_thermal_drift",
                family: "coolant lag A·L_tau[coolant_on] (002 §7.1)".into(),
                params: vec![
                    Param::linear(amp("amplitude")),
                    Param::nonlinear("time_constant_s", 10.0, 1e6, vec![300.0, 900.0, 3000.0]),
                ],
                driver: Driver::Coolant {
                    t_s: t.clone(),
                    coolant: c.clone(),
                },
                sensors: Vec::new(),
            });
        }
        (Some(_), Some(_)) => skipped.push((
            "coolant_thermal_drift".into(),
            "the coolant is never switched in this record".into(),
        )),
        _ => skipped.push((
            "coolant_thermal_drift".into(),
            "needs t_s and coolant_on (not in the record)".into(),
        )),
    }
    // spindle growth, speed-driven
    match (&ctx.t_s, &ctx.speed_rpm) {
        (Some(t), Some(n)) if n.iter().any(|&v| v > 0.0) => out.push(Family {
            effect: "spindle_thermal_growth",
            family: "speed-driven G·L_tau[(n/1000 rpm)^e] (002 §7.6)".into(),
            params: vec![
                Param::linear(amp("gain")),
                Param::nonlinear(
                    "time_constant_s",
                    30.0,
                    1e6,
                    vec![600.0, 1800.0, 3600.0, 7200.0, 14_400.0],
                ),
                Param::nonlinear("exponent", 0.25, 4.0, vec![1.0, 2.0]),
            ],
            driver: Driver::Speed {
                t_s: t.clone(),
                speed_rpm: n.clone(),
            },
            sensors: Vec::new(),
        }),
        (Some(_), Some(_)) => skipped.push((
            "spindle_thermal_growth (speed-driven)".into(),
            "the spindle never runs in this record".into(),
        )),
        (None, Some(_)) => skipped.push((
            "spindle_thermal_growth (speed-driven)".into(),
            "needs t_s: the record has no time column".into(),
        )),
        _ => skipped.push((
            "spindle_thermal_growth (speed-driven)".into(),
            "needs speed_rpm (not in the record)".into(),
        )),
    }
    // spindle growth, temperature-driven: sensors by stepwise BIC on the current residual
    if ctx.temps_c.is_empty() {
        skipped.push((
            "spindle_thermal_growth (temperature-driven)".into(),
            "needs temp_c (not in the record)".into(),
        ));
    } else {
        let delta: Vec<Vec<f64>> = ctx
            .temps_c
            .iter()
            .map(|(_, v)| v.iter().map(|x| x - v[0]).collect())
            .collect();
        let cols: Vec<&[f64]> = delta.iter().map(Vec::as_slice).collect();
        let rows: Vec<usize> = (0..residual.len()).collect();
        let g = Gram::new(&cols, residual, &rows);
        let cand: Vec<usize> = (0..cols.len()).collect();
        // BIC on the effective sample size, as the tests count it
        let n = residual.len();
        let sel = match n_eff {
            Some(ne) => stepwise_by(&[], &cand, |s| {
                let (_, rss) = g.solve(s, 0.0)?;
                Some(ne * (rss.max(1e-300) / n as f64).ln() + (1 + s.len()) as f64 * ne.ln())
            }),
            None => cand.clone(),
        };
        if sel.is_empty() {
            skipped.push((
                "spindle_thermal_growth (temperature-driven)".into(),
                "stepwise BIC keeps no temperature sensor on the current residual".into(),
            ));
        } else {
            out.push(Family {
                effect: "spindle_thermal_growth",
                family: format!(
                    "temperature-driven Σ m_i·ΔT_i, {} of {} sensors by stepwise BIC on n_eff (002's Δl = m·ΔT)",
                    sel.len(),
                    cols.len()
                ),
                params: sel
                    .iter()
                    .map(|&j| Param::linear(format!("m_{}_{unit}_per_k", ctx.temps_c[j].0)))
                    .collect(),
                driver: Driver::Temperature {
                    delta_c: sel.iter().map(|&j| delta[j].clone()).collect(),
                },
                sensors: sel.iter().map(|&j| ctx.temps_c[j].0.clone()).collect(),
            });
        }
    }
    // tool wear on engaged length (or cut count)
    let (length, len_unit) = match (&ctx.cut_length_mm, &ctx.cut) {
        (Some(l), _) => (Some(l.clone()), "mm"),
        (None, Some(c)) => (Some(c.clone()), "cuts"),
        _ => (None, ""),
    };
    match length {
        Some(l) if l.iter().any(|&v| v > 0.0) => {
            let lmax = l.iter().copied().fold(0.0f64, f64::max);
            out.push(Family {
                effect: "tool_wear",
                family: format!("engaged length W·(1 − exp(−L/L0)), L in {len_unit} (002 §7.5)"),
                params: vec![
                    Param::linear(amp("amplitude")),
                    Param::nonlinear(
                        &format!("length_scale_{len_unit}"),
                        1e-3 * lmax,
                        1e3 * lmax,
                        vec![0.1 * lmax, 0.3 * lmax, lmax, 3.0 * lmax],
                    ),
                ],
                driver: Driver::Length { length: l },
                sensors: Vec::new(),
            });
        }
        Some(_) => skipped.push((
            "tool_wear".into(),
            "the tool never engages (no cut length)".into(),
        )),
        None => skipped.push((
            "tool_wear".into(),
            "needs cut_length_mm or cut (not in the record)".into(),
        )),
    }
    skipped.push((
        "probe_tilt_offset".into(),
        "a constant offset: the nominal's level, recalibrated in the nuisance step".into(),
    ));
    skipped.push((
        "slideway_straightness".into(),
        if ctx.machine_x_mm.is_some() {
            "a record's machine X is not a groove's span: not implemented on records".into()
        } else {
            "needs machine_x_mm (not in the record)".into()
        },
    ));
    skipped.push((
        "machine_compliance".into(),
        "needs the nominal's predicted force (a record's constant nominal has none)".into(),
    ));
    if ctx.flutes.len() < 2 {
        skipped.push((
            "flute_runout".into(),
            "needs per-flute channels (flute_n with 2 or more columns)".into(),
        ));
    }
    (out, skipped)
}
