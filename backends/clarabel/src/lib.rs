//! The [Clarabel](https://clarabel.org) interior-point backend of `sweeping`.
//!
//! [`ClarabelProjector`] solves the projection `min ½‖x − y‖² s.t. A x ≥ b` of a
//! [`ProjectionProblem`] with Clarabel 0.11, a primal–dual interior-point method for conic
//! programs. It is the accurate backend, the one used to cross-validate the others.
//!
//! # Formulation: the displacement, not the point
//!
//! Clarabel solves `min ½ uᵀPu + qᵀu s.t. G u + s = h, s ∈ K`. The projection is handed to it
//! in the **displacement** `d = x − y`: `P = I`, `q = 0`, `G = −A`, `h = A y − b`, cone
//! `ℝᵐ₊`; then `x = y + d`, the cone's dual variable is the vector of multipliers `λ`
//! (stationarity reads `d = Aᵀλ`) and the slack is `A x − b`. A problem in a metric `W` has
//! `P = W`; its equality rows (the leading ones) have their slacks in the zero cone, and
//! their multipliers have either sign. Written in `x`, the cost
//! `½‖x‖² − yᵀx` is dominated by `‖y‖²` when the configuration lies far from the origin (crowds
//! sit at coordinates ~10²), and Clarabel's relative duality-gap rule stops while the point is
//! still visibly off; in `d` the cost is the squared step itself.
//!
//! # Tolerances and shortcuts
//!
//! The defaults of [`ClarabelSettings`] are tight (gap and feasibility `1e-10`). No solver is
//! built when there are no rows or when `y` already satisfies every row within
//! [`ClarabelSettings::tol_feas`]: the answer is `x = y`, `λ = 0` ([`Projection::identity`],
//! [`SolveStatus::Trivial`]). A row with no non-zero entry and `bᵢ > 0` is
//! [`ProjectionError::Infeasible`] without calling the solver.
//!
//! # Polish: why, and when its answer is kept
//!
//! An interior-point iterate approaches the answer from inside the cone: on a row tight at the
//! answer with a zero multiplier (*weakly* active, common at degenerate vertices and contact
//! loops) the point stays off by about the square root of the duality gap, however small the
//! residuals. Unless [`ClarabelSettings::polish`] is off, a Lawson–Hanson active-set method on
//! the dual of the projection finishes the job from the interior-point answer, block by block
//! (connected components of the rows, each under its own cap of iterations; each step one
//! sparse `LDLᵀ` factorization in QDLDL's arithmetic; linearly dependent active rows are
//! handled); it works in the identity metric on inequalities, so a problem with a metric or
//! equality rows is polished in `z = Lᵀx` with each equality as a pair of opposite
//! inequalities, and said back in `x`. **KKT acceptance:** the polished answer replaces the interior-point one when its
//! KKT residuals are no larger, or below a hundredth of [`ClarabelSettings::kkt_tolerance`];
//! a solve that stops short (iteration limit, insufficient progress) is kept only if its KKT
//! residuals are within tolerance. Measurements, with the commands that reproduce them:
//! `docs/lab/2026-11-23-clarabel-contact-loop-and-conformance.md` and
//! `docs/lab/2026-11-23-clarabel-polish-block-by-block.md`.
//!
//! # Statuses
//!
//! Every [`clarabel::solver::SolverStatus`] is mapped explicitly; see
//! [`ClarabelProjector`]. Clarabel 0.11 has no warm start, so a fresh solver is built for
//! every projection and [`SolveStats::warm_started`] is always `false`.
//! [`SolveStats::setup_seconds`] times the conversion of the data and Clarabel's set-up
//! (equilibration, symbolic factorization), [`SolveStats::solve_seconds`] the interior-point
//! iterations and the polishing.
//!
//! ```
//! use sweeping_api::{ProjectionProblem, Projector, SparseRows};
//! use sweeping_clarabel::ClarabelProjector;
//!
//! // Two points on a line, 0.1 apart, that must be at least 0.4 apart: x₁ − x₀ ≥ 0.4.
//! let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
//! let p = ProjectionProblem::new(vec![0.0, 0.1], a, vec![0.4]).unwrap();
//! let sol = ClarabelProjector::default().project(&p).unwrap();
//! assert!((sol.x[0] + 0.15).abs() < 1e-7 && (sol.x[1] - 0.25).abs() < 1e-7);
//! assert!((sol.multipliers[0] - 0.15).abs() < 1e-6);
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod polish;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolution, DefaultSolver, IPSolver,
    SolverStatus, SupportedConeT,
};
use serde::{Deserialize, Serialize};
use std::time::Instant;
use sweeping_api::{
    BackendCounters, Metric, Projection, ProjectionError, ProjectionProblem, Projector, SolveStats,
    SolveStatus,
};

