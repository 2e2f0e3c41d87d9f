//! Full factorials (two-level and mixed-level) and regular two-level fractions.

use super::fractional::{
    self, CatalogueChoice, Generator, Word, alias_structure, choose_block_generators,
    defining_subgroup, letters, parse_generators, resolution, resolution_roman, term_name,
    word_length_pattern,
};
use super::{BasePoints, DesignRequest, require_two_levels};
use crate::error::{DoeError, Result};
use crate::factor::{FactorSpec, factor_letter};

/// Two-level points in Yates standard order (first factor alternates fastest) for the base factors, with the
/// generated columns appended; returns rows of ±1 for all k factors.
pub(crate) fn two_level_points(k: usize, base: &[usize], gens: &[Generator]) -> Vec<Vec<f64>> {
    let n = 1usize << base.len();
    (0..n)
        .map(|r| {
            let mut row = vec![0.0; k];
            for (j, &f) in base.iter().enumerate() {
                row[f] = if r >> j & 1 == 1 { 1.0 } else { -1.0 };
            }
            for g in gens {
                let mut v = if g.word.negative { -1.0 } else { 1.0 };
                for (i, x) in row.iter().enumerate().take(k) {
                    if g.word.mask >> i & 1 == 1 {
                        v *= x;
                    }
                }
                row[g.factor] = v;
            }
            row
        })
        .collect()
}

