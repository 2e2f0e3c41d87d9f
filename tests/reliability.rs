//! Issue 51, the hostile user's probe: every finding as a regression test through the binary — outputs
//! never overwrite an input, sizes have upper bounds checked before anything is allocated, non-finite
//! numbers are refused where they enter and never saved, no input panics the program, messages name the
//! file, row and column (rows counted from 1, `millcomp_datasets::error::row_at`), what European and
//! Windows instruments write is read as the plain file is, output files respect the umask, a permission
//! error is a clear message, and a killed write leaves nothing half-written or stray.
//! The before/after messages are in docs/reliability.md.

use std::path::{Path, PathBuf};

use crate::common::*;

use predicates::prelude::*;

/// The shipped synthetic spindle step response (datasets/runs).
const STEP: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/runs/spindle_step_synthetic.csv"
);
/// The shipped example session and the shipped commissioned groove scenario.
const SESSION: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/sessions/example.toml"
);
const SCENARIO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/datasets/scenarios/groove_s7_20deg_commissioned.toml"
);
const CLEAN_TOML: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/datasets/synthetic/clean.toml");
const CLEAN_CSV: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/datasets/synthetic/clean.csv");

/// A copy of `from` in `dir` named `name`.
fn copy(dir: &Path, from: &str, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::copy(from, &p).expect("copy");
    p
}

/// Runs `millcomp ARGS`, which must fail with status 1; returns stderr.
fn fails(args: &[&str]) -> String {
    let out = millcomp().args(args).output().expect("run");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "millcomp {args:?}: {err}");
    err
}

// ---------------------------------------------------------------------------------------------
// Outputs never overwrite an input.

