//! Crowd scenes as TOML files: parse, check, build a [`Problem`] with only the effects the
//! scene calls for.
//!
//! The schema is documented in the README, with an annotated example; in short:
//!
//! ```toml
//! name = "tiny"
//! [room]
//! rectangle = [0.0, 0.0, 4.0, 4.0]
//! [[exits]]
//! from = [4.0, 1.5]
//! to = [4.0, 2.5]
//! [desired]
//! kind = "exit"
//! [[people]]
//! position = [1.0, 2.0]
//! radius = 0.2
//! [run]
//! h = 0.05
//! t_end = 5.0
//! ```
//!
//! Each element present becomes a constraint family or a velocity term, and an absent one
//! costs nothing: no pair family for one person, no wall family without walls, no obstacle
//! family without obstacles, no geodesic field unless someone heads for the exits, no time
//! derivatives unless something moves.
//!
//! ```
//! use sweeping::scene::{Overrides, Scene};
//! let scene = Scene::from_toml_str(r#"
//!     [room]
//!     rectangle = [0.0, 0.0, 4.0, 4.0]
//!     [[people]]
//!     position = [1.0, 2.0]
//!     radius = 0.2
//!     desired = { kind = "constant", velocity = [0.5, 0.0] }
//! "#, "inline").unwrap();
//! let built = scene.build(&Overrides::default()).unwrap();
//! assert_eq!(built.population.len(), 1);
//! // One person: no pair family; four walls; no obstacles.
//! let names: Vec<_> = built.problem.families().iter().map(|f| f.name().to_string()).collect();
//! assert_eq!(names, vec!["walls"]);
//! ```

mod effect;
mod error;
pub mod spec;

pub use effect::Effect;
pub use error::{line_column, SceneError};
pub use spec::SceneSpec;

use crate::backends::BackendChoice;
use crate::constraint::ConstraintKernel;
use crate::crowd::fast_marching::{DistanceField, MarchingDomain};
use crate::crowd::velocity::{
    ConstantVelocity, DesiredVelocity, ExitSegment, TowardsExits, TowardsPoint, VelocityField,
};
use crate::crowd::{
    segment_distance, DiskPairs, Motion, PersonShapeKernel, PersonShapes, Population, Room, Shape,
    ShapeParams,
};
use crate::problem::Problem;
use crate::stepper::{display_number, StepperSettings};

/// The most people a scene may hold (explicit and placed): beyond it a run would not end in
/// reasonable time on the machines this is made for.
pub const MAX_PEOPLE: usize = 1_000_000;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spec::{DesiredKind, DesiredSpec, RadiusSpec};
use std::path::Path;
use std::sync::Arc;
use toml::Spanned;

/// A parsed (not yet checked) scene file.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The parsed file.
    pub spec: SceneSpec,
    /// The scene's name: `name` in the file, else the file's stem.
    pub name: String,
    origin: String,
    text: String,
}

/// Command-line overrides of a scene's settings.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Time step.
    pub h: Option<f64>,
    /// Horizon.
    pub t_end: Option<f64>,
    /// Seed of every random placement (group `g` uses `seed + g`).
    pub seed: Option<u64>,
    /// Backend.
    pub backend: Option<BackendChoice>,
}

/// An obstacle as drawn: its shape at `t = 0` and its motion.
#[derive(Debug, Clone, PartialEq)]
pub enum ObstacleShape {
    /// A disk.
    Disk {
        /// Centre.
        center: [f64; 2],
        /// Radius.
        radius: f64,
    },
    /// A segment.
    Segment {
        /// One end.
        a: [f64; 2],
        /// The other end.
        b: [f64; 2],
    },
    /// A polygon.
    Polygon(Vec<[f64; 2]>),
}

/// One obstacle.
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    /// Its shape at `t = 0`.
    pub shape: ObstacleShape,
    /// Its motion.
    pub motion: Motion,
}

impl Obstacle {
    /// Its displacement at time `t`.
    pub fn offset(&self, t: f64) -> [f64; 2] {
        self.motion.offset(t)
    }
}

/// What there is to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneGeometry {
    /// The room's boundary.
    pub room: Vec<[f64; 2]>,
    /// Wall segments: the room's edges minus the exits.
    pub walls: Vec<([f64; 2], [f64; 2])>,
    /// Exits with their outward normals.
    pub exits: Vec<ExitSegment>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// `[x0, y0, x1, y1]`: the room's bounding box with a margin for people walking out.
    pub bounds: [f64; 4],
}

/// What `sweep run` writes, from the scene's `[output]`.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSettings {
    /// Seconds between trajectory rows (at least one step).
    pub trajectory_every: f64,
    /// Seconds between SVG snapshots.
    pub snapshot_every: f64,
    /// Most frames in the HTML animation.
    pub animation_frames: usize,
    /// Trajectory formats to write (at least one, no repeats).
    pub formats: Vec<crate::output::TrajectoryFormat>,
}

