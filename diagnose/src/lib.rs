//! # millcomp-diagnose
//!
//! The discrepancy workflow behind `millcomp diagnose`: find where simulation and measurement
//! disagree, name the missing effect, add it, show the gap shrink (issue 7; the manual loop of
//! `002_…txt` §7, automated) — on data as a user has them (issue 15): a nominal model that is a
//! few percent off, effects whose shape is not any candidate's, scatter between grooves. It is
//! built on `millcomp-sim` (the session's nominal model) and `millcomp-identify` (the
//! least-squares engine); it returns report data ([`DiagnoseReport`], serialisable) — text and
//! plots are the CLI's.
//!
//! # Algorithm
//! 1. **Nominal model.** Play the session's plan out once with sim ([`SessionModel`]); check that
//!    the measured points are that plan point by point ([`Measured::check_against`]).
//! 2. **Recalibrate before blaming** ([`nuisance`]). The nominal model's uncertain parameters —
//!    force scale, axial and radial stiffness, wearland, touch-off — are refitted first, as
//!    nuisance parameters with Gaussian priors (the session's `[uncertainty]` table,
//!    `sim/SESSION.md`), by GLS with the groove scatter below. Reported with their posterior SD
//!    and whether the data or the prior determine them.
//! 3. **Groove-to-groove scatter** ([`scatter`]): a random offset per groove (a mixed model); its
//!    variance and the measurement noise are estimated from the residual (method of moments, pooled
//!    with the stated scatter) and every fit is GLS in that covariance. Tests split the
//!    information into within-groove, between-groove and prior strata, so an effect constant
//!    within grooves is judged against the grooves' scatter with their few degrees of freedom
//!    ([`nested::StrataTest`]).
//! 4. **Candidates as families** ([`families`]): each effect is its driver and a few flexible
//!    shapes (one or two lags, speed gains with an onset or ∝ rpm², saturating or power-law wear,
//!    a bow, a cubic or a spline in machine X, …). In each round every shape of every remaining
//!    family is searched over its grid of nonlinear parameters (linearised, in the GLS metric);
//!    the family's best shape by GLS-BIC is refined by bounded nonlinear least squares jointly with
//!    the nuisance and the effects already added, and tested (`nested::strata_test`) against the
//!    round's family-wise threshold: the α quantile of the round's smallest p when the current
//!    model is right, simulated by repeating the round's linearised search on draws of the null
//!    ([`familywise`]; [`Multiplicity::Bonferroni`]: α over all shapes tried in the round).
//! 5. **Stop when the gain is not real.** A family is added — the most significant first — only if
//!    it is significant, it is still significant when every effect already named is given a
//!    flexible shape in its own driver ([`Family::driver_basis`]: lags of the coolant state or of
//!    the speed, splines in engaged length, machine X or force — otherwise what it fits is the
//!    named effect's misfit, not a second effect), it improves the prediction of held-out grooves
//!    (leave-one-groove-out, [`logo`]) and its amplitude exceeds the measurement's resolution.
//!    Otherwise the selection stops; what remains is reported with what it correlates with
//!    ([`DiagnoseReport::unexplained`]). The final intervals of nonlinear parameters are
//!    profile-likelihood intervals ([`DiagnoseReport::final_ci95`]).
//! 6. **What the plan cannot separate** ([`aliasing`]): candidates aliased with the nuisance (a
//!    constant offset and the touch-off, a tilt-independent compliance and the stiffnesses) are
//!    named only beyond the nuisance's prior and are otherwise reported as "within the nominal
//!    model's uncertainty" ([`report::WithinNominal`], with whether the data point to it);
//!    aliased pairs get a proposed session change. Where the data, not only the plan, fail to
//!    tell a named effect from another family — the named effect is not significant beyond a
//!    flexible shape of the other in its own driver, at the level it was named at (a dead-band
//!    machine compliance and a flute runout growing with depth; a coolant step and a spindle lag
//!    that start together) — the other is listed as its look-alike
//!    ([`DiagnoseReport::look_alikes`]) with the standard session change that separates them
//!    most. A session that states a tighter prior (a stiffness measured by a load–deflection
//!    test) separates what the default priors cannot. A plan that separates no candidate from
//!    the nuisance names none (`verdict = plan_cannot_separate`).
//! 7. With a force trace ([`ForceTrace`]), `flute_runout` is also tested on the flute-to-flute
//!    force asymmetry ([`force_channel`]).
//!
//! How well this works on data drawn from a fixed distribution of nominal errors, non-candidate
//! shapes and scatter is measured by `examples/real_data_study.rs` (results in `docs/studies/diagnose.md`).
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
//! // the 4.67 µm offset (002 §7.4) lies 4.7 SDs beyond the touch-off's 1 µm prior: named
//! assert_eq!(rep.named, vec!["probe_tilt_offset".to_string()]);
//! assert!(rep.steps[0].beyond_prior);
//! let ci = rep.final_ci95["probe_tilt_offset"]["offset_um"];
//! assert!(ci[0] < 4.67 && 4.67 < ci[1]);
//! ```
#![warn(missing_docs)]

