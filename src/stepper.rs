//! The prediction–correction scheme of Bernicot & Venel (paper, equation `schema`):
//!
//! ```text
//!     q_{k+1} = P_{Q̃(t_{k+1}, q_k)} ( q_k + h f(t_k, q_k) ),
//!     Q̃(t, q) = { x : gᵢ(t, q) + ⟨∇gᵢ(t, q), x − q⟩ ≥ 0  ∀ i }.
//! ```
//!
//! One step is a pipeline of named stages, each timed ([`StageTimes`]):
//!
//! 1. **effects** — the prediction `y = q_k + h f(t_k, q_k)` (or, with
//!    [`Prediction::Averaged`], `y = q_k + ∫_{t_k}^{t_{k+1}} f(s, q_k) ds`, the paper's remark
//!    after Theorem 3.2);
//! 2. **broad phase** — each family proposes the members that may matter (all of them, unless
//!    the family culls far-apart pairs);
//! 3. **assembly** — each candidate is linearized at `(t_{k+1}, q_k)` by autodiff into the row
//!    `∇gᵢ · x ≥ ⟨∇gᵢ, q_k⟩ − gᵢ`, written in the displacement `u = x − q_k` as
//!    `∇gᵢ · u ≥ −gᵢ`;
//! 4. **projection** — one QP, solved by any [`Projector`]: `u` is the projection of
//!    `y − q_k` (`h f`, computed as such), so the backend sees the step's own numbers wherever
//!    the scene lies, and `q_{k+1} = q_k + u`;
//! 5. **check** — the proof that culling lost nothing (below), then the largest violation of
//!    the *true* constraints `gᵢ(t_{k+1}, q_{k+1}) ≥ 0`.
//!
//! # Why culling loses nothing
//! Let `C` be the rows assembled and `x` the projection of `y` onto `Q̃_C ⊇ Q̃`. If `x` also
//! satisfies every omitted row, then `x ∈ Q̃` and, being the closest point of the larger set
//! `Q̃_C`, it is the closest point of `Q̃`: the projection onto all rows. A family omits only
//! members with `gᵢ(t_{k+1}, q_k) > cutoff` (its candidate contract), and bounds
//! `|⟨∇gᵢ, x − q_k⟩| ≤ δ` for all of them at once
//! ([`ConstraintFamily::linearization_drift_bound`](crate::constraint::ConstraintFamily::linearization_drift_bound)); an omitted row then has
//! `gᵢ + ⟨∇gᵢ, x − q_k⟩ > cutoff − δ`, which is `≥ 0` when `δ ≤ cutoff`. When the bound
//! fails, the cutoff grows to `2δ` and the step is assembled and solved again, so the result
//! is always the projection onto every row.

use crate::constraint::{ConstraintId, LinearizedRow};
pub use crate::error::ObserverError;
use crate::error::SweepError;
use crate::problem::{LinearizeScratch, Problem};
use serde::{Deserialize, Serialize};
use std::time::Instant;
use sweeping_api::{
    BackendCounters, Projection, ProjectionProblem, Projector, RowKey, SolveStats, SparseRows,
};

/// A time or coordinate for messages: rounded to 1e-9 so that `t = k·h` prints as `3.78`, not
/// `3.7800000000000002`.
pub fn display_number(v: f64) -> String {
    if v.is_finite() {
        format!("{}", (v * 1e9).round() / 1e9)
    } else {
        format!("{v}")
    }
}

/// The number of steps of length `h` that cover `span = T − t₀`: `⌈span/h⌉`, the last one
/// shortened to land on `T`. A ratio within `1e-9` above an integer counts as that integer,
/// so that rounding in `T/h` adds no sliver of a step. Any `span > 0` takes at least one step,
/// however much longer than the horizon `h` is, so a run always reaches `T`; `span ≤ 0`
/// takes none.
pub fn step_count(span: f64, h: f64) -> usize {
    if span > 0.0 {
        ((span / h) - 1e-9).ceil().max(1.0) as usize
    } else {
        0
    }
}

/// How the prediction uses `f`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Prediction {
    /// `y = q_k + h f(t_k, q_k)`: the paper's scheme as stated.
    #[default]
    Explicit,
    /// `y = q_k + ∫_{t_k}^{t_{k+1}} f(s, q_k) ds`, by Gauss–Legendre quadrature with the given
    /// number of points (1 to 5): the averaged `fⁿ` of the paper's remark.
    Averaged {
        /// Quadrature points (1–5).
        points: usize,
    },
}

/// Settings of a run; plain values with documented defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StepperSettings {
    /// Time step `h` (> 0). Default `0.01` (the paper's `h_min`).
    pub h: f64,
    /// Final time `T`. The run makes `n = ⌈(T − t₀)/h⌉` steps, the last one shortened to land on
    /// `T` when `h` does not divide `T − t₀`. Default `1.0`.
    pub t_end: f64,
    /// Explicit or averaged prediction. Default explicit.
    pub prediction: Prediction,
    /// A multiplier above this counts the row as active in reports. Default `1e-9`.
    pub active_threshold: f64,
    /// `q₀ ∈ Q(t₀)` is accepted when every `gᵢ(t₀, q₀) ≥ −feasibility_tolerance`. Default
    /// `1e-9`.
    pub feasibility_tolerance: f64,
    /// Smallest cutoff a culling family is asked for (the cutoff of a step is
    /// `max(min_cutoff, 2 δ(y))`, with `δ` the drift bound of the prediction). Default `0.0`.
    pub min_cutoff: f64,
    /// Most re-solves of a step whose culling proof fails. Default `12`.
    pub max_cull_retries: usize,
    /// Keep the configuration every this many steps in [`Run::trajectory`] (0: keep only the
    /// start and the end). Default `1`.
    pub record_every: usize,
    /// Compute `∂ₜgᵢ` of every assembled row (for the run-time checks of A2). Default `false`.
    pub want_time_derivatives: bool,
    /// The run fails with [`SweepError::ViolationTooLarge`] when, after a step, some true
    /// constraint is violated by more than `violation_tolerance` as a distance,
    /// `max(0, −gᵢ)/|∇gᵢ|` at `(t_{k+1}, q_{k+1})` (in the units of `q`: metres for crowds,
    /// whatever the scale of `gᵢ`). The scheme keeps the configuration inside `Q(t)` up to the
    /// solver's accuracy, so a larger violation means the answer is wrong. Default `1e-6`.
    pub violation_tolerance: f64,
    /// Every backend's answer `(x, λ)` is checked against the KKT conditions of the projection
    /// before it is used; the run fails with [`SweepError::KktCheckFailed`] when a residual
    /// exceeds `kkt_tolerance` times the size of its terms: primal `b − Ax` against
    /// `max(1, ‖b‖∞)`, stationarity `x − y − Aᵀλ` against `max(1, ‖x − y‖∞)`, dual `−λ` against
    /// `max(1, ‖λ‖∞)`, complementarity against the product of the first and the last.
    /// Default `1e-6`.
    pub kkt_tolerance: f64,
    /// A1 near contact: the run fails with [`SweepError::DegenerateConstraint`] when a row
    /// active at a step's solution has `|∇gᵢ(t_{k+1}, q_k)| < gradient_floor` (absolute, in
    /// units of `g` per unit of `q`). A constraint that flattens where it touches (a double
    /// root, `g = (x − 1)²`) otherwise pins the point where `∇g` vanishes, a wrong answer
    /// without an error. `0` disables the check. Default `1e-6`.
    pub gradient_floor: f64,
}

