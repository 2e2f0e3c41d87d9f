//! The one model-file format: a `[header]` (format, version, kind, provenance) and a `[model]` table whose
//! shape depends on the kind. One [`ModelFile::load`] (checks format, version and kind before the body is
//! read, so a file of another version is refused with the key named), one atomic [`ModelFile::save`]
//! (temporary file + rename: nothing half-written). Schema and examples: `models/MODEL.md`.

use std::io::Write as _;

pub use crate::atomic::write_atomic;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::{ModelError, Result};

/// The value of `header.format` in every millcomp model file.
pub const FORMAT: &str = "millcomp-model";
/// The `header.version` this build writes and reads.
pub const VERSION: u32 = 1;

/// Where a model came from: enough to reproduce it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// The program and its version, e.g. `millcomp 0.1.0`.
    pub program: String,
    /// The command that made the model, e.g. `millcomp identify spindle step.csv --save m.toml`.
    pub command: String,
    /// UTC time the model was made, `YYYY-MM-DDThh:mm:ssZ`.
    pub created_utc: String,
    /// The data files the model was made from, with their SHA-256.
    #[serde(default)]
    pub inputs: Vec<InputFile>,
}

/// One input of a model and the SHA-256 of its bytes.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputFile {
    /// The path as given (or the name of embedded data).
    pub path: String,
    /// Lower-case hex SHA-256 of the bytes read.
    pub sha256: String,
}

impl InputFile {
    /// The input `path` with the SHA-256 of `bytes` (the bytes that were read from it).
    pub fn from_bytes(path: &str, bytes: &[u8]) -> Self {
        Self {
            path: path.to_string(),
            sha256: sha256_hex(bytes),
        }
    }

    /// Reads the file and records its hash.
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("data.csv");
    /// std::fs::write(&path, "abc").unwrap();
    /// let input = millcomp_models::InputFile::from_path(&path).unwrap();
    /// // FIPS 180-2 test vector: SHA-256("abc")
    /// assert_eq!(input.sha256, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    /// assert!(millcomp_models::InputFile::from_path(&dir.path().join("missing.csv")).is_err());
    /// ```
    ///
    /// # Errors
    /// [`ModelError::Io`] when the file cannot be read.
    pub fn from_path(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|source| ModelError::Io {
            path: path.to_path_buf(),
            action: "reading (to record its SHA-256)".into(),
            source,
        })?;
        Ok(Self::from_bytes(&path.display().to_string(), &bytes))
    }
}

impl Provenance {
    /// Provenance of a model made now by `program` (e.g. `millcomp 0.1.0`) running `command`.
    pub fn now(program: &str, command: &str) -> Self {
        Self {
            program: program.to_string(),
            command: command.to_string(),
            created_utc: utc_now_rfc3339(),
            inputs: Vec::new(),
        }
    }

    /// Adds an input.
    pub fn with_input(mut self, input: InputFile) -> Self {
        self.inputs.push(input);
        self
    }
}

/// The `[header]` table of a model file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// Always [`FORMAT`].
    pub format: String,
    /// [`VERSION`].
    pub version: u32,
    /// What the `[model]` table holds: `spindle`, `stiffness`, `force`, `thermal_exponential`,
    /// `thermal_linear_temp`, `thermal_speed`, `wall`, `response_surface`, `bundle`.
    pub kind: String,
    /// Where the model came from.
    pub provenance: Provenance,
}

/// A model with its header: what is written to and read from disk.
///
/// # Examples
/// ```
/// use millcomp_models::{ModelFile, Provenance};
/// #[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
/// struct Gain { gain_um_per_v: f64 }
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("gain.toml");
/// let file = ModelFile::new("gain", Gain { gain_um_per_v: 0.05 }, Provenance::now("millcomp 0.1.0", "example"));
/// file.save(&path).unwrap();
/// let back: ModelFile<Gain> = ModelFile::load(&path, &["gain"]).unwrap();
/// assert_eq!(back.model.gain_um_per_v, 0.05);
/// // a reader that needs another kind is told which kind the file holds
/// let err = ModelFile::<Gain>::load(&path, &["spindle"]).unwrap_err();
/// assert!(err.to_string().contains("header.kind"));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFile<B> {
    /// The header.
    pub header: Header,
    /// The model.
    pub model: B,
}

impl<B: Serialize + DeserializeOwned> ModelFile<B> {
    /// A model of `kind` with its provenance, at the current format and version.
    pub fn new(kind: &str, model: B, provenance: Provenance) -> Self {
        Self {
            header: Header {
                format: FORMAT.to_string(),
                version: VERSION,
                kind: kind.to_string(),
                provenance,
            },
            model,
        }
    }

