//! Thin-wall stage (`004_…txt`): a micro-milled H59 brass wall as a cantilever whose moment of inertia
//! changes as layers are cut (eqs. 14–18), cut in axial layers with springback, residual material removed
//! by later layers, a linear-motor stage (0.1 µm resolution, 0.5 µm accuracy) moving the work towards the
//! tool as the actuator, and a measured radial force.
//!
//! Reconstruction and assumptions (the paper gives eqs. 1–18 but not every dimension):
//! * Wall before finishing: nominal thickness + `ae` (50 µm) over the full height `l` = 800 µm; the
//!   finishing side is cut top-down in layers of `ap` = 200 µm (Table 2). The tool flank spans from the
//!   current floor to the top, so residual material of upper layers is cut again by later passes
//!   ("the residual material of the first layer will be partially removed", §4.3).
//! * Section inertia per unit length `t³/12` (eq. 14) on a grid along the wall length and height; the cut
//!   part of the current layer is thinner than the uncut part (eqs. 15–16); `I_ave` is the mean over the
//!   height of the section inertias (eq. 17). The wall length `b` is not published: default 5 mm.
//! * Deflection (eq. 18 generalised to a load at the cutting height `zc` instead of the top):
//!   `w(z) = F z² (3 zc − z)/(6 E I_ave)` for z ≤ zc, `F zc² (3 z − zc)/(6 E I_ave)` above.
//! * Radial force (the one calibrated coefficient): `F = K_r · Σ_z h_max(ae_local(z)) dz`, the peak
//!   undeformed chip thickness `h_max = fz · sin(acos(1 − 2 ae/D))` of a Ø1 mm end mill (004 §3.1 uses the
//!   peak of several cycles) over the locally engaged radial depth.
//! * The tool (Ø1 mm, 4 flutes, carbide) deflects away from the wall by `F/k_tool`; `k_tool` from a
//!   cantilever of the fluted part (assumed 3 mm long, core Ø0.75 mm, E = 600 GPa) = 1.035 N/µm.
//! * The surface left at (x, z) is the envelope `min` over passes of `w(z) + F/k_tool − u` (springback:
//!   once the tool has passed, the wall returns and keeps the extra material). `u` is the stage command.
//!
//! [`THINWALL_KR_N_PER_MM2`] is calibrated once so that the 100 µm wall comes out at 106.7 µm uncompensated
//! (Table 5); the 80 and 120 µm walls then follow (tests). See the crate report for what this implies.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_nonneg, check_positive, check_range};
use crate::sensors::{ForceSensor, NoiseSpec, quantize};

/// Specific radial-force coefficient K_r (N/mm²) calibrated on the 100 µm wall (106.7 µm, 004 Table 5) by
/// `tests/thinwall.rs::kr_calibration_record`.
pub const THINWALL_KR_N_PER_MM2: f64 = 39_567.4;

/// Linear-motor compensation stage (004 §2.2: resolution 0.1 µm, positioning accuracy 0.5 µm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearStage {
    /// Command resolution (µm).
    pub resolution_um: f64,
    /// Positioning accuracy (µm): each new position lands within ±accuracy (uniform, seeded) if
    /// `accuracy_seed` is set; exact otherwise.
    pub accuracy_um: f64,
    /// Seed of the positioning error (None = exact positioning).
    pub accuracy_seed: Option<u64>,
}

impl Default for LinearStage {
    fn default() -> Self {
        Self {
            resolution_um: 0.1,
            accuracy_um: 0.5,
            accuracy_seed: None,
        }
    }
}

