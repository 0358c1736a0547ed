//! Two exact cases in the plane, both through the crowd's wall-and-obstacle family
//! (`PersonShapes`).
//!
//! # 1. Sliding around a disk obstacle (curved: the scheme has a linearization error)
//! A person of radius `r_p = ¼` walks at the desired velocity `u = (1, 0)` from `(−a, b)`,
//! `a = 2`, `b = 0.6`, towards a fixed disk obstacle of radius `¾` centred at the origin. Her
//! centre must stay outside the disk of radius `R = 1`.
//!
//! * Free until it reaches the circle at `t₁ = a − √(R² − b²) = 1.2`, at angle `θ₀` with
//!   `cos θ₀ = −√(R² − b²)/R`, `sin θ₀ = b/R`.
//! * Then it slides: on the circle `z = R(cos θ, sin θ)`, the velocity is the tangential part
//!   of `u` (the normal part `u·n = cos θ < 0` pushes into the obstacle), `R θ' = u·τ = −sin θ`,
//!   whence `tan(θ/2) = tan(θ₀/2) e^{−(t − t₁)/R}` (here `tan(θ₀/2) = 3`).
//! * It leaves the circle at the top, `θ = π/2`, when `u·n` turns non-negative, at
//!   `t₂ = t₁ + R ln tan(θ₀/2) = 1.2 + ln 3`, and walks on freely: `z = (t − t₂, R)`.
//!
//! The scheme linearizes the circle at each `q_k` and projects onto the tangent half-plane:
//! an `O(h²)` error per step of contact, so first order overall (measured below).
//!
//! # 2. A moving oblique wall (flat: the scheme is exact to round-off)
//! The long segment through the origin along `τ = (0.8, 0.6)` translates at speed `w = 0.1`
//! along its normal `n = (−0.6, 0.8)`; a person of radius `0.2` starts at `(−1, 0.5)` with
//! `u = (1, 0)`, so `u·n = −0.6`. The gap `z·n − w t − 0.2 = 0.8 − 0.7 t` closes at
//! `t_c = 8/7`; afterwards the person moves at `u + 0.7 n` (the multiplier `0.7` keeps the
//! normal speed at `w`). The constraint is affine on that side, so a step that starts with gap
//! `γ < 0.7 h` ends at `z + h u + (0.7 h − γ) n`, exactly the true motion.

mod common;
use common::run;

use std::sync::Arc;
use sweeping::api::conformance::ReferenceProjector;
use sweeping::crowd::{Motion, PersonShapes, Population, Shape};
use sweeping::prelude::*;
use sweeping::stepper::Run;

// --- Case 1: the disk obstacle -------------------------------------------------------------

const A0: f64 = 2.0;
const B0: f64 = 0.6;
const R: f64 = 1.0;
const T_DISK: f64 = 3.5;

fn disk_exact(t: f64) -> [f64; 2] {
    let c = (R * R - B0 * B0).sqrt();
    let t1 = A0 - c;
    let theta0 = std::f64::consts::PI - (B0 / R).asin();
    let k = (theta0 / 2.0).tan();
    let t2 = t1 + R * k.ln();
    if t <= t1 {
        [-A0 + t, B0]
    } else if t <= t2 {
        let th = 2.0 * (k * (-(t - t1) / R).exp()).atan();
        [R * th.cos(), R * th.sin()]
    } else {
        [t - t2, R]
    }
}

fn disk_problem() -> Problem {
    let pop = Population::new(vec![0.25]).shared();
    let obstacle = PersonShapes::new(
        "obstacles",
        Arc::clone(&pop),
        vec![(
            Shape::Disk {
                center: [0.0, 0.0],
                radius: R - 0.25,
            },
            Motion::Static,
        )],
    );
    Problem::new(vec![-A0, B0], |_t: f64, _q: &[f64], f: &mut [f64]| {
        f.copy_from_slice(&[1.0, 0.0]);
    })
    .with_family(obstacle)
}

