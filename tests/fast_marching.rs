//! The geodesic field: distances against exact ones, continuity of the directions, and the
//! rule for people outside the room.

use sweeping::crowd::fast_marching::{DistanceField, MarchingDomain};
use sweeping::crowd::segment_distance;

fn square_with_exit() -> MarchingDomain {
    MarchingDomain {
        room: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]],
        exits: vec![([10.0, 4.5], [10.0, 5.5])],
        ..Default::default()
    }
}

/// Largest |d − exact| over the free nodes.
fn max_error(field: &DistanceField, exact: impl Fn([f64; 2]) -> f64) -> f64 {
    let g = field.grid().clone();
    let mut worst = 0.0f64;
    for j in 0..g.ny {
        for i in 0..g.nx {
            if field.is_free(i, j) {
                let e = (field.node_value(i, j) - exact(g.node(i, j))).abs();
                worst = worst.max(e);
            }
        }
    }
    worst
}

#[test]
fn empty_room_distance_is_euclidean_within_grid_error() {
    let domain = square_with_exit();
    let exact = |p: [f64; 2]| segment_distance(p, [10.0, 4.5], [10.0, 5.5]);
    let coarse = max_error(&DistanceField::compute(&domain, 0.2).unwrap(), exact);
    let fine = max_error(&DistanceField::compute(&domain, 0.05).unwrap(), exact);
    // First-order fast marching: the error is a few cells at most, and shrinks with the cell.
    assert!(fine < 0.15, "error {fine} at cell 0.05");
    assert!(coarse < 0.6, "error {coarse} at cell 0.2");
    assert!(fine < 0.5 * coarse, "no convergence: {coarse} → {fine}");
    // Between nodes the interpolated distance is within the same error plus a cell's worth.
    let field = DistanceField::compute(&domain, 0.05).unwrap();
    for p in [[1.234, 8.765], [5.01, 5.02], [9.5, 0.3], [3.3, 3.3]] {
        let d = field.distance(p);
        assert!((d - exact(p)).abs() < 0.2, "at {p:?}: {d} vs {}", exact(p));
    }
}

#[test]
fn distance_around_a_thin_wall_matches_the_hand_computed_geodesic() {
    // A thin wall x = 5, 2 ≤ y ≤ 8 between the point (2, 5) and the exit (10, 4.9–5.1):
    // the shortest way goes round an end of the wall: |(2,5)–(5,8)| + |(5,8)–(10,5.1)|.
    let mut domain = square_with_exit();
    domain.exits = vec![([10.0, 4.9], [10.0, 5.1])];
    domain.segments = vec![([5.0, 2.0], [5.0, 8.0])];
    let geodesic = 18f64.sqrt() + (25.0f64 + 2.9 * 2.9).sqrt();
    let field = DistanceField::compute(&domain, 0.05).unwrap();
    let d = field.distance([2.0, 5.0]);
    assert!(
        (d - geodesic).abs() < 0.25,
        "fast marching {d}, geodesic {geodesic}, Euclidean 8"
    );
    // The direction at (2, 5) points up or down towards an end of the wall, not at the exit.
    let v = field.direction([2.0, 4.0]);
    assert!(
        v[1] < -0.3,
        "below the middle, people go round the bottom end: {v:?}"
    );
}

#[test]
fn distance_around_a_pillar() {
    // Behind a pillar of radius 1 at (7, 5), the point (4, 5) sees the exit point (10, 5)
    // hidden; the geodesic wraps the pillar: two tangents and an arc.
    let mut domain = square_with_exit();
    domain.exits = vec![([10.0, 4.99], [10.0, 5.01])];
    domain.disks = vec![([7.0, 5.0], 1.0)];
    let (a, r) = (3.0f64, 1.0f64); // distance from each end to the centre, radius
    let tangent = (a * a - r * r).sqrt();
    let arc = r * (std::f64::consts::PI - 2.0 * (r / a).acos());
    let geodesic = 2.0 * tangent + arc;
    let field = DistanceField::compute(&domain, 0.05).unwrap();
    let d = field.distance([4.0, 5.0]);
    assert!(
        (d - geodesic).abs() < 0.25,
        "fast marching {d}, geodesic {geodesic}, Euclidean 6"
    );
}