/// The name this backend reports in statistics and errors.
pub const NAME: &str = "clarabel";

/// Settings of [`ClarabelProjector`]: a plain, serialisable value.
///
/// The defaults ([`ClarabelSettings::default`]) are tight, for cross-validation: gap and
/// feasibility tolerances `1e-10`, two orders below Clarabel's own `1e-8`, and the answer is
/// polished. Polishing removes the point error of weakly active rows when its active-set
/// method converges; the tight tolerances are for the steps where it does not. `1e-10` is
/// the tightest setting that solves jammed crowds without stalling (a step that stalls just
/// above it is accepted after verification: see [`ClarabelProjector`]).
/// [`ClarabelSettings::loose`] restores Clarabel's own tolerances for speed.
///
/// ```
/// use sweeping_clarabel::ClarabelSettings;
/// let s: ClarabelSettings = serde_json::from_str(r#"{
///     "tol_gap_abs": 1e-9, "tol_gap_rel": 1e-9, "tol_feas": 1e-9,
///     "tol_infeas_abs": 1e-8, "tol_infeas_rel": 1e-8, "max_iter": 100,
///     "time_limit": 0.5, "accept_almost_solved": true, "verbose": false,
///     "presolve": true, "equilibrate": true, "polish": true
/// }"#).unwrap();
/// assert_eq!(s.max_iter, 100);
/// assert_eq!(s.time_limit, Some(0.5));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ClarabelSettings {
    /// Absolute duality-gap tolerance (Clarabel `tol_gap_abs`). Default `1e-10`. For this
    /// problem the gap is `Σᵢ λᵢ (Ax − b)ᵢ`, so it bounds the complementarity residual.
    pub tol_gap_abs: f64,
    /// Relative duality-gap tolerance (Clarabel `tol_gap_rel`). Default `1e-10`.
    pub tol_gap_rel: f64,
    /// Primal and dual feasibility tolerance (Clarabel `tol_feas`), relative to the size of
    /// the data. Default `1e-10`.
    pub tol_feas: f64,
    /// Absolute tolerance of the infeasibility certificate (Clarabel `tol_infeas_abs`).
    /// Default `1e-8` (Clarabel's).
    pub tol_infeas_abs: f64,
    /// Relative tolerance of the infeasibility certificate (Clarabel `tol_infeas_rel`).
    /// Default `1e-8` (Clarabel's).
    pub tol_infeas_rel: f64,
    /// Most interior-point iterations. Default `200` (Clarabel's); a projection typically
    /// needs 8–20.
    pub max_iter: u32,
    /// Wall-clock limit in seconds for set-up plus solve (Clarabel counts both), `None` for
    /// none. Default `None`.
    pub time_limit: Option<f64>,
    /// What to do when Clarabel stops with `AlmostSolved` (its reduced accuracy: gaps
    /// `5e-5`, feasibility `1e-4`) and the answer's KKT residuals exceed
    /// [`ClarabelSettings::kkt_tolerance`] (within it, the answer counts as solved: see
    /// [`ClarabelProjector`]): `true` returns it with [`SolveStatus::SolvedReducedAccuracy`],
    /// `false` returns [`ProjectionError::NotConverged`]. Default `false`: a reference backend
    /// must not pass off a `1e-4` answer as a solution; a simulation that prefers to go on may
    /// set it.
    pub accept_almost_solved: bool,
    /// Let Clarabel print its iteration log to standard output. Default `false` (Clarabel's
    /// own default is `true`).
    pub verbose: bool,
    /// Clarabel's presolve, which drops the rows with `(A y − b)ᵢ > 1e20` (satisfied at `y`
    /// by more than any step moves; their multiplier is then `0`). Default `true`
    /// (Clarabel's).
    pub presolve: bool,
    /// Clarabel's Ruiz equilibration of the data. Default `true` (Clarabel's).
    pub equilibrate: bool,
    /// Polish the interior-point answer: guess the active rows (multiplier larger than
    /// slack), finish the projection from them with the active-set method, block by block
    /// (see the crate documentation), and keep the result when its KKT residuals are no
    /// larger than the interior-point answer's, or below a hundredth of
    /// [`kkt_tolerance`](Self::kkt_tolerance). Default `true`. Without it, a row that is
    /// tight at the answer with a zero multiplier leaves the point off by about the square
    /// root of the duality gap.
    pub polish: bool,
}

