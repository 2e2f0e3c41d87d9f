//! The stage chain: what each stage read and wrote, with the SHA-256 of every file, so that a program can
//! recompute the hashes and check that each stage read only what the stages before it wrote
//! (`pipeline.json`, `demo --json`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{PipelineError, Result};

/// One file a stage read or wrote.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileRef {
    /// The path relative to the output directory (a user's file outside it: as the plan gave it).
    pub path: String,
    /// Lower-case hex SHA-256 of its bytes when the stage ran.
    pub sha256: String,
}

/// Whether a stage ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StageStatus {
    /// It ran.
    Ok,
    /// It was skipped: its inputs were not given (the record says what it needs).
    Skipped,
}

/// One stage of the chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageRecord {
    /// The stage (`design`, `measure`, `analyse`, `identify`, `commission`, `build`,
    /// `design-comparison`, `batch`, `design-session`, `measure-session`, `diagnose`, `rerun`).
    pub name: String,
    /// Ran or skipped.
    pub status: StageStatus,
    /// What it did or found, in one paragraph; for a skipped stage, what it would need.
    pub summary: String,
    /// Where its measurements came from: `simulated machine (seed N)`, `files`, or empty.
    pub source: String,
    /// Files it read.
    pub inputs: Vec<FileRef>,
    /// Files it wrote.
    pub outputs: Vec<FileRef>,
    /// Wall-clock seconds (informative).
    pub seconds: f64,
}

/// Hashes a file.
///
/// # Errors
/// [`PipelineError::Io`] when it cannot be read.
pub fn sha256_file(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| PipelineError::io(path, "reading", e))?;
    Ok(millcomp_models::sha256_hex(&bytes))
}

/// The chain being written: the output directory and the stages so far.
#[derive(Debug, Clone)]
pub struct Chain {
    out: PathBuf,
    /// The stages, in order.
    pub stages: Vec<StageRecord>,
}

impl Chain {
    /// An empty chain writing into `out`.
    pub fn new(out: &Path) -> Self {
        Self {
            out: out.to_path_buf(),
            stages: Vec::new(),
        }
    }

    /// The output directory.
    pub fn out(&self) -> &Path {
        &self.out
    }

    /// A file reference: the path relative to the output directory when it is inside it.
    ///
    /// # Errors
    /// [`PipelineError::Io`] when the file cannot be read.
    pub fn file(&self, path: &Path) -> Result<FileRef> {
        let rel = path.strip_prefix(&self.out).unwrap_or(path);
        Ok(FileRef {
            path: rel.display().to_string().replace('\\', "/"),
            sha256: sha256_file(path)?,
        })
    }

    /// Records a stage that ran.
    ///
    /// # Errors
    /// [`PipelineError::Io`] when one of its files cannot be read.
    pub fn ran(
        &mut self,
        name: &str,
        source: &str,
        inputs: &[PathBuf],
        outputs: &[PathBuf],
        summary: String,
        seconds: f64,
    ) -> Result<()> {
        let inputs = inputs
            .iter()
            .map(|p| self.file(p))
            .collect::<Result<Vec<_>>>()?;
        let outputs = outputs
            .iter()
            .map(|p| self.file(p))
            .collect::<Result<Vec<_>>>()?;
        self.stages.push(StageRecord {
            name: name.to_string(),
            status: StageStatus::Ok,
            summary,
            source: source.to_string(),
            inputs,
            outputs,
            seconds,
        });
        Ok(())
    }

    /// Records a skipped stage with what it would need.
    pub fn skipped(&mut self, name: &str, needs: String) {
        self.stages.push(StageRecord {
            name: name.to_string(),
            status: StageStatus::Skipped,
            summary: needs,
            source: String::new(),
            inputs: Vec::new(),
            outputs: Vec::new(),
            seconds: 0.0,
        });
    }

    /// The stage called `name`, if it ran.
    pub fn stage(&self, name: &str) -> Option<&StageRecord> {
        self.stages
            .iter()
            .find(|s| s.name == name && s.status == StageStatus::Ok)
    }
}

/// Checks a written chain: every file's SHA-256 as recorded, and every input of a stage inside the
/// output directory written by an earlier stage with the same hash. Returns the problems found (empty:
/// the chain holds).
///
/// # Examples
/// ```
/// use millcomp_pipeline::chain::{Chain, verify};
/// let dir = tempfile::tempdir().unwrap();
/// let a = dir.path().join("a.csv");
/// std::fs::write(&a, "x\n1\n").unwrap();
/// let b = dir.path().join("b.toml");
/// std::fs::write(&b, "k = 1\n").unwrap();
/// let mut chain = Chain::new(dir.path());
/// chain.ran("measure", "", &[], &[a.clone()], "measured".into(), 0.0).unwrap();
/// chain.ran("identify", "", &[a.clone()], &[b.clone()], "fitted".into(), 0.0).unwrap();
/// assert!(verify(dir.path(), &chain.stages).is_empty());
/// std::fs::write(&a, "x\n2\n").unwrap(); // a file changed after the fact
/// assert_eq!(verify(dir.path(), &chain.stages).len(), 2);
/// ```
pub fn verify(out: &Path, stages: &[StageRecord]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut written: std::collections::BTreeMap<&str, &str> = Default::default();
    for s in stages {
        for f in &s.inputs {
            let inside = !Path::new(&f.path).is_absolute() && !f.path.starts_with("..");
            if inside {
                match written.get(f.path.as_str()) {
                    Some(h) if *h == f.sha256 => {}
                    Some(_) => problems.push(format!(
                        "{}: read {} with another hash than the stage that wrote it",
                        s.name, f.path
                    )),
                    None => problems.push(format!(
                        "{}: read {}, which no earlier stage wrote",
                        s.name, f.path
                    )),
                }
            }
            let p = if inside {
                out.join(&f.path)
            } else {
                PathBuf::from(&f.path)
            };
            match sha256_file(&p) {
                Ok(h) if h == f.sha256 => {}
                Ok(_) => problems.push(format!("{}: {} changed since it was read", s.name, f.path)),
                Err(_) => problems.push(format!("{}: {} is missing", s.name, f.path)),
            }
        }
        for f in &s.outputs {
            match sha256_file(&out.join(&f.path)) {
                Ok(h) if h == f.sha256 => {}
                Ok(_) => problems.push(format!(
                    "{}: {} changed since it was written",
                    s.name, f.path
                )),
                Err(_) => problems.push(format!("{}: {} is missing", s.name, f.path)),
            }
            written.insert(f.path.as_str(), f.sha256.as_str());
        }
    }
    problems
}
