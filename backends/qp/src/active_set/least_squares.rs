//! Conjugate gradients on the support's equations, after a refinement that stalls: they tell
//! nearly dependent rows (solved) from inconsistent ones (left to the ray).

use super::refine::Refined;
use super::system::{ActiveSystem, Scratch};
use sweeping_api::max_or_nan;

/// Most conjugate-gradient steps after a stalled refinement: on the nearly dependent supports
/// where they succeed they take two or three.
const LEAST_SQUARES_STEPS: usize = 3;

impl ActiveSystem {
    /// `out = A_Pᵀ μ`, by unknown of the problem.
    fn transposed_times(&self, mu: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.n, 0.0);
        for (row, m) in self.rows.iter().zip(mu) {
            for &(c, a) in row {
                out[c] += a * m;
            }
        }
    }

    /// `out = g − A_P (f + A_Pᵀ μ)`, by row of the support, with `d = f + A_Pᵀ μ` left in
    /// `d`: the second block of the residual of `K₀ [d; −μ] = [f; g]`, whose first block is
    /// then zero.
    fn support_residual(
        &self,
        f: &[f64],
        g: &[f64],
        mu: &[f64],
        d: &mut Vec<f64>,
        out: &mut Vec<f64>,
    ) {
        self.transposed_times(mu, d);
        d.iter_mut().zip(f).for_each(|(di, fi)| *di += fi);
        out.clear();
        out.extend(
            self.rows
                .iter()
                .zip(g)
                .map(|(row, gi)| gi - row.iter().map(|&(c, a)| a * d[c]).sum::<f64>()),
        );
    }

    /// The support's equations `A_P d = g` with `d = f + A_Pᵀμ` (the system `K₀ [d; −μ] =
    /// [f; g]`), solved in the least-squares sense by conjugate gradients from the `μ` of
    /// `v = [d; −μ]`: on `G Δ = ρ` (`G = A_P A_Pᵀ`, `ρ` the residual at `μ`, `μ ← μ + Δ`),
    /// preconditioned by `(G + δI)⁻¹ G (G + δI)⁻¹`, two solves with the factor. On a singular
    /// vector of `A_P` the preconditioned `G` is `σ⁴/(σ² + δ)²`: near 1 where refinement was
    /// fast, still well away from zero where it stalled (`σ² ≈ δ`), and zero on dependent rows,
    /// which the preconditioner does not amplify (the plain `(G + δI)⁻¹` would, by `1/δ`, and
    /// the method then diverges on inconsistent equations). So the steps stay in the range of
    /// `G`: `μ` moves to the multipliers nearest it that solve the equations, as refinement's,
    /// and on inconsistent equations the residual tends to its part orthogonal to the rows.
    /// At most [`LEAST_SQUARES_STEPS`] steps; `None` when the numbers stop being finite.
    pub(super) fn least_squares(
        &mut self,
        rhs: &[f64],
        v: &mut [f64],
        tol: f64,
    ) -> Option<Refined> {
        let n = self.n;
        let scale = rhs.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
        let tol = tol * scale;
        let (f, g) = rhs.split_at(n);
        let mut mu: Vec<f64> = v[n..].iter().map(|w| -w).collect();
        let mut scratch = std::mem::take(&mut self.scratch);
        let Scratch {
            by_unknown: d,
            residual: rho,
            preconditioned: z,
            direction: p,
            product_g: q,
            step: solved,
            ..
        } = &mut scratch;
        self.support_residual(f, g, &mu, d, rho);
        p.clear();
        p.resize(mu.len(), 0.0);
        let mut rz_before = 0.0;
        let mut finite = true;
        for step in 0..LEAST_SQUARES_STEPS {
            let r = rho.iter().fold(0.0, |acc: f64, v| max_or_nan(acc, v.abs()));
            if r.is_nan() {
                finite = false;
                break;
            }
            if r <= tol {
                break;
            }
            // z = (G + δI)⁻¹ G (G + δI)⁻¹ ρ: K_δ [u; ·] = [0; ρ] has u = A_Pᵀ(G + δI)⁻¹ρ, and
            // K_δ [·; w] = [u; 0] has w = (G + δI)⁻¹ A_P u.
            solved.clear();
            solved.resize(n, 0.0);
            solved.extend_from_slice(rho);
            self.solve_in_place(solved);
            solved[n..].iter_mut().for_each(|x| *x = 0.0);
            self.solve_in_place(solved);
            z.clear();
            z.extend_from_slice(&solved[n..]);
            let rz: f64 = rho.iter().zip(z.iter()).map(|(a, b)| a * b).sum();
            if rz.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                // ρ is orthogonal to the rows: least squares reached (or rounding, or NaN).
                break;
            }
            let beta = if step == 0 { 0.0 } else { rz / rz_before };
            p.iter_mut()
                .zip(z.iter())
                .for_each(|(pi, zi)| *pi = zi + beta * *pi);
            rz_before = rz;
            // q = G p = A_P (A_Pᵀ p).
            self.transposed_times(p, d);
            q.clear();
            q.extend(
                self.rows
                    .iter()
                    .map(|row| row.iter().map(|&(c, a)| a * d[c]).sum::<f64>()),
            );
            let pq: f64 = p.iter().zip(q.iter()).map(|(a, b)| a * b).sum();
            if pq.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                break;
            }
            let alpha = rz / pq;
            mu.iter_mut()
                .zip(p.iter())
                .for_each(|(m, pi)| *m += alpha * pi);
            rho.iter_mut()
                .zip(q.iter())
                .for_each(|(r, qi)| *r -= alpha * qi);
        }
        // The residual measured afresh, not as the recurrence left it.
        self.support_residual(f, g, &mu, d, rho);
        let second = rho.iter().fold(0.0, |acc: f64, v| max_or_nan(acc, v.abs()));
        finite &= !second.is_nan() && d.iter().all(|x| x.is_finite());
        let refined = finite.then(|| {
            v[..n].copy_from_slice(d);
            v[n..].iter_mut().zip(&mu).for_each(|(w, m)| *w = -m);
            Refined {
                second,
                solved: second <= tol,
                stalled: false,
                residual: rho.clone(),
            }
        });
        self.scratch = scratch;
        refined
    }
}

#[cfg(test)]
mod tests;
