//! Thin-wall stage against `004_…txt` Table 5.
use crate::common;

use approx::{assert_abs_diff_eq, assert_relative_eq};
use millcomp_sim::thinwall::{
    THINWALL_KR_N_PER_MM2, THINWALL_TOOL_FLUTE_MM, ThinWallConfig, ThinWallStage, ThinWallTargets,
    calibrate_kr_and_flute, threshold_compensated_thickness_for, threshold_mean_error_pct,
    tool_stiffness_004_n_per_um, uncompensated_thickness_um,
};

/// Calibrated constants as written in the code vs recomputed: K_r is printed to 0.1 N/mm² (7 digits) and
/// the flute length to 0.1 µm; the bisections resolve both far below that, so 1e-4 relative is sharp yet
/// above the rounding of the literals (≤ 2e-5 relative).
const CALIBRATION_REL: f64 = 1e-4;

/// The threshold-compensated mean error is a step function of the constants (0.5 µm threshold, 0.1 µm
/// stage resolution); at the calibrated point the bisection lands within its last step: ±0.01 % of 2.19 %.
const THRESHOLD_MEAN_ABS_PCT: f64 = 0.01;

#[test]
fn joint_calibration_record() {
    // Joint calibration of K_r and the fluted tool length on 004 Table 5 (100 µm wall uncompensated
    // 106.7 µm; threshold compensation mean relative error (2.38 + 2.10 + 2.08)/3 = 2.19 %).
    let targets = ThinWallTargets {
        uncompensated_100_um: 106.7,
        threshold_mean_error_pct: 2.19,
    };
    assert_eq!(targets, ThinWallTargets::PAPER);
    let c = calibrate_kr_and_flute(targets).unwrap();
    eprintln!("joint calibration: {c:?}");
    assert!(c.bracketed);
    assert_relative_eq!(
        c.kr_n_per_mm2,
        THINWALL_KR_N_PER_MM2,
        max_relative = CALIBRATION_REL
    );
    assert_relative_eq!(
        c.flute_mm,
        THINWALL_TOOL_FLUTE_MM,
        max_relative = CALIBRATION_REL
    );
    assert_relative_eq!(
        c.tool_stiffness_n_per_um,
        tool_stiffness_004_n_per_um(),
        max_relative = 3.0 * CALIBRATION_REL
    );
    // the constants in the code reproduce both targets
    assert_abs_diff_eq!(
        uncompensated_thickness_um(100.0).unwrap(),
        106.7,
        epsilon = 0.01
    );
    let m = threshold_mean_error_pct(THINWALL_KR_N_PER_MM2, tool_stiffness_004_n_per_um()).unwrap();
    assert_abs_diff_eq!(m, 2.19, epsilon = THRESHOLD_MEAN_ABS_PCT);
}

#[test]
fn threshold_compensation_per_wall() {
    // 004 Table 5 with compensation: 81.9/102.1/122.5 µm. Only the mean (2.19 %) was calibrated; per wall
    // the model's trend is flatter than the paper's (sim: 81.2/102.5/123.1 µm), so each wall is checked
    // against the 2 µm tolerance and must be well below its uncompensated thickness.
    for (nominal, published) in [(80.0, 81.9), (100.0, 102.1), (120.0, 122.5)] {
        let cfg = ThinWallConfig::paper(nominal).unwrap();
        let t = threshold_compensated_thickness_for(&cfg).unwrap();
        let t0 = uncompensated_thickness_um(nominal).unwrap();
        eprintln!(
            "wall {nominal}: threshold {t:.2} µm (published {published}), uncompensated {t0:.2}"
        );
        assert_abs_diff_eq!(t, published, epsilon = common::THINWALL_ABS_UM);
        assert!(t < t0 - 2.5, "{t} vs {t0}");
    }
}

#[test]
fn uncompensated_thicknesses_follow_table_5() {
    // 004 Table 5: 80 → 85.9, 100 → 106.7, 120 → 127.8 µm without compensation; issue tolerance 2 µm.
    // Only the 100 µm wall (and the compensated mean) were used for calibration; 80 and 120 are predictions.
    for (nominal, published) in [(80.0, 85.9), (100.0, 106.7), (120.0, 127.8)] {
        let t = uncompensated_thickness_um(nominal).unwrap();
        eprintln!("wall {nominal}: {t:.2} µm (published {published})");
        assert_abs_diff_eq!(t, published, epsilon = common::THINWALL_ABS_UM);
    }
}

#[test]
fn the_grating_ruler_reads_the_command_not_the_accuracy_error() {
    // 004 §2.2: 0.1 µm resolution, 0.5 µm accuracy. With a seeded accuracy error the stage lands off its
    // command by up to 0.5 µm; the ruler (what a controller reads) shows only the quantised command.
    let mut cfg = ThinWallConfig::paper(100.0).unwrap();
    cfg.stage.accuracy_seed = Some(7);
    let dt = cfg.length_um / cfg.feed_um_s() / cfg.cells_x as f64;
    let mut st = ThinWallStage::new(cfg).unwrap();
    let mut worst: f64 = 0.0;
    let mut k = 0;
    while !st.done() && k < 90 {
        k += 1;
        let cmd = 1.0 + 0.37 * k as f64;
        let o = st.step(dt, cmd);
        // the ruler's 0.1 µm resolution: within half a count of the command, on the 0.1 µm grid
        assert!(
            (o.encoder_um - cmd).abs() <= 0.05 + 1e-9,
            "{} vs {cmd}",
            o.encoder_um
        );
        assert_abs_diff_eq!(
            o.encoder_um * 10.0,
            (o.encoder_um * 10.0).round(),
            epsilon = 1e-6
        );
        let off = o.stage_um - o.encoder_um;
        assert!(off.abs() <= 0.5 + 1e-12, "{off}");
        worst = worst.max(off.abs());
    }
    assert_eq!(k, 90, "the wall is longer than 90 stage steps");
    // uniform in ±0.5 µm over 90 moves: the largest is near the bound (P(max < 0.4) = 0.8^90 ≈ 2e-9)
    assert!(worst > 0.4, "{worst}");
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
