//! Seeded variants of a measured session for the real-data study of `diagnose` (issue 15): a
//! nominal model that is off, effects hidden with shapes other than the candidates' forms, and
//! groove-to-groove scatter. The distribution is documented, and fixed, in `synthetic/VARIANTS.md`
//! (version [`SPEC_VERSION`]); this module is its one implementation.
//!
//! A variant is drawn from one seed ([`draw`]): the truth session is the nominal one with its force
//! scale, axial and radial stiffness and wearland changed ([`NominalErrors`]); sim plays its plan out
//! ([`Session::contexts`]: the static deflection at the *true* force model and stiffness); the
//! hidden effects ([`HiddenTruth`], each a [`Shape`]) are evaluated on those true contexts; a
//! touch-off error, one random offset per groove and the profilometer noise are added. What
//! `diagnose` may see is [`Variant::points`] and the nominal session — never the rest.
//!
//! ```
//! use millcomp_synthetic::variants::{Row, VariantSpec, draw, study_session};
//! let nominal = study_session();
//! let v = draw(&nominal, &VariantSpec { row: Row::Single, effects: vec!["tool_wear"], seed: 9_000_001 })
//!     .unwrap();
//! assert_eq!(v.points.len(), 294);
//! assert_eq!(v.hidden[0].effect, "tool_wear");
//! // the same seed replays the same variant
//! let again = draw(&nominal, &VariantSpec { row: Row::Single, effects: vec!["tool_wear"], seed: 9_000_001 })
//!     .unwrap();
//! assert_eq!(v.points, again.points);
//! // 0.5–2× the 002 magnitude: wear at the end of the session 4–16 µm
//! assert!((0.5..=2.0).contains(&v.hidden[0].amplitude_factor));
//! ```

use std::f64::consts::PI;

use millcomp_sim::SimError;
use millcomp_sim::effects::{
    Effect, EffectContext, FluteRunout, default_effect, first_order_response,
};
use millcomp_sim::session::{GroovePoint, PointContext, Session, SessionContexts};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::{Result, SyntheticError};

/// Version of the distribution of `synthetic/VARIANTS.md`; changed only with a note there saying
/// what changed and why.
pub const SPEC_VERSION: u32 = 1;

/// The effects, in the order of the study's strata (DESIGN.md names).
pub const EFFECTS: [&str; 7] = millcomp_sim::effects::EFFECT_NAMES;

/// Groove-to-groove scatter (µm, one SD): issue 15 (002 §7.9: 60 grooves at 52.7 ± 1 µm).
pub const GROOVE_SCATTER_UM: f64 = 0.5;
/// Depth noise (µm): sim's profilometer σ (002 §7.9).
pub const DEPTH_NOISE_UM: f64 = millcomp_sim::sensors::PROFILOMETER_SIGMA_UM;
/// Force-scale error: uniform in ±5 % (issue 15).
pub const FORCE_SCALE_RANGE: f64 = 0.05;
/// Axial and radial stiffness errors: independent, uniform in ±10 % (issue 15).
pub const STIFFNESS_RANGE: f64 = 0.10;
/// Wearland error: uniform in ±2 µm (issue 15).
pub const WEARLAND_RANGE_UM: f64 = 2.0;
/// Touch-off error: uniform in ±√3 µm, SD 1 µm (002 §4: positioning repeatability ≈ 1 µm).
pub const TOUCH_OFF_RANGE_UM: f64 = 1.732_050_807_568_877_2;
/// Effect amplitudes: the 002 magnitude times a factor log-uniform in [0.5, 2] (issue 15).
pub const AMPLITUDE_RANGE: (f64, f64) = (0.5, 2.0);

/// The 002 magnitude each amplitude factor multiplies (what "1×" means, `VARIANTS.md`).
pub fn reference_magnitude(effect: &str) -> f64 {
    match effect {
        // +8.5 µm, 95 % of it 45 min after the coolant is switched on (002 §7.1)
        "coolant_thermal_drift" => 8.5,
        // +20 µm steady growth at 50 000 rpm (002 §7.6, Tab. 5)
        "spindle_thermal_growth" => 20.0,
        // (6 − 1)/2·tan 0.107° = 4.67 µm (002 §7.3–7.4)
        "probe_tilt_offset" => 4.67,
        // 8 µm shorter at the end of the test (002 §7.5)
        "tool_wear" => 8.0,
        // 5 µm bow over 90 mm (002 §4.5)
        "slideway_straightness" => 5.0,
        // machine compliance 0.1 µm/N (k_M = 10 N/µm, sim's default; 003 gives no value)
        "machine_compliance" => 0.1,
        // 3 µm extra runout (000 §4, sim's default)
        "flute_runout" => 3.0,
        _ => f64::NAN,
    }
}

/// Which row of the study a variant belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Row {
    /// One hidden effect, with a shape other than the candidates' forms.
    Single,
    /// Two hidden effects, each with a shape other than the candidates' forms.
    Two,
    /// Nothing hidden (nominal errors, touch-off, scatter and noise only).
    None,
    /// One hidden effect with the candidate family's reference form (sim's effect), for the
    /// coverage of the parameter intervals.
    Matched,
    /// Added after version 1's study (`VARIANTS.md`, "Row `measured_stiffness`"): the session
    /// states the axial and radial stiffness from a load–deflection test (prior SD
    /// [`MEASURED_STIFFNESS_PCT`] %, [`measured_stiffness_session`]) and the truth's stiffness
    /// errors are drawn within it; even variants hide `machine_compliance` (a non-candidate
    /// shape, as in [`Row::Single`]), odd ones nothing.
    MeasuredStiffness,
}

/// Which block of seeds a run uses (`VARIANTS.md`, "Seeds").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SeedBlock {
    /// Version 1's study seeds (1 000 000 + k … 4 000 000 + k): run for the first study and
    /// looked at since — kept for comparison with it.
    Study,
    /// Fresh study seeds (5 000 000 + k … 8 000 000 + k), first run after the second round of
    /// development: the honest estimate of that version of `diagnose` (looked at since).
    Fresh,
    /// The third round's fresh seeds (11 000 000 + k … 14 500 000 + k), first run after the third
    /// round of development (the leave-one-groove-out step): the honest estimate of that version.
    Third,
    /// The fifth round's fresh seeds (15 000 000 + k … 18 500 000 + k), first run after the fifth
    /// round of development (compliance past a preload, runout changing with depth): the honest
    /// estimate of that version. (The fourth round changed no name and had no block.)
    Fifth,
    /// The sixth round's fresh seeds (19 000 000 + k … 22 500 000 + k), first run after the sixth
    /// round of development (a compliance that varies along X): the honest estimate of that
    /// version.
    Sixth,
    /// The seventh round's fresh seeds (23 000 000 + k … 26 500 000 + k), first run after the
    /// seventh round of development (the compliance's spline along X as flexible as the
    /// straightness's): the honest estimate of that version.
    Seventh,
    /// The eighth round's fresh seeds (27 000 000 + k … 30 500 000 + k), first run after the
    /// eighth round of development (a monotone spline among the wear's shapes): the honest
    /// estimate of that version.
    Eighth,
    /// The ninth round's fresh seeds (31 000 000 + k … 34 500 000 + k), first run after the
    /// ninth round of development (each round's threshold simulated instead of Bonferroni's):
    /// the honest estimate of that version.
    Ninth,
    /// Development seeds (9 000 000 + 100 000·row + k): tuning and tests.
    Dev,
}

