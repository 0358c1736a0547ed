//! Screening: rows far from violated left out of a block, the rows kept solved as blocks of
//! their own, and rows left out that the answer violates joining until it satisfies them all.

use sweeping_api::conformance::max_gap;
use sweeping_api::{ProjectionProblem, Projector, RowKey, SparseRows};
use sweeping_native::{NativeProjector, NativeSettings};

/// `pairs` pairs of points on a line, each pair on top of each other (`x₂ₖ₊₁ − x₂ₖ ≥ 1`
/// violated by 1) and 5 from the next pair (`x₂ₖ₊₂ − x₂ₖ₊₁ ≥ 1` with room 4): one connected
/// block, in which every pair is a cluster of its own. The answer parts each pair by ½ a side.
fn pairs_in_a_line(pairs: usize) -> (ProjectionProblem, Vec<f64>) {
    let n = 2 * pairs;
    let y: Vec<f64> = (0..n).map(|j| 5.0 * (j / 2) as f64).collect();
    let rows: Vec<Vec<(usize, f64)>> = (0..n - 1).map(|j| vec![(j, -1.0), (j + 1, 1.0)]).collect();
    let b = vec![1.0; n - 1];
    let keys = (0..rows.len() as u64)
        .map(|member| RowKey { family: 1, member })
        .collect();
    let p = ProjectionProblem::new(y.clone(), SparseRows::from_rows(n, &rows), b)
        .unwrap()
        .with_row_keys(keys)
        .unwrap();
    let exact = y
        .iter()
        .enumerate()
        .map(|(j, v)| if j % 2 == 0 { v - 0.5 } else { v + 0.5 })
        .collect();
    (p, exact)
}

#[test]
fn a_block_of_many_clusters_is_solved_cluster_by_cluster() {
    let (p, exact) = pairs_in_a_line(300);
    // Every pair a block of its own: the active set answers each.
    let sol = NativeProjector::default().project(&p).unwrap();
    assert!(max_gap(&sol.x, &exact) <= 1e-12);
    assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() <= 1e-10);
    assert_eq!(sol.stats.counters.escalations, 0);
    for (i, &l) in sol.multipliers.iter().enumerate() {
        let pushed = if i % 2 == 0 { 0.5 } else { 0.0 };
        assert!((l - pushed).abs() <= 1e-12, "row {i}: {l}");
    }
    // With the interior point alone, one run per pair: 300 blocks, none of them the whole.
    let mut interior = NativeProjector::new(NativeSettings {
        active_set_iterations: 0,
        ..NativeSettings::default()
    });
    let sol = interior.project(&p).unwrap();
    assert!(max_gap(&sol.x, &exact) <= 1e-9);
    assert_eq!(sol.stats.counters.escalations, 300);
}

/// A point between a wall `x₀ ≥ 0` (room 0.4 at `y`) and a point on top of it (`x₁ − x₀ ≥ 1`
/// violated by 1): the wall's room is beyond the screening's reach (half the violation, as
/// distances: 0.35), so the first run leaves it out and its answer `(−0.1, 0.9)` violates it;
/// the wall joins, and the answer is `(0, 1)` with multipliers `(0.2, 0.6)`.
#[test]
fn a_row_left_out_that_the_answer_violates_joins() {
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, -1.0), (1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.4, 0.4], a, vec![0.0, 1.0]).unwrap();
    for active_set_iterations in [0, 48] {
        let mut native = NativeProjector::new(NativeSettings {
            active_set_iterations,
            ..NativeSettings::default()
        });
        let sol = native.project(&p).unwrap();
        assert!(max_gap(&sol.x, &[0.0, 1.0]) <= 1e-9, "{:?}", sol.x);
        assert!(
            max_gap(&sol.multipliers, &[0.2, 0.6]) <= 1e-8,
            "{:?}",
            sol.multipliers
        );
        assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() <= 1e-10);
    }
}
