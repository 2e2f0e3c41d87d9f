//! What the session plan cannot separate, and the session change that would (issue 15: "a design
//! for the next experiment").
//!
//! The analysis is of the plan, before any data: each family's reference form at its 002 size
//! ([`crate::families`]) is a column of the whitened design (σ_e and σ_g as the session states
//! them); the nuisance columns are the nominal model's five uncertain parameters at their nominal
//! values ([`crate::nuisance`]).
//! * **Aliased with the nuisance**: the share of a family's column that the nuisance columns
//!   explain, `‖P_N b‖²/‖b‖²`, is at least [`thresholds::ALIAS_SHARE`], or the part they do not
//!   explain is below [`thresholds::MIN_UNIQUE_SD`] noise SDs at the 002 size. Such an effect is
//!   named only when it lies beyond the nuisance's prior; the report says how many prior SDs a
//!   002-size effect would be.
//! * **Aliased with each other**: two families whose columns, with the nuisance projected out,
//!   have |cos| ≥ [`thresholds::ALIAS_CORR`] (the correlation of their estimates).
//! * **Proposed change**: for each aliased pair or nuisance-aliased family, a few standard changes
//!   are appended to the plan ([`Change`]: a pause with the spindle stopped or running, the coolant
//!   switched with the spindle stopped or running, a groove at a second X position, upfeed, speed or
//!   tilt), the plan is played out again by sim, and the change that lowers the aliasing most is
//!   proposed, with the value it would reach.
//! * When every family is untestable or aliased with the nuisance, the plan cannot separate any
//!   candidate from the nominal model's uncertainty: the diagnosis says so instead of naming one.

use nalgebra::DMatrix;
use serde::Serialize;

use millcomp_sim::session::{GrooveSpec, PauseSpec, PlanItem, Session};

use crate::families::Family;
use crate::model::{NuisanceSet, orthonormal_basis, project_out};
use crate::nominal::SessionModel;
use crate::nuisance::{self, NuisanceModel};
use crate::scatter::Whitening;
use crate::thresholds;

/// One family as the plan sees it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FamilyPlan {
    /// Effect name.
    pub effect: String,
    /// Whether the plan excites it at all.
    pub testable: bool,
    /// Share of its reference column explained by the nuisance (1 = aliased).
    pub nuisance_share: f64,
    /// The nuisance parameters it is aliased with (|cos| ≥ 0.9 each, or the closest).
    pub aliased_with: Vec<String>,
    /// How many prior SDs a 002-size effect lies beyond the nuisance prior (√ of the χ² drop).
    pub beyond_prior_sd: f64,
    /// The part of a 002-size effect that no nuisance change explains, in noise SDs (√ of its
    /// noncentrality in the whitened data).
    pub unique_sd: f64,
    /// Aliased with the nuisance: share ≥ [`thresholds::ALIAS_SHARE`] or unique part below
    /// [`thresholds::MIN_UNIQUE_SD`].
    pub aliased: bool,
    /// Why it is not testable, or what aliasing means for it.
    pub note: String,
}

/// A proposed change of the session plan and what it would achieve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Proposal {
    /// The change, in words.
    pub change: String,
    /// The aliasing measure after the change (as [`AliasPair::measure`]).
    pub after: f64,
}

/// Two families the plan cannot separate, or one it cannot separate from the nuisance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AliasPair {
    /// First effect.
    pub a: String,
    /// Second effect, or `nominal model (…)` for a nuisance alias.
    pub b: String,
    /// |correlation| of the two estimates; for a nuisance alias, how many noise SDs a 002-size
    /// effect differs from the best nominal-model change.
    pub measure: f64,
    /// The best standard change, when one lowers the aliasing below the threshold.
    pub proposal: Option<Proposal>,
    /// What to do otherwise.
    pub note: String,
}

/// The plan analysis of a session.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanAnalysis {
    /// Per family.
    pub families: Vec<FamilyPlan>,
    /// Aliased pairs and nuisance aliases, with proposals.
    pub aliasing: Vec<AliasPair>,
    /// True when no family is both testable and separable from the nuisance.
    pub cannot_separate_any: bool,
}

