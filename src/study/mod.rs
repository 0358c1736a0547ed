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

pub mod exact;
pub mod plot;
pub mod work_precision;

use crate::error::SweepError;
pub use crate::meter::{peak_memory_bytes, thread_cpu_seconds};
use crate::problem::Problem;
use crate::stepper::{
    step_count, Observer, ObserverError, RunStats, StepReport, Stepper, StepperSettings, Trajectory,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;
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

/// A least-squares fit `log e = log C + p log h`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrderFit {
    /// The slope `p`: the fitted order.
    pub order: f64,
    /// `C` (the error the fit predicts at `h = 1`).
    pub constant: f64,
    /// Coefficient of determination of the fit in log–log coordinates (1 for an exact power
    /// law).
    pub r_squared: f64,
    /// Points used.
    pub points: usize,
    /// Why the slope is not to be read as an order of convergence, if it is not.
    #[serde(default)]
    pub caveat: Option<FitCaveat>,
}

/// Why a fitted slope cannot be trusted as an order of convergence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
#[non_exhaustive]
pub enum FitCaveat {
    /// Fewer than two errors lie above the round-off floor: the slope is fitted to rounding.
    RoundOff {
        /// The largest round-off floor of the points ([`round_off_floor`]).
        floor: f64,
        /// The largest error.
        largest_error: f64,
    },
    /// Fewer than [`MIN_FIT_POINTS`] usable points: errors above the round-off floor, from
    /// runs with different step counts.
    TooFewPoints {
        /// Usable points.
        usable: usize,
    },
    /// Two step sizes take the same number of steps, so their runs are the same run.
    RepeatedSteps {
        /// The step count they share.
        steps: usize,
    },
    /// The points do not lie on a power law: `R²` is below [`MIN_R_SQUARED`].
    PoorFit {
        /// The fit's `R²`.
        r_squared: f64,
    },
}

impl std::fmt::Display for FitCaveat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::RoundOff {
                floor,
                largest_error,
            } => write!(
                f,
                "the errors are round-off (largest {largest_error:.2e}, floor {floor:.2e})"
            ),
            Self::TooFewPoints { usable } => write!(
                f,
                "{usable} usable point(s) above round-off, at least {MIN_FIT_POINTS} are needed"
            ),
            Self::RepeatedSteps { steps } => write!(
                f,
                "two step sizes both take {steps} step(s): their runs are the same run"
            ),
            Self::PoorFit { r_squared } => write!(
                f,
                "the errors do not follow a power law (R² = {r_squared:.3} < {MIN_R_SQUARED})"
            ),
        }
    }
}

/// Fewest usable points for a fitted order to be trusted: two points always fit exactly.
pub const MIN_FIT_POINTS: usize = 3;

/// Lowest `R²` of a trusted fit: below it the errors are not a power law of `h`.
pub const MIN_R_SQUARED: f64 = 0.9;

impl OrderFit {
    /// The error the fit predicts at `h`: `C h^p`.
    pub fn predict(&self, h: f64) -> f64 {
        self.constant * h.powf(self.order)
    }

    /// The order with its `R²` and points, or, when the fit has a caveat, the caveat in its
    /// place (the slope follows in parentheses, marked as no order).
    pub fn describe(&self) -> String {
        match self.caveat {
            None => format!(
                "{:.3} (R² = {:.3}, {} points)",
                self.order, self.r_squared, self.points
            ),
            Some(c) => format!(
                "no trustworthy order: {c} (slope {:.3} over {} points is not an order)",
                self.order, self.points
            ),
        }
    }
}

/// Least-squares slope of `log es` against `log hs`: the empirical order of convergence.
///
/// ```
/// use sweeping::study::fit_order;
/// let hs = [0.1, 0.05, 0.025];
/// let es: Vec<f64> = hs.iter().map(|h: &f64| 3.0 * h.sqrt()).collect();
/// let fit = fit_order(&hs, &es).unwrap();
/// assert!((fit.order - 0.5).abs() < 1e-12 && (fit.constant - 3.0).abs() < 1e-12);
/// ```
///
/// # Errors
/// [`StudyError::InvalidInput`] when the lengths differ, fewer than two points are given, a
/// value is not finite and positive, or all `h` are equal.
pub fn fit_order(hs: &[f64], es: &[f64]) -> Result<OrderFit, StudyError> {
    if hs.len() != es.len() {
        return Err(StudyError::InvalidInput(format!(
            "fit_order: {} step sizes but {} errors",
            hs.len(),
            es.len()
        )));
    }
    if hs.len() < 2 {
        return Err(StudyError::InvalidInput(format!(
            "fit_order needs at least two points, got {}",
            hs.len()
        )));
    }
    if let Some((h, e)) = hs
        .iter()
        .zip(es)
        .find(|(h, e)| !(h.is_finite() && **h > 0.0 && e.is_finite() && **e > 0.0))
    {
        return Err(StudyError::InvalidInput(format!(
            "fit_order needs finite positive values, got h = {h}, e = {e}"
        )));
    }
    let n = hs.len() as f64;
    let x: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let y: Vec<f64> = es.iter().map(|e| e.ln()).collect();
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let syy: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
    if sxx <= 1e-300 {
        return Err(StudyError::InvalidInput(
            "fit_order: all step sizes are equal, the slope is undefined".into(),
        ));
    }
    let order = sxy / sxx;
    let intercept = my - order * mx;
    let sse: f64 = x
        .iter()
        .zip(&y)
        .map(|(a, b)| (b - intercept - order * a).powi(2))
        .sum();
    let r_squared = if syy > 0.0 { 1.0 - sse / syy } else { 1.0 };
    Ok(OrderFit {
        order,
        constant: intercept.exp(),
        r_squared,
        points: hs.len(),
        caveat: None,
    })
}

