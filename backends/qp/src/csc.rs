//! A compressed-sparse-column matrix: the upper triangles handed to the `LDLᵀ` factorization
//! of the active-set method, and its factor.

/// An `m × n` matrix compressed by columns: column `j` holds rows `rowval[colptr[j]..colptr[j +
/// 1]]` with values `nzval[…]`. The field names are QDLDL's (and Clarabel's), whose arithmetic
/// the factorization follows.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CscMatrix {
    /// Rows.
    pub m: usize,
    /// Columns.
    pub n: usize,
    /// Where each column starts in `rowval` and `nzval`, and where the last ends.
    pub colptr: Vec<usize>,
    /// Row of each entry.
    pub rowval: Vec<usize>,
    /// Value of each entry.
    pub nzval: Vec<f64>,
}

impl CscMatrix {
    /// The matrix from its parts.
    pub(crate) fn new(
        m: usize,
        n: usize,
        colptr: Vec<usize>,
        rowval: Vec<usize>,
        nzval: Vec<f64>,
    ) -> Self {
        debug_assert_eq!(colptr.len(), n + 1);
        debug_assert_eq!(rowval.len(), nzval.len());
        Self {
            m,
            n,
            colptr,
            rowval,
            nzval,
        }
    }

    /// Number of stored entries.
    pub(crate) fn nnz(&self) -> usize {
        self.colptr[self.n]
    }
}
