//! The scene file's schema: plain serde structs, unknown keys refused.
//!
//! Every table that may be wrong on its own is wrapped in [`toml::Spanned`], so that errors
//! found after parsing (an exit off the walls, two people overlapping) name its line.

use crate::backends::BackendChoice;
use serde::{Deserialize, Serialize};
use toml::Spanned;

/// Fixed-size arrays read exactly: `position = [1, 1, 3]` is an error ("expected 2 numbers,
/// got 3"), never silently truncated.
mod exact {
    use serde::de::Error;
    use serde::{Deserialize, Deserializer};

    fn fixed<E: Error, const N: usize>(v: Vec<f64>) -> Result<[f64; N], E> {
        let n = v.len();
        v.try_into()
            .map_err(|_| E::custom(format!("expected {N} numbers, got {n}")))
    }

    pub fn array<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
        fixed(Vec::<f64>::deserialize(d)?)
    }

    pub fn option_array<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<Option<[f64; N]>, D::Error> {
        Option::<Vec<f64>>::deserialize(d)?.map(fixed).transpose()
    }

    pub fn option_vec_array<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<Option<Vec<[f64; N]>>, D::Error> {
        Option::<Vec<Vec<f64>>>::deserialize(d)?
            .map(|vs| vs.into_iter().map(fixed).collect())
            .transpose()
    }
}

/// A whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Name of the scene (default: the file's stem); outputs go to `out/<name>/`.
    pub name: Option<String>,
    /// Free text.
    pub description: Option<String>,
    /// The room.
    pub room: Spanned<RoomSpec>,
    /// Exits: segments on the room's walls.
    #[serde(default)]
    pub exits: Vec<Spanned<ExitSpec>>,
    /// Obstacles inside the room, fixed or moving.
    #[serde(default)]
    pub obstacles: Vec<Spanned<ObstacleSpec>>,
    /// People listed one by one.
    #[serde(default)]
    pub people: Vec<Spanned<PersonSpec>>,
    /// Groups of people placed at random.
    #[serde(default)]
    pub crowds: Vec<Spanned<CrowdSpec>>,
    /// A round arena inside the room: everybody kept inside its circle.
    pub arena: Option<Spanned<ArenaSpec>>,
    /// People arriving during the run.
    #[serde(default)]
    pub sources: Vec<Spanned<SourceSpec>>,
    /// The desired velocity of everybody without their own.
    pub desired: Option<Spanned<DesiredSpec>>,
    /// Settings of the geodesic field.
    pub geodesic: Option<Spanned<GeodesicSpec>>,
    /// Time step, horizon, backend.
    pub run: Option<Spanned<RunSpec>>,
    /// What `sweep run` writes.
    pub output: Option<Spanned<OutputSpec>>,
}

/// `[room]`: exactly one of `rectangle`, `polygon`, `wkt` and `wkt_file`; maybe exits and
/// obstacles in WKT too.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomSpec {
    /// `[x0, y0, x1, y1]`.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub rectangle: Option<[f64; 4]>,
    /// Vertices in order, the last joined to the first.
    #[serde(default, deserialize_with = "exact::option_vec_array")]
    pub polygon: Option<Vec<[f64; 2]>>,
    /// The walkable area in WKT, as shapely and JuPedSim write it: a `POLYGON` (its holes are
    /// obstacles) or a `MULTIPOLYGON` of one polygon.
    pub wkt: Option<String>,
    /// A file holding `wkt` (relative to the scene file's directory).
    pub wkt_file: Option<String>,
    /// Exits in WKT: a `LINESTRING` of two points, or a `MULTILINESTRING` of such, numbered
    /// after the `[[exits]]`.
    pub exits_wkt: Option<String>,
    /// Polygon obstacles in WKT: a `POLYGON` or `MULTIPOLYGON`, numbered after the
    /// `[[obstacles]]` and the holes of `wkt`.
    pub obstacles_wkt: Option<String>,
}

