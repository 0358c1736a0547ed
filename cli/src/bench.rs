//! `sweep bench`: milliseconds per step, by stage, on synthetic crowds of growing size, on a
//! door queue of a real evacuation, or on any scene from a time of its run.

use crate::resume;
use crate::stdout::{out, outln};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;
use sweeping::backends::{make_projector, make_projector_with, BackendChoice, ProjectorOptions};
use sweeping::scene::synthetic::{Start, SyntheticCrowd};
use sweeping::scene::{BuiltScene, Overrides, ResumeState, Scene};
use sweeping::stepper::{
    Observer, ObserverError, StageTimes, StepReport, Stepper, StepperSettings,
};
use sweeping::study::peak_memory_bytes;

/// The scene of `--start queue`: the 2000-person evacuation through two doors, whose queues at
/// the doors hold most of the room by [`QUEUE_FROM`].
const QUEUE_SCENE: &str = include_str!("../../examples/scenes/large-evacuation.toml");

/// The time `--start queue` measures from: each door has a queue of a few hundred people
/// pressed together, projections of 2000–4500 rows on as many unknowns.
const QUEUE_FROM: f64 = 20.0;

/// What `sweep bench` measures: a synthetic crowd, or a door queue of a real evacuation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BenchStart {
    /// A synthetic crowd ([`Start`]), one per size in `--n`.
    Synthetic(Start),
    /// `examples/scenes/large-evacuation.toml` from its state at t = 20 s.
    Queue,
}

impl std::fmt::Display for BenchStart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BenchStart::Synthetic(s) => s.fmt(f),
            BenchStart::Queue => f.write_str("queue"),
        }
    }
}

impl std::str::FromStr for BenchStart {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "queue" => Ok(BenchStart::Queue),
            other => other
                .parse()
                .map(BenchStart::Synthetic)
                .map_err(|_| format!("unknown start `{other}` (expected spread, jammed or queue)")),
        }
    }
}

/// Arguments of `sweep bench`.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// Crowd sizes.
    #[arg(long, value_delimiter = ',', default_value = "150,1000,5000")]
    pub n: Vec<usize>,
    /// Starts: `spread` (the paper's density, h = 0.01), `jammed` (twice it, everybody
    /// walking to the centre, h = 0.1), `queue` (the 2000-person evacuation of
    /// `examples/scenes/large-evacuation.toml` from t = 20 s, when its doors have queues; the
    /// run there is not timed; `--n` does not apply).
    #[arg(long, value_delimiter = ',', default_value = "spread,jammed")]
    pub start: Vec<BenchStart>,
    /// Measure this scene instead of `--start`: its steps from `--from` (or from the state
    /// `--resume` names), with its own time step unless `--h` is given.
    #[arg(long, conflicts_with = "start")]
    pub scene: Option<PathBuf>,
    /// With `--scene`: the time the measured steps start from; the scene is run there first
    /// (not timed) by its own backend. Default: the scene's start.
    #[arg(long, requires = "scene", conflicts_with = "resume")]
    pub from: Option<f64>,
    /// With `--scene`: start from the last state of an earlier `sweep run` of the scene (its
    /// directory), as `sweep run --resume` does.
    #[arg(long, requires = "scene")]
    pub resume: Option<PathBuf>,
    /// With `--scene`: the time step (default: the scene's).
    #[arg(long, requires = "scene")]
    pub h: Option<f64>,
    /// Backends (default: every compiled one but `reference` and `cross`).
    #[arg(long, value_delimiter = ',')]
    pub backends: Vec<BackendChoice>,
    /// Steps per configuration.
    #[arg(long, default_value_t = 20)]
    pub steps: usize,
    /// Stop a configuration after this many seconds of stepping (at least one step is taken).
    #[arg(long, default_value_t = 60.0)]
    pub budget: f64,
    /// Seed of the placements.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Most threads a projection runs on (0: as many as the cores). The native backend uses
    /// more than one, and a cross-check with two or more runs its two backends at once.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Also write the table as CSV.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// One measured configuration.
struct Row {
    start: String,
    n: usize,
    backend: String,
    steps: usize,
    times: StageTimes,
    rows: usize,
    active: usize,
    solves: usize,
    peak_mib: Option<f64>,
    failure: Option<String>,
}

