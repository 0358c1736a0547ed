//! Independent blocks of a projection.
//!
//! The projection `min ½‖x − y‖² s.t. A x ≥ b` separates: an unknown touched by no row keeps
//! `xⱼ = yⱼ`, and two groups of rows that share no unknown can be projected separately (the
//! cost is a sum over coordinates and each row only constrains its own). On a crowd most
//! people touch nobody and contacts form small clusters, so a step splits into many tiny
//! problems, each far cheaper to factor than the whole. [`Blocks::split`] finds the connected
//! components of the graph "rows sharing an unknown", [`Blocks::stitch`] puts the answers
//! back together, and [`Blocked`] wraps any [`Projector`] so that it only ever sees blocks.

use crate::{
    Metric, Projection, ProjectionError, ProjectionProblem, Projector, SolveStats, SolveStatus,
    SparseRows,
};

/// One independent sub-problem: the rows of a connected component and the unknowns they touch.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// Indices, in the whole problem, of this block's rows (increasing).
    pub rows: Vec<usize>,
    /// Indices, in the whole problem, of this block's unknowns (increasing).
    pub cols: Vec<usize>,
    /// The sub-problem in local numbering: row `t` is row `rows[t]` of the whole problem,
    /// unknown `j` is unknown `cols[j]`; it carries the rows' keys when the whole problem does.
    pub problem: ProjectionProblem,
}

/// A projection problem split into independent [`Block`]s.
///
/// The projection separates: an unknown touched by no row keeps `xⱼ = yⱼ`, and two groups of
/// rows that share no unknown can be projected separately (the cost is a sum over coordinates
/// and each row only constrains its own). On a crowd most people touch nobody and contacts
/// form small clusters, so a step splits into many small problems, each far cheaper to factor
/// than the whole. [`Blocks::split`] finds the connected components of the graph "rows sharing
/// an unknown", [`Blocks::stitch`] puts the answers back together, and [`Blocked`] wraps any
/// [`Projector`] so that it only ever sees blocks.
///
/// ```
/// use sweeping_api::{Blocks, ProjectionProblem, SparseRows};
/// // Rows 0 and 2 share unknown 1; row 1 touches only unknown 3; unknown 2 is free.
/// let a = SparseRows::from_rows(4, &[
///     vec![(0, 1.0), (1, 1.0)], vec![(3, 1.0)], vec![(1, -1.0)],
/// ]);
/// let p = ProjectionProblem::new(vec![0.0; 4], a, vec![1.0, 2.0, -5.0]).unwrap();
/// let blocks = Blocks::split(&p);
/// assert_eq!(blocks.blocks().len(), 2);
/// assert_eq!(blocks.blocks()[0].rows, vec![0, 2]);
/// assert_eq!(blocks.blocks()[0].cols, vec![0, 1]);
/// assert_eq!(blocks.blocks()[1].cols, vec![3]);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Blocks {
    blocks: Vec<Block>,
    empty_rows: Vec<usize>,
}

/// Whether `y` violates row `r` (`aᵣ·y ≥ bᵣ` fails, `=` on an equality row); a NaN counts as
/// violated, so that its block is built and its solver reports it.
fn violated_at_y(problem: &ProjectionProblem, r: usize) -> bool {
    let ay: f64 = problem.a().row(r).map(|(c, v)| v * problem.y()[c]).sum();
    ay.partial_cmp(&problem.b()[r])
        .is_none_or(|o| o.is_lt() || (r < problem.equalities() && o.is_gt()))
}

/// Union–find root with path halving.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

impl Blocks {
    /// Splits `problem` into the connected components of its rows. Stored zeros do not
    /// connect anything and are dropped from the sub-problems; a row without a non-zero entry
    /// belongs to no block (see [`Blocks::empty_rows`]).
    pub fn split(problem: &ProjectionProblem) -> Self {
        Self::split_keeping(problem, |_| true, |_| true)
    }