impl SeedBlock {
    /// Label.
    pub fn name(self) -> &'static str {
        match self {
            SeedBlock::Study => "study (version 1's, looked at)",
            SeedBlock::Fresh => "fresh study (second round's)",
            SeedBlock::Third => "third round's fresh study",
            SeedBlock::Fifth => "fifth round's fresh study",
            SeedBlock::Sixth => "sixth round's fresh study",
            SeedBlock::Seventh => "seventh round's fresh study",
            SeedBlock::Eighth => "eighth round's fresh study",
            SeedBlock::Ninth => "ninth round's fresh study",
            SeedBlock::Dev => "development",
        }
    }
}

impl Row {
    /// Seed of the first variant of the row in the study (`VARIANTS.md`); variant k has seed
    /// `base + k`. Development runs use [`DEV_SEED_BASE`].
    pub fn study_seed_base(self) -> u64 {
        self.seed_base(SeedBlock::Study)
    }

    /// Seed of the first variant of the row in a block (`VARIANTS.md`, "Seeds").
    pub fn seed_base(self, block: SeedBlock) -> u64 {
        let k = match self {
            Row::Single => 0,
            Row::Two => 1,
            Row::None => 2,
            Row::Matched => 3,
            Row::MeasuredStiffness => 4,
        };
        let start = match block {
            SeedBlock::Dev => return DEV_SEED_BASE + 100_000 * k,
            SeedBlock::Study => 1_000_000,
            SeedBlock::Fresh => 5_000_000,
            SeedBlock::Third => 11_000_000,
            SeedBlock::Fifth => 15_000_000,
            SeedBlock::Sixth => 19_000_000,
            SeedBlock::Seventh => 23_000_000,
            SeedBlock::Eighth => 27_000_000,
            SeedBlock::Ninth => 31_000_000,
        };
        // a million seeds per row; the added row has no version-1 seeds: its block continues
        // after `matched`'s
        start + 1_000_000 * k - u64::from(k == 4) * 500_000
    }

    /// Row label.
    pub fn name(self) -> &'static str {
        match self {
            Row::Single => "single",
            Row::Two => "two",
            Row::None => "none",
            Row::Matched => "matched",
            Row::MeasuredStiffness => "measured_stiffness",
        }
    }

    /// The nominal session `diagnose` is given for this row's variants: [`study_session`], or
    /// for [`Row::MeasuredStiffness`] [`measured_stiffness_session`].
    pub fn nominal_session(self) -> Session {
        match self {
            Row::MeasuredStiffness => measured_stiffness_session(),
            _ => study_session(),
        }
    }

    /// Half-range of the truth's axial and radial stiffness errors (uniform, relative).
    pub fn stiffness_range(self) -> f64 {
        match self {
            Row::MeasuredStiffness => MEASURED_STIFFNESS_PCT / 100.0 * 3f64.sqrt(),
            _ => STIFFNESS_RANGE,
        }
    }
}

/// Seeds for development and tests (never the study's): `DEV_SEED_BASE + k`.
pub const DEV_SEED_BASE: u64 = 9_000_000;

/// What to draw: the row, its hidden effects and the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct VariantSpec {
    /// The row.
    pub row: Row,
    /// Hidden effects (none for [`Row::None`]).
    pub effects: Vec<&'static str>,
    /// Seed of everything random in the variant.
    pub seed: u64,
}

/// The stratified list of a row (`VARIANTS.md`): single and matched rows cycle through the seven
/// effects, the two-effect row through the 21 unordered pairs; variant k has seed
/// `seed_base + k`.
pub fn row_specs(row: Row, n: usize, seed_base: u64) -> Vec<VariantSpec> {
    let pairs: Vec<(usize, usize)> = (0..EFFECTS.len())
        .flat_map(|a| (a + 1..EFFECTS.len()).map(move |b| (a, b)))
        .collect();
    (0..n)
        .map(|k| VariantSpec {
            row,
            effects: match row {
                Row::Single | Row::Matched => vec![EFFECTS[k % EFFECTS.len()]],
                Row::Two => {
                    let (a, b) = pairs[k % pairs.len()];
                    vec![EFFECTS[a], EFFECTS[b]]
                }
                Row::None => Vec::new(),
                Row::MeasuredStiffness => {
                    if k % 2 == 0 {
                        vec!["machine_compliance"]
                    } else {
                        Vec::new()
                    }
                }
            },
            seed: seed_base + k as u64,
        })
        .collect()
}

/// How the truth's nominal model differs from the session file's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NominalErrors {
    /// True force scale / nominal.
    pub force_scale_factor: f64,
    /// True axial stiffness / nominal.
    pub axial_stiffness_factor: f64,
    /// True radial stiffness / nominal.
    pub radial_stiffness_factor: f64,
    /// True wearland − nominal (µm).
    pub wearland_delta_um: f64,
    /// Touch-off error (µm, + = deeper grooves).
    pub touch_off_um: f64,
}

