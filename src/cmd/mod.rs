//! One module per verb. Each returns `anyhow::Result<()>`; printing happens here, errors are
//! reported by `main`.

use crate::cli::{Cli, Command};

mod batch;
mod datasets;
mod demo;
mod diagnose;
mod doe;
mod identify;
mod simulate;

/// Prints a serialisable value as one pretty JSON document on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// Runs the verb the user asked for.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let json = cli.json;
    match cli.command {
        Command::Datasets(c) => datasets::run(c, json),
        Command::Demo(a) => demo::run(a, json),
        Command::Doe(c) => doe::run(c, json),
        Command::Identify(a) => identify::run(a, json),
        Command::Diagnose(a) => diagnose::run(a, json),
        Command::Simulate(a) => simulate::run(a, json),
        Command::Batch(a) => batch::run(a, json),
    }
}
