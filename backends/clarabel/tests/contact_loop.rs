//! A contact loop: a projection whose active rows are linearly dependent.
//!
//! `data/contact_loop_qp.json` is the projection of step 287 of the paper's evacuation scene
//! (142 rows, 300 coordinates): a cycle of touching disks makes the 113 active rows
//! rank-deficient, so their multipliers are not unique, and their equations are consistent
//! only to `1.1e-10` (rounding of the data). The interior-point iterate alone was `2.2e-6`
//! off there (∞-norm) with KKT residuals of `1e-11`, because some tight rows are only weakly
//! active, and the former polish failed on the dependent rows; the polished answer must be
//! exact.
//!
//! The reference is computed here, independently of the backend, and certified: the
//! projection of `y` onto the affine set of the rows tight at Clarabel's answer (dense SVD
//! least squares, min-norm multipliers), checked to be feasible and to satisfy
//! `x − y = A_Tᵀλ` with `λ ≥ 0` found by a dense non-negative least-squares solve. Those are
//! the KKT conditions of the convex projection (to `1e-9`, the least-squares fit spreading
//! the inconsistency over the loop), so they pin the point, whatever the active-set guess it
//! came from.

use nalgebra::{DMatrix, DVector};
use sweeping_api::{ProjectionProblem, Projector};
use sweeping_clarabel::ClarabelProjector;

fn load() -> ProjectionProblem {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/contact_loop_qp.json"
    );
    let text = std::fs::read_to_string(path).expect("read the contact-loop QP");
    serde_json::from_str(&text).expect("parse the contact-loop QP")
}

/// `A` restricted to `rows`, dense.
fn dense_rows(problem: &ProjectionProblem, rows: &[usize]) -> DMatrix<f64> {
    let mut a = DMatrix::zeros(rows.len(), problem.dim());
    for (t, &r) in rows.iter().enumerate() {
        for (c, v) in problem.a().row(r) {
            a[(t, c)] += v;
        }
    }
    a
}

/// Lawson–Hanson non-negative least squares: `argmin ‖M λ − g‖₂` over `λ ≥ 0`.
fn nnls(m: &DMatrix<f64>, g: &DVector<f64>) -> DVector<f64> {
    let k = m.ncols();
    let mut lambda = DVector::zeros(k);
    let mut passive = vec![false; k];
    // Least squares on the passive columns (zero elsewhere), by SVD (they may be dependent).
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
            // Step from λ toward s until a passive coordinate reaches zero.
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

/// The projection of `y` onto the affine set `{A_T x = b_T}`: `x = y + A_Tᵀμ` with
/// `(A_T A_Tᵀ) μ = b_T − A_T y`, min-norm `μ` by SVD. The point is unique even though `A_T` is
/// rank-deficient.
fn affine_projection(problem: &ProjectionProblem, rows: &[usize]) -> DVector<f64> {
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

/// The certified reference projection: `(x, max violation, NNLS residual)`.
fn reference(problem: &ProjectionProblem, guess: &[f64]) -> (Vec<f64>, f64, f64) {
    // Rows nearly tight at the answer under test, plus any row the affine projection then
    // violates: a guess, certified below.
    let mut ax = vec![0.0; problem.n_rows()];
    problem.a().mul_vec(guess, &mut ax);
    let mut tight: Vec<usize> = (0..problem.n_rows())
        .filter(|&i| ax[i] - problem.b()[i] <= 1e-7)
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
    let violation = problem.max_violation(x.as_slice());
    // Non-negative multipliers: x − y ∈ cone{a_i : i ∈ T}.
    let at = dense_rows(problem, &tight).transpose();
    let d = &x - DVector::from_column_slice(problem.y());
    let lambda = nnls(&at, &d);
    let residual = (at * &lambda - d).amax();
    (x.as_slice().to_vec(), violation, residual)
}

#[test]
fn contact_loop_is_polished_to_the_exact_projection() {
    let problem = load();
    assert_eq!((problem.n_rows(), problem.dim()), (142, 300));
    let mut clarabel = ClarabelProjector::default();
    let sol = clarabel
        .project(&problem)
        .expect("clarabel solves the contact loop");
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    // The polished answer's residuals are rounding (1e-14); the iterate's are 1e-11.
    assert!(
        kkt <= 1e-12,
        "KKT residual {kkt:.3e}: the answer was not polished"
    );

    let (x_ref, violation, cone_residual) = reference(&problem, &sol.x);
    assert!(
        violation <= 1e-9,
        "reference violates a row by {violation:.3e}"
    );
    assert!(
        cone_residual <= 1e-9,
        "reference is not certified: NNLS residual {cone_residual:.3e}"
    );
    let gap = sol
        .x
        .iter()
        .zip(&x_ref)
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max);
    eprintln!("contact loop: ‖x − x_ref‖∞ = {gap:.3e}, KKT {kkt:.3e}");
    assert!(
        gap <= 1e-8,
        "Clarabel is {gap:.3e} from the exact projection"
    );
}
