//! Beyond the candidate list (issue 50): when the candidate rounds end and the final model still
//! leaves significant structure, a term is built from the data — a smooth function of the session
//! variable the residual follows — and added only on evidence.
//!
//! # The term
//! For each session variable ([`VARIABLES`]: the ones [`DiagnoseReport::unexplained`] examines),
//! a flexible basis in it: a clamped cubic B-spline on its range with [`INTERVALS`] knot
//! intervals (4 to 19 columns), or — for a variable with at most [`DISCRETE_LEVELS`] distinct
//! values (coolant state, tilt, upfeed, a plan's few speeds) — one column per value (any function
//! of a discrete variable). The basis is whitened in the model's GLS metric (random groove
//! offset) and fitted jointly with the current model's linearisation (nuisance, named effects):
//! its evidence is what the current model cannot already fit.
//!
//! **Flexibility by leave-one-groove-out cross-validation.** Per variable, the number of knot
//! intervals is the one whose model predicts held-out grooves best ([`crate::logo`]: refitted
//! without each groove, the groove predicted with its own offset unknown — the score every
//! candidate's acceptance already uses). A spline in the session clock or the engaged length
//! with more intervals than there are grooves could otherwise follow each groove's random offset:
//! such a term fits the offsets of the grooves it sees and predicts nothing of a groove it does
//! not, so cross-validation does not choose it.
//!
//! **What the groove offset can absorb is not evidence.** The test is the candidates' GLS F-test
//! with the information split into strata ([`crate::nested`]): the part of the term that lies
//! between grooves is judged against the between-groove residual variance — groove scatter
//! included, with the grooves' few degrees of freedom — not against the measurement noise. The
//! report gives that share (`between_share`).
//!
//! **Accepted only on evidence.** The variable with the smallest p (its basis chosen by
//! cross-validation) is added when (1) p is below the family-wise threshold of this search: the α
//! quantile of the smallest p over **every** variable and every flexibility tried, under the null
//! that the current model is right, simulated as each round's ([`crate::familywise`], every basis
//! its own family, so no choice between them is credited); the reported p is that of one basis of
//! the grid, never smaller than the grid's smallest, so the chance that it passes under the null
//! is at most α; Bonferroni's α over the bases with `Multiplicity::Bonferroni`; (2) the model
//! with it predicts held-out grooves better; (3) its amplitude exceeds the measurement's
//! resolution. A basis that would leave fewer than `MIN_RESIDUAL_DOF` residual degrees of
//! freedom is not tried, nor any with fewer than [`MIN_GROOVES`] grooves. Then it is added (the model refitted with it, twice alternating) and the search
//! repeated for a second variable, at most [`MAX_TERMS`].
//!
//! [`DiagnoseReport::unexplained`]: crate::DiagnoseReport::unexplained

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use millcomp_sim::session::PointContext;

use crate::families::bspline_basis;
use crate::familywise::{NullBlock, NullShape};
use crate::logo;
use crate::model::{Fitted, orthonormal_basis, project_out, strata_of_columns};
use crate::nested::{StrataTest, StrataVariance, strata_test};
use crate::report::Logo;
use crate::scatter::Whitening;
use crate::thresholds;

