//! A scene run with the standard outputs: the trajectory, the summary, the snapshots, the
//! animation and, for a cross-checking backend, its closest calls, all in one output
//! directory. This is what `sweep run` does once it has read its arguments.

use super::{
    csv_interval_note, prepare_output_dir, steps_between, AnimationWriter, ContactKinds, Departure,
    OutputError, PeopleWriter, ResumedFrom, RunSummary, SnapshotWriter, SummaryCollector,
    TrajectoryFormat, TrajectoryWriter, CONTACTS_FILE, PEOPLE_FILE,
};
use crate::backends::{make_projector_with, BackendError, ProjectorOptions};
use crate::scene::BuiltScene;
use crate::stepper::{Observer, Run, RunFailure};
use std::path::{Path, PathBuf};
use sweeping_api::{CrossCheckDisagreement, CrossCheckStats};

/// Where a cross-checked run that stopped on a disagreement keeps the problem and both answers.
pub const DISAGREEMENT_FILE: &str = "disagreement.json";

/// Where a cross-checked run keeps the problem of the largest gap between its backends that
/// passed, and both answers.
pub const LARGEST_GAP_FILE: &str = "largest-gap.json";

/// What [`run_scene`] writes and where; plain values with documented defaults.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunOptions {
    /// The output directory, created when missing; files of the same names are replaced.
    /// Default `None`: `out/<scene name>`.
    pub out: Option<PathBuf>,
    /// The trajectory formats. Default empty: the scene's `[output] formats`.
    pub formats: Vec<TrajectoryFormat>,
    /// The earlier run this one goes on from, recorded in the summary (the scene itself is
    /// set to its state by [`BuiltScene::resume_at`]). Default `None`.
    pub resumed_from: Option<ResumedFrom>,
    /// For a resumed run, when and where each person the earlier run saw leave had left (its
    /// `people.csv`), so that this run's people table keeps them. Default empty.
    pub departures_before: Vec<Option<Departure>>,
}

impl RunOptions {
    /// The output directory of a run of `scene`: [`out`](Self::out), else `out/<scene name>`.
    pub fn out_dir(&self, scene: &BuiltScene) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| PathBuf::from("out").join(&scene.name))
    }

    /// The trajectory formats of a run of `scene`: [`formats`](Self::formats), else the
    /// scene's, each once, in the order first named.
    pub fn trajectory_formats(&self, scene: &BuiltScene) -> Vec<TrajectoryFormat> {
        let mut formats = if self.formats.is_empty() {
            scene.output.formats.clone()
        } else {
            self.formats.clone()
        };
        let mut seen = std::collections::HashSet::new();
        formats.retain(|f| seen.insert(*f));
        formats
    }
}

/// What the caller of [`run_scene`] hears of the run besides its result: the notes as they
/// come, the moment the first step is next, and observers of its own. Every method defaults
/// to doing nothing; `()` hears nothing.
pub trait RunHooks {
    /// A note for the user, as soon as it is known (an interval rounded to whole steps, a
    /// walkable area drawn simpler than the room).
    fn note(&mut self, note: &str) {
        let _ = note;
    }

    /// Everything is set up (the writers and the backend): the first step is next.
    fn before_first_step(&mut self) {}

    /// Observers called at every step after the standard outputs, in this order: a progress
    /// display, then (last, so that every other observer has seen the step it stops after)
    /// one that stops the run on an interrupt. Asked once, after
    /// [`before_first_step`](Self::before_first_step).
    fn observers(&mut self) -> Vec<&mut dyn Observer> {
        Vec::new()
    }
}

impl RunHooks for () {}

/// Why [`run_scene`] could not start a run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunSceneError {
    /// The output directory cannot be created or written.
    #[error(transparent)]
    OutputDir(OutputError),
    /// The SQLite trajectory cannot be written: this build lacks it, or its walkable area or
    /// its file could not be made.
    #[error(transparent)]
    SqliteTrajectory(OutputError),
    /// The backend could not be built; `summary.json` records the run as failed with this
    /// message.
    #[error(transparent)]
    Backend(BackendError),
}

