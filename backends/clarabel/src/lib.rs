//! The [Clarabel](https://clarabel.org) interior-point backend of `sweeping`.
//!
//! [`ClarabelProjector`] solves the projection `min ½‖x − y‖² s.t. A x ≥ b` of a
//! [`ProjectionProblem`] with Clarabel 0.11, a primal–dual interior-point method for conic
//! programs. It is the accurate backend, the one used to cross-validate the others.
//!
//! # Formulation
//!
//! Clarabel solves `min ½ uᵀPu + qᵀu s.t. G u + s = h, s ∈ K`. The projection is handed to it
//! in the unknown **displacement** `d = x − y` rather than in `x`:
//!
//! ```text
//!     min ½‖d‖²   s.t.   (−A) d + s = −(b − A y),   s ∈ ℝᵐ₊ (NonnegativeConeT(m)),
//! ```
//!
//! that is `P = I` (identity, upper-triangular CSC), `q = 0`, `G = −A`, `h = A y − b`. The
//! answer is `x = y + d`, and the dual variable `z ≥ 0` of the cone is the vector of
//! multipliers `λ` (stationarity reads `d − Aᵀz = 0`, so `x − y = Aᵀλ`); the slack `s` is
//! `A x − b`.
//!
//! Why `d` and not `x`: written in `x` the cost is `½‖x‖² − yᵀx`, whose value is dominated by
//! `‖y‖²` when the configuration lives far from the origin (crowds sit at coordinates ~10²).
//! Clarabel's relative duality-gap rule then stops while the point is still ~1e-4 off; in `d`
//! the cost is the squared step itself and the same tolerances give ~1e-7, at the same
//! number of iterations (measured; see `shared/CRATES.md`).
//!
//! # Shortcuts
//!
//! No solver is built when the problem has no rows or when `y` already satisfies every row to
//! within [`ClarabelSettings::tol_feas`] (absolute): the answer is then `x = y`, `λ = 0`
//! ([`Projection::identity`], status [`SolveStatus::Trivial`]), which is exact when `y` is
//! feasible and otherwise meets the KKT conditions to within `tol_feas` (only the primal
//! residual is non-zero). Calling the solver there would do worse: at a `y` on the boundary
//! every tight row is *weakly* active (`λᵢ = 0` and `(Ay − b)ᵢ = 0`), strict complementarity
//! fails, and the interior-point iterate converges only like the square root of the duality
//! gap — projecting an answer again moved it by up to `7e-6` at the default tolerances,
//! where the shortcut returns it unchanged. A row with no non-zero entry and `bᵢ > 0` is
//! reported as [`ProjectionError::Infeasible`] without calling the solver.
//!
//! # Statuses
//!
//! Every [`clarabel::solver::SolverStatus`] is mapped explicitly; see
//! [`ClarabelProjector`]. Clarabel 0.11 has no warm start, so a fresh solver is built for
//! every projection and [`SolveStats::warm_started`] is always `false`.
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

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus,
    SupportedConeT,
};
use serde::{Deserialize, Serialize};
use std::time::Instant;
use sweeping_api::{
    Projection, ProjectionError, ProjectionProblem, Projector, SolveStats, SolveStatus,
};

/// The name this backend reports in statistics and errors.
pub const NAME: &str = "clarabel";