/// A session variable: its name and its value at a point.
pub type Variable = (&'static str, fn(&PointContext) -> f64);

/// The session variables a residual is examined against (the unexplained correlations' and the
/// unlisted term's).
pub const VARIABLES: [Variable; 10] = [
    ("t_s", |p| p.t_s),
    ("cut_length_mm", |p| p.cut_length_mm),
    ("x_mm", |p| p.x_mm),
    ("machine_x_mm", |p| p.machine_x_mm),
    ("speed_rpm", |p| p.speed_rpm),
    ("coolant_on", |p| f64::from(u8::from(p.coolant_on))),
    ("force_z_n", |p| p.force_z_n),
    ("tilt_deg", |p| p.tilt_deg),
    ("upfeed_um", |p| p.upfeed_um),
    ("depth_cmd_um", |p| p.depth_cmd_um),
];

/// The session variables each family's driver is a function of (the variables a named effect's
/// shape can misfit along): a term in one of them beside that named effect is reported as
/// possibly its shape's misfit ([`UnlistedTerm::driver_of`]).
pub const DRIVER_VARIABLES: [(&str, &[&str]); 7] = [
    ("coolant_thermal_drift", &["coolant_on", "t_s"]),
    ("spindle_thermal_growth", &["speed_rpm", "t_s"]),
    ("probe_tilt_offset", &[]),
    ("tool_wear", &["cut_length_mm"]),
    ("slideway_straightness", &["machine_x_mm"]),
    ("machine_compliance", &["force_z_n", "machine_x_mm"]),
    (
        "flute_runout",
        &["depth_cmd_um", "upfeed_um", "cut_length_mm", "speed_rpm"],
    ),
];

/// The named effects whose driver is a function of `variable` ([`DRIVER_VARIABLES`]).
pub(crate) fn driver_of(variable: &str, named: &[&str]) -> Vec<String> {
    DRIVER_VARIABLES
        .iter()
        .filter(|(f, vars)| named.contains(f) && vars.contains(&variable))
        .map(|(f, _)| (*f).to_string())
        .collect()
}

/// The knot intervals of the cubic B-spline tried per continuous variable (a cubic polynomial at
/// 1; 16 intervals follow a periodic error of 3–4 periods over the range with ≈ 5 intervals per
/// period). Chosen per variable by leave-one-groove-out cross-validation.
pub const INTERVALS: [usize; 5] = [1, 2, 4, 8, 16];

/// A variable with at most this many distinct values gets one column per value (any function of
/// it) instead of a spline: a cubic spline through ≤ 8 values has no fewer free parameters.
pub const DISCRETE_LEVELS: usize = 8;

/// At most this many unlisted terms are added (the study's sessions hide at most two effects).
pub const MAX_TERMS: usize = 2;

/// Points of the shape table over the variable's range.
pub const SHAPE_POINTS: usize = 9;

/// One point of an unlisted term's shape.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapePoint {
    /// The variable's value.
    pub value: f64,
    /// The term's depth offset there (µm; its mean over the measured points is 0 — a constant is
    /// the touch-off's).
    pub offset_um: f64,
}

/// A flexibility tried for the chosen variable, with its cross-validation score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Flexibility {
    /// `spline_<m>` (cubic B-spline, m knot intervals) or `levels_<k>` (one column per value).
    pub basis: String,
    /// Free parameters beyond the current model.
    pub dof: usize,
    /// Leave-one-groove-out score of the model with it (whitened squared prediction errors).
    pub logo: f64,
}

/// A term built from the data ([module documentation](self)).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnlistedTerm {
    /// The session variable it follows.
    pub variable: String,
    /// The basis chosen by cross-validation.
    pub basis: String,
    /// Its free parameters beyond the current model (F numerator dof).
    pub dof: usize,
    /// Every flexibility tried for this variable, with its cross-validation score.
    pub flexibility: Vec<Flexibility>,
    /// The GLS F-test with strata beyond the current model.
    pub test: StrataTest,
    /// `test.p_value`.
    pub p_value: f64,
    /// The search's family-wise threshold (simulated or Bonferroni's, `correction`).
    pub threshold: f64,
    /// α over the bases tried (Bonferroni's threshold, for comparison).
    pub bonferroni_threshold: f64,
    /// Bases tried over every variable.
    pub bases_tried: usize,
    /// Share of its information between grooves (judged against the groove scatter).
    pub between_share: f64,
    /// Leave-one-groove-out scores without and with it (whitened).
    pub logo: Logo,
    /// Held-out-groove RMS prediction error (µm) without and with it.
    pub held_out_rms_um: [f64; 2],
    /// RMS residual before and after it is added (µm).
    pub rms_before_um: f64,
    /// RMS residual after it is added (µm).
    pub rms_after_um: f64,
    /// Largest minus smallest offset at a measured point (µm).
    pub amplitude_um: f64,
    /// The function over the variable's range ([`SHAPE_POINTS`] points, or every level).
    pub shape: Vec<ShapePoint>,
    /// Named effects whose driver is a function of this variable: the term may be what their
    /// shapes miss (a kink in a straightness no bow, cubic or spline of the family follows)
    /// rather than a further effect. Empty when it follows a variable no named effect drives.
    pub driver_of: Vec<String>,
}