/// A hidden effect's shape and parameters (`VARIANTS.md` lists each with its physics).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A sim effect (the candidate family's reference form; [`Row::Matched`] and probe tilt).
    Sim(SimEffect),
    /// Coolant: first-order lag delayed by a dead time (transport of the coolant to the column).
    CoolantDeadTime {
        /// Final drift scale (µm).
        gain_um: f64,
        /// Time constant (s).
        tau_s: f64,
        /// Dead time (s).
        dead_s: f64,
    },
    /// Coolant: a quick lag plus a slow linear drift (pump heating the fluid, 002 §4.7).
    CoolantLagRamp {
        /// Scale (µm).
        gain_um: f64,
        /// Lag time constant (s).
        tau_s: f64,
        /// Share of the ramp (µm per hour of coolant, relative to the gain).
        ramp_per_h: f64,
    },
    /// Coolant: diffusion-like step response `1 − exp(−√(t/τ))`.
    CoolantDiffusion {
        /// Scale (µm).
        gain_um: f64,
        /// Time scale (s).
        tau_s: f64,
    },
    /// Spindle: heats with τ_heat and cools with a slower τ_cool (air circuit closed at rest,
    /// 002 §7.6); steady growth linear above the onset.
    SpindleAsymmetric {
        /// Steady growth at 50 000 rpm (µm).
        growth_um: f64,
        /// Onset (rpm).
        onset_rpm: f64,
        /// Heating time constant (s).
        tau_heat_s: f64,
        /// Cooling time constant (s).
        tau_cool_s: f64,
    },
    /// Spindle: steady growth saturating with speed, `G·tanh((rpm − onset)₊/scale)`, one lag.
    SpindleSaturating {
        /// Gain (µm).
        gain_um: f64,
        /// Onset (rpm).
        onset_rpm: f64,
        /// Speed scale (rpm).
        scale_rpm: f64,
        /// Time constant (s).
        tau_s: f64,
    },
    /// Spindle: linear gain above the onset, one lag delayed by a dead time (conduction from the
    /// bearings to the tool).
    SpindleDeadTime {
        /// Steady growth at 50 000 rpm (µm).
        growth_um: f64,
        /// Onset (rpm).
        onset_rpm: f64,
        /// Time constant (s).
        tau_s: f64,
        /// Dead time (s).
        dead_s: f64,
    },
    /// Wear: fast running-in then steady linear wear (the first two stages of the wear curve).
    WearRunningIn {
        /// Scale (µm).
        gain_um: f64,
        /// Running-in length (mm).
        running_in_mm: f64,
        /// Linear wear rate relative to the gain (1/mm).
        rate_per_mm: f64,
    },
    /// Wear driven by load: saturating in the cumulative force × engaged length.
    WearLoadDriven {
        /// Scale (µm).
        gain_um: f64,
        /// Load-length scale (N·mm).
        scale_n_mm: f64,
    },
    /// Wear accelerating after a cut length (logistic), zero at L = 0.
    WearLogistic {
        /// Scale (µm).
        gain_um: f64,
        /// Mid-point (mm).
        mid_mm: f64,
        /// Width (mm).
        width_mm: f64,
    },
    /// Straightness: a local dip or bump (worn guideway), Gaussian in machine X. Every
    /// straightness shape is zero at `anchor_mm`, the start of the measured X range, where the
    /// tool length is taken to be corrected (`VARIANTS.md`).
    StraightnessBump {
        /// Height (µm, + = deeper).
        height_um: f64,
        /// Machine X where the deviation is zero (mm).
        anchor_mm: f64,
        /// Centre (mm).
        centre_mm: f64,
        /// Width (mm, SD).
        width_mm: f64,
    },
    /// Straightness: waviness `A·sin(2πX/P + φ)`.
    StraightnessWave {
        /// Amplitude (µm).
        amplitude_um: f64,
        /// Machine X where the deviation is zero (mm).
        anchor_mm: f64,
        /// Period (mm).
        period_mm: f64,
        /// Phase (rad).
        phase_rad: f64,
    },
    /// Straightness: a roof (two straight guideway segments meeting at a kink).
    StraightnessKink {
        /// Height at the kink (µm).
        height_um: f64,
        /// Machine X where the deviation is zero (mm).
        anchor_mm: f64,
        /// Kink position (mm).
        kink_mm: f64,
        /// Half-width of the roof (mm).
        half_width_mm: f64,
    },
    /// Compliance stiffening less than linearly: `−c·F·(F/F_ref)^e`.
    CompliancePower {
        /// Compliance at F_ref (µm/N).
        compliance_um_per_n: f64,
        /// Reference force (N).
        ref_n: f64,
        /// Exponent e.
        exponent: f64,
    },
    /// Compliance varying with machine X: sim's `MachineCompliance` with a span and a period.
    CompliancePosition {
        /// Mean stiffness (N/µm).
        stiffness_n_per_um: f64,
        /// Stiffness span (N/µm).
        span_n_per_um: f64,
        /// Period (mm).
        period_mm: f64,
    },
    /// Compliance with a dead band: only the force above F0 deflects the machine.
    ComplianceDeadband {
        /// Compliance above the band (µm/N).
        compliance_um_per_n: f64,
        /// Dead band (N).
        band_n: f64,
    },
    /// Runout growing with speed (dynamic unbalance): `r(rpm) = r0·(1 + b·(rpm/36 000)²)`.
    RunoutSpeed {
        /// Runout at rest (µm).
        runout_um: f64,
        /// Speed coefficient b.
        speed_coeff: f64,
    },
    /// Runout effect growing faster than the depth: depth^(1+e) instead of depth.
    RunoutDepthPower {
        /// Runout (µm).
        runout_um: f64,
        /// Reference depth (µm).
        ref_depth_um: f64,
        /// Exponent e.
        exponent: f64,
    },
    /// Runout growing with engaged length (collet loosening): `r(L) = r0·(0.5 + L/L_end)`.
    RunoutGrowing {
        /// Runout scale (µm).
        runout_um: f64,
        /// Engaged length at the end of the session (mm).
        end_mm: f64,
    },
}

