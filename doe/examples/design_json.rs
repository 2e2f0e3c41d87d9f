//! Prints the `doe design --json` document of a blocked 2^(5-1) design (first two runs) and of a
//! face-centred CCD.
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
    // 2^(5-1) of resolution V: 16 runs, E = ABCD, in two blocks confounded with DE (= ABC, aliased by the
    // defining relation I = ABCDE).
    assert_eq!((d.n_runs(), d.resolution, d.blocks), (16, Some(5), 2));
    assert_eq!(d.generators, ["E=ABCD"]);
    assert_eq!(d.confounded_with_blocks, ["tilt_deg:coolant"]);
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
    let ccf = generate(&r2)?;
    // face-centred: α = 1, 4 factorial + 4 axial + 4 centre points (the default for a CCD)
    assert_eq!((ccf.n_runs(), ccf.alpha), (12, Some(1.0)));
    println!("{}", serde_json::to_string_pretty(&ccf)?);
    Ok(())
}
