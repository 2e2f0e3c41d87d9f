//! `millcomp`: the command-line front end. Thin by design: parse arguments, call the libraries,
//! print. Every error is reported in one place ([`report`]) with its cause chain.

use std::process::ExitCode;

use clap::Parser;

mod cli;
mod cmd;
mod present;

use cli::Cli;

/// Exit status of a successful run.
const EXIT_OK: u8 = 0;
/// Exit status when the run failed: bad input, unreadable file, failed check.
const EXIT_FAILURE: u8 = 1;

fn main() -> ExitCode {
    // clap prints usage errors itself and exits with status 2.
    let cli = Cli::parse();
    match cmd::run(cli) {
        Ok(()) => ExitCode::from(EXIT_OK),
        Err(err) => {
            report(&err);
            ExitCode::from(EXIT_FAILURE)
        }
    }
}

/// Prints an error and every cause under it to stderr.
fn report(err: &anyhow::Error) {
    eprintln!("error: {err}");
    for cause in err.chain().skip(1) {
        eprintln!("  caused by: {cause}");
    }
}
