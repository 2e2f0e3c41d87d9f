//! Stages 1–5: the calibration design, its measurement, its analysis, the identification of the models
//! and the commissioning of the bundles.

use std::path::{Path, PathBuf};

use millcomp_closedloop::commissioning::{
    CommissioningPlan, ForceTraces, identify_force_traces, identify_hysteresis_sweep,
    identify_load_deflection, identify_step_test, sensor_noise_at_rest,
};
use millcomp_datasets::{Column, ColumnData, Table};
use millcomp_doe::{
    AnalysisInput, DesignKind, DesignRequest, FactorSpec, ModelSpec, Values, generate,
    resolution_roman,
};
use millcomp_identify::targets::Identified;
use millcomp_models::{
    ForceModelParams, IdentifiedModel, ModelBundle, ModelFile, SensorNoise, SpindleModel,
};
use millcomp_mpc::identified::{IdentifiedForceModel, NominalTool};
use millcomp_sim::force::CutConditions;
use statrs::distribution::{ContinuousCDF, Normal};

use crate::ctx::{Ctx, f, fp};
use crate::error::{PipelineError, Result};
use crate::files;
use crate::report::Section;
use crate::svg::{Chart, Mark, RefLine, Series};

/// The calibration's factor columns, in order.
const CAL_FACTORS: [&str; 5] = ["depth_um", "upfeed_um", "speed_rpm", "tilt_deg", "material"];

fn values_column(name: &str, v: &Values) -> Column {
    Column {
        name: name.to_string(),
        data: match v {
            Values::F64(x) => ColumnData::Float(x.clone()),
            Values::I64(x) => ColumnData::Int(x.clone()),
            Values::Str(x) => ColumnData::Text(x.clone()),
        },
    }
}

/// A generated design as a table: `run_order`, `std_order`, the factors (actual levels); and the design
/// itself (for its resolution and aliases).
pub(crate) fn design_table(
    factors: &str,
    resolution: u32,
    seed: u64,
    origin: &str,
) -> Result<(millcomp_doe::Design, Vec<Column>)> {
    let factors = FactorSpec::parse_list(factors)?;
    let k = factors.len();
    let mut req = DesignRequest::new(
        if k <= 3 {
            DesignKind::Full
        } else {
            DesignKind::Fractional
        },
        factors,
    );
    if k > 3 {
        req.resolution = Some(resolution);
    }
    req.seed = Some(seed);
    let d = generate(&req)?;
    let mut cols = Vec::new();
    for (name, v) in d.columns() {
        if name == "block" || name.ends_with("_coded") {
            continue;
        }
        cols.push(values_column(&name, &v));
    }
    let _ = origin;
    Ok((d, cols))
}

/// The design in words: family, runs, resolution, generators.
pub(crate) fn describe_design(d: &millcomp_doe::Design) -> String {
    let k = d.factors.len();
    match d.resolution {
        Some(r) => format!(
            "2^({k}−{}) fraction of resolution {} ({} runs), generators {}",
            d.generators.len(),
            resolution_roman(r),
            d.n_runs(),
            d.generators.join(", ")
        ),
        None => format!("full factorial 2^{k} ({} runs)", d.n_runs()),
    }
}

/// The alias structure as lines `term = aliases` (main effects and two-factor interactions with an
/// alias of order ≤ 3), or a note that none is aliased below order 4.
pub(crate) fn aliases(d: &millcomp_doe::Design) -> Vec<String> {
    let v: Vec<String> = d
        .alias_structure
        .iter()
        .map(|a| format!("{} = {}", a.term, a.aliases.join(" = ")))
        .collect();
    if v.is_empty() {
        vec![format!(
            "no main effect or two-factor interaction is aliased with an effect of order ≤ 3 (defining relation {})",
            d.defining_relation.join(", ")
        )]
    } else {
        v
    }
}

