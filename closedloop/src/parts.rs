//! Run-to-run learning: successive parts of one program on one machine. After each part its groove is
//! measured (a profilometer, σ = 0.1 µm), the machine's log gives the gauge and the measured force's
//! per-revolution peak at the same positions, `millcomp_identify::targets::part` fits what the parts so
//! far say about the controllers' deflection model, and the next part's controllers are built from the
//! updated model.
//!
//! What is identified (pooled over every part measured so far, one offset per part for its touch-off):
//! * `deflection_scale` ρ — the measured deflection against the part-1 model's planned deflection: the
//!   force model's scale ÷ the stiffness. The groove alone sees only this ratio;
//! * `compliance_um_per_n` c — the measured deflection against the measured force peak: the z-compliance
//!   per *measured* newton (the tool's compliance ÷ the force sensor's gain, which the force log cannot
//!   separate either).
//!
//! The next part's stiffness is the part-1 model's scaled so its z-compliance is c (the measured-error
//! channel of `pid-tuned` and the MPC divides by it); its force model is rescaled so the plan is ρ times
//! the part-1 plan. Each controller learns from its own parts.
//!
//! The reference is **an MPC given the true model** (`mpc-true-model`): the truth's force model and
//! stiffness for its plan and the truth's compliance per measured newton (its compliance ÷ the sensor's
//! gain) in its measured channel, the same commissioned spindle and sensors. No user can build it; it
//! measures the gap learning can close.
//!
//! The parts share the machine, the tool and the force sensor; each has its own sensor noise, touch-off
//! and force-sensor drift, and its own material: a part-to-part force factor `1 + N(0, σ)` (σ = 2 %, an
//! assumption — the scatter between workpieces of one bar).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use serde::Serialize;

use millcomp_identify::targets::part::{PartData, PartRegressor, identify_part};
use millcomp_identify::{LinearMethod, fit_linear};
use millcomp_models::StiffnessModel;
use millcomp_mpc::groove::DeflectionPlan;
use millcomp_mpc::identified::IdentifiedStiffness;
use millcomp_sim::groove::GrooveConfig;
use millcomp_sim::sensors::{InstrumentErrors, NoiseSpec, PROFILOMETER_SIGMA_UM};
use nalgebra::DMatrix;

use crate::error::{ClosedLoopError, invalid};
use crate::groove::{GrooveSetup, deflection_plan, groove_setup, run_groove_with};
use crate::model_errors::ForceErrors;
use crate::report::Trace;
use crate::scenario::commissioned;
use crate::scenario::{ControllerKind, Scenario, StageKind};
use crate::stats::{median, median_ci95};

/// Name of the reference rows: the MPC given the true model.
pub const REFERENCE: &str = "mpc-true-model";

/// How a run-to-run study is made.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartsPlan {
    /// Parts cut in a row (≥ 1).
    pub parts: usize,
    /// Profile spacing along the groove (mm).
    pub profile_step_mm: f64,
    /// Profilometer noise σ (µm).
    pub profilometer_sigma_um: f64,
    /// σ of the part-to-part force factor (relative).
    pub part_force_scatter: f64,
    /// Size of the deliberate force-model errors on the commissioned model: W, rake and flank friction
    /// and wearland each off by ± this (signs drawn per seed).
    pub force_error_rel: f64,
    /// Size of the deliberate stiffness error on the commissioned model (sign drawn per seed).
    pub stiffness_error_rel: f64,
    /// The fit uses the groove where the part-1 plan is at least this fraction of its largest value
    /// (the first micrometres of a ramp, where the tool barely cuts, carry no scale).
    pub min_plan_fraction: f64,
}

impl Default for PartsPlan {
    fn default() -> Self {
        Self {
            parts: 3,
            profile_step_mm: 0.05,
            profilometer_sigma_um: PROFILOMETER_SIGMA_UM,
            part_force_scatter: 0.02,
            force_error_rel: 0.15,
            stiffness_error_rel: 0.10,
            min_plan_fraction: 0.1,
        }
    }
}

