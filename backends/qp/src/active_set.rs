//! Lawson–Hanson on the dual of the projection, one block at a time.
//!
//! The projection `x = y + d`, `d = Aᵀλ`, has `λ` solving the dual
//!
//! ```text
//!     min ½‖Aᵀλ‖² − λᵀr   over λ ≥ 0,     r = b − A y,
//! ```
//!
//! a non-negative least-squares problem in disguise, for which the Lawson–Hanson active-set
//! method terminates finitely. Each step solves the equality-constrained projection on the
//! support `P`,
//!
//! ```text
//!     [ I    A_Pᵀ ] [ d  ]   [ 0   ]
//!     [ A_P  0    ] [ −μ ] = [ r_P ],
//! ```
//!
//! by an `LDLᵀ` factorization (QDLDL's arithmetic, run by this crate's `ldl` module so that
//! the matrix is permuted and analysed once, ordered by AMD or by an ordering remembered from
//! recent factorizations, see [`Orderings`]) of the quasi-definite matrix whose
//! lower-right block is `−δI`, on the unknowns the rows of `P` touch (`dⱼ = 0` for the others),
//! followed by iterative refinement against the unregularized
//! matrix, started from the current `(d, λ)`. Between steps the support changes by a few
//! rows; up to `BORDER_MAX` (24) such changes are solved through the factor already made, by
//! bordering it with the changed rows and a small dense Schur complement (the factor extended
//! by the identity on unknowns that only joined rows touch),
//! instead of factoring again. Refinement is the proximal-point method on the
//! multipliers, so on linearly dependent rows (a *contact loop*: a cycle of touching disks)
//! it still converges to the unique `d` and to the least-squares `μ` nearest `λ`. Then:
//!
//! - if `A_P d = r_P` is inconsistent (residual `e = r_P − A_P d` beyond a tolerance), the rows
//!   cannot all be tight: `e` lies in the null space of `A_Pᵀ` and the dual objective
//!   decreases without bound along it on `P`. `λ` moves along `e` until an entry reaches zero
//!   and that row leaves `P`. If no entry of `e` is negative the ray never stops: `e ≥ 0`,
//!   `A_Pᵀe = 0`, `eᵀr_P > 0` is Farkas' certificate that `A x ≥ b` is empty, returned after
//!   it is checked;
//! - otherwise, if some `μ` is negative, `λ` moves toward `μ` until an entry reaches zero and
//!   that row leaves `P` (on the first pass, before any row joined, every row with a negative
//!   `μ` leaves at once, saving one factorization per row when the starting guess holds
//!   several rows that are no longer tight);
//! - otherwise the rows outside `P` that `d` violates join it;
//! - when none does, `(y + d, μ)` satisfies the KKT conditions.
//!
//! Those tests allow `1e-12` (relative), which jams need to finish at all; an answer that
//! uses that room (a row violated, or the support's equations left unsolved, by more than
//! `1e-15`) is finished by a second pass at `1e-15` from its own support, under the same cap
//! of iterations, then, when that pass does not converge, by one at `1e-14`, then at `1e-13`;
//! from the answer of the first that converges, the passes below it run again, down to
//! `1e-15`. An answer no pass at `1e-15` finished stands as the best one of the others, or
//! as it was, and says it is unfinished ([`Outcome::unfinished`]). On a jam with more
//! tight rows than unknowns the feasible set is a sliver around the projection, and two
//! points that pass the `1e-12` tests can lie millions of times further apart than that
//! (measured: `docs/lab/2026-11-24-second-pass-1e-13.md`). The second pass tells a support
//! whose rows are nearly dependent from one whose equations are inconsistent by conjugate
//! gradients where refinement stalls (see `LEAST_SQUARES_STEPS` in the source).
//!
//! The same method polishes Clarabel's interior-point answers (started from the interior-point
//! guess, see `sweeping-clarabel`) and is the engine's warm path and finish ([`crate::Engine`],
//! started from the previous step's support, from the rows violated at `y`, or from an
//! interior point's support): one implementation, several starts.

use crate::csc::CscMatrix;
use sweeping_api::{max_or_nan, FastMap, ProjectionProblem, RowKey};

use crate::ldl::{Ldl, NotFactored};

/// How often the same working set may be factored before the method is declared cycling.
const REPEATS: u32 = 3;
/// Regularization of the lower-right block, removed again by iterative refinement.
const DELTA: f64 = 1e-9;
/// Most refinement steps per factorization.
const REFINE_STEPS: usize = 50;
/// Refinement also stops when a step moves the first block by more than this fraction of the
/// step before: on consistent equations it contracts by far more (the regularization `δ` is
/// tiny against the rows' scale), so slower progress means inconsistent or nearly dependent
/// rows. Running such refinements to [`REFINE_STEPS`] multiplies the solves without changing
/// the number of active-set iterations.
const REFINE_CONTRACTION: f64 = 0.1;
/// Refinement stops when the residual of the unregularized system, or the change of its first
/// block, falls below this, relative to `max(1, ‖right-hand side‖∞)`.
const REFINE_TOL: f64 = 1e-13;
/// The equations of the support are taken as inconsistent, and a row outside it as violated,
/// beyond this, relative to `max(1, ‖r‖∞)`.
const ACTIVE_TOL: f64 = 1e-12;
/// The tolerance of the second pass ([`second_pass`]), relative as [`ACTIVE_TOL`], and of its
/// refinement, below which a support's equations count as solved there.
///
/// On a jam the support's rows can be nearly dependent, its smallest singular value `σ` far
/// below one: a point that violates a row, or leaves its support's equations unsolved, by `τ`
/// can then be `τ/σ` from the projection, so the test must be far tighter than the distance
/// it is to guarantee. The crowd's problems are posed in the displacement `x − q_k`, whose
/// rows and right-hand sides are of the order of a step's travel, so `1e-15` is still a
/// hundred times the rounding of `r − A d` (measured:
/// `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
const SECOND_PASS_TOL: f64 = 1e-15;

/// The tests of the second pass, tried in turn, each from the first answer, until a pass
/// converges; then the ones below it again, each from the last answer ([`second_pass`]); an
/// answer that no pass at `1e-15` converges to is [`Outcome::unfinished`], off by up to
/// `1e-14` or `1e-13`. On the slivers where the pass at `1e-15` cycles, a row violated by a
/// few `1e-15` joins and the refinement then measures the support's equations inconsistent by
/// ten times that, so the row leaves again: the test is below what the refinement can resolve
/// there. A pass at `1e-14` still brings such an answer much nearer the projection, and from
/// there the pass at `1e-15` often finishes it. The rung at `1e-13` is for answers that
/// neither lower rung finishes from the first answer: from its answer the lower rungs can
/// converge where they cycled before (measured:
/// `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
const FINISH_LADDER: [f64; 3] = [SECOND_PASS_TOL, 1e-14, 1e-13];

/// The tests of one pass of the method.
#[derive(Debug, Clone, Copy)]
struct Tolerances {
    /// A row outside the support is violated, and the support's equations inconsistent,
    /// beyond this, relative to `max(1, ‖r‖∞)`.
    active: f64,
    /// Refinement's, relative to `max(1, ‖right-hand side‖∞)` (see [`ActiveSystem::refine`]).
    refine: f64,
    /// Whether a refinement that stalls is followed by conjugate gradients on the support's
    /// equations ([`ActiveSystem::least_squares`]).
    least_squares: bool,
    /// Whether a run that cycles restarts as Lawson–Hanson proper, from an empty support.
    restarts: bool,
}

/// The first pass: tests at [`ACTIVE_TOL`], refinement alone.
const FIRST_PASS: Tolerances = Tolerances {
    active: ACTIVE_TOL,
    refine: REFINE_TOL,
    least_squares: false,
    restarts: true,
};

/// The second pass: tests and refinement at [`SECOND_PASS_TOL`], and a refinement that stalls
/// followed by conjugate gradients. Refinement (the proximal-point method with step `1/δ`)
/// contracts an error along a singular vector of `A_P` by `δ/(σ² + δ)` per step, so it stalls
/// on rows nearly dependent (`σ² ≲ 10δ`, `σ ≲ 1e-4`) whether or not their equations are
/// consistent, and the method would take consistent supports for inconsistent ones, dropping
/// and taking back the same rows until it runs out of iterations. Conjugate gradients tell
/// the two apart in a few steps (measured:
/// `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
const SECOND_PASS: Tolerances = Tolerances {
    active: SECOND_PASS_TOL,
    refine: SECOND_PASS_TOL,
    least_squares: true,
    restarts: false,
};

/// Under Bland's rule, rows whose multipliers reach zero within this fraction of the first
/// count as reaching it together.
const BLAND_TIE: f64 = 1e-9;

/// Most conjugate-gradient steps after a stalled refinement: on the nearly dependent supports
/// where they succeed they take two or three.
const LEAST_SQUARES_STEPS: usize = 3;

/// Where the method starts.
#[derive(Debug, Clone)]
pub struct Start {
    /// The starting support (row indices, distinct, in any order).
    pub support: Vec<usize>,
    /// A positive starting multiplier per row of the support.
    pub lambda: Vec<f64>,
    /// For every row, the positive multiplier it starts from if it joins the support later.
    pub join: Vec<f64>,
    /// How many of the rows violated at an iteration join the support: all of them (`None`),
    /// or at most this many, the most violated first. Rows joining together that are
    /// linearly dependent on the support make its equations inconsistent, and the method then
    /// leaves one row per iteration; on a jam whose support already holds more rows than
    /// unknowns, joining the most violated row alone keeps that from happening again. With a
    /// bound, rows with negative multipliers also leave one at a time from the start (without
    /// it, every such row leaves at once on the first pass, before any row joined).
    pub join_at_most: Option<usize>,
}

/// A converged answer.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The point `y + d`.
    pub x: Vec<f64>,
    /// One multiplier per row (zero off the support).
    pub lambda: Vec<f64>,
    /// Iterations spent: each solved the working set's system once, through a fresh
    /// factorization or through the previous one by bordering.
    pub iterations: u32,
    /// `None` when the answer passed the tests at `1e-15`, relative (the first pass's, or
    /// a second pass's own); `Some(off)` when no second pass converged at `1e-15` and the
    /// answer is one at `1e-14` or `1e-13`, or stands as the first pass or a pass's best
    /// iterate left it: a row violated, or a row of its support not tight, by `off`
    /// (absolute), certified only to that. On a sliver of a feasible set an answer off by
    /// `1e-12` lay `1e-8` from the projection.
    pub unfinished: Option<f64>,
}

/// Why no answer came out.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// Factorization failed or numbers stopped being finite.
    Numerical(&'static str),
    /// The cap on iterations was reached.
    Cap(u32),
    /// A working set came back three times even after the restart as Lawson–Hanson
    /// proper: rounding on degenerate, dependent rows made the method cycle.
    Cycling(u32),
    /// A checked Farkas certificate: rows `support` with weights `e ≥ 0`, `A_Pᵀe ≈ 0`,
    /// `eᵀr_P > 0`.
    Infeasible {
        /// Row indices of the certificate.
        rows: Vec<usize>,
    },
}

/// Rows of `A`, each with its columns sorted and repeats summed, stored one after another.
///
/// One vector for all of a support's rows rather than one per row: the method builds these
/// rows at every fresh factorization, and a vector each would cost two allocations per row,
/// most of a run's allocations (measured: `docs/lab/2026-11-23-targets-release-by-release.md`).
#[derive(Debug, Clone, Default)]
struct MergedRows {
    /// Where each row starts in `entries`, and where the last ends.
    start: Vec<usize>,
    entries: Vec<(usize, f64)>,
}

impl MergedRows {
    /// The rows `active` of `problem`'s `A`, in that order.
    fn of(problem: &ProjectionProblem, active: &[usize]) -> Self {
        let entries = active.iter().map(|&r| problem.a().row_len(r)).sum();
        let mut rows = Self {
            start: Vec::with_capacity(active.len() + 1),
            entries: Vec::with_capacity(entries),
        };
        rows.start.push(0);
        active.iter().for_each(|&r| rows.push(problem, r));
        rows
    }

    /// Appends row `r` of `problem`'s `A`, its columns sorted (stably) and repeats summed in
    /// the order they come.
    fn push(&mut self, problem: &ProjectionProblem, r: usize) {
        let first = self.entries.len();
        self.entries.extend(problem.a().row(r));
        let row = &mut self.entries[first..];
        if !row.is_sorted_by_key(|&(c, _)| c) {
            row.sort_by_key(|&(c, _)| c);
        }
        // Repeats summed in place: `end` is the merged row's length so far.
        let mut end = first;
        for q in first..self.entries.len() {
            let (c, v) = self.entries[q];
            if end > first && self.entries[end - 1].0 == c {
                self.entries[end - 1].1 += v;
            } else {
                self.entries[end] = (c, v);
                end += 1;
            }
        }
        self.entries.truncate(end);
        self.start.push(end);
    }

    /// How many rows.
    fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// Row `t`.
    fn row(&self, t: usize) -> &[(usize, f64)] {
        &self.entries[self.start[t]..self.start[t + 1]]
    }

    /// The rows in order.
    fn iter(&self) -> impl Iterator<Item = &[(usize, f64)]> {
        self.start.windows(2).map(|w| &self.entries[w[0]..w[1]])
    }

    /// Keeps the rows `t` for which `keep(t)` holds, in order.
    fn retain(&mut self, mut keep: impl FnMut(usize) -> bool) {
        let mut end = 0;
        let mut kept = 1;
        for t in 0..self.len() {
            let (from, to) = (self.start[t], self.start[t + 1]);
            if keep(t) {
                self.entries.copy_within(from..to, end);
                end += to - from;
                self.start[kept] = end;
                kept += 1;
            }
        }
        self.entries.truncate(end);
        self.start.truncate(kept);
    }
}

/// The KKT system `K₀ = [I A_Pᵀ; A_P 0]` of a set of rows `P`, with the `LDLᵀ` factors of its
/// regularization `K_δ = [I A_Pᵀ; A_P −δI]`.
///
/// An unknown that no row of `P` touches has the equation `dⱼ = fⱼ` alone, so a sparse factor
/// covers only the touched ones ([`Unknowns`]): on a jam the support touches a fraction of
/// the block's people, and every factorization, solve and bordering column of the rest would
/// be identity work.
struct ActiveSystem {
    n: usize,
    /// The support, in the order of `rows` and of the unknowns `μ`.
    support: Vec<usize>,
    rows: MergedRows,
    factor: Factor,
    /// The unknowns of a sparse factor (empty for a dense one).
    unknowns: Unknowns,
    /// Rows removed from and added to the support of a sparse factor since it was made.
    bordered: Option<Bordered>,
    /// Work vectors of solves and refinement, kept from one to the next: a solve is short,
    /// and allocating its vectors afresh each time would be a sizeable part of it.
    scratch: Scratch,
}

