//! Stages 6–8 and 12: build the controllers from the bundles, design the comparison, run (or read) it,
//! and rerun it with the corrected model.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use millcomp_closedloop::batch::exec::RunRecord;
use millcomp_closedloop::batch::factors::{FactorValue, ScenarioSpec, build_scenario};
use millcomp_closedloop::batch::paired::PairedEntry;
use millcomp_closedloop::groove::groove_program;
use millcomp_closedloop::machine::{DIAGNOSED, FIXTURE_X_MM, ORACLE};
use millcomp_closedloop::scenario::ControlSpec;
use millcomp_datasets::{Column, ColumnData};
use millcomp_models::{ModelBundle, ModelFile};
use millcomp_mpc::groove::{
    DeflectionPlan, GrooveMpcSettings, MpcGrooveController, TunedPidController,
};
use millcomp_mpc::identified::{
    IdentifiedForceModel, IdentifiedSpindle, IdentifiedStiffness, NominalTool,
};
use millcomp_mpc::pid::PidGains;
use millcomp_mpc::predictor::ForcePredictor;
use millcomp_sim::groove::{GrooveProgram, PathOffset};

use crate::batch::{Compared, Runs, compare, paired_against, records_from_table};
use crate::calibration::{aliases, describe_design, design_table, read};
use crate::ctx::{BatchAnswer, Ctx, RerunAnswer, f, fp, median};
use crate::error::{PipelineError, Result};
use crate::files;
use crate::report::Section;
use crate::svg::{Chart, Mark, RefLine, Series};

/// The controllers' models from a bundle file, for a program.
struct Built {
    spindle: IdentifiedSpindle,
    stiffness: IdentifiedStiffness,
    tool: NominalTool,
    predictor: ForcePredictor,
    settings: GrooveMpcSettings,
}

fn load_bundle(path: &Path) -> Result<ModelBundle> {
    Ok(ModelFile::<ModelBundle>::load(path, &ModelBundle::KINDS)?.model)
}

fn built(path: &Path, material: &str) -> Result<Built> {
    let b = load_bundle(path)?;
    b.check_material(material, path)?;
    let spindle = IdentifiedSpindle::new(&b.spindle(path, "the controllers")?)?;
    let stiffness = IdentifiedStiffness::new(&b.stiffness(path, "the controllers")?)?;
    let tool = NominalTool::thesis_ball_end(material);
    let predictor = ForcePredictor::Mechanistic(IdentifiedForceModel::new(
        &b.force(path, "the controllers' force predictor")?,
        &tool,
    )?);
    let (noise, _) = b.sensor_noise(path, "the MPC's Kalman filter")?;
    let c = ControlSpec::default();
    let settings = GrooveMpcSettings {
        dt_s: c.dt_s,
        mpc_every: c.mpc_every,
        horizon: c.horizon,
        slew_v_per_cycle: c.slew_v_per_cycle,
        voltage_max_v: spindle.plant().voltage_max_v,
        config: None,
        force_noise_n: noise.force_noise_n,
        gauge_noise_um: noise.gauge_noise_um,
        features: Default::default(),
        budget: Default::default(),
    };
    Ok(Built {
        spindle,
        stiffness,
        tool,
        predictor,
        settings,
    })
}

/// The program of a condition (batch factor values).
fn program_of(spec: &ScenarioSpec) -> Result<GrooveProgram> {
    let s = build_scenario(spec)?;
    let g = s.groove.as_ref().ok_or_else(|| PipelineError::Stage {
        stage: "build",
        source: "the condition is not a groove".into(),
    })?;
    Ok(groove_program(g))
}

fn spec(index: usize, pairs: &[(&str, FactorValue)]) -> ScenarioSpec {
    ScenarioSpec {
        index,
        factors: pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect(),
    }
}

/// The reference condition of the build stage: the deep 20° groove with a feed step and a depth step at
/// once half-way along, in `material`.
fn reference_condition(cx: &Ctx<'_>, material: &str) -> ScenarioSpec {
    use FactorValue::{Num, Text};
    spec(
        0,
        &[
            ("tilt_deg", Num(20.0)),
            ("depth_um", Num(60.0)),
            ("wearland_um", Num(8.0)),
            ("material", Text(material.into())),
            ("feed_step", Num(1.0)),
            ("depth_step", Num(1.0)),
            ("length_mm", Num(cx.plan.compare.length_mm)),
            ("seed", Num(7.0)),
        ],
    )
}

