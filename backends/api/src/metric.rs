//! The metric of a projection: `min ½ (x − y)ᵀ W (x − y)` with `W` symmetric positive definite,
//! and the change of variables `z = Lᵀx` (`W = LLᵀ`) that turns it into the Euclidean
//! projection the identity-metric solvers know.
//!
//! `W` is the identity (the sweeping process of the paper), a diagonal (masses), or a sparse
//! symmetric matrix (a stiffness). Its Cholesky factor is computed on the matrix's envelope
//! (the skyline: row `i` from its first non-zero column to the diagonal), where the fill of a
//! Cholesky factorization in the natural ordering stays; a banded stiffness keeps a banded
//! factor.

use crate::{Projection, ProjectionError, ProjectionProblem, RowKey, SparseRows};
use serde::{Deserialize, Serialize};

/// The matrix `W` of the cost `½ (x − y)ᵀ W (x − y)`.
///
/// ```
/// use sweeping_api::{Metric, SparseRows};
/// // Masses 1 and 4: W = diag(1, 4).
/// let masses = Metric::Diagonal(vec![1.0, 4.0]);
/// assert_eq!(masses.apply(&[1.0, 1.0]), vec![1.0, 4.0]);
/// // A spring between two unit masses: W = [[2, −1], [−1, 2]].
/// let w = SparseRows::from_rows(2, &[vec![(0, 2.0), (1, -1.0)], vec![(0, -1.0), (1, 2.0)]]);
/// assert_eq!(Metric::Symmetric(w).apply(&[1.0, 0.0]), vec![2.0, -1.0]);
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub enum Metric {
    /// `W = I`: the Euclidean projection.
    #[default]
    Identity,
    /// `W = diag(w)`, every `wⱼ > 0` (masses).
    Diagonal(Vec<f64>),
    /// A sparse symmetric positive definite `W`, both triangles stored by rows (a stiffness
    /// matrix).
    Symmetric(SparseRows),
}

impl Metric {
    /// Whether this is [`Metric::Identity`].
    pub fn is_identity(&self) -> bool {
        matches!(self, Metric::Identity)
    }

    /// `W v`.
    ///
    /// # Panics
    /// When `v` does not have the metric's dimension.
    pub fn apply(&self, v: &[f64]) -> Vec<f64> {
        match self {
            Metric::Identity => v.to_vec(),
            Metric::Diagonal(w) => {
                assert_eq!(w.len(), v.len(), "metric and vector dimensions");
                w.iter().zip(v).map(|(wi, vi)| wi * vi).collect()
            }
            Metric::Symmetric(w) => {
                let mut out = vec![0.0; v.len()];
                w.mul_vec(v, &mut out);
                out
            }
        }
    }

