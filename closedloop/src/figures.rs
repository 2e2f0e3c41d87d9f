//! The published figures millcomp touches: each with the value as published, millcomp's value as it
//! computes it now, `fitted_on` (the published figures whose values set a parameter the figure depends
//! on) and a label given by one rule ([`label_by_rule`]):
//!
//! * **calibrated to** — the figure's own name is in its `fitted_on`: a parameter was set so that it
//!   comes out, so it is no check (the fitting data — Table 3-3, the 20° groove, 004's Table 5 — are
//!   calibrated by definition);
//! * **predicted** — otherwise, when millcomp's value is within the published value's stated scatter or
//!   reach (the `reach` of [`Published`]);
//! * **disagrees** — otherwise, with a `reason`.
//!
//! Cheap figures are computed live ([`Computed::Live`]: the DOE analysis of Table 3-3, the force and
//! spindle fits, the stiffnesses, the groove and thin-wall simulations); the long studies (controllers
//! over ten commissioned seeds, the NC stage's band) are recorded in [`recorded`] and recomputed by the
//! slow suite's tests named in [`Computed::Recorded`], which fail when a value moved beyond the stated
//! tolerance. `millcomp datasets figures` prints the list; README's figure table is its `--markdown`.
//!
//! Seed documents: 000 Clayton's thesis, 003 the NC feed-axis paper, 004 the thin-wall paper.

use std::collections::BTreeSet;

use serde::Serialize;

use millcomp_doe::AnalyzeOptions;
use millcomp_identify::{IdentifyOptions, Target, identify_columns};
use millcomp_sim::stiffness::TiltedToolStiffness;

use crate::error::ClosedLoopError;
use crate::{ControllerKind, Scenario, run_scenario};

/// What a figure's label says of millcomp's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Label {
    /// Nothing was fitted to the figure and millcomp's value is within its published reach.
    #[serde(rename = "predicted")]
    Predicted,
    /// A parameter was set so that the figure comes out (its name is in its own `fitted_on`).
    #[serde(rename = "calibrated to")]
    CalibratedTo,
    /// Nothing was fitted to it and millcomp's value is outside its published reach.
    #[serde(rename = "disagrees")]
    Disagrees,
}

impl Label {
    /// `predicted`, `calibrated to` or `disagrees`.
    pub fn as_str(self) -> &'static str {
        match self {
            Label::Predicted => "predicted",
            Label::CalibratedTo => "calibrated to",
            Label::Disagrees => "disagrees",
        }
    }
}

/// The labelling rule: a figure whose own name is in `fitted_on` is calibrated to, whatever its value;
/// otherwise predicted when `within` its published reach, else disagrees.
///
/// ```
/// use millcomp_closedloop::figures::{Label, label_by_rule};
/// assert_eq!(label_by_rule("a", &["a"], true), Label::CalibratedTo);
/// assert_eq!(label_by_rule("a", &["b"], true), Label::Predicted);
/// assert_eq!(label_by_rule("a", &[], false), Label::Disagrees);
/// ```
pub fn label_by_rule(name: &str, fitted_on: &[&str], within: bool) -> Label {
    if fitted_on.contains(&name) {
        Label::CalibratedTo
    } else if within {
        Label::Predicted
    } else {
        Label::Disagrees
    }
}

/// Where millcomp's value comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Computed {
    /// Computed by this call.
    Live,
    /// Recorded from a long study; the test named recomputes it in the slow suite.
    Recorded {
        /// The test (`closedloop` crate, `tests/figures.rs`).
        test: &'static str,
    },
    /// Computed by this call, with a recorded part the test named recomputes.
    LiveAndRecorded {
        /// The test (`closedloop` crate, `tests/figures.rs`).
        test: &'static str,
    },
}

impl std::fmt::Display for Computed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Computed::Live => write!(f, "live"),
            Computed::Recorded { test } => write!(f, "recorded, checked by {test}"),
            Computed::LiveAndRecorded { test } => {
                write!(f, "live; the commissioned part recorded, checked by {test}")
            }
        }
    }
}

impl Serialize for Computed {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A figure as published.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Published {
    /// As published (words and numbers).
    pub text: &'static str,
    /// Its numbers (empty for a qualitative figure).
    pub values: Vec<f64>,
    /// Their unit.
    pub unit: &'static str,
    /// The reach a prediction must land in, and where it comes from.
    pub reach: &'static str,
}

/// millcomp's value of a figure.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Millcomp {
    /// As the table shows it.
    pub text: String,
    /// Its numbers.
    pub values: Vec<f64>,
    /// Their unit.
    pub unit: &'static str,
}

