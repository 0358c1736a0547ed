//! What a crowd run leaves behind: the trajectory (CSV, or JuPedSim's SQLite trajectory file
//! for PedPy), a JSON summary, SVG snapshots and a self-contained HTML animation. Each is an
//! [`Observer`], so a run writes them as it goes and a failed run still leaves what it
//! computed.
//!
//! * [`TrajectoryWriter`] — `t,id,x,y` (and `pressure` with contact forces) for the people present, buffered, flushed at the end even on failure;
//! * `SqliteTrajectoryWriter` (cargo feature `sqlite`, on by default) — JuPedSim's trajectory
//!   schema with the [`WalkableArea`] as WKT, streamed in transactions;
//! * [`SummaryCollector`] — evacuation time, people out over time, steps, time per stage,
//!   solver iterations, largest overlap and wall penetration, status; [`RunSummary`] is the
//!   JSON;
//! * [`SnapshotWriter`] — SVG pictures every `snapshot_every` seconds and at the end;
//! * [`AnimationWriter`] — one HTML page with inline SVG and a few lines of JavaScript
//!   (play/pause, time slider, speed).
//!
//! [`run_scene`] runs a scene with all of them in one output directory, as `sweep run` does.

mod contacts;
mod html;
mod people;
mod run;
#[cfg(feature = "sqlite")]
mod sqlite;
mod svg;
mod walkable;

pub use contacts::{pressures, ContactForce, ContactKinds, ContactWith};
pub use html::AnimationWriter;
pub use people::{Departure, PeopleWriter, PEOPLE_FILE};
pub use run::{
    run_scene, RunHooks, RunOptions, RunSceneError, SceneRun, DISAGREEMENT_FILE, LARGEST_GAP_FILE,
};
#[cfg(feature = "sqlite")]
pub use sqlite::{SqliteTrajectoryWriter, DEFAULT_FRAMES_PER_COMMIT, JUPEDSIM_DATABASE_VERSION};
pub use svg::{render_svg, SnapshotWriter};
pub use walkable::WalkableArea;

