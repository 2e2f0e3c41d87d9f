//! Recorded QP sequences: export the identical per-cycle QPs of a closed-loop run (fixed P, A, cones;
//! per-cycle q, b) as JSON, and replay them with Clarabel — the millcomp side of `bench/mpc-vs-casadi`.
//!
//! The recording loop ([`record_spindle_sequence`]) runs the spindle MPC of [`crate::spindle_mpc`] in closed
//! loop against the nominal spindle with a groove-like deflection: a 0 → 17 µm ramp (`000_…txt` ch. 6: 17 µm
//! predicted at the 80 µm end of the 20° groove), a per-flute ripple at 10 000 rpm with 2 flutes (±10 %),
//! a feed-rate doubling halfway (deflection × 1.6: `003_…txt` §3 doubles the feed; with the chip-thickness
//! exponent of the force model the peak force grows by ≈ 60 %), the planned deflection 10 % low (model
//! error), and seeded Gaussian noise on both measurements.

use std::time::Instant;

use clarabel::solver::{DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::config::{MpcConfig, SolverConfig};
use crate::controller::{MpcController, PreviewWindow};
use crate::error::MpcError;
use crate::qp::QpData;
use crate::qp::clarabel_settings;
use crate::spindle_mpc::{OUT_ERROR, default_spindle_config, spindle_prediction_model};
use crate::stats::percentile;
use millcomp_sim::PztSpindle;

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
    /// First move of each cycle.
    pub first_moves: Vec<f64>,
    /// Cycles whose status was not Solved/AlmostSolved.
    pub failures: usize,
    /// Interior-point iterations, median.
    pub median_iterations: f64,
}

fn csc_json(colptr: &[usize], rowval: &[usize], nzval: &[f64], m: usize, n: usize) -> CscJson {
    CscJson {
        m,
        n,
        colptr: colptr.to_vec(),
        rowval: rowval.to_vec(),
        nzval: nzval.to_vec(),
    }
}

/// The nominal spindle used for recordings (ζ 0.46, ωn 1302 rad/s, 50 µm/1000 V, extra pole 37 000 rad/s;
/// `000_…txt` §5.2.2/5.2.4 and sim's provisional fit).
pub fn bench_spindle() -> PztSpindle {
    PztSpindle::new(0.05, 0.46, 1302.0, Some(37_000.0), None)
        .expect("constant parameters are valid")
}

/// Control period of the spindle MPC (2 kHz).
pub const BENCH_DT_S: f64 = 5e-4;

/// Record `cycles` closed-loop QPs of the spindle MPC with the given horizon (see the module docs).
pub fn record_spindle_sequence(
    horizon: usize,
    cycles: usize,
    seed: u64,
) -> Result<QpSequence, MpcError> {
    let cfg = default_spindle_config(horizon, 1000.0, 100.0);
    record_spindle_sequence_with(&cfg, cycles, seed)
}

/// As [`record_spindle_sequence`] with an explicit configuration (two outputs: gauge, depth error).
pub fn record_spindle_sequence_with(
    cfg: &MpcConfig,
    cycles: usize,
    seed: u64,
) -> Result<QpSequence, MpcError> {
    let horizon = cfg.horizon;
    let sp = bench_spindle();
    let model = spindle_prediction_model(&sp, BENCH_DT_S)?;
    let cfg = cfg.clone();
    let mut mpc = MpcController::new(&model, &cfg)?;
    let mut plant = sp.discretize(BENCH_DT_S)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let gauge_noise = Normal::new(0.0, 0.05).expect("valid");
    let force_noise = Normal::new(0.0, 0.2).expect("valid");
    let rev_s = 60.0 / 10_000.0;
    let total = cycles.max(1) as f64;
    let smooth = |k: usize| {
        let frac = (k as f64 / total).min(1.0);
        let feed = if frac >= 0.5 { 1.6 } else { 1.0 };
        17.0 * frac * feed / 1.6
    };
    let actual = |k: usize| {
        let t = k as f64 * BENCH_DT_S;
        let ripple = 1.0 + 0.1 * (2.0 * std::f64::consts::PI * 2.0 * t / rev_s).sin();
        smooth(k) * ripple
    };
    let ny = 2;
    let mut win = PreviewWindow::zeros(horizon, ny);
    let mut q = Vec::with_capacity(cycles);
    let mut b = Vec::with_capacity(cycles);
    let mut tip = 0.0;
    let mut fixed: Option<QpData> = None;
    for k in 0..cycles {
        win.offset_now[OUT_ERROR] = -0.9 * smooth(k);
        for j in 0..horizon {
            win.offsets[j * ny + OUT_ERROR] = -0.9 * smooth(k + 1 + j);
        }
        let g = tip + gauge_noise.sample(&mut rng);
        let e = g - actual(k) + force_noise.sample(&mut rng);
        let s = mpc.step(&[g, e], &win)?;
        let snap = mpc.qp();
        q.push(snap.q().to_vec());
        b.push(snap.b().to_vec());
        if fixed.is_none() {
            fixed = Some(snap.snapshot());
        }
        plant.step(s.u[0]);
        tip = plant.tip_um();
    }
    let d = fixed.ok_or(MpcError::Numerical {
        what: "record",
        detail: "no cycles recorded".into(),
    })?;
    Ok(QpSequence {
        source: format!(
            "millcomp-mpc replay::record_spindle_sequence(horizon={horizon}, cycles={cycles}, seed={seed}): \
             spindle MPC (default_spindle_config, dt 0.5 ms) in closed loop on the nominal PZT spindle with a \
             synthetic groove deflection (0→17 µm ramp, ±10 % flute ripple, feed doubling halfway)"
        ),
        horizon,
        p: csc_json(&d.p_colptr, &d.p_rowval, &d.p_nzval, d.n, d.n),
        a: csc_json(&d.a_colptr, &d.a_rowval, &d.a_nzval, d.m, d.n),
        nonneg_rows: d.m,
        q,
        b,
        first_move_index: 0,
        input_range: cfg.limits.u_max[0] - cfg.limits.u_min[0],
        solver: cfg.solver.clone(),
    })
}

