//! Run-time checks of declared bounds (A1–A4), as a stepper observer.
//!
//! The monitor is an [`Observer`]: after each step it re-linearizes, at the new state
//! `(t_{k+1}, q_{k+1})`, the constraints within [`MonitorSettings::neighbourhood`] of activity
//! (the same candidates and `linearize` calls as the assembly, so the cost is of the order of
//! one assembly of the near-active rows), and compares `|∇g|` with `α` and `β` (A1) and
//! `|∂ₜg|` with `β` (A2). Every [`MonitorSettings::second_order_every`] steps it also computes
//! `D²g` and `∂ₜ∇g` of the [`MonitorSettings::second_order_max`] most active of them and
//! compares their norms (spectral, Euclidean) with `M` (A4, A3), so that cost stays bounded,
//! and — unless [`MonitorSettings::convexity`] is off — checks that `D²g` has no negative
//! eigenvalue (section 2 of the paper: each `gᵢ` convex in `q`). At the start, every member of
//! a family that does not cull (user constraints) is checked however far from contact, and a
//! family that declares itself affine has that claim verified once (`D²g = 0`).
//!
//! An observer was chosen over a hook inside the stepper: the stepper stays unchanged, and the
//! monitor stops the run with its typed [`SweepError::AssumptionViolated`] through
//! [`ObserverError::Stop`].

use super::AssumptionReport;
use crate::constraint::{ConstraintFamily, Curvature};
use crate::curvature::{
    concave_direction, convex_direction, describe_point, second_order_norms,
    symmetric_spectral_norm, AFFINE_CLAIM, CONCAVITY, CONCAVITY_MEANING, CONVEXITY,
    CONVEXITY_MEANING,
};
use crate::error::SweepError;
use crate::problem::Problem;
use crate::stepper::{Observer, ObserverError, StepReport};
use serde::{Deserialize, Serialize};
use std::io::Write as _;

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
    /// Where the bounds hold: constraints with `gᵢ ≤ reach`, the neighbourhood of activity
    /// they were measured in (`max(neighbourhood, ρ)` of the estimate, for
    /// [`Bounds::from_report`]); farther constraints are not compared with them, at the start
    /// as at every step. `None`: the bounds hold everywhere, and at the start every member of
    /// a family that does not cull is compared with them.
    pub reach: Option<f64>,
}

impl Bounds {
    /// Checks that each declared bound is a finite number of the right sign: `α > 0`,
    /// `β > 0`, `M ≥ 0`, and `α ≤ β` when both are given.
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] naming the bound and its value.
    pub fn validate(&self) -> Result<(), SweepError> {
        let bad = |name: &str, v: f64, rule: &str| {
            Err(SweepError::InvalidInput(format!(
                "declared bound {name} = {v} must be {rule}"
            )))
        };
        if let Some(a) = self.alpha {
            if !(a.is_finite() && a > 0.0) {
                return bad("α (A1)", a, "finite and > 0");
            }
        }
        if let Some(b) = self.beta {
            if !(b.is_finite() && b > 0.0) {
                return bad("β (A1, A2)", b, "finite and > 0");
            }
        }
        if let Some(m) = self.m {
            if !(m.is_finite() && m >= 0.0) {
                return bad("M (A3, A4)", m, "finite and ≥ 0");
            }
        }
        if let Some(r) = self.reach {
            if !(r.is_finite() && r >= 0.0) {
                return bad("reach", r, "finite and ≥ 0");
            }
        }
        if let (Some(a), Some(b)) = (self.alpha, self.beta) {
            if a > b {
                return Err(SweepError::InvalidInput(format!(
                    "declared bounds α = {a} > β = {b}: A1 asks α ≤ |∇gᵢ| ≤ β"
                )));
            }
        }
        Ok(())
    }

    /// The bounds measured by [`super::estimate_problem`], widened by the relative `slack`
    /// (`α/(1 + slack)`, `β(1 + slack)`, `M(1 + slack)`), holding within the neighbourhood
    /// the estimate sampled ([`Bounds::reach`]).
    pub fn from_report(report: &AssumptionReport, slack: f64) -> Self {
        Self {
            alpha: report.alpha.as_ref().map(|w| w.value / (1.0 + slack)),
            beta: report.beta.map(|b| b * (1.0 + slack)),
            m: report.m.map(|m| m * (1.0 + slack)),
            reach: Some(report.neighbourhood.max(report.rho)),
        }
    }

    /// Whether a constraint of value `g` lies where the bounds hold (within [`Self::reach`]).
    fn reaches(&self, g: f64) -> bool {
        self.reach.is_none_or(|r| !not_within(g, r))
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
    /// Check that each `gᵢ` is convex in `q` (no negative eigenvalue of `D²gᵢ` beyond
    /// `relative_tolerance · max(1, |D²gᵢ|)`) on the second-order schedule, whether or not `M`
    /// is declared. Default `true`.
    pub convexity: bool,
    /// Under [`Policy::Warn`], also print a kept warning on standard error as it is found,
    /// the first of each assumption and constraint only. Default `false` (read them all from
    /// [`BoundsMonitor::warnings`]).
    pub print_warnings: bool,
}