/// A sim effect with its parameters (the family's reference form).
#[derive(Debug, Clone, PartialEq)]
pub struct SimEffect {
    /// Effect name.
    pub name: &'static str,
    /// All its parameters, in `Effect::params` order.
    pub params: Vec<(&'static str, f64)>,
}

/// One hidden effect of a variant.
#[derive(Debug, Clone, PartialEq)]
pub struct HiddenTruth {
    /// The effect (DESIGN.md name) it should be named as.
    pub effect: &'static str,
    /// Shape label (`VARIANTS.md`).
    pub shape: &'static str,
    /// The amplitude factor (× the 002 magnitude, [`reference_magnitude`]).
    pub amplitude_factor: f64,
    /// The shape and its parameters.
    pub truth: Shape,
    /// For [`Row::Matched`]: the truth in the diagnose family's reference parameters (names of
    /// the reference shape), for the coverage of the intervals.
    pub family_params: Vec<(&'static str, f64)>,
}

/// One drawn variant: its truth and what a user would measure.
#[derive(Debug, Clone)]
pub struct Variant {
    /// What was drawn.
    pub spec: VariantSpec,
    /// The nominal model's errors.
    pub errors: NominalErrors,
    /// Hidden effects.
    pub hidden: Vec<HiddenTruth>,
    /// Offsets (µm) of each hidden effect at every point, noise-free.
    pub hidden_offsets_um: Vec<Vec<f64>>,
    /// Random offset of each groove (µm).
    pub groove_offsets_um: Vec<f64>,
    /// The measured points (the only thing diagnose sees, with the nominal session).
    pub points: Vec<GroovePoint>,
}

/// The nominal session of the study: the common plan of the committed cases (`base_session`,
/// 14 grooves, 294 points) with the default `[uncertainty]` (whose SDs are those of the error
/// distributions drawn here, `VARIANTS.md`).
pub fn study_session() -> Session {
    crate::base_session(
        "study",
        "Nominal model of the diagnose study (issue 15): the truth of each variant is drawn by \
         millcomp_synthetic::variants (synthetic/VARIANTS.md).",
    )
}

/// Prior SD (%) of the axial and radial stiffness that a load–deflection test of the tool gives
/// (row [`Row::MeasuredStiffness`]): an assumption — a known load and a dial gauge at the tip
/// read the tool's stiffness to about ±1.7 % (uniform, SD 1 %).
pub const MEASURED_STIFFNESS_PCT: f64 = 1.0;

/// The study's nominal session with the tool's axial and radial stiffness measured by a
/// load–deflection test: its `[uncertainty]` states them to [`MEASURED_STIFFNESS_PCT`] % (the
/// other priors as [`study_session`]). Row [`Row::MeasuredStiffness`].
pub fn measured_stiffness_session() -> Session {
    let mut s = crate::base_session(
        "study_measured_stiffness",
        "Nominal model of the diagnose study (issue 15) with the tool's stiffness measured by a \
         load-deflection test (prior SD 1 %): row measured_stiffness of synthetic/VARIANTS.md.",
    );
    s.uncertainty.axial_stiffness_pct = MEASURED_STIFFNESS_PCT;
    s.uncertainty.radial_stiffness_pct = MEASURED_STIFFNESS_PCT;
    s
}

/// Response at `t` of a linear system with unit step response `h` to a piecewise-constant input
/// given as `(t_start, u)` events (u = 0 before the first): `Σ_k (u_k − u_{k−1})·h(t − t_k)`.
pub fn step_superposition(events: &[(f64, f64)], t: f64, h: impl Fn(f64) -> f64) -> f64 {
    let mut prev = 0.0;
    let mut out = 0.0;
    for &(te, u) in events {
        if te > t {
            break;
        }
        out += (u - prev) * h(t - te);
        prev = u;
    }
    out
}

/// First-order state that rises towards its target with `tau_up` and falls with `tau_down`
/// (piecewise-constant target given as events, 0 before the first).
pub fn asymmetric_lag(events: &[(f64, f64)], t: f64, tau_up: f64, tau_down: f64) -> f64 {
    let mut s = 0.0;
    let mut t_prev: Option<f64> = None;
    let mut target = 0.0;
    let step = |s: f64, target: f64, dt: f64| {
        let tau = if target >= s { tau_up } else { tau_down };
        target + (s - target) * (-dt / tau).exp()
    };
    for &(te, u) in events {
        if te > t {
            break;
        }
        if let Some(tp) = t_prev {
            s = step(s, target, te - tp);
        }
        t_prev = Some(te);
        target = u;
    }
    if let Some(tp) = t_prev {
        s = step(s, target, t - tp);
    }
    s
}

fn sim_err(what: &str) -> impl FnOnce(SimError) -> SyntheticError + '_ {
    move |source| SyntheticError::Sim {
        case: "variant".into(),
        what: what.into(),
        source,
    }
}

fn coolant_events(c: &SessionContexts) -> Vec<(f64, f64)> {
    c.timeline
        .coolant_events
        .iter()
        .map(|(t, on)| (*t, if *on { 1.0 } else { 0.0 }))
        .collect()
}

fn lag_step(tau: f64) -> impl Fn(f64) -> f64 {
    move |dt: f64| 1.0 - (-dt.max(0.0) / tau).exp()
}

fn linear_gain(growth_um: f64, onset_rpm: f64) -> impl Fn(f64) -> f64 {
    move |rpm: f64| growth_um * ((rpm - onset_rpm) / (50_000.0 - onset_rpm)).max(0.0)
}

impl Shape {
    /// Offsets (µm, + = deeper) at every point of `c` (the truth's contexts).
    ///
    /// # Errors
    /// [`SyntheticError::Sim`] when a sim effect rejects its parameters.
    pub fn offsets(&self, c: &SessionContexts) -> Result<Vec<f64>> {
        let pts = &c.points;
        let spindle = |gain: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
            c.timeline
                .spindle_events
                .iter()
                .map(|(t, rpm)| (*t, gain(*rpm)))
                .collect()
        };
        let per_point = |f: &dyn Fn(&PointContext) -> f64| pts.iter().map(f).collect::<Vec<f64>>();
        Ok(match self {
            Shape::Sim(s) => {
                let mut e = default_effect(s.name).map_err(sim_err("hidden sim effect"))?;
                let values: Vec<f64> = s.params.iter().map(|(_, v)| *v).collect();
                e.set_params(&values)
                    .map_err(sim_err("hidden sim effect"))?;
                c.offsets_um(e.as_ref())
            }
            Shape::CoolantDeadTime {
                gain_um,
                tau_s,
                dead_s,
            } => {
                let ev = coolant_events(c);
                let h = lag_step(*tau_s);
                per_point(&|p| gain_um * step_superposition(&ev, p.t_s, |dt| h(dt - dead_s)))
            }
            Shape::CoolantLagRamp {
                gain_um,
                tau_s,
                ramp_per_h,
            } => {
                let ev = coolant_events(c);
                let h = lag_step(*tau_s);
                per_point(&|p| {
                    gain_um * step_superposition(&ev, p.t_s, |dt| h(dt) + ramp_per_h * dt / 3600.0)
                })
            }
            Shape::CoolantDiffusion { gain_um, tau_s } => {
                let ev = coolant_events(c);
                per_point(&|p| {
                    gain_um
                        * step_superposition(&ev, p.t_s, |dt| {
                            1.0 - (-(dt.max(0.0) / tau_s).sqrt()).exp()
                        })
                })
            }
            Shape::SpindleAsymmetric {
                growth_um,
                onset_rpm,
                tau_heat_s,
                tau_cool_s,
            } => {
                let ev = spindle(&linear_gain(*growth_um, *onset_rpm));
                per_point(&|p| asymmetric_lag(&ev, p.t_s, *tau_heat_s, *tau_cool_s))
            }
            Shape::SpindleSaturating {
                gain_um,
                onset_rpm,
                scale_rpm,
                tau_s,
            } => {
                let ev =
                    spindle(&|rpm: f64| gain_um * ((rpm - onset_rpm).max(0.0) / scale_rpm).tanh());
                per_point(&|p| first_order_response(&ev, p.t_s, *tau_s))
            }
            Shape::SpindleDeadTime {
                growth_um,
                onset_rpm,
                tau_s,
                dead_s,
            } => {
                let ev = spindle(&linear_gain(*growth_um, *onset_rpm));
                let h = lag_step(*tau_s);
                per_point(&|p| step_superposition(&ev, p.t_s, |dt| h(dt - dead_s)))
            }
            Shape::WearRunningIn {
                gain_um,
                running_in_mm,
                rate_per_mm,
            } => per_point(&|p| {
                let l = p.cut_length_mm.max(0.0);
                -gain_um * ((1.0 - (-l / running_in_mm).exp()) + rate_per_mm * l)
            }),
            Shape::WearLoadDriven {
                gain_um,
                scale_n_mm,
            } => cumulative_load_n_mm(pts)
                .into_iter()
                .map(|e| -gain_um * (1.0 - (-e / scale_n_mm).exp()))
                .collect(),
            Shape::WearLogistic {
                gain_um,
                mid_mm,
                width_mm,
            } => {
                let s = |l: f64| 1.0 / (1.0 + (-(l - mid_mm) / width_mm).exp());
                per_point(&|p| -gain_um * (s(p.cut_length_mm.max(0.0)) - s(0.0)))
            }
            Shape::StraightnessBump { anchor_mm, .. }
            | Shape::StraightnessWave { anchor_mm, .. }
            | Shape::StraightnessKink { anchor_mm, .. } => {
                let zero = self.straightness_at(*anchor_mm);
                per_point(&|p| self.straightness_at(p.machine_x_mm) - zero)
            }
            Shape::CompliancePower {
                compliance_um_per_n,
                ref_n,
                exponent,
            } => per_point(&|p| {
                let f = p.force_z_n.max(0.0);
                -compliance_um_per_n * f * (f / ref_n).powf(*exponent)
            }),
            Shape::CompliancePosition {
                stiffness_n_per_um,
                span_n_per_um,
                period_mm,
            } => per_point(&|p| {
                let k = stiffness_n_per_um
                    + 0.5 * span_n_per_um * (2.0 * PI * p.machine_x_mm / period_mm).cos();
                -p.force_z_n / k
            }),
            Shape::ComplianceDeadband {
                compliance_um_per_n,
                band_n,
            } => per_point(&|p| -compliance_um_per_n * (p.force_z_n - band_n).max(0.0)),
            Shape::RunoutSpeed {
                runout_um,
                speed_coeff,
            } => runout_offsets(c, |p| {
                (
                    runout_um * (1.0 + speed_coeff * (p.speed_rpm / 36_000.0).powi(2)),
                    p.depth_actual_um,
                )
            }),
            Shape::RunoutDepthPower {
                runout_um,
                ref_depth_um,
                exponent,
            } => runout_offsets(c, |p| {
                let d = p.depth_actual_um.max(0.0);
                (*runout_um, d * (d / ref_depth_um).powf(*exponent))
            }),
            Shape::RunoutGrowing { runout_um, end_mm } => runout_offsets(c, |p| {
                (
                    runout_um * (0.5 + p.cut_length_mm.max(0.0) / end_mm),
                    p.depth_actual_um,
                )
            }),
        })
    }
}

