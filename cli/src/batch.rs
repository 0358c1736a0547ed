//! `sweep batch`: a plan of many trials run one per core into one results table, resumable;
//! or written as a Slurm job array (`--slurm`), one trial per task (`--trial N`), and its
//! table built from the trial folders (`--collect`).

use crate::interrupt::Interrupt;
use crate::stdout::{errln, outln};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use sweeping::batch::{
    plot_svg, run_batch, run_trial, slurm_script, trial_state, BatchHooks, BatchSettings, Plan,
    ResultsTable, Trial, TrialRecord, TrialState,
};
use sweeping::output::RunStatus;

/// Arguments of `sweep batch`.
#[derive(clap::Args)]
pub struct BatchArgs {
    /// The plan file (TOML): scenes, overrides (a grid or a list of trials), seeds, plot.
    pub plan: PathBuf,
    /// Output folder (default `out/<plan name>/`): a folder per trial under `trials/`, the
    /// table `results.csv`, the plot `plot.svg`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Trials at once; 0, one per core. Each trial's projections run on one thread.
    #[arg(long, default_value_t = 0)]
    pub jobs: usize,
    /// Run again the trials that failed (by default a failure is a result, kept).
    #[arg(long)]
    pub retry_failed: bool,
    /// List the trials (number, folder, scene, overrides, seed, where each stands) and exit.
    #[arg(long, conflicts_with_all = ["trial", "slurm", "collect"])]
    pub list: bool,
    /// Run trial N alone (what a task of the Slurm array runs); nothing if it has finished.
    #[arg(long, value_name = "N", conflicts_with_all = ["slurm", "collect"])]
    pub trial: Option<usize>,
    /// Write the Slurm job-array script OUT/batch.slurm (a task per trial) and exit.
    #[arg(long, conflicts_with = "collect")]
    pub slurm: bool,
    /// Build the results table (and plot) from the trial folders, running nothing.
    #[arg(long)]
    pub collect: bool,
}

/// Entry point of `sweep batch`.
pub fn main(args: BatchArgs) -> Result<()> {
    let plan = Plan::from_file(&args.plan)?;
    // Every override against every scene, before anything runs.
    plan.check_scenes()?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&plan.name));
    if args.list {
        list(&plan, &out);
        return Ok(());
    }
    if args.slurm {
        return write_slurm(&plan, &args.plan, &out);
    }
    if let Some(n) = args.trial {
        return one_trial(&plan.trial(n)?, &out, args.retry_failed);
    }
    if args.collect {
        let table = ResultsTable::collect(&plan, &out);
        write_table(&plan, &table, &out)?;
        return verdict(&table, &out);
    }
    let interrupt = Interrupt::install();
    let hooks = Terminal {
        total: plan.trial_count(),
        done: AtomicUsize::new(0),
        interrupt,
    };
    let settings = BatchSettings {
        jobs: args.jobs,
        retry_failed: args.retry_failed,
        ..BatchSettings::default()
    };
    errln!(
        "plan `{}`: {} trials → {}",
        plan.name,
        plan.trial_count(),
        out.display()
    );
    let report = run_batch(&plan, &out, &settings, &hooks)?;
    outln!(
        "ran {}, skipped {} (finished before), not run {}",
        report.ran,
        report.skipped,
        report.not_run
    );
    if plan.plot.is_some() {
        outln!("plot: {}", out.join("plot.svg").display());
    }
    verdict(&report.table, &out)
}

/// What `sweep batch` says as trials go.
struct Terminal {
    total: usize,
    done: AtomicUsize,
    interrupt: Option<Interrupt>,
}

impl BatchHooks for Terminal {
    fn finished(&self, trial: &Trial, record: &TrialRecord, skipped: bool) {
        let k = self.done.fetch_add(1, Ordering::SeqCst) + 1;
        if !skipped {
            errln!("[{k}/{}] {}", self.total, describe(trial, record));
        }
    }
    fn stop_requested(&self) -> bool {
        self.interrupt.as_ref().is_some_and(Interrupt::requested)
    }
}

/// One line on a trial that ran: its folder, parameters, status, time and error.
fn describe(trial: &Trial, record: &TrialRecord) -> String {
    let sets: Vec<String> = trial
        .sets
        .iter()
        .map(|s| format!("{}={}", s.key, s.value))
        .chain(trial.seed.map(|s| format!("seed={s}")))
        .collect();
    format!(
        "{} ({}{}{}): {}{}{}",
        trial.dir_name(),
        trial.scene,
        if sets.is_empty() { "" } else { " " },
        sets.join(" "),
        record.status,
        record
            .wall_seconds
            .map(|s| format!(" in {s:.1} s"))
            .unwrap_or_default(),
        record
            .error
            .as_ref()
            .map(|e| format!(": {e}"))
            .unwrap_or_default()
    )
}

