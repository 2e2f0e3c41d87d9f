//! The force disagreements, diagnosed on a measured peak-force table (issue 50): the nominal force
//! model that `millcomp identify force` fits (W free, everything else the material's and the
//! default tool's), its residual per response, and candidate effects from the micro-milling
//! literature — not from millcomp's own generator — each with its fit and its evidence.
//!
//! # Data
//! The Table 3-3 contract (`000_…txt` §3.5.1): per run the cut (`depth_um`, `upfeed_um`, optional
//! `speed_rpm` and `tilt_deg`) and any of `max_fx_n`, `max_fy_n`, `max_fz_n` = "the largest
//! positive force per flute … averaged" — identify's [`PeakForceData`].
//!
//! # Method
//! 1. **Nominal**: [`identify_force`] with W free ([`ForceOptions::default`] with the material
//!    set). Its residual per response: RMS, per run, and the relative bias `Σ(ŷ − y)/Σy`.
//! 2. **Candidates** ([`Candidate`]): each adds one parameter θ to the nominal model; (W, θ) are
//!    fitted jointly by identify's bounded nonlinear least squares ([`CurveFit`]) on all
//!    responses. A fit that does not converge is a status in the report, not an error.
//! 3. **Evidence** per candidate: the extra-sum-of-squares F test against the nominal model,
//!    `F = (RSS₀ − RSS₁) / (RSS₁/(n − 2))` with (1, n − 2) degrees of freedom; the
//!    leave-one-run-out RMS prediction error of the nominal and of the augmented model (a run = its
//!    responses, refitted on the other runs); and the smallest effect the data could have detected:
//!    the θ − θ₀ at which the F test at level α has power `power` (noncentral F, `millcomp-doe`'s
//!    [`f_test_power`]), `λ = (θ − θ₀)²·‖M ∂ŷ/∂θ‖²/σ²` with `M` the projection off the nominal W
//!    column and σ the noise estimate: the pooled residual SD of a main-effects regression of each
//!    response on the varying conditions (a noise estimate that does not depend on the force model;
//!    [`NoiseEstimate`]).
//! 4. **Verdict**: a candidate is *supported* when it is significant at α and predicts the held-out
//!    runs better than the nominal model. One supported candidate (or one clearly ahead of the
//!    others: the runner-up's RSS exceeds the best's by more than the F test's critical ratio) is
//!    *named*; two or more that explain the data equally are "not identifiable from these data";
//!    none supported is "not identifiable from these data" with each candidate's detectable size.
//!
//! # Examples
//! ```
//! use millcomp_diagnose::forces::{ForceDiagnoseOptions, diagnose_forces};
//! use millcomp_identify::targets::force::{ForceConditions, PeakForceData};
//! // 000 Table 3-3 (6061)
//! let depth = [200.0, 100.0, 100.0, 200.0, 200.0, 100.0, 200.0, 100.0];
//! let speed = [1e4, 1e4, 2e4, 2e4, 2e4, 2e4, 1e4, 1e4];
//! let upfeed = [20.0, 20.0, 10.0, 10.0, 20.0, 20.0, 10.0, 10.0];
//! let fx = [3.34, 1.78, 0.94, 1.91, 3.60, 2.20, 2.20, 1.00];
//! let fy = [1.75, 1.33, 0.93, 1.64, 2.30, 1.75, 2.10, 1.10];
//! let fz = [2.17, 1.24, 0.59, 0.83, 2.00, 1.50, 1.40, 0.82];
//! let conditions = ForceConditions { depth_um: &depth, upfeed_um: &upfeed, speed_rpm: Some(&speed), tilt_deg: None };
//! let data = PeakForceData { conditions, max_fx_n: Some(&fx), max_fy_n: Some(&fy), max_fz_n: Some(&fz) };
//! let opts = ForceDiagnoseOptions { candidates: Some(vec!["sensor_gain_y".into()]), ..ForceDiagnoseOptions::new("6061") };
//! let rep = diagnose_forces("clayton_doe.csv", &data, &opts).unwrap();
//! // the nominal fit is identify force's: W = 2049 MPa [1691, 2407]
//! assert!((rep.nominal.w_mpa - 2049.0).abs() < 1.0);
//! // Y is under-predicted: the relative bias of Y is about −40 %
//! let y = rep.nominal.responses.iter().find(|r| r.axis == "y").unwrap();
//! assert!(y.relative_bias < -0.3);
//! ```

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, PI};

use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze, f_test_power};
use millcomp_identify::targets::force::{ForceData, ForceOptions, PeakForceData, identify_force};
use millcomp_identify::{CurveFit, FitStatus, ParamSpec};
use millcomp_sim::force::{BallEndForceModel, CutConditions, PEAK_SAMPLES_PER_REV};
use millcomp_sim::material::Material;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use crate::error::{DiagnoseError, Result};

/// The three responses, in the order of the peak columns.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// Angles per revolution of the peak search: sim's peak-and-hold grid (0.5°,
/// [`PEAK_SAMPLES_PER_REV`]); identify force's 3600 would make every fit five times slower for peaks
/// that differ by less than 0.1 % (`evaluator_without_candidate_is_table33_response`).
pub const PEAK_GRID: usize = PEAK_SAMPLES_PER_REV;

/// Reference spindle speed of the speed candidate (the Table 3-3 low level, rpm).
pub const SPEED_REF_RPM: f64 = 10_000.0;

/// A value a candidate uses, with its source.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cited {
    /// What the value is.
    pub name: String,
    /// The value.
    pub value: f64,
    /// Its unit.
    pub unit: String,
    /// Document and section/table/page.
    pub source: String,
}

fn cited(name: &str, value: f64, unit: &str, source: &str) -> Cited {
    Cited {
        name: name.into(),
        value,
        unit: unit.into(),
        source: source.into(),
    }
}

/// A candidate effect from the micro-milling literature, one parameter each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Candidate {
    /// Ploughing below the minimum chip thickness (size effect): where the uncut chip
    /// `h = ft·sin θ·sin κ` is thinner than `h_min = ratio·r_e`, the edge ploughs instead of cutting,
    /// with a force per unit of ploughing edge length `k` (N/µm) in both the cutting and the thrust
    /// direction. θ = k, nominal 0.
    Ploughing,
    /// Tool runout (one flute takes the larger chip): θ = runout (µm), nominal the base tool's.
    Runout,
    /// Flank-wear rubbing ∝ wearland: θ = wearland (µm), nominal the base tool's.
    FlankWear,
    /// The Y channel's gain: measured Fy = (1 + θ)·Fy, nominal 0.
    SensorGainY,
    /// The Z channel's gain: measured Fz = (1 + θ)·Fz, nominal 0.
    SensorGainZ,
    /// X→Y crosstalk of the dynamometer: measured Fy = Fy + θ·Fx at every angle, nominal 0.
    CrosstalkXY,
    /// The cutting speed's effect on specific energy: forces × (n/10 000 rpm)^θ, nominal 0.
    Speed,
}

