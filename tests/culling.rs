//! Culling far-apart pairs changes nothing: on random scenes, including jammed ones where
//! people are pushed faster than they want to go (a moving wall, a strong velocity field),
//! the culled run equals the all-pairs run (`DiskPairs::all_pairs`) step by step, to solver
//! tolerance.

mod common;

use common::kernels::Floor;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweeping::api::conformance::ReferenceProjector;
use sweeping::constraint::FamilyKind;
use sweeping::crowd::DiskPairs;
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping::stepper::Stepper;

/// Largest ∞-norm gap allowed between the two runs after any step.
const GAP: f64 = 1e-6;

fn build(text: &str, all_pairs: bool) -> BuiltScene {
    let mut built = Scene::from_toml_str(text, "random scene")
        .unwrap()
        .build(&Overrides::default())
        .unwrap();
    if all_pairs {
        // The same pairs, every one assembled at every step: the reference of culling.
        let pairs = built
            .problem
            .families()
            .iter()
            .position(|f| f.kind() == FamilyKind::Pairs)
            .expect("a crowd of two or more has a pair family");
        let every_pair = DiskPairs::all_pairs(built.population.clone());
        built.problem.replace_family(pairs, Box::new(every_pair));
    }
    built
}

/// Steps both versions in lockstep; returns (largest gap, rows culled, rows all-pairs).
fn compare(text: &str, steps: usize) -> (f64, usize, usize) {
    let culled = build(text, false);
    let full = build(text, true);
    let mut a = Stepper::new(&culled.problem, culled.settings.clone()).unwrap();
    let mut b = Stepper::new(&full.problem, full.settings.clone()).unwrap();
    let mut pa = ReferenceProjector::default();
    let mut pb = ReferenceProjector::default();
    let (mut gap, mut rows_a, mut rows_b) = (0.0f64, 0, 0);
    for k in 0..steps.min(a.n_steps()) {
        let ra = a
            .step(&mut pa)
            .unwrap_or_else(|e| panic!("culled, step {k}: {e}\n{text}"));
        let rb = b
            .step(&mut pb)
            .unwrap_or_else(|e| panic!("all pairs, step {k}: {e}\n{text}"));
        rows_a += ra.rows;
        rows_b += rb.rows;
        let g = a
            .state()
            .iter()
            .zip(b.state())
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(
            g <= GAP,
            "step {k}: culled and all-pairs differ by {g:.3e}\n{text}"
        );
        gap = gap.max(g);
    }
    (gap, rows_a, rows_b)
}

/// A random scene: `n` people in a `w × 3` room, with one of several ways of pushing them.
fn random_scene(seed: u64) -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rng.gen_range(8..=16);
    let w = rng.gen_range(3.0..5.0);
    let kind = seed % 4;
    let mut s = format!("[room]\nrectangle = [0.0, 0.0, {w}, 3.0]\n");
    let (region_x0, desired, extra) = match kind {
        // A wall sweeping the room at 1.5 m/s while people want 0.3 m/s the other way.
        0 => (
            0.7,
            "{ kind = \"constant\", velocity = [-0.3, 0.0] }".to_string(),
            format!(
                "[[obstacles]]\nsegment = {{ from = [0.4, 0.1], to = [0.4, 2.9] }}\npath = [[0.0, 0.0, 0.0], [{t}, {d}, 0.0]]\n",
                t = (w - 2.0) / 1.5,
                d = w - 2.0
            ),
        ),
        // A strong uniform field into a corner: 3 m/s.
        1 => (
            0.0,
            "{ kind = \"constant\", velocity = [3.0, -1.0] }".to_string(),
            String::new(),
        ),
        // Everybody towards the centre: a jam.
        2 => (
            0.0,
            format!("{{ kind = \"point\", point = [{}, 1.5] }}", w / 2.0),
            String::new(),
        ),
        // Towards an exit around a pillar (geodesic field).
        _ => (
            0.0,
            "{ kind = \"exit\" }".to_string(),
            format!(
                "[[exits]]\nfrom = [{w}, 1.0]\nto = [{w}, 1.8]\n[[obstacles]]\ndisk = {{ center = [{}, 1.4], radius = 0.3 }}\n[geodesic]\ncell = 0.1\n",
                w - 0.8
            ),
        ),
    };
    s.push_str(&extra);
    // A constant desire's speed is its velocity's length: a `speed` beside it is refused.
    let speed = if kind < 2 { "" } else { "speed = 1.5\n" };
    s.push_str(&format!(
        "[[crowds]]\ncount = {n}\nregion = [{region_x0}, 0.0, {w}, 3.0]\nradius = [0.15, 0.25]\n{speed}seed = {seed}\ndesired = {desired}\n"
    ));
    s.push_str("[run]\nh = 0.05\nt_end = 2.0\n");
    s
}