/// Work vectors of an [`ActiveSystem`] (their contents do not outlive a call).
#[derive(Debug, Default)]
struct Scratch {
    /// The right-hand side gathered onto a sparse factor's nodes.
    gathered: Vec<f64>,
    /// Refinement's product `K₀ v` and step.
    product: Vec<f64>,
    step: Vec<f64>,
    /// Conjugate gradients' vectors ([`ActiveSystem::least_squares`]): by unknown, `A_Pᵀ·`;
    /// by row, the residual, the preconditioned residual, the direction and its product.
    by_unknown: Vec<f64>,
    residual: Vec<f64>,
    preconditioned: Vec<f64>,
    direction: Vec<f64>,
    product_g: Vec<f64>,
    /// Bordering's marks by row of the problem: whether a row is in the next support, and
    /// its position in the factored one (`usize::MAX` when not), clear between calls.
    in_next: Vec<bool>,
    position: Vec<usize>,
}

/// The unknowns a sparse factor and its bordering work on, numbered locally: first the `base`
/// ones, touched by the factored support `P₀` (increasing), then those that joined rows
/// touched first (an identity block of the bordered system).
struct Unknowns {
    /// Local → global.
    global: Vec<usize>,
    /// Global → local, `usize::MAX` for an unknown not in the system.
    local: Vec<usize>,
    /// How many unknowns the factor of `K_δ(P₀)` covers.
    base: usize,
}

impl Unknowns {
    /// The unknowns touched by `rows` (columns sorted), of `n`.
    fn touched_by(n: usize, rows: &MergedRows) -> Self {
        let mut local = vec![usize::MAX; n];
        for &(c, _) in &rows.entries {
            local[c] = 0;
        }
        let global: Vec<usize> = (0..n).filter(|&c| local[c] == 0).collect();
        global.iter().enumerate().for_each(|(l, &c)| local[c] = l);
        let base = global.len();
        Self {
            global,
            local,
            base,
        }
    }

    /// The local index of the global unknown `c`, added (after every other) when new.
    fn index(&mut self, c: usize) -> usize {
        if self.local[c] == usize::MAX {
            self.local[c] = self.global.len();
            self.global.push(c);
        }
        self.local[c]
    }
}

/// Most rows removed from or added to the support of a sparse factorization before it is
/// made afresh: each one costs a solve with the old factor when it happens and `O(n + k)` per
/// solve afterwards, a fresh factorization costs far more on the blocks where it matters.
const BORDER_MAX: usize = 24;

/// One change of the support since the sparse factorization of `K_δ` for the support `P₀`.
enum Change {
    /// A row joined: the system gains an unknown `u` with the column `[a; 0]` and `−δ` on the
    /// diagonal. `entries` index the layout of [`Bordered`].
    Joined {
        row: usize,
        entries: Vec<(usize, f64)>,
    },
    /// The row at position `p` of `P₀` left: its multiplier is pinned to zero by a Lagrange
    /// multiplier `ν` on the column `e_{n+p}`, which also frees its equation.
    Left { position: usize },
}

/// The system of the current support solved through the factor of `K_δ(P₀)` by bordering:
///
/// ```text
///     [ K_δ(P₀)  C ] [z]   [rhs]
///     [ Cᵀ       D ] [w] = [ g ],   D = diag(−δ for a joined row, 0 for a left one),
/// ```
///
/// `C` one column per [`Change`]. With `W = K_δ(P₀)⁻¹ C` and `S = D − Cᵀ W` (a small dense
/// matrix, LU-factored), `w = S⁻¹(g − Cᵀ z₀)` and `z = z₀ − W w`, `z₀ = K_δ(P₀)⁻¹ rhs`. This
/// is the exact solve of the regularized system of the current support, at the price of one
/// solve with the old factor per change: a working set that changes by one row no longer
/// costs a factorization.
///
/// The layout of `z` (and of `C`'s columns) is `[d_U; μ_{P₀}; d_E]`: the unknowns `U` of the
/// factor, the multipliers of `P₀`, then the unknowns `E` that only joined rows touch, on
/// which `K_δ(P₀)` is extended by the identity.
#[derive(Default)]
struct Bordered {
    /// `P₀`, in the order of the factor.
    base: Vec<usize>,
    changes: Vec<Change>,
    /// `W`, one column per change, as long as the layout was when the change came (the
    /// identity block keeps later unknowns of `E` at zero in it).
    w: Vec<Vec<f64>>,
    /// `S`, row-major, and its LU factors with the row permutation.
    s: Vec<f64>,
    lu: Vec<f64>,
    pivots: Vec<usize>,
    /// The positions of `P₀` whose rows are still in the support, in order (made with the
    /// LU factors).
    stayed: Vec<usize>,
    /// Work vectors of a solve: the layout's `z`, the bordering unknowns `g − Cᵀz₀`, and
    /// their permuted copy.
    work_z: Vec<f64>,
    work_g: Vec<f64>,
    work_y: Vec<f64>,
}

/// Supports of at most this many rows are factored densely, by the Schur complement
/// `A_P A_Pᵀ + δI` (`k × k`): a contact cluster of a few people costs a few microseconds that
/// way, where the sparse path pays for building, ordering and analysing a matrix of size
/// `n + k` every time.
const DENSE_MAX: usize = 24;

/// Relative size of the smallest Cholesky pivot accepted on the dense path.
const DENSE_PIVOT: f64 = 1e-6;

/// The factors of `K_δ = [I A_Pᵀ; A_P −δI]`.
enum Factor {
    /// Sparse `LDLᵀ` of `K_δ` itself.
    Sparse(Box<Ldl>),
    /// Dense Cholesky factor `L` (row-major, lower triangle) of `S = A_P A_Pᵀ + δI`.
    Dense(Vec<f64>),
}

/// The dense Cholesky factor (row-major `k × k`, lower triangle) of `A_P A_Pᵀ + δI`, the rows
/// given with sorted columns; `None` when a row is nearly a combination of the ones before
/// it (its pivot below [`DENSE_PIVOT`] times its diagonal entry). Such rows (a contact loop)
/// make `S` as ill-conditioned as `1/δ`, and the sparse `LDLᵀ` of `K_δ` is used instead.
fn schur_cholesky(rows: &MergedRows) -> Option<Vec<f64>> {
    let k = rows.len();
    let dot = |a: &[(usize, f64)], b: &[(usize, f64)]| {
        let (mut i, mut j, mut sum) = (0, 0, 0.0);
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    sum += a[i].1 * b[j].1;
                    i += 1;
                    j += 1;
                }
            }
        }
        sum
    };
    let mut l = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..=i {
            let diagonal = dot(rows.row(i), rows.row(j)) + if i == j { DELTA } else { 0.0 };
            let mut v = diagonal;
            for p in 0..j {
                v -= l[i * k + p] * l[j * k + p];
            }
            if i == j {
                if v.is_nan() || v <= DENSE_PIVOT * diagonal {
                    return None;
                }
                l[i * k + i] = v.sqrt();
            } else {
                l[i * k + j] = v / l[j * k + j];
            }
        }
    }
    Some(l)
}

/// What a node of `K_δ` stands for, across factorizations and steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Node {
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
const STALE_FILL: f64 = 1.25;

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
/// use sweeping_qp::active_set::{solve_remembering, Orderings, Start};
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
///     let out = solve_remembering(&p, start, 50, &mut orderings, &names).unwrap();
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
    amd_fill: f64,
    /// A reused ordering filled beyond [`STALE_FILL`]: the next factorization runs AMD.
    stale: bool,
    /// Factorizations ordered by AMD, and from memory.
    by_amd: u64,
    by_memory: u64,
    /// In a [`fork`](Orderings::fork), `next` when it was made: ranks from there on are new.
    forked_at: u64,
}