    /// [`Blocks::split`] without the components in which `y` satisfies every row (`aᵢ·y ≥
    /// bᵢ`): there `x = y`, `λ = 0` is the exact projection, which [`Blocks::stitch`] gives any
    /// row and unknown outside every block. On a spread crowd nearly every block is such a
    /// pair of people near each other but apart, and building their sub-problems cost more
    /// than the rest of the projection.
    ///
    /// ```
    /// use sweeping_api::{Blocks, ProjectionProblem, SparseRows};
    /// // Row 0 holds at y = 0 (0 ≥ −1), row 1 does not (0 ≥ 1): only row 1's block is built.
    /// let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    /// let p = ProjectionProblem::new(vec![0.0; 2], a, vec![-1.0, 1.0]).unwrap();
    /// let blocks = Blocks::split_violated(&p);
    /// assert_eq!(blocks.blocks().len(), 1);
    /// assert_eq!(blocks.blocks()[0].rows, vec![1]);
    /// ```
    pub fn split_violated(problem: &ProjectionProblem) -> Self {
        Self::split_keeping(problem, |_| true, |r| violated_at_y(problem, r))
    }

    /// [`Blocks::split_violated`] of the rows `among` marks alone: the components of the graph
    /// of those rows that hold a row `y` violates. Rows left unmarked belong to no block (their
    /// multiplier is `0` in [`Blocks::stitch`]), so the answer stitched from these blocks is the
    /// projection onto the marked rows' set; it is the whole problem's when it satisfies the
    /// unmarked rows too. A jam's candidate pairs connect everybody into one block, while the
    /// rows that can be active form thousands of small clusters.
    ///
    /// ```
    /// use sweeping_api::{Blocks, ProjectionProblem, SparseRows};
    /// // Row 1 joins rows 0 and 2 through unknowns 1 and 2; left out, they are two blocks.
    /// let a = SparseRows::from_rows(4, &[
    ///     vec![(0, 1.0), (1, 1.0)], vec![(1, 1.0), (2, 1.0)], vec![(2, 1.0), (3, 1.0)],
    /// ]);
    /// let p = ProjectionProblem::new(vec![0.0; 4], a, vec![1.0, -9.0, 1.0]).unwrap();
    /// assert_eq!(Blocks::split_violated(&p).blocks().len(), 1);
    /// let blocks = Blocks::split_among(&p, &[true, false, true]);
    /// assert_eq!(blocks.blocks().len(), 2);
    /// assert_eq!(blocks.blocks()[1].rows, vec![2]);
    /// ```
    ///
    /// # Panics
    /// When `among` does not hold one flag per row.
    pub fn split_among(problem: &ProjectionProblem, among: &[bool]) -> Self {
        assert_eq!(among.len(), problem.n_rows(), "one flag per row");
        Self::split_keeping(problem, |r| among[r], |r| violated_at_y(problem, r))
    }

    /// [`Blocks::split_violated`], or, when `among` (given the rows of each block that would
    /// build, in order) marks rows, [`Blocks::split_among`] those rows: a caller that screens
    /// a block's rows by what the whole block holds finds its blocks without splitting the
    /// problem twice when it leaves nothing out.
    ///
    /// ```
    /// use sweeping_api::{Blocks, ProjectionProblem, SparseRows};
    /// let a = SparseRows::from_rows(3, &[vec![(0, 1.0), (1, 1.0)], vec![(1, 1.0), (2, 1.0)]]);
    /// let p = ProjectionProblem::new(vec![0.0; 3], a, vec![1.0, -1.0]).unwrap();
    /// let whole = Blocks::split_violated_or_among(&p, |rows| {
    ///     assert_eq!(rows, &[vec![0, 1]]);
    ///     None
    /// });
    /// assert_eq!(whole.blocks()[0].rows, vec![0, 1]);
    /// let screened = Blocks::split_violated_or_among(&p, |_| Some(vec![true, false]));
    /// assert_eq!(screened.blocks()[0].rows, vec![0]);
    /// ```
    pub fn split_violated_or_among(
        problem: &ProjectionProblem,
        among: impl FnOnce(&[Vec<usize>]) -> Option<Vec<bool>>,
    ) -> Self {
        let components = Components::of(problem, |_| true, |r| violated_at_y(problem, r));
        match among(&components.rows_of) {
            Some(keep) => Self::split_among(problem, &keep),
            None => Self::built(problem, components),
        }
    }

