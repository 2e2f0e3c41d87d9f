//! # millcomp-diagnose
//!
//! The discrepancy workflow behind `millcomp diagnose`: find where simulation and measurement
//! disagree, name the missing effect, add it, show the gap shrink (issue 7; the manual loop of
//! `002_…txt` §7, automated). It is built on `millcomp-sim` (the session's nominal model and the
//! candidate effects) and `millcomp-identify` (the least-squares engine); it returns report data
//! ([`DiagnoseReport`], serialisable) — text and plots are the CLI's.
//!
//! # Algorithm
//! 1. Play the session's plan out once with sim and take its nominal model ([`SessionModel`]:
//!    sim's per-point contexts plus the effects listed in the session file); check that the
//!    measured points are that session's plan point by point ([`Measured::check_against`]);
//!    residual = measured − nominal; its structure against time, engaged length, position,
//!    machine X, speed, coolant, predicted force and tilt ([`structure`]).
//! 2. Forward selection ([`Diagnoser`]). In each round, every candidate effect not yet in the
//!    model is added to it and the augmented model — the candidate's free parameters *jointly*
//!    with those of the effects already added (and the nominal offset if
//!    [`DiagnoseOptions::free_offset`]) — is fitted by bounded nonlinear least squares on the
//!    identify engine, from a small grid of starting values ([`candidates`]). Each is tested
//!    against the current model with the nested F-test `F = ((RSS₀ − RSS₁)/q) / (RSS₁/(n − p₁))`
//!    (FisherSnedecor(q, n − p₁), statrs; [`nested`]).
//! 3. The candidate with the smallest p-value is added if `p < α/m` — **Bonferroni** over the m
//!    candidates tried in that round (this is also Holm's first, most stringent comparison; the
//!    remaining candidates are not tested at Holm's relaxed levels because after adding one effect
//!    they are refitted and retested in the next round) — **and** BIC
//!    (`n·ln(RSS/n) + k·ln n`) decreases, and the augmented fit is identifiable (full-rank
//!    Jacobian; a candidate trading off against the model cannot be named). Repeat until no
//!    candidate passes.
//! 4. With a force trace ([`ForceTrace`]), `flute_runout` is also tested on the flute-to-flute
//!    force asymmetry ([`force_channel`]).
//!
//! # Nominal model: no free parameters by default
//! The nominal model (force model, stiffness, effects listed in the session file) is taken as
//! identified beforehand (`millcomp identify …`), as 002 took the machine's tool-length reference as
//! given. A free constant depth offset is *not* part of it by default: a constant offset is exactly
//! what `probe_tilt_offset` (and the ±3 µm axial runout of the reference tool, 002 Tab. 5) predicts,
//! so a free offset would make that effect untestable; a free stiffness scale would likewise absorb
//! `machine_compliance`. [`DiagnoseOptions::free_offset`] adds the offset for data whose zero is not
//! trusted; `probe_tilt_offset` is then skipped with a note.
//!
//! # Why the F-test is honest enough here
//! Time constants and length scales are not identified when their amplitude is zero (Davies'
//! problem), so the F reference with q = the candidate's free-parameter count is approximate; the
//! false-alarm rate over clean seeded sessions is measured in `tests/sweeps.rs` (report).
//!
//! # Examples
//! ```
//! use millcomp_diagnose::{DiagnoseOptions, Measured, diagnose};
//! // the committed `probe_tilt_offset` synthetic session, regenerated in memory
//! let case = millcomp_synthetic::cases()
//!     .into_iter()
//!     .find(|c| c.name == "probe_tilt_offset")
//!     .unwrap();
//! let data = millcomp_synthetic::generate(&case).unwrap();
//! let measured = Measured::new("probe_tilt_offset.csv", data.points);
//! let rep = diagnose(&data.session, &measured, &DiagnoseOptions::default()).unwrap();
//! assert_eq!(rep.n_points, 294);
//! assert_eq!(rep.named, vec!["probe_tilt_offset".to_string()]);
//! // the hidden tilt is 0.107° (002 §7.3); its 95 % interval covers it
//! let ci = rep.steps[0].ci95["alpha_deg"];
//! assert!(ci[0] < 0.107 && 0.107 < ci[1]);
//! assert!(rep.final_rms_um < 0.5 * rep.initial_rms_um);
//! ```
#![warn(missing_docs)]