/// Settings of [`ClarabelProjector`]: a plain, serialisable value.
///
/// The defaults ([`ClarabelSettings::default`]) are tight, for cross-validation: the gap and
/// feasibility tolerances are `1e-10`, two orders below Clarabel's own `1e-8`. Measured on
/// 400 random instances of [`sweeping_api::conformance::random_instance`] (up to 61
/// coordinates and 89 rows) against the reference projector:
///
/// | gap and feasibility tolerance | worst KKT residual | worst ‖x − x_ref‖∞ | iterations |
/// |---|---|---|---|
/// | `1e-8` (Clarabel's default) | `5.6e-8` | `5.6e-5` | (baseline) |
/// | `1e-10` (this default) | `5.6e-10` | `3.6e-7` | +11 % |
/// | `1e-11` | `4.3e-11` | `4.0e-8` | +16 %, but `InsufficientProgress` on a jammed crowd |
///
/// The point error is much larger than the KKT residual on instances with weakly active rows
/// (`λᵢ = 0` on a tight row), where an interior-point iterate converges only like the square
/// root of the gap; `1e-10` is the tightest setting that kept every crowd and random instance
/// solvable, and the first to bring the point error below the `1e-6` used to cross-validate
/// backends. With it the backend passes the `sweeping_api` conformance kit at a KKT tolerance
/// of `1e-7` and a point tolerance of `1e-6`. [`ClarabelSettings::loose`] restores Clarabel's
/// own tolerances for speed.
///
/// ```
/// use sweeping_clarabel::ClarabelSettings;
/// let s: ClarabelSettings = serde_json::from_str(r#"{
///     "tol_gap_abs": 1e-9, "tol_gap_rel": 1e-9, "tol_feas": 1e-9,
///     "tol_infeas_abs": 1e-8, "tol_infeas_rel": 1e-8, "max_iter": 100,
///     "time_limit": 0.5, "accept_almost_solved": true, "verbose": false,
///     "presolve": true, "equilibrate": true
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
    /// `5e-5`, feasibility `1e-4`): `true` returns the answer with
    /// [`SolveStatus::SolvedReducedAccuracy`], `false` returns
    /// [`ProjectionError::NotConverged`]. Default `false`: a reference backend must not pass
    /// off a `1e-4` answer as a solution; a simulation that prefers to go on may set it.
    pub accept_almost_solved: bool,
    /// Let Clarabel print its iteration log to standard output. Default `false` (Clarabel's
    /// own default is `true`).
    pub verbose: bool,
    /// Clarabel's presolve, which drops rows with `|bᵢ| ≥ 1e20` (none in a finite problem).
    /// Default `true` (Clarabel's).
    pub presolve: bool,
    /// Clarabel's Ruiz equilibration of the data. Default `true` (Clarabel's).
    pub equilibrate: bool,
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
        }
    }
}

