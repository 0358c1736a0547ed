//! The walkable area of a scene as one polygon with holes, the form JuPedSim's trajectory
//! file stores (as WKT) and PedPy's `WalkableArea` reads.
//!
//! * The shell is the room, counter-clockwise, with an **apron** outside each exit: a strip
//!   as wide as the exit and as deep as the largest radius. A person counts as present while
//!   their disk is not wholly outside the room, so a present person's centre can be up to a
//!   radius beyond the door; the apron keeps every position the trajectory file holds inside
//!   the walkable area, as JuPedSim's do (its agents are removed inside the walkable area, at
//!   their exit stage), and PedPy can measure a flow on a line in the doorway.
//! * Holes (clockwise) are the **static** obstacles: a disk as the regular 64-gon inscribed
//!   in it (area within 0.2 % of the disk's, and no centre can fall in it since centres stay a
//!   radius away from the disk), a polygon as itself, and a thin wall (a segment) as a
//!   rectangle of half-width `min(0.01, r_min / 2)` around it (a centre stays `r ≥ r_min`
//!   away from the segment, so none falls in it).
//! * Moving obstacles are left out: the area they cover changes with time, and PedPy 1.5
//!   reads the walkable area of a file whose geometry changes as the union of all its
//!   geometries, in which a moving hole would vanish anyway.
//!
//! A hole that touches the shell or another hole would make an invalid polygon (OGC simple
//! features) and there is no polygon clipping here: a thin wall that touches is left out (it
//! has no area, so the area stays exact) and said so in [`WalkableArea::notes`]; a disk or
//! polygon that touches is refused with an error naming the obstacle rather than written
//! wrong.

use super::OutputError;
use crate::crowd::{segment_distance, Motion, Population, Room};
use crate::scene::{Obstacle, ObstacleShape, SceneGeometry};
use std::fmt::Write as _;

/// Vertices of the regular polygon inscribed in a disk obstacle.
const DISK_VERTICES: usize = 64;

/// A polygon with holes: the floor people may stand on.
#[derive(Debug, Clone, PartialEq)]
pub struct WalkableArea {
    /// The outer boundary, counter-clockwise, not closed (the last vertex joins the first).
    pub shell: Vec<[f64; 2]>,
    /// Inner boundaries, clockwise, not closed.
    pub holes: Vec<Vec<[f64; 2]>>,
    /// Obstacles left out, and why (moving ones; thin walls that touch the boundary or
    /// another obstacle), for the user to be told.
    pub notes: Vec<String>,
}

