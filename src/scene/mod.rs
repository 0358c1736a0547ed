//! Crowd scenes as TOML files: parse, check, build a [`Problem`] with only the effects the
//! scene calls for. [`CrowdBuilder`] builds the same scenes in code: both fill a
//! [`SceneSpec`], which [`Scene::build`] checks and turns into a [`BuiltScene`] step by step.
//!
//! The schema is documented key by key in the guide, `docs/guide/src/scene-format.md`, with an
//! annotated example; in short:
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

mod build;
mod builder;
mod checks;
mod drawn;
mod effect;
mod error;
mod journey;
mod notes;
mod running;
mod set;
mod sources;
pub mod spec;
pub mod synthetic;
mod wkt;

pub use builder::CrowdBuilder;
pub use effect::Effect;
pub use error::{line_column, ResumeError, SceneError};
pub use running::ResumeState;
pub use set::SetOverride;
pub use spec::{SceneSpec, TrajectoryFormat};

use crate::backends::BackendChoice;
use crate::crowd::fast_marching::DistanceField;
use crate::crowd::velocity::ExitSegment;
use crate::crowd::{Motion, Population};
use crate::problem::Problem;
use crate::stepper::StepperSettings;
use std::path::Path;
use std::sync::Arc;
use toml::Spanned;

/// The most people a scene may hold (explicit and placed): beyond it a run would not end in
/// reasonable time on the machines this is made for.
pub const MAX_PEOPLE: usize = 1_000_000;

/// A parsed (not yet checked) scene file.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The parsed file.
    pub spec: SceneSpec,
    /// The scene's name: `name` in the file, else the file's stem.
    pub name: String,
    origin: String,
    /// The TOML text the spec was read from; `None` for a scene built in code (its errors
    /// then name no line).
    text: Option<String>,
    /// Offsets in `text` of the newlines `--set` overrides added: lines the file does not
    /// have, skipped by the line numbers of errors.
    added_newlines: Vec<usize>,
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
    /// Most threads a projection runs on (`0`: as many as the cores).
    pub threads: Option<usize>,
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

/// A checked `[arena]`: the circle people stay inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arena {
    /// Its centre.
    pub center: [f64; 2],
    /// Its radius (m).
    pub radius: f64,
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
    /// The round arena people stay inside, when the scene has one.
    pub arena: Option<Arena>,
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
    pub formats: Vec<TrajectoryFormat>,
    /// Write the contact forces and pressures (`[output] contact_forces`): the run keeps each
    /// step's contacts ([`StepperSettings::record_contacts`]).
    pub contact_forces: bool,
    /// What the user is told before a run, one sentence each: what was adjusted (an interval
    /// below one step clamped to one step, naming the file, line and key), and what is allowed
    /// but rarely meant (nobody moving, people cut off from every exit, a run of very many
    /// steps, a very large trajectory).
    pub notes: Vec<String>,
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
    /// Most threads a projection runs on, `0` meaning as many as the cores (see
    /// [`ProjectorOptions::threads`](crate::backends::ProjectorOptions::threads)).
    pub threads: usize,
    /// Stop as soon as everybody has left.
    pub stop_when_empty: bool,
    /// Outputs.
    pub output: OutputSettings,
    /// The geometry, for drawing.
    pub geometry: SceneGeometry,
    /// The active effects (constraint families, velocity terms, exits).
    pub effects: Vec<Effect>,
    /// The geodesic field to every exit, when some people head for the nearest of all exits
    /// (people given their own `exits` follow fields of their own).
    pub distance_field: Option<Arc<DistanceField>>,
    /// The people who had left at the start: nobody, unless the run was resumed from a
    /// state of an earlier one ([`BuiltScene::resume_at`]).
    pub departed_at_start: Vec<bool>,
    /// The people of a source who had arrived at the start, present or gone: nobody, unless
    /// the run was resumed from a state of an earlier one ([`BuiltScene::resume_at`]). They are
    /// in as the run starts, wherever their neighbours stand; the others come in when due and
    /// their place is free.
    pub arrived_at_start: Vec<bool>,
    /// The waypoint each person of a journey has reached, one record per journey (empty
    /// without journeys); a run starts them all at the first waypoint.
    pub journeys: Vec<Arc<crate::crowd::journey::JourneyProgress>>,
}

/// Where person `i` came from, for error messages.
#[derive(Debug, Clone)]
struct Origin {
    item: String,
    line: Option<usize>,
}

struct Ctx<'a> {
    file: &'a str,
    /// Byte offset of the start of every line: a line is found by binary search, so that
    /// 200 000 `[[people]]` are located in `O(N log N)` (scanning the text for each would be
    /// quadratic).
    /// Empty when there is no text (a scene built in code): nothing has a line.
    line_starts: Vec<usize>,
}

