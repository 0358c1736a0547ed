//! Active-set polishing of an interior-point answer.
//!
//! An interior-point iterate approaches the solution from inside the cone. On a row that is
//! *weakly* active at the solution (tight, with a zero multiplier) both the slack and the
//! multiplier only go to zero like `√μ`, so the point stays off by about the square root of
//! the duality gap (`1e-5` for a gap of `1e-10`) however small the KKT residuals are.
//! Polishing guesses the active set from the iterate and finishes the job exactly.
//!
//! # The method
//!
//! The projection is `d = x − y = Aᵀλ` with `λ` solving the dual problem
//!
//! ```text
//!     min ½‖Aᵀλ‖² − λᵀr   over λ ≥ 0,     r = b − A y,
//! ```
//!
//! and polishing runs the Lawson–Hanson active-set method on it, warm-started from the
//! interior-point answer: the support `P` starts as the rows whose multiplier exceeds their
//! slack (`zᵢ > sᵢ`), and `λ` as their multipliers `z_P > 0`. Each step solves the
//! equality-constrained projection on `P`,
//!
//! ```text
//!     [ I    A_Pᵀ ] [ d  ]   [ 0   ]
//!     [ A_P  0    ] [ −μ ] = [ r_P ],
//! ```
//!
//! by an `LDLᵀ` factorization of the regularized, quasi-definite matrix (lower-right block
//! `−δI`) followed by iterative refinement against the unregularized one, started from the
//! current `(d, λ)`. Refinement is the proximal-point method on the multipliers, so when the
//! rows of `A_P` are linearly dependent (a *contact loop*: a cycle of touching disks) it
//! still converges to the unique point `d` and to the least-squares multipliers `μ` nearest
//! `λ`. Then:
//!
//! - if the equations `A_P d = r_P` are inconsistent (their least-squares residual
//!   `e = r_P − A_P d` exceeds a tolerance), the rows cannot all be tight: `e` lies in the
//!   null space of `A_Pᵀ` and is a direction along which the dual objective decreases without
//!   bound on `P`. `λ` moves along it until its first entry reaches zero, and that row leaves
//!   `P`. (Refinement itself would drift along `e / δ` per step, by `0.1` on a crowd, which
//!   is why it stops as soon as `d` stops moving.)
//! - otherwise, if some `μ` is negative (beyond rounding), `λ` moves toward `μ` until its
//!   first entry reaches zero, and that row leaves `P`. On dependent rows, whose multipliers
//!   are not unique, this redistributes them without moving `d`, so a row leaves `P` only
//!   when no non-negative multipliers exist on `P`, not merely because the least-squares ones
//!   came out negative. As long as no row has had to join `P` (below), every row with a
//!   negative `μ` is dropped at once instead, saving a factorization per row when the guess
//!   holds several contacts that are nearly but not exactly tight (eighteen on a step of the
//!   corridor scene); a row wrongly dropped that way is violated by the new point and joins
//!   again, and from then on rows leave one at a time;
//! - otherwise the rows outside `P` that `d` violates join it (a weakly active row can have
//!   its multiplier below its slack), starting from their interior-point multipliers;
//! - when there are none, `(y + d, μ)` satisfies the KKT conditions: it is the projection.
//!
//! At most [`FACTORIZATIONS`] steps are taken; the last consistent answer is returned and the
//! caller keeps it only when its KKT residuals are small enough (see the crate
//! documentation).

use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
use sweeping_api::ProjectionProblem;

/// Regularization of the lower-right block, removed again by iterative refinement.
const DELTA: f64 = 1e-9;
/// Most refinement steps.
const REFINE_STEPS: usize = 50;
/// Refinement stops when the residual of the unregularized system, or the change of its first
/// block, falls below this, relative to `max(1, ‖right-hand side‖∞)`.
const REFINE_TOL: f64 = 1e-13;
/// Most active-set steps (each costs one factorization).
const FACTORIZATIONS: usize = 40;
/// The equations of the support are taken as inconsistent, and a row outside it as violated,
/// beyond this, relative to `max(1, ‖r_S‖∞)` over the starting support `S`.
const ACTIVE_TOL: f64 = 1e-12;

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

