//! Commissioning, as a machine is commissioned: calibration experiments run on the truth plant *through its
//! instruments* (force sensor with its gain error, drift, noise and quantisation; capacitance gauge with its
//! zero offset and noise; dial indicator with its resolution), each identified with `millcomp-identify`,
//! the results written as one [`ModelBundle`]. Nothing of the truth crosses except what the instruments
//! read; the starting model is the *nominal* one a user has (published material table, catalogue tool,
//! force scale 1).
//!
//! The three experiments:
//! 1. **Force calibration**: a full-factorial DOE (`millcomp-doe`) over depth and upfeed at the plant's
//!    speed and tilt, `replicates` times; each run is cut for `revolutions` revolutions, the force sensor is
//!    zeroed before the cut (as in `000_…txt` §3.4) and sampled `samples_per_rev` times per revolution; the
//!    traces are synchronously averaged over the revolutions (so the noise averages out without bias) and
//!    the free force parameters fitted to them (`identify force`, trace form).
//! 2. **Spindle step test** in air: from a bias voltage (so that the gauge reads inside its range), a
//!    voltage step held for `step_duration_s`, the gauge sampled every `step_dt_s`; three structures fitted
//!    (`identify spindle`: 2nd order; + a real pole; + pole and dead time) and the one with the smallest
//!    BIC kept (the choice and the BICs go into the bundle's warnings/experiments).
//! 3. **Load–deflection** (`000_…txt` §5.2.3): hanging masses, read by a dial indicator
//!    ([`StiffnessCalibration`]), axial and radial directions fitted by `identify stiffness`.
//! 4. **Hysteresis sweep** in air: the amplifier drives the stack quasi-statically through the turning
//!    points `hysteresis_turning_v` at `hysteresis_rate_v_per_s`, the gauge (its offset, noise and 0–50 µm
//!    range) read every `hysteresis_dt_s`; a Prandtl–Ishlinskii model fitted (`identify hysteresis`). A
//!    linear stack gives a model that is linear too (the plays' weights ≈ 0).
//! 5. **Sensors at rest**: the force channel (spindle in air, not cutting) and the gauge (PZT held) recorded
//!    for `noise_samples` samples every `step_dt_s`; each channel's noise level is its sample standard
//!    deviation (quantisation included), with the χ² 95 % interval. The MPC's Kalman filter takes its
//!    measurement noise from here.
//!
//! [`Commissioned::pseudo_true`] is what each identified parameter *should* come out as — the value the
//! truth implies for it through the same instruments: the same fit on the same experiment without noise
//! and quantisation (force, spindle), the truth's stiffness (loads and indicator are unbiased), and the
//! standard deviation of the truth's noise through the channel's quantiser (sensors at rest). The coverage
//! study compares the intervals to it. The hysteresis model has none: it is not the stack's form, and its
//! intervals are not claimed (its report flags the correlated residuals).

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

use millcomp_doe::{DesignKind, DesignRequest, FactorSpec, Level, generate};
use millcomp_identify::targets::Identified;
use millcomp_identify::targets::force::{
    ForceConditions, ForceData, ForceOptions, ForceParam, ForceTraceData, identify_force,
};
use millcomp_identify::targets::hysteresis::{
    HysteresisData, HysteresisOptions, identify_hysteresis,
};
use millcomp_identify::targets::spindle::{SpindleData, SpindleOptions, identify_spindle};
use millcomp_identify::targets::stiffness::{StiffnessData, StiffnessOptions, identify_stiffness};
use millcomp_models::{FitStatus, IdentifiedModel, ModelBundle, NamedMatrix, SensorNoise};
use millcomp_mpc::identified::NominalTool;
use millcomp_sim::force::{BallEndForceModel, CutConditions};
use millcomp_sim::groove::GrooveConfig;
use millcomp_sim::sensors::{CapacitanceGauge, ForceSensor, InstrumentErrors};

use crate::calibration::{G_N_PER_KG, StiffnessCalibration, axial_masses_g, radial_masses_g};
pub use crate::commissioning_plan::CommissioningPlan;
use crate::error::{ClosedLoopError, invalid};
use crate::scenario::Scenario;

/// The plant as the commissioning sees it: the truth and its instruments, with the sensors' noise levels.
#[derive(Debug, Clone)]
pub struct CommissioningPlant<'a> {
    /// The truth plant (force model, stiffness, spindle) and the program's speed and tilt.
    pub truth: &'a GrooveConfig,
    /// The instruments' errors.
    pub instruments: InstrumentErrors,
    /// Force-sensor noise σ (N); quantisation is the same value (`000_…txt` §5.2.2: 0.04 N).
    pub force_noise_n: f64,
    /// Gauge noise σ (µm).
    pub gauge_noise_um: f64,
    /// The workpiece material's name (the nominal model's material; written into the bundle).
    pub material: &'a str,
}

impl<'a> CommissioningPlant<'a> {
    /// The plant of a groove scenario: its truth (`crate::groove::groove_truth`, with its instruments) and
    /// the scenario's sensor noise and material.
    pub fn of_scenario(s: &'a Scenario, truth: &'a GrooveConfig) -> Self {
        Self {
            truth,
            instruments: truth.instruments,
            force_noise_n: s.truth.force_noise_n,
            gauge_noise_um: s.truth.gauge_noise_um,
            material: s.groove.as_ref().map_or("", |g| g.material.as_str()),
        }
    }
}

/// One identified experiment: the fit and what it was.
#[derive(Debug, Clone)]
pub struct Experiment {
    /// What was done, in words.
    pub description: String,
    /// The identification.
    pub fit: Identified,
}

