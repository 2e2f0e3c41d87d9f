//! Text and plots of the record verbs (`identify thermal --train`, `identify wear`, `identify flutes`):
//! every output names the file it read.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use millcomp_identify::targets::thermal_record::ChannelStudy;
use millcomp_identify::targets::wear::WearStudy;
use serde_json::{Value, json};

use crate::cmd::record::{FluteFile, InputInfo};
use crate::present::plot::{Series, line_plot};

/// Share of drift a channel must lose to count in the summary (issue 17's bound).
pub const REMOVED_BOUND: f64 = 0.75;

fn pct(x: f64) -> String {
    if x.is_finite() {
        format!("{:.1} %", 100.0 * x)
    } else {
        "–".into()
    }
}

fn opt(x: Option<f64>, f: impl Fn(f64) -> String) -> String {
    x.map_or_else(|| "–".into(), f)
}

fn list_names(names: &[String]) -> String {
    match names.len() {
        0 => "none".into(),
        1..=3 => names.join(", "),
        n => format!("{n} ({} … {})", names[0], names[n - 1]),
    }
}

/// How many channels removed ≥ 75 % of their test drift and how many beat the plain LSQ baseline.
pub fn thermal_summary(studies: &[ChannelStudy]) -> Value {
    let removed: Vec<&str> = studies
        .iter()
        .filter(|s| {
            s.test_metrics
                .as_ref()
                .is_some_and(|m| m.removed >= REMOVED_BOUND)
        })
        .map(|s| s.channel.as_str())
        .collect();
    let beats: Vec<&str> = studies
        .iter()
        .filter(|s| match (&s.test_metrics, &s.baseline_test_metrics) {
            (Some(a), Some(b)) => a.rms_um < b.rms_um,
            _ => false,
        })
        .map(|s| s.channel.as_str())
        .collect();
    json!({
        "channels": studies.len(),
        "removed_at_least_75_pct": removed,
        "test_rms_below_plain_lsq": beats,
    })
}

