//! MPC configuration: horizon, move blocking, weights, limits, soft output bounds, disturbance model,
//! Kalman-filter noise and solver settings. Serde (TOML/JSON); the keys are documented in `mpc/CONFIG.md`.
//!
//! [`MpcConfig::validate`] checks every value and names the offending key (`horizon`,
//! `limits.u_min[0]`, `weights.output[1]`, …) in [`MpcError::InvalidConfig`].

use serde::{Deserialize, Serialize};

use crate::error::{MpcError, invalid};

/// Complete configuration of one MPC controller. Vectors indexed by input carry one entry per model input,
/// vectors indexed by output one entry per model output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpcConfig {
    /// Prediction horizon N (control cycles), `1 ..= 500`.
    pub horizon: usize,
    /// Control horizon Nc (`1 ..= horizon`): free moves in the first Nc steps, input held afterwards.
    /// Mutually exclusive with `move_blocking`. Default: `horizon` (every step free).
    #[serde(default)]
    pub control_horizon: Option<usize>,
    /// Move blocking: lengths of the blocks over which the input is held; must sum to `horizon`.
    #[serde(default)]
    pub move_blocking: Option<Vec<usize>>,
    /// Cost weights.
    pub weights: Weights,
    /// Hard input limits.
    pub limits: Limits,
    /// Soft output bounds (slack with exact penalty, so the QP is always feasible).
    #[serde(default)]
    pub soft_outputs: Vec<SoftOutput>,
    /// Integrating disturbance model for offset-free control.
    #[serde(default)]
    pub disturbance: DisturbanceConfig,
    /// Kalman filter noise covariances (diagonal).
    #[serde(default)]
    pub kalman: KalmanConfig,
    /// Clarabel settings.
    #[serde(default)]
    pub solver: SolverConfig,
    /// Outputs between the control cycles in the cost (default none: the outputs at the cycles only).
    /// With it, the model given to [`crate::MpcController::new`] is sampled at the sub-step and the
    /// controller runs every `substeps` of its steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intersample: Option<Intersample>,
}

/// Tracking costs between the control cycles: the input is held over a cycle, but the output it moves
/// is weighted at every one of `substeps` sub-steps of the first `cycles` cycles (each at `Q / substeps`,
/// so such a cycle weighs as much as a later one seen at its end only). A change in the known offsets
/// that falls between two cycles — a deflection rising within a fraction of a cycle — is then tracked
/// where it happens, not only where the cycles sample it. Costs only: no rows are added to the QP's
/// constraints and its size is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intersample {
    /// Sub-steps per control cycle (`2 ..= 100`); the model's sample time is the cycle's over this.
    pub substeps: usize,
    /// Cycles of the horizon with costs between them (`1 ..= horizon`), from the first.
    pub cycles: usize,
}

/// Largest `intersample.substeps`.
pub const MAX_SUBSTEPS: usize = 100;

/// Weights of the quadratic cost
/// `Σₖ ‖y_k − r_k‖²_Q + Σₖ ‖Δu_k‖²_R + Σₖ ‖u_k − u_target‖²_S + ρ₁·Σ s + ρ₂·Σ s²`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Weights {
    /// Q: weight per output on the tracking error (≥ 0), one per model output.
    pub output: Vec<f64>,
    /// R: weight per input on the move Δu between consecutive steps (≥ 0; > 0 recommended).
    pub input_rate: Vec<f64>,
    /// S: weight per input on `u − input_target` (≥ 0). Default: all 0.
    #[serde(default)]
    pub input: Vec<f64>,
    /// Target for the S term, one per input. Default: all 0.
    #[serde(default)]
    pub input_target: Vec<f64>,
    /// ρ₁: linear (exact) penalty per unit of output-bound violation (≥ 0). Exactness needs ρ₁ larger
    /// than the bound's Lagrange multiplier; the default 1e4 is generous for µm-scaled outputs.
    #[serde(default = "default_slack_linear")]
    pub slack_linear: f64,
    /// ρ₂: quadratic penalty on the slack (≥ 0), keeps the QP strictly convex in the slack.
    #[serde(default = "default_slack_quadratic")]
    pub slack_quadratic: f64,
}