use crate::constraint::{ConstraintId, FamilyKind};
use crate::crowd::Population;
use crate::error::SweepError;
use crate::problem::{LinearizeScratch, Problem};
use crate::stepper::{Observer, ObserverError, RunStats, StageTimes, StepReport};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why an output could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// A file or directory could not be created or written.
    #[error("{}: {message}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// The SQLite library refused an operation.
    #[error("{}: SQLite: {message}", path.display())]
    Sqlite {
        /// The database file.
        path: PathBuf,
        /// SQLite's message.
        message: String,
    },
    /// Frames at a fixed rate need `trajectory_every` to be a whole number of steps.
    #[error("[output] trajectory_every = {trajectory_every} is not a whole number of steps h = {h}: the SQLite trajectory's frames must be evenly spaced at the rate asked for")]
    FrameInterval {
        /// Seconds asked for between frames.
        trajectory_every: f64,
        /// The time step.
        h: f64,
    },
    /// The scene's walkable area cannot be written as one polygon with holes.
    #[error("walkable area: {0}")]
    WalkableArea(String),
    /// A file of the run's results could not be created or written.
    #[error("{operation} {}: {message}", path.display())]
    WriteFailed {
        /// What was being done: `creating` or `writing`.
        operation: &'static str,
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// The format was left out of this build.
    #[error("the `{0}` trajectory format needs the cargo feature `{0}`, which this build lacks")]
    Unavailable(&'static str),
}

pub use crate::scene::TrajectoryFormat;

/// Creates the output directory if needed and checks that files can be written in it, so that
/// a run does not compute for minutes and then fail to write its results.
///
/// # Errors
/// [`OutputError::Io`] naming the directory and what failed.
pub fn prepare_output_dir(dir: &Path) -> Result<(), OutputError> {
    let io = |what: &str, e: std::io::Error| OutputError::Io {
        path: dir.to_path_buf(),
        message: format!("{what}: {e}"),
    };
    std::fs::create_dir_all(dir).map_err(|e| io("cannot create the output directory", e))?;
    let probe = dir.join(format!(".sweep-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(|e| io("cannot write in the output directory", e))?;
    std::fs::remove_file(&probe).map_err(|e| io("cannot remove a file in the output directory", e))
}

/// Writes `contents` to `path`, removing the file when the writing fails: cut short by a full
/// disk, it would pass for a result.
pub(crate) fn write_whole(path: &Path, contents: impl AsRef<[u8]>) -> std::io::Result<()> {
    let mut file = std::fs::File::create(path)?;
    file.write_all(contents.as_ref()).inspect_err(|_| {
        let _ = std::fs::remove_file(path);
    })
}

/// Writes `t,id,x,y` rows every `every` steps (and the first and last states) to a CSV file,
/// one for each person **present** (their disk not wholly outside the room): who has left is
/// written no more, as in JuPedSim's trajectories. With
/// [`with_contact_forces`](Self::with_contact_forces), each row has the person's `pressure`
/// too, and each contact of the frame's step goes to a second file, `t,a,b,kind,force`.
pub struct TrajectoryWriter {
    path: PathBuf,
    out: Option<std::io::BufWriter<std::fs::File>>,
    population: Arc<Population>,
    every: usize,
    last: Option<(Vec<f64>, StepReport)>,
    last_written_step: usize,
    forces: Option<ForceFiles>,
}

/// The contact forces' part of the CSV trajectory: the contacts file and what each family is.
struct ForceFiles {
    path: PathBuf,
    out: Option<std::io::BufWriter<std::fs::File>>,
    kinds: ContactKinds,
    pressure: Vec<f64>,
}

/// Where [`TrajectoryWriter::with_contact_forces`] writes the contacts, in the output directory.
pub const CONTACTS_FILE: &str = "contacts.csv";

impl TrajectoryWriter {
    /// A writer to `path` (created or truncated at the start of the run), keeping every
    /// `every`-th step (`every ≥ 1`).
    pub fn new(path: impl Into<PathBuf>, population: Arc<Population>, every: usize) -> Self {
        Self {
            path: path.into(),
            out: None,
            population,
            every: every.max(1),
            last: None,
            last_written_step: 0,
            forces: None,
        }
    }

    /// Writes the contact forces too: a `pressure` column (empty at the first frame, before
    /// any step) and the file `contacts` (`t,a,b,kind,force`, each contact of each frame's
    /// step; `b` empty for a wall or obstacle), `kinds` saying what each family keeps apart.
    /// The run must keep its contacts
    /// ([`StepperSettings::record_contacts`](crate::stepper::StepperSettings::record_contacts)).
    #[must_use]
    pub fn with_contact_forces(
        mut self,
        contacts: impl Into<PathBuf>,
        kinds: ContactKinds,
    ) -> Self {
        self.forces = Some(ForceFiles {
            path: contacts.into(),
            out: None,
            kinds,
            pressure: Vec::new(),
        });
        self
    }

    /// Where it writes.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The header: `t,id,x,y`, and `pressure` with the contact forces.
    fn header(&self) -> &'static str {
        if self.forces.is_some() {
            "t,id,x,y,pressure"
        } else {
            "t,id,x,y"
        }
    }

    fn write_state(
        &mut self,
        t: f64,
        q: &[f64],
        report: Option<&StepReport>,
    ) -> Result<(), String> {
        let pop = self.population.clone();
        let Some(out) = self.out.as_mut() else {
            return Ok(());
        };
        // `t` formatted once for all of its rows: formatting floats is most of the time spent
        // writing, and a third of the floats are this one.
        let t_text = t.to_string();
        let io = |path: &Path, e: std::io::Error| format!("{}: {e}", path.display());
        let forces = self.forces.as_mut();
        match forces {
            None => {
                for i in (0..pop.len()).filter(|&i| pop.is_present(q, i)) {
                    writeln!(out, "{t_text},{i},{},{}", q[2 * i], q[2 * i + 1])
                        .map_err(|e| io(&self.path, e))?;
                }
            }
            Some(f) => {
                match report {
                    Some(r) => contacts::pressures(r, pop.len(), &mut f.pressure),
                    None => f.pressure.clear(),
                }
                for i in (0..pop.len()).filter(|&i| pop.is_present(q, i)) {
                    let p = contacts::optional_field(f.pressure.get(i).copied());
                    writeln!(out, "{t_text},{i},{},{},{p}", q[2 * i], q[2 * i + 1])
                        .map_err(|e| io(&self.path, e))?;
                }
                if let (Some(cout), Some(r)) = (f.out.as_mut(), report) {
                    for c in f.kinds.forces(r) {
                        let b = c.b.map(|b| b.to_string()).unwrap_or_default();
                        writeln!(cout, "{t_text},{},{b},{},{}", c.a, c.with.as_str(), c.force)
                            .map_err(|e| io(&f.path, e))?;
                    }
                }
            }
        }
        Ok(())
    }
}

impl Observer for TrajectoryWriter {
    fn name(&self) -> &str {
        "trajectory writer"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        let create = |path: &Path, header: &str| -> Result<_, String> {
            let file =
                std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut out = std::io::BufWriter::new(file);
            writeln!(out, "{header}").map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(out)
        };
        self.out = Some(create(&self.path, self.header())?);
        if let Some(f) = self.forces.as_mut() {
            f.out = Some(create(&f.path, "t,a,b,kind,force")?);
        }
        Ok(self.write_state(t, q, None)?)
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let k = report.step + 1;
        if k.is_multiple_of(self.every) {
            self.write_state(report.t, q, Some(report))?;
            self.last_written_step = k;
            self.last = None;
        } else {
            // The report is kept for its contacts; without them, its time alone.
            let mut kept = report.clone();
            if self.forces.is_none() {
                kept.contacts = Vec::new();
            }
            self.last = Some((q.to_vec(), kept));
        }
        Ok(())
    }

    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), ObserverError> {
        if let Some((q, report)) = self.last.take() {
            self.write_state(report.t, &q, Some(&report))?;
        }
        if let Some(out) = self.out.as_mut() {
            out.flush()
                .map_err(|e| format!("{}: {e}", self.path.display()))?;
        }
        if let Some(f) = self.forces.as_mut() {
            if let Some(out) = f.out.as_mut() {
                out.flush()
                    .map_err(|e| format!("{}: {e}", f.path.display()))?;
            }
        }
        Ok(())
    }
}

/// Wall-clock milliseconds per step, by stage (averages over the steps done).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MsPerStep {
    /// The prediction `y = q + h f`.
    pub effects: f64,
    /// Candidate selection.
    pub broad_phase: f64,
    /// Linearization and assembly.
    pub assembly: f64,
    /// The QP.
    pub projection: f64,
    /// Culling proof and constraint check.
    pub check: f64,
    /// All stages.
    pub total: f64,
}

