//! Orderings: the fill-reducing orderings of recent sparse factorizations, remembered node
//! by node so that the next factorization of a similar support skips AMD.

use sweeping_api::{FastMap, RowKey};

/// What a node of `K_δ` stands for, across factorizations and steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Node {
    /// An unknown, by its index in the whole problem.
    Unknown(usize),
    /// A row, by its key.
    Row(RowKey),
}

/// A sparse factorization reuses the ordering it finds in [`Orderings`] when at least this
/// fraction of its nodes is remembered there; below it, AMD orders it afresh.
const REMEMBERED_FRACTION: f64 = 0.5;
/// [`Orderings::ordering`] places remembered nodes in a table by rank when their ranks span at
/// most this many times the nodes, and sorts them otherwise.
const SPAN_PER_NODE: u64 = 8;

/// A remembered ordering predicted to fill more than this many times the last AMD ordering
/// (`nnz(L)/nnz(K)`) is not used, and one that does makes the next sparse factorization run
/// AMD again.
pub(super) const STALE_FILL: f64 = 1.25;

/// The fill-reducing orderings of recent sparse factorizations, remembered node by node
/// (an unknown by its index in the whole problem, a row by its [`RowKey`]).
///
/// On a queue at a door the method factors, at the start of every step, a support of a
/// hundred rows or more, much like the one of the step before: the same contacts, a few
/// made or broken. AMD, which orders each fresh factorization, costs more there than the
/// rest of the factorization (measured: `docs/lab/2026-11-23-targets-release-by-release.md`).
/// A factorization whose nodes are mostly remembered is ordered by their ranks in the
/// orderings that placed them last (nodes new to the memory go last, in their own order),
/// which keeps the fill of the AMD ordering it descends from as long as the support changes
/// little. An ordering whose factor is predicted (by a symbolic count, before any numeric
/// work) to fill beyond `STALE_FILL` (1.25) times the last AMD ordering is not used: AMD
/// orders that factorization instead; and when a reused ordering's fill grows beyond it all
/// the same, the next factorization runs AMD again. The ordering changes only the rounding, and every
/// answer is still refined against the unregularized system and checked.
///
/// [`Orderings::forget_older`] bounds the memory: call it once per projection.
///
/// ```
/// use sweeping_api::{ProjectionProblem, RowKey, SparseRows};
/// use sweeping_qp::active_set::{solve, Memory, Options, Orderings, Start};
///
/// // A chain of 40 unknowns pushed together: x_{j+1} − x_j ≥ 1, y = 0.
/// let n = 40;
/// let rows: Vec<Vec<(usize, f64)>> = (0..n - 1).map(|j| vec![(j, -1.0), (j + 1, 1.0)]).collect();
/// let keys = (0..n - 1).map(|j| RowKey { family: 0, member: j as u64 }).collect();
/// let a = SparseRows::from_rows(n, &rows);
/// let p = ProjectionProblem::new(vec![0.0; n], a, vec![1.0; n - 1]).unwrap().with_row_keys(keys).unwrap();
/// let names: Vec<usize> = (0..n).collect();
/// let mut orderings = Orderings::default();
/// for _ in 0..2 {
///     orderings.forget_older();
///     // Every row starts in the support: a sparse factorization (AMD the first time,
///     // the remembered ordering the second).
///     let start = Start { support: (0..n - 1).collect(), lambda: vec![1.0; n - 1], join: vec![1.0; n - 1], join_at_most: None };
///     let memory = Memory { orderings: &mut orderings, unknowns: &names };
///     let options = Options { cap: 50, memory: Some(memory), ..Options::default() };
///     let out = solve(&p, start, options).unwrap();
///     assert!((out.x[n - 1] - out.x[0] - (n - 1) as f64).abs() < 1e-9);
/// }
/// assert_eq!(orderings.stats(), (1, 1));
/// ```
#[derive(Debug, Default, Clone)]
pub struct Orderings {
    /// Each remembered node's rank: its position in the ordering that placed it last, offset
    /// by every rank handed out before (so a later ordering ranks after an earlier one).
    ranks: FastMap<Node, u64>,
    /// Ranks handed out so far.
    next: u64,
    /// `next` when [`Orderings::forget_older`] was last called.
    since_last: u64,
    /// `nnz(L)/nnz(K)` of the last AMD ordering.
    pub(super) amd_fill: f64,
    /// A reused ordering filled beyond [`STALE_FILL`]: the next factorization runs AMD.
    stale: bool,
    /// Factorizations ordered by AMD, and from memory.
    by_amd: u64,
    by_memory: u64,
    /// In a [`fork`](Orderings::fork), `next` when it was made: ranks from there on are new.
    forked_at: u64,
}

