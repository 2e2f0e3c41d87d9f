//! The controllers' models, and the only way to make them: from identified models (`millcomp-models`)
//! and the catalogue (published material, ordered tool). What crosses here was estimated from
//! measurements.
//!
//! Every controller of this crate takes these types — [`IdentifiedSpindle`], [`IdentifiedStiffness`],
//! [`IdentifiedForceModel`] (inside [`crate::predictor::ForcePredictor`]), [`WallModel`] — and none of
//! the simulator's (`PztSpindle`, `TiltedToolStiffness`, `BallEndForceModel`, `ThinWallConfig`). Their
//! fields are private, so a truth plant cannot be wrapped into one: a controller built from the truth
//! does not compile.
//!
//! ```compile_fail
//! // the truth's spindle handed to a controller: PztSpindle is not an IdentifiedSpindle
//! use millcomp_mpc::groove::TunedPidController;
//! use millcomp_mpc::identified::IdentifiedStiffness;
//! use millcomp_models::StiffnessModel;
//! let truth = millcomp_sim::PztSpindle::default();
//! let k = IdentifiedStiffness::new(&StiffnessModel {
//!     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
//! }).unwrap();
//! let program = millcomp_sim::groove::GrooveProgram::thesis(20.0);
//! let _ = TunedPidController::new(&program, &truth, &k, 1000.0, 5e-5);
//! ```
//!
//! ```compile_fail
//! // nor can the truth be wrapped: the field is private
//! let truth = millcomp_sim::PztSpindle::default();
//! let _ = millcomp_mpc::identified::IdentifiedSpindle(truth);
//! ```
//!
//! The same controller from an identified spindle compiles and runs:
//! ```
//! use millcomp_mpc::groove::TunedPidController;
//! use millcomp_mpc::identified::{IdentifiedSpindle, IdentifiedStiffness};
//! use millcomp_models::{SpindleModel, StiffnessModel};
//! let spindle = IdentifiedSpindle::new(&SpindleModel {
//!     gain_um_per_v: 0.05, zeta: 0.46, wn_rad_s: 1302.0, pole_rad_s: Some(37_000.0),
//!     dead_time_s: None, dead_time_pade_order: None, covariance: Default::default(),
//! }).unwrap();
//! let k = IdentifiedStiffness::new(&StiffnessModel {
//!     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
//! }).unwrap();
//! let program = millcomp_sim::groove::GrooveProgram::thesis(20.0);
//! let c = TunedPidController::new(&program, &spindle, &k, 1000.0, 5e-5).unwrap();
//! assert!(c.design().ms <= 1.6 + 1e-9);
//! ```

use millcomp_models::{ForceModelParams, HysteresisModel, SpindleModel, StiffnessModel};
use millcomp_sim::actuator::PrandtlIshlinskii;
use millcomp_sim::force::{BallEndForceModel, ForceParams};
use millcomp_sim::material::Material;
use millcomp_sim::spindle::{DeadTimeModel, PztSpindle};
use millcomp_sim::stiffness::TiltedToolStiffness;
use millcomp_sim::thinwall::{ThinWallConfig, WallGeometry};
use millcomp_sim::tool::BallEndTool;

use crate::error::{MpcError, invalid};

/// The controllers' spindle: an identified PZT-spindle transfer function (the extra pole and dead time
/// when they were fitted, the dead time as a Padé approximant of the recorded order; the fields an
/// identification does not give — voltage range, loop scale — at the physics crate's catalogue
/// defaults).
#[derive(Debug, Clone)]
pub struct IdentifiedSpindle(PztSpindle);