    /// `W`'s upper triangle for `n` unknowns, compressed by columns with sorted row indices
    /// and repeats summed, as `(col_ptr, row_idx, values)`: the form in which Clarabel and
    /// OSQP take the quadratic cost `P`.
    ///
    /// ```
    /// use sweeping_api::{Metric, SparseRows};
    /// let w = SparseRows::from_rows(2, &[vec![(1, -1.0), (0, 2.0)], vec![(0, -1.0), (1, 2.0)]]);
    /// let (ptr, idx, val) = Metric::Symmetric(w).upper_triangle_csc(2);
    /// assert_eq!((ptr, idx, val), (vec![0, 1, 3], vec![0, 0, 1], vec![2.0, -1.0, 2.0]));
    /// assert_eq!(Metric::Identity.upper_triangle_csc(2).2, vec![1.0, 1.0]);
    /// ```
    pub fn upper_triangle_csc(&self, n: usize) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        match self {
            Metric::Identity => ((0..=n).collect(), (0..n).collect(), vec![1.0; n]),
            Metric::Diagonal(w) => ((0..=n).collect(), (0..n).collect(), w.clone()),
            Metric::Symmetric(w) => {
                // Column j of the upper triangle is row j's part left of the diagonal (W is
                // symmetric).
                let mut col_ptr = vec![0];
                let (mut row_idx, mut values) = (Vec::new(), Vec::new());
                for j in 0..n {
                    let mut entries: Vec<(usize, f64)> =
                        w.row(j).filter(|&(i, _)| i <= j).collect();
                    entries.sort_by_key(|&(i, _)| i);
                    let start = row_idx.len();
                    for (i, v) in entries {
                        if row_idx.len() > start && row_idx.last() == Some(&i) {
                            if let Some(last) = values.last_mut() {
                                *last += v;
                            }
                        } else {
                            row_idx.push(i);
                            values.push(v);
                        }
                    }
                    col_ptr.push(row_idx.len());
                }
                (col_ptr, row_idx, values)
            }
        }
    }

    /// Checks that the metric fits a problem of dimension `n` and is symmetric positive
    /// definite, and returns its Cholesky factor (`None` for the identity).
    ///
    /// # Errors
    /// [`ProjectionError::InvalidInput`] naming the entry or the pivot at fault.
    pub(crate) fn validate(&self, n: usize) -> Result<Option<Factor>, ProjectionError> {
        let invalid = |reason: String| ProjectionError::InvalidInput {
            reason: format!("metric W: {reason}"),
        };
        match self {
            Metric::Identity => Ok(None),
            Metric::Diagonal(w) => {
                if w.len() != n {
                    return Err(invalid(format!(
                        "{} diagonal entries for {n} unknowns",
                        w.len()
                    )));
                }
                if let Some(j) = w.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
                    return Err(invalid(format!(
                        "W[{j}, {j}] = {} is not a positive finite number: W must be positive \
                         definite",
                        w[j]
                    )));
                }
                Ok(Some(Factor::diagonal(w)))
            }
            Metric::Symmetric(w) => {
                if w.n_rows() != n || w.n_cols() != n {
                    return Err(invalid(format!(
                        "{}×{} for {n} unknowns",
                        w.n_rows(),
                        w.n_cols()
                    )));
                }
                Factor::skyline(w).map(Some).map_err(invalid)
            }
        }
    }
}

/// The Cholesky factor `L` of `W = LLᵀ`, lower triangular, stored by rows on its envelope.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Factor {
    /// Row `i` holds `L[i, first[i]..=i]`.
    first: Vec<usize>,
    /// Where row `i` starts in `values`.
    start: Vec<usize>,
    values: Vec<f64>,
}

/// Tolerance of the symmetry check, relative to the largest `|Wᵢⱼ|`: entries assembled in two
/// orders may differ in their last bits.
const SYMMETRY: f64 = 1e-12;

/// A pivot below this fraction of its diagonal entry means `W` is not (numerically) positive
/// definite: its factor would amplify rounding by more than the inverse square root of it.
const PIVOT: f64 = 1e-14;

impl Factor {
    fn diagonal(w: &[f64]) -> Self {
        Self {
            first: (0..w.len()).collect(),
            start: (0..=w.len()).collect(),
            values: w.iter().map(|v| v.sqrt()).collect(),
        }
    }

    fn dim(&self) -> usize {
        self.first.len()
    }

    fn row(&self, i: usize) -> &[f64] {
        &self.values[self.start[i]..self.start[i + 1]]
    }

    /// `L[i, j]` for `first[i] ≤ j ≤ i`.
    fn at(&self, i: usize, j: usize) -> f64 {
        self.values[self.start[i] + j - self.first[i]]
    }

