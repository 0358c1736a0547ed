//! Numeric refactorization of a QDLDL factor whose pattern does not change, with the pattern
//! of each row of `L` worked out once.
//!
//! The interior point refactors `I + AᵀWA` at every iteration with the same pattern and new
//! values. QDLDL's own `refactor` recomputes, for every row `k` of `L`, which columns it
//! reaches (a walk up the elimination tree from each entry of column `k` of the matrix,
//! with markers) before it does any arithmetic; on the normal matrices of jams (10 000
//! unknowns, 2–4 entries of `L` per column) that walk, not the arithmetic, was most of the
//! time. [`Refactor`] records those row patterns, and where each entry of `L` lives, from the
//! first factorization, and then runs only the arithmetic: the same up-looking `LDLᵀ`, with
//! the same pivots (and QDLDL's default regularization of a vanishing one), writing into the
//! factor so that QDLDL's `solve` uses it unchanged. It eliminates in QDLDL's order, so the
//! factor is QDLDL's to the bit: near an interior point's answer the normal matrix's
//! weights span twenty orders of magnitude, and another (equally valid) order changed
//! which iterations broke down.

use clarabel::algebra::CscMatrix;
use clarabel::qdldl::QDLDLFactorisation;

/// QDLDL's default `regularize_eps`: a pivot below it (for a positive definite matrix, whose
/// pivots `Dsigns` says are positive) is replaced by [`REGULARIZE_DELTA`].
const REGULARIZE_EPS: f64 = 1e-12;
/// QDLDL's default `regularize_delta`.
const REGULARIZE_DELTA: f64 = 1e-7;

/// The arithmetic of an `LDLᵀ` refactorization on a fixed pattern (see the module's docs).
#[derive(Debug)]
pub(crate) struct Refactor {
    /// For each entry of the caller's upper triangle, its place in [`Self::values`].
    place: Vec<usize>,
    /// The permuted upper triangle `P A Pᵀ` by columns: where each column starts…
    column_start: Vec<usize>,
    /// …the row of each entry…
    row: Vec<usize>,
    /// …and its value.
    values: Vec<f64>,
    /// Where the pattern of each row of `L` starts in [`Self::row_pattern`].
    row_start: Vec<usize>,
    /// Row by row, in the order QDLDL eliminates with them: `(c, p)` for each entry
    /// `L[k, c]`, `p` its position in `L`'s columns.
    row_pattern: Vec<(usize, usize)>,
    /// The row of `L` being computed, scattered (all zeros between rows).
    work: Vec<f64>,
}

impl Refactor {
    /// The patterns of `ldl`, a factorization of `upper` (upper triangle by columns), whose
    /// ordering and factor pattern every later refactorization keeps.
    pub(crate) fn new(upper: &CscMatrix<f64>, ldl: &QDLDLFactorisation<f64>) -> Self {
        let n = upper.n;
        let mut position = vec![0; n];
        for (p, &node) in ldl.perm.iter().enumerate() {
            position[node] = p;
        }
        // Entry (i, j) of `upper` is entry (min, max) of the permuted upper triangle.
        let nnz = upper.rowval.len();
        let mut permuted = Vec::with_capacity(nnz);
        let mut column_start = vec![0usize; n + 1];
        for j in 0..n {
            for &i in &upper.rowval[upper.colptr[j]..upper.colptr[j + 1]] {
                let (pi, pj) = (position[i], position[j]);
                let (r, c) = (pi.min(pj), pi.max(pj));
                permuted.push((r, c));
                column_start[c + 1] += 1;
            }
        }
        prefix_sums(&mut column_start);
        let mut next = column_start.clone();
        let mut row = vec![0; nnz];
        let mut place = vec![0; nnz];
        for (e, &(r, c)) in permuted.iter().enumerate() {
            place[e] = next[c];
            row[next[c]] = r;
            next[c] += 1;
        }
        // The rows of `L`, each in the order QDLDL's up-looking factorization eliminates
        // with its columns: for each entry of column k of the matrix, the path up the
        // elimination tree (a column's parent is the first row below its diagonal) to a
        // node already on the list, or to k; the paths are listed back to front and
        // eliminated last list entry first. With the same order the arithmetic is QDLDL's,
        // so the factor is too, to the bit.
        const NONE: usize = usize::MAX;
        let l = &ldl.L;
        let parent: Vec<usize> = (0..n)
            .map(|c| {
                let first = l.colptr[c];
                if first < l.colptr[c + 1] {
                    l.rowval[first]
                } else {
                    NONE
                }
            })
            .collect();
        let mut next_in_column = l.colptr[..n].to_vec();
        let mut on_list = vec![false; n];
        let mut path = Vec::new();
        let mut list = Vec::new();
        let mut row_start = Vec::with_capacity(n + 1);
        row_start.push(0);
        let mut row_pattern = Vec::with_capacity(l.rowval.len());
        for k in 0..n {
            list.clear();
            for &i in &row[column_start[k]..column_start[k + 1]] {
                if i == k || on_list[i] {
                    continue;
                }
                path.clear();
                let mut node = i;
                while node != NONE && node < k && !on_list[node] {
                    on_list[node] = true;
                    path.push(node);
                    node = parent[node];
                }
                list.extend(path.iter().rev());
            }
            for &c in list.iter().rev() {
                row_pattern.push((c, next_in_column[c]));
                next_in_column[c] += 1;
                on_list[c] = false;
            }
            row_start.push(row_pattern.len());
        }
        Self {
            place,
            column_start,
            row,
            values: vec![0.0; nnz],
            row_start,
            row_pattern,
            work: vec![0.0; n],
        }
    }