/// Stage `build`: every controller of the comparison built from the bundles alone; on the simulated
/// machine, each one cut once at a change, its part error traced.
pub(crate) fn build(cx: &mut Ctx<'_>) -> Result<()> {
    if cx.bundles.is_empty() {
        cx.chain.skipped(
            "build",
            "skipped: needs a commissioned bundle (the commission stage's inputs)".into(),
        );
        return Ok(());
    }
    let t0 = cx.start("build");
    let (mut rows, mut doc) = (Vec::new(), serde_json::Map::new());
    let inputs: Vec<PathBuf> = cx.bundles.values().cloned().collect();
    for (material, path) in &cx.bundles {
        let b = built(path, material)?;
        let program = program_of(&reference_condition(cx, material))?;
        let plan =
            DeflectionPlan::new(&program, &b.predictor, &b.stiffness, b.tool.radius_um, 0.01)?;
        let pid = TunedPidController::new(
            &program,
            &b.spindle,
            &b.stiffness,
            b.settings.voltage_max_v,
            b.settings.dt_s,
        )?;
        let d = pid.design();
        let mpc = MpcGrooveController::new(
            plan.clone(),
            &program,
            &b.spindle,
            &b.stiffness,
            b.tool.flutes,
            &b.settings,
        )?;
        let (lo, hi) = plan.range_um();
        let published = PidGains::tuned();
        rows.push(vec![
            material.clone(),
            format!("{:.1}–{:.1} µm planned", lo, hi),
            format!(
                "P {} I {} (published, `000_…txt` §5.2.6)",
                published.p, published.i
            ),
            format!(
                "kp {:.3} V/µm, ki {:.1} V/(µm·s), Ms {:.2}, crossover {:.0} rad/s",
                d.kp_v_per_um, d.ki_v_per_um_s, d.ms, d.crossover_rad_s
            ),
            format!(
                "horizon {} × {:.1} ms, force σ {:.3} N, gauge σ {:.4} µm",
                mpc.mpc().config().horizon,
                1e3 * b.settings.dt_s * b.settings.mpc_every as f64,
                b.settings.force_noise_n,
                b.settings.gauge_noise_um
            ),
        ]);
        doc.insert(
            material.clone(),
            serde_json::json!({
                "bundle": cx.rel(path),
                "open-loop": {"planned_deflection_um": [lo, hi]},
                "pid": {"p": published.p, "i": published.i, "d": published.d},
                "pid-tuned": {"kp_v_per_um": d.kp_v_per_um, "ki_v_per_um_s": d.ki_v_per_um_s, "ms": d.ms, "crossover_rad_s": d.crossover_rad_s},
                "mpc": {"horizon": mpc.mpc().config().horizon, "period_s": b.settings.dt_s * b.settings.mpc_every as f64,
                        "force_noise_n": b.settings.force_noise_n, "gauge_noise_um": b.settings.gauge_noise_um},
            }),
        );
    }
    let json = cx.path("build/controllers.json");
    files::write_text(&json, &serde_json::to_string_pretty(&doc)?)?;
    let mut outputs = vec![json.clone()];
    let mut s = Section::new(
        "6. Build: the controllers, from the bundles only",
        "stage-build",
    );
    s.para(
        "`none`, `open-loop` (the plan fed forward through the spindle's static gain), the published `pid` \
         (the thesis' gains and signal chain), `pid-tuned` (the best PI a fixed tuning rule gives on the \
         identified spindle) and `mpc` (Clarabel every 0.5 ms, with the plan's preview) — each built from \
         a bundle file and the catalogue tool, nothing else.",
    );
    s.table(
        &["material", "open-loop", "pid", "pid-tuned", "mpc"],
        rows,
        &[cx.rel(&json)],
    );
    let mut summary = format!(
        "{} controllers built from {} bundle(s): {}",
        cx.plan.compare.controllers.len(),
        cx.bundles.len(),
        cx.plan.compare.controllers.join(", ")
    );
    if let Some(machine) = &cx.machine {
        let material = cx.bundles.keys().next().cloned().unwrap_or_default();
        let cond = reference_condition(cx, &material);
        let runs = machine.runs(cx.bundles.clone());
        let (mut c_ctrl, mut c_x, mut c_e) = (vec![], vec![], vec![]);
        let mut series = Vec::new();
        let half = cx.plan.compare.length_mm / 2.0;
        let mut line = Vec::new();
        for (k, ctrl) in cx.plan.compare.controllers.iter().enumerate() {
            if ctrl == "none" {
                continue;
            }
            let (m, pts) = runs.profile(&cond, ctrl)?;
            let near: Vec<(f64, f64)> = pts
                .into_iter()
                .filter(|(x, _)| *x >= half - 1.0 && *x <= half + 3.0)
                .collect();
            for &(x, e) in &near {
                c_ctrl.push(ctrl.clone());
                c_x.push(x);
                c_e.push(e);
            }
            line.push(format!("{ctrl} {:.2} µm", m.pp_error_um));
            series.push(Series::new(
                ctrl,
                near.iter().map(|p| p.0).collect(),
                near.iter().map(|p| p.1).collect(),
                Mark::Line,
                k,
            ));
        }
        let csv = cx.path("build/change_traces.csv");
        files::write_columns(
            &csv,
            "change traces",
            vec![
                Column {
                    name: "controller".into(),
                    data: ColumnData::Text(c_ctrl),
                },
                Column {
                    name: "x_mm".into(),
                    data: ColumnData::Float(c_x),
                },
                Column {
                    name: "error_um".into(),
                    data: ColumnData::Float(c_e),
                },
            ],
        )?;
        let chart = Chart {
            title: format!("The controllers at a change (simulated machine, {material})"),
            x_label: "position along the groove (mm)".into(),
            y_label: "depth error of the part (µm, + = deeper)".into(),
            series,
            lines: vec![
                RefLine::V(half, " feed ×2 and depth +20 µm at once".into()),
                RefLine::H(0.0, String::new()),
            ],
            ..Default::default()
        };
        let (fig, svg) = cx.figure(
            "change",
            &chart,
            format!(
                "Each controller's part error around the change of the reference condition (20° tilt, \
                 ramp to 60 µm, feed doubled and depth +20 µm at once at {half} mm, {material}), cut once on the \
                 simulated machine; peak-to-peak over the groove: {}.",
                line.join(", ")
            ),
            &[&csv],
        )?;
        s.figure(fig);
        summary.push_str(&format!(
            "; at a change on the simulated machine, pp {}",
            line.join(", ")
        ));
        outputs.push(csv);
        outputs.push(svg);
    }
    cx.section(s);
    cx.chain.ran(
        "build",
        &cx.source(),
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// Stage `design-comparison`: the conditions of the comparison as a designed experiment, one seed per
/// condition.
pub(crate) fn design_comparison(cx: &mut Ctx<'_>) -> Result<()> {
    let t0 = cx.start("design-comparison");
    let c = &cx.plan.compare;
    let (d, mut cols) = design_table(&c.factors, c.resolution, cx.plan.seed ^ 0xc0, "conditions")?;
    let n = d.n_runs();
    cols.push(Column {
        name: "length_mm".into(),
        data: ColumnData::Float(vec![c.length_mm; n]),
    });

    let csv = cx.path("batch/conditions.csv");
    files::write_columns(&csv, "conditions", cols)?;
    let json = cx.path("batch/design.json");
    files::write_text(&json, &serde_json::to_string_pretty(&d)?)?;
    let al = aliases(&d);
    let summary = format!(
        "{n} conditions: {} over {}, {} mm grooves, one seed per condition; aliases: {}",
        describe_design(&d),
        d.factor_names().join(", "),
        c.length_mm,
        al.join("; ")
    );
    let mut s = Section::new("7. Design the comparison", "stage-design-comparison");
    s.para(format!(
        "The conditions as a designed experiment: a {} over `{}` — {} conditions, each a {} mm groove (long \
         enough to hold a change at half-length and its window, 0.5 mm before to 2 mm after) with its own \
         seed on a simulated machine (the noise, the set-up's drift and touch-off: 1000 + its index); every \
         controller cuts every condition (paired). Aliases: {}.",
        describe_design(&d),
        c.factors,
        n,
        c.length_mm,
        al.join("; ")
    ));
    cx.section(s);
    cx.conditions = Some(csv.clone());
    cx.chain.ran(
        "design-comparison",
        "",
        &[],
        &[csv, json],
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

fn entry<'e>(p: &'e [PairedEntry], controller: &str, metric: &str) -> Option<&'e PairedEntry> {
    p.iter()
        .find(|e| e.controller == controller && e.metric == metric)
}

/// Plots of a comparison: pp by controller (each condition a point, the medians a line) and the medians
/// by factor level, against the part's tolerance.
fn batch_figures(
    cx: &Ctx<'_>,
    c: &Compared,
    controllers: &[String],
    name: &str,
    results: &Path,
) -> Result<Vec<(crate::report::Figure, PathBuf)>> {
    let tol = cx.plan.compare.tolerance_pp_um;
    let mut series = Vec::new();
    let (mut mx, mut my) = (Vec::new(), Vec::new());
    for (k, ctrl) in controllers.iter().enumerate() {
        let v: Vec<f64> = c
            .records
            .iter()
            .filter(|r| &r.controller == ctrl)
            .map(|r| r.metrics.pp_error_um)
            .collect();
        let n = v.len().max(1) as f64;
        let xs: Vec<f64> = (0..v.len())
            .map(|i| k as f64 + 0.5 * ((i as f64 + 0.5) / n - 0.5))
            .collect();
        mx.push(k as f64);
        my.push(median(&v));
        series.push(Series::new("", xs, v, Mark::Points, k));
    }
    series.push(Series::new("median", mx, my, Mark::Line, 7));
    let by_ctrl = Chart {
        title: format!("Peak-to-peak part error by controller{}", cx.sim_tag()),
        x_label: "controller (each point a condition)".into(),
        y_label: "peak-to-peak depth error (µm)".into(),
        series,
        lines: vec![RefLine::H(tol, format!(" part tolerance {tol} µm"))],
        categories: controllers.to_vec(),
        ..Default::default()
    };
    let f1 = cx.figure(
        &format!("{name}_by_controller"),
        &by_ctrl,
        format!(
            "The part's peak-to-peak depth error of every condition and controller{}, the medians joined, \
             against the part's tolerance of {tol} µm.",
            cx.sim_tag()
        ),
        &[results],
    )?;
    // by factor level
    let factors = millcomp_closedloop::batch::results::varying_factors(&c.plan, &c.records);
    let mut cats = Vec::new();
    let mut levels: Vec<(String, String)> = Vec::new();
    for fname in &factors {
        let mut vals: Vec<String> = c
            .plan
            .scenarios
            .iter()
            .filter_map(|s| s.factors.get(fname).map(FactorValue::text))
            .collect();
        vals.sort_by(|a, b| {
            a.parse::<f64>()
                .ok()
                .zip(b.parse::<f64>().ok())
                .map_or_else(|| a.cmp(b), |(x, y)| x.total_cmp(&y))
        });
        vals.dedup();
        let short = fname
            .trim_end_matches("_deg")
            .trim_end_matches("_um")
            .trim_end_matches("_mm")
            .replace('_', " ");
        for v in vals {
            cats.push(if fname == "material" {
                v.clone()
            } else {
                format!("{short} {v}")
            });
            levels.push((fname.clone(), v));
        }
    }
    let mut series = Vec::new();
    for (k, ctrl) in controllers.iter().enumerate() {
        if ctrl == "none" {
            continue;
        }
        let ys: Vec<f64> = levels
            .iter()
            .map(|(fname, lv)| {
                let v: Vec<f64> = c
                    .records
                    .iter()
                    .filter(|r| &r.controller == ctrl)
                    .filter(|r| {
                        c.plan.scenarios[r.scenario]
                            .factors
                            .get(fname)
                            .is_some_and(|x| &x.text() == lv)
                    })
                    .map(|r| r.metrics.pp_error_um)
                    .collect();
                median(&v)
            })
            .collect();
        let xs: Vec<f64> = (0..levels.len()).map(|i| i as f64).collect();
        series.push(Series::new(ctrl, xs, ys, Mark::Points, k));
    }
    let by_factor = Chart {
        title: format!("Median part error by factor level{}", cx.sim_tag()),
        x_label: "factor level".into(),
        y_label: "median peak-to-peak error (µm)".into(),
        series,
        lines: vec![RefLine::H(tol, format!(" part tolerance {tol} µm"))],
        categories: cats,
        ..Default::default()
    };
    let f2 = cx.figure(
        &format!("{name}_by_factor"),
        &by_factor,
        format!(
            "Each compensating controller's median peak-to-peak error at each level of each factor{} (over \
             the conditions at that level; `none` is in the table above), against the part's tolerance.",
            cx.sim_tag()
        ),
        &[results],
    )?;
    Ok(vec![f1, f2])
}

/// Stage `batch`: the designed comparison — run on the simulated machine with the bundles' controllers,
/// or the plan's measured results — with its ANOVA and the paired mpc − pid-tuned difference.
pub(crate) fn batch(cx: &mut Ctx<'_>) -> Result<()> {
    let controllers = cx.plan.compare.controllers.clone();
    let dir = cx.path("batch");
    let (compared, inputs, source, t0) = if let Some(file) = cx.plan.compare.results.clone() {
        let t0 = cx.start("batch");
        let dst = dir.join("measured_results.csv");
        if let Some(d) = dst.parent() {
            std::fs::create_dir_all(d).map_err(|e| PipelineError::io(d, "creating", e))?;
        }
        std::fs::copy(&file, &dst).map_err(|e| PipelineError::io(&file, "reading", e))?;
        let table = read(&dst)?;
        let (plan, records) = records_from_table(&table, &file)?;
        let ctrls = plan.controllers.clone();
        let c = compare(&ctrls, Runs::Measured(plan, records), &dir, false)?;
        (
            c,
            vec![std::fs::canonicalize(&file).unwrap_or(file)],
            "measured results".to_string(),
            t0,
        )
    } else {
        let (Some(machine), Some(conditions)) = (cx.machine.as_ref(), cx.conditions.clone()) else {
            cx.chain.skipped(
                "batch",
                "skipped: needs measured part errors per condition and controller (compare.results: \
                 scenario, the factors, controller, pp_error_um[, change_excess_um]) or a simulated machine"
                    .into(),
            );
            return Ok(());
        };
        if cx.bundles.is_empty() {
            cx.chain
                .skipped("batch", "skipped: needs the commissioned bundles".into());
            return Ok(());
        }
        let t0 = cx.start("batch");
        let table = read(&conditions)?;
        let runs = machine.runs(cx.bundles.clone());
        let c = compare(
            &controllers,
            Runs::Machine {
                conditions: &table,
                runner: &runs,
            },
            &dir,
            cx.opts.progress_bar,
        )?;
        let mut inputs = vec![conditions];
        inputs.extend(cx.bundles.values().cloned());
        (c, inputs, cx.source(), t0)
    };
    let results = dir.join("results.csv");
    let summary_json = dir.join("summary.json");
    let ctrls: Vec<String> = compared.plan.controllers.clone();
    let figs = batch_figures(cx, &compared, &ctrls, "batch", &results)?;
    let n = compared.plan.scenarios.len();
    let mpc = entry(&compared.paired, "mpc", "pp_error_um");
    let med = |c: &str| {
        compared
            .by_controller
            .get(c)
            .and_then(|m| m.get("pp_error_um"))
            .copied()
            .unwrap_or(f64::NAN)
    };
    let mut s = Section::new(
        "8. Compare: the controllers over the designed conditions",
        "stage-batch",
    );
    s.para(format!(
        "{} conditions × {} controllers{} (`{}`). Median part error per controller (peak to peak over the \
         groove, and the largest excess at a change):",
        n,
        ctrls.len(),
        if source.starts_with("simulated") {
            format!(", cut on the {source} with the controllers built from the bundles")
        } else {
            format!(" ({source})")
        },
        cx.rel(&results)
    ));
    let tol = cx.plan.compare.tolerance_pp_um;
    s.table(
        &[
            "controller",
            "median pp (µm)",
            "median change excess (µm)",
            "within tolerance",
        ],
        ctrls
            .iter()
            .map(|c| {
                let within = compared
                    .records
                    .iter()
                    .filter(|r| &r.controller == c)
                    .filter(|r| r.metrics.pp_error_um <= tol)
                    .count();
                vec![
                    format!("`{c}`"),
                    f(med(c), 3),
                    f(
                        compared
                            .by_controller
                            .get(c)
                            .and_then(|m| m.get("change_excess_um"))
                            .copied()
                            .unwrap_or(f64::NAN),
                        3,
                    ),
                    format!("{within} of {n}"),
                ]
            })
            .collect(),
        &[cx.rel(&summary_json)],
    );
    if let Some(a) = compared.anova.get("pp_error_um") {
        s.para(format!(
            "ANOVA of the peak-to-peak error with the controller as a factor (`{}`, R² = {:.3}; from `{}`):",
            a.model,
            a.r_squared,
            cx.rel(&summary_json)
        ));
        s.table(
            &["term", "df", "F", "p-value"],
            a.terms
                .iter()
                .map(|t| {
                    vec![
                        format!("`{}`", t.term),
                        t.df.to_string(),
                        t.f.map_or("–".into(), |x| f(x, 2)),
                        fp(t.p_value),
                    ]
                })
                .collect(),
            &[cx.rel(&summary_json)],
        );
    }
    if let Some(e) = mpc {
        s.para(format!(
            "**mpc − {}**, condition by condition ({} conditions): median difference {:+.3} µm, 95 % interval \
             [{:+.3}, {:+.3}] µm; paired t-test p = {}, sign test p = {}; mpc better in {}, worse in {}.",
            e.reference,
            e.n,
            e.median_diff,
            e.ci95[0],
            e.ci95[1],
            fp(e.t_p_value),
            fp(e.sign_p_value),
            e.better,
            e.worse
        ));
        let no_help: Vec<String> = e
            .by_level
            .iter()
            .filter(|l| l.median_diff >= 0.0)
            .map(|l| {
                format!(
                    "{}={} ({:+.3} µm over {})",
                    l.factor, l.level, l.median_diff, l.n
                )
            })
            .collect();
        s.para(format!(
            "Where mpc does not help (median difference ≥ 0 at a factor level): {}.",
            if no_help.is_empty() {
                "nowhere — it is better at every level of every factor".to_string()
            } else {
                no_help.join("; ")
            }
        ));
        if let Some(ce) = entry(&compared.paired, "mpc", "change_excess_um") {
            s.para(format!(
                "At the changes (largest excess over the level before), mpc − {}: median {:+.3} µm [{:+.3}, \
                 {:+.3}], sign test p = {}, paired t-test p = {}.",
                ce.reference,
                ce.median_diff,
                ce.ci95[0],
                ce.ci95[1],
                fp(ce.sign_p_value),
                fp(ce.t_p_value)
            ));
        }
        cx.batch = Some(BatchAnswer {
            n: e.n,
            mpc_median: med("mpc"),
            ref_median: med(&e.reference),
            diff: e.median_diff,
            ci: e.ci95,
            p: e.sign_p_value,
            reference: e.reference.clone(),
        });
    }
    for n in &compared.notes {
        s.para(format!("Note: {n}"));
    }
    let mut outputs: Vec<PathBuf> = compared
        .files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e != "json") || p.ends_with("summary.json"))
        .cloned()
        .collect();
    for (fig, svg) in figs {
        s.figure(fig);
        outputs.push(svg);
    }
    cx.section(s);
    cx.batch_results = Some(results.clone());
    let summary = match &cx.batch {
        Some(b) => format!(
            "{n} conditions × {} controllers ({source}); median pp mpc {:.3} vs {} {:.3} µm, paired difference \
             {:+.3} [{:+.3}, {:+.3}] µm, sign test p = {}",
            ctrls.len(),
            b.mpc_median,
            b.reference,
            b.ref_median,
            b.diff,
            b.ci[0],
            b.ci[1],
            fp(b.p)
        ),
        None => format!("{n} conditions × {} controllers ({source})", ctrls.len()),
    };
    cx.chain.ran(
        "batch",
        &source,
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// The corrections of the diagnosed effects along each condition's groove, relative to its start.
fn corrections(
    cx: &Ctx<'_>,
    plan: &millcomp_closedloop::batch::plan::Plan,
) -> Result<BTreeMap<usize, PathOffset>> {
    use millcomp_diagnose::{FittedEffect, SessionModel};
    let effects: Vec<FittedEffect> = cx
        .effects
        .iter()
        .map(|p| Ok(ModelFile::<FittedEffect>::load(p, &[FittedEffect::KIND])?.model))
        .collect::<Result<_>>()?;
    let mut out = BTreeMap::new();
    for sc in &plan.scenarios {
        let program = program_of(sc)?;
        let material = match sc.factors.get("material") {
            Some(FactorValue::Text(m)) => m.clone(),
            _ => cx.bundles.keys().next().cloned().unwrap_or_default(),
        };
        let bundle = cx
            .bundles
            .get(&material)
            .ok_or_else(|| PipelineError::Stage {
                stage: "rerun",
                source: format!("no bundle for material {material}").into(),
            })?;
        let mut one = crate::diagnosis::nominal_session(bundle, &material)?;
        one.name = format!("condition {}", sc.index + 1);
        one.plan = vec![millcomp_sim::session::PlanItem::Groove(
            millcomp_sim::session::GrooveSpec {
                start_s: Some(0.0),
                speed_rpm: program.speed_rpm,
                upfeed_um: Some(program.upfeed_um),
                feed_mm_min: None,
                tilt_deg: program.tilt_deg,
                coolant: None,
                length_mm: program.length_mm,
                x_offset_mm: FIXTURE_X_MM,
                measure_every_mm: 0.05,
                depth: program.depth_profile.clone(),
            },
        )];
        let sm = SessionModel::new(&one)?;
        let mut total = vec![0.0; sm.len()];
        for e in &effects {
            for (t, v) in total.iter_mut().zip(e.offsets_um(&sm)?) {
                *t += v;
            }
        }
        let zero = total.first().copied().unwrap_or(0.0);
        let pts: Vec<(f64, f64)> = sm
            .points()
            .iter()
            .zip(&total)
            .map(|(p, v)| (p.x_mm, v - zero))
            .collect();
        out.insert(sc.index, PathOffset::new(pts)?);
    }
    Ok(out)
}

/// Stage `rerun`: the corrected model in the controllers (the MPC's prediction and preview, open-loop's
/// feedforward), rerun on the comparison's conditions beside an MPC given the true effect (an oracle).
pub(crate) fn rerun(cx: &mut Ctx<'_>) -> Result<()> {
    let dir = cx.path("rerun");
    let Some(batch_results) = cx.batch_results.clone() else {
        cx.chain.skipped(
            "rerun",
            "skipped: needs the comparison's results (the batch stage) to pair with".into(),
        );
        return Ok(());
    };
    let (rerun_compared, inputs, source, t0) = if let Some(file) = cx.plan.rerun.results.clone() {
        let t0 = cx.start("rerun");
        std::fs::create_dir_all(&dir).map_err(|e| PipelineError::io(&dir, "creating", e))?;
        let dst = dir.join("measured_results.csv");
        std::fs::copy(&file, &dst).map_err(|e| PipelineError::io(&file, "reading", e))?;
        let (plan, records) = records_from_table(&read(&dst)?, &file)?;
        let ctrls = plan.controllers.clone();
        let c = compare(&ctrls, Runs::Measured(plan, records), &dir, false)?;
        (
            c,
            vec![
                std::fs::canonicalize(&file).unwrap_or(file),
                batch_results.clone(),
            ],
            "measured results".to_string(),
            t0,
        )
    } else {
        let (Some(machine), Some(conditions)) = (cx.machine.as_ref(), cx.conditions.clone()) else {
            cx.chain.skipped(
                "rerun",
                "skipped: needs the corrected controllers' measured part errors (rerun.results, as \
                 compare.results with controllers such as mpc+diagnosed) or a simulated machine"
                    .into(),
            );
            return Ok(());
        };
        if cx.effects.is_empty() {
            cx.chain.skipped(
                "rerun",
                "skipped: the diagnosis named no effect to correct the model with".into(),
            );
            return Ok(());
        }
        let t0 = cx.start("rerun");
        let table = read(&conditions)?;
        let controllers: Vec<String> = [
            format!("open-loop+{DIAGNOSED}"),
            format!("mpc+{DIAGNOSED}"),
            format!("mpc+{ORACLE}"),
        ]
        .to_vec();
        let plan = millcomp_closedloop::batch::plan::Plan::from_table(&table, controllers.clone())?;
        let corr = corrections(cx, &plan)?;
        let runs = machine.runs(cx.bundles.clone()).with_corrections(corr);
        let c = compare(
            &controllers,
            Runs::Machine {
                conditions: &table,
                runner: &runs,
            },
            &dir,
            cx.opts.progress_bar,
        )?;
        let mut inputs = vec![conditions, batch_results.clone()];
        inputs.extend(cx.bundles.values().cloned());
        inputs.extend(cx.effects.iter().cloned());
        (c, inputs, cx.source(), t0)
    };
    // the batch's records of the same conditions, from its results file
    let (bplan, brecords) = records_from_table(&read(&batch_results)?, &batch_results)?;
    let mut all: Vec<RunRecord> = brecords
        .into_iter()
        .filter(|r| r.controller == "mpc" || r.controller == "open-loop")
        .collect();
    all.extend(rerun_compared.records.iter().cloned());
    let paired_mpc = paired_against(&bplan, &all, "mpc");
    let paired_ol = paired_against(&bplan, &all, "open-loop");
    let med = |c: &str| {
        median(
            &all.iter()
                .filter(|r| r.controller == c)
                .map(|r| r.metrics.pp_error_um)
                .collect::<Vec<_>>(),
        )
    };
    let (m0, m1, m2) = (
        med("mpc"),
        med(&format!("mpc+{DIAGNOSED}")),
        med(&format!("mpc+{ORACLE}")),
    );
    let (o0, o1) = (med("open-loop"), med(&format!("open-loop+{DIAGNOSED}")));
    let d_diag = entry(&paired_mpc, &format!("mpc+{DIAGNOSED}"), "pp_error_um");
    let d_orac = entry(&paired_mpc, &format!("mpc+{ORACLE}"), "pp_error_um");
    let d_ol = entry(&paired_ol, &format!("open-loop+{DIAGNOSED}"), "pp_error_um");
    let combined = dir.join("paired_with_batch.json");
    files::write_text(
        &combined,
        &serde_json::to_string_pretty(&serde_json::json!({
            "against_mpc": paired_mpc,
            "against_open_loop": paired_ol,
        }))?,
    )?;
    let mut ctrl_order: Vec<String> = vec!["open-loop".into()];
    ctrl_order.push(format!("open-loop+{DIAGNOSED}"));
    ctrl_order.push("mpc".into());
    ctrl_order.push(format!("mpc+{DIAGNOSED}"));
    ctrl_order.push(format!("mpc+{ORACLE}"));
    let both = Compared {
        plan: bplan.clone(),
        records: all.clone(),
        ..rerun_compared.clone()
    };
    let figs = batch_figures(cx, &both, &ctrl_order, "rerun", &dir.join("results.csv"))?;
    let mut s = Section::new(
        "12. Rerun: the corrected model in the controllers",
        "stage-rerun",
    );
    s.para(format!(
        "The diagnosed effect, evaluated along each condition's groove at its machine X (the fixture at X = \
         {FIXTURE_X_MM} mm) from the effect's model file, enters the controllers built from the same bundles: \
         the MPC adds it to its error channel's prediction, preview, measurement and stroke band; open-loop \
         subtracts it from its feedforward. They are rerun on the comparison's {} conditions{} beside **an MPC \
         given the true effect** (`mpc+{ORACLE}`, an oracle no user can build: the ideal this diagnosis could \
         reach). Results `{}`, paired with the batch's `{}` in `{}`.",
        bplan.scenarios.len(),
        if source.starts_with("simulated") {
            format!(" on the {source}")
        } else {
            format!(" ({source})")
        },
        cx.rel(&dir.join("results.csv")),
        cx.rel(&batch_results),
        cx.rel(&combined)
    ));
    let row = |name: &str, e: Option<&PairedEntry>, m: f64| {
        vec![
            format!("`{name}`"),
            f(m, 3),
            e.map_or("–".into(), |e| {
                format!(
                    "{:+.3} [{:+.3}, {:+.3}]",
                    e.median_diff, e.ci95[0], e.ci95[1]
                )
            }),
            e.map_or("–".into(), |e| fp(e.sign_p_value)),
        ]
    };
    s.table(
        &[
            "controller",
            "median pp (µm)",
            "paired difference to its uncorrected self (µm, 95 %)",
            "sign test p",
        ],
        vec![
            row("open-loop", None, o0),
            row(&format!("open-loop+{DIAGNOSED}"), d_ol, o1),
            row("mpc", None, m0),
            row(&format!("mpc+{DIAGNOSED}"), d_diag, m1),
            row(&format!("mpc+{ORACLE} (oracle)"), d_orac, m2),
        ],
        &[cx.rel(&combined)],
    );
    let (dd, dor) = (
        d_diag.map_or(f64::NAN, |e| e.median_diff),
        d_orac.map_or(f64::NAN, |e| e.median_diff),
    );
    let rec = if dor < 0.0 {
        100.0 * dd / dor
    } else {
        f64::NAN
    };
    s.para(format!(
        "What the diagnosis was worth{}: condition by condition, the corrected model changed mpc's \
         peak-to-peak part error by {} µm (median; medians {:.3} → {:.3} µm); the oracle, given the true \
         effect, by {} µm ({:.3} µm) — the diagnosis recovered {} of what knowing the effect exactly gives.",
        cx.sim_tag(),
        f(dd, 3),
        m0,
        m1,
        f(dor, 3),
        m2,
        if rec.is_finite() {
            format!("{rec:.0} %")
        } else {
            "– (knowing it exactly gains nothing here)".into()
        },
    ));
    for (fig, _) in &figs {
        s.figure(fig.clone());
    }
    cx.section(s);
    cx.rerun = Some(RerunAnswer {
        corrected: d_diag.map_or(f64::NAN, |e| e.median_diff),
        ideal: d_orac.map_or(f64::NAN, |e| e.median_diff),
    });
    let mut outputs: Vec<PathBuf> = rerun_compared
        .files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e != "json") || p.ends_with("summary.json"))
        .cloned()
        .collect();
    outputs.push(combined);
    outputs.extend(figs.into_iter().map(|(_, p)| p));
    let summary = format!(
        "{} conditions ({source}): mpc's pp changed by {} µm with the corrected model (paired median; medians \
         {:.3} → {:.3} µm), the oracle's by {} µm ({} of the ideal recovered); open-loop {:.3} → {:.3} µm",
        bplan.scenarios.len(),
        f(dd, 3),
        m0,
        m1,
        f(dor, 3),
        if rec.is_finite() {
            format!("{rec:.0} %")
        } else {
            "–".into()
        },
        o0,
        o1
    );
    cx.chain.ran(
        "rerun",
        &source,
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}
