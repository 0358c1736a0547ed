//! A jammed queue at a door: more tight rows than coordinates, and an interior point whose
//! directions lose accuracy before it converges.
//!
//! `data/door_queue_qp.json` is one block of a projection of the 2000-person evacuation scene
//! (`examples/scenes/large-evacuation.toml`) in its first 12 s: 2094 rows on 1604
//! coordinates, where the native method used to hand the block to its fallback. Its interior
//! point's dual residual stalled near `1e-12` (directions of the normal equations no better
//! than that, their weights `λ/s` spanning some twenty orders of magnitude), then broke down
//! to `8e-4`: no guess for the active-set finish, which then had to start cold and gave up.
//! Since the interior point refines its solves once its residuals grow, it converges in 32
//! iterations and the finish takes 22. The native method must solve the block on its own and
//! agree with Clarabel, an independent interior-point solver.

use sweeping_api::conformance::max_gap;
use sweeping_api::{ProjectionProblem, Projector};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::NativeProjector;

fn door_queue_qp() -> ProjectionProblem {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/door_queue_qp.json");
    let text = std::fs::read_to_string(path).expect("read the door-queue QP");
    serde_json::from_str(&text).expect("parse the door-queue QP")
}

#[test]
fn a_door_queue_is_rescued_without_fallback_and_agrees_with_clarabel() {
    let problem = door_queue_qp();
    assert_eq!((problem.n_rows(), problem.dim()), (2094, 1604));
    // No fallback configured: a failure would be an error here, not a Clarabel answer.
    let sol = NativeProjector::default()
        .project(&problem)
        .expect("the native method solves the door queue on its own");
    assert_eq!((sol.stats.rescues, sol.stats.fallbacks), (1, 0));
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= 1e-10, "KKT residual {kkt:.3e}");
    let clarabel = ClarabelProjector::default().project(&problem).unwrap();
    let gap = max_gap(&sol.x, &clarabel.x);
    assert!(gap <= 1e-8, "native and Clarabel differ by {gap:.3e}");
    let tight = problem
        .kkt_residuals(&clarabel.x, &clarabel.multipliers)
        .max();
    assert!(tight <= 1e-10, "Clarabel's own KKT residual {tight:.3e}");
}
