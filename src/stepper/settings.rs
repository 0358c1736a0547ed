//! The settings of a run: plain values with documented defaults, checked when a
//! [`Stepper`](super::Stepper) is made.

use super::prediction::Prediction;
use crate::error::SweepError;
use serde::{Deserialize, Serialize};

/// Settings of a run; plain values with documented defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StepperSettings {
    /// Time step `h` (> 0). Default `0.01` (the paper's `h_min`).
    pub h: f64,
    /// Final time `T`. The run makes `n = ⌈(T − t₀)/h⌉` steps, the last one shortened to land on
    /// `T` when `h` does not divide `T − t₀`. Default `1.0`.
    pub t_end: f64,
    /// Explicit or averaged prediction. Default explicit.
    pub prediction: Prediction,
    /// A multiplier above this counts the row as active in reports. Default `1e-9`.
    pub active_threshold: f64,
    /// `q₀ ∈ Q(t₀)` is accepted when every `gᵢ(t₀, q₀) ≥ −feasibility_tolerance`. Default
    /// `1e-9`.
    pub feasibility_tolerance: f64,
    /// Smallest cutoff a culling family is asked for (the cutoff of a step is
    /// `max(min_cutoff, 2 δ(y))`, with `δ` the drift bound of the prediction). Default `0.0`.
    pub min_cutoff: f64,
    /// Most re-solves of a step whose culling proof fails. Default `12`.
    pub max_cull_retries: usize,
    /// Keep the configuration every this many steps in [`Run::trajectory`](super::Run::trajectory) (0: keep only the
    /// start and the end). Default `1`.
    pub record_every: usize,
    /// Compute `∂ₜgᵢ` of every assembled row (for the run-time checks of A2). Default `false`.
    pub want_time_derivatives: bool,
    /// The run fails with [`SweepError::ViolationTooLarge`] when, after a step, some true
    /// constraint is violated by more than `violation_tolerance` as a distance,
    /// `max(0, −gᵢ)/|∇gᵢ|` at `(t_{k+1}, q_{k+1})` (in the units of `q`: metres for crowds,
    /// whatever the scale of `gᵢ`). The scheme keeps the configuration inside `Q(t)` up to the
    /// solver's accuracy, so a larger violation means the answer is wrong. Default `1e-6`.
    pub violation_tolerance: f64,
    /// Every backend's answer `(x, λ)` is checked against the KKT conditions of the projection
    /// before it is used; the run fails with [`SweepError::KktCheckFailed`] when a residual
    /// exceeds `kkt_tolerance` times the size of its terms: primal `b − Ax` against
    /// `max(1, ‖b‖∞)`, stationarity `x − y − Aᵀλ` against `max(1, ‖x − y‖∞)`, dual `−λ` against
    /// `max(1, ‖λ‖∞)`, complementarity against the product of the first and the last.
    /// Default `1e-6`.
    pub kkt_tolerance: f64,
    /// A1 near contact: the run fails with [`SweepError::DegenerateConstraint`] when a row
    /// active at a step's solution has `|∇gᵢ(t_{k+1}, q_k)| < gradient_floor` (absolute, in
    /// units of `g` per unit of `q`). A constraint that flattens where it touches (a double
    /// root, `g = (x − 1)²`) otherwise pins the point where `∇g` vanishes, a wrong answer
    /// without an error. `0` disables the check. Default `1e-6`.
    pub gradient_floor: f64,
    /// A constraint declared concave ([`Curvature::Concave`](crate::constraint::Curvature),
    /// a convex set) is projected onto exactly: its linearization is refined at each iterate
    /// until the iterate is within `concave_tolerance` of the set (a distance,
    /// `max(0, −gᵢ)/|∇gᵢ|`) and satisfies the KKT conditions with `∇gᵢ` at the iterate
    /// (the part of the stationarity residual its linearizations leave, within the
    /// backend's own KKT check: `kkt_tolerance · max(1, ‖x − y‖∞)`). The distance cannot be
    /// met below the backend's accuracy. Default `1e-9`.
    pub concave_tolerance: f64,
    /// Most refinements of a step's concave constraints (each one more projection) before the
    /// run fails with [`SweepError::ConcaveNotCertified`]. Default `50`.
    pub max_concave_iterations: usize,
    /// Keep each step's contacts, the rows active at its solution with their multipliers and
    /// gradients, in [`StepReport::contacts`](super::StepReport::contacts): the contact forces
    /// of a crowd. Off, a step allocates nothing for them. Default `false`.
    pub record_contacts: bool,
}

