//! Candidate effects as **families**: each effect is defined by what drives it and a small set of
//! flexible shapes (issue 15), not by one curve. A shape is linear in its coefficients (µm, µm/N)
//! and may have nonlinear parameters (time constants, onsets, exponents) searched on a grid and
//! then refined; `diagnose` picks the shape of a family by a BIC in the GLS metric and says which in
//! its report.
//!
//! | family (effect) | driver | shapes (coefficients; nonlinear parameters) |
//! |---|---|---|
//! | `coolant_thermal_drift` | coolant state history | `one_lag` (amplitude; τ), `two_lag` (fast, slow; τ_fast, τ_slow) — the fast reaction and slow drift of 002 §4.7, `dead_time_lag` (amplitude; τ, dead time) — the coolant reaching the column late |
//! | `spindle_thermal_growth` | spindle speed history | `onset_one_lag` (growth at 50 000 rpm; onset, τ) — sim's form, `onset_two_lag` (fast, slow; onset, τ_fast, τ_slow), `quadratic_one_lag` (growth at 50 000 rpm with gain ∝ rpm²; τ) |
//! | `probe_tilt_offset` | one constant per tool | `constant` (offset) |
//! | `tool_wear` | engaged length, monotone | `saturating` (max wear ≥ 0; L0) — sim's form, `power_law` (wear at the end ≥ 0; exponent), `running_in_linear` (running-in wear ≥ 0, steady wear at the end ≥ 0; running-in length), `monotone_spline` (a non-decreasing cubic spline in engaged length, knots at sixths, eight coefficients ≥ 0: a wear of any onset and curvature) |
//! | `slideway_straightness` | machine X, smooth, zero at the start of the X range | `bow` (amplitude) — sim's parabola, `cubic` (three polynomial coefficients), `spline` (eight cubic B-spline coefficients, knots every 1/6 of the range) |
//! | `machine_compliance` | peak force | `constant` (compliance ≥ 0), `x_linear` (compliance at X start and its change over the range), `x_spline` (the compliance a cubic B-spline along X, knots at sixths of the range, as the straightness's `spline` — a stiffness that varies with the axis position), `preload` (compliance ≥ 0 beyond a preload; the preload as a share of the session's largest force) — a joint that gives once its preload is overcome |
//! | `flute_runout` | chip asymmetry of the two flutes | `constant` (runout; sim's form), `growing` (runout at the start and its growth over the session's engaged length), `speed_dependent` (runout at rest and its growth ∝ rpm², dynamic unbalance), `depth_dependent` (runout and its change at 80 µm depth: a chip asymmetry that changes with the depth cut) |
//!
//! The first shape of each family is its **reference** form (sim's effect); the plan analysis
//! ([`crate::aliasing`]) uses it at its reference parameters (002's values).

use millcomp_sim::effects::{EffectContext, FluteRunout, first_order_response};

use crate::nominal::{SessionFacts, SessionModel};

/// A nonlinear parameter of a shape: bounds and the grid its search starts from.
#[derive(Debug, Clone, PartialEq)]
pub struct NonlinearParam {
    /// Name (with unit).
    pub name: &'static str,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// Grid of the search (strictly inside the bounds).
    pub grid: Vec<f64>,
    /// Reference value (002's) for the plan analysis.
    pub reference: f64,
}

/// How a shape is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShapeKind {
    /// Σ_k A_k·lag(τ_k) of the coolant state (one column per lag).
    CoolantLags(usize),
    /// A·lag(τ) of the coolant state delayed by a dead time.
    CoolantDeadTime,
    /// Σ_k G_k·lag(τ_k) of the steady growth ((rpm − onset)/(50 000 − onset))₊.
    SpindleOnsetLags(usize),
    /// G·lag(τ) of (rpm/50 000)².
    SpindleQuadratic,
    /// A constant.
    Constant,
    /// −W·(1 − exp(−L/L0)).
    WearSaturating,
    /// −W·(L/L_end)^k.
    WearPower,
    /// −W₁·(1 − exp(−L/L₁)) − W₂·L/L_end: running-in, then steady wear.
    WearRunningIn,
    /// −Σ_j c_j·C_j(L/L_end), c_j ≥ 0, with C_j the tail sums of the clamped cubic B-splines on `n`
    /// equal intervals of the engaged length (j ≥ 1): a wear that never decreases and is zero at
    /// L = 0, with no fixed onset or curvature.
    WearMonotoneSpline(usize),
    /// a·4u(1 − u), u = (X − X_start)/(X_end − X_start).
    Bow,
    /// b₁u + b₂u² + b₃u³.
    Cubic,
    /// Clamped cubic B-splines on `n` equal intervals of the X range, without the first (so the
    /// shape is zero at the start).
    Spline(usize),
    /// −c·F.
    ComplianceConstant,
    /// −(c₀ + c₁u)·F.
    ComplianceXLinear,
    /// −c(u)·F with c(u) a cubic B-spline in X with this many knot intervals.
    ComplianceXSpline(usize),
    /// −c·(F − b·F_max)₊: a joint that gives once its preload b·F_max is overcome.
    CompliancePreload,
    /// sim's flute runout with runout r (a fixed column, no coefficient).
    RunoutConstant,
    /// sim's flute runout with runout r₀ + r₁·L/L_end (fixed column).
    RunoutGrowing,
    /// sim's flute runout with runout r₀ + r₂·(rpm/50 000)² (fixed column).
    RunoutSpeed,
    /// sim's flute runout with runout r₀ + r₁·d/80 µm, d the depth cut (fixed column).
    RunoutDepth,
}

