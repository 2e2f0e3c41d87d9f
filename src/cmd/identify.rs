//! `millcomp identify <what> FILE`: least-squares fits with honest uncertainty
//! (`millcomp-identify`), reading the data through `millcomp-datasets`.

use anyhow::{Context, bail};
use millcomp_identify::targets::force::ForceParam;
use millcomp_identify::targets::thermal::ThermalModel;
use millcomp_identify::targets::wall::WallGeometry;
use millcomp_identify::units::{UNIT_ROLE, identify_units, one_unit_note};
use millcomp_identify::{
    Columns, FitReport, Identified, IdentifyOptions, Target, identify_columns,
};

use crate::cli::{IdentifyArgs, IdentifyWhat};
use crate::cmd::guard::{Inputs, svg_starting};
use crate::cmd::print_json;

pub fn run(args: IdentifyArgs, json: bool) -> anyhow::Result<()> {
    let mut inputs = Inputs::new().add("FILE", &args.file);
    for j in &args.join {
        inputs = inputs.add("--join", j);
    }
    for a in &args.also {
        inputs = inputs.add("--also", a);
    }
    inputs.check_opt("--save", args.save.as_deref())?;
    if let Some(dir) = &args.plots {
        inputs.check_dir("--plots", dir, |rel| {
            svg_starting(rel, &["thermal_", "wear_", "flutes_"])
        })?;
    }
    if args.diagnose {
        if !matches!(args.what, IdentifyWhat::Force) {
            bail!("--diagnose is for `identify force` on a peak-force table");
        }
        return crate::cmd::forces::run(&args, json);
    }
    let record_study = matches!(args.what, IdentifyWhat::Wear | IdentifyWhat::Flutes)
        || (matches!(args.what, IdentifyWhat::Thermal)
            && crate::cmd::record::is_thermal_study(&args));
    if record_study && args.save.is_some() {
        bail!(
            "--save: the models of a record study (thermal --train, wear, flutes) have no model-file kind yet; \
             use --json to keep them"
        );
    }
    let verb = match args.what {
        IdentifyWhat::Spindle => Target::Spindle,
        IdentifyWhat::Stiffness => Target::Stiffness,
        IdentifyWhat::Force => Target::Force,
        IdentifyWhat::Thermal if crate::cmd::record::is_thermal_study(&args) => {
            return crate::cmd::record::thermal(args, json);
        }
        IdentifyWhat::Thermal => Target::Thermal,
        IdentifyWhat::Wall => Target::Wall,
        IdentifyWhat::Part => Target::Part,
        IdentifyWhat::Kienzle => Target::Kienzle,
        IdentifyWhat::FeedAxis => Target::FeedAxis,
        IdentifyWhat::Hysteresis => Target::Hysteresis,
        IdentifyWhat::Wear => return crate::cmd::record::wear(args, json),
        IdentifyWhat::Flutes => return crate::cmd::record::flutes(args, json),
    };
    let options = options(&args)?;
    let meta = crate::cmd::units::meta_options(&args)?;
    let files = crate::cmd::units::read_files(&args)?;
    for f in &files {
        for n in &f.m.notes {
            eprintln!("note: {}: {n}", f.path.display());
        }
    }
    let (unit_col, unit_rows) = crate::cmd::units::units_of(&files)?;
    let columns_of = |i: usize| {
        let mut c = millcomp_datasets::adapters::identify_columns(&files[i].m.table);
        c.remove(UNIT_ROLE);
        c
    };
    if unit_rows.len() >= 2 {
        if args.save.is_some() {
            bail!(
                "--save: {} units were fitted; a model file holds one unit's fit — save each unit's \
                 from its own rows, or keep the across-units analysis with --json",
                unit_rows.len()
            );
        }
        let units: Vec<(String, Columns)> = unit_rows
            .iter()
            .map(|u| (u.unit.clone(), columns_of(u.file).rows(&u.rows)))
            .collect();
        let r = identify_units(verb, &units, &options, &meta).with_context(|| {
            format!(
                "{}: identify {} unit by unit",
                files[0].path.display(),
                verb.name()
            )
        })?;
        if json {
            return print_json(&serde_json::json!({
                "inputs": files.iter().map(|f| &f.info).collect::<Vec<_>>(),
                "unit_column": unit_col,
                "target": r.target,
                "units": r.units,
                "across_units": r.across_units,
                "new_unit": r.new_unit,
            }));
        }
        for u in &r.units {
            println!(
                "=== unit `{}`{}: {} rows ===",
                u.unit,
                unit_col
                    .as_ref()
                    .map_or(" (a file)".to_string(), |c| format!(" ({c} = {})", u.unit)),
                u.rows
            );
            print_fit(&u.fit);
            println!();
        }
        print!("{}", crate::present::units::across_text(&r.across_units));
        return Ok(());
    }
    let mut fit = identify_columns(verb, &columns_of(0), &options)
        .with_context(|| format!("{}: identify {}", args.file.display(), verb.name()))?;
    fit.notes.push(one_unit_note(
        unit_rows
            .first()
            .filter(|_| unit_col.is_some())
            .map(|u| u.unit.as_str()),
    ));
    if let Some(path) = &args.save {
        let inputs = vec![millcomp_models::InputFile::from_path(&args.file)?];
        millcomp_models::ModelFile::new(
            &fit.kind,
            fit.model.clone(),
            crate::cmd::provenance(inputs),
        )
        .save(path)
        .with_context(|| format!("saving the model to {}", path.display()))?;
    }
    if json {
        return print_json(&fit);
    }
    print_fit(&fit);
    if let Some(path) = &args.save {
        println!("model: {}", path.display());
    }
    Ok(())
}

