//! Constraints declared concave ([`Curvature::Concave`]): convex sets `Cᵢ(t) = {gᵢ ≥ 0}`, the
//! class of Moreau's sweeping process. Their linearization at `q_k` contains `Cᵢ` (an outer
//! approximation: `g` lies below its tangent planes), so one projection can end outside. The
//! step projects onto `C(t_{k+1}) ∩ Q̃` instead (`Q̃` the rows of every other constraint),
//! by cutting planes:
//!
//! 1. project onto the assembled rows plus the cuts kept so far;
//! 2. at the answer `x`, every concave member that is violated, or whose rows carry a
//!    multiplier, is linearized at `x`; the step is **certified** when each is within
//!    [`StepperSettings::concave_tolerance`](super::StepperSettings) of its set and the KKT
//!    conditions hold with its gradient *at `x`* (`Σ λ_r a_r − μ ∇gᵢ(x)` over its rows `r`,
//!    `μ ≥ 0` fitted, within the backend's KKT tolerance `kkt_tolerance · max(1, ‖x − y‖∞)`);
//! 3. otherwise a cut `gᵢ(x) + ⟨∇gᵢ(x), z − x⟩ ≥ 0` is added for each member that is not,
//!    each member's active rows are merged into one (their multiplier-weighted mean), its
//!    inactive rows are dropped, and the step is projected again.
//!
//! Each cut contains `Cᵢ(t_{k+1})` (concavity), and so does a convex combination of cuts, so
//! every projection is onto a superset of the true set and the distance `‖x − y‖` never
//! decreases; merging the rows active at `x` and dropping the inactive ones keeps `x` the
//! projection onto what remains (the aggregation of bundle methods), so each member carries
//! at most two rows into a solve. At a certified `x`, feasibility (to the tolerance)
//! and the KKT conditions with the true gradients are exactly the optimality conditions of the
//! projection onto the convex set `C ∩ Q̃`. A member is concave only as declared: the Hessian at
//! each cut point is checked (largest eigenvalue not positive beyond rounding) before the cut
//! is used.

use super::Stepper;
use crate::constraint::{ConstraintFamily, Curvature};
use crate::curvature::{
    convex_direction, describe_point, symmetric_spectrum, CONCAVITY, CONCAVITY_MEANING,
    CONVEXITY_TOLERANCE,
};
use crate::error::SweepError;
use sweeping_api::RowKey;

/// A cut of a concave member: the row `⟨∇gᵢ(xⱼ), u⟩ ≥ ⟨∇gᵢ(xⱼ), xⱼ − q_k⟩ − gᵢ(xⱼ)` in the
/// displacement `u = x − q_k`, linearized at an earlier iterate `xⱼ`.
#[derive(Debug, Clone)]
pub(super) struct Cut {
    family: usize,
    member: usize,
    entries: Vec<(usize, f64)>,
    rhs: f64,
    norm: f64,
    /// Unique within the run: the row's key for warm-starting backends.
    serial: u64,
}

/// The cutting-plane state of a step.
#[derive(Debug, Default)]
pub(super) struct Cuts {
    /// Whether the problem has a concave family at all (otherwise nothing here runs).
    pub(super) enabled: bool,
    /// The cuts currently appended after the assembled rows.
    kept: Vec<Cut>,
    /// Rows assembled before the cuts.
    base_rows: usize,
    next_serial: u64,
    /// Members seen in one check (family, member), reused.
    members: Vec<(usize, usize)>,
    /// Each refined member's distance outside its set at the previous iterate.
    last_violation: Vec<((usize, usize), f64)>,
}

/// The verdict on one iterate.
pub(super) enum Refinement {
    /// The iterate is the projection onto the true sets (to the tolerances).
    Certified,
    /// Cuts were added; the worst member, its distance outside and its residual.
    Refined {
        worst: (usize, usize),
        violation: f64,
        residual: f64,
        added: usize,
    },
}

