//! The normal matrix `I + AᵀWA` of a block, and its Cholesky factor.
//!
//! The interior point solves with it, with the weights `W = diag(λ/s)` of its iterate.
//! Whatever the rows — more of them than unknowns, linearly dependent — it
//! is symmetric positive definite (the identity comes from the objective `½‖d‖²`), so a
//! Cholesky factorization exists. Its pattern is that of `I + AᵀA` for every `W`: it is
//! ordered (AMD) and analysed once per block, and only refactored numerically after that.

use crate::simplicial::Reaches;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use sweeping_api::SparseRows;

/// Blocks of at least this many unknowns are factored supernodally (dense kernels on groups
/// of columns with the same pattern), smaller ones column by column: on a jam's large blocks
/// the supernodal factorization is the faster, on small ones its bookkeeping costs more than
/// it saves (measured: `docs/lab/2026-12-04-projection-engine.md`).
const SUPERNODAL_FROM: usize = 400;

/// How a factorization chooses between supernodal and column-by-column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Layout {
    /// Supernodal from [`SUPERNODAL_FROM`] unknowns: a door queue's whole block, whose fill is
    /// dense enough for the dense kernels at any size past that.
    ByUnknowns,
    /// By the factor's own flops per entry (faer's automatic choice): a jam's rows screened
    /// for an interior point leave a sparser factor, where the supernodes do not pay.
    ByFill,
}

impl Layout {
    /// faer's choice between the supernodal and the column-by-column factorization for a
    /// matrix of `n` unknowns.
    fn threshold(self, n: usize) -> SupernodalThreshold {
        match self {
            Layout::ByFill => SupernodalThreshold::AUTO,
            Layout::ByUnknowns if n >= SUPERNODAL_FROM => SupernodalThreshold::FORCE_SUPERNODAL,
            Layout::ByUnknowns => SupernodalThreshold::FORCE_SIMPLICIAL,
        }
    }
}

/// The dynamic regularization of `I + AᵀWA`, whose largest diagonal entry is `largest`.
///
/// Every pivot of `I + AᵀWA` is at least 1 in exact arithmetic (a Schur complement of the
/// identity plus a positive semidefinite matrix); one far below it is rounding after
/// cancellation between weights of 1e20, as near an interior point's answer. Such a pivot is
/// made far larger than any entry, which sets the direction's component there to zero instead
/// of letting the rounding through (the treatment of dependent rows in the normal equations
/// of LIPSOL, Zhang 1996).
fn regularization(largest: f64) -> LltRegularization<f64> {
    LltRegularization {
        dynamic_regularization_delta: largest * 1e8,
        dynamic_regularization_epsilon: 0.5,
    }
}

/// Why a factorization could not be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NotFactorable;

/// `I + AᵀWA` for one block's rows `A`, and its factor for the last weights given.
///
/// The unknowns are renumbered once, by the fill-reducing order (AMD), and the matrix is kept
/// in that numbering and in the triangle the factorization reads: the factorization is then
/// handed the matrix as it stands, where with an ordering of its own it would copy and
/// permute every entry at each refactorization.
pub(crate) struct NormalMatrix {
    n: usize,
    /// The factored triangle's pattern, compressed by columns, in the order's numbering:
    /// the upper triangle for a column-by-column factorization, the lower for a supernodal
    /// one.
    pattern: SymbolicSparseColMat<usize>,
    /// Which triangle `pattern` is.
    side: Side,
    values: Vec<f64>,
    /// The order: `order[k]` is the unknown at position `k`.
    order: Vec<usize>,
    /// For each row of `A`, for each pair `k ≤ l` of its entries, where `aₖ aₗ` adds up in
    /// `values`…
    slots: Vec<usize>,
    /// …and `aₖ aₗ` itself.
    products: Vec<f64>,
    /// Where each row's pairs start in `slots`.
    row_slots: Vec<usize>,
    /// Where the diagonal entries are.
    diagonal: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    /// For a column-by-column factor, its rows' reaches (found once for the pattern).
    reaches: Option<Reaches>,
    factor: Vec<f64>,
    workspace: MemBuffer,
    /// A right-hand side in the order's numbering.
    ordered: Vec<f64>,
    factored: bool,
}

