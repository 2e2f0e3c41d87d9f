//! The verbs on measured records (issue 17): `identify thermal --train …` (the thermal study of a drift
//! record), `identify wear` (force against wear and cut count), `identify flutes` (per-flute peaks of a
//! raw force record); and what every verb reading a user's table shares: `--columns`, and the line
//! naming the file read (with its provenance when it is one of the shipped real records).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use millcomp_datasets::mapping::{ColumnMap, MappedTable, RoleGroup, join_on, map_table};
use millcomp_datasets::real::{self, RealRecord};
use millcomp_datasets::{ColumnData, Table};
use millcomp_identify::targets::flutes::{FluteReport, flute_peaks};
use millcomp_identify::targets::thermal_record::{
    Structure, StudyOptions, ThermalRecord, TimeRange, study_channel,
};
use millcomp_identify::targets::wear::{
    CutRange, WearLaw, WearOptions, WearStudy, study_wear, wear_across_units,
};
use millcomp_identify::units::one_unit_note;
use serde::Serialize;
use serde_json::json;

use crate::cli::IdentifyArgs;
use crate::cmd::{print_json, progress_bar, units};
use crate::present;

/// The file a verb read: path, SHA-256, and the shipped real record it is, if any.
#[derive(Debug, Clone, Serialize)]
pub struct InputInfo {
    /// As given.
    pub path: String,
    /// SHA-256 of its bytes.
    pub sha256: String,
    /// The shipped real record (name, source, licence) when the file is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub real: Option<RealInfo>,
}

/// Provenance of a shipped real record.
#[derive(Debug, Clone, Serialize)]
pub struct RealInfo {
    /// Record name (`datasets list`).
    pub name: &'static str,
    /// Where it comes from.
    pub source: &'static str,
    /// Its licence.
    pub licence: &'static str,
    /// Whether the bytes read are the shipped ones.
    pub sha256_matches: bool,
}

impl InputInfo {
    /// Hashes the file and looks it up among the shipped real records.
    pub fn of(path: &Path) -> anyhow::Result<Self> {
        let f = millcomp_models::InputFile::from_path(path)
            .with_context(|| format!("reading {}", path.display()))?;
        let real = real::by_path(path).map(|r: &RealRecord| RealInfo {
            name: r.name,
            source: r.source,
            licence: r.licence,
            sha256_matches: r.sha256 == f.sha256,
        });
        Ok(InputInfo {
            path: path.display().to_string(),
            sha256: f.sha256,
            real,
        })
    }

    /// One line: `FILE (REAL record NAME: SOURCE; LICENCE), sha256 …`.
    pub fn line(&self) -> String {
        let short = &self.sha256[..12.min(self.sha256.len())];
        match &self.real {
            Some(r) => format!(
                "{} — REAL measured record `{}` ({}; licence {}), sha256 {short}…{}",
                self.path,
                r.name,
                r.source,
                r.licence,
                if r.sha256_matches {
                    ""
                } else {
                    " (differs from the shipped copy)"
                }
            ),
            None => format!("{} (user file), sha256 {short}…", self.path),
        }
    }
}

/// Reads `path` (every column typed as `read_any` does) through `--columns` if given: the table, with
/// single-column roles under their role's name, and the notes.
pub fn read_mapped(path: &Path, columns: Option<&str>) -> anyhow::Result<(Table, Vec<String>)> {
    let m = read_mapped_full(path, None, columns)?;
    Ok((m.table, m.notes))
}

/// Reads `path`, joins `join = (file, key)` onto it if given, and applies `--columns`.
pub fn read_mapped_full(
    path: &Path,
    join: Option<(&Path, &str)>,
    columns: Option<&str>,
) -> anyhow::Result<MappedTable> {
    let map = match columns {
        Some(c) => ColumnMap::parse(c)?,
        None => ColumnMap::default(),
    };
    let mut table = millcomp_datasets::read_any(path)?;
    // how the file was read (its encoding, delimiter, decimal commas), then the mapping's notes
    let mut notes = std::mem::take(&mut table.notes);
    if let Some((other, key)) = join {
        let right = millcomp_datasets::read_any(other)?;
        notes.extend(
            right
                .notes
                .iter()
                .map(|n| format!("{} (the --join file {})", n, other.display())),
        );
        let (joined, n) = join_on(&table, &right, key)?;
        table = joined;
        notes.extend(n);
    }
    let mut m = map_table(table, &map)?;
    notes.append(&mut m.notes);
    m.notes = notes;
    Ok(m)
}