/// [`Orderings`] with the names of a problem's unknowns.
struct Remembered<'a> {
    orderings: &'a mut Orderings,
    unknowns: &'a [usize],
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
    fn ordering(&self, nodes: &[Node]) -> Option<Vec<usize>> {
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
    fn record(&mut self, nodes: &[Node], perm: &[usize], fill: f64, reused: bool) {
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

/// Where iterative refinement stopped.
struct Refined {
    /// `‖residual‖∞` of the second block.
    second: f64,
    /// Whether the whole residual met the tolerance.
    solved: bool,
    /// Whether refinement, unsolved, stopped while its first block still moved, slowly (its
    /// steps contracting by less than [`REFINE_CONTRACTION`], or at [`REFINE_STEPS`]): the
    /// mark of nearly dependent rows, where [`ActiveSystem::least_squares`] may solve what
    /// refinement did not. Unsolved with the first block settled, the equations are
    /// inconsistent and it could not.
    stalled: bool,
    /// The second block of the residual, `r_P − A_P d` for the right-hand side `[0; r_P]`.
    residual: Vec<f64>,
}

impl ActiveSystem {
    /// Factors `K_δ` for the rows `active` (increasing); `None` when the factorization fails.
    /// A sparse factorization is ordered from `memory` when it holds most of the matrix (see
    /// [`Orderings`]), by AMD otherwise.
    fn new(
        problem: &ProjectionProblem,
        active: &[usize],
        memory: Option<&mut Remembered<'_>>,
    ) -> Option<Self> {
        let n = problem.dim();
        let k = active.len();
        if k <= DENSE_MAX {
            let rows = MergedRows::of(problem, active);
            if let Some(l) = schur_cholesky(&rows) {
                return Some(Self {
                    n,
                    support: active.to_vec(),
                    rows,
                    factor: Factor::Dense(l),
                    unknowns: Unknowns {
                        global: Vec::new(),
                        local: Vec::new(),
                        base: 0,
                    },
                    bordered: None,
                    scratch: Scratch::default(),
                });
            }
        }
        Self::sparse_ordered(problem, active, memory)
    }

    /// The sparse `LDLᵀ` of `K_δ` for the rows `active`, whatever their number, ordered by
    /// AMD; see [`Self::new`].
    #[cfg(test)]
    fn sparse(problem: &ProjectionProblem, active: &[usize]) -> Option<Self> {
        Self::sparse_ordered(problem, active, None)
    }

    /// The sparse `LDLᵀ` of `K_δ` for the rows `active`, whatever their number, ordered from
    /// `memory` when it can be (and the ordering remembered), else by AMD; see [`Self::new`].
    fn sparse_ordered(
        problem: &ProjectionProblem,
        active: &[usize],
        memory: Option<&mut Remembered<'_>>,
    ) -> Option<Self> {
        let n = problem.dim();
        let k = active.len();
        let rows = MergedRows::of(problem, active);
        let unknowns = Unknowns::touched_by(n, &rows);
        let kkt = kkt_matrix(&rows, &unknowns);
        let u = unknowns.base;
        let signs: Vec<i8> = (0..u + k).map(|i| if i < u { 1 } else { -1 }).collect();
        // Each node of `K_δ` named by what it stands for, so that orderings carry over.
        let nodes = memory.as_ref().and_then(|m| {
            let keys = problem.row_keys()?;
            let unknown_ids = unknowns.global[..u]
                .iter()
                .map(|&c| Node::Unknown(m.unknowns[c]));
            let row_ids = active.iter().map(|&i| Node::Row(keys[i]));
            Some(unknown_ids.chain(row_ids).collect::<Vec<Node>>())
        });
        // A remembered ordering is used only when its factor is predicted to fill no more
        // than `STALE_FILL` times the last AMD ordering: when thousands of rows new to the
        // memory go last, eliminating the unknowns before them can fill a hundred times more
        // than AMD (measured: `docs/lab/2026-11-24-crowd-at-1000-m-s.md`). The count is the
        // factorization's own symbolic analysis, which gives up at the budget.
        let remembered = match (&memory, &nodes) {
            (Some(m), Some(nodes)) => m.orderings.ordering(nodes).map(|perm| {
                let budget = STALE_FILL * m.orderings.amd_fill * kkt.nnz() as f64;
                Ldl::ordered(&kkt, perm, &signs, budget)
            }),
            _ => None,
        };
        let (ldl, reordered) = match remembered {
            Some(Ok(ldl)) => (ldl, true),
            Some(Err(NotFactored::Failed)) => return None,
            Some(Err(NotFactored::TooMuchFill)) | None => (Ldl::amd(&kkt, &signs).ok()?, false),
        };
        if let (Some(m), Some(nodes)) = (memory, nodes) {
            let fill = ldl.entries_below_diagonal() as f64 / kkt.nnz() as f64;
            m.orderings.record(&nodes, ldl.perm(), fill, reordered);
        }
        Some(Self {
            n,
            support: active.to_vec(),
            rows,
            factor: Factor::Sparse(Box::new(ldl)),
            unknowns,
            bordered: None,
            scratch: Scratch::default(),
        })
    }

    /// `v ← K_δ⁻¹ v`. Densely: `[u; w]` with `u + A_Pᵀw = f`, `A_P u − δw = g` gives
    /// `(A_P A_Pᵀ + δI) w = A_P f − g` and `u = f − A_Pᵀw`.
    fn solve_in_place(&mut self, v: &mut [f64]) {
        match &mut self.factor {
            Factor::Sparse(ldl) => match &mut self.bordered {
                None => {
                    // The factored unknowns gathered, solved and scattered back; the others
                    // are their own solution.
                    let (n, u) = (self.n, self.unknowns.base);
                    let global = &self.unknowns.global[..u];
                    let z = &mut self.scratch.gathered;
                    z.clear();
                    z.extend(global.iter().map(|&c| v[c]));
                    z.extend_from_slice(&v[n..]);
                    ldl.solve(z);
                    global.iter().zip(z.iter()).for_each(|(&c, zc)| v[c] = *zc);
                    v[n..].copy_from_slice(&z[u..]);
                }
                Some(bordered) => bordered.solve(ldl, self.n, &self.unknowns, &self.support, v),
            },
            Factor::Dense(l) => {
                let (n, k) = (self.n, self.rows.len());
                let (f, g) = v.split_at_mut(n);
                // w ← A f − g, then the two triangular solves with L and Lᵀ.
                for (t, row) in self.rows.iter().enumerate() {
                    g[t] = row.iter().map(|&(c, a)| a * f[c]).sum::<f64>() - g[t];
                }
                for i in 0..k {
                    let mut s = g[i];
                    for p in 0..i {
                        s -= l[i * k + p] * g[p];
                    }
                    g[i] = s / l[i * k + i];
                }
                for i in (0..k).rev() {
                    let mut s = g[i];
                    for p in i + 1..k {
                        s -= l[p * k + i] * g[p];
                    }
                    g[i] = s / l[i * k + i];
                }
                for (t, row) in self.rows.iter().enumerate() {
                    for &(c, a) in row {
                        f[c] -= a * g[t];
                    }
                }
            }
        }
    }
}

impl ActiveSystem {
    /// The system for the support `next`, made from this one without a factorization when
    /// the factor is sparse, `next` is this support with rows removed and rows appended (the
    /// order the method keeps), and at most [`BORDER_MAX`] changes separate it from the
    /// factored support; `None` otherwise.
    fn bordered_to(mut self, problem: &ProjectionProblem, next: &[usize]) -> Option<Self> {
        let Factor::Sparse(ldl) = &mut self.factor else {
            return None;
        };
        // Marks by row, all clear between calls.
        let mut in_next = std::mem::take(&mut self.scratch.in_next);
        in_next.resize(problem.n_rows(), false);
        next.iter().for_each(|&i| in_next[i] = true);
        let kept: Vec<usize> = self
            .support
            .iter()
            .copied()
            .filter(|&i| in_next[i])
            .collect();
        if next.len() < kept.len() || next[..kept.len()] != kept[..] {
            return None;
        }
        // Counted before any is made: each change costs a solve with the old factor and a
        // copy of `S`, and a jam can take in thousands of rows at once, each iteration then
        // costing minutes (measured: `docs/lab/2026-11-24-crowd-at-1000-m-s.md`).
        let leaving: Vec<usize> = self
            .support
            .iter()
            .copied()
            .filter(|&i| !in_next[i])
            .collect();
        let changes = self.bordered.as_ref().map_or(&[][..], |b| &b.changes[..]);
        if changes_after(changes, &leaving, next.len() - kept.len()) > BORDER_MAX {
            return None;
        }
        let unknowns = &mut self.unknowns;
        let bordered = self.bordered.get_or_insert_with(|| Bordered {
            base: self.support.clone(),
            ..Bordered::default()
        });
        // Rows leaving: a joined row's change is undone, a row of P₀ gets a `Left` change.
        let mut position = std::mem::take(&mut self.scratch.position);
        position.resize(problem.n_rows(), usize::MAX);
        bordered
            .base
            .iter()
            .enumerate()
            .for_each(|(p, &i)| position[i] = p);
        for &i in &leaving {
            match bordered
                .changes
                .iter()
                .position(|c| matches!(c, Change::Joined { row, .. } if *row == i))
            {
                Some(c) => bordered.undo(c),
                None => bordered.push(
                    ldl,
                    unknowns,
                    Change::Left {
                        position: position[i],
                    },
                ),
            }
        }
        // The rows that stay keep their merged entries; joining rows are merged once.
        let mut rows = std::mem::take(&mut self.rows);
        let support = &self.support;
        rows.retain(|t| in_next[support[t]]);
        for &i in &next[kept.len()..] {
            rows.push(problem, i);
            let local = rows
                .row(rows.len() - 1)
                .iter()
                .map(|&(c, a)| (bordered.position(unknowns.index(c), unknowns), a))
                .collect();
            bordered.push(
                ldl,
                unknowns,
                Change::Joined {
                    row: i,
                    entries: local,
                },
            );
        }
        if bordered.changes.len() > BORDER_MAX || !bordered.factor_s() {
            return None;
        }
        bordered.base.iter().for_each(|&i| position[i] = usize::MAX);
        next.iter().for_each(|&i| in_next[i] = false);
        (self.scratch.in_next, self.scratch.position) = (in_next, position);
        self.rows = rows;
        self.support.clear();
        self.support.extend_from_slice(next);
        Some(self)
    }
}

/// How many changes separate the support from the factored one after `leaving` rows leave
/// and `joining` rows join, `changes` separating them now: a leaving row that had joined
/// since the factorization undoes its change, any other adds one, and so does each joining
/// row.
fn changes_after(changes: &[Change], leaving: &[usize], joining: usize) -> usize {
    let undone = leaving
        .iter()
        .filter(|&&i| {
            changes
                .iter()
                .any(|c| matches!(c, Change::Joined { row, .. } if *row == i))
        })
        .count();
    changes.len() - undone + (leaving.len() - undone) + joining
}

impl Bordered {
    /// Where the unknown of local index `l` sits in the layout.
    fn position(&self, l: usize, unknowns: &Unknowns) -> usize {
        if l < unknowns.base {
            l
        } else {
            l + self.base.len()
        }
    }

    /// `cᵀz` for the column `c` of `C` of a change, `z` in the layout (missing entries of a
    /// shorter `z` are zero).
    fn column_dot(u: usize, change: &Change, z: &[f64]) -> f64 {
        match change {
            Change::Joined { entries, .. } => entries
                .iter()
                .map(|&(i, a)| a * z.get(i).copied().unwrap_or(0.0))
                .sum(),
            Change::Left { position } => z[u + position],
        }
    }

    /// `D`'s diagonal entry of a change.
    fn diagonal(change: &Change) -> f64 {
        match change {
            Change::Joined { .. } => -DELTA,
            Change::Left { .. } => 0.0,
        }
    }

    /// Adds a change: its column of `W` (one solve with the old factor) and its row and
    /// column of `S`.
    fn push(&mut self, ldl: &mut Ldl, unknowns: &Unknowns, change: Change) {
        let (u, factored) = (unknowns.base, unknowns.base + self.base.len());
        let mut w = vec![0.0; unknowns.global.len() + self.base.len()];
        match &change {
            Change::Joined { entries, .. } => entries.iter().for_each(|&(i, a)| w[i] += a),
            Change::Left { position } => w[u + position] = 1.0,
        }
        ldl.solve(&mut w[..factored]);
        let c = self.changes.len();
        // S grows from c × c to (c + 1) × (c + 1): S_jk = D_jk − c_jᵀ w_k.
        let mut s = vec![0.0; (c + 1) * (c + 1)];
        for j in 0..c {
            for k in 0..c {
                s[j * (c + 1) + k] = self.s[j * c + k];
            }
        }
        for j in 0..c {
            let value = -Self::column_dot(u, &self.changes[j], &w);
            s[j * (c + 1) + c] = value;
            s[c * (c + 1) + j] = value;
        }
        s[c * (c + 1) + c] = Self::diagonal(&change) - Self::column_dot(u, &change, &w);
        self.s = s;
        self.w.push(w);
        self.changes.push(change);
    }

    /// Removes change `c` (a joined row leaving again).
    fn undo(&mut self, c: usize) {
        let old = self.changes.len();
        self.changes.remove(c);
        self.w.remove(c);
        let new = old - 1;
        let mut s = Vec::with_capacity(new * new);
        for j in (0..old).filter(|&j| j != c) {
            for k in (0..old).filter(|&k| k != c) {
                s.push(self.s[j * old + k]);
            }
        }
        self.s = s;
    }

    /// LU factors of `S` with partial pivoting; `false` when a pivot vanishes.
    fn factor_s(&mut self) -> bool {
        let c = self.changes.len();
        let mut left = vec![false; self.base.len()];
        for change in &self.changes {
            if let Change::Left { position } = change {
                left[*position] = true;
            }
        }
        self.stayed.clear();
        self.stayed
            .extend((0..self.base.len()).filter(|&p| !left[p]));
        self.lu.clone_from(&self.s);
        self.pivots.clear();
        self.pivots.extend(0..c);
        let scale = self.s.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
        for k in 0..c {
            let (p, best) = (k..c)
                .map(|i| (i, self.lu[i * c + k].abs()))
                .fold((k, -1.0), |acc, x| if x.1 > acc.1 { x } else { acc });
            if best.is_nan() || best <= 1e-14 * scale {
                return false;
            }
            if p != k {
                for j in 0..c {
                    self.lu.swap(k * c + j, p * c + j);
                }
                self.pivots.swap(k, p);
            }
            let pivot = self.lu[k * c + k];
            for i in k + 1..c {
                let factor = self.lu[i * c + k] / pivot;
                self.lu[i * c + k] = factor;
                for j in k + 1..c {
                    self.lu[i * c + j] -= factor * self.lu[k * c + j];
                }
            }
        }
        true
    }

    /// `v ← K_δ⁻¹ v` for the current support `support` (rows of `P₀` that stayed, in their
    /// order, then the joined rows in the order they joined).
    fn solve(
        &mut self,
        ldl: &mut Ldl,
        n: usize,
        unknowns: &Unknowns,
        support: &[usize],
        v: &mut [f64],
    ) {
        let base = self.base.len();
        let u = unknowns.base;
        let c = self.changes.len();
        // Where each unknown of the current layout lives: a position of P₀ (`stayed`), or a
        // change.
        let stayed = std::mem::take(&mut self.stayed);
        debug_assert_eq!(stayed.len() + (c - (base - stayed.len())), support.len());
        // z₀ = K_δ(P₀)⁻¹ [f_U; g_{P₀}; f_E], with zero for the rows that left.
        let mut z = std::mem::take(&mut self.work_z);
        z.clear();
        z.resize(unknowns.global.len() + base, 0.0);
        for (l, &c) in unknowns.global.iter().enumerate() {
            z[self.position(l, unknowns)] = v[c];
        }
        for (t, &p) in stayed.iter().enumerate() {
            z[u + p] = v[n + t];
        }
        ldl.solve(&mut z[..u + base]);
        // g − Cᵀ z₀, then w = S⁻¹ (…) by the LU factors.
        let mut joined_slot = stayed.len();
        let mut w = std::mem::take(&mut self.work_g);
        w.clear();
        w.resize(c, 0.0);
        for (j, change) in self.changes.iter().enumerate() {
            let g = match change {
                Change::Joined { .. } => {
                    let g = v[n + joined_slot];
                    joined_slot += 1;
                    g
                }
                Change::Left { .. } => 0.0,
            };
            w[j] = g - Self::column_dot(u, change, &z);
        }
        let mut y = std::mem::take(&mut self.work_y);
        y.clear();
        y.extend(self.pivots.iter().map(|&p| w[p]));
        for i in 0..c {
            for k in 0..i {
                y[i] -= self.lu[i * c + k] * y[k];
            }
        }
        for i in (0..c).rev() {
            for k in i + 1..c {
                y[i] -= self.lu[i * c + k] * y[k];
            }
            y[i] /= self.lu[i * c + i];
        }
        // z = z₀ − W w.
        for (wj, column) in y.iter().zip(&self.w) {
            z.iter_mut().zip(column).for_each(|(zi, ci)| *zi -= wj * ci);
        }
        for (l, &c) in unknowns.global.iter().enumerate() {
            v[c] = z[self.position(l, unknowns)];
        }
        for (t, &p) in stayed.iter().enumerate() {
            v[n + t] = z[u + p];
        }
        let mut slot = stayed.len();
        for (j, change) in self.changes.iter().enumerate() {
            if let Change::Joined { .. } = change {
                v[n + slot] = y[j];
                slot += 1;
            }
        }
        (self.stayed, self.work_z, self.work_g, self.work_y) = (stayed, z, w, y);
    }
}

/// The upper triangle of `K_δ` for the support's `rows` (columns sorted) on `unknowns`, by
/// columns.
fn kkt_matrix(rows: &MergedRows, unknowns: &Unknowns) -> CscMatrix {
    let u = unknowns.base;
    let k = rows.len();
    let nnz = u + k + rows.entries.len();
    let mut colptr = Vec::with_capacity(u + k + 1);
    let mut rowval = Vec::with_capacity(nnz);
    let mut nzval = Vec::with_capacity(nnz);
    colptr.push(0);
    for j in 0..u {
        rowval.push(j);
        nzval.push(1.0);
        colptr.push(rowval.len());
    }
    for (t, row) in rows.iter().enumerate() {
        // Local indices keep the order of the global ones: the column stays sorted.
        for &(c, a) in row {
            rowval.push(unknowns.local[c]);
            nzval.push(a);
        }
        rowval.push(u + t);
        nzval.push(-DELTA);
        colptr.push(rowval.len());
    }
    CscMatrix::new(u + k, u + k, colptr, rowval, nzval)
}

impl ActiveSystem {
    /// `out = K₀ v`.
    fn apply(&self, v: &[f64], out: &mut [f64]) {
        let n = self.n;
        out[..n].copy_from_slice(&v[..n]);
        for (t, row) in self.rows.iter().enumerate() {
            let mu = v[n + t];
            let mut ad = 0.0;
            for &(c, a) in row {
                out[c] += a * mu;
                ad += a * v[c];
            }
            out[n + t] = ad;
        }
    }

    /// Iterative refinement of `K₀ v = rhs` from `v`, until the residual is below `tol`
    /// (relative to `max(1, ‖rhs‖∞)`), the first block of `v` stops moving by more than that,
    /// or [`REFINE_STEPS`] steps; with `least_squares`, a refinement that ends unsolved is
    /// followed by [`Self::least_squares`], whose answer replaces it when it solves the
    /// equations. `None` when the numbers stop being finite.
    fn refine(
        &mut self,
        rhs: &[f64],
        v: &mut [f64],
        tol: f64,
        least_squares: bool,
    ) -> Option<Refined> {
        let mut kv = std::mem::take(&mut self.scratch.product);
        let mut step = std::mem::take(&mut self.scratch.step);
        kv.resize(rhs.len(), 0.0);
        step.resize(rhs.len(), 0.0);
        let refined = self.refine_with(rhs, v, &mut kv[..rhs.len()], &mut step[..rhs.len()], tol);
        (self.scratch.product, self.scratch.step) = (kv, step);
        match refined {
            Some(refined) if least_squares && refined.stalled => {
                // Tried on a copy: the refinement's answer stands when this one does not
                // solve the equations either (on inconsistent ones its residual is the ray
                // the method follows, as it always was).
                let mut w = v.to_vec();
                match self.least_squares(rhs, &mut w, tol) {
                    Some(better) if better.solved => {
                        v.copy_from_slice(&w);
                        Some(better)
                    }
                    _ => Some(refined),
                }
            }
            other => other,
        }
    }

    /// [`Self::refine`] with the work vectors `kv` and `step` (as long as `rhs`).
    fn refine_with(
        &mut self,
        rhs: &[f64],
        v: &mut [f64],
        kv: &mut [f64],
        step: &mut [f64],
        tol: f64,
    ) -> Option<Refined> {
        let n = self.n;
        let scale = rhs.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
        if !scale.is_finite() {
            return None;
        }
        let tol = tol * scale;
        let mut steps = 0;
        let mut last_moved = f64::INFINITY;
        let mut stalled = false;
        loop {
            self.apply(v, kv);
            let first = residual_into(&mut step[..n], &rhs[..n], &kv[..n]);
            let second = residual_into(&mut step[n..], &rhs[n..], &kv[n..]);
            if first.is_nan() || second.is_nan() {
                return None;
            }
            let solved = first.max(second) <= tol;
            if solved || steps == REFINE_STEPS {
                return Some(Refined {
                    second,
                    solved,
                    stalled: !solved && stalled,
                    residual: step[n..].to_vec(),
                });
            }
            self.solve_in_place(step);
            let moved = step[..n]
                .iter()
                .fold(0.0, |acc: f64, s| max_or_nan(acc, s.abs()));
            v.iter_mut().zip(step.iter()).for_each(|(vi, si)| *vi += si);
            steps += 1;
            // Slow progress of a first block still moving: a nearly dependent direction (or
            // the cap).
            stalled = moved > tol
                && (steps == REFINE_STEPS
                    || (steps >= 2 && moved > REFINE_CONTRACTION * last_moved));
            if moved <= tol || (steps >= 2 && moved > REFINE_CONTRACTION * last_moved) {
                // The first block has converged, or converges too slowly to be worth it: the
                // equations are inconsistent (or nearly so, rows nearly dependent), the
                // residual will be the ray along which the method drops a row, and the answer
                // of the method is checked anyway. One more pass measures the residual.
                steps = REFINE_STEPS;
            }
            last_moved = moved;
        }
    }
}

impl ActiveSystem {
    /// `out = A_Pᵀ μ`, by unknown of the problem.
    fn transposed_times(&self, mu: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.n, 0.0);
        for (row, m) in self.rows.iter().zip(mu) {
            for &(c, a) in row {
                out[c] += a * m;
            }
        }
    }

    /// `out = g − A_P (f + A_Pᵀ μ)`, by row of the support, with `d = f + A_Pᵀ μ` left in
    /// `d`: the second block of the residual of `K₀ [d; −μ] = [f; g]`, whose first block is
    /// then zero.
    fn support_residual(
        &self,
        f: &[f64],
        g: &[f64],
        mu: &[f64],
        d: &mut Vec<f64>,
        out: &mut Vec<f64>,
    ) {
        self.transposed_times(mu, d);
        d.iter_mut().zip(f).for_each(|(di, fi)| *di += fi);
        out.clear();
        out.extend(
            self.rows
                .iter()
                .zip(g)
                .map(|(row, gi)| gi - row.iter().map(|&(c, a)| a * d[c]).sum::<f64>()),
        );
    }

    /// The support's equations `A_P d = g` with `d = f + A_Pᵀμ` (the system `K₀ [d; −μ] =
    /// [f; g]`), solved in the least-squares sense by conjugate gradients from the `μ` of
    /// `v = [d; −μ]`: on `G Δ = ρ` (`G = A_P A_Pᵀ`, `ρ` the residual at `μ`, `μ ← μ + Δ`),
    /// preconditioned by `(G + δI)⁻¹ G (G + δI)⁻¹`, two solves with the factor. On a singular
    /// vector of `A_P` the preconditioned `G` is `σ⁴/(σ² + δ)²`: near 1 where refinement was
    /// fast, still well away from zero where it stalled (`σ² ≈ δ`), and zero on dependent rows,
    /// which the preconditioner does not amplify (the plain `(G + δI)⁻¹` would, by `1/δ`, and
    /// the method then diverges on inconsistent equations). So the steps stay in the range of
    /// `G`: `μ` moves to the multipliers nearest it that solve the equations, as refinement's,
    /// and on inconsistent equations the residual tends to its part orthogonal to the rows.
    /// At most [`LEAST_SQUARES_STEPS`] steps; `None` when the numbers stop being finite.
    fn least_squares(&mut self, rhs: &[f64], v: &mut [f64], tol: f64) -> Option<Refined> {
        let n = self.n;
        let scale = rhs.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
        let tol = tol * scale;
        let (f, g) = rhs.split_at(n);
        let mut mu: Vec<f64> = v[n..].iter().map(|w| -w).collect();
        let mut scratch = std::mem::take(&mut self.scratch);
        let Scratch {
            by_unknown: d,
            residual: rho,
            preconditioned: z,
            direction: p,
            product_g: q,
            step: solved,
            ..
        } = &mut scratch;
        self.support_residual(f, g, &mu, d, rho);
        p.clear();
        p.resize(mu.len(), 0.0);
        let mut rz_before = 0.0;
        let mut finite = true;
        for step in 0..LEAST_SQUARES_STEPS {
            let r = rho.iter().fold(0.0, |acc: f64, v| max_or_nan(acc, v.abs()));
            if r.is_nan() {
                finite = false;
                break;
            }
            if r <= tol {
                break;
            }
            // z = (G + δI)⁻¹ G (G + δI)⁻¹ ρ: K_δ [u; ·] = [0; ρ] has u = A_Pᵀ(G + δI)⁻¹ρ, and
            // K_δ [·; w] = [u; 0] has w = (G + δI)⁻¹ A_P u.
            solved.clear();
            solved.resize(n, 0.0);
            solved.extend_from_slice(rho);
            self.solve_in_place(solved);
            solved[n..].iter_mut().for_each(|x| *x = 0.0);
            self.solve_in_place(solved);
            z.clear();
            z.extend_from_slice(&solved[n..]);
            let rz: f64 = rho.iter().zip(z.iter()).map(|(a, b)| a * b).sum();
            if rz.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                // ρ is orthogonal to the rows: least squares reached (or rounding, or NaN).
                break;
            }
            let beta = if step == 0 { 0.0 } else { rz / rz_before };
            p.iter_mut()
                .zip(z.iter())
                .for_each(|(pi, zi)| *pi = zi + beta * *pi);
            rz_before = rz;
            // q = G p = A_P (A_Pᵀ p).
            self.transposed_times(p, d);
            q.clear();
            q.extend(
                self.rows
                    .iter()
                    .map(|row| row.iter().map(|&(c, a)| a * d[c]).sum::<f64>()),
            );
            let pq: f64 = p.iter().zip(q.iter()).map(|(a, b)| a * b).sum();
            if pq.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                break;
            }
            let alpha = rz / pq;
            mu.iter_mut()
                .zip(p.iter())
                .for_each(|(m, pi)| *m += alpha * pi);
            rho.iter_mut()
                .zip(q.iter())
                .for_each(|(r, qi)| *r -= alpha * qi);
        }
        // The residual measured afresh, not as the recurrence left it.
        self.support_residual(f, g, &mu, d, rho);
        let second = rho.iter().fold(0.0, |acc: f64, v| max_or_nan(acc, v.abs()));
        finite &= !second.is_nan() && d.iter().all(|x| x.is_finite());
        let refined = finite.then(|| {
            v[..n].copy_from_slice(d);
            v[n..].iter_mut().zip(&mu).for_each(|(w, m)| *w = -m);
            Refined {
                second,
                solved: second <= tol,
                stalled: false,
                residual: rho.clone(),
            }
        });
        self.scratch = scratch;
        refined
    }
}