/// Each verb with an output option, given one of its inputs as the output: refused (status 1) with a
/// message naming the option and the input, and the input unchanged.
#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let session = copy(d, SESSION, "S.toml");
    let step = copy(d, STEP, "R.csv");
    let scenario = copy(d, SCENARIO, "C.toml");
    let doe = copy(d, CLAYTON, "doe.csv");
    let clean_toml = copy(d, CLEAN_TOML, "clean.toml");
    let clean_csv = copy(d, CLEAN_CSV, "clean.csv");
    // a directory output holding an input under a name the verb writes there
    let plots = d.join("plots");
    std::fs::create_dir(&plots).unwrap();
    let pareto = copy(&plots, CLAYTON, "pareto.svg");
    let report = d.join("report");
    std::fs::create_dir(&report).unwrap();
    let report_txt = copy(&report, CLEAN_CSV, "diagnose.txt");
    let batch_out = d.join("batch");
    std::fs::create_dir(&batch_out).unwrap();
    let batch_scenarios = write(&batch_out, "results.csv", "tilt_deg\n20\n");
    let hard = d.join("hard.csv");
    std::fs::hard_link(&step, &hard).unwrap();
    let cases: Vec<(Vec<&str>, &Path, &str)> = vec![
        (
            vec!["simulate", s(&session), "--out", s(&session)],
            &session,
            "--out",
        ),
        (
            vec!["simulate", s(&session), "--plot", s(&session)],
            &session,
            "--plot",
        ),
        (
            vec![
                "simulate",
                s(&scenario),
                "--controller",
                "none",
                "--out",
                s(&scenario),
            ],
            &scenario,
            "--out",
        ),
        (
            vec!["identify", "spindle", s(&step), "--save", s(&step)],
            &step,
            "--save",
        ),
        // a hard link is the same file
        (
            vec!["identify", "spindle", s(&step), "--save", s(&hard)],
            &step,
            "--save",
        ),
        (
            vec!["commission", s(&scenario), "--out", s(&scenario)],
            &scenario,
            "--out",
        ),
        (
            vec![
                "diagnose",
                s(&clean_toml),
                s(&clean_csv),
                "--next-plan",
                s(&clean_csv),
            ],
            &clean_csv,
            "--next-plan",
        ),
        (
            vec![
                "diagnose",
                s(&clean_toml),
                s(&report_txt),
                "--report",
                s(&report),
            ],
            &report_txt,
            "--report",
        ),
        (
            vec![
                "doe",
                "analyze",
                s(&doe),
                "--response",
                "max_fx_n",
                "--save",
                s(&doe),
            ],
            &doe,
            "--save",
        ),
        (
            vec![
                "doe",
                "analyze",
                s(&pareto),
                "--response",
                "max_fx_n",
                "--plots",
                s(&plots),
            ],
            &pareto,
            "--plots",
        ),
        (
            vec![
                "batch",
                "--scenarios",
                s(&batch_scenarios),
                "--out",
                s(&batch_out),
            ],
            &batch_scenarios,
            "--out",
        ),
    ];
    for (args, input, flag) in cases {
        let before = std::fs::read(input).unwrap();
        let err = fails(&args);
        let name = input.file_name().unwrap().to_str().unwrap();
        assert!(err.contains(flag) && err.contains(name), "{args:?}: {err}");
        assert!(
            err.contains("overwrite") || err.contains("is the input"),
            "{err}"
        );
        assert_eq!(
            std::fs::read(input).unwrap(),
            before,
            "{args:?} changed {name}"
        );
    }
    // a model file given to commission and written as its bundle
    let model = d.join("sp.toml");
    millcomp()
        .args(["identify", "spindle", s(&step), "--save", s(&model)])
        .assert()
        .success();
    let err = fails(&[
        "commission",
        "--spindle",
        s(&model),
        "--material",
        "S7",
        "--out",
        s(&model),
    ]);
    assert!(
        err.contains("--spindle") && err.contains("sp.toml"),
        "{err}"
    );
    // merging slices into one of them
    let slice = d.join("slice");
    std::fs::create_dir(&slice).unwrap();
    let err = fails(&["batch", "merge", s(&slice), "--out", s(&slice)]);
    assert!(err.contains("slice"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Every size, count and coverage has an upper bound, checked before anything is allocated.

#[test]
fn a_groove_longer_than_a_metre_is_refused_before_it_is_simulated() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo("datasets/scenarios/groove_s7_20deg.toml")).unwrap();
    for length in ["1e9", "1e308", "2000.0"] {
        let p = write(
            dir.path(),
            "long.toml",
            &text.replace("length_mm = 20.0", &format!("length_mm = {length}")),
        );
        let err = fails(&["simulate", s(&p), "--controller", "pid"]);
        assert!(
            err.contains("groove.length_mm") && err.contains("1000"),
            "{err}"
        );
    }
    // a batch row of 10 km, refused as the scenario it makes
    let rows = write(dir.path(), "rows.csv", "length_mm\n1e7\n");
    let err = fails(&[
        "batch",
        "--scenarios",
        s(&rows),
        "--controllers",
        "none",
        "--out",
        s(&dir.path().join("b")),
    ]);
    assert!(err.contains("length_mm"), "{err}");
}

