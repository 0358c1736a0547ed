//! The projection contract of `sweeping`.
//!
//! Every step of the Bernicot–Venel scheme is one Euclidean projection onto a convex polyhedron:
//!
//! ```text
//!     x* = argmin ½‖x − y‖²   subject to   A x ≥ b,
//! ```
//!
//! with a sparse `A` (one row per linearized constraint, a handful of non-zeros per row).
//! Two generalizations ride on the same problem: a **metric** `W` (symmetric positive
//! definite; masses or a stiffness), for `min ½ (x − y)ᵀ W (x − y)`, and **equality rows**
//! (the first `k` rows read `aᵢ·x = bᵢ`). Both default to the plain case, which costs nothing
//! extra: see [`ProjectionProblem::with_metric`] and
//! [`ProjectionProblem::with_leading_equalities`].
//! This crate holds that problem ([`ProjectionProblem`]), its answer ([`Projection`], with the
//! multipliers λ ≥ 0 of the rows), the statistics of a solve ([`SolveStats`]), the typed error
//! ([`ProjectionError`]) and the object-safe [`Projector`] trait that every backend implements.
//! A backend sees only this assembled QP: never scenes, constraints or time.
//!
//! The optimality (KKT) conditions of the projection are
//!
//! ```text
//!     A x ≥ b,   x − y = Aᵀλ,   λ ≥ 0,   λᵢ (A x − b)ᵢ = 0,
//! ```
//!
//! (in a metric `W`: `W(x − y) = Aᵀλ`; on an equality row `(Ax − b)ᵢ = 0` and `λᵢ` of either
//! sign)
//!
//! and [`ProjectionProblem::kkt_residuals`] measures how far an answer is from them. The
//! [`conformance`] module runs the checks every backend must pass (closed forms, degenerate and
//! infeasible sets, KKT on random instances, idempotence), and [`CrossCheck`] runs two backends
//! on the same problem and fails loudly when they disagree.
//!
//! From a crate that depends on `sweeping` (and not on this crate directly), these names are
//! `sweeping::api::…`, and the ones a backend needs are in `sweeping::prelude`: the examples
//! below write `sweeping_api::…` because they are compiled as this crate's own tests.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod blocks;
pub mod conformance;
mod cross;
mod matrix;
mod metric;

pub use blocks::{Block, Blocked, Blocks};
pub use cross::{CrossCheck, CrossCheckDisagreement, CrossCheckStats};
pub use matrix::SparseRows;
pub use metric::{EqualityPairs, Metric, MetricChange};

/// A hash map for what backends look up on every solve (multipliers by [`RowKey`], working
/// sets, orderings by node): std's map with foldhash's fixed-seed hasher, much cheaper than
/// SipHash on such small keys and the same from run to run. It does not resist hash
/// flooding, which keys the program makes itself do not call for.
pub type FastMap<K, V> = std::collections::HashMap<K, V, foldhash::fast::FixedState>;

use serde::{Deserialize, Serialize};
use std::fmt;

/// The QP `min ½‖x − y‖² s.t. A x ≥ b`, validated on construction; in general
/// `min ½ (x − y)ᵀ W (x − y)` ([`Self::with_metric`]) with the first `k` rows equalities
/// ([`Self::with_leading_equalities`]).
///
/// `A` is stored by rows ([`SparseRows`]) because that is how the constraints are assembled:
/// one linearized constraint `gᵢ + ⟨∇gᵢ, x − q⟩ ≥ 0` becomes the row `∇gᵢ` with
/// `bᵢ = ⟨∇gᵢ, q⟩ − gᵢ`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProjectionProblem {
    y: Vec<f64>,
    a: SparseRows,
    b: Vec<f64>,
    /// One stable identity per row, when the caller attached them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    keys: Option<Vec<RowKey>>,
    /// The metric `W` of the cost.
    #[serde(default, skip_serializing_if = "Metric::is_identity")]
    metric: Metric,
    /// How many leading rows are equalities.
    #[serde(default, skip_serializing_if = "is_zero")]
    equalities: usize,
}

