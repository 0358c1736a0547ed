//! The check stage: nothing the backend answers is used unchecked (finite, KKT), the
//! culling proof, A1 on the active rows, and the true constraints at the new configuration.

use super::Stepper;
use crate::constraint::{ConstraintId, Curvature};
use crate::error::SweepError;
use sweeping_api::{Projection, ProjectionProblem};

impl Stepper<'_> {
    /// A projection with a coordinate that is not a number is refused before anything uses
    /// it.
    pub(super) fn check_finite_projection(
        &self,
        sol: &Projection,
        t_next: f64,
    ) -> Result<(), SweepError> {
        match sol.x.iter().position(|v| !v.is_finite()) {
            Some(i) => Err(SweepError::NonFinite {
                step: self.k,
                t: t_next,
                what: format!(
                    "the projection's coordinate {i} (backend {})",
                    sol.stats.backend
                ),
            }),
            None => Ok(()),
        }
    }

    /// The KKT conditions of the projection at the backend's answer, each residual relative to
    /// the size of its terms: whatever status the solver reported, an answer that is not the
    /// projection is never used.
    pub(super) fn check_kkt(
        &self,
        qp: &ProjectionProblem,
        sol: &Projection,
        t_next: f64,
    ) -> Result<(), SweepError> {
        let tol = self.settings.kkt_tolerance;
        if tol.is_infinite() {
            return Ok(());
        }
        let hint = kkt_hint(qp);
        let wrong = |residuals: String, scale: f64| SweepError::KktCheckFailed {
            step: self.k,
            t: t_next,
            backend: sol.stats.backend.clone(),
            residuals,
            tolerance: tol,
            scale,
            hint: hint.clone(),
        };
        if sol.x.len() != qp.dim() || sol.multipliers.len() != qp.n_rows() {
            return Err(wrong(
                format!(
                    "{} coordinates and {} multipliers for a problem of dimension {} with {} rows",
                    sol.x.len(),
                    sol.multipliers.len(),
                    qp.dim(),
                    qp.n_rows()
                ),
                1.0,
            ));
        }
        let r = qp.kkt_residuals(&sol.x, &sol.multipliers);
        // Each residual against the size of the terms it is made of (what rounding alone
        // leaves): Ax − b against b, x − y − Aᵀλ against x − y, λᵢ(Ax − b)ᵢ against both.
        let inf = |v: &[f64]| v.iter().map(|a| a.abs()).fold(0.0, f64::max);
        let disp = sol
            .x
            .iter()
            .zip(qp.y())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let primal_scale = 1f64.max(inf(qp.b()));
        let lambda_scale = 1f64.max(inf(&sol.multipliers));
        let scale = primal_scale.max(disp).max(lambda_scale);
        // In a metric, W(x − y) is up to ‖W‖∞ times the displacement.
        let ok = r.primal <= tol * primal_scale
            && r.stationarity <= tol * 1f64.max(disp) * self.metric_scale
            && r.dual <= tol * lambda_scale
            && r.complementarity <= tol * primal_scale * lambda_scale;
        if ok {
            Ok(())
        } else {
            Err(wrong(
                format!(
                    "primal {:.2e}, stationarity {:.2e}, dual {:.2e}, complementarity {:.2e}",
                    r.primal, r.stationarity, r.dual, r.complementarity
                ),
                scale,
            ))
        }
    }

    /// The culling proof (module docs): every omitted row holds at `x` when `δ ≤ cutoff`.
    /// Where it fails, the family's cutoff grows to `2δ` for the next solve.
    pub(super) fn culling_proven(&mut self, t_next: f64, x: &[f64]) -> bool {
        let mut proven = true;
        for (fi, fam) in self.problem.families().iter().enumerate() {
            if fam.culls() {
                let d = fam.linearization_drift_bound(t_next, &self.q, x);
                self.families[fi].last_drift = d;
                if d > self.families[fi].cutoff {
                    self.families[fi].cutoff = 2.0 * d;
                    proven = false;
                }
            }
        }
        proven
    }

    /// A run never continues from a configuration outside Q(t): the linearized set is an
    /// inner approximation of Q for convex gᵢ (paper, inclusion after equation `schema`), so
    /// a violation beyond the solver's accuracy means the answer is wrong.
    pub(super) fn check_violation(
        &self,
        max_violation: f64,
        worst_constraint: Option<ConstraintId>,
        t_next: f64,
        x: &[f64],
    ) -> Result<(), SweepError> {
        if max_violation.is_nan() || max_violation > self.settings.violation_tolerance {
            return Err(SweepError::ViolationTooLarge {
                step: self.k,
                t: t_next,
                constraint: worst_constraint
                    .map(|id| self.problem.describe(id))
                    .unwrap_or_default(),
                violation: max_violation,
                tolerance: self.settings.violation_tolerance,
                why: worst_constraint.and_then(|id| self.convexity_failure(id, t_next, x)),
            });
        }
        Ok(())
    }

    /// The largest violation of the true constraints at the new configuration, as a distance
    /// `max(0, −gᵢ(t, x))/|∇gᵢ(t, x)|` (in the units of `q`, whatever the scale of `gᵢ`), and
    /// the constraint that has it (`NaN` when some `gᵢ` is not a number).
    ///
    /// For a culling family only the assembled rows can be violated: an omitted member has
    /// `gᵢ(t, q) + ⟨∇gᵢ, x − q⟩ ≥ 0` by the culling proof, and `gᵢ` is convex in `q`, so
    /// `gᵢ(t, x) ≥ gᵢ(t, q) + ⟨∇gᵢ, x − q⟩ ≥ 0`. That makes the check `O(rows)` instead of a
    /// second broad phase. Families that do not cull, and concave ones (for which that
    /// inequality goes the other way), are checked through their candidates within 0 at `x`:
    /// every violated member.
    pub(super) fn true_violation(&mut self, t: f64, x: &[f64]) -> (f64, Option<ConstraintId>) {
        let families = self.problem.families();
        // (distance, family, member) of the largest distance seen; a NaN wins over everything.
        let mut worst: Option<(f64, usize, usize)> = None;
        let mut consider = |d: f64, fi: usize, idx: usize| {
            let replace = match worst {
                None => true,
                Some((w, _, _)) => !w.is_nan() && (d.is_nan() || d > w),
            };
            if replace {
                worst = Some((d, fi, idx));
            }
        };
        // A flat constraint (`x³ ≥ 0` near 0) is violated by tiny values far from its set, so
        // the value is divided by the gradient's length; a vanishing gradient is infinitely far.
        let distance = |value: f64, norm: f64| {
            if value.is_nan() {
                f64::NAN
            } else if value >= 0.0 {
                0.0
            } else if norm > 0.0 {
                -value / norm
            } else {
                f64::INFINITY
            }
        };
        let by_rows = |fam: &dyn crate::constraint::ConstraintFamily| {
            fam.culls() && fam.curvature() == Curvature::Convex
        };
        // Equality rows (family index past the inequalities) are measured apart.
        for &(fi, idx) in &self.row_origin[self.equality_rows..] {
            if by_rows(families[fi].as_ref()) {
                let v = families[fi].value(idx, t, x, &mut self.lin);
                // The gradient only where it is needed: the row is violated.
                let d = if v < 0.0 {
                    families[fi].linearize(idx, t, x, false, &mut self.lin);
                    distance(v, self.lin.gradient_norm())
                } else {
                    distance(v, 1.0)
                };
                consider(d, fi, idx);
            }
        }
        let _ = self.problem.for_each_linearized(
            t,
            x,
            |fam| (!by_rows(fam)).then_some(0.0),
            false,
            &mut self.scratch,
            |_, id, row| {
                consider(
                    distance(row.value, row.gradient_norm()),
                    id.family,
                    id.member,
                );
                Ok::<(), std::convert::Infallible>(())
            },
        );
        let id = |family, member| Some(ConstraintId { family, member });
        match worst {
            Some((d, fi, idx)) if d.is_nan() => (f64::NAN, id(fi, idx)),
            Some((d, fi, idx)) if d > 0.0 => (d, id(fi, idx)),
            _ => (0.0, None),
        }
    }

    /// `maxⱼ |hⱼ(t, x)|` over every equality constraint; NaN when one is not a number.
    pub(super) fn equality_residual(&mut self, t: f64, x: &[f64]) -> f64 {
        let mut worst = 0.0;
        for fam in self.problem.equalities() {
            for member in 0..fam.count() {
                let h = fam.value(member, t, x, &mut self.lin);
                worst = sweeping_api::max_or_nan(worst, h.abs());
            }
        }
        worst
    }

    /// A1 where it matters: a row active at the solution with `|∇gᵢ|` below
    /// [`StepperSettings::gradient_floor`](super::StepperSettings::gradient_floor) decides the step with a normal it hardly has.
    pub(super) fn check_active_gradients(
        &self,
        sol: &Projection,
        t_next: f64,
    ) -> Result<(), SweepError> {
        let floor = self.settings.gradient_floor;
        let threshold = self.settings.active_threshold;
        for ((&lambda, &norm), &(fi, idx)) in sol
            .multipliers
            .iter()
            .zip(&self.row_norms)
            .zip(&self.row_origin)
        {
            // An equality's multiplier has either sign.
            if lambda.abs() > threshold && norm < floor {
                return Err(SweepError::DegenerateConstraint {
                    step: self.k,
                    t: t_next,
                    constraint: self.problem.family_at(fi).describe(idx),
                    norm,
                });
            }
        }
        Ok(())
    }

    /// Why a violated constraint could be violated: `D²gᵢ` at the point has a negative
    /// eigenvalue, so `gᵢ` is not convex there and the linearization overshoots (`None` when
    /// it is convex there, or not a number).
    fn convexity_failure(&self, id: ConstraintId, t: f64, x: &[f64]) -> Option<String> {
        use crate::curvature::{
            concave_direction, describe_point, symmetric_min_eigenvalue, symmetric_spectral_norm,
            CONVEXITY_MEANING, CONVEXITY_TOLERANCE,
        };
        let fam = &self.problem.families()[id.family];
        if fam.curvature() == Curvature::Concave {
            // Refined until certified: its violation is not a linearization's overshoot.
            return None;
        }
        let so = fam.second_order(id.member, t, x);
        let n = so.columns.len();
        if n == 0 || so.hessian.len() != n * n || so.hessian.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let min_eig = symmetric_min_eigenvalue(&so.hessian, n);
        let norm = symmetric_spectral_norm(&so.hessian, n);
        concave_direction(min_eig, norm, CONVEXITY_TOLERANCE).then(|| {
            format!(
                "convexity fails there: the smallest eigenvalue of D²g is {min_eig:.3e} < 0 at {}: {CONVEXITY_MEANING}",
                describe_point(&so.columns, x)
            )
        })
    }
}

/// A prediction this many times farther than the farthest constraint's distance is beyond
/// what the projection resolves in double precision, whatever the backend.
const FAR_PREDICTION: f64 = 1e4;

/// What a failed KKT check asks of the user (see [`SweepError::KktCheckFailed`]): the QP is in
/// the displacement `u = x − q_k`, so `‖y‖∞` is the step's travel and `|bᵢ|` the distances
/// to the constraints.
fn kkt_hint(qp: &ProjectionProblem) -> String {
    let travel = qp.y().iter().fold(0.0, |m: f64, v| m.max(v.abs()));
    let reach = qp.b().iter().fold(1.0, |m: f64, v| m.max(v.abs()));
    if travel > FAR_PREDICTION * reach {
        format!(
            "the prediction moves people up to {travel:.3e} in one step, {:.1e} times the \
             farthest constraint's distance ({reach:.3e}): the projection cannot be resolved \
             at that scale; use a shorter step or lower speeds",
            travel / reach
        )
    } else {
        "a backend set loose on purpose (OsqpSettings::loose, ClarabelSettings::loose) needs \
         StepperSettings::kkt_tolerance raised to match"
            .to_string()
    }
}
