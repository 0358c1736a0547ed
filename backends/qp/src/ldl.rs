//! The sparse `LDLᵀ` factorization the active-set method solves with: QDLDL's arithmetic, run
//! by this crate so that a factorization permutes and analyses its matrix once.
//!
//! A fresh factorization is ordered by AMD (as QDLDL orders it, [`Ldl::amd`]) or by an
//! ordering remembered from earlier factorizations (most of them on a queue at a door,
//! [`Ldl::ordered`]). A remembered ordering must first have its fill counted, to refuse one
//! that fills too much, and that count is the elimination tree that QDLDL's symbolic analysis
//! builds again right after, on a permuted copy of the matrix that it makes again too.
//! [`Ldl::ordered`] permutes once, counts the fill while it builds the tree (giving up as soon
//! as the count passes the budget), and runs QDLDL's numeric factorization on what it built:
//! the same permuted matrix, entry for entry in the same order, the same tree, the same
//! up-looking elimination with the same regularization of pivots of the wrong sign. The
//! factor and its solves are QDLDL's to the bit (property tests against QDLDL assert it), so
//! nothing downstream sees the difference but the time.

use crate::csc::CscMatrix;

/// QDLDL's default `regularize_eps`: a pivot `D[k]` with `D[k]·sign[k]` below it is replaced
/// by `sign[k]·`[`REGULARIZE_DELTA`].
const REGULARIZE_EPS: f64 = 1e-12;
/// QDLDL's default `regularize_delta`.
const REGULARIZE_DELTA: f64 = 1e-7;
/// No parent in the elimination tree (a root), or no node on a path yet.
const NONE: usize = usize::MAX;

/// An `LDLᵀ` factorization `P K Pᵀ = L D Lᵀ` of a symmetric matrix `K`, `L` unit lower
/// triangular (its diagonal implied), solved as QDLDL solves.
///
#[derive(Debug)]
pub struct Ldl {
    /// The ordering: `perm[p]` is the node eliminated at position `p`.
    perm: Vec<usize>,
    /// `L` below its diagonal, by columns.
    l: CscMatrix,
    /// `D⁻¹`.
    d_inv: Vec<f64>,
    /// The permuted right-hand side of a solve.
    work: Vec<f64>,
}

/// Why [`Ldl::ordered`] made no factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotFactored {
    /// The factor would have more entries below its diagonal than the budget.
    TooMuchFill,
    /// A pivot vanished (QDLDL's `ZeroPivot`), or `perm` is not a permutation of the nodes.
    Failed,
}

impl Ldl {
    /// [`Self::ordered`] by the AMD ordering QDLDL finds for `upper` (its default controls),
    /// with no budget: what `QDLDLFactorisation::new` gives without an ordering, to the bit.
    pub fn amd(upper: &CscMatrix, signs: &[i8]) -> Result<Self, NotFactored> {
        Self::ordered(upper, amd_ordering(upper)?, signs, f64::INFINITY)
    }

    /// The factorization of the symmetric matrix whose upper triangle (diagonal included) is
    /// `upper`, ordered by `perm` (position → node, as QDLDL takes it), the pivot of node `i`
    /// expected to have the sign `signs[i]`: what `QDLDLFactorisation::new` gives with that
    /// ordering and those `Dsigns`, to the bit, unless the factor would have more than
    /// `max_entries` entries below its diagonal (counted before any arithmetic).
    pub fn ordered(
        upper: &CscMatrix,
        perm: Vec<usize>,
        signs: &[i8],
        max_entries: f64,
    ) -> Result<Self, NotFactored> {
        Self::factorize(upper, perm, signs, max_entries)
    }