/// A regular two-level design (full when `gens` is empty) with its metadata and optional blocking.
pub(crate) fn regular_two_level(
    factors: &[FactorSpec],
    gens: Vec<Generator>,
    blocks: usize,
) -> Result<BasePoints> {
    let k = factors.len();
    if k > 63 {
        return Err(DoeError::Unsupported {
            what: format!("{k} factors in a two-level factorial (at most 63)"),
        });
    }
    let generated: u64 = gens.iter().fold(0, |m, g| m | 1 << g.factor);
    let base: Vec<usize> = (0..k).filter(|&i| generated >> i & 1 == 0).collect();
    if base.len() > 20 {
        return Err(DoeError::Unsupported {
            what: format!(
                "a two-level design with 2^{} runs (at most 2^20)",
                base.len()
            ),
        });
    }
    let coded = two_level_points(k, &base, &gens);
    let names: Vec<String> = factors.iter().map(|f| f.name.clone()).collect();
    let words = defining_subgroup(&gens);
    let mut bp = BasePoints::unblocked(coded);
    if !gens.is_empty() {
        bp.resolution = resolution(&words);
        bp.generators = gens.iter().map(|g| g.letters(k)).collect();
        bp.defining_relation = words
            .iter()
            .filter(|w| w.mask != 0)
            .map(|w| {
                format!(
                    "I={}{}",
                    if w.negative { "-" } else { "" },
                    letters(w.mask, k)
                )
            })
            .collect();
        bp.word_length_pattern = word_length_pattern(&words, k);
        bp.alias_structure = alias_structure(&words, &names);
    }
    if blocks > 1 {
        if !blocks.is_power_of_two() {
            return Err(DoeError::InvalidParameter {
                name: "blocks",
                value: blocks.to_string(),
                allowed: "a power of two (2, 4, 8, …) for a two-level factorial".into(),
            });
        }
        let b = blocks.trailing_zeros() as usize;
        if b >= base.len() {
            return Err(DoeError::InvalidParameter {
                name: "blocks",
                value: blocks.to_string(),
                allowed: format!("fewer than the {} runs of the design", 1usize << base.len()),
            });
        }
        // Block generators as words over the k factors (lowest-order representative of each alias set).
        let bg = choose_block_generators(k, base.len(), &gens, b)?;
        for (r, row) in bp.coded.iter().enumerate() {
            let mut blk = 0usize;
            for (j, &w) in bg.iter().enumerate() {
                let v: f64 = (0..k)
                    .filter(|&i| w >> i & 1 == 1)
                    .map(|i| row[i])
                    .product();
                if v > 0.0 {
                    blk |= 1 << j;
                }
            }
            bp.block[r] = blk + 1;
        }
        bp.n_blocks = blocks;
        bp.block_generators = bg.iter().map(|&w| letters(w, k)).collect();
        // All 2^b − 1 confounded alias sets, by their lowest-order member.
        let mut conf: Vec<(u32, u64)> = Vec::new();
        for s in 1..(1usize << b) {
            let mut c = 0u64;
            for (j, &w) in bg.iter().enumerate() {
                if s >> j & 1 == 1 {
                    c ^= w;
                }
            }
            let rep = words
                .iter()
                .map(|w: &Word| c ^ w.mask)
                .min_by_key(|m| (m.count_ones(), *m))
                .unwrap_or(c);
            conf.push((rep.count_ones(), rep));
        }
        conf.sort();
        bp.confounded_with_blocks = conf.iter().map(|&(_, m)| term_name(m, &names)).collect();
        if conf.iter().any(|&(o, _)| o == 2) {
            bp.notes.push(format!(
                "{blocks} blocks confound two-factor interaction(s) {} with blocks",
                conf.iter()
                    .filter(|&&(o, _)| o == 2)
                    .map(|&(_, m)| term_name(m, &names))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
    }
    Ok(bp)
}

/// Full factorial: two-level (with blocking) or mixed-level (all combinations of the listed levels).
pub(crate) fn full(req: &DesignRequest) -> Result<BasePoints> {
    let factors = &req.factors;
    if factors.iter().all(|f| f.n_levels() == 2) {
        return regular_two_level(factors, Vec::new(), req.blocks);
    }
    let levels: Vec<Vec<f64>> = factors.iter().map(|f| f.coded_levels()).collect();
    let total: f64 = levels.iter().map(|l| l.len() as f64).product();
    if total > 1e6 {
        return Err(DoeError::Unsupported {
            what: format!("a full factorial of {total} runs (at most 1e6)"),
        });
    }
    let n = total as usize;
    let mut coded = Vec::with_capacity(n);
    for r in 0..n {
        let mut rem = r;
        let row: Vec<f64> = levels
            .iter()
            .map(|l| {
                let v = l[rem % l.len()];
                rem /= l.len();
                v
            })
            .collect();
        coded.push(row);
    }
    let bp = BasePoints::unblocked(coded);
    if req.blocks > 1 {
        return Err(DoeError::Unsupported {
            what: format!(
                "{} blocks in a mixed-level full factorial (blocking by confounding needs two-level factors; use --replicates)",
                req.blocks
            ),
        });
    }
    Ok(bp)
}

/// Regular fraction from generators, a resolution or a run count.
pub(crate) fn fractional(req: &DesignRequest) -> Result<BasePoints> {
    let factors = &req.factors;
    require_two_levels(factors, "fractional", true)?;
    let k = factors.len();
    let mut notes = Vec::new();
    let gens = match (&req.generators, req.resolution, req.runs) {
        (Some(g), _, _) => {
            let gens = parse_generators(g, factors)?;
            if let Some(r) = req.resolution {
                let words = defining_subgroup(&gens);
                let got = resolution(&words).unwrap_or(u32::MAX);
                if got < r {
                    return Err(DoeError::InvalidGenerator {
                        generator: g.clone(),
                        reason: format!(
                            "these generators give resolution {} but {} was requested",
                            resolution_roman(got),
                            resolution_roman(r)
                        ),
                    });
                }
            }
            gens
        }
        (None, res, runs) => {
            let choice = match (res, runs) {
                (_, Some(n)) => fractional::by_runs(k, n)?,
                (Some(r), None) => fractional::by_resolution(k, r)?,
                (None, None) => {
                    return Err(DoeError::InvalidParameter {
                        name: "resolution",
                        value: "none".into(),
                        allowed: "a fractional design needs --resolution, --generators or --runs"
                            .into(),
                    });
                }
            };
            match choice {
                CatalogueChoice::Full => {
                    notes.push(format!(
                        "the full factorial (2^{k} runs) is the smallest two-level design with the requested properties"
                    ));
                    Vec::new()
                }
                CatalogueChoice::Fraction(e) => {
                    let letters_only: Vec<FactorSpec> = (0..k)
                        .map(|i| FactorSpec::coded(&factor_letter(i)))
                        .collect();
                    let g = parse_generators(&e.generators, &letters_only)?;
                    if let (Some(r), Some(_)) = (res, runs)
                        && e.resolution < r
                    {
                        return Err(DoeError::NoCatalogueDesign {
                            factors: k,
                            request: format!(
                                "in {} runs at resolution {}",
                                e.runs,
                                resolution_roman(r)
                            ),
                            reason: format!(
                                "the best {}-run design has resolution {}; use more runs",
                                e.runs,
                                resolution_roman(e.resolution)
                            ),
                        });
                    }
                    notes.push(format!(
                        "minimum-aberration 2^({k}-{}) design from the built-in catalogue (doe/data/fractional_catalogue.csv)",
                        k - (e.runs.trailing_zeros() as usize)
                    ));
                    g.into_iter()
                        .map(|g| Generator {
                            text: g.letters(k),
                            ..g
                        })
                        .collect()
                }
            }
        }
    };
    let mut bp = regular_two_level(factors, gens, req.blocks)?;
    bp.notes.splice(0..0, notes);
    if let Some(r) = bp.resolution
        && r == 3
    {
        bp.notes
            .push("resolution III: main effects are aliased with two-factor interactions".into());
    }
    Ok(bp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::DesignKind;

    #[test]
    fn full_two_level_yates_order() {
        let f = FactorSpec::parse_list("A,B,C").unwrap();
        let bp = regular_two_level(&f, vec![], 1).unwrap();
        assert_eq!(bp.coded[0], vec![-1.0, -1.0, -1.0]);
        assert_eq!(bp.coded[1], vec![1.0, -1.0, -1.0]);
        assert_eq!(bp.coded[7], vec![1.0, 1.0, 1.0]);
    }

    #[test]
    fn blocked_2_3_splits_on_abc() {
        let f = FactorSpec::parse_list("A,B,C").unwrap();
        let bp = regular_two_level(&f, vec![], 2).unwrap();
        assert_eq!(bp.block_generators, vec!["ABC"]);
        assert_eq!(bp.confounded_with_blocks, vec!["A:B:C"]);
        for (row, &b) in bp.coded.iter().zip(&bp.block) {
            let abc: f64 = row.iter().product();
            assert_eq!(b, if abc > 0.0 { 2 } else { 1 });
        }
    }

    #[test]
    fn mixed_level_full_factorial() {
        let mut req = DesignRequest::new(
            DesignKind::Full,
            FactorSpec::parse_list("m=S7:1018:6061,d=1:2").unwrap(),
        );
        req.blocks = 1;
        let bp = full(&req).unwrap();
        assert_eq!(bp.coded.len(), 6);
        assert_eq!(bp.coded[1], vec![0.0, -1.0]);
    }
}
