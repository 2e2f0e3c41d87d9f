//! End-to-end tests of `millcomp batch`: the real closed loop (millcomp-closedloop's runner) on short grooves,
//! shards as separate processes, merge, resume and bad input.

use crate::common::*;

use predicates::str::contains;
use serde_json::Value;

/// Four scenarios on short grooves (`length_mm` = 0.5: 30 revolutions at 10 000 rpm and 10 µm/rev,
/// 0.18 s of machining) so the whole file runs in seconds. Levels chosen inside the published ranges
/// (`000_…txt` ch. 6–7: tilt 20–40°, 0–80 µm ramp).
const SCENARIOS: &str = "\
tilt_deg,depth_um,stiffness_error_pct,length_mm
20,60,0,0.5
40,60,10,0.5
20,100,10,0.5
40,100,0,0.5
";

#[test]
fn four_shards_merge_to_the_single_run_and_resume_skips_done_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(tmp.path(), "s.csv", SCENARIOS);
    let single = tmp.path().join("single");
    let doc = run_json(&[
        "batch",
        "--scenarios",
        s(&file),
        "--controllers",
        "pid,mpc",
        "--out",
        s(&single),
    ]);
    // 4 scenarios × 2 controllers.
    assert_eq!(doc["n_runs"], 8);
    assert_eq!(doc["n_ran"], 8);
    for c in ["pid", "mpc"] {
        let pp = doc["by_controller"][c]["pp_error_um"].as_f64().unwrap();
        assert!(pp.is_finite() && pp > 0.0, "{c}: {pp}");
    }
    // The ANOVA has the controller as a factor, with the contract's term keys.
    let terms = doc["anova"]["pp_error_um"]["terms"].as_array().unwrap();
    assert!(terms.iter().any(|t| t["term"] == "controller"));
    assert!(terms[0].get("p_value").is_some() && terms[0].get("sum_sq").is_some());
    // Scenario by scenario: mpc against the reference (pid-tuned did not run: the first controller),
    // its differences on the 4 scenarios agree with the runs' own numbers.
    let paired = doc["paired"].as_array().unwrap();
    let p = paired
        .iter()
        .find(|p| p["metric"] == "pp_error_um" && p["controller"] == "mpc")
        .unwrap();
    assert_eq!(
        (p["reference"].as_str(), p["n"].as_u64()),
        (Some("pid"), Some(4))
    );
    let (better, worse) = (p["better"].as_u64().unwrap(), p["worse"].as_u64().unwrap());
    assert_eq!(better + worse, 4);
    // solve times are reported for the MPC (wall-clock: beside the results table, not in it)
    assert_eq!(doc["solve_times_us"]["mpc"]["runs"], 4);
    assert!(doc["solve_times_us"].get("pid").is_none());
    // the ramps from 0 µm have no process change: no change excess to pair
    assert!(!paired.iter().any(|p| p["metric"] == "change_excess_um"));

    // Four slices as separate processes (one of them through the Slurm environment), then merge.
    let mut dirs = Vec::new();
    for k in 0..4 {
        let d = tmp.path().join(format!("shard-{k}"));
        let mut cmd = millcomp();
        cmd.args([
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,mpc",
            "--out",
            s(&d),
            "--json",
        ]);
        if k == 3 {
            cmd.env("SLURM_ARRAY_TASK_ID", "3")
                .env("SLURM_ARRAY_TASK_COUNT", "4");
        } else {
            cmd.args(["--shard", &format!("{k}/4")]);
        }
        let out = cmd.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            v["n_runs"], 2,
            "4 scenarios over 4 shards, both controllers each"
        );
        assert_eq!(v["shard"]["index"], k);
        dirs.push(d);
    }
    let merged = tmp.path().join("merged");
    let mut args = vec!["batch", "merge"];
    args.extend(dirs.iter().map(|d| s(d)));
    args.extend(["--out", s(&merged)]);
    let m = run_json(&args);
    assert_eq!(m["n_runs"], 8);
    // The results are the same bytes as the single run's: the tables, summary.json, every plot. Only
    // invocation.json (wall clock, threads, solve times, runs done now, paths) may differ.
    let mut result_files = vec![
        "results.csv".to_string(),
        "results.parquet".to_string(),
        "summary.json".to_string(),
    ];
    for e in std::fs::read_dir(single.join("plots")).unwrap() {
        result_files.push(format!(
            "plots/{}",
            e.unwrap().file_name().to_string_lossy()
        ));
    }
    assert!(result_files.contains(&"plots/pp_error_um_by_tilt_deg.svg".to_string()));
    for f in &result_files {
        let (x, y) = (single.join(f), merged.join(f));
        assert!(
            std::fs::read(&x).unwrap() == std::fs::read(&y).unwrap(),
            "merged slices differ from the single run in {f}"
        );
    }
    assert_eq!(
        std::fs::read_dir(merged.join("plots")).unwrap().count(),
        result_files.len() - 3
    );
    let a = std::fs::read_to_string(single.join("results.csv")).unwrap();
    assert_eq!(doc["by_controller"], m["by_controller"]);
    let inv: Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("invocation.json")).unwrap())
            .unwrap();
    assert_eq!(
        (inv["n_ran"].as_u64(), m["n_ran"].as_u64()),
        (Some(0), Some(0))
    );
    let summary = std::fs::read_to_string(single.join("summary.json")).unwrap();
    for key in ["wall_clock_s", "solve_times_us", "threads", "files"] {
        assert!(!summary.contains(key), "summary.json holds `{key}`");
    }

    // Resume: remove one finished run; only that one runs again and the results are unchanged.
    std::fs::remove_file(single.join("runs/run-000005.json")).unwrap();
    let again = run_json(&[
        "batch",
        "--scenarios",
        s(&file),
        "--controllers",
        "pid,mpc",
        "--out",
        s(&single),
    ]);
    assert_eq!(again["n_ran"], 1);
    assert_eq!(again["n_resumed"], 7);
    assert_eq!(
        std::fs::read_to_string(single.join("results.csv")).unwrap(),
        a
    );

    // Merging slices of different batches is refused.
    let other_file = write(tmp.path(), "o.csv", &SCENARIOS.replace("20,60", "25,60"));
    let other = tmp.path().join("other");
    run_json(&[
        "batch",
        "--scenarios",
        s(&other_file),
        "--controllers",
        "pid,mpc",
        "--out",
        s(&other),
        "--shard",
        "0/4",
    ]);
    millcomp()
        .args([
            "batch",
            "merge",
            s(&dirs[0]),
            s(&other),
            "--out",
            s(&tmp.path().join("bad")),
        ])
        .assert()
        .code(1)
        .stderr(contains("different batch"));
    // Missing slices are named.
    millcomp()
        .args([
            "batch",
            "merge",
            s(&dirs[0]),
            s(&dirs[1]),
            "--out",
            s(&tmp.path().join("bad2")),
        ])
        .assert()
        .code(1)
        .stderr(contains("runs are missing"));
    // The same --out cannot hold two batches.
    millcomp()
        .args(["batch", "--scenarios", s(&other_file), "--out", s(&single)])
        .assert()
        .code(1)
        .stderr(contains("another batch"));
}