/// Thin-wall set-up (004 Tables 2–4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThinWallConfig {
    /// Nominal wall thickness (µm): 80, 100 or 120.
    pub nominal_thickness_um: f64,
    /// Wall height l (µm), 800.
    pub height_um: f64,
    /// Wall length b (µm) along the feed; not published, 5000 assumed.
    pub length_um: f64,
    /// Radial depth of cut ae (µm), 50.
    pub ae_um: f64,
    /// Axial depth per layer ap (µm), 200.
    pub ap_um: f64,
    /// Feed per tooth fz (µm), 1.6.
    pub fz_um: f64,
    /// Tool diameter (mm), 1.0.
    pub tool_diameter_mm: f64,
    /// Flutes, 4.
    pub flutes: u32,
    /// Spindle speed (rpm); not published, 20 000 assumed (machine max 36 000).
    pub speed_rpm: f64,
    /// Workpiece modulus (GPa), H59 brass 100 (Table 4).
    pub e_gpa: f64,
    /// Specific radial-force coefficient (N/mm²).
    pub kr_n_per_mm2: f64,
    /// Tool radial stiffness (N/µm).
    pub tool_stiffness_n_per_um: f64,
    /// Compensation stage.
    pub stage: LinearStage,
    /// Optional force-sensor noise (σ in N; 0.001 N resolution, Table 1).
    pub force_noise: Option<NoiseSpec>,
    /// Grid cells along the wall length.
    pub cells_x: usize,
    /// Grid cells over the height.
    pub cells_z: usize,
}

impl ThinWallConfig {
    /// The 004 set-up for a wall of nominal thickness `nominal_thickness_um`.
    pub fn paper(nominal_thickness_um: f64) -> Result<Self, SimError> {
        let c = Self {
            nominal_thickness_um,
            height_um: 800.0,
            length_um: 5000.0,
            ae_um: 50.0,
            ap_um: 200.0,
            fz_um: 1.6,
            tool_diameter_mm: 1.0,
            flutes: 4,
            speed_rpm: 20_000.0,
            e_gpa: 100.0,
            kr_n_per_mm2: THINWALL_KR_N_PER_MM2,
            tool_stiffness_n_per_um: tool_stiffness_004_n_per_um(),
            stage: LinearStage::default(),
            force_noise: None,
            cells_x: 25,
            cells_z: 80,
        };
        c.validate()?;
        Ok(c)
    }

    /// Validate (errors name the parameter).
    pub fn validate(&self) -> Result<(), SimError> {
        check_range(
            "nominal_thickness_um",
            self.nominal_thickness_um,
            1.0,
            1e4,
            "1 <= nominal_thickness_um <= 10000",
        )?;
        check_positive("height_um", self.height_um)?;
        check_positive("length_um", self.length_um)?;
        check_range(
            "ae_um",
            self.ae_um,
            1e-3,
            self.tool_diameter_mm * 500.0,
            "0 < ae_um <= tool radius",
        )?;
        check_range(
            "ap_um",
            self.ap_um,
            1e-3,
            self.height_um,
            "0 < ap_um <= height_um",
        )?;
        check_positive("fz_um", self.fz_um)?;
        check_positive("tool_diameter_mm", self.tool_diameter_mm)?;
        if self.flutes == 0 {
            return Err(SimError::InvalidParameter {
                name: "flutes",
                value: 0.0,
                allowed: ">= 1",
            });
        }
        check_positive("speed_rpm", self.speed_rpm)?;
        check_positive("e_gpa", self.e_gpa)?;
        check_nonneg("kr_n_per_mm2", self.kr_n_per_mm2)?;
        check_positive("tool_stiffness_n_per_um", self.tool_stiffness_n_per_um)?;
        check_nonneg("resolution_um", self.stage.resolution_um)?;
        check_nonneg("accuracy_um", self.stage.accuracy_um)?;
        if self.cells_x < 2 || self.cells_z < 4 {
            return Err(SimError::InvalidParameter {
                name: "cells",
                value: self.cells_x.min(self.cells_z) as f64,
                allowed: "cells_x >= 2 and cells_z >= 4",
            });
        }
        Ok(())
    }

    /// Feed velocity (µm/s) = fz · flutes · rpm/60.
    pub fn feed_um_s(&self) -> f64 {
        self.fz_um * self.flutes as f64 * self.speed_rpm / 60.0
    }

    /// Number of axial layers.
    pub fn layers(&self) -> usize {
        (self.height_um / self.ap_um).ceil() as usize
    }

    /// Peak undeformed chip thickness (µm) at radial engagement `ae_um`.
    pub fn h_max_um(&self, ae_um: f64) -> f64 {
        let r = self.tool_diameter_mm * 500.0;
        let a = ae_um.clamp(0.0, r);
        if a <= 0.0 {
            return 0.0;
        }
        self.fz_um * (1.0 - (1.0 - a / r).powi(2)).max(0.0).sqrt()
    }
}