/// The error below which a distance between two runs of `steps` steps in `dim` coordinates
/// of size up to `scale` measures rounding, not discretization: `10 √dim · steps · ε · scale`,
/// and at least [`ROUNDING_FLOOR`].
///
/// Each step rounds every coordinate by about `ε · scale`, and the rounding accumulates over
/// the steps; the factor 10 leaves room for projections that round more than once per step.
pub fn round_off_floor(steps: usize, dim: usize, scale: f64) -> f64 {
    let floor = 10.0 * (dim as f64).sqrt() * steps as f64 * f64::EPSILON * scale.abs();
    if floor.is_finite() {
        floor.max(ROUNDING_FLOOR)
    } else {
        ROUNDING_FLOOR
    }
}

/// [`fit_order`] over the usable points, with a [`FitCaveat`] when its slope cannot be
/// trusted; `None` when no slope can be fitted at all.
///
/// Point `i` has step `hs[i]`, error `es[i]`, step count `steps[i]` and round-off floor
/// `floors[i]`. It is usable when its error exceeds its floor and no earlier point has the
/// same step count. With fewer than two usable points, the slope is fitted over all positive
/// errors of distinct `h` and carries the reason ([`FitCaveat::RoundOff`] or
/// [`FitCaveat::RepeatedSteps`]); with fewer than [`MIN_FIT_POINTS`], or an `R²` below
/// [`MIN_R_SQUARED`], it carries that.
///
/// ```
/// use sweeping::study::{fit_order_checked, FitCaveat};
/// let hs = [0.1, 0.05, 0.025, 0.0125];
/// let es = [2e-11, 3e-12, 8e-11, 4e-12]; // round-off, under each run's floor
/// let fit = fit_order_checked(&hs, &es, &[100, 200, 400, 800], &[1e-10; 4]).unwrap();
/// assert!(matches!(fit.caveat, Some(FitCaveat::RoundOff { .. })));
/// ```
pub fn fit_order_checked(
    hs: &[f64],
    es: &[f64],
    steps: &[usize],
    floors: &[f64],
) -> Option<OrderFit> {
    let n = hs.len().min(es.len()).min(steps.len()).min(floors.len());
    let mut seen: Vec<usize> = Vec::new();
    let mut repeated = None;
    let (mut uh, mut ue) = (Vec::new(), Vec::new());
    for i in 0..n {
        if seen.contains(&steps[i]) {
            repeated = Some(steps[i]);
            continue;
        }
        seen.push(steps[i]);
        if es[i].is_finite() && es[i] > floors[i] {
            uh.push(hs[i]);
            ue.push(es[i]);
        }
    }
    if uh.len() >= 2 {
        let mut fit = fit_order(&uh, &ue).ok()?;
        fit.caveat = if let Some(steps) = repeated.filter(|_| uh.len() < MIN_FIT_POINTS) {
            Some(FitCaveat::RepeatedSteps { steps })
        } else if uh.len() < MIN_FIT_POINTS {
            Some(FitCaveat::TooFewPoints { usable: uh.len() })
        } else if fit.r_squared < MIN_R_SQUARED {
            Some(FitCaveat::PoorFit {
                r_squared: fit.r_squared,
            })
        } else {
            None
        };
        return Some(fit);
    }
    // Too few usable points: the slope of whatever there is, labelled with the reason.
    let (ah, ae): (Vec<f64>, Vec<f64>) = hs[..n]
        .iter()
        .zip(&es[..n])
        .filter(|(_, e)| e.is_finite() && **e > 0.0)
        .map(|(h, e)| (*h, *e))
        .unzip();
    let mut fit = fit_order(&ah, &ae).ok()?;
    fit.caveat = Some(match repeated {
        Some(steps) => FitCaveat::RepeatedSteps { steps },
        None => FitCaveat::RoundOff {
            floor: floors[..n].iter().copied().fold(0.0, f64::max),
            largest_error: max_of(&ae),
        },
    });
    Some(fit)
}