/// The thermal study as text: the file, the columns, the table per channel, each channel's structures
/// by cross-validated score and the chosen model's coefficients.
pub fn thermal_text(
    info: &InputInfo,
    t_col: &str,
    speed_col: Option<&str>,
    temps: &[(String, Vec<f64>)],
    studies: &[ChannelStudy],
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "thermal record: {}", info.line());
    let temp_names: Vec<String> = temps.iter().map(|t| t.0.clone()).collect();
    let chans: Vec<String> = studies.iter().map(|c| c.channel.clone()).collect();
    let _ = writeln!(
        s,
        "columns: t_s = {t_col}, speed_rpm = {}, temp_c = {}, drift_um = {}",
        speed_col.unwrap_or("none"),
        list_names(&temp_names),
        list_names(&chans)
    );
    if let Some(c) = studies.first() {
        let _ = writeln!(
            s,
            "train {}: {}–{} s ({} rows), structure and sensors chosen by {}-fold blocked cross-validation inside it",
            c.train.range, c.train.start_s, c.train.end_s, c.train.rows, c.folds
        );
        if let Some(t) = &c.test {
            let _ = writeln!(
                s,
                "test {}: {}–{} s ({} rows), drift = measured − its value at {} s (a machine zeroed then); removed = 1 − rms/drift rms",
                t.range, t.start_s, t.end_s, t.rows, t.start_s
            );
        }
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{:<12} {:<24} {:>12} {:>5} {:>7} {:>8} {:>7} {:>8} {:>8} {:>9} {:>8} | {:>8} {:>8}",
        "channel",
        "chosen model (by CV)",
        "tau s",
        "e",
        "lambda",
        "sensors",
        "CV rms",
        "test rms",
        "max|err|",
        "drift rms",
        "removed",
        "LSQ-16",
        "removed"
    );
    for c in studies {
        let m = &c.chosen;
        let taus = if m.taus_s.is_empty() {
            "–".to_string()
        } else {
            m.taus_s
                .iter()
                .map(|t| format!("{t:.0}"))
                .collect::<Vec<_>>()
                .join("+")
        };
        let tm = c.test_metrics.as_ref();
        let bm = c.baseline_test_metrics.as_ref();
        let _ = writeln!(
            s,
            "{:<12} {:<24} {:>12} {:>5} {:>7} {:>8} {:>7.2} {:>8} {:>8} {:>9} {:>8} | {:>8} {:>8}",
            c.channel,
            m.model,
            taus,
            opt(m.exponent, |e| format!("{e:.2}")),
            opt(m.lambda, |l| format!("{l:.0e}")),
            if m.lambda.is_some() {
                format!("{} all", m.sensors.len())
            } else {
                m.sensors.len().to_string()
            },
            c.chosen_cv_rms_um,
            opt(tm.map(|t| t.rms_um), |x| format!("{x:.2}")),
            opt(tm.map(|t| t.max_abs_um), |x| format!("{x:.2}")),
            opt(tm.map(|t| t.drift_rms_um), |x| format!("{x:.2}")),
            opt(tm.map(|t| t.removed), pct),
            opt(bm.map(|t| t.rms_um), |x| format!("{x:.2}")),
            opt(bm.map(|t| t.removed), pct),
        );
    }
    let _ = writeln!(
        s,
        "(µm; LSQ-16 = plain least squares on all {} temperatures, fitted on the same training rows)",
        temps.len()
    );
    if studies.iter().any(|c| c.test_metrics.is_some()) {
        let sum = thermal_summary(studies);
        let removed = sum["removed_at_least_75_pct"]
            .as_array()
            .map_or(0, Vec::len);
        let beats = sum["test_rms_below_plain_lsq"]
            .as_array()
            .map_or(0, Vec::len);
        let _ = writeln!(
            s,
            "drift removed >= 75 %: {removed} of {} channels; chosen model's test rms below plain LSQ: {beats} of {}",
            studies.len(),
            studies.len()
        );
    }
    for c in studies {
        let _ = writeln!(s, "\n{}: structures by cross-validated rms (µm)", c.channel);
        for k in &c.candidates {
            let taus: Vec<String> = k.taus_s.iter().map(|t| format!("{t:.0}")).collect();
            let _ = writeln!(
                s,
                "  {:<26} {:>7.3}   folds {}{}{}{}",
                k.model,
                k.cv_rms_um,
                k.fold_rms_um
                    .iter()
                    .map(|x| format!("{x:.2}"))
                    .collect::<Vec<_>>()
                    .join(" / "),
                if taus.is_empty() {
                    String::new()
                } else {
                    format!("   tau {} s", taus.join("+"))
                },
                opt(k.exponent, |e| format!("  e {e}")).replace('–', ""),
                opt(k.lambda, |l| format!("  lambda {l:.0e}")).replace('–', ""),
            );
        }
        let m = &c.chosen;
        let _ = writeln!(
            s,
            "  chosen {}: train rms {:.3} µm; sensors: {}",
            m.model,
            m.train_rms_um,
            if m.sensors.is_empty() {
                "none".into()
            } else {
                m.sensors.join(", ")
            }
        );
        match &m.report {
            Some(r) => {
                for (name, v) in &r.params {
                    let ci = r.ci95.get(name).copied().unwrap_or([f64::NAN; 2]);
                    let _ = writeln!(
                        s,
                        "    {name:<28} {v:>12.5}   95 % [{:.5}, {:.5}]",
                        ci[0], ci[1]
                    );
                }
                for w in &r.warnings {
                    let _ = writeln!(s, "    warning: {w}");
                }
            }
            None => {
                let coefs: Vec<String> = m
                    .coefficients
                    .iter()
                    .map(|(k, v)| format!("{k} {v:.4}"))
                    .collect();
                let _ = writeln!(
                    s,
                    "    ridge coefficients (shrunk; no interval — the CV rms {:.3} µm is their uncertainty): {}",
                    c.chosen_cv_rms_um,
                    coefs.join(", ")
                );
            }
        }
        for n in &c.notes {
            let _ = writeln!(s, "  note: {n}");
        }
    }
    s
}

/// At most `max` points of a long series (every k-th, the last kept): a 46 h record at 15 s has
/// 11 115 samples, far more than a 960-pixel plot shows.
fn thin(points: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    let k = points.len().div_ceil(max.max(1)).max(1);
    if k == 1 {
        return points;
    }
    let last = points.last().copied();
    let mut out: Vec<(f64, f64)> = points.into_iter().step_by(k).collect();
    if let Some(l) = last {
        if out.last() != Some(&l) {
            out.push(l);
        }
    }
    out
}

/// Points per series in the record plots.
const PLOT_POINTS: usize = 2000;

