//! Response-surface designs: central composite and Box–Behnken.

use super::factorial::regular_two_level;
use super::fractional::{self, CatalogueChoice, parse_generators};
use super::{BasePoints, CcdAlpha, CcdVariant, DesignRequest, require_two_levels};
use crate::error::{DoeError, Result};
use crate::factor::{FactorSpec, factor_letter};

/// Axial distance for the given rule (coded units of the factorial cube).
pub(crate) fn ccd_alpha(
    rule: CcdAlpha,
    k: usize,
    n_f: usize,
    n_center_f: usize,
    n_center_a: usize,
) -> f64 {
    let nf = n_f as f64;
    let na = (2 * k) as f64;
    match rule {
        CcdAlpha::Rotatable => nf.powf(0.25),
        CcdAlpha::Orthogonal => {
            let n = nf + na + (n_center_f + n_center_a) as f64;
            (((n * nf).sqrt() - nf) / 2.0).sqrt()
        }
        CcdAlpha::OrthogonalBlocking => {
            (k as f64 * (1.0 + n_center_a as f64 / na) / (1.0 + n_center_f as f64 / nf)).sqrt()
        }
        CcdAlpha::Value(v) => v,
    }
}

/// Central composite design: a two-level factorial portion (full for k ≤ 4, the minimum-aberration resolution V
/// fraction for k ≥ 5), 2k axial points and `centers` centre points per block.
pub(crate) fn ccd(
    req: &DesignRequest,
    variant: CcdVariant,
    alpha: CcdAlpha,
    centers: usize,
) -> Result<BasePoints> {
    let factors = &req.factors;
    require_two_levels(factors, "ccd", false)?;
    let k = factors.len();
    if k < 2 {
        return Err(DoeError::NotEnoughData {
            what: "central composite design factors",
            needed: 2,
            have: k,
        });
    }
    if req.blocks > 2 {
        return Err(DoeError::InvalidParameter {
            name: "blocks",
            value: req.blocks.to_string(),
            allowed: "1 or 2 for a central composite design (2 = factorial block + axial block)"
                .into(),
        });
    }
    if matches!(alpha, CcdAlpha::OrthogonalBlocking) && req.blocks != 2 {
        return Err(DoeError::InvalidParameter {
            name: "alpha",
            value: "orthogonal-blocking".into(),
            allowed: "only with --blocks 2 (factorial and axial blocks)".into(),
        });
    }
    let gens = if k <= 4 {
        Vec::new()
    } else {
        match fractional::by_resolution(k, 5)? {
            CatalogueChoice::Full => Vec::new(),
            CatalogueChoice::Fraction(e) => {
                let letters: Vec<FactorSpec> = (0..k)
                    .map(|i| FactorSpec::coded(&factor_letter(i)))
                    .collect();
                parse_generators(&e.generators, &letters)?
            }
        }
    };
    let fact = regular_two_level(factors, gens, 1)?;
    let n_f = fact.coded.len();
    let (c_f, c_a) = if req.blocks == 2 {
        (centers, centers)
    } else {
        (centers, 0)
    };
    let mut a = ccd_alpha(alpha, k, n_f, c_f, c_a);
    let mut notes = Vec::new();
    if variant == CcdVariant::FaceCentred {
        if !matches!(alpha, CcdAlpha::Rotatable) && (a - 1.0).abs() > 1e-12 {
            notes.push("face-centred CCD: alpha set to 1".to_string());
        }
        a = 1.0;
    }
    if !(a.is_finite() && a > 0.0) {
        return Err(DoeError::InvalidParameter {
            name: "alpha",
            value: a.to_string(),
            allowed: "a positive finite axial distance".into(),
        });
    }
    let scale = if variant == CcdVariant::Inscribed {
        1.0 / a
    } else {
        1.0
    };
    let axial_block = if req.blocks == 2 { 2 } else { 1 };
    let mut coded: Vec<Vec<f64>> = fact
        .coded
        .iter()
        .map(|r| r.iter().map(|v| v * scale).collect())
        .collect();
    let mut block = vec![1usize; n_f];
    for j in 0..k {
        for s in [-1.0, 1.0] {
            let mut p = vec![0.0; k];
            p[j] = s * a * scale;
            coded.push(p);
            block.push(axial_block);
        }
    }
    for b in 1..=req.blocks {
        for _ in 0..centers {
            coded.push(vec![0.0; k]);
            block.push(b);
        }
    }
    if variant == CcdVariant::Circumscribed && a > 1.0 {
        notes.push(format!(
            "axial points lie at ±{a:.4} coded units, outside the given low/high: check they are feasible"
        ));
    }
    Ok(BasePoints {
        coded,
        block,
        n_blocks: req.blocks,
        centers_included: true,
        resolution: fact.resolution,
        generators: fact.generators,
        defining_relation: fact.defining_relation,
        word_length_pattern: fact.word_length_pattern,
        alias_structure: fact.alias_structure,
        alpha: Some(a),
        variant: Some(variant.as_str()),
        notes,
        ..Default::default()
    })
}

