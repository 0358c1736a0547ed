//! A primal–dual interior-point method (Mehrotra's predictor–corrector) for one block of the
//! projection, on the normal equations: the identifier the active-set method is started from
//! when its own warm start does not converge.
//!
//! With `d = x − y` and `r = b − A y`, the projection is `min ½‖d‖²` subject to
//! `A d − s = r`, `s ≥ 0`; its KKT conditions are `d = Aᵀλ`, `A d − s = r`, `λ ∘ s = 0`,
//! `λ, s ≥ 0`. A Newton step on them with `λ ∘ s = σμ` eliminates `Δs = A Δd + r_p` and
//! `Δλ = −r_c/s − W (A Δd + r_p)`, `W = diag(λ/s)`, leaving
//!
//! ```text
//!     (I + AᵀWA) Δd = −r_d − Aᵀ(W r_p + r_c/s),
//! ```
//!
//! an `n × n` symmetric positive definite system (the identity comes from the objective, so
//! it is never singular, whatever the rows: contact loops included). Its pattern is that of
//! `I + AᵀA` at every iteration, so it is ordered (by AMD) and analysed once per block and
//! only refactored numerically after that (by `sweeping_clarabel`'s [`Refactor`], which also
//! keeps the pattern of each row of the factor: the same `LDLᵀ` code as the active-set
//! method's). Near the answer its weights `λ/s` span many orders of magnitude and its solves
//! lose accuracy; once the residuals grow instead of shrinking, each solve is refined once
//! against the matrix itself. A general interior-point solver factors the
//! `(n + m)`-square KKT matrix instead, with `m` (the candidate rows) about twice `n` on a jam.
//!
//! Interior points cannot be warm-started usefully, and they approach weakly active rows only
//! like `√μ`; the crate takes the iterate as the answer only when it passes the KKT check
//! well within the certificate's tolerance, and otherwise has the active-set method finish
//! from the rows whose multiplier exceeds their slack, exactly, as it polishes Clarabel's
//! answers.

use clarabel::algebra::CscMatrix;
use sweeping_api::SparseRows;
use sweeping_clarabel::ldl::{Ldl, Refactor};

/// Fraction of the step to the boundary that an iteration takes.
const TO_BOUNDARY: f64 = 0.99;

/// Where the method stopped: the converged iterate, or the most accurate one measured.
#[derive(Debug, Clone)]
pub(crate) struct Iterate {
    /// The multipliers `λ > 0`.
    pub lambda: Vec<f64>,
    /// The slacks `s = A d − r > 0` (up to the primal residual).
    pub slack: Vec<f64>,
    /// The multipliers one iteration before `lambda` (equal to them when there was none).
    /// With [`Self::previous_slack`], Tapia's indicators of which rows are active: as `μ → 0`
    /// an active row keeps its multiplier and its slack shrinks with `μ`, an inactive one the
    /// other way round (El-Bakry, Tapia & Zhang, 1994).
    pub previous_lambda: Vec<f64>,
    /// The slacks one iteration before `slack` (equal to them when there was none).
    pub previous_slack: Vec<f64>,
    /// Interior-point iterations (one factorization each).
    pub iterations: u32,
    /// Whether the duality measure and both residuals reached the tolerance.
    pub converged: bool,
    /// The largest of the duality measure and both residuals at this iterate (the
    /// tolerance's scale): how far a stalled run got.
    pub accuracy: f64,
}

/// The multipliers and slacks of an iterate.
type Previous = (Vec<f64>, Vec<f64>);

/// The normal matrix `I + AᵀWA`, its pattern fixed, and its factorization.
struct NormalMatrix {
    /// Upper triangle, compressed by columns.
    csc: CscMatrix<f64>,
    /// For each row of `A`, for each pair `k ≤ l` of its entries, where `aₖ aₗ` adds up…
    slots: Vec<usize>,
    /// …and `aₖ aₗ` itself.
    coefficients: Vec<f64>,
    /// Where each row's pairs start in `slots`.
    row_slots: Vec<usize>,
    /// Where the diagonal entries are.
    diagonal: Vec<usize>,
    /// The factorization, and the arithmetic that refactors it with new weights.
    factor: Option<(Ldl, Refactor)>,
}