impl Shape {
    /// A straightness shape's deviation at machine X before anchoring (0 for other shapes).
    fn straightness_at(&self, x_mm: f64) -> f64 {
        match self {
            Shape::StraightnessBump {
                height_um,
                centre_mm,
                width_mm,
                ..
            } => height_um * (-0.5 * ((x_mm - centre_mm) / width_mm).powi(2)).exp(),
            Shape::StraightnessWave {
                amplitude_um,
                period_mm,
                phase_rad,
                ..
            } => amplitude_um * (2.0 * PI * x_mm / period_mm + phase_rad).sin(),
            Shape::StraightnessKink {
                height_um,
                kink_mm,
                half_width_mm,
                ..
            } => height_um * (1.0 - (x_mm - kink_mm).abs() / half_width_mm).max(0.0),
            _ => 0.0,
        }
    }

    /// The same straightness shape with its height scaled by `k` (others unchanged).
    fn scaled_straightness(self, k: f64) -> Shape {
        match self {
            Shape::StraightnessBump {
                height_um,
                anchor_mm,
                centre_mm,
                width_mm,
            } => Shape::StraightnessBump {
                height_um: height_um * k,
                anchor_mm,
                centre_mm,
                width_mm,
            },
            Shape::StraightnessWave {
                amplitude_um,
                anchor_mm,
                period_mm,
                phase_rad,
            } => Shape::StraightnessWave {
                amplitude_um: amplitude_um * k,
                anchor_mm,
                period_mm,
                phase_rad,
            },
            Shape::StraightnessKink {
                height_um,
                anchor_mm,
                kink_mm,
                half_width_mm,
            } => Shape::StraightnessKink {
                height_um: height_um * k,
                anchor_mm,
                kink_mm,
                half_width_mm,
            },
            other => other,
        }
    }
}

/// sim's flute-runout offset at every point with the runout and the depth term a point gives
/// (sim's `FluteRunout` evaluated with that depth in place of the actual one).
fn runout_offsets(c: &SessionContexts, f: impl Fn(&PointContext) -> (f64, f64)) -> Vec<f64> {
    (0..c.len())
        .map(|i| {
            let (runout_um, depth_um) = f(&c.points[i]);
            let ctx = EffectContext {
                depth_actual_um: depth_um,
                ..c.effect_context(i)
            };
            FluteRunout {
                runout_um: runout_um.max(0.0),
            }
            .depth_offset_um(&ctx)
        })
        .collect()
}

/// Cumulative peak force × engaged length (N·mm) at every point, in plan order.
pub fn cumulative_load_n_mm(pts: &[PointContext]) -> Vec<f64> {
    let mut acc = 0.0;
    let mut last_l = 0.0;
    pts.iter()
        .map(|p| {
            let dl = (p.cut_length_mm - last_l).max(0.0);
            last_l = p.cut_length_mm;
            acc += p.force_z_n.max(0.0) * dl;
            acc
        })
        .collect()
}

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + (hi.ln() - lo.ln()) * rng.random::<f64>()).exp()
}

fn sign(rng: &mut ChaCha8Rng) -> f64 {
    if rng.random::<bool>() { 1.0 } else { -1.0 }
}

