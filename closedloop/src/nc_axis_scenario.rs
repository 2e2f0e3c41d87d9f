//! The `[nc_axis]` table of a scenario (the NC feed-axis stage of `003_…txt`): the program, the
//! machine, truth vs model, the controllers, the contour measurement and the commissioning plan, with
//! their validation. The stage's runner is [`crate::nc_axis`].

use millcomp_mpc::nc_axis::{CorrectionLimits, NcChannel, OffsetWindow, ToothOffsets};
use millcomp_sim::kienzle::EdgeForces;
use millcomp_sim::nc_axis::{AxisDynamics, ContourDevice, ForcePlatform, NcProgram, STAGE_DT_S};
use serde::{Deserialize, Serialize};

use crate::error::{
    ClosedLoopError, finite_nonneg as nonneg, finite_pos as pos, invalid, sim_keyed as sim_key,
};

/// The machine: static stiffness, the tool's overhang, the axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NcMachineSpec {
    /// Mean static stiffness of the machine at the tool, k_M (N/µm).
    pub machine_stiffness_n_per_um: f64,
    /// ΔkM/kM over the blank (003 eqs. 1–5's span).
    pub machine_span_rel: f64,
    /// Tool overhang in diameters.
    pub overhang_d: f64,
    /// Fluted length (mm).
    pub flute_length_mm: f64,
    /// Radial runout of the tool (µm).
    pub runout_um: f64,
    /// The feed axes (x and y alike).
    pub axis: AxisDynamics,
}

impl Default for NcMachineSpec {
    /// k_M = 30 N/µm (the middle of the 20–50 N/µm assumed; module doc of the scenario file), 10 %
    /// span, 3.5 D overhang, 32 mm flutes, 3 µm runout (a shrink chuck), 003's 16 ms axes as its
    /// 840D sl runs them by default (sim's `AxisDynamics::speed_feedforward_003`: speed feedforward,
    /// the set-points fine-interpolated over the cycle, 11 ms dead time, a 4 ms loop;
    /// docs/studies/published-nc.md).
    fn default() -> Self {
        Self {
            machine_stiffness_n_per_um: 30.0,
            machine_span_rel: 0.10,
            overhang_d: 3.5,
            flute_length_mm: 32.0,
            runout_um: 3.0,
            axis: AxisDynamics::speed_feedforward_003(),
        }
    }
}

/// How the truth differs from the controllers' models (and the platform's errors).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NcTruthSpec {
    /// Edge forces of the truth (N/mm).
    pub edge: EdgeForces,
    /// σ of the per-seed force factor (material lot, tool).
    pub force_factor_sigma: f64,
    /// Platform noise σ (N).
    pub platform_noise_n: f64,
    /// Platform quantisation (N).
    pub platform_resolution_n: f64,
    /// σ of the platform's gain error.
    pub platform_gain_sigma: f64,
    /// Extra relative error on the controllers' identified stiffness (`k·(1 + e)`).
    pub stiffness_error: f64,
    /// Extra relative error on the controllers' identified kc1.1 and kr1.1.
    pub kienzle_error: f64,
    /// Axial elements of the truth's cutting edge (sim's `KienzleMillingModel::axial_slices`): the
    /// force model's resolution. The elements leave the blank one by one at the exit; against 128
    /// elements the uncompensated wall there is off by up to 6.0 µm with 8, 3.5 with 16 and 1.4 with
    /// 32 (≈ 0.6 % of the deflection; 0.1 µm before the exit) — SCENARIOS.md.
    pub axial_slices: usize,
}

impl Default for NcTruthSpec {
    /// Edge forces 25/40 N/mm, force factor σ 3 %, platform σ 2 N, 0.5 N steps, gain σ 1 % (assumed),
    /// no extra model errors, the edge in 32 elements.
    fn default() -> Self {
        let p = ForcePlatform::assumed();
        Self {
            edge: EdgeForces::c45_assumed(),
            force_factor_sigma: 0.03,
            platform_noise_n: p.noise_n,
            platform_resolution_n: p.resolution_n,
            platform_gain_sigma: 0.01,
            stiffness_error: 0.0,
            kienzle_error: 0.0,
            axial_slices: 32,
        }
    }
}

