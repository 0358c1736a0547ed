//! Active-set polishing of an interior-point answer.
//!
//! An interior-point iterate approaches the solution from inside the cone. On a row that is
//! *weakly* active at the solution (tight, with a zero multiplier) both the slack and the
//! multiplier only go to zero like `√μ`, so the point stays off by about the square root of
//! the duality gap (`1e-5` for a gap of `1e-10`) however small the KKT residuals are.
//! Polishing guesses the active set `S` from the iterate (rows whose multiplier exceeds their
//! slack) and solves the projection onto the affine set `{A_S x = b_S}` directly:
//!
//! ```text
//!     [ I    A_Sᵀ ] [ d  ]   [ 0   ]
//!     [ A_S  0    ] [ −λ ] = [ r_S ],     r = b − A y,
//! ```
//!
//! by an `LDLᵀ` factorization of the regularized, quasi-definite matrix (lower-right block
//! `−δI`) followed by iterative refinement against the unregularized one. If `S` contains
//! every row with a positive multiplier and only rows tight at the solution, the answer is
//! exact: the true projection lies on `{A_S x = b_S}` and differs from `y` by a combination
//! of the rows of `A_S`, which characterizes the projection onto that affine set. The caller
//! keeps the polished answer only when its KKT residuals are no larger than the iterate's.

use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
use sweeping_api::ProjectionProblem;

/// Regularization of the lower-right block, removed again by iterative refinement.
const DELTA: f64 = 1e-9;
/// Most refinement steps.
const REFINE_STEPS: usize = 50;
/// Refinement stops when the residual of the unregularized system falls below this, relative
/// to `max(1, ‖r_S‖∞)`.
const REFINE_TOL: f64 = 1e-13;

/// Rows of `A` restricted to `active`, each with its columns sorted and repeats summed.
fn active_rows(problem: &ProjectionProblem, active: &[usize]) -> Vec<Vec<(usize, f64)>> {
    active
        .iter()
        .map(|&r| {
            let mut row: Vec<(usize, f64)> = problem.a().row(r).collect();
            row.sort_by_key(|&(c, _)| c);
            let mut merged: Vec<(usize, f64)> = Vec::with_capacity(row.len());
            for (c, v) in row {
                match merged.last_mut() {
                    Some(last) if last.0 == c => last.1 += v,
                    _ => merged.push((c, v)),
                }
            }
            merged
        })
        .collect()
}

/// `out = K₀ v` for `K₀ = [I A_Sᵀ; A_S 0]`.
fn apply_kkt(n: usize, rows: &[Vec<(usize, f64)>], v: &[f64], out: &mut [f64]) {
    out[..n].copy_from_slice(&v[..n]);
    for (t, row) in rows.iter().enumerate() {
        let mu = v[n + t];
        let mut ad = 0.0;
        for &(c, a) in row {
            out[c] += a * mu;
            ad += a * v[c];
        }
        out[n + t] = ad;
    }
}

/// Most active-set guesses tried: rows that end with a negative multiplier are dropped and
/// the projection is solved again.
const ROUNDS: usize = 4;

/// The polished answer `(x, λ)` from an interior-point answer `x_ipm` with multipliers `z`
/// and slacks `s = A x − b`, or `None` when a factorization fails or the result is not
/// finite.
///
/// The active set starts as the rows with `zᵢ > sᵢ`. Iterative refinement from the starting
/// point `(x_ipm − y, z_S)` is the proximal-point method on the multipliers, so when the
/// active rows are linearly dependent (a degenerate vertex: their multipliers are not unique)
/// it returns the multipliers nearest to `z`, which are non-negative when `z` is not tiny.
/// Rows that still end with a negative multiplier are dropped and the projection solved
/// again, at most [`ROUNDS`] times. When refinement does not converge (the equations of the
/// guessed rows are inconsistent, or too ill-conditioned), the multipliers are not trusted to
/// drop rows and the answer is returned as it is, for the caller to judge.
pub(crate) fn polish(
    problem: &ProjectionProblem,
    x_ipm: &[f64],
    z: &[f64],
    s: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let m = problem.n_rows();
    let mut active: Vec<usize> = (0..m).filter(|&i| z[i] > s[i]).collect();
    let mut answer = None;
    for _ in 0..ROUNDS {
        let (x, lambda, converged) = solve_active(problem, &active, x_ipm, z)?;
        let kept: Vec<usize> = active
            .iter()
            .copied()
            .filter(|&r| lambda[r] >= 0.0)
            .collect();
        let done = !converged || kept.len() == active.len();
        answer = Some((x, lambda));
        if done {
            break;
        }
        active = kept;
    }
    answer
}

