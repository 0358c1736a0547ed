//! The library's error type: what went wrong, and where (step, time, constraint, agent).

use crate::numbers::display_number;
use crate::report::Run;
use sweeping_api::ProjectionError;

/// Most constraints [`SweepError::EmptySet`] names; the rest are counted.
pub const EMPTY_SET_NAMED: usize = 8;

/// What is wrong with a support, for [`SweepError::InvalidSupport`].
fn support_fault(support: &[usize], dim: usize) -> String {
    if let Some(c) = support.iter().find(|c| **c >= dim) {
        return format!("coordinate {c} is beyond q's dimension {dim}");
    }
    let repeated = support
        .iter()
        .enumerate()
        .find(|(i, c)| support[..*i].contains(c))
        .map_or(0, |(_, c)| *c);
    format!("coordinate {repeated} is read twice (a support lists distinct coordinates)")
}

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
    /// A constraint's support reads a coordinate twice or one beyond `q`'s dimension: refused
    /// before the first step, where the backends would otherwise meet an invalid matrix.
    #[error("constraint {constraint} has support {support:?}: {}", support_fault(support, *dim))]
    InvalidSupport {
        /// The family and member.
        constraint: String,
        /// The coordinates it reads.
        support: Vec<usize>,
        /// The dimension of `q`.
        dim: usize,
    },
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
    /// The projection's set is empty, and the backend named the rows that make it so (a
    /// Farkas certificate): no position satisfies their linearizations together after the
    /// step — a moving obstacle or wall squeezing people against each other or a wall, say.
    #[error("step {step}, t = {}: no position satisfies these constraints together after the step: {}{}; {source}", display_number(*t), constraints.join("; "), if *more > 0 { format!("; and {more} more") } else { String::new() })]
    EmptySet {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// The constraints of the certificate (people, walls and obstacles, for crowds), at
        /// most [`EMPTY_SET_NAMED`] of them.
        constraints: Vec<String>,
        /// How many more the certificate holds.
        more: usize,
        /// The backend's error.
        #[source]
        source: Box<ProjectionError>,
    },
    /// The backend stopped short of its tolerances on a step's projection (OSQP, a
    /// first-order method, can stall on a jam's dependent contacts): the error names the
    /// constraints the prediction violates most, where the step got stuck.
    #[error("step {step}, t = {}: {source}, on the projection of {rows} rows; the prediction violates most: {}; a backend that stops short on people pressed together (OSQP) can be replaced by the native backend or Clarabel, which solve such steps exactly", display_number(*t), constraints.join("; "))]
    ProjectionStalled {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// Rows in the QP.
        rows: usize,
        /// The constraints most violated at the prediction, at most [`EMPTY_SET_NAMED`].
        constraints: Vec<String>,
        /// The backend's error.
        #[source]
        source: Box<ProjectionError>,
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
    /// After a step, a true constraint `gᵢ(t_{k+1}, q_{k+1}) ≥ 0` is violated by more than
    /// [`StepperSettings::violation_tolerance`](crate::stepper::StepperSettings): the
    /// configuration is physically wrong (people overlap, someone is inside a wall), so the run
    /// stops instead of continuing from it.
    #[error("step {step}, t = {t}: constraint {constraint} is violated by a distance of {violation:.3e} after the step, beyond the tolerance {tolerance:.1e}{}", why.as_deref().map(|w| format!("; {w}")).unwrap_or_default())]
    ViolationTooLarge {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// Which constraint (and people, for crowds).
        constraint: String,
        /// How far the configuration is outside the constraint, in units of length:
        /// `max(0, −gᵢ)/|∇gᵢ|` at `(t_{k+1}, q_{k+1})` (infinite where `∇gᵢ` vanishes).
        violation: f64,
        /// The tolerance it exceeds.
        tolerance: f64,
        /// Why the scheme could end there, when known: `D²gᵢ` has a negative eigenvalue at the
        /// point, so `gᵢ` is not convex and the linearization is not an inner approximation.
        why: Option<String>,
    },
    /// The backend's answer does not satisfy the KKT conditions of the projection within
    /// [`StepperSettings::kkt_tolerance`](crate::stepper::StepperSettings) (relative): it is
    /// not the projection, whatever status the solver reported.
    #[error("step {step}, t = {t}: the answer of backend {backend} fails the KKT check ({residuals}; tolerance {tolerance:.1e} relative to terms up to {scale:.3e}); {hint}")]
    KktCheckFailed {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// The backend that answered.
        backend: String,
        /// The four residuals, printed.
        residuals: String,
        /// The relative tolerance.
        tolerance: f64,
        /// The largest of the term sizes the residuals are compared with.
        scale: f64,
        /// What to do about it: with a prediction far larger than the distances to the
        /// constraints, a shorter step or lower speeds; otherwise, a backend set loose on
        /// purpose needs the tolerance raised to match.
        hint: String,
    },
    /// A moving constraint moves farther in one step than the linearization can follow
    /// (the rule of the README, from the paper's `h < c/K_L` with `K_L ≤ β/α` by A1–A2): the
    /// moving boundary could pass over the point, which would then be kept on the wrong side.
    #[error("step {step}, t = {t}: the step h = {h} is too long for the moving constraint {constraint}: {detail}; h ≤ {suggested_h:.3e} would do")]
    StepTooLong {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// Which constraint.
        constraint: String,
        /// The step length used.
        h: f64,
        /// A step that passes the rule at this configuration (half the largest allowed).
        suggested_h: f64,
        /// The distance and the motion compared.
        detail: String,
    },
    /// A moving set's path turns inside the step (a waypoint strictly between `t_k` and
    /// `t_{k+1}`) where the set overlaps the point at both ends of the step: the scheme sees the
    /// set at the step's ends only, so what the set did in between is lost, and no pace along
    /// the straight line from `q_k` to `q_{k+1}` keeps clear of it.
    #[error("step {step}, t = {t}: the moving constraint {constraint} turns at its waypoint t = {waypoint}, inside the step from {t_k} (h = {h}), where it overlaps the person by {overlap:.3e} at both ends of the step (tolerance {tolerance:.1e}); a step sees the motion at its ends only: choose h so that the path's waypoints fall on step ends (h = {suggested_h} puts this one on one), or a smaller h")]
    PathTurnsWithinStep {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// Time `t_k`.
        t_k: f64,
        /// Which constraint (person and obstacle).
        constraint: String,
        /// The waypoint's time.
        waypoint: f64,
        /// `min(−gᵢ(waypoint, q_k), −gᵢ(waypoint, q_{k+1}))`.
        overlap: f64,
        /// The violation tolerance it exceeds.
        tolerance: f64,
        /// The step length used.
        h: f64,
        /// A step at most `h` that puts this waypoint on a step end.
        suggested_h: f64,
    },
    /// The projection failed on a prediction `y` so far from `q_k` that the QP could not be
    /// solved, also after rescaling. The set is not empty (`q_k` satisfies every row), so any
    /// "infeasible" from the backend is numerical: a shorter step or lower speeds would do.
    #[error("step {step}, t = {t}: the prediction is {distance:.3e} away from the current configuration, too far for the projection to be resolved ({first}; rescaled: {second}); the set is not empty (the current configuration satisfies every row): use a shorter step or lower speeds")]
    PredictionTooFar {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// `‖y − q_k‖∞`.
        distance: f64,
        /// The backend's error on the original QP.
        first: String,
        /// Its error on the rescaled QP.
        second: String,
    },
    /// The culling proof of a step (module docs of [`crate::stepper`]) still failed after
    /// [`StepperSettings::max_cull_retries`](crate::stepper::StepperSettings) re-solves: a
    /// family's drift bound grows faster than its cutoff.
    #[error("step {step}, t = {}: the culling proof still failed after {solves} solves; a family's drift bound grows faster than its cutoff", display_number(*t))]
    CullingFailed {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// Solves made.
        solves: usize,
    },
    /// The projection onto a convex set declared by a concave constraint
    /// ([`Curvature::Concave`](crate::constraint::Curvature::Concave)) was not certified
    /// after [`StepperSettings::max_concave_iterations`](crate::stepper::StepperSettings)
    /// refinements of its linearization: the last iterate is still outside the set, or its
    /// KKT conditions with the constraint's gradient at the iterate still fail.
    #[error("step {step}, t = {}: the projection onto {constraint} (a convex set, g declared concave) is not certified after {iterations} refinements: the iterate is {violation:.3e} outside it, stationarity residual {residual:.3e} (tolerances {tolerance:.1e} and {stationarity_tolerance:.1e}); raise max_concave_iterations or concave_tolerance, or shorten the step", display_number(*t))]
    ConcaveNotCertified {
        /// Step index.
        step: usize,
        /// Time `t_{k+1}`.
        t: f64,
        /// The constraint furthest from certification.
        constraint: String,
        /// Refinements made (each one more projection).
        iterations: usize,
        /// Its distance outside `{g ≥ 0}` at the last iterate: `max(0, −g)/|∇g|`.
        violation: f64,
        /// Its part of the stationarity residual, `‖Σ λ_r a_r − μ ∇g(x)‖∞` over its rows.
        residual: f64,
        /// [`StepperSettings::concave_tolerance`](crate::stepper::StepperSettings).
        tolerance: f64,
        /// The absolute stationarity tolerance it was held to:
        /// `kkt_tolerance · max(1, ‖x − y‖∞)`.
        stationarity_tolerance: f64,
    },
    /// The user asked the run to stop (Ctrl-C, SIGTERM or SIGHUP in `sweep run`): not a failure of the run,
    /// which stops after the step it was taking.
    #[error("step {step}, t = {}: interrupted (Ctrl-C, SIGTERM or SIGHUP)", display_number(*t))]
    Interrupted {
        /// The last step taken.
        step: usize,
        /// Its time.
        t: f64,
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
    /// A run failed, with what it computed before: a
    /// [`RunFailure`](crate::stepper::RunFailure) converted by `?`, so that the set-up's error
    /// and the run's share one type.
    #[error("{error} (after {} completed steps, t = {})", partial.stats.steps, display_number(partial.t_final))]
    RunFailed {
        /// What went wrong.
        error: Box<SweepError>,
        /// What was computed before.
        partial: Box<Run>,
    },
}

impl SweepError {
    /// What a failed run computed before it failed ([`SweepError::RunFailed`]); `None` for an
    /// error that is not a run's.
    pub fn partial_run(&self) -> Option<&Run> {
        match self {
            Self::RunFailed { partial, .. } => Some(partial),
            _ => None,
        }
    }
}

/// Why an [`Observer`](crate::stepper::Observer) stopped a run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ObserverError {
    /// The observer could not do its work (a file it could not write…); the run stops with
    /// [`SweepError::Observer`], which adds the observer's name, the step and the time.
    #[error("{0}")]
    Failed(String),
    /// The observer stops the run with an error of the library, returned as is (the run-time
    /// assumption monitor stops with [`SweepError::AssumptionViolated`]).
    #[error(transparent)]
    Stop(Box<SweepError>),
}

impl From<String> for ObserverError {
    fn from(message: String) -> Self {
        Self::Failed(message)
    }
}

impl From<&str> for ObserverError {
    fn from(message: &str) -> Self {
        Self::Failed(message.to_string())
    }
}

impl From<SweepError> for ObserverError {
    fn from(e: SweepError) -> Self {
        Self::Stop(Box::new(e))
    }
}

impl ObserverError {
    /// The error the run stops with: a [`Stop`](Self::Stop) as is, a
    /// [`Failed`](Self::Failed) as [`SweepError::Observer`] naming `observer`, `step` and `t`.
    pub fn into_sweep_error(self, observer: &str, step: usize, t: f64) -> SweepError {
        match self {
            Self::Stop(e) => *e,
            Self::Failed(message) => SweepError::Observer {
                step,
                t,
                observer: observer.to_string(),
                message,
            },
        }
    }
}
