//! Moving constraints: a step is refused when a moving set could pass over a point within
//! it, unseen by the linearization at `t_{k+1}`.

use super::Stepper;
use crate::constraint::{Curvature, LinearizedRow};
use crate::error::SweepError;

impl Stepper<'_> {
    /// Moving boundaries cannot be jumped. For every member of a time-dependent family (all of
    /// them: a fast set may jump a point far outside any cutoff), the step is refused when
    ///
    /// * the constraint's gradient at `q_k` turns by more than 90° between `t_k` and `t_{k+1}`
    ///   (the moving set passed over the point, which the linearization at `t_{k+1}` would then
    ///   keep on the wrong side), or
    /// * where the family knows the margin `c` of A0: `h · max|∂ₜgᵢ| / |∇gᵢ| ≥ gᵢ(t_k, q_k) + c`,
    ///   the paper's condition `h < c/K_L` (with `K_L ≤ β/α` by A1–A2) applied to each member
    ///   with its current distance: the set moves less in one step than its distance to the
    ///   point's own "centre" (for a person and a wall: the wall cannot reach the centre).
    ///
    /// The error names the member and the `h` (half the largest allowed) that would pass.
    pub(super) fn check_moving_constraints(
        &mut self,
        t_k: f64,
        t_next: f64,
    ) -> Result<(), SweepError> {
        let h = t_next - t_k;
        for fam in self.problem.families() {
            if !fam.is_time_dependent() {
                continue;
            }
            let margin = fam.a0_margin().filter(|c| c.is_finite() && *c > 0.0);
            self.cands.clear();
            // Every member: a set moving fast may jump a point far outside any cutoff.
            fam.candidates(t_k, &self.q, f64::INFINITY, &mut self.cands);
            let mut now = LinearizedRow::default();
            for &idx in &self.cands {
                fam.linearize(idx, t_k, &self.q, true, &mut now);
                fam.linearize(idx, t_next, &self.q, true, &mut self.lin);
                let next = &self.lin;
                let (n0, n1) = (now.gradient_norm(), next.gradient_norm());
                if !(n0 > 1e-12 && now.value.is_finite()) {
                    continue; // reported by the assembly with its own error
                }
                // A gradient that vanishes (or is NaN) at t_{k+1} but not at t_k: the moving
                // set's singular point (a disk's centre, a segment) reached the point itself.
                let cos = if n1 > 1e-12 {
                    now.gradient
                        .iter()
                        .zip(&next.gradient)
                        .map(|(a, b)| a * b)
                        .sum::<f64>()
                        / (n0 * n1)
                } else {
                    -1.0
                };
                // Speed of the set along the normal, |∂ₜg| / |∇g|, at both ends of the step.
                // The change of g over the step counts too: a path may speed up in between.
                let speed = [
                    now.dt.unwrap_or(0.0).abs() / n0,
                    next.dt.unwrap_or(0.0).abs() / n1,
                    (next.value - now.value).abs() / (h * n0.min(n1)),
                ]
                .into_iter()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
                let clearance = now.value.max(0.0) + margin.unwrap_or(0.0);
                let too_far = margin.is_some() && h * speed >= clearance;
                // A path that turns inside the step moves the set where neither end sees it
                // (4 m out and back within one step went through two people unnoticed): the
                // length of its path in the step bounds how far `g` can fall there.
                // Asked only where it can refuse the step: it is per member, at every step.
                let travel = margin.and_then(|_| fam.travel_within(idx, t_k, t_next));
                let travels_too_far = travel.is_some_and(|t| t.distance >= clearance);
                if cos < 0.0 || too_far || travels_too_far {
                    let fastest = travel.map_or(speed, |t| t.max_speed.max(speed));
                    let suggested_h = if fastest > 0.0 && clearance > 0.0 {
                        0.5 * clearance / fastest
                    } else {
                        0.25 * h
                    };
                    let normal_lost = n1.is_nan() || n1 <= 1e-12;
                    let detail = if cos < 0.0 && normal_lost {
                        // Not a turn that was measured: the normal at the end of the step
                        // vanished, or is not a number (a set moving at 1e308 m/s is
                        // nowhere representable a step later).
                        if n1.is_nan() {
                            "its normal at the point is not a number at the end of the step (the moving set's position overflows)".to_string()
                        } else {
                            "its normal at the point vanishes at the end of the step (the moving set's centre or edge reaches the point)".to_string()
                        }
                    } else if cos < 0.0 {
                        format!(
                            "its normal at the point turns by {:.0}° within the step (the moving set passes over the point)",
                            cos.clamp(-1.0, 1.0).acos().to_degrees()
                        )
                    } else if travels_too_far && !too_far {
                        format!(
                            "its path within the step is {:.3e} long (up to {:.3e} per second), not less than the clearance g + c = {:.3e}",
                            travel.map_or(0.0, |t| t.distance),
                            travel.map_or(0.0, |t| t.max_speed),
                            clearance
                        )
                    } else {
                        format!(
                            "it moves {:.3e} along its normal in one step (h·|∂ₜg|/|∇g|), not less than the clearance g + c = {:.3e}",
                            h * speed,
                            clearance
                        )
                    };
                    return Err(SweepError::StepTooLong {
                        step: self.k,
                        t: t_next,
                        constraint: fam.describe(idx),
                        h,
                        suggested_h,
                        detail,
                    });
                }
            }
        }
        Ok(())
    }

    /// A path that turns inside the step (a waypoint strictly between `t_k` and `t_{k+1}`)
    /// is where the step cannot see it: the scheme linearizes at `q_k` with `Q(t_{k+1})`. The
    /// step is refused when, at such a waypoint, the set overlaps the person by more than the
    /// violation tolerance at both `q_k` and `x = q_{k+1}`: `gᵢ` is convex in the point, so
    /// it then overlaps every point of the straight line between them, whatever the pace.
    /// A concave family is not checked so: for it that inference does not hold (its set is
    /// convex, and a segment between two points outside it may cross it).
    pub(super) fn check_waypoints(
        &mut self,
        t_k: f64,
        t_next: f64,
        x: &[f64],
    ) -> Result<(), SweepError> {
        let tol = self.settings.violation_tolerance;
        let mut waypoints = Vec::new();
        for fam in self.problem.families() {
            if !fam.is_time_dependent() || fam.curvature() == Curvature::Concave {
                continue;
            }
            waypoints.clear();
            fam.waypoints_within(t_k, t_next, &mut waypoints);
            waypoints.sort_by(f64::total_cmp);
            waypoints.dedup();
            for &tw in &waypoints {
                self.cands.clear();
                fam.candidates(tw, x, 0.0, &mut self.cands);
                for &idx in &self.cands {
                    // A value that is not a number is the violation check's to report.
                    let at_next = fam.value(idx, tw, x, &mut self.lin);
                    let at_k = fam.value(idx, tw, &self.q, &mut self.lin);
                    if at_next.is_nan() || at_k.is_nan() || at_next.max(at_k) >= -tol {
                        continue;
                    }
                    let h = t_next - t_k;
                    let since_start = tw - self.problem.t0();
                    let suggested_h = since_start / (since_start / h).ceil().max(1.0);
                    return Err(SweepError::PathTurnsWithinStep {
                        step: self.k,
                        t: t_next,
                        t_k,
                        constraint: fam.describe(idx),
                        waypoint: tw,
                        overlap: -at_next.max(at_k),
                        tolerance: tol,
                        h,
                        suggested_h,
                    });
                }
            }
        }
        Ok(())
    }
}
