//! Shared test helpers and the tolerance constants of this crate's tests.
#![allow(dead_code)]

use std::path::PathBuf;

use millcomp_doe::Values;

/// F and p-values against statsmodels (contract: "to 1e-8 in F and p"). Both sides solve the same small,
/// well-conditioned least-squares problem in double precision; the SS differences behind F lose at most a few
/// digits, and statrs' regularised incomplete beta is accurate to ~1e-14 relative, so 1e-8 has margin.
pub const TOL_F: f64 = 1e-8;
/// Same for p-values (absolute).
pub const TOL_P: f64 = 1e-8;
/// Coefficients, standard errors, sums of squares, R², leverages (relative to the value's magnitude, floored at
/// 1): pure linear algebra on matrices with condition number < 100, so rounding is ~1e-13.
pub const TOL_LINALG: f64 = 1e-10;
/// Noncentral F CDF/SF against scipy.stats.ncf (absolute): the Poisson mixture is truncated when the remaining
/// Poisson mass is below 1e-17 and each beta term is accurate to ~1e-14; scipy (Boost) is accurate to ~1e-15.
pub const TOL_NCF: f64 = 1e-10;
/// Quantile-based numbers (critical F, Lenth ME/SME): statrs' inverse incomplete beta is Newton-refined to about
/// 1e-10 relative for these degrees of freedom, so 1e-8 relative is safe.
pub const TOL_QUANTILE: f64 = 1e-8;
/// Published figures printed with 3 decimals (Montgomery's effects are exact multiples of 1/8, so exact).
pub const TOL_PUBLISHED_EXACT: f64 = 1e-12;

/// Path inside the crate.
pub fn crate_path(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Loads a golden JSON file from `tests/golden/`.
pub fn golden(name: &str) -> serde_json::Value {
    let p = crate_path(&format!("tests/golden/{name}"));
    let s = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&s).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Reads a small CSV fixture (no quoted commas) into named columns: numeric when every cell parses.
pub fn read_csv(rel: &str) -> Vec<(String, Values)> {
    let p = crate_path(rel);
    let s = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut lines = s.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|h| h.trim().to_string())
        .collect();
    let rows: Vec<Vec<String>> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut cells: Vec<String> = l
                .splitn(header.len(), ',')
                .map(|c| c.trim().to_string())
                .collect();
            cells.resize(header.len(), String::new());
            cells
        })
        .collect();
    header
        .iter()
        .enumerate()
        .map(|(j, h)| {
            let vals: Vec<String> = rows.iter().map(|r| r[j].clone()).collect();
            let nums: Option<Vec<f64>> = vals.iter().map(|v| v.parse::<f64>().ok()).collect();
            (
                h.clone(),
                match nums {
                    Some(v) => Values::F64(v),
                    None => Values::Str(vals),
                },
            )
        })
        .collect()
}

/// A JSON number or null as Option<f64>.
pub fn num(v: &serde_json::Value) -> Option<f64> {
    v.as_f64()
}

/// |a − b| ≤ tol·max(1, |b|).
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

pub fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}
