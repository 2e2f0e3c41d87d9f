//! Simulated units with a known between-unit scatter, for the coverage of the across-units analysis
//! (`identify::units`): shared by the fast test (`tests/units.rs`) and the study example
//! (`examples/unit_coverage.rs`, which includes this file).
//!
//! Two families, each fitted through the crate's real per-unit path:
//! * `wall`: thin walls whose stiffness varies from wall to wall, k_u = k̄·(1 + τ_rel·z_u); each wall
//!   measured at 12 loads 0.1 … 1.2 N, deflection = 0.5 µm + F/k_u + σ·ε (independent errors), fitted by
//!   `identify wall` (nonlinear least squares) through `units::identify_units`;
//! * `wear`: cutters whose force-against-wear slope varies from tool to tool, k_u = k̄·(1 + τ_rel·z_u),
//!   over 150 cuts with a flank wear growing 30 → 180 µm (faster early, as measured wear does),
//!   force = 2 N + k_u·VB + AR(1) noise (lag-1 ρ = 0.9, as the PHM records' residuals), fitted by
//!   `identify wear` (force against wear, Newey–West) through `wear::wear_across_units`.
//!
//! The new unit is a fresh draw of the same family; the study counts how often its true parameter lies
//! inside the reported 95 % prediction interval, how often the mean k̄ lies inside the mean's interval
//! and how often the true τ lies inside its Q-profile interval.
#![allow(dead_code)]

use millcomp_identify::targets::wear::{
    CutRange, WearLaw, WearOptions, force_at_vb_name, study_wear, wear_across_units,
};
use millcomp_identify::units::{MetaAnalysis, MetaOptions, Tau2Method, identify_units};
use millcomp_identify::{Columns, IdentifyOptions, Target};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Which simulated family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Thin-wall stiffness, independent errors.
    Wall,
    /// Force-against-wear slope, AR(1) errors.
    Wear,
}

/// One setting of the study.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    /// Family.
    pub family: Family,
    /// Units per data set.
    pub units: usize,
    /// Between-unit scatter τ relative to the mean.
    pub tau_rel: f64,
    /// Measurement noise σ (µm for walls, N for wear).
    pub noise: f64,
    /// τ² estimator.
    pub tau2: Tau2Method,
}

/// Counts over the data sets of one setting.
#[derive(Debug, Clone, Default)]
pub struct Coverage {
    /// Data sets.
    pub sets: usize,
    /// New unit's true parameter inside its 95 % prediction interval.
    pub new_unit: usize,
    /// Mean k̄ inside the mean's 95 % HKSJ interval.
    pub mean: usize,
    /// True τ inside the 95 % Q-profile interval.
    pub tau: usize,
    /// Median over sets of the prediction interval's width / (2·1.96·τ) (1 would be the interval
    /// with known μ and τ).
    pub median_width_ratio: f64,
    /// Median over sets of the per-unit standard error / τ (how much of the spread is the units' own).
    pub median_se_over_tau: f64,
}

impl Coverage {
    /// Fraction of sets whose new unit is covered.
    pub fn new_unit_rate(&self) -> f64 {
        self.new_unit as f64 / self.sets as f64
    }
}

const WALL_K: f64 = 0.25;
const WEAR_K: f64 = 0.12;

fn wall_units(rng: &mut ChaCha8Rng, s: &Setting) -> Vec<(String, Columns)> {
    (0..s.units)
        .map(|u| {
            let z: f64 = StandardNormal.sample(rng);
            let k = WALL_K * (1.0 + s.tau_rel * z);
            let f: Vec<f64> = (1..=12).map(|i| 0.1 * i as f64).collect();
            let d: Vec<f64> = f
                .iter()
                .map(|f| {
                    let e: f64 = StandardNormal.sample(rng);
                    0.5 + f / k + s.noise * e
                })
                .collect();
            let mut c = Columns::new();
            c.insert("force_n", f).insert("deflection_um", d);
            (format!("w{u}"), c)
        })
        .collect()
}

