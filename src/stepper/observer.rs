//! The observer of a run: told of the start, of every step and of the end.

use super::{ObserverError, StepReport};
use crate::error::SweepError;

/// Receives every step of a run. Every method defaults to doing nothing, so an observer
/// implements only what it needs; `()` is the observer that does nothing.
///
/// ```
/// use sweeping::stepper::{Observer, ObserverError, StepReport};
/// /// Counts steps whose projection had an active constraint.
/// #[derive(Default)]
/// struct ContactSteps(usize);
/// impl Observer for ContactSteps {
///     fn on_step(&mut self, report: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
///         if report.active > 0 { self.0 += 1; }
///         Ok(())
///     }
/// }
/// ```
pub trait Observer {
    /// A name for errors.
    fn name(&self) -> &str {
        "observer"
    }
    /// Called once before the first step with `(t₀, q₀)`.
    ///
    /// # Errors
    /// An [`ObserverError`]; the run stops with it (see
    /// [`ObserverError::into_sweep_error`]).
    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        let _ = (t, q);
        Ok(())
    }
    /// Called after every step with its report and `q_{k+1}`.
    ///
    /// # Errors
    /// An [`ObserverError`]; the run stops with it.
    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let _ = (report, q);
        Ok(())
    }
    /// Called once at the end, with the error if the run failed (also after a failure, so
    /// writers can flush what they have), or if an observer before this one failed to finish.
    ///
    /// # Errors
    /// An [`ObserverError`]; reported if the run had not already failed.
    fn on_finish(&mut self, error: Option<&SweepError>) -> Result<(), ObserverError> {
        let _ = error;
        Ok(())
    }
}

impl Observer for () {}
