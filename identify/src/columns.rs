//! One entry point for the CLI: `millcomp identify <what> FILE` reads the CSV into named columns
//! and calls [`identify_columns`], which picks the target's columns by their contract names,
//! reports missing ones by name and notes the ignored ones.
//!
//! | target        | required columns                     | optional columns                         |
//! |-------------|--------------------------------------|------------------------------------------|
//! | `spindle`   | `t_s, u_v, y_um`                     |                                          |
//! | `stiffness` | `load_n, deflection_um`              | `direction` (text)                       |
//! | `thermal`   | `t_s, drift_um`                      | `speed_rpm`, `temp_c`                    |
//! | `force`     | `depth_um, upfeed_um` and any of `max_fx_n, max_fy_n, max_fz_n` (peaks) or `rot_deg` with any of `fx_n, fy_n, fz_n` (traces) | `speed_rpm`, `tilt_deg` |
//! | `wall`      | `force_n, deflection_um`             |                                          |
//! | `part`      | `part, deflection_um` and one of `planned_deflection_um` (→ ρ) or `force_peak_n` (→ c) |      |
//! | `kienzle`   | `fz_mm, ap_mm, ae_mm` and any of `mean_fx_n, mean_fy_n` | `diameter_mm, teeth, helix_deg` (constant; 003's tool otherwise) |
//! | `feed-axis` | `t_s, reference_um, position_um`     |                                          |
//! | `hysteresis`| `u_v, y_um` (a quasi-static sweep)   |                                          |

use std::collections::{BTreeMap, BTreeSet};
use std::str::FromStr;

use crate::error::{IdentifyError, Result};
use crate::nonlinear::NlsOptions;
use crate::targets::Identified;
use crate::targets::feed_axis::{FeedAxisData, FeedAxisOptions, identify_feed_axis};
use crate::targets::force::{
    ForceConditions, ForceData, ForceOptions, ForceParam, ForceTraceData, PeakForceData,
    identify_force,
};
use crate::targets::hysteresis::{HysteresisData, HysteresisOptions, identify_hysteresis};
use crate::targets::kienzle::{KienzleData, KienzleOptions, identify_kienzle};
use crate::targets::part::{PartData, PartRegressor, identify_part};
use crate::targets::spindle::{SpindleData, SpindleOptions, identify_spindle};
use crate::targets::stiffness::{StiffnessData, StiffnessOptions, identify_stiffness};
use crate::targets::thermal::{CommonOptions, ThermalData, ThermalModel, identify_thermal};
use crate::targets::wall::{WallData, WallGeometry, WallOptions, identify_wall};

/// What to identify (`millcomp identify <what>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// PZT spindle plant from a step response.
    Spindle,
    /// Static stiffness from load–deflection data.
    Stiffness,
    /// Force-model material/friction parameters.
    Force,
    /// Thermal drift model.
    Thermal,
    /// Thin-wall effective stiffness.
    Wall,
    /// What measured parts say of the deflection model (`targets::part`).
    Part,
    /// Kienzle's coefficients of a flat end mill from mean forces (`targets::kienzle`).
    Kienzle,
    /// Dead time and lag of an NC feed axis from a servo trace (`targets::feed_axis`).
    FeedAxis,
    /// The PZT stack's hysteresis from a quasi-static sweep in air (`targets::hysteresis`).
    Hysteresis,
}

impl Target {
    /// The name `millcomp identify` takes.
    pub fn name(self) -> &'static str {
        match self {
            Target::Spindle => "spindle",
            Target::Stiffness => "stiffness",
            Target::Force => "force",
            Target::Thermal => "thermal",
            Target::Wall => "wall",
            Target::Part => "part",
            Target::Kienzle => "kienzle",
            Target::FeedAxis => "feed-axis",
            Target::Hysteresis => "hysteresis",
        }
    }
}