fn wear_units(
    rng: &mut ChaCha8Rng,
    s: &Setting,
) -> Vec<(String, Vec<millcomp_identify::targets::wear::WearStudy>)> {
    let cut: Vec<f64> = (1..=150).map(f64::from).collect();
    let opts = {
        let mut o = WearOptions::new(CutRange::parse("--train", "1:end").expect("range"), None);
        o.laws = vec![WearLaw::Linear];
        o
    };
    (0..s.units)
        .map(|u| {
            let z: f64 = StandardNormal.sample(rng);
            let k = WEAR_K * (1.0 + s.tau_rel * z);
            let vb: Vec<f64> = cut
                .iter()
                .map(|n| 30.0 + 150.0 * (n / 150.0f64).powf(0.7))
                .collect();
            let mut e = 0.0f64;
            let f: Vec<f64> = vb
                .iter()
                .map(|v| {
                    let w: f64 = StandardNormal.sample(rng);
                    e = 0.9 * e + (1.0f64 - 0.81).sqrt() * w;
                    2.0 + k * v + s.noise * e
                })
                .collect();
            let vbs = vec![("vb_um".to_string(), vb.as_slice())];
            let st = study_wear(&cut, Some(&vbs), "force_n", &f, &opts).expect("wear fit");
            (format!("c{u}"), vec![st])
        })
        .collect()
}

/// The meta-analysis of the family's parameter on one data set, and the true τ and k̄.
fn one_set(rng: &mut ChaCha8Rng, s: &Setting) -> (MetaAnalysis, f64) {
    let meta = MetaOptions { tau2: s.tau2 };
    match s.family {
        Family::Wall => {
            let units = wall_units(rng, s);
            let r = identify_units(Target::Wall, &units, &IdentifyOptions::default(), &meta)
                .expect("units fit");
            let q = r
                .across_units
                .quantities
                .iter()
                .find(|q| q.name == "wall_stiffness_n_per_um")
                .expect("stiffness combined");
            (q.meta.clone(), WALL_K)
        }
        Family::Wear => {
            let units = wear_units(rng, s);
            let a = wear_across_units(&units, 100.0, &meta).expect("wear across units");
            let q = a[0]
                .across
                .quantities
                .iter()
                .find(|q| q.name == "k_n_per_um")
                .expect("slope combined");
            debug_assert!(
                a[0].across
                    .quantities
                    .iter()
                    .any(|q| q.name == force_at_vb_name(100.0))
            );
            (q.meta.clone(), WEAR_K)
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Runs `sets` data sets of setting `s`, data set i from seed `seed + i`.
pub fn coverage(s: &Setting, sets: usize, seed: u64) -> Coverage {
    let mut c = Coverage {
        sets,
        ..Default::default()
    };
    let (mut widths, mut ses) = (Vec::new(), Vec::new());
    for i in 0..sets {
        let mut rng = ChaCha8Rng::seed_from_u64(seed + i as u64);
        let (m, kbar) = one_set(&mut rng, s);
        let tau = kbar * s.tau_rel;
        let z: f64 = StandardNormal.sample(&mut rng);
        let k_new = kbar + tau * z;
        let pi = m.new_unit.pi95;
        c.new_unit += usize::from(pi[0] <= k_new && k_new <= pi[1]);
        c.mean += usize::from(m.ci95[0] <= kbar && kbar <= m.ci95[1]);
        c.tau += usize::from(m.tau_ci95[0] <= tau && tau <= m.tau_ci95[1]);
        widths.push((pi[1] - pi[0]) / (2.0 * 1.959_964 * tau));
        // the per-unit SE this set had, relative to τ (from the fixed-effect SE: 1/√Σ(1/sᵢ²) = s/√k)
        ses.push(m.fixed_se * (s.units as f64).sqrt() / tau);
    }
    c.median_width_ratio = median(widths);
    c.median_se_over_tau = median(ses);
    c
}