    /// The TOML text of the file (`[header]`, then `[model]`).
    ///
    /// ```
    /// use millcomp_models::{ModelFile, Provenance};
    /// #[derive(serde::Serialize, serde::Deserialize)]
    /// struct Gain { gain_um_per_v: f64 }
    /// let text = ModelFile::new("gain", Gain { gain_um_per_v: 0.05 }, Provenance::now("millcomp 0.1.0", "doc"))
    ///     .to_toml()
    ///     .unwrap();
    /// assert!(text.starts_with("[header]\nformat = \"millcomp-model\"\nversion = 1\nkind = \"gain\"\n"));
    /// assert!(text.contains("[model]\ngain_um_per_v = 0.05\n"));
    /// ```
    ///
    /// # Errors
    /// [`ModelError::Serialize`] when the model cannot be written as TOML (e.g. a map with non-string keys).
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string(self).map_err(|source| ModelError::Serialize {
            path: PathBuf::from("<memory>"),
            source,
        })
    }

    /// Parses a model file's text (`origin` names it in errors), checking the header first: format,
    /// version, and that `kind` is one of `kinds` (any kind when `kinds` is empty).
    ///
    /// # Errors
    /// [`ModelError::Parse`] for text that is not TOML or a `[model]` table of the wrong shape;
    /// [`ModelError::Header`] for a missing header, another format or version;
    /// [`ModelError::Kind`] for another kind.
    ///
    /// # Examples
    /// ```
    /// use std::path::Path;
    /// use millcomp_models::{ModelError, ModelFile};
    /// #[derive(serde::Serialize, serde::Deserialize, Debug)]
    /// struct Gain { gain_um_per_v: f64 }
    /// let text = r#"
    /// [header]
    /// format = "millcomp-model"
    /// version = 1
    /// kind = "gain"
    /// [header.provenance]
    /// program = "millcomp 0.1.0"
    /// command = "by hand"
    /// created_utc = "2000-02-29T00:00:00Z"
    /// [model]
    /// gain_um_per_v = 0.05
    /// "#;
    /// let f = ModelFile::<Gain>::from_toml(text, Path::new("gain.toml"), &["gain"]).unwrap();
    /// assert_eq!(f.model.gain_um_per_v, 0.05);
    /// // a file of another version is refused before its body is read, naming the key
    /// let v2 = text.replace("version = 1", "version = 2");
    /// let e = ModelFile::<Gain>::from_toml(&v2, Path::new("gain.toml"), &["gain"]).unwrap_err();
    /// assert!(matches!(&e, ModelError::Header { key, .. } if key == "header.version"));
    /// ```
    pub fn from_toml(text: &str, origin: &Path, kinds: &[&str]) -> Result<Self> {
        let parse_err = |source| ModelError::Parse {
            path: origin.to_path_buf(),
            source,
        };
        let doc: toml::Table = toml::from_str(text).map_err(parse_err)?;
        check_header(&doc, origin, kinds)?;
        check_numbers(&doc, origin)?;
        toml::from_str(text).map_err(parse_err)
    }

    /// Reads a model file (see [`ModelFile::from_toml`]; an example with [`ModelFile::save`] is on
    /// [`ModelFile`]).
    ///
    /// # Errors
    /// [`ModelError::Io`] when the file cannot be read, and those of [`ModelFile::from_toml`].
    pub fn load(path: &Path, kinds: &[&str]) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: path.to_path_buf(),
            action: "reading".into(),
            source,
        })?;
        Self::from_toml(&text, path, kinds)
    }

    /// Writes the file atomically: to a temporary file in the same directory, then renamed over `path`
    /// (an example with [`ModelFile::load`] is on [`ModelFile`]).
    ///
    /// A model holding a number the format does not allow — NaN or infinite anywhere but where
    /// [`check_numbers`] allows it (an S = inf fit, a NaN covariance) — is refused before anything is
    /// written, naming the key: it would drive a controller with garbage.
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] naming the first non-finite key; [`ModelError::Serialize`], or
    /// [`ModelError::Io`] naming the file; nothing is left half-written.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = self.to_toml().map_err(|e| match e {
            ModelError::Serialize { source, .. } => ModelError::Serialize {
                path: path.to_path_buf(),
                source,
            },
            other => other,
        })?;
        // check what will be on disk: the text read back
        let doc: toml::Table = toml::from_str(&text).map_err(|source| ModelError::Parse {
            path: path.to_path_buf(),
            source,
        })?;
        check_numbers(&doc, path)?;
        write_atomic(path, |f| f.write_all(text.as_bytes()))
    }
}

