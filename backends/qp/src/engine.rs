//! The engine: a projection split into blocks; each block solved by the active set from the
//! previous step's support, or by the interior point (and finished from its support when
//! that is cheap); every answer certified.

use crate::active_set::{self, Failure, Memory, Options, Orderings, Start};
use crate::ipm::{self, Tolerance};
use crate::normal::{Layout, NormalMatrix};
use crate::screen::{row_slack, Screening, SCREEN_REACH, SCREEN_ROUNDS};
use std::time::Instant;
use sweeping_api::{
    BackendCounters, Block, Blocks, EqualityPairs, FastMap, MetricChange, Projection,
    ProjectionError, ProjectionProblem, Projector, RowKey, SolveStats, SolveStatus,
};

/// Settings of an [`Engine`]. Every field has a documented default.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineSettings {
    /// The certificate: largest KKT residual of an answer, relative to `max(1, ‖y‖∞, ‖b‖∞)`.
    /// Default `1e-10`.
    pub kkt_tolerance: f64,
    /// When the interior point stops (its accuracy contract). Default
    /// [`Tolerance::default`].
    pub interior_point: Tolerance,
    /// Most interior-point iterations per block. Default `100`.
    pub interior_point_iterations: u32,
    /// With [`warm_start`](Self::warm_start), the interior point starts from the previous
    /// projection's multipliers (by row key; `0` for a row without one) when the block has
    /// any, the start's slacks and multipliers raised to at least this fraction of the
    /// block's length scale. With `warm_start`, a block solved again because rows that
    /// screening left out came back violated starts from the last round's answers as if they
    /// were remembered. `0` (or anything but a finite positive number) starts every run from
    /// Mehrotra's point. Default `0.1`.
    pub interior_point_warm_floor: f64,
    /// Most active-set iterations per block from the warm start before the interior point
    /// takes the block (at most 16 on blocks of 400 rows or more); `0` sends every block to
    /// the interior point. Default `48`.
    ///
    /// The active set pays an iteration for each row that joins or leaves: it wins while the
    /// support changes by a few rows a step (a crowd walking, a queue moving) and loses to
    /// the interior point when it changes by hundreds (a jam).
    pub active_set_iterations: u32,
    /// Most active-set iterations when it finishes an interior point's answer that is not the
    /// block's answer on its own (short of its tolerance, or failing the KKT check), from the
    /// interior point's support (rows whose multiplier exceeds
    /// their slack), the most violated row joining alone; `0` never finishes. Default `16`.
    pub finish_iterations: u32,
    /// Start the active set from the previous projection's support, matched by row keys.
    /// Default `true`.
    pub warm_start: bool,
    /// Most threads a projection runs on, the caller's included: `1` keeps it on the caller's
    /// thread; `0` means as many as the cores the process may run on. The answers do not
    /// depend on it. Default `0`.
    pub threads: usize,
    /// Blocks of at least this many rows go to threads of their own when a projection has
    /// two or more of them (a queue at each door). Default `400`.
    pub parallel_rows: usize,
}

impl Default for EngineSettings {
    fn default() -> Self {
        Self {
            kkt_tolerance: 1e-10,
            interior_point: Tolerance::default(),
            interior_point_iterations: 100,
            interior_point_warm_floor: 0.1,
            active_set_iterations: 48,
            finish_iterations: 16,
            warm_start: true,
            threads: 0,
            parallel_rows: 400,
        }
    }
}

/// Which method answered a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The active set, from the warm start (its tests at `1e-12`).
    ActiveSet,
    /// The interior point, finished by the active set or answered as it stood.
    InteriorPoint,
}

/// A block's answer, in the block's local numbering.
#[derive(Debug, Clone)]
struct BlockAnswer {
    x: Vec<f64>,
    lambda: Vec<f64>,
    method: Method,
    iterations: u32,
    /// Whether the block started from remembered multipliers.
    warm: bool,
    /// For an interior point accepted short of its tolerance, how far its tests were from it,
    /// as a length ([`ipm::Iterate::accuracy`] times the block's length scale).
    short_of: Option<f64>,
}

/// Why a block has no answer.
#[derive(Debug, Clone, PartialEq)]
enum BlockFailure {
    /// A non-negative combination of these local rows reads `0 ≥ positive`.
    Infeasible(Vec<usize>),
    /// Neither method certified an answer.
    Unsolved { iterations: u32, reason: String },
}

type BlockResult = Result<BlockAnswer, BlockFailure>;

/// What a remembered row carries to the next projection.
#[derive(Debug, Clone, Copy)]
struct Remembered {
    multiplier: f64,
    /// How many projections in a row this row's block went to the interior point.
    interior_streak: u32,
    /// The screening reach of this row's block at the next projection.
    screen_reach: f64,
}

/// The projection engine; see the [crate documentation](crate).
#[derive(Debug)]
pub struct Engine {
    /// The settings used for every solve.
    pub settings: EngineSettings,
    memory: FastMap<RowKey, Remembered>,
    orderings: Orderings,
    pool: Option<(usize, rayon::ThreadPool)>,
}