impl NormalMatrix {
    fn new(a: &SparseRows) -> Self {
        let (m, n) = (a.n_rows(), a.n_cols());
        let (ptr, idx) = (a.row_ptr(), a.col_idx());
        // The rows touching each column (the transpose's pattern), by counting: every
        // column's entries of `I + AᵀA` are then gathered from its own rows, and only a
        // column's few entries are sorted, not every pair of the matrix at once (that sort
        // was most of this function on a jam's normal matrix).
        let mut col_start = vec![0usize; n + 1];
        for &c in idx {
            col_start[c + 1] += 1;
        }
        for j in 0..n {
            col_start[j + 1] += col_start[j];
        }
        let mut next = col_start.clone();
        let mut col_rows = vec![0usize; idx.len()];
        for i in 0..m {
            for &c in &idx[ptr[i]..ptr[i + 1]] {
                col_rows[next[c]] = i;
                next[c] += 1;
            }
        }
        // Column q holds the diagonal and every p < q that shares a row with q.
        let mut colptr = Vec::with_capacity(n + 1);
        colptr.push(0);
        let mut rowval = Vec::with_capacity(n + 2 * idx.len());
        let mut seen = vec![usize::MAX; n];
        for q in 0..n {
            let start = rowval.len();
            seen[q] = q;
            rowval.push(q);
            for &i in &col_rows[col_start[q]..col_start[q + 1]] {
                for &p in &idx[ptr[i]..ptr[i + 1]] {
                    if p < q && seen[p] != q {
                        seen[p] = q;
                        rowval.push(p);
                    }
                }
            }
            rowval[start..].sort_unstable();
            colptr.push(rowval.len());
        }
        let position = |row: usize, col: usize| -> usize {
            let range = colptr[col]..colptr[col + 1];
            range.start
                + rowval[range]
                    .binary_search(&row)
                    .expect("every pair was entered in the pattern")
        };
        let val = a.values();
        let pairs: usize = (0..m)
            .map(|i| {
                let t = ptr[i + 1] - ptr[i];
                t * (t + 1) / 2
            })
            .sum();
        let mut slots = Vec::with_capacity(pairs);
        let mut coefficients = Vec::with_capacity(pairs);
        let mut row_slots = Vec::with_capacity(m + 1);
        row_slots.push(0);
        for i in 0..m {
            for k in ptr[i]..ptr[i + 1] {
                for l in ptr[i]..ptr[i + 1] {
                    let (p, q) = (idx[k], idx[l]);
                    if p <= q {
                        slots.push(position(p, q));
                        coefficients.push(val[k] * val[l]);
                    }
                }
            }
            row_slots.push(slots.len());
        }
        let diagonal = (0..n).map(|j| position(j, j)).collect();
        let nnz = rowval.len();
        Self {
            csc: CscMatrix::new(n, n, colptr, rowval, vec![0.0; nnz]),
            slots,
            coefficients,
            row_slots,
            diagonal,
            factor: None,
        }
    }

    /// Fills `I + AᵀWA` and factors it. `false` when the factorization fails.
    fn factor(&mut self, w: &[f64]) -> bool {
        if !w.iter().all(|v| v.is_finite()) {
            return false;
        }
        let values = &mut self.csc.nzval;
        values.iter_mut().for_each(|v| *v = 0.0);
        self.diagonal.iter().for_each(|&p| values[p] = 1.0);
        for (i, &wi) in w.iter().enumerate() {
            let range = self.row_slots[i]..self.row_slots[i + 1];
            for (&slot, &c) in self.slots[range.clone()]
                .iter()
                .zip(&self.coefficients[range])
            {
                values[slot] += wi * c;
            }
        }
        match self.factor.as_mut() {
            Some((ldl, refactor)) => refactor.refactor(values, ldl),
            None => match Ldl::amd_refactorable(&self.csc, &vec![1; self.csc.n]) {
                Ok(factor) => {
                    self.factor = Some(factor);
                    true
                }
                Err(_) => false,
            },
        }
    }

    fn solve(&mut self, v: &mut [f64]) {
        if let Some((ldl, _)) = self.factor.as_mut() {
            ldl.solve(v);
        }
    }
}

/// `a` on the columns that hold an entry, renumbered in their order; `None` when every
/// column does.
fn touched_columns_only(a: &SparseRows) -> Option<SparseRows> {
    let mut local = vec![usize::MAX; a.n_cols()];
    a.col_idx().iter().for_each(|&c| local[c] = 0);
    let mut touched = 0;
    for l in local.iter_mut().filter(|l| **l == 0) {
        *l = touched;
        touched += 1;
    }
    if touched == a.n_cols() {
        return None;
    }
    let mut compressed = SparseRows::new(touched);
    for i in 0..a.n_rows() {
        compressed.push_row(a.row(i).map(|(c, v)| (local[c], v)));
    }
    Some(compressed)
}

/// The largest `α` with `v + α Δv ≥ 0` (infinite when `Δv ≥ 0`).
fn step_to_boundary(v: &[f64], dv: &[f64]) -> f64 {
    v.iter()
        .zip(dv)
        .filter(|(_, &d)| d < 0.0)
        .map(|(&x, &d)| -x / d)
        .fold(f64::INFINITY, f64::min)
}

