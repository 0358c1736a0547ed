//! Tests of bordering.

use super::*;
use crate::active_set::test_problems::{random_problem, raw_solve_gap, solve_gap};
use sweeping_api::{ProjectionProblem, SparseRows};

#[test]
fn a_bordered_factor_solves_what_a_fresh_factorization_solves() {
    let p = random_problem();
    let base: Vec<usize> = (0..26).collect();
    let system = ActiveSystem::sparse(&p, &base).unwrap();
    // Rows 3 and 10 leave, 27 and 30 join (appended, in that order).
    let next: Vec<usize> = (0..26)
        .filter(|&i| i != 3 && i != 10)
        .chain([27, 30])
        .collect();
    let mut system = system.bordered_to(&p, &next).expect("two changes each way");
    let gap = solve_gap(&p, &mut system, &next);
    assert!(gap < 1e-11, "gap {gap:e}");
    // A joined row leaves again (its change is undone), a row of the base leaves, one more
    // joins.
    let next: Vec<usize> = next
        .iter()
        .copied()
        .filter(|&i| i != 27 && i != 5)
        .chain([33])
        .collect();
    let mut system = system.bordered_to(&p, &next).expect("still few changes");
    assert_eq!(system.bordered.as_ref().map(|b| b.changes.len()), Some(5));
    let gap = solve_gap(&p, &mut system, &next);
    assert!(gap < 1e-11, "gap {gap:e}");
}

#[test]
fn a_bordered_solve_is_the_regularized_solve_of_the_new_support() {
    let p = random_problem();
    let base: Vec<usize> = (0..26).collect();
    let mut system = ActiveSystem::sparse(&p, &base).unwrap();
    let mut support = base;
    // Rows leave and join one or two at a time, a joined row leaving again in between,
    // eight changes in the end (so that the Schur complement mixes both kinds).
    for (leave, join) in [
        (vec![3], vec![27]),
        (vec![10, 27], vec![30, 31]),
        (vec![0], vec![]),
        (vec![], vec![33, 26]),
        (vec![25, 31], vec![32]),
    ] {
        support.retain(|i| !leave.contains(i));
        support.extend(join);
        system = system.bordered_to(&p, &support).expect("few changes");
        let gap = raw_solve_gap(&p, &mut system, &support);
        assert!(gap < 1e-6, "{support:?}: gap {gap:e}");
    }
    assert_eq!(system.bordered.as_ref().map(|b| b.changes.len()), Some(8));
}

#[test]
fn a_bordered_solve_pivots_when_a_row_is_replaced_by_its_copy() {
    // Row 34 (a copy of row 3) joins: its entry of the Schur complement is only −δ. Then
    // row 3 leaves, and the complement [[−δ, ≈ −1], [≈ −1, s]] must be pivoted.
    let p = random_problem();
    let base: Vec<usize> = (0..26).collect();
    let system = ActiveSystem::sparse(&p, &base).unwrap();
    let mut support = base.clone();
    support.push(34);
    let system = system.bordered_to(&p, &support).expect("one change");
    support.retain(|&i| i != 3);
    let mut system = system.bordered_to(&p, &support).expect("two changes");
    assert_ne!(system.bordered.as_ref().map(|b| b.pivots[0]), Some(0));
    let gap = raw_solve_gap(&p, &mut system, &support);
    assert!(gap < 1e-6, "gap {gap:e}");
}

#[test]
fn a_factor_covers_the_touched_unknowns_and_bordering_extends_it_by_the_identity() {
    // Rows 0 and 1 touch unknowns 0–2; row 2 joins with unknown 4, which they do not
    // touch; unknowns 3 and 5 no row touches.
    let a = SparseRows::from_rows(
        6,
        &[
            vec![(0, 1.0), (1, -0.5)],
            vec![(2, 1.0), (1, 0.25)],
            vec![(4, 1.0), (2, -0.5)],
        ],
    );
    let p = ProjectionProblem::new(vec![0.0; 6], a, vec![1.0, 1.0, 1.0]).unwrap();
    let system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
    assert_eq!(system.unknowns.global, vec![0, 1, 2]);
    let mut system = system.bordered_to(&p, &[0, 1, 2]).expect("one change");
    assert_eq!(system.unknowns.global, vec![0, 1, 2, 4]);
    assert_eq!(system.unknowns.base, 3);
    let gap = raw_solve_gap(&p, &mut system, &[0, 1, 2]);
    assert!(gap < 1e-12, "gap {gap:e}");
    // An unknown outside every row is its own solution, through either factor.
    let mut v: Vec<f64> = (0..9).map(|i| 1.0 + i as f64).collect();
    system.solve_in_place(&mut v);
    assert_eq!((v[3], v[5]), (4.0, 6.0));
    let mut fresh = ActiveSystem::sparse(&p, &[0, 1, 2]).unwrap();
    assert_eq!(fresh.unknowns.global, vec![0, 1, 2, 4]);
    let mut v: Vec<f64> = (0..9).map(|i| 1.0 + i as f64).collect();
    fresh.solve_in_place(&mut v);
    assert_eq!((v[3], v[5]), (4.0, 6.0));
}

