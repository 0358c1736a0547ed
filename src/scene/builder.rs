//! [`CrowdBuilder`]: a crowd scene built in code.
//!
//! A TOML file and the builder fill the same [`SceneSpec`]; [`Scene::build`] then runs the
//! same steps on it, so a scene built in code is checked exactly as a file is, with the same
//! error messages. The items in those messages keep the file's names (`[[people]] #2`,
//! `[[crowds]] #1, person 7`): each builder call adds one such item, in call order. Only the
//! line is missing (there is no file).

use super::spec::{
    ArenaSpec, CrowdSpec, DesiredSpec, DiskSpec, ExitSpec, GeodesicSpec, ObstacleSpec, OutputSpec,
    PersonSpec, RadiusSpec, RoomSpec, RunSpec, SceneSpec, SegmentSpec, SourceSpec,
};
use super::{BuiltScene, ObstacleShape, Overrides, Scene, SceneError};
use crate::backends::BackendChoice;
use crate::crowd::Motion;
use toml::Spanned;

/// A value with no place in a file.
fn unplaced<T>(value: T) -> Spanned<T> {
    Spanned::new(0..0, value)
}

/// Builds a crowd scene in code: room, exits, obstacles (static or moving), people (one by
/// one or random crowds with a seed), desired velocities, the geodesic grid, run and output
/// settings. Everything not given takes the default a scene file would get.
///
/// ```
/// use sweeping::scene::spec::{CrowdSpec, DesiredSpec, RadiusSpec};
/// use sweeping::scene::{CrowdBuilder, ObstacleShape};
/// use sweeping::crowd::Motion;
///
/// let built = CrowdBuilder::new("corridor")
///     .rectangle([0.0, 0.0, 10.0, 4.0])
///     .exit([10.0, 1.5], [10.0, 2.5])
///     .obstacle(ObstacleShape::Disk { center: [5.0, 2.0], radius: 0.5 }, Motion::Static)
///     .person([1.0, 2.0], 0.25)
///     .crowd(CrowdSpec::new(20, RadiusSpec::Range([0.2, 0.25])).region([0.5, 0.5, 4.0, 3.5]))
///     .desired(DesiredSpec::exit())
///     .step(0.05)
///     .horizon(2.0)
///     .build()
///     .unwrap();
/// assert_eq!(built.population.len(), 21);
/// let families: Vec<_> = built.problem.families().iter().map(|f| f.name().to_string()).collect();
/// assert_eq!(families, ["pairs of people", "walls", "obstacles"]);
/// ```
#[derive(Debug, Clone)]
pub struct CrowdBuilder {
    spec: SceneSpec,
}

impl CrowdBuilder {
    /// An empty scene named `name` (the name of its output directory). A room must be given.
    pub fn new(name: impl Into<String>) -> Self {
        CrowdBuilder {
            spec: SceneSpec {
                name: Some(name.into()),
                description: None,
                room: unplaced(RoomSpec::default()),
                exits: Vec::new(),
                obstacles: Vec::new(),
                people: Vec::new(),
                crowds: Vec::new(),
                arena: None,
                sources: Vec::new(),
                desired: None,
                geodesic: None,
                run: None,
                output: None,
            },
        }
    }

    /// The room `[x0, y0, x1, y1]`.
    pub fn rectangle(mut self, r: [f64; 4]) -> Self {
        self.spec.room = unplaced(RoomSpec {
            rectangle: Some(r),
            ..RoomSpec::default()
        });
        self
    }

    /// A polygonal room (vertices in order).
    pub fn polygon(mut self, vertices: Vec<[f64; 2]>) -> Self {
        self.spec.room = unplaced(RoomSpec {
            polygon: Some(vertices),
            ..RoomSpec::default()
        });
        self
    }

    /// The room, its holes (obstacles) and maybe exits and more obstacles, in WKT (see
    /// [`RoomSpec`]): `walkable` a `POLYGON` or a `MULTIPOLYGON` of one polygon, `exits` a
    /// `LINESTRING` or `MULTILINESTRING`.
    pub fn wkt(mut self, walkable: impl Into<String>, exits: Option<String>) -> Self {
        self.spec.room = unplaced(RoomSpec {
            wkt: Some(walkable.into()),
            exits_wkt: exits,
            ..RoomSpec::default()
        });
        self
    }

    /// An exit: a segment on one edge of the room.
    pub fn exit(mut self, from: [f64; 2], to: [f64; 2]) -> Self {
        self.spec.exits.push(unplaced(ExitSpec { from, to }));
        self
    }

    /// A round arena inside the room: every person's disk kept inside the circle of
    /// `radius` about `center` (`[arena]` in a scene file).
    pub fn arena(mut self, center: [f64; 2], radius: f64) -> Self {
        self.spec.arena = Some(unplaced(ArenaSpec { center, radius }));
        self
    }