impl IdentifiedSpindle {
    /// From an identified spindle model.
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] (key `spindle_model`) when the physics crate rejects the parameters.
    ///
    /// # Examples
    /// ```
    /// use millcomp_models::{NamedMatrix, SpindleModel};
    /// let m = SpindleModel {
    ///     gain_um_per_v: 0.05, zeta: 0.46, wn_rad_s: 1302.0, pole_rad_s: None, dead_time_s: None,
    ///     dead_time_pade_order: None, covariance: NamedMatrix::default(),
    /// };
    /// let s = millcomp_mpc::identified::IdentifiedSpindle::new(&m).unwrap();
    /// assert_eq!(s.plant().zeta, 0.46);
    /// ```
    pub fn new(m: &SpindleModel) -> Result<Self, MpcError> {
        let mut s = PztSpindle::new(
            m.gain_um_per_v,
            m.zeta,
            m.wn_rad_s,
            m.pole_rad_s,
            m.dead_time_s,
        )
        .map_err(|source| MpcError::IdentifiedModel {
            key: "spindle_model".into(),
            value: format!("{m:?}"),
            source,
        })?;
        s.dead_time_model = match m.dead_time_pade_order {
            Some(1) => DeadTimeModel::Pade1,
            _ => DeadTimeModel::Pade2,
        };
        Ok(Self(s))
    }

    /// The transfer function (read only).
    pub fn plant(&self) -> &PztSpindle {
        &self.0
    }
}

/// The controllers' model of the stack's hysteresis: the identified Prandtl–Ishlinskii operator (volts →
/// tip µm), at rest at 0 V. Made only from an identified [`HysteresisModel`].
#[derive(Debug, Clone)]
pub struct IdentifiedHysteresis(PrandtlIshlinskii);

impl IdentifiedHysteresis {
    /// From an identified hysteresis model.
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] (key `hysteresis_model`) when the operator cannot be inverted (a
    /// first weight ≤ 0, a negative weight, thresholds out of order).
    pub fn new(m: &HysteresisModel) -> Result<Self, MpcError> {
        PrandtlIshlinskii::new(m.thresholds_v.clone(), m.weights_um_per_v.clone(), 0.0)
            .map(Self)
            .map_err(|source| MpcError::IdentifiedModel {
                key: "hysteresis_model".into(),
                value: format!("{m:?}"),
                source,
            })
    }

    /// The operator (read only).
    pub fn operator(&self) -> &PrandtlIshlinskii {
        &self.0
    }
}

/// The inverse of the identified hysteresis in front of the amplifier: a controller designed on the
/// linear spindle model asks for `u` volts; the compensator emits the voltage `v` that, through the
/// identified operator from the state the stack is in, gives the tip the linear model expects,
/// `P[v] = K·u` (`K` the spindle model's static gain). The operator is stepped with the voltage actually
/// emitted (clamped to the amplifier's `0 … v_max`), so its state follows the stack's. A non-finite
/// request holds the last voltage.
///
/// # Examples
/// ```
/// use millcomp_models::{HysteresisModel, NamedMatrix, SpindleModel};
/// use millcomp_mpc::identified::{HysteresisCompensator, IdentifiedHysteresis, IdentifiedSpindle};
/// use millcomp_sim::actuator::PrandtlIshlinskii;
/// // a stack that reads 0.04 µm/V plus 0.01 µm/V behind a 100 V play; the spindle fitted at 0.045 µm/V
/// let h = HysteresisModel { thresholds_v: vec![0.0, 100.0], weights_um_per_v: vec![0.04, 0.01], offset_um: 0.0 };
/// let sp = SpindleModel { gain_um_per_v: 0.045, zeta: 0.46, wn_rad_s: 1302.0, pole_rad_s: None,
///     dead_time_s: None, dead_time_pade_order: None, covariance: NamedMatrix::default() };
/// let (h, sp) = (IdentifiedHysteresis::new(&h).unwrap(), IdentifiedSpindle::new(&sp).unwrap());
/// let mut c = HysteresisCompensator::new(&h, &sp);
/// let mut stack = PrandtlIshlinskii::new(vec![0.0, 100.0], vec![0.04, 0.01], 0.0).unwrap();
/// // up to 600 V-equivalent, back to 300: the stack reads 0.045 µm per requested volt on both branches
/// for u in [600.0, 300.0, 450.0] {
///     let v = c.drive_v(u);
///     assert!((stack.step(v) - 0.045 * u).abs() < 1e-9, "{u} -> {v}");
/// }
/// ```
#[derive(Debug, Clone)]
pub struct HysteresisCompensator {
    model: PrandtlIshlinskii,
    gain_um_per_v: f64,
    v_max: f64,
    last_v: f64,
    /// The inverse's corner list, kept between cycles (no allocation in a cycle).
    corners: Vec<f64>,
    /// The operator at rest, as identified (what a reset returns to).
    initial: PrandtlIshlinskii,
}

