//! The NC feed-axis stage (`003_…txt`) in the harness: its scenario table (`[nc_axis]`), the truth it
//! builds, the commissioning of the NC plant from simulated calibration measurements, the closed-loop
//! run of `none | reactive | proactive | mpc`, and the metrics of the measured wall contour.
//!
//! **The truth** (sim's `nc_axis` stage): Kienzle's C45 law (handbook kc1.1, mc) with edge forces and a
//! per-seed force factor (the material lot and the tool, σ `force_factor_sigma`), a 3 µm runout at a
//! drawn angle, the Ø16 mm tool at `overhang_d` diameters in series with the machine's static stiffness
//! `machine_stiffness_n_per_um` (rising by `machine_span_rel` along the blank), the feed axes' 16 ms
//! structure, the force platform with a drawn gain error (σ `platform_gain_sigma`), noise and
//! quantisation.
//!
//! **The commissioning** ([`commission_nc`]), through the instruments only:
//! 1. *Force calibration*: full slots and part-width cuts at the plan's feeds per tooth and depths, each
//!    cut for `revolutions` revolutions on the platform (zeroed before the cut), the revolution means of
//!    Fx and Fy averaged; `identify kienzle` fits kc1.1, mc, kr1.1, mr starting from the handbook.
//! 2. *Load–deflection* at the tool tip in y at the plan's positions along the blank (its start, middle
//!    and end): loads read by a dial indicator (resolution and noise of the plan); `identify stiffness`
//!    at each, the controllers' compliance interpolated between them (003's ΔkM along the axis).
//! 3. *Axis tests*: a step and a ramp sent to each axis, the NC's trace (reference and encoder at each
//!    cycle); `identify feed-axis` (dead time + first-order lag — not the truth's structure).
//! 4. *The platform at rest*: its noise level (σ of `noise_samples` samples).
//!
//! **The controllers** see those models, the NC program and the measured signals only
//! (`millcomp_mpc::nc_axis`); the proactive controller's offset curve is recorded in one reference run
//! on the same machine (another blank: its own noise), uncompensated.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use millcomp_identify::targets::Identified;
use millcomp_identify::targets::feed_axis::{FeedAxisData, FeedAxisOptions, identify_feed_axis};
use millcomp_identify::targets::kienzle::{KienzleData, KienzleOptions, identify_kienzle};
use millcomp_identify::targets::stiffness::{StiffnessData, StiffnessOptions, identify_stiffness};
use millcomp_mpc::nc_axis::{
    CorrectionLimits, IdentifiedFeedAxis, IdentifiedKienzle, IdentifiedNcStiffness, MpcNc,
    NcController, NcCycle, NcMpcSettings, NcPlan, NcReferenceRun, NominalEndMill, NoneNc,
    OffsetCurve, ProactiveNc, ReactiveNc,
};
use millcomp_sim::kienzle::{
    CutState, EdgeForces, EndMill, KienzleCoefficients, KienzleMillingModel,
};
use millcomp_sim::nc_axis::{
    AxisDynamics, ContourDevice, FeedAxis, ForcePlatform, NcAxisConfig, NcAxisStage, NcProgram,
    NcStiffness, ToolOverhang, WallPoint,
};
use millcomp_sim::sensors::quantize;

use crate::error::{ClosedLoopError, invalid, sim_keyed as sim_key};
use crate::nc_axis_bound::{Level, NcBoundSetup, Segment};
pub use crate::nc_axis_scenario::*;
use crate::report::{Metrics, ModelSummary, RunOutput, RunReport, Trace};
pub use crate::report::{NcAxisReport, NcModelLine, NcReferenceWall, NcTruthDraw, NcWallMetrics};
use crate::scenario::{ControllerKind, Scenario};

impl Scenario {
    /// The validated `[nc_axis]` table.
    ///
    /// # Errors
    /// [`ClosedLoopError::InvalidConfig`] (`nc_axis`) when there is none, and those of
    /// [`NcAxisScenario::validate`].
    pub fn nc(&self) -> Result<&NcAxisScenario, ClosedLoopError> {
        let nc = self.nc_axis.as_ref().ok_or_else(|| {
            invalid(
                "nc_axis",
                "missing",
                "an [nc_axis] table for stage = \"nc_axis\"",
            )
        })?;
        nc.validate()?;
        Ok(nc)
    }
}

impl NcTruthDraw {
    /// The draw of `seed` for `truth`.
    pub fn draw(seed: u64, truth: &NcTruthSpec) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0003_0003);
        let n = |rng: &mut ChaCha8Rng, s: f64| {
            if s > 0.0 {
                Normal::new(0.0, s).map_or(0.0, |d| d.sample(rng))
            } else {
                0.0
            }
        };
        Self {
            force_factor: 1.0 + n(&mut rng, truth.force_factor_sigma),
            platform_gain: 1.0 + n(&mut rng, truth.platform_gain_sigma),
            runout_phase_deg: rng.random_range(0.0..360.0),
            spindle_phase_rad: rng.random_range(0.0..std::f64::consts::TAU),
        }
    }
}

