//! `millcomp.doe`: `design` (the treatment matrix as a frame, and the design's report) and `analyze`
//! (effects, type II ANOVA, Lenth) on a file or a frame, as `millcomp doe design|analyze`.

use std::path::PathBuf;

use anyhow::Context;
use millcomp_doe::{Analysis, AnalyzeOptions, AnalyzeOutcome, DesignOptions, Elimination};
use polars::prelude::{Column, DataFrame, NamedFrom, PlSmallStr, Series};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrow::to_polars;
use crate::errors::{argument_error, raise};
use crate::input::{Read, Source, provenance, read};
use crate::json::to_py;

/// The [`DesignOptions`] of a dict of `doe.design`'s arguments (`design` and `factors` required);
/// an unknown key or a value of the wrong type is an argument error naming it.
pub fn design_options(d: &Bound<'_, PyDict>) -> PyResult<DesignOptions> {
    fn need<'py, T: FromPyObjectOwned<'py>>(
        d: &Bound<'py, PyDict>,
        key: &str,
    ) -> PyResult<Option<T>> {
        match d.get_item(key)? {
            None => Ok(None),
            Some(v) if v.is_none() => Ok(None),
            Some(v) => v.extract::<T>().map(Some).map_err(|e| {
                let e: PyErr = e.into();
                argument_error(format!("argument `{key}`: {e}"))
            }),
        }
    }
    for k in d.keys() {
        let k: String = k.extract()?;
        if !DESIGN_KEYS.contains(&k.as_str()) {
            return Err(argument_error(format!(
                "unknown design argument `{k}`; allowed: {}",
                DESIGN_KEYS.join(", ")
            )));
        }
    }
    let design: String = need(d, "design")?
        .ok_or_else(|| argument_error("argument `design` is required (e.g. \"full\")".into()))?;
    let factors: String = need(d, "factors")?.ok_or_else(|| {
        argument_error(
            "argument `factors` is required (e.g. \"depth_um=100:200,speed_rpm=10000:20000\")"
                .into(),
        )
    })?;
    let mut o = DesignOptions::new(&design, &factors);
    o.resolution = need(d, "resolution")?;
    o.generators = need(d, "generators")?;
    o.runs = need(d, "runs")?;
    if let Some(r) = need(d, "replicates")? {
        o.replicates = r;
    }
    o.center_points = need(d, "center_points")?;
    if let Some(b) = need(d, "blocks")? {
        o.blocks = b;
    }
    o.seed = need(d, "seed")?;
    if let Some(r) = need(d, "randomize")? {
        o.randomize = r;
    }
    if let Some(v) = need(d, "ccd_variant")? {
        o.ccd_variant = v;
    }
    if let Some(v) = need(d, "alpha")? {
        o.alpha = v;
    }
    o.model = need(d, "model")?;
    o.constraints = need(d, "constraints")?;
    Ok(o)
}

/// The arguments of `doe.design` (and of `batch(design=…)`).
const DESIGN_KEYS: [&str; 14] = [
    "design",
    "factors",
    "resolution",
    "generators",
    "runs",
    "replicates",
    "center_points",
    "blocks",
    "seed",
    "randomize",
    "ccd_variant",
    "alpha",
    "model",
    "constraints",
];

/// The design's matrix (a frame) and its report (the CLI's `doe design --json`), from the dict of
/// `doe.design`'s arguments.
#[pyfunction]
pub fn design<'py>(
    py: Python<'py>,
    options: &Bound<'py, PyDict>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let options = design_options(options)?;
    let (df, report) = py
        .detach(|| -> anyhow::Result<(DataFrame, serde_json::Value)> {
            let design = millcomp_doe::generate(&options.request()?)?;
            let table = millcomp_datasets::adapters::table_from_doe("design", design.columns())?;
            Ok((table.to_dataframe()?, serde_json::to_value(&design)?))
        })
        .map_err(raise)?;
    Ok((to_polars(py, df)?, to_py(py, &report)?))
}

/// An analysis of one response (`doe.analyze`).
#[pyclass(name = "Analysis", module = "millcomp._core", frozen)]
pub struct PyAnalysis {
    analysis: Analysis,
    elimination: Option<Elimination>,
    read: Read,
}

/// Analyses `source` (a path or a table) as `millcomp doe analyze FILE --response R …`.
// One argument per keyword of the Python call (the signature below), as the CLI has one flag each.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (source, response, factors = None, model = "main".to_string(), alpha = 0.05,
    reduce = false, columns = None))]
