//! Stages 9–11: the session design (the nominal model from a bundle), its measurement on the
//! profilometer, and the diagnosis of what the bundle lacks.

use std::path::{Path, PathBuf};

use millcomp_diagnose::{DiagnoseOptions, FittedEffect, Measured, SessionModel, diagnose};
use millcomp_models::{ModelBundle, ModelFile};
use millcomp_sim::groove::DepthProfile;
use millcomp_sim::session::{
    ForceModelSpec, GrooveSpec, MaterialSpec, PauseSpec, PlanItem, Session, StiffnessSpec, ToolSpec,
};

use crate::ctx::{Ctx, DiagnosisAnswer, f, fp};
use crate::error::{PipelineError, Result};
use crate::files;
use crate::report::Section;
use crate::svg::{Chart, Mark, RefLine, Series};

/// The nominal model of `material` a bundle gives, as a session's tool, material, force model and
/// stiffness: the catalogue tool with the fitted wearland and runout, the published material with the
/// fitted W (which carries the force scale), the identified stiffness. Priors: the defaults
/// (`sim/SESSION.md`).
pub(crate) fn nominal_session(bundle: &Path, material: &str) -> Result<Session> {
    let b = ModelFile::<ModelBundle>::load(bundle, &ModelBundle::KINDS)?.model;
    let force = b.force(bundle, "the session's nominal model")?;
    let k = b.stiffness(bundle, "the session's nominal model")?;
    let tool = millcomp_mpc::identified::NominalTool::thesis_ball_end(material);
    let get = |name: &str, default: f64| force.fitted.get(name).copied().unwrap_or(default);
    let cat = tool.force_model()?;
    Ok(Session {
        name: format!("nominal model of {}", bundle.display()),
        description: "the nominal model a commissioned bundle gives (millcomp pipeline)".into(),
        tool: ToolSpec {
            radius_um: tool.radius_um,
            wearland_um: get("wearland_um", cat.tool.wearland_um),
            runout_um: get("runout_um", cat.tool.runout_um),
        },
        material: MaterialSpec {
            name: material.to_string(),
            w_mpa: Some(get("w_mpa", cat.material.w_mpa)),
            e_gpa: None,
            mu_rake: force.fitted.get("mu_rake").copied(),
            mu_flank: force.fitted.get("mu_flank").copied(),
        },
        force_model: ForceModelSpec::default(),
        stiffness: StiffnessSpec {
            axial_n_per_um: k.axial_n_per_um,
            radial_n_per_um: k.radial_n_per_um,
        },
        uncertainty: Default::default(),
        effects: Vec::new(),
        plan: Vec::new(),
    })
}

/// The session's plan: 12 grooves of 20 mm across the table's X range (0–90 mm), ramps, constant depths
/// and steps at 20° and 30° tilt, 5 and 10 µm/rev, 10 000 rpm, a short pause between grooves; measured
/// every mm — grooves that overlap in X at different depths and tilts, so that what depends on the
/// machine's position is told from what depends on the cut.
fn session_plan() -> Vec<PlanItem> {
    let grooves: [(f64, f64, f64, DepthProfile); 12] = [
        (
            0.0,
            20.0,
            10.0,
            DepthProfile::Ramp {
                from_um: 0.0,
                to_um: 80.0,
            },
        ),
        (35.0, 30.0, 10.0, DepthProfile::Constant { depth_um: 40.0 }),
        (70.0, 20.0, 5.0, DepthProfile::Constant { depth_um: 60.0 }),
        (
            10.0,
            30.0,
            10.0,
            DepthProfile::Ramp {
                from_um: 80.0,
                to_um: 20.0,
            },
        ),
        (
            50.0,
            20.0,
            10.0,
            DepthProfile::Steps {
                steps: vec![(0.0, 20.0), (5.0, 40.0), (10.0, 60.0), (15.0, 80.0)],
            },
        ),
        (25.0, 20.0, 5.0, DepthProfile::Constant { depth_um: 50.0 }),
        (
            60.0,
            30.0,
            10.0,
            DepthProfile::Ramp {
                from_um: 0.0,
                to_um: 80.0,
            },
        ),
        (40.0, 20.0, 10.0, DepthProfile::Constant { depth_um: 30.0 }),
        (5.0, 20.0, 10.0, DepthProfile::Constant { depth_um: 70.0 }),
        (
            45.0,
            30.0,
            5.0,
            DepthProfile::Ramp {
                from_um: 20.0,
                to_um: 70.0,
            },
        ),
        (65.0, 20.0, 10.0, DepthProfile::Constant { depth_um: 45.0 }),
        (
            30.0,
            30.0,
            10.0,
            DepthProfile::Steps {
                steps: vec![(0.0, 60.0), (10.0, 30.0)],
            },
        ),
    ];
    let mut plan = Vec::new();
    for (i, (x, tilt, upfeed, depth)) in grooves.into_iter().enumerate() {
        if i > 0 {
            plan.push(PlanItem::Pause(PauseSpec {
                duration_s: 120.0,
                speed_rpm: 10_000.0,
                coolant: None,
            }));
        }
        plan.push(PlanItem::Groove(GrooveSpec {
            start_s: None,
            speed_rpm: 10_000.0,
            upfeed_um: Some(upfeed),
            feed_mm_min: None,
            tilt_deg: tilt,
            coolant: None,
            length_mm: 20.0,
            x_offset_mm: x,
            measure_every_mm: 1.0,
            depth,
        }));
    }
    plan
}

