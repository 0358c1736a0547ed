//! The factor: the KKT system of a support, its regularization `K_δ` factored sparse
//! (`LDLᵀ`, ordered by AMD or from memory) or, for a few rows, dense.

use super::bordered::Bordered;
use super::dense::{self, schur_cholesky};
use super::merged_rows::MergedRows;
use super::orderings::{Memory, Node, STALE_FILL};
use crate::csc::CscMatrix;
use crate::ldl::{Ldl, NotFactored};
use sweeping_api::ProjectionProblem;

/// Regularization of the lower-right block, removed again by iterative refinement.
pub(super) const DELTA: f64 = 1e-9;

/// Supports of at most this many rows are factored densely, by the Schur complement
/// `A_P A_Pᵀ + δI` (`k × k`): a contact cluster of a few people costs a few microseconds that
/// way, where the sparse path pays for building, ordering and analysing a matrix of size
/// `n + k` every time.
const DENSE_MAX: usize = 24;

/// The KKT system `K₀ = [I A_Pᵀ; A_P 0]` of a set of rows `P`, with the `LDLᵀ` factors of its
/// regularization `K_δ = [I A_Pᵀ; A_P −δI]`.
///
/// An unknown that no row of `P` touches has the equation `dⱼ = fⱼ` alone, so a sparse factor
/// covers only the touched ones ([`Unknowns`]): on a jam the support touches a fraction of
/// the block's people, and every factorization, solve and bordering column of the rest would
/// be identity work.
pub(super) struct ActiveSystem {
    pub(super) n: usize,
    /// The support, in the order of `rows` and of the unknowns `μ`.
    pub(super) support: Vec<usize>,
    pub(super) rows: MergedRows,
    pub(super) factor: Factor,
    /// The unknowns of a sparse factor (empty for a dense one).
    pub(super) unknowns: Unknowns,
    /// Rows removed from and added to the support of a sparse factor since it was made.
    pub(super) bordered: Option<Bordered>,
    /// Work vectors of solves and refinement, kept from one to the next: a solve is short,
    /// and allocating its vectors afresh each time would be a sizeable part of it.
    pub(super) scratch: Scratch,
}

/// Work vectors of an [`ActiveSystem`] (their contents do not outlive a call).
#[derive(Debug, Default)]
pub(super) struct Scratch {
    /// The right-hand side gathered onto a sparse factor's nodes.
    pub(super) gathered: Vec<f64>,
    /// Refinement's product `K₀ v` and step.
    pub(super) product: Vec<f64>,
    pub(super) step: Vec<f64>,
    /// Conjugate gradients' vectors ([`ActiveSystem::least_squares`]): by unknown, `A_Pᵀ·`;
    /// by row, the residual, the preconditioned residual, the direction and its product.
    pub(super) by_unknown: Vec<f64>,
    pub(super) residual: Vec<f64>,
    pub(super) preconditioned: Vec<f64>,
    pub(super) direction: Vec<f64>,
    pub(super) product_g: Vec<f64>,
    /// Bordering's marks by row of the problem: whether a row is in the next support, and
    /// its position in the factored one (`usize::MAX` when not), clear between calls.
    pub(super) in_next: Vec<bool>,
    pub(super) position: Vec<usize>,
}

/// The unknowns a sparse factor and its bordering work on, numbered locally: first the `base`
/// ones, touched by the factored support `P₀` (increasing), then those that joined rows
/// touched first (an identity block of the bordered system).
pub(super) struct Unknowns {
    /// Local → global.
    pub(super) global: Vec<usize>,
    /// Global → local, `usize::MAX` for an unknown not in the system.
    local: Vec<usize>,
    /// How many unknowns the factor of `K_δ(P₀)` covers.
    pub(super) base: usize,
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
    pub(super) fn index(&mut self, c: usize) -> usize {
        if self.local[c] == usize::MAX {
            self.local[c] = self.global.len();
            self.global.push(c);
        }
        self.local[c]
    }
}

/// The factors of `K_δ = [I A_Pᵀ; A_P −δI]`.
pub(super) enum Factor {
    /// Sparse `LDLᵀ` of `K_δ` itself.
    Sparse(Box<Ldl>),
    /// Dense Cholesky factor `L` (row-major, lower triangle) of `S = A_P A_Pᵀ + δI`.
    Dense(Vec<f64>),
}

impl ActiveSystem {
    /// Factors `K_δ` for the rows `active` (increasing); `None` when the factorization fails.
    /// A sparse factorization is ordered from `memory` when it holds most of the matrix (see
    /// [`Orderings`](super::Orderings)), by AMD otherwise.
    pub(super) fn new(
        problem: &ProjectionProblem,
        active: &[usize],
        memory: Option<&mut Memory<'_>>,
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
    pub(super) fn sparse(problem: &ProjectionProblem, active: &[usize]) -> Option<Self> {
        Self::sparse_ordered(problem, active, None)
    }

    /// The sparse `LDLᵀ` of `K_δ` for the rows `active`, whatever their number, ordered from
    /// `memory` when it can be (and the ordering remembered), else by AMD; see [`Self::new`].
    pub(super) fn sparse_ordered(
        problem: &ProjectionProblem,
        active: &[usize],
        memory: Option<&mut Memory<'_>>,
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

    /// `v ← K_δ⁻¹ v`.
    pub(super) fn solve_in_place(&mut self, v: &mut [f64]) {
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
            Factor::Dense(l) => dense::solve_in_place(l, &self.rows, self.n, v),
        }
    }
}

/// The upper triangle of `K_δ` for the support's `rows` (columns sorted) on `unknowns`, by
/// columns.
pub(super) fn kkt_matrix(rows: &MergedRows, unknowns: &Unknowns) -> CscMatrix {
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