#[test]
fn directions_are_continuous() {
    // Pillar room: the field has ridges (behind the pillar, where two routes meet) and
    // walls; along many random lines, the direction changes by at most K·δ over a step δ.
    let mut domain = square_with_exit();
    domain.disks = vec![([8.0, 5.0], 0.7)];
    let cell = 0.1;
    let field = DistanceField::compute(&domain, cell).unwrap();
    let delta = 1e-4;
    let mut worst = 0.0f64;
    let mut state = 12345u64;
    let mut rand = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..200 {
        let p0 = [0.2 + 9.6 * rand(), 0.2 + 9.6 * rand()];
        let angle = std::f64::consts::TAU * rand();
        let dir = [angle.cos(), angle.sin()];
        let mut prev = field.direction(p0);
        for s in 1..2000 {
            let p = [
                p0[0] + dir[0] * delta * s as f64,
                p0[1] + dir[1] * delta * s as f64,
            ];
            let v = field.direction(p);
            let jump = ((v[0] - prev[0]).powi(2) + (v[1] - prev[1]).powi(2)).sqrt();
            worst = worst.max(jump);
            prev = v;
        }
    }
    // Lipschitz bound ~ (2/τ)·(2√2/cell)·δ ≈ 1.1e-2 for τ = 0.5, cell 0.1; a discontinuity
    // would show a jump of order 1.
    assert!(worst < 0.02, "largest jump {worst} over δ = {delta}");
}

/// A 5 × 3 room whose exit on the right wall ends 6 cm below where a person of radius 0.2
/// walking down that wall stopped for good: off the grid's nodes at both ends.
fn room_with_an_off_grid_door() -> MarchingDomain {
    MarchingDomain {
        room: vec![[0.0, 0.0], [5.0, 0.0], [5.0, 3.0], [0.0, 3.0]],
        exits: vec![([5.0, 0.38], [5.0, 1.84])],
        ..Default::default()
    }
}

#[test]
fn beside_a_door_the_direction_along_the_wall_leads_into_it() {
    // Nodes in the wall above the door lie within the seeding band of its end; seeded with
    // minus their distance, they made the field fall into the wall along the row y = 1.9,
    // and at (4.8, 1.9018) the direction was (1, −1.7e-5): into the wall, which stopped a
    // lone person there for good. Along that wall, the direction must lead down to the door.
    let field = DistanceField::compute(&room_with_an_off_grid_door(), 0.05).unwrap();
    for k in 0..=70 {
        let p = [4.8, 1.85 + 0.01 * k as f64];
        let v = field.direction(p);
        assert!(v[1] < -0.1, "at {p:?}: {v:?}");
    }
    // The same on a wall at 45°: a square turned by 45° with a door from (4, 1) to (5, 2), and
    // the point where a person of radius 0.2 stopped against the wall from (3, 0) to (4, 1).
    let diamond = MarchingDomain {
        room: vec![[3.0, 0.0], [6.0, 3.0], [3.0, 6.0], [0.0, 3.0]],
        exits: vec![([4.0, 1.0], [5.0, 2.0])],
        ..Default::default()
    };
    let field = DistanceField::compute(&diamond, 0.05).unwrap();
    let along = std::f64::consts::FRAC_1_SQRT_2;
    for k in 0..=40 {
        // Points 0.2 from the wall, from 0.4 m before the door's corner up to it.
        let s = 0.01 * k as f64;
        let on_wall = [4.0 - (0.4 - s) * along, 1.0 - (0.4 - s) * along];
        let p = [on_wall[0] - 0.2 * along, on_wall[1] + 0.2 * along];
        let v = field.direction(p);
        assert!((v[0] + v[1]) * along > 0.1, "at {p:?}: {v:?}");
    }
}

