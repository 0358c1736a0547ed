//! [`Scene::build`](super::Scene::build) in named steps, in the order their errors are
//! reported: name, run settings, room, exits (which cut the walls), obstacles, people (explicit,
//! then each random crowd), desired velocities and the geodesic field, constraint families,
//! outputs, stepper settings. Each step checks its own part of the spec and returns typed
//! values; the only state passed along is what a later step needs.

use super::checks::{
    bbox, check_desired, check_resolution, meeting_edges, polygon_area, SpatialHash,
};
use super::drawn;
use super::spec::{
    ArenaSpec, CrowdSpec, DesiredKind, DesiredSpec, Drawn, RadiusSpec, RunSpec, SceneSpec,
    TrajectoryFormat,
};
use super::{
    finite, fmt_pt, Ctx, Effect, Obstacle, ObstacleShape, Origin, OutputSettings, Overrides,
    SceneError, MAX_PEOPLE,
};
use crate::backends::BackendChoice;
use crate::constraint::ConstraintKernel;
use crate::crowd::fast_marching::{DistanceField, MarchingDomain};
use crate::crowd::velocity::{
    ConstantVelocity, DesiredVelocity, ExitSegment, TowardsExits, VelocityField,
};
use crate::crowd::{
    segment_distance, ArenaWall, DiskPairs, Motion, PersonShapeKernel, PersonShapes, Population,
    Room, Shape, ShapeParams,
};
use crate::numbers::display_number;
use crate::problem::Problem;
use crate::stepper::StepperSettings;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

/// A wall segment.
pub(super) type Wall = ([f64; 2], [f64; 2]);
/// An obstacle with its line and its index in `[[obstacles]]`.
pub(super) type Placed = (Obstacle, Option<usize>, usize);

/// The scene's name becomes a directory under out/: a path in it would write elsewhere, and a
/// control character would make a directory no one can type. `line` is the `name` key's.
pub(super) fn check_name(cx: &Ctx<'_>, name: &str, line: Option<usize>) -> Result<(), SceneError> {
    if name.is_empty()
        || name == "."
        || name == ".."
        || name.contains(['/', '\\', ':'])
        || name.contains(char::is_control)
    {
        return Err(cx.err(
            line,
            "name",
            format!(
                "the name {:?} names the output directory out/<name>/: it must be a plain \
                 file name (not empty, `.` or `..`, without `/`, `\\`, `:` or control \
                 characters); give another `name`, or `sweep run --out DIR`",
                name
            ),
        ));
    }
    Ok(())
}

/// `[run]` with the command line's overrides applied.
pub(super) struct RunSettings {
    pub h: f64,
    pub t_end: f64,
    pub backend: BackendChoice,
    pub threads: usize,
    pub stop_when_empty: bool,
}

pub(super) fn run_settings(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    overrides: &Overrides,
) -> Result<RunSettings, SceneError> {
    let run_line = spec.run.as_ref().and_then(|r| cx.line_of(r));
    let run: Option<RunSpec> = spec.run.as_ref().map(|r| r.get_ref().clone());
    let h = overrides
        .h
        .or(run.as_ref().and_then(|r| r.h))
        .unwrap_or(0.01);
    let t_end = overrides
        .t_end
        .or(run.as_ref().and_then(|r| r.t_end))
        .unwrap_or(10.0);
    // The error names the flag when the value came from the command line, else the key.
    let positive = |value: f64, overridden: bool, flag: &str, key: &str, what: &str| {
        if value.is_finite() && value > 0.0 {
            return Ok(());
        }
        let item = if overridden { flag } else { key };
        Err(cx.err(
            run_line,
            item,
            format!("{what} must be positive and finite, got {value}"),
        ))
    };
    positive(h, overrides.h.is_some(), "--h", "[run] h", "the time step")?;
    positive(
        t_end,
        overrides.t_end.is_some(),
        "--t-end",
        "[run] t_end",
        "the horizon",
    )?;
    let backend = overrides
        .backend
        .or(run.as_ref().and_then(|r| r.backend))
        .unwrap_or_default();
    let stop_when_empty = run
        .as_ref()
        .and_then(|r| r.stop_when_empty)
        .unwrap_or(false);
    let threads = overrides
        .threads
        .or(run.as_ref().and_then(|r| r.threads))
        .unwrap_or(0);
    Ok(RunSettings {
        h,
        t_end,
        backend,
        threads,
        stop_when_empty,
    })
}