fn default_stride() -> usize {
    1
}

fn default_slack_linear() -> f64 {
    1e4
}
fn default_slack_quadratic() -> f64 {
    1e2
}

/// Hard input limits (never violated by an emitted command).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Minimum command per input (finite).
    pub u_min: Vec<f64>,
    /// Maximum command per input (finite, ≥ `u_min`).
    pub u_max: Vec<f64>,
    /// Maximum change per control cycle per input (slew, finite and > 0).
    pub du_max: Vec<f64>,
    /// Which move-block boundaries of the plan carry slew rows in the QP. The first block's slew is
    /// always enforced (merged into its bounds, an exact reformulation); the emitted command is always
    /// clamped to `u_prev ± du_max`.
    #[serde(default)]
    pub slew_rows: SlewRows,
}

/// Slew rows of the planned moves beyond the first (`limits.slew_rows`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlewRows {
    /// A slew row pair at every block boundary (the plan is slew-feasible throughout).
    #[default]
    EveryBlock,
    /// Only the first move is slew-limited (two rows fewer per block; the later boundaries of a
    /// geometric move blocking rarely bind — check the first moves against `every_block` before
    /// choosing it, as `bench/mpc-vs-casadi` does).
    FirstBlock,
}

/// A soft bound on one output over the horizon: `min − s ≤ y_k ≤ max + s`, `s ≥ 0`, checked at the steps
/// `k = from_step, from_step + stride, …` and `k = N`. One slack per bounded output (the largest violation
/// over the checked steps is penalised). Start after the plant's dead time / relative degree: earlier
/// predictions are fixed by the current state, and a violation there that no input can remove would only
/// inflate the slack.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftOutput {
    /// Output index (0-based).
    pub output: usize,
    /// Check the bound every `stride` steps (≥ 1; default 1 = every step). Fewer rows, faster QP.
    #[serde(default = "default_stride")]
    pub stride: usize,
    /// First checked step (1-based, 1 ..= horizon; default 1).
    #[serde(default = "default_stride")]
    pub from_step: usize,
    /// Lower bound (omit for none).
    #[serde(default)]
    pub min: Option<f64>,
    /// Upper bound (omit for none).
    #[serde(default)]
    pub max: Option<f64>,
    /// Bound the output's deviation from its reference (`min ≤ y − r ≤ max`) instead of the output
    /// itself (default false).
    #[serde(default)]
    pub about_reference: bool,
}

/// Where the integrating disturbance enters (offset-free MPC, Pannocchia & Rawlings 2003).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DisturbanceKind {
    /// `y = C x + D u + d` on the listed outputs (the usual choice; requires a stable plant).
    #[default]
    Output,
    /// `x⁺ = A x + B (u + d)` on the listed inputs.
    Input,
    /// No disturbance state (no offset-free guarantee).
    None,
}

/// Disturbance model configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisturbanceConfig {
    /// Kind.
    #[serde(default)]
    pub kind: DisturbanceKind,
    /// Output (for `output`) or input (for `input`) indices that get a disturbance state.
    /// Default: all outputs / inputs.
    #[serde(default)]
    pub channels: Option<Vec<usize>>,
    /// Output disturbances only: where a disturbance state enters another output as well, with a gain
    /// — a disturbance that is a physical displacement seen by two sensors (the groove MPC's stack
    /// disturbance, on the gauge and, through the tilt, on the depth error). Default: none (each state
    /// enters its own channel only).
    #[serde(default)]
    pub coupling: Vec<DisturbanceCoupling>,
}

/// An output disturbance state entering one more output ([`DisturbanceConfig::coupling`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisturbanceCoupling {
    /// Index of the disturbance state (its position in `channels`).
    pub state: usize,
    /// The other output it enters.
    pub output: usize,
    /// Its gain there (finite), in that output's units per the state's.
    pub gain: f64,
}

impl Default for DisturbanceConfig {
    fn default() -> Self {
        Self {
            kind: DisturbanceKind::Output,
            channels: None,
            coupling: Vec::new(),
        }
    }
}