#[test]
fn a_lone_person_walking_down_the_wall_beside_a_door_leaves_through_it() {
    use sweeping::backends::{make_projector, BackendChoice};
    use sweeping::scene::{Overrides, Scene};
    let text = r#"
name = "off-grid-door"
[room]
rectangle = [0.0, 0.0, 5.0, 3.0]
[[exits]]
from = [5.0, 0.38]
to = [5.0, 1.84]
[[people]]
position = [4.5, 2.7]
radius = 0.2
[desired]
kind = "exit"
[run]
h = 0.01
t_end = 10.0
stop_when_empty = true
"#;
    let built = Scene::from_toml_str(text, "off-grid-door.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap();
    let mut projector = make_projector(BackendChoice::Native).unwrap();
    let run = built.run(projector.as_mut(), &mut []).unwrap();
    // It stood still at (4.8, 1.9018) from t = 3 s to the end; it is out in about 2 s.
    assert!(
        run.t_final < 4.0,
        "still in the room at t = {}",
        run.t_final
    );
    assert!(!built.population.is_present(&run.q_final, 0));
}

#[test]
fn a_grid_too_large_says_how_large_in_a_readable_number() {
    use sweeping::crowd::fast_marching::FastMarchingError;
    // 1e-9 m cells on a 10 m room: 1e20 nodes, which overflowed to 18446744073709551615.
    let e = DistanceField::compute(&square_with_exit(), 1e-9).unwrap_err();
    assert!(matches!(e, FastMarchingError::TooLarge(n) if n > 1e19));
    assert!(e.to_string().contains("would have 1.000e20 nodes"), "{e}");
}

#[test]
fn a_cell_that_is_not_a_positive_finite_number_is_refused() {
    use sweeping::crowd::fast_marching::FastMarchingError;
    for cell in [0.0, -0.1, f64::INFINITY, f64::NAN] {
        let e = DistanceField::compute(&square_with_exit(), cell).unwrap_err();
        assert!(matches!(e, FastMarchingError::BadCell(_)), "{cell}: {e}");
    }
}

#[test]
fn a_region_walled_off_from_the_exits_has_no_route() {
    let mut domain = square_with_exit();
    domain.segments = vec![([5.0, 0.0], [5.0, 10.0])];
    let field = DistanceField::compute(&domain, 0.1).unwrap();
    assert!(field.reaches_exit([7.0, 5.0]));
    assert!(field.reaches_exit([5.3, 9.9]));
    assert!(!field.reaches_exit([2.0, 5.0]));
    assert!(!field.reaches_exit([4.8, 0.1]));
    // A gap in the wall opens the route.
    domain.segments = vec![([5.0, 0.0], [5.0, 9.0])];
    let field = DistanceField::compute(&domain, 0.1).unwrap();
    assert!(field.reaches_exit([2.0, 5.0]));
}

/// A thin wall meeting the room's edge at an end of an exit (a corridor's wall ending at the
/// corridor's exit): the people behind it are led around it, not into it. The exit's seeds
/// once reached the nodes beside its end, behind the wall, at a distance of a cell.
#[test]
fn a_wall_ending_at_an_exit_is_walked_around() {
    let mut domain = MarchingDomain {
        room: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]],
        exits: vec![([10.0, 4.0], [10.0, 6.0])],
        ..Default::default()
    };
    domain.segments = vec![([5.0, 4.0], [10.0, 4.0])];
    let field = DistanceField::compute(&domain, 0.05).unwrap();
    // Around the wall's free end at (5, 4): about 4.9 + 5.0.
    let behind = field.distance([9.9, 3.9]);
    assert!(behind > 9.0, "{behind}");
    // In front of the exit, the distance is the straight one.
    assert!((field.distance([9.0, 5.0]) - 1.0).abs() < 0.1);
}

/// A waypoint's field: the distance to a point target (or a region) inside the room, with no
/// exit, against the exact Euclidean distance; the error shrinks with the cell; and round a
/// thin wall, the hand-computed geodesic.
#[test]
fn a_target_inside_the_room_is_where_the_distance_vanishes() {
    use sweeping::crowd::fast_marching::Target;
    let at = [3.0, 7.0];
    let domain = MarchingDomain {
        room: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]],
        targets: vec![Target::Point { at, reach: 0.3 }],
        ..Default::default()
    };
    let exact = |p: [f64; 2]| (p[0] - at[0]).hypot(p[1] - at[1]);
    let coarse = max_error(&DistanceField::compute(&domain, 0.2).unwrap(), exact);
    let fine = max_error(&DistanceField::compute(&domain, 0.05).unwrap(), exact);
    assert!(fine < 0.15 && coarse < 0.6, "errors {coarse}, {fine}");
    assert!(fine < 0.5 * coarse, "no convergence: {coarse} → {fine}");
    // The direction points at the target.
    let field = DistanceField::compute(&domain, 0.05).unwrap();
    let v = field.direction([8.0, 2.0]);
    let want = [-5.0 / 50f64.sqrt(), 5.0 / 50f64.sqrt()];
    assert!(
        (v[0] - want[0]).abs() < 0.02 && (v[1] - want[1]).abs() < 0.02,
        "{v:?}"
    );
    // A region: zero inside, the distance to the rectangle outside.
    let region = MarchingDomain {
        targets: vec![Target::Region([6.0, 6.0, 8.0, 8.0])],
        ..domain.clone()
    };
    let field = DistanceField::compute(&region, 0.05).unwrap();
    assert!(field.distance([7.0, 7.0]).abs() < 1e-9);
    assert!((field.distance([7.0, 2.0]) - 4.0).abs() < 0.1);
    // Round a thin wall x = 5, 0 ≤ y ≤ 8 from (2, 5) to the point (8, 5): over its top end.
    let walled = MarchingDomain {
        segments: vec![([5.0, 0.0], [5.0, 8.0])],
        targets: vec![Target::Point {
            at: [8.0, 5.0],
            reach: 0.3,
        }],
        ..domain.clone()
    };
    let field = DistanceField::compute(&walled, 0.05).unwrap();
    let geodesic = 2.0 * (9.0f64 + 9.0).sqrt();
    let d = field.distance([2.0, 5.0]);
    assert!(
        (d - geodesic).abs() < 0.25,
        "fast marching {d}, geodesic {geodesic}"
    );
    // A target inside an obstacle has no free node: an error, not a field of infinities.
    let buried = MarchingDomain {
        disks: vec![([3.0, 7.0], 1.0)],
        ..domain
    };
    assert!(DistanceField::compute(&buried, 0.05)
        .unwrap_err()
        .to_string()
        .contains("lies at the target"));
}