#[test]
fn counts_beyond_their_bounds_are_usage_errors() {
    for (args, what) in [
        (
            vec!["commission", SCENARIO, "--coverage", "1000000000"],
            "1..=100000",
        ),
        (
            vec![
                "doe",
                "design",
                "--design",
                "full",
                "--factors",
                "A,B",
                "--replicates",
                "1000000000",
            ],
            "1..=1000",
        ),
        (
            vec![
                "doe",
                "design",
                "--design",
                "full",
                "--factors",
                "A,B",
                "--center-points",
                "1000000000",
            ],
            "0..=1000",
        ),
        (vec!["demo", "--threads", "1000000000"], "1..=1024"),
    ] {
        millcomp()
            .args(&args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(what));
    }
    // within the bounds, a design too large as a whole
    let err = fails(&[
        "doe",
        "design",
        "--design",
        "full",
        "--factors",
        "A,B,C,D,E,F,G,H,J,K,L,M,N,O,P,Q",
        "--replicates",
        "1000",
    ]);
    assert!(err.contains("at most 1000000 runs"), "{err}");
    // a seed range past the largest seed is an error, not an empty study
    let err = fails(&[
        "commission",
        SCENARIO,
        "--coverage",
        "2",
        "--seed",
        "18446744073709551615",
    ]);
    assert!(err.contains("--seed"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Non-finite numbers are refused where they enter and never saved.

#[test]
fn a_nan_level_is_not_a_label() {
    let err = fails(&[
        "doe",
        "design",
        "--design",
        "full",
        "--factors",
        "a=nan:1,b=1:2",
    ]);
    assert!(err.contains("level `nan` is not a finite number"), "{err}");
}

#[test]
fn a_fit_that_overflows_is_refused_and_never_saved() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(CLAYTON).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // 000_…txt Table 3-3, trial 1: max X force 3.34 N, made 1e308
    lines[1] = lines[1].replacen(",3.34,", ",1e308,", 1);
    let data = write(dir.path(), "huge.csv", &(lines.join("\n") + "\n"));
    let model = dir.path().join("m.toml");
    let err = fails(&[
        "doe",
        "analyze",
        s(&data),
        "--response",
        "max_fx_n",
        "--factors",
        "depth_um,speed_rpm,upfeed_um",
        "--save",
        s(&model),
    ]);
    assert!(
        err.contains("not finite") && err.contains("max_fx_n"),
        "{err}"
    );
    assert!(!model.exists());
}

#[test]
fn a_model_file_with_nan_or_a_foreign_unit_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("sp.toml");
    millcomp()
        .args(["identify", "spindle", STEP, "--save", s(&model)])
        .assert()
        .success();
    let text = std::fs::read_to_string(&model).unwrap();
    // the first covariance entry made NaN, by hand
    let first = text.find("values = [[").unwrap() + "values = [[".len();
    let end = first + text[first..].find(',').unwrap();
    let nan = write(
        dir.path(),
        "nan.toml",
        &format!("{}nan{}", &text[..first], &text[end..]),
    );
    let err = fails(&["commission", "--spindle", s(&nan), "--material", "S7"]);
    assert!(err.contains("model.covariance.values[0][0]"), "{err}");
    let mm = write(
        dir.path(),
        "mm.toml",
        &text.replace("residual_unit = \"um\"", "residual_unit = \"mm\""),
    );
    let err = fails(&["commission", "--spindle", s(&mm), "--material", "S7"]);
    assert!(err.contains("residual_unit `mm`"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// No input panics the program (exit status 101); a failure writes nothing.

#[test]
fn very_long_names_do_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    // a 70 000-character column name in doe analyze (Rust's format width stops at 65 535)
    let long = "d".repeat(70_000);
    let text = std::fs::read_to_string(CLAYTON)
        .unwrap()
        .replacen("depth_um", &long, 1);
    let data = write(dir.path(), "wide.csv", &text);
    let out = millcomp()
        .args(["doe", "analyze", s(&data), "--response", "max_fx_n"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains(&long));
    // a 65 536-character factor name in doe design, written and printed
    let name = "a".repeat(65_536);
    let csv = dir.path().join("design.csv");
    millcomp()
        .args([
            "doe",
            "design",
            "--design",
            "full",
            "--no-randomize",
            "--out",
            s(&csv),
        ])
        .arg("--factors")
        .arg(format!("{name}=1:2,b=1:2"))
        .assert()
        .success();
    assert!(std::fs::read_to_string(&csv).unwrap().contains(&name));
}

// ---------------------------------------------------------------------------------------------
// Messages name the file, the row (from 1; line = row + 1 in a CSV) and the column.

#[test]
fn one_bad_cell_is_named_by_row_and_column_not_as_a_missing_column() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(STEP).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // data row 3 is line 4
    let cells: Vec<&str> = lines[3].split(',').collect();
    lines[3] = format!("{},{},abc", cells[0], cells[1]);
    let bad = write(dir.path(), "bad.csv", &(lines.join("\n") + "\n"));
    let err = fails(&["identify", "spindle", s(&bad)]);
    assert!(
        err.contains("bad.csv") && err.contains("column `y_um`, row 3: `abc` is not a number"),
        "{err}"
    );
    assert!(!err.contains("missing"), "{err}");
    // the measured-groove reader: line numbers beside rows
    let groove = std::fs::read_to_string(CLEAN_CSV).unwrap();
    let mut lines: Vec<String> = groove.lines().map(String::from).collect();
    lines[2] = lines[2].replacen(",10000.0,", ",-10000.0,", 1);
    let neg = write(dir.path(), "neg.csv", &(lines.join("\n") + "\n"));
    let err = fails(&["datasets", "check", s(&neg), "--as", "measured-groove"]);
    assert!(
        err.contains("neg.csv") && err.contains("column `speed_rpm`, row 2 (line 3)"),
        "{err}"
    );
}

#[test]
fn an_overdamped_step_response_ends_on_the_bound_not_past_it() {
    // ζ = 20, ωn = 1302 rad/s, 0.05 µm/V, a 100 V step at 1 ms, sampled at 20 kHz: far beyond the
    // model's ζ ≤ 10, so the fit ends on the bound (with a warning) instead of stepping past it
    let (zeta, wn, k): (f64, f64, f64) = (20.0, 1302.0, 0.05);
    let r = (zeta * zeta - 1.0).sqrt();
    let (s1, s2) = (-wn * (zeta - r), -wn * (zeta + r));
    let mut text = String::from("t_s,u_v,y_um\n");
    for i in 0..2000 {
        let t = i as f64 * 5e-5;
        let u = if t >= 1e-3 { 100.0 } else { 0.0 };
        let tt = t - 1e-3;
        let y = if tt < 0.0 {
            0.0
        } else {
            k * u * (1.0 + (s2 * (s1 * tt).exp() - s1 * (s2 * tt).exp()) / (s1 - s2))
        };
        // deterministic ±0.01 µm gauge noise
        let noise = 0.01 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
        text.push_str(&format!("{t:.5},{u},{:.6}\n", y + noise));
    }
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "over.csv", &text);
    let doc = run_json(&["identify", "spindle", s(&p)]);
    let z = doc["params"]["zeta"].as_f64().unwrap();
    assert!(z <= 10.0 && z > 9.9, "zeta {z}");
    let warnings = doc["warnings"].to_string();
    assert!(warnings.contains("upper bound"), "{warnings}");
}

#[test]
fn a_directory_as_input_is_said_once() {
    let dir = tempfile::tempdir().unwrap();
    let err = fails(&["identify", "spindle", s(dir.path())]);
    assert!(err.contains("is a directory, not a file"), "{err}");
    assert!(!err.contains("os error 19"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

#[test]
fn a_negative_value_gets_the_range_not_a_wrong_hint() {
    let err = fails(&[
        "identify",
        "stiffness",
        &repo("datasets/runs/stiffness_masses_synthetic.csv"),
        "--machine-stiffness-n-per-um",
        "-1",
    ]);
    assert!(
        err.contains("machine_stiffness_n_per_um") && err.contains("> 0"),
        "{err}"
    );
    assert!(!err.contains("'-- -1'"), "{err}");
}

#[test]
fn silently_accepted_inputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // an invented stiffness direction
    let text =
        std::fs::read_to_string(repo("datasets/runs/stiffness_masses_synthetic.csv")).unwrap();
    let side = write(
        dir.path(),
        "side.csv",
        &text.replace(",radial", ",sideways"),
    );
    let err = fails(&["identify", "stiffness", s(&side)]);
    assert!(
        err.contains("`sideways` is not one of axial, radial"),
        "{err}"
    );
    // an unknown material recorded in a bundle
    let model = dir.path().join("st.toml");
    millcomp()
        .args([
            "identify",
            "stiffness",
            &repo("datasets/runs/stiffness_masses_synthetic.csv"),
            "--save",
            s(&model),
        ])
        .assert()
        .success();
    let err = fails(&[
        "commission",
        "--stiffness",
        s(&model),
        "--material",
        "unobtainium",
    ]);
    assert!(err.contains("unknown material `unobtainium`"), "{err}");
    // negative peak forces (a sign error) in a force fit
    let neg = std::fs::read_to_string(CLAYTON)
        .unwrap()
        .replacen(",3.34,", ",-3.34,", 1);
    let neg = write(dir.path(), "neg.csv", &neg);
    let err = fails(&["identify", "force", s(&neg), "--material", "6061"]);
    assert!(
        err.contains("max_fx_n, row 1") && err.contains("sign"),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------------
// Output files get the mode a plain create would give.

#[cfg(unix)]
#[test]
fn output_files_respect_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("design.csv");
    let bin = assert_cmd::cargo::cargo_bin("millcomp");
    let status = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "umask 022 && exec '{}' doe design --design full --factors A,B --seed 1 --out '{}'",
            bin.display(),
            out.display()
        ))
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o644, "{mode:o}");
}

// ---------------------------------------------------------------------------------------------
// What European and Windows instruments write: the same numbers as the plain file.

/// The step response in the encodings, delimiters and number formats instruments write.
fn step_variants(dir: &Path) -> Vec<(&'static str, PathBuf)> {
    let plain = std::fs::read_to_string(STEP).unwrap();
    let mut out = Vec::new();
    let mut utf16le = vec![0xFF, 0xFE];
    utf16le.extend(plain.encode_utf16().flat_map(|u| u.to_le_bytes()));
    let mut utf16be = vec![0xFE, 0xFF];
    utf16be.extend(plain.encode_utf16().flat_map(|u| u.to_be_bytes()));
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend(plain.as_bytes());
    let semicolon: String = plain.replace(',', ";").replace('.', ",");
    let tab_crlf: String = plain.replace(',', "\t").replace('\n', "\r\n");
    for (what, bytes) in [
        ("UTF-16 LE with BOM", utf16le),
        ("UTF-16 BE with BOM", utf16be),
        ("UTF-8 with BOM", bom),
        ("semicolons and decimal commas", semicolon.into_bytes()),
        ("tabs and CRLF", tab_crlf.into_bytes()),
    ] {
        let p = dir.join(format!("{}.csv", what.replace(' ', "_")));
        std::fs::write(&p, bytes).unwrap();
        out.push((what, p));
    }
    out
}

#[test]
fn instrument_files_give_the_numbers_of_the_plain_file() {
    let dir = tempfile::tempdir().unwrap();
    let plain = run_json(&["identify", "spindle", STEP]);
    for (what, p) in step_variants(dir.path()) {
        let doc = run_json(&["identify", "spindle", s(&p)]);
        assert_eq!(doc["params"], plain["params"], "{what}");
        assert_eq!(doc["n_obs"], plain["n_obs"], "{what}");
    }
}

#[test]
fn a_windows_header_with_micro_and_degree_signs_is_read() {
    let dir = tempfile::tempdir().unwrap();
    // Windows-1252: µ is byte B5, ° is byte B0
    let plain = std::fs::read_to_string(STEP).unwrap();
    let mut bytes = b"t_s,u_V,y_\xB5m,temp_\xB0C".to_vec();
    for line in plain.lines().skip(1) {
        bytes.extend(format!("\n{line},20.5").as_bytes());
    }
    bytes.push(b'\n');
    let p = dir.path().join("win.csv");
    std::fs::write(&p, bytes).unwrap();
    let doc = run_json(&["identify", "spindle", s(&p), "--columns", "u_v=u_V"]);
    let reference = run_json(&["identify", "spindle", STEP]);
    assert_eq!(doc["params"], reference["params"]);
    let out = millcomp()
        .args(["identify", "spindle", s(&p), "--columns", "u_v=u_V"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("Windows-1252") && err.contains("`y_µm` read as `y_um`"),
        "{err}"
    );
}

#[test]
fn missing_values_and_mixed_decimal_marks_are_named_with_what_to_change() {
    let dir = tempfile::tempdir().unwrap();
    let plain = std::fs::read_to_string(STEP).unwrap();
    let mut lines: Vec<String> = plain.lines().map(String::from).collect();
    let cells: Vec<String> = lines[5].split(',').map(String::from).collect();
    lines[5] = format!("{},{},NA", cells[0], cells[1]);
    let na = write(dir.path(), "na.csv", &(lines.join("\n") + "\n"));
    let err = fails(&["identify", "spindle", s(&na)]);
    assert!(
        err.contains("column `y_um`, row 5: `NA` is not a number"),
        "{err}"
    );
    // a semicolon file with one decimal point among decimal commas
    let mut semi: Vec<String> = plain
        .replace(',', ";")
        .replace('.', ",")
        .lines()
        .map(String::from)
        .collect();
    semi[7] = semi[7].replacen(',', ".", 1);
    let mixed = write(dir.path(), "mixed.csv", &(semi.join("\n") + "\n"));
    let err = fails(&["identify", "spindle", s(&mixed)]);
    assert!(
        err.contains("mixed.csv") && err.contains("row 7 (line 8)") && err.contains("decimal mark"),
        "{err}"
    );
    // a row with more fields than the header: named, no polars advice
    let ragged = write(dir.path(), "ragged.csv", "t_s,u_v,y_um\n0,0,1\n0.1,0,1,5\n");
    let err = fails(&["identify", "spindle", s(&ragged)]);
    assert!(
        err.contains("row 2 (line 3) has 4 fields but the header has 3"),
        "{err}"
    );
    assert!(!err.contains("truncate_ragged_lines"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Permission errors, as an unprivileged user.

/// `setpriv` running the binary as `nobody`, or `None` (with the reason) when that is impossible here:
/// not root, no `setpriv`, or a directory on the way to the binary that others cannot enter.
#[cfg(unix)]
fn as_nobody() -> Result<std::process::Command, String> {
    let bin = assert_cmd::cargo::cargo_bin("millcomp");
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        return Err("not root: cannot switch to the user nobody".into());
    }
    if !Path::new("/usr/bin/setpriv").exists() {
        return Err("no /usr/bin/setpriv".into());
    }
    use std::os::unix::fs::PermissionsExt;
    for dir in bin.ancestors().skip(1) {
        let mode = std::fs::metadata(dir)
            .map(|m| m.permissions().mode())
            .unwrap_or(0);
        if mode & 0o001 == 0 {
            return Err(format!("{} is not searchable by others", dir.display()));
        }
    }
    let mut c = std::process::Command::new("/usr/bin/setpriv");
    c.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
        .arg(bin)
        .env("RAYON_NUM_THREADS", "2");
    Ok(c)
}

#[cfg(unix)]
#[test]
fn permission_errors_name_the_file_as_an_unprivileged_user() {
    use std::os::unix::fs::PermissionsExt;
    let run = |args: &[&str]| match as_nobody() {
        Ok(mut c) => Some(c.args(args).output().unwrap()),
        Err(why) => {
            eprintln!("skipped: permission errors as nobody: {why}");
            None
        }
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    // an input nobody may read
    let secret = copy(dir.path(), STEP, "secret.csv");
    std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o000)).unwrap();
    let Some(out) = run(&["identify", "spindle", s(&secret)]) else {
        return;
    };
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("secret.csv") && err.contains("ermission denied"),
        "{err}"
    );
    // an output directory nobody may write: refused naming the file, nothing left there
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let model = locked.join("m.toml");
    let out = run(&["identify", "spindle", STEP, "--save", s(&model)]).unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("m.toml") && err.contains("ermission denied"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(&locked).unwrap().count(), 0);
}

// ---------------------------------------------------------------------------------------------
// Killed writes: SIGKILL at random moments leaves no half-written, empty or stray file, and a rerun
// gives the files of an undisturbed run.

/// A file's text without the lines that differ between two runs of the same command (the time in the
/// provenance).
fn stable(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes)
        .lines()
        .filter(|l| !l.starts_with("created_utc"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every file under `dir`, relative, sorted.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

#[cfg(unix)]
#[test]
fn killed_writes_leave_no_half_written_or_stray_file() {
    use rand_chacha::rand_core::{RngCore, SeedableRng};
    let work = tempfile::tempdir().unwrap();
    let step = copy(work.path(), STEP, "step.csv");
    let scenario = copy(work.path(), SCENARIO, "scenario.toml");
    let clean_toml = copy(work.path(), CLEAN_TOML, "clean.toml");
    let clean_csv = copy(work.path(), CLEAN_CSV, "clean.csv");
    // each verb writes into `out/` (relative: the provenance records the command as typed)
    let verbs: Vec<(&str, Vec<String>)> = vec![
        (
            "identify --save",
            vec![
                "identify".into(),
                "spindle".into(),
                s(&step).into(),
                "--save".into(),
                "out/m.toml".into(),
            ],
        ),
        (
            "commission --out",
            vec![
                "commission".into(),
                s(&scenario).into(),
                "--out".into(),
                "out/b.toml".into(),
            ],
        ),
        (
            "diagnose --next-plan --report",
            vec![
                "diagnose".into(),
                s(&clean_toml).into(),
                s(&clean_csv).into(),
                "--next-plan".into(),
                "out/next.toml".into(),
                "--report".into(),
                "out/report".into(),
            ],
        ),
        (
            "doe design --out",
            vec![
                "doe".into(),
                "design".into(),
                "--design".into(),
                "full".into(),
                "--factors".into(),
                "A,B,C,D,E,F,G,H,J,K,L,M".into(),
                "--seed".into(),
                "1".into(),
                "--out".into(),
                "out/d.csv".into(),
            ],
        ),
    ];
    let bin = assert_cmd::cargo::cargo_bin("millcomp");
    let run_in = |dir: &Path, args: &[String]| {
        std::fs::create_dir_all(dir.join("out")).unwrap();
        std::process::Command::new(&bin)
            .args(args)
            .current_dir(dir)
            .env("RAYON_NUM_THREADS", "2")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(51);
    let kills_per_verb = 6;
    let (mut kills, mut with_output, mut damaged, mut stray) = (0, 0, 0, 0);
    for (verb, args) in &verbs {
        // an undisturbed run: the reference files and the run's duration
        let reference_dir = work.path().join(format!("ref-{}", verb.replace(' ', "_")));
        let start = std::time::Instant::now();
        assert!(
            run_in(&reference_dir, args).wait().unwrap().success(),
            "{verb}"
        );
        let duration = start.elapsed();
        let reference: Vec<(PathBuf, String)> = files_under(&reference_dir.join("out"))
            .into_iter()
            .map(|f| {
                let text = stable(&std::fs::read(reference_dir.join("out").join(&f)).unwrap());
                (f, text)
            })
            .collect();
        assert!(!reference.is_empty(), "{verb} wrote nothing");
        for k in 0..kills_per_verb {
            let dir = work
                .path()
                .join(format!("kill-{}-{k}", verb.replace(' ', "_")));
            // a moment anywhere in the run, and a little past it
            let at = duration.mul_f64((rng.next_u32() as f64 / u32::MAX as f64) * 1.2);
            let mut child = run_in(&dir, args);
            std::thread::sleep(at);
            let _ = child.kill(); // SIGKILL
            let _ = child.wait();
            kills += 1;
            let left = files_under(&dir.join("out"));
            if !left.is_empty() {
                with_output += 1;
            }
            for f in &left {
                let name = f.file_name().unwrap().to_string_lossy();
                let bytes = std::fs::read(dir.join("out").join(f)).unwrap();
                let expected = reference.iter().find(|(r, _)| r == f);
                if name.starts_with(".millcomp-") || expected.is_none() {
                    stray += 1;
                    eprintln!("{verb}: stray file {} after a kill at {at:?}", f.display());
                } else if bytes.is_empty() || expected.is_some_and(|(_, t)| *t != stable(&bytes)) {
                    damaged += 1;
                    eprintln!(
                        "{verb}: damaged file {} after a kill at {at:?}",
                        f.display()
                    );
                }
            }
            // the rerun completes and gives the files of the undisturbed run, nothing else
            assert!(run_in(&dir, args).wait().unwrap().success(), "{verb} rerun");
            let again: Vec<(PathBuf, String)> = files_under(&dir.join("out"))
                .into_iter()
                .map(|f| {
                    let text = stable(&std::fs::read(dir.join("out").join(&f)).unwrap());
                    (f, text)
                })
                .collect();
            assert_eq!(again, reference, "{verb}: the rerun after a kill at {at:?}");
        }
    }
    eprintln!(
        "killed writes: {kills} kills ({with_output} with output files present), {damaged} damaged, \
         {stray} stray files"
    );
    assert_eq!((damaged, stray), (0, 0));
}

/// A batch killed while it writes its results (`results.csv`, `results.parquet`, `plots/`,
/// `summary.json` last, then `invocation.json`): no temporary file is left anywhere in its directory, no
/// file is empty, and whenever `summary.json` is present the tables it summarises are present and
/// complete (its presence is the batch's "the results are whole" marker). The rerun gives the
/// undisturbed run's results byte for byte. `MILLCOMP_TEST_SLOW_WRITE_MS` (closedloop's batch store)
/// stretches every text file the batch writes, so the kills land inside those writes.
#[cfg(unix)]
#[test]
fn a_killed_batch_leaves_no_stray_file_and_no_summary_without_its_tables() {
    use rand_chacha::rand_core::{RngCore, SeedableRng};
    let work = tempfile::tempdir().unwrap();
    let scenarios = write(
        work.path(),
        "s.csv",
        "tilt_deg,depth_um,length_mm\n20,60,0.5\n40,100,0.5\n",
    );
    let bin = assert_cmd::cargo::cargo_bin("millcomp");
    let run_in = |out: &Path| {
        std::process::Command::new(&bin)
            .args([
                "batch",
                "--scenarios",
                s(&scenarios),
                "--controllers",
                "none,pid",
                "--out",
                s(out),
            ])
            .env("RAYON_NUM_THREADS", "2")
            .env("MILLCOMP_TEST_SLOW_WRITE_MS", "150")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let reference = work.path().join("ref");
    let start = std::time::Instant::now();
    assert!(run_in(&reference).wait().unwrap().success());
    let duration = start.elapsed();
    let tables = ["results.csv", "results.parquet"];
    let read = |dir: &Path, name: &str| std::fs::read(dir.join(name)).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5151);
    let (mut kills, mut tables_only, mut summary_seen, mut stray, mut broken) = (0, 0, 0, 0, 0);
    for k in 0..12 {
        let dir = work.path().join(format!("kill-{k}"));
        // the first half of the kills in the last third of the run, where the results are written
        let share = rng.next_u32() as f64 / u32::MAX as f64;
        let at = duration.mul_f64(if k < 6 {
            0.67 + 0.4 * share
        } else {
            1.1 * share
        });
        let mut child = run_in(&dir);
        std::thread::sleep(at);
        let _ = child.kill(); // SIGKILL
        let _ = child.wait();
        kills += 1;
        let left = if dir.exists() {
            files_under(&dir)
        } else {
            Vec::new()
        };
        for f in &left {
            let name = f.file_name().unwrap().to_string_lossy();
            if name.starts_with(".millcomp-") || name.ends_with(".partial") {
                stray += 1;
                eprintln!("stray file {} after a kill at {at:?}", f.display());
            } else if std::fs::metadata(dir.join(f)).unwrap().len() == 0 {
                broken += 1;
                eprintln!("empty file {} after a kill at {at:?}", f.display());
            }
        }
        let has = |name: &str| dir.join(name).exists();
        if has("summary.json") {
            summary_seen += 1;
            assert_eq!(
                read(&dir, "summary.json"),
                read(&reference, "summary.json"),
                "a kill at {at:?}"
            );
            for t in tables {
                if !has(t) || read(&dir, t) != read(&reference, t) {
                    broken += 1;
                    eprintln!("summary.json without a complete {t} after a kill at {at:?}");
                }
            }
        } else if tables.iter().any(|t| has(t)) {
            tables_only += 1;
        }
        // the rerun resumes and gives the undisturbed run's results
        assert!(run_in(&dir).wait().unwrap().success(), "rerun after {at:?}");
        for name in ["summary.json", "results.csv", "results.parquet"] {
            assert_eq!(
                read(&dir, name),
                read(&reference, name),
                "{name} after {at:?}"
            );
        }
        assert!(
            !files_under(&dir)
                .iter()
                .any(|f| f.to_string_lossy().contains(".millcomp-")),
            "a temporary file after the rerun"
        );
    }
    eprintln!(
        "killed batches: {kills} kills ({tables_only} with the tables but no summary yet, \
         {summary_seen} with the summary), {stray} stray files, {broken} empty or incomplete"
    );
    assert_eq!((stray, broken), (0, 0));
}