impl Cuts {
    /// A new cut of member `(family, member)`, keyed by the next serial of the run.
    fn cut(
        &mut self,
        (family, member): (usize, usize),
        entries: Vec<(usize, f64)>,
        rhs: f64,
        norm: f64,
    ) -> Cut {
        let serial = self.next_serial;
        self.next_serial += 1;
        Cut {
            family,
            member,
            entries,
            rhs,
            norm,
            serial,
        }
    }

    pub(super) fn new(enabled: bool) -> Self {
        Self {
            enabled,
            ..Self::default()
        }
    }
}

impl Stepper<'_> {
    /// Forgets the previous step's cuts (they linearize another time's sets).
    pub(super) fn reset_cuts(&mut self) {
        self.cuts.kept.clear();
        self.cuts.last_violation.clear();
    }

    /// Appends the kept cuts after freshly assembled rows.
    pub(super) fn append_cuts(&mut self) {
        self.cuts.base_rows = self.b.len();
        for cut in &self.cuts.kept {
            self.rows.push_row(cut.entries.iter().copied());
            self.b.push(cut.rhs);
            self.row_origin.push((cut.family, cut.member));
            self.row_norms.push(cut.norm);
        }
    }

    /// The key of row `r`: its constraint for an assembled row; for a cut, a key of its own,
    /// family `F + f` (`F` the problem's family count, `f` the cut member's family) and member
    /// the cut's serial, unique within the run.
    pub(super) fn row_key(&self, r: usize) -> RowKey {
        let (fi, idx) = self.row_origin[r];
        match r.checked_sub(self.cuts.base_rows) {
            Some(c) if self.cuts.enabled && c < self.cuts.kept.len() => RowKey {
                family: (self.problem.families().len() + fi) as u32,
                member: self.cuts.kept[c].serial,
            },
            _ => RowKey {
                family: fi as u32,
                member: idx as u64,
            },
        }
    }

    /// Checks the iterate `x` (with the multipliers of the solve) against every concave
    /// member (module docs); when it is not certified, updates the cuts and the rows for the
    /// next solve.
    pub(super) fn refine_concave(
        &mut self,
        t: f64,
        x: &[f64],
        multipliers: &[f64],
    ) -> Result<Refinement, SweepError> {
        if !self.cuts.enabled {
            return Ok(Refinement::Certified);
        }
        let threshold = self.settings.active_threshold;
        let families = self.problem.families();
        // The members to check: those with a multiplier on one of their rows, and those
        // violated at x (a family's candidates within 0 are every violated member).
        let members = &mut self.cuts.members;
        members.clear();
        for (r, &(fi, idx)) in self.row_origin.iter().enumerate() {
            if families[fi].curvature() == Curvature::Concave && multipliers[r] > threshold {
                members.push((fi, idx));
            }
        }
        for (fi, fam) in families.iter().enumerate() {
            if fam.curvature() == Curvature::Concave {
                self.cands.clear();
                fam.candidates(t, x, 0.0, &mut self.cands);
                members.extend(self.cands.iter().map(|&idx| (fi, idx)));
            }
        }
        members.sort_unstable();
        members.dedup();
        let members = std::mem::take(&mut self.cuts.members);

        let disp = x
            .iter()
            .zip(&self.q)
            .zip(&self.dy)
            .map(|((x, q), dy)| (x - q - dy).abs())
            .fold(0.0, f64::max);
        let stationarity_tol = self.settings.kkt_tolerance * disp.max(1.0);
        let mut worst: Option<((usize, usize), f64, f64, f64)> = None;
        let mut new_cuts = Vec::new();
        let mut replaced = Vec::new();
        let mut violations = Vec::new();
        for &(fi, idx) in &members {
            let fam = families[fi].as_ref();
            fam.linearize(idx, t, x, false, &mut self.lin);
            let norm = self.lin.gradient_norm();
            if norm.is_nan() || norm <= 1e-12 || !self.lin.value.is_finite() {
                return Err(SweepError::DegenerateConstraint {
                    step: self.k,
                    t,
                    constraint: fam.describe(idx),
                    norm,
                });
            }
            let violation = (-self.lin.value).max(0.0) / norm;
            let residual = self.member_residual(fi, idx, multipliers);
            // How far from certification, as a multiple of the tolerances (≤ 1: certified).
            let score =
                (violation / self.settings.concave_tolerance).max(residual / stationarity_tol);
            if score <= 1.0 {
                continue;
            }
            if worst.is_none_or(|(_, _, _, s)| score > s) {
                worst = Some(((fi, idx), violation, residual, score));
            }
            self.check_concavity_at(fam, idx, t, x)?;
            // The member's rows are replaced by the cut at x while that converges (its
            // distance outside at least halves); otherwise they are kept, merged.
            let before = self
                .cuts
                .last_violation
                .iter()
                .find(|(m, _)| *m == (fi, idx))
                .map(|&(_, v)| v);
            if before.is_none_or(|b| violation <= 0.5 * b)
                || violation <= self.settings.concave_tolerance
            {
                replaced.push((fi, idx));
            }
            violations.push(((fi, idx), violation));
            let entries: Vec<(usize, f64)> = self
                .lin
                .columns
                .iter()
                .copied()
                .zip(self.lin.gradient.iter().copied())
                .collect();
            // g(x) + ∇g(x)·(z − x) ≥ 0 with z = q_k + u: ∇g·u ≥ ∇g·(x − q_k) − g(x).
            let rhs = entries
                .iter()
                .map(|&(c, v)| v * (x[c] - self.q[c]))
                .sum::<f64>()
                - self.lin.value;
            new_cuts.push(self.cuts.cut((fi, idx), entries, rhs, norm));
        }
        self.cuts.members = members;
        let Some((worst, violation, residual, _)) = worst else {
            return Ok(Refinement::Certified);
        };
        // Each member's active rows become one aggregate cut, its inactive rows are dropped:
        // x stays the projection onto what remains (module docs), with at most two rows per
        // member in the next solve (the aggregate and the new cut), not a growing bundle of
        // nearly parallel ones.
        let added = new_cuts.len();
        let mut kept = self.aggregate_active_rows(multipliers);
        kept.retain(|cut| !replaced.contains(&(cut.family, cut.member)));
        kept.extend(new_cuts);
        self.cuts.kept = kept;
        self.cuts.last_violation = violations;
        self.rebuild_rows_with_cuts();
        Ok(Refinement::Refined {
            worst,
            violation,
            residual,
            added,
        })
    }

    /// For each concave member with a multiplier on some row: the multiplier-weighted mean
    /// of its active rows, `Σ λ_r (a_r, b_r) / Σ λ_r`. A convex combination of valid cuts is
    /// valid, and at `x` (where every active row is tight) it is tight with multiplier
    /// `Σ λ_r` and the same `Σ λ_r a_r`: `x` keeps its KKT conditions.
    fn aggregate_active_rows(&mut self, multipliers: &[f64]) -> Vec<Cut> {
        let threshold = self.settings.active_threshold;
        let families = self.problem.families();
        let mut active: Vec<(usize, usize, usize)> = self
            .row_origin
            .iter()
            .enumerate()
            .filter(|&(r, &(fi, _))| {
                multipliers[r] > threshold && families[fi].curvature() == Curvature::Concave
            })
            .map(|(r, &(fi, idx))| (fi, idx, r))
            .collect();
        active.sort_unstable();
        let mut out = Vec::new();
        for group in active.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)) {
            let (fi, idx) = (group[0].0, group[0].1);
            let total: f64 = group.iter().map(|&(_, _, r)| multipliers[r]).sum();
            let mut entries: Vec<(usize, f64)> = Vec::new();
            let mut rhs = 0.0;
            for &(_, _, r) in group {
                let w = multipliers[r] / total;
                rhs += w * self.b[r];
                for (c, v) in self.rows.row(r) {
                    match entries.iter_mut().find(|(k, _)| *k == c) {
                        Some(e) => e.1 += w * v,
                        None => entries.push((c, w * v)),
                    }
                }
            }
            let norm = entries.iter().map(|(_, v)| v * v).sum::<f64>().sqrt();
            out.push(self.cuts.cut((fi, idx), entries, rhs, norm));
        }
        out
    }

    /// `‖Σ_r λ_r a_r − μ ∇gᵢ(x)‖∞` over the rows `r` of member `(fi, idx)`, with `∇gᵢ(x)` in
    /// `self.lin` and `μ ≥ 0` the best multiplier for it (the projection of `Σ λ_r a_r` on
    /// `∇gᵢ(x)`): what the KKT conditions of the true set miss at `x`.
    fn member_residual(&self, fi: usize, idx: usize, multipliers: &[f64]) -> f64 {
        let lin = &self.lin;
        let mut sum = vec![0.0; lin.columns.len()];
        let mut extra = 0.0f64;
        for (r, &origin) in self.row_origin.iter().enumerate() {
            let lambda = multipliers[r];
            if origin != (fi, idx) || lambda == 0.0 {
                continue;
            }
            for (c, v) in self.rows.row(r) {
                match lin.columns.iter().position(|&k| k == c) {
                    Some(j) => sum[j] += lambda * v,
                    None => extra = extra.max((lambda * v).abs()),
                }
            }
        }
        let n2: f64 = lin.gradient.iter().map(|g| g * g).sum();
        let dot: f64 = sum.iter().zip(&lin.gradient).map(|(s, g)| s * g).sum();
        let mu = (dot / n2).max(0.0);
        sum.iter()
            .zip(&lin.gradient)
            .fold(extra, |m, (s, g)| m.max((s - mu * g).abs()))
    }

    /// The rows assembled before the cuts, except those of concave families (their active
    /// ones live on in the aggregates), then the cuts kept.
    fn rebuild_rows_with_cuts(&mut self) {
        let families = self.problem.families();
        let mut rows = sweeping_api::SparseRows::new(self.q.len());
        let mut kept = 0;
        for r in 0..self.cuts.base_rows {
            let (fi, _) = self.row_origin[r];
            if families[fi].curvature() == Curvature::Concave {
                continue;
            }
            rows.push_row(self.rows.row(r));
            self.b[kept] = self.b[r];
            self.row_origin[kept] = self.row_origin[r];
            self.row_norms[kept] = self.row_norms[r];
            kept += 1;
        }
        self.rows = rows;
        self.b.truncate(kept);
        self.row_origin.truncate(kept);
        self.row_norms.truncate(kept);
        self.append_cuts();
    }

    /// A member declared concave must be concave where the stepper relies on it: the
    /// largest eigenvalue of `D²gᵢ` at `x` not positive beyond rounding.
    pub(super) fn check_concavity_at(
        &self,
        fam: &dyn ConstraintFamily,
        idx: usize,
        t: f64,
        x: &[f64],
    ) -> Result<(), SweepError> {
        let so = fam.second_order(idx, t, x);
        let n = so.columns.len();
        if n == 0 || so.hessian.len() != n * n || so.hessian.iter().any(|v| !v.is_finite()) {
            return Ok(());
        }
        let (_, max_eig, norm) = symmetric_spectrum(&so.hessian, n);
        if convex_direction(max_eig, norm, CONVEXITY_TOLERANCE) {
            return Err(SweepError::AssumptionViolated {
                step: self.k,
                t,
                assumption: CONCAVITY.into(),
                constraint: fam.describe(idx),
                detail: format!(
                    "the largest eigenvalue of D²g = {max_eig:.6e} > 0 at {}, g = {:.3e}: {CONCAVITY_MEANING}",
                    describe_point(&so.columns, x),
                    so.value
                ),
            });
        }
        Ok(())
    }

    /// Before the first step: every member of a concave family, at `(t₀, q₀)`, is concave
    /// there (a false declaration is refused before it is used).
    pub(super) fn check_concavity_claims(&mut self) -> Result<(), SweepError> {
        let (t, q) = (self.t, self.q.clone());
        for fam in self.problem.families() {
            if fam.curvature() != Curvature::Concave || fam.is_affine() {
                continue;
            }
            self.cands.clear();
            fam.candidates(t, &q, f64::INFINITY, &mut self.cands);
            for &idx in &self.cands {
                self.check_concavity_at(fam.as_ref(), idx, t, &q)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "concave_tests.rs"]
mod tests;