fn is_zero(k: &usize) -> bool {
    *k == 0
}

/// Stable identity of a row across steps: which constraint (`family`, `member`) it linearizes.
///
/// Rows appear, vanish and are reordered from one step to the next (contacts form and break);
/// a key lets a backend find the row that linearizes the same constraint in the previous
/// step's problem, and start from its multiplier (warm start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct RowKey {
    /// The constraint family (e.g. disk–disk contacts, disk–wall contacts).
    pub family: u32,
    /// The member of the family (e.g. an encoded pair of agents).
    pub member: u64,
}

impl ProjectionProblem {
    /// Builds a problem, checking dimensions and finiteness.
    ///
    /// # Errors
    /// [`ProjectionError::InvalidInput`] when `a` has a number of columns other than `y.len()`,
    /// a number of rows other than `b.len()`, or when `y`, `a` or `b` hold a non-finite value.
    pub fn new(y: Vec<f64>, a: SparseRows, b: Vec<f64>) -> Result<Self, ProjectionError> {
        if a.n_cols() != y.len() {
            return Err(ProjectionError::InvalidInput {
                reason: format!("A has {} columns but y has {} entries", a.n_cols(), y.len()),
            });
        }
        if a.n_rows() != b.len() {
            return Err(ProjectionError::InvalidInput {
                reason: format!("A has {} rows but b has {} entries", a.n_rows(), b.len()),
            });
        }
        if let Some(i) = y.iter().position(|v| !v.is_finite()) {
            return Err(ProjectionError::InvalidInput {
                reason: format!("y[{i}] = {} is not finite", y[i]),
            });
        }
        if let Some(i) = b.iter().position(|v| !v.is_finite()) {
            return Err(ProjectionError::InvalidInput {
                reason: format!("b[{i}] = {} is not finite", b[i]),
            });
        }
        for r in 0..a.n_rows() {
            if let Some((c, v)) = a.row(r).find(|(_, v)| !v.is_finite()) {
                return Err(ProjectionError::InvalidInput {
                    reason: format!("A[{r}, {c}] = {v} is not finite"),
                });
            }
        }
        Ok(Self {
            y,
            a,
            b,
            keys: None,
            metric: Metric::Identity,
            equalities: 0,
        })
    }

    /// Sets the metric `W` of the cost `½ (x − y)ᵀ W (x − y)` (default
    /// [`Metric::Identity`]).
    ///
    /// # Errors
    /// [`ProjectionError::InvalidInput`] when `W` does not have the problem's dimension, holds
    /// a non-finite entry, is not symmetric, or is not positive definite (its Cholesky
    /// factorization meets a pivot `≤ 1e-14` times its diagonal entry).
    ///
    /// ```
    /// use sweeping_api::{Metric, ProjectionProblem, SparseRows};
    /// let p = ProjectionProblem::new(vec![0.0, 0.0], SparseRows::new(2), vec![]).unwrap();
    /// assert!(p.clone().with_metric(Metric::Diagonal(vec![1.0, -2.0])).is_err());
    /// let p = p.with_metric(Metric::Diagonal(vec![1.0, 2.0])).unwrap();
    /// assert_eq!(p.metric(), &Metric::Diagonal(vec![1.0, 2.0]));
    /// ```
    pub fn with_metric(mut self, metric: Metric) -> Result<Self, ProjectionError> {
        metric.validate(self.dim())?;
        self.metric = metric;
        Ok(self)
    }

    /// Declares the first `k` rows equalities: `aᵢ·x = bᵢ`, with a multiplier of either sign.
    ///
    /// # Errors
    /// [`ProjectionError::InvalidInput`] when `k` exceeds the number of rows.
    pub fn with_leading_equalities(mut self, k: usize) -> Result<Self, ProjectionError> {
        if k > self.n_rows() {
            return Err(ProjectionError::InvalidInput {
                reason: format!(
                    "{k} equality rows but the problem has {} rows",
                    self.n_rows()
                ),
            });
        }
        self.equalities = k;
        Ok(self)
    }

