//! Design generation: the request, the generated design (serialised exactly as the CLI contract says) and the
//! builders of each design family.

pub(crate) mod doptimal;
pub(crate) mod factorial;
pub(crate) mod fractional;
pub(crate) mod rsm;
pub(crate) mod screening;
pub(crate) mod spacefilling;

use std::str::FromStr;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::ser::{SerializeMap, SerializeStruct};
use serde::{Serialize, Serializer};

use crate::error::{DoeError, Result};
use crate::factor::{FactorInfo, FactorSpec, Level, Values};
use crate::model::ModelSpec;

pub use doptimal::LinearConstraint;
pub use fractional::{AliasEntry, resolution_roman};

/// The most runs a generated design may have, replicates and centre points included (a full factorial
/// stops at the same 1e6): more is no experiment anyone runs, and a billion-run request would exhaust
/// memory before it failed.
pub const MAX_DESIGN_RUNS: usize = 1_000_000;

/// The most centre points per block.
pub const MAX_CENTER_POINTS: usize = 1000;

/// Variant of a central composite design.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CcdVariant {
    /// Axial points at ±α outside the factorial cube (CCC); actual low/high map to the cube.
    Circumscribed,
    /// The CCC scaled so that the axial points sit at the actual low/high (CCI).
    Inscribed,
    /// Axial points on the faces of the cube, α = 1 (CCF).
    FaceCentred,
}

impl FromStr for CcdVariant {
    type Err = DoeError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "circumscribed" | "ccc" | "c" => Ok(CcdVariant::Circumscribed),
            "inscribed" | "cci" | "i" => Ok(CcdVariant::Inscribed),
            "face-centred" | "face-centered" | "faced" | "ccf" | "f" => Ok(CcdVariant::FaceCentred),
            _ => Err(DoeError::InvalidParameter {
                name: "ccd variant",
                value: s.to_string(),
                allowed: "circumscribed, inscribed or face-centred".into(),
            }),
        }
    }
}

impl CcdVariant {
    /// `circumscribed`, `inscribed` or `face-centred`.
    pub fn as_str(self) -> &'static str {
        match self {
            CcdVariant::Circumscribed => "circumscribed",
            CcdVariant::Inscribed => "inscribed",
            CcdVariant::FaceCentred => "face-centred",
        }
    }
}

/// Choice of the axial distance α of a central composite design (coded units of the factorial cube).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CcdAlpha {
    /// Rotatable: α = n_F^{1/4}, n_F = number of factorial points (Box & Hunter 1957; Montgomery eq. 11.19).
    Rotatable,
    /// Orthogonal quadratic effects: α = √((√(N·n_F) − n_F)/2), N = total runs of one replicate
    /// (Box & Hunter 1957; equivalently Montgomery's α = (Q·n_F/4)^{1/4}, Q = (√N − √n_F)²).
    Orthogonal,
    /// Orthogonal blocking with two blocks (factorial + axial):
    /// α = √(k (1 + n_0a/n_a) / (1 + n_0f/n_F)) (Montgomery eq. 11.22; pyDOE3's `alpha="orthogonal"`).
    OrthogonalBlocking,
    /// An explicit value (> 0).
    Value(f64),
}

impl FromStr for CcdAlpha {
    type Err = DoeError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "rotatable" | "r" => Ok(CcdAlpha::Rotatable),
            "orthogonal" | "o" => Ok(CcdAlpha::Orthogonal),
            "orthogonal-blocking" | "blocking" => Ok(CcdAlpha::OrthogonalBlocking),
            other => match other.parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(CcdAlpha::Value(v)),
                _ => Err(DoeError::InvalidParameter {
                    name: "alpha",
                    value: s.to_string(),
                    allowed: "rotatable, orthogonal, orthogonal-blocking or a positive number"
                        .into(),
                }),
            },
        }
    }
}