/// Twice the signed area of a ring (positive when counter-clockwise).
fn signed_area2(v: &[[f64; 2]]) -> f64 {
    (0..v.len())
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

fn orient(mut v: Vec<[f64; 2]>, ccw: bool) -> Vec<[f64; 2]> {
    if (signed_area2(&v) > 0.0) != ccw {
        v.reverse();
    }
    v
}

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Whether the closed segments `[a, b]` and `[c, d]` meet or come within `tol` of each other.
fn segments_touch(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2], tol: f64) -> bool {
    let (d1, d2) = (cross(c, d, a), cross(c, d, b));
    let (d3, d4) = (cross(a, b, c), cross(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    segment_distance(a, c, d) <= tol
        || segment_distance(b, c, d) <= tol
        || segment_distance(c, a, b) <= tol
        || segment_distance(d, a, b) <= tol
}

fn rings_touch(p: &[[f64; 2]], q: &[[f64; 2]], tol: f64) -> bool {
    (0..p.len()).any(|i| {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        (0..q.len()).any(|j| segments_touch(a, b, q[j], q[(j + 1) % q.len()], tol))
    })
}

fn fmt_ring(out: &mut String, ring: &[[f64; 2]]) {
    out.push('(');
    for (k, p) in ring.iter().chain(ring.first()).enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        // `{}` on f64 is the shortest decimal that reads back to the same number, and never
        // uses an exponent: valid WKT, and no precision lost.
        let _ = write!(out, "{} {}", p[0], p[1]);
    }
    out.push(')');
}

/// The room's boundary, counter-clockwise, with an apron of depth `depth` (the largest
/// radius) pushed outward along each exit's normal, so that people walking out stay inside;
/// repeated vertices (an exit at a corner) within `tol` are dropped.
fn shell_with_aprons(geometry: &SceneGeometry, depth: f64, tol: f64) -> Vec<[f64; 2]> {
    let room = orient(geometry.room.clone(), true);
    let n = room.len();
    let mut shell: Vec<[f64; 2]> = Vec::with_capacity(n + 4 * geometry.exits.len());
    for i in 0..n {
        let (v0, v1) = (room[i], room[(i + 1) % n]);
        let len = (v1[0] - v0[0]).hypot(v1[1] - v0[1]);
        let along = |p: [f64; 2]| {
            ((p[0] - v0[0]) * (v1[0] - v0[0]) + (p[1] - v0[1]) * (v1[1] - v0[1])) / len
        };
        shell.push(v0);
        if depth <= 0.0 {
            continue;
        }
        // The exits on this edge, in the edge's direction.
        let mut on_edge: Vec<([f64; 2], [f64; 2], [f64; 2])> = geometry
            .exits
            .iter()
            .filter(|e| {
                segment_distance(e.a, v0, v1) <= tol && segment_distance(e.b, v0, v1) <= tol
            })
            .map(|e| {
                if along(e.a) <= along(e.b) {
                    (e.a, e.b, e.outward)
                } else {
                    (e.b, e.a, e.outward)
                }
            })
            .collect();
        on_edge.sort_by(|x, y| along(x.0).total_cmp(&along(y.0)));
        for (p, q, nrm) in on_edge {
            let out = |z: [f64; 2]| [z[0] + depth * nrm[0], z[1] + depth * nrm[1]];
            shell.extend([p, out(p), out(q), q]);
        }
    }
    // An exit that starts or ends at a corner repeats the corner: drop repeats.
    shell.dedup_by(|b, a| (a[0] - b[0]).hypot(a[1] - b[1]) <= tol);
    while shell.len() > 1 {
        let (f, l) = (shell[0], shell[shell.len() - 1]);
        if (f[0] - l[0]).hypot(f[1] - l[1]) <= tol {
            shell.pop();
        } else {
            break;
        }
    }
    shell
}

/// Checks that the shell is a simple polygon: no two non-adjacent edges meet or come within
/// `tol` of each other (the error names the first such pair).
fn check_simple(shell: &[[f64; 2]], depth: f64, tol: f64) -> Result<(), OutputError> {
    let m = shell.len();
    for i in 0..m {
        for j in i + 2..m {
            if i == 0 && j == m - 1 {
                continue; // adjacent through the closing edge
            }
            let (a, b) = (shell[i], shell[(i + 1) % m]);
            let (c, d) = (shell[j], shell[(j + 1) % m]);
            if segments_touch(a, b, c, d, tol) {
                return Err(OutputError::WalkableArea(format!(
                    "the room with its exit aprons (depth {depth}) is not a simple polygon: \
                     edges ({}, {})–({}, {}) and ({}, {})–({}, {}) meet",
                    a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]
                )));
            }
        }
    }
    Ok(())
}