/// The numbers of column `name` of the mapped table; a text column is an error naming the file, the
/// file's column and the first 1-based row that is not a finite number.
pub fn numbers(m: &MappedTable, name: &str) -> anyhow::Result<Vec<f64>> {
    let c = m
        .table
        .column(name)
        .with_context(|| format!("{}: no column `{name}`", m.table.origin))?;
    match &c.data {
        ColumnData::Float(v) => Ok(v.clone()),
        ColumnData::Int(v) => Ok(v.iter().map(|&x| x as f64).collect()),
        ColumnData::Text(v) => {
            let row = v
                .iter()
                .position(|s| s.parse::<f64>().map_or(true, |x| !x.is_finite()))
                .unwrap_or(0);
            bail!(
                "{}: column `{}`{}, row {}: `{}` is not a finite number",
                m.table.origin,
                m.file_column(name),
                if m.file_column(name) == name {
                    String::new()
                } else {
                    format!(" (read as `{name}`)")
                },
                row + 1,
                v.get(row).map_or("", String::as_str)
            )
        }
    }
}

/// The columns of `role` (mapped, or present under that name), or an error saying how to map it.
fn role(m: &MappedTable, role: &str, what: &str) -> anyhow::Result<RoleGroup> {
    m.group(role).with_context(|| {
        format!(
            "{}: no `{role}` column ({what}); map one with --columns {role}=COLUMN (columns present: {})",
            m.table.origin,
            m.table.names().join(", ")
        )
    })
}

fn single(m: &MappedTable, r: &str, what: &str) -> anyhow::Result<(String, Vec<f64>)> {
    let g = role(m, r, what)?;
    if g.columns.len() != 1 {
        bail!(
            "{}: --columns {r}={}: `{r}` takes one column, not {}",
            m.table.origin,
            g.sources.join("+"),
            g.columns.len()
        );
    }
    Ok((g.sources[0].clone(), numbers(m, &g.columns[0])?))
}

fn several(m: &MappedTable, r: &str) -> anyhow::Result<Vec<(String, Vec<f64>)>> {
    match m.group(r) {
        Some(g) => g
            .columns
            .iter()
            .zip(&g.sources)
            .map(|(c, s)| Ok((s.clone(), numbers(m, c)?)))
            .collect(),
        None => Ok(Vec::new()),
    }
}

const LEGACY_THERMAL: [&str; 3] = ["exponential", "linear-temperature", "speed-dependent"];

/// Whether `identify thermal` runs the record study (a training range, or one of its models).
pub fn is_thermal_study(args: &IdentifyArgs) -> bool {
    args.train.is_some()
        || args
            .model
            .as_deref()
            .is_some_and(|m| !LEGACY_THERMAL.contains(&m))
}