/// The Newton system at one iterate: the rows, the slacks, `W = diag(λ/s)` (factored in
/// the caller's [`NormalMatrix`]) and the dual and primal residuals.
struct Newton<'a> {
    a: &'a SparseRows,
    slack: &'a [f64],
    w: &'a [f64],
    r_d: &'a [f64],
    r_p: &'a [f64],
    /// Whether the solve of the normal equations is refined once against `I + AᵀWA` itself
    /// (see [`solve_unless`]).
    refine: bool,
}

impl Newton<'_> {
    /// The direction `(Δd, Δλ, Δs)` for the complementarity residual `r_c` (`λ ∘ s` minus
    /// what it should become).
    fn direction(
        &self,
        matrix: &mut NormalMatrix,
        r_c: &[f64],
        (dd, dl, ds): (&mut [f64], &mut [f64], &mut [f64]),
    ) {
        let m = self.slack.len();
        // rhs = −r_d − Aᵀ(W r_p + r_c/s).
        let t: Vec<f64> = (0..m)
            .map(|i| self.w[i] * self.r_p[i] + r_c[i] / self.slack[i])
            .collect();
        self.a.mul_transpose_vec(&t, dd);
        dd.iter_mut()
            .zip(self.r_d)
            .for_each(|(v, rd)| *v = -*v - rd);
        let rhs = self.refine.then(|| dd.to_vec());
        matrix.solve(dd);
        if let Some(rhs) = rhs {
            // One step of iterative refinement: the residual `rhs − (I + AᵀWA) Δd` of the
            // computed direction, solved with the same factor and added.
            let mut weighted = vec![0.0; m];
            self.a.mul_vec(dd, &mut weighted);
            weighted.iter_mut().zip(self.w).for_each(|(v, wi)| *v *= wi);
            let mut residual = vec![0.0; dd.len()];
            self.a.mul_transpose_vec(&weighted, &mut residual);
            residual
                .iter_mut()
                .zip(&rhs)
                .zip(dd.iter())
                .for_each(|((v, b), x)| *v = b - x - *v);
            matrix.solve(&mut residual);
            dd.iter_mut().zip(&residual).for_each(|(x, e)| *x += e);
        }
        // Δs = A Δd + r_p; Δλ = −r_c/s − W Δs.
        self.a.mul_vec(dd, ds);
        for i in 0..m {
            ds[i] += self.r_p[i];
            dl[i] = -r_c[i] / self.slack[i] - self.w[i] * ds[i];
        }
    }
}

/// Mehrotra's starting point: the least-squares `d̂ = argmin ½‖d‖² + ½‖Ad − r‖²` (written to
/// `d`, with `A d̂` to `ad`; `matrix` holds `I + AᵀA`), whose `λ̂ = r − A d̂` makes it dual
/// feasible (`d̂ = Aᵀλ̂`) with `s = −λ̂`; both are shifted into the positive orthant (by 1.5 ×
/// their most negative entry) and then balanced (each by `½ sᵀλ` over the other's sum), and
/// kept at least `tolerance`. Returns `(s, λ)`.
fn starting_point(
    a: &SparseRows,
    r: &[f64],
    matrix: &mut NormalMatrix,
    tolerance: f64,
    (d, ad): (&mut [f64], &mut [f64]),
) -> (Vec<f64>, Vec<f64>) {
    a.mul_transpose_vec(r, d);
    matrix.solve(d);
    a.mul_vec(d, ad);
    let mut slack: Vec<f64> = ad.iter().zip(r).map(|(v, ri)| v - ri).collect();
    let mut lambda: Vec<f64> = slack.iter().map(|s| -s).collect();
    let shift = |v: &mut Vec<f64>| {
        let low = v.iter().fold(f64::INFINITY, |acc, &x| acc.min(x));
        let by = (-1.5 * low).max(0.0);
        v.iter_mut().for_each(|x| *x += by);
    };
    shift(&mut slack);
    shift(&mut lambda);
    let product: f64 = slack.iter().zip(&lambda).map(|(s, l)| s * l).sum();
    let (sum_s, sum_l): (f64, f64) = (slack.iter().sum(), lambda.iter().sum());
    let floor = tolerance.max(f64::MIN_POSITIVE);
    let by_s = if sum_l > 0.0 {
        0.5 * product / sum_l
    } else {
        1.0
    };
    let by_l = if sum_s > 0.0 {
        0.5 * product / sum_s
    } else {
        1.0
    };
    slack.iter_mut().for_each(|s| *s = (*s + by_s).max(floor));
    lambda.iter_mut().for_each(|l| *l = (*l + by_l).max(floor));
    (slack, lambda)
}

