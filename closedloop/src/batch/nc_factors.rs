//! Batch rows with `stage = nc_axis`: the published NC scenario with the row's factors.

use super::spec::{ScenarioSpec, bad, num};
use crate::error::{ClosedLoopError, invalid};
use crate::scenario::Scenario;

/// The published NC scenario batch rows with `stage = nc_axis` start from (`003_…txt` Fig. 5).
pub const NC_BASE_SCENARIO_TOML: &str =
    include_str!("../../../datasets/scenarios/nc_c45_feed_step.toml");
/// File name of [`NC_BASE_SCENARIO_TOML`].
pub const NC_BASE_SCENARIO_FILE: &str = "datasets/scenarios/nc_c45_feed_step.toml";
/// Batch factors only the NC stage has.
pub const NC_ONLY_FACTORS: &[&str] = &[
    "feed_ratio",
    "ae_mm",
    "machine_stiffness_n_per_um",
    "overhang_d",
    "kienzle_error_pct",
];
/// Batch factors the NC stage takes (besides `stage`).
const NC_FACTORS: &[&str] = &[
    "feed_ratio",
    "ae_mm",
    "machine_stiffness_n_per_um",
    "overhang_d",
    "kienzle_error_pct",
    "stiffness_error_pct",
    "noise_scale",
    "seed",
];

/// A batch row with `stage = nc_axis`: the published NC scenario with the row's factors
/// (`feed_ratio`, `ae_mm`, `machine_stiffness_n_per_um`, `overhang_d`, `kienzle_error_pct`,
/// `stiffness_error_pct`, `noise_scale`, `seed`).
///
/// ```
/// use millcomp_closedloop::batch::factors::{FactorValue, ScenarioSpec, build_scenario};
/// let spec = ScenarioSpec {
///     index: 2,
///     factors: [
///         ("stage".to_string(), FactorValue::Text("nc_axis".into())),
///         ("feed_ratio".to_string(), FactorValue::Num(1.5)),
///         ("stiffness_error_pct".to_string(), FactorValue::Num(-10.0)),
///     ].into_iter().collect(),
/// };
/// let s = build_scenario(&spec).unwrap();
/// let nc = s.nc_axis.unwrap();
/// // 003's 500 mm/min stepped to 1.5 × 500 at 90 mm
/// assert_eq!(nc.program.feed_changes[0].feed_mm_min, 750.0);
/// assert!((nc.truth.stiffness_error + 0.1).abs() < 1e-15);
/// ```
///
/// # Errors
/// [`ClosedLoopError::InvalidFactor`] naming a factor the NC stage does not take or a value it cannot
/// take; the scenario's validation errors naming the key (a feed above the axis' maximum, …).
pub fn build_nc_scenario(spec: &ScenarioSpec) -> Result<Scenario, ClosedLoopError> {
    for name in spec.factors.keys() {
        if name != "stage" && !NC_FACTORS.contains(&name.as_str()) {
            return Err(bad(
                name,
                format!(
                    "does not apply to stage = nc_axis (its factors: {})",
                    NC_FACTORS.join(", ")
                ),
            ));
        }
    }
    let mut s = Scenario::from_toml_str(NC_BASE_SCENARIO_TOML, NC_BASE_SCENARIO_FILE)?;
    s.name = format!("batch_{:04}", spec.index);
    s.controllers.clear();
    let nc = s
        .nc_axis
        .as_mut()
        .ok_or_else(|| invalid("nc_axis", "missing", "the NC base scenario's [nc_axis]"))?;
    if let Some(v) = num(spec, "feed_ratio")? {
        if v <= 0.0 {
            return Err(bad("feed_ratio", format!("{v} is not > 0")));
        }
        let f0 = nc.program.feed_mm_min;
        for c in &mut nc.program.feed_changes {
            c.feed_mm_min = f0 * v;
        }
    }
    if let Some(v) = num(spec, "ae_mm")? {
        nc.program.ae_mm = v;
    }
    if let Some(v) = num(spec, "machine_stiffness_n_per_um")? {
        nc.machine.machine_stiffness_n_per_um = v;
    }
    if let Some(v) = num(spec, "overhang_d")? {
        nc.machine.overhang_d = v;
    }
    if let Some(v) = num(spec, "kienzle_error_pct")? {
        nc.truth.kienzle_error = v / 100.0;
    }
    if let Some(v) = num(spec, "stiffness_error_pct")? {
        nc.truth.stiffness_error = v / 100.0;
    }
    if let Some(v) = num(spec, "noise_scale")? {
        if v < 0.0 {
            return Err(bad(
                "noise_scale",
                format!("{v} is negative (allowed >= 0)"),
            ));
        }
        nc.truth.platform_noise_n *= v;
    }
    if let Some(v) = num(spec, "seed")? {
        if v < 0.0 || v.fract() != 0.0 {
            return Err(bad("seed", format!("{v} is not a non-negative integer")));
        }
        s.seed = v as u64;
    }
    s.validate()?;
    Ok(s)
}