    /// The factor of a sparse symmetric `w`, after checking it is finite and symmetric.
    fn skyline(w: &SparseRows) -> Result<Self, String> {
        let n = w.n_rows();
        let mut lower: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n];
        let mut upper: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n];
        let mut largest: f64 = 0.0;
        for i in 0..n {
            for (j, v) in w.row(i) {
                if !v.is_finite() {
                    return Err(format!("W[{i}, {j}] = {v} is not finite"));
                }
                largest = largest.max(v.abs());
                // Entry (i, j) above the diagonal is kept by its lower-triangle position (j, i).
                let (map, r, c) = if j <= i {
                    (&mut lower, i, j)
                } else {
                    (&mut upper, j, i)
                };
                *map[r].entry(c).or_insert(0.0) += v;
            }
        }
        for i in 0..n {
            let pairs: std::collections::BTreeSet<usize> =
                lower[i].keys().chain(upper[i].keys()).copied().collect();
            for j in pairs.into_iter().filter(|&j| j < i) {
                let (l, u) = (
                    lower[i].get(&j).copied().unwrap_or(0.0),
                    upper[i].get(&j).copied().unwrap_or(0.0),
                );
                if (l - u).abs() > SYMMETRY * largest {
                    return Err(format!(
                        "W[{i}, {j}] = {l} but W[{j}, {i}] = {u}: W must be symmetric"
                    ));
                }
            }
        }
        let first: Vec<usize> = (0..n)
            .map(|i| {
                lower[i]
                    .iter()
                    .chain(upper[i].iter())
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(j, _)| *j)
                    .min()
                    .unwrap_or(i)
                    .min(i)
            })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        for i in 0..n {
            start.push(start[i] + i - first[i] + 1);
        }
        let mut factor = Self {
            first,
            start,
            values: vec![0.0; 0],
        };
        factor.values = vec![0.0; factor.start[n]];
        for i in 0..n {
            let wij = |j: usize| {
                let (l, u) = (
                    lower[i].get(&j).copied().unwrap_or(0.0),
                    upper[i].get(&j).copied().unwrap_or(0.0),
                );
                if j == i {
                    l
                } else {
                    0.5 * (l + u)
                }
            };
            let fi = factor.first[i];
            for j in fi..=i {
                let from = fi.max(factor.first[j]);
                let dot: f64 = (from..j).map(|k| factor.at(i, k) * factor.at(j, k)).sum();
                let slot = factor.start[i] + j - fi;
                if j < i {
                    factor.values[slot] = (wij(j) - dot) / factor.at(j, j);
                } else {
                    let pivot = wij(i) - dot;
                    let positive = pivot.is_finite() && pivot > PIVOT * wij(i).abs();
                    if !positive {
                        return Err(format!(
                            "not positive definite (the Cholesky pivot of row {i} is {pivot:.3e})"
                        ));
                    }
                    factor.values[slot] = pivot.sqrt();
                }
            }
        }
        Ok(factor)
    }

    /// `Lᵀ x`.
    pub(crate) fn mul_lt(&self, x: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.dim()];
        for (i, &xi) in x.iter().enumerate() {
            for (k, l) in self.row(i).iter().enumerate() {
                out[self.first[i] + k] += l * xi;
            }
        }
        out
    }

    /// Solves `L v = r` in place, from the first non-zero of `r` on (`from`).
    pub(crate) fn solve_l(&self, v: &mut [f64], from: usize) {
        for i in from..self.dim() {
            let fi = self.first[i].max(from);
            let row = self.row(i);
            let off = self.first[i];
            let dot: f64 = (fi..i).map(|k| row[k - off] * v[k]).sum();
            v[i] = (v[i] - dot) / row[i - off];
        }
    }

    /// Solves `Lᵀ v = r` in place.
    pub(crate) fn solve_lt(&self, v: &mut [f64]) {
        for i in (0..self.dim()).rev() {
            let row = self.row(i);
            let off = self.first[i];
            v[i] /= row[i - off];
            let vi = v[i];
            for k in off..i {
                v[k] -= row[k - off] * vi;
            }
        }
    }
}