/// What [`run_scene`] did.
#[derive(Debug)]
pub struct SceneRun {
    /// The summary, as written to `summary.json`.
    pub summary: RunSummary,
    /// What the stepper computed, or its failure with everything computed before it.
    pub result: Result<Run, Box<RunFailure>>,
    /// The problem on which a cross-check stopped the run, with both answers
    /// ([`DISAGREEMENT_FILE`]), when one was written.
    pub disagreement: Option<PathBuf>,
    /// The largest gap a cross-check passed, with its problem and both answers
    /// ([`LARGEST_GAP_FILE`]), when one was written.
    pub largest_gap: Option<PathBuf>,
    /// The files that could not be written after the run, in the order tried: each is tried
    /// whatever failed before it.
    pub write_errors: Vec<OutputError>,
}

/// The SQLite writer, or, in a build without it, the type of an observer never built.
#[cfg(feature = "sqlite")]
type SqliteWriter = super::SqliteTrajectoryWriter;
#[cfg(not(feature = "sqlite"))]
type SqliteWriter = ();

/// Runs `scene` with the standard outputs in [`RunOptions::out_dir`]: the trajectory in each
/// of the formats asked for, [`PEOPLE_FILE`], [`CONTACTS_FILE`] with the contact forces
/// (`[output] contact_forces`), `summary.json`, `snapshots/` and `animation.html`, and for a
/// cross-checking backend [`DISAGREEMENT_FILE`] and [`LARGEST_GAP_FILE`]. A failed run still
/// writes what it computed (its status is in the summary); files it left empty are removed.
///
/// # Errors
/// A [`RunSceneError`] when the run could not start; a run that started and failed is a
/// [`SceneRun`] whose `result` is the failure.
pub fn run_scene(
    scene: &BuiltScene,
    options: &RunOptions,
    hooks: &mut dyn RunHooks,
) -> Result<SceneRun, RunSceneError> {
    let out = options.out_dir(scene);
    prepare_output_dir(&out).map_err(RunSceneError::OutputDir)?;
    let formats = options.trajectory_formats(scene);
    let (h, t_end) = (scene.settings.h, scene.settings.t_end);
    for note in &scene.output.notes {
        hooks.note(note);
    }
    if formats.contains(&TrajectoryFormat::Csv) {
        if let Some(note) = csv_interval_note(scene.output.trajectory_every, h) {
            hooks.note(&note);
        }
    }
    // The trajectory writers, created before the run so that their errors come first (the
    // SQLite file gets its schema and walkable area now).
    let forces = scene.output.contact_forces;
    let mut csv = formats.contains(&TrajectoryFormat::Csv).then(|| {
        let writer = TrajectoryWriter::new(
            out.join(TrajectoryFormat::Csv.file_name()),
            scene.population.clone(),
            steps_between(scene.output.trajectory_every, h),
        );
        if forces {
            writer.with_contact_forces(out.join(CONTACTS_FILE), ContactKinds::of(&scene.problem))
        } else {
            writer
        }
    });
    let mut people = PeopleWriter::new(out.join(PEOPLE_FILE), scene.population.clone())
        .with_departures_before(&options.departures_before);
    let mut sqlite = if formats.contains(&TrajectoryFormat::Sqlite) {
        Some(
            sqlite_writer(scene, &out, &options.departures_before, hooks)
                .map_err(RunSceneError::SqliteTrajectory)?,
        )
    } else {
        None
    };
    let mut summary = SummaryCollector::new(
        &scene.name,
        &scene.problem,
        scene.population.clone(),
        &scene.backend.to_string(),
        h,
        t_end,
    );
    summary.summary.resumed_from = options.resumed_from.clone();
    let summary_path = out.join("summary.json");
    let projector_options = ProjectorOptions {
        threads: scene.threads,
        ..ProjectorOptions::default()
    };
    let mut projector = match make_projector_with(scene.backend, projector_options) {
        Ok(p) => p,
        Err(e) => {
            summary.mark_failed(&e.to_string());
            let _ = summary.write_json(&summary_path);
            return Err(RunSceneError::Backend(e));
        }
    };
    let mut snapshots = SnapshotWriter::new(
        out.join("snapshots"),
        scene.geometry.clone(),
        scene.population.clone(),
        scene.group_of.clone(),
        &scene.name,
        scene.output.snapshot_every,
    )
    .with_pressure(forces);
    // A resumed run covers [t₀, T]: its frames are spread over that span.
    let mut animation = AnimationWriter::new(
        out.join("animation.html"),
        scene.geometry.clone(),
        scene.population.clone(),
        scene.group_of.clone(),
        &scene.name,
        t_end - scene.problem.t0(),
        h,
        scene.output.animation_frames,
    )
    .with_pressure(forces);
    hooks.before_first_step();
    let mut observers: Vec<&mut dyn Observer> = Vec::new();
    if let Some(w) = csv.as_mut() {
        observers.push(w);
    }
    if let Some(w) = sqlite.as_mut() {
        observers.push(w);
    }
    observers.extend([
        &mut people as &mut dyn Observer,
        &mut summary,
        &mut snapshots,
        &mut animation,
    ]);
    observers.extend(hooks.observers());
    let result = scene.run(projector.as_mut(), &mut observers);
    drop(observers);
    summary.record_cross_check(projector.cross_check());
    let (disagreement, largest_gap, write_errors) =
        write_after_run(&out, &summary, projector.cross_check(), &summary_path);
    if result.is_err() || !write_errors.is_empty() {
        remove_empty_outputs(&out);
    }
    Ok(SceneRun {
        summary: summary.summary().clone(),
        result,
        disagreement,
        largest_gap,
        write_errors,
    })
}