    /// [`Self::ordered`].
    fn factorize(
        upper: &CscMatrix,
        perm: Vec<usize>,
        signs: &[i8],
        max_entries: f64,
    ) -> Result<Self, NotFactored> {
        let n = upper.n;
        if perm.len() != n || signs.len() != n {
            return Err(NotFactored::Failed);
        }
        let mut position = vec![NONE; n];
        for (p, &node) in perm.iter().enumerate() {
            if node >= n || position[node] != NONE {
                return Err(NotFactored::Failed);
            }
            position[node] = p;
        }
        let permuted = permute_symmetric(upper, &position);
        let (parent, column_counts) = elimination_tree(&permuted, max_entries)?;
        let mut column_start = Vec::with_capacity(n + 1);
        column_start.push(0);
        for count in &column_counts {
            column_start.push(column_start.last().copied().unwrap_or(0) + count);
        }
        let entries = column_start[n];
        let mut l = CscMatrix::new(n, n, column_start, vec![0; entries], vec![0.0; entries]);
        let signs: Vec<i8> = perm.iter().map(|&node| signs[node]).collect();
        let d_inv = factor(&permuted, &parent, &signs, &mut l).ok_or(NotFactored::Failed)?;
        Ok(Self {
            perm,
            l,
            d_inv,
            work: vec![0.0; n],
        })
    }

    /// The ordering (position → node).
    pub fn perm(&self) -> &[usize] {
        &self.perm
    }

    /// Entries of `L` below its diagonal.
    pub fn entries_below_diagonal(&self) -> usize {
        self.l.rowval.len()
    }

    /// `b ← K⁻¹ b`, with QDLDL's arithmetic: permute, `L` forward, `D⁻¹` and `Lᵀ` backward in
    /// one pass, permute back. The forward pass skips the columns of zeros, so the answer is
    /// QDLDL's to the bit but for the sign of a zero.
    pub fn solve(&mut self, b: &mut [f64]) {
        let x = &mut self.work;
        x.iter_mut()
            .zip(&self.perm)
            .for_each(|(xi, &node)| *xi = b[node]);
        let (lp, li, lx) = (&self.l.colptr, &self.l.rowval, &self.l.nzval);
        for i in 0..x.len() {
            let xi = x[i];
            // A zero updates nothing (but the sign of a zero below it): right-hand sides of
            // bordering are a row's two to four entries, so many columns of a forward pass
            // meet a zero (measured: `docs/lab/2026-11-25-less-work-and-speculated-rescue.md`).
            if xi == 0.0 {
                continue;
            }
            for (&row, &value) in li[lp[i]..lp[i + 1]].iter().zip(&lx[lp[i]..lp[i + 1]]) {
                x[row] -= value * xi;
            }
        }
        for i in (0..x.len()).rev() {
            let mut s = 0.0;
            for (&row, &value) in li[lp[i]..lp[i + 1]].iter().zip(&lx[lp[i]..lp[i + 1]]) {
                s += value * x[row];
            }
            x[i] *= self.d_inv[i];
            x[i] -= s;
        }
        x.iter()
            .zip(&self.perm)
            .for_each(|(&xi, &node)| b[node] = xi);
    }
}

/// The AMD ordering QDLDL finds for `upper` (its default controls; position → node).
fn amd_ordering(upper: &CscMatrix) -> Result<Vec<usize>, NotFactored> {
    let (perm, _, _) = amd::order(
        upper.n,
        &upper.colptr,
        &upper.rowval,
        &amd::Control::default(),
    )
    .map_err(|_| NotFactored::Failed)?;
    Ok(perm)
}