    /// An obstacle: its shape at `t = 0` and its motion.
    pub fn obstacle(mut self, shape: ObstacleShape, motion: Motion) -> Self {
        let mut o = ObstacleSpec {
            disk: None,
            segment: None,
            polygon: None,
            velocity: None,
            path: None,
        };
        match shape {
            ObstacleShape::Disk { center, radius } => o.disk = Some(DiskSpec { center, radius }),
            ObstacleShape::Segment { a, b } => o.segment = Some(SegmentSpec { from: a, to: b }),
            ObstacleShape::Polygon(p) => o.polygon = Some(p),
        }
        match motion {
            Motion::Static => {}
            Motion::Velocity(v) => o.velocity = Some(v),
            Motion::Path(p) => o.path = Some(p.iter().map(|(t, d)| [*t, d[0], d[1]]).collect()),
        }
        self.spec.obstacles.push(unplaced(o));
        self
    }

    /// A person at `position` with `radius`, speed 1 and the scene's desired velocity.
    pub fn person(self, position: [f64; 2], radius: f64) -> Self {
        self.person_with(PersonSpec {
            position,
            radius,
            speed: None,
            pre_movement: None,
            desired: None,
        })
    }

    /// A person with their own speed or desired velocity.
    pub fn person_with(mut self, person: PersonSpec) -> Self {
        self.spec.people.push(unplaced(person));
        self
    }

    /// `count` people placed at random without overlap (see [`CrowdSpec`]).
    pub fn crowd(mut self, crowd: CrowdSpec) -> Self {
        self.spec.crowds.push(unplaced(crowd));
        self
    }

    /// People arriving during the run (see [`SourceSpec`]).
    pub fn source(mut self, source: SourceSpec) -> Self {
        self.spec.sources.push(unplaced(source));
        self
    }

    /// The desired velocity of everybody who has none of their own.
    pub fn desired(mut self, desired: DesiredSpec) -> Self {
        self.spec.desired = Some(unplaced(desired));
        self
    }

    /// The cell of the fast-marching grid (default 0.05).
    pub fn geodesic_cell(mut self, cell: f64) -> Self {
        self.spec.geodesic = Some(unplaced(GeodesicSpec { cell: Some(cell) }));
        self
    }

    fn run_mut(&mut self) -> &mut RunSpec {
        let run = self.spec.run.get_or_insert_with(|| {
            unplaced(RunSpec {
                h: None,
                t_end: None,
                stop_when_empty: None,
                backend: None,
                threads: None,
            })
        });
        run.get_mut()
    }

    /// The time step (default 0.01).
    pub fn step(mut self, h: f64) -> Self {
        self.run_mut().h = Some(h);
        self
    }

    /// The horizon (default 10).
    pub fn horizon(mut self, t_end: f64) -> Self {
        self.run_mut().t_end = Some(t_end);
        self
    }

    /// The projection backend (default: the first one compiled in).
    pub fn backend(mut self, backend: BackendChoice) -> Self {
        self.run_mut().backend = Some(backend);
        self
    }

    /// Most threads a projection runs on (default `0`: as many as the cores).
    pub fn threads(mut self, threads: usize) -> Self {
        self.run_mut().threads = Some(threads);
        self
    }

    /// Stop as soon as everybody has left (default `false`).
    pub fn stop_when_empty(mut self, stop: bool) -> Self {
        self.run_mut().stop_when_empty = Some(stop);
        self
    }

    /// What `sweep run` writes.
    pub fn output(mut self, output: OutputSpec) -> Self {
        self.spec.output = Some(unplaced(output));
        self
    }

    /// The spec filled so far.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }

    /// The scene, not yet checked (as [`Scene::from_file`] returns it).
    pub fn scene(self) -> Scene {
        let name = self.spec.name.clone().unwrap_or_default();
        Scene {
            origin: format!("{name} (built in code)"),
            name,
            spec: self.spec,
            text: None,
            added_newlines: Vec::new(),
        }
    }

    /// Checks and builds the scene.
    ///
    /// # Errors
    /// As [`Scene::build`], without lines.
    pub fn build(self) -> Result<BuiltScene, SceneError> {
        self.scene().build(&Overrides::default())
    }
}

impl DesiredSpec {
    /// Towards the nearest exit, around the obstacles.
    pub fn exit() -> Self {
        DesiredSpec {
            kind: super::spec::DesiredKind::Exit,
            point: None,
            velocity: None,
            exits: None,
            waypoints: None,
            route: None,
        }
    }

    /// Towards the nearest of the exits numbered `exits` (from 1, in the order they were
    /// added), around the obstacles.
    pub fn exits(exits: Vec<usize>) -> Self {
        DesiredSpec {
            exits: Some(exits),
            ..Self::exit()
        }
    }

    /// Through `waypoints` in order, then towards the nearest exit (or, with
    /// [`ending_at`](Self::ending_at), a point).
    pub fn journey(waypoints: Vec<super::spec::WaypointSpec>) -> Self {
        DesiredSpec {
            kind: super::spec::DesiredKind::Journey,
            waypoints: Some(waypoints),
            ..Self::exit()
        }
    }

    /// A journey's end: the point `point` rather than the exits.
    pub fn ending_at(mut self, point: [f64; 2]) -> Self {
        self.point = Some(point);
        self
    }

