//! Tests of iterative refinement.

use super::*;
use crate::active_set::test_problems::nearly_dependent;
use crate::active_set::tolerances::{REFINE_TOL, SECOND_PASS_TOL};
use sweeping_api::{ProjectionProblem, SparseRows};

#[test]
fn a_refinement_whose_iterate_is_not_a_number_says_so() {
    // Unknown 0 is touched by no row of the support, so its equation is `v₀ = rhs₀` and
    // its residual `rhs₀ − v₀`: NaN for a NaN `v₀`, while every other residual is 0.
    // `f64::max` passed over it and the refinement read as solved, the NaN kept.
    let a = SparseRows::from_rows(3, &[vec![(1, 1.0), (2, -1.0)], vec![(2, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0; 3], a, vec![0.0, 0.0]).unwrap();
    let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    let mut v = vec![0.0; 5];
    v[0] = f64::NAN;
    assert!(system
        .refine(&[0.0; 5], &mut v, REFINE_TOL, false)
        .is_none());
    // And one entry too many for the four lanes, the remainder's: NaN there too.
    let mut w = vec![0.0; 5];
    w[4] = f64::NAN;
    assert!(system
        .refine(&[0.0; 5], &mut w, REFINE_TOL, false)
        .is_none());
    let mut u = vec![0.0; 5];
    assert!(
        system
            .refine(&[0.0; 5], &mut u, REFINE_TOL, false)
            .unwrap()
            .solved
    );
}

#[test]
fn refinement_goes_on_while_its_steps_contract_tenfold_and_gives_up_when_they_do_not() {
    // x₀ ≥ 1 and x₀ + ε x₁ ≥ 1 + ε, both in the support: nearly dependent rows, whose
    // `A Aᵀ` has a smallest eigenvalue of about ε²/2 against the factor's δ = 1e-9, so
    // each refinement step shrinks the error by about δ/(δ + ε²/2).
    let refined = |e: f64| {
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, e)]]);
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 1.0 + e]).unwrap();
        let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
        let mut v = vec![0.0; 4];
        system
            .refine(&[0.0, 0.0, 1.0, 1.0 + e], &mut v, REFINE_TOL, false)
            .unwrap()
    };
    // ε = 1.5e-4: steps shrink by about 0.08, and refinement runs on until it is solved
    // (nine steps).
    let fast = refined(1.5e-4);
    assert!(fast.solved && fast.second < 1e-12, "{}", fast.second);
    // ε = 3e-5: about 0.2 per step, too slow to be worth it: refinement gives up after its
    // second step, its residual still 7e-6 (run on, it reached 1.3e-13).
    let slow = refined(3e-5);
    assert!(!slow.solved && slow.second > 1e-7, "{}", slow.second);
}

#[test]
fn refinement_gives_up_on_slow_contraction_at_any_scale_of_the_steps() {
    // The slow case above with every right-hand side a thousandth as large: the steps
    // are a thousandth as large too, and shrink by the same factor, so refinement gives
    // up as it did. The rule compares each step with the one before (a ratio); a rule
    // against the reciprocal of the last step would run on here until solved.
    let e = 3e-5;
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, e)]]);
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1e-3, 1e-3 * (1.0 + e)]).unwrap();
    let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    let mut v = vec![0.0; 4];
    let slow = system
        .refine(
            &[0.0, 0.0, 1e-3, 1e-3 * (1.0 + e)],
            &mut v,
            REFINE_TOL,
            false,
        )
        .unwrap();
    assert!(!slow.solved && slow.second > 1e-10, "{}", slow.second);
}

#[test]
fn refinement_tolerance_grows_with_the_right_hand_side() {
    // Well-conditioned equations whose right-hand side is near 1e6: no residual can fall
    // far below the rounding of numbers that size (about 1e-10), and the tolerance,
    // relative to the right-hand side (1e-13 · 1e6 = 1e-7), takes that as solved. One
    // that shrank with the scale would never be met, and refinement would give up with
    // the equations unsolved.
    let rows = [
        vec![
            (0, 0.7310585786300049),
            (1, 0.2689414213699951),
            (2, -0.1192029220221176),
        ],
        vec![
            (1, -0.6224593312018546),
            (3, 0.8807970779778823),
            (4, 0.3775406687981454),
        ],
        vec![(0, 0.0474258731775668), (2, 0.9525741268224334), (5, -0.5)],
        vec![
            (3, 0.1824255238063563),
            (4, -0.8175744761936437),
            (5, 0.9933071490757153),
        ],
    ];
    let rhs = [1.0e6 / 3.0, 2.0e6 / 7.0, -1.0e6 / 11.0, 0.9e6 / 13.0];
    let a = SparseRows::from_rows(6, &rows);
    let p = ProjectionProblem::new(vec![0.0; 6], a, rhs.to_vec()).unwrap();
    let mut system = ActiveSystem::sparse(&p, &[0, 1, 2, 3]).unwrap();
    let mut v = vec![0.0; 10];
    let mut full_rhs = vec![0.0; 6];
    full_rhs.extend_from_slice(&rhs);
    let refined = system.refine(&full_rhs, &mut v, REFINE_TOL, false).unwrap();
    assert!(refined.solved, "{}", refined.second);
    // And the answer satisfies the equations to the rounding of that scale.
    for (row, r) in rows.iter().zip(rhs) {
        let ax: f64 = row.iter().map(|&(c, a)| a * v[c]).sum();
        assert!((ax - r).abs() < 1e-7, "{ax} against {r}");
    }
}

