//! CLI manners: a reader that stops early ends each verb quietly, and each verb's `--help` shows an
//! example.

use std::io::Read;
use std::process::Stdio;

use crate::common::*;

/// Each verb's largest output (of the inputs that keep the test quick), piped into a reader that closes
/// after 16 bytes: the verb ends quietly — successfully, or by SIGPIPE as any Unix tool does — with no
/// panic and no error on stderr. (`demo` prints through the same code as `pipeline`, here with a plan
/// that runs no stage.)
#[cfg(unix)]
#[test]
fn a_reader_that_closes_early_ends_every_verb_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let tmp = tempfile::tempdir().unwrap();
    let empty_plan = write(tmp.path(), "plan.toml", "name = \"nothing to run\"\n");
    let out = |n: &str| tmp.path().join(n).display().to_string();
    let session = repo("datasets/synthetic/coolant_thermal_drift.toml");
    let measured = repo("datasets/synthetic/coolant_thermal_drift.csv");
    let cases: Vec<Vec<String>> = vec![
        vec!["datasets".into(), "show".into(), "fl_thermal_drift".into()],
        vec![
            "doe".into(),
            "design".into(),
            "--design".into(),
            "lhs".into(),
            "--factors".into(),
            "a=0:1,b=0:1,c=0:1,d=0:1".into(),
            "--runs".into(),
            "3000".into(),
            "--seed".into(),
            "1".into(),
        ],
        vec![
            "identify".into(),
            "spindle".into(),
            repo("datasets/runs/spindle_step_synthetic.csv"),
            "--json".into(),
        ],
        vec!["diagnose".into(), session, measured, "--json".into()],
        vec!["simulate".into(), repo("datasets/sessions/example.toml")],
        vec![
            "commission".into(),
            repo("datasets/scenarios/groove_s7_20deg_commissioned.toml"),
            "--json".into(),
        ],
        vec![
            "batch".into(),
            "--doe".into(),
            "--design full --factors tilt_deg=20:40,length_mm=1:2 --seed 1".into(),
            "--controllers".into(),
            "none".into(),
            "--out".into(),
            out("batch"),
            "--json".into(),
        ],
        vec![
            "parts".into(),
            repo("datasets/scenarios/groove_s7_20deg.toml"),
            "--parts".into(),
            "1".into(),
            "--seeds".into(),
            "1".into(),
            "--controllers".into(),
            "pid-tuned".into(),
            "--out".into(),
            out("parts"),
            "--json".into(),
        ],
        vec![
            "pipeline".into(),
            empty_plan.display().to_string(),
            "--out".into(),
            out("pipeline"),
            "--json".into(),
        ],
    ];
    for args in cases {
        let bin = assert_cmd::cargo::cargo_bin("millcomp");
        let mut child = std::process::Command::new(bin)
            .args(&args)
            .env("RAYON_NUM_THREADS", "2")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut head = [0u8; 16];
        let mut stdout = child.stdout.take().unwrap();
        let _ = stdout.read_exact(&mut head);
        drop(stdout);
        let mut err = String::new();
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        let status = child.wait().unwrap();
        let quiet = status.success() || status.signal() == Some(libc::SIGPIPE);
        assert!(quiet, "millcomp {args:?}: {status:?}, stderr {err}");
        assert!(
            !err.contains("panicked") && !err.contains("Broken pipe") && !err.contains("error"),
            "millcomp {args:?} wrote to stderr: {err}"
        );
    }
}

/// Every verb's `--help` ends with one example that names the verb.
#[test]
fn every_verb_shows_an_example() {
    let verbs: [&[&str]; 15] = [
        &["demo"],
        &["pipeline"],
        &["doe"],
        &["doe", "design"],
        &["doe", "analyze"],
        &["identify"],
        &["diagnose"],
        &["commission"],
        &["simulate"],
        &["batch"],
        &["batch", "merge"],
        &["parts"],
        &["datasets"],
        &["datasets", "show"],
        &["datasets", "check"],
    ];
    for v in verbs {
        let mut args = v.to_vec();
        args.push("--help");
        let o = millcomp().args(&args).output().unwrap();
        assert!(o.status.success(), "{v:?}");
        let text = String::from_utf8_lossy(&o.stdout);
        let (_, example) = text
            .split_once("Example:\n")
            .unwrap_or_else(|| panic!("{v:?} --help has no example:\n{text}"));
        let line = example.lines().next().unwrap_or("");
        assert!(
            line.trim_start().starts_with(&format!("millcomp {}", v[0])),
            "{v:?}: {line}"
        );
    }
}