/// Session facts the normalisations use (`VARIANTS.md`).
struct Facts {
    /// Engaged length at the last point (mm).
    end_mm: f64,
    /// Mean peak force over engaged points (N).
    mean_force_n: f64,
    /// Machine X range of the points (mm).
    x_range: (f64, f64),
    /// Mean actual depth over engaged points (µm).
    mean_depth_um: f64,
}

fn facts(c: &SessionContexts) -> Facts {
    let pts = &c.points;
    let engaged: Vec<&PointContext> = pts.iter().filter(|p| p.depth_actual_um > 0.0).collect();
    let mean = |f: &dyn Fn(&PointContext) -> f64| {
        engaged.iter().map(|p| f(p)).sum::<f64>() / engaged.len().max(1) as f64
    };
    Facts {
        end_mm: pts.iter().map(|p| p.cut_length_mm).fold(0.0, f64::max),
        mean_force_n: mean(&|p| p.force_z_n),
        x_range: pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
            (a.0.min(p.machine_x_mm), a.1.max(p.machine_x_mm))
        }),
        mean_depth_um: mean(&|p| p.depth_actual_um),
    }
}

/// Draws the shape of `effect` (the row decides: a non-candidate shape, or the reference form)
/// and scales it to `a` × the 002 magnitude (`VARIANTS.md`, "Shapes").
fn draw_shape(
    rng: &mut ChaCha8Rng,
    effect: &'static str,
    a: f64,
    matched: bool,
    c: &SessionContexts,
) -> Result<HiddenTruth> {
    let f = facts(c);
    let m = reference_magnitude(effect) * a;
    let pick = rng.random_range(0..3usize);
    let hidden =
        |shape: &'static str, truth: Shape, family_params: Vec<(&'static str, f64)>| HiddenTruth {
            effect,
            shape,
            amplitude_factor: a,
            truth,
            family_params,
        };
    let sim = |name: &'static str, params: Vec<(&'static str, f64)>| {
        Shape::Sim(SimEffect { name, params })
    };
    // a value of a coolant step response 45 min after the switch-on: the scales below make the
    // drift there 95 % of the magnitude, as sim's τ = 900 s form (1 − e⁻³)
    let at_45min = 2700.0;
    Ok(match effect {
        "coolant_thermal_drift" => {
            if matched {
                let tau = uniform(rng, 400.0, 1600.0);
                hidden(
                    "one_lag",
                    sim(effect, vec![("amplitude_um", m), ("time_constant_s", tau)]),
                    vec![("amplitude_um", m), ("time_constant_s", tau)],
                )
            } else {
                let target = 0.95 * m;
                match pick {
                    0 => {
                        let tau = uniform(rng, 400.0, 1500.0);
                        let dead = uniform(rng, 120.0, 600.0);
                        let h = 1.0 - (-(at_45min - dead) / tau).exp();
                        hidden(
                            "dead_time_lag",
                            Shape::CoolantDeadTime {
                                gain_um: target / h,
                                tau_s: tau,
                                dead_s: dead,
                            },
                            vec![],
                        )
                    }
                    1 => {
                        let tau = uniform(rng, 200.0, 900.0);
                        let ramp = uniform(rng, 0.1, 0.4);
                        let h = 1.0 - (-at_45min / tau).exp() + ramp * at_45min / 3600.0;
                        hidden(
                            "lag_plus_ramp",
                            Shape::CoolantLagRamp {
                                gain_um: target / h,
                                tau_s: tau,
                                ramp_per_h: ramp,
                            },
                            vec![],
                        )
                    }
                    _ => {
                        let tau = uniform(rng, 100.0, 600.0);
                        let h = 1.0 - (-(at_45min / tau).sqrt()).exp();
                        hidden(
                            "diffusion",
                            Shape::CoolantDiffusion {
                                gain_um: target / h,
                                tau_s: tau,
                            },
                            vec![],
                        )
                    }
                }
            }
        }
        "spindle_thermal_growth" => {
            if matched {
                let onset = uniform(rng, 12_000.0, 20_000.0);
                let tau = uniform(rng, 300.0, 900.0);
                hidden(
                    "onset_one_lag",
                    sim(
                        effect,
                        vec![
                            ("max_growth_um", m),
                            ("rpm_onset", onset),
                            ("rpm_max", 50_000.0),
                            ("time_constant_s", tau),
                            ("um_per_c", 1.0),
                        ],
                    ),
                    vec![
                        ("max_growth_um", m),
                        ("rpm_onset", onset),
                        ("time_constant_s", tau),
                    ],
                )
            } else {
                match pick {
                    0 => {
                        let tau_h = uniform(rng, 300.0, 900.0);
                        hidden(
                            "asymmetric_heating_cooling",
                            Shape::SpindleAsymmetric {
                                growth_um: m,
                                onset_rpm: uniform(rng, 12_000.0, 20_000.0),
                                tau_heat_s: tau_h,
                                tau_cool_s: tau_h * uniform(rng, 2.0, 4.0),
                            },
                            vec![],
                        )
                    }
                    1 => {
                        let onset = uniform(rng, 8_000.0, 16_000.0);
                        let scale = uniform(rng, 10_000.0, 25_000.0);
                        hidden(
                            "saturating_gain",
                            Shape::SpindleSaturating {
                                gain_um: m / ((50_000.0 - onset) / scale).tanh(),
                                onset_rpm: onset,
                                scale_rpm: scale,
                                tau_s: uniform(rng, 300.0, 900.0),
                            },
                            vec![],
                        )
                    }
                    _ => hidden(
                        "dead_time_lag",
                        Shape::SpindleDeadTime {
                            growth_um: m,
                            onset_rpm: uniform(rng, 12_000.0, 20_000.0),
                            tau_s: uniform(rng, 300.0, 900.0),
                            dead_s: uniform(rng, 60.0, 240.0),
                        },
                        vec![],
                    ),
                }
            }
        }
        "probe_tilt_offset" => {
            // one constant per tool-length correction (002 eq. 1): no other shape exists; the
            // tools' diameters vary (VARIANTS.md)
            let d1 = uniform(rng, 3.0, 8.0);
            let d2 = uniform(rng, 0.2, 1.0);
            let alpha = (m / 1e3 / ((d1 - d2) / 2.0)).atan().to_degrees();
            hidden(
                "constant",
                sim(
                    effect,
                    vec![("d1_mm", d1), ("d2_mm", d2), ("alpha_deg", alpha)],
                ),
                vec![("offset_um", m)],
            )
        }
        "tool_wear" => {
            let end = f.end_mm.max(1e-9);
            if matched {
                let l0 = uniform(rng, 60.0, 200.0);
                let w = m / (1.0 - (-end / l0).exp());
                hidden(
                    "saturating",
                    sim(effect, vec![("max_wear_um", w), ("length_scale_mm", l0)]),
                    vec![("max_wear_um", w), ("length_scale_mm", l0)],
                )
            } else {
                match pick {
                    0 => {
                        let l1 = uniform(rng, 10.0, 50.0);
                        // half of the wear at the end from running-in, half linear
                        let rate = (1.0 - (-end / l1).exp()) / end;
                        let g = m / (2.0 * (1.0 - (-end / l1).exp()));
                        hidden(
                            "running_in_linear",
                            Shape::WearRunningIn {
                                gain_um: g,
                                running_in_mm: l1,
                                rate_per_mm: rate,
                            },
                            vec![],
                        )
                    }
                    1 => {
                        let load = cumulative_load_n_mm(&c.points);
                        let e_end = load.last().copied().unwrap_or(1.0).max(1e-9);
                        let scale = e_end * uniform(rng, 0.3, 1.5);
                        hidden(
                            "load_driven",
                            Shape::WearLoadDriven {
                                gain_um: m / (1.0 - (-e_end / scale).exp()),
                                scale_n_mm: scale,
                            },
                            vec![],
                        )
                    }
                    _ => {
                        let mid = uniform(rng, 0.35, 0.7) * end;
                        let width = uniform(rng, 0.07, 0.18) * end;
                        let s = |l: f64| 1.0 / (1.0 + (-(l - mid) / width).exp());
                        hidden(
                            "logistic",
                            Shape::WearLogistic {
                                gain_um: m / (s(end) - s(0.0)),
                                mid_mm: mid,
                                width_mm: width,
                            },
                            vec![],
                        )
                    }
                }
            }
        }
        "slideway_straightness" => {
            let s = sign(rng);
            let (x0, x1) = f.x_range;
            let span = (x1 - x0).max(1e-9);
            if matched {
                hidden(
                    "bow",
                    sim(
                        effect,
                        vec![("amplitude_um", s * m), ("span_mm", span), ("x0_mm", x0)],
                    ),
                    vec![("amplitude_um", s * m)],
                )
            } else {
                // each shape zero at the start of the X range and scaled so its largest
                // |deviation| over the measured points is m
                let (label, shape) = match pick {
                    0 => (
                        "bump",
                        Shape::StraightnessBump {
                            height_um: s,
                            anchor_mm: x0,
                            centre_mm: x0 + uniform(rng, 0.22, 0.78) * span,
                            width_mm: uniform(rng, 0.09, 0.22) * span,
                        },
                    ),
                    1 => (
                        "waviness",
                        Shape::StraightnessWave {
                            amplitude_um: s,
                            anchor_mm: x0,
                            period_mm: uniform(rng, 0.55, 1.35) * span,
                            phase_rad: uniform(rng, 0.0, 2.0 * PI),
                        },
                    ),
                    _ => (
                        "kink",
                        Shape::StraightnessKink {
                            height_um: s,
                            anchor_mm: x0,
                            kink_mm: x0 + uniform(rng, 0.28, 0.72) * span,
                            half_width_mm: uniform(rng, 0.33, 0.67) * span,
                        },
                    ),
                };
                let unit = shape.offsets(c)?;
                let peak = unit.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-12);
                hidden(label, shape.scaled_straightness(m / peak), vec![])
            }
        }
        "machine_compliance" => {
            // m = compliance (µm/N); each shape deflects the machine by m·F at the mean force
            let fm = f.mean_force_n.max(1e-9);
            if matched {
                hidden(
                    "constant",
                    sim(
                        effect,
                        vec![
                            ("stiffness_n_per_um", 1.0 / m),
                            ("span_n_per_um", 0.0),
                            ("period_mm", 200.0),
                        ],
                    ),
                    vec![("compliance_um_per_n", m)],
                )
            } else {
                match pick {
                    0 => hidden(
                        "progressive",
                        Shape::CompliancePower {
                            compliance_um_per_n: m,
                            ref_n: fm,
                            exponent: uniform(rng, 0.2, 0.5),
                        },
                        vec![],
                    ),
                    1 => {
                        let k = 1.0 / m;
                        hidden(
                            "position_dependent",
                            Shape::CompliancePosition {
                                stiffness_n_per_um: k,
                                span_n_per_um: k * uniform(rng, 0.5, 1.5),
                                period_mm: uniform(rng, 60.0, 200.0),
                            },
                            vec![],
                        )
                    }
                    _ => {
                        let band = fm * uniform(rng, 0.2, 0.6);
                        hidden(
                            "deadband",
                            Shape::ComplianceDeadband {
                                compliance_um_per_n: m * fm / (fm - band),
                                band_n: band,
                            },
                            vec![],
                        )
                    }
                }
            }
        }
        _ => {
            // flute_runout: m = runout (µm) on average over the session
            if matched {
                hidden(
                    "runout",
                    sim("flute_runout", vec![("runout_um", m)]),
                    vec![("runout_um", m)],
                )
            } else {
                match pick {
                    0 => {
                        let b = uniform(rng, 0.5, 2.0);
                        let mean_sq = c
                            .points
                            .iter()
                            .map(|p| (p.speed_rpm / 36_000.0).powi(2))
                            .sum::<f64>()
                            / c.points.len().max(1) as f64;
                        hidden(
                            "speed_dependent",
                            Shape::RunoutSpeed {
                                runout_um: m / (1.0 + b * mean_sq),
                                speed_coeff: b,
                            },
                            vec![],
                        )
                    }
                    1 => hidden(
                        "depth_power",
                        Shape::RunoutDepthPower {
                            runout_um: m,
                            ref_depth_um: f.mean_depth_um.max(1e-9),
                            exponent: uniform(rng, 0.2, 0.5),
                        },
                        vec![],
                    ),
                    _ => hidden(
                        "growing_with_cut_length",
                        Shape::RunoutGrowing {
                            runout_um: m,
                            end_mm: f.end_mm.max(1e-9),
                        },
                        vec![],
                    ),
                }
            }
        }
    })
}

