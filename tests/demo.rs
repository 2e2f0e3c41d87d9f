//! `millcomp demo` and `millcomp pipeline`: the main job end to end, its stage chain (every hash
//! recomputed), its report; and the generator of the shipped synthetic spindle run.

use crate::common::*;

use millcomp_identify::targets::spindle::simulate_spindle_um;
use millcomp_sim::sensors::NoiseSource;
use millcomp_sim::spindle::PztSpindle;
use serde_json::Value;

const SPINDLE_RUN: &str = "datasets/runs/spindle_step_synthetic.csv";

/// The committed, seeded generator of `datasets/runs/spindle_step_synthetic.csv` (documented in
/// `datasets/runs/README.md`): the published plant of `000_…txt` §5.2.4 (ζ = 0.46, ωn = 1302 rad/s,
/// 0.05 µm/V), a 100 V step at 2 ms, 20 kHz for 30 ms, gauge offset 0.25 µm and σ = 0.01 µm noise.
fn generate_spindle_run() -> String {
    let spindle = PztSpindle::new(0.05, 0.46, 1302.0, None, None).expect("published spindle");
    let n = 601;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 5e-5).collect();
    let u: Vec<f64> = t
        .iter()
        .map(|&t| if t < 2e-3 { 0.0 } else { 100.0 })
        .collect();
    let y = simulate_spindle_um(&spindle, &t, &u, 0.25).expect("simulation");
    let mut noise = NoiseSource::new(5, 0.01).expect("noise");
    let mut s = String::from("t_s,u_v,y_um\n");
    for k in 0..n {
        s.push_str(&format!(
            "{:.5},{},{:.6}\n",
            t[k],
            u[k],
            y[k] + noise.sample()
        ));
    }
    s
}

#[test]
fn shipped_spindle_run_matches_its_generator() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(SPINDLE_RUN);
    let text = generate_spindle_run();
    if std::env::var_os("MILLCOMP_REGENERATE").is_some() {
        std::fs::write(&path, &text).expect("write the spindle run");
    }
    let shipped = std::fs::read_to_string(&path).expect("shipped spindle run");
    assert_eq!(shipped, text, "{SPINDLE_RUN} differs from its generator");
}

fn sha256(path: &std::path::Path) -> String {
    millcomp_models::sha256_hex(&std::fs::read(path).unwrap_or_else(|e| panic!("{path:?}: {e}")))
}

/// Recomputes every recorded hash and checks the chain: each input inside the output directory was
/// written, with the same hash, by an earlier stage. Returns the stage names.
fn check_chain(out: &std::path::Path, doc: &Value) -> Vec<String> {
    let stages = doc["stages"].as_array().expect("stages");
    let mut written: std::collections::BTreeMap<String, String> = Default::default();
    let mut names = Vec::new();
    for s in stages {
        let name = s["name"].as_str().unwrap().to_string();
        for f in s["inputs"].as_array().unwrap() {
            let (p, h) = (f["path"].as_str().unwrap(), f["sha256"].as_str().unwrap());
            let path = std::path::Path::new(p);
            if path.is_absolute() {
                assert_eq!(sha256(path), h, "{name}: {p}");
                continue;
            }
            assert_eq!(
                written.get(p).map(String::as_str),
                Some(h),
                "{name} read {p}, which no earlier stage wrote with that hash"
            );
            assert_eq!(sha256(&out.join(p)), h, "{name}: {p}");
        }
        for f in s["outputs"].as_array().unwrap() {
            let (p, h) = (f["path"].as_str().unwrap(), f["sha256"].as_str().unwrap());
            assert!(
                !std::path::Path::new(p).is_absolute(),
                "{name}: {p} not relative to --out"
            );
            assert_eq!(sha256(&out.join(p)), h, "{name}: {p}");
            written.insert(p.to_string(), h.to_string());
        }
        names.push(name);
    }
    names
}

