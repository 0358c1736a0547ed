//! Running trials: each into its own folder with the usual outputs and a record of what it
//! was and how it ended, so that a batch run again goes on where it stopped.

use super::{BatchError, Plan, ResultsTable, Trial};
use crate::error::SweepError;
use crate::output::{run_scene, RunHooks, RunOptions, RunStatus};
use crate::scene::{Overrides, Scene};
use crate::stepper::{Observer, ObserverError, StepReport};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The record of a trial in its folder: what the trial is and how it ended.
pub const RECORD_FILE: &str = "trial.json";

/// The file a trial holds locked while it runs (the one `sweep run` holds in its folder): a
/// trial another process is running is left to it.
const LOCK_FILE: &str = ".sweep.lock";

/// What a trial's folder says of it (`trial.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// The trial's number.
    pub trial: usize,
    /// The scene as the plan names it.
    pub scene: String,
    /// The overrides, `[key, value]`.
    pub set: Vec<[String; 2]>,
    /// The tags, `[name, value]`.
    pub tags: Vec<[String; 2]>,
    /// The seed.
    pub seed: Option<u64>,
    /// `running` while it runs (and after it was killed), then how it ended.
    pub status: RunStatus,
    /// Why it failed or stopped.
    pub error: Option<String>,
    /// Seconds from reading the scene to the last file written.
    pub wall_seconds: Option<f64>,
}

impl TrialRecord {
    /// The record of `trial` before it runs.
    pub fn of(trial: &Trial) -> Self {
        Self {
            trial: trial.index,
            scene: trial.scene.clone(),
            set: trial
                .sets
                .iter()
                .map(|s| [s.key.clone(), s.value.clone()])
                .collect(),
            tags: trial
                .tags
                .iter()
                .map(|(k, v)| [k.clone(), v.clone()])
                .collect(),
            seed: trial.seed,
            status: RunStatus::Running,
            error: None,
            wall_seconds: None,
        }
    }

    /// Whether it records `trial` (the same scene, overrides, tags and seed).
    pub fn is_of(&self, trial: &Trial) -> bool {
        let me = Self::of(trial);
        (self.trial, &self.scene, &self.set, &self.tags, self.seed)
            == (me.trial, &me.scene, &me.set, &me.tags, me.seed)
    }

    fn write(&self, dir: &Path) -> Result<(), BatchError> {
        let path = dir.join(RECORD_FILE);
        let text = serde_json::to_string_pretty(self).map_err(|e| BatchError::Io {
            path: path.clone(),
            message: e.to_string(),
        })?;
        // Written whole then renamed: a trial killed while writing leaves the old record.
        let part = dir.join(format!("{RECORD_FILE}.part"));
        crate::output::write_whole(&part, text + "\n")
            .and_then(|()| std::fs::rename(&part, &path))
            .map_err(|e| BatchError::Io {
                path,
                message: e.to_string(),
            })
    }
}

/// Where a trial stands, read from its folder.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialState {
    /// Never run, or its folder holds another trial's record (the plan changed).
    NotRun,
    /// Started and not finished: killed, interrupted, or its summary is missing.
    Unfinished(TrialRecord),
    /// Finished: completed, everybody left, or failed (with its error).
    Finished(TrialRecord),
}

/// Where `trial` stands in its folder under `out`.
pub fn trial_state(trial: &Trial, out: &Path) -> TrialState {
    let dir = trial_dir(out, trial);
    let Some(record) = std::fs::read_to_string(dir.join(RECORD_FILE))
        .ok()
        .and_then(|t| serde_json::from_str::<TrialRecord>(&t).ok())
    else {
        return TrialState::NotRun;
    };
    if !record.is_of(trial) {
        return TrialState::NotRun;
    }
    let has_summary = || dir.join("summary.json").is_file();
    match record.status {
        RunStatus::Completed | RunStatus::EverybodyLeft if has_summary() => {
            TrialState::Finished(record)
        }
        RunStatus::Failed => TrialState::Finished(record),
        _ => TrialState::Unfinished(record),
    }
}

/// The folder of `trial` under the batch's output folder `out`.
pub(crate) fn trial_dir(out: &Path, trial: &Trial) -> PathBuf {
    out.join("trials").join(trial.dir_name())
}