/// Factor groups of the Box–Behnken designs (Box & Behnken 1960, Technometrics 2:455–475, Table 1; the same
/// designs as NIST/SEMATECH e-Handbook §5.3.3.6.2): each group is run as a 2^|g| factorial with the other
/// factors at their centre. 0-based factor indices.
fn bbd_groups(k: usize) -> Vec<Vec<usize>> {
    match k {
        6 => vec![
            vec![0, 1, 3],
            vec![1, 2, 4],
            vec![2, 3, 5],
            vec![0, 3, 4],
            vec![1, 4, 5],
            vec![0, 2, 5],
        ],
        7 => vec![
            vec![3, 4, 5],
            vec![0, 5, 6],
            vec![1, 4, 6],
            vec![0, 1, 3],
            vec![2, 3, 6],
            vec![0, 2, 4],
            vec![1, 2, 5],
        ],
        // k = 3, 4, 5 (Box & Behnken's tables) and k > 7 (all pairs, as pyDOE3's bbdesign).
        _ => {
            let mut g = Vec::new();
            for i in 0..k {
                for j in i + 1..k {
                    g.push(vec![i, j]);
                }
            }
            g
        }
    }
}

/// Box–Behnken design (centre points are added by the caller).
pub(crate) fn box_behnken(req: &DesignRequest) -> Result<BasePoints> {
    let factors = &req.factors;
    require_two_levels(factors, "box-behnken", false)?;
    let k = factors.len();
    if k < 3 {
        return Err(DoeError::NotEnoughData {
            what: "Box–Behnken design factors",
            needed: 3,
            have: k,
        });
    }
    let mut coded = Vec::new();
    for g in bbd_groups(k) {
        for r in 0..(1usize << g.len()) {
            let mut p = vec![0.0; k];
            for (j, &f) in g.iter().enumerate() {
                p[f] = if r >> j & 1 == 1 { 1.0 } else { -1.0 };
            }
            coded.push(p);
        }
    }
    let mut bp = BasePoints::unblocked(coded);
    if k > 7 {
        bp.notes.push(format!("Box–Behnken for {k} factors built from all factor pairs (Box & Behnken tabulate k ≤ 7 here)"));
    }
    Ok(bp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotatable_alpha_values() {
        // Montgomery §11.4.2: α = n_F^{1/4}: 1.414 for k = 2, 1.682 for k = 3, 2 for k = 4.
        assert!((ccd_alpha(CcdAlpha::Rotatable, 2, 4, 5, 0) - 2f64.sqrt()).abs() < 1e-12);
        assert!((ccd_alpha(CcdAlpha::Rotatable, 3, 8, 6, 0) - 1.681_792_830_507_429).abs() < 1e-12);
        assert!((ccd_alpha(CcdAlpha::Rotatable, 4, 16, 7, 0) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn bbd_k7_pairs_once() {
        let g = bbd_groups(7);
        for i in 0..7 {
            for j in i + 1..7 {
                let c = g
                    .iter()
                    .filter(|t| t.contains(&i) && t.contains(&j))
                    .count();
                assert_eq!(c, 1, "pair ({i},{j})");
            }
        }
    }
}