impl Default for StepperSettings {
    fn default() -> Self {
        Self {
            h: 0.01,
            t_end: 1.0,
            prediction: Prediction::Explicit,
            active_threshold: 1e-9,
            feasibility_tolerance: 1e-9,
            min_cutoff: 0.0,
            max_cull_retries: 12,
            record_every: 1,
            want_time_derivatives: false,
            violation_tolerance: 1e-6,
            kkt_tolerance: 1e-6,
            gradient_floor: 1e-6,
        }
    }
}

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
    /// Solves of this step (1 + re-solves after a failed culling proof).
    pub solves: usize,
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
    /// [`Problem::describe`].
    pub worst_constraint: Option<ConstraintId>,
    /// `‖q_{k+1} − q_k‖∞`.
    pub max_displacement: f64,
    /// Statistics of the final solve.
    pub solve: SolveStats,
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
    /// The constraint of that violation (named by [`Problem::describe`]).
    pub worst_constraint: Option<ConstraintId>,
    /// The time of that violation.
    pub worst_time: f64,
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

/// A failed run: the error, and everything computed before it.
#[derive(Debug, Clone)]
pub struct RunFailure {
    /// What went wrong.
    pub error: SweepError,
    /// What was computed before.
    pub partial: Run,
}

impl std::fmt::Display for RunFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} (after {} completed steps, t = {})",
            self.error,
            self.partial.stats.steps,
            display_number(self.partial.t_final)
        )
    }
}

impl std::error::Error for RunFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// Receives every step of a run. Every method defaults to doing nothing, so an observer
/// implements only what it needs; `()` is the observer that does nothing.
///
/// ```
/// use sweeping::stepper::{Observer, ObserverError, StepReport};
/// /// Counts steps whose projection had an active constraint.
/// #[derive(Default)]
/// struct ContactSteps(usize);
/// impl Observer for ContactSteps {
///     fn on_step(&mut self, report: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
///         if report.active > 0 { self.0 += 1; }
///         Ok(())
///     }
/// }
/// ```
pub trait Observer {
    /// A name for errors.
    fn name(&self) -> &str {
        "observer"
    }
    /// Called once before the first step with `(t₀, q₀)`.
    ///
    /// # Errors
    /// An [`ObserverError`]; the run stops with it (see
    /// [`ObserverError::into_sweep_error`]).
    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        let _ = (t, q);
        Ok(())
    }
    /// Called after every step with its report and `q_{k+1}`.
    ///
    /// # Errors
    /// An [`ObserverError`]; the run stops with it.
    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let _ = (report, q);
        Ok(())
    }
    /// Called once at the end, with the error if the run failed (also after a failure, so
    /// writers can flush what they have), or if an observer before this one failed to finish.
    ///
    /// # Errors
    /// An [`ObserverError`]; reported if the run had not already failed.
    fn on_finish(&mut self, error: Option<&SweepError>) -> Result<(), ObserverError> {
        let _ = error;
        Ok(())
    }
}

impl Observer for () {}

/// The per-family cache of the assembly.
struct FamilyState {
    cutoff: f64,
    /// The drift bound `δ` of the previous step's solution: displacements change little from
    /// one step to the next, so `1.5 δ` is a good first cutoff (a crowd pushed by a wall moves
    /// faster than its own prediction says).
    last_drift: f64,
}

/// Runs the scheme on a [`Problem`].
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::api::conformance::ReferenceProjector;
///
/// struct Floor;
/// impl ConstraintKernel<1> for Floor {
///     type Params = ();
///     fn value<D: DualNum<Primitive = f64> + Copy>(&self, _: &(), _t: D, z: [D; 1]) -> D { z[0] }
///     fn is_time_dependent(&self) -> bool { false }
///     fn is_affine(&self) -> bool { true }
/// }
/// // Falling at speed 1 from height 0.5 onto the floor x ≥ 0.
/// let problem = Problem::new(vec![0.5], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = -1.0)
///     .with_family(KernelFamily::single("floor", Floor, [0]));
/// let settings = StepperSettings { h: 0.1, t_end: 1.0, ..Default::default() };
/// let run = Stepper::new(&problem, settings).unwrap()
///     .run(&mut ReferenceProjector::default(), &mut [])
///     .unwrap();
/// assert!(run.q_final[0].abs() < 1e-9);
/// assert_eq!(run.stats.steps, 10);
/// ```
pub struct Stepper<'p> {
    problem: &'p Problem,
    settings: StepperSettings,
    k: usize,
    n_steps: usize,
    t: f64,
    q: Vec<f64>,
    /// The prediction `y`.
    y: Vec<f64>,
    /// Its displacement `y − q_k`, computed as such (`h f`), not as a difference.
    dy: Vec<f64>,
    f: Vec<f64>,
    rows: SparseRows,
    b: Vec<f64>,
    row_origin: Vec<(usize, usize)>,
    /// `|∇gᵢ|` of each assembled row, for the A1 check on the active ones.
    row_norms: Vec<f64>,
    cands: Vec<usize>,
    lin: LinearizedRow,
    scratch: LinearizeScratch,
    families: Vec<FamilyState>,
}

