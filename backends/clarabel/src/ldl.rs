//! The sparse `LDLᵀ` factorization the active-set method (and the native backend's interior
//! point) solves with: QDLDL's arithmetic, run by this crate so that a factorization permutes
//! and analyses its matrix once.
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
//!
//! [`Refactor`] refactors a factor numerically when only the matrix's values change (the
//! native backend's interior point, at every iteration). It eliminates each row of `L` with
//! the same code as the fresh factorization, on row patterns recorded once, so both are
//! QDLDL's arithmetic written once.

use clarabel::algebra::CscMatrix;

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
/// ```
/// use clarabel::algebra::CscMatrix;
/// use sweeping_clarabel::ldl::Ldl;
///
/// // [[4, 1], [1, 3]] by its upper triangle, both pivots positive.
/// let upper = CscMatrix::new(2, 2, vec![0, 1, 3], vec![0, 0, 1], vec![4.0, 1.0, 3.0]);
/// let mut ldl = Ldl::amd(&upper, &[1, 1]).unwrap();
/// let mut b = vec![5.0, 4.0]; // the matrix times [1, 1]
/// ldl.solve(&mut b);
/// assert!((b[0] - 1.0).abs() < 1e-12 && (b[1] - 1.0).abs() < 1e-12);
/// ```
#[derive(Debug)]
pub struct Ldl {
    /// The ordering: `perm[p]` is the node eliminated at position `p`.
    perm: Vec<usize>,
    /// The expected sign of each pivot, in elimination order.
    signs: Vec<i8>,
    /// `L` below its diagonal, by columns.
    l: CscMatrix<f64>,
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
    pub fn amd(upper: &CscMatrix<f64>, signs: &[i8]) -> Result<Self, NotFactored> {
        Self::ordered(upper, amd_ordering(upper)?, signs, f64::INFINITY)
    }

    /// The factorization of the symmetric matrix whose upper triangle (diagonal included) is
    /// `upper`, ordered by `perm` (position → node, as QDLDL takes it), the pivot of node `i`
    /// expected to have the sign `signs[i]`: what `QDLDLFactorisation::new` gives with that
    /// ordering and those `Dsigns`, to the bit, unless the factor would have more than
    /// `max_entries` entries below its diagonal (counted before any arithmetic).
    pub fn ordered(
        upper: &CscMatrix<f64>,
        perm: Vec<usize>,
        signs: &[i8],
        max_entries: f64,
    ) -> Result<Self, NotFactored> {
        Self::factorize(upper, perm, signs, max_entries, None)
    }

    /// [`Self::amd`], with what a [`Refactor`] of the factor needs recorded on the way (the
    /// permuted matrix, where each entry of `upper` went, and the pattern of each row of `L`):
    /// for a matrix whose values change and whose pattern does not.
    pub fn amd_refactorable(
        upper: &CscMatrix<f64>,
        signs: &[i8],
    ) -> Result<(Self, Refactor), NotFactored> {
        let perm = amd_ordering(upper)?;
        let mut refactor = Refactor::default();
        let ldl = Self::factorize(upper, perm, signs, f64::INFINITY, Some(&mut refactor))?;
        Ok((ldl, refactor))
    }

