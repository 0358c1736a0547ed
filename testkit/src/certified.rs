//! A certified reference projection, independent of every backend: the projection of `y` onto
//! the affine set of the rows tight at a guess (dense SVD least squares, min-norm multipliers),
//! grown by any row it violates, then checked feasible and `x − y = A_Tᵀλ` with `λ ≥ 0` found
//! by a dense non-negative least-squares solve: the KKT conditions of the convex projection,
//! which pin the point whatever guess it came from. Shared by the contact-loop tests of the
//! Clarabel and native backends and by the cross-check certificate.

use nalgebra::{DMatrix, DVector};
use sweeping_api::conformance::max_gap;
use sweeping_api::ProjectionProblem;

/// The rows `rows` of the problem's `A`, dense, one matrix row each.
pub fn dense_rows(problem: &ProjectionProblem, rows: &[usize]) -> DMatrix<f64> {
    let mut a = DMatrix::zeros(rows.len(), problem.dim());
    for (t, &r) in rows.iter().enumerate() {
        for (c, v) in problem.a().row(r) {
            a[(t, c)] += v;
        }
    }
    a
}

/// Lawson–Hanson non-negative least squares: `argmin ‖M λ − g‖₂` over `λ ≥ 0`.
pub fn nnls(m: &DMatrix<f64>, g: &DVector<f64>) -> DVector<f64> {
    let k = m.ncols();
    let mut lambda = DVector::zeros(k);
    let mut passive = vec![false; k];
    let solve_passive = |passive: &[bool]| -> DVector<f64> {
        let cols: Vec<usize> = (0..k).filter(|&j| passive[j]).collect();
        let mut out = DVector::zeros(k);
        if cols.is_empty() {
            return out;
        }
        let sub = m.select_columns(&cols);
        let sol = sub.svd(true, true).solve(g, 1e-13).expect("SVD solve");
        for (t, &j) in cols.iter().enumerate() {
            out[j] = sol[t];
        }
        out
    };
    for _ in 0..10 * k {
        let w = m.transpose() * (g - m * &lambda);
        let Some(j) = (0..k)
            .filter(|&j| !passive[j] && w[j] > 1e-14)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]))
        else {
            break;
        };
        passive[j] = true;
        loop {
            let s = solve_passive(&passive);
            if (0..k).all(|i| !passive[i] || s[i] > 0.0) {
                lambda = s;
                break;
            }
            let alpha = (0..k)
                .filter(|&i| passive[i] && s[i] <= 0.0)
                .map(|i| lambda[i] / (lambda[i] - s[i]))
                .fold(f64::INFINITY, f64::min);
            lambda += (s - &lambda) * alpha;
            for i in 0..k {
                if passive[i] && lambda[i] <= 1e-15 {
                    passive[i] = false;
                    lambda[i] = 0.0;
                }
            }
        }
    }
    lambda
}

/// The projection of `y` onto the affine set `{x : A_R x = b_R}` of the rows `R = rows`
/// (dense SVD least squares, min-norm multipliers).
pub fn affine_projection(problem: &ProjectionProblem, rows: &[usize]) -> DVector<f64> {
    let a = dense_rows(problem, rows);
    let y = DVector::from_column_slice(problem.y());
    let b = DVector::from_iterator(rows.len(), rows.iter().map(|&i| problem.b()[i]));
    let gram = &a * a.transpose();
    let mu = gram
        .svd(true, true)
        .solve(&(b - &a * &y), 1e-13)
        .expect("SVD solve");
    &y + a.transpose() * mu
}

/// `x`, the projection onto the affine set of `rows`, with its certificate: `(x, max
/// violation, cone residual)`, the residual of `x − y = A_rowsᵀλ` with `λ ≥ 0` found by
/// [`nnls`].
fn certify(problem: &ProjectionProblem, rows: &[usize], x: DVector<f64>) -> (Vec<f64>, f64, f64) {
    let violation = problem.max_violation(x.as_slice());
    let at = dense_rows(problem, rows).transpose();
    let d = &x - DVector::from_column_slice(problem.y());
    let lambda = nnls(&at, &d);
    let residual = (at * &lambda - d).amax();
    (x.as_slice().to_vec(), violation, residual)
}