/// The projection in the metric `W` said as a Euclidean one, by the change of variables
/// `z = Lᵀx` (`W = LLᵀ`): `½(x − y)ᵀW(x − y) = ½‖z − Lᵀy‖²` and `Ax ≥ b` reads
/// `(A L⁻ᵀ) z ≥ b`, with the same multipliers (`W(x − y) = Aᵀλ` is `z − Lᵀy = (AL⁻ᵀ)ᵀλ`). A
/// diagonal `W` scales each column (`zⱼ = √wⱼ xⱼ`), so the rows keep their sparsity; a general
/// `W` couples the unknowns its envelope couples. Equality rows and row keys are kept.
///
/// ```
/// use sweeping_api::{conformance::ReferenceProjector, Metric, MetricChange, ProjectionProblem,
///                    Projector, SparseRows};
/// // Masses 1 and 3 kept 1 apart on a line: x₁ − x₀ ≥ 1 from y = (0, 0). The lighter one
/// // moves three times as far: x = (−3/4, 1/4).
/// let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
/// let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0]).unwrap()
///     .with_metric(Metric::Diagonal(vec![1.0, 3.0])).unwrap();
/// let change = MetricChange::new(&p).unwrap().expect("not the identity");
/// assert!(change.problem().metric().is_identity());
/// let z = ReferenceProjector::default().project(change.problem()).unwrap();
/// let x = change.answer(z);
/// assert!((x.x[0] + 0.75).abs() < 1e-9 && (x.x[1] - 0.25).abs() < 1e-9);
/// assert!(p.kkt_residuals(&x.x, &x.multipliers).max() < 1e-9);
/// ```
#[derive(Debug, Clone)]
pub struct MetricChange {
    problem: ProjectionProblem,
    factor: Factor,
}

impl MetricChange {
    /// The Euclidean problem in `z`, or `None` when `problem`'s metric is the identity already.
    ///
    /// # Errors
    /// [`ProjectionError::InvalidInput`] when the metric is not symmetric positive definite
    /// (possible only for a problem deserialized without checks).
    pub fn new(problem: &ProjectionProblem) -> Result<Option<Self>, ProjectionError> {
        let Some(factor) = problem.metric().validate(problem.dim())? else {
            return Ok(None);
        };
        let a = problem.a();
        let n = problem.dim();
        let mut rows = SparseRows::with_capacity(n, a.n_rows(), a.nnz());
        if let Metric::Diagonal(_) = problem.metric() {
            // L = diag(√w): each column scaled, the rows' sparsity kept.
            for r in 0..a.n_rows() {
                rows.push_row(a.row(r).map(|(c, x)| (c, x / factor.at(c, c))));
            }
        } else {
            let mut v = vec![0.0; n];
            for r in 0..a.n_rows() {
                // Row r of A L⁻ᵀ is (L⁻¹ aᵣ)ᵀ; zero up to the row's first column.
                let Some(from) = a.row(r).filter(|(_, x)| *x != 0.0).map(|(c, _)| c).min() else {
                    rows.push_row(std::iter::empty());
                    continue;
                };
                v[from..].iter_mut().for_each(|x| *x = 0.0);
                a.row(r).for_each(|(c, x)| v[c] += x);
                factor.solve_l(&mut v, from);
                rows.push_row((from..n).filter(|&c| v[c] != 0.0).map(|c| (c, v[c])));
            }
        }
        let y = factor.mul_lt(problem.y());
        let mut changed = ProjectionProblem::new(y, rows, problem.b().to_vec())?
            .with_leading_equalities(problem.equalities())?;
        if let Some(keys) = problem.row_keys() {
            changed = changed.with_row_keys(keys.to_vec())?;
        }
        Ok(Some(Self {
            problem: changed,
            factor,
        }))
    }

    /// The Euclidean problem in `z = Lᵀx`.
    pub fn problem(&self) -> &ProjectionProblem {
        &self.problem
    }

    /// A point in the new variables, `z = Lᵀx` (to start a solver of [`Self::problem`] from
    /// a known `x`).
    pub fn point(&self, x: &[f64]) -> Vec<f64> {
        self.factor.mul_lt(x)
    }

    /// The answer in `x = L⁻ᵀz` from an answer of [`Self::problem`]; the multipliers and the
    /// statistics are kept.
    pub fn answer(&self, mut z: Projection) -> Projection {
        self.factor.solve_lt(&mut z.x);
        z
    }
}

