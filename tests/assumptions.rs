//! The constants of A0–A5 against values known by hand, the detection of wedged
//! configurations, and the run-time monitor's policies.

mod common;

use approx::assert_abs_diff_eq;
use common::{estimate, estimate_with};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::SQRT_2;
use sweeping::api::conformance::ReferenceProjector;
use sweeping::assumptions::{
    coordinate_groups, estimate_problem, hull_distance, symmetric_spectral_norm, AssumptionReport,
    Bounds, BoundsMonitor, EstimateSettings, MonitorSettings, Policy, SparseVector,
};
use sweeping::crowd::{DiskPairs, Motion, PersonShapes, Population, Shape};
use sweeping::prelude::*;

fn wall(a: [f64; 2], b: [f64; 2]) -> (Shape, Motion) {
    (Shape::Segment { a, b }, Motion::Static)
}

// ---------------------------------------------------------------- γ by projection

fn dense(v: &[f64]) -> SparseVector {
    SparseVector {
        columns: (0..v.len()).collect(),
        values: v.to_vec(),
    }
}

/// Distance from the origin to the segment [a, b] of the plane.
fn segment_distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let s = if len2 == 0.0 {
        0.0
    } else {
        (-(a[0] * ab[0] + a[1] * ab[1]) / len2).clamp(0.0, 1.0)
    };
    (a[0] + s * ab[0]).hypot(a[1] + s * ab[1])
}

/// dist(0, conv{v₁, v₂, v₃}) in the plane: 0 when the origin is inside the triangle, else the
/// nearest edge.
fn triangle_distance(v: [[f64; 2]; 3]) -> f64 {
    let cross = |p: [f64; 2], q: [f64; 2]| p[0] * q[1] - p[1] * q[0];
    let signs = [cross(v[0], v[1]), cross(v[1], v[2]), cross(v[2], v[0])];
    if signs.iter().all(|s| *s >= 0.0) || signs.iter().all(|s| *s <= 0.0) {
        return 0.0;
    }
    segment_distance(v[0], v[1])
        .min(segment_distance(v[1], v[2]))
        .min(segment_distance(v[2], v[0]))
}

#[test]
fn hull_distance_matches_brute_force_in_the_plane() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut proj = ReferenceProjector::default();
    let mut unit = || {
        let a: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
        [a.cos(), a.sin()]
    };
    let mut inside = 0;
    for _ in 0..40 {
        let (a, b) = (unit(), unit());
        let d = hull_distance(&[dense(&a), dense(&b)], &mut proj).unwrap();
        assert_abs_diff_eq!(d, segment_distance(a, b), epsilon = 1e-7);
        let v = [unit(), unit(), unit()];
        let d3 = hull_distance(&[dense(&v[0]), dense(&v[1]), dense(&v[2])], &mut proj).unwrap();
        let exact = triangle_distance(v);
        if exact == 0.0 {
            inside += 1;
        }
        assert_abs_diff_eq!(d3, exact, epsilon = 1e-7);
    }
    // Both cases (origin inside and outside the triangle) were exercised.
    assert!(
        (1..40).contains(&inside),
        "origin inside {inside} of 40 triangles"
    );
}

#[test]
fn gamma_of_two_half_planes_is_one_over_cos_half_angle() {
    let mut proj = ReferenceProjector::default();
    for deg in [0.0f64, 60.0, 90.0, 120.0, 170.0] {
        let th = deg.to_radians();
        let d = hull_distance(
            &[dense(&[1.0, 0.0]), dense(&[th.cos(), th.sin()])],
            &mut proj,
        )
        .unwrap();
        assert_abs_diff_eq!(1.0 / d, 1.0 / (th / 2.0).cos(), epsilon = 1e-6 / d);
    }
    // Opposite normals: the hull contains the origin.
    let d = hull_distance(&[dense(&[1.0, 0.0]), dense(&[-1.0, 0.0])], &mut proj).unwrap();
    assert!(d < 1e-8, "d = {d}");
}