/// One published figure with millcomp's value and its label.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PublishedFigure {
    /// Stable snake_case id.
    pub name: &'static str,
    /// What the figure is.
    pub figure: &'static str,
    /// Seed document and section, e.g. `000 §7.2.2`.
    pub source: &'static str,
    /// The published value.
    pub published: Published,
    /// millcomp's value.
    pub millcomp: Millcomp,
    /// By [`label_by_rule`].
    pub label: Label,
    /// What was set, for a calibrated figure (e.g. the record made from the figure); why, for one that
    /// disagrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<&'static str>,
    /// The published figures whose values set a parameter this figure depends on.
    pub fitted_on: Vec<&'static str>,
    /// Why it disagrees (only when it does).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Live or recorded (and by which test it is checked).
    pub computed: Computed,
    /// The command that reproduces millcomp's value.
    pub command: &'static str,
}

/// The values of the long studies, and the tolerance within which the slow suite's tests
/// (`closedloop/tests/figures.rs`) must recompute them.
pub mod recorded {
    /// Seeds of the controller comparison: `cargo run --release -p millcomp-closedloop --example
    /// compare -- --seeds 10 --commissioned` (docs/studies/controllers.md).
    pub const GROOVE_SEEDS: std::ops::Range<u64> = 1..11;
    /// Open loop on the commissioned 20° groove: median peak-to-peak error (µm) and its 95 % interval.
    pub const OPEN_LOOP_20DEG_UM: (f64, [f64; 2]) = (3.50, [2.45, 4.26]);
    /// The published PID on the commissioned 20° / 30° / 40° grooves: median peak-to-peak error (µm).
    pub const PID_UM: [f64; 3] = [1.94, 1.06, 1.42];
    /// How far a recomputed groove median may move (µm) before the record is stale.
    pub const GROOVE_TOL_UM: f64 = 0.05;
    /// Seeds at the NC study's nominal machine: `cargo run --release -p millcomp-closedloop --example
    /// nc_axis_study -- --seeds 10 --band-seeds 3` (docs/studies/nc-axis.md).
    pub const NC_SEEDS: std::ops::Range<u64> = 1..11;
    /// Reactive: static wall error removed (%), median and 95 % interval.
    pub const NC_REACTIVE_REMOVED_PCT: (f64, [f64; 2]) = (96.11, [94.40, 96.74]);
    /// Feed-step peak (µm), median: reactive, proactive.
    pub const NC_PEAK_UM: [f64; 2] = [75.89, 16.55];
    /// Proactive / reactive feed-step peak per seed (the ratio on one machine): median and 95 %
    /// interval, to 0.01.
    pub const NC_PROACTIVE_OVER_REACTIVE: (f64, [f64; 2]) = (0.21, [0.19, 0.28]);
    /// Exit undersize (µm), median: reactive, proactive.
    pub const NC_EXIT_UNDERSIZE_UM: [f64; 2] = [155.35, 191.39];
    /// The band over machine stiffness 20/30/50 N/µm × overhang 3/3.5/4 D (medians over seeds 1..=3
    /// at each point): the feed-step peak's range (µm), reactive and proactive.
    pub const NC_BAND_PEAK_UM: [[f64; 2]; 2] = [[52.9, 115.9], [11.8, 24.5]];
    /// Seeds of each band point.
    pub const NC_BAND_SEEDS: std::ops::Range<u64> = 1..4;
    /// How far a recomputed NC figure may move (µm or percentage points) before the record is stale.
    pub const NC_TOL: f64 = 0.05;
    /// The notch chain after the feed step (reactive, seed 1): the correction's first overshoot and
    /// the undershoot after it, % of the step (docs/studies/nc-axis.md, the `ringing` section),
    /// recorded to 0.1 %.
    pub const NC_RINGING_PCT: [f64; 2] = [6.6, 4.3];
    /// Seeds of the axis shipped before (`nc_axis_study -- --sections 8 --seeds 5`,
    /// docs/studies/published-nc.md).
    pub const NC_P_LOOP_SEEDS: std::ops::Range<u64> = 1..6;
    /// The published groove with both axes as sim's `AxisDynamics::brecher_003` (a P position loop
    /// without feedforward, 4 ms dead time + 1/kv = 12 ms: the default until the diagnosis of
    /// docs/studies/published-nc.md): the reactive correction's first overshoot and the undershoot
    /// after it (seed 1, % of the step, to 0.1 %).
    pub const NC_P_LOOP_RINGING_PCT: [f64; 2] = [1.4, 1.1];
    /// The same: feed-step peak (µm), median over [`NC_P_LOOP_SEEDS`]: reactive, proactive.
    pub const NC_P_LOOP_PEAK_UM: [f64; 2] = [57.61, 17.98];
}

const TEST_GROOVES: &str = "`recorded_groove_controller_figures_hold`";
const TEST_NC: &str = "`recorded_nc_figures_hold`";
const TEST_NC_AND_BAND: &str = "`recorded_nc_figures_hold`, `recorded_nc_band_holds`";

const GROOVE_REACH: &str =
    "±2 µm (issue 50: the thesis reports 16 and 17 µm for the same 20° groove)";

/// A figure before its label.
struct Draft {
    name: &'static str,
    figure: &'static str,
    source: &'static str,
    published: Published,
    millcomp: Millcomp,
    within: bool,
    note: Option<&'static str>,
    why: &'static str,
    fitted_on: Vec<&'static str>,
    computed: Computed,
    command: &'static str,
}

