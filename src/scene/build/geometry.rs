//! The room, its exits and walls, the arena and the obstacles: each checked, in the shapes the
//! constraint families and the geodesic field take.

use super::people::TOUCHING;
use crate::crowd::velocity::ExitSegment;
use crate::crowd::{segment_distance, Motion, Room, Shape};
use crate::scene::checks::{bbox, check_resolution, meeting_edges, polygon_area};
use crate::scene::spec::{ArenaSpec, ObstacleSpec, SceneSpec};
use crate::scene::{finite, fmt_pt, Arena, Ctx, Obstacle, ObstacleShape, SceneError};

/// A wall segment.
pub(in crate::scene) type Wall = ([f64; 2], [f64; 2]);
/// An obstacle with its line and its index in `[[obstacles]]`.
pub(in crate::scene) type Placed = (Obstacle, Option<usize>, usize);

/// The room and the lengths derived from its size.
pub(in crate::scene) struct RoomPlan {
    pub vertices: Vec<[f64; 2]>,
    pub room: Room,
    /// Bounding box `(x0, y0, x1, y1)`.
    pub bbox: (f64, f64, f64, f64),
    /// The bounding box's larger side.
    pub scale: f64,
    /// How far a point may be from an edge and still be on it.
    pub on_tol: f64,
}

impl RoomPlan {
    pub(in crate::scene) fn edge(&self, k: usize) -> Wall {
        let n = self.vertices.len();
        (self.vertices[k], self.vertices[(k + 1) % n])
    }
}

pub(super) fn room(cx: &Ctx<'_>, spec: &SceneSpec) -> Result<RoomPlan, SceneError> {
    let room_line = cx.line_of(&spec.room);
    let room_spec = spec.room.get_ref();
    let vertices: Vec<[f64; 2]> = match (&room_spec.rectangle, &room_spec.polygon) {
        (Some(r), None) => {
            if !finite(r) {
                return Err(cx.err(
                    room_line,
                    "[room]",
                    "the rectangle has a non-finite coordinate",
                ));
            }
            if !(r[2] > r[0] && r[3] > r[1]) {
                return Err(cx.err(
                    room_line,
                    "[room]",
                    format!("the rectangle [x0, y0, x1, y1] = {r:?} needs x1 > x0 and y1 > y0"),
                ));
            }
            Room::rectangle(r[0], r[1], r[2], r[3]).vertices
        }
        (None, Some(p)) => {
            if p.len() < 3 {
                return Err(cx.err(
                    room_line,
                    "[room]",
                    format!("a polygon needs at least 3 vertices, got {}", p.len()),
                ));
            }
            if !p.iter().all(finite) {
                return Err(cx.err(
                    room_line,
                    "[room]",
                    "the polygon has a non-finite coordinate",
                ));
            }
            let area = polygon_area(p);
            if area.abs() < 1e-12 {
                return Err(cx.err(room_line, "[room]", "the polygon has zero area"));
            }
            if let Some(k) = (0..p.len()).find(|&k| p[k] == p[(k + 1) % p.len()]) {
                return Err(cx.err(
                    room_line,
                    "[room]",
                    format!("vertices {} and {} coincide", k + 1, (k + 1) % p.len() + 1),
                ));
            }
            if let Some((a, b)) = meeting_edges(p) {
                return Err(cx.err(
                    room_line,
                    "[room]",
                    format!("edges {a} and {b} of the polygon meet: a room's boundary must not cross or touch itself (edge k runs from vertex k to the next)"),
                ));
            }
            p.clone()
        }
        (Some(_), Some(_)) => {
            return Err(cx.err(
                room_line,
                "[room]",
                "give either `rectangle` or `polygon`, not both",
            ))
        }
        (None, None) => {
            return Err(cx.err(
                room_line,
                "[room]",
                "give `rectangle = [x0, y0, x1, y1]`, `polygon = [[x, y], …]`, `wkt = \"POLYGON ((…))\"` or `wkt_file`",
            ))
        }
    };
    let bb = bbox(&vertices);
    check_resolution(cx, spec, room_line, &vertices)?;
    let scale = (bb.2 - bb.0).max(bb.3 - bb.1);
    let on_tol = 1e-9 * scale.max(1.0);
    let vertices = drop_vertices_under_exits(vertices, spec, on_tol);
    Ok(RoomPlan {
        room: Room {
            vertices: vertices.clone(),
        },
        vertices,
        bbox: bb,
        scale,
        on_tol,
    })
}

