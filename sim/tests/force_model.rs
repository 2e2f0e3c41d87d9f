//! Cutting-force model against the published figures of `000_…txt`.
use crate::common;

use approx::assert_abs_diff_eq;
use millcomp_sim::force::{BallEndForceModel, CutConditions, FlankLaw, ForceParams};
use millcomp_sim::material::Material;
use millcomp_sim::tool::BallEndTool;

/// `000_…txt` Table 3-3: (depth µm, speed rpm, upfeed µm/rev, max X, max Y, max Z in N), 6061.
const TABLE_3_3: [(f64, f64, f64, f64, f64, f64); 8] = [
    (200.0, 10_000.0, 20.0, 3.34, 1.75, 2.17),
    (100.0, 10_000.0, 20.0, 1.78, 1.33, 1.24),
    (100.0, 20_000.0, 10.0, 0.94, 0.93, 0.59),
    (200.0, 20_000.0, 10.0, 1.91, 1.64, 0.83),
    (200.0, 20_000.0, 20.0, 3.60, 2.30, 2.00),
    (100.0, 20_000.0, 20.0, 2.20, 1.75, 1.50),
    (200.0, 10_000.0, 10.0, 2.20, 2.10, 1.40),
    (100.0, 10_000.0, 10.0, 1.00, 1.10, 0.82),
];

/// Tool assumed for the DOE (not published): 0° tilt; wearland 4 µm and runout 8 µm, the values of the
/// 0°-tilt 6061 cuts in Table 4-4 (Figs. 4-14, C-8).
fn doe_model() -> BallEndForceModel {
    BallEndForceModel::new(
        Material::al6061(),
        BallEndTool::new(400.0, 4.0, 8.0).unwrap(),
        ForceParams::default(),
    )
    .unwrap()
}

fn table33_mean_rel_error(m: &BallEndForceModel) -> (f64, Vec<[f64; 3]>) {
    let mut errs = Vec::new();
    let mut preds = Vec::new();
    for (d, s, f, x, y, z) in TABLE_3_3 {
        let c = CutConditions::new(d, f, s, 0.0).unwrap();
        let p = m.table33_response(&c).unwrap();
        for (pi, mi) in p.iter().zip([x, y, z]) {
            errs.push((pi - mi).abs() / mi);
        }
        preds.push(p);
    }
    (errs.iter().sum::<f64>() / errs.len() as f64, preds)
}

#[test]
fn table_3_3_peak_forces_within_35_percent_on_average() {
    let (e, preds) = table33_mean_rel_error(&doe_model());
    eprintln!("Table 3-3 predictions (x, y, z): {preds:?}; mean rel error {e:.3}");
    assert!(e < common::TABLE33_MEAN_REL, "mean relative error {e}");
    // the x-forces alone are much better (the thesis' y-force weakness is what costs most)
    let mut ex = 0.0;
    for ((_, _, _, x, _, _), p) in TABLE_3_3.iter().zip(&preds) {
        ex += (p[0] - x).abs() / x / 8.0;
    }
    assert!(ex < 0.15, "x-force mean rel error {ex}");
}

#[test]
fn table_3_3_speed_does_not_matter_depth_and_upfeed_do() {
    // 000 §3.5.1: depth and upfeed significant, speed not — the model has no speed term at all.
    let m = doe_model();
    let r = |d: f64, s: f64, f: f64| {
        m.table33_response(&CutConditions::new(d, f, s, 0.0).unwrap())
            .unwrap()
    };
    assert_eq!(r(100.0, 10_000.0, 10.0), r(100.0, 20_000.0, 10.0));
    assert!(r(200.0, 10_000.0, 10.0)[0] > 1.5 * r(100.0, 10_000.0, 10.0)[0]);
    assert!(r(100.0, 10_000.0, 20.0)[2] > 1.2 * r(100.0, 10_000.0, 10.0)[2]);
}

