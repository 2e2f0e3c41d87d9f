//! # millcomp-doe — design of experiments: treatment matrices and their statistical analysis
//!
//! **Designs** ([`generate`]): full factorials (two-level and mixed-level, labels allowed), regular fractions
//! 2^(k−p) from generators or chosen by resolution / run count from a minimum-aberration catalogue (with
//! generators, defining relation, resolution, word-length pattern and alias structure), Plackett–Burman,
//! central composite (circumscribed / inscribed / face-centred; rotatable, orthogonal or orthogonal-blocking
//! α), Box–Behnken, maximin Latin hypercube, definitive screening (conference matrices) and D-optimal designs
//! by coordinate exchange with linear constraints. Replicates, centre points, blocks (confounded with the
//! highest-order interactions), seeded randomisation (ChaCha8), coded and actual levels.
//!
//! **Analysis** ([`analyze`]): least squares in coded units (factors coded −1/+1 from their min/max),
//! effects and coefficients with standard errors, type II ANOVA (equal to the sequential ANOVA in orthogonal
//! designs; matches statsmodels' `anova_lm(..., typ=2)`), R², adjusted and predicted R², lack of fit, Lenth's
//! PSE/ME/SME for saturated models, residual diagnostics, [`backward_eliminate`], [`power`] (noncentral F),
//! and the actual-unit [`response_surface`] of a fit (a `millcomp_models::ResponseSurface`, saved in the common
//! model-file format: `models/MODEL.md`). The crate returns data (serialisable to the `--json` contracts);
//! the text tables and plots of a design or an analysis are the CLI's.
//!
//! ```
//! use millcomp_doe::{analyze, generate, AnalysisInput, Values, DesignKind, DesignRequest, FactorSpec, ModelSpec};
//! // The 2^3 of the Clayton thesis (seed 000, Table 3-2) …
//! let f = FactorSpec::parse_list("depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20").unwrap();
//! let mut req = DesignRequest::new(DesignKind::Full, f);
//! req.seed = Some(2024);
//! let d = generate(&req).unwrap();
//! assert_eq!(d.n_runs(), 8);
//! // … and a response that depends on depth and upfeed only.
//! let cols = d.columns();
//! let get = |n: &str| cols.iter().find(|(c, _)| c == n).unwrap().1.clone();
//! let (Values::F64(dep), Values::F64(up)) = (get("depth_um"), get("upfeed_um")) else { unreachable!() };
//! let y: Vec<f64> = dep.iter().zip(&up).enumerate()
//!     .map(|(i, (d, u))| 0.01 * d + 0.1 * u + 0.01 * ((i * 7 % 5) as f64 - 2.0)).collect();
//! let input = AnalysisInput {
//!     factors: vec![("depth_um".into(), get("depth_um")), ("speed_rpm".into(), get("speed_rpm")),
//!                   ("upfeed_um".into(), get("upfeed_um"))],
//!     response_name: "fx_n".into(),
//!     response: Values::F64(y),
//!     model: ModelSpec::Main,
//! };
//! let a = analyze(&input).unwrap();
//! assert!(a.terms[0].p_value.unwrap() < 0.01); // depth
//! assert!(a.terms[2].p_value.unwrap() < 0.01); // upfeed
//! ```
#![warn(missing_docs)]

pub mod analysis;
pub mod design;
pub mod error;
pub mod factor;
pub mod model;
pub mod surface;

pub use analysis::{
    Analysis, AnalysisInput, AnalyzeOptions, AnalyzeOutcome, BOOKKEEPING_COLUMNS, CoefRow,
    Diagnostics, Elimination, EliminationStep, FactorCoding, LackOfFit, Lenth, LenthTerm,
    PowerReport, RunDiagnostic, TermPower, TermRow, analyze, backward_eliminate, f_test_power,
    lenth, noncentral_f_cdf, noncentral_f_sf, power,
};
pub use design::{
    AliasEntry, CcdAlpha, CcdVariant, Design, DesignCriteria, DesignKind, DesignOptions,
    DesignRequest, LinearConstraint, MAX_FACTORS, Run, generate, resolution_roman,
};
pub use error::{DoeError, Result};
pub use factor::{
    FACTOR_LETTERS, FactorInfo, FactorLevels, FactorSpec, Level, Values, factor_letter,
};
pub use model::ModelSpec;
pub use surface::response_surface;
