//! Command-line arguments (clap derive). One enum variant per verb of the CLI contract.

use std::path::PathBuf;

use clap::builder::RangedU64ValueParser;
use clap::{Args, Parser, Subcommand};

/// The most worker threads a run takes (`--threads`): far beyond any machine's cores; a pool of a
/// billion threads would exhaust the machine before it started.
pub const MAX_THREADS: u64 = 1024;
/// The most seeds of a coverage study (`commission --coverage`): at 100 000 seeds a 95 % rate's
/// binomial interval is ±0.14 %, finer than any use; one seed takes about 0.3 s.
pub const MAX_COVERAGE_SEEDS: u64 = 100_000;
/// The most replicates of a design (`doe design --replicates`).
pub const MAX_REPLICATES: u64 = 1000;
/// The most centre points per block (`doe design --center-points`).
pub const MAX_CENTER_POINTS: u64 = 1000;
/// The most blocks (`doe design --blocks`).
pub const MAX_BLOCKS: u64 = 64;
/// The most parts in a row (`parts --parts`).
pub const MAX_PARTS: u64 = 1000;
/// The most machines (`parts --seeds`).
pub const MAX_MACHINES: u64 = 10_000;
/// The most cross-validation folds (`identify --folds`).
pub const MAX_FOLDS: u64 = 100;
/// The most flutes of a cutter (`identify flutes --flutes`).
pub const MAX_FLUTES: u64 = 64;

const EXIT_CODES: &str = "\
Exit status:
  0  success
  1  failure: bad input (the message names the file, column, row or parameter), unreadable file
  2  usage error (unknown option, missing argument)

Errors go to stderr with their cause chain; with --json, results go to stdout as one JSON document.";

/// A number in `(0, max]` (`unit` names it in the message).
fn positive_at_most(s: &str, max: f64, unit: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v > 0.0 && v <= max {
        Ok(v)
    } else {
        Err(format!("{v} is not in (0, {max}] {unit}"))
    }
}

/// A spindle speed: above 0, at most 1e6 rpm (the physics crate's bound).
fn speed_rpm(s: &str) -> Result<f64, String> {
    positive_at_most(s, 1e6, "rpm")
}

/// A sample rate: above 0, at most 100 MHz (a revolution is then still a few million samples).
fn sample_rate_hz(s: &str) -> Result<f64, String> {
    positive_at_most(s, 1e8, "Hz")
}

/// Micro-milling accuracy: design and analyse experiments, identify material, friction and machine
/// parameters, compensate tool and thin-wall deflection with MPC, and diagnose model gaps.
#[derive(Debug, Parser)]
#[command(name = "millcomp", version, about, after_help = EXIT_CODES)]
pub struct Cli {
    /// Print one JSON document on stdout instead of human-readable tables.
    #[arg(long, global = true)]
    pub json: bool,

    /// The verb.
    #[command(subcommand)]
    pub command: Command,
}

