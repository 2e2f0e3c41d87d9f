//! Groove stage against `000_…txt` ch. 6–7.
use crate::common;

use approx::assert_relative_eq;
use millcomp_sim::force::{CutConditions, S7_GROOVE_FORCE_SCALE};
use millcomp_sim::groove::{GrooveConfig, GrooveStage, profile};

#[test]
fn s7_groove_force_scale_reproduces_fig_7_6() {
    // Calibration record for S7_GROOVE_FORCE_SCALE: 000 §7.2.2 (Fig. 7-6) deep-end force ≈ 8.55 N
    // (6 µm axial: 6·1.220/cos²20° = 8.29 N; 9 µm radial: 9·0.114/sin²20° = 8.77 N; mean 8.53 N), 5 µm
    // wearland (Fig. 7-9), actual depth 80 µm (compensated cut).
    let cfg = GrooveConfig::thesis(20.0, 5.0).unwrap();
    let mut m = cfg.force_model.clone();
    m.params.force_scale = 1.0;
    let unscaled = m
        .peak_z_force_n(&CutConditions::new(80.0, 10.0, 10_000.0, 20.0).unwrap())
        .unwrap();
    eprintln!(
        "unscaled deep-end peak Fz = {unscaled:.4} N; scale = {:.4}",
        8.53 / unscaled
    );
    assert_relative_eq!(S7_GROOVE_FORCE_SCALE, 8.53 / unscaled, max_relative = 0.002);
}

#[test]
fn uncompensated_deflection_at_80_um_is_17_um() {
    // 000 §6.1: predicted deflection 17 µm at the 80 µm end of the 20° groove (measured 16 µm, §6.3);
    // §6.2 simulated with an 8 µm wearland.
    let cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
    let d_static = cfg.static_deflection_um(80.0).unwrap();
    eprintln!("static self-consistent deflection at 80 µm: {d_static:.2} µm");
    assert_relative_eq!(d_static, 17.0, max_relative = common::GROOVE_DEFLECTION_REL);
    // and the stepped plant at 20 kHz with no actuation agrees at the deep end
    let mut st = GrooveStage::new(cfg, 5e-5).unwrap();
    let run = st.run(|_| 0.0);
    let end = &run[run.len() - 1];
    let err = end.depth_cmd_um - end.depth_cut_um;
    eprintln!("stepped: error at end {err:.2} µm, x = {:.3}", end.x_mm);
    assert_relative_eq!(err, 17.0, max_relative = common::GROOVE_DEFLECTION_REL);
    assert_relative_eq!(err, d_static, max_relative = 0.03);
    let p = profile(&run, 1.0).unwrap();
    assert!(p.len() >= 20, "{}", p.len());
    // error grows along the ramp
    assert!(p[5].1 - p[5].2 < p[15].1 - p[15].2);
}

#[test]
fn more_deflection_at_30_than_20_degrees() {
    // 000 §7.2.2: "there was more deflection with the 30° tilt than with the 20° tilt"
    let d20 = GrooveConfig::thesis(20.0, 8.0)
        .unwrap()
        .static_deflection_um(80.0)
        .unwrap();
    let d30 = GrooveConfig::thesis(30.0, 8.0)
        .unwrap()
        .static_deflection_um(80.0)
        .unwrap();
    assert!(d30 > d20);
}

#[test]
fn a_path_offset_adds_to_the_depth_cut_where_the_tool_is() {
    // a constant 40 µm groove, 4 mm long; the machine cuts 2 µm deeper from x = 2 mm on (a guideway
    // step under the path), and nothing else changes: the depth cut there is 2 µm deeper than without,
    // up to the small extra deflection the deeper cut's force makes (loop gain ≈ 0.2, so < 0.5 µm)
    use millcomp_sim::groove::{DepthProfile, PathOffset};
    let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
    cfg.program.length_mm = 4.0;
    cfg.program.depth_profile = DepthProfile::Constant { depth_um: 40.0 };
    let plain = GrooveStage::new(cfg.clone(), 5e-5).unwrap().run(|_| 0.0);
    cfg.path_offset = PathOffset::new(vec![(1.999, 0.0), (2.0, 2.0)]).unwrap();
    let offset = GrooveStage::new(cfg, 5e-5).unwrap().run(|_| 0.0);
    assert_eq!(plain.len(), offset.len());
    let at = |run: &[millcomp_sim::groove::GrooveStepOutput], x: f64| {
        run.iter().find(|o| o.x_mm >= x).unwrap().depth_cut_um
    };
    // before the step: identical
    assert_eq!(at(&plain, 1.5), at(&offset, 1.5));
    let gain = at(&offset, 3.5) - at(&plain, 3.5);
    assert!(gain > 1.5 && gain < 2.0, "{gain}");
}