impl Draft {
    fn finish(self) -> PublishedFigure {
        let label = label_by_rule(self.name, &self.fitted_on, self.within);
        let reason = (label == Label::Disagrees).then(|| {
            let mut r = format!(
                "{} against {} (reach: {})",
                self.millcomp.text, self.published.text, self.published.reach
            );
            if !self.why.is_empty() {
                r.push_str(": ");
                r.push_str(self.why);
            }
            r
        });
        let note = match label {
            Label::CalibratedTo => self.note,
            Label::Disagrees => Some(self.why).filter(|w| !w.is_empty()),
            Label::Predicted => None,
        };
        PublishedFigure {
            name: self.name,
            figure: self.figure,
            source: self.source,
            published: self.published,
            millcomp: self.millcomp,
            label,
            note,
            fitted_on: self.fitted_on,
            reason,
            computed: self.computed,
            command: self.command,
        }
    }
}

fn fail<E: std::error::Error + Send + Sync + 'static>(
    name: &'static str,
) -> impl FnOnce(E) -> ClosedLoopError {
    move |e| ClosedLoopError::Figure {
        name,
        source: Box::new(e),
    }
}

fn within_abs(values: &[f64], published: &[f64], tol: f64) -> bool {
    values.len() == published.len()
        && values
            .iter()
            .zip(published)
            .all(|(v, p)| (v - p).abs() <= tol)
}

fn within_rel(values: &[f64], published: &[f64], rel: f64) -> bool {
    values.len() == published.len()
        && values
            .iter()
            .zip(published)
            .all(|(v, p)| (v / p - 1.0).abs() <= rel)
}

fn scenario(name: &'static str, text: &'static str) -> Result<Scenario, ClosedLoopError> {
    Scenario::from_toml_str(text, name)
}

const GROOVE_20: (&str, &str) = (
    "groove_s7_20deg.toml",
    include_str!("../../datasets/scenarios/groove_s7_20deg.toml"),
);
const GROOVE_30: (&str, &str) = (
    "groove_s7_30deg.toml",
    include_str!("../../datasets/scenarios/groove_s7_30deg.toml"),
);
const GROOVE_40: (&str, &str) = (
    "groove_s7_40deg.toml",
    include_str!("../../datasets/scenarios/groove_s7_40deg.toml"),
);
const THIN_WALL: (&str, &str) = (
    "thin_wall_h59.toml",
    include_str!("../../datasets/scenarios/thin_wall_h59.toml"),
);

/// The published 20° / 30° / 40° groove scenarios (`datasets/scenarios/groove_s7_*deg.toml`).
///
/// # Errors
/// A shipped scenario that does not parse ([`ClosedLoopError::Scenario`]).
pub fn groove_scenarios() -> Result<[Scenario; 3], ClosedLoopError> {
    Ok([
        scenario(GROOVE_20.0, GROOVE_20.1)?,
        scenario(GROOVE_30.0, GROOVE_30.1)?,
        scenario(GROOVE_40.0, GROOVE_40.1)?,
    ])
}

/// The peak-to-peak depth error (µm) of `s` cut with `kind`.
fn pp_um(name: &'static str, s: &Scenario, kind: ControllerKind) -> Result<f64, ClosedLoopError> {
    Ok(run_scenario(s, kind)
        .map_err(fail(name))?
        .metrics
        .pp_error_um)
}