/// Family of design to generate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DesignKind {
    /// Full factorial, two-level or mixed-level (labels and numeric levels).
    Full,
    /// Regular two-level fraction 2^(k−p) from generators, resolution or run count.
    Fractional,
    /// Plackett–Burman screening design (12, 20, 24, 36, 44 runs and doublings; 2^m runs via Sylvester).
    PlackettBurman,
    /// Central composite design.
    Ccd {
        /// Circumscribed, inscribed or face-centred.
        variant: CcdVariant,
        /// Axial distance rule.
        alpha: CcdAlpha,
    },
    /// Box–Behnken design (3–7 factors from Box & Behnken 1960; more factors: all pairs).
    BoxBehnken,
    /// Maximin Latin hypercube.
    Lhs,
    /// Definitive screening design (Jones & Nachtsheim 2011, conference-matrix construction).
    Dsd,
    /// D-optimal design by coordinate exchange, optionally with linear constraints.
    DOptimal,
}

impl DesignKind {
    /// The CLI name (`full`, `fractional`, `plackett-burman`, `ccd`, `box-behnken`, `lhs`, `dsd`, `d-optimal`).
    pub fn name(&self) -> &'static str {
        match self {
            DesignKind::Full => "full",
            DesignKind::Fractional => "fractional",
            DesignKind::PlackettBurman => "plackett-burman",
            DesignKind::Ccd { .. } => "ccd",
            DesignKind::BoxBehnken => "box-behnken",
            DesignKind::Lhs => "lhs",
            DesignKind::Dsd => "dsd",
            DesignKind::DOptimal => "d-optimal",
        }
    }
}

impl FromStr for DesignKind {
    type Err = DoeError;
    /// Parses the CLI names; `ccd` is circumscribed and rotatable, `ccf`/`ccd-face` face-centred,
    /// `cci`/`ccd-inscribed` inscribed.
    ///
    /// ```
    /// use millcomp_doe::{CcdAlpha, CcdVariant, DesignKind};
    /// let k: DesignKind = "ccf".parse().unwrap();
    /// assert_eq!(k, DesignKind::Ccd { variant: CcdVariant::FaceCentred, alpha: CcdAlpha::Rotatable });
    /// assert!("taguchi".parse::<DesignKind>().is_err());
    /// ```
    ///
    /// # Errors
    /// [`DoeError::InvalidParameter`] (`design`) for an unknown name, listing the known ones.
    fn from_str(s: &str) -> Result<Self> {
        let ccd = |variant| {
            Ok(DesignKind::Ccd {
                variant,
                alpha: CcdAlpha::Rotatable,
            })
        };
        match s.trim().to_ascii_lowercase().as_str() {
            "full" | "full-factorial" | "factorial" => Ok(DesignKind::Full),
            "fractional" | "fractional-factorial" | "frac" => Ok(DesignKind::Fractional),
            "plackett-burman" | "pb" | "plackett_burman" => Ok(DesignKind::PlackettBurman),
            "ccd" | "ccc" | "central-composite" => ccd(CcdVariant::Circumscribed),
            "ccf" | "ccd-face" | "ccd-face-centred" | "ccd-face-centered" => ccd(CcdVariant::FaceCentred),
            "cci" | "ccd-inscribed" => ccd(CcdVariant::Inscribed),
            "box-behnken" | "bbd" | "box_behnken" => Ok(DesignKind::BoxBehnken),
            "lhs" | "latin-hypercube" => Ok(DesignKind::Lhs),
            "dsd" | "definitive-screening" => Ok(DesignKind::Dsd),
            "d-optimal" | "doptimal" | "d_optimal" => Ok(DesignKind::DOptimal),
            _ => Err(DoeError::InvalidParameter {
                name: "design",
                value: s.to_string(),
                allowed: "full, fractional, plackett-burman, ccd (ccf, cci), box-behnken, lhs, dsd, d-optimal".into(),
            }),
        }
    }
}

