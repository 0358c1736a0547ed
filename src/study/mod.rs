//! Studies of accuracy and cost: the paper's convergence experiment, true errors on exact
//! solutions, and error against CPU time.
//!
//! # The paper's protocol ([`converge`])
//! A reference run at `h_min`; for each `h`,
//!
//! ```text
//!     e_h = max_{i = 1..10} | q_{h_min}(tᵢ) − q_h(tᵢ) |,   tᵢ = t₀ + i (T − t₀)/10,
//! ```
//!
//! the Euclidean norm in `R^d`; the order is the least-squares slope of `log e_h` against
//! `log h` ([`fit_order`]).
//!
//! **Which `q_h(t)`.** The paper's discrete solution is the continuous, piecewise-linear
//! function `qⁿ` with `qⁿ(t_k) = q_k` (its section 3). We evaluate exactly that object: each
//! run records, at every comparison time, the linear interpolation between the two steps
//! around it ([`Sampler`]). So any `T` and any `h` can be compared, even when `tᵢ` is not a
//! multiple of `h` (for the paper's list, `tᵢ` is a common grid point of every `h` only when
//! `tᵢ` is a multiple of 2 s); where `tᵢ` is a grid point, the interpolant is the computed
//! configuration itself.
//!
//! **A short horizon.** The report also fits the order over `[t₀, T_short]` with the same
//! protocol (`tᵢ = t₀ + i (T_short − t₀)/10`), read from the same runs: on `[t₀, T_short]`
//! a run to `T` *is* a run to `T_short`, except that the run to `T_short` would shorten
//! its last step to land on `T_short` where the long run interpolates between two steps —
//! both are the paper's `qⁿ`, up to that last step.
//!
//! **What is compared.** All `d` coordinates, always. In crowds, people who have left keep
//! their coordinates and walk on (see [`crate::crowd::Population`]), so the dimension never
//! changes and `e_h` is well defined; the price is that a person who leaves at different
//! times in two runs carries that difference (times the walking speed) to the end, and two
//! people who leave in a different order differ by the distance between them. This is what
//! makes `e_h` saturate over a whole evacuation; the short horizon shows the order before
//! it does.
//!
//! # True errors ([`exact`])
//! Where the solution is known, [`exact::true_error_study`] measures `|q(tᵢ) − qⁿ(tᵢ)|` with
//! the same protocol, and also the sup over `[t₀, T]` of `|q(t) − qⁿ(t)|`.
//!
//! # Work against precision ([`work_precision`])
//! Error against CPU time over `h` × backend × solver tolerance, and the settings that no
//! other setting beats on both counts.
//!
//! Runs are independent and run in parallel (rayon); each one's CPU time is measured on its
//! own thread ([`thread_cpu_seconds`]). The projectors the studies build keep their
//! projections on that thread ([`ProjectorOptions::threads`] `= 1`), so that the time is the
//! whole of the run's work; a projector from your own factory that starts threads of its own
//! would have their work left out.
//!
//! [`ProjectorOptions::threads`]: crate::backends::ProjectorOptions::threads

mod convergence;
pub mod exact;
mod fit;
pub mod plot;
mod sampling;
pub mod work_precision;

pub use convergence::{
    converge, ConvergenceReport, ConvergenceRow, ConvergenceSettings, ReferenceSummary, RunCost,
    PAPER_HS,
};
pub use fit::{
    fit_order, fit_order_checked, fit_order_positive, round_off_floor, FitCaveat, OrderFit,
    MIN_FIT_POINTS, MIN_R_SQUARED, ROUNDING_FLOOR,
};
pub use sampling::{comparison_times, distance, run_sampled, SampledRun, Sampler};
use sampling::{distances, max_of};

use crate::error::SweepError;
pub use crate::meter::{peak_memory_bytes, thread_cpu_seconds};
use crate::problem::Problem;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use sweeping_api::Projector;

/// Any error a problem or projector factory may return.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// Builds a fresh problem for one run (each run, possibly on its own thread, gets its own).
pub type ProblemFactory<'a> = dyn Fn() -> Result<Problem, BoxError> + Sync + 'a;

/// Builds a fresh projector for one run.
pub type ProjectorFactory<'a> = dyn Fn() -> Result<Box<dyn Projector>, BoxError> + Sync + 'a;

/// Why a study failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StudyError {
    /// The study's settings are malformed (no step sizes, a non-positive `h`, a horizon
    /// outside the run, too few points for a fit…).
    #[error("invalid study settings: {0}")]
    InvalidInput(String),
    /// Building the problem or the projector of a run failed.
    #[error("setting up the run with h = {h}: {source}")]
    Setup {
        /// The run's step.
        h: f64,
        /// What the factory reported.
        #[source]
        source: BoxError,
    },
    /// A run failed.
    #[error("the run with h = {h} failed after {steps} steps (t = {t}): {source}")]
    Run {
        /// The run's step.
        h: f64,
        /// Steps completed before the failure.
        steps: usize,
        /// Time reached.
        t: f64,
        /// The run's error (boxed: a run's error carries the projection's, and a study's
        /// every `Result` would otherwise be as large as the largest).
        #[source]
        source: Box<SweepError>,
    },
    /// Writing an output file failed.
    #[error("writing {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        #[source]
        source: std::io::Error,
    },
    /// Drawing a plot failed.
    #[error("plotting {}: {message}", path.display())]
    Plot {
        /// The file.
        path: PathBuf,
        /// What the plotting library reported.
        message: String,
    },
}

pub(crate) fn write_file(path: &Path, contents: &str) -> Result<(), StudyError> {
    let io = |source| StudyError::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let mut f = std::fs::File::create(path).map_err(io)?;
    f.write_all(contents.as_bytes()).map_err(io)
}

/// Runs `f` over `items`, in parallel when asked.
pub(crate) fn map_runs<T: Sync, R: Send>(
    items: &[T],
    parallel: bool,
    f: impl Fn(&T) -> R + Sync + Send,
) -> Vec<R> {
    if parallel {
        items.par_iter().map(f).collect()
    } else {
        items.iter().map(f).collect()
    }
}
