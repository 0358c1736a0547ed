//! Exact case (a): two disks of radius ½ on a line. The rear one (person 0, at x = 0) wants
//! velocity (1, 0); the front one (person 1) is at rest, the gap between them is `d₀`.
//!
//! Exact solution: the rear disk moves freely until `t = d₀`, then the two touch and move
//! together at speed ½ (the projection of (1, 0) onto `{v₀ ≤ v₁}` is (½, ½)):
//!
//! ```text
//! x₀(t) = t,               x₁(t) = 1 + d₀                for t ≤ d₀,
//! x₀(t) = d₀ + (t − d₀)/2,  x₁(t) = 1 + d₀ + (t − d₀)/2  for t ≥ d₀.
//! ```
//!
//! The scheme reproduces it to round-off for every `h`: the disks stay on the x-axis, so the
//! linearized pair constraint `x₁ − x₀ ≥ 1` is exact, and a step of length `h` with gap
//! `g < h` at its start gives `x₀ += (h + g)/2`, `x₁ += (h − g)/2` — exactly the motion over a
//! step in which contact begins after time `g`.

mod common;

use sweeping::api::conformance::ReferenceProjector;
use sweeping::crowd::{DiskPairs, Population};
use sweeping::prelude::*;
use sweeping::stepper::Run;

const T_END: f64 = 2.0;

fn exact(d0: f64, t: f64) -> [f64; 4] {
    if t <= d0 {
        [t, 0.0, 1.0 + d0, 0.0]
    } else {
        let s = (t - d0) / 2.0;
        [d0 + s, 0.0, 1.0 + d0 + s, 0.0]
    }
}

fn problem(d0: f64, culled: bool) -> Problem {
    let pop = Population::new(vec![0.5, 0.5]).shared();
    let pairs = if culled {
        DiskPairs::new(pop)
    } else {
        DiskPairs::all_pairs(pop)
    };
    Problem::new(
        vec![0.0, 0.0, 1.0 + d0, 0.0],
        |_t: f64, _q: &[f64], f: &mut [f64]| {
            f.copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
        },
    )
    .with_family(pairs)
}

fn run(d0: f64, h: f64, culled: bool, projector: &mut dyn Projector) -> Run {
    let p = problem(d0, culled);
    let settings = StepperSettings {
        h,
        t_end: T_END,
        ..Default::default()
    };
    Stepper::new(&p, settings)
        .expect("feasible start")
        .run(projector, &mut [])
        .unwrap_or_else(|f| panic!("d0 = {d0}, h = {h}: {f}"))
}

/// Largest coordinate error over all recorded times.
fn max_error(d0: f64, run: &Run) -> f64 {
    run.trajectory
        .times
        .iter()
        .zip(&run.trajectory.states)
        .flat_map(|(&t, q)| {
            let e = exact(d0, t);
            q.iter()
                .zip(e)
                .map(|(a, b)| (a - b).abs())
                .collect::<Vec<_>>()
        })
        .fold(0.0, f64::max)
}

/// Step lengths: larger than the gap, dividing it, not dividing it, not dividing T.
const STEPS: [f64; 10] = [0.9, 0.5, 0.37, 0.25, 0.1, 0.07, 0.037, 0.0125, 0.01, 0.003];
const GAPS: [f64; 3] = [0.37, 0.5, 0.05];

#[test]
fn reference_backend_reproduces_the_exact_solution_to_round_off() {
    let mut inside_a_step = 0;
    for d0 in GAPS {
        for h in STEPS {
            let mut p = ReferenceProjector::default();
            let r = run(d0, h, true, &mut p);
            let n = r.stats.steps as f64;
            let err = max_error(d0, &r);
            // Round-off: a few ulps of the positions (≤ 3) per step.
            let tol = 4.0 * f64::EPSILON * 3.0 * (n + 1.0);
            assert!(
                err <= tol,
                "d0 = {d0}, h = {h}: error {err:.3e} > {tol:.3e}"
            );
            assert!((r.t_final - T_END).abs() < 1e-12);
            assert!(r.stats.max_violation <= 1e-12);
            // One row active in every step after contact.
            assert!(r.stats.max_active == 1);
            let frac = d0 / h - (d0 / h).floor();
            if frac > 1e-6 && frac < 1.0 - 1e-6 {
                inside_a_step += 1;
            }
        }
    }
    assert!(
        inside_a_step >= 10,
        "contact began inside a step in {inside_a_step} runs only"
    );
}

#[test]
fn culling_changes_nothing() {
    for h in [0.37, 0.07, 0.01] {
        let a = run(0.37, h, true, &mut ReferenceProjector::default());
        let b = run(0.37, h, false, &mut ReferenceProjector::default());
        let gap = common::trajectory_gap(&a.trajectory, &b.trajectory);
        assert!(
            gap <= 1e-14,
            "h = {h}: culled and all-pairs differ by {gap:.3e}"
        );
        // The culled run assembles no row while the gap exceeds twice the step (its cutoff).
        if 2.0 * h < 0.37 {
            assert!(
                a.stats.rows < b.stats.rows,
                "h = {h}: {} vs {} rows",
                a.stats.rows,
                b.stats.rows
            );
        }
    }
}

#[test]
fn real_backends_reproduce_the_exact_solution() {
    for (choice, mut p) in common::real_backends() {
        for d0 in GAPS {
            for h in [0.9, 0.37, 0.07, 0.01] {
                let r = run(d0, h, true, &mut p);
                let err = max_error(d0, &r);
                assert!(err <= 1e-7, "{choice}: d0 = {d0}, h = {h}: error {err:.3e}");
            }
        }
    }
}
