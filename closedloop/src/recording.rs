//! Recording the spindle MPC's per-cycle QPs in closed loop (the recording side of
//! `bench/mpc-vs-casadi` and of `benches/solve.rs`; the sequence format and its replay are
//! [`millcomp_mpc::replay`]).
//!
//! The recording loop ([`record_spindle_sequence`]) runs the spindle MPC of [`millcomp_mpc::spindle_mpc`]
//! in closed loop against the nominal spindle with a groove-like deflection: a 0 → 17 µm ramp (`000_…txt`
//! ch. 6: 17 µm predicted at the 80 µm end of the 20° groove), a per-flute ripple at 10 000 rpm with 2
//! flutes (±10 %), a feed-rate doubling halfway (deflection × 1.6: `003_…txt` §3 doubles the feed; with
//! the chip-thickness exponent of the force model the peak force grows by ≈ 60 %), the planned deflection
//! 10 % low (model error), and seeded Gaussian noise on both measurements.

use millcomp_mpc::identified::IdentifiedSpindle;
use millcomp_mpc::qp::QpData;
use millcomp_mpc::replay::QpSequence;
use millcomp_mpc::spindle_mpc::{OUT_ERROR, default_spindle_config, spindle_prediction_model};
use millcomp_mpc::{MpcConfig, MpcController, MpcError, PreviewWindow};
use millcomp_sim::PztSpindle;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use crate::error::ClosedLoopError;

/// The nominal spindle used for recordings (ζ 0.46, ωn 1302 rad/s, 50 µm/1000 V, extra pole 37 000 rad/s;
/// `000_…txt` §5.2.2/5.2.4 and sim's provisional fit).
pub fn bench_spindle() -> PztSpindle {
    PztSpindle::new(0.05, 0.46, 1302.0, Some(37_000.0), None)
        .expect("constant parameters are valid")
}

/// Control period of the spindle MPC (2 kHz).
pub const BENCH_DT_S: f64 = 5e-4;

/// Record `cycles` closed-loop QPs of the spindle MPC with the given horizon (see the module docs).
///
/// # Errors
/// Configuration errors of the MPC (e.g. a horizon of 0), [`ClosedLoopError::Mpc`] when no cycle was
/// recorded.
///
/// ```
/// use millcomp_closedloop::recording::record_spindle_sequence;
/// use millcomp_mpc::replay::replay_clarabel;
/// let seq = record_spindle_sequence(10, 20, 7).unwrap();
/// assert_eq!((seq.q.len(), seq.b.len()), (20, 20));
/// // the replay solves every recorded cycle, first moves within the 0–1000 V amplifier range
/// let r = replay_clarabel(&seq).unwrap();
/// assert_eq!(r.failures, 0);
/// assert!(r.first_moves.iter().all(|u| (0.0..=1000.0 + 1e-6).contains(u)));
/// ```
pub fn record_spindle_sequence(
    horizon: usize,
    cycles: usize,
    seed: u64,
) -> Result<QpSequence, ClosedLoopError> {
    let cfg = default_spindle_config(horizon, 1000.0, 100.0);
    record_spindle_sequence_with(&cfg, cycles, seed)
}

/// As [`record_spindle_sequence`] with an explicit configuration (two outputs: gauge, depth error).
///
/// # Errors
/// As [`record_spindle_sequence`].
pub fn record_spindle_sequence_with(
    cfg: &MpcConfig,
    cycles: usize,
    seed: u64,
) -> Result<QpSequence, ClosedLoopError> {
    let horizon = cfg.horizon;
    let sp = bench_spindle();
    // a solver benchmark, not a comparison: the MPC's (identified) model has the plant's values
    let identified = IdentifiedSpindle::new(&millcomp_models::SpindleModel {
        gain_um_per_v: sp.gain_um_per_v,
        zeta: sp.zeta,
        wn_rad_s: sp.wn_rad_s,
        pole_rad_s: sp.pole_rad_s,
        dead_time_s: sp.dead_time_s,
        dead_time_pade_order: None,
        covariance: Default::default(),
    })?;
    let model = spindle_prediction_model(&identified, BENCH_DT_S)?;
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
    Ok(QpSequence::from_cycles(
        format!(
            "millcomp-closedloop recording::record_spindle_sequence(horizon={horizon}, cycles={cycles}, seed={seed}): \
             spindle MPC (default_spindle_config, dt 0.5 ms) in closed loop on the nominal PZT spindle with a \
             synthetic groove deflection (0→17 µm ramp, ±10 % flute ripple, feed doubling halfway)"
        ),
        horizon,
        &d,
        q,
        b,
        cfg.limits.u_max[0] - cfg.limits.u_min[0],
        cfg.solver.clone(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_mpc::replay::replay_clarabel;

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