/// A standard change appended to a plan.
///
/// Every change ends with the first groove again, as it was cut — its coolant too, so when the plan
/// ends with the coolant in the other state the groove switches it as it starts (the description
/// says so) — except after a coolant switch, which the groove keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// A 30 min pause with the spindle stopped, then the first groove again.
    PauseStopped,
    /// A 30 min pause with the spindle at the plan's top speed, then the first groove again.
    PauseRunning,
    /// The coolant switched (off if it is on at the end, else on) for 45 min, then the first groove
    /// with the coolant as the switch left it.
    CoolantSwitch,
    /// The coolant switched for 45 min with the spindle running at the last groove's speed (so the
    /// switch is not also a speed change), then the first groove.
    CoolantSwitchRunning,
    /// The first groove again at a second machine X position.
    SecondX,
    /// The first groove again at half its upfeed.
    SecondUpfeed,
    /// The first groove again at another speed.
    SecondSpeed,
    /// The first groove again at 20° more tilt.
    SecondTilt,
}

/// All standard changes.
pub const CHANGES: [Change; 8] = [
    Change::PauseStopped,
    Change::PauseRunning,
    Change::CoolantSwitch,
    Change::CoolantSwitchRunning,
    Change::SecondX,
    Change::SecondUpfeed,
    Change::SecondSpeed,
    Change::SecondTilt,
];

impl Change {
    /// The session with the change appended and its description; `None` when it does not apply.
    pub fn apply(self, s: &Session) -> Option<(Session, String)> {
        let (first_item, first) = s.plan.iter().enumerate().find_map(|(i, p)| match p {
            PlanItem::Groove(g) => Some((i, g.clone())),
            PlanItem::Pause(_) => None,
        })?;
        let grooves: Vec<&GrooveSpec> = s
            .plan
            .iter()
            .filter_map(|p| match p {
                PlanItem::Groove(g) => Some(g),
                PlanItem::Pause(_) => None,
            })
            .collect();
        let top = grooves.iter().map(|g| g.speed_rpm).fold(0.0, f64::max);
        let timeline = s.timeline();
        let coolant_end = timeline.coolant_events.last().is_some_and(|e| e.1);
        // the coolant while the first groove was cut (the last switch at or before its start)
        let first_start = timeline.item_start_s[first_item];
        let coolant_first = timeline
            .coolant_events
            .iter()
            .take_while(|e| e.0 <= first_start)
            .last()
            .is_some_and(|e| e.1);
        // The repeated groove is the first groove as it was cut, coolant included, except after
        // a coolant change: there it keeps the coolant as the change left it (with the first
        // groove's own setting it would switch the coolant back as it starts and undo the change).
        let mut g = GrooveSpec {
            start_s: None,
            coolant: Some(coolant_first),
            ..first.clone()
        };
        let mut out = s.clone();
        let repeat = "then cut the first groove again";
        let what = match self {
            Change::PauseStopped => {
                out.plan.push(PlanItem::Pause(PauseSpec {
                    duration_s: 1800.0,
                    speed_rpm: 0.0,
                    coolant: None,
                }));
                format!("a 30 min pause with the spindle stopped, {repeat}")
            }
            Change::PauseRunning => {
                out.plan.push(PlanItem::Pause(PauseSpec {
                    duration_s: 1800.0,
                    speed_rpm: top,
                    coolant: None,
                }));
                format!("a 30 min pause with the spindle at {top:.0} rpm, {repeat}")
            }
            Change::CoolantSwitch => {
                out.plan.push(PlanItem::Pause(PauseSpec {
                    duration_s: 2700.0,
                    speed_rpm: 0.0,
                    coolant: Some(!coolant_end),
                }));
                format!(
                    "the coolant switched {} for 45 min, {repeat}",
                    if coolant_end { "off" } else { "on" }
                )
            }
            Change::CoolantSwitchRunning => {
                let last = grooves.last().map_or(first.speed_rpm, |g| g.speed_rpm);
                out.plan.push(PlanItem::Pause(PauseSpec {
                    duration_s: 2700.0,
                    speed_rpm: last,
                    coolant: Some(!coolant_end),
                }));
                format!(
                    "the coolant switched {} for 45 min with the spindle running at {last:.0} rpm, {repeat}",
                    if coolant_end { "off" } else { "on" }
                )
            }
            Change::SecondX => {
                let x_max = grooves
                    .iter()
                    .map(|g| g.x_offset_mm + g.length_mm)
                    .fold(f64::NEG_INFINITY, f64::max);
                let x_min = grooves
                    .iter()
                    .map(|g| g.x_offset_mm)
                    .fold(f64::INFINITY, f64::min);
                // beyond the range covered, or into its middle when it is already wide
                g.x_offset_mm = if x_max - x_min < 3.0 * first.length_mm {
                    x_max + first.length_mm
                } else {
                    0.5 * (x_min + x_max) - 0.5 * first.length_mm
                };
                format!(
                    "the first groove again at machine X = {:.0} mm",
                    g.x_offset_mm
                )
            }
            Change::SecondUpfeed => {
                let f = first.upfeed();
                g.upfeed_um = Some(0.5 * f);
                g.feed_mm_min = None;
                format!("the first groove again at {:.1} µm/rev", 0.5 * f)
            }
            Change::SecondSpeed => {
                let other = if first.speed_rpm < 20_000.0 {
                    36_000.0
                } else {
                    10_000.0
                };
                g.speed_rpm = other;
                format!("the first groove again at {other:.0} rpm")
            }
            Change::SecondTilt => {
                if first.tilt_deg + 20.0 >= 80.0 {
                    return None;
                }
                g.tilt_deg = first.tilt_deg + 20.0;
                format!("the first groove again at {:.0}° tilt", g.tilt_deg)
            }
        };
        let what = if matches!(self, Change::CoolantSwitch | Change::CoolantSwitchRunning) {
            g.coolant = None;
            what
        } else if coolant_end != coolant_first {
            format!(
                "{what} (with the coolant {}, as the first groove was cut; it is switched as the groove starts)",
                if coolant_first { "on" } else { "off" }
            )
        } else {
            what
        };
        out.plan.push(PlanItem::Groove(g));
        out.validate().ok()?;
        Some((out, what))
    }
}

