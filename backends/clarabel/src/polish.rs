//! Active-set polishing of an interior-point answer.
//!
//! An interior-point iterate approaches the solution from inside the cone. On a row that is
//! *weakly* active at the solution (tight, with a zero multiplier) both the slack and the
//! multiplier only go to zero like `√μ`, so the point stays off by about the square root of
//! the duality gap (`1e-5` for a gap of `1e-10`) however small the KKT residuals are.
//! Polishing guesses the active set from the iterate — the rows whose multiplier exceeds their
//! slack (`zᵢ > sᵢ`), starting from their multipliers — and finishes the job exactly with the
//! dual Lawson–Hanson method of [`sweeping_qp::active_set`], robust to the linearly dependent rows of
//! contact loops. The caller keeps the answer only when its KKT residuals say so.
//!
//! The polish runs block by block ([`Blocks`]): after its first pass the method drops one row
//! per iteration, so on the whole problem every block's leaving rows would queue behind each
//! other under one cap, and each iteration would re-solve every block; on large jams such a
//! polish gives up, even with a cap growing with the rows, and leaves the unpolished answer
//! (measured: `docs/lab/2026-11-23-clarabel-polish-block-by-block.md`). Block by block, a
//! jam's block whose guess holds more rows than unknowns can still go round for good when
//! every violated row joins at once; such a block is polished again with the most violated
//! row joining alone, as the native engine finishes its interior points.

use sweeping_api::{
    Blocks, EqualityPairs, MetricChange, Projection, ProjectionProblem, SolveStats,
};
use sweeping_qp::active_set::{self, Options, Start};

/// Most active-set iterations on a block of `m` rows: `ITERATIONS + m/2`.
const ITERATIONS: u32 = 40;

/// Most active-set iterations of the first tries on a block of `m` rows: `ITERATIONS + m/2`.
fn short_cap(m: usize) -> u32 {
    ITERATIONS.saturating_add(u32::try_from(m / 2).unwrap_or(u32::MAX))
}

/// Most active-set iterations of the last try on a block of `m` rows, one row joining at a
/// time: `ITERATIONS + 2m`, room for every row to join and leave once.
fn long_cap(m: usize) -> u32 {
    ITERATIONS.saturating_add(u32::try_from(m.saturating_mul(2)).unwrap_or(u32::MAX))
}

/// How far an interior-point iterate is off, as [`active_set::Outcome::unfinished`] measures
/// an answer, from its rows' `(multiplier, slack)`: the largest violation of a row, or slack
/// of a row whose multiplier exceeds it (the rows the polish would start from as tight).
pub(crate) fn iterate_off(rows: impl Iterator<Item = (f64, f64)>) -> f64 {
    rows.fold(0.0, |off: f64, (z, s)| {
        if s < 0.0 {
            off.max(-s)
        } else if z > s {
            off.max(s)
        } else {
            off
        }
    })
}

/// [`polish`] for a problem with a metric or equality rows: polished in `z = Lᵀx`
/// ([`MetricChange`]) with the equalities as pairs of inequalities ([`EqualityPairs`]), where
/// the active set works, and said back in `x` with free-sign multipliers.
pub(crate) fn polish_general(
    problem: &ProjectionProblem,
    x: &[f64],
    z: &[f64],
    s: &[f64],
) -> Option<Polished> {
    let change = MetricChange::new(problem).ok()?;
    let (euclidean, point) = match &change {
        Some(c) => (c.problem(), c.point(x)),
        None => (problem, x.to_vec()),
    };
    let pairs = EqualityPairs::new(euclidean).ok()?;
    let polished = match &pairs {
        Some(pairs) => {
            let z = pairs.per_row(z, |l| l.max(0.0), |l| (-l).max(0.0));
            let s = pairs.per_row(s, |v| v, |v| v);
            polish(pairs.problem(), &point, &z, &s)?
        }
        None => polish(euclidean, &point, z, s)?,
    };
    let mut answer = Projection {
        x: polished.x,
        multipliers: polished.lambda,
        stats: SolveStats::trivial(""),
    };
    if let Some(pairs) = &pairs {
        answer = pairs.answer(answer);
    }
    if let Some(change) = &change {
        answer = change.answer(answer);
    }
    Some(Polished {
        x: answer.x,
        lambda: answer.multipliers,
        unfinished: polished.unfinished,
    })
}