/// Where a run stands, written to `summary.json` as `"running"`, `"completed"`,
/// `"everybody left"`, `"interrupted"` or `"failed"`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum RunStatus {
    /// Not finished yet.
    #[default]
    #[serde(rename = "running")]
    Running,
    /// Reached `T` (or stopped with people still in the room).
    #[serde(rename = "completed")]
    Completed,
    /// Stopped early: everybody has left.
    #[serde(rename = "everybody left")]
    EverybodyLeft,
    /// Stopped by the user ([`SweepError::Interrupted`], Ctrl-C, SIGTERM or SIGHUP in `sweep run`); what was
    /// computed up to then is right, and can be resumed from.
    #[serde(rename = "interrupted")]
    Interrupted,
    /// Stopped by an error (see [`RunSummary::error`]).
    #[serde(rename = "failed")]
    Failed,
}

impl std::fmt::Display for RunStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Running => "running",
            Self::Completed => "completed",
            Self::EverybodyLeft => "everybody left",
            Self::Interrupted => "interrupted",
            Self::Failed => "failed",
        })
    }
}

/// The JSON summary of a run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Scene name.
    pub scene: String,
    /// Where the run stands.
    pub status: RunStatus,
    /// The error, when the run failed.
    pub error: Option<String>,
    /// Backend.
    pub backend: String,
    /// People.
    pub people: usize,
    /// Time step.
    pub h: f64,
    /// Horizon asked for.
    pub t_end: f64,
    /// Last time reached.
    pub t_final: f64,
    /// Steps done.
    pub steps: usize,
    /// The first time at which nobody was left in the room (`None` if some remain).
    pub evacuation_time: Option<f64>,
    /// `(t, number of people out)` at `t = 0` and each time the number changed.
    pub people_out: Vec<(f64, usize)>,
    /// People still in the room at the end.
    pub people_remaining: usize,
    /// Seconds per stage, summed over the run.
    pub seconds_per_stage: StageTimes,
    /// Milliseconds per step, by stage.
    pub ms_per_step: MsPerStep,
    /// Solver iterations, summed.
    pub solver_iterations: u64,
    /// How the backend reached its answers (fallbacks, escalations to its second method,
    /// answers short of its accuracy target and their largest estimated error), summed; written
    /// as four fields of the summary.
    #[serde(flatten)]
    pub counters: crate::api::BackendCounters,
    /// The process's peak resident memory at the end of the run, in MiB (`None` where the
    /// platform does not report it).
    #[serde(default)]
    pub peak_memory_mib: Option<f64>,
    /// QP solves (more than steps when a culling proof needed a re-solve).
    pub solves: u64,
    /// Most rows in one QP.
    pub max_rows: usize,
    /// Most active rows in one QP.
    pub max_active: usize,
    /// Largest overlap of two people after any step: `max(0, −min D_ij)`.
    pub max_overlap: f64,
    /// Where and when it happened.
    pub max_overlap_at: String,
    /// Largest penetration of a person into a wall or obstacle after any step.
    pub max_wall_penetration: f64,
    /// Where and when it happened.
    pub max_wall_penetration_at: String,
    /// With a cross-checking backend (`cross`, `cross-native`): how many projections the two
    /// backends made, the largest and summed gaps between their answers (∞-norm; a failed
    /// run's last gap included) and the seconds each spent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cross_check: Option<sweeping_api::CrossCheckStats>,
    /// The run this one resumed (`sweep run --resume`), `None` for a run from the scene's
    /// start. Everything above counts this run's steps alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resumed_from: Option<ResumedFrom>,
    /// With people arriving during the run (a scene's `[[sources]]`): how many were due,
    /// arrived, and waited because their place was taken, and how long. `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arrivals: Option<crate::crowd::ArrivalReport>,
}