/// Errors at or below this are rounding, not discretization: [`fit_order_positive`] leaves
/// them out (the scheme can be exact at grid points, e.g. for disks on a line).
pub const ROUNDING_FLOOR: f64 = 1e-12;

/// [`fit_order`] over the points whose error exceeds [`ROUNDING_FLOOR`] (an error of zero —
/// a run that reproduces the reference — has no logarithm, and one of `1e-16` measures
/// rounding); `None` when fewer than two remain.
pub fn fit_order_positive(hs: &[f64], es: &[f64]) -> Option<OrderFit> {
    let (h, e): (Vec<f64>, Vec<f64>) = hs
        .iter()
        .zip(es)
        .filter(|(_, e)| e.is_finite() && **e > ROUNDING_FLOOR)
        .map(|(h, e)| (*h, *e))
        .unzip();
    fit_order(&h, &e).ok()
}

/// The comparison times `tᵢ = t₀ + i (T − t₀)/count`, `i = 1..=count`.
pub fn comparison_times(t0: f64, t_end: f64, count: usize) -> Vec<f64> {
    (1..=count)
        .map(|i| {
            if i == count {
                t_end
            } else {
                t0 + i as f64 * (t_end - t0) / count as f64
            }
        })
        .collect()
}

/// An observer that records the piecewise-linear interpolant `qⁿ(s)` at given times.
///
/// The times must be sorted and lie in `[t₀, T]`; a time within `1e-9` (relative) of a step
/// time takes that step's configuration.
#[derive(Debug, Clone)]
pub struct Sampler {
    times: Vec<f64>,
    samples: Vec<Vec<f64>>,
    t_prev: f64,
    q_prev: Vec<f64>,
}

impl Sampler {
    /// A sampler for `times` (sorted ascending).
    pub fn new(times: Vec<f64>) -> Self {
        Self {
            times,
            samples: Vec::new(),
            t_prev: f64::NEG_INFINITY,
            q_prev: Vec::new(),
        }
    }

    /// The requested times.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The samples taken so far, one per requested time, in order.
    pub fn samples(&self) -> &[Vec<f64>] {
        &self.samples
    }

    /// The samples, consumed.
    pub fn into_samples(self) -> Vec<Vec<f64>> {
        self.samples
    }

    fn take_up_to(&mut self, t: f64, q: &[f64]) {
        let eps = 1e-9 * t.abs().max(1.0);
        while let Some(&s) = self.times.get(self.samples.len()) {
            if s > t + eps {
                break;
            }
            let span = t - self.t_prev;
            let w = if span > 0.0 && s < t - eps {
                ((s - self.t_prev) / span).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let sample = if w >= 1.0 {
                q.to_vec()
            } else {
                self.q_prev
                    .iter()
                    .zip(q)
                    .map(|(a, b)| a + w * (b - a))
                    .collect()
            };
            self.samples.push(sample);
        }
        self.t_prev = t;
        self.q_prev.clear();
        self.q_prev.extend_from_slice(q);
    }
}

impl Observer for Sampler {
    fn name(&self) -> &str {
        "sampler"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        if let Some(&s) = self.times.first() {
            if s < t - 1e-9 * t.abs().max(1.0) {
                return Err(format!("sample time {s} is before the start t₀ = {t}").into());
            }
        }
        self.t_prev = t;
        self.take_up_to(t, q);
        Ok(())
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        self.take_up_to(report.t, q);
        Ok(())
    }
}

/// One run of a study: the configurations at the requested times and what the run cost.
#[derive(Debug, Clone)]
pub struct SampledRun {
    /// Time step.
    pub h: f64,
    /// `qⁿ(s)` at each requested time.
    pub samples: Vec<Vec<f64>>,
    /// Every step's configuration when asked for, else the start and the end only.
    pub trajectory: Trajectory,
    /// CPU seconds of the run's thread (wall seconds where CPU time is unavailable).
    pub cpu_seconds: f64,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// The run's totals (steps, iterations, time per stage, worst violation).
    pub stats: RunStats,
}

/// Runs the scheme once with step `h` up to `t_end` and samples `qⁿ` at `times` (sorted, in
/// `[t₀, t_end]`); with `keep_trajectory`, also keeps every step.
///
/// # Errors
/// [`StudyError::Setup`] when a factory fails, [`StudyError::Run`] when the run does.
pub fn run_sampled(
    make_problem: &ProblemFactory<'_>,
    make_projector: &ProjectorFactory<'_>,
    base: &StepperSettings,
    h: f64,
    t_end: f64,
    times: &[f64],
    keep_trajectory: bool,
) -> Result<SampledRun, StudyError> {
    let problem = make_problem().map_err(|source| StudyError::Setup { h, source })?;
    let mut projector = make_projector().map_err(|source| StudyError::Setup { h, source })?;
    let settings = StepperSettings {
        h,
        t_end,
        record_every: usize::from(keep_trajectory),
        ..base.clone()
    };
    let stepper = Stepper::new(&problem, settings).map_err(|source| StudyError::Run {
        h,
        steps: 0,
        t: problem.t0(),
        source: Box::new(source),
    })?;
    let mut sampler = Sampler::new(times.to_vec());
    let cpu0 = thread_cpu_seconds();
    let wall0 = Instant::now();
    let result = stepper.run(projector.as_mut(), &mut [&mut sampler]);
    let wall_seconds = wall0.elapsed().as_secs_f64();
    let cpu_seconds = match (cpu0, thread_cpu_seconds()) {
        (Some(a), Some(b)) => b - a,
        _ => wall_seconds,
    };
    let run = result.map_err(|failure| StudyError::Run {
        h,
        steps: failure.partial.stats.steps,
        t: failure.partial.t_final,
        source: Box::new(failure.error),
    })?;
    if sampler.samples().len() != times.len() {
        return Err(StudyError::InvalidInput(format!(
            "the run with h = {h} ended at t = {} before the last comparison time {}",
            run.t_final,
            times.last().copied().unwrap_or(f64::NAN)
        )));
    }
    Ok(SampledRun {
        h,
        samples: sampler.into_samples(),
        trajectory: run.trajectory,
        cpu_seconds,
        wall_seconds,
        stats: run.stats,
    })
}

/// Euclidean distance between two configurations.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Settings of the convergence experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceSettings {
    /// Step of the reference run. The paper: `0.01`.
    pub h_min: f64,
    /// Steps compared with the reference (each `> h_min`). The paper: `0.02, 0.025, 0.04,
    /// 0.05, 0.0625, 0.08, 0.1, 0.2, 0.5`.
    pub hs: Vec<f64>,
    /// The horizon `T`.
    pub t_end: f64,
    /// A second, short horizon (`t₀ < T_short ≤ T`), or none.
    pub t_short: Option<f64>,
    /// Comparison times per horizon. The paper: 10.
    pub samples: usize,
    /// Run the step sizes in parallel (rayon). Default `true`.
    pub parallel: bool,
}

