//! Tests of the finishing passes.

use super::*;
use crate::active_set::pass::run;
use crate::active_set::test_problems::start_from;
use crate::active_set::tolerances::{FIRST_PASS, SECOND_PASS_TOL};
use crate::active_set::{solve, Options};
use sweeping_api::SparseRows;

/// `outcome` as [`run`] would hand it on, measured from its point: with no factorization,
/// and needing a second pass when it leaves a row violated, or a row of its support not
/// tight, by more than [`SECOND_PASS_TOL`].
fn finished(p: &ProjectionProblem, outcome: Outcome) -> Finished {
    let r = p.shortfall(&outcome.x);
    let scale = p
        .shortfall(p.y())
        .iter()
        .fold(1.0, |acc: f64, v| acc.max(v.abs()));
    let off = r
        .iter()
        .zip(&outcome.lambda)
        .map(|(gap, l)| if *l > 0.0 { gap.abs() } else { *gap })
        .fold(0.0, f64::max);
    Finished {
        outcome,
        held: None,
        needs_second_pass: off > SECOND_PASS_TOL * scale,
        off,
    }
}

#[test]
fn a_row_violated_below_the_tolerance_joins_in_the_second_pass() {
    // x₀ ≥ 1, and x₁ ≥ 5e-13, which y = 0 violates by less than ACTIVE_TOL.
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 5e-13]).unwrap();
    let first = run(&p, start_from(vec![0], 2), 10, FIRST_PASS, None, None)
        .unwrap()
        .outcome;
    assert_eq!((first.x[1], first.lambda[1]), (0.0, 0.0));
    let outcome = solve(&p, start_from(vec![0], 2), Options::capped(10)).unwrap();
    assert!((outcome.x[0] - 1.0).abs() <= 1e-16 && (outcome.x[1] - 5e-13).abs() <= 1e-20);
    assert!(outcome.lambda[1] > 0.0);
    assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() < 1e-16);
}

#[test]
fn a_support_solved_only_to_the_tolerance_is_solved_exactly_in_the_second_pass() {
    // x₀ ≥ 1 and x₀ ≥ 1 + 5e-13: together their equations are inconsistent by less
    // than ACTIVE_TOL, so the first pass keeps both, between the two bounds; the second
    // drops the first row and lands on the second bound.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, 1.0 + 5e-13]).unwrap();
    let first = run(&p, start_from(vec![0, 1], 2), 10, FIRST_PASS, None, None)
        .unwrap()
        .outcome;
    assert!(first.x[0] < 1.0 + 4e-13 && first.lambda.iter().all(|l| *l > 0.0));
    let outcome = solve(&p, start_from(vec![0, 1], 2), Options::capped(10)).unwrap();
    assert!((outcome.x[0] - (1.0 + 5e-13)).abs() <= 1e-16);
    assert_eq!(outcome.lambda[0], 0.0);
    assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() < 1e-16);
}

#[test]
fn an_answer_exact_to_rounding_gets_no_second_pass() {
    // y = (0.5, 7): x₀ ≥ 1 is active, x₁ ≥ 2 holds with a slack of 5. One iteration
    // solves it exactly, and no second pass adds one.
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.5, 7.0], a, vec![1.0, 2.0]).unwrap();
    let outcome = solve(&p, start_from(vec![0], 2), Options::capped(10)).unwrap();
    assert_eq!(outcome.iterations, 1);
    assert_eq!(outcome.x, vec![1.0, 7.0]);
    assert_eq!(outcome.lambda, vec![0.5, 0.0]);
    assert_eq!(outcome.unfinished, None);
}

/// x₀ ≥ 1 active, x₁ ≥ −1 inactive (y = 0), and a first answer past the first row by
/// 5e-13, after three iterations.
fn overshot() -> (ProjectionProblem, Outcome) {
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, -1.0]).unwrap();
    let first = Outcome {
        x: vec![1.0 + 5e-13, 0.0],
        lambda: vec![1.0 + 5e-13, 0.0],
        iterations: 3,
        unfinished: None,
    };
    (p, first)
}

#[test]
fn an_answer_the_second_pass_cannot_finish_stands_and_says_by_how_much_it_is_off() {
    // As below, but the pass gets no iteration: the first answer stands, off by 5e-13
    // (the row's gap), and says so.
    let (p, first) = overshot();
    let kept = second_pass(&p, finished(&p, first.clone()), 0, None);
    assert_eq!((&kept.x, kept.iterations), (&first.x, 3));
    let off = kept.unfinished.expect("the answer says it is unfinished");
    assert!((off - 5e-13).abs() < 1e-16, "{off:e}");
    // Given the iteration, the pass finishes it.
    let done = second_pass(&p, finished(&p, first), 10, None);
    assert_eq!(done.unfinished, None);
}