fn max_error(r: &Run, exact: impl Fn(f64) -> [f64; 2]) -> f64 {
    r.trajectory
        .times
        .iter()
        .zip(&r.trajectory.states)
        .map(|(&t, q)| {
            let e = exact(t);
            ((q[0] - e[0]).powi(2) + (q[1] - e[1]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_disk_solution_is_consistent() {
    // On the circle during contact, continuous at t₁ and t₂, leaves horizontally at height R.
    let t1 = A0 - (R * R - B0 * B0).sqrt();
    let t2 = t1 + 3f64.ln();
    for t in [t1 + 0.1, 1.7, t2 - 0.01] {
        let z = disk_exact(t);
        assert!((z[0].hypot(z[1]) - R).abs() < 1e-12);
    }
    for s in [t1, t2] {
        let (a, b) = (disk_exact(s - 1e-9), disk_exact(s + 1e-9));
        assert!((a[0] - b[0]).abs() + (a[1] - b[1]).abs() < 1e-8);
    }
    assert!((disk_exact(t2)[0]).abs() < 1e-12 && (disk_exact(t2)[1] - R).abs() < 1e-12);
    // The velocity on the circle is the tangential part of u: check by differences at t = 1.7.
    let (zm, zp) = (disk_exact(1.7 - 1e-6), disk_exact(1.7 + 1e-6));
    let v = [(zp[0] - zm[0]) / 2e-6, (zp[1] - zm[1]) / 2e-6];
    let z = disk_exact(1.7);
    let n = [z[0] / R, z[1] / R];
    let un = n[0]; // u·n with u = (1, 0)
    assert!(un < 0.0);
    assert!((v[0] - (1.0 - un * n[0])).abs() < 1e-6 && (v[1] + un * n[1]).abs() < 1e-6);
}

/// Measured order of the scheme on the curved obstacle (≈ 1).
#[test]
fn sliding_around_a_disk_converges_at_order_one() {
    let p = disk_problem();
    let hs = common::halvings(0.1, 6);
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let r = run(&p, h, T_DISK, &mut ReferenceProjector::default());
            // The linearization is an inner approximation of the convex distance: the
            // solution never enters the obstacle.
            assert!(r.stats.max_violation <= 1e-12);
            max_error(&r, disk_exact)
        })
        .collect();
    let order = common::fitted_order(&hs, &errs);
    eprintln!(
        "disk obstacle: h = {hs:?}\n  errors = {}\n  fitted order = {order:.3}",
        common::sci(&errs)
    );
    assert!(order >= 0.8, "fitted order {order:.3}");
    // Errors at most |u| h: no step can be off by more than one step's free motion.
    for (&h, &e) in hs.iter().zip(&errs) {
        assert!(e <= h, "h = {h}: error {e:.3e}");
    }
}

// --- Case 2: the moving oblique wall ---------------------------------------------------------

const N: [f64; 2] = [-0.6, 0.8];
const W: f64 = 0.1;
const T_WALL: f64 = 3.0;

fn wall_exact(t: f64) -> [f64; 2] {
    let tc = 0.8 / 0.7;
    if t <= tc {
        [-1.0 + t, 0.5]
    } else {
        let s = t - tc;
        [-1.0 + tc + s * (1.0 + 0.7 * N[0]), 0.5 + s * 0.7 * N[1]]
    }
}

fn wall_problem() -> Problem {
    let pop = Population::new(vec![0.2]).shared();
    let wall = PersonShapes::new(
        "walls",
        pop,
        vec![(
            Shape::Segment {
                a: [-8.0, -6.0],
                b: [8.0, 6.0],
            },
            Motion::Velocity([W * N[0], W * N[1]]),
        )],
    );
    Problem::new(vec![-1.0, 0.5], |_t: f64, _q: &[f64], f: &mut [f64]| {
        f.copy_from_slice(&[1.0, 0.0]);
    })
    .with_family(wall)
}

#[test]
fn moving_oblique_wall_is_exact_to_round_off() {
    let p = wall_problem();
    for h in [0.9, 0.5, 0.3, 0.1, 0.07, 0.01, 0.003] {
        let r = run(&p, h, T_WALL, &mut ReferenceProjector::default());
        let err = max_error(&r, wall_exact);
        let tol = 1e-13 * (r.stats.steps as f64 + 1.0);
        assert!(err <= tol, "h = {h}: error {err:.3e} > {tol:.1e}");
        assert_eq!(r.stats.max_active, 1);
    }
}

#[test]
fn real_backends_agree_on_both_cases() {
    let (pd, pw) = (disk_problem(), wall_problem());
    let reference = run(&pd, 0.05, T_DISK, &mut ReferenceProjector::default());
    for (choice, mut p) in common::real_backends() {
        let r = run(&pd, 0.05, T_DISK, &mut p);
        let gap = common::trajectory_gap(&r.trajectory, &reference.trajectory);
        // ~1e-8 per step, accumulated at worst over the steps.
        let tol = (1e-8 * r.stats.steps as f64).max(1e-7);
        assert!(gap <= tol, "{choice}, disk: {gap:.3e} from the reference");
        let r = run(&pw, 0.07, T_WALL, &mut p);
        let err = max_error(&r, wall_exact);
        assert!(err <= 1e-7, "{choice}, wall: error {err:.3e}");
    }
}