impl std::fmt::Debug for NormalMatrix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NormalMatrix")
            .field("n", &self.n)
            .field("entries", &self.values.len())
            .field("factor_entries", &self.factor.len())
            .finish()
    }
}

impl NormalMatrix {
    /// The pattern of `I + AᵀA`, ordered and analysed.
    ///
    /// # Errors
    /// [`NotFactorable`] when the ordering or the symbolic analysis cannot allocate its
    /// workspace.
    pub(crate) fn new(a: &SparseRows) -> Result<Self, NotFactorable> {
        Self::with_layout(a, Layout::ByUnknowns)
    }

    /// As [`new`](Self::new), with the choice between the supernodal and the column-by-column
    /// factorization made as `layout` says.
    pub(crate) fn with_layout(a: &SparseRows, layout: Layout) -> Result<Self, NotFactorable> {
        let n = a.n_cols();
        let (ptr, idx, val) = (a.row_ptr(), a.col_idx(), a.values());
        let m = a.n_rows();
        let (col_ptr, row_idx) = upper_pattern(a);
        let entry = |row: usize, col: usize| -> usize {
            let range = col_ptr[col]..col_ptr[col + 1];
            range.start
                + row_idx[range]
                    .binary_search(&row)
                    .expect("every pair of a row was entered in the pattern")
        };
        let pairs: usize = (0..m)
            .map(|i| {
                let t = ptr[i + 1] - ptr[i];
                t * (t + 1) / 2
            })
            .sum();
        let mut slots = Vec::with_capacity(pairs);
        let mut products = Vec::with_capacity(pairs);
        let mut row_slots = Vec::with_capacity(m + 1);
        row_slots.push(0);
        for i in 0..m {
            for k in ptr[i]..ptr[i + 1] {
                for l in ptr[i]..ptr[i + 1] {
                    let (p, q) = (idx[k], idx[l]);
                    if p <= q {
                        slots.push(entry(p, q));
                        products.push(val[k] * val[l]);
                    }
                }
            }
            row_slots.push(slots.len());
        }
        let diagonal: Vec<usize> = (0..n).map(|j| entry(j, j)).collect();
        let threshold = layout.threshold(n);
        let analyse = |pattern: SymbolicSparseColMatRef<'_, usize>, ordering, threshold| {
            factorize_symbolic_cholesky(
                pattern,
                Side::Upper,
                ordering,
                CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: threshold,
                    ..Default::default()
                },
            )
            .map_err(|_| NotFactorable)
        };
        // faer's own analysis finds the order (AMD) and chooses the layout; the matrix is then
        // renumbered once and analysed again as it stands, in the same order, so that the
        // factorizations are the same to the bit.
        let unordered = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let ordered = analyse(unordered, SymmetricOrdering::Amd, threshold)?;
        let (order, position) = match ordered.perm() {
            Some(perm) => {
                let (fwd, inv) = perm.arrays();
                (fwd.to_vec(), inv.to_vec())
            }
            None => ((0..n).collect(), (0..n).collect()),
        };
        let (side, kept) = match ordered.raw() {
            SymbolicCholeskyRaw::Supernodal(_) => {
                (Side::Lower, SupernodalThreshold::FORCE_SUPERNODAL)
            }
            SymbolicCholeskyRaw::Simplicial(_) => {
                (Side::Upper, SupernodalThreshold::FORCE_SIMPLICIAL)
            }
        };
        let upper = Renumbered::of((&col_ptr, &row_idx), &position, Side::Upper);
        let symbolic = analyse(upper.pattern.as_ref(), SymmetricOrdering::Identity, kept)?;
        let renumbered = match side {
            Side::Upper => upper,
            Side::Lower => Renumbered::of((&col_ptr, &row_idx), &position, Side::Lower),
        };
        slots.iter_mut().for_each(|e| *e = renumbered.moved[*e]);
        let scratch = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let workspace = MemBuffer::try_new(scratch).map_err(|_| NotFactorable)?;
        let reaches = match symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(l) => {
                Some(Reaches::of(renumbered.pattern.as_ref(), l).map_err(|_| NotFactorable)?)
            }
            SymbolicCholeskyRaw::Supernodal(_) => None,
        };
        Ok(Self {
            n,
            reaches,
            factor: vec![0.0; symbolic.len_val()],
            values: vec![0.0; row_idx.len()],
            diagonal: diagonal.iter().map(|&e| renumbered.moved[e]).collect(),
            pattern: renumbered.pattern,
            side,
            order,
            slots,
            products,
            row_slots,
            symbolic,
            workspace,
            ordered: vec![0.0; n],
            factored: false,
        })
    }

    /// Fills `I + AᵀWA` (one weight per row of the `A` this matrix was built from) and factors
    /// it. A factorization that meets a pivot too small for its size (weights spanning twenty
    /// orders of magnitude near an interior point's answer) is redone with such pivots raised
    /// (faer's dynamic regularization); the solves are then those of a nearby matrix, which
    /// callers refine against the true one.
    ///
    /// # Errors
    /// [`NotFactorable`] when a weight is not finite or both factorizations fail.
    pub(crate) fn factor(&mut self, w: &[f64]) -> Result<(), NotFactorable> {
        self.factored = false;
        if !w.iter().all(|v| v.is_finite()) {
            return Err(NotFactorable);
        }
        self.values.iter_mut().for_each(|v| *v = 0.0);
        for &p in &self.diagonal {
            self.values[p] = 1.0;
        }
        for (i, &wi) in w.iter().enumerate() {
            if wi == 0.0 {
                continue;
            }
            let range = self.row_slots[i]..self.row_slots[i + 1];
            for (&slot, &c) in self.slots[range.clone()].iter().zip(&self.products[range]) {
                self.values[slot] += wi * c;
            }
        }
        let largest = self
            .diagonal
            .iter()
            .map(|&p| self.values[p])
            .fold(1.0, f64::max);
        let regularization = regularization(largest);
        if let (Some(reaches), SymbolicCholeskyRaw::Simplicial(l)) =
            (self.reaches.as_mut(), self.symbolic.raw())
        {
            let matrix = (self.pattern.as_ref(), &self.values[..]);
            let (epsilon, delta) = (
                regularization.dynamic_regularization_epsilon,
                regularization.dynamic_regularization_delta,
            );
            if reaches
                .factor(matrix, l, (epsilon, delta), &mut self.factor)
                .is_ok()
            {
                self.factored = true;
                return Ok(());
            }
            return Err(NotFactorable);
        }
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), &self.values);
        let stack = MemStack::new(&mut self.workspace);
        if self
            .symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.factor,
                matrix,
                self.side,
                regularization,
                Par::Seq,
                stack,
                Default::default(),
            )
            .is_ok()
        {
            self.factored = true;
            return Ok(());
        }
        Err(NotFactorable)
    }

    /// Solves `(I + AᵀWA) v_new = v` in place with the last factor.
    ///
    /// # Panics
    /// When no factorization succeeded since the last [`Self::factor`] call, or `v` has the
    /// wrong length.
    pub(crate) fn solve(&mut self, v: &mut [f64]) {
        assert!(self.factored, "solve without a factor");
        assert_eq!(v.len(), self.n, "right-hand side of the wrong length");
        let ordered = &mut self.ordered;
        ordered
            .iter_mut()
            .zip(&self.order)
            .for_each(|(o, &j)| *o = v[j]);
        let llt = LltRef::<'_, usize, f64>::new(&self.symbolic, &self.factor);
        let stack = MemStack::new(&mut self.workspace);
        let n = ordered.len();
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(ordered, n, 1),
            Par::Seq,
            stack,
        );
        self.order
            .iter()
            .zip(ordered.iter())
            .for_each(|(&j, &o)| v[j] = o);
    }
}

