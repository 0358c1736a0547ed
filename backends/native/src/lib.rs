//! The native projection backend of `sweeping`: an active-set method on the dual of the
//! projection, per contact cluster, warm-started across steps, and certified.
//!
//! [`NativeProjector`] solves `min ½‖x − y‖² s.t. A x ≥ b` in four moves.
//!
//! 1. **Blocks.** [`sweeping_api::Blocks`] splits the rows into connected components (rows
//!    sharing an unknown). Unknowns touched by no row keep `x = y`; on a crowd most people
//!    touch nobody and contacts form small clusters, each solved on its own. A block whose
//!    rows all hold at `y` is answered `x = y`, `λ = 0` (exact). When two or more blocks are
//!    large (an evacuation through several doors: a queue at each), each is solved on a
//!    thread of its own ([`NativeSettings::parallel_rows`]), with the same answers as on one.
//! 2. **Dual active set.** Each block runs the Lawson–Hanson method on the dual
//!    `min ½‖Aᵀλ‖² − λᵀ(b − Ay)`, `λ ≥ 0` (see [the method](sweeping_clarabel::active_set)); every step solves
//!    the quasi-definite KKT system of the working set (factored as QDLDL factors, ordered as the
//!    last factorizations of the same rows and people were, see [`Orderings`], or the
//!    previous factor bordered with the few rows that joined or left) and refines against the
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
//!    analysed once per block) to a relative accuracy of `1e-12`, first on the rows that could
//!    plausibly be tight (those whose slack at `y` is at most half the largest violation, a
//!    third of a jam's rows, which makes its factorizations many times cheaper). Its
//!    iterate is the answer if it passes the KKT check, with a hundredth of the tolerance and
//!    against every row of the block, and every row keeping a multiplier is tight to that;
//!    otherwise the active-set method finishes exactly from
//!    the rows whose multiplier exceeds their slack (as Clarabel's answers are polished), less
//!    those that Tapia's indicators over the interior point's last iteration find inactive,
//!    the most violated row joining alone and rows leaving one at a time (on a jam that
//!    guess already holds more rows than unknowns, and rows joining together add dependent
//!    ones, which then leave one per iteration), and if that runs out too (or the first interior point stalls short of a guess), the interior
//!    point runs again on every row. A block rescued three
//!    solves in a row skips the active-set attempt (see [`NativeSettings::max_iterations`]),
//!    except at powers of two, which find out when the jam is over. Counted in
//!    [`SolveStats::rescues`]. With two threads or more ([`NativeSettings::threads`]), the
//!    rescue's first interior point runs on a thread of its own while the active set tries
//!    a large block (from its third iteration, [`NativeSettings::speculate_after`]), and is
//!    used if the attempt fails ([`NativeSettings::speculate_rows`]; the same answers).
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
//! factorization is QDLDL's arithmetic as Clarabel ships it (run by `sweeping_clarabel`, to
//! the bit, AMD-ordered or ordered from memory; the interior-point rescue factors and
//! refactors with the same code), with small well-conditioned supports factored densely.
//! faer's sparse Cholesky was measured against it on the interior point's normal matrices
//! only, and was no faster there (`docs/performance.md`); the active set's systems are
//! indefinite. The cross-check `cross-native` still compares two different paths to the
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

use std::time::Instant;
use sweeping_api::{
    Blocks, FastMap, Projection, ProjectionError, ProjectionProblem, Projector, RowKey, SolveStats,
    SolveStatus, SparseRows,
};
use sweeping_clarabel::active_set::{self, Failure, Orderings, Start};

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
    /// A block whose rows were rescued at the last three or more solves in a row is rescued
    /// without the attempt, except when that count is a power of two.
    pub max_iterations: u32,
    /// Start from the previous step's active rows, matched by row keys. Default `true`.
    pub warm_start: bool,
    /// When the active-set method does not converge within its cap (or cycles), solve the
    /// block by the interior-point method of this crate and finish from its guess, before
    /// any fallback. Default `true`.
    pub interior_point: bool,
    /// Blocks of at least this many rows are solved on threads of their own (scoped threads,
    /// as many as [`threads`](NativeSettings::threads) allows) when a projection has two or
    /// more of them, as an evacuation through several doors has (a queue at each); the
    /// other blocks share one more. `0` never does. Default [`PARALLEL_ROWS`].
    ///
    /// The answers do not depend on the number of threads: each block's factorizations are
    /// ordered from the memory as it stood before the projection (see [`Orderings::fork`]).
    pub parallel_rows: usize,
    /// While the active set tries a block of at least this many rows, the interior point
    /// its rescue would run first runs on a thread of its own, and the rescue starts from its
    /// iterate if the attempt fails (the same computation on the same data, so the same
    /// iterate; an attempt that converges stops it at its next iteration). The answers are
    /// the same either way;
    /// the time is shorter on a machine with a core to spare, and the CPU time longer (the
    /// interior point also runs for the attempts that converge, until they do). `0` never
    /// does. Needs two [`threads`](NativeSettings::threads) or more. Default
    /// [`SPECULATE_ROWS`].
    pub speculate_rows: usize,
    /// The speculation of [`speculate_rows`](NativeSettings::speculate_rows) starts once the
    /// attempt has run this many iterations without converging (`0`: with the attempt). An
    /// attempt that ends in a rescue runs all of its
    /// [`max_iterations`](NativeSettings::max_iterations), so a short delay leaves the
    /// interior point most of the attempt to run in, while the attempts that converge within
    /// it, many of them, start none. Default [`SPECULATE_AFTER`].
    pub speculate_after: u32,
    /// Most threads a projection runs on, the caller's included: blocks on threads of their
    /// own ([`parallel_rows`](NativeSettings::parallel_rows)) and the speculation
    /// ([`speculate_rows`](NativeSettings::speculate_rows)) share them. `1` keeps a
    /// projection on its caller's thread (for runs side by side, one per core); `0` means
    /// [`std::thread::available_parallelism`], which counts the cores the process may run on
    /// (`taskset -c 0` makes it 1). The answers do not depend on it. Default `0`.
    pub threads: usize,
}

/// The default [`NativeSettings::speculate_rows`] on two cores or more: the blocks whose
/// attempts end in rescues are door queues of a hundred people or more, and speculating on
/// smaller blocks too burned more CPU time for no time saved (`docs/performance.md`).
pub const SPECULATE_ROWS: usize = 150;

/// The default [`NativeSettings::speculate_after`]: on the paper's evacuation, starting
/// after two iterations instead of with the attempt took a tenth less CPU time for the same
/// time; after four, a sixth less for a little more time (`docs/performance.md`).
pub const SPECULATE_AFTER: u32 = 2;

/// The default [`NativeSettings::parallel_rows`]: blocks that take milliseconds (a queue of
/// a hundred people or more), against tens of microseconds to start a thread and copy the
/// ordering memory.
pub const PARALLEL_ROWS: usize = 400;

impl Default for NativeSettings {
    fn default() -> Self {
        Self {
            kkt_tolerance: 1e-10,
            max_iterations: 0,
            warm_start: true,
            interior_point: true,
            parallel_rows: PARALLEL_ROWS,
            speculate_rows: SPECULATE_ROWS,
            speculate_after: SPECULATE_AFTER,
            threads: 0,
        }
    }
}

impl NativeSettings {
    /// The threads a projection may run on: [`threads`](NativeSettings::threads), or the
    /// cores available when it is `0`.
    fn thread_budget(&self) -> usize {
        match self.threads {
            0 => std::thread::available_parallelism().map_or(1, usize::from),
            n => n,
        }
    }
}

/// The cap on iterations per block when [`NativeSettings::max_iterations`] is `0`.
pub const DEFAULT_ITERATIONS: u32 = 16;

/// Relative accuracy (duality measure and residuals, against `max(1, ‖b − Ay‖∞)`) to which
/// the interior-point rescue runs. There its iterate often passes the KKT check as it is (see
/// [`certified_iterate`]), and when it does not, the active-set finish from it is shorter:
/// stopping at `1e-8` and always finishing made jammed steps several times slower (the
/// finish spends an iteration on each nearly tight row of a contact loop that leaves).
const INTERIOR_POINT_TOLERANCE: f64 = 1e-12;
/// An interior point that stopped short of [`INTERIOR_POINT_TOLERANCE`] (its iteration cap,
/// rounding) but reached this relative accuracy is still a good guess to finish from;
/// beyond it, its iterates diverged (an empty set) or stalled (a sliver of a set).
const INTERIOR_POINT_GUESS: f64 = 1e-8;
/// Most interior-point iterations of a rescue (it needs 8–25 on crowds).
const INTERIOR_POINT_ITERATIONS: u32 = 60;
/// The first rescue leaves out of the interior point the rows whose slack at `y`, as a
/// distance (`−rᵢ/‖aᵢ‖`), exceeds this fraction of the largest violation at `y` (`rⱼ/‖aⱼ‖`):
/// rows that only a push of half the largest one could make tight. On a jam that keeps about
/// a third of the rows, and the normal matrix's factorization, which dominates the interior
/// point, costs several times less (its fill falls faster than its rows). Nothing rests on
/// it: the answer is checked against every row, and a row it missed is added by the
/// active-set finish, or by a second interior point on every row.
const SCREEN_FRACTION: f64 = 0.5;
/// An interior point's iterate is accepted as the answer only if its KKT residuals are within
/// this fraction of the certificate's tolerance (so `1e-12` relative by default): an answer
/// the check would only just accept leaves people overlapping by ~1e-9, where the exact
/// active-set answer leaves ~1e-12, and the finish is cheap against that. Multipliers below
/// their slack and below this fraction of the tolerance are set to zero first.
const CLEAN_FRACTION: f64 = 1e-2;
/// A row whose multiplier exceeds its slack still starts an interior point's finish outside
/// the support when Tapia's indicators say it is inactive and its slack exceeds this many times
/// the interior point's tolerance (see [`tapia_says_inactive`]).
const TAPIA_SLACK: f64 = 100.0;
/// Fewest active-set iterations when finishing from an interior-point guess; `40 + rows / 2`
/// (see [`cap_on_its_own`]) when larger, as from a cold start after an interior point that
/// diverged. On a jam the guess holds rows of contact loops that are nearly but not quite
/// tight, which leave one per iteration (1700–1900 rows on 1600 unknowns at the door queues
/// of the 2000-person evacuation took 280–380 iterations); an iteration there costs a solve
/// through a bordered factor, far less than handing the block on.
const POLISH_ITERATIONS: u32 = 300;

