//! Lawson–Hanson on the dual of the projection, one block at a time.
//!
//! The projection `x = y + d`, `d = Aᵀλ`, has `λ` solving the dual
//!
//! ```text
//!     min ½‖Aᵀλ‖² − λᵀr   over λ ≥ 0,     r = b − A y,
//! ```
//!
//! a non-negative least-squares problem in disguise, for which the Lawson–Hanson active-set
//! method terminates finitely. Each step solves the equality-constrained projection on the
//! support `P`,
//!
//! ```text
//!     [ I    A_Pᵀ ] [ d  ]   [ 0   ]
//!     [ A_P  0    ] [ −μ ] = [ r_P ],
//! ```
//!
//! by an `LDLᵀ` factorization (QDLDL's arithmetic, run by this crate's `ldl` module so that
//! the matrix is permuted and analysed once, ordered by AMD or by an ordering remembered from
//! recent factorizations, see [`Orderings`]) of the quasi-definite matrix whose
//! lower-right block is `−δI`, on the unknowns the rows of `P` touch (`dⱼ = 0` for the others),
//! followed by iterative refinement against the unregularized
//! matrix, started from the current `(d, λ)`. Between steps the support changes by a few
//! rows; up to `BORDER_MAX` (24) such changes are solved through the factor already made, by
//! bordering it with the changed rows and a small dense Schur complement (the factor extended
//! by the identity on unknowns that only joined rows touch),
//! instead of factoring again. Refinement is the proximal-point method on the
//! multipliers, so on linearly dependent rows (a *contact loop*: a cycle of touching disks)
//! it still converges to the unique `d` and to the least-squares `μ` nearest `λ`. Then:
//!
//! - if `A_P d = r_P` is inconsistent (residual `e = r_P − A_P d` beyond a tolerance), the rows
//!   cannot all be tight: `e` lies in the null space of `A_Pᵀ` and the dual objective
//!   decreases without bound along it on `P`. `λ` moves along `e` until an entry reaches zero
//!   and that row leaves `P`. If no entry of `e` is negative the ray never stops: `e ≥ 0`,
//!   `A_Pᵀe = 0`, `eᵀr_P > 0` is Farkas' certificate that `A x ≥ b` is empty, returned after
//!   it is checked;
//! - otherwise, if some `μ` is negative, `λ` moves toward `μ` until an entry reaches zero and
//!   that row leaves `P` (on the first pass, before any row joined, every row with a negative
//!   `μ` leaves at once, saving one factorization per row when the starting guess holds
//!   several rows that are no longer tight);
//! - otherwise the rows outside `P` that `d` violates join it;
//! - when none does, `(y + d, μ)` satisfies the KKT conditions.
//!
//! Those tests allow `1e-12` (relative), which jams need to finish at all; an answer that
//! uses that room (a row violated, or the support's equations left unsolved, by more than
//! `1e-15`) is finished by a second pass at `1e-15` from its own support, under the same cap
//! of iterations, then, when that pass does not converge, by one at `1e-14`, then at `1e-13`;
//! from the answer of the first that converges, the passes below it run again, down to
//! `1e-15`. An answer no pass at `1e-15` finished stands as the best one of the others, or
//! as it was, and says it is unfinished ([`Outcome::unfinished`]). On a jam with more
//! tight rows than unknowns the feasible set is a sliver around the projection, and two
//! points that pass the `1e-12` tests can lie millions of times further apart than that
//! (measured: `docs/lab/2026-11-24-second-pass-1e-13.md`). The second pass tells a support
//! whose rows are nearly dependent from one whose equations are inconsistent by conjugate
//! gradients where refinement stalls (see `LEAST_SQUARES_STEPS` in the source).
//!
//! The same method polishes Clarabel's interior-point answers (started from the interior-point
//! guess, see `sweeping-clarabel`) and is the engine's warm path and finish ([`crate::Engine`],
//! started from the previous step's support, from the rows violated at `y`, or from an
//! interior point's support): one implementation, several starts.

mod bordered;
mod dense;
mod farkas;
mod finish;
mod least_squares;
mod merged_rows;
mod orderings;
mod pass;
mod pivots;
mod refine;
mod system;
#[cfg(test)]
mod test_problems;
mod tolerances;
mod visits;

pub use orderings::{Memory, Orderings};

use finish::second_pass;
use pass::run_pass;
use sweeping_api::ProjectionProblem;
use tolerances::FIRST_PASS;