/// The certified projection from an active-set guess: `(x, max violation, cone residual)`.
pub fn reference(
    problem: &ProjectionProblem,
    guess: &[f64],
    tight_tol: f64,
) -> (Vec<f64>, f64, f64) {
    let mut ax = vec![0.0; problem.n_rows()];
    problem.a().mul_vec(guess, &mut ax);
    let mut tight: Vec<usize> = (0..problem.n_rows())
        .filter(|&i| ax[i] - problem.b()[i] <= tight_tol)
        .collect();
    let mut x = affine_projection(problem, &tight);
    for _ in 0..10 {
        problem.a().mul_vec(x.as_slice(), &mut ax);
        let violated: Vec<usize> = (0..problem.n_rows())
            .filter(|i| !tight.contains(i) && ax[*i] < problem.b()[*i])
            .collect();
        if violated.is_empty() {
            break;
        }
        tight.extend(violated);
        tight.sort_unstable();
        x = affine_projection(problem, &tight);
    }
    certify(problem, &tight, x)
}

/// The certified projection from no guess at all: the least-distance program
/// `min ‖x − y‖` over `A x ≥ b`, solved as Lawson and Hanson's dense non-negative least-squares
/// problem (`min ‖E u − e‖`, `u ≥ 0`, with `E = [A; (b − A y)ᵀ]ᵀ` stacked as columns and `e` the
/// last unit vector; the displacement is read from the residual), whose positive `u` name the
/// projection's support; then the projection onto that support's affine set, certified as
/// [`reference()`] certifies its own. Where the rows tight at an answer are nearly dependent and
/// not all in the support, forcing them all tight moves the point by their slack over the
/// support's smallest singular value; this candidate does not depend on an answer's slacks.
/// Dense, cubic in the rows: for problems of a few hundred rows.
pub fn least_distance(problem: &ProjectionProblem) -> (Vec<f64>, f64, f64) {
    let (m, n) = (problem.n_rows(), problem.dim());
    let mut ay = vec![0.0; m];
    problem.a().mul_vec(problem.y(), &mut ay);
    let all: Vec<usize> = (0..m).collect();
    let a = dense_rows(problem, &all);
    let mut e = DMatrix::zeros(n + 1, m);
    e.view_mut((0, 0), (n, m)).copy_from(&a.transpose());
    for i in 0..m {
        e[(n, i)] = problem.b()[i] - ay[i];
    }
    let mut unit = DVector::zeros(n + 1);
    unit[n] = 1.0;
    let u = nnls(&e, &unit);
    let support: Vec<usize> = (0..m).filter(|&i| u[i] > 0.0).collect();
    let x = affine_projection(problem, &support);
    certify(problem, &support, x)
}

/// The contact-loop QP (`fixtures/contact_loop_qp.json`: step 287 of the paper's evacuation,
/// 142 rows, 300 coordinates, 113 dependent active rows).
pub fn contact_loop_qp() -> ProjectionProblem {
    crate::fixtures::problem("contact_loop_qp.json")
}

/// Asserts that `x` is the exact projection: the certified reference from `x`'s tight rows
/// (slack ≤ `1e-7`) is feasible and certified to `1e-9`, and `x` lies within `1e-8` of it.
pub fn assert_is_the_projection(problem: &ProjectionProblem, x: &[f64], what: &str) {
    let (x_ref, violation, cone_residual) = reference(problem, x, 1e-7);
    assert!(
        violation <= 1e-9,
        "{what}: reference violates a row by {violation:.3e}"
    );
    assert!(
        cone_residual <= 1e-9,
        "{what}: reference is not certified: NNLS residual {cone_residual:.3e}"
    );
    let gap = max_gap(x, &x_ref);
    eprintln!("{what}: ‖x − x_ref‖∞ = {gap:.3e}");
    assert!(gap <= 1e-8, "{what}: {gap:.3e} from the exact projection");
}
