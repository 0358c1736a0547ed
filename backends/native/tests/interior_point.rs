//! The interior point as crowds use it: a push through a chain, answered by the interior point
//! within its accuracy; and straight away, without the support method's attempt, when a block
//! goes to the interior point solve after solve.

use sweeping_api::conformance::max_gap;
use sweeping_api::{Projection, ProjectionProblem, Projector, RowKey, SparseRows};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::{NativeProjector, NativeSettings};

/// `k ≥ 7` points on a line, `xᵢ₊₁ − xᵢ ≥ 1`, the first held by a wall `x₀ ≥ 0`. `y` puts the
/// first two on top of each other, the third 0.6 beyond its place (a row that holds at `y`
/// but not at the answer) and the others 0.15 apart from theirs.
/// The push of 1 runs down the chain, 0.15 less at each row after the left-out one:
/// `x = (0, 1, 2, 3, 4, y₅, …)`.
fn chain(k: usize, from_the_right: bool) -> ProjectionProblem {
    let mut rows = vec![vec![(0, 1.0)]];
    let mut b = vec![0.0];
    for i in 0..k - 1 {
        rows.push(vec![(i, -1.0), (i + 1, 1.0)]);
        b.push(1.0);
    }
    let mut y = vec![0.0, 0.0, 1.6];
    while y.len() < k {
        y.push(y[y.len() - 1] + 1.15);
    }
    if from_the_right {
        // The last point pushed back onto the one before it instead: the wall is far, and
        // every row within the screening's reach, so that the block is solved whole.
        y = (0..k).map(|i| 10.0 + i.min(k - 2) as f64 * 1.15).collect();
    }
    let keys = (0..rows.len() as u64)
        .map(|m| RowKey {
            family: 1,
            member: m,
        })
        .collect();
    ProjectionProblem::new(y, SparseRows::from_rows(k, &rows), b)
        .unwrap()
        .with_row_keys(keys)
        .unwrap()
}

fn interior(active_set_iterations: u32) -> NativeProjector {
    NativeProjector::new(NativeSettings {
        active_set_iterations,
        ..NativeSettings::default()
    })
}

#[test]
fn a_push_through_a_chain_is_answered_by_the_interior_point_within_its_accuracy() {
    let p = chain(12, false);
    let sol = interior(0).project(&p).unwrap();
    assert_eq!(
        (sol.stats.counters.escalations, sol.stats.counters.fallbacks),
        (1, 0)
    );
    let exact: Vec<f64> = (0..12)
        .map(|i| if i < 5 { i as f64 } else { p.y()[i] })
        .collect();
    let gap = max_gap(&sol.x, &exact);
    assert!(gap <= 1e-10, "{:?}", sol.x);
    // The wall and the chain's first four rows hold the push (the row that held at `y` among
    // them); the rest are slack, their multipliers the interior point's last `μ / slack`
    // (positive: no finish ran, whose would be zeros), no contact force at any threshold a
    // report uses.
    for (i, &l) in sol.multipliers.iter().enumerate() {
        if i < 5 {
            assert!(l > 0.1, "row {i}: {:?}", sol.multipliers);
        } else {
            assert!(l > 0.0 && l <= 1e-12, "row {i}: {:?}", sol.multipliers);
        }
    }
    assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() <= 1e-10);
}

/// The chains of `k` points pushed from the left and from the right, solved in turn nine
/// times: each solve's warm start (the other side's support) is wrong by every row, and one
/// guess of the support method cannot mend it, so every solve goes to the interior point,
/// which starts from Mehrotra's point so that its iterations do not depend on the last solve
/// (its warm start has a test of its own, below). Each problem with its answer, certified
/// and without fallback.
fn solved_in_turn(k: usize) -> Vec<(ProjectionProblem, Projection)> {
    let (left, right) = (chain(k, false), chain(k, true));
    let mut native = NativeProjector::new(NativeSettings {
        active_set_iterations: 1,
        interior_point_warm_floor: 0.0,
        ..NativeSettings::default()
    });
    (0..9)
        .map(|solve| {
            let p = if solve % 2 == 0 { &left } else { &right };
            let sol = native.project(p).unwrap();
            assert_eq!(
                (sol.stats.counters.escalations, sol.stats.counters.fallbacks),
                (1, 0),
                "solve {solve}"
            );
            assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() <= 1e-10);
            (p.clone(), sol)
        })
        .collect()
}

