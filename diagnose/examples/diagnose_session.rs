//! Runs `diagnose` on a session file and a measured-groove CSV (what `millcomp diagnose` does,
//! without the CLI):
//!
//! ```text
//! cargo run -p millcomp-identify --example diagnose_session -- \
//!     datasets/synthetic/tool_wear.toml datasets/synthetic/tool_wear.csv [--json] [--report DIR] \
//!     [--forces FILE] [--alpha 0.01]
//! ```

use std::path::PathBuf;

use millcomp_identify::diagnose::{DiagnoseOptions, ForceTrace, MeasuredGroove, diagnose};
use millcomp_sim::session::Session;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let positional: Vec<&String> = args
        .iter()
        .enumerate()
        .filter(|(i, a)| {
            let after_flag =
                *i > 0 && ["--report", "--forces", "--alpha"].contains(&args[i - 1].as_str());
            !a.starts_with("--") && !after_flag
        })
        .map(|(_, a)| a)
        .collect();
    let [session, csv] = positional[..] else {
        return Err("usage: diagnose_session SESSION.toml MEASURED.csv [--json] [--report DIR] [--forces FILE] [--alpha A]".into());
    };
    let session = Session::from_path(session)?;
    let mut measured = MeasuredGroove::from_path(&PathBuf::from(csv))?;
    if let Some(f) = value("--forces") {
        measured.forces = Some(ForceTrace::from_path(&PathBuf::from(f))?);
    }
    let opts = DiagnoseOptions {
        alpha: value("--alpha")
            .map(|a| a.parse())
            .transpose()?
            .unwrap_or(0.01),
        ..DiagnoseOptions::default()
    };
    let rep = diagnose(&session, &measured, &opts)?;
    if args.iter().any(|a| a == "--json") {
        println!("{}", serde_json::to_string_pretty(&rep)?);
    } else {
        print!("{}", rep.human());
    }
    if let Some(dir) = value("--report") {
        for f in rep.write_report(&PathBuf::from(dir))? {
            eprintln!("wrote {}", f.display());
        }
    }
    Ok(())
}