/// The outline of a static obstacle, unoriented: a disk as a `DISK_VERTICES`-gon, a
/// polygon as given, a segment (thin wall) as a rectangle of half-width `half_width`
/// around it.
fn obstacle_ring(shape: &ObstacleShape, half_width: f64) -> Vec<[f64; 2]> {
    match shape {
        ObstacleShape::Disk { center, radius } => (0..DISK_VERTICES)
            .map(|j| {
                let a = std::f64::consts::TAU * j as f64 / DISK_VERTICES as f64;
                [center[0] + radius * a.cos(), center[1] + radius * a.sin()]
            })
            .collect(),
        ObstacleShape::Polygon(v) => v.clone(),
        ObstacleShape::Segment { a, b } => {
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            let (t, nrm) = if len > 0.0 {
                let t = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
                (t, [-t[1], t[0]])
            } else {
                ([1.0, 0.0], [0.0, 1.0])
            };
            let w = half_width;
            let p = |s: [f64; 2], u: f64, v: f64| {
                [s[0] + u * t[0] + v * nrm[0], s[1] + u * t[1] + v * nrm[1]]
            };
            vec![p(*a, -w, -w), p(*b, w, -w), p(*b, w, w), p(*a, -w, w)]
        }
    }
}

/// Adds obstacle `k` to `holes` as a clockwise ring, unless it moves or is a thin wall
/// touching the shell or a hole already placed (then left out, with a note). An obstacle
/// with an area that touches or crosses the shell, or touches, overlaps or contains another
/// hole, is an error.
fn add_hole(
    k: usize,
    obstacle: &Obstacle,
    shell: &[[f64; 2]],
    half_width: f64,
    tol: f64,
    holes: &mut Vec<(usize, Vec<[f64; 2]>)>,
    notes: &mut Vec<String>,
) -> Result<(), OutputError> {
    if !matches!(obstacle.motion, Motion::Static) {
        notes.push(format!(
            "obstacle #{} moves: left out of the walkable area",
            k + 1
        ));
        return Ok(());
    }
    let thin = matches!(obstacle.shape, ObstacleShape::Segment { .. });
    let ring = orient(obstacle_ring(&obstacle.shape, half_width), false);
    let room_poly = Room {
        vertices: shell.to_vec(),
    };
    if !ring.iter().all(|&p| room_poly.contains(p)) || rings_touch(&ring, shell, tol) {
        if thin {
            notes.push(format!(
                "obstacle #{} (a thin wall) touches the room's boundary: left out of \
                 the walkable area",
                k + 1
            ));
            return Ok(());
        }
        return Err(OutputError::WalkableArea(format!(
            "obstacle #{} touches or crosses the room's boundary; the walkable area \
             would not be a polygon with holes (write the trajectory as csv instead)",
            k + 1
        )));
    }
    let inside = |x: &[[f64; 2]], y: &[[f64; 2]]| {
        Room {
            vertices: y.to_vec(),
        }
        .contains(x[0])
    };
    let touched = holes.iter().find(|(_, other)| {
        rings_touch(&ring, other, tol) || inside(&ring, other) || inside(other, &ring)
    });
    if let Some((j, _)) = touched {
        if thin {
            notes.push(format!(
                "obstacle #{} (a thin wall) touches obstacle #{}: left out of the \
                 walkable area",
                k + 1,
                j + 1
            ));
            return Ok(());
        }
        let (first, second) = ((*j).min(k) + 1, (*j).max(k) + 1);
        return Err(OutputError::WalkableArea(format!(
            "obstacles #{first} and #{second} touch or overlap; the walkable area would \
             not be a polygon with holes (write the trajectory as csv instead)"
        )));
    }
    holes.push((k, ring));
    Ok(())
}