/// `step = rhs − kv`, returning `‖step‖∞`, NaN when an entry is (`f64::max` would pass over
/// it, and a refinement whose iterate had gone NaN read as solved).
///
/// Four running maxima, not one: with one, each `max` waits on the one before, and this loop
/// runs over every unknown of the block at every refinement step. The maximum is the same in
/// any order.
fn residual_into(step: &mut [f64], rhs: &[f64], kv: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let mut nan = false;
    let mut steps = step.chunks_exact_mut(4);
    let (mut rhs4, mut kv4) = (rhs.chunks_exact(4), kv.chunks_exact(4));
    for ((st, r), k) in (&mut steps).zip(&mut rhs4).zip(&mut kv4) {
        for j in 0..4 {
            st[j] = r[j] - k[j];
            nan |= st[j].is_nan();
            lanes[j] = lanes[j].max(st[j].abs());
        }
    }
    let rest = steps.into_remainder();
    for ((st, r), k) in rest.iter_mut().zip(rhs4.remainder()).zip(kv4.remainder()) {
        *st = r - k;
        nan |= st.is_nan();
        lanes[0] = lanes[0].max(st.abs());
    }
    if nan {
        f64::NAN
    } else {
        lanes[0].max(lanes[1]).max(lanes[2].max(lanes[3]))
    }
}

/// Checks the Farkas certificate `e ≥ 0`, `A_Pᵀe = 0`, `eᵀr_P > 0` of an empty polyhedron,
/// with room for rounding relative to the size of the numbers involved.
fn farkas(problem: &ProjectionProblem, support: &[usize], e: &[f64], r: &[f64]) -> bool {
    let emax = e.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
    if emax == 0.0 || !emax.is_finite() || e.iter().any(|&v| v < -1e-12 * emax) {
        return false;
    }
    let mut ate = vec![0.0; problem.dim()];
    let mut amax: f64 = 0.0;
    for (&i, &ei) in support.iter().zip(e) {
        for (c, v) in problem.a().row(i) {
            ate[c] += v * ei.max(0.0);
            amax = amax.max(v.abs());
        }
    }
    let ate_max = ate.iter().fold(0.0, |acc: f64, v| acc.max(v.abs()));
    let er: f64 = support
        .iter()
        .zip(e)
        .map(|(&i, &ei)| ei.max(0.0) * r[i])
        .sum();
    let rmax = support.iter().fold(0.0, |acc: f64, &i| acc.max(r[i].abs()));
    // Aᵀe vanishes to rounding while eᵀr is clearly positive: no x can satisfy eᵀA x ≥ eᵀb.
    ate_max <= 1e-9 * emax * amax.max(1.0) * (support.len() as f64).sqrt()
        && er > 1e-6 * emax * rmax
}

/// Runs the method from `start` for at most `cap` iterations. See the module
/// documentation.
pub fn solve(problem: &ProjectionProblem, start: Start, cap: u32) -> Result<Outcome, Failure> {
    solve_with(problem, start, cap, None)
}

/// [`solve`], its sparse factorizations ordered from (and remembered in) `orderings` when
/// `problem` carries row keys; `unknowns[j]` names unknown `j` of `problem` (its index in the
/// whole problem when `problem` is one of its blocks). See [`Orderings`]. Without one name
/// per unknown, it is [`solve`]: an ordering only saves time, so none is guessed.
pub fn solve_remembering(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    orderings: &mut Orderings,
    unknowns: &[usize],
) -> Result<Outcome, Failure> {
    let memory = (unknowns.len() == problem.dim()).then_some(Remembered {
        orderings,
        unknowns,
    });
    solve_with(problem, start, cap, memory)
}

/// [`solve_remembering`] without the second pass: the answer of the tests at `1e-12`, which
/// on a sliver of a feasible set can lie `1e-8` from the projection (the engine checks such
/// answers against its interior point's before it keeps them).
pub fn first_pass_remembering(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    orderings: &mut Orderings,
    unknowns: &[usize],
) -> Result<Outcome, Failure> {
    let mut memory = (unknowns.len() == problem.dim()).then_some(Remembered {
        orderings,
        unknowns,
    });
    let first = run_pass(problem, start, cap, FIRST_PASS, memory.as_mut(), None, None)?;
    Ok(first.outcome)
}

/// The method at [`ACTIVE_TOL`], then, when its answer leaves a row violated or the support's
/// equations unsolved by more than [`SECOND_PASS_TOL`], a second pass (see [`second_pass`]).
fn solve_with(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    mut memory: Option<Remembered<'_>>,
) -> Result<Outcome, Failure> {
    let first = run_pass(problem, start, cap, FIRST_PASS, memory.as_mut(), None, None)?;
    Ok(second_pass(problem, first, cap, memory.as_mut()))
}

/// What [`run_pass`] converged to.
struct Finished {
    outcome: Outcome,
    /// The factorization of the last iteration.
    held: Option<ActiveSystem>,
    /// Whether the answer leaves a row violated, or a row of its support not tight, by more
    /// than [`SECOND_PASS_TOL`] (relative, as [`ACTIVE_TOL`]).
    needs_second_pass: bool,
    /// By how much, absolutely: the largest violation of a row, or gap of a row of the
    /// support.
    off: f64,
}

/// The iterate of a second pass that was off by least so far, as [`Finished::off`] measures
/// it, with its answer: every row of its support solved and every multiplier non-negative (to
/// the pass's tolerance), so certified to that `off`.
type Best = Option<(f64, Outcome)>;

