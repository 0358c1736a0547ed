//! The candidate contract of the crowd families, checked member by member on random crowds:
//! every member with `gᵢ ≤ cutoff` is proposed, nothing is proposed twice, and the drift bound
//! bounds `|⟨∇gᵢ, x − q⟩|` of every member. The culling proof rests on exactly these three
//! facts (see `sweeping::stepper`).

use proptest::prelude::*;
use std::collections::HashSet;
use std::sync::Arc;
use sweeping::constraint::{ConstraintFamily, LinearizedRow};
use sweeping::crowd::{rectangle_walls, DiskPairs, Motion, PersonShapes, Population, Room, Shape};

/// A crowd of `n` people: clustered (many neighbours per cell), spread over a large square
/// (the sparse grid), or mixed; some radii differ so that the grid cell follows the largest.
fn crowd() -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (1usize..60, 0u8..3, any::<u64>()).prop_flat_map(|(n, layout, _)| {
        let extent = match layout {
            0 => 3.0,
            1 => 400.0,
            _ => 40.0,
        };
        (
            prop::collection::vec(-extent..extent, 2 * n),
            prop::collection::vec(0.05f64..0.5, n),
        )
    })
}

fn all_values(fam: &dyn ConstraintFamily, t: f64, q: &[f64]) -> Vec<(usize, f64)> {
    let mut all = Vec::new();
    fam.candidates(t, q, f64::INFINITY, &mut all);
    let mut row = LinearizedRow::default();
    all.into_iter()
        .map(|i| {
            fam.linearize(i, t, q, false, &mut row);
            (i, row.value)
        })
        .collect()
}

fn check_contract(fam: &dyn ConstraintFamily, t: f64, q: &[f64], cutoff: f64) {
    let mut proposed = Vec::new();
    fam.candidates(t, q, cutoff, &mut proposed);
    let set: HashSet<usize> = proposed.iter().copied().collect();
    assert_eq!(set.len(), proposed.len(), "a member proposed twice");
    for (i, g) in all_values(fam, t, q) {
        if g <= cutoff {
            assert!(
                set.contains(&i),
                "{} (g = {g}) missing at cutoff {cutoff}",
                fam.describe(i)
            );
        }
    }
}