/// One shape of a family.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// Shape name (reported in `--json`).
    pub name: &'static str,
    /// One line on the shape.
    pub description: &'static str,
    /// Names (with unit) of the linear coefficients.
    pub linear: Vec<&'static str>,
    /// Nonlinear parameters.
    pub nonlinear: Vec<NonlinearParam>,
    /// How it is evaluated.
    pub kind: ShapeKind,
    /// For shapes whose coefficients have a physical sign (wear shortens the tool, compliance
    /// adds deflection): every coefficient must be ≥ 0.
    pub nonnegative: bool,
    /// Reference coefficient (002's magnitude) for the plan analysis.
    pub reference_coef: f64,
}

impl Shape {
    /// Number of free parameters.
    pub fn n_params(&self) -> usize {
        self.linear.len() + self.nonlinear.len()
    }

    /// Whether the shape has a fixed column (no linear coefficient).
    pub fn is_fixed(&self) -> bool {
        self.linear.is_empty()
    }

    /// Parameter names: the coefficients, then the nonlinear parameters.
    pub fn param_names(&self) -> Vec<&'static str> {
        self.linear
            .iter()
            .copied()
            .chain(self.nonlinear.iter().map(|p| p.name))
            .collect()
    }

    /// Reference nonlinear parameters.
    pub fn reference_phi(&self) -> Vec<f64> {
        self.nonlinear.iter().map(|p| p.reference).collect()
    }

    /// The grid of nonlinear parameters (cartesian product; for lags in pairs, τ_fast < τ_slow).
    pub fn grid(&self) -> Vec<Vec<f64>> {
        let mut grid: Vec<Vec<f64>> = vec![Vec::new()];
        for p in &self.nonlinear {
            grid = grid
                .into_iter()
                .flat_map(|g| {
                    p.grid.iter().map(move |&v| {
                        let mut g = g.clone();
                        g.push(v);
                        g
                    })
                })
                .collect();
        }
        let ordered = |g: &Vec<f64>, a: usize| g[a] < g[a + 1];
        match self.kind {
            ShapeKind::CoolantLags(2) => grid.retain(|g| ordered(g, 0)),
            ShapeKind::SpindleOnsetLags(2) => grid.retain(|g| ordered(g, 1)),
            _ => {}
        }
        grid
    }

    /// The shape's columns at every point for nonlinear parameters `phi`: one per coefficient,
    /// or, for a fixed shape, the one column that enters with coefficient 1.
    pub fn columns(&self, sm: &SessionModel, phi: &[f64]) -> Vec<Vec<f64>> {
        self.columns_with(sm, &sm.facts, phi)
    }

    /// [`Self::columns`] at the points of `sm` with the facts `f` the shape is scaled by (the X
    /// range, the engaged length at the end, the largest force, the coolant and spindle histories) —
    /// those of another session, e.g. the one a shape was fitted on ([`crate::fitted`]).
    pub fn columns_with(&self, sm: &SessionModel, f: &SessionFacts, phi: &[f64]) -> Vec<Vec<f64>> {
        let pts = sm.points();
        let n = pts.len();
        let lag = |events: &[(f64, f64)], tau: f64| lag_column(pts, events, tau);
        let u = |x: f64| f.along_x(x);
        match self.kind {
            ShapeKind::CoolantLags(k) => (0..k).map(|j| lag(&f.coolant_events, phi[j])).collect(),
            ShapeKind::CoolantDeadTime => {
                let ev: Vec<(f64, f64)> = f
                    .coolant_events
                    .iter()
                    .map(|(t, on)| (t + phi[1], *on))
                    .collect();
                vec![lag(&ev, phi[0])]
            }
            ShapeKind::SpindleOnsetLags(k) => {
                let onset = phi[0];
                let ev: Vec<(f64, f64)> = f
                    .spindle_events
                    .iter()
                    .map(|(t, rpm)| (*t, ((rpm - onset) / (50_000.0 - onset)).max(0.0)))
                    .collect();
                (0..k).map(|j| lag(&ev, phi[1 + j])).collect()
            }
            ShapeKind::SpindleQuadratic => {
                let ev: Vec<(f64, f64)> = f
                    .spindle_events
                    .iter()
                    .map(|(t, rpm)| (*t, (rpm / 50_000.0).powi(2)))
                    .collect();
                vec![lag(&ev, phi[0])]
            }
            ShapeKind::Constant => vec![vec![1.0; n]],
            ShapeKind::WearSaturating => vec![
                pts.iter()
                    .map(|p| -(1.0 - (-p.cut_length_mm.max(0.0) / phi[0]).exp()))
                    .collect(),
            ],
            ShapeKind::WearPower => vec![
                pts.iter()
                    .map(|p| -(p.cut_length_mm.max(0.0) / f.end_mm.max(1e-9)).powf(phi[0]))
                    .collect(),
            ],
            ShapeKind::WearRunningIn => vec![
                pts.iter()
                    .map(|p| -(1.0 - (-p.cut_length_mm.max(0.0) / phi[0]).exp()))
                    .collect(),
                pts.iter()
                    .map(|p| -p.cut_length_mm.max(0.0) / f.end_mm.max(1e-9))
                    .collect(),
            ],
            ShapeKind::WearMonotoneSpline(m) => {
                // B_1 … B_{m+2} (B_0 is the only one not zero at L = 0)
                let b = spline_columns(
                    pts,
                    |p| p.cut_length_mm.max(0.0) / f.end_mm.max(1e-9),
                    m,
                    1..m + 3,
                    |_| -1.0,
                );
                // their tail sums B_j + … + B_{m+2}: non-decreasing in L, zero at L = 0
                (0..b.len())
                    .map(|j| {
                        (0..pts.len())
                            .map(|i| b[j..].iter().map(|col| col[i]).sum())
                            .collect()
                    })
                    .collect()
            }
            ShapeKind::Bow => vec![
                pts.iter()
                    .map(|p| {
                        let v = u(p.machine_x_mm);
                        4.0 * v * (1.0 - v)
                    })
                    .collect(),
            ],
            ShapeKind::Cubic => (1..=3)
                .map(|k| pts.iter().map(|p| u(p.machine_x_mm).powi(k)).collect())
                .collect(),
            ShapeKind::Spline(m) => {
                spline_columns(pts, |p| u(p.machine_x_mm), m, 1..m + 3, |_| 1.0)
            }
            ShapeKind::ComplianceConstant => vec![pts.iter().map(|p| -p.force_z_n).collect()],
            ShapeKind::ComplianceXLinear => vec![
                pts.iter().map(|p| -p.force_z_n).collect(),
                pts.iter()
                    .map(|p| -p.force_z_n * u(p.machine_x_mm))
                    .collect(),
            ],
            ShapeKind::ComplianceXSpline(m) => {
                spline_columns(pts, |p| u(p.machine_x_mm), m, 0..m + 3, |p| -p.force_z_n)
            }
            ShapeKind::CompliancePreload => {
                let f0 = phi[0] * f.max_force_n;
                vec![pts.iter().map(|p| -(p.force_z_n - f0).max(0.0)).collect()]
            }
            ShapeKind::RunoutConstant => vec![runout_column(sm, |_| phi[0])],
            ShapeKind::RunoutGrowing => vec![runout_column(sm, |c| {
                phi[0] + phi[1] * c.cut_length_mm.max(0.0) / f.end_mm.max(1e-9)
            })],
            ShapeKind::RunoutSpeed => vec![runout_column(sm, |c| {
                phi[0] + phi[1] * (c.speed_rpm / 50_000.0).powi(2)
            })],
            ShapeKind::RunoutDepth => vec![runout_column(sm, |c| {
                phi[0] + phi[1] * c.depth_actual_um.max(0.0) / 80.0
            })],
        }
    }

    /// Offsets (µm) of the shape at every point for parameters `theta` (coefficients, then
    /// nonlinear parameters).
    pub fn offsets(&self, sm: &SessionModel, theta: &[f64]) -> Vec<f64> {
        self.offsets_with(sm, &sm.facts, theta)
    }

    /// [`Self::offsets`] with the facts `f` of another session ([`Self::columns_with`]).
    pub fn offsets_with(&self, sm: &SessionModel, f: &SessionFacts, theta: &[f64]) -> Vec<f64> {
        let nl = self.linear.len();
        let cols = self.columns_with(sm, f, &theta[nl..]);
        if self.is_fixed() {
            return cols.into_iter().next().unwrap_or_default();
        }
        let mut out = vec![0.0; sm.len()];
        for (c, b) in cols.iter().zip(&theta[..nl]) {
            for (o, v) in out.iter_mut().zip(c) {
                *o += b * v;
            }
        }
        out
    }
}

