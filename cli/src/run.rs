//! `sweep run`: run a scene and write its trajectory (CSV and/or JuPedSim's SQLite format),
//! summary, snapshots and animation.

use crate::interrupt::Interrupt;
use crate::out_dir::{self, DISAGREEMENT_FILE, LARGEST_GAP_FILE};
use crate::resume;
use crate::stdout::{errln, outln};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use sweeping::backends::{make_projector_with, threads_phrase, BackendChoice, ProjectorOptions};
use sweeping::error::SweepError;
use sweeping::output::{
    csv_interval_note, prepare_output_dir, steps_between, AnimationWriter, RunSummary,
    SnapshotWriter, SummaryCollector, TrajectoryFormat, TrajectoryWriter,
};
use sweeping::scene::{Overrides, Scene};
use sweeping::stepper::{Observer, ObserverError, StepReport};

/// Arguments of `sweep run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Output directory (default `out/<scene name>/`): new, empty, or an earlier run's, never
    /// one holding other files (refused, so that none of them is replaced or deleted). In an
    /// earlier run's, the files `sweep run` writes (trajectory.csv, trajectory.sqlite,
    /// summary.json, animation.html, snapshots/t*.svg, disagreement.json, largest-gap.json) are
    /// taken for that run's and replaced or removed; other files are left alone. One run at a
    /// time: a folder another run is writing to is refused (the lock file .sweep.lock).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Projection backend: clarabel, osqp, native, cross, cross-native or reference (default: the scene's).
    #[arg(long)]
    pub backend: Option<BackendChoice>,
    /// Time step (default: the scene's).
    #[arg(long)]
    pub h: Option<f64>,
    /// Horizon in seconds (default: the scene's).
    #[arg(long = "t-end")]
    pub t_end: Option<f64>,
    /// Seed of the random placements (default: the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Most threads a projection runs on: 1 keeps the run on one core (for runs side by side);
    /// 0, as many as the cores (default: the scene's `[run] threads`, else 0). The native backend
    /// uses more than one, and a cross-check with two or more runs its two backends at once;
    /// the trajectory does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Trajectory formats, comma-separated: csv (trajectory.csv), sqlite (trajectory.sqlite,
    /// JuPedSim's format, read by PedPy). Default: the scene's `[output] formats`, else csv.
    #[arg(long = "format", value_delimiter = ',')]
    pub formats: Vec<TrajectoryFormat>,
    /// Go on from where an earlier run of this scene stopped: the output directory it wrote
    /// (the last frame of its trajectory.csv: the time, every position, who had left), up to
    /// the same horizon. The outputs go to a new directory (default: DIR-from-t followed by the time resumed at).
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
}

/// A progress bar on stderr when stderr is a terminal; otherwise (a run under `nohup`, in a
/// batch job or a pipe) plain lines, so that a run of an hour says how far it got.
struct Progress {
    bar: ProgressBar,
    people: usize,
    population: std::sync::Arc<sweeping::crowd::Population>,
    lines: Option<ProgressLines>,
}

/// When [`Progress`] writes a plain line: at every tenth of the run's steps, and at least
/// every [`ProgressLines::EVERY`] of wall time in between.
struct ProgressLines {
    n_steps: usize,
    started: std::time::Instant,
    last: std::time::Instant,
}

impl ProgressLines {
    const EVERY: std::time::Duration = std::time::Duration::from_secs(60);

    fn new(n_steps: usize) -> Self {
        let now = std::time::Instant::now();
        Self {
            n_steps: n_steps.max(1),
            started: now,
            last: now,
        }
    }

    /// Whether step `done` (counted from 1) gets a line.
    fn due(&mut self, done: usize) -> bool {
        let tenth = |k: usize| k.saturating_mul(10) / self.n_steps;
        let due = tenth(done) > tenth(done - 1) || self.last.elapsed() >= Self::EVERY;
        if due {
            self.last = std::time::Instant::now();
        }
        due
    }
}