impl Row {
    /// A configuration not measured yet.
    fn new(start: String, n: usize, backend: BackendChoice) -> Self {
        Row {
            start,
            n,
            backend: backend.to_string(),
            steps: 0,
            times: StageTimes::default(),
            rows: 0,
            active: 0,
            solves: 0,
            peak_mib: None,
            failure: None,
        }
    }
}

/// A fresh projector of `backend` on at most `threads` threads.
fn projector(backend: BackendChoice, threads: usize) -> Result<Box<dyn sweeping::api::Projector>> {
    make_projector_with(
        backend,
        ProjectorOptions {
            threads,
            ..ProjectorOptions::default()
        },
    )
    .map_err(anyhow::Error::msg)
}

fn default_backends() -> Vec<BackendChoice> {
    BackendChoice::ALL
        .iter()
        .copied()
        .filter(|b| {
            !matches!(
                b,
                BackendChoice::Reference | BackendChoice::Cross | BackendChoice::CrossNative
            )
        })
        .filter(|b| make_projector(*b).is_ok())
        .collect()
}

fn measure(crowd: SyntheticCrowd, backend: BackendChoice, args: &BenchArgs) -> Result<Row> {
    let h = match crowd.start {
        Start::Spread => 0.01,
        Start::Jammed => 0.1,
    };
    let problem = crowd
        .problem()
        .with_context(|| format!("building the {} crowd of {}", crowd.start, crowd.n))?;
    let mut projector = projector(backend, args.threads)?;
    let settings = StepperSettings {
        h,
        t_end: args.steps as f64 * h,
        ..Default::default()
    };
    let mut stepper = Stepper::new(&problem, settings)?;
    let mut row = Row::new(crowd.start.to_string(), crowd.n, backend);
    let began = Instant::now();
    while row.steps < args.steps && (row.steps == 0 || began.elapsed().as_secs_f64() < args.budget)
    {
        match stepper.step(projector.as_mut()) {
            Ok(r) => {
                row.steps += 1;
                row.times.add(&r.times);
                row.rows += r.rows;
                row.active += r.active;
                row.solves += r.solves;
            }
            Err(e) => {
                row.failure = Some(e.to_string());
                break;
            }
        }
    }
    row.peak_mib = peak_memory_bytes().map(|b| b as f64 / (1024.0 * 1024.0));
    Ok(row)
}

/// A scene made ready to be measured: built, with its horizon at the end of the measured steps,
/// resumed at the state they start from.
struct PreparedScene {
    label: String,
    built: BuiltScene,
}

/// Builds `scene` and brings it to where the measured steps start: `from` (run there by the
/// scene's own backend, not timed) or `resume` (an earlier run's last state), else its start.
fn prepare_scene(
    scene: &Scene,
    label: &str,
    from: Option<f64>,
    resume: Option<ResumeState>,
    args: &BenchArgs,
) -> Result<PreparedScene> {
    let overrides = Overrides {
        h: args.h,
        threads: Some(args.threads),
        ..Overrides::default()
    };
    let mut built = scene
        .build(&overrides)
        .with_context(|| format!("building {}", scene.origin()))?;
    let t0 = built.problem.t0();
    let state = match (from, resume) {
        (Some(t), _) if !(t.is_finite() && t >= t0) => {
            anyhow::bail!("--from {t}: not a time of the run, which starts at t = {t0}")
        }
        (Some(t), _) if t > t0 => Some(run_untimed(&mut built, label, t)?),
        (_, resume) => resume,
    };
    let t_start = state.as_ref().map_or(t0, |s| s.t);
    built.settings.t_end = t_start + args.steps as f64 * built.settings.h;
    if let Some(state) = state {
        built
            .resume_at(state)
            .map_err(|e| anyhow::anyhow!("{label}: its state at t = {t_start}: {e}"))?;
    }
    Ok(PreparedScene {
        label: label.to_string(),
        built,
    })
}

