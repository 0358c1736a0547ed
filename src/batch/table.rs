//! The results table: one row per trial, built from the trial folders alone.

use super::run::trial_dir;
use super::{trial_state, BatchError, Plan, TrialState};
use crate::output::{RunStatus, RunSummary};
use std::path::Path;

/// The outputs of the table, each a number per trial (empty when the trial has none): people,
/// people out and still inside at the end, evacuation time (empty when somebody is left),
/// last time reached, steps, QP solves, solver iterations, largest overlap and wall
/// penetration, milliseconds per step (all stages), and the trial's wall-clock seconds.
pub const OUTPUTS: &[&str] = &[
    "people",
    "people_out",
    "people_remaining",
    "evacuation_time",
    "t_final",
    "steps",
    "solves",
    "solver_iterations",
    "max_overlap",
    "max_wall_penetration",
    "ms_per_step",
    "wall_seconds",
];

/// One trial's row.
#[derive(Debug, Clone, PartialEq)]
pub struct ResultsRow {
    /// The trial's number.
    pub trial: usize,
    /// The scene as the plan names it.
    pub scene: String,
    /// The seed, when the plan gives seeds.
    pub seed: Option<u64>,
    /// The value of each of the plan's parameters ([`Plan::parameters`]), when the trial sets
    /// it.
    pub parameters: Vec<Option<String>>,
    /// `not run`, `running` (now, or killed: it runs again), `interrupted`, `completed`,
    /// `everybody left` or `failed`.
    pub status: String,
    /// Why it failed or stopped.
    pub error: Option<String>,
    /// The run's summary (`summary.json`), when the trial wrote one and is not running.
    pub summary: Option<RunSummary>,
    /// The trial's wall-clock seconds.
    pub wall_seconds: Option<f64>,
    /// Its folder, relative to the batch's output folder.
    pub dir: String,
}

impl ResultsRow {
    /// The value of `output` (one of [`OUTPUTS`]), when the trial has it.
    pub fn output(&self, output: &str) -> Option<f64> {
        if output == "wall_seconds" {
            return self.wall_seconds;
        }
        let s = self.summary.as_ref()?;
        Some(match output {
            "people" => s.people as f64,
            "people_out" => (s.people - s.people_remaining) as f64,
            "people_remaining" => s.people_remaining as f64,
            "evacuation_time" => s.evacuation_time?,
            "t_final" => s.t_final,
            "steps" => s.steps as f64,
            "solves" => s.solves as f64,
            "solver_iterations" => s.solver_iterations as f64,
            "max_overlap" => s.max_overlap,
            "max_wall_penetration" => s.max_wall_penetration,
            "ms_per_step" => s.ms_per_step.total,
            _ => return None,
        })
    }
}

/// The results of a plan's trials.
#[derive(Debug, Clone, PartialEq)]
pub struct ResultsTable {
    /// The plan's parameters: the columns between `seed` and `status`.
    pub parameters: Vec<String>,
    /// One row per trial, in the plan's order.
    pub rows: Vec<ResultsRow>,
}

impl ResultsTable {
    /// The table of `plan`'s trials as their folders under `out` say: what `sweep batch`
    /// writes after its runs, and `sweep batch --collect` after a cluster's.
    pub fn collect(plan: &Plan, out: &Path) -> ResultsTable {
        let parameters = plan.parameters().to_vec();
        let rows = plan
            .trials()
            .iter()
            .map(|trial| {
                let dir = trial_dir(out, trial);
                let record = match trial_state(trial, out) {
                    TrialState::NotRun => None,
                    TrialState::Unfinished(r) | TrialState::Finished(r) => Some(r),
                };
                let summary = record
                    .as_ref()
                    .filter(|r| r.status != RunStatus::Running)
                    .and_then(|_| std::fs::read_to_string(dir.join("summary.json")).ok())
                    .and_then(|t| serde_json::from_str::<RunSummary>(&t).ok());
                ResultsRow {
                    trial: trial.index,
                    scene: trial.scene.clone(),
                    seed: trial.seed,
                    parameters: parameters.iter().map(|p| trial.parameter(p)).collect(),
                    status: record
                        .as_ref()
                        .map_or("not run".to_string(), |r| r.status.to_string()),
                    error: record.as_ref().and_then(|r| r.error.clone()),
                    wall_seconds: record.as_ref().and_then(|r| r.wall_seconds),
                    summary,
                    dir: format!("trials/{}", trial.dir_name()),
                }
            })
            .collect();
        ResultsTable { parameters, rows }
    }

    /// The column names: `trial, scene, seed`, the parameters, `status, error`, the
    /// [`OUTPUTS`], `dir`.
    pub fn header(&self) -> Vec<String> {
        ["trial", "scene", "seed"]
            .iter()
            .map(|s| s.to_string())
            .chain(self.parameters.iter().cloned())
            .chain(["status".to_string(), "error".to_string()])
            .chain(OUTPUTS.iter().map(|s| s.to_string()))
            .chain(["dir".to_string()])
            .collect()
    }

    /// Writes the table as CSV (numbers as the shortest text that reads back to the same
    /// value; empty cells for what a trial lacks).
    ///
    /// # Errors
    /// [`BatchError::Io`] when the file cannot be written.
    pub fn write_csv(&self, path: &Path) -> Result<(), BatchError> {
        let io = |e: String| BatchError::Io {
            path: path.to_path_buf(),
            message: e,
        };
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(self.header())
            .map_err(|e| io(e.to_string()))?;
        let opt = |v: Option<String>| v.unwrap_or_default();
        for row in &self.rows {
            let mut record = vec![
                row.trial.to_string(),
                row.scene.clone(),
                opt(row.seed.map(|s| s.to_string())),
            ];
            record.extend(row.parameters.iter().cloned().map(opt));
            record.push(row.status.clone());
            record.push(opt(row.error.clone()));
            record.extend(
                OUTPUTS
                    .iter()
                    .map(|o| opt(row.output(o).map(|v| v.to_string()))),
            );
            record.push(row.dir.clone());
            w.write_record(&record).map_err(|e| io(e.to_string()))?;
        }
        let bytes = w.into_inner().map_err(|e| io(e.to_string()))?;
        crate::output::write_whole(path, bytes).map_err(|e| io(e.to_string()))
    }
}
