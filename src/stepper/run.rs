//! A run: stepping to the horizon with observers, and what it leaves, a [`Run`] or a
//! [`RunFailure`].

use super::{display_number, Observer, Stepper};
use crate::error::SweepError;
use crate::report::{Run, RunStats, Trajectory};
use sweeping_api::Projector;

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

/// `?` turns a run's failure into a [`SweepError`] that keeps the partial run, so one function
/// can `?` both [`Stepper::new`](crate::stepper::Stepper::new) and its `run`.
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::api::conformance::ReferenceProjector;
/// struct Floor; // x ≥ 0
/// impl ConstraintKernel<1> for Floor {
///     type Params = ();
///     fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D { z[0] }
///     fn is_affine(&self) -> bool { true }
/// }
/// fn fall(x0: f64) -> Result<Run, SweepError> {
///     let problem = Problem::new(vec![x0], |_t: f64, q: &[f64], f: &mut [f64]| {
///         f[0] = if q[0] < 0.5 { f64::NAN } else { -1.0 }
///     })
///     .with_constraint("floor", Floor, [0]);
///     let settings = StepperSettings { h: 0.1, t_end: 1.0, ..Default::default() };
///     let run = Stepper::new(&problem, settings)?.run(&mut ReferenceProjector::default(), &mut [])?;
///     Ok(run)
/// }
/// assert!(fall(5.0).is_ok());
/// let err = fall(1.0).unwrap_err(); // f turns NaN below 0.5: a failure mid-run
/// assert!(err.partial_run().is_some_and(|run| run.stats.steps > 0), "{err}");
/// ```
impl From<Box<RunFailure>> for SweepError {
    fn from(failure: Box<RunFailure>) -> Self {
        Self::from(*failure)
    }
}

impl From<RunFailure> for SweepError {
    fn from(failure: RunFailure) -> Self {
        Self::RunFailed {
            error: Box::new(failure.error),
            partial: Box::new(failure.partial),
        }
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