impl FromStr for Target {
    type Err = IdentifyError;
    /// Parses `spindle`, `stiffness`, `force`, `thermal`, `wall`, `part`, `kienzle`, `feed-axis` or
    /// `hysteresis`.
    ///
    /// # Errors
    /// [`IdentifyError::UnknownTarget`] for any other name.
    fn from_str(s: &str) -> Result<Self> {
        Ok(match s {
            "spindle" => Target::Spindle,
            "stiffness" => Target::Stiffness,
            "force" => Target::Force,
            "thermal" => Target::Thermal,
            "wall" => Target::Wall,
            "part" => Target::Part,
            "kienzle" => Target::Kienzle,
            "feed-axis" => Target::FeedAxis,
            "hysteresis" => Target::Hysteresis,
            _ => {
                return Err(IdentifyError::UnknownTarget { name: s.into() });
            }
        })
    }
}

/// Named data columns (numeric and text).
#[derive(Debug, Clone, Default)]
pub struct Columns {
    numeric: BTreeMap<String, Vec<f64>>,
    text: BTreeMap<String, Vec<String>>,
}

impl Columns {
    /// Empty set of columns.
    pub fn new() -> Self {
        Self::default()
    }
    /// Adds (or replaces) a numeric column.
    pub fn insert(&mut self, name: &str, values: Vec<f64>) -> &mut Self {
        self.numeric.insert(name.to_string(), values);
        self
    }
    /// Adds (or replaces) a text column.
    pub fn insert_text(&mut self, name: &str, values: Vec<String>) -> &mut Self {
        self.text.insert(name.to_string(), values);
        self
    }
    /// The numeric column `name`.
    pub fn numeric(&self, name: &str) -> Option<&[f64]> {
        self.numeric.get(name).map(Vec::as_slice)
    }
    /// The text column `name`.
    pub fn text(&self, name: &str) -> Option<&[String]> {
        self.text.get(name).map(Vec::as_slice)
    }
    /// Removes column `name` (numeric or text).
    pub fn remove(&mut self, name: &str) -> &mut Self {
        self.numeric.remove(name);
        self.text.remove(name);
        self
    }
    /// The rows `rows` of every column (e.g. one unit's, [`crate::units::split_units`]).
    ///
    /// # Panics
    /// When a row is out of range of a column.
    pub fn rows(&self, rows: &[usize]) -> Columns {
        Columns {
            numeric: self
                .numeric
                .iter()
                .map(|(k, v)| (k.clone(), rows.iter().map(|&i| v[i]).collect()))
                .collect(),
            text: self
                .text
                .iter()
                .map(|(k, v)| (k.clone(), rows.iter().map(|&i| v[i].clone()).collect()))
                .collect(),
        }
    }
    /// Rows of the longest column (columns of one table all have the same).
    pub fn n_rows(&self) -> usize {
        self.numeric
            .values()
            .map(Vec::len)
            .chain(self.text.values().map(Vec::len))
            .max()
            .unwrap_or(0)
    }
    fn names(&self) -> BTreeSet<String> {
        self.numeric
            .keys()
            .chain(self.text.keys())
            .cloned()
            .collect()
    }
}

/// Options of all targets (each target uses its own).
#[derive(Debug, Clone, Default)]
pub struct IdentifyOptions {
    /// Nonlinear solver options.
    pub nls: NlsOptions,
    /// Thermal model (default exponential).
    pub thermal_model: ThermalModel,
    /// Spindle: fit the extra real pole.
    pub spindle_extra_pole: bool,
    /// Spindle: fit a dead time.
    pub spindle_dead_time: bool,
    /// Stiffness: tilts (deg) at which to derive the tilted-tool z-stiffness.
    pub tilt_deg: Vec<f64>,
    /// Stiffness: known machine stiffness (N/µm) for the series combination.
    pub machine_stiffness_n_per_um: Option<f64>,
    /// Force: parameters to fit (empty: W only).
    pub force_free: Vec<ForceParam>,
    /// Force: material name for the fixed parameters (the physics crate's `Material::by_name`;
    /// default 6061).
    pub material: Option<String>,
    /// Force: weight by 1/F² (relative errors).
    pub relative_errors: bool,
    /// Wall: geometry for the derived modulus.
    pub wall_geometry: Option<WallGeometry>,
}

