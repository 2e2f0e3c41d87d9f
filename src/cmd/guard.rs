//! Outputs never overwrite an input: every verb lists the files it reads, then checks each output it
//! will write against them before it computes or writes anything. Two paths are the same file when
//! they name one file on disk (the same device and inode: a symbolic or hard link to the input too) or,
//! for an output that does not exist yet, when their canonical forms are equal (`./a/../S.toml` is
//! `S.toml`). A directory output is checked by the names the verb writes into it.

use std::path::{Path, PathBuf};

use anyhow::bail;

/// The files a run reads, each with the option or argument that named it.
#[derive(Debug, Default)]
pub struct Inputs {
    files: Vec<(String, PathBuf)>,
}

impl Inputs {
    /// No inputs yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the input `path`, named `what` in messages (`SESSION`, `--forces`).
    pub fn add(mut self, what: &str, path: &Path) -> Self {
        self.files.push((what.to_string(), path.to_path_buf()));
        self
    }

    /// Adds an optional input.
    pub fn add_opt(self, what: &str, path: Option<&Path>) -> Self {
        match path {
            Some(p) => self.add(what, p),
            None => self,
        }
    }

    /// Refuses the output file `out` (given to `flag`) when it is one of the inputs.
    ///
    /// # Errors
    /// A message naming the option, the output and the input it would overwrite.
    pub fn check_file(&self, flag: &str, out: &Path) -> anyhow::Result<()> {
        for (what, input) in &self.files {
            if same_file(input, out) {
                bail!(
                    "{flag} {}: that is the input {what} {} — the output would overwrite it; write the \
                     output to another file",
                    out.display(),
                    input.display()
                );
            }
        }
        Ok(())
    }

    /// [`Inputs::check_file`] for an optional output.
    ///
    /// # Errors
    /// As [`Inputs::check_file`].
    pub fn check_opt(&self, flag: &str, out: Option<&Path>) -> anyhow::Result<()> {
        match out {
            Some(p) => self.check_file(flag, p),
            None => Ok(()),
        }
    }

    /// Refuses the output directory `dir` (given to `flag`) when it is an input file, or when an input
    /// lies in it under a name the verb writes there (`writes` is given the path relative to `dir`).
    ///
    /// # Errors
    /// A message naming the option, the directory and the input it would overwrite.
    pub fn check_dir(
        &self,
        flag: &str,
        dir: &Path,
        writes: impl Fn(&Path) -> bool,
    ) -> anyhow::Result<()> {
        let base = canonical(dir);
        for (what, input) in &self.files {
            if same_file(input, dir) {
                bail!(
                    "{flag} {}: that is the input {what} {}, not a directory for the output",
                    dir.display(),
                    input.display()
                );
            }
            if let Ok(rel) = canonical(input).strip_prefix(&base)
                && writes(rel)
            {
                bail!(
                    "{flag} {}: the output would overwrite the input {what} {} (the verb writes `{}` \
                     there); choose another directory",
                    dir.display(),
                    input.display(),
                    rel.display()
                );
            }
        }
        Ok(())
    }
}

/// The model files a scenario names (`control.spindle_model`, `control.force_model`,
/// `control.force_response_surface`, `control.bundle`): inputs of any verb that runs it.
pub fn with_scenario_models(mut inputs: Inputs, s: &millcomp_closedloop::Scenario) -> Inputs {
    let c = &s.control;
    for (what, p) in [
        ("control.spindle_model", &c.spindle_model),
        ("control.force_model", &c.force_model),
        ("control.force_response_surface", &c.force_response_surface),
        ("control.bundle", &c.bundle),
    ] {
        if let Some(p) = p {
            inputs = inputs.add(what, Path::new(p));
        }
    }
    inputs
}

/// Whether `rel` (a path in an output directory) is an SVG whose name starts with one of `prefixes`.
pub fn svg_starting(rel: &Path, prefixes: &[&str]) -> bool {
    rel.extension().is_some_and(|e| e == "svg")
        && rel
            .to_str()
            .is_some_and(|n| prefixes.iter().any(|p| n.starts_with(p)))
}

/// Whether `a` and `b` name the same file: the same device and inode when both exist, else the same
/// canonical path.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    canonical(a) == canonical(b)
}

/// The canonical form of `p`, also for a path that does not exist yet: its nearest existing ancestor
/// canonicalised, with the rest appended (`.` and `..` resolved lexically).
pub fn canonical(p: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(p) {
        return c;
    }
    // `.` and `..` resolved lexically first: a path through a directory that does not exist names no
    // file the system could resolve, but says which one the user meant
    let mut abs = PathBuf::new();
    for part in std::path::absolute(p)
        .unwrap_or_else(|_| p.to_path_buf())
        .components()
    {
        match part {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                abs.pop();
            }
            other => abs.push(other),
        }
    }
    let mut existing = abs.as_path();
    let mut rest: Vec<&std::ffi::OsStr> = Vec::new();
    loop {
        if let Ok(c) = std::fs::canonicalize(existing) {
            let mut out = c;
            for part in rest.iter().rev() {
                match part.to_str() {
                    Some(".") => {}
                    Some("..") => {
                        out.pop();
                    }
                    _ => out.push(part),
                }
            }
            return out;
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name);
                existing = parent;
            }
            _ => return abs,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_is_refused_however_it_is_spelled() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("S.toml");
        std::fs::write(&input, "x").unwrap();
        let inputs = Inputs::new().add("SESSION", &input);
        let e = inputs.check_file("--out", &input).unwrap_err().to_string();
        assert!(
            e.contains("--out") && e.contains("S.toml") && e.contains("SESSION"),
            "{e}"
        );
        // through `..` of a directory that does not exist: the same canonical path
        let odd = dir.path().join("nowhere/../S.toml");
        assert!(inputs.check_file("--out", &odd).is_err());
        // a symbolic and a hard link to the input
        #[cfg(unix)]
        {
            let sym = dir.path().join("link.toml");
            std::os::unix::fs::symlink(&input, &sym).unwrap();
            assert!(inputs.check_file("--out", &sym).is_err());
            let hard = dir.path().join("hard.toml");
            std::fs::hard_link(&input, &hard).unwrap();
            assert!(inputs.check_file("--out", &hard).is_err());
        }
        // another file, existing or not, is fine
        assert!(
            inputs
                .check_file("--out", &dir.path().join("out.csv"))
                .is_ok()
        );
        assert!(
            inputs
                .check_file("--out", &dir.path().join("new/deeper/out.csv"))
                .is_ok()
        );
    }

    #[test]
    fn a_directory_output_is_checked_by_the_names_it_writes() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("pareto.svg");
        std::fs::write(&input, "x").unwrap();
        let inputs = Inputs::new().add("FILE", &input);
        let writes = |rel: &Path| rel == Path::new("pareto.svg");
        assert!(inputs.check_dir("--plots", dir.path(), writes).is_err());
        assert!(
            inputs
                .check_dir("--plots", dir.path(), |rel| rel == Path::new("a.svg"))
                .is_ok()
        );
        // the input file itself given as the directory
        assert!(inputs.check_dir("--plots", &input, writes).is_err());
    }
}