impl MonitorSettings {
    /// Checks the bounds ([`Bounds::validate`]) and the numeric settings.
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] naming the setting.
    pub fn validate(&self) -> Result<(), SweepError> {
        self.bounds.validate()?;
        for (name, v) in [
            ("neighbourhood", self.neighbourhood),
            ("relative_tolerance", self.relative_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SweepError::InvalidInput(format!(
                    "monitor setting {name} = {v} must be finite and ≥ 0"
                )));
            }
        }
        Ok(())
    }
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
            convexity: true,
            print_warnings: false,
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
    /// Where (the coordinates the constraint reads) and what the violation means, when the
    /// bare numbers do not say it (convexity, a false affine claim); empty otherwise.
    #[serde(default)]
    pub note: String,
}

impl BoundViolation {
    fn detail(&self) -> String {
        let mut out = if self.assumption == CONVEXITY {
            format!("{} = {:.6e} < 0", self.quantity, self.value)
        } else if self.assumption == CONCAVITY {
            format!("{} = {:.6e} > 0", self.quantity, self.value)
        } else if self.assumption == AFFINE_CLAIM {
            format!("{} = {:.6e} ≠ 0", self.quantity, self.value)
        } else {
            let rel = if self.bound_name.starts_with('α') {
                "is below"
            } else {
                "exceeds"
            };
            format!(
                "{} = {:.6e} {rel} the declared bound {} = {:.6e}",
                self.quantity, self.value, self.bound_name, self.bound
            )
        };
        if !self.note.is_empty() {
            out.push_str(": ");
            out.push_str(&self.note);
        }
        out
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
            crate::numbers::display_number(self.t),
            self.assumption,
            self.constraint,
            self.detail()
        )
    }
}

/// Checks declared bounds and convexity at every step of a run (module docs).
///
/// ```
/// use sweeping::assumptions::{Bounds, BoundsMonitor, MonitorSettings, Policy};
/// use sweeping::prelude::*;
/// use sweeping::api::conformance::ReferenceProjector;
///
/// /// A floor that rises at speed 2: g = x − 2t, so |∂ₜg| = 2.
/// struct RisingFloor;
/// impl ConstraintKernel<1> for RisingFloor {
///     type Params = ();
///     fn value<D: Scalar>(&self, _: &(), t: D, z: [D; 1]) -> D {
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
    invalid: Option<SweepError>,
    convexity_explained: bool,
    printed: std::collections::HashSet<(String, String)>,
    scratch: crate::problem::LinearizeScratch,
    near: Vec<(f64, usize, usize)>,
}

impl<'p> BoundsMonitor<'p> {
    /// A monitor of `problem`'s constraints. Invalid settings (a NaN or negative bound…) are
    /// reported when the run starts, as [`SweepError::InvalidInput`] whatever the policy
    /// (except `Off`); [`try_new`](Self::try_new) reports them at once.
    pub fn new(problem: &'p Problem, settings: MonitorSettings) -> Self {
        let invalid = settings.validate().err();
        Self {
            problem,
            settings,
            invalid,
            convexity_explained: false,
            printed: std::collections::HashSet::new(),
            warnings: Vec::new(),
            violations: 0,
            checks: 0,
            second_order_checks: 0,
            states_seen: 0,
            scratch: Default::default(),
            near: Vec::new(),
        }
    }