/// Where a resumed run started: the earlier run's output directory and the time of the state
/// (the last frame of its trajectory) it went on from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResumedFrom {
    /// The earlier run's output directory, as given.
    pub run: String,
    /// The time of the state.
    pub t: f64,
}

/// Collects a [`RunSummary`] as the run goes.
pub struct SummaryCollector<'a> {
    problem: &'a Problem,
    population: Arc<Population>,
    summary: RunSummary,
    stats: RunStats,
    scratch: LinearizeScratch,
    last_out: usize,
}

impl<'a> SummaryCollector<'a> {
    /// A collector for a run of `problem` (whose people are `population`).
    pub fn new(
        scene: &str,
        problem: &'a Problem,
        population: Arc<Population>,
        backend: &str,
        h: f64,
        t_end: f64,
    ) -> Self {
        Self {
            problem,
            summary: RunSummary {
                scene: scene.to_string(),
                backend: backend.to_string(),
                people: population.len(),
                h,
                t_end,
                ..Default::default()
            },
            population,
            stats: RunStats::default(),
            scratch: LinearizeScratch::default(),
            last_out: 0,
        }
    }

    /// The summary so far.
    pub fn summary(&self) -> &RunSummary {
        &self.summary
    }

    /// Records what a cross-checking backend saw over the run (`None` for other backends).
    pub fn record_cross_check(&mut self, stats: Option<&sweeping_api::CrossCheckStats>) {
        self.summary.cross_check = stats.cloned();
    }