/// Checks that every number of a model file is finite, except where the format says a fit could not
/// determine a value (`models/MODEL.md`): `std_err.<name> = inf` for a parameter the data do not
/// determine, and `nan` in the covariance rows and columns of such parameters (and in a derived
/// quantity's `std_err`/`ci95` that depends on one). Any other NaN or infinity — an S = inf fit, a NaN
/// covariance of a determined parameter, an estimate that overflowed — is refused naming its key.
///
/// ```
/// use std::path::Path;
/// use millcomp_models::{file::check_numbers, ModelError};
/// let ok: toml::Table = toml::from_str(r#"
/// [model]
/// params = { a = 1.0, b = 2.0 }
/// std_err = { a = 0.1, b = inf }
/// covariance = { names = ["a", "b"], values = [[0.01, nan], [nan, nan]] }
/// "#).unwrap();
/// assert!(check_numbers(&ok, Path::new("m.toml")).is_ok());
/// let bad: toml::Table = toml::from_str(r#"
/// [model]
/// params = { a = 1.0 }
/// std_err = { a = 0.1 }
/// covariance = { names = ["a"], values = [[nan]] }
/// "#).unwrap();
/// let e = check_numbers(&bad, Path::new("m.toml")).unwrap_err();
/// assert!(matches!(&e, ModelError::InvalidValue { key, .. } if key == "model.covariance.values[0][0]"));
/// ```
///
/// # Errors
/// [`ModelError::InvalidValue`] naming the first non-finite key not allowed to be.
pub fn check_numbers(doc: &toml::Table, origin: &Path) -> Result<()> {
    walk_table(doc, "", &[], origin)
}

/// The parameters a fit table (one with `std_err`) could not determine: those with `std_err = inf`.
fn undetermined(t: &toml::Table) -> Vec<String> {
    match t.get("std_err") {
        Some(toml::Value::Table(se)) => se
            .iter()
            .filter(|(_, v)| matches!(v, toml::Value::Float(x) if *x == f64::INFINITY))
            .map(|(k, _)| k.clone())
            .collect(),
        _ => Vec::new(),
    }
}

fn walk_table(t: &toml::Table, at: &str, loose: &[String], origin: &Path) -> Result<()> {
    let own = undetermined(t);
    let loose: Vec<String> = if own.is_empty() { loose.to_vec() } else { own };
    for (k, v) in t {
        let key = if at.is_empty() {
            k.clone()
        } else {
            format!("{at}.{k}")
        };
        match (k.as_str(), v) {
            // the standard error of an undetermined parameter
            ("std_err", toml::Value::Table(se)) => {
                for (name, x) in se {
                    check_float(x, &format!("{key}.{name}"), origin, |x| x == f64::INFINITY)?;
                }
            }
            ("covariance", toml::Value::Table(c)) => {
                let names: Vec<&str> = match c.get("names") {
                    Some(toml::Value::Array(a)) => a.iter().filter_map(|v| v.as_str()).collect(),
                    _ => Vec::new(),
                };
                let free = |i: usize| names.get(i).is_some_and(|n| loose.iter().any(|l| l == n));
                for (ck, cv) in c {
                    let ckey = format!("{key}.{ck}");
                    match (ck.as_str(), cv) {
                        ("values", toml::Value::Array(rows)) => {
                            for (i, row) in rows.iter().enumerate() {
                                let cells: &[toml::Value] = match row {
                                    toml::Value::Array(r) => r,
                                    other => std::slice::from_ref(other),
                                };
                                for (j, x) in cells.iter().enumerate() {
                                    check_float(x, &format!("{ckey}[{i}][{j}]"), origin, |x| {
                                        x.is_nan() && (free(i) || free(j))
                                    })?;
                                }
                            }
                        }
                        _ => walk_value(cv, &ckey, &loose, origin)?,
                    }
                }
            }
            // a derived quantity of an undetermined parameter has no finite uncertainty
            ("derived", toml::Value::Table(d)) if !loose.is_empty() => {
                for (name, q) in d {
                    let qkey = format!("{key}.{name}");
                    match q {
                        toml::Value::Table(q) => {
                            for (qk, qv) in q {
                                let allowed = matches!(qk.as_str(), "std_err" | "ci95");
                                walk_value_allowing(qv, &format!("{qkey}.{qk}"), origin, allowed)?;
                            }
                        }
                        other => walk_value(other, &qkey, &loose, origin)?,
                    }
                }
            }
            _ => walk_value(v, &key, &loose, origin)?,
        }
    }
    Ok(())
}

