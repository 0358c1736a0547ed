//! Run-time checks of declared bounds (A1–A4), as a stepper observer.
//!
//! The monitor is an [`Observer`]: after each step it re-linearizes, at the new state
//! `(t_{k+1}, q_{k+1})`, the constraints within [`MonitorSettings::neighbourhood`] of activity
//! (the same candidates and `linearize` calls as the assembly, so the cost is of the order of
//! one assembly of the near-active rows), and compares `|∇g|` with `α` and `β` (A1) and
//! `|∂ₜg|` with `β` (A2). Every [`MonitorSettings::second_order_every`] steps it also computes
//! `D²g` and `∂ₜ∇g` of the [`MonitorSettings::second_order_max`] most active of them and
//! compares their norms (spectral, Euclidean) with `M` (A4, A3), so that cost stays bounded.
//!
//! An observer was chosen over a hook inside the stepper: the stepper stays unchanged but for
//! one additive method, [`Observer::take_error`], through which the monitor hands the run its
//! typed [`SweepError::AssumptionViolated`] instead of the generic observer error.

use super::{second_order_norms, AssumptionReport};
use crate::constraint::LinearizedRow;
use crate::error::SweepError;
use crate::problem::Problem;
use crate::stepper::{Observer, StepReport};
use serde::{Deserialize, Serialize};

/// `true` unless `a ≤ b` (so a NaN is never within a bound).
pub(crate) fn not_within(a: f64, b: f64) -> bool {
    !matches!(
        a.partial_cmp(&b),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    )
}

/// What to do when a declared bound is exceeded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Policy {
    /// No checks (no cost).
    Off,
    /// Record the violation (see [`BoundsMonitor::warnings`]) and go on.
    #[default]
    Warn,
    /// Stop the run with [`SweepError::AssumptionViolated`]; the run keeps what it computed.
    Error,
}

/// Declared bounds; `None` leaves a quantity unchecked.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Bounds {
    /// A1: `|∇gᵢ| ≥ α`.
    pub alpha: Option<f64>,
    /// A1 and A2: `|∇gᵢ| ≤ β` and `|∂ₜgᵢ| ≤ β`.
    pub beta: Option<f64>,
    /// A3 and A4: `|∂ₜ∇gᵢ| ≤ M` and `|D²gᵢ| ≤ M` (spectral norm).
    pub m: Option<f64>,
}

impl Bounds {
    /// The bounds measured by [`super::estimate_problem`], widened by the relative `slack`
    /// (`α/(1 + slack)`, `β(1 + slack)`, `M(1 + slack)`).
    pub fn from_report(report: &AssumptionReport, slack: f64) -> Self {
        Self {
            alpha: report.alpha.as_ref().map(|w| w.value / (1.0 + slack)),
            beta: report.beta.map(|b| b * (1.0 + slack)),
            m: report.m.map(|m| m * (1.0 + slack)),
        }
    }
}

/// Settings of the monitor; plain values with documented defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MonitorSettings {
    /// Off, warn or error. Default warn.
    pub policy: Policy,
    /// The declared bounds. Default: none (nothing checked).
    pub bounds: Bounds,
    /// Constraints with `gᵢ ≤ neighbourhood` at the new state are checked. Default `0.1`.
    pub neighbourhood: f64,
    /// A value counts as a violation when beyond the bound by more than this relative
    /// amount (rounding). Default `1e-9`.
    pub relative_tolerance: f64,
    /// Second-order checks (A3, A4) every this many steps, counting the start as step 0;
    /// 0 = never. Default `10`.
    pub second_order_every: usize,
    /// At most this many constraints (the most active ones) per second-order check.
    /// Default `16`.
    pub second_order_max: usize,
    /// At most this many warnings are kept (all are counted). Default `100`.
    pub max_warnings: usize,
}

impl Default for MonitorSettings {
    fn default() -> Self {
        Self {
            policy: Policy::Warn,
            bounds: Bounds::default(),
            neighbourhood: 0.1,
            relative_tolerance: 1e-9,
            second_order_every: 10,
            second_order_max: 16,
            max_warnings: 100,
        }
    }
}

