//! The library's error type: what went wrong, and where (step, time, constraint, agent).

use crate::stepper::display_number;
use sweeping_api::ProjectionError;

/// A violated constraint, as reported in [`SweepError::InfeasibleStart`].
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// The family and member, e.g. "disk pairs #… (people 3 and 17)".
    pub constraint: String,
    /// The value `gᵢ(t, q) < 0`.
    pub value: f64,
}

/// Why a run (or its set-up) failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SweepError {
    /// Malformed problem or settings (dimensions, non-positive step, NaN in `q₀`…).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// `q₀ ∉ Q(0)`: the constraints listed are violated.
    #[error("the initial configuration is not feasible at t = {}: {} constraint(s) violated, worst {}", display_number(*t), violations.len(), violations.first().map(|v| format!("{} = {:.3e}", v.constraint, v.value)).unwrap_or_default())]
    InfeasibleStart {
        /// Initial time.
        t: f64,
        /// The violated constraints, worst first (at most 20).
        violations: Vec<Violation>,
    },
    /// A non-finite number appeared (in `f`, in a constraint's value or gradient).
    #[error("step {step}, t = {}: {what} is not finite", display_number(*t))]
    NonFinite {
        /// Step index `k` (the step computing `q_{k+1}`).
        step: usize,
        /// Time.
        t: f64,
        /// What was not finite.
        what: String,
    },
    /// A constraint's gradient vanished, so its linearization is meaningless (A1 fails).
    #[error("step {step}, t = {}: constraint {constraint} has a vanishing gradient (|∇g| = {norm:.3e}); assumption A1 fails", display_number(*t))]
    DegenerateConstraint {
        /// Step index.
        step: usize,
        /// Time.
        t: f64,
        /// Which constraint.
        constraint: String,
        /// `|∇g|`.
        norm: f64,
    },
    /// The projection backend failed.
    #[error("step {step}, t = {}: projection failed ({rows} rows): {source}", display_number(*t))]
    Projection {
        /// Step index.
        step: usize,
        /// Time.
        t: f64,
        /// Rows in the QP.
        rows: usize,
        /// The backend's error.
        #[source]
        source: ProjectionError,
    },
    /// A run-time assumption check failed under the `error` policy.
    #[error("step {step}, t = {}: assumption {assumption} violated by {constraint}: {detail}", display_number(*t))]
    AssumptionViolated {
        /// Step index.
        step: usize,
        /// Time.
        t: f64,
        /// "A1", "A2", …
        assumption: String,
        /// Which constraint (and people, for crowds).
        constraint: String,
        /// The bound and the value seen.
        detail: String,
    },
    /// An observer failed (for instance, writing a file).
    #[error("step {step}, t = {}: observer {observer} failed: {message}", display_number(*t))]
    Observer {
        /// Step index.
        step: usize,
        /// Time.
        t: f64,
        /// Which observer.
        observer: String,
        /// What it reported.
        message: String,
    },
}