    /// The metric `W` of the cost.
    pub fn metric(&self) -> &Metric {
        &self.metric
    }

    /// How many leading rows are equalities (`0` by default).
    pub fn equalities(&self) -> usize {
        self.equalities
    }

    /// A problem whose parts are already known to be consistent (sub-problems cut out of a
    /// validated problem).
    pub(crate) fn from_parts_unchecked(
        y: Vec<f64>,
        a: SparseRows,
        b: Vec<f64>,
        keys: Option<Vec<RowKey>>,
    ) -> Self {
        debug_assert_eq!(a.n_cols(), y.len());
        debug_assert_eq!(a.n_rows(), b.len());
        Self {
            y,
            a,
            b,
            keys,
            metric: Metric::Identity,
            equalities: 0,
        }
    }

    /// The same problem with `metric` and `equalities` set without checks (sub-problems of a
    /// validated problem).
    pub(crate) fn with_parts_unchecked(mut self, metric: Metric, equalities: usize) -> Self {
        debug_assert!(equalities <= self.n_rows());
        self.metric = metric;
        self.equalities = equalities;
        self
    }

    /// Attaches one key per row. Without keys, backends cold-start.
    ///
    /// # Errors
    /// [`ProjectionError::InvalidInput`] when there are not exactly [`Self::n_rows`] keys, or
    /// when two rows share a key (the first repeated key and both rows are named).
    ///
    /// ```
    /// use sweeping_api::{ProjectionProblem, RowKey, SparseRows};
    /// let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
    /// let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 1.0]).unwrap();
    /// let k = |m| RowKey { family: 0, member: m };
    /// assert!(p.clone().with_row_keys(vec![k(1), k(1)]).is_err());
    /// let p = p.with_row_keys(vec![k(7), k(3)]).unwrap();
    /// assert_eq!(p.row_keys().unwrap()[1], k(3));
    /// ```
    pub fn with_row_keys(mut self, keys: Vec<RowKey>) -> Result<Self, ProjectionError> {
        if keys.len() != self.n_rows() {
            return Err(ProjectionError::InvalidInput {
                reason: format!(
                    "{} row keys for {} rows: one key per row is required",
                    keys.len(),
                    self.n_rows()
                ),
            });
        }
        let mut seen = FastMap::with_capacity_and_hasher(keys.len(), Default::default());
        for (i, k) in keys.iter().enumerate() {
            if let Some(first) = seen.insert(*k, i) {
                return Err(ProjectionError::InvalidInput {
                    reason: format!(
                        "rows {first} and {i} share the key (family {}, member {})",
                        k.family, k.member
                    ),
                });
            }
        }
        self.keys = Some(keys);
        Ok(self)
    }

    /// The key of each row, when attached by [`Self::with_row_keys`].
    pub fn row_keys(&self) -> Option<&[RowKey]> {
        self.keys.as_deref()
    }

    /// The point to project.
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// The constraint matrix `A`, by rows.
    pub fn a(&self) -> &SparseRows {
        &self.a
    }

    /// The right-hand side `b`.
    pub fn b(&self) -> &[f64] {
        &self.b
    }

    /// Dimension of the space (length of `y`).
    pub fn dim(&self) -> usize {
        self.y.len()
    }

    /// Number of constraint rows.
    pub fn n_rows(&self) -> usize {
        self.b.len()
    }

    /// `b − A x`, row by row: by how much `x` falls short of each row (positive where it
    /// violates it).
    ///
    /// ```
    /// use sweeping_api::{ProjectionProblem, SparseRows};
    /// // x₀ ≥ 1 and x₀ + x₁ ≥ 0 at y = (0.25, 0.5).
    /// let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, 1.0)]]);
    /// let p = ProjectionProblem::new(vec![0.25, 0.5], a, vec![1.0, 0.0]).unwrap();
    /// assert_eq!(p.shortfall(p.y()), vec![0.75, -0.75]);
    /// ```
    pub fn shortfall(&self, x: &[f64]) -> Vec<f64> {
        let mut r = vec![0.0; self.n_rows()];
        self.a.mul_vec(x, &mut r);
        r.iter_mut()
            .zip(&self.b)
            .for_each(|(ri, bi)| *ri = bi - *ri);
        r
    }