/// How [`run_batch`] runs; plain values with documented defaults.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BatchSettings {
    /// Trials at once. Default `0`: one per core.
    pub jobs: usize,
    /// Run again the trials that failed. Default `false`: a failure is a result, kept.
    pub retry_failed: bool,
    /// Threads of each trial's projections. Default `1`: the cores go to trials side by side.
    pub threads_per_trial: usize,
}

impl Default for BatchSettings {
    fn default() -> Self {
        Self {
            jobs: 0,
            retry_failed: false,
            threads_per_trial: 1,
        }
    }
}

/// What the caller of [`run_batch`] hears as trials go; every method defaults to nothing.
/// Called from the threads that run the trials.
pub trait BatchHooks: Sync {
    /// A trial starts.
    fn started(&self, trial: &Trial) {
        let _ = trial;
    }
    /// A trial ended (or was found finished, `skipped`, or running in another process).
    fn finished(&self, trial: &Trial, record: &TrialRecord, skipped: bool) {
        let _ = (trial, record, skipped);
    }
    /// Whether to stop: checked before each trial and at every step of a running one (which
    /// then ends as interrupted, and runs again next time).
    fn stop_requested(&self) -> bool {
        false
    }
}

impl BatchHooks for () {}

/// What [`run_batch`] did.
#[derive(Debug)]
pub struct BatchReport {
    /// Trials run now.
    pub ran: usize,
    /// Trials found finished, not run again.
    pub skipped: usize,
    /// Trials left to a process that holds them, or not started because of a stop.
    pub not_run: usize,
    /// The results table of all trials, as written to `results.csv`.
    pub table: ResultsTable,
}

/// Runs every trial of `plan` not yet finished into `out/trials/trial-NNNN/`, `settings.jobs`
/// at once, then writes the results table `out/results.csv` (and `out/plot.svg` when the
/// plan has a `[plot]`). A finished trial is skipped; a failed one is recorded with its error
/// and the others go on.
///
/// # Errors
/// The output folder cannot be written, the threads cannot be started, or the table or plot
/// cannot be written. A trial's own failure is in its record, not an error here.
pub fn run_batch(
    plan: &Plan,
    out: &Path,
    settings: &BatchSettings,
    hooks: &dyn BatchHooks,
) -> Result<BatchReport, BatchError> {
    use rayon::prelude::*;
    crate::output::prepare_output_dir(&out.join("trials")).map_err(|e| BatchError::Io {
        path: out.to_path_buf(),
        message: e.to_string(),
    })?;
    let trials = plan.trials();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.jobs)
        .thread_name(|i| format!("trial-runner-{i}"))
        .build()
        .map_err(|e| BatchError::Threads {
            jobs: settings.jobs,
            message: e.to_string(),
        })?;
    // One trial per task: a trial is long, and work stealing would otherwise hand one thread
    // several trials in a row while another sits idle.
    let outcomes: Vec<Outcome> = pool.install(|| {
        trials
            .par_iter()
            .with_max_len(1)
            .map(|trial| run_or_skip(trial, out, settings, hooks))
            .collect()
    });
    let table = ResultsTable::collect(plan, out);
    table.write_csv(&out.join("results.csv"))?;
    if let Some(plot) = &plan.plot {
        let svg = super::plot_svg(&table, plot)?;
        let path = out.join("plot.svg");
        crate::output::write_whole(&path, svg).map_err(|e| BatchError::Io {
            path,
            message: e.to_string(),
        })?;
    }
    let count = |o: Outcome| outcomes.iter().filter(|&&x| x == o).count();
    Ok(BatchReport {
        ran: count(Outcome::Ran),
        skipped: count(Outcome::Skipped),
        not_run: count(Outcome::NotRun),
        table,
    })
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Ran,
    Skipped,
    NotRun,
}

fn run_or_skip(
    trial: &Trial,
    out: &Path,
    settings: &BatchSettings,
    hooks: &dyn BatchHooks,
) -> Outcome {
    if let TrialState::Finished(record) = trial_state(trial, out) {
        if !(record.status == RunStatus::Failed && settings.retry_failed) {
            hooks.finished(trial, &record, true);
            return Outcome::Skipped;
        }
    }
    if hooks.stop_requested() {
        return Outcome::NotRun;
    }
    match run_trial(trial, out, settings.threads_per_trial, hooks) {
        Ok(Some(_)) => Outcome::Ran,
        Ok(None) => Outcome::NotRun,
        // The folder could not be written: the table says the trial did not run.
        Err(_) => Outcome::NotRun,
    }
}