#[test]
fn gamma_of_separate_groups_combines_as_root_sum_of_squares() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut proj = ReferenceProjector::default();
    // Three groups on disjoint coordinates, each a pair of unit vectors in its own plane
    // (kept in one open half-plane so each hull misses the origin).
    let mut vectors = Vec::new();
    for g in 0..3 {
        for _ in 0..2 {
            let a: f64 = rng.gen_range(-1.2..1.2);
            vectors.push(SparseVector {
                columns: vec![2 * g, 2 * g + 1],
                values: vec![a.cos(), a.sin()],
            });
        }
    }
    let groups = coordinate_groups(&vectors);
    assert_eq!(groups.len(), 3);
    let sum_sq: f64 = groups
        .iter()
        .map(|g| {
            let gv: Vec<SparseVector> = g.iter().map(|&i| vectors[i].clone()).collect();
            hull_distance(&gv, &mut proj).unwrap().powi(-2)
        })
        .sum();
    let whole = hull_distance(&vectors, &mut proj).unwrap();
    assert_abs_diff_eq!(1.0 / whole, sum_sq.sqrt(), epsilon = 1e-6);
}

#[test]
fn spectral_norm_of_a_small_symmetric_matrix() {
    // diag(1, −3) rotated by 30°: spectral norm 3.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let h = [
        c * c - 3.0 * s * s,
        4.0 * c * s,
        4.0 * c * s,
        s * s - 3.0 * c * c,
    ];
    assert_abs_diff_eq!(symmetric_spectral_norm(&h, 2), 3.0, epsilon = 1e-12);
}

// ---------------------------------------------------------------- crowds

#[test]
fn disk_pair_constants() {
    let pop = Population::new(vec![0.5, 0.3]).shared();
    // |q₁ − q₂| = 1.3, 1.0 and 2.0: D = 0.5, 0.2, 1.2 (the last is beyond the neighbourhood).
    let samples = vec![
        (0.0, vec![0.0, 0.0, 1.2, 0.5]),
        (0.5, vec![0.0, 0.0, 0.6, 0.8]),
        (1.0, vec![0.0, 0.0, 2.0, 0.0]),
    ];
    let problem =
        Problem::new(samples[0].1.clone(), NoPerturbation).with_family(DiskPairs::new(pop));
    let r = estimate(&problem, &samples);
    assert_eq!(r.evaluations, 2);
    assert_abs_diff_eq!(r.alpha.as_ref().unwrap().value, SQRT_2, epsilon = 1e-12);
    assert_abs_diff_eq!(r.beta_grad.as_ref().unwrap().value, SQRT_2, epsilon = 1e-12);
    assert_abs_diff_eq!(r.beta_dt.as_ref().unwrap().value, 0.0, epsilon = 1e-15);
    assert_abs_diff_eq!(r.m_dt_grad.as_ref().unwrap().value, 0.0, epsilon = 1e-15);
    // Spectral |D²D| = 2/|q₁ − q₂|, largest at the closest sample (|q₁ − q₂| = 1).
    let m = r.m_hess.as_ref().unwrap();
    assert_abs_diff_eq!(m.value, 2.0, epsilon = 1e-9);
    assert_abs_diff_eq!(m.t, 0.5, epsilon = 1e-15);
    assert!(m.constraint.contains("people 0 and 1"), "{}", m.constraint);
    // A0: the pair is smooth off q₁ = q₂, which lies (r₁ + r₂)/√2 from {D ≥ 0}.
    assert_abs_diff_eq!(r.c.unwrap(), 0.8 / SQRT_2, epsilon = 1e-12);
    // One constraint within ρ nowhere (D ≥ 0.2 > ρ = 0.05): A5 vacuous, γ = 1 in derivations.
    assert!(r.gamma.is_none());
    // Derived: η = α/(Mγ') = √2/2, Θ = 2β/α = 2, r = min(4ρ/(13β), α/(2M)).
    assert_abs_diff_eq!(r.eta.unwrap(), SQRT_2 / 2.0, epsilon = 1e-9);
    assert_abs_diff_eq!(r.theta.unwrap(), 2.0, epsilon = 1e-12);
    let expect_r = (4.0 * 0.05 / (13.0 * SQRT_2)).min(SQRT_2 / 4.0);
    assert_abs_diff_eq!(r.r.unwrap(), expect_r, epsilon = 1e-12);
    // Nothing moves: Q(t) is constant, K_L = 0 and every h is well-posed.
    assert_eq!(r.k_l, Some(0.0));
    assert!(r.h_max.is_some_and(f64::is_infinite));
    assert!(r.failures.is_empty(), "{:?}", r.failures);
}