/// The native backend; see the [crate documentation](crate).
pub struct NativeProjector {
    /// The settings used for every solve.
    pub settings: NativeSettings,
    fallback: Option<Box<dyn Projector>>,
    /// Multipliers of the rows active at the previous solve, by key.
    previous: FastMap<RowKey, f64>,
    /// For the rows active at the previous solve in a block that the interior point rescued,
    /// how many solves in a row their block has been rescued (see [`goes_straight_to_rescue`]).
    rescued: FastMap<RowKey, u32>,
    /// The orderings of the last sparse factorizations, reused by the next ones.
    orderings: Orderings,
    /// The thread that speculates on rescues, started at the first block that could use it
    /// ([`NativeSettings::speculate_rows`]); `None` before, or when it could not start.
    speculator: Option<Speculator>,
    /// Whether starting the speculator was decided (so that it is decided once).
    speculator_decided: bool,
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
            .field("orderings_by_amd_and_memory", &self.orderings.stats())
            .finish()
    }
}

/// `‖aᵢ‖²`.
fn row_norm_squared(problem: &ProjectionProblem, i: usize) -> f64 {
    problem.a().row(i).map(|(_, v)| v * v).sum()
}

/// One row's starting multiplier when it enters the support without a remembered one: the
/// multiplier of its own half-space projection, `max(0, rᵢ)/‖aᵢ‖²`.
fn own_multiplier(problem: &ProjectionProblem, i: usize, r: f64) -> f64 {
    let norm2 = row_norm_squared(problem, i);
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
            previous: FastMap::default(),
            rescued: FastMap::default(),
            orderings: Orderings::default(),
            speculator: None,
            speculator_decided: false,
        }
    }

    /// A projector that hands the blocks it cannot certify to `fallback`.
    pub fn with_fallback(settings: NativeSettings, fallback: Box<dyn Projector>) -> Self {
        Self {
            fallback: Some(fallback),
            ..Self::new(settings)
        }
    }

    /// The orderings of recent sparse factorizations, with how many were made by AMD and
    /// how many reused from memory ([`Orderings::stats`]).
    pub fn orderings(&self) -> &Orderings {
        &self.orderings
    }
}

/// What solving a block reads besides the ordering memory, shared by the threads that solve
/// blocks at once.
struct BlockContext<'a> {
    settings: &'a NativeSettings,
    /// Multipliers of the rows active at the previous solve, by key.
    previous: &'a FastMap<RowKey, f64>,
    /// Whether a fallback backend takes the blocks this one cannot certify.
    has_fallback: bool,
    /// The certificate's tolerance (absolute).
    tol: f64,
}

/// A block's answer, or the reason it failed with the iterations spent.
type BlockResult = Result<Projection, (Failure, u32)>;

impl BlockContext<'_> {
    /// Solves one block: a certified answer, or the reason it failed with the iterations
    /// spent.
    ///
    /// `straight`: skip the active-set attempt and rescue at once.
    /// `unknowns[j]`: the index of the block's unknown `j` in the whole problem.
    fn solve_block(
        &self,
        orderings: &mut Orderings,
        block: &ProjectionProblem,
        unknowns: &[usize],
        straight: bool,
        speculator: Option<&mut Speculator>,
    ) -> BlockResult {
        let tol = self.tol;
        let m = block.n_rows();
        let r = block.shortfall(block.y());
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
            0 if self.has_fallback || rescue => DEFAULT_ITERATIONS,
            0 => cap_on_its_own(m),
            c => c,
        };
        let start = Start {
            support,
            lambda,
            join,
            join_at_most: None,
        };
        let (first, cap, speculated) = if rescue && straight {
            (Err(Failure::Cap(0)), 0, None)
        } else {
            let mut speculator = speculator.filter(|_| rescue && m >= self.settings.speculate_rows);
            let mut started = None;
            let after = self.settings.speculate_after;
            let outcome = {
                let mut speculate = |iteration: u32| {
                    // `iteration` counts from 1; `after + 1` would overflow at `u32::MAX`.
                    if iteration - 1 == after {
                        if let Some(s) = speculator.as_deref_mut() {
                            started = s.speculate(block, &r);
                        }
                    }
                };
                active_set::solve_remembering_watched(
                    block,
                    start,
                    cap,
                    orderings,
                    unknowns,
                    &mut speculate,
                )
            };
            let speculated = match (&outcome, started, speculator) {
                (Err(Failure::Cap(_) | Failure::Cycling(_)), Some(number), Some(s)) => {
                    s.take(number)
                }
                (_, Some(number), Some(s)) => {
                    s.cancel(number);
                    None
                }
                _ => None,
            };
            (outcome, cap, speculated)
        };
        let (outcome, rescued) = match first {
            Ok(outcome) => (outcome, false),
            Err(Failure::Cap(_) | Failure::Cycling(_)) if rescue => {
                // The cold multipliers, for a rescue that must start over.
                let cold = (0..m).map(|i| own_multiplier(block, i, r[i])).collect();
                let memory = (&mut *orderings, unknowns);
                let outcome = rescue_by_interior_point(block, &r, cold, tol, memory, speculated)
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
                unfinished: u32::from(outcome.unfinished.is_some()),
                unfinished_off: outcome.unfinished.unwrap_or(0.0),
            },
        })
    }
}

/// Whether a block holding rows whose block was rescued at the last `streak` solves in a row
/// is rescued at once, without the active-set attempt: from the third solve in a row on, except
/// when `streak` is a power of two.
///
/// On a jam the active set changes by hundreds of rows step after step, and the attempt
/// (up to [`DEFAULT_ITERATIONS`] iterations, each a fresh factorization) cost as much as the
/// rescue itself at N = 5000; on a queue at a door rescues come one to a few in a row. The
/// attempts at powers of two find out, at a cost logarithmic in the length of the jam, when
/// the active set is back to changing slowly.
fn goes_straight_to_rescue(streak: u32) -> bool {
    streak > 2 && !streak.is_power_of_two()
}

