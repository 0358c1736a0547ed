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
//! by an `LDLᵀ` factorization (QDLDL, with AMD ordering) of the quasi-definite matrix whose
//! lower-right block is `−δI`, followed by iterative refinement against the unregularized
//! matrix, started from the current `(d, λ)`. Refinement is the proximal-point method on the
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
//! The same method polishes Clarabel's interior-point answers (started from the interior-point
//! guess, see the crate documentation) and is the whole of the native backend
//! (`sweeping-native`, started from the previous step's active set or from the rows violated
//! at `y`): one implementation, two starts.

use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
use std::collections::HashMap;
use sweeping_api::ProjectionProblem;

/// How often the same working set may be factored before the method is declared cycling.
const REPEATS: u32 = 3;
/// Regularization of the lower-right block, removed again by iterative refinement.
const DELTA: f64 = 1e-9;
/// Most refinement steps per factorization.
const REFINE_STEPS: usize = 50;
/// Refinement stops when the residual of the unregularized system, or the change of its first
/// block, falls below this, relative to `max(1, ‖right-hand side‖∞)`.
const REFINE_TOL: f64 = 1e-13;
/// The equations of the support are taken as inconsistent, and a row outside it as violated,
/// beyond this, relative to `max(1, ‖r‖∞)`.
const ACTIVE_TOL: f64 = 1e-12;

/// Where the method starts.
#[derive(Debug, Clone)]
pub struct Start {
    /// The starting support (row indices, increasing).
    pub support: Vec<usize>,
    /// A positive starting multiplier per row of the support.
    pub lambda: Vec<f64>,
    /// For every row, the positive multiplier it starts from if it joins the support later.
    pub join: Vec<f64>,
}

/// A converged answer.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The point `y + d`.
    pub x: Vec<f64>,
    /// One multiplier per row (zero off the support).
    pub lambda: Vec<f64>,
    /// Factorizations spent.
    pub factorizations: u32,
}

/// Why no answer came out.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// Factorization failed or numbers stopped being finite.
    Numerical(&'static str),
    /// The cap on factorizations was reached.
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
    factor: Factor,
}

/// Supports of at most this many rows are factored densely, by the Schur complement
/// `A_P A_Pᵀ + δI` (`k × k`): a contact cluster of a few people costs a few microseconds that
/// way, where the sparse path pays for building, ordering and analysing a matrix of size
/// `n + k` every time.
const DENSE_MAX: usize = 24;

/// Relative size of the smallest Cholesky pivot accepted on the dense path.
const DENSE_PIVOT: f64 = 1e-6;

/// The factors of `K_δ = [I A_Pᵀ; A_P −δI]`.
enum Factor {
    /// Sparse `LDLᵀ` of `K_δ` itself.
    Sparse(Box<QDLDLFactorisation<f64>>),
    /// Dense Cholesky factor `L` (row-major, lower triangle) of `S = A_P A_Pᵀ + δI`.
    Dense(Vec<f64>),
}

