//! Run a scenario with its controllers (or the ones given) and print the reports as JSON lines;
//! `--sweep` adds the residual-error-vs-stiffness-error sweep (MPC and PID).
//!
//! ```text
//! cargo run --release -p millcomp-closedloop --example simulate -- datasets/scenarios/groove_s7_20deg.toml
//! cargo run --release -p millcomp-closedloop --example simulate -- datasets/scenarios/groove_s7_30deg.toml mpc pid
//! cargo run --release -p millcomp-closedloop --example simulate -- datasets/scenarios/groove_s7_20deg.toml --sweep
//! ```

use std::process::ExitCode;

use millcomp_closedloop::{
    ClosedLoopError, ControllerKind, Scenario, run_scenario, stiffness_sweep,
};

fn run() -> Result<(), ClosedLoopError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: simulate SCENARIO.toml [CONTROLLER …] [--sweep]");
        return Ok(());
    };
    let s = Scenario::load(path)?;
    if args.iter().any(|a| a == "--sweep") {
        let errors = [-0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3];
        for p in stiffness_sweep(&s, &errors, &[ControllerKind::Mpc, ControllerKind::Pid])? {
            println!("{}", serde_json::to_string(&p).unwrap_or_default());
        }
        return Ok(());
    }
    let names: Vec<String> = if args.len() > 1 {
        args[1..].to_vec()
    } else {
        s.controllers.clone()
    };
    for n in names {
        let k: ControllerKind = n.parse()?;
        let r = run_scenario(&s, k)?;
        println!("{}", serde_json::to_string(&r).unwrap_or_default());
    }
    Ok(())
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
