//! `sweep run`: run a scene and write its trajectory (CSV and/or JuPedSim's SQLite format),
//! summary, snapshots and animation.

use crate::interrupt::Interrupt;
use crate::out_dir;
use crate::resume;
use crate::stdout::{errln, outln};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use sweeping::backends::{threads_phrase, BackendChoice};
use sweeping::error::SweepError;
use sweeping::output::{
    prepare_output_dir, run_scene, ResumedFrom, RunHooks, RunOptions, RunSceneError, RunSummary,
    SceneRun, TrajectoryFormat,
};
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping::stepper::{Observer, ObserverError, StepReport};

/// Arguments of `sweep run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Output directory (default `out/<scene name>/`): new, empty, or an earlier run's, never
    /// one holding other files (refused, so that none of them is replaced or deleted). In an
    /// earlier run's, the files `sweep run` writes (trajectory.csv, trajectory.sqlite,
    /// people.csv, contacts.csv, summary.json, animation.html, snapshots/t*.svg,
    /// disagreement.json, largest-gap.json) are
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
    /// Write the contact forces: each person's pressure in the trajectory, each contact in
    /// contacts.csv (and the SQLite tables pressure and contacts), people coloured by pressure
    /// in the pictures (default: the scene's `[output] contact_forces`, else off).
    #[arg(long = "contact-forces")]
    pub contact_forces: bool,
    /// Go on from where an earlier run of this scene stopped: the output directory it wrote
    /// (the last frame of its trajectory.csv, the time and the positions, and its people.csv,
    /// who had left), up to the same horizon. The outputs go to a new directory (default: DIR-from-t followed by the time resumed at).
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// Override a scene field, as if the file said it: a dotted path through the scene's
    /// tables, list items numbered from 0, and a TOML value (a bare word is a string), e.g.
    /// `--set crowds.0.count=200 --set exits.0.to=[10.0,5.8] --set run.backend=native`.
    /// Repeatable; applied in order.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<sweeping::scene::SetOverride>,
}

/// A progress bar on stderr when stderr is a terminal; otherwise (a run under `nohup`, in a
/// batch job or a pipe) plain lines, so that a run of an hour says how far it got.
struct Progress {
    bar: ProgressBar,
    people: usize,
    population: std::sync::Arc<sweeping::crowd::Population>,
    lines: Option<ProgressLines>,
}

impl Progress {
    /// A bar of `n_steps` on a terminal, else plain lines.
    fn new(n_steps: u64, population: std::sync::Arc<sweeping::crowd::Population>) -> Self {
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
        Self {
            bar,
            people: population.len(),
            population,
            lines,
        }
    }
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

/// What `sweep run` adds to the library's run: the notes and the line saying what runs, on
/// stderr; the progress display; and the interrupt that stops the run cleanly.
struct Terminal {
    /// The line said before the first step.
    running: String,
    n_steps: u64,
    population: std::sync::Arc<sweeping::crowd::Population>,
    progress: Option<Progress>,
    interrupt: Option<Interrupt>,
}

impl RunHooks for Terminal {
    fn note(&mut self, note: &str) {
        errln!("note: {note}");
    }

    fn before_first_step(&mut self) {
        self.progress = Some(Progress::new(self.n_steps, self.population.clone()));
        errln!("{}", self.running);
    }

