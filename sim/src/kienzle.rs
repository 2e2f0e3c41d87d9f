//! Mechanistic cutting force of a flat (square) end mill with Kienzle's law (`003_…txt` §3: C45, Ø16 mm
//! carbide end mill with 5 teeth, full slot ae = 16 mm, ap = 8 mm, 1990 rpm).
//!
//! 003 gives no force model (its eqs. 1–5 are about stiffness, and they were images); this is the
//! mechanistic model of the milling literature with Kienzle's power law per cutting edge element:
//!
//! * **Kienzle** (Kienzle & Victor 1957): tangential element force `dFt = kc1.1·b·h^(1−mc)`, radial
//!   `dFr = kr1.1·b·h^(1−mr)`, chip width b and thickness h in mm, forces in N.
//! * **Geometry** (Altintas, *Manufacturing Automation*, 2nd ed. 2012, ch. 2): the immersion angle φ is
//!   measured clockwise from the +y axis, the cutter turns clockwise and feeds along +x; tooth j at height
//!   z above the tip sits at `φ_j(z) = θ + 2πj/Z − z·tan β/R` (helix β lags the upper slices); chip
//!   thickness `h = fz·sin φ` plus the radius difference to the previous tooth from a radial runout ρ
//!   (`R_j = R + ρ·cos(θ_ρ + 2πj/Z)`, `h += R_j − R_{j−1}`, clamped at 0); an element cuts while
//!   `φ_st ≤ φ ≤ π` (down milling; `φ_st = π − acos(1 − 2ae/D)`, 0 for a full slot) and the point it
//!   cuts, `x_c + R sin φ`, lies on the blank (`blank_start ≤ x ≤ blank_end`: the entry and the exit).
//! * **Cartesian forces on the tool**: `Fx = −Ft cos φ − Fr sin φ` (feed direction),
//!   `Fy = Ft sin φ − Fr cos φ` (orthogonal to the feed: the component 003 compensates, `003_…txt` §2).
//!   In a full slot the revolution-mean `Fy` depends on kc1.1 and mc only (the radial part cancels by
//!   symmetry): for the linear law it is `Z·ap·fz·Kt/4`.
//! * **Edge (ploughing) forces** `dFte = kte·b`, `dFre = kre·b` on every cutting element (Altintas'
//!   edge coefficients): not part of Kienzle's law. The truth plant carries them so that the Kienzle
//!   model a user fits is wrong in shape, not only in its numbers; the controllers' models have none.
//!
//! C45 coefficients ([`KienzleCoefficients::c45_handbook`]): kc1.1 = 2220 N/mm², mc = 0.14 — the
//! Kienzle–Victor value for C45/Ck45 as tabulated in the German handbooks (Tschätsch & Dietrich,
//! *Praxis der Zerspantechnik*, Vieweg+Teubner; *Tabellenbuch Metall*, Europa-Lehrmittel; quoted here
//! from those tables, not re-measured). They are turning values (rake 6°, vc ≈ 100 m/min with carbide);
//! 003's 1990 rpm on Ø16 mm is vc = 100.0 m/min, so no speed correction is applied, and none for rake or
//! wear. The radial law is an assumption: kr1.1 = 0.4·kc1.1 with mr = mc (a constant Fr/Ft = 0.4, of
//! the order of the radial/tangential coefficient ratios reported for steels); it does not enter the
//! full-slot orthogonal mean force.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

use crate::error::{SimError, check_nonneg, check_positive, check_range};

/// Kienzle's coefficients of the tangential and radial element forces.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KienzleCoefficients {
    /// Specific cutting force at h = b = 1 mm, kc1.1 (N/mm²).
    pub kc11_n_mm2: f64,
    /// Exponent mc (`dFt = kc1.1·b·h^(1−mc)`).
    pub mc: f64,
    /// Radial counterpart kr1.1 (N/mm²).
    pub kr11_n_mm2: f64,
    /// Exponent mr.
    pub mr: f64,
}

/// C45's kc1.1 (N/mm²): Kienzle–Victor value as tabulated in the handbooks (module doc).
pub const C45_KC11_N_MM2: f64 = 2220.0;
/// C45's mc, same source.
pub const C45_MC: f64 = 0.14;
/// Assumed radial/tangential ratio of the C45 law (module doc).
pub const C45_RADIAL_RATIO: f64 = 0.4;