impl Default for ClarabelSettings {
    fn default() -> Self {
        Self {
            tol_gap_abs: 1e-10,
            tol_gap_rel: 1e-10,
            tol_feas: 1e-10,
            tol_infeas_abs: 1e-8,
            tol_infeas_rel: 1e-8,
            max_iter: 200,
            time_limit: None,
            accept_almost_solved: false,
            verbose: false,
            presolve: true,
            equilibrate: true,
            polish: true,
        }
    }
}

impl ClarabelSettings {
    /// Clarabel's own stopping tolerances (`1e-8` for gaps and feasibility), quiet, polished,
    /// and accepting `AlmostSolved`: for production runs where speed matters more than a
    /// safety margin. Fewer iterations than the default; as accurate when polishing
    /// succeeds, but off by up to ~`1e-4` on instances with weakly active rows when it does
    /// not.
    pub fn loose() -> Self {
        Self {
            tol_gap_abs: 1e-8,
            tol_gap_rel: 1e-8,
            tol_feas: 1e-8,
            accept_almost_solved: true,
            ..Self::default()
        }
    }

    /// The absolute KKT accuracy these settings aim at, reported by
    /// [`Projector::tolerance`]: `100 × max(tol_gap_abs, tol_feas)` (so `1e-8` by default).
    ///
    /// The factor covers Clarabel's scaling of the feasibility residuals by the size of the
    /// data and the sum over rows in the gap, which can leave an unpolished answer's residuals
    /// several times `max(tol_gap_abs, tol_feas)`.
    /// It bounds residuals, not the distance to the exact projection, which can reach
    /// `√(rows × residual)` when polishing fails (see the crate documentation).
    pub fn kkt_tolerance(&self) -> f64 {
        100.0 * self.tol_gap_abs.max(self.tol_feas)
    }

    /// Checks that the tolerances are positive and finite and the time limit non-negative.
    fn validate(&self) -> Result<(), String> {
        let tolerances = [
            ("tol_gap_abs", self.tol_gap_abs),
            ("tol_gap_rel", self.tol_gap_rel),
            ("tol_feas", self.tol_feas),
            ("tol_infeas_abs", self.tol_infeas_abs),
            ("tol_infeas_rel", self.tol_infeas_rel),
        ];
        for (name, v) in tolerances {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("setting {name} = {v} must be positive and finite"));
            }
        }
        if let Some(t) = self.time_limit {
            if t.is_nan() || t < 0.0 {
                return Err(format!("setting time_limit = {t} must be non-negative"));
            }
        }
        Ok(())
    }

    /// The Clarabel settings object.
    fn to_clarabel(&self) -> Result<DefaultSettings<f64>, String> {
        self.validate()?;
        DefaultSettingsBuilder::default()
            .tol_gap_abs(self.tol_gap_abs)
            .tol_gap_rel(self.tol_gap_rel)
            .tol_feas(self.tol_feas)
            .tol_infeas_abs(self.tol_infeas_abs)
            .tol_infeas_rel(self.tol_infeas_rel)
            .max_iter(self.max_iter)
            .time_limit(self.time_limit.unwrap_or(f64::INFINITY))
            .verbose(self.verbose)
            .presolve_enable(self.presolve)
            .equilibrate_enable(self.equilibrate)
            .build()
            .map_err(|e| format!("settings rejected by clarabel: {e}"))
    }
}