/// Stage `design-session`: a session to diagnose, its nominal model from the first material's bundle.
pub(crate) fn design_session(cx: &mut Ctx<'_>) -> Result<()> {
    if let Some(given) = cx.plan.diagnose.session.clone() {
        let t0 = cx.start("design-session");
        let dst = cx.path("session/session.toml");
        if let Some(d) = dst.parent() {
            std::fs::create_dir_all(d).map_err(|e| PipelineError::io(d, "creating", e))?;
        }
        std::fs::copy(&given, &dst).map_err(|e| PipelineError::io(&given, "reading", e))?;
        Session::from_path(&dst)?;
        cx.session = Some(dst.clone());
        cx.chain.ran(
            "design-session",
            "files",
            &[std::fs::canonicalize(&given).unwrap_or(given)],
            &[dst],
            "the plan's session file (nominal model and plan)".into(),
            t0.elapsed().as_secs_f64(),
        )?;
        return Ok(());
    }
    let Some((material, bundle)) = cx
        .bundles
        .iter()
        .find(|(m, _)| m.as_str() == "S7")
        .or_else(|| cx.bundles.iter().next())
        .map(|(m, p)| (m.clone(), p.clone()))
    else {
        cx.chain.skipped(
            "design-session",
            "skipped: needs a session file (diagnose.session) or a commissioned bundle for its nominal model"
                .into(),
        );
        return Ok(());
    };
    let t0 = cx.start("design-session");
    let mut s = nominal_session(&bundle, &material)?;
    s.name = format!("diagnosis session ({material})");
    s.plan = session_plan();
    s.validate()?;
    let dst = cx.path("session/session.toml");
    let text = format!(
        "# Session to diagnose (schema: sim/SESSION.md), written by the pipeline's design-session stage:\n\
         # the nominal model of {} and 12 grooves across machine X 0-90 mm.\n{}",
        cx.rel(&bundle),
        toml::to_string(&s).map_err(|e| PipelineError::Stage {
            stage: "design-session",
            source: Box::new(e),
        })?
    );
    files::write_text(&dst, &text)?;
    cx.session = Some(dst.clone());
    let mut sec = Section::new("9. Design the session to diagnose", "stage-design-session");
    sec.para(format!(
        "A measured session checks the bundle against parts: 12 grooves of 20 mm across machine X 0–90 mm \
         ({material}; ramps, constant depths and steps, 20° and 30° tilt, 5 and 10 µm/rev), its nominal \
         model the bundle's (`{}`) with the stated priors of `sim/SESSION.md`. Session file: `{}`.",
        cx.rel(&bundle),
        cx.rel(&dst)
    ));
    cx.section(sec);
    cx.chain.ran(
        "design-session",
        "",
        &[bundle],
        &[dst],
        format!("12 grooves across X 0-90 mm in {material}, nominal model from the bundle"),
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// Stage `measure-session`: the session's grooves cut and measured on the profilometer.
pub(crate) fn measure_session(cx: &mut Ctx<'_>) -> Result<()> {
    if let Some(given) = cx.plan.diagnose.measured.clone() {
        let t0 = cx.start("measure-session");
        let dst = cx.path("measured/session.csv");
        if let Some(d) = dst.parent() {
            std::fs::create_dir_all(d).map_err(|e| PipelineError::io(d, "creating", e))?;
        }
        std::fs::copy(&given, &dst).map_err(|e| PipelineError::io(&given, "reading", e))?;
        cx.session_measured = Some(dst.clone());
        cx.chain.ran(
            "measure-session",
            "files",
            &[std::fs::canonicalize(&given).unwrap_or(given)],
            &[dst],
            "the plan's measured session".into(),
            t0.elapsed().as_secs_f64(),
        )?;
        return Ok(());
    }
    let (Some(machine), Some(session)) = (cx.machine.as_ref(), cx.session.clone()) else {
        cx.chain.skipped(
            "measure-session",
            "skipped: needs the session's measured grooves (diagnose.measured: the measured-groove CSV \
             contract) or a simulated machine"
                .into(),
        );
        return Ok(());
    };
    let t0 = cx.start("measure-session");
    let s = Session::from_path(&session)?;
    let points = machine.cut_session(&s, cx.seed(0x5e55))?;
    let dst = cx.path("measured/session.csv");
    crate::calibration::parent_dir(&dst)?;
    let t = millcomp_datasets::contracts::measured_groove_table(&cx.rel(&dst), &points)?;
    millcomp_datasets::write_table(&t, &dst)?;
    cx.session_measured = Some(dst.clone());
    let mut sec = Section::new("10. Measure the session", "stage-measure-session");
    sec.para(format!(
        "The session's {} grooves cut on the {} (uncompensated) and measured on the profilometer: {} \
         points (`{}`, the measured-groove contract). The machine was not told what to hide; the pipeline \
         is not told what it hides.",
        s.plan
            .iter()
            .filter(|p| matches!(p, PlanItem::Groove(_)))
            .count(),
        cx.source(),
        points.len(),
        cx.rel(&dst)
    ));
    cx.section(sec);
    cx.chain.ran(
        "measure-session",
        &cx.source(),
        &[session],
        &[dst],
        format!("{} points measured on the profilometer", points.len()),
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}

/// Stage `diagnose`: what the bundle's nominal model lacks, named, added, and the gap on held-out
/// grooves; the named effects saved as model files.
pub(crate) fn diagnose_stage(cx: &mut Ctx<'_>) -> Result<()> {
    let (Some(session), Some(measured)) = (cx.session.clone(), cx.session_measured.clone()) else {
        cx.chain.skipped(
            "diagnose",
            "skipped: needs a session file and its measured grooves (diagnose.session, diagnose.measured)"
                .into(),
        );
        return Ok(());
    };
    let t0 = cx.start("diagnose");
    let s = Session::from_path(&session)?;
    let file = millcomp_datasets::contracts::read_measured_groove(&measured)?;
    let m = Measured::new(cx.rel(&measured), file.points);
    let rep = diagnose(&s, &m, &DiagnoseOptions::default())?;
    let sm = SessionModel::new(&s)?;
    let json = cx.path("diagnose/diagnose.json");
    files::write_text(&json, &serde_json::to_string_pretty(&rep)?)?;
    let mut outputs = vec![json.clone()];
    cx.effects.clear();
    for e in FittedEffect::from_report(&rep, &sm)? {
        let p = cx.path(&format!("models/effect_{}.toml", e.effect));
        crate::calibration::parent_dir(&p)?;
        ModelFile::new(
            FittedEffect::KIND,
            e,
            cx.provenance(&[&session, &measured])?,
        )
        .save(&p)?;
        cx.effects.push(p.clone());
        outputs.push(p);
    }
    // residual before (after the nuisance step) and after, against machine X
    let series_pred = &rep.series.predictions_um;
    let x: Vec<f64> = sm.points().iter().map(|p| p.machine_x_mm).collect();
    let y = &rep.series.measured_um;
    let mut chart = Chart {
        title: format!("Diagnosis: residual before and after{}", cx.sim_tag()),
        x_label: "machine X (mm)".into(),
        y_label: "measured − model (µm)".into(),
        lines: vec![RefLine::H(0.0, String::new())],
        ..Default::default()
    };
    if series_pred.len() >= 2 && y.len() == x.len() {
        let resid =
            |k: usize| -> Vec<f64> { y.iter().zip(&series_pred[k]).map(|(a, b)| a - b).collect() };
        chart.series.push(Series::new(
            &format!("nominal recalibrated (rms {:.3} µm)", rep.nuisance_rms_um),
            x.clone(),
            resid(1),
            Mark::Points,
            1,
        ));
        let last = series_pred.len() - 1;
        chart.series.push(Series::new(
            &format!(
                "with {} (rms {:.3} µm)",
                rep.named.join(" + "),
                rep.final_rms_um
            ),
            x.clone(),
            resid(last),
            Mark::Points,
            0,
        ));
    }
    let (fig, svg) = cx.figure(
        "diagnose_residual",
        &chart,
        format!(
            "The session's residual along machine X{}: after the nominal model's recalibration within its \
             priors, and with the named effect added.",
            cx.sim_tag()
        ),
        &[&measured, &json],
    )?;
    outputs.push(svg);
    let mut sec = Section::new("11. Diagnose: what the bundle lacks", "stage-diagnose");
    sec.para(format!(
        "`diagnose` on the session's nominal model and its measured points (`{}`, `{}`), with every \
         candidate family and no hint of what to look for: the nominal model recalibrated within its priors \
         (rms {:.3} → {:.3} µm), then families added one at a time while each is significant at the \
         round's family-wise level, better on held-out grooves and above the measurement's resolution.",
        cx.rel(&session),
        cx.rel(&measured),
        rep.initial_rms_um,
        rep.nuisance_rms_um
    ));
    sec.table(
        &[
            "step",
            "effect (shape)",
            "p-value",
            "rms before → after (µm)",
            "held-out grooves (LOGO score)",
            "amplitude (µm)",
        ],
        rep.steps
            .iter()
            .enumerate()
            .map(|(i, st)| {
                vec![
                    (i + 1).to_string(),
                    format!("`{}` ({})", st.effect, st.shape),
                    fp(Some(st.p_value)),
                    format!("{} → {}", f(st.rms_before_um, 3), f(st.rms_after_um, 3)),
                    format!("{} → {}", f(st.logo.before, 1), f(st.logo.after, 1)),
                    f(st.amplitude_um, 2),
                ]
            })
            .collect(),
        &[cx.rel(&json)],
    );
    sec.para(format!(
        "Named: **{}** (verdict `{}`); rms {:.3} µm (nominal) → {:.3} µm. The held-out score is the \
         whitened squared error of predicting each groove from the others (leave-one-groove-out), without \
         and with the effect. Effect model files: {}.",
        rep.named.join(", "),
        rep.verdict,
        rep.initial_rms_um,
        rep.final_rms_um,
        cx.effects
            .iter()
            .map(|p| format!("`{}`", cx.rel(p)))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    if !rep.look_alikes.is_empty() {
        sec.list(rep.look_alikes.iter().map(|l| l.note.clone()).collect());
    }
    sec.figure(fig);
    cx.section(sec);
    cx.diagnosis = Some(DiagnosisAnswer {
        named: rep.named.clone(),
        rms_before: rep.initial_rms_um,
        rms_after: rep.final_rms_um,
    });
    let summary = format!(
        "named {}; rms {:.3} → {:.3} µm (held-out grooves {})",
        rep.named.join(", "),
        rep.initial_rms_um,
        rep.final_rms_um,
        rep.steps
            .iter()
            .map(|s| format!("{:.1} → {:.1}", s.logo.before, s.logo.after))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let inputs: Vec<PathBuf> = vec![session, measured];
    cx.chain.ran(
        "diagnose",
        "",
        &inputs,
        &outputs,
        summary,
        t0.elapsed().as_secs_f64(),
    )?;
    Ok(())
}