impl PartsPlan {
    /// Check the plan (errors name the option).
    ///
    /// # Errors
    /// [`ClosedLoopError::InvalidConfig`] naming the field.
    pub fn validate(&self) -> Result<(), ClosedLoopError> {
        if self.parts == 0 {
            return Err(invalid("parts", self.parts, "at least 1"));
        }
        let checks = [
            ("profile_step_mm", self.profile_step_mm, 1e-3, 1.0),
            (
                "profilometer_sigma_um",
                self.profilometer_sigma_um,
                0.0,
                5.0,
            ),
            ("part_force_scatter", self.part_force_scatter, 0.0, 0.3),
            ("force_error_rel", self.force_error_rel, 0.0, 0.5),
            ("stiffness_error_rel", self.stiffness_error_rel, 0.0, 0.5),
            ("min_plan_fraction", self.min_plan_fraction, 0.0, 0.9),
        ];
        for (k, v, lo, hi) in checks {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(invalid(k, v, format!("in [{lo}, {hi}]")));
            }
        }
        Ok(())
    }
}

/// An estimate with its 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// Value.
    pub value: f64,
    /// 95 % interval.
    pub ci95: [f64; 2],
}

impl Estimate {
    /// Whether `v` lies in the interval.
    pub fn covers(&self, v: f64) -> bool {
        self.ci95[0] <= v && v <= self.ci95[1]
    }
}

/// One part cut by one controller.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartRow {
    /// Seed of the machine (tool, instruments, commissioning, deliberate errors).
    pub seed: u64,
    /// Part number (1-based).
    pub part: usize,
    /// Controller (or [`REFERENCE`]).
    pub controller: String,
    /// Peak-to-peak groove error (µm).
    pub pp_error_um: f64,
    /// RMS groove error (µm).
    pub rms_error_um: f64,
    /// The force factor of this part's model over the part-1 model.
    pub force_factor: f64,
    /// The stiffness factor of this part's model over the part-1 model.
    pub stiffness_factor: f64,
    /// ρ identified from the parts up to and including this one (what the next part uses).
    pub deflection_scale: Option<Estimate>,
    /// c identified from the parts up to and including this one (µm/N).
    pub compliance_um_per_n: Option<Estimate>,
    /// Profile points of this part left out of the fit because the gauge read its range limit there.
    pub gauge_saturated_points: usize,
    /// Why the models were not updated after this part, if they were not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_updated: Option<String>,
    /// Median MPC solve time (µs), MPC rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solve_median_us: Option<f64>,
    /// p99 MPC solve time (µs), MPC rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solve_p99_us: Option<f64>,
}

/// One machine (seed): every controller's parts, the reference's, and the true values of what was
/// identified (hidden from every controller; for the report only).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartsRun {
    /// Seed.
    pub seed: u64,
    /// Rows, by controller then part.
    pub rows: Vec<PartRow>,
    /// The true ρ per part: the truth's planned deflection (its force model at the programmed
    /// conditions × its compliance) projected on the part-1 plan, over the fitted window.
    pub true_deflection_scale: Vec<f64>,
    /// The true compliance per measured newton (µm/N): the truth's z-compliance ÷ the sensor's gain.
    pub true_compliance_um_per_n: f64,
    /// The deliberate errors laid on the commissioned model (force parameters, stiffness).
    pub force_errors: ForceErrors,
    /// See [`Self::force_errors`].
    pub stiffness_error: f64,
}

/// The scenario the study runs: commissioned ([`commissioned`]), with the plan's deliberate errors on
/// top — each force parameter and the stiffness off by their full size, signs drawn from the seed.
fn study_scenario(s: &Scenario, plan: &PartsPlan, seed: u64) -> Scenario {
    let mut s = commissioned(s);
    s.seed = seed;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9a27_5eed);
    let mut sign = || {
        if rand::Rng::random_bool(&mut rng, 0.5) {
            1.0
        } else {
            -1.0
        }
    };
    let e = plan.force_error_rel;
    s.truth.force_errors = Some(ForceErrors {
        w_mpa: sign() * e,
        mu_rake: sign() * e,
        mu_flank: sign() * e,
        wearland_um: sign() * e,
    });
    s.truth.stiffness_error = sign() * plan.stiffness_error_rel;
    s
}

