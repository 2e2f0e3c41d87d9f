//! The NIST StRD nonlinear regression suite (27 problems, both certified starts) through the
//! closure-based [`CurveFit`]: every fit must end converged (the certified values are reached, so the
//! status must say so), with
//! ≥ 6 correct digits (LRE) in every parameter and ≥ 4 in every standard error (Lanczos1: ≥ 2 in
//! the standard errors — its certified RSS, 1.4e-25, is at the rounding level of its own data).
//!
//! Reference values: the certified parameters, standard deviations and RSS in each `.dat` file,
//! NIST Statistical Reference Datasets, <https://www.itl.nist.gov/div898/strd/nls/nls_main.shtml>
//! (fixtures and their provenance: `tests/fixtures/nist_strd/README.md`). The table of LREs is
//! printed with `cargo test -p millcomp-identify --test main nist_strd -- --nocapture`.

use std::f64::consts::PI;
use std::path::PathBuf;

use millcomp_identify::{CurveFit, FitStatus, LinearMethod, NlsOptions, fd_jacobian, fit_linear};
use nalgebra::{DMatrix, DVector};

use crate::common::nist;

type X = [f64; 2];
type F = fn(&X, &[f64]) -> f64;
type D = fn(&X, &[f64], &mut [f64]);

/// The model `f(x, b)` and its analytic Jacobian of a NIST problem, as its file states them.
fn model(name: &str) -> (F, D) {
    fn exp_sat(x: &X, b: &[f64]) -> f64 {
        b[0] * (1.0 - (-b[1] * x[0]).exp())
    }
    fn exp_sat_d(x: &X, b: &[f64], d: &mut [f64]) {
        let e = (-b[1] * x[0]).exp();
        d[0] = 1.0 - e;
        d[1] = b[0] * x[0] * e;
    }
    fn chwirut(x: &X, b: &[f64]) -> f64 {
        (-b[0] * x[0]).exp() / (b[1] + b[2] * x[0])
    }
    fn chwirut_d(x: &X, b: &[f64], d: &mut [f64]) {
        let (e, g) = ((-b[0] * x[0]).exp(), b[1] + b[2] * x[0]);
        d[0] = -x[0] * e / g;
        d[1] = -e / (g * g);
        d[2] = -x[0] * e / (g * g);
    }
    fn lanczos(x: &X, b: &[f64]) -> f64 {
        (0..3)
            .map(|k| b[2 * k] * (-b[2 * k + 1] * x[0]).exp())
            .sum()
    }
    fn lanczos_d(x: &X, b: &[f64], d: &mut [f64]) {
        for k in 0..3 {
            let e = (-b[2 * k + 1] * x[0]).exp();
            d[2 * k] = e;
            d[2 * k + 1] = -b[2 * k] * x[0] * e;
        }
    }
    fn gauss(x: &X, b: &[f64]) -> f64 {
        let t = x[0];
        b[0] * (-b[1] * t).exp()
            + b[2] * (-((t - b[3]) / b[4]).powi(2)).exp()
            + b[5] * (-((t - b[6]) / b[7]).powi(2)).exp()
    }
    fn gauss_d(x: &X, b: &[f64], d: &mut [f64]) {
        let t = x[0];
        let e = (-b[1] * t).exp();
        d[0] = e;
        d[1] = -b[0] * t * e;
        for (a, m, w) in [(2, 3, 4), (5, 6, 7)] {
            let u = t - b[m];
            let g = (-(u / b[w]).powi(2)).exp();
            d[a] = g;
            d[m] = b[a] * g * 2.0 * u / (b[w] * b[w]);
            d[w] = b[a] * g * 2.0 * u * u / b[w].powi(3);
        }
    }
    /// Rational `(Σ_{k<nn} b_k x^k) / (1 + Σ_{k≥1} b_{nn+k−1} x^k)`.
    fn rational(x: f64, b: &[f64], nn: usize) -> (f64, f64) {
        let num: f64 = (0..nn).map(|k| b[k] * x.powi(k as i32)).sum();
        let den: f64 = 1.0
            + (nn..b.len())
                .map(|k| b[k] * x.powi((k - nn + 1) as i32))
                .sum::<f64>();
        (num, den)
    }
    fn rational_d(x: f64, b: &[f64], nn: usize, d: &mut [f64]) {
        let (num, den) = rational(x, b, nn);
        for (k, dk) in d.iter_mut().enumerate().take(b.len()) {
            *dk = if k < nn {
                x.powi(k as i32) / den
            } else {
                -num * x.powi((k - nn + 1) as i32) / (den * den)
            };
        }
    }
    fn roszman_v(x: &X, b: &[f64]) -> f64 {
        b[2] / (x[0] - b[3])
    }
    fn enso_d(x: &X, b: &[f64], d: &mut [f64]) {
        let t = x[0];
        let a = 2.0 * PI * t / 12.0;
        d[0] = 1.0;
        d[1] = a.cos();
        d[2] = a.sin();
        for (per, c, s) in [(3, 4, 5), (6, 7, 8)] {
            let a = 2.0 * PI * t / b[per];
            d[c] = a.cos();
            d[s] = a.sin();
            d[per] = (b[c] * a.sin() - b[s] * a.cos()) * 2.0 * PI * t / (b[per] * b[per]);
        }
    }
    match name {
        "Misra1a" | "BoxBOD" => (exp_sat, exp_sat_d),
        "Misra1b" => (
            |x, b| b[0] * (1.0 - (1.0 + b[1] * x[0] / 2.0).powi(-2)),
            |x, b, d| {
                let u = 1.0 + b[1] * x[0] / 2.0;
                d[0] = 1.0 - u.powi(-2);
                d[1] = b[0] * x[0] * u.powi(-3);
            },
        ),
        "Misra1c" => (
            |x, b| b[0] * (1.0 - (1.0 + 2.0 * b[1] * x[0]).powf(-0.5)),
            |x, b, d| {
                let u = 1.0 + 2.0 * b[1] * x[0];
                d[0] = 1.0 - u.powf(-0.5);
                d[1] = b[0] * x[0] * u.powf(-1.5);
            },
        ),
        "Misra1d" => (
            |x, b| b[0] * b[1] * x[0] / (1.0 + b[1] * x[0]),
            |x, b, d| {
                let u = 1.0 + b[1] * x[0];
                d[0] = b[1] * x[0] / u;
                d[1] = b[0] * x[0] / (u * u);
            },
        ),
        "Chwirut1" | "Chwirut2" => (chwirut, chwirut_d),
        "DanWood" => (
            |x, b| b[0] * x[0].powf(b[1]),
            |x, b, d| {
                d[0] = x[0].powf(b[1]);
                d[1] = b[0] * x[0].powf(b[1]) * x[0].ln();
            },
        ),
        "Lanczos1" | "Lanczos2" | "Lanczos3" => (lanczos, lanczos_d),
        "Gauss1" | "Gauss2" | "Gauss3" => (gauss, gauss_d),
        "Hahn1" | "Thurber" => (
            |x, b| {
                let (n, d) = rational(x[0], b, 4);
                n / d
            },
            |x, b, d| rational_d(x[0], b, 4, d),
        ),
        "Kirby2" => (
            |x, b| {
                let (n, d) = rational(x[0], b, 3);
                n / d
            },
            |x, b, d| rational_d(x[0], b, 3, d),
        ),
        "MGH09" => (
            |x, b| {
                let t = x[0];
                b[0] * (t * t + t * b[1]) / (t * t + t * b[2] + b[3])
            },
            |x, b, d| {
                let t = x[0];
                let (n, q) = (t * t + t * b[1], t * t + t * b[2] + b[3]);
                d[0] = n / q;
                d[1] = b[0] * t / q;
                d[2] = -b[0] * n * t / (q * q);
                d[3] = -b[0] * n / (q * q);
            },
        ),
        "MGH10" => (
            |x, b| b[0] * (b[1] / (x[0] + b[2])).exp(),
            |x, b, d| {
                let u = x[0] + b[2];
                let e = (b[1] / u).exp();
                d[0] = e;
                d[1] = b[0] * e / u;
                d[2] = -b[0] * e * b[1] / (u * u);
            },
        ),
        "MGH17" => (
            |x, b| b[0] + b[1] * (-x[0] * b[3]).exp() + b[2] * (-x[0] * b[4]).exp(),
            |x, b, d| {
                let (e4, e5) = ((-x[0] * b[3]).exp(), (-x[0] * b[4]).exp());
                d[0] = 1.0;
                d[1] = e4;
                d[2] = e5;
                d[3] = -b[1] * x[0] * e4;
                d[4] = -b[2] * x[0] * e5;
            },
        ),
        "Eckerle4" => (
            |x, b| b[0] / b[1] * (-0.5 * ((x[0] - b[2]) / b[1]).powi(2)).exp(),
            |x, b, d| {
                let u = (x[0] - b[2]) / b[1];
                let g = (-0.5 * u * u).exp();
                d[0] = g / b[1];
                d[1] = b[0] * g * (u * u - 1.0) / (b[1] * b[1]);
                d[2] = b[0] * g * u / (b[1] * b[1]);
            },
        ),
        "Rat42" => (
            |x, b| b[0] / (1.0 + (b[1] - b[2] * x[0]).exp()),
            |x, b, d| {
                let e = (b[1] - b[2] * x[0]).exp();
                d[0] = 1.0 / (1.0 + e);
                d[1] = -b[0] * e / (1.0 + e).powi(2);
                d[2] = b[0] * x[0] * e / (1.0 + e).powi(2);
            },
        ),
        "Rat43" => (
            |x, b| b[0] / (1.0 + (b[1] - b[2] * x[0]).exp()).powf(1.0 / b[3]),
            |x, b, d| {
                let e = (b[1] - b[2] * x[0]).exp();
                let w = 1.0 + e;
                let p = w.powf(-1.0 / b[3]);
                d[0] = p;
                d[1] = -b[0] / b[3] * p / w * e;
                d[2] = b[0] / b[3] * p / w * x[0] * e;
                d[3] = b[0] * p * w.ln() / (b[3] * b[3]);
            },
        ),
        "Bennett5" => (
            |x, b| b[0] * (b[1] + x[0]).powf(-1.0 / b[2]),
            |x, b, d| {
                let u = b[1] + x[0];
                let p = u.powf(-1.0 / b[2]);
                d[0] = p;
                d[1] = -b[0] / b[2] * p / u;
                d[2] = b[0] * p * u.ln() / (b[2] * b[2]);
            },
        ),
        "ENSO" => (
            |x, b| {
                let t = x[0];
                let a = 2.0 * PI * t / 12.0;
                let a4 = 2.0 * PI * t / b[3];
                let a7 = 2.0 * PI * t / b[6];
                b[0] + b[1] * a.cos()
                    + b[2] * a.sin()
                    + b[4] * a4.cos()
                    + b[5] * a4.sin()
                    + b[7] * a7.cos()
                    + b[8] * a7.sin()
            },
            enso_d,
        ),
        // the file's model is log(y) = b1 − b2·x1·exp(−b3·x2): the response is log(y)
        "Nelson" => (
            |x, b| b[0] - b[1] * x[0] * (-b[2] * x[1]).exp(),
            |x, b, d| {
                let e = (-b[2] * x[1]).exp();
                d[0] = 1.0;
                d[1] = -x[0] * e;
                d[2] = b[1] * x[0] * x[1] * e;
            },
        ),
        "Roszman1" => (
            |x, b| b[0] - b[1] * x[0] - (b[2] / (x[0] - b[3])).atan() / PI,
            |x, b, d| {
                let v = roszman_v(x, b);
                let k = 1.0 / (PI * (1.0 + v * v));
                d[0] = 1.0;
                d[1] = -x[0];
                d[2] = -k / (x[0] - b[3]);
                d[3] = -k * b[2] / (x[0] - b[3]).powi(2);
            },
        ),
        other => panic!("no model for NIST problem {other}"),
    }
}