    /// Refactors `ldl` for `values`, the entries of the upper triangle it was made from, in
    /// that triangle's order. `false` when a pivot is not finite (the factor is then not
    /// usable).
    pub(crate) fn refactor(&mut self, values: &[f64], ldl: &mut QDLDLFactorisation<f64>) -> bool {
        for (&v, &place) in values.iter().zip(&self.place) {
            self.values[place] = v;
        }
        let (lp, li) = (&ldl.L.colptr, &ldl.L.rowval);
        let lx = &mut ldl.L.nzval;
        let y = &mut self.work;
        for k in 0..y.len() {
            // Row k of L solves L[..k, ..k] D y = A[..k, k]: scatter the column above the
            // diagonal, then eliminate with the columns it reaches (each column c only
            // updates rows after c, and comes after every column that updates it).
            let mut pivot = 0.0;
            for e in self.column_start[k]..self.column_start[k + 1] {
                let i = self.row[e];
                if i == k {
                    pivot = self.values[e];
                } else {
                    y[i] = self.values[e];
                }
            }
            for &(c, p) in &self.row_pattern[self.row_start[k]..self.row_start[k + 1]] {
                let yc = y[c];
                y[c] = 0.0;
                // Column c's entries above row k are already final.
                for (&i, &l) in li[lp[c]..p].iter().zip(&lx[lp[c]..p]) {
                    y[i] -= l * yc;
                }
                let lkc = yc * ldl.Dinv[c];
                lx[p] = lkc;
                pivot -= yc * lkc;
            }
            if !pivot.is_finite() {
                return false;
            }
            if pivot < REGULARIZE_EPS {
                pivot = REGULARIZE_DELTA;
            }
            ldl.D[k] = pivot;
            ldl.Dinv[k] = 1.0 / pivot;
        }
        true
    }
}