/// Stops a trial's run when the batch is asked to stop.
struct Stop<'a>(&'a dyn BatchHooks);

impl Observer for Stop<'_> {
    fn name(&self) -> &str {
        "batch stop"
    }
    fn on_step(&mut self, report: &StepReport, _: &[f64]) -> Result<(), ObserverError> {
        if self.0.stop_requested() {
            return Err(ObserverError::from(SweepError::Interrupted {
                step: report.step,
                t: report.t,
            }));
        }
        Ok(())
    }
}

impl RunHooks for Stop<'_> {
    fn observers(&mut self) -> Vec<&mut dyn Observer> {
        vec![self]
    }
}

/// Runs `trial` into its folder under `out` (`out/trials/trial-NNNN/`), its projections on
/// `threads` threads, and records how it ended in [`RECORD_FILE`]: a scene that does not
/// build, a run that fails, or a panic, is a failed trial with its error. Returns `None`
/// when another process holds the trial's folder.
///
/// # Errors
/// The trial's folder or record cannot be written.
pub fn run_trial(
    trial: &Trial,
    out: &Path,
    threads: usize,
    hooks: &dyn BatchHooks,
) -> Result<Option<TrialRecord>, BatchError> {
    let dir = trial_dir(out, trial);
    let io = |e: String| BatchError::Io {
        path: dir.clone(),
        message: e,
    };
    crate::output::prepare_output_dir(&dir).map_err(|e| io(e.to_string()))?;
    let lock = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(false)
        .open(dir.join(LOCK_FILE))
        .map_err(|e| io(e.to_string()))?;
    match lock.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => return Ok(None),
        Err(std::fs::TryLockError::Error(e)) => return Err(io(e.to_string())),
    }
    let mut record = TrialRecord::of(trial);
    record.write(&dir)?;
    hooks.started(trial);
    let start = Instant::now();
    // A panic is a bug, but one trial's must not take the others' results with it.
    let ended = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run_in(trial, &dir, threads, hooks)
    }))
    .unwrap_or_else(|panic| {
        let message = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".to_string());
        (RunStatus::Failed, Some(format!("panicked: {message}")))
    });
    (record.status, record.error) = ended;
    record.wall_seconds = Some(start.elapsed().as_secs_f64());
    record.write(&dir)?;
    hooks.finished(trial, &record, false);
    drop(lock);
    Ok(Some(record))
}

/// Builds and runs the trial's scene in `dir`: its status and error.
fn run_in(
    trial: &Trial,
    dir: &Path,
    threads: usize,
    hooks: &dyn BatchHooks,
) -> (RunStatus, Option<String>) {
    let failed = |e: String| (RunStatus::Failed, Some(e));
    let scene = match Scene::from_file_with(&trial.scene_path, &trial.sets) {
        Ok(scene) => scene,
        Err(e) => return failed(e.to_string()),
    };
    let overrides = Overrides {
        seed: trial.seed,
        threads: Some(threads),
        ..Overrides::default()
    };
    let built = match scene.build(&overrides) {
        Ok(built) => built,
        Err(e) => return failed(e.to_string()),
    };
    let options = RunOptions {
        out: Some(dir.to_path_buf()),
        ..RunOptions::default()
    };
    match run_scene(&built, &options, &mut Stop(hooks)) {
        Err(e) => failed(e.to_string()),
        Ok(run) => {
            let mut errors: Vec<String> =
                run.write_errors.iter().map(ToString::to_string).collect();
            if let Err(failure) = &run.result {
                errors.insert(0, failure.to_string());
            }
            let error = (!errors.is_empty()).then(|| errors.join("; then "));
            let status = match run.summary.status {
                RunStatus::Completed | RunStatus::EverybodyLeft if error.is_some() => {
                    RunStatus::Failed
                }
                s => s,
            };
            (status, error)
        }
    }
}