fn list(plan: &Plan, out: &Path) {
    outln!("plan `{}`: {} trials", plan.name, plan.trial_count());
    for trial in plan.trials() {
        let state = match trial_state(&trial, out) {
            TrialState::NotRun => "not run".to_string(),
            TrialState::Unfinished(r) | TrialState::Finished(r) => r.status.to_string(),
        };
        let sets: Vec<String> = trial
            .sets
            .iter()
            .map(|s| format!("{}={}", s.key, s.value))
            .collect();
        outln!(
            "{:>5}  {}  {}  {}{}  [{state}]",
            trial.index,
            trial.dir_name(),
            trial.scene,
            sets.join(" "),
            trial.seed.map(|s| format!(" seed={s}")).unwrap_or_default()
        );
    }
}

fn write_slurm(plan: &Plan, plan_file: &Path, out: &Path) -> Result<()> {
    let absolute = |p: &Path| std::path::absolute(p).with_context(|| format!("{}", p.display()));
    let (plan_abs, out_abs) = (absolute(plan_file)?, absolute(out)?);
    let sweep = std::env::current_exe().context("finding the sweep binary's path")?;
    let workdir = std::env::current_dir().context("reading the current folder")?;
    let logs = out_abs.join("slurm");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let script = out_abs.join("batch.slurm");
    std::fs::write(
        &script,
        slurm_script(plan, &plan_abs, &out_abs, &sweep, &workdir),
    )
    .with_context(|| format!("writing {}", script.display()))?;
    outln!(
        "{}: {} tasks, one trial each (logs in {})",
        script.display(),
        plan.trial_count(),
        logs.display()
    );
    outln!("submit:  sbatch {}", script.display());
    outln!(
        "then:    sweep batch {} --out {} --collect",
        plan_file.display(),
        out.display()
    );
    Ok(())
}

/// `--trial N`: runs it unless it has finished; fails when the trial fails, so that the
/// scheduler's accounting shows it.
fn one_trial(trial: &Trial, out: &Path, retry_failed: bool) -> Result<()> {
    if let TrialState::Finished(record) = trial_state(trial, out) {
        if !(retry_failed && record.status == RunStatus::Failed) {
            outln!(
                "{} finished before: {}",
                trial.dir_name(),
                describe(trial, &record)
            );
            return Ok(());
        }
    }
    let Some(record) = run_trial(trial, out, 1, &())? else {
        anyhow::bail!(
            "{}: another process is running this trial",
            trial.dir_name()
        );
    };
    outln!("{}", describe(trial, &record));
    match record.status {
        RunStatus::Completed | RunStatus::EverybodyLeft => Ok(()),
        status => anyhow::bail!("{}: {status}", trial.dir_name()),
    }
}

fn write_table(plan: &Plan, table: &ResultsTable, out: &Path) -> Result<()> {
    table.write_csv(&out.join("results.csv"))?;
    if let Some(p) = &plan.plot {
        let path = out.join("plot.svg");
        std::fs::write(&path, plot_svg(table, p)?)
            .with_context(|| format!("writing {}", path.display()))?;
        outln!("plot: {}", path.display());
    }
    Ok(())
}

/// The table's counts by status; an error when some trial has not run to its end (a failure
/// is a result: it does not make the batch fail).
fn verdict(table: &ResultsTable, out: &Path) -> Result<()> {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for row in &table.rows {
        match counts.iter_mut().find(|(s, _)| *s == row.status) {
            Some((_, n)) => *n += 1,
            None => counts.push((row.status.clone(), 1)),
        }
    }
    let text: Vec<String> = counts.iter().map(|(s, n)| format!("{n} {s}")).collect();
    outln!(
        "results: {} ({})",
        out.join("results.csv").display(),
        text.join(", ")
    );
    let unfinished = table
        .rows
        .iter()
        .filter(|r| !matches!(r.status.as_str(), "completed" | "everybody left" | "failed"))
        .count();
    if unfinished > 0 {
        anyhow::bail!(
            "{unfinished} trial(s) have not run to their end: run the same command again to go on"
        );
    }
    Ok(())
}