/// Part `part`'s truth: the machine's plant with this part's noise, touch-off, drift and force factor.
fn part_truth(base: &GrooveConfig, s: &Scenario, plan: &PartsPlan, part: usize) -> GrooveConfig {
    let mut t = base.clone();
    let seed = s.seed.wrapping_mul(1_000_003).wrapping_add(part as u64);
    if let Some(n) = &mut t.force_noise {
        n.seed = seed.wrapping_mul(31).wrapping_add(1);
    }
    if let Some(n) = &mut t.gauge_noise {
        *n = NoiseSpec {
            seed: seed.wrapping_mul(31).wrapping_add(2),
            sigma: n.sigma,
        };
    }
    if s.truth.draw_instruments && part > 1 {
        let d = InstrumentErrors::draw(seed);
        t.instruments.touch_off_um = d.touch_off_um;
        t.instruments.force_drift_n_per_s = d.force_drift_n_per_s;
    }
    if part > 1 && plan.part_force_scatter > 0.0 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x00fa_c7e5);
        let z: f64 = Normal::new(0.0, 1.0).map_or(0.0, |d| d.sample(&mut rng));
        t.force_model.params.force_scale *= 1.0 + plan.part_force_scatter * z.clamp(-3.0, 3.0);
    }
    t
}

/// The points of one measured part: the profilometer's groove error at every `profile_step_mm` where
/// the part-1 plan is large enough, with the gauge and force peak the machine logged there, and the
/// part-1 model's deflection at the depth the profilometer measured (the force follows the depth
/// actually cut, not the programmed one: a part cut 2 µm too deep at 60 µm met ≈ 4 % more force).
struct Measured {
    deflection_um: Vec<f64>,
    model_um: Vec<f64>,
    force_peak_n: Vec<f64>,
    /// Profile points left out because the gauge read its range limit there.
    saturated: usize,
}

/// The part-1 model the measurements are regressed on: its set-up (force predictor, stiffness, tool),
/// its plan and z-compliance, and the profile positions the fit uses ([`fit_window`], once).
struct Model0<'a> {
    setup: &'a GrooveSetup,
    plan: &'a DeflectionPlan,
    compliance_um_per_n: f64,
    window: Vec<f64>,
}

impl Model0<'_> {
    /// The model's deflection at `x_mm` for a groove of depth `depth_um` there.
    fn deflection_at_depth(&self, x_mm: f64, depth_um: f64) -> Result<f64, ClosedLoopError> {
        let s = self.setup;
        Ok(self.plan.deflection_at_depth(
            &s.truth.program,
            &s.model_force,
            &s.model_stiffness,
            s.nominal_tool.radius_um,
            x_mm,
            depth_um,
        )?)
    }
}

fn measure(
    trace: &Trace,
    model0: &Model0<'_>,
    plan: &PartsPlan,
    seed: u64,
) -> Result<Measured, ClosedLoopError> {
    let col = |name: &str| {
        trace.column(name).ok_or_else(|| {
            invalid(
                "trace",
                name,
                "a groove trace (x_mm, depth_cmd_um, depth_cut_um, gauge_um, force_peak_n)",
            )
        })
    };
    let (x, cmd, cut, gauge, fpk) = (
        col("x_mm")?,
        col("depth_cmd_um")?,
        col("depth_cut_um")?,
        col("gauge_um")?,
        col("force_peak_n")?,
    );
    let program = &model0.setup.truth.program;
    let sin_a = program.tilt_deg.to_radians().sin();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0bf1_1e00);
    let noise = Normal::new(0.0, plan.profilometer_sigma_um).map_err(|e| {
        invalid(
            "profilometer_sigma_um",
            plan.profilometer_sigma_um,
            e.to_string(),
        )
    })?;
    let mut m = Measured {
        deflection_um: vec![],
        model_um: vec![],
        force_peak_n: vec![],
        saturated: 0,
    };
    // a gauge at the end of its range (the RD20's 50 µm: the 20° groove's deep end needs 55 µm of tip)
    // reads its limit, bit for bit, where a live reading never repeats (its noise): such rows measure
    // nothing and are left out
    let repeated = repeated_readings(&gauge);
    for &xk in &model0.window {
        // the logged row nearest to xk (the feed moves forward: x is sorted)
        let i = x
            .partition_point(|v| *v < xk)
            .min(x.len().saturating_sub(1));
        if repeated.contains(&gauge[i].to_bits()) {
            m.saturated += 1;
            continue;
        }
        let depth_meas = cut[i] + noise.sample(&mut rng);
        m.deflection_um
            .push(sin_a * gauge[i] - (depth_meas - cmd[i]));
        m.model_um.push(model0.deflection_at_depth(xk, depth_meas)?);
        m.force_peak_n.push(fpk[i]);
    }
    Ok(m)
}