pub fn analyze(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    response: String,
    factors: Option<Vec<String>>,
    model: String,
    alpha: f64,
    reduce: bool,
    columns: Option<String>,
) -> PyResult<PyAnalysis> {
    let source = Source::of(source, "frame")?;
    py.detach(|| analyze_source(source, &response, factors, &model, alpha, reduce, columns))
        .map_err(raise)
}

/// The Rust side of `python/bench/overhead.py`: `repeats` timings (s) of the call `analyze` makes once
/// its arguments are converted (the frame read into a table, the analysis), without Python around
/// it, for the medians side by side with the Python call's.
#[pyfunction]
#[pyo3(name = "_time_analyze", signature = (source, response, factors, repeats))]
pub fn time_analyze(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    response: String,
    factors: Vec<String>,
    repeats: usize,
) -> PyResult<Vec<f64>> {
    let source = Source::of(source, "frame")?;
    py.detach(|| -> anyhow::Result<Vec<f64>> {
        (0..repeats)
            .map(|_| {
                let start = std::time::Instant::now();
                let a = analyze_source(
                    source.clone(),
                    &response,
                    Some(factors.clone()),
                    "main",
                    0.05,
                    false,
                    None,
                )?;
                let took = start.elapsed().as_secs_f64();
                std::hint::black_box(a);
                Ok(took)
            })
            .collect()
    })
    .map_err(raise)
}

fn analyze_source(
    source: Source,
    response: &str,
    factors: Option<Vec<String>>,
    model: &str,
    alpha: f64,
    reduce: bool,
    columns: Option<String>,
) -> anyhow::Result<PyAnalysis> {
    let read = read(source, "frame", columns.as_deref())?;
    let cols = millcomp_datasets::adapters::doe_columns(&read.table);
    let options = AnalyzeOptions {
        response: response.to_string(),
        factors,
        model: model.to_string(),
        alpha,
        reduce,
    };
    let AnalyzeOutcome {
        analysis,
        elimination,
    } = options.run(&read.origin, &cols)?;
    Ok(PyAnalysis {
        analysis,
        elimination,
        read,
    })
}

/// A frame of named columns of equal length.
fn frame(columns: Vec<(&str, Series)>) -> anyhow::Result<DataFrame> {
    let height = columns.first().map_or(0, |(_, s)| s.len());
    let columns: Vec<Column> = columns
        .into_iter()
        .map(|(name, s)| s.with_name(PlSmallStr::from(name)).into())
        .collect();
    Ok(DataFrame::new(height, columns)?)
}

/// One column from the rows: `f` picks the value.
fn pick<R, T>(rows: &[R], f: impl Fn(&R) -> T) -> Series
where
    Series: NamedFrom<Vec<T>, [T]>,
{
    Series::new(PlSmallStr::EMPTY, rows.iter().map(f).collect::<Vec<T>>())
}

impl PyAnalysis {
    fn anova_frame(&self) -> anyhow::Result<DataFrame> {
        let a = &self.analysis;
        let mut term: Vec<String> = a.terms.iter().map(|t| t.term.clone()).collect();
        let mut df: Vec<i64> = a.terms.iter().map(|t| t.df as i64).collect();
        let mut ss: Vec<f64> = a.terms.iter().map(|t| t.sum_sq).collect();
        let mut f: Vec<Option<f64>> = a.terms.iter().map(|t| t.f).collect();
        let mut p: Vec<Option<f64>> = a.terms.iter().map(|t| t.p_value).collect();
        term.push("Residual".to_string());
        df.push(a.residual_df as i64);
        ss.push(a.residual_sum_sq);
        f.push(None);
        p.push(None);
        let ms: Vec<Option<f64>> = ss
            .iter()
            .zip(&df)
            .map(|(s, d)| (*d > 0).then(|| s / *d as f64))
            .collect();
        let s = |v| Series::new(PlSmallStr::EMPTY, v);
        frame(vec![
            ("term", Series::new(PlSmallStr::EMPTY, term)),
            ("df", Series::new(PlSmallStr::EMPTY, df)),
            ("sum_sq", Series::new(PlSmallStr::EMPTY, ss)),
            ("mean_sq", s(ms)),
            ("f", s(f)),
            ("p_value", s(p)),
        ])
    }