/// Diagonal noise covariances of the augmented-state Kalman filter (steady-state gain by DARE iteration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KalmanConfig {
    /// Variance of an equivalent noise added to each input per cycle (> 0), in input units²: the plant-state
    /// process noise is `input_noise · B Bᵀ` (independent of the state realisation).
    #[serde(default = "default_input_noise")]
    pub input_noise: f64,
    /// Random-walk variance per disturbance state per cycle (> 0), in output (or input) units².
    #[serde(default = "default_disturbance_noise")]
    pub disturbance_noise: f64,
    /// Random-walk variance per cycle of each disturbance state (each positive), in
    /// `disturbance.channels` order: for disturbances that move at different speeds (the groove MPC's:
    /// the stack's misfit as fast as the stack moves, the plan's misfit per revolution). Empty:
    /// `disturbance_noise` for each.
    #[serde(default)]
    pub disturbance_noise_per_state: Vec<f64>,
    /// Measurement-noise variance per output (> 0). Default: 1e-2 for every output.
    #[serde(default)]
    pub measurement_noise: Vec<f64>,
    /// Innovation gate per output (output units, > 0): a measurement whose innovation exceeds it is treated
    /// as an outlier and skipped (prediction only for that output) — for at most `gate_max_skips`
    /// consecutive cycles, after which it is accepted (a real change, not a glitch). Empty: no gating.
    #[serde(default)]
    pub innovation_gate: Vec<f64>,
    /// Maximum consecutive cycles an output may be gated out (default 20).
    #[serde(default = "default_gate_max_skips")]
    pub gate_max_skips: usize,
}

fn default_gate_max_skips() -> usize {
    20
}

fn default_input_noise() -> f64 {
    1e-4
}
fn default_disturbance_noise() -> f64 {
    1e-2
}

impl Default for KalmanConfig {
    fn default() -> Self {
        Self {
            input_noise: default_input_noise(),
            disturbance_noise: default_disturbance_noise(),
            disturbance_noise_per_state: Vec::new(),
            measurement_noise: Vec::new(),
            innovation_gate: Vec::new(),
            gate_max_skips: default_gate_max_skips(),
        }
    }
}

/// Clarabel settings used by the controller (presolve is always off so the data can be updated).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverConfig {
    /// Maximum interior-point iterations per cycle (1 ..= 500).
    #[serde(default = "default_max_iter")]
    pub max_iter: u32,
    /// Absolute and relative duality-gap tolerance (1e-12 ..= 1e-3).
    #[serde(default = "default_tol")]
    pub tol_gap: f64,
    /// Primal/dual feasibility tolerance (1e-12 ..= 1e-3).
    #[serde(default = "default_tol")]
    pub tol_feas: f64,
    /// Iterative refinement of the KKT solves (Clarabel default on; off is ~40 % faster per iteration).
    #[serde(default = "default_true")]
    pub iterative_refinement: bool,
    /// Ruiz equilibration of the problem data (Clarabel default on).
    #[serde(default = "default_true")]
    pub equilibrate: bool,
    /// Time budget of one control cycle as a fraction of the control period (0 < f ≤ 1; default 0.5).
    /// The cycle starts at the measurement and ends with the emitted command; Clarabel is stopped (its
    /// termination callback) when the remaining budget would not hold one more iteration, and a cycle
    /// whose fresh plan is not ready within the budget emits the fallback instead (counted in
    /// [`crate::SolverStats::deadline_misses`]).
    #[serde(default = "default_budget_fraction")]
    pub budget_fraction: f64,
    /// Enforce the budget: the solver is stopped at the cycle's deadline and a plan not ready in time is
    /// replaced by the fallback, as on a real controller. Off (default), cycles are timed and misses
    /// counted, but the fresh plan is always used, so a simulation's result does not depend on how busy
    /// the machine running it is.
    #[serde(default)]
    pub enforce_budget: bool,
}

