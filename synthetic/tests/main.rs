//! The generator against the committed files of `datasets/synthetic/` (one integration-test binary).

use std::path::PathBuf;

use millcomp_sim::session::Session;

/// `datasets/synthetic/` of the workspace.
fn synthetic_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../datasets/synthetic")
}

#[test]
fn session_toml_round_trips() {
    let c = millcomp_synthetic::cases()
        .into_iter()
        .find(|c| c.name == "clean")
        .unwrap();
    let d = millcomp_synthetic::generate(&c).unwrap();
    let back = Session::from_toml_str(&d.session_toml).unwrap();
    assert_eq!(back, d.session);
    // the common plan: 14 grooves × 21 points (crate documentation)
    assert_eq!(d.points.len(), 294);
}

#[test]
fn committed_files_are_up_to_date() {
    let dir = synthetic_dir();
    let cases = millcomp_synthetic::cases();
    for c in &cases {
        let d = millcomp_synthetic::generate(c).unwrap();
        let files = d.files().unwrap();
        assert_eq!(files.len(), if c.force_trace { 3 } else { 2 }, "{}", c.name);
        for (name, text) in files {
            let committed = std::fs::read_to_string(dir.join(&name)).unwrap();
            assert!(
                committed == text,
                "{name} differs from the generator: rerun gen_synthetic"
            );
        }
    }
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap();
    assert_eq!(readme, millcomp_synthetic::readme(&cases));
}
