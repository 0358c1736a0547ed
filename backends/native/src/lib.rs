//! The native projection backend of `sweeping`: an active-set method on the dual of the
//! projection, per contact cluster, warm-started across steps, and certified.
//!
//! [`NativeProjector`] solves `min ½‖x − y‖² s.t. A x ≥ b` in four moves.
//!
//! 1. **Blocks.** [`sweeping_api::Blocks`] splits the rows into connected components (rows
//!    sharing an unknown). Unknowns touched by no row keep `x = y`; on a crowd most people
//!    touch nobody and contacts form small clusters, each solved on its own. A block whose
//!    rows all hold at `y` is answered `x = y`, `λ = 0` (exact).
//! 2. **Dual active set.** Each block runs the Lawson–Hanson method on the dual
//!    `min ½‖Aᵀλ‖² − λᵀ(b − Ay)`, `λ ≥ 0` (see [the method](sweeping_clarabel::active_set)); every step solves
//!    the quasi-definite KKT system of the working set (factored with QDLDL, or the previous
//!    factor bordered with the few rows that joined or left) and refines against the
//!    unregularized one, which copes with linearly dependent rows (contact loops). It starts
//!    from the rows active at the previous step, matched by their [`RowKey`]s (rows may
//!    appear, vanish or be reordered) with their previous multipliers; in a block without a
//!    remembered row (or without keys), from the rows violated at `y`.
//!    A working set factored three times means rounding on dependent rows made this
//!    many-rows-at-once variant cycle: the block restarts as Lawson–Hanson proper (empty
//!    support, the steepest violated row joining one at a time), and a second cycle stops it.
//! 3. **Interior-point rescue.** The active-set method pays an iteration per row that joins
//!    or leaves; when a jam forms, or a queue's contact loops make rows join and leave again,
//!    it runs out of [`NativeSettings::max_iterations`]. The block is then solved by a
//!    primal–dual interior-point method of this crate (Mehrotra's predictor–corrector on the
//!    normal equations `(I + AᵀWA) Δd = …`, positive definite whatever the rows, ordered and
//!    analysed once per block), stopped at a relative accuracy of `1e-8`, and finished
//!    exactly by the active-set method from the rows whose multiplier exceeds their slack —
//!    the way Clarabel's answers are polished. Counted in [`SolveStats::rescues`].
//! 4. **Certificate.** The answer is checked by [`ProjectionProblem::kkt_residuals`]: every
//!    residual must be at most [`NativeSettings::kkt_tolerance`] `× scale`, with
//!    `scale = max(1, ‖y‖∞, ‖b‖∞)` (the residuals are absolute and the data of a crowd sit at
//!    coordinates ~10², where rounding alone is ~1e-14 × 10²). A block that fails the check,
//!    or that the rescue does not finish either, or whose factorization fails, is handed
//!    to the fallback backend given to [`NativeProjector::with_fallback`] (the root crate
//!    passes Clarabel), and counted in [`SolveStats::fallbacks`]; without a fallback it is a
//!    [`ProjectionError::NotConverged`]. Infeasibility is reported only with a checked Farkas
//!    certificate ([`ProjectionError::Infeasible`]). This backend never returns an answer that
//!    it has not checked.
//!
//! # One implementation of the method
//!
//! The active-set method is `sweeping_clarabel::active_set`, the code that also polishes
//! Clarabel's interior-point answers: this backend runs it on its own, from the previous
//! step's active rows, block by block; Clarabel runs it from its interior-point guess. Its
//! factorization is QDLDL as Clarabel ships it (`clarabel::qdldl`, AMD ordering), with small
//! well-conditioned supports factored densely; faer's sparse Cholesky was not measured
//! against it. The cross-check `cross-native` still compares two different paths to the
//! answer (a warm active set against an interior point), not one computation with itself.
//!
//! ```
//! use sweeping_api::{ProjectionProblem, Projector, SparseRows};
//! use sweeping_native::NativeProjector;
//!
//! // Two points on a line, 0.1 apart, that must be at least 0.4 apart: x₁ − x₀ ≥ 0.4.
//! let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
//! let p = ProjectionProblem::new(vec![0.0, 0.1], a, vec![0.4]).unwrap();
//! let sol = NativeProjector::default().project(&p).unwrap();
//! assert!((sol.x[0] + 0.15).abs() < 1e-12 && (sol.x[1] - 0.25).abs() < 1e-12);
//! assert_eq!(sol.stats.fallbacks, 0);
//! ```
#![deny(missing_docs)]