impl Default for Engine {
    fn default() -> Self {
        Self::new(EngineSettings::default())
    }
}

/// What solving a block needs besides the block and its orderings.
struct Context<'a> {
    settings: &'a EngineSettings,
    memory: &'a FastMap<RowKey, Remembered>,
    tol: f64,
}

impl Engine {
    /// An engine with empty memory.
    pub fn new(settings: EngineSettings) -> Self {
        Self {
            settings,
            memory: FastMap::default(),
            orderings: Orderings::default(),
            pool: None,
        }
    }

    /// The orderings of recent sparse factorizations of the active set, with how many were
    /// made by AMD and how many reused from memory ([`Orderings::stats`]).
    pub fn orderings(&self) -> &Orderings {
        &self.orderings
    }

    /// Projects `problem`, block by block; the blocks neither method certifies go to
    /// `fallback` (counted in [`BackendCounters::fallbacks`]), or fail without one. `name` is the
    /// backend's name in statistics and errors.
    ///
    /// A metric `W` other than the identity is changed away exactly ([`MetricChange`]: the
    /// problem is solved in `z = Lᵀx` and its certificate holds there), and equality rows are
    /// solved as pairs of opposite inequalities ([`EqualityPairs`]): the active set keeps one
    /// of a pair, the one its multiplier's sign calls for, and the interior point converges to
    /// the face they share.
    ///
    /// # Errors
    /// [`ProjectionError::Infeasible`] with a checked Farkas certificate,
    /// [`ProjectionError::NotConverged`] for a block that neither method certified when there
    /// is no fallback, or the fallback's own error.
    pub fn project(
        &mut self,
        problem: &ProjectionProblem,
        name: &str,
        fallback: Option<&mut (dyn Projector + '_)>,
    ) -> Result<Projection, ProjectionError> {
        if let Some(change) = MetricChange::new(problem)? {
            return self
                .project(change.problem(), name, fallback)
                .map(|z| change.answer(z));
        }
        if let Some(pairs) = EqualityPairs::new(problem)? {
            return self
                .project_inequalities(pairs.problem(), name, fallback)
                .map(|answer| pairs.answer(answer))
                .map_err(|e| pairs.error(e));
        }
        self.project_inequalities(problem, name, fallback)
    }

    /// [`Self::project`] for a problem in the identity metric without equality rows.
    fn project_inequalities(
        &mut self,
        problem: &ProjectionProblem,
        name: &str,
        mut fallback: Option<&mut (dyn Projector + '_)>,
    ) -> Result<Projection, ProjectionError> {
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
                self.memory.clear();
            }
            return Ok(Projection::identity(problem, name));
        }
        let mut screening = None;
        let blocks = Blocks::split_violated_or_among(problem, |parents| {
            let screened = self.screening(problem, parents);
            let keep = screened.any().then(|| screened.keep().to_vec());
            screening = Some(screened);
            keep
        });
        let screening = screening.expect("the split hands over its blocks' rows");
        if let Some(r) = blocks.infeasible_empty_row(problem) {
            return Err(ProjectionError::Infeasible {
                backend: name.to_string(),
                detail: format!(
                    "row {r} has no non-zero entry and b[{r}] = {} > 0",
                    problem.b()[r]
                ),
                rows: vec![r],
            });
        }
        self.orderings.forget_older();
        let setup_seconds = setup_start.elapsed().as_secs_f64();
        let solve_start = Instant::now();
        let (screening, blocks, results) = self.solve_screened(problem, screening, blocks, tol);
        let mut answers = Vec::with_capacity(results.len());
        let mut methods = Vec::with_capacity(results.len());
        let reaches: Vec<f64> = blocks
            .blocks()
            .iter()
            .map(|b| screening.next_reach(b.rows[0]))
            .collect();
        for (index, (block, result)) in blocks.blocks().iter().zip(results).enumerate() {
            match result {
                Ok(answer) => {
                    methods.push(Some(answer.method));
                    answers.push(Projection {
                        x: answer.x,
                        multipliers: answer.lambda,
                        stats: SolveStats {
                            status: SolveStatus::Solved,
                            iterations: answer.iterations,
                            warm_started: answer.warm,
                            counters: BackendCounters {
                                escalations: u64::from(answer.method == Method::InteriorPoint),
                                reduced: u64::from(answer.short_of.is_some()),
                                reduced_by: answer.short_of.unwrap_or(0.0),
                                ..BackendCounters::default()
                            },
                            ..SolveStats::trivial(name)
                        },
                    });
                }
                Err(BlockFailure::Infeasible(rows)) => {
                    let global: Vec<usize> = rows.iter().map(|&t| block.rows[t]).collect();
                    return Err(ProjectionError::Infeasible {
                        backend: name.to_string(),
                        detail: format!(
                            "Farkas certificate on rows {global:?} (block {index}): a \
                             non-negative combination of them reads 0 ≥ positive"
                        ),
                        rows: global,
                    });
                }
                Err(BlockFailure::Unsolved { iterations, reason }) => match fallback.as_mut() {
                    Some(fallback) => {
                        let mut answer = fallback
                            .project(&block.problem)
                            .map_err(|e| through_fallback(e, name, index, block, &reason))?;
                        answer.stats.counters.fallbacks =
                            answer.stats.counters.fallbacks.saturating_add(1);
                        methods.push(None);
                        answers.push(answer);
                    }
                    None => {
                        return Err(ProjectionError::NotConverged {
                            backend: name.to_string(),
                            iterations,
                            status: format!(
                                "{reason} on block {index} ({} rows, {} unknowns), no fallback",
                                block.rows.len(),
                                block.cols.len()
                            ),
                        })
                    }
                },
            }
        }
        let mut answer = blocks.stitch(problem, answers, name);
        // The stitched answer is checked once more as a whole (blocks are independent, so this
        // only guards the stitching itself); fallback answers are held to their backend's own
        // tolerance.
        let whole = problem.kkt_residuals(&answer.x, &answer.multipliers).max();
        let allowed = if answer.stats.counters.fallbacks > 0 {
            tol.max(fallback.map_or(0.0, |f| f.tolerance()))
        } else {
            tol
        };
        if whole.is_nan() || whole > allowed {
            return Err(ProjectionError::Backend {
                backend: name.to_string(),
                message: format!("stitched answer has KKT residual {whole:.3e} > {allowed:.1e}"),
            });
        }
        self.remember(problem, &blocks, (&methods, &reaches), &answer);
        answer.stats.setup_seconds = setup_seconds;
        answer.stats.solve_seconds = solve_start.elapsed().as_secs_f64();
        Ok(answer)
    }