/// The files written once the run has ended: the cross-check's disagreement and largest gap,
/// then the summary. Every file is tried whatever failed before it, and the failures are kept
/// in order: on a full disk the first says the most.
fn write_after_run(
    out: &Path,
    summary: &SummaryCollector<'_>,
    cross_check: Option<&CrossCheckStats>,
    summary_path: &Path,
) -> (Option<PathBuf>, Option<PathBuf>, Vec<OutputError>) {
    let mut errors = Vec::new();
    let disagreement = write_disagreement(out, cross_check).unwrap_or_else(|e| {
        errors.push(e);
        None
    });
    let largest_gap = write_largest_gap(out, cross_check).unwrap_or_else(|e| {
        errors.push(e);
        None
    });
    if let Err(e) = summary.write_json(summary_path) {
        errors.push(OutputError::WriteFailed {
            operation: "writing",
            path: summary_path.to_path_buf(),
            message: e.to_string(),
        });
    }
    (disagreement, largest_gap, errors)
}

/// Writes the problem on which a cross-checked run's backends disagreed, with both answers
/// (a [`CrossCheckDisagreement`]), to `out/disagreement.json`, so that the step can be
/// decided afterwards (against a projection computed independently) without running again to
/// it. Returns the path written, if any.
fn write_disagreement(
    out: &Path,
    stats: Option<&CrossCheckStats>,
) -> Result<Option<PathBuf>, OutputError> {
    write_case(
        out,
        DISAGREEMENT_FILE,
        stats.and_then(|s| s.disagreement.as_deref()),
    )
}

/// Writes the problem of the largest gap that passed, with both answers
/// ([`CrossCheckStats::largest_passed_gap`]), to `out/largest-gap.json`: a run's closest
/// call, decided the same way as a disagreement. Returns the path written, if any.
fn write_largest_gap(
    out: &Path,
    stats: Option<&CrossCheckStats>,
) -> Result<Option<PathBuf>, OutputError> {
    write_case(
        out,
        LARGEST_GAP_FILE,
        stats.and_then(|s| s.largest_passed_gap.as_deref()),
    )
}