/// The sensors' record at rest: the levels as a saveable model and their 95 % intervals.
#[derive(Debug, Clone)]
pub struct NoiseRecord {
    /// What was done, in words.
    pub description: String,
    /// The levels (kind `sensor_noise`: `force_noise_n`, `gauge_noise_um`) with standard errors.
    pub model: IdentifiedModel,
    /// χ² 95 % interval of each level.
    pub ci95: BTreeMap<String, [f64; 2]>,
}

/// The result of a commissioning.
#[derive(Debug, Clone)]
pub struct Commissioned {
    /// The bundle the controllers are built from.
    pub bundle: ModelBundle,
    /// Force calibration.
    pub force: Experiment,
    /// Spindle step test (the selected structure).
    pub spindle: Experiment,
    /// BIC of each spindle structure tried (name → BIC; the smallest was kept).
    pub spindle_bic: Vec<(String, f64)>,
    /// Load–deflection test.
    pub stiffness: Experiment,
    /// Hysteresis sweep in air.
    pub hysteresis: Experiment,
    /// The sensors' record at rest.
    pub sensor_noise: NoiseRecord,
    /// The value the truth implies for each identified parameter through the same instruments (see the
    /// module docs), by parameter name (`force.w_mpa`, `spindle.zeta`, `stiffness.axial_stiffness_n_per_um`…).
    pub pseudo_true: BTreeMap<String, f64>,
}

impl Commissioned {
    /// Every identified parameter: `(name, estimate, standard error, 95 % interval)`, named
    /// `<experiment>.<parameter>` (`force.w_mpa`, …, `sensor_noise.gauge_noise_um`).
    pub fn parameters(&self) -> Vec<(String, f64, f64, [f64; 2])> {
        let mut out = Vec::new();
        for (prefix, e) in [
            ("force", &self.force),
            ("spindle", &self.spindle),
            ("stiffness", &self.stiffness),
            ("hysteresis", &self.hysteresis),
        ] {
            let r = &e.fit.report;
            for (name, v) in &r.params {
                let ci = r.ci95.get(name).copied().unwrap_or([f64::NAN; 2]);
                out.push((format!("{prefix}.{name}"), *v, r.se(name), ci));
            }
        }
        let m = &self.sensor_noise.model;
        for (name, v) in &m.params {
            let ci = self
                .sensor_noise
                .ci95
                .get(name)
                .copied()
                .unwrap_or([f64::NAN; 2]);
            let se = m.std_err.get(name).copied().unwrap_or(f64::NAN);
            out.push((format!("sensor_noise.{name}"), *v, se, ci));
        }
        out
    }

    /// Every identified parameter with its estimate, 95 % interval and pseudo-true value:
    /// `(name, estimate, [lo, hi], pseudo_true)`.
    pub fn intervals(&self) -> Vec<(String, f64, [f64; 2], f64)> {
        self.parameters()
            .into_iter()
            .filter_map(|(name, v, _, ci)| {
                let t = *self.pseudo_true.get(&name)?;
                Some((name, v, ci, t))
            })
            .collect()
    }
}

/// The nominal force model a user starts from: the published material, the catalogue tool
/// ([`NominalTool::thesis_ball_end`]: radius 400 µm, runout 10 µm as measured, wearland 5 µm as the
/// starting value), force scale 1.
///
/// # Errors
/// [`ClosedLoopError::Mpc`] for an unknown material.
pub fn nominal_force_model(material: &str) -> Result<BallEndForceModel, ClosedLoopError> {
    Ok(NominalTool::thesis_ball_end(material).force_model()?)
}

/// Run the three experiments on the plant and identify them (seeded).
///
/// # Errors
/// Bad plan values ([`ClosedLoopError::InvalidConfig`] naming `commissioning.<key>`), the physics
/// crate's errors, and identification errors ([`ClosedLoopError::Commissioning`] naming the experiment).
/// A fit that did not converge or is poorly identified is *not* an error: its warnings go into the bundle.
pub fn commission(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
) -> Result<Commissioned, ClosedLoopError> {
    commission_with(plant, plan, seed, true)
}

/// The bundle of [`commission`] alone — the same bundle, value for value — without the pseudo-true
/// values: the force and spindle experiments are not run a second time without noise. What a run's
/// controllers are built from (`crate::groove::groove_setup`).
///
/// # Errors
/// As [`commission`].
pub fn commission_bundle(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
) -> Result<ModelBundle, ClosedLoopError> {
    Ok(commission_with(plant, plan, seed, false)?.bundle)
}

