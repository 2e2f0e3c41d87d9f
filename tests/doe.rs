//! End-to-end tests of `millcomp doe design|analyze` through the binary.

use crate::common::*;

use predicates::prelude::*;

fn term<'a>(doc: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    doc["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["term"] == name)
        .unwrap_or_else(|| panic!("term {name} missing"))
}

#[test]
fn analyze_table_3_3_reproduces_the_thesis_conclusion() {
    // 000_…txt §3.5: depth and upfeed significant for the X force, speed not; upfeed for Z.
    let fx = json_of(&[
        "doe",
        "analyze",
        CLAYTON,
        "--response",
        "max_fx_n",
        "--factors",
        "depth_um,speed_rpm,upfeed_um",
        "--json",
    ]);
    assert_eq!(fx["n_runs"], 8);
    assert_eq!(fx["residual_df"], 4);
    assert!(term(&fx, "depth_um")["p_value"].as_f64().unwrap() < 0.05);
    assert!(term(&fx, "upfeed_um")["p_value"].as_f64().unwrap() < 0.05);
    assert!(term(&fx, "speed_rpm")["p_value"].as_f64().unwrap() > 0.05);
    // Effect of depth = mean(high) - mean(low) of Table 3-3's X column:
    // (3.34+1.91+3.60+2.20)/4 - (1.78+0.94+2.20+1.00)/4 = 2.7625 - 1.48 = 1.2825 N.
    let effect = term(&fx, "depth_um")["effect"].as_f64().unwrap();
    assert!((effect - 1.2825).abs() < 1e-12, "{effect}");

    let fz = json_of(&[
        "doe",
        "analyze",
        CLAYTON,
        "--response",
        "max_fz_n",
        "--factors",
        "depth_um,speed_rpm,upfeed_um",
        "--json",
    ]);
    assert!(term(&fz, "upfeed_um")["p_value"].as_f64().unwrap() < 0.05);
    assert!(term(&fz, "speed_rpm")["p_value"].as_f64().unwrap() > 0.05);
}

#[test]
fn analyze_matches_statsmodels_golden_through_the_cli() {
    // Golden from bench/peers/doe_goldens.py: statsmodels 0.15.0,
    // anova_lm(ols('fx_n ~ depth_um_c + speed_rpm_c + upfeed_um_c', coded).fit(), typ=2),
    // stored in doe/tests/golden/anova_clayton.json with the versions and calls.
    let golden: serde_json::Value =
        serde_json::from_str(include_str!("../doe/tests/golden/anova_clayton.json")).unwrap();
    for (response, key) in [
        ("max_fx_n", "fx_n"),
        ("max_fy_n", "fy_n"),
        ("max_fz_n", "fz_n"),
    ] {
        let doc = json_of(&[
            "doe",
            "analyze",
            CLAYTON,
            "--response",
            response,
            "--factors",
            "depth_um,speed_rpm,upfeed_um",
            "--json",
        ]);
        let want = golden["responses"][key]["main"]["terms"]
            .as_array()
            .unwrap();
        assert_eq!(want.len(), 3);
        for w in want {
            let name = w["term"].as_str().unwrap();
            let got = term(&doc, name);
            for field in ["f", "p_value", "sum_sq"] {
                let (g, e) = (got[field].as_f64().unwrap(), w[field].as_f64().unwrap());
                assert!(
                    (g - e).abs() <= 1e-8 * e.abs().max(1e-12) + 1e-14,
                    "{key} {name} {field}: {g} vs {e}"
                );
            }
        }
    }
}

#[test]
fn fractional_resolution_3_for_seven_factors_has_8_runs() {
    let d = json_of(&[
        "doe",
        "design",
        "--design",
        "fractional",
        "--factors",
        "A,B,C,D,E,F,G",
        "--resolution",
        "3",
        "--json",
    ]);
    assert_eq!(d["n_runs"], 8);
    assert_eq!(d["resolution"], 3);
    assert_eq!(d["runs"].as_array().unwrap().len(), 8);
    let run = &d["runs"][0];
    for k in ["std_order", "run_order", "block", "A", "A_coded", "G_coded"] {
        assert!(!run[k].is_null(), "run lacks {k}: {run}");
    }
}