/// The verbs.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The main job end to end on a simulated machine — design, measure, analyse, identify, commission,
    /// build, compare, diagnose, rerun — with one report (report.md, report.html).
    #[command(
        after_help = "Example:\n  millcomp demo --out millcomp-demo    # then open millcomp-demo/report.html"
    )]
    Demo(DemoArgs),
    /// The same pipeline on your measured files: PLAN.toml names a file for each stage (docs/pipeline.md);
    /// a stage without files is skipped, saying what it would need.
    #[command(
        after_help = "Example:\n  millcomp pipeline datasets/pipeline/plan.toml --out my-machine"
    )]
    Pipeline(PipelineArgs),
    /// Design of experiments: generate treatment matrices and analyse responses.
    #[command(
        after_help = "Example:\n  millcomp doe design --design fractional --factors A,B,C,D --resolution 4 --seed 1"
    )]
    #[command(subcommand)]
    Doe(DoeCommand),
    /// Identify model parameters from measured runs by least squares.
    #[command(
        after_help = "Example:\n  millcomp identify spindle datasets/runs/spindle_step_synthetic.csv --save spindle.toml"
    )]
    Identify(Box<IdentifyArgs>),
    /// Find where simulation and measurement disagree and name the missing physical effect.
    #[command(
        after_help = "Example:\n  millcomp diagnose datasets/synthetic/coolant_thermal_drift.toml datasets/synthetic/coolant_thermal_drift.csv"
    )]
    Diagnose(DiagnoseArgs),
    /// Commission a scenario's machine: calibration experiments through its instruments, identified into
    /// one model bundle the controllers are built from.
    #[command(
        after_help = "Example:\n  millcomp commission datasets/scenarios/groove_s7_20deg_commissioned.toml --out bundle.toml"
    )]
    Commission(CommissionArgs),
    /// Simulate a session or a closed-loop scenario.
    #[command(
        after_help = "Example:\n  millcomp simulate datasets/scenarios/groove_s7_20deg.toml --controller mpc"
    )]
    Simulate(SimulateArgs),
    /// A recorded sensor log through a commissioned controller: the commands each controller would
    /// have sent, before it moves the spindle (docs/replay.md).
    Replay(ReplayArgs),
    /// Run controllers over many conditions and compare them statistically.
    #[command(
        after_help = "Example:\n  millcomp batch --doe \"--design fractional --factors tilt_deg=20:40,depth_um=40:80,upfeed_um=8:12 --resolution 3 --seed 1\" --controllers pid-tuned,mpc"
    )]
    Batch(BatchArgs),
    /// Cut successive parts of a groove scenario: after each the groove is measured, the deflection model
    /// identified from the parts so far, and the next part uses it (run-to-run learning).
    #[command(
        after_help = "Example:\n  millcomp parts datasets/scenarios/groove_s7_20deg.toml --parts 3 --seeds 4"
    )]
    Parts(PartsArgs),
    /// List and show the published tables, real measured records and synthetic runs shipped with millcomp.
    #[command(after_help = "Example:\n  millcomp datasets show clayton_doe")]
    #[command(subcommand)]
    Datasets(DatasetsCommand),
}

/// `millcomp demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Directory for the report, the measured files, the models and the tables.
    #[arg(long, default_value = "millcomp-demo")]
    pub out: PathBuf,
    /// Seed of the simulated machine (its tool, instruments and what the nominal model lacks).
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Worker threads of the comparison's runs (default: all cores; 1 to 1024).
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_THREADS))]
    pub threads: Option<usize>,
    /// A quicker look: 8 conditions (a 2^(4−1) over tilt, depth, material and a depth step at once) on
    /// 5 mm grooves instead of 32 on 10 mm.
    #[arg(long)]
    pub quick: bool,
}

/// `millcomp pipeline PLAN.toml`.
#[derive(Debug, Args)]
pub struct PipelineArgs {
    /// The plan (TOML, docs/pipeline.md): the measured files of each stage and the designs.
    pub plan: PathBuf,
    /// Directory for the report, the models and the tables.
    #[arg(long, default_value = "millcomp-pipeline")]
    pub out: PathBuf,
    /// Worker threads of the comparison's runs, if the plan runs them on a simulated machine (1 to 1024).
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_THREADS))]
    pub threads: Option<usize>,
}

/// `millcomp commission`.
#[derive(Debug, Args)]
pub struct CommissionArgs {
    /// Groove scenario (TOML): its truth plant, instruments, noise and `[commissioning]` plan. Not with
    /// `--spindle/--force/--stiffness`, which assemble a bundle from your own identified models instead.
    #[arg(required_unless_present_any = ["spindle", "force", "stiffness"])]
    pub scenario: Option<PathBuf>,
    /// Write the model bundle here (kind `bundle`, the common model-file format).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Seed of the experiments' noise (default: the scenario's seed).
    #[arg(long, requires = "scenario")]
    pub seed: Option<u64>,
    /// Instead of one commissioning: a coverage study over this many seeds (1 to 100 000), each with its
    /// own drawn instrument errors, counting how often each 95 % interval covers the value the truth
    /// implies.
    #[arg(long, requires = "scenario", value_parser = RangedU64ValueParser::<u64>::new().range(1..=MAX_COVERAGE_SEEDS))]
    pub coverage: Option<u64>,
    /// Your machine's spindle model (`millcomp identify spindle STEP.csv --save`), for a bundle from your
    /// own calibration records.
    #[arg(long, conflicts_with = "scenario", requires = "material")]
    pub spindle: Option<PathBuf>,
    /// Your force model (`millcomp identify force CUTS.csv --save`).
    #[arg(long, conflicts_with = "scenario", requires = "material")]
    pub force: Option<PathBuf>,
    /// Your stiffness model (`millcomp identify stiffness LOADS.csv --save`).
    #[arg(long, conflicts_with = "scenario", requires = "material")]
    pub stiffness: Option<PathBuf>,
    /// The workpiece material the force model was identified on (with `--spindle/--force/--stiffness`).
    #[arg(long)]
    pub material: Option<String>,
    /// Also write the MPC the bundle gives `--program` as JSON (its prediction model, weights,
    /// constraints, horizon and first QP: docs/export-mpc.md), for CasADi, do-mpc or acados.
    #[arg(long, requires = "program", conflicts_with = "coverage")]
    pub export_mpc: Option<PathBuf>,
    /// The program file (docs/runtime.md) whose MPC `--export-mpc` writes.
    #[arg(long, requires = "export_mpc")]
    pub program: Option<PathBuf>,
}