/// The dense Cholesky factor (row-major `k × k`, lower triangle) of `A_P A_Pᵀ + δI`, the rows
/// given with sorted columns; `None` when a row is nearly a combination of the ones before
/// it (its pivot below [`DENSE_PIVOT`] times its diagonal entry). Such rows (a contact loop)
/// make `S` as ill-conditioned as `1/δ`, and the sparse `LDLᵀ` of `K_δ` is used instead.
fn schur_cholesky(rows: &[Vec<(usize, f64)>]) -> Option<Vec<f64>> {
    let k = rows.len();
    let dot = |a: &[(usize, f64)], b: &[(usize, f64)]| {
        let (mut i, mut j, mut sum) = (0, 0, 0.0);
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    sum += a[i].1 * b[j].1;
                    i += 1;
                    j += 1;
                }
            }
        }
        sum
    };
    let mut l = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..=i {
            let diagonal = dot(&rows[i], &rows[j]) + if i == j { DELTA } else { 0.0 };
            let mut v = diagonal;
            for p in 0..j {
                v -= l[i * k + p] * l[j * k + p];
            }
            if i == j {
                if v.is_nan() || v <= DENSE_PIVOT * diagonal {
                    return None;
                }
                l[i * k + i] = v.sqrt();
            } else {
                l[i * k + j] = v / l[j * k + j];
            }
        }
    }
    Some(l)
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
    /// Factors `K_δ` for the rows `active` (increasing); `None` when the factorization fails.
    /// `order`, when given, is a fill-reducing ordering of the matrix with *every* row of the
    /// problem; the ordering of `K_δ` is its restriction to the unknowns and `active`.
    fn new(problem: &ProjectionProblem, active: &[usize], order: Option<&[usize]>) -> Option<Self> {
        let n = problem.dim();
        let k = active.len();
        if k <= DENSE_MAX {
            let rows = active_rows(problem, active);
            if let Some(l) = schur_cholesky(&rows) {
                return Some(Self {
                    n,
                    rows,
                    factor: Factor::Dense(l),
                });
            }
        }
        let (rows, kkt) = kkt_matrix(problem, active);
        let signs: Vec<i8> = (0..n + k).map(|i| if i < n { 1 } else { -1 }).collect();
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(signs);
        if let Some(order) = order {
            // Position of each row of the problem in `active`, then the restriction.
            let mut slot = vec![usize::MAX; problem.n_rows()];
            for (t, &i) in active.iter().enumerate() {
                slot[i] = t;
            }
            let perm: Vec<usize> = order
                .iter()
                .filter_map(|&v| {
                    if v < n {
                        Some(v)
                    } else {
                        let t = slot[v - n];
                        (t != usize::MAX).then(|| n + t)
                    }
                })
                .collect();
            builder.perm(perm);
        }
        let settings = builder.build().ok()?;
        let ldl = QDLDLFactorisation::new(&kkt, Some(settings)).ok()?;
        Some(Self {
            n,
            rows,
            factor: Factor::Sparse(Box::new(ldl)),
        })
    }

    /// `v ← K_δ⁻¹ v`. Densely: `[u; w]` with `u + A_Pᵀw = f`, `A_P u − δw = g` gives
    /// `(A_P A_Pᵀ + δI) w = A_P f − g` and `u = f − A_Pᵀw`.
    fn solve_in_place(&mut self, v: &mut [f64]) {
        match &mut self.factor {
            Factor::Sparse(ldl) => ldl.solve(v),
            Factor::Dense(l) => {
                let (n, k) = (self.n, self.rows.len());
                let (f, g) = v.split_at_mut(n);
                // w ← A f − g, then the two triangular solves with L and Lᵀ.
                for (t, row) in self.rows.iter().enumerate() {
                    g[t] = row.iter().map(|&(c, a)| a * f[c]).sum::<f64>() - g[t];
                }
                for i in 0..k {
                    let mut s = g[i];
                    for p in 0..i {
                        s -= l[i * k + p] * g[p];
                    }
                    g[i] = s / l[i * k + i];
                }
                for i in (0..k).rev() {
                    let mut s = g[i];
                    for p in i + 1..k {
                        s -= l[p * k + i] * g[p];
                    }
                    g[i] = s / l[i * k + i];
                }
                for (t, row) in self.rows.iter().enumerate() {
                    for &(c, a) in row {
                        f[c] -= a * g[t];
                    }
                }
            }
        }
    }
}

/// A fill-reducing (AMD) ordering of `K_δ` with every row of the problem, computed once per
/// block so that each working set's factorization skips its own ordering (the restriction of
/// an elimination order to a subset of the vertices fills no more than the whole).
pub fn full_ordering(problem: &ProjectionProblem) -> Option<Vec<usize>> {
    let all: Vec<usize> = (0..problem.n_rows()).collect();
    let (_, kkt) = kkt_matrix(problem, &all);
    let settings = QDLDLSettingsBuilder::default().logical(true).build().ok()?;
    let ldl = QDLDLFactorisation::new(&kkt, Some(settings)).ok()?;
    Some(ldl.perm.clone())
}