/// Projection backend built on Clarabel's interior-point solver.
///
/// Holds only its [`ClarabelSettings`]: Clarabel 0.11 cannot warm-start, so every call to
/// [`Projector::project`] builds and solves a fresh problem.
///
/// # Status mapping
///
/// | Clarabel status | result |
/// |---|---|
/// | `Solved` | `Ok`, [`SolveStatus::Solved`] |
/// | `AlmostSolved` | verified (below), else `Ok` with [`SolveStatus::SolvedReducedAccuracy`] if [`ClarabelSettings::accept_almost_solved`], else [`ProjectionError::NotConverged`] |
/// | `MaxIterations`, `MaxTime`, `InsufficientProgress` | verified (below), else [`ProjectionError::NotConverged`] |
/// | `PrimalInfeasible`, `AlmostPrimalInfeasible` | [`ProjectionError::Infeasible`] |
/// | `DualInfeasible`, `AlmostDualInfeasible` | [`ProjectionError::Backend`]: the cost `½‖d‖²` is bounded below, so a dual-infeasibility certificate can only be a numerical failure |
/// | `NumericalError` | [`ProjectionError::Backend`] |
/// | `CallbackTerminated`, `Unsolved` | [`ProjectionError::Backend`]: no callback is installed and the solver has run, so neither should occur |
///
/// *Verified*: when Clarabel stops short of its own stopping rule it still hands back its
/// best iterate. That iterate (polished, if polishing is on) is returned as
/// [`SolveStatus::Solved`] when its KKT residuals, measured by
/// [`ProjectionProblem::kkt_residuals`], are within [`ClarabelSettings::kkt_tolerance`]: the
/// accuracy this backend promises through [`Projector::tolerance`]. This matters at the tight
/// default tolerances, which sit close to what double precision allows on jammed crowds.
///
/// A rejected set-up (`DefaultSolver::new` returns a `Result`) is a
/// [`ProjectionError::Backend`]; so is a non-finite answer under `Solved` (under the other
/// statuses it is that status's error).
///
/// # Multipliers
///
/// The multipliers are Clarabel's `z`, which an interior-point method keeps inside the cone
/// (`z > 0`), or those of the polished answer. A multiplier negative by less than
/// [`ClarabelSettings::kkt_tolerance`] (undoing Clarabel's equilibration, or rounding in
/// polishing a weakly active row) is clamped to `0`; a more negative one from Clarabel is
/// reported as [`ProjectionError::Backend`], and a polished answer with one is not used.
///
/// ```
/// use sweeping_api::{ProjectionProblem, Projector, SolveStatus, SparseRows};
/// use sweeping_clarabel::{ClarabelProjector, ClarabelSettings};
///
/// // Project (−1, 2, −0.5) onto the non-negative orthant: x = max(y, 0), λ = max(−y, 0).
/// let rows: Vec<Vec<(usize, f64)>> = (0..3).map(|i| vec![(i, 1.0)]).collect();
/// let a = SparseRows::from_rows(3, &rows);
/// let p = ProjectionProblem::new(vec![-1.0, 2.0, -0.5], a, vec![0.0; 3]).unwrap();
///
/// let mut clarabel = ClarabelProjector::new(ClarabelSettings::default());
/// let sol = clarabel.project(&p).unwrap();
/// assert_eq!(sol.stats.status, SolveStatus::Solved);
/// for (x, expected) in sol.x.iter().zip([0.0, 2.0, 0.0]) {
///     assert!((x - expected).abs() < 1e-7);
/// }
/// for (l, expected) in sol.multipliers.iter().zip([1.0, 0.0, 0.5]) {
///     assert!((l - expected).abs() < 1e-6);
/// }
/// assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() < clarabel.tolerance());
/// ```
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ClarabelProjector {
    /// The settings used for every solve.
    pub settings: ClarabelSettings,
}

/// An infeasibility said with the rows of Clarabel's certificate: for `−A x + s = −b`,
/// `s ≥ 0`, its dual ray `z ≥ 0` has `Aᵀz = 0` and `bᵀz > 0`, a non-negative combination of
/// the rows reading `0 ≥ positive`; the rows are those where `z` is not negligible.
fn with_certificate(error: ProjectionError, z: &[f64]) -> ProjectionError {
    match error {
        ProjectionError::Infeasible {
            backend,
            detail,
            rows,
        } if rows.is_empty() => ProjectionError::Infeasible {
            backend,
            detail,
            rows: sweeping_api::certificate_rows(z),
        },
        other => other,
    }
}

impl ClarabelProjector {
    /// A projector with the given settings.
    pub fn new(settings: ClarabelSettings) -> Self {
        Self { settings }
    }

    fn backend_error(message: impl Into<String>) -> ProjectionError {
        ProjectionError::Backend {
            backend: NAME.to_string(),
            message: message.into(),
        }
    }