/// The truth of an `[nc_axis]` scenario for `seed`.
///
/// # Errors
/// The physics crate's checks of the assembled truth, keys under `nc_axis.`.
pub fn nc_truth(
    nc: &NcAxisScenario,
    seed: u64,
) -> Result<(NcAxisConfig, NcTruthDraw), ClosedLoopError> {
    let d = NcTruthDraw::draw(seed, &nc.truth);
    let m = &nc.machine;
    let tool = EndMill {
        runout_um: m.runout_um,
        runout_phase_deg: d.runout_phase_deg - 360.0 * (d.runout_phase_deg / 360.0).floor(),
        ..EndMill::brecher_003()
    };
    let cfg = NcAxisConfig {
        force: KienzleMillingModel {
            coefficients: KienzleCoefficients::c45_handbook().scaled(d.force_factor),
            edge: EdgeForces {
                kte_n_mm: nc.truth.edge.kte_n_mm * d.force_factor,
                kre_n_mm: nc.truth.edge.kre_n_mm * d.force_factor,
            },
            tool,
            axial_slices: nc.truth.axial_slices,
        },
        stiffness: NcStiffness {
            machine_n_per_um: m.machine_stiffness_n_per_um,
            machine_span_rel: m.machine_span_rel,
            tool: ToolOverhang {
                flute_length_mm: m.flute_length_mm,
                ..ToolOverhang::brecher_003(m.overhang_d)
            },
        },
        x_axis: m.axis,
        y_axis: m.axis,
        platform: ForcePlatform {
            gain: d.platform_gain,
            noise_n: nc.truth.platform_noise_n,
            resolution_n: nc.truth.platform_resolution_n,
        },
        dt_s: nc.control.dt_s,
        contour_height_mm: nc.contour.height_mm,
        spindle_phase_rad: d.spindle_phase_rad,
        seed: seed ^ 0x5A5A,
    };
    cfg.validate().map_err(sim_key("nc_axis.truth."))?;
    Ok((cfg, d))
}

/// One load–deflection test of the commissioning: where along the blank, and its `identify stiffness`.
#[derive(Debug, Clone)]
pub struct NcStiffnessTest {
    /// The tool's position along x (mm).
    pub x_mm: f64,
    /// The fit.
    pub fit: Identified,
}

/// The commissioning's four identifications and the platform's noise level.
#[derive(Debug, Clone)]
pub struct NcCommissioned {
    /// `identify kienzle` of the force calibration.
    pub kienzle: Identified,
    /// `identify stiffness` of the load–deflection test at each of the plan's positions.
    pub stiffness: Vec<NcStiffnessTest>,
    /// `identify feed-axis` of the x axis' trace.
    pub x_axis: Identified,
    /// `identify feed-axis` of the y axis' trace.
    pub y_axis: Identified,
    /// The x axis' unit step response at the cycle starts, read off the same trace
    /// (`IdentifiedFeedAxis::step_response_from_trace`).
    pub x_axis_step: Vec<f64>,
    /// The y axis' unit step response, the same way.
    pub y_axis_step: Vec<f64>,
    /// The NC cycle of the traces (s).
    pub cycle_s: f64,
    /// σ of the platform at rest (N).
    pub force_noise_n: f64,
}

fn experiment(what: &'static str) -> impl Fn(millcomp_identify::IdentifyError) -> ClosedLoopError {
    move |e| ClosedLoopError::Commissioning {
        experiment: what,
        source: Box::new(e),
    }
}

/// An NC servo trace: time (s), reference and encoder (µm) at the start of each cycle.
type AxisTrace = (Vec<f64>, Vec<f64>, Vec<f64>);

/// The axis test: a step of `a` µm, back, then a ramp to `a` and a hold, sent every cycle; the NC's
/// trace (time, reference, encoder at the start of each cycle).
fn axis_trace(
    d: &AxisDynamics,
    dt_s: f64,
    steps_per_cycle: usize,
    cycle_s: f64,
    a: f64,
) -> Result<AxisTrace, ClosedLoopError> {
    let mut axis = FeedAxis::new(d, dt_s, 0.0, steps_per_cycle)?;
    let refs: Vec<f64> = (0..230)
        .map(|i| match i {
            0..10 => 0.0,
            10..70 => a,
            70..130 => 0.0,
            130..180 => a * (i - 130) as f64 / 50.0,
            _ => a,
        })
        .collect();
    let mut t = Vec::with_capacity(refs.len());
    let mut p = Vec::with_capacity(refs.len());
    for (i, r) in refs.iter().enumerate() {
        t.push(i as f64 * cycle_s);
        p.push(axis.position());
        for _ in 0..steps_per_cycle {
            axis.step(*r);
        }
    }
    Ok((t, refs, p))
}

