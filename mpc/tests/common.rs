//! Tolerances shared by the integration tests of millcomp-mpc (the controller core), each argued.

/// MPC first move vs. the Riccati (dynamic-programming) LQ solution. Both are exact solutions of the same
/// unconstrained problem; the difference is Clarabel's interior-point accuracy (gap/feasibility tolerance
/// 1e-10 in that test) amplified by the conditioning of the condensed Hessian (~1e4 for the spindle), so
/// 1e-5 relative to the size of the move is a safe, still-sharp bound (a wrong sign or index would be O(1)).
pub const LQ_FIRST_MOVE_REL: f64 = 1e-5;

/// Constraint satisfaction of emitted commands: they are clamped explicitly, so only round-off remains.
pub const LIMIT_ABS: f64 = 1e-9;

/// Offset-free tracking: the integrating disturbance removes the steady-state error exactly; after the
/// transient has decayed (hundreds of closed-loop time constants) what remains is ~1e-9 of the step.
pub const OFFSET_FREE_ABS: f64 = 1e-6;

/// Soft bound after the slack is no longer needed: interior-point solutions sit at most ~tol_gap inside
/// or outside an active bound, so 1e-6 in output units.
pub const SOFT_BOUND_ABS: f64 = 1e-6;

/// First moves of Clarabel vs CasADi (qpOASES / DAQP) on the identical QP: issue 6 asks for agreement to
/// 1e-6 of the input range; Clarabel runs at gap/feasibility tolerance 1e-10 and the active-set peers are
/// exact to round-off, so 1e-6 holds with two orders of margin (bench: ≤ 2e-8).
pub const FIRST_MOVE_REL_RANGE: f64 = 1e-6;