/// [`solve_unless`] run to its end (the tests' entry point).
#[cfg(test)]
pub(crate) fn solve(
    a: &SparseRows,
    r: &[f64],
    tolerance: f64,
    max_iterations: u32,
) -> Option<Iterate> {
    solve_unless(a, r, tolerance, max_iterations, &|| false)
}

/// Runs the method on `min ½‖d‖²` s.t. `A d ≥ r` until the duality measure `μ` and both
/// residuals are at most `tolerance` (absolute), or `max_iterations`, or until the normal
/// matrix can no longer be factored or its directions are no longer finite (then, not
/// converged, the most accurate iterate measured, or the one a step after it when that was
/// the last measured). `None` without rows, when the first factorization fails, when a step
/// overflows, or at the start of an iteration where `abandoned()` holds (a speculative
/// rescue whose answer is no longer wanted; until then, the iterates do not depend on it).
pub(crate) fn solve_unless(
    a: &SparseRows,
    r: &[f64],
    tolerance: f64,
    max_iterations: u32,
    abandoned: &dyn Fn() -> bool,
) -> Option<Iterate> {
    if a.n_rows() == 0 {
        return None;
    }
    // Unknowns no row touches keep `d = 0` at every iteration (their rows of the normal
    // equations are the identity's, with nothing on the right), so the method runs on the
    // others: on a jam's screened rows 10–15 % of the block's unknowns are left out, and each
    // of them cost the ordering, every refactorization and every solve a column.
    let compressed = touched_columns_only(a);
    let a = compressed.as_ref().unwrap_or(a);
    let (m, n) = (a.n_rows(), a.n_cols());
    let mut matrix = NormalMatrix::new(a);
    if !matrix.factor(&vec![1.0; m]) {
        return None;
    }
    let mut d = vec![0.0; n];
    let mut ad = vec![0.0; m];
    let (mut slack, mut lambda) = starting_point(a, r, &mut matrix, tolerance, (&mut d, &mut ad));

    let (mut r_d, mut r_p, mut r_c) = (vec![0.0; n], vec![0.0; m], vec![0.0; m]);
    let (mut dd, mut dl, mut ds) = (vec![0.0; n], vec![0.0; m], vec![0.0; m]);
    let mut w = vec![0.0; m];
    let mut at_lambda = vec![0.0; n];
    let mut accuracy = f64::INFINITY;
    // The residuals shrink by `1 − α` per iteration in exact arithmetic, so their growth
    // means the directions are no longer accurate (the normal matrix's weights span too many
    // orders of magnitude): from then on each solve is refined once. Growth below the
    // tolerance is rounding that does not hold the method back. Always refining cost
    // 10 % on the jammed 5000-person start, where it is never needed; on the 2000-person
    // evacuation's door queues the dual residual stalled near 1e-12 and then broke down
    // without it.
    let mut refine = false;
    let mut last_residual = f64::INFINITY;
    // The multipliers and slacks of the best accuracy measured, returned when the method
    // does not converge: after a breakdown the last iterate can be far worse than an earlier
    // one. On the 2000-person evacuation's door queues the dual residual stalled near 1e-11
    // (refined or not) until a step of 1e-30 left it at 3e-3; the iterate before, at 4e-12,
    // is a guess the active set finishes from.
    let mut best: Option<(f64, Vec<f64>, Vec<f64>, Previous)> = None;
    // The iterate before the current one, for Tapia's indicators (see `Iterate`).
    let mut previous: Previous = (lambda.clone(), slack.clone());
    // Where the method stopped without converging: the cap, or a breakdown (below).
    let mut stopped = max_iterations;
    for iterations in 1..=max_iterations {
        if abandoned() {
            return None;
        }
        // Residuals: r_d = d − Aᵀλ, r_p = A d − s − r, and μ = sᵀλ / m.
        a.mul_transpose_vec(&lambda, &mut at_lambda);
        r_d.iter_mut()
            .zip(&d)
            .zip(&at_lambda)
            .for_each(|((v, di), ai)| *v = di - ai);
        a.mul_vec(&d, &mut ad);
        for i in 0..m {
            r_p[i] = ad[i] - slack[i] - r[i];
        }
        let mu = slack.iter().zip(&lambda).map(|(s, l)| s * l).sum::<f64>() / m as f64;
        let worst = |v: &[f64]| v.iter().fold(0.0f64, |acc, x| acc.max(x.abs()));
        let residual = worst(&r_p).max(worst(&r_d));
        accuracy = mu.max(residual);
        if accuracy <= tolerance {
            let (previous_lambda, previous_slack) = previous;
            return Some(Iterate {
                lambda,
                slack,
                previous_lambda,
                previous_slack,
                iterations,
                converged: true,
                accuracy,
            });
        }
        refine |= residual > last_residual && residual > tolerance;
        last_residual = residual;
        if best.as_ref().is_none_or(|b| accuracy < b.0) {
            best = Some((accuracy, lambda.clone(), slack.clone(), previous.clone()));
        }
        for i in 0..m {
            w[i] = lambda[i] / slack[i];
        }
        // Close to the answer the weights λ/s span many orders of magnitude and the normal
        // matrix can stop being factorable, or its directions finite: the iterate reached so
        // far is returned, not lost (a random crowd of 88 reached 2.5e-11 and broke down at
        // the 13th iteration, on its way to 1e-12).
        if !matrix.factor(&w) {
            stopped = iterations;
            break;
        }
        let newton = Newton {
            a,
            slack: &slack,
            w: &w,
            r_d: &r_d,
            r_p: &r_p,
            refine,
        };
        // Predictor: the affine-scaling direction (target λ ∘ s = 0).
        for i in 0..m {
            r_c[i] = slack[i] * lambda[i];
        }
        newton.direction(&mut matrix, &r_c, (&mut dd, &mut dl, &mut ds));
        let alpha = step_to_boundary(&slack, &ds)
            .min(step_to_boundary(&lambda, &dl))
            .min(1.0);
        let mu_affine = slack
            .iter()
            .zip(&ds)
            .zip(lambda.iter().zip(&dl))
            .map(|((s, dsi), (l, dli))| (s + alpha * dsi) * (l + alpha * dli))
            .sum::<f64>()
            / m as f64;
        let sigma = (mu_affine / mu).clamp(0.0, 1.0).powi(3);
        // Corrector: the second-order term of the predictor, and centring.
        for i in 0..m {
            r_c[i] = slack[i] * lambda[i] + ds[i] * dl[i] - sigma * mu;
        }
        newton.direction(&mut matrix, &r_c, (&mut dd, &mut dl, &mut ds));
        let alpha = (TO_BOUNDARY
            * step_to_boundary(&slack, &ds).min(step_to_boundary(&lambda, &dl)))
        .min(1.0);
        if !(alpha.is_finite() && dd.iter().chain(&ds).chain(&dl).all(|v| v.is_finite())) {
            stopped = iterations;
            break;
        }
        previous.0.copy_from_slice(&lambda);
        previous.1.copy_from_slice(&slack);
        for j in 0..n {
            d[j] += alpha * dd[j];
        }
        for i in 0..m {
            slack[i] = (slack[i] + alpha * ds[i]).max(f64::MIN_POSITIVE);
            lambda[i] = (lambda[i] + alpha * dl[i]).max(f64::MIN_POSITIVE);
        }
        if !d.iter().chain(&slack).chain(&lambda).all(|v| v.is_finite()) {
            return None;
        }
    }
    let (accuracy, lambda, slack, (previous_lambda, previous_slack)) = match best {
        Some(best) if best.0 < accuracy => best,
        _ => (accuracy, lambda, slack, previous),
    };
    Some(Iterate {
        lambda,
        slack,
        previous_lambda,
        previous_slack,
        iterations: stopped,
        converged: false,
        accuracy,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use sweeping_api::conformance::{max_gap, random_instance, ReferenceProjector};
    use sweeping_api::{ProjectionProblem, Projector};

    fn residual(p: &ProjectionProblem) -> Vec<f64> {
        let mut ay = vec![0.0; p.n_rows()];
        p.a().mul_vec(p.y(), &mut ay);
        ay.iter().zip(p.b()).map(|(v, b)| b - v).collect()
    }

    #[test]
    fn stopped_at_its_cap_the_method_returns_the_iterate_a_step_after_the_last_measured() {
        // The cap reached while the accuracy still improves: the last measured iterate is the
        // most accurate, and the one a step after it, not measured, is returned. It is the
        // iterate a run with one more iteration measures and, here, accepts.
        let p = random_instance(11, 20, 40);
        let r = residual(&p);
        let full = solve(p.a(), &r, 1e-12, 60).unwrap();
        assert!(full.converged && full.iterations > 3, "{full:?}");
        let short = solve(p.a(), &r, 1e-12, full.iterations - 1).unwrap();
        assert!(!short.converged);
        assert_eq!(short.lambda, full.lambda);
        assert_eq!(short.slack, full.slack);
        // Its accuracy is the last one measured, the step before.
        assert!(short.accuracy > full.accuracy);
    }

    #[test]
    fn on_a_door_queue_whose_solves_lose_accuracy_the_refined_method_converges() {
        // A block of the 2000-person evacuation's door queue (2094 rows on 1604 unknowns),
        // every row: near the answer the normal matrix's weights span some twenty orders of
        // magnitude, and unrefined solves leave the residuals at 2.5e-12 relative after 39
        // iterations, short of the 1e-12 it reaches in 26 with them refined once its
        // residuals grow.
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/door_queue_qp.json");
        let p: ProjectionProblem =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let r = residual(&p);
        let scale = r.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
        let it = solve(p.a(), &r, 1e-12 * scale, 60).unwrap();
        assert!(
            it.converged,
            "{:.3e} after {}",
            it.accuracy / scale,
            it.iterations
        );
    }

    #[test]
    fn the_normal_matrix_is_the_identity_plus_a_transpose_w_a() {
        let p = random_instance(3, 12, 30);
        let (a, n) = (p.a(), p.dim());
        let w: Vec<f64> = (0..p.n_rows()).map(|i| 0.5 + (i % 7) as f64).collect();
        let mut matrix = NormalMatrix::new(a);
        assert!(matrix.factor(&w));
        // The dense I + AᵀWA, from its definition.
        let mut dense = vec![vec![0.0; n]; n];
        (0..n).for_each(|j| dense[j][j] = 1.0);
        for (i, &wi) in w.iter().enumerate() {
            for (p_, u) in a.row(i) {
                for (q, v) in a.row(i) {
                    dense[p_][q] += wi * u * v;
                }
            }
        }
        // Every stored entry is the upper triangle's, and nothing non-zero is missing.
        let csc = &matrix.csc;
        let mut stored = vec![vec![false; n]; n];
        for col in 0..n {
            for k in csc.colptr[col]..csc.colptr[col + 1] {
                let row = csc.rowval[k];
                assert!(row <= col, "entry ({row}, {col}) below the diagonal");
                assert!((csc.nzval[k] - dense[row][col]).abs() < 1e-12);
                stored[row][col] = true;
            }
        }
        for (row, line) in dense.iter().enumerate() {
            for (col, v) in line.iter().enumerate().skip(row) {
                assert!(
                    stored[row][col] || *v == 0.0,
                    "({row}, {col}) = {v} missing"
                );
            }
        }
        // And the factor solves the dense system.
        let rhs: Vec<f64> = (0..n).map(|j| (j as f64).sin()).collect();
        let mut x = rhs.clone();
        matrix.solve(&mut x);
        for j in 0..n {
            let hx: f64 = (0..n).map(|k| dense[j][k] * x[k]).sum();
            assert!(
                (hx - rhs[j]).abs() < 1e-10,
                "row {j}: {hx} against {}",
                rhs[j]
            );
        }
    }

    #[test]
    fn converges_to_the_projection_on_random_instances() {
        let mut most = 0;
        for seed in 0..40u64 {
            let (n, m) = (2 + (seed as usize * 7) % 30, 1 + (seed as usize * 13) % 45);
            let p = random_instance(seed, n, m);
            let r = residual(&p);
            let tol = 1e-11;
            let it = solve(p.a(), &r, tol, 80).expect("factorizations succeed");
            assert!(it.converged, "seed {seed}: {} iterations", it.iterations);
            most = most.max(it.iterations);
            assert!(it.lambda.iter().chain(&it.slack).all(|&v| v > 0.0));
            // x = y + Aᵀλ against the reference projection: an interior point is off by about
            // √μ on weakly active rows.
            let mut d = vec![0.0; n];
            p.a().mul_transpose_vec(&it.lambda, &mut d);
            let x: Vec<f64> = p.y().iter().zip(&d).map(|(y, d)| y + d).collect();
            let reference = ReferenceProjector::default().project(&p).unwrap();
            let gap = max_gap(&x, &reference.x);
            assert!(gap < 1e-4, "seed {seed}: {gap:.2e} from the reference");
            let kkt = p.kkt_residuals(&x, &it.lambda);
            assert!(kkt.primal <= 10.0 * tol, "seed {seed}: {kkt:?}");
            assert!(kkt.complementarity <= 1e-8, "seed {seed}: {kkt:?}");
        }
        // Mehrotra's predictor–corrector from its starting point needs 15 at most here (a
        // count, not a time: deterministic); a worse start or a broken corrector needs more.
        assert!(most <= 20, "{most} iterations");
    }

    #[test]
    fn dependent_rows_do_not_break_the_factorization() {
        // The same row three times and a row that is the sum of two others: AᵀWA is singular
        // where A is, the identity keeps the normal matrix definite.
        let a = SparseRows::from_rows(
            3,
            &[
                vec![(0, 1.0), (1, 1.0)],
                vec![(0, 1.0), (1, 1.0)],
                vec![(0, 1.0), (1, 1.0)],
                vec![(1, 1.0), (2, 1.0)],
                vec![(0, 1.0), (1, 2.0), (2, 1.0)],
            ],
        );
        let r = [1.0, 1.0, 1.0, 1.0, 2.0];
        let it = solve(&a, &r, 1e-12, 80).expect("factorizations succeed");
        assert!(it.converged);
        let mut d = vec![0.0; 3];
        a.mul_transpose_vec(&it.lambda, &mut d);
        // The projection of 0 onto {x₀ + x₁ ≥ 1, x₁ + x₂ ≥ 1} is (1/3, 2/3, 1/3).
        for (got, want) in d.iter().zip([1.0 / 3.0, 2.0 / 3.0, 1.0 / 3.0]) {
            assert!((got - want).abs() < 1e-5, "{d:?}");
        }
    }

    #[test]
    fn an_empty_set_stops_without_converging() {
        // x₀ + x₁ ≥ 1, −x₀ ≥ 0, −x₁ ≥ 0: no point satisfies all three.
        let a = SparseRows::from_rows(
            2,
            &[vec![(0, 1.0), (1, 1.0)], vec![(0, -1.0)], vec![(1, -1.0)]],
        );
        let r = [1.0, 0.0, 0.0];
        if let Some(it) = solve(&a, &r, 1e-10, 30) {
            // It diverges (its residuals pass 1e196, so its solves are refined from some
            // iteration on): to the cap, or to a breakdown one iteration before it.
            assert!(!it.converged);
            assert!((29..=30).contains(&it.iterations), "{}", it.iterations);
        }
    }

    #[test]
    fn the_starting_point_is_mehrotras() {
        // Two copies of x ≥ …: r = (2, −1). I + AᵀA = 3 and Aᵀr = 1, so d̂ = 1/3; s = A d̂ − r
        // = (−5/3, 4/3), λ = −s; shifted by 1.5 × their lowest: s = (5/6, 23/6),
        // λ = (11/3, 2/3); sᵀλ = 101/18, so s gains ½ sᵀλ / Σλ = 101/156 and λ gains
        // ½ sᵀλ / Σs = 101/168.
        let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
        let mut matrix = NormalMatrix::new(&a);
        assert!(matrix.factor(&[1.0, 1.0]));
        let (mut d, mut ad) = (vec![0.0], vec![0.0; 2]);
        let (s, l) = starting_point(&a, &[2.0, -1.0], &mut matrix, 1e-12, (&mut d, &mut ad));
        let close =
            |got: &[f64], want: &[f64]| got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-14);
        assert!(close(&d, &[1.0 / 3.0]), "{d:?}");
        assert!(close(&ad, &[1.0 / 3.0, 1.0 / 3.0]), "{ad:?}");
        let (bs, bl) = (101.0 / 156.0, 101.0 / 168.0);
        assert!(close(&s, &[5.0 / 6.0 + bs, 23.0 / 6.0 + bs]), "{s:?}");
        assert!(close(&l, &[11.0 / 3.0 + bl, 2.0 / 3.0 + bl]), "{l:?}");
        // Nothing to balance (r = 0): both start at 1.
        let (s, l) = starting_point(&a, &[0.0, 0.0], &mut matrix, 1e-12, (&mut d, &mut ad));
        assert_eq!((s, l), (vec![1.0; 2], vec![1.0; 2]));
    }

    #[test]
    fn no_rows_is_no_problem_to_solve() {
        assert!(solve(&SparseRows::new(3), &[], 1e-10, 10).is_none());
    }

    #[test]
    fn the_method_runs_on_the_touched_columns_renumbered_in_order() {
        // Columns 1 and 3 of five are touched by no row.
        let a = SparseRows::from_rows(5, &[vec![(0, 1.0), (2, -1.0)], vec![(4, 2.0), (2, 0.5)]]);
        let compressed = touched_columns_only(&a).unwrap();
        let expected =
            SparseRows::from_rows(3, &[vec![(0, 1.0), (1, -1.0)], vec![(2, 2.0), (1, 0.5)]]);
        assert_eq!(compressed, expected);
        // Every column touched: nothing to drop.
        assert!(touched_columns_only(&expected).is_none());
        // And the untouched unknowns change nothing: the same iterate, to the bit, as on the
        // compressed rows.
        let r = [0.5, 1.0];
        let whole = solve(&a, &r, 1e-12, 60).unwrap();
        let alone = solve(&expected, &r, 1e-12, 60).unwrap();
        assert_eq!(whole.lambda, alone.lambda);
        assert_eq!(whole.slack, alone.slack);
    }

    #[test]
    fn the_step_to_the_boundary_stops_at_the_first_zero() {
        assert_eq!(step_to_boundary(&[1.0, 2.0, 3.0], &[-2.0, -1.0, 5.0]), 0.5);
        assert_eq!(step_to_boundary(&[1.0, 2.0], &[0.0, 1.0]), f64::INFINITY);
    }

    /// 88 disks of radius 0.2 at random in a 4 × 3 room, one row per pair closer than 0.6
    /// (the linearized non-overlap `eᵢⱼ·(dⱼ − dᵢ) ≥ 0.4 − distance`): the rows and `r`.
    pub(crate) fn random_crowd() -> (SparseRows, Vec<f64>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let people = 88;
        let at: Vec<(f64, f64)> = (0..people)
            .map(|_| (rng.gen_range(0.0..4.0), rng.gen_range(0.0..3.0)))
            .collect();
        let (mut rows, mut r) = (Vec::new(), Vec::new());
        for i in 0..people {
            for j in i + 1..people {
                let (dx, dy) = (at[j].0 - at[i].0, at[j].1 - at[i].1);
                let distance = dx.hypot(dy);
                if distance < 0.6 {
                    let (ex, ey) = (dx / distance, dy / distance);
                    rows.push(vec![
                        (2 * i, -ex),
                        (2 * i + 1, -ey),
                        (2 * j, ex),
                        (2 * j + 1, ey),
                    ]);
                    r.push(0.4 - distance);
                }
            }
        }
        (SparseRows::from_rows(2 * people, &rows), r)
    }

    /// `‖rhs − (I + AᵀWA) v‖∞`.
    fn normal_residual(a: &SparseRows, w: &[f64], rhs: &[f64], v: &[f64]) -> f64 {
        let mut av = vec![0.0; a.n_rows()];
        a.mul_vec(v, &mut av);
        av.iter_mut().zip(w).for_each(|(x, wi)| *x *= wi);
        let mut atwav = vec![0.0; a.n_cols()];
        a.mul_transpose_vec(&av, &mut atwav);
        rhs.iter()
            .zip(v)
            .zip(&atwav)
            .fold(0.0, |acc: f64, ((b, x), y)| acc.max((b - x - y).abs()))
    }

    #[test]
    fn a_refined_direction_solves_the_normal_equations_more_accurately() {
        // Weights spanning twenty orders of magnitude, as near the answer of a jam.
        let (a, r) = random_crowd();
        let (m, n) = (r.len(), a.n_cols());
        let w: Vec<f64> = (0..m).map(|i| 10f64.powi((i % 21) as i32 - 10)).collect();
        let mut matrix = NormalMatrix::new(&a);
        assert!(matrix.factor(&w));
        let slack = vec![1.0; m];
        let r_p = vec![0.0; m];
        let r_c = vec![0.0; m];
        let r_d: Vec<f64> = (0..n).map(|j| (j as f64).sin()).collect();
        // With r_p = r_c = 0 the right-hand side is −r_d.
        let rhs: Vec<f64> = r_d.iter().map(|v| -v).collect();
        let mut residuals = Vec::new();
        for refine in [false, true] {
            let newton = Newton {
                a: &a,
                slack: &slack,
                w: &w,
                r_d: &r_d,
                r_p: &r_p,
                refine,
            };
            let (mut dd, mut dl, mut ds) = (vec![0.0; n], vec![0.0; m], vec![0.0; m]);
            newton.direction(&mut matrix, &r_c, (&mut dd, &mut dl, &mut ds));
            residuals.push(normal_residual(&a, &w, &rhs, &dd));
        }
        // 1.4e-6 against 3.9e-7 on this machine: one step of refinement with a factor this
        // inaccurate gains a few times, and the method refines at every solve from then on.
        assert!(residuals[1] < 0.5 * residuals[0], "{residuals:?}");
    }

    #[test]
    fn an_interior_point_that_breaks_down_near_the_answer_returns_where_it_got() {
        // On the way to 1e-12 the normal matrix's directions stop being finite (at the 13th
        // iteration on this machine, with 2.5e-11 reached); the iterate is a guess to finish
        // from, where it used to be lost.
        let (a, r) = random_crowd();
        let it = solve(&a, &r, 1e-12, 60).expect("an iterate");
        assert!(it.accuracy <= 1e-8, "{}", it.accuracy);
        assert_eq!(it.lambda.len(), r.len());
        assert!(it
            .lambda
            .iter()
            .chain(&it.slack)
            .all(|v| v.is_finite() && *v > 0.0));
    }
}