/// [`commission`]; the force and spindle experiments are rerun without noise for their pseudo-true values
/// only when `pseudo_true_wanted` (without, the map holds only the values that cost nothing).
fn commission_with(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
    pseudo_true_wanted: bool,
) -> Result<Commissioned, ClosedLoopError> {
    validate_plan(plan)?;
    let mut pseudo_true = BTreeMap::new();

    let (force, force_desc) = force_experiment(plant, plan, seed, true)?;
    if pseudo_true_wanted {
        let (force_ideal, _) = force_experiment(plant, plan, seed, false)?;
        for (k, v) in &force_ideal.report.params {
            pseudo_true.insert(format!("force.{k}"), *v);
        }
    }

    let (spindle, spindle_bic, spindle_desc, structure) =
        spindle_experiment(plant, plan, seed, true, None)?;
    if pseudo_true_wanted {
        let (spindle_ideal, _, _, _) =
            spindle_experiment(plant, plan, seed, false, Some(structure))?;
        for (k, v) in &spindle_ideal.report.params {
            pseudo_true.insert(format!("spindle.{k}"), *v);
        }
    }

    let (stiffness, stiffness_desc) = stiffness_experiment(plant, plan, seed)?;
    pseudo_true.insert(
        "stiffness.axial_stiffness_n_per_um".into(),
        plant.truth.stiffness.axial_n_per_um,
    );
    pseudo_true.insert(
        "stiffness.radial_stiffness_n_per_um".into(),
        plant.truth.stiffness.radial_n_per_um,
    );
    // the indicator offsets are pure instrument zeros (truth 0)
    pseudo_true.insert("stiffness.axial_offset_um".into(), 0.0);
    pseudo_true.insert("stiffness.radial_offset_um".into(), 0.0);

    // no pseudo-true values for the hysteresis: its model is not the stack's form (a Prandtl–Ishlinskii
    // fit of whatever the stack does), its residuals are correlated along the sweep and the plays it
    // keeps depend on the noise — the report says so, and no coverage is claimed
    let (hysteresis, hysteresis_desc) = hysteresis_experiment(plant, plan, seed)?;

    let sensor_noise = noise_experiment(plant, plan, seed)?;
    pseudo_true.insert(
        "sensor_noise.force_noise_n".into(),
        quantised_sd(plant.force_noise_n, plant.force_noise_n),
    );
    pseudo_true.insert("sensor_noise.gauge_noise_um".into(), plant.gauge_noise_um);

    let mut warnings = Vec::new();
    for (what, fit) in [
        ("force", &force),
        ("spindle", &spindle),
        ("stiffness", &stiffness),
        ("hysteresis", &hysteresis),
    ] {
        warnings.extend(fit.report.warnings.iter().map(|w| format!("{what}: {w}")));
    }
    for (what, fit) in [("force", &force), ("stiffness", &stiffness)] {
        for (name, v) in &fit.report.params {
            if what == "stiffness" && !name.ends_with("stiffness_n_per_um") {
                continue;
            }
            let rel = fit.report.se(name) / v.abs();
            if rel.is_nan() || rel > plan.accept_rel_se {
                warnings.push(format!(
                    "{what}: {name} has a relative standard error of {:.1} %, above the {:.1} % the plan \
                     accepts (commissioning.accept_rel_se): the experiment is too small to trust this model",
                    100.0 * rel,
                    100.0 * plan.accept_rel_se
                ));
            }
        }
    }
    let bundle = ModelBundle {
        material: plant.material.to_string(),
        experiments: vec![
            force_desc.clone(),
            spindle_desc.clone(),
            stiffness_desc.clone(),
            hysteresis_desc.clone(),
            sensor_noise.description.clone(),
        ],
        warnings,
        spindle: Some(spindle.model.clone()),
        force: Some(force.model.clone()),
        stiffness: Some(stiffness.model.clone()),
        sensor_noise: Some(sensor_noise.model.clone()),
        hysteresis: Some(hysteresis.model.clone()),
    };
    Ok(Commissioned {
        bundle,
        force: Experiment {
            description: force_desc,
            fit: force,
        },
        spindle: Experiment {
            description: spindle_desc,
            fit: spindle,
        },
        spindle_bic,
        stiffness: Experiment {
            description: stiffness_desc,
            fit: stiffness,
        },
        hysteresis: Experiment {
            description: hysteresis_desc,
            fit: hysteresis,
        },
        sensor_noise,
        pseudo_true,
    })
}

fn validate_plan(p: &CommissioningPlan) -> Result<(), ClosedLoopError> {
    let key = |k: &str| format!("commissioning.{k}");
    for (name, levels) in [
        ("force_depths_um", &p.force_depths_um),
        ("force_upfeeds_um", &p.force_upfeeds_um),
    ] {
        if levels.is_empty() || levels.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(invalid(
                key(name),
                format!("{levels:?}"),
                "one or more finite levels > 0",
            ));
        }
    }
    for (name, v) in [
        ("replicates", p.replicates),
        ("revolutions", p.revolutions),
        ("samples_per_rev", p.samples_per_rev),
    ] {
        if v == 0 {
            return Err(invalid(key(name), v, "at least 1"));
        }
    }
    for (name, v) in [
        ("step_v", p.step_v),
        ("step_duration_s", p.step_duration_s),
        ("step_dt_s", p.step_dt_s),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(invalid(key(name), v, "finite and > 0"));
        }
    }
    if !(p.step_bias_v.is_finite() && p.step_bias_v >= 0.0) {
        return Err(invalid(
            key("step_bias_v"),
            p.step_bias_v,
            "finite and >= 0",
        ));
    }
    if !(10..=1_000_000).contains(&p.noise_samples) {
        return Err(invalid(
            key("noise_samples"),
            p.noise_samples,
            "10 to 1 000 000",
        ));
    }
    if p.step_duration_s / p.step_dt_s > 20_000.0 {
        return Err(invalid(
            key("step_duration_s"),
            p.step_duration_s,
            "at most 20 000 samples of step_dt_s",
        ));
    }
    for (name, v) in [
        ("hysteresis_rate_v_per_s", p.hysteresis_rate_v_per_s),
        ("hysteresis_dt_s", p.hysteresis_dt_s),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(invalid(key(name), v, "finite and > 0"));
        }
    }
    if p.hysteresis_turning_v.len() < 2
        || p.hysteresis_turning_v
            .iter()
            .any(|v| !v.is_finite() || *v < 0.0)
    {
        return Err(invalid(
            key("hysteresis_turning_v"),
            format!("{:?}", p.hysteresis_turning_v),
            "two or more finite voltages >= 0 (a loop needs a reversal)",
        ));
    }
    let travel: f64 = std::iter::once(0.0)
        .chain(p.hysteresis_turning_v.iter().copied())
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .sum();
    if travel / p.hysteresis_rate_v_per_s / p.hysteresis_dt_s > 1e6 {
        return Err(invalid(
            key("hysteresis_rate_v_per_s"),
            p.hysteresis_rate_v_per_s,
            "a sweep of at most 1 000 000 samples of hysteresis_dt_s",
        ));
    }
    if !(p.accept_rel_se.is_finite() && p.accept_rel_se > 0.0) {
        return Err(invalid(
            key("accept_rel_se"),
            p.accept_rel_se,
            "finite and > 0",
        ));
    }
    if p.force_free.is_empty() {
        return Err(invalid(
            key("force_free"),
            "[]",
            "at least one force parameter",
        ));
    }
    Ok(())
}