/// `P K Pᵀ`'s upper triangle from `K`'s (`upper`), `position[node]` the position of a node:
/// entry `(i, j)`, `i ≤ j`, goes to column `max(pᵢ, pⱼ)`, row `min(pᵢ, pⱼ)`, each column's
/// entries in the order they are met column by column of `upper` (QDLDL's order, which fixes
/// the order the factorization eliminates in, and so its rounding). Entries below the
/// diagonal are left out.
fn permute_symmetric(upper: &CscMatrix, position: &[usize]) -> CscMatrix {
    let n = upper.n;
    let mut start = vec![0usize; n + 1];
    for j in 0..n {
        for &i in &upper.rowval[upper.colptr[j]..upper.colptr[j + 1]] {
            if i <= j {
                start[position[i].max(position[j]) + 1] += 1;
            }
        }
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let entries = start[n];
    let mut next = start[..n].to_vec();
    let (mut rows, mut values) = (vec![0usize; entries], vec![0.0; entries]);
    for j in 0..n {
        for e in upper.colptr[j]..upper.colptr[j + 1] {
            let i = upper.rowval[e];
            if i <= j {
                let (pi, pj) = (position[i], position[j]);
                let column = pi.max(pj);
                rows[next[column]] = pi.min(pj);
                values[next[column]] = upper.nzval[e];
                next[column] += 1;
            }
        }
    }
    CscMatrix::new(n, n, start, rows, values)
}

/// The elimination tree of the upper triangle `upper` (each node's parent, [`NONE`] for a
/// root) and the number of entries of each column of `L` below its diagonal, as QDLDL's
/// symbolic analysis counts them; [`NotFactored::TooMuchFill`] as soon as their sum passes
/// `max_entries`.
fn elimination_tree(
    upper: &CscMatrix,
    max_entries: f64,
) -> Result<(Vec<usize>, Vec<usize>), NotFactored> {
    let n = upper.n;
    let mut parent = vec![NONE; n];
    let mut counts = vec![0usize; n];
    let mut flag = vec![NONE; n];
    let mut total = 0.0;
    for k in 0..n {
        flag[k] = k;
        for &first in &upper.rowval[upper.colptr[k]..upper.colptr[k + 1]] {
            // Row k of L has an entry in each column on the path from `first` up the tree.
            let mut i = first;
            while flag[i] != k {
                if parent[i] == NONE {
                    parent[i] = k;
                }
                counts[i] += 1;
                total += 1.0;
                if total > max_entries {
                    return Err(NotFactored::TooMuchFill);
                }
                flag[i] = k;
                i = parent[i];
            }
        }
    }
    Ok((parent, counts))
}

/// QDLDL's up-looking numeric factorization of the permuted upper triangle `upper` into `l`
/// (its column pointers set, one entry per count of [`elimination_tree`]), with `parent` its
/// elimination tree and `signs` the expected signs of the pivots (in elimination order).
/// Returns `D⁻¹`, or `None` when a pivot is zero.
fn factor(
    upper: &CscMatrix,
    parent: &[usize],
    signs: &[i8],
    l: &mut CscMatrix,
) -> Option<Vec<f64>> {
    let n = upper.n;
    let (ap, ai, ax) = (&upper.colptr, &upper.rowval, &upper.nzval);
    let mut d = vec![0.0; n];
    let mut d_inv = vec![0.0; n];
    let mut y = vec![0.0; n];
    let mut used = vec![false; n];
    let mut pattern = vec![0usize; n];
    let mut path = vec![0usize; n];
    let mut next_in_column = l.colptr[..n].to_vec();
    let mut row_of_l = Vec::with_capacity(n);
    let pivot = |k: usize, value: f64| regularized_pivot(value, signs[k]);
    if n == 0 {
        return Some(d_inv);
    }
    // QDLDL takes the first entry of the first column as its diagonal.
    d[0] = pivot(0, ax.first().copied().unwrap_or(0.0))?;
    d_inv[0] = d[0].recip();
    for k in 1..n {
        // Row k of L: where its entries go (the tree's paths from the entries of column k,
        // each listed back to front), then their values, last listed first.
        let mut entries = 0;
        for e in ap[k]..ap[k + 1] {
            let b = ai[e];
            if b == k {
                d[k] = ax[e];
                continue;
            }
            y[b] = ax[e];
            if used[b] {
                continue;
            }
            used[b] = true;
            path[0] = b;
            let mut length = 1;
            let mut next = parent[b];
            while next != NONE && next < k && !used[next] {
                used[next] = true;
                path[length] = next;
                next = parent[next];
                length += 1;
            }
            while length != 0 {
                length -= 1;
                pattern[entries] = path[length];
                entries += 1;
            }
        }
        row_of_l.clear();
        for &c in pattern[..entries].iter().rev() {
            let place = next_in_column[c];
            l.rowval[place] = k;
            next_in_column[c] += 1;
            used[c] = false;
            row_of_l.push((c, place));
        }
        d[k] = eliminate_row(&row_of_l, d[k], &mut y, l, &d_inv);
        d[k] = pivot(k, d[k])?;
        d_inv[k] = d[k].recip();
    }
    Some(d_inv)
}

/// QDLDL's rule for a pivot `value` expected to have the sign `sign`: one of the wrong sign,
/// or smaller than [`REGULARIZE_EPS`], is replaced by `sign·`[`REGULARIZE_DELTA`]; `None`
/// when the pivot is then zero (no sign), which QDLDL reports as a failure.
fn regularized_pivot(value: f64, sign: i8) -> Option<f64> {
    let sign = f64::from(sign);
    let value = if value * sign < REGULARIZE_EPS {
        REGULARIZE_DELTA * sign
    } else {
        value
    };
    (value != 0.0).then_some(value)
}

/// Row `k` of `L`, QDLDL's up-looking step: `y` holds column `k` of the permuted matrix above
/// its diagonal (scattered), `row` the entries of the row as `(column c, place in l)`, in the
/// order QDLDL eliminates with them (each column after every column that updates it). Writes
/// `L[k, c]` at each place, leaves `y` zero on the row's columns, and returns `pivot` (the
/// diagonal entry) minus the row's contributions, subtracted in that order: the rounding is
/// QDLDL's only in that order.
fn eliminate_row(
    row: &[(usize, usize)],
    mut pivot: f64,
    y: &mut [f64],
    l: &mut CscMatrix,
    d_inv: &[f64],
) -> f64 {
    for &(c, place) in row {
        let yc = y[c];
        y[c] = 0.0;
        // Column c's entries above row k are already final.
        let range = l.colptr[c]..place;
        for (&i, &value) in l.rowval[range.clone()].iter().zip(&l.nzval[range]) {
            y[i] -= value * yc;
        }
        let entry = yc * d_inv[c];
        l.nzval[place] = entry;
        pivot -= yc * entry;
    }
    pivot
}

#[cfg(test)]
mod tests {
    use super::*;
    use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
    use proptest::prelude::*;

    /// The upper triangle of `[I Aᵀ; A −δI]` for `rows` of `A` on `n` unknowns, and the
    /// signs of its pivots.
    fn kkt(n: usize, rows: &[Vec<(usize, f64)>], delta: f64) -> (CscMatrix, Vec<i8>) {
        let k = rows.len();
        let mut colptr = vec![0];
        let (mut rowval, mut nzval) = (Vec::new(), Vec::new());
        for j in 0..n {
            rowval.push(j);
            nzval.push(1.0);
            colptr.push(rowval.len());
        }
        for (t, row) in rows.iter().enumerate() {
            let mut entries: Vec<(usize, f64)> = Vec::new();
            for &(c, a) in row {
                match entries.iter_mut().find(|(e, _)| *e == c) {
                    Some(entry) => entry.1 += a,
                    None => entries.push((c, a)),
                }
            }
            entries.sort_by_key(|&(c, _)| c);
            for (c, a) in entries {
                rowval.push(c);
                nzval.push(a);
            }
            rowval.push(n + t);
            nzval.push(-delta);
            colptr.push(rowval.len());
        }
        let signs = (0..n + k).map(|i| if i < n { 1 } else { -1 }).collect();
        (CscMatrix::new(n + k, n + k, colptr, rowval, nzval), signs)
    }

    /// `upper` as Clarabel's matrix type, which QDLDL takes.
    fn theirs(upper: &CscMatrix) -> clarabel::algebra::CscMatrix<f64> {
        clarabel::algebra::CscMatrix::new(
            upper.m,
            upper.n,
            upper.colptr.clone(),
            upper.rowval.clone(),
            upper.nzval.clone(),
        )
    }

    fn qdldl(upper: &CscMatrix, perm: &[usize], signs: &[i8]) -> QDLDLFactorisation<f64> {
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(signs.to_vec());
        builder.perm(perm.to_vec());
        QDLDLFactorisation::new(&theirs(upper), Some(builder.build().unwrap())).unwrap()
    }

    /// Rows of two or four entries on `n` unknowns (people's contacts and walls), some
    /// repeated (contact loops make the KKT matrix's pivots regularize), a permutation of
    /// the KKT matrix's nodes, and a right-hand side.
    /// Unknowns, rows, an ordering of the KKT matrix's nodes and a right-hand side.
    type System = (usize, Vec<Vec<(usize, f64)>>, Vec<usize>, Vec<f64>);

    fn system() -> impl Strategy<Value = System> {
        (2usize..12)
            .prop_flat_map(|n| {
                let entry = (0..n, -2.0f64..2.0);
                let rows = proptest::collection::vec(proptest::collection::vec(entry, 1..4), 1..14);
                (Just(n), rows)
            })
            .prop_flat_map(|(n, rows)| {
                let size = n + rows.len();
                let perm = Just((0..size).collect::<Vec<usize>>()).prop_shuffle();
                // Half the entries zero, as in a bordering's column, which the forward pass
                // skips.
                let entry = prop_oneof![Just(0.0), -3.0f64..3.0];
                let rhs = proptest::collection::vec(entry, size);
                (Just(n), Just(rows), perm, rhs)
            })
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// `ours` is `theirs` to the bit: ordering, factor, `D⁻¹`, and the solve of `rhs` (but
    /// for the sign of a zero, which skipping a zero of the forward pass can keep where
    /// QDLDL's `x − l·0` would flip a `−0`).
    fn same_bits(
        mut ours: Ldl,
        theirs: &mut QDLDLFactorisation<f64>,
        rhs: Vec<f64>,
    ) -> Result<(), TestCaseError> {
        prop_assert_eq!(&ours.perm, &theirs.perm);
        prop_assert_eq!(&ours.l.colptr, &theirs.L.colptr);
        prop_assert_eq!(&ours.l.rowval, &theirs.L.rowval);
        prop_assert_eq!(bits(&ours.l.nzval), bits(&theirs.L.nzval));
        prop_assert_eq!(bits(&ours.d_inv), bits(&theirs.Dinv));
        let (mut a, mut b) = (rhs.clone(), rhs);
        ours.solve(&mut a);
        theirs.solve(&mut b);
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            prop_assert!(
                x.to_bits() == y.to_bits() || (*x == 0.0 && *y == 0.0),
                "entry {i} of the solve: {x:e} against QDLDL's {y:e}"
            );
        }
        Ok(())
    }

    proptest! {
        /// For any ordering, the factor is QDLDL's to the bit, and so is every solve.
        #[test]
        fn an_ordered_factorization_is_qdldls_to_the_bit(
            (n, rows, perm, rhs) in system(),
            delta_exponent in -12i32..0,
        ) {
            let (upper, signs) = kkt(n, &rows, 10f64.powi(delta_exponent));
            let mut theirs = qdldl(&upper, &perm, &signs);
            let ours = Ldl::ordered(&upper, perm.clone(), &signs, f64::INFINITY).unwrap();
            same_bits(ours, &mut theirs, rhs)?;
        }

        /// Ordered by AMD, the factor is QDLDL's own (no ordering given) to the bit.
        #[test]
        fn an_amd_factorization_is_qdldls_to_the_bit((n, rows, _perm, rhs) in system()) {
            let (upper, signs) = kkt(n, &rows, 1e-9);
            let mut theirs = qdldl_amd(&upper, &signs);
            let ours = Ldl::amd(&upper, &signs).unwrap();
            same_bits(ours, &mut theirs, rhs)?;
        }

        /// The fill is refused exactly when it passes the budget.
        #[test]
        fn the_budget_refuses_exactly_a_fill_beyond_it((n, rows, perm, _rhs) in system()) {
            let (upper, signs) = kkt(n, &rows, 1e-9);
            let fill = qdldl(&upper, &perm, &signs).nnzL() as f64;
            prop_assert!(Ldl::ordered(&upper, perm.clone(), &signs, fill).is_ok());
            prop_assert_eq!(
                Ldl::ordered(&upper, perm, &signs, fill - 1.0).err(),
                Some(NotFactored::TooMuchFill)
            );
        }
    }

    #[test]
    fn the_factor_solves_its_matrix() {
        // Two unknowns, a row joining them twice (a loop): K_δ is quasi-definite.
        let rows = vec![
            vec![(0, 1.0), (1, -1.0)],
            vec![(0, 1.0), (1, -1.0)],
            vec![(1, 2.0)],
        ];
        let (upper, signs) = kkt(2, &rows, 1e-3);
        let size = upper.n;
        let mut dense = vec![vec![0.0; size]; size];
        for (j, window) in upper.colptr.windows(2).enumerate() {
            for e in window[0]..window[1] {
                let (i, value) = (upper.rowval[e], upper.nzval[e]);
                dense[i][j] = value;
                dense[j][i] = value;
            }
        }
        for perm in [
            vec![0, 1, 2, 3, 4],
            vec![4, 3, 2, 1, 0],
            vec![2, 0, 4, 1, 3],
        ] {
            let mut ldl = Ldl::ordered(&upper, perm.clone(), &signs, f64::INFINITY).unwrap();
            let x: Vec<f64> = (0..size).map(|i| i as f64 - 1.5).collect();
            let mut b: Vec<f64> = dense
                .iter()
                .map(|row| row.iter().zip(&x).map(|(a, xi)| a * xi).sum())
                .collect();
            ldl.solve(&mut b);
            for (got, want) in b.iter().zip(&x) {
                assert!((got - want).abs() < 1e-9, "{perm:?}: {got} against {want}");
            }
            assert_eq!(ldl.perm(), &perm[..]);
        }
    }

    #[test]
    fn a_permutation_that_is_not_one_is_refused() {
        let (upper, signs) = kkt(2, &[vec![(0, 1.0)]], 1e-9);
        for perm in [vec![0, 1], vec![0, 1, 1], vec![0, 1, 3]] {
            assert_eq!(
                Ldl::ordered(&upper, perm, &signs, f64::INFINITY).err(),
                Some(NotFactored::Failed)
            );
        }
    }

    #[test]
    fn a_zero_pivot_fails() {
        // A 1 × 1 matrix [0] whose expected sign is +: regularized to 1e-7, not zero; with
        // no sign (0) it stays zero and the factorization fails, as QDLDL's does.
        let upper = CscMatrix::new(1, 1, vec![0, 1], vec![0], vec![0.0]);
        let ok = Ldl::ordered(&upper, vec![0], &[1], f64::INFINITY).unwrap();
        assert_eq!(ok.d_inv, vec![1e7]);
        assert_eq!(
            Ldl::ordered(&upper, vec![0], &[0], f64::INFINITY).err(),
            Some(NotFactored::Failed)
        );
        // Without a sign, QDLDL zeroes even a good pivot (`D·0 < eps`) and fails; so does this.
        let one = CscMatrix::new(1, 1, vec![0, 1], vec![0], vec![1.0]);
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(vec![0]);
        assert!(QDLDLFactorisation::new(&theirs(&one), Some(builder.build().unwrap())).is_err());
        assert_eq!(
            Ldl::ordered(&one, vec![0], &[0], f64::INFINITY).err(),
            Some(NotFactored::Failed)
        );
    }

    fn qdldl_amd(upper: &CscMatrix, signs: &[i8]) -> QDLDLFactorisation<f64> {
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(signs.to_vec());
        QDLDLFactorisation::new(&theirs(upper), Some(builder.build().unwrap())).unwrap()
    }
}