impl HysteresisCompensator {
    /// The inverse of `hysteresis` for controllers designed on `spindle` (its static gain and the
    /// amplifier's rated maximum voltage).
    pub fn new(hysteresis: &IdentifiedHysteresis, spindle: &IdentifiedSpindle) -> Self {
        let p = spindle.plant();
        Self {
            model: hysteresis.0.clone(),
            gain_um_per_v: p.gain_um_per_v,
            v_max: p.voltage_max_v,
            last_v: 0.0,
            // two corners a play
            corners: Vec::with_capacity(2 * hysteresis.0.thresholds_v().len()),
            initial: hysteresis.0.clone(),
        }
    }

    /// Back to the stack at rest at 0 V (the operator as identified).
    pub fn reset(&mut self) {
        self.model.clone_from(&self.initial);
        self.last_v = 0.0;
    }

    /// The voltage to emit for a request of `u_v` volts of the linear model.
    pub fn drive_v(&mut self, u_v: f64) -> f64 {
        if !u_v.is_finite() {
            return self.last_v;
        }
        let v = self
            .model
            .input_for_with(self.gain_um_per_v * u_v, &mut self.corners)
            .clamp(0.0, self.v_max);
        self.model.step(v);
        self.last_v = v;
        v
    }

    /// The stack was raised to `bias_v` (a touch-off at a bias): the model follows, and the request in
    /// linear-model volts that holds it there is returned (its tip over the static gain).
    pub fn hold_at(&mut self, bias_v: f64) -> f64 {
        let v = if bias_v.is_finite() {
            bias_v.clamp(0.0, self.v_max)
        } else {
            self.last_v
        };
        let tip = self.model.step(v);
        self.last_v = v;
        tip / self.gain_um_per_v
    }
}

/// The controllers' tool/spindle stiffness: identified axial and radial stiffness (a load–deflection
/// calibration), possibly scaled for a what-if study.
#[derive(Debug, Clone, Copy)]
pub struct IdentifiedStiffness(TiltedToolStiffness);

impl IdentifiedStiffness {
    /// From an identified stiffness model.
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] (key `stiffness`) for a non-positive or non-finite stiffness.
    ///
    /// # Examples
    /// ```
    /// use millcomp_models::StiffnessModel;
    /// use millcomp_mpc::identified::IdentifiedStiffness;
    /// let k = IdentifiedStiffness::new(&StiffnessModel {
    ///     axial_n_per_um: 1.22, radial_n_per_um: 0.114, covariance: Default::default(),
    /// }).unwrap();
    /// // 10 % stiffer for a sensitivity study
    /// let k2 = k.scaled(1.1).unwrap();
    /// assert!((k2.stiffness().radial_n_per_um - 0.1254).abs() < 1e-12);
    /// ```
    pub fn new(m: &StiffnessModel) -> Result<Self, MpcError> {
        Self::from_values(m.axial_n_per_um, m.radial_n_per_um)
    }

    fn from_values(axial: f64, radial: f64) -> Result<Self, MpcError> {
        TiltedToolStiffness::new(axial, radial)
            .map(Self)
            .map_err(|source| MpcError::IdentifiedModel {
                key: "stiffness".into(),
                value: format!("axial {axial} N/um, radial {radial} N/um"),
                source,
            })
    }

    /// Both stiffnesses times `factor` (a deliberate model error for a sensitivity study).
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] when the product is not a positive stiffness.
    pub fn scaled(&self, factor: f64) -> Result<Self, MpcError> {
        Self::from_values(
            self.0.axial_n_per_um * factor,
            self.0.radial_n_per_um * factor,
        )
    }

    /// The stiffness (read only).
    pub fn stiffness(&self) -> &TiltedToolStiffness {
        &self.0
    }
}

/// The catalogue: what a user knows before any measurement — the published material by name and the
/// tool as ordered (ball radius, flutes) with the runout and wearland a toolmaker states or a microscope
/// shows. The starting point of every force model the controllers use.
#[derive(Debug, Clone, PartialEq)]
pub struct NominalTool {
    /// Material name (published properties, `millcomp_sim::material::Material::by_name`).
    pub material: String,
    /// Ball radius (µm).
    pub radius_um: f64,
    /// Wearland (µm) before the force fit.
    pub wearland_um: f64,
    /// Runout (µm).
    pub runout_um: f64,
    /// Number of flutes.
    pub flutes: u32,
}

