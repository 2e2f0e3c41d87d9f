//! Scenario factors: the names a batch accepts and how each one changes the published scenario.

use std::collections::BTreeMap;

use millcomp_datasets::{ColumnData, Table};
use millcomp_sim::groove::DepthProfile;

pub use super::spec::{FactorValue, ScenarioSpec};
use super::spec::{bad, num};
use crate::error::ClosedLoopError;
use crate::model_errors::ForceErrors;
use crate::scenario::{FeedStep, Scenario, StageKind, ThinWallScenario, commissioned};

/// The published scenario unnamed factors take their values from: the S7 groove at 20° tilt,
/// 0–80 µm over 20 mm (`000_…txt` ch. 6–7), shipped as `datasets/scenarios/groove_s7_20deg.toml`.
pub const BASE_SCENARIO_TOML: &str =
    include_str!("../../../datasets/scenarios/groove_s7_20deg.toml");
/// File name of [`BASE_SCENARIO_TOML`] (for messages and the plan record).
pub const BASE_SCENARIO_FILE: &str = "datasets/scenarios/groove_s7_20deg.toml";

/// Every factor a batch accepts, with what it sets (shown in the unknown-factor error).
pub const FACTORS: &[(&str, &str)] = &[
    ("tilt_deg", "tool tilt (deg)"),
    ("depth_um", "final depth of the 0..depth ramp (um)"),
    ("upfeed_um", "upfeed (um/rev)"),
    ("wearland_um", "wearland of the tool (um)"),
    (
        "material",
        "a material the force model knows: S7, 1018, 6061, H59, C45",
    ),
    (
        "stiffness_error_pct",
        "error of the controllers' stiffness (%)",
    ),
    (
        "force_model_error_pct",
        "bound of the controllers' force-parameter errors (%)",
    ),
    (
        "force_w_error_pct",
        "error of the controllers' volumetric work W against the truth (%), other force parameters exact",
    ),
    (
        "noise_scale",
        "multiplies the force and gauge noise (nc_axis: the platform's noise)",
    ),
    (
        "stage",
        "groove, thin_wall or nc_axis (003's NC stage: base datasets/scenarios/nc_c45_feed_step.toml)",
    ),
    (
        "feed_ratio",
        "nc_axis: the feed after the feed step over the feed before it (003: 2)",
    ),
    ("ae_mm", "nc_axis: radial depth of cut (mm; 16 = full slot)"),
    (
        "machine_stiffness_n_per_um",
        "nc_axis: the truth machine's static stiffness at the tool (N/um)",
    ),
    ("overhang_d", "nc_axis: the tool's overhang in diameters"),
    (
        "kienzle_error_pct",
        "nc_axis: error of the controllers' Kienzle kc1.1 and kr1.1 against the commissioned ones (%)",
    ),
    (
        "wall_um",
        "nominal wall thickness of the thin-wall stage (um)",
    ),
    (
        "feed_step",
        "0/1: the upfeed doubles half-way along the groove, at once (unless feed_accel_mm_s2 is a factor)",
    ),
    (
        "feed_accel_mm_s2",
        "feed-axis acceleration of the feed changes (mm/s^2; 1e5 = at once)",
    ),
    (
        "depth_step",
        "0/1: the depth steps 20 um deeper at once half-way along the groove",
    ),
    (
        "entry_depth_um",
        "depth where the tool enters (um): the ramp runs from it; > 0 adds a 0.5 mm approach in air",
    ),
    (
        "commissioned",
        "0/1: the commissioned form (instrument errors, a drawn tool, a hysteretic stack, models from commissioning)",
    ),
    (
        "length_mm",
        "groove length (mm); shorter grooves run faster",
    ),
    ("speed_rpm", "spindle speed (rpm)"),
    ("seed", "seed of the scenario's random draws (replicates)"),
    (
        "mpc_stroke_aware",
        "0/1: the groove MPC plans the whole cut within its stroke (control.groove_mpc.stroke_aware)",
    ),
    (
        "mpc_plan_scale",
        "0/1: the groove MPC scales its preview by the measured/planned deflection (adapt_plan_scale)",
    ),
    (
        "mpc_spindle_phase",
        "0/1: the groove MPC times its plan by the spindle angle seen in the force (spindle_phase)",
    ),
    (
        "mpc_flute_phase",
        "0/1: the groove MPC's plan steps once per revolution where one flute dominates (flute_phase)",
    ),
    (
        "mpc_intersample",
        "0/1: the groove MPC weighs the error between its cycles, at every stage step (intersample)",
    ),
];

