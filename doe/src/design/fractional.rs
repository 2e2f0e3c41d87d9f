//! Regular two-level fractional factorials 2^(k−p): generators, defining relation, resolution, word-length
//! pattern, alias structure, block confounding, and the minimum-aberration catalogue.
//!
//! Words are bit masks over the k factors (bit i = factor i). A generator `D = ±ABC` contributes the defining
//! word `±ABCD`; the defining contrast subgroup is all products (XORs) of generator words.

use serde::Serialize;

use crate::error::{DoeError, Result};
use crate::factor::{FactorSpec, factor_letter};

/// The minimum-aberration catalogue (CSV: `k,runs,generators,resolution,wlp,source`), see the file's header.
const CATALOGUE: &str = include_str!("../../data/fractional_catalogue.csv");

/// A signed word: bit mask over factors and sign (+1 / −1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Word {
    pub mask: u64,
    pub negative: bool,
}

impl Word {
    pub fn mul(self, o: Word) -> Word {
        Word {
            mask: self.mask ^ o.mask,
            negative: self.negative ^ o.negative,
        }
    }
    pub fn len(self) -> u32 {
        self.mask.count_ones()
    }
}

/// Letters of a mask (`ABD`).
pub(crate) fn letters(mask: u64, k: usize) -> String {
    (0..k)
        .filter(|i| mask >> i & 1 == 1)
        .map(factor_letter)
        .collect::<Vec<_>>()
        .join("")
}

/// Names of a mask joined with `:` (`depth_um:speed_rpm`).
pub(crate) fn term_name(mask: u64, names: &[String]) -> String {
    (0..names.len())
        .filter(|i| mask >> i & 1 == 1)
        .map(|i| names[i].as_str())
        .collect::<Vec<_>>()
        .join(":")
}

/// One generated factor: `factor = sign · word(base factors)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Generator {
    /// Index of the generated factor.
    pub factor: usize,
    /// Product of base factors (mask) and sign.
    pub word: Word,
    /// As written (for messages).
    pub text: String,
}

impl Generator {
    /// The defining word `I = ±(word · factor)`.
    pub fn defining_word(&self) -> Word {
        Word {
            mask: self.word.mask | (1 << self.factor),
            negative: self.word.negative,
        }
    }
    /// `D=ABC` / `D=-ABC` in letters.
    pub fn letters(&self, k: usize) -> String {
        format!(
            "{}={}{}",
            factor_letter(self.factor),
            if self.word.negative { "-" } else { "" },
            letters(self.word.mask, k)
        )
    }
}

/// Resolves one factor reference (a letter or a full name) to its index.
fn resolve_factor(token: &str, factors: &[FactorSpec], generator: &str) -> Result<usize> {
    if let Some(i) = factors.iter().position(|f| f.name == token) {
        return Ok(i);
    }
    if let Some(i) = (0..factors.len()).find(|&i| factor_letter(i) == token) {
        return Ok(i);
    }
    Err(DoeError::UnknownFactor {
        name: token.to_string(),
        context: "generators",
        available: available(factors),
    })
    .map_err(|e| match e {
        DoeError::UnknownFactor {
            name, available, ..
        } => DoeError::InvalidGenerator {
            generator: generator.to_string(),
            reason: format!("`{name}` is neither a factor name nor a factor letter ({available})"),
        },
        other => other,
    })
}