impl NominalTool {
    /// The thesis' tool as ordered: Ø0.8 mm two-flute ball end (radius 400 µm), runout 10 µm as measured
    /// (`000_…txt` §6.2), wearland 5 µm as the starting value (the measured grooves of Fig. 7-9).
    pub fn thesis_ball_end(material: &str) -> Self {
        Self {
            material: material.to_string(),
            radius_um: 400.0,
            wearland_um: 5.0,
            runout_um: 10.0,
            flutes: 2,
        }
    }

    /// The nominal force model: published material, this tool, force scale 1.
    ///
    /// # Errors
    /// [`MpcError::Sim`] for an unknown material or an invalid tool.
    pub fn force_model(&self) -> Result<BallEndForceModel, MpcError> {
        let mut tool = BallEndTool::new(self.radius_um, self.wearland_um, self.runout_um)?;
        tool.flutes = self.flutes;
        Ok(BallEndForceModel::new(
            Material::by_name(&self.material)?,
            tool,
            ForceParams::default(),
        )?)
    }
}

/// The controllers' force model: the nominal model ([`NominalTool::force_model`]) with the identified
/// parameters substituted (W, rake and flank friction, wearland, runout — whichever were fitted).
#[derive(Debug, Clone)]
pub struct IdentifiedForceModel(BallEndForceModel);

impl IdentifiedForceModel {
    /// From identified parameters on the nominal tool.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] (key `force_model.<name>`) for a parameter the force model does not
    /// have, [`MpcError::IdentifiedModel`] (key `force_model`) for values it rejects, [`MpcError::Sim`]
    /// for a bad nominal tool.
    ///
    /// # Examples
    /// ```
    /// use millcomp_models::ForceModelParams;
    /// use millcomp_mpc::identified::{IdentifiedForceModel, NominalTool};
    /// let p = ForceModelParams {
    ///     fitted: [("w_mpa".to_string(), 3000.0), ("wearland_um".to_string(), 7.5)].into(),
    ///     fixed: Default::default(),
    ///     covariance: Default::default(),
    /// };
    /// let m = IdentifiedForceModel::new(&p, &NominalTool::thesis_ball_end("S7")).unwrap();
    /// assert_eq!(m.model().material.w_mpa, 3000.0);
    /// assert_eq!(m.model().tool.wearland_um, 7.5);
    /// assert_eq!(m.model().tool.runout_um, 10.0); // the catalogue's, not fitted
    /// ```
    pub fn new(p: &ForceModelParams, nominal: &NominalTool) -> Result<Self, MpcError> {
        let mut m = nominal.force_model()?;
        for (name, v) in &p.fitted {
            m = with_force_param(&m, name, *v)?;
        }
        Ok(Self(m))
    }

    /// This model with parameters multiplied by `1 + ε` (a deliberate model error for a robustness
    /// study), `rel` as `(name, ε)` with names of [`ForceModelParams::PARAMETERS`].
    ///
    /// # Errors
    /// As [`IdentifiedForceModel::new`].
    pub fn perturbed(&self, rel: &[(&str, f64)]) -> Result<Self, MpcError> {
        let mut m = self.0.clone();
        for (name, e) in rel {
            let v = m.param(name).ok_or_else(|| unknown_force_param(name, *e))?;
            m = with_force_param(&m, name, v * (1.0 + e))?;
        }
        Ok(Self(m))
    }