#[test]
fn a_block_sent_to_the_interior_point_solve_after_solve_goes_there_at_once_and_stays_exact() {
    // 420 points: from 400 rows a block's streak skips the active set.
    let solves = solved_in_turn(420);
    let mut clarabel = ClarabelProjector::default();
    for (solve, (p, sol)) in solves.iter().enumerate() {
        let reference = clarabel.project(p).unwrap();
        let gap = max_gap(&sol.x, &reference.x);
        assert!(gap <= 1e-8, "solve {solve}: {gap:.3e} from Clarabel");
    }
    let iterations: Vec<u32> = solves.iter().map(|(_, sol)| sol.stats.iterations).collect();
    // The interior point then does not depend on the warm start, so a solve that went straight
    // to it (the 4th, 6th, 7th and 8th: streaks 3, 5, 6, 7) reports one iteration fewer, the
    // support method's one guess, than the same problem solved with the attempt.
    for (straight, attempted) in [(3, 1), (5, 1), (6, 0), (7, 1)] {
        assert_eq!(
            iterations[straight] + 1,
            iterations[attempted],
            "iterations {iterations:?}"
        );
    }
    for attempted in [0, 1, 2, 4, 8] {
        let same = if attempted % 2 == 0 { 0 } else { 1 };
        assert_eq!(iterations[attempted], iterations[same], "{iterations:?}");
    }
}

#[test]
fn a_small_block_tries_the_active_set_whatever_its_streak() {
    // Below 400 rows every solve tries the support method's guess first (a jam's small
    // clusters inherit the streak of the large one they were part of), so every solve of a
    // side reports the iterations of its first.
    let iterations: Vec<u32> = solved_in_turn(12)
        .iter()
        .map(|(_, sol)| sol.stats.iterations)
        .collect();
    for (solve, &it) in iterations.iter().enumerate() {
        assert_eq!(it, iterations[solve % 2], "{iterations:?}");
    }
}

/// The recorded door queue with keyed rows, `y` moved by up to `by` per coordinate (seeded):
/// the next step of the queue, as far as the projection sees it.
fn door_queue_moved(by: f64, seed: u64) -> ProjectionProblem {
    use rand::{Rng, SeedableRng};
    let p = sweeping_testkit::fixtures::problem("door_queue_qp.json");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let y = p.y().iter().map(|v| v + rng.gen_range(-by..=by)).collect();
    let keys = (0..p.n_rows() as u64)
        .map(|m| RowKey {
            family: 2,
            member: m,
        })
        .collect();
    ProjectionProblem::new(y, p.a().clone(), p.b().to_vec())
        .unwrap()
        .with_row_keys(keys)
        .unwrap()
}

/// The recorded door queue projected, then projected again moved by up to 1e-3 (its next
/// step), every block by the interior point started with `warm_floor`: the second answer,
/// which must need no fallback.
fn door_queue_next_step(warm_floor: f64) -> sweeping_api::Projection {
    let (first, next) = (door_queue_moved(0.0, 1), door_queue_moved(1e-3, 2));
    let mut native = NativeProjector::new(NativeSettings {
        active_set_iterations: 0,
        interior_point_warm_floor: warm_floor,
        ..NativeSettings::default()
    });
    native.project(&first).unwrap();
    let sol = native.project(&next).unwrap();
    assert_eq!(sol.stats.counters.fallbacks, 0, "floor {warm_floor}");
    sol
}

