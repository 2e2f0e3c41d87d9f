//! Every input the fuzz campaign found (a crash, a hang or an out-of-memory; `fuzz/regressions/<target>/`)
//! replayed through the same harness the fuzzer ran (`fuzz/src/lib.rs`, compiled here on stable), plus
//! the shipped files the campaign's corpora are seeded from: none may panic, and each harness checks
//! what an accepted input promises. A found input is a file named after what it found; its fix is in
//! the commit that added it (`git log -- fuzz/regressions`).
//!
//! Rerun: `cargo test -p millcomp-closedloop --test main fuzz_regressions`.

#[allow(dead_code)]
#[path = "../../fuzz/src/lib.rs"]
mod harness;

use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The files of `dir`, sorted (none when it does not exist).
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Replays `inputs` through the harness of `target`, naming the input that panics.
fn replay(target: &str, inputs: &[PathBuf]) {
    for path in inputs {
        let data = std::fs::read(path).unwrap();
        let outcome = std::panic::catch_unwind(|| harness::run(target, &data));
        assert!(
            outcome.is_ok(),
            "fuzz target `{target}` panics on {}",
            path.display()
        );
    }
}

#[test]
fn found_inputs_are_handled() {
    let root = repo().join("fuzz/regressions");
    let mut n = 0;
    for target in harness::TARGETS {
        let inputs = files(&root.join(target));
        n += inputs.len();
        replay(target, &inputs);
    }
    // every directory under fuzz/regressions is a target's
    for d in std::fs::read_dir(&root).into_iter().flatten().flatten() {
        let name = d.file_name().to_string_lossy().to_string();
        assert!(
            harness::TARGETS.contains(&name.as_str()) || !d.path().is_dir(),
            "fuzz/regressions/{name} is no fuzz target"
        );
    }
    eprintln!("{n} found inputs replayed");
}

/// The shipped files the corpora start from go through the harnesses too (each harness's reading of
/// them must not panic; `fuzz/run` seeds from the same places).
#[test]
fn seed_files_are_handled() {
    let r = repo();
    let csv: Vec<PathBuf> = [
        "datasets/data",
        "datasets/runs",
        "datasets/synthetic",
        "datasets/scenarios",
        "doe/data",
    ]
    .iter()
    .flat_map(|d| files(&r.join(d)))
    .filter(|p| p.extension().is_some_and(|e| e == "csv"))
    .collect();
    let with_mode = |mode: u8, paths: &[PathBuf]| -> Vec<Vec<u8>> {
        paths
            .iter()
            .map(|p| {
                let mut v = vec![mode];
                v.extend(std::fs::read(p).unwrap());
                v
            })
            .collect()
    };
    for data in with_mode(0, &csv) {
        harness::table(&data);
    }
    for p in &csv {
        harness::batch_plan(&std::fs::read(p).unwrap());
    }
    let toml = |d: &str| -> Vec<PathBuf> {
        files(&r.join(d))
            .into_iter()
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect()
    };
    replay("scenario", &toml("datasets/scenarios"));
    replay("session", &toml("datasets/sessions"));
    replay("session", &toml("datasets/synthetic"));
}

/// The sensor-log target's seeds (`fuzz/seeds/sensor_log/`: no sensor log is shipped; logs of the
/// shipped runtime programs from `millcomp simulate --sensor-log`, and one with the empty and NaN
/// readings the contract allows) go through its harness, are accepted at the program's rate and so
/// are replayed through every controller the shipped bundle builds — the harness's checks ran on the
/// commands, not only on a refusal.
#[test]
fn sensor_log_seeds_are_replayed_through_every_controller() {
    use millcomp_datasets::contracts::read_sensor_log;
    let seeds = files(&repo().join("fuzz/seeds/sensor_log"));
    assert!(seeds.len() >= 4, "{} seeds", seeds.len());
    replay("sensor_log", &seeds);
    let kinds = harness::replay_kinds();
    for kind in ["none", "open-loop", "pid", "pid-tuned", "pid-ff", "mpc"] {
        assert!(
            kinds.iter().any(|k| k.name() == kind),
            "the shipped bundle builds no `{kind}`: {kinds:?}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    for path in &seeds {
        let data = std::fs::read(path).unwrap();
        let ext = if data[0] & 1 == 0 { "csv" } else { "parquet" };
        let file = dir.path().join(format!("log.{ext}"));
        std::fs::write(&file, &data[1..]).unwrap();
        let log = read_sensor_log(&file).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        log.check_rate("seed", 5e-5)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
}

/// The program target's seeds (the shipped runtime programs and `fuzz/seeds/program/`: every
/// controller kind's family, each depth-profile kind, feed steps, an exit, both budgets, the groove
/// MPC's features) go through its harness; each is accepted and builds its controller from the
/// shipped bundle, so the harness's round trip and its checks on the commands ran on every seed.
#[test]
fn program_seeds_are_accepted_and_built() {
    use millcomp_runtime::{Controller, Program};
    let r = repo();
    let mut seeds: Vec<PathBuf> = files(&r.join("runtime/tests/data"))
        .into_iter()
        .filter(|p| std::fs::read_to_string(p).is_ok_and(|t| t.contains("\n[controller]")))
        .collect();
    assert_eq!(seeds.len(), 2, "the shipped programs: {seeds:?}");
    seeds.extend(files(&r.join("fuzz/seeds/program")));
    assert!(seeds.len() >= 6, "{} seeds", seeds.len());
    replay("program", &seeds);
    let bundle = r.join("runtime/tests/data/bundle_s7.toml");
    for path in &seeds {
        let p = Program::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            p.program.groove_program().duration_s() <= 30.0,
            "{}",
            path.display()
        );
        Controller::from_files(&bundle, path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    // found writing the harness: a touch-off above the amplifier's 1000 V was accepted and the `none`
    // controller sent it (5000 V); now the build is refused naming the key
    let found = r.join("fuzz/regressions/program/touch_off_bias_above_the_amplifier.toml");
    let e = Controller::from_files(&bundle, &found).unwrap_err().chain();
    assert!(
        e.contains("controller.touch_off.bias_v") && e.contains("1000"),
        "{e}"
    );
}

/// The recorded QP sequences the campaign found (malformed CSC arrays that panicked inside Clarabel's
/// constructor or its matrix products) are refused before a solver sees them, naming the matrix.
#[test]
fn malformed_qp_sequences_are_refused_naming_the_matrix() {
    use millcomp_mpc::replay::{QpSequence, replay_clarabel};
    let inputs = files(&repo().join("fuzz/regressions/qp_sequence"));
    assert!(inputs.len() >= 3, "the three found inputs are kept");
    for path in inputs {
        let seq: QpSequence = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        let err = replay_clarabel(&seq).expect_err("a malformed sequence is refused");
        let msg = err.to_string();
        assert!(
            msg.contains("`p`") || msg.contains("`a`"),
            "{}: {msg}",
            path.display()
        );
        assert!(seq.validate().is_err());
    }
    // the shipped golden sequence passes the same checks
    let golden: serde_json::Value = serde_json::from_slice(
        &std::fs::read(repo().join("fuzz/seeds/qp_sequence/casadi_golden.json")).unwrap(),
    )
    .unwrap();
    let seq: QpSequence = serde_json::from_value(golden["sequence"].clone())
        .or_else(|_| serde_json::from_value(golden.clone()))
        .unwrap();
    seq.validate().unwrap();
}