use std::collections::HashMap;
use std::time::Instant;
use sweeping_api::{
    Blocks, Projection, ProjectionError, ProjectionProblem, Projector, RowKey, SolveStats,
    SolveStatus,
};
use sweeping_clarabel::active_set::{self, Failure, Start};

mod interior_point;

/// The name this backend reports in statistics and errors.
pub const NAME: &str = "native";

/// Settings of [`NativeProjector`].
#[derive(Debug, Clone, PartialEq)]
pub struct NativeSettings {
    /// Largest KKT residual accepted, relative to `max(1, ‖y‖∞, ‖b‖∞)`. Default `1e-10`.
    pub kkt_tolerance: f64,
    /// Most active-set iterations per block from the warm start before the block goes to the
    /// interior-point rescue (or, with that off, to the fallback); `0` means
    /// [`DEFAULT_ITERATIONS`] with the rescue or a fallback, and `40 + rows of the block / 2`
    /// with neither (then the method must converge on its own). Default `0`.
    ///
    /// The active-set method wins when the active set changes by a few rows per step (a crowd
    /// walking, a queue at a door) and loses to an interior point when it changes by hundreds
    /// (a jam forming): each change costs it an iteration (a solve through a bordered factor,
    /// a fresh factorization after 24 changes). The cap bounds what it spends before the
    /// interior point takes over (`sweep bench --start jammed` in the README measures both).
    pub max_iterations: u32,
    /// Start from the previous step's active rows, matched by row keys. Default `true`.
    pub warm_start: bool,
    /// When the active-set method does not converge within its cap (or cycles), solve the
    /// block by the interior-point method of this crate and finish from its guess, before
    /// any fallback. Default `true`.
    pub interior_point: bool,
}

impl Default for NativeSettings {
    fn default() -> Self {
        Self {
            kkt_tolerance: 1e-10,
            max_iterations: 0,
            warm_start: true,
            interior_point: true,
        }
    }
}

/// The cap on iterations per block when [`NativeSettings::max_iterations`] is `0`.
pub const DEFAULT_ITERATIONS: u32 = 16;

/// Relative accuracies (duality measure and residuals, against `max(1, ‖b − Ay‖∞)`) at which
/// the interior-point rescue hands over to the active-set method: the first, and the second
/// when the finish from the first runs out of iterations.
const INTERIOR_POINT_TOLERANCES: [f64; 2] = [1e-8, 1e-11];
/// Most interior-point iterations of a rescue (it needs 8–17 on crowds).
const INTERIOR_POINT_ITERATIONS: u32 = 60;
/// Most active-set iterations when finishing from an interior-point guess. On a jam the
/// guess holds rows of contact loops that are nearly but not quite tight, which leave one per
/// iteration; an iteration there costs a solve through a bordered factor, far less than
/// handing the block on. (From a cold start, after an interior point that diverged, `40 +
/// rows / 2` when larger.)
const POLISH_ITERATIONS: u32 = 300;

/// The native backend; see the [crate documentation](crate).
pub struct NativeProjector {
    /// The settings used for every solve.
    pub settings: NativeSettings,
    fallback: Option<Box<dyn Projector>>,
    /// Multipliers of the rows active at the previous solve, by key.
    previous: HashMap<RowKey, f64>,
}

