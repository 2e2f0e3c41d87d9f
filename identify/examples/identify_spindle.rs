//! Identify the PZT spindle from a synthetic open-loop step (the thesis' plant, `000_…txt`
//! §5.2.4: ζ = 0.46, ωn = 1302 rad/s, 50 µm / 1000 V, gauge offset 0.25 µm), print the JSON
//! report the CLI prints with `--json` and the TOML that `--save` writes.
//!
//! Run: `cargo run -p millcomp-identify --example identify_spindle`

use millcomp_identify::{Columns, IdentifyOptions, Target, identify_columns};
use millcomp_sim::spindle::PztSpindle;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let plant = PztSpindle::new(0.05, 0.46, 1302.0, None, None)?;
    let mut d = plant.discretize(2e-5)?;
    let t: Vec<f64> = (0..500).map(|k| k as f64 * 2e-5).collect();
    let u: Vec<f64> = (0..500).map(|k| if k >= 50 { 10.0 } else { 0.0 }).collect();
    // 5 nm gauge noise from a tiny xorshift generator (sum of 12 uniforms − 6 ≈ N(0, 1)), so the
    // example needs no RNG crate
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut gauss = move || {
        (0..12)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            })
            .sum::<f64>()
            - 6.0
    };
    let y: Vec<f64> = (0..500)
        .map(|k| 0.25 + d.step(u[k]).tip_um + 0.005 * gauss())
        .collect();
    let mut cols = Columns::new();
    cols.insert("t_s", t).insert("u_v", u).insert("y_um", y);
    let opts = IdentifyOptions::default();
    let fit = identify_columns(Target::Spindle, &cols, &opts)?;
    println!("{}", serde_json::to_string_pretty(&fit)?);
    let file = millcomp_models::ModelFile::new(
        &fit.kind,
        fit.model.clone(),
        millcomp_models::Provenance::now(
            "identify_spindle example",
            "cargo run --example identify_spindle",
        ),
    );
    println!("---- model.toml ----\n{}", file.to_toml()?);
    let zeta = fit.report.param("zeta");
    assert!((zeta - 0.46).abs() < 0.01, "zeta {zeta}");
    Ok(())
}
