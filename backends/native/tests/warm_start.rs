//! Warm start by row keys: reordered, appearing and vanishing rows give the cold answer; the
//! key checks; and a property test of the KKT conditions on random instances with linearly
//! dependent rows.

use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweeping_api::conformance::{max_gap, random_instance};
use sweeping_api::{ProjectionError, ProjectionProblem, Projector, RowKey, SparseRows};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::{NativeProjector, NativeSettings};

fn key(m: u64) -> RowKey {
    RowKey {
        family: 3,
        member: m,
    }
}

/// The rows `order` of `p` (in that order), with keys `key(original index)`, and `y` moved.
fn reshuffled(p: &ProjectionProblem, order: &[usize], dy: &[f64]) -> ProjectionProblem {
    let mut a = SparseRows::new(p.dim());
    for &r in order {
        a.push_row(p.a().row(r));
    }
    let b = order.iter().map(|&r| p.b()[r]).collect();
    let y = p.y().iter().zip(dy).map(|(u, v)| u + v).collect();
    ProjectionProblem::new(y, a, b)
        .unwrap()
        .with_row_keys(order.iter().map(|&r| key(r as u64)).collect())
        .unwrap()
}

#[test]
fn reordered_appearing_and_vanishing_rows_match_a_cold_start() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut warm_starts = 0;
    for seed in 0..40u64 {
        let base = random_instance(700 + seed, 20, 30);
        let mut warm = NativeProjector::default();
        let all: Vec<usize> = (0..base.n_rows()).collect();
        let first = reshuffled(&base, &all, &vec![0.0; base.dim()]);
        warm.project(&first).unwrap();
        for step in 0..5 {
            // A random subset of the rows (some vanish, some come back), shuffled, and a
            // slightly moved y: like the next step of a simulation.
            let mut order: Vec<usize> = all.iter().copied().filter(|_| rng.gen_bool(0.8)).collect();
            for i in (1..order.len()).rev() {
                order.swap(i, rng.gen_range(0..=i));
            }
            let dy: Vec<f64> = (0..base.dim())
                .map(|_| rng.gen_range(-0.05..0.05))
                .collect();
            let p = reshuffled(&base, &order, &dy);
            let w = warm.project(&p).unwrap();
            let c = NativeProjector::default().project(&p).unwrap();
            warm_starts += usize::from(w.stats.warm_started);
            assert_eq!(w.stats.counters.fallbacks, 0);
            let gap = max_gap(&w.x, &c.x);
            assert!(
                gap <= 1e-9,
                "seed {seed}, step {step}: warm and cold differ by {gap:.3e}"
            );
            let kkt = p.kkt_residuals(&w.x, &w.multipliers).max();
            assert!(kkt <= 1e-10, "seed {seed}, step {step}: KKT {kkt:.3e}");
        }
    }
    assert!(
        warm_starts >= 100,
        "only {warm_starts} of 200 solves were warm-started"
    );
}

#[test]
fn a_stale_active_set_is_corrected() {
    // Last step the row was active with a large multiplier; now y satisfies it: the warm
    // start must drop it.
    let a = SparseRows::from_rows(1, &[vec![(0, 1.0)]]);
    let mut native = NativeProjector::default();
    let p1 = ProjectionProblem::new(vec![-3.0], a.clone(), vec![0.0])
        .unwrap()
        .with_row_keys(vec![key(9)])
        .unwrap();
    assert!((native.project(&p1).unwrap().multipliers[0] - 3.0).abs() < 1e-12);
    let a2 = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, 1.0)]]);
    let p2 = ProjectionProblem::new(vec![2.0, -5.0], a2, vec![0.0, 0.0])
        .unwrap()
        .with_row_keys(vec![key(9), key(10)])
        .unwrap();
    let sol = native.project(&p2).unwrap();
    assert!(sol.stats.warm_started);
    assert!(max_gap(&sol.x, &[3.5, -3.5]) <= 1e-12, "{:?}", sol.x);
    assert_eq!(sol.multipliers[0], 0.0);
}

