//! The harness of fuzz target `pipeline_plan`: a `millcomp pipeline PLAN.toml` plan
//! (`millcomp_pipeline::plan::Plan`) read as the CLI reads it, then its two designs (`[design]` and
//! `[compare]`) generated as the pipeline's design stages generate them, without running a stage.
//!
//! A file of its own, not a part of `src/lib.rs`: the pipeline crate depends on closedloop, whose
//! integration tests compile `src/lib.rs` on stable (`closedloop/tests/fuzz_regressions.rs`), so the
//! pipeline's harness is compiled on stable by the pipeline's own tests instead
//! (`pipeline/tests/fuzz_regressions.rs`), which replay `fuzz/regressions/pipeline/` and the shipped
//! plans through it.

use std::path::Path;

use millcomp_doe::{DesignKind, DesignRequest, FactorSpec, generate};
use millcomp_pipeline::plan::Plan;

/// Where the harness says the plan lives: absolute, so that the paths it anchors stay put when the
/// plan is written back and read again.
const AT: &str = "/fuzz/plan.toml";

/// Reads `data` as a plan; when the plan is accepted, checks what it promises and generates its designs.
///
/// # Panics
/// When an accepted plan breaks a promise: a tolerance or groove length out of its documented range,
/// no controller or force parameter, a relative path left unanchored, a plan that does not read back
/// the same after being written, or a design of more runs than the design's own bound.
pub fn pipeline_plan(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(plan) = Plan::from_toml_str(text, Path::new(AT)) else {
        return;
    };
    let c = &plan.compare;
    assert!(
        c.tolerance_pp_um.is_finite() && c.tolerance_pp_um > 0.0,
        "{plan:?}"
    );
    assert!((3.0..=40.0).contains(&c.length_mm), "{plan:?}");
    assert!(
        !c.controllers.is_empty() && !plan.identify.force_free.is_empty(),
        "{plan:?}"
    );
    let m = &plan.measure;
    for p in [
        &m.forces,
        &m.spindle_step,
        &m.hysteresis_sweep,
        &m.load_deflection,
        &m.sensors_at_rest,
        &c.results,
        &plan.diagnose.session,
        &plan.diagnose.measured,
        &plan.rerun.results,
    ]
    .into_iter()
    .flatten()
    {
        assert!(
            p.is_absolute(),
            "{} not anchored at the plan's directory",
            p.display()
        );
    }
    // written back (what a report records) and read again: the same plan
    if let Ok(again) = toml::to_string(&plan) {
        let back = Plan::from_toml_str(&again, Path::new(AT))
            .unwrap_or_else(|e| panic!("a written plan does not read back: {e}\n{again}"));
        assert_eq!(back, plan, "{again}");
    }
    // the designs of the `design` and `design-comparison` stages (pipeline/src/calibration.rs,
    // design_table): a full factorial up to 3 factors, else the smallest fraction of the resolution
    for (factors, resolution, salt) in [
        (&plan.design.factors, plan.design.resolution, 0),
        (&c.factors, c.resolution, 0xc0),
    ] {
        let Ok(factors) = FactorSpec::parse_list(factors) else {
            continue;
        };
        let k = factors.len();
        let kind = if k <= 3 {
            DesignKind::Full
        } else {
            DesignKind::Fractional
        };
        let mut req = DesignRequest::new(kind, factors);
        if k > 3 {
            req.resolution = Some(resolution);
        }
        req.seed = Some(plan.seed ^ salt);
        if let Ok(d) = generate(&req) {
            assert!((1..=1_000_000).contains(&d.n_runs()), "{} runs", d.n_runs());
        }
    }
}
