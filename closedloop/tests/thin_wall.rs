//! Thin walls (004_…txt): 80/100/120 µm H59 brass walls. Published (Table 5): uncompensated
//! 85.9/106.7/127.8 µm (6.86 % mean), iterative compensation 81.9/102.1/122.5 µm (2.38/2.10/2.08 %, mean
//! 2.19 %). sim's K_r and tool fluted length are calibrated jointly on 106.7 µm and 2.19 %
//! (`millcomp_sim::thinwall::calibrate_kr_and_flute`); the scenario adds what the ideal calibration lacks:
//! the controllers' force coefficient off by up to 15 %, the identified tool stiffness, 0.001 N force noise
//! and the stage's ±0.5 µm positioning accuracy.

use crate::common::*;
use millcomp_closedloop::{ControllerKind, RunReport, run_scenario};

/// Published values, 004 Table 5.
const NOMINAL_UM: [f64; 3] = [80.0, 100.0, 120.0];
/// 004 Table 5, thickness without compensation (µm).
const UNCOMPENSATED_UM: [f64; 3] = [85.9, 106.7, 127.8];
/// 004 Table 5, mean relative error with compensation: (2.38 + 2.10 + 2.08)/3 = 2.19 %.
const THRESHOLD_MEAN_PCT: f64 = 2.19;

/// Uncompensated walls vs Table 5: the 2 µm (sim's own test, ideal stage) plus the stage's 0.5 µm
/// positioning accuracy (004 §2.2), which the scenario draws once per wall even at a zero command.
const UNCOMPENSATED_ABS_UM: f64 = 2.5;

/// "Near the published 2.19 %" (issue 6): ±0.5 percentage points. The ideal calibration hits 2.19 %
/// exactly; the scenario's stage accuracy (±0.5 µm per move, ≈ ±0.4 % of the 120 µm wall at worst, less on
/// the mean of many moves) and force noise move it by a few tenths at most.
const THRESHOLD_MEAN_RANGE_PCT: (f64, f64) = (THRESHOLD_MEAN_PCT - 0.49, THRESHOLD_MEAN_PCT + 0.51);

/// Issue 6: MPC ≤ 1 % on every wall.
const MPC_MAX_PCT: f64 = 1.0;

/// Open loop follows the plan of the perturbed model: its residual is bounded by the force-coefficient
/// error (≤ 15 %) × the uncompensated excess (≈ 7 %) ≈ 1.05 %, plus the stage accuracy 0.5 µm on the
/// 80 µm wall (0.63 %): 1.7 %.
const OPEN_LOOP_MAX_PCT: f64 = 1.7;

/// PID measures the force, so the force-coefficient error drops out; what remains is the stage accuracy
/// (0.63 % of 80 µm) and the lag at layer changes: the 1 % bound for the model-based controllers.
const PID_MAX_PCT: f64 = 1.0;