/// Drops each vertex that lies inside an exit, between its ends, on the straight line of its
/// two edges: the room keeps its shape, and an exit over consecutive collinear edges lies on
/// one edge, as the walls, the geodesic field and the outputs expect.
fn drop_vertices_under_exits(
    mut vertices: Vec<[f64; 2]>,
    spec: &SceneSpec,
    on_tol: f64,
) -> Vec<[f64; 2]> {
    let under_an_exit = |v: [f64; 2]| {
        spec.exits.iter().map(|e| e.get_ref()).any(|e| {
            let near = |p: [f64; 2]| (p[0] - v[0]).hypot(p[1] - v[1]) <= on_tol;
            finite(&e.from)
                && finite(&e.to)
                && segment_distance(v, e.from, e.to) <= on_tol
                && !near(e.from)
                && !near(e.to)
        })
    };
    while vertices.len() > 3 {
        let n = vertices.len();
        let Some(k) = (0..n).find(|&k| {
            let (prev, next) = (vertices[(k + n - 1) % n], vertices[(k + 1) % n]);
            under_an_exit(vertices[k]) && segment_distance(vertices[k], prev, next) <= on_tol
        }) else {
            break;
        };
        vertices.remove(k);
    }
    vertices
}

/// Exits, each on one edge of the room, with their outward normals; the walls are the edges
/// with the exits cut out.
pub(super) fn exits_and_walls(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    room: &RoomPlan,
) -> Result<(Vec<ExitSegment>, Vec<Wall>), SceneError> {
    let n_edges = room.vertices.len();
    let on_tol = room.on_tol;
    let mut openings: Vec<Vec<(f64, f64)>> = vec![Vec::new(); n_edges];
    let mut exits = Vec::new();
    for (k, e) in spec.exits.iter().enumerate() {
        let line = cx.line_of(e);
        let item = format!("[[exits]] #{}", k + 1);
        let ex = e.get_ref();
        if !finite(&ex.from) || !finite(&ex.to) {
            return Err(cx.err(line, item, "an end is not finite"));
        }
        let len = ((ex.to[0] - ex.from[0]).powi(2) + (ex.to[1] - ex.from[1]).powi(2)).sqrt();
        if len <= on_tol {
            return Err(cx.err(line, item, "the exit has zero length"));
        }
        let Some(ei) = (0..n_edges).find(|&ei| {
            let (a, b) = room.edge(ei);
            segment_distance(ex.from, a, b) <= on_tol && segment_distance(ex.to, a, b) <= on_tol
        }) else {
            return Err(cx.err(line, item, format!("the exit {}–{} is not on a wall of the room (both ends must lie on the same edge of the room's boundary)", fmt_pt(ex.from), fmt_pt(ex.to))));
        };
        let (a, b) = room.edge(ei);
        let ab = [b[0] - a[0], b[1] - a[1]];
        let l2 = ab[0] * ab[0] + ab[1] * ab[1];
        let param = |p: [f64; 2]| ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2;
        let (s0, s1) = {
            let (u, v) = (param(ex.from), param(ex.to));
            (u.min(v), u.max(v))
        };
        if openings[ei].iter().any(|&(u, v)| s0 < v && u < s1) {
            return Err(cx.err(line, item, "the exit overlaps another exit"));
        }
        openings[ei].push((s0, s1));
        let l = l2.sqrt();
        let mut normal = [ab[1] / l, -ab[0] / l];
        let mid = [(ex.from[0] + ex.to[0]) / 2.0, (ex.from[1] + ex.to[1]) / 2.0];
        let probe = [
            mid[0] + normal[0] * 1e-6 * room.scale,
            mid[1] + normal[1] * 1e-6 * room.scale,
        ];
        if room.room.contains(probe) {
            normal = [-normal[0], -normal[1]];
        }
        exits.push(ExitSegment {
            a: ex.from,
            b: ex.to,
            outward: normal,
        });
    }
    let mut walls = Vec::new();
    for (ei, ops) in openings.iter_mut().enumerate() {
        let (a, b) = room.edge(ei);
        ops.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut s = 0.0;
        let lerp = |u: f64| [a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])];
        let elen = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        for &(u, v) in ops.iter() {
            if (u - s) * elen > on_tol {
                walls.push((lerp(s), lerp(u)));
            }
            s = v;
        }
        if (1.0 - s) * elen > on_tol {
            walls.push((lerp(s), lerp(1.0)));
        }
    }
    Ok((exits, walls))
}