fn file_stem(info: &InputInfo) -> String {
    Path::new(&info.path)
        .file_name()
        .map_or_else(|| info.path.clone(), |f| f.to_string_lossy().into_owned())
}

/// Per channel: the test range's drift, measured and predicted (zeroed at its start) by the chosen
/// model and the plain LSQ baseline; and the whole record with the training/test boundary.
pub fn thermal_plots(
    dir: &Path,
    t_s: &[f64],
    studies: &[ChannelStudy],
    info: &InputInfo,
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = file_stem(info);
    let mut out = Vec::new();
    let h = |i: usize| t_s[i] / 3600.0;
    for c in studies {
        if let (Some(w), Some(m)) = (&c.test, &c.test_metrics) {
            let rows: Vec<usize> = (w.first_row..w.first_row + w.rows).collect();
            let z = |v: &[f64]| -> Vec<(f64, f64)> {
                let v0 = v[w.first_row];
                thin(
                    rows.iter().map(|&i| (h(i), v[i] - v0)).collect(),
                    PLOT_POINTS,
                )
            };
            let mut series = vec![
                Series {
                    label: "measured drift".into(),
                    points: z(&c.measured_um),
                },
                Series {
                    label: format!("{} (test rms {:.2} µm)", c.chosen.model, m.rms_um),
                    points: z(&c.prediction_um),
                },
            ];
            if let Some(b) = &c.baseline_test_metrics {
                series.push(Series {
                    label: format!(
                        "plain LSQ on all temperatures (test rms {:.2} µm)",
                        b.rms_um
                    ),
                    points: z(&c.baseline_prediction_um),
                });
            }
            let p = dir.join(format!("thermal_{}_test.svg", c.channel));
            line_plot(
                &p,
                &format!(
                    "{file} {}: test range, measured vs predicted drift",
                    c.channel
                ),
                "time (h)",
                "drift since the test start (µm)",
                &series,
            )?;
            out.push(p);
        }
        let all = |v: &[f64]| -> Vec<(f64, f64)> {
            thin((0..v.len()).map(|i| (h(i), v[i])).collect(), PLOT_POINTS)
        };
        let (lo, hi) = c
            .measured_um
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let split = c.test.as_ref().map_or(c.train.end_s, |w| w.start_s) / 3600.0;
        let series = vec![
            Series {
                label: "measured".into(),
                points: all(&c.measured_um),
            },
            Series {
                label: format!("{} (fitted left of the line)", c.chosen.model),
                points: all(&c.prediction_um),
            },
            Series {
                label: "train | test".into(),
                points: vec![(split, lo), (split, hi)],
            },
        ];
        let p = dir.join(format!("thermal_{}_record.svg", c.channel));
        line_plot(
            &p,
            &format!("{file} {}: whole record", c.channel),
            "time (h)",
            "displacement (µm)",
            &series,
        )?;
        out.push(p);
    }
    Ok(out)
}

