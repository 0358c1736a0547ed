//! Tests of conjugate gradients after a stalled refinement.

use super::*;
use crate::active_set::test_problems::{nearly_dependent, start_from};
use crate::active_set::tolerances::SECOND_PASS_TOL;
use crate::active_set::{solve, Options};
use sweeping_api::{ProjectionProblem, SparseRows};

#[test]
fn least_squares_solves_nearly_dependent_rows_that_refinement_leaves_unsolved() {
    let (p, rhs) = nearly_dependent();
    for sparse in [false, true] {
        let system = || {
            if sparse {
                ActiveSystem::sparse(&p, &[0, 1]).unwrap()
            } else {
                ActiveSystem::new(&p, &[0, 1], None).unwrap()
            }
        };
        let mut v = vec![0.0; 4];
        let plain = system()
            .refine(&rhs, &mut v, SECOND_PASS_TOL, false)
            .unwrap();
        assert!(!plain.solved, "refinement alone stalls (sparse: {sparse})");
        let mut v = vec![0.0; 4];
        let out = system()
            .refine(&rhs, &mut v, SECOND_PASS_TOL, true)
            .unwrap();
        assert!(
            out.solved && out.second <= SECOND_PASS_TOL,
            "{}",
            out.second
        );
        assert!(
            (v[0] - 1.0).abs() <= 1e-15 && (v[1] - 0.3).abs() <= 1e-9,
            "{v:?}"
        );
        // d = A_Pᵀμ: μ₁ = 0.3/ε = 3e4, μ₀ = 1 − μ₁ (v holds −μ).
        assert!(
            (v[3] + 3e4).abs() <= 1e-5 && (v[2] + 1.0 - 3e4).abs() <= 1e-5,
            "{v:?}"
        );
    }
}

#[test]
fn least_squares_leaves_inconsistent_equations_to_the_ray() {
    // x₀ ≥ 1 and x₀ ≥ 1 + 1e-10, both in the support: the same row twice with different
    // right-hand sides. No step solves them; refinement's answer (its residual along the
    // ray (1, −1)) is kept as it was.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
    let rhs = [0.0, 1.0, 1.0 + 1e-10];
    let p = ProjectionProblem::new(vec![0.0], a, rhs[1..].to_vec()).unwrap();
    let mut plain_v = vec![0.0; 3];
    let plain = ActiveSystem::sparse(&p, &[0, 1])
        .unwrap()
        .refine(&rhs, &mut plain_v, SECOND_PASS_TOL, false)
        .unwrap();
    let mut v = vec![0.0; 3];
    let out = ActiveSystem::sparse(&p, &[0, 1])
        .unwrap()
        .refine(&rhs, &mut v, SECOND_PASS_TOL, true)
        .unwrap();
    assert!(!out.solved);
    assert_eq!(
        (out.second, &out.residual, &v),
        (plain.second, &plain.residual, &plain_v)
    );
    assert!(
        out.residual[0] < 0.0 && out.residual[1] > 0.0,
        "{:?}",
        out.residual
    );
    // Conjugate gradients alone end at the least-squares point, x₀ = 1 + 5e-11, their
    // residual ±5e-11 orthogonal to the row.
    let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    let mut w = vec![0.0; 3];
    let ls = system.least_squares(&rhs, &mut w, SECOND_PASS_TOL).unwrap();
    assert!(!ls.solved);
    assert!((w[0] - (1.0 + 5e-11)).abs() <= 1e-15, "{w:?}");
    assert!((ls.residual[0] + 5e-11).abs() <= 1e-15 && (ls.residual[1] - 5e-11).abs() <= 1e-15);
}

#[test]
fn least_squares_tests_relative_to_the_right_hand_side() {
    // `x₀ + 0.37 x₁ ≥ 0.7k` and `0.41 x₀ + x₁ ≥ 0.11k` (k = 1234.567) in the support, from
    // μ = 0: its residual ends at 2.3e-13, rounding of numbers of size k, within 1e-15
    // relative to ‖rhs‖∞ = k, not within 1e-15 divided by it.
    let k = 1234.567;
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 0.37)], vec![(0, 0.41), (1, 1.0)]]);
    let b = vec![0.7 * k, 0.11 * k];
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, b.clone()).unwrap();
    let rhs = [vec![0.0, 0.0], b].concat();
    let mut v = vec![0.0; 4];
    let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    let out = system.least_squares(&rhs, &mut v, SECOND_PASS_TOL).unwrap();
    assert!(out.solved && out.second > 0.0, "{}", out.second);
    // d = A_Pᵀμ solves A_P d = b: check it by the equations themselves.
    let (r0, r1) = (v[0] + 0.37 * v[1] - 0.7 * k, 0.41 * v[0] + v[1] - 0.11 * k);
    assert!(r0.abs() <= 1e-12 && r1.abs() <= 1e-12, "{r0:e} {r1:e}");
}