/// The first-order response to `events` (time, level) with time constant `tau` at every point.
fn lag_column(
    pts: &[millcomp_sim::session::PointContext],
    events: &[(f64, f64)],
    tau: f64,
) -> Vec<f64> {
    pts.iter()
        .map(|p| first_order_response(events, p.t_s, tau))
        .collect()
}

/// Columns `scale(point)·B_j(v(point))` for the cubic B-splines `B_j` with `m` intervals
/// ([`bspline_basis`]) and `j` in `cols` (all of them: `0..m + 3`; without the first, zero at
/// `v = 0`: `1..m + 3`).
fn spline_columns(
    pts: &[millcomp_sim::session::PointContext],
    v: impl Fn(&millcomp_sim::session::PointContext) -> f64,
    m: usize,
    cols: std::ops::Range<usize>,
    scale: impl Fn(&millcomp_sim::session::PointContext) -> f64,
) -> Vec<Vec<f64>> {
    let basis: Vec<Vec<f64>> = pts.iter().map(|p| bspline_basis(v(p), m)).collect();
    cols.map(|j| {
        basis
            .iter()
            .zip(pts)
            .map(|(b, p)| b[j] * scale(p))
            .collect()
    })
    .collect()
}

/// sim's flute runout offset at every point with the runout `r(point)` (µm) there.
fn runout_column(sm: &SessionModel, r: impl Fn(&EffectContext<'_>) -> f64) -> Vec<f64> {
    (0..sm.len())
        .map(|i| {
            let ctx: EffectContext<'_> = sm.ctx(i);
            let e = FluteRunout {
                runout_um: r(&ctx).max(0.0),
            };
            millcomp_sim::effects::Effect::depth_offset_um(&e, &ctx)
        })
        .collect()
}

/// Clamped uniform cubic B-spline basis on [0, 1] with `m` intervals: `m + 3` values at `u`.
pub fn bspline_basis(u: f64, m: usize) -> Vec<f64> {
    let deg = 3usize;
    let m = m.max(1);
    // knots: 0 (×4), 1/m, …, (m−1)/m, 1 (×4)
    let mut knots = vec![0.0; deg];
    knots.extend((0..=m).map(|k| k as f64 / m as f64));
    knots.extend(vec![1.0; deg]);
    let nb = m + deg;
    let u = u.clamp(0.0, 1.0);
    // degree 0
    let mut b: Vec<f64> = (0..knots.len() - 1)
        .map(|i| {
            let last = i + 1 == knots.len() - 1 - deg; // the last non-empty interval holds u = 1
            if (knots[i] <= u && u < knots[i + 1]) || (last && u == 1.0 && knots[i] < knots[i + 1])
            {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    for d in 1..=deg {
        let next: Vec<f64> = (0..knots.len() - 1 - d)
            .map(|i| {
                let mut v = 0.0;
                let a = knots[i + d] - knots[i];
                if a > 0.0 {
                    v += (u - knots[i]) / a * b[i];
                }
                let c = knots[i + d + 1] - knots[i + 1];
                if c > 0.0 {
                    v += (knots[i + d + 1] - u) / c * b[i + 1];
                }
                v
            })
            .collect();
        b = next;
    }
    b.truncate(nb);
    b
}

/// A candidate family: the effect, its driver and its shapes (the first is the reference form).
#[derive(Debug, Clone, PartialEq)]
pub struct Family {
    /// Effect name (DESIGN.md).
    pub name: &'static str,
    /// What drives it.
    pub driver: &'static str,
    /// One line on the effect and its source.
    pub description: &'static str,
    /// Shapes, the reference form first.
    pub shapes: Vec<Shape>,
}

impl Family {
    /// A flexible basis in the family's own driver (raw columns, µm per unit coefficient): what
    /// the effect could look like if its true shape were none of the family's. `diagnose` names
    /// a further effect only if it is significant beyond this basis of every effect already
    /// named — otherwise what it fits is the named effect's misfit, not a second effect.
    ///
    /// | family | basis |
    /// |---|---|
    /// | coolant | first-order lags of the coolant state, τ = 30 s … 10 000 s (6) |
    /// | spindle | first-order lags of (rpm/50 000)^k, k = 1, 2, 3, τ = 120 … 9600 s (12): any gain as a function of the speed, any mix of lags |
    /// | probe tilt | none (a constant is complete) |
    /// | wear | cubic B-spline in engaged length, 6 intervals, zero at L = 0 (8) |
    /// | straightness | cubic B-spline in machine X, 12 intervals, zero at the start (14) |
    /// | compliance | force × a cubic B-spline in force (4 intervals, 7) and force × a cubic B-spline along X (6 intervals, zero at the start: 8) |
    /// | runout | the runout column's change for a runout change ∝ 1, L, rpm², depth, at runout `runout_um` (4) |
    pub fn driver_basis(&self, sm: &SessionModel, runout_um: f64) -> Vec<Vec<f64>> {
        let pts = sm.points();
        let f = &sm.facts;
        let lag = |events: &[(f64, f64)], tau: f64| lag_column(pts, events, tau);
        let u = |x: f64| f.along_x(x);
        match self.name {
            "coolant_thermal_drift" => [30.0, 120.0, 400.0, 1200.0, 3600.0, 10_000.0]
                .iter()
                .map(|&tau| lag(&f.coolant_events, tau))
                .collect(),
            "spindle_thermal_growth" => {
                let mut out = Vec::new();
                for k in 1..=3 {
                    let ev: Vec<(f64, f64)> = f
                        .spindle_events
                        .iter()
                        .map(|(t, rpm)| (*t, (rpm / 50_000.0).powi(k)))
                        .collect();
                    for tau in [120.0, 600.0, 2400.0, 9600.0] {
                        out.push(lag(&ev, tau));
                    }
                }
                out
            }
            "tool_wear" => spline_columns(
                pts,
                |p| p.cut_length_mm.max(0.0) / f.end_mm.max(1e-9),
                6,
                1..9,
                |_| -1.0,
            ),
            "slideway_straightness" => {
                spline_columns(pts, |p| u(p.machine_x_mm), 12, 1..15, |_| 1.0)
            }
            "machine_compliance" => {
                let fmax = f.max_force_n.max(1e-9);
                // all seven B-splines (a compliance at zero force is allowed)
                let mut out =
                    spline_columns(pts, |p| p.force_z_n / fmax, 4, 0..7, |p| -p.force_z_n);
                // force × a cubic B-spline along X (the `x_spline` shape's, without its first
                // column: the force splines above already sum to the force)
                out.extend(spline_columns(
                    pts,
                    |p| u(p.machine_x_mm),
                    6,
                    1..9,
                    |p| -p.force_z_n,
                ));
                out
            }
            "flute_runout" => {
                let r0 = runout_um.max(0.1);
                let h = 0.05 * r0;
                let base = runout_column(sm, |_| r0);
                let dmax = pts
                    .iter()
                    .map(|p| p.depth_actual_um)
                    .fold(0.0f64, f64::max)
                    .max(1e-9);
                let gs: [&dyn Fn(&EffectContext<'_>) -> f64; 4] = [
                    &|_| 1.0,
                    &|c| c.cut_length_mm.max(0.0) / f.end_mm.max(1e-9),
                    &|c| (c.speed_rpm / 50_000.0).powi(2),
                    &|c| c.depth_actual_um / dmax,
                ];
                gs.iter()
                    .map(|g| {
                        runout_column(sm, |c| r0 + h * g(c))
                            .iter()
                            .zip(&base)
                            .map(|(a, b)| (a - b) / h)
                            .collect()
                    })
                    .collect()
            }
            _ => Vec::new(),
        }
    }
}

fn nl(name: &'static str, lower: f64, upper: f64, grid: &[f64], reference: f64) -> NonlinearParam {
    NonlinearParam {
        name,
        lower,
        upper,
        grid: grid.to_vec(),
        reference,
    }
}

/// Time-constant grid (s): 30 s … 8 h, log-spaced.
const TAU_GRID: [f64; 12] = [
    30.0, 60.0, 120.0, 240.0, 400.0, 600.0, 900.0, 1400.0, 2200.0, 3500.0, 6000.0, 12000.0,
];
const TAU_FAST: [f64; 5] = [60.0, 150.0, 300.0, 600.0, 1200.0];
const TAU_SLOW: [f64; 5] = [900.0, 1800.0, 3600.0, 7200.0, 14400.0];
const ONSET_GRID: [f64; 6] = [0.0, 6000.0, 12000.0, 16000.0, 20000.0, 26000.0];

/// The seven families of DESIGN.md's effect names (module documentation).
pub fn standard() -> Vec<Family> {
    let lag_shapes = |amp: &'static str| {
        vec![
            Shape {
                name: "one_lag",
                description: "first-order lag of the driver",
                linear: vec![amp],
                nonlinear: vec![nl("time_constant_s", 5.0, 1e5, &TAU_GRID, 900.0)],
                kind: ShapeKind::CoolantLags(1),
                nonnegative: false,
                reference_coef: 8.5,
            },
            Shape {
                name: "two_lag",
                description: "a fast and a slow first-order lag of the driver",
                linear: vec!["fast_um", "slow_um"],
                nonlinear: vec![
                    nl("tau_fast_s", 5.0, 1e5, &TAU_FAST, 300.0),
                    nl("tau_slow_s", 5.0, 1e5, &TAU_SLOW, 3600.0),
                ],
                kind: ShapeKind::CoolantLags(2),
                nonnegative: false,
                reference_coef: 8.5,
            },
            Shape {
                name: "dead_time_lag",
                description: "first-order lag of the driver delayed by a dead time (transport to the column)",
                linear: vec![amp],
                nonlinear: vec![
                    nl("time_constant_s", 5.0, 1e5, &TAU_GRID, 900.0),
                    nl(
                        "dead_time_s",
                        0.0,
                        3600.0,
                        &[60.0, 180.0, 400.0, 800.0],
                        300.0,
                    ),
                ],
                kind: ShapeKind::CoolantDeadTime,
                nonnegative: false,
                reference_coef: 8.5,
            },
        ]
    };
    vec![
        Family {
            name: "coolant_thermal_drift",
            driver: "coolant state history (time since the coolant was switched)",
            description: "coolant switched on cools the column: the depth drifts after the switch (002 §7.1, §4.7)",
            shapes: lag_shapes("amplitude_um"),
        },
        Family {
            name: "spindle_thermal_growth",
            driver: "spindle speed history",
            description: "speed-dependent spindle thermal growth (002 §7.6, Tab. 5)",
            shapes: vec![
                Shape {
                    name: "onset_one_lag",
                    description: "growth linear in speed above an onset, one first-order lag (sim's form)",
                    linear: vec!["max_growth_um"],
                    nonlinear: vec![
                        nl("rpm_onset", 0.0, 45_000.0, &ONSET_GRID, 16_000.0),
                        nl("time_constant_s", 5.0, 1e5, &TAU_GRID, 600.0),
                    ],
                    kind: ShapeKind::SpindleOnsetLags(1),
                    nonnegative: false,
                    reference_coef: 20.0,
                },
                Shape {
                    name: "onset_two_lag",
                    description: "growth linear in speed above an onset, a fast (spindle) and a slow (housing) lag",
                    linear: vec!["fast_um", "slow_um"],
                    nonlinear: vec![
                        nl("rpm_onset", 0.0, 45_000.0, &ONSET_GRID, 16_000.0),
                        nl("tau_fast_s", 5.0, 1e5, &TAU_FAST, 300.0),
                        nl("tau_slow_s", 5.0, 1e5, &TAU_SLOW, 1800.0),
                    ],
                    kind: ShapeKind::SpindleOnsetLags(2),
                    nonnegative: false,
                    reference_coef: 20.0,
                },
                Shape {
                    name: "quadratic_one_lag",
                    description: "growth ∝ rpm² (friction heat), one first-order lag",
                    linear: vec!["growth_at_50000_rpm_um"],
                    nonlinear: vec![nl("time_constant_s", 5.0, 1e5, &TAU_GRID, 600.0)],
                    kind: ShapeKind::SpindleQuadratic,
                    nonnegative: false,
                    reference_coef: 20.0,
                },
            ],
        },
        Family {
            name: "probe_tilt_offset",
            driver: "one constant per tool-length correction",
            description: "tool-length probe tip tilt: constant offset (D1 − D2)/2·tan α (002 §7.3)",
            shapes: vec![Shape {
                name: "constant",
                description: "a constant depth offset",
                linear: vec!["offset_um"],
                nonlinear: vec![],
                kind: ShapeKind::Constant,
                nonnegative: false,
                reference_coef: 4.67,
            }],
        },
        Family {
            name: "tool_wear",
            driver: "engaged length (monotone)",
            description: "the tool shortens with engaged length (002 §7.5)",
            shapes: vec![
                Shape {
                    name: "saturating",
                    description: "−W(1 − exp(−L/L0)) (sim's form)",
                    linear: vec!["max_wear_um"],
                    nonlinear: vec![nl(
                        "length_scale_mm",
                        1.0,
                        1e6,
                        &[10.0, 25.0, 50.0, 100.0, 200.0, 400.0, 1000.0, 5000.0],
                        100.0,
                    )],
                    kind: ShapeKind::WearSaturating,
                    nonnegative: true,
                    reference_coef: 8.0,
                },
                Shape {
                    name: "power_law",
                    description: "−W·(L/L_end)^k: running-in (k < 1), steady (k = 1) or accelerating (k > 1)",
                    linear: vec!["wear_at_end_um"],
                    nonlinear: vec![nl(
                        "exponent",
                        0.05,
                        6.0,
                        &[0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0],
                        0.5,
                    )],
                    kind: ShapeKind::WearPower,
                    nonnegative: true,
                    reference_coef: 8.0,
                },
                Shape {
                    name: "running_in_linear",
                    description: "−W₁(1 − exp(−L/L₁)) − W₂·L/L_end: running-in, then steady wear (the classic wear curve's first two stages)",
                    linear: vec!["running_in_um", "steady_wear_at_end_um"],
                    nonlinear: vec![nl(
                        "running_in_length_mm",
                        0.5,
                        1e5,
                        &[5.0, 10.0, 20.0, 40.0, 80.0, 160.0],
                        20.0,
                    )],
                    kind: ShapeKind::WearRunningIn,
                    nonnegative: true,
                    reference_coef: 8.0,
                },
                Shape {
                    name: "monotone_spline",
                    description: "−W(L), W a non-decreasing cubic spline in engaged length (knots at sixths of the session's), zero at L = 0: a wear of any onset and curvature",
                    linear: vec![
                        "w1_um", "w2_um", "w3_um", "w4_um", "w5_um", "w6_um", "w7_um", "w8_um",
                    ],
                    nonlinear: vec![],
                    kind: ShapeKind::WearMonotoneSpline(6),
                    nonnegative: true,
                    // the eight tail sums reach 1 each at the end: 8 µm there, 002's wear
                    reference_coef: 1.0,
                },
            ],
        },
        Family {
            name: "slideway_straightness",
            driver: "machine X (not time), zero at the start of the measured X range",
            description: "X slideway deviation (002 §4.5: 5 µm over 90 mm)",
            shapes: vec![
                Shape {
                    name: "bow",
                    description: "parabolic bow zero at both ends of the X range (sim's form)",
                    linear: vec!["amplitude_um"],
                    nonlinear: vec![],
                    kind: ShapeKind::Bow,
                    nonnegative: false,
                    reference_coef: 5.0,
                },
                Shape {
                    name: "cubic",
                    description: "cubic polynomial in X, zero at the start of the range",
                    linear: vec!["b1_um", "b2_um", "b3_um"],
                    nonlinear: vec![],
                    kind: ShapeKind::Cubic,
                    nonnegative: false,
                    reference_coef: 5.0,
                },
                Shape {
                    name: "spline",
                    description: "cubic B-spline in X, knots every 1/6 of the range, zero at the start",
                    linear: vec![
                        "s1_um", "s2_um", "s3_um", "s4_um", "s5_um", "s6_um", "s7_um", "s8_um",
                    ],
                    nonlinear: vec![],
                    kind: ShapeKind::Spline(6),
                    nonnegative: false,
                    reference_coef: 5.0,
                },
            ],
        },
        Family {
            name: "machine_compliance",
            driver: "peak force",
            description: "machine compliance in series with the tool (003 eqs 1–5)",
            shapes: vec![
                Shape {
                    name: "constant",
                    description: "−c·F (sim's form, k_M = 1/c)",
                    linear: vec!["compliance_um_per_n"],
                    nonlinear: vec![],
                    kind: ShapeKind::ComplianceConstant,
                    nonnegative: true,
                    reference_coef: 0.1,
                },
                Shape {
                    name: "x_linear",
                    description: "−(c0 + c1·u)·F, compliance changing along X",
                    linear: vec!["c0_um_per_n", "c1_um_per_n"],
                    nonlinear: vec![],
                    kind: ShapeKind::ComplianceXLinear,
                    nonnegative: false,
                    reference_coef: 0.1,
                },
                Shape {
                    name: "x_spline",
                    description: "−c(u)·F, c a cubic B-spline in X (knots at sixths of the range, as the straightness's spline): a stiffness that varies with the axis position",
                    linear: vec![
                        "c1_um_per_n",
                        "c2_um_per_n",
                        "c3_um_per_n",
                        "c4_um_per_n",
                        "c5_um_per_n",
                        "c6_um_per_n",
                        "c7_um_per_n",
                        "c8_um_per_n",
                        "c9_um_per_n",
                    ],
                    nonlinear: vec![],
                    kind: ShapeKind::ComplianceXSpline(6),
                    nonnegative: false,
                    reference_coef: 0.1,
                },
                Shape {
                    name: "preload",
                    description: "−c·(F − b·F_max)₊, a joint that gives once its preload b·F_max is overcome",
                    linear: vec!["compliance_um_per_n"],
                    nonlinear: vec![nl(
                        "preload_share",
                        0.0,
                        0.9,
                        &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7],
                        0.3,
                    )],
                    kind: ShapeKind::CompliancePreload,
                    nonnegative: true,
                    reference_coef: 0.1,
                },
            ],
        },
        Family {
            name: "flute_runout",
            driver: "chip asymmetry of the two flutes (depth, upfeed, tool compliance)",
            description: "flute runout: one flute cuts more, larger peak force (000 §4)",
            shapes: vec![
                Shape {
                    name: "constant",
                    description: "sim's runout form with one runout",
                    linear: vec![],
                    nonlinear: vec![nl(
                        "runout_um",
                        0.0,
                        50.0,
                        &[0.5, 1.0, 2.0, 3.0, 4.5, 7.0, 12.0],
                        3.0,
                    )],
                    kind: ShapeKind::RunoutConstant,
                    nonnegative: false,
                    reference_coef: 1.0,
                },
                Shape {
                    name: "growing",
                    description: "runout r0 + r1·L/L_end, growing with engaged length",
                    linear: vec![],
                    nonlinear: vec![
                        nl("runout_start_um", 0.0, 50.0, &[0.5, 1.5, 3.0, 5.0], 3.0),
                        nl("runout_growth_um", -50.0, 50.0, &[-2.0, 0.0, 2.0, 5.0], 0.0),
                    ],
                    kind: ShapeKind::RunoutGrowing,
                    nonnegative: false,
                    reference_coef: 1.0,
                },
                Shape {
                    name: "speed_dependent",
                    description: "runout r0 + r2·(rpm/50 000)², growing with speed (dynamic unbalance)",
                    linear: vec![],
                    nonlinear: vec![
                        nl("runout_um", 0.0, 50.0, &[0.5, 1.5, 3.0, 5.0], 3.0),
                        nl(
                            "runout_at_50000_rpm_um",
                            0.0,
                            100.0,
                            &[0.5, 2.0, 5.0, 10.0, 20.0],
                            0.0,
                        ),
                    ],
                    kind: ShapeKind::RunoutSpeed,
                    nonnegative: false,
                    reference_coef: 1.0,
                },
                Shape {
                    name: "depth_dependent",
                    description: "runout r0 + r1·d/80 µm, changing with the depth cut (chip asymmetry)",
                    linear: vec![],
                    nonlinear: vec![
                        nl("runout_um", 0.0, 50.0, &[0.5, 1.5, 3.0, 5.0], 3.0),
                        nl(
                            "runout_at_80_um_depth_um",
                            -50.0,
                            50.0,
                            &[-1.0, 1.0, 2.0, 4.0],
                            0.0,
                        ),
                    ],
                    kind: ShapeKind::RunoutDepth,
                    nonnegative: false,
                    reference_coef: 1.0,
                },
            ],
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bspline_basis_is_a_partition_of_unity() {
        for k in 0..=40 {
            let u = k as f64 / 40.0;
            let b = bspline_basis(u, 6);
            assert_eq!(b.len(), 9);
            let s: f64 = b.iter().sum();
            assert!((s - 1.0).abs() < 1e-12, "u = {u}: {s}");
            assert!(b.iter().all(|v| *v >= -1e-15));
        }
        // clamped: only the first function is non-zero at the start, only the last at the end
        assert_eq!(bspline_basis(0.0, 6)[0], 1.0);
        assert_eq!(bspline_basis(1.0, 6)[8], 1.0);
    }

    #[test]
    fn every_family_has_its_reference_first_and_a_grid() {
        let f = standard();
        assert_eq!(
            f.iter().map(|f| f.name).collect::<Vec<_>>(),
            millcomp_sim::effects::EFFECT_NAMES.to_vec()
        );
        for fam in &f {
            for s in &fam.shapes {
                assert!(!s.grid().is_empty(), "{} {}", fam.name, s.name);
                for p in &s.nonlinear {
                    assert!(p.grid.iter().all(|g| *g >= p.lower && *g <= p.upper));
                }
            }
        }
    }
}
