//! Closed-loop runs on sim's thin-wall stage (`millcomp_sim::thinwall::ThinWallStage`, `004_…txt`) with
//! every controller of [`millcomp_mpc::thin_wall`].
//!
//! Per wall, the truth is sim's stage configured from the scenario: the part (`truth.wall`, or
//! `truth.draw_wall` drawing every wall as its own part from the spreads of
//! `millcomp_sim::wall_variation`; the published wall by default), force noise and stage accuracy. The
//! controllers' model ([`millcomp_mpc::identified::WallModel`]) is the programmed wall with the
//! published material and force coefficient of 004 (E = 100 GPa, Table 4; the coefficient times
//! `1 + truth.force_errors.w_mpa`) and the identified tool stiffness (a simulated calibration: loads
//! 0.5–5 N on the tool, deflection read on the stage's 0.1 µm grating ruler, σ 0.05 µm, 3 trials),
//! planned by [`millcomp_mpc::thin_wall::plan_wall`]: the part's deviations are not in it. The
//! controllers read the force sensor and the stage's grating ruler, which does not see the stage's
//! ±0.5 µm positioning accuracy error.

use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use millcomp_sim::sensors::NoiseSpec;
use millcomp_sim::thinwall::{ThinWallConfig, ThinWallStage, ThinWallStepOutput};
use millcomp_sim::wall_variation::WallVariation;

use millcomp_mpc::SolverStats;
use millcomp_mpc::identified::WallModel;
use millcomp_mpc::thin_wall::{
    MpcThinWallController, NoneController, OpenLoopController, PiController, STAGE_MAX_UM,
    STAGE_MIN_UM, ThinWallController, ThresholdController, WallPlan, estimated_deflection_um,
    plan_wall,
};

use crate::calibration::{StiffnessCalibration, fit_compliance};
use crate::error::{ClosedLoopError, invalid};
use crate::faults::{SolverFailures, thin_wall_measurement};
use crate::model_errors::ForceErrors;
use crate::report::{Metrics, ModelSummary, RunOutput, RunReport, Trace, WallReport};
use crate::scenario::{ControllerKind, Scenario, StageKind, ThinWallScenario};

/// The truth plant of wall `wall_index` of a thin-wall scenario: 004's wall with the scenario's geometry,
/// the part's deviations from the published wall (`truth.wall`, or `truth.draw_wall` drawn on the wall's
/// own seed — every wall is its own part), force noise and the stage's positioning accuracy.
///
/// # Errors
/// [`ClosedLoopError::InvalidConfig`] without a `[thin_wall]` table (`thin_wall`) or for a wall index
/// beyond `thin_wall.walls_um`; the physics crate's errors (a `truth.wall` factor out of range names
/// `e_factor` / `kr_factor`).
pub fn thin_wall_truth(s: &Scenario, wall_index: usize) -> Result<ThinWallConfig, ClosedLoopError> {
    let tw = s
        .thin_wall
        .as_ref()
        .ok_or_else(|| invalid("thin_wall", "missing", "a [thin_wall] table"))?;
    let nominal = *tw.walls_um.get(wall_index).ok_or_else(|| {
        invalid(
            "thin_wall.walls_um",
            format!("index {wall_index}"),
            format!("an index below {}", tw.walls_um.len()),
        )
    })?;
    truth_config(s, tw, nominal, wall_index)
}

/// The seed of wall `wall_index`'s own draws (part, force noise, stage accuracy).
fn wall_seed(s: &Scenario, wall_index: usize) -> u64 {
    s.seed.wrapping_mul(1000).wrapping_add(wall_index as u64)
}

/// The part of a wall: `truth.wall` when given, else a draw on the wall's seed when
/// `truth.draw_wall`, else the published wall.
fn wall_variation(s: &Scenario, wall_seed: u64) -> WallVariation {
    match (s.truth.wall, s.truth.draw_wall) {
        (Some(w), _) => w,
        (None, true) => WallVariation::draw(wall_seed),
        (None, false) => WallVariation::NONE,
    }
}

fn truth_config(
    s: &Scenario,
    tw: &ThinWallScenario,
    nominal: f64,
    wall_index: usize,
) -> Result<ThinWallConfig, ClosedLoopError> {
    let mut c = ThinWallConfig::paper(nominal)?.with_geometry(&tw.geometry(nominal))?;
    let seed = wall_seed(s, wall_index);
    wall_variation(s, seed).apply(&mut c)?;
    c.force_noise = (s.truth.force_noise_n > 0.0).then_some(NoiseSpec {
        seed: seed.wrapping_add(11),
        sigma: s.truth.force_noise_n,
    });
    c.stage.accuracy_seed = Some(seed.wrapping_add(13));
    c.validate()?;
    Ok(c)
}