/// The answer of the method at [`ACTIVE_TOL`], finished at [`SECOND_PASS_TOL`] when it is off
/// by more than that: from its own support, the most violated row joining alone, for at most
/// `cap` iterations (the first pass's own cap), through the factorization of its last
/// iteration, bordered. When the pass does not converge (it runs out, or cycles: it does not
/// restart from an empty support as the first pass does, since from there it would need as
/// many iterations as the answer has rows), it is run again from the same start at the next
/// tolerance of [`FINISH_LADDER`]. When one converges above `1e-15`, the
/// tolerances below it are tried again in turn, each from the answer kept so far, closer to
/// the projection than the first, until one does not converge. When none converges at
/// `1e-15`, the answer is the first, a pass's answer or a pass's best iterate ([`Best`]),
/// whichever is off by least, marked
/// [`Outcome::unfinished`]: on a jam, rows that the data make dependent on the support and
/// inconsistent with it by a few units in the last place of `b` can keep joining and leaving
/// at `1e-15`, and the pass's iterates between them are then still far nearer the projection
/// than the first answer.
///
/// On a jam with more tight rows than unknowns the feasible set is a sliver around the
/// projection, and a point that violates a row, or solves its support's equations, only to
/// `1e-12` can be `1e-8` from the projection, and two answers from different supports that
/// far apart. Finished from each, both come to the same point. The whole method at a tighter
/// tolerance finishes fewer jams, hence a second pass from an answer rather than a tighter
/// tolerance throughout; and the pass gets the first pass's cap, since a short fixed cap
/// leaves the larger jams as they were (measured: `docs/lab/2026-11-24-second-pass-1e-13.md`).
fn second_pass(
    problem: &ProjectionProblem,
    first: Finished,
    cap: u32,
    mut memory: Option<&mut Remembered<'_>>,
) -> Outcome {
    let Finished {
        outcome: first,
        mut held,
        needs_second_pass,
        off,
    } = first;
    if !needs_second_pass {
        return first;
    }
    // In the factored support's order, so that the pass borders that factorization.
    let order = held.as_ref().map(|h| h.support.as_slice());
    let start = start_at_answer(&first, order);
    // The answer off by least so far: the first, or a later pass's best iterate or answer.
    let mut spent = first.iterations;
    let mut kept: (f64, Outcome) = (off, first);
    let keep_if_less = |kept: &mut (f64, Outcome), candidate: Option<(f64, Outcome)>| {
        if let Some(candidate) = candidate.filter(|(off, _)| *off < kept.0) {
            *kept = candidate;
        }
    };
    // Up the ladder, each rung from the first answer, until a pass converges.
    let mut converged = None;
    for (rung, &tolerance) in FINISH_LADDER.iter().enumerate() {
        let held = if rung == 0 { held.take() } else { None };
        let pass = finishing_pass(
            problem,
            start.clone(),
            cap,
            tolerance,
            memory.as_deref_mut(),
            held,
            &mut spent,
        );
        match pass {
            // Finished at the second pass's own tests.
            Ok((_, second)) if rung == 0 => {
                return Outcome {
                    iterations: spent,
                    ..second
                }
            }
            Ok(second) => {
                keep_if_less(&mut kept, Some(second));
                converged = Some(rung);
                break;
            }
            Err(best) => keep_if_less(&mut kept, best),
        }
    }
    // Down again: the rungs below the one that converged, each from the answer kept so far,
    // which is closer to the projection than the first answer: a lower rung that cycles from
    // the first answer can converge from there (measured:
    // `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
    for rung in (0..converged.unwrap_or(0)).rev() {
        let pass = finishing_pass(
            problem,
            start_at_answer(&kept.1, None),
            cap,
            FINISH_LADDER[rung],
            memory.as_deref_mut(),
            None,
            &mut spent,
        );
        match pass {
            Ok((_, lower)) if rung == 0 => {
                return Outcome {
                    iterations: spent,
                    ..lower
                }
            }
            Ok(lower) => keep_if_less(&mut kept, Some(lower)),
            Err(best) => {
                keep_if_less(&mut kept, best);
                break;
            }
        }
    }
    Outcome {
        iterations: spent,
        unfinished: Some(kept.0),
        ..kept.1
    }
}

/// One pass of the finishing ladder at `tolerance` from `start` (see [`second_pass`]), its
/// iterations added to `spent`: its answer and how far off it is when it converges, otherwise
/// its best iterate ([`Best`]) when it ran out or cycled, `None` when it failed otherwise
/// (whose iterations are not counted).
fn finishing_pass(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    tolerance: f64,
    memory: Option<&mut Remembered<'_>>,
    held: Option<ActiveSystem>,
    spent: &mut u32,
) -> Result<(f64, Outcome), Best> {
    let mut best: Best = None;
    let pass = run_pass(
        problem,
        start,
        cap,
        Tolerances {
            active: tolerance,
            refine: tolerance,
            ..SECOND_PASS
        },
        memory,
        held,
        Some(&mut best),
    );
    match pass {
        Ok(Finished { outcome, off, .. }) => {
            *spent = spent.saturating_add(outcome.iterations);
            Ok((off, outcome))
        }
        Err(Failure::Cap(n) | Failure::Cycling(n)) => {
            *spent = spent.saturating_add(n);
            Err(best)
        }
        Err(_) => Err(None),
    }
}

/// A second pass's start from an answer: the rows with a positive multiplier (in `order`
/// when given, the order of a factorization the pass can border, otherwise by index), the
/// most violated row joining alone, and every row's multiplier as it stands (or the smallest
/// positive number) if it joins.
fn start_at_answer(answer: &Outcome, order: Option<&[usize]>) -> Start {
    let order = order.map_or_else(|| (0..answer.lambda.len()).collect(), <[usize]>::to_vec);
    let support: Vec<usize> = order
        .into_iter()
        .filter(|&i| answer.lambda[i] > 0.0)
        .collect();
    Start {
        lambda: support.iter().map(|&i| answer.lambda[i]).collect(),
        support,
        join: answer
            .lambda
            .iter()
            .map(|l| l.max(f64::MIN_POSITIVE))
            .collect(),
        join_at_most: Some(1),
    }
}

/// The method from `start`, for at most `cap` iterations, with the tests of `pass`, its first
/// iteration bordering `held` when it can. The answer comes with the factorization of its
/// last iteration and whether it needs a second pass.
#[cfg(test)]
fn run(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    pass: Tolerances,
    memory: Option<&mut Remembered<'_>>,
    held: Option<ActiveSystem>,
) -> Result<Finished, Failure> {
    run_pass(problem, start, cap, pass, memory, held, None)
}

/// The method from `start`, for at most `cap` iterations, with the tests of `pass`, its first
/// iteration bordering `held` when it can, and keeping in `best`, when given, the iterate off
/// by least ([`Best`]).
fn run_pass(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    pass: Tolerances,
    mut memory: Option<&mut Remembered<'_>>,
    mut held: Option<ActiveSystem>,
    mut best: Option<&mut Best>,
) -> Result<Finished, Failure> {
    let (m, n) = (problem.n_rows(), problem.dim());
    let r = problem.shortfall(problem.y());
    if r.iter().any(|v| !v.is_finite()) {
        return Err(Failure::Numerical("b − A y overflows"));
    }
    let Start {
        mut support,
        mut lambda,
        join,
        join_at_most,
    } = start;
    let scale = r.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
    let tol = pass.active * scale;
    // d = A_Pᵀλ: the displacement the starting multipliers describe.
    let mut d = vec![0.0; n];
    for (&i, &l) in support.iter().zip(&lambda) {
        for (c, v) in problem.a().row(i) {
            d[c] += v * l;
        }
    }
    // Every negative row leaves at once on the first pass, unless rows join one at a time:
    // from an interior point's guess on a jam, whose first solves are near inconsistent, that
    // pass drops hundreds of rows and the method runs out of iterations taking them back one
    // by one (measured: `docs/lab/2026-11-24-hard-blocks-door-queues.md`).
    let mut aggressive = join_at_most.is_none();
    // Set when the method restarted as Lawson–Hanson proper: from an empty support, one row
    // (the steepest) joining at a time, starting at a zero multiplier.
    let mut proper = false;
    // Set when a pass that does not restart cycled: from then on, the lowest-numbered row
    // joins, and of the rows a step would drop at (nearly) the same point the
    // lowest-numbered leaves (Bland's rule).
    let mut bland = false;
    let mut visits = Visits::default();
    let mut in_support = vec![false; m];
    let mut ad = vec![0.0; m];
    // Work vectors of every iteration, kept from one to the next: `[0; r_P]`, `[d; −λ]` (then
    // the solution), `μ`, and the rows the point violates.
    let (mut rhs, mut v, mut mu, mut violated) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // The system of the previous iteration (`held`), carried to the next support by
    // bordering.
    for iterations in 1..=cap {
        if visits.count(&support) >= REPEATS {
            if proper || bland {
                return Err(Failure::Cycling(iterations));
            }
            if pass.restarts {
                // The warm, many-rows-at-once variant cycled (heavily dependent rows): restart
                // as Lawson–Hanson proper, which terminates finitely in exact arithmetic.
                proper = true;
                aggressive = false;
                visits.clear();
                support.clear();
                lambda.clear();
                d.iter_mut().for_each(|v| *v = 0.0);
                held = None;
            } else {
                // A second pass, from a support near the answer, goes on from where it is
                // under Bland's rule (from an empty support it would need as many
                // iterations as the answer has rows).
                bland = true;
                visits.clear();
            }
        }
        let reused = held.take().and_then(|h| h.bordered_to(problem, &support));
        let mut system = match reused {
            Some(system) => system,
            // A fresh factorization is ordered by AMD, or as its nodes were ordered last
            // (`Orderings`, with `memory`), not from an ordering of the whole block restricted
            // to each working set: with bordering most iterations do not factor, and ordering
            // the whole block costs more than it saves.
            None => ActiveSystem::new(problem, &support, memory.as_deref_mut())
                .ok_or(Failure::Numerical("factorization"))?,
        };
        let k = support.len();
        rhs.clear();
        rhs.resize(n, 0.0);
        rhs.extend(support.iter().map(|&i| r[i]));
        v.clear();
        v.extend_from_slice(&d);
        v.extend(lambda.iter().map(|l| -l));
        let refined = system
            .refine(&rhs, &mut v, pass.refine, pass.least_squares)
            .ok_or(Failure::Numerical("refinement"))?;
        held = Some(system);
        d.copy_from_slice(&v[..n]);
        mu.clear();
        mu.extend(v[n..].iter().map(|v| -v));

        if !refined.solved && refined.second > tol {
            // Inconsistent: follow the ray λ + t e until an entry reaches zero.
            let e = &refined.residual;
            let Some((blocking, t)) = blocking_row(
                lambda
                    .iter()
                    .zip(e)
                    .enumerate()
                    .filter(|(_, (_, ei))| **ei < 0.0)
                    .map(|(j, (l, ei))| (j, l / -ei)),
                &support,
                bland,
            ) else {
                return Err(if farkas(problem, &support, e, &r) {
                    Failure::Infeasible { rows: support }
                } else {
                    Failure::Numerical("unbounded ray without an infeasibility certificate")
                });
            };
            let step: Vec<f64> = lambda.iter().zip(e).map(|(l, ei)| l + t * ei).collect();
            (support, lambda) = shrink(&support, &step, blocking);
            // The point of the smaller support is recomputed from its multipliers.
            continue;
        }
        if !d.iter().chain(&mu).all(|v| v.is_finite()) {
            return Err(Failure::Numerical("non-finite step"));
        }

        // Negative multipliers (beyond rounding): rows leave the support.
        if let Some(smaller) = drop_negative(&support, &lambda, &mu, tol, aggressive, bland)? {
            (support, lambda) = smaller;
            continue;
        }
        lambda.clear();
        lambda.extend(mu.iter().map(|m| m.max(f64::MIN_POSITIVE)));

        // Rows outside the support that the point violates join it.
        problem.a().mul_vec(&d, &mut ad);
        in_support.iter_mut().for_each(|s| *s = false);
        support.iter().for_each(|&i| in_support[i] = true);
        violated.clear();
        violated.extend((0..m).filter(|&i| !in_support[i] && r[i] - ad[i] > tol));
        if violated.is_empty() {
            let (off, outcome) = answer_at(problem, &d, &support, &mu, &r, &ad, iterations);
            return Ok(Finished {
                outcome,
                held,
                needs_second_pass: off > SECOND_PASS_TOL * scale,
                off,
            });
        }
        if let Some(best) = best.as_deref_mut() {
            let (off, outcome) = answer_at(problem, &d, &support, &mu, &r, &ad, iterations);
            if best.as_ref().is_none_or(|(least, _)| off < *least) {
                *best = Some((off, outcome));
            }
        }
        // From now on, drop one row at a time: dropping every negative row at once could
        // cycle with adding them back.
        aggressive = false;
        // Joining rows go last: the factored system then only has rows appended.
        let violation = |i: usize| r[i] - ad[i];
        let joining = if bland {
            // Bland's rule: the lowest-numbered violated row (`violated` is in increasing order).
            vec![(violated[0], join[violated[0]].max(f64::MIN_POSITIVE))]
        } else {
            joining_rows(&violated, violation, &join, proper, join_at_most)?
        };
        support.extend(joining.iter().map(|&(i, _)| i));
        lambda.extend(joining.iter().map(|&(_, l)| l));
        debug_assert!(support.len() > k);
    }
    Err(Failure::Cap(cap))
}

/// The iterate `y + d` with the multipliers `μ` of `support` as an answer, and how far off it
/// is ([`Finished::off`]): the largest violation of a row, or gap of a row keeping a positive
/// multiplier, from `r` and `A d` as the iteration left them (no product with `A`).
fn answer_at(
    problem: &ProjectionProblem,
    d: &[f64],
    support: &[usize],
    mu: &[f64],
    r: &[f64],
    ad: &[f64],
    iterations: u32,
) -> (f64, Outcome) {
    let x: Vec<f64> = problem.y().iter().zip(d).map(|(y, d)| y + d).collect();
    let mut full = vec![0.0; problem.n_rows()];
    support
        .iter()
        .zip(mu)
        .for_each(|(&i, &l)| full[i] = l.max(0.0));
    let off = r
        .iter()
        .zip(ad)
        .zip(&full)
        .map(|((ri, adi), l)| {
            let gap = ri - adi;
            if *l > 0.0 {
                gap.abs()
            } else {
                gap
            }
        })
        .fold(0.0, f64::max);
    let outcome = Outcome {
        x,
        lambda: full,
        iterations,
        unfinished: None,
    };
    (off, outcome)
}

/// How often each support (a set of rows) has been factored in one run of the method.
///
/// Sorting and hashing every support to count it would cost more than the count is worth
/// (measured: `docs/lab/2026-11-25-one-ldl-code.md`): a support is found by a fingerprint
/// that does not depend on the order of its rows, and sorted only when the fingerprint has
/// been seen before (to tell a repeat from a collision).
#[derive(Debug, Default)]
struct Visits {
    /// By fingerprint: the supports seen with it (sorted once a later one shares it) and
    /// their counts.
    seen: FastMap<u64, Vec<(Vec<usize>, bool, u32)>>,
}

impl Visits {
    /// Counts one more visit of `support` and returns its number of visits.
    fn count(&mut self, support: &[usize]) -> u32 {
        let fingerprint = support
            .iter()
            .fold(0u64, |acc, &i| acc.wrapping_add(mix(i as u64)));
        let same = self.seen.entry(fingerprint).or_default();
        if !same.is_empty() {
            let mut key = support.to_vec();
            key.sort_unstable();
            for (other, sorted, count) in same.iter_mut() {
                if !*sorted {
                    other.sort_unstable();
                    *sorted = true;
                }
                if *other == key {
                    *count += 1;
                    return *count;
                }
            }
            same.push((key, true, 1));
        } else {
            same.push((support.to_vec(), false, 1));
        }
        1
    }

    fn clear(&mut self) {
        self.seen.clear();
    }
}

/// SplitMix64's finalizer: a row index spread over 64 bits, so that sums of them collide
/// rarely.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A support (row indices, increasing) and a positive multiplier per row.
type Support = (Vec<usize>, Vec<f64>);