#[test]
fn least_squares_takes_conjugate_steps() {
    // Three rows `x₀ ≥ 1`, `x₀ + ε₁x₁ ≥ 1 + 0.3ε₁`, `x₀ + ε₂x₂ ≥ 1 + 0.7ε₂` (ε₁ = 1e-5,
    // ε₂ = 3e-5), all in the support: the preconditioned G has three distinct eigenvalues,
    // so conjugate gradients need all three of their steps, each direction conjugate to the
    // last (β = ρᵀz / ρ₋ᵀz₋, added); solution d = (1, 0.3, 0.7). Not to 1e-15 (below).
    let (e1, e2) = (1e-5, 3e-5);
    let a = SparseRows::from_rows(
        3,
        &[
            vec![(0, 1.0)],
            vec![(0, 1.0), (1, e1)],
            vec![(0, 1.0), (2, e2)],
        ],
    );
    let b = vec![1.0, 1.0 + 0.3 * e1, 1.0 + 0.7 * e2];
    let p = ProjectionProblem::new(vec![0.0; 3], a, b.clone()).unwrap();
    let rhs = [vec![0.0; 3], b].concat();
    let mut v = vec![0.0; 6];
    let mut system = ActiveSystem::sparse(&p, &[0, 1, 2]).unwrap();
    let plain = system.refine(&rhs, &mut v, SECOND_PASS_TOL, false).unwrap();
    assert!(!plain.solved && plain.stalled);
    // Within `refine`, an answer of conjugate gradients that does not solve the equations
    // to the tolerance (this one, below) is not taken: refinement's stands, its residual
    // the ray the method would follow.
    let mut w = vec![0.0; 6];
    let with = ActiveSystem::sparse(&p, &[0, 1, 2])
        .unwrap()
        .refine(&rhs, &mut w, SECOND_PASS_TOL, true)
        .unwrap();
    assert_eq!(
        (with.second, &with.residual, &w),
        (plain.second, &plain.residual, &v)
    );
    let out = system.least_squares(&rhs, &mut v, SECOND_PASS_TOL).unwrap();
    // Multipliers of 5e4 leave rounding of about 4e-12 in the residual (refinement left
    // 5e-6; with β multiplied instead of divided, or subtracted, three steps leave 1e-6).
    assert!(
        out.second <= 1e-11,
        "{} (refinement: {})",
        out.second,
        plain.second
    );
    assert!(
        (v[0] - 1.0).abs() <= 1e-10 && (v[1] - 0.3).abs() <= 1e-10 && (v[2] - 0.7).abs() <= 1e-10,
        "{v:?}"
    );
}

#[test]
fn least_squares_from_multipliers_that_overflow_is_none() {
    // μ = 1e308 on both rows: d = A_Pᵀμ overflows, its residual is infinite, not NaN.
    let (p, rhs) = nearly_dependent();
    let mut v = vec![0.0, 0.0, -1e308, -1e308];
    let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    assert!(system
        .least_squares(&rhs, &mut v, SECOND_PASS_TOL)
        .is_none());
}

#[test]
fn on_nearly_dependent_rows_the_method_ends_at_the_projection_to_rounding() {
    // The rows of `nearly_dependent` as `x₀ ≥ 1` and `x₀ + ε x₁ ≥ 1 + 0.3 ε` from y = 0:
    // the projection is d = (1, 0.3) if both multipliers were positive; they are not (μ₀
    // = 1 − 3e4), so the projection keeps the second row alone:
    // x = (1 + 0.3ε)/(1 + ε²) · (1, ε). Either way the method must finish at it.
    let (p, _) = nearly_dependent();
    let e: f64 = 1e-5;
    let t = (1.0 + 0.3 * e) / (1.0 + e * e);
    let outcome = solve(&p, start_from(vec![0, 1], 2), Options::capped(20)).unwrap();
    assert!((outcome.x[0] - t).abs() <= 1e-15 && (outcome.x[1] - t * e).abs() <= 1e-15);
    assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() <= 1e-15);
}