fn available(factors: &[FactorSpec]) -> String {
    factors
        .iter()
        .enumerate()
        .map(|(i, f)| format!("{}={}", factor_letter(i), f.name))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Parses a generator word: `ABC`, `-ABC`, `depth_um*speed_rpm`, `A*B*C`.
fn parse_word(rhs: &str, factors: &[FactorSpec], generator: &str) -> Result<Word> {
    let mut s = rhs.trim();
    let mut negative = false;
    if let Some(r) = s.strip_prefix('-') {
        negative = true;
        s = r.trim();
    } else if let Some(r) = s.strip_prefix('+') {
        s = r.trim();
    }
    if s.is_empty() {
        return Err(DoeError::InvalidGenerator {
            generator: generator.to_string(),
            reason: "empty word".into(),
        });
    }
    let tokens: Vec<String> = if s.contains('*') || s.contains(':') {
        s.split(['*', ':']).map(|t| t.trim().to_string()).collect()
    } else if factors.iter().any(|f| f.name == s) {
        vec![s.to_string()]
    } else {
        // Concatenated letters; multi-character letters (F26…) are not supported in this form.
        s.chars().map(|c| c.to_string()).collect()
    };
    let mut mask = 0u64;
    for t in tokens {
        let i = resolve_factor(&t, factors, generator)?;
        if mask >> i & 1 == 1 {
            return Err(DoeError::InvalidGenerator {
                generator: generator.to_string(),
                reason: format!("factor `{t}` appears twice in the word"),
            });
        }
        mask |= 1 << i;
    }
    Ok(Word { mask, negative })
}

/// Parses `"D=AB,E=AC"` (also `;` or space separated, `D = -ABC`, names with `*`).
pub(crate) fn parse_generators(s: &str, factors: &[FactorSpec]) -> Result<Vec<Generator>> {
    let k = factors.len();
    if k > 63 {
        return Err(DoeError::Unsupported {
            what: format!("{k} factors in a fractional factorial (at most 63)"),
        });
    }
    let items: Vec<String> = {
        // Split on commas/semicolons; also allow whitespace-separated `D=AB E=AC`.
        let mut v = Vec::new();
        for chunk in s.split([',', ';']) {
            let chunk = chunk.trim();
            if chunk.is_empty() {
                continue;
            }
            // Whitespace separation only when every piece contains '=' (so `D = ABC` still works).
            let pieces: Vec<&str> = chunk.split_whitespace().collect();
            if pieces.len() > 1
                && pieces
                    .iter()
                    .all(|p| p.contains('=') && !p.ends_with('=') && !p.starts_with('='))
            {
                v.extend(pieces.iter().map(|p| p.to_string()));
            } else {
                v.push(chunk.to_string());
            }
        }
        v
    };
    if items.is_empty() {
        return Err(DoeError::InvalidGenerator {
            generator: s.to_string(),
            reason: "no generators given".into(),
        });
    }
    let mut gens: Vec<Generator> = Vec::new();
    for it in &items {
        let Some((lhs, rhs)) = it.split_once('=') else {
            return Err(DoeError::InvalidGenerator {
                generator: it.clone(),
                reason: "expected `factor=word`, e.g. `D=ABC`".into(),
            });
        };
        let factor = resolve_factor(lhs.trim(), factors, it)?;
        if let Some(prev) = gens.iter().find(|g| g.factor == factor) {
            return Err(DoeError::InvalidGenerator {
                generator: it.clone(),
                reason: format!(
                    "factor `{}` is already generated by `{}`",
                    factors[factor].name, prev.text
                ),
            });
        }
        let word = parse_word(rhs, factors, it)?;
        gens.push(Generator {
            factor,
            word,
            text: it.clone(),
        });
    }
    // Right-hand sides must use base (non-generated) factors only.
    let generated: u64 = gens.iter().fold(0, |m, g| m | 1 << g.factor);
    for g in &gens {
        if g.word.mask & generated != 0 {
            let bad = (0..k)
                .find(|&i| (g.word.mask & generated) >> i & 1 == 1)
                .unwrap_or(0);
            return Err(DoeError::InvalidGenerator {
                generator: g.text.clone(),
                reason: format!(
                    "the word uses `{}` ({}), which is itself generated; write words over the base factors only",
                    factor_letter(bad),
                    factors[bad].name
                ),
            });
        }
    }
    if gens.len() >= k {
        return Err(DoeError::InvalidGenerator {
            generator: s.to_string(),
            reason: format!(
                "{} generators for {k} factors leave no base factor",
                gens.len()
            ),
        });
    }
    check_generators(&gens, factors)?;
    Ok(gens)
}

/// Rejects generator sets that alias main effects with each other or with the mean.
pub(crate) fn check_generators(gens: &[Generator], factors: &[FactorSpec]) -> Result<()> {
    let k = factors.len();
    for (i, a) in gens.iter().enumerate() {
        if a.word.mask == 0 || a.word.len() == 1 {
            let with = if a.word.mask == 0 {
                "the mean".to_string()
            } else {
                factors[a.word.mask.trailing_zeros() as usize].name.clone()
            };
            return Err(DoeError::AliasedGenerators {
                factor: factors[a.factor].name.clone(),
                aliased_with: with,
                word: format!("I = {}", letters(a.defining_word().mask, k)),
            });
        }
        for b in &gens[..i] {
            if a.word.mask == b.word.mask {
                return Err(DoeError::DuplicateGenerator {
                    first: b.text.clone(),
                    second: a.text.clone(),
                    first_factor: factors[b.factor].name.clone(),
                    second_factor: factors[a.factor].name.clone(),
                });
            }
        }
    }
    for w in defining_subgroup(gens) {
        if w.mask != 0 && w.len() <= 2 {
            let idx: Vec<usize> = (0..k).filter(|&i| w.mask >> i & 1 == 1).collect();
            let (f, with) = if idx.len() == 1 {
                (factors[idx[0]].name.clone(), "the mean".to_string())
            } else {
                (factors[idx[1]].name.clone(), factors[idx[0]].name.clone())
            };
            return Err(DoeError::AliasedGenerators {
                factor: f,
                aliased_with: with,
                word: format!(
                    "I = {}{}",
                    if w.negative { "-" } else { "" },
                    letters(w.mask, k)
                ),
            });
        }
    }
    Ok(())
}

/// All 2^p words of the defining contrast subgroup (identity first).
pub(crate) fn defining_subgroup(gens: &[Generator]) -> Vec<Word> {
    let mut out = vec![Word {
        mask: 0,
        negative: false,
    }];
    for g in gens {
        let w = g.defining_word();
        let n = out.len();
        for j in 0..n {
            let x = out[j].mul(w);
            out.push(x);
        }
    }
    out
}

/// Resolution (shortest non-identity word); `None` for a full factorial.
pub(crate) fn resolution(words: &[Word]) -> Option<u32> {
    words.iter().filter(|w| w.mask != 0).map(|w| w.len()).min()
}

/// Word-length pattern (A3, A4, …, Ak).
pub(crate) fn word_length_pattern(words: &[Word], k: usize) -> Vec<usize> {
    let mut c = vec![0usize; k + 1];
    for w in words.iter().filter(|w| w.mask != 0) {
        c[w.len() as usize] += 1;
    }
    c.into_iter().skip(3).collect()
}

/// One entry of an alias structure: an effect and the effects it is aliased (or confounded) with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AliasEntry {
    /// Main effect or two-factor interaction, written with factor names and `:`.
    pub term: String,
    /// Effects of order ≤ 3 aliased with it; a leading `-` marks a negative alias (`A = -B:C`).
    pub aliases: Vec<String>,
}