    /// This model with every force multiplied by `factor` (its force scale times `factor`): the scale a
    /// run-to-run identification measured on cut parts.
    ///
    /// # Errors
    /// [`MpcError::IdentifiedModel`] (key `force_model`) for a factor that is not finite and > 0.
    ///
    /// # Examples
    /// ```
    /// use millcomp_models::ForceModelParams;
    /// use millcomp_mpc::identified::{IdentifiedForceModel, NominalTool};
    /// use millcomp_sim::force::CutConditions;
    /// let p = ForceModelParams {
    ///     fitted: Default::default(), fixed: Default::default(), covariance: Default::default(),
    /// };
    /// let m = IdentifiedForceModel::new(&p, &NominalTool::thesis_ball_end("S7")).unwrap();
    /// let c = CutConditions::new(40.0, 10.0, 10_000.0, 30.0).unwrap();
    /// let f = m.model().peak_z_force_n(&c).unwrap();
    /// let g = m.rescaled(1.1).unwrap().model().peak_z_force_n(&c).unwrap();
    /// assert!((g / f - 1.1).abs() < 1e-12);
    /// assert!(m.rescaled(0.0).is_err());
    /// ```
    pub fn rescaled(&self, factor: f64) -> Result<Self, MpcError> {
        let s = self.0.params.force_scale * factor;
        self.0
            .with_param("force_scale", s)
            .map(Self)
            .map_err(|source| MpcError::IdentifiedModel {
                key: "force_model".into(),
                value: format!("force_scale = {s}"),
                source,
            })
    }

    /// The model (read only).
    pub fn model(&self) -> &BallEndForceModel {
        &self.0
    }
}

fn unknown_force_param(name: &str, v: f64) -> MpcError {
    invalid(
        format!("force_model.{name}"),
        v,
        format!(
            "a force-model parameter ({})",
            ForceModelParams::PARAMETERS.join(", ")
        ),
    )
}

/// `m` with the identified parameter `name` (one of [`ForceModelParams::PARAMETERS`]) set to `v`.
fn with_force_param(
    m: &BallEndForceModel,
    name: &str,
    v: f64,
) -> Result<BallEndForceModel, MpcError> {
    if !ForceModelParams::PARAMETERS.contains(&name) {
        return Err(unknown_force_param(name, v));
    }
    m.with_param(name, v)
        .map_err(|source| MpcError::IdentifiedModel {
            key: "force_model".into(),
            value: format!("{name} = {v}"),
            source,
        })
}

/// The controllers' model of a thin wall: the programmed geometry, the published material and force
/// coefficients of `004_…txt` (Table 4: H59 brass, E = 100 GPa) — each possibly scaled for a what-if
/// study — and the identified tool stiffness; exact stage, no noise (a digital twin for planning).
#[derive(Debug, Clone)]
pub struct WallModel(ThinWallConfig);

impl WallModel {
    /// The published wall of `004_…txt` with the program's geometry and the identified tool stiffness
    /// (N/µm, e.g. a load–deflection calibration).
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a geometry or stiffness the wall model rejects.
    ///
    /// # Examples
    /// ```
    /// use millcomp_mpc::identified::WallModel;
    /// use millcomp_sim::thinwall::WallGeometry;
    /// let program = WallGeometry {
    ///     nominal_thickness_um: 100.0, height_um: 800.0, length_um: 5000.0, ae_um: 50.0, ap_um: 200.0,
    ///     fz_um: 1.6,
    /// };
    /// let m = WallModel::published_004(&program, 0.2).unwrap();
    /// assert_eq!(m.config().e_gpa, 100.0);
    /// assert_eq!(m.config().tool_stiffness_n_per_um, 0.2);
    /// ```
    pub fn published_004(
        program: &WallGeometry,
        tool_stiffness_n_per_um: f64,
    ) -> Result<Self, MpcError> {
        let mut c = ThinWallConfig::paper(program.nominal_thickness_um)?.with_geometry(program)?;
        c.tool_stiffness_n_per_um = tool_stiffness_n_per_um;
        c.force_noise = None;
        c.stage.accuracy_seed = None;
        c.validate()?;
        Ok(Self(c))
    }

    /// This model with Young's modulus and the radial force coefficient times the given factors (a
    /// deliberate model error for a sensitivity study).
    ///
    /// # Errors
    /// [`MpcError::Sim`] for a product the wall model rejects.
    pub fn scaled(&self, e_factor: f64, force_factor: f64) -> Result<Self, MpcError> {
        let mut c = self.0.clone();
        c.e_gpa *= e_factor;
        c.kr_n_per_mm2 *= force_factor;
        c.validate()?;
        Ok(Self(c))
    }

    /// The configuration of the digital twin (read only).
    pub fn config(&self) -> &ThinWallConfig {
        &self.0
    }
}