#[test]
fn probing_outside_q_finds_the_larger_curvature() {
    let pop = Population::new(vec![0.5, 0.5]).shared();
    let q = vec![0.0, 0.0, 1.0, 0.0];
    let problem = Problem::new(q.clone(), NoPerturbation).with_family(DiskPairs::new(pop));
    let settings = EstimateSettings {
        probe_depth: 0.1,
        ..Default::default()
    };
    let r = estimate_with(&problem, &[(0.0, q)], &settings);
    // Moving 0.1 against the unit normal (−e, e)/√2 brings the centres √2·0.1 closer.
    assert_abs_diff_eq!(
        r.m_hess.unwrap().value,
        2.0 / (1.0 - 0.1 * SQRT_2),
        epsilon = 1e-9
    );
    assert_eq!(r.evaluations, 2);
}

#[test]
fn straight_wall_has_zero_curvature() {
    let pop = Population::new(vec![0.2]).shared();
    let q = vec![1.0, 0.25]; // 0.05 from the wall y = 0, interior projection
    let problem = Problem::new(q.clone(), NoPerturbation).with_family(PersonShapes::new(
        "walls",
        pop,
        vec![wall([-10.0, 0.0], [10.0, 0.0])],
    ));
    let r = estimate(&problem, &[(0.0, q)]);
    assert_abs_diff_eq!(r.alpha.as_ref().unwrap().value, 1.0, epsilon = 1e-12);
    assert_abs_diff_eq!(r.beta.unwrap(), 1.0, epsilon = 1e-12);
    assert_abs_diff_eq!(r.m.unwrap(), 0.0, epsilon = 1e-12);
    assert_eq!(r.eta, Some(f64::INFINITY));
    assert_abs_diff_eq!(r.c.unwrap(), 0.2, epsilon = 1e-15);
    // g = 0.05 ≤ ρ: one near-active constraint, γ = 1.
    assert_abs_diff_eq!(r.gamma.as_ref().unwrap().value, 1.0, epsilon = 1e-9);
    assert!(r.failures.is_empty(), "{:?}", r.failures);
}

#[test]
fn moving_wall_dt_is_minus_velocity_dot_normal() {
    let pop = Population::new(vec![0.2]).shared();
    // The line through the origin along (1, 1)/√2; the person on the side of n = (−1, 1)/√2.
    let v = [0.4, -0.2];
    let n = [-1.0 / SQRT_2, 1.0 / SQRT_2];
    let q = vec![0.0, 0.5]; // distance 0.5/√2 ≈ 0.354 from the line
    let problem = Problem::new(q.clone(), NoPerturbation).with_family(PersonShapes::new(
        "walls",
        pop,
        vec![(
            Shape::Segment {
                a: [-10.0, -10.0],
                b: [10.0, 10.0],
            },
            Motion::Velocity(v),
        )],
    ));
    let r = estimate(&problem, &[(0.3, q)]);
    let expect = -(v[0] * n[0] + v[1] * n[1]); // ∂ₜg = −v·n = 0.3·√2
    assert_abs_diff_eq!(
        r.beta_dt.as_ref().unwrap().value,
        expect.abs(),
        epsilon = 1e-12
    );
    // A straight moving wall: the normal does not turn.
    assert_abs_diff_eq!(r.m_dt_grad.as_ref().unwrap().value, 0.0, epsilon = 1e-12);
    assert_abs_diff_eq!(r.beta.unwrap(), 1.0f64.max(expect.abs()), epsilon = 1e-12);
}