    /// The components of the graph of the rows for which `joins` is true that hold at least
    /// one row for which `keep` is true; every empty row is listed in [`Blocks::empty_rows`].
    fn split_keeping(
        problem: &ProjectionProblem,
        joins: impl Fn(usize) -> bool,
        keep: impl Fn(usize) -> bool,
    ) -> Self {
        Self::built(problem, Components::of(problem, joins, keep))
    }

    /// The blocks of `components`, built.
    fn built(problem: &ProjectionProblem, components: Components) -> Self {
        let Components {
            rows_of,
            empty_rows,
            mut parent,
            block_of_root,
        } = components;
        let (a, n) = (problem.a(), problem.dim());
        // An unknown touched by no non-zero was never united with anything: it is its own
        // root, and no block has that root; nor has the root of a component left out.
        let mut cols_of: Vec<Vec<usize>> = vec![Vec::new(); rows_of.len()];
        let mut local = vec![usize::MAX; n];
        for c in 0..n {
            let blk = block_of_root[find(&mut parent, c)];
            if blk != usize::MAX {
                cols_of[blk].push(c);
            }
        }
        let keys = problem.row_keys();
        let blocks = rows_of
            .into_iter()
            .zip(cols_of)
            .map(|(rows, cols)| {
                for (j, &c) in cols.iter().enumerate() {
                    local[c] = j;
                }
                let entries = rows.iter().map(|&r| a.row_len(r)).sum();
                let mut sub = SparseRows::with_capacity(cols.len(), rows.len(), entries);
                for &r in &rows {
                    sub.push_row(
                        a.row(r)
                            .filter(|&(_, v)| v != 0.0)
                            .map(|(c, v)| (local[c], v)),
                    );
                }
                let y = cols.iter().map(|&c| problem.y()[c]).collect();
                let b = rows.iter().map(|&r| problem.b()[r]).collect();
                let sub_keys = keys.map(|k| rows.iter().map(|&r| k[r]).collect());
                // Rows are in increasing order, so the equalities stay leading.
                let equalities = rows.partition_point(|&r| r < problem.equalities());
                let metric = sub_metric(problem.metric(), &cols, &local);
                let problem = ProjectionProblem::from_parts_unchecked(y, sub, b, sub_keys)
                    .with_parts_unchecked(metric, equalities);
                Block {
                    rows,
                    cols,
                    problem,
                }
            })
            .collect();
        Self { blocks, empty_rows }
    }

    /// The blocks, in the order of their first row.
    pub fn blocks(&self) -> &[Block] {
        &self.blocks
    }

    /// Rows without a non-zero entry: `0 ≥ bᵢ` holds or fails whatever `x`; their multiplier
    /// is `0`.
    pub fn empty_rows(&self) -> &[usize] {
        &self.empty_rows
    }

    /// The first empty row with `bᵢ > 0` (`bᵢ ≠ 0` on an equality row), which makes the
    /// whole problem infeasible.
    pub fn infeasible_empty_row(&self, problem: &ProjectionProblem) -> Option<usize> {
        let k = problem.equalities();
        self.empty_rows
            .iter()
            .copied()
            .find(|&r| problem.b()[r] > 0.0 || (r < k && problem.b()[r] != 0.0))
    }