/// A Clarabel solver set up once for a recorded sequence; [`ReplaySolver::solve_cycle`] does what the
/// controller does every cycle (`update_q`, `update_b`, `solve`, status check).
pub struct ReplaySolver<'a> {
    seq: &'a QpSequence,
    solver: DefaultSolver<f64>,
}

impl<'a> ReplaySolver<'a> {
    /// Build the solver once (presolve off) with the sequence's first cycle data.
    pub fn new(seq: &'a QpSequence) -> Result<Self, MpcError> {
        let p = clarabel::algebra::CscMatrix::new(
            seq.p.m,
            seq.p.n,
            seq.p.colptr.clone(),
            seq.p.rowval.clone(),
            seq.p.nzval.clone(),
        );
        let a = clarabel::algebra::CscMatrix::new(
            seq.a.m,
            seq.a.n,
            seq.a.colptr.clone(),
            seq.a.rowval.clone(),
            seq.a.nzval.clone(),
        );
        let settings = clarabel_settings(&seq.solver);
        let cones: Vec<SupportedConeT<f64>> = vec![NonnegativeConeT(seq.nonneg_rows)];
        let (q0, b0) = match (seq.q.first(), seq.b.first()) {
            (Some(q), Some(b)) if seq.q.len() == seq.b.len() => (q, b),
            _ => {
                return Err(MpcError::DimensionMismatch {
                    what: "recorded cycles (q and b, at least one)".into(),
                    expected: seq.q.len().max(1),
                    found: seq.b.len(),
                });
            }
        };
        let solver = DefaultSolver::new(&p, q0, &a, b0, &cones, settings).map_err(|e| {
            MpcError::SolverSetup {
                what: "DefaultSolver::new",
                detail: e.to_string(),
            }
        })?;
        Ok(Self { seq, solver })
    }

    /// Number of recorded cycles.
    pub fn cycles(&self) -> usize {
        self.seq.q.len()
    }

    /// Solve cycle `k` (mod the number of cycles); returns (accepted?, first move, iterations).
    pub fn solve_cycle(&mut self, k: usize) -> Result<(bool, f64, u32), MpcError> {
        let k = k % self.seq.q.len();
        self.solver
            .update_q(&self.seq.q[k])
            .map_err(|e| MpcError::SolverSetup {
                what: "update_q",
                detail: e.to_string(),
            })?;
        self.solver
            .update_b(&self.seq.b[k])
            .map_err(|e| MpcError::SolverSetup {
                what: "update_b",
                detail: e.to_string(),
            })?;
        self.solver.solve();
        let ok = matches!(
            self.solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        );
        Ok((
            ok,
            self.solver.solution.x[self.seq.first_move_index],
            self.solver.solution.iterations,
        ))
    }
}

/// Replay a sequence with Clarabel exactly as the controller does: one `DefaultSolver` built once
/// (presolve off), then per cycle `update_q`, `update_b`, `solve`, status check — each cycle timed.
pub fn replay_clarabel(seq: &QpSequence) -> Result<ReplayResult, MpcError> {
    let mut rs = ReplaySolver::new(seq)?;
    let n = rs.cycles();
    let mut times = Vec::with_capacity(n);
    let mut iters = Vec::with_capacity(n);
    let mut first = Vec::with_capacity(n);
    let mut failures = 0;
    for k in 0..n {
        let t0 = Instant::now();
        let (ok, u0, it) = rs.solve_cycle(k)?;
        times.push(t0.elapsed().as_secs_f64() * 1e6);
        iters.push(it as f64);
        if !ok {
            failures += 1;
        }
        first.push(u0);
    }
    Ok(ReplayResult {
        median_us: percentile(&times, 50.0),
        p99_us: percentile(&times, 99.0),
        first_moves: first,
        failures,
        median_iterations: percentile(&iters, 50.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_reproduces_the_recorded_first_moves() {
        let seq = record_spindle_sequence(10, 60, 7).unwrap();
        assert_eq!(seq.q.len(), 60);
        let json = serde_json::to_string(&seq).unwrap();
        let back: QpSequence = serde_json::from_str(&json).unwrap();
        let r1 = replay_clarabel(&back).unwrap();
        let r2 = replay_clarabel(&seq).unwrap();
        assert_eq!(r1.failures, 0);
        // deterministic: same data, same solver path → bit-identical first moves
        assert_eq!(r1.first_moves, r2.first_moves);
        assert!(
            r1.first_moves
                .iter()
                .all(|u| (0.0..=1000.0 + 1e-6).contains(u))
        );
    }
}