impl KienzleCoefficients {
    /// C45 (module doc: kc1.1 = 2220 N/mm², mc = 0.14; radial 0.4 × tangential, assumed).
    ///
    /// ```
    /// use millcomp_sim::kienzle::KienzleCoefficients;
    /// let c = KienzleCoefficients::c45_handbook();
    /// // specific cutting force at h = 0.05 mm: 2220 · 0.05^−0.14 ≈ 3377 N/mm²
    /// let kc = c.kc11_n_mm2 * 0.05f64.powf(-c.mc);
    /// assert!((kc - 3377.0).abs() < 1.0);
    /// ```
    pub fn c45_handbook() -> Self {
        Self {
            kc11_n_mm2: C45_KC11_N_MM2,
            mc: C45_MC,
            kr11_n_mm2: C45_RADIAL_RATIO * C45_KC11_N_MM2,
            mr: C45_MC,
        }
    }

    /// Validate (positive coefficients, exponents in `[0, 1)`).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `kc11_n_mm2`, `mc`, `kr11_n_mm2` or `mr`.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("kc11_n_mm2", self.kc11_n_mm2)?;
        check_nonneg("kr11_n_mm2", self.kr11_n_mm2)?;
        check_range("mc", self.mc, 0.0, 0.9, "0 <= mc <= 0.9")?;
        check_range("mr", self.mr, 0.0, 0.9, "0 <= mr <= 0.9")?;
        Ok(())
    }

    /// All four coefficients times `factor` on kc1.1 and kr1.1 (a force-level deviation).
    pub fn scaled(&self, factor: f64) -> Self {
        Self {
            kc11_n_mm2: self.kc11_n_mm2 * factor,
            kr11_n_mm2: self.kr11_n_mm2 * factor,
            ..*self
        }
    }
}

/// Edge (ploughing) force coefficients per unit of cutting-edge width (N/mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct EdgeForces {
    /// Tangential edge force per mm (N/mm).
    pub kte_n_mm: f64,
    /// Radial edge force per mm (N/mm).
    pub kre_n_mm: f64,
}

impl EdgeForces {
    /// The truth's assumption for C45 with a honed carbide edge: 25 N/mm tangential, 40 N/mm radial (the
    /// order of the edge coefficients reported for steels; no 003 value).
    pub fn c45_assumed() -> Self {
        Self {
            kte_n_mm: 25.0,
            kre_n_mm: 40.0,
        }
    }
}

/// A flat end mill as the force model sees it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndMill {
    /// Diameter D (mm).
    pub diameter_mm: f64,
    /// Number of teeth Z.
    pub teeth: u32,
    /// Helix angle β (deg).
    pub helix_deg: f64,
    /// Radial runout ρ (µm).
    #[serde(default)]
    pub runout_um: f64,
    /// Angle of the runout θ_ρ (deg).
    #[serde(default)]
    pub runout_phase_deg: f64,
}

impl EndMill {
    /// 003's tool: Ø16 mm carbide, 5 teeth (`003_…txt` §3). Helix 30° (not given: a common helix of
    /// 5-tooth carbide end mills; assumption), no runout.
    pub fn brecher_003() -> Self {
        Self {
            diameter_mm: 16.0,
            teeth: 5,
            helix_deg: 30.0,
            runout_um: 0.0,
            runout_phase_deg: 0.0,
        }
    }