    /// The blocks of `problem` and their answers: the blocks of `parents` (those of every row),
    /// split further where rows far from violated are left out ([`Screening`]), until the
    /// answers satisfy every row left out. A block whose rows did not change keeps its answer
    /// from one round to the next; the others start from the last round's multipliers, the
    /// active set first. A parent with a block that has no answer, or still missing rows after
    /// [`SCREEN_ROUNDS`] rounds, is taken whole.
    fn solve_screened(
        &mut self,
        problem: &ProjectionProblem,
        mut screening: Screening,
        first: Blocks,
        tol: f64,
    ) -> (Screening, Blocks, Vec<BlockResult>) {
        if !screening.any() {
            let todo: Vec<usize> = (0..first.blocks().len()).collect();
            let results = self.solve_blocks(&first, &todo, &screening, None, tol);
            return (screening, first, results);
        }
        // A block is named by its first row and its number of rows: rows only join, so a
        // block with the same first row and as many rows is the same block.
        let name = |b: &Block| (b.rows[0], b.rows.len());
        let mut solved: FastMap<(usize, usize), BlockResult> = FastMap::default();
        let mut overlay: Option<FastMap<RowKey, Remembered>> = None;
        let mut rounds = 0;
        let mut next = Some(first);
        loop {
            let blocks = next
                .take()
                .unwrap_or_else(|| Blocks::split_among(problem, screening.keep()));
            let mut results: Vec<Option<BlockResult>> = blocks
                .blocks()
                .iter()
                .map(|b| solved.remove(&name(b)))
                .collect();
            let todo: Vec<usize> = (0..results.len())
                .filter(|&b| results[b].is_none())
                .collect();
            let fresh = self.solve_blocks(&blocks, &todo, &screening, overlay.as_ref(), tol);
            for (&b, result) in todo.iter().zip(fresh) {
                results[b] = Some(result);
            }
            let results: Vec<BlockResult> = results
                .into_iter()
                .map(|r| r.expect("every block is solved or kept"))
                .collect();
            let mut x = problem.y().to_vec();
            let mut failed = Vec::new();
            for (block, result) in blocks.blocks().iter().zip(&results) {
                match result {
                    Ok(answer) => {
                        for (&c, &v) in block.cols.iter().zip(&answer.x) {
                            x[c] = v;
                        }
                    }
                    Err(_) => failed.push(block.rows[0]),
                }
            }
            let missed = screening.join_violated(problem, &x);
            rounds += 1;
            let unscreened = failed.iter().any(|&i| screening.screened(i));
            if missed.is_empty() && !unscreened {
                return (screening, blocks, results);
            }
            for &i in &failed {
                screening.unscreen(i);
            }
            if rounds >= SCREEN_ROUNDS {
                for &i in &missed {
                    screening.unscreen(i);
                }
            }
            overlay = Some(self.memory_with(problem, &blocks, &results));
            for (block, result) in blocks.blocks().iter().zip(results) {
                solved.insert(name(block), result);
            }
        }
    }

