//! The results table: one row per trial, built from the trial folders alone.

use super::run::trial_dir;
use super::{trial_state, BatchError, Plan, TrialState};
use crate::output::{RunStatus, RunSummary};
use std::path::Path;

/// The outputs of the table, each a number per trial (empty when the trial has none): people,
/// people out and still inside at the end, evacuation time (empty when somebody is left), the
/// flow out in the middle of the run ([`middle_flow`]), last time reached, steps, QP solves, solver iterations, largest overlap and wall
/// penetration, milliseconds per step (all stages), and the trial's wall-clock seconds.
pub const OUTPUTS: &[&str] = &[
    "people",
    "people_out",
    "people_remaining",
    "evacuation_time",
    "flow",
    "t_final",
    "steps",
    "solves",
    "solver_iterations",
    "max_overlap",
    "max_wall_penetration",
    "ms_per_step",
    "wall_seconds",
];

/// The part of the people whose exits open the window of [`middle_flow`].
pub const FLOW_FROM: f64 = 0.2;
/// The part of the people whose exits close it.
pub const FLOW_TO: f64 = 0.8;

/// People out per second between the exit of the first [`FLOW_FROM`] (20 %) of the `people`
/// and that of the first [`FLOW_TO`] (80 %): `(k₂ − k₁) / (t(k₂) − t(k₁))`, `t(k)` the
/// first time `k` people were out (`people_out` as the summary records it, `(t, out)` at each
/// change), `k₁ = ⌈0.2 N⌉`, `k₂ = ⌊0.8 N⌋`. It is the inverse of the mean time gap between
/// consecutive exits over the middle of the run, as bottleneck experiments measure a door's
/// flow: the first exits (through an empty room, before a queue forms) and the last (a
/// thinning queue) are left out. `None` when fewer than 80 % went out (a clogged door, a
/// horizon too short) or the window holds no time.
pub fn middle_flow(people_out: &[(f64, usize)], people: usize) -> Option<f64> {
    let k1 = ((FLOW_FROM * people as f64).ceil() as usize).max(1);
    let k2 = (FLOW_TO * people as f64).floor() as usize;
    if k2 <= k1 {
        return None;
    }
    let time_of = |k: usize| people_out.iter().find(|(_, out)| *out >= k).map(|p| p.0);
    let (t1, t2) = (time_of(k1)?, time_of(k2)?);
    (t2 > t1).then(|| (k2 - k1) as f64 / (t2 - t1))
}

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
            // Who has not arrived yet (a scene's sources) is neither inside nor out.
            "people_out" => s.people_out.last()?.1 as f64,
            "people_remaining" => s.people_remaining as f64,
            "evacuation_time" => s.evacuation_time?,
            "flow" => middle_flow(&s.people_out, s.people)?,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn middle_flow_counts_the_exits_between_20_and_80_percent() {
        // 10 people: k₁ = 2 (out at t = 3), k₂ = 8 (out at t = 6, two at once).
        let out = [
            (0.0, 0),
            (2.0, 1),
            (3.0, 2),
            (4.0, 4),
            (5.5, 6),
            (6.0, 8),
            (9.0, 10),
        ];
        assert_eq!(middle_flow(&out, 10), Some(6.0 / 3.0));
        // 11 people: k₁ = 3, out at t = 4 when the count jumps from 2 to 4; k₂ = 8.
        assert_eq!(middle_flow(&out, 11), Some(5.0 / 2.0));
    }

    #[test]
    fn people_out_leaves_out_who_has_not_arrived() {
        let row = ResultsRow {
            trial: 0,
            scene: "room.toml".into(),
            seed: None,
            parameters: Vec::new(),
            status: "completed".into(),
            error: None,
            summary: Some(RunSummary {
                people: 10,
                people_remaining: 5,
                people_out: vec![(0.0, 0), (4.0, 2), (7.0, 3)],
                ..Default::default()
            }),
            wall_seconds: None,
            dir: String::new(),
        };
        // 3 out, 5 inside, 2 still waiting at their source.
        assert_eq!(row.output("people_out"), Some(3.0));
        assert_eq!(row.output("people_remaining"), Some(5.0));
    }

    #[test]
    fn middle_flow_is_empty_without_its_window() {
        // Fewer than 80 % out: the door clogged, or the run ended first.
        assert_eq!(middle_flow(&[(0.0, 0), (1.0, 5), (2.0, 7)], 10), None);
        // Nobody, one person, or everybody out at once.
        assert_eq!(middle_flow(&[(0.0, 0)], 0), None);
        assert_eq!(middle_flow(&[(0.0, 0), (1.0, 1)], 1), None);
        assert_eq!(middle_flow(&[(0.0, 0), (1.0, 10)], 10), None);
    }
}