/// The session with every standard change that applies appended once, in the order of
/// [`CHANGES`], and each change in words: the next experiment that gives every family the
/// variation the standard changes can give it (a design chosen from the changes alone, not from
/// any data). A change that does not apply to the plan so far is left out.
///
/// # Examples
/// ```
/// use millcomp_diagnose::aliasing::{CHANGES, extended_session};
/// let base = millcomp_synthetic::base_session("plan", "the committed cases' plan");
/// let (ext, changes) = extended_session(&base);
/// // the 14 grooves, then each of the eight changes' groove (the 20° first groove takes 40° tilt)
/// assert_eq!(changes.len(), CHANGES.len());
/// let grooves = |s: &millcomp_sim::session::Session| s.contexts().unwrap().points.len() / 21;
/// assert_eq!((grooves(&base), grooves(&ext)), (14, 22));
/// ```
pub fn extended_session(s: &Session) -> (Session, Vec<String>) {
    let mut out = s.clone();
    let mut what = Vec::new();
    for c in CHANGES {
        if let Some((next, w)) = c.apply(&out) {
            out = next;
            what.push(w);
        }
    }
    (out, what)
}

/// Whitened reference column of a family — its first shape at the 002 size and reference
/// parameters, or, where those leave it flat (a speed below the reference onset), at the first
/// grid point that does not — or `None` when no shape responds anywhere (not testable).
fn reference_column(sm: &SessionModel, fam: &Family, w: &Whitening) -> Option<Vec<f64>> {
    // 002's straightness is 5 µm over 90 mm: a bow over a shorter X range is smaller by the
    // square of the ratio
    let scale = if fam.name == "slideway_straightness" {
        (sm.facts.x_span_mm() / 90.0).powi(2)
    } else {
        1.0
    };
    let responds = |b: &[f64]| {
        let max = b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        max > thresholds::ZERO_SENSITIVITY
    };
    let shape = fam.shapes.first()?;
    let phis = std::iter::once(shape.reference_phi()).chain(shape.grid());
    for phi in phis {
        let mut theta: Vec<f64> = shape
            .linear
            .iter()
            .map(|_| shape.reference_coef * scale)
            .collect();
        theta.extend(phi);
        let mut b = shape.offsets(sm, &theta);
        if responds(&b) {
            w.apply(&mut b);
            return Some(b);
        }
    }
    None
}

/// The whitened nuisance columns (data rows only) at the nominal values.
fn nuisance_columns(sm: &SessionModel, nuis: &NuisanceSet, w: &Whitening) -> DMatrix<f64> {
    let nm = NuisanceModel::new(&sm.deflection);
    let n = sm.len();
    let mut x = DMatrix::zeros(n, nuis.free.len());
    let mut col = vec![0.0; n];
    for (j, &k) in nuis.free.iter().enumerate() {
        for (i, c) in col.iter_mut().enumerate() {
            *c = nm.gradient(i, &[0.0; 5])[k];
        }
        w.apply(&mut col);
        x.column_mut(j).copy_from_slice(&col);
    }
    x
}