/// The room and the lengths derived from its size.
pub(super) struct RoomPlan {
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
    pub(super) fn edge(&self, k: usize) -> Wall {
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

/// A checked `[arena]`: its centre and radius.
#[derive(Debug, Clone, Copy)]
pub(super) struct Arena {
    pub center: [f64; 2],
    pub radius: f64,
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
    os: &super::spec::ObstacleSpec,
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

/// How far a person placed at `t = 0` may cross a wall, an obstacle or another person:
/// rounding. A person written as touching a wall (at (9.8, 9.8) with radius 0.2 in a room of
/// 10) is 0.1999999999999993 from it in floating point, and must not be refused as crossing
/// it; the stepper itself accepts `q₀` within `feasibility_tolerance` (1e-9).
const TOUCHING: f64 = 1e-12;

/// Where a person of a given radius may stand at `t = 0`: inside the room, clear of the walls
/// and of the obstacles (to within [`TOUCHING`]). The message says what is in the way.
pub(super) struct Clearance<'a> {
    pub room: &'a RoomPlan,
    pub walls: &'a [Wall],
    pub obstacles: &'a [Placed],
    /// The round arena, when there is one.
    pub arena: Option<Arena>,
    /// How many exits a desire `kind = "exit"` can head for.
    pub exit_count: usize,
}

impl Clearance<'_> {
    fn walls(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        if !self.room.room.contains(p) {
            return Err(format!("the person at {} is outside the room", fmt_pt(p)));
        }
        if let Some((a, b)) = self
            .walls
            .iter()
            .find(|(a, b)| segment_distance(p, *a, *b) < r - TOUCHING)
        {
            return Err(format!(
                "the person at {} (radius {r}) crosses the wall {}–{}",
                fmt_pt(p),
                fmt_pt(*a),
                fmt_pt(*b)
            ));
        }
        Ok(())
    }

    fn obstacles(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        for (o, _, k) in self.obstacles {
            let inside_polygon = matches!(&o.shape, ObstacleShape::Polygon(v) if (Room { vertices: v.clone() }).contains(p));
            let touches = shapes_of(o).iter().any(|s| {
                let params = ShapeParams {
                    shape: s.clone(),
                    motion: o.motion.clone(),
                    person_radius: r,
                };
                PersonShapeKernel.value(&params, 0.0, p) < -TOUCHING
            });
            if inside_polygon || touches {
                return Err(format!(
                    "the person at {} (radius {r}) is inside obstacle #{} at t = 0",
                    fmt_pt(p),
                    k + 1
                ));
            }
        }
        Ok(())
    }

    fn arena(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        match self.arena {
            Some(Arena { center, radius })
                if (p[0] - center[0]).hypot(p[1] - center[1]) > radius - r + TOUCHING =>
            {
                Err(format!(
                    "the person at {} (radius {r}) crosses the arena wall (circle of radius {radius} about {})",
                    fmt_pt(p),
                    fmt_pt(center)
                ))
            }
            _ => Ok(()),
        }
    }

    pub(super) fn check(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        self.walls(p, r)?;
        self.arena(p, r)?;
        self.obstacles(p, r)
    }
}

/// Everybody placed so far, person by person.
#[derive(Default)]
pub(super) struct People {
    pub positions: Vec<[f64; 2]>,
    pub radii: Vec<f64>,
    pub speeds: Vec<f64>,
    /// The speed as the scene file gave it (`None`: the default).
    pub speeds_given: Vec<Option<f64>>,
    /// When each person starts walking (their pre-movement time).
    pub starts: Vec<f64>,
    pub desired: Vec<Option<DesiredSpec>>,
    pub origins: Vec<Origin>,
    pub group_of: Vec<usize>,
    pub groups: Vec<String>,
    /// When each person arrives (`None`: there from the start).
    pub due: Vec<Option<f64>>,
    /// The least gap each person keeps (`gap`; their radius includes half of it).
    pub gaps: Vec<f64>,
}

impl People {
    pub(super) fn push(
        &mut self,
        p: [f64; 2],
        r: f64,
        (speed, given): (f64, Option<f64>),
        d: Option<DesiredSpec>,
        origin: Origin,
        (start, due, gap): (f64, Option<f64>, f64),
    ) {
        self.due.push(due);
        self.gaps.push(gap);
        self.positions.push(p);
        self.radii.push(r);
        self.speeds.push(speed);
        self.speeds_given.push(given);
        self.starts.push(start);
        self.desired.push(d);
        self.origins.push(origin);
        self.group_of.push(self.groups.len());
    }
}

fn check_speed(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    speed: Option<f64>,
) -> Result<f64, SceneError> {
    let speed = speed.unwrap_or(1.0);
    if !(speed.is_finite() && speed >= 0.0) {
        return Err(cx.err(
            line,
            item,
            format!("the speed must be ≥ 0 and finite, got {speed}"),
        ));
    }
    Ok(speed)
}

/// `gap`: the least distance a group keeps, ≥ 0 and finite (default 0).
pub(super) fn check_gap(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    gap: Option<f64>,
) -> Result<f64, SceneError> {
    let gap = gap.unwrap_or(0.0);
    if !(gap.is_finite() && gap >= 0.0) {
        return Err(cx.err(
            line,
            item,
            format!("gap: must be ≥ 0 and finite, got {gap}"),
        ));
    }
    Ok(gap)
}

/// A group's radii: a number or a range drawn with the placement (so that the crowds of
/// earlier scenes keep their places), or a distribution drawn from a stream of its own.
#[derive(Clone, Copy)]
pub(super) enum Radii {
    Placement(f64, f64),
    Drawn(drawn::Checked),
}

impl Radii {
    /// The least and the largest radius.
    pub fn range(self) -> (f64, f64) {
        match self {
            Radii::Placement(a, b) => (a, b),
            Radii::Drawn(c) => drawn::range(c),
        }
    }

