//! The exact cases beyond the Euclidean class, against their closed forms
//! (`sweeping::study::exact`), with measured orders of convergence:
//!
//! * `masses-wall`: a point with masses `(1, 4)` pushed by a moving wall, projected in the
//!   metric `W = diag(1, 4)`; the reaction moves it along `W⁻¹n`. The scheme is the discrete
//!   Skorokhod map along `n`, pushed along the same direction: first order (the explicit
//!   prediction). The same problem projected in the identity metric pushes along `n` and stays
//!   off by `O(1)`: a backend that dropped the metric would fail here.
//! * `on-circle`: a point held on a moving circle by an equality constraint. The scheme
//!   projects onto the tangent line at `q_k` and leaves the circle by `O(h²)` per step, which
//!   the next step corrects: the position converges at order 1, the residual `|h|` at order 2.

mod common;
use common::run;

use sweeping::api::conformance::ReferenceProjector;
use sweeping::api::Metric;
use sweeping::prelude::*;
use sweeping::stepper::Run;
use sweeping::study::distance;
use sweeping::study::exact::{ExactCase, MassesAgainstMovingWall, PointOnMovingCircle};

/// `max_k |q(t_k) − q_k|` over the grid.
fn grid_error(case: &dyn ExactCase, r: &Run) -> f64 {
    r.trajectory
        .times
        .iter()
        .zip(&r.trajectory.states)
        .map(|(&t, q)| distance(q, &case.exact(t)))
        .fold(0.0, f64::max)
}

fn errors(case: &dyn ExactCase, hs: &[f64], mut check: impl FnMut(&Run)) -> Vec<f64> {
    let problem = case.problem();
    hs.iter()
        .map(|&h| {
            let r = run(
                &problem,
                h,
                case.t_end(),
                &mut ReferenceProjector::default(),
            );
            check(&r);
            grid_error(case, &r)
        })
        .collect()
}

#[test]
fn masses_against_a_moving_wall_converge_at_order_one() {
    let case = MassesAgainstMovingWall::default();
    let hs = common::halvings(0.08, 6);
    let errs = errors(&case, &hs, |r| {
        // The wall is affine: the linearized set is the true one.
        assert!(r.stats.max_violation <= 1e-10, "{}", r.stats.max_violation);
        assert_eq!(r.stats.max_equality_residual, 0.0);
    });
    let order = common::fitted_order(&hs, &errs);
    eprintln!(
        "masses-wall: h = {hs:?}\n  errors = {}\n  fitted order = {order:.3}",
        common::sci(&errs)
    );
    assert!((0.85..=1.2).contains(&order), "fitted order {order:.3}");
    // Along n, the moving-wall bound T A h + A h²/8 (A = a n·e = 1), doubled by the
    // Skorokhod map's Lipschitz constant over |W⁻¹n|/κ ≤ 1 and the free part's own error.
    for (&h, &e) in hs.iter().zip(&errs) {
        assert!(e <= 2.0 * (6.0 * h + h * h / 8.0), "h = {h}: error {e:.3e}");
    }
}

#[test]
fn the_identity_metric_would_push_the_masses_the_wrong_way() {
    let case = MassesAgainstMovingWall::default();
    let euclidean = case.problem().with_metric(Metric::Identity);
    let r = run(
        &euclidean,
        0.01,
        case.t_end(),
        &mut ReferenceProjector::default(),
    );
    let off = grid_error(&case, &r);
    assert!(off > 0.1, "the identity metric is off by only {off:.3e}");
}

#[test]
fn a_point_on_a_moving_circle_converges_at_order_one_and_its_residual_at_order_two() {
    let case = PointOnMovingCircle::default();
    let hs = common::halvings(0.08, 6);
    let mut residuals = Vec::new();
    let errs = errors(&case, &hs, |r| {
        residuals.push(r.stats.max_equality_residual)
    });
    let order = common::fitted_order(&hs, &errs);
    let residual_order = common::fitted_order(&hs, &residuals);
    eprintln!(
        "on-circle: h = {hs:?}\n  errors = {}\n  fitted order = {order:.3}\n  residuals = {}\n  \
         residual order = {residual_order:.3}",
        common::sci(&errs),
        common::sci(&residuals)
    );
    assert!((0.85..=1.2).contains(&order), "fitted order {order:.3}");
    assert!(
        (1.8..=2.2).contains(&residual_order),
        "residual order {residual_order:.3}"
    );
    assert!(
        residuals.iter().all(|r| *r > 0.0),
        "a nonlinear h is never exact"
    );
}

/// Every real backend gives the reference's trajectories on both cases (Clarabel and OSQP
/// with `P = W` and an equality row, native in `z = Lᵀx` with the row as a pair).
#[test]
fn real_backends_agree_with_the_reference() {
    let cases: [Box<dyn ExactCase>; 2] = [
        Box::new(MassesAgainstMovingWall::default()),
        Box::new(PointOnMovingCircle::default()),
    ];
    for case in &cases {
        let problem = case.problem();
        let reference = run(
            &problem,
            0.04,
            case.t_end(),
            &mut ReferenceProjector::default(),
        );
        for (choice, mut p) in common::real_backends() {
            let r = run(&problem, 0.04, case.t_end(), &mut p);
            let gap = common::trajectory_gap(&r.trajectory, &reference.trajectory);
            let tol = (1e-8 * r.stats.steps as f64).max(1e-7);
            assert!(
                gap <= tol,
                "{} on {choice}: differs by {gap:.3e}",
                case.name()
            );
        }
    }
}

/// A metric that is not positive definite, or of the wrong dimension, is refused before the
/// first step with a typed error naming it.
#[test]
fn a_bad_metric_is_refused_at_set_up() {
    let case = MassesAgainstMovingWall::default();
    for (metric, expect) in [
        (Metric::Diagonal(vec![1.0, -4.0]), "W[1, 1] = -4"),
        (
            Metric::Diagonal(vec![1.0]),
            "1 diagonal entries for 2 unknowns",
        ),
    ] {
        let problem = case.problem().with_metric(metric);
        match Stepper::new(&problem, StepperSettings::default()) {
            Err(SweepError::InvalidInput(why)) => {
                assert!(why.contains("metric") && why.contains(expect), "{why}")
            }
            Err(other) => panic!("expected InvalidInput, got {other}"),
            Ok(_) => panic!("accepted a bad metric"),
        }
    }
}

/// A start off an equality constraint is refused, naming it.
#[test]
fn a_start_off_the_circle_is_refused() {
    let case = PointOnMovingCircle::default();
    let mut problem = case.problem();
    problem.set_start(0.0, vec![0.0, 0.0]);
    match Stepper::new(&problem, StepperSettings::default()) {
        Err(SweepError::InfeasibleStart { violations, .. }) => {
            assert_eq!(violations.len(), 1);
            assert!(
                violations[0].constraint.contains("equality"),
                "{violations:?}"
            );
            assert!((violations[0].value + 1.0).abs() < 1e-12, "{violations:?}");
        }
        other => panic!("expected InfeasibleStart, got {:?}", other.err()),
    }
}