/// Turns counts at `1..` into where each group starts.
fn prefix_sums(v: &mut [usize]) {
    for j in 1..v.len() {
        v[j] += v[j - 1];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clarabel::qdldl::QDLDLSettingsBuilder;
    use proptest::prelude::*;

    /// The upper triangle of a dense symmetric matrix, by columns, without its zeros.
    fn upper(dense: &[Vec<f64>]) -> CscMatrix<f64> {
        let n = dense.len();
        let (mut colptr, mut rowval, mut nzval) = (vec![0], vec![], vec![]);
        for j in 0..n {
            for (i, row) in dense.iter().enumerate().take(j + 1) {
                if row[j] != 0.0 || i == j {
                    rowval.push(i);
                    nzval.push(row[j]);
                }
            }
            colptr.push(rowval.len());
        }
        CscMatrix::new(n, n, colptr, rowval, nzval)
    }

    fn factor(m: &CscMatrix<f64>) -> QDLDLFactorisation<f64> {
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(vec![1; m.n]);
        QDLDLFactorisation::new(m, Some(builder.build().unwrap())).unwrap()
    }

    /// `I + Aᵀ W A` for a sparse `A` (rows of up to four entries, as a contact's) and
    /// weights `w`.
    fn normal(n: usize, rows: &[Vec<(usize, f64)>], w: &[f64]) -> Vec<Vec<f64>> {
        let mut m = vec![vec![0.0; n]; n];
        (0..n).for_each(|i| m[i][i] = 1.0);
        for (row, wi) in rows.iter().zip(w) {
            for &(p, a) in row {
                for &(q, b) in row {
                    m[p][q] += wi * a * b;
                }
            }
        }
        m
    }

    fn rows_strategy() -> impl Strategy<Value = (usize, Vec<Vec<(usize, f64)>>)> {
        (4usize..24).prop_flat_map(|n| {
            let row = proptest::collection::btree_map(0..n, -1.0f64..1.0, 1..=4)
                .prop_map(|m| m.into_iter().collect::<Vec<_>>());
            (Just(n), proptest::collection::vec(row, 1..30))
        })
    }

    proptest! {
        /// Refactored for new weights spanning twelve orders of magnitude (as an interior
        /// point's near the answer), the factor is QDLDL's own refactorization of the same
        /// values, to the bit, and it solves the new matrix.
        #[test]
        fn refactoring_gives_qdldls_factor_for_the_new_values(
            (n, rows) in rows_strategy(),
            exponents in proptest::collection::vec(-6.0f64..6.0, 30),
        ) {
            let first = upper(&normal(n, &rows, &vec![1.0; rows.len()]));
            let w: Vec<f64> = exponents.iter().take(rows.len()).map(|e| 10f64.powf(*e)).collect();
            let dense = normal(n, &rows, &w);
            let second = upper(&dense);
            prop_assert_eq!(&first.rowval, &second.rowval);

            let mut ours = factor(&first);
            let mut refactor = Refactor::new(&first, &ours);
            prop_assert!(refactor.refactor(&second.nzval, &mut ours));
            let mut theirs = factor(&first);
            let every: Vec<usize> = (0..second.nzval.len()).collect();
            theirs.update_values(&every, &second.nzval);
            theirs.refactor().unwrap();

            prop_assert_eq!(&ours.D, &theirs.D);
            prop_assert_eq!(&ours.Dinv, &theirs.Dinv);
            prop_assert_eq!(&ours.L.nzval, &theirs.L.nzval);
            // And the factor solves the matrix: M x = b for b = M·1.
            let mut x: Vec<f64> = dense.iter().map(|r| r.iter().sum()).collect();
            ours.solve(&mut x);
            for v in &x {
                prop_assert!((v - 1.0).abs() <= 1e-6, "x = {v}, not 1");
            }
        }
    }

    #[test]
    fn a_vanishing_pivot_is_regularized_as_qdldl_does() {
        // [[1, 1], [1, 1]]: the second pivot is 1 − 1 = 0.
        let first = upper(&[vec![2.0, 1.0], vec![1.0, 2.0]]);
        let mut ldl = factor(&first);
        let mut refactor = Refactor::new(&first, &ldl);
        assert!(refactor.refactor(&[1.0, 1.0, 1.0], &mut ldl));
        assert_eq!(ldl.D, vec![1.0, REGULARIZE_DELTA]);
        assert_eq!(ldl.Dinv, vec![1.0, 1.0 / REGULARIZE_DELTA]);
        // QDLDL's refactor of the same values gives the same.
        let mut theirs = factor(&first);
        theirs.update_values(&[0, 1, 2], &[1.0, 1.0, 1.0]);
        theirs.refactor().unwrap();
        assert_eq!(theirs.D, ldl.D);
        // A pivot of exactly the threshold is kept, as QDLDL keeps it.
        assert!(refactor.refactor(&[1.0, 0.0, REGULARIZE_EPS], &mut ldl));
        theirs.update_values(&[0, 1, 2], &[1.0, 0.0, REGULARIZE_EPS]);
        theirs.refactor().unwrap();
        assert_eq!(theirs.D, ldl.D);
        assert!(ldl.D.contains(&REGULARIZE_EPS));
    }

    #[test]
    fn a_pivot_that_is_not_finite_fails_the_refactorization() {
        let first = upper(&[vec![2.0, 1.0], vec![1.0, 2.0]]);
        let mut ldl = factor(&first);
        let mut refactor = Refactor::new(&first, &ldl);
        assert!(!refactor.refactor(&[1.0, f64::INFINITY, 1.0], &mut ldl));
        assert!(!refactor.refactor(&[f64::NAN, 0.0, 1.0], &mut ldl));
        // A failed row leaves the work row clean: the next refactorization is QDLDL's.
        assert!(refactor.refactor(&[4.0, 2.0, 5.0], &mut ldl));
        let mut theirs = factor(&first);
        theirs.update_values(&[0, 1, 2], &[4.0, 2.0, 5.0]);
        theirs.refactor().unwrap();
        assert_eq!(ldl.D, theirs.D);
        assert_eq!(ldl.L.nzval, theirs.L.nzval);
    }
}