impl ConvergenceSettings {
    /// The paper's steps (`h_min = 0.01`, nine `h`), 10 comparison times, horizon `t_end`,
    /// short horizon 2 s when `t_end > 2`.
    pub fn paper(t_end: f64) -> Self {
        Self {
            h_min: 0.01,
            hs: PAPER_HS.to_vec(),
            t_end,
            t_short: (t_end > 2.0).then_some(2.0),
            samples: 10,
            parallel: true,
        }
    }

    fn validate(&self, t0: f64) -> Result<(), StudyError> {
        let bad = |m: String| Err(StudyError::InvalidInput(m));
        if !(self.h_min.is_finite() && self.h_min > 0.0) {
            return bad(format!("h_min = {} must be positive", self.h_min));
        }
        if self.hs.is_empty() {
            return bad("no step sizes to compare".into());
        }
        if let Some(h) = self
            .hs
            .iter()
            .find(|h| !(h.is_finite() && **h > self.h_min))
        {
            return bad(format!(
                "every compared h must exceed h_min = {}; got {h}",
                self.h_min
            ));
        }
        if !(self.t_end.is_finite() && self.t_end > t0) {
            return bad(format!("T = {} must exceed t₀ = {t0}", self.t_end));
        }
        if let Some(ts) = self.t_short {
            if !(ts > t0 && ts <= self.t_end) {
                return bad(format!(
                    "the short horizon {ts} must lie in (t₀, T] = ({t0}, {}]",
                    self.t_end
                ));
            }
        }
        if self.samples == 0 {
            return bad("at least one comparison time is needed".into());
        }
        // Two step sizes with one step count are one run twice: their errors fit a slope of 0.
        let span = self.t_end - t0;
        let mut counts: Vec<(usize, f64)> = Vec::new();
        for &h in std::iter::once(&self.h_min).chain(&self.hs) {
            let n = step_count(span, h);
            if let Some((_, other)) = counts.iter().find(|(m, _)| *m == n) {
                return bad(format!(
                    "h = {other} and h = {h} both take {n} step(s) over T − t₀ = {span}: their \
                     runs are the same run; give step sizes with different step counts"
                ));
            }
            counts.push((n, h));
        }
        Ok(())
    }
}

/// The paper's compared step sizes.
pub const PAPER_HS: [f64; 9] = [0.02, 0.025, 0.04, 0.05, 0.0625, 0.08, 0.1, 0.2, 0.5];

