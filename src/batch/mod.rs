//! Many runs, one table: a batch plan (scenes × overrides × seeds) expanded into trials, each
//! run into its own folder with the usual outputs, and a results table with each trial's
//! parameters, status and summary numbers.
//!
//! * [`Plan`] — the plan file (TOML), checked and expanded into [`Trial`]s;
//! * [`run_batch`] — every trial not yet finished, one per core, resumable; [`run_trial`]
//!   runs one (what a Slurm array task does);
//! * [`ResultsTable`] — the table, built from the trial folders alone
//!   ([`ResultsTable::collect`]), written as CSV; [`plot_svg`] draws an output, or an output
//!   divided by a parameter, against a parameter, mean and spread over seeds, over a
//!   reference band;
//! * [`slurm_script`] — a Slurm job-array script whose tasks each run one trial.
//!
//! ```
//! use sweeping::batch::Plan;
//! let dir = std::env::temp_dir().join(format!("sweep-batch-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! std::fs::write(dir.join("room.toml"), r#"
//!     [room]
//!     rectangle = [0.0, 0.0, 4.0, 4.0]
//!     [[crowds]]
//!     count = 3
//!     region = [0.0, 0.0, 2.0, 4.0]
//!     radius = 0.2
//! "#).unwrap();
//! let plan = Plan::from_toml_str(r#"
//!     scenes = ["room.toml"]
//!     seeds = [1, 2]
//!     [grid]
//!     "crowds.0.count" = [3, 5]
//!     "crowds.0.radius" = [0.2, 0.25]
//! "#, &dir.join("plan.toml")).unwrap();
//! let trials = plan.trials();
//! assert_eq!(trials.len(), 8); // 1 scene × 2 × 2 values × 2 seeds
//! assert_eq!(trials[1].sets[1].to_string(), "--set crowds.0.radius=0.2");
//! assert_eq!(trials[1].seed, Some(2));
//! plan.check_scenes().unwrap();
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

mod plan;
mod plot;
mod run;
mod slurm;
mod table;

pub use plan::{Plan, PlotBand, PlotSpec, SlurmSpec, Trial};
pub use plot::plot_svg;
pub use run::{
    run_batch, run_trial, trial_state, BatchHooks, BatchReport, BatchSettings, TrialRecord,
    TrialState, RECORD_FILE,
};
pub use slurm::slurm_script;
pub use table::{middle_flow, ResultsRow, ResultsTable, FLOW_FROM, FLOW_TO, OUTPUTS};

use std::path::PathBuf;

/// Why a plan could not be read, checked or run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BatchError {
    /// A file or folder could not be read or written.
    #[error("{}: {message}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// The plan is not valid TOML, or has an unknown key or a wrong type.
    #[error("{file}:{line}:{column}: {message}")]
    Parse {
        /// The plan file.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// The plan parses but cannot be run as written.
    #[error("{}: {item}: {message}", location(file, *line))]
    Invalid {
        /// The plan file.
        file: String,
        /// The item's line, when it has one.
        line: Option<usize>,
        /// The item: `scenes[0]`, `[grid] crowds.0.count`, `[[trials]] #2`, `[plot]`…
        item: String,
        /// What is wrong.
        message: String,
    },
    /// An override of the plan does not fit one of its scenes.
    #[error("{}: {item}: {source}", location(file, *line))]
    Scene {
        /// The plan file.
        file: String,
        /// The line of the override in the plan.
        line: Option<usize>,
        /// The item the override comes from.
        item: String,
        /// The scene's error, naming the scene file and the override.
        source: Box<crate::scene::SceneError>,
    },
    /// A trial number past the plan's trials.
    #[error("trial {trial}: the plan has {count} trials, numbered from 0")]
    NoSuchTrial {
        /// The number asked for.
        trial: usize,
        /// How many there are.
        count: usize,
    },
    /// The plot asked for cannot be drawn from the table.
    #[error("plot: {0}")]
    Plot(String),
    /// The threads to run trials on could not be started.
    #[error("cannot start {jobs} threads for the trials: {message}")]
    Threads {
        /// Threads asked for.
        jobs: usize,
        /// The system's message.
        message: String,
    },
}

fn location(file: &str, line: Option<usize>) -> String {
    match line {
        Some(l) => format!("{file}:{l}"),
        None => file.to_string(),
    }
}

impl BatchError {
    /// The line of the plan the error points at, if any.
    pub fn line(&self) -> Option<usize> {
        match self {
            BatchError::Parse { line, .. } => Some(*line),
            BatchError::Invalid { line, .. } | BatchError::Scene { line, .. } => *line,
            _ => None,
        }
    }
}
