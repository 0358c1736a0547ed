//! A run sampled at the comparison times: the paper's piecewise-linear `qⁿ` read where the
//! studies compare runs, and the distances between samples.

use super::{ProblemFactory, ProjectorFactory, StudyError};
use crate::meter::thread_cpu_seconds;
use crate::stepper::{
    Observer, ObserverError, RunStats, StepReport, Stepper, StepperSettings, Trajectory,
};
use std::time::Instant;

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

/// The largest of `values` (0 for none): `e_h = max_i |q_ref(tᵢ) − qⁿ(tᵢ)|`.
pub(super) fn max_of(values: &[f64]) -> f64 {
    values.iter().copied().fold(0.0, f64::max)
}

/// `|aᵢ − bᵢ|` at each comparison time, from two runs' (or a run's and the exact) samples.
pub(super) fn distances(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| distance(a, b)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
            cuts: 0,
            iterations: 0,
            counters: Default::default(),
            times: Default::default(),
            max_violation: 0.0,
            worst_constraint: None,
            max_equality_residual: 0.0,
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
            contacts: Vec::new(),
        };
        s.on_step(&report(0.5), &[1.0, 3.0]).unwrap();
        s.on_step(&report(1.0), &[2.0, 3.0]).unwrap();
        let got = s.samples();
        assert_eq!(got.len(), 3);
        assert!((got[1][0] - 0.5).abs() < 1e-15 && (got[1][1] - 2.0).abs() < 1e-15);
        assert!((got[2][0] - 2.0).abs() < 1e-15);
    }
}