/// Commission the NC plant `truth` running `program` (module doc), seeded.
///
/// # Errors
/// [`ClosedLoopError::Commissioning`] naming the experiment whose identification failed; the physics
/// crate's errors.
pub fn commission_nc(
    truth: &NcAxisConfig,
    program: &NcProgram,
    plan: &NcCommissioningPlan,
    seed: u64,
) -> Result<NcCommissioned, ClosedLoopError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0C03);
    let p = &truth.platform;
    let noise = Normal::new(0.0, p.noise_n.max(1e-12))
        .map_err(|source| ClosedLoopError::CalibrationNoise { source })?;
    let read = |f: f64, rng: &mut ChaCha8Rng| {
        quantize(
            p.gain * f
                + if p.noise_n > 0.0 {
                    noise.sample(rng)
                } else {
                    0.0
                },
            p.resolution_n,
        )
    };
    // 1. force calibration
    let dt = truth.dt_s;
    let per_rev = ((60.0 / program.speed_rpm) / dt).round().max(8.0) as usize;
    let (mut fz, mut ap, mut ae, mut mfx, mut mfy) = (vec![], vec![], vec![], vec![], vec![]);
    for _ in 0..plan.replicates {
        for &f in &plan.fz_mm {
            for &a in &plan.ap_mm {
                for &e in &plan.ae_mm {
                    let cut = CutState::steady(f, a, e);
                    let n = per_rev * plan.revolutions;
                    let phase: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                    let (mut sx, mut sy) = (0.0, 0.0);
                    for k in 0..n {
                        let rot = phase + std::f64::consts::TAU * k as f64 / per_rev as f64;
                        let fk = truth.force.forces(rot, &cut);
                        sx += read(fk[0], &mut rng);
                        sy += read(fk[1], &mut rng);
                    }
                    fz.push(f);
                    ap.push(a);
                    ae.push(e);
                    mfx.push(sx / n as f64);
                    mfy.push(sy / n as f64);
                }
            }
        }
    }
    let tool = NominalEndMill::brecher_003();
    let kienzle = identify_kienzle(
        &KienzleData {
            fz_mm: &fz,
            ap_mm: &ap,
            ae_mm: &ae,
            mean_fx_n: Some(&mfx),
            mean_fy_n: Some(&mfy),
        },
        &KienzleOptions {
            tool: EndMill {
                diameter_mm: tool.diameter_mm,
                teeth: tool.teeth,
                helix_deg: tool.helix_deg,
                runout_um: 0.0,
                runout_phase_deg: 0.0,
            },
            ..KienzleOptions::default()
        },
    )
    .map_err(experiment("force calibration"))?;
    // 2. load–deflection at the plan's positions along the blank
    let ind = Normal::new(0.0, plan.indicator_noise_um.max(1e-12))
        .map_err(|source| ClosedLoopError::CalibrationNoise { source })?;
    let (x0, x1) = (program.blank_start_mm, program.blank_end_mm);
    let mut stiffness = Vec::with_capacity(plan.stiffness_at.len());
    for &a in &plan.stiffness_at {
        let x_mm = x0 + a * (x1 - x0);
        let k_true = truth.stiffness.system_at(x_mm, x0, x1)?;
        let (mut load, mut defl) = (vec![], vec![]);
        for _ in 0..plan.trials {
            for &f in &plan.loads_n {
                let e = if plan.indicator_noise_um > 0.0 {
                    ind.sample(&mut rng)
                } else {
                    0.0
                };
                load.push(f);
                defl.push(quantize(f / k_true + e, plan.indicator_resolution_um));
            }
        }
        let fit = identify_stiffness(
            &StiffnessData {
                load_n: &load,
                deflection_um: &defl,
                direction: None,
            },
            &StiffnessOptions::default(),
        )
        .map_err(experiment("load-deflection test"))?;
        stiffness.push(NcStiffnessTest { x_mm, fit });
    }
    // 3. axis traces
    let spc = (program.cycle_s / dt).round() as usize;
    let axis_fit = |d: &AxisDynamics, what: &'static str| {
        let (t, r, pos) = axis_trace(d, dt, spc, program.cycle_s, plan.axis_step_um)?;
        let fit = identify_feed_axis(
            &FeedAxisData {
                t_s: &t,
                reference_um: &r,
                position_um: &pos,
            },
            &FeedAxisOptions::default(),
        )
        .map_err(experiment(what))?;
        let step = IdentifiedFeedAxis::step_response_from_trace(&r, &pos)?;
        Ok::<_, ClosedLoopError>((fit, step))
    };
    let (x_axis, x_axis_step) = axis_fit(&truth.x_axis, "x axis trace")?;
    let (y_axis, y_axis_step) = axis_fit(&truth.y_axis, "y axis trace")?;
    // 4. the platform at rest
    let rest: Vec<f64> = (0..plan.noise_samples)
        .map(|_| read(0.0, &mut rng))
        .collect();
    let mean = rest.iter().sum::<f64>() / rest.len() as f64;
    let var = rest.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (rest.len().max(2) - 1) as f64;
    Ok(NcCommissioned {
        kienzle,
        stiffness,
        x_axis,
        y_axis,
        x_axis_step,
        y_axis_step,
        cycle_s: program.cycle_s,
        force_noise_n: var.sqrt(),
    })
}