/// [`Orderings`] with the names of a problem's unknowns, for [`solve`](super::solve) to order
/// its sparse factorizations from and remember them in when the problem carries row keys.
/// Without one name per unknown nothing is remembered: an ordering only saves time, so none
/// is guessed.
#[derive(Debug)]
pub struct Memory<'a> {
    /// The orderings remembered.
    pub orderings: &'a mut Orderings,
    /// `unknowns[j]` names unknown `j` of the problem: its index in the whole problem when
    /// the problem is one of its blocks.
    pub unknowns: &'a [usize],
}

impl Orderings {
    /// Forgets the nodes no ordering has placed since the call before last. Called once per
    /// projection, it keeps the nodes of the last two projections' factorizations.
    pub fn forget_older(&mut self) {
        let keep_from = self.since_last;
        self.ranks.retain(|_, rank| *rank >= keep_from);
        self.since_last = self.next;
    }

    /// How many sparse factorizations were ordered by AMD, and how many from memory.
    pub fn stats(&self) -> (u64, u64) {
        (self.by_amd, self.by_memory)
    }

    /// A copy of this memory for blocks solved on another thread: it orders their
    /// factorizations from what this memory holds, and what it learns is taken back by
    /// [`Orderings::join`]. Blocks have disjoint nodes, so forks never disagree about a node.
    pub fn fork(&self) -> Orderings {
        Orderings {
            by_amd: 0,
            by_memory: 0,
            forked_at: self.next,
            ..self.clone()
        }
    }

    /// Takes back what `forked`, a [`fork`](Orderings::fork) of this memory made since, has
    /// learned: its nodes' new ranks (after every rank handed out here, in their own order),
    /// its counts, and, when it factored anything, its last fill and staleness. Joining forks
    /// in a fixed order gives the same memory whichever thread ran which.
    pub fn join(&mut self, forked: Orderings) {
        let since = forked.forked_at;
        for (node, rank) in forked.ranks {
            if rank >= since {
                self.ranks.insert(node, rank - since + self.next);
            }
        }
        self.next += forked.next - since;
        if forked.by_amd + forked.by_memory > 0 {
            self.amd_fill = forked.amd_fill;
            self.stale = forked.stale;
        }
        self.by_amd += forked.by_amd;
        self.by_memory += forked.by_memory;
    }

    /// The ordering (QDLDL's `perm`: position → node) of `nodes` by their remembered ranks,
    /// unremembered nodes last in their own order; `None` when too few are remembered or the
    /// last reused ordering filled too much.
    pub(super) fn ordering(&self, nodes: &[Node]) -> Option<Vec<usize>> {
        if self.stale || self.ranks.is_empty() {
            return None;
        }
        // The remembered nodes with their ranks (distinct: each placement hands out new
        // ones), then the others in their own order.
        let mut ranked: Vec<(u64, usize)> = Vec::with_capacity(nodes.len());
        let mut unremembered = Vec::new();
        let (mut lowest, mut highest) = (u64::MAX, 0);
        for (l, node) in nodes.iter().enumerate() {
            match self.ranks.get(node) {
                Some(&rank) => {
                    ranked.push((rank, l));
                    lowest = lowest.min(rank);
                    highest = highest.max(rank);
                }
                None => unremembered.push(l),
            }
        }
        if (ranked.len() as f64) < REMEMBERED_FRACTION * nodes.len() as f64 {
            return None;
        }
        // Ranks are distinct, so any sort gives this order. Most of them were handed out by
        // the last few factorizations and span a few times the nodes: placed by rank in a
        // table of that span, they are in order without the comparison sort, which would be
        // most of the time spent here (measured:
        // `docs/lab/2026-11-25-less-work-and-speculated-rescue.md`).
        // (No nodes at all leave `lowest` above `highest`: the difference saturates instead of
        // wrapping, and the sort has nothing to sort.)
        let span = highest.saturating_sub(lowest) + 1;
        let mut perm = Vec::with_capacity(nodes.len());
        if span <= SPAN_PER_NODE * nodes.len() as u64 {
            let mut by_rank = vec![usize::MAX; span as usize];
            ranked
                .iter()
                .for_each(|&(rank, l)| by_rank[(rank - lowest) as usize] = l);
            perm.extend(by_rank.into_iter().filter(|&l| l != usize::MAX));
        } else {
            ranked.sort_unstable();
            perm.extend(ranked.into_iter().map(|(_, l)| l));
        }
        perm.extend(unremembered);
        Some(perm)
    }

    /// Remembers the ordering `perm` (position → node) of `nodes`, whose factor had `fill`
    /// (`nnz(L)/nnz(K)`); `reused` when `perm` came from [`Self::ordering`].
    pub(super) fn record(&mut self, nodes: &[Node], perm: &[usize], fill: f64, reused: bool) {
        if reused {
            self.by_memory += 1;
            self.stale = fill > STALE_FILL * self.amd_fill;
        } else {
            self.by_amd += 1;
            self.amd_fill = fill;
            self.stale = false;
        }
        for (position, &l) in perm.iter().enumerate() {
            self.ranks.insert(nodes[l], self.next + position as u64);
        }
        self.next += perm.len() as u64;
    }
}

#[cfg(test)]
mod tests;