fn fmt_levels(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join("/")
}

/// The force calibration; `noisy = false` gives the pseudo-true fit (same instruments' gain and drift, no
/// noise, no quantisation).
fn force_experiment(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
    noisy: bool,
) -> Result<(Identified, String), ClosedLoopError> {
    let mut factors = Vec::new();
    let mut levels_of = Vec::new();
    for (name, levels) in [
        ("depth_um", &plan.force_depths_um),
        ("upfeed_um", &plan.force_upfeeds_um),
    ] {
        if levels.len() > 1 {
            let spec = format!("{name}={}", fmt_levels(levels).replace('/', ":"));
            factors.push(FactorSpec::parse(&spec).map_err(|source| {
                ClosedLoopError::Commissioning {
                    experiment: "force calibration design",
                    source: Box::new(source),
                }
            })?);
            levels_of.push(name);
        }
    }
    let program = &plant.truth.program;
    // the runs: (depth, upfeed) in run order
    let runs: Vec<(f64, f64)> = if factors.is_empty() {
        vec![(plan.force_depths_um[0], plan.force_upfeeds_um[0]); plan.replicates]
    } else {
        let mut req = DesignRequest::new(DesignKind::Full, factors);
        req.replicates = plan.replicates;
        req.seed = Some(seed ^ 0xd0e);
        let design = generate(&req).map_err(|source| ClosedLoopError::Commissioning {
            experiment: "force calibration design",
            source: Box::new(source),
        })?;
        let mut runs: Vec<_> = design.runs.iter().collect();
        runs.sort_by_key(|r| r.run_order);
        runs.iter()
            .map(|r| {
                let mut d = plan.force_depths_um[0];
                let mut f = plan.force_upfeeds_um[0];
                for (i, name) in levels_of.iter().enumerate() {
                    if let Level::Num(v) = r.actual[i] {
                        if *name == "depth_um" {
                            d = v;
                        } else {
                            f = v;
                        }
                    }
                }
                (d, f)
            })
            .collect()
    };
    let cuts = runs
        .iter()
        .map(|&(d, f)| CutConditions::new(d, f, program.speed_rpm, program.tilt_deg))
        .collect::<Result<Vec<_>, _>>()?;
    let traces = record_force_calibration(
        plant,
        &cuts,
        plan.revolutions,
        plan.samples_per_rev,
        seed,
        noisy,
    )?;
    let fit = identify_force_traces(&traces, plant.material, &plan.force_free, program.tilt_deg)?;
    let desc = format!(
        "force: full factorial depth_um {} x upfeed_um {}, {} replicate(s), {} runs at {} rpm and tilt {} deg, \
         {} revolutions each synchronously averaged at {} samples/rev; free {}",
        fmt_levels(&plan.force_depths_um),
        fmt_levels(&plan.force_upfeeds_um),
        plan.replicates,
        runs.len(),
        program.speed_rpm,
        program.tilt_deg,
        plan.revolutions,
        plan.samples_per_rev,
        plan.force_free.join(", ")
    );
    Ok((fit, desc))
}

/// A force calibration as the dynamometer recorded it: for every sample of every run, the run's cut
/// conditions, the rotation angle and the z-force synchronously averaged over the run's revolutions (the
/// columns of `millcomp identify force` on traces).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ForceTraces {
    /// Run of each sample (0-based, in the order cut).
    pub run: Vec<usize>,
    /// Programmed depth (µm).
    pub depth_um: Vec<f64>,
    /// Upfeed (µm/rev).
    pub upfeed_um: Vec<f64>,
    /// Spindle speed (rpm).
    pub speed_rpm: Vec<f64>,
    /// Tool tilt (deg).
    pub tilt_deg: Vec<f64>,
    /// Rotation angle of the sample (deg).
    pub rot_deg: Vec<f64>,
    /// Measured z-force averaged over the revolutions (N).
    pub fz_n: Vec<f64>,
}

/// Cuts `cuts` on the plant, each for `revolutions` revolutions, the force sensor zeroed before the cut and
/// sampled `samples_per_rev` times a revolution through the plant's instruments (gain, drift; with
/// `noisy`, its noise and quantisation too), averaged synchronously over the revolutions.
///
/// # Errors
/// The sensor's errors for a bad noise level.
pub fn record_force_calibration(
    plant: &CommissioningPlant<'_>,
    cuts: &[CutConditions],
    revolutions: usize,
    samples_per_rev: usize,
    seed: u64,
    noisy: bool,
) -> Result<ForceTraces, ClosedLoopError> {
    let spr = samples_per_rev.max(1);
    let mut out = ForceTraces::default();
    for (k, cond) in cuts.iter().enumerate() {
        let rev_s = 60.0 / cond.speed_rpm;
        let prepared = plant.truth.force_model.prepare(cond);
        let mut sensor = if noisy {
            ForceSensor::new(
                plant.force_noise_n,
                plant.force_noise_n,
                seed.wrapping_mul(1009).wrapping_add(k as u64),
            )?
        } else {
            ForceSensor::ideal()
        };
        let mut sum = vec![0.0; spr];
        for r in 0..revolutions {
            for (j, s) in sum.iter_mut().enumerate() {
                let phase = j as f64 / spr as f64;
                let t = (r as f64 + phase) * rev_s;
                let true_fz = prepared.forces(2.0 * std::f64::consts::PI * phase)[2];
                *s += sensor.measure(plant.instruments.force_reading(true_fz, t));
            }
        }
        for (j, s) in sum.iter().enumerate() {
            out.run.push(k);
            out.depth_um.push(cond.depth_um);
            out.upfeed_um.push(cond.upfeed_um);
            out.speed_rpm.push(cond.speed_rpm);
            out.tilt_deg.push(cond.tilt_deg);
            out.rot_deg.push(360.0 * j as f64 / spr as f64);
            out.fz_n.push(s / revolutions.max(1) as f64);
        }
    }
    Ok(out)
}