/// All 27 problems, in NIST's order of difficulty (lower, average, higher).
const PROBLEMS: [&str; 27] = [
    "Misra1a", "Chwirut2", "Chwirut1", "Lanczos3", "Gauss1", "Gauss2", "DanWood", "Misra1b",
    "Kirby2", "Hahn1", "Nelson", "MGH17", "Lanczos1", "Lanczos2", "Gauss3", "Misra1c", "Misra1d",
    "Roszman1", "ENSO", "MGH09", "Thurber", "BoxBOD", "Rat42", "MGH10", "Eckerle4", "Rat43",
    "Bennett5",
];

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nist_strd/nonlinear")
}

/// (x, y) of a problem: `x = [x1, x2]` (x2 = 0 with one predictor); Nelson's response is log(y).
fn data(p: &nist::Problem) -> (Vec<X>, Vec<f64>) {
    let x: Vec<X> = p
        .data
        .iter()
        .map(|r| [r[1], r.get(2).copied().unwrap_or(0.0)])
        .collect();
    let y: Vec<f64> = p
        .data
        .iter()
        .map(|r| if p.name == "Nelson" { r[0].ln() } else { r[0] })
        .collect();
    (x, y)
}

#[test]
fn analytic_jacobians_match_central_differences() {
    for name in PROBLEMS {
        let p = nist::read(&dir().join(format!("{name}.dat"))).unwrap();
        let (x, _) = data(&p);
        let (f, d) = model(name);
        for b in [&p.starts[0], &p.certified] {
            let bv = DVector::from_column_slice(b);
            let fd = fd_jacobian(
                |q| {
                    Ok(DVector::from_iterator(
                        x.len(),
                        x.iter().map(|xi| f(xi, q.as_slice())),
                    ))
                },
                &bv,
            )
            .unwrap();
            // central differences carry a round-off of ~ε·|f|/h, h = ε^⅓·|b_k|: a floor of
            // 1e-9·max|f|/|b_k| (≈ 150× that) keeps tiny derivatives (MGH17's e^{−20} terms)
            // from failing on the differences' own rounding
            let fmax = x.iter().map(|xi| f(xi, b).abs()).fold(0.0, f64::max);
            let mut row = vec![0.0; b.len()];
            for (i, xi) in x.iter().enumerate() {
                d(xi, b, &mut row);
                for (k, &dk) in row.iter().enumerate() {
                    let allowed = 1e-5 * fd.column(k).amax() + 1e-9 * fmax / b[k].abs().max(1e-300);
                    assert!(
                        (dk - fd[(i, k)]).abs() <= allowed,
                        "{name} row {i} column b{}: analytic {dk} vs fd {}",
                        k + 1,
                        fd[(i, k)]
                    );
                }
            }
        }
    }
}