    /// Validate.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `diameter_mm`, `teeth`, `helix_deg` or `runout_um`.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("diameter_mm", self.diameter_mm)?;
        if !(1..=40).contains(&self.teeth) {
            return Err(SimError::InvalidParameter {
                name: "teeth",
                value: self.teeth as f64,
                allowed: "1 ..= 40",
            });
        }
        check_range(
            "helix_deg",
            self.helix_deg,
            0.0,
            60.0,
            "0 <= helix_deg <= 60",
        )?;
        check_range(
            "runout_um",
            self.runout_um,
            0.0,
            100.0,
            "0 <= runout_um <= 100",
        )?;
        check_range(
            "runout_phase_deg",
            self.runout_phase_deg,
            -360.0,
            360.0,
            "-360 ..= 360",
        )?;
        Ok(())
    }

    /// Radius (mm).
    pub fn radius_mm(&self) -> f64 {
        0.5 * self.diameter_mm
    }

    /// Tooth-passing frequency (Hz) at `speed_rpm`.
    pub fn tooth_frequency_hz(&self, speed_rpm: f64) -> f64 {
        speed_rpm / 60.0 * self.teeth as f64
    }

    /// Feed per tooth (mm) at feed velocity `feed_mm_min` and `speed_rpm`.
    ///
    /// ```
    /// use millcomp_sim::kienzle::EndMill;
    /// // 003: 500 mm/min at 1990 rpm with 5 teeth = 0.0503 mm per tooth
    /// let fz = EndMill::brecher_003().feed_per_tooth_mm(500.0, 1990.0);
    /// assert!((fz - 0.050251).abs() < 1e-6);
    /// ```
    pub fn feed_per_tooth_mm(&self, feed_mm_min: f64, speed_rpm: f64) -> f64 {
        feed_mm_min / (speed_rpm * self.teeth as f64)
    }
}

/// The cut at one instant: where the tool is, how much it takes, where the blank is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutState {
    /// Tool centre along the feed (mm).
    pub x_center_mm: f64,
    /// Feed per tooth (mm).
    pub fz_mm: f64,
    /// Axial depth of cut ap (mm).
    pub ap_mm: f64,
    /// Radial depth of cut ae (mm; = D for a full slot).
    pub ae_mm: f64,
    /// Start of the blank along x (mm): the entry.
    pub blank_start_mm: f64,
    /// End of the blank along x (mm): the exit edge.
    pub blank_end_mm: f64,
}

impl CutState {
    /// Steady cutting in the middle of an endless blank.
    pub fn steady(fz_mm: f64, ap_mm: f64, ae_mm: f64) -> Self {
        Self {
            x_center_mm: 0.0,
            fz_mm,
            ap_mm,
            ae_mm,
            blank_start_mm: f64::NEG_INFINITY,
            blank_end_mm: f64::INFINITY,
        }
    }
}

/// The mechanistic milling-force model (module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KienzleMillingModel {
    /// Kienzle coefficients.
    pub coefficients: KienzleCoefficients,
    /// Edge forces (0 in a Kienzle model a user fits).
    #[serde(default)]
    pub edge: EdgeForces,
    /// The tool.
    pub tool: EndMill,
    /// Axial slices of the engaged flute length.
    #[serde(default = "default_slices")]
    pub axial_slices: usize,
}

fn default_slices() -> usize {
    8
}

/// Angles per revolution at which [`KienzleMillingModel::mean_forces`] averages.
pub const MEAN_SAMPLES_PER_REV: usize = 360;

impl KienzleMillingModel {
    /// A pure Kienzle model (no edge forces) of `tool`.
    pub fn new(coefficients: KienzleCoefficients, tool: EndMill) -> Result<Self, SimError> {
        let m = Self {
            coefficients,
            edge: EdgeForces::default(),
            tool,
            axial_slices: default_slices(),
        };
        m.validate()?;
        Ok(m)
    }

    /// Validate.
    ///
    /// # Errors
    /// Those of [`KienzleCoefficients::validate`], [`EndMill::validate`], and `axial_slices` (1..=200),
    /// `kte_n_mm`/`kre_n_mm` (≥ 0).
    pub fn validate(&self) -> Result<(), SimError> {
        self.coefficients.validate()?;
        self.tool.validate()?;
        check_nonneg("kte_n_mm", self.edge.kte_n_mm)?;
        check_nonneg("kre_n_mm", self.edge.kre_n_mm)?;
        if !(1..=200).contains(&self.axial_slices) {
            return Err(SimError::InvalidParameter {
                name: "axial_slices",
                value: self.axial_slices as f64,
                allowed: "1 ..= 200",
            });
        }
        Ok(())
    }

    /// Start of the engagement `φ_st` for radial depth `ae_mm` (down milling, exit at φ = π).
    pub fn entry_angle_rad(&self, ae_mm: f64) -> f64 {
        let r = (1.0 - 2.0 * ae_mm / self.tool.diameter_mm).clamp(-1.0, 1.0);
        PI - r.acos()
    }