#[test]
fn a_support_row_overshot_beyond_the_second_tolerance_is_finished_and_counted() {
    let (p, first) = overshot();
    let second = second_pass(&p, finished(&p, first), 10, None);
    assert_eq!(second.x, vec![1.0, 0.0]);
    assert_eq!(second.lambda, vec![1.0, 0.0]);
    // One iteration from the support {x₀ ≥ 1} alone, added to the first pass's three.
    assert_eq!(second.iterations, 4);
}

#[test]
fn both_tolerances_are_relative_to_the_size_of_r() {
    // y = 0, x₀ ≥ 1000 and x₁ ≥ 5e-13: r reaches 1000, so the first pass takes the second
    // row as satisfied (5e-13 < 1e-12 · 1000) and so does the second pass (< 1e-15 · 1000).
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1000.0, 5e-13]).unwrap();
    let first = run(&p, start_from(vec![0], 2), 10, FIRST_PASS, None, None)
        .unwrap()
        .outcome;
    assert_eq!((first.x[1], first.iterations), (0.0, 1));
    let outcome = solve(&p, start_from(vec![0], 2), Options::capped(10)).unwrap();
    assert_eq!((outcome.x[1], outcome.iterations), (0.0, 1));
    // An answer 4.5e-13 short of the first row is within the second pass's 1e-12.
    let short = Outcome {
        x: vec![1000.0 - 4.5e-13, 0.0],
        lambda: vec![1000.0, 0.0],
        iterations: 2,
        unfinished: None,
    };
    let kept = second_pass(&p, finished(&p, short.clone()), 10, None);
    assert_eq!((kept.x, kept.iterations), (short.x, 2));
}

#[test]
fn the_second_pass_has_the_first_passs_cap() {
    // x₀ ≥ 1, and 20 rows xⱼ ≥ 5e-13 that y = 0 violates by less than ACTIVE_TOL: the
    // second pass takes them in one at a time, 20 iterations, more than a fixed 16.
    let rows: Vec<Vec<(usize, f64)>> = (0..21).map(|j| vec![(j, 1.0)]).collect();
    let a = SparseRows::from_rows(21, &rows);
    let mut b = vec![5e-13; 21];
    b[0] = 1.0;
    let p = ProjectionProblem::new(vec![0.0; 21], a, b).unwrap();
    let outcome = solve(&p, start_from(vec![0], 21), Options::capped(30)).unwrap();
    assert!(outcome.x[1..].iter().all(|x| (x - 5e-13).abs() <= 1e-20));
    assert_eq!(outcome.iterations, 1 + 21);
    // Under a cap of 10 the pass runs out, at 1e-15, 1e-14 and 1e-13 (each row still
    // joins, 5e-13 exceeding all three), and the first answer stands, unfinished; the
    // count is every iteration spent.
    let capped = solve(&p, start_from(vec![0], 21), Options::capped(10)).unwrap();
    assert!(capped.x[1..].iter().all(|x| *x == 0.0));
    assert_eq!(capped.iterations, 1 + 10 + 10 + 10);
    assert_eq!(capped.unfinished, Some(5e-13));
}

#[test]
fn a_pass_that_runs_out_keeps_its_best_iterate_when_it_is_off_by_less() {
    // x₀ ≥ 1, and 20 rows xⱼ ≥ 4e-14·j that y = 0 violates by 4e-14 to 8e-13: the first
    // pass accepts y as it is (all within ACTIVE_TOL), off by 8e-13. Under a cap of 10 the
    // passes at 1e-15, 1e-14 and 1e-13 run out, each joining the most violated row at a
    // time, and
    // the iterates they pass through are off by less and less: the answer is the best of
    // them, not the first.
    let rows: Vec<Vec<(usize, f64)>> = (0..21).map(|j| vec![(j, 1.0)]).collect();
    let a = SparseRows::from_rows(21, &rows);
    let mut b: Vec<f64> = (0..21).map(|j| 4e-14 * j as f64).collect();
    b[0] = 1.0;
    let p = ProjectionProblem::new(vec![0.0; 21], a, b.clone()).unwrap();
    let outcome = solve(&p, start_from(vec![0], 21), Options::capped(10)).unwrap();
    let joined: Vec<usize> = (1..21).filter(|&j| outcome.x[j] != 0.0).collect();
    // The rows joined are the most violated ones, each made tight.
    assert!(!joined.is_empty());
    assert_eq!(joined, (21 - joined.len()..21).collect::<Vec<_>>());
    assert!(joined.iter().all(|&j| (outcome.x[j] - b[j]).abs() <= 1e-20));
    // Ten iterations: the start's own solve, then nine rows joined, one at a time.
    assert_eq!(joined.len(), 9);
    // Off by the most violated row left out, 4.4e-13, where the first answer was 8e-13.
    assert_eq!(outcome.unfinished, Some(b[11]));
    assert_eq!(outcome.iterations, 1 + 10 + 10 + 10);
}