/// One bound exceeded: which assumption, constraint, when, the bound and the value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundViolation {
    /// Step index (`0` for the start; `k` for the step that computed `q_{k+1}`).
    pub step: usize,
    /// Time.
    pub t: f64,
    /// "A1", "A2", "A3" or "A4".
    pub assumption: String,
    /// The constraint (for crowds, the people).
    pub constraint: String,
    /// What was measured, e.g. "|∇g|".
    pub quantity: String,
    /// The declared bound, e.g. "β = 1.2".
    pub bound_name: String,
    /// The bound's value.
    pub bound: f64,
    /// The value seen.
    pub value: f64,
}

impl BoundViolation {
    fn detail(&self) -> String {
        let rel = if self.quantity.starts_with("|∇g|") && self.bound_name.starts_with('α') {
            "is below"
        } else {
            "exceeds"
        };
        format!(
            "{} = {:.6e} {rel} the declared bound {} = {:.6e}",
            self.quantity, self.value, self.bound_name, self.bound
        )
    }

    /// The error this violation stops a run with.
    pub fn to_error(&self) -> SweepError {
        SweepError::AssumptionViolated {
            step: self.step,
            t: self.t,
            assumption: self.assumption.clone(),
            constraint: self.constraint.clone(),
            detail: self.detail(),
        }
    }
}

impl std::fmt::Display for BoundViolation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "step {}, t = {}: assumption {} violated by {}: {}",
            self.step,
            self.t,
            self.assumption,
            self.constraint,
            self.detail()
        )
    }
}

/// Checks declared bounds at every step of a run (module docs).
///
/// ```
/// use sweeping::assumptions::{Bounds, BoundsMonitor, MonitorSettings, Policy};
/// use sweeping::prelude::*;
/// use sweeping_api::conformance::ReferenceProjector;
///
/// /// A floor that rises at speed 2: g = x − 2t, so |∂ₜg| = 2.
/// struct RisingFloor;
/// impl ConstraintKernel<1> for RisingFloor {
///     type Params = ();
///     fn value<D: DualNum<Primitive = f64> + Copy>(&self, _: &(), t: D, z: [D; 1]) -> D {
///         z[0] - t * 2.0
///     }
///     fn is_affine(&self) -> bool { true }
/// }
/// let problem = Problem::new(vec![0.0], NoPerturbation)
///     .with_family(KernelFamily::single("rising floor", RisingFloor, [0]));
/// let settings = MonitorSettings {
///     policy: Policy::Error,
///     bounds: Bounds { beta: Some(1.5), ..Default::default() },
///     ..Default::default()
/// };
/// let mut monitor = BoundsMonitor::new(&problem, settings);
/// let run = Stepper::new(&problem, StepperSettings { h: 0.1, t_end: 1.0, ..Default::default() })
///     .unwrap()
///     .run(&mut ReferenceProjector::default(), &mut [&mut monitor]);
/// let failure = run.unwrap_err();
/// assert!(matches!(failure.error, SweepError::AssumptionViolated { .. }));
/// assert!(failure.error.to_string().contains("rising floor"));
/// ```
pub struct BoundsMonitor<'p> {
    problem: &'p Problem,
    settings: MonitorSettings,
    warnings: Vec<BoundViolation>,
    violations: usize,
    checks: usize,
    second_order_checks: usize,
    states_seen: usize,
    pending: Option<SweepError>,
    cands: Vec<usize>,
    row: LinearizedRow,
    near: Vec<(f64, usize, usize)>,
}

impl<'p> BoundsMonitor<'p> {
    /// A monitor of `problem`'s constraints.
    pub fn new(problem: &'p Problem, settings: MonitorSettings) -> Self {
        Self {
            problem,
            settings,
            warnings: Vec::new(),
            violations: 0,
            checks: 0,
            second_order_checks: 0,
            states_seen: 0,
            pending: None,
            cands: Vec::new(),
            row: LinearizedRow::default(),
            near: Vec::new(),
        }
    }

    /// The violations kept under [`Policy::Warn`] (at most `max_warnings`).
    pub fn warnings(&self) -> &[BoundViolation] {
        &self.warnings
    }

    /// All violations seen (including those beyond `max_warnings`).
    pub fn violation_count(&self) -> usize {
        self.violations
    }

    /// Constraint evaluations checked so far (first order).
    pub fn checks(&self) -> usize {
        self.checks
    }

    /// Constraint evaluations checked at second order so far.
    pub fn second_order_checks(&self) -> usize {
        self.second_order_checks
    }

    fn exceeds(&self, value: f64, bound: f64) -> bool {
        not_within(value, bound * (1.0 + self.settings.relative_tolerance))
    }