fn write_case(
    out: &Path,
    name: &str,
    case: Option<&CrossCheckDisagreement>,
) -> Result<Option<PathBuf>, OutputError> {
    let Some(case) = case else {
        return Ok(None);
    };
    let path = out.join(name);
    let failed = |operation, message: String| OutputError::WriteFailed {
        operation,
        path: path.clone(),
        message,
    };
    let file = std::fs::File::create(&path).map_err(|e| failed("creating", e.to_string()))?;
    serde_json::to_writer(std::io::BufWriter::new(file), case)
        .map_err(|e| failed("writing", e.to_string()))?;
    Ok(Some(path))
}

/// Removes the files of `out` left empty by a run that failed (a full disk): an empty
/// trajectory, summary or picture would pass for a result.
fn remove_empty_outputs(out: &Path) {
    let mut paths: Vec<PathBuf> = [
        TrajectoryFormat::Csv.file_name(),
        TrajectoryFormat::Sqlite.file_name(),
        PEOPLE_FILE,
        CONTACTS_FILE,
        "summary.json",
        "animation.html",
        DISAGREEMENT_FILE,
        LARGEST_GAP_FILE,
    ]
    .iter()
    .map(|name| out.join(name))
    .collect();
    if let Ok(entries) = std::fs::read_dir(out.join("snapshots")) {
        paths.extend(entries.flatten().map(|entry| entry.path()));
    }
    for path in paths {
        // `symlink_metadata`: a link is the user's doing, and not an empty file.
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file() && m.len() == 0) {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// The SQLite trajectory writer of `scene` in `out`, its walkable area's notes told first.
#[cfg(feature = "sqlite")]
fn sqlite_writer(
    scene: &BuiltScene,
    out: &Path,
    departures_before: &[Option<Departure>],
    hooks: &mut dyn RunHooks,
) -> Result<SqliteWriter, OutputError> {
    let walkable = super::WalkableArea::of_scene(&scene.geometry, &scene.population)?;
    for note in &walkable.notes {
        hooks.note(&format!("trajectory.sqlite: {note}"));
    }
    let writer = super::SqliteTrajectoryWriter::for_scene(
        out.join(TrajectoryFormat::Sqlite.file_name()),
        &walkable,
        scene,
    )?
    .with_departures_before(departures_before)?;
    if scene.output.contact_forces {
        writer.with_contact_forces(ContactKinds::of(&scene.problem))
    } else {
        Ok(writer)
    }
}

/// Without the `sqlite` feature there is no SQLite writer: asking for one is an error before
/// the run.
#[cfg(not(feature = "sqlite"))]
fn sqlite_writer(
    _: &BuiltScene,
    _: &Path,
    _: &[Option<Departure>],
    _: &mut dyn RunHooks,
) -> Result<SqliteWriter, OutputError> {
    Err(OutputError::Unavailable("sqlite"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::conformance::ReferenceProjector;
    use sweeping_api::{CrossCheck, ProjectionProblem, Projector, SparseRows};

    #[test]
    fn a_disagreement_is_written_with_its_problem_and_both_answers_and_nothing_else_is() {
        let dir = std::env::temp_dir().join(format!("sweep-disagreement-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Two backends that agree: nothing written.
        let mut agree = CrossCheck::new(
            ReferenceProjector::default(),
            ReferenceProjector::default(),
            1e-9,
        );
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 1.0)]]);
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0]).unwrap();
        agree.project(&p).unwrap();
        assert_eq!(write_disagreement(&dir, agree.cross_check()).unwrap(), None);
        assert_eq!(write_disagreement(&dir, None).unwrap(), None);
        assert!(!dir.join(DISAGREEMENT_FILE).exists());
        // A cross-check at a tolerance of −1 disagrees with itself on every problem.
        let mut apart = CrossCheck::new(
            ReferenceProjector::default(),
            ReferenceProjector::default(),
            -1.0,
        );
        assert!(apart.project(&p).is_err());
        let path = write_disagreement(&dir, apart.cross_check())
            .unwrap()
            .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let back: CrossCheckDisagreement = serde_json::from_str(&text).unwrap();
        assert_eq!(back.problem, p);
        assert!((back.first.x[0] - 0.5).abs() < 1e-9 && (back.second.x[1] - 0.5).abs() < 1e-9);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