impl Observer for Progress {
    fn name(&self) -> &str {
        "progress bar"
    }
    fn on_step(&mut self, r: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        self.bar.set_position((r.step + 1) as u64);
        if let Some(lines) = self.lines.as_mut() {
            if lines.due(r.step + 1) {
                errln!(
                    "t = {:.2} s, step {}/{}, in the room {}/{}, {:.0} s elapsed",
                    r.t,
                    r.step + 1,
                    lines.n_steps,
                    self.population.present_count(q),
                    self.people,
                    lines.started.elapsed().as_secs_f64()
                );
            }
        }
        if r.step.is_multiple_of(10) {
            self.bar.set_message(format!(
                "t = {:.2} s, in the room {}/{}",
                r.t,
                self.population.present_count(q),
                self.people
            ));
        }
        Ok(())
    }
    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), ObserverError> {
        self.bar.finish_and_clear();
        Ok(())
    }
}

/// Writes the problem on which a cross-checked run's backends disagreed, with both answers
/// (a [`CrossCheckDisagreement`](sweeping::api::CrossCheckDisagreement)), to
/// `out/disagreement.json`, so that the step can be decided afterwards (against a projection
/// computed independently) without running again to it. Returns the path written, if any.
fn write_disagreement(
    out: &std::path::Path,
    stats: Option<&sweeping::api::CrossCheckStats>,
) -> Result<Option<PathBuf>> {
    write_case(
        out,
        DISAGREEMENT_FILE,
        stats.and_then(|s| s.disagreement.as_deref()),
    )
}

/// Writes the problem of the largest gap that passed, with both answers
/// ([`CrossCheckStats::largest_passed_gap`](sweeping::api::CrossCheckStats::largest_passed_gap)),
/// to `out/largest-gap.json`: a run's closest call, decided the same way as a disagreement.
/// Returns the path written, if any.
fn write_largest_gap(
    out: &std::path::Path,
    stats: Option<&sweeping::api::CrossCheckStats>,
) -> Result<Option<PathBuf>> {
    write_case(
        out,
        LARGEST_GAP_FILE,
        stats.and_then(|s| s.largest_passed_gap.as_deref()),
    )
}

fn write_case(
    out: &std::path::Path,
    name: &str,
    case: Option<&sweeping::api::CrossCheckDisagreement>,
) -> Result<Option<PathBuf>> {
    let Some(case) = case else {
        return Ok(None);
    };
    let path = out.join(name);
    let file =
        std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
    serde_json::to_writer(std::io::BufWriter::new(file), case)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(Some(path))
}