/// A polished answer.
#[derive(Debug, Clone)]
pub(crate) struct Polished {
    /// The point.
    pub x: Vec<f64>,
    /// One multiplier per row.
    pub lambda: Vec<f64>,
    /// Blocks whose answer the method's second pass could not finish
    /// ([`active_set::Outcome::unfinished`]) or that kept the interior-point iterate
    /// ([`iterate_off`]), and the largest amount by which they are off.
    pub unfinished: (u32, f64),
}

/// The start of the active-set method from the rows `support` of a block, at their
/// interior-point multipliers `z`; a row that joins later starts from its own.
fn start_at(support: Vec<usize>, z: &[f64], join_at_most: Option<usize>) -> Start {
    Start {
        lambda: support
            .iter()
            .map(|&t| z[t].max(f64::MIN_POSITIVE))
            .collect(),
        support,
        join: z.iter().map(|v| v.max(f64::MIN_POSITIVE)).collect(),
        join_at_most,
    }
}

/// The rows of `guess` the interior point is surest are tight, at most `n` of them (the
/// block's unknowns): rows whose slack `s` is not positive (the point violates them or holds
/// them exactly) first, then the largest `z/s`, ties by row.
fn surest(guess: &[usize], z: &[f64], s: &[f64], n: usize) -> Vec<usize> {
    let confidence = |t: usize| {
        if s[t] > 0.0 {
            z[t] / s[t]
        } else {
            f64::INFINITY
        }
    };
    let mut rows = guess.to_vec();
    rows.sort_by(|&a, &b| confidence(b).total_cmp(&confidence(a)).then(a.cmp(&b)));
    rows.truncate(n);
    rows.sort_unstable();
    rows
}

/// The active-set method on one block from its interior-point multipliers `z` and slacks `s`,
/// in up to four tries, each run only when the one before ran out of iterations (or cycled):
/// from the rows with `z > s`, every violated row joining at once, under `ITERATIONS + m/2`
/// (skipped when those rows outnumber the block's unknowns, see below);
/// the same with the most violated row joining alone; that under [`long_cap`]; and, when
/// those rows outnumber the block's unknowns (so some of them depend on the others), from the
/// [`surest`] of them by the interior-point answer's own slacks `point_slack` (Clarabel's cone
/// slacks `s` rank them less well: from that ranking the try can fail to finish), the most
/// violated row joining alone, under [`long_cap`]. A block whose guess outnumbers its unknowns
/// and whose answer is unfinished gets the skipped first try last, kept when it finishes.
fn polish_block(
    block: &ProjectionProblem,
    z: &[f64],
    s: &[f64],
    point_slack: impl Fn(usize) -> f64,
) -> Result<active_set::Outcome, active_set::Failure> {
    use active_set::Failure::{Cap, Cycling};
    let m = block.n_rows();
    let guess: Vec<usize> = (0..m).filter(|&t| z[t] > s[t]).collect();
    let cap = short_cap(m);
    // A guess with more rows than unknowns holds dependent rows, and its first solves are
    // inconsistent: the method leaves rows along the ray one per iteration, and every row
    // joining at once then takes back hundreds that leave again. On a jam's door queues that
    // first try runs out or cycles on such blocks, spending iterations before the next try
    // finishes from the same guess (measured:
    // `docs/lab/2026-11-29-clarabel-polish-over-complete-guess.md`); they start at the next.
    let over_complete = guess.len() > block.dim();
    let mut outcome = if over_complete {
        Err(Cap(0))
    } else {
        active_set::solve(
            block,
            start_at(guess.clone(), z, None),
            Options::capped(cap),
        )
    };
    // Rows joining together that depend on the support make its equations inconsistent, and
    // they leave again one per iteration; on a jam whose guess holds more rows than unknowns
    // that can go round for good, while the most violated row joining alone finishes (measured:
    // `docs/lab/2026-11-24-clarabel-jam-polish-one-row-at-a-time.md`). Tried second, because
    // joining every violated row at once is what saves iterations when the guess is good.
    if matches!(outcome, Err(Cap(_) | Cycling(_))) {
        outcome = active_set::solve(
            block,
            start_at(guess.clone(), z, Some(1)),
            Options::capped(cap),
        );
        // Room for every row of the block to join and leave once: on a jam both tries above
        // can run out where one row at a time under this cap finishes (measured:
        // `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
        if matches!(outcome, Err(Cap(_))) {
            outcome = active_set::solve(
                block,
                start_at(guess.clone(), z, Some(1)),
                Options::capped(long_cap(m)),
            );
        }
    }
    // A guess far beyond the block's unknowns can make every try above run out, where the
    // unknowns' count of its surest rows finishes (measured:
    // `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
    if matches!(outcome, Err(Cap(_) | Cycling(_))) && over_complete {
        let point_slack: Vec<f64> = (0..m).map(point_slack).collect();
        let surest = surest(&guess, z, &point_slack, block.dim());
        outcome = active_set::solve(
            block,
            start_at(surest, z, Some(1)),
            Options::capped(long_cap(m)),
        );
    }
    // The try skipped above is still worth its time where the answer is unfinished: on a
    // sliver, one row at a time can leave an answer unfinished that every row at once
    // finishes (measured: `docs/lab/2026-11-29-clarabel-polish-over-complete-guess.md`). Kept
    // only if finished: two unfinished answers are both off by about the tolerance of the
    // rung that stood, which does not say which is nearer.
    if over_complete && outcome.as_ref().is_ok_and(|o| o.unfinished.is_some()) {
        if let Ok(first) = active_set::solve(block, start_at(guess, z, None), Options::capped(cap))
        {
            if first.unfinished.is_none() {
                outcome = Ok(first);
            }
        }
    }
    outcome
}