/// `millcomp doe …`.
#[derive(Debug, Subcommand)]
pub enum DoeCommand {
    /// Generate a treatment matrix.
    #[command(
        after_help = "Example:\n  millcomp doe design --design fractional --factors A,B,C,D --resolution 4 --seed 1"
    )]
    Design(DoeDesignArgs),
    /// Analyse a response: effects, ANOVA, Lenth.
    #[command(
        after_help = "Example:\n  millcomp doe analyze datasets/data/clayton_doe.csv --response max_fx_n --factors depth_um,speed_rpm,upfeed_um"
    )]
    Analyze(DoeAnalyzeArgs),
}

/// `millcomp doe design`.
#[derive(Debug, Args)]
pub struct DoeDesignArgs {
    /// full | fractional | plackett-burman | ccd | box-behnken | lhs | dsd | d-optimal
    #[arg(long)]
    pub design: String,
    /// Factors: `depth_um=100:200,speed_rpm=10000:20000` or bare names `A,B,C` (coded -1/+1).
    #[arg(long)]
    pub factors: String,
    /// Resolution for a fractional design (minimum aberration).
    #[arg(long)]
    pub resolution: Option<u32>,
    /// Generators for a fractional design, e.g. "D=AB,E=AC".
    #[arg(long)]
    pub generators: Option<String>,
    /// Number of runs (LHS, D-optimal, Plackett-Burman).
    #[arg(long)]
    pub runs: Option<usize>,
    /// Replicates of the whole design (1 to 1000).
    #[arg(long, default_value_t = 1, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_REPLICATES))]
    pub replicates: usize,
    /// Centre points (per block; default 4 for CCD, 3 for Box-Behnken, 0 otherwise; at most 1000).
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(0..=MAX_CENTER_POINTS))]
    pub center_points: Option<usize>,
    /// Number of blocks (1 to 64).
    #[arg(long, default_value_t = 1, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_BLOCKS))]
    pub blocks: usize,
    /// Seed of the randomised run order (and of LHS / D-optimal searches).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Keep the standard order (no randomisation).
    #[arg(long)]
    pub no_randomize: bool,
    /// CCD variant: circumscribed | inscribed | face-centred.
    #[arg(long, default_value = "circumscribed")]
    pub ccd_variant: String,
    /// CCD alpha: rotatable | orthogonal | orthogonal-blocking | a number.
    #[arg(long, default_value = "rotatable", allow_negative_numbers = true)]
    pub alpha: String,
    /// Model a D-optimal design is optimal for: main | 2fi | quadratic | formula.
    #[arg(long)]
    pub model: Option<String>,
    /// Linear constraints for D-optimal designs, in coded units: "a + b <= 1.5; 2*A - B >= -1".
    #[arg(long, allow_hyphen_values = true)]
    pub constraints: Option<String>,
    /// Write the matrix to FILE.csv or FILE.parquet.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `millcomp doe analyze`.
