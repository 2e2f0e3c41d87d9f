//! Record and replay the spindle MPC's per-cycle QPs (the millcomp side of `bench/mpc-vs-casadi`).
//!
//! ```text
//! cargo run --release -p millcomp-closedloop --example qp_replay -- record HORIZON CYCLES OUT.json [SEED]
//! cargo run --release -p millcomp-closedloop --example qp_replay -- replay IN.json [OUT_FIRST_MOVES.json]
//! ```
//! `replay` prints `{"median_us": …, "p99_us": …, "failures": …, "median_iterations": …, "n": …, "m": …}`
//! and optionally writes the first moves as a JSON array.

use std::process::ExitCode;

use millcomp_closedloop::recording::record_spindle_sequence;
use millcomp_mpc::replay::{QpSequence, replay_clarabel};

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("record") if args.len() >= 4 => {
            let horizon: usize = args[1].parse().map_err(|e| format!("HORIZON `{}`: {e}", args[1]))?;
            let cycles: usize = args[2].parse().map_err(|e| format!("CYCLES `{}`: {e}", args[2]))?;
            let seed: u64 = args.get(4).map(|s| s.parse().unwrap_or(1)).unwrap_or(1);
            let seq = record_spindle_sequence(horizon, cycles, seed).map_err(|e| e.to_string())?;
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
                    "median_us": r.median_us, "p99_us": r.p99_us, "failures": r.failures,
                    "median_iterations": r.median_iterations, "n": seq.p.n, "m": seq.a.m,
                    "cycles": seq.q.len()
                })
            );
            Ok(())
        }
        _ => Err("usage: qp_replay record HORIZON CYCLES OUT.json [SEED] | qp_replay replay IN.json [FIRST_MOVES.json]".into()),
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