/// The wear study as text.
pub fn wear_text(
    info: &InputInfo,
    joined: Option<&InputInfo>,
    cut_col: &str,
    last_cut: f64,
    vb: &[(String, Vec<f64>)],
    studies: &[WearStudy],
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "wear record: {}", info.line());
    if let Some(j) = joined {
        let _ = writeln!(s, "joined:      {}", j.line());
    }
    let vb_names: Vec<String> = vb.iter().map(|v| v.0.clone()).collect();
    let chans: Vec<String> = studies.iter().map(|c| c.channel.clone()).collect();
    let _ = writeln!(
        s,
        "columns: cut = {cut_col} (last cut {last_cut}), force_n = {}, vb_um = {}",
        chans.join(", "),
        if vb_names.is_empty() {
            "none".into()
        } else {
            format!("mean of {}", vb_names.join(", "))
        }
    );
    if let Some(c) = studies.first() {
        let _ = writeln!(
            s,
            "laws fitted on cuts {}–{} ({} cuts), chosen by rolling-origin cross-validation inside them{}",
            c.train_cuts[0],
            c.train_cuts[1],
            c.train_cuts[2],
            c.test_cuts.map_or(String::new(), |t| format!(
                "; predicting cuts {}–{} ({} cuts)",
                t[0], t[1], t[2]
            ))
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{:<16} {:<12} {:<34} {:>8} {:>9} {:>8} {:>8} {:>7} {:>10}",
        "channel",
        "law (by CV)",
        "parameters",
        "CV rms",
        "test rms",
        "max|err|",
        "bias",
        "rel",
        "naive rms"
    );
    for c in studies {
        let p: Vec<String> = c
            .chosen
            .report
            .params
            .iter()
            .map(|(k, v)| format!("{k} {v:.4}"))
            .collect();
        let cv = c
            .laws
            .iter()
            .find(|l| l.law == c.chosen.law)
            .map_or(f64::NAN, |l| l.cv_rms_n);
        let tm = c.test_metrics.as_ref();
        let _ = writeln!(
            s,
            "{:<16} {:<12} {:<34} {:>8.3} {:>9} {:>8} {:>8} {:>7} {:>10}",
            c.channel,
            c.chosen.law.name(),
            p.join(", "),
            cv,
            opt(tm.map(|t| t.rms_n), |x| format!("{x:.3}")),
            opt(tm.map(|t| t.max_abs_n), |x| format!("{x:.3}")),
            opt(tm.map(|t| t.bias_n), |x| format!("{x:+.3}")),
            opt(tm.map(|t| t.rms_relative), pct),
            opt(tm.map(|t| t.naive_rms_n), |x| format!("{x:.3}")),
        );
    }
    let _ = writeln!(
        s,
        "(N; rel = test rms / mean test force; naive = the mean of the last 10 training cuts, held)"
    );
    if studies.iter().any(|c| c.force_vs_wear.is_some()) {
        let _ = writeln!(
            s,
            "\nforce against flank wear, F = F0 + k·VB (the force model's wearland term: flank force ∝ wearland width):"
        );
        let _ = writeln!(
            s,
            "{:<16} {:>28} {:>10} {:>10} {:>8}",
            "channel", "k N/µm [95 % Newey–West]", "F0 N", "test rms", "rel"
        );
        for c in studies {
            if let Some(f) = &c.force_vs_wear {
                let r = &f.report;
                let ci = r.ci95.get("k_n_per_um").copied().unwrap_or([f64::NAN; 2]);
                let tm = f.test_metrics.as_ref();
                let _ = writeln!(
                    s,
                    "{:<16} {:>28} {:>10.3} {:>10} {:>8}",
                    c.channel,
                    format!("{:.4} [{:.4}, {:.4}]", r.param("k_n_per_um"), ci[0], ci[1]),
                    r.param("f0_n"),
                    opt(tm.map(|t| t.rms_n), |x| format!("{x:.3}")),
                    opt(tm.map(|t| t.rms_relative), pct),
                );
            }
        }
    }
    for c in studies {
        let _ = writeln!(s, "\n{}: laws by rolling-origin CV rms (N)", c.channel);
        for l in &c.laws {
            let _ = writeln!(
                s,
                "  {:<12} {:>9.3}   {}",
                l.law.name(),
                l.cv_rms_n,
                l.formula
            );
        }
        let r = &c.chosen.report;
        for (name, v) in &r.params {
            let ci = r.ci95.get(name).copied().unwrap_or([f64::NAN; 2]);
            let _ = writeln!(
                s,
                "  {name:<10} {v:>12.5}   95 % [{:.5}, {:.5}]",
                ci[0], ci[1]
            );
        }
        for w in &r.warnings {
            let _ = writeln!(s, "  warning: {w}");
        }
        for n in &c.notes {
            let _ = writeln!(s, "  note: {n}");
        }
    }
    s
}

/// Per channel: the measured force per cut, the chosen law (fitted on the training cuts, extended to
/// the rest) and the force predicted from the measured flank wear.
pub fn wear_plots(
    dir: &Path,
    cut: &[f64],
    studies: &[WearStudy],
    info: &InputInfo,
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = file_stem(info);
    let mut out = Vec::new();
    for c in studies {
        let pts =
            |v: &[f64]| -> Vec<(f64, f64)> { cut.iter().copied().zip(v.iter().copied()).collect() };
        let mut series = vec![
            Series {
                label: "measured".into(),
                points: pts(&c.measured_n),
            },
            Series {
                label: format!(
                    "{} law, fitted on cuts {}–{}",
                    c.chosen.law.name(),
                    c.train_cuts[0],
                    c.train_cuts[1]
                ),
                points: pts(&c.prediction_n),
            },
        ];
        if let Some(f) = &c.force_vs_wear {
            series.push(Series {
                label: "F0 + k·VB from the measured wear".into(),
                points: pts(&f.prediction_n),
            });
        }
        let (lo, hi) = c
            .measured_n
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        series.push(Series {
            label: "train | test".into(),
            points: vec![(c.train_cuts[1] + 0.5, lo), (c.train_cuts[1] + 0.5, hi)],
        });
        let p = dir.join(format!("wear_{}.svg", c.channel));
        line_plot(
            &p,
            &format!("{file} {}: force per cut, measured vs predicted", c.channel),
            "cut",
            "force (N)",
            &series,
        )?;
        out.push(p);
    }
    Ok(out)
}