#[derive(Debug, Args)]
pub struct DoeAnalyzeArgs {
    /// CSV or Parquet file with one row per run.
    pub file: PathBuf,
    /// Read your file's columns under other names: `role=column,...` (e.g. `max_fx_n=Fx_max_N`; unit
    /// suffixes checked), then name the roles in --response and --factors.
    #[arg(long)]
    pub columns: Option<String>,
    /// Response column.
    #[arg(long)]
    pub response: String,
    /// Factor columns (default: every other numeric column except std/run order and block).
    #[arg(long, value_delimiter = ',')]
    pub factors: Vec<String>,
    /// main | 2fi | quadratic | an explicit formula such as "a+b+a:b".
    #[arg(long, default_value = "main")]
    pub model: String,
    /// Significance level for flags and backward elimination.
    #[arg(long, default_value_t = 0.05, allow_negative_numbers = true)]
    pub alpha: f64,
    /// Drop insignificant terms by backward elimination at --alpha.
    #[arg(long)]
    pub reduce: bool,
    /// Write the fitted model (coefficients in actual units, covariance, ranges) as TOML.
    #[arg(long)]
    pub save: Option<PathBuf>,
    /// Write half-normal, Pareto, main-effect, interaction and residual plots (SVG) here.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// `millcomp identify <what> FILE`.
#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// What to identify.
    #[arg(value_enum)]
    pub what: IdentifyWhat,
    /// Measured data (CSV or Parquet). Columns: spindle `t_s,u_v,y_um`; stiffness
    /// `load_n,deflection_um[,direction]`; thermal `t_s,drift_um[,speed_rpm][,temp_c]` (a record study
    /// with --train: several `drift_um` channels and `temp_c` sensors); wear `cut,force_n[,vb_um]`;
    /// flutes `force_n` (one or more channels of a raw record);
    /// force `depth_um,upfeed_um,max_fx_n|max_fy_n|max_fz_n[,speed_rpm,tilt_deg]` or traces
    /// `rot_deg,fx_n|fy_n|fz_n` with the cut conditions; wall `force_n,deflection_um`; part
    /// `part,deflection_um,planned_deflection_um|force_peak_n`; kienzle
    /// `fz_mm,ap_mm,ae_mm,mean_fx_n|mean_fy_n[,diameter_mm,teeth,helix_deg]`; feed-axis
    /// `t_s,reference_um,position_um`; hysteresis `u_v,y_um` (a slow sweep that reverses).
    pub file: PathBuf,
    /// Force on a peak-force table (Table 3-3 shape): diagnose the disagreements of the nominal
    /// force model (W free) — its residual per response, candidate effects from the literature
    /// (ploughing, runout, flank wear, sensor gains and crosstalk, speed) each with its F test,
    /// held-out prediction and smallest detectable size, the verdict, and the S7 groove's deep-end
    /// force predicted without a scale factor (docs/studies/published-forces.md).
    #[arg(long, conflicts_with_all = ["save", "free", "relative_errors", "also", "join"])]
    pub diagnose: bool,
    /// Write the identified model as TOML (schema: models/MODEL.md).
    #[arg(long)]
    pub save: Option<PathBuf>,
    /// Thermal model: exponential (the default) | linear-temperature | speed-dependent; on a record
    /// study (--train): auto (the default: every structure, chosen by cross-validation) or a comma list
    /// of speed-1tau, speed-2tau, temperature-stepwise, temperature-ridge,
    /// combined-{1,2}tau-{stepwise,ridge}.
    #[arg(long)]
    pub model: Option<String>,
    /// Spindle: also fit the extra real pole.
    #[arg(long)]
    pub extra_pole: bool,
    /// Spindle: also fit a dead time.
    #[arg(long)]
    pub dead_time: bool,
    /// Stiffness: tilts (deg) at which to report the tilted-tool z-stiffness.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub tilt_deg: Vec<f64>,
    /// Stiffness: machine stiffness (N/um) in series with the identified tool stiffness.
    #[arg(long, allow_negative_numbers = true)]
    pub machine_stiffness_n_per_um: Option<f64>,
    /// Force: parameters to fit (w_mpa, mu_rake, mu_flank, wearland_um, runout_um); default W only.
    #[arg(long, value_delimiter = ',')]
    pub free: Vec<String>,
    /// Force: workpiece material for the parameters held fixed (S7, 1018, 6061, ...).
    #[arg(long)]
    pub material: Option<String>,
    /// Force: weight residuals by 1/F^2 (relative errors).
    #[arg(long)]
    pub relative_errors: bool,
    /// Wall: geometry `height_um,thickness_um,length_um` to derive the modulus.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub wall_geometry: Vec<f64>,
    /// Read your own file's columns under the names this verb reads: `role=column,...`, e.g.
    /// `t_s=time_s,drift_um=disp_ch*_um,temp_c=temp_t*_C,speed_rpm=spindle_rpm`. A role may take several
    /// columns (`a+b`, or a `*` pattern) where the verb reads several (temperatures, drift channels, force
    /// channels, flank wear per flute), or a constant (`speed_rpm=10400`). Unit suffixes must agree.
    #[arg(long)]
    pub columns: Option<String>,
    /// Thermal record / wear: fit on this range only — thermal: times `START:END` (seconds, `90min`,
    /// `23.15h`, `50%` of the record, `start`, `end`); wear: cut numbers `FIRST:LAST` (inclusive).
    #[arg(long)]
    pub train: Option<String>,
    /// Thermal record / wear: predict this range (same forms as --train) and report the error.
    #[arg(long)]
    pub test: Option<String>,
    /// Thermal record / wear: cross-validation blocks inside the training range (1 to 100).
    #[arg(long, default_value_t = 3, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_FOLDS))]
    pub folds: usize,
    /// Thermal record / wear / flutes: write SVG plots of measured vs predicted here.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Wear: a second per-cut file joined row by row on `--on` (e.g. the flank wear beside the forces);
    /// with `--also`, one `--join` per file, in the same order (FILE's first).
    #[arg(long, requires = "on")]
    pub join: Vec<PathBuf>,
    /// Wear: the key column both files share (e.g. `run`, the cut number).
    #[arg(long)]
    pub on: Option<String>,
    /// Wear: laws to try (linear, power, saturating, exponential; default all).
    #[arg(long, value_delimiter = ',')]
    pub laws: Vec<String>,
    /// Flutes: number of flutes of the cutter (at most 64).
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(0..=MAX_FLUTES))]
    pub flutes: Option<usize>,
    /// Flutes: spindle speed of the record (rpm; above 0, at most 1 000 000).
    #[arg(long, allow_negative_numbers = true, value_parser = speed_rpm)]
    pub speed_rpm: Option<f64>,
    /// Flutes: sample rate of the record (Hz; above 0, at most 100 MHz).
    #[arg(long, allow_negative_numbers = true, value_parser = sample_rate_hz)]
    pub sample_rate_hz: Option<f64>,
    /// Further files of the same layout: flutes analyses each the same way (e.g. the worn tool beside
    /// the fresh one); every other target reads each file as one unit (tool, part or machine; the file's
    /// name is the unit, unless `--columns unit=COLUMN` names it) and combines the units.
    #[arg(long)]
    pub also: Vec<PathBuf>,
    /// Across units (a `unit` column, or several files): the between-unit variance estimator, `dl`
    /// (DerSimonian–Laird, the default) or `pm` (Paule–Mandel).
    #[arg(long, default_value = "dl")]
    pub tau2: String,
    /// Wear across units: the flank wear (um) at which the new unit's force is predicted (default: the
    /// middle of the wear range every unit covers, rounded to 10 um).
    #[arg(long)]
    pub at_vb_um: Option<f64>,
    /// Flutes: significance level of the flute-to-flute F-test.
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub alpha: f64,
}