/// The projection finished from the interior-point answer `x` with multipliers `z` and slacks
/// `s`, block by block, as `(x, λ)`, each by [`polish_block`]'s tries. A block where none
/// converges, or whose rows it certifies empty, keeps the interior-point `x` and `z`. `None`
/// when no block was polished.
pub(crate) fn polish(
    problem: &ProjectionProblem,
    x: &[f64],
    z: &[f64],
    s: &[f64],
) -> Option<Polished> {
    let (m, n) = (problem.n_rows(), problem.dim());
    if z.len() != m || s.len() != m || x.len() != n {
        return None;
    }
    let blocks = Blocks::split(problem);
    // Unknowns in no block are not constrained: x = y exactly.
    let mut px = problem.y().to_vec();
    let mut pl = vec![0.0; m];
    let mut polished = false;
    let mut unfinished = (0u32, 0.0f64);
    for block in blocks.blocks() {
        let rows = &block.rows;
        let z_block: Vec<f64> = rows.iter().map(|&i| z[i]).collect();
        let s_block: Vec<f64> = rows.iter().map(|&i| s[i]).collect();
        // Only the fourth try reads the point's own slacks: computed then, not for every block.
        let point_slack = |t: usize| {
            let i = rows[t];
            problem.a().row(i).map(|(c, v)| v * x[c]).sum::<f64>() - problem.b()[i]
        };
        let outcome = polish_block(&block.problem, &z_block, &s_block, point_slack);
        match outcome {
            Ok(outcome) => {
                polished = true;
                if let Some(off) = outcome.unfinished {
                    unfinished = (unfinished.0.saturating_add(1), unfinished.1.max(off));
                }
                block
                    .cols
                    .iter()
                    .zip(&outcome.x)
                    .for_each(|(&c, v)| px[c] = *v);
                rows.iter()
                    .zip(&outcome.lambda)
                    .for_each(|(&i, l)| pl[i] = *l);
            }
            // The iterate stands, unfinished: its statistics say so, as for an answer the
            // second pass could not finish.
            Err(_) => {
                block.cols.iter().for_each(|&c| px[c] = x[c]);
                rows.iter().for_each(|&i| pl[i] = z[i]);
                // Slacks of the point itself: an interior point's cone slacks `s` are never
                // negative, its rows may be violated.
                let off = iterate_off(rows.iter().map(|&i| {
                    let ax: f64 = problem.a().row(i).map(|(c, v)| v * x[c]).sum();
                    (z[i], ax - problem.b()[i])
                }));
                unfinished = (unfinished.0.saturating_add(1), unfinished.1.max(off));
            }
        }
    }
    polished.then_some(Polished {
        x: px,
        lambda: pl,
        unfinished,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::{Projector, SparseRows};

    /// `blocks` chains of six unknowns at `y = 0`, each with rows `x_{j+1} − x_j ≥ 1` and
    /// weaker copies `x_{j+1} − x_j ≥ 0.9`; the interior-point guess holds the copies
    /// (`z > s`) and not the real rows. From it the method solves on the copies, the real rows
    /// join, and the copies leave one per iteration (parallel rows with different right-hand
    /// sides are inconsistent): seven iterations a chain. Returns the problem and
    /// `(z, s)`.
    fn chains_with_decoys(blocks: usize) -> (ProjectionProblem, Vec<f64>, Vec<f64>) {
        chains_of(blocks, 6)
    }

    /// As [`chains_with_decoys`], chains of `len` unknowns.
    fn chains_of(blocks: usize, len: usize) -> (ProjectionProblem, Vec<f64>, Vec<f64>) {
        let mut a = SparseRows::new(len * blocks);
        let (mut b, mut z, mut s) = (Vec::new(), Vec::new(), Vec::new());
        for block in 0..blocks {
            // Blocks differ in their guesses, so that their rows do not leave in step.
            let weight = 1.0 + 0.37 * block as f64;
            for (bound, guess) in [(1.0, (0.0, 1.0)), (0.9, (weight, 0.0))] {
                for j in 0..len - 1 {
                    let c = len * block + j;
                    a.push_row([(c, -1.0), (c + 1, 1.0)]);
                    b.push(bound);
                    z.push(guess.0 * (1.0 + 0.1 * j as f64));
                    s.push(guess.1);
                }
            }
        }
        let problem = ProjectionProblem::new(vec![0.0; len * blocks], a, b).unwrap();
        (problem, z, s)
    }

    /// A problem and the interior-point answer Clarabel gave on it, from a run, as JSON:
    /// `(problem, x, z, s)`, the slacks those of `x` itself.
    fn interior_point_guess(json: &str) -> (ProjectionProblem, Vec<f64>, Vec<f64>, Vec<f64>) {
        #[derive(serde::Deserialize)]
        struct Data {
            problem: ProjectionProblem,
            interior_point_x: Vec<f64>,
            interior_point_z: Vec<f64>,
        }
        let data: Data = serde_json::from_str(json).unwrap();
        let s = data.problem.shortfall(&data.interior_point_x);
        let s = s.iter().map(|r| -r).collect();
        (
            data.problem,
            data.interior_point_x,
            data.interior_point_z,
            s,
        )
    }

    #[test]
    fn each_block_is_polished_under_its_own_cap() {
        let (problem, z, s) = chains_with_decoys(20);
        // On the whole problem the chains' leaving rows queue behind each other (a chain
        // alone needs 7 iterations, the 20 together 59): a single cap of 40 runs out.
        let support: Vec<usize> = (0..z.len()).filter(|&i| z[i] > s[i]).collect();
        assert!(matches!(
            active_set::solve(
                &problem,
                start_at(support, &z, None),
                Options::capped(ITERATIONS)
            ),
            Err(active_set::Failure::Cap(_))
        ));
        // Block by block, every chain is finished: x_j = j − 2.5, the copies inactive.
        let x_guess = vec![0.0; problem.dim()];
        let Polished { x, lambda, .. } =
            polish(&problem, &x_guess, &z, &s).expect("every block polished");
        for (c, v) in x.iter().enumerate() {
            let exact = (c % 6) as f64 - 2.5;
            assert!((v - exact).abs() < 1e-12, "x[{c}] = {v}, exact {exact}");
        }
        assert!(problem.kkt_residuals(&x, &lambda).max() < 1e-12);
        for (i, l) in lambda.iter().enumerate() {
            let copy = (i / 5) % 2 == 1;
            assert_eq!(copy, *l == 0.0, "row {i} (copy: {copy}) has multiplier {l}");
        }
    }

    /// One chain of `len` unknowns at `y = 0` with rows `x_{j+1} − x_j ≥ 1`, copies `≥ 0.9`,
    /// and rows `≥ 1.05` outside the guess (`z = 0 < s`), which the point violates once the
    /// copies have left and which join then. The guess holds the first rows and the first
    /// `copies` copies: `len − 1 + copies` rows on `len` unknowns.
    fn chain_with_late_rows(len: usize, copies: usize) -> (ProjectionProblem, Vec<f64>, Vec<f64>) {
        let mut a = SparseRows::new(len);
        let (mut b, mut z, mut s) = (Vec::new(), Vec::new(), Vec::new());
        for (bound, guessed) in [(1.0, len), (0.9, copies), (1.05, 0)] {
            for j in 0..len - 1 {
                a.push_row([(j, -1.0), (j + 1, 1.0)]);
                b.push(bound);
                let guess = j < guessed;
                z.push(if guess { 1.0 + 0.1 * j as f64 } else { 0.0 });
                s.push(if guess { 0.0 } else { 1.0 });
            }
        }
        (ProjectionProblem::new(vec![0.0; len], a, b).unwrap(), z, s)
    }

    #[test]
    fn a_guess_with_more_rows_than_unknowns_starts_with_rows_joining_one_at_a_time() {
        let no_slack = |_: usize| 0.0;
        // Fewer guessed rows than unknowns, as many, more.
        for copies in [0, 1, 7] {
            let (problem, z, s) = chain_with_late_rows(8, copies);
            let m = problem.n_rows();
            let guess: Vec<usize> = (0..m).filter(|&t| z[t] > s[t]).collect();
            assert_eq!(guess.len(), 7 + copies);
            let tries = [None, Some(1)].map(|join_at_most| {
                active_set::solve(
                    &problem,
                    start_at(guess.clone(), &z, join_at_most),
                    Options::capped(short_cap(m)),
                )
                .unwrap()
            });
            // The tries differ: the late rows join together in one, one at a time in the other.
            assert_ne!(tries[0].iterations, tries[1].iterations);
            let polished = polish_block(&problem, &z, &s, no_slack).unwrap();
            // More rows than unknowns: the first try is skipped; otherwise it is the answer.
            let expected = &tries[usize::from(guess.len() > problem.dim())];
            assert_eq!(polished.iterations, expected.iterations, "{copies} copies");
            assert_eq!(polished.x, expected.x);
            for (c, v) in polished.x.iter().enumerate() {
                assert!(
                    (v - (1.05 * c as f64 - 3.675)).abs() < 1e-12,
                    "x[{c}] = {v}"
                );
            }
        }
    }

    #[test]
    fn an_unfinished_answer_from_a_guess_with_more_rows_than_unknowns_gets_the_first_try_too() {
        // The hall's late sliver block of `tests/sliver_blocks.rs` (`hall_late`, 4000 rows on
        // 3000 unknowns): one row at a time from Clarabel's guess leaves an answer unfinished;
        // every row at once finishes it, and that answer is kept.
        #[derive(serde::Deserialize)]
        struct Block {
            problem: ProjectionProblem,
        }
        let block: Block = serde_json::from_str(&sweeping_testkit::fixtures::text(
            "hall_late_sliver_qp.json",
        ))
        .unwrap();
        let answer = crate::ClarabelProjector::default()
            .project(&block.problem)
            .unwrap();
        assert_eq!(answer.stats.counters.reduced, 0, "{:?}", answer.stats);
    }

    #[test]
    fn a_block_gets_more_iterations_than_the_fixed_forty_when_it_has_the_rows_for_it() {
        // One chain of 61 unknowns: its 60 copies leave one at a time, more than 41
        // iterations, fewer than 40 + 120/2.
        let (problem, z, s) = chains_of(1, 61);
        let x_guess = vec![0.0; problem.dim()];
        let Polished { x, .. } = polish(&problem, &x_guess, &z, &s).expect("the chain is polished");
        assert!((x[0] + 30.0).abs() < 1e-10 && (x[60] - 30.0).abs() < 1e-10);
        // The first try alone does it under its cap, not under 41 (the later tries, one row
        // at a time under longer caps, would finish it all the same).
        let guess: Vec<usize> = (0..z.len()).filter(|&i| z[i] > s[i]).collect();
        let m = problem.n_rows();
        assert_eq!(short_cap(m), 40 + 60);
        assert!(active_set::solve(
            &problem,
            start_at(guess.clone(), &z, None),
            Options::capped(short_cap(m))
        )
        .is_ok());
        assert!(matches!(
            active_set::solve(
                &problem,
                start_at(guess, &z, None),
                Options::capped(ITERATIONS + 1)
            ),
            Err(active_set::Failure::Cap(_))
        ));
    }

    #[test]
    fn a_block_that_is_not_polished_keeps_the_interior_point_answer() {
        // One chain polished, one whose guess is garbage: rows x₁ ≥ 1 and −x₁ ≥ 0 (empty).
        let (chain, z, s) = chains_with_decoys(1);
        let mut a = SparseRows::new(8);
        for r in 0..chain.n_rows() {
            a.push_row(chain.a().row(r));
        }
        a.push_row([(7, 1.0)]);
        a.push_row([(7, -1.0)]);
        let mut b = chain.b().to_vec();
        b.extend([1.0, 0.0]);
        let problem = ProjectionProblem::new(vec![0.0; 8], a, b).unwrap();
        let (mut z, mut s) = (z, s);
        z.extend([0.5, 0.5]);
        s.extend([0.0, 0.0]);
        let x_guess: Vec<f64> = (0..8).map(|c| 0.25 * c as f64).collect();
        let Polished { x, lambda, .. } =
            polish(&problem, &x_guess, &z, &s).expect("the chain is polished");
        assert!((x[0] + 2.5).abs() < 1e-12 && (x[5] - 2.5).abs() < 1e-12);
        // The empty block keeps the guess and its multipliers; unknown 6 is in no row: y.
        assert_eq!((x[6], x[7]), (0.0, x_guess[7]));
        assert_eq!(&lambda[10..], &[0.5, 0.5]);
        // And says so: one block unfinished, off by the guess's violation of −x₇ ≥ 0.
        let kept = polish(&problem, &x_guess, &z, &s).expect("the chain is polished");
        assert_eq!(kept.unfinished, (1, 1.75));
        // No block polished: nothing to offer.
        let empty = ProjectionProblem::new(
            vec![0.0],
            SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, -1.0)]]),
            vec![1.0, 0.0],
        )
        .unwrap();
        assert!(polish(&empty, &[0.5], &[0.5, 0.5], &[0.0, 0.0]).is_none());
    }

    #[test]
    fn a_jam_whose_rows_joining_together_run_out_is_polished_one_row_at_a_time() {
        // 400 rows of a jam of the 2000-person evacuation and the interior-point answer
        // Clarabel gave there (see `tests/jam_polish.rs`): joining every violated row at once
        // runs out of the block's cap of 240 iterations, and the polish must not stop there
        // with the iterate (every multiplier positive, the point off by ~√gap).
        let (problem, x, z, s) =
            interior_point_guess(&sweeping_testkit::fixtures::text("jam_polish_guess.json"));
        let Polished {
            x: px, lambda: pl, ..
        } = polish(&problem, &x, &z, &s).expect("the block is polished");
        assert!(problem.kkt_residuals(&px, &pl).max() <= 1e-12);
        // By the second try, under the block's cap of 40 + 400/2: the rows with z > s, one
        // violated row joining at a time.
        let support: Vec<usize> = (0..z.len()).filter(|&i| z[i] > s[i]).collect();
        let one_at_a_time = Start {
            lambda: support.iter().map(|&i| z[i]).collect(),
            support,
            join: z.clone(),
            join_at_most: Some(1),
        };
        let second = active_set::solve(&problem, one_at_a_time, Options::capped(240)).unwrap();
        assert_eq!(px, second.x);
        // Polished, not the iterate: rows left the support with a zero multiplier.
        assert!(pl.iter().filter(|l| **l == 0.0).count() > 30);
        assert!(z.iter().all(|l| *l > 0.0));
    }

    #[test]
    fn a_block_whose_first_two_tries_run_out_is_polished_under_the_long_cap() {
        // A block of 1004 rows on 694 unknowns of the 2000-person evacuation at h = 0.05
        // (t = 44.6 s) and the interior-point answer Clarabel gave there (the case:
        // `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`): both tries under
        // 40 + 1004/2 iterations run out.
        let (problem, x, z, s) = interior_point_guess(&sweeping_testkit::fixtures::text(
            "evacuation_h005_polish_guess.json",
        ));
        let m = problem.n_rows();
        let support: Vec<usize> = (0..m).filter(|&i| z[i] > s[i]).collect();
        for join_at_most in [None, Some(1)] {
            assert!(matches!(
                active_set::solve(
                    &problem,
                    start_at(support.clone(), &z, join_at_most),
                    Options::capped(short_cap(m))
                ),
                Err(active_set::Failure::Cap(_))
            ));
        }
        let Polished {
            x: px,
            lambda: pl,
            unfinished,
        } = polish(&problem, &x, &z, &s).expect("the block is polished");
        // The iterate violates rows by 1.8e-11; the polished answer is finished.
        assert!(problem.kkt_residuals(&x, &z).max() > 1e-11);
        assert!(problem.kkt_residuals(&px, &pl).max() <= 1e-13);
        assert_eq!(unfinished, (0, 0.0));
        assert!(pl.iter().filter(|l| **l == 0.0).count() > 300);
        assert_eq!(long_cap(m), 40 + 2008);
    }

    #[test]
    fn a_guess_holding_more_rows_than_unknowns_is_polished_from_its_surest_rows() {
        // Clarabel's interior-point answer on a door queue of the hall at t = 14.8 s
        // (`hall_t14_polish_guess.json`), a block of 3743 rows on 2804 unknowns: 3373 rows have
        // z > s, and the three tries from them run out, so only the fourth moves the iterate
        // (the case: `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
        let (problem, x, z, s) = interior_point_guess(&sweeping_testkit::fixtures::text(
            "hall_t14_polish_guess.json",
        ));
        let (m, n) = (problem.n_rows(), problem.dim());
        let guess: Vec<usize> = (0..m).filter(|&i| z[i] > s[i]).collect();
        assert_eq!((m, n, guess.len()), (3743, 2804, 3373));
        // (Asserting here that the first three tries run out would double the test's time:
        // without the fourth the iterate stands, which the assertions below refuse.)
        let Polished {
            x: px,
            lambda: pl,
            unfinished,
        } = polish(&problem, &x, &z, &s).expect("the block is polished");
        // The polished answer is finished but for its last rounding, and it is not the
        // iterate, which lies 5.2e-7 from it (the projection's support has a smallest singular
        // value of about 5.7e-5: rows off by 6.5e-9 at the iterate put it that far).
        assert!(problem.kkt_residuals(&px, &pl).max() <= 1e-13);
        let moved = px
            .iter()
            .zip(&x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(moved > 5e-7, "{moved:.3e}");
        assert!(unfinished.0 <= 1 && unfinished.1 <= 1e-14, "{unfinished:?}");
        // The surest rows: every row the iterate violates, then by z/s, and no more than the
        // unknowns.
        let surest = surest(&guess, &z, &s, n);
        assert_eq!(surest.len(), n);
        assert!(guess
            .iter()
            .filter(|&&i| s[i] <= 0.0)
            .all(|i| surest.binary_search(i).is_ok()));
    }

    #[test]
    fn the_surest_rows_are_the_violated_then_the_largest_multiplier_over_slack() {
        // Rows 0–4: (z, s) = violated, tight, 1e3, 10, 1e3 (a tie with row 2).
        let z = [1.0, 0.5, 1.0, 1.0, 2.0];
        let s = [-1e-12, 0.0, 1e-3, 0.1, 2e-3];
        let guess = [0, 1, 2, 3, 4];
        assert_eq!(surest(&guess, &z, &s, 2), vec![0, 1]);
        assert_eq!(surest(&guess, &z, &s, 3), vec![0, 1, 2]);
        assert_eq!(surest(&guess, &z, &s, 4), vec![0, 1, 2, 4]);
        assert_eq!(surest(&guess, &z, &s, 9), vec![0, 1, 2, 3, 4]);
        assert_eq!(surest(&guess[3..], &z, &s, 1), vec![4]);
    }

    #[test]
    fn an_iterate_is_off_by_its_largest_violation_or_slack_of_a_row_it_holds_tight() {
        // (multiplier, slack): a violated row, a row the polish would not hold (its
        // multiplier below its slack), a row it would, whose slack counts.
        let rows = [(1.0, -2e-11), (1e-13, 0.29), (0.5, 3e-12)];
        assert_eq!(iterate_off(rows.into_iter()), 2e-11);
        assert_eq!(iterate_off(rows[1..].iter().copied()), 3e-12);
        assert_eq!(iterate_off(rows[1..2].iter().copied()), 0.0);
        assert_eq!(iterate_off([(0.5, 0.5)].into_iter()), 0.0);
    }

    #[test]
    fn answers_of_the_wrong_dimensions_are_not_polished() {
        let (problem, z, s) = chains_with_decoys(1);
        let x = vec![0.0; problem.dim()];
        assert!(polish(&problem, &x, &z, &s).is_some());
        assert!(polish(&problem, &x, &z[1..], &s).is_none());
        assert!(polish(&problem, &x, &z, &s[1..]).is_none());
        assert!(polish(&problem, &x[1..], &z, &s).is_none());
    }
}