/// The upper triangle of `I + AᵀA`'s pattern, compressed by columns: column `q` holds `q`
/// and every `p < q` that shares a row with it, sorted.
fn upper_pattern(a: &SparseRows) -> (Vec<usize>, Vec<usize>) {
    let (m, n) = (a.n_rows(), a.n_cols());
    let (ptr, idx) = (a.row_ptr(), a.col_idx());
    // The rows touching each column (the transpose's pattern), by counting: each column of
    // `I + AᵀA` is then gathered from its own rows.
    let mut col_start = vec![0usize; n + 1];
    for &c in idx {
        col_start[c + 1] += 1;
    }
    for j in 0..n {
        col_start[j + 1] += col_start[j];
    }
    let mut next = col_start.clone();
    let mut col_rows = vec![0usize; idx.len()];
    for i in 0..m {
        for &c in &idx[ptr[i]..ptr[i + 1]] {
            col_rows[next[c]] = i;
            next[c] += 1;
        }
    }
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0);
    let mut row_idx = Vec::with_capacity(n + 2 * idx.len());
    let mut seen = vec![usize::MAX; n];
    for q in 0..n {
        let start = row_idx.len();
        seen[q] = q;
        row_idx.push(q);
        for &i in &col_rows[col_start[q]..col_start[q + 1]] {
            for &p in &idx[ptr[i]..ptr[i + 1]] {
                if p < q && seen[p] != q {
                    seen[p] = q;
                    row_idx.push(p);
                }
            }
        }
        row_idx[start..].sort_unstable();
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx)
}

