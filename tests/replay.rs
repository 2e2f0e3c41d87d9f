//! `millcomp replay`: the sensor log of a simulated run (`simulate PROGRAM --bundle --sensor-log`)
//! replayed through the same bundle and program gives the simulation's commands bit for bit (the
//! iteration budget), from CSV and from Parquet; several controllers on one log, a gap in a channel;
//! bad input names the file, the column, the row or the argument. And `commission --export-mpc`.

use std::path::{Path, PathBuf};

use millcomp_runtime::replay::{measurements, replay};
use millcomp_runtime::{Controller, ControllerKind, Program, load_bundle};
use serde_json::Value;

use crate::common::{millcomp, repo, run_json, s};

fn bundle() -> String {
    repo("runtime/tests/data/bundle_s7.toml")
}

/// The published 20° program cut at 40 µm after a 0.3 mm approach (the MPC, iteration budget).
fn program() -> PathBuf {
    PathBuf::from(repo("runtime/tests/data/cut_40um.toml"))
}

fn rows(path: &Path) -> Vec<Value> {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The rows of `controller` as (voltage bits, flags, iterations).
fn commands(rows: &[Value], controller: &str) -> Vec<(u64, u64, u64)> {
    rows.iter()
        .filter(|r| r["controller"] == controller)
        .map(|r| {
            (
                r["voltage_v"].as_f64().unwrap().to_bits(),
                r["flags"].as_u64().unwrap(),
                r["iterations"].as_u64().unwrap(),
            )
        })
        .collect()
}

/// The message of a `millcomp` call that must fail.
fn failure(args: &[&str]) -> String {
    let out = millcomp().args(args).output().unwrap();
    assert!(!out.status.success(), "millcomp {args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `simulate PROGRAM --bundle BUNDLE --sensor-log LOG --steps STEPS` (and `--out OUT`): the run's
/// report; the log (and the commands sent) written.
fn simulate_logged(
    program: &Path,
    bundle: &str,
    log: &Path,
    steps: usize,
    out: Option<&Path>,
) -> Value {
    let steps = steps.to_string();
    let mut args = vec![
        "simulate",
        s(program),
        "--bundle",
        bundle,
        "--sensor-log",
        s(log),
        "--steps",
        &steps,
    ];
    if let Some(out) = out {
        args.extend(["--out", s(out)]);
    }
    run_json(&args)
}

const STEPS: usize = 3_000;

#[test]
fn replaying_a_simulated_runs_sensor_log_gives_its_commands_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let program = program();
    let bundle = bundle();
    let sent = dir.path().join("sent.json");
    for ext in ["csv", "parquet"] {
        let log = dir.path().join(format!("sensors.{ext}"));
        let v = simulate_logged(&program, &bundle, &log, STEPS, Some(&sent));
        assert_eq!(v["samples"], STEPS);
        assert_eq!(v["controller"], "mpc");
        assert!(v["counts"]["planned"].as_u64().unwrap() >= 299, "{v}");
        let replayed = dir.path().join("replayed.json");
        let r = run_json(&[
            "replay",
            &bundle,
            s(&program),
            s(&log),
            "--out",
            s(&replayed),
        ]);
        assert_eq!(r["samples"], STEPS);
        let (want, got) = (
            commands(&rows(&sent), "mpc"),
            commands(&rows(&replayed), "mpc"),
        );
        assert_eq!(want.len(), STEPS);
        assert_eq!(got.len(), STEPS);
        for (k, (w, g)) in want.iter().zip(&got).enumerate() {
            assert_eq!(
                w, g,
                "{ext} log, cycle {k}: (voltage bits, flags, iterations)"
            );
        }
        assert!(want.iter().any(|c| c.0 != 0), "the MPC moved the stack");
    }
}

#[test]
fn several_controllers_on_a_log_with_a_gap() {
    let dir = tempfile::tempdir().unwrap();
    let program = program();
    let bundle = bundle();
    let log = dir.path().join("sensors.csv");
    simulate_logged(&program, &bundle, &log, 2000, None);
    // three periods without a force reading: empty cells
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    assert_eq!(lines[0], "t_s,x_mm,force_n,gauge_um");
    for line in &mut lines[1501..1504] {
        let mut cells: Vec<&str> = line.split(',').collect();
        cells[2] = "";
        *line = cells.join(",");
    }
    std::fs::write(&log, lines.join("\n") + "\n").unwrap();
    let out = dir.path().join("commands.json");
    let v = run_json(&[
        "replay",
        &bundle,
        s(&program),
        s(&log),
        "--controllers",
        "mpc,pid-tuned,none",
        "--out",
        s(&out),
    ]);
    let runs = v["controllers"].as_array().unwrap();
    assert_eq!(runs.len(), 3);
    for r in runs {
        // the gap's three cycles (and the first, before any reading, is not "held")
        assert_eq!(r["counts"]["readings_held"], 3, "{r}");
    }
    let rows = rows(&out);
    assert_eq!(rows.len(), 3 * 2000);
    // pid-tuned through the CLI = the runtime's replay of the same log
    let sensor = millcomp_datasets::contracts::read_sensor_log(&log).unwrap();
    assert!(sensor.force_n[1500].is_nan());
    let mut p = Program::load(&program).unwrap();
    p.controller.kind = ControllerKind::PidTuned;
    let mut ctl = Controller::from_bundle(&load_bundle(bundle.as_ref()).unwrap(), &p).unwrap();
    let lib = replay(
        &mut ctl,
        &measurements(&sensor.x_mm, &sensor.force_n, &sensor.gauge_um),
    );
    let cli = commands(&rows, "pid-tuned");
    assert_eq!(cli.len(), lib.commands.len());
    for (k, (c, l)) in cli.iter().zip(&lib.commands).enumerate() {
        assert_eq!(
            *c,
            (
                l.voltage_v.to_bits(),
                u64::from(l.flags),
                u64::from(l.iterations)
            ),
            "cycle {k}"
        );
    }
    // `none` sends the touch-off's voltage throughout
    assert!(commands(&rows, "none").iter().all(|c| c.0 == 0));
    // CSV and Parquet through the table writer
    for ext in ["csv", "parquet"] {
        let out = dir.path().join(format!("commands.{ext}"));
        millcomp()
            .args(["replay", &bundle, s(&program), s(&log), "--out", s(&out)])
            .assert()
            .success();
        let t = millcomp_datasets::read_any(&out).unwrap();
        assert_eq!(t.n_rows(), 2000);
    }
}

#[test]
fn bad_input_names_the_file_the_column_the_row_or_the_argument() {
    let dir = tempfile::tempdir().unwrap();
    let program = program();
    let bundle = bundle();
    let fail = |log_text: &str, extra: &[&str], want: &[&str]| {
        let log = dir.path().join("bad.csv");
        std::fs::write(&log, log_text).unwrap();
        let out = millcomp()
            .args(["replay", &bundle, s(&program), s(&log)])
            .args(extra)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        for w in want {
            assert!(err.contains(w), "`{w}` not in: {err}");
        }
    };
    let good = "t_s,x_mm,force_n,gauge_um\n0,,,\n5e-5,0,0.1,0.0\n";
    fail("t_s,x_mm,force_n\n0,0,0\n", &[], &["bad.csv", "gauge_um"]);
    fail(
        "t_s,x_mm,force_n,gauge_um\n0,0,abc,0\n",
        &[],
        &["bad.csv", "force_n", "row 1", "abc"],
    );
    fail(
        "t_s,x_mm,force_n,gauge_um\n0,0,inf,0\n",
        &[],
        &["bad.csv", "force_n", "row 1"],
    );
    fail("t_s,x_mm,force_n,gauge_um\n", &[], &["bad.csv"]);
    // a missing sample is a row of NaN readings, not a gap in t_s
    fail(
        "t_s,x_mm,force_n,gauge_um\n0,,,\n5e-5,0,0,0\n1.5e-4,0,0,0\n",
        &[],
        &["bad.csv", "t_s", "row 3"],
    );
    fail(
        good,
        &["--controllers", "mpc,lqr"],
        &["--controllers", "lqr"],
    );
    fail(good, &["--out", "x.xlsx"], &["x.xlsx"]);
    assert!(failure(&["replay", "no/such.toml", s(&program), "x.csv"]).contains("no/such.toml"));
    // simulate's program run: the sensor log's format from its extension, at least one cycle
    let simulate = ["simulate", s(&program), "--bundle", &bundle];
    let e = failure(
        &[
            &simulate[..],
            &["--sensor-log", "log.xlsx", "--steps", "10"],
        ]
        .concat(),
    );
    assert!(e.contains("log.xlsx"), "{e}");
    let e = failure(&[&simulate[..], &["--sensor-log", "log.csv", "--steps", "0"]].concat());
    assert!(e.contains("--steps"), "{e}");
}

/// `commission … --program P --export-mpc OUT`: the runtime's export document of the commissioned
/// bundle's MPC (the one `bench/peers/mpc_export_casadi.py` rebuilds; lives here beside the other
/// runtime-facing verbs).
#[test]
fn commission_exports_the_mpc_of_its_bundle() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("models.toml");
    let export = dir.path().join("mpc.json");
    let program = repo("runtime/tests/data/ramp_20deg.toml");
    let v = run_json(&[
        "commission",
        &repo("datasets/scenarios/groove_s7_20deg_commissioned.toml"),
        "--out",
        s(&bundle),
        "--program",
        &program,
        "--export-mpc",
        s(&export),
    ]);
    assert_eq!(v["export_mpc"]["horizon"], 20, "{v}");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&export).unwrap()).unwrap();
    assert_eq!(doc["format"], "millcomp-mpc-export");
    assert_eq!(doc["horizon"], 20);
    // the document is the library's for the bundle written beside it
    let lib = millcomp_runtime::export::export_mpc(
        &load_bundle(&bundle).unwrap(),
        &Program::load(program.as_ref()).unwrap(),
        &millcomp_runtime::Origins::default(),
    )
    .unwrap();
    assert_eq!(doc, serde_json::to_value(&lib).unwrap());
    // --export-mpc needs --program; the export is not the bundle
    let scenario = repo("datasets/scenarios/groove_s7_20deg_commissioned.toml");
    let e = failure(&["commission", &scenario, "--export-mpc", s(&export)]);
    assert!(e.contains("--program"), "{e}");
    let e = failure(&[
        "commission",
        &scenario,
        "--out",
        s(&export),
        "--program",
        &program,
        "--export-mpc",
        s(&export),
    ]);
    assert!(e.contains("--export-mpc"), "{e}");
}