    /// The screening of `problem`'s blocks (`parents`: the rows of each). A block
    /// is screened from [`LARGE_BLOCK_ROWS`] rows (a jam's candidate pairs, and the only
    /// blocks that skip the active set on their streak), and at any size when the active set
    /// is off: the interior point's iterations pay for every row. Its reach is the widest its
    /// remembered rows carry.
    fn screening(&self, problem: &ProjectionProblem, parents: &[Vec<usize>]) -> Screening {
        let (memory, settings) = (&self.memory, &self.settings);
        let keys = problem.row_keys().filter(|_| settings.warm_start);
        Screening::new(problem, parents, |rows| {
            let screens = rows.len() >= LARGE_BLOCK_ROWS || settings.active_set_iterations == 0;
            screens.then(|| {
                keys.into_iter()
                    .flat_map(|keys| rows.iter().filter_map(|&i| memory.get(&keys[i])))
                    .map(|rem| rem.screen_reach)
                    .fold(SCREEN_REACH, f64::max)
            })
        })
    }

    /// The memory of the last projection with the support of `results` (answers of `blocks`,
    /// a round of [`Self::solve_screened`]) written over it: blocks that grew by a few rows
    /// start from their parts' answers, each row keeping its interior-point streak (so a jam
    /// that skips the active set still does).
    fn memory_with(
        &self,
        problem: &ProjectionProblem,
        blocks: &Blocks,
        results: &[BlockResult],
    ) -> FastMap<RowKey, Remembered> {
        let mut memory = self.memory.clone();
        let Some(keys) = problem.row_keys() else {
            return memory;
        };
        for (block, result) in blocks.blocks().iter().zip(results) {
            let Ok(answer) = result else { continue };
            for (t, &i) in block.rows.iter().enumerate() {
                let lambda = answer.lambda[t];
                let slack = || row_slack(&block.problem, t, &answer.x);
                if !in_support(Some(answer.method), lambda, slack) {
                    memory.remove(&keys[i]);
                    continue;
                }
                let kept = memory.get(&keys[i]);
                let remembered = Remembered {
                    multiplier: lambda,
                    interior_streak: kept.map_or(0, |r| r.interior_streak),
                    screen_reach: kept.map_or(SCREEN_REACH, |r| r.screen_reach),
                };
                memory.insert(keys[i], remembered);
            }
        }
        memory
    }

    /// The answers of the blocks `todo` (indices into `blocks`), in that order, each starting
    /// from `memory` (the engine's own when `None`). When two blocks or more reach
    /// [`EngineSettings::parallel_rows`], the large blocks each form a group and the rest
    /// another; each group orders its factorizations from the memory as it stood before any
    /// of them, and the groups' memories are joined in a fixed order. The groups run on
    /// threads when there are threads to spare and one after the other otherwise — the same
    /// arithmetic either way, so the answers do not depend on the threads.
    fn solve_blocks(
        &mut self,
        blocks: &Blocks,
        todo: &[usize],
        screening: &Screening,
        memory: Option<&FastMap<RowKey, Remembered>>,
        tol: f64,
    ) -> Vec<BlockResult> {
        let all: Vec<&Block> = todo.iter().map(|&b| &blocks.blocks()[b]).collect();
        let context = Context {
            settings: &self.settings,
            memory: memory.unwrap_or(&self.memory),
            tol,
        };
        let layout = |block: &Block| {
            if screening.screened(block.rows[0]) {
                Layout::ByFill
            } else {
                Layout::ByUnknowns
            }
        };
        let groups = parallel_groups(&all, self.settings.parallel_rows);
        if groups.len() < 2 {
            return all
                .iter()
                .map(|block| solve_block(&context, &mut self.orderings, block, layout(block)))
                .collect();
        }
        let threads = match self.settings.threads {
            0 => cores(),
            t => t,
        };
        if threads < 2 {
            self.pool = None;
        } else if self.pool.as_ref().is_none_or(|(size, _)| *size != threads) {
            self.pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .ok()
                .map(|pool| (threads, pool));
        }
        let solve_group = |group: &Vec<usize>, orderings: &Orderings| {
            let mut fork = orderings.fork();
            let results: Vec<BlockResult> = group
                .iter()
                .map(|&b| solve_block(&context, &mut fork, all[b], layout(all[b])))
                .collect();
            (results, fork)
        };
        let orderings = &self.orderings;
        let done: Vec<(Vec<BlockResult>, Orderings)> = match &self.pool {
            Some((_, pool)) => {
                use rayon::prelude::*;
                pool.install(|| {
                    groups
                        .par_iter()
                        .map(|g| solve_group(g, orderings))
                        .collect()
                })
            }
            None => groups.iter().map(|g| solve_group(g, orderings)).collect(),
        };
        let mut results: Vec<Option<BlockResult>> = (0..all.len()).map(|_| None).collect();
        for (group, (group_results, fork)) in groups.iter().zip(done) {
            self.orderings.join(fork);
            for (&b, result) in group.iter().zip(group_results) {
                results[b] = Some(result);
            }
        }
        results
            .into_iter()
            .map(|result| result.expect("every block is in exactly one group"))
            .collect()
    }

