//! A contact loop: a projection whose active rows are linearly dependent.
//!
//! `data/contact_loop_qp.json` (a copy of the Clarabel backend's test data) is the projection
//! of step 287 of the paper's evacuation scene (142 rows, 300 coordinates): a cycle of
//! touching disks makes the 113 active rows rank-deficient, so their multipliers are not
//! unique, and their equations are consistent only to `1.1e-10` (rounding of the data). The
//! native method must reach the exact projection without a fallback, cold and warm.
//!
//! The reference is computed here, independently of the backend, and certified: the
//! projection of `y` onto the affine set of the rows tight at the answer under test (dense SVD
//! least squares, min-norm multipliers), checked to be feasible and to satisfy
//! `x − y = A_Tᵀλ` with `λ ≥ 0` found by a dense non-negative least-squares solve.

use nalgebra::{DMatrix, DVector};
use sweeping_api::RowKey;
use sweeping_api::{ProjectionProblem, Projector};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::NativeProjector;

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

fn check_against_reference(problem: &ProjectionProblem, x: &[f64], what: &str) {
    let (x_ref, violation, cone_residual) = reference(problem, x);
    assert!(
        violation <= 1e-9,
        "{what}: reference violates a row by {violation:.3e}"
    );
    assert!(
        cone_residual <= 1e-9,
        "{what}: reference is not certified: NNLS residual {cone_residual:.3e}"
    );
    let gap = x
        .iter()
        .zip(&x_ref)
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max);
    eprintln!("{what}: ‖x − x_ref‖∞ = {gap:.3e}");
    assert!(gap <= 1e-8, "{what}: {gap:.3e} from the exact projection");
}

#[test]
fn contact_loop_is_solved_exactly_without_fallback() {
    let problem = load();
    assert_eq!((problem.n_rows(), problem.dim()), (142, 300));
    let mut native = NativeProjector::default();
    let sol = native
        .project(&problem)
        .expect("native solves the contact loop");
    assert_eq!(sol.stats.fallbacks, 0);
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= 1e-10, "KKT residual {kkt:.3e}");
    check_against_reference(&problem, &sol.x, "cold");
    let clarabel = ClarabelProjector::default().project(&problem).unwrap();
    let gap = sol
        .x
        .iter()
        .zip(&clarabel.x)
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max);
    assert!(gap <= 1e-8, "native and Clarabel differ by {gap:.3e}");

    // Warm: the same problem with keys, solved twice (the second starts from the first's
    // active set, reordered).
    let m = problem.n_rows() as u64;
    let keys: Vec<RowKey> = (0..m)
        .map(|i| RowKey {
            family: 0,
            member: i,
        })
        .collect();
    let keyed = problem.clone().with_row_keys(keys).unwrap();
    let mut warm = NativeProjector::default();
    let first = warm.project(&keyed).unwrap();
    assert!(!first.stats.warm_started);
    let second = warm.project(&keyed).unwrap();
    assert!(second.stats.warm_started);
    assert_eq!(second.stats.fallbacks, 0);
    check_against_reference(&problem, &second.x, "warm");
}
