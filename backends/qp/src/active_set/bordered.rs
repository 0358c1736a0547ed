//! Bordering: the system of a support a few rows away from the factored one, solved through
//! the old factor and a small dense Schur complement instead of a new factorization.

use super::system::{ActiveSystem, Factor, Unknowns, DELTA};
use crate::ldl::Ldl;
use sweeping_api::ProjectionProblem;

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
pub(super) struct Bordered {
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

impl ActiveSystem {
    /// The system for the support `next`, made from this one without a factorization when
    /// the factor is sparse, `next` is this support with rows removed and rows appended (the
    /// order the method keeps), and at most [`BORDER_MAX`] changes separate it from the
    /// factored support; `None` otherwise.
    pub(super) fn bordered_to(
        mut self,
        problem: &ProjectionProblem,
        next: &[usize],
    ) -> Option<Self> {
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
    pub(super) fn solve(
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

#[cfg(test)]
mod tests;