/// `[arena]`: a round wall inside the room, `center` and `radius`: every person's disk stays
/// inside the circle (a concave constraint per person, projected onto exactly each step).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArenaSpec {
    /// `[x, y]`.
    #[serde(deserialize_with = "exact::array")]
    pub center: [f64; 2],
    /// `> 0`, with the circle inside the room.
    pub radius: f64,
}

/// A disk.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiskSpec {
    /// Centre.
    #[serde(deserialize_with = "exact::array")]
    pub center: [f64; 2],
    /// Radius (> 0).
    pub radius: f64,
}

/// A segment.
#[derive(Debug, Clone, Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a segment: a table with `from = [x, y]` and `to = [x, y]`"
)]
pub struct SegmentSpec {
    /// One end.
    #[serde(deserialize_with = "exact::array")]
    pub from: [f64; 2],
    /// The other end.
    #[serde(deserialize_with = "exact::array")]
    pub to: [f64; 2],
}

/// `[[exits]]`: a segment lying on one wall of the room (the same table as a segment
/// obstacle's: `from` and `to`).
pub type ExitSpec = SegmentSpec;

/// `[[obstacles]]`: exactly one of `disk`, `segment`, `polygon`; at most one of `velocity`
/// and `path`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// A disk obstacle (a pillar).
    pub disk: Option<DiskSpec>,
    /// A thin wall.
    pub segment: Option<SegmentSpec>,
    /// A polygon (its edges are the constraints).
    #[serde(default, deserialize_with = "exact::option_vec_array")]
    pub polygon: Option<Vec<[f64; 2]>>,
    /// Moves at this constant velocity from `t = 0`.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub velocity: Option<[f64; 2]>,
    /// Moves through these waypoints `[t, dx, dy]` (displacement from the declared position,
    /// times increasing), linearly in between, still before the first and after the last.
    #[serde(default, deserialize_with = "exact::option_vec_array")]
    pub path: Option<Vec<[f64; 3]>>,
}

/// `[[people]]`: one person.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PersonSpec {
    /// Centre at `t = 0`.
    #[serde(deserialize_with = "exact::array")]
    pub position: [f64; 2],
    /// Radius (> 0).
    pub radius: f64,
    /// Desired speed (≥ 0). Default 1.
    pub speed: Option<f64>,
    /// Seconds before the person starts walking (≥ 0): until then their desired velocity is
    /// zero. Default 0.
    pub pre_movement: Option<f64>,
    /// Own desired velocity (default: the scene's `[desired]`).
    pub desired: Option<DesiredSpec>,
}

/// A number, or a distribution from which each person's value is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(
    untagged,
    expecting = "a number, or a distribution: { uniform = [min, max] } or { normal = [mean, sd], within = [min, max] }"
)]
pub enum Drawn {
    /// Everybody the same.
    Fixed(f64),
    /// Drawn per person.
    Distribution(Distribution),
}

/// A distribution: `uniform = [min, max]`, or `normal = [mean, sd]` truncated to
/// `within = [min, max]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Distribution {
    /// Uniform in `[min, max]`.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub uniform: Option<[f64; 2]>,
    /// Normal with `[mean, standard deviation]`.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub normal: Option<[f64; 2]>,
    /// Where a normal distribution is cut: values outside `[min, max]` are drawn again.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub within: Option<[f64; 2]>,
}

/// A radius, a range `[min, max]` drawn uniformly, or a distribution.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(
    untagged,
    expecting = "a radius (a number), a range [min, max], or a distribution: { uniform = [min, max] } or { normal = [mean, sd], within = [min, max] }"
)]
pub enum RadiusSpec {
    /// Everybody the same.
    Fixed(f64),
    /// Uniform in `[min, max]`, drawn with the placement (a crowd's positions depend on it).
    Range([f64; 2]),
    /// Drawn per person from a stream of the seed of its own: the positions a crowd's seed
    /// gives do not depend on the radii's law (only on where bigger people do not fit).
    Distribution(Distribution),
}