impl WalkableArea {
    /// The walkable area of a scene whose people are `population` (see the module's
    /// documentation for what it contains).
    ///
    /// # Errors
    /// [`OutputError::WalkableArea`] when a static obstacle touches the room's boundary or
    /// another obstacle, or the room with its exit aprons is not a simple polygon.
    pub fn of_scene(
        geometry: &SceneGeometry,
        population: &Population,
    ) -> Result<WalkableArea, OutputError> {
        let depth = population.max_radius();
        let r_min = population
            .radii()
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        let scale = {
            let b = geometry.bounds;
            (b[2] - b[0]).max(b[3] - b[1]).max(1.0)
        };
        let tol = 1e-9 * scale;
        let shell = shell_with_aprons(geometry, depth, tol);
        check_simple(&shell, depth, tol)?;

        let half_width = (0.5 * r_min).min(0.01);
        let mut holes: Vec<(usize, Vec<[f64; 2]>)> = Vec::new();
        let mut notes = Vec::new();
        // Areas first, thin walls last: a thin wall that touches something is left out (it
        // has no area, so the area stays exact; only a Voronoi cell could then reach across
        // it), while an obstacle with an area that touches something is an error.
        let mut order: Vec<usize> = (0..geometry.obstacles.len()).collect();
        order
            .sort_by_key(|&k| matches!(geometry.obstacles[k].shape, ObstacleShape::Segment { .. }));
        for k in order {
            add_hole(
                k,
                &geometry.obstacles[k],
                &shell,
                half_width,
                tol,
                &mut holes,
                &mut notes,
            )?;
        }
        holes.sort_by_key(|(k, _)| *k);
        Ok(WalkableArea {
            shell,
            holes: holes.into_iter().map(|(_, h)| h).collect(),
            notes,
        })
    }

    /// `POLYGON ((x y, …), (x y, …), …)`: the shell then the holes, each ring closed.
    pub fn to_wkt(&self) -> String {
        let mut s = String::from("POLYGON (");
        fmt_ring(&mut s, &self.shell);
        for h in &self.holes {
            s.push_str(", ");
            fmt_ring(&mut s, h);
        }
        s.push(')');
        s
    }

    /// The area: the shell's minus the holes'.
    pub fn area(&self) -> f64 {
        0.5 * (signed_area2(&self.shell).abs()
            - self
                .holes
                .iter()
                .map(|h| signed_area2(h).abs())
                .sum::<f64>())
    }