pub mod candidates;
pub mod error;
mod fit;
pub mod force_channel;
pub mod measured;
pub mod nested;
pub mod nominal;
pub mod record;
pub mod report;
mod selection;
pub mod structure;
pub mod thresholds;

use millcomp_sim::session::Session;

pub use candidates::{CandidateSpec, FreeParam, Registry};
pub use error::{DiagnoseError, Result};
pub use force_channel::ForceChannelReport;
pub use measured::{ForceTrace, Measured};
pub use nested::Decision;
pub use nominal::SessionModel;
pub use report::{DiagnoseReport, Round, Series, Skipped, Step, StructureReport};
pub use selection::{DiagnoseOptions, Diagnoser};
pub use structure::StructureItem;

/// Diagnoses `measured` against the nominal model of `session` (crate documentation): the
/// effects named, the RMS residual before and after, every round's tests.
///
/// Prepare a [`Diagnoser`] instead to diagnose many measured files of one session (the nominal
/// model is then simulated once).
///
/// # Errors
/// * [`DiagnoseError::InvalidOption`] for `alpha` outside (0, 1);
/// * [`DiagnoseError::UnknownCandidate`] for a name in `opts.candidates` that is not registered;
/// * [`DiagnoseError::Session`] when sim cannot evaluate the session (its plan or effects, or —
///   with a force trace — its force model at the measured conditions);
/// * [`DiagnoseError::InvalidPoints`] when the measured points are not a measurement (a
///   non-finite value, `coolant_on` not 0/1, time going backwards in a groove), and
///   [`DiagnoseError::NonFinite`] for a NaN or infinite force-trace value;
/// * [`DiagnoseError::SessionMismatch`] when the points or the force rows are not this session's
///   plan point by point (row, column and both values named);
/// * [`DiagnoseError::NominalOffset`] when [`DiagnoseOptions::free_offset`] is set and the offset
///   cannot be fitted.
///
/// A candidate that cannot be tested or fitted is not an error: it is listed in
/// [`DiagnoseReport::skipped`] or [`DiagnoseReport::notes`]. ([`DiagnoseError::BadCandidate`]
/// comes only from a custom registry, [`Diagnoser::with_registry`].)
///
/// # Examples
/// ```
/// use millcomp_diagnose::{DiagnoseError, DiagnoseOptions, Measured, diagnose};
/// let case = millcomp_synthetic::cases()
///     .into_iter()
///     .find(|c| c.name == "clean")
///     .unwrap();
/// let data = millcomp_synthetic::generate(&case).unwrap();
/// // nothing is hidden in `clean`: no candidate passes Bonferroni + BIC
/// let mut measured = Measured::new("clean.csv", data.points);
/// let rep = diagnose(&data.session, &measured, &DiagnoseOptions::default()).unwrap();
/// assert_eq!(rep.named, vec!["none".to_string()]);
/// assert_eq!(rep.rounds[0].tested.len(), 7);
/// // a point moved by 0.5 mm is not the session's plan
/// measured.points[17].x_mm += 0.5;
/// let e = diagnose(&data.session, &measured, &DiagnoseOptions::default()).unwrap_err();
/// assert!(matches!(e, DiagnoseError::SessionMismatch { row: Some(17), .. }));
/// ```
pub fn diagnose(
    session: &Session,
    measured: &Measured,
    opts: &DiagnoseOptions,
) -> Result<DiagnoseReport> {
    Diagnoser::new(session, opts)?.run(measured)
}