    /// What to do with the iterate Clarabel hands back: `Ok(None)` when it is solved,
    /// `Ok(Some(fallback))` when it must first be verified (`fallback` applies when its KKT
    /// residuals exceed the tolerance), `Err` when there is no answer.
    fn verdict(status: SolverStatus, iterations: u32, accept_almost_solved: bool) -> Verdict {
        let name = status_name(status);
        let not_converged = || ProjectionError::NotConverged {
            backend: NAME.to_string(),
            iterations,
            status: name.clone(),
        };
        match status {
            SolverStatus::Solved => Ok(None),
            SolverStatus::AlmostSolved => Ok(Some(if accept_almost_solved {
                Ok(SolveStatus::SolvedReducedAccuracy)
            } else {
                Err(not_converged())
            })),
            SolverStatus::MaxIterations
            | SolverStatus::MaxTime
            | SolverStatus::InsufficientProgress => Ok(Some(Err(not_converged()))),
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                Err(ProjectionError::Infeasible {
                    backend: NAME.to_string(),
                    detail: format!("{name} after {iterations} iterations"),
                    rows: Vec::new(),
                })
            }
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                Err(Self::backend_error(format!(
                    "status {name} after {iterations} iterations: impossible for a \
                     projection (the cost ½‖x − y‖² is bounded below), a numerical failure"
                )))
            }
            SolverStatus::NumericalError => Err(Self::backend_error(format!(
                "status {name} after {iterations} iterations"
            ))),
            // No callback is installed and `solve` has run: neither can happen.
            SolverStatus::CallbackTerminated | SolverStatus::Unsolved => Err(Self::backend_error(
                format!("unexpected status {name} after {iterations} iterations"),
            )),
        }
    }
}

/// `−A` in CSC form with entries repeated within a row summed (the [`sweeping_api::SparseRows`]
/// contract asks for distinct columns but does not enforce it; Clarabel needs a valid CSC).
/// Returns the matrix and, per row, whether it kept a non-zero entry.
fn negated_csc(problem: &ProjectionProblem) -> (CscMatrix<f64>, Vec<bool>) {
    let a = problem.a();
    let (m, n) = (a.n_rows(), a.n_cols());
    let (col_ptr, row_idx, values) = a.to_csc();
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval: Vec<usize> = Vec::with_capacity(row_idx.len());
    let mut nzval: Vec<f64> = Vec::with_capacity(values.len());
    let mut nonzero_row = vec![false; m];
    colptr.push(0);
    for j in 0..n {
        let start = rowval.len();
        for k in col_ptr[j]..col_ptr[j + 1] {
            let (r, v) = (row_idx[k], -values[k]);
            // `to_csc` sorts row indices within a column, so repeats are adjacent.
            if rowval.len() > start && rowval.last() == Some(&r) {
                if let Some(last) = nzval.last_mut() {
                    *last += v;
                }
            } else {
                rowval.push(r);
                nzval.push(v);
            }
        }
        for (r, v) in rowval[start..].iter().zip(&nzval[start..]) {
            if *v != 0.0 {
                nonzero_row[*r] = true;
            }
        }
        colptr.push(rowval.len());
    }
    (CscMatrix::new(m, n, colptr, rowval, nzval), nonzero_row)
}

/// `P = W`, its upper triangle compressed by columns (Clarabel reads only that triangle).
fn metric_csc(metric: &Metric, n: usize) -> CscMatrix<f64> {
    let (col_ptr, row_idx, values) = metric.upper_triangle_csc(n);
    CscMatrix::new(n, n, col_ptr, row_idx, values)
}

fn status_name(status: SolverStatus) -> String {
    format!("{status:?}")
}

/// What `verdict` makes of a status: see there.
type Verdict = Result<Option<Result<SolveStatus, ProjectionError>>, ProjectionError>;

/// An answer to a projection as it is refined: the point, the multipliers, its largest KKT
/// residual, and what the active-set polish left unfinished (blocks, how far off).
struct Answer {
    x: Vec<f64>,
    multipliers: Vec<f64>,
    kkt: f64,
    unfinished: (u32, f64),
}