impl Default for StepperSettings {
    fn default() -> Self {
        Self {
            h: 0.01,
            t_end: 1.0,
            prediction: Prediction::Explicit,
            active_threshold: 1e-9,
            feasibility_tolerance: 1e-9,
            min_cutoff: 0.0,
            max_cull_retries: 12,
            record_every: 1,
            want_time_derivatives: false,
            violation_tolerance: 1e-6,
            kkt_tolerance: 1e-6,
            gradient_floor: 1e-6,
            concave_tolerance: 1e-9,
            max_concave_iterations: 50,
            record_contacts: false,
        }
    }
}

impl StepperSettings {
    /// Refuses settings the scheme cannot run with from `t0`: a step that is not positive, a
    /// horizon before the start, tolerances out of range, more steps than a `usize` counts.
    pub(super) fn check(&self, t0: f64) -> Result<(), SweepError> {
        if !(self.h.is_finite() && self.h > 0.0) {
            return Err(SweepError::InvalidInput(format!(
                "the time step h = {} must be positive and finite",
                self.h
            )));
        }
        if !(self.t_end.is_finite() && self.t_end >= t0) {
            return Err(SweepError::InvalidInput(format!(
                "the final time T = {} must be finite and ≥ t₀ = {}",
                self.t_end, t0
            )));
        }
        if let Prediction::Averaged { points } = self.prediction {
            if !(1..=5).contains(&points) {
                return Err(SweepError::InvalidInput(format!(
                    "averaged prediction needs 1 to 5 quadrature points, got {points}"
                )));
            }
        }
        if !(self.feasibility_tolerance >= 0.0 && self.min_cutoff >= 0.0) {
            return Err(SweepError::InvalidInput(
                "feasibility_tolerance and min_cutoff must be ≥ 0".into(),
            ));
        }
        if !(self.gradient_floor.is_finite() && self.gradient_floor >= 0.0) {
            return Err(SweepError::InvalidInput(format!(
                "gradient_floor = {} must be finite and ≥ 0 (0 disables the check)",
                self.gradient_floor
            )));
        }
        for (name, v) in [
            ("violation_tolerance", self.violation_tolerance),
            ("kkt_tolerance", self.kkt_tolerance),
            ("concave_tolerance", self.concave_tolerance),
        ] {
            if v.is_nan() || v <= 0.0 {
                return Err(SweepError::InvalidInput(format!(
                    "{name} = {v} must be positive (use f64::INFINITY to disable the check)"
                )));
            }
        }
        // The step count is a usize: a horizon of 1e300 steps would overflow it (and never end).
        let steps = ((self.t_end - t0) / self.h).ceil();
        if steps.is_nan() || steps > 1e12 {
            // In scientific notation when tiny or huge: h = 1e-300 printed 300 zeros.
            let readable = |v: f64| {
                if v == 0.0 || (1e-4..1e7).contains(&v.abs()) {
                    format!("{v}")
                } else {
                    format!("{v:e}")
                }
            };
            return Err(SweepError::InvalidInput(format!(
                "T − t₀ = {} with h = {} would take {steps:.3e} steps (at most 1e12)",
                readable(self.t_end - t0),
                readable(self.h)
            )));
        }
        Ok(())
    }
}