/// Draws one variant of `nominal` (`VARIANTS.md`): nominal errors, touch-off, hidden effects,
/// groove offsets and noise, in that order from one ChaCha8 stream seeded with `spec.seed`.
///
/// # Errors
/// [`SyntheticError::Sim`] when sim rejects the truth session or a hidden effect,
/// [`SyntheticError::Noise`] never in practice (fixed σ).
pub fn draw(nominal: &Session, spec: &VariantSpec) -> Result<Variant> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let stiffness_range = spec.row.stiffness_range();
    let errors = NominalErrors {
        force_scale_factor: 1.0 + uniform(&mut rng, -FORCE_SCALE_RANGE, FORCE_SCALE_RANGE),
        axial_stiffness_factor: 1.0 + uniform(&mut rng, -stiffness_range, stiffness_range),
        radial_stiffness_factor: 1.0 + uniform(&mut rng, -stiffness_range, stiffness_range),
        wearland_delta_um: uniform(&mut rng, -WEARLAND_RANGE_UM, WEARLAND_RANGE_UM),
        touch_off_um: uniform(&mut rng, -TOUCH_OFF_RANGE_UM, TOUCH_OFF_RANGE_UM),
    };
    let mut truth = nominal.clone();
    truth.force_model.force_scale *= errors.force_scale_factor;
    truth.stiffness.axial_n_per_um *= errors.axial_stiffness_factor;
    truth.stiffness.radial_n_per_um *= errors.radial_stiffness_factor;
    truth.tool.wearland_um = (truth.tool.wearland_um + errors.wearland_delta_um).max(0.0);
    let contexts = truth.contexts().map_err(sim_err("truth session"))?;
    let mut hidden = Vec::new();
    let mut hidden_offsets_um = Vec::new();
    for &effect in &spec.effects {
        let a = log_uniform(&mut rng, AMPLITUDE_RANGE.0, AMPLITUDE_RANGE.1);
        let h = draw_shape(&mut rng, effect, a, spec.row == Row::Matched, &contexts)?;
        hidden_offsets_um.push(h.truth.offsets(&contexts)?);
        hidden.push(h);
    }
    let n_grooves = contexts
        .points
        .iter()
        .map(|p| p.groove_id)
        .max()
        .map_or(0, |g| g as usize + 1);
    let scatter = Normal::new(0.0, GROOVE_SCATTER_UM).map_err(|source| SyntheticError::Noise {
        sigma: GROOVE_SCATTER_UM,
        source,
    })?;
    let groove_offsets_um: Vec<f64> = (0..n_grooves).map(|_| scatter.sample(&mut rng)).collect();
    let noise = Normal::new(0.0, DEPTH_NOISE_UM).map_err(|source| SyntheticError::Noise {
        sigma: DEPTH_NOISE_UM,
        source,
    })?;
    let points = contexts
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let hidden_sum: f64 = hidden_offsets_um.iter().map(|o| o[i]).sum();
            p.measured(
                p.depth_nominal_um
                    + hidden_sum
                    + errors.touch_off_um
                    + groove_offsets_um[p.groove_id as usize]
                    + noise.sample(&mut rng),
            )
        })
        .collect();
    Ok(Variant {
        spec: spec.clone(),
        errors,
        hidden,
        hidden_offsets_um,
        groove_offsets_um,
        points,
    })
}