/// Radial stiffness of the 004 tool (N/µm): cantilever of the fluted part, 3 mm long, core Ø0.75 mm
/// (≈ 75 % of D for 4 flutes), E = 600 GPa (carbide): `3EI/L³` (assumptions; 004 gives only Ø1 mm, 4 flutes).
pub fn tool_stiffness_004_n_per_um() -> f64 {
    let i = std::f64::consts::PI * 0.75f64.powi(4) / 64.0; // mm⁴
    3.0 * 600_000.0 * i / 27.0 * 1e-3
}

/// One step of the thin-wall stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThinWallStepOutput {
    /// Time since the start (s).
    pub t_s: f64,
    /// Layer index (0 = top).
    pub layer: usize,
    /// Tool position along the wall (µm).
    pub x_um: f64,
    /// True radial force (N).
    pub force_n: f64,
    /// Measured radial force (N).
    pub force_meas_n: f64,
    /// Wall deflection at the cutting height (µm).
    pub wall_deflection_um: f64,
    /// Tool deflection (µm).
    pub tool_deflection_um: f64,
    /// Stage position actually reached (µm, + = towards the tool).
    pub stage_um: f64,
    /// Average moment of inertia per µm of wall length, eq. 17 (µm⁴/µm).
    pub i_ave_um3: f64,
    /// True once every layer has been cut.
    pub done: bool,
}

/// The steppable thin-wall plant.
#[derive(Debug, Clone)]
pub struct ThinWallStage {
    cfg: ThinWallConfig,
    /// Extra material beyond nominal at (x, z) (µm), row-major [ix * cells_z + iz]; z index 0 = bottom.
    excess: Vec<f64>,
    t_s: f64,
    layer: usize,
    x_um: f64,
    stage_um: f64,
    last_cmd: f64,
    rng: Option<ChaCha8Rng>,
    sensor: ForceSensor,
    finished: bool,
    last_force: f64,
}

impl ThinWallStage {
    /// Build the stage (wall pre-finished to nominal + ae everywhere).
    pub fn new(cfg: ThinWallConfig) -> Result<Self, SimError> {
        cfg.validate()?;
        let sensor = match cfg.force_noise {
            Some(n) => ForceSensor::new(n.sigma, 0.001, n.seed)?,
            None => ForceSensor::ideal(),
        };
        Ok(Self {
            excess: vec![cfg.ae_um; cfg.cells_x * cfg.cells_z],
            rng: cfg.stage.accuracy_seed.map(ChaCha8Rng::seed_from_u64),
            t_s: 0.0,
            layer: 0,
            x_um: 0.0,
            stage_um: 0.0,
            last_cmd: f64::NAN,
            sensor,
            finished: false,
            last_force: 0.0,
            cfg,
        })
    }

    /// Configuration.
    pub fn config(&self) -> &ThinWallConfig {
        &self.cfg
    }

    /// Whether every layer has been cut.
    pub fn done(&self) -> bool {
        self.finished
    }

    fn dz(&self) -> f64 {
        self.cfg.height_um / self.cfg.cells_z as f64
    }

    fn dx(&self) -> f64 {
        self.cfg.length_um / self.cfg.cells_x as f64
    }

    /// Mean section inertia per unit length over the height (eq. 17), µm³.
    pub fn i_ave_um3(&self) -> f64 {
        let (nx, nz) = (self.cfg.cells_x, self.cfg.cells_z);
        let mut acc = 0.0;
        for iz in 0..nz {
            let mut row = 0.0;
            for ix in 0..nx {
                let t = self.cfg.nominal_thickness_um + self.excess[ix * nz + iz];
                row += t * t * t / 12.0;
            }
            acc += row / nx as f64;
        }
        acc / nz as f64
    }