fn unit(v: &DMatrix<f64>) -> DMatrix<f64> {
    let n = v.norm();
    if n > 0.0 { v / n } else { v.clone() }
}

struct Columns {
    n: DMatrix<f64>,
    qn: DMatrix<f64>,
    b: Vec<Option<DMatrix<f64>>>,
}

fn columns(sm: &SessionModel, families: &[Family], nuis: &NuisanceSet, w: &Whitening) -> Columns {
    let n = nuisance_columns(sm, nuis, w);
    let qn = orthonormal_basis(&n);
    let b = families
        .iter()
        .map(|f| reference_column(sm, f, w).map(|c| DMatrix::from_column_slice(c.len(), 1, &c)))
        .collect();
    Columns { n, qn, b }
}

fn share(c: &Columns, k: usize) -> Option<f64> {
    let b = c.b[k].as_ref()?;
    let tot = b.norm_squared();
    let rest = project_out(&c.qn, b).norm_squared();

    Some(((tot - rest) / tot).clamp(0.0, 1.0))
}

fn pair_corr(c: &Columns, a: usize, b: usize) -> Option<f64> {
    let ba = unit(&project_out(&c.qn, c.b[a].as_ref()?));
    let bb = unit(&project_out(&c.qn, c.b[b].as_ref()?));
    Some((ba.transpose() * bb)[(0, 0)].abs())
}

fn whitening(sm: &SessionModel) -> Whitening {
    let u = &sm.session.uncertainty;
    let groups: Vec<(usize, usize)> = sm.facts.grooves.iter().map(|g| (g.1, g.2)).collect();
    Whitening::new(&groups, u.measurement_sd_um, u.groove_scatter_um)
}

fn untestable_note(name: &str) -> String {
    let why = match name {
        "coolant_thermal_drift" => "the coolant is never switched in this session",
        "spindle_thermal_growth" => "the spindle never turns in this session",
        "slideway_straightness" => "every measured point lies at one machine X",
        "tool_wear" => "the tool never engages (no cut length)",
        "flute_runout" => "no point is engaged with a positive upfeed",
        "machine_compliance" => "the predicted force is zero everywhere",
        _ => "its offset is zero at every measured point",
    };
    format!("not testable on this session: {why} (the effect predicts no change)")
}

/// What to do when no standard change of the groove plan separates `effect` from the nominal
/// model (by the effect: what would measure it directly).
fn outside_plan_note(effect: &str, nuisance: &[String]) -> String {
    let how = match effect {
        "probe_tilt_offset" => {
            "no change of the groove plan separates them: measure the tool length independently — a tool-length correction at the reference tool's contact point (002 §7.4), or a depth reference cut with a second tool"
        }
        "machine_compliance" => {
            "no change of the groove plan separates them: measure the machine's stiffness without the tool's (a load–deflection test on a rigid dummy tool), or commission the tool's stiffness and force model to a tighter prior"
        }
        "flute_runout" => {
            "none of the standard changes separates them: measure the per-flute peak forces (`--forces`), where runout shows as the asymmetry between the two flutes (000 §4)"
        }
        "slideway_straightness" => {
            "none of the standard changes separates them: cut grooves spread over the slideway's X range (002's bow is 5 µm over 90 mm)"
        }
        "tool_wear" => {
            "none of the standard changes separates them: cut more engaged length between measured grooves, or check the tool length before and after (002 §7.5)"
        }
        _ => {
            "none of the standard changes separates them: pauses long enough for the thermal lags (≥ 15 min) with the spindle stopped and running, and the coolant switched"
        }
    };
    format!(
        "{effect} is aliased with the nominal model ({}); {how}",
        nuisance.join(", ")
    )
}