/// Identifies the force parameters `free` (names of `identify force --free`; the rest at the nominal
/// values of `material`'s catalogue tool) from recorded force traces, as a commissioning does: the fit
/// starts from the W at which the nominal model's mean force matches the measured mean, with tolerances
/// for a trace fit of a thousand noisy samples.
///
/// # Errors
/// [`ClosedLoopError::Commissioning`] naming the force calibration for an unknown parameter or a fit that
/// fails; an unknown material.
pub fn identify_force_traces(
    traces: &ForceTraces,
    material: &str,
    free: &[String],
    default_tilt_deg: f64,
) -> Result<Identified, ClosedLoopError> {
    // the nominal model's force at the same samples, for the fit's starting W (below)
    let mut base = nominal_force_model(material)?;
    let mut predicted = 0.0;
    for i in 0..traces.fz_n.len() {
        let cond = CutConditions::new(
            traces.depth_um[i],
            traces.upfeed_um[i],
            traces.speed_rpm[i],
            traces.tilt_deg[i],
        )?;
        predicted += base.prepare(&cond).forces(traces.rot_deg[i].to_radians())[2];
    }
    let free = free
        .iter()
        .map(|n| ForceParam::parse(n))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|source| ClosedLoopError::Commissioning {
            experiment: "force calibration",
            source: Box::new(source),
        })?;
    // start W where the nominal model's mean force matches the measured mean (the model is close to
    // proportional to W): a start 3–4× off (the groove's calibrated force scale) otherwise costs hundreds
    // of trust-region steps
    let measured: f64 = traces.fz_n.iter().sum();
    if predicted.is_finite() && predicted > 0.0 && measured > 0.0 {
        base.material.w_mpa *= measured / predicted;
    }
    // identify's defaults: its gradient test stops at its own resolution (identify's nonlinear module),
    // which the ~1300 trace samples reach in a few iterations
    let common = millcomp_identify::targets::thermal::CommonOptions::default();
    let opts = ForceOptions {
        base,
        common,
        free,
        default_tilt_deg,
        ..ForceOptions::default()
    };
    let data = ForceData::Traces(ForceTraceData {
        conditions: ForceConditions {
            depth_um: &traces.depth_um,
            upfeed_um: &traces.upfeed_um,
            speed_rpm: Some(&traces.speed_rpm),
            tilt_deg: Some(&traces.tilt_deg),
        },
        rot_deg: &traces.rot_deg,
        fx_n: None,
        fy_n: None,
        fz_n: Some(&traces.fz_n),
    });
    identify_force(&data, &opts).map_err(|source| ClosedLoopError::Commissioning {
        experiment: "force calibration",
        source: Box::new(source),
    })
}

/// Spindle structures tried, in order of complexity: (name, extra pole, dead time).
pub const SPINDLE_STRUCTURES: [(&str, bool, bool); 3] = [
    ("2nd order", false, false),
    ("2nd order + pole", true, false),
    ("2nd order + pole + dead time", true, true),
];

/// Bayesian information criterion of a least-squares fit: `n ln(RSS/n) + p ln n`.
pub fn bic(fit: &Identified) -> f64 {
    let n = fit.report.n_obs as f64;
    let p = fit.report.params.len() as f64;
    let rss = fit.report.rms_residual.value.powi(2) * n;
    n * (rss / n).max(f64::MIN_POSITIVE).ln() + p * n.ln()
}

type SpindleOutcome = (Identified, Vec<(String, f64)>, String, usize);

fn spindle_experiment(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
    noisy: bool,
    structure: Option<usize>,
) -> Result<SpindleOutcome, ClosedLoopError> {
    let rec = record_step_test(plant, plan, seed, noisy)?;
    let (fit, bics, chosen) = identify_step_test(&rec, structure)?;
    let desc = format!(
        "spindle: step test in air, {} V -> {} V, {} s after the step sampled every {} s by the gauge; \
         structure {} chosen by BIC",
        plan.step_bias_v,
        plan.step_bias_v + plan.step_v,
        plan.step_duration_s,
        plan.step_dt_s,
        SPINDLE_STRUCTURES[chosen].0
    );
    Ok((fit, bics, desc, chosen))
}

/// A spindle step test as the gauge recorded it (the columns of `millcomp identify spindle`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepRecord {
    /// Time (s).
    pub t_s: Vec<f64>,
    /// Amplifier command (V).
    pub u_v: Vec<f64>,
    /// Gauge reading of the tool tip (µm).
    pub y_um: Vec<f64>,
}

/// The step test in air: the stack settled at the plan's bias, then a step of `step_v`, the gauge (its
/// zero offset; with `noisy`, its noise) sampled every `step_dt_s` before each interval's command.
///
/// # Errors
/// The spindle's discretisation errors; a bad gauge noise level.
pub fn record_step_test(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
    noisy: bool,
) -> Result<StepRecord, ClosedLoopError> {
    let mut sp = plant.truth.spindle.discretize(plan.step_dt_s)?;
    let pre = (0.005 / plan.step_dt_s).round() as usize;
    let post = (plan.step_duration_s / plan.step_dt_s).round() as usize;
    // settle at the bias before recording
    let settle = (0.2 / plan.step_dt_s).round() as usize;
    for _ in 0..settle {
        sp.step(plan.step_bias_v);
    }
    let noise = Normal::new(0.0, if noisy { plant.gauge_noise_um } else { 0.0 }).map_err(|_| {
        invalid(
            "truth.gauge_noise_um",
            plant.gauge_noise_um,
            "finite and >= 0",
        )
    })?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5_7e9);
    let mut rec = StepRecord::default();
    for k in 0..pre + post {
        let v = if k < pre {
            plan.step_bias_v
        } else {
            plan.step_bias_v + plan.step_v
        };
        // sample the gauge before applying this interval's command (ZOH: y[k] depends on u[..k])
        let tip = sp.tip_um();
        rec.t_s.push(k as f64 * plan.step_dt_s);
        rec.u_v.push(v);
        rec.y_um
            .push(tip + plant.instruments.gauge_offset_um + noise.sample(&mut rng));
        sp.step(v);
    }
    Ok(rec)
}