/// Everything `millcomp doe design` passes to [`generate`].
#[derive(Debug, Clone, PartialEq)]
pub struct DesignRequest {
    /// Design family.
    pub kind: DesignKind,
    /// Factors, in order (their letters A, B, … follow this order).
    pub factors: Vec<FactorSpec>,
    /// Fractional: minimum resolution (3 = III …); the smallest minimum-aberration design reaching it is used.
    pub resolution: Option<u32>,
    /// Fractional: generators such as `"D=AB,E=AC"` (letters or factor names, `-` for a negative word).
    pub generators: Option<String>,
    /// Run count of one replicate without centre points: fractional (power of two), Plackett–Burman, LHS and
    /// D-optimal. `None`: the design's default.
    pub runs: Option<usize>,
    /// Number of replicates of the whole design (≥ 1).
    pub replicates: usize,
    /// Centre points per block (`None`: 4 for CCD, 3 for Box–Behnken, 0 otherwise; a DSD always contains
    /// its own centre run and these are extra).
    pub center_points: Option<usize>,
    /// Blocks per replicate: a power of two for two-level factorials (confounded with the highest-order
    /// interactions), 1 or 2 for CCD (factorial and axial blocks), 1 otherwise.
    pub blocks: usize,
    /// Seed of the run-order randomisation (and of LHS / D-optimal searches); `None`: drawn from the OS and
    /// reported in the design.
    pub seed: Option<u64>,
    /// Randomise the run order within blocks (default true).
    pub randomize: bool,
    /// D-optimal: the model the design must support (default quadratic).
    pub model: Option<ModelSpec>,
    /// D-optimal: linear constraints on coded factors, e.g. `depth_um + upfeed_um <= 1.5`.
    pub constraints: Vec<LinearConstraint>,
}

impl DesignRequest {
    /// A request with defaults: 1 replicate, 1 block, default centre points, randomised, no seed.
    pub fn new(kind: DesignKind, factors: Vec<FactorSpec>) -> Self {
        DesignRequest {
            kind,
            factors,
            resolution: None,
            generators: None,
            runs: None,
            replicates: 1,
            center_points: None,
            blocks: 1,
            seed: None,
            randomize: true,
            model: None,
            constraints: Vec::new(),
        }
    }
}

/// A design request as text and numbers, as `millcomp doe design` takes its flags and Python's
/// `doe.design` its arguments: one place that turns them into a [`DesignRequest`].
#[derive(Debug, Clone, PartialEq)]
pub struct DesignOptions {
    /// `full | fractional | plackett-burman | ccd | box-behnken | lhs | dsd | d-optimal` (also `ccf`,
    /// `cci`).
    pub design: String,
    /// `depth_um=100:200,speed_rpm=10000:20000` or bare names `A,B,C` (coded −1/+1).
    pub factors: String,
    /// Fractional: minimum resolution.
    pub resolution: Option<u32>,
    /// Fractional: generators such as `"D=AB,E=AC"`.
    pub generators: Option<String>,
    /// Runs (LHS, D-optimal, Plackett–Burman, fractional).
    pub runs: Option<usize>,
    /// Replicates of the whole design.
    pub replicates: usize,
    /// Centre points per block (`None`: the design's default).
    pub center_points: Option<usize>,
    /// Blocks.
    pub blocks: usize,
    /// Seed of the run order (and of LHS / D-optimal searches).
    pub seed: Option<u64>,
    /// Randomise the run order.
    pub randomize: bool,
    /// CCD variant (`circumscribed | inscribed | face-centred`), used when `design` is `ccd`.
    pub ccd_variant: String,
    /// CCD alpha (`rotatable | orthogonal | orthogonal-blocking | a number`).
    pub alpha: String,
    /// D-optimal: the model (`main | 2fi | quadratic | a formula`).
    pub model: Option<String>,
    /// D-optimal: linear constraints in coded units (`"a + b <= 1.5; 2*A - B >= -1"`).
    pub constraints: Option<String>,
}

impl DesignOptions {
    /// `design` over `factors` with the defaults of `doe design`: 1 replicate, 1 block, randomised,
    /// a circumscribed rotatable CCD.
    pub fn new(design: &str, factors: &str) -> Self {
        Self {
            design: design.to_string(),
            factors: factors.to_string(),
            resolution: None,
            generators: None,
            runs: None,
            replicates: 1,
            center_points: None,
            blocks: 1,
            seed: None,
            randomize: true,
            ccd_variant: "circumscribed".to_string(),
            alpha: "rotatable".to_string(),
            model: None,
            constraints: None,
        }
    }