/// Runs `built` from its start to `t` with its own backend and returns the state there.
fn run_untimed(built: &mut BuiltScene, label: &str, t: f64) -> Result<ResumeState> {
    outln!("{label}: running to t = {t} s first (not timed)");
    std::io::stdout().flush().ok();
    built.settings.t_end = t;
    let mut projector = projector(built.backend, built.threads)?;
    let run = built
        .run(projector.as_mut(), &mut [])
        .map_err(|f| anyhow::anyhow!("{label}: running to t = {t}: {}", f.error))?;
    if run.t_final < t {
        anyhow::bail!(
            "{label}: everybody has left by t = {}, before --from {t}",
            run.t_final
        );
    }
    let population = &built.population;
    Ok(ResumeState {
        t: run.t_final,
        departed: (0..population.len())
            .map(|i| population.has_departed(i))
            .collect(),
        q: run.q_final,
    })
}

/// Sums the step reports of a measured run and stops it when the budget is spent.
struct Meter {
    row: Row,
    began: Instant,
    budget: f64,
    out_of_budget: bool,
}

impl Observer for Meter {
    fn name(&self) -> &str {
        "bench"
    }
    fn on_step(&mut self, r: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
        self.row.steps += 1;
        self.row.times.add(&r.times);
        self.row.rows += r.rows;
        self.row.active += r.active;
        self.row.solves += r.solves;
        if self.began.elapsed().as_secs_f64() >= self.budget {
            self.out_of_budget = true;
            return Err("the budget of --budget seconds is spent".into());
        }
        Ok(())
    }
}

/// Times the steps of a prepared scene with `backend`.
fn measure_scene(
    prepared: &PreparedScene,
    backend: BackendChoice,
    args: &BenchArgs,
) -> Result<Row> {
    let mut projector = projector(backend, args.threads)?;
    let mut meter = Meter {
        row: Row::new(
            prepared.label.clone(),
            prepared.built.population.len(),
            backend,
        ),
        began: Instant::now(),
        budget: args.budget,
        out_of_budget: false,
    };
    let result = prepared.built.run(projector.as_mut(), &mut [&mut meter]);
    if let Err(failure) = result {
        if !meter.out_of_budget {
            meter.row.failure = Some(failure.error.to_string());
        }
    }
    meter.row.peak_mib = peak_memory_bytes().map(|b| b as f64 / (1024.0 * 1024.0));
    Ok(meter.row)
}

pub fn main(mut args: BenchArgs) -> Result<()> {
    if args.backends.is_empty() {
        args.backends = default_backends();
    }
    if args.steps == 0 {
        anyhow::bail!("--steps must be at least 1");
    }
    if args.n.contains(&0) {
        anyhow::bail!("--n: every crowd size must be at least 1, got {:?}", args.n);
    }
    if !(args.budget.is_finite() && args.budget > 0.0) {
        anyhow::bail!("--budget must be a positive number of seconds");
    }
    // A scene's file and an earlier run's state are read before anything is measured.
    let scene = match &args.scene {
        Some(path) => {
            let resume = match &args.resume {
                Some(dir) => Some(
                    resume::read(&dir.join(resume::TRAJECTORY), &dir.join(resume::PEOPLE))
                        .with_context(|| {
                            format!("--resume {}: reading the run's last state", dir.display())
                        })?
                        .state,
                ),
                None => None,
            };
            Some((Scene::from_file(path)?, resume))
        }
        None => None,
    };
    let mut csv = create_csv(args.csv.as_deref())?;
    // The CSV records the threads a projection could use, `--threads 0` resolved to the cores.
    let threads = match args.threads {
        0 => std::thread::available_parallelism().map_or(1, usize::from),
        t => t,
    };
    outln!("ms per step (mean), by stage; rows and active constraints per step (mean)");
    let mut header_printed = false;
    let mut print = |row: &Row| -> Result<()> {
        if !std::mem::replace(&mut header_printed, true) {
            outln!("{}", header());
        }
        print_row(row, threads, csv.as_mut())
    };
    if let Some((scene, resume)) = scene {
        let label = scene.name.clone();
        let prepared = prepare_scene(&scene, &label, args.from, resume, &args)?;
        for &backend in &args.backends {
            print(&measure_scene(&prepared, backend, &args)?)?;
        }
    } else {
        for &start in &args.start {
            match start {
                BenchStart::Queue => {
                    let scene = Scene::from_toml_str(QUEUE_SCENE, "large-evacuation.toml")?;
                    let prepared = prepare_scene(&scene, "queue", Some(QUEUE_FROM), None, &args)?;
                    for &backend in &args.backends {
                        print(&measure_scene(&prepared, backend, &args)?)?;
                    }
                }
                BenchStart::Synthetic(start) => {
                    for &n in &args.n {
                        for &backend in &args.backends {
                            let crowd = SyntheticCrowd {
                                n,
                                start,
                                seed: args.seed,
                            };
                            print(&measure(crowd, backend, &args)?)?;
                        }
                    }
                }
            }
        }
    }
    outln!(
        "peak MiB is the process's resident peak so far (VmHWM), so it only grows down the table"
    );
    Ok(())
}

