//! ANOVA on data that share a large common offset, against exact answers.
//!
//! The float64 limit. A response given as decimal text is rounded once, to float64, before any
//! program sees it; after that, the best any float64 program can do is what exact arithmetic on
//! those f64 inputs gives. So the limit of a statistic is the number of digits (LRE,
//! `−log₁₀|x − c|/|c|`) by which the exact answer on the f64-rounded inputs agrees with the exact
//! answer on the decimal data. `analyze` must come within 0.5 digit of it.
//!
//! Reference values: `bench/peers/exact_anova.py` (Python `fractions`: exact rational arithmetic,
//! standard library only) — the exact F on the decimal data and on their f64 values; and NIST's
//! certified values in the StRD `.dat` files (see `tests/fixtures/nist_strd/README.md`).

use millcomp_doe::{AnalysisInput, ModelSpec, Values, analyze};

use crate::common::crate_path;
use crate::offset_data::{lre, offset_responses};

/// The offset factorial of `exact_anova.py`: 2³ in standard order, two replicates, responses
/// 1e12 + d with d to four decimals (the f64 spacing at 1e12 is 1.2e-4, so the 4th decimal is
/// already rounded in the inputs).
fn offset_factorial() -> AnalysisInput {
    let level = |i: usize, bit: usize| if (i % 8) >> bit & 1 == 0 { -1.0 } else { 1.0 };
    let y = offset_responses();
    let f = |bit| Values::F64((0..16).map(|i| level(i, bit)).collect());
    AnalysisInput {
        factors: vec![("a".into(), f(0)), ("b".into(), f(1)), ("c".into(), f(2))],
        response_name: "y".into(),
        response: Values::F64(y),
        model: ModelSpec::Main,
    }
}

#[test]
fn offset_response_f_within_half_a_digit_of_the_float64_limit() {
    // (term, exact F on the decimal data, exact F on the f64 inputs): exact_anova.py
    let reference = [
        ("a", 40.8382519223655, 40.836842714583334),
        ("b", 4.254539028276122, 4.254288243431874),
        ("c", 0.3823340933315851, 0.3821102956481117),
    ];
    let a = analyze(&offset_factorial()).unwrap();
    for (term, decimal, f64_exact) in reference {
        let row = a.terms.iter().find(|r| r.term == term).unwrap();
        let f = row.f.unwrap();
        let limit = lre(f64_exact, decimal);
        let got = lre(f, decimal);
        let vs_rounded = lre(f, f64_exact);
        eprintln!(
            "OFFSET F_{term}: {f:.15e}  LRE vs exact {got:.2}  float64 limit {limit:.2}  \
             LRE vs exact-on-f64-inputs {vs_rounded:.2}"
        );
        assert!(
            got >= limit - 0.5,
            "F_{term} = {f}: {got:.2} digits, the float64 limit is {limit:.2}"
        );
        // what is left is the rounding of the computation itself: far below the inputs' rounding
        assert!(
            vs_rounded >= 10.0,
            "F_{term}: {vs_rounded:.2} digits vs exact on the f64 inputs"
        );
    }
}

/// A NIST StRD one-way ANOVA set: certified values and the (treatment, response) rows.
struct AnovaSet {
    ss_between: f64,
    ss_within: f64,
    f: f64,
    r_squared: f64,
    resid_sd: f64,
    treatment: Vec<String>,
    response: Vec<f64>,
}