/// `feed_step`: the feed axis' acceleration (mm/s²) — a doubling of 1.67 mm/s in 17 µs, at once.
pub const FEED_AT_ONCE_MM_S2: f64 = 1e5;
/// `depth_step`: the step (µm) …
pub const DEPTH_STEP_UM: f64 = 20.0;
/// … made over this much travel (mm): at once.
pub const DEPTH_STEP_TRAVEL_MM: f64 = 0.001;
/// `entry_depth_um` > 0: the approach in air before the entry (mm).
pub const ENTRY_APPROACH_MM: f64 = 0.5;
/// The largest `entry_depth_um` (µm): half the ball radius, so the entry's contact half-length is defined.
pub const ENTRY_DEPTH_MAX_UM: f64 = 200.0;
/// Ball radius of the thesis tool (µm, `000_…txt` §6.2: Ø0.8 mm), for the entry's contact length.
const BALL_RADIUS_UM: f64 = 400.0;

/// Columns of a scenario table that are bookkeeping, not factors (ignored).
pub const BOOKKEEPING: &[&str] = &[
    "std_order",
    "run_order",
    "block",
    "run",
    "std",
    "scenario",
    "point_type",
];

fn is_label_factor(name: &str) -> bool {
    matches!(name, "material" | "stage")
}