/// How the names a diagnosis gave compare with what was hidden (the study's criteria).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outcome {
    /// The first name is a hidden effect (for nothing hidden: the first name is `none`).
    pub first_right: bool,
    /// The names are exactly the hidden effects, in any order (`none` for nothing hidden).
    pub exact: bool,
    /// Every hidden effect is named.
    pub all_named: bool,
    /// Nothing is named that was not hidden.
    pub nothing_else: bool,
}

/// Scores `named` (a diagnosis' names, `["none"]` for none) against the hidden effects.
///
/// ```
/// use millcomp_synthetic::variants::score;
/// let o = score(&["tool_wear", "coolant_thermal_drift"], &["tool_wear".to_string()]);
/// assert!(!o.all_named && o.nothing_else && o.first_right && !o.exact);
/// let o = score(&[], &["none".to_string()]);
/// assert!(o.exact && o.first_right && o.all_named && o.nothing_else);
/// ```
pub fn score(hidden: &[&str], named: &[String]) -> Outcome {
    let names: Vec<&str> = named
        .iter()
        .map(String::as_str)
        .filter(|n| *n != "none")
        .collect();
    let all_named = hidden.iter().all(|h| names.contains(h));
    let nothing_else = names.iter().all(|n| hidden.contains(n));
    Outcome {
        first_right: match names.first() {
            Some(f) => hidden.contains(f),
            None => hidden.is_empty(),
        },
        exact: all_named && nothing_else,
        all_named,
        nothing_else,
    }
}

/// `n` seeded draws of N(0, σ²) (e.g. groove offsets for a hand-made variant in a test).
///
/// # Errors
/// [`SyntheticError::Noise`] for a negative or non-finite σ.
pub fn normal_draws(seed: u64, n: usize, sigma: f64) -> Result<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = Normal::new(0.0, sigma).map_err(|source| SyntheticError::Noise { sigma, source })?;
    Ok((0..n).map(|_| d.sample(&mut rng)).collect())
}

/// A committed variant of `datasets/synthetic/` (`real_*` files): a name, what it shows, and the
/// variant it is (development seeds, never the study's).
#[derive(Debug, Clone)]
pub struct CommittedVariant {
    /// File stem.
    pub name: &'static str,
    /// One line for the README.
    pub description: &'static str,
    /// What to draw.
    pub spec: VariantSpec,
}

/// The committed variants (data as a user has them: the nominal model off, groove scatter, a
/// shape other than the candidates').
pub fn committed_variants() -> Vec<CommittedVariant> {
    vec![
        CommittedVariant {
            name: "real_none",
            description: "nothing hidden: only the nominal model's errors, touch-off, groove scatter and noise",
            spec: VariantSpec {
                row: Row::None,
                effects: vec![],
                seed: DEV_SEED_BASE + 16,
            },
        },
        CommittedVariant {
            name: "real_tool_wear",
            description: "tool wear with running-in then linear wear (a wear family shape since diagnose's second round)",
            spec: VariantSpec {
                row: Row::Single,
                effects: vec!["tool_wear"],
                seed: DEV_SEED_BASE + 4,
            },
        },
        CommittedVariant {
            name: "real_coolant_thermal_drift+tool_wear",
            description: "two effects of non-candidate shapes",
            spec: VariantSpec {
                row: Row::Two,
                effects: vec!["coolant_thermal_drift", "tool_wear"],
                seed: DEV_SEED_BASE + 15,
            },
        },
        CommittedVariant {
            name: "real_machine_compliance",
            description: "machine compliance: aliased with the stiffness nuisance by any groove plan",
            spec: VariantSpec {
                row: Row::Single,
                effects: vec!["machine_compliance"],
                seed: DEV_SEED_BASE + 5,
            },
        },
    ]
}

/// A one-line description of a hidden truth for the README (shape and parameters).
pub fn describe(h: &HiddenTruth) -> String {
    format!(
        "`{}` as `{}` at {:.2}× the 002 magnitude ({:?})",
        h.effect, h.shape, h.amplitude_factor, h.truth
    )
}