impl Candidate {
    /// Every candidate, in report order.
    pub const ALL: [Candidate; 7] = [
        Candidate::Ploughing,
        Candidate::Runout,
        Candidate::FlankWear,
        Candidate::SensorGainY,
        Candidate::SensorGainZ,
        Candidate::CrosstalkXY,
        Candidate::Speed,
    ];

    /// Name in reports and `--candidates`.
    pub fn name(self) -> &'static str {
        match self {
            Candidate::Ploughing => "ploughing",
            Candidate::Runout => "runout",
            Candidate::FlankWear => "flank_wear",
            Candidate::SensorGainY => "sensor_gain_y",
            Candidate::SensorGainZ => "sensor_gain_z",
            Candidate::CrosstalkXY => "crosstalk_xy",
            Candidate::Speed => "speed",
        }
    }

    /// Parse a name as printed by [`Candidate::name`].
    ///
    /// # Errors
    /// [`DiagnoseError::UnknownCandidate`] listing the allowed names.
    pub fn parse(name: &str) -> Result<Self> {
        Candidate::ALL
            .into_iter()
            .find(|c| c.name() == name)
            .ok_or_else(|| DiagnoseError::UnknownCandidate {
                name: name.into(),
                allowed: Candidate::ALL.map(|c| c.name()).join(", "),
            })
    }

    /// The parameter's name (with its unit).
    pub fn param(self) -> &'static str {
        match self {
            Candidate::Ploughing => "k_plough_n_per_um",
            Candidate::Runout => "runout_um",
            Candidate::FlankWear => "wearland_um",
            Candidate::SensorGainY => "gain_y_minus_1",
            Candidate::SensorGainZ => "gain_z_minus_1",
            Candidate::CrosstalkXY => "crosstalk_x_to_y",
            Candidate::Speed => "speed_exponent",
        }
    }

    /// The effect and where it comes from.
    pub fn source(self) -> &'static str {
        match self {
            Candidate::Ploughing => {
                "size effect / ploughing below the minimum chip thickness h_min = ratio x edge radius \
                 (Liu, DeVor & Kapoor, J. Manuf. Sci. Eng. 126 (2004); Malekian et al., J. Mater. \
                 Process. Technol. 212 (2012); edge force per unit edge length as in Waldorf's \
                 ploughing model, J. Manuf. Sci. Eng. 120 (1998)); equal cutting and thrust \
                 components assumed"
            }
            Candidate::Runout => {
                "tool runout: one flute's feed per tooth (f/2)(1 + runout/f) (000_...txt section 4, \
                 eq. 7; Table 4-2 runout 5-10 um)"
            }
            Candidate::FlankWear => {
                "flank-wear rubbing, force proportional to the wearland (000_...txt section 4.1, \
                 eq. 8; Table 4-2 wearland 5-12 um, Table 4-4 (6061) 2-6 um)"
            }
            Candidate::SensorGainY => {
                "dynamometer calibration, Y channel (000_...txt section 3.4: Kistler 9251 and 5004 \
                 charge amplifier calibrated with a 1 kg mass; S7 constants 5.649/5.333/4.547 N/V for \
                 x/y/z against the 5 N/V setting; the aluminium constants (2 N/V) are in Appendix A only)"
            }
            Candidate::SensorGainZ => {
                "dynamometer calibration, Z channel (000_...txt section 3.4, as for Y)"
            }
            Candidate::CrosstalkXY => {
                "dynamometer X-to-Y crosstalk (000_...txt section 3.4 calibrates each axis alone \
                 with a hanging mass; no cross-axis sensitivity is reported)"
            }
            Candidate::Speed => {
                "cutting speed on the specific cutting energy, forces x (n/10000 rpm)^b (a speed \
                 factor on the specific cutting force as in Kienzle-type force tables; speed is a \
                 Table 3-3 factor, which 000_...txt section 3.5.1 found not significant)"
            }
        }
    }
}

/// Options of [`diagnose_forces`].
#[derive(Debug, Clone)]
pub struct ForceDiagnoseOptions {
    /// Material of the table (the physics crate's `Material::by_name`: S7, 1018, 6061, …).
    pub material: String,
    /// Significance level of each candidate's F test (default 0.05).
    pub alpha: f64,
    /// Power at which the detectable size is stated (default 0.8).
    pub power: f64,
    /// Cutting-edge radius used by the ploughing candidate (µm).
    pub edge_radius: Cited,
    /// h_min / edge radius used by the ploughing candidate.
    pub hmin_ratio: Cited,
    /// Only these candidates (default all).
    pub candidates: Option<Vec<String>>,
}

impl ForceDiagnoseOptions {
    /// Defaults for `material`: α = 0.05, power 0.8, edge radius 5 µm (`004_…txt` Table 3: a Ø1 mm
    /// carbide micro end mill; the thesis gives none), h_min/r_e = 0.3 (the middle of 0.14–0.43
    /// reported for conventional micro-cutting, Cheng et al., Int. J. Adv. Manuf. Technol. 97
    /// (2018), abstract; Wojciechowski, Materials 15 (2022) 59, a review).
    pub fn new(material: &str) -> Self {
        ForceDiagnoseOptions {
            material: material.into(),
            alpha: 0.05,
            power: 0.8,
            edge_radius: cited(
                "edge_radius",
                5.0,
                "um",
                "004_13bffb4774552fad.txt Table 3 (cutting edge radius of a 1 mm carbide micro end mill; 000_...txt gives none)",
            ),
            hmin_ratio: cited(
                "hmin_over_edge_radius",
                0.3,
                "1",
                "middle of 0.14-0.43 (Cheng et al., Int. J. Adv. Manuf. Technol. 97 (2018) 3119, abstract; Wojciechowski, Materials 15 (2022) 59)",
            ),
            candidates: None,
        }
    }

    fn h_min_um(&self) -> f64 {
        self.edge_radius.value * self.hmin_ratio.value
    }
}

/// A response's residual.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResponseResidual {
    /// `x`, `y` or `z`.
    pub axis: String,
    /// RMS of ŷ − y (N).
    pub rms_n: f64,
    /// Σ(ŷ − y)/Σy: −0.5 is a model giving half the measured force on average.
    pub relative_bias: f64,
    /// ŷ − y per run (N), in table order.
    pub per_run_n: Vec<f64>,
}

/// The nominal model's fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NominalFit {
    /// identify's status.
    pub status: FitStatus,
    /// Fitted W (MPa).
    pub w_mpa: f64,
    /// Its 95 % interval.
    pub w_ci95: [f64; 2],
    /// The material's published W (Table 4-1 "modeled parameter").
    pub w_published_mpa: f64,
    /// The fixed parameters of the nominal model (tool, friction).
    pub fixed: BTreeMap<String, f64>,
    /// Residual sum of squares (N²).
    pub rss: f64,
    /// Per response.
    pub responses: Vec<ResponseResidual>,
    /// Leave-one-run-out RMS prediction error (N).
    pub loo_rms_n: f64,
}