/// The per-flute peaks as text.
pub fn flutes_text(flutes: usize, rpm: f64, fs: f64, files: &[FluteFile]) -> String {
    let mut s = String::new();
    let p = fs * 60.0 / (rpm * flutes as f64);
    let _ = writeln!(
        s,
        "per-flute peak forces: {flutes} flutes at {rpm} rpm sampled at {fs} Hz: tooth period {p:.2} samples \
         (flute numbers are relative: no once-per-revolution mark)"
    );
    for f in files {
        let _ = writeln!(s, "\n{}", f.input.line());
        let mut head = format!(
            "{:<12} {:>5} {:>12} {:>6}",
            "channel", "teeth", "period meas", "r"
        );
        for k in 1..=flutes {
            let _ = write!(head, " {:>18}", format!("flute {k} N (n)"));
        }
        let _ = write!(
            head,
            " {:>7} {:>8} {:>10} {:>13}",
            "asym", "F", "p", "named"
        );
        let _ = writeln!(s, "{head}");
        for c in &f.channels {
            let mut line = format!(
                "{:<12} {:>5} {:>12.0} {:>6.2}",
                c.channel, c.teeth, c.measured_period_samples, c.period_autocorrelation
            );
            for fl in &c.flutes {
                let _ = write!(
                    line,
                    " {:>18}",
                    format!("{:.2} ± {:.2} ({})", fl.mean_n, fl.sd_n, fl.peaks_n.len())
                );
            }
            let _ = write!(
                line,
                " {:>7} {:>8.2} {:>10.3e} {:>13}",
                pct(c.asymmetry),
                c.f_statistic,
                c.p_value,
                c.named
            );
            let _ = writeln!(s, "{line}");
        }
        for n in &f.notes {
            let _ = writeln!(s, "note: {n}");
        }
    }
    let _ = writeln!(
        s,
        "(asym = (largest − smallest flute mean)/mean; F, p: one-way ANOVA of the tooth peaks by flute; named flute_runout when p < alpha)"
    );
    s
}

/// Per file and channel: the force trace with each flute's tooth peaks.
pub fn flute_plots(dir: &Path, files: &[FluteFile]) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut out = Vec::new();
    for f in files {
        let stem = Path::new(&f.input.path)
            .file_stem()
            .map_or_else(|| "record".into(), |s| s.to_string_lossy().into_owned());
        for (c, trace) in f.channels.iter().zip(&f.traces) {
            let mut series = vec![Series {
                label: c.channel.clone(),
                points: trace
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (i as f64, v))
                    .collect(),
            }];
            for fl in &c.flutes {
                series.push(Series {
                    label: format!("flute {} mean peak {:.2} N", fl.flute, fl.mean_n),
                    points: vec![(0.0, fl.mean_n), ((trace.len() - 1) as f64, fl.mean_n)],
                });
            }
            let p = dir.join(format!("flutes_{stem}_{}.svg", c.channel));
            line_plot(
                &p,
                &format!("{stem} {}: per-flute mean peaks", c.channel),
                "sample",
                "force (N)",
                &series,
            )?;
            out.push(p);
        }
    }
    Ok(out)
}

