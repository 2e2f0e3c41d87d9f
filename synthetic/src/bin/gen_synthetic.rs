//! Writes the synthetic measured sessions of `datasets/synthetic/` (seeded, deterministic):
//! `NAME.toml` (session, nominal model only), `NAME.csv` (measured-groove CSV), the force trace
//! `flute_runout_force.forces.csv`, and `README.md` listing what is hidden in each.
//!
//! ```text
//! cargo run -p millcomp-identify --example gen_synthetic --release [-- OUT_DIR] [--diagnose]
//! ```
//! `OUT_DIR` defaults to `datasets/synthetic` of the workspace; `--diagnose` also runs `diagnose`
//! on every case and prints what it names.

use std::path::PathBuf;

use millcomp_identify::diagnose::{DiagnoseOptions, diagnose, synthetic};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let run_diagnose = args.iter().any(|a| a == "--diagnose");
    let out = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../datasets/synthetic"));
    std::fs::create_dir_all(&out)?;
    let cases = synthetic::cases();
    for case in &cases {
        let data = synthetic::generate(case)?;
        std::fs::write(out.join(format!("{}.toml", case.name)), &data.session_toml)?;
        std::fs::write(out.join(format!("{}.csv", case.name)), &data.csv)?;
        if let Some(f) = &data.forces_csv {
            std::fs::write(out.join(format!("{}.forces.csv", case.name)), f)?;
        }
        print!("{:<45} {} rows", case.name, data.measured.len());
        if run_diagnose {
            let rep = diagnose(&data.session, &data.measured, &DiagnoseOptions::default())?;
            print!(
                "  named {:?}  RMS {:.3} -> {:.3} µm",
                rep.named, rep.initial_rms_um, rep.final_rms_um
            );
        }
        println!();
    }
    std::fs::write(out.join("README.md"), synthetic::readme(&cases))?;
    println!("wrote {} cases to {}", cases.len(), out.display());
    Ok(())
}