struct Picker<'a> {
    cols: &'a Columns,
    used: BTreeSet<String>,
    target: &'static str,
    /// The first optional column asked for as numbers but present as text.
    bad: Option<IdentifyError>,
}

impl<'a> Picker<'a> {
    fn req(&mut self, name: &str) -> Result<&'a [f64]> {
        self.not_text(name)?;
        self.opt(name).ok_or_else(|| IdentifyError::MissingColumn {
            column: name.into(),
            reason: format!("required by `identify {}`", self.target),
        })
    }
    /// A column present as text where numbers are needed is not missing: its first cell that is not a
    /// finite number is named.
    fn not_text(&self, name: &str) -> Result<()> {
        let Some(cells) = self.cols.text.get(name) else {
            return Ok(());
        };
        let bad = cells
            .iter()
            .position(|c| c.trim().parse::<f64>().map_or(true, |x| !x.is_finite()))
            .unwrap_or(0);
        Err(IdentifyError::NotANumber {
            column: name.into(),
            row: bad + 1,
            value: cells.get(bad).cloned().unwrap_or_default(),
            reason: format!("needed by `identify {}`", self.target),
        })
    }
    fn opt(&mut self, name: &str) -> Option<&'a [f64]> {
        if let Err(e) = self.not_text(name) {
            self.bad.get_or_insert(e);
        }
        let v = self.cols.numeric.get(name)?;
        self.used.insert(name.to_string());
        Some(v.as_slice())
    }
    fn text(&mut self, name: &str) -> Option<&'a [String]> {
        let v = self.cols.text.get(name)?;
        self.used.insert(name.to_string());
        Some(v.as_slice())
    }
    /// An optional column that was present as text where numbers are needed.
    fn ok(&mut self) -> Result<()> {
        self.bad.take().map_or(Ok(()), Err)
    }
    fn notes(&self) -> Vec<String> {
        self.cols
            .names()
            .difference(&self.used)
            .map(|c| {
                format!(
                    "column `{c}` is not used by `identify {}` and was ignored",
                    self.target
                )
            })
            .collect()
    }
}