/// One fit of the suite.
struct Outcome {
    name: &'static str,
    start: usize,
    lre_param: f64,
    lre_se: f64,
    lre_rss: f64,
    iterations: u64,
    status: FitStatus,
}

fn run(name: &'static str, start: usize) -> Outcome {
    let p = nist::read(&dir().join(format!("{name}.dat"))).unwrap();
    let (x, y) = data(&p);
    let (f, d) = model(name);
    let fit = CurveFit::new(&x, &y, f)
        .jacobian(d)
        .options(NlsOptions::default())
        .fit(&p.starts[start])
        .unwrap_or_else(|e| panic!("{name} start {}: {e}", start + 1));
    let r = &fit.report;
    let names: Vec<String> = (1..=p.certified.len()).map(|k| format!("b{k}")).collect();
    let lre_param = names
        .iter()
        .zip(&p.certified)
        .map(|(n, c)| nist::lre(r.param(n), *c, 11.0))
        .fold(f64::INFINITY, f64::min);
    let lre_se = names
        .iter()
        .zip(&p.certified_sd)
        .map(|(n, c)| nist::lre(r.se(n), *c, 11.0))
        .fold(f64::INFINITY, f64::min);
    Outcome {
        name,
        start: start + 1,
        lre_param,
        lre_se,
        lre_rss: nist::lre(r.rss, p.certified_rss, 11.0),
        iterations: r.iterations,
        status: r.status,
    }
}