    /// As a law to draw from, a range drawn uniformly.
    pub fn law(self) -> drawn::Checked {
        match self {
            Radii::Placement(a, b) if a == b => drawn::Checked::Fixed(a),
            Radii::Placement(a, b) => drawn::Checked::Uniform(a, b),
            Radii::Drawn(c) => c,
        }
    }
}

pub(super) fn check_radii(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    radius: RadiusSpec,
) -> Result<Radii, SceneError> {
    let (rmin, rmax) = match radius {
        RadiusSpec::Fixed(r) => (r, r),
        RadiusSpec::Range([a, b]) => (a, b),
        RadiusSpec::Distribution(d) => {
            let law = Drawn::Distribution(d);
            return drawn::check(cx, line, item, &drawn::RADIUS, Some(&law), 0.0).map(Radii::Drawn);
        }
    };
    if !(rmin.is_finite() && rmax.is_finite() && rmin > 0.0 && rmax >= rmin) {
        return Err(cx.err(
            line,
            item,
            match radius {
                RadiusSpec::Range([a, b]) => format!(
                    "a range of radii needs 0 < min ≤ max, both finite, got radius = [{a:?}, {b:?}]"
                ),
                _ => format!("the radius must be positive and finite, got radius = {rmin:?}"),
            },
        ));
    }
    Ok(Radii::Placement(rmin, rmax))
}

/// The `[[people]]`, each its own group, then a check that no two of them overlap.
pub(super) fn explicit_people(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    clear: &Clearance<'_>,
) -> Result<People, SceneError> {
    let exit_count = clear.exit_count;
    // Checked before any person: a million checks would come first, for an error in the end.
    if let Some(p) = spec.people.get(MAX_PEOPLE) {
        return Err(cx.err(
            cx.line_of(p),
            format!("[[people]] #{}", MAX_PEOPLE + 1),
            format!(
                "{} people: a scene holds at most {MAX_PEOPLE}",
                spec.people.len()
            ),
        ));
    }
    let mut people = People::default();
    for (k, p) in spec.people.iter().enumerate() {
        let line = cx.line_of(p);
        let item = format!("[[people]] #{}", k + 1);
        let ps = p.get_ref();
        if !finite(&ps.position) {
            return Err(cx.err(
                line,
                item,
                format!("the position {:?} is not finite", ps.position),
            ));
        }
        if !(ps.radius.is_finite() && ps.radius > 0.0) {
            return Err(cx.err(
                line,
                item,
                format!("the radius must be positive and finite, got {}", ps.radius),
            ));
        }
        let speed = check_speed(cx, line, &item, ps.speed)?;
        let (radius, gap) = (ps.radius, 0.0);
        let start = match drawn::check(
            cx,
            line,
            &item,
            &drawn::PRE_MOVEMENT,
            ps.pre_movement.map(Drawn::Fixed).as_ref(),
            0.0,
        )? {
            drawn::Checked::Fixed(v) => v,
            _ => unreachable!("a number is checked as a number"),
        };
        if let Some(d) = &ps.desired {
            check_desired(cx, line, &item, d, (exit_count, &clear.room.room))?;
        }
        clear
            .walls(ps.position, radius)
            .map_err(|m| cx.err(line, item.clone(), m))?;
        clear
            .arena(ps.position, radius)
            .map_err(|m| cx.err(line, item.clone(), m))?;
        clear
            .obstacles(ps.position, radius)
            .map_err(|m| cx.err(line, item.clone(), m))?;
        let origin = Origin {
            item: item.clone(),
            line,
        };
        people.push(
            ps.position,
            radius,
            (speed, ps.speed),
            ps.desired.clone(),
            origin,
            (start, None, gap),
        );
        people.groups.push(item);
    }
    check_overlaps(cx, &people)?;
    Ok(people)
}

/// Explicit people must not overlap (random ones are placed clear of everybody): a spatial
/// hash of cell 2·r_max finds every overlapping pair in O(N).
fn check_overlaps(cx: &Ctx<'_>, people: &People) -> Result<(), SceneError> {
    let (positions, radii, origins) = (&people.positions, &people.radii, &people.origins);
    let rmax = radii.iter().copied().fold(0.0, f64::max);
    let mut hash = SpatialHash::new(2.0 * rmax);
    for (j, p) in positions.iter().enumerate() {
        if let Some(i) = hash.near(*p).find(|&i| {
            let d = ((p[0] - positions[i][0]).powi(2) + (p[1] - positions[i][1]).powi(2)).sqrt();
            d < radii[i] + radii[j] - TOUCHING
        }) {
            let d = ((positions[i][0] - p[0]).powi(2) + (positions[i][1] - p[1]).powi(2)).sqrt();
            return Err(cx.err(
                origins[j].line,
                format!("{} and {}", origins[i].item, origins[j].item),
                format!(
                    "the two people overlap at t = 0 (centres {} apart, radii {} + {})",
                    d, radii[i], radii[j]
                ),
            ));
        }
        hash.insert(*p, j);
    }
    Ok(())
}

/// One `[[crowds]]` entry (index `g`): checks it, bounds its count by area, then places its
/// people at random (seed `seed` or the override's `seed + g`), clear of the walls, the
/// obstacles and everybody placed before.
pub(super) fn place_crowd(
    cx: &Ctx<'_>,
    g: usize,
    c: &toml::Spanned<CrowdSpec>,
    seed_override: Option<u64>,
    clear: &Clearance<'_>,
    people: &mut People,
) -> Result<(), SceneError> {
    let (room, exit_count) = (clear.room, clear.exit_count);
    let line = cx.line_of(c);
    let item = format!("[[crowds]] #{}", g + 1);
    let cs = c.get_ref();
    if cs.count == 0 {
        return Err(cx.err(
            line,
            item,
            "count = 0 places nobody: give at least 1, or drop the crowd",
        ));
    }
    let radii = check_radii(cx, line, &item, cs.radius)?;
    let gap = check_gap(cx, line, &item, cs.gap)?;
    // The disks of the constraints: each radius grown by half the gap.
    let (rmin, rmax) = {
        let (a, b) = radii.range();
        (a + gap / 2.0, b + gap / 2.0)
    };
    let speed = drawn::check(cx, line, &item, &drawn::SPEED, cs.speed.as_ref(), 1.0)?;
    let pre_movement = drawn::check(
        cx,
        line,
        &item,
        &drawn::PRE_MOVEMENT,
        cs.pre_movement.as_ref(),
        0.0,
    )?;
    if let Some(d) = &cs.desired {
        check_desired(cx, line, &item, d, (exit_count, &clear.room.room))?;
    }
    let (bx0, by0, bx1, by1) = room.bbox;
    let region = cs.region.unwrap_or([bx0, by0, bx1, by1]);
    if !(finite(&region) && region[2] > region[0] && region[3] > region[1]) {
        return Err(cx.err(line, item, format!("the region [x0, y0, x1, y1] = {region:?} needs finite numbers, x1 > x0 and y1 > y0")));
    }
    let seed = match seed_override {
        Some(s) => s.wrapping_add(g as u64),
        None => cs.seed.unwrap_or(0),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // A packing bound before any placement: the disks (radius ≥ rmin) are disjoint and lie in
    // the room and in the region grown by rmin, so their count is at most the smaller of those
    // areas over π rmin² (a count beyond it would only fail, slowly).
    let room_area = polygon_area(&room.vertices).abs();
    let grown = (region[2] - region[0] + 2.0 * rmin) * (region[3] - region[1] + 2.0 * rmin);
    let fit = room_area.min(grown) / (std::f64::consts::PI * rmin * rmin);
    if cs.count as f64 > fit {
        return Err(cx.err(line, item, format!("{} people of radius ≥ {rmin} cannot fit: the area bound allows at most {} (room area {}, region {region:?})", cs.count, fit.floor(), display_number(room_area))));
    }
    let total = people.positions.len().saturating_add(cs.count);
    if total > MAX_PEOPLE {
        return Err(cx.err(
            line,
            item,
            format!("{total} people: a scene holds at most {MAX_PEOPLE}"),
        ));
    }
    // Drawn after the count is bounded: a count far beyond the room is refused, not
    // allocated.
    let speeds = drawn::draw(
        cx,
        line,
        &item,
        &drawn::SPEED,
        speed,
        cs.count,
        &mut drawn::source(seed, 1),
    )?;
    let starts = drawn::draw(
        cx,
        line,
        &item,
        &drawn::PRE_MOVEMENT,
        pre_movement,
        cs.count,
        &mut drawn::source(seed, 2),
    )?;
    let drawn_radii = match radii {
        Radii::Placement(..) => None,
        Radii::Drawn(law) => Some(drawn::draw(
            cx,
            line,
            &item,
            &drawn::RADIUS,
            law,
            cs.count,
            &mut drawn::source(seed, drawn::RADIUS_STREAM),
        )?),
    };
    let max_attempts = cs.count.saturating_mul(2000).saturating_add(10_000);
    let mut placed = 0usize;
    let mut attempts = 0usize;
    let global_rmax = people.radii.iter().copied().fold(rmax, f64::max);
    let mut hash = SpatialHash::new(2.0 * global_rmax);
    for (i, p) in people.positions.iter().enumerate() {
        hash.insert(*p, i);
    }
    while placed < cs.count {
        attempts += 1;
        if attempts > max_attempts {
            return Err(cx.err(line, item, format!("could place only {placed} of {} people without overlap in the region {region:?} after {max_attempts} attempts; enlarge the region or lower the count", cs.count)));
        }
        let r = match &drawn_radii {
            Some(drawn) => drawn[placed] + gap / 2.0,
            None if rmax > rmin => rng.gen_range(rmin..=rmax),
            None => rmin,
        };
        let p = [
            rng.gen_range(region[0]..=region[2]),
            rng.gen_range(region[1]..=region[3]),
        ];
        if clear.check(p, r).is_err() {
            continue;
        }
        let (positions, radii) = (&people.positions, &people.radii);
        let clash = hash.near(p).any(|j| {
            let d = ((p[0] - positions[j][0]).powi(2) + (p[1] - positions[j][1]).powi(2)).sqrt();
            d < r + radii[j] + 1e-9
        });
        if clash {
            continue;
        }
        hash.insert(p, people.positions.len());
        let origin = Origin {
            item: format!("{item}, person {}", placed + 1),
            line,
        };
        // A speed the file gives, drawn or not, is checked against a constant desire.
        let given = cs.speed.map(|_| speeds[placed]);
        people.push(
            p,
            r,
            (speeds[placed], given),
            cs.desired.clone(),
            origin,
            (starts[placed], None, gap),
        );
        placed += 1;
    }
    people.groups.push(format!("{item} ({} people)", cs.count));
    Ok(())
}

/// Each distinct desire with the people who have it.
pub(super) type DesireTerms = Vec<(DesiredSpec, Vec<usize>)>;

/// One velocity term per distinct desire, with its people; a person's own desire wins over
/// the scene's `[desired]`. A constant desire sets that person's speed to its norm, and a
/// `speed` the file gives that differs from it is an error rather than ignored (a person
/// given `speed = 0` would walk at the velocity's 1 m/s). Also returns how many people have
/// no desire at all (they stand still).
pub(super) fn desire_terms(
    cx: &Ctx<'_>,
    people: &mut People,
    default: Option<&DesiredSpec>,
) -> Result<(DesireTerms, usize), SceneError> {
    let mut terms: DesireTerms = Vec::new();
    let mut still = 0usize;
    for (i, d) in people.desired.iter().enumerate() {
        match d.clone().or_else(|| default.cloned()) {
            None => still += 1,
            Some(d) => {
                if d.kind == DesiredKind::Constant {
                    let v = d.velocity.unwrap_or([0.0, 0.0]);
                    let norm = (v[0] * v[0] + v[1] * v[1]).sqrt();
                    if let Some(given) = people.speeds_given[i] {
                        if (given - norm).abs() > 1e-12 * norm.max(1.0) {
                            let origin = &people.origins[i];
                            return Err(cx.err(
                                origin.line,
                                origin.item.clone(),
                                format!(
                                    "speed = {given} has no effect with the constant desired velocity ({}, {}), whose length {norm} is the speed: drop `speed`, or scale the velocity",
                                    v[0], v[1]
                                ),
                            ));
                        }
                    }
                    people.speeds[i] = norm;
                }
                match terms.iter_mut().find(|(s, _)| *s == d) {
                    Some((_, who)) => who.push(i),
                    None => terms.push((d, vec![i])),
                }
            }
        }
    }
    Ok((terms, still))
}

/// The geodesic fields the desires call for, one per distinct set of exits (by index from 0,
/// sorted; `None`: every exit).
pub(super) type ExitFields = Vec<(Option<Vec<usize>>, Arc<DistanceField>)>;

/// The exits a desire `kind = "exit"` heads for, by index from 0 and sorted (`None`: all).
pub(super) fn chosen_exits(d: &DesiredSpec) -> Option<Vec<usize>> {
    d.exits.as_ref().map(|e| {
        let mut e: Vec<usize> = e.iter().map(|n| n - 1).collect();
        e.sort_unstable();
        e
    })
}

/// The geodesic distance to the exits by fast marching, one field per set of exits that
/// somebody heads for, only when somebody does (`[geodesic] cell` is checked either way);
/// and one per waypoint (or point) somebody heads for by the geodesic route. Static
/// obstacles are holes in their domain.
pub(super) fn geodesic_fields(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    terms: &[(DesiredSpec, Vec<usize>)],
    room: &RoomPlan,
    exits: &[ExitSegment],
    obstacles: &[Placed],
) -> Result<(ExitFields, super::journey::TargetFields), SceneError> {
    let cell = spec
        .geodesic
        .as_ref()
        .and_then(|g| g.get_ref().cell)
        .unwrap_or(0.05);
    let geodesic_line = spec.geodesic.as_ref().and_then(|g| cx.line_of(g));
    // A wrong value is wrong whether or not the field is needed: the file is checked as a whole.
    if !(cell.is_finite() && cell > 0.0) {
        return Err(cx.err(
            geodesic_line,
            "[geodesic] cell",
            format!("the cell size must be positive and finite, got {cell}"),
        ));
    }
    let mut wanted: Vec<Option<Vec<usize>>> = Vec::new();
    let heads_for_exits = |d: &DesiredSpec| {
        d.kind == DesiredKind::Exit || (d.kind == DesiredKind::Journey && d.point.is_none())
    };
    for (d, _) in terms.iter().filter(|(d, _)| heads_for_exits(d)) {
        let chosen = chosen_exits(d);
        if !wanted.contains(&chosen) {
            wanted.push(chosen);
        }
    }
    let targets = super::journey::geodesic_targets(terms);
    if wanted.is_empty() && targets.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    // A grid coarser than the room (or than a door) cannot represent the routes: the field
    // would point people anywhere. Refuse it rather than run with it.
    let (bx0, by0, bx1, by1) = room.bbox;
    let room_side = (bx1 - bx0).min(by1 - by0);
    let shortest_exit = exits
        .iter()
        .map(|e| (e.b[0] - e.a[0]).hypot(e.b[1] - e.a[1]))
        .fold(f64::INFINITY, f64::min);
    // The numbers are printed to the last digit: rounded, a width of 0.19999999999999996
    // would read 0.2, and a refused cell 0.1 would look like half of it.
    if cell > room_side / 4.0 || cell > shortest_exit / 2.0 {
        return Err(cx.err(
            geodesic_line,
            "[geodesic] cell",
            format!(
                "the cell {cell} is too coarse for the geodesic field: it must be at most {}, a \
                 quarter of the room's smallest side ({room_side}), and at most {}, half the \
                 narrowest exit ({shortest_exit})",
                room_side / 4.0,
                shortest_exit / 2.0,
            ),
        ));
    }
    let fixed = || {
        obstacles
            .iter()
            .filter(|(o, _, _)| o.motion.is_static())
            .map(|(o, _, _)| &o.shape)
    };
    let domain = |chosen: &Option<Vec<usize>>| MarchingDomain {
        room: room.vertices.clone(),
        exits: exits
            .iter()
            .enumerate()
            .filter(|(k, _)| chosen.as_ref().is_none_or(|c| c.contains(k)))
            .map(|(_, e)| (e.a, e.b))
            .collect(),
        disks: fixed()
            .filter_map(|s| match s {
                ObstacleShape::Disk { center, radius } => Some((*center, *radius)),
                _ => None,
            })
            .collect(),
        segments: fixed()
            .filter_map(|s| match s {
                ObstacleShape::Segment { a, b } => Some((*a, *b)),
                _ => None,
            })
            .collect(),
        polygons: fixed()
            .filter_map(|s| match s {
                ObstacleShape::Polygon(p) => Some(p.clone()),
                _ => None,
            })
            .collect(),
        targets: Vec::new(),
    };
    let exit_fields = wanted
        .into_iter()
        .map(|chosen| {
            let field = DistanceField::compute(&domain(&chosen), cell)
                .map_err(|e| cx.err(geodesic_line, "[geodesic]", e.to_string()))?;
            Ok((chosen, Arc::new(field)))
        })
        .collect::<Result<ExitFields, SceneError>>()?;
    // A waypoint's field: the room without its exits, the target the only place d = 0.
    let target_fields = targets
        .into_iter()
        .map(|target| {
            let domain = MarchingDomain {
                exits: Vec::new(),
                targets: vec![target],
                ..domain(&None)
            };
            let field = DistanceField::compute(&domain, cell).map_err(|e| {
                cx.err(
                    geodesic_line,
                    "[geodesic]",
                    format!("the field to {}: {e}", super::journey::describe(&target)),
                )
            })?;
            Ok((target, Arc::new(field)))
        })
        .collect::<Result<super::journey::TargetFields, SceneError>>()?;
    Ok((exit_fields, target_fields))
}

/// The perturbation `f`: each person's desired velocity (at their speed, from their start
/// time), one term per distinct desire.
pub(super) fn desired_velocity(
    population: &Arc<Population>,
    people: &People,
    exits: &[ExitSegment],
    (terms, still): (DesireTerms, usize),
    (fields, targets): (&ExitFields, &super::journey::TargetFields),
    effects: &mut Vec<Effect>,
    journeys: &mut Vec<Arc<crate::crowd::journey::JourneyProgress>>,
) -> DesiredVelocity {
    let starts = &people.starts;
    let mut velocity =
        DesiredVelocity::new(population.clone(), people.speeds.clone(), exits.to_vec());
    if starts.iter().any(|&s| s > 0.0) {
        velocity = velocity.with_start_times(starts.to_vec());
    }
    for (d, people) in terms {
        let field: Box<dyn VelocityField> = match d.kind {
            DesiredKind::Exit => {
                let chosen = chosen_exits(&d);
                match fields.iter().find(|(c, _)| *c == chosen) {
                    Some((_, f)) => Box::new(TowardsExits {
                        field: f.clone(),
                        exits: chosen,
                    }),
                    None => continue,
                }
            }
            DesiredKind::Point => super::journey::towards_point(&d, targets),
            DesiredKind::Constant => Box::new(ConstantVelocity(d.velocity.unwrap_or_default())),
            DesiredKind::Journey => {
                let progress = Arc::new(crate::crowd::journey::JourneyProgress::new(
                    population.len(),
                ));
                journeys.push(progress.clone());
                match super::journey::journey(&d, fields, targets, progress) {
                    Some(j) => Box::new(j),
                    None => continue,
                }
            }
        };
        effects.push(Effect::DesiredVelocity {
            field: field.describe(),
            people: people.len(),
        });
        velocity = velocity.with_term(field, people);
    }
    if still > 0 {
        effects.push(Effect::StandingStill { people: still });
    }
    velocity
}

/// The constraint families the scene calls for, and no other: pairs only with two people or
/// more, walls only with walls, obstacles only with obstacles.
pub(super) fn push_families(
    problem: &mut Problem,
    population: &Arc<Population>,
    walls: &[Wall],
    obstacles: &[Placed],
    arena: Option<Arena>,
    effects: &mut Vec<Effect>,
) {
    if let Some(Arena { center, radius }) = arena {
        problem.push_family(Box::new(ArenaWall::new(population.clone(), center, radius)));
        effects.push(Effect::Arena { radius });
    }
    let n = population.len();
    if n >= 2 {
        problem.push_family(Box::new(DiskPairs::new(population.clone())));
        effects.push(Effect::Pairs { people: n });
    }
    if !walls.is_empty() {
        let shapes = walls
            .iter()
            .map(|(a, b)| (Shape::Segment { a: *a, b: *b }, Motion::Static))
            .collect();
        problem.push_family(Box::new(PersonShapes::new(
            "walls",
            population.clone(),
            shapes,
        )));
        effects.push(Effect::Walls {
            segments: walls.len(),
        });
    }
    if !obstacles.is_empty() {
        let mut shapes = Vec::new();
        for (o, _, _) in obstacles {
            for s in shapes_of(o) {
                shapes.push((s, o.motion.clone()));
            }
        }
        let moving = obstacles
            .iter()
            .filter(|(o, _, _)| !o.motion.is_static())
            .count();
        problem.push_family(Box::new(PersonShapes::new(
            "obstacles",
            population.clone(),
            shapes,
        )));
        effects.push(Effect::Obstacles {
            count: obstacles.len(),
            moving,
        });
    }
}

/// `[output]`, checked; intervals below one step are clamped to one step, with a note.
pub(super) fn output_settings(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    h: f64,
    t_end: f64,
) -> Result<OutputSettings, SceneError> {
    let out_spec = spec.output.as_ref().map(|o| o.get_ref().clone());
    let out_line = spec.output.as_ref().and_then(|o| cx.line_of(o));
    let trajectory_every = out_spec
        .as_ref()
        .and_then(|o| o.trajectory_every)
        .unwrap_or(0.1);
    let snapshot_every = out_spec
        .as_ref()
        .and_then(|o| o.snapshot_every)
        .unwrap_or(t_end / 4.0);
    let animation_frames = out_spec
        .as_ref()
        .and_then(|o| o.animation_frames)
        .unwrap_or(400);
    for (name, v) in [
        ("trajectory_every", trajectory_every),
        ("snapshot_every", snapshot_every),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(cx.err(
                out_line,
                format!("[output] {name}"),
                format!("must be positive and finite, got {v}"),
            ));
        }
    }
    if animation_frames < 2 {
        return Err(cx.err(out_line, "[output] animation_frames", "must be at least 2"));
    }
    let mut formats = out_spec
        .as_ref()
        .and_then(|o| o.formats.clone())
        .unwrap_or_else(|| vec![TrajectoryFormat::Csv]);
    if formats.is_empty() {
        return Err(cx.err(
            out_line,
            "[output] formats",
            "needs at least one trajectory format (csv, sqlite)",
        ));
    }
    let mut seen = std::collections::HashSet::new();
    formats.retain(|f| seen.insert(*f));
    // Nothing is written between steps: an interval the file gives shorter than a step is one
    // step, and the user is told.
    let given = |f: fn(&super::spec::OutputSpec) -> Option<f64>| out_spec.as_ref().and_then(f);
    let notes = [
        ("trajectory_every", given(|o| o.trajectory_every)),
        ("snapshot_every", given(|o| o.snapshot_every)),
    ]
    .into_iter()
    .filter_map(|(name, v)| Some((name, v?)))
    .filter(|&(_, v)| v < h)
    .map(|(name, v)| {
        cx.err(
            out_line,
            format!("[output] {name}"),
            format!("{v} is shorter than the step h = {h}: every step is written instead"),
        )
        .to_string()
    })
    .collect();
    Ok(OutputSettings {
        trajectory_every: trajectory_every.max(h),
        snapshot_every: snapshot_every.max(h),
        animation_frames,
        formats,
        contact_forces: out_spec
            .as_ref()
            .and_then(|o| o.contact_forces)
            .unwrap_or(false),
        notes,
    })
}

/// Step and horizon, and the floor of the culling cutoff. A moving obstacle pushes people who
/// may not want to move: the prediction's drift (the stepper's first guess of the cutoff) is
/// then too small and every step would be solved twice. Twice the distance the fastest
/// obstacle covers in a step is a better floor (the culling proof still decides).
pub(super) fn stepper_settings(h: f64, t_end: f64, obstacles: &[Placed]) -> StepperSettings {
    let obstacle_speed = obstacles
        .iter()
        .map(|(o, _, _)| match &o.motion {
            Motion::Static => 0.0,
            Motion::Velocity(v) => v[0].hypot(v[1]),
            Motion::Path(p) => p
                .windows(2)
                .map(|w| (w[1].1[0] - w[0].1[0]).hypot(w[1].1[1] - w[0].1[1]) / (w[1].0 - w[0].0))
                .fold(0.0, f64::max),
        })
        .fold(0.0, f64::max);
    StepperSettings {
        h,
        t_end,
        record_every: 0,
        min_cutoff: 2.0 * h * obstacle_speed,
        ..Default::default()
    }
}