    /// The answer of the whole problem from one answer per block (in the order of
    /// [`Blocks::blocks`]): unknowns outside every block keep `y`, rows outside every block get
    /// multiplier `0`. Statistics are summed (iterations, seconds, counters, see
    /// [`crate::BackendCounters::add`]); the status is
    /// the weakest of the blocks', `warm_started` whether any block was.
    ///
    /// # Panics
    /// When the number of answers or their dimensions do not match the blocks.
    pub fn stitch(
        &self,
        problem: &ProjectionProblem,
        answers: Vec<Projection>,
        backend: &str,
    ) -> Projection {
        assert_eq!(answers.len(), self.blocks.len(), "one answer per block");
        let mut x = problem.y().to_vec();
        let mut multipliers = vec![0.0; problem.n_rows()];
        let mut stats = SolveStats::trivial(backend);
        for (block, answer) in self.blocks.iter().zip(answers) {
            assert_eq!(answer.x.len(), block.cols.len(), "block answer dimension");
            assert_eq!(
                answer.multipliers.len(),
                block.rows.len(),
                "block multipliers"
            );
            for (&c, v) in block.cols.iter().zip(&answer.x) {
                x[c] = *v;
            }
            for (&r, l) in block.rows.iter().zip(&answer.multipliers) {
                multipliers[r] = *l;
            }
            let s = answer.stats;
            stats.status = weaker(stats.status, s.status);
            stats.iterations = stats.iterations.saturating_add(s.iterations);
            stats.solve_seconds += s.solve_seconds;
            stats.setup_seconds += s.setup_seconds;
            stats.warm_started |= s.warm_started;
            stats.counters.add(&s.counters);
        }
        Projection {
            x,
            multipliers,
            stats,
        }
    }
}

/// The rows of a problem's blocks, before the blocks are built: the union–find of their
/// unknowns and each root's block.
struct Components {
    rows_of: Vec<Vec<usize>>,
    empty_rows: Vec<usize>,
    parent: Vec<usize>,
    block_of_root: Vec<usize>,
}

impl Components {
    /// See [`Blocks::split_keeping`].
    fn of(
        problem: &ProjectionProblem,
        joins: impl Fn(usize) -> bool,
        keep: impl Fn(usize) -> bool,
    ) -> Self {
        let a = problem.a();
        let (m, n) = (a.n_rows(), a.n_cols());
        let mut parent: Vec<usize> = (0..n).collect();
        // Union by size keeps the trees shallow: linking a row's first root under the next
        // one's, whatever their sizes, makes `find` a large part of this function's time
        // (measured: `docs/lab/2026-11-25-less-work-and-speculated-rescue.md`). The
        // components, and so the blocks, are the same either way.
        let mut size = vec![1u32; n];
        let mut unite = |parent: &mut [usize], p: usize, q: usize| {
            let (ra, rb) = (find(parent, p), find(parent, q));
            if ra != rb {
                let (small, large) = if size[ra] < size[rb] {
                    (ra, rb)
                } else {
                    (rb, ra)
                };
                parent[small] = large;
                size[large] += size[small];
            }
        };
        // A metric that couples two unknowns couples their rows' answers: moving one moves the
        // other, so they belong to one block (and an unknown coupled to a block is in it).
        if let Metric::Symmetric(w) = problem.metric() {
            for i in 0..n {
                for (j, v) in w.row(i) {
                    if v != 0.0 && j != i {
                        unite(&mut parent, i, j);
                    }
                }
            }
        }
        let mut first_col = vec![usize::MAX; m];
        for (r, first) in first_col.iter_mut().enumerate() {
            if !joins(r) {
                continue;
            }
            for (c, v) in a.row(r) {
                if v == 0.0 {
                    continue;
                }
                if *first == usize::MAX {
                    *first = c;
                } else {
                    unite(&mut parent, *first, c);
                }
            }
        }
        // The components to build: those holding a kept row.
        let mut wanted = vec![false; n];
        for (r, &c) in first_col.iter().enumerate() {
            if c != usize::MAX && keep(r) {
                wanted[find(&mut parent, c)] = true;
            }
        }
        // Blocks numbered in the order of their first row.
        let mut block_of_root = vec![usize::MAX; n];
        let mut rows_of: Vec<Vec<usize>> = Vec::new();
        let mut empty_rows = Vec::new();
        for (r, &c) in first_col.iter().enumerate() {
            if !joins(r) {
                if a.row(r).all(|(_, v)| v == 0.0) {
                    empty_rows.push(r);
                }
                continue;
            }
            if c == usize::MAX {
                empty_rows.push(r);
                continue;
            }
            let root = find(&mut parent, c);
            if !wanted[root] {
                continue;
            }
            if block_of_root[root] == usize::MAX {
                block_of_root[root] = rows_of.len();
                rows_of.push(Vec::new());
            }
            rows_of[block_of_root[root]].push(r);
        }
        Self {
            rows_of,
            empty_rows,
            parent,
            block_of_root,
        }
    }
}