    /// Keeps the support of the answer by row key for the next projection.
    fn remember(
        &mut self,
        problem: &ProjectionProblem,
        blocks: &Blocks,
        (methods, reaches): (&[Option<Method>], &[f64]),
        answer: &Projection,
    ) {
        let Some(keys) = problem.row_keys() else {
            return;
        };
        let previous = std::mem::take(&mut self.memory);
        for ((block, method), &screen_reach) in blocks.blocks().iter().zip(methods).zip(reaches) {
            let interior = *method == Some(Method::InteriorPoint);
            let streak = if interior {
                1 + block
                    .rows
                    .iter()
                    .filter_map(|&i| previous.get(&keys[i]))
                    .map(|r| r.interior_streak)
                    .max()
                    .unwrap_or(0)
            } else {
                0
            };
            for &i in &block.rows {
                let lambda = answer.multipliers[i];
                if !in_support(*method, lambda, || row_slack(problem, i, &answer.x)) {
                    continue;
                }
                self.memory.insert(
                    keys[i],
                    Remembered {
                        multiplier: lambda,
                        interior_streak: streak,
                        screen_reach,
                    },
                );
            }
        }
    }
}

/// Whether a row with multiplier `lambda` in the answer of `method` (`None`: the fallback's)
/// is in the support remembered for the next projection. An interior point's multipliers are
/// all positive: there a row counts when its multiplier exceeds its `slack`.
fn in_support(method: Option<Method>, lambda: f64, slack: impl FnOnce() -> f64) -> bool {
    lambda > 0.0 && (method != Some(Method::InteriorPoint) || lambda > slack())
}

/// The error of a fallback that failed on block `index` too, said as this backend's (`name`):
/// the block, why it went to the fallback, and the fallback's own error; a certificate's rows
/// in the whole problem's numbering.
fn through_fallback(
    error: ProjectionError,
    name: &str,
    index: usize,
    block: &Block,
    reason: &str,
) -> ProjectionError {
    let handed = format!(
        "block {index} ({} rows, {} unknowns) went to its fallback ({reason})",
        block.rows.len(),
        block.cols.len()
    );
    match error.in_rows_of(&block.rows) {
        ProjectionError::Infeasible {
            backend,
            detail,
            rows,
        } => ProjectionError::Infeasible {
            backend: name.to_string(),
            detail: format!("{handed}, and {backend} found: {detail}"),
            rows,
        },
        error @ ProjectionError::InvalidInput { .. } => error,
        other => ProjectionError::Backend {
            backend: name.to_string(),
            message: format!("{handed}, which failed too: {other}"),
        },
    }
}

/// The machine's cores, asked once: the standard library reads the control group's files at
/// every call, too slow a question for every projection of a small crowd.
fn cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, usize::from))
}

/// The blocks (by index) grouped for threads: every block of at least `parallel_rows` rows
/// on its own, then the rest together. A single group when fewer than two blocks are that
/// large (or `parallel_rows` is `0`): nothing to share out.
fn parallel_groups(blocks: &[&Block], parallel_rows: usize) -> Vec<Vec<usize>> {
    let large = |b: &Block| parallel_rows > 0 && b.rows.len() >= parallel_rows;
    if blocks.iter().filter(|b| large(b)).count() < 2 {
        return vec![(0..blocks.len()).collect()];
    }
    let mut groups: Vec<Vec<usize>> = (0..blocks.len())
        .filter(|&b| large(blocks[b]))
        .map(|b| vec![b])
        .collect();
    let rest: Vec<usize> = (0..blocks.len()).filter(|&b| !large(blocks[b])).collect();
    if !rest.is_empty() {
        groups.push(rest);
    }
    groups
}

/// Blocks of at least this many rows give the active set at most [`LARGE_BLOCK_ITERATIONS`]:
/// on a jam's large blocks the interior point is the better bet, on smaller ones an iteration
/// of the active set costs a small fraction of an interior point with its set-up (measured:
/// `docs/lab/2026-12-04-projection-engine.md`).
const LARGE_BLOCK_ROWS: usize = 400;

/// The active set's cap on blocks of [`LARGE_BLOCK_ROWS`] or more.
const LARGE_BLOCK_ITERATIONS: u32 = 16;

/// How many times [`EngineSettings::finish_iterations`] the finish of an interior point that
/// stopped too far short of its tolerance to be kept may take.
const UNCONVERGED_FINISH: u32 = 4;

/// A finish is kept when it lies within this many times the interior point's accuracy (its
/// measure times the block's length scale) of the interior point's answer.
const AGREEMENT: f64 = 100.0;

/// The interior point runs until its residuals and products are within this fraction of the
/// certificate's tolerance, so that its answer passes the check with room to spare.
const CERTIFIABLE: f64 = 0.5;

/// How far from `y`, in the block's length scales, a Farkas certificate must rule out every
/// point before the block is declared infeasible.
const FARKAS_REACH: f64 = 1e6;