    /// The request these options describe.
    ///
    /// ```
    /// use millcomp_doe::{DesignOptions, DoeError};
    /// let mut o = DesignOptions::new("fractional", "a=1:2,b=1:2,c=1:2,d=1:2");
    /// o.resolution = Some(4);
    /// assert_eq!(millcomp_doe::generate(&o.request().unwrap()).unwrap().runs.len(), 8);
    /// o.factors = "a=1:1".into();
    /// let e = o.request().unwrap_err();
    /// assert!(matches!(e, DoeError::BadOption { option: "factors", .. }));
    /// assert_eq!(e.to_string(), "--factors");
    /// ```
    ///
    /// # Errors
    /// [`DoeError::BadOption`] naming the option, with the parser's error as its source.
    pub fn request(&self) -> Result<DesignRequest> {
        fn at<T>(option: &'static str, r: Result<T>) -> Result<T> {
            r.map_err(|e| DoeError::BadOption {
                option,
                source: Box::new(e),
            })
        }
        let factors = at("factors", FactorSpec::parse_list(&self.factors))?;
        let mut kind: DesignKind = at("design", self.design.parse())?;
        if let DesignKind::Ccd { variant, alpha } = &mut kind {
            if self.design == "ccd" {
                *variant = at("ccd_variant", self.ccd_variant.parse::<CcdVariant>())?;
            }
            *alpha = at("alpha", self.alpha.parse::<CcdAlpha>())?;
        }
        let mut req = DesignRequest::new(kind, factors);
        req.resolution = self.resolution;
        req.generators = self.generators.clone();
        req.runs = self.runs;
        req.replicates = self.replicates;
        req.center_points = self.center_points;
        req.blocks = self.blocks;
        req.seed = self.seed;
        req.randomize = self.randomize;
        if let Some(m) = &self.model {
            req.model = Some(at("model", ModelSpec::parse(m))?);
        }
        if let Some(c) = &self.constraints {
            req.constraints = at("constraints", LinearConstraint::parse_list(c, &req.factors))?;
        }
        Ok(req)
    }
}

/// One run of a design.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Standard (unrandomised) order, 1-based.
    pub std_order: usize,
    /// Order in which to perform the run, 1-based.
    pub run_order: usize,
    /// Block, 1-based (blocks of later replicates continue the numbering).
    pub block: usize,
    /// Actual level of each factor (factor order).
    pub actual: Vec<Level>,
    /// Coded level of each factor (factor order).
    pub coded: Vec<f64>,
}

/// Summary numbers of a design's quality, where they apply.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct DesignCriteria {
    /// D-optimal: model the design supports.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// D-optimal: ln det(XᵀX) of one replicate in coded units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub log_det_xtx: Option<f64>,
    /// D-optimal: D-efficiency 100·det(XᵀX)^{1/p}/n (%), relative to an orthogonal ±1 design.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub d_efficiency_pct: Option<f64>,
    /// LHS: smallest distance between two runs in coded units ([−1, 1]^k).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_distance: Option<f64>,
}