/// The metric of the unknowns `cols` (`local[c]` numbering unknown `c` among them): a
/// principal sub-matrix, exact for a block because no entry couples it to another.
fn sub_metric(metric: &Metric, cols: &[usize], local: &[usize]) -> Metric {
    match metric {
        Metric::Identity => Metric::Identity,
        Metric::Diagonal(w) => Metric::Diagonal(cols.iter().map(|&c| w[c]).collect()),
        Metric::Symmetric(w) => {
            let mut sub = SparseRows::new(cols.len());
            for &c in cols {
                sub.push_row(w.row(c).map(|(j, v)| (local[j], v)));
            }
            Metric::Symmetric(sub)
        }
    }
}

/// The status of a whole made of parts with statuses `a` and `b`.
fn weaker(a: SolveStatus, b: SolveStatus) -> SolveStatus {
    use SolveStatus::*;
    match (a, b) {
        (SolvedReducedAccuracy, _) | (_, SolvedReducedAccuracy) => SolvedReducedAccuracy,
        (Solved, _) | (_, Solved) => Solved,
        _ => Trivial,
    }
}

/// Any [`Projector`] run block by block (see [`Blocks`]): unknowns touched by no row never
/// reach it, nor do blocks whose rows `y` satisfies (see [`Blocks::split_violated`]), and each
/// other connected component of the rows is a separate call. Reports the inner backend's name
/// and tolerance.
///
/// ```
/// use sweeping_api::{conformance::ReferenceProjector, Blocked, ProjectionProblem, Projector,
///                    SparseRows};
/// let mut blocked = Blocked::new(ReferenceProjector::default());
/// let a = SparseRows::from_rows(3, &[vec![(0, 1.0)], vec![(2, 1.0)]]);
/// let p = ProjectionProblem::new(vec![-1.0, 5.0, -2.0], a, vec![0.0, 0.0]).unwrap();
/// let sol = blocked.project(&p).unwrap();
/// assert!(sol.x[0].abs() < 1e-9 && sol.x[1] == 5.0 && sol.x[2].abs() < 1e-9);
/// ```
#[derive(Debug, Clone)]
pub struct Blocked<P> {
    inner: P,
}

impl<P: Projector> Blocked<P> {
    /// Wraps `inner`.
    pub fn new(inner: P) -> Self {
        Self { inner }
    }

    /// The wrapped backend.
    pub fn inner(&self) -> &P {
        &self.inner
    }
}

