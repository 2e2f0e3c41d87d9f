//! End-to-end tests of `millcomp simulate SESSION`.

use crate::common::*;

use predicates::prelude::*;

const EXAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/sessions/example.toml"
);

#[test]
fn session_csv_follows_the_measured_groove_contract_and_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.csv");
    let plot = dir.path().join("run.svg");
    millcomp()
        .args(["simulate", EXAMPLE, "--out"])
        .arg(&out)
        .arg("--plot")
        .arg(&plot)
        .assert()
        .success()
        .stdout(predicate::str::contains("written"));
    let text = std::fs::read_to_string(&out).unwrap();
    let header = millcomp_datasets::contracts::MEASURED_GROOVE_COLUMNS.join(",");
    assert!(text.starts_with(&header), "{}", &text[..200]);
    assert!(std::fs::read_to_string(&plot).unwrap().contains("<svg"));
    // What simulate writes is what diagnose accepts.
    millcomp()
        .args(["datasets", "check"])
        .arg(&out)
        .args(["--as", "measured-groove"])
        .assert()
        .success();
    // Noise-free output is the library's prediction, bit for bit.
    let session = millcomp_sim::session::Session::from_path(std::path::Path::new(EXAMPLE)).unwrap();
    let points = millcomp_sim::session::simulate_session(&session, &Default::default()).unwrap();
    let read = millcomp_datasets::contracts::read_measured_groove(&out).unwrap();
    assert_eq!(read.points.len(), points.len());
    for (m, p) in read.points.iter().zip(&points) {
        assert!(
            (m.depth_meas_um - p.depth_meas_um).abs() <= 1e-12 * p.depth_meas_um.abs().max(1.0)
        );
    }
}

#[test]
fn noise_seed_changes_the_profile_by_about_the_profilometer_noise() {
    let run = |extra: &[&str]| -> Vec<f64> {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("r.csv");
        millcomp()
            .args(["simulate", EXAMPLE, "--out"])
            .arg(&out)
            .args(extra)
            .assert()
            .success();
        millcomp_datasets::contracts::read_measured_groove(&out)
            .unwrap()
            .points
            .iter()
            .map(|p| p.depth_meas_um)
            .collect()
    };
    let clean = run(&[]);
    let noisy = run(&["--noise-seed", "7"]);
    let again = run(&["--noise-seed", "7"]);
    assert_eq!(noisy, again, "seeded noise is reproducible");
    let rms = (clean
        .iter()
        .zip(&noisy)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / clean.len() as f64)
        .sqrt();
    // sigma = 0.1 um (PROFILOMETER_SIGMA_UM); with ~160 points the sample RMS is within ±25 %.
    assert!((0.075..0.125).contains(&rms), "rms {rms}");
}

#[test]
fn bad_session_names_the_key_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text =
        std::fs::read_to_string(EXAMPLE)
            .unwrap()
            .replacen("tilt_deg = 20.0", "tilt_deg = 95.0", 1);
    std::fs::write(&bad, text).unwrap();
    let out = dir.path().join("run.csv");
    millcomp()
        .args(["simulate"])
        .arg(&bad)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("bad.toml"))
        .stderr(predicate::str::contains("tilt"));
    assert!(!out.exists());
}

#[test]
fn json_summary_lists_each_groove() {
    let out = millcomp()
        .args(["simulate", EXAMPLE, "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let doc: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let grooves = doc["grooves"].as_array().unwrap();
    assert_eq!(grooves.len(), 4);
    // Uncompensated ramp groove at 20 deg tilt: deflection of the order of the thesis's 16-17 um
    // (000_…txt §6.3) plus the session's effects, so the largest error is clearly negative.
    assert!(grooves[0]["max_error_um"].as_f64().unwrap() < -8.0);
}

const GROOVE_30: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/scenarios/groove_s7_30deg.toml"
);

#[test]
fn scenario_with_mpc_reports_metrics_and_solver_stats() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("trace.csv");
    let run = |controller: &str| -> serde_json::Value {
        let o = millcomp()
            .args([
                "simulate",
                GROOVE_30,
                "--controller",
                controller,
                "--json",
                // timed, not enforced: the result must not depend on how busy the test machine is
                "--no-realtime",
                "--out",
            ])
            .arg(&out)
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        serde_json::from_slice(&o).unwrap()
    };
    let none = run("none");
    let mpc = run("mpc");
    for doc in [&none, &mpc] {
        for k in [
            "pp_error_um",
            "rms_error_um",
            "max_error_um",
            "min_error_um",
            "actuator_travel_um",
        ] {
            assert!(doc["metrics"][k].as_f64().unwrap().is_finite(), "{k}");
        }
    }
    // 000_…txt §7.2.2 (Figure 7-13): uncompensated 30 deg groove error about 16 um.
    let pp_none = none["metrics"]["pp_error_um"].as_f64().unwrap();
    assert!(
        (13.0..19.0).contains(&pp_none),
        "uncompensated pp {pp_none}"
    );
    // Issue 6: MPC removes at least 90 % of it.
    let pp_mpc = mpc["metrics"]["pp_error_um"].as_f64().unwrap();
    assert!(pp_mpc <= 0.1 * pp_none, "mpc pp {pp_mpc} vs {pp_none}");
    assert!(mpc["solver"]["solves"].as_u64().unwrap() > 1000);
    assert_eq!(mpc["solver"]["fallbacks"], 0);
    assert_eq!(mpc["solver"]["budget_enforced"], false);
    assert_eq!(mpc["realtime"], false);
    let st = &mpc["solver"];
    assert!(st["max_us"].as_f64().unwrap() >= st["p99_us"].as_f64().unwrap());
    assert!((st["budget_us"].as_f64().unwrap() - 250.0).abs() < 1e-9); // 0.5 × 500 µs
    assert!(std::fs::read_to_string(&out).unwrap().lines().count() > 10);
}