/// A `Bordered` with `S` given (row-major `c × c`) and `c` placeholder changes.
fn with_schur(s: Vec<f64>, c: usize) -> Bordered {
    Bordered {
        base: (0..c).collect(),
        changes: (0..c).map(|position| Change::Left { position }).collect(),
        s,
        ..Bordered::default()
    }
}

#[test]
fn the_schur_complement_is_lu_factored_with_row_pivoting() {
    // Pivoting needed at the second column only: P S = L U checked entry by entry.
    let s = vec![4.0, 1.0, 2.0, 1.0, 0.3, 1.0, 2.0, 2.0, 1.0];
    let mut b = with_schur(s.clone(), 3);
    assert!(b.factor_s());
    let c = 3;
    for i in 0..c {
        for j in 0..c {
            let lu: f64 = (0..c)
                .map(|k| {
                    let l = match k.cmp(&i) {
                        std::cmp::Ordering::Less => b.lu[i * c + k],
                        std::cmp::Ordering::Equal => 1.0,
                        std::cmp::Ordering::Greater => 0.0,
                    };
                    let u = if k <= j { b.lu[k * c + j] } else { 0.0 };
                    l * u
                })
                .sum();
            let ps = s[b.pivots[i] * c + j];
            assert!((lu - ps).abs() < 1e-12, "({i}, {j}): {lu} against {ps}");
        }
    }
    assert_eq!(b.pivots, vec![0, 2, 1]);
    // A singular complement is refused.
    let mut b = with_schur(vec![1.0, 2.0, 2.0, 4.0], 2);
    assert!(!b.factor_s());
}

#[test]
fn a_bordered_factor_takes_up_to_border_max_changes() {
    let p = random_problem();
    let base: Vec<usize> = (0..26).collect();
    let system = ActiveSystem::sparse(&p, &base).unwrap();
    assert!(system.bordered_to(&p, &base[BORDER_MAX..]).is_some());
}

#[test]
fn a_bordered_factor_refuses_a_reordered_support_or_too_many_changes() {
    let p = random_problem();
    let base: Vec<usize> = (0..26).collect();
    let mut swapped = base.clone();
    swapped.swap(0, 1);
    let system = ActiveSystem::sparse(&p, &base).unwrap();
    assert!(system.bordered_to(&p, &swapped).is_none());
    // BORDER_MAX + 1 rows leave.
    let fewer: Vec<usize> = base[BORDER_MAX + 1..].to_vec();
    let system = ActiveSystem::sparse(&p, &base).unwrap();
    assert!(system.bordered_to(&p, &fewer).is_none());
    // A dense factor is not bordered.
    let small: Vec<usize> = (0..4).collect();
    let system = ActiveSystem::new(&p, &small, None).unwrap();
    assert!(matches!(system.factor, Factor::Dense(_)));
    assert!(system.bordered_to(&p, &small[..3]).is_none());
}

#[test]
fn changes_are_counted_before_any_is_made() {
    // Two changes so far: row 7 joined, position 2 of the base left.
    let changes = vec![
        Change::Joined {
            row: 7,
            entries: vec![(0, 1.0)],
        },
        Change::Left { position: 2 },
    ];
    // Nothing moves: still two.
    assert_eq!(changes_after(&changes, &[], 0), 2);
    // Row 7 leaves again (its change undone), row 4 of the base leaves, 3 rows join.
    assert_eq!(changes_after(&changes, &[7, 4], 3), 2 - 1 + 1 + 3);
    // From a fresh factor: every leaving and joining row is a change.
    assert_eq!(changes_after(&[], &[1, 2, 3], 40), 43);
}

#[test]
fn a_support_that_takes_in_many_rows_at_once_is_factored_afresh() {
    let p = random_problem();
    let base: Vec<usize> = (0..4).chain(26..30).collect();
    let system = ActiveSystem::sparse(&p, &base).unwrap();
    // BORDER_MAX + 1 rows join.
    let mut next = base.clone();
    next.extend((4..26).chain(30..33));
    assert!(next.len() - base.len() > BORDER_MAX);
    assert!(system.bordered_to(&p, &next).is_none());
}