    /// Wall deflection (µm) at height `z` for a load `f` (N) at `zc`, using I_ave over the full length.
    fn wall_w(&self, f: f64, z: f64, zc: f64, i_ave: f64) -> f64 {
        let e = self.cfg.e_gpa * 1e-3; // N/µm²
        let ei = e * i_ave * self.cfg.length_um;
        if z <= zc {
            f * z * z * (3.0 * zc - z) / (6.0 * ei)
        } else {
            f * zc * zc * (3.0 * z - zc) / (6.0 * ei)
        }
    }

    /// Wall compliance at the cutting height (µm/N) for the current state and layer.
    pub fn wall_compliance_um_per_n(&self) -> f64 {
        let zc = self.layer_center_z();
        self.wall_w(1.0, zc, zc, self.i_ave_um3())
    }

    fn layer_floor_z(&self) -> f64 {
        (self.cfg.height_um - (self.layer as f64 + 1.0) * self.cfg.ap_um).max(0.0)
    }

    fn layer_center_z(&self) -> f64 {
        let top = self.cfg.height_um - self.layer as f64 * self.cfg.ap_um;
        0.5 * (top + self.layer_floor_z())
    }

    /// Advance by `dt_s` with the stage commanded to `stage_command_um` (µm towards the tool; NaN holds).
    pub fn step(&mut self, dt_s: f64, stage_command_um: f64) -> ThinWallStepOutput {
        if self.finished || dt_s.is_nan() || dt_s <= 0.0 {
            return self.output(0.0, 0.0, self.last_force);
        }
        // actuator: resolution + accuracy
        if stage_command_um.is_finite() && stage_command_um != self.last_cmd {
            self.last_cmd = stage_command_um;
            let q = quantize(stage_command_um, self.cfg.stage.resolution_um);
            let err = match self.rng.as_mut() {
                Some(r) => self.cfg.stage.accuracy_um * (2.0 * r.random::<f64>() - 1.0),
                None => 0.0,
            };
            self.stage_um = q + err;
        }
        let nz = self.cfg.cells_z;
        let ix = ((self.x_um / self.dx()) as usize).min(self.cfg.cells_x - 1);
        let z_floor = self.layer_floor_z();
        let zc = self.layer_center_z();
        let iz0 = ((z_floor / self.dz()).floor() as usize).min(nz - 1);
        let i_ave = self.i_ave_um3();
        let kt = self.cfg.tool_stiffness_n_per_um;
        let dz = self.dz();
        // self-consistent force: F = Kr Σ h_max(ae_local) dz
        let kr = self.cfg.kr_n_per_mm2 * 1e-6; // N/µm²
        let mut f = self.last_force.max(0.0);
        for _ in 0..100 {
            let mut sum = 0.0;
            for iz in iz0..nz {
                let z = (iz as f64 + 0.5) * dz;
                let pos = self.wall_w(f, z, zc, i_ave) + f / kt - self.stage_um;
                let ae = (self.excess[ix * nz + iz] - pos).max(0.0);
                sum += self.cfg.h_max_um(ae) * dz;
            }
            let f_new = kr * sum;
            let f_next = 0.5 * (f + f_new);
            if (f_next - f).abs() < 1e-9 {
                f = f_next;
                break;
            }
            f = f_next;
        }
        // cut: envelope of the deflected tool position
        for iz in iz0..nz {
            let z = (iz as f64 + 0.5) * dz;
            let pos = self.wall_w(f, z, zc, i_ave) + f / kt - self.stage_um;
            let e = &mut self.excess[ix * nz + iz];
            *e = e.min(pos.max(-self.cfg.nominal_thickness_um + 1.0));
        }
        self.last_force = f;
        let w_c = self.wall_w(f, zc, zc, i_ave);
        let out = self.output(w_c, f / kt, f);
        // advance
        self.t_s += dt_s;
        self.x_um += self.cfg.feed_um_s() * dt_s;
        if self.x_um >= self.cfg.length_um {
            self.x_um = 0.0;
            self.layer += 1;
            self.last_force = 0.0;
            if self.layer >= self.cfg.layers() {
                self.finished = true;
            }
        }
        ThinWallStepOutput {
            done: self.finished,
            ..out
        }
    }