/// The readings (as bits) that occur more than once in a noisy channel's log: a clamped instrument
/// (at the end of its range) repeats its limit exactly, a live reading with noise never does.
fn repeated_readings(log: &[f64]) -> std::collections::HashSet<u64> {
    let mut seen = std::collections::HashSet::new();
    let mut repeated = std::collections::HashSet::new();
    for v in log {
        if !seen.insert(v.to_bits()) {
            repeated.insert(v.to_bits());
        }
    }
    repeated
}

/// The profile positions (mm) the fit uses: every `profile_step_mm` where the part-1 plan is at least
/// `min_plan_fraction` of its largest value.
fn fit_window(plan0: &DeflectionPlan, length_mm: f64, plan: &PartsPlan) -> Vec<f64> {
    let n = (length_mm / plan.profile_step_mm).floor() as usize;
    let xs: Vec<f64> = (0..=n).map(|k| k as f64 * plan.profile_step_mm).collect();
    let peak = xs
        .iter()
        .map(|x| plan0.deflection_at(*x))
        .fold(0.0, f64::max);
    xs.into_iter()
        .filter(|x| plan0.deflection_at(*x) >= plan.min_plan_fraction * peak)
        .collect()
}

/// The plan of the truth (its force model at the programmed conditions × its compliance): the
/// reference MPC's, and the source of the true ρ.
fn true_plan(t: &GrooveConfig) -> Result<DeflectionPlan, ClosedLoopError> {
    let c = t.stiffness.z_compliance_um_per_n(t.program.tilt_deg)?;
    Ok(DeflectionPlan::reference(
        &t.program,
        t.force_model.tool.radius_um,
        0.01,
        c,
        |cond| t.force_model.peak_z_force_n(cond),
    )?)
}

/// Slope of `y` on `x` with an intercept (least squares).
fn slope(x: &[f64], y: &[f64]) -> Result<f64, ClosedLoopError> {
    let a = DMatrix::from_fn(x.len(), 2, |i, j| if j == 0 { x[i] } else { 1.0 });
    let names = ["slope".to_string(), "intercept".to_string()];
    let fit = fit_linear(&names, &a, y, None, LinearMethod::Qr, "true scale", "um")
        .map_err(|e| invalid("true deflection scale", "fit", e.to_string()))?;
    Ok(fit.theta[0])
}