#[test]
fn culled_equals_all_pairs_on_random_scenes() {
    let mut culled_something = false;
    for seed in 0..8 {
        let text = random_scene(seed);
        let (gap, rows_culled, rows_all) = compare(&text, 40);
        assert!(gap <= GAP);
        assert!(rows_culled <= rows_all, "seed {seed}: culling added rows");
        culled_something |= rows_culled < rows_all;
    }
    assert!(culled_something, "no scene had a far-apart pair to cull");
}

#[test]
fn moving_wall_pushes_people_faster_than_they_walk() {
    // Jammed: the wall moves at 2 m/s, people want 0.2 m/s towards it.
    let text = "[room]\nrectangle = [0.0, 0.0, 4.0, 2.0]\n\
        [[obstacles]]\nsegment = { from = [0.3, 0.05], to = [0.3, 1.95] }\nvelocity = [2.0, 0.0]\n\
        [[crowds]]\ncount = 12\nregion = [0.6, 0.0, 4.0, 2.0]\nradius = 0.2\nseed = 9\n\
        desired = { kind = \"constant\", velocity = [-0.2, 0.0] }\n\
        [run]\nh = 0.02\nt_end = 0.7\n";
    let built = build(text, false);
    let mut stepper = Stepper::new(&built.problem, built.settings.clone()).unwrap();
    let mut p = ReferenceProjector::default();
    let mut fastest = 0.0f64;
    while stepper.steps_done() < stepper.n_steps() {
        let r = stepper.step(&mut p).unwrap();
        fastest = fastest.max(r.max_displacement / r.h);
    }
    // Somebody moved faster than their desired speed (0.2): the scene is jammed.
    assert!(fastest > 1.0, "fastest coordinate speed {fastest}");
    let (gap, _, _) = compare(text, 35);
    assert!(gap <= GAP);
}

/// A "backend" that ignores the constraints (`x = y`): every step ends with violations, so
/// the run-time check has something to find.
struct Unconstrained;

impl sweeping::api::Projector for Unconstrained {
    fn name(&self) -> &str {
        "unconstrained"
    }
    fn project(
        &mut self,
        p: &sweeping::api::ProjectionProblem,
    ) -> Result<sweeping::api::Projection, sweeping::api::ProjectionError> {
        Ok(sweeping::api::Projection::identity(p, self.name()))
    }
}

#[test]
fn the_true_constraint_check_on_assembled_rows_finds_the_worst_violation() {
    // The stepper checks only the assembled rows of culling families (convexity and the
    // culling proof cover the rest). Against the full check over every member, on jammed
    // scenes whose steps violate many constraints when the projection is skipped.
    for seed in 0..6 {
        let text = random_scene(seed);
        let built = build(&text, false);
        let mut settings = built.settings.clone();
        settings.kkt_tolerance = f64::INFINITY;
        settings.violation_tolerance = f64::INFINITY;
        let mut stepper = Stepper::new(&built.problem, settings).unwrap();
        let mut found = 0usize;
        for _ in 0..stepper.n_steps().min(5) {
            // Without projections a moving wall soon passes over someone, which the stepper
            // refuses (StepTooLong): the steps before that are what is compared.
            let Ok(report) = stepper.step(&mut Unconstrained) else {
                break;
            };
            // The largest violation as a distance, −g/|∇g|, over every member.
            let mut full = 0.0f64;
            let _ = built.problem.for_each_linearized(
                report.t,
                stepper.state(),
                |_| Some(0.0),
                false,
                &mut sweeping::problem::LinearizeScratch::default(),
                |_, _, row| {
                    if row.value < 0.0 {
                        full = full.max(-row.value / row.gradient_norm());
                    }
                    Ok::<(), std::convert::Infallible>(())
                },
            );
            assert!(
                (report.max_violation - full).abs() <= 1e-12,
                "seed {seed}, step {}: assembled rows give {:.6e}, every member {:.6e}\n{text}",
                report.step,
                report.max_violation,
                full
            );
            if full > 0.0 {
                found += 1;
                assert!(report.worst_constraint.is_some());
            }
        }
        assert!(found > 0, "seed {seed}: no step violated anything\n{text}");
    }
}