impl ClarabelSettings {
    /// Clarabel's own stopping tolerances (`1e-8` for gaps and feasibility), quiet, and
    /// accepting `AlmostSolved`: for production runs where speed matters more than the last
    /// digits. About 10 % fewer iterations than the default; KKT residuals stay near `1e-7`,
    /// but on instances with weakly active rows the point may be off by up to ~`1e-4`.
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
    /// data and the sum over rows in the gap; it is what the conformance kit measured, with
    /// margin.
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
/// | `AlmostSolved` | `Ok`, [`SolveStatus::SolvedReducedAccuracy`] if [`ClarabelSettings::accept_almost_solved`], else [`ProjectionError::NotConverged`] |
/// | `PrimalInfeasible`, `AlmostPrimalInfeasible` | [`ProjectionError::Infeasible`] |
/// | `DualInfeasible`, `AlmostDualInfeasible` | [`ProjectionError::Backend`]: the cost `½‖d‖²` is bounded below, so a dual-infeasibility certificate can only be a numerical failure |
/// | `MaxIterations`, `MaxTime`, `InsufficientProgress` | [`ProjectionError::NotConverged`] (after Clarabel found the iterate short even of its reduced accuracy) |
/// | `NumericalError` | [`ProjectionError::Backend`] |
/// | `CallbackTerminated`, `Unsolved` | [`ProjectionError::Backend`]: no callback is installed and the solver has run, so neither should occur |
///
/// A rejected set-up (`DefaultSolver::new` returns a `Result`) or an answer with a non-finite
/// entry is a [`ProjectionError::Backend`] too.
///
/// # Multipliers
///
/// The multipliers are Clarabel's `z`, which an interior-point method keeps inside the cone
/// (`z > 0`). Should undoing the equilibration leave a coordinate negative by less than
/// [`ClarabelSettings::kkt_tolerance`], it is clamped to `0`; a more negative one is reported
/// as [`ProjectionError::Backend`].
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

fn status_name(status: SolverStatus) -> String {
    format!("{status:?}")
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
        let settings = self
            .settings
            .to_clarabel()
            .map_err(Self::backend_error)?;
        if problem.n_rows() == 0 || problem.max_violation(problem.y()) <= self.settings.tol_feas {
            return Ok(Projection::identity(problem, NAME));
        }
        let (m, n) = (problem.n_rows(), problem.dim());
        let (g, nonzero_row) = negated_csc(problem);
        if let Some(r) = (0..m).find(|&r| !nonzero_row[r] && problem.b()[r] > 0.0) {
            return Err(ProjectionError::Infeasible {
                backend: NAME.to_string(),
                detail: format!(
                    "row {r} has no non-zero entry and b[{r}] = {} > 0",
                    problem.b()[r]
                ),
            });
        }
        // h = A y − b, the (negated) violation of each row at y.
        let mut h = vec![0.0; m];
        problem.a().mul_vec(problem.y(), &mut h);
        for (hi, bi) in h.iter_mut().zip(problem.b()) {
            *hi -= bi;
        }
        let p = CscMatrix::identity(n);
        let q = vec![0.0; n];
        let cones = [SupportedConeT::NonnegativeConeT(m)];
        let mut solver = DefaultSolver::new(&p, &q, &g, &h, &cones, settings)
            .map_err(|e| Self::backend_error(format!("set-up failed: {e}")))?;
        let setup_seconds = setup_start.elapsed().as_secs_f64();

        let solve_start = Instant::now();
        solver.solve();
        let solve_seconds = solve_start.elapsed().as_secs_f64();

        let solution = &solver.solution;
        let iterations = solution.iterations;
        let not_converged = |status: SolverStatus| ProjectionError::NotConverged {
            backend: NAME.to_string(),
            iterations,
            status: status_name(status),
        };
        let status = match solution.status {
            SolverStatus::Solved => SolveStatus::Solved,
            SolverStatus::AlmostSolved => {
                if self.settings.accept_almost_solved {
                    SolveStatus::SolvedReducedAccuracy
                } else {
                    return Err(not_converged(solution.status));
                }
            }
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                return Err(ProjectionError::Infeasible {
                    backend: NAME.to_string(),
                    detail: format!(
                        "{} after {iterations} iterations",
                        status_name(solution.status)
                    ),
                });
            }
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                return Err(Self::backend_error(format!(
                    "status {} after {iterations} iterations: impossible for a projection \
                     (the cost ½‖x − y‖² is bounded below), a numerical failure",
                    status_name(solution.status)
                )));
            }
            SolverStatus::MaxIterations
            | SolverStatus::MaxTime
            | SolverStatus::InsufficientProgress => {
                return Err(not_converged(solution.status));
            }
            SolverStatus::NumericalError => {
                return Err(Self::backend_error(format!(
                    "status NumericalError after {iterations} iterations"
                )));
            }
            // No callback is installed and `solve` has run: neither can happen.
            SolverStatus::CallbackTerminated | SolverStatus::Unsolved => {
                return Err(Self::backend_error(format!(
                    "unexpected status {} after {iterations} iterations",
                    status_name(solution.status)
                )));
            }
        };

        if solution.x.len() != n || solution.z.len() != m {
            return Err(Self::backend_error(format!(
                "answer has {} coordinates and {} multipliers, expected {n} and {m}",
                solution.x.len(),
                solution.z.len()
            )));
        }
        let x: Vec<f64> = problem
            .y()
            .iter()
            .zip(&solution.x)
            .map(|(y, d)| y + d)
            .collect();
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(Self::backend_error(format!(
                "status {} but x[{i}] = {} is not finite",
                status_name(solution.status),
                x[i]
            )));
        }
        let clamp = self.tolerance();
        let mut multipliers = Vec::with_capacity(m);
        for (i, &z) in solution.z.iter().enumerate() {
            if !z.is_finite() || z < -clamp {
                return Err(Self::backend_error(format!(
                    "status {} but multiplier {i} = {z} is not a finite non-negative number",
                    status_name(solution.status)
                )));
            }
            multipliers.push(z.max(0.0));
        }
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
            },
        })
    }
}
