//! A contact loop: a projection whose active rows are linearly dependent.
//!
//! The fixture `contact_loop_qp.json` is the projection
//! of step 287 of the paper's evacuation scene (142 rows, 300 coordinates): a cycle of
//! touching disks makes the 113 active rows rank-deficient, so their multipliers are not
//! unique, and their equations are consistent only to `1.1e-10` (rounding of the data). The
//! native method must reach the exact projection without a fallback, cold and warm.
//!
//! The reference is computed here, independently of the backend, and certified: the
//! projection of `y` onto the affine set of the rows tight at the answer under test (dense SVD
//! least squares, min-norm multipliers), checked to be feasible and to satisfy
//! `x − y = A_Tᵀλ` with `λ ≥ 0` found by a dense non-negative least-squares solve.

use sweeping_api::conformance::max_gap;
use sweeping_api::Projector;
use sweeping_api::RowKey;
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::{NativeProjector, NativeSettings};
use sweeping_testkit::certified::{assert_is_the_projection, contact_loop_qp};

#[test]
fn contact_loop_is_solved_exactly_without_fallback() {
    let problem = contact_loop_qp();
    assert_eq!((problem.n_rows(), problem.dim()), (142, 300));
    let mut native = NativeProjector::default();
    let sol = native
        .project(&problem)
        .expect("native solves the contact loop");
    assert_eq!(sol.stats.counters.fallbacks, 0);
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= 1e-10, "KKT residual {kkt:.3e}");
    assert_is_the_projection(&problem, &sol.x, "cold");
    let clarabel = ClarabelProjector::default().project(&problem).unwrap();
    let gap = max_gap(&sol.x, &clarabel.x);
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
    assert_eq!(second.stats.counters.fallbacks, 0);
    assert_is_the_projection(&problem, &second.x, "warm");
}

/// The interior point on the contact loop: its support holds every row of the loop, and the
/// finish from it must still reach the exact projection.
#[test]
fn contact_loop_is_solved_exactly_by_the_interior_point() {
    let problem = contact_loop_qp();
    let mut interior = NativeProjector::new(NativeSettings {
        active_set_iterations: 0,
        ..NativeSettings::default()
    });
    let sol = interior
        .project(&problem)
        .expect("the interior point solves the loop");
    // Every block (the loop's, and the pairs and small clusters beside it) went there.
    assert!(sol.stats.counters.escalations >= 1);
    assert_eq!(sol.stats.counters.fallbacks, 0);
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= 1e-10, "KKT residual {kkt:.3e}");
    assert_is_the_projection(&problem, &sol.x, "interior point");
}
