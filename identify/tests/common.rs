//! Shared test tolerances and the recovery-study harness.
#![allow(dead_code)]

use std::collections::BTreeMap;

use millcomp_identify::FitReport;

/// A golden file of this crate's tests, `tests/golden/NAME.json`, parsed.
pub fn golden_json(name: &str) -> serde_json::Value {
    let path = format!("{}/tests/golden/{name}.json", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(path).expect("golden")).expect("json")
}

/// A JSON array of numbers as a vector.
pub fn nums(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Tolerances, each argued.
pub mod tol {
    /// Number of synthetic data sets per verb in the recovery studies (the issue asks for ≥ 200).
    /// 400: the coverage estimate then has a binomial standard deviation of
    /// √(0.95·0.05/400) = 1.1 %, so the [92 %, 98 %] band is ±2.7σ around 95 % — a correct
    /// interval fails it with probability < 1 %, while 200 sets (±2σ) would fail one parameter in
    /// twenty by chance. Debug run time stays under ~10 s per verb.
    pub const RECOVERY_SETS: usize = 400;
    /// 95 % CI coverage must lie in [0.92, 0.98] (issue 5).
    pub const COVERAGE_LO: f64 = 0.92;
    /// Upper coverage bound (see [`COVERAGE_LO`]).
    pub const COVERAGE_HI: f64 = 0.98;
    /// "Unbiased within the standard error": |mean − truth| ≤ BIAS_FRAC_SE·mean(SE) +
    /// BIAS_SIGMAS·sd/√N. Nonlinear least-squares estimators carry a genuine O(σ²) bias (M. J.
    /// Box, "Bias in nonlinear estimation", JRSS B 33, 1971) — e.g. k = 1/slope or a time
    /// constant — that a large enough study always detects; it must stay a small fraction of the
    /// standard error, here a quarter, with 3 standard errors of the mean for sampling noise.
    pub const BIAS_FRAC_SE: f64 = 0.25;
    /// Allowance for the sampling noise of the mean estimate, in standard errors of the mean.
    pub const BIAS_SIGMAS: f64 = 3.0;
    /// The reported SE must match the spread of the estimates: mean(SE)/sd(θ̂) in [0.85, 1.15].
    /// The sample sd of 400 estimates has a relative SE of 1/√(2·399) = 3.5 %, so ±15 % is 4σ.
    pub const SE_RATIO_LO: f64 = 0.85;
    /// Upper bound of mean(SE)/sd(θ̂).
    pub const SE_RATIO_HI: f64 = 1.15;
    /// Golden comparison with scipy.optimize.least_squares: 1e-6 relative (issue 5).
    pub const GOLDEN_REL: f64 = 1e-6;
    /// Analytic vs central-difference Jacobian: central differences with h = ε^{1/3}|x| have
    /// relative truncation + round-off error ~ε^{2/3} ≈ 4e-11 times the ratio of third to first
    /// derivative scales; 1e-6 leaves room for that ratio while catching any real slip (a wrong
    /// factor or sign gives errors of order 1).
    pub const JACOBIAN_REL: f64 = 1e-6;
}

/// Statistics of one parameter over a recovery study.
#[derive(Debug, Clone)]
pub struct ParamStats {
    /// True value.
    pub truth: f64,
    /// Mean estimate.
    pub mean: f64,
    /// Standard deviation of the estimates.
    pub sd: f64,
    /// Mean reported standard error.
    pub mean_se: f64,
    /// Fraction of 95 % intervals that contain the truth.
    pub coverage: f64,
    /// Number of sets.
    pub n: usize,
}

impl ParamStats {
    /// (mean − truth) / (sd/√n).
    pub fn bias_z(&self) -> f64 {
        (self.mean - self.truth) / (self.sd / (self.n as f64).sqrt())
    }
    /// (mean − truth) / mean(SE): the bias in units of the reported standard error.
    pub fn bias_se(&self) -> f64 {
        (self.mean - self.truth) / self.mean_se
    }
    /// mean(SE)/sd.
    pub fn se_ratio(&self) -> f64 {
        self.mean_se / self.sd
    }
}

/// Runs `fit(seed)` for `n` seeds and summarises each parameter in `truth`.
pub fn recovery<F>(n: usize, truth: &BTreeMap<String, f64>, fit: F) -> BTreeMap<String, ParamStats>
where
    F: Fn(u64) -> FitReport,
{
    // Exploration knobs (defaults are what the test asserts): MILLCOMP_RECOVERY_SETS overrides the
    // count, MILLCOMP_RECOVERY_SEED_BASE the first seed.
    let n = std::env::var("MILLCOMP_RECOVERY_SETS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(n);
    let base: u64 = std::env::var("MILLCOMP_RECOVERY_SEED_BASE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    let reports: Vec<FitReport> = (0..n as u64).map(|s| fit(base + s)).collect();
    truth
        .iter()
        .map(|(name, &t)| {
            let est: Vec<f64> = reports.iter().map(|r| r.param(name)).collect();
            let se: Vec<f64> = reports.iter().map(|r| r.se(name)).collect();
            let cover = reports
                .iter()
                .filter(|r| {
                    let ci = r.ci95[name];
                    ci[0] <= t && t <= ci[1]
                })
                .count();
            let nf = n as f64;
            let mean = est.iter().sum::<f64>() / nf;
            let sd = (est.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (nf - 1.0)).sqrt();
            (
                name.clone(),
                ParamStats {
                    truth: t,
                    mean,
                    sd,
                    mean_se: se.iter().sum::<f64>() / nf,
                    coverage: cover as f64 / nf,
                    n,
                },
            )
        })
        .collect()
}

/// Prints the table (visible with `--nocapture`) and asserts the three honesty criteria.
pub fn assert_honest(verb: &str, stats: &BTreeMap<String, ParamStats>) {
    for (name, s) in stats {
        eprintln!(
            "RECOVERY {verb:>22} {name:>28}: truth {:>12.5e} mean {:>12.5e} bias/SE {:>+6.3} bias/SEM {:>+6.2} SE/sd {:>5.3} coverage {:>5.1}% (n={})",
            s.truth,
            s.mean,
            s.bias_se(),
            s.bias_z(),
            s.se_ratio(),
            100.0 * s.coverage,
            s.n
        );
    }
    for (name, s) in stats {
        let allowed = tol::BIAS_FRAC_SE * s.mean_se + tol::BIAS_SIGMAS * s.sd / (s.n as f64).sqrt();
        assert!(
            (s.mean - s.truth).abs() <= allowed,
            "{verb} {name}: biased, mean {} vs truth {} ({:.3} SE, {:.2} SEM)",
            s.mean,
            s.truth,
            s.bias_se(),
            s.bias_z()
        );
        assert!(
            (tol::SE_RATIO_LO..=tol::SE_RATIO_HI).contains(&s.se_ratio()),
            "{verb} {name}: SE/sd = {:.3}",
            s.se_ratio()
        );
        assert!(
            (tol::COVERAGE_LO..=tol::COVERAGE_HI).contains(&s.coverage),
            "{verb} {name}: coverage {:.3}",
            s.coverage
        );
    }
}

/// A reader for NIST StRD regression files (`*.dat`): NIST's fixed text format, whose header
/// gives the line ranges of the starting values, the certified values and the data.
pub mod nist {
    use std::path::Path;

    /// One StRD regression problem.
    #[derive(Debug, Clone)]
    pub struct Problem {
        /// Dataset name (the file stem).
        pub name: String,
        /// Starting values (nonlinear problems: two starts; linear ones: none).
        pub starts: Vec<Vec<f64>>,
        /// Certified parameter values b1, b2, …
        pub certified: Vec<f64>,
        /// Certified standard deviations of the parameters.
        pub certified_sd: Vec<f64>,
        /// Certified residual sum of squares.
        pub certified_rss: f64,
        /// Data rows in file order (`y, x` or `y, x1, x2`).
        pub data: Vec<Vec<f64>>,
    }

    /// The 1-based inclusive line range `(lines a to b)` following `label` in the header.
    fn range(text: &str, label: &str) -> Result<(usize, usize), String> {
        let line = text
            .lines()
            .take(15)
            .find(|l| {
                l.trim_start()
                    .strip_prefix(label)
                    .is_some_and(|rest| rest.starts_with(' '))
            })
            .ok_or_else(|| format!("no `{label}` line range in the header"))?;
        let inner = line
            .split('(')
            .nth(1)
            .and_then(|s| s.split(')').next())
            .ok_or_else(|| format!("`{label}`: no (lines a to b)"))?;
        let nums: Vec<usize> = inner
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        match nums[..] {
            [a, b] => Ok((a, b)),
            _ => Err(format!("`{label}`: cannot read `{inner}`")),
        }
    }

    fn number(w: &str, path: &Path, line: usize) -> Result<f64, String> {
        w.parse::<f64>()
            .map_err(|e| format!("{} line {line}: `{w}`: {e}", path.display()))
    }

    /// Reads a problem; the error names the file and line.
    pub fn read(path: &Path) -> Result<Problem, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let lines: Vec<&str> = text.lines().collect();
        let (c0, c1) = range(&text, "Certified Values")?;
        let (d0, d1) = range(&text, "Data")?;
        let mut starts: Vec<Vec<f64>> = Vec::new();
        let (mut certified, mut certified_sd, mut certified_rss) = (Vec::new(), Vec::new(), None);
        for (k, l) in lines.iter().enumerate().take(c1).skip(c0 - 1) {
            if let Some((lhs, rhs)) = l.split_once('=') {
                if !lhs.trim().starts_with('b') {
                    continue;
                }
                let v: Vec<f64> = rhs
                    .split_whitespace()
                    .map(|w| number(w, path, k + 1))
                    .collect::<Result<_, _>>()?;
                let nstart = v.len() - 2;
                starts.resize(nstart, Vec::new());
                for (s, &x) in starts.iter_mut().zip(&v) {
                    s.push(x);
                }
                certified.push(v[nstart]);
                certified_sd.push(v[nstart + 1]);
            } else if let Some(rest) = l.trim().strip_prefix("Residual Sum of Squares:") {
                certified_rss = Some(number(rest.trim(), path, k + 1)?);
            } else {
                // linear files: `B0  estimate  sd` and the ANOVA row `Residual  df  SS  MS`
                let w: Vec<&str> = l.split_whitespace().collect();
                let is_param = |t: &str| {
                    t.len() > 1 && t.starts_with('B') && t[1..].chars().all(|c| c.is_ascii_digit())
                };
                match w[..] {
                    [b, est, sd] if is_param(b) => {
                        certified.push(number(est, path, k + 1)?);
                        certified_sd.push(number(sd, path, k + 1)?);
                    }
                    ["Residual", df, ss, _] if df.parse::<usize>().is_ok() => {
                        certified_rss = Some(number(ss, path, k + 1)?)
                    }
                    _ => {}
                }
            }
        }
        let data = lines
            .iter()
            .enumerate()
            .take(d1)
            .skip(d0 - 1)
            .map(|(k, l)| {
                l.split_whitespace()
                    .map(|w| number(w, path, k + 1))
                    .collect::<Result<Vec<f64>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Problem {
            name: path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            starts,
            certified,
            certified_sd,
            certified_rss: certified_rss
                .ok_or_else(|| format!("{}: no residual sum of squares", path.display()))?,
            data,
        })
    }

    /// Log relative error `−log₁₀(|x − c|/|c|)` (absolute when `c = 0`), capped at `cap` (the
    /// digits NIST certifies: 11 for nonlinear problems, 15 for linear ones); 0 for a non-finite `x`.
    pub fn lre(x: f64, c: f64, cap: f64) -> f64 {
        if !x.is_finite() {
            return 0.0;
        }
        let err = if c == 0.0 {
            x.abs()
        } else {
            ((x - c) / c).abs()
        };
        if err == 0.0 {
            cap
        } else {
            (-err.log10()).clamp(0.0, cap)
        }
    }
}