/// The thin-wall controller of `kind` on the controllers' plan of one wall.
fn thin_wall_controller(
    kind: ControllerKind,
    plan: &WallPlan,
    horizon: usize,
    budget: millcomp_mpc::config::CycleBudget,
) -> Result<Box<dyn ThinWallController>, ClosedLoopError> {
    Ok(match kind {
        ControllerKind::None => Box::new(NoneController),
        ControllerKind::OpenLoop => Box::new(OpenLoopController::new(plan.clone())),
        ControllerKind::Threshold => Box::new(ThresholdController::new(plan.clone())),
        ControllerKind::Pid => Box::new(PiController::new(plan.clone())),
        ControllerKind::Mpc => Box::new(MpcThinWallController::new(plan.clone(), horizon, budget)?),
        ControllerKind::PidAntiWindup
        | ControllerKind::PidDesign
        | ControllerKind::PidTuned
        | ControllerKind::PidFeedforward
        | ControllerKind::PidFeedforwardRead
        | ControllerKind::MpcNoPreview
        | ControllerKind::Reactive
        | ControllerKind::Proactive => {
            return Err(thin_wall_refuses(kind));
        }
    })
}

fn thin_wall_refuses(kind: ControllerKind) -> ClosedLoopError {
    ClosedLoopError::InvalidConfig {
        key: "controller".into(),
        value: kind.name().into(),
        allowed: "none, open-loop, pid, threshold, mpc on the thin-wall stage".into(),
    }
}