/// Analyses the plan of `sm` for the candidate `families` (module documentation). A changed plan
/// sim cannot play out is not proposed.
pub(crate) fn analyse(sm: &SessionModel, families: &[Family], nuis: &NuisanceSet) -> PlanAnalysis {
    let w = whitening(sm);
    let cols = columns(sm, families, nuis, &w);
    let nuis_names: Vec<&str> = nuis.free.iter().map(|&k| nuisance::NAMES[k]).collect();
    let mut out = Vec::new();
    for (k, fam) in families.iter().enumerate() {
        let Some(b) = cols.b[k].as_ref() else {
            out.push(FamilyPlan {
                effect: fam.name.into(),
                testable: false,
                nuisance_share: 0.0,
                aliased_with: vec![],
                beyond_prior_sd: 0.0,
                unique_sd: 0.0,
                aliased: false,
                note: untestable_note(fam.name),
            });
            continue;
        };
        let sh = share(&cols, k).unwrap_or(0.0);
        let bu = unit(b);
        let mut cosines: Vec<(f64, &str)> = (0..cols.n.ncols())
            .map(|j| {
                let nj = unit(&cols.n.columns(j, 1).into_owned());
                ((bu.transpose() * nj)[(0, 0)].abs(), nuis_names[j])
            })
            .collect();
        cosines.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut with: Vec<String> = cosines
            .iter()
            .filter(|c| c.0 >= 0.9)
            .map(|c| c.1.to_string())
            .collect();
        if with.is_empty() {
            with.extend(cosines.first().map(|c| c.1.to_string()));
        }
        // χ² drop of adding the 002-size column to the nuisance with its prior rows
        let beyond = beyond_prior(&cols, b, nuis);
        let unique = project_out(&cols.qn, b).norm();
        let aliased = sh >= thresholds::ALIAS_SHARE || unique < thresholds::MIN_UNIQUE_SD;
        out.push(FamilyPlan {
            effect: fam.name.into(),
            testable: true,
            nuisance_share: sh,
            aliased_with: if aliased { with.clone() } else { vec![] },
            beyond_prior_sd: beyond,
            unique_sd: unique,
            aliased,
            note: if aliased {
                format!(
                    "aliased with the nominal model's {} (share {:.3}; a 002-size effect differs from a nominal-model change by {:.1} noise SDs): named only beyond their prior; a 002-size effect lies {:.1} prior SDs beyond it",
                    with.join(", "),
                    sh,
                    unique,
                    beyond
                )
            } else {
                String::new()
            },
        });
    }
    // pairs
    let mut pairs: Vec<AliasPair> = Vec::new();
    let sep: Vec<usize> = (0..families.len())
        .filter(|&k| out[k].testable && !out[k].aliased)
        .collect();
    for (ia, &a) in sep.iter().enumerate() {
        for &b in &sep[ia + 1..] {
            let c = pair_corr(&cols, a, b).unwrap_or(0.0);
            if c >= thresholds::ALIAS_CORR {
                pairs.push(AliasPair {
                    a: families[a].name.into(),
                    b: families[b].name.into(),
                    measure: c,
                    proposal: None,
                    note: String::new(),
                });
            }
        }
    }
    for (k, f) in out.iter().enumerate() {
        if f.testable && f.aliased {
            pairs.push(AliasPair {
                a: families[k].name.into(),
                b: format!("nominal model ({})", f.aliased_with.join(", ")),
                measure: f.unique_sd,
                proposal: None,
                note: String::new(),
            });
        }
    }
    if !pairs.is_empty() {
        propose(sm, families, nuis, &mut pairs, &out);
    }
    let cannot = !out.iter().any(|f| f.testable && !f.aliased);
    PlanAnalysis {
        families: out,
        aliasing: pairs,
        cannot_separate_any: cannot,
    }
}

fn beyond_prior(cols: &Columns, b: &DMatrix<f64>, nuis: &NuisanceSet) -> f64 {
    // [N; P] with P the prior rows, b with zeros there: ‖(I − Q Qᵀ) b‖² is the χ² of the
    // reference-size effect once the nuisance has moved as far as its prior lets it
    let x = with_prior_rows(&cols.n, nuis, 0);
    let mut bb = DMatrix::zeros(x.nrows(), 1);
    bb.rows_mut(0, cols.n.nrows()).copy_from(b);
    let q = orthonormal_basis(&x);
    project_out(&q, &bb).norm()
}

/// The whitened nuisance columns `nc` (data rows) with their prior rows below (`1/SD` where a free
/// parameter has a finite prior) and `extra` zero columns after them.
fn with_prior_rows(nc: &DMatrix<f64>, nuis: &NuisanceSet, extra: usize) -> DMatrix<f64> {
    let prior = nuis.prior_rows();
    let (n, p) = (nc.nrows(), nc.ncols());
    let mut x = DMatrix::zeros(n + prior.len(), p + extra);
    x.view_mut((0, 0), (n, p)).copy_from(nc);
    for (r, k) in prior.iter().enumerate() {
        let j = nuis.free.iter().position(|f| f == k).unwrap_or(0);
        x[(n + r, j)] = 1.0 / nuis.sd[*k];
    }
    x
}