#[test]
fn bad_input_gives_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(tmp.path(), "s.csv", SCENARIOS);
    let bad = write(tmp.path(), "b.csv", "tilt_deg,spindle_colour\n20,1\n");
    millcomp()
        .args(["batch", "--scenarios", s(&bad)])
        .assert()
        .code(1)
        .stderr(contains("unknown factor `spindle_colour`"));
    millcomp()
        .args(["batch", "--scenarios", s(&file), "--controllers", "pid,lqr"])
        .assert()
        .code(1)
        .stderr(contains("unknown controller `lqr`"));
    millcomp()
        .args(["batch", "--scenarios", s(&file), "--shard", "4/4"])
        .assert()
        .code(1)
        .stderr(contains("out of range"));
    millcomp()
        .args(["batch", "--scenarios", s(&file)])
        .env("JOB_COMPLETION_INDEX", "7")
        .env("MILLCOMP_SHARD_COUNT", "4")
        .assert()
        .code(1)
        .stderr(contains("out of range"));
    let bad_value = write(tmp.path(), "v.csv", "material\nunobtainium\n");
    millcomp()
        .args(["batch", "--scenarios", s(&bad_value)])
        .assert()
        .code(1)
        .stderr(contains("material"))
        .stderr(contains("row 1"));
    millcomp()
        .args(["batch", "--doe", "--design full --factors colour=1:2"])
        .assert()
        .code(1)
        .stderr(contains("unknown factor `colour`"));
    millcomp()
        .args(["batch"])
        .assert()
        .code(1)
        .stderr(contains("--scenarios"));
}

