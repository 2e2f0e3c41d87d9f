//! Recorded QP sequences: the identical per-cycle QPs of a closed-loop run (fixed P, A, cones; per-cycle
//! q, b) as JSON ([`QpSequence`]), and their replay with Clarabel exactly as the controller solves them
//! ([`replay_clarabel`]) — the millcomp side of `bench/mpc-vs-casadi`. Recording a sequence in closed
//! loop is the harness's job (`millcomp_closedloop::recording`).

use std::time::Instant;

use clarabel::solver::{DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT};
use serde::{Deserialize, Serialize};

use crate::config::SolverConfig;
use crate::error::MpcError;
use crate::qp::{QpData, clarabel_settings};
use crate::stats::percentile;

/// Sparse matrix in CSC form (JSON friendly).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CscJson {
    /// Rows.
    pub m: usize,
    /// Columns.
    pub n: usize,
    /// Column pointers (n + 1).
    pub colptr: Vec<usize>,
    /// Row indices.
    pub rowval: Vec<usize>,
    /// Values.
    pub nzval: Vec<f64>,
}

/// A recorded sequence of QPs `min ½zᵀPz + qₖᵀz s.t. A z + s = bₖ, s ≥ 0` sharing P and A.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QpSequence {
    /// What produced the sequence.
    pub source: String,
    /// MPC horizon.
    pub horizon: usize,
    /// P, upper triangle (Clarabel convention; the full symmetric matrix is P + Pᵀ − diag P).
    pub p: CscJson,
    /// A.
    pub a: CscJson,
    /// All rows of A belong to the nonnegative cone (`b − A z ≥ 0`).
    pub nonneg_rows: usize,
    /// Per-cycle q.
    pub q: Vec<Vec<f64>>,
    /// Per-cycle b.
    pub b: Vec<Vec<f64>>,
    /// Index of the first move in z.
    pub first_move_index: usize,
    /// Input range (u_max − u_min) used to normalise first-move differences.
    pub input_range: f64,
    /// Clarabel settings used for recording and replay.
    pub solver: SolverConfig,
}

/// Result of replaying a sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReplayResult {
    /// Median per-cycle time (update_q + update_b + solve), µs.
    pub median_us: f64,
    /// 99th percentile, µs.
    pub p99_us: f64,
    /// Median time of Clarabel's `solve()` call alone, µs (the counterpart of a peer's own solver
    /// timer; Clarabel's `solution.solve_time` cannot serve, it includes the one-time setup).
    pub solve_median_us: f64,
    /// 99th percentile of the `solve()` time, µs.
    pub solve_p99_us: f64,
    /// First move of each cycle.
    pub first_moves: Vec<f64>,
    /// Cycles whose status was not Solved/AlmostSolved.
    pub failures: usize,
    /// Interior-point iterations, median.
    pub median_iterations: f64,
}

impl CscJson {
    /// From the CSC arrays of an `m × n` matrix.
    pub fn new(colptr: &[usize], rowval: &[usize], nzval: &[f64], m: usize, n: usize) -> Self {
        Self {
            m,
            n,
            colptr: colptr.to_vec(),
            rowval: rowval.to_vec(),
            nzval: nzval.to_vec(),
        }
    }
}