/// A problem with equality rows said with inequalities only: each equality `aᵢ·x = bᵢ` as
/// `aᵢ·x ≥ bᵢ` (its own row) and `−aᵢ·x ≥ −bᵢ` (appended after the last row). The projection
/// is the same (so is the set); the equality's free-sign multiplier is the difference of the
/// pair's. For a solver that handles only `Ax ≥ b`: its active set holds one row of a pair
/// at a time, the one the multiplier's sign calls for.
///
/// ```
/// use sweeping_api::{conformance::ReferenceProjector, EqualityPairs, ProjectionProblem,
///                    Projector, SparseRows};
/// // x₀ + x₁ = 1 from y = (2, 2): x = (½, ½), λ = −3/2 (the row pulls back).
/// let a = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 1.0)]]);
/// let p = ProjectionProblem::new(vec![2.0, 2.0], a, vec![1.0]).unwrap()
///     .with_leading_equalities(1).unwrap();
/// let pairs = EqualityPairs::new(&p).unwrap().expect("one equality");
/// assert_eq!(pairs.problem().n_rows(), 2);
/// let sol = pairs.answer(ReferenceProjector::default().project(pairs.problem()).unwrap());
/// assert!((sol.x[0] - 0.5).abs() < 1e-9 && (sol.multipliers[0] + 1.5).abs() < 1e-9);
/// ```
#[derive(Debug, Clone)]
pub struct EqualityPairs {
    problem: ProjectionProblem,
    /// For each row of [`Self::problem`], the row of the original problem it comes from.
    origin: Vec<usize>,
    rows: usize,
}

impl EqualityPairs {
    /// The problem in inequalities, or `None` when `problem` has no equality row.
    ///
    /// # Errors
    /// Only those of [`ProjectionProblem::new`] on the mirrored rows (none for a valid problem).
    pub fn new(problem: &ProjectionProblem) -> Result<Option<Self>, ProjectionError> {
        let k = problem.equalities();
        if k == 0 {
            return Ok(None);
        }
        let a = problem.a();
        let m = problem.n_rows();
        let mut rows = a.clone();
        let mut b = problem.b().to_vec();
        for r in 0..k {
            rows.push_row(a.row(r).map(|(c, v)| (c, -v)));
            b.push(-problem.b()[r]);
        }
        let mut paired = ProjectionProblem::new(problem.y().to_vec(), rows, b)?
            .with_metric(problem.metric().clone())?;
        if let Some(keys) = problem.row_keys() {
            // The mirror of a row keeps its member under the complement of its family; when
            // that collides with a key in use, the rows go without keys (a cold start).
            let mirrored = keys
                .iter()
                .copied()
                .chain(keys[..k].iter().map(|key| RowKey {
                    family: !key.family,
                    member: key.member,
                }))
                .collect();
            if let Ok(keyed) = paired.clone().with_row_keys(mirrored) {
                paired = keyed;
            }
        }
        Ok(Some(Self {
            problem: paired,
            origin: (0..m).chain(0..k).collect(),
            rows: m,
        }))
    }

    /// The problem in inequalities.
    pub fn problem(&self) -> &ProjectionProblem {
        &self.problem
    }

    /// One value per row of [`Self::problem`] from one per row of the original problem:
    /// `positive` of it on the original rows, `mirror` of the equality's value on the
    /// appended ones. Multipliers split as `(λ⁺, λ⁻)` with `positive = max(·, 0)` and
    /// `mirror = max(−·, 0)`; slacks are copied (`|x| → x`).
    ///
    /// ```
    /// use sweeping_api::{EqualityPairs, ProjectionProblem, SparseRows};
    /// let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
    /// let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, 0.0]).unwrap()
    ///     .with_leading_equalities(1).unwrap();
    /// let pairs = EqualityPairs::new(&p).unwrap().unwrap();
    /// let split = pairs.per_row(&[-2.0, 3.0], |l| l.max(0.0), |l| (-l).max(0.0));
    /// assert_eq!(split, vec![0.0, 3.0, 2.0]);
    /// ```
    pub fn per_row(
        &self,
        values: &[f64],
        positive: impl Fn(f64) -> f64,
        mirror: impl Fn(f64) -> f64,
    ) -> Vec<f64> {
        self.origin
            .iter()
            .enumerate()
            .map(|(t, &r)| {
                if t < self.rows {
                    positive(values[r])
                } else {
                    mirror(values[r])
                }
            })
            .collect()
    }

