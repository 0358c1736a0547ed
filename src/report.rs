//! What a run leaves and reports: its [`Trajectory`], the [`Run`] with its totals, and what each
//! step reports, stage times included.
//!
//! It sits below the error type, which keeps the partial [`Run`] of a failed run.

use crate::constraint::ConstraintId;
use serde::{Deserialize, Serialize};
use sweeping_api::{BackendCounters, SolveStats};

/// Wall-clock seconds spent in each stage of a step (or summed over a run).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct StageTimes {
    /// The prediction `y`.
    pub effects: f64,
    /// Candidate selection, and the drift bound that sizes the step's first cutoff.
    pub broad_phase: f64,
    /// Linearization and row assembly.
    pub assembly: f64,
    /// The QP (building the problem and the backend's solve).
    pub projection: f64,
    /// The moving-constraint check, the KKT check, the culling proof and the true-constraint
    /// check.
    pub check: f64,
}

impl StageTimes {
    /// Sum of all stages.
    pub fn total(&self) -> f64 {
        self.effects + self.broad_phase + self.assembly + self.projection + self.check
    }

    /// Adds another step's times, stage by stage.
    pub fn add(&mut self, o: &StageTimes) {
        self.effects += o.effects;
        self.broad_phase += o.broad_phase;
        self.assembly += o.assembly;
        self.projection += o.projection;
        self.check += o.check;
    }
}

/// What one step did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepReport {
    /// Step index `k` (this step computed `q_{k+1}`).
    pub step: usize,
    /// `t_{k+1}`.
    pub t: f64,
    /// The step length used (`h`, or less for a last shortened step).
    pub h: f64,
    /// Rows assembled in the final solve.
    pub rows: usize,
    /// Rows whose multiplier exceeds the active threshold at the solution.
    pub active: usize,
    /// Solves of this step (1 + re-solves after a failed culling proof + refinements of
    /// concave constraints).
    pub solves: usize,
    /// Refinements of concave constraints: cuts added at the iterates (0 without concave
    /// constraints, or when the first projection already lies in their sets).
    #[serde(default)]
    pub cuts: usize,
    /// Solver iterations, summed over the solves.
    pub iterations: u32,
    /// How the backend reached its answers, summed over the solves.
    #[serde(default)]
    pub counters: BackendCounters,
    /// Seconds per stage.
    pub times: StageTimes,
    /// `maxᵢ max(0, −gᵢ)/|∇gᵢ|` at `(t_{k+1}, q_{k+1})`: how far (a distance) the new
    /// configuration is outside the true `Q(t_{k+1})` (the linearization is an inner
    /// approximation for convex `gᵢ`, so this is of the order of the solver's tolerance).
    pub max_violation: f64,
    /// The constraint achieving `max_violation` (`None` when none is violated); named by
    /// [`Problem::describe`](crate::problem::Problem::describe).
    pub worst_constraint: Option<ConstraintId>,
    /// `maxⱼ |hⱼ(t_{k+1}, q_{k+1})|` over the equality constraints (`0` without any): zero up
    /// to the solver's accuracy for an affine `hⱼ`, of the order of the step squared for a
    /// nonlinear one (measured, never refused).
    #[serde(default)]
    pub max_equality_residual: f64,
    /// `‖q_{k+1} − q_k‖∞`.
    pub max_displacement: f64,
    /// Statistics of the final solve.
    pub solve: SolveStats,
    /// The rows active at the solution (multiplier above the active threshold), with their
    /// multipliers and gradients, when
    /// [`StepperSettings::record_contacts`](crate::stepper::StepperSettings::record_contacts) asks for
    /// them; empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contacts: Vec<Contact>,
}

