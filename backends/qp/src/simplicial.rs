//! faer's column-by-column (up-looking) Cholesky factorization, its arithmetic to the bit, with
//! each row's elimination reach found once per pattern instead of at every factorization.
//!
//! The interior point refactors one pattern with new weights at every iteration; faer's
//! numeric factorization walks the elimination tree from every entry of every column each
//! time to find which columns update the next row. Here that walk is done once, in faer's own
//! order, and kept with where each entry of the factor goes; the factor is then laid out as
//! faer's symbolic analysis says, so faer's solves read it.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::simplicial::{
    prefactorize_symbolic_cholesky, prefactorize_symbolic_cholesky_scratch,
    SymbolicSimplicialCholesky,
};
use faer::sparse::SymbolicSparseColMatRef;

/// Why a factorization could not be done: a pivot not positive after regularization (a
/// number that is not finite), or no memory for the analysis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NotFactored;

/// The reaches of a pattern's rows, and a work vector for the numeric factorization.
pub(crate) struct Reaches {
    /// For row `k`, the entries `start[k]..start[k + 1]` of `updates`.
    start: Vec<usize>,
    /// `(j, p)`: column `j` updates row `k`, and `L[k, j]` is entry `p` of the factor.
    updates: Vec<(usize, usize)>,
    /// Zero between factorizations.
    x: Vec<f64>,
}

impl Reaches {
    /// The reaches of the upper triangle `a` (compressed by columns, entries in the order the
    /// factorization reads them) for the factor `l` that faer's analysis of `a` laid out.
    pub(crate) fn of(
        a: SymbolicSparseColMatRef<'_, usize>,
        l: &SymbolicSimplicialCholesky<usize>,
    ) -> Result<Self, NotFactored> {
        let n = a.ncols();
        let mut etree = vec![0isize; n];
        let mut counts = vec![0usize; n];
        let mut buffer = MemBuffer::try_new(prefactorize_symbolic_cholesky_scratch::<usize>(
            n,
            a.compute_nnz(),
        ))
        .map_err(|_| NotFactored)?;
        prefactorize_symbolic_cholesky(&mut etree, &mut counts, a, MemStack::new(&mut buffer));
        let l_col_ptr = l.col_ptr();
        // The next free entry of each column of `L`, its diagonal first.
        let mut next: Vec<usize> = l_col_ptr[..n].to_vec();
        let mut visited = vec![usize::MAX; n];
        let mut stack = vec![0usize; n];
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        let mut updates = Vec::with_capacity(l.len_val().saturating_sub(n));
        for k in 0..n {
            // faer's `ereach`: each entry's path up the tree to a visited node, the paths
            // stacked from the top in the order the entries come.
            let mut top = n;
            visited[k] = k;
            for &entry in &a.row_idx()[a.col_ptr()[k]..a.col_ptr()[k + 1]] {
                let mut i = entry;
                if i >= k {
                    continue;
                }
                let mut len = 0;
                while visited[i] != k {
                    stack[len] = i;
                    len += 1;
                    visited[i] = k;
                    i = usize::try_from(etree[i]).map_err(|_| NotFactored)?;
                }
                stack.copy_within(..len, top - len);
                top -= len;
            }
            for &j in &stack[top..] {
                next[j] += 1;
                updates.push((j, next[j]));
            }
            start.push(updates.len());
        }
        Ok(Self {
            start,
            updates,
            x: vec![0.0; n],
        })
    }

    /// The factor `L` (`values`, laid out as `l`) of the matrix with pattern `a` and entries
    /// `a_values`; a pivot at most `epsilon` becomes `delta` (faer's dynamic regularization).
    pub(crate) fn factor(
        &mut self,
        (a, a_values): (SymbolicSparseColMatRef<'_, usize>, &[f64]),
        l: &SymbolicSimplicialCholesky<usize>,
        (epsilon, delta): (f64, f64),
        values: &mut [f64],
    ) -> Result<(), NotFactored> {
        let (l_col_ptr, l_row_idx) = (l.col_ptr(), l.row_idx());
        let x = &mut self.x;
        x.iter_mut().for_each(|v| *v = 0.0);
        let a_col_ptr = a.col_ptr();
        for k in 0..a.ncols() {
            let column = a_col_ptr[k]..a_col_ptr[k + 1];
            for (&i, &aik) in a.row_idx()[column.clone()].iter().zip(&a_values[column]) {
                x[i] += aik;
            }
            let mut d = x[k];
            x[k] = 0.0;
            for &(j, p) in &self.updates[self.start[k]..self.start[k + 1]] {
                let j_start = l_col_ptr[j];
                let xj = x[j];
                x[j] = 0.0;
                let lkj = xj * values[j_start].recip();
                let below = j_start + 1..p;
                for (&i, &lij) in l_row_idx[below.clone()].iter().zip(&values[below]) {
                    x[i] -= lij * lkj;
                }
                d -= lkj * lkj;
                values[p] = lkj;
            }
            if d <= epsilon {
                d = delta;
            }
            // Not positive, or not a number.
            if d.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return Err(NotFactored);
            }
            values[l_col_ptr[k]] = d.sqrt();
        }
        Ok(())
    }
}