#[test]
fn refinement_is_marked_stalled_only_when_unsolved_with_its_first_block_still_moving() {
    let refine = |p: &ProjectionProblem, rhs: &[f64], tol: f64| {
        let mut v = vec![0.0; rhs.len()];
        ActiveSystem::sparse(p, &[0, 1])
            .unwrap()
            .refine(rhs, &mut v, tol, false)
            .unwrap()
    };
    let (p, rhs) = nearly_dependent();
    // Slow contraction (0.95 a step) at 1e-15: unsolved, stalled.
    let r = refine(&p, &rhs, SECOND_PASS_TOL);
    assert!(!r.solved && r.stalled);
    // With ε = 1e-4 at 1e-7 the same slow steps are detected, and the residual measured
    // after them meets the tolerance: solved, so not stalled.
    let e = 1e-4;
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, e)]]);
    let b = vec![1.0, 1.0 + 0.3 * e];
    let q = ProjectionProblem::new(vec![0.0, 0.0], a, b.clone()).unwrap();
    let r = refine(&q, &[vec![0.0, 0.0], b].concat(), 1e-7);
    assert!(r.solved && !r.stalled);
    // Inconsistent equations: the first block settles, unsolved but not stalled.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
    let rhs = [0.0, 1.0, 1.0 + 1e-10];
    let q = ProjectionProblem::new(vec![0.0], a, rhs[1..].to_vec()).unwrap();
    let r = refine(&q, &rhs, SECOND_PASS_TOL);
    assert!(!r.solved && !r.stalled);
}

#[test]
fn refinement_of_inconsistent_equations_stops_after_its_first_steps_along_the_ray() {
    // x₀ ≥ 1 and x₀ ≤ 0.5 both in the support: their equations have no solution. Each
    // refinement step moves the multipliers along the ray (1, 1) by 0.25/δ = 2.5e8, while
    // x₀ settles at 0.75 within three steps, where refinement stops (the first block no
    // longer moves): multipliers of about 7.5e8. A rule that also waited for the steps to
    // contract (the stop rule's `||` made `&&`) ran to the cap of 50 steps: 1.25e10.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, -1.0)]]);
    let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, -0.5]).unwrap();
    let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    let mut v = vec![0.0; 3];
    let out = system
        .refine(&[0.0, 1.0, -0.5], &mut v, REFINE_TOL, false)
        .unwrap();
    assert!(!out.solved);
    assert!((out.second - 0.25).abs() < 1e-9, "{}", out.second);
    assert!(v[1].abs() < 1e9 && v[2].abs() < 1e9, "{v:?}");
    assert!(v[1].abs() > 1e8, "it did move along the ray: {v:?}");
}

#[test]
fn residual_into_takes_the_largest_magnitude_over_lanes_and_remainder() {
    for len in 0..11 {
        for at in 0..len {
            let rhs: Vec<f64> = (0..len).map(|i| i as f64 * 0.01).collect();
            let mut kv = rhs.clone();
            kv[at] += 3.0;
            let mut step = vec![7.0; len];
            assert_eq!(
                residual_into(&mut step, &rhs, &kv),
                3.0,
                "len {len}, at {at}"
            );
            assert_eq!(step[at], -3.0);
            assert!(step.iter().enumerate().all(|(i, &s)| i == at || s == 0.0));
        }
    }
    assert_eq!(residual_into(&mut [], &[], &[]), 0.0);
    // A NaN anywhere, in the four lanes or in the remainder, makes the result NaN.
    for len in 1..11 {
        for at in 0..len {
            let rhs = vec![1.0; len];
            let mut kv = vec![0.5; len];
            kv[at] = f64::NAN;
            let mut step = vec![0.0; len];
            assert!(
                residual_into(&mut step, &rhs, &kv).is_nan(),
                "len {len}, at {at}"
            );
        }
    }
}
