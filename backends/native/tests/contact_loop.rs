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

#[path = "../../../tests/common/certified.rs"]
mod certified;
use certified::reference;
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

fn check_against_reference(problem: &ProjectionProblem, x: &[f64], what: &str) {
    let (x_ref, violation, cone_residual) = reference(problem, x, 1e-7);
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