/// A spindle fit from a step test: the fit kept, every structure's BIC (by name) and the index of the
/// one kept ([`identify_step_test`]).
pub type SpindleFit = (Identified, Vec<(String, f64)>, usize);

/// Identifies the spindle from a step record: each structure of [`SPINDLE_STRUCTURES`] (or only
/// `structure`) fitted, the one with the smallest BIC kept (its choice and the BICs noted in its
/// warnings). Returns the fit, every structure's BIC and the index of the one kept.
///
/// # Errors
/// [`ClosedLoopError::Commissioning`] naming the spindle step test when a fit fails.
pub fn identify_step_test(
    rec: &StepRecord,
    structure: Option<usize>,
) -> Result<SpindleFit, ClosedLoopError> {
    let data = SpindleData {
        t_s: &rec.t_s,
        u_v: &rec.u_v,
        y_um: &rec.y_um,
    };
    let mut fits = Vec::new();
    let which: Vec<usize> = match structure {
        Some(i) => vec![i],
        None => (0..SPINDLE_STRUCTURES.len()).collect(),
    };
    for &i in &which {
        let (_, pole, dead) = SPINDLE_STRUCTURES[i];
        let opts = SpindleOptions {
            extra_pole: pole,
            dead_time: dead,
            ..SpindleOptions::default()
        };
        let fit =
            identify_spindle(&data, &opts).map_err(|source| ClosedLoopError::Commissioning {
                experiment: "spindle step test",
                source: Box::new(source),
            })?;
        fits.push((i, fit));
    }
    let bics: Vec<(String, f64)> = fits
        .iter()
        .map(|(i, f)| (SPINDLE_STRUCTURES[*i].0.to_string(), bic(f)))
        .collect();
    let best = (0..fits.len())
        .min_by(|&a, &b| bics[a].1.total_cmp(&bics[b].1))
        .unwrap_or(0);
    let (chosen, mut fit) = fits.swap_remove(best);
    if structure.is_none() {
        let list = bics
            .iter()
            .map(|(n, b)| format!("{n} {b:.1}"))
            .collect::<Vec<_>>()
            .join(", ");
        fit.report.warnings.push(format!(
            "structure chosen by BIC: {} (BIC {list})",
            SPINDLE_STRUCTURES[chosen].0
        ));
        fit.model.warnings = fit.report.warnings.clone();
    }
    Ok((fit, bics, chosen))
}

/// The hysteresis sweep: from rest at 0 V the drive voltage ramps through the plan's turning points at
/// its rate, the gauge (its offset, noise and range) read after every step.
fn hysteresis_experiment(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
) -> Result<(Identified, String), ClosedLoopError> {
    let rec = record_hysteresis_sweep(plant, plan, seed)?;
    let fit = identify_hysteresis_sweep(&rec)?;
    let desc = format!(
        "hysteresis: sweep in air from 0 V through {} V at {} V/s, the gauge read every {} s; \
         Prandtl-Ishlinskii model, {} plays",
        fmt_levels(&plan.hysteresis_turning_v),
        plan.hysteresis_rate_v_per_s,
        plan.hysteresis_dt_s,
        fit.report.params.len() - 1
    );
    Ok((fit, desc))
}

/// A quasi-static sweep in air as the gauge recorded it (the columns of `millcomp identify hysteresis`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SweepRecord {
    /// Drive voltage (V).
    pub u_v: Vec<f64>,
    /// Gauge reading of the tool tip (µm).
    pub y_um: Vec<f64>,
}

/// The hysteresis sweep of the plan on the plant's stack, read by its gauge (offset, noise, range).
///
/// # Errors
/// The spindle's discretisation errors; a bad gauge.
pub fn record_hysteresis_sweep(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
) -> Result<SweepRecord, ClosedLoopError> {
    let dt = plan.hysteresis_dt_s;
    let mut sp = plant.truth.spindle.discretize(dt)?;
    let mut gauge = CapacitanceGauge::new(
        CapacitanceGauge::rd20().range_um,
        CapacitanceGauge::rd20().sensitivity_um_per_v,
        plant.instruments.gauge_offset_um,
        plant.gauge_noise_um,
        seed ^ 0x4_7573,
    )?;
    let dv = plan.hysteresis_rate_v_per_s * dt;
    let mut rec = SweepRecord::default();
    let mut v = 0.0f64;
    for &target in &plan.hysteresis_turning_v {
        let n = ((target - v).abs() / dv).ceil().max(1.0) as usize;
        let from = v;
        for k in 1..=n {
            v = from + (target - from) * k as f64 / n as f64;
            sp.step(v);
            rec.u_v.push(v);
            rec.y_um.push(gauge.measure_um(sp.tip_um()));
        }
    }
    Ok(rec)
}

/// Identifies the stack's Prandtl–Ishlinskii hysteresis from a sweep record.
///
/// # Errors
/// [`ClosedLoopError::Commissioning`] naming the hysteresis sweep when the fit fails.
pub fn identify_hysteresis_sweep(rec: &SweepRecord) -> Result<Identified, ClosedLoopError> {
    identify_hysteresis(
        &HysteresisData {
            u_v: &rec.u_v,
            y_um: &rec.y_um,
        },
        &HysteresisOptions::default(),
    )
    .map_err(|source| ClosedLoopError::Commissioning {
        experiment: "hysteresis sweep",
        source: Box::new(source),
    })
}

