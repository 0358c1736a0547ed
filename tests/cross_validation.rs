//! Clarabel and OSQP, at their tight settings, on a jammed crowd with many simultaneous
//! contacts: every step is projected by both and they must agree to 1e-6 (∞-norm).
#![cfg(all(feature = "clarabel", feature = "osqp"))]

use std::sync::Arc;
use sweeping::backends::{ClarabelProjector, OsqpProjector};
use sweeping::crowd::{DiskPairs, Motion, PersonShapes, Population, Shape};
use sweeping::prelude::*;

/// 100 people on a 10 × 10 grid with 1 cm gaps, all walking left at speed 1 into the wall
/// x = 0: after a few steps every person presses on a neighbour or the wall.
fn jammed_crowd() -> (Problem, Arc<Population>) {
    let r = 0.2;
    let side = 10;
    let mut q0 = Vec::new();
    for i in 0..side {
        for j in 0..side {
            q0.push(0.21 + i as f64 * 0.41);
            q0.push(0.21 + j as f64 * 0.41 + if i % 2 == 0 { 0.0 } else { 0.1 });
        }
    }
    let pop = Population::new(vec![r; side * side]).shared();
    let walls = vec![
        (
            Shape::Segment {
                a: [0.0, -1.0],
                b: [0.0, 6.0],
            },
            Motion::Static,
        ),
        (
            Shape::Segment {
                a: [-1.0, 0.0],
                b: [6.0, 0.0],
            },
            Motion::Static,
        ),
    ];
    let problem = Problem::new(q0, |_t: f64, q: &[f64], f: &mut [f64]| {
        for i in 0..q.len() / 2 {
            f[2 * i] = -1.0;
            f[2 * i + 1] = -0.3;
        }
    })
    .with_family(DiskPairs::new(pop.clone()))
    .with_family(PersonShapes::new("walls", pop.clone(), walls));
    (problem, pop)
}

#[test]
fn clarabel_and_osqp_agree_on_a_jam_with_many_contacts() {
    let (problem, _) = jammed_crowd();
    let settings = StepperSettings {
        h: 0.05,
        t_end: 1.0,
        ..Default::default()
    };
    let mut both = CrossCheck::new(ClarabelProjector::default(), OsqpProjector::default(), 1e-6);
    let mut max_active = 0;
    let mut obs = sweeping::observers::Callback::new(|r: &StepReport, _q: &[f64]| {
        max_active = max_active.max(r.active);
    });
    let run = Stepper::new(&problem, settings)
        .unwrap()
        .run(&mut both, &mut [&mut obs])
        .unwrap_or_else(|f| panic!("{f}"));
    let stats = both.stats().clone();
    println!(
        "steps {}, most active contacts {}, largest Clarabel–OSQP gap {:.2e}, mean {:.2e}",
        run.stats.steps,
        max_active,
        stats.max_gap,
        stats.sum_gap / stats.compared as f64
    );
    assert!(max_active >= 50, "only {max_active} simultaneous contacts");
    assert!(stats.max_gap <= 1e-6, "gap {:.3e}", stats.max_gap);
    assert!(
        run.stats.max_violation < 1e-6,
        "violation {}",
        run.stats.max_violation
    );
}
