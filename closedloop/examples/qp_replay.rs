//! Record and replay the spindle MPC's per-cycle QPs (the millcomp side of `bench/mpc-vs-casadi`).
//!
//! ```text
//! cargo run --release -p millcomp-closedloop --example qp_replay -- record HORIZON CYCLES OUT.json [SEED] [VARIANT]
//! cargo run --release -p millcomp-closedloop --example qp_replay -- replay IN.json [OUT_FIRST_MOVES.json]
//! ```
//! `replay` prints `{"median_us": …, "p99_us": …, "solve_median_us": …, "solve_p99_us": …, "failures": …,
//! "median_iterations": …, "n": …, "m": …}` (`median_us`: update_q + update_b + solve; `solve_*`: the
//! `solve()` call alone) and optionally writes the first moves as a JSON array.
//!
//! VARIANT (default `shipped`) records the spindle MPC's QP with the choices of
//! `default_spindle_config` undone one at a time, for the bench's ablation:
//! `before` — slew rows at every block boundary, tolerances 1e-10, equilibration on (the configuration
//! issue 18 measured; the first move's slew merged into its bounds, as always now); `first-block` — slew
//! rows on the first move only; `tol-1e-6` — and tolerances 1e-6; `shipped` — and equilibration off.

use std::process::ExitCode;

use millcomp_closedloop::recording::record_spindle_sequence_with;
use millcomp_mpc::config::SlewRows;
use millcomp_mpc::replay::{QpSequence, replay_clarabel};
use millcomp_mpc::spindle_mpc::default_spindle_config;

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("record") if args.len() >= 4 => {
            let horizon: usize = args[1].parse().map_err(|e| format!("HORIZON `{}`: {e}", args[1]))?;
            let cycles: usize = args[2].parse().map_err(|e| format!("CYCLES `{}`: {e}", args[2]))?;
            let seed: u64 = args.get(4).map(|s| s.parse().unwrap_or(1)).unwrap_or(1);
            let variant = args.get(5).map(String::as_str).unwrap_or("shipped");
            let mut cfg = default_spindle_config(horizon, 1000.0, 100.0);
            let sc = &mut cfg.solver;
            match variant {
                "shipped" => {}
                "tol-1e-6" => sc.equilibrate = true,
                "first-block" | "before" => {
                    (sc.equilibrate, sc.tol_gap, sc.tol_feas) = (true, 1e-10, 1e-10);
                    if variant == "before" {
                        cfg.limits.slew_rows = SlewRows::EveryBlock;
                    }
                }
                other => return Err(format!("VARIANT `{other}`: one of before, first-block, tol-1e-6, shipped")),
            }
            let seq = record_spindle_sequence_with(&cfg, cycles, seed).map_err(|e| e.to_string())?;
            let text = serde_json::to_string(&seq).map_err(|e| e.to_string())?;
            std::fs::write(&args[3], text).map_err(|e| format!("cannot write `{}`: {e}", args[3]))?;
            Ok(())
        }
        Some("replay") if args.len() >= 2 => {
            let text = std::fs::read_to_string(&args[1]).map_err(|e| format!("cannot read `{}`: {e}", args[1]))?;
            let seq: QpSequence = serde_json::from_str(&text).map_err(|e| format!("`{}`: {e}", args[1]))?;
            // one untimed warm-up pass (page faults, caches), then the measured pass
            replay_clarabel(&seq).map_err(|e| e.to_string())?;
            let r = replay_clarabel(&seq).map_err(|e| e.to_string())?;
            if let Some(out) = args.get(2) {
                let fm = serde_json::to_string(&r.first_moves).map_err(|e| e.to_string())?;
                std::fs::write(out, fm).map_err(|e| format!("cannot write `{out}`: {e}"))?;
            }
            println!(
                "{}",
                serde_json::json!({
                    "median_us": r.median_us, "p99_us": r.p99_us,
                    "solve_median_us": r.solve_median_us, "solve_p99_us": r.solve_p99_us,
                    "failures": r.failures,
                    "median_iterations": r.median_iterations, "n": seq.p.n, "m": seq.a.m,
                    "cycles": seq.q.len()
                })
            );
            Ok(())
        }
        _ => Err("usage: qp_replay record HORIZON CYCLES OUT.json [SEED] [VARIANT] | qp_replay replay IN.json [FIRST_MOVES.json]".into()),
    }
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