/// Alias structure: for every main effect and two-factor interaction that is aliased with some effect of order
/// ≤ 3, the list of those aliases (order ≤ 3, sorted by order then factor order).
pub(crate) fn alias_structure(words: &[Word], names: &[String]) -> Vec<AliasEntry> {
    let k = names.len();
    let mut effects: Vec<u64> = (0..k).map(|i| 1u64 << i).collect();
    for i in 0..k {
        for j in i + 1..k {
            effects.push(1 << i | 1 << j);
        }
    }
    let mut out = Vec::new();
    for e in effects {
        let mut al: Vec<(u32, Vec<usize>, bool)> = words
            .iter()
            .filter(|w| w.mask != 0)
            .map(|w| (e ^ w.mask, w.negative))
            .filter(|(m, _)| m.count_ones() <= 3 && *m != 0)
            .map(|(m, neg)| {
                (
                    m.count_ones(),
                    (0..k).filter(|i| m >> i & 1 == 1).collect(),
                    neg,
                )
            })
            .collect();
        if al.is_empty() {
            continue;
        }
        al.sort();
        out.push(AliasEntry {
            term: term_name(e, names),
            aliases: al
                .into_iter()
                .map(|(_, idx, neg)| {
                    let n: Vec<&str> = idx.iter().map(|&i| names[i].as_str()).collect();
                    format!("{}{}", if neg { "-" } else { "" }, n.join(":"))
                })
                .collect(),
        });
    }
    out
}