/// Stage `design`: the calibration cuts as a design of experiments.
pub(crate) fn design(cx: &mut Ctx<'_>) -> Result<()> {
    let t0 = cx.start("design");
    let spec = &cx.plan.design;
    let (d, cols) = design_table(
        &spec.factors,
        spec.resolution,
        cx.plan.seed,
        "calibration design",
    )?;
    let csv = cx.path("design/calibration_doe.csv");
    files::write_columns(&csv, "calibration design", cols)?;
    let json = cx.path("design/calibration_doe.json");
    files::write_text(&json, &serde_json::to_string_pretty(&d)?)?;
    let al = aliases(&d);
    let summary = format!(
        "calibration cuts: {} over {}, in random order (seed {}); {}",
        describe_design(&d),
        d.factor_names().join(", "),
        d.seed,
        if d.resolution.is_some() {
            format!("aliases: {}", al.join("; "))
        } else {
            "no aliases".into()
        }
    );
    let mut s = Section::new("1. Design: the calibration cuts", "stage-design");
    s.para(format!(
        "The force calibration as a designed experiment: a {} over `{}`, {} revolutions per cut at {} \
         samples each. Every main effect and two-factor interaction of the force is estimable; the \
         alias structure (main effects and two-factor interactions aliased with effects of order ≤ 3):",
        describe_design(&d),
        spec.factors,
        spec.revolutions,
        spec.samples_per_rev
    ));
    s.list(al.iter().map(|a| format!("`{a}`")).collect());
    s.para(format!(
        "Defining relation `{}`. Runs: `{}` (design: `{}`).",
        d.defining_relation.join(", "),
        cx.rel(&csv),
        cx.rel(&json)
    ));
    cx.section(s);
    cx.chain.ran(
        "design",
        "",
        &[],
        &[csv, json],
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// The measured files' roles, their file names and what they hold.
const ROLES: [(&str, &str, &str); 5] = [
    (
        "forces",
        "calibration_forces",
        "force calibration traces: run, material, depth_um, upfeed_um, speed_rpm, tilt_deg, rot_deg, fz_n",
    ),
    (
        "spindle_step",
        "spindle_step",
        "the spindle's step test in air: t_s, u_v, y_um",
    ),
    (
        "hysteresis_sweep",
        "hysteresis_sweep",
        "a quasi-static sweep of the stack in air: u_v, y_um",
    ),
    (
        "load_deflection",
        "load_deflection",
        "the load-deflection test: load_n, deflection_um, direction",
    ),
    (
        "sensors_at_rest",
        "sensors_at_rest",
        "the sensors at rest: t_s, force_n, gauge_um",
    ),
];

/// Stage `measure`: the calibration on the simulated machine's instruments, or the plan's files
/// imported (copied, hashes unchanged).
pub(crate) fn measure(cx: &mut Ctx<'_>) -> Result<()> {
    let t0 = cx.start("measure");
    let m = &cx.plan.measure;
    let given: [(&str, Option<&PathBuf>); 5] = [
        ("forces", m.forces.as_ref()),
        ("spindle_step", m.spindle_step.as_ref()),
        ("hysteresis_sweep", m.hysteresis_sweep.as_ref()),
        ("load_deflection", m.load_deflection.as_ref()),
        ("sensors_at_rest", m.sensors_at_rest.as_ref()),
    ];
    let (mut inputs, mut outputs, mut notes) = (Vec::new(), Vec::new(), Vec::new());
    let plan = CommissioningPlan::default();
    let design_csv = cx.path("design/calibration_doe.csv");
    for ((role, file), (_, name, what)) in given.iter().zip(ROLES) {
        if let Some(src) = file {
            let ext = src
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("csv")
                .to_string();
            let dst = cx.path(&format!("measured/{name}.{ext}"));
            if let Some(dir) = dst.parent() {
                std::fs::create_dir_all(dir).map_err(|e| PipelineError::io(dir, "creating", e))?;
            }
            std::fs::copy(src, &dst).map_err(|e| PipelineError::io(src, "reading", e))?;
            inputs.push(std::fs::canonicalize(src).unwrap_or_else(|_| (*src).clone()));
            outputs.push(dst.clone());
            cx.measured.insert(role, dst);
            continue;
        }
        let Some(machine) = cx.machine.as_ref() else {
            notes.push(format!(
                "no `{role}` file: {what} (plan key measure.{role})"
            ));
            continue;
        };
        let dst = cx.path(&format!("measured/{name}.csv"));
        match *role {
            "forces" => {
                if !design_csv.exists() {
                    notes.push("no calibration design to cut".into());
                    continue;
                }
                let t = millcomp_datasets::read_any(&design_csv)?;
                let col = |n: &str| t.f64s(n);
                let (dep, up, sp, ti) = (
                    col("depth_um")?,
                    col("upfeed_um")?,
                    col("speed_rpm")?,
                    col("tilt_deg")?,
                );
                let mat = t
                    .strings("material")
                    .unwrap_or_else(|_| vec!["S7".into(); dep.len()]);
                let order = t.f64s("run_order")?;
                let mut rows: Vec<(f64, usize)> =
                    order.iter().enumerate().map(|(i, o)| (*o, i)).collect();
                rows.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut per_run = Vec::new();
                for (k, &(_, i)) in rows.iter().enumerate() {
                    let cond = CutConditions::new(dep[i], up[i], sp[i], ti[i])?;
                    let mut tr = machine.force_calibration(
                        &mat[i],
                        &[cond],
                        cx.plan.design.revolutions,
                        cx.plan.design.samples_per_rev,
                        cx.seed(0xf0 + k as u64),
                    )?;
                    tr.run = vec![k; tr.fz_n.len()];
                    per_run.push((mat[i].clone(), tr));
                }
                files::write_forces(&dst, &per_run)?;
                inputs.push(design_csv.clone());
            }
            "spindle_step" => files::write_step(&dst, &machine.step_test(&plan, cx.seed(1))?)?,
            "hysteresis_sweep" => {
                files::write_sweep(&dst, &machine.hysteresis_sweep(&plan, cx.seed(2))?)?
            }
            "load_deflection" => {
                files::write_load(&dst, &machine.load_deflection(&plan.stiffness, cx.seed(3))?)?
            }
            _ => files::write_rest(
                &dst,
                &machine.sensors_at_rest(plan.noise_samples, plan.step_dt_s, cx.seed(4))?,
            )?,
        }
        outputs.push(dst.clone());
        cx.measured.insert(role, dst);
    }
    if outputs.is_empty() {
        cx.chain.skipped(
            "measure",
            format!(
                "skipped: no measured file and no simulated machine; it needs {}",
                notes.join("; ")
            ),
        );
        let mut s = Section::new("2. Measure", "stage-measure");
        s.para("Skipped: the plan gives no calibration file.");
        s.list(notes);
        cx.section(s);
        return Ok(());
    }
    let mut summary = format!(
        "{} calibration records from the {}: {}",
        outputs.len(),
        cx.source(),
        outputs
            .iter()
            .map(|p| cx.rel(p))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if !notes.is_empty() {
        summary.push_str(&format!("; missing: {}", notes.join("; ")));
    }
    let mut s = Section::new("2. Measure", "stage-measure");
    s.para(match &cx.machine {
        Some(_) => format!(
            "Measured on the {}: the cuts of the design on the dynamometer (the force sensor zeroed before \
             each cut, its gain and drift, 0.04 N noise and quantisation), the spindle's step test and a \
             hysteresis sweep on the capacitance gauge, hanging masses on the dial indicator, and the \
             sensors at rest.",
            cx.source()
        ),
        None => "Your calibration records, copied into the output directory with their SHA-256 \
                 (`pipeline.json`)."
            .into(),
    });
    s.table(
        &["record", "file", "what it holds"],
        ROLES
            .iter()
            .filter_map(|(role, _, what)| {
                cx.measured.get(role).map(|p| {
                    vec![
                        role.to_string(),
                        format!("`{}`", cx.rel(p)),
                        what.to_string(),
                    ]
                })
            })
            .collect(),
        &outputs.iter().map(|p| cx.rel(p)).collect::<Vec<_>>(),
    );
    if !notes.is_empty() {
        s.para("Not given:");
        s.list(notes);
    }
    cx.section(s);
    cx.chain.ran(
        "measure",
        &cx.source(),
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// Each calibration cut's largest averaged z-force with its conditions.
struct Maxima {
    factors: Vec<(String, Values)>,
    max_fz: Vec<f64>,
    material: Vec<String>,
}

fn maxima(per_material: &[(String, ForceTraces)]) -> Maxima {
    let mut runs: std::collections::BTreeMap<usize, (String, [f64; 4], f64)> = Default::default();
    for (m, t) in per_material {
        for i in 0..t.fz_n.len() {
            let e = runs.entry(t.run[i]).or_insert((
                m.clone(),
                [t.depth_um[i], t.upfeed_um[i], t.speed_rpm[i], t.tilt_deg[i]],
                f64::NEG_INFINITY,
            ));
            e.2 = e.2.max(t.fz_n[i]);
        }
    }
    let vals: Vec<&(String, [f64; 4], f64)> = runs.values().collect();
    let mut factors = Vec::new();
    for (j, name) in CAL_FACTORS[..4].iter().enumerate() {
        factors.push((
            name.to_string(),
            Values::F64(vals.iter().map(|v| v.1[j]).collect()),
        ));
    }
    let material: Vec<String> = vals.iter().map(|v| v.0.clone()).collect();
    factors.push(("material".into(), Values::Str(material.clone())));
    Maxima {
        factors,
        max_fz: vals.iter().map(|v| v.2).collect(),
        material,
    }
}

fn varies(v: &Values) -> bool {
    match v {
        Values::F64(x) => x.iter().any(|a| (a - x[0]).abs() > 1e-12),
        Values::I64(x) => x.iter().any(|a| *a != x[0]),
        Values::Str(x) => x.iter().any(|a| *a != x[0]),
    }
}

/// Stage `analyse`: the force maxima's effects (half-normal plot with Lenth's margins) and ANOVA.
pub(crate) fn analyse(cx: &mut Ctx<'_>) -> Result<()> {
    let Some(forces) = cx.measured.get("forces").cloned() else {
        cx.chain.skipped(
            "analyse",
            "skipped: needs the force calibration traces (measure.forces)".into(),
        );
        return Ok(());
    };
    let t0 = cx.start("analyse");
    let per = files::read_forces(&forces)?;
    let mx = maxima(&per);
    let mut table_cols: Vec<Column> = mx
        .factors
        .iter()
        .map(|(n, v)| values_column(n, v))
        .collect();
    table_cols.push(Column {
        name: "max_fz_n".into(),
        data: ColumnData::Float(mx.max_fz.clone()),
    });
    let maxima_csv = cx.path("analysis/force_maxima.csv");
    files::write_columns(&maxima_csv, "force maxima", table_cols)?;
    let mut cols: Vec<(String, Values)> = mx
        .factors
        .iter()
        .filter(|(_, v)| varies(v))
        .cloned()
        .collect();
    let names: Vec<String> = cols.iter().map(|(n, _)| n.clone()).collect();
    cols.push(("max_fz_n".into(), Values::F64(mx.max_fz.clone())));
    let effects_in =
        AnalysisInput::from_table(&cols, "max_fz_n", Some(names.as_slice()), ModelSpec::TwoFi)?;
    let effects = millcomp_doe::analyze(&effects_in)?;
    let main_in =
        AnalysisInput::from_table(&cols, "max_fz_n", Some(names.as_slice()), ModelSpec::Main)?;
    let anova = millcomp_doe::analyze(&main_in)?;
    let anova_csv = cx.path("analysis/anova.csv");
    let rows = &anova.terms;
    files::write_columns(
        &anova_csv,
        "anova",
        vec![
            Column {
                name: "term".into(),
                data: ColumnData::Text(rows.iter().map(|t| t.term.clone()).collect()),
            },
            Column {
                name: "effect_n".into(),
                data: ColumnData::Float(
                    rows.iter().map(|t| t.effect.unwrap_or(f64::NAN)).collect(),
                ),
            },
            Column {
                name: "f".into(),
                data: ColumnData::Float(rows.iter().map(|t| t.f.unwrap_or(f64::NAN)).collect()),
            },
            Column {
                name: "p_value".into(),
                data: ColumnData::Float(
                    rows.iter().map(|t| t.p_value.unwrap_or(f64::NAN)).collect(),
                ),
            },
        ],
    )?;
    let effects_csv = cx.path("analysis/effects.csv");
    let eff: Vec<(String, f64)> = effects
        .terms
        .iter()
        .filter_map(|t| t.effect.map(|e| (t.term.clone(), e)))
        .collect();
    files::write_columns(
        &effects_csv,
        "effects",
        vec![
            Column {
                name: "term".into(),
                data: ColumnData::Text(eff.iter().map(|e| e.0.clone()).collect()),
            },
            Column {
                name: "effect_n".into(),
                data: ColumnData::Float(eff.iter().map(|e| e.1).collect()),
            },
        ],
    )?;
    // half-normal plot: |effects| against half-normal quantiles, Lenth's ME and SME
    let mut sorted: Vec<(String, f64)> = eff.iter().map(|(n, e)| (n.clone(), e.abs())).collect();
    sorted.sort_by(|a, b| a.1.total_cmp(&b.1));
    let m = sorted.len();
    let z = Normal::new(0.0, 1.0).map_err(|e| PipelineError::Plot {
        name: "half-normal".into(),
        message: e.to_string(),
    })?;
    let q: Vec<f64> = (0..m)
        .map(|i| z.inverse_cdf(0.5 + 0.5 * (i as f64 + 0.5) / m as f64))
        .collect();
    let lenth = effects.lenth.clone().or_else(|| {
        millcomp_doe::lenth(
            &eff.iter().map(|e| e.0.clone()).collect::<Vec<_>>(),
            &eff.iter().map(|e| e.1).collect::<Vec<_>>(),
        )
    });
    let mut chart = Chart {
        title: format!(
            "Half-normal plot of the force maxima's effects{}",
            cx.sim_tag()
        ),
        x_label: "|effect| on the largest z-force (N)".into(),
        y_label: "half-normal quantile".into(),
        series: vec![Series::new(
            "effects (main and two-factor)",
            sorted.iter().map(|s| s.1).collect(),
            q.clone(),
            Mark::Points,
            0,
        )],
        legend_lower_right: true,
        ..Default::default()
    };
    let mut active = Vec::new();
    if let Some(l) = &lenth {
        chart
            .lines
            .push(RefLine::V(l.me, format!(" ME {:.2} N", l.me)));
        chart
            .lines
            .push(RefLine::V(l.sme, format!(" SME {:.2} N", l.sme)));
        for (i, (n, e)) in sorted.iter().enumerate() {
            if *e > l.me {
                chart.labels.push((*e, q[i], format!(" {n}")));
                active.push(format!(
                    "{n} ({})",
                    if *e > l.sme { "> SME" } else { "> ME" }
                ));
            }
        }
    }
    let (fig, svg) = cx.figure(
        "half_normal",
        &chart,
        format!(
            "Half-normal plot of the {} effects of the calibration cuts' largest z-force{}, with Lenth's margin \
             of error (ME, individual 5 %) and simultaneous margin (SME).",
            m,
            cx.sim_tag()
        ),
        &[&maxima_csv],
    )?;
    let significant: Vec<String> = anova
        .terms
        .iter()
        .filter(|t| t.p_value.is_some_and(|p| p < 0.05))
        .map(|t| t.term.clone())
        .collect();
    let summary = format!(
        "{} cuts; main-effects ANOVA of the largest z-force: significant at 5 % {} (R² {:.3}); Lenth on the \
         {} effects: {}",
        mx.max_fz.len(),
        if significant.is_empty() {
            "none".into()
        } else {
            significant.join(", ")
        },
        anova.r_squared,
        m,
        if active.is_empty() {
            "none beyond ME".into()
        } else {
            active.join(", ")
        }
    );
    let mut s = Section::new("3. Analyse: what moves the force", "stage-analyse");
    s.para(format!(
        "The largest synchronously averaged z-force of each cut{} (`{}`), analysed as the design's response. \
         ANOVA of the main effects (type II; {} residual degrees of freedom, R² = {:.3}):",
        cx.sim_tag(),
        cx.rel(&maxima_csv),
        anova.residual_df,
        anova.r_squared
    ));
    s.table(
        &["term", "effect (N)", "F", "p-value"],
        anova
            .terms
            .iter()
            .map(|t| {
                vec![
                    format!("`{}`", t.term),
                    t.effect.map_or("–".into(), |e| f(e, 3)),
                    t.f.map_or("–".into(), |x| f(x, 2)),
                    fp(t.p_value),
                ]
            })
            .collect(),
        &[cx.rel(&anova_csv)],
    );
    if let Some(l) = &lenth {
        s.para(format!(
            "The saturated model of main effects and two-factor interactions (`{}`): Lenth's PSE {:.3} N, \
             ME {:.3} N, SME {:.3} N; beyond ME: {}.",
            cx.rel(&effects_csv),
            l.pse,
            l.me,
            l.sme,
            if active.is_empty() {
                "none".into()
            } else {
                active.join(", ")
            }
        ));
    }
    s.figure(fig);
    let _ = &mx.material;
    cx.section(s);
    cx.chain.ran(
        "analyse",
        "",
        &[forces],
        &[maxima_csv, anova_csv, effects_csv, svg],
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// Creates the directory of `path`.
pub(crate) fn parent_dir(path: &Path) -> Result<()> {
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d).map_err(|e| PipelineError::io(d, "creating", e))?;
    }
    Ok(())
}

fn save(cx: &Ctx<'_>, fit: &Identified, kind: &str, path: &Path, inputs: &[&Path]) -> Result<()> {
    parent_dir(path)?;
    ModelFile::new(kind, fit.model.clone(), cx.provenance(inputs)?).save(path)?;
    Ok(())
}

fn param_rows(name: &str, fit: &Identified) -> Vec<Vec<String>> {
    fit.report
        .params
        .iter()
        .map(|(p, v)| {
            let ci = fit.report.ci95.get(p).copied().unwrap_or([f64::NAN; 2]);
            vec![
                name.to_string(),
                format!("`{p}`"),
                format!("{v:.5}"),
                format!("[{:.5}, {:.5}]", ci[0], ci[1]),
            ]
        })
        .collect()
}

/// Stage `identify`: force model (per material), spindle, stiffness, hysteresis and the sensors' noise,
/// each from its measured file, saved as model files whose provenance holds that file's SHA-256.
pub(crate) fn identify(cx: &mut Ctx<'_>) -> Result<()> {
    if cx.measured.is_empty() {
        cx.chain.skipped(
            "identify",
            "skipped: needs calibration records (measure.forces, measure.spindle_step, \
             measure.load_deflection, measure.hysteresis_sweep, measure.sensors_at_rest)"
                .into(),
        );
        return Ok(());
    }
    let t0 = cx.start("identify");
    let (mut inputs, mut outputs, mut rows, mut notes) = (vec![], vec![], vec![], vec![]);
    let mut figures = Vec::new();
    let dir = cx.path("models");
    if let Some(p) = cx.measured.get("forces").cloned() {
        let per = files::read_forces(&p)?;
        for (material, traces) in &per {
            let tilt = traces.tilt_deg.first().copied().unwrap_or(20.0);
            let fit = identify_force_traces(traces, material, &cx.plan.identify.force_free, tilt)?;
            let out = dir.join(format!("force_{material}.toml"));
            save(cx, &fit, &fit.kind, &out, &[&p])?;
            rows.extend(param_rows(&format!("force ({material})"), &fit));
            notes.extend(
                fit.report
                    .warnings
                    .iter()
                    .map(|w| format!("force ({material}): {w}")),
            );
            cx.models.insert(format!("force_{material}"), out.clone());
            outputs.push(out);
        }
        let (fig, svg) = force_fit_figure(cx, &per, &p)?;
        figures.push(fig);
        outputs.push(svg);
        inputs.push(p);
    }
    if let Some(p) = cx.measured.get("spindle_step").cloned() {
        let rec = files::read_step(&p)?;
        let (fit, bics, _) = identify_step_test(&rec, None)?;
        let out = dir.join("spindle.toml");
        save(cx, &fit, &fit.kind, &out, &[&p])?;
        rows.extend(param_rows("spindle", &fit));
        notes.push(format!(
            "spindle: structures by BIC {}",
            bics.iter()
                .map(|(n, b)| format!("{n} {b:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        let (fig, svg) = spindle_fit_figure(cx, &rec, &fit, &p)?;
        figures.push(fig);
        outputs.push(svg);
        cx.models.insert("spindle".into(), out.clone());
        outputs.push(out);
        inputs.push(p);
    }
    if let Some(p) = cx.measured.get("load_deflection").cloned() {
        let rec = files::read_load(&p)?;
        let fit = identify_load_deflection(&rec, &[20.0, 40.0])?;
        let out = dir.join("stiffness.toml");
        save(cx, &fit, &fit.kind, &out, &[&p])?;
        rows.extend(param_rows("stiffness", &fit));
        cx.models.insert("stiffness".into(), out.clone());
        outputs.push(out);
        inputs.push(p);
    }
    if let Some(p) = cx.measured.get("hysteresis_sweep").cloned() {
        let rec = files::read_sweep(&p)?;
        let fit = identify_hysteresis_sweep(&rec)?;
        let out = dir.join("hysteresis.toml");
        save(cx, &fit, &fit.kind, &out, &[&p])?;
        notes.push(format!(
            "hysteresis: a Prandtl–Ishlinskii model of {} plays, rms residual {:.3} µm (its intervals are not \
             claimed: the residuals along the sweep are correlated)",
            fit.report.params.len().saturating_sub(1),
            fit.report.rms_residual.value
        ));
        cx.models.insert("hysteresis".into(), out.clone());
        outputs.push(out);
        inputs.push(p);
    }
    if let Some(p) = cx.measured.get("sensors_at_rest").cloned() {
        let rec = files::read_rest(&p)?;
        let noise = sensor_noise_at_rest(&rec)?;
        let out = dir.join("sensor_noise.toml");
        parent_dir(&out)?;
        ModelFile::new("sensor_noise", noise.model.clone(), cx.provenance(&[&p])?).save(&out)?;
        for (k, v) in &noise.model.params {
            let ci = noise.ci95.get(k).copied().unwrap_or([f64::NAN; 2]);
            rows.push(vec![
                "sensors at rest".into(),
                format!("`{k}`"),
                format!("{v:.5}"),
                format!("[{:.5}, {:.5}]", ci[0], ci[1]),
            ]);
        }
        cx.models.insert("sensor_noise".into(), out.clone());
        outputs.push(out);
        inputs.push(p);
    }
    let summary = format!(
        "{} model files with 95 % intervals ({}); each one's provenance holds the SHA-256 of the file it was \
         fitted to",
        cx.models.len(),
        cx.models.keys().cloned().collect::<Vec<_>>().join(", ")
    );
    let mut s = Section::new("4. Identify: the models, with intervals", "stage-identify");
    s.para(format!(
        "Each model fitted by least squares to its measured file only, starting from the catalogue (the \
         published material, the catalogue tool), and saved in the common model-file format with the \
         SHA-256 of that file in its provenance (`{}`). Estimates and 95 % intervals{}:",
        cx.rel(&dir),
        cx.sim_tag()
    ));
    s.table(
        &["model", "parameter", "estimate", "95 % interval"],
        rows,
        &cx.models.values().map(|p| cx.rel(p)).collect::<Vec<_>>(),
    );
    if !notes.is_empty() {
        s.list(notes);
    }
    for fig in figures {
        s.figure(fig);
    }
    cx.section(s);
    cx.chain.ran(
        "identify",
        "",
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// The spindle's step response: measured, fitted, and the fit's 95 % confidence band (delta method on
/// the parameters' covariance).
fn spindle_fit_figure(
    cx: &Ctx<'_>,
    rec: &millcomp_closedloop::commissioning::StepRecord,
    fit: &Identified,
    source: &Path,
) -> Result<(crate::report::Figure, PathBuf)> {
    use millcomp_identify::targets::spindle::{SpindleData, SpindleResponse};
    use nalgebra::DVector;
    let data = SpindleData {
        t_s: &rec.t_s,
        u_v: &rec.u_v,
        y_um: &rec.y_um,
    };
    let r = &fit.report;
    let pole = r.params.contains_key("pole_rad_s");
    let dead = r.params.contains_key("dead_time_s");
    let op = SpindleResponse::new(&data, pole, dead, Default::default());
    let names = op.param_names();
    let p = DVector::from_iterator(names.len(), names.iter().map(|n| r.param(n)));
    let sim = |p: &DVector<f64>| op.simulate(p).ok();
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    let fitted = sim(&p);
    if let Some(y) = &fitted {
        // Jacobian by central differences, band ±1.96 √(g' C g)
        let mut cols = Vec::new();
        for (j, n) in names.iter().enumerate() {
            let h = 1e-6 * p[j].abs().max(1e-6);
            let (mut a, mut b) = (p.clone(), p.clone());
            a[j] += h;
            b[j] -= h;
            match (sim(&a), sim(&b)) {
                (Some(ya), Some(yb)) => cols.push((n.clone(), (ya - yb) / (2.0 * h))),
                _ => cols.push((n.clone(), DVector::zeros(y.len()))),
            }
        }
        for i in 0..y.len() {
            let mut var = 0.0;
            for (a, ga) in &cols {
                for (b, gb) in &cols {
                    let c = r.covariance.get(a, b).unwrap_or(0.0);
                    var += ga[i] * c * gb[i];
                }
            }
            let half = 1.96 * var.max(0.0).sqrt();
            lo.push(y[i] - half);
            hi.push(y[i] + half);
        }
    }
    let t_ms: Vec<f64> = rec.t_s.iter().map(|t| 1e3 * t).collect();
    let mut series = vec![Series::new(
        "measured (gauge)",
        t_ms.clone(),
        rec.y_um.clone(),
        Mark::Points,
        7,
    )];
    if let Some(y) = fitted {
        series.push(Series::new(
            "95 % band of the fit",
            t_ms.clone(),
            y.iter().copied().collect(),
            Mark::Band { lo, hi },
            0,
        ));
        series.push(Series::new(
            "fitted",
            t_ms,
            y.iter().copied().collect(),
            Mark::Line,
            0,
        ));
    }
    let chart = Chart {
        title: format!("Spindle step test: measured and fitted{}", cx.sim_tag()),
        x_label: "time (ms)".into(),
        y_label: "tool tip (µm, gauge)".into(),
        series,
        ..Default::default()
    };
    cx.figure(
        "fit_spindle",
        &chart,
        format!(
            "The spindle's step response as the gauge measured it{} and as fitted ({}), with the fit's 95 % \
             confidence band (delta method on the parameters' covariance); rms residual {:.4} µm.",
            cx.sim_tag(),
            r.model,
            r.rms_residual.value
        ),
        &[source],
    )
}

/// Each cut's largest z-force: measured and predicted by the identified force model, with the
/// prediction's 95 % interval from the fitted parameters' covariance.
fn force_fit_figure(
    cx: &Ctx<'_>,
    per: &[(String, ForceTraces)],
    source: &Path,
) -> Result<(crate::report::Figure, PathBuf)> {
    let mut series = Vec::new();
    let mut x = 1.0;
    for (k, (material, tr)) in per.iter().enumerate() {
        let Some(path) = cx.models.get(&format!("force_{material}")) else {
            continue;
        };
        let file = ModelFile::<IdentifiedModel>::load(path, &ForceModelParams::KINDS)?;
        let params = ForceModelParams::from_identified(&file.model, path)?;
        let tool = NominalTool::thesis_ball_end(material);
        let peak = |p: &ForceModelParams, c: &CutConditions| -> Result<f64> {
            Ok(IdentifiedForceModel::new(p, &tool)?
                .model()
                .peak_z_force_n(c)?)
        };
        let mut runs: Vec<usize> = tr.run.clone();
        runs.dedup();
        let (mut xs, mut meas, mut pred, mut lo, mut hi) = (vec![], vec![], vec![], vec![], vec![]);
        for r in runs {
            let idx: Vec<usize> = (0..tr.run.len()).filter(|&i| tr.run[i] == r).collect();
            let i0 = idx[0];
            let cond = CutConditions::new(
                tr.depth_um[i0],
                tr.upfeed_um[i0],
                tr.speed_rpm[i0],
                tr.tilt_deg[i0],
            )?;
            let m = idx
                .iter()
                .map(|&i| tr.fz_n[i])
                .fold(f64::NEG_INFINITY, f64::max);
            let y = peak(&params, &cond)?;
            let mut grads = Vec::new();
            for (name, v) in &params.fitted {
                let h = 1e-5 * v.abs().max(1e-3);
                let mut a = params.clone();
                a.fitted.insert(name.clone(), v + h);
                let mut b = params.clone();
                b.fitted.insert(name.clone(), v - h);
                grads.push((
                    name.clone(),
                    (peak(&a, &cond)? - peak(&b, &cond)?) / (2.0 * h),
                ));
            }
            let mut var = 0.0;
            for (a, ga) in &grads {
                for (b, gb) in &grads {
                    var += ga * params.covariance.get(a, b).unwrap_or(0.0) * gb;
                }
            }
            let half = 1.96 * var.max(0.0).sqrt();
            xs.push(x);
            meas.push(m);
            pred.push(y);
            lo.push(y - half);
            hi.push(y + half);
            x += 1.0;
        }
        series.push(Series::new(
            &format!("predicted {material} (95 % interval)"),
            xs.iter().map(|x| x - 0.12).collect(),
            pred,
            Mark::ErrorBars { lo, hi },
            2 * k,
        ));
        series.push(Series::new(
            &format!("measured {material}"),
            xs.iter().map(|x| x + 0.12).collect(),
            meas,
            Mark::Points,
            2 * k + 1,
        ));
    }
    let chart = Chart {
        title: format!("Force calibration: largest z-force per cut{}", cx.sim_tag()),
        x_label: "calibration cut, by material (conditions: analysis/force_maxima.csv)".into(),
        y_label: "largest averaged z-force (N)".into(),
        series,
        ..Default::default()
    };
    cx.figure(
        "fit_force",
        &chart,
        format!(
            "Each calibration cut's largest z-force as measured{} and as the identified force model predicts \
             it, with the prediction's 95 % interval from the fitted parameters' covariance.",
            cx.sim_tag()
        ),
        &[source],
    )
}

/// Stage `commission`: a bundle per material from the model files.
pub(crate) fn commission(cx: &mut Ctx<'_>) -> Result<()> {
    let forces: Vec<(String, PathBuf)> = cx
        .models
        .iter()
        .filter_map(|(k, p)| k.strip_prefix("force_").map(|m| (m.to_string(), p.clone())))
        .collect();
    let (Some(spindle), Some(stiffness)) = (
        cx.models.get("spindle").cloned(),
        cx.models.get("stiffness").cloned(),
    ) else {
        cx.chain.skipped(
            "commission",
            "skipped: needs a spindle and a stiffness model (measure.spindle_step, \
             measure.load_deflection) and a force model (measure.forces)"
                .into(),
        );
        return Ok(());
    };
    if forces.is_empty() {
        cx.chain.skipped(
            "commission",
            "skipped: needs a force model (measure.forces)".into(),
        );
        return Ok(());
    }
    let t0 = cx.start("commission");
    let (mut inputs, mut outputs, mut rows) =
        (vec![spindle.clone(), stiffness.clone()], vec![], vec![]);
    let hysteresis = cx.models.get("hysteresis").cloned();
    let noise = cx.models.get("sensor_noise").cloned();
    inputs.extend(hysteresis.iter().cloned());
    inputs.extend(noise.iter().cloned());
    let mut warnings = 0;
    for (material, force) in &forces {
        let mut b =
            ModelBundle::from_files(material, Some(&spindle), Some(force), Some(&stiffness))?;
        if let Some(h) = &hysteresis {
            let f =
                ModelFile::<IdentifiedModel>::load(h, &millcomp_models::HysteresisModel::KINDS)?;
            millcomp_models::HysteresisModel::from_identified(&f.model, h)?;
            b.experiments.push(format!(
                "hysteresis: {} (`{}`)",
                cx.rel(h),
                f.header.provenance.command
            ));
            b.hysteresis = Some(f.model);
        }
        if let Some(n) = &noise {
            let f = ModelFile::<IdentifiedModel>::load(n, &SensorNoise::KINDS)?;
            SensorNoise::from_identified(&f.model, n)?;
            b.experiments.push(format!(
                "sensor_noise: {} (`{}`)",
                cx.rel(n),
                f.header.provenance.command
            ));
            b.sensor_noise = Some(f.model);
        }
        // the experiments name the model files relative to the output directory
        for e in &mut b.experiments {
            *e = e.replace(&format!("{}/", cx.opts.out.display()), "");
        }
        warnings += b.warnings.len();
        let out = cx.path(&format!("bundles/bundle_{material}.toml"));
        parent_dir(&out)?;
        let mut used: Vec<&Path> = vec![&spindle, force, &stiffness];
        if let Some(h) = &hysteresis {
            used.push(h);
        }
        if let Some(n) = &noise {
            used.push(n);
        }
        ModelFile::new("bundle", b.clone(), cx.provenance(&used)?).save(&out)?;
        let sp = b.spindle(&out, "the report")?;
        let k = b.stiffness(&out, "the report")?;
        rows.push(vec![
            material.clone(),
            format!("`{}`", cx.rel(&out)),
            format!(
                "ζ {:.3}, ωn {:.0} rad/s, gain {:.4} µm/V",
                sp.zeta, sp.wn_rad_s, sp.gain_um_per_v
            ),
            format!(
                "axial {:.3}, radial {:.4} N/µm",
                k.axial_n_per_um, k.radial_n_per_um
            ),
            b.warnings.len().to_string(),
        ]);
        inputs.push(force.clone());
        cx.bundles.insert(material.clone(), out.clone());
        outputs.push(out);
    }
    let _: Option<SpindleModel> = None;
    let summary = format!(
        "{} bundle(s) ({}) from the model files only, {warnings} identification warning(s) carried",
        cx.bundles.len(),
        cx.bundles.keys().cloned().collect::<Vec<_>>().join(", ")
    );
    let mut s = Section::new("5. Commission: the bundles", "stage-commission");
    s.para(
        "One model bundle per material — the spindle, the force model of that material, the stiffness, \
         the stack's hysteresis and the sensors' noise — assembled from the model files alone (each loaded \
         through its typed view, so a file of the wrong kind or version is refused). Every controller below \
         is built from these files and nothing else.",
    );
    s.table(
        &["material", "bundle", "spindle", "stiffness", "warnings"],
        rows,
        &outputs.iter().map(|p| cx.rel(p)).collect::<Vec<_>>(),
    );
    cx.section(s);
    cx.chain.ran(
        "commission",
        "",
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// A table read back with its origin (for readers of other stages).
pub(crate) fn read(path: &Path) -> Result<Table> {
    Ok(millcomp_datasets::read_any(path)?)
}
