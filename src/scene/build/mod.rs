//! [`Scene::build`](super::Scene::build) in named steps, in the order their errors are
//! reported: name, run settings, room, exits (which cut the walls), obstacles, people (explicit,
//! then each random crowd, then the sources), desired velocities and the geodesic field,
//! constraint families, outputs, stepper settings. Each step checks its own part of the spec
//! and returns typed values; the only state passed along is what a later step needs.
//!
//! The steps of one concept share a file: the room, exits, arena and obstacles in `geometry`,
//! the people in `people`, the desires and their fields in `desire`; this file holds the
//! entry and the wiring (run settings, families, effects, outputs, stepper settings).

mod desire;
mod geometry;
mod people;

pub(super) use desire::{chosen_exits, ExitFields};
pub(super) use people::{check_gap, check_radii, Clearance, People};

use super::checks::check_desired;
use super::spec::{RunSpec, SceneSpec, TrajectoryFormat};
use super::{
    notes, wkt, BuiltScene, Ctx, Effect, OutputSettings, Overrides, Scene, SceneError,
    SceneGeometry,
};
use crate::backends::BackendChoice;
use crate::crowd::velocity::ExitSegment;
use crate::crowd::{ArenaWall, DiskPairs, Motion, PersonShapes, Population, Shape};
use crate::problem::Problem;
use crate::scene::Arena;
use crate::stepper::StepperSettings;
use geometry::{shapes_of, Placed, RoomPlan, Wall};
use std::path::Path;
use std::sync::Arc;

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
struct RunSettings {
    h: f64,
    t_end: f64,
    backend: BackendChoice,
    threads: usize,
    stop_when_empty: bool,
}

