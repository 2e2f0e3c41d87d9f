//! # millcomp-synthetic (dev tool)
//!
//! Seeded synthetic measured sessions with hidden effects (`datasets/synthetic/`), written by
//! `cargo run -p millcomp-synthetic --bin gen_synthetic --release`, and the variants the tests of
//! `millcomp-diagnose` use ([`resample`], [`hidden_offsets`]). Not library code of millcomp: nothing
//! but tests, examples and this generator depend on it.
//!
//! Every case uses the same session plan ([`base_session`]): 14 grooves of 20 mm in S7, measured
//! every 1 mm (294 points) over ≈ 2.8 h, built so that the effects of `002_…txt` §7 are
//! distinguishable as in its tests: pauses of 5–30 min with the spindle running or stopped (time
//! advances while the engaged length does not, the spindle heats and cools), three speeds
//! (10 000 rpm below the growth onset, 24 000, 36 000), coolant switched on part-way (groove 3,
//! t ≈ 30 min, as in 002 §7.1), two tilts (20°, 30°: the tool compliance changes, the machine's does
//! not), two upfeeds (5, 10 µm/rev), ramps, constants and steps in depth (force varies), and groove
//! offsets covering machine X 0–90 mm (the 90 mm straightness span of 002 §7.2).
//!
//! The session file (`NAME.toml`) is the nominal model only; the hidden effects live in the truth
//! used to simulate `NAME.csv` and are listed in the generated README. Standard hidden effects
//! are simulated by sim's `simulate_session` (with its seeded profilometer noise, σ = 0.1 µm —
//! 002 §7.2 profilometer, repeatability ±2·STD < 0.15 µm per groove in §7.9); robustness variants
//! (other functional forms) are added over sim's nominal contexts ([`Session::contexts`]) with
//! their own seeded noise. Files are written through `millcomp-datasets` (the measured-groove and
//! force-trace contracts).
//!
//! ```
//! let case = millcomp_synthetic::cases().into_iter().find(|c| c.name == "tool_wear").unwrap();
//! assert_eq!(case.seed, 7005);
//! let data = millcomp_synthetic::generate(&case).unwrap();
//! // 14 grooves × 21 points
//! assert_eq!(data.points.len(), 294);
//! ```
#![warn(missing_docs)]

use std::collections::BTreeMap;

pub mod variants;