/// Run every wall of a thin-wall scenario with one controller.
pub fn run_thin_wall(s: &Scenario, kind: ControllerKind) -> Result<RunOutput, ClosedLoopError> {
    let wall_clock = Instant::now();
    let tw = s
        .thin_wall
        .as_ref()
        .ok_or_else(|| invalid("thin_wall", "missing", "a [thin_wall] table"))?;
    if !kind.runs_on(StageKind::ThinWall) {
        return Err(thin_wall_refuses(kind));
    }
    let force_errors = s
        .truth
        .force_errors
        .unwrap_or_else(|| ForceErrors::draw(s.truth.force_error_max, s.seed));
    let mut walls = Vec::new();
    let mut errors = Vec::new();
    let mut travel = 0.0;
    let mut finite = true;
    let mut in_limits = true;
    let mut times = Vec::new();
    let mut fallbacks = 0;
    let (mut deadline_misses, mut budget_us, mut enforced) = (0, 0.0, false);
    let mut trace = Trace::new(&[
        "wall_um",
        "t_s",
        "layer",
        "x_um",
        "force_meas_n",
        "command_um",
        "stage_um",
        "est_deflection_um",
        "true_deflection_um",
    ]);
    let mut simulated = 0.0;
    let mut k_tool_rel = 0.0;
    let mut part_notes = Vec::new();
    for (wi, &nominal) in tw.walls_um.iter().enumerate() {
        let truth = truth_config(s, tw, nominal, wi)?;
        let part = wall_variation(s, wall_seed(s, wi));
        if part != WallVariation::NONE {
            part_notes.push(format!(
                "{nominal} um: E x{:.4}, K_r x{:.4}",
                part.e_factor, part.kr_factor
            ));
        }
        // controllers' model: identified tool stiffness, Table-4 E, force coefficient with the force error
        let mut rng = ChaCha8Rng::seed_from_u64(s.seed.wrapping_add(101 + wi as u64));
        let cal = StiffnessCalibration {
            indicator_resolution_um: 0.1,
            noise_um: 0.05,
            trials: 3,
        };
        let loads: Vec<f64> = (1..=10).map(|i| 0.5 * i as f64).collect();
        let (k_tool_id, _) = fit_compliance(
            truth.tool_stiffness_n_per_um,
            &loads,
            &cal,
            &mut rng,
            "tool",
        )?;
        let k_tool_model = k_tool_id * (1.0 + s.truth.stiffness_error);
        k_tool_rel = k_tool_model / truth.tool_stiffness_n_per_um - 1.0;
        let model = WallModel::published_004(&tw.geometry(nominal), k_tool_model)?
            .scaled(1.0 + s.truth.stiffness_error, 1.0 + force_errors.w_mpa)?;
        let plan = plan_wall(&model)?;
        let dt = plan.dt_s;
        let mut ctl =
            thin_wall_controller(kind, &plan, s.control.horizon, s.control.cycle_budget())?;
        let mut pending = SolverFailures::new(s);
        let mut st = ThinWallStage::new(truth.clone())?;
        let mut last: Option<ThinWallStepOutput> = None;
        let mut prev_stage = 0.0;
        let mut k = 0usize;
        let mut stuck: Option<f64> = None;
        while !st.done() {
            // measurement of the previous step, with faults
            let meas = last
                .as_ref()
                .map(|o| thin_wall_measurement(o, &s.faults, dt, &mut stuck));
            let t_now = k as f64 * dt;
            pending.inject_due(t_now, |n| ctl.inject_solver_failures(n));
            let est = estimated_deflection_um(&plan, k, meas.as_ref());
            let cmd = crate::realtime::cycle(|| ctl.command(k, meas.as_ref()));
            // stage travel (assumed ±: −20 … +60 µm around the programmed path) for every controller
            let cmd = if cmd.is_finite() {
                cmd.clamp(STAGE_MIN_UM, STAGE_MAX_UM)
            } else {
                cmd
            };
            if !cmd.is_finite() {
                finite = false;
            }
            if !(STAGE_MIN_UM..=STAGE_MAX_UM).contains(&cmd) {
                in_limits = false;
            }
            let o = st.step(dt, cmd);
            travel += (o.stage_um - prev_stage).abs();
            prev_stage = o.stage_um;
            trace.rows.push(vec![
                nominal,
                o.t_s,
                o.layer as f64,
                o.x_um,
                o.force_meas_n,
                cmd,
                o.stage_um,
                est,
                o.wall_deflection_um + o.tool_deflection_um,
            ]);
            simulated += dt;
            last = Some(o);
            k += 1;
        }
        times.extend_from_slice(ctl.solve_times_us());
        if let Some(st) = ctl.solver_stats() {
            fallbacks += st.fallbacks;
            deadline_misses += st.deadline_misses;
            budget_us = st.budget_us;
            enforced = st.budget_enforced;
        }
        let t = st.mean_thickness_um();
        walls.push(WallReport {
            nominal_um: nominal,
            thickness_um: t,
            thickness_error_pct: 100.0 * (t - nominal) / nominal,
        });
        errors.extend(st.thickness_profile_um().iter().map(|v| v - nominal));
    }
    let mut metrics = Metrics::from_errors(&errors, travel);
    metrics.thickness_um = Some(walls.iter().map(|w| w.thickness_um).collect());
    metrics.thickness_error_pct = Some(walls.iter().map(|w| w.thickness_error_pct).collect());
    let mut notes = vec![
        "thin wall: error series = thickness profile over the height (mean along the wall) − nominal, all walls".into(),
    ];
    if !part_notes.is_empty() {
        notes.push(format!(
            "truth part vs the published wall (not in the controllers' model): {}",
            part_notes.join("; ")
        ));
    }
    if kind == ControllerKind::Threshold {
        notes.push("threshold uses the published deformation model (eq. 18 as printed: load at the wall top, evaluated at the cutting height; wall only, no tool deflection)".into());
    }
    Ok(RunOutput {
        report: RunReport {
            scenario: s.name.clone(),
            stage: "thin_wall".into(),
            controller: kind.name().into(),
            metrics,
            solver: (kind == ControllerKind::Mpc).then(|| {
                SolverStats::from_times(&times, fallbacks).with_budget(
                    budget_us,
                    deadline_misses,
                    enforced,
                )
            }),
            walls: Some(walls),
            commands_finite: finite,
            commands_in_limits: in_limits,
            process_change_peak_um: None,
            changes: Vec::new(),
            model: ModelSummary {
                kz_model_n_per_um: 0.0,
                kz_truth_n_per_um: 0.0,
                stiffness_error_rel: k_tool_rel,
                force_error_max_rel: force_errors.w_mpa.abs(),
                truth_force_scale: 1.0,
            },
            touch_off: None,
            nc_axis: None,
            simulated_s: simulated,
            realtime: false,
            wall_clock_s: wall_clock.elapsed().as_secs_f64(),
            notes,
        },
        trace,
    })
}
