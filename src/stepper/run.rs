//! A run: stepping to the horizon with observers, and what it leaves, [`Run`] or
//! [`RunFailure`].

use super::{display_number, Observer, RunStats, Stepper};
use crate::error::SweepError;
use serde::{Deserialize, Serialize};
use sweeping_api::Projector;

/// Configurations at recorded times.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Recorded times.
    pub times: Vec<f64>,
    /// The configuration at each recorded time.
    pub states: Vec<Vec<f64>>,
}

impl Trajectory {
    /// The recorded state at time `t` (within `1e-9 · max(1, |t|)`), if any.
    pub fn at(&self, t: f64) -> Option<&[f64]> {
        let tol = 1e-9 * t.abs().max(1.0);
        self.times
            .iter()
            .position(|s| (s - t).abs() <= tol)
            .map(|i| self.states[i].as_slice())
    }
}

/// The result of a run: what was computed, and the statistics.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Run {
    /// Recorded configurations (always including the start and the last computed one).
    pub trajectory: Trajectory,
    /// Totals.
    pub stats: RunStats,
    /// The last configuration computed.
    pub q_final: Vec<f64>,
    /// The time of `q_final`.
    pub t_final: f64,
}

/// A failed run: the error, and everything computed before it.
#[derive(Debug, Clone)]
pub struct RunFailure {
    /// What went wrong.
    pub error: SweepError,
    /// What was computed before.
    pub partial: Run,
}

impl std::fmt::Display for RunFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} (after {} completed steps, t = {})",
            self.error,
            self.partial.stats.steps,
            display_number(self.partial.t_final)
        )
    }
}

impl std::error::Error for RunFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

impl Stepper<'_> {
    /// Steps until `T`, calling the observers after each step; returns what was computed, or
    /// the error together with everything computed before it.
    ///
    /// # Errors
    /// A [`RunFailure`]: the [`SweepError`] and the partial [`Run`].
    pub fn run(
        self,
        projector: &mut dyn Projector,
        observers: &mut [&mut dyn Observer],
    ) -> Result<Run, Box<RunFailure>> {
        self.run_until(projector, observers, |_, _| false)
    }

    /// Like [`run`](Self::run), but stops early, after the step at the end of which
    /// `stop(t, q)` is true (a crowd stops when everybody has left), or without a step when it
    /// is true of the start already (a run resumed from the last state of one that ended so).
    /// The last configuration is always recorded.
    ///
    /// # Errors
    /// A [`RunFailure`]: the [`SweepError`] and the partial [`Run`].
    pub fn run_until(
        mut self,
        projector: &mut dyn Projector,
        observers: &mut [&mut dyn Observer],
        mut stop: impl FnMut(f64, &[f64]) -> bool,
    ) -> Result<Run, Box<RunFailure>> {
        let mut run = Run {
            trajectory: Trajectory {
                times: vec![self.t],
                states: vec![self.q.clone()],
            },
            stats: RunStats::default(),
            q_final: self.q.clone(),
            t_final: self.t,
        };
        let fail = |run: Run, error: SweepError, observers: &mut [&mut dyn Observer]| {
            for o in observers.iter_mut() {
                let _ = o.on_finish(Some(&error));
            }
            Box::new(RunFailure {
                error,
                partial: run,
            })
        };
        for o in observers.iter_mut() {
            if let Err(e) = o.on_start(self.t, &self.q) {
                let e = e.into_sweep_error(o.name(), 0, self.t);
                return Err(fail(run, e, observers));
            }
        }
        // A start that already meets `stop` is where the run ends: a run resumed from a
        // finished one takes no step past the end it had reached.
        let mut stopping = stop(self.t, &self.q);
        while self.k < self.n_steps && !stopping {
            let report = match self.step(projector) {
                Ok(r) => r,
                Err(e) => return Err(fail(run, e, observers)),
            };
            run.stats.absorb(&report);
            run.q_final.clone_from(&self.q);
            run.t_final = self.t;
            stopping = stop(self.t, &self.q);
            let every = self.settings.record_every;
            if (every > 0 && self.k.is_multiple_of(every)) || self.k == self.n_steps || stopping {
                run.trajectory.times.push(self.t);
                run.trajectory.states.push(self.q.clone());
            }
            for o in observers.iter_mut() {
                if let Err(e) = o.on_step(&report, &self.q) {
                    let e = e.into_sweep_error(o.name(), report.step, report.t);
                    return Err(fail(run, e, observers));
                }
            }
        }
        // Every observer finishes, those after a failed one told of its error (a summary
        // records the run as failed); that first error is the run's.
        let mut failed: Option<SweepError> = None;
        for o in observers.iter_mut() {
            if let Err(e) = o.on_finish(failed.as_ref()) {
                if failed.is_none() {
                    failed = Some(e.into_sweep_error(o.name(), self.k, self.t));
                }
            }
        }
        match failed {
            Some(error) => Err(Box::new(RunFailure {
                error,
                partial: run,
            })),
            None => Ok(run),
        }
    }
}