/// The identification targets.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum IdentifyWhat {
    /// PZT spindle plant from a step response.
    Spindle,
    /// Tool / spindle / machine stiffness from load-deflection data.
    Stiffness,
    /// Force-model material and friction parameters.
    Force,
    /// Thermal drift models.
    Thermal,
    /// Thin-wall effective stiffness.
    Wall,
    /// What cut parts say of the deflection model: force scale / stiffness (from the planned deflection)
    /// or the compliance per measured newton (from the force peak).
    Part,
    /// Kienzle's coefficients of a flat end mill from the mean forces of calibration cuts (003).
    Kienzle,
    /// Dead time and lag of an NC feed axis from its servo trace (003).
    FeedAxis,
    /// The PZT stack's hysteresis (a Prandtl–Ishlinskii model) from a quasi-static voltage sweep in air.
    Hysteresis,
    /// How the cutting force grows with flank wear and with cut count, from a per-cut record.
    Wear,
    /// Per-flute peak forces and the flute asymmetry (flute runout) of a raw force record.
    Flutes,
}

/// `millcomp diagnose SESSION MEASURED.csv`, or `millcomp diagnose --record FILE`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// Session file (TOML).
    #[arg(required_unless_present = "record")]
    pub session: Option<PathBuf>,
    /// Measured groove CSV.
    #[arg(required_unless_present = "record")]
    pub measured: Option<PathBuf>,
    /// Instead of a groove session: a measured record (CSV/Parquet) — a signal with its context (time,
    /// speed, temperatures, coolant, cumulative cut length or cut count, per-flute channels) — against
    /// a nominal that holds the signal at its first value (no drift, a fresh tool).
    #[arg(long, conflicts_with_all = ["session", "measured", "forces", "free_offset"])]
    pub record: Option<PathBuf>,
    /// Your file's columns under the names diagnose reads, `role=column,...` (unit suffixes checked): for a
    /// groove session the measured-groove columns; with --record the record's roles, e.g.
    /// `t_s=time_s,speed_rpm=spindle_rpm,temp_c=temp_t*_C,drift_um=disp_ch1_um` or
    /// `cut=run,force_n=force_y__rms` — roles t_s, speed_rpm, temp_c (several), coolant_on,
    /// cut_length_mm, cut, flute_n (several), and the signal.
    #[arg(long)]
    pub columns: Option<String>,
    /// With --record: the signal's role (default the first of drift_um, force_n, depth_um present); several
    /// columns in it are diagnosed one by one.
    #[arg(long)]
    pub signal: Option<String>,
    /// Write plots and a report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Family-wise significance level of each round (for a session: the threshold on a family's p
    /// is the level's quantile of the round's smallest p under the null, simulated; with
    /// --record: Bonferroni over the candidates).
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub alpha: f64,
    /// For a session: each round's threshold is --alpha over the shapes tried (Bonferroni,
    /// conservative) instead of the simulated family-wise one.
    #[arg(long, conflicts_with = "record")]
    pub bonferroni: bool,
    /// Per-flute peak force trace (`groove_id,x_mm,fz_peak_flute1_n,fz_peak_flute2_n`) for the
    /// flute-runout force channel.
    #[arg(long)]
    pub forces: Option<PathBuf>,
    /// Only these candidate effects (comma separated; default all).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Vec<String>,
    /// Leave the touch-off free (no prior), whatever the session's `[uncertainty]` states: a
    /// constant offset is then never blamed on an effect.
    #[arg(long)]
    pub free_offset: bool,
    /// Also write the next experiment's session file here: this session's plan with each of
    /// diagnose's standard changes appended (pauses with the spindle stopped and running, the
    /// coolant switched with the spindle stopped and running, the first groove again at a second X,
    /// upfeed, speed and tilt; docs/studies/diagnose.md).
    #[arg(long, conflicts_with = "record")]
    pub next_plan: Option<PathBuf>,
}

