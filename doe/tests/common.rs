//! Shared test helpers and the tolerance constants of this crate's tests.

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

/// Reads a CSV fixture of this crate (`rel` from the crate root) through the one table reader,
/// `millcomp_datasets::read_any` (a column whose cells are all finite numbers is numeric, any other is
/// text), as doe's named values (`millcomp_datasets::adapters::doe_columns`).
pub fn read_fixture(rel: &str) -> Vec<(String, Values)> {
    let p = crate_path(rel);
    let table = millcomp_datasets::read_any(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    millcomp_datasets::adapters::doe_columns(&table)
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