/// The rows `active` (sorted, repeats summed) and the upper triangle of their `K_δ`, by columns.
fn kkt_matrix(
    problem: &ProjectionProblem,
    active: &[usize],
) -> (Vec<Vec<(usize, f64)>>, CscMatrix<f64>) {
    {
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
        (rows, kkt)
    }
}

impl ActiveSystem {
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
            self.solve_in_place(&mut step);
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

/// Checks the Farkas certificate `e ≥ 0`, `A_Pᵀe = 0`, `eᵀr_P > 0` of an empty polyhedron,
/// with room for rounding relative to the size of the numbers involved.
fn farkas(problem: &ProjectionProblem, support: &[usize], e: &[f64], r: &[f64]) -> bool {
    let emax = e.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
    if emax == 0.0 || !emax.is_finite() || e.iter().any(|&v| v < -1e-12 * emax) {
        return false;
    }
    let mut ate = vec![0.0; problem.dim()];
    let mut amax: f64 = 0.0;
    for (&i, &ei) in support.iter().zip(e) {
        for (c, v) in problem.a().row(i) {
            ate[c] += v * ei.max(0.0);
            amax = amax.max(v.abs());
        }
    }
    let ate_max = ate.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
    let er: f64 = support
        .iter()
        .zip(e)
        .map(|(&i, &ei)| ei.max(0.0) * r[i])
        .sum();
    let rmax = support.iter().fold(0.0, |acc: f64, &i| acc.max(r[i].abs()));
    // Aᵀe vanishes to rounding while eᵀr is clearly positive: no x can satisfy eᵀA x ≥ eᵀb.
    ate_max <= 1e-9 * emax * amax.max(1.0) * (support.len() as f64).sqrt()
        && er > 1e-6 * emax * rmax
}

/// Runs the method from `start` for at most `cap` factorizations. See the module
/// documentation.
pub fn solve(problem: &ProjectionProblem, start: Start, cap: u32) -> Result<Outcome, Failure> {
    // Small blocks are ordered per factorization; larger ones once.
    let order = if problem.n_rows() > 8 {
        full_ordering(problem)
    } else {
        None
    };
    let (m, n) = (problem.n_rows(), problem.dim());
    // r = b − A y.
    let mut r = vec![0.0; m];
    problem.a().mul_vec(problem.y(), &mut r);
    r.iter_mut()
        .zip(problem.b())
        .for_each(|(ri, bi)| *ri = bi - *ri);
    if r.iter().any(|v| !v.is_finite()) {
        return Err(Failure::Numerical("b − A y overflows"));
    }
    let Start {
        mut support,
        mut lambda,
        join,
    } = start;
    let scale = r.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
    let tol = ACTIVE_TOL * scale;
    // d = A_Pᵀλ: the displacement the starting multipliers describe.
    let mut d = vec![0.0; n];
    for (&i, &l) in support.iter().zip(&lambda) {
        for (c, v) in problem.a().row(i) {
            d[c] += v * l;
        }
    }
    let mut aggressive = true;
    // Set when the method restarted as Lawson–Hanson proper: from an empty support, one row
    // (the steepest) joining at a time, starting at a zero multiplier.
    let mut proper = false;
    let mut visits: HashMap<Vec<usize>, u32> = HashMap::new();
    let mut in_support = vec![false; m];
    let mut ad = vec![0.0; m];
    for factorizations in 1..=cap {
        let count = visits.entry(support.clone()).or_insert(0);
        *count += 1;
        if *count >= REPEATS {
            if proper {
                return Err(Failure::Cycling(factorizations));
            }
            // The warm, many-rows-at-once variant cycled (heavily dependent rows): restart
            // as Lawson–Hanson proper, which terminates finitely in exact arithmetic.
            proper = true;
            aggressive = false;
            visits.clear();
            support.clear();
            lambda.clear();
            d.iter_mut().for_each(|v| *v = 0.0);
        }
        let mut system = ActiveSystem::new(problem, &support, order.as_deref())
            .ok_or(Failure::Numerical("factorization"))?;
        let k = support.len();
        let rhs: Vec<f64> = std::iter::repeat_n(0.0, n)
            .chain(support.iter().map(|&i| r[i]))
            .collect();
        let mut v: Vec<f64> = d.iter().copied().chain(lambda.iter().map(|l| -l)).collect();
        let refined = system
            .refine(&rhs, &mut v)
            .ok_or(Failure::Numerical("refinement"))?;
        d.copy_from_slice(&v[..n]);
        let mu: Vec<f64> = v[n..].iter().map(|v| -v).collect();

        if !refined.solved && refined.second > tol {
            // Inconsistent: follow the ray λ + t e until an entry reaches zero.
            let e = &refined.residual;
            let Some((blocking, t)) = lambda
                .iter()
                .zip(e)
                .enumerate()
                .filter(|(_, (_, ei))| **ei < 0.0)
                .map(|(j, (l, ei))| (j, l / -ei))
                .min_by(|a, b| a.1.total_cmp(&b.1))
            else {
                return Err(if farkas(problem, &support, e, &r) {
                    Failure::Infeasible { rows: support }
                } else {
                    Failure::Numerical("unbounded ray without an infeasibility certificate")
                });
            };
            let step: Vec<f64> = lambda.iter().zip(e).map(|(l, ei)| l + t * ei).collect();
            (support, lambda) = shrink(&support, &step, blocking);
            // The point of the smaller support is recomputed from its multipliers.
            continue;
        }
        if !d.iter().chain(&mu).all(|v| v.is_finite()) {
            return Err(Failure::Numerical("non-finite step"));
        }

        // Negative multipliers (beyond rounding): rows leave the support.
        if let Some(smaller) = drop_negative(&support, &lambda, &mu, tol, aggressive)? {
            (support, lambda) = smaller;
            continue;
        }
        lambda = mu.iter().map(|m| m.max(f64::MIN_POSITIVE)).collect();

        // Rows outside the support that the point violates join it.
        problem.a().mul_vec(&d, &mut ad);
        in_support.iter_mut().for_each(|s| *s = false);
        support.iter().for_each(|&i| in_support[i] = true);
        let violated: Vec<usize> = (0..m)
            .filter(|&i| !in_support[i] && r[i] - ad[i] > tol)
            .collect();
        if violated.is_empty() {
            let x: Vec<f64> = problem.y().iter().zip(&d).map(|(y, d)| y + d).collect();
            let mut full = vec![0.0; m];
            support
                .iter()
                .zip(&mu)
                .for_each(|(&i, &l)| full[i] = l.max(0.0));
            return Ok(Outcome {
                x,
                lambda: full,
                factorizations,
            });
        }
        // From now on, drop one row at a time: dropping every negative row at once could
        // cycle with adding them back.
        aggressive = false;
        let mut joined: Vec<(usize, f64)> = support.iter().copied().zip(lambda).collect();
        joined.extend(joining_rows(&violated, &r, &ad, &join, proper)?);
        joined.sort_unstable_by_key(|&(i, _)| i);
        (support, lambda) = joined.into_iter().unzip();
        debug_assert!(support.len() > k);
    }
    Err(Failure::Cap(cap))
}

/// A support (row indices, increasing) and a positive multiplier per row.
type Support = (Vec<usize>, Vec<f64>);

/// When some multiplier `μ` of the support is negative beyond rounding, the smaller support
/// and its multipliers: every such row at once (`aggressive`, before any row has joined), or
/// Lawson–Hanson's step from `λ` toward `μ` until the first entry reaches zero. `None` when
/// every `μ` is non-negative.
fn drop_negative(
    support: &[usize],
    lambda: &[f64],
    mu: &[f64],
    tol: f64,
    aggressive: bool,
) -> Result<Option<Support>, Failure> {
    let floor = -tol * mu.iter().fold(1.0, |acc: f64, m| acc.max(m.abs()));
    if !mu.iter().any(|&m| m < floor) {
        return Ok(None);
    }
    if aggressive {
        return Ok(Some(
            support
                .iter()
                .zip(mu)
                .filter(|(_, &m)| m >= floor)
                .map(|(&i, &m)| (i, m.max(f64::MIN_POSITIVE)))
                .unzip(),
        ));
    }
    let (blocking, alpha) = lambda
        .iter()
        .zip(mu)
        .enumerate()
        .filter(|(_, (_, m))| **m < 0.0)
        .map(|(j, (l, m))| (j, l / (l - m)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .ok_or(Failure::Numerical("no blocking multiplier"))?;
    let step: Vec<f64> = lambda
        .iter()
        .zip(mu)
        .map(|(l, m)| l + alpha * (m - l))
        .collect();
    Ok(Some(shrink(support, &step, blocking)))
}

/// The violated rows that join the support, with their starting multipliers: all of them
/// from their remembered multipliers, or (Lawson–Hanson `proper`) only the steepest descent
/// direction of the dual, the largest `rᵢ − aᵢ·d`, from zero.
fn joining_rows(
    violated: &[usize],
    r: &[f64],
    ad: &[f64],
    join: &[f64],
    proper: bool,
) -> Result<Vec<(usize, f64)>, Failure> {
    if proper {
        let steepest = violated
            .iter()
            .copied()
            .max_by(|&a, &b| (r[a] - ad[a]).total_cmp(&(r[b] - ad[b])))
            .ok_or(Failure::Numerical("no steepest row"))?;
        Ok(vec![(steepest, f64::MIN_POSITIVE)])
    } else {
        Ok(violated
            .iter()
            .map(|&i| (i, join[i].max(f64::MIN_POSITIVE)))
            .collect())
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::SparseRows;

    /// `x₀ + x₁ ≥ 1`, `−x₀ ≥ 0`, `−x₁ ≥ 0` (empty) and `x₀ ≥ 0.5` (feasible on its own).
    fn problem() -> (ProjectionProblem, Vec<f64>) {
        let a = SparseRows::from_rows(
            2,
            &[
                vec![(0, 1.0), (1, 1.0)],
                vec![(0, -1.0)],
                vec![(1, -1.0)],
                vec![(0, 1.0)],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 0.0, 0.0, 0.5]).unwrap();
        // r = b − A y with y = 0.
        let r = p.b().to_vec();
        (p, r)
    }

    #[test]
    fn farkas_accepts_a_certificate() {
        let (p, r) = problem();
        assert!(farkas(&p, &[0, 1, 2], &[1.0, 1.0, 1.0], &r));
        // Scaled, and with rounding-size negative entries.
        assert!(farkas(&p, &[0, 1, 2], &[3.0, 3.0, 3.0 - 1e-15], &r));
    }

    #[test]
    fn farkas_rejects_what_is_not_a_certificate() {
        let (p, r) = problem();
        // Aᵀe ≠ 0.
        assert!(!farkas(&p, &[0, 1, 2], &[1.0, 1.0, 0.5], &r));
        // A clearly negative weight.
        assert!(!farkas(&p, &[0, 1, 2], &[1.0, -1.0, 1.0], &r));
        // Zero, non-finite.
        assert!(!farkas(&p, &[0, 1, 2], &[0.0, 0.0, 0.0], &r));
        assert!(!farkas(&p, &[0, 1, 2], &[f64::NAN, 1.0, 1.0], &r));
        assert!(!farkas(&p, &[0, 1, 2], &[f64::INFINITY, 1.0, 1.0], &r));
        // Aᵀe = 0 but eᵀr < 0: rows −x₀ ≥ 0 and x₀ ≥ −1 (r = b − A·0 = (0, −1)) can both
        // hold.
        let r2 = vec![1.0, 0.0, 0.0, -1.0];
        assert!(!farkas(&p, &[1, 3], &[1.0, 1.0], &r2));
    }

    #[test]
    fn shrink_drops_the_blocking_row_and_non_positive_ones() {
        let (support, lambda) = shrink(&[4, 7, 9, 12], &[0.5, 0.0, 2.0, -1e-300], 2);
        assert_eq!(support, vec![4]);
        assert_eq!(lambda, vec![0.5]);
        let (support, lambda) = shrink(&[1, 2], &[1.0, 3.0], 0);
        assert_eq!((support, lambda), (vec![2], vec![3.0]));
    }
}