/// Every published figure millcomp touches, computed now; `progress` is told each figure's name
/// before it is computed (the groove and thin-wall simulations take a few seconds).
///
/// # Errors
/// [`ClosedLoopError::Figure`] naming the figure whose table, analysis, fit or run failed;
/// [`ClosedLoopError::Scenario`] for a shipped scenario that does not parse.
///
/// # Examples
/// ```
/// use millcomp_closedloop::figures::{Label, published_figures};
/// let figs = published_figures(&|_| {}).unwrap();
/// let kz = figs.iter().find(|f| f.name == "z_stiffness_20deg").unwrap();
/// // 000 §6.1: 0.597 N/µm; from Table 5-1's measured stiffnesses 0.571 N/µm (−4.3 %)
/// assert!((kz.millcomp.values[0] - 0.571).abs() < 5e-4);
/// assert_eq!(kz.label, Label::Predicted);
/// // 000 Table 4-1 sets W(6061) = 2500 MPa; fitted to Table 3-3: 2049 [1691, 2407] MPa
/// let w = figs.iter().find(|f| f.name == "w_6061").unwrap();
/// assert!((w.millcomp.values[0] - 2049.0).abs() < 1.0);
/// assert_eq!(w.label, Label::Disagrees);
/// ```
pub fn published_figures(progress: &dyn Fn(&str)) -> Result<Vec<PublishedFigure>, ClosedLoopError> {
    let mut out = Vec::new();
    let mut push = |d: Draft| out.push(d.finish());

    // --- 000 Table 3-3 (6061): the significance of the X force, and the force model fitted to it
    progress("table_3_3_x_force_terms");
    let doe = millcomp_datasets::load("clayton_doe").map_err(fail("table_3_3_x_force_terms"))?;
    let columns = millcomp_datasets::adapters::doe_columns(&doe);
    let analysis = AnalyzeOptions {
        factors: Some(vec![
            "depth_um".to_string(),
            "speed_rpm".to_string(),
            "upfeed_um".to_string(),
        ]),
        ..AnalyzeOptions::new("max_fx_n")
    }
    .run("datasets/data/clayton_doe.csv", &columns)
    .map_err(fail("table_3_3_x_force_terms"))?
    .analysis;
    let p = |term: &str| {
        analysis
            .terms
            .iter()
            .find(|t| t.term == term)
            .and_then(|t| t.p_value)
            .unwrap_or(f64::NAN)
    };
    let (pd, ps, pu) = (p("depth_um"), p("speed_rpm"), p("upfeed_um"));
    push(Draft {
        name: "table_3_3_x_force_terms",
        figure: "Table 3-3: the terms significant for the X force",
        source: "000 §3.5",
        published: Published {
            text: "depth, upfeed; not speed",
            values: vec![],
            unit: "",
            reach: "the same terms significant at α = 0.05",
        },
        millcomp: Millcomp {
            text: format!("depth p = {pd:.3}, upfeed p = {pu:.3}, speed p = {ps:.2}"),
            values: vec![pd, pu, ps],
            unit: "p-value",
        },
        within: pd < 0.05 && pu < 0.05 && ps >= 0.05,
        note: Some("a re-analysis of the published table, fitting data by definition"),
        why: "",
        fitted_on: vec!["table_3_3_x_force_terms"],
        computed: Computed::Live,
        command: "millcomp doe analyze datasets/data/clayton_doe.csv --response max_fx_n --factors depth_um,speed_rpm,upfeed_um",
    });

    progress("w_6061");
    let force_cols = millcomp_datasets::adapters::identify_columns(&doe);
    let opts = IdentifyOptions {
        material: Some("6061".to_string()),
        ..Default::default()
    };
    let fit = |cols: &millcomp_identify::Columns| {
        identify_columns(Target::Force, cols, &opts).map_err(fail("w_6061"))
    };
    let all = fit(&force_cols)?.report;
    let (w, ci) = (all.param("w_mpa"), all.ci95["w_mpa"]);
    let rms = all.rms_residual.value;
    let only = |keep: &str| {
        let mut c = force_cols.clone();
        for r in ["max_fx_n", "max_fy_n", "max_fz_n"] {
            if r != keep {
                c.remove(r);
            }
        }
        fit(&c).map(|f| f.report.param("w_mpa"))
    };
    let (wx, wy) = (only("max_fx_n")?, only("max_fy_n")?);
    push(Draft {
        name: "table_3_3_forces",
        figure: "Table 3-3: the X/Y/Z force maxima of 8 cuts in 6061",
        source: "000 §3.5",
        published: Published {
            text: "24 force maxima, 0.59–3.60 N",
            values: vec![],
            unit: "N",
            reach: "the fitting data",
        },
        millcomp: Millcomp {
            text: format!(
                "RMS residual {rms:.2} N; W fitted on X alone {wx:.0}, on Y alone {wy:.0} MPa"
            ),
            values: vec![rms, wx, wy],
            unit: "N, MPa",
        },
        within: false,
        note: Some("W is fitted to it"),
        why: "",
        fitted_on: vec!["table_3_3_forces"],
        computed: Computed::Live,
        command: "millcomp identify force datasets/data/clayton_doe.csv --material 6061",
    });
    push(Draft {
        name: "w_6061",
        figure: "W of 6061",
        source: "000 Table 4-1",
        published: Published {
            text: "2500 MPa",
            values: vec![2500.0],
            unit: "MPa",
            reach: "inside the fit's 95 % interval",
        },
        millcomp: Millcomp {
            text: format!(
                "{w:.0} [{:.0}, {:.0}] MPa, fitted to Table 3-3",
                ci[0], ci[1]
            ),
            values: vec![w, ci[0], ci[1]],
            unit: "MPa",
        },
        within: (ci[0]..=ci[1]).contains(&2500.0),
        note: None,
        why: "W from the X forces alone and from the Y forces alone in table_3_3_forces",
        fitted_on: vec!["table_3_3_forces"],
        computed: Computed::Live,
        command: "millcomp identify force datasets/data/clayton_doe.csv --material 6061",
    });

    // --- 000 §5.2.4: the PZT spindle's step response (the synthetic record is made from it)
    progress("pzt_step_response");
    let step = millcomp_datasets::synthetic_runs::SYNTHETIC_RUNS
        .iter()
        .find(|r| r.name == "spindle_step_synthetic")
        .expect("the shipped synthetic runs hold the spindle step");
    let step_table =
        millcomp_datasets::read_any_str(step.file, step.csv).map_err(fail("pzt_step_response"))?;
    let spindle = identify_columns(
        Target::Spindle,
        &millcomp_datasets::adapters::identify_columns(&step_table),
        &IdentifyOptions::default(),
    )
    .map_err(fail("pzt_step_response"))?
    .report;
    let (zeta, wn) = (spindle.param("zeta"), spindle.param("wn_rad_s"));
    push(Draft {
        name: "pzt_step_response",
        figure: "PZT spindle step response",
        source: "000 §5.2.4",
        published: Published {
            text: "ζ 0.46, ωn 1302 rad/s",
            values: vec![0.46, 1302.0],
            unit: "-, rad/s",
            reach: "ζ ±0.01, ωn ±1 %",
        },
        millcomp: Millcomp {
            text: format!("ζ {zeta:.3}, ωn {wn:.0} rad/s"),
            values: vec![zeta, wn],
            unit: "-, rad/s",
        },
        within: (zeta - 0.46).abs() <= 0.01 && (wn / 1302.0 - 1.0).abs() <= 0.01,
        note: Some("the synthetic step record is made from them"),
        why: "",
        fitted_on: vec!["pzt_step_response"],
        computed: Computed::Live,
        command: "millcomp identify spindle datasets/runs/spindle_step_synthetic.csv",
    });

    // --- 000 ch. 5–7: the tilted tool's stiffness
    progress("table_5_1_stiffness");
    let st = TiltedToolStiffness::default();
    let (ka, kr) = (st.axial_n_per_um, st.radial_n_per_um);
    push(Draft {
        name: "table_5_1_stiffness",
        figure: "Table 5-1: the tool's measured axial and radial stiffness",
        source: "000 Table 5-1",
        published: Published {
            text: "axial 1.220, radial 0.114 N/µm",
            values: vec![1.220, 0.114],
            unit: "N/µm",
            reach: "as measured (3 digits)",
        },
        millcomp: Millcomp {
            text: format!("{ka:.3} / {kr:.3} N/µm, taken as measured"),
            values: vec![ka, kr],
            unit: "N/µm",
        },
        within: within_abs(&[ka, kr], &[1.220, 0.114], 5e-4),
        note: Some("the simulated tool's stiffnesses are these"),
        why: "",
        fitted_on: vec!["table_5_1_stiffness"],
        computed: Computed::Live,
        command: "cargo test -p millcomp-sim --test main stiffness::",
    });
    let kz = st.z_stiffness_n_per_um(20.0)?;
    push(Draft {
        name: "z_stiffness_20deg",
        figure: "z-stiffness of the tilted tool at 20°",
        source: "000 §6.1",
        published: Published {
            text: "0.597 N/µm",
            values: vec![0.597],
            unit: "N/µm",
            reach: "±5 % (the modelled radial stiffness's spread, sim/tests/common.rs KZ_REL)",
        },
        millcomp: Millcomp {
            text: format!(
                "{kz:.3} N/µm ({:+.1} %), from Table 5-1's measured stiffnesses",
                100.0 * (kz / 0.597 - 1.0)
            ),
            values: vec![kz],
            unit: "N/µm",
        },
        within: within_rel(&[kz], &[0.597], 0.05),
        note: None,
        why: "",
        fitted_on: vec!["table_5_1_stiffness"],
        computed: Computed::Live,
        command: "cargo test -p millcomp-sim --test main z_stiffness_at_20_degrees",
    });
    let c: Vec<f64> = [20.0, 30.0, 40.0]
        .iter()
        .map(|&t| st.pzt_compliance_um_per_n(t))
        .collect::<Result<_, _>>()?;
    push(Draft {
        name: "pzt_compliance",
        figure: "PZT compliance at 20/30/40°",
        source: "000 eq. 28",
        published: Published {
            text: "5.17 / 5.75 / 6.57 µm/N",
            values: vec![5.17, 5.75, 6.57],
            unit: "µm/N",
            reach: "±5 % (reconstructed with the measured radial stiffness, sim/tests/common.rs)",
        },
        millcomp: Millcomp {
            text: format!("{:.2} / {:.2} / {:.2} µm/N", c[0], c[1], c[2]),
            values: c.clone(),
            unit: "µm/N",
        },
        within: within_rel(&c, &[5.17, 5.75, 6.57], 0.05),
        note: None,
        why: "",
        fitted_on: vec!["table_5_1_stiffness"],
        computed: Computed::Live,
        command: "cargo test -p millcomp-sim --test main effective_pzt_compliance_eq_28",
    });

    // --- 000 §6.3, §7.2.2: the S7 grooves
    let [g20, g30, g40] = groove_scenarios()?;
    progress("groove_20deg_uncompensated");
    let none20 = pp_um("groove_20deg_uncompensated", &g20, ControllerKind::None)?;
    push(Draft {
        name: "groove_20deg_uncompensated",
        figure: "uncompensated 20° groove",
        source: "000 §6.3, §7.2.2",
        published: Published {
            text: "16–17 µm",
            values: vec![16.0, 17.0],
            unit: "µm",
            reach: GROOVE_REACH,
        },
        millcomp: Millcomp {
            text: format!("{none20:.2} µm"),
            values: vec![none20],
            unit: "µm",
        },
        within: (14.0..=19.0).contains(&none20),
        note: Some("the force scale is set from Fig. 7-6's deep-end deflections"),
        why: "",
        fitted_on: vec!["groove_20deg_uncompensated", "table_5_1_stiffness"],
        computed: Computed::Live,
        command: "millcomp simulate datasets/scenarios/groove_s7_20deg.toml --controller none",
    });
    progress("grooves_30_40deg_uncompensated");
    // the held-out prediction: the force scale fitted on the 20° groove, the 30° and 40° scenarios
    // without their `calibrate_uncompensated_um` (which the controllers' runs keep)
    let uncalibrated = |g: &Scenario| {
        let mut g = g.clone();
        if let Some(gs) = g.groove.as_mut() {
            gs.calibrate_uncompensated_um = None;
        }
        g
    };
    let none30 = pp_um(
        "grooves_30_40deg_uncompensated",
        &uncalibrated(&g30),
        ControllerKind::None,
    )?;
    let none40 = pp_um(
        "grooves_30_40deg_uncompensated",
        &uncalibrated(&g40),
        ControllerKind::None,
    )?;
    push(Draft {
        name: "grooves_30_40deg_uncompensated",
        figure: "uncompensated 30° / 40° grooves",
        source: "000 §7.2.2",
        published: Published {
            text: "≈ 16 µm",
            values: vec![16.0, 16.0],
            unit: "µm",
            reach: GROOVE_REACH,
        },
        millcomp: Millcomp {
            text: format!("{none30:.2} / {none40:.2} µm, predicted from the 20° groove"),
            values: vec![none30, none40],
            unit: "µm",
        },
        within: within_abs(&[none30, none40], &[16.0, 16.0], 2.0),
        note: None,
        why: "larger: the model's force does not fall with tilt while the compliance grows 2.35× \
              from 20° to 40°; 30° not identifiable (a sharp, low-runout tool gives 15.0 µm, the \
              force measured in that cut 17.4 µm), 40° needs 0.48 of the force; the controllers' \
              scenarios stay calibrated to 16 µm: docs/studies/published-grooves.md",
        fitted_on: vec!["groove_20deg_uncompensated", "table_5_1_stiffness"],
        computed: Computed::Live,
        command: "sed /calibrate_uncompensated_um/d datasets/scenarios/groove_s7_30deg.toml > g30.toml \
                  && millcomp simulate g30.toml --controller none",
    });
    progress("groove_20deg_open_loop");
    let ol20 = pp_um("groove_20deg_open_loop", &g20, ControllerKind::OpenLoop)?;
    let (olc, olci) = recorded::OPEN_LOOP_20DEG_UM;
    push(Draft {
        name: "groove_20deg_open_loop",
        figure: "open-loop 20° groove",
        source: "000 §6.3",
        published: Published {
            text: "5 µm",
            values: vec![5.0],
            unit: "µm",
            reach: GROOVE_REACH,
        },
        millcomp: Millcomp {
            text: format!(
                "{ol20:.2} µm; commissioned {olc:.2} [{:.2}, {:.2}] µm",
                olci[0], olci[1]
            ),
            values: vec![ol20, olc],
            unit: "µm",
        },
        within: within_abs(&[ol20, olc], &[5.0, 5.0], 2.0),
        note: None,
        why: "smaller",
        fitted_on: vec![
            "groove_20deg_uncompensated",
            "table_5_1_stiffness",
            "pzt_step_response",
        ],
        computed: Computed::LiveAndRecorded { test: TEST_GROOVES },
        command: "millcomp simulate datasets/scenarios/groove_s7_20deg.toml --controller open-loop",
    });
    let pid = recorded::PID_UM;
    push(Draft {
        name: "published_pid",
        figure: "published PID, 20° / 30° / 40°",
        source: "000 §7.2.2",
        published: Published {
            text: "5 / 3 / 4.8 µm",
            values: vec![5.0, 3.0, 4.8],
            unit: "µm",
            reach: GROOVE_REACH,
        },
        millcomp: Millcomp {
            text: format!(
                "commissioned {:.2} / {:.2} / {:.2} µm",
                pid[0], pid[1], pid[2]
            ),
            values: pid.to_vec(),
            unit: "µm",
        },
        within: within_abs(&pid, &[5.0, 3.0, 4.8], 2.0),
        note: None,
        why: "smaller: docs/studies/controllers.md",
        fitted_on: vec![
            "groove_20deg_uncompensated",
            "grooves_30_40deg_uncompensated",
            "table_5_1_stiffness",
            "pzt_step_response",
        ],
        computed: Computed::Recorded { test: TEST_GROOVES },
        command: "cargo run --release -p millcomp-closedloop --example compare -- --seeds 10 --commissioned",
    });

    // --- 004 Table 5: the thin walls
    progress("thin_walls");
    let tw = scenario(THIN_WALL.0, THIN_WALL.1)?;
    let walls = |kind: ControllerKind| -> Result<Vec<f64>, ClosedLoopError> {
        let r = run_scenario(&tw, kind).map_err(fail("thin_wall_100um_calibration"))?;
        Ok(r.walls
            .unwrap_or_default()
            .iter()
            .map(|w| w.thickness_um)
            .collect())
    };
    let (open, thr) = (
        walls(ControllerKind::None)?,
        walls(ControllerKind::Threshold)?,
    );
    if open.len() != 3 || thr.len() != 3 {
        return Err(ClosedLoopError::Figure {
            name: "thin_wall_100um_calibration",
            source: format!(
                "{} and {} walls reported, 3 expected",
                open.len(),
                thr.len()
            )
            .into(),
        });
    }
    let nominal = [80.0, 100.0, 120.0];
    let mean_pct = (0..3)
        .map(|i| 100.0 * (thr[i] - nominal[i]) / nominal[i])
        .sum::<f64>()
        / 3.0;
    push(Draft {
        name: "thin_wall_100um_calibration",
        figure: "100 µm wall uncompensated; iterative compensation's mean error",
        source: "004 Table 5",
        published: Published {
            text: "106.7 µm; mean 2.19 %",
            values: vec![106.7, 2.19],
            unit: "µm, %",
            reach: "the fitting data",
        },
        millcomp: Millcomp {
            text: format!("{:.2} µm; mean {mean_pct:.2} %", open[1]),
            values: vec![open[1], mean_pct],
            unit: "µm, %",
        },
        within: false,
        note: Some("the wall's force coefficient and the tool's fluted length are set from them"),
        why: "",
        fitted_on: vec!["thin_wall_100um_calibration"],
        computed: Computed::Live,
        command: "millcomp simulate datasets/scenarios/thin_wall_h59.toml --controller threshold",
    });
    push(Draft {
        name: "thin_walls_80_120um_uncompensated",
        figure: "thin walls uncompensated, 80 / 120 µm",
        source: "004 Table 5",
        published: Published {
            text: "85.9 / 127.8 µm",
            values: vec![85.9, 127.8],
            unit: "µm",
            reach: "±2 µm (sim/tests/common.rs THINWALL_ABS_UM)",
        },
        millcomp: Millcomp {
            text: format!("{:.2} / {:.2} µm", open[0], open[2]),
            values: vec![open[0], open[2]],
            unit: "µm",
        },
        within: within_abs(&[open[0], open[2]], &[85.9, 127.8], 2.0),
        note: None,
        why: "",
        fitted_on: vec!["thin_wall_100um_calibration"],
        computed: Computed::Live,
        command: "millcomp simulate datasets/scenarios/thin_wall_h59.toml --controller none",
    });
    push(Draft {
        name: "thin_walls_iterative",
        figure: "thin walls, iterative compensation, 80 / 100 / 120 µm",
        source: "004 Table 5",
        published: Published {
            text: "81.9 / 102.1 / 122.5 µm",
            values: vec![81.9, 102.1, 122.5],
            unit: "µm",
            reach: "±2 µm (sim/tests/common.rs THINWALL_ABS_UM)",
        },
        millcomp: Millcomp {
            text: format!("{:.2} / {:.2} / {:.2} µm", thr[0], thr[1], thr[2]),
            values: thr.clone(),
            unit: "µm",
        },
        within: within_abs(&thr, &[81.9, 102.1, 122.5], 2.0),
        note: None,
        why: "",
        fitted_on: vec!["thin_wall_100um_calibration"],
        computed: Computed::Live,
        command: "millcomp simulate datasets/scenarios/thin_wall_h59.toml --controller threshold",
    });

    // --- 003: the NC feed axis (recorded: ten seeds and a nine-point band)
    let nc_cmd = "cargo run --release -p millcomp-closedloop --example nc_axis_study -- --seeds 10 --band-seeds 3";
    let (rm, rci) = recorded::NC_REACTIVE_REMOVED_PCT;
    push(Draft {
        name: "nc_error_removed",
        figure: "NC axis, error removed at constant conditions",
        source: "003 §3.1",
        published: Published {
            text: "95 %",
            values: vec![95.0],
            unit: "%",
            reach: "inside the 95 % interval of millcomp's median",
        },
        millcomp: Millcomp {
            text: format!("reactive {rm:.2} % [{:.2}, {:.2}]", rci[0], rci[1]),
            values: vec![rm, rci[0], rci[1]],
            unit: "%",
        },
        within: (rci[0]..=rci[1]).contains(&95.0),
        note: None,
        why: "",
        fitted_on: vec![],
        computed: Computed::Recorded { test: TEST_NC },
        command: nc_cmd,
    });
    let [rb, pb] = recorded::NC_BAND_PEAK_UM;
    let [rp, pp] = recorded::NC_PEAK_UM;
    push(Draft {
        name: "nc_reactive_peak",
        figure: "NC feed step, reactive peak",
        source: "003 Fig. 6",
        published: Published {
            text: "74 µm",
            values: vec![74.0],
            unit: "µm",
            reach: "inside millcomp's band over the unpublished machine stiffness × overhang",
        },
        millcomp: Millcomp {
            text: format!(
                "{rp:.2} µm; {:.1}–{:.1} over the stiffness × overhang band",
                rb[0], rb[1]
            ),
            values: vec![rp, rb[0], rb[1]],
            unit: "µm",
        },
        within: (rb[0]..=rb[1]).contains(&74.0),
        note: None,
        why: "",
        fitted_on: vec![],
        computed: Computed::Recorded {
            test: TEST_NC_AND_BAND,
        },
        command: nc_cmd,
    });
    let (qm, qci) = recorded::NC_PROACTIVE_OVER_REACTIVE;
    push(Draft {
        name: "nc_proactive_peak",
        figure: "NC feed step, proactive peak",
        source: "003 Fig. 6",
        published: Published {
            text: "43 µm, 0.58 of the reactive",
            values: vec![43.0, 43.0 / 74.0],
            unit: "µm",
            reach: "the ratio proactive/reactive on one machine (003: 43/74) inside the 95 % interval \
                    of millcomp's per-seed median (the peak alone moves with the unpublished machine)",
        },
        millcomp: Millcomp {
            text: format!(
                "{pp:.2} µm; {:.1}–{:.1} over the band; proactive/reactive {qm:.2} [{:.2}, {:.2}]",
                pb[0], pb[1], qci[0], qci[1]
            ),
            values: vec![pp, pb[0], pb[1], qm, qci[0], qci[1]],
            unit: "µm",
        },
        within: (qci[0]..=qci[1]).contains(&(43.0 / 74.0)),
        note: None,
        why: "smaller; no machine candidate reaches 0.58 and keeps 95 % removed; 003's offset curve \
              not identifiable: docs/studies/published-nc.md",
        fitted_on: vec![],
        computed: Computed::Recorded {
            test: TEST_NC_AND_BAND,
        },
        command: nc_cmd,
    });
    let [over, under] = recorded::NC_RINGING_PCT;
    push(Draft {
        name: "nc_notch_oscillation",
        figure: "NC notch chain: decaying oscillation after the step",
        source: "003 §3.2",
        published: Published {
            text: "visible",
            values: vec![],
            unit: "",
            reach: "visible: taken here as a first overshoot ≥ 5 % of the step",
        },
        millcomp: Millcomp {
            text: format!(
                "{} (overshoot {over} %, undershoot {under} %)",
                if over >= 5.0 {
                    "visible"
                } else {
                    "not visible"
                }
            ),
            values: vec![over, under],
            unit: "% of the step",
        },
        within: over >= 5.0,
        note: None,
        why: "the feed axis smooths the feed step: docs/studies/published-nc.md",
        fitted_on: vec![],
        computed: Computed::Recorded {
            test: "`recorded_nc_ringing_holds`",
        },
        command: nc_cmd,
    });
    let [re, pe] = recorded::NC_EXIT_UNDERSIZE_UM;
    push(Draft {
        name: "nc_exit_undersize",
        figure: "NC exit: reactive and proactive undersize, the slower filter more",
        source: "003 §3.3",
        published: Published {
            text: "undersize",
            values: vec![],
            unit: "",
            reach: "both undersize, proactive (the slower filter) more",
        },
        millcomp: Millcomp {
            text: format!("{re:.0} / {pe:.0} µm undersize"),
            values: vec![re, pe],
            unit: "µm",
        },
        within: re > 0.0 && pe > re,
        note: None,
        why: "",
        fitted_on: vec![],
        computed: Computed::Recorded { test: TEST_NC },
        command: nc_cmd,
    });
    Ok(out)
}

/// Checks the registry's own consistency: names unique and snake_case, every `fitted_on` name in the
/// registry, and no figure in its own `fitted_on` labelled other than "calibrated to".
///
/// # Errors
/// A message naming the first figure at fault.
pub fn check_registry(figs: &[PublishedFigure]) -> Result<(), String> {
    let mut names = BTreeSet::new();
    for f in figs {
        if !f
            .name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        {
            return Err(format!("`{}` is not snake_case", f.name));
        }
        if !names.insert(f.name) {
            return Err(format!("`{}` is listed twice", f.name));
        }
    }
    for f in figs {
        for n in &f.fitted_on {
            if !names.contains(n) {
                return Err(format!("`{}`: fitted_on `{n}` is not a figure", f.name));
            }
        }
        if f.fitted_on.contains(&f.name) && f.label != Label::CalibratedTo {
            return Err(format!(
                "`{}` is in its own fitted_on but labelled {}",
                f.name,
                f.label.as_str()
            ));
        }
        if (f.label == Label::Disagrees) != f.reason.is_some() {
            return Err(format!("`{}`: a reason exactly when it disagrees", f.name));
        }
    }
    Ok(())
}