/// Reads NIST's fixed text format: the certified block (`Between …`, `Within …`,
/// `Certified R-Squared`, `Standard Deviation`) and the data lines the header points to.
fn read_anova(name: &str) -> AnovaSet {
    let path = crate_path(&format!("tests/fixtures/nist_strd/{name}.dat"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let lines: Vec<&str> = text.lines().collect();
    let num = |w: &str, k: usize| -> f64 {
        w.parse()
            .unwrap_or_else(|e| panic!("{} line {}: `{w}`: {e}", path.display(), k + 1))
    };
    let data_range = lines[..15]
        .iter()
        .find(|l| l.trim_start().starts_with("Data "))
        .and_then(|l| l.split('(').nth(1))
        .map(|s| {
            s.split_whitespace()
                .filter_map(|w| w.trim_end_matches(')').parse::<usize>().ok())
                .collect::<Vec<_>>()
        })
        .unwrap_or_else(|| panic!("{}: no data line range", path.display()));
    let (mut sb, mut sw, mut f, mut r2, mut sd) = (None, None, None, None, None);
    for (k, l) in lines.iter().enumerate().take(data_range[0] - 1) {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first().copied() {
            Some("Between") => {
                sb = Some(num(w[3], k));
                f = Some(num(w[5], k));
            }
            Some("Within") => sw = Some(num(w[3], k)),
            Some("Certified") if l.contains("R-Squared") => r2 = Some(num(w[2], k)),
            Some("Standard") if l.contains("Deviation") => sd = Some(num(w[2], k)),
            _ => {}
        }
    }
    let mut treatment = Vec::new();
    let mut response = Vec::new();
    for (k, l) in lines
        .iter()
        .enumerate()
        .take(data_range[1])
        .skip(data_range[0] - 1)
    {
        let w: Vec<&str> = l.split_whitespace().collect();
        treatment.push(w[0].to_string());
        response.push(num(w[1], k));
    }
    let missing = || panic!("{}: incomplete certified block", path.display());
    AnovaSet {
        ss_between: sb.unwrap_or_else(missing),
        ss_within: sw.unwrap_or_else(missing),
        f: f.unwrap_or_else(missing),
        r_squared: r2.unwrap_or_else(missing),
        resid_sd: sd.unwrap_or_else(missing),
        treatment,
        response,
    }
}

#[test]
fn nist_strd_one_way_anova_sets() {
    // (set, float64 limit of F): LRE of the exact F on the f64-rounded data against NIST's
    // certified F, from exact_anova.py (15 = exact to float64 precision).
    let sets = [
        ("SiRstv", 13.06_f64),
        ("SmLs01", 15.0),
        ("SmLs02", 15.0),
        ("SmLs03", 15.0),
        ("AtmWtAg", 10.15),
        ("SmLs04", 10.43),
        ("SmLs05", 10.21),
        ("SmLs06", 10.19),
        ("SmLs07", 4.41),
        ("SmLs08", 4.19),
        ("SmLs09", 4.17),
    ];
    let mut failures = Vec::new();
    for (name, limit) in sets {
        let s = read_anova(name);
        let input = AnalysisInput {
            factors: vec![("treatment".into(), Values::Str(s.treatment.clone()))],
            response_name: "y".into(),
            response: Values::F64(s.response.clone()),
            model: ModelSpec::Main,
        };
        let a = analyze(&input).unwrap();
        let row = &a.terms[0];
        let l = [
            lre(row.f.unwrap(), s.f),
            lre(row.sum_sq, s.ss_between),
            lre(a.residual_sum_sq, s.ss_within),
            lre(a.r_squared, s.r_squared),
            lre(a.sigma.unwrap(), s.resid_sd),
        ];
        eprintln!(
            "NIST ANOVA {name:8} n={:>5}  LRE F {:>5.2} (f64 limit {limit:>5.2})  SSB {:>5.2}  SSW {:>5.2}  R² {:>5.2}  sd {:>5.2}",
            s.response.len(),
            l[0],
            l[1],
            l[2],
            l[3],
            l[4]
        );
        // where the inputs are exact in float64 (limit 15) what is left is the computation's own
        // rounding: a sum of n terms may lose n·ε relative, so the bar is the smaller of the two
        let rounding = -(s.response.len() as f64 * f64::EPSILON).log10();
        let need = limit.min(rounding) - 0.5;
        if l[0] < need {
            failures.push(format!("{name}: F has {:.2} digits, need {need:.2}", l[0]));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
