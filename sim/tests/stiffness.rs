//! Stiffness against `000_…txt` §5.2.3, §6.1, §7.2.1 and `003_…txt` §2.2.
use crate::common;

use approx::assert_relative_eq;
use millcomp_sim::stiffness::{
    MachineStiffness, RADIAL_MODELLED_N_PER_UM, SteppedTool, TiltedToolStiffness,
};

#[test]
fn radial_and_axial_tool_stiffness() {
    let t = SteppedTool::thesis_long_tool();
    // Table 5-1 modelled radial 0.141 N/µm
    assert_relative_eq!(
        t.radial_stiffness_n_per_um().unwrap(),
        0.141,
        max_relative = common::RADIAL_MODEL_REL
    );
    // §5.2.3 "approximately 39 N/µm" axial tool stiffness: ±5 % (the thesis rounds)
    assert_relative_eq!(
        t.axial_stiffness_n_per_um().unwrap(),
        39.0,
        max_relative = 0.05
    );
}

#[test]
fn z_stiffness_at_20_degrees() {
    // 000 §6.1: 0.597 N/µm at 20°
    let kz = TiltedToolStiffness::default()
        .z_stiffness_n_per_um(20.0)
        .unwrap();
    assert_relative_eq!(kz, 0.597, max_relative = common::KZ_REL);
    // the modelled radial stiffness does NOT reproduce it (documented choice of the measured value)
    let km = TiltedToolStiffness::new(1.220, RADIAL_MODELLED_N_PER_UM)
        .unwrap()
        .z_stiffness_n_per_um(20.0)
        .unwrap();
    assert!((km - 0.597).abs() / 0.597 > common::KZ_REL);
}

#[test]
fn effective_pzt_compliance_eq_28() {
    // 000 §7.2.1: 5.17, 5.75, 6.57 (printed "N/µm"; dimensionally µm/N) at 20/30/40°
    let s = TiltedToolStiffness::default();
    for (tilt, published) in [(20.0, 5.17), (30.0, 5.75), (40.0, 6.57)] {
        assert_relative_eq!(
            s.pzt_compliance_um_per_n(tilt).unwrap(),
            published,
            max_relative = common::PZT_COMPLIANCE_REL
        );
    }
}

#[test]
fn deflection_parts_at_the_deep_end_of_fig_7_6() {
    // 000 §7.2.2: 15 µm z-error = 9 µm radial + 6 µm axial at the deep end of the 20° cut. With one
    // z-force both parts must come out in that ratio: radial/axial = tan²α·k_a/k_r = 1.41 (9/6 = 1.5)
    let (ax, rad) = TiltedToolStiffness::default()
        .z_deflection_parts_um(8.55, 20.0)
        .unwrap();
    assert_relative_eq!(ax, 6.0, max_relative = 0.1);
    assert_relative_eq!(rad, 9.0, max_relative = 0.1);
}

#[test]
fn machine_in_series_reduces_span() {
    // 003 eq. (5): the system span is always smaller than the machine span
    let m = MachineStiffness::new(30.0, 10.0).unwrap();
    for kt in [0.1, 1.0, 10.0, 100.0] {
        assert!(m.system_span(kt).unwrap() < 10.0);
    }
}