    /// Checks the state `(t, q)`; `step` is reported with violations (the stepper's index:
    /// `0` for the start, `k` for the step that computed `q_{k+1}`). The second-order
    /// schedule counts the calls: the first call, then every `second_order_every`-th.
    ///
    /// # Errors
    /// Under [`Policy::Error`], the first bound exceeded.
    pub fn check(&mut self, step: usize, t: f64, q: &[f64]) -> Result<(), Box<BoundViolation>> {
        if self.settings.policy == Policy::Off {
            return Ok(());
        }
        let b = self.settings.bounds;
        if b.alpha.is_none() && b.beta.is_none() && b.m.is_none() {
            return Ok(());
        }
        let state = self.states_seen;
        self.states_seen += 1;
        let second = b.m.is_some()
            && self.settings.second_order_every > 0
            && state.is_multiple_of(self.settings.second_order_every);
        let mut found: Vec<BoundViolation> = Vec::new();
        self.near.clear();
        let problem = self.problem;
        for (fi, fam) in problem.families().iter().enumerate() {
            self.cands.clear();
            fam.candidates(t, q, self.settings.neighbourhood, &mut self.cands);
            let want_dt = b.beta.is_some() && fam.is_time_dependent();
            for ci in 0..self.cands.len() {
                let idx = self.cands[ci];
                fam.linearize(idx, t, q, want_dt, &mut self.row);
                if not_within(self.row.value, self.settings.neighbourhood) {
                    continue;
                }
                self.checks += 1;
                let grad = self.row.gradient_norm();
                let dt = self.row.dt.unwrap_or(0.0).abs();
                let mk = |assumption: &str, quantity: &str, bound_name: &str, bound, value| {
                    BoundViolation {
                        step,
                        t,
                        assumption: assumption.into(),
                        constraint: fam.describe(idx),
                        quantity: quantity.into(),
                        bound_name: bound_name.into(),
                        bound,
                        value,
                    }
                };
                if let Some(a) = b.alpha {
                    if self.exceeds(a, grad) {
                        found.push(mk("A1", "|∇g|", "α", a, grad));
                    }
                }
                if let Some(be) = b.beta {
                    if self.exceeds(grad, be) {
                        found.push(mk("A1", "|∇g|", "β", be, grad));
                    }
                    if self.exceeds(dt, be) {
                        found.push(mk("A2", "|∂ₜg|", "β", be, dt));
                    }
                }
                if second {
                    self.near.push((self.row.value, fi, idx));
                }
            }
        }
        if second {
            if let Some(m) = b.m {
                self.near.sort_by(|x, y| x.0.total_cmp(&y.0));
                self.near.truncate(self.settings.second_order_max);
                for &(_, fi, idx) in &self.near {
                    let fam = &problem.families()[fi];
                    if fam.is_affine() && !fam.is_time_dependent() {
                        continue;
                    }
                    self.second_order_checks += 1;
                    let so = fam.second_order(idx, t, q);
                    let n = second_order_norms(fam.as_ref(), &so);
                    for (assumption, quantity, value) in [
                        ("A4", "|D²g| (spectral)", n.hess),
                        ("A3", "|∂ₜ∇g|", n.dt_grad),
                    ] {
                        if self.exceeds(value, m) {
                            found.push(BoundViolation {
                                step,
                                t,
                                assumption: assumption.into(),
                                constraint: fam.describe(idx),
                                quantity: quantity.into(),
                                bound_name: "M".into(),
                                bound: m,
                                value,
                            });
                        }
                    }
                }
            }
        }
        self.violations += found.len();
        match self.settings.policy {
            Policy::Error => match found.into_iter().next() {
                Some(v) => Err(Box::new(v)),
                None => Ok(()),
            },
            _ => {
                let room = self
                    .settings
                    .max_warnings
                    .saturating_sub(self.warnings.len());
                self.warnings.extend(found.into_iter().take(room));
                Ok(())
            }
        }
    }

    fn observe(&mut self, step: usize, t: f64, q: &[f64]) -> Result<(), String> {
        self.check(step, t, q).map_err(|v| {
            let message = v.to_string();
            self.pending = Some(v.to_error());
            message
        })
    }
}

impl Observer for BoundsMonitor<'_> {
    fn name(&self) -> &str {
        "assumption monitor"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), String> {
        self.observe(0, t, q)
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), String> {
        self.observe(report.step, report.t, q)
    }

    fn take_error(&mut self) -> Option<SweepError> {
        self.pending.take()
    }
}