/// `millcomp identify thermal RECORD --train … [--test …]`.
pub fn thermal(args: IdentifyArgs, json: bool) -> anyhow::Result<()> {
    let info = InputInfo::of(&args.file)?;
    let m = read_mapped_full(&args.file, None, args.columns.as_deref())?;
    if !args.also.is_empty() || m.group(millcomp_identify::units::UNIT_ROLE).is_some() {
        bail!(
            "{}: the thermal record study (--train) reads one machine's record: it does not combine units \
             (--also, --columns unit=…) yet; study each machine's record on its own",
            args.file.display()
        );
    }
    let (t_col, t) = single(&m, "t_s", "the record's time in s")?;
    m.strictly_increasing(
        &m.group("t_s")
            .map_or("t_s".into(), |g| g.columns[0].clone()),
    )?;
    let speed = match m.group("speed_rpm") {
        Some(_) => Some(single(&m, "speed_rpm", "the spindle speed")?),
        None => None,
    };
    let temps = several(&m, "temp_c")?;
    let channels = several(&m, "drift_um")?;
    if channels.is_empty() {
        bail!(
            "{}: no drift channel: map one or more with --columns drift_um=COLUMN (or a pattern such as disp_ch*_um)",
            args.file.display()
        );
    }
    let train = TimeRange::parse("--train", args.train.as_deref().unwrap_or("start:end"))?;
    let test = args
        .test
        .as_deref()
        .map(|r| TimeRange::parse("--test", r))
        .transpose()?;
    let mut opts = StudyOptions::new(train, test);
    opts.folds = args.folds;
    match args.model.as_deref().unwrap_or("auto") {
        "auto" => {}
        m if LEGACY_THERMAL.contains(&m) => bail!(
            "--model {m}: a record study (--train) fits auto or the structures speed-1tau, speed-2tau, \
             temperature-stepwise, temperature-ridge, combined-{{1,2}}tau-{{stepwise,ridge}}"
        ),
        m => {
            opts.structures = m
                .split(',')
                .map(|s| Structure::parse(s.trim()))
                .collect::<Result<_, _>>()?;
        }
    }
    let rec = ThermalRecord {
        t_s: &t,
        speed_rpm: speed.as_ref().map(|(_, v)| v.as_slice()),
        temps_c: temps
            .iter()
            .map(|(n, v)| (n.clone(), v.as_slice()))
            .collect(),
    };
    let bar = progress_bar(channels.len() as u64, "channels", json);
    let mut studies = Vec::new();
    for (name, y) in &channels {
        let s = study_channel(&rec, name, y, &opts)
            .with_context(|| format!("{}: thermal study of `{name}`", args.file.display()))?;
        studies.push(s);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let plots = match &args.plots {
        Some(dir) => present::record::thermal_plots(dir, &t, &studies, &info)?,
        None => Vec::new(),
    };
    let mapping = json!({
        "t_s": t_col,
        "speed_rpm": speed.as_ref().map(|(n, _)| n),
        "temp_c": temps.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        "drift_um": channels.iter().map(|(n, _)| n).collect::<Vec<_>>(),
    });
    if json {
        return print_json(&json!({
            "input": info,
            "columns": mapping,
            "notes": m.notes,
            "channels": studies,
            "summary": present::record::thermal_summary(&studies),
            "plots": plots,
        }));
    }
    print!(
        "{}",
        present::record::thermal_text(
            &info,
            &t_col,
            speed.as_ref().map(|s| s.0.as_str()),
            &temps,
            &studies
        )
    );
    for n in &m.notes {
        println!("note: {n}");
    }
    for p in &plots {
        println!("plot: {}", p.display());
    }
    Ok(())
}

/// `millcomp identify wear PER_CUT.csv [--join WEAR.csv --on run] --columns cut=…,force_n=…[,vb_um=…]`;
/// with `--also` (one `--join` each) or `--columns unit=COLUMN`, each unit (tool) is studied on its own
/// and the units are combined (issue 50: what one tool's fit says of the next).
pub fn wear(args: IdentifyArgs, json: bool) -> anyhow::Result<()> {
    let files = units::read_files(&args)?;
    let (unit_col, unit_rows) = units::units_of(&files)?;
    let meta = units::meta_options(&args)?;
    let laws: Vec<WearLaw> = args
        .laws
        .iter()
        .map(|l| WearLaw::parse(l.trim()))
        .collect::<Result<_, _>>()?;
    let multi = unit_rows.len() >= 2;
    let mut out: Vec<WearUnit> = Vec::new();
    for u in &unit_rows {
        let f = &files[u.file];
        let m = &f.m;
        let (cut_col, cut_all) = single(m, "cut", "the cut number of each row")?;
        let cut = units::take(&cut_all, &u.rows);
        let cut_name = m
            .group("cut")
            .map_or("cut".into(), |g| g.columns[0].clone());
        if unit_col.is_none() {
            m.strictly_increasing(&cut_name)?;
        } else if let Some(j) = (1..cut.len()).find(|&j| cut[j] <= cut[j - 1]) {
            bail!(
                "{}: column `{cut_col}` read as `cut`, row {}: {} is not after the unit's previous cut {} (unit `{}`: a unit's cuts must strictly increase)",
                f.path.display(),
                u.rows[j] + 1,
                cut[j],
                cut[j - 1],
                u.unit
            );
        }
        let forces: Vec<(String, Vec<f64>)> = several(m, "force_n")?
            .into_iter()
            .map(|(n, v)| (n, units::take(&v, &u.rows)))
            .collect();
        if forces.is_empty() {
            bail!(
                "{}: no force channel: map one or more with --columns force_n=COLUMN (e.g. force_*__rms)",
                f.path.display()
            );
        }
        let vb: Vec<(String, Vec<f64>)> = several(m, "vb_um")?
            .into_iter()
            .map(|(n, v)| (n, units::take(&v, &u.rows)))
            .collect();
        let train = CutRange::parse(
            "--train",
            args.train.as_deref().unwrap_or(&format!("{}:end", cut[0])),
        )?;
        let test = args
            .test
            .as_deref()
            .map(|r| CutRange::parse("--test", r))
            .transpose()?;
        let mut opts = WearOptions::new(train, test);
        opts.folds = args.folds;
        if !laws.is_empty() {
            opts.laws = laws.clone();
        }
        let vb_refs: Vec<(String, &[f64])> =
            vb.iter().map(|(n, v)| (n.clone(), v.as_slice())).collect();
        let mut studies = Vec::new();
        for (name, force) in &forces {
            let s = study_wear(
                &cut,
                (!vb_refs.is_empty()).then_some(vb_refs.as_slice()),
                name,
                force,
                &opts,
            )
            .with_context(|| {
                format!(
                    "{}: wear study of `{name}`{}",
                    f.path.display(),
                    if multi {
                        format!(" (unit `{}`)", u.unit)
                    } else {
                        String::new()
                    }
                )
            })?;
            studies.push(s);
        }
        let mean_vb: Vec<f64> = (0..cut.len())
            .map(|i| vb.iter().map(|v| v.1[i]).sum::<f64>() / vb.len().max(1) as f64)
            .collect();
        out.push(WearUnit {
            unit: u.unit.clone(),
            input: f.info.clone(),
            joined: f.joined.clone(),
            cut_column: cut_col,
            last_cut: cut[cut.len() - 1],
            vb_range_um: (!vb.is_empty()).then(|| {
                [
                    mean_vb.iter().copied().fold(f64::INFINITY, f64::min),
                    mean_vb.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                ]
            }),
            vb,
            cut,
            studies,
        });
    }
    let notes: Vec<String> = files.iter().flat_map(|f| f.m.notes.clone()).collect();
    let across = if multi {
        let at_vb_um = match args.at_vb_um {
            Some(v) => v,
            None => shared_wear_midpoint(&out)?,
        };
        let per: Vec<(String, Vec<WearStudy>)> = out
            .iter()
            .map(|u| (u.unit.clone(), u.studies.clone()))
            .collect();
        Some(wear_across_units(&per, at_vb_um, &meta)?)
    } else {
        if args.at_vb_um.is_some() {
            bail!(
                "--at-vb-um: the force at a stated wear is predicted for a new unit: it needs two or more units (--also, or --columns unit=COLUMN)"
            );
        }
        None
    };
    let plots = match (&args.plots, &across) {
        (Some(dir), Some(a)) => present::units::wear_units_plots(dir, &out, a)?,
        (Some(dir), None) => {
            present::record::wear_plots(dir, &out[0].cut, &out[0].studies, &out[0].input)?
        }
        (None, _) => Vec::new(),
    };
    let one_unit = (!multi).then(|| {
        one_unit_note(
            unit_rows
                .first()
                .filter(|_| unit_col.is_some())
                .map(|u| u.unit.as_str()),
        )
    });
    if json {
        let new_unit: Option<serde_json::Map<String, serde_json::Value>> =
            across.as_ref().map(|a| {
                a.iter()
                    .map(|c| (c.channel.clone(), json!(c.across.new_unit())))
                    .collect()
            });
        if !multi {
            let u = &out[0];
            return print_json(&json!({
                "input": u.input,
                "joined": u.joined,
                "columns": {"cut": u.cut_column, "force_n": u.studies.iter().map(|s| &s.channel).collect::<Vec<_>>(),
                            "vb_um": u.vb.iter().map(|v| &v.0).collect::<Vec<_>>()},
                "notes": notes.iter().chain(&one_unit).collect::<Vec<_>>(),
                "channels": u.studies,
                "plots": plots,
            }));
        }
        return print_json(&json!({
            "unit_column": unit_col,
            "units": out,
            "notes": notes,
            "across_units": across,
            "new_unit": new_unit,
            "plots": plots,
        }));
    }
    for u in &out {
        if multi {
            println!(
                "=== unit `{}`{}: {} cuts ===",
                u.unit,
                unit_col
                    .as_ref()
                    .map_or(" (a file)".to_string(), |c| format!(" ({c} = {})", u.unit)),
                u.cut.len()
            );
        }
        print!(
            "{}",
            present::record::wear_text(
                &u.input,
                u.joined.as_ref(),
                &u.cut_column,
                u.last_cut,
                &u.vb,
                &u.studies
            )
        );
        if multi {
            println!();
        }
    }
    if let Some(a) = &across {
        print!(
            "{}",
            present::units::wear_across_text(
                &out.iter()
                    .map(|u| (u.unit.as_str(), u.vb_range_um))
                    .collect::<Vec<_>>(),
                a
            )
        );
    }
    for n in notes.iter().chain(&one_unit) {
        println!("note: {n}");
    }
    for p in &plots {
        println!("plot: {}", p.display());
    }
    Ok(())
}

/// One unit of a wear run.
#[derive(Debug, Serialize)]
pub struct WearUnit {
    /// The unit.
    pub unit: String,
    /// Its file.
    pub input: InputInfo,
    /// The file joined onto it.
    pub joined: Option<InputInfo>,
    /// The cut column's name in the file.
    pub cut_column: String,
    /// Its last cut.
    pub last_cut: f64,
    /// Range of its mean flank wear (µm).
    pub vb_range_um: Option<[f64; 2]>,
    /// The flank-wear columns (for the report).
    #[serde(skip)]
    pub vb: Vec<(String, Vec<f64>)>,
    /// Its cut numbers.
    #[serde(skip)]
    pub cut: Vec<f64>,
    /// One study per force channel.
    pub studies: Vec<WearStudy>,
}

/// The middle of the mean-wear range every unit covers, rounded to 10 µm.
fn shared_wear_midpoint(units: &[WearUnit]) -> anyhow::Result<f64> {
    let ranges: Vec<[f64; 2]> = units.iter().filter_map(|u| u.vb_range_um).collect();
    if ranges.len() != units.len() {
        bail!(
            "across units, wear is combined through the force against flank wear: map vb_um in every file (--columns vb_um=…)"
        );
    }
    let lo = ranges
        .iter()
        .map(|r| r[0])
        .fold(f64::NEG_INFINITY, f64::max);
    let hi = ranges.iter().map(|r| r[1]).fold(f64::INFINITY, f64::min);
    if lo > hi {
        bail!(
            "the units' flank-wear ranges do not overlap (shared from {lo:.1} to {hi:.1} um): state the wear to predict the force at with --at-vb-um"
        );
    }
    Ok((0.5 * (lo + hi) / 10.0).round() * 10.0)
}

/// One raw record's per-flute reports.
#[derive(Debug, Serialize)]
pub struct FluteFile {
    /// The file.
    pub input: InputInfo,
    /// One report per force channel.
    pub channels: Vec<FluteReport>,
    /// Notes of the mapping.
    pub notes: Vec<String>,
    /// Channel values, for plots.
    #[serde(skip)]
    pub traces: Vec<Vec<f64>>,
}

/// `millcomp identify flutes RAW.csv [--also RAW2.csv] --flutes 3 --speed-rpm 10400 --sample-rate-hz 50000`.
pub fn flutes(args: IdentifyArgs, json: bool) -> anyhow::Result<()> {
    let (Some(z), Some(rpm), Some(fs)) = (args.flutes, args.speed_rpm, args.sample_rate_hz) else {
        bail!(
            "identify flutes needs --flutes, --speed-rpm and --sample-rate-hz (the cutter and the record's conditions)"
        );
    };
    let mut files: Vec<PathBuf> = vec![args.file.clone()];
    files.extend(args.also.iter().cloned());
    let mut out = Vec::new();
    for f in &files {
        let input = InputInfo::of(f)?;
        let m = read_mapped_full(f, None, args.columns.as_deref())?;
        let chans = several(&m, "force_n")?;
        if chans.is_empty() {
            bail!(
                "{}: no force channel: map one or more with --columns force_n=COLUMN (e.g. force_x_N+force_y_N)",
                f.display()
            );
        }
        let mut reps = Vec::new();
        for (name, v) in &chans {
            reps.push(
                flute_peaks(name, v, fs, rpm, z, args.alpha)
                    .with_context(|| format!("{}: per-flute peaks of `{name}`", f.display()))?,
            );
        }
        out.push(FluteFile {
            input,
            channels: reps,
            notes: m.notes.clone(),
            traces: chans.into_iter().map(|c| c.1).collect(),
        });
    }
    let plots = match &args.plots {
        Some(dir) => present::record::flute_plots(dir, &out)?,
        None => Vec::new(),
    };
    if json {
        return print_json(&json!({
            "flutes": z, "speed_rpm": rpm, "sample_rate_hz": fs, "alpha": args.alpha,
            "files": out, "plots": plots,
        }));
    }
    print!("{}", present::record::flutes_text(z, rpm, fs, &out));
    for p in &plots {
        println!("plot: {}", p.display());
    }
    Ok(())
}

/// Signal roles `diagnose --record` looks for when `--signal` is not given.
const SIGNAL_ROLES: [&str; 3] = ["drift_um", "force_n", "depth_um"];

/// `millcomp diagnose --record FILE --columns …`: each signal column against the no-drift nominal.
pub fn diagnose(args: crate::cli::DiagnoseArgs, json: bool) -> anyhow::Result<()> {
    use millcomp_diagnose::record::{Record, RecordContext, RecordOptions, diagnose_record};
    let Some(path) = args.record.as_deref() else {
        bail!("diagnose --record needs a file");
    };
    let info = InputInfo::of(path)?;
    let m = read_mapped_full(path, None, args.columns.as_deref())?;
    let signal_role = match &args.signal {
        Some(s) => s.clone(),
        None => SIGNAL_ROLES
            .iter()
            .find(|r| m.group(r).is_some())
            .map(|r| r.to_string())
            .with_context(|| {
                format!(
                    "{}: no signal: map one with --columns drift_um=COLUMN (or force_n=…), or name its role with --signal",
                    path.display()
                )
            })?,
    };
    let unit = millcomp_datasets::mapping::unit_suffix(&signal_role).with_context(|| {
        format!("--signal {signal_role}: the signal's role must end in its unit (e.g. drift_um, force_n)")
    })?;
    let signals = several(&m, &signal_role)?;
    if signals.is_empty() {
        bail!("{}: no `{signal_role}` column", path.display());
    }
    let opt_single = |r: &str, what: &str| -> anyhow::Result<Option<Vec<f64>>> {
        match m.group(r) {
            Some(_) => Ok(Some(single(&m, r, what)?.1)),
            None => Ok(None),
        }
    };
    if m.group("t_s").is_some() {
        m.strictly_increasing(
            &m.group("t_s")
                .map_or("t_s".into(), |g| g.columns[0].clone()),
        )?;
    }
    if m.group("cut").is_some() {
        m.strictly_increasing(
            &m.group("cut")
                .map_or("cut".into(), |g| g.columns[0].clone()),
        )?;
    }
    let context = RecordContext {
        t_s: opt_single("t_s", "time")?,
        speed_rpm: opt_single("speed_rpm", "spindle speed")?,
        temps_c: several(&m, "temp_c")?,
        coolant_on: opt_single("coolant_on", "coolant")?,
        cut_length_mm: opt_single("cut_length_mm", "engaged length")?,
        cut: opt_single("cut", "cut count")?,
        machine_x_mm: opt_single("machine_x_mm", "machine X")?,
        flutes: several(&m, "flute_n")?,
    };
    let opts = RecordOptions {
        alpha: args.alpha,
        candidates: (!args.candidates.is_empty()).then(|| args.candidates.clone()),
    };
    let bar = progress_bar(signals.len() as u64, "signals", json);
    let mut reports = Vec::new();
    for (name, values) in signals {
        let rec = Record {
            origin: path.display().to_string(),
            signal: name.clone(),
            unit: unit.clone(),
            values,
            context: context.clone(),
        };
        reports.push(
            diagnose_record(&rec, &opts)
                .with_context(|| format!("diagnosing `{name}` of {}", path.display()))?,
        );
        bar.inc(1);
    }
    bar.finish_and_clear();
    let plots = match &args.report {
        Some(dir) => {
            let x = match (&context.t_s, &context.cut) {
                (Some(t), _) => Some(("time (s)", t.as_slice())),
                (None, Some(c)) => Some(("cut", c.as_slice())),
                _ => None,
            };
            present::record::diagnose_plots(dir, x, &reports, &info)?
        }
        None => Vec::new(),
    };
    if json {
        // one signal: the contract document itself, with the input beside it
        if reports.len() == 1 {
            let mut v = serde_json::to_value(&reports[0])?;
            if let Some(o) = v.as_object_mut() {
                o.insert("input".into(), serde_json::to_value(&info)?);
                o.insert("notes_columns".into(), serde_json::to_value(&m.notes)?);
            }
            return print_json(&v);
        }
        return print_json(
            &json!({"input": info, "signals": reports, "notes_columns": m.notes, "plots": plots}),
        );
    }
    print!("{}", present::record::diagnose_text(&info, &reports));
    for n in &m.notes {
        println!("note: {n}");
    }
    for p in &plots {
        println!("report: {}", p.display());
    }
    Ok(())
}