/// The controllers' models of a commissioning, with the scenario's deliberate errors on top.
#[derive(Debug, Clone)]
pub struct NcModels {
    /// Force model.
    pub force: IdentifiedKienzle,
    /// x axis.
    pub x_axis: IdentifiedFeedAxis,
    /// y axis.
    pub y_axis: IdentifiedFeedAxis,
    /// Stiffness.
    pub stiffness: IdentifiedNcStiffness,
    /// Platform noise (N).
    pub force_noise_n: f64,
}

impl NcModels {
    /// From a commissioning and the scenario's `truth.stiffness_error`, `truth.kienzle_error`; the
    /// axes as `axis_model` says (the MPC and its plan use it; the published controllers use the dead
    /// time + lag's equivalent delay either way).
    ///
    /// # Errors
    /// The identified types' errors.
    pub fn of(
        c: &NcCommissioned,
        truth: &NcTruthSpec,
        axis_model: NcAxisModel,
    ) -> Result<Self, ClosedLoopError> {
        let axis =
            |fit: &Identified, step: &[f64]| -> Result<IdentifiedFeedAxis, ClosedLoopError> {
                let a = IdentifiedFeedAxis::new(&fit.model)?;
                Ok(match axis_model {
                    NcAxisModel::StepResponse => a.with_step_response(step.to_vec(), c.cycle_s)?,
                    NcAxisModel::DeadTimeLag => a,
                })
            };
        Ok(Self {
            force: IdentifiedKienzle::new(&c.kienzle.model, &NominalEndMill::brecher_003())?
                .rescaled(1.0 + truth.kienzle_error)?,
            x_axis: axis(&c.x_axis, &c.x_axis_step)?,
            y_axis: axis(&c.y_axis, &c.y_axis_step)?,
            stiffness: IdentifiedNcStiffness::along(
                &c.stiffness
                    .iter()
                    .map(|t| (t.x_mm, &t.fit.model))
                    .collect::<Vec<_>>(),
            )?
            .scaled(1.0 + truth.stiffness_error)?,
            force_noise_n: c.force_noise_n,
        })
    }
}

/// One run of the stage with a controller.
struct Drive {
    wall: Vec<WallPoint>,
    rows: Vec<[f64; 6]>,
    finite: bool,
    in_limits: bool,
    travel_um: f64,
    reference: NcReferenceRun,
    simulated_s: f64,
}

fn drive(
    truth: &NcAxisConfig,
    program: &NcProgram,
    ctl: &mut dyn NcController,
    limits: &CorrectionLimits,
    record: bool,
) -> Result<Drive, ClosedLoopError> {
    let mut stage = NcAxisStage::new(truth.clone(), program.clone())?;
    let spc = stage.steps_per_cycle();
    let mut prev = 0.0;
    let mut setpoint = 0.0;
    let mut finite = true;
    let mut in_limits = true;
    let mut travel = 0.0;
    let mut rows = Vec::with_capacity(stage.interpolator().len());
    let mut reference = NcReferenceRun {
        samples_per_cycle: spc,
        ..Default::default()
    };
    let mut last_t = 0.0;
    let mut last_f = 0.0;
    while !stage.finished() {
        if stage.at_cycle_start() {
            let k = stage.cycle();
            let a = stage.interpolator().reference(k).a_mm_s2;
            let (x, y) = stage.axes();
            let theta = stage.spindle_angle_rad();
            let u = crate::realtime::cycle(|| {
                ctl.cycle(&NcCycle {
                    index: k,
                    a_cmd_mm_s2: a,
                    y_axis_um: y,
                    x_axis_mm: x,
                    spindle_angle_rad: theta,
                })
            })?;
            if !u.is_finite() {
                finite = false;
            }
            let safe = limits.apply(u, prev);
            if u.is_finite() && (safe - u).abs() > 1e-9 {
                in_limits = false;
            }
            travel += (safe - prev).abs();
            prev = safe;
            setpoint = safe;
            rows.push([last_t, x, a, last_f, safe, y]);
            if record {
                reference.a_cmd_mm_s2.push(a);
                reference.x_axis_mm.push(x);
            }
        }
        let s = stage.step(setpoint);
        ctl.force_sample(s.fy_measured_n);
        if record {
            reference.force_n.push(s.fy_measured_n);
        }
        last_t = s.t_s;
        last_f = s.fy_measured_n;
    }
    Ok(Drive {
        wall: stage.wall().to_vec(),
        rows,
        finite,
        in_limits,
        travel_um: travel,
        reference,
        simulated_s: last_t,
    })
}