#[test]
fn doe_design_drives_the_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("doe");
    // 2^(3-1) resolution III design: 4 scenarios; length_mm fixed through a constant factor would not
    // be a design factor, so the groove length is one of the factors (0.3 / 0.5 mm).
    let doc = run_json(&[
        "batch",
        "--doe",
        "--design fractional --factors tilt_deg=20:40,upfeed_um=8:12,length_mm=0.3:0.5 --resolution 3 --seed 1",
        "--controllers",
        "none,pid",
        "--out",
        s(&out),
    ]);
    assert_eq!(doc["n_runs"], 8);
    assert_eq!(doc["n_scenarios"], 4);
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert_eq!(
        header,
        "run,scenario,tilt_deg,upfeed_um,length_mm,controller,pp_error_um,change_excess_um,stroke_bound_um,optimum_pp_um,change_bound_um,rms_error_um,max_error_um,min_error_um,actuator_travel_um,solver_fallbacks"
    );
    // PID (the thesis' closed loop) removes part of the uncompensated error (000 ch. 7: 16 → 3 µm).
    let none = doc["by_controller"]["none"]["pp_error_um"]
        .as_f64()
        .unwrap();
    let pid = doc["by_controller"]["pid"]["pp_error_um"].as_f64().unwrap();
    assert!(pid < none, "pid {pid} vs none {none}");
}

#[test]
fn thin_wall_stage_runs_in_a_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(
        tmp.path(),
        "tw.csv",
        "stage,wall_um,stiffness_error_pct\nthin_wall,80,0\nthin_wall,120,10\n",
    );
    let out = tmp.path().join("tw");
    let doc = run_json(&[
        "batch",
        "--scenarios",
        s(&file),
        "--controllers",
        "threshold,mpc",
        "--out",
        s(&out),
    ]);
    assert_eq!(doc["n_runs"], 4);
    // 004 Table 5: the iterative (threshold) compensation leaves ≈ 2 % of the wall; the MPC, which also
    // compensates the tool's deflection, leaves less (closedloop/tests/thin_wall.rs: ≤ 1 % per wall)
    let med = |c: &str| doc["by_controller"][c]["pp_error_um"].as_f64().unwrap();
    assert!(
        med("mpc") < med("threshold"),
        "mpc {} threshold {}",
        med("mpc"),
        med("threshold")
    );
    // `threshold` on a groove is refused before anything runs
    let mixed = write(
        tmp.path(),
        "mixed.csv",
        "stage,wall_um\nthin_wall,80\ngroove,80\n",
    );
    millcomp()
        .args([
            "batch",
            "--scenarios",
            s(&mixed),
            "--controllers",
            "threshold",
        ])
        .arg("--out")
        .arg(tmp.path().join("mixed"))
        .assert()
        .code(1)
        .stderr(contains("runs only on thin-wall"))
        .stderr(contains("row 2"));
    assert!(!tmp.path().join("mixed").join("results.csv").exists());
}

