//! Runs `diagnose` on a session file and a measured-groove CSV (what `millcomp diagnose` does,
//! without the CLI's text report and plots — `millcomp diagnose … --report DIR` writes those):
//!
//! ```text
//! cargo run -p millcomp-diagnose --example diagnose_session -- \
//!     datasets/synthetic/tool_wear.toml datasets/synthetic/tool_wear.csv [--json] \
//!     [--forces FILE] [--alpha 0.01]
//! ```

use std::path::Path;

use millcomp_datasets::contracts::{read_force_trace, read_measured_groove};
use millcomp_diagnose::{DiagnoseOptions, Measured, diagnose};
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
            let after_flag = *i > 0 && ["--forces", "--alpha"].contains(&args[i - 1].as_str());
            !a.starts_with("--") && !after_flag
        })
        .map(|(_, a)| a)
        .collect();
    let [session, csv] = positional[..] else {
        return Err("usage: diagnose_session SESSION.toml MEASURED.csv [--json] [--forces FILE] [--alpha A]".into());
    };
    let session = Session::from_path(session)?;
    let mut measured = Measured::new(csv.as_str(), read_measured_groove(Path::new(csv))?.points);
    if let Some(f) = value("--forces") {
        let rows = read_force_trace(Path::new(&f))?;
        measured = measured.with_forces(f, rows);
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
        return Ok(());
    }
    for st in &rep.steps {
        println!(
            "step: {} (p = {:.2e}), RMS {:.3} -> {:.3} µm, {:?}",
            st.effect, st.p_value, st.rms_before_um, st.rms_after_um, st.params
        );
    }
    for n in &rep.notes {
        println!("note: {n}");
    }
    println!(
        "named: {}   RMS {:.3} -> {:.3} µm",
        rep.named.join(", "),
        rep.initial_rms_um,
        rep.final_rms_um
    );
    Ok(())
}
