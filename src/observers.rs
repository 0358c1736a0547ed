//! A ready-made observer: a closure called after every step.

use crate::stepper::{Observer, ObserverError, StepReport};

/// Turns a closure `FnMut(&StepReport, &[f64])` into an observer.
///
/// ```
/// use sweeping::observers::Callback;
/// let mut worst = 0.0f64;
/// let mut obs = Callback::new(|r: &sweeping::stepper::StepReport, _q: &[f64]| {
///     worst = worst.max(r.max_violation);
/// });
/// # let _ = &mut obs;
/// ```
pub struct Callback<F>(F);

impl<F: FnMut(&StepReport, &[f64])> Callback<F> {
    /// Wraps `f`.
    pub fn new(f: F) -> Self {
        Self(f)
    }
}

impl<F: FnMut(&StepReport, &[f64])> Observer for Callback<F> {
    fn name(&self) -> &str {
        "callback"
    }
    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        (self.0)(report, q);
        Ok(())
    }
}