    /// The largest violation of the rows at `x`: `max(0, maxᵢ (b − A x)ᵢ)` over the
    /// inequality rows and `|b − A x|ᵢ` over the equality rows.
    pub fn max_violation(&self, x: &[f64]) -> f64 {
        let k = self.equalities;
        self.shortfall(x)
            .into_iter()
            .enumerate()
            .map(|(i, s)| if i < k { s.abs() } else { s })
            .fold(0.0, max_or_nan)
    }

    /// How far `(x, λ)` is from the KKT conditions of this projection.
    ///
    /// Every residual is an absolute, infinity-norm quantity; see [`KktResiduals`].
    pub fn kkt_residuals(&self, x: &[f64], multipliers: &[f64]) -> KktResiduals {
        assert_eq!(x.len(), self.dim(), "x has the wrong dimension");
        assert_eq!(
            multipliers.len(),
            self.n_rows(),
            "λ has the wrong dimension"
        );
        let mut ax = vec![0.0; self.n_rows()];
        self.a.mul_vec(x, &mut ax);
        let mut at_lambda = vec![0.0; self.dim()];
        self.a.mul_transpose_vec(multipliers, &mut at_lambda);
        let k = self.equalities;
        let primal = ax
            .iter()
            .zip(&self.b)
            .enumerate()
            .map(|(i, (axi, bi))| if i < k { (bi - axi).abs() } else { bi - axi })
            .fold(0.0, max_or_nan);
        let stationarity = if self.metric.is_identity() {
            x.iter()
                .zip(&self.y)
                .zip(&at_lambda)
                .map(|((xi, yi), ai)| (xi - yi - ai).abs())
                .fold(0.0, max_or_nan)
        } else {
            let d: Vec<f64> = x.iter().zip(&self.y).map(|(xi, yi)| xi - yi).collect();
            self.metric
                .apply(&d)
                .iter()
                .zip(&at_lambda)
                .map(|(wd, ai)| (wd - ai).abs())
                .fold(0.0, max_or_nan)
        };
        let dual = multipliers[k..].iter().map(|l| -l).fold(0.0, max_or_nan);
        let complementarity = multipliers[k..]
            .iter()
            .zip(ax[k..].iter().zip(&self.b[k..]))
            .map(|(l, (axi, bi))| (l.max(0.0) * (axi - bi)).abs())
            .fold(0.0, max_or_nan);
        KktResiduals {
            primal,
            stationarity,
            dual,
            complementarity,
        }
    }
}

/// The larger of `a` and `b`, NaN when either is. `f64::max` returns the other one, so a
/// residual folded with it would read 0 where the answer holds a NaN, and pass a check.
///
/// ```
/// assert!(sweeping_api::max_or_nan(1.0, f64::NAN).is_nan());
/// assert_eq!(sweeping_api::max_or_nan(1.0, 2.0), 2.0);
/// ```
pub fn max_or_nan(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// The end of a disagreement's message: `; NAME's answer: K block(s) short of its accuracy
/// target` for each side with any, nothing when neither has.
fn reduced_clause(first: &str, second: &str, reduced: &[u64; 2]) -> String {
    [(first, reduced[0]), (second, reduced[1])]
        .iter()
        .filter(|(_, blocks)| *blocks > 0)
        .map(|(name, blocks)| {
            format!(
                "; {name}'s answer: {blocks} block(s) short of its accuracy target (see \
                 BackendCounters::reduced)"
            )
        })
        .collect()
}

/// Residuals of the KKT conditions `Ax ≥ b`, `W(x − y) = Aᵀλ`, `λ ≥ 0`, `λᵢ(Ax − b)ᵢ = 0`
/// (`W = I` by default); on the equality rows `(Ax − b)ᵢ = 0` and no sign on `λᵢ`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct KktResiduals {
    /// `max(0, maxᵢ (b − Ax)ᵢ)` over the inequality rows, with `|b − Ax|ᵢ` over the equality
    /// rows.
    pub primal: f64,
    /// `‖W(x − y) − Aᵀλ‖∞`.
    pub stationarity: f64,
    /// `max(0, maxᵢ −λᵢ)` over the inequality rows.
    pub dual: f64,
    /// `maxᵢ |λᵢ⁺ (Ax − b)ᵢ|` over the inequality rows.
    pub complementarity: f64,
}