impl Default for NativeProjector {
    fn default() -> Self {
        Self::new(NativeSettings::default())
    }
}

impl std::fmt::Debug for NativeProjector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NativeProjector")
            .field("settings", &self.settings)
            .field("fallback", &self.fallback.as_ref().map(|p| p.name()))
            .field("remembered_rows", &self.previous.len())
            .finish()
    }
}

/// One row's starting multiplier when it enters the support without a remembered one: the
/// multiplier of its own half-space projection, `max(0, rᵢ)/‖aᵢ‖²`.
fn own_multiplier(problem: &ProjectionProblem, i: usize, r: f64) -> f64 {
    let norm2: f64 = problem.a().row(i).map(|(_, v)| v * v).sum();
    if norm2 > 0.0 {
        (r.max(0.0) / norm2).max(f64::MIN_POSITIVE)
    } else {
        f64::MIN_POSITIVE
    }
}

impl NativeProjector {
    /// A projector without fallback: a block it cannot certify is an error.
    pub fn new(settings: NativeSettings) -> Self {
        Self {
            settings,
            fallback: None,
            previous: HashMap::new(),
        }
    }

    /// A projector that hands the blocks it cannot certify to `fallback`.
    pub fn with_fallback(settings: NativeSettings, fallback: Box<dyn Projector>) -> Self {
        Self {
            fallback: Some(fallback),
            ..Self::new(settings)
        }
    }

    /// Solves one block: a certified answer, or the reason it failed with the iterations
    /// spent.
    fn solve_block(
        &self,
        block: &ProjectionProblem,
        tol: f64,
    ) -> Result<Projection, (Failure, u32)> {
        let m = block.n_rows();
        let mut r = vec![0.0; m];
        block.a().mul_vec(block.y(), &mut r);
        r.iter_mut()
            .zip(block.b())
            .for_each(|(ri, bi)| *ri = bi - *ri);
        if r.iter().all(|&ri| ri <= 0.0) {
            return Ok(Projection::identity(block, NAME));
        }
        let remembered: Vec<Option<f64>> = match (self.settings.warm_start, block.row_keys()) {
            (true, Some(keys)) => keys.iter().map(|k| self.previous.get(k).copied()).collect(),
            _ => vec![None; m],
        };
        let join: Vec<f64> = (0..m)
            .map(|i| remembered[i].unwrap_or_else(|| own_multiplier(block, i, r[i])))
            .collect();
        // With remembered rows, start from them alone: the rows violated at y join after the
        // first solve if the point still violates them. Also starting from every violated
        // row cost 1.8 × the iterations on the paper's evacuation (25,777 against 14,266
        // over its first 12 s), most of them dropping rows one at a time.
        let any_remembered = remembered.iter().any(Option::is_some);
        let support: Vec<usize> = (0..m)
            .filter(|&i| remembered[i].is_some() || (!any_remembered && r[i] > 0.0))
            .collect();
        let warm = support.iter().any(|&i| remembered[i].is_some());
        let lambda = support.iter().map(|&i| join[i]).collect();
        let rescue = self.settings.interior_point;
        let cap = match self.settings.max_iterations {
            0 if self.fallback.is_some() || rescue => DEFAULT_ITERATIONS,
            0 => 40 + u32::try_from(m / 2).unwrap_or(u32::MAX / 4),
            c => c,
        };
        let start = Start {
            support,
            lambda,
            join,
        };
        let (outcome, rescued) = match active_set::solve(block, start, cap) {
            Ok(outcome) => (outcome, false),
            Err(Failure::Cap(_) | Failure::Cycling(_)) if rescue => {
                // The cold multipliers, for a rescue that must start over.
                let cold = (0..m).map(|i| own_multiplier(block, i, r[i])).collect();
                let outcome = rescue_by_interior_point(block, &r, cold)
                    .map_err(|(failure, spent)| (failure, cap.saturating_add(spent)))?;
                (outcome, true)
            }
            Err(failure) => return Err((failure, cap)),
        };
        let iterations = if rescued {
            outcome.iterations.saturating_add(cap)
        } else {
            outcome.iterations
        };
        let kkt = block.kkt_residuals(&outcome.x, &outcome.lambda).max();
        if kkt.is_nan() || kkt > tol {
            return Err((Failure::Numerical("KKT check failed"), iterations));
        }
        Ok(Projection {
            x: outcome.x,
            multipliers: outcome.lambda,
            stats: SolveStats {
                backend: NAME.to_string(),
                status: SolveStatus::Solved,
                iterations,
                solve_seconds: 0.0,
                setup_seconds: 0.0,
                warm_started: warm,
                fallbacks: 0,
                rescues: u32::from(rescued),
            },
        })
    }
}

