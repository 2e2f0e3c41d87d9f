//! One module per verb. Each returns `anyhow::Result<()>`; printing happens here, errors are
//! reported by `main`.

use std::fmt;

use crate::cli::{Cli, Command};

mod datasets;
mod doe;

/// A verb of the CLI contract whose issue has not landed in this build.
#[derive(Debug)]
pub struct NotYet {
    verb: &'static str,
    what: &'static str,
}

impl fmt::Display for NotYet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "`millcomp {}` is not available in this build yet ({})",
            self.verb, self.what
        )
    }
}

impl std::error::Error for NotYet {}

fn not_yet(verb: &'static str, what: &'static str) -> anyhow::Result<()> {
    Err(NotYet { verb, what }.into())
}

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
        Command::Demo(_) => not_yet("demo", "the batch issue builds the main job"),
        Command::Doe(c) => doe::run(c, json),
        Command::Identify(_) => not_yet("identify", "the identification issue adds the fits"),
        Command::Diagnose(_) => not_yet("diagnose", "the diagnose issue adds the workflow"),
        Command::Simulate(_) => not_yet("simulate", "the physics issue adds sessions"),
        Command::Batch(_) => not_yet("batch", "the batch issue adds controller comparisons"),
    }
}