    /// Records that the run resumed the one in `run` from its state at `t`.
    pub fn record_resumed_from(&mut self, run: &Path, t: f64) {
        self.summary.resumed_from = Some(ResumedFrom {
            run: run.display().to_string(),
            t,
        });
    }

    /// Marks the summary as failed with `message` (for errors the stepper never saw, such as
    /// a backend that could not be built).
    pub fn mark_failed(&mut self, message: &str) {
        self.summary.status = RunStatus::Failed;
        self.summary.error = Some(message.to_string());
    }

    /// Writes the summary as pretty JSON.
    ///
    /// # Errors
    /// The file could not be written.
    pub fn write_json(&self, path: &Path) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(&self.summary).map_err(std::io::Error::other)?;
        write_whole(path, text + "\n")
    }

    /// The most negative value of the constraints of each kind at `(t, q)`, and the
    /// constraint that has it: pairs of people, and walls or obstacles. Described only by the
    /// caller, when it is a new worst: a description formatted at every step would almost
    /// always be thrown away.
    fn violations(&mut self, t: f64, q: &[f64]) -> [(f64, Option<ConstraintId>); 2] {
        let mut worst: [(f64, Option<ConstraintId>); 2] = [(0.0, None), (0.0, None)];
        let _ = self.problem.for_each_linearized(
            t,
            q,
            |_| Some(0.0),
            false,
            &mut self.scratch,
            |fam, id, row| {
                let slot = usize::from(fam.kind() != FamilyKind::Pairs);
                if -row.value > worst[slot].0 {
                    worst[slot] = (-row.value, Some(id));
                }
                Ok::<(), std::convert::Infallible>(())
            },
        );
        worst
    }

    /// What `id` is, or nothing when no constraint was violated.
    fn describe(&self, id: Option<ConstraintId>) -> String {
        id.map(|id| self.problem.describe(id)).unwrap_or_default()
    }

    fn record(&mut self, t: f64, q: &[f64]) {
        let present = self.population.present_count(q);
        // Who has not arrived yet is neither in the room nor out.
        let pending = self.population.pending_count();
        let out = self.population.len() - present - pending;
        if out != self.last_out || self.summary.people_out.is_empty() {
            self.summary.people_out.push((t, out));
            self.last_out = out;
        }
        self.summary.people_remaining = present;
        if present == 0 && pending == 0 && self.summary.evacuation_time.is_none() {
            self.summary.evacuation_time = Some(t);
        }
        let [(ov, ow), (pv, pw)] = self.violations(t, q);
        if ov > self.summary.max_overlap {
            self.summary.max_overlap = ov;
            self.summary.max_overlap_at = format!(
                "{} at t = {}",
                self.describe(ow),
                crate::numbers::display_number(t)
            );
        }
        if pv > self.summary.max_wall_penetration {
            self.summary.max_wall_penetration = pv;
            self.summary.max_wall_penetration_at = format!(
                "{} at t = {}",
                self.describe(pw),
                crate::numbers::display_number(t)
            );
        }
        self.summary.t_final = t;
    }
}

