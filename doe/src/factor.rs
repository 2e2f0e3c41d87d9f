//! Factor specifications (`depth_um=100:200`, `A`, `material=S7:1018:6061`), levels and the typed values of
//! a factor or response ([`Values`]).

use serde::Serialize;

use crate::error::{DoeError, Result};

/// Letters used for factors in generators and defining relations, in factor order.
///
/// `I` is skipped because it denotes the identity in defining relations (the convention of
/// Montgomery, *Design and Analysis of Experiments*, Table 8.14, and of R's FrF2).
pub const FACTOR_LETTERS: &[u8] = b"ABCDEFGHJKLMNOPQRSTUVWXYZ";

/// The letter of factor number `i` (0-based): `A`, `B`, …, `H`, `J`, …; beyond 25 factors `F26`, `F27`, ….
pub fn factor_letter(i: usize) -> String {
    match FACTOR_LETTERS.get(i) {
        Some(&c) => (c as char).to_string(),
        None => format!("F{}", i + 1),
    }
}

/// One level of a factor, or one value in a table: a number or a label (the models crate's type).
pub use millcomp_models::Level;

/// The typed values of one factor or response (a table column's cells without its name), in the three
/// types the table layer (`millcomp-datasets`, polars) distinguishes. Named columns are
/// `(String, Values)` pairs.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// Floating-point values.
    F64(Vec<f64>),
    /// Integer values.
    I64(Vec<i64>),
    /// Text values.
    Str(Vec<String>),
}

impl Values {
    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            Values::F64(v) => v.len(),
            Values::I64(v) => v.len(),
            Values::Str(v) => v.len(),
        }
    }

    /// `true` when the column has no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The levels a factor is given in a specification.
#[derive(Debug, Clone, PartialEq)]
pub enum FactorLevels {
    /// Bare name: coded levels only, actual = coded (−1/+1 in two-level designs).
    Coded,
    /// Numeric levels in actual units, as written (at least two distinct values).
    Numeric(Vec<f64>),
    /// Categorical levels, as written (at least two distinct labels).
    Labels(Vec<String>),
}

/// A factor of a design: its name and levels.
#[derive(Debug, Clone, PartialEq)]
pub struct FactorSpec {
    /// Factor name (a column name in tables; letters, digits and `_`, not starting with a digit).
    pub name: String,
    /// Levels.
    pub levels: FactorLevels,
}

/// Whether `s` can be used as a factor name in model formulas (`a:b`, `a^2`, `a+b`).
pub(crate) fn valid_name(s: &str) -> bool {
    let mut chars = s.chars();
    match chars.next() {
        Some(c) if c.is_alphabetic() || c == '_' => {}
        _ => return false,
    }
    chars.all(|c| c.is_alphanumeric() || c == '_' || c == '.')
}

impl FactorSpec {
    /// A factor with coded levels only (`A` → −1/+1).
    pub fn coded(name: &str) -> Self {
        FactorSpec {
            name: name.to_string(),
            levels: FactorLevels::Coded,
        }
    }

    /// A numeric factor between `low` and `high` (actual units).
    pub fn numeric(name: &str, low: f64, high: f64) -> Self {
        FactorSpec {
            name: name.to_string(),
            levels: FactorLevels::Numeric(vec![low, high]),
        }
    }

