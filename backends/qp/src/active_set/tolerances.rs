//! The tests of a pass of the method: how far a row may be violated, and the support's
//! equations left unsolved, before the method acts on it, in the first pass and in the
//! passes that finish its answer.

/// Refinement stops when the residual of the unregularized system, or the change of its first
/// block, falls below this, relative to `max(1, ‖right-hand side‖∞)`.
pub(super) const REFINE_TOL: f64 = 1e-13;
/// The equations of the support are taken as inconsistent, and a row outside it as violated,
/// beyond this, relative to `max(1, ‖r‖∞)`.
pub(super) const ACTIVE_TOL: f64 = 1e-12;
/// The tolerance of the second pass ([`second_pass`](super::finish::second_pass)), relative as [`ACTIVE_TOL`], and of its
/// refinement, below which a support's equations count as solved there.
///
/// On a jam the support's rows can be nearly dependent, its smallest singular value `σ` far
/// below one: a point that violates a row, or leaves its support's equations unsolved, by `τ`
/// can then be `τ/σ` from the projection, so the test must be far tighter than the distance
/// it is to guarantee. The crowd's problems are posed in the displacement `x − q_k`, whose
/// rows and right-hand sides are of the order of a step's travel, so `1e-15` is still a
/// hundred times the rounding of `r − A d` (measured:
/// `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
pub(super) const SECOND_PASS_TOL: f64 = 1e-15;

/// The tests of the second pass, tried in turn, each from the first answer, until a pass
/// converges; then the ones below it again, each from the last answer ([`second_pass`](super::finish::second_pass)); an
/// answer that no pass at `1e-15` converges to is [`Outcome::unfinished`](super::Outcome::unfinished), off by up to
/// `1e-14` or `1e-13`. On the slivers where the pass at `1e-15` cycles, a row violated by a
/// few `1e-15` joins and the refinement then measures the support's equations inconsistent by
/// ten times that, so the row leaves again: the test is below what the refinement can resolve
/// there. A pass at `1e-14` still brings such an answer much nearer the projection, and from
/// there the pass at `1e-15` often finishes it. The rung at `1e-13` is for answers that
/// neither lower rung finishes from the first answer: from its answer the lower rungs can
/// converge where they cycled before (measured:
/// `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
pub(super) const FINISH_LADDER: [f64; 3] = [SECOND_PASS_TOL, 1e-14, 1e-13];

/// The tests of one pass of the method.
#[derive(Debug, Clone, Copy)]
pub(super) struct Tolerances {
    /// A row outside the support is violated, and the support's equations inconsistent,
    /// beyond this, relative to `max(1, ‖r‖∞)`.
    pub(super) active: f64,
    /// Refinement's, relative to `max(1, ‖right-hand side‖∞)` (see [`ActiveSystem::refine`](super::system::ActiveSystem::refine)).
    pub(super) refine: f64,
    /// Whether a refinement that stalls is followed by conjugate gradients on the support's
    /// equations ([`ActiveSystem::least_squares`](super::system::ActiveSystem::least_squares)).
    pub(super) least_squares: bool,
    /// Whether a run that cycles restarts as Lawson–Hanson proper, from an empty support.
    pub(super) restarts: bool,
}

/// The first pass: tests at [`ACTIVE_TOL`], refinement alone.
pub(super) const FIRST_PASS: Tolerances = Tolerances {
    active: ACTIVE_TOL,
    refine: REFINE_TOL,
    least_squares: false,
    restarts: true,
};

/// The second pass: tests and refinement at [`SECOND_PASS_TOL`], and a refinement that stalls
/// followed by conjugate gradients. Refinement (the proximal-point method with step `1/δ`)
/// contracts an error along a singular vector of `A_P` by `δ/(σ² + δ)` per step, so it stalls
/// on rows nearly dependent (`σ² ≲ 10δ`, `σ ≲ 1e-4`) whether or not their equations are
/// consistent, and the method would take consistent supports for inconsistent ones, dropping
/// and taking back the same rows until it runs out of iterations. Conjugate gradients tell
/// the two apart in a few steps (measured:
/// `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
pub(super) const SECOND_PASS: Tolerances = Tolerances {
    active: SECOND_PASS_TOL,
    refine: SECOND_PASS_TOL,
    least_squares: true,
    restarts: false,
};