/// A basis of one variable.
#[derive(Debug, Clone)]
pub(crate) enum Basis {
    /// Cubic B-spline with this many intervals on `[lo, hi]`.
    Spline { m: usize, lo: f64, hi: f64 },
    /// One column per value.
    Levels(Vec<f64>),
}

impl Basis {
    fn name(&self) -> String {
        match self {
            Basis::Spline { m, .. } => format!("spline_{m}"),
            Basis::Levels(v) => format!("levels_{}", v.len()),
        }
    }

    /// The basis values at `v`.
    fn at(&self, v: f64) -> Vec<f64> {
        match self {
            Basis::Spline { m, lo, hi } => {
                let u = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
                bspline_basis(u, *m)
            }
            Basis::Levels(levels) => levels
                .iter()
                .map(|l| f64::from(u8::from((v - l).abs() <= level_tol(levels))))
                .collect(),
        }
    }

    /// Raw columns at the values `x`.
    fn columns(&self, x: &[f64]) -> Vec<Vec<f64>> {
        let rows: Vec<Vec<f64>> = x.iter().map(|&v| self.at(v)).collect();
        let k = rows.first().map_or(0, Vec::len);
        (0..k)
            .map(|j| rows.iter().map(|r| r[j]).collect())
            .collect()
    }

    /// Where the shape table evaluates the term.
    fn table_points(&self) -> Vec<f64> {
        match self {
            Basis::Spline { lo, hi, .. } => (0..SHAPE_POINTS)
                .map(|k| lo + (hi - lo) * k as f64 / (SHAPE_POINTS - 1) as f64)
                .collect(),
            Basis::Levels(v) => v.clone(),
        }
    }
}

fn level_tol(levels: &[f64]) -> f64 {
    let span = levels.last().unwrap_or(&0.0) - levels.first().unwrap_or(&0.0);
    1e-9 * span.abs().max(1.0)
}

/// The bases tried for a variable with values `x` (none when it is constant).
pub(crate) fn bases(x: &[f64]) -> Vec<Basis> {
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // constant (or empty, or NaN: the measured points are checked finite before)
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return Vec::new();
    }
    let tol = 1e-9 * (hi - lo).max(1.0);
    let mut sorted = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mut levels: Vec<f64> = Vec::new();
    for v in sorted {
        if levels.last().is_none_or(|l| v - l > tol) {
            levels.push(v);
        }
        if levels.len() > DISCRETE_LEVELS {
            break;
        }
    }
    if levels.len() <= DISCRETE_LEVELS {
        return vec![Basis::Levels(levels)];
    }
    INTERVALS
        .iter()
        .map(|&m| Basis::Spline { m, lo, hi })
        .collect()
}

/// What the search needs of the current model.
pub(crate) struct Context<'a> {
    /// Points of the session.
    pub pts: &'a [PointContext],
    /// The whitening of the rounds.
    pub w: &'a Whitening,
    /// Rows of the whitened problem (data then prior rows).
    pub rows: usize,
    /// Residual variances per stratum of a model (orthonormal basis, residual).
    pub variance: &'a dyn Fn(&DMatrix<f64>, &DVector<f64>) -> StrataVariance,
}

/// One basis of one variable, linearised beyond the current model.
pub(crate) struct Tried {
    /// Index into [`VARIABLES`].
    pub var: usize,
    pub basis: Basis,
    /// Whitened columns (rows: data then prior rows, prior rows zero).
    pub b: DMatrix<f64>,
    /// Raw columns.
    pub raw: Vec<Vec<f64>>,
    /// Rank beyond the current model.
    pub dof: usize,
    /// Drop of the whitened RSS.
    pub drop: f64,
    /// LOGO score with it.
    pub logo: f64,
    /// The test.
    pub test: StrataTest,
    /// The whitened residual of the joint linear fit.
    pub r1: DVector<f64>,
    /// The joint design `[X | B]`.
    pub xa: DMatrix<f64>,
}

impl Tried {
    /// The basis's name (`spline_8`, `levels_3`).
    pub fn basis_name(&self) -> String {
        self.basis.name()
    }