impl KktResiduals {
    /// The largest of the four residuals; NaN when one of them is.
    pub fn max(&self) -> f64 {
        [self.stationarity, self.dual, self.complementarity]
            .into_iter()
            .fold(self.primal, max_or_nan)
    }
}

/// The answer of a projection: the point, the multipliers of the rows, and how it was found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Projection {
    /// The projected point `x = P(y)`.
    pub x: Vec<f64>,
    /// Multipliers, one per row, with `W(x − y) = Aᵀλ` (`W = I` by default): `λᵢ ≥ 0` on an
    /// inequality row, of either sign on an equality row.
    pub multipliers: Vec<f64>,
    /// Statistics of the solve.
    pub stats: SolveStats,
}

impl Projection {
    /// The answer for a problem without rows, or whose `y` already satisfies every row:
    /// `x = y`, `λ = 0`. Backends use it to skip the solver when there is nothing to do.
    pub fn identity(problem: &ProjectionProblem, backend: &str) -> Self {
        Self {
            x: problem.y().to_vec(),
            multipliers: vec![0.0; problem.n_rows()],
            stats: SolveStats::trivial(backend),
        }
    }

    /// Number of rows whose multiplier exceeds `threshold` (the active constraints).
    pub fn active_count(&self, threshold: f64) -> usize {
        self.multipliers.iter().filter(|l| **l > threshold).count()
    }
}

/// How a solve ended, when it produced an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SolveStatus {
    /// Solved to the backend's requested accuracy.
    Solved,
    /// Solved, but only to the backend's reduced accuracy (the backend accepted it by setting).
    SolvedReducedAccuracy,
    /// No solve was needed: no rows, or `y` already feasible.
    Trivial,
}

/// Statistics of one solve, a first-class value: summed over a run, compared across backends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolveStats {
    /// Name of the backend that produced the answer.
    pub backend: String,
    /// How the solve ended.
    pub status: SolveStatus,
    /// Solver iterations (interior-point or ADMM); not reproducible across runs for every
    /// backend (OSQP adapts its step to measured time).
    pub iterations: u32,
    /// Seconds spent in the solver's solve phase.
    pub solve_seconds: f64,
    /// Seconds spent setting the problem up (conversion, factorization set-up).
    pub setup_seconds: f64,
    /// Whether the solve started from a previous answer.
    pub warm_started: bool,
    /// How the backend reached its answer, counted by sub-problem (block).
    #[serde(default)]
    pub counters: BackendCounters,
}

/// What a backend counts about how it reached its answers, by sub-problem (block), summed over
/// blocks and solves: in every backend's statistics, zero where a backend has no such thing.
///
/// ```
/// use sweeping_api::BackendCounters;
/// let mut total = BackendCounters::default();
/// total.add(&BackendCounters { escalations: 2, reduced: 1, reduced_by: 3e-10, ..Default::default() });
/// total.add(&BackendCounters { fallbacks: 1, reduced: 1, reduced_by: 1e-10, ..Default::default() });
/// assert_eq!((total.fallbacks, total.escalations, total.reduced), (1, 2, 2));
/// assert_eq!(total.reduced_by, 3e-10);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BackendCounters {
    /// Sub-problems the backend could not answer itself and handed to a fallback backend.
    #[serde(default)]
    pub fallbacks: u64,
    /// Sub-problems its first method did not answer and its second one did (the native
    /// backend: the active set's warm attempt, then the interior point).
    #[serde(default)]
    pub escalations: u64,
    /// Sub-problems answered short of the backend's own accuracy target, within its KKT check
    /// (the native backend: an interior point that stalled near its tolerance; Clarabel: an
    /// interior-point answer its polish could not finish).
    #[serde(default)]
    pub reduced: u64,
    /// The largest estimated distance of those answers from the exact projection (absolute;
    /// `0` when there are none).
    #[serde(default)]
    pub reduced_by: f64,
}