/// Where the method starts.
#[derive(Debug, Clone)]
pub struct Start {
    /// The starting support (row indices, distinct, in any order).
    pub support: Vec<usize>,
    /// A positive starting multiplier per row of the support.
    pub lambda: Vec<f64>,
    /// For every row, the positive multiplier it starts from if it joins the support later.
    pub join: Vec<f64>,
    /// How many of the rows violated at an iteration join the support: all of them (`None`),
    /// or at most this many, the most violated first. Rows joining together that are
    /// linearly dependent on the support make its equations inconsistent, and the method then
    /// leaves one row per iteration; on a jam whose support already holds more rows than
    /// unknowns, joining the most violated row alone keeps that from happening again. With a
    /// bound, rows with negative multipliers also leave one at a time from the start (without
    /// it, every such row leaves at once on the first pass, before any row joined).
    pub join_at_most: Option<usize>,
}

/// A converged answer.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The point `y + d`.
    pub x: Vec<f64>,
    /// One multiplier per row (zero off the support).
    pub lambda: Vec<f64>,
    /// Iterations spent: each solved the working set's system once, through a fresh
    /// factorization or through the previous one by bordering.
    pub iterations: u32,
    /// `None` when the answer passed the tests at `1e-15`, relative (the first pass's, or
    /// a second pass's own); `Some(off)` when no second pass converged at `1e-15` and the
    /// answer is one at `1e-14` or `1e-13`, or stands as the first pass or a pass's best
    /// iterate left it: a row violated, or a row of its support not tight, by `off`
    /// (absolute), certified only to that. On a sliver of a feasible set an answer off by
    /// `1e-12` lay `1e-8` from the projection.
    pub unfinished: Option<f64>,
}

/// Why no answer came out.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// Factorization failed or numbers stopped being finite.
    Numerical(&'static str),
    /// The cap on iterations was reached.
    Cap(u32),
    /// A working set came back three times even after the restart as Lawson–Hanson
    /// proper: rounding on degenerate, dependent rows made the method cycle.
    Cycling(u32),
    /// A checked Farkas certificate: rows `support` with weights `e ≥ 0`, `A_Pᵀe ≈ 0`,
    /// `eᵀr_P > 0`.
    Infeasible {
        /// Row indices of the certificate.
        rows: Vec<usize>,
    },
}

/// How [`solve`] runs. Every field has a documented default; [`Options::capped`] is the
/// defaults with a cap of one's own.
#[derive(Debug)]
pub struct Options<'a> {
    /// Most iterations of the first pass, and of each pass that finishes its answer. Default
    /// `100`.
    pub cap: u32,
    /// The first pass's answer as it is, of the tests at `1e-12`, without the passes that
    /// finish it at `1e-15`: on a sliver of a feasible set it can lie `1e-8` from the
    /// projection. Default `false`.
    pub first_pass_only: bool,
    /// Where sparse factorizations are ordered from, and remembered ([`Memory`]); `None`
    /// orders each by AMD. Default `None`.
    pub memory: Option<Memory<'a>>,
}

impl Default for Options<'_> {
    fn default() -> Self {
        Self {
            cap: 100,
            first_pass_only: false,
            memory: None,
        }
    }
}

impl Options<'_> {
    /// The defaults, with at most `cap` iterations per pass.
    pub fn capped(cap: u32) -> Self {
        Self {
            cap,
            ..Self::default()
        }
    }
}

/// Runs the method from `start` as `options` say: a first pass at `1e-12` (relative), then,
/// when its answer leaves a row violated or the support's equations unsolved by more than
/// `1e-15` and `options` do not ask for the first pass only, the passes that finish it. See
/// the module documentation.
pub fn solve(
    problem: &ProjectionProblem,
    start: Start,
    options: Options<'_>,
) -> Result<Outcome, Failure> {
    let Options {
        cap,
        first_pass_only,
        memory,
    } = options;
    // Without one name per unknown nothing is remembered: an ordering only saves time, so
    // none is guessed.
    let mut memory = memory.filter(|m| m.unknowns.len() == problem.dim());
    let first = run_pass(problem, start, cap, FIRST_PASS, memory.as_mut(), None, None)?;
    if first_pass_only {
        return Ok(first.outcome);
    }
    Ok(second_pass(problem, first, cap, memory.as_mut()))
}