    /// How to head for the point (`kind = "point"`, or a journey's end at a point).
    pub fn route(mut self, route: super::spec::Route) -> Self {
        self.route = Some(route);
        self
    }

    /// Straight towards `point`.
    pub fn point(point: [f64; 2]) -> Self {
        DesiredSpec {
            kind: super::spec::DesiredKind::Point,
            point: Some(point),
            velocity: None,
            exits: None,
            waypoints: None,
            route: None,
        }
    }

    /// The constant vector `velocity`.
    pub fn constant(velocity: [f64; 2]) -> Self {
        DesiredSpec {
            kind: super::spec::DesiredKind::Constant,
            point: None,
            velocity: Some(velocity),
            exits: None,
            waypoints: None,
            route: None,
        }
    }
}

impl super::spec::WaypointSpec {
    /// The point `at`, reached within `reach`, by the geodesic route.
    pub fn point(at: [f64; 2], reach: f64) -> Self {
        Self {
            point: Some(at),
            reach: Some(reach),
            region: None,
            route: None,
        }
    }

    /// The rectangle `[x0, y0, x1, y1]`, reached once the centre is inside, by the geodesic
    /// route.
    pub fn region(region: [f64; 4]) -> Self {
        Self {
            point: None,
            reach: None,
            region: Some(region),
            route: None,
        }
    }

    /// In a straight line rather than around the obstacles.
    pub fn straight(mut self) -> Self {
        self.route = Some(super::spec::Route::Straight);
        self
    }
}

impl CrowdSpec {
    /// `count` people of `radius` drawn over the room's bounding box, speed 1, seed 0, the
    /// scene's desired velocity.
    pub fn new(count: usize, radius: super::spec::RadiusSpec) -> Self {
        CrowdSpec {
            count,
            region: None,
            radius,
            speed: None,
            pre_movement: None,
            seed: None,
            desired: None,
            gap: None,
        }
    }

    /// Draw the centres in `[x0, y0, x1, y1]`.
    pub fn region(mut self, region: [f64; 4]) -> Self {
        self.region = Some(region);
        self
    }

    /// The seed of the placement.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = Some(seed);
        self
    }

    /// The desired speed.
    pub fn speed(mut self, speed: f64) -> Self {
        self.speed = Some(super::spec::Drawn::Fixed(speed));
        self
    }

    /// Desired speeds drawn per person (see [`Drawn`](super::spec::Drawn)).
    pub fn speeds(mut self, speeds: super::spec::Drawn) -> Self {
        self.speed = Some(speeds);
        self
    }

    /// Seconds before they start walking, the same for all or drawn per person.
    pub fn pre_movement(mut self, pre_movement: super::spec::Drawn) -> Self {
        self.pre_movement = Some(pre_movement);
        self
    }

    /// Their own desired velocity.
    pub fn desired(mut self, desired: DesiredSpec) -> Self {
        self.desired = Some(desired);
        self
    }

    /// The least distance they keep from everybody (their disks grow by `gap / 2`).
    pub fn gap(mut self, gap: f64) -> Self {
        self.gap = Some(gap);
        self
    }
}

impl SourceSpec {
    /// `count` people of `radius` arriving at `rate` people per second from `t = 0`, at
    /// places drawn in `region` `[x0, y0, x1, y1]`; speed 1, seed 0, the scene's desired
    /// velocity.
    pub fn at_rate(region: [f64; 4], rate: f64, count: usize, radius: RadiusSpec) -> Self {
        SourceSpec {
            region: Some(region),
            door: None,
            rate: Some(rate),
            count: Some(count),
            start: None,
            times: None,
            counts: None,
            radius,
            speed: None,
            seed: None,
            desired: None,
            gap: None,
        }
    }

    /// `counts[k]` people of `radius` arriving at `times[k]`, at places drawn in `region`.
    pub fn on_schedule(
        region: [f64; 4],
        times: Vec<f64>,
        counts: Vec<usize>,
        radius: RadiusSpec,
    ) -> Self {
        SourceSpec {
            rate: None,
            count: None,
            times: Some(times),
            counts: Some(counts),
            ..Self::at_rate(region, 1.0, 1, radius)
        }
    }

    /// The people appear in the row of places just inside the door `from`–`to` (a segment
    /// on a wall) rather than in a region.
    pub fn through_door(mut self, from: [f64; 2], to: [f64; 2]) -> Self {
        self.region = None;
        self.door = Some(SegmentSpec { from, to });
        self
    }

    /// The first arrival at `rate` (default 0).
    pub fn start(mut self, start: f64) -> Self {
        self.start = Some(start);
        self
    }

    /// The seed of the places and draws.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = Some(seed);
        self
    }

    /// Desired speeds, the same for all or drawn per person.
    pub fn speeds(mut self, speeds: super::spec::Drawn) -> Self {
        self.speed = Some(speeds);
        self
    }

    /// Their own desired velocity.
    pub fn desired(mut self, desired: DesiredSpec) -> Self {
        self.desired = Some(desired);
        self
    }

    /// The least distance they keep.
    pub fn gap(mut self, gap: f64) -> Self {
        self.gap = Some(gap);
        self
    }
}