/// One step size of a convergence study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRow {
    /// Time step.
    pub h: f64,
    /// `e_h` over the whole horizon.
    pub error: f64,
    /// `e_h` over the short horizon.
    pub error_short: Option<f64>,
    /// `|q_ref(tᵢ) − qⁿ(tᵢ)|` at each comparison time of the whole horizon.
    pub errors_at: Vec<f64>,
    /// `|q_ref(tᵢ) − qⁿ(tᵢ)|` at each comparison time of the short horizon.
    pub errors_at_short: Vec<f64>,
    /// For exact solutions: `sup_t |q(t) − qⁿ(t)|` (see [`exact::true_error_study`]).
    pub error_sup: Option<f64>,
    /// The error at or below which this row measures rounding ([`round_off_floor`]).
    #[serde(default)]
    pub round_off: f64,
    /// What the run cost (flattened into the row's JSON).
    #[serde(flatten)]
    pub cost: RunCost,
}

/// What one run of a study cost, and how far it strayed from the true constraints.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunCost {
    /// CPU seconds of the run's thread (wall seconds where CPU time is unavailable).
    pub cpu_seconds: f64,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// Steps.
    pub steps: usize,
    /// Solver iterations, summed.
    pub iterations: u64,
    /// Largest violation of the true constraints after any step.
    pub max_violation: f64,
}

impl RunCost {
    /// The cost of `run`.
    pub fn of(run: &SampledRun) -> Self {
        Self {
            cpu_seconds: run.cpu_seconds,
            wall_seconds: run.wall_seconds,
            steps: run.stats.steps,
            iterations: run.stats.iterations,
            max_violation: run.stats.max_violation,
        }
    }

    /// A run that failed: no steps counted, times and violation unknown (NaN).
    pub fn failed() -> Self {
        Self {
            cpu_seconds: f64::NAN,
            wall_seconds: f64::NAN,
            steps: 0,
            iterations: 0,
            max_violation: f64::NAN,
        }
    }
}

/// The reference run's cost.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReferenceSummary {
    /// Its step (`h_min`), or 0 for an exact solution.
    pub h: f64,
    /// CPU seconds.
    pub cpu_seconds: f64,
    /// Steps.
    pub steps: usize,
    /// Solver iterations.
    pub iterations: u64,
}

/// The outcome of [`converge`] (or of [`exact::true_error_study`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceReport {
    /// What was studied.
    pub label: String,
    /// The settings.
    pub settings: ConvergenceSettings,
    /// Comparison times of the whole horizon.
    pub times: Vec<f64>,
    /// Comparison times of the short horizon.
    pub times_short: Vec<f64>,
    /// The reference run (absent for an exact solution).
    pub reference: Option<ReferenceSummary>,
    /// One row per compared `h`, in the order given.
    pub rows: Vec<ConvergenceRow>,
    /// Fitted order over the whole horizon.
    pub order: Option<OrderFit>,
    /// Fitted order over the short horizon.
    pub order_short: Option<OrderFit>,
    /// Fitted order of the sup-norm error (exact solutions).
    pub order_sup: Option<OrderFit>,
}

impl ConvergenceRow {
    /// The row of `run` whose distances at the comparison times of the whole horizon are
    /// `errors_at`: `e_h` is their max, the costs are the run's; the short horizon and the sup
    /// error are left empty for the caller to fill.
    fn measured(run: &SampledRun, errors_at: Vec<f64>) -> Self {
        Self {
            h: run.h,
            error: max_of(&errors_at),
            error_short: None,
            errors_at,
            errors_at_short: Vec::new(),
            error_sup: None,
            round_off: run.round_off(run.stats.steps),
            cost: RunCost::of(run),
        }
    }
}

impl SampledRun {
    /// The round-off floor of a distance to this run from a run of `steps` steps: the larger
    /// step count and the largest coordinate of this run's samples ([`round_off_floor`]).
    fn round_off(&self, steps: usize) -> f64 {
        let scale = self
            .samples
            .iter()
            .flatten()
            .chain(self.trajectory.states.iter().flatten())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let dim = self.samples.first().map_or(0, Vec::len);
        round_off_floor(steps.max(self.stats.steps), dim, scale)
    }
}

impl ReferenceSummary {
    /// The cost of the reference `run`, made with step `h`.
    fn of(h: f64, run: &SampledRun) -> Self {
        Self {
            h,
            cpu_seconds: run.cpu_seconds,
            steps: run.stats.steps,
            iterations: run.stats.iterations,
        }
    }
}

/// The largest of `values` (0 for none): `e_h = max_i |q_ref(tᵢ) − qⁿ(tᵢ)|`.
fn max_of(values: &[f64]) -> f64 {
    values.iter().copied().fold(0.0, f64::max)
}

/// `|aᵢ − bᵢ|` at each comparison time, from two runs' (or a run's and the exact) samples.
fn distances(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| distance(a, b)).collect()
}