/// A scene ready to run.
pub struct BuiltScene {
    /// The scene's name.
    pub name: String,
    /// The sweeping process.
    pub problem: Problem,
    /// The people (shared with the constraint families and the velocity field).
    pub population: Arc<Population>,
    /// Desired speed of each person.
    pub speeds: Vec<f64>,
    /// Group of each person (index into [`BuiltScene::groups`]), for colours and reports.
    pub group_of: Vec<usize>,
    /// Names of the groups (`[[people]] #1`, `[[crowds]] #2 (150 people)`).
    pub groups: Vec<String>,
    /// Step, horizon and the rest.
    pub settings: StepperSettings,
    /// The projection backend.
    pub backend: BackendChoice,
    /// Stop as soon as everybody has left.
    pub stop_when_empty: bool,
    /// Outputs.
    pub output: OutputSettings,
    /// The geometry, for drawing.
    pub geometry: SceneGeometry,
    /// The active effects (constraint families, velocity terms, exits).
    pub effects: Vec<Effect>,
    /// The geodesic field, when some people head for the exits.
    pub distance_field: Option<Arc<DistanceField>>,
}

/// Where person `i` came from, for error messages.
#[derive(Debug, Clone)]
struct Origin {
    item: String,
    line: usize,
}

struct Ctx<'a> {
    file: &'a str,
    /// Byte offset of the start of every line: a line is found by binary search, so that
    /// 200 000 `[[people]]` are located in `O(N log N)` (scanning the text for each was
    /// quadratic).
    line_starts: Vec<usize>,
}

impl Ctx<'_> {
    fn new<'a>(file: &'a str, text: &str) -> Ctx<'a> {
        let line_starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Ctx { file, line_starts }
    }

    fn line_of<T>(&self, s: &Spanned<T>) -> usize {
        let offset = s.span().start;
        self.line_starts
            .partition_point(|&start| start <= offset)
            .max(1)
    }

    fn err(
        &self,
        line: Option<usize>,
        item: impl Into<String>,
        message: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_string(),
            line,
            item: item.into(),
            message: message.into(),
        }
    }
}