impl CscJson {
    /// The matrix as Clarabel's CSC type after checking the structure Clarabel's constructor assumes and
    /// does not check (it indexes by `colptr`/`rowval` and panics or reads out of range otherwise):
    /// `colptr` of `n + 1` non-decreasing entries from 0 to `nnz`, row indices below `m` and strictly
    /// increasing within each column, `rowval` and `nzval` of equal length, finite values, and — for
    /// `upper` (P) — no entry below the diagonal. `name` (`p` or `a`) goes into the message.
    fn to_clarabel(
        &self,
        name: &str,
        upper: bool,
    ) -> Result<clarabel::algebra::CscMatrix<f64>, MpcError> {
        let bad = |what: &str| MpcError::InvalidConfig {
            key: name.to_string(),
            value: format!("{}x{} matrix, {} entries", self.m, self.n, self.nzval.len()),
            allowed: format!("a CSC matrix: {what}"),
        };
        if self.colptr.len() != self.n + 1 || self.colptr.first() != Some(&0) {
            return Err(bad("colptr holds n + 1 entries starting at 0"));
        }
        // Clarabel's own check: equal lengths, colptr monotone and ending at nnz, rows sorted and in range.
        let mat = clarabel::algebra::CscMatrix {
            m: self.m,
            n: self.n,
            colptr: self.colptr.clone(),
            rowval: self.rowval.clone(),
            nzval: self.nzval.clone(),
        };
        mat.check_format().map_err(|e| bad(&e.to_string()))?;
        if let Some(k) = self.nzval.iter().position(|v| !v.is_finite()) {
            return Err(bad(&format!(
                "finite values (entry {} is {})",
                k + 1,
                self.nzval[k]
            )));
        }
        if upper {
            for col in 0..self.n {
                if self.rowval[self.colptr[col]..self.colptr[col + 1]]
                    .iter()
                    .any(|&r| r > col)
                {
                    return Err(bad(
                        "the upper triangle only (an entry lies below the diagonal)",
                    ));
                }
            }
        }
        Ok(mat)
    }
}

impl QpSequence {
    /// Checks what replaying the sequence needs before any solver sees it (a recorded file is user
    /// input): P square and upper-triangular, A with P's columns, the cone covering A's rows, every
    /// cycle's `q` of length n and `b` of length m with finite entries, at least one cycle, the first
    /// move inside z.
    ///
    /// # Errors
    /// [`MpcError::InvalidConfig`] or [`MpcError::DimensionMismatch`] naming the key (`p`, `a`,
    /// `q[k]`, `b[k]`, `nonneg_rows`, `first_move_index`; cycles counted from 1).
    pub fn validate(&self) -> Result<(), MpcError> {
        self.matrices().map(|_| ())
    }

    fn matrices(
        &self,
    ) -> Result<
        (
            clarabel::algebra::CscMatrix<f64>,
            clarabel::algebra::CscMatrix<f64>,
        ),
        MpcError,
    > {
        let p = self.p.to_clarabel("p", true)?;
        let a = self.a.to_clarabel("a", false)?;
        let n = self.p.n;
        let dim = |what: String, expected: usize, found: usize| {
            if expected == found {
                Ok(())
            } else {
                Err(MpcError::DimensionMismatch {
                    what,
                    expected,
                    found,
                })
            }
        };
        dim("p (rows of a square P)".into(), n, self.p.m)?;
        dim("a (columns, as P's)".into(), n, self.a.n)?;
        dim("nonneg_rows (rows of A)".into(), self.a.m, self.nonneg_rows)?;
        if self.q.is_empty() || self.q.len() != self.b.len() {
            return Err(MpcError::DimensionMismatch {
                what: "recorded cycles (q and b, at least one)".into(),
                expected: self.q.len().max(1),
                found: self.b.len(),
            });
        }
        for (k, (q, b)) in self.q.iter().zip(&self.b).enumerate() {
            dim(format!("q[{}]", k + 1), n, q.len())?;
            dim(format!("b[{}]", k + 1), self.a.m, b.len())?;
            for (key, v) in [("q", q), ("b", b)] {
                if let Some(v) = v.iter().find(|v| !v.is_finite()) {
                    return Err(MpcError::InvalidConfig {
                        key: format!("{key}[{}]", k + 1),
                        value: v.to_string(),
                        allowed: "finite numbers".into(),
                    });
                }
            }
        }
        if self.first_move_index >= n {
            return Err(MpcError::InvalidConfig {
                key: "first_move_index".into(),
                value: self.first_move_index.to_string(),
                allowed: format!("an index into z (below {n})"),
            });
        }
        Ok((p, a))
    }