fn header() -> String {
    format!(
        "{:<7} {:>7} {:<9} {:>5} {:>9} {:>9} {:>9} {:>10} {:>9} {:>9} {:>7} {:>6} {:>8}",
        "start",
        "N",
        "backend",
        "steps",
        "effects",
        "broad",
        "assembly",
        "projection",
        "check",
        "total",
        "rows",
        "active",
        "peak MiB"
    )
}

/// The CSV file, created before the first measurement (a path that cannot be written fails
/// now, not after minutes of benching); rows are written as they are measured, so an
/// interrupted or failed bench keeps the rows it finished.
fn create_csv(
    path: Option<&std::path::Path>,
) -> Result<Option<(PathBuf, std::io::BufWriter<std::fs::File>)>> {
    let Some(path) = path else {
        return Ok(None);
    };
    let mut file = std::io::BufWriter::new(
        std::fs::File::create(path)
            .with_context(|| format!("--csv: creating {}", path.display()))?,
    );
    file.write_all(
        b"start,n,backend,steps,threads,effects_ms,broad_phase_ms,assembly_ms,projection_ms,check_ms,total_ms,rows,active,solves,peak_mib,failure\n",
    )
    .and_then(|()| file.flush())
    .with_context(|| format!("--csv: writing {}", path.display()))?;
    Ok(Some((path.to_path_buf(), file)))
}

/// Prints one measured configuration, and writes it to the CSV.
fn print_row(
    row: &Row,
    threads: usize,
    csv: Option<&mut (PathBuf, std::io::BufWriter<std::fs::File>)>,
) -> Result<()> {
    let k = row.steps.max(1) as f64;
    let t = &row.times;
    // effects, broad phase, assembly, projection, check, total: ms per step.
    let ms = [
        t.effects,
        t.broad_phase,
        t.assembly,
        t.projection,
        t.check,
        t.total(),
    ]
    .map(|v| 1e3 * v / k);
    let (rows, active) = (row.rows / row.steps.max(1), row.active / row.steps.max(1));
    let peak = row
        .peak_mib
        .map_or_else(|| "—".to_string(), |m| format!("{m:.0}"));
    let failure = row.failure.as_deref().unwrap_or("");
    out!(
        "{:<7} {:>7} {:<9} {:>5}",
        row.start,
        row.n,
        row.backend,
        row.steps
    );
    for (v, width) in ms.iter().zip([9, 9, 9, 10, 9, 9]) {
        out!(" {v:>width$.3}");
    }
    out!(" {rows:>7} {active:>6} {peak:>8}");
    if !failure.is_empty() {
        out!("  failed after {} steps: {failure}", row.steps);
    }
    outln!();
    std::io::stdout().flush().ok();
    if let Some((path, file)) = csv {
        let ms: Vec<String> = ms.iter().map(f64::to_string).collect();
        writeln!(
            file,
            "{},{},{},{},{threads},{},{rows},{active},{},{},{}",
            row.start,
            row.n,
            row.backend,
            row.steps,
            ms.join(","),
            row.solves,
            row.peak_mib.map(|m| m.to_string()).unwrap_or_default(),
            failure.replace([',', '\n'], ";")
        )
        .and_then(|()| file.flush())
        .with_context(|| format!("--csv: writing {}", path.display()))?;
    }
    Ok(())
}