/// Solves one block: the active set from the remembered support (unless its rows went to the
/// interior point at the last projections, see [`skips_active_set`]), else the interior
/// point (its normal matrix factored in `layout`), finished by the active set from its support
/// when that converges within [`EngineSettings::finish_iterations`]. Every answer is certified
/// by its KKT residuals.
fn solve_block(
    context: &Context<'_>,
    orderings: &mut Orderings,
    block: &Block,
    layout: Layout,
) -> BlockResult {
    let p = &block.problem;
    let settings = context.settings;
    let m = p.n_rows();
    let r = p.shortfall(p.y());
    let (start, streak, warm) = warm_start(context, p, &r);
    // `warm`: some row of the block is remembered, with a positive multiplier.
    let floor = settings.interior_point_warm_floor;
    let guess = if warm && floor > 0.0 && floor.is_finite() {
        remembered_multipliers(context, p)
    } else {
        None
    };
    let mut iterations = 0;
    let certified = |x: &[f64], lambda: &[f64]| certified(context, p, x, lambda);
    if settings.active_set_iterations > 0 && !skips_active_set(streak, m) {
        let cap = if m >= LARGE_BLOCK_ROWS {
            settings.active_set_iterations.min(LARGE_BLOCK_ITERATIONS)
        } else {
            settings.active_set_iterations
        };
        let res = first_pass(p, start, cap, orderings, block);
        match res {
            Ok(outcome) if certified(&outcome.x, &outcome.lambda) => {
                return Ok(BlockAnswer {
                    x: outcome.x,
                    lambda: outcome.lambda,
                    method: Method::ActiveSet,
                    iterations: outcome.iterations,
                    warm,
                    short_of: None,
                });
            }
            Ok(outcome) => iterations += outcome.iterations,
            Err(Failure::Infeasible { rows }) => return Err(BlockFailure::Infeasible(rows)),
            Err(Failure::Cap(n) | Failure::Cycling(n)) => iterations += n,
            Err(Failure::Numerical(_)) => {}
        }
    }
    let unsolved = |iterations: u32, reason: &str| BlockFailure::Unsolved {
        iterations,
        reason: reason.to_string(),
    };
    let it = interior_point(p, &r, layout, settings, CERTIFIABLE * context.tol, guess)
        .map_err(|reason| unsolved(iterations, reason))?;
    iterations = iterations.saturating_add(it.iterations);
    // An interior point within its tolerance, or stalled near it (the directions' rounding,
    // with weights spanning twenty orders of magnitude, sets a floor), is the answer when it
    // is certified: within its accuracy of the projection, as exact as the scheme needs. The
    // active set's finish is for the others.
    let x: Vec<f64> = p.y().iter().zip(&it.d).map(|(y, d)| y + d).collect();
    let acceptable = it.converged || it.accuracy <= settings.interior_point.acceptable;
    if acceptable && certified(&x, &it.lambda) {
        return Ok(BlockAnswer {
            x,
            lambda: it.lambda,
            method: Method::InteriorPoint,
            iterations,
            warm,
            short_of: (!it.converged).then_some(it.accuracy * it.length),
        });
    }
    if settings.finish_iterations > 0 {
        match finish_interior_point(context, orderings, block, (&it, &r)) {
            Finished::Answer(outcome) => {
                return Ok(BlockAnswer {
                    x: outcome.x,
                    lambda: outcome.lambda,
                    method: Method::InteriorPoint,
                    iterations: iterations.saturating_add(outcome.iterations),
                    warm,
                    short_of: None,
                });
            }
            Finished::Infeasible(rows) => return Err(BlockFailure::Infeasible(rows)),
            Finished::Spent(n) => iterations = iterations.saturating_add(n),
        }
    }
    if !it.converged {
        if let Some(rows) = farkas(p, &r, &it.lambda) {
            return Err(BlockFailure::Infeasible(rows));
        }
    }
    Err(unsolved(
        iterations,
        &if it.converged {
            "the interior point's answer failed the KKT check".to_string()
        } else {
            format!(
                "the interior point did not converge (accuracy {:.1e})",
                it.accuracy
            )
        },
    ))
}

/// What the active set's finish of an interior point came to.
enum Finished {
    /// An answer to keep.
    Answer(active_set::Outcome),
    /// A certificate that the block's rows are empty.
    Infeasible(Vec<usize>),
    /// No answer to keep, after this many iterations.
    Spent(u32),
}

/// The block's KKT residuals certify `(x, λ)` to the engine's tolerance.
fn certified(context: &Context<'_>, p: &ProjectionProblem, x: &[f64], lambda: &[f64]) -> bool {
    let k = p.kkt_residuals(x, lambda).max();
    k.is_finite() && k <= context.tol
}