impl<'p> Stepper<'p> {
    /// Validates the problem and settings and checks `q₀ ∈ Q(t₀)`.
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] (dimension, NaN, non-positive `h`, `T < t₀`…) or
    /// [`SweepError::InfeasibleStart`].
    pub fn new(problem: &'p Problem, settings: StepperSettings) -> Result<Self, SweepError> {
        if !(settings.h.is_finite() && settings.h > 0.0) {
            return Err(SweepError::InvalidInput(format!(
                "the time step h = {} must be positive and finite",
                settings.h
            )));
        }
        if !(settings.t_end.is_finite() && settings.t_end >= problem.t0()) {
            return Err(SweepError::InvalidInput(format!(
                "the final time T = {} must be finite and ≥ t₀ = {}",
                settings.t_end,
                problem.t0()
            )));
        }
        if let Prediction::Averaged { points } = settings.prediction {
            if !(1..=5).contains(&points) {
                return Err(SweepError::InvalidInput(format!(
                    "averaged prediction needs 1 to 5 quadrature points, got {points}"
                )));
            }
        }
        if !(settings.feasibility_tolerance >= 0.0 && settings.min_cutoff >= 0.0) {
            return Err(SweepError::InvalidInput(
                "feasibility_tolerance and min_cutoff must be ≥ 0".into(),
            ));
        }
        if !(settings.gradient_floor.is_finite() && settings.gradient_floor >= 0.0) {
            return Err(SweepError::InvalidInput(format!(
                "gradient_floor = {} must be finite and ≥ 0 (0 disables the check)",
                settings.gradient_floor
            )));
        }
        for (name, v) in [
            ("violation_tolerance", settings.violation_tolerance),
            ("kkt_tolerance", settings.kkt_tolerance),
        ] {
            if v.is_nan() || v <= 0.0 {
                return Err(SweepError::InvalidInput(format!(
                    "{name} = {v} must be positive (use f64::INFINITY to disable the check)"
                )));
            }
        }
        // The step count is a usize: a horizon of 1e300 steps would overflow it (and never end).
        let steps = ((settings.t_end - problem.t0()) / settings.h).ceil();
        if steps.is_nan() || steps > 1e12 {
            // In scientific notation when tiny or huge: h = 1e-300 printed 300 zeros.
            let readable = |v: f64| {
                if v == 0.0 || (1e-4..1e7).contains(&v.abs()) {
                    format!("{v}")
                } else {
                    format!("{v:e}")
                }
            };
            return Err(SweepError::InvalidInput(format!(
                "T − t₀ = {} with h = {} would take {steps:.3e} steps (at most 1e12)",
                readable(settings.t_end - problem.t0()),
                readable(settings.h)
            )));
        }
        problem.validate(settings.feasibility_tolerance)?;
        let n_steps = step_count(settings.t_end - problem.t0(), settings.h);
        let dim = problem.dim();
        Ok(Self {
            problem,
            n_steps,
            k: 0,
            t: problem.t0(),
            q: problem.q0().to_vec(),
            y: vec![0.0; dim],
            dy: vec![0.0; dim],
            f: vec![0.0; dim],
            rows: SparseRows::new(dim),
            b: Vec::new(),
            row_origin: Vec::new(),
            row_norms: Vec::new(),
            cands: Vec::new(),
            lin: LinearizedRow::default(),
            scratch: LinearizeScratch::default(),
            families: problem
                .families()
                .iter()
                .map(|_| FamilyState {
                    cutoff: settings.min_cutoff,
                    last_drift: 0.0,
                })
                .collect(),
            settings,
        })
    }

    /// Number of steps the run will make.
    pub fn n_steps(&self) -> usize {
        self.n_steps
    }

    /// Steps done so far.
    pub fn steps_done(&self) -> usize {
        self.k
    }

    /// Current time `t_k`.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Current configuration `q_k`.
    pub fn state(&self) -> &[f64] {
        &self.q
    }

    /// The settings.
    pub fn settings(&self) -> &StepperSettings {
        &self.settings
    }

    fn time_of(&self, k: usize) -> f64 {
        if k >= self.n_steps {
            self.settings.t_end
        } else {
            self.problem.t0() + k as f64 * self.settings.h
        }
    }

    /// The prediction `y = q_k + h f(t_k, q_k)` (or its averaged form) into `self.y`, its
    /// displacement `y − q_k` into `self.dy`.
    fn predict(&mut self, t_k: f64, h: f64) -> Result<(), SweepError> {
        let pert = self.problem.perturbation();
        match self.settings.prediction {
            Prediction::Averaged { points } if pert.is_time_dependent() => {
                let (nodes, weights) = gauss_legendre(points);
                self.dy.iter_mut().for_each(|d| *d = 0.0);
                for (s, w) in nodes.iter().zip(weights) {
                    let ts = t_k + 0.5 * h * (1.0 + s);
                    pert.eval(ts, &self.q, &mut self.f);
                    for (di, fi) in self.dy.iter_mut().zip(&self.f) {
                        *di += 0.5 * h * w * fi;
                    }
                }
            }
            _ => {
                pert.eval(t_k, &self.q, &mut self.f);
                for (di, fi) in self.dy.iter_mut().zip(&self.f) {
                    *di = h * fi;
                }
            }
        }
        for ((yi, qi), di) in self.y.iter_mut().zip(&self.q).zip(&self.dy) {
            *yi = qi + di;
        }
        if let Some(i) = self.y.iter().position(|v| !v.is_finite()) {
            return Err(SweepError::NonFinite {
                step: self.k,
                t: t_k,
                what: format!(
                    "the prediction q + h f(t, q) at coordinate {i} (f = {})",
                    self.f[i]
                ),
            });
        }
        Ok(())
    }

    /// Assembles the rows of `Q̃(t_next, q_k)` for the candidates within each family's cutoff,
    /// in the displacement `u = x − q_k`: `∇gᵢ · u ≥ −gᵢ`.
    fn assemble(&mut self, t_next: f64, times: &mut StageTimes) -> Result<(), SweepError> {
        self.rows.clear();
        self.b.clear();
        self.row_origin.clear();
        self.row_norms.clear();
        let want_dt = self.settings.want_time_derivatives;
        for (fi, fam) in self.problem.families().iter().enumerate() {
            let t0 = Instant::now();
            self.cands.clear();
            fam.candidates(t_next, &self.q, self.families[fi].cutoff, &mut self.cands);
            let t1 = Instant::now();
            times.broad_phase += (t1 - t0).as_secs_f64();
            for &idx in &self.cands {
                fam.linearize(idx, t_next, &self.q, want_dt, &mut self.lin);
                let lin = &self.lin;
                if !lin.value.is_finite() || lin.gradient.iter().any(|v| !v.is_finite()) {
                    return Err(SweepError::NonFinite {
                        step: self.k,
                        t: t_next,
                        what: format!(
                            "constraint {} (value {}, gradient {:?})",
                            fam.describe(idx),
                            lin.value,
                            lin.gradient
                        ),
                    });
                }
                let norm = lin.gradient_norm();
                if norm < 1e-12 {
                    return Err(SweepError::DegenerateConstraint {
                        step: self.k,
                        t: t_next,
                        constraint: fam.describe(idx),
                        norm,
                    });
                }
                // Row of Q̃ in the displacement u = x − q_k: ∇g · u ≥ −g (see `step`).
                self.rows.push_row(
                    lin.columns
                        .iter()
                        .copied()
                        .zip(lin.gradient.iter().copied()),
                );
                self.b.push(-lin.value);
                self.row_origin.push((fi, idx));
                self.row_norms.push(norm);
            }
            times.assembly += t1.elapsed().as_secs_f64();
        }
        Ok(())
    }

    /// A failed solve of a far prediction, retried once on the same QP (already written in
    /// the displacement `u = x − q_k`) scaled by `s = ‖h f‖∞`: `min ½‖v − h f/s‖²` s.t.
    /// `A v ≥ b/s`, then `u = s v`, `λ = s μ`. Done only when `u = 0` satisfies every row
    /// (`gᵢ(t_{k+1}, q_k) ≥ 0`, true for constraints that do not move) to within the
    /// `violation_tolerance` the stepper accepted `q_k` with: the set is then not empty (up to
    /// that), so an "infeasible" answer is the solver's scaling, not the problem's: a step
    /// accurate relative to a huge travel can leave a person slightly inside a wall, and a
    /// solver then calls the next step's set empty. The answer is KKT-checked on the original
    /// QP like any other; when the retry fails too, the error says that the prediction is too
    /// far to be resolved.
    fn rescaled_projection(
        &self,
        projector: &mut dyn Projector,
        qp: &ProjectionProblem,
        first: sweeping_api::ProjectionError,
        t_next: f64,
    ) -> Result<Projection, SweepError> {
        let fail = |source| SweepError::Projection {
            step: self.k,
            t: t_next,
            rows: qp.n_rows(),
            source,
        };
        let far = qp.y().iter().fold(0.0, |m: f64, d| m.max(d.abs()));
        // Only when q_k satisfies every row (as far as the stepper asks) is the set known to
        // be non-empty (with a moving constraint g(t_{k+1}, q_k) may be negative, and a
        // squeezed person makes it empty).
        let b_scale = qp.b().iter().fold(1f64, |m, b| m.max(b.abs()));
        // At u = 0 each row reads 0 ≥ bᵢ = −gᵢ(t_{k+1}, q_k).
        let violation_at_q = qp.b().iter().copied().fold(0.0, sweeping_api::max_or_nan);
        let q_in_set = violation_at_q <= 1e-9 * b_scale + self.settings.violation_tolerance;
        if !(far > 1.0 && far.is_finite() && q_in_set)
            || matches!(first, sweeping_api::ProjectionError::InvalidInput { .. })
        {
            return Err(fail(first));
        }
        let b: Vec<f64> = qp.b().iter().map(|b| b / far).collect();
        let y: Vec<f64> = qp.y().iter().map(|d| d / far).collect();
        // The same rows, so the same keys: a warm-starting backend keeps its memory.
        let scaled = ProjectionProblem::new(y, qp.a().clone(), b)
            .and_then(|p| match qp.row_keys() {
                Some(keys) => p.with_row_keys(keys.to_vec()),
                None => Ok(p),
            })
            .map_err(fail)?;
        match projector.project(&scaled) {
            Ok(mut sol) => {
                sol.x.iter_mut().for_each(|x| *x *= far);
                sol.multipliers.iter_mut().for_each(|l| *l *= far);
                Ok(sol)
            }
            Err(second) => Err(SweepError::PredictionTooFar {
                step: self.k,
                t: t_next,
                distance: far,
                first: first.to_string(),
                second: second.to_string(),
            }),
        }
    }

    /// The KKT conditions of the projection at the backend's answer, each residual relative to
    /// the size of its terms: whatever status the solver reported, an answer that is not the
    /// projection is never used.
    fn check_kkt(
        &self,
        qp: &ProjectionProblem,
        sol: &Projection,
        t_next: f64,
    ) -> Result<(), SweepError> {
        let tol = self.settings.kkt_tolerance;
        if tol.is_infinite() {
            return Ok(());
        }
        let wrong = |residuals: String, scale: f64| SweepError::KktCheckFailed {
            step: self.k,
            t: t_next,
            backend: sol.stats.backend.clone(),
            residuals,
            tolerance: tol,
            scale,
        };
        if sol.x.len() != qp.dim() || sol.multipliers.len() != qp.n_rows() {
            return Err(wrong(
                format!(
                    "{} coordinates and {} multipliers for a problem of dimension {} with {} rows",
                    sol.x.len(),
                    sol.multipliers.len(),
                    qp.dim(),
                    qp.n_rows()
                ),
                1.0,
            ));
        }
        let r = qp.kkt_residuals(&sol.x, &sol.multipliers);
        // Each residual against the size of the terms it is made of (what rounding alone
        // leaves): Ax − b against b, x − y − Aᵀλ against x − y, λᵢ(Ax − b)ᵢ against both.
        let inf = |v: &[f64]| v.iter().map(|a| a.abs()).fold(0.0, f64::max);
        let disp = sol
            .x
            .iter()
            .zip(qp.y())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let primal_scale = 1f64.max(inf(qp.b()));
        let lambda_scale = 1f64.max(inf(&sol.multipliers));
        let scale = primal_scale.max(disp).max(lambda_scale);
        let ok = r.primal <= tol * primal_scale
            && r.stationarity <= tol * 1f64.max(disp)
            && r.dual <= tol * lambda_scale
            && r.complementarity <= tol * primal_scale * lambda_scale;
        if ok {
            Ok(())
        } else {
            Err(wrong(
                format!(
                    "primal {:.2e}, stationarity {:.2e}, dual {:.2e}, complementarity {:.2e}",
                    r.primal, r.stationarity, r.dual, r.complementarity
                ),
                scale,
            ))
        }
    }

    /// Moving boundaries cannot be jumped. For every member of a time-dependent family (all of
    /// them: a fast set may jump a point far outside any cutoff), the step is refused when
    ///
    /// * the constraint's gradient at `q_k` turns by more than 90° between `t_k` and `t_{k+1}`
    ///   (the moving set passed over the point, which the linearization at `t_{k+1}` would then
    ///   keep on the wrong side), or
    /// * where the family knows the margin `c` of A0: `h · max|∂ₜgᵢ| / |∇gᵢ| ≥ gᵢ(t_k, q_k) + c`,
    ///   the paper's condition `h < c/K_L` (with `K_L ≤ β/α` by A1–A2) applied to each member
    ///   with its current distance: the set moves less in one step than its distance to the
    ///   point's own "centre" (for a person and a wall: the wall cannot reach the centre).
    ///
    /// The error names the member and the `h` (half the largest allowed) that would pass.
    fn check_moving_constraints(&mut self, t_k: f64, t_next: f64) -> Result<(), SweepError> {
        let h = t_next - t_k;
        for fam in self.problem.families() {
            if !fam.is_time_dependent() {
                continue;
            }
            let margin = fam.a0_margin().filter(|c| c.is_finite() && *c > 0.0);
            self.cands.clear();
            // Every member: a set moving fast may jump a point far outside any cutoff.
            fam.candidates(t_k, &self.q, f64::INFINITY, &mut self.cands);
            let mut now = LinearizedRow::default();
            for &idx in &self.cands {
                fam.linearize(idx, t_k, &self.q, true, &mut now);
                fam.linearize(idx, t_next, &self.q, true, &mut self.lin);
                let next = &self.lin;
                let (n0, n1) = (now.gradient_norm(), next.gradient_norm());
                if !(n0 > 1e-12 && now.value.is_finite()) {
                    continue; // reported by the assembly with its own error
                }
                // A gradient that vanishes (or is NaN) at t_{k+1} but not at t_k: the moving
                // set's singular point (a disk's centre, a segment) reached the point itself.
                let cos = if n1 > 1e-12 {
                    now.gradient
                        .iter()
                        .zip(&next.gradient)
                        .map(|(a, b)| a * b)
                        .sum::<f64>()
                        / (n0 * n1)
                } else {
                    -1.0
                };
                // Speed of the set along the normal, |∂ₜg| / |∇g|, at both ends of the step.
                // The change of g over the step counts too: a path may speed up in between.
                let speed = [
                    now.dt.unwrap_or(0.0).abs() / n0,
                    next.dt.unwrap_or(0.0).abs() / n1,
                    (next.value - now.value).abs() / (h * n0.min(n1)),
                ]
                .into_iter()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
                let clearance = now.value.max(0.0) + margin.unwrap_or(0.0);
                let too_far = margin.is_some() && h * speed >= clearance;
                // A path that turns inside the step moves the set where neither end sees it
                // (4 m out and back within one step went through two people unnoticed): the
                // length of its path in the step bounds how far `g` can fall there.
                // Asked only where it can refuse the step: it is per member, at every step.
                let travel = margin.and_then(|_| fam.travel_within(idx, t_k, t_next));
                let travels_too_far = travel.is_some_and(|t| t.distance >= clearance);
                if cos < 0.0 || too_far || travels_too_far {
                    let fastest = travel.map_or(speed, |t| t.max_speed.max(speed));
                    let suggested_h = if fastest > 0.0 && clearance > 0.0 {
                        0.5 * clearance / fastest
                    } else {
                        0.25 * h
                    };
                    let normal_lost = n1.is_nan() || n1 <= 1e-12;
                    let detail = if cos < 0.0 && normal_lost {
                        // Not a turn that was measured: the normal at the end of the step
                        // vanished, or is not a number (a set moving at 1e308 m/s is
                        // nowhere representable a step later).
                        if n1.is_nan() {
                            "its normal at the point is not a number at the end of the step (the moving set's position overflows)".to_string()
                        } else {
                            "its normal at the point vanishes at the end of the step (the moving set's centre or edge reaches the point)".to_string()
                        }
                    } else if cos < 0.0 {
                        format!(
                            "its normal at the point turns by {:.0}° within the step (the moving set passes over the point)",
                            cos.clamp(-1.0, 1.0).acos().to_degrees()
                        )
                    } else if travels_too_far && !too_far {
                        format!(
                            "its path within the step is {:.3e} long (up to {:.3e} per second), not less than the clearance g + c = {:.3e}",
                            travel.map_or(0.0, |t| t.distance),
                            travel.map_or(0.0, |t| t.max_speed),
                            clearance
                        )
                    } else {
                        format!(
                            "it moves {:.3e} along its normal in one step (h·|∂ₜg|/|∇g|), not less than the clearance g + c = {:.3e}",
                            h * speed,
                            clearance
                        )
                    };
                    return Err(SweepError::StepTooLong {
                        step: self.k,
                        t: t_next,
                        constraint: fam.describe(idx),
                        h,
                        suggested_h,
                        detail,
                    });
                }
            }
        }
        Ok(())
    }

    /// A path that turns inside the step (a waypoint strictly between `t_k` and `t_{k+1}`)
    /// is where the step cannot see it: the scheme linearizes at `q_k` with `Q(t_{k+1})`. The
    /// step is refused when, at such a waypoint, the set overlaps the person by more than the
    /// violation tolerance at both `q_k` and `x = q_{k+1}`: `gᵢ` is convex in the point, so
    /// it then overlaps every point of the straight line between them, whatever the pace.
    fn check_waypoints(&mut self, t_k: f64, t_next: f64, x: &[f64]) -> Result<(), SweepError> {
        let tol = self.settings.violation_tolerance;
        let mut waypoints = Vec::new();
        for fam in self.problem.families() {
            if !fam.is_time_dependent() {
                continue;
            }
            waypoints.clear();
            fam.waypoints_within(t_k, t_next, &mut waypoints);
            waypoints.sort_by(f64::total_cmp);
            waypoints.dedup();
            for &tw in &waypoints {
                self.cands.clear();
                fam.candidates(tw, x, 0.0, &mut self.cands);
                for &idx in &self.cands {
                    // A value that is not a number is the violation check's to report.
                    let at_next = fam.value(idx, tw, x, &mut self.lin);
                    let at_k = fam.value(idx, tw, &self.q, &mut self.lin);
                    if at_next.is_nan() || at_k.is_nan() || at_next.max(at_k) >= -tol {
                        continue;
                    }
                    let h = t_next - t_k;
                    let since_start = tw - self.problem.t0();
                    let suggested_h = since_start / (since_start / h).ceil().max(1.0);
                    return Err(SweepError::PathTurnsWithinStep {
                        step: self.k,
                        t: t_next,
                        t_k,
                        constraint: fam.describe(idx),
                        waypoint: tw,
                        overlap: -at_next.max(at_k),
                        tolerance: tol,
                        h,
                        suggested_h,
                    });
                }
            }
        }
        Ok(())
    }

    /// The largest violation of the true constraints at the new configuration, as a distance
    /// `max(0, −gᵢ(t, x))/|∇gᵢ(t, x)|` (in the units of `q`, whatever the scale of `gᵢ`), and
    /// the constraint that has it (`NaN` when some `gᵢ` is not a number).
    ///
    /// For a culling family only the assembled rows can be violated: an omitted member has
    /// `gᵢ(t, q) + ⟨∇gᵢ, x − q⟩ ≥ 0` by the culling proof, and `gᵢ` is convex in `q`, so
    /// `gᵢ(t, x) ≥ gᵢ(t, q) + ⟨∇gᵢ, x − q⟩ ≥ 0`. That makes the check `O(rows)` instead of a
    /// second broad phase. Families that do not cull are checked member by member.
    fn true_violation(&mut self, t: f64, x: &[f64]) -> (f64, Option<ConstraintId>) {
        let families = self.problem.families();
        // (distance, family, member) of the largest distance seen; a NaN wins over everything.
        let mut worst: Option<(f64, usize, usize)> = None;
        let mut consider = |d: f64, fi: usize, idx: usize| {
            let replace = match worst {
                None => true,
                Some((w, _, _)) => !w.is_nan() && (d.is_nan() || d > w),
            };
            if replace {
                worst = Some((d, fi, idx));
            }
        };
        // A flat constraint (`x³ ≥ 0` near 0) is violated by tiny values far from its set, so
        // the value is divided by the gradient's length; a vanishing gradient is infinitely far.
        let distance = |value: f64, norm: f64| {
            if value.is_nan() {
                f64::NAN
            } else if value >= 0.0 {
                0.0
            } else if norm > 0.0 {
                -value / norm
            } else {
                f64::INFINITY
            }
        };
        for &(fi, idx) in &self.row_origin {
            if families[fi].culls() {
                let v = families[fi].value(idx, t, x, &mut self.lin);
                // The gradient only where it is needed: the row is violated.
                let d = if v < 0.0 {
                    families[fi].linearize(idx, t, x, false, &mut self.lin);
                    distance(v, self.lin.gradient_norm())
                } else {
                    distance(v, 1.0)
                };
                consider(d, fi, idx);
            }
        }
        let _ = self.problem.for_each_linearized(
            t,
            x,
            |fam| (!fam.culls()).then_some(0.0),
            false,
            &mut self.scratch,
            |_, id, row| {
                consider(
                    distance(row.value, row.gradient_norm()),
                    id.family,
                    id.member,
                );
                Ok::<(), std::convert::Infallible>(())
            },
        );
        let id = |family, member| Some(ConstraintId { family, member });
        match worst {
            Some((d, fi, idx)) if d.is_nan() => (f64::NAN, id(fi, idx)),
            Some((d, fi, idx)) if d > 0.0 => (d, id(fi, idx)),
            _ => (0.0, None),
        }
    }

    /// A1 where it matters: a row active at the solution with `|∇gᵢ|` below
    /// [`StepperSettings::gradient_floor`] decides the step with a normal it hardly has.
    fn check_active_gradients(&self, sol: &Projection, t_next: f64) -> Result<(), SweepError> {
        let floor = self.settings.gradient_floor;
        let threshold = self.settings.active_threshold;
        for ((&lambda, &norm), &(fi, idx)) in sol
            .multipliers
            .iter()
            .zip(&self.row_norms)
            .zip(&self.row_origin)
        {
            if lambda > threshold && norm < floor {
                return Err(SweepError::DegenerateConstraint {
                    step: self.k,
                    t: t_next,
                    constraint: self.problem.families()[fi].describe(idx),
                    norm,
                });
            }
        }
        Ok(())
    }

    /// Why a violated constraint could be violated: `D²gᵢ` at the point has a negative
    /// eigenvalue, so `gᵢ` is not convex there and the linearization overshoots (`None` when
    /// it is convex there, or not a number).
    fn convexity_failure(&self, id: ConstraintId, t: f64, x: &[f64]) -> Option<String> {
        use crate::assumptions::{
            concave_direction, describe_point, symmetric_min_eigenvalue, symmetric_spectral_norm,
            CONVEXITY_MEANING, CONVEXITY_TOLERANCE,
        };
        let fam = &self.problem.families()[id.family];
        let so = fam.second_order(id.member, t, x);
        let n = so.columns.len();
        if n == 0 || so.hessian.len() != n * n || so.hessian.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let min_eig = symmetric_min_eigenvalue(&so.hessian, n);
        let norm = symmetric_spectral_norm(&so.hessian, n);
        concave_direction(min_eig, norm, CONVEXITY_TOLERANCE).then(|| {
            format!(
                "convexity fails there: the smallest eigenvalue of D²g is {min_eig:.3e} < 0 at {}: {CONVEXITY_MEANING}",
                describe_point(&so.columns, x)
            )
        })
    }

    /// One step: computes `q_{k+1}` from `q_k`.
    ///
    /// # Errors
    /// Non-finite values, degenerate constraints, projection failures, with step and time.
    pub fn step(&mut self, projector: &mut dyn Projector) -> Result<StepReport, SweepError> {
        let mut times = StageTimes::default();
        let t_k = self.t;
        let t_next = self.time_of(self.k + 1);
        let h = t_next - t_k;

        let t0 = Instant::now();
        self.predict(t_k, h)?;
        times.effects = t0.elapsed().as_secs_f64();

        // Initial cutoffs: twice the drift bound of the prediction itself, or 1.5 times the
        // previous step's, whichever is larger. Only the cost depends on this guess: the proof
        // below decides whether the step is exact. Timed with the broad phase it sizes.
        let tb = Instant::now();
        for (fi, fam) in self.problem.families().iter().enumerate() {
            if fam.culls() {
                let d = fam.linearization_drift_bound(t_next, &self.q, &self.y);
                let state = &mut self.families[fi];
                state.cutoff = self
                    .settings
                    .min_cutoff
                    .max(2.0 * d)
                    .max(1.5 * state.last_drift);
            }
        }

        times.broad_phase += tb.elapsed().as_secs_f64();

        let tc = Instant::now();
        self.check_moving_constraints(t_k, t_next)?;
        times.check += tc.elapsed().as_secs_f64();

        let mut solves = 0usize;
        let mut iterations = 0u32;
        let mut counters = BackendCounters::default();
        let solution: Projection = loop {
            self.assemble(t_next, &mut times)?;
            let tp = Instant::now();
            // Each row keyed by its constraint (family, candidate index), stable across steps,
            // so that backends can warm-start from the previous step's active rows.
            let keys = self
                .row_origin
                .iter()
                .map(|&(fi, idx)| RowKey {
                    family: fi as u32,
                    member: idx as u64,
                })
                .collect();
            // The projection of the displacement: `u = x − q_k` is the projection of `h f`
            // onto `∇gᵢ · u ≥ −gᵢ`, the scheme's step written relative to `q_k`. Its numbers
            // are those of the step, wherever the scene lies: written in `x`, a room at 10⁶
            // put six digits before the ones that matter in `y` and `b`, and tolerances
            // relative to the data's size let overlaps of 7e-7 through.
            let qp = ProjectionProblem::new(self.dy.clone(), self.rows.clone(), self.b.clone())
                .and_then(|p| p.with_row_keys(keys))
                .map_err(|e| SweepError::Projection {
                    step: self.k,
                    t: t_next,
                    rows: self.b.len(),
                    source: e,
                })?;
            let mut sol = match projector.project(&qp) {
                Ok(sol) => sol,
                Err(e) => self.rescaled_projection(projector, &qp, e, t_next)?,
            };
            times.projection += tp.elapsed().as_secs_f64();
            solves += 1;
            iterations += sol.stats.iterations;
            counters.add(&sol.stats.counters);
            if let Some(i) = sol.x.iter().position(|v| !v.is_finite()) {
                return Err(SweepError::NonFinite {
                    step: self.k,
                    t: t_next,
                    what: format!(
                        "the projection's coordinate {i} (backend {})",
                        sol.stats.backend
                    ),
                });
            }
            let tc = Instant::now();
            self.check_kkt(&qp, &sol, t_next)?;
            times.check += tc.elapsed().as_secs_f64();
            // From the displacement to the point.
            sol.x.iter_mut().zip(&self.q).for_each(|(x, q)| *x += q);

            // The culling proof (module docs): every omitted row holds at x when δ ≤ cutoff.
            let tc = Instant::now();
            let mut proven = true;
            for (fi, fam) in self.problem.families().iter().enumerate() {
                if fam.culls() {
                    let d = fam.linearization_drift_bound(t_next, &self.q, &sol.x);
                    self.families[fi].last_drift = d;
                    if d > self.families[fi].cutoff {
                        self.families[fi].cutoff = 2.0 * d;
                        proven = false;
                    }
                }
            }
            times.check += tc.elapsed().as_secs_f64();
            if proven {
                break sol;
            }
            if solves > self.settings.max_cull_retries {
                return Err(SweepError::CullingFailed {
                    step: self.k,
                    t: t_next,
                    solves,
                });
            }
        };

        let tc = Instant::now();
        self.check_active_gradients(&solution, t_next)?;
        let max_displacement = solution
            .x
            .iter()
            .zip(&self.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let (max_violation, worst_constraint) = self.true_violation(t_next, &solution.x);
        times.check += tc.elapsed().as_secs_f64();
        // A run never continues from a configuration outside Q(t): the linearized set is an
        // inner approximation of Q for convex gᵢ (paper, inclusion after equation `schema`), so
        // a violation beyond the solver's accuracy means the answer is wrong.
        if max_violation.is_nan() || max_violation > self.settings.violation_tolerance {
            return Err(SweepError::ViolationTooLarge {
                step: self.k,
                t: t_next,
                constraint: worst_constraint
                    .map(|id| self.problem.describe(id))
                    .unwrap_or_default(),
                violation: max_violation,
                tolerance: self.settings.violation_tolerance,
                why: worst_constraint
                    .and_then(|id| self.convexity_failure(id, t_next, &solution.x)),
            });
        }
        let tc = Instant::now();
        self.check_waypoints(t_k, t_next, &solution.x)?;
        times.check += tc.elapsed().as_secs_f64();

        let report = StepReport {
            step: self.k,
            t: t_next,
            h,
            rows: self.b.len(),
            active: solution.active_count(self.settings.active_threshold),
            solves,
            iterations,
            counters,
            times,
            max_violation,
            worst_constraint,
            max_displacement,
            solve: solution.stats,
        };
        self.q = solution.x;
        self.k += 1;
        self.t = t_next;
        Ok(report)
    }

    /// Steps until `T`, calling the observers after each step; returns what was computed, or
    /// the error together with everything computed before it.
    ///
    /// # Errors
    /// A [`RunFailure`]: the [`SweepError`] and the partial [`Run`].
    pub fn run(
        self,
        projector: &mut dyn Projector,
        observers: &mut [&mut dyn Observer],
    ) -> Result<Run, Box<RunFailure>> {
        self.run_until(projector, observers, |_, _| false)
    }

    /// Like [`run`](Self::run), but stops early, after the step at the end of which
    /// `stop(t, q)` is true (a crowd stops when everybody has left), or without a step when it
    /// is true of the start already (a run resumed from the last state of one that ended so).
    /// The last configuration is always recorded.
    ///
    /// # Errors
    /// A [`RunFailure`]: the [`SweepError`] and the partial [`Run`].
    pub fn run_until(
        mut self,
        projector: &mut dyn Projector,
        observers: &mut [&mut dyn Observer],
        mut stop: impl FnMut(f64, &[f64]) -> bool,
    ) -> Result<Run, Box<RunFailure>> {
        let mut run = Run {
            trajectory: Trajectory {
                times: vec![self.t],
                states: vec![self.q.clone()],
            },
            stats: RunStats::default(),
            q_final: self.q.clone(),
            t_final: self.t,
        };
        let fail = |run: Run, error: SweepError, observers: &mut [&mut dyn Observer]| {
            for o in observers.iter_mut() {
                let _ = o.on_finish(Some(&error));
            }
            Box::new(RunFailure {
                error,
                partial: run,
            })
        };
        for o in observers.iter_mut() {
            if let Err(e) = o.on_start(self.t, &self.q) {
                let e = e.into_sweep_error(o.name(), 0, self.t);
                return Err(fail(run, e, observers));
            }
        }
        // A start that already meets `stop` is where the run ends: a run resumed from a
        // finished one takes no step past the end it had reached.
        let mut stopping = stop(self.t, &self.q);
        while self.k < self.n_steps && !stopping {
            let report = match self.step(projector) {
                Ok(r) => r,
                Err(e) => return Err(fail(run, e, observers)),
            };
            run.stats.absorb(&report);
            run.q_final.clone_from(&self.q);
            run.t_final = self.t;
            stopping = stop(self.t, &self.q);
            let every = self.settings.record_every;
            if (every > 0 && self.k.is_multiple_of(every)) || self.k == self.n_steps || stopping {
                run.trajectory.times.push(self.t);
                run.trajectory.states.push(self.q.clone());
            }
            for o in observers.iter_mut() {
                if let Err(e) = o.on_step(&report, &self.q) {
                    let e = e.into_sweep_error(o.name(), report.step, report.t);
                    return Err(fail(run, e, observers));
                }
            }
        }
        // Every observer finishes, those after a failed one told of its error (a summary
        // records the run as failed); that first error is the run's.
        let mut failed: Option<SweepError> = None;
        for o in observers.iter_mut() {
            if let Err(e) = o.on_finish(failed.as_ref()) {
                if failed.is_none() {
                    failed = Some(e.into_sweep_error(o.name(), self.k, self.t));
                }
            }
        }
        match failed {
            Some(error) => Err(Box::new(RunFailure {
                error,
                partial: run,
            })),
            None => Ok(run),
        }
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1].
fn gauss_legendre(points: usize) -> (Vec<f64>, Vec<f64>) {
    match points {
        1 => (vec![0.0], vec![2.0]),
        2 => {
            let a = 1.0 / 3f64.sqrt();
            (vec![-a, a], vec![1.0, 1.0])
        }
        3 => {
            let a = (3.0f64 / 5.0).sqrt();
            (vec![-a, 0.0, a], vec![5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])
        }
        4 => {
            let a = (3.0 / 7.0 - 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
            let b = (3.0 / 7.0 + 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
            let wa = (18.0 + 30f64.sqrt()) / 36.0;
            let wb = (18.0 - 30f64.sqrt()) / 36.0;
            (vec![-b, -a, a, b], vec![wb, wa, wa, wb])
        }
        _ => {
            let a = 1.0 / 3.0 * (5.0 - 2.0 * (10.0f64 / 7.0).sqrt()).sqrt();
            let b = 1.0 / 3.0 * (5.0 + 2.0 * (10.0f64 / 7.0).sqrt()).sqrt();
            let wa = (322.0 + 13.0 * 70f64.sqrt()) / 900.0;
            let wb = (322.0 - 13.0 * 70f64.sqrt()) / 900.0;
            (vec![-b, -a, 0.0, a, b], vec![wb, wa, 128.0 / 225.0, wa, wb])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{gauss_legendre, step_count};

    #[test]
    fn a_positive_span_takes_at_least_one_step_however_long_the_step() {
        assert_eq!(step_count(40.0, 0.01), 4000);
        // A ratio within 1e-9 above an integer counts as that integer.
        assert_eq!(step_count(0.3, 0.1), 3);
        assert_eq!(step_count(40.0, 100.0), 1);
        // 4e-299 steps is within 1e-9 of none, and is still one step to T.
        assert_eq!(step_count(40.0, 1e300), 1);
        assert_eq!(step_count(1e-12, 1.0), 1);
        assert_eq!(step_count(0.0, 0.01), 0);
        assert_eq!(step_count(-1.0, 0.01), 0);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..=5 {
            let (x, w) = gauss_legendre(n);
            for p in 0..(2 * n) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p as i32)).sum();
                let exact = if p % 2 == 1 {
                    0.0
                } else {
                    2.0 / (p as f64 + 1.0)
                };
                assert!(
                    (q - exact).abs() < 1e-13,
                    "n = {n}, degree {p}: {q} vs {exact}"
                );
            }
        }
    }
}