/// The controllers' settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NcControlSpec {
    /// Stage step = the force platform's sampling interval (s).
    pub dt_s: f64,
    /// Explicit notch frequencies (Hz) of the reactive chain (default: 003's harmonics up to Nyquist).
    pub notch_hz: Option<Vec<f64>>,
    /// The chain's first-order low-pass (Hz).
    pub lowpass_hz: f64,
    /// When the proactive offset curve is superimposed.
    pub proactive_window: OffsetWindow,
    /// The correction's limits (every controller).
    pub limits: CorrectionLimits,
    /// The MPC's model of the feed axes (its preview's x axis and its y axis).
    pub mpc_axis_model: NcAxisModel,
    /// The MPC plans for the instants the teeth generate the wall (`millcomp_mpc::nc_axis::
    /// WallInstants`, from the NC's spindle angle); off: at the cycle starts.
    pub mpc_wall_instants: bool,
    /// How the MPC plans each tooth's offset (the runout's force) into the entry, the exit and
    /// another feed (`chip`, `engagement`, `constant`; `millcomp_mpc::nc_axis::ToothOffsets`).
    pub mpc_tooth_offsets: ToothOffsets,
}

/// Which commissioned model of the feed axes the MPC uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum NcAxisModel {
    /// The step response read off the commissioning's servo trace at the cycle starts (DMC-style).
    #[default]
    StepResponse,
    /// `identify feed-axis`' dead time + first-order lag.
    DeadTimeLag,
}

impl Default for NcControlSpec {
    fn default() -> Self {
        Self {
            dt_s: STAGE_DT_S,
            notch_hz: None,
            lowpass_hz: 120.0,
            proactive_window: OffsetWindow::default(),
            limits: CorrectionLimits::default(),
            mpc_axis_model: NcAxisModel::default(),
            mpc_wall_instants: true,
            mpc_tooth_offsets: ToothOffsets::Chip,
        }
    }
}

/// The wall's measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NcContourSpec {
    /// Height above the groove floor at which the wall is traced (mm).
    pub height_mm: f64,
    /// The contour device.
    pub device: ContourDevice,
}

impl Default for NcContourSpec {
    fn default() -> Self {
        Self {
            height_mm: 1.0,
            device: ContourDevice::default(),
        }
    }
}

/// The commissioning's experiments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NcCommissioningPlan {
    /// Feeds per tooth of the force calibration (mm).
    pub fz_mm: Vec<f64>,
    /// Axial depths (mm).
    pub ap_mm: Vec<f64>,
    /// Radial depths (mm).
    pub ae_mm: Vec<f64>,
    /// Replicates of every cut.
    pub replicates: usize,
    /// Revolutions per cut.
    pub revolutions: usize,
    /// Where along the blank the load–deflection test is made, as fractions of its length (0 = its
    /// start, 1 = its end), increasing.
    pub stiffness_at: Vec<f64>,
    /// Loads of the load–deflection test (N).
    pub loads_n: Vec<f64>,
    /// Trials per load.
    pub trials: usize,
    /// Dial indicator resolution (µm).
    pub indicator_resolution_um: f64,
    /// Dial indicator noise σ (µm).
    pub indicator_noise_um: f64,
    /// Height of the axis test's step (µm).
    pub axis_step_um: f64,
    /// Samples of the platform at rest.
    pub noise_samples: usize,
}

impl Default for NcCommissioningPlan {
    /// fz 0.03/0.06/0.09/0.12 mm (around 003's 0.05 and 0.10), full slots and half-width cuts at 4 and
    /// 8 mm, 2 replicates, 20 revolutions; loads 500 … 3000 N three times on a 1 µm indicator (σ
    /// 0.5 µm) at the blank's start, middle and end (003's ΔkM: the machine's stiffness changes along
    /// the axis); a 100 µm step and ramp per axis; 2000 platform samples at rest.
    fn default() -> Self {
        Self {
            fz_mm: vec![0.03, 0.06, 0.09, 0.12],
            ap_mm: vec![4.0, 8.0],
            ae_mm: vec![8.0, 16.0],
            replicates: 2,
            revolutions: 20,
            stiffness_at: vec![0.0, 0.5, 1.0],
            loads_n: vec![500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0],
            trials: 3,
            indicator_resolution_um: 1.0,
            indicator_noise_um: 0.5,
            axis_step_um: 100.0,
            noise_samples: 2000,
        }
    }
}

/// The `[nc_axis]` table of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NcAxisScenario {
    /// The NC program (003's: `NcProgram::brecher_003`).
    pub program: NcProgram,
    /// The machine.
    #[serde(default)]
    pub machine: NcMachineSpec,
    /// Truth vs model.
    #[serde(default)]
    pub truth: NcTruthSpec,
    /// The controllers.
    #[serde(default)]
    pub control: NcControlSpec,
    /// The wall's measurement.
    #[serde(default)]
    pub contour: NcContourSpec,
    /// The commissioning.
    #[serde(default)]
    pub commissioning: NcCommissioningPlan,
}

