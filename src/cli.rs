//! Command-line arguments (clap derive). One enum variant per verb of the CLI contract.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

const EXIT_CODES: &str = "\
Exit status:
  0  success
  1  failure: bad input (the message names the file, column, row or parameter), unreadable file
  2  usage error (unknown option, missing argument)
  3  the verb is part of the CLI contract but not available in this build yet

Errors go to stderr with their cause chain; with --json, results go to stdout as one JSON document.";

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
    /// Run the whole pipeline on the shipped data and write a report (the main job).
    Demo(DemoArgs),
    /// Design of experiments: generate treatment matrices and analyse responses.
    #[command(subcommand)]
    Doe(DoeCommand),
    /// Identify model parameters from measured runs by least squares.
    Identify(IdentifyArgs),
    /// Find where simulation and measurement disagree and name the missing physical effect.
    Diagnose(DiagnoseArgs),
    /// Simulate a session or a closed-loop scenario.
    Simulate(SimulateArgs),
    /// Run controllers over many conditions and compare them statistically.
    Batch(BatchArgs),
    /// List and show the published tables shipped with millcomp.
    #[command(subcommand)]
    Datasets(DatasetsCommand),
}

/// `millcomp demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Directory for the report and tables.
    #[arg(long, default_value = "millcomp-demo")]
    pub out: PathBuf,
}

/// `millcomp doe …`.
#[derive(Debug, Subcommand)]
pub enum DoeCommand {
    /// Generate a treatment matrix.
    Design(DoeDesignArgs),
    /// Analyse a response: effects, ANOVA, Lenth.
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
    /// Replicates of the whole design.
    #[arg(long, default_value_t = 1)]
    pub replicates: usize,
    /// Centre points (per block; default 4 for CCD, 3 for Box-Behnken, 0 otherwise).
    #[arg(long)]
    pub center_points: Option<usize>,
    /// Number of blocks.
    #[arg(long, default_value_t = 1)]
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
    #[arg(long, default_value = "rotatable")]
    pub alpha: String,
    /// Model a D-optimal design is optimal for: main | 2fi | quadratic | formula.
    #[arg(long)]
    pub model: Option<String>,
    /// Linear constraints for D-optimal designs, in coded units: "a + b <= 1.5; 2*A - B >= -1".
    #[arg(long)]
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
    #[arg(long, default_value_t = 0.05)]
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
    /// spindle | stiffness | force | thermal | wall
    pub what: String,
    /// Measured data (CSV).
    pub file: PathBuf,
    /// Write the identified model as TOML.
    #[arg(long)]
    pub save: Option<PathBuf>,
}

/// `millcomp diagnose SESSION MEASURED.csv`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// Session file (TOML).
    pub session: PathBuf,
    /// Measured groove CSV.
    pub measured: PathBuf,
    /// Write plots and a report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Significance level (corrected for the number of candidates).
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
}

/// `millcomp simulate SESSION|SCENARIO`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Session file (TOML) or closed-loop scenario file.
    pub file: PathBuf,
    /// Controller for scenarios: none | open-loop | pid | threshold | mpc.
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
}

/// `millcomp batch`.
#[derive(Debug, Args)]
pub struct BatchArgs {
    /// Sub-command `merge` or scenario options.
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    pub args: Vec<String>,
}

/// `millcomp datasets …`.
#[derive(Debug, Subcommand)]
pub enum DatasetsCommand {
    /// List the shipped tables.
    List,
    /// Print one table.
    Show(DatasetsShowArgs),
    /// Validate your own CSV/Parquet file against a contract or a shipped table's schema.
    Check(DatasetsCheckArgs),
}

/// `millcomp datasets check FILE --as SCHEMA`.
#[derive(Debug, Args)]
pub struct DatasetsCheckArgs {
    /// The file to check.
    pub file: PathBuf,
    /// `measured-groove` (the diagnose input contract) or the name of a shipped dataset.
    #[arg(long = "as", value_name = "SCHEMA")]
    pub schema: String,
}

/// `millcomp datasets show NAME`.
#[derive(Debug, Args)]
pub struct DatasetsShowArgs {
    /// Dataset name (see `millcomp datasets list`).
    pub name: String,
}
