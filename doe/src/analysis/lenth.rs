//! Lenth's pseudo standard error for unreplicated (saturated) two-level designs.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// Lenth's method applied to one term.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LenthTerm {
    /// Term name.
    pub term: String,
    /// Effect estimate.
    pub effect: f64,
    /// Effect / PSE.
    pub t_pse: f64,
    /// |effect| > ME (individually active at 5 %).
    pub exceeds_me: bool,
    /// |effect| > SME (active allowing for the m simultaneous tests).
    pub exceeds_sme: bool,
}

/// Lenth (1989), "Quick and easy analysis of unreplicated factorials", Technometrics 31:469–473:
/// s0 = 1.5·median|c_j|, PSE = 1.5·median{|c_j| : |c_j| < 2.5·s0}, d = m/3 degrees of freedom,
/// ME = t_{0.975; d}·PSE, SME = t_{γ; d}·PSE with γ = (1 + 0.95^{1/m})/2.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lenth {
    /// Initial scale s0.
    pub s0: f64,
    /// Pseudo standard error.
    pub pse: f64,
    /// Degrees of freedom d = m/3.
    pub df: f64,
    /// Margin of error (individual 95 %).
    pub me: f64,
    /// Simultaneous margin of error (95 % over the m effects).
    pub sme: f64,
    /// Per-term results (in model order).
    pub terms: Vec<LenthTerm>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Lenth's PSE, ME and SME for named effects (at least two effects; `None` otherwise or if all effects are 0).
///
/// # Examples
/// ```
/// use millcomp_doe::lenth;
/// // Montgomery, Design and Analysis of Experiments, 8th ed., Example 6.2 (pilot-plant filtration rate,
/// // unreplicated 2^4): the 15 effect estimates of Table 6.11.
/// let e = [21.625, 3.125, 9.875, 14.625, 0.125, -18.125, 16.625, 2.375, -0.375, -1.125,
///          1.875, 4.125, -1.625, -2.625, 1.375];
/// let names: Vec<String> = (0..15).map(|i| format!("e{i}")).collect();
/// let l = lenth(&names, &e).unwrap();
/// assert!((l.pse - 2.625).abs() < 1e-12);
/// // scipy 1.17.1: t.ppf(0.975, 5)·PSE and t.ppf((1 + 0.95^(1/15))/2, 5)·PSE (tests/golden/lenth.json)
/// assert!((l.me - 6.747777318545326).abs() < 1e-8 * 6.75);
/// assert!((l.sme - 13.698959562802404).abs() < 1e-8 * 13.7);
/// // A and A:C exceed the simultaneous margin
/// assert!(l.terms[0].exceeds_sme && l.terms[5].exceeds_sme && !l.terms[1].exceeds_me);
/// assert!(lenth(&names[..1], &e[..1]).is_none());
/// ```
///
/// # Errors
/// None: the result is `None` (not an error) for fewer than two effects, names and effects of different
/// lengths, or effects that are all 0 (no scale to estimate).
pub fn lenth(names: &[String], effects: &[f64]) -> Option<Lenth> {
    let m = effects.len();
    if m < 2 || names.len() != m {
        return None;
    }
    let mut abs: Vec<f64> = effects.iter().map(|e| e.abs()).collect();
    let s0 = 1.5 * median(&mut abs.clone());
    let mut trimmed: Vec<f64> = abs.drain(..).filter(|a| *a < 2.5 * s0).collect();
    if trimmed.is_empty() || s0 <= 0.0 {
        return None;
    }
    let pse = 1.5 * median(&mut trimmed);
    if pse.is_nan() || pse <= 0.0 {
        return None;
    }
    let d = m as f64 / 3.0;
    let t = StudentsT::new(0.0, 1.0, d).ok()?;
    let me = t.inverse_cdf(0.975) * pse;
    let gamma = (1.0 + 0.95f64.powf(1.0 / m as f64)) / 2.0;
    let sme = t.inverse_cdf(gamma) * pse;
    let terms = names
        .iter()
        .zip(effects)
        .map(|(n, &e)| LenthTerm {
            term: n.clone(),
            effect: e,
            t_pse: e / pse,
            exceeds_me: e.abs() > me,
            exceeds_sme: e.abs() > sme,
        })
        .collect();
    Some(Lenth {
        s0,
        pse,
        df: d,
        me,
        sme,
        terms,
    })
}
