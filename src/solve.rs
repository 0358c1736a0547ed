//! [`Problem::solve`]: a run with the default backend and a convexity monitor, in one call.
//!
//! It sits above the stepper and the assumptions' monitor, which it wires together, so that
//! the problem itself depends on neither.

use crate::assumptions::{BoundsMonitor, MonitorSettings, Policy};
use crate::backends::{make_projector, BackendChoice};
use crate::error::SweepError;
use crate::problem::Problem;
use crate::stepper::{Run, RunFailure, Stepper, StepperSettings};

impl Problem {
    /// Runs the scheme with the default backend ([`BackendChoice::default`], or the first
    /// one compiled in) and a [`BoundsMonitor`] that checks convexity of the constraints
    /// under [`Policy::Warn`], printing what it finds on standard error. For another backend,
    /// observers, declared bounds or [`Policy::Error`], use [`Stepper`] directly:
    /// `Stepper::new(&problem, settings)?.run(backend, &mut [&mut monitor])`.
    ///
    /// # Errors
    /// What [`Stepper::new`] and [`Stepper::run`] report, as a [`RunFailure`] that keeps what
    /// was computed (only the start, when the set-up failed).
    ///
    /// ```
    /// use sweeping::prelude::*;
    /// struct Floor; // x ≥ 0
    /// impl ConstraintKernel<1> for Floor {
    ///     type Params = ();
    ///     fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D { z[0] }
    ///     fn is_affine(&self) -> bool { true }
    /// }
    /// let problem = Problem::new(vec![1.0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = -1.0)
    ///     .with_constraint("floor", Floor, [0]);
    /// let run = problem.solve(StepperSettings { h: 0.1, t_end: 2.0, ..Default::default() })?;
    /// assert!(run.q_final[0].abs() < 1e-9);
    /// # Ok::<(), Box<RunFailure>>(())
    /// ```
    pub fn solve(&self, settings: StepperSettings) -> Result<Run, Box<RunFailure>> {
        let failed = |error: SweepError| {
            Box::new(RunFailure {
                error,
                partial: Run {
                    q_final: self.q0().to_vec(),
                    t_final: self.t0(),
                    ..Run::default()
                },
            })
        };
        let mut backend = [
            BackendChoice::default(),
            BackendChoice::Clarabel,
            BackendChoice::Osqp,
            BackendChoice::Reference,
        ]
        .into_iter()
        .find_map(|c| make_projector(c).ok())
        .ok_or_else(|| failed(SweepError::InvalidInput("no projection backend".into())))?;
        let stepper = Stepper::new(self, settings).map_err(failed)?;
        let mut monitor = BoundsMonitor::new(
            self,
            MonitorSettings {
                policy: Policy::Warn,
                print_warnings: true,
                ..MonitorSettings::default()
            },
        );
        stepper.run(backend.as_mut(), &mut [&mut monitor])
    }
}