fn walk_value(v: &toml::Value, key: &str, loose: &[String], origin: &Path) -> Result<()> {
    match v {
        toml::Value::Table(t) => walk_table(t, key, loose, origin),
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                walk_value(x, &format!("{key}[{i}]"), loose, origin)?;
            }
            Ok(())
        }
        other => check_float(other, key, origin, |_| false),
    }
}

fn walk_value_allowing(v: &toml::Value, key: &str, origin: &Path, allowed: bool) -> Result<()> {
    match v {
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                walk_value_allowing(x, &format!("{key}[{i}]"), origin, allowed)?;
            }
            Ok(())
        }
        toml::Value::Table(t) => walk_table(t, key, &[], origin),
        other => check_float(other, key, origin, |_| allowed),
    }
}

fn check_float(
    v: &toml::Value,
    key: &str,
    origin: &Path,
    allowed: impl Fn(f64) -> bool,
) -> Result<()> {
    match v {
        toml::Value::Float(x) if !x.is_finite() && !allowed(*x) => Err(ModelError::InvalidValue {
            path: origin.to_path_buf(),
            key: key.to_string(),
            value: format!("{x}"),
            allowed:
                "a finite number (a model file holds no NaN or infinity but a `std_err = inf` \
                      of a parameter the data do not determine, and NaN in its covariance)"
                    .into(),
        }),
        _ => Ok(()),
    }
}

/// Checks `[header]` of a parsed file: present, format [`FORMAT`], version [`VERSION`], kind in `kinds`.
fn check_header(doc: &toml::Table, origin: &Path, kinds: &[&str]) -> Result<()> {
    let header_err = |key: &str, found: String, expected: String| ModelError::Header {
        path: origin.to_path_buf(),
        key: key.to_string(),
        found,
        expected,
    };
    let Some(toml::Value::Table(h)) = doc.get("header") else {
        return Err(header_err(
            "header",
            "missing".into(),
            format!(
                "a [header] table with format = \"{FORMAT}\" (files of other formats, e.g. saved by an older \
                 millcomp, must be made again)"
            ),
        ));
    };
    match h.get("format") {
        Some(toml::Value::String(f)) if f == FORMAT => {}
        other => {
            return Err(header_err(
                "header.format",
                other.map_or("missing".into(), |v| v.to_string()),
                format!("this build reads \"{FORMAT}\""),
            ));
        }
    }
    match h.get("version") {
        Some(toml::Value::Integer(v)) if *v == i64::from(VERSION) => {}
        other => {
            return Err(header_err(
                "header.version",
                other.map_or("missing".into(), |v| v.to_string()),
                format!("this build reads version {VERSION}"),
            ));
        }
    }
    let kind = match h.get("kind") {
        Some(toml::Value::String(k)) => k.clone(),
        other => {
            return Err(header_err(
                "header.kind",
                other.map_or("missing".into(), |v| v.to_string()),
                "a model kind (a string)".into(),
            ));
        }
    };
    if !kinds.is_empty() && !kinds.contains(&kind.as_str()) {
        return Err(ModelError::Kind {
            path: origin.to_path_buf(),
            found: kind,
            expected: kinds
                .iter()
                .map(|k| format!("`{k}`"))
                .collect::<Vec<_>>()
                .join(" or "),
        });
    }
    Ok(())
}

/// Reads only the header of a model file (e.g. to dispatch on its kind).
///
/// ```
/// use millcomp_models::{read_header, InputFile, ModelFile, Provenance};
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("k.toml");
/// let provenance = Provenance::now("millcomp 0.1.0", "doc")
///     .with_input(InputFile::from_bytes("a.csv", b"abc"));
/// let stiffness: std::collections::BTreeMap<String, f64> = [("k_n_per_um".to_string(), 0.114)].into();
/// ModelFile::new("stiffness", stiffness, provenance).save(&path).unwrap();
/// let h = read_header(&path).unwrap();
/// assert_eq!((h.kind.as_str(), h.version), ("stiffness", 1));
/// assert_eq!(h.provenance.inputs[0].path, "a.csv");
/// ```
///
/// # Errors
/// As [`ModelFile::load`] for the header.
pub fn read_header(path: &Path) -> Result<Header> {
    #[derive(Deserialize)]
    struct OnlyHeader {
        header: Header,
    }
    let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
        path: path.to_path_buf(),
        action: "reading".into(),
        source,
    })?;
    let parse_err = |source| ModelError::Parse {
        path: path.to_path_buf(),
        source,
    };
    let doc: toml::Table = toml::from_str(&text).map_err(parse_err)?;
    check_header(&doc, path, &[])?;
    let h: OnlyHeader = toml::from_str(&text).map_err(parse_err)?;
    Ok(h.header)
}