/// How the harness applies a controller's cycle budget: a fraction of the period other than the
/// configuration's, and whether it is enforced (the run is a real-time one).
///
/// ```
/// use millcomp_mpc::config::{CycleBudget, SolverConfig};
/// let mut s = SolverConfig::default();
/// CycleBudget { fraction: Some(0.2), enforced: true, max_iter: None }.apply(&mut s);
/// assert_eq!((s.budget_fraction, s.enforce_budget), (0.2, true));
/// // a deterministic budget: an iteration cap, whatever the clock says
/// CycleBudget { max_iter: Some(30), ..CycleBudget::default() }.apply(&mut s);
/// assert_eq!(s.max_iter, 30);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CycleBudget {
    /// Overrides `solver.budget_fraction` when given.
    pub fraction: Option<f64>,
    /// Sets `solver.enforce_budget` (a configuration that enforces it keeps it).
    pub enforced: bool,
    /// Overrides `solver.max_iter` when given: the iteration-count budget (deterministic — a replay
    /// gives the same commands on any machine).
    pub max_iter: Option<u32>,
}

impl CycleBudget {
    /// Apply to a solver configuration.
    pub fn apply(&self, s: &mut SolverConfig) {
        if let Some(f) = self.fraction {
            s.budget_fraction = f;
        }
        s.enforce_budget |= self.enforced;
        if let Some(m) = self.max_iter {
            s.max_iter = m;
        }
    }
}

fn default_budget_fraction() -> f64 {
    0.5
}

fn default_true() -> bool {
    true
}

fn default_max_iter() -> u32 {
    50
}
fn default_tol() -> f64 {
    1e-8
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            max_iter: default_max_iter(),
            tol_gap: default_tol(),
            tol_feas: default_tol(),
            iterative_refinement: true,
            equilibrate: true,
            budget_fraction: default_budget_fraction(),
            enforce_budget: false,
        }
    }
}

/// Maximum horizon accepted by [`MpcConfig::validate`] (keeps the dense condensed QP small).
pub const MAX_HORIZON: usize = 500;

fn check_vec_len(key: &str, v: &[f64], n: usize) -> Result<(), MpcError> {
    if v.len() == n {
        Ok(())
    } else {
        Err(invalid(
            key,
            format!("{} entries", v.len()),
            format!(
                "exactly {n} entries (one per {})",
                if key.contains("output") || key.contains("measurement") {
                    "output"
                } else {
                    "input"
                }
            ),
        ))
    }
}

fn check_nonneg_vec(key: &str, v: &[f64]) -> Result<(), MpcError> {
    for (i, x) in v.iter().enumerate() {
        if !(x.is_finite() && *x >= 0.0) {
            return Err(invalid(format!("{key}[{i}]"), x, "finite and >= 0"));
        }
    }
    Ok(())
}

impl MpcConfig {
    /// A reasonable single-input single-output configuration (used in docs and tests).
    ///
    /// ```
    /// let c = millcomp_mpc::MpcConfig::siso(20, 0.0, 10.0, 1.0);
    /// assert_eq!(c.horizon, 20);
    /// assert!(c.validate(1, 1).is_ok());
    /// ```
    pub fn siso(horizon: usize, u_min: f64, u_max: f64, du_max: f64) -> Self {
        Self {
            horizon,
            control_horizon: None,
            move_blocking: None,
            weights: Weights {
                output: vec![1.0],
                input_rate: vec![1e-3],
                input: vec![0.0],
                input_target: vec![0.0],
                slack_linear: default_slack_linear(),
                slack_quadratic: default_slack_quadratic(),
            },
            limits: Limits {
                u_min: vec![u_min],
                u_max: vec![u_max],
                du_max: vec![du_max],
                slew_rows: SlewRows::EveryBlock,
            },
            soft_outputs: Vec::new(),
            disturbance: DisturbanceConfig::default(),
            kalman: KalmanConfig::default(),
            solver: SolverConfig::default(),
            intersample: None,
        }
    }

    /// Sub-steps of the model per control cycle: `intersample.substeps`, 1 without it.
    pub fn substeps(&self) -> usize {
        self.intersample.map_or(1, |i| i.substeps)
    }