/// `[arena]`, checked: a finite centre, a positive radius, the circle inside the room.
pub(super) fn arena(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    room: &RoomPlan,
) -> Result<Option<Arena>, SceneError> {
    let Some(a) = &spec.arena else {
        return Ok(None);
    };
    let line = cx.line_of(a);
    let item = "[arena]";
    let ArenaSpec { center, radius } = *a.get_ref();
    if !finite(&center) {
        return Err(cx.err(line, item, "the centre is not finite"));
    }
    if !(radius.is_finite() && radius > 0.0) {
        return Err(cx.err(
            line,
            item,
            format!("the radius {radius} must be positive and finite"),
        ));
    }
    let inside = room.room.contains(center)
        && room
            .vertices
            .iter()
            .zip(room.vertices.iter().cycle().skip(1))
            .all(|(a, b)| segment_distance(center, *a, *b) >= radius - TOUCHING);
    if !inside {
        return Err(cx.err(
            line,
            item,
            format!(
                "the circle of radius {radius} about {} reaches outside the room",
                fmt_pt(center)
            ),
        ));
    }
    Ok(Some(Arena { center, radius }))
}

pub(super) fn obstacles(cx: &Ctx<'_>, spec: &SceneSpec) -> Result<Vec<Placed>, SceneError> {
    let mut obstacles = Vec::new();
    for (k, o) in spec.obstacles.iter().enumerate() {
        let line = cx.line_of(o);
        let item = format!("[[obstacles]] #{}", k + 1);
        let os = o.get_ref();
        let shape = obstacle_shape(cx, line, &item, os)?;
        let motion = match (&os.velocity, &os.path) {
            (None, None) => Motion::Static,
            (Some(v), None) => {
                if !finite(v) {
                    return Err(cx.err(line, item, "the velocity is not finite"));
                }
                Motion::Velocity(*v)
            }
            (None, Some(p)) => {
                if p.is_empty() || !p.iter().all(finite) {
                    return Err(cx.err(
                        line,
                        item,
                        "the path needs at least one finite waypoint [t, dx, dy]",
                    ));
                }
                if p.windows(2).any(|w| w[1][0] <= w[0][0]) {
                    return Err(cx.err(line, item, "the path's times must increase"));
                }
                Motion::Path(p.iter().map(|w| (w[0], [w[1], w[2]])).collect())
            }
            (Some(_), Some(_)) => {
                return Err(cx.err(line, item, "give `velocity` or `path`, not both"))
            }
        };
        obstacles.push((Obstacle { shape, motion }, line, k));
    }
    Ok(obstacles)
}

fn obstacle_shape(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    os: &ObstacleSpec,
) -> Result<ObstacleShape, SceneError> {
    Ok(match (&os.disk, &os.segment, &os.polygon) {
        (Some(d), None, None) => {
            if !finite(&d.center) || !d.radius.is_finite() {
                return Err(cx.err(line, item, "the disk has a non-finite number"));
            }
            if d.radius <= 0.0 {
                return Err(cx.err(
                    line,
                    item,
                    format!("the disk's radius must be positive, got {}", d.radius),
                ));
            }
            ObstacleShape::Disk {
                center: d.center,
                radius: d.radius,
            }
        }
        (None, Some(s), None) => {
            if !finite(&s.from) || !finite(&s.to) {
                return Err(cx.err(line, item, "the segment has a non-finite end"));
            }
            if s.from == s.to {
                return Err(cx.err(line, item, "the segment has zero length"));
            }
            ObstacleShape::Segment { a: s.from, b: s.to }
        }
        (None, None, Some(p)) => {
            if p.len() < 3 || !p.iter().all(finite) {
                return Err(cx.err(line, item, "a polygon needs at least 3 finite vertices"));
            }
            if polygon_area(p).abs() < 1e-12 {
                return Err(cx.err(line, item, "the polygon has zero area"));
            }
            if let Some(v) = (0..p.len()).find(|&v| p[v] == p[(v + 1) % p.len()]) {
                return Err(cx.err(
                    line,
                    item,
                    format!("vertices {} and {} coincide", v + 1, (v + 1) % p.len() + 1),
                ));
            }
            if let Some((a, b)) = meeting_edges(p) {
                return Err(cx.err(
                    line,
                    item,
                    format!("edges {a} and {b} of the polygon meet: an obstacle's boundary must not cross or touch itself (edge k runs from vertex k to the next)"),
                ));
            }
            ObstacleShape::Polygon(p.clone())
        }
        _ => {
            return Err(cx.err(
                line,
                item,
                "give exactly one of `disk`, `segment` and `polygon`",
            ))
        }
    })
}

/// The shapes an obstacle contributes to the obstacle family: a polygon is its edges.
pub(super) fn shapes_of(o: &Obstacle) -> Vec<Shape> {
    match &o.shape {
        ObstacleShape::Disk { center, radius } => vec![Shape::Disk {
            center: *center,
            radius: *radius,
        }],
        ObstacleShape::Segment { a, b } => vec![Shape::Segment { a: *a, b: *b }],
        ObstacleShape::Polygon(p) => (0..p.len())
            .map(|v| Shape::Segment {
                a: p[v],
                b: p[(v + 1) % p.len()],
            })
            .collect(),
    }
}
