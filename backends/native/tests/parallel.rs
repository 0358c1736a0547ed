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

/// A crowd pressed together: `people` disks of radius `r = 0.2` on a jittered grid around
/// `centre`, everyone pulled towards it by `pull` per step; rows keyed by the pair.
struct Crowd {
    q: Vec<[f64; 2]>,
    centre: [f64; 2],
    pull: f64,
    family: u32,
}

const R: f64 = 0.2;

impl Crowd {
    fn pressed(people: usize, centre: [f64; 2], pull: f64, seed: u64, family: u32) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let side = (people as f64).sqrt().ceil() as usize;
        let q = (0..people)
            .map(|k| {
                let (i, j) = ((k % side) as f64, (k / side) as f64);
                let half = side as f64 / 2.0;
                [
                    centre[0] + (i - half) * 2.1 * R + rng.gen_range(-0.02..0.02),
                    centre[1] + (j - half) * 2.1 * R + rng.gen_range(-0.02..0.02),
                ]
            })
            .collect();
        Self {
            q,
            centre,
            pull,
            family,
        }
    }
}

/// One step's projection of the crowds, each its own block, in the displacements: for each
/// pair nearer than `3r`, `nᵢⱼ·(uⱼ − uᵢ) ≥ 2r − dᵢⱼ`; `y` the pull towards each centre.
fn crowds_problem(crowds: &[Crowd]) -> ProjectionProblem {
    let n: usize = crowds.iter().map(|c| 2 * c.q.len()).sum();
    let (mut y, mut b, mut keys) = (Vec::new(), Vec::new(), Vec::new());
    let mut a = SparseRows::new(n);
    let mut offset = 0;
    for c in crowds {
        for p in &c.q {
            y.push(c.pull * (c.centre[0] - p[0]));
            y.push(c.pull * (c.centre[1] - p[1]));
        }
        for i in 0..c.q.len() {
            for j in i + 1..c.q.len() {
                let d = [c.q[j][0] - c.q[i][0], c.q[j][1] - c.q[i][1]];
                let dist = d[0].hypot(d[1]);
                if dist < 3.0 * R {
                    let nrm = [d[0] / dist, d[1] / dist];
                    let (xi, xj) = (offset + 2 * i, offset + 2 * j);
                    a.push_row(vec![
                        (xi, -nrm[0]),
                        (xi + 1, -nrm[1]),
                        (xj, nrm[0]),
                        (xj + 1, nrm[1]),
                    ]);
                    b.push(2.0 * R - dist);
                    keys.push(RowKey {
                        family: c.family,
                        member: (i * c.q.len() + j) as u64,
                    });
                }
            }
        }
        offset += 2 * c.q.len();
    }
    ProjectionProblem::new(y, a, b)
        .unwrap()
        .with_row_keys(keys)
        .unwrap()
}

/// With blocks large enough to be grouped, one thread and two give the same bits, step after
/// step of crowds pressed together (two large, three smaller, as queues at the doors of an
/// evacuation): the groups run one after the other on one thread with the memory they have
/// on two. (One thread once solved the blocks in a row with one memory, so the orderings of
/// later blocks, and then the rounding of their answers, differed: the 2000-person
/// evacuation run on one thread and on two drifted apart from t = 6 s.)
#[test]
fn one_thread_and_two_give_the_same_bits() {
    let mut crowds = vec![
        Crowd::pressed(250, [0.0, 0.0], 0.4, 1, 0),
        Crowd::pressed(30, [20.0, 0.0], 0.3, 2, 1),
        Crowd::pressed(300, [40.0, 0.0], 0.3, 3, 2),
        Crowd::pressed(40, [60.0, 0.0], 0.5, 4, 3),
        Crowd::pressed(60, [80.0, 0.0], 0.2, 5, 4),
    ];
    let with_threads = |threads| {
        NativeProjector::new(NativeSettings {
            threads,
            ..NativeSettings::default()
        })
    };
    let (mut one, mut two) = (with_threads(1), with_threads(2));
    for step in 0..10 {
        let p = crowds_problem(&crowds);
        let (a, b) = (one.project(&p).unwrap(), two.project(&p).unwrap());
        assert!(a.x == b.x, "step {step}: the points differ");
        assert!(
            a.multipliers == b.multipliers,
            "step {step}: the multipliers differ"
        );
        let kkt = p.kkt_residuals(&a.x, &a.multipliers).max();
        assert!(kkt <= 1e-10, "step {step}: KKT residual {kkt:e}");
        let mut k = 0;
        for c in &mut crowds {
            for q in &mut c.q {
                q[0] += a.x[k];
                q[1] += a.x[k + 1];
                k += 2;
            }
        }
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