#[test]
fn s7_zero_tilt_z_offset_is_1_5_n() {
    // 000 §4.2.1, Fig. 4-6: S7, depth 100 µm, upfeed 20 µm/rev, 0° tilt, wearland 7 µm, runout 10 µm:
    // "the wearland defines the non-zero offset ... approximately 1.5 N". Default flank law, no fitting.
    let m = BallEndForceModel::new(
        Material::s7(),
        BallEndTool::new(400.0, 7.0, 10.0).unwrap(),
        ForceParams::default(),
    )
    .unwrap();
    let c = CutConditions::new(100.0, 20.0, 10_000.0, 0.0).unwrap();
    let fz0 = m.forces_at(&c, 0.0)[2];
    assert_abs_diff_eq!(fz0, 1.5, epsilon = common::OFFSET_ABS_N);
    // the offset is the minimum of the z-force and it vanishes with a sharp tool
    let rev = m.revolution(&c, 720).unwrap();
    let min = rev.iter().map(|f| f[2]).fold(f64::INFINITY, f64::min);
    assert_abs_diff_eq!(min, fz0, epsilon = 1e-9);
    let sharp = m.with_param("wearland_um", 0.0).unwrap();
    assert_abs_diff_eq!(sharp.forces_at(&c, 0.0)[2], 0.0, epsilon = 1e-12);
    // elastic-recovery law with c = 9.24 (calibrated on this offset) gives the same
    let mut er = m.clone();
    er.params.flank_law = FlankLaw::ElasticRecovery { c: 9.24 };
    assert_abs_diff_eq!(er.forces_at(&c, 0.0)[2], 1.5, epsilon = 0.01);
}

#[test]
fn duty_cycle_90_and_75_percent() {
    // 000 §4.2.1: ≈ 90 % at 10° and ≈ 75 % at 25° for depths of about 50 µm; 1 at 0°
    let m = BallEndForceModel::default();
    assert_abs_diff_eq!(m.duty_cycle(50.0, 10.0), 0.90, epsilon = common::DUTY_ABS);
    assert_abs_diff_eq!(m.duty_cycle(50.0, 25.0), 0.75, epsilon = common::DUTY_ABS);
    assert_eq!(m.duty_cycle(50.0, 0.0), 1.0);
    // forces are zero in the out-of-contact window at the start of each flute (10°: ≈ 8° per side)
    let c = CutConditions::new(50.0, 10.0, 10_000.0, 10.0).unwrap();
    assert_eq!(m.forces_at(&c, 5f64.to_radians()), [0.0; 3]);
    assert!(m.forces_at(&c, 20f64.to_radians())[2] > 0.0);
}

#[test]
fn runout_makes_second_flute_cut_more() {
    // 000 §4: "the first flute in each figure produces smaller forces than the second flute"
    let m = BallEndForceModel::default();
    let c = CutConditions::new(80.0, 20.0, 10_000.0, 0.0).unwrap();
    let p = m.per_flute_peaks(&c, 720).unwrap();
    assert!(p[1][0] > p[0][0]);
    let no_runout = m.clone();
    let mut t = no_runout.tool.clone();
    t.runout_um = 0.0;
    let m0 = BallEndForceModel::new(m.material.clone(), t, m.params).unwrap();
    let p0 = m0.per_flute_peaks(&c, 720).unwrap();
    assert_abs_diff_eq!(p0[0][0], p0[1][0], epsilon = 1e-9);
}

#[test]
fn force_along_ramp_grows_with_depth() {
    let m = BallEndForceModel::default();
    let c = CutConditions::new(0.0, 10.0, 10_000.0, 20.0).unwrap();
    let series = m
        .force_along_path(&c, 2.0, |x| 40.0 * x, 1.0 / 20_000.0)
        .unwrap();
    let first = series[..200].iter().map(|s| s.2[2]).fold(0.0, f64::max);
    let last = series[series.len() - 200..]
        .iter()
        .map(|s| s.2[2])
        .fold(0.0, f64::max);
    assert!(last > 3.0 * first);
    // feed 100 mm/min → 2 mm in 1.2 s
    assert_abs_diff_eq!(series.last().unwrap().0, 1.2, epsilon = 1e-4);
}