/// `millcomp simulate SESSION|SCENARIO`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Session file (TOML) or closed-loop scenario file.
    pub file: PathBuf,
    /// Controller for scenarios: none | open-loop | pid | pid-aw | pid-design | pid-tuned | pid-ff |
    /// pid-ff-read | threshold | mpc | mpc-nopreview; on nc_axis scenarios (003): none | reactive |
    /// proactive | mpc.
    #[arg(long)]
    pub controller: Option<String>,
    /// Output CSV (default: stdout for sessions).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Plot of the profiles (SVG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Add measurement noise with this seed (sessions).
    #[arg(long)]
    pub noise_seed: Option<u64>,
    /// Scenarios: run the controller at normal priority (by default its thread gets real-time
    /// priority where the machine permits it, as a real controller would; the report says which).
    #[arg(long)]
    pub no_realtime: bool,
    /// Scenarios: the MPC cycle's time budget as a fraction of its period (default 0.5); a cycle
    /// whose plan is not ready within it emits the fallback and counts as a deadline miss.
    #[arg(long, allow_negative_numbers = true)]
    pub budget_fraction: Option<f64>,
    /// FILE is a program file (docs/runtime.md): run its controller, built from this commissioned
    /// bundle, on the simulated machine (sim's S7 groove stage with sensor noise; `--noise-seed`
    /// seeds it, 7 by default); `--out` gets the commands (.csv, .parquet or .json).
    #[arg(long)]
    pub bundle: Option<PathBuf>,
    /// With `--bundle`: write the run's sensor log here (.csv or .parquet; the sensor-log contract,
    /// docs/replay.md), what `millcomp replay` takes.
    #[arg(long, requires = "bundle")]
    pub sensor_log: Option<PathBuf>,
    /// With `--bundle`: control cycles to run, at least 1 (default: the whole program).
    #[arg(long, requires = "bundle", value_parser = RangedU64ValueParser::<usize>::new().range(1..))]
    pub steps: Option<usize>,
}