    /// The same basis beside another fit of the model (its joint design `[X | B]` rebuilt).
    pub fn rebased(&self, cur: &Fitted) -> Tried {
        let mut xa = DMatrix::zeros(self.b.nrows(), cur.x.ncols() + self.b.ncols());
        xa.columns_mut(0, cur.x.ncols()).copy_from(&cur.x);
        xa.columns_mut(cur.x.ncols(), self.b.ncols())
            .copy_from(&self.b);
        Tried {
            var: self.var,
            basis: self.basis.clone(),
            b: self.b.clone(),
            raw: self.raw.clone(),
            dof: self.dof,
            drop: self.drop,
            logo: self.logo,
            test: self.test,
            r1: self.r1.clone(),
            xa,
        }
    }
}

/// The search needs at least this many grooves: with fewer, leaving one out leaves at most one
/// to refit from, and the held-out criterion cannot tell a function of the variable from the
/// grooves' offsets.
pub const MIN_GROOVES: usize = 3;

/// Every variable's cross-validated basis, tested beyond `cur`, and the null blocks of every
/// basis tried (for the family-wise threshold). `skip`: variables already given a term.
pub(crate) fn search(
    ctx: &Context<'_>,
    cur: &Fitted,
    skip: &[usize],
) -> (Vec<(Tried, Vec<Flexibility>)>, Vec<NullShape>) {
    let n = ctx.pts.len();
    let q0 = orthonormal_basis(&cur.x);
    let r = &cur.r;
    let rcol = DMatrix::from_column_slice(r.len(), 1, r.as_slice());
    let mut out = Vec::new();
    let mut null = Vec::new();
    if ctx.w.n_groups() < MIN_GROOVES {
        return (out, null);
    }
    for (vi, (_, get)) in VARIABLES.iter().enumerate() {
        if skip.contains(&vi) {
            continue;
        }
        let x: Vec<f64> = ctx.pts.iter().map(get).collect();
        let mut best: Option<Tried> = None;
        let mut flex = Vec::new();
        for basis in bases(&x) {
            let raw = basis.columns(&x);
            let mut b = DMatrix::zeros(ctx.rows, raw.len());
            for (j, c) in raw.iter().enumerate() {
                let mut c = c.clone();
                ctx.w.apply(&mut c);
                b.column_mut(j).rows_mut(0, n).copy_from_slice(&c);
            }
            let qb = orthonormal_basis(&project_out(&q0, &b));
            let dof = qb.ncols();
            // as a candidate's shape: at least MIN_RESIDUAL_DOF residual dof must remain
            if dof == 0 || n < cur.x.ncols() + dof + thresholds::MIN_RESIDUAL_DOF {
                continue;
            }
            let mut xa = DMatrix::zeros(ctx.rows, cur.x.ncols() + b.ncols());
            xa.columns_mut(0, cur.x.ncols()).copy_from(&cur.x);
            xa.columns_mut(cur.x.ncols(), b.ncols()).copy_from(&b);
            let qa = orthonormal_basis(&xa);
            let r1m = project_out(&qa, &rcol);
            let r1 = DVector::from_column_slice(r1m.as_slice());
            // the drop of the linearised joint fit: what the basis explains beyond the current
            // model's columns (the current residual is orthogonal to them at convergence)
            let drop = (project_out(&q0, &rcol).norm_squared() - r1.norm_squared()).max(0.0);
            let score = logo::score(ctx.w, &xa, &r1);
            let s = strata_of_columns(ctx.w, &qb, n);
            let tot = (s[0] + s[1] + s[2]).max(1e-300);
            let v = (ctx.variance)(&qa, &r1);
            let test = strata_test(drop, dof, [s[0] / tot, s[1] / tot, s[2] / tot], &v);
            null.push(NullShape {
                family: null.len(),
                params: dof,
                blocks: vec![NullBlock::Free(qb)],
            });
            flex.push(Flexibility {
                basis: basis.name(),
                dof,
                logo: score,
            });
            if best.as_ref().is_none_or(|t| score < t.logo) {
                best = Some(Tried {
                    var: vi,
                    basis,
                    b,
                    raw,
                    dof,
                    drop,
                    logo: score,
                    test,
                    r1,
                    xa,
                });
            }
        }
        if let Some(t) = best {
            out.push((t, flex));
        }
    }
    (out, null)
}