impl Observer for SummaryCollector<'_> {
    fn name(&self) -> &str {
        "summary"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.record(t, q);
        Ok(())
    }

    fn on_step(&mut self, r: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        // The run's counters are summed by RunStats, here as in the stepper.
        self.stats.absorb(r);
        let (s, st) = (&mut self.summary, &self.stats);
        s.steps = st.steps;
        s.seconds_per_stage = st.times;
        s.solver_iterations = st.iterations;
        s.solves = st.solves;
        s.counters = st.counters;
        s.max_rows = st.max_rows;
        s.max_active = st.max_active;
        self.record(r.t, q);
        Ok(())
    }

    fn on_finish(&mut self, error: Option<&SweepError>) -> Result<(), ObserverError> {
        let s = &mut self.summary;
        s.arrivals = self.population.arrival_report(s.t_final);
        s.peak_memory_mib = crate::meter::peak_memory_bytes().map(|b| b as f64 / 1048576.0);
        let per = |v: f64| {
            if s.steps > 0 {
                1e3 * v / s.steps as f64
            } else {
                0.0
            }
        };
        let st = s.seconds_per_stage;
        s.ms_per_step = MsPerStep {
            effects: per(st.effects),
            broad_phase: per(st.broad_phase),
            assembly: per(st.assembly),
            projection: per(st.projection),
            check: per(st.check),
            total: per(st.total()),
        };
        match error {
            Some(e) => {
                s.status = match e {
                    SweepError::Interrupted { .. } => RunStatus::Interrupted,
                    _ => RunStatus::Failed,
                };
                s.error = Some(e.to_string());
            }
            None => {
                let reached_end = s.t_final >= s.t_end - 1e-9 * s.t_end.abs().max(1.0);
                s.status = if reached_end || s.people_remaining > 0 {
                    RunStatus::Completed
                } else {
                    RunStatus::EverybodyLeft
                };
            }
        }
        Ok(())
    }
}

/// The first time of the schedule `next, next + every, …` strictly after `t` (within the
/// `1e-9` relative tolerance the writers use), computed without a loop: a loop adding `every`
/// would never end when `every` is tiny against `t − next` or below the resolution of `t`.
pub(crate) fn next_time_after(next: f64, every: f64, t: f64) -> f64 {
    let tol = 1e-9 * t.abs().max(1.0);
    if !(every > 0.0 && every.is_finite()) {
        return f64::INFINITY;
    }
    let n = ((t + tol - next) / every).floor() + 1.0;
    let candidate = next + n.max(1.0) * every;
    if candidate > t + tol {
        candidate
    } else {
        // `every` is below the resolution of `t`: the next step is due.
        t + tol + every
    }
}

/// `every` steps between writes so that writes are `interval` seconds apart (at least 1; an
/// interval below `h` is clamped to one step, a huge one to `usize::MAX`).
pub fn steps_between(interval: f64, h: f64) -> usize {
    let steps = (interval / h).round();
    if steps.is_nan() {
        1
    } else {
        // `as` saturates: 1e300 becomes usize::MAX, not a wrapped value.
        (steps as usize).max(1)
    }
}

/// Steps between the SQLite trajectory's frames: its frame rate is fixed, so
/// `trajectory_every` must be a whole number of steps `h`.
///
/// # Errors
/// [`OutputError::FrameInterval`] when it is not (or is less than one step).
pub fn sqlite_frame_steps(trajectory_every: f64, h: f64) -> Result<usize, OutputError> {
    let ratio = trajectory_every / h;
    if !(h > 0.0 && ratio.is_finite() && ratio >= 1.0 - 1e-9)
        || (ratio - ratio.round()).abs() > 1e-6 * ratio
    {
        return Err(OutputError::FrameInterval {
            trajectory_every,
            h,
        });
    }
    Ok((ratio.round() as usize).max(1))
}

/// Whether this build can write `format` with frames `trajectory_every` apart at step `h`:
/// what `sweep run` refuses before running, for `sweep check` to refuse as well.
///
/// # Errors
/// [`OutputError::Unavailable`] for a format whose cargo feature is off,
/// [`OutputError::FrameInterval`] as [`sqlite_frame_steps`].
pub fn check_format(
    format: TrajectoryFormat,
    trajectory_every: f64,
    h: f64,
) -> Result<(), OutputError> {
    match format {
        TrajectoryFormat::Csv => Ok(()),
        TrajectoryFormat::Sqlite if !cfg!(feature = "sqlite") => {
            Err(OutputError::Unavailable("sqlite"))
        }
        TrajectoryFormat::Sqlite => sqlite_frame_steps(trajectory_every, h).map(|_| ()),
    }
}