impl BackendCounters {
    /// Adds `other`'s counts (saturating) and keeps the larger `reduced_by` (NaN when either
    /// is).
    pub fn add(&mut self, other: &BackendCounters) {
        self.fallbacks = self.fallbacks.saturating_add(other.fallbacks);
        self.escalations = self.escalations.saturating_add(other.escalations);
        self.reduced = self.reduced.saturating_add(other.reduced);
        self.reduced_by = max_or_nan(self.reduced_by, other.reduced_by);
    }
}

impl SolveStats {
    /// The statistics of an answer that needed no solver work (status
    /// [`SolveStatus::Trivial`], every count zero); solves add to them.
    pub fn trivial(backend: &str) -> Self {
        Self {
            backend: backend.to_string(),
            status: SolveStatus::Trivial,
            iterations: 0,
            solve_seconds: 0.0,
            setup_seconds: 0.0,
            warm_started: false,
            counters: BackendCounters::default(),
        }
    }
}

/// Why a projection failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ProjectionError {
    /// The problem itself is malformed (dimensions, non-finite numbers).
    #[error("invalid projection problem: {reason}")]
    InvalidInput {
        /// What is wrong.
        reason: String,
    },
    /// The polyhedron `{x : Ax ≥ b}` is empty (certified by the backend).
    #[error("{backend}: the constraint set is infeasible ({detail})")]
    Infeasible {
        /// Backend that certified it.
        backend: String,
        /// Backend status or certificate summary.
        detail: String,
        /// The rows (indices into the problem's rows) of the certificate, when the backend
        /// names them: a non-negative combination of them reads `0 ≥ positive`. Empty when it
        /// gives only a status.
        rows: Vec<usize>,
    },
    /// The backend stopped before reaching its tolerances.
    #[error("{backend}: not converged after {iterations} iterations (status {status})")]
    NotConverged {
        /// Backend name.
        backend: String,
        /// Iterations spent.
        iterations: u32,
        /// The backend's own status name.
        status: String,
    },
    /// Any other failure inside the backend (numerical error, set-up failure).
    #[error("{backend}: backend failure: {message}")]
    Backend {
        /// Backend name.
        backend: String,
        /// What it reported.
        message: String,
    },
    /// Two backends run by [`CrossCheck`] returned points farther apart than allowed.
    #[error(
        "backends disagree: {first} and {second} differ by {gap:.3e} (∞-norm, coordinate {coordinate}) > tolerance {tolerance:.1e}{}", reduced_clause(first, second, reduced)
    )]
    Disagreement {
        /// First backend.
        first: String,
        /// Second backend.
        second: String,
        /// `‖x₁ − x₂‖∞`.
        gap: f64,
        /// Where the gap is largest.
        coordinate: usize,
        /// The allowed gap.
        tolerance: f64,
        /// How many blocks of each answer (first, second) were answered short of their
        /// backend's accuracy target ([`BackendCounters::reduced`]); the message names the
        /// answers that have any, the side to suspect.
        reduced: [u64; 2],
    },
}

/// The rows of an infeasibility certificate given as one weight per row (a dual ray): those
/// whose weight is not negligible against the largest, `|wᵢ| > 1e-6 · maxⱼ |wⱼ|`; none when
/// the weights are all zero or not finite.
pub fn certificate_rows(weights: &[f64]) -> Vec<usize> {
    let top = weights.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
    if !(top.is_finite() && top > 0.0) {
        return Vec::new();
    }
    (0..weights.len())
        .filter(|&i| weights[i].abs() > 1e-6 * top)
        .collect()
}