impl ConvergenceReport {
    fn fit(&mut self) {
        let (hs, steps, floors) = self.fit_inputs();
        let es: Vec<f64> = self.rows.iter().map(|r| r.error).collect();
        self.order = fit_order_checked(&hs, &es, &steps, &floors);
        let short: Option<Vec<f64>> = self.rows.iter().map(|r| r.error_short).collect();
        self.order_short = short.and_then(|es| fit_order_checked(&hs, &es, &steps, &floors));
        let sup: Option<Vec<f64>> = self.rows.iter().map(|r| r.error_sup).collect();
        self.order_sup = sup.and_then(|es| fit_order_checked(&hs, &es, &steps, &floors));
    }

    /// Each row's `h`, step count and round-off floor, for [`fit_order_checked`].
    fn fit_inputs(&self) -> (Vec<f64>, Vec<usize>, Vec<f64>) {
        let hs = self.rows.iter().map(|r| r.h).collect();
        let steps = self.rows.iter().map(|r| r.cost.steps).collect();
        let floors = self
            .rows
            .iter()
            .map(|r| r.round_off.max(ROUNDING_FLOOR))
            .collect();
        (hs, steps, floors)
    }

    /// The fitted order of `e_h` at each comparison time `tᵢ` alone (not the max over
    /// `t ≤ tᵢ`): how the order changes along the run; `None` where it cannot be fitted.
    pub fn order_at_times(&self) -> Vec<(f64, Option<OrderFit>)> {
        let (hs, steps, floors) = self.fit_inputs();
        self.times
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let es: Vec<f64> = self.rows.iter().map(|r| r.errors_at[i]).collect();
                (t, fit_order_checked(&hs, &es, &steps, &floors))
            })
            .collect()
    }

    /// Writes the per-`h` table.
    ///
    /// Columns: `h`, `error` (`e_h`, whole horizon), `error_short` (short horizon, empty if
    /// none), `error_sup` (exact solutions only), `cpu_seconds`, `wall_seconds`, `steps`,
    /// `iterations`, `max_violation`. The fitted orders follow as comment lines starting with
    /// `#`.
    ///
    /// # Errors
    /// [`StudyError::Io`].
    pub fn write_csv(&self, path: &Path) -> Result<(), StudyError> {
        let mut s = String::from(
            "h,error,error_short,error_sup,cpu_seconds,wall_seconds,steps,iterations,max_violation\n",
        );
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.9e}")).unwrap_or_default();
        for r in &self.rows {
            s.push_str(&format!(
                "{},{:.9e},{},{},{:.6},{:.6},{},{},{:.3e}\n",
                r.h,
                r.error,
                opt(r.error_short),
                opt(r.error_sup),
                r.cost.cpu_seconds,
                r.cost.wall_seconds,
                r.cost.steps,
                r.cost.iterations,
                r.cost.max_violation
            ));
        }
        for (name, fit) in [
            ("order", self.order),
            ("order_short", self.order_short),
            ("order_sup", self.order_sup),
        ] {
            if let Some(f) = fit {
                s.push_str(&format!(
                    "# {name} = {:.4} (C = {:.4e}, R² = {:.4}, {} points)\n",
                    f.order, f.constant, f.r_squared, f.points
                ));
                if let Some(c) = f.caveat {
                    s.push_str(&format!("# {name} is not an order: {c}\n"));
                }
            }
        }
        write_file(path, &s)
    }

    /// Writes the error at every comparison time, long format.
    ///
    /// Columns: `horizon` (`whole` or `short`), `h`, `t`, `error`
    /// (`|q_ref(t) − qⁿ(t)|`).
    ///
    /// # Errors
    /// [`StudyError::Io`].
    pub fn write_times_csv(&self, path: &Path) -> Result<(), StudyError> {
        let mut s = String::from("horizon,h,t,error\n");
        for r in &self.rows {
            for (t, e) in self.times.iter().zip(&r.errors_at) {
                s.push_str(&format!("whole,{},{t},{e:.9e}\n", r.h));
            }
            for (t, e) in self.times_short.iter().zip(&r.errors_at_short) {
                s.push_str(&format!("short,{},{t},{e:.9e}\n", r.h));
            }
        }
        write_file(path, &s)
    }

    /// Draws `e_h` against `h` in log–log coordinates (whole horizon, short horizon, sup
    /// norm where present), each with its fitted line, and a slope-½ reference line (SVG).
    ///
    /// # Errors
    /// [`StudyError::Plot`].
    pub fn plot(&self, path: &Path) -> Result<(), StudyError> {
        let mut series = Vec::new();
        let hs: Vec<f64> = self.rows.iter().map(|r| r.h).collect();
        let horizon = |t: f64| {
            format!("{t:.3}")
                .trim_end_matches('0')
                .trim_end_matches('.')
                .to_string()
        };
        series.push(plot::Series {
            label: format!("e_h, t ≤ {}", horizon(self.settings.t_end)),
            points: hs
                .iter()
                .zip(self.rows.iter().map(|r| r.error))
                .map(|(a, b)| (*a, b))
                .collect(),
            fit: self.order,
        });
        if let Some(ts) = self.settings.t_short {
            series.push(plot::Series {
                label: format!("e_h, t ≤ {}", horizon(ts)),
                points: hs
                    .iter()
                    .zip(&self.rows)
                    .filter_map(|(h, r)| r.error_short.map(|e| (*h, e)))
                    .collect(),
                fit: self.order_short,
            });
        }
        if self.rows.iter().all(|r| r.error_sup.is_some()) {
            series.push(plot::Series {
                label: "sup_t |q − qⁿ|".into(),
                points: hs
                    .iter()
                    .zip(&self.rows)
                    .filter_map(|(h, r)| r.error_sup.map(|e| (*h, e)))
                    .collect(),
                fit: self.order_sup,
            });
        }
        plot::log_log(
            path,
            &format!("Convergence: {}", self.label),
            "h",
            "error",
            &series,
            Some(0.5),
        )
    }

    /// A plain-text summary: one line per `h`, then the fitted orders.
    pub fn summary(&self) -> String {
        let mut s = format!("{}\n", self.label);
        if let Some(r) = &self.reference {
            s.push_str(&format!(
                "reference h = {}: {} steps, {:.2} s CPU, {} solver iterations\n",
                r.h, r.steps, r.cpu_seconds, r.iterations
            ));
        }
        s.push_str(&format!(
            "{:>8} {:>12} {:>12} {:>12} {:>9} {:>6}\n",
            "h", "e_h", "e_h short", "sup", "cpu [s]", "steps"
        ));
        let opt = |v: Option<f64>| {
            v.map(|x| format!("{x:12.4e}"))
                .unwrap_or(format!("{:>12}", "-"))
        };
        for r in &self.rows {
            s.push_str(&format!(
                "{:>8} {:12.4e} {} {} {:9.3} {:>6}\n",
                r.h,
                r.error,
                opt(r.error_short),
                opt(r.error_sup),
                r.cost.cpu_seconds,
                r.cost.steps
            ));
        }
        let line = |name: &str, f: Option<OrderFit>| match f {
            Some(f) => format!("{name}: {}\n", f.describe()),
            None => format!("{name}: not fitted (fewer than two positive errors)\n"),
        };
        s.push_str(&line(
            &format!("fitted order, t ≤ {}", self.settings.t_end),
            self.order,
        ));
        if let Some(ts) = self.settings.t_short {
            s.push_str(&line(&format!("fitted order, t ≤ {ts}"), self.order_short));
        }
        if self.rows.iter().all(|r| r.error_sup.is_some()) {
            s.push_str(&line("fitted order, sup norm", self.order_sup));
        }
        s
    }
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