/// Runs target `target` on named columns (see the module table for the names). Columns the target
/// does not read are listed in [`Identified::notes`].
///
/// # Errors
/// [`IdentifyError::MissingColumn`] naming a required column that is absent;
/// [`IdentifyError::Physics`] when `opts.material` is not a material sim knows (force target);
/// otherwise the errors of the target's function ([`identify_spindle`], [`identify_stiffness`],
/// [`identify_force`], [`identify_thermal`], [`identify_wall`]).
///
/// # Examples
/// ```
/// use millcomp_identify::{Columns, IdentifyError, IdentifyOptions, Target, identify_columns};
/// let mut cols = Columns::new();
/// cols.insert("load_n", (1..=10).map(|i| i as f64).collect());
/// cols.insert("deflection_um", (1..=10).map(|i| i as f64 / 0.114 + if i % 2 == 0 { 0.01 } else { -0.01 }).collect());
/// cols.insert("temp_c", vec![20.0; 10]);
/// let target: Target = "stiffness".parse().unwrap();
/// let fit = identify_columns(target, &cols, &IdentifyOptions::default()).unwrap();
/// assert!((fit.report.param("stiffness_n_per_um") - 0.114).abs() < 1e-4);
/// assert_eq!(fit.notes, vec!["column `temp_c` is not used by `identify stiffness` and was ignored"]);
/// // the wall target reads `force_n`, which these columns do not have
/// let e = identify_columns(Target::Wall, &cols, &IdentifyOptions::default()).unwrap_err();
/// assert!(matches!(&e, IdentifyError::MissingColumn { column, .. } if column == "force_n"));
/// ```
pub fn identify_columns(
    target: Target,
    cols: &Columns,
    opts: &IdentifyOptions,
) -> Result<Identified> {
    let common = CommonOptions { nls: opts.nls };
    let name = target.name();
    let mut p = Picker {
        cols,
        used: BTreeSet::new(),
        target: name,
        bad: None,
    };
    let mut out = match target {
        Target::Spindle => {
            let d = SpindleData {
                t_s: p.req("t_s")?,
                u_v: p.req("u_v")?,
                y_um: p.req("y_um")?,
            };
            let o = SpindleOptions {
                common,
                extra_pole: opts.spindle_extra_pole,
                dead_time: opts.spindle_dead_time,
                ..Default::default()
            };
            p.ok()?;
            identify_spindle(&d, &o)?
        }
        Target::Hysteresis => {
            let d = HysteresisData {
                u_v: p.req("u_v")?,
                y_um: p.req("y_um")?,
            };
            p.ok()?;
            identify_hysteresis(&d, &HysteresisOptions::default())?
        }
        Target::Stiffness => {
            let d = StiffnessData {
                load_n: p.req("load_n")?,
                deflection_um: p.req("deflection_um")?,
                direction: p.text("direction"),
            };
            let o = StiffnessOptions {
                common,
                tilt_deg: opts.tilt_deg.clone(),
                machine_stiffness_n_per_um: opts.machine_stiffness_n_per_um,
            };
            p.ok()?;
            identify_stiffness(&d, &o)?
        }
        Target::Thermal => {
            let d = ThermalData {
                t_s: p.req("t_s")?,
                drift_um: p.req("drift_um")?,
                speed_rpm: p.opt("speed_rpm"),
                temp_c: p.opt("temp_c"),
            };
            p.ok()?;
            identify_thermal(&d, opts.thermal_model, &common)?
        }
        Target::Wall => {
            let d = WallData {
                force_n: p.req("force_n")?,
                deflection_um: p.req("deflection_um")?,
            };
            let o = WallOptions {
                common,
                geometry: opts.wall_geometry,
            };
            p.ok()?;
            identify_wall(&d, &o)?
        }
        Target::Part => {
            let part = p.req("part")?;
            let parts = part
                .iter()
                .enumerate()
                .map(|(row, v)| {
                    if v.is_finite() && *v >= 0.0 && v.fract() == 0.0 {
                        Ok(*v as usize)
                    } else {
                        Err(IdentifyError::InvalidParameter {
                            name: format!("part[{row}]"),
                            value: *v,
                            allowed: "a part number (an integer ≥ 0)",
                        })
                    }
                })
                .collect::<Result<Vec<usize>>>()?;
            let deflection_um = p.req("deflection_um")?;
            let (what, regressor) = match (p.opt("planned_deflection_um"), p.opt("force_peak_n")) {
                (Some(r), None) => (PartRegressor::PlannedDeflection, r),
                (None, Some(r)) => (PartRegressor::MeasuredForce, r),
                (Some(_), Some(_)) => {
                    return Err(IdentifyError::MissingColumn {
                        column: "planned_deflection_um or force_peak_n".into(),
                        reason:
                            "`identify part` fits one of them: give a file with one (ρ from the \
                                 planned deflection, c from the measured force peak)"
                                .into(),
                    });
                }
                (None, None) => {
                    return Err(IdentifyError::MissingColumn {
                        column: "planned_deflection_um or force_peak_n".into(),
                        reason: "required by `identify part`".into(),
                    });
                }
            };
            p.ok()?;
            identify_part(
                &PartData {
                    part: &parts,
                    deflection_um,
                    regressor,
                },
                what,
            )?
        }
        Target::Kienzle => {
            let d = KienzleData {
                fz_mm: p.req("fz_mm")?,
                ap_mm: p.req("ap_mm")?,
                ae_mm: p.req("ae_mm")?,
                mean_fx_n: p.opt("mean_fx_n"),
                mean_fy_n: p.opt("mean_fy_n"),
            };
            let mut o = KienzleOptions {
                common,
                ..Default::default()
            };
            let constant = |name: &str, col: Option<&[f64]>| -> Result<Option<f64>> {
                let Some(c) = col else { return Ok(None) };
                match c.iter().position(|v| *v != c[0] || !v.is_finite()) {
                    Some(i) => Err(IdentifyError::InvalidParameter {
                        name: format!("{name} (row {})", i + 1),
                        value: c[i],
                        allowed: "one tool per file: the same finite value in every row",
                    }),
                    None => Ok(c.first().copied()),
                }
            };
            if let Some(v) = constant("diameter_mm", p.opt("diameter_mm"))? {
                o.tool.diameter_mm = v;
            }
            if let Some(v) = constant("teeth", p.opt("teeth"))? {
                if !(v >= 1.0 && v.fract() == 0.0 && v <= 40.0) {
                    return Err(IdentifyError::InvalidParameter {
                        name: "teeth".into(),
                        value: v,
                        allowed: "a whole number 1 ..= 40",
                    });
                }
                o.tool.teeth = v as u32;
            }
            if let Some(v) = constant("helix_deg", p.opt("helix_deg"))? {
                o.tool.helix_deg = v;
            }
            p.ok()?;
            identify_kienzle(&d, &o)?
        }
        Target::FeedAxis => {
            let d = FeedAxisData {
                t_s: p.req("t_s")?,
                reference_um: p.req("reference_um")?,
                position_um: p.req("position_um")?,
            };
            p.ok()?;
            identify_feed_axis(&d, &FeedAxisOptions { common })?
        }
        Target::Force => {
            let depth = p.req("depth_um")?;
            let upfeed = p.req("upfeed_um")?;
            let conditions = ForceConditions {
                depth_um: depth,
                upfeed_um: upfeed,
                speed_rpm: p.opt("speed_rpm"),
                tilt_deg: p.opt("tilt_deg"),
            };
            let data = match p.opt("rot_deg") {
                Some(rot) => ForceData::Traces(ForceTraceData {
                    conditions,
                    rot_deg: rot,
                    fx_n: p.opt("fx_n"),
                    fy_n: p.opt("fy_n"),
                    fz_n: p.opt("fz_n"),
                }),
                None => ForceData::Peaks(PeakForceData {
                    conditions,
                    max_fx_n: p.opt("max_fx_n"),
                    max_fy_n: p.opt("max_fy_n"),
                    max_fz_n: p.opt("max_fz_n"),
                }),
            };
            let mut o = ForceOptions {
                common,
                relative_errors: opts.relative_errors,
                ..Default::default()
            };
            if !opts.force_free.is_empty() {
                o.free = opts.force_free.clone();
            }
            if let Some(m) = &opts.material {
                o.base.material =
                    millcomp_sim::material::Material::by_name(m).map_err(|source| {
                        IdentifyError::Physics {
                            model: "force".into(),
                            source,
                        }
                    })?;
            }
            p.ok()?;
            identify_force(&data, &o)?
        }
    };
    out.notes.extend(p.notes());
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_and_ignored_columns_are_named() {
        let mut c = Columns::new();
        c.insert("load_n", vec![1.0, 2.0, 3.0, 4.0]);
        let e = identify_columns(Target::Stiffness, &c, &IdentifyOptions::default()).unwrap_err();
        assert!(e.to_string().contains("deflection_um"), "{e}");
        c.insert("deflection_um", vec![1.0, 2.1, 2.9, 4.0]);
        c.insert_text("source", vec!["x".into(); 4]);
        let r = identify_columns(Target::Stiffness, &c, &IdentifyOptions::default()).unwrap();
        assert_eq!(r.notes.len(), 1);
        assert!(r.notes[0].contains("`source`"));
        assert!(matches!(
            "nonsense".parse::<Target>(),
            Err(IdentifyError::UnknownTarget { ref name }) if name == "nonsense"
        ));
    }
}
