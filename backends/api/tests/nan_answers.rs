//! An answer holding a NaN never passes a check: its KKT residuals, its violation and its
//! distance to another answer are NaN (`f64::max`, which these folds once used, drops NaN
//! and read them as 0).

use sweeping_api::conformance::max_gap;
use sweeping_api::{ProjectionProblem, SparseRows};

/// `x₁ − x₀ ≥ 0.4` with `y = (0, 0.1)`: the answer is `(−0.15, 0.25)`, `λ = 0.15`.
fn pair() -> ProjectionProblem {
    let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
    ProjectionProblem::new(vec![0.0, 0.1], a, vec![0.4]).unwrap()
}

#[test]
fn the_true_answer_has_small_residuals() {
    let p = pair();
    let r = p.kkt_residuals(&[-0.15, 0.25], &[0.15]);
    assert!(r.max() < 1e-15, "{r:?}");
}

#[test]
fn a_nan_in_the_point_makes_every_residual_it_reaches_nan() {
    let p = pair();
    let r = p.kkt_residuals(&[f64::NAN, 0.25], &[0.15]);
    assert!(r.primal.is_nan() && r.stationarity.is_nan() && r.complementarity.is_nan());
    assert!(r.max().is_nan());
    assert!(p.max_violation(&[f64::NAN, 0.25]).is_nan());
}

#[test]
fn a_nan_multiplier_makes_the_residuals_nan() {
    let p = pair();
    let r = p.kkt_residuals(&[-0.15, 0.25], &[f64::NAN]);
    assert!(r.dual.is_nan() && r.max().is_nan(), "{r:?}");
}

#[test]
fn a_nan_entry_makes_the_gap_to_any_answer_nan() {
    assert!(max_gap(&[1.0, f64::NAN], &[1.0, 2.0]).is_nan());
    assert_eq!(max_gap(&[1.0, 2.5], &[1.0, 2.0]), 0.5);
}

/// A backend whose answer holds a NaN in its second coordinate.
struct NanProjector;

impl sweeping_api::Projector for NanProjector {
    fn name(&self) -> &str {
        "nan"
    }
    fn project(
        &mut self,
        p: &ProjectionProblem,
    ) -> Result<sweeping_api::Projection, sweeping_api::ProjectionError> {
        let mut answer = sweeping_api::Projection::identity(p, "nan");
        answer.x[1] = f64::NAN;
        Ok(answer)
    }
}

#[test]
fn a_cross_check_fails_on_a_nan_coordinate_and_names_it() {
    use sweeping_api::conformance::ReferenceProjector;
    use sweeping_api::{CrossCheck, ProjectionError, Projector};
    let mut both = CrossCheck::new(ReferenceProjector::default(), NanProjector, 1e-9);
    match both.project(&pair()) {
        Err(ProjectionError::Disagreement {
            gap, coordinate, ..
        }) => {
            assert!(gap.is_nan());
            assert_eq!(coordinate, 1);
        }
        other => panic!("{other:?}"),
    }
    assert!(both.stats().max_gap.is_nan());
}