    /// Forces on the tool `[Fx, Fy]` (N) at spindle rotation `rot_rad`, and, if `jac` is given, their
    /// derivatives with respect to `[kc1.1, mc, kr1.1, mr]` (2 × 4, row-major).
    pub fn forces_with_jacobian(
        &self,
        rot_rad: f64,
        cut: &CutState,
        mut jac: Option<&mut [[f64; 4]; 2]>,
    ) -> [f64; 2] {
        let c = &self.coefficients;
        let (ec, er) = (1.0 - c.mc, 1.0 - c.mr);
        let mut fx = 0.0;
        let mut fy = 0.0;
        if let Some(j) = jac.as_deref_mut() {
            *j = [[0.0; 4]; 2];
        }
        self.engaged_elements(rot_rad, cut, |_, b, sp, cp, h| {
            // two powers of one chip: one logarithm
            let lh = h.ln();
            let ht = (ec * lh).exp();
            let hr = (er * lh).exp();
            let ft = c.kc11_n_mm2 * b * ht + self.edge.kte_n_mm * b;
            let fr = c.kr11_n_mm2 * b * hr + self.edge.kre_n_mm * b;
            fx += -ft * cp - fr * sp;
            fy += ft * sp - fr * cp;
            if let Some(j) = jac.as_deref_mut() {
                // d ft / d kc11, d ft / d mc; d fr / d kr11, d fr / d mr
                let dft = [b * ht, -c.kc11_n_mm2 * b * ht * lh];
                let dfr = [b * hr, -c.kr11_n_mm2 * b * hr * lh];
                j[0][0] += -dft[0] * cp;
                j[0][1] += -dft[1] * cp;
                j[0][2] += -dfr[0] * sp;
                j[0][3] += -dfr[1] * sp;
                j[1][0] += dft[0] * sp;
                j[1][1] += dft[1] * sp;
                j[1][2] += -dfr[0] * cp;
                j[1][3] += -dfr[1] * cp;
            }
        });
        [fx, fy]
    }

    /// Visit every cutting element that cuts at spindle rotation `rot_rad`: `f(tooth, b, sin φ, cos φ,
    /// h)` with the element's width `b` and its chip `h > 0` (mm) — the geometry of the module doc
    /// (helix lag, engagement `φ_st ≤ φ ≤ π`, the point cut on the blank, the runout's radius step).
    fn engaged_elements(
        &self,
        rot_rad: f64,
        cut: &CutState,
        mut f: impl FnMut(usize, f64, f64, f64, f64),
    ) {
        let t = &self.tool;
        let r = t.radius_mm();
        let z_teeth = t.teeth as usize;
        let pitch = 2.0 * PI / z_teeth as f64;
        let n = self.axial_slices;
        let b = cut.ap_mm / n as f64;
        let lag_per_mm = t.helix_deg.to_radians().tan() / r;
        let phi_st = self.entry_angle_rad(cut.ae_mm);
        let rho = t.runout_um * 1e-3;
        let th_rho = t.runout_phase_deg.to_radians();
        // the slices' angles step back by the helix' lag over a slice: their sine and cosine by a
        // rotation (one sin_cos per tooth), the angle reduced once per tooth (no fmod per element)
        let step = b * lag_per_mm;
        let (sin_step, cos_step) = step.sin_cos();
        for tooth in 0..z_teeth {
            let base = (rot_rad + tooth as f64 * pitch).rem_euclid(2.0 * PI);
            let dr = if rho > 0.0 {
                let rj = rho * (th_rho + tooth as f64 * pitch).cos();
                let rp = rho * (th_rho + (tooth as f64 - 1.0) * pitch).cos();
                rj - rp
            } else {
                0.0
            };
            let phi0 = base - 0.5 * step;
            let (mut sp, mut cp) = phi0.sin_cos();
            for s in 0..n {
                if s > 0 {
                    (sp, cp) = (sp * cos_step - cp * sin_step, cp * cos_step + sp * sin_step);
                }
                let mut phi = phi0 - s as f64 * step;
                if phi < 0.0 {
                    phi = phi.rem_euclid(2.0 * PI);
                }
                if phi < phi_st || phi > PI {
                    continue;
                }
                let x_cut = cut.x_center_mm + r * sp;
                if x_cut < cut.blank_start_mm || x_cut > cut.blank_end_mm {
                    continue;
                }
                let h = cut.fz_mm * sp + dr;
                if h <= 0.0 {
                    continue;
                }
                f(tooth, b, sp, cp, h);
            }
        }
    }