/// Lower-case hex SHA-256 of `bytes`.
///
/// ```
/// // FIPS 180-2 test vector: SHA-256("abc")
/// assert_eq!(
///     millcomp_models::sha256_hex(b"abc"),
///     "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
/// );
/// ```
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Current UTC time as `YYYY-MM-DDThh:mm:ssZ`.
pub fn utc_now_rfc3339() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    rfc3339_from_unix(secs)
}

/// Formats Unix seconds as `YYYY-MM-DDThh:mm:ssZ` (proleptic Gregorian; H. Hinnant's `civil_from_days`
/// algorithm).
///
/// ```
/// // reference: `date -u -d @951782400` (GNU coreutils)
/// assert_eq!(millcomp_models::file::rfc3339_from_unix(951_782_400), "2000-02-29T00:00:00Z");
/// ```
pub fn rfc3339_from_unix(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        sod / 3600,
        (sod % 3600) / 60,
        sod % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    struct Body {
        a_um: f64,
    }

    fn file() -> ModelFile<Body> {
        ModelFile::new(
            "test",
            Body { a_um: 1.5 },
            Provenance::now("millcomp 0.1.0", "millcomp test")
                .with_input(InputFile::from_bytes("data.csv", b"abc")),
        )
    }

    #[test]
    fn dates() {
        // Reference: `date -u -d @0` and `date -u -d @1700000000` (GNU coreutils).
        assert_eq!(rfc3339_from_unix(0), "1970-01-01T00:00:00Z");
        assert_eq!(rfc3339_from_unix(1_700_000_000), "2023-11-14T22:13:20Z");
    }

    #[test]
    fn round_trip_keeps_header_and_body() {
        let f = file();
        let text = f.to_toml().unwrap();
        let back = ModelFile::<Body>::from_toml(&text, Path::new("m.toml"), &["test"]).unwrap();
        assert_eq!(back, f);
        assert_eq!(
            back.header.provenance.inputs[0].sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn another_version_or_format_is_refused_naming_the_key() {
        let text = file().to_toml().unwrap();
        let p = Path::new("bundle.toml");
        let e = ModelFile::<Body>::from_toml(&text.replace("version = 1", "version = 2"), p, &[])
            .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("bundle.toml") && msg.contains("header.version"),
            "{msg}"
        );
        let e = ModelFile::<Body>::from_toml(
            &text.replace("millcomp-model", "millcomp-doe-model"),
            p,
            &[],
        )
        .unwrap_err();
        assert!(e.to_string().contains("header.format"), "{e}");
        let e = ModelFile::<Body>::from_toml("[model]\na_um = 1.0\n", p, &[]).unwrap_err();
        assert!(e.to_string().contains("`header`"), "{e}");
    }

    #[test]
    fn a_non_finite_number_is_never_saved_nor_loaded() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        for (bad, written) in [
            (f64::NAN, "nan"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            let mut f = file();
            f.model.a_um = bad;
            let e = f.save(&path).unwrap_err();
            assert!(
                matches!(&e, ModelError::InvalidValue { key, .. } if key == "model.a_um"),
                "{e}"
            );
            assert!(!path.exists(), "nothing written for {bad}");
            // a file written by hand is refused on load, naming the key
            let text = file()
                .to_toml()
                .unwrap()
                .replace("a_um = 1.5", &format!("a_um = {written}"));
            let e = ModelFile::<Body>::from_toml(&text, &path, &[]).unwrap_err();
            assert!(e.to_string().contains("key `model.a_um`"), "{e}");
        }
    }

    #[test]
    fn save_is_atomic_and_leaves_no_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        file().save(&path).unwrap();
        // a failing writer leaves the old file and no temporary file behind
        let e = write_atomic(&path, |_| Err(std::io::Error::other("disk full"))).unwrap_err();
        assert!(e.to_string().contains("m.toml"));
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, vec!["m.toml".to_string()]);
        let back = ModelFile::<Body>::load(&path, &[]).unwrap();
        assert_eq!(back.model.a_um, 1.5);
    }
}