/// The noise the detectable sizes are computed with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseEstimate {
    /// σ (N).
    pub sigma_n: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// How it was estimated.
    pub method: String,
}

/// One candidate's fit and evidence.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CandidateReport {
    /// [`Candidate::name`].
    pub name: String,
    /// [`Candidate::source`].
    pub source: String,
    /// Values it uses, each with its source.
    pub uses: Vec<Cited>,
    /// Its parameter.
    pub param: String,
    /// The parameter's value in the nominal model.
    pub nominal_value: f64,
    /// Status of the joint fit (`converged`, … or `failed: …`).
    pub status: String,
    /// Fitted value and 95 % interval (absent when the fit failed).
    pub value: Option<f64>,
    /// 95 % interval of the value.
    pub ci95: Option<[f64; 2]>,
    /// W fitted with it (MPa).
    pub w_mpa: Option<f64>,
    /// RSS with it (N²).
    pub rss: Option<f64>,
    /// Extra-sum-of-squares F against the nominal model.
    pub f: Option<f64>,
    /// Its degrees of freedom (1, n − 2).
    pub dof: [usize; 2],
    /// p value.
    pub p: Option<f64>,
    /// Leave-one-run-out RMS of the augmented model (N).
    pub loo_rms_n: Option<f64>,
    /// Per response with the effect.
    pub responses: Vec<ResponseResidual>,
    /// Smallest |θ − θ₀| the F test detects at level α with the stated power.
    pub detectable: Option<f64>,
    /// Whether it is significant and predicts held-out runs better.
    pub supported: bool,
}

/// The verdict on one disagreement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// The disagreement.
    pub disagreement: String,
    /// The gap with the nominal model.
    pub before: f64,
    /// The gap with the named effect (the nominal one when none is named).
    pub after: f64,
    /// Unit of the gap.
    pub unit: String,
    /// The effect named, or `none`.
    pub named: String,
    /// The reasoning in one line.
    pub reason: String,
}

/// The report of [`diagnose_forces`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForceDiagnosis {
    /// The table's name.
    pub origin: String,
    /// Material.
    pub material: String,
    /// Runs and observations.
    pub n_runs: usize,
    /// Observations (runs × responses).
    pub n_obs: usize,
    /// The nominal fit.
    pub nominal: NominalFit,
    /// Noise estimate of the detectable sizes.
    pub noise: NoiseEstimate,
    /// Family-wise level of each selection round.
    pub alpha: f64,
    /// Power of the detectable sizes.
    pub power: f64,
    /// The selection rounds: round 1 tests every candidate against the nominal model.
    pub rounds: Vec<SelectionRound>,
    /// The effects named by the verdicts (empty: none).
    pub named: Vec<String>,
    /// Verdicts per disagreement.
    pub verdicts: Vec<Verdict>,
    /// The nominal model and the model after each selection step, fitted (for predictions).
    pub models: Vec<ForceModelFit>,
}

/// One round of the forward selection.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelectionRound {
    /// The effects already in the model.
    pub given: Vec<String>,
    /// Level of each candidate's test: the round's α over its candidates (Bonferroni).
    pub alpha_each: f64,
    /// Each candidate tested, added to the current model.
    pub candidates: Vec<CandidateReport>,
    /// The candidate added (the supported one with the smallest RSS), if any.
    pub added: Option<String>,
    /// A supported candidate that fits as well as the one added (RSS within the critical ratio).
    pub look_alike: Option<String>,
}

/// What one selection step did.
#[derive(Debug, Clone, PartialEq)]
struct SelectionStep {
    added: String,
    look_alike: Option<String>,
    w_mpa: f64,
    responses: Vec<ResponseResidual>,
}

/// A fitted force model: the nominal model with the effects added, and its parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForceModelFit {
    /// The effects added (empty: the nominal model).
    pub effects: Vec<String>,
    /// W (MPa), then each effect's parameter.
    pub params: Vec<f64>,
    /// W relative to the material's published W.
    pub w_ratio: f64,
}

/// One observation: run `run`, response `axis`.
#[derive(Debug, Clone, Copy)]
struct Obs {
    run: usize,
    axis: usize,
}

/// The model evaluator: the base force model and the candidates added to it, one parameter each.
struct Evaluator<'a> {
    base: &'a BallEndForceModel,
    conds: &'a [CutConditions],
    cands: Vec<Candidate>,
    h_min_um: f64,
}

impl Evaluator<'_> {
    fn model(&self, w: f64, th: &[f64]) -> std::result::Result<BallEndForceModel, String> {
        let mut m = self.base.clone();
        m.material.w_mpa = w;
        for (c, t) in self.cands.iter().zip(th) {
            match c {
                Candidate::Runout => m.tool.runout_um = t.max(0.0),
                Candidate::FlankWear => m.tool.wearland_um = t.clamp(0.0, m.tool.radius_um),
                _ => {}
            }
        }
        m.validate().map_err(|e| e.to_string())?;
        Ok(m)
    }

    /// The forces the dynamometer reads at `rot` (N): the model's, the ploughing term, the
    /// sensor's gains and crosstalk, the speed factor.
    fn signal(
        &self,
        p: &millcomp_sim::force::PreparedCut,
        plough: &Plough,
        speed_rpm: f64,
        rot: f64,
        th: &[f64],
    ) -> [f64; 3] {
        let mut f = p.forces(rot);
        for (c, t) in self.cands.iter().zip(th) {
            if *c == Candidate::Ploughing {
                let g = plough.forces(rot, self.h_min_um);
                for i in 0..3 {
                    f[i] += t * g[i];
                }
            }
        }
        for (c, t) in self.cands.iter().zip(th) {
            match c {
                Candidate::CrosstalkXY => f[1] += t * f[0],
                Candidate::Speed => {
                    let k = (speed_rpm / SPEED_REF_RPM).powf(*t);
                    f = f.map(|v| v * k);
                }
                _ => {}
            }
        }
        for (c, t) in self.cands.iter().zip(th) {
            match c {
                Candidate::SensorGainY => f[1] *= 1.0 + t,
                Candidate::SensorGainZ => f[2] *= 1.0 + t,
                _ => {}
            }
        }
        f
    }

    /// Per run the three responses (per-flute maxima on [`PEAK_GRID`] angles, averaged over the
    /// flutes, as `table33_response`) at W and the candidates' parameters `th`.
    fn responses(&self, w: f64, th: &[f64]) -> std::result::Result<Vec<[f64; 3]>, String> {
        let m = self.model(w, th)?;
        Ok(self
            .conds
            .iter()
            .map(|c| {
                let p = m.prepare(c);
                let plough = Plough::new(&m, c);
                let mut best = [[f64::NEG_INFINITY; 3]; 2];
                for k in 0..PEAK_GRID {
                    let rot = 2.0 * PI * k as f64 / PEAK_GRID as f64;
                    let f = self.signal(&p, &plough, c.speed_rpm, rot, th);
                    let flute = usize::from(2 * k >= PEAK_GRID);
                    for i in 0..3 {
                        best[flute][i] = best[flute][i].max(f[i]);
                    }
                }
                [0, 1, 2].map(|i| 0.5 * (best[0][i] + best[1][i]))
            })
            .collect())
    }

    /// The per-revolution peak z force of the first cut (the groove's peak-and-hold, §6.2).
    fn peak_z(&self, w: f64, th: &[f64]) -> std::result::Result<f64, String> {
        let m = self.model(w, th)?;
        let c = &self.conds[0];
        m.check_conditions(c).map_err(|e| e.to_string())?;
        let p = m.prepare(c);
        let plough = Plough::new(&m, c);
        Ok((0..PEAK_GRID)
            .map(|k| {
                let rot = 2.0 * PI * k as f64 / PEAK_GRID as f64;
                self.signal(&p, &plough, c.speed_rpm, rot, th)[2]
            })
            .fold(f64::NEG_INFINITY, f64::max))
    }
}

