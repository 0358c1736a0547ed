//! Blocks solved on threads of their own ([`NativeSettings::parallel_rows`]): the conformance
//! kit with every block large enough, the same answers as one thread over warm-started steps,
//! fallbacks and infeasibility reported from a block solved on another thread.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweeping_api::conformance::{max_gap, random_instance, Tolerances};
use sweeping_api::{ProjectionError, ProjectionProblem, Projector, RowKey, SparseRows};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::{NativeProjector, NativeSettings};

/// The kit with every block of one row or more on a thread of its own whenever a problem has
/// two blocks or more.
mod every_block_on_a_thread {
    use super::*;
    sweeping_api::conformance_tests!(
        NativeProjector::new(NativeSettings {
            parallel_rows: 1,
            ..NativeSettings::default()
        }),
        Tolerances {
            kkt: 1e-10,
            point: 1e-7,
            certifies_infeasibility: true
        }
    );
}

fn threaded(parallel_rows: usize) -> NativeSettings {
    NativeSettings {
        parallel_rows,
        ..NativeSettings::default()
    }
}

/// The problems `parts` side by side (block-diagonal `A`), each row keyed by its part and
/// its index there, `y` moved by `dy`.
fn side_by_side(
    parts: &[ProjectionProblem],
    keep: &dyn Fn(usize, usize) -> bool,
    dy: &[f64],
) -> ProjectionProblem {
    let n: usize = parts.iter().map(ProjectionProblem::dim).sum();
    let mut a = SparseRows::new(n);
    let (mut y, mut b, mut keys) = (Vec::new(), Vec::new(), Vec::new());
    let mut offset = 0;
    for (part, p) in parts.iter().enumerate() {
        y.extend_from_slice(p.y());
        for r in (0..p.n_rows()).filter(|&r| keep(part, r)) {
            let row: Vec<(usize, f64)> = p.a().row(r).map(|(c, v)| (c + offset, v)).collect();
            a.push_row(row);
            b.push(p.b()[r]);
            keys.push(RowKey {
                family: part as u32,
                member: r as u64,
            });
        }
        offset += p.dim();
    }
    y.iter_mut().zip(dy).for_each(|(yi, d)| *yi += d);
    ProjectionProblem::new(y, a, b)
        .unwrap()
        .with_row_keys(keys)
        .unwrap()
}

#[test]
fn blocks_on_threads_give_the_answers_of_one_thread_step_after_step() {
    let parts: Vec<ProjectionProblem> = (0..5).map(|s| random_instance(900 + s, 30, 45)).collect();
    let n: usize = parts.iter().map(ProjectionProblem::dim).sum();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (mut on_threads, mut on_one) = (
        NativeProjector::new(threaded(10)),
        NativeProjector::new(threaded(0)),
    );
    for step in 0..8 {
        // As the next step of a simulation: some rows vanish, y moves a little.
        let kept: Vec<Vec<bool>> = parts
            .iter()
            .map(|p| {
                (0..p.n_rows())
                    .map(|_| step == 0 || rng.gen_bool(0.85))
                    .collect()
            })
            .collect();
        let dy: Vec<f64> = (0..n).map(|_| rng.gen_range(-0.05..0.05)).collect();
        let p = side_by_side(&parts, &|part, r| kept[part][r], &dy);
        let threads = on_threads.project(&p).unwrap();
        let one = on_one.project(&p).unwrap();
        let reference = ClarabelProjector::default().project(&p).unwrap();
        let kkt = p.kkt_residuals(&threads.x, &threads.multipliers).max();
        assert!(kkt <= 1e-10, "step {step}: KKT residual {kkt:e}");
        assert_eq!(threads.stats.counters.fallbacks, 0, "step {step}");
        let (gap_one, gap_reference) = (
            max_gap(&threads.x, &one.x),
            max_gap(&threads.x, &reference.x),
        );
        assert!(gap_one <= 1e-9, "step {step}: {gap_one:e} from one thread");
        assert!(
            gap_reference <= 1e-8,
            "step {step}: {gap_reference:e} from Clarabel"
        );
    }
}

#[test]
fn a_block_that_fails_on_another_thread_goes_to_the_fallback() {
    let parts: Vec<ProjectionProblem> = (0..3).map(|s| random_instance(950 + s, 30, 45)).collect();
    let p = side_by_side(&parts, &|_, _| true, &vec![0.0; 90]);
    // One guess of the support method, one interior-point iteration and no finish: the
    // blocks that need more go to Clarabel.
    let settings = NativeSettings {
        active_set_iterations: 1,
        interior_point_iterations: 1,
        finish_iterations: 0,
        parallel_rows: 10,
        ..NativeSettings::default()
    };
    let mut native =
        NativeProjector::with_fallback(settings, Box::new(ClarabelProjector::default()));
    let answer = native.project(&p).unwrap();
    assert!(answer.stats.counters.fallbacks > 0, "{:?}", answer.stats);
    let reference = ClarabelProjector::default().project(&p).unwrap();
    assert!(max_gap(&answer.x, &reference.x) <= 1e-8);
}

#[test]
fn an_empty_block_on_another_thread_is_reported_with_its_certificate() {
    // Two chains of 20 unknowns pushed apart (x_{j+1} − x_j ≥ 1), the second with rows that
    // also ask x_0 ≥ 1 and −x_0 ≥ 0 of its first unknown: empty.
    let chain = |offset: usize, rows: &mut Vec<Vec<(usize, f64)>>, b: &mut Vec<f64>| {
        for j in 0..19 {
            rows.push(vec![(offset + j, -1.0), (offset + j + 1, 1.0)]);
            b.push(1.0);
        }
    };
    let (mut rows, mut b) = (Vec::new(), Vec::new());
    chain(0, &mut rows, &mut b);
    chain(20, &mut rows, &mut b);
    rows.push(vec![(20, 1.0)]);
    b.push(1.0);
    rows.push(vec![(20, -1.0)]);
    b.push(0.0);
    let a = SparseRows::from_rows(40, &rows);
    let p = ProjectionProblem::new(vec![0.0; 40], a, b).unwrap();
    match NativeProjector::new(threaded(10)).project(&p) {
        Err(ProjectionError::Infeasible { detail, .. }) => {
            assert!(detail.contains("block 1"), "{detail}");
        }
        other => panic!("expected infeasibility, got {other:?}"),
    }
}