/// `[[crowds]]`: `count` people placed at random without overlap.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrowdSpec {
    /// How many.
    pub count: usize,
    /// `[x0, y0, x1, y1]`: where the centres are drawn (default: the room's bounding box).
    #[serde(default, deserialize_with = "exact::option_array")]
    pub region: Option<[f64; 4]>,
    /// Radius or radius range.
    pub radius: RadiusSpec,
    /// Desired speed (≥ 0), or its distribution. Default 1.
    pub speed: Option<Drawn>,
    /// Seconds before each person starts walking (≥ 0), or their distribution. Default 0.
    pub pre_movement: Option<Drawn>,
    /// Seed of the placement (and of the draws). Default 0.
    pub seed: Option<u64>,
    /// Own desired velocity (default: the scene's `[desired]`).
    pub desired: Option<DesiredSpec>,
    /// The least distance (≥ 0) its people keep from everybody, walls and obstacles
    /// included, half of it each: their disk in the constraints has radius `radius + gap/2`.
    /// Default 0.
    pub gap: Option<f64>,
}

/// `[[sources]]`: people arriving during the run, at a region or a door, at a `rate` or on
/// a schedule (`times`, with `counts`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceSpec {
    /// `[x0, y0, x1, y1]`: the people appear at places drawn in it without overlap.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub region: Option<[f64; 4]>,
    /// A segment on a wall: the people appear in a row of places just inside it.
    pub door: Option<SegmentSpec>,
    /// People per second (> 0), evenly spaced from `start`; with `count`.
    pub rate: Option<f64>,
    /// How many people arrive at `rate`.
    pub count: Option<usize>,
    /// When the first person arrives at `rate` (≥ 0). Default 0.
    pub start: Option<f64>,
    /// When people arrive (≥ 0, non-decreasing): one at each time, or `counts[k]` at
    /// `times[k]`.
    pub times: Option<Vec<f64>>,
    /// How many people arrive at each of `times`. Default one each.
    pub counts: Option<Vec<usize>>,
    /// Radius, range of radii or their distribution.
    pub radius: RadiusSpec,
    /// Desired speed (≥ 0), or its distribution. Default 1.
    pub speed: Option<Drawn>,
    /// Seed of the places and of the draws. Default 0.
    pub seed: Option<u64>,
    /// Own desired velocity (default: the scene's `[desired]`).
    pub desired: Option<DesiredSpec>,
    /// The least distance its people keep, as a crowd's `gap`. Default 0.
    pub gap: Option<f64>,
}

/// Which desired velocity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DesiredKind {
    /// Towards the nearest exit, around obstacles (geodesic distance).
    Exit,
    /// Straight towards `point`.
    Point,
    /// The constant vector `velocity` (the speed is its length).
    Constant,
    /// Through `waypoints` in order, then towards the exits (or `point`).
    Journey,
}

/// How a person heads for a point or a waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Route {
    /// In a straight line (through whatever is in the way).
    Straight,
    /// The shortest way around the fixed obstacles (a geodesic field of its own).
    Geodesic,
}

/// A waypoint of a journey: exactly one of `point` (with `reach`) and `region`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointSpec {
    /// A point, reached within `reach` of it.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub point: Option<[f64; 2]>,
    /// How near the point counts as reached (> 0). Default `0.5`.
    pub reach: Option<f64>,
    /// `[x0, y0, x1, y1]`: reached once the centre is inside.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub region: Option<[f64; 4]>,
    /// How to head for it. Default `"geodesic"`.
    pub route: Option<Route>,
}