/// Chooses `b` block generators (words over all k factors that are columns of the fraction) so that the
/// confounded effects have the highest possible order: among all sets of `b` independent columns, the one whose
/// 2^b − 1 confounded alias sets have the lexicographically smallest count of low-order effects (the minimum
/// effect order in each alias set counts). Main effects are never confounded with blocks.
///
/// Returns the block generator words (as their lowest-order representative over the k factors).
pub(crate) fn choose_block_generators(
    k: usize,
    base: usize,
    gens: &[Generator],
    b: usize,
) -> Result<Vec<u64>> {
    let words = defining_subgroup(gens);
    let ncol = 1usize << base;
    // Lowest-order member of the alias set of base column c (c ⊂ base factors): min over defining words of |c ⊕ w|.
    // Precomputed once for every column (the scores below only look it up).
    let reps: Vec<(u32, u64)> = (0..ncol as u64)
        .map(|c| {
            words
                .iter()
                .map(|w| c ^ w.mask)
                .map(|m| (m.count_ones(), m))
                .min()
                .unwrap_or((c.count_ones(), c))
        })
        .collect();
    let min_rep = |c: u64| -> (u32, u64) { reps[c as usize] };
    let mut cands: Vec<(u64, u32, u64)> = (1..ncol as u64)
        .map(|c| (c, min_rep(c).0, min_rep(c).1))
        .filter(|&(_, o, _)| o >= 2)
        .collect();
    if cands.len() < b {
        return Err(DoeError::Unsupported {
            what: format!(
                "{} blocks in a {}-run two-level design of {k} factors",
                1 << b,
                1 << base
            ),
        });
    }
    // Prefer high-order columns first so ties go to the highest-order interactions.
    cands.sort_by(|a, b| {
        b.1.cmp(&a.1)
            .then(b.0.count_ones().cmp(&a.0.count_ones()))
            .then(a.0.cmp(&b.0))
    });
    let score = |set: &[u64]| -> Option<Vec<usize>> {
        // Orders of the 2^b − 1 confounded columns; None when a main effect (or the mean) is confounded.
        let mut counts = vec![0usize; k + 1];
        for s in 1..(1usize << set.len()) {
            let mut c = 0u64;
            for (j, &g) in set.iter().enumerate() {
                if s >> j & 1 == 1 {
                    c ^= g;
                }
            }
            if c == 0 {
                return None;
            }
            let o = min_rep(c).0 as usize;
            if o < 2 {
                return None;
            }
            counts[o] += 1;
        }
        Some(counts)
    };
    let better = |a: &[usize], b: &[usize]| a < b;
    let n = cands.len();
    let total = binomial(n, b);
    let mut best: Option<(Vec<usize>, Vec<u64>)> = None;
    if total <= 400_000.0 {
        for_each_combination(n, b, &mut |idx: &[usize]| {
            let set: Vec<u64> = idx.iter().map(|&i| cands[i].0).collect();
            if let Some(sc) = score(&set)
                && best.as_ref().is_none_or(|(bs, _)| better(&sc, bs))
            {
                best = Some((sc, set));
            }
        });
    } else {
        // Greedy: add the column that keeps the best score.
        let mut set: Vec<u64> = Vec::new();
        for _ in 0..b {
            let mut pick: Option<(Vec<usize>, u64)> = None;
            for &(c, _, _) in &cands {
                if set.contains(&c) {
                    continue;
                }
                let mut trial = set.clone();
                trial.push(c);
                if let Some(sc) = score(&trial)
                    && pick.as_ref().is_none_or(|(bs, _)| better(&sc, bs))
                {
                    pick = Some((sc, c));
                }
            }
            match pick {
                Some((_, c)) => set.push(c),
                None => break,
            }
        }
        if set.len() == b {
            let sc = score(&set).unwrap_or_default();
            best = Some((sc, set));
        }
    }
    match best {
        Some((_, set)) => Ok(set.into_iter().map(|c| min_rep(c).1).collect()),
        None => Err(DoeError::Unsupported {
            what: format!(
                "{} blocks in a {}-run design of {k} factors without confounding a main effect with blocks",
                1 << b,
                1 << base
            ),
        }),
    }
}