/// The raw offsets (µm) of the basis `t` fitted jointly with `cur`'s linearisation (min-norm
/// least squares of `[X | B]·δ = −r`), and its coefficients.
pub(crate) fn offsets(t: &Tried, cur: &Fitted) -> (Vec<f64>, Vec<f64>) {
    let p0 = cur.x.ncols();
    let svd = t.xa.clone().svd(true, true);
    let smax = svd.singular_values.iter().fold(0.0f64, |m, v| m.max(*v));
    let rhs = -&cur.r;
    let delta = svd
        .solve(&rhs, 1e-10 * smax.max(1e-300))
        .unwrap_or_else(|_| DVector::zeros(t.xa.ncols()));
    let beta: Vec<f64> = delta.iter().skip(p0).copied().collect();
    let n = t.raw.first().map_or(0, Vec::len);
    let s = (0..n)
        .map(|i| t.raw.iter().zip(&beta).map(|(c, b)| c[i] * b).sum())
        .collect();
    (s, beta)
}

/// The shape table of basis `basis` with coefficients `beta`, less `mean` (the term's mean over
/// the measured points).
pub(crate) fn shape_table(basis: &Basis, beta: &[f64], mean: f64) -> Vec<ShapePoint> {
    basis
        .table_points()
        .into_iter()
        .map(|v| ShapePoint {
            value: v,
            offset_um: basis
                .at(v)
                .iter()
                .zip(beta)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                - mean,
        })
        .collect()
}

/// Whether a basis beyond the current model is accepted: significant at the family-wise
/// threshold, better on held-out grooves, larger than the resolution.
pub(crate) fn accepts(
    test: &StrataTest,
    threshold: f64,
    l: Logo,
    amplitude_um: f64,
    resolution_um: f64,
) -> Result<(), String> {
    if test.p_value >= threshold {
        Err(format!(
            "not significant (p = {:.2e} ≥ {threshold:.2e})",
            test.p_value
        ))
    } else if l.after >= l.before {
        Err("significant but does not improve the prediction of held-out grooves".into())
    } else if amplitude_um <= resolution_um {
        Err(format!(
            "significant but its amplitude {amplitude_um:.3} µm is within the measurement resolution ({resolution_um} µm)"
        ))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_discrete_variable_gets_one_column_per_value_and_a_continuous_one_splines() {
        let b = bases(&[1.0, 2.0, 2.0, 1.0, 3.0]);
        assert_eq!(b.len(), 1);
        assert_eq!(b[0].name(), "levels_3");
        // each value's column is its indicator: the columns sum to one at every point
        let cols = b[0].columns(&[1.0, 2.0, 3.0]);
        assert_eq!(
            cols,
            vec![
                vec![1.0, 0.0, 0.0],
                vec![0.0, 1.0, 0.0],
                vec![0.0, 0.0, 1.0]
            ]
        );
        let x: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.25).collect();
        let b = bases(&x);
        let names: Vec<String> = b.iter().map(Basis::name).collect();
        assert_eq!(
            names,
            ["spline_1", "spline_2", "spline_4", "spline_8", "spline_16"]
        );
        // m intervals: m + 3 cubic B-splines
        assert_eq!(b[3].columns(&x).len(), 11);
        assert!(bases(&[2.0; 5]).is_empty());
    }

    #[test]
    fn a_term_in_a_named_effects_driver_is_flagged_and_every_family_has_an_entry() {
        assert_eq!(
            driver_of("machine_x_mm", &["tool_wear", "slideway_straightness"]),
            vec!["slideway_straightness".to_string()]
        );
        assert!(driver_of("x_mm", &["slideway_straightness"]).is_empty());
        let names: Vec<&str> = crate::families::standard().iter().map(|f| f.name).collect();
        let listed: Vec<&str> = DRIVER_VARIABLES.iter().map(|(f, _)| *f).collect();
        assert_eq!(names, listed);
        for (_, vars) in DRIVER_VARIABLES {
            assert!(vars.iter().all(|v| VARIABLES.iter().any(|(n, _)| n == v)));
        }
    }
}