use millcomp_datasets::DatasetError;
use millcomp_datasets::contracts::{force_trace_table, measured_groove_table};
use millcomp_sim::SimError;
use millcomp_sim::effects::{Effect, EffectContext, effect_from_params, first_order_response};
use millcomp_sim::force::{CutConditions, PEAK_SAMPLES_PER_REV};
use millcomp_sim::groove::DepthProfile;
use millcomp_sim::sensors::NoiseSpec;
use millcomp_sim::session::{
    EffectSpec, FluteForcePoint, ForceModelSpec, GroovePoint, GrooveSpec, MaterialSpec, PauseSpec,
    PlanItem, Session, SessionContexts, SimOptions, StiffnessSpec, ToolSpec, UncertaintySpec,
    simulate_session,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Why a synthetic case could not be generated or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SyntheticError {
    /// sim rejected a hidden effect's parameters, the session or the force model.
    #[error("case `{case}`: {what}")]
    Sim {
        /// The case.
        case: String,
        /// What was being evaluated.
        what: String,
        /// sim's error.
        #[source]
        source: SimError,
    },
    /// The noise distribution could not be built.
    #[error("noise σ = {sigma}")]
    Noise {
        /// The standard deviation given.
        sigma: f64,
        /// rand_distr's error.
        #[source]
        source: rand_distr::NormalError,
    },
    /// A table or text could not be built or written.
    #[error("`{file}`")]
    Table {
        /// The file.
        file: String,
        /// The table writer's error.
        #[source]
        source: DatasetError,
    },
    /// The session could not be serialised as TOML.
    #[error("`{file}`")]
    Toml {
        /// The file.
        file: String,
        /// toml's error.
        #[source]
        source: toml::ser::Error,
    },
}

/// Result alias of the crate.
pub type Result<T> = std::result::Result<T, SyntheticError>;

/// The generator's command (named in the generated files).
pub const COMMAND: &str = "cargo run -p millcomp-synthetic --bin gen_synthetic --release";

/// Profilometer noise σ (µm): 002 §7.9 reports < 0.15 µm standard deviation over 10 profiles.
pub const DEPTH_NOISE_UM: f64 = millcomp_sim::sensors::PROFILOMETER_SIGMA_UM;
/// Force-sensor noise σ (N) on each per-flute peak: 000 §7.2 force sensor (sim's
/// `ForceSensor::thesis`, 0.04 N).
pub const FORCE_NOISE_N: f64 = 0.04;

/// How a hidden effect is generated.
#[derive(Debug, Clone)]
pub enum Truth {
    /// A sim effect (simulated by `simulate_session`), with parameters (others at seed defaults).
    Sim {
        /// Effect name.
        name: &'static str,
        /// Parameters set explicitly.
        params: Vec<(&'static str, f64)>,
    },
    /// Another functional form (robustness), evaluated on the session's contexts.
    Custom(Box<dyn Effect>),
}

/// A hidden effect and the name `diagnose` should give it.
#[derive(Debug, Clone)]
pub struct Hidden {
    /// The candidate name that should be named.
    pub expect: &'static str,
    /// How it is generated.
    pub truth: Truth,
    /// Functional form in words (README).
    pub form: &'static str,
}

impl Hidden {
    /// The truth parameters (all of them, defaults filled in).
    pub fn params(&self) -> Vec<(&'static str, f64)> {
        match &self.truth {
            Truth::Sim { name, params } => sim_effect(name, params)
                .map(|e| e.params())
                .unwrap_or_default(),
            Truth::Custom(e) => e.params(),
        }
    }

    /// The truth as an effect.
    ///
    /// # Errors
    /// sim's error when the truth parameters are not valid for the effect.
    pub fn effect(&self) -> std::result::Result<Box<dyn Effect>, SimError> {
        match &self.truth {
            Truth::Sim { name, params } => sim_effect(name, params),
            Truth::Custom(e) => Ok(e.clone()),
        }
    }
}

fn sim_effect(
    name: &str,
    params: &[(&'static str, f64)],
) -> std::result::Result<Box<dyn Effect>, SimError> {
    let map: BTreeMap<String, f64> = params.iter().map(|(k, v)| (k.to_string(), *v)).collect();
    effect_from_params(name, &map)
}

/// One synthetic session.
#[derive(Debug, Clone)]
pub struct SyntheticCase {
    /// File stem: says what is hidden (`clean` for nothing).
    pub name: String,
    /// One line for the README.
    pub description: String,
    /// Hidden effects.
    pub hidden: Vec<Hidden>,
    /// Noise seed.
    pub seed: u64,
    /// Whether a per-flute force trace (`NAME.forces.csv`) is written too.
    pub force_trace: bool,
    /// Robustness variant (hidden form differs from the candidate's).
    pub robustness: bool,
}

/// Generated data of one case.
#[derive(Debug, Clone)]
pub struct SyntheticData {
    /// The case name (file stem).
    pub name: String,
    /// The session `diagnose` reads (nominal model, no hidden effect).
    pub session: Session,
    /// `NAME.toml` text.
    pub session_toml: String,
    /// The measured points (`NAME.csv`).
    pub points: Vec<GroovePoint>,
    /// The per-flute force trace (`NAME.forces.csv`), when the case has one.
    pub forces: Option<Vec<FluteForcePoint>>,
}

impl SyntheticData {
    /// The files of the case, as (file name, contents): `NAME.toml`, `NAME.csv` (the
    /// measured-groove contract) and, with a force trace, `NAME.forces.csv` — the CSV text the
    /// table writer of `millcomp-datasets` writes.
    ///
    /// # Errors
    /// [`SyntheticError::Table`] when a table cannot be built or written.
    pub fn files(&self) -> Result<Vec<(String, String)>> {
        let csv = |file: String, table: std::result::Result<_, DatasetError>| {
            let mut buf = Vec::new();
            table
                .and_then(|t| millcomp_datasets::write_csv_to(&t, &mut buf))
                .map_err(|source| SyntheticError::Table {
                    file: file.clone(),
                    source,
                })?;
            let text = String::from_utf8(buf).unwrap_or_default();
            Ok::<_, SyntheticError>((file, text))
        };
        let name = &self.name;
        let mut out = vec![(format!("{name}.toml"), self.session_toml.clone())];
        out.push(csv(
            format!("{name}.csv"),
            measured_groove_table(name, &self.points),
        )?);
        if let Some(rows) = &self.forces {
            out.push(csv(
                format!("{name}.forces.csv"),
                force_trace_table(name, rows),
            )?);
        }
        Ok(out)
    }
}

struct G {
    pause_s: f64,
    pause_rpm: f64,
    rpm: f64,
    upfeed: f64,
    tilt: f64,
    coolant: Option<bool>,
    x0: f64,
    depth: DepthProfile,
}

fn ramp(a: f64, b: f64) -> DepthProfile {
    DepthProfile::Ramp {
        from_um: a,
        to_um: b,
    }
}
fn constant(d: f64) -> DepthProfile {
    DepthProfile::Constant { depth_um: d }
}
fn steps(s: &[(f64, f64)]) -> DepthProfile {
    DepthProfile::Steps { steps: s.to_vec() }
}

/// The common plan (module documentation), nominal model only.
pub fn base_session(name: &str, description: &str) -> Session {
    #[rustfmt::skip]
    let plan = [
        G { pause_s: 0.0, pause_rpm: 0.0, rpm: 10_000.0, upfeed: 10.0, tilt: 20.0, coolant: Some(false), x0: 0.0, depth: ramp(0.0, 80.0) },
        G { pause_s: 300.0, pause_rpm: 10_000.0, rpm: 24_000.0, upfeed: 10.0, tilt: 20.0, coolant: None, x0: 10.0, depth: constant(40.0) },
        G { pause_s: 600.0, pause_rpm: 24_000.0, rpm: 24_000.0, upfeed: 5.0, tilt: 30.0, coolant: None, x0: 20.0, depth: steps(&[(0.0, 20.0), (5.0, 40.0), (10.0, 60.0), (15.0, 80.0)]) },
        G { pause_s: 900.0, pause_rpm: 0.0, rpm: 36_000.0, upfeed: 10.0, tilt: 30.0, coolant: Some(true), x0: 30.0, depth: ramp(0.0, 80.0) },
        G { pause_s: 600.0, pause_rpm: 36_000.0, rpm: 36_000.0, upfeed: 10.0, tilt: 20.0, coolant: None, x0: 40.0, depth: constant(50.0) },
        G { pause_s: 1200.0, pause_rpm: 36_000.0, rpm: 10_000.0, upfeed: 5.0, tilt: 20.0, coolant: None, x0: 50.0, depth: ramp(80.0, 0.0) },
        G { pause_s: 600.0, pause_rpm: 0.0, rpm: 24_000.0, upfeed: 10.0, tilt: 30.0, coolant: None, x0: 60.0, depth: constant(30.0) },
        G { pause_s: 1800.0, pause_rpm: 24_000.0, rpm: 36_000.0, upfeed: 10.0, tilt: 20.0, coolant: None, x0: 70.0, depth: ramp(0.0, 80.0) },
        G { pause_s: 300.0, pause_rpm: 36_000.0, rpm: 10_000.0, upfeed: 10.0, tilt: 30.0, coolant: None, x0: 5.0, depth: steps(&[(0.0, 60.0), (10.0, 20.0)]) },
        G { pause_s: 900.0, pause_rpm: 10_000.0, rpm: 24_000.0, upfeed: 5.0, tilt: 20.0, coolant: None, x0: 35.0, depth: ramp(20.0, 70.0) },
        G { pause_s: 600.0, pause_rpm: 0.0, rpm: 36_000.0, upfeed: 5.0, tilt: 30.0, coolant: None, x0: 65.0, depth: constant(60.0) },
        G { pause_s: 1200.0, pause_rpm: 36_000.0, rpm: 10_000.0, upfeed: 10.0, tilt: 20.0, coolant: None, x0: 15.0, depth: constant(70.0) },
        G { pause_s: 600.0, pause_rpm: 24_000.0, rpm: 24_000.0, upfeed: 10.0, tilt: 30.0, coolant: None, x0: 45.0, depth: ramp(80.0, 10.0) },
        G { pause_s: 300.0, pause_rpm: 36_000.0, rpm: 36_000.0, upfeed: 10.0, tilt: 20.0, coolant: None, x0: 55.0, depth: steps(&[(0.0, 30.0), (10.0, 70.0)]) },
    ];
    let mut items = Vec::new();
    for (i, g) in plan.into_iter().enumerate() {
        if i > 0 {
            items.push(PlanItem::Pause(PauseSpec {
                duration_s: g.pause_s,
                speed_rpm: g.pause_rpm,
                coolant: None,
            }));
        }
        items.push(PlanItem::Groove(GrooveSpec {
            start_s: (i == 0).then_some(0.0),
            speed_rpm: g.rpm,
            upfeed_um: Some(g.upfeed),
            feed_mm_min: None,
            tilt_deg: g.tilt,
            coolant: g.coolant,
            length_mm: 20.0,
            x_offset_mm: g.x0,
            measure_every_mm: 1.0,
            depth: g.depth,
        }));
    }
    Session {
        name: name.into(),
        description: description.into(),
        tool: ToolSpec {
            radius_um: 400.0,
            wearland_um: 8.0,
            // 2 µm (not the 10 µm default): with 10 µm at 10 µm/rev runout saturates (ξ = 1) and
            // extra runout would be invisible
            runout_um: 2.0,
        },
        material: MaterialSpec {
            name: "S7".into(),
            w_mpa: None,
            e_gpa: None,
            mu_rake: None,
            mu_flank: None,
        },
        force_model: ForceModelSpec {
            force_scale: millcomp_sim::force::S7_GROOVE_FORCE_SCALE,
            ..ForceModelSpec::default()
        },
        stiffness: StiffnessSpec::default(),
        uncertainty: UncertaintySpec::default(),
        effects: Vec::new(),
        plan: items,
    }
}

// ---- robustness forms -------------------------------------------------------------------

/// Spindle growth with two thermal time constants (fast spindle, slow housing): the steady
/// growth `G·((rpm − onset)/(max − onset))₊` is reached through `share·lag(τ₁) + (1 − share)·lag(τ₂)`.
#[derive(Debug, Clone, PartialEq)]
pub struct TwoTauSpindleGrowth {
    /// Steady growth at `rpm_max` (µm).
    pub max_growth_um: f64,
    /// Onset speed (rpm).
    pub rpm_onset: f64,
    /// Speed of `max_growth_um` (rpm).
    pub rpm_max: f64,
    /// Fast time constant (s).
    pub tau1_s: f64,
    /// Slow time constant (s).
    pub tau2_s: f64,
    /// Share of the fast part.
    pub share1: f64,
}

impl Effect for TwoTauSpindleGrowth {
    fn name(&self) -> &'static str {
        "spindle_growth_two_tau"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("max_growth_um", self.max_growth_um),
            ("rpm_onset", self.rpm_onset),
            ("rpm_max", self.rpm_max),
            ("tau1_s", self.tau1_s),
            ("tau2_s", self.tau2_s),
            ("share1", self.share1),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> std::result::Result<(), SimError> {
        if let [g, r0, r1, t1, t2, s] = v {
            *self = TwoTauSpindleGrowth {
                max_growth_um: *g,
                rpm_onset: *r0,
                rpm_max: *r1,
                tau1_s: *t1,
                tau2_s: *t2,
                share1: *s,
            };
            Ok(())
        } else {
            Err(SimError::EffectParameter {
                effect: "spindle_growth_two_tau",
                param: format!("<{} values>", v.len()),
                message: "expected 6 parameter values".into(),
            })
        }
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        let ev: Vec<(f64, f64)> = ctx
            .spindle_events
            .iter()
            .map(|(t, rpm)| {
                (
                    *t,
                    self.max_growth_um
                        * ((rpm - self.rpm_onset) / (self.rpm_max - self.rpm_onset)).max(0.0),
                )
            })
            .collect();
        self.share1 * first_order_response(&ev, ctx.t_s, self.tau1_s)
            + (1.0 - self.share1) * first_order_response(&ev, ctx.t_s, self.tau2_s)
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
}

/// Tool wear growing as a power of the engaged length: `−W·(L/L_ref)^k` (k < 1: fast running-in,
/// no saturation).
#[derive(Debug, Clone, PartialEq)]
pub struct PowerLawWear {
    /// Wear at `ref_length_mm` (µm).
    pub wear_um: f64,
    /// Reference engaged length (mm).
    pub ref_length_mm: f64,
    /// Exponent k.
    pub exponent: f64,
}

impl Effect for PowerLawWear {
    fn name(&self) -> &'static str {
        "tool_wear_power_law"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("wear_um", self.wear_um),
            ("ref_length_mm", self.ref_length_mm),
            ("exponent", self.exponent),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> std::result::Result<(), SimError> {
        if let [w, l, k] = v {
            *self = PowerLawWear {
                wear_um: *w,
                ref_length_mm: *l,
                exponent: *k,
            };
            Ok(())
        } else {
            Err(SimError::EffectParameter {
                effect: "tool_wear_power_law",
                param: format!("<{} values>", v.len()),
                message: "expected 3 parameter values".into(),
            })
        }
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        -self.wear_um * (ctx.cut_length_mm.max(0.0) / self.ref_length_mm).powf(self.exponent)
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
}

/// A slideway bow that is not a parabola: the skewed cubic `a·(27/4)·u²(1 − u)` (maximum `a` at
/// u = 2/3 instead of the middle), u = (X − x0)/span.
#[derive(Debug, Clone, PartialEq)]
pub struct SkewedStraightness {
    /// Maximum deviation (µm).
    pub amplitude_um: f64,
    /// Span (mm).
    pub span_mm: f64,
    /// Span start (mm).
    pub x0_mm: f64,
}

impl Effect for SkewedStraightness {
    fn name(&self) -> &'static str {
        "slideway_straightness_skewed"
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("amplitude_um", self.amplitude_um),
            ("span_mm", self.span_mm),
            ("x0_mm", self.x0_mm),
        ]
    }
    fn set_params(&mut self, v: &[f64]) -> std::result::Result<(), SimError> {
        if let [a, s, x] = v {
            *self = SkewedStraightness {
                amplitude_um: *a,
                span_mm: *s,
                x0_mm: *x,
            };
            Ok(())
        } else {
            Err(SimError::EffectParameter {
                effect: "slideway_straightness_skewed",
                param: format!("<{} values>", v.len()),
                message: "expected 3 parameter values".into(),
            })
        }
    }
    fn depth_offset_um(&self, ctx: &EffectContext<'_>) -> f64 {
        let u = (ctx.machine_x_mm - self.x0_mm) / self.span_mm;
        if (0.0..=1.0).contains(&u) {
            self.amplitude_um * 6.75 * u * u * (1.0 - u)
        } else {
            0.0
        }
    }
    fn clone_box(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
}

// ---- cases --------------------------------------------------------------------------------

fn sim(expect: &'static str, params: Vec<(&'static str, f64)>, form: &'static str) -> Hidden {
    Hidden {
        expect,
        truth: Truth::Sim {
            name: expect,
            params,
        },
        form,
    }
}

/// All committed cases (seeds fixed: 7001, 7002, … in this order).
pub fn cases() -> Vec<SyntheticCase> {
    let coolant = || {
        sim(
            "coolant_thermal_drift",
            vec![("amplitude_um", 8.5), ("time_constant_s", 900.0)],
            "sim CoolantThermalDrift: A·first-order lag of the coolant state (002 §7.1: +8.5 µm, settled ≈ 45 min = 3τ)",
        )
    };
    let wear = || {
        sim(
            "tool_wear",
            vec![("max_wear_um", 8.0), ("length_scale_mm", 100.0)],
            "sim ToolWear: −W(1 − e^{−L/L0}) (002 §7.5: 8 µm over a test)",
        )
    };
    let mut v: Vec<(String, String, Vec<Hidden>, bool, bool)> = vec![
        (
            "clean".into(),
            "nothing hidden: nominal model + profilometer noise".into(),
            vec![],
            false,
            false,
        ),
        (
            "coolant_thermal_drift".into(),
            "coolant drift only".into(),
            vec![coolant()],
            false,
            false,
        ),
        (
            "spindle_thermal_growth".into(),
            "spindle thermal growth only".into(),
            vec![sim(
                "spindle_thermal_growth",
                vec![("max_growth_um", 20.0), ("time_constant_s", 600.0)],
                "sim SpindleThermalGrowth: first-order lag (τ) to G·((rpm − 16 000)/(50 000 − 16 000))₊ (002 §7.6, Tab. 5: up to +20 µm)",
            )],
            false,
            false,
        ),
        (
            "probe_tilt_offset".into(),
            "probe tip tilt only".into(),
            vec![sim(
                "probe_tilt_offset",
                vec![("alpha_deg", 0.107)],
                "sim ProbeTiltOffset: (D1 − D2)/2·tan α, D1 = 6, D2 = 1 mm, α = 0.107° → +4.67 µm (002 §7.3–7.4)",
            )],
            false,
            false,
        ),
        (
            "tool_wear".into(),
            "tool wear only".into(),
            vec![wear()],
            false,
            false,
        ),
        (
            "slideway_straightness".into(),
            "slideway straightness only".into(),
            vec![sim(
                "slideway_straightness",
                vec![("amplitude_um", 5.0)],
                "sim SlidewayStraightness: parabolic bow 5 µm over 90 mm (002 §7.2)",
            )],
            false,
            false,
        ),
        (
            "machine_compliance".into(),
            "machine compliance only".into(),
            vec![sim(
                "machine_compliance",
                vec![("stiffness_n_per_um", 10.0)],
                "sim MachineCompliance: −Fz/k_M, k_M = 10 N/µm (003 eqs 1–5)",
            )],
            false,
            false,
        ),
        (
            "flute_runout".into(),
            "flute runout only (depth data)".into(),
            vec![sim(
                "flute_runout",
                vec![("runout_um", 3.0)],
                "sim FluteRunout: extra peak chip force of the larger flute, −c_z·k_cz·d·(f/2)·min(r/f, 1), r = 3 µm (000 §4)",
            )],
            false,
            false,
        ),
        (
            "coolant_thermal_drift+tool_wear".into(),
            "two effects: coolant drift and tool wear (the example.toml truth)".into(),
            vec![coolant(), wear()],
            false,
            false,
        ),
        (
            "robust_spindle_thermal_growth_two_tau".into(),
            "robustness: spindle growth with two time constants (candidate has one)".into(),
            vec![Hidden {
                expect: "spindle_thermal_growth",
                truth: Truth::Custom(Box::new(TwoTauSpindleGrowth {
                    max_growth_um: 20.0,
                    rpm_onset: 16_000.0,
                    rpm_max: 50_000.0,
                    tau1_s: 240.0,
                    tau2_s: 1800.0,
                    share1: 0.6,
                })),
                form: "0.6·lag(τ1 = 240 s) + 0.4·lag(τ2 = 1800 s) to G·((rpm − 16 000)/34 000)₊, G = 20 µm",
            }],
            false,
            true,
        ),
        (
            "robust_tool_wear_power_law".into(),
            "robustness: wear as a power law of engaged length (candidate saturates exponentially)"
                .into(),
            vec![Hidden {
                expect: "tool_wear",
                truth: Truth::Custom(Box::new(PowerLawWear {
                    wear_um: 8.0,
                    ref_length_mm: 280.0,
                    exponent: 0.5,
                })),
                form: "−8 µm·(L/280 mm)^0.5 (8 µm at the end of the session)",
            }],
            false,
            true,
        ),
        (
            "robust_slideway_straightness_skewed".into(),
            "robustness: skewed (cubic) slideway bow (candidate is a symmetric parabola)".into(),
            vec![Hidden {
                expect: "slideway_straightness",
                truth: Truth::Custom(Box::new(SkewedStraightness {
                    amplitude_um: 5.0,
                    span_mm: 90.0,
                    x0_mm: 0.0,
                })),
                form: "5 µm·(27/4)·u²(1 − u), u = X/90 mm (maximum at X = 60 mm)",
            }],
            false,
            true,
        ),
        (
            "flute_runout_force".into(),
            "flute runout with a per-flute force trace (NAME.forces.csv)".into(),
            vec![sim(
                "flute_runout",
                vec![("runout_um", 3.0)],
                "sim FluteRunout on depth; forces from sim's force model with tool runout 2 + 3 µm (000 §4)",
            )],
            true,
            false,
        ),
    ];
    v.drain(..)
        .enumerate()
        .map(
            |(i, (name, description, hidden, force_trace, robustness))| SyntheticCase {
                name,
                description,
                hidden,
                seed: 7001 + i as u64,
                force_trace,
                robustness,
            },
        )
        .collect()
}

/// Offsets (µm) of the case's hidden effects at every planned point of `contexts` (sim's nominal
/// contexts of the session), noise-free.
///
/// # Errors
/// [`SyntheticError::Sim`] when a hidden effect's parameters are not valid.
pub fn hidden_offsets(case: &SyntheticCase, contexts: &SessionContexts) -> Result<Vec<f64>> {
    let mut out = vec![0.0; contexts.len()];
    for h in &case.hidden {
        let e = h.effect().map_err(|source| SyntheticError::Sim {
            case: case.name.clone(),
            what: format!("hidden effect {}", h.expect),
            source,
        })?;
        for (o, v) in out.iter_mut().zip(contexts.offsets_um(e.as_ref())) {
            *o += v;
        }
    }
    Ok(out)
}

/// Measured points for seeded sweeps without re-simulation: `base` (noise-free predictions of the
/// planned points, e.g. the nominal model's) with `offsets_um[i]` + N(0, σ²) noise (seeded) added
/// to the depth of point `i` (points beyond `offsets_um` are left as they are); no temperature.
pub fn resample(
    base: &[GroovePoint],
    offsets_um: &[f64],
    sigma_um: f64,
    seed: u64,
) -> Vec<GroovePoint> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, sigma_um.max(0.0))
        .unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("σ = 0 is valid"));
    let extra: Vec<f64> = offsets_um
        .iter()
        .map(|o| o + normal.sample(&mut rng))
        .collect();
    base.iter()
        .zip(extra.iter().chain(std::iter::repeat(&0.0)))
        .map(|(p, e)| GroovePoint {
            depth_meas_um: p.depth_meas_um + e,
            spindle_temp_c: None,
            ..*p
        })
        .collect()
}

/// Generates one case.
///
/// # Errors
/// [`SyntheticError::Sim`] when sim rejects the session or a hidden effect,
/// [`SyntheticError::Toml`] when the session cannot be serialised.
pub fn generate(case: &SyntheticCase) -> Result<SyntheticData> {
    let sim_err = |what: &str| {
        let what = what.to_string();
        move |source| SyntheticError::Sim {
            case: case.name.clone(),
            what,
            source,
        }
    };
    let session = base_session(
        &case.name,
        "Synthetic measured session (millcomp gen_synthetic). This file is the NOMINAL model only; \
         the effects hidden in the measured CSV are listed in README.md, not here.",
    );
    let mut truth = session.clone();
    let mut custom: Vec<Box<dyn Effect>> = Vec::new();
    for h in &case.hidden {
        match &h.truth {
            Truth::Sim { name, params } => truth.effects.push(EffectSpec {
                name: name.to_string(),
                enabled: true,
                params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            }),
            Truth::Custom(e) => custom.push(e.clone()),
        }
    }
    let noisy = simulate_session(
        &truth,
        &SimOptions {
            noise: Some(NoiseSpec {
                seed: case.seed,
                sigma: DEPTH_NOISE_UM,
            }),
        },
    )
    .map_err(sim_err("simulate the truth"))?;
    let clean =
        simulate_session(&truth, &SimOptions::default()).map_err(sim_err("simulate the truth"))?;
    let contexts = session.contexts().map_err(sim_err("nominal contexts"))?;
    let mut points: Vec<GroovePoint> = noisy;
    let mut truth_depth: Vec<f64> = clean.iter().map(|p| p.depth_meas_um).collect();
    for e in &custom {
        for (i, o) in contexts.offsets_um(e.as_ref()).into_iter().enumerate() {
            points[i].depth_meas_um += o;
            truth_depth[i] += o;
        }
    }
    for p in &mut points {
        // a thermocouple column would only appear when sim models the spindle: drop it so the
        // file's columns do not reveal what is hidden
        p.spindle_temp_c = None;
    }
    let mut forces = None;
    if case.force_trace {
        let extra: f64 = case
            .hidden
            .iter()
            .filter(|h| h.expect == "flute_runout")
            .flat_map(|h| h.params())
            .filter(|(k, _)| *k == "runout_um")
            .map(|(_, v)| v)
            .sum();
        let mut model = session.force_model().map_err(sim_err("force model"))?;
        model.tool.runout_um += extra;
        let mut rng = ChaCha8Rng::seed_from_u64(case.seed ^ 0xF0);
        let normal = Normal::new(0.0, FORCE_NOISE_N).map_err(|source| SyntheticError::Noise {
            sigma: FORCE_NOISE_N,
            source,
        })?;
        let mut rows = Vec::with_capacity(contexts.len());
        for (i, p) in contexts.points.iter().enumerate() {
            let c = CutConditions {
                depth_um: truth_depth[i].clamp(0.0, model.tool.radius_um),
                upfeed_um: p.upfeed_um,
                speed_rpm: p.speed_rpm,
                tilt_deg: p.tilt_deg,
            };
            let pk = model
                .per_flute_peaks(&c, PEAK_SAMPLES_PER_REV)
                .map_err(sim_err("per-flute peaks"))?;
            let flute1 = pk[0][2] + normal.sample(&mut rng);
            let flute2 = pk[1][2] + normal.sample(&mut rng);
            rows.push(FluteForcePoint {
                groove_id: p.groove_id,
                x_mm: p.x_mm,
                fz_peak_flute1_n: flute1,
                fz_peak_flute2_n: flute2,
            });
        }
        forces = Some(rows);
    }
    let body = toml::to_string(&session).map_err(|source| SyntheticError::Toml {
        file: format!("{}.toml", case.name),
        source,
    })?;
    let session_toml = format!(
        "# Synthetic groove session `{}` (schema: sim/SESSION.md), written by\n\
         # `{COMMAND}` (seed {}).\n\
         # Nominal model only: what is hidden in {}.csv is listed in README.md.\n\n{body}",
        case.name, case.seed, case.name
    );
    Ok(SyntheticData {
        name: case.name.clone(),
        session,
        session_toml,
        points,
        forces,
    })
}

/// A session whose plan separates no candidate from the nominal model's uncertainty (`diagnose`
/// says so instead of naming one): one 4 mm groove at one speed and one depth, measured every mm,
/// the coolant never switched; a 4.67 µm constant offset (the 002 §7.4 probe tilt) and the
/// profilometer's noise are hidden in it (seed 7099).
///
/// # Errors
/// [`SyntheticError::Sim`] when sim rejects the session.
pub fn cannot_separate_case() -> Result<SyntheticData> {
    let name = "plan_cannot_separate";
    let mut session = base_session(
        name,
        "One 4 mm groove at one speed and one depth: no candidate can be told from the nominal \
         model's uncertainty (SYNTHETIC; a 4.67 µm constant offset is hidden, README.md).",
    );
    session.plan = vec![PlanItem::Groove(GrooveSpec {
        start_s: Some(0.0),
        speed_rpm: 10_000.0,
        upfeed_um: Some(10.0),
        feed_mm_min: None,
        tilt_deg: 20.0,
        coolant: None,
        length_mm: 4.0,
        x_offset_mm: 30.0,
        measure_every_mm: 1.0,
        depth: constant(40.0),
    })];
    let contexts = session.contexts().map_err(|source| SyntheticError::Sim {
        case: name.into(),
        what: "plan".into(),
        source,
    })?;
    let base: Vec<GroovePoint> =
        simulate_session(&session, &SimOptions::default()).map_err(|source| {
            SyntheticError::Sim {
                case: name.into(),
                what: "nominal".into(),
                source,
            }
        })?;
    let points = resample(&base, &vec![4.67; contexts.len()], DEPTH_NOISE_UM, 7099);
    data_of(name, &session, 7099, points)
}

/// The committed variant `v` as files' data (`real_*`).
///
/// # Errors
/// As [`variants::draw`].
pub fn committed_variant_data(
    v: &variants::CommittedVariant,
) -> Result<(SyntheticData, variants::Variant)> {
    let mut session = variants::study_session();
    session.name = v.name.into();
    session.description =
        "Synthetic measured session drawn from the diagnose study's distribution \
        (synthetic/VARIANTS.md). This file is the NOMINAL model only; the truth is in README.md."
            .into();
    let variant = variants::draw(&session, &v.spec)?;
    let data = data_of(v.name, &session, v.spec.seed, variant.points.clone())?;
    Ok((data, variant))
}

fn data_of(
    name: &str,
    session: &Session,
    seed: u64,
    points: Vec<GroovePoint>,
) -> Result<SyntheticData> {
    let body = toml::to_string(session).map_err(|source| SyntheticError::Toml {
        file: format!("{name}.toml"),
        source,
    })?;
    Ok(SyntheticData {
        name: name.into(),
        session: session.clone(),
        session_toml: format!(
            "# Synthetic groove session `{name}` (schema: sim/SESSION.md), written by\n\
             # `{COMMAND}` (seed {seed}).\n\
             # Nominal model only: what is hidden in {name}.csv is listed in README.md.\n\n{body}"
        ),
        points,
        forces: None,
    })
}

/// README of `datasets/synthetic/`: the cases, and the committed variants with their drawn truth.
pub fn readme(
    cases: &[SyntheticCase],
    drawn: &[(variants::CommittedVariant, variants::Variant)],
) -> String {
    let mut s = String::from(
        "# datasets/synthetic/ — measured groove sessions with hidden effects (SYNTHETIC)\n\n\
         Generated by `cargo run -p millcomp-synthetic --bin gen_synthetic --release` \
         (`synthetic/src/bin/gen_synthetic.rs`, cases in `synthetic/src/lib.rs`); \
         deterministic (seeded), regenerate after changing sim. Each case is `NAME.toml` \
         (session file, nominal model only — schema `sim/SESSION.md`) beside `NAME.csv` \
         (measured-groove CSV contract, DESIGN.md); NAME says what is hidden (`clean`: nothing). \
         Try: `millcomp diagnose datasets/synthetic/tool_wear.toml datasets/synthetic/tool_wear.csv`.\n\n\
         ## Plan (all cases)\n\
         14 grooves × 21 points (20 mm, every 1 mm) = 294 rows over ≈ 2.8 h in S7, 0.8 mm ball-end tool \
         (wearland 8 µm, runout 2 µm), force scale 3.7396 (sim `S7_GROOVE_FORCE_SCALE`). Pauses of \
         5–30 min with the spindle running or stopped; speeds 10 000 / 24 000 / 36 000 rpm; coolant \
         switched on at groove 3 (t ≈ 30 min); tilts 20° / 30°; upfeeds 5 / 10 µm/rev; ramps, \
         constants and steps in depth; groove offsets over machine X 0–90 mm.\n\
         Depth noise: Gaussian σ = 0.1 µm (profilometer, 002 §7.9). Force noise (force trace): \
         σ = 0.04 N per flute peak (000 §7.2 sensor).\n\n\
         ## Cases\n\n| NAME | hidden effect(s) → expected name | truth parameters | form | seed |\n|---|---|---|---|---|\n",
    );
    for c in cases {
        let hidden = if c.hidden.is_empty() {
            "none → `none`".to_string()
        } else {
            c.hidden
                .iter()
                .map(|h| format!("`{}`", h.expect))
                .collect::<Vec<_>>()
                .join(" + ")
        };
        let params = c
            .hidden
            .iter()
            .map(|h| {
                h.params()
                    .iter()
                    .map(|(k, v)| format!("{k} = {v}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .collect::<Vec<_>>()
            .join("; ");
        let form = c
            .hidden
            .iter()
            .map(|h| h.form)
            .collect::<Vec<_>>()
            .join("; ");
        s.push_str(&format!(
            "| `{}` | {} | {} | {} | {} |\n",
            c.name,
            hidden,
            if params.is_empty() {
                "–".into()
            } else {
                params
            },
            if form.is_empty() {
                c.description.clone()
            } else {
                form
            },
            c.seed
        ));
    }
    s.push_str(
        "\nRobustness cases (`robust_*`) hide a functional form that differs from the candidate's; \
         diagnose should still name the effect in the second column first.\n\n\
         ## Force trace (`flute_runout_force.forces.csv`)\n\
         Flute runout shows mainly in the force asymmetry between the two flutes (000 §4). One row \
         per measured point: `groove_id, x_mm, fz_peak_flute1_n, fz_peak_flute2_n` — the peak z-force \
         of each flute over the revolution in which the point was cut (flute 2 is the one runout \
         makes cut more), from sim's force model at the true depth with tool runout 2 + 3 µm, plus \
         noise. `diagnose` tests `flute_runout` on `flute2 − flute1` (diagnose/src/force_channel.rs).\n",
    );
    s.push_str(
        "\n## Data as a user has them (`real_*`, issue 15)\n\
         Drawn by `millcomp_synthetic::variants` from the diagnose study's distribution \
         (`synthetic/VARIANTS.md`, development seeds): the nominal model in `NAME.toml` is off \
         (force scale ±5 %, stiffnesses ±10 %, wearland ±2 µm, touch-off), every groove has a \
         random offset (σ = 0.5 µm), and the hidden effects have shapes that were none of the \
         candidate families' when the distribution was fixed (some are family shapes since, \
         `synthetic/VARIANTS.md`). The truth:\n\n| NAME | what it shows | seed | nominal errors | hidden |\n|---|---|---|---|---|\n",
    );
    for (c, v) in drawn {
        let e = &v.errors;
        s.push_str(&format!(
            "| `{}` | {} | {} | force ×{:.4}, axial ×{:.4}, radial ×{:.4}, wearland {:+.3} µm, touch-off {:+.3} µm | {} |\n",
            c.name,
            c.description,
            c.spec.seed,
            e.force_scale_factor,
            e.axial_stiffness_factor,
            e.radial_stiffness_factor,
            e.wearland_delta_um,
            e.touch_off_um,
            if v.hidden.is_empty() {
                "none → `none`".to_string()
            } else {
                v.hidden
                    .iter()
                    .map(variants::describe)
                    .collect::<Vec<_>>()
                    .join("; ")
            }
        ));
    }
    s.push_str(
        "\n## A plan that separates nothing (`plan_cannot_separate`)\n\
         One 4 mm groove at 10 000 rpm and 40 µm, measured every mm, the coolant never switched: \
         every candidate is either not excited or a change of the nominal model. Hidden: a \
         4.67 µm constant offset (002 §7.4) and 0.1 µm noise (seed 7099). `diagnose` says the plan \
         cannot separate any candidate instead of naming one.\n",
    );
    s
}
