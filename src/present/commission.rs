//! Text of `millcomp commission`: the experiments, the identified parameters with their intervals, the
//! warnings; the coverage study's table.

use std::fmt::Write;

use millcomp_closedloop::commissioning::{Commissioned, CoverageRow};
use millcomp_models::ModelBundle;

/// One commissioning: experiments, parameters (estimate, standard error, 95 % interval), warnings.
pub fn commissioning_text(scenario: &str, seed: u64, c: &Commissioned) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "commissioning of `{scenario}` (seed {seed}, material {})",
        c.bundle.material
    );
    for e in &c.bundle.experiments {
        let _ = writeln!(s, "  {e}");
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{:<38} {:>14} {:>12} {:>30}",
        "parameter", "estimate", "std err", "95 % interval"
    );
    for (name, v, se, ci) in c.parameters() {
        let _ = writeln!(
            s,
            "{:<38} {:>14} {:>12} {:>30}",
            name,
            num(v),
            num(se),
            format!("[{}, {}]", num(ci[0]), num(ci[1]))
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "spindle structures (BIC, smallest kept):");
    for (name, b) in &c.spindle_bic {
        let _ = writeln!(s, "  {name:<32} {b:>12.1}");
    }
    if c.bundle.warnings.is_empty() {
        let _ = writeln!(s, "warnings: none");
    } else {
        let _ = writeln!(s, "warnings:");
        for w in &c.bundle.warnings {
            let _ = writeln!(s, "  {w}");
        }
    }
    s
}

/// A bundle assembled from the user's own models: its parts, each parameter with its standard error,
/// the warnings.
pub fn bundle_text(b: &ModelBundle) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "bundle from your own models (material {})", b.material);
    for e in &b.experiments {
        let _ = writeln!(s, "  {e}");
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{:<38} {:>14} {:>12}",
        "parameter", "estimate", "std err"
    );
    for (prefix, m) in [
        ("force", &b.force),
        ("spindle", &b.spindle),
        ("stiffness", &b.stiffness),
    ] {
        let Some(m) = m else {
            let _ = writeln!(s, "{:<38} {:>14}", format!("{prefix}.*"), "(none)");
            continue;
        };
        for (name, v) in &m.params {
            let se = m.std_err.get(name).copied().unwrap_or(f64::NAN);
            let _ = writeln!(
                s,
                "{:<38} {:>14} {:>12}",
                format!("{prefix}.{name}"),
                num(*v),
                num(se)
            );
        }
    }
    if b.warnings.is_empty() {
        let _ = writeln!(s, "warnings: none");
    } else {
        let _ = writeln!(s, "warnings:");
        for w in &b.warnings {
            let _ = writeln!(s, "  {w}");
        }
    }
    s
}

/// The coverage study: per parameter, how often the 95 % interval covered the pseudo-true value.
pub fn coverage_text(scenario: &str, seed: u64, n: u64, rows: &[CoverageRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "coverage of the 95 % intervals, `{scenario}`, seeds {seed}..{} (each its own instrument errors and noise)",
        seed + n - 1
    );
    let _ = writeln!(
        s,
        "{:<38} {:>9} {:>9} {:>10} {:>14}",
        "parameter", "covered", "rate", "p (95 %)", "median |z|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{:<38} {:>9} {:>8.1}% {:>10.4} {:>14.3}",
            r.parameter,
            format!("{}/{}", r.covered, r.n),
            100.0 * r.covered as f64 / r.n.max(1) as f64,
            r.p_value,
            r.median_abs_z
        );
    }
    let _ = writeln!(
        s,
        "p: two-sided binomial test of the count against 95 %; a standard normal has median |z| = 0.674"
    );
    s
}

fn num(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:.4e}")
    } else {
        format!("{v:.5}")
    }
}