/// The block solved by the interior-point method of [`interior_point`] to a relative
/// accuracy of [`INTERIOR_POINT_TOLERANCES`]`[0]`, then finished exactly by the active-set
/// method from the rows whose multiplier exceeds their slack (as Clarabel's answers are
/// polished); when that finish runs out of [`POLISH_ITERATIONS`], again from a tighter
/// interior point, whose guess holds fewer rows that are nearly but not quite tight. When the
/// interior point does not converge (its iterates diverge on an empty set), the active-set
/// method starts from the rows violated at `y` instead, with `cold` multipliers, and
/// certifies what it finds (a Farkas certificate on an empty set). On failure, the reason and
/// the iterations spent (both methods).
fn rescue_by_interior_point(
    block: &ProjectionProblem,
    r: &[f64],
    cold: Vec<f64>,
) -> Result<active_set::Outcome, (Failure, u32)> {
    let scale = r.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
    let mut spent = 0u32;
    let mut last = Failure::Cap(POLISH_ITERATIONS);
    for tolerance in INTERIOR_POINT_TOLERANCES {
        let iterate =
            interior_point::solve(block.a(), r, tolerance * scale, INTERIOR_POINT_ITERATIONS);
        spent = spent.saturating_add(iterate.as_ref().map_or(0, |it| it.iterations));
        let Some(it) = iterate.filter(|it| it.converged) else {
            let support: Vec<usize> = (0..block.n_rows()).filter(|&i| r[i] > 0.0).collect();
            let lambda = support.iter().map(|&i| cold[i]).collect();
            let start = Start {
                support,
                lambda,
                join: cold,
            };
            let rows = u32::try_from(block.n_rows() / 2).unwrap_or(u32::MAX / 4);
            let cap = POLISH_ITERATIONS.max(40 + rows);
            return finish(block, start, cap, spent);
        };
        let support: Vec<usize> = (0..block.n_rows())
            .filter(|&i| it.lambda[i] > it.slack[i])
            .collect();
        let lambda = support.iter().map(|&i| it.lambda[i]).collect();
        let start = Start {
            support,
            lambda,
            join: it.lambda,
        };
        match finish(block, start, POLISH_ITERATIONS, spent) {
            Ok(outcome) => return Ok(outcome),
            Err((failure @ (Failure::Cap(_) | Failure::Cycling(_)), total)) => {
                spent = total;
                last = failure;
            }
            Err(other) => return Err(other),
        }
    }
    Err((last, spent))
}

/// The active-set method from `start`, its iterations added to the `spent` ones.
fn finish(
    block: &ProjectionProblem,
    start: Start,
    cap: u32,
    spent: u32,
) -> Result<active_set::Outcome, (Failure, u32)> {
    active_set::solve(block, start, cap)
        .map(|mut outcome| {
            outcome.iterations = outcome.iterations.saturating_add(spent);
            outcome
        })
        .map_err(|failure| (failure, cap.saturating_add(spent)))
}

impl Projector for NativeProjector {
    fn name(&self) -> &str {
        NAME
    }

