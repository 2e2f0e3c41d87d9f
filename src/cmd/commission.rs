//! `millcomp commission SCENARIO`: the scenario's machine commissioned through its instruments (force
//! calibration DOE, spindle step test, load–deflection test), written as one model bundle; or, with
//! `--coverage N`, the coverage study of the intervals over N seeds.

use anyhow::{Context, bail};
use millcomp_closedloop::Scenario;
use millcomp_closedloop::commissioning::{CommissioningPlant, commission, coverage_study};
use millcomp_closedloop::groove::groove_truth;
use millcomp_closedloop::scenario::StageKind;
use millcomp_models::{IdentifiedModel, InputFile, ModelBundle, ModelFile};
use millcomp_runtime::{Origins, Program};
use millcomp_sim::material::Material;
use serde_json::json;

use crate::cli::CommissionArgs;
use crate::cmd::guard::{Inputs, same_file, with_scenario_models};
use crate::cmd::{print_json, progress_bar, provenance};
use crate::present::commission::{bundle_text, commissioning_text, coverage_text};

pub fn run(args: CommissionArgs, json: bool) -> anyhow::Result<()> {
    let Some(scenario) = args.scenario.clone() else {
        return from_files(&args, json);
    };
    let s = Scenario::load(&scenario)?;
    check_outputs(
        &args,
        with_scenario_models(Inputs::new().add("SCENARIO", &scenario), &s),
    )?;
    if s.stage != StageKind::Groove {
        bail!(
            "{}: stage: commissioning is implemented for groove scenarios (the thin wall is not commissioned yet)",
            scenario.display()
        );
    }
    let material = s
        .groove
        .as_ref()
        .map(|g| g.material.clone())
        .unwrap_or_default();
    let truth = groove_truth(&s)?;
    let seed = args.seed.unwrap_or(s.seed);
    if let Some(n) = args.coverage {
        if n == 0 {
            bail!("--coverage: give at least 1 seed");
        }
        if seed.checked_add(n).is_none() {
            bail!(
                "--seed {seed} with --coverage {n}: the seeds would pass {} (the largest seed); give a \
                 smaller --seed",
                u64::MAX
            );
        }
        let bar = progress_bar(n, "commissionings", json);
        let rows = coverage_study(
            &truth,
            &material,
            s.truth.force_noise_n,
            s.truth.gauge_noise_um,
            &s.commissioning,
            seed..seed + n,
            || bar.inc(1),
        )?;
        bar.finish_and_clear();
        if json {
            return print_json(
                &json!({ "scenario": s.name, "seeds": [seed, seed + n - 1], "coverage": rows }),
            );
        }
        print!("{}", coverage_text(&s.name, seed, n, &rows));
        return Ok(());
    }
    let plant = CommissioningPlant::of_scenario(&s, &truth);
    let c = commission(&plant, &s.commissioning, seed)?;
    if let Some(out) = &args.out {
        let inputs = vec![InputFile::from_path(&scenario)?];
        ModelFile::new("bundle", c.bundle.clone(), provenance(inputs))
            .save(out)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    let export = export_mpc(&args, &c.bundle)?;
    if json {
        return print_json(&json!({
            "scenario": s.name,
            "seed": seed,
            "bundle": c.bundle,
            "spindle_bic": c.spindle_bic,
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "export_mpc": export,
        }));
    }
    print!("{}", commissioning_text(&s.name, seed, &c));
    if let Some(out) = &args.out {
        println!("written: {}", out.display());
    }
    print_export(args.export_mpc.as_deref(), export.as_ref());
    Ok(())
}

/// A bundle assembled from the user's own identified models (`--spindle/--force/--stiffness`).
fn from_files(args: &CommissionArgs, json: bool) -> anyhow::Result<()> {
    check_outputs(
        args,
        Inputs::new()
            .add_opt("--spindle", args.spindle.as_deref())
            .add_opt("--force", args.force.as_deref())
            .add_opt("--stiffness", args.stiffness.as_deref()),
    )?;
    let given = args
        .material
        .as_deref()
        .context("--material: give the workpiece material the force model was identified on")?;
    // a material the physics crate knows (its canonical name is recorded), and the one the force model
    // was identified for: its modulus is a fixed input of that fit
    let known = Material::by_name(given).map_err(|e| anyhow::anyhow!("--material: {e}"))?;
    if let Some(path) = &args.force {
        let f = ModelFile::<IdentifiedModel>::load(path, &["force"])?;
        if let Some(e) = f.model.fixed.get("e_gpa")
            && (e - known.e_gpa).abs() > 1e-9 * known.e_gpa
        {
            bail!(
                "--material {given}: the force model {} was identified with e_gpa = {e} (a material of \
                 that modulus), not {}'s {} GPa; give the material it was identified on",
                path.display(),
                known.name,
                known.e_gpa
            );
        }
    }
    let material = known.name.as_str();
    let bundle = ModelBundle::from_files(
        material,
        args.spindle.as_deref(),
        args.force.as_deref(),
        args.stiffness.as_deref(),
    )?;
    if let Some(out) = &args.out {
        let inputs = [&args.spindle, &args.force, &args.stiffness]
            .into_iter()
            .flatten()
            .map(|p| InputFile::from_path(p))
            .collect::<Result<Vec<_>, _>>()?;
        ModelFile::new("bundle", bundle.clone(), provenance(inputs))
            .save(out)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    let export = export_mpc(args, &bundle)?;
    if json {
        return print_json(&json!({
            "bundle": bundle,
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "export_mpc": export,
        }));
    }
    print!("{}", bundle_text(&bundle));
    if let Some(out) = &args.out {
        println!("written: {}", out.display());
    }
    print_export(args.export_mpc.as_deref(), export.as_ref());
    Ok(())
}

/// `--out` and `--export-mpc` are neither an input (the program too) nor each other.
fn check_outputs(args: &CommissionArgs, inputs: Inputs) -> anyhow::Result<()> {
    let inputs = inputs.add_opt("--program", args.program.as_deref());
    inputs.check_opt("--out", args.out.as_deref())?;
    inputs.check_opt("--export-mpc", args.export_mpc.as_deref())?;
    if let (Some(o), Some(e)) = (&args.out, &args.export_mpc)
        && same_file(o, e)
    {
        bail!("--out and --export-mpc name the same file {}", o.display());
    }
    Ok(())
}

/// `--export-mpc PATH --program PROGRAM`: the MPC `bundle` gives the program, written as JSON
/// (`millcomp_runtime::export`); what was written, for the report.
fn export_mpc(
    args: &CommissionArgs,
    bundle: &ModelBundle,
) -> anyhow::Result<Option<serde_json::Value>> {
    let (Some(out), Some(program)) = (&args.export_mpc, &args.program) else {
        return Ok(None);
    };
    let origins = Origins {
        bundle: args
            .out
            .clone()
            .unwrap_or_else(|| "the commissioned bundle".into()),
        program: program.clone(),
    };
    let doc = millcomp_runtime::export::export_mpc(bundle, &Program::load(program)?, &origins)?;
    doc.save(out)?;
    Ok(Some(json!({
        "path": out.display().to_string(),
        "program": program.display().to_string(),
        "horizon": doc.horizon,
        "qp_n": doc.first_cycle.qp.n,
        "qp_m": doc.first_cycle.qp.m,
        "first_move_v": doc.first_cycle.plan.first(),
    })))
}

fn print_export(path: Option<&std::path::Path>, export: Option<&serde_json::Value>) {
    if let (Some(path), Some(e)) = (path, export) {
        println!(
            "MPC exported: {} (horizon {}, QP {} x {})",
            path.display(),
            e["horizon"],
            e["qp_n"],
            e["qp_m"]
        );
    }
}