fn stiffness_experiment(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
) -> Result<(Identified, String), ClosedLoopError> {
    let cal = &plan.stiffness;
    let rec = record_load_deflection(plant, cal, seed)?;
    let fit = identify_load_deflection(&rec, &[plant.truth.program.tilt_deg])?;
    let desc = format!(
        "stiffness: hanging masses 100-1000 g axial, 50-1000 g radial, {} trial(s) each, dial indicator \
         resolution {} um, noise {} um",
        cal.trials, cal.indicator_resolution_um, cal.noise_um
    );
    Ok((fit, desc))
}

/// A load–deflection test as the dial indicator recorded it (the columns of `millcomp identify
/// stiffness`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadRecord {
    /// Hanging load (N).
    pub load_n: Vec<f64>,
    /// Indicator reading (µm).
    pub deflection_um: Vec<f64>,
    /// `axial` or `radial`.
    pub direction: Vec<String>,
}

/// The load–deflection test (`000_…txt` §5.2.3): the masses hung axially and radially, `cal.trials` times
/// each, read by the dial indicator (its resolution and noise).
///
/// # Errors
/// A bad indicator noise level.
pub fn record_load_deflection(
    plant: &CommissioningPlant<'_>,
    cal: &StiffnessCalibration,
    seed: u64,
) -> Result<LoadRecord, ClosedLoopError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(7));
    let noise = cal.noise()?;
    let mut rec = LoadRecord::default();
    for (name, masses, k) in [
        (
            "axial",
            axial_masses_g(),
            plant.truth.stiffness.axial_n_per_um,
        ),
        (
            "radial",
            radial_masses_g(),
            plant.truth.stiffness.radial_n_per_um,
        ),
    ] {
        for m in masses {
            let f = m * 1e-3 * G_N_PER_KG;
            for _ in 0..cal.trials.max(1) {
                rec.load_n.push(f);
                rec.deflection_um
                    .push(cal.reading_um(f / k, &noise, &mut rng));
                rec.direction.push(name.to_string());
            }
        }
    }
    Ok(rec)
}

/// Identifies the axial and radial stiffness from a load–deflection record, with the tilted tool's
/// z-stiffness reported at `tilt_deg`.
///
/// # Errors
/// [`ClosedLoopError::Commissioning`] naming the load–deflection test when the fit fails.
pub fn identify_load_deflection(
    rec: &LoadRecord,
    tilt_deg: &[f64],
) -> Result<Identified, ClosedLoopError> {
    identify_stiffness(
        &StiffnessData {
            load_n: &rec.load_n,
            deflection_um: &rec.deflection_um,
            direction: Some(&rec.direction),
        },
        &StiffnessOptions {
            tilt_deg: tilt_deg.to_vec(),
            ..StiffnessOptions::default()
        },
    )
    .map_err(|source| ClosedLoopError::Commissioning {
        experiment: "load-deflection test",
        source: Box::new(source),
    })
}

/// The standard deviation of `N(0, σ²)` read through a quantiser of step `q` (σ when `q` is 0): the level
/// a record at rest measures. Summed over the quantiser's levels within ±12 σ.
fn quantised_sd(sigma: f64, q: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal as StdNormal};
    if q <= 0.0 || sigma <= 0.0 {
        return sigma.max(0.0);
    }
    let Ok(n) = StdNormal::new(0.0, sigma) else {
        return sigma;
    };
    let k_max = (12.0 * sigma / q).ceil() as i64 + 1;
    (-k_max..=k_max)
        .map(|k| {
            let x = k as f64 * q;
            let p = n.cdf(x + 0.5 * q) - n.cdf(x - 0.5 * q);
            p * x * x
        })
        .sum::<f64>()
        .sqrt()
}

/// Each sensor recorded at rest: the force channel (zeroed, spindle in air) and the gauge (PZT held at the
/// step test's bias, the tip at mid-range). The level is the sample standard deviation; its standard error
/// σ̂/√(2(n−1)) and its 95 % interval from χ²(n−1).
fn noise_experiment(
    plant: &CommissioningPlant<'_>,
    plan: &CommissioningPlan,
    seed: u64,
) -> Result<NoiseRecord, ClosedLoopError> {
    let rec = record_sensors_at_rest(plant, plan.noise_samples, plan.step_dt_s, seed)?;
    sensor_noise_at_rest(&rec)
}

/// The sensors recorded at rest (`t_s, force_n, gauge_um`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RestRecord {
    /// Sampling interval (s).
    pub dt_s: f64,
    /// The force channel, zeroed, spindle in air (N).
    pub force_n: Vec<f64>,
    /// The gauge, PZT held (µm).
    pub gauge_um: Vec<f64>,
}

/// Each sensor recorded at rest for `samples` samples every `dt_s`: the force channel (zeroed, spindle in
/// air) and the gauge (PZT held, the tip at mid-range), through the plant's instruments.
///
/// # Errors
/// A bad noise level.
pub fn record_sensors_at_rest(
    plant: &CommissioningPlant<'_>,
    samples: usize,
    dt_s: f64,
    seed: u64,
) -> Result<RestRecord, ClosedLoopError> {
    let mut force = ForceSensor::new(plant.force_noise_n, plant.force_noise_n, seed ^ 0x0015_e0f0)?;
    let mut gauge = CapacitanceGauge::new(
        50.0,
        2.5,
        plant.instruments.gauge_offset_um,
        plant.gauge_noise_um,
        seed ^ 0x0015_e06a,
    )?;
    let mut rec = RestRecord {
        dt_s,
        force_n: Vec::with_capacity(samples),
        gauge_um: Vec::with_capacity(samples),
    };
    for k in 0..samples {
        let t = k as f64 * dt_s;
        rec.force_n
            .push(force.measure(plant.instruments.force_reading(0.0, t)));
        rec.gauge_um.push(gauge.measure_um(25.0));
    }
    Ok(rec)
}