/// A record diagnosis as text, in the groove diagnosis' layout.
pub fn diagnose_text(
    info: &InputInfo,
    reports: &[millcomp_diagnose::record::RecordReport],
) -> String {
    let mut s = String::new();
    for r in reports {
        let u = if r.unit == "um" {
            "µm".to_string()
        } else {
            r.unit.to_uppercase()
        };
        let _ = writeln!(
            s,
            "diagnose record: {}\nsignal `{}`, {} rows, alpha {} ({})",
            info.line(),
            r.signal,
            r.n_rows,
            r.alpha,
            r.correction
        );
        let _ = writeln!(s, "nominal: {}", r.nominal);
        let _ = writeln!(s, "RMS residual: nominal {:.3} {u}", r.initial_rms);
        let _ = writeln!(
            s,
            "nuisance step: level recalibrated to {:.4} {u}, RMS {:.3} {u}",
            r.nuisance.level, r.nuisance.rms_after
        );
        for (e, n) in &r.skipped {
            let _ = writeln!(s, "not testable: {e}: {n}");
        }
        for (k, round) in r.rounds.iter().enumerate() {
            let _ = writeln!(
                s,
                "round {} (threshold p < {:.3e}):",
                k + 1,
                round.threshold
            );
            for d in &round.tested {
                let _ = writeln!(
                    s,
                    "  {:<24} {:<58} F({},{:.0}) = {:>10.2}  p = {:>9.2e}  dBIC = {:>9.1}  n_eff {:>6.0}  RMS {:.3} {u}{}",
                    d.effect,
                    d.family.chars().take(58).collect::<String>(),
                    d.df1,
                    d.df2,
                    d.f_statistic,
                    d.p_value,
                    d.bic_after - d.bic_before,
                    d.n_eff,
                    d.rms_after,
                    if round.added_family.as_deref() == Some(d.family.as_str()) && d.significant {
                        "  <- added"
                    } else {
                        ""
                    }
                );
            }
        }
        for st in &r.steps {
            let _ = writeln!(
                s,
                "step: {} [{}] (p = {:.2e}), RMS {:.3} → {:.3} {u}",
                st.effect, st.family, st.p_value, st.rms_before, st.rms_after
            );
            for (k, v) in &st.params {
                let ci = st.ci95.get(k).copied().unwrap_or([f64::NAN; 2]);
                let _ = writeln!(s, "  {k} = {v:.5}  [{:.5}, {:.5}]", ci[0], ci[1]);
            }
            if !st.aliases.is_empty() {
                let _ = writeln!(s, "  aliased with: {}", st.aliases.join("; "));
            }
            for w in &st.warnings {
                let _ = writeln!(s, "  warning: {w}");
            }
        }
        if let Some(f) = &r.flute_channel {
            let _ = writeln!(
                s,
                "flute channel: {} flutes, asymmetry {}, F({},{}) = {:.2}, p = {:.2e}{}",
                f.channels.len(),
                pct(f.asymmetry),
                f.df[0],
                f.df[1],
                f.f_statistic,
                f.p_value,
                if f.significant {
                    " -> flute_runout"
                } else {
                    ""
                }
            );
        }
        let _ = writeln!(
            s,
            "named: {}   RMS {:.3} → {:.3} → {:.3} {u} (nominal → nuisance → final; {} of the gap after the nuisance step closed)",
            r.named.join(", "),
            r.initial_rms,
            r.nuisance.rms_after,
            r.final_rms,
            pct(r.shrink_after_nuisance)
        );
        for n in &r.notes {
            let _ = writeln!(s, "note: {n}");
        }
        let _ = writeln!(s);
    }
    s
}

/// Per signal: measured, the prediction after the nuisance step and after each step.
pub fn diagnose_plots(
    dir: &Path,
    x: Option<(&str, &[f64])>,
    reports: &[millcomp_diagnose::record::RecordReport],
    info: &InputInfo,
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = file_stem(info);
    let mut out = Vec::new();
    for r in reports {
        let xs: Vec<f64> = match x {
            Some((_, v)) => v.to_vec(),
            None => (0..r.measured.len()).map(|i| i as f64).collect(),
        };
        let pts = |v: &[f64]| -> Vec<(f64, f64)> {
            thin(
                xs.iter().copied().zip(v.iter().copied()).collect(),
                PLOT_POINTS,
            )
        };
        let mut series = vec![Series {
            label: "measured".into(),
            points: pts(&r.measured),
        }];
        for (k, p) in r.predictions.iter().enumerate() {
            series.push(Series {
                label: if k == 0 {
                    "nominal, level recalibrated".into()
                } else {
                    let st = &r.steps[k - 1];
                    format!(
                        "+ {} ({})",
                        st.effect,
                        st.family.split(' ').next().unwrap_or("")
                    )
                },
                points: pts(p),
            });
        }
        let p = dir.join(format!("diagnose_{}.svg", r.signal));
        line_plot(
            &p,
            &format!("{file} {}: measured vs the model after each step", r.signal),
            if x.is_some() {
                "time (s) or cut"
            } else {
                "row"
            },
            &r.signal,
            &series,
        )?;
        out.push(p);
    }
    Ok(out)
}