#[test]
fn nist_strd_nonlinear_suite_from_both_starts() {
    let outcomes: Vec<Outcome> = PROBLEMS
        .iter()
        .flat_map(|&name| [run(name, 0), run(name, 1)])
        .collect();
    eprintln!(
        "NIST {:<9} {:>5} {:>9} {:>9} {:>9} {:>6}  status",
        "problem", "start", "LRE θ", "LRE SE", "LRE RSS", "iter"
    );
    for o in &outcomes {
        eprintln!(
            "NIST {:<9} {:>5} {:>9.1} {:>9.1} {:>9.1} {:>6}  {:?}",
            o.name, o.start, o.lre_param, o.lre_se, o.lre_rss, o.iterations, o.status
        );
    }
    let mut failures = Vec::new();
    for o in &outcomes {
        let se_needed = if o.name == "Lanczos1" { 2.0 } else { 4.0 };
        // certified values reached: the status says converged (not merely stalled at rounding level)
        if o.status != FitStatus::Converged || o.lre_param < 6.0 || o.lre_se < se_needed {
            failures.push(format!(
                "{} start {}: LRE θ {:.1}, SE {:.1} (need 6, {se_needed}), {:?} after {} iterations",
                o.name, o.start, o.lre_param, o.lre_se, o.status, o.iterations
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "NIST StRD failures:\n{}",
        failures.join("\n")
    );
}

/// NIST's linear Norris problem through [`fit_linear`] (QR on centred data), certified to 15
/// digits. A backward-stable float64 solve keeps ~15.5 − log₁₀(cond) digits of the slope; the
/// intercept B0 = −0.26 is what is left of responses of order 500 (ȳ − B1·x̄), which costs another
/// log₁₀(500/0.26) ≈ 3.3 digits: ≥ 11 for every quantity.
#[test]
fn nist_strd_linear_norris() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/nist_strd/linear/Norris.dat");
    let p = nist::read(&path).unwrap();
    let y: Vec<f64> = p.data.iter().map(|r| r[0]).collect();
    let a = DMatrix::from_fn(y.len(), 2, |i, j| if j == 0 { 1.0 } else { p.data[i][1] });
    let names = ["B0".to_string(), "B1".to_string()];
    let fit = fit_linear(&names, &a, &y, None, LinearMethod::Qr, "norris", "y").unwrap();
    let r = &fit.report;
    let l = [
        nist::lre(r.param("B0"), p.certified[0], 15.0),
        nist::lre(r.param("B1"), p.certified[1], 15.0),
        nist::lre(r.se("B0"), p.certified_sd[0], 15.0),
        nist::lre(r.se("B1"), p.certified_sd[1], 15.0),
        nist::lre(r.rss, p.certified_rss, 15.0),
    ];
    eprintln!(
        "NIST linear Norris LRE: B0 {:.1} B1 {:.1} SE(B0) {:.1} SE(B1) {:.1} RSS {:.1}",
        l[0], l[1], l[2], l[3], l[4]
    );
    assert!(l.iter().all(|&v| v >= 11.0), "Norris LREs {l:?}");
}