/// A family that claims to cull and whose drift bound grows fourfold at every call: the proof
/// can never close, and the step fails with its own error, not `InvalidInput`.
#[test]
fn a_culling_proof_that_never_closes_is_a_culling_error() {
    use std::sync::atomic::{AtomicU32, Ordering};
    use sweeping::constraint::{LinearizedRow, SecondOrderData};
    use sweeping::prelude::*;

    struct Runaway {
        inner: KernelFamily<Floor, 1>,
        calls: AtomicU32,
    }
    impl ConstraintFamily for Runaway {
        fn name(&self) -> &str {
            "runaway"
        }
        fn count(&self) -> usize {
            self.inner.count()
        }
        fn is_time_dependent(&self) -> bool {
            false
        }
        fn is_affine(&self) -> bool {
            true
        }
        fn describe(&self, index: usize) -> String {
            self.inner.describe(index)
        }
        fn culls(&self) -> bool {
            true
        }
        fn linearization_drift_bound(&self, _t: f64, _q: &[f64], _x: &[f64]) -> f64 {
            4f64.powi(self.calls.fetch_add(1, Ordering::Relaxed) as i32)
        }
        fn linearize(&self, i: usize, t: f64, q: &[f64], dt: bool, out: &mut LinearizedRow) {
            self.inner.linearize(i, t, q, dt, out);
        }
        fn second_order(&self, i: usize, t: f64, q: &[f64]) -> SecondOrderData {
            self.inner.second_order(i, t, q)
        }
        fn min_dimension(&self) -> usize {
            self.inner.min_dimension()
        }
    }
    let problem = Problem::new(vec![1.0], NoPerturbation).with_family(Runaway {
        inner: KernelFamily::single("floor", Floor, [0]),
        calls: AtomicU32::new(0),
    });
    let settings = StepperSettings {
        h: 0.1,
        t_end: 0.1,
        max_cull_retries: 2,
        ..Default::default()
    };
    let mut stepper = Stepper::new(&problem, settings).unwrap();
    match stepper.step(&mut ReferenceProjector::default()) {
        Err(SweepError::CullingFailed { step, t, solves }) => {
            assert_eq!((step, solves), (0, 3));
            assert!((t - 0.1).abs() < 1e-12);
        }
        other => panic!("expected CullingFailed, got {other:?}"),
    }
}

/// `Problem::for_each_linearized` names every candidate in order, skips the families whose
/// cutoff is `None` and stops at the first error.
#[test]
fn for_each_linearized_names_every_candidate_and_skips_families_without_cutoff() {
    use sweeping::constraint::ConstraintId;
    use sweeping::prelude::*;
    use sweeping::problem::LinearizeScratch;

    let mut first = KernelFamily::new("first", Floor);
    first.push([0], (), "x0");
    first.push([1], (), "x1");
    let problem = Problem::new(vec![2.0, -1.0, 0.5], NoPerturbation)
        .with_family(first)
        .with_family(KernelFamily::single("second", Floor, [2]));
    let mut scratch = LinearizeScratch::default();
    // Every (constraint, value) the walk visits with this cutoff.
    let mut seen_with = |cutoff: &dyn Fn(&dyn ConstraintFamily) -> Option<f64>| {
        let mut seen = Vec::new();
        let _ = problem.for_each_linearized(
            0.0,
            problem.q0(),
            cutoff,
            false,
            &mut scratch,
            |_, id, row| {
                seen.push((id, row.value));
                Ok::<(), ()>(())
            },
        );
        seen
    };
    let all = |_: &dyn ConstraintFamily| Some(f64::INFINITY);
    let id = |family, member| ConstraintId { family, member };
    assert_eq!(
        seen_with(&all),
        vec![(id(0, 0), 2.0), (id(0, 1), -1.0), (id(1, 0), 0.5)]
    );
    assert_eq!(problem.describe(id(0, 1)), "first #1 (x1)");
    // A family whose cutoff is None is skipped; an Err stops the walk.
    let second_only = |f: &dyn ConstraintFamily| (f.name() == "second").then_some(0.0);
    // (A family that does not cull returns every member, whatever the cutoff.)
    assert_eq!(seen_with(&second_only), vec![(id(1, 0), 0.5)]);
    let mut calls = 0;
    let stopped =
        problem.for_each_linearized(0.0, problem.q0(), all, false, &mut scratch, |_, _, _| {
            calls += 1;
            Err("stop")
        });
    assert_eq!((stopped, calls), (Err("stop"), 1));
    assert_eq!(
        problem.min_constraint(0.0, problem.q0(), f64::INFINITY),
        Some((-1.0, "first #1 (x1)".to_string()))
    );
}
