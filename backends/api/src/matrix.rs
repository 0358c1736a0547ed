//! A sparse matrix stored by rows (CSR), the form in which constraints are assembled.

use serde::{Deserialize, Serialize};

/// A sparse `n_rows × n_cols` matrix in compressed-sparse-row form.
///
/// Rows are appended one at a time with [`SparseRows::push_row`]; within a row, column indices
/// need not be sorted but must be distinct. Backends convert to their own format (both Clarabel
/// and OSQP take compressed-sparse-column).
///
/// ```
/// use sweeping_api::SparseRows;
/// let mut a = SparseRows::new(3);
/// a.push_row([(0, 1.0), (2, -1.0)]);
/// a.push_row([(1, 2.0)]);
/// let mut ax = [0.0; 2];
/// a.mul_vec(&[1.0, 1.0, 1.0], &mut ax);
/// assert_eq!(ax, [0.0, 2.0]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SparseRows {
    n_cols: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
}

impl SparseRows {
    /// An empty matrix (no rows) with `n_cols` columns.
    pub fn new(n_cols: usize) -> Self {
        Self {
            n_cols,
            row_ptr: vec![0],
            col_idx: Vec::new(),
            values: Vec::new(),
        }
    }

    /// An empty matrix with `n_cols` columns and room for `rows` rows of `entries` entries in
    /// all, so that pushing them does not grow its vectors one doubling at a time.
    pub fn with_capacity(n_cols: usize, rows: usize, entries: usize) -> Self {
        let mut row_ptr = Vec::with_capacity(rows + 1);
        row_ptr.push(0);
        Self {
            n_cols,
            row_ptr,
            col_idx: Vec::with_capacity(entries),
            values: Vec::with_capacity(entries),
        }
    }

    /// Entries stored in row `r`.
    pub fn row_len(&self, r: usize) -> usize {
        self.row_ptr[r + 1] - self.row_ptr[r]
    }

    /// Builds a matrix from a list of rows, each a list of `(column, value)`.
    ///
    /// # Panics
    /// If a column index is `≥ n_cols`.
    pub fn from_rows(n_cols: usize, rows: &[Vec<(usize, f64)>]) -> Self {
        let mut m = Self::new(n_cols);
        for r in rows {
            m.push_row(r.iter().copied());
        }
        m
    }

    /// Removes every row, keeping the allocation.
    pub fn clear(&mut self) {
        self.row_ptr.truncate(1);
        self.col_idx.clear();
        self.values.clear();
    }

    /// Sets the number of columns (only allowed on an empty matrix).
    ///
    /// # Panics
    /// If the matrix has rows.
    pub fn reset(&mut self, n_cols: usize) {
        assert_eq!(self.n_rows(), 0, "reset on a matrix with rows");
        self.n_cols = n_cols;
    }

