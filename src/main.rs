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
    restore_sigpipe();
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

/// A reader that stops early (`millcomp … | head`) ends the program quietly, as it ends any Unix tool:
/// the Rust runtime ignores SIGPIPE, so a write to the closed pipe would fail and `println!` panic.
fn restore_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Prints an error and every cause under it to stderr.
fn report(err: &anyhow::Error) {
    eprintln!("error: {err}");
    for cause in err.chain().skip(1) {
        eprintln!("  caused by: {cause}");
    }
}