/// The projection of `y` onto `{A_S x = b_S}`, its multipliers (zero off `S`), and whether
/// iterative refinement from `(x_ipm − y, z_S)` converged.
fn solve_active(
    problem: &ProjectionProblem,
    active: &[usize],
    x_ipm: &[f64],
    z: &[f64],
) -> Option<(Vec<f64>, Vec<f64>, bool)> {
    let n = problem.dim();
    let m = problem.n_rows();
    let k = active.len();
    let rows = active_rows(problem, active);

    // Upper triangle of K_δ = [I A_Sᵀ; A_S −δI], by columns.
    let nnz = n + k + rows.iter().map(Vec::len).sum::<usize>();
    let mut colptr = Vec::with_capacity(n + k + 1);
    let mut rowval = Vec::with_capacity(nnz);
    let mut nzval = Vec::with_capacity(nnz);
    colptr.push(0);
    for j in 0..n {
        rowval.push(j);
        nzval.push(1.0);
        colptr.push(rowval.len());
    }
    for (t, row) in rows.iter().enumerate() {
        for &(c, a) in row {
            rowval.push(c);
            nzval.push(a);
        }
        rowval.push(n + t);
        nzval.push(-DELTA);
        colptr.push(rowval.len());
    }
    let kkt = CscMatrix::new(n + k, n + k, colptr, rowval, nzval);
    let signs: Vec<i8> = (0..n + k).map(|i| if i < n { 1 } else { -1 }).collect();
    let settings = QDLDLSettingsBuilder::default().Dsigns(signs).build().ok()?;
    let mut ldl = QDLDLFactorisation::new(&kkt, Some(settings)).ok()?;

    // Right-hand side [0; r_S] with r = b − A y.
    let mut rhs = vec![0.0; n + k];
    for (t, (&r, row)) in active.iter().zip(&rows).enumerate() {
        let ay: f64 = row.iter().map(|&(c, a)| a * problem.y()[c]).sum();
        rhs[n + t] = problem.b()[r] - ay;
    }
    let scale = rhs.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
    if !scale.is_finite() {
        return None;
    }
    // Start from the interior-point answer: d = x_ipm − y, and the unknown is −λ.
    let mut v: Vec<f64> = x_ipm
        .iter()
        .zip(problem.y())
        .map(|(x, y)| x - y)
        .chain(active.iter().map(|&r| -z[r]))
        .collect();
    let mut kv = vec![0.0; n + k];
    let mut step = vec![0.0; n + k];
    let mut converged = false;
    for _ in 0..=REFINE_STEPS {
        apply_kkt(n, &rows, &v, &mut kv);
        let mut worst: f64 = 0.0;
        for ((st, r), kvi) in step.iter_mut().zip(&rhs).zip(&kv) {
            *st = r - kvi;
            worst = worst.max(st.abs());
        }
        if worst.is_nan() {
            return None;
        }
        if worst <= REFINE_TOL * scale {
            converged = true;
            break;
        }
        ldl.solve(&mut step);
        v.iter_mut().zip(&step).for_each(|(vi, si)| *vi += si);
    }

    let x: Vec<f64> = problem
        .y()
        .iter()
        .zip(&v[..n])
        .map(|(y, d)| y + d)
        .collect();
    let mut lambda = vec![0.0; m];
    for (t, &r) in active.iter().enumerate() {
        lambda[r] = -v[n + t];
    }
    if x.iter().chain(&lambda).all(|v| v.is_finite()) {
        Some((x, lambda, converged))
    } else {
        None
    }
}