#[test]
fn keys_are_checked() {
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    let p = ProjectionProblem::new(vec![0.0; 2], a, vec![1.0, 1.0]).unwrap();
    match p.clone().with_row_keys(vec![key(1)]) {
        Err(ProjectionError::InvalidInput { reason }) => {
            assert!(reason.contains("1 row keys for 2 rows"), "{reason}")
        }
        other => panic!("expected InvalidInput, got {other:?}"),
    }
    match p.with_row_keys(vec![key(4), key(4)]) {
        Err(ProjectionError::InvalidInput { reason }) => {
            assert!(reason.contains("rows 0 and 1"), "{reason}")
        }
        other => panic!("expected InvalidInput, got {other:?}"),
    }
}

/// A random instance whose rows include exact copies, scaled copies and sums of other rows
/// (linearly dependent, as in contact loops), all satisfiable by a known point.
fn dependent_instance(seed: u64, n: usize, m: usize) -> ProjectionProblem {
    let base = random_instance(seed, n, m);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let mut rows: Vec<Vec<(usize, f64)>> = (0..m).map(|r| base.a().row(r).collect()).collect();
    let mut b = base.b().to_vec();
    for _ in 0..m / 2 {
        let i = rng.gen_range(0..m);
        let j = rng.gen_range(0..m);
        let s = rng.gen_range(0.5..2.0);
        let mut row: Vec<(usize, f64)> = rows[i].iter().map(|&(c, v)| (c, s * v)).collect();
        let mut rhs = s * b[i];
        if rng.gen_bool(0.5) {
            // The sum of two rows: summed entries per column.
            for &(c, v) in &rows[j] {
                match row.iter_mut().find(|e| e.0 == c) {
                    Some(e) => e.1 += v,
                    None => row.push((c, v)),
                }
            }
            rhs += b[j];
        }
        rows.push(row);
        b.push(rhs);
    }
    ProjectionProblem::new(base.y().to_vec(), SparseRows::from_rows(n, &rows), b).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The one thing the backend may never do is return a wrong answer: alone, it returns an
    /// answer within its certificate or a typed error; with Clarabel behind it, always an
    /// answer, within Clarabel's tolerance where Clarabel took over. (On rows this dependent —
    /// up to 55 rows on 4 unknowns — the method alone does fail now and then: proptest found
    /// such cases, one of them kept below.)
    #[test]
    fn answers_are_certified_on_random_instances_with_dependent_rows(
        seed in 0u64..1_000_000, n in 2usize..25, m in 1usize..40,
    ) {
        let p = dependent_instance(seed, n, m);
        let scale = p.y().iter().chain(p.b()).fold(1.0, |a: f64, v| a.max(v.abs()));
        match NativeProjector::default().project(&p) {
            Ok(sol) => {
                let kkt = p.kkt_residuals(&sol.x, &sol.multipliers).max();
                prop_assert!(kkt <= 1e-10 * scale, "KKT {:.3e}", kkt);
            }
            Err(e) => prop_assert!(
                matches!(e, ProjectionError::NotConverged { .. }),
                "unexpected error {}", e
            ),
        }
        let mut backed = NativeProjector::with_fallback(
            NativeSettings::default(),
            Box::new(ClarabelProjector::default()),
        );
        let sol = backed.project(&p).unwrap();
        let allowed = if sol.stats.counters.fallbacks > 0 { backed.tolerance() } else { 1e-10 * scale };
        let kkt = p.kkt_residuals(&sol.x, &sol.multipliers).max();
        prop_assert!(kkt <= allowed, "KKT {:.3e} > {:.1e}", kkt, allowed);
    }
}

/// A case proptest found cycling (55 rows on 7 unknowns); the restart as Lawson–Hanson
/// proper solves it without a fallback.
#[test]
fn kkt_holds_on_the_shrunk_dependent_case() {
    let p = dependent_instance(17802, 7, 37);
    let sol = NativeProjector::default().project(&p).unwrap();
    assert_eq!(sol.stats.counters.fallbacks, 0);
    let scale = p
        .y()
        .iter()
        .chain(p.b())
        .fold(1.0, |a: f64, v| a.max(v.abs()));
    let kkt = p.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= 1e-10 * scale, "KKT {kkt:.3e}");
}