fn pct(r: &RunReport) -> Vec<f64> {
    r.metrics.thickness_error_pct.clone().unwrap()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn thin_walls_all_controllers_against_table_5() {
    let s = scenario("thin_wall_h59.toml");
    let run = |k| run_scenario(&s, k).unwrap();
    let (none, thr, mpc) = (
        run(ControllerKind::None),
        run(ControllerKind::Threshold),
        run(ControllerKind::Mpc),
    );
    let (ol, pid) = (run(ControllerKind::OpenLoop), run(ControllerKind::Pid));
    for r in [&none, &thr, &mpc, &ol, &pid] {
        eprintln!(
            "{:10} {:?} µm, {:?} %",
            r.controller,
            r.metrics.thickness_um.as_ref().unwrap(),
            pct(r)
        );
        assert_eq!(r.walls.as_ref().unwrap().len(), 3);
        assert!(r.commands_finite && r.commands_in_limits);
    }

    // uncompensated: per wall within 2.5 µm of Table 5, mean within ±1.5 % of the published 6.86 %
    let t_none = none.metrics.thickness_um.clone().unwrap();
    for ((t, published), nominal) in t_none.iter().zip(UNCOMPENSATED_UM).zip(NOMINAL_UM) {
        assert!(
            (t - published).abs() <= UNCOMPENSATED_ABS_UM,
            "wall {nominal}: {t} µm"
        );
    }
    assert!((mean(&pct(&none)) - 6.86).abs() < 1.5, "{:?}", pct(&none));

    // the faithful 004 threshold baseline lands near the published 2.19 % mean (Table 5), every wall
    // thinner than uncompensated and still over nominal (it never compensates the tool deflection)
    let m = mean(&pct(&thr));
    assert!(
        m >= THRESHOLD_MEAN_RANGE_PCT.0 && m <= THRESHOLD_MEAN_RANGE_PCT.1,
        "threshold mean {m} %"
    );
    for (i, p) in pct(&thr).iter().enumerate() {
        assert!(*p > 0.0 && *p < pct(&none)[i] - 2.0, "wall {i}: {p} %");
    }

    // MPC ≤ 1 % on every wall (issue 6), no fallbacks; PID and open loop within their bounds
    for (i, p) in pct(&mpc).iter().enumerate() {
        assert!(p.abs() <= MPC_MAX_PCT, "mpc wall {i}: {p} %");
    }
    assert_eq!(mpc.solver.as_ref().unwrap().fallbacks, 0);
    for (i, p) in pct(&pid).iter().enumerate() {
        assert!(p.abs() <= PID_MAX_PCT, "pid wall {i}: {p} %");
    }
    for (i, p) in pct(&ol).iter().enumerate() {
        assert!(p.abs() <= OPEN_LOOP_MAX_PCT, "open-loop wall {i}: {p} %");
    }
    // MPC is at least as good as the published method on every wall
    for (m, t) in pct(&mpc).iter().zip(pct(&thr)) {
        assert!(m.abs() < t.abs(), "mpc {m} % vs threshold {t} %");
    }
}

/// `truth.draw_wall` makes every wall its own part, drawn on the wall's seed (two seeds, two different
/// walls; within the documented spreads of `millcomp_sim::wall_variation`); `truth.wall = {…}` is applied
/// as given to every wall and wins over `draw_wall`; a factor that is not a finite positive number is
/// refused naming `truth.wall.<factor>`; neither key leaves the published wall. The hard form of the
/// comparison draws the part and drops the deliberate force errors.
#[test]
fn truth_wall_variation_keys_reach_the_thin_wall_truth() {
    use millcomp_closedloop::thin_wall::thin_wall_truth;
    use millcomp_closedloop::{ClosedLoopError, Scenario};
    use millcomp_sim::thinwall::{THINWALL_KR_N_PER_MM2, ThinWallConfig};
    let base = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../datasets/scenarios/thin_wall_h59.toml"),
    )
    .unwrap();
    let scenario_with = |seed: u64, truth_keys: &str| {
        let t = base
            .replace("seed = 4", &format!("seed = {seed}"))
            .replace("[truth]\n", &format!("[truth]\n{truth_keys}\n"));
        Scenario::from_toml_str(&t, "t")
    };
    let walls = |seed: u64, truth_keys: &str| -> Vec<ThinWallConfig> {
        let s = scenario_with(seed, truth_keys).unwrap();
        (0..3).map(|i| thin_wall_truth(&s, i).unwrap()).collect()
    };
    let material = |c: &ThinWallConfig| (c.e_gpa, c.kr_n_per_mm2);

    // default: the published wall (E = 100 GPa, the calibrated K_r) on every wall
    for c in walls(1, "") {
        assert_eq!(material(&c), (100.0, THINWALL_KR_N_PER_MM2));
    }

    // drawn: two seeds give two different walls; within a scenario every wall is its own part; seeded;
    // inside the documented spreads (E uniform ±8 %, K_r within 5 σ of its 4 %)
    let a = walls(1, "draw_wall = true");
    let b = walls(2, "draw_wall = true");
    assert_eq!(a, walls(1, "draw_wall = true"));
    for (ca, cb) in a.iter().zip(&b) {
        assert_ne!(material(ca), material(cb));
        for c in [ca, cb] {
            assert_ne!(material(c), (100.0, THINWALL_KR_N_PER_MM2));
            assert!((c.e_gpa / 100.0 - 1.0).abs() <= 0.08, "{}", c.e_gpa);
            assert!((c.kr_n_per_mm2 / THINWALL_KR_N_PER_MM2 - 1.0).abs() < 0.2);
        }
    }
    assert_ne!(material(&a[0]), material(&a[1]));
    // only the material moves: geometry, tool, stage seed as without the part
    let published = walls(1, "");
    for (c, p) in a.iter().zip(&published) {
        let mut c = c.clone();
        (c.e_gpa, c.kr_n_per_mm2) = material(p);
        assert_eq!(&c, p);
    }

    // explicit: applied as given to every wall, and it wins over draw_wall
    for extra in ["", "\ndraw_wall = true"] {
        for c in walls(
            1,
            &format!("wall = {{ e_factor = 1.05, kr_factor = 0.97 }}{extra}"),
        ) {
            assert!((c.e_gpa - 105.0).abs() < 1e-12);
            assert!((c.kr_n_per_mm2 - 0.97 * THINWALL_KR_N_PER_MM2).abs() < 1e-9);
        }
    }
    // a partial table keeps the other factor at 1
    for c in walls(1, "wall = { kr_factor = 1.1 }") {
        assert_eq!(c.e_gpa, 100.0);
        assert!((c.kr_n_per_mm2 - 1.1 * THINWALL_KR_N_PER_MM2).abs() < 1e-9);
    }

    // invalid: refused at load, naming the key
    let key_of = |keys: &str| match scenario_with(1, keys) {
        Err(ClosedLoopError::InvalidConfig { key, .. }) => key,
        other => panic!("{keys}: expected InvalidConfig, got {other:?}"),
    };
    assert_eq!(key_of("wall = { e_factor = 0.0 }"), "truth.wall.e_factor");
    assert_eq!(
        key_of("wall = { kr_factor = -0.5 }\ndraw_wall = true"),
        "truth.wall.kr_factor"
    );
    assert_eq!(key_of("wall = { e_factor = nan }"), "truth.wall.e_factor");
    // unknown factor: the parser names it
    let e = scenario_with(1, "wall = { e_gpa = 90.0 }").unwrap_err();
    assert!(e.to_string().contains("e_gpa"), "{e}");
    // the keys belong to the thin wall only
    let groove = scenario("groove_s7_20deg.toml");
    let mut drawn = groove.clone();
    drawn.truth.draw_wall = true;
    let mut given = groove.clone();
    given.truth.wall = Some(millcomp_sim::wall_variation::WallVariation::NONE);
    for (key, s) in [("truth.draw_wall", drawn), ("truth.wall", given)] {
        match s.validate() {
            Err(ClosedLoopError::InvalidConfig { key: k, .. }) => assert_eq!(k, key),
            other => panic!("{key}: {other:?}"),
        }
    }

    // the hard form: a drawn part, no deliberate force errors
    let hard = millcomp_closedloop::compare::commissioned(&scenario("thin_wall_h59.toml"));
    assert!(hard.truth.draw_wall);
    assert_eq!(hard.truth.force_error_max, 0.0);
    assert!(hard.truth.force_errors.is_none());
    hard.validate().unwrap();
}

/// A drawn part reaches the cut wall: the uncompensated walls differ from the published wall's, and the
/// run report names the part's factors.
#[test]
fn a_drawn_part_changes_the_cut_wall() {
    let exact = scenario("thin_wall_h59.toml");
    let mut part = exact.clone();
    part.truth.draw_wall = true;
    let (r0, r1) = (
        run_scenario(&exact, ControllerKind::None).unwrap(),
        run_scenario(&part, ControllerKind::None).unwrap(),
    );
    for (t0, t1) in pct(&r0).iter().zip(pct(&r1)) {
        assert!((t0 - t1).abs() > 1e-6, "{t0} vs {t1}");
    }
    assert!(
        r1.notes.iter().any(|n| n.contains("truth part")),
        "{:?}",
        r1.notes
    );
    assert!(!r0.notes.iter().any(|n| n.contains("truth part")));
}
