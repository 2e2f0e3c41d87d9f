//! `millcomp commission`: a bundle written with its provenance, a scenario run on it, the coverage study,
//! and bad input named.

use predicates::str::contains;

use crate::common::{millcomp, repo, s, write};

const SCENARIO: &str = "datasets/scenarios/groove_s7_20deg_commissioned.toml";

#[test]
fn commission_writes_a_bundle_that_a_scenario_runs_on() {
    let tmp = tempfile::tempdir().unwrap();
    let bundle = tmp.path().join("models.toml");
    millcomp()
        .args(["commission", &repo(SCENARIO), "--out", s(&bundle)])
        .assert()
        .success()
        .stdout(contains("force.w_mpa"))
        .stdout(contains("spindle structures (BIC, smallest kept)"))
        .stdout(contains("stiffness.radial_stiffness_n_per_um"));
    let text = std::fs::read_to_string(&bundle).unwrap();
    assert!(text.contains("kind = \"bundle\""), "{text}");
    assert!(text.contains("sha256"), "{text}");
    // the same scenario, its controllers built from the saved bundle instead of commissioning itself
    let scenario = std::fs::read_to_string(repo(SCENARIO))
        .unwrap()
        .replace("commission = true", &format!("bundle = \"{}\"", s(&bundle)));
    let file = write(tmp.path(), "on_bundle.toml", &scenario);
    millcomp()
        .args(["simulate", s(&file), "--controller", "mpc"])
        .assert()
        .success()
        .stdout(contains("peak-to-peak error"));
}

#[test]
fn coverage_study_prints_a_row_per_parameter() {
    millcomp()
        .args(["commission", &repo(SCENARIO), "--coverage", "5"])
        .assert()
        .success()
        .stdout(contains("force.w_mpa"))
        .stdout(contains("/5"));
}

#[test]
fn bad_input_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario =
        std::fs::read_to_string(repo(SCENARIO)).unwrap() + "\n[commissioning]\nreplicates = 0\n";
    let file = write(tmp.path(), "bad.toml", &scenario);
    millcomp()
        .args(["commission", s(&file)])
        .assert()
        .code(1)
        .stderr(contains("commissioning.replicates"));
    millcomp()
        .args(["commission", &repo("datasets/scenarios/thin_wall_h59.toml")])
        .assert()
        .code(1)
        .stderr(contains("groove scenarios"));
    let out = tmp.path().join("no/such/dir/models.toml");
    millcomp()
        .args(["commission", &repo(SCENARIO), "--out", s(&out)])
        .assert()
        .code(1)
        .stderr(contains("models.toml"));
}

const STIFFNESS_RUN: &str = "datasets/runs/stiffness_masses_synthetic.csv";

/// The committed, seeded generator of `datasets/runs/stiffness_masses_synthetic.csv` (documented in
/// `datasets/runs/README.md`): the thesis' hanging-mass calibration (`000_…txt` §5.2.3: 50, 100 … 1000 g
/// radial, 100 … 1000 g axial, three trials) on the Table 5-1 measured stiffnesses (1.220 axial, 0.114
/// radial N/µm), read on the commissioning's dial indicator (`StiffnessCalibration::default()`: σ = 0.5 µm
/// noise, rounded to its 1 µm resolution).
fn generate_stiffness_run() -> String {
    use millcomp_closedloop::calibration::{
        G_N_PER_KG, StiffnessCalibration, axial_masses_g, radial_masses_g,
    };
    use rand_chacha::rand_core::SeedableRng;
    let cal = StiffnessCalibration::default();
    let noise = cal.noise().expect("noise");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let mut out = String::from("load_n,deflection_um,direction\n");
    for (direction, k, masses) in [
        ("radial", 0.114, radial_masses_g()),
        ("axial", 1.220, axial_masses_g()),
    ] {
        for _trial in 0..cal.trials {
            for m in &masses {
                let load = m * 1e-3 * G_N_PER_KG;
                let reading = cal.reading_um(load / k, &noise, &mut rng);
                out.push_str(&format!("{load:.5},{reading:.0},{direction}\n"));
            }
        }
    }
    out
}

#[test]
fn shipped_stiffness_run_matches_its_generator() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(STIFFNESS_RUN);
    let text = generate_stiffness_run();
    if std::env::var_os("MILLCOMP_REGENERATE").is_some() {
        std::fs::write(&path, &text).expect("write the stiffness run");
    }
    let shipped = std::fs::read_to_string(&path).expect("shipped stiffness run");
    assert_eq!(shipped, text, "{STIFFNESS_RUN} differs from its generator");
}

/// A bundle from the user's own calibration records: each identified with `identify … --save`, put
/// together by `commission --spindle/--force/--stiffness`, and a scenario run on it.
#[test]
fn a_bundle_from_your_own_identified_models_runs_a_scenario() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n);
    for (target, data, file, extra) in [
        (
            "spindle",
            "datasets/runs/spindle_step_synthetic.csv",
            "spindle.toml",
            vec![],
        ),
        ("stiffness", STIFFNESS_RUN, "stiffness.toml", vec![]),
        (
            "force",
            "datasets/data/clayton_doe.csv",
            "force.toml",
            vec!["--material", "6061"],
        ),
    ] {
        let save = p(file);
        millcomp()
            .args(["identify", target, &repo(data)])
            .args(extra)
            .args(["--save", s(&save)])
            .assert()
            .success();
    }
    let bundle = p("models.toml");
    millcomp()
        .args([
            "commission",
            "--spindle",
            s(&p("spindle.toml")),
            "--force",
            s(&p("force.toml")),
            "--stiffness",
            s(&p("stiffness.toml")),
            "--material",
            "6061",
            "--out",
            s(&bundle),
        ])
        .assert()
        .success()
        .stdout(contains("bundle from your own models (material 6061)"))
        .stdout(contains("stiffness.radial_stiffness_n_per_um"))
        .stdout(contains("spindle.zeta"));
    let text = std::fs::read_to_string(&bundle).unwrap();
    assert!(
        text.contains("kind = \"bundle\"") && text.contains("sha256"),
        "{text}"
    );
    // the radial stiffness comes back near Table 5-1's 0.114 N/µm (the generator's value)
    let b: toml::Value = toml::from_str(&text).unwrap();
    let kr = b["model"]["stiffness"]["params"]["radial_stiffness_n_per_um"]
        .as_float()
        .unwrap();
    assert!((kr - 0.114).abs() < 0.005, "{kr}");
    let scenario = format!(
        "{}\n[groove]\nmaterial = \"6061\"\ntilt_deg = 20.0\nlength_mm = 2.0\ndepth = {{ kind = \"ramp\", from_um = 0.0, to_um = 20.0 }}\n[control]\nbundle = \"{}\"\n",
        "name = \"own\"\ndescription = \"own bundle\"\nstage = \"groove\"\nseed = 1\ncontrollers = [\"mpc\"]",
        s(&bundle)
    );
    let file = write(tmp.path(), "own.toml", &scenario);
    millcomp()
        .args(["simulate", s(&file), "--controller", "mpc"])
        .assert()
        .success()
        .stdout(contains("peak-to-peak error"));
    // a file of the wrong kind is refused naming the file
    millcomp()
        .args([
            "commission",
            "--spindle",
            s(&p("force.toml")),
            "--material",
            "6061",
        ])
        .assert()
        .failure()
        .stderr(contains("force.toml"))
        .stderr(contains("spindle"));
    // the material is required
    millcomp()
        .args(["commission", "--stiffness", s(&p("stiffness.toml"))])
        .assert()
        .failure()
        .stderr(contains("--material"));
}