/// The sensors' noise levels from a record at rest: each channel's sample standard deviation with its
/// standard error σ̂/√(2(n−1)) and its χ²(n−1) 95 % interval, as a saveable model (kind
/// `sensor_noise`).
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] naming `commissioning.noise_samples` for fewer than 10 samples or
/// channels of different lengths.
pub fn sensor_noise_at_rest(rec: &RestRecord) -> Result<NoiseRecord, ClosedLoopError> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let n = rec.force_n.len();
    if n < 10 || rec.gauge_um.len() != n {
        return Err(invalid(
            "commissioning.noise_samples",
            n,
            ">= 10 samples of each channel, as many of one as of the other",
        ));
    }
    let (f, g) = (&rec.force_n, &rec.gauge_um);
    let sd = |x: &[f64]| {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
    };
    let dof = (n - 1) as f64;
    let chi =
        ChiSquared::new(dof).map_err(|_| invalid("commissioning.noise_samples", n, ">= 10"))?;
    let (c_hi, c_lo) = (chi.inverse_cdf(0.975), chi.inverse_cdf(0.025));
    let mut params = BTreeMap::new();
    let mut std_err = BTreeMap::new();
    let mut ci95 = BTreeMap::new();
    for (name, x) in [(SensorNoise::PARAMS[0], f), (SensorNoise::PARAMS[1], g)] {
        let s = sd(x);
        params.insert(name.to_string(), s);
        std_err.insert(name.to_string(), s / (2.0 * dof).sqrt());
        ci95.insert(
            name.to_string(),
            [s * (dof / c_hi).sqrt(), s * (dof / c_lo).sqrt()],
        );
    }
    // the two records are independent: a diagonal covariance
    let names: Vec<String> = SensorNoise::PARAMS.iter().map(|s| s.to_string()).collect();
    let covariance = NamedMatrix::from_matrix(
        &names,
        &nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            names.len(),
            names.iter().map(|n| std_err[n].powi(2)),
        )),
    );
    let model = IdentifiedModel {
        status: FitStatus::Converged,
        n_obs: n,
        dof: n - 1,
        // no model is fitted: the levels are the records' sample standard deviations
        rms_residual: 0.0,
        residual_unit: "none".into(),
        warnings: vec![],
        params,
        std_err,
        fixed: BTreeMap::new(),
        derived: BTreeMap::new(),
        covariance,
    };
    let description = format!(
        "sensor_noise: force channel (spindle in air) and gauge (PZT held) recorded at rest, {n} samples \
         every {} s each; sample standard deviations",
        rec.dt_s
    );
    Ok(NoiseRecord {
        description,
        model,
        ci95,
    })
}

/// One parameter of a coverage study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoverageRow {
    /// Parameter (`force.w_mpa`, …).
    pub parameter: String,
    /// Commissionings whose 95 % interval covered the pseudo-true value.
    pub covered: usize,
    /// Commissionings run.
    pub n: usize,
    /// Two-sided binomial p-value of `covered` under a true coverage of 95 %.
    pub p_value: f64,
    /// Median |estimate − pseudo-true| / standard error.
    pub median_abs_z: f64,
}

/// Commission the plant `seeds.len()` times, each with its own instrument draw
/// ([`InstrumentErrors::draw`]) and measurement noise, and count per parameter how often the 95 % interval
/// covers the pseudo-true value; `progress` is called after each commissioning.
///
/// # Errors
/// As [`commission`].
pub fn coverage_study(
    truth: &GrooveConfig,
    material: &str,
    force_noise_n: f64,
    gauge_noise_um: f64,
    plan: &CommissioningPlan,
    seeds: std::ops::Range<u64>,
    mut progress: impl FnMut(),
) -> Result<Vec<CoverageRow>, ClosedLoopError> {
    let mut hits: BTreeMap<String, (usize, usize, Vec<f64>)> = BTreeMap::new();
    for seed in seeds {
        let plant = CommissioningPlant {
            truth,
            instruments: InstrumentErrors::draw(seed),
            force_noise_n,
            gauge_noise_um,
            material,
        };
        let c = commission(&plant, plan, seed)?;
        for (name, est, ci, t) in c.intervals() {
            let e = hits.entry(name).or_default();
            e.0 += usize::from(ci[0] <= t && t <= ci[1]);
            e.1 += 1;
            let half = (ci[1] - ci[0]) / 2.0;
            let se = half / 1.96;
            e.2.push(if se > 0.0 {
                (est - t).abs() / se
            } else {
                f64::INFINITY
            });
        }
        progress();
    }
    Ok(hits
        .into_iter()
        .map(|(parameter, (covered, n, mut z))| {
            z.sort_by(f64::total_cmp);
            CoverageRow {
                parameter,
                covered,
                n,
                p_value: binomial_two_sided(covered, n, 0.95),
                median_abs_z: z.get(z.len() / 2).copied().unwrap_or(f64::NAN),
            }
        })
        .collect())
}

/// Two-sided binomial test p-value: `2·min(P(X ≤ k), P(X ≥ k))`, capped at 1 (statrs' binomial).
pub fn binomial_two_sided(k: usize, n: usize, p: f64) -> f64 {
    use statrs::distribution::{Binomial, Discrete, DiscreteCDF};
    let Ok(b) = Binomial::new(p, n as u64) else {
        return f64::NAN;
    };
    let k = k as u64;
    let lower = b.cdf(k);
    let upper = 1.0 - b.cdf(k) + b.pmf(k);
    (2.0 * lower.min(upper)).min(1.0)
}