/// A generated design. Serialises to the `doe design --json` contract: `design`, `n_runs`, `factors`,
/// `resolution`, `generators`, `alias_structure`, `runs` (each with `std_order`, `run_order`, `block`, the
/// actual level under the factor name and the coded level under `<name>_coded`), plus extra keys
/// (`defining_relation`, `word_length_pattern`, `blocks`, `block_generators`, `confounded_with_blocks`,
/// `replicates`, `center_points`, `seed`, `randomized`, `alpha`, `variant`, `criteria`, `notes`).
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// CLI name of the family.
    pub design: &'static str,
    /// Factors.
    pub factors: Vec<FactorInfo>,
    /// Resolution of a regular two-level fraction; `None` for full factorials and other designs.
    pub resolution: Option<u32>,
    /// Generators in letters, e.g. `D=ABC` (CCD: those of its factorial portion).
    pub generators: Vec<String>,
    /// Defining relation, e.g. `I=ABCD=…`, one word per entry (`I=ABCD`).
    pub defining_relation: Vec<String>,
    /// Word-length pattern (A3, A4, …) of a regular fraction.
    pub word_length_pattern: Vec<usize>,
    /// Alias structure of main effects and two-factor interactions (aliases up to order 3).
    pub alias_structure: Vec<AliasEntry>,
    /// Blocks per replicate.
    pub blocks: usize,
    /// Block generators (letters) of a blocked two-level design.
    pub block_generators: Vec<String>,
    /// Effects confounded with blocks (lowest-order member of each confounded alias set; names joined by `:`).
    pub confounded_with_blocks: Vec<String>,
    /// Replicates.
    pub replicates: usize,
    /// Centre points per block (added by the request; a DSD's built-in centre run is not counted).
    pub center_points: usize,
    /// Seed used for randomisation and searches.
    pub seed: u64,
    /// Whether the run order is randomised.
    pub randomized: bool,
    /// CCD: axial distance in coded units of the factorial cube.
    pub alpha: Option<f64>,
    /// CCD variant.
    pub variant: Option<&'static str>,
    /// Quality criteria where they apply.
    pub criteria: DesignCriteria,
    /// Notes (choices made, caveats).
    pub notes: Vec<String>,
    /// Runs, in run order.
    pub runs: Vec<Run>,
}

struct RunView<'a> {
    run: &'a Run,
    names: &'a [FactorInfo],
}

impl Serialize for RunView<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(3 + 2 * self.names.len()))?;
        m.serialize_entry("std_order", &self.run.std_order)?;
        m.serialize_entry("run_order", &self.run.run_order)?;
        m.serialize_entry("block", &self.run.block)?;
        for (i, f) in self.names.iter().enumerate() {
            m.serialize_entry(&f.name, &self.run.actual[i])?;
            m.serialize_entry(&format!("{}_coded", f.name), &self.run.coded[i])?;
        }
        m.end()
    }
}

impl Serialize for Design {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("Design", 21)?;
        st.serialize_field("design", self.design)?;
        st.serialize_field("n_runs", &self.n_runs())?;
        st.serialize_field("factors", &self.factors)?;
        st.serialize_field("resolution", &self.resolution)?;
        st.serialize_field("generators", &self.generators)?;
        st.serialize_field("defining_relation", &self.defining_relation)?;
        st.serialize_field("word_length_pattern", &self.word_length_pattern)?;
        st.serialize_field("alias_structure", &self.alias_structure)?;
        st.serialize_field("blocks", &self.blocks)?;
        st.serialize_field("block_generators", &self.block_generators)?;
        st.serialize_field("confounded_with_blocks", &self.confounded_with_blocks)?;
        st.serialize_field("replicates", &self.replicates)?;
        st.serialize_field("center_points", &self.center_points)?;
        st.serialize_field("seed", &self.seed)?;
        st.serialize_field("randomized", &self.randomized)?;
        st.serialize_field("alpha", &self.alpha)?;
        st.serialize_field("variant", &self.variant)?;
        st.serialize_field("criteria", &self.criteria)?;
        st.serialize_field("notes", &self.notes)?;
        let runs: Vec<RunView<'_>> = self
            .runs
            .iter()
            .map(|r| RunView {
                run: r,
                names: &self.factors,
            })
            .collect();
        st.serialize_field("runs", &runs)?;
        st.end()
    }
}

impl Design {
    /// Number of runs (all replicates, centre points included).
    pub fn n_runs(&self) -> usize {
        self.runs.len()
    }