/// The KKT system `K₀ = [I A_Pᵀ; A_P 0]` of a set of rows `P`, with the `LDLᵀ` factors of its
/// regularization `K_δ = [I A_Pᵀ; A_P −δI]`.
struct ActiveSystem {
    n: usize,
    rows: Vec<Vec<(usize, f64)>>,
    ldl: QDLDLFactorisation<f64>,
}

/// Where iterative refinement stopped.
struct Refined {
    /// `‖residual‖∞` of the second block.
    second: f64,
    /// Whether the whole residual met the tolerance.
    solved: bool,
    /// The second block of the residual, `r_P − A_P d` for the right-hand side `[0; r_P]`.
    residual: Vec<f64>,
}

impl ActiveSystem {
    /// Factors `K_δ` for the rows `active`; `None` when the factorization fails.
    fn new(problem: &ProjectionProblem, active: &[usize]) -> Option<Self> {
        let n = problem.dim();
        let k = active.len();
        let rows = active_rows(problem, active);
        // Upper triangle of K_δ, by columns.
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
        let ldl = QDLDLFactorisation::new(&kkt, Some(settings)).ok()?;
        Some(Self { n, rows, ldl })
    }

    /// `out = K₀ v`.
    fn apply(&self, v: &[f64], out: &mut [f64]) {
        let n = self.n;
        out[..n].copy_from_slice(&v[..n]);
        for (t, row) in self.rows.iter().enumerate() {
            let mu = v[n + t];
            let mut ad = 0.0;
            for &(c, a) in row {
                out[c] += a * mu;
                ad += a * v[c];
            }
            out[n + t] = ad;
        }
    }

    /// Iterative refinement of `K₀ v = rhs` from `v`, until the residual is below
    /// [`REFINE_TOL`] (relative), the first block of `v` stops moving by more than that, or
    /// [`REFINE_STEPS`] steps. `None` when the numbers stop being finite.
    fn refine(&mut self, rhs: &[f64], v: &mut [f64]) -> Option<Refined> {
        let n = self.n;
        let scale = rhs.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
        if !scale.is_finite() {
            return None;
        }
        let tol = REFINE_TOL * scale;
        let mut kv = vec![0.0; rhs.len()];
        let mut step = vec![0.0; rhs.len()];
        let mut steps = 0;
        loop {
            self.apply(v, &mut kv);
            let (mut first, mut second): (f64, f64) = (0.0, 0.0);
            for (i, ((st, r), kvi)) in step.iter_mut().zip(rhs).zip(&kv).enumerate() {
                *st = r - kvi;
                if i < n {
                    first = first.max(st.abs());
                } else {
                    second = second.max(st.abs());
                }
            }
            if first.is_nan() || second.is_nan() {
                return None;
            }
            let solved = first.max(second) <= tol;
            if solved || steps == REFINE_STEPS {
                return Some(Refined {
                    second,
                    solved,
                    residual: step[n..].to_vec(),
                });
            }
            self.ldl.solve(&mut step);
            let moved = step[..n].iter().fold(0.0, |acc: f64, s| acc.max(s.abs()));
            v.iter_mut().zip(&step).for_each(|(vi, si)| *vi += si);
            steps += 1;
            if moved <= tol {
                // The first block has converged; one more pass measures the residual.
                steps = REFINE_STEPS;
            }
        }
    }
}