/// A symmetric pattern renumbered: one triangle of it with unknown `j` at `position[j]`.
struct Renumbered {
    pattern: SymbolicSparseColMat<usize>,
    /// Where each entry of the upper triangle it came from went.
    moved: Vec<usize>,
}

impl Renumbered {
    /// The triangle `side` of the matrix whose upper triangle is `(col_ptr, row_idx)`, with
    /// the entries of each column in the order faer's own permutation of a matrix puts them
    /// (by the column, then the row, they came from): the factorization's arithmetic follows
    /// that order.
    fn of((col_ptr, row_idx): (&[usize], &[usize]), position: &[usize], side: Side) -> Self {
        let n = col_ptr.len() - 1;
        let target = |i: usize, j: usize| {
            let (p, q) = (position[i], position[j]);
            match side {
                Side::Upper => (p.min(q), p.max(q)),
                Side::Lower => (p.max(q), p.min(q)),
            }
        };
        let mut next = vec![0usize; n + 1];
        for j in 0..n {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                next[target(i, j).1 + 1] += 1;
            }
        }
        for q in 0..n {
            next[q + 1] += next[q];
        }
        let new_ptr = next.clone();
        let mut new_idx = vec![0usize; row_idx.len()];
        let mut moved = vec![0usize; row_idx.len()];
        for j in 0..n {
            for e in col_ptr[j]..col_ptr[j + 1] {
                let (row, col) = target(row_idx[e], j);
                new_idx[next[col]] = row;
                moved[e] = next[col];
                next[col] += 1;
            }
        }
        Self {
            pattern: SymbolicSparseColMat::new_unsorted_checked(n, n, new_ptr, None, new_idx),
            moved,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense(a: &SparseRows, w: &[f64]) -> Vec<Vec<f64>> {
        let n = a.n_cols();
        let mut m = vec![vec![0.0; n]; n];
        for (j, row) in m.iter_mut().enumerate() {
            row[j] = 1.0;
        }
        for (i, wi) in w.iter().enumerate() {
            let row: Vec<_> = a.row(i).collect();
            for &(p, u) in &row {
                for &(q, v) in &row {
                    m[p][q] += wi * u * v;
                }
            }
        }
        m
    }

    fn chain(n: usize) -> SparseRows {
        // Rows x_{j+1} − x_j and a few repeated (dependent) ones, more rows than unknowns.
        let mut rows: Vec<Vec<(usize, f64)>> =
            (0..n - 1).map(|j| vec![(j, -1.0), (j + 1, 1.0)]).collect();
        rows.extend((0..n - 1).map(|j| vec![(j, -2.0), (j + 1, 2.0)]));
        rows.push(vec![(0, 0.5), (n - 1, 0.25)]);
        SparseRows::from_rows(n, &rows)
    }

    #[test]
    fn solves_against_the_dense_matrix_for_small_and_large_blocks() {
        for n in [5, SUPERNODAL_FROM + 3] {
            let a = chain(n);
            let w: Vec<f64> = (0..a.n_rows()).map(|i| 0.1 + (i % 7) as f64).collect();
            let mut normal = NormalMatrix::new(&a).unwrap();
            normal.factor(&w).unwrap();
            let x: Vec<f64> = (0..n).map(|j| (j as f64 * 0.37).sin()).collect();
            let m = dense(&a, &w);
            let mut b: Vec<f64> = m
                .iter()
                .map(|row| row.iter().zip(&x).map(|(u, v)| u * v).sum())
                .collect();
            normal.solve(&mut b);
            for (u, v) in b.iter().zip(&x) {
                assert!((u - v).abs() < 1e-9, "n = {n}: {u} vs {v}");
            }
        }
    }

    /// A jam-like block: unknowns in pairs (people), rows between neighbours on a grid, and
    /// every fifth row repeated (dependent rows, more rows than unknowns).
    fn grid(side: usize) -> SparseRows {
        let person = |i: usize, j: usize| 2 * (i * side + j);
        let mut rows = Vec::new();
        for i in 0..side {
            for j in 0..side {
                let (p, right, up) = (person(i, j), person(i, j + 1), person(i + 1, j));
                if j + 1 < side {
                    rows.push(vec![
                        (p, -0.6),
                        (p + 1, -0.8),
                        (right, 0.6),
                        (right + 1, 0.8),
                    ]);
                }
                if i + 1 < side {
                    rows.push(vec![(p, 0.8), (p + 1, -0.6), (up, -0.8), (up + 1, 0.6)]);
                }
            }
        }
        let repeated: Vec<_> = rows.iter().step_by(5).cloned().collect();
        rows.extend(repeated);
        SparseRows::from_rows(2 * side * side, &rows)
    }

    /// `v ← (I + AᵀWA)⁻¹ v` by faer's own analysis and ordering of the matrix as built before
    /// the renumbering: the reference of the factorization's arithmetic.
    fn solved_by_faers_own_ordering(a: &SparseRows, w: &[f64], layout: Layout, v: &mut [f64]) {
        let n = a.n_cols();
        let (col_ptr, row_idx) = upper_pattern(a);
        // The entries summed as `factor` sums them: `1`, then `wᵢ (aᵢₚ aᵢ_q)` row by row.
        let entry = |row: usize, col: usize| {
            col_ptr[col]
                + row_idx[col_ptr[col]..col_ptr[col + 1]]
                    .binary_search(&row)
                    .unwrap()
        };
        let mut values = vec![0.0; row_idx.len()];
        (0..n).for_each(|j| values[entry(j, j)] = 1.0);
        for (i, wi) in w.iter().enumerate() {
            for (p, u) in a.row(i) {
                for (q, v) in a.row(i) {
                    if p <= q {
                        values[entry(p, q)] += wi * (u * v);
                    }
                }
            }
        }
        let threshold = layout.threshold(n);
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: threshold,
                ..Default::default()
            },
        )
        .unwrap();
        let largest = (0..n).map(|j| values[entry(j, j)]).fold(1.0, f64::max);
        let regularization = regularization(largest);
        let mut factor = vec![0.0; symbolic.len_val()];
        let mut workspace = MemBuffer::new(
            symbolic
                .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
                .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq)),
        );
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut factor,
                SparseColMatRef::new(pattern, &values),
                Side::Upper,
                regularization,
                Par::Seq,
                MemStack::new(&mut workspace),
                Default::default(),
            )
            .unwrap();
        LltRef::<'_, usize, f64>::new(&symbolic, &factor).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(v, n, 1),
            Par::Seq,
            MemStack::new(&mut workspace),
        );
    }

    #[test]
    fn the_renumbered_matrix_factors_as_faers_own_ordering_to_the_bit() {
        for side in [4, 9, 30] {
            let a = grid(side);
            let n = a.n_cols();
            let b: Vec<f64> = (0..n).map(|j| (j as f64 * 0.37).sin()).collect();
            // Moderate weights, and an interior point's near its answer (tight rows 1e20,
            // the others 1e-20), whose cancellations call on the dynamic regularization of
            // the column-by-column factor (`ByFill` on these grids; faer's supernodal one
            // refuses such weights on the largest).
            let moderate: Vec<f64> = (0..a.n_rows())
                .map(|i| 10f64.powi((i % 9) as i32 - 4))
                .collect();
            let extreme: Vec<f64> = (0..a.n_rows())
                .map(|i| if i % 3 == 0 { 1e-20 } else { 1e20 })
                .collect();
            for (w, layout) in [
                (&moderate, Layout::ByUnknowns),
                (&moderate, Layout::ByFill),
                (&extreme, Layout::ByFill),
            ] {
                let mut normal = NormalMatrix::with_layout(&a, layout).unwrap();
                normal.factor(w).unwrap();
                let mut ours = b.clone();
                normal.solve(&mut ours);
                let mut theirs = b.clone();
                solved_by_faers_own_ordering(&a, w, layout, &mut theirs);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&ours), bits(&theirs), "{side} × {side}, {layout:?}");
            }
        }
    }

    #[test]
    fn both_triangles_solve_a_grid_against_the_dense_matrix() {
        let a = grid(30);
        let n = a.n_cols();
        let w: Vec<f64> = (0..a.n_rows())
            .map(|i| 10f64.powi((i % 9) as i32 - 4))
            .collect();
        let x: Vec<f64> = (0..n).map(|j| (j as f64 * 0.37).sin()).collect();
        let m = dense(&a, &w);
        let b: Vec<f64> = m
            .iter()
            .map(|row| row.iter().zip(&x).map(|(u, v)| u * v).sum())
            .collect();
        for layout in [Layout::ByUnknowns, Layout::ByFill] {
            let mut normal = NormalMatrix::with_layout(&a, layout).unwrap();
            normal.factor(&w).unwrap();
            let mut v = b.clone();
            normal.solve(&mut v);
            for (u, t) in v.iter().zip(&x) {
                assert!((u - t).abs() < 1e-8, "{layout:?}: {u} vs {t}");
            }
        }
    }

    #[test]
    fn weights_far_apart_still_factor() {
        let a = chain(40);
        let w: Vec<f64> = (0..a.n_rows())
            .map(|i| if i % 2 == 0 { 1e20 } else { 1e-20 })
            .collect();
        let mut normal = NormalMatrix::new(&a).unwrap();
        assert!(normal.factor(&w).is_ok());
        let mut v = vec![1.0; 40];
        normal.solve(&mut v);
        assert!(v.iter().all(|x| x.is_finite()));
    }

    /// Two rows equal to within rounding, weighted `1e20` (an interior point's tight rows near
    /// its answer): the second pivot is lost to cancellation, and raised far above every entry
    /// (`1e8` times the largest diagonal) its component of a solve is zero instead of the
    /// rounding divided by what is left of the pivot.
    #[test]
    fn a_pivot_lost_to_cancellation_gives_no_direction_along_it() {
        let a = SparseRows::from_rows(
            2,
            &[vec![(0, 1.0), (1, 1.0)], vec![(0, 1.0), (1, 1.0 + 1e-12)]],
        );
        let mut normal = NormalMatrix::new(&a).unwrap();
        normal.factor(&[1e20, 1e20]).unwrap();
        let mut v = vec![0.0, 1e20];
        normal.solve(&mut v);
        assert!(v.iter().all(|x| x.abs() < 1e-6), "{v:?}");
    }

    /// Weights whose products overflow leave no factor (a pivot that is not a number), for
    /// either layout: refused, not factored into NaNs.
    #[test]
    fn weights_that_overflow_the_matrix_are_refused() {
        let a = chain(SUPERNODAL_FROM + 3);
        let w = vec![f64::MAX / 2.0; a.n_rows()];
        for layout in [Layout::ByUnknowns, Layout::ByFill] {
            let mut normal = NormalMatrix::with_layout(&a, layout).unwrap();
            assert_eq!(normal.factor(&w), Err(NotFactorable), "{layout:?}");
        }
        let small = chain(5);
        let mut normal = NormalMatrix::new(&small).unwrap();
        assert_eq!(
            normal.factor(&vec![f64::MAX / 2.0; small.n_rows()]),
            Err(NotFactorable)
        );
    }

    #[test]
    fn a_weight_that_is_not_finite_is_refused() {
        let a = chain(4);
        let mut normal = NormalMatrix::new(&a).unwrap();
        let mut w = vec![1.0; a.n_rows()];
        w[2] = f64::NAN;
        assert_eq!(normal.factor(&w), Err(NotFactorable));
    }
}