    /// Parses one entry: `name`, `name=low:high`, `name=l1:l2:l3` (numeric) or `name=S7:1018:6061` (labels:
    /// any level that is not a number makes all of them labels).
    ///
    /// ```
    /// use millcomp_doe::{FactorLevels, FactorSpec};
    /// let f = FactorSpec::parse("speed_rpm=10000:20000").unwrap();
    /// assert_eq!(f.range(), Some((10000.0, 20000.0)));
    /// assert_eq!(FactorSpec::parse("coolant=off:on").unwrap().kind(), "label");
    /// assert!(FactorSpec::parse("depth_um=100").is_err()); // one level
    /// assert!(FactorSpec::parse("depth_um=nan:1").is_err()); // not a label: a number gone wrong
    /// ```
    ///
    /// # Errors
    /// [`DoeError::InvalidFactorSpec`] for a missing or invalid name, an empty level or a level listed
    /// twice; [`DoeError::SingleLevelFactor`] when only one distinct level is given.
    pub fn parse(entry: &str) -> Result<FactorSpec> {
        let entry = entry.trim();
        let bad = |reason: &str| DoeError::InvalidFactorSpec {
            spec: entry.to_string(),
            reason: reason.to_string(),
        };
        let (name, levels) = match entry.split_once('=') {
            None => (entry, None),
            Some((n, l)) => (n.trim(), Some(l.trim())),
        };
        if name.is_empty() {
            return Err(bad("missing factor name"));
        }
        if !valid_name(name) {
            return Err(bad(
                "a factor name uses letters, digits, `_` or `.` and does not start with a digit",
            ));
        }
        let Some(levels) = levels else {
            return Ok(FactorSpec::coded(name));
        };
        let parts: Vec<&str> = levels.split(':').map(str::trim).collect();
        if parts.iter().any(|p| p.is_empty()) {
            return Err(bad("empty level; write levels as `low:high` or `l1:l2:l3`"));
        }
        if parts.len() < 2 {
            return Err(DoeError::SingleLevelFactor {
                name: name.to_string(),
                level: parts[0].to_string(),
            });
        }
        if parts.iter().all(|p| *p == parts[0]) {
            return Err(DoeError::SingleLevelFactor {
                name: name.to_string(),
                level: parts[0].to_string(),
            });
        }
        // `nan` or `inf` is a number gone wrong, not a label: refused, not read as a category
        if let Some(p) = parts
            .iter()
            .find(|p| p.parse::<f64>().is_ok_and(|v| !v.is_finite()))
        {
            return Err(bad(&format!(
                "level `{p}` is not a finite number (a factor's levels are finite numbers or labels)"
            )));
        }
        let nums: Option<Vec<f64>> = parts
            .iter()
            .map(|p| p.parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect();
        let levels = match nums {
            Some(v) => {
                let mut seen: Vec<f64> = Vec::new();
                for &x in &v {
                    if seen.contains(&x) {
                        return Err(bad(&format!("level {x} is listed twice")));
                    }
                    seen.push(x);
                }
                FactorLevels::Numeric(v)
            }
            None => {
                let labels: Vec<String> = parts.iter().map(|s| s.to_string()).collect();
                for (i, l) in labels.iter().enumerate() {
                    if labels[..i].contains(l) {
                        return Err(bad(&format!("level `{l}` is listed twice")));
                    }
                }
                FactorLevels::Labels(labels)
            }
        };
        Ok(FactorSpec {
            name: name.to_string(),
            levels,
        })
    }

    /// Parses a comma-separated list, e.g. `"depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20"` or
    /// `"A,B,C"`; names must be unique.
    ///
    /// ```
    /// use millcomp_doe::{FactorLevels, FactorSpec};
    /// let f = FactorSpec::parse_list("depth_um=100:200, material=S7:1018:6061, C").unwrap();
    /// assert_eq!(f.len(), 3);
    /// assert_eq!(f[0].levels, FactorLevels::Numeric(vec![100.0, 200.0]));
    /// assert_eq!(f[1].n_levels(), 3);
    /// assert_eq!(f[2].levels, FactorLevels::Coded);
    /// ```
    ///
    /// # Errors
    /// [`DoeError::NoFactors`] for an empty list, [`DoeError::DuplicateFactor`] for a repeated name, and
    /// those of [`FactorSpec::parse`] for a bad entry.
    pub fn parse_list(s: &str) -> Result<Vec<FactorSpec>> {
        let entries: Vec<&str> = s
            .split(',')
            .map(str::trim)
            .filter(|e| !e.is_empty())
            .collect();
        if entries.is_empty() {
            return Err(DoeError::NoFactors);
        }
        let mut out: Vec<FactorSpec> = Vec::with_capacity(entries.len());
        for e in entries {
            let f = FactorSpec::parse(e)?;
            if out.iter().any(|g| g.name == f.name) {
                return Err(DoeError::DuplicateFactor { name: f.name });
            }
            out.push(f);
        }
        Ok(out)
    }

    /// Number of levels (2 for a coded factor).
    pub fn n_levels(&self) -> usize {
        match &self.levels {
            FactorLevels::Coded => 2,
            FactorLevels::Numeric(v) => v.len(),
            FactorLevels::Labels(v) => v.len(),
        }
    }

    /// `numeric`, `coded` or `label`.
    pub fn kind(&self) -> &'static str {
        match self.levels {
            FactorLevels::Coded => "coded",
            FactorLevels::Numeric(_) => "numeric",
            FactorLevels::Labels(_) => "label",
        }
    }

    /// `true` for coded and numeric factors (those with a continuous scale).
    pub fn is_continuous(&self) -> bool {
        !matches!(self.levels, FactorLevels::Labels(_))
    }

    /// (low, high) in actual units for continuous factors: min and max of the levels (−1, +1 when coded).
    pub fn range(&self) -> Option<(f64, f64)> {
        match &self.levels {
            FactorLevels::Coded => Some((-1.0, 1.0)),
            FactorLevels::Numeric(v) => {
                let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
                let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                Some((lo, hi))
            }
            FactorLevels::Labels(_) => None,
        }
    }