impl ClarabelProjector {
    /// Clarabel set up on the projection problem, or `None` when `y` already lies in the set
    /// (within `tol_feas`): nothing to solve.
    fn set_up(
        &self,
        problem: &ProjectionProblem,
        settings: DefaultSettings<f64>,
    ) -> Result<Option<DefaultSolver<f64>>, ProjectionError> {
        let (m, n) = (problem.n_rows(), problem.dim());
        // h = A y − b: how much each row is satisfied (> 0) or violated (< 0) at y.
        let mut h = vec![0.0; m];
        problem.a().mul_vec(problem.y(), &mut h);
        for (hi, bi) in h.iter_mut().zip(problem.b()) {
            *hi -= bi;
        }
        if let Some(i) = h.iter().position(|v| !v.is_finite()) {
            return Err(Self::backend_error(format!(
                "(A y − b)[{i}] = {} overflows: the data are too large",
                h[i]
            )));
        }
        let k = problem.equalities();
        let violation = h.iter().enumerate().fold(0.0, |worst: f64, (i, hi)| {
            worst.max(if i < k { hi.abs() } else { -hi })
        });
        if m == 0 || violation <= self.settings.tol_feas {
            return Ok(None);
        }
        let (g, nonzero_row) = negated_csc(problem);
        if let Some(r) = (0..m).find(|&r| {
            !nonzero_row[r] && (problem.b()[r] > 0.0 || (r < k && problem.b()[r] != 0.0))
        }) {
            return Err(ProjectionError::Infeasible {
                backend: NAME.to_string(),
                detail: format!(
                    "row {r} has no non-zero entry and b[{r}] = {} > 0",
                    problem.b()[r]
                ),
                rows: vec![r],
            });
        }
        let p = metric_csc(problem.metric(), n);
        let q = vec![0.0; n];
        // Equality rows are the leading ones: their slacks lie in the zero cone.
        let cones: Vec<SupportedConeT<f64>> = [
            (k > 0).then_some(SupportedConeT::ZeroConeT(k)),
            (m > k).then_some(SupportedConeT::NonnegativeConeT(m - k)),
        ]
        .into_iter()
        .flatten()
        .collect();
        DefaultSolver::new(&p, &q, &g, &h, &cones, settings)
            .map(Some)
            .map_err(|e| Self::backend_error(format!("set-up failed: {e}")))
    }
}

/// The point `x = y + Δ` and the multipliers of Clarabel's answer, checked: sizes, finite
/// values, inequality multipliers non-negative up to `clamp` (then clamped to 0).
fn read_answer(
    problem: &ProjectionProblem,
    solution: &DefaultSolution<f64>,
    clamp: f64,
    malformed: &dyn Fn(String) -> ProjectionError,
) -> Result<(Vec<f64>, Vec<f64>), ProjectionError> {
    let (m, n, k) = (problem.n_rows(), problem.dim(), problem.equalities());
    if solution.x.len() != n || solution.z.len() != m || solution.s.len() != m {
        return Err(malformed(format!(
            "the answer has {} coordinates, {} multipliers and {} slacks, expected {n}, \
             {m}, {m}",
            solution.x.len(),
            solution.z.len(),
            solution.s.len()
        )));
    }
    let x: Vec<f64> = problem
        .y()
        .iter()
        .zip(&solution.x)
        .map(|(y, d)| y + d)
        .collect();
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(malformed(format!("x[{i}] = {} is not finite", x[i])));
    }
    let mut multipliers = Vec::with_capacity(m);
    for (i, &z) in solution.z.iter().enumerate() {
        if i < k {
            // An equality's multiplier has either sign.
            if !z.is_finite() {
                return Err(malformed(format!("multiplier {i} = {z} is not finite")));
            }
            multipliers.push(z);
            continue;
        }
        if !z.is_finite() || z < -clamp {
            return Err(malformed(format!(
                "multiplier {i} = {z} is not a finite non-negative number"
            )));
        }
        multipliers.push(z.max(0.0));
    }
    Ok((x, multipliers))
}

