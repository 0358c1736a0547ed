//! Iterative refinement: the unregularized system `K₀` solved through the factor of `K_δ`,
//! and where it stops (solved, inconsistent, or stalled on nearly dependent rows).

use super::system::ActiveSystem;
use sweeping_api::max_or_nan;

/// Most refinement steps per factorization.
const REFINE_STEPS: usize = 50;
/// Refinement also stops when a step moves the first block by more than this fraction of the
/// step before: on consistent equations it contracts by far more (the regularization `δ` is
/// tiny against the rows' scale), so slower progress means inconsistent or nearly dependent
/// rows. Running such refinements to [`REFINE_STEPS`] multiplies the solves without changing
/// the number of active-set iterations.
const REFINE_CONTRACTION: f64 = 0.1;

/// Where iterative refinement stopped.
pub(super) struct Refined {
    /// `‖residual‖∞` of the second block.
    pub(super) second: f64,
    /// Whether the whole residual met the tolerance.
    pub(super) solved: bool,
    /// Whether refinement, unsolved, stopped while its first block still moved, slowly (its
    /// steps contracting by less than [`REFINE_CONTRACTION`], or at [`REFINE_STEPS`]): the
    /// mark of nearly dependent rows, where [`ActiveSystem::least_squares`] may solve what
    /// refinement did not. Unsolved with the first block settled, the equations are
    /// inconsistent and it could not.
    pub(super) stalled: bool,
    /// The second block of the residual, `r_P − A_P d` for the right-hand side `[0; r_P]`.
    pub(super) residual: Vec<f64>,
}

impl ActiveSystem {
    /// `out = K₀ v`.
    fn apply(&self, v: &[f64], out: &mut [f64]) {
        let n = self.n;
        out[..n].copy_from_slice(&v[..n]);
        for (t, row) in self.rows.iter().enumerate() {
            let mu = v[n + t];
            let mut ad = 0.0;
            for &(c, a) in row {
                out[c] += a * mu;
                ad += a * v[c];
            }
            out[n + t] = ad;
        }
    }

    /// Iterative refinement of `K₀ v = rhs` from `v`, until the residual is below `tol`
    /// (relative to `max(1, ‖rhs‖∞)`), the first block of `v` stops moving by more than that,
    /// or [`REFINE_STEPS`] steps; with `least_squares`, a refinement that ends unsolved is
    /// followed by [`Self::least_squares`], whose answer replaces it when it solves the
    /// equations. `None` when the numbers stop being finite.
    pub(super) fn refine(
        &mut self,
        rhs: &[f64],
        v: &mut [f64],
        tol: f64,
        least_squares: bool,
    ) -> Option<Refined> {
        let mut kv = std::mem::take(&mut self.scratch.product);
        let mut step = std::mem::take(&mut self.scratch.step);
        kv.resize(rhs.len(), 0.0);
        step.resize(rhs.len(), 0.0);
        let refined = self.refine_with(rhs, v, &mut kv[..rhs.len()], &mut step[..rhs.len()], tol);
        (self.scratch.product, self.scratch.step) = (kv, step);
        match refined {
            Some(refined) if least_squares && refined.stalled => {
                // Tried on a copy: the refinement's answer stands when this one does not
                // solve the equations either (on inconsistent ones its residual is the ray
                // the method follows, as it always was).
                let mut w = v.to_vec();
                match self.least_squares(rhs, &mut w, tol) {
                    Some(better) if better.solved => {
                        v.copy_from_slice(&w);
                        Some(better)
                    }
                    _ => Some(refined),
                }
            }
            other => other,
        }
    }

    /// [`Self::refine`] with the work vectors `kv` and `step` (as long as `rhs`).
    fn refine_with(
        &mut self,
        rhs: &[f64],
        v: &mut [f64],
        kv: &mut [f64],
        step: &mut [f64],
        tol: f64,
    ) -> Option<Refined> {
        let n = self.n;
        let scale = rhs.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
        if !scale.is_finite() {
            return None;
        }
        let tol = tol * scale;
        let mut steps = 0;
        let mut last_moved = f64::INFINITY;
        let mut stalled = false;
        loop {
            self.apply(v, kv);
            let first = residual_into(&mut step[..n], &rhs[..n], &kv[..n]);
            let second = residual_into(&mut step[n..], &rhs[n..], &kv[n..]);
            if first.is_nan() || second.is_nan() {
                return None;
            }
            let solved = first.max(second) <= tol;
            if solved || steps == REFINE_STEPS {
                return Some(Refined {
                    second,
                    solved,
                    stalled: !solved && stalled,
                    residual: step[n..].to_vec(),
                });
            }
            self.solve_in_place(step);
            let moved = step[..n]
                .iter()
                .fold(0.0, |acc: f64, s| max_or_nan(acc, s.abs()));
            v.iter_mut().zip(step.iter()).for_each(|(vi, si)| *vi += si);
            steps += 1;
            // Slow progress of a first block still moving: a nearly dependent direction (or
            // the cap).
            stalled = moved > tol
                && (steps == REFINE_STEPS
                    || (steps >= 2 && moved > REFINE_CONTRACTION * last_moved));
            if moved <= tol || (steps >= 2 && moved > REFINE_CONTRACTION * last_moved) {
                // The first block has converged, or converges too slowly to be worth it: the
                // equations are inconsistent (or nearly so, rows nearly dependent), the
                // residual will be the ray along which the method drops a row, and the answer
                // of the method is checked anyway. One more pass measures the residual.
                steps = REFINE_STEPS;
            }
            last_moved = moved;
        }
    }
}

/// `step = rhs − kv`, returning `‖step‖∞`, NaN when an entry is (`f64::max` would pass over
/// it, and a refinement whose iterate had gone NaN read as solved).
///
/// Four running maxima, not one: with one, each `max` waits on the one before, and this loop
/// runs over every unknown of the block at every refinement step. The maximum is the same in
/// any order.
fn residual_into(step: &mut [f64], rhs: &[f64], kv: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let mut nan = false;
    let mut steps = step.chunks_exact_mut(4);
    let (mut rhs4, mut kv4) = (rhs.chunks_exact(4), kv.chunks_exact(4));
    for ((st, r), k) in (&mut steps).zip(&mut rhs4).zip(&mut kv4) {
        for j in 0..4 {
            st[j] = r[j] - k[j];
            nan |= st[j].is_nan();
            lanes[j] = lanes[j].max(st[j].abs());
        }
    }
    let rest = steps.into_remainder();
    for ((st, r), k) in rest.iter_mut().zip(rhs4.remainder()).zip(kv4.remainder()) {
        *st = r - k;
        nan |= st.is_nan();
        lanes[0] = lanes[0].max(st.abs());
    }
    if nan {
        f64::NAN
    } else {
        lanes[0].max(lanes[1]).max(lanes[2].max(lanes[3]))
    }
}

#[cfg(test)]
mod tests;