#[test]
fn a_second_pass_that_runs_out_at_1e_15_is_finished_at_1e_14_and_says_so() {
    // x₀ ≥ 1, and 20 rows xⱼ ≥ 5e-15 that y = 0 violates by more than the second pass's
    // 1e-15 but less than 1e-14, and a cap of 10: at 1e-15 the pass takes them in one at
    // a time and runs out; at 1e-14 it finds the first answer finished as it is; down
    // again at 1e-15 from that answer, the same 20 rows, and it runs out again.
    let rows: Vec<Vec<(usize, f64)>> = (0..21).map(|j| vec![(j, 1.0)]).collect();
    let a = SparseRows::from_rows(21, &rows);
    let mut b = vec![5e-15; 21];
    b[0] = 1.0;
    let p = ProjectionProblem::new(vec![0.0; 21], a, b).unwrap();
    let outcome = solve(&p, start_from(vec![0], 21), Options::capped(10)).unwrap();
    assert_eq!(outcome.x[0], 1.0);
    assert!(outcome.x[1..].iter().all(|x| *x == 0.0));
    assert_eq!(outcome.unfinished, Some(5e-15));
    // The first pass's iteration, the 10 at 1e-15, the 1 at 1e-14 and the 10 at 1e-15.
    assert_eq!(outcome.iterations, 1 + 10 + 1 + 10);
    // With room for the 20 rows the pass at 1e-15 finishes, and nothing is unfinished.
    let finished = solve(&p, start_from(vec![0], 21), Options::capped(30)).unwrap();
    assert!(finished.x[1..].iter().all(|x| (x - 5e-15).abs() <= 1e-22));
    assert_eq!(finished.unfinished, None);
}

#[test]
fn a_pass_that_converges_higher_up_the_ladder_is_finished_again_from_its_answer() {
    // x₀ ≥ 1, 8 rows xⱼ ≥ 5e-14 and 8 rows xⱼ ≥ 5e-15, y = 0 and a cap of 10: the first
    // pass accepts y as it is. At 1e-15 the pass would take the 16 rows in one at a
    // time, and runs out; at 1e-14 it takes the 8 larger ones and converges, off by 5e-15;
    // down again at 1e-15 from that answer only the 8 smaller ones remain, and it
    // finishes: nothing is left unfinished, where the answer at 1e-14 alone was.
    let rows: Vec<Vec<(usize, f64)>> = (0..17).map(|j| vec![(j, 1.0)]).collect();
    let a = SparseRows::from_rows(17, &rows);
    let mut b = vec![1.0; 17];
    b[1..9].fill(5e-14);
    b[9..].fill(5e-15);
    let p = ProjectionProblem::new(vec![0.0; 17], a, b.clone()).unwrap();
    let outcome = solve(&p, start_from(vec![0], 17), Options::capped(10)).unwrap();
    assert_eq!(outcome.unfinished, None);
    assert!(outcome
        .x
        .iter()
        .zip(&b)
        .all(|(x, b)| (x - b).abs() <= 1e-22));
    // The first pass's iteration, the 10 at 1e-15, the start's solve and 8 joins at
    // 1e-14, the same at 1e-15.
    assert_eq!(outcome.iterations, 1 + 10 + 9 + 9);
    // Three rungs up and two down: 4 rows each at 5e-13, 5e-14 and 5e-15, a cap of 6.
    // At 1e-15 (12 rows to take in) and 1e-14 (8) the passes run out; at 1e-13 the pass
    // takes the 4 largest in and converges, off by 5e-14; from its answer the pass at
    // 1e-14 takes the next 4, and the pass at 1e-15 the last 4.
    let rows: Vec<Vec<(usize, f64)>> = (0..13).map(|j| vec![(j, 1.0)]).collect();
    let a = SparseRows::from_rows(13, &rows);
    let mut b = vec![1.0; 13];
    b[1..5].fill(5e-13);
    b[5..9].fill(5e-14);
    b[9..].fill(5e-15);
    let p = ProjectionProblem::new(vec![0.0; 13], a, b.clone()).unwrap();
    let outcome = solve(&p, start_from(vec![0], 13), Options::capped(6)).unwrap();
    assert_eq!(outcome.unfinished, None);
    assert!(outcome
        .x
        .iter()
        .zip(&b)
        .all(|(x, b)| (x - b).abs() <= 1e-22));
    assert_eq!(outcome.iterations, 1 + 6 + 6 + 5 + 5 + 5);
}