/// The active set from the support of the interior point's iterate `it` (of the block whose
/// `y` falls short of its rows by `r`), its first pass alone.
fn finish_interior_point(
    context: &Context<'_>,
    orderings: &mut Orderings,
    block: &Block,
    (it, r): (&ipm::Iterate, &[f64]),
) -> Finished {
    let p = &block.problem;
    let settings = context.settings;
    // The interior point's support, finished when the active set gets there within its cap.
    // The finish's tests are at `1e-12`, and on a sliver of a feasible set an answer that
    // passes them can lie `1e-8` from the projection, farther than the interior point: it is
    // kept only where it agrees with the interior point's answer. An interior point too far
    // short of its tolerance to be kept leaves the finish as the way to an answer: the finish
    // then gets more iterations.
    let cap = if it.converged || it.accuracy <= settings.interior_point.acceptable {
        settings.finish_iterations
    } else {
        settings
            .finish_iterations
            .saturating_mul(UNCONVERGED_FINISH)
    };
    let res = first_pass(p, finish_start(it, r, p), cap, orderings, block);
    let agrees = |x: &[f64]| {
        let apart = x
            .iter()
            .zip(p.y().iter().zip(&it.d))
            .map(|(a, (y, d))| (a - (y + d)).abs())
            .fold(0.0, f64::max);
        apart <= AGREEMENT * it.accuracy.max(settings.interior_point.accuracy) * it.length
    };
    match res {
        Ok(outcome) if certified(context, p, &outcome.x, &outcome.lambda) && agrees(&outcome.x) => {
            Finished::Answer(outcome)
        }
        Ok(outcome) => Finished::Spent(outcome.iterations),
        // A converged interior point says the set has points: a certificate of the
        // finish's tests would be rounding of a set of zero width.
        Err(Failure::Infeasible { rows }) if !it.converged => Finished::Infeasible(rows),
        Err(Failure::Cap(n) | Failure::Cycling(n)) => Finished::Spent(n),
        Err(Failure::Infeasible { .. } | Failure::Numerical(_)) => Finished::Spent(0),
    }
}

/// The active set from `start` for at most `cap` iterations, its factorizations ordered from
/// (and remembered in) `orderings`: the answer of its tests at `1e-12`, which the engine keeps
/// on its KKT certificate. The active set's second pass at `1e-15` moves the congested scenes'
/// answers by far less than the scheme's own error, and on a jam that stands still it cycles
/// through its finishing ladder at every step (measured:
/// `docs/lab/2026-12-04-warm-active-set-first-pass.md`).
fn first_pass(
    p: &ProjectionProblem,
    start: Start,
    cap: u32,
    orderings: &mut Orderings,
    block: &Block,
) -> Result<active_set::Outcome, Failure> {
    let options = Options {
        cap,
        first_pass_only: true,
        memory: Some(Memory {
            orderings,
            unknowns: &block.cols,
        }),
    };
    active_set::solve(p, start, options)
}

/// The active set's start: the remembered multipliers by row key, or, without any, the rows
/// violated at `y` with their own half-space multipliers. Also the longest streak of interior
/// points among the remembered rows, and whether any row was remembered.
fn warm_start(context: &Context<'_>, p: &ProjectionProblem, r: &[f64]) -> (Start, u32, bool) {
    let m = p.n_rows();
    let remembered: Vec<Option<Remembered>> = match (context.settings.warm_start, p.row_keys()) {
        (true, Some(keys)) => keys
            .iter()
            .map(|k| context.memory.get(k).copied())
            .collect(),
        _ => vec![None; m],
    };
    let join: Vec<f64> = (0..m)
        .map(|i| remembered[i].map_or_else(|| own_multiplier(p, i, r[i]), |rem| rem.multiplier))
        .collect();
    // With remembered rows, start from them alone: the rows violated at y join after the
    // first solve if the point still violates them (starting from every violated row too
    // costs more iterations, most of them dropping rows again).
    let warm = remembered.iter().any(Option::is_some);
    let support: Vec<usize> = (0..m)
        .filter(|&i| remembered[i].is_some() || (!warm && r[i] > 0.0))
        .collect();
    let streak = remembered
        .iter()
        .flatten()
        .map(|rem| rem.interior_streak)
        .max()
        .unwrap_or(0);
    let start = Start {
        lambda: support.iter().map(|&i| join[i]).collect(),
        support,
        join,
        join_at_most: None,
    };
    (start, streak, warm)
}

/// The previous projection's multiplier of each row of `p`, matched by row key (`0` for a row
/// it did not have in its support; the memory holds positive multipliers only).
fn remembered_multipliers(context: &Context<'_>, p: &ProjectionProblem) -> Option<Vec<f64>> {
    let keys = p.row_keys()?;
    Some(
        keys.iter()
            .map(|k| context.memory.get(k).map_or(0.0, |rem| rem.multiplier))
            .collect(),
    )
}

/// The active set's start from an interior point's iterate: the rows whose multiplier exceeds
/// their slack, with those multipliers; a row that joins later starts from its iterate's
/// multiplier, and only the most violated row joins at an iteration (rows then also leave one
/// at a time, see [`Start::join_at_most`]): on a jam the guess already holds more rows than
/// unknowns, and rows joining together add dependent ones.
///
/// An interior point that got nowhere near its tolerance (a set with no interior, whose
/// multipliers grow without bound) lends only its support: the multipliers start from the
/// rows' own.
fn finish_start(it: &ipm::Iterate, r: &[f64], p: &ProjectionProblem) -> Start {
    let support: Vec<usize> = (0..it.lambda.len())
        .filter(|&i| it.lambda[i] > it.slack[i])
        .collect();
    let near = it.accuracy <= 1e-3;
    let start = |i: usize| {
        let own = own_multiplier(p, i, r[i]);
        if near {
            it.lambda[i].max(own)
        } else {
            own
        }
    };
    Start {
        lambda: support.iter().map(|&i| start(i)).collect(),
        support,
        join: (0..r.len()).map(start).collect(),
        join_at_most: Some(1),
    }
}