#[test]
fn design_writes_csv_and_parquet_that_analyze_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["d.csv", "d.parquet"] {
        let out = dir.path().join(name);
        millcomp()
            .args([
                "doe",
                "design",
                "--design",
                "full",
                "--factors",
                "depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20",
                "--seed",
                "7",
                "--out",
            ])
            .arg(&out)
            .assert()
            .success();
        let table = millcomp_datasets::read_any(&out).unwrap();
        assert_eq!(table.n_rows(), 8);
        let depth = table.f64s("depth_um").unwrap();
        assert_eq!(depth.iter().filter(|&&d| d == 100.0).count(), 4);
        assert_eq!(
            table.f64s("depth_um_coded").unwrap().iter().sum::<f64>(),
            0.0
        );
    }
}

#[test]
fn save_writes_a_model_file_and_plots_land_in_the_directory() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("fx.toml");
    let plots = dir.path().join("plots");
    millcomp()
        .args([
            "doe",
            "analyze",
            CLAYTON,
            "--response",
            "max_fx_n",
            "--factors",
            "depth_um,speed_rpm,upfeed_um",
            "--save",
        ])
        .arg(&model)
        .arg("--plots")
        .arg(&plots)
        .assert()
        .success()
        .stdout(predicate::str::contains("depth_um"));
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("depth_um"), "{text}");
    let svgs = std::fs::read_dir(&plots).unwrap().count();
    assert!(svgs >= 4, "only {svgs} plots");
}

#[test]
fn bad_input_is_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.toml");
    // Unknown factor name.
    millcomp()
        .args([
            "doe",
            "analyze",
            CLAYTON,
            "--response",
            "max_fx_n",
            "--factors",
            "depth_um,feed",
            "--save",
        ])
        .arg(&model)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("feed"));
    // Non-numeric response cell.
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "a,b,y\n-1,-1,1.0\n1,-1,2.0\n-1,1,x\n1,1,4.0\n").unwrap();
    millcomp()
        .args(["doe", "analyze"])
        .arg(&bad)
        .args(["--response", "y", "--factors", "a,b", "--save"])
        .arg(&model)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("y"))
        .stderr(predicate::str::contains("x"));
    // More model terms than runs.
    millcomp()
        .args(["doe", "analyze"])
        .arg(&bad)
        .args([
            "--response",
            "a",
            "--factors",
            "b,y",
            "--model",
            "quadratic",
        ])
        .assert()
        .code(1);
    // Aliased generators.
    millcomp()
        .args([
            "doe",
            "design",
            "--design",
            "fractional",
            "--factors",
            "A,B,C,D,E",
            "--generators",
            "D=AB,E=AB",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("E"));
    // A factor with one level.
    millcomp()
        .args([
            "doe",
            "design",
            "--design",
            "full",
            "--factors",
            "depth_um=100:100,B",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("depth_um"));
    assert!(!model.exists());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n.to_string_lossy().contains("partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn a_reader_that_stops_early_ends_the_program_quietly() {
    // `millcomp doe design … | head -1`: the pipe closes after the first line; before, println!
    // panicked on the broken pipe ("failed printing to stdout"). The design is 4096 runs (≈ 0.5 MB),
    // far more than a pipe's buffer, so the program is still writing when the reader goes away.
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("millcomp"))
        .args([
            "doe",
            "design",
            "--design",
            "full",
            "--factors",
            "a=0:1,b=0:1,c=0:1,d=0:1,e=0:1,f=0:1,g=0:1,h=0:1,i=0:1,j=0:1,k=0:1,l=0:1",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    // the reader is dropped here: the pipe is closed with most of the design unwritten
    let out = child.wait_with_output().unwrap();
    assert!(first.contains("runs: 4096"), "{first}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}
