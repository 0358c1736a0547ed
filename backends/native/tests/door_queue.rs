//! Jammed queues at doors: more nearly tight rows than coordinates, rows of contact loops
//! linearly dependent, multipliers not unique, and normal equations whose weights span twenty
//! orders of magnitude near the answer.
//!
//! Each fixture (`sweeping_testkit::fixtures`) is one block of a projection recorded where an earlier native method (a dual
//! active set, rescued by an interior point and finished by the active set again) struggled:
//!
//! * `door_queue_qp.json`: the 2000-person evacuation (`examples/scenes/large-evacuation.toml`)
//!   in its first 12 s, 2094 rows on 1604 coordinates; its interior point's solves lost
//!   accuracy near the answer (the residuals jumped from 1e-11 to 1e-7 a step before the
//!   tolerance, unless every late solve is refined).
//! * `door_queue_loops_qp.json` (2073 rows on 1572 coordinates): 1852 rows whose
//!   multiplier exceeds their slack near the answer, consistent only to `5e-8`.
//! * `door_queue_breakdown_qp.json` (1804 rows on 1474 coordinates), from the same
//!   scene's first 30 s: the interior point's dual residual stalls near its tolerance.
//! * `door_queue_drop_qp.json` (1756 rows on 1258 coordinates): a support guess holding
//!   480 rows that leave.
//! * `hall_queue_fallback_qp.json` (3115 rows on 2256 coordinates): a door-queue jam of
//!   the 10 000-person hall (`examples/scenes/hall-10000.toml`) at t ≈ 17.8 s that the earlier
//!   method could not finish at all (it went to Clarabel).
//! * `door_queue_stalled_qp.json` (2275 rows on 1670 coordinates): a block of the
//!   2000-person evacuation between t = 0 and 20 s on which the interior point itself breaks
//!   down short of its tolerance (its residuals jump from `1e-14` to `1e-2`); the engine handed
//!   it to its fallback until the finish of an unconverged interior point got more iterations.
//!
//! The native method must solve each on its own, pass the KKT check at `1e-10`, and agree with
//! Clarabel, an independent interior-point solver polished by an active-set method, within
//! `1e-8`.

use sweeping_api::conformance::max_gap;
use sweeping_api::{ProjectionProblem, Projector};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::NativeProjector;

fn load(name: &str) -> ProjectionProblem {
    sweeping_testkit::fixtures::problem(name)
}

#[test]
fn a_door_queue_whose_late_solves_lose_accuracy_is_solved_and_agrees_with_clarabel() {
    let problem = load("door_queue_qp.json");
    assert_eq!((problem.n_rows(), problem.dim()), (2094, 1604));
    let iterations = solved_natively_as_clarabel_solves_it(&problem);
    // A count, not a time: deterministic.
    assert!(iterations <= 60, "{iterations} iterations");
}

#[test]
fn a_door_queue_with_more_tight_rows_than_unknowns_is_solved_without_fallback() {
    let problem = load("door_queue_loops_qp.json");
    assert_eq!((problem.n_rows(), problem.dim()), (2073, 1572));
    solved_natively_as_clarabel_solves_it(&problem);
}

#[test]
fn a_door_queue_whose_dual_residual_stalls_is_solved_without_fallback() {
    let problem = load("door_queue_breakdown_qp.json");
    assert_eq!((problem.n_rows(), problem.dim()), (1804, 1474));
    solved_natively_as_clarabel_solves_it(&problem);
}

#[test]
fn a_door_queue_whose_support_guess_holds_many_loose_rows_is_solved_without_fallback() {
    let problem = load("door_queue_drop_qp.json");
    assert_eq!((problem.n_rows(), problem.dim()), (1756, 1258));
    solved_natively_as_clarabel_solves_it(&problem);
}

#[test]
fn a_hall_queue_the_earlier_method_handed_to_its_fallback_is_solved_natively() {
    let problem = load("hall_queue_fallback_qp.json");
    assert_eq!((problem.n_rows(), problem.dim()), (3115, 2256));
    solved_natively_as_clarabel_solves_it(&problem);
}

#[test]
fn a_door_queue_whose_interior_point_breaks_down_is_finished_by_the_active_set() {
    let problem = load("door_queue_stalled_qp.json");
    assert_eq!((problem.n_rows(), problem.dim()), (2275, 1670));
    let sol = NativeProjector::default().project(&problem).unwrap();
    // Within the accuracy target, not an answer short of it.
    assert_eq!(sol.stats.counters.reduced, 0);
    solved_natively_as_clarabel_solves_it(&problem);
}

/// The native method, without a fallback, solves `problem` (one block) by its interior point
/// and agrees with Clarabel within `1e-8`; both answers pass the KKT check at `1e-10`. Returns
/// the native method's iterations.
fn solved_natively_as_clarabel_solves_it(problem: &ProjectionProblem) -> u32 {
    // No fallback configured: a failure would be an error here, not a Clarabel answer.
    let sol = NativeProjector::default()
        .project(problem)
        .expect("the native method solves the door queue on its own");
    assert_eq!(
        (sol.stats.counters.escalations, sol.stats.counters.fallbacks),
        (1, 0)
    );
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= 1e-10, "KKT residual {kkt:.3e}");
    let clarabel = ClarabelProjector::default().project(problem).unwrap();
    let gap = max_gap(&sol.x, &clarabel.x);
    assert!(gap <= 1e-8, "native and Clarabel differ by {gap:.3e}");
    let tight = problem
        .kkt_residuals(&clarabel.x, &clarabel.multipliers)
        .max();
    assert!(tight <= 1e-10, "Clarabel's own KKT residual {tight:.3e}");
    sol.stats.iterations
}
