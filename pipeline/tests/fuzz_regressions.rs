//! The fuzz target `pipeline_plan` on stable: its harness (`fuzz/src/pipeline_plan.rs`, which the
//! fuzzer runs) replays the shipped plans, the campaign's seeds and every input the campaign found
//! (`fuzz/regressions/pipeline_plan/`, named after what it found; its fix is in the commit that added
//! it). None may panic; the harness checks what an accepted plan promises.
//!
//! Rerun: `cargo test --workspace --test main fuzz_regressions` (or `-p millcomp-pipeline`).

#[path = "../../fuzz/src/pipeline_plan.rs"]
mod harness;

use std::path::{Path, PathBuf};

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.path())
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn plans_the_fuzzer_starts_from_and_found_are_handled() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut inputs = vec![root.join("datasets/pipeline/plan.toml")];
    inputs.extend(files(&root.join("fuzz/seeds/pipeline_plan")));
    inputs.extend(files(&root.join("fuzz/regressions/pipeline_plan")));
    for path in &inputs {
        let data = std::fs::read(path).unwrap();
        let outcome = std::panic::catch_unwind(|| harness::pipeline_plan(&data));
        assert!(
            outcome.is_ok(),
            "fuzz target `pipeline_plan` panics on {}",
            path.display()
        );
    }
    // the shipped plan and the seeds are accepted (the harness's checks ran on them, not only a refusal)
    let seeds = files(&root.join("fuzz/seeds/pipeline_plan"));
    assert!(seeds.len() >= 4, "{} seeds", seeds.len());
    for path in std::iter::once(&inputs[0]).chain(&seeds) {
        let text = std::fs::read_to_string(path).unwrap();
        millcomp_pipeline::plan::Plan::from_toml_str(&text, Path::new("/fuzz/plan.toml"))
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
}