/// Six scenarios of very short grooves (0.2 mm: 0.12 s of machining) over two commissionings (tilt
/// 20° and 40°; the controllers' stiffness error is not the commissioning's), with a depth step so
/// the change bound's linear programme runs too.
const SIX: &str = "\
tilt_deg,stiffness_error_pct,depth_step,length_mm
20,0,0,0.2
40,0,1,0.2
20,10,1,0.2
40,10,0,0.2
20,-10,1,0.2
40,-10,0,0.2
";

/// The files of a batch's results (not `invocation.json`, which says how one call ran).
fn result_files(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut names = vec![
        "results.csv".to_string(),
        "results.parquet".to_string(),
        "summary.json".to_string(),
    ];
    let mut plots: Vec<String> = std::fs::read_dir(dir.join("plots"))
        .unwrap()
        .map(|e| format!("plots/{}", e.unwrap().file_name().to_string_lossy()))
        .collect();
    plots.sort();
    names.extend(plots);
    names
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap_or_else(|e| panic!("{n}: {e}"));
            (n, bytes)
        })
        .collect()
}

fn assert_same_results(a: &std::path::Path, b: &std::path::Path, what: &str) {
    let (x, y) = (result_files(a), result_files(b));
    assert_eq!(
        x.iter().map(|f| &f.0).collect::<Vec<_>>(),
        y.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "{what}: the files"
    );
    for ((name, p), (_, q)) in x.iter().zip(&y) {
        assert!(p == q, "{what}: {name} differs");
    }
}

/// Every `.partial` file under `dir`.
/// Whether process `pid` holds a file open for writing in `dir` that has no name yet: the atomic writer's
/// unnamed temporary file (`O_TMPFILE` on Linux; /proc shows it as `DIR/#<inode> (deleted)`), which
/// leaves no `.partial` a test could see.
fn writing_unnamed_in(pid: u32, dir: &std::path::Path) -> bool {
    let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) else {
        return false;
    };
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    fds.flatten().any(|fd| {
        std::fs::read_link(fd.path()).is_ok_and(|target| {
            let t = target.to_string_lossy();
            t.ends_with(" (deleted)") && target.parent() == Some(dir.as_path())
        })
    })
}

fn partials(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.to_string_lossy().ends_with(".partial") {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn the_same_bytes_with_or_without_the_cache_on_any_threads_and_shards() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(tmp.path(), "six.csv", SIX);
    let cache = tmp.path().join("shared-cache");
    let batch = |out: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,pid-tuned",
            "--out",
            s(out),
        ];
        args.extend_from_slice(extra);
        run_json(&args)
    };
    // one thread, its own cache (OUT/cache): two commissionings for six scenarios
    let one = tmp.path().join("one");
    let a = batch(&one, &["--threads", "1"]);
    assert_eq!(
        (a["cache"]["computed"].as_u64(), a["threads"].as_u64()),
        (Some(2), Some(1))
    );
    assert!(one.join("cache/commissioning").read_dir().unwrap().count() == 2);
    // two threads, a new cache, then the same cache again: nothing commissioned the second time
    let two = tmp.path().join("two");
    let b = batch(&two, &["--threads", "2", "--cache", s(&cache)]);
    assert_eq!(b["cache"]["computed"], 2);
    let warm = tmp.path().join("warm");
    let c = batch(&warm, &["--threads", "2", "--cache", s(&cache)]);
    assert_eq!(
        (
            c["cache"]["computed"].as_u64(),
            c["cache"]["from_disk"].as_u64()
        ),
        (Some(0), Some(2))
    );
    // three slices sharing the cache, merged
    let mut dirs = Vec::new();
    for k in 0..3 {
        let d = tmp.path().join(format!("slice-{k}"));
        batch(&d, &["--shard", &format!("{k}/3"), "--cache", s(&cache)]);
        dirs.push(d);
    }
    let merged = tmp.path().join("merged");
    let mut args = vec!["batch", "merge"];
    args.extend(dirs.iter().map(|d| s(d)));
    args.extend(["--out", s(&merged)]);
    run_json(&args);
    for (dir, what) in [
        (&two, "two threads"),
        (&warm, "the cache read back"),
        (&merged, "three slices merged"),
    ] {
        assert_same_results(&one, dir, what);
    }
}