    /// The coded values of the listed levels, in the order written: numeric levels are mapped linearly so that
    /// min → −1 and max → +1; labels and coded factors are evenly spaced on [−1, 1].
    pub fn coded_levels(&self) -> Vec<f64> {
        match &self.levels {
            FactorLevels::Numeric(v) => {
                let (lo, hi) = self.range().unwrap_or((-1.0, 1.0));
                v.iter().map(|&x| code_value(x, lo, hi)).collect()
            }
            _ => {
                let n = self.n_levels();
                (0..n)
                    .map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64)
                    .collect()
            }
        }
    }

    /// The actual level for a coded value. Numeric: `mid + coded·half` (snapped to a listed level when within
    /// 1e-9 of the range); labels: the nearest evenly spaced level; coded: the coded value itself.
    pub fn actual(&self, coded: f64) -> Level {
        match &self.levels {
            FactorLevels::Coded => Level::Num(coded),
            FactorLevels::Numeric(v) => {
                let (lo, hi) = self.range().unwrap_or((-1.0, 1.0));
                let x = 0.5 * (lo + hi) + coded * 0.5 * (hi - lo);
                let tol = 1e-9 * (hi - lo).abs().max(f64::MIN_POSITIVE);
                let snapped = v.iter().copied().find(|&l| (l - x).abs() <= tol);
                Level::Num(snapped.unwrap_or(x))
            }
            FactorLevels::Labels(v) => {
                let n = v.len();
                let idx = ((coded + 1.0) * (n - 1) as f64 / 2.0)
                    .round()
                    .clamp(0.0, (n - 1) as f64) as usize;
                Level::Label(v[idx].clone())
            }
        }
    }

    /// Levels as [`Level`] values, in the order written.
    pub fn level_values(&self) -> Vec<Level> {
        match &self.levels {
            FactorLevels::Coded => vec![Level::Num(-1.0), Level::Num(1.0)],
            FactorLevels::Numeric(v) => v.iter().map(|&x| Level::Num(x)).collect(),
            FactorLevels::Labels(v) => v.iter().map(|s| Level::Label(s.clone())).collect(),
        }
    }
}

/// Codes `x` linearly so that `lo` → −1 and `hi` → +1.
pub(crate) fn code_value(x: f64, lo: f64, hi: f64) -> f64 {
    if x == lo {
        -1.0
    } else if x == hi {
        1.0
    } else {
        (x - 0.5 * (lo + hi)) / (0.5 * (hi - lo))
    }
}

/// A factor as reported in a design's JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FactorInfo {
    /// Factor name (column name of the actual level; the coded level is in `<name>_coded`).
    pub name: String,
    /// Letter used in generators and defining relations (`A`, `B`, …; `I` skipped).
    pub letter: String,
    /// `numeric`, `coded` or `label`.
    pub kind: &'static str,
    /// Levels as specified (for continuous designs these are the low/high that map to coded −1/+1).
    pub levels: Vec<Level>,
    /// Lowest numeric level (null for labels).
    pub low: Option<f64>,
    /// Highest numeric level (null for labels).
    pub high: Option<f64>,
}

impl FactorInfo {
    pub(crate) fn from_spec(i: usize, f: &FactorSpec) -> Self {
        let (low, high) = match f.range() {
            Some((l, h)) => (Some(l), Some(h)),
            None => (None, None),
        };
        FactorInfo {
            name: f.name.clone(),
            letter: factor_letter(i),
            kind: f.kind(),
            levels: f.level_values(),
            low,
            high,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_numeric_label_and_coded() {
        let f = FactorSpec::parse_list("depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20")
            .unwrap();
        assert_eq!(f.len(), 3);
        assert_eq!(f[1].range(), Some((10000.0, 20000.0)));
        let m = FactorSpec::parse("material=S7:1018:6061").unwrap();
        assert_eq!(
            m.levels,
            FactorLevels::Labels(vec!["S7".into(), "1018".into(), "6061".into()])
        );
        assert_eq!(m.actual(0.0), Level::Label("1018".into()));
        let a = FactorSpec::parse("A").unwrap();
        assert_eq!(a.levels, FactorLevels::Coded);
    }

    #[test]
    fn numeric_actual_snaps_to_listed_levels() {
        let f = FactorSpec::parse("d=100:120:200").unwrap();
        let c = f.coded_levels();
        assert_eq!(c[0], -1.0);
        assert_eq!(c[2], 1.0);
        assert_eq!(f.actual(c[1]), Level::Num(120.0));
        assert_eq!(f.actual(0.0), Level::Num(150.0));
    }

    #[test]
    fn rejects_bad_specs() {
        assert!(matches!(
            FactorSpec::parse("d=100"),
            Err(DoeError::SingleLevelFactor { .. })
        ));
        assert!(
            matches!(FactorSpec::parse_list("a,b,a"), Err(DoeError::DuplicateFactor { name }) if name == "a")
        );
        assert!(matches!(
            FactorSpec::parse("1x=1:2"),
            Err(DoeError::InvalidFactorSpec { .. })
        ));
        assert!(matches!(
            FactorSpec::parse("x=1:1"),
            Err(DoeError::SingleLevelFactor { .. })
        ));
        assert!(matches!(
            FactorSpec::parse("x=1:2:1"),
            Err(DoeError::InvalidFactorSpec { .. })
        ));
        assert!(matches!(
            FactorSpec::parse_list(" , "),
            Err(DoeError::NoFactors)
        ));
        assert_eq!(factor_letter(8), "J");
    }
}
