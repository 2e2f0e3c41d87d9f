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

/// Prints an error and every cause under it to stderr, each once: a cause whose text the line above
/// already says (a library that copies its source's message into its own) is not repeated.
fn report(err: &anyhow::Error) {
    for line in report_lines(err) {
        eprintln!("{line}");
    }
}

/// The lines [`report`] prints.
fn report_lines(err: &anyhow::Error) -> Vec<String> {
    let mut lines = vec![format!("error: {err}")];
    let mut above = err.to_string();
    for cause in err.chain().skip(1) {
        let text = cause.to_string();
        if text.is_empty() || above.contains(&text) {
            continue;
        }
        lines.push(format!("  caused by: {text}"));
        above = text;
    }
    lines
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_cause_the_line_above_already_says_is_printed_once() {
        let io = std::io::Error::from_raw_os_error(19);
        let text = io.to_string();
        #[derive(Debug)]
        struct Wrap(std::io::Error);
        impl std::fmt::Display for Wrap {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}", self.0)
            }
        }
        impl std::error::Error for Wrap {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let e = anyhow::Error::new(Wrap(io)).context("x.csv: cannot parse as CSV");
        assert_eq!(
            super::report_lines(&e),
            vec![
                "error: x.csv: cannot parse as CSV".to_string(),
                format!("  caused by: {text}")
            ]
        );
    }
}