/// One active row of a step's projection. The scheme's step is
/// `q_{k+1} = q_k + h f + Σᵢ λᵢ ∇gᵢ` (the projection's stationarity), so the row moves the
/// configuration by `λᵢ ∇gᵢ` in the step: an impulse, and `λᵢ/h · ∇gᵢ` is its contribution to
/// the velocity `(q_{k+1} − q_k)/h`, the force of the constraint in a first-order model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// The constraint (named by [`Problem::describe`](crate::problem::Problem::describe)).
    pub constraint: ConstraintId,
    /// Its multiplier `λᵢ ≥ 0`, in units of `q` per unit of `∇gᵢ`.
    pub multiplier: f64,
    /// `∇gᵢ(t_{k+1}, q_k)`, the row of the step's QP, as `(coordinate, value)`.
    pub gradient: Vec<(usize, f64)>,
}

impl Contact {
    /// `λᵢ/h` times the length of the part of `∇gᵢ` on `coordinates` (a person's two, say):
    /// the magnitude of the force the constraint puts on them over a step of length `h`.
    pub fn force_on(&self, coordinates: std::ops::Range<usize>, h: f64) -> f64 {
        let squared: f64 = self
            .gradient
            .iter()
            .filter(|(c, _)| coordinates.contains(c))
            .map(|(_, v)| v * v)
            .sum();
        self.multiplier / h * squared.sqrt()
    }
}

/// Totals and extremes over a run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunStats {
    /// Steps completed.
    pub steps: usize,
    /// Time per stage, summed.
    pub times: StageTimes,
    /// Solver iterations, summed.
    pub iterations: u64,
    /// How the backend reached its answers, summed.
    #[serde(default)]
    pub counters: BackendCounters,
    /// Solves, summed (more than `steps` when culling proofs failed).
    pub solves: u64,
    /// Rows assembled, summed over steps.
    pub rows: u64,
    /// Largest number of rows in one step.
    pub max_rows: usize,
    /// Largest number of active rows in one step.
    pub max_active: usize,
    /// Largest violation of the true constraints after any step.
    pub max_violation: f64,
    /// The constraint of that violation (named by [`Problem::describe`](crate::problem::Problem::describe)).
    pub worst_constraint: Option<ConstraintId>,
    /// The time of that violation.
    pub worst_time: f64,
    /// Largest `|hⱼ|` of the equality constraints after any step (NaN when one was not a
    /// number).
    #[serde(default)]
    pub max_equality_residual: f64,
}

impl RunStats {
    /// Adds one step: sums its times and counters, keeps the extremes.
    pub fn absorb(&mut self, r: &StepReport) {
        self.steps += 1;
        self.times.add(&r.times);
        self.iterations += u64::from(r.iterations);
        self.counters.add(&r.counters);
        self.solves += r.solves as u64;
        self.rows += r.rows as u64;
        self.max_rows = self.max_rows.max(r.rows);
        self.max_active = self.max_active.max(r.active);
        self.max_equality_residual =
            sweeping_api::max_or_nan(self.max_equality_residual, r.max_equality_residual);
        if r.max_violation > self.max_violation {
            self.max_violation = r.max_violation;
            self.worst_constraint = r.worst_constraint;
            self.worst_time = r.t;
        }
    }
}

/// Configurations at recorded times.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Recorded times.
    pub times: Vec<f64>,
    /// The configuration at each recorded time.
    pub states: Vec<Vec<f64>>,
}

impl Trajectory {
    /// The recorded state at time `t` (within `1e-9 · max(1, |t|)`), if any.
    pub fn at(&self, t: f64) -> Option<&[f64]> {
        let tol = 1e-9 * t.abs().max(1.0);
        self.times
            .iter()
            .position(|s| (s - t).abs() <= tol)
            .map(|i| self.states[i].as_slice())
    }
}

/// The result of a run: what was computed, and the statistics.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Run {
    /// Recorded configurations (always including the start and the last computed one).
    pub trajectory: Trajectory,
    /// Totals.
    pub stats: RunStats,
    /// The last configuration computed.
    pub q_final: Vec<f64>,
    /// The time of `q_final`.
    pub t_final: f64,
}