/// The ploughing term of one cut: Cartesian forces per unit ploughing force (N per N/µm).
struct Plough {
    radius_um: f64,
    phi: f64,
    window_off: f64,
    ft: [f64; 2],
    cos_a: f64,
    sin_a: f64,
}

impl Plough {
    fn new(m: &BallEndForceModel, c: &CutConditions) -> Self {
        let d = c.depth_um.clamp(0.0, m.tool.radius_um);
        let a = c.tilt_deg.to_radians();
        Plough {
            radius_um: m.tool.radius_um,
            phi: m.contact_angle_rad(d),
            window_off: (1.0 - m.duty_cycle(d, c.tilt_deg)) * FRAC_PI_2,
            ft: [m.feed_per_tooth_um(c, 0), m.feed_per_tooth_um(c, 1)],
            cos_a: a.cos(),
            sin_a: a.sin(),
        }
    }

    /// Forces at `rot_rad` of a unit ploughing force per µm of edge: the edge from the ball's tip
    /// (κ = 0) to κ* = asin(h_min/(ft·sin θ)) (where the chip `ft·sin θ·sin κ` is thinner than
    /// h_min), within the engaged edge κ ≤ φ; cutting and thrust components equal; eqs. (4)–(6).
    fn forces(&self, rot_rad: f64, h_min_um: f64) -> [f64; 3] {
        let r = rot_rad.rem_euclid(2.0 * PI);
        let (flute, th) = if r < PI { (0, r) } else { (1, r - PI) };
        if self.phi <= 0.0 || th < self.window_off || th > PI - self.window_off {
            return [0.0; 3];
        }
        let (s, c) = th.sin_cos();
        let h = self.ft[flute] * s;
        let kappa = if h <= h_min_um {
            FRAC_PI_2
        } else {
            (h_min_um / h).asin()
        };
        let len = self.radius_um * kappa.min(self.phi);
        let (fc, ft) = (len, len);
        let (sh, ch) = (0.5 * self.phi).sin_cos();
        [
            self.cos_a * (fc * s - ft * sh * c),
            self.cos_a * (-fc * c - ft * sh * s),
            fc * c * self.sin_a + ft * ch,
        ]
    }
}

fn residuals(pred: &[[f64; 3]], obs: &[Obs], y: &[f64]) -> Vec<f64> {
    obs.iter()
        .zip(y)
        .map(|(o, y)| pred[o.run][o.axis] - y)
        .collect()
}

fn per_response(
    pred: &[[f64; 3]],
    obs: &[Obs],
    y: &[f64],
    axes: &[usize],
) -> Vec<ResponseResidual> {
    axes.iter()
        .map(|&a| {
            let (mut ss, mut sr, mut sy) = (0.0, 0.0, 0.0);
            let mut per_run = Vec::new();
            for (o, yv) in obs.iter().zip(y).filter(|(o, _)| o.axis == a) {
                let r = pred[o.run][a] - yv;
                ss += r * r;
                sr += r;
                sy += yv;
                per_run.push(r);
            }
            ResponseResidual {
                axis: AXES[a].into(),
                rms_n: (ss / per_run.len() as f64).sqrt(),
                relative_bias: sr / sy,
                per_run_n: per_run,
            }
        })
        .collect()
}

/// The nominal (W only) least-squares W on a subset of the observations: forces are proportional
/// to W under the flow-stress flank law, so W = W₀·Σ f₀y/Σ f₀² (identify force's own start, which is
/// its solution; the full-data value is checked against identify's fit).
fn nominal_w(unit: &[[f64; 3]], obs: &[Obs], y: &[f64], keep: impl Fn(&Obs) -> bool) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (o, yv) in obs.iter().zip(y) {
        if keep(o) {
            let f = unit[o.run][o.axis];
            num += f * yv;
            den += f * f;
        }
    }
    num / den
}

/// Joint fit of W and the candidates' parameters on the observations `keep`.
struct JointFit {
    /// W then the candidates' parameters.
    params: Vec<f64>,
    /// Standard errors, same order.
    se: Vec<f64>,
    rss: f64,
    status: FitStatus,
    dof: usize,
}

fn fit_joint(
    ev: &Evaluator<'_>,
    obs: &[Obs],
    y: &[f64],
    keep: &[usize],
    start: &[f64],
) -> std::result::Result<JointFit, String> {
    let xs: Vec<Obs> = keep.iter().map(|&i| obs[i]).collect();
    let ys: Vec<f64> = keep.iter().map(|&i| y[i]).collect();
    type Cache = Option<(Vec<f64>, Vec<[f64; 3]>)>;
    let cache: RefCell<Cache> = RefCell::new(None);
    let err: RefCell<Option<String>> = RefCell::new(None);
    let f = |o: &Obs, b: &[f64]| -> f64 {
        let mut c = cache.borrow_mut();
        if c.as_ref().map(|(k, _)| k.as_slice() != b).unwrap_or(true) {
            match ev.responses(b[0], &b[1..]) {
                Ok(p) => *c = Some((b.to_vec(), p)),
                Err(e) => {
                    *err.borrow_mut() = Some(e);
                    return f64::NAN;
                }
            }
        }
        c.as_ref()
            .map(|(_, p)| p[o.run][o.axis])
            .unwrap_or(f64::NAN)
    };
    let mut specs = vec![ParamSpec::positive("w_mpa", start[0])];
    for (c, s0) in ev.cands.iter().zip(&start[1..]) {
        specs.push(match c {
            Candidate::Runout => ParamSpec::positive(c.param(), s0.max(0.5)),
            Candidate::FlankWear => {
                ParamSpec::bounded(c.param(), s0.max(0.5), 0.0, ev.base.tool.radius_um)
            }
            _ => ParamSpec::free(c.param(), *s0),
        });
    }
    let fit = CurveFit::new(&xs, &ys, f)
        .label("force", "n")
        .fit_specs(&specs)
        .map_err(|e| match err.borrow().clone() {
            Some(m) => format!("{e}: {m}"),
            None => e.to_string(),
        })?;
    let r = &fit.report;
    let mut se = vec![r.se("w_mpa")];
    se.extend(ev.cands.iter().map(|c| r.se(c.param())));
    Ok(JointFit {
        params: fit.theta.iter().copied().collect(),
        se,
        rss: r.rss,
        status: r.status,
        dof: r.dof,
    })
}