/// The session with each standard change that applies and that sim can play out: the change in
/// words and the changed plan's nominal model.
pub(crate) fn changed_plans(sm: &SessionModel) -> Vec<(String, SessionModel)> {
    CHANGES
        .iter()
        .filter_map(|c| {
            let (s, what) = c.apply(&sm.session)?;
            SessionModel::new(&s).ok().map(|m| (what, m))
        })
        .collect()
}

/// How far `offsets` (an effect as fitted, µm at every point of `sm`) lies from the span of
/// `basis` (another family's flexible shape, raw columns) and the nominal model within its
/// prior: the whitened norm of the part they leave, in noise SDs, with the nuisance's prior
/// rows as in [`beyond_prior`] (the plan alone; no data).
pub(crate) fn unique_beyond(
    sm: &SessionModel,
    nuis: &NuisanceSet,
    offsets: &[f64],
    basis: &[Vec<f64>],
) -> f64 {
    let w = whitening(sm);
    let n = sm.len();
    let nc = nuisance_columns(sm, nuis, &w);
    let p = nc.ncols();
    let mut x = with_prior_rows(&nc, nuis, basis.len());
    for (j, b) in basis.iter().enumerate() {
        let mut c = b.clone();
        w.apply(&mut c);
        x.view_mut((0, p + j), (n, 1)).copy_from_slice(&c);
    }
    let mut e = DMatrix::zeros(x.nrows(), 1);
    let mut off = offsets.to_vec();
    w.apply(&mut off);
    e.view_mut((0, 0), (n, 1)).copy_from_slice(&off);
    project_out(&orthonormal_basis(&x), &e).norm()
}

fn propose(
    sm: &SessionModel,
    families: &[Family],
    nuis: &NuisanceSet,
    pairs: &mut [AliasPair],
    plan: &[FamilyPlan],
) {
    let changed: Vec<(String, Columns)> = changed_plans(sm)
        .into_iter()
        .map(|(what, m)| {
            let w = whitening(&m);
            (what, columns(&m, families, nuis, &w))
        })
        .collect();
    let index = |name: &str| families.iter().position(|f| f.name == name);
    for pair in pairs.iter_mut() {
        let Some(a) = index(&pair.a) else { continue };
        let b = index(&pair.b);
        // (proposal, separates, rank: lower is better)
        let mut best: Option<(Proposal, bool, f64)> = None;
        for (what, cols) in &changed {
            let scored = match b {
                Some(b) => pair_corr(cols, a, b).map(|c| (c, c < thresholds::ALIAS_CORR, c)),
                None => share(cols, a).map(|sh| {
                    let unique = cols.b[a]
                        .as_ref()
                        .map_or(0.0, |col| project_out(&cols.qn, col).norm());
                    let ok = sh < thresholds::ALIAS_SHARE && unique >= thresholds::MIN_UNIQUE_SD;
                    (unique, ok, -unique)
                }),
            };
            let Some((after, ok, rank)) = scored else {
                continue;
            };
            let better = match &best {
                None => true,
                Some((_, bok, brank)) => (ok && !bok) || (ok == *bok && rank < *brank),
            };
            if better {
                best = Some((
                    Proposal {
                        change: what.clone(),
                        after,
                    },
                    ok,
                    rank,
                ));
            }
        }
        let best = best.and_then(|(p, ok, _)| ok.then_some(p));
        match best {
            Some(p) => {
                pair.note = match b {
                    Some(_) => format!(
                        "the plan cannot separate {} from {} (their estimates correlate by {:.3}); add {} ({:.3} after)",
                        pair.a, pair.b, pair.measure, p.change, p.after
                    ),
                    None => format!(
                        "the plan cannot separate {} from {}: at its 002 size it differs from a nominal-model change by {:.1} noise SDs; add {} ({:.1} SDs after)",
                        pair.a, pair.b, pair.measure, p.change, p.after
                    ),
                };
                pair.proposal = Some(p);
            }
            _ => {
                pair.note = match b {
                    Some(_) => format!(
                        "the plan cannot separate {} from {} ({:.3}), and none of the standard changes does: run a session in which their drivers ({}; {}) vary independently",
                        pair.a,
                        pair.b,
                        pair.measure,
                        families[a].driver,
                        b.map(|b| families[b].driver).unwrap_or_default()
                    ),
                    None => outside_plan_note(&pair.a, &plan[a].aliased_with),
                };
            }
        }
    }
}