/// `millcomp replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The commissioned bundle (`millcomp commission --out`).
    pub bundle: PathBuf,
    /// The program file: the NC program and the controller's settings (docs/runtime.md).
    pub program: PathBuf,
    /// The recorded sensor log (CSV or Parquet; columns t_s, x_mm, force_n, gauge_um: docs/replay.md).
    pub log: PathBuf,
    /// Controllers to replay, comma-separated (default: the program's `[controller] kind`): none,
    /// open-loop, pid, pid-aw, pid-design, pid-tuned, pid-ff, pid-ff-read, mpc, mpc-nopreview.
    #[arg(long)]
    pub controllers: Option<String>,
    /// Write the commands here, one row per controller and sample (.csv, .parquet or .json).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `millcomp batch`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BatchArgs {
    /// `merge DIR...`: join the slices of one batch.
    #[command(subcommand)]
    pub command: Option<BatchCommand>,
    /// Scenario table (CSV or Parquet): one row per scenario, one column per factor
    /// (tilt_deg, depth_um, upfeed_um, wearland_um, material, stiffness_error_pct,
    /// force_model_error_pct, force_w_error_pct, noise_scale, stage, wall_um, feed_step,
    /// feed_accel_mm_s2, depth_step, entry_depth_um, commissioned, length_mm, speed_rpm, seed; with
    /// stage = nc_axis: feed_ratio, ae_mm, machine_stiffness_n_per_um, overhang_d, kienzle_error_pct).
    #[arg(long, conflicts_with = "doe")]
    pub scenarios: Option<PathBuf>,
    /// Generate the scenarios with `doe design` arguments given as one string, e.g.
    /// "--design fractional --factors tilt_deg=20:40,depth_um=60:100,upfeed_um=8:12 --resolution 3 --seed 1".
    #[arg(long, allow_hyphen_values = true)]
    pub doe: Option<String>,
    /// Controllers to compare: none, open-loop, pid, pid-aw, pid-design, pid-tuned, pid-ff, pid-ff-read,
    /// threshold, mpc, mpc-nopreview; on stage = nc_axis rows: none, reactive, proactive, mpc.
    #[arg(long, default_value = "pid,mpc")]
    pub controllers: String,
    /// Output directory (results.csv/.parquet, summary.json, plots/, runs/ for resuming).
    #[arg(long, default_value = "millcomp-batch")]
    pub out: PathBuf,
    /// Run slice K of N (0-based K). Also taken from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT or
    /// JOB_COMPLETION_INDEX/MILLCOMP_SHARD_COUNT.
    #[arg(long)]
    pub shard: Option<String>,
    /// Worker threads (default: all cores, or RAYON_NUM_THREADS; 1 to 1024).
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_THREADS))]
    pub threads: Option<usize>,
    /// Read the --scenarios file's columns under the factor names: `factor=column,...` (unit suffixes
    /// checked).
    #[arg(long, requires = "scenarios")]
    pub columns: Option<String>,
    /// Commissioning cache: each distinct commissioning computed once and kept here (default
    /// OUT/cache). Slices of one batch may share a directory.
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// No progress line.
    #[arg(long)]
    pub quiet: bool,
    /// Print the plan's run count and an estimate of its time, and run nothing.
    #[arg(long)]
    pub dry_run: bool,
}

