//! The broad phase and the assembly: each family's candidates within its cutoff, linearized
//! into the rows of `Q̃(t_{k+1}, q_k)`.

use super::{StageTimes, Stepper};
use crate::error::SweepError;
use std::time::Instant;

/// The per-family cache of the assembly.
pub(super) struct FamilyState {
    /// The cutoff the family is asked for candidates within.
    pub(super) cutoff: f64,
    /// The drift bound `δ` of the previous step's solution: displacements change little from
    /// one step to the next, so `1.5 δ` is a good first cutoff (a crowd pushed by a wall moves
    /// faster than its own prediction says).
    pub(super) last_drift: f64,
}

impl Stepper<'_> {
    /// The first cutoff of each culling family for the step to `t_next`: twice the drift
    /// bound of the prediction itself, or 1.5 times the previous step's, whichever is larger.
    /// Only the cost depends on this guess: the culling proof decides whether the step is
    /// exact.
    pub(super) fn size_cutoffs(&mut self, t_next: f64) {
        for (fi, fam) in self.problem.families().iter().enumerate() {
            if fam.culls() {
                let d = fam.linearization_drift_bound(t_next, &self.q, &self.y);
                let state = &mut self.families[fi];
                state.cutoff = self
                    .settings
                    .min_cutoff
                    .max(2.0 * d)
                    .max(1.5 * state.last_drift);
            }
        }
    }

    /// Assembles the rows of `Q̃(t_next, q_k)`, in the displacement `u = x − q_k`: first every
    /// member of the equality families, `∇hⱼ · u = −hⱼ` (the leading rows of the QP), then
    /// the candidates within each family's cutoff, `∇gᵢ · u ≥ −gᵢ`.
    pub(super) fn assemble(
        &mut self,
        t_next: f64,
        times: &mut StageTimes,
    ) -> Result<(), SweepError> {
        self.rows.clear();
        self.b.clear();
        self.row_origin.clear();
        self.row_norms.clear();
        let want_dt = self.settings.want_time_derivatives;
        let t0 = Instant::now();
        let problem = self.problem;
        let first_equality = problem.families().len();
        for (j, fam) in problem.equalities().iter().enumerate() {
            for idx in 0..fam.count() {
                fam.linearize(idx, t_next, &self.q, want_dt, &mut self.lin);
                self.push_linearized(first_equality + j, idx, t_next)?;
            }
        }
        self.equality_rows = self.b.len();
        times.assembly += t0.elapsed().as_secs_f64();
        for (fi, fam) in problem.families().iter().enumerate() {
            let t0 = Instant::now();
            self.cands.clear();
            fam.candidates(t_next, &self.q, self.families[fi].cutoff, &mut self.cands);
            let t1 = Instant::now();
            times.broad_phase += (t1 - t0).as_secs_f64();
            for i in 0..self.cands.len() {
                let idx = self.cands[i];
                fam.linearize(idx, t_next, &self.q, want_dt, &mut self.lin);
                self.push_linearized(fi, idx, t_next)?;
            }
            times.assembly += t1.elapsed().as_secs_f64();
        }
        Ok(())
    }

    /// Appends the row of the constraint just linearized into `self.lin`: member `idx` of the
    /// family `fi` ([`Problem::family_at`](crate::problem::Problem::family_at)'s numbering).
    fn push_linearized(&mut self, fi: usize, idx: usize, t_next: f64) -> Result<(), SweepError> {
        let fam = self.problem.family_at(fi);
        let lin = &self.lin;
        if !lin.value.is_finite() || lin.gradient.iter().any(|v| !v.is_finite()) {
            return Err(SweepError::NonFinite {
                step: self.k,
                t: t_next,
                what: format!(
                    "constraint {} (value {}, gradient {:?})",
                    fam.describe(idx),
                    lin.value,
                    lin.gradient
                ),
            });
        }
        let norm = lin.gradient_norm();
        if norm < 1e-12 {
            return Err(SweepError::DegenerateConstraint {
                step: self.k,
                t: t_next,
                constraint: fam.describe(idx),
                norm,
            });
        }
        // Row of Q̃ in the displacement u = x − q_k: ∇g · u ≥ −g (see `step`).
        self.rows.push_row(
            lin.columns
                .iter()
                .copied()
                .zip(lin.gradient.iter().copied()),
        );
        self.b.push(-lin.value);
        self.row_origin.push((fi, idx));
        self.row_norms.push(norm);
        Ok(())
    }
}