/// The interior point on the block `p` (whose `y` falls short of its rows by `r`), its normal
/// matrix factored in `layout`, from the multipliers `guess` when there are any.
fn interior_point(
    p: &ProjectionProblem,
    r: &[f64],
    layout: Layout,
    settings: &EngineSettings,
    kkt: f64,
    guess: Option<Vec<f64>>,
) -> Result<ipm::Iterate, &'static str> {
    let mut normal = NormalMatrix::with_layout(p.a(), layout)
        .map_err(|_| "the normal matrix could not be analysed")?;
    let warm = guess.as_deref().map(|multipliers| ipm::Warm {
        multipliers,
        floor: settings.interior_point_warm_floor,
    });
    ipm::solve(
        p.a(),
        r,
        &mut normal,
        settings.interior_point,
        kkt,
        settings.interior_point_iterations,
        warm,
    )
    .ok_or("the interior point could not start")
}

/// One row's starting multiplier when it enters the support without a remembered one: the
/// multiplier of its own half-space projection, `max(0, rᵢ)/‖aᵢ‖²`.
fn own_multiplier(p: &ProjectionProblem, i: usize, r: f64) -> f64 {
    let norm2: f64 = p.a().row(i).map(|(_, v)| v * v).sum();
    if norm2 > 0.0 {
        (r.max(0.0) / norm2).max(f64::MIN_POSITIVE)
    } else {
        f64::MIN_POSITIVE
    }
}

/// A block of [`LARGE_BLOCK_ROWS`] rows or more whose rows went to the interior point at the
/// last three projections or more skips the active set, except when that count is a power of
/// two (which finds out when the jam is over). A smaller block always tries it: a jam's small
/// clusters inherit the streak of the large one they were part of, and on them a failed
/// attempt costs less than an interior point's analysis.
fn skips_active_set(streak: u32, rows: usize) -> bool {
    rows >= LARGE_BLOCK_ROWS && streak >= 3 && !streak.is_power_of_two()
}

/// The size of the terms of `b − A y`, `maxᵢ |bᵢ| + Σⱼ |aᵢⱼ yⱼ|`: what its rounding is
/// relative to.
fn rounding_scale(p: &ProjectionProblem) -> f64 {
    let y = p.y();
    (0..p.n_rows())
        .map(|i| p.b()[i].abs() + p.a().row(i).map(|(c, v)| (v * y[c]).abs()).sum::<f64>())
        .fold(f64::MIN_POSITIVE, f64::max)
}

/// A Farkas certificate from diverging multipliers: with `λ̂ = λ/‖λ‖∞ ≥ 0`, every `d` with
/// `A d ≥ r` has `λ̂ᵀr ≤ λ̂ᵀA d ≤ ‖Aᵀλ̂‖₁ ‖d‖∞`, so no such `d` lies within
/// `λ̂ᵀr / ‖Aᵀλ̂‖₁` of `y`. A certificate that rules out every point within [`FARKAS_REACH`]
/// times the block's length scale is taken; the rows it rests on.
fn farkas(p: &ProjectionProblem, r: &[f64], lambda: &[f64]) -> Option<Vec<usize>> {
    let top = lambda.iter().fold(0.0, |acc: f64, l| acc.max(*l));
    if !(top.is_finite() && top > 0.0) {
        return None;
    }
    let hat: Vec<f64> = lambda.iter().map(|l| l / top).collect();
    let mut at = vec![0.0; p.dim()];
    p.a().mul_transpose_vec(&hat, &mut at);
    let combined: f64 = at.iter().map(|v| v.abs()).sum();
    let reads: f64 = hat.iter().zip(r).map(|(h, ri)| h * ri).sum();
    let norms: Vec<f64> = (0..p.n_rows())
        .map(|i| p.a().row(i).map(|(_, v)| v * v).sum::<f64>().sqrt())
        .collect();
    let length = (0..p.n_rows())
        .filter(|&i| norms[i] > 0.0)
        .map(|i| r[i].abs() / norms[i])
        .fold(0.0, f64::max);
    // The certificate's own infeasibility, as a distance: beyond the rounding of the data, or
    // it is a set of zero width (two rows facing each other on one hyperplane) seen through
    // rounding.
    let weight: f64 = hat.iter().zip(&norms).map(|(h, n)| h * n).sum();
    let width = reads / weight.max(f64::MIN_POSITIVE);
    let noise = 1e3 * f64::EPSILON * rounding_scale(p);
    (reads > 0.0 && width > noise && reads >= FARKAS_REACH * length * combined).then(|| {
        (0..p.n_rows())
            .filter(|&i| hat[i] > 1e-9)
            .collect::<Vec<_>>()
    })
}