/// Calls `f` with every `b`-subset of `0..n` (as increasing indices), in lexicographic order.
pub(crate) fn for_each_combination(n: usize, b: usize, f: &mut dyn FnMut(&[usize])) {
    fn rec(start: usize, n: usize, b: usize, cur: &mut Vec<usize>, f: &mut dyn FnMut(&[usize])) {
        if cur.len() == b {
            f(cur);
            return;
        }
        let need = b - cur.len();
        for i in start..=n.saturating_sub(need) {
            if n < need {
                return;
            }
            cur.push(i);
            rec(i + 1, n, b, cur, f);
            cur.pop();
        }
    }
    if b > n {
        return;
    }
    let mut cur = Vec::with_capacity(b);
    rec(0, n, b, &mut cur, f);
}

pub(crate) fn binomial(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    let mut r = 1.0;
    for i in 0..k {
        r = r * (n - i) as f64 / (i + 1) as f64;
    }
    r
}

/// One catalogue entry.
#[derive(Debug, Clone)]
pub(crate) struct CatalogueEntry {
    pub k: usize,
    pub runs: usize,
    pub generators: String,
    pub resolution: u32,
}

pub(crate) fn catalogue() -> Vec<CatalogueEntry> {
    CATALOGUE
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty() && !l.starts_with("k,"))
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Some(CatalogueEntry {
                k: f.first()?.trim().parse().ok()?,
                runs: f.get(1)?.trim().parse().ok()?,
                generators: f.get(2)?.trim().to_string(),
                resolution: f.get(3)?.trim().parse().ok()?,
            })
        })
        .collect()
}

/// Largest run size in the catalogue for each k is 128; a full factorial is returned when it is the smallest
/// design reaching the requested resolution (then `None` is returned for the generators).
pub(crate) enum CatalogueChoice {
    /// The full factorial (2^k runs) is the smallest design with the requested resolution.
    Full,
    /// A catalogued fraction.
    Fraction(CatalogueEntry),
}

/// Smallest-run minimum-aberration design for `k` factors with resolution ≥ `res`.
pub(crate) fn by_resolution(k: usize, res: u32) -> Result<CatalogueChoice> {
    if !(3..=8).contains(&res) {
        return Err(DoeError::InvalidParameter {
            name: "resolution",
            value: res.to_string(),
            allowed: "3 to 8 (III to VIII)".into(),
        });
    }
    let cat = catalogue();
    let best = cat
        .iter()
        .filter(|e| e.k == k && e.resolution >= res)
        .min_by_key(|e| e.runs);
    let full_runs = 1usize.checked_shl(k as u32).unwrap_or(usize::MAX);
    match best {
        Some(e) if e.runs < full_runs => Ok(CatalogueChoice::Fraction(e.clone())),
        _ if k <= 7 => Ok(CatalogueChoice::Full),
        _ => Err(DoeError::NoCatalogueDesign {
            factors: k,
            request: format!("at resolution {}", resolution_roman(res)),
            reason: format!(
                "the built-in minimum-aberration catalogue covers 8–128 runs ({}); give --generators instead",
                catalogue_coverage()
            ),
        }),
    }
}