/// The feed step's window (mm before, after the change) of [`NcWallMetrics::feed_step_peak_um`].
pub const FEED_STEP_WINDOW_MM: [f64; 2] = [2.0, 15.0];
/// The exit's window (mm before the blank's end) of [`NcWallMetrics::exit_undersize_um`]: one
/// radius plus 1 mm.
pub const EXIT_WINDOW_MM: f64 = 9.0;

fn contour_at(contour: &[(f64, f64)], x: f64) -> f64 {
    if contour.is_empty() || x < contour[0].0 || x > contour[contour.len() - 1].0 {
        return f64::NAN;
    }
    let dx = contour[1].0 - contour[0].0;
    let i = (((x - contour[0].0) / dx).round() as usize).min(contour.len() - 1);
    contour[i].1
}

/// The constant-condition windows of a program: 10 mm after the blank's start (or a feed change) to
/// 5 mm before the next change (or one radius + 5 mm before the end).
pub fn constant_windows(p: &NcProgram) -> Vec<[f64; 2]> {
    let r = 8.0;
    let mut edges: Vec<f64> = p
        .feed_changes
        .iter()
        .map(|c| c.x_mm)
        .filter(|x| *x > p.blank_start_mm && *x < p.blank_end_mm)
        .collect();
    edges.insert(0, p.blank_start_mm);
    let mut out = Vec::new();
    for (i, &a) in edges.iter().enumerate() {
        let end = edges
            .get(i + 1)
            .map_or(p.blank_end_mm - r - 5.0, |b| b - 5.0);
        let start = a + 10.0;
        if end > start + 1.0 {
            out.push([start, end]);
        }
    }
    out
}