#[test]
fn person_wedged_between_walls_is_flagged() {
    let pop = Population::new(vec![0.2]).shared();
    let q = vec![0.2, 1.0];
    let problem = Problem::new(q.clone(), NoPerturbation).with_family(PersonShapes::new(
        "walls",
        pop,
        vec![wall([0.0, -5.0], [0.0, 5.0]), wall([0.4, -5.0], [0.4, 5.0])],
    ));
    let r = estimate(&problem, &[(0.0, q)]);
    assert_eq!(r.gamma_prime.as_ref().unwrap().value, f64::INFINITY);
    assert_eq!(r.gamma.as_ref().unwrap().value, f64::INFINITY);
    assert_eq!(r.eta, Some(0.0));
    let f = r
        .failures
        .iter()
        .find(|f| f.starts_with("A5'"))
        .expect("A5' flagged");
    assert!(f.contains("person 0 against walls #0"), "{f}");
    assert!(f.contains("person 0 against walls #1"), "{f}");
    assert!(r.table().contains("FAILED"));
    // JSON keeps the infinity as "inf" and reads it back.
    let json = serde_json::to_string(&r).unwrap();
    assert!(json.contains("\"inf\""), "{json}");
    let back: AssumptionReport = serde_json::from_str(&json).unwrap();
    assert_eq!(back, r);
}

fn chain(wall_x: f64) -> (Problem, Vec<f64>) {
    let pop = Population::new(vec![0.2; 3]).shared();
    let q = vec![0.2, 1.0, 0.6, 1.0, 1.0, 1.0];
    let problem = Problem::new(q.clone(), NoPerturbation)
        .with_family(DiskPairs::new(pop.clone()))
        .with_family(PersonShapes::new(
            "walls",
            pop,
            vec![
                wall([0.0, -5.0], [0.0, 5.0]),
                wall([wall_x, -5.0], [wall_x, 5.0]),
            ],
        ));
    (problem, q)
}

#[test]
fn chain_from_wall_to_wall_is_flagged() {
    let (problem, q) = chain(1.2);
    let r = estimate(&problem, &[(0.0, q)]);
    assert_eq!(r.gamma_prime.as_ref().unwrap().value, f64::INFINITY);
    let f = r
        .failures
        .iter()
        .find(|f| f.starts_with("A5'"))
        .expect("A5' flagged");
    for who in [
        "people 0 and 1",
        "people 1 and 2",
        "person 0 against walls #0",
        "person 2 against walls #1",
    ] {
        assert!(f.contains(who), "{who} missing from {f}");
    }
}

#[test]
fn chain_with_slack_is_not_flagged() {
    // 0.03 of slack at the far wall: the active set is the wall and the two pairs, whose
    // normals do not cancel; the far wall is within ρ, so A5 at ρ still sees the dependence.
    let (problem, q) = chain(1.23);
    let r = estimate(&problem, &[(0.0, q)]);
    let gp = r.gamma_prime.as_ref().unwrap().value;
    assert!(gp.is_finite(), "γ' = {gp}");
    // Active normals on (x₀, x₁, x₂): a = (1, 0, 0), b = (−1, 1, 0)/√2, c = (0, −1, 1)/√2,
    // Gram matrix G = [[1, −s, 0], [−s, 1, −½], [0, −½, 1]] with s = 1/√2. The nearest point
    // of their hull has all weights positive: G w = 1 gives w = (1 + s w₂, 6 + 4s, 1 + w₂/2),
    // dist² = 1/Σw, so γ' = √(Σw) = √(13 + 6√2).
    assert_abs_diff_eq!(gp, (13.0 + 6.0 * SQRT_2).sqrt(), epsilon = 1e-5);
    assert!(
        r.failures.iter().all(|f| !f.starts_with("A5'")),
        "{:?}",
        r.failures
    );
    assert_eq!(r.gamma.as_ref().unwrap().value, f64::INFINITY);
    assert!(
        r.failures.iter().any(|f| f.starts_with("A5 at ρ")),
        "{:?}",
        r.failures
    );
}

// ---------------------------------------------------------------- a non-crowd constraint

/// A point of the plane outside a ball of radius 1 whose centre moves at velocity (0.5, 0).
struct OutsideMovingBall;