/// Minimum-aberration design with a given number of runs.
pub(crate) fn by_runs(k: usize, runs: usize) -> Result<CatalogueChoice> {
    if !runs.is_power_of_two() || runs < 4 {
        return Err(DoeError::InvalidParameter {
            name: "runs",
            value: runs.to_string(),
            allowed: "a power of two for a regular fractional factorial".into(),
        });
    }
    if k < 64 && runs == 1 << k {
        return Ok(CatalogueChoice::Full);
    }
    if k < 64 && runs > 1 << k {
        return Err(DoeError::InvalidParameter {
            name: "runs",
            value: runs.to_string(),
            allowed: format!(
                "at most 2^{k} = {} for {k} factors (use --replicates for more)",
                1u64 << k
            ),
        });
    }
    if runs <= k {
        return Err(DoeError::InvalidParameter {
            name: "runs",
            value: runs.to_string(),
            allowed: format!("more than the number of factors ({k}) for a regular fraction"),
        });
    }
    match catalogue().into_iter().find(|e| e.k == k && e.runs == runs) {
        Some(e) => Ok(CatalogueChoice::Fraction(e)),
        None => Err(DoeError::NoCatalogueDesign {
            factors: k,
            request: format!("in {runs} runs"),
            reason: format!(
                "not in the built-in catalogue ({}); give --generators instead",
                catalogue_coverage()
            ),
        }),
    }
}

fn catalogue_coverage() -> &'static str {
    "8 runs: 4–7 factors, 16 runs: 5–15, 32 runs: 6–16, 64 runs: 7–11, 128 runs: 8–11"
}