    /// Rows of intersample outputs per output (`cycles · (substeps − 1)`; 0 without them).
    pub fn intersample_rows(&self) -> usize {
        self.intersample
            .map_or(0, |i| i.cycles * (i.substeps.saturating_sub(1)))
    }

    /// Parse from TOML text and validate the dimension-free parts (see [`Self::validate_keys`]).
    pub fn from_toml_str(text: &str) -> Result<Self, MpcError> {
        let c: Self = toml::from_str(text).map_err(|source| MpcError::ConfigToml {
            source: Box::new(source),
        })?;
        c.validate_keys()?;
        Ok(c)
    }

    /// Checks that need no model: horizon, blocking, weights ≥ 0, limits ordered and finite, slack
    /// penalties, noise variances, solver settings. Errors name the key.
    ///
    /// ```
    /// use millcomp_mpc::{MpcConfig, MpcError};
    /// let mut c = MpcConfig::siso(20, 0.0, 10.0, 1.0);
    /// c.limits.u_min[0] = 20.0; // min > max
    /// match c.validate_keys() {
    ///     Err(MpcError::InvalidConfig { key, .. }) => assert_eq!(key, "limits.u_min[0]"),
    ///     other => panic!("{other:?}"),
    /// }
    /// ```
    pub fn validate_keys(&self) -> Result<(), MpcError> {
        if self.horizon == 0 || self.horizon > MAX_HORIZON {
            return Err(invalid(
                "horizon",
                self.horizon,
                format!("1 ..= {MAX_HORIZON}"),
            ));
        }
        if let Some(i) = self.intersample {
            if !(2..=MAX_SUBSTEPS).contains(&i.substeps) {
                return Err(invalid(
                    "intersample.substeps",
                    i.substeps,
                    format!("2 ..= {MAX_SUBSTEPS}"),
                ));
            }
            if i.cycles == 0 || i.cycles > self.horizon {
                return Err(invalid(
                    "intersample.cycles",
                    i.cycles,
                    format!("1 ..= horizon ({})", self.horizon),
                ));
            }
        }
        if self.control_horizon.is_some() && self.move_blocking.is_some() {
            return Err(invalid(
                "control_horizon",
                "given together with move_blocking",
                "at most one of control_horizon / move_blocking",
            ));
        }
        if let Some(nc) = self.control_horizon
            && (nc == 0 || nc > self.horizon)
        {
            return Err(invalid(
                "control_horizon",
                nc,
                format!("1 ..= horizon ({})", self.horizon),
            ));
        }
        if let Some(b) = &self.move_blocking {
            if let Some(i) = b.iter().position(|&l| l == 0) {
                return Err(invalid(format!("move_blocking[{i}]"), 0, ">= 1"));
            }
            let s: usize = b.iter().sum();
            if s != self.horizon || b.is_empty() {
                return Err(invalid(
                    "move_blocking",
                    format!("{b:?} (sum {s})"),
                    format!("block lengths summing to horizon ({})", self.horizon),
                ));
            }
        }
        check_nonneg_vec("weights.output", &self.weights.output)?;
        check_nonneg_vec("weights.input_rate", &self.weights.input_rate)?;
        check_nonneg_vec("weights.input", &self.weights.input)?;
        for (i, x) in self.weights.input_target.iter().enumerate() {
            if !x.is_finite() {
                return Err(invalid(format!("weights.input_target[{i}]"), x, "finite"));
            }
        }
        for (key, v) in [
            ("weights.slack_linear", self.weights.slack_linear),
            ("weights.slack_quadratic", self.weights.slack_quadratic),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(key, v, "finite and >= 0"));
            }
        }
        let l = &self.limits;
        if l.u_min.len() != l.u_max.len() || l.u_min.len() != l.du_max.len() {
            return Err(invalid(
                "limits",
                format!(
                    "u_min {} / u_max {} / du_max {} entries",
                    l.u_min.len(),
                    l.u_max.len(),
                    l.du_max.len()
                ),
                "the same number of entries (one per input)",
            ));
        }
        for i in 0..l.u_min.len() {
            if !l.u_min[i].is_finite() {
                return Err(invalid(format!("limits.u_min[{i}]"), l.u_min[i], "finite"));
            }
            if !l.u_max[i].is_finite() {
                return Err(invalid(format!("limits.u_max[{i}]"), l.u_max[i], "finite"));
            }
            if l.u_min[i] > l.u_max[i] {
                return Err(invalid(
                    format!("limits.u_min[{i}]"),
                    l.u_min[i],
                    format!("<= limits.u_max[{i}] ({})", l.u_max[i]),
                ));
            }
            if !(l.du_max[i].is_finite() && l.du_max[i] > 0.0) {
                return Err(invalid(
                    format!("limits.du_max[{i}]"),
                    l.du_max[i],
                    "finite and > 0",
                ));
            }
        }
        for (j, so) in self.soft_outputs.iter().enumerate() {
            for (side, v) in [("min", so.min), ("max", so.max)] {
                if let Some(v) = v
                    && !v.is_finite()
                {
                    return Err(invalid(
                        format!("soft_outputs[{j}].{side}"),
                        v,
                        "finite (omit the key for no bound)",
                    ));
                }
            }
            if so.stride == 0 {
                return Err(invalid(format!("soft_outputs[{j}].stride"), 0, ">= 1"));
            }
            if so.from_step == 0 || so.from_step > self.horizon {
                return Err(invalid(
                    format!("soft_outputs[{j}].from_step"),
                    so.from_step,
                    format!("1 ..= horizon ({})", self.horizon),
                ));
            }
            if let (Some(lo), Some(hi)) = (so.min, so.max)
                && lo > hi
            {
                return Err(invalid(
                    format!("soft_outputs[{j}].min"),
                    lo,
                    format!("<= soft_outputs[{j}].max ({hi})"),
                ));
            }
        }
        let k = &self.kalman;
        if !(k.input_noise.is_finite() && k.input_noise > 0.0) {
            return Err(invalid(
                "kalman.input_noise",
                k.input_noise,
                "finite and > 0",
            ));
        }
        if !(k.disturbance_noise.is_finite() && k.disturbance_noise > 0.0) {
            return Err(invalid(
                "kalman.disturbance_noise",
                k.disturbance_noise,
                "finite and > 0",
            ));
        }
        for (i, x) in k.disturbance_noise_per_state.iter().enumerate() {
            if !(x.is_finite() && *x > 0.0) {
                return Err(invalid(
                    format!("kalman.disturbance_noise_per_state[{i}]"),
                    x,
                    "finite and > 0",
                ));
            }
        }
        for (i, x) in k.measurement_noise.iter().enumerate() {
            if !(x.is_finite() && *x > 0.0) {
                return Err(invalid(
                    format!("kalman.measurement_noise[{i}]"),
                    x,
                    "finite and > 0",
                ));
            }
        }
        for (i, x) in k.innovation_gate.iter().enumerate() {
            if !(x.is_finite() && *x > 0.0) {
                return Err(invalid(
                    format!("kalman.innovation_gate[{i}]"),
                    x,
                    "finite and > 0",
                ));
            }
        }
        let s = &self.solver;
        if s.max_iter == 0 || s.max_iter > 500 {
            return Err(invalid("solver.max_iter", s.max_iter, "1 ..= 500"));
        }
        if !(s.budget_fraction.is_finite() && s.budget_fraction > 0.0 && s.budget_fraction <= 1.0) {
            return Err(invalid(
                "solver.budget_fraction",
                s.budget_fraction,
                "0 < fraction <= 1 (of the control period)",
            ));
        }
        for (key, v) in [
            ("solver.tol_gap", s.tol_gap),
            ("solver.tol_feas", s.tol_feas),
        ] {
            if !(v.is_finite() && (1e-12..=1e-3).contains(&v)) {
                return Err(invalid(key, v, "1e-12 ..= 1e-3"));
            }
        }
        Ok(())
    }

    /// Full validation against a model with `n_inputs` inputs and `n_outputs` outputs.
    pub fn validate(&self, n_inputs: usize, n_outputs: usize) -> Result<(), MpcError> {
        self.validate_keys()?;
        check_vec_len("weights.output", &self.weights.output, n_outputs)?;
        check_vec_len("weights.input_rate", &self.weights.input_rate, n_inputs)?;
        if !self.weights.input.is_empty() {
            check_vec_len("weights.input", &self.weights.input, n_inputs)?;
        }
        if !self.weights.input_target.is_empty() {
            check_vec_len("weights.input_target", &self.weights.input_target, n_inputs)?;
        }
        check_vec_len("limits.u_min", &self.limits.u_min, n_inputs)?;
        if !self.kalman.measurement_noise.is_empty() {
            check_vec_len(
                "kalman.measurement_noise",
                &self.kalman.measurement_noise,
                n_outputs,
            )?;
        }
        if !self.kalman.innovation_gate.is_empty() {
            check_vec_len(
                "kalman.innovation_gate",
                &self.kalman.innovation_gate,
                n_outputs,
            )?;
        }
        for (j, so) in self.soft_outputs.iter().enumerate() {
            if so.output >= n_outputs {
                return Err(invalid(
                    format!("soft_outputs[{j}].output"),
                    so.output,
                    format!("0 ..= {}", n_outputs.saturating_sub(1)),
                ));
            }
        }
        if let Some(ch) = &self.disturbance.channels {
            let n = match self.disturbance.kind {
                DisturbanceKind::Output => n_outputs,
                DisturbanceKind::Input => n_inputs,
                DisturbanceKind::None => usize::MAX,
            };
            for (i, &c) in ch.iter().enumerate() {
                if c >= n {
                    return Err(invalid(
                        format!("disturbance.channels[{i}]"),
                        c,
                        format!("0 ..= {}", n.saturating_sub(1)),
                    ));
                }
            }
        }
        let n_states = match (self.disturbance.kind, &self.disturbance.channels) {
            (DisturbanceKind::None, _) => 0,
            (_, Some(ch)) => ch.len(),
            (DisturbanceKind::Output, None) => n_outputs,
            (DisturbanceKind::Input, None) => n_inputs,
        };
        let per_state = &self.kalman.disturbance_noise_per_state;
        if !per_state.is_empty() && per_state.len() != n_states {
            return Err(invalid(
                "kalman.disturbance_noise_per_state",
                format!("{} values", per_state.len()),
                format!("empty or one per disturbance state ({n_states})"),
            ));
        }
        if !self.disturbance.coupling.is_empty() {
            if self.disturbance.kind != DisturbanceKind::Output {
                return Err(invalid(
                    "disturbance.coupling",
                    format!("{:?}", self.disturbance.coupling),
                    "empty unless disturbance.kind = \"output\"",
                ));
            }
            for (i, c) in self.disturbance.coupling.iter().enumerate() {
                if c.state >= n_states {
                    return Err(invalid(
                        format!("disturbance.coupling[{i}].state"),
                        c.state,
                        format!("0 ..= {}", n_states.saturating_sub(1)),
                    ));
                }
                if c.output >= n_outputs {
                    return Err(invalid(
                        format!("disturbance.coupling[{i}].output"),
                        c.output,
                        format!("0 ..= {}", n_outputs.saturating_sub(1)),
                    ));
                }
                if !c.gain.is_finite() {
                    return Err(invalid(
                        format!("disturbance.coupling[{i}].gain"),
                        c.gain,
                        "finite",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Geometric move blocking `1, 1, 2, 4, 8, …` truncated to sum to `horizon` (few variables, fine
    /// resolution early in the horizon).
    ///
    /// ```
    /// assert_eq!(millcomp_mpc::MpcConfig::geometric_blocks(20), vec![1, 1, 2, 4, 8, 4]);
    /// ```
    pub fn geometric_blocks(horizon: usize) -> Vec<usize> {
        let mut b = Vec::new();
        let (mut sum, mut next) = (0usize, 1usize);
        while sum < horizon {
            let len = next.min(horizon - sum);
            b.push(len);
            sum += len;
            if b.len() >= 2 {
                next *= 2;
            }
        }
        b
    }

    /// Block lengths of the input parameterisation (sum = `horizon`).
    pub fn blocks(&self) -> Vec<usize> {
        if let Some(b) = &self.move_blocking {
            return b.clone();
        }
        match self.control_horizon {
            Some(nc) if nc < self.horizon => {
                let mut b = vec![1; nc - 1];
                b.push(self.horizon - nc + 1);
                b
            }
            _ => vec![1; self.horizon],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key_of(r: Result<(), MpcError>) -> String {
        match r {
            Err(MpcError::InvalidConfig { key, .. }) => key,
            other => panic!("expected InvalidConfig, got {other:?}"),
        }
    }

    #[test]
    fn errors_name_the_key() {
        let base = MpcConfig::siso(20, 0.0, 10.0, 1.0);
        let mut c = base.clone();
        c.horizon = 0;
        assert_eq!(key_of(c.validate_keys()), "horizon");
        let mut c = base.clone();
        c.weights.output[0] = -1.0;
        assert_eq!(key_of(c.validate_keys()), "weights.output[0]");
        let mut c = base.clone();
        c.weights.input_rate[0] = f64::NAN;
        assert_eq!(key_of(c.validate_keys()), "weights.input_rate[0]");
        let mut c = base.clone();
        c.limits.u_min[0] = 11.0;
        assert_eq!(key_of(c.validate_keys()), "limits.u_min[0]");
        let mut c = base.clone();
        c.limits.du_max[0] = 0.0;
        assert_eq!(key_of(c.validate_keys()), "limits.du_max[0]");
        let mut c = base.clone();
        c.control_horizon = Some(21);
        assert_eq!(key_of(c.validate_keys()), "control_horizon");
        let mut c = base.clone();
        c.move_blocking = Some(vec![5, 5]);
        assert_eq!(key_of(c.validate_keys()), "move_blocking");
        let mut c = base.clone();
        c.soft_outputs = vec![SoftOutput {
            output: 3,
            stride: 1,
            from_step: 1,
            min: Some(-1.0),
            max: Some(1.0),
            about_reference: false,
        }];
        assert_eq!(key_of(c.validate(1, 1)), "soft_outputs[0].output");
        let mut c = base;
        c.weights.output = vec![1.0, 2.0];
        assert_eq!(key_of(c.validate(1, 1)), "weights.output");
    }

    #[test]
    fn blocks_from_control_horizon() {
        let mut c = MpcConfig::siso(10, 0.0, 1.0, 1.0);
        assert_eq!(c.blocks(), vec![1; 10]);
        c.control_horizon = Some(3);
        assert_eq!(c.blocks(), vec![1, 1, 8]);
        c.control_horizon = None;
        c.move_blocking = Some(vec![1, 2, 3, 4]);
        assert_eq!(c.blocks(), vec![1, 2, 3, 4]);
    }

    #[test]
    fn toml_roundtrip_and_unknown_key() {
        let text = r#"
horizon = 20
control_horizon = 5
[weights]
output = [1.0]
input_rate = [0.001]
[limits]
u_min = [0.0]
u_max = [1000.0]
du_max = [50.0]
[[soft_outputs]]
output = 0
min = -1.0
max = 1.0
"#;
        let c = MpcConfig::from_toml_str(text).unwrap();
        assert_eq!(c.control_horizon, Some(5));
        assert_eq!(c.soft_outputs[0].max, Some(1.0));
        let bad = text.replace("horizon = 20\n", "horizon = 20\nhorizonn = 3\n");
        let e = MpcConfig::from_toml_str(&bad).unwrap_err();
        // the parser's message (the cause) names the unknown key
        let cause = std::error::Error::source(&e).map(|c| c.to_string());
        assert!(
            matches!(e, MpcError::ConfigToml { .. })
                && cause.as_deref().is_some_and(|c| c.contains("horizonn")),
            "{e}: {cause:?}"
        );
        let zero = text.replace("horizon = 20\n", "horizon = 0\n");
        assert!(
            matches!(MpcConfig::from_toml_str(&zero), Err(MpcError::InvalidConfig { key, .. }) if key == "horizon")
        );
    }
}
