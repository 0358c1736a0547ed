//! A contact loop: a projection whose active rows are linearly dependent.
//!
//! The fixture `contact_loop_qp.json` is the projection of step 287 of the paper's evacuation scene
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

use sweeping_api::Projector;
use sweeping_clarabel::ClarabelProjector;
use sweeping_testkit::certified::{assert_is_the_projection, contact_loop_qp};

#[test]
fn contact_loop_is_polished_to_the_exact_projection() {
    let problem = contact_loop_qp();
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

    assert_is_the_projection(&problem, &sol.x, "Clarabel on the contact loop");
}

/// `copies` copies of `problem` side by side, sharing no unknown.
fn side_by_side(
    problem: &sweeping_api::ProjectionProblem,
    copies: usize,
) -> sweeping_api::ProjectionProblem {
    let n = problem.dim();
    let mut a = sweeping_api::SparseRows::new(copies * n);
    let (mut y, mut b) = (Vec::new(), Vec::new());
    for copy in 0..copies {
        for r in 0..problem.n_rows() {
            a.push_row(problem.a().row(r).map(|(c, v)| (c + copy * n, v)));
        }
        y.extend_from_slice(problem.y());
        b.extend_from_slice(problem.b());
    }
    sweeping_api::ProjectionProblem::new(y, a, b).expect("copies of a valid problem")
}

/// Eight contact loops in one projection: the polish runs block by block, so each loop is
/// finished as if it were alone. On the whole problem the loops' leaving rows queued behind
/// each other under one cap of 40 iterations, the polish gave up, and the answer stayed the
/// interior-point iterate, microns off.
#[test]
fn independent_contact_loops_are_each_polished_to_the_exact_projection() {
    let single = contact_loop_qp();
    let alone = ClarabelProjector::default()
        .project(&single)
        .expect("clarabel solves the contact loop");
    let copies = 8;
    let problem = side_by_side(&single, copies);
    let sol = ClarabelProjector::default()
        .project(&problem)
        .expect("clarabel solves eight contact loops");
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(
        kkt <= 1e-12,
        "KKT residual {kkt:.3e}: the answer was not polished"
    );
    let n = single.dim();
    for copy in 0..copies {
        let gap = sol.x[copy * n..(copy + 1) * n]
            .iter()
            .zip(&alone.x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            gap <= 1e-10,
            "copy {copy} is {gap:.3e} from the loop solved alone"
        );
    }
}