    /// [`Self::ordered`], filling `refactor` (when given) as it goes.
    fn factorize(
        upper: &CscMatrix<f64>,
        perm: Vec<usize>,
        signs: &[i8],
        max_entries: f64,
        refactor: Option<&mut Refactor>,
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
        let mut place = refactor
            .as_ref()
            .map(|_| Vec::with_capacity(upper.rowval.len()));
        let permuted = permute_symmetric(upper, &position, place.as_mut());
        let (parent, column_counts) = elimination_tree(&permuted, max_entries)?;
        let mut column_start = Vec::with_capacity(n + 1);
        column_start.push(0);
        for count in &column_counts {
            column_start.push(column_start.last().copied().unwrap_or(0) + count);
        }
        let entries = column_start[n];
        let mut l = CscMatrix::new(n, n, column_start, vec![0; entries], vec![0.0; entries]);
        let signs: Vec<i8> = perm.iter().map(|&node| signs[node]).collect();
        let mut rows = refactor.as_ref().map(|_| RowPatterns::default());
        let d_inv =
            factor(&permuted, &parent, &signs, &mut l, rows.as_mut()).ok_or(NotFactored::Failed)?;
        if let (Some(refactor), Some(rows), Some(place)) = (refactor, rows, place) {
            *refactor = Refactor {
                values: vec![0.0; permuted.nzval.len()],
                place,
                column_start: permuted.colptr,
                row: permuted.rowval,
                row_start: rows.start,
                row_pattern: rows.entries,
                work: vec![0.0; n],
            };
        }
        Ok(Self {
            perm,
            signs,
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
            // bordering are a row's two to four entries, and about two in five columns of all
            // forward passes on the paper's evacuation meet a zero.
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
fn amd_ordering(upper: &CscMatrix<f64>) -> Result<Vec<usize>, NotFactored> {
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
/// the order the factorization eliminates in, and so its rounding). Where each entry of
/// `upper` went is pushed onto `place`, when given ([`NONE`] for one below the diagonal,
/// which is left out).
fn permute_symmetric(
    upper: &CscMatrix<f64>,
    position: &[usize],
    mut place: Option<&mut Vec<usize>>,
) -> CscMatrix<f64> {
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
            let destination = if i > j {
                NONE
            } else {
                let (pi, pj) = (position[i], position[j]);
                let column = pi.max(pj);
                rows[next[column]] = pi.min(pj);
                values[next[column]] = upper.nzval[e];
                next[column] += 1;
                next[column] - 1
            };
            if let Some(place) = place.as_deref_mut() {
                place.push(destination);
            }
        }
    }
    CscMatrix::new(n, n, start, rows, values)
}

/// The pattern of each row of `L`, as the factorization eliminates with it.
#[derive(Debug, Default)]
struct RowPatterns {
    /// Where each row starts in [`Self::entries`] (one more than the rows).
    start: Vec<usize>,
    /// Row by row: `(c, p)` for each entry `L[k, c]`, `p` its place in `L`'s columns.
    entries: Vec<(usize, usize)>,
}

/// The elimination tree of the upper triangle `upper` (each node's parent, [`NONE`] for a
/// root) and the number of entries of each column of `L` below its diagonal, as QDLDL's
/// symbolic analysis counts them; [`NotFactored::TooMuchFill`] as soon as their sum passes
/// `max_entries`.
fn elimination_tree(
    upper: &CscMatrix<f64>,
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
    upper: &CscMatrix<f64>,
    parent: &[usize],
    signs: &[i8],
    l: &mut CscMatrix<f64>,
    mut record: Option<&mut RowPatterns>,
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
    if let Some(rows) = record.as_deref_mut() {
        // Row 0 has no entries.
        rows.start.extend([0, 0]);
    }
    if n == 0 {
        if let Some(rows) = record {
            rows.start.truncate(1);
        }
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
        if let Some(rows) = record.as_deref_mut() {
            rows.entries.extend_from_slice(&row_of_l);
            rows.start.push(rows.entries.len());
        }
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
    l: &mut CscMatrix<f64>,
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

/// Numeric refactorization of an [`Ldl`] whose matrix keeps its pattern and changes its
/// values, with the pattern of each row of `L` worked out once (by the first factorization,
/// [`Ldl::amd_refactorable`]).
///
/// The interior point refactors `I + AᵀWA` at every iteration with the same pattern and new
/// values. A fresh factorization works out, for every row `k` of `L`, which columns it
/// reaches (a walk up the elimination tree from each entry of column `k` of the matrix,
/// with markers) before it does any arithmetic; on the normal matrices of jams (10 000
/// unknowns, 2–4 entries of `L` per column) that walk, not the arithmetic, was most of the
/// time. [`Refactor`] keeps those row patterns, and where each entry of `L` lives, as the
/// first factorization found them, and then runs only the arithmetic: the same row
/// elimination as the fresh factorization, in the same order and with the same pivot rule,
/// so the factor is
/// QDLDL's refactorization to the bit (near an interior point's answer the normal matrix's
/// weights span twenty orders of magnitude, and another, equally valid, order changed which
/// iterations broke down).
///
/// ```
/// use clarabel::algebra::CscMatrix;
/// use sweeping_clarabel::ldl::{Ldl, Refactor};
///
/// let upper = CscMatrix::new(2, 2, vec![0, 1, 3], vec![0, 0, 1], vec![4.0, 1.0, 3.0]);
/// let (mut ldl, mut refactor) = Ldl::amd_refactorable(&upper, &[1, 1]).unwrap();
/// // New values on the same pattern: [[2, 1], [1, 2]].
/// assert!(refactor.refactor(&[2.0, 1.0, 2.0], &mut ldl));
/// let mut b = vec![3.0, 3.0];
/// ldl.solve(&mut b);
/// assert!((b[0] - 1.0).abs() < 1e-12 && (b[1] - 1.0).abs() < 1e-12);
/// ```
#[derive(Debug, Default)]
pub struct Refactor {
    /// For each entry of the caller's upper triangle, its place in [`Self::values`] ([`NONE`]
    /// for an entry below the diagonal, left out as the factorization leaves it out).
    place: Vec<usize>,
    /// The permuted upper triangle `P A Pᵀ` by columns: where each column starts…
    column_start: Vec<usize>,
    /// …the row of each entry…
    row: Vec<usize>,
    /// …and its value.
    values: Vec<f64>,
    /// Where the pattern of each row of `L` starts in [`Self::row_pattern`].
    row_start: Vec<usize>,
    /// Row by row, in the order the factorization eliminates with them: `(c, p)` for each
    /// entry `L[k, c]`, `p` its place in `L`'s columns.
    row_pattern: Vec<(usize, usize)>,
    /// The row of `L` being computed, scattered (all zeros between rows).
    work: Vec<f64>,
}

impl Refactor {
    /// Refactors `ldl` for `values`, the entries of the upper triangle it was made from, in
    /// that triangle's order. `false` when a pivot is not finite, or zero (the factor is then
    /// not usable), and, leaving `ldl` as it was, when `values` or `ldl` is not the size this
    /// refactorization was recorded for (a default `Refactor` fits no factor).
    pub fn refactor(&mut self, values: &[f64], ldl: &mut Ldl) -> bool {
        if values.len() != self.place.len()
            || ldl.d_inv.len() != self.work.len()
            || ldl.l.rowval.len() != self.row_pattern.len()
        {
            return false;
        }
        for (&v, &place) in values.iter().zip(&self.place) {
            if place != NONE {
                self.values[place] = v;
            }
        }
        let y = &mut self.work;
        for k in 0..y.len() {
            // Row k of L solves L[..k, ..k] D y = A[..k, k]: scatter the column above the
            // diagonal, then eliminate with the columns it reaches.
            let mut pivot = 0.0;
            for e in self.column_start[k]..self.column_start[k + 1] {
                let i = self.row[e];
                if i == k {
                    pivot = self.values[e];
                } else {
                    y[i] = self.values[e];
                }
            }
            let row = &self.row_pattern[self.row_start[k]..self.row_start[k + 1]];
            let pivot = eliminate_row(row, pivot, y, &mut ldl.l, &ldl.d_inv);
            // Stricter than QDLDL, which would regularize −∞ and carry NaN on.
            if !pivot.is_finite() {
                return false;
            }
            match regularized_pivot(pivot, ldl.signs[k]) {
                Some(pivot) => ldl.d_inv[k] = pivot.recip(),
                None => return false,
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
    use proptest::prelude::*;

    /// The upper triangle of `[I Aᵀ; A −δI]` for `rows` of `A` on `n` unknowns, and the
    /// signs of its pivots.
    fn kkt(n: usize, rows: &[Vec<(usize, f64)>], delta: f64) -> (CscMatrix<f64>, Vec<i8>) {
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

    fn qdldl(upper: &CscMatrix<f64>, perm: &[usize], signs: &[i8]) -> QDLDLFactorisation<f64> {
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(signs.to_vec());
        builder.perm(perm.to_vec());
        QDLDLFactorisation::new(upper, Some(builder.build().unwrap())).unwrap()
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
        assert!(QDLDLFactorisation::new(&one, Some(builder.build().unwrap())).is_err());
        assert_eq!(
            Ldl::ordered(&one, vec![0], &[0], f64::INFINITY).err(),
            Some(NotFactored::Failed)
        );
    }

    /// `I + Aᵀ W A` for a sparse `A` (rows of up to four entries, as a contact's) and
    /// weights `w`, dense.
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

    /// The upper triangle of a dense symmetric matrix, by columns, without its zeros.
    fn upper_of(dense: &[Vec<f64>]) -> CscMatrix<f64> {
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

    /// QDLDL's factorization of `upper` with pivots of the signs `signs`, ordered by its AMD
    /// (no ordering given).
    fn qdldl_amd(upper: &CscMatrix<f64>, signs: &[i8]) -> QDLDLFactorisation<f64> {
        let mut builder = QDLDLSettingsBuilder::default();
        builder.Dsigns(signs.to_vec());
        QDLDLFactorisation::new(upper, Some(builder.build().unwrap())).unwrap()
    }

    /// [`qdldl_amd`] of a positive definite `upper`.
    fn qdldl_positive(upper: &CscMatrix<f64>) -> QDLDLFactorisation<f64> {
        qdldl_amd(upper, &vec![1; upper.n])
    }

    /// QDLDL's own refactorization of `theirs` for every value of `values`.
    fn qdldl_refactor(theirs: &mut QDLDLFactorisation<f64>, values: &[f64]) {
        let every: Vec<usize> = (0..values.len()).collect();
        theirs.update_values(&every, values);
        theirs.refactor().unwrap();
    }

    fn normal_rows() -> impl Strategy<Value = (usize, Vec<Vec<(usize, f64)>>)> {
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
            (n, rows) in normal_rows(),
            exponents in proptest::collection::vec(-6.0f64..6.0, 30),
        ) {
            let first = upper_of(&normal(n, &rows, &vec![1.0; rows.len()]));
            let w: Vec<f64> = exponents.iter().take(rows.len()).map(|e| 10f64.powf(*e)).collect();
            let dense = normal(n, &rows, &w);
            let second = upper_of(&dense);
            prop_assert_eq!(&first.rowval, &second.rowval);

            let (mut ours, mut refactor) = Ldl::amd_refactorable(&first, &vec![1; n]).unwrap();
            // Recording what the refactorization needs changes nothing in the factor.
            let plain = Ldl::amd(&first, &vec![1; n]).unwrap();
            prop_assert_eq!(&ours.perm, &plain.perm);
            prop_assert_eq!(&ours.l.rowval, &plain.l.rowval);
            prop_assert_eq!(bits(&ours.l.nzval), bits(&plain.l.nzval));
            prop_assert_eq!(bits(&ours.d_inv), bits(&plain.d_inv));
            prop_assert!(refactor.refactor(&second.nzval, &mut ours));
            let mut theirs = qdldl_positive(&first);
            qdldl_refactor(&mut theirs, &second.nzval);
            let rhs: Vec<f64> = dense.iter().map(|r| r.iter().sum()).collect();
            let mut x = rhs.clone();
            ours.solve(&mut x);
            same_bits(ours, &mut theirs, rhs)?;
            // And the factor solves the matrix: M x = b for b = M·1.
            for v in &x {
                prop_assert!((v - 1.0).abs() <= 1e-6, "x = {v}, not 1");
            }
        }
    }

    #[test]
    fn a_vanishing_pivot_is_regularized_when_refactoring_as_qdldl_does() {
        // [[1, 1], [1, 1]]: the second pivot is 1 − 1 = 0.
        let first = upper_of(&[vec![2.0, 1.0], vec![1.0, 2.0]]);
        let (mut ldl, mut refactor) = Ldl::amd_refactorable(&first, &[1, 1]).unwrap();
        assert!(refactor.refactor(&[1.0, 1.0, 1.0], &mut ldl));
        assert_eq!(ldl.d_inv, vec![1.0, 1.0 / REGULARIZE_DELTA]);
        // QDLDL's refactor of the same values gives the same.
        let mut theirs = qdldl_positive(&first);
        qdldl_refactor(&mut theirs, &[1.0, 1.0, 1.0]);
        assert_eq!(theirs.Dinv, ldl.d_inv);
        // A pivot of exactly the threshold is kept, as QDLDL keeps it.
        assert!(refactor.refactor(&[1.0, 0.0, REGULARIZE_EPS], &mut ldl));
        qdldl_refactor(&mut theirs, &[1.0, 0.0, REGULARIZE_EPS]);
        assert_eq!(theirs.Dinv, ldl.d_inv);
        assert!(ldl.d_inv.contains(&REGULARIZE_EPS.recip()));
    }

    #[test]
    fn entries_below_the_diagonal_are_left_out_of_the_refactorization_too() {
        // [[4, 1], [1, 3]] given with both triangles: the factorization reads the upper one.
        let full = CscMatrix::new(
            2,
            2,
            vec![0, 2, 4],
            vec![0, 1, 0, 1],
            vec![4.0, 1.0, 1.0, 3.0],
        );
        let (mut ldl, mut refactor) = Ldl::amd_refactorable(&full, &[1, 1]).unwrap();
        let mut b = vec![5.0, 4.0];
        ldl.solve(&mut b);
        assert!((b[0] - 1.0).abs() < 1e-15 && (b[1] - 1.0).abs() < 1e-15);
        // New values [[2, 1], [1, 2]], the one below the diagonal a decoy.
        assert!(refactor.refactor(&[2.0, 99.0, 1.0, 2.0], &mut ldl));
        let mut b = vec![3.0, 3.0];
        ldl.solve(&mut b);
        assert!((b[0] - 1.0).abs() < 1e-15 && (b[1] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn a_refactorization_of_another_size_is_refused() {
        let first = upper_of(&[vec![2.0, 1.0], vec![1.0, 2.0]]);
        let (mut ldl, mut refactor) = Ldl::amd_refactorable(&first, &[1, 1]).unwrap();
        let before = ldl.d_inv.clone();
        // Values of another matrix, too few or too many.
        assert!(!refactor.refactor(&[1.0, 1.0], &mut ldl));
        assert!(!refactor.refactor(&[1.0, 1.0, 1.0, 1.0], &mut ldl));
        // A default refactorization fits no factor, and one of a 3 × 3 not this 2 × 2.
        assert!(!Refactor::default().refactor(&[2.0, 1.0, 2.0], &mut ldl));
        let three = upper_of(&[
            vec![2.0, 1.0, 0.0],
            vec![1.0, 2.0, 1.0],
            vec![0.0, 1.0, 2.0],
        ]);
        let (_, mut other) = Ldl::amd_refactorable(&three, &[1, 1, 1]).unwrap();
        assert!(!other.refactor(&three.nzval, &mut ldl));
        // Nor one of a diagonal 2 × 2, whose factor has no entry below its diagonal.
        let diagonal = upper_of(&[vec![2.0, 0.0], vec![0.0, 2.0]]);
        let (_, mut other) = Ldl::amd_refactorable(&diagonal, &[1, 1]).unwrap();
        assert!(!other.refactor(&[2.0, 2.0], &mut ldl));
        assert_eq!(ldl.d_inv, before);
        assert!(refactor.refactor(&first.nzval, &mut ldl));
    }

    #[test]
    fn a_pivot_that_is_not_finite_fails_the_refactorization() {
        let first = upper_of(&[vec![2.0, 1.0], vec![1.0, 2.0]]);
        let (mut ldl, mut refactor) = Ldl::amd_refactorable(&first, &[1, 1]).unwrap();
        assert!(!refactor.refactor(&[1.0, f64::INFINITY, 1.0], &mut ldl));
        assert!(!refactor.refactor(&[f64::NAN, 0.0, 1.0], &mut ldl));
        // −∞ would be a pivot of the wrong sign, which QDLDL regularizes; it fails here.
        assert!(!refactor.refactor(&[1.0, 0.0, f64::NEG_INFINITY], &mut ldl));
        // A failed row leaves the work row clean: the next refactorization is QDLDL's.
        assert!(refactor.refactor(&[4.0, 2.0, 5.0], &mut ldl));
        let mut theirs = qdldl_positive(&first);
        qdldl_refactor(&mut theirs, &[4.0, 2.0, 5.0]);
        assert_eq!(ldl.d_inv, theirs.Dinv);
        assert_eq!(ldl.l.nzval, theirs.L.nzval);
    }

    #[test]
    fn a_pivot_without_a_sign_fails_the_refactorization() {
        // Signs of 0, as in `a_zero_pivot_fails`: every pivot is zeroed, as QDLDL's is.
        let first = upper_of(&[vec![2.0, 1.0], vec![1.0, 2.0]]);
        let (mut ldl, mut refactor) = Ldl::amd_refactorable(&first, &[1, 1]).unwrap();
        ldl.signs = vec![0, 0];
        assert!(!refactor.refactor(&[2.0, 1.0, 2.0], &mut ldl));
    }
}