/// From one step of a door queue to the next the forces change little: the interior point
/// started from the last multipliers (by row key) takes fewer iterations than from Mehrotra's
/// point, and lands on the same answer.
#[test]
fn the_next_step_of_a_door_queue_starts_the_interior_point_from_the_last_multipliers() {
    let warm = door_queue_next_step(NativeSettings::default().interior_point_warm_floor);
    let cold = door_queue_next_step(0.0);
    let (w, c) = (warm.stats.iterations, cold.stats.iterations);
    assert!(w < c, "{w} iterations warm, {c} cold");
    let gap = max_gap(&warm.x, &cold.x);
    assert!(gap < 1e-9, "{gap:e} between the warm and the cold answer");
}

/// A warm floor that is not a finite positive number is Mehrotra's point, not a broken start.
#[test]
fn a_warm_floor_that_is_no_finite_positive_number_starts_cold() {
    let counts: Vec<_> = [0.0, -1.0, f64::NAN, f64::INFINITY]
        .into_iter()
        .map(|floor| door_queue_next_step(floor).stats.iterations)
        .collect();
    assert!(counts.iter().all(|&c| c == counts[0]), "{counts:?}");
}

/// The recorded cycling queue of the large evacuation, whose interior point stalls short of
/// its tolerance, run alone with `acceptable` as the tolerance's threshold.
fn cycling_queue_interior_point(acceptable: f64) -> sweeping_qp::Iterate {
    let p = sweeping_testkit::fixtures::problem("large_evacuation_cycling_qp.json");
    let r = p.shortfall(p.y());
    let tolerance = sweeping_qp::Tolerance {
        acceptable,
        ..sweeping_qp::Tolerance::default()
    };
    sweeping_qp::interior_point(p.a(), &r, tolerance, 100).unwrap()
}

/// A run that stalls once its best iterate is acceptable stops waiting soon after, and keeps
/// that iterate: the iterations after it would not have improved on it.
#[test]
fn a_stalled_interior_point_with_an_acceptable_iterate_stops_waiting() {
    let settled = cycling_queue_interior_point(sweeping_qp::Tolerance::default().acceptable);
    let waited = cycling_queue_interior_point(0.0);
    assert!(!settled.converged && !waited.converged);
    assert!(
        settled.iterations < waited.iterations,
        "{} iterations settled, {} waiting",
        settled.iterations,
        waited.iterations
    );
    assert!(settled.accuracy <= 1e-6, "{:e}", settled.accuracy);
    assert_eq!(settled.d, waited.d);
    assert_eq!(settled.lambda, waited.lambda);
}

/// The engine takes a stalled interior point's answer when it is within the tolerance's
/// `acceptable` (counted as reduced, and the projection as Clarabel finds it); with
/// `acceptable = 0` it asks the active set to finish it, which cannot on this queue, and says
/// so rather than answer.
#[test]
fn a_stalled_interior_point_is_the_answer_only_within_acceptable() {
    let p = sweeping_testkit::fixtures::problem("large_evacuation_cycling_qp.json");
    let project = |acceptable: f64| {
        let mut native = NativeProjector::new(NativeSettings {
            active_set_iterations: 0,
            interior_point: sweeping_qp::Tolerance {
                acceptable,
                ..sweeping_qp::Tolerance::default()
            },
            ..NativeSettings::default()
        });
        native.project(&p)
    };
    let accepted = project(1e-6).unwrap();
    assert_eq!(accepted.stats.counters.reduced, 1);
    // Its estimated distance from the projection: short of the tolerance, within `acceptable`.
    let reduced_by = accepted.stats.counters.reduced_by;
    assert!(reduced_by > 0.0 && reduced_by < 1e-8, "{reduced_by:e}");
    assert_eq!(accepted.stats.counters.fallbacks, 0);
    let reference = ClarabelProjector::default().project(&p).unwrap();
    let gap = max_gap(&accepted.x, &reference.x);
    assert!(gap < 1e-8, "{gap:e} from Clarabel's answer");
    // Nothing is acceptable below zero, nor at NaN: refused alike, not a panic.
    for nothing in [0.0, -1.0, f64::NAN] {
        let refused = project(nothing).unwrap_err().to_string();
        assert!(refused.contains("did not converge"), "{nothing}: {refused}");
    }
}
