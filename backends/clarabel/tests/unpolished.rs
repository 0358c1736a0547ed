//! What Clarabel's statistics say about the polish: nothing left unfinished when it finishes,
//! one block when the interior-point iterate stands.

use sweeping_api::{ProjectionProblem, Projector, SparseRows};
use sweeping_clarabel::ClarabelProjector;

#[test]
fn a_polished_answer_leaves_nothing_unfinished() {
    // Two points on a line, 0.1 apart, that must be at least 0.4 apart.
    let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0, 0.1], a, vec![0.4]).unwrap();
    let answer = ClarabelProjector::default().project(&p).unwrap();
    assert_eq!(
        (
            answer.stats.counters.reduced,
            answer.stats.counters.reduced_by
        ),
        (0, 0.0)
    );
    assert!((answer.x[0] + 0.15).abs() < 1e-15 && (answer.x[1] - 0.25).abs() < 1e-15);
}

#[test]
fn an_interior_point_answer_that_stands_unpolished_says_so() {
    // 1 ≤ x ≤ 1 − 1e-13: empty by 1e-13, within Clarabel's feasibility tolerance, so it
    // answers x ≈ 1 − 5e-14; the polish certifies the rows empty (a checked Farkas
    // certificate) and keeps the iterate, which violates both rows by about 5e-14.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, -1.0)]]);
    let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, -(1.0 - 1e-13)]).unwrap();
    let answer = ClarabelProjector::default().project(&p).unwrap();
    assert!((answer.x[0] - 1.0).abs() <= 1e-13, "{answer:?}");
    assert_eq!(answer.stats.counters.reduced, 1, "{answer:?}");
    let violation = (1.0 - answer.x[0]).max(answer.x[0] - (1.0 - 1e-13));
    assert!(
        (answer.stats.counters.reduced_by - violation).abs() <= 1e-15,
        "{answer:?}, violation {violation:e}"
    );
}
