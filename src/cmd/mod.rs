//! One module per verb. Each returns `anyhow::Result<()>`; printing happens here, errors are
//! reported by `main`.

use crate::cli::{Cli, Command};

mod batch;
mod commission;
mod datasets;
mod demo;
mod diagnose;
mod doe;
mod forces;
pub(crate) mod guard;
mod identify;
mod parts;
pub(crate) mod record;
pub(crate) mod replay;
mod simulate;
mod units;

/// Prints a serialisable value as one pretty JSON document on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// The provenance of a model this run saves: the program and version, the command line as typed, the
/// time, and each input with its SHA-256.
pub fn provenance(inputs: Vec<millcomp_models::InputFile>) -> millcomp_models::Provenance {
    let words: Vec<String> = std::env::args()
        .enumerate()
        .map(|(i, a)| {
            let a = if i == 0 { "millcomp".to_string() } else { a };
            if a.is_empty() || a.contains(|c: char| c.is_whitespace() || c == '"' || c == '\'') {
                format!("'{}'", a.replace('\'', "'\\''"))
            } else {
                a
            }
        })
        .collect();
    let mut p = millcomp_models::Provenance::now(
        &format!("millcomp {}", env!("CARGO_PKG_VERSION")),
        &words.join(" "),
    );
    p.inputs = inputs;
    p
}

/// A progress bar on stderr over `total` items called `what` (e.g. `parts`), or a hidden one for `--json`
/// or when stderr is not a terminal.
pub fn progress_bar(total: u64, what: &str, json: bool) -> indicatif::ProgressBar {
    use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
    use std::io::IsTerminal;
    if json || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(&format!(
        "{{spinner}} [{{elapsed_precise}}] {{bar:40}} {{pos}}/{{len}} {what} (eta {{eta}})"
    )) {
        b.set_style(style);
    }
    b
}

/// Runs the verb the user asked for.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let json = cli.json;
    match cli.command {
        Command::Datasets(c) => datasets::run(c, json),
        Command::Demo(a) => demo::run(a, json),
        Command::Pipeline(a) => demo::run_plan(a, json),
        Command::Doe(c) => doe::run(c, json),
        Command::Identify(a) => identify::run(*a, json),
        Command::Diagnose(a) => diagnose::run(a, json),
        Command::Commission(a) => commission::run(a, json),
        Command::Simulate(a) => simulate::run(a, json),
        Command::Replay(a) => replay::run(a, json),
        Command::Batch(a) => batch::run(a, json),
        Command::Parts(a) => parts::run(a, json),
    }
}