/// When some multiplier `μ` of the support is negative beyond rounding, the smaller support
/// and its multipliers: every such row at once (`aggressive`, before any row has joined), or
/// Lawson–Hanson's step from `λ` toward `μ` until the first entry reaches zero. `None` when
/// every `μ` is non-negative.
fn drop_negative(
    support: &[usize],
    lambda: &[f64],
    mu: &[f64],
    tol: f64,
    aggressive: bool,
    bland: bool,
) -> Result<Option<Support>, Failure> {
    let floor = -tol * mu.iter().fold(1.0, |acc: f64, m| acc.max(m.abs()));
    if !mu.iter().any(|&m| m < floor) {
        return Ok(None);
    }
    if aggressive {
        return Ok(Some(
            support
                .iter()
                .zip(mu)
                .filter(|(_, &m)| m >= floor)
                .map(|(&i, &m)| (i, m.max(f64::MIN_POSITIVE)))
                .unzip(),
        ));
    }
    let (blocking, alpha) = blocking_row(
        lambda
            .iter()
            .zip(mu)
            .enumerate()
            .filter(|(_, (_, m))| **m < 0.0)
            .map(|(j, (l, m))| (j, l / (l - m))),
        support,
        bland,
    )
    .ok_or(Failure::Numerical("no blocking multiplier"))?;
    let step: Vec<f64> = lambda
        .iter()
        .zip(mu)
        .map(|(l, m)| l + alpha * (m - l))
        .collect();
    Ok(Some(shrink(support, &step, blocking)))
}

/// The violated rows that join the support, with their starting multipliers: all of them
/// (or the `at_most` most violated, in the order of `violated`) from their remembered
/// multipliers, or (Lawson–Hanson `proper`) only the steepest descent direction of the dual,
/// the largest `violation`, from zero.
/// Of the rows `(position in the support, step at which its multiplier reaches zero)`, the one
/// that blocks a step, and the step: the first smallest, or under Bland's rule, of those that
/// reach zero within [`BLAND_TIE`] (relative) of the smallest, the lowest-numbered row.
fn blocking_row(
    candidates: impl Iterator<Item = (usize, f64)>,
    support: &[usize],
    bland: bool,
) -> Option<(usize, f64)> {
    if !bland {
        return candidates.min_by(|a, b| a.1.total_cmp(&b.1));
    }
    let candidates: Vec<(usize, f64)> = candidates.collect();
    let least = candidates.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    candidates
        .iter()
        .filter(|c| c.1 <= least * (1.0 + BLAND_TIE))
        .min_by_key(|c| support[c.0])
        .map(|c| (c.0, least))
}

fn joining_rows(
    violated: &[usize],
    violation: impl Fn(usize) -> f64,
    join: &[f64],
    proper: bool,
    at_most: Option<usize>,
) -> Result<Vec<(usize, f64)>, Failure> {
    if proper {
        let steepest = violated
            .iter()
            .copied()
            .max_by(|&a, &b| violation(a).total_cmp(&violation(b)))
            .ok_or(Failure::Numerical("no steepest row"))?;
        return Ok(vec![(steepest, f64::MIN_POSITIVE)]);
    }
    let most_violated: Vec<usize>;
    let joining = match at_most.filter(|&k| k < violated.len()) {
        Some(k) => {
            // The most violated first (ties by index), then back in the order of `violated`.
            let mut chosen = violated.to_vec();
            chosen.sort_by(|&a, &b| violation(b).total_cmp(&violation(a)).then(a.cmp(&b)));
            chosen.truncate(k);
            chosen.sort_unstable();
            most_violated = chosen;
            &most_violated[..]
        }
        None => violated,
    };
    Ok(joining
        .iter()
        .map(|&i| (i, join[i].max(f64::MIN_POSITIVE)))
        .collect())
}