#[test]
fn an_impossible_cycle_budget_is_missed_every_cycle_and_the_commands_stay_safe() {
    // 1e-4 of the 0.5 ms period (50 ns): enforced in a real-time run, every cycle falls back
    let o = millcomp()
        .args([
            "simulate",
            GROOVE_30,
            "--controller",
            "mpc",
            "--json",
            "--budget-fraction",
            "0.0001",
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let doc: serde_json::Value = serde_json::from_slice(&o).unwrap();
    let st = &doc["solver"];
    assert_eq!(st["budget_enforced"], true);
    let solves = st["solves"].as_u64().unwrap();
    assert!(solves > 1000);
    assert_eq!(st["deadline_misses"].as_u64(), Some(solves));
    assert_eq!(st["fallbacks"].as_u64(), Some(solves));
    assert_eq!(doc["commands_finite"], true);
    assert_eq!(doc["commands_in_limits"], true);
    // a budget outside (0, 1] is refused, naming the key
    millcomp()
        .args([
            "simulate",
            GROOVE_30,
            "--controller",
            "mpc",
            "--budget-fraction",
            "2",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("control.budget_fraction"));
}

#[test]
fn unknown_controller_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("trace.csv");
    millcomp()
        .args(["simulate", GROOVE_30, "--controller", "fuzzy", "--out"])
        .arg(&out)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("fuzzy"));
    assert!(!out.exists());
}

/// The DOE → MPC path: a response surface saved by `doe analyze --save` on Table 3-3 (`000_…txt`, 6061,
/// 100–200 µm deep) drives the MPC's preview of the S7 feed-step groove. Every planned point lies
/// outside the surface's ranges, which the run reports; the offset-free estimator absorbs the level
/// error, and the surface's upfeed slope (0.82 N per 10 µm/rev) still anticipates the doubling.
#[test]
fn doe_response_surface_drives_the_mpc_preview() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("fz.toml");
    millcomp()
        .args([
            "doe",
            "analyze",
            concat!(env!("CARGO_MANIFEST_DIR"), "/datasets/data/clayton_doe.csv"),
            "--response",
            "max_fz_n",
            "--factors",
            "depth_um,speed_rpm,upfeed_um",
            "--save",
        ])
        .arg(&model)
        .assert()
        .success();
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/scenarios/groove_s7_20deg_feed_step.toml"
    ))
    .unwrap()
    .replace("length_mm = 20.0", "length_mm = 12.0");
    let scenario = dir.path().join("rs.toml");
    std::fs::write(
        &scenario,
        format!(
            "{base}force_response_surface = {:?}\n",
            model.display().to_string()
        ),
    )
    .unwrap();
    let run = |controller: &str| -> serde_json::Value {
        let o = millcomp()
            .arg("simulate")
            .arg(&scenario)
            .args(["--controller", controller, "--json"])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        serde_json::from_slice(&o).unwrap()
    };
    let mpc = run("mpc");
    let notes = mpc["notes"].to_string();
    assert!(notes.contains("response surface `max_fz_n`"), "{notes}");
    assert!(notes.contains("extrapolated"), "{notes}");
    assert_eq!(mpc["commands_finite"], true);
    assert_eq!(mpc["commands_in_limits"], true);
    // measured (release): MPC 0.54 µm vs PID 1.69 µm peak at the feed doubling
    let pid = run("pid");
    let (m, p) = (
        mpc["process_change_peak_um"].as_f64().unwrap(),
        pid["process_change_peak_um"].as_f64().unwrap(),
    );
    assert!(m < p, "mpc {m} pid {p}");
}