/// A desired velocity: `kind = "exit"`, `kind = "point"` with `point`,
/// `kind = "constant"` with `velocity`, or `kind = "journey"` with `waypoints` (then the exits,
/// or `point`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesiredSpec {
    /// Which one.
    pub kind: DesiredKind,
    /// The target of `kind = "point"`.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub point: Option<[f64; 2]>,
    /// The vector of `kind = "constant"`.
    #[serde(default, deserialize_with = "exact::option_array")]
    pub velocity: Option<[f64; 2]>,
    /// With `kind = "exit"` (or a journey's end): the exits to head for (the nearest of
    /// them), numbered from 1 in the order of `[[exits]]`. Default: every exit.
    pub exits: Option<Vec<usize>>,
    /// With `kind = "journey"`: the waypoints, in order.
    pub waypoints: Option<Vec<WaypointSpec>>,
    /// With `kind = "point"`, or a journey ending at `point`: how to head for the point.
    /// Default `"straight"`.
    pub route: Option<Route>,
}

/// `[geodesic]`: the fast-marching grid (used only when someone heads for the exits).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeodesicSpec {
    /// Grid spacing. Default `0.05`.
    pub cell: Option<f64>,
}

/// `[run]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Time step. Default `0.01`.
    pub h: Option<f64>,
    /// Horizon. Default `10`.
    pub t_end: Option<f64>,
    /// Stop as soon as everybody has left. Default `false`.
    pub stop_when_empty: Option<bool>,
    /// Projection backend. Default `native` when compiled in, else `clarabel`.
    pub backend: Option<BackendChoice>,
    /// Most threads a projection runs on (the native backend's large blocks,
    /// [`NativeSettings::threads`](crate::backends::NativeSettings::threads) when the native
    /// backend is compiled in; with two or more, a cross-check's two backends at once); `0`,
    /// as many as the cores the process may run on. Default `0`.
    pub threads: Option<usize>,
}

/// `[output]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write the trajectory every this many seconds (at least every step). Default `0.1`.
    pub trajectory_every: Option<f64>,
    /// Write an SVG snapshot every this many seconds (plus the first and last). Default: a
    /// quarter of the horizon.
    pub snapshot_every: Option<f64>,
    /// Most frames in the HTML animation. Default `400`.
    pub animation_frames: Option<usize>,
    /// Trajectory files to write: `"csv"` (`trajectory.csv`), `"sqlite"` (`trajectory.sqlite`,
    /// JuPedSim's trajectory format, for PedPy). Default `["csv"]`.
    pub formats: Option<Vec<TrajectoryFormat>>,
    /// Write the contact forces (the projection's multipliers over the step): a `pressure`
    /// column in the trajectory, `contacts.csv`, the SQLite tables `pressure` and `contacts`,
    /// and people coloured by pressure in the pictures. Default `false`.
    pub contact_forces: Option<bool>,
}

/// A trajectory file format (`[output] formats`, `sweep run --format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TrajectoryFormat {
    /// `trajectory.csv`: `t,id,x,y`, the people present (see `output::TrajectoryWriter`).
    Csv,
    /// `trajectory.sqlite`: JuPedSim's SQLite trajectory schema, for PedPy and JuPedSim's
    /// viewer.
    Sqlite,
}

impl TrajectoryFormat {
    /// The file name it writes in the output directory.
    pub const fn file_name(self) -> &'static str {
        match self {
            TrajectoryFormat::Csv => "trajectory.csv",
            TrajectoryFormat::Sqlite => "trajectory.sqlite",
        }
    }
}

impl std::str::FromStr for TrajectoryFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "csv" => Ok(TrajectoryFormat::Csv),
            "sqlite" => Ok(TrajectoryFormat::Sqlite),
            other => Err(format!(
                "unknown trajectory format `{other}` (expected csv or sqlite)"
            )),
        }
    }
}

impl std::fmt::Display for TrajectoryFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TrajectoryFormat::Csv => "csv",
            TrajectoryFormat::Sqlite => "sqlite",
        })
    }
}