    /// Forces on the tool `[Fx, Fy]` (N) at spindle rotation `rot_rad`.
    pub fn forces(&self, rot_rad: f64, cut: &CutState) -> [f64; 2] {
        self.forces_with_jacobian(rot_rad, cut, None)
    }

    /// Revolution means of `[Fx, Fy]` (N) of `cut` (at its position on the blank), averaged over
    /// `samples` angles of one revolution.
    pub fn mean_forces_at(&self, cut: &CutState, samples: usize) -> [f64; 2] {
        let n = samples.max(1);
        let mut f = [0.0; 2];
        for k in 0..n {
            let fk = self.forces(2.0 * PI * k as f64 / n as f64, cut);
            f[0] += fk[0] / n as f64;
            f[1] += fk[1] / n as f64;
        }
        f
    }

    /// Mean of `[Fx, Fy]` (N) over the instants at which a tooth passes the lower wall (φ = π) at
    /// `height_mm` above the tip — the forces that shape the wall in the static surface-error model
    /// (the wall is generated where the tooth's edge is at the wall; Kline, DeVor & Shareef, J. Eng.
    /// Ind. 104, 1982), averaged over the Z teeth.
    ///
    /// ```
    /// use millcomp_sim::kienzle::{CutState, EndMill, KienzleCoefficients, KienzleMillingModel};
    /// let m = KienzleMillingModel::new(KienzleCoefficients::c45_handbook(), EndMill::brecher_003()).unwrap();
    /// let cut = CutState::steady(0.05, 8.0, 16.0);
    /// let mean = m.mean_forces_at(&cut, 360)[1];
    /// let wall = m.wall_forces_at(&cut, 1.0)[1];
    /// // 5 teeth, 30° helix, 1 mm above the floor: the wall sees a few % less than the mean
    /// assert!(wall < mean && wall > 0.85 * mean, "{wall} {mean}");
    /// ```
    pub fn wall_forces_at(&self, cut: &CutState, height_mm: f64) -> [f64; 2] {
        let t = &self.tool;
        let z = t.teeth as usize;
        let lag = height_mm * t.helix_deg.to_radians().tan() / t.radius_mm();
        let mut f = [0.0; 2];
        for j in 0..z {
            let rot = PI + lag - 2.0 * PI * j as f64 / z as f64;
            let fk = self.forces(rot, cut);
            f[0] += fk[0] / z as f64;
            f[1] += fk[1] / z as f64;
        }
        f
    }

    /// How the orthogonal force at a wall instant depends on each tooth's chip: `∂Fy/∂Δh_i` (N per mm)
    /// at the instant tooth 0 passes the lower wall (φ = π) at `height_mm` above the tip, for an
    /// additive increment `Δh_i` of tooth `i`'s chip thickness (the radius difference a runout gives
    /// it over the tooth before, `h += R_i − R_{i−1}` in [`Self::forces`]), at the model's own runout.
    /// This is the runout's force to first order: `Σ_i ∂Fy/∂Δh_i · Δh_i` — with the cut's engagement,
    /// so it falls where the cutter leaves the blank, tooth by tooth. Elements whose chip is not
    /// positive contribute nothing (as in the force).
    ///
    /// ```
    /// use millcomp_sim::kienzle::{CutState, EndMill, KienzleCoefficients, KienzleMillingModel};
    /// let mut m = KienzleMillingModel::new(KienzleCoefficients::c45_handbook(), EndMill::brecher_003()).unwrap();
    /// m.axial_slices = 32;
    /// let cut = CutState::steady(0.1, 8.0, 16.0);
    /// let g = m.wall_chip_sensitivity_at(&cut, 1.0);
    /// assert_eq!(g.len(), 5);
    /// // a 1 µm thicker chip on every tooth at once: ≈ the force's change from fz to fz + 1 µm at the
    /// // wall instant (there h = fz·sin φ: the change is not exactly that of a 1 µm larger feed)
    /// let total: f64 = g.iter().sum::<f64>() * 1e-3;
    /// assert!(total > 0.0 && total < 0.05 * m.wall_forces_at(&cut, 1.0)[1], "{total}");
    /// ```
    pub fn wall_chip_sensitivity_at(&self, cut: &CutState, height_mm: f64) -> Vec<f64> {
        let t = &self.tool;
        let c = &self.coefficients;
        let rot = PI + height_mm * t.helix_deg.to_radians().tan() / t.radius_mm();
        let mut g = vec![0.0; t.teeth as usize];
        self.engaged_elements(rot, cut, |tooth, b, sp, cp, h| {
            let dft = c.kc11_n_mm2 * b * (1.0 - c.mc) * h.powf(-c.mc);
            let dfr = c.kr11_n_mm2 * b * (1.0 - c.mr) * h.powf(-c.mr);
            g[tooth] += dft * sp - dfr * cp;
        });
        g
    }

