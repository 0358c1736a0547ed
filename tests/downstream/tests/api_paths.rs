//! The projection contract as a downstream crate names it: everything through `sweeping::api`
//! (the trait, the problem and answer types, the conformance kit and its tolerances), with no
//! dependency on `sweeping-api` itself.

use sweeping::api::conformance::{run_all, ReferenceProjector, Tolerances};
use sweeping::api::{Projection, ProjectionError, ProjectionProblem, Projector, SparseRows};

/// A backend of the user's own: the reference projector behind a name of its own.
struct MyBackend(ReferenceProjector);

impl Projector for MyBackend {
    fn name(&self) -> &str {
        "my-backend"
    }
    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        self.0.project(problem)
    }
}

#[test]
fn a_backend_written_against_sweeping_api_passes_the_conformance_kit() {
    let mut backend = MyBackend(ReferenceProjector::default());
    // Hildreth's method, underneath, reports an empty set as not converged, not with a
    // certificate: the kit is told so.
    let tolerances = Tolerances {
        certifies_infeasibility: false,
        ..Tolerances::default()
    };
    let failures = run_all(&mut backend, &tolerances);
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn a_problem_built_from_sweeping_api_types_is_projected() {
    // min ½‖x − (−1, 0)‖² s.t. x₀ ≥ 0: the answer is the origin.
    let rows = SparseRows::from_rows(2, &[vec![(0, 1.0)]]);
    let problem = ProjectionProblem::new(vec![-1.0, 0.0], rows, vec![0.0]).unwrap();
    let answer = MyBackend(ReferenceProjector::default())
        .project(&problem)
        .unwrap();
    assert!(
        answer.x[0].abs() < 1e-9 && answer.x[1].abs() < 1e-9,
        "{:?}",
        answer.x
    );
}