impl ConstraintKernel<2> for OutsideMovingBall {
    type Params = ();
    fn value<D: DualNum<Primitive = f64> + Copy>(&self, _: &(), t: D, z: [D; 2]) -> D {
        let dx = z[0] - t * 0.5;
        (dx * dx + z[1] * z[1]).sqrt() - 1.0
    }
}

#[test]
fn custom_moving_ball_constants() {
    // At t = 2 the centre is (1, 0); z = (4, 4): z − c = (3, 4), |z − c| = 5, n = (0.6, 0.8).
    let q = vec![4.0, 4.0];
    let problem = Problem::new(q.clone(), NoPerturbation).with_family(KernelFamily::single(
        "ball",
        OutsideMovingBall,
        [0, 1],
    ));
    let settings = EstimateSettings {
        neighbourhood: 5.0,
        ..Default::default()
    };
    let r = estimate_with(&problem, &[(2.0, q)], &settings);
    assert_abs_diff_eq!(r.alpha.as_ref().unwrap().value, 1.0, epsilon = 1e-12);
    // ∂ₜg = −v·n = −0.3.
    assert_abs_diff_eq!(r.beta_dt.as_ref().unwrap().value, 0.3, epsilon = 1e-12);
    // D²g = (I − nnᵀ)/|z − c|: spectral norm 1/5.
    assert_abs_diff_eq!(r.m_hess.as_ref().unwrap().value, 0.2, epsilon = 1e-12);
    // ∂ₜ∇g = −(I − nnᵀ)v/|z − c|: |v − (v·n)n|/5 = |(0.32, −0.24)|/5 = 0.08.
    assert_abs_diff_eq!(r.m_dt_grad.as_ref().unwrap().value, 0.08, epsilon = 1e-12);
    // A user family does not state an A0 margin: c is not derived, and the report says so.
    assert!(r.c.is_none());
    assert!(r.notes.iter().any(|n| n.contains("`ball`")));
    let table = r.table();
    for line in ["α (A1)", "M (A3)", "η", "Θ", "K_L"] {
        assert!(table.contains(line), "{line} missing from\n{table}");
    }
}

/// `⟨n, z⟩ ≥ 0` for a unit normal `n`: affine and static.
struct HalfPlane;