fn finite<const K: usize>(v: &[f64; K]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn fmt_pt(p: [f64; 2]) -> String {
    format!("({}, {})", p[0], p[1])
}

impl Scene {
    /// Reads and parses a scene file.
    ///
    /// # Errors
    /// [`SceneError::Io`] or [`SceneError::Parse`] (with line and column).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|reason| SceneError::Io {
            file: file.clone(),
            reason,
        })?;
        let mut scene = Self::from_toml_str(&text, &file)?;
        if scene.spec.name.is_none() {
            if let Some(stem) = path.file_stem() {
                scene.name = stem.to_string_lossy().into_owned();
            }
        }
        Ok(scene)
    }

    /// Parses a scene from text; `origin` names it in errors (a file name, or "inline").
    ///
    /// # Errors
    /// [`SceneError::Parse`] for invalid TOML, a missing field, an unknown key or a wrong
    /// type, with line and column.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        let spec: SceneSpec = toml::from_str(text).map_err(|e| {
            let (line, column) = e
                .span()
                .map(|s| line_column(text, s.start))
                .unwrap_or((1, 1));
            SceneError::Parse {
                file: origin.to_string(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        let name = spec.name.clone().unwrap_or_else(|| "scene".to_string());
        Ok(Scene {
            spec,
            name,
            origin: origin.to_string(),
            text: text.to_string(),
        })
    }

    /// Where the scene came from (a file name, or what [`Scene::from_toml_str`] was given).
    pub fn origin(&self) -> &str {
        &self.origin
    }

    /// Checks the scene and builds the problem: room, walls, exits, obstacles, people (the
    /// random ones placed now), desired velocities, step and horizon.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the item and its line: non-finite numbers, a
    /// non-positive radius or step, an exit not on a wall, a person outside the room or
    /// inside an obstacle, overlapping people, a crowd that does not fit…
    pub fn build(&self, overrides: &Overrides) -> Result<BuiltScene, SceneError> {
        let cx = Ctx::new(&self.origin, &self.text);
        let spec = &self.spec;
        // The name becomes a directory under out/: a path in it would write elsewhere.
        if self.name.is_empty()
            || self.name == "."
            || self.name == ".."
            || self.name.contains(['/', '\\', '\0', ':'])
        {
            return Err(cx.err(
                None,
                "name",
                format!(
                    "the name {:?} names the output directory out/<name>/: it must be a plain \
                     file name (not empty, `.` or `..`, without `/`, `\\`, `:`)",
                    self.name
                ),
            ));
        }

        // ---- run settings
        let run_line = spec.run.as_ref().map(|r| cx.line_of(r));
        let run = spec.run.as_ref().map(|r| r.get_ref().clone());
        let h = overrides
            .h
            .or(run.as_ref().and_then(|r| r.h))
            .unwrap_or(0.01);
        let t_end = overrides
            .t_end
            .or(run.as_ref().and_then(|r| r.t_end))
            .unwrap_or(10.0);
        if !(h.is_finite() && h > 0.0) {
            let item = if overrides.h.is_some() {
                "--h"
            } else {
                "[run] h"
            };
            return Err(cx.err(
                run_line,
                item,
                format!("the time step must be positive and finite, got {h}"),
            ));
        }
        if !(t_end.is_finite() && t_end > 0.0) {
            let item = if overrides.t_end.is_some() {
                "--t-end"
            } else {
                "[run] t_end"
            };
            return Err(cx.err(
                run_line,
                item,
                format!("the horizon must be positive and finite, got {t_end}"),
            ));
        }
        let backend = overrides
            .backend
            .or(run.as_ref().and_then(|r| r.backend))
            .unwrap_or_default();
        let stop_when_empty = run
            .as_ref()
            .and_then(|r| r.stop_when_empty)
            .unwrap_or(false);

        // ---- room
        let room_line = Some(cx.line_of(&spec.room));
        let room_spec = spec.room.get_ref();
        let room_vertices: Vec<[f64; 2]> = match (&room_spec.rectangle, &room_spec.polygon) {
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
                    "give `rectangle = [x0, y0, x1, y1]` or `polygon = [[x, y], …]`",
                ))
            }
        };
        let room = Room {
            vertices: room_vertices.clone(),
        };
        let (bx0, by0, bx1, by1) = bbox(&room_vertices);
        check_resolution(&cx, spec, room_line, &room_vertices)?;
        let scale = (bx1 - bx0).max(by1 - by0);
        let on_tol = 1e-9 * scale.max(1.0);
        let n_edges = room_vertices.len();
        let edge = |k: usize| (room_vertices[k], room_vertices[(k + 1) % n_edges]);

        // ---- exits: each on one edge; openings cut out of the walls.
        let mut openings: Vec<Vec<(f64, f64)>> = vec![Vec::new(); n_edges];
        let mut exits = Vec::new();
        for (k, e) in spec.exits.iter().enumerate() {
            let line = Some(cx.line_of(e));
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
                let (a, b) = edge(ei);
                segment_distance(ex.from, a, b) <= on_tol && segment_distance(ex.to, a, b) <= on_tol
            }) else {
                return Err(cx.err(line, item, format!("the exit {}–{} is not on a wall of the room (both ends must lie on the same edge of the room's boundary)", fmt_pt(ex.from), fmt_pt(ex.to))));
            };
            let (a, b) = edge(ei);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let l2 = ab[0] * ab[0] + ab[1] * ab[1];
            let param = |p: [f64; 2]| ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2;
            let (s0, s1) = {
                let (u, v) = (param(ex.from), param(ex.to));
                (u.min(v), u.max(v))
            };
            if let Some(other) = openings[ei].iter().position(|&(u, v)| s0 < v && u < s1) {
                let _ = other;
                return Err(cx.err(line, item, "the exit overlaps another exit"));
            }
            openings[ei].push((s0, s1));
            let l = l2.sqrt();
            let mut normal = [ab[1] / l, -ab[0] / l];
            let mid = [(ex.from[0] + ex.to[0]) / 2.0, (ex.from[1] + ex.to[1]) / 2.0];
            let probe = [
                mid[0] + normal[0] * 1e-6 * scale,
                mid[1] + normal[1] * 1e-6 * scale,
            ];
            if room.contains(probe) {
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
            let (a, b) = edge(ei);
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

        // ---- obstacles
        let mut obstacles = Vec::new();
        for (k, o) in spec.obstacles.iter().enumerate() {
            let line = Some(cx.line_of(o));
            let item = format!("[[obstacles]] #{}", k + 1);
            let os = o.get_ref();
            let shape = match (&os.disk, &os.segment, &os.polygon) {
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
                        return Err(cx.err(
                            line,
                            item,
                            "a polygon needs at least 3 finite vertices",
                        ));
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
                    ObstacleShape::Polygon(p.clone())
                }
                _ => {
                    return Err(cx.err(
                        line,
                        item,
                        "give exactly one of `disk`, `segment` and `polygon`",
                    ))
                }
            };
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
        let shapes_of = |o: &Obstacle| -> Vec<Shape> {
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
        };

        // ---- people
        let default_desired = spec
            .desired
            .as_ref()
            .map(|d| (d.get_ref().clone(), cx.line_of(d)));
        if let Some((d, line)) = &default_desired {
            check_desired(&cx, Some(*line), "[desired]", d, !exits.is_empty())?;
        }
        let mut positions: Vec<[f64; 2]> = Vec::new();
        let mut radii: Vec<f64> = Vec::new();
        let mut speeds: Vec<f64> = Vec::new();
        let mut desired: Vec<Option<DesiredSpec>> = Vec::new();
        let mut origins: Vec<Origin> = Vec::new();
        let mut group_of = Vec::new();
        let mut groups = Vec::new();
        let wall_clear = |p: [f64; 2], r: f64| -> Result<(), String> {
            if !room.contains(p) {
                return Err(format!("the person at {} is outside the room", fmt_pt(p)));
            }
            if let Some((a, b)) = walls.iter().find(|(a, b)| segment_distance(p, *a, *b) < r) {
                return Err(format!(
                    "the person at {} (radius {r}) crosses the wall {}–{}",
                    fmt_pt(p),
                    fmt_pt(*a),
                    fmt_pt(*b)
                ));
            }
            Ok(())
        };
        let obstacle_clear = |p: [f64; 2], r: f64| -> Result<(), String> {
            for (o, _, k) in &obstacles {
                let inside_polygon = matches!(&o.shape, ObstacleShape::Polygon(v) if (Room { vertices: v.clone() }).contains(p));
                let touches = shapes_of(o).iter().any(|s| {
                    let params = ShapeParams {
                        shape: s.clone(),
                        motion: o.motion.clone(),
                        person_radius: r,
                    };
                    PersonShapeKernel.value(&params, 0.0, p) < 0.0
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
        };
        for (k, p) in spec.people.iter().enumerate() {
            let line = cx.line_of(p);
            let item = format!("[[people]] #{}", k + 1);
            let ps = p.get_ref();
            if !finite(&ps.position) {
                return Err(cx.err(
                    Some(line),
                    item,
                    format!("the position {:?} is not finite", ps.position),
                ));
            }
            if !(ps.radius.is_finite() && ps.radius > 0.0) {
                return Err(cx.err(
                    Some(line),
                    item,
                    format!("the radius must be positive and finite, got {}", ps.radius),
                ));
            }
            let speed = ps.speed.unwrap_or(1.0);
            if !(speed.is_finite() && speed >= 0.0) {
                return Err(cx.err(
                    Some(line),
                    item,
                    format!("the speed must be ≥ 0 and finite, got {speed}"),
                ));
            }
            if let Some(d) = &ps.desired {
                check_desired(&cx, Some(line), &item, d, !exits.is_empty())?;
            }
            wall_clear(ps.position, ps.radius).map_err(|m| cx.err(Some(line), item.clone(), m))?;
            obstacle_clear(ps.position, ps.radius)
                .map_err(|m| cx.err(Some(line), item.clone(), m))?;
            positions.push(ps.position);
            radii.push(ps.radius);
            speeds.push(speed);
            desired.push(ps.desired.clone());
            origins.push(Origin {
                item: item.clone(),
                line,
            });
            group_of.push(groups.len());
            groups.push(item);
        }
        // Explicit people must not overlap (random ones are placed clear of everybody): a
        // spatial hash of cell 2·r_max finds every overlapping pair in O(N).
        {
            let rmax = radii.iter().copied().fold(0.0, f64::max);
            let mut hash = SpatialHash::new(2.0 * rmax);
            for (j, p) in positions.iter().enumerate() {
                if let Some(i) = hash.near(*p).find(|&i| {
                    let d = ((p[0] - positions[i][0]).powi(2) + (p[1] - positions[i][1]).powi(2))
                        .sqrt();
                    d < radii[i] + radii[j] - 1e-12
                }) {
                    let d = ((positions[i][0] - p[0]).powi(2) + (positions[i][1] - p[1]).powi(2))
                        .sqrt();
                    return Err(cx.err(
                        Some(origins[j].line),
                        format!("{} and {}", origins[i].item, origins[j].item),
                        format!(
                            "the two people overlap at t = 0 (centres {} apart, radii {} + {})",
                            d, radii[i], radii[j]
                        ),
                    ));
                }
                hash.insert(*p, j);
            }
        }
        for (g, c) in spec.crowds.iter().enumerate() {
            let line = cx.line_of(c);
            let item = format!("[[crowds]] #{}", g + 1);
            let cs = c.get_ref();
            let (rmin, rmax) = match cs.radius {
                RadiusSpec::Fixed(r) => (r, r),
                RadiusSpec::Range([a, b]) => (a, b),
            };
            if !(rmin.is_finite() && rmax.is_finite() && rmin > 0.0 && rmax >= rmin) {
                return Err(cx.err(Some(line), item, format!("the radius must be positive and finite (a range needs 0 < min ≤ max), got {:?}", cs.radius)));
            }
            let speed = cs.speed.unwrap_or(1.0);
            if !(speed.is_finite() && speed >= 0.0) {
                return Err(cx.err(
                    Some(line),
                    item,
                    format!("the speed must be ≥ 0 and finite, got {speed}"),
                ));
            }
            if let Some(d) = &cs.desired {
                check_desired(&cx, Some(line), &item, d, !exits.is_empty())?;
            }
            let region = cs.region.unwrap_or([bx0, by0, bx1, by1]);
            if !(finite(&region) && region[2] > region[0] && region[3] > region[1]) {
                return Err(cx.err(Some(line), item, format!("the region [x0, y0, x1, y1] = {region:?} needs finite numbers, x1 > x0 and y1 > y0")));
            }
            let seed = match overrides.seed {
                Some(s) => s.wrapping_add(g as u64),
                None => cs.seed.unwrap_or(0),
            };
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            // A packing bound before any placement: the disks (radius ≥ rmin) are disjoint and
            // lie in the room and in the region grown by rmin, so their count is at most the
            // smaller of those areas over π rmin² (a count beyond it would only fail, slowly).
            let room_area = polygon_area(&room_vertices).abs();
            let grown = (region[2] - region[0] + 2.0 * rmin) * (region[3] - region[1] + 2.0 * rmin);
            let fit = room_area.min(grown) / (std::f64::consts::PI * rmin * rmin);
            if cs.count as f64 > fit {
                return Err(cx.err(Some(line), item, format!("{} people of radius ≥ {rmin} cannot fit: the area bound allows at most {} (room area {}, region {region:?})", cs.count, fit.floor(), display_number(room_area))));
            }
            if positions.len().saturating_add(cs.count) > MAX_PEOPLE {
                return Err(cx.err(
                    Some(line),
                    item,
                    format!(
                        "{} people: a scene holds at most {MAX_PEOPLE}",
                        positions.len().saturating_add(cs.count)
                    ),
                ));
            }
            let max_attempts = cs.count.saturating_mul(2000).saturating_add(10_000);
            let mut placed = 0usize;
            let mut attempts = 0usize;
            let global_rmax = radii.iter().copied().fold(rmax, f64::max);
            let mut hash = SpatialHash::new(2.0 * global_rmax);
            for (i, p) in positions.iter().enumerate() {
                hash.insert(*p, i);
            }
            while placed < cs.count {
                attempts += 1;
                if attempts > max_attempts {
                    return Err(cx.err(Some(line), item, format!("could place only {placed} of {} people without overlap in the region {region:?} after {max_attempts} attempts; enlarge the region or lower the count", cs.count)));
                }
                let r = if rmax > rmin {
                    rng.gen_range(rmin..=rmax)
                } else {
                    rmin
                };
                let p = [
                    rng.gen_range(region[0]..=region[2]),
                    rng.gen_range(region[1]..=region[3]),
                ];
                if wall_clear(p, r).is_err() || obstacle_clear(p, r).is_err() {
                    continue;
                }
                let clash = hash.near(p).any(|j| {
                    let d = ((p[0] - positions[j][0]).powi(2) + (p[1] - positions[j][1]).powi(2))
                        .sqrt();
                    d < r + radii[j] + 1e-9
                });
                if clash {
                    continue;
                }
                hash.insert(p, positions.len());
                positions.push(p);
                radii.push(r);
                speeds.push(speed);
                desired.push(cs.desired.clone());
                origins.push(Origin {
                    item: format!("{item}, person {}", placed + 1),
                    line,
                });
                group_of.push(groups.len());
                placed += 1;
            }
            groups.push(format!("{item} ({} people)", cs.count));
        }
        if positions.is_empty() {
            return Err(cx.err(
                None,
                "[[people]] / [[crowds]]",
                "the scene has nobody in it",
            ));
        }

        // ---- desired velocities: one term per distinct desire.
        let mut terms: Vec<(DesiredSpec, Vec<usize>)> = Vec::new();
        let mut still = 0usize;
        for (i, d) in desired.iter().enumerate() {
            let d = d
                .clone()
                .or_else(|| default_desired.as_ref().map(|x| x.0.clone()));
            match d {
                None => still += 1,
                Some(d) => {
                    if d.kind == DesiredKind::Constant {
                        let v = d.velocity.unwrap_or([0.0, 0.0]);
                        speeds[i] = (v[0] * v[0] + v[1] * v[1]).sqrt();
                    }
                    match terms.iter_mut().find(|(s, _)| *s == d) {
                        Some((_, people)) => people.push(i),
                        None => terms.push((d, vec![i])),
                    }
                }
            }
        }
        let population = Population::new(radii.clone())
            .with_room(room.clone())
            .shared();
        let mut effects = Vec::new();
        let cell = spec
            .geodesic
            .as_ref()
            .and_then(|g| g.get_ref().cell)
            .unwrap_or(0.05);
        let geodesic_line = spec.geodesic.as_ref().map(|g| cx.line_of(g));
        let needs_field = terms.iter().any(|(d, _)| d.kind == DesiredKind::Exit);
        let distance_field = if needs_field {
            if !(cell.is_finite() && cell > 0.0) {
                return Err(cx.err(
                    geodesic_line,
                    "[geodesic] cell",
                    format!("the cell size must be positive and finite, got {cell}"),
                ));
            }
            // A grid coarser than the room (or than a door) cannot represent the routes: the
            // field would point people anywhere. Refuse it rather than run with it.
            let room_side = (bx1 - bx0).min(by1 - by0);
            let shortest_exit = exits
                .iter()
                .map(|e| (e.b[0] - e.a[0]).hypot(e.b[1] - e.a[1]))
                .fold(f64::INFINITY, f64::min);
            if cell > room_side / 4.0 || cell > shortest_exit / 2.0 {
                return Err(cx.err(
                    geodesic_line,
                    "[geodesic] cell",
                    format!(
                        "the cell {cell} is too coarse for the geodesic field: it must be at most a \
                         quarter of the room's smallest side ({}) and half the narrowest exit ({})",
                        display_number(room_side),
                        display_number(shortest_exit)
                    ),
                ));
            }
            let domain = MarchingDomain {
                room: room_vertices.clone(),
                exits: exits.iter().map(|e| (e.a, e.b)).collect(),
                disks: obstacles
                    .iter()
                    .filter(|(o, _, _)| o.motion.is_static())
                    .filter_map(|(o, _, _)| match &o.shape {
                        ObstacleShape::Disk { center, radius } => Some((*center, *radius)),
                        _ => None,
                    })
                    .collect(),
                segments: obstacles
                    .iter()
                    .filter(|(o, _, _)| o.motion.is_static())
                    .filter_map(|(o, _, _)| match &o.shape {
                        ObstacleShape::Segment { a, b } => Some((*a, *b)),
                        _ => None,
                    })
                    .collect(),
                polygons: obstacles
                    .iter()
                    .filter(|(o, _, _)| o.motion.is_static())
                    .filter_map(|(o, _, _)| match &o.shape {
                        ObstacleShape::Polygon(p) => Some(p.clone()),
                        _ => None,
                    })
                    .collect(),
            };
            let field = DistanceField::compute(&domain, cell)
                .map_err(|e| cx.err(geodesic_line, "[geodesic]", e.to_string()))?;
            Some(Arc::new(field))
        } else {
            None
        };
        let mut velocity = DesiredVelocity::new(population.clone(), speeds.clone(), exits.clone());
        for (d, people) in terms {
            let field: Box<dyn VelocityField> = match d.kind {
                DesiredKind::Exit => match &distance_field {
                    Some(f) => Box::new(TowardsExits { field: f.clone() }),
                    None => continue,
                },
                DesiredKind::Point => Box::new(TowardsPoint {
                    point: d.point.unwrap_or_default(),
                }),
                DesiredKind::Constant => Box::new(ConstantVelocity(d.velocity.unwrap_or_default())),
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

        // ---- constraint families
        let q0: Vec<f64> = positions.iter().flatten().copied().collect();
        let n = positions.len();
        let mut problem = Problem::new(q0, velocity);
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
            for (o, _, _) in &obstacles {
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
        if !exits.is_empty() {
            effects.push(Effect::Exits { count: exits.len() });
        }
        problem
            .validate(1e-9)
            .map_err(|e| cx.err(None, "initial configuration", e.to_string()))?;

        // ---- outputs
        let out_spec = spec.output.as_ref().map(|o| o.get_ref().clone());
        let out_line = spec.output.as_ref().map(|o| cx.line_of(o));
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
        // Intervals below one step are clamped to one step (a write per step at most).
        let trajectory_every = trajectory_every.max(h);
        let snapshot_every = snapshot_every.max(h);
        if animation_frames < 2 {
            return Err(cx.err(out_line, "[output] animation_frames", "must be at least 2"));
        }
        let mut formats = out_spec
            .as_ref()
            .and_then(|o| o.formats.clone())
            .unwrap_or_else(|| vec![crate::output::TrajectoryFormat::Csv]);
        if formats.is_empty() {
            return Err(cx.err(
                out_line,
                "[output] formats",
                "needs at least one trajectory format (csv, sqlite)",
            ));
        }
        let mut seen = std::collections::HashSet::new();
        formats.retain(|f| seen.insert(*f));

        let margin = 2.0 * population.max_radius() + 0.05 * scale;
        // A moving obstacle pushes people who may not want to move: the prediction's drift
        // (the stepper's first guess of the cutoff) is then too small and every step would be
        // solved twice. Twice the distance the fastest obstacle covers in a step is a better
        // floor (the culling proof still decides).
        let obstacle_speed = obstacles
            .iter()
            .map(|(o, _, _)| match &o.motion {
                Motion::Static => 0.0,
                Motion::Velocity(v) => v[0].hypot(v[1]),
                Motion::Path(p) => p
                    .windows(2)
                    .map(|w| {
                        (w[1].1[0] - w[0].1[0]).hypot(w[1].1[1] - w[0].1[1]) / (w[1].0 - w[0].0)
                    })
                    .fold(0.0, f64::max),
            })
            .fold(0.0, f64::max);
        let settings = StepperSettings {
            h,
            t_end,
            record_every: 0,
            min_cutoff: 2.0 * h * obstacle_speed,
            ..Default::default()
        };
        Ok(BuiltScene {
            name: self.name.clone(),
            problem,
            population,
            speeds,
            group_of,
            groups,
            settings,
            backend,
            stop_when_empty,
            output: OutputSettings {
                trajectory_every,
                snapshot_every,
                animation_frames,
                formats,
            },
            geometry: SceneGeometry {
                room: room_vertices,
                walls,
                exits,
                obstacles: obstacles.into_iter().map(|(o, _, _)| o).collect(),
                bounds: [bx0 - margin, by0 - margin, bx1 + margin, by1 + margin],
            },
            effects,
            distance_field,
        })
    }
}

impl BuiltScene {
    /// Whether anything depends on time (a moving obstacle): only then are time derivatives
    /// of the constraints meaningful.
    pub fn is_time_dependent(&self) -> bool {
        self.problem
            .families()
            .iter()
            .any(|f| f.is_time_dependent())
    }

    /// A short description: people, walls, obstacles, exits, active effects, `h`, `T`.
    pub fn describe(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(s, "scene `{}`", self.name);
        let _ = writeln!(
            s,
            "  people: {} (radii {:.3}–{:.3})",
            self.population.len(),
            self.population
                .radii()
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min),
            self.population.max_radius()
        );
        for g in &self.groups {
            let _ = writeln!(s, "    {g}");
        }
        let _ = writeln!(s, "  room: {} vertices", self.geometry.room.len());
        let _ = writeln!(s, "  walls: {} segments", self.geometry.walls.len());
        let _ = writeln!(
            s,
            "  obstacles: {} ({} moving)",
            self.geometry.obstacles.len(),
            self.geometry
                .obstacles
                .iter()
                .filter(|o| !o.motion.is_static())
                .count()
        );
        let _ = writeln!(s, "  exits: {}", self.geometry.exits.len());
        let _ = writeln!(s, "  active effects:");
        for e in &self.effects {
            let _ = writeln!(s, "    - {e}");
        }
        let _ = writeln!(
            s,
            "    - time derivatives of the constraints: {}",
            if self.is_time_dependent() {
                "only for the moving obstacles"
            } else {
                "none (static scene)"
            }
        );
        let _ = writeln!(
            s,
            "  h = {}, T = {}{}, backend {}",
            self.settings.h,
            self.settings.t_end,
            if self.stop_when_empty {
                " (stops when everybody has left)"
            } else {
                ""
            },
            self.backend
        );
        s
    }
}

fn check_desired(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    d: &DesiredSpec,
    has_exits: bool,
) -> Result<(), SceneError> {
    let item = format!("{item} desired");
    match d.kind {
        DesiredKind::Exit => {
            if !has_exits {
                return Err(cx.err(line, item, "kind = \"exit\" needs at least one [[exits]]"));
            }
            if d.point.is_some() || d.velocity.is_some() {
                return Err(cx.err(
                    line,
                    item,
                    "kind = \"exit\" takes neither `point` nor `velocity`",
                ));
            }
        }
        DesiredKind::Point => match d.point {
            None => return Err(cx.err(line, item, "kind = \"point\" needs `point = [x, y]`")),
            Some(p) if !finite(&p) => return Err(cx.err(line, item, "the point is not finite")),
            Some(_) if d.velocity.is_some() => {
                return Err(cx.err(line, item, "kind = \"point\" does not take `velocity`"))
            }
            _ => {}
        },
        DesiredKind::Constant => match d.velocity {
            None => {
                return Err(cx.err(
                    line,
                    item,
                    "kind = \"constant\" needs `velocity = [vx, vy]`",
                ))
            }
            Some(v) if !finite(&v) => return Err(cx.err(line, item, "the velocity is not finite")),
            Some(_) if d.point.is_some() => {
                return Err(cx.err(line, item, "kind = \"constant\" does not take `point`"))
            }
            _ => {}
        },
    }
    Ok(())
}

/// Refuses scenes whose coordinates f64 cannot resolve at the people's size. Positions are
/// stored as absolute coordinates, so a constraint value computed from them carries a rounding
/// error of a few units in the last place of the largest coordinate: 16 ε max|x| must stay
/// below `1e-6 · min(r_min, 1)` (the run-time violation tolerance is 1e-6). A 5 m room at
/// (1e12, 1e12) with people of radius 0.2 is refused (ε·1e12 ≈ 2e-4); at (1e6, 1e6) it runs.
fn check_resolution(
    cx: &Ctx<'_>,
    spec: &spec::SceneSpec,
    room_line: Option<usize>,
    room: &[[f64; 2]],
) -> Result<(), SceneError> {
    let mut max_abs = 0.0f64;
    // Non-finite numbers are reported by their own checks, with their item.
    let mut see = |v: f64| {
        if v.is_finite() {
            max_abs = max_abs.max(v.abs());
        }
    };
    for p in room {
        see(p[0]);
        see(p[1]);
    }
    let mut r_min = f64::INFINITY;
    for o in &spec.obstacles {
        let o = o.get_ref();
        if let Some(d) = &o.disk {
            see(d.center[0].abs() + d.radius.abs());
            see(d.center[1].abs() + d.radius.abs());
        }
        if let Some(sg) = &o.segment {
            sg.from.iter().chain(&sg.to).for_each(|&v| see(v));
        }
        for p in o.polygon.iter().flatten() {
            see(p[0]);
            see(p[1]);
        }
        for w in o.path.iter().flatten() {
            see(w[1]);
            see(w[2]);
        }
    }
    for p in &spec.people {
        let p = p.get_ref();
        see(p.position[0]);
        see(p.position[1]);
        if p.radius > 0.0 {
            r_min = r_min.min(p.radius);
        }
    }
    for c in &spec.crowds {
        let c = c.get_ref();
        c.region.iter().flatten().for_each(|&v| see(v));
        let r = match c.radius {
            RadiusSpec::Fixed(r) => r,
            RadiusSpec::Range([a, _]) => a,
        };
        if r > 0.0 {
            r_min = r_min.min(r);
        }
    }
    if !r_min.is_finite() {
        return Ok(()); // nobody (or bad radii): reported with their own errors
    }
    let needed = 1e-6 * r_min.min(1.0);
    let rounding = 16.0 * f64::EPSILON * max_abs;
    if rounding > needed {
        let limit = needed / (16.0 * f64::EPSILON);
        return Err(cx.err(
            room_line,
            "[room]",
            format!(
                "coordinates as large as {max_abs:.3e} are resolved by 64-bit floats only to \
                 about {rounding:.1e}, too coarse for people of radius {r_min} (a contact must \
                 be resolved to {needed:.1e}); keep every coordinate within ±{limit:.2e}, \
                 for instance by moving the scene nearer the origin"
            ),
        ));
    }
    Ok(())
}

fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
}

fn bbox(p: &[[f64; 2]]) -> (f64, f64, f64, f64) {
    p.iter().fold(
        (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), v| (a.min(v[0]), b.min(v[1]), c.max(v[0]), d.max(v[1])),
    )
}

/// Buckets of points by cell, for the random placement.
struct SpatialHash {
    cell: f64,
    map: std::collections::HashMap<(i64, i64), Vec<usize>>,
}

impl SpatialHash {
    fn new(cell: f64) -> Self {
        Self {
            cell: cell.max(1e-9),
            map: Default::default(),
        }
    }
    fn key(&self, p: [f64; 2]) -> (i64, i64) {
        (
            (p[0] / self.cell).floor() as i64,
            (p[1] / self.cell).floor() as i64,
        )
    }
    fn insert(&mut self, p: [f64; 2], i: usize) {
        let k = self.key(p);
        self.map.entry(k).or_default().push(i);
    }
    /// Everything in the 3×3 cells around `p` (all points within `cell` of it, and more).
    fn near(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        let (kx, ky) = self.key(p);
        (-1..=1)
            .flat_map(move |dx| (-1..=1).map(move |dy| (kx + dx, ky + dy)))
            .flat_map(move |k| self.map.get(&k).into_iter().flatten().copied())
    }
}

impl BuiltScene {
    /// Runs the scene to its horizon (or until everybody has left, when the scene says
    /// `stop_when_empty`), calling the observers after each step.
    ///
    /// # Errors
    /// A [`RunFailure`](crate::stepper::RunFailure): the error and everything computed before
    /// it. The observers' `on_finish` is called in every case, so writers flush.
    pub fn run(
        &self,
        projector: &mut dyn sweeping_api::Projector,
        observers: &mut [&mut dyn crate::stepper::Observer],
    ) -> Result<crate::stepper::Run, Box<crate::stepper::RunFailure>> {
        use crate::stepper::{Run, RunFailure, RunStats, Stepper, Trajectory};
        // A new run from q₀: nobody has left yet.
        self.population.reset_departures();
        let stepper = match Stepper::new(&self.problem, self.settings.clone()) {
            Ok(s) => s,
            Err(error) => {
                for o in observers.iter_mut() {
                    let _ = o.on_finish(Some(&error));
                }
                let q0 = self.problem.q0().to_vec();
                return Err(Box::new(RunFailure {
                    error,
                    partial: Run {
                        trajectory: Trajectory {
                            times: vec![self.problem.t0()],
                            states: vec![q0.clone()],
                        },
                        stats: RunStats::default(),
                        q_final: q0,
                        t_final: self.problem.t0(),
                    },
                }));
            }
        };
        let stop_when_empty = self.stop_when_empty;
        let population = &self.population;
        stepper.run_until(projector, observers, |_, q| {
            stop_when_empty && population.present_count(q) == 0
        })
    }
}