/// The paper's convergence experiment: a reference run at `h_min` and one run per `h`, all
/// in parallel; `e_h` over the whole and the short horizon; fitted orders.
///
/// `base` supplies everything but `h`, `t_end` and `record_every`.
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::study::{converge, ConvergenceSettings};
/// use sweeping::api::conformance::ReferenceProjector;
///
/// struct Floor;
/// impl ConstraintKernel<1> for Floor {
///     type Params = ();
///     fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D { z[0] }
///     fn is_time_dependent(&self) -> bool { false }
/// }
/// // x' = −x − 1 above the floor x ≥ 0: explicit Euler until contact.
/// let make = || -> Result<Problem, sweeping::study::BoxError> {
///     Ok(Problem::new(vec![1.0], |_t: f64, q: &[f64], f: &mut [f64]| f[0] = -q[0] - 1.0)
///         .with_family(KernelFamily::single("floor", Floor, [0])))
/// };
/// let proj = || -> Result<Box<dyn Projector>, sweeping::study::BoxError> {
///     Ok(Box::new(ReferenceProjector::default()))
/// };
/// let settings = ConvergenceSettings {
///     h_min: 0.001, hs: vec![0.004, 0.01, 0.02], t_end: 0.5, t_short: None,
///     samples: 10, parallel: false,
/// };
/// let report = converge("floor", &make, &proj, &StepperSettings::default(), &settings).unwrap();
/// assert!(report.order.unwrap().order > 0.8);
/// ```
///
/// # Errors
/// [`StudyError::InvalidInput`] for bad settings; the first failing run's error otherwise.
pub fn converge(
    label: &str,
    make_problem: &ProblemFactory<'_>,
    make_projector: &ProjectorFactory<'_>,
    base: &StepperSettings,
    settings: &ConvergenceSettings,
) -> Result<ConvergenceReport, StudyError> {
    let t0 = make_problem()
        .map_err(|source| StudyError::Setup {
            h: settings.h_min,
            source,
        })?
        .t0();
    settings.validate(t0)?;
    let times = comparison_times(t0, settings.t_end, settings.samples);
    let times_short = settings
        .t_short
        .map(|ts| comparison_times(t0, ts, settings.samples))
        .unwrap_or_default();
    let mut all: Vec<f64> = times.iter().chain(&times_short).copied().collect();
    all.sort_by(f64::total_cmp);
    all.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * a.abs().max(1.0));

    // The reference first in the list: rayon starts it at once, and it is the longest.
    let steps: Vec<f64> = std::iter::once(settings.h_min)
        .chain(settings.hs.iter().copied())
        .collect();
    let runs = map_runs(&steps, settings.parallel, |&h| {
        run_sampled(
            make_problem,
            make_projector,
            base,
            h,
            settings.t_end,
            &all,
            false,
        )
    });
    let mut runs = runs.into_iter().collect::<Result<Vec<_>, _>>()?;
    let reference = runs.remove(0);
    let at = |run: &SampledRun, ts: &[f64]| -> Vec<f64> {
        ts.iter()
            .map(|t| {
                let i = all
                    .iter()
                    .position(|s| (s - t).abs() <= 1e-12 * t.abs().max(1.0))
                    .unwrap_or(0);
                distance(&reference.samples[i], &run.samples[i])
            })
            .collect()
    };
    let rows = runs
        .iter()
        .map(|run| {
            let errors_at_short = at(run, &times_short);
            ConvergenceRow {
                error_short: settings.t_short.map(|_| max_of(&errors_at_short)),
                errors_at_short,
                round_off: run
                    .round_off(reference.stats.steps)
                    .max(reference.round_off(run.stats.steps)),
                ..ConvergenceRow::measured(run, at(run, &times))
            }
        })
        .collect();
    let mut report = ConvergenceReport {
        label: label.to_string(),
        settings: settings.clone(),
        times,
        times_short,
        reference: Some(ReferenceSummary::of(settings.h_min, &reference)),
        rows,
        order: None,
        order_short: None,
        order_sup: None,
    };
    report.fit();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows' JSON keeps the cost columns of [`RunCost`] at the top level (flattened),
    /// and reads back equal.
    #[test]
    fn row_json_is_flat_and_round_trips() {
        let cost = RunCost {
            cpu_seconds: 1.5,
            wall_seconds: 2.5,
            steps: 7,
            iterations: 40,
            max_violation: 1e-9,
        };
        let row = ConvergenceRow {
            h: 0.1,
            error: 0.25,
            error_short: None,
            errors_at: vec![0.25],
            errors_at_short: Vec::new(),
            error_sup: Some(0.5),
            round_off: 1e-12,
            cost,
        };
        let json: serde_json::Value = serde_json::to_value(&row).unwrap();
        assert!(json.get("cost").is_none(), "{json}");
        assert_eq!(json["cpu_seconds"], 1.5);
        assert_eq!(json["steps"], 7);
        assert_eq!(json["max_violation"], 1e-9);
        let back: ConvergenceRow = serde_json::from_value(json).unwrap();
        assert_eq!(back, row);
        let wp = work_precision::WorkPrecisionRow {
            h: 0.1,
            solver: "clarabel".into(),
            error: 0.25,
            cost,
            failure: None,
            infeasible: false,
        };
        let json = serde_json::to_value(&wp).unwrap();
        assert_eq!(json["iterations"], 40);
        assert_eq!(json["wall_seconds"], 2.5);
        let back: work_precision::WorkPrecisionRow = serde_json::from_value(json).unwrap();
        assert_eq!(back, wp);
    }

    #[test]
    fn comparison_times_end_exactly_at_the_horizon() {
        let t = comparison_times(0.0, 2.0, 10);
        assert_eq!(t.len(), 10);
        assert!((t[0] - 0.2).abs() < 1e-15);
        assert!((t[9] - 2.0).abs() < 1e-15);
    }

    #[test]
    fn sampler_interpolates_linearly_between_steps() {
        let mut s = Sampler::new(vec![0.0, 0.25, 1.0]);
        s.on_start(0.0, &[0.0, 1.0]).unwrap();
        let report = |t: f64| StepReport {
            step: 0,
            t,
            h: 0.5,
            rows: 0,
            active: 0,
            solves: 1,
            iterations: 0,
            counters: Default::default(),
            times: Default::default(),
            max_violation: 0.0,
            worst_constraint: None,
            max_displacement: 0.0,
            solve: sweeping_api::SolveStats {
                backend: "none".into(),
                status: sweeping_api::SolveStatus::Trivial,
                iterations: 0,
                solve_seconds: 0.0,
                setup_seconds: 0.0,
                warm_started: false,
                counters: Default::default(),
            },
        };
        s.on_step(&report(0.5), &[1.0, 3.0]).unwrap();
        s.on_step(&report(1.0), &[2.0, 3.0]).unwrap();
        let got = s.samples();
        assert_eq!(got.len(), 3);
        assert!((got[1][0] - 0.5).abs() < 1e-15 && (got[1][1] - 2.0).abs() < 1e-15);
        assert!((got[2][0] - 2.0).abs() < 1e-15);
    }
}