fn print_fit(fit: &Identified) {
    print_report(&fit.report);
    for (name, d) in &fit.derived {
        println!(
            "derived {name} = {:.6} ± {:.3} (95 % [{:.6}, {:.6}])  {}",
            d.value, d.std_err, d.ci95[0], d.ci95[1], d.formula
        );
    }
    for (group, r) in &fit.groups {
        println!("\n[{group}]");
        print_report(r);
    }
    for n in &fit.notes {
        println!("note: {n}");
    }
}

fn options(args: &IdentifyArgs) -> anyhow::Result<IdentifyOptions> {
    let thermal_model: ThermalModel = args
        .model
        .as_deref()
        .unwrap_or("exponential")
        .parse()
        .context("--model")?;
    let force_free = args
        .free
        .iter()
        .map(|n| ForceParam::parse(n).with_context(|| format!("--free {n}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let wall_geometry = match args.wall_geometry.as_slice() {
        [] => None,
        [height_um, thickness_um, length_um] => Some(WallGeometry {
            height_um: *height_um,
            thickness_um: *thickness_um,
            length_um: *length_um,
        }),
        other => bail!(
            "--wall-geometry takes height_um,thickness_um,length_um (3 numbers), got {}",
            other.len()
        ),
    };
    Ok(IdentifyOptions {
        thermal_model,
        spindle_extra_pole: args.extra_pole,
        spindle_dead_time: args.dead_time,
        tilt_deg: args.tilt_deg.clone(),
        machine_stiffness_n_per_um: args.machine_stiffness_n_per_um,
        force_free,
        material: args.material.clone(),
        relative_errors: args.relative_errors,
        wall_geometry,
        ..Default::default()
    })
}

fn print_report(r: &FitReport) {
    println!(
        "model: {}   method: {}   status: {:?}",
        r.model, r.method, r.status
    );
    println!(
        "{:<22} {:>14} {:>12} {:>28}",
        "parameter", "estimate", "std err", "95 % interval"
    );
    for (name, value) in &r.params {
        let se = r.std_err.get(name).copied().unwrap_or(f64::NAN);
        let ci = r.ci95.get(name).copied().unwrap_or([f64::NAN; 2]);
        println!(
            "{name:<22} {value:>14.6} {se:>12.4} {:>28}",
            format!("[{:.6}, {:.6}]", ci[0], ci[1])
        );
    }
    for (name, value) in &r.fixed {
        println!("{name:<22} {value:>14.6} {:>12} {:>28}", "(fixed)", "");
    }
    println!(
        "rms residual {:.4} {}   n = {}   dof = {}   condition number {:.3e}   iterations {}",
        r.rms_residual.value, r.rms_residual.unit, r.n_obs, r.dof, r.condition_number, r.iterations
    );
    for w in &r.warnings {
        println!("warning: {w}");
    }
}