/// The quick demo (8 conditions on 5 mm grooves) end to end: every stage ran, the chain holds, the
/// models' provenance holds the measured files' hashes, the answer has the form.
#[test]
fn the_demo_runs_the_pipeline_and_its_chain_holds() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("demo");
    let doc = run_json(&["demo", "--quick", "--out", s(&out)]);
    let names = check_chain(&out, &doc);
    for want in [
        "design",
        "measure",
        "analyse",
        "identify",
        "commission",
        "build",
        "batch",
        "diagnose",
        "rerun",
    ] {
        assert!(names.iter().any(|n| n == want), "{want} in {names:?}");
    }
    for st in doc["stages"].as_array().unwrap() {
        assert_eq!(st["status"], "ok", "{st}");
    }
    // the identified models name the measured files they were fitted to, with their hashes
    let stage = |n: &str| {
        doc["stages"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == n)
            .unwrap()
            .clone()
    };
    let identify = stage("identify");
    let spindle = out.join("models/spindle.toml");
    let text = std::fs::read_to_string(&spindle).unwrap();
    let step = out.join("measured/spindle_step.csv");
    assert!(
        text.contains("measured/spindle_step.csv") && text.contains(&sha256(&step)),
        "{text}"
    );
    assert!(
        identify["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f["path"] == "models/force_6061.toml")
    );
    // the answer, in the form (figures as measured)
    let h = doc["headline"].as_str().unwrap();
    assert!(
        h.starts_with("mpc vs pid-tuned over 8 designed conditions: median pp "),
        "{h}"
    );
    for part in [
        " µm, difference ",
        "sign-test p = ",
        "; diagnosis named ",
        ", rms ",
        "; with the corrected model mpc ",
        " (ideal ",
        "simulated machine",
    ] {
        assert!(h.contains(part), "{part} in {h}");
    }
    // the hidden effect is named without being given (its shape is not its family's)
    assert!(h.contains("diagnosis named slideway_straightness"), "{h}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.lines().take(4).any(|l| l == h),
        "the report starts with the answer"
    );
    for sec in [
        "1. Design",
        "4. Identify",
        "8. Compare",
        "11. Diagnose",
        "12. Rerun",
        "What was hidden",
    ] {
        assert!(md.contains(sec), "{sec}");
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>") && html.contains("<svg"));
    // rendered in a browser: not blank, every figure with a size, no console error, no broken link
    let shot = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    if let Some(line) = crate::report_html::check_in_chromium(&out.join("report.html"), &shot) {
        eprintln!("{line}");
    }
    // self-contained: no external asset, no script
    for external in ["src=\"http", "href=\"http", "<link", "@import", "<script"] {
        assert!(!html.contains(external), "{external}");
    }
}

/// The truth stays hidden: the pipeline and the demo's CLI hold no truth type and call no truth
/// constructor of the harness or the physics.
#[test]
fn the_pipeline_holds_no_truth() {
    let forbidden = [
        "GrooveConfig",
        "ToolVariation",
        "InstrumentErrors",
        "groove_truth",
        "groove_setup",
        "BoucWen",
        "LogCreep",
        "TruthSpec",
        "CommissioningPlant",
        "GuidewayBump",
        "tool_variation",
        "wall_variation",
    ];
    let mut files = vec![repo("src/cmd/demo.rs")];
    for e in std::fs::read_dir(repo("pipeline/src")).unwrap() {
        files.push(e.unwrap().path().display().to_string());
    }
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for w in forbidden {
            assert!(!text.contains(w), "{f} mentions {w}");
        }
    }
}

/// The shipped example plan runs every stage on the files of `datasets/pipeline/`.
#[test]
fn the_example_plan_runs_every_stage_on_its_files() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("p");
    let doc = run_json(&[
        "pipeline",
        &repo("datasets/pipeline/plan.toml"),
        "--out",
        s(&out),
    ]);
    check_chain(&out, &doc);
    for st in doc["stages"].as_array().unwrap() {
        assert_eq!(st["status"], "ok", "{st}");
    }
    let h = doc["headline"].as_str().unwrap();
    assert!(h.starts_with("mpc vs pid-tuned over "), "{h}");
    assert!(
        !h.contains("simulated machine"),
        "files, not the machine: {h}"
    );
}

/// A plan without files skips every measuring stage, saying what each would need.
#[test]
fn a_plan_without_files_says_what_each_stage_needs() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = write(tmp.path(), "plan.toml", "name = \"empty\"\n");
    let out = tmp.path().join("p");
    let o = millcomp()
        .args(["pipeline", s(&plan), "--out", s(&out)])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("measure") && text.contains("skipped"),
        "{text}"
    );
    assert!(text.contains("measure.forces"), "{text}");
    assert!(text.contains("diagnose.session"), "{text}");
    // a bad key is a clear error naming the file and the key
    let bad = write(tmp.path(), "bad.toml", "[measure]\nforce = \"f.csv\"\n");
    let o = millcomp().args(["pipeline", s(&bad)]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.toml") && err.contains("force"), "{err}");
}
