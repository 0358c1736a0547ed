//! Problems and measures shared by the unit tests of the method's parts.

use super::system::ActiveSystem;
use super::tolerances::REFINE_TOL;
use super::Start;
use sweeping_api::{ProjectionProblem, SparseRows};

/// The start from the rows `support`, each at multiplier 1/2, any row joining at 1.
pub(super) fn start_from(support: Vec<usize>, m: usize) -> Start {
    Start {
        lambda: vec![0.5; support.len()],
        support,
        join: vec![1.0; m],
        join_at_most: None,
    }
}

/// 40 unknowns, 34 rows of three entries each, clearly independent (`K_δ` is well
/// conditioned, so a solve of it is accurate to rounding), and row 34, a copy of row 3.
pub(super) fn random_problem() -> ProjectionProblem {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let n = 40;
    // Row i has its own unknown i (entry 1) and two random ones (entries below ½); row 34
    // repeats row 3.
    let mut rows: Vec<Vec<(usize, f64)>> = (0..34)
        .map(|i| {
            let mut row = vec![(i, 1.0)];
            row.extend((0..2).map(|_| (rng.gen_range(0..n), rng.gen_range(-0.5..0.5))));
            row
        })
        .collect();
    rows.push(rows[3].clone());
    let a = SparseRows::from_rows(n, &rows);
    let y: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let b: Vec<f64> = (0..35).map(|_| rng.gen_range(-1.0..1.0)).collect();
    ProjectionProblem::new(y, a, b).unwrap()
}

/// The largest difference between the solutions of `K₀ v = rhs` for `support`
/// (consistent: the rows are independent) refined from zero through a fresh sparse
/// factorization and through `system`; both refinements must meet their tolerance.
pub(super) fn solve_gap(
    p: &ProjectionProblem,
    system: &mut ActiveSystem,
    support: &[usize],
) -> f64 {
    let size = p.dim() + support.len();
    let rhs: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut fresh = ActiveSystem::sparse(p, support).unwrap();
    let (mut a, mut b) = (vec![0.0; size], vec![0.0; size]);
    assert!(
        fresh
            .refine(&rhs, &mut a, REFINE_TOL, false)
            .unwrap()
            .solved
    );
    assert!(
        system
            .refine(&rhs, &mut b, REFINE_TOL, false)
            .unwrap()
            .solved
    );
    max_difference(&a, &b)
}

/// `K_δ⁻¹ v` for `support` by a fresh factorization and by `system`, without refinement:
/// the largest difference relative to the largest entry. Both solve the same regularized
/// system, so only rounding separates them; an error in the bordering (its Schur
/// complement, pivoting or back-substitution) shows here even where refinement would hide
/// it.
pub(super) fn raw_solve_gap(
    p: &ProjectionProblem,
    system: &mut ActiveSystem,
    support: &[usize],
) -> f64 {
    let size = p.dim() + support.len();
    let v: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut fresh = ActiveSystem::sparse(p, support).unwrap();
    let (mut a, mut b) = (v.clone(), v);
    fresh.solve_in_place(&mut a);
    system.solve_in_place(&mut b);
    let scale = a.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
    max_difference(&a, &b) / scale
}

/// The largest `|aᵢ − bᵢ|`, infinite when one is not finite (`f64::max` would drop a NaN).
pub(super) fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m: f64, (a, b)| {
        let d = (a - b).abs();
        if d.is_finite() {
            m.max(d)
        } else {
            f64::INFINITY
        }
    })
}

/// `x₀ ≥ 1` and `x₀ + ε x₁ ≥ 1 + 0.3 ε` (ε = 1e-5), both in the support: independent
/// rows whose smallest singular value (about ε/√2) is below `√δ`, with the solution
/// `d = (1, 0.3)`. Refinement contracts along that singular vector by
/// `δ/(σ² + δ) ≈ 0.95` a step and stops unsolved; conjugate gradients solve it.
pub(super) fn nearly_dependent() -> (ProjectionProblem, Vec<f64>) {
    let e = 1e-5;
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, e)]]);
    let b = vec![1.0, 1.0 + 0.3 * e];
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, b.clone()).unwrap();
    (p, [vec![0.0, 0.0], b].concat())
}