impl NcAxisScenario {
    /// Validate every value; errors name the key (`nc_axis.program.feed_changes[0].feed_mm_min`, …).
    ///
    /// # Errors
    /// [`ClosedLoopError::InvalidConfig`] naming the key and what is allowed: a feed above the axis'
    /// `max_feed_mm_min`, an NC cycle that is not a whole number of stage steps
    /// (`nc_axis.program.cycle_s`), a notch at or above the force channel's Nyquist frequency
    /// (`nc_axis.control.notch_hz[i]`), and every out-of-range number.
    pub fn validate(&self) -> Result<(), ClosedLoopError> {
        let p = &self.program;
        let m = &self.machine;
        m.axis
            .validate()
            .map_err(sim_key("nc_axis.machine.axis."))?;
        for (i, c) in p.feed_changes.iter().enumerate() {
            if !(c.feed_mm_min.is_finite() && c.feed_mm_min > 0.0)
                || c.feed_mm_min > m.axis.max_feed_mm_min
            {
                return Err(invalid(
                    format!("nc_axis.program.feed_changes[{i}].feed_mm_min"),
                    c.feed_mm_min,
                    format!(
                        "0 < feed <= the axis' maximum feed nc_axis.machine.axis.max_feed_mm_min = {}",
                        m.axis.max_feed_mm_min
                    ),
                ));
            }
            if !(c.x_mm.is_finite() && c.x_mm >= p.start_mm && c.x_mm < p.end_mm) {
                return Err(invalid(
                    format!("nc_axis.program.feed_changes[{i}].x_mm"),
                    c.x_mm,
                    "start_mm <= x_mm < end_mm, sorted",
                ));
            }
        }
        p.validate(m.axis.max_feed_mm_min)
            .map_err(sim_key("nc_axis.program."))?;
        let c = &self.control;
        if !(c.dt_s.is_finite() && c.dt_s >= 1e-6 && c.dt_s <= 1e-3) {
            return Err(invalid("nc_axis.control.dt_s", c.dt_s, "1e-6 ..= 1e-3 s"));
        }
        let ratio = p.cycle_s / c.dt_s;
        if (ratio - ratio.round()).abs() > 1e-6 || ratio.round() < 1.0 {
            return Err(invalid(
                "nc_axis.program.cycle_s",
                p.cycle_s,
                format!(
                    "a whole multiple of the stage step nc_axis.control.dt_s = {} s",
                    c.dt_s
                ),
            ));
        }
        if p.ae_mm > 16.0 + 1e-9 {
            return Err(invalid(
                "nc_axis.program.ae_mm",
                p.ae_mm,
                "<= the tool diameter (16 mm)",
            ));
        }
        let nyq = 0.5 / c.dt_s;
        if let Some(n) = &c.notch_hz {
            for (i, f) in n.iter().enumerate() {
                if !(f.is_finite() && *f > 0.0 && *f < nyq) {
                    return Err(invalid(
                        format!("nc_axis.control.notch_hz[{i}]"),
                        f,
                        format!(
                            "0 < f < the force channel's Nyquist frequency {nyq} Hz (0.5/nc_axis.control.dt_s)"
                        ),
                    ));
                }
            }
        }
        if !(c.lowpass_hz.is_finite() && c.lowpass_hz > 0.0 && c.lowpass_hz < nyq) {
            return Err(invalid(
                "nc_axis.control.lowpass_hz",
                c.lowpass_hz,
                "0 < f < Nyquist",
            ));
        }
        pos("nc_axis.control.limits.range_um", c.limits.range_um)?;
        pos(
            "nc_axis.control.limits.slew_um_per_cycle",
            c.limits.slew_um_per_cycle,
        )?;
        pos(
            "nc_axis.machine.machine_stiffness_n_per_um",
            m.machine_stiffness_n_per_um,
        )?;
        if !(m.machine_span_rel.is_finite() && (0.0..=1.0).contains(&m.machine_span_rel)) {
            return Err(invalid(
                "nc_axis.machine.machine_span_rel",
                m.machine_span_rel,
                "0 ..= 1",
            ));
        }
        if !(m.overhang_d.is_finite() && (1.0..=10.0).contains(&m.overhang_d)) {
            return Err(invalid(
                "nc_axis.machine.overhang_d",
                m.overhang_d,
                "1 ..= 10",
            ));
        }
        nonneg("nc_axis.machine.flute_length_mm", m.flute_length_mm)?;
        if !(m.runout_um.is_finite() && (0.0..=50.0).contains(&m.runout_um)) {
            return Err(invalid(
                "nc_axis.machine.runout_um",
                m.runout_um,
                "0 ..= 50",
            ));
        }
        let t = &self.truth;
        nonneg("nc_axis.truth.edge.kte_n_mm", t.edge.kte_n_mm)?;
        nonneg("nc_axis.truth.edge.kre_n_mm", t.edge.kre_n_mm)?;
        for (k, v, hi) in [
            (
                "nc_axis.truth.force_factor_sigma",
                t.force_factor_sigma,
                0.3,
            ),
            (
                "nc_axis.truth.platform_gain_sigma",
                t.platform_gain_sigma,
                0.1,
            ),
        ] {
            if !(v.is_finite() && (0.0..=hi).contains(&v)) {
                return Err(invalid(k, v, format!("0 ..= {hi}")));
            }
        }
        if !(1..=200).contains(&t.axial_slices) {
            return Err(invalid(
                "nc_axis.truth.axial_slices",
                t.axial_slices,
                "1 ..= 200",
            ));
        }
        nonneg("nc_axis.truth.platform_noise_n", t.platform_noise_n)?;
        nonneg(
            "nc_axis.truth.platform_resolution_n",
            t.platform_resolution_n,
        )?;
        for (k, v) in [
            ("nc_axis.truth.stiffness_error", t.stiffness_error),
            ("nc_axis.truth.kienzle_error", t.kienzle_error),
        ] {
            if !(v.is_finite() && v > -0.9 && v < 9.0) {
                return Err(invalid(k, v, "-0.9 < error < 9"));
            }
        }
        let ct = &self.contour;
        nonneg("nc_axis.contour.height_mm", ct.height_mm)?;
        pos("nc_axis.contour.device.spacing_mm", ct.device.spacing_mm)?;
        pos("nc_axis.contour.device.cutoff_mm", ct.device.cutoff_mm)?;
        nonneg("nc_axis.contour.device.noise_um", ct.device.noise_um)?;
        let cp = &self.commissioning;
        for (k, v) in [
            ("nc_axis.commissioning.fz_mm", &cp.fz_mm),
            ("nc_axis.commissioning.ap_mm", &cp.ap_mm),
            ("nc_axis.commissioning.ae_mm", &cp.ae_mm),
            ("nc_axis.commissioning.loads_n", &cp.loads_n),
        ] {
            if v.is_empty() {
                return Err(invalid(k, "[]", "at least one value"));
            }
            for (i, x) in v.iter().enumerate() {
                pos(&format!("{k}[{i}]"), *x)?;
            }
        }
        if cp.stiffness_at.is_empty() {
            return Err(invalid(
                "nc_axis.commissioning.stiffness_at",
                "[]",
                "at least one position",
            ));
        }
        for (i, a) in cp.stiffness_at.iter().enumerate() {
            let before = if i > 0 {
                cp.stiffness_at[i - 1]
            } else {
                f64::NEG_INFINITY
            };
            if !(0.0..=1.0).contains(a) || *a <= before {
                return Err(invalid(
                    format!("nc_axis.commissioning.stiffness_at[{i}]"),
                    a,
                    "increasing fractions of the blank's length in 0 ..= 1",
                ));
            }
        }
        if cp.fz_mm.len() < 2 {
            return Err(invalid(
                "nc_axis.commissioning.fz_mm",
                cp.fz_mm.len(),
                "at least two feeds (the exponents need the feed to vary)",
            ));
        }
        if let Some((i, a)) = cp.ae_mm.iter().enumerate().find(|(_, a)| **a > 16.0) {
            return Err(invalid(
                format!("nc_axis.commissioning.ae_mm[{i}]"),
                a,
                "<= the tool diameter (16 mm)",
            ));
        }
        for (k, v) in [
            ("nc_axis.commissioning.replicates", cp.replicates),
            ("nc_axis.commissioning.revolutions", cp.revolutions),
            ("nc_axis.commissioning.trials", cp.trials),
            ("nc_axis.commissioning.noise_samples", cp.noise_samples),
        ] {
            if v == 0 {
                return Err(invalid(k, 0, ">= 1"));
            }
        }
        nonneg(
            "nc_axis.commissioning.indicator_resolution_um",
            cp.indicator_resolution_um,
        )?;
        nonneg(
            "nc_axis.commissioning.indicator_noise_um",
            cp.indicator_noise_um,
        )?;
        pos("nc_axis.commissioning.axis_step_um", cp.axis_step_um)?;
        Ok(())
    }

    /// The notch frequencies the reactive chain uses.
    pub fn channel(&self) -> NcChannel {
        let mut ch = NcChannel::brecher_003(self.program.speed_rpm, 5, self.control.dt_s);
        if let Some(n) = &self.control.notch_hz {
            ch.notch_hz = n.clone();
        }
        ch.lowpass_hz = self.control.lowpass_hz;
        ch
    }
}