    fn effects_frame(&self) -> anyhow::Result<DataFrame> {
        let t = &self.analysis.terms;
        frame(vec![
            ("term", pick(t, |r| r.term.clone())),
            ("effect", pick(t, |r| r.effect)),
            ("coef", pick(t, |r| r.coef)),
            ("std_err", pick(t, |r| r.std_err)),
            ("p_value", pick(t, |r| r.p_value)),
        ])
    }

    fn coefficients_frame(&self) -> anyhow::Result<DataFrame> {
        let c = &self.analysis.coefficients;
        frame(vec![
            ("name", pick(c, |r| r.name.clone())),
            ("coef", pick(c, |r| r.coef)),
            ("std_err", pick(c, |r| r.std_err)),
            ("t", pick(c, |r| r.t)),
            ("p_value", pick(c, |r| r.p_value)),
        ])
    }

    fn lenth_frame(&self) -> anyhow::Result<Option<DataFrame>> {
        let Some(l) = &self.analysis.lenth else {
            return Ok(None);
        };
        let t = &l.terms;
        Ok(Some(frame(vec![
            ("term", pick(t, |r| r.term.clone())),
            ("effect", pick(t, |r| r.effect)),
            ("t_pse", pick(t, |r| r.t_pse)),
            ("exceeds_me", pick(t, |r| r.exceeds_me)),
            ("exceeds_sme", pick(t, |r| r.exceeds_sme)),
        ])?))
    }

    fn report_value(&self) -> anyhow::Result<serde_json::Value> {
        let mut doc = serde_json::to_value(&self.analysis)?;
        if let Some(e) = &self.elimination {
            doc["elimination"] = serde_json::to_value(&e.steps)?;
        }
        Ok(doc)
    }
}

#[pymethods]
impl PyAnalysis {
    /// Type II ANOVA: `term, df, sum_sq, mean_sq, f, p_value`, the residual last.
    #[getter]
    fn anova<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_polars(py, self.anova_frame().map_err(raise)?)
    }

    /// Per term: `term, effect, coef, std_err, p_value` (effect = 2 × coefficient for coded ±1).
    #[getter]
    fn effects<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_polars(py, self.effects_frame().map_err(raise)?)
    }

    /// The coefficients in coded units: `name, coef, std_err, t, p_value`.
    #[getter]
    fn coefficients<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_polars(py, self.coefficients_frame().map_err(raise)?)
    }

    /// Lenth's method (unreplicated two-level designs): `term, effect, t_pse, exceeds_me,
    /// exceeds_sme`, or `None` where it does not apply.
    #[getter]
    fn lenth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        match self.lenth_frame().map_err(raise)? {
            Some(df) => Ok(Some(to_polars(py, df)?)),
            None => Ok(None),
        }
    }

    /// Lenth's scale: `{s0, pse, df, me, sme}`, or `None`.
    #[getter]
    fn lenth_limits<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        match &self.analysis.lenth {
            Some(l) => Ok(Some(to_py(
                py,
                &serde_json::json!({"s0": l.s0, "pse": l.pse, "df": l.df, "me": l.me, "sme": l.sme}),
            )?)),
            None => Ok(None),
        }
    }

    /// The whole analysis as `millcomp --json doe analyze` prints it.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report_value().map_err(raise)?)
    }

    /// The response's name.
    #[getter]
    fn response(&self) -> String {
        self.analysis.response.clone()
    }

    /// R².
    #[getter]
    fn r_squared(&self) -> f64 {
        self.analysis.r_squared
    }

    /// Notes on the input (columns renamed or ignored).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.read.notes.clone()
    }

    /// Writes the response surface (coefficients in actual units, covariance, ranges) in the model-file
    /// format `millcomp doe analyze --save` writes (kind `response_surface`), atomically. `command`
    /// goes into the provenance.
    #[pyo3(signature = (path, command = "millcomp.doe.analyze(...)".to_string()))]
    fn save(&self, py: Python<'_>, path: PathBuf, command: String) -> PyResult<()> {
        py.detach(|| -> anyhow::Result<()> {
            let surface = millcomp_doe::response_surface(&self.analysis)?;
            let prov = provenance(&command, vec![self.read.input_file()?]);
            millcomp_models::ModelFile::new("response_surface", surface, prov)
                .save(&path)
                .with_context(|| format!("saving the model to {}", path.display()))?;
            Ok(())
        })
        .map_err(raise)
    }

    fn __repr__(&self) -> String {
        format!(
            "<millcomp Analysis of `{}`: {} runs, model {}, R² = {:.4}>",
            self.analysis.response,
            self.analysis.n_runs,
            self.analysis.model,
            self.analysis.r_squared
        )
    }
}