/// Entry point of `sweep run`.
pub fn main(args: RunArgs) -> Result<()> {
    let scene = Scene::from_file(&args.scene)?;
    // Before `out/<name>/` is created: a name such as `../x` would create a directory elsewhere.
    scene.check_name()?;
    let overrides = Overrides {
        h: args.h,
        t_end: args.t_end,
        seed: args.seed,
        backend: args.backend,
        threads: args.threads,
    };
    // The state to resume from, read before any work (a missing or malformed file is an
    // error now), and the run's directory, which must not be the one it resumes.
    let resume = match &args.resume {
        Some(dir) => {
            let path = dir.join(resume::TRAJECTORY);
            let sqlite = TrajectoryFormat::Sqlite.file_name();
            if !path.exists() && dir.join(sqlite).exists() {
                // The SQLite trajectory leaves out who had left and rounds the time to its
                // frame: not a state to go on from to the bit.
                anyhow::bail!(
                    "--resume {}: the run wrote no {} but a {sqlite}, which keeps only the \
                     people still inside; --resume reads the CSV (every position to the bit, \
                     and who had left): run with --format csv or --format csv,sqlite to be \
                     able to resume",
                    dir.display(),
                    resume::TRAJECTORY
                );
            }
            let saved = resume::read(&path).with_context(|| {
                format!("--resume {}: reading the run's last state", dir.display())
            })?;
            Some((dir.clone(), path, saved))
        }
        None => None,
    };
    let out = match (&args.out, &resume) {
        (Some(out), _) => out.clone(),
        (None, Some((dir, _, saved))) => resume::default_out(dir, saved.state.t),
        (None, None) => PathBuf::from("out").join(&scene.name),
    };
    if let Some((dir, _, _)) = &resume {
        if resume::same_dir(dir, &out) {
            anyhow::bail!(
                "--resume {} --out {}: a resumed run writes to another directory than the \
                 run it resumes (whose trajectory it would overwrite)",
                dir.display(),
                out.display()
            );
        }
    }
    // Before any work: a directory that cannot be written is an error now, not after the run.
    prepare_output_dir(&out)?;
    let mut built = scene.build(&overrides)?;
    let resumed_at = match resume {
        Some((dir, path, saved)) => {
            let t = saved.state.t;
            let (listed, people) = (saved.state.departed.len(), built.population.len());
            if listed != people {
                anyhow::bail!(
                    "--resume {}: {}: its last frame (t = {}) lists {listed} people, the scene \
                     has {people}: a frame cut short (a run killed while writing it) or a run \
                     of another scene",
                    dir.display(),
                    path.display(),
                    sweeping::stepper::display_number(t)
                );
            }
            resume::check_start(&saved, &path, built.problem.t0(), built.problem.q0())
                .with_context(|| format!("--resume {}", dir.display()))?;
            // An error about one person points at their row of the last frame.
            let last_line = saved.last.line;
            built.resume_at(saved.state).map_err(|e| {
                let row = e
                    .person()
                    .map_or(String::new(), |i| format!(":{}", last_line + i));
                anyhow::anyhow!("--resume {}: {}{row}: {e}", dir.display(), path.display())
            })?;
            Some((dir, t))
        }
        None => None,
    };
    let built = built;
    let mut formats = if args.formats.is_empty() {
        built.output.formats.clone()
    } else {
        args.formats.clone()
    };
    let mut seen = std::collections::HashSet::new();
    formats.retain(|f| seen.insert(*f));
    // Held until the run ends: a second run into `out` is refused rather than mixed in.
    let _out_dir = out_dir::claim(&out, &formats)?;
    let h = built.settings.h;
    let t_end = built.settings.t_end;
    let backend_name = built.backend.to_string();

    for note in &built.output.notes {
        errln!("note: {note}");
    }
    if formats.contains(&TrajectoryFormat::Csv) {
        if let Some(note) = csv_interval_note(built.output.trajectory_every, h) {
            errln!("note: {note}");
        }
    }
    // The trajectory writers, created before the run so that their errors come first (the
    // SQLite file gets its schema and walkable area now).
    let mut csv = formats.contains(&TrajectoryFormat::Csv).then(|| {
        TrajectoryWriter::new(
            out.join(TrajectoryFormat::Csv.file_name()),
            built.population.clone(),
            steps_between(built.output.trajectory_every, h),
        )
    });
    let mut sqlite = if formats.contains(&TrajectoryFormat::Sqlite) {
        Some(
            sqlite_writer(&built, &out)
                .with_context(|| format!("{} (--format sqlite)", args.scene.display()))?,
        )
    } else {
        None
    };

    let mut summary = SummaryCollector::new(
        &built.name,
        &built.problem,
        built.population.clone(),
        &backend_name,
        h,
        t_end,
    );
    if let Some((dir, t)) = &resumed_at {
        summary.record_resumed_from(dir, *t);
    }
    let summary_path = out.join("summary.json");
    let options = ProjectorOptions {
        threads: built.threads,
        ..ProjectorOptions::default()
    };
    let mut projector = match make_projector_with(built.backend, options) {
        Ok(p) => p,
        Err(e) => {
            summary.mark_failed(&e.to_string());
            let _ = summary.write_json(&summary_path);
            anyhow::bail!("{e}");
        }
    };
    let mut snapshots = SnapshotWriter::new(
        out.join("snapshots"),
        built.geometry.clone(),
        built.population.clone(),
        built.group_of.clone(),
        &built.name,
        built.output.snapshot_every,
    );
    // A resumed run covers [t₀, T]: its frames are spread over that span.
    let t_start = built.problem.t0();
    let mut animation = AnimationWriter::new(
        out.join("animation.html"),
        built.geometry.clone(),
        built.population.clone(),
        built.group_of.clone(),
        &built.name,
        t_end - t_start,
        h,
        built.output.animation_frames,
    );
    let n_steps = sweeping::stepper::step_count(t_end - t_start, h) as u64;
    let (bar, lines) = if std::io::stderr().is_terminal() {
        let bar = ProgressBar::with_draw_target(Some(n_steps), ProgressDrawTarget::stderr());
        (bar, None)
    } else {
        let lines = ProgressLines::new(usize::try_from(n_steps).unwrap_or(usize::MAX));
        (ProgressBar::hidden(), Some(lines))
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} steps [{elapsed} < {eta}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut progress = Progress {
        bar,
        people: built.population.len(),
        population: built.population.clone(),
        lines,
    };
    errln!(
        "running `{}`: {} people, h = {h:?}, T = {t_end:?}, backend {backend_name}{}{} → {}",
        built.name,
        built.population.len(),
        threads_phrase(built.threads),
        resumed_at
            .as_ref()
            .map(|(dir, t)| format!(
                ", resuming {} from t = {}",
                dir.display(),
                sweeping::stepper::display_number(*t)
            ))
            .unwrap_or_default(),
        out.display()
    );
    let mut observers: Vec<&mut dyn Observer> = Vec::new();
    if let Some(w) = csv.as_mut() {
        observers.push(w);
    }
    if let Some(w) = sqlite.as_mut() {
        observers.push(w);
    }
    observers.extend([
        &mut summary as &mut dyn Observer,
        &mut snapshots,
        &mut animation,
        &mut progress,
    ]);
    // Last, so that every other observer has seen the step it stops after.
    let mut interrupt = Interrupt::install();
    if let Some(i) = interrupt.as_mut() {
        observers.push(i);
    }
    let result = built.run(projector.as_mut(), &mut observers);
    summary.record_cross_check(projector.cross_check());
    // Every file is tried whatever failed before it, and the first failure is the one
    // reported: on a full disk the trajectory fails first and says the most.
    let mut later_errors = Vec::new();
    let disagreement = write_disagreement(&out, projector.cross_check()).unwrap_or_else(|e| {
        later_errors.push(format!("{e:#}"));
        None
    });
    let largest_gap = write_largest_gap(&out, projector.cross_check()).unwrap_or_else(|e| {
        later_errors.push(format!("{e:#}"));
        None
    });
    if let Err(e) = summary.write_json(&summary_path) {
        later_errors.push(format!("writing {}: {e}", summary_path.display()));
    }
    if result.is_err() || !later_errors.is_empty() {
        remove_empty_outputs(&out);
    }
    print_summary(summary.summary(), &out, &formats);
    if let Some(path) = largest_gap {
        outln!(
            "  the largest gap that passed, its problem and both answers: {}",
            path.display()
        );
    }
    let later = later_errors.join("; then ");
    match result {
        Ok(_) if later.is_empty() => Ok(()),
        Ok(_) => Err(anyhow::anyhow!("{later}")),
        Err(failure) => Err(anyhow::anyhow!(
            "{failure}; what was computed is in {}{}{}",
            out.display(),
            disagreement
                .map(|path| format!(
                    " (the problem the backends disagreed on, with both answers: {})",
                    path.display()
                ))
                .unwrap_or_default(),
            if later.is_empty() {
                String::new()
            } else {
                format!("; then {later}")
            }
        )),
    }
}

/// Removes the files of `out` left empty by a run that failed (a full disk): an empty
/// trajectory, summary or picture would pass for a result.
fn remove_empty_outputs(out: &std::path::Path) {
    let mut paths: Vec<PathBuf> = [
        TrajectoryFormat::Csv.file_name(),
        TrajectoryFormat::Sqlite.file_name(),
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

#[cfg(feature = "sqlite")]
fn sqlite_writer(
    built: &sweeping::scene::BuiltScene,
    out: &std::path::Path,
) -> Result<sweeping::output::SqliteTrajectoryWriter> {
    let walkable = sweeping::output::WalkableArea::of_scene(&built.geometry, &built.population)?;
    for note in &walkable.notes {
        errln!("note: trajectory.sqlite: {note}");
    }
    Ok(sweeping::output::SqliteTrajectoryWriter::for_scene(
        out.join(TrajectoryFormat::Sqlite.file_name()),
        &walkable,
        built,
    )?)
}

/// Without the `sqlite` feature there is no SQLite writer: asking for one is an error before
/// the run. (The observer type only has to exist; it is never built.)
#[cfg(not(feature = "sqlite"))]
fn sqlite_writer(_: &sweeping::scene::BuiltScene, _: &std::path::Path) -> Result<()> {
    Err(sweeping::output::OutputError::Unavailable("sqlite").into())
}

fn print_summary(s: &RunSummary, out: &std::path::Path, formats: &[TrajectoryFormat]) {
    outln!("scene `{}` ({}, backend {})", s.scene, s.status, s.backend);
    if let Some(r) = &s.resumed_from {
        outln!(
            "  resumed {} from its state at t = {} (the counts below are this run's)",
            r.run,
            sweeping::stepper::display_number(r.t)
        );
    }
    outln!(
        "  people: {}, left: {}, remaining: {}",
        s.people,
        s.people - s.people_remaining,
        s.people_remaining
    );
    match s.evacuation_time {
        Some(t) => outln!("  evacuation time: {t:.2} s"),
        None => outln!(
            "  evacuation time: — (not everybody left by t = {:.2} s)",
            s.t_final
        ),
    }
    let m = &s.ms_per_step;
    outln!(
        "  steps: {} (h = {:?}, t = {:.2} s)",
        s.steps,
        s.h,
        s.t_final
    );
    outln!(
        "  ms per step: {:.3} total = effects {:.3} + broad phase {:.3} + assembly {:.3} + projection {:.3} + check {:.3}",
        m.total, m.effects, m.broad_phase, m.assembly, m.projection, m.check
    );
    let c = &s.counters;
    outln!(
        "  solver iterations: {} over {} solves (max rows {}, max active {}, blocks escalated to the backend's second method {}, fallbacks {})",
        s.solver_iterations, s.solves, s.max_rows, s.max_active, c.escalations, c.fallbacks
    );
    if c.reduced > 0 {
        outln!(
            "  answers short of the backend's accuracy target: {} (estimated distance from the exact projection up to {:.1e}; each passed the KKT check)",
            c.reduced, c.reduced_by
        );
    }
    if let Some(mib) = s.peak_memory_mib {
        outln!("  peak memory: {mib:.0} MiB (resident, the whole process)");
    }
    // A positive worst value is followed by where it happened.
    let worst = |value: f64, at: &str| {
        if value > 0.0 {
            format!("{value:.3e} ({at})")
        } else {
            format!("{value:.3e}")
        }
    };
    outln!("  max overlap: {}", worst(s.max_overlap, &s.max_overlap_at));
    outln!(
        "  max wall penetration: {}",
        worst(s.max_wall_penetration, &s.max_wall_penetration_at)
    );
    if let Some(c) = &s.cross_check {
        let mean = if c.compared > 0 {
            c.sum_gap / c.compared as f64
        } else {
            0.0
        };
        outln!(
            "  cross-check: {} projections compared, largest gap {:.3e}, mean {mean:.3e} (seconds: first backend {:.1}, second {:.1})",
            c.compared, c.max_gap, c.first_seconds, c.second_seconds
        );
    }
    if let Some(e) = &s.error {
        outln!("  error: {e}");
    }
    let files: Vec<&str> = formats.iter().map(|f| f.file_name()).collect();
    outln!(
        "  outputs: {}/{{{}, summary.json, snapshots/, animation.html}}",
        out.display(),
        files.join(", ")
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use sweeping::api::{CrossCheck, ProjectionProblem, Projector, SparseRows};

    #[test]
    fn a_disagreement_is_written_with_its_problem_and_both_answers_and_nothing_else_is() {
        use sweeping::api::conformance::ReferenceProjector;
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
        let back: sweeping::api::CrossCheckDisagreement = serde_json::from_str(&text).unwrap();
        assert_eq!(back.problem, p);
        assert!((back.first.x[0] - 0.5).abs() < 1e-9 && (back.second.x[1] - 0.5).abs() < 1e-9);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