/// When to stop a batch under test.
#[derive(Debug, Clone, Copy)]
enum Trigger {
    /// Once this many runs are stored.
    RunsStored(usize),
    /// While a run's record is being written (a `.partial` in `runs/`).
    WritingARun,
    /// While the results are being written (`results.csv` there, a `.partial` beside it).
    WritingTheResults,
    /// After this many milliseconds.
    After(u64),
}

#[test]
fn a_killed_batch_resumes_and_writes_the_same_files() {
    use rand_chacha::rand_core::{RngCore, SeedableRng};
    use std::time::{Duration, Instant};

    let tmp = tempfile::tempdir().unwrap();
    let file = write(tmp.path(), "six.csv", SIX);
    let cache = tmp.path().join("cache");
    let args = |out: &std::path::Path| -> Vec<String> {
        [
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,pid-tuned",
            "--out",
            s(out),
            "--cache",
            s(&cache),
            "--threads",
            "2",
        ]
        .iter()
        .map(|a| a.to_string())
        .collect()
    };
    let reference = tmp.path().join("reference");
    let whole = run_json(
        &args(&reference)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    let total = whole["n_runs"].as_u64().unwrap() as usize;
    let stored = |dir: &std::path::Path| {
        std::fs::read_dir(dir.join("runs"))
            .map(|d| {
                d.flatten()
                    .filter(|e| {
                        let n = e.file_name().to_string_lossy().to_string();
                        n.starts_with("run-") && n.ends_with(".json")
                    })
                    .count()
            })
            .unwrap_or(0)
    };
    // the moments: a seeded draw for the random ones (the batch takes about a second here)
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(48);
    let mut kills = vec![
        (libc::SIGKILL, Trigger::RunsStored(3), false),
        (libc::SIGTERM, Trigger::RunsStored(3), false),
        (libc::SIGKILL, Trigger::WritingARun, true),
        (libc::SIGTERM, Trigger::WritingARun, true),
        (libc::SIGKILL, Trigger::WritingTheResults, true),
        (libc::SIGTERM, Trigger::WritingTheResults, true),
    ];
    for sig in [libc::SIGKILL, libc::SIGTERM, libc::SIGKILL, libc::SIGTERM] {
        kills.push((sig, Trigger::After(50 + rng.next_u64() % 850), false));
    }
    let mut report = Vec::new();
    for (i, (sig, trigger, slow)) in kills.iter().enumerate() {
        let out = tmp.path().join(format!("killed-{i}"));
        let mut cmd = std::process::Command::new(assert_cmd::cargo::cargo_bin("millcomp"));
        cmd.args(args(&out))
            .arg("--quiet")
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped());
        if *slow {
            // every batch file written as text pauses half-way: the kill lands inside a write
            cmd.env("MILLCOMP_TEST_SLOW_WRITE_MS", "300");
        }
        let mut child = cmd.spawn().unwrap();
        let start = Instant::now();
        let mut fired = false;
        while start.elapsed() < Duration::from_secs(120) {
            if child.try_wait().unwrap().is_some() {
                break;
            }
            let now = match trigger {
                Trigger::RunsStored(n) => stored(&out) >= *n,
                Trigger::WritingARun => {
                    !partials(&out.join("runs")).is_empty()
                        || writing_unnamed_in(child.id(), &out.join("runs"))
                }
                Trigger::WritingTheResults => {
                    out.join("results.csv").exists()
                        && (writing_unnamed_in(child.id(), &out)
                            || std::fs::read_dir(&out)
                                .unwrap()
                                .flatten()
                                .any(|e| e.file_name().to_string_lossy().ends_with(".partial")))
                }
                Trigger::After(ms) => start.elapsed() >= Duration::from_millis(*ms),
            };
            if now {
                // SAFETY: signalling a child process this test started and has not reaped
                unsafe {
                    libc::kill(child.id() as i32, *sig);
                }
                fired = true;
                break;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let status = child.wait_with_output().unwrap();
        if !matches!(trigger, Trigger::After(_)) {
            assert!(fired, "kill {i} ({trigger:?}) never fired");
        }
        let code = status.status.code();
        let stderr = String::from_utf8_lossy(&status.stderr).to_string();
        if fired && *sig == libc::SIGTERM && code == Some(143) {
            // stopped cleanly: the runs under way finished and were stored
            assert!(stderr.contains("stopped by SIGTERM"), "{stderr}");
            assert!(
                partials(&out).is_empty(),
                "SIGTERM left {:?}",
                partials(&out)
            );
        }
        let before = stored(&out);
        // the same command again: it resumes, runs exactly what was missing, and writes the same files
        let again = run_json(&args(&out).iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(again["n_resumed"].as_u64(), Some(before as u64), "kill {i}");
        assert_eq!(
            again["n_ran"].as_u64(),
            Some((total - before) as u64),
            "kill {i}: a run lost or done twice"
        );
        assert!(partials(&out).is_empty(), "kill {i}: {:?}", partials(&out));
        assert_same_results(&reference, &out, &format!("kill {i} ({trigger:?})"));
        report.push((i, *sig, *trigger, code, before));
    }
    // the kills landed at different moments: before any run, among the runs, in the final writes
    assert!(report.iter().any(|r| r.4 > 0 && r.4 < total), "{report:?}");
}

#[test]
fn dry_run_quiet_and_the_progress_line() {
    let tmp = tempfile::tempdir().unwrap();
    let file = write(tmp.path(), "six.csv", SIX);
    let out = tmp.path().join("dry");
    // --dry-run: the plan's size and an estimate, nothing run or written
    let dry = millcomp()
        .args([
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,mpc",
            "--out",
            s(&out),
            "--dry-run",
        ])
        .output()
        .unwrap();
    assert!(dry.status.success());
    let text = String::from_utf8_lossy(&dry.stdout);
    assert!(
        text.contains(
            "batch: 12 runs (6 scenarios × 2 controllers in the plan), 0 finished already"
        ),
        "{text}"
    );
    assert!(text.contains("2 commissionings (0 in the cache)"), "{text}");
    assert!(text.contains("core-s, about"), "{text}");
    assert!(!out.exists(), "--dry-run wrote {}", out.display());
    // not a terminal: a progress line every tenth of the runs on stderr (12 runs: at each run past a
    // tenth), the last one saying it is done
    let run = millcomp()
        .args([
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,pid-tuned",
            "--out",
            s(&out),
        ])
        .output()
        .unwrap();
    assert!(run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("batch: ")).collect();
    assert!(lines.len() >= 10 && lines.len() <= 13, "{err}");
    assert!(lines[0].starts_with("batch: 0/12 runs"), "{err}");
    let last = lines.last().unwrap();
    assert!(
        last.starts_with("batch: 12/12 runs | done in") && last.ends_with("simulated s per wall s"),
        "{last}"
    );
    // --quiet: nothing on stderr; the dry run now finds every run finished
    let quiet = millcomp()
        .args([
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,pid-tuned",
            "--out",
            s(&out),
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(quiet.status.success() && quiet.stderr.is_empty());
    let again = millcomp()
        .args([
            "batch",
            "--scenarios",
            s(&file),
            "--controllers",
            "pid,pid-tuned",
            "--out",
            s(&out),
            "--dry-run",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&again.stdout);
    assert!(
        text.contains("12 finished already") && text.contains("to run: 0 runs"),
        "{text}"
    );
}