    /// `kkt_tolerance`, or the fallback's tolerance when larger (its answers are accepted).
    fn tolerance(&self) -> f64 {
        let own = self.settings.kkt_tolerance;
        self.fallback
            .as_ref()
            .map_or(own, |f| own.max(f.tolerance()))
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let setup_start = Instant::now();
        let scale = problem
            .y()
            .iter()
            .chain(problem.b())
            .fold(1.0, |acc: f64, v| acc.max(v.abs()));
        let tol = self.settings.kkt_tolerance * scale;
        // Nothing violated at y (most steps of a sparse crowd): x = y, λ = 0 is exact, and the
        // split is skipped. An empty row with bᵢ > 0 is violated too, so it is still caught.
        let mut ay = vec![0.0; problem.n_rows()];
        problem.a().mul_vec(problem.y(), &mut ay);
        if ay.iter().zip(problem.b()).all(|(ayi, bi)| ayi >= bi) {
            if problem.row_keys().is_some() {
                self.previous.clear();
            }
            return Ok(Projection::identity(problem, NAME));
        }
        let blocks = Blocks::split(problem);
        if let Some(r) = blocks.infeasible_empty_row(problem) {
            return Err(ProjectionError::Infeasible {
                backend: NAME.to_string(),
                detail: format!(
                    "row {r} has no non-zero entry and b[{r}] = {} > 0",
                    problem.b()[r]
                ),
            });
        }
        let setup_seconds = setup_start.elapsed().as_secs_f64();
        let solve_start = Instant::now();
        let mut answers = Vec::with_capacity(blocks.blocks().len());
        for (index, block) in blocks.blocks().iter().enumerate() {
            let answer = match self.solve_block(&block.problem, tol) {
                Ok(answer) => answer,
                Err((Failure::Infeasible { rows }, _)) => {
                    let global: Vec<usize> = rows.iter().map(|&t| block.rows[t]).collect();
                    return Err(ProjectionError::Infeasible {
                        backend: NAME.to_string(),
                        detail: format!(
                            "Farkas certificate on rows {global:?} (block {index}): a \
                             non-negative combination of them reads 0 ≥ positive"
                        ),
                    });
                }
                Err((failure, iterations)) => match self.fallback.as_mut() {
                    Some(fallback) => {
                        let mut answer = fallback.project(&block.problem)?;
                        answer.stats.fallbacks = answer.stats.fallbacks.saturating_add(1);
                        answer
                    }
                    None => {
                        return Err(ProjectionError::NotConverged {
                            backend: NAME.to_string(),
                            iterations,
                            status: format!(
                                "{failure:?} on block {index} ({} rows, {} unknowns), no \
                                 fallback",
                                block.rows.len(),
                                block.cols.len()
                            ),
                        })
                    }
                },
            };
            answers.push(answer);
        }
        let mut answer = blocks.stitch(problem, answers, NAME);
        // The stitched answer is checked once more as a whole (blocks are independent, so this
        // only guards the stitching itself); fallback answers are held to their backend's own
        // tolerance.
        let whole = problem.kkt_residuals(&answer.x, &answer.multipliers).max();
        let allowed = if answer.stats.fallbacks > 0 {
            tol.max(self.tolerance())
        } else {
            tol
        };
        if whole.is_nan() || whole > allowed {
            return Err(ProjectionError::Backend {
                backend: NAME.to_string(),
                message: format!("stitched answer has KKT residual {whole:.3e} > {allowed:.1e}"),
            });
        }
        if let Some(keys) = problem.row_keys() {
            self.previous.clear();
            for (k, &l) in keys.iter().zip(&answer.multipliers) {
                if l > 0.0 {
                    self.previous.insert(*k, l);
                }
            }
        }
        answer.stats.setup_seconds = setup_seconds;
        answer.stats.solve_seconds = solve_start.elapsed().as_secs_f64();
        Ok(answer)
    }
}