/// The polished answer `(x, λ)` from an interior-point answer `x_ipm` with multipliers `z`
/// and slacks `s = A x − b`, or `None` when a factorization fails, the result is not finite,
/// or no step reached consistent equations. See the module documentation for the method.
pub(crate) fn polish(
    problem: &ProjectionProblem,
    x_ipm: &[f64],
    z: &[f64],
    s: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let (m, n) = (problem.n_rows(), problem.dim());
    // r = b − A y.
    let mut r = vec![0.0; m];
    problem.a().mul_vec(problem.y(), &mut r);
    r.iter_mut()
        .zip(problem.b())
        .for_each(|(ri, bi)| *ri = bi - *ri);

    let mut support: Vec<usize> = (0..m).filter(|&i| z[i] > s[i]).collect();
    let mut lambda: Vec<f64> = support.iter().map(|&i| z[i].max(0.0)).collect();
    let scale = support.iter().fold(1.0, |acc: f64, &i| acc.max(r[i].abs()));
    let tol = ACTIVE_TOL * scale;
    let mut d: Vec<f64> = x_ipm.iter().zip(problem.y()).map(|(x, y)| x - y).collect();
    let mut answer = None;
    let mut aggressive = true;
    for _ in 0..FACTORIZATIONS {
        let mut system = ActiveSystem::new(problem, &support)?;
        let k = support.len();
        let rhs: Vec<f64> = std::iter::repeat_n(0.0, n)
            .chain(support.iter().map(|&i| r[i]))
            .collect();
        let mut v: Vec<f64> = d.iter().copied().chain(lambda.iter().map(|l| -l)).collect();
        let refined = system.refine(&rhs, &mut v)?;
        d.copy_from_slice(&v[..n]);
        let mu: Vec<f64> = v[n..].iter().map(|v| -v).collect();

        if !refined.solved && refined.second > tol {
            // Inconsistent: follow the ray λ + t e until an entry reaches zero.
            let e = &refined.residual;
            let (blocking, t) = lambda
                .iter()
                .zip(e)
                .enumerate()
                .filter(|(_, (_, ei))| **ei < 0.0)
                .map(|(j, (l, ei))| (j, l / -ei))
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            let step: Vec<f64> = lambda.iter().zip(e).map(|(l, ei)| l + t * ei).collect();
            (support, lambda) = shrink(&support, &step, blocking);
            continue;
        }

        let x: Vec<f64> = problem.y().iter().zip(&d).map(|(y, d)| y + d).collect();
        let mut full = vec![0.0; m];
        support.iter().zip(&mu).for_each(|(&i, &l)| full[i] = l);
        if !x.iter().chain(&full).all(|v| v.is_finite()) {
            return None;
        }
        answer = Some((x, full));

        // Negative multipliers (beyond rounding).
        let floor = -tol * mu.iter().fold(1.0, |acc: f64, m| acc.max(m.abs()));
        if mu.iter().any(|&m| m < floor) {
            if aggressive {
                // First try: drop every such row at once (one factorization instead of one per
                // row when the guess holds several rows that are nearly but not exactly tight).
                (support, lambda) = support
                    .iter()
                    .zip(&mu)
                    .filter(|(_, &m)| m >= floor)
                    .map(|(&i, &m)| (i, m.max(f64::MIN_POSITIVE)))
                    .unzip();
                continue;
            }
            // Lawson–Hanson: step from λ toward μ until an entry reaches zero.
            let (blocking, alpha) = lambda
                .iter()
                .zip(&mu)
                .enumerate()
                .filter(|(_, (_, m))| **m < 0.0)
                .map(|(j, (l, m))| (j, l / (l - m)))
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            let step: Vec<f64> = lambda
                .iter()
                .zip(&mu)
                .map(|(l, m)| l + alpha * (m - l))
                .collect();
            (support, lambda) = shrink(&support, &step, blocking);
            continue;
        }
        lambda = mu.iter().map(|m| m.max(f64::MIN_POSITIVE)).collect();

        // Rows outside the support that the point violates join it.
        let mut ad = vec![0.0; m];
        problem.a().mul_vec(&d, &mut ad);
        let mut in_support = vec![false; m];
        support.iter().for_each(|&i| in_support[i] = true);
        let violated: Vec<usize> = (0..m)
            .filter(|&i| !in_support[i] && r[i] - ad[i] > tol)
            .collect();
        if violated.is_empty() {
            break;
        }
        // From now on, drop one row at a time: dropping every negative row at once could
        // cycle with adding them back.
        aggressive = false;
        let mut joined: Vec<(usize, f64)> = support.iter().copied().zip(lambda).collect();
        joined.extend(violated.iter().map(|&i| (i, z[i].max(f64::MIN_POSITIVE))));
        joined.sort_unstable_by_key(|&(i, _)| i);
        (support, lambda) = joined.into_iter().unzip();
        debug_assert!(support.len() > k);
    }
    answer
}

/// The support without its entry `blocking` and without any entry that `lambda` leaves
/// non-positive, with the remaining multipliers.
fn shrink(support: &[usize], lambda: &[f64], blocking: usize) -> (Vec<usize>, Vec<f64>) {
    support
        .iter()
        .zip(lambda)
        .enumerate()
        .filter(|&(j, (_, &l))| j != blocking && l > 0.0)
        .map(|(_, (&i, &l))| (i, l))
        .unzip()
}