impl ConstraintKernel<2> for HalfPlane {
    type Params = [f64; 2];
    fn value<D: DualNum<Primitive = f64> + Copy>(&self, n: &[f64; 2], _t: D, z: [D; 2]) -> D {
        z[0] * n[0] + z[1] * n[1]
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
    fn is_affine(&self) -> bool {
        true
    }
}

#[test]
fn custom_wedge_gamma_is_one_over_cos_half_angle() {
    let th = 120f64.to_radians();
    let mut fam = KernelFamily::new("wedge", HalfPlane);
    fam.push([0, 1], [1.0, 0.0], "x ≥ 0");
    fam.push([0, 1], [th.cos(), th.sin()], "tilted");
    let q = vec![0.0, 0.0];
    let problem = Problem::new(q.clone(), NoPerturbation).with_family(fam);
    let r = estimate(&problem, &[(0.0, q)]);
    assert_abs_diff_eq!(r.gamma_prime.as_ref().unwrap().value, 2.0, epsilon = 1e-6);
    assert_abs_diff_eq!(r.gamma.as_ref().unwrap().value, 2.0, epsilon = 1e-6);
    // M = 0: η = ∞; Θ = 2γβ/α = 4.
    assert_eq!(r.eta, Some(f64::INFINITY));
    assert_abs_diff_eq!(r.theta.unwrap(), 4.0, epsilon = 1e-5);
}

#[test]
fn bad_samples_are_refused() {
    let (problem, q) = chain(1.3);
    let mut proj = ReferenceProjector::default();
    let s = EstimateSettings::default();
    assert!(matches!(
        estimate_problem(&problem, &[], &s, &mut proj),
        Err(SweepError::InvalidInput(_))
    ));
    assert!(matches!(
        estimate_problem(&problem, &[(0.0, vec![0.0; 3])], &s, &mut proj),
        Err(SweepError::InvalidInput(_))
    ));
    let mut nan = q.clone();
    nan[1] = f64::NAN;
    assert!(matches!(
        estimate_problem(&problem, &[(0.0, nan)], &s, &mut proj),
        Err(SweepError::InvalidInput(_))
    ));
    let bad = EstimateSettings {
        rho: 0.0,
        ..Default::default()
    };
    assert!(matches!(
        estimate_problem(&problem, &[(0.0, q)], &bad, &mut proj),
        Err(SweepError::InvalidInput(_))
    ));
}

/// A constraint reading past `q` is refused, naming it, by the estimate as by `validate` (one
/// check serves both).
#[test]
fn a_family_reading_past_q_is_refused_by_the_estimate_and_by_validate() {
    let problem = Problem::new(vec![1.0, 2.0], NoPerturbation).with_family(KernelFamily::single(
        "far",
        common::kernels::Floor,
        [4],
    ));
    let expected =
        "constraint far #0 (far) has support [4]: coordinate 4 is beyond q's dimension 2";
    let estimated = estimate_problem(
        &problem,
        &[(0.0, vec![1.0, 2.0])],
        &EstimateSettings::default(),
        &mut ReferenceProjector::default(),
    );
    for result in [estimated.map(|_| ()), problem.validate(1e-9)] {
        match result {
            Err(e @ SweepError::InvalidSupport { .. }) => assert_eq!(e.to_string(), expected),
            other => panic!("expected InvalidSupport, got {other:?}"),
        }
    }
}

// ---------------------------------------------------------------- run-time monitor

/// Two people of radius 0.2 walking into each other at speed 1 each.
fn head_on() -> Problem {
    let pop = Population::new(vec![0.2, 0.2]).shared();
    Problem::new(
        vec![0.0, 0.0, 2.0, 0.0],
        |_t: f64, _q: &[f64], f: &mut [f64]| {
            f.copy_from_slice(&[1.0, 0.0, -1.0, 0.0]);
        },
    )
    .with_family(DiskPairs::new(pop))
}

fn head_on_settings() -> StepperSettings {
    StepperSettings {
        h: 0.05,
        t_end: 1.5,
        ..Default::default()
    }
}

#[test]
fn error_policy_stops_the_run_and_keeps_what_it_computed() {
    let problem = head_on();
    // |D²D| = 2/|q₁ − q₂| ≥ 2/0.5 = 4 once D ≤ 0.1 (the monitor's neighbourhood): M = 3 fails.
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds: Bounds {
                alpha: Some(1.0),
                beta: Some(2.0),
                m: Some(3.0),
                reach: None,
            },
            second_order_every: 1,
            ..Default::default()
        },
    );
    let failure = Stepper::new(&problem, head_on_settings())
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
        .unwrap_err();
    let SweepError::AssumptionViolated {
        step,
        t,
        assumption,
        constraint,
        detail,
    } = &failure.error
    else {
        panic!("expected AssumptionViolated, got {}", failure.error);
    };
    assert_eq!(assumption, "A4");
    assert_eq!(constraint, "no overlap of people 0 and 1");
    assert!(detail.contains("M = 3"), "{detail}");
    // The gap closes at speed 2 from 1.6: D ≤ 0.1 first after 0.75 s, i.e. at t = 0.75.
    assert_abs_diff_eq!(*t, 0.75, epsilon = 1e-9);
    assert_eq!(*step, 14);
    let seen = 2.0 / 0.5;
    assert!(detail.contains(&format!("{seen:.6e}")), "{detail}");
    let msg = failure.error.to_string();
    assert!(msg.contains("t = 0.75") && msg.contains("A4"), "{msg}");
    // The partial run holds every step up to and including the one that was checked.
    let partial = &failure.partial;
    assert_eq!(partial.stats.steps, 15);
    assert_abs_diff_eq!(partial.t_final, *t, epsilon = 1e-12);
    assert_eq!(partial.trajectory.states.len(), 16);
    assert_abs_diff_eq!(partial.q_final[0], 0.75, epsilon = 1e-9);
}

