//! Farkas certificates: rows whose weighted sum proves `A x ≥ b` empty, checked before the
//! method says so.

use sweeping_api::ProjectionProblem;

/// Checks the Farkas certificate `e ≥ 0`, `A_Pᵀe = 0`, `eᵀr_P > 0` of an empty polyhedron,
/// with room for rounding relative to the size of the numbers involved.
pub(super) fn farkas(problem: &ProjectionProblem, support: &[usize], e: &[f64], r: &[f64]) -> bool {
    let emax = e.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
    if emax == 0.0 || !emax.is_finite() || e.iter().any(|&v| v < -1e-12 * emax) {
        return false;
    }
    let mut ate = vec![0.0; problem.dim()];
    let mut amax: f64 = 0.0;
    for (&i, &ei) in support.iter().zip(e) {
        for (c, v) in problem.a().row(i) {
            ate[c] += v * ei.max(0.0);
            amax = amax.max(v.abs());
        }
    }
    let ate_max = ate.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
    let er: f64 = support
        .iter()
        .zip(e)
        .map(|(&i, &ei)| ei.max(0.0) * r[i])
        .sum();
    let rmax = support.iter().fold(0.0, |acc: f64, &i| acc.max(r[i].abs()));
    // Aᵀe vanishes to rounding while eᵀr is clearly positive: no x can satisfy eᵀA x ≥ eᵀb.
    ate_max <= 1e-9 * emax * amax.max(1.0) * (support.len() as f64).sqrt()
        && er > 1e-6 * emax * rmax
}
#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::SparseRows;

    /// `x₀ + x₁ ≥ 1`, `−x₀ ≥ 0`, `−x₁ ≥ 0` (empty) and `x₀ ≥ 0.5` (feasible on its own).
    fn problem() -> (ProjectionProblem, Vec<f64>) {
        let a = SparseRows::from_rows(
            2,
            &[
                vec![(0, 1.0), (1, 1.0)],
                vec![(0, -1.0)],
                vec![(1, -1.0)],
                vec![(0, 1.0)],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 0.0, 0.0, 0.5]).unwrap();
        // r = b − A y with y = 0.
        let r = p.b().to_vec();
        (p, r)
    }

    #[test]
    fn farkas_accepts_a_certificate() {
        let (p, r) = problem();
        assert!(farkas(&p, &[0, 1, 2], &[1.0, 1.0, 1.0], &r));
        // Scaled, and with rounding-size negative entries.
        assert!(farkas(&p, &[0, 1, 2], &[3.0, 3.0, 3.0 - 1e-15], &r));
    }

    #[test]
    fn farkas_rejects_what_is_not_a_certificate() {
        let (p, r) = problem();
        // Aᵀe ≠ 0.
        assert!(!farkas(&p, &[0, 1, 2], &[1.0, 1.0, 0.5], &r));
        // A clearly negative weight.
        assert!(!farkas(&p, &[0, 1, 2], &[1.0, -1.0, 1.0], &r));
        // Zero, non-finite.
        assert!(!farkas(&p, &[0, 1, 2], &[0.0, 0.0, 0.0], &r));
        assert!(!farkas(&p, &[0, 1, 2], &[f64::NAN, 1.0, 1.0], &r));
        assert!(!farkas(&p, &[0, 1, 2], &[f64::INFINITY, 1.0, 1.0], &r));
        // Aᵀe = 0 but eᵀr < 0: rows −x₀ ≥ 0 and x₀ ≥ −1 (r = b − A·0 = (0, −1)) can both
        // hold.
        let r2 = vec![1.0, 0.0, 0.0, -1.0];
        assert!(!farkas(&p, &[1, 3], &[1.0, 1.0], &r2));
    }
}