fn check_drift(fam: &dyn ConstraintFamily, t: f64, q: &[f64], x: &[f64]) {
    let bound = fam.linearization_drift_bound(t, q, x);
    let mut row = LinearizedRow::default();
    let mut all = Vec::new();
    fam.candidates(t, q, f64::INFINITY, &mut all);
    for i in all {
        fam.linearize(i, t, q, false, &mut row);
        let drift: f64 = row
            .columns
            .iter()
            .zip(&row.gradient)
            .map(|(&c, g)| g * (x[c] - q[c]))
            .sum::<f64>()
            .abs();
        assert!(
            drift <= bound * (1.0 + 1e-12) + 1e-12,
            "{}: drift {drift} above the bound {bound}",
            fam.describe(i)
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn pair_candidates_cover_every_pair_within_the_cutoff(
        (q, radii) in crowd(),
        cutoff in prop_oneof![Just(0.0), 0.0f64..0.3, 0.3f64..5.0],
    ) {
        let n = radii.len();
        let pairs = DiskPairs::new(Population::new(radii).shared());
        check_contract(&pairs, 0.0, &q, cutoff);
        // The grid agrees with the brute-force enumeration exactly on the pairs within it, and
        // proposes only real pairs (i < j: nobody paired with themselves).
        let mut grid = Vec::new();
        pairs.candidates(0.0, &q, cutoff, &mut grid);
        for &m in &grid {
            prop_assert!(m / n < m % n, "member {m} is not a pair i < j of {n} people");
        }
        let grid: HashSet<usize> = grid.into_iter().collect();
        for i in pairs.brute_force_candidates(&q, cutoff) {
            prop_assert!(grid.contains(&i));
        }
    }

    #[test]
    fn people_who_left_are_in_no_pair(
        (q, radii) in crowd(),
        cutoff in 0.0f64..2.0,
    ) {
        // A small room: most of a spread crowd is outside it and has left.
        let pop = Population::new(radii).with_room(Room::rectangle(-2.0, -2.0, 2.0, 2.0)).shared();
        let pairs = DiskPairs::new(pop.clone());
        let mut proposed = Vec::new();
        pairs.candidates(0.0, &q, cutoff, &mut proposed);
        let n = pop.len();
        for m in proposed {
            let (i, j) = (m / n, m % n);
            prop_assert!(i < j);
            prop_assert!(pop.is_present(&q, i) && pop.is_present(&q, j));
        }
        check_contract(&pairs, 0.0, &q, cutoff);
    }

    #[test]
    fn pair_drift_bound_bounds_every_pair(
        (q, radii) in crowd(),
        moves in prop::collection::vec(-1.0f64..1.0, 120),
    ) {
        let pairs = DiskPairs::new(Population::new(radii).shared());
        let x: Vec<f64> = q.iter().zip(moves.iter().cycle()).map(|(a, d)| a + d).collect();
        check_drift(&pairs, 0.0, &q, &x);
    }

    #[test]
    fn shape_candidates_cover_every_person_within_the_cutoff(
        (q, radii) in crowd(),
        cutoff in prop_oneof![Just(0.0), 0.0f64..0.3, 0.3f64..5.0],
        t in 0.0f64..3.0,
        corner in prop::array::uniform2(-3.0f64..3.0),
    ) {
        let shapes = vec![
            (Shape::Segment { a: corner, b: [corner[0] + 2.0, corner[1] - 1.0] }, Motion::Static),
            (Shape::Segment { a: [0.0, -1.0], b: [0.0, 1.0] }, Motion::Velocity([0.5, -0.25])),
            (Shape::Disk { center: [1.0, 1.0], radius: 0.7 }, Motion::Static),
            (
                Shape::Disk { center: [-1.0, 0.5], radius: 0.3 },
                Motion::Path(vec![(0.0, [0.0, 0.0]), (1.0, [1.0, 0.0]), (2.5, [1.0, -2.0])]),
            ),
        ];
        let fam = PersonShapes::new("shapes", Population::new(radii).shared(), shapes);
        check_contract(&fam, t, &q, cutoff);
        let x: Vec<f64> = q.iter().enumerate().map(|(k, a)| a + 0.1 * ((k % 7) as f64 - 3.0)).collect();
        check_drift(&fam, t, &q, &x);
    }
}

#[test]
fn all_pairs_proposes_every_present_pair_however_far() {
    // The reference the culling is tested against: no cutoff applies to it.
    let pop = Population::new(vec![0.2; 4]).shared();
    let q = [0.0, 0.0, 100.0, 0.0, 0.0, 100.0, 1e6, 1e6];
    let pairs = DiskPairs::all_pairs(pop.clone());
    assert!(!pairs.culls());
    for cutoff in [0.0, 1.0, f64::INFINITY] {
        let mut proposed = Vec::new();
        pairs.candidates(0.0, &q, cutoff, &mut proposed);
        assert_eq!(proposed.len(), 6, "cutoff {cutoff}: {proposed:?}");
    }
    // The culled family proposes none of them at a finite cutoff, and says it culls.
    let culled = DiskPairs::new(pop);
    assert!(culled.culls());
    let mut proposed = Vec::new();
    culled.candidates(0.0, &q, 1.0, &mut proposed);
    assert!(proposed.is_empty(), "{proposed:?}");
}

#[test]
fn the_pair_drift_bound_is_attained_by_two_people_walking_into_each_other() {
    // |⟨∇D, x − q⟩| = |Δᵢ| + |Δⱼ| when both move along the line between them: the bound is
    // exact there, so a looser or a smaller bound is caught. Far from the origin, and with
    // displacements of different sizes, so that the two largest are the ones summed.
    for (origin, step_i, step_j) in [(0.0, 0.3, 0.5), (250.0, 1.5, 2.5), (-1e4, 0.01, 3.0)] {
        let pop = Population::new(vec![0.2; 3]).shared();
        let pairs = DiskPairs::new(pop);
        let q = [origin, origin, origin + 5.0, origin, origin, origin + 40.0];
        let x = [
            origin + step_i,
            origin,
            origin + 5.0 - step_j,
            origin,
            origin,
            origin + 40.0 + 0.001,
        ];
        let bound = pairs.linearization_drift_bound(0.0, &q, &x);
        let exact = step_i + step_j;
        assert!(
            (bound - exact).abs() <= 1e-9 * (1.0 + origin.abs()),
            "origin {origin}: bound {bound}, exact drift {exact}"
        );
        check_drift(&pairs, 0.0, &q, &x);
    }
}

#[test]
fn the_shape_drift_bound_is_attained_by_a_person_walking_into_a_wall() {
    // |∇g| = 1 on the person's two coordinates, so |⟨∇g, x − q⟩| = |Δ| when the person moves
    // along the wall's normal: the bound (the largest displacement) is exact there.
    for step in [0.05, 2.5] {
        let pop = Population::new(vec![0.2, 0.2]).shared();
        let wall = vec![(
            Shape::Segment {
                a: [0.0, -10.0],
                b: [0.0, 10.0],
            },
            Motion::Static,
        )];
        let fam = PersonShapes::new("wall", pop, wall);
        let q = [5.0, 0.0, 8.0, 3.0];
        let x = [5.0 - step, 0.0, 8.0 - 0.5 * step, 3.0];
        let bound = fam.linearization_drift_bound(0.0, &q, &x);
        assert!((bound - step).abs() <= 1e-12, "bound {bound}, step {step}");
        check_drift(&fam, 0.0, &q, &x);
    }
}

#[test]
fn drift_bounds_leave_out_who_has_left_and_count_who_is_leaving() {
    // Person 2 is wholly outside the room and far away, taking a long stride. Until presence
    // has been asked (which latches the departure), the bounds count them: larger, so still
    // bounds. Once they are seen leaving, the bounds are the exact drifts of the two people
    // left, walking into each other and into the wall at x = 0.
    let room = Room::rectangle(0.0, 0.0, 10.0, 10.0);
    let pop = Population::new(vec![0.2; 3]).with_room(room).shared();
    let pairs = DiskPairs::new(Arc::clone(&pop));
    let walls = PersonShapes::new(
        "walls",
        Arc::clone(&pop),
        rectangle_walls(0.0, 0.0, 10.0, 10.0),
    );
    let q = [1.0, 5.0, 3.0, 5.0, 50.0, 50.0];
    let x = [0.7, 5.0, 2.5, 5.0, 60.0, 50.0];
    assert_eq!(pairs.linearization_drift_bound(0.0, &q, &x), 10.0 + 0.5);
    assert_eq!(walls.linearization_drift_bound(0.0, &q, &x), 10.0);
    let mut found = Vec::new();
    pairs.candidates(0.0, &q, 0.0, &mut found);
    assert!(pop.has_departed(2));
    assert!((pairs.linearization_drift_bound(0.0, &q, &x) - 0.8).abs() < 1e-12);
    assert!((walls.linearization_drift_bound(0.0, &q, &x) - 0.5).abs() < 1e-12);
    check_drift(&pairs, 0.0, &q, &x);
    check_drift(&walls, 0.0, &q, &x);
}