/// Roman numeral for a resolution.
/// The Roman numeral of a design resolution, as designs are named (2^(k−p)_IV): 3 → `III` … 10 → `X`;
/// other values → `high`.
///
/// ```
/// use millcomp_doe::resolution_roman;
/// assert_eq!(resolution_roman(4), "IV");
/// assert_eq!(resolution_roman(9), "IX");
/// assert_eq!(resolution_roman(12), "high");
/// ```
pub fn resolution_roman(r: u32) -> &'static str {
    match r {
        3 => "III",
        4 => "IV",
        5 => "V",
        6 => "VI",
        7 => "VII",
        8 => "VIII",
        9 => "IX",
        10 => "X",
        _ => "high",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn letters_factors(k: usize) -> Vec<FactorSpec> {
        (0..k)
            .map(|i| FactorSpec::coded(&factor_letter(i)))
            .collect()
    }

    #[test]
    fn defining_relation_of_2_7_4() {
        let f = letters_factors(7);
        let g = parse_generators("D=AB,E=AC,F=BC,G=ABC", &f).unwrap();
        let w = defining_subgroup(&g);
        assert_eq!(w.len(), 16);
        assert_eq!(resolution(&w), Some(3));
        // Montgomery Table 8.14 / Box, Hunter & Hunter: 2^(7-4)_III has 7 words of length 3, 7 of 4, 1 of 7.
        assert_eq!(word_length_pattern(&w, 7), vec![7, 7, 0, 0, 1]);
    }

    #[test]
    fn rejects_aliased_and_duplicate_generators() {
        let f = letters_factors(5);
        assert!(matches!(
            parse_generators("D=AB,E=AB", &f),
            Err(DoeError::DuplicateGenerator { first_factor, second_factor, .. }) if first_factor == "D" && second_factor == "E"
        ));
        assert!(matches!(
            parse_generators("D=A", &f),
            Err(DoeError::AliasedGenerators { .. })
        ));
        // D·E = ABC·ABC… here D=ABC, E=-ABC: same column up to sign.
        assert!(matches!(
            parse_generators("D=ABC,E=-ABC", &f),
            Err(DoeError::DuplicateGenerator { .. })
        ));
        // I = ABD = ACE → BCDE fine; but D=AB, E=ABC gives DE = C → word CDE (length 3), fine.
        assert!(parse_generators("D=AB,E=ABC", &f).is_ok());
        assert!(matches!(
            parse_generators("D=AX", &f),
            Err(DoeError::InvalidGenerator { .. })
        ));
        assert!(matches!(
            parse_generators("D=AE,E=BC", &f),
            Err(DoeError::InvalidGenerator { .. })
        ));
    }

    #[test]
    fn names_with_stars_and_signs() {
        let f = FactorSpec::parse_list("x,y,z,w").unwrap();
        let g = parse_generators("w = -x*y*z", &f).unwrap();
        assert_eq!(g[0].letters(4), "D=-ABC");
        let w = defining_subgroup(&g);
        let al = alias_structure(&w, &f.iter().map(|f| f.name.clone()).collect::<Vec<_>>());
        assert_eq!(al[0].term, "x");
        assert_eq!(al[0].aliases, vec!["-y:z:w".to_string()]);
    }

    #[test]
    fn block_generator_of_2_3_in_two_blocks_is_abc() {
        let g = choose_block_generators(3, 3, &[], 1).unwrap();
        assert_eq!(g, vec![0b111]);
        let g4 = choose_block_generators(4, 4, &[], 2).unwrap();
        // Two 3FIs whose product is a 2FI (Montgomery Table 7.8: ABC, ACD → BD).
        assert_eq!(g4.len(), 2);
        assert!(g4.iter().all(|m| m.count_ones() == 3));
    }

    /// C(n, k) by the product formula: C(5, 0) = C(5, 5) = 1, C(5, 2) = 10, C(12, 4) = 495 (Pascal's
    /// triangle), and 0 for k > n (no way to choose more than there are). Kills `replace > with == in
    /// binomial` (which gives C(5, 5) = 0 and, for k > n + 1, underflows `n - i`).
    #[test]
    fn binomial_counts_the_ways_to_choose() {
        assert_eq!(binomial(5, 0), 1.0);
        assert_eq!(binomial(5, 5), 1.0);
        assert_eq!(binomial(5, 2), 10.0);
        assert_eq!(binomial(12, 4), 495.0);
        assert_eq!(binomial(3, 5), 0.0);
    }

    /// Every resolution a design can have, III to X, by its numeral; anything else is `high` (the
    /// doctest covers IV, IX and 12 only). Kills `delete match arm 6 in resolution_roman`.
    #[test]
    fn each_resolution_has_its_numeral() {
        let got: Vec<&str> = (2..=11).map(resolution_roman).collect();
        assert_eq!(
            got,
            [
                "high", "III", "IV", "V", "VI", "VII", "VIII", "IX", "X", "high"
            ]
        );
    }

    /// The catalogue holds proper fractions only: every entry has fewer runs than the full factorial
    /// 2^k of its factors (this is why `by_resolution`'s guard `e.runs < full_runs` cannot be false
    /// for an entry it sees: docs/reliability-mutants.md lists that mutant as equivalent).
    #[test]
    fn every_catalogue_entry_is_a_proper_fraction() {
        let cat = catalogue();
        assert_eq!(
            cat.len(),
            36,
            "entries read from data/fractional_catalogue.csv"
        );
        for e in &cat {
            assert!(e.runs < 1usize << e.k, "{e:?}");
        }
    }

    /// The coverage named in "no catalogue design" messages is the catalogue's: for each run size of 8
    /// or more, the smallest and largest number of factors it holds (from the file, not retyped).
    /// Kills `replace catalogue_coverage -> &'static str with ""`. The 4-run entry (3 factors, 2^(3−1))
    /// is not named by the message; every request it could serve is met before the message is reached.
    #[test]
    fn the_coverage_in_messages_is_the_catalogues() {
        let cat = catalogue();
        let mut sizes: Vec<usize> = cat.iter().map(|e| e.runs).filter(|&r| r >= 8).collect();
        sizes.sort_unstable();
        sizes.dedup();
        let expected = sizes
            .iter()
            .map(|&r| {
                let ks = cat.iter().filter(|e| e.runs == r).map(|e| e.k);
                let (lo, hi) = (ks.clone().min().unwrap(), ks.max().unwrap());
                if r == 8 {
                    format!("{r} runs: {lo}–{hi} factors")
                } else {
                    format!("{r} runs: {lo}–{hi}")
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        assert_eq!(catalogue_coverage(), expected);
        assert_eq!(
            expected,
            "8 runs: 4–7 factors, 16 runs: 5–15, 32 runs: 6–16, 64 runs: 7–11, 128 runs: 8–11"
        );
    }

    /// Generators over up to 63 factors are taken (a word is a 64-bit mask); 64 are refused naming
    /// the count. With 63 factors, `<63rd> = AB` generates factor index 62 from the word of A and B
    /// (mask 0b11). Kills `replace > with >= in parse_generators` (which refuses 63).
    #[test]
    fn generators_over_63_factors_are_taken_and_64_refused() {
        let last = factor_letter(62);
        let g = parse_generators(&format!("{last}=AB"), &letters_factors(63)).unwrap();
        assert_eq!(g.len(), 1);
        assert_eq!(
            (g[0].factor, g[0].word.mask, g[0].word.negative),
            (62, 0b11, false)
        );
        match parse_generators(&format!("{last}=AB"), &letters_factors(64)) {
            Err(DoeError::Unsupported { what }) => {
                assert_eq!(what, "64 factors in a fractional factorial (at most 63)")
            }
            other => panic!("{other:?}"),
        }
    }

    /// Every catalogue generator is written as `Generator::letters` writes it (the generated letter,
    /// `=`, the word's letters in order, no sign), so `factorial.rs`'s rewrite of a catalogue
    /// generator's text by `letters(k)` changes no entry's text: the mutant `factorial.rs:256:29:
    /// delete field text from struct Generator expression in fractional` (found by the draw of seed
    /// 53) is equivalent on this catalogue, and this test fails if an entry is ever written otherwise.
    #[test]
    fn catalogue_generators_are_written_as_letters_writes_them() {
        let cat = catalogue();
        assert!(cat.len() >= 30, "{}", cat.len());
        for e in &cat {
            let g = parse_generators(&e.generators, &letters_factors(e.k)).unwrap();
            for g in &g {
                assert_eq!(g.text, g.letters(e.k), "k = {}, {} runs", e.k, e.runs);
            }
        }
    }

    /// Every b-subset of 0..n once, in lexicographic order, including the whole set when b = n
    /// (C(4, 2) = 6, C(3, 3) = 1, C(3, 4) = 0, C(0, 0) = 1: the empty subset). Kills `fractional.rs:512:10:
    /// replace > with >= in for_each_combination` (found by the draw of seed 53), which gives no subset
    /// when b = n — so a design whose block-generator candidates are exactly as many as needed would
    /// find none.
    #[test]
    fn every_subset_is_visited_once_including_the_whole_set() {
        let subsets = |n: usize, b: usize| {
            let mut v: Vec<Vec<usize>> = Vec::new();
            for_each_combination(n, b, &mut |idx: &[usize]| v.push(idx.to_vec()));
            v
        };
        let four_two = subsets(4, 2);
        assert_eq!(four_two.len(), 6);
        assert_eq!(four_two[0], [0, 1]);
        assert_eq!(four_two[5], [2, 3]);
        assert_eq!(subsets(3, 3), [vec![0, 1, 2]]);
        assert!(subsets(3, 4).is_empty());
        assert_eq!(subsets(0, 0), [Vec::<usize>::new()]);
    }
}