    /// Appends a row given as `(column, value)` pairs.
    ///
    /// # Panics
    /// If a column index is `≥ n_cols` (an assembly bug, not a user error).
    pub fn push_row(&mut self, entries: impl IntoIterator<Item = (usize, f64)>) {
        for (c, v) in entries {
            assert!(
                c < self.n_cols,
                "column {c} out of range ({} columns)",
                self.n_cols
            );
            self.col_idx.push(c);
            self.values.push(v);
        }
        self.row_ptr.push(self.col_idx.len());
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Number of columns.
    pub fn n_cols(&self) -> usize {
        self.n_cols
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// The entries `(column, value)` of row `r`.
    // Inlined across crates: called per row in the backends' hot loops, on rows of two to four
    // entries, where the call cost as much as the row's arithmetic.
    #[inline]
    pub fn row(&self, r: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let range = self.row_ptr[r]..self.row_ptr[r + 1];
        self.col_idx[range.clone()]
            .iter()
            .copied()
            .zip(self.values[range].iter().copied())
    }

    /// Row pointers (length `n_rows + 1`).
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Column index of each stored entry.
    pub fn col_idx(&self) -> &[usize] {
        &self.col_idx
    }

    /// Value of each stored entry.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// `out = A x`.
    ///
    /// # Panics
    /// On dimension mismatch.
    pub fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), self.n_cols);
        assert_eq!(out.len(), self.n_rows());
        for (o, ends) in out.iter_mut().zip(self.row_ptr.windows(2)) {
            let (cols, values) = (
                &self.col_idx[ends[0]..ends[1]],
                &self.values[ends[0]..ends[1]],
            );
            *o = cols.iter().zip(values).map(|(&c, &v)| v * x[c]).sum();
        }
    }

    /// `out = Aᵀ λ`.
    ///
    /// # Panics
    /// On dimension mismatch.
    pub fn mul_transpose_vec(&self, lambda: &[f64], out: &mut [f64]) {
        assert_eq!(lambda.len(), self.n_rows());
        assert_eq!(out.len(), self.n_cols);
        out.iter_mut().for_each(|o| *o = 0.0);
        for (l, ends) in lambda.iter().zip(self.row_ptr.windows(2)) {
            let (cols, values) = (
                &self.col_idx[ends[0]..ends[1]],
                &self.values[ends[0]..ends[1]],
            );
            for (&c, &v) in cols.iter().zip(values) {
                out[c] += v * l;
            }
        }
    }

    /// The same matrix in compressed-sparse-column form: `(col_ptr, row_idx, values)`, with row
    /// indices sorted within each column. Both shipped backends take this form.
    pub fn to_csc(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let mut count = vec![0usize; self.n_cols + 1];
        for &c in &self.col_idx {
            count[c + 1] += 1;
        }
        for j in 0..self.n_cols {
            count[j + 1] += count[j];
        }
        let col_ptr = count.clone();
        let mut next = count;
        let mut row_idx = vec![0usize; self.nnz()];
        let mut vals = vec![0.0; self.nnz()];
        for r in 0..self.n_rows() {
            for k in self.row_ptr[r]..self.row_ptr[r + 1] {
                let c = self.col_idx[k];
                row_idx[next[c]] = r;
                vals[next[c]] = self.values[k];
                next[c] += 1;
            }
        }
        (col_ptr, row_idx, vals)
    }

    /// Whether two matrices have the same shape and the same pattern of stored entries (so a
    /// backend may update values in place instead of rebuilding).
    pub fn same_pattern(&self, other: &Self) -> bool {
        self.n_cols == other.n_cols
            && self.row_ptr == other.row_ptr
            && self.col_idx == other.col_idx
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csc_round_trip_and_products() {
        let a = SparseRows::from_rows(
            3,
            &[vec![(2, 1.0), (0, 2.0)], vec![], vec![(1, -1.0), (2, 3.0)]],
        );
        let (cp, ri, v) = a.to_csc();
        assert_eq!(cp, vec![0, 1, 2, 4]);
        assert_eq!(ri, vec![0, 2, 0, 2]);
        assert_eq!(v, vec![2.0, -1.0, 1.0, 3.0]);
        let mut ax = [0.0; 3];
        a.mul_vec(&[1.0, 2.0, 3.0], &mut ax);
        assert_eq!(ax, [5.0, 0.0, 7.0]);
        let mut atl = [0.0; 3];
        a.mul_transpose_vec(&[1.0, 5.0, 2.0], &mut atl);
        assert_eq!(atl, [2.0, -2.0, 7.0]);
        // The compressed rows as stored (entries in the order given), which other crates read.
        assert_eq!(a.row_ptr(), [0, 2, 2, 4]);
        assert_eq!(a.col_idx(), [2, 0, 1, 2]);
        assert_eq!(a.values(), [1.0, 2.0, -1.0, 3.0]);
    }

    #[test]
    fn a_matrix_made_with_room_is_the_same_matrix() {
        let rows = [vec![(2, 1.0), (0, 2.0)], vec![], vec![(1, -1.0), (2, 3.0)]];
        let mut roomy = SparseRows::with_capacity(3, rows.len(), 4);
        rows.iter().for_each(|r| roomy.push_row(r.iter().copied()));
        assert_eq!(roomy, SparseRows::from_rows(3, &rows));
        assert!(roomy.col_idx.capacity() >= 4 && roomy.row_ptr.capacity() >= 4);
        let lengths: Vec<usize> = (0..3).map(|r| roomy.row_len(r)).collect();
        assert_eq!(lengths, [2, 0, 2]);
    }
}