    /// A sequence from the fixed data of a controller's QP ([`QpData`], e.g. of its first cycle) and the
    /// per-cycle `q`, `b`; every row of A is in the nonnegative cone, the first move is `z[0]`.
    pub fn from_cycles(
        source: String,
        horizon: usize,
        fixed: &QpData,
        q: Vec<Vec<f64>>,
        b: Vec<Vec<f64>>,
        input_range: f64,
        solver: SolverConfig,
    ) -> Self {
        let d = fixed;
        Self {
            source,
            horizon,
            p: CscJson::new(&d.p_colptr, &d.p_rowval, &d.p_nzval, d.n, d.n),
            a: CscJson::new(&d.a_colptr, &d.a_rowval, &d.a_nzval, d.m, d.n),
            nonneg_rows: d.m,
            q,
            b,
            first_move_index: 0,
            input_range,
            solver,
        }
    }
}

/// A Clarabel solver set up once for a recorded sequence; [`ReplaySolver::solve_cycle`] does what the
/// controller does every cycle (`update_q`, `update_b`, `solve`, status check).
pub struct ReplaySolver<'a> {
    seq: &'a QpSequence,
    solver: DefaultSolver<f64>,
}

impl<'a> ReplaySolver<'a> {
    /// Build the solver once (presolve off) with the sequence's first cycle data.
    ///
    /// # Errors
    /// The sequence fails [`QpSequence::validate`], or Clarabel refuses its data.
    pub fn new(seq: &'a QpSequence) -> Result<Self, MpcError> {
        let (p, a) = seq.matrices()?;
        let settings = clarabel_settings(&seq.solver);
        let cones: Vec<SupportedConeT<f64>> = vec![NonnegativeConeT(seq.nonneg_rows)];
        let (q0, b0) = (&seq.q[0], &seq.b[0]);
        let solver = DefaultSolver::new(&p, q0, &a, b0, &cones, settings).map_err(|e| {
            MpcError::SolverSetup {
                what: "DefaultSolver::new",
                source: Box::new(e),
            }
        })?;
        Ok(Self { seq, solver })
    }

    /// Number of recorded cycles.
    pub fn cycles(&self) -> usize {
        self.seq.q.len()
    }

    /// Solve cycle `k` (mod the number of cycles); returns (accepted?, first move, iterations, seconds
    /// in `solve()`).
    pub fn solve_cycle(&mut self, k: usize) -> Result<(bool, f64, u32, f64), MpcError> {
        let k = k % self.seq.q.len();
        self.solver
            .update_q(&self.seq.q[k])
            .map_err(|e| MpcError::SolverSetup {
                what: "update_q",
                source: Box::new(e),
            })?;
        self.solver
            .update_b(&self.seq.b[k])
            .map_err(|e| MpcError::SolverSetup {
                what: "update_b",
                source: Box::new(e),
            })?;
        let t0 = Instant::now();
        self.solver.solve();
        let solve_s = t0.elapsed().as_secs_f64();
        let ok = matches!(
            self.solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        );
        Ok((
            ok,
            self.solver.solution.x[self.seq.first_move_index],
            self.solver.solution.iterations,
            solve_s,
        ))
    }
}

/// Replay a sequence with Clarabel exactly as the controller does: one `DefaultSolver` built once
/// (presolve off), then per cycle `update_q`, `update_b`, `solve`, status check — each cycle timed.
pub fn replay_clarabel(seq: &QpSequence) -> Result<ReplayResult, MpcError> {
    let mut rs = ReplaySolver::new(seq)?;
    let n = rs.cycles();
    let mut times = Vec::with_capacity(n);
    let mut solve_times = Vec::with_capacity(n);
    let mut iters = Vec::with_capacity(n);
    let mut first = Vec::with_capacity(n);
    let mut failures = 0;
    for k in 0..n {
        let t0 = Instant::now();
        let (ok, u0, it, solve_s) = rs.solve_cycle(k)?;
        times.push(t0.elapsed().as_secs_f64() * 1e6);
        solve_times.push(solve_s * 1e6);
        iters.push(it as f64);
        if !ok {
            failures += 1;
        }
        first.push(u0);
    }
    Ok(ReplayResult {
        median_us: percentile(&times, 50.0),
        p99_us: percentile(&times, 99.0),
        solve_median_us: percentile(&solve_times, 50.0),
        solve_p99_us: percentile(&solve_times, 99.0),
        first_moves: first,
        failures,
        median_iterations: percentile(&iters, 50.0),
    })
}