    fn output(&mut self, w: f64, td: f64, f: f64) -> ThinWallStepOutput {
        ThinWallStepOutput {
            t_s: self.t_s,
            layer: self.layer.min(self.cfg.layers().saturating_sub(1)),
            x_um: self.x_um,
            force_n: f,
            force_meas_n: self.sensor.measure(f),
            wall_deflection_um: w,
            tool_deflection_um: td,
            stage_um: self.stage_um,
            i_ave_um3: self.i_ave_um3(),
            done: self.finished,
        }
    }

    /// Final wall thickness (µm): nominal + excess, averaged over the wall (004 Table 5 averages ≥ 6 points).
    pub fn mean_thickness_um(&self) -> f64 {
        self.cfg.nominal_thickness_um + self.excess.iter().sum::<f64>() / self.excess.len() as f64
    }

    /// Thickness profile over the height (µm), averaged along the length; index 0 = bottom.
    pub fn thickness_profile_um(&self) -> Vec<f64> {
        let (nx, nz) = (self.cfg.cells_x, self.cfg.cells_z);
        (0..nz)
            .map(|iz| {
                self.cfg.nominal_thickness_um
                    + (0..nx).map(|ix| self.excess[ix * nz + iz]).sum::<f64>() / nx as f64
            })
            .collect()
    }

    /// Run all layers with a command policy; returns the steps.
    pub fn run(
        &mut self,
        dt_s: f64,
        mut policy: impl FnMut(Option<&ThinWallStepOutput>) -> f64,
    ) -> Result<Vec<ThinWallStepOutput>, SimError> {
        check_positive("dt_s", dt_s)?;
        let mut out: Vec<ThinWallStepOutput> = Vec::new();
        while !self.finished {
            let u = policy(out.last());
            out.push(self.step(dt_s, u));
        }
        Ok(out)
    }
}

/// Uncompensated final mean thickness (µm) of the 004 wall of nominal thickness `nominal_um`.
pub fn uncompensated_thickness_um(nominal_um: f64) -> Result<f64, SimError> {
    let cfg = ThinWallConfig::paper(nominal_um)?;
    let dt = cfg.length_um / cfg.feed_um_s() / cfg.cells_x as f64;
    let mut st = ThinWallStage::new(cfg)?;
    st.run(dt, |_| 0.0)?;
    Ok(st.mean_thickness_um())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn tool_stiffness_assumption() {
        assert_relative_eq!(tool_stiffness_004_n_per_um(), 1.035, epsilon = 0.001);
    }

    #[test]
    fn chip_thickness_geometry() {
        let c = ThinWallConfig::paper(100.0).unwrap();
        // ae = 50 µm on Ø1 mm: φ = acos(0.9), h_max = 1.6·sin φ = 0.6975
        assert_relative_eq!(
            c.h_max_um(50.0),
            1.6 * (1.0f64 - 0.81).sqrt(),
            epsilon = 1e-12
        );
        assert_eq!(c.h_max_um(0.0), 0.0);
        assert_eq!(c.layers(), 4);
    }

    #[test]
    fn inertia_drops_as_layers_are_cut() {
        let cfg = ThinWallConfig::paper(100.0).unwrap();
        let dt = cfg.length_um / cfg.feed_um_s() / cfg.cells_x as f64;
        let mut st = ThinWallStage::new(cfg).unwrap();
        let i0 = st.i_ave_um3();
        // eq. 14: (100 + 50)³/12 before any cut
        assert_relative_eq!(i0, 150f64.powi(3) / 12.0, max_relative = 1e-12);
        let run = st.run(dt, |_| 0.0).unwrap();
        assert!(
            run.windows(2)
                .all(|w| w[1].i_ave_um3 <= w[0].i_ave_um3 + 1e-6)
        );
        assert!(st.i_ave_um3() < 0.8 * i0);
    }

    #[test]
    fn rejects_bad_parameters() {
        let mut c = ThinWallConfig::paper(100.0).unwrap();
        c.e_gpa = -5.0;
        assert!(matches!(
            c.validate(),
            Err(SimError::InvalidParameter { name: "e_gpa", .. })
        ));
        let mut c = ThinWallConfig::paper(100.0).unwrap();
        c.ap_um = 1000.0;
        assert!(matches!(
            c.validate(),
            Err(SimError::InvalidParameter { name: "ap_um", .. })
        ));
    }
}
