//! Prints the `doe design --json` document of a blocked 2^(5-1) design and of a CCD.
//!
//! Run: `cargo run -p millcomp-doe --example design_json`.

use millcomp_doe::{DesignKind, DesignRequest, FactorSpec, generate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let f = FactorSpec::parse_list(
        "depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20,tilt_deg=20:40,coolant=off:on",
    )?;
    let mut req = DesignRequest::new(DesignKind::Fractional, f);
    req.resolution = Some(5);
    req.blocks = 2;
    req.seed = Some(1);
    let d = generate(&req)?;
    println!("{}", d.human());
    let mut j = serde_json::to_value(&d)?;
    if let Some(runs) = j.get_mut("runs").and_then(|r| r.as_array_mut()) {
        runs.truncate(2);
    }
    println!("{}", serde_json::to_string_pretty(&j)?);
    let ccd: DesignKind = "ccf".parse()?;
    let mut r2 = DesignRequest::new(
        ccd,
        FactorSpec::parse_list("depth_um=100:200,upfeed_um=10:20")?,
    );
    r2.seed = Some(1);
    println!("{}", generate(&r2)?.human());
    Ok(())
}
