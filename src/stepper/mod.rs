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
//!    `∇gᵢ · u ≥ −gᵢ`; equality constraints `hⱼ = 0`
//!    ([`Problem::with_equality`](crate::problem::Problem::with_equality)) give the leading
//!    rows `∇hⱼ · u = −hⱼ`, every member at every step;
//! 4. **projection** — one QP, solved by any [`Projector`]: `u` is the projection of
//!    `y − q_k` (`h f`, computed as such), so the backend sees the step's own numbers wherever
//!    the scene lies, and `q_{k+1} = q_k + u`; in the problem's metric `W`
//!    ([`Problem::with_metric`](crate::problem::Problem::with_metric)) when it has one;
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

mod assembly;
mod checks;
mod concave;
mod moving;
mod observer;
mod prediction;
mod projection;
mod run;
mod settings;

pub use crate::error::ObserverError;
pub use crate::report::{Contact, Run, RunStats, StageTimes, StepReport, Trajectory};
pub use observer::Observer;
pub use prediction::Prediction;
pub use run::RunFailure;
pub use settings::StepperSettings;

use crate::constraint::{Curvature, LinearizedRow};
use crate::error::SweepError;
use crate::problem::{LinearizeScratch, Problem};
use assembly::FamilyState;
use std::time::Instant;
use sweeping_api::{Projector, SparseRows};

pub use crate::numbers::display_number;

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
    /// How many leading rows are equalities.
    equality_rows: usize,
    /// `max(1, ‖W‖∞)`: the scale of `W(x − y)` in the KKT check.
    metric_scale: f64,
    /// `|∇gᵢ|` of each assembled row, for the A1 check on the active ones.
    row_norms: Vec<f64>,
    cands: Vec<usize>,
    lin: LinearizedRow,
    scratch: LinearizeScratch,
    families: Vec<FamilyState>,
    /// The cuts of concave constraints (see `concave.rs`).
    cuts: concave::Cuts,
}

impl<'p> Stepper<'p> {
    /// Validates the problem and settings and checks `q₀ ∈ Q(t₀)`.
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] (dimension, NaN, non-positive `h`, `T < t₀`…) or
    /// [`SweepError::InfeasibleStart`].
    pub fn new(problem: &'p Problem, settings: StepperSettings) -> Result<Self, SweepError> {
        settings.check(problem.t0())?;
        problem.validate(settings.feasibility_tolerance)?;
        let n_steps = step_count(settings.t_end - problem.t0(), settings.h);
        let dim = problem.dim();
        let concave = problem
            .families()
            .iter()
            .any(|f| f.curvature() == Curvature::Concave && !f.is_affine());
        // A convex set's cuts stop within `concave_tolerance` of it, and the check after the
        // step refuses a distance beyond `violation_tolerance`: the first must not exceed the
        // second, or a certified step fails its check.
        if concave && settings.concave_tolerance > settings.violation_tolerance {
            return Err(SweepError::InvalidInput(format!(
                "concave_tolerance = {:e} exceeds violation_tolerance = {:e}: the cuts of a \
                 convex set (a constraint declared concave) would stop farther outside it than \
                 the check after each step allows; lower concave_tolerance",
                settings.concave_tolerance, settings.violation_tolerance
            )));
        }
        let mut stepper = Self {
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
            equality_rows: 0,
            metric_scale: metric_scale(problem.metric()),
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
            cuts: concave::Cuts::new(concave),
            settings,
        };
        stepper.check_concavity_claims()?;
        Ok(stepper)
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

    /// One step: computes `q_{k+1}` from `q_k`, stage by stage (module docs).
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

        // The first cutoffs are timed with the broad phase they size.
        let tb = Instant::now();
        self.size_cutoffs(t_next);
        times.broad_phase += tb.elapsed().as_secs_f64();

        let tc = Instant::now();
        self.check_moving_constraints(t_k, t_next)?;
        times.check += tc.elapsed().as_secs_f64();

        let solved = self.project_until_proven(projector, t_next, &mut times)?;
        let solution = solved.solution;

        let tc = Instant::now();
        self.check_active_gradients(&solution, t_next)?;
        let max_displacement = solution
            .x
            .iter()
            .zip(&self.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let (max_violation, worst_constraint) = self.true_violation(t_next, &solution.x);
        let max_equality_residual = self.equality_residual(t_next, &solution.x);
        times.check += tc.elapsed().as_secs_f64();
        self.check_violation(max_violation, worst_constraint, t_next, &solution.x)?;
        let tc = Instant::now();
        self.check_waypoints(t_k, t_next, &solution.x)?;
        times.check += tc.elapsed().as_secs_f64();

        let contacts = if self.settings.record_contacts {
            self.contacts(&solution.multipliers)
        } else {
            Vec::new()
        };
        let report = StepReport {
            step: self.k,
            t: t_next,
            h,
            rows: self.b.len(),
            active: solution.active_count(self.settings.active_threshold),
            solves: solved.solves,
            cuts: solved.cuts,
            iterations: solved.iterations,
            counters: solved.counters,
            times,
            max_violation,
            worst_constraint,
            max_equality_residual,
            max_displacement,
            solve: solution.stats,
            contacts,
        };
        self.q = solution.x;
        self.k += 1;
        self.t = t_next;
        Ok(report)
    }
}

/// `max(1, ‖W‖∞)`, with `‖W‖∞` the largest absolute row sum of the metric: `W(x − y)` is up
/// to that times the displacement, and a small `W` does not ask more of a backend's absolute
/// accuracy than the identity does (1 for the identity).
fn metric_scale(metric: &sweeping_api::Metric) -> f64 {
    use sweeping_api::Metric;
    let norm = match metric {
        Metric::Identity => 1.0,
        Metric::Diagonal(w) => w.iter().fold(0.0, |m: f64, v| m.max(v.abs())),
        Metric::Symmetric(w) => (0..w.n_rows())
            .map(|r| w.row(r).map(|(_, v)| v.abs()).sum::<f64>())
            .fold(0.0, f64::max),
    };
    norm.max(1.0)
}

impl Stepper<'_> {
    /// The assembled rows whose multiplier exceeds the active threshold, with it and their
    /// gradient (see [`Contact`]).
    fn contacts(&self, multipliers: &[f64]) -> Vec<Contact> {
        let threshold = self.settings.active_threshold;
        // The leading equality rows are no contacts.
        multipliers
            .iter()
            .enumerate()
            .skip(self.equality_rows)
            .filter(|(_, &l)| l > threshold)
            .map(|(r, &l)| {
                let (family, member) = self.row_origin[r];
                Contact {
                    constraint: crate::constraint::ConstraintId { family, member },
                    multiplier: l,
                    gradient: self.rows.row(r).collect(),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::step_count;

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
}
