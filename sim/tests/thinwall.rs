//! Thin-wall stage against `004_…txt` Table 5.
mod common;

use approx::assert_abs_diff_eq;
use millcomp_sim::thinwall::{
    THINWALL_KR_N_PER_MM2, ThinWallConfig, ThinWallStage, uncompensated_thickness_um,
};

fn thickness_with_kr(nominal: f64, kr: f64) -> f64 {
    let mut cfg = ThinWallConfig::paper(nominal).unwrap();
    cfg.kr_n_per_mm2 = kr;
    let dt = cfg.length_um / cfg.feed_um_s() / cfg.cells_x as f64;
    let mut st = ThinWallStage::new(cfg).unwrap();
    st.run(dt, |_| 0.0).unwrap();
    st.mean_thickness_um()
}

#[test]
fn kr_calibration_record() {
    // Calibrate K_r ONCE on the 100 µm wall: 106.7 µm uncompensated (004 Table 5) — bisection.
    let (mut lo, mut hi) = (1.0f64, 1e6f64);
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if thickness_with_kr(100.0, mid) < 106.7 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let kr = (lo * hi).sqrt();
    eprintln!("calibrated K_r = {kr:.1} N/mm²");
    assert!((kr - THINWALL_KR_N_PER_MM2).abs() / kr < 1e-3, "{kr}");
}

#[test]
fn uncompensated_thicknesses_follow_table_5() {
    // 004 Table 5: 80 → 85.9, 100 → 106.7, 120 → 127.8 µm without compensation; issue tolerance 2 µm.
    // Only the 100 µm wall was used for calibration; 80 and 120 are predictions.
    for (nominal, published) in [(80.0, 85.9), (100.0, 106.7), (120.0, 127.8)] {
        let t = uncompensated_thickness_um(nominal).unwrap();
        eprintln!("wall {nominal}: {t:.2} µm (published {published})");
        assert_abs_diff_eq!(t, published, epsilon = common::THINWALL_ABS_UM);
    }
}

#[test]
fn stage_command_reduces_the_thickness_and_force_is_measured() {
    let cfg = ThinWallConfig::paper(100.0).unwrap();
    let dt = cfg.length_um / cfg.feed_um_s() / cfg.cells_x as f64;
    let mut st = ThinWallStage::new(cfg).unwrap();
    let run = st.run(dt, |_| 3.04).unwrap();
    // resolution 0.1 µm: 3.04 → 3.0
    assert_abs_diff_eq!(run[0].stage_um, 3.0, epsilon = 1e-12);
    let t = st.mean_thickness_um();
    let t0 = uncompensated_thickness_um(100.0).unwrap();
    assert!(t < t0 - 2.0, "{t} vs {t0}");
    assert!(run.iter().all(|o| o.force_meas_n >= 0.0));
    assert_eq!(run.iter().map(|o| o.layer).max(), Some(3));
}
