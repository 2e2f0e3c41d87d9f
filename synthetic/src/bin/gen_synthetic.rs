//! Writes the synthetic measured sessions of `datasets/synthetic/` (seeded, deterministic):
//! `NAME.toml` (session, nominal model only), `NAME.csv` (measured-groove CSV), the force trace
//! `flute_runout_force.forces.csv`, and `README.md` listing what is hidden in each.
//!
//! ```text
//! cargo run -p millcomp-synthetic --bin gen_synthetic --release [-- OUT_DIR]
//! ```
//! `OUT_DIR` defaults to `datasets/synthetic` of the workspace. To see what `diagnose` names in
//! every case: `cargo run -p millcomp-diagnose --example diagnose_synthetic --release`.

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../datasets/synthetic"));
    std::fs::create_dir_all(&out)?;
    let cases = millcomp_synthetic::cases();
    for case in &cases {
        let data = millcomp_synthetic::generate(case)?;
        for (name, text) in data.files()? {
            millcomp_datasets::write_text_atomic(&out.join(name), &text)?;
        }
        println!("{:<45} {} rows", case.name, data.points.len());
    }
    let mut drawn = Vec::new();
    for v in millcomp_synthetic::variants::committed_variants() {
        let (data, variant) = millcomp_synthetic::committed_variant_data(&v)?;
        for (name, text) in data.files()? {
            millcomp_datasets::write_text_atomic(&out.join(name), &text)?;
        }
        println!("{:<45} {} rows", v.name, data.points.len());
        drawn.push((v, variant));
    }
    let bad = millcomp_synthetic::cannot_separate_case()?;
    for (name, text) in bad.files()? {
        millcomp_datasets::write_text_atomic(&out.join(name), &text)?;
    }
    println!("{:<45} {} rows", bad.name, bad.points.len());
    millcomp_datasets::write_text_atomic(
        &out.join("README.md"),
        &millcomp_synthetic::readme(&cases, &drawn),
    )?;
    println!("wrote {} cases to {}", cases.len(), out.display());
    Ok(())
}