/// One controller's parts on one machine.
fn controller_parts(
    s: &Scenario,
    base: &GrooveSetup,
    model0: &Model0<'_>,
    plan: &PartsPlan,
    kind: ControllerKind,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<PartRow>, ClosedLoopError> {
    let c0 = model0.compliance_um_per_n;
    let (mut force_factor, mut stiffness_factor) = (1.0, 1.0);
    let (mut part_col, mut defl, mut reg_plan, mut reg_force) = (vec![], vec![], vec![], vec![]);
    let mut rows = Vec::with_capacity(plan.parts);
    for part in 1..=plan.parts {
        let used = (force_factor, stiffness_factor);
        let mut setup = base.clone();
        setup.truth = part_truth(&base.truth, s, plan, part);
        setup.model_force = base.model_force.rescaled(force_factor)?;
        setup.model_stiffness = base.model_stiffness.scaled(stiffness_factor)?;
        let part_plan = deflection_plan(&setup, 0.01)?;
        let out = run_groove_with(s, &setup, &part_plan, kind)?;
        progress();
        let m = measure(
            &out.trace,
            model0,
            plan,
            s.seed.wrapping_mul(7919).wrapping_add(part as u64),
        )?;
        let gauge_saturated_points = m.saturated;
        part_col.extend(std::iter::repeat_n(part, m.deflection_um.len()));
        defl.extend(m.deflection_um);
        reg_plan.extend(m.model_um);
        reg_force.extend(m.force_peak_n);
        let fit = |what, reg: &[f64]| {
            identify_part(
                &PartData {
                    part: &part_col,
                    deflection_um: &defl,
                    regressor: reg,
                },
                what,
            )
            .map(|f| {
                let name = PartRegressor::parameter(what);
                Estimate {
                    value: f.report.param(name),
                    ci95: f.report.ci95[name],
                }
            })
        };
        let rho = fit(PartRegressor::PlannedDeflection, &reg_plan);
        let c = fit(PartRegressor::MeasuredForce, &reg_force);
        let not_updated = match (&rho, &c) {
            (Ok(r), Ok(c)) if r.value > 0.0 && c.value > 0.0 => {
                stiffness_factor = c0 / c.value;
                force_factor = r.value * c0 / c.value;
                None
            }
            (Err(e), _) | (_, Err(e)) => Some(format!("fit failed: {e}")),
            _ => Some("an identified scale or compliance was not positive".into()),
        };
        let stats = out.report.solver.as_ref();
        rows.push(PartRow {
            seed: s.seed,
            part,
            controller: kind.name().into(),
            pp_error_um: out.report.metrics.pp_error_um,
            rms_error_um: out.report.metrics.rms_error_um,
            force_factor: used.0,
            stiffness_factor: used.1,
            deflection_scale: rho.ok(),
            compliance_um_per_n: c.ok(),
            gauge_saturated_points,
            not_updated,
            solve_median_us: stats.map(|s| s.median_us),
            solve_p99_us: stats.map(|s| s.p99_us),
        });
    }
    Ok(rows)
}

/// The reference's parts: an MPC given the true model on each part's truth.
fn reference_parts(
    s: &Scenario,
    base: &GrooveSetup,
    plan: &PartsPlan,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<PartRow>, ClosedLoopError> {
    let mut rows = Vec::with_capacity(plan.parts);
    for part in 1..=plan.parts {
        let mut setup = base.clone();
        setup.truth = part_truth(&base.truth, s, plan, part);
        let t = &setup.truth;
        // the truth's stiffness times the sensor's gain: its compliance per measured newton
        let gain = t.instruments.force_gain;
        setup.model_stiffness = IdentifiedStiffness::new(&StiffnessModel {
            axial_n_per_um: t.stiffness.axial_n_per_um * gain,
            radial_n_per_um: t.stiffness.radial_n_per_um * gain,
            covariance: Default::default(),
        })?;
        let truth_plan = true_plan(t)?;
        let out = run_groove_with(s, &setup, &truth_plan, ControllerKind::Mpc)?;
        progress();
        let stats = out.report.solver.as_ref();
        rows.push(PartRow {
            seed: s.seed,
            part,
            controller: REFERENCE.into(),
            pp_error_um: out.report.metrics.pp_error_um,
            rms_error_um: out.report.metrics.rms_error_um,
            force_factor: f64::NAN,
            stiffness_factor: f64::NAN,
            deflection_scale: None,
            compliance_um_per_n: None,
            gauge_saturated_points: 0,
            not_updated: Some("the reference does not learn".into()),
            solve_median_us: stats.map(|s| s.median_us),
            solve_p99_us: stats.map(|s| s.p99_us),
        });
    }
    Ok(rows)
}

/// Cut `plan.parts` parts of a groove scenario on one machine (`seed`) with each of `controllers`, and
/// the reference; see the module documentation.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] for a thin-wall scenario, an invalid plan or a controller the
/// groove does not have; set-up (commissioning), model and physics errors.
pub fn run_parts(
    s: &Scenario,
    controllers: &[ControllerKind],
    plan: &PartsPlan,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<PartsRun, ClosedLoopError> {
    plan.validate()?;
    if s.stage != StageKind::Groove {
        return Err(invalid(
            "stage",
            s.stage.name(),
            "groove (run-to-run learning is the PZT spindle's)",
        ));
    }
    for k in controllers {
        if !k.runs_on(StageKind::Groove) {
            return Err(invalid("controller", k.name(), "a groove controller"));
        }
    }
    let study = study_scenario(s, plan, seed);
    let base = groove_setup(&study)?;
    let plan0 = deflection_plan(&base, 0.01)?;
    let model0 = Model0 {
        setup: &base,
        plan: &plan0,
        compliance_um_per_n: base
            .model_stiffness
            .stiffness()
            .z_compliance_um_per_n(base.truth.program.tilt_deg)?,
        window: fit_window(&plan0, base.truth.program.length_mm, plan),
    };
    let jobs: Vec<Option<ControllerKind>> = controllers
        .iter()
        .map(|k| Some(*k))
        .chain(std::iter::once(None))
        .collect();
    let results: Vec<Result<Vec<PartRow>, ClosedLoopError>> = jobs
        .par_iter()
        .map(|k| match k {
            Some(k) => controller_parts(&study, &base, &model0, plan, *k, progress),
            None => reference_parts(&study, &base, plan, progress),
        })
        .collect();
    let mut rows = Vec::new();
    for r in results {
        rows.extend(r?);
    }
    // the true ρ of each part over the fitted window
    let window = &model0.window;
    let p0: Vec<f64> = window.iter().map(|x| plan0.deflection_at(*x)).collect();
    let mut true_scale = Vec::with_capacity(plan.parts);
    for part in 1..=plan.parts {
        let tp = true_plan(&part_truth(&base.truth, &study, plan, part))?;
        let y: Vec<f64> = window.iter().map(|x| tp.deflection_at(*x)).collect();
        true_scale.push(slope(&p0, &y)?);
    }
    let t = &base.truth;
    Ok(PartsRun {
        seed,
        rows,
        true_deflection_scale: true_scale,
        true_compliance_um_per_n: t.stiffness.z_compliance_um_per_n(t.program.tilt_deg)?
            / t.instruments.force_gain,
        force_errors: study.truth.force_errors.unwrap_or_default(),
        stiffness_error: study.truth.stiffness_error,
    })
}

/// One controller's result at one part over the machines (seeds).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartSummary {
    /// Controller (or [`REFERENCE`]).
    pub controller: String,
    /// Part number.
    pub part: usize,
    /// Machines.
    pub n: usize,
    /// Median peak-to-peak error (µm) and its 95 % interval.
    pub pp_error_um: Estimate,
    /// Median of the per-machine gap to the reference's pp on the same part (µm), with its interval.
    pub gap_um: Estimate,
    /// In how many machines the pooled ρ's interval after this part covers the true ρ (the mean of the
    /// parts' true values so far).
    pub scale_covered: usize,
    /// In how many machines c's interval after this part covers the true compliance per measured newton.
    pub compliance_covered: usize,
    /// Median |ρ − true ρ| / true ρ after this part.
    pub scale_error_rel: f64,
}

fn estimate(mut v: Vec<f64>) -> Estimate {
    let value = median(&mut v);
    Estimate {
        value,
        ci95: median_ci95(&v),
    }
}

/// Summaries per controller and part over the machines, and for each controller the shrink of its
/// median gap to the reference from part 1 to part `k`: `1 − gap_k / gap_1`.
pub fn summarize(runs: &[PartsRun]) -> Vec<PartSummary> {
    let mut names: Vec<String> = Vec::new();
    let mut parts = 0;
    for r in runs {
        for row in &r.rows {
            if !names.contains(&row.controller) {
                names.push(row.controller.clone());
            }
            parts = parts.max(row.part);
        }
    }
    let mut out = Vec::new();
    for name in &names {
        for part in 1..=parts {
            let (mut pp, mut gap) = (vec![], vec![]);
            let (mut sc, mut cc) = (0, 0);
            let mut serr = vec![];
            for r in runs {
                let row = r
                    .rows
                    .iter()
                    .find(|x| x.controller == *name && x.part == part);
                let reference = r
                    .rows
                    .iter()
                    .find(|x| x.controller == REFERENCE && x.part == part);
                let Some(row) = row else { continue };
                pp.push(row.pp_error_um);
                if let Some(refr) = reference {
                    gap.push(row.pp_error_um - refr.pp_error_um);
                }
                let k = part.min(r.true_deflection_scale.len());
                let truth = r.true_deflection_scale[..k].iter().sum::<f64>() / k.max(1) as f64;
                if let Some(e) = row.deflection_scale {
                    sc += usize::from(e.covers(truth));
                    serr.push((e.value - truth).abs() / truth);
                }
                if let Some(e) = row.compliance_um_per_n {
                    cc += usize::from(e.covers(r.true_compliance_um_per_n));
                }
            }
            out.push(PartSummary {
                controller: name.clone(),
                part,
                n: pp.len(),
                pp_error_um: estimate(pp),
                gap_um: estimate(gap),
                scale_covered: sc,
                compliance_covered: cc,
                scale_error_rel: median(&mut serr),
            });
        }
    }
    out
}

/// Every part of every machine as one table (`parts.csv`): seed, part, controller, pp and rms error,
/// the model factors the part was cut with, and ρ and c after it with their intervals.
///
/// # Errors
/// [`ClosedLoopError::Dataset`] when the columns cannot form a table (not expected).
pub fn rows_table(runs: &[PartsRun]) -> Result<millcomp_datasets::Table, ClosedLoopError> {
    use millcomp_datasets::{Column, ColumnData, Table};
    let rows: Vec<&PartRow> = runs.iter().flat_map(|r| &r.rows).collect();
    let float = |name: &str, f: &dyn Fn(&PartRow) -> f64| Column {
        name: name.into(),
        data: ColumnData::Float(rows.iter().map(|r| f(r)).collect()),
    };
    let est = |e: Option<Estimate>, i: usize| match (e, i) {
        (Some(e), 0) => e.value,
        (Some(e), i) => e.ci95[i - 1],
        (None, _) => f64::NAN,
    };
    let cols = vec![
        Column {
            name: "seed".into(),
            data: ColumnData::Int(rows.iter().map(|r| r.seed as i64).collect()),
        },
        Column {
            name: "part".into(),
            data: ColumnData::Int(rows.iter().map(|r| r.part as i64).collect()),
        },
        Column {
            name: "controller".into(),
            data: ColumnData::Text(rows.iter().map(|r| r.controller.clone()).collect()),
        },
        float("pp_error_um", &|r| r.pp_error_um),
        Column {
            name: "gauge_saturated_points".into(),
            data: ColumnData::Int(
                rows.iter()
                    .map(|r| r.gauge_saturated_points as i64)
                    .collect(),
            ),
        },
        float("rms_error_um", &|r| r.rms_error_um),
        float("force_factor", &|r| r.force_factor),
        float("stiffness_factor", &|r| r.stiffness_factor),
        float("deflection_scale", &|r| est(r.deflection_scale, 0)),
        float("deflection_scale_lo", &|r| est(r.deflection_scale, 1)),
        float("deflection_scale_hi", &|r| est(r.deflection_scale, 2)),
        float("compliance_um_per_n", &|r| est(r.compliance_um_per_n, 0)),
        float("compliance_lo_um_per_n", &|r| est(r.compliance_um_per_n, 1)),
        float("compliance_hi_um_per_n", &|r| est(r.compliance_um_per_n, 2)),
    ];
    Ok(Table::from_columns("parts", cols)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clamped_gauge_is_recognised_by_its_repeated_limit() {
        // a noisy ramp that runs into a 50 µm range limit: the limit repeats, live readings do not
        let log: Vec<f64> = (0..100)
            .map(|i| (0.6 * i as f64 + 0.01 * ((i * 7919) % 13) as f64).min(50.0))
            .collect();
        let r = repeated_readings(&log);
        assert_eq!(r.len(), 1);
        assert!(r.contains(&50.0f64.to_bits()));
        assert!(!r.contains(&log[10].to_bits()));
    }
}