/// `millcomp parts`.
#[derive(Debug, Args)]
pub struct PartsArgs {
    /// Groove scenario (TOML). It is run commissioned (instruments and tool drawn, the controllers built
    /// from a commissioning of the plant) with the deliberate model errors below on top.
    pub scenario: PathBuf,
    /// Parts cut in a row on each machine (1 to 1000).
    #[arg(long, default_value_t = 3, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_PARTS))]
    pub parts: usize,
    /// Machines (seeds 1..=N, N from 1 to 10 000): each its own tool, instruments, commissioning and
    /// error signs.
    #[arg(long, default_value_t = 10, value_parser = RangedU64ValueParser::<u64>::new().range(1..=MAX_MACHINES))]
    pub seeds: u64,
    /// Controllers, each learning from its own parts (plus the reference, an MPC given the true model).
    #[arg(long, default_value = "pid-tuned,pid-ff,mpc")]
    pub controllers: String,
    /// Size of the force-model errors on the commissioned model (relative; W, rake and flank friction,
    /// wearland each off by ± this).
    #[arg(long, default_value_t = 0.15, allow_negative_numbers = true)]
    pub force_error: f64,
    /// Size of the stiffness error on the commissioned model (relative, ±).
    #[arg(long, default_value_t = 0.10, allow_negative_numbers = true)]
    pub stiffness_error: f64,
    /// σ of the part-to-part force factor (relative).
    #[arg(long, default_value_t = 0.02, allow_negative_numbers = true)]
    pub part_scatter: f64,
    /// Output directory (parts.csv, summary.json, parts.svg).
    #[arg(long, default_value = "millcomp-parts")]
    pub out: PathBuf,
    /// Worker threads (default: all cores, or RAYON_NUM_THREADS; 1 to 1024).
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_THREADS))]
    pub threads: Option<usize>,
}

/// `millcomp batch merge`.
#[derive(Debug, Subcommand)]
pub enum BatchCommand {
    /// Join the slices (output directories of `--shard K/N` runs) of one batch.
    #[command(after_help = "Example:\n  millcomp batch merge slice-0 slice-1 --out merged")]
    Merge(BatchMergeArgs),
}

/// `millcomp batch merge DIR... --out OUT`.
#[derive(Debug, Args)]
pub struct BatchMergeArgs {
    /// Slice directories.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Output directory of the merged results.
    #[arg(long, default_value = "millcomp-batch-merged")]
    pub out: PathBuf,
}

/// `millcomp datasets …`.
#[derive(Debug, Subcommand)]
pub enum DatasetsCommand {
    /// List the shipped tables: published, real measured records, synthetic runs.
    #[command(after_help = "Example:\n  millcomp datasets list")]
    List,
    /// Print one table (a real record: its provenance and first rows).
    #[command(after_help = "Example:\n  millcomp datasets show clayton_doe")]
    Show(DatasetsShowArgs),
    /// Validate your own CSV/Parquet file against a contract or a shipped table's schema.
    #[command(
        after_help = "Example:\n  millcomp datasets check my-grooves.csv --as measured-groove"
    )]
    Check(DatasetsCheckArgs),
    /// Every published figure millcomp touches: the published value, millcomp's (computed now, or
    /// recorded and checked by a test), the label (predicted / calibrated to / disagrees) and the
    /// published figures its parameters were fitted on.
    #[command(
        after_help = "Example:\n  millcomp datasets figures\n  millcomp datasets figures --markdown"
    )]
    Figures(DatasetsFiguresArgs),
}

/// `millcomp datasets figures`.
#[derive(Debug, Args)]
pub struct DatasetsFiguresArgs {
    /// Print README's figure table (markdown) instead of the aligned text table (not with --json).
    #[arg(long)]
    pub markdown: bool,
}

/// `millcomp datasets check FILE --as SCHEMA`.
#[derive(Debug, Args)]
pub struct DatasetsCheckArgs {
    /// The file to check.
    pub file: PathBuf,
    /// `measured-groove` (the diagnose input contract) or the name of a shipped dataset.
    #[arg(long = "as", value_name = "SCHEMA")]
    pub schema: String,
    /// Read your file's columns under the schema's names: `role=column,...` (unit suffixes checked).
    #[arg(long)]
    pub columns: Option<String>,
}

/// `millcomp datasets show NAME`.
#[derive(Debug, Args)]
pub struct DatasetsShowArgs {
    /// Dataset name (see `millcomp datasets list`).
    pub name: String,
}