impl<P: Projector> Projector for Blocked<P> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn tolerance(&self) -> f64 {
        self.inner.tolerance()
    }

    fn cross_check(&self) -> Option<&crate::CrossCheckStats> {
        self.inner.cross_check()
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let blocks = Blocks::split_violated(problem);
        if let Some(r) = blocks.infeasible_empty_row(problem) {
            return Err(ProjectionError::Infeasible {
                backend: self.inner.name().to_string(),
                detail: format!(
                    "row {r} has no non-zero entry and b[{r}] = {} > 0",
                    problem.b()[r]
                ),
                rows: vec![r],
            });
        }
        let answers = blocks
            .blocks()
            .iter()
            .map(|b| {
                self.inner
                    .project(&b.problem)
                    .map_err(|e| e.in_rows_of(&b.rows))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(blocks.stitch(problem, answers, self.inner.name()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conformance::testing::{capped_reference, CAPPED_REFERENCE_TOLERANCES};
    use crate::conformance::{max_gap, random_instance, ReferenceProjector};
    use crate::RowKey;

    crate::conformance_tests!(
        Blocked::new(capped_reference()),
        CAPPED_REFERENCE_TOLERANCES
    );

    /// Two copies of a random instance side by side, with free unknowns in between.
    fn two_copies(seed: u64) -> ProjectionProblem {
        let p = random_instance(seed, 10, 12);
        let n = p.dim();
        let mut a = SparseRows::new(2 * n + 3);
        let mut b = Vec::new();
        for shift in [0, n + 3] {
            for r in 0..p.n_rows() {
                a.push_row(p.a().row(r).map(|(c, v)| (c + shift, v)));
                b.push(p.b()[r]);
            }
        }
        let mut y = p.y().to_vec();
        y.extend([7.0, -8.0, 9.0]);
        y.extend(p.y().iter().map(|v| v + 0.25));
        let keys = (0..b.len() as u64)
            .map(|m| RowKey {
                family: 1,
                member: 100 + m,
            })
            .collect();
        ProjectionProblem::new(y, a, b)
            .unwrap()
            .with_row_keys(keys)
            .unwrap()
    }

    #[test]
    fn split_answers_match_the_whole_and_free_unknowns_stay() {
        for seed in 0..10 {
            let p = two_copies(seed);
            let blocks = Blocks::split(&p);
            assert!(
                blocks.blocks().len() >= 2,
                "seed {seed}: two copies at least"
            );
            // Every row in exactly one block; keys follow their rows.
            let mut seen = vec![0; p.n_rows()];
            for b in blocks.blocks() {
                for (t, &r) in b.rows.iter().enumerate() {
                    seen[r] += 1;
                    assert_eq!(b.problem.row_keys().unwrap()[t], p.row_keys().unwrap()[r]);
                }
            }
            for r in blocks.empty_rows() {
                seen[*r] += 1;
            }
            assert!(seen.iter().all(|&s| s == 1));
            let mut whole = ReferenceProjector::default();
            let mut split = Blocked::new(ReferenceProjector::default());
            let (Ok(s1), Ok(s2)) = (whole.project(&p), split.project(&p)) else {
                continue;
            };
            let gap = max_gap(&s1.x, &s2.x);
            assert!(gap <= 1e-8, "seed {seed}: gap {gap:.3e}");
            assert!(p.kkt_residuals(&s2.x, &s2.multipliers).max() <= 1e-9);
            let n = 10;
            assert_eq!(&s2.x[n..n + 3], &[7.0, -8.0, 9.0], "free unknowns keep y");
        }
    }

    #[test]
    fn stitched_statistics_sum_the_blocks_counts_and_keep_the_largest_reduced_by() {
        let p = two_copies(3);
        let blocks = Blocks::split(&p);
        let answers: Vec<Projection> = blocks
            .blocks()
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let mut answer = Projection::identity(&b.problem, "b");
                let k = u32::try_from(i).unwrap();
                answer.stats.iterations = 10 + k;
                answer.stats.counters.fallbacks = u64::from(k);
                answer.stats.counters.escalations = 2 * u64::from(k);
                answer.stats.counters.reduced = u64::from(k) + 1;
                answer.stats.counters.reduced_by = [3e-13, 5e-13, 4e-13][i % 3];
                answer
            })
            .collect();
        let count = u32::try_from(answers.len()).unwrap();
        assert!(count >= 2);
        let stats = blocks.stitch(&p, answers, "whole").stats;
        let triangle = count * (count - 1) / 2;
        assert_eq!(stats.backend, "whole");
        assert_eq!(stats.iterations, 10 * count + triangle);
        assert_eq!(stats.counters.fallbacks, u64::from(triangle));
        assert_eq!(stats.counters.escalations, 2 * u64::from(triangle));
        assert_eq!(stats.counters.reduced, u64::from(triangle + count));
        assert_eq!(stats.counters.reduced_by, 5e-13);
    }

    #[test]
    fn split_violated_keeps_exactly_the_blocks_with_a_row_violated_at_y() {
        for seed in 0..10 {
            let mut p = two_copies(seed);
            // The second copy's rows hold at y: b lowered below a·y.
            let n = p.dim();
            let mut ay = vec![0.0; p.n_rows()];
            p.a().mul_vec(p.y(), &mut ay);
            let half = p.n_rows() / 2;
            let b: Vec<f64> = (0..p.n_rows())
                .map(|r| if r < half { p.b()[r] } else { ay[r] - 1.0 })
                .collect();
            p = ProjectionProblem::new(p.y().to_vec(), p.a().clone(), b)
                .unwrap()
                .with_row_keys(p.row_keys().unwrap().to_vec())
                .unwrap();
            let all = Blocks::split(&p);
            let violated = Blocks::split_violated(&p);
            let expected: Vec<&Block> = all
                .blocks()
                .iter()
                .filter(|blk| blk.rows.iter().any(|&r| ay[r] < p.b()[r]))
                .collect();
            assert_eq!(violated.blocks().len(), expected.len(), "seed {seed}");
            for (got, want) in violated.blocks().iter().zip(expected) {
                assert_eq!(got, want, "seed {seed}");
            }
            assert!(violated.blocks().iter().all(|blk| blk.cols[0] < n / 2));
            assert_eq!(violated.empty_rows(), all.empty_rows());
            // Stitched, the left-out blocks are x = y, λ = 0, and the whole passes KKT.
            let Ok(sol) = Blocked::new(ReferenceProjector::default()).project(&p) else {
                continue;
            };
            assert_eq!(&sol.x[n / 2..], &p.y()[n / 2..]);
            assert!(sol.multipliers[half..].iter().all(|&l| l == 0.0));
            assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() <= 1e-9);
        }
    }

    #[test]
    fn a_row_with_a_nan_keeps_its_block() {
        let a = SparseRows::from_rows(2, &[vec![(0, f64::NAN)], vec![(1, 1.0)]]);
        let p = ProjectionProblem::from_parts_unchecked(vec![0.0; 2], a, vec![-1.0, -1.0], None);
        let blocks = Blocks::split_violated(&p);
        assert_eq!(blocks.blocks().len(), 1);
        assert_eq!(blocks.blocks()[0].rows, vec![0]);
    }

    #[test]
    fn zero_entries_do_not_connect_and_empty_rows_are_checked() {
        let a = SparseRows::from_rows(
            3,
            &[vec![(0, 1.0), (1, 0.0)], vec![(1, 1.0)], vec![(2, 0.0)]],
        );
        let p = ProjectionProblem::new(vec![0.0; 3], a.clone(), vec![1.0, 1.0, 0.0]).unwrap();
        let blocks = Blocks::split(&p);
        assert_eq!(blocks.blocks().len(), 2);
        assert_eq!(blocks.blocks()[0].cols, vec![0]);
        assert_eq!(blocks.blocks()[1].cols, vec![1]);
        assert_eq!(blocks.empty_rows(), &[2]);
        assert_eq!(blocks.infeasible_empty_row(&p), None);
        let sol = Blocked::new(ReferenceProjector::default())
            .project(&p)
            .unwrap();
        assert!((sol.x[0] - 1.0).abs() < 1e-9 && (sol.x[1] - 1.0).abs() < 1e-9);
        assert_eq!(sol.x[2], 0.0);
        assert_eq!(sol.multipliers[2], 0.0);

        let bad = ProjectionProblem::new(vec![0.0; 3], a, vec![1.0, 1.0, 0.5]).unwrap();
        match Blocked::new(ReferenceProjector::default()).project(&bad) {
            Err(ProjectionError::Infeasible { detail, .. }) => {
                assert!(detail.contains("row 2"), "{detail}")
            }
            other => panic!("expected Infeasible, got {other:?}"),
        }
    }
}