/// The metrics of a measured contour `contour` and of the deflection's part of the wall `defl` (the same
/// grid, noise-free: the uncompensated wall of the same run, a model output).
fn wall_metrics(p: &NcProgram, contour: &[(f64, f64)], defl: &[(f64, f64)]) -> NcWallMetrics {
    let windows = constant_windows(p);
    let in_w = |x: f64, w: &[f64; 2]| x >= w[0] && x <= w[1];
    let mean = |v: &[f64]| {
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    let e_abs: Vec<f64> = contour
        .iter()
        .filter(|(x, _)| windows.iter().any(|w| in_w(*x, w)))
        .map(|(_, e)| e.abs())
        .collect();
    let d_all: Vec<f64> = defl
        .iter()
        .filter(|(x, _)| windows.iter().any(|w| in_w(*x, w)))
        .map(|(_, d)| *d)
        .collect();
    let static_error_um = mean(&e_abs);
    let static_uncompensated_um = mean(&d_all);
    let change = p
        .feed_changes
        .first()
        .map(|c| c.x_mm)
        .filter(|x| *x > p.blank_start_mm && *x < p.blank_end_mm);
    let mut m = NcWallMetrics {
        static_error_um,
        static_uncompensated_um,
        static_removed_pct: 100.0 * (1.0 - static_error_um / static_uncompensated_um),
        windows_mm: windows.clone(),
        ..Default::default()
    };
    if let Some(xc) = change {
        let level = |c: &[(f64, f64)], w: &[f64; 2]| {
            mean(
                &c.iter()
                    .filter(|(x, _)| in_w(*x, w))
                    .map(|(_, v)| *v)
                    .collect::<Vec<_>>(),
            )
        };
        let before = windows.iter().rev().find(|w| w[1] <= xc);
        let after = windows.iter().find(|w| w[0] >= xc);
        if let (Some(b), Some(a)) = (before, after) {
            m.deflection_step_um = Some(level(defl, a) - level(defl, b));
        }
        // the settled levels of this run's wall just before and just after the change
        let settled_before = level(contour, &[xc - 7.0, xc - 2.0]);
        let settled_after = level(contour, &[xc + 10.0, xc + 20.0]);
        let (mut peak, mut signed, mut excess) = (0.0f64, 0.0, 0.0f64);
        for &(x, e) in contour {
            if x >= xc - FEED_STEP_WINDOW_MM[0] && x <= xc + FEED_STEP_WINDOW_MM[1] {
                if e.abs() > peak {
                    peak = e.abs();
                    signed = e;
                }
                let settled = if x < xc {
                    settled_before
                } else {
                    settled_after
                };
                excess = excess.max((e - settled).abs());
            }
        }
        m.feed_step_peak_um = Some(peak);
        m.feed_step_peak_signed_um = Some(signed);
        m.feed_step_excess_um = Some(excess);
    }
    let (lo_x, hi_x) = (p.blank_end_mm - EXIT_WINDOW_MM, p.blank_end_mm);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(x, e) in contour {
        if x >= lo_x && x <= hi_x {
            lo = lo.min(e);
            hi = hi.max(e);
        }
    }
    m.exit_min_um = lo;
    m.exit_max_um = hi;
    m.exit_undersize_um = (-lo).max(0.0);
    m
}

/// Fill the wall metrics' physical limits ([`crate::nc_axis_bound`]) of a run on `p`.
fn nc_bounds(
    setup: &NcBoundSetup<'_>,
    p: &NcProgram,
    wm: &mut NcWallMetrics,
) -> Result<(), ClosedLoopError> {
    if let Some(xc) = p
        .feed_changes
        .first()
        .map(|c| c.x_mm)
        .filter(|x| *x > p.blank_start_mm && *x < p.blank_end_mm)
    {
        let (a, b) = (xc - FEED_STEP_WINDOW_MM[0], xc + FEED_STEP_WINDOW_MM[1]);
        let seg = |from_mm, to_mm, level| Segment {
            from_mm,
            to_mm,
            level,
        };
        wm.feed_step_peak_bound_um = setup.bound(&[seg(a, b, Level::Zero)])?;
        // the excess' settled level switches at the change (x < xc before it); a point within 1e-9 mm
        // below xc is left out (fewer rows: still a lower bound)
        wm.feed_step_excess_bound_um =
            setup.bound(&[seg(a, xc - 1e-9, Level::Free), seg(xc, b, Level::Free)])?;
    }
    let exit = [Segment {
        from_mm: p.blank_end_mm - EXIT_WINDOW_MM,
        to_mm: p.blank_end_mm,
        level: Level::Zero,
    }];
    wm.exit_bound_um = setup.bound(&exit)?;
    Ok(())
}

/// The ringing of the executed correction after the first feed change ([`NcWallMetrics`]); rows are
/// `[t, x, a_cmd, F, correction, y]` per cycle.
fn step_ringing_um(rows: &[[f64; 6]], cycle_s: f64) -> Option<f64> {
    let start = rows.iter().position(|r| r[2] != 0.0)?;
    let c = |t: f64| (t / cycle_s).round() as usize;
    let (from, to, half) = (start + c(0.04), start + c(0.34), c(0.03));
    if to + half >= rows.len() {
        return None;
    }
    let mut acc = 0.0;
    for i in from..to {
        let avg =
            rows[i - half..=i + half].iter().map(|r| r[5]).sum::<f64>() / (2 * half + 1) as f64;
        acc += (rows[i][5] - avg).powi(2);
    }
    Some((acc / (to - from) as f64).sqrt())
}

/// A controller of the stage for `kind`, built from `models` (the proactive one records its reference
/// run on `truth` with its own noise); the MPC with the harness's cycle `budget`.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] (`controller`) for a kind the stage does not have; the
/// controllers' construction errors.
pub fn nc_controller(
    kind: ControllerKind,
    nc: &NcAxisScenario,
    truth: &NcAxisConfig,
    models: &NcModels,
    budget: millcomp_mpc::config::CycleBudget,
) -> Result<Box<dyn NcController>, ClosedLoopError> {
    let p = &nc.program;
    let channel = nc.channel();
    Ok(match kind {
        ControllerKind::None => Box::new(NoneNc),
        ControllerKind::Reactive => Box::new(ReactiveNc::new(&channel, &models.stiffness)?),
        ControllerKind::Proactive => {
            let mut ref_truth = truth.clone();
            ref_truth.seed ^= 0x0FF5E7;
            let reference = drive(&ref_truth, p, &mut NoneNc, &nc.control.limits, true)?.reference;
            let curve = OffsetCurve::from_reference_run(
                &reference,
                &models.stiffness,
                &models.y_axis,
                p.speed_rpm,
                p.cycle_s,
                nc.control.proactive_window,
            )?;
            Box::new(ProactiveNc::new(
                nc.control.dt_s,
                &models.stiffness,
                curve,
                nc.control.proactive_window,
            )?)
        }
        ControllerKind::Mpc => {
            let stage = NcAxisStage::new(truth.clone(), p.clone())?;
            let plan = NcPlan::new(
                p,
                stage.interpolator(),
                &models.force,
                &models.x_axis,
                &models.stiffness,
                nc.contour.height_mm,
            )?;
            Box::new(MpcNc::new(
                &models.y_axis,
                p.cycle_s,
                plan,
                &channel,
                models.force_noise_n,
                &NcMpcSettings {
                    wall_instants: nc.control.mpc_wall_instants,
                    tooth_offsets: nc.control.mpc_tooth_offsets,
                    ..NcMpcSettings::default_nc()
                }
                .with_budget(budget),
            )?)
        }
        other => {
            return Err(invalid(
                "controller",
                other.name(),
                "one of none, reactive, proactive, mpc on stage = \"nc_axis\"",
            ));
        }
    })
}

/// Run an `nc_axis` scenario with one controller.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] for a missing `[nc_axis]` table or a controller the stage does
/// not have; the commissioning's, the controllers' and the stage's errors.
pub fn run_nc_axis(s: &Scenario, kind: ControllerKind) -> Result<RunOutput, ClosedLoopError> {
    let wall_clock = std::time::Instant::now();
    let nc = s.nc()?;
    if !kind.runs_on(crate::scenario::StageKind::NcAxis) {
        return Err(invalid(
            "controller",
            kind.name(),
            "one of none, reactive, proactive, mpc on stage = \"nc_axis\"",
        ));
    }
    let (truth, draw) = nc_truth(nc, s.seed)?;
    let commissioned = commission_nc(&truth, &nc.program, &nc.commissioning, s.seed)?;
    let models = NcModels::of(&commissioned, &nc.truth, nc.control.mpc_axis_model)?;
    let mut ctl = nc_controller(kind, nc, &truth, &models, s.control.cycle_budget())?;
    let d = drive(&truth, &nc.program, ctl.as_mut(), &nc.control.limits, false)?;
    let p = &nc.program;
    let contour =
        nc.contour
            .device
            .measure(&d.wall, p.blank_start_mm, p.blank_end_mm, s.seed ^ 0xC0C0)?;
    let deflection_wall: Vec<WallPoint> = d
        .wall
        .iter()
        .map(|w| WallPoint {
            error_um: w.deflection_um,
            ..*w
        })
        .collect();
    let defl_contour = ContourDevice {
        noise_um: 0.0,
        ..nc.contour.device
    }
    .measure(&deflection_wall, p.blank_start_mm, p.blank_end_mm, 0)?;
    let mut wm = wall_metrics(p, &contour, &defl_contour);
    wm.feed_step_oscillation_um = step_ringing_um(&d.rows, p.cycle_s);
    // the physical limits on this seed: the deflection-only wall measured with the run's seed (its
    // noise is the run's), the true y axis, the limits every controller has
    let uncompensated = nc.contour.device.measure(
        &deflection_wall,
        p.blank_start_mm,
        p.blank_end_mm,
        s.seed ^ 0xC0C0,
    )?;
    let setup = NcBoundSetup {
        wall: &d.wall,
        axis: &truth.y_axis,
        dt_s: truth.dt_s,
        steps_per_cycle: (p.cycle_s / truth.dt_s).round() as usize,
        limits: &nc.control.limits,
        device: &nc.contour.device,
        from_mm: p.blank_start_mm,
        to_mm: p.blank_end_mm,
        uncompensated: &uncompensated,
    };
    nc_bounds(&setup, p, &mut wm)?;
    // the certainty-equivalent wall: the deflection seen per measured newton through the commissioned
    // stiffness, cancelled exactly at every pass — the error left is δ (1 − g k(x)/k_model)
    let mut ce_wall = Vec::with_capacity(d.wall.len());
    for w in &d.wall {
        let k = truth
            .stiffness
            .system_at(w.x_mm, p.blank_start_mm, p.blank_end_mm)?;
        let k_model = models.stiffness.n_per_um_at(w.x_mm);
        ce_wall.push(WallPoint {
            error_um: w.deflection_um * (1.0 - truth.platform.gain * k / k_model),
            ..*w
        });
    }
    let ce =
        nc.contour
            .device
            .measure(&ce_wall, p.blank_start_mm, p.blank_end_mm, s.seed ^ 0xC0C0)?;
    let cm = wall_metrics(p, &ce, &defl_contour);
    let ce_errors: Vec<f64> = ce.iter().map(|c| c.1).collect();
    wm.certainty_equivalent = Some(NcReferenceWall {
        static_error_um: cm.static_error_um,
        feed_step_peak_um: cm.feed_step_peak_um,
        feed_step_excess_um: cm.feed_step_excess_um,
        exit_undersize_um: cm.exit_undersize_um,
        exit_max_um: cm.exit_max_um,
        pp_um: Metrics::from_errors(&ce_errors, 0.0).pp_error_um,
    });
    let mut trace = Trace::new(&[
        "t_s",
        "x_mm",
        "a_cmd_mm_s2",
        "fy_measured_n",
        "correction_um",
        "y_axis_um",
        "error_um",
    ]);
    for r in &d.rows {
        let mut row = r.to_vec();
        row.push(contour_at(&contour, r[1]));
        trace.rows.push(row);
    }
    let errors: Vec<f64> = contour.iter().map(|c| c.1).collect();
    let x_mid = 0.5 * (p.blank_start_mm + p.blank_end_mm);
    let k_true = truth
        .stiffness
        .system_at(x_mid, p.blank_start_mm, p.blank_end_mm)?;
    let est = |i: &Identified, n: &str| (i.report.param(n), i.report.se(n));
    let kc = KienzleCoefficients::c45_handbook().scaled(draw.force_factor);
    let line = |name: &str, (estimate, std_err): (f64, f64), truth: f64| NcModelLine {
        name: name.into(),
        estimate,
        std_err,
        truth,
    };
    let mut lines: Vec<NcModelLine> = [
        (
            "kienzle.kc11_n_mm2",
            est(&commissioned.kienzle, "kc11_n_mm2"),
            kc.kc11_n_mm2,
        ),
        ("kienzle.mc", est(&commissioned.kienzle, "mc"), kc.mc),
        (
            "kienzle.kr11_n_mm2",
            est(&commissioned.kienzle, "kr11_n_mm2"),
            kc.kr11_n_mm2,
        ),
        ("kienzle.mr", est(&commissioned.kienzle, "mr"), kc.mr),
    ]
    .into_iter()
    .map(|(n, e, t)| line(n, e, t))
    .collect();
    // one line per load–deflection test, named by its position
    for t in &commissioned.stiffness {
        lines.push(line(
            &format!("stiffness@{:.1}mm.n_per_um", t.x_mm),
            est(&t.fit, "stiffness_n_per_um"),
            truth
                .stiffness
                .system_at(t.x_mm, p.blank_start_mm, p.blank_end_mm)?,
        ));
    }
    lines.extend(
        [
            (
                "x_axis.dead_time_s",
                est(&commissioned.x_axis, "dead_time_s"),
                f64::NAN,
            ),
            ("x_axis.lag_s", est(&commissioned.x_axis, "lag_s"), f64::NAN),
            (
                "y_axis.dead_time_s",
                est(&commissioned.y_axis, "dead_time_s"),
                f64::NAN,
            ),
            ("y_axis.lag_s", est(&commissioned.y_axis, "lag_s"), f64::NAN),
        ]
        .into_iter()
        .map(|(n, e, t)| line(n, e, t)),
    );
    let k_model = models.stiffness.n_per_um_at(x_mid);
    let notes = vec![
        format!(
            "truth: C45 Kienzle × {:.4} with edge forces {}/{} N/mm, k_M {} N/µm (±{} % over the blank), tool {} D overhang: k = {:.2} N/µm at the blank's middle; axes {} ms equivalent delay",
            draw.force_factor,
            nc.truth.edge.kte_n_mm,
            nc.truth.edge.kre_n_mm,
            nc.machine.machine_stiffness_n_per_um,
            50.0 * nc.machine.machine_span_rel,
            nc.machine.overhang_d,
            k_true,
            1e3 * nc.machine.axis.equivalent_delay_s(nc.program.cycle_s)
        ),
        format!(
            "controllers' models (commissioned): k {:.2} N/µm at the blank's middle, kc1.1 {:.0} N/mm², mc {:.3}, y axis {:.2} + {:.2} ms, platform σ {:.2} N",
            k_model,
            models.force.coefficients().kc11_n_mm2,
            models.force.coefficients().mc,
            1e3 * models.y_axis.dead_time_s(),
            1e3 * models.y_axis.lag_s(),
            models.force_noise_n
        ),
        format!(
            "force channel sampled every {} s (Nyquist {} Hz), {} notches + {} Hz; NC cycle {} s",
            nc.control.dt_s,
            0.5 / nc.control.dt_s,
            nc.channel().notch_hz.len(),
            nc.control.lowpass_hz,
            p.cycle_s
        ),
    ];
    let report = RunReport {
        scenario: s.name.clone(),
        stage: "nc_axis".into(),
        controller: kind.name().into(),
        metrics: Metrics {
            exit_overcut_um: None,
            exit_floor_tip_um: None,
            // the NC meaning of the whole cut's optimum: the certainty-equivalent wall's
            // peak-to-peak (the deflection seen through the commissioned stiffness, cancelled)
            optimum_pp_um: wm.certainty_equivalent.map(|c| c.pp_um),
            change_excess_um: wm.feed_step_peak_um.map(|p| p.max(wm.exit_undersize_um)),
            ..Metrics::from_errors(&errors, d.travel_um)
        },
        solver: ctl.solver_stats(),
        walls: None,
        commands_finite: d.finite,
        commands_in_limits: d.in_limits,
        process_change_peak_um: None,
        changes: Vec::new(),
        model: ModelSummary {
            kz_model_n_per_um: k_model,
            kz_truth_n_per_um: k_true,
            stiffness_error_rel: k_model / k_true - 1.0,
            force_error_max_rel: nc.truth.kienzle_error.abs(),
            truth_force_scale: draw.force_factor,
        },
        touch_off: None,
        nc_axis: Some(NcAxisReport {
            wall: wm,
            models: lines,
            draw,
        }),
        simulated_s: d.simulated_s,
        realtime: false,
        wall_clock_s: wall_clock.elapsed().as_secs_f64(),
        notes,
    };
    Ok(RunOutput { report, trace })
}
