//! A block the engine cannot certify goes to the fallback; when the fallback fails too, the
//! error is the engine's, naming the block and why it was handed on, with the fallback's own
//! error inside and a certificate's rows in the whole problem's numbering.

use sweeping_api::{Projection, ProjectionError, ProjectionProblem, Projector, SparseRows};
use sweeping_qp::{Engine, EngineSettings};

/// A fallback that always fails with `error` (its rows, if any, in the block's numbering).
struct Failing(ProjectionError);

impl Projector for Failing {
    fn name(&self) -> &str {
        "failing"
    }
    fn project(&mut self, _: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        Err(self.0.clone())
    }
}

/// Two independent blocks: unknown 0 (rows 0), unknowns 1–2 (rows 1, 2), every row violated
/// at y = 0; an engine allowed no iteration certifies neither.
fn two_blocks() -> ProjectionProblem {
    let a = SparseRows::from_rows(
        3,
        &[
            vec![(0, 1.0)],
            vec![(1, 1.0), (2, -1.0)],
            vec![(1, 1.0), (2, 1.0)],
        ],
    );
    ProjectionProblem::new(vec![0.0; 3], a, vec![1.0, 1.0, 1.0]).unwrap()
}

fn helpless() -> Engine {
    Engine::new(EngineSettings {
        active_set_iterations: 0,
        interior_point_iterations: 0,
        finish_iterations: 0,
        ..EngineSettings::default()
    })
}

#[test]
fn a_failing_fallback_is_reported_as_the_engines_with_the_block() {
    let mut fallback = Failing(ProjectionError::NotConverged {
        backend: "failing".into(),
        iterations: 7,
        status: "gave up".into(),
    });
    let err = helpless()
        .project(&two_blocks(), "native", Some(&mut fallback))
        .unwrap_err();
    match &err {
        ProjectionError::Backend { backend, message } => {
            assert_eq!(backend, "native");
            assert!(message.contains("block 0"), "{message}");
            assert!(message.contains("went to its fallback"), "{message}");
            assert!(
                message.contains("failing: not converged after 7"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().starts_with("native: "), "{err}");
}

#[test]
fn a_fallbacks_certificate_keeps_its_variant_and_gets_the_whole_problems_rows() {
    // The fallback certifies the second block (rows 1 and 2) empty, in its own numbering
    // (rows 0 and 1 of the block); the first block goes to it first, so answer it.
    struct SecondEmpty;
    impl Projector for SecondEmpty {
        fn name(&self) -> &str {
            "second-empty"
        }
        fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
            if p.n_rows() == 1 {
                let mut x = p.y().to_vec();
                x[0] = 1.0;
                let mut answer = Projection::identity(p, "second-empty");
                answer.x = x;
                answer.multipliers = vec![1.0];
                return Ok(answer);
            }
            Err(ProjectionError::Infeasible {
                backend: "second-empty".into(),
                detail: "certified".into(),
                rows: vec![0, 1],
            })
        }
    }
    let err = helpless()
        .project(&two_blocks(), "native", Some(&mut SecondEmpty))
        .unwrap_err();
    match err {
        ProjectionError::Infeasible {
            backend,
            detail,
            rows,
        } => {
            assert_eq!(backend, "native");
            assert!(detail.contains("block 1"), "{detail}");
            assert!(detail.contains("second-empty found: certified"), "{detail}");
            assert_eq!(rows, vec![1, 2]);
        }
        other => panic!("{other:?}"),
    }
}