impl ProjectionError {
    /// The error of a block said in the whole problem's rows: a certificate's rows renumbered,
    /// `rows[k]` being the whole problem's index of the block's row `k`.
    #[must_use]
    pub fn in_rows_of(self, rows: &[usize]) -> Self {
        match self {
            Self::Infeasible {
                backend,
                detail,
                rows: local,
            } => Self::Infeasible {
                backend,
                detail,
                rows: local.iter().filter_map(|&k| rows.get(k).copied()).collect(),
            },
            other => other,
        }
    }
}

/// A backend that projects onto `{x : Ax ≥ b}`.
///
/// Object-safe, so a simulation can hold a `Box<dyn Projector>` chosen at run time; `&mut self`
/// so that a backend may cache its factorization or warm-start from the previous step.
///
/// # Implementing your own
/// A backend needs one method. This one handles a single row in closed form
/// (`x = y + max(0, b − a·y)/|a|² a`) and refuses anything larger:
///
/// ```
/// use sweeping_api::{Projection, ProjectionError, ProjectionProblem, Projector, SparseRows,
///                    SolveStats, SolveStatus};
///
/// struct OneRow;
///
/// impl Projector for OneRow {
///     fn name(&self) -> &str { "one-row" }
///
///     fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
///         match p.n_rows() {
///             0 => Ok(Projection::identity(p, self.name())),
///             1 => {
///                 let row: Vec<(usize, f64)> = p.a().row(0).collect();
///                 let ay: f64 = row.iter().map(|&(j, v)| v * p.y()[j]).sum();
///                 let norm2: f64 = row.iter().map(|&(_, v)| v * v).sum();
///                 let lambda = ((p.b()[0] - ay) / norm2).max(0.0);
///                 let mut x = p.y().to_vec();
///                 for &(j, v) in &row { x[j] += lambda * v; }
///                 Ok(Projection {
///                     x,
///                     multipliers: vec![lambda],
///                     stats: SolveStats {
///                         status: SolveStatus::Solved,
///                         ..SolveStats::trivial(self.name())
///                     },
///                 })
///             }
///             n => Err(ProjectionError::Backend {
///                 backend: self.name().into(),
///                 message: format!("{n} rows: this backend handles one"),
///             }),
///         }
///     }
/// }
///
/// // Project (0, 0) onto x₀ + x₁ ≥ 2.
/// let a = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 1.0)]]);
/// let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![2.0]).unwrap();
/// let sol = OneRow.project(&p).unwrap();
/// assert!((sol.x[0] - 1.0).abs() < 1e-12 && (sol.x[1] - 1.0).abs() < 1e-12);
/// assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() < 1e-12);
/// ```
pub trait Projector: Send {
    /// A short name for reports and errors ("clarabel", "osqp", …).
    fn name(&self) -> &str;

    /// Projects `problem.y()` onto `{x : A x ≥ b}`.
    ///
    /// # Errors
    /// A [`ProjectionError`] saying why no answer within the backend's tolerances was found.
    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError>;

    /// The accuracy this backend aims at, as an absolute tolerance on the KKT residuals; used
    /// by callers to decide what "active" and "agree" mean. Defaults to `1e-6`.
    fn tolerance(&self) -> f64 {
        1e-6
    }

    /// What a backend that runs two others and compares them ([`CrossCheck`]) has seen so
    /// far, for a run's report; `None` (the default) for every other backend.
    fn cross_check(&self) -> Option<&CrossCheckStats> {
        None
    }
}

impl<P: Projector + ?Sized> Projector for Box<P> {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        (**self).project(problem)
    }
    fn tolerance(&self) -> f64 {
        (**self).tolerance()
    }
    fn cross_check(&self) -> Option<&CrossCheckStats> {
        (**self).cross_check()
    }
}

impl fmt::Display for SolveStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            SolveStatus::Solved => "solved",
            SolveStatus::SolvedReducedAccuracy => "solved (reduced accuracy)",
            SolveStatus::Trivial => "trivial",
        };
        f.write_str(s)
    }
}
