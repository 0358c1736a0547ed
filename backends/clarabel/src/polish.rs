//! Active-set polishing of an interior-point answer.
//!
//! An interior-point iterate approaches the solution from inside the cone. On a row that is
//! *weakly* active at the solution (tight, with a zero multiplier) both the slack and the
//! multiplier only go to zero like `√μ`, so the point stays off by about the square root of
//! the duality gap (`1e-5` for a gap of `1e-10`) however small the KKT residuals are.
//! Polishing guesses the active set from the iterate — the rows whose multiplier exceeds their
//! slack (`zᵢ > sᵢ`), starting from their multipliers — and finishes the job exactly with the
//! dual Lawson–Hanson method of [`crate::active_set`], robust to the linearly dependent rows of
//! contact loops. The caller keeps the answer only when its KKT residuals say so.

use crate::active_set::{self, Start};
use sweeping_api::ProjectionProblem;

/// Most active-set iterations.
const ITERATIONS: u32 = 40;

/// The projection finished from the interior-point multipliers `z` and slacks `s`, as
/// `(x, λ)`; `None` when the active-set method does not converge within [`ITERATIONS`]
/// iterations or certifies the set empty (the interior-point answer then stands on its
/// own residuals).
pub(crate) fn polish(
    problem: &ProjectionProblem,
    z: &[f64],
    s: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let m = problem.n_rows();
    if z.len() != m || s.len() != m {
        return None;
    }
    let support: Vec<usize> = (0..m).filter(|&i| z[i] > s[i]).collect();
    let lambda = support
        .iter()
        .map(|&i| z[i].max(f64::MIN_POSITIVE))
        .collect();
    // A row that joins later starts from its interior-point multiplier.
    let join = z.iter().map(|v| v.max(f64::MIN_POSITIVE)).collect();
    let start = Start {
        support,
        lambda,
        join,
    };
    active_set::solve(problem, start, ITERATIONS)
        .ok()
        .map(|outcome| (outcome.x, outcome.lambda))
}