    /// Whether `p` is inside the shell and outside every hole.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        let inside = |v: &[[f64; 2]]| {
            Room {
                vertices: v.to_vec(),
            }
            .contains(p)
        };
        inside(&self.shell) && !self.holes.iter().any(|h| inside(h))
    }

    /// `[xmin, ymin, xmax, ymax]` of the shell.
    pub fn bounds(&self) -> [f64; 4] {
        self.shell.iter().fold(
            [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ],
            |b, p| {
                [
                    b[0].min(p[0]),
                    b[1].min(p[1]),
                    b[2].max(p[0]),
                    b[3].max(p[1]),
                ]
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Overrides, Scene};

    fn area_of(toml: &str) -> Result<WalkableArea, OutputError> {
        let built = Scene::from_toml_str(toml, "inline")
            .unwrap()
            .build(&Overrides::default())
            .unwrap();
        WalkableArea::of_scene(&built.geometry, &built.population)
    }

    const ROOM: &str = r#"
        [room]
        rectangle = [0.0, 0.0, 10.0, 10.0]
        [[exits]]
        from = [10.0, 4.4]
        to = [10.0, 5.6]
        [[people]]
        position = [2.0, 2.0]
        radius = 0.25
    "#;

    #[test]
    fn door_apron_adds_exit_width_times_largest_radius() {
        let w = area_of(ROOM).unwrap();
        assert!(
            (w.area() - (100.0 + 1.2 * 0.25)).abs() < 1e-12,
            "{}",
            w.area()
        );
        assert_eq!(w.shell.len(), 8);
        assert!(w.contains([10.1, 5.0]), "the doorway is walkable");
        assert!(!w.contains([10.1, 3.0]), "beside the door is not");
        assert_eq!(
            w.to_wkt(),
            "POLYGON ((0 0, 10 0, 10 4.4, 10.25 4.4, 10.25 5.6, 10 5.6, 10 10, 0 10, 0 0))"
        );
        assert_eq!(w.bounds(), [0.0, 0.0, 10.25, 10.0]);
    }

    #[test]
    fn exit_over_a_whole_edge_and_a_clockwise_room() {
        let w = area_of(
            r#"
            [room]
            polygon = [[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]]
            [[exits]]
            from = [4.0, 0.0]
            to = [4.0, 4.0]
            [[exits]]
            from = [0.0, 4.0]
            to = [4.0, 4.0]
            [[people]]
            position = [1.0, 1.0]
            radius = 0.5
        "#,
        )
        .unwrap();
        assert!(signed_area2(&w.shell) > 0.0, "shell counter-clockwise");
        assert!(
            (w.area() - (16.0 + 2.0 * 4.0 * 0.5)).abs() < 1e-12,
            "{}",
            w.area()
        );
    }

    #[test]
    fn static_obstacles_are_holes_and_moving_ones_are_not() {
        let w = area_of(&format!(
            "{ROOM}
            [[obstacles]]
            disk = {{ center = [5.0, 5.0], radius = 1.0 }}
            [[obstacles]]
            polygon = [[2.0, 6.0], [3.0, 6.0], [3.0, 7.0], [2.0, 7.0]]
            [[obstacles]]
            segment = {{ from = [6.0, 8.0], to = [8.0, 8.0] }}
            [[obstacles]]
            disk = {{ center = [7.0, 2.0], radius = 0.5 }}
            velocity = [0.1, 0.0]
            "
        ))
        .unwrap();
        assert_eq!(w.holes.len(), 3);
        assert!(
            w.holes.iter().all(|h| signed_area2(h) < 0.0),
            "holes clockwise"
        );
        let disk = std::f64::consts::PI;
        let inscribed = 0.5 * DISK_VERTICES as f64 * (std::f64::consts::TAU / 64.0).sin();
        assert!((disk - inscribed) / disk < 2e-3);
        let expected = 100.0 + 1.2 * 0.25 - inscribed - 1.0 - 2.02 * 0.02;
        assert!(
            (w.area() - expected).abs() < 1e-9,
            "{} vs {expected}",
            w.area()
        );
        assert!(!w.contains([5.0, 5.0]) && !w.contains([7.0, 8.0]));
        assert!(
            w.contains([7.0, 2.0]),
            "the moving disk's place is walkable"
        );
        assert_eq!(w.to_wkt().matches('(').count(), 1 + 4);
    }

    #[test]
    fn a_thin_wall_against_a_wall_is_left_out_and_a_pillar_against_one_refused() {
        let w = area_of(&format!(
            "{ROOM}
            [[obstacles]]
            segment = {{ from = [0.0, 8.0], to = [3.0, 8.0] }}
            [[obstacles]]
            disk = {{ center = [6.0, 7.0], radius = 0.5 }}
            [[obstacles]]
            segment = {{ from = [6.0, 7.5], to = [6.0, 9.0] }}
            "
        ))
        .unwrap();
        assert_eq!(w.holes.len(), 1, "only the disk");
        assert_eq!(w.notes.len(), 2, "{:?}", w.notes);
        assert!(w.notes[0].contains("obstacle #1") && w.notes[0].contains("boundary"));
        assert!(w.notes[1].contains("obstacle #3") && w.notes[1].contains("obstacle #2"));
        let err = area_of(&format!(
            "{ROOM}
            [[obstacles]]
            polygon = [[0.0, 8.0], [1.0, 8.0], [1.0, 9.0]]
            "
        ))
        .unwrap_err();
        assert!(err.to_string().contains("obstacle #1"), "{err}");
        let err = area_of(&format!(
            "{ROOM}
            [[obstacles]]
            disk = {{ center = [6.0, 7.0], radius = 0.5 }}
            [[obstacles]]
            polygon = [[6.0, 7.0], [7.0, 7.0], [7.0, 8.0]]
            "
        ))
        .unwrap_err();
        assert!(err.to_string().contains("#1 and #2"), "{err}");
    }
}