    /// The runs as table columns in run order: `std_order`, `run_order`, `block` (I64), then for each factor
    /// its actual level (F64, or Str for label factors) and `<name>_coded` (F64).
    ///
    /// ```
    /// use millcomp_doe::{generate, Values, DesignKind, DesignRequest, FactorSpec};
    /// let mut req = DesignRequest::new(DesignKind::Full, FactorSpec::parse_list("a=1:2,m=x:y:z").unwrap());
    /// req.seed = Some(1);
    /// let d = generate(&req).unwrap();
    /// let cols = d.columns();
    /// assert_eq!(cols.len(), 3 + 2 * 2);
    /// assert_eq!(cols[3].0, "a");
    /// assert!(matches!(&cols[5].1, Values::Str(v) if v.len() == 6));
    /// ```
    pub fn columns(&self) -> Vec<(String, Values)> {
        let mut out = vec![
            (
                "std_order".to_string(),
                Values::I64(self.runs.iter().map(|r| r.std_order as i64).collect()),
            ),
            (
                "run_order".to_string(),
                Values::I64(self.runs.iter().map(|r| r.run_order as i64).collect()),
            ),
            (
                "block".to_string(),
                Values::I64(self.runs.iter().map(|r| r.block as i64).collect()),
            ),
        ];
        for (i, f) in self.factors.iter().enumerate() {
            let col = if f.kind == "label" {
                Values::Str(self.runs.iter().map(|r| r.actual[i].to_string()).collect())
            } else {
                Values::F64(
                    self.runs
                        .iter()
                        .map(|r| match &r.actual[i] {
                            Level::Num(v) => *v,
                            Level::Label(_) => f64::NAN,
                        })
                        .collect(),
                )
            };
            out.push((f.name.clone(), col));
            out.push((
                format!("{}_coded", f.name),
                Values::F64(self.runs.iter().map(|r| r.coded[i]).collect()),
            ));
        }
        out
    }

    /// Coded design matrix in run order (rows = runs, columns = factors).
    pub fn coded_matrix(&self) -> Vec<Vec<f64>> {
        self.runs.iter().map(|r| r.coded.clone()).collect()
    }

    /// Factor names in order.
    pub fn factor_names(&self) -> Vec<String> {
        self.factors.iter().map(|f| f.name.clone()).collect()
    }
}

/// What a family builder returns: one replicate's points in standard order, before centre points.
#[derive(Debug, Clone, Default)]
pub(crate) struct BasePoints {
    /// Coded points.
    pub coded: Vec<Vec<f64>>,
    /// Block of each point within a replicate (1-based).
    pub block: Vec<usize>,
    /// Number of blocks per replicate.
    pub n_blocks: usize,
    /// Whether the builder already placed the centre points.
    pub centers_included: bool,
    pub resolution: Option<u32>,
    pub generators: Vec<String>,
    pub defining_relation: Vec<String>,
    pub word_length_pattern: Vec<usize>,
    pub alias_structure: Vec<AliasEntry>,
    pub block_generators: Vec<String>,
    pub confounded_with_blocks: Vec<String>,
    pub alpha: Option<f64>,
    pub variant: Option<&'static str>,
    pub criteria: DesignCriteria,
    pub notes: Vec<String>,
}

impl BasePoints {
    pub(crate) fn unblocked(coded: Vec<Vec<f64>>) -> Self {
        let n = coded.len();
        BasePoints {
            coded,
            block: vec![1; n],
            n_blocks: 1,
            ..Default::default()
        }
    }
}

/// Checks that every factor has exactly two levels (labels allowed when `labels_ok`).
pub(crate) fn require_two_levels(
    factors: &[FactorSpec],
    design: &'static str,
    labels_ok: bool,
) -> Result<()> {
    for f in factors {
        let ok = f.n_levels() == 2 && (labels_ok || f.is_continuous());
        if !ok {
            return Err(DoeError::LevelsNotAllowed {
                name: f.name.clone(),
                design,
                levels: f.n_levels(),
                kind: f.kind(),
                allowed: if labels_ok {
                    "exactly two levels (numeric low:high, two labels, or a bare name)"
                } else {
                    "a numeric range low:high or a bare (coded) name"
                },
            });
        }
    }
    Ok(())
}

