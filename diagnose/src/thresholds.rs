//! Thresholds of the workflow, each argued.

/// A candidate is fitted only if at least this many residual degrees of freedom remain
/// (`n − p₁ ≥ 5`). Below it the F reference is heavy-tailed (F(1, 4) has its 99 % point at
/// 21.2) and s² has a relative standard error √(2/dof) > 63 %: a test would have almost no
/// power and the intervals would be meaningless, so the candidate is skipped with a note.
pub const MIN_RESIDUAL_DOF: usize = 5;
/// Candidate Jacobian columns with max |∂r/∂θ| at or below this are "no sensitivity": sim's
/// effects return exact zeros where they are inactive (no coolant event, speeds below the
/// growth onset, X outside the slideway span), so any genuine sensitivity is many orders above.
pub const ZERO_SENSITIVITY: f64 = 1e-12;
/// Positions, engaged lengths and feed must match the session to 1 µm (mm columns): far below
/// the 0.1–1 mm spacing of measured points, above the rounding of any CSV writer.
pub const MATCH_ABS_MM: f64 = 1e-3;
/// Times must match to 10 ms (a point is cut in well under a second at these feeds;
/// rounding of t_s to 2 decimals still matches).
pub const MATCH_ABS_S: f64 = 1e-2;
/// Programmed depth and upfeed must match to 1 nm (µm columns; the profilometer resolves 1 nm,
/// 002 §7.2).
pub const MATCH_ABS_UM: f64 = 1e-3;
/// Tilt must match to 0.001°.
pub const MATCH_ABS_DEG: f64 = 1e-3;
/// A note warns that the final residual is still structured when a binned-means ANOVA p-value
/// (`structure`) is below 1e-4: with ~8 variables examined, white residuals trigger it with
/// probability < 1e-3, while a mis-specified form (e.g. a skewed bow fitted by a parabola)
/// leaves p-values many orders smaller.
pub const STRUCTURE_WARN_P: f64 = 1e-4;
/// Relative part of every match tolerance (round-off of printed values).
pub const MATCH_REL: f64 = 1e-6;
/// A family whose reference column the nuisance columns explain to this share (cos² ≥ 0.99,
/// i.e. at most 10 % of its amplitude is distinguishable from a nominal-model change) is aliased
/// with the nuisance: the data alone cannot tell them apart (`aliasing`).
pub const ALIAS_SHARE: f64 = 0.99;
/// Two families whose estimates would correlate by |r| ≥ 0.95 (each one's standard error
/// inflated ≥ 3.2× by the other) are aliased by the plan (`aliasing`).
pub const ALIAS_CORR: f64 = 0.95;
/// At most this many effects are added: beyond it the model describes noise (the study's
/// sessions hide at most two).
pub const MAX_EFFECTS: usize = 4;
/// A residual correlation with a session variable is reported as unexplained below this p-value
/// (the GLS test with strata, Bonferroni over the ten variables at α = 0.1: p < 0.01).
pub const UNEXPLAINED_P: f64 = 0.01;
/// A nuisance parameter is "determined by the data" when its posterior SD is below this fraction
/// of its prior SD (the data carry at least 3× the prior's information).
pub const DATA_DETERMINED: f64 = 0.5;
/// A family whose 002-size effect differs from the best nominal-model change by less than 3
/// noise SDs (whitened norm of its part beyond the nuisance) cannot be told from the nominal
/// model's uncertainty by this plan (`aliasing`): a 3σ difference is the least a test at
/// α/15 ≈ 7e-4 could see with even odds.
pub const MIN_UNIQUE_SD: f64 = 3.0;