fn run_settings(
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

impl Scene {
    /// Checks the scene and builds the problem: room, walls, exits, obstacles, people (the
    /// random ones placed now), desired velocities, step and horizon.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the item and its line: non-finite numbers, a
    /// non-positive radius or step, an exit not on a wall, a person outside the room or
    /// inside an obstacle, overlapping people, a crowd that does not fit…
    pub fn build(&self, overrides: &Overrides) -> Result<BuiltScene, SceneError> {
        let cx = self.ctx();
        self.check_name()?;
        let base = Path::new(&self.origin).parent();
        let expanded = wkt::expand(&cx, &self.spec, base)?;
        let spec = expanded.as_ref().unwrap_or(&self.spec);
        let run = run_settings(&cx, spec, overrides)?;
        let room = geometry::room(&cx, spec)?;
        let (exits, walls) = geometry::exits_and_walls(&cx, spec, &room)?;
        let obstacles = geometry::obstacles(&cx, spec)?;
        let arena = geometry::arena(&cx, spec, &room)?;
        let has_exits = !exits.is_empty();
        let default_desired = spec
            .desired
            .as_ref()
            .map(|d| (d.get_ref().clone(), cx.line_of(d)));
        if let Some((d, line)) = &default_desired {
            check_desired(&cx, *line, "[desired]", d, (exits.len(), &room.room))?;
        }
        let clear = Clearance {
            room: &room,
            walls: &walls,
            obstacles: &obstacles,
            arena,
            exit_count: exits.len(),
        };
        let mut people = people::everybody(&cx, spec, overrides.seed, &clear)?;

        let (terms, still) =
            desire::desire_terms(&cx, &mut people, default_desired.as_ref().map(|d| &d.0))?;
        let mut population = Population::new(people.radii.clone()).with_room(room.room.clone());
        if people.due.iter().any(Option::is_some) {
            population = population.with_arrivals(people.due.clone());
        }
        let population = population.shared();
        let (fields, target_fields) =
            desire::geodesic_fields(&cx, spec, &terms, &room, &exits, &obstacles)?;
        let routes = desire::routes(&terms, &fields);
        let distance_field = fields
            .iter()
            .find(|(chosen, _)| chosen.is_none())
            .map(|(_, field)| field.clone());
        let mut effects = Vec::new();
        let mut journeys = Vec::new();
        let velocity = desire::desired_velocity(
            &population,
            &people,
            &exits,
            (terms, still),
            (&fields, &target_fields),
            &mut effects,
            &mut journeys,
        );
        let q0: Vec<f64> = people.positions.iter().flatten().copied().collect();
        let mut problem = Problem::new(q0, velocity);
        push_families(
            &mut problem,
            &population,
            &walls,
            &obstacles,
            arena,
            &mut effects,
        );
        push_scene_effects(spec, &people, exits.len(), &mut effects);
        problem
            .validate(1e-9)
            .map_err(|e| cx.err(None, "initial configuration", e.to_string()))?;

        let mut output = output_settings(&cx, spec, run.h, run.t_end)?;
        let facts = notes::SceneFacts {
            positions: &people.positions,
            still,
            routes: &routes,
            has_exits,
            moving_obstacles: obstacles.iter().any(|(o, _, _)| !o.motion.is_static()),
            h: run.h,
            t_end: run.t_end,
        };
        let scene_notes = notes::scene_notes(&facts, &output);
        output.notes.extend(scene_notes);
        let settings = stepper_settings(run.h, run.t_end, &obstacles);
        let geometry = scene_geometry(
            room,
            walls,
            exits,
            obstacles,
            arena,
            population.max_radius(),
        );
        let departed_at_start = vec![false; population.len()];
        let arrived_at_start = vec![false; population.len()];
        Ok(BuiltScene {
            name: self.name.clone(),
            problem,
            population,
            speeds: people.speeds,
            group_of: people.group_of,
            groups: people.groups,
            settings,
            backend: run.backend,
            threads: run.threads,
            stop_when_empty: run.stop_when_empty,
            output,
            geometry,
            effects,
            distance_field,
            departed_at_start,
            arrived_at_start,
            journeys,
        })
    }
}

/// The constraint families the scene calls for, and no other: pairs only with two people or
/// more, walls only with walls, obstacles only with obstacles.
fn push_families(
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

/// The effects of the scene as a whole, after the constraint families: its exits, its sources
/// and the gaps its groups keep.
fn push_scene_effects(
    spec: &SceneSpec,
    people: &People,
    exit_count: usize,
    effects: &mut Vec<Effect>,
) {
    if exit_count > 0 {
        effects.push(Effect::Exits { count: exit_count });
    }
    if !spec.sources.is_empty() {
        effects.push(Effect::Sources {
            sources: spec.sources.len(),
            people: people.due.iter().flatten().count(),
        });
    }
    if let Some(largest) = people
        .gaps
        .iter()
        .copied()
        .reduce(f64::max)
        .filter(|&g| g > 0.0)
    {
        effects.push(Effect::Gaps {
            people: people.gaps.iter().filter(|&&g| g > 0.0).count(),
            largest,
        });
    }
}

/// What there is to draw, within the room's bounding box grown by a margin for people
/// walking out (`max_radius`: the largest person's).
fn scene_geometry(
    room: RoomPlan,
    walls: Vec<Wall>,
    exits: Vec<ExitSegment>,
    obstacles: Vec<Placed>,
    arena: Option<Arena>,
    max_radius: f64,
) -> SceneGeometry {
    let (bx0, by0, bx1, by1) = room.bbox;
    let margin = 2.0 * max_radius + 0.05 * room.scale;
    SceneGeometry {
        room: room.vertices,
        walls,
        exits,
        obstacles: obstacles.into_iter().map(|(o, _, _)| o).collect(),
        arena,
        bounds: [bx0 - margin, by0 - margin, bx1 + margin, by1 + margin],
    }
}

/// `[output]`, checked; intervals below one step are clamped to one step, with a note.
fn output_settings(
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
fn stepper_settings(h: f64, t_end: f64, obstacles: &[Placed]) -> StepperSettings {
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