/// Generates a design: the family's points in standard order, centre points, replicates, blocks and the
/// run order (randomised within blocks with ChaCha8 from `req.seed`, or from a seed drawn from the OS and
/// reported in [`Design::seed`]).
///
/// # Examples
/// ```
/// use millcomp_doe::{generate, DesignKind, DesignRequest, DoeError, FactorSpec};
/// let mut req = DesignRequest::new(DesignKind::Fractional, FactorSpec::parse_list("A,B,C,D,E,F,G").unwrap());
/// req.resolution = Some(3);
/// req.seed = Some(7);
/// let d = generate(&req).unwrap();
/// assert_eq!(d.n_runs(), 8); // 2^(7-4), not 16 (pyDOE3 issue #153)
/// assert_eq!(d.resolution, Some(3));
/// // Montgomery, Design and Analysis of Experiments, Table 8.14: the 2^(7-4)_III generators
/// assert_eq!(d.generators, vec!["D=AB", "E=AC", "F=BC", "G=ABC"]);
///
/// // Generators that alias two main effects are refused, naming the short defining word.
/// let mut req = DesignRequest::new(DesignKind::Fractional, FactorSpec::parse_list("A,B,C,D").unwrap());
/// req.generators = Some("D=A".into());
/// let e = generate(&req).unwrap_err();
/// assert!(matches!(&e, DoeError::AliasedGenerators { factor, .. } if factor == "D"));
/// assert!(e.to_string().contains("I = AD"));
/// ```
///
/// # Errors
/// [`DoeError`] naming the factor, generator or parameter at fault:
/// * the factors: [`DoeError::NoFactors`], [`DoeError::DuplicateFactor`], [`DoeError::SingleLevelFactor`],
///   [`DoeError::LevelsNotAllowed`] (e.g. three levels for a two-level family);
/// * the options: [`DoeError::InvalidParameter`] (0 replicates or blocks, a run count or resolution the
///   family cannot give), [`DoeError::Unsupported`] (blocks, centre points or constraints the family does
///   not take), [`DoeError::NotEnoughData`] (too few factors for a CCD, Box–Behnken or DSD);
/// * fractional designs: [`DoeError::InvalidGenerator`], [`DoeError::DuplicateGenerator`],
///   [`DoeError::AliasedGenerators`], [`DoeError::UnknownFactor`], [`DoeError::NoCatalogueDesign`];
/// * D-optimal designs: [`DoeError::UnknownFactor`] in the model, [`DoeError::InfeasibleConstraints`].
pub fn generate(req: &DesignRequest) -> Result<Design> {
    let factors = &req.factors;
    if factors.is_empty() {
        return Err(DoeError::NoFactors);
    }
    if factors.len() > MAX_FACTORS {
        return Err(DoeError::InvalidParameter {
            name: "factors",
            value: factors.len().to_string(),
            allowed: format!(
                "at most {MAX_FACTORS} factors (the largest Plackett–Burman design's)"
            ),
        });
    }
    for (i, f) in factors.iter().enumerate() {
        if factors[..i].iter().any(|g| g.name == f.name) {
            return Err(DoeError::DuplicateFactor {
                name: f.name.clone(),
            });
        }
        if f.n_levels() < 2 {
            return Err(DoeError::SingleLevelFactor {
                name: f.name.clone(),
                level: f
                    .level_values()
                    .first()
                    .map(|l| l.to_string())
                    .unwrap_or_default(),
            });
        }
    }
    if req.replicates == 0 {
        return Err(DoeError::InvalidParameter {
            name: "replicates",
            value: "0".into(),
            allowed: "≥ 1".into(),
        });
    }
    if req.blocks == 0 {
        return Err(DoeError::InvalidParameter {
            name: "blocks",
            value: "0".into(),
            allowed: "≥ 1".into(),
        });
    }
    if !req.constraints.is_empty() && req.kind != DesignKind::DOptimal {
        return Err(DoeError::Unsupported {
            what: format!(
                "constraints with the {} design (use --design d-optimal)",
                req.kind.name()
            ),
        });
    }
    let seed = req.seed.unwrap_or_else(rand::random::<u64>);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let default_centers = match req.kind {
        DesignKind::Ccd { .. } => 4,
        DesignKind::BoxBehnken => 3,
        _ => 0,
    };
    let centers = req.center_points.unwrap_or(default_centers);
    if centers > MAX_CENTER_POINTS {
        return Err(DoeError::InvalidParameter {
            name: "center_points",
            value: centers.to_string(),
            allowed: format!("at most {MAX_CENTER_POINTS} per block"),
        });
    }
    let mut base = match req.kind {
        DesignKind::Full => factorial::full(req)?,
        DesignKind::Fractional => factorial::fractional(req)?,
        DesignKind::PlackettBurman => screening::plackett_burman(req)?,
        DesignKind::Dsd => screening::dsd(req)?,
        DesignKind::Ccd { variant, alpha } => rsm::ccd(req, variant, alpha, centers)?,
        DesignKind::BoxBehnken => rsm::box_behnken(req)?,
        DesignKind::Lhs => spacefilling::lhs(req, &mut rng)?,
        DesignKind::DOptimal => doptimal::d_optimal(req, &mut rng)?,
    };
    if base.n_blocks != req.blocks && !matches!(req.kind, DesignKind::Ccd { .. }) {
        return Err(DoeError::Unsupported {
            what: format!(
                "{} blocks with the {} design (two-level factorials take a power of two, CCD 1 or 2; others 1)",
                req.blocks,
                req.kind.name()
            ),
        });
    }
    let total = (base.coded.len()
        + if base.centers_included {
            0
        } else {
            centers * base.n_blocks
        })
    .saturating_mul(req.replicates);
    if total > MAX_DESIGN_RUNS {
        return Err(DoeError::InvalidParameter {
            name: "replicates",
            value: req.replicates.to_string(),
            allowed: format!(
                "a design of at most {MAX_DESIGN_RUNS} runs (this one would have {total}: {} runs × {} replicates)",
                total / req.replicates.max(1),
                req.replicates
            ),
        });
    }
    if centers > 0 && !base.centers_included {
        if let Some(f) = factors.iter().find(|f| !f.is_continuous()) {
            return Err(DoeError::Unsupported {
                what: format!(
                    "centre points with the label factor `{}` (centre points need numeric factors)",
                    f.name
                ),
            });
        }
        let k = factors.len();
        for b in 1..=base.n_blocks {
            for _ in 0..centers {
                base.coded.push(vec![0.0; k]);
                base.block.push(b);
            }
        }
    }
    // Standard order: replicate, block, then the builder's order (centre points last in their block).
    let mut order: Vec<usize> = (0..base.coded.len()).collect();
    order.sort_by_key(|&i| base.block[i]);
    let mut runs: Vec<Run> = Vec::with_capacity(order.len() * req.replicates);
    for rep in 0..req.replicates {
        for &i in &order {
            let coded = base.coded[i].clone();
            let actual = coded
                .iter()
                .zip(factors)
                .map(|(&c, f)| f.actual(c))
                .collect();
            runs.push(Run {
                std_order: runs.len() + 1,
                run_order: 0,
                block: rep * base.n_blocks + base.block[i],
                actual,
                coded,
            });
        }
    }
    // Run order: randomised within blocks, blocks in order.
    let n_total_blocks = base.n_blocks * req.replicates;
    let mut next = 1;
    for b in 1..=n_total_blocks {
        let mut idx: Vec<usize> = (0..runs.len()).filter(|&i| runs[i].block == b).collect();
        if req.randomize {
            idx.shuffle(&mut rng);
        }
        for i in idx {
            runs[i].run_order = next;
            next += 1;
        }
    }
    runs.sort_by_key(|r| r.run_order);
    Ok(Design {
        design: req.kind.name(),
        factors: factors
            .iter()
            .enumerate()
            .map(|(i, f)| FactorInfo::from_spec(i, f))
            .collect(),
        resolution: base.resolution,
        generators: base.generators,
        defining_relation: base.defining_relation,
        word_length_pattern: base.word_length_pattern,
        alias_structure: base.alias_structure,
        blocks: base.n_blocks,
        block_generators: base.block_generators,
        confounded_with_blocks: base.confounded_with_blocks,
        replicates: req.replicates,
        center_points: centers,
        seed,
        randomized: req.randomize,
        alpha: base.alpha,
        variant: base.variant,
        criteria: base.criteria,
        notes: base.notes,
        runs,
    })
}

/// The most factors a design takes: the largest Plackett–Burman design's (4096 runs). A design holds
/// runs × factors levels, and a definitive screening design of k factors builds a conference matrix of
/// order ≈ k: without a bound, 20 000 factors asked for 8 GB or more before anything was checked.
pub const MAX_FACTORS: usize = 4095;
