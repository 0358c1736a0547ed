//! The projection stage: one QP per solve, in the displacement `u = x − q_k`, solved again
//! with larger cutoffs until the culling proof holds.

use super::concave::Refinement;
use super::{StageTimes, Stepper};
use crate::error::SweepError;
use std::time::Instant;
use sweeping_api::{BackendCounters, Projection, ProjectionProblem, Projector};

/// The projection a step keeps, and what the solves that led to it cost.
pub(super) struct Solved {
    /// The projection onto every row, as the point `q_{k+1}` (not the displacement).
    pub(super) solution: Projection,
    /// Solves of the step (1 + re-solves after a failed culling proof + refinements of
    /// concave constraints).
    pub(super) solves: usize,
    /// Cuts of concave constraints added in the step.
    pub(super) cuts: usize,
    /// Solver iterations, summed over the solves.
    pub(super) iterations: u32,
    /// How the backend reached its answers, summed over the solves.
    pub(super) counters: BackendCounters,
}

impl Stepper<'_> {
    /// Assembles, projects and checks until the culling proof holds (module docs) and the
    /// concave constraints are certified (`concave.rs`): the result is the projection onto
    /// every row and onto the convex sets of the concave constraints.
    pub(super) fn project_until_proven(
        &mut self,
        projector: &mut dyn Projector,
        t_next: f64,
        times: &mut StageTimes,
    ) -> Result<Solved, SweepError> {
        let mut solves = 0usize;
        let mut culling_solves = 0usize;
        let mut refinements = 0usize;
        let mut cuts = 0usize;
        let mut iterations = 0u32;
        let mut counters = BackendCounters::default();
        let mut assembled = false;
        self.reset_cuts();
        loop {
            if !assembled {
                self.assemble(t_next, times)?;
                self.append_cuts();
                assembled = true;
            }
            let tp = Instant::now();
            let (qp, mut sol) = self.project_rows(projector, t_next)?;
            times.projection += tp.elapsed().as_secs_f64();
            solves += 1;
            iterations += sol.stats.iterations;
            counters.add(&sol.stats.counters);
            self.check_finite_projection(&sol, t_next)?;
            let tc = Instant::now();
            self.check_kkt(&qp, &sol, t_next)?;
            times.check += tc.elapsed().as_secs_f64();
            // From the displacement to the point.
            sol.x.iter_mut().zip(&self.q).for_each(|(x, q)| *x += q);

            let tc = Instant::now();
            let proven = self.culling_proven(t_next, &sol.x);
            times.check += tc.elapsed().as_secs_f64();
            if !proven {
                culling_solves += 1;
                if culling_solves > self.settings.max_cull_retries {
                    return Err(SweepError::CullingFailed {
                        step: self.k,
                        t: t_next,
                        solves,
                    });
                }
                assembled = false;
                continue;
            }
            let tc = Instant::now();
            let refinement = self.refine_concave(t_next, &sol.x, &sol.multipliers);
            times.check += tc.elapsed().as_secs_f64();
            match refinement? {
                Refinement::Certified => {
                    return Ok(Solved {
                        solution: sol,
                        solves,
                        cuts,
                        iterations,
                        counters,
                    })
                }
                Refinement::Refined {
                    worst,
                    violation,
                    residual,
                    added,
                } => {
                    refinements += 1;
                    cuts += added;
                    if refinements > self.settings.max_concave_iterations {
                        let disp = sol
                            .x
                            .iter()
                            .zip(&self.q)
                            .zip(&self.dy)
                            .map(|((x, q), dy)| (x - q - dy).abs())
                            .fold(0.0, f64::max);
                        return Err(SweepError::ConcaveNotCertified {
                            step: self.k,
                            t: t_next,
                            constraint: self.problem.families()[worst.0].describe(worst.1),
                            iterations: refinements - 1,
                            violation,
                            residual,
                            tolerance: self.settings.concave_tolerance,
                            stationarity_tolerance: self.settings.kkt_tolerance * disp.max(1.0),
                        });
                    }
                }
            }
        }
    }

    /// The QP of the assembled rows and the backend's answer to it, in the displacement.
    fn project_rows(
        &self,
        projector: &mut dyn Projector,
        t_next: f64,
    ) -> Result<(ProjectionProblem, Projection), SweepError> {
        // Each row keyed by its constraint (family, candidate index), stable across steps,
        // so that backends can warm-start from the previous step's active rows.
        let keys = (0..self.row_origin.len())
            .map(|r| self.row_key(r))
            .collect();
        // The projection of the displacement: `u = x − q_k` is the projection of `h f`
        // onto `∇gᵢ · u ≥ −gᵢ`, the scheme's step written relative to `q_k`. Its numbers
        // are those of the step, wherever the scene lies: written in `x`, a room at 10⁶
        // put six digits before the ones that matter in `y` and `b`, and tolerances
        // relative to the data's size let overlaps of 7e-7 through.
        let qp = ProjectionProblem::new(self.dy.clone(), self.rows.clone(), self.b.clone())
            .and_then(|p| p.with_row_keys(keys))
            .and_then(|p| self.with_metric_and_equalities(p))
            .map_err(|e| SweepError::Projection {
                step: self.k,
                t: t_next,
                rows: self.b.len(),
                source: e,
            })?;
        let sol = match projector.project(&qp) {
            Ok(sol) => sol,
            Err(e) => self.rescaled_projection(projector, &qp, e, t_next)?,
        };
        Ok((qp, sol))
    }

    /// The problem's metric and the step's leading equality rows on `qp` (nothing to do, and
    /// nothing done, without them).
    fn with_metric_and_equalities(
        &self,
        mut qp: ProjectionProblem,
    ) -> Result<ProjectionProblem, sweeping_api::ProjectionError> {
        if !self.problem.metric().is_identity() {
            qp = qp.with_metric(self.problem.metric().clone())?;
        }
        if self.equality_rows > 0 {
            qp = qp.with_leading_equalities(self.equality_rows)?;
        }
        Ok(qp)
    }

    /// The constraints of the assembled rows `rows`, by name, at most
    /// [`EMPTY_SET_NAMED`](crate::error::EMPTY_SET_NAMED) of them.
    fn names_of_rows(&self, rows: impl Iterator<Item = usize>) -> Vec<String> {
        rows.filter_map(|r| self.row_origin.get(r))
            .take(crate::error::EMPTY_SET_NAMED)
            .map(|&(fi, idx)| self.problem.family_at(fi).describe(idx))
            .collect()
    }

    /// A backend's certificate that the step's set is empty, said by the constraints it rests
    /// on (people, walls, obstacles), or the error back when it names no rows.
    fn empty_set(
        &self,
        error: sweeping_api::ProjectionError,
        t_next: f64,
    ) -> Result<SweepError, sweeping_api::ProjectionError> {
        let sweeping_api::ProjectionError::Infeasible { rows, .. } = &error else {
            return Err(error);
        };
        let named = self.names_of_rows(rows.iter().copied());
        if named.is_empty() {
            return Err(error);
        }
        Ok(SweepError::EmptySet {
            step: self.k,
            t: t_next,
            more: rows.len() - named.len(),
            constraints: named,
            source: Box::new(error),
        })
    }

    /// A backend that stopped short, said with the constraints the prediction violates most
    /// (where the step is stuck), or the error back when it is another.
    fn stalled(
        &self,
        qp: &ProjectionProblem,
        error: sweeping_api::ProjectionError,
        t_next: f64,
    ) -> Result<SweepError, sweeping_api::ProjectionError> {
        if !matches!(error, sweeping_api::ProjectionError::NotConverged { .. }) {
            return Err(error);
        }
        // Each row's violation at the prediction `u = y`, as a distance.
        let mut ay = vec![0.0; qp.n_rows()];
        qp.a().mul_vec(qp.y(), &mut ay);
        let mut worst: Vec<(f64, usize)> = (0..qp.n_rows())
            .map(|i| {
                let norm = qp.a().row(i).map(|(_, v)| v * v).sum::<f64>().sqrt();
                ((qp.b()[i] - ay[i]) / norm.max(f64::MIN_POSITIVE), i)
            })
            .filter(|(d, _)| *d > 0.0)
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        let constraints = self.names_of_rows(worst.iter().map(|&(_, r)| r));
        if constraints.is_empty() {
            return Err(error);
        }
        Ok(SweepError::ProjectionStalled {
            step: self.k,
            t: t_next,
            rows: qp.n_rows(),
            constraints,
            source: Box::new(error),
        })
    }

    /// A failed solve of a far prediction, retried once on the same QP (already written in
    /// the displacement `u = x − q_k`) scaled by `s = ‖h f‖∞`: `min ½‖v − h f/s‖²` s.t.
    /// `A v ≥ b/s`, then `u = s v`, `λ = s μ`. Done only when `u = 0` satisfies every row
    /// (`gᵢ(t_{k+1}, q_k) ≥ 0`, true for constraints that do not move) to within the
    /// `violation_tolerance` the stepper accepted `q_k` with: the set is then not empty (up to
    /// that), so an "infeasible" answer is the solver's scaling, not the problem's: a step
    /// accurate relative to a huge travel can leave a person slightly inside a wall, and a
    /// solver then calls the next step's set empty. The answer is KKT-checked on the original
    /// QP like any other; when the retry fails too, the error says that the prediction is too
    /// far to be resolved.
    fn rescaled_projection(
        &self,
        projector: &mut dyn Projector,
        qp: &ProjectionProblem,
        first: sweeping_api::ProjectionError,
        t_next: f64,
    ) -> Result<Projection, SweepError> {
        let fail = |source| SweepError::Projection {
            step: self.k,
            t: t_next,
            rows: qp.n_rows(),
            source,
        };
        let far = qp.y().iter().fold(0.0, |m: f64, d| m.max(d.abs()));
        // Only when q_k satisfies every row (as far as the stepper asks) is the set known to
        // be non-empty (with a moving constraint g(t_{k+1}, q_k) may be negative, and a
        // squeezed person makes it empty).
        let b_scale = qp.b().iter().fold(1f64, |m, b| m.max(b.abs()));
        // At u = 0 each row reads 0 ≥ bᵢ = −gᵢ(t_{k+1}, q_k).
        // (−|bⱼ| on an equality row.)
        let violation_at_q = qp
            .b()
            .iter()
            .enumerate()
            .map(|(i, b)| if i < qp.equalities() { b.abs() } else { *b })
            .fold(0.0, sweeping_api::max_or_nan);
        let q_in_set = violation_at_q <= 1e-9 * b_scale + self.settings.violation_tolerance;
        if !(far > 1.0 && far.is_finite() && q_in_set)
            || matches!(first, sweeping_api::ProjectionError::InvalidInput { .. })
        {
            return Err(self
                .empty_set(first, t_next)
                .or_else(|e| self.stalled(qp, e, t_next))
                .unwrap_or_else(fail));
        }
        let b: Vec<f64> = qp.b().iter().map(|b| b / far).collect();
        let y: Vec<f64> = qp.y().iter().map(|d| d / far).collect();
        // The same rows, so the same keys: a warm-starting backend keeps its memory.
        let scaled = ProjectionProblem::new(y, qp.a().clone(), b)
            .and_then(|p| match qp.row_keys() {
                Some(keys) => p.with_row_keys(keys.to_vec()),
                None => Ok(p),
            })
            .and_then(|p| self.with_metric_and_equalities(p))
            .map_err(fail)?;
        match projector.project(&scaled) {
            Ok(mut sol) => {
                sol.x.iter_mut().for_each(|x| *x *= far);
                sol.multipliers.iter_mut().for_each(|l| *l *= far);
                Ok(sol)
            }
            Err(second) => Err(SweepError::PredictionTooFar {
                step: self.k,
                t: t_next,
                distance: far,
                first: first.to_string(),
                second: second.to_string(),
            }),
        }
    }
}