#[test]
fn warn_policy_collects_and_finishes() {
    let problem = head_on();
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Warn,
            bounds: Bounds {
                alpha: Some(1.5), // |∇D| = √2 < 1.5: A1 fails at every check near contact
                beta: None,
                m: None,
                reach: None,
            },
            max_warnings: 3,
            ..Default::default()
        },
    );
    let run = Stepper::new(&problem, head_on_settings())
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
        .unwrap();
    assert_eq!(run.stats.steps, 30);
    assert_eq!(monitor.warnings().len(), 3);
    assert!(monitor.violation_count() > 3);
    let w = &monitor.warnings()[0];
    assert_eq!(w.assumption, "A1");
    assert!(
        w.to_string().contains("is below the declared bound α"),
        "{w}"
    );
}

#[test]
fn measured_bounds_pass_their_own_run() {
    // Estimate on a trajectory, declare the measured bounds, rerun under the error policy.
    let problem = head_on();
    let run = Stepper::new(&problem, head_on_settings())
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap();
    let samples = sweeping::assumptions::samples_from_trajectory(&run.trajectory);
    let report = estimate(&problem, &samples);
    // In contact the centres are 0.4 apart: M = 2/0.4 = 5.
    assert_abs_diff_eq!(report.m.unwrap(), 5.0, epsilon = 1e-6);
    assert_abs_diff_eq!(
        report.gamma_prime.as_ref().unwrap().value,
        1.0,
        epsilon = 1e-9
    );
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds: Bounds::from_report(&report, 1e-6),
            second_order_every: 1,
            ..Default::default()
        },
    );
    Stepper::new(&problem, head_on_settings())
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
        .unwrap();
    assert!(monitor.second_order_checks() > 0);
    assert_eq!(monitor.violation_count(), 0);
}

/// A room of 150 people of radius 0.2 (the paper's set-up), run towards the exit at the
/// middle of the right wall for 2 s, then the constants measured along the trajectory; prints
/// the table. Slow with the reference backend: `cargo test --no-default-features --release
/// --test assumptions -- --ignored --nocapture`.
#[test]
#[ignore]
fn paper_room_table() {
    let n = 150;
    let pop = Population::new(vec![0.2; n]).shared();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut q: Vec<f64> = Vec::new();
    while q.len() < 2 * n {
        let p = [rng.gen_range(0.3..9.7), rng.gen_range(0.3..9.7)];
        if q.chunks(2)
            .all(|c| (c[0] - p[0]).hypot(c[1] - p[1]) >= 0.45)
        {
            q.extend_from_slice(&p);
        }
    }
    let walls = vec![
        wall([0.0, 0.0], [10.0, 0.0]),
        wall([0.0, 10.0], [10.0, 10.0]),
        wall([0.0, 0.0], [0.0, 10.0]),
        wall([10.0, 0.0], [10.0, 4.5]),
        wall([10.0, 5.5], [10.0, 10.0]),
    ];
    let problem = Problem::new(q, |_t: f64, q: &[f64], f: &mut [f64]| {
        for (p, v) in q.chunks(2).zip(f.chunks_mut(2)) {
            let d = [10.5 - p[0], 5.0 - p[1]];
            let l = d[0].hypot(d[1]).max(1e-9);
            v[0] = d[0] / l;
            v[1] = d[1] / l;
        }
    })
    .with_family(DiskPairs::new(pop.clone()))
    .with_family(PersonShapes::new("walls", pop, walls));
    let t0 = std::time::Instant::now();
    let run = Stepper::new(
        &problem,
        StepperSettings {
            h: 0.05,
            t_end: 2.0,
            ..Default::default()
        },
    )
    .unwrap()
    .run(&mut ReferenceProjector::default(), &mut [])
    .unwrap();
    let t_run = t0.elapsed().as_secs_f64();
    let samples = sweeping::assumptions::samples_from_trajectory(&run.trajectory);
    let t1 = std::time::Instant::now();
    let report = estimate(&problem, &samples);
    let t_est = t1.elapsed().as_secs_f64();
    println!(
        "run: {t_run:.2} s; estimate over {} samples: {t_est:.3} s",
        samples.len()
    );
    println!("{}", report.table());
    assert_abs_diff_eq!(report.alpha.as_ref().unwrap().value, 1.0, epsilon = 1e-9);
}