/// The CSV writes a row every whole number of steps ([`steps_between`]): when that is not
/// `trajectory_every`, the sentence telling the user what is written instead.
pub fn csv_interval_note(trajectory_every: f64, h: f64) -> Option<String> {
    let every = steps_between(trajectory_every, h);
    let written = every as f64 * h;
    ((written - trajectory_every).abs() > 1e-6 * trajectory_every).then(|| {
        format!(
            "trajectory.csv: [output] trajectory_every = {trajectory_every} is not a whole \
             number of steps h = {h}: a row is written every {every} step(s), every {} s",
            crate::numbers::display_number(written)
        )
    })
}

#[cfg(test)]
mod status_tests {
    use super::RunStatus;

    #[test]
    fn run_status_serializes_to_the_strings_of_summary_json() {
        for (status, text) in [
            (RunStatus::Running, "running"),
            (RunStatus::Completed, "completed"),
            (RunStatus::EverybodyLeft, "everybody left"),
            (RunStatus::Interrupted, "interrupted"),
            (RunStatus::Failed, "failed"),
        ] {
            assert_eq!(
                serde_json::to_string(&status).unwrap(),
                format!("\"{text}\"")
            );
            assert_eq!(status.to_string(), text);
            let back: RunStatus = serde_json::from_str(&format!("\"{text}\"")).unwrap();
            assert_eq!(back, status);
        }
    }
}

#[cfg(test)]
mod schedule_tests {
    use super::{next_time_after, steps_between};

    #[test]
    fn tiny_intervals_terminate_and_land_after_t() {
        // A tiny snapshot_every must not loop once per interval within a step.
        let n = next_time_after(0.0, 1e-12, 1.0);
        assert!(n > 1.0 && n < 1.0 + 1e-8, "{n}");
        // An interval below the resolution of t.
        let n = next_time_after(1e17, 1e-3, 1e17);
        assert!(n > 1e17, "{n}");
        assert!((next_time_after(0.0, 0.5, 0.7) - 1.0).abs() < 1e-15);
        assert!((next_time_after(0.0, 0.5, 1.0) - 1.5).abs() < 1e-15);
        assert_eq!(steps_between(1e-12, 0.01), 1);
        assert_eq!(steps_between(1e300, 1e-5), usize::MAX);
    }
}

#[cfg(test)]
mod summary_tests {
    use super::SummaryCollector;
    use crate::crowd::{DiskPairs, Population};
    use crate::problem::{NoPerturbation, Problem};

    #[test]
    fn the_worst_overlap_is_described_where_and_when_it_happened() {
        // Three people of radius 0.5: 0 and 1 overlap by 0.1, 1 and 2 by 0.05.
        let population = Population::new(vec![0.5; 3]).shared();
        let q = vec![0.0, 0.0, 0.9, 0.0, 1.85, 0.0];
        let problem =
            Problem::new(q.clone(), NoPerturbation).with_family(DiskPairs::new(population.clone()));
        let mut collector = SummaryCollector::new("three", &problem, population, "none", 0.1, 1.0);
        collector.record(0.0, &q);
        let s = collector.summary();
        assert!((s.max_overlap - 0.1).abs() < 1e-12, "{}", s.max_overlap);
        assert_eq!(s.max_overlap_at, "no overlap of people 0 and 1 at t = 0");
        assert_eq!(
            (s.max_wall_penetration, s.max_wall_penetration_at.as_str()),
            (0.0, "")
        );
        // A smaller overlap later leaves the record; a larger one replaces it.
        collector.record(0.5, &[0.0, 0.0, 0.95, 0.0, 1.9, 0.0]);
        assert_eq!(
            collector.summary().max_overlap_at,
            "no overlap of people 0 and 1 at t = 0"
        );
        collector.record(0.7, &[0.0, 0.0, 1.0, 0.0, 1.8, 0.0]);
        let s = collector.summary();
        assert!((s.max_overlap - 0.2).abs() < 1e-12, "{}", s.max_overlap);
        assert_eq!(s.max_overlap_at, "no overlap of people 1 and 2 at t = 0.7");
    }
}