    /// A monitor of `problem`'s constraints, with its settings checked first.
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] from [`MonitorSettings::validate`].
    pub fn try_new(problem: &'p Problem, settings: MonitorSettings) -> Result<Self, SweepError> {
        settings.validate()?;
        Ok(Self::new(problem, settings))
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
    /// schedule counts the calls: the first call, then every `second_order_every`-th. The
    /// first call is the start: every member of a non-culling family is checked there, and
    /// affine claims are verified. Does nothing when the settings are invalid (see
    /// [`new`](Self::new)).
    ///
    /// # Errors
    /// Under [`Policy::Error`], the first bound exceeded (or convexity failed).
    pub fn check(&mut self, step: usize, t: f64, q: &[f64]) -> Result<(), Box<BoundViolation>> {
        if self.settings.policy == Policy::Off || self.invalid.is_some() {
            return Ok(());
        }
        let b = self.settings.bounds;
        let first_order = b.alpha.is_some() || b.beta.is_some();
        let wants_second = b.m.is_some() || self.settings.convexity;
        if !first_order && !wants_second {
            return Ok(());
        }
        let state = self.states_seen;
        self.states_seen += 1;
        let start = state == 0;
        let second = wants_second
            && self.settings.second_order_every > 0
            && state.is_multiple_of(self.settings.second_order_every);
        if !first_order && !second {
            return Ok(());
        }
        let mut found: Vec<BoundViolation> = Vec::new();
        if start && wants_second {
            self.verify_affine_claims(step, t, q, &mut found);
        }
        self.check_first_order(step, t, q, start, second, &mut found);
        if second {
            self.check_second_order(step, t, q, start, &mut found);
        }
        self.violations += found.len();
        self.deliver(found)
    }

    /// First-order checks at `(t, q)`: every constraint within the neighbourhood of
    /// activity (every member of a non-culling family at the start) has `|∇g| ≥ α` (A1),
    /// `|∇g| ≤ β` (A1) and `|∂ₜg| ≤ β` (A2) within the relative tolerance; when `second`,
    /// the constraints seen are collected in `self.near` for [`Self::check_second_order`].
    fn check_first_order(
        &mut self,
        step: usize,
        t: f64,
        q: &[f64],
        start: bool,
        second: bool,
        found: &mut Vec<BoundViolation>,
    ) {
        let b = self.settings.bounds;
        let problem = self.problem;
        self.near.clear();
        // At the start, a family that does not cull (user constraints) is checked whole,
        // however far from contact: a constraint that is wrong everywhere is caught before
        // the state gets near it.
        let neighbourhood = self.settings.neighbourhood;
        let cutoff = |fam: &dyn ConstraintFamily| {
            Some(if start && !fam.culls() {
                f64::INFINITY
            } else {
                neighbourhood
            })
        };
        let mut scratch = std::mem::take(&mut self.scratch);
        let _ = problem.for_each_linearized(
            t,
            q,
            cutoff,
            b.beta.is_some(),
            &mut scratch,
            |fam, id, row| {
                let (fi, idx) = (id.family, id.member);
                let whole = start && !fam.culls();
                if !whole && not_within(row.value, self.settings.neighbourhood) {
                    return Ok(());
                }
                self.checks += 1;
                if second {
                    self.near.push((row.value, fi, idx));
                }
                // Bounds measured near contact say nothing of a constraint far from it.
                if !b.reaches(row.value) {
                    return Ok(());
                }
                let grad = row.gradient_norm();
                let dt = row.dt.unwrap_or(0.0).abs();
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
                        note: String::new(),
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
                Ok::<(), std::convert::Infallible>(())
            },
        );
        self.scratch = scratch;
    }

    /// Second-order checks on the constraints collected by [`Self::check_first_order`]
    /// (nearest to activity first; all of them at the start, at most `second_order_max`
    /// later): `|D²g| ≤ M` (A4) and `|∂ₜ∇g| ≤ M` (A3), and, when asked, convexity (the
    /// smallest eigenvalue of `D²g` not negative beyond the tolerance).
    fn check_second_order(
        &mut self,
        step: usize,
        t: f64,
        q: &[f64],
        start: bool,
        found: &mut Vec<BoundViolation>,
    ) {
        let b = self.settings.bounds;
        let problem = self.problem;
        self.near.sort_by(|x, y| x.0.total_cmp(&y.0));
        if !start {
            self.near.truncate(self.settings.second_order_max);
        }
        for &(value, fi, idx) in &self.near {
            let fam = &problem.families()[fi];
            if fam.is_affine() && !fam.is_time_dependent() {
                // D²g = 0 and ∂ₜ∇g = 0: nothing to bound (the affine claim itself is
                // verified at the start).
                continue;
            }
            self.second_order_checks += 1;
            let so = fam.second_order(idx, t, q);
            let n = second_order_norms(fam.as_ref(), &so);
            if let Some(m) = b.m.filter(|_| b.reaches(value)) {
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
                            note: String::new(),
                        });
                    }
                }
            }
            let declared_concave = fam.curvature() == Curvature::Concave;
            if self.settings.convexity
                && !fam.is_affine()
                && declared_concave
                && convex_direction(n.max_eig, n.hess, self.settings.relative_tolerance)
            {
                found.push(BoundViolation {
                    step,
                    t,
                    assumption: CONCAVITY.into(),
                    constraint: fam.describe(idx),
                    quantity: "the largest eigenvalue of D²g".into(),
                    bound_name: "0".into(),
                    bound: 0.0,
                    value: n.max_eig,
                    note: format!(
                        "at {}, g = {:.3e}: {CONCAVITY_MEANING}",
                        describe_point(&so.columns, q),
                        so.value,
                    ),
                });
            }
            if self.settings.convexity
                && !fam.is_affine()
                && !declared_concave
                && concave_direction(n.min_eig, n.hess, self.settings.relative_tolerance)
            {
                found.push(BoundViolation {
                    step,
                    t,
                    assumption: CONVEXITY.into(),
                    constraint: fam.describe(idx),
                    quantity: "the smallest eigenvalue of D²g".into(),
                    bound_name: "0".into(),
                    bound: 0.0,
                    value: n.min_eig,
                    note: format!(
                        "at {}, g = {:.3e}{}",
                        describe_point(&so.columns, q),
                        so.value,
                        if self.convexity_explained {
                            String::new()
                        } else {
                            format!(": {CONVEXITY_MEANING}")
                        }
                    ),
                });
                // The meaning is said once; later messages give the where and the value.
                self.convexity_explained = true;
            }
        }
    }

    /// Hands the violations found at one state over by the policy: under
    /// [`Policy::Error`] the first is returned as the error; otherwise they are kept as
    /// warnings (up to `max_warnings`), each printed once per assumption and constraint.
    fn deliver(&mut self, found: Vec<BoundViolation>) -> Result<(), Box<BoundViolation>> {
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
                for v in found.into_iter().take(room) {
                    // Printed once per assumption and constraint; all are kept.
                    if self.settings.print_warnings
                        && self
                            .printed
                            .insert((v.assumption.clone(), v.constraint.clone()))
                    {
                        // Not `eprintln!`, which panics when standard error is a closed
                        // pipe: the warning is also kept below.
                        let _ = writeln!(std::io::stderr(), "warning: {v}");
                    }
                    self.warnings.push(v);
                }
                Ok(())
            }
        }
    }

    /// Verifies, once, that each family declaring itself affine has `D²g = 0` (on its first
    /// member at the start state): a false claim would skip the A4 and convexity checks.
    fn verify_affine_claims(
        &mut self,
        step: usize,
        t: f64,
        q: &[f64],
        found: &mut Vec<BoundViolation>,
    ) {
        for fam in self.problem.families() {
            if !fam.is_affine() || fam.count() == 0 {
                continue;
            }
            let Some(h) = fam.affine_check(0, t, q) else {
                continue;
            };
            self.second_order_checks += 1;
            let n = (h.len() as f64).sqrt().round() as usize;
            let norm = symmetric_spectral_norm(&h, n);
            if not_within(norm, self.settings.relative_tolerance) {
                found.push(affine_claim_violation(step, t, fam.describe(0), norm));
            }
        }
    }

    fn observe(&mut self, step: usize, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        if self.settings.policy != Policy::Off {
            if let Some(e) = self.invalid.take() {
                return Err(e.into());
            }
        }
        self.check(step, t, q).map_err(|v| v.to_error().into())
    }
}

impl Observer for BoundsMonitor<'_> {
    fn name(&self) -> &str {
        "assumption monitor"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.observe(0, t, q)
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        self.observe(report.step, report.t, q)
    }
}

/// The violation reported for a family that declares itself affine but has `|D²g| = norm`.
pub(crate) fn affine_claim_violation(
    step: usize,
    t: f64,
    constraint: String,
    norm: f64,
) -> BoundViolation {
    BoundViolation {
        step,
        t,
        assumption: AFFINE_CLAIM.into(),
        constraint,
        quantity: "|D²g| (spectral)".into(),
        bound_name: "0".into(),
        bound: 0.0,
        value: norm,
        note: "the kernel says `is_affine() == true` but its Hessian is not zero: the \
               curvature (A4) and convexity checks were skipped on a false premise; return \
               false from `is_affine`"
            .into(),
    }
}