    /// Revolution means of `[Fx, Fy]` (N) in steady cutting (an endless blank), averaged over
    /// [`MEAN_SAMPLES_PER_REV`] angles, with their derivatives w.r.t. `[kc1.1, mc, kr1.1, mr]`.
    pub fn mean_forces_with_jacobian(
        &self,
        fz_mm: f64,
        ap_mm: f64,
        ae_mm: f64,
    ) -> ([f64; 2], [[f64; 4]; 2]) {
        let cut = CutState::steady(fz_mm, ap_mm, ae_mm);
        let n = MEAN_SAMPLES_PER_REV;
        let mut f = [0.0; 2];
        let mut jac = [[0.0; 4]; 2];
        let mut j1 = [[0.0; 4]; 2];
        for k in 0..n {
            let rot = 2.0 * PI * k as f64 / n as f64;
            let fk = self.forces_with_jacobian(rot, &cut, Some(&mut j1));
            for i in 0..2 {
                f[i] += fk[i] / n as f64;
                for p in 0..4 {
                    jac[i][p] += j1[i][p] / n as f64;
                }
            }
        }
        (f, jac)
    }

    /// Revolution means of `[Fx, Fy]` (N) in steady cutting.
    ///
    /// ```
    /// use millcomp_sim::kienzle::{EndMill, KienzleCoefficients, KienzleMillingModel};
    /// // a straight-flute linear law (mc = 0) in a full slot: mean Fy = Z·ap·fz·kc/4
    /// let c = KienzleCoefficients { kc11_n_mm2: 2000.0, mc: 0.0, kr11_n_mm2: 800.0, mr: 0.0 };
    /// let tool = EndMill { helix_deg: 0.0, ..EndMill::brecher_003() };
    /// let m = KienzleMillingModel::new(c, tool).unwrap();
    /// let [fx, fy] = m.mean_forces(0.05, 8.0, 16.0);
    /// assert!((fy - 5.0 * 8.0 * 0.05 * 2000.0 / 4.0).abs() < 0.01 * fy);
    /// // and the feed-direction mean is the radial law's: −Z·ap·fz·Kr/4
    /// assert!((fx + 5.0 * 8.0 * 0.05 * 800.0 / 4.0).abs() < 0.01 * fy);
    /// ```
    pub fn mean_forces(&self, fz_mm: f64, ap_mm: f64, ae_mm: f64) -> [f64; 2] {
        self.mean_forces_with_jacobian(fz_mm, ap_mm, ae_mm).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c45() -> KienzleMillingModel {
        KienzleMillingModel::new(KienzleCoefficients::c45_handbook(), EndMill::brecher_003())
            .unwrap()
    }

    #[test]
    fn full_slot_orthogonal_mean_ignores_the_radial_law() {
        // symmetry of the full slot: h(φ) = h(π − φ), cos φ changes sign
        let m = c45();
        let mut m2 = m.clone();
        m2.coefficients.kr11_n_mm2 *= 3.0;
        let a = m.mean_forces(0.05, 8.0, 16.0)[1];
        let b = m2.mean_forces(0.05, 8.0, 16.0)[1];
        assert!((a - b).abs() < 1e-6 * a, "{a} {b}");
    }

    #[test]
    fn jacobian_matches_differences() {
        let mut m = c45();
        m.tool.runout_um = 3.0;
        let (f0, j) = m.mean_forces_with_jacobian(0.06, 8.0, 12.0);
        let p0 = [
            m.coefficients.kc11_n_mm2,
            m.coefficients.mc,
            m.coefficients.kr11_n_mm2,
            m.coefficients.mr,
        ];
        for p in 0..4 {
            let h = 1e-6 * p0[p].abs().max(1e-3);
            let set = |v: f64| {
                let mut mm = m.clone();
                match p {
                    0 => mm.coefficients.kc11_n_mm2 = v,
                    1 => mm.coefficients.mc = v,
                    2 => mm.coefficients.kr11_n_mm2 = v,
                    _ => mm.coefficients.mr = v,
                }
                mm.mean_forces(0.06, 8.0, 12.0)
            };
            let (fp, fm) = (set(p0[p] + h), set(p0[p] - h));
            for i in 0..2 {
                let fd = (fp[i] - fm[i]) / (2.0 * h);
                // central difference, relative step 1e-6: agreement to 1e-5 of the force scale
                let scale = j[i][p].abs() + f0[i].abs() / p0[p].abs().max(1e-3);
                assert!(
                    (fd - j[i][p]).abs() <= 1e-5 * scale,
                    "param {p} force {i}: fd {fd} analytic {}",
                    j[i][p]
                );
            }
        }
    }

    /// A full slot at 0.1 mm per tooth with the tool's centre at `x`, the blank ending at 100 mm.
    fn exit_cut(x: f64) -> CutState {
        CutState {
            x_center_mm: x,
            fz_mm: 0.1,
            ap_mm: 8.0,
            ae_mm: 16.0,
            blank_start_mm: -1e9,
            blank_end_mm: 100.0,
        }
    }

    #[test]
    fn the_wall_chip_sensitivity_is_the_runouts_force_to_first_order() {
        // a small runout changes each tooth's chip by R_i − R_{i−1}; the force at the wall instant
        // changes by Σ ∂Fy/∂Δh_i · Δh_i — in the full slot and one third of the way out of the blank
        let mut m = c45();
        m.axial_slices = 32;
        let pass = PI + 1.0 * m.tool.helix_deg.to_radians().tan() / m.tool.radius_mm();
        for x in [50.0, 94.5] {
            let cut = exit_cut(x);
            let g = m.wall_chip_sensitivity_at(&cut, 1.0);
            let f0 = m.forces(pass, &cut)[1];
            let mut mr = m.clone();
            // 0.2 µm: small against the 100 µm chip, so the change is linear
            (mr.tool.runout_um, mr.tool.runout_phase_deg) = (0.2, 40.0);
            let (rho, th, pitch) = (0.2e-3, 40f64.to_radians(), 2.0 * PI / 5.0);
            let predicted: f64 = (0..5)
                .map(|i| {
                    let i = i as f64;
                    g[i as usize] * rho * ((th + i * pitch).cos() - (th + (i - 1.0) * pitch).cos())
                })
                .sum();
            let got = mr.forces(pass, &cut)[1] - f0;
            assert!(predicted.abs() > 0.05, "{predicted}");
            assert!(
                (got - predicted).abs() < 0.02 * predicted.abs(),
                "x {x}: {got} vs {predicted}"
            );
        }
    }

    #[test]
    fn exit_drops_the_front_first() {
        // 003 §3.3: the cutter leaves first where the largest orthogonal force was made (φ = 90°)
        let m = c45();
        let mean_fy = |x: f64| m.mean_forces_at(&exit_cut(x), 360)[1];
        let full = mean_fy(80.0);
        assert!((mean_fy(92.0) - full).abs() < 1e-9 * full);
        // 1 mm into the exit (centre 7 mm before the edge) more than a third of the force is gone
        assert!(mean_fy(93.0) < 0.67 * full);
        // half-way through it is below 15 %, and nothing is left at the edge
        assert!(mean_fy(96.0) < 0.15 * full);
        assert!(mean_fy(100.0).abs() < 1e-9);
    }
}