/// The support without its entry `blocking` and without any entry that `lambda` leaves
/// non-positive, with the remaining multipliers.
fn shrink(support: &[usize], lambda: &[f64], blocking: usize) -> (Vec<usize>, Vec<f64>) {
    support
        .iter()
        .zip(lambda)
        .enumerate()
        .filter(|&(j, (_, &l))| j != blocking && l > 0.0)
        .map(|(_, (&i, &l))| (i, l))
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::SparseRows;

    /// `x₀ + x₁ ≥ 1`, `−x₀ ≥ 0`, `−x₁ ≥ 0` (empty) and `x₀ ≥ 0.5` (feasible on its own).
    fn problem() -> (ProjectionProblem, Vec<f64>) {
        let a = SparseRows::from_rows(
            2,
            &[
                vec![(0, 1.0), (1, 1.0)],
                vec![(0, -1.0)],
                vec![(1, -1.0)],
                vec![(0, 1.0)],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 0.0, 0.0, 0.5]).unwrap();
        // r = b − A y with y = 0.
        let r = p.b().to_vec();
        (p, r)
    }

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

    /// The start from the rows `support`, each at multiplier 1/2, any row joining at 1.
    fn start_from(support: Vec<usize>, m: usize) -> Start {
        Start {
            lambda: vec![0.5; support.len()],
            support,
            join: vec![1.0; m],
            join_at_most: None,
        }
    }

    #[test]
    fn a_support_is_counted_whatever_the_order_of_its_rows() {
        let mut visits = Visits::default();
        assert_eq!(visits.count(&[3, 1, 2]), 1);
        assert_eq!(visits.count(&[1, 2]), 1);
        assert_eq!(visits.count(&[1, 2, 3]), 2);
        assert_eq!(visits.count(&[2, 3, 1]), 3);
        assert_eq!(visits.count(&[2, 1]), 2);
        assert_eq!(visits.count(&[]), 1);
        visits.clear();
        assert_eq!(visits.count(&[1, 2, 3]), 1);
    }

    #[test]
    fn supports_sharing_a_fingerprint_are_told_apart() {
        // A support seen before under the fingerprint of {1, 2} (a collision, planted).
        let mut visits = Visits::default();
        let fingerprint = mix(1).wrapping_add(mix(2));
        visits
            .seen
            .insert(fingerprint, vec![(vec![7, 5, 6], false, 4)]);
        assert_eq!(visits.count(&[2, 1]), 1);
        assert_eq!(visits.count(&[1, 2]), 2);
        // The planted support was sorted to be compared, and keeps its count.
        let same = &visits.seen[&fingerprint];
        assert_eq!(same[0], (vec![5, 6, 7], true, 4));
        assert_eq!(same[1], (vec![1, 2], true, 2));
        // mix is SplitMix64's output (its published first three from seed 0)…
        let gamma = 0x9e37_79b9_7f4a_7c15u64;
        assert_eq!(mix(0), 0xe220_a839_7b1d_cdaf);
        assert_eq!(mix(gamma), 0x6e78_9e6a_a1b9_65f4);
        assert_eq!(mix(gamma.wrapping_mul(2)), 0x06c4_5d18_8009_454f);
        // …and spreads neighbouring rows: no two of the first thousand collide.
        let mut mixed: Vec<u64> = (0..1000).map(mix).collect();
        mixed.sort_unstable();
        mixed.dedup();
        assert_eq!(mixed.len(), 1000);
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
        let outcome = solve(&p, start_from(vec![0], 2), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0, 1], 2), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 2), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 2), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 21), 30).unwrap();
        assert!(outcome.x[1..].iter().all(|x| (x - 5e-13).abs() <= 1e-20));
        assert_eq!(outcome.iterations, 1 + 21);
        // Under a cap of 10 the pass runs out, at 1e-15, 1e-14 and 1e-13 (each row still
        // joins, 5e-13 exceeding all three), and the first answer stands, unfinished; the
        // count is every iteration spent.
        let capped = solve(&p, start_from(vec![0], 21), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 21), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 21), 10).unwrap();
        assert_eq!(outcome.x[0], 1.0);
        assert!(outcome.x[1..].iter().all(|x| *x == 0.0));
        assert_eq!(outcome.unfinished, Some(5e-15));
        // The first pass's iteration, the 10 at 1e-15, the 1 at 1e-14 and the 10 at 1e-15.
        assert_eq!(outcome.iterations, 1 + 10 + 1 + 10);
        // With room for the 20 rows the pass at 1e-15 finishes, and nothing is unfinished.
        let finished = solve(&p, start_from(vec![0], 21), 30).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 17), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 13), 6).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 21), 5).unwrap();
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
        let outcome = solve(&p, start_from(vec![0, 1], 2), 10).unwrap();
        assert_eq!(outcome.lambda, vec![0.0, 0.0]);
        assert!((outcome.x[0] - y).abs() <= 1e-16);
    }

    #[test]
    fn a_row_violated_by_exactly_the_second_tolerance_is_left_as_it_is() {
        // x₀ ≥ 1, and x₁ ≥ 1e-13 = SECOND_PASS_TOL, violated by exactly that at y = 0:
        // "more than" the tolerance is what starts a second pass.
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, SECOND_PASS_TOL]).unwrap();
        let outcome = solve(&p, start_from(vec![0], 2), 10).unwrap();
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
        let outcome = solve(&p, start_from(vec![0], 2), 10).unwrap();
        assert_eq!(outcome.x, vec![1.0]);
        assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() <= 1e-12);
    }

    #[test]
    fn farkas_accepts_a_certificate() {
        let (p, r) = problem();
        assert!(farkas(&p, &[0, 1, 2], &[1.0, 1.0, 1.0], &r));
        // Scaled, and with rounding-size negative entries.
        assert!(farkas(&p, &[0, 1, 2], &[3.0, 3.0, 3.0 - 1e-15], &r));
    }

    #[test]
    fn farkas_rejects_what_is_not_a_certificate() {
        let (p, r) = problem();
        // Aᵀe ≠ 0.
        assert!(!farkas(&p, &[0, 1, 2], &[1.0, 1.0, 0.5], &r));
        // A clearly negative weight.
        assert!(!farkas(&p, &[0, 1, 2], &[1.0, -1.0, 1.0], &r));
        // Zero, non-finite.
        assert!(!farkas(&p, &[0, 1, 2], &[0.0, 0.0, 0.0], &r));
        assert!(!farkas(&p, &[0, 1, 2], &[f64::NAN, 1.0, 1.0], &r));
        assert!(!farkas(&p, &[0, 1, 2], &[f64::INFINITY, 1.0, 1.0], &r));
        // Aᵀe = 0 but eᵀr < 0: rows −x₀ ≥ 0 and x₀ ≥ −1 (r = b − A·0 = (0, −1)) can both
        // hold.
        let r2 = vec![1.0, 0.0, 0.0, -1.0];
        assert!(!farkas(&p, &[1, 3], &[1.0, 1.0], &r2));
    }

    /// 40 unknowns, 34 rows of three entries each, clearly independent (`K_δ` is well
    /// conditioned, so a solve of it is accurate to rounding), and row 34, a copy of row 3.
    fn random_problem() -> ProjectionProblem {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let n = 40;
        // Row i has its own unknown i (entry 1) and two random ones (entries below ½); row 34
        // repeats row 3.
        let mut rows: Vec<Vec<(usize, f64)>> = (0..34)
            .map(|i| {
                let mut row = vec![(i, 1.0)];
                row.extend((0..2).map(|_| (rng.gen_range(0..n), rng.gen_range(-0.5..0.5))));
                row
            })
            .collect();
        rows.push(rows[3].clone());
        let a = SparseRows::from_rows(n, &rows);
        let y: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let b: Vec<f64> = (0..35).map(|_| rng.gen_range(-1.0..1.0)).collect();
        ProjectionProblem::new(y, a, b).unwrap()
    }

    /// The largest difference between the solutions of `K₀ v = rhs` for `support`
    /// (consistent: the rows are independent) refined from zero through a fresh sparse
    /// factorization and through `system`; both refinements must meet their tolerance.
    fn solve_gap(p: &ProjectionProblem, system: &mut ActiveSystem, support: &[usize]) -> f64 {
        let size = p.dim() + support.len();
        let rhs: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut fresh = ActiveSystem::sparse(p, support).unwrap();
        let (mut a, mut b) = (vec![0.0; size], vec![0.0; size]);
        assert!(
            fresh
                .refine(&rhs, &mut a, REFINE_TOL, false)
                .unwrap()
                .solved
        );
        assert!(
            system
                .refine(&rhs, &mut b, REFINE_TOL, false)
                .unwrap()
                .solved
        );
        max_difference(&a, &b)
    }

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
    fn a_blocking_row_is_the_first_to_reach_zero_or_under_blands_rule_the_lowest_numbered_near_it()
    {
        // Positions 0..4 of the support [7, 3, 9, 5] reach zero at these steps.
        let support = [7, 3, 9, 5];
        let steps = [(0, 2.0), (1, 1.0 + 1e-12), (2, 1.0), (3, 1.0 + 1e-6)];
        // The first smallest: position 2 (row 9).
        assert_eq!(
            blocking_row(steps.into_iter(), &support, false),
            Some((2, 1.0))
        );
        // Bland: rows 3 and 9 reach zero within 1e-9 of each other, row 5 does not: row 3
        // leaves, at the smallest step.
        assert_eq!(
            blocking_row(steps.into_iter(), &support, true),
            Some((1, 1.0))
        );
        // A tie at zero: only exact zeros are tied.
        let at_zero = [(0, 0.0), (1, 1e-300), (2, 0.0)];
        assert_eq!(
            blocking_row(at_zero.into_iter(), &support, true),
            Some((0, 0.0))
        );
        assert_eq!(blocking_row(std::iter::empty(), &support, true), None);
        assert_eq!(blocking_row(std::iter::empty(), &support, false), None);
    }

    #[test]
    fn an_iterate_as_an_answer_is_off_by_its_worst_violation_or_support_gap() {
        // Three rows on two unknowns at y = 0: r = b. The support {0, 2} with μ = (2, 0): row 2
        // keeps no multiplier, so only its violation counts.
        let a = SparseRows::from_rows(
            2,
            &[vec![(0, 1.0)], vec![(1, 1.0)], vec![(0, 1.0), (1, 1.0)]],
        );
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, -1.0, 0.5]).unwrap();
        let r = p.b().to_vec();
        let d = [1.0 + 3e-15, 0.0];
        let ad = [1.0 + 3e-15, 0.0, 1.0 + 3e-15];
        let (off, outcome) = answer_at(&p, &d, &[0, 2], &[2.0, 0.0], &r, &ad, 7);
        // Row 0 is in the support with μ > 0: its gap |1 − (1 + 3e-15)| counts; row 1 holds
        // (r − ad = −1); row 2 holds with room.
        assert_eq!(off, (1.0 + 3e-15) - 1.0);
        assert_eq!(outcome.x, vec![1.0 + 3e-15, 0.0]);
        assert_eq!(outcome.lambda, vec![2.0, 0.0, 0.0]);
        assert_eq!(outcome.iterations, 7);
        // A row outside the support violated by 2e-14 is the worst.
        let ad = [1.0, -1.0, 0.5 - 2e-14];
        let (off, _) = answer_at(&p, &d, &[0], &[2.0], &r, &ad, 1);
        assert_eq!(off, 0.5 - (0.5 - 2e-14));
        // Negative multipliers count as none.
        let (off, outcome) = answer_at(&p, &d, &[0], &[-1.0], &r, &[0.5, -1.0, 0.5], 1);
        assert_eq!(outcome.lambda, vec![0.0, 0.0, 0.0]);
        assert_eq!(off, 0.5);
    }

    /// `x₀ ≥ 1` and `x₀ + ε x₁ ≥ 1 + 0.3 ε` (ε = 1e-5), both in the support: independent
    /// rows whose smallest singular value (about ε/√2) is below `√δ`, with the solution
    /// `d = (1, 0.3)`. Refinement contracts along that singular vector by
    /// `δ/(σ² + δ) ≈ 0.95` a step and stops unsolved; conjugate gradients solve it.
    fn nearly_dependent() -> (ProjectionProblem, Vec<f64>) {
        let e = 1e-5;
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, e)]]);
        let b = vec![1.0, 1.0 + 0.3 * e];
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, b.clone()).unwrap();
        (p, [vec![0.0, 0.0], b].concat())
    }

    #[test]
    fn least_squares_solves_nearly_dependent_rows_that_refinement_leaves_unsolved() {
        let (p, rhs) = nearly_dependent();
        for sparse in [false, true] {
            let system = || {
                if sparse {
                    ActiveSystem::sparse(&p, &[0, 1]).unwrap()
                } else {
                    ActiveSystem::new(&p, &[0, 1], None).unwrap()
                }
            };
            let mut v = vec![0.0; 4];
            let plain = system()
                .refine(&rhs, &mut v, SECOND_PASS_TOL, false)
                .unwrap();
            assert!(!plain.solved, "refinement alone stalls (sparse: {sparse})");
            let mut v = vec![0.0; 4];
            let out = system()
                .refine(&rhs, &mut v, SECOND_PASS_TOL, true)
                .unwrap();
            assert!(
                out.solved && out.second <= SECOND_PASS_TOL,
                "{}",
                out.second
            );
            assert!(
                (v[0] - 1.0).abs() <= 1e-15 && (v[1] - 0.3).abs() <= 1e-9,
                "{v:?}"
            );
            // d = A_Pᵀμ: μ₁ = 0.3/ε = 3e4, μ₀ = 1 − μ₁ (v holds −μ).
            assert!(
                (v[3] + 3e4).abs() <= 1e-5 && (v[2] + 1.0 - 3e4).abs() <= 1e-5,
                "{v:?}"
            );
        }
    }

    #[test]
    fn least_squares_leaves_inconsistent_equations_to_the_ray() {
        // x₀ ≥ 1 and x₀ ≥ 1 + 1e-10, both in the support: the same row twice with different
        // right-hand sides. No step solves them; refinement's answer (its residual along the
        // ray (1, −1)) is kept as it was.
        let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
        let rhs = [0.0, 1.0, 1.0 + 1e-10];
        let p = ProjectionProblem::new(vec![0.0], a, rhs[1..].to_vec()).unwrap();
        let mut plain_v = vec![0.0; 3];
        let plain = ActiveSystem::sparse(&p, &[0, 1])
            .unwrap()
            .refine(&rhs, &mut plain_v, SECOND_PASS_TOL, false)
            .unwrap();
        let mut v = vec![0.0; 3];
        let out = ActiveSystem::sparse(&p, &[0, 1])
            .unwrap()
            .refine(&rhs, &mut v, SECOND_PASS_TOL, true)
            .unwrap();
        assert!(!out.solved);
        assert_eq!(
            (out.second, &out.residual, &v),
            (plain.second, &plain.residual, &plain_v)
        );
        assert!(
            out.residual[0] < 0.0 && out.residual[1] > 0.0,
            "{:?}",
            out.residual
        );
        // Conjugate gradients alone end at the least-squares point, x₀ = 1 + 5e-11, their
        // residual ±5e-11 orthogonal to the row.
        let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
        let mut w = vec![0.0; 3];
        let ls = system.least_squares(&rhs, &mut w, SECOND_PASS_TOL).unwrap();
        assert!(!ls.solved);
        assert!((w[0] - (1.0 + 5e-11)).abs() <= 1e-15, "{w:?}");
        assert!((ls.residual[0] + 5e-11).abs() <= 1e-15 && (ls.residual[1] - 5e-11).abs() <= 1e-15);
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
    fn least_squares_tests_relative_to_the_right_hand_side() {
        // `x₀ + 0.37 x₁ ≥ 0.7k` and `0.41 x₀ + x₁ ≥ 0.11k` (k = 1234.567) in the support, from
        // μ = 0: its residual ends at 2.3e-13, rounding of numbers of size k, within 1e-15
        // relative to ‖rhs‖∞ = k, not within 1e-15 divided by it.
        let k = 1234.567;
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 0.37)], vec![(0, 0.41), (1, 1.0)]]);
        let b = vec![0.7 * k, 0.11 * k];
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, b.clone()).unwrap();
        let rhs = [vec![0.0, 0.0], b].concat();
        let mut v = vec![0.0; 4];
        let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
        let out = system.least_squares(&rhs, &mut v, SECOND_PASS_TOL).unwrap();
        assert!(out.solved && out.second > 0.0, "{}", out.second);
        // d = A_Pᵀμ solves A_P d = b: check it by the equations themselves.
        let (r0, r1) = (v[0] + 0.37 * v[1] - 0.7 * k, 0.41 * v[0] + v[1] - 0.11 * k);
        assert!(r0.abs() <= 1e-12 && r1.abs() <= 1e-12, "{r0:e} {r1:e}");
    }

    #[test]
    fn least_squares_takes_conjugate_steps() {
        // Three rows `x₀ ≥ 1`, `x₀ + ε₁x₁ ≥ 1 + 0.3ε₁`, `x₀ + ε₂x₂ ≥ 1 + 0.7ε₂` (ε₁ = 1e-5,
        // ε₂ = 3e-5), all in the support: the preconditioned G has three distinct eigenvalues,
        // so conjugate gradients need all three of their steps, each direction conjugate to the
        // last (β = ρᵀz / ρ₋ᵀz₋, added); solution d = (1, 0.3, 0.7). Not to 1e-15 (below).
        let (e1, e2) = (1e-5, 3e-5);
        let a = SparseRows::from_rows(
            3,
            &[
                vec![(0, 1.0)],
                vec![(0, 1.0), (1, e1)],
                vec![(0, 1.0), (2, e2)],
            ],
        );
        let b = vec![1.0, 1.0 + 0.3 * e1, 1.0 + 0.7 * e2];
        let p = ProjectionProblem::new(vec![0.0; 3], a, b.clone()).unwrap();
        let rhs = [vec![0.0; 3], b].concat();
        let mut v = vec![0.0; 6];
        let mut system = ActiveSystem::sparse(&p, &[0, 1, 2]).unwrap();
        let plain = system.refine(&rhs, &mut v, SECOND_PASS_TOL, false).unwrap();
        assert!(!plain.solved && plain.stalled);
        // Within `refine`, an answer of conjugate gradients that does not solve the equations
        // to the tolerance (this one, below) is not taken: refinement's stands, its residual
        // the ray the method would follow.
        let mut w = vec![0.0; 6];
        let with = ActiveSystem::sparse(&p, &[0, 1, 2])
            .unwrap()
            .refine(&rhs, &mut w, SECOND_PASS_TOL, true)
            .unwrap();
        assert_eq!(
            (with.second, &with.residual, &w),
            (plain.second, &plain.residual, &v)
        );
        let out = system.least_squares(&rhs, &mut v, SECOND_PASS_TOL).unwrap();
        // Multipliers of 5e4 leave rounding of about 4e-12 in the residual (refinement left
        // 5e-6; with β multiplied instead of divided, or subtracted, three steps leave 1e-6).
        assert!(
            out.second <= 1e-11,
            "{} (refinement: {})",
            out.second,
            plain.second
        );
        assert!(
            (v[0] - 1.0).abs() <= 1e-10
                && (v[1] - 0.3).abs() <= 1e-10
                && (v[2] - 0.7).abs() <= 1e-10,
            "{v:?}"
        );
    }

    #[test]
    fn least_squares_from_multipliers_that_overflow_is_none() {
        // μ = 1e308 on both rows: d = A_Pᵀμ overflows, its residual is infinite, not NaN.
        let (p, rhs) = nearly_dependent();
        let mut v = vec![0.0, 0.0, -1e308, -1e308];
        let mut system = ActiveSystem::sparse(&p, &[0, 1]).unwrap();
        assert!(system
            .least_squares(&rhs, &mut v, SECOND_PASS_TOL)
            .is_none());
    }

    #[test]
    fn on_nearly_dependent_rows_the_method_ends_at_the_projection_to_rounding() {
        // The rows of `nearly_dependent` as `x₀ ≥ 1` and `x₀ + ε x₁ ≥ 1 + 0.3 ε` from y = 0:
        // the projection is d = (1, 0.3) if both multipliers were positive; they are not (μ₀
        // = 1 − 3e4), so the projection keeps the second row alone:
        // x = (1 + 0.3ε)/(1 + ε²) · (1, ε). Either way the method must finish at it.
        let (p, _) = nearly_dependent();
        let e: f64 = 1e-5;
        let t = (1.0 + 0.3 * e) / (1.0 + e * e);
        let outcome = solve(&p, start_from(vec![0, 1], 2), 20).unwrap();
        assert!((outcome.x[0] - t).abs() <= 1e-15 && (outcome.x[1] - t * e).abs() <= 1e-15);
        assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() <= 1e-15);
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

    /// `K_δ⁻¹ v` for `support` by a fresh factorization and by `system`, without refinement:
    /// the largest difference relative to the largest entry. Both solve the same regularized
    /// system, so only rounding separates them; an error in the bordering (its Schur
    /// complement, pivoting or back-substitution) shows here even where refinement would hide
    /// it.
    fn raw_solve_gap(p: &ProjectionProblem, system: &mut ActiveSystem, support: &[usize]) -> f64 {
        let size = p.dim() + support.len();
        let v: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut fresh = ActiveSystem::sparse(p, support).unwrap();
        let (mut a, mut b) = (v.clone(), v);
        fresh.solve_in_place(&mut a);
        system.solve_in_place(&mut b);
        let scale = a.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
        max_difference(&a, &b) / scale
    }

    /// The largest `|aᵢ − bᵢ|`, infinite when one is not finite (`f64::max` would drop a NaN).
    fn max_difference(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).fold(0.0, |m: f64, (a, b)| {
            let d = (a - b).abs();
            if d.is_finite() {
                m.max(d)
            } else {
                f64::INFINITY
            }
        })
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

    #[test]
    fn a_dense_factor_solves_what_the_sparse_one_solves() {
        let p = random_problem();
        let support: Vec<usize> = (0..20).collect();
        let mut dense = ActiveSystem::new(&p, &support, None).unwrap();
        assert!(matches!(dense.factor, Factor::Dense(_)));
        // Without refinement the sparse LDLᵀ of the quasi-definite K_δ is accurate to about
        // ε/δ, as in the bordered tests.
        let gap = raw_solve_gap(&p, &mut dense, &support);
        assert!(gap < 1e-6, "gap {gap:e}");
        // With refinement both solve K₀ to rounding.
        let gap = solve_gap(&p, &mut dense, &support);
        assert!(gap < 1e-11, "gap {gap:e}");
    }

    #[test]
    fn the_dense_factor_is_the_cholesky_factor_of_the_rows_gram_matrix_plus_delta() {
        let p = random_problem();
        let support: Vec<usize> = (0..20).collect();
        let rows = MergedRows::of(&p, &support);
        let l = schur_cholesky(&rows).expect("independent rows");
        let k = support.len();
        // (L Lᵀ)ᵢⱼ against aᵢ·aⱼ + δ on the diagonal, from the rows as A holds them.
        let dense: Vec<Vec<f64>> = support
            .iter()
            .map(|&i| {
                let mut row = vec![0.0; p.dim()];
                p.a().row(i).for_each(|(c, v)| row[c] += v);
                row
            })
            .collect();
        for i in 0..k {
            for j in 0..k {
                let llt: f64 = (0..k).map(|q| l[i * k + q] * l[j * k + q]).sum();
                let gram: f64 = dense[i].iter().zip(&dense[j]).map(|(a, b)| a * b).sum();
                let expected = gram + if i == j { DELTA } else { 0.0 };
                assert!(
                    (llt - expected).abs() <= 1e-13 * (1.0 + gram.abs()),
                    "({i}, {j}): {llt:e} against {expected:e}"
                );
            }
        }
        // Upper triangle untouched.
        assert!((0..k).all(|i| (i + 1..k).all(|j| l[i * k + j] == 0.0)));
    }

    #[test]
    fn a_row_repeated_in_a_small_support_is_factored_sparse_not_dense() {
        // Rows of norm about 1.4e3, the last a copy of the first: its pivot in A Aᵀ + δI is
        // about δ against a diagonal of 2e6, far below DENSE_PIVOT times it.
        let s = 1e3;
        let a = SparseRows::from_rows(
            4,
            &[
                vec![(0, -s), (1, s)],
                vec![(1, -s), (2, s)],
                vec![(2, -s), (3, s)],
                vec![(0, -s), (1, s)],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0; 4], a, vec![1.0; 4]).unwrap();
        assert!(schur_cholesky(&MergedRows::of(&p, &[0, 1, 2])).is_some());
        assert!(schur_cholesky(&MergedRows::of(&p, &[0, 1, 2, 3])).is_none());
        let system = ActiveSystem::new(&p, &[0, 1, 2, 3], None).unwrap();
        assert!(matches!(system.factor, Factor::Sparse(_)));
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

    #[test]
    fn at_most_k_violated_rows_join_the_most_violated_first_in_index_order() {
        let violated = [1, 3, 4, 7];
        let violation = |i: usize| [0.0, 0.5, 0.0, 2.0, 0.5, 0.0, 0.0, 1.0][i];
        let join: Vec<f64> = (0..8).map(|i| 0.1 * i as f64).collect();
        let rows = |at_most| -> Vec<usize> {
            joining_rows(&violated, violation, &join, false, at_most)
                .unwrap()
                .into_iter()
                .map(|(i, _)| i)
                .collect()
        };
        assert_eq!(rows(None), vec![1, 3, 4, 7]);
        assert_eq!(rows(Some(1)), vec![3]);
        assert_eq!(rows(Some(2)), vec![3, 7]);
        // Rows 1 and 4 are as violated: the lower index goes first.
        assert_eq!(rows(Some(3)), vec![1, 3, 7]);
        assert_eq!(rows(Some(4)), vec![1, 3, 4, 7]);
        assert_eq!(rows(Some(10)), vec![1, 3, 4, 7]);
        // Each starts from its remembered multiplier.
        let two = joining_rows(&violated, violation, &join, false, Some(2)).unwrap();
        assert_eq!(two, vec![(3, join[3]), (7, join[7])]);
        // Lawson–Hanson proper: the steepest alone, from zero, whatever the bound.
        let proper = joining_rows(&violated, violation, &join, true, Some(3)).unwrap();
        assert_eq!(proper, vec![(3, f64::MIN_POSITIVE)]);
    }

    #[test]
    fn merged_rows_sort_columns_sum_repeats_and_keep_rows_in_order() {
        let a = SparseRows::from_rows(
            5,
            &[
                vec![(3, 1.0), (1, 2.0), (3, 0.5)],
                vec![(0, 1.0), (4, -1.0)],
                vec![(2, 1.0), (2, 1.0), (2, 1.0)],
                vec![],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0; 5], a, vec![0.0; 4]).unwrap();
        let mut rows = MergedRows::of(&p, &[2, 0, 3, 1]);
        let listed: Vec<Vec<(usize, f64)>> = rows.iter().map(<[_]>::to_vec).collect();
        assert_eq!(
            listed,
            vec![
                vec![(2, 3.0)],
                vec![(1, 2.0), (3, 1.5)],
                vec![],
                vec![(0, 1.0), (4, -1.0)],
            ]
        );
        rows.retain(|t| t != 0 && t != 2);
        assert_eq!(rows.len(), 2);
        assert_eq!(rows.row(0), &[(1, 2.0), (3, 1.5)]);
        assert_eq!(rows.row(1), &[(0, 1.0), (4, -1.0)]);
        rows.push(&p, 2);
        assert_eq!(rows.row(2), &[(2, 3.0)]);
        assert_eq!(rows.entries.len(), 5);
    }

    #[test]
    fn shrink_drops_the_blocking_row_and_non_positive_ones() {
        let (support, lambda) = shrink(&[4, 7, 9, 12], &[0.5, 0.0, 2.0, -1e-300], 2);
        assert_eq!(support, vec![4]);
        assert_eq!(lambda, vec![0.5]);
        let (support, lambda) = shrink(&[1, 2], &[1.0, 3.0], 0);
        assert_eq!((support, lambda), (vec![2], vec![3.0]));
    }

    /// The KKT nodes of a sparse factor, position by position, named as `record` names them.
    fn factored_nodes(system: &ActiveSystem, keys: &[RowKey], names: &[usize]) -> Vec<Node> {
        let Factor::Sparse(ldl) = &system.factor else {
            panic!("a sparse factor");
        };
        let u = system.unknowns.base;
        ldl.perm()
            .iter()
            .map(|&l| {
                if l < u {
                    Node::Unknown(names[system.unknowns.global[l]])
                } else {
                    Node::Row(keys[system.support[l - u]])
                }
            })
            .collect()
    }

    #[test]
    fn a_remembered_ordering_keeps_the_order_of_known_nodes_puts_new_ones_last_and_solves_alike() {
        let keys: Vec<RowKey> = (0..35)
            .map(|i| RowKey {
                family: 3,
                member: 1000 + i,
            })
            .collect();
        let p = random_problem().with_row_keys(keys.clone()).unwrap();
        // Unknown j of this problem is unknown 100 + j of a larger one.
        let names: Vec<usize> = (100..140).collect();
        let mut orderings = Orderings::default();
        let base: Vec<usize> = (0..30).collect();
        let mut memory = Remembered {
            orderings: &mut orderings,
            unknowns: &names,
        };
        let first = ActiveSystem::sparse_ordered(&p, &base, Some(&mut memory)).unwrap();
        assert_eq!(memory.orderings.stats(), (1, 0));
        // The fill remembered is the factor's entries per entry of the matrix's upper triangle.
        let Factor::Sparse(ldl) = &first.factor else {
            panic!("a sparse factor");
        };
        let kkt = kkt_matrix(&first.rows, &first.unknowns);
        let fill = ldl.entries_below_diagonal() as f64 / kkt.nnz() as f64;
        assert!(fill > 0.0 && fill.fract() != 0.0, "{fill}");
        assert_eq!(memory.orderings.amd_fill, fill);
        let before = factored_nodes(&first, &keys, &names);
        // Row 5 leaves, row 31 joins: the next factorization is ordered from memory.
        let next: Vec<usize> = (0..30).filter(|&i| i != 5).chain([31]).collect();
        let mut second = ActiveSystem::sparse_ordered(&p, &next, Some(&mut memory)).unwrap();
        assert_eq!(memory.orderings.stats(), (1, 1));
        let after = factored_nodes(&second, &keys, &names);
        let known: Vec<Node> = before
            .iter()
            .copied()
            .filter(|n| after.contains(n))
            .collect();
        let new: Vec<Node> = after
            .iter()
            .copied()
            .filter(|n| !before.contains(n))
            .collect();
        assert!(new.contains(&Node::Row(keys[31])), "{new:?}");
        // Known nodes first, in their remembered order, then the new ones.
        assert_eq!(after[..known.len()], known[..]);
        assert_eq!(after[known.len()..], new[..]);
        let gap = solve_gap(&p, &mut second, &next);
        assert!(gap < 1e-12, "gap {gap:e}");
        // Without keys nothing is remembered or reused.
        let unkeyed = random_problem();
        let mut memory = Remembered {
            orderings: &mut orderings,
            unknowns: &names,
        };
        ActiveSystem::sparse_ordered(&unkeyed, &next, Some(&mut memory)).unwrap();
        assert_eq!(orderings.stats(), (1, 1));
    }

    #[test]
    fn without_a_name_per_unknown_the_method_solves_without_memory() {
        let keys: Vec<RowKey> = (0..35)
            .map(|i| RowKey {
                family: 1,
                member: i,
            })
            .collect();
        let p = random_problem().with_row_keys(keys).unwrap();
        let start = || Start {
            support: (0..30).collect(),
            lambda: vec![1.0; 30],
            join: vec![1.0; 35],
            join_at_most: None,
        };
        let mut orderings = Orderings::default();
        let names: Vec<usize> = (0..39).collect();
        let remembering = solve_remembering(&p, start(), 200, &mut orderings, &names).unwrap();
        assert_eq!(
            orderings.stats(),
            (0, 0),
            "nothing ordered from or into memory"
        );
        let plain = solve(&p, start(), 200).unwrap();
        assert_eq!(remembering.x, plain.x);
    }

    #[test]
    fn an_ordering_is_reused_while_most_nodes_are_known_and_its_fill_stays_near_amds() {
        let nodes: Vec<Node> = (0..4).map(Node::Unknown).collect();
        let mut o = Orderings::default();
        assert_eq!(o.ordering(&nodes), None, "nothing remembered");
        o.record(&nodes, &[2, 0, 3, 1], 1.0, false);
        assert_eq!(o.ordering(&nodes), Some(vec![2, 0, 3, 1]));
        // Half the nodes known is enough; fewer is not. New nodes go last, in their order.
        let half = [
            Node::Unknown(9),
            Node::Unknown(3),
            Node::Unknown(8),
            Node::Unknown(0),
        ];
        assert_eq!(o.ordering(&half), Some(vec![3, 1, 0, 2]));
        assert_eq!(o.ordering(&half[..3]), None);
        // A reused ordering filling up to STALE_FILL times AMD's keeps being reused …
        o.record(&nodes, &[2, 0, 3, 1], 1.25, true);
        assert!(o.ordering(&nodes).is_some());
        // … beyond it, the next factorization runs AMD, after which reuse resumes.
        o.record(&nodes, &[2, 0, 3, 1], 1.26, true);
        assert_eq!(o.ordering(&nodes), None);
        o.record(&nodes, &[0, 1, 2, 3], 2.0, false);
        assert_eq!(o.ordering(&nodes), Some(vec![0, 1, 2, 3]));
        o.record(&nodes, &[0, 1, 2, 3], 2.4, true);
        assert!(
            o.ordering(&nodes).is_some(),
            "relative to the last AMD fill"
        );
        assert_eq!(o.stats(), (2, 3));
    }

    proptest::proptest! {
        /// Placed in a table by rank (ranks spanning few nodes) or sorted (spanning many), the
        /// remembered nodes come in the order of their ranks, and the others after them in
        /// their own order.
        #[test]
        fn an_ordering_lists_nodes_by_rank_then_the_unremembered(
            rounds in proptest::collection::vec(
                (proptest::collection::btree_set(0usize..300, 1..120), 0usize..120),
                1..6,
            ),
            query in proptest::collection::btree_set(0usize..400, 1..60),
            shuffle in proptest::collection::vec(proptest::num::usize::ANY, 60),
        ) {
            let mut o = Orderings::default();
            for (ids, rotation) in &rounds {
                let nodes: Vec<Node> = ids.iter().copied().map(Node::Unknown).collect();
                let perm: Vec<usize> =
                    (0..nodes.len()).map(|p| (p + rotation) % nodes.len()).collect();
                o.record(&nodes, &perm, 1.0, false);
            }
            // The query in a scrambled order, so that its own order is not its ranks'.
            let mut ids: Vec<usize> = query.into_iter().collect();
            let len = ids.len();
            for (i, &r) in shuffle.iter().enumerate().take(len) {
                ids.swap(i, r % len);
            }
            let nodes: Vec<Node> = ids.iter().copied().map(Node::Unknown).collect();
            let mut ranked: Vec<(u64, usize)> = nodes
                .iter()
                .enumerate()
                .filter_map(|(l, node)| o.ranks.get(node).map(|&rank| (rank, l)))
                .collect();
            let known = ranked.len();
            ranked.sort_unstable();
            let mut expected: Vec<usize> = ranked.into_iter().map(|(_, l)| l).collect();
            expected.extend((0..nodes.len()).filter(|&l| !o.ranks.contains_key(&nodes[l])));
            let enough = known as f64 >= REMEMBERED_FRACTION * nodes.len() as f64;
            proptest::prop_assert_eq!(o.ordering(&nodes), enough.then_some(expected));
        }
    }

    #[test]
    fn an_ordering_is_by_rank_whether_its_ranks_are_placed_or_sorted() {
        let hundred: Vec<Node> = (0..100).map(Node::Unknown).collect();
        let mut o = Orderings::default();
        o.record(&hundred, &(0..100).rev().collect::<Vec<_>>(), 1.0, false);
        // Ranks 0 and 99, of three nodes: a span of 33 per node, sorted.
        let far = [Node::Unknown(0), Node::Unknown(500), Node::Unknown(99)];
        assert_eq!(o.ordering(&far), Some(vec![2, 0, 1]));
        // Ranks 49 to 51: placed.
        let near = [Node::Unknown(50), Node::Unknown(48), Node::Unknown(49)];
        assert_eq!(o.ordering(&near), Some(vec![0, 2, 1]));
        // No nodes: an empty ordering, as the sort gave.
        assert_eq!(o.ordering(&[]), Some(Vec::new()));
    }

    #[test]
    fn orderings_forget_nodes_not_placed_since_the_call_before_last() {
        let a: Vec<Node> = (0..4).map(Node::Unknown).collect();
        let b: Vec<Node> = (10..14).map(Node::Unknown).collect();
        let mut o = Orderings::default();
        o.record(&a, &[0, 1, 2, 3], 1.0, false);
        o.forget_older();
        o.record(&b, &[0, 1, 2, 3], 1.0, false);
        assert!(o.ordering(&a).is_some() && o.ordering(&b).is_some());
        o.forget_older();
        // `a` was placed before the call before last, `b` since.
        assert_eq!(o.ordering(&a), None);
        assert!(o.ordering(&b).is_some());
        o.forget_older();
        assert!(o.ranks.is_empty());
    }

    #[test]
    fn forks_joined_in_order_rank_their_nodes_after_the_memory_and_each_other() {
        let u = |j: usize| Node::Unknown(j);
        let mut main = Orderings::default();
        main.record(&[u(0), u(1), u(2)], &[2, 0, 1], 2.0, false);
        main.record(&[u(0), u(1), u(2)], &[2, 0, 1], 2.1, true);
        let (mut a, mut b, idle) = (main.fork(), main.fork(), main.fork());
        // A fork orders from the memory as it stood, and counts only its own factorizations.
        let known = [u(0), u(1), u(2)];
        assert_eq!(a.ordering(&known), Some(vec![2, 0, 1]));
        assert_eq!(a.ordering(&known), main.ordering(&known));
        assert_eq!((a.stats(), main.stats()), ((0, 0), (1, 1)));
        // Fork `a` orders two of the memory's nodes anew (AMD); fork `b` two new nodes from
        // memory.
        a.record(&[u(0), u(1)], &[1, 0], 3.0, false);
        b.record(&[u(5), u(6)], &[0, 1], 1.5, true);
        main.join(a);
        // `a` ran AMD: the fill the next orderings are held to is its own.
        assert_eq!(main.amd_fill, 3.0);
        main.join(b);
        assert_eq!(main.stats(), (2, 2));
        // u2 keeps its rank; u1 and u0 as fork `a` placed them, then fork `b`'s nodes, each
        // rank handed out once.
        assert_eq!(
            main.ordering(&[u(0), u(1), u(2), u(5)]),
            Some(vec![2, 1, 0, 3])
        );
        assert_eq!(main.ordering(&[u(6), u(5)]), Some(vec![1, 0]));
        assert_eq!(main.next, 6 + 2 + 2);
        let mut ranks: Vec<u64> = main.ranks.values().copied().collect();
        ranks.sort_unstable();
        assert_eq!(ranks, vec![3, 6, 7, 8, 9]);
        // The last fork that factored sets the fill and staleness the next orderings are held
        // to (`b` reused an ordering: the AMD fill it was held to stays `main`'s 2.0).
        assert_eq!((main.amd_fill, main.stale), (2.0, false));
        // A fork that factored nothing changes nothing, though made before the others joined.
        main.amd_fill = 3.5;
        main.join(idle);
        assert_eq!((main.amd_fill, main.stats(), main.next), (3.5, (2, 2), 10));
    }
}
