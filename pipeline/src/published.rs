//! Prediction cases built from the thesis's published tables (datasets `clayton_*`), for the
//! diagnoses that predict a published figure they were not fitted on.

use std::path::Path;

use millcomp_diagnose::forces::{Cited, PredictCase};
use millcomp_sim::force::CutConditions;

use crate::error::{PipelineError, Result};

/// The thesis's S7 groove deep end (datasets `clayton_groove_conditions`) as a force-prediction
/// case, W carried from `material` by the Table 4-1 ratios (datasets `clayton_force_materials`):
/// what `millcomp identify force TABLE --material M --diagnose` predicts without a scale factor.
///
/// # Errors
///
/// [`PipelineError::UnknownMaterial`] if `material` is not in Table 4-1; a dataset or cut-condition
/// error if the shipped tables do not hold what the case needs.
///
/// # Examples
///
/// ```
/// let case = millcomp_pipeline::published::s7_groove_case("6061").unwrap();
/// assert_eq!(case.material, "S7");
/// assert_eq!(case.measured.value, 8.53); // N, thesis §7.2.2
/// assert!(millcomp_pipeline::published::s7_groove_case("unobtainium").is_err());
/// ```
pub fn s7_groove_case(material: &str) -> Result<PredictCase> {
    let g = millcomp_datasets::load("clayton_groove_conditions")?;
    let names = g.strings("parameter")?;
    let values = g.f64s("value")?;
    let sources = g.strings("source")?;
    let get = |p: &str| -> Result<(f64, String)> {
        let i = names.iter().position(|n| n == p).ok_or_else(|| {
            PipelineError::data(
                Path::new("clayton_groove_conditions"),
                format!("no row `{p}` in column `parameter`"),
            )
        })?;
        Ok((values[i], sources[i].clone()))
    };
    let (depth, _) = get("depth_end")?;
    let (upfeed, _) = get("upfeed")?;
    let (speed, _) = get("spindle_speed")?;
    let (tilt, _) = get("tilt")?;
    let (wl, wl_src) = get("wearland_closed_loop")?;
    let m = millcomp_datasets::load("clayton_force_materials")?;
    let mats = m.strings("material")?;
    let row = |name: &str| -> Result<usize> {
        mats.iter()
            .position(|x| x.eq_ignore_ascii_case(name))
            .ok_or_else(|| PipelineError::UnknownMaterial {
                material: name.to_string(),
                known: mats.join(", "),
            })
    };
    let (src, s7) = (row(material)?, row("S7")?);
    let mut transfers = Vec::new();
    for (col, what) in [
        (
            "model_w_nm_per_m3",
            "Table 4-1 modelled W (itself set by hand in the thesis)",
        ),
        ("volumetric_work_nm_per_m3", "Table 4-1 volumetric work"),
        ("hardness_mpa", "Table 4-1 hardness"),
    ] {
        let v = m.f64s(col)?;
        transfers.push(Cited {
            name: format!("{col} ratio S7/{material}"),
            value: v[s7] / v[src],
            unit: "1".into(),
            source: format!("000_367e180efde69d0c.txt {what}: {} / {}", v[s7], v[src]),
        });
    }
    Ok(PredictCase {
        name: "S7 groove deep end (20 deg, 80 um, 10 um/rev, 10 000 rpm)".into(),
        material: "S7".into(),
        cut: CutConditions::new(depth, upfeed, speed, tilt)?,
        wearland: Cited {
            name: "wearland".into(),
            value: wl,
            unit: "um".into(),
            source: wl_src,
        },
        runout: Cited {
            name: "runout".into(),
            value: 10.0,
            unit: "um".into(),
            source: "000_367e180efde69d0c.txt Table 4-2 (S7 cuts: 5-10 um, 10 um at 0 and 25 deg tilt); the value sim's groove uses".into(),
        },
        measured: Cited {
            name: "deep-end peak Fz".into(),
            value: 8.53,
            unit: "N".into(),
            source: "000_367e180efde69d0c.txt section 7.2.2, Fig. 7-6: 6 um axial and 9 um radial deflection at the deep end times the measured stiffnesses (8.29 and 8.77 N, mean 8.53; sim/tests/groove.rs)".into(),
        },
        transfers,
    })
}