pub mod aliasing;
pub mod error;
pub mod families;
pub mod familywise;
pub mod fitted;
pub mod force_channel;
pub mod forces;
pub mod logo;
pub mod measured;
mod model;
pub mod nested;
pub mod nominal;
pub mod nuisance;
pub mod record;
pub mod report;
pub mod scatter;
mod selection;
pub mod structure;
pub mod thresholds;
pub mod unlisted;

use millcomp_sim::session::Session;

pub use aliasing::PlanAnalysis;
pub use error::{DiagnoseError, Result};
pub use families::{Family, Shape};
pub use fitted::FittedEffect;
pub use force_channel::ForceChannelReport;
pub use measured::{ForceTrace, Measured};
pub use nested::{Decision, StrataTest};
pub use nominal::SessionModel;
pub use report::{DiagnoseReport, Round, Series, Skipped, Step, StructureReport};
pub use selection::{DiagnoseOptions, Diagnoser, Multiplicity, NULL_DRAWS, WITHIN_NOMINAL};
pub use structure::StructureItem;
pub use unlisted::UnlistedTerm;

/// Diagnoses `measured` against the nominal model of `session` (crate documentation): the
/// nuisance step, the effects named, the RMS residual before and after, every round's tests.
///
/// Prepare a [`Diagnoser`] instead to diagnose many measured files of one session (the nominal
/// model is then simulated and the plan analysed once).
///
/// # Errors
/// * [`DiagnoseError::InvalidOption`] for `alpha` outside (0, 1);
/// * [`DiagnoseError::UnknownCandidate`] for a name in `opts.candidates` that is no family;
/// * [`DiagnoseError::Session`] when sim cannot evaluate the session (its plan or effects, or —
///   with a force trace — its force model at the measured conditions);
/// * [`DiagnoseError::InvalidPoints`] when the measured points are not a measurement (a
///   non-finite value, `coolant_on` not 0/1, time going backwards in a groove), and
///   [`DiagnoseError::NonFinite`] for a NaN or infinite force-trace value;
/// * [`DiagnoseError::SessionMismatch`] when the points or the force rows are not this session's
///   plan point by point (row, column and both values named);
/// * [`DiagnoseError::Fit`] when the nominal model cannot be recalibrated at all.
///
/// A candidate that cannot be tested or fitted is not an error: it is listed in
/// [`DiagnoseReport::skipped`] or [`DiagnoseReport::notes`].
///
/// # Examples
/// ```
/// use millcomp_diagnose::{DiagnoseError, DiagnoseOptions, Measured, diagnose};
/// let case = millcomp_synthetic::cases()
///     .into_iter()
///     .find(|c| c.name == "clean")
///     .unwrap();
/// let data = millcomp_synthetic::generate(&case).unwrap();
/// // nothing is hidden in `clean`: no candidate passes
/// let mut measured = Measured::new("clean.csv", data.points);
/// let rep = diagnose(&data.session, &measured, &DiagnoseOptions::default()).unwrap();
/// assert_eq!(rep.named, vec!["none".to_string()]);
/// assert_eq!(rep.verdict, "none");
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