impl Ctx<'_> {
    fn new<'a>(file: &'a str, text: Option<&str>) -> Ctx<'a> {
        let line_starts = match text {
            Some(text) => std::iter::once(0)
                .chain(text.match_indices('\n').map(|(i, _)| i + 1))
                .collect(),
            None => Vec::new(),
        };
        Ctx { file, line_starts }
    }

    /// The same, with the lines that overrides added ending at `added_newlines` not counted.
    fn skipping(mut self, added_newlines: &[usize]) -> Self {
        self.line_starts.retain(|start| {
            start
                .checked_sub(1)
                .is_none_or(|nl| added_newlines.binary_search(&nl).is_err())
        });
        self
    }

    fn line_of<T>(&self, s: &Spanned<T>) -> Option<usize> {
        if self.line_starts.is_empty() {
            return None;
        }
        let offset = s.span().start;
        Some(
            self.line_starts
                .partition_point(|&start| start <= offset)
                .max(1),
        )
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

/// A point for messages, its coordinates rounded to 1e-9 (an exit's end computed as
/// 4.4 + 1.2 printed as 5.6000000000000005).
fn fmt_pt(p: [f64; 2]) -> String {
    use crate::numbers::display_number;
    format!("({}, {})", display_number(p[0]), display_number(p[1]))
}

impl Scene {
    /// Reads and parses a scene file.
    ///
    /// # Errors
    /// [`SceneError::Io`] or [`SceneError::Parse`] (with line and column).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        Self::from_file_with(path, &[])
    }

    /// Reads and parses a scene file with `sets` written into it, each as if the file said
    /// it (see [`SetOverride`]).
    ///
    /// # Errors
    /// As [`Scene::from_file`]; an error in an override is a [`SceneError::Set`] naming it.
    pub fn from_file_with(
        path: impl AsRef<Path>,
        sets: &[SetOverride],
    ) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|reason| SceneError::Io {
            file: file.clone(),
            reason,
        })?;
        let mut scene = Self::from_toml_str_with(&text, &file, sets)?;
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
        Self::from_toml_str_with(text, origin, &[])
    }

    /// Parses a scene from text with `sets` written into it (see [`SetOverride`]).
    ///
    /// # Errors
    /// As [`Scene::from_toml_str`], the lines those of `text`; an error that an override
    /// caused (an unknown key, a wrong type, a path through a value or to a missing list
    /// item) is a [`SceneError::Set`] naming the override.
    pub fn from_toml_str_with(
        text: &str,
        origin: &str,
        sets: &[SetOverride],
    ) -> Result<Scene, SceneError> {
        let edited = set::apply(text, origin, sets)?;
        let spec: SceneSpec = toml::from_str(&edited.text).map_err(|e| {
            let message = e.message().trim().to_string();
            if let Some(i) = e.span().and_then(|s| edited.override_at(&s)) {
                return SceneError::Set {
                    file: origin.to_string(),
                    set: sets[i].to_string(),
                    message,
                };
            }
            let (line, column) = e
                .span()
                .map(|s| edited.file_line_column(s.start))
                .unwrap_or((1, 1));
            SceneError::Parse {
                file: origin.to_string(),
                line,
                column,
                message,
            }
        })?;
        let name = spec.name.clone().unwrap_or_else(|| "scene".to_string());
        Ok(Scene {
            spec,
            name,
            origin: origin.to_string(),
            text: Some(edited.text),
            added_newlines: edited.added_newlines,
        })
    }

    /// Checks that the scene's name can be the output directory `out/<name>/` (as
    /// [`Scene::build`] does first): for `sweep run` to refuse it before creating anything.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] for an empty name, `.`, `..`, or one with `/`, `\`, `:` or a
    /// control character, naming the `name` key's line when the file gives it.
    pub fn check_name(&self) -> Result<(), SceneError> {
        let cx = self.ctx();
        // `name` is a top-level key: before the first table header.
        let line = self
            .spec
            .name
            .as_ref()
            .and(self.text.as_deref())
            .and_then(|text| {
                text.lines()
                    .take_while(|l| !l.trim_start().starts_with('['))
                    .position(|l| {
                        let l = l.trim_start();
                        let rest = l
                            .strip_prefix("name")
                            .or_else(|| l.strip_prefix("\"name\""))
                            .or_else(|| l.strip_prefix("'name'"));
                        rest.is_some_and(|r| r.trim_start().starts_with('='))
                    })
                    .map(|i| i + 1)
            })
            .and_then(|line| self.file_line(line));
        build::check_name(&cx, &self.name, line)
    }

    /// The file's number of line `line` (1-based) of the text, `None` for a line an override
    /// added.
    fn file_line(&self, line: usize) -> Option<usize> {
        let text = self.text.as_deref()?;
        let mut before = 0;
        for &nl in &self.added_newlines {
            match line_column(text, nl).0.cmp(&line) {
                std::cmp::Ordering::Less => before += 1,
                std::cmp::Ordering::Equal => return None,
                std::cmp::Ordering::Greater => break,
            }
        }
        Some(line - before)
    }

    /// The context of the scene's errors: its file, and its lines as the file numbers them.
    fn ctx(&self) -> Ctx<'_> {
        Ctx::new(&self.origin, self.text.as_deref()).skipping(&self.added_newlines)
    }

    /// Where the scene came from (a file name, or what [`Scene::from_toml_str`] was given).
    pub fn origin(&self) -> &str {
        &self.origin
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
            "  h = {:?}, T = {:?}{}, backend {}{}",
            self.settings.h,
            self.settings.t_end,
            if self.stop_when_empty {
                " (stops when everybody has left)"
            } else {
                ""
            },
            self.backend,
            crate::backends::threads_phrase(self.threads)
        );
        s
    }
}
