//! Exact cases of Moreau's class (sweeping by moving convex sets) against their closed forms:
//! the play operator and a point pushed against the inside of a moving disk
//! (`sweeping::study::exact::{PlayOperator, PointInsideMovingDisk}`; the derivations are
//! in their docs). The fitted orders must stay near 1, the order of the catching-up
//! algorithm for convex sets; `sweep converge --exact play` (or `inside-disk`) reproduces
//! the numbers printed here.

use sweeping::api::conformance::ReferenceProjector;
use sweeping::prelude::*;
use sweeping::study::exact::{true_error_study, ExactCase, PlayOperator, PointInsideMovingDisk};
use sweeping::study::{fit_order, BoxError, ConvergenceReport};

fn study(case: &dyn ExactCase, hs: &[f64]) -> ConvergenceReport {
    let make =
        || -> Result<Box<dyn Projector>, BoxError> { Ok(Box::new(ReferenceProjector::default())) };
    true_error_study(case, hs, 20, &make, &StepperSettings::default(), false).unwrap()
}

fn errors(report: &ConvergenceReport) -> (Vec<f64>, Vec<f64>) {
    let grid = report.rows.iter().map(|r| r.error).collect();
    let sup = report.rows.iter().map(|r| r.error_sup.unwrap()).collect();
    (grid, sup)
}

#[test]
fn the_play_operator_converges_at_order_one_in_the_sup_norm() {
    // h = 6/(2m + 1)·…: steps that do not land on the extrema of u = sin 2t.
    let hs = [0.3 / 8.0, 0.3 / 4.0, 0.3 / 2.0, 0.3];
    let report = study(&PlayOperator::default(), &hs);
    let (grid, sup) = errors(&report);
    let order_sup = fit_order(&hs, &sup).unwrap().order;
    println!("play operator: h = {hs:?}, grid errors {grid:?}, sup errors {sup:?}, sup order {order_sup:.3}");
    assert!((0.85..1.3).contains(&order_sup), "sup order {order_sup}");
    // The scheme clamps to the interval at the grid times: its grid error is no larger
    // than the sup error.
    for (g, s) in grid.iter().zip(&sup) {
        assert!(g <= s, "grid {g:.3e} > sup {s:.3e}");
    }
}

#[test]
fn a_point_pressed_inside_a_moving_disk_converges_at_order_one() {
    let hs = [0.025, 0.05, 0.1, 0.2];
    let case = PointInsideMovingDisk::default();
    let report = study(&case, &hs);
    let (grid, sup) = errors(&report);
    let order = fit_order(&hs, &grid).unwrap().order;
    let order_sup = fit_order(&hs, &sup).unwrap().order;
    println!("inside a moving disk: h = {hs:?}, grid errors {grid:?}, order {order:.3}; sup errors {sup:?}, order {order_sup:.3}");
    assert!((0.85..1.3).contains(&order), "order {order}");
    // The sup norm adds the piecewise-linear interpolant's error across the contact step,
    // where the velocity jumps by the normal part of f − v (≤ |f − v| < 0.91): at most a
    // quarter of that jump times h, wherever t_c falls in its step (so no clean fitted order).
    for ((h, g), s) in hs.iter().zip(&grid).zip(&sup) {
        assert!(*s <= g + 0.25 * 0.91 * h, "h = {h}: sup {s:.3e}");
    }
    // Every run stays inside the disk (the concave constraint is projected onto exactly).
    for row in &report.rows {
        assert!(
            row.cost.max_violation <= 1e-9,
            "h = {}: {:.3e}",
            row.h,
            row.cost.max_violation
        );
    }
}
