//! The controllers' model equations built from identified models (`millcomp-models`): an identified
//! spindle as sim's PZT-spindle transfer function, identified force-model parameters substituted into the
//! ball-end force model's equations. What crosses here was estimated from measurements.

use millcomp_models::{ForceModelParams, SpindleModel};
use millcomp_sim::force::BallEndForceModel;
use millcomp_sim::spindle::{DeadTimeModel, PztSpindle};

use crate::error::{MpcError, invalid};

/// The identified spindle as the physics crate's transfer function (the extra pole and dead time when they
/// were fitted, the dead time as a Padé approximant of the recorded order; the other fields — voltage range,
/// loop gain — at the physics crate's defaults).
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
/// let s = millcomp_mpc::identified::spindle_plant(&m).unwrap();
/// assert_eq!(s.zeta, 0.46);
/// ```
pub fn spindle_plant(m: &SpindleModel) -> Result<PztSpindle, MpcError> {
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
    Ok(s)
}

/// `base` with the identified force-model parameters substituted (W, rake and flank friction, wearland,
/// runout — whichever were fitted).
///
/// # Errors
/// [`MpcError::InvalidConfig`] (key `force_model.<name>`) for a parameter the force model does not have,
/// [`MpcError::IdentifiedModel`] (key `force_model`) for values it rejects.
pub fn force_model_with(
    p: &ForceModelParams,
    base: &BallEndForceModel,
) -> Result<BallEndForceModel, MpcError> {
    let mut m = base.clone();
    for (name, v) in &p.fitted {
        match name.as_str() {
            "w_mpa" => m.material.w_mpa = *v,
            "mu_rake" => m.material.mu_rake = *v,
            "mu_flank" => m.material.mu_flank = *v,
            "wearland_um" => m.tool.wearland_um = *v,
            "runout_um" => m.tool.runout_um = *v,
            other => {
                return Err(invalid(
                    format!("force_model.{other}"),
                    v,
                    format!(
                        "a force-model parameter ({})",
                        ForceModelParams::PARAMETERS.join(", ")
                    ),
                ));
            }
        }
    }
    m.validate().map_err(|source| MpcError::IdentifiedModel {
        key: "force_model".into(),
        value: format!("{:?}", p.fitted),
        source,
    })?;
    Ok(m)
}