    /// The answer of the original problem: the point, and each equality's multiplier as the
    /// difference of its pair's.
    pub fn answer(&self, mut paired: Projection) -> Projection {
        for t in self.rows..paired.multipliers.len() {
            let r = self.origin[t];
            paired.multipliers[r] -= paired.multipliers[t];
        }
        paired.multipliers.truncate(self.rows);
        paired
    }

    /// An error of the paired problem said in the original's rows.
    #[must_use]
    pub fn error(&self, error: ProjectionError) -> ProjectionError {
        let mapped = error.in_rows_of(&self.origin);
        match mapped {
            ProjectionError::Infeasible {
                backend,
                detail,
                mut rows,
            } => {
                rows.sort_unstable();
                rows.dedup();
                ProjectionError::Infeasible {
                    backend,
                    detail,
                    rows,
                }
            }
            other => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense(w: &SparseRows) -> Vec<Vec<f64>> {
        let n = w.n_cols();
        let mut d = vec![vec![0.0; n]; n];
        for (i, row) in d.iter_mut().enumerate() {
            for (j, v) in w.row(i) {
                row[j] += v;
            }
        }
        d
    }

    /// A stiffness-like banded SPD matrix with a gap in its envelope.
    fn banded(n: usize) -> SparseRows {
        let rows: Vec<Vec<(usize, f64)>> = (0..n)
            .map(|i| {
                let mut r = vec![(i, 4.0 + i as f64 * 0.1)];
                if i >= 1 {
                    r.push((i - 1, -1.0));
                }
                if i + 1 < n {
                    r.push((i + 1, -1.0));
                }
                if i >= 3 {
                    r.push((i - 3, 0.5));
                }
                if i + 3 < n {
                    r.push((i + 3, 0.5));
                }
                r
            })
            .collect();
        SparseRows::from_rows(n, &rows)
    }

    #[test]
    fn the_factor_reproduces_w_and_its_solves_invert_it() {
        let w = banded(9);
        let f = Metric::Symmetric(w.clone()).validate(9).unwrap().unwrap();
        let d = dense(&w);
        for (i, row) in d.iter().enumerate() {
            for (j, &dij) in row.iter().enumerate().take(i + 1) {
                let llt: f64 = (0..=j)
                    .filter(|&k| k >= f.first[i] && k >= f.first[j])
                    .map(|k| f.at(i, k) * f.at(j, k))
                    .sum();
                assert!((llt - dij).abs() < 1e-13, "({i}, {j}): {llt} vs {dij}");
            }
        }
        let x: Vec<f64> = (0..9).map(|i| (i as f64 * 0.7).sin()).collect();
        // L (Lᵀ x) = W x, so solving L then Lᵀ on W x gives x back.
        let mut v = Metric::Symmetric(w).apply(&x);
        f.solve_l(&mut v, 0);
        let lt = f.mul_lt(&x);
        assert!(v.iter().zip(&lt).all(|(a, b)| (a - b).abs() < 1e-12));
        f.solve_lt(&mut v);
        assert!(v.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-12));
    }

    #[test]
    fn bad_metrics_are_named() {
        let err = |m: Metric, n| match m.validate(n) {
            Err(ProjectionError::InvalidInput { reason }) => reason,
            other => panic!("expected InvalidInput, got {other:?}"),
        };
        assert!(err(Metric::Diagonal(vec![1.0]), 2).contains("1 diagonal entries for 2"));
        assert!(err(Metric::Diagonal(vec![1.0, 0.0]), 2).contains("W[1, 1] = 0"));
        assert!(err(Metric::Diagonal(vec![1.0, f64::NAN]), 2).contains("W[1, 1] = NaN"));
        let asym = SparseRows::from_rows(2, &[vec![(0, 2.0), (1, 1.0)], vec![(1, 2.0)]]);
        assert!(err(Metric::Symmetric(asym), 2).contains("must be symmetric"));
        let indefinite =
            SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 2.0)], vec![(0, 2.0), (1, 1.0)]]);
        assert!(err(Metric::Symmetric(indefinite), 2).contains("pivot of row 1"));
        let semi = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 1.0)], vec![(0, 1.0), (1, 1.0)]]);
        assert!(err(Metric::Symmetric(semi), 2).contains("not positive definite"));
        assert!(err(Metric::Symmetric(banded(3)), 4).contains("3×3 for 4"));
        let inf = SparseRows::from_rows(1, &[vec![(0, f64::INFINITY)]]);
        assert!(err(Metric::Symmetric(inf), 1).contains("not finite"));
    }

    #[test]
    fn both_changes_give_the_weighted_projection_on_random_instances() {
        use crate::conformance::{max_gap, random_weighted_instance, ReferenceProjector};
        use crate::Projector;
        let mut kinds = [0usize; 2];
        for seed in 0..24u64 {
            let p =
                random_weighted_instance(seed, 3 + (seed as usize % 9), 2 + (seed as usize % 11));
            assert!(
                !p.metric().is_identity() && p.equalities() >= 1,
                "seed {seed}"
            );
            kinds[usize::from(matches!(p.metric(), Metric::Symmetric(_)))] += 1;
            let direct = ReferenceProjector::default().project(&p).unwrap();
            assert!(
                p.kkt_residuals(&direct.x, &direct.multipliers).max() < 1e-9,
                "seed {seed}"
            );
            // In z = Lᵀx, then back; then the equalities as pairs of inequalities.
            let change = MetricChange::new(&p).unwrap().unwrap();
            assert!(change.problem().metric().is_identity());
            assert_eq!(change.problem().equalities(), p.equalities());
            let z = ReferenceProjector::default()
                .project(change.problem())
                .unwrap();
            let x = change.answer(z);
            let kkt = p.kkt_residuals(&x.x, &x.multipliers).max();
            assert!(
                kkt < 1e-8,
                "seed {seed}: change of variables, KKT {kkt:.3e}"
            );
            assert!(max_gap(&x.x, &direct.x) < 1e-8, "seed {seed}");
            let pairs = EqualityPairs::new(&p).unwrap().unwrap();
            assert_eq!(pairs.problem().equalities(), 0);
            assert_eq!(pairs.problem().n_rows(), p.n_rows() + p.equalities());
            let paired = pairs.answer(
                ReferenceProjector::default()
                    .project(pairs.problem())
                    .unwrap(),
            );
            let kkt = p.kkt_residuals(&paired.x, &paired.multipliers).max();
            assert!(kkt < 1e-8, "seed {seed}: pairs, KKT {kkt:.3e}");
        }
        assert!(
            kinds[0] > 0 && kinds[1] > 0,
            "both kinds of metric drawn: {kinds:?}"
        );
    }

    #[test]
    fn pairs_keep_keys_and_say_errors_in_the_original_rows() {
        use crate::RowKey;
        let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
        let key = |family, member| RowKey { family, member };
        let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, 2.0])
            .unwrap()
            .with_leading_equalities(1)
            .unwrap()
            .with_row_keys(vec![key(3, 7), key(4, 8)])
            .unwrap();
        let pairs = EqualityPairs::new(&p).unwrap().unwrap();
        assert_eq!(
            pairs.problem().row_keys().unwrap(),
            &[key(3, 7), key(4, 8), key(!3, 7)]
        );
        let error = ProjectionError::Infeasible {
            backend: "b".into(),
            detail: "d".into(),
            rows: vec![1, 2],
        };
        match pairs.error(error) {
            ProjectionError::Infeasible { rows, .. } => assert_eq!(rows, vec![0, 1]),
            other => panic!("{other:?}"),
        }
        let no_eq = ProjectionProblem::new(vec![0.0], SparseRows::new(1), vec![]).unwrap();
        assert!(EqualityPairs::new(&no_eq).unwrap().is_none());
        assert!(MetricChange::new(&no_eq).unwrap().is_none());
    }
}