/// Reads the scenarios of a table (a CSV/Parquet file or a generated design): one row per scenario,
/// one column per factor ([`FACTORS`]; [`BOOKKEEPING`] columns and a design's `name_coded` columns are
/// skipped). Every scenario is built once, so a bad value is reported before anything runs.
///
/// # Errors
/// [`ClosedLoopError::UnknownFactor`], [`ClosedLoopError::NoFactors`],
/// [`ClosedLoopError::NoScenarios`], [`ClosedLoopError::FactorNotNumber`], and
/// [`ClosedLoopError::Row`] naming the row of a value the scenario cannot take.
pub fn scenarios_from_table(
    table: &Table,
) -> Result<(Vec<String>, Vec<ScenarioSpec>), ClosedLoopError> {
    let mut names = Vec::new();
    for c in &table.columns {
        if BOOKKEEPING.contains(&c.name.as_str()) {
            continue;
        }
        // `doe design` writes `name_coded` beside each factor: bookkeeping too.
        if let Some(base) = c.name.strip_suffix("_coded")
            && table.column(base).is_some()
        {
            continue;
        }
        if !FACTORS.iter().any(|(n, _)| *n == c.name) {
            return Err(ClosedLoopError::UnknownFactor {
                origin: table.origin.clone(),
                name: c.name.clone(),
                allowed: FACTORS
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        names.push(c.name.clone());
    }
    if names.is_empty() {
        return Err(ClosedLoopError::NoFactors {
            origin: table.origin.clone(),
        });
    }
    let n = table.n_rows();
    if n == 0 {
        return Err(ClosedLoopError::NoScenarios {
            origin: table.origin.clone(),
        });
    }
    let mut specs: Vec<ScenarioSpec> = (0..n)
        .map(|index| ScenarioSpec {
            index,
            factors: BTreeMap::new(),
        })
        .collect();
    for c in table.columns.iter().filter(|c| names.contains(&c.name)) {
        for (row, spec) in specs.iter_mut().enumerate() {
            let v = match (&c.data, is_label_factor(&c.name)) {
                (ColumnData::Float(v), false) => FactorValue::Num(v[row]),
                (ColumnData::Int(v), false) => FactorValue::Num(v[row] as f64),
                (ColumnData::Float(v), true) => FactorValue::Text(format!("{}", v[row])),
                (ColumnData::Int(v), true) => FactorValue::Text(v[row].to_string()),
                (ColumnData::Text(v), true) => FactorValue::Text(v[row].trim().to_string()),
                (ColumnData::Text(v), false) => match v[row].trim().parse::<f64>() {
                    Ok(x) if x.is_finite() => FactorValue::Num(x),
                    _ => {
                        return Err(ClosedLoopError::FactorNotNumber {
                            origin: table.origin.clone(),
                            factor: c.name.clone(),
                            row: row + 1,
                            value: v[row].clone(),
                        });
                    }
                },
            };
            spec.factors.insert(c.name.clone(), v);
        }
    }
    // Build every scenario once now, so a bad value is reported before anything runs.
    for s in &specs {
        build_scenario(s).map_err(|e| ClosedLoopError::Row {
            origin: table.origin.clone(),
            row: s.index + 1,
            source: Box::new(e),
        })?;
    }
    Ok((names, specs))
}

/// The published base scenario with this scenario's factors applied (validated).
///
/// # Errors
/// [`ClosedLoopError::InvalidFactor`] for a value a factor cannot take, the scenario's own validation
/// errors naming the key.
///
/// ```
/// use millcomp_closedloop::batch::factors::{FactorValue, ScenarioSpec, build_scenario};
/// let spec = ScenarioSpec {
///     index: 0,
///     factors: [("tilt_deg".to_string(), FactorValue::Num(30.0))].into_iter().collect(),
/// };
/// let s = build_scenario(&spec).unwrap();
/// assert_eq!(s.name, "batch_0000");
/// let g = s.groove.unwrap();
/// // the factor, and the published groove_s7_20deg.toml for the rest (20 mm, 10 µm/rev)
/// assert_eq!((g.tilt_deg, g.length_mm, g.upfeed_um), (30.0, 20.0, 10.0));
/// ```
pub fn build_scenario(spec: &ScenarioSpec) -> Result<Scenario, ClosedLoopError> {
    if matches!(spec.factors.get("stage"), Some(FactorValue::Text(t)) if t == "nc_axis") {
        return super::nc_factors::build_nc_scenario(spec);
    }
    for f in super::nc_factors::NC_ONLY_FACTORS {
        if spec.factors.contains_key(*f) {
            return Err(bad(f, "applies to stage = nc_axis only".into()));
        }
    }
    let mut s = Scenario::from_toml_str(BASE_SCENARIO_TOML, BASE_SCENARIO_FILE)?;
    s.name = format!("batch_{:04}", spec.index);
    s.controllers.clear();
    let Some(g) = s.groove.as_mut() else {
        return Err(ClosedLoopError::NoGrooveInBase {
            file: BASE_SCENARIO_FILE.to_string(),
        });
    };
    if let Some(v) = num(spec, "tilt_deg")? {
        g.tilt_deg = v;
    }
    if let Some(v) = num(spec, "depth_um")? {
        g.depth = DepthProfile::Ramp {
            from_um: 0.0,
            to_um: v,
        };
    }
    if let Some(v) = num(spec, "entry_depth_um")? {
        if !(0.0..=ENTRY_DEPTH_MAX_UM).contains(&v) {
            return Err(bad(
                "entry_depth_um",
                format!("{v} is outside 0..={ENTRY_DEPTH_MAX_UM}"),
            ));
        }
        let to_um = match g.depth {
            DepthProfile::Ramp { to_um, .. } => to_um,
            _ => g.depth.depth_at(g.length_mm, g.length_mm),
        };
        g.depth = DepthProfile::Ramp { from_um: v, to_um };
        if v > 0.0 {
            g.approach_mm = ENTRY_APPROACH_MM;
            // the half-length of the ball's contact at the entry depth (closedloop/SCENARIOS.md)
            g.entry_length_mm = (2.0 * BALL_RADIUS_UM * v - v * v).sqrt() / 1000.0;
        }
    }
    match num(spec, "depth_step")? {
        None | Some(0.0) => {}
        Some(1.0) => {
            let (l, x) = (g.length_mm, g.length_mm / 2.0);
            let d = |x: f64| g.depth.depth_at(x, l);
            g.depth = DepthProfile::Points {
                points: vec![
                    (0.0, d(0.0)),
                    (x, d(x)),
                    (x + DEPTH_STEP_TRAVEL_MM, d(x) + DEPTH_STEP_UM),
                    (l, d(l) + DEPTH_STEP_UM),
                ],
            };
        }
        Some(x) => return Err(bad("depth_step", format!("{x} is not 0 or 1"))),
    }
    if let Some(v) = num(spec, "upfeed_um")? {
        g.upfeed_um = v;
    }
    if let Some(v) = num(spec, "wearland_um")? {
        g.wearland_um = v;
    }
    if let Some(v) = num(spec, "length_mm")? {
        g.length_mm = v;
    }
    if let Some(v) = num(spec, "speed_rpm")? {
        g.speed_rpm = v;
    }
    match spec.factors.get("material") {
        None => {}
        // every material the physics knows (sim's `Material::by_name`), one list
        Some(FactorValue::Text(m)) if millcomp_sim::material::Material::by_name(m).is_ok() => {
            g.material = m.clone();
        }
        Some(v) => {
            return Err(bad(
                "material",
                format!(
                    "`{}` is not one of {}",
                    v.text(),
                    millcomp_sim::material::MATERIAL_NAMES.join(", ")
                ),
            ));
        }
    }
    match num(spec, "feed_step")? {
        None => {}
        Some(0.0) => g.feed_steps.clear(),
        Some(1.0) => {
            g.feed_steps = vec![FeedStep {
                x_mm: g.length_mm / 2.0,
                upfeed_um: 2.0 * g.upfeed_um,
            }];
            g.feed_accel_mm_s2 = FEED_AT_ONCE_MM_S2;
        }
        Some(x) => return Err(bad("feed_step", format!("{x} is not 0 or 1"))),
    }
    if let Some(v) = num(spec, "feed_accel_mm_s2")? {
        g.feed_accel_mm_s2 = v;
    }
    let features = &mut s.control.groove_mpc;
    for (name, flag) in [
        ("mpc_stroke_aware", &mut features.stroke_aware),
        ("mpc_plan_scale", &mut features.adapt_plan_scale),
        ("mpc_spindle_phase", &mut features.spindle_phase),
        ("mpc_flute_phase", &mut features.flute_phase),
        ("mpc_intersample", &mut features.intersample),
    ] {
        match num(spec, name)? {
            None => {}
            Some(0.0) => *flag = false,
            Some(1.0) => *flag = true,
            Some(x) => return Err(bad(name, format!("{x} is not 0 or 1"))),
        }
    }
    if let Some(v) = num(spec, "stiffness_error_pct")? {
        s.truth.stiffness_error = v / 100.0;
    }
    if let Some(v) = num(spec, "force_model_error_pct")? {
        if !(0.0..=50.0).contains(&v) {
            return Err(bad(
                "force_model_error_pct",
                format!("{v} is outside 0..=50"),
            ));
        }
        s.truth.force_error_max = v / 100.0;
        s.truth.force_errors = None;
    }
    if let Some(v) = num(spec, "force_w_error_pct")? {
        if !(-50.0..=50.0).contains(&v) {
            return Err(bad("force_w_error_pct", format!("{v} is outside -50..=50")));
        }
        s.truth.force_errors = Some(ForceErrors {
            w_mpa: v / 100.0,
            mu_rake: 0.0,
            mu_flank: 0.0,
            wearland_um: 0.0,
        });
    }
    if let Some(v) = num(spec, "noise_scale")? {
        if v < 0.0 {
            return Err(bad(
                "noise_scale",
                format!("{v} is negative (allowed >= 0)"),
            ));
        }
        s.truth.force_noise_n *= v;
        s.truth.gauge_noise_um *= v;
    }
    if let Some(v) = num(spec, "seed")? {
        if v < 0.0 || v.fract() != 0.0 {
            return Err(bad("seed", format!("{v} is not a non-negative integer")));
        }
        s.seed = v as u64;
    }
    match num(spec, "commissioned")? {
        None | Some(0.0) => {}
        Some(1.0) => s = commissioned(&s),
        Some(x) => return Err(bad("commissioned", format!("{x} is not 0 or 1"))),
    }
    match spec.factors.get("stage") {
        None => {}
        Some(FactorValue::Text(t)) if t == "groove" => s.stage = StageKind::Groove,
        Some(FactorValue::Text(t)) if t == "thin_wall" => {
            s.stage = StageKind::ThinWall;
            s.thin_wall = Some(default_thin_wall()?);
        }
        Some(v) => {
            return Err(bad(
                "stage",
                format!("`{}` is not groove, thin_wall or nc_axis", v.text()),
            ));
        }
    }
    if let Some(v) = num(spec, "wall_um")? {
        if s.thin_wall.is_none() {
            s.thin_wall = Some(default_thin_wall()?);
        }
        if let Some(tw) = s.thin_wall.as_mut() {
            tw.walls_um = vec![v];
        }
    }
    s.validate()?;
    Ok(s)
}

/// The thin-wall stage's published defaults (`004_…txt` Tables 2–4, via the scenario's serde defaults).
fn default_thin_wall() -> Result<ThinWallScenario, ClosedLoopError> {
    Ok(serde_json::from_str::<ThinWallScenario>("{}")?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::error_chain;

    fn spec(pairs: &[(&str, FactorValue)]) -> ScenarioSpec {
        ScenarioSpec {
            index: 3,
            factors: pairs
                .iter()
                .map(|(n, v)| (n.to_string(), v.clone()))
                .collect(),
        }
    }

    #[test]
    fn factors_change_the_published_scenario() {
        let s = build_scenario(&spec(&[
            ("tilt_deg", FactorValue::Num(30.0)),
            ("depth_um", FactorValue::Num(60.0)),
            ("material", FactorValue::Text("6061".into())),
            ("stiffness_error_pct", FactorValue::Num(-10.0)),
            ("noise_scale", FactorValue::Num(2.0)),
            ("feed_step", FactorValue::Num(1.0)),
        ]))
        .unwrap();
        let g = s.groove.unwrap();
        assert_eq!(g.tilt_deg, 30.0);
        assert_eq!(g.material, "6061");
        assert_eq!(
            g.depth,
            DepthProfile::Ramp {
                from_um: 0.0,
                to_um: 60.0
            }
        );
        // 20 mm groove of the base scenario: the step is at 10 mm, upfeed 10 → 20 µm/rev.
        assert_eq!(g.feed_steps.len(), 1);
        assert_eq!(g.feed_steps[0].x_mm, 10.0);
        assert_eq!(g.feed_steps[0].upfeed_um, 20.0);
        assert_eq!(g.feed_accel_mm_s2, FEED_AT_ONCE_MM_S2);
        assert!((s.truth.stiffness_error + 0.1).abs() < 1e-15);
        // groove_s7_20deg.toml: force_noise_n = 0.04, doubled.
        assert!((s.truth.force_noise_n - 0.08).abs() < 1e-15);
        // Unnamed factors keep the published values (groove_s7_20deg.toml: upfeed 10, wearland 8).
        assert_eq!(g.upfeed_um, 10.0);
        assert_eq!(g.wearland_um, 8.0);
    }

    #[test]
    fn changes_at_once_and_the_entry() {
        let s = build_scenario(&spec(&[
            ("depth_um", FactorValue::Num(60.0)),
            ("entry_depth_um", FactorValue::Num(40.0)),
            ("depth_step", FactorValue::Num(1.0)),
            ("feed_accel_mm_s2", FactorValue::Num(1e5)),
            ("commissioned", FactorValue::Num(1.0)),
        ]))
        .unwrap();
        let g = s.groove.as_ref().unwrap();
        // 40 → 60 µm over the base's 20 mm, +20 µm at once at 10 mm (50 µm there)
        assert_eq!(
            g.depth,
            DepthProfile::Points {
                points: vec![(0.0, 40.0), (10.0, 50.0), (10.001, 70.0), (20.0, 80.0)]
            }
        );
        // an approach in air, and the contact half-length at 40 µm: √(2·400·40 − 40²) µm
        assert_eq!(g.approach_mm, 0.5);
        assert!(
            (g.entry_length_mm - 0.174_355).abs() < 1e-6,
            "{}",
            g.entry_length_mm
        );
        assert_eq!(g.feed_accel_mm_s2, 1e5);
        assert!(s.control.commission && s.truth.draw_tool);
    }

    #[test]
    fn bad_values_name_the_factor() {
        let e = build_scenario(&spec(&[("material", FactorValue::Text("titanium".into()))]));
        let msg = error_chain(&e.unwrap_err());
        assert!(msg.contains("material") && msg.contains("C45"), "{msg}");
        // every material sim knows is a level, the 004 brass and the 003 steel included
        for m in millcomp_sim::material::MATERIAL_NAMES {
            build_scenario(&spec(&[("material", FactorValue::Text(m.into()))])).unwrap();
        }
        for f in ["feed_step", "depth_step", "commissioned"] {
            let e = build_scenario(&spec(&[(f, FactorValue::Num(2.0))]));
            assert!(error_chain(&e.unwrap_err()).contains(f));
        }
        let e = build_scenario(&spec(&[("entry_depth_um", FactorValue::Num(-1.0))]));
        assert!(error_chain(&e.unwrap_err()).contains("entry_depth_um"));
        let e = build_scenario(&spec(&[("feed_step", FactorValue::Num(2.0))]));
        assert!(error_chain(&e.unwrap_err()).contains("feed_step"));
        let e = build_scenario(&spec(&[("tilt_deg", FactorValue::Num(0.0))]));
        assert!(error_chain(&e.unwrap_err()).contains("tilt_deg"));
    }
}