/// The block solved by the interior-point method of [`interior_point`] to a relative
/// accuracy of [`INTERIOR_POINT_TOLERANCE`], first on the rows that [`SCREEN_FRACTION`]
/// keeps, then (when that answer fails and rows were left out) on every row.
///
/// Each interior point's iterate is tried as the answer ([`certified_iterate`]); when it fails
/// the KKT check at `tol`, the active-set method finishes from the rows whose multiplier
/// exceeds their slack (as Clarabel's answers are polished) and that Tapia's indicators do not
/// find inactive ([`finish_start`]), the most violated row joining
/// alone, up to [`POLISH_ITERATIONS`] or `40 + rows / 2` iterations.
/// When an interior point does not even reach [`INTERIOR_POINT_GUESS`] (its iterates diverge
/// on an empty set, or stall on a sliver of one), the one on every row is tried next; when
/// that one does not either, the active-set method starts from the rows violated at `y`
/// instead, with `cold` multipliers, and certifies what it finds (a Farkas certificate on an
/// empty set). On failure, the reason and the iterations spent (both methods).
///
/// `memory`: the orderings the active-set method reuses, and the names of the block's
/// unknowns (see [`active_set::solve_remembering`]).
fn rescue_by_interior_point(
    block: &ProjectionProblem,
    r: &[f64],
    cold: Vec<f64>,
    tol: f64,
    memory: (&mut Orderings, &[usize]),
    speculated: Option<Option<interior_point::Iterate>>,
) -> Result<active_set::Outcome, (Failure, u32)> {
    let (orderings, unknowns) = memory;
    let m = block.n_rows();
    let scale = shortfall_scale(r);
    // The interior point's tolerance, which Tapia's indicators in the finish's start are
    // measured against too.
    let tolerance = INTERIOR_POINT_TOLERANCE * scale;
    let mut spent = 0u32;
    let mut last = Failure::Cap(POLISH_ITERATIONS);
    let mut speculated = speculated;
    for rows in rescue_attempts(screened_rows(block, r), m) {
        // The first row set's interior point, when another thread ran it during the attempt
        // (see [`Speculator`]): the same computation, so the same iterate.
        let iterate = match speculated.take() {
            Some(iterate) => iterate,
            None => solve_rows(block, r, &rows, tolerance, &|| false),
        };
        spent = spent.saturating_add(iterate.as_ref().map_or(0, |it| it.iterations));
        let Some(it) = iterate.filter(|it| is_a_guess(it.accuracy, scale)) else {
            // The screened rows' set holds the block's, so an interior point that diverges
            // on them means the block's set is empty, too, but on a sliver of a feasible set
            // (a jam with more tight rows than unknowns) the interior point also stalls short
            // of a guess. Every row is tried before the active set starts cold: on the 2000-
            // person evacuation that halved the blocks handed to the fallback.
            if rows.len() < m {
                continue;
            }
            let (start, cap) = cold_start(r, cold);
            return finish(block, start, cap, spent, (orderings, unknowns));
        };
        if it.converged {
            if let Some(outcome) = certified_iterate(block, &it, tol, spent) {
                return Ok(outcome);
            }
        }
        let start = finish_start(&it, &cold, tolerance);
        match finish(
            block,
            start,
            finish_cap(m),
            spent,
            (&mut *orderings, unknowns),
        ) {
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

/// The scale a rescue measures its interior point against on a block whose shortfall at `y`
/// is `r`: `max(1, ‖r‖∞)`.
fn shortfall_scale(r: &[f64]) -> f64 {
    r.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()))
}

/// The interior point a rescue runs first on a block whose shortfall at `y` is `r` (on the
/// screened rows, see [`rescue_attempts`]), as [`solve_rows`] gives it, or `None` when it
/// stopped because `stopped()` held.
fn first_rescue_iterate(
    block: &ProjectionProblem,
    r: &[f64],
    stopped: &dyn Fn() -> bool,
) -> Option<interior_point::Iterate> {
    let rows = rescue_attempts(screened_rows(block, r), block.n_rows()).swap_remove(0);
    let tolerance = INTERIOR_POINT_TOLERANCE * shortfall_scale(r);
    solve_rows(block, r, &rows, tolerance, stopped)
}

/// A rescue's first interior point run on a thread of its own while the active set tries
/// the block, so that, when the attempt fails, the rescue starts from its iterate instead of
/// computing it then. It is the same computation on the same data, so the same iterate:
/// answers do not depend on whether it ran. An attempt that ends in a rescue runs its whole
/// cap of iterations, which takes about as long as the interior point, so on a core that
/// would otherwise idle the rescue's interior point costs next to nothing. An attempt that
/// converges cancels its speculation, which stops at its next iteration without the attempt
/// waiting for it; the attempts that converge within [`NativeSettings::speculate_after`]
/// iterations, many of them, start none.
struct Speculator {
    jobs: Option<std::sync::mpsc::Sender<Speculation>>,
    results: std::sync::mpsc::Receiver<(u64, Option<interior_point::Iterate>)>,
    /// Speculations up to this number are no longer wanted.
    cancelled: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// The number of the last speculation started.
    last: u64,
    /// How many speculations' iterates a rescue took (for tests: the rescue computes the
    /// same iterate itself when none is taken, so answers cannot tell).
    taken: u64,
    worker: Option<std::thread::JoinHandle<()>>,
}

/// A block and its shortfall at `y`, for [`Speculator`]'s thread.
struct Speculation {
    number: u64,
    block: ProjectionProblem,
    r: Vec<f64>,
}

impl Speculator {
    /// The thread and its channels; `None` when the thread cannot be started.
    fn start() -> Option<Self> {
        use std::sync::atomic::{AtomicU64, Ordering};
        let (jobs, incoming) = std::sync::mpsc::channel::<Speculation>();
        let (outgoing, results) = std::sync::mpsc::channel();
        let cancelled = std::sync::Arc::new(AtomicU64::new(0));
        let flag = std::sync::Arc::clone(&cancelled);
        let worker = std::thread::Builder::new()
            .name("sweeping-native-rescue".to_string())
            .spawn(move || {
                for job in incoming {
                    let stopped = || flag.load(Ordering::Acquire) >= job.number;
                    let iterate = if stopped() {
                        None
                    } else {
                        first_rescue_iterate(&job.block, &job.r, &stopped)
                    };
                    if outgoing.send((job.number, iterate)).is_err() {
                        break;
                    }
                }
            })
            .ok()?;
        Some(Self {
            jobs: Some(jobs),
            results,
            cancelled,
            last: 0,
            taken: 0,
            worker: Some(worker),
        })
    }

    /// Starts the rescue's first interior point on `block`; its number, or `None` when the
    /// thread is gone.
    fn speculate(&mut self, block: &ProjectionProblem, r: &[f64]) -> Option<u64> {
        // Answers of earlier speculations, all cancelled or taken by now.
        while self.results.try_recv().is_ok() {}
        self.last += 1;
        let job = Speculation {
            number: self.last,
            block: block.clone(),
            r: r.to_vec(),
        };
        self.jobs.as_ref()?.send(job).ok()?;
        Some(self.last)
    }

    /// The speculation `number` is not wanted: its thread stops it at its next iteration.
    fn cancel(&self, number: u64) {
        self.cancelled
            .store(number, std::sync::atomic::Ordering::Release);
    }

    /// The iterate of speculation `number`, waiting for it; `None` when the thread is gone
    /// (the rescue then runs the interior point itself).
    fn take(&mut self, number: u64) -> Option<Option<interior_point::Iterate>> {
        loop {
            match self.results.recv() {
                Ok((got, iterate)) if got == number => {
                    self.taken += u64::from(iterate.is_some());
                    return Some(iterate);
                }
                Ok(_) => {}
                Err(_) => return None,
            }
        }
    }
}

impl Drop for Speculator {
    fn drop(&mut self) {
        self.cancel(self.last);
        // Closing the channel ends the thread's loop.
        self.jobs = None;
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
    }
}

/// The row sets a rescue's interior point runs on, in turn: the `screened` rows, then every
/// one of the block's `m` rows; only the latter when the screen kept them all.
fn rescue_attempts(screened: Vec<usize>, m: usize) -> Vec<Vec<usize>> {
    if screened.len() < m {
        vec![screened, (0..m).collect()]
    } else {
        vec![(0..m).collect()]
    }
}

/// Whether an interior point that stopped at `accuracy` (on data of `scale`) got close enough
/// to the answer for the active-set method to finish from it: [`INTERIOR_POINT_GUESS`]
/// relative. Worse means its iterates diverged (the set is empty) or stalled.
fn is_a_guess(accuracy: f64, scale: f64) -> bool {
    accuracy <= INTERIOR_POINT_GUESS * scale
}

/// The active-set method's start when the interior point diverged: the rows violated at `y`
/// (`rᵢ > 0`) with their `cold` multipliers, and a cap that lets Lawson–Hanson take about
/// every other row of the block in turn before it must conclude (a Farkas certificate).
fn cold_start(r: &[f64], cold: Vec<f64>) -> (Start, u32) {
    let support: Vec<usize> = (0..r.len()).filter(|&i| r[i] > 0.0).collect();
    let lambda = support.iter().map(|&i| cold[i]).collect();
    let start = Start {
        support,
        lambda,
        join: cold,
        join_at_most: None,
    };
    (start, finish_cap(r.len()))
}

/// Iterations the active-set method gets when it finishes a rescue of a block of `m` rows:
/// [`POLISH_ITERATIONS`], or [`cap_on_its_own`] when that is more.
fn finish_cap(m: usize) -> u32 {
    POLISH_ITERATIONS.max(cap_on_its_own(m))
}

/// Iterations the active-set method gets on a block of `m` rows when nothing takes over after
/// it: `40 + m/2`, room for Lawson–Hanson to take about every other row in turn.
fn cap_on_its_own(m: usize) -> u32 {
    u32::try_from(m / 2).unwrap_or(u32::MAX).saturating_add(40)
}

/// The active-set method's start from an interior point's iterate `it` (as Clarabel's answers
/// are polished): the rows whose multiplier exceeds their slack, with those multipliers, but
/// for those that Tapia's indicators find inactive ([`tapia_says_inactive`], the iterate run
/// to `tolerance`); a row that joins later starts from its iterate's multiplier when positive,
/// from `cold` otherwise, and only the most violated row joins at an iteration (rows then also
/// leave one at a time: see [`Start::join_at_most`]).
///
/// On a jam the guess already holds more rows than unknowns. When every violated row joined
/// at once, the door queues of the 2000-person evacuation took in 100–200 rows at a time,
/// whose dependence on the support cost some hundred iterations of leaving one row each
/// before the next such join: four of their blocks ran out of iterations and went to the
/// fallback, where one row at a time finished them in 190–380 iterations.
fn finish_start(it: &interior_point::Iterate, cold: &[f64], tolerance: f64) -> Start {
    let support: Vec<usize> = (0..it.lambda.len())
        .filter(|&i| it.lambda[i] > it.slack[i] && !tapia_says_inactive(it, i, tolerance))
        .collect();
    let lambda = support.iter().map(|&i| it.lambda[i]).collect();
    let join = it
        .lambda
        .iter()
        .zip(cold)
        .map(|(&l, &c)| if l > 0.0 { l } else { c })
        .collect();
    Start {
        support,
        lambda,
        join,
        join_at_most: Some(1),
    }
}

/// Whether Tapia's indicators (see [`interior_point::Iterate::previous_lambda`]) say that row
/// `i` of the iterate `it`, run to `tolerance`, is inactive although its multiplier exceeds
/// its slack: over the last iteration its multiplier shrank by a larger factor than its slack,
/// and the slack is more than [`TAPIA_SLACK`] times the tolerance.
///
/// At the tolerance, `λᵢsᵢ ≈ μ ≈ 1e-12` relative, so a row with a gap of `10⁻⁹`–`10⁻⁷` at the
/// answer still has `λᵢ ≈ μ/sᵢ > sᵢ`: on the door queues of the 10 000-person hall about a
/// hundred such rows per block of 3000 started the finish, which then left them one
/// iteration each. A tight row's slack, the other way round, shrinks with `μ` while its
/// multiplier stays. Slacks at the tolerance are left to the test `λᵢ > sᵢ`: there rows of a
/// contact loop trade multiplier among themselves from one iteration to the next.
fn tapia_says_inactive(it: &interior_point::Iterate, i: usize, tolerance: f64) -> bool {
    let lambda_ratio = it.lambda[i] / it.previous_lambda[i];
    let slack_ratio = it.slack[i] / it.previous_slack[i];
    lambda_ratio < slack_ratio && it.slack[i] > TAPIA_SLACK * tolerance
}

/// The rows of `block` that the first interior point of a rescue keeps (see
/// [`SCREEN_FRACTION`]): every row whose slack at `y`, as a distance, is at most that fraction
/// of the largest violation. Violated rows are always kept.
fn screened_rows(block: &ProjectionProblem, r: &[f64]) -> Vec<usize> {
    let distance: Vec<f64> = (0..block.n_rows())
        .map(|i| {
            let norm = row_norm_squared(block, i).sqrt();
            if norm > 0.0 {
                r[i] / norm
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let largest = distance
        .iter()
        .filter(|d| d.is_finite())
        .fold(0.0, |acc: f64, &d| acc.max(d));
    (0..block.n_rows())
        .filter(|&i| distance[i] >= -SCREEN_FRACTION * largest)
        .collect()
}

/// The interior point on `rows` of `block` alone, its iterate spread back over every row
/// (a row left out: multiplier 0, slack ∞).
fn solve_rows(
    block: &ProjectionProblem,
    r: &[f64],
    rows: &[usize],
    tolerance: f64,
    stopped: &dyn Fn() -> bool,
) -> Option<interior_point::Iterate> {
    let m = block.n_rows();
    let solve = |a: &SparseRows, r: &[f64]| {
        interior_point::solve_unless(a, r, tolerance, INTERIOR_POINT_ITERATIONS, stopped)
    };
    if rows.len() == m {
        return solve(block.a(), r);
    }
    let mut a = SparseRows::new(block.dim());
    for &i in rows {
        a.push_row(block.a().row(i));
    }
    let r_kept: Vec<f64> = rows.iter().map(|&i| r[i]).collect();
    let it = solve(&a, &r_kept)?;
    let (mut lambda, mut slack) = (vec![0.0; m], vec![f64::INFINITY; m]);
    let (mut previous_lambda, mut previous_slack) = (vec![0.0; m], vec![f64::INFINITY; m]);
    for (t, &i) in rows.iter().enumerate() {
        lambda[i] = it.lambda[t];
        slack[i] = it.slack[t];
        previous_lambda[i] = it.previous_lambda[t];
        previous_slack[i] = it.previous_slack[t];
    }
    Some(interior_point::Iterate {
        lambda,
        slack,
        previous_lambda,
        previous_slack,
        ..it
    })
}

/// A converged interior point taken as the answer, if it passes the KKT check at
/// [`CLEAN_FRACTION`]` × tol`.
///
/// The multipliers of rows that are not tight, about `μ/sᵢ`, are below their slack; those
/// also below [`CLEAN_FRACTION`]` × tol` are set to zero, so that the answer's support is the
/// rows in contact and the next step's warm start is not handed every candidate row. Rows
/// below their slack with larger multipliers are kept: on a degenerate row (tight with a
/// zero multiplier) both approach zero like `√μ`, and dropping them would move `x` by about
/// that much. `x` is then `y + Aᵀλ`, so stationarity holds to rounding; feasibility and
/// complementarity are what the check decides.
///
/// Complementarity is checked as tightness: every row keeping a multiplier must hold with
/// equality to [`CLEAN_FRACTION`]` × tol`, whatever the size of its multiplier. The product
/// `λᵢ(Ax − b)ᵢ` alone does not bound the error in `x`: a degenerate row's `√μ` multiplier
/// with a slack of `√μ` passes it, and such an iterate was 9.4e-8 from the projection on the
/// paper's evacuation with every KKT residual below 1e-12 (the duality gap, a sum of such
/// products, only bounds `‖x − x*‖²`). With every kept row tight, `x` is the projection onto
/// the rows moved by at most that much.
fn certified_iterate(
    block: &ProjectionProblem,
    it: &interior_point::Iterate,
    tol: f64,
    spent: u32,
) -> Option<active_set::Outcome> {
    let lambda = cleaned_multipliers(it, tol);
    let mut x = vec![0.0; block.dim()];
    block.a().mul_transpose_vec(&lambda, &mut x);
    x.iter_mut().zip(block.y()).for_each(|(xi, yi)| *xi += yi);
    let mut ax = vec![0.0; block.n_rows()];
    block.a().mul_vec(&x, &mut ax);
    let loose = lambda
        .iter()
        .zip(ax.iter().zip(block.b()))
        .any(|(&l, (axi, bi))| {
            let slack = (axi - bi).abs();
            // A NaN slack is loose too.
            l > 0.0 && (slack.is_nan() || slack > CLEAN_FRACTION * tol)
        });
    if loose {
        return None;
    }
    let kkt = block.kkt_residuals(&x, &lambda).max();
    (kkt <= CLEAN_FRACTION * tol).then_some(active_set::Outcome {
        x,
        lambda,
        iterations: spent,
        unfinished: None,
    })
}

/// The multipliers of `it` with those of rows that are not tight cleared: below their slack
/// and below [`CLEAN_FRACTION`]` × tol` (see [`certified_iterate`]).
fn cleaned_multipliers(it: &interior_point::Iterate, tol: f64) -> Vec<f64> {
    it.lambda
        .iter()
        .zip(&it.slack)
        .map(|(&l, &s)| {
            if l > s || l > CLEAN_FRACTION * tol {
                l
            } else {
                0.0
            }
        })
        .collect()
}

/// The active-set method from `start` (ordering from `memory`, see
/// [`active_set::solve_remembering`]), its iterations added to the `spent` ones.
fn finish(
    block: &ProjectionProblem,
    start: Start,
    cap: u32,
    spent: u32,
    memory: (&mut Orderings, &[usize]),
) -> Result<active_set::Outcome, (Failure, u32)> {
    active_set::solve_remembering(block, start, cap, memory.0, memory.1)
        .map(|mut outcome| {
            outcome.iterations = outcome.iterations.saturating_add(spent);
            outcome
        })
        .map_err(|failure| (failure, cap.saturating_add(spent)))
}

/// Every block solved, in order: on this thread, or, when two or more blocks have at least
/// [`NativeSettings::parallel_rows`] rows, each such block on a thread of its own and the
/// others together (see [`parallel_groups`]). Each group orders its factorizations from a
/// [fork](Orderings::fork) of `orderings`, joined back in the order of the groups, so the
/// answers do not depend on how many threads ran them.
fn solve_blocks(
    context: &BlockContext<'_>,
    orderings: &mut Orderings,
    blocks: &Blocks,
    streaks: &[u32],
    speculator: Option<&mut Speculator>,
) -> Vec<BlockResult> {
    let all = blocks.blocks();
    let solve = |orderings: &mut Orderings, index: usize, speculator: Option<&mut Speculator>| {
        let block = &all[index];
        let straight = goes_straight_to_rescue(streaks[index]);
        context.solve_block(orderings, &block.problem, &block.cols, straight, speculator)
    };
    let sizes: Vec<usize> = all.iter().map(|block| block.rows.len()).collect();
    let groups = parallel_groups(&sizes, context.settings.parallel_rows);
    if groups.len() < 2 {
        // One block after another: a second core, if any, speculates on their rescues.
        let mut speculator = speculator;
        return (0..all.len())
            .map(|index| solve(orderings, index, speculator.as_deref_mut()))
            .collect();
    }
    let workers = workers_for(&groups, &sizes, context.settings.thread_budget());
    // One fork per group, all from the memory as it stood: the answers are those of any
    // number of threads.
    let solve_groups = |mine: &[usize]| -> Vec<(usize, Vec<BlockResult>, Orderings)> {
        mine.iter()
            .map(|&g| {
                let mut fork = orderings.fork();
                let results = groups[g]
                    .iter()
                    .map(|&b| solve(&mut fork, b, None))
                    .collect();
                (g, results, fork)
            })
            .collect()
    };
    let mut done: Vec<(usize, Vec<BlockResult>, Orderings)> = std::thread::scope(|scope| {
        let handles: Vec<_> = workers[1..]
            .iter()
            .map(|mine| scope.spawn(|| solve_groups(mine)))
            .collect();
        let mut done = solve_groups(&workers[0]);
        for handle in handles {
            match handle.join() {
                Ok(theirs) => done.extend(theirs),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        done
    });
    done.sort_by_key(|(g, _, _)| *g);
    let mut results: Vec<Option<BlockResult>> = (0..all.len()).map(|_| None).collect();
    for (g, group_results, fork) in done {
        orderings.join(fork);
        for (&b, result) in groups[g].iter().zip(group_results) {
            results[b] = Some(result);
        }
    }
    results
        .into_iter()
        .map(|result| result.expect("every block is in exactly one group"))
        .collect()
}

/// The blocks (by index, of `rows` rows each) grouped for threads: every block of at least
/// `parallel_rows` rows on its own, in order, then the rest together. A single group when
/// fewer than two blocks are that large (or `parallel_rows` is `0`): nothing to share out.
fn parallel_groups(rows: &[usize], parallel_rows: usize) -> Vec<Vec<usize>> {
    let large: Vec<usize> = (0..rows.len())
        .filter(|&b| parallel_rows > 0 && rows[b] >= parallel_rows)
        .collect();
    if large.len() < 2 {
        return vec![(0..rows.len()).collect()];
    }
    let rest: Vec<usize> = (0..rows.len())
        .filter(|&b| rows[b] < parallel_rows)
        .collect();
    let mut groups: Vec<Vec<usize>> = large.into_iter().map(|b| vec![b]).collect();
    if !rest.is_empty() {
        groups.push(rest);
    }
    groups
}

/// The groups shared out among at most `threads` workers (at least one), largest first to
/// the least loaded (by rows), each worker's groups in order.
fn workers_for(groups: &[Vec<usize>], rows: &[usize], threads: usize) -> Vec<Vec<usize>> {
    let load = |g: usize| groups[g].iter().map(|&b| rows[b]).sum::<usize>();
    let mut by_load: Vec<usize> = (0..groups.len()).collect();
    by_load.sort_by_key(|&g| std::cmp::Reverse(load(g)));
    let count = threads.clamp(1, groups.len());
    let mut workers: Vec<(usize, Vec<usize>)> = vec![(0, Vec::new()); count];
    for g in by_load {
        let lightest = (0..count)
            .min_by_key(|&w| workers[w].0)
            .expect("at least one worker");
        workers[lightest].0 += load(g);
        workers[lightest].1.push(g);
    }
    workers
        .into_iter()
        .map(|(_, mut mine)| {
            mine.sort_unstable();
            mine
        })
        .collect()
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
                self.rescued.clear();
            }
            return Ok(Projection::identity(problem, NAME));
        }
        // Blocks that y satisfies are x = y, λ = 0, exactly what `solve_block` returns for
        // them: they are left out of the split rather than built and then skipped.
        let blocks = Blocks::split_violated(problem);
        if let Some(r) = blocks.infeasible_empty_row(problem) {
            return Err(ProjectionError::Infeasible {
                backend: NAME.to_string(),
                detail: format!(
                    "row {r} has no non-zero entry and b[{r}] = {} > 0",
                    problem.b()[r]
                ),
            });
        }
        self.orderings.forget_older();
        let setup_seconds = setup_start.elapsed().as_secs_f64();
        let solve_start = Instant::now();
        let streaks: Vec<u32> = blocks
            .blocks()
            .iter()
            .map(|block| {
                block.problem.row_keys().map_or(0, |keys| {
                    keys.iter()
                        .filter_map(|k| self.rescued.get(k))
                        .fold(0, |acc, &s| acc.max(s))
                })
            })
            .collect();
        let context = BlockContext {
            settings: &self.settings,
            previous: &self.previous,
            has_fallback: self.fallback.is_some(),
            tol,
        };
        // Decided once, at the first projection with a block that could use it.
        let wants_speculator = !self.speculator_decided
            && self.settings.interior_point
            && self.settings.speculate_rows > 0
            && blocks
                .blocks()
                .iter()
                .any(|block| block.rows.len() >= self.settings.speculate_rows);
        if wants_speculator {
            // Decided here for good, threads or not: with `threads = 0` the budget asks the
            // system for the cores (affinity, cgroup quota), not something to redo at every
            // projection of a run pinned to one core.
            self.speculator_decided = true;
            if self.settings.thread_budget() >= 2 {
                self.speculator = Speculator::start();
            }
        }
        let results = solve_blocks(
            &context,
            &mut self.orderings,
            &blocks,
            &streaks,
            self.speculator.as_mut(),
        );
        let mut answers = Vec::with_capacity(blocks.blocks().len());
        let mut rescued_blocks = Vec::with_capacity(blocks.blocks().len());
        for (index, ((block, result), streak)) in blocks
            .blocks()
            .iter()
            .zip(results)
            .zip(&streaks)
            .enumerate()
        {
            let answer = match result {
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
            rescued_blocks.push((answer.stats.rescues > 0).then_some(streak + 1));
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
            self.rescued.clear();
            for (block, streak) in blocks.blocks().iter().zip(&rescued_blocks) {
                if let Some(streak) = *streak {
                    self.rescued.extend(
                        block
                            .rows
                            .iter()
                            .filter(|&&i| answer.multipliers[i] > 0.0)
                            .map(|&i| (keys[i], streak)),
                    );
                }
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Names for the unknowns of a problem of dimension `n` solved on its own.
    fn names(n: usize) -> Vec<usize> {
        (0..n).collect()
    }

    /// [`rescue_by_interior_point`] on `p` solved on its own, with a fresh ordering memory.
    fn rescue_alone(
        p: &ProjectionProblem,
        r: &[f64],
        cold: Vec<f64>,
        tol: f64,
    ) -> Result<active_set::Outcome, (Failure, u32)> {
        let memory = (&mut Orderings::default(), &names(p.dim())[..]);
        rescue_by_interior_point(p, r, cold, tol, memory, None)
    }

    /// The bits of an iterate's vectors, and its counts.
    fn iterate_bits(it: &interior_point::Iterate) -> (Vec<u64>, u32, bool, u64) {
        let vectors = [
            &it.lambda,
            &it.slack,
            &it.previous_lambda,
            &it.previous_slack,
        ];
        let bits = vectors
            .iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .collect();
        (bits, it.iterations, it.converged, it.accuracy.to_bits())
    }

    #[test]
    fn a_speculated_iterate_is_the_rescues_own_and_a_cancelled_one_is_passed_over() {
        let mut speculator = Speculator::start().expect("a thread starts");
        let blocks: Vec<ProjectionProblem> = (0..3)
            .map(|seed| sweeping_api::conformance::random_instance(seed, 20, 40))
            .collect();
        let shortfalls: Vec<Vec<f64>> = blocks.iter().map(|b| b.shortfall(b.y())).collect();
        let own = |k: usize| {
            first_rescue_iterate(&blocks[k], &shortfalls[k], &|| false).expect("an iterate")
        };
        let first = speculator.speculate(&blocks[0], &shortfalls[0]).unwrap();
        let got = speculator.take(first).unwrap().expect("an iterate");
        assert_eq!(iterate_bits(&got), iterate_bits(&own(0)));
        // The second is cancelled before anything takes it; the third is still the third's.
        let second = speculator.speculate(&blocks[1], &shortfalls[1]).unwrap();
        speculator.cancel(second);
        let third = speculator.speculate(&blocks[2], &shortfalls[2]).unwrap();
        assert!(third > second && second > first);
        let got = speculator.take(third).unwrap().expect("an iterate");
        assert_eq!(iterate_bits(&got), iterate_bits(&own(2)));
        // A speculation cancelled before its thread starts it runs no iteration: its answer
        // is none, where the same block's own answer is an iterate.
        speculator.cancel(speculator.last + 1);
        let cancelled = speculator.speculate(&blocks[1], &shortfalls[1]).unwrap();
        assert!(speculator.take(cancelled).unwrap().is_none());
        assert!(first_rescue_iterate(&blocks[1], &shortfalls[1], &|| true).is_none());
        // A long speculation cancelled while the next one waits behind it: its answer (none,
        // stopped at its next iteration) reaches the channel first, and is passed over.
        let large = sweeping_api::conformance::random_instance(7, 300, 600);
        let large_shortfall = large.shortfall(large.y());
        let long = speculator.speculate(&large, &large_shortfall).unwrap();
        let next = speculator.speculate(&blocks[0], &shortfalls[0]).unwrap();
        speculator.cancel(long);
        let got = speculator.take(next).unwrap().expect("an iterate");
        assert_eq!(iterate_bits(&got), iterate_bits(&own(0)));
        // Dropping it ends its thread (a hang here would time the test out).
        drop(speculator);
    }

    /// The speculations started by `projector`, and the rescues of its answers, over 30
    /// random instances whose answers must match `plain`'s bit for bit.
    fn speculations_matching(
        plain: &mut NativeProjector,
        projector: &mut NativeProjector,
    ) -> (u64, u32) {
        let mut rescues = 0;
        for seed in 0..30u64 {
            let p =
                sweeping_api::conformance::random_instance(seed % 10, 12 + (seed as usize % 7), 30);
            let (a, b) = (plain.project(&p).unwrap(), projector.project(&p).unwrap());
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a.x), bits(&b.x), "seed {seed}");
            assert_eq!(bits(&a.multipliers), bits(&b.multipliers), "seed {seed}");
            assert_eq!(a.stats.iterations, b.stats.iterations, "seed {seed}");
            assert_eq!(a.stats.rescues, b.stats.rescues, "seed {seed}");
            rescues += b.stats.rescues;
        }
        (projector.speculator.as_ref().map_or(0, |s| s.last), rescues)
    }

    #[test]
    fn speculating_on_rescues_changes_no_answer() {
        // Two threads asked for, so that it speculates on a machine with one core too.
        let settings = |max_iterations, speculate_rows, speculate_after| NativeSettings {
            max_iterations,
            speculate_rows,
            speculate_after,
            threads: 2,
            ..NativeSettings::default()
        };
        let projector = |max_iterations, speculate_rows, speculate_after| {
            NativeProjector::new(settings(max_iterations, speculate_rows, speculate_after))
        };
        // One active-set iteration before the rescue, so that nearly every block is rescued,
        // from warm starts as well as cold ones; the speculation starts with the attempt.
        let mut plain = projector(1, 0, 0);
        let mut speculating = projector(1, 1, 0);
        let (started, rescues) = speculations_matching(&mut plain, &mut speculating);
        assert!(plain.speculator.is_none());
        // The rescues started from the speculated iterates.
        let taken = speculating.speculator.as_ref().map_or(0, |s| s.taken);
        assert!(
            taken >= 1 && taken <= u64::from(rescues),
            "{taken} taken, {rescues} rescues"
        );
        assert!(
            rescues >= 10,
            "only {rescues} rescues: the test would test little"
        );
        assert!(
            started >= u64::from(rescues),
            "{started} speculations, {rescues} rescues"
        );
        // One thread: nothing to speculate on.
        let mut plain = projector(1, 0, 0);
        let mut one_thread = NativeProjector::new(NativeSettings {
            threads: 1,
            ..settings(1, 1, 0)
        });
        speculations_matching(&mut plain, &mut one_thread);
        assert!(one_thread.speculator.is_none());
        // Four iterations before the rescue, the speculation started after the second: the
        // same answers, and a speculation for every rescue. Started after the fourth, never.
        let mut plain = projector(4, 0, 0);
        let mut delayed = projector(4, 1, 2);
        let (started, rescues) = speculations_matching(&mut plain, &mut delayed);
        assert!(rescues >= 1, "no rescue: the test would test little");
        assert!(
            started >= u64::from(rescues),
            "{started} speculations, {rescues} rescues"
        );
        let mut plain = projector(4, 0, 0);
        let mut never = projector(4, 1, 4);
        assert_eq!(speculations_matching(&mut plain, &mut never), (0, rescues));
        // Nor after u32::MAX iterations (once `after + 1`, which overflowed).
        let mut plain = projector(4, 0, 0);
        let mut never = projector(4, 1, u32::MAX);
        assert_eq!(speculations_matching(&mut plain, &mut never), (0, rescues));
        // An attempt that converges at its first iteration: a speculation started with it
        // (then cancelled), none when it would start after the second.
        let single = ProjectionProblem::new(
            vec![0.0, 0.0],
            SparseRows::from_rows(2, &[vec![(0, 1.0)]]),
            vec![1.0],
        )
        .unwrap();
        for (after, expected) in [(0, 1), (2, 0)] {
            let mut projector = projector(4, 1, after);
            let answer = projector.project(&single).unwrap();
            assert_eq!((answer.x[0], answer.stats.iterations), (1.0, 1));
            let speculator = projector.speculator.as_ref().unwrap();
            assert_eq!(speculator.last, expected);
            // A converged attempt cancels what it started.
            let cancelled = speculator
                .cancelled
                .load(std::sync::atomic::Ordering::Acquire);
            assert_eq!(cancelled, expected);
        }
    }

    #[test]
    fn a_block_whose_rows_are_remembered_by_their_keys_starts_warm() {
        let p = sweeping_api::conformance::random_instance(3, 14, 30);
        let keys = (0..p.n_rows() as u64)
            .map(|member| sweeping_api::RowKey { family: 0, member })
            .collect();
        let p = p.with_row_keys(keys).unwrap();
        let mut projector = NativeProjector::new(NativeSettings::default());
        let first = projector.project(&p).unwrap();
        let again = projector.project(&p).unwrap();
        assert!(!first.stats.warm_started);
        assert!(again.stats.warm_started, "{:?}", again.stats);
        // From the last answer's active rows, the first solve is the answer.
        assert!(again.stats.iterations <= 1, "{:?}", again.stats);
        let gap = first.x.iter().zip(&again.x).map(|(a, b)| (a - b).abs());
        assert!(gap.fold(0.0, f64::max) < 1e-12);
    }

    #[test]
    fn an_answer_that_fails_the_kkt_check_is_never_returned_as_certified() {
        // At tolerance 0, an exact answer passes: x = (1, 0), λ = 1 for x₀ ≥ 1 from y = 0.
        let exact = ProjectionProblem::new(
            vec![0.0, 0.0],
            SparseRows::from_rows(2, &[vec![(0, 1.0)]]),
            vec![1.0],
        )
        .unwrap();
        let exacting = NativeSettings {
            kkt_tolerance: 0.0,
            ..NativeSettings::default()
        };
        let answer = NativeProjector::new(exacting.clone())
            .project(&exact)
            .unwrap();
        assert_eq!(answer.x, vec![1.0, 0.0]);
        assert_eq!(
            exact.kkt_residuals(&answer.x, &answer.multipliers).max(),
            0.0
        );
        // Rounding leaves residuals on a random instance: no answer without a fallback, and
        // the fallback's with one.
        let p = sweeping_api::conformance::random_instance(5, 16, 30);
        let loose = NativeProjector::new(NativeSettings::default())
            .project(&p)
            .unwrap();
        assert!(p.kkt_residuals(&loose.x, &loose.multipliers).max() > 0.0);
        assert!(NativeProjector::new(exacting.clone()).project(&p).is_err());
        let reference = sweeping_api::conformance::ReferenceProjector {
            tolerance: 1e-6,
            ..Default::default()
        };
        let mut with_fallback = NativeProjector::with_fallback(exacting, Box::new(reference));
        let answer = with_fallback.project(&p).unwrap();
        assert!(answer.stats.fallbacks >= 1, "{:?}", answer.stats);
    }

    #[test]
    fn blocks_smaller_than_speculate_rows_start_no_speculation() {
        let settings = NativeSettings {
            speculate_rows: 3,
            speculate_after: 0,
            threads: 2,
            ..NativeSettings::default()
        };
        let mut projector = NativeProjector::new(settings);
        // A block of 30 rows starts the thread (and a speculation).
        let large = sweeping_api::conformance::random_instance(2, 14, 30);
        projector.project(&large).unwrap();
        let started = projector.speculator.as_ref().map(|s| s.last);
        assert!(started.is_some_and(|n| n >= 1), "{started:?}");
        // A block of one row starts none.
        let single = ProjectionProblem::new(
            vec![0.0, 0.0],
            SparseRows::from_rows(2, &[vec![(0, 1.0)]]),
            vec![1.0],
        )
        .unwrap();
        projector.project(&single).unwrap();
        assert_eq!(projector.speculator.as_ref().map(|s| s.last), started);
    }

    /// A chain `x_{j+1} − x_j ≥ 1` of 41 unknowns at spacing 1 but for the first pair (0.5):
    /// only the first row is violated at `y`, and each solve pushes the next one out of
    /// place, so rows join one per iteration (41 iterations from a cold start).
    fn cascade() -> ProjectionProblem {
        let m = 40;
        let rows: Vec<Vec<(usize, f64)>> = (0..m).map(|j| vec![(j, -1.0), (j + 1, 1.0)]).collect();
        let y = (0..=m)
            .map(|j| if j == 0 { 0.5 } else { j as f64 })
            .collect();
        ProjectionProblem::new(y, SparseRows::from_rows(m + 1, &rows), vec![1.0; m]).unwrap()
    }

    #[test]
    fn alone_the_active_set_gets_forty_plus_half_the_rows_and_with_a_rescue_sixteen() {
        let p = cascade();
        // No rescue, no fallback: 40 + 40/2 iterations, enough for the cascade, which starts
        // from the violated row alone (rows tight at `y` do not start in the support).
        let alone = NativeProjector::new(NativeSettings {
            interior_point: false,
            ..NativeSettings::default()
        })
        .project(&p)
        .unwrap();
        assert!(
            alone.stats.iterations > DEFAULT_ITERATIONS,
            "{:?}",
            alone.stats
        );
        assert_eq!(alone.stats.rescues, 0);
        let mut ax = vec![0.0; p.n_rows()];
        p.a().mul_vec(&alone.x, &mut ax);
        assert!(ax.iter().all(|&gap| gap >= 1.0 - 1e-12), "{ax:?}");
        // With the rescue: the active set stops at 16 iterations and the interior point
        // takes the block.
        let rescued = NativeProjector::default().project(&p).unwrap();
        assert_eq!(rescued.stats.rescues, 1, "{:?}", rescued.stats);
        assert!(sweeping_api::conformance::max_gap(&rescued.x, &alone.x) < 1e-9);
    }

    #[test]
    fn blocks_go_to_threads_only_when_two_or_more_are_large() {
        // One large block: nothing to share out.
        assert_eq!(parallel_groups(&[3, 500, 2], 400), vec![vec![0, 1, 2]]);
        // Two large blocks, each on its own, the rest together, in order.
        assert_eq!(
            parallel_groups(&[3, 500, 2, 400, 399], 400),
            vec![vec![1], vec![3], vec![0, 2, 4]]
        );
        // Only large blocks: no group of the rest.
        assert_eq!(parallel_groups(&[400, 401], 400), vec![vec![0], vec![1]]);
        // `0` never shares out.
        assert_eq!(parallel_groups(&[500, 500], 0), vec![vec![0, 1]]);
    }

    #[test]
    fn groups_go_largest_first_to_the_least_loaded_worker() {
        let rows = [10, 900, 500, 450, 5];
        let groups = vec![vec![1], vec![2], vec![3], vec![0, 4]];
        // Two workers: 900 on one, 500 then 450 on the other (950), and the 15 of the rest
        // back on the first.
        assert_eq!(workers_for(&groups, &rows, 2), vec![vec![0, 3], vec![1, 2]]);
        // As many workers as groups: one each; more threads than groups do not add workers.
        assert_eq!(
            workers_for(&groups, &rows, 8),
            vec![vec![0], vec![1], vec![2], vec![3]]
        );
        // One thread (or none reported): every group on it, in order.
        assert_eq!(workers_for(&groups, &rows, 1), vec![vec![0, 1, 2, 3]]);
        assert_eq!(workers_for(&groups, &rows, 0), vec![vec![0, 1, 2, 3]]);
    }

    #[test]
    fn a_block_goes_straight_to_the_rescue_from_the_third_rescue_in_a_row_but_at_powers_of_two() {
        let straight: Vec<u32> = (0..=17).filter(|&s| goes_straight_to_rescue(s)).collect();
        assert_eq!(straight, vec![3, 5, 6, 7, 9, 10, 11, 12, 13, 14, 15, 17]);
    }

    /// Rows `x₁ − x₀ ≥ 1` (violated by 1 at `y`), `x₂ − x₁ ≥ 1` (slack 0.8), `x₃ − x₂ ≥ 1`
    /// (slack 0.2), an empty row, and `x₀ ≥ −5` (slack 5).
    fn chain() -> (ProjectionProblem, Vec<f64>) {
        let a = SparseRows::from_rows(
            4,
            &[
                vec![(0, -1.0), (1, 1.0)],
                vec![(1, -1.0), (2, 1.0)],
                vec![(2, -1.0), (3, 1.0)],
                vec![],
                vec![(0, 1.0)],
            ],
        );
        let p =
            ProjectionProblem::new(vec![0.0, 0.0, 1.8, 3.0], a, vec![1.0, 1.0, 1.0, -1.0, -5.0])
                .unwrap();
        let mut r = vec![0.0; 5];
        p.a().mul_vec(p.y(), &mut r);
        r.iter_mut().zip(p.b()).for_each(|(ri, bi)| *ri = bi - *ri);
        (p, r)
    }

    #[test]
    fn the_screen_keeps_violated_rows_and_rows_within_half_the_largest_violation() {
        let (p, r) = chain();
        // Distances: 1/√2 (violated), −0.8/√2, −0.2/√2, empty row (kept: it has no
        // distance), −5. Half the largest violation is 0.5/√2: the second and last rows go.
        assert_eq!(screened_rows(&p, &r), vec![0, 2, 3]);
        // Nothing violated: only rows at distance ≥ 0 stay.
        let zero = vec![-0.0, -1.0];
        let q = ProjectionProblem::new(
            vec![0.0, 0.0],
            SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]),
            vec![0.0, -1.0],
        )
        .unwrap();
        assert_eq!(screened_rows(&q, &zero), vec![0]);
    }

    #[test]
    fn an_iterate_on_screened_rows_is_spread_over_every_row() {
        let (p, r) = chain();
        // Without the empty row, which the interior point cannot take.
        let rows = [0, 2];
        let it = solve_rows(&p, &r, &rows, 1e-12, &|| false).unwrap();
        assert!(it.converged);
        assert_eq!((it.lambda.len(), it.slack.len()), (5, 5));
        for left_out in [1, 3, 4] {
            assert_eq!(it.lambda[left_out], 0.0);
            assert_eq!(it.slack[left_out], f64::INFINITY);
        }
        // Row 0 alone is tight: λ₀ = ½ (the half-space projection); row 2 is not.
        assert!((it.lambda[0] - 0.5).abs() < 1e-9, "{}", it.lambda[0]);
        assert!(it.lambda[2] < 1e-9 && it.slack[2] > 0.1);
    }

    #[test]
    fn an_interior_point_is_the_answer_only_if_every_row_passes_the_check() {
        let (p, r) = chain();
        let tol = 1e-10 * 5.0;
        // On rows 0 and 2 the answer moves x₁ to 0.5, and row 1 (left out) then has slack
        // 0.3: the iterate is the projection, accepted, with row 2's μ/s multiplier cleared.
        let it = solve_rows(&p, &r, &[0, 2, 4], 1e-12, &|| false).unwrap();
        let outcome = certified_iterate(&p, &it, tol, 7).expect("accepted");
        assert_eq!(outcome.iterations, 7);
        assert_eq!(outcome.lambda[1..], [0.0, 0.0, 0.0, 0.0]);
        let expected = [-0.5, 0.5, 1.8, 3.0];
        for (x, e) in outcome.x.iter().zip(expected) {
            assert!((x - e).abs() < 1e-10, "{:?}", outcome.x);
        }
        // Row 1 made tighter (slack 0.2 < the push of 0.5): the same rows' answer violates
        // it, and the iterate is refused.
        let y = vec![0.0, 0.0, 1.2, 3.0];
        let q = ProjectionProblem::new(y, p.a().clone(), p.b().to_vec()).unwrap();
        let mut rq = vec![0.0; 5];
        q.a().mul_vec(q.y(), &mut rq);
        rq.iter_mut().zip(q.b()).for_each(|(ri, bi)| *ri = bi - *ri);
        let it = solve_rows(&q, &rq, &[0, 2, 4], 1e-12, &|| false).unwrap();
        assert!(certified_iterate(&q, &it, tol, 7).is_none());
        // So is an iterate that is not converged enough for the fraction of `tol`.
        let loose = solve_rows(&p, &r, &[0, 2, 4], 1e-4, &|| false).unwrap();
        assert!(certified_iterate(&p, &loose, tol, 7).is_none());
    }

    fn iterate(lambda: Vec<f64>, slack: Vec<f64>) -> interior_point::Iterate {
        interior_point::Iterate {
            previous_lambda: lambda.clone(),
            previous_slack: slack.clone(),
            lambda,
            slack,
            iterations: 9,
            converged: true,
            accuracy: 0.0,
        }
    }

    #[test]
    fn the_screen_measures_slack_as_a_distance_and_keeps_rows_without_one() {
        // Row 0 violated by 4 (‖a‖ = 1); row 1 slack 3 with ‖a‖ = 2, at distance 1.5 (within
        // half of 4, kept; its raw slack 3 would not be); row 2 at distance 2.5 (out); row 3
        // empty with a negative r (no distance: kept); row 4 at distance 2, on the line; row 5
        // empty with r = 0 (kept too, although 0/0 has no sign).
        let a = SparseRows::from_rows(
            2,
            &[
                vec![(0, 1.0)],
                vec![(1, 2.0)],
                vec![(0, -1.0)],
                vec![],
                vec![(1, -1.0)],
                vec![],
            ],
        );
        let b = vec![4.0, -3.0, -2.5, -1.0, -2.0, 0.0];
        let p = ProjectionProblem::new(vec![0.0; 2], a, b).unwrap();
        let r = p.b().to_vec();
        assert_eq!(screened_rows(&p, &r), vec![0, 1, 3, 4, 5]);
    }

    #[test]
    fn a_rescue_runs_on_the_screened_rows_then_on_every_row_unless_the_screen_kept_them_all() {
        assert_eq!(
            rescue_attempts(vec![0, 2], 3),
            vec![vec![0, 2], vec![0, 1, 2]]
        );
        assert_eq!(rescue_attempts(vec![0, 1, 2], 3), vec![vec![0, 1, 2]]);
    }

    #[test]
    fn an_interior_point_is_finished_from_when_it_reached_a_relative_1e_8() {
        assert!(is_a_guess(1e-8, 1.0));
        assert!(!is_a_guess(2e-8, 1.0));
        // Relative to the data's scale: 1e-6 on data of 100 is a guess, 1e-3 is not.
        assert!(is_a_guess(1e-6, 100.0));
        assert!(!is_a_guess(1e-3, 100.0));
        assert!(!is_a_guess(f64::INFINITY, 1.0));
    }

    #[test]
    fn a_diverged_interior_point_hands_the_violated_rows_to_the_active_set_with_room_for_half_the_rows(
    ) {
        let r = [1.0, 0.0, -2.0, 3.0];
        let cold = vec![0.1, 0.2, 0.3, 0.4];
        let (start, cap) = cold_start(&r, cold.clone());
        assert_eq!(start.support, vec![0, 3]);
        assert_eq!(start.lambda, vec![0.1, 0.4]);
        assert_eq!(start.join, cold);
        assert_eq!(cap, POLISH_ITERATIONS);
        // A block of 1000 rows: 40 + 500 iterations.
        let (_, cap) = cold_start(&vec![-1.0; 1000], vec![0.0; 1000]);
        assert_eq!(cap, 540);
    }

    #[test]
    fn a_finish_starts_from_multipliers_above_their_slack_and_joins_rows_at_their_iterate() {
        let it = iterate(vec![2.0, 0.5, 0.0, 1.0], vec![1.0, 1.0, 0.1, 1.0]);
        let start = finish_start(&it, &[9.0; 4], 1e-12);
        // Row 3, with its multiplier equal to its slack, is not in the support.
        assert_eq!(start.support, vec![0]);
        assert_eq!(start.lambda, vec![2.0]);
        // Row 2's multiplier is zero: it joins at the cold one.
        assert_eq!(start.join, vec![2.0, 0.5, 9.0, 1.0]);
    }

    #[test]
    fn a_row_with_a_small_gap_at_the_answer_does_not_start_the_finish() {
        // x₀ ≥ 1, tight at the answer x₀ = 1 (λ = 1), and x₀ ≥ 1 − 1e-8, with a gap of 1e-8
        // there; from y = 0 both are violated. Parallel rows: in one support they are
        // inconsistent, and the finish would spend an iteration leaving the second.
        let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
        let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, 1.0 - 1e-8]).unwrap();
        let r = p.b().to_vec();
        let tolerance = INTERIOR_POINT_TOLERANCE;
        let it = interior_point::solve(p.a(), &r, tolerance, INTERIOR_POINT_ITERATIONS).unwrap();
        assert!(it.converged, "{it:?}");
        // At μ ≈ 1e-12 the gapped row's multiplier, about μ/1e-8, still exceeds its slack…
        assert!(it.lambda[1] > it.slack[1], "{it:?}");
        assert!((it.slack[1] - 1e-8).abs() < 1e-10, "{it:?}");
        // …but over the last iteration it shrank faster than the slack: Tapia's indicators
        // say inactive, and the finish starts from the tight row alone.
        assert!(tapia_says_inactive(&it, 1, tolerance));
        assert!(!tapia_says_inactive(&it, 0, tolerance));
        let start = finish_start(&it, &[1.0, 1.0], tolerance);
        assert_eq!(start.support, vec![0]);
        let memory = (&mut Orderings::default(), &names(1)[..]);
        let outcome = finish(&p, start, finish_cap(2), 0, memory).unwrap();
        assert_eq!(outcome.iterations, 1);
        assert!((outcome.x[0] - 1.0).abs() < 1e-15, "{outcome:?}");
        assert_eq!(outcome.lambda[1], 0.0);
    }

    #[test]
    fn tapia_leaves_slacks_at_the_tolerance_to_the_multiplier_test() {
        // Row 0: multiplier shrinking, slack steady but within 100 × the tolerance (a row of a
        // contact loop trading multiplier with its neighbours): not called inactive. Row 1:
        // the same ratios with a slack beyond that: inactive. Row 2: slack shrinking faster
        // than the multiplier: active.
        let mut it = iterate(vec![1e-2, 1e-4, 1.0], vec![1e-11, 1e-8, 1e-12]);
        it.previous_lambda = vec![2e-2, 3e-4, 1.0];
        it.previous_slack = vec![1e-11, 1e-8, 1e-11];
        let tolerance = 1e-12;
        assert!(!tapia_says_inactive(&it, 0, tolerance));
        assert!(tapia_says_inactive(&it, 1, tolerance));
        assert!(!tapia_says_inactive(&it, 2, tolerance));
        // A slack of exactly 100 × the tolerance is still left to the multiplier test.
        let mut it = iterate(vec![1e-4, 1e-4], vec![25.0, 25.5]);
        it.previous_lambda = vec![1e-3, 1e-3];
        assert!(!tapia_says_inactive(&it, 0, 0.25));
        assert!(tapia_says_inactive(&it, 1, 0.25));
        // With no previous iterate (ratios 1), nothing is called inactive.
        let it = iterate(vec![1e-4, 1.0], vec![1e-8, 1e-12]);
        assert!(!tapia_says_inactive(&it, 0, tolerance));
        assert!(!tapia_says_inactive(&it, 1, tolerance));
    }

    #[test]
    fn multipliers_below_their_slack_and_a_hundredth_of_the_tolerance_are_cleared() {
        let tol = 1e-8;
        let at_threshold = CLEAN_FRACTION * tol;
        let it = iterate(
            vec![2.0, 1e-12, 1e-12, at_threshold, 1e-9, 1e-12],
            vec![1.0, 1e-13, 1e-12, 1.0, 1.0, 1.0],
        );
        assert_eq!(
            cleaned_multipliers(&it, tol),
            // Above the slack: kept however small (rows 0, 1); at or below both the slack and
            // the threshold: cleared (rows 2, 3, 5); above the threshold: kept, below its
            // slack or not (row 4: a degenerate row's multiplier, about √μ).
            vec![2.0, 1e-12, 0.0, 0.0, 1e-9, 0.0]
        );
    }

    #[test]
    fn a_rescue_whose_screened_interior_point_gets_nowhere_tries_every_row_before_the_cold_start() {
        // x₀ ≥ 1 and −x₀ ≥ 0 (empty), and x₁ ≥ −100, which the screen leaves out.
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, -1.0)], vec![(1, 1.0)]]);
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 0.0, -100.0]).unwrap();
        let r = p.b().to_vec();
        let screened = screened_rows(&p, &r);
        assert_eq!(screened, vec![0, 1]);
        let tolerance = INTERIOR_POINT_TOLERANCE * 100.0;
        let ipm = |rows: &[usize]| {
            solve_rows(&p, &r, rows, tolerance, &|| false).map_or(0, |it| it.iterations)
        };
        let (_, cap) = cold_start(&r, vec![0.0; 3]);
        // Both interior points ran (and diverged), then the active set found the certificate.
        let spent = ipm(&screened) + ipm(&[0, 1, 2]) + cap;
        match rescue_alone(&p, &r, vec![0.0; 3], 1e-10) {
            Err((Failure::Infeasible { .. }, total)) => assert_eq!(total, spent),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_rescue_on_an_empty_set_ends_with_a_farkas_certificate() {
        // x₀ ≥ 1 and −x₀ ≥ 0: the interior point diverges, and the active set proves it.
        let a = SparseRows::from_rows(1, &[vec![(0, 1.0)], vec![(0, -1.0)]]);
        let p = ProjectionProblem::new(vec![0.0], a, vec![1.0, 0.0]).unwrap();
        let r = p.b().to_vec();
        match rescue_alone(&p, &r, vec![0.0; 2], 1e-10) {
            Err((Failure::Infeasible { mut rows }, _)) => {
                rows.sort_unstable();
                assert_eq!(rows, vec![0, 1]);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_rescue_on_large_data_is_its_interior_point_accepted_as_it_is() {
        // The chain scaled by 1000: the interior point's tolerance is relative, so it stops
        // at the same iteration as on the chain, and its iterate is the answer.
        let (p, _) = chain();
        let scaled = |v: &[f64]| v.iter().map(|x| 1000.0 * x).collect::<Vec<f64>>();
        let q = ProjectionProblem::new(scaled(p.y()), p.a().clone(), scaled(p.b())).unwrap();
        let mut r = vec![0.0; 5];
        q.a().mul_vec(q.y(), &mut r);
        r.iter_mut().zip(q.b()).for_each(|(ri, bi)| *ri = bi - *ri);
        let screened = screened_rows(&q, &r);
        let alone = solve_rows(&q, &r, &screened, 1e-12 * 1000.0, &|| false).unwrap();
        assert!(alone.converged);
        let tol = 1e-10 * 5000.0;
        let outcome = rescue_alone(&q, &r, vec![0.0; 5], tol).unwrap();
        assert_eq!(outcome.iterations, alone.iterations);
        assert!(q.kkt_residuals(&outcome.x, &outcome.lambda).max() <= CLEAN_FRACTION * tol);
        assert!((outcome.x[0] + 500.0).abs() < 1e-7 && (outcome.x[1] - 500.0).abs() < 1e-7);
    }

    #[test]
    fn a_rescue_whose_interior_point_breaks_down_finishes_from_where_it_got() {
        let (a, r) = interior_point::tests::random_crowd();
        let m = r.len();
        let p = ProjectionProblem::new(vec![0.0; a.n_cols()], a, r.clone()).unwrap();
        let tol = 1e-10;
        let outcome = rescue_alone(&p, &r, vec![0.0; m], tol).expect("solved");
        assert!(p.kkt_residuals(&outcome.x, &outcome.lambda).max() <= tol);
        let reference = sweeping_clarabel::ClarabelProjector::default()
            .project(&p)
            .unwrap();
        let gap = sweeping_api::conformance::max_gap(&outcome.x, &reference.x);
        assert!(gap <= 1e-8, "{gap:e}");
    }

    #[test]
    fn an_iterate_whose_kept_row_is_not_tight_is_refused_though_its_products_are_small() {
        // x₀ ≥ 0 with y = 1e-7: the projection is y, the row is not active. An iterate with
        // λ = 5e-7 on it (a degenerate row's √μ, above its slack) gives x = 6e-7: feasible,
        // stationary, and λ(Ax − b) = 3e-13 within a hundredth of tol = 1e-10, yet 5e-7 from
        // the projection. The row holds a multiplier without being tight: refused.
        let a = SparseRows::from_rows(1, &[vec![(0, 1.0)]]);
        let p = ProjectionProblem::new(vec![1e-7], a, vec![0.0]).unwrap();
        let tol = 1e-10;
        let it = iterate(vec![5e-7], vec![1e-7]);
        let x = [6e-7];
        assert!(p.kkt_residuals(&x, &it.lambda).max() <= CLEAN_FRACTION * tol);
        assert!(certified_iterate(&p, &it, tol, 3).is_none());
        // The same row tight (y = −5e-7, so x = 0): accepted.
        let q = ProjectionProblem::new(vec![-5e-7], p.a().clone(), vec![0.0]).unwrap();
        let outcome = certified_iterate(&q, &it, tol, 3).expect("accepted");
        assert!(outcome.x[0].abs() < 1e-18);
        // Tight, but a row without a multiplier (x₁ ≥ 1e-9, y₁ = 0) violated by 1e-9, more
        // than a hundredth of tol: refused.
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
        let r = ProjectionProblem::new(vec![-5e-7, 0.0], a, vec![0.0, 1e-9]).unwrap();
        let it = iterate(vec![5e-7, 0.0], vec![1e-7, 1.0]);
        assert!(certified_iterate(&r, &it, tol, 3).is_none());
    }

    /// Step `s` of 60 people on a line squeezed toward the middle: `x_{j+1} − x_j ≥ 1` for
    /// every neighbour pair, keyed by the pair, `y` drifting a little from step to step.
    fn squeezed_line(s: usize) -> ProjectionProblem {
        let n = 60;
        let rows: Vec<Vec<(usize, f64)>> =
            (0..n - 1).map(|j| vec![(j, -1.0), (j + 1, 1.0)]).collect();
        let keys = (0..n - 1)
            .map(|j| RowKey {
                family: 0,
                member: j as u64,
            })
            .collect();
        let y = (0..n)
            .map(|j| 0.5 * j as f64 + 0.01 * ((j * 7 + s * 3) as f64).sin())
            .collect();
        let a = SparseRows::from_rows(n, &rows);
        ProjectionProblem::new(y, a, vec![1.0; n - 1])
            .unwrap()
            .with_row_keys(keys)
            .unwrap()
    }

    /// `‖x − x_fresh‖∞` between `warm`'s answer on `p` and a fresh projector's (both
    /// certified, or this panics).
    fn gap_to_a_fresh_projector(warm: &mut NativeProjector, p: &ProjectionProblem) -> f64 {
        let answer = warm.project(p).unwrap();
        let fresh = NativeProjector::default().project(p).unwrap();
        assert!(p.kkt_residuals(&answer.x, &answer.multipliers).max() < 1e-10);
        answer
            .x
            .iter()
            .zip(&fresh.x)
            .fold(0.0, |acc: f64, (a, b)| acc.max((a - b).abs()))
    }

    #[test]
    fn steps_after_the_first_reuse_its_ordering_and_answer_as_a_fresh_projector_does() {
        let mut warm = NativeProjector::default();
        for s in 0..6 {
            let gap = gap_to_a_fresh_projector(&mut warm, &squeezed_line(s));
            assert!(gap < 1e-10, "step {s}: gap {gap:e}");
        }
        let (by_amd, by_memory) = warm.orderings().stats();
        assert_eq!(by_amd, 1, "only the first step's factorization runs AMD");
        assert!(by_memory >= 5, "{by_memory} reused");
    }

    #[test]
    fn a_remembered_ordering_from_an_unrelated_problem_with_the_same_keys_changes_no_answer() {
        // The same 59 keys on a line of 60, then on a 6 × 10 grid whose rows link other
        // unknowns, in another order, in a problem of another dimension: the remembered ranks
        // name the wrong nodes, which may cost fill but not accuracy.
        let mut warm = NativeProjector::default();
        warm.project(&squeezed_line(0)).unwrap();
        let (w, h) = (6usize, 10usize);
        let n = w * h + 7;
        let mut rows: Vec<Vec<(usize, f64)>> = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let c = 7 + j * w + i;
                if i + 1 < w {
                    rows.push(vec![(c, -1.0), (c + 1, 1.0)]);
                }
                if j + 1 < h && rows.len() < 59 {
                    rows.push(vec![(c, -0.6), (c + w, 0.8)]);
                }
            }
        }
        rows.truncate(59);
        let keys: Vec<RowKey> = (0..59)
            .rev()
            .map(|j| RowKey {
                family: 0,
                member: j as u64,
            })
            .collect();
        let y: Vec<f64> = (0..n).map(|c| 0.1 * ((c * 13) as f64).sin()).collect();
        let p = ProjectionProblem::new(y, SparseRows::from_rows(n, &rows), vec![0.5; 59])
            .unwrap()
            .with_row_keys(keys)
            .unwrap();
        let gap = gap_to_a_fresh_projector(&mut warm, &p);
        assert!(gap < 1e-10, "gap {gap:e}");
        let (by_amd, by_memory) = warm.orderings().stats();
        assert!(
            by_memory >= 1,
            "the grid is ordered from the line's memory ({by_amd} by AMD)"
        );
    }

    /// A chain of `chain` unknowns (`x_{j+1} − x_j ≥ 1`, rows present when `with_chain`), then
    /// a grid of `w × h` unknowns pushed apart (`x_{c+1} − x_c ≥ 1` along a row of the grid,
    /// `x_{c+w} − x_c ≥ 1` across); `y = 0`. Rows keyed by family (chain 0, grid 1) and
    /// position, so the grid's keys are the same with or without the chain.
    fn chain_and_grid(chain: usize, w: usize, h: usize, with_chain: bool) -> ProjectionProblem {
        let n = chain + w * h;
        let (mut rows, mut keys) = (Vec::new(), Vec::new());
        if with_chain {
            for j in 0..chain - 1 {
                rows.push(vec![(j, -1.0), (j + 1, 1.0)]);
                keys.push(RowKey {
                    family: 0,
                    member: j as u64,
                });
            }
        }
        for g in 0..w * h {
            let c = chain + g;
            if (g + 1) % w != 0 {
                rows.push(vec![(c, -1.0), (c + 1, 1.0)]);
                keys.push(RowKey {
                    family: 1,
                    member: 2 * g as u64,
                });
            }
            if g + w < w * h {
                rows.push(vec![(c, -1.0), (c + w, 1.0)]);
                keys.push(RowKey {
                    family: 1,
                    member: 2 * g as u64 + 1,
                });
            }
        }
        let b = vec![1.0; rows.len()];
        ProjectionProblem::new(vec![0.0; n], SparseRows::from_rows(n, &rows), b)
            .unwrap()
            .with_row_keys(keys)
            .unwrap()
    }

    #[test]
    fn blocks_on_threads_order_from_the_memory_as_it_stood_before_any_of_them() {
        // Two blocks of at least `parallel_rows` rows, so two groups, each ordered from a fork
        // of the memory: the grid, remembered from the projection before, reuses its ordering
        // under the fill budget of its own AMD ordering (fill 1.30). Solved one after the
        // other, the chain (the first block) would set that budget by its fresh AMD ordering,
        // which fills far less (0.50), and the grid's remembered ordering, beyond it, would
        // run AMD again.
        let settings = NativeSettings {
            parallel_rows: 30,
            threads: 1,
            ..NativeSettings::default()
        };
        let mut warm = NativeProjector::new(settings);
        let alone = chain_and_grid(40, 8, 8, false);
        warm.project(&alone).unwrap();
        assert_eq!(warm.orderings().stats(), (1, 0), "the grid, by AMD");
        let both = chain_and_grid(40, 8, 8, true);
        let answer = warm.project(&both).unwrap();
        assert!(both.kkt_residuals(&answer.x, &answer.multipliers).max() < 1e-10);
        assert_eq!(
            warm.orderings().stats(),
            (2, 1),
            "the chain by AMD, the grid from memory"
        );
    }

    #[test]
    fn a_block_the_native_method_cannot_finish_goes_to_the_fallback_and_is_counted() {
        // x₁ − x₀ ≥ 1 is violated at y; its projection alone breaks x₂ − x₁ ≥ 1, which joins
        // in a second iteration: one iteration and no rescue cannot finish.
        let settings = NativeSettings {
            max_iterations: 1,
            interior_point: false,
            ..NativeSettings::default()
        };
        let a = SparseRows::from_rows(3, &[vec![(0, -1.0), (1, 1.0)], vec![(1, -1.0), (2, 1.0)]]);
        let p = ProjectionProblem::new(vec![0.0, 0.5, 1.6], a, vec![1.0, 1.0]).unwrap();
        let without = NativeProjector::new(settings.clone()).project(&p);
        assert!(
            matches!(without, Err(ProjectionError::NotConverged { .. })),
            "{without:?}"
        );
        let fallback = Box::new(sweeping_api::conformance::ReferenceProjector::default());
        let answer = NativeProjector::with_fallback(settings, fallback)
            .project(&p)
            .unwrap();
        assert_eq!(answer.stats.fallbacks, 1);
        assert!(p.kkt_residuals(&answer.x, &answer.multipliers).max() < 1e-9);
    }
}