    fn observers(&mut self) -> Vec<&mut dyn Observer> {
        let mut observers: Vec<&mut dyn Observer> = Vec::new();
        if let Some(progress) = self.progress.as_mut() {
            observers.push(progress);
        }
        // Last, so that every other observer has seen the step it stops after.
        self.interrupt = Interrupt::install();
        if let Some(interrupt) = self.interrupt.as_mut() {
            observers.push(interrupt);
        }
        observers
    }
}

/// An earlier run to go on from: its directory, its trajectory and people table, and what
/// was read there.
struct Resume {
    dir: PathBuf,
    path: PathBuf,
    people: PathBuf,
    saved: resume::Saved,
}

/// The state the run in `dir` left, read before any work: a missing or malformed file is an
/// error now.
fn read_resume(dir: &Path) -> Result<Resume> {
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
    let people = dir.join(resume::PEOPLE);
    let saved = resume::read(&path, &people)
        .with_context(|| format!("--resume {}: reading the run's last state", dir.display()))?;
    Ok(Resume {
        dir: dir.to_path_buf(),
        path,
        people,
        saved,
    })
}

/// Sets `built` to the state `resume` read, once it is known to be a state of this scene;
/// returns its time and each person's departure before it.
fn resume_scene(
    built: &mut BuiltScene,
    resume: Resume,
) -> Result<(f64, Vec<Option<sweeping::output::Departure>>)> {
    let Resume {
        dir,
        path,
        people,
        mut saved,
    } = resume;
    let t = saved.state.t;
    let due = |i| built.population.due(i).is_some();
    resume::check_start(
        &saved,
        (&path, &people),
        built.problem.t0(),
        built.problem.q0(),
        built.population.radii(),
        due,
    )
    .and_then(|()| saved.place_absent(due, built.problem.q0(), (&path, &people)))
    .with_context(|| format!("--resume {}", dir.display()))?;
    // An error about one person points at the row it was read from.
    let departures = saved.departures();
    let place = |i| saved.place_of(i, &path, &people);
    built.resume_at(saved.state.clone()).map_err(|e| {
        let at = e.person().map_or(path.display().to_string(), place);
        anyhow::anyhow!("--resume {}: {at}: {e}", dir.display())
    })?;
    Ok((t, departures))
}

/// Entry point of `sweep run`.
pub fn main(args: RunArgs) -> Result<()> {
    let scene = Scene::from_file_with(&args.scene, &args.sets)?;
    // Before `out/<name>/` is created: a name such as `../x` would create a directory elsewhere.
    scene.check_name()?;
    let overrides = Overrides {
        h: args.h,
        t_end: args.t_end,
        seed: args.seed,
        backend: args.backend,
        threads: args.threads,
    };
    // The run's directory must not be the one it resumes.
    let resume = args.resume.as_deref().map(read_resume).transpose()?;
    let out = match (&args.out, &resume) {
        (Some(out), _) => out.clone(),
        (None, Some(r)) => resume::default_out(&r.dir, r.saved.state.t),
        (None, None) => PathBuf::from("out").join(&scene.name),
    };
    if let Some(r) = &resume {
        if resume::same_dir(&r.dir, &out) {
            anyhow::bail!(
                "--resume {} --out {}: a resumed run writes to another directory than the \
                 run it resumes (whose trajectory it would overwrite)",
                r.dir.display(),
                out.display()
            );
        }
    }
    // Before any work: a directory that cannot be written is an error now, not after the run.
    prepare_output_dir(&out)?;
    let mut built = scene
        .build(&overrides)
        .map_err(|e| with_sets(e.into(), &args.sets))?;
    if args.contact_forces {
        built.output.contact_forces = true;
    }
    let (resumed_at, departures_before) = match resume {
        Some(r) => {
            let dir = r.dir.clone();
            let (t, departures) = resume_scene(&mut built, r)?;
            (Some((dir, t)), departures)
        }
        None => (None, Vec::new()),
    };
    let built = built;
    let options = RunOptions {
        out: Some(out.clone()),
        formats: args.formats.clone(),
        resumed_from: resumed_at.as_ref().map(|(dir, t)| ResumedFrom {
            run: dir.display().to_string(),
            t: *t,
        }),
        departures_before,
    };
    let formats = options.trajectory_formats(&built);
    // Held until the run ends: a second run into `out` is refused rather than mixed in.
    let _out_dir = out_dir::claim(&out, &formats)?;
    let mut terminal = Terminal {
        running: running_line(&built, &out, resumed_at.as_ref()),
        n_steps: sweeping::stepper::step_count(
            built.settings.t_end - built.problem.t0(),
            built.settings.h,
        ) as u64,
        population: built.population.clone(),
        progress: None,
        interrupt: None,
    };
    let scene_run = match run_scene(&built, &options, &mut terminal) {
        Ok(scene_run) => scene_run,
        Err(RunSceneError::SqliteTrajectory(e)) => {
            return Err(anyhow::Error::new(e)
                .context(format!("{} (--format sqlite)", args.scene.display())));
        }
        Err(e) => anyhow::bail!("{e}"),
    };
    print_summary(
        &scene_run.summary,
        &out,
        &formats,
        built.output.contact_forces,
    );
    if let Some(path) = &scene_run.largest_gap {
        outln!(
            "  the largest gap that passed, its problem and both answers: {}",
            path.display()
        );
    }
    outcome(scene_run, &out)
}

/// `error`, said to be of the scene as the overrides `sets` changed it (when there are any).
pub fn with_sets(error: anyhow::Error, sets: &[sweeping::scene::SetOverride]) -> anyhow::Error {
    if sets.is_empty() {
        return error;
    }
    let sets: Vec<String> = sets.iter().map(ToString::to_string).collect();
    error.context(format!("with {}", sets.join(" ")))
}

/// What the run is, said before its first step.
fn running_line(built: &BuiltScene, out: &Path, resumed_at: Option<&(PathBuf, f64)>) -> String {
    let (h, t_end) = (built.settings.h, built.settings.t_end);
    format!(
        "running `{}`: {} people, h = {h:?}, T = {t_end:?}, backend {}{}{} → {}",
        built.name,
        built.population.len(),
        built.backend,
        threads_phrase(built.threads),
        resumed_at
            .map(|(dir, t)| format!(
                ", resuming {} from t = {}",
                dir.display(),
                sweeping::stepper::display_number(*t)
            ))
            .unwrap_or_default(),
        out.display()
    )
}

/// How `sweep run` ends: the run's failure, with where what it computed is, and the files
/// that could not be written after it.
fn outcome(scene_run: SceneRun, out: &Path) -> Result<()> {
    let later = scene_run
        .write_errors
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; then ");
    match scene_run.result {
        Ok(_) if later.is_empty() => Ok(()),
        Ok(_) => Err(anyhow::anyhow!("{later}")),
        Err(failure) => Err(anyhow::anyhow!(
            "{failure}; what was computed is in {}{}{}",
            out.display(),
            scene_run
                .disagreement
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

/// The summary on stdout, and where the outputs are.
fn print_summary(
    s: &RunSummary,
    out: &std::path::Path,
    formats: &[TrajectoryFormat],
    contact_forces: bool,
) {
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
        s.people_out.last().map_or(0, |&(_, out)| out),
        s.people_remaining
    );
    if let Some(a) = &s.arrivals {
        outln!(
            "  arrivals: {} of {} arrived, {} waited for their place (longest {:.2} s, {:.2} s in all), {} still waiting",
            a.arrived,
            a.scheduled,
            a.waited,
            a.longest_wait,
            a.total_wait,
            a.still_waiting
        );
    }
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
    let mut files: Vec<&str> = formats.iter().map(|f| f.file_name()).collect();
    files.push(sweeping::output::PEOPLE_FILE);
    if contact_forces && formats.contains(&TrajectoryFormat::Csv) {
        files.push(sweeping::output::CONTACTS_FILE);
    }
    outln!(
        "  outputs: {}/{{{}, summary.json, snapshots/, animation.html}}",
        out.display(),
        files.join(", ")
    );
}