/// The interior-point answer polished by the active-set method, or, when no block is
/// polished or the polished answer is not kept, the iterate as it is, saying it is unfinished.
fn polished(
    problem: &ProjectionProblem,
    solution: &DefaultSolution<f64>,
    answer: Answer,
    clamp: f64,
) -> Answer {
    let k = problem.equalities();
    // The polish is an active set in the identity metric on inequalities: a problem with
    // a metric or equality rows is polished in z = Lᵀx with its equalities as pairs.
    let plain = problem.metric().is_identity() && k == 0;
    let attempt = if plain {
        polish::polish(problem, &answer.x, &solution.z, &solution.s)
    } else {
        polish::polish_general(problem, &answer.x, &solution.z, &solution.s)
    };
    if let Some(polish::Polished {
        x,
        lambda: mut multipliers,
        unfinished,
    }) = attempt
    {
        // Tiny negative multipliers of weakly active rows are clamped as above; a
        // larger one disqualifies the polished answer (an equality's has no sign).
        let valid = multipliers[k..].iter().all(|l| *l >= -clamp);
        multipliers[k..].iter_mut().for_each(|l| *l = l.max(0.0));
        let kkt = problem.kkt_residuals(&x, &multipliers).max();
        // Small KKT residuals of the interior-point iterate do not make its point
        // accurate (weakly active rows leave it off by ~√gap), so the polished answer
        // is kept whenever it meets a hundredth of the tolerance, not only when it
        // beats the iterate's residuals (measured:
        // `docs/lab/2026-11-23-clarabel-contact-loop-and-conformance.md`).
        if valid && kkt <= answer.kkt.max(0.01 * clamp) {
            return Answer {
                x,
                multipliers,
                kkt,
                unfinished,
            };
        }
    }
    // The interior-point iterate stands, unpolished: an answer the active-set method did not
    // finish, which says so, as one (a problem without rows returned `y` before).
    // Slacks of the point itself (Clarabel's cone slacks are never negative). An equality
    // row is off by its |slack|, whatever its multiplier.
    let slack = problem.shortfall(&answer.x).into_iter().map(|r| -r);
    let rows = answer.multipliers.iter().copied().zip(slack).enumerate();
    let off =
        polish::iterate_off(rows.map(|(i, (l, s))| if i < k { (0.0, -s.abs()) } else { (l, s) }));
    Answer {
        unfinished: (1, off),
        ..answer
    }
}

impl Projector for ClarabelProjector {
    fn name(&self) -> &str {
        NAME
    }

    fn tolerance(&self) -> f64 {
        self.settings.kkt_tolerance()
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let setup_start = Instant::now();
        let settings = self.settings.to_clarabel().map_err(Self::backend_error)?;
        let Some(mut solver) = self.set_up(problem, settings)? else {
            return Ok(Projection::identity(problem, NAME));
        };
        let setup_seconds = setup_start.elapsed().as_secs_f64();

        let solve_start = Instant::now();
        solver.solve();

        let solution = &solver.solution;
        let iterations = solution.iterations;
        let status = solution.status;
        let name = status_name(status);
        let not_converged = || ProjectionError::NotConverged {
            backend: NAME.to_string(),
            iterations,
            status: name.clone(),
        };
        let verify = Self::verdict(status, iterations, self.settings.accept_almost_solved)
            .map_err(|e| with_certificate(e, &solution.z))?;
        // A malformed iterate is a backend failure when Clarabel called it solved, and the
        // status's own error otherwise.
        let malformed = |message: String| match &verify {
            None => Self::backend_error(format!("status {name} but {message}")),
            Some(_) => not_converged(),
        };
        let clamp = self.tolerance();
        let (x, multipliers) = read_answer(problem, solution, clamp, &malformed)?;
        let kkt = problem.kkt_residuals(&x, &multipliers).max();
        let answer = Answer {
            x,
            multipliers,
            kkt,
            unfinished: (0, 0.0),
        };
        let Answer {
            x,
            multipliers,
            kkt,
            unfinished,
        } = if self.settings.polish {
            polished(problem, solution, answer, clamp)
        } else {
            answer
        };
        let status = match verify {
            None => SolveStatus::Solved,
            Some(_) if kkt <= clamp => SolveStatus::Solved,
            Some(fallback) => fallback?,
        };
        let solve_seconds = solve_start.elapsed().as_secs_f64();
        Ok(Projection {
            x,
            multipliers,
            stats: SolveStats {
                backend: NAME.to_string(),
                status,
                iterations,
                solve_seconds,
                setup_seconds,
                warm_started: false,
                counters: BackendCounters {
                    reduced: u64::from(unfinished.0),
                    reduced_by: unfinished.1,
                    ..BackendCounters::default()
                },
            },
        })
    }
}
