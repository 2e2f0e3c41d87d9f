//! Diagnoses every synthetic case of `datasets/synthetic/` (regenerated in memory by
//! `millcomp-synthetic`) and prints what it names next to what is hidden:
//!
//! ```text
//! cargo run -p millcomp-diagnose --example diagnose_synthetic --release
//! ```

use millcomp_diagnose::{DiagnoseOptions, Measured, diagnose};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for case in millcomp_synthetic::cases() {
        let data = millcomp_synthetic::generate(&case)?;
        let mut measured = Measured::new(format!("{}.csv", case.name), data.points);
        if let Some(rows) = data.forces {
            measured = measured.with_forces(format!("{}.forces.csv", case.name), rows);
        }
        let rep = diagnose(&data.session, &measured, &DiagnoseOptions::default())?;
        let hidden: Vec<&str> = case.hidden.iter().map(|h| h.expect).collect();
        println!(
            "{:<45} hidden {:?}  named {:?}  RMS {:.3} -> {:.3} µm",
            case.name, hidden, rep.named, rep.initial_rms_um, rep.final_rms_um
        );
    }
    Ok(())
}
