//! Helpers and tolerances shared by the integration tests of millcomp-closedloop, each argued.

use millcomp_closedloop::Scenario;

/// Load a scenario shipped in `datasets/scenarios/`.
pub fn scenario(name: &str) -> Scenario {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../datasets/scenarios")
        .join(name);
    Scenario::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// "Near the published 16–17 µm" uncompensated groove error (000_…txt §6.3: ≈ 16 µm measured at 20°,
/// 17 µm predicted; §7.2.2: ≈ 16 µm at 30° and 40°): accept 15.5–17.5 µm. The 20° truth is sim's §6.2 tool
/// (8 µm wearland, 16.0 µm); 30°/40° are calibrated to 16 µm, so ±0.5 µm only has to absorb noise and the
/// stepped-vs-static difference (< 3 %, sim's own test).
pub const UNCOMPENSATED_RANGE_UM: (f64, f64) = (15.5, 17.5);

/// Force-sensor resolution mapped to the z-deflection at 20° (0.04 N, 000 §5.2.2, × 1.75 µm/N z-compliance
/// of the measured Table 5-1 stiffnesses): differences of peak-to-peak errors below this are at the
/// measurement floor and are not a ranking of controllers.
pub const RESOLUTION_20DEG_UM: f64 = 0.07;