fn status_name(s: FitStatus) -> String {
    match s {
        FitStatus::Converged => "converged",
        FitStatus::StalledAtRoundingLevel => "stalled_at_rounding_level",
        FitStatus::NotConverged => "not_converged",
        FitStatus::RankDeficient => "rank_deficient",
    }
    .into()
}

/// Diagnoses a measured peak-force table against the nominal force model (module docs).
///
/// # Errors
/// * [`DiagnoseError::InvalidOption`] for `alpha` or `power` outside (0, 1) or a non-positive
///   edge radius or h_min ratio;
/// * [`DiagnoseError::UnknownCandidate`] for a name in `opts.candidates` that is no candidate;
/// * [`DiagnoseError::UnknownMaterial`] for a material the physics crate does not know;
/// * [`DiagnoseError::Fit`] when the nominal model cannot be fitted at all (identify's error names
///   the column and row of bad data: a missing force column, a non-finite value, a cut the model
///   rejects);
/// * [`DiagnoseError::TooFewRuns`] for fewer than 3 runs (no leave-one-run-out fit).
///
/// A candidate whose fit fails or does not converge is not an error: its `status` says so.
pub fn diagnose_forces(
    origin: &str,
    data: &PeakForceData<'_>,
    opts: &ForceDiagnoseOptions,
) -> Result<ForceDiagnosis> {
    for (name, v, ok) in [
        ("alpha", opts.alpha, opts.alpha > 0.0 && opts.alpha < 1.0),
        ("power", opts.power, opts.power > 0.0 && opts.power < 1.0),
    ] {
        if !ok {
            return Err(DiagnoseError::InvalidOption {
                name,
                value: v,
                allowed: "(0, 1)",
            });
        }
    }
    for (name, v) in [
        ("edge_radius_um", opts.edge_radius.value),
        ("hmin_ratio", opts.hmin_ratio.value),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(DiagnoseError::InvalidOption {
                name,
                value: v,
                allowed: "> 0",
            });
        }
    }
    let cands: Vec<Candidate> = match &opts.candidates {
        Some(names) => names
            .iter()
            .map(|n| Candidate::parse(n))
            .collect::<Result<_>>()?,
        None => Candidate::ALL.to_vec(),
    };
    let material =
        Material::by_name(&opts.material).map_err(|source| DiagnoseError::UnknownMaterial {
            name: opts.material.clone(),
            source,
        })?;
    // 1. the nominal fit: identify force, W free
    let mut fopts = ForceOptions::default();
    fopts.base.material = material.clone();
    let nominal =
        identify_force(&ForceData::Peaks(*data), &fopts).map_err(|source| DiagnoseError::Fit {
            what: format!("{origin}: the nominal force model (W)"),
            source,
        })?;
    let rep = &nominal.report;
    let w_nom = rep.param("w_mpa");
    let c = &data.conditions;
    let n_runs = c.depth_um.len();
    if n_runs < 3 {
        return Err(DiagnoseError::TooFewRuns {
            origin: origin.into(),
            runs: n_runs,
        });
    }
    let conds: Vec<CutConditions> = (0..n_runs)
        .map(|i| CutConditions {
            depth_um: c.depth_um[i],
            upfeed_um: c.upfeed_um[i],
            speed_rpm: c.speed_rpm.map(|s| s[i]).unwrap_or(10_000.0),
            tilt_deg: c.tilt_deg.map(|t| t[i]).unwrap_or(fopts.default_tilt_deg),
        })
        .collect();
    let cols = [data.max_fx_n, data.max_fy_n, data.max_fz_n];
    let axes: Vec<usize> = (0..3).filter(|&a| cols[a].is_some()).collect();
    let mut obs = Vec::new();
    let mut y = Vec::new();
    for &a in &axes {
        let v = cols[a].expect("present");
        for (run, yv) in v.iter().enumerate() {
            obs.push(Obs { run, axis: a });
            y.push(*yv);
        }
    }
    let n = y.len();
    let base = fopts.base.clone();
    let h_min = opts.h_min_um();
    let eval_err = |e: String| DiagnoseError::Evaluation {
        origin: origin.into(),
        message: e,
    };
    let ev_with = |cands: Vec<Candidate>| Evaluator {
        base: &base,
        conds: &conds,
        cands,
        h_min_um: h_min,
    };
    let ev0 = ev_with(Vec::new());
    let unit = ev0.responses(1.0, &[]).map_err(eval_err)?;
    let pred0 = ev0.responses(w_nom, &[]).map_err(eval_err)?;
    let rss0: f64 = residuals(&pred0, &obs, &y).iter().map(|r| r * r).sum();
    // leave-one-run-out: each run predicted by the model refitted on the other runs
    let loo = |pred_run: &dyn Fn(usize) -> Option<[f64; 3]>| -> Option<f64> {
        let mut ss = 0.0;
        for run in 0..n_runs {
            let p = pred_run(run)?;
            for (o, yv) in obs.iter().zip(&y).filter(|(o, _)| o.run == run) {
                ss += (p[o.axis] - yv).powi(2);
            }
        }
        Some((ss / n as f64).sqrt())
    };
    let loo0 = loo(&|run| {
        let w = nominal_w(&unit, &obs, &y, |o| o.run != run);
        Some(unit[run].map(|u| u * w))
    })
    .unwrap_or(f64::NAN);
    let nominal_fit = NominalFit {
        status: rep.status,
        w_mpa: w_nom,
        w_ci95: rep.ci95.get("w_mpa").copied().unwrap_or([f64::NAN; 2]),
        w_published_mpa: material.w_mpa,
        fixed: rep.fixed.clone(),
        rss: rss0,
        responses: per_response(&pred0, &obs, &y, &axes),
        loo_rms_n: loo0,
    };
    let noise = noise_estimate(&conds, &cols, &axes, rss0, n);
    let theta0 = |c: Candidate| match c {
        Candidate::Runout => base.tool.runout_um,
        Candidate::FlankWear => base.tool.wearland_um,
        _ => 0.0,
    };
    let all: Vec<usize> = (0..n).collect();
    // forward selection: each round tests every remaining candidate added to the current model
    let mut chosen: Vec<Candidate> = Vec::new();
    let mut cur = vec![w_nom];
    let (mut cur_rss, mut cur_loo) = (rss0, loo0);
    let mut remaining = cands.clone();
    let mut rounds: Vec<SelectionRound> = Vec::new();
    let mut steps: Vec<SelectionStep> = Vec::new();
    let mut models = vec![ForceModelFit {
        effects: Vec::new(),
        params: vec![w_nom],
        w_ratio: w_nom / material.w_mpa,
    }];
    while !remaining.is_empty() && chosen.len() < MAX_EFFECTS {
        let m = remaining.len();
        // Bonferroni over the candidates tried in the round: its family-wise level is `alpha`
        let alpha_each = opts.alpha / m as f64;
        let d2 = n.saturating_sub(2 + chosen.len());
        if d2 == 0 {
            break;
        }
        let f_dist = FisherSnedecor::new(1.0, d2 as f64).ok();
        let f_crit = f_dist
            .as_ref()
            .map(|f| f.inverse_cdf(1.0 - alpha_each))
            .unwrap_or(f64::NAN);
        let ratio_crit = 1.0 + f_crit / d2 as f64;
        let lambda_crit = critical_lambda(1.0, d2 as f64, alpha_each, opts.power);
        // the current model's columns (W and the chosen parameters), for the detectable sizes
        let ev_cur = ev_with(chosen.clone());
        let cur_pred = ev_cur.responses(cur[0], &cur[1..]).map_err(eval_err)?;
        let mut cur_cols: Vec<Vec<f64>> = vec![
            obs.iter()
                .map(|o| cur_pred[o.run][o.axis] / cur[0])
                .collect(),
        ];
        for (k, c) in chosen.iter().enumerate() {
            let h = fd_step(*c);
            let (mut pp, mut pm) = (cur.clone(), cur.clone());
            pp[k + 1] += h;
            pm[k + 1] -= h;
            let a = ev_cur.responses(pp[0], &pp[1..]).map_err(eval_err)?;
            let b = ev_cur.responses(pm[0], &pm[1..]).map_err(eval_err)?;
            cur_cols.push(
                obs.iter()
                    .map(|o| (a[o.run][o.axis] - b[o.run][o.axis]) / (2.0 * h))
                    .collect(),
            );
        }
        let mut reports = Vec::new();
        let mut fits: Vec<Option<JointFit>> = Vec::new();
        for cand in &remaining {
            let mut set = chosen.clone();
            set.push(*cand);
            let ev = ev_with(set);
            let t0 = theta0(*cand);
            let uses = candidate_uses(*cand, t0, opts);
            // detectable size: the noncentrality per unit θ, linearised at the current model
            let detectable = (|| {
                let h = fd_step(*cand);
                let lo = if matches!(cand, Candidate::Runout | Candidate::FlankWear) {
                    (t0 - h).max(0.0)
                } else {
                    t0 - h
                };
                let hi = t0 + h;
                let mut pp = cur.clone();
                pp.push(hi);
                let mut pm = cur.clone();
                pm.push(lo);
                let a = ev.responses(pp[0], &pp[1..]).ok()?;
                let b = ev.responses(pm[0], &pm[1..]).ok()?;
                let j: Vec<f64> = obs
                    .iter()
                    .map(|o| (a[o.run][o.axis] - b[o.run][o.axis]) / (hi - lo))
                    .collect();
                let mj2 = residual_norm2(&cur_cols, &j)?;
                (mj2 > 0.0 && lambda_crit.is_finite())
                    .then(|| (lambda_crit * noise.sigma_n.powi(2) / mj2).sqrt())
            })();
            let mut cr = CandidateReport {
                name: cand.name().into(),
                source: cand.source().into(),
                uses,
                param: cand.param().into(),
                nominal_value: t0,
                status: String::new(),
                value: None,
                ci95: None,
                w_mpa: None,
                rss: None,
                f: None,
                dof: [1, d2],
                p: None,
                loo_rms_n: None,
                responses: Vec::new(),
                detectable,
                supported: false,
            };
            let mut start = cur.clone();
            start.push(t0);
            match fit_joint(&ev, &obs, &y, &all, &start) {
                Err(e) => {
                    cr.status = format!("failed: {e}");
                    fits.push(None);
                }
                Ok(jf) => {
                    cr.status = status_name(jf.status);
                    let t = statrs::distribution::StudentsT::new(0.0, 1.0, jf.dof.max(1) as f64)
                        .map(|t| t.inverse_cdf(0.975))
                        .unwrap_or(f64::NAN);
                    let k = jf.params.len() - 1;
                    let v = jf.params[k];
                    cr.value = Some(v);
                    cr.ci95 = Some([v - t * jf.se[k], v + t * jf.se[k]]);
                    cr.w_mpa = Some(jf.params[0]);
                    cr.rss = Some(jf.rss);
                    if let Ok(p) = ev.responses(jf.params[0], &jf.params[1..]) {
                        cr.responses = per_response(&p, &obs, &y, &axes);
                    }
                    let fstat = ((cur_rss - jf.rss) / (jf.rss / d2 as f64)).max(0.0);
                    cr.f = Some(fstat);
                    cr.p = f_dist.as_ref().map(|f| f.sf(fstat));
                    cr.loo_rms_n = loo(&|run| {
                        let keep: Vec<usize> = (0..n).filter(|&i| obs[i].run != run).collect();
                        let jf2 = fit_joint(&ev, &obs, &y, &keep, &jf.params).ok()?;
                        ev.responses(jf2.params[0], &jf2.params[1..])
                            .ok()
                            .map(|p| p[run])
                    });
                    cr.supported = jf.status.is_success()
                        && cr.p.is_some_and(|p| p < alpha_each)
                        && cr.loo_rms_n.is_some_and(|l| l < cur_loo);
                    fits.push(Some(jf));
                }
            }
            reports.push(cr);
        }
        // the best supported candidate by RSS; a supported one within the critical RSS ratio of
        // it is its look-alike (the data cannot tell them apart)
        let mut sup: Vec<usize> = (0..reports.len())
            .filter(|&i| reports[i].supported)
            .collect();
        sup.sort_by(|&a, &b| {
            reports[a]
                .rss
                .partial_cmp(&reports[b].rss)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let given: Vec<String> = chosen.iter().map(|c| c.name().to_string()).collect();
        let Some(&best) = sup.first() else {
            rounds.push(SelectionRound {
                given,
                alpha_each,
                candidates: reports,
                added: None,
                look_alike: None,
            });
            break;
        };
        let r1 = reports[best].rss.unwrap_or(f64::NAN);
        let look_alike = sup
            .get(1)
            .filter(|&&c| reports[c].rss.is_some_and(|r| r / r1 <= ratio_crit))
            .map(|&c| reports[c].name.clone());
        let Some(jf) = fits[best].take() else {
            break;
        };
        let added = remaining[best];
        cur = jf.params;
        cur_rss = jf.rss;
        cur_loo = reports[best].loo_rms_n.unwrap_or(cur_loo);
        chosen.push(added);
        steps.push(SelectionStep {
            added: added.name().into(),
            look_alike: look_alike.clone(),
            w_mpa: cur[0],
            responses: reports[best].responses.clone(),
        });
        models.push(ForceModelFit {
            effects: chosen.iter().map(|c| c.name().to_string()).collect(),
            params: cur.clone(),
            w_ratio: cur[0] / material.w_mpa,
        });
        rounds.push(SelectionRound {
            given,
            alpha_each,
            candidates: reports,
            added: Some(added.name().into()),
            look_alike: look_alike.clone(),
        });
        remaining.retain(|c| *c != added && Some(c.name().to_string()) != look_alike);
    }
    // 4. the verdicts, one per disagreement: the step that closed most of its gap (at least half)
    // names its effect, unless that step's effect had a look-alike
    let w_pub = material.w_mpa;
    let detect: Vec<String> = rounds
        .first()
        .map(|r| {
            r.candidates
                .iter()
                .filter_map(|c| c.detectable.map(|d| format!("{} {}", c.param, sig3(d))))
                .collect()
        })
        .unwrap_or_default();
    let mut verdicts = Vec::new();
    let mut gap_defs: Vec<(String, f64, String, Option<usize>)> = vec![(
        format!("W({}) against the published {}", material.name, w_pub),
        w_nom - w_pub,
        "MPa".into(),
        None,
    )];
    for (k, &a) in axes.iter().enumerate() {
        gap_defs.push((
            format!("{} force relative bias", AXES[a].to_uppercase()),
            nominal_fit.responses[k].relative_bias,
            "1".into(),
            Some(k),
        ));
    }
    for (what, before, unit, k) in gap_defs {
        let gap_after = |st: &SelectionStep| match k {
            None => st.w_mpa - w_pub,
            Some(k) => st
                .responses
                .get(k)
                .map(|r| r.relative_bias)
                .unwrap_or(f64::NAN),
        };
        let mut prev = before;
        let mut best: Option<(usize, f64)> = None;
        for (i, st) in steps.iter().enumerate() {
            let g = gap_after(st);
            let closed = prev.abs() - g.abs();
            if best.is_none_or(|(_, c)| closed > c) {
                best = Some((i, closed));
            }
            prev = g;
        }
        let after = steps.last().map(gap_after).unwrap_or(before);
        let (named, reason) = match best {
            Some((i, closed)) if closed >= 0.5 * before.abs() => match &steps[i].look_alike {
                None => (
                    steps[i].added.clone(),
                    format!(
                        "{} (round {}) is significant, predicts the held-out runs better, has no look-alike and closes most of this gap",
                        steps[i].added,
                        i + 1
                    ),
                ),
                Some(l) => (
                    "none".to_string(),
                    format!(
                        "not identifiable from these data: {} (round {}) closes most of this gap but {} fits as well (RSS within the F test's critical ratio)",
                        steps[i].added,
                        i + 1,
                        l
                    ),
                ),
            },
            _ => (
                "none".to_string(),
                format!(
                    "not identifiable from these data: no added effect closes half of this gap; the smallest changes the round-1 tests could have detected: {}",
                    detect.join(", ")
                ),
            ),
        };
        verdicts.push(Verdict {
            disagreement: what,
            before,
            after,
            unit,
            named,
            reason,
        });
    }
    let mut named: Vec<String> = verdicts
        .iter()
        .filter(|v| v.named != "none")
        .map(|v| v.named.clone())
        .collect();
    named.sort();
    named.dedup();
    Ok(ForceDiagnosis {
        origin: origin.into(),
        material: material.name.clone(),
        n_runs,
        n_obs: n,
        nominal: nominal_fit,
        noise,
        alpha: opts.alpha,
        power: opts.power,
        rounds,
        named,
        verdicts,
        models,
    })
}

/// At most this many effects are added (each costs a residual degree of freedom).
pub const MAX_EFFECTS: usize = 3;

fn fd_step(c: Candidate) -> f64 {
    match c {
        Candidate::Runout | Candidate::FlankWear => 0.5,
        Candidate::Ploughing => 1e-4,
        _ => 1e-3,
    }
}

/// ‖(I − P)j‖² with P the projection on the columns `cols` (least squares by SVD).
fn residual_norm2(cols: &[Vec<f64>], j: &[f64]) -> Option<f64> {
    let n = j.len();
    let x = nalgebra::DMatrix::from_fn(n, cols.len(), |r, c| cols[c][r]);
    let jv = nalgebra::DVector::from_column_slice(j);
    let beta = x.clone().svd(true, true).solve(&jv, 1e-12).ok()?;
    Some((jv - x * beta).norm_squared())
}

fn candidate_uses(cand: Candidate, t0: f64, opts: &ForceDiagnoseOptions) -> Vec<Cited> {
    match cand {
        Candidate::Ploughing => vec![
            opts.edge_radius.clone(),
            opts.hmin_ratio.clone(),
            cited(
                "h_min",
                opts.h_min_um(),
                "um",
                "edge radius x h_min ratio (both above)",
            ),
        ],
        Candidate::Runout => vec![cited(
            "runout_nominal",
            t0,
            "um",
            "the nominal tool's (BallEndTool::default; Table 4-2 typical 10 um; Table 3-3's tool not published)",
        )],
        Candidate::FlankWear => vec![cited(
            "wearland_nominal",
            t0,
            "um",
            "the nominal tool's (000_...txt section 6.2 simulation tool; Table 3-3's tool not published)",
        )],
        _ => Vec::new(),
    }
}

/// The noncentrality at which an F(d1, d2) test at level `alpha` has power `power` (bisection on
/// `millcomp-doe`'s [`f_test_power`]); NaN for invalid arguments.
pub fn critical_lambda(d1: f64, d2: f64, alpha: f64, power: f64) -> f64 {
    let pw = |l: f64| f_test_power(d1, d2, l, alpha).map(|(_, p)| p);
    let (mut lo, mut hi) = (0.0, 1.0);
    while pw(hi).is_some_and(|p| p < power) {
        hi *= 2.0;
        if hi > 1e6 {
            return f64::NAN;
        }
    }
    if pw(hi).is_none() {
        return f64::NAN;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if pw(mid).is_some_and(|p| p < power) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The pooled residual SD of a main-effects regression of each response on the conditions that
/// vary (`millcomp-doe`'s [`analyze`]); the nominal model's residual SD when that has no residual
/// degrees of freedom.
fn noise_estimate(
    conds: &[CutConditions],
    cols: &[Option<&[f64]>; 3],
    axes: &[usize],
    rss0: f64,
    n: usize,
) -> NoiseEstimate {
    let factor_cols: [(&str, Vec<f64>); 4] = [
        ("depth_um", conds.iter().map(|c| c.depth_um).collect()),
        ("upfeed_um", conds.iter().map(|c| c.upfeed_um).collect()),
        ("speed_rpm", conds.iter().map(|c| c.speed_rpm).collect()),
        ("tilt_deg", conds.iter().map(|c| c.tilt_deg).collect()),
    ];
    let varying: Vec<String> = factor_cols
        .iter()
        .filter(|(_, v)| v.iter().any(|x| *x != v[0]))
        .map(|(n, _)| n.to_string())
        .collect();
    let (mut ss, mut df) = (0.0, 0usize);
    for &a in axes {
        let mut table: Vec<(String, Values)> = factor_cols
            .iter()
            .map(|(n, v)| (n.to_string(), Values::F64(v.clone())))
            .collect();
        table.push((
            "response".into(),
            Values::F64(cols[a].expect("present").to_vec()),
        ));
        let an = AnalysisInput::from_table(&table, "response", Some(&varying), ModelSpec::Main)
            .and_then(|i| analyze(&i));
        match an {
            Ok(an) if an.residual_df > 0 => {
                ss += an.residual_sum_sq;
                df += an.residual_df;
            }
            _ => {
                df = 0;
                break;
            }
        }
    }
    if df > 0 {
        NoiseEstimate {
            sigma_n: (ss / df as f64).sqrt(),
            dof: df,
            method: format!(
                "pooled residual SD of a main-effects regression of each response on {} (millcomp-doe analyze)",
                varying.join(", ")
            ),
        }
    } else {
        let dof = n.saturating_sub(1);
        NoiseEstimate {
            sigma_n: (rss0 / dof.max(1) as f64).sqrt(),
            dof,
            method: "the nominal model's residual SD (no main-effects residual degrees of freedom)"
                .into(),
        }
    }
}

/// A cut the fitted model predicts without a scale factor, e.g. the S7 groove's deep end.
#[derive(Debug, Clone)]
pub struct PredictCase {
    /// What is predicted.
    pub name: String,
    /// Material (the physics crate's name).
    pub material: String,
    /// The cut.
    pub cut: CutConditions,
    /// Tool wearland (µm), with its source.
    pub wearland: Cited,
    /// Tool runout (µm), with its source.
    pub runout: Cited,
    /// The measured peak z force (N), with its source.
    pub measured: Cited,
    /// Ways to carry W from the table's material to this one: (name, ratio, source).
    pub transfers: Vec<Cited>,
}

/// One transfer's prediction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransferPrediction {
    /// The transfer (ratio and source).
    pub transfer: Cited,
    /// W of the target material (MPa).
    pub w_mpa: f64,
    /// Predicted peak z force (N).
    pub predicted_n: f64,
    /// measured / predicted: the force scale that would remain.
    pub scale_left: f64,
}

/// The prediction of one [`PredictCase`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// What is predicted.
    pub name: String,
    /// The model used (`nominal` or the named effect).
    pub model: String,
    /// The measured value.
    pub measured: Cited,
    /// Wearland and runout used.
    pub tool: Vec<Cited>,
    /// The cut.
    pub cut: CutConditions,
    /// Per transfer.
    pub transfers: Vec<TransferPrediction>,
}

/// Predicts the peak z force of `case` (per revolution, as [`BallEndForceModel::peak_z_force_n`]
/// on the [`PEAK_GRID`], force scale 1) from one fitted model of a diagnosis (`models`): W of the target material = W fitted × each
/// transfer ratio; the named effect (if any) carried with its fitted parameter (a ploughing force
/// scaled with W, as the flow stress).
///
/// # Errors
/// [`DiagnoseError::UnknownMaterial`] for an unknown material, [`DiagnoseError::Evaluation`] when
/// the physics crate rejects the cut or the tool.
pub fn predict_peak_z(
    fit: &ForceModelFit,
    case: &PredictCase,
    opts: &ForceDiagnoseOptions,
) -> Result<Prediction> {
    let material =
        Material::by_name(&case.material).map_err(|source| DiagnoseError::UnknownMaterial {
            name: case.material.clone(),
            source,
        })?;
    let eval_err = |e: String| DiagnoseError::Evaluation {
        origin: case.name.clone(),
        message: e,
    };
    let mut base = ForceOptions::default().base;
    base.material = material;
    base.tool.wearland_um = case.wearland.value;
    base.tool.runout_um = case.runout.value;
    base.params.force_scale = 1.0;
    let cands: Vec<Candidate> = fit
        .effects
        .iter()
        .map(|e| Candidate::parse(e))
        .collect::<Result<_>>()?;
    let mut transfers = Vec::new();
    for t in &case.transfers {
        let w = fit.params[0] * t.value;
        let th: Vec<f64> = cands
            .iter()
            .zip(&fit.params[1..])
            .map(|(c, v)| match c {
                // a ploughing force scales with the flow stress, as W
                Candidate::Ploughing => v * t.value,
                // the table's tool is not the groove's: the groove's published tool
                Candidate::Runout => case.runout.value,
                Candidate::FlankWear => case.wearland.value,
                _ => *v,
            })
            .collect();
        let conds = [case.cut];
        let ev = Evaluator {
            base: &base,
            conds: &conds,
            cands: cands.clone(),
            h_min_um: opts.h_min_um(),
        };
        let predicted = ev.peak_z(w, &th).map_err(eval_err)?;
        transfers.push(TransferPrediction {
            transfer: t.clone(),
            w_mpa: w,
            predicted_n: predicted,
            scale_left: case.measured.value / predicted,
        });
    }
    Ok(Prediction {
        name: case.name.clone(),
        model: if fit.effects.is_empty() {
            "nominal".into()
        } else {
            fit.effects.join(" + ")
        },
        measured: case.measured.clone(),
        tool: vec![case.wearland.clone(), case.runout.clone()],
        cut: case.cut,
        transfers,
    })
}

/// Three significant digits.
fn sig3(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    let prec = (2 - mag).max(0) as usize;
    format!("{v:.prec$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evaluator_without_candidate_is_table33_response() {
        let base = ForceOptions::default().base;
        let conds = [
            CutConditions::new(200.0, 20.0, 1e4, 0.0).unwrap(),
            CutConditions::new(100.0, 10.0, 2e4, 0.0).unwrap(),
        ];
        let ev = Evaluator {
            base: &base,
            conds: &conds,
            cands: Vec::new(),
            h_min_um: 1.5,
        };
        let p = ev.responses(base.material.w_mpa, &[]).unwrap();
        for (c, pr) in conds.iter().zip(&p) {
            let t = base.table33_response(c).unwrap();
            for i in 0..3 {
                assert!((pr[i] - t[i]).abs() < 1e-3 * t[i].abs(), "{pr:?} {t:?}");
            }
        }
    }

    #[test]
    fn critical_lambda_matches_scipy() {
        // scipy 1.17.1 (the project's venv): c = f.ppf(1 - a, 1, d2);
        // brentq(lambda l: ncf.sf(c, 1, d2, l) - 0.8, 0.1, 200, xtol=1e-12)
        for (d2, alpha, want) in [
            (22.0, 0.05, 8.594152541410017),
            (22.0, 0.05 / 7.0, 14.841367936481356),
            (21.0, 0.01, 13.800324982530732),
        ] {
            let l = critical_lambda(1.0, d2, alpha, 0.8);
            assert!(
                (l - want).abs() < 1e-6 * want,
                "{d2} {alpha}: {l} vs {want}"
            );
        }
        assert!(critical_lambda(1.0, 0.0, 0.05, 0.8).is_nan());
    }
}