#[test]
fn a_pass_down_that_runs_out_keeps_its_best_iterate_when_it_is_off_by_less() {
    // x₀ ≥ 1, 4 rows xⱼ ≥ 5e-14 and 16 rows xⱼ ≥ 2e-15 … 9.5e-15, a cap of 5. The pass
    // at 1e-14 takes the 4 larger rows in and converges, off by 9.5e-15; down at 1e-15
    // from its answer the pass runs out, the 4 most violated of the smaller rows joined:
    // that iterate, off by less, is the answer.
    let rows: Vec<Vec<(usize, f64)>> = (0..21).map(|j| vec![(j, 1.0)]).collect();
    let a = SparseRows::from_rows(21, &rows);
    let mut b = vec![1.0; 21];
    b[1..5].fill(5e-14);
    for (k, bj) in b[5..].iter_mut().enumerate() {
        *bj = 2e-15 + 0.5e-15 * k as f64;
    }
    let p = ProjectionProblem::new(vec![0.0; 21], a, b.clone()).unwrap();
    let outcome = solve(&p, start_from(vec![0], 21), Options::capped(5)).unwrap();
    let joined: Vec<usize> = (5..21).filter(|&j| outcome.x[j] != 0.0).collect();
    assert_eq!(joined, vec![17, 18, 19, 20]);
    assert!(joined.iter().all(|&j| (outcome.x[j] - b[j]).abs() <= 1e-22));
    assert_eq!(outcome.unfinished, Some(b[16]));
    // The first pass's iteration; 5 at 1e-15, 5 at 1e-14, 5 at 1e-15 again.
    assert_eq!(outcome.iterations, 1 + 5 + 5 + 5);
}

#[test]
fn a_support_the_first_pass_leaves_overshot_is_finished() {
    // 1 ≤ x₀ ≤ 1 + 5e-13 with y₀ in between, both rows in the starting support: their
    // equations disagree by less than ACTIVE_TOL, and the first pass keeps both with
    // multipliers 1/2 though y satisfies both by 2.5e-13. The second pass finds them
    // inconsistent at 1e-13 and ends at the projection, y itself, with no multiplier.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, -1.0)]]);
    let y = 1.0 + 2.5e-13;
    let p = ProjectionProblem::new(vec![y], a, vec![1.0, -(1.0 + 5e-13)]).unwrap();
    let first = run(&p, start_from(vec![0, 1], 2), 10, FIRST_PASS, None, None)
        .unwrap()
        .outcome;
    assert!(first.lambda.iter().all(|l| *l > 0.1));
    let outcome = solve(&p, start_from(vec![0, 1], 2), Options::capped(10)).unwrap();
    assert_eq!(outcome.lambda, vec![0.0, 0.0]);
    assert!((outcome.x[0] - y).abs() <= 1e-16);
}

#[test]
fn a_row_violated_by_exactly_the_second_tolerance_is_left_as_it_is() {
    // x₀ ≥ 1, and x₁ ≥ 1e-13 = SECOND_PASS_TOL, violated by exactly that at y = 0:
    // "more than" the tolerance is what starts a second pass.
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, SECOND_PASS_TOL]).unwrap();
    let outcome = solve(&p, start_from(vec![0], 2), Options::capped(10)).unwrap();
    assert_eq!((outcome.x[1], outcome.iterations), (0.0, 1));
}

#[test]
fn the_first_answer_stands_when_the_second_pass_fails() {
    // x₀ ≥ 1 and x₀ ≤ 1 − 5e-13: empty, but by less than ACTIVE_TOL. The second pass
    // finds the rows inconsistent and cannot finish (the gap is too small to certify as
    // empty); the first pass's x₀ = 1 stands.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, -1.0)]]);
    let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, -(1.0 - 5e-13)]).unwrap();
    assert!(run(&p, start_from(vec![0, 1], 2), 10, SECOND_PASS, None, None).is_err());
    let outcome = solve(&p, start_from(vec![0], 2), Options::capped(10)).unwrap();
    assert_eq!(outcome.x, vec![1.0]);
    assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() <= 1e-12);
}
