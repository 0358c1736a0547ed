//! The [OSQP](https://osqp.org) backend of `sweeping` (osqp 0.6.3, an ADMM solver).
//!
//! # Formulation
//!
//! The projection `min ½‖x − y‖² s.t. A x ≥ b` is handed to OSQP, whose problems read
//! `min ½ dᵀP d + qᵀd s.t. l ≤ A d ≤ u`, as a problem in the **displacement** `d = x − y`:
//!
//! ```text
//!     P = I (upper-triangular CSC),   q = 0,   l = b − A y,   u = 1e30,   x = y + d.
//! ```
//!
//! Solving for `d` rather than for `x` (with `q = −y`) keeps the data independent of where the
//! problem sits in space: crowds live at coordinates ~10², and OSQP's relative stopping rule
//! would otherwise measure the answer against `‖y‖`. The upper bound is OSQP's own "infinity"
//! (`OSQP_INFTY = 1e30`), a large finite number: an infinite bound is not what the C library
//! expects.
//!
//! A problem in a metric `W` has `P = W` (its upper triangle); an equality row has
//! `uᵢ = lᵢ`, and its multiplier `λᵢ = −y_osqp,ᵢ` keeps its sign.
//!
//! # Multipliers
//!
//! OSQP's Lagrangian is `½dᵀPd + qᵀd + y_osqpᵀ(A d − z)`, so its optimality condition is
//! `d + Aᵀ y_osqp = 0` with `y_osqp ≤ 0` on rows active at their lower bound. Ours is
//! `x − y = Aᵀλ`, `λ ≥ 0`: hence `λ = −y_osqp`. The returned multipliers are
//! `λᵢ = max(0, −y_osqp,ᵢ)`. OSQP's dual iterate lies in the normal cone of `[l, u]` at its `z`
//! by construction, so with `u = 1e30` it is never positive and the clamp only guards the
//! contract `λ ≥ 0` (it would matter only if a row could become active at `u`). The multipliers
//! are as accurate as OSQP's dual residual allows: `‖x − y − Aᵀλ‖∞` is within OSQP's
//! tolerance.
//!
//! # Accuracy
//!
//! OSQP's C defaults (`eps_abs = eps_rel = 1e-3`, no polishing) leave answers visibly off
//! on crowd projections, far from what a second opinion must deliver. The defaults of
//! [`OsqpSettings`] are tight, `eps_abs = eps_rel = 1e-9`, so that the KKT residuals are below
//! [`Projector::tolerance`] (`1e-6`; the point error grows with the multipliers at looser
//! settings). [`OsqpSettings::loose`] restores OSQP's own settings for work–precision studies.
//! ADMM converges linearly, so tight tolerances cost iterations, the more so on jammed crowds.
//!
//! Sets whose feasible region is (nearly) a single point, with huge multipliers, are hard for
//! ADMM: a few such random instances end in [`ProjectionError::NotConverged`] after
//! `max_iter` iterations (the coordinate-ascent reference fails on them too).
//!
//! # Warm start
//!
//! [`OsqpProjector`] keeps the OSQP workspace of the previous solve. When the next problem has
//! the same dimension and the same sparsity pattern of `A` ([`SparseRows::same_pattern`]), it
//! updates the values of `A` (only if they changed) and the bounds in place and starts ADMM
//! from the previous displacement and dual (and from the step `rho` adapted so far); otherwise
//! it builds a new workspace, which starts from `d = 0`, i.e. `x = y`, unless both problems
//! carry row keys ([`ProjectionProblem::with_row_keys`]): then the new workspace starts from
//! the last duals of the rows with the same key (`0` for new rows) and the displacement
//! `d = Aᵀλ` they describe, so rows may appear, vanish or be reordered between steps. Keys
//! also re-map the duals when the pattern is unchanged but the rows were reordered. The
//! duals are remembered by key over the last two rounds of solves, not only the last solve's:
//! handed a step block by block ([`sweeping_api::Blocked`]), each block starts from its own
//! rows' duals of the step before, whatever blocks were solved in between.
//! [`SolveStats::warm_started`] tells which happened. A failed solve discards the workspace, so
//! that the next one does not start from its iterates (the duals remembered by key come from
//! converged solves only). Problems without rows, or whose `y` satisfies every row,
//! are answered without calling OSQP ([`Projection::identity`]) and leave the workspace as it
//! was.
//!
//! # Failures
//!
//! Every OSQP status is mapped to a result: `Solved` to an answer, `SolvedInaccurate` to an
//! answer of reduced accuracy when [`OsqpSettings::accept_inaccurate`] is set or when its KKT
//! residuals are within [`Projector::tolerance`] anyway (checked, not trusted: on a jam at
//! tight tolerances OSQP often stops this way with residuals far below that), else to
//! [`ProjectionError::NotConverged`], iteration and time limits to
//! [`ProjectionError::NotConverged`], primal infeasibility to [`ProjectionError::Infeasible`],
//! and the statuses a projection cannot produce (dual infeasibility, non-convexity) to
//! [`ProjectionError::Backend`]. The osqp crate panics when the C library reports an internal
//! error (a failed refactorization, say); those panics are caught and reported as
//! [`ProjectionError::Backend`], and the workspace is then discarded.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

use osqp::{CscMatrix, Problem, Settings, Status};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};
use sweeping_api::{
    FastMap, Metric, Projection, ProjectionError, ProjectionProblem, Projector, RowKey, SolveStats,
    SolveStatus, SparseRows,
};

/// The upper bound of every row: OSQP's own "infinity" (`OSQP_INFTY`), large but finite.
pub const UPPER_BOUND: f64 = 1e30;

/// The name this backend reports.
const NAME: &str = "osqp";

/// Settings of [`OsqpProjector`]: a plain, serialisable value.
///
/// The defaults are tight enough for cross-validation against an interior-point backend; they
/// differ from the C library's (see [`OsqpSettings::loose`]). Missing fields take their
/// default when deserialising. Integer knobs use `0` for "off"/"automatic" where OSQP uses
/// `None`, so that every setting can be written in a configuration file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OsqpSettings {
    /// Absolute tolerance on OSQP's primal and dual residuals (∞-norm). Default `1e-9`
    /// (OSQP: `1e-3`).
    pub eps_abs: f64,
    /// Relative tolerance on OSQP's primal and dual residuals. Default `1e-9` (OSQP: `1e-3`).
    pub eps_rel: f64,
    /// Tolerance of OSQP's primal infeasibility certificate. Default `1e-7` (OSQP: `1e-4`).
    ///
    /// OSQP's own value can certify as infeasible a *feasible* set whose region is (nearly) a
    /// single point; a tighter one does not, and still detects sets infeasible by a margin of
    /// `1e-4` in a few hundred iterations.
    pub eps_prim_inf: f64,
    /// Most ADMM iterations per solve. Default `100_000` (OSQP: `4000`).
    pub max_iter: u32,
    /// Polish the ADMM answer by solving the KKT system of the guessed active set. Default
    /// `false` (OSQP's): on jammed crowds the guess is usually wrong and polishing is wasted
    /// work. A failed polish keeps the ADMM answer, so `true` never makes an answer worse.
    pub polish: bool,
    /// Adapt the ADMM step `rho` during the solve. Default `true` (OSQP's).
    pub adaptive_rho: bool,
    /// Iterations between `rho` adaptations; `0` lets OSQP choose from the measured set-up
    /// time, which makes iteration counts vary from run to run. A fixed value (e.g. `100`)
    /// makes them reproducible. Default `0` (OSQP's).
    pub adaptive_rho_interval: u32,
    /// Initial ADMM step `rho`. Default `0.1` (OSQP's).
    pub rho: f64,
    /// ADMM regularization `sigma`. Default `1e-6` (OSQP's).
    pub sigma: f64,
    /// ADMM relaxation `alpha`, in `(0, 2)`. Default `1.6` (OSQP's).
    pub alpha: f64,
    /// Ruiz scaling iterations; `0` disables scaling. Default `10` (OSQP's).
    pub scaling: u32,
    /// Iterations between termination checks; `0` checks only at `max_iter`. Default `25`
    /// (OSQP's).
    pub check_termination: u32,
    /// Time limit of one solve in seconds (set-up of a new workspace included); `None` for no
    /// limit. Default `None`.
    pub time_limit: Option<f64>,
    /// Whether OSQP's `SolvedInaccurate` (its tolerances met only when multiplied by 10, at
    /// the iteration or time limit) is accepted, as [`SolveStatus::SolvedReducedAccuracy`];
    /// when `false` it is kept only if its KKT residuals are within
    /// [`Projector::tolerance`], and is [`ProjectionError::NotConverged`] otherwise. Default
    /// `false`.
    pub accept_inaccurate: bool,
    /// Reuse the workspace and start from the previous answer when the sparsity pattern of `A`
    /// is unchanged; when `false` every solve builds a new workspace and starts from `x = y`.
    /// Default `true`.
    pub warm_start: bool,
    /// Let OSQP print its progress to standard output. Default `false`.
    pub verbose: bool,
}

impl Default for OsqpSettings {
    fn default() -> Self {
        Self {
            eps_abs: 1e-9,
            eps_rel: 1e-9,
            eps_prim_inf: 1e-7,
            max_iter: 100_000,
            polish: false,
            adaptive_rho: true,
            adaptive_rho_interval: 0,
            rho: 0.1,
            sigma: 1e-6,
            alpha: 1.6,
            scaling: 10,
            check_termination: 25,
            time_limit: None,
            accept_inaccurate: false,
            warm_start: true,
            verbose: false,
        }
    }
}

impl OsqpSettings {
    /// OSQP's own C defaults for every solver knob (`eps_abs = eps_rel = 1e-3`,
    /// `eps_prim_inf = 1e-4`, `max_iter = 4000`, no polishing), for work–precision studies.
    /// Fast, but answers may be off by ~10⁻² on crowds: not fit for cross-validation, and a
    /// run needs `StepperSettings::kkt_tolerance` of about `1e-2` to accept them (the default
    /// `1e-6` refuses them with `SweepError::KktCheckFailed`). The
    /// fields that are ours ([`accept_inaccurate`](Self::accept_inaccurate),
    /// [`warm_start`](Self::warm_start), [`verbose`](Self::verbose),
    /// [`time_limit`](Self::time_limit)) keep their defaults.
    pub fn loose() -> Self {
        Self {
            eps_abs: 1e-3,
            eps_rel: 1e-3,
            eps_prim_inf: 1e-4,
            max_iter: 4000,
            ..Self::default()
        }
    }

    /// A deprecated alias of [`loose`](Self::loose), whose name matches
    /// `ClarabelSettings::loose`.
    #[deprecated(
        since = "0.1.0",
        note = "renamed `OsqpSettings::loose`, as for Clarabel"
    )]
    pub fn preset_loose() -> Self {
        Self::loose()
    }

    /// Checks the settings before they reach the C library (which, for instance, accepts a
    /// NaN `rho`).
    ///
    /// # Errors
    /// A message naming the first invalid setting.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} = {v} must be finite and positive"))
            }
        };
        let non_negative = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} = {v} must be finite and non-negative"))
            }
        };
        non_negative("eps_abs", self.eps_abs)?;
        non_negative("eps_rel", self.eps_rel)?;
        if self.eps_abs == 0.0 && self.eps_rel == 0.0 {
            return Err("eps_abs and eps_rel cannot both be zero".into());
        }
        non_negative("eps_prim_inf", self.eps_prim_inf)?;
        positive("rho", self.rho)?;
        positive("sigma", self.sigma)?;
        if !(self.alpha > 0.0 && self.alpha < 2.0) {
            return Err(format!("alpha = {} must lie in (0, 2)", self.alpha));
        }
        let int_limit = i32::MAX as u32;
        for (name, v) in [
            ("max_iter", self.max_iter),
            ("adaptive_rho_interval", self.adaptive_rho_interval),
            ("scaling", self.scaling),
            ("check_termination", self.check_termination),
        ] {
            if v > int_limit {
                return Err(format!("{name} = {v} exceeds {int_limit}"));
            }
        }
        if self.max_iter == 0 {
            return Err("max_iter must be positive".into());
        }
        if let Some(t) = self.time_limit {
            non_negative("time_limit", t)?;
            Duration::try_from_secs_f64(t).map_err(|e| format!("time_limit = {t}: {e}"))?;
        }
        Ok(())
    }

    /// The osqp crate's settings (after [`validate`](Self::validate)).
    fn to_osqp(&self) -> Result<Settings, String> {
        self.validate()?;
        let optional = |v: u32| (v > 0).then_some(v);
        let time_limit = match self.time_limit {
            Some(t) => {
                Some(Duration::try_from_secs_f64(t).map_err(|e| format!("time_limit: {e}"))?)
            }
            None => None,
        };
        Ok(Settings::default()
            .eps_abs(self.eps_abs)
            .eps_rel(self.eps_rel)
            .eps_prim_inf(self.eps_prim_inf)
            .max_iter(self.max_iter)
            .polish(self.polish)
            .adaptive_rho(self.adaptive_rho)
            .adaptive_rho_interval(optional(self.adaptive_rho_interval))
            .rho(self.rho)
            .sigma(self.sigma)
            .alpha(self.alpha)
            .scaling(optional(self.scaling))
            .check_termination(optional(self.check_termination))
            .time_limit(time_limit)
            .warm_start(self.warm_start)
            .verbose(self.verbose))
    }
}

/// A workspace kept between solves for warm starting.
struct Cache {
    problem: Problem,
    /// `A` as it was last given to OSQP (pattern and values).
    a: SparseRows,
    /// The metric `P = W` the workspace was set up with.
    metric: Metric,
    /// The last converged displacement `d`.
    d: Vec<f64>,
    /// The last converged OSQP dual (`−λ`, unclamped).
    y_osqp: Vec<f64>,
    /// The row keys of the last problem, when it had them.
    keys: Option<Vec<RowKey>>,
}

/// The last converged OSQP dual (`−λ`) of every keyed row, over the last two rounds of solves.
///
/// A step handed over block by block solves each of its blocks after others, so the last
/// solve's duals rarely hold the next block's rows; these do. Within one step the blocks'
/// rows are disjoint, so a solve meeting a key already written in the current round starts
/// a new round (a new step began): the current round becomes the older one, and the one
/// before is forgotten. Memory is then about two steps' rows; a round is also closed at
/// [`KeyedDuals::ROUND_CAP`] keys, for callers whose keys never repeat.
#[derive(Debug)]
struct KeyedDuals {
    current: FastMap<RowKey, f64>,
    older: FastMap<RowKey, f64>,
    /// The most keys a round holds.
    round_cap: usize,
}

impl Default for KeyedDuals {
    fn default() -> Self {
        Self::with_round_cap(Self::ROUND_CAP)
    }
}

impl KeyedDuals {
    /// The most keys a round holds by default (24 bytes each and the map's overhead: about
    /// 100 MiB).
    const ROUND_CAP: usize = 1 << 22;

    fn with_round_cap(round_cap: usize) -> Self {
        Self {
            current: FastMap::default(),
            older: FastMap::default(),
            round_cap,
        }
    }

    /// The last dual of the row `key`, if it was solved in this round or the one before.
    fn get(&self, key: &RowKey) -> Option<f64> {
        self.current
            .get(key)
            .or_else(|| self.older.get(key))
            .copied()
    }

    /// Remembers a converged solve's duals.
    fn record(&mut self, keys: &[RowKey], y_osqp: &[f64]) {
        if self.current.len() + keys.len() > self.round_cap
            || keys.iter().any(|k| self.current.contains_key(k))
        {
            self.older = std::mem::take(&mut self.current);
        }
        self.current
            .extend(keys.iter().copied().zip(y_osqp.iter().copied()));
    }
}

/// OSQP's dual `−λ` for the rows of `problem`, the last duals of the rows with the same key
/// (`0` for rows without one), and the displacement `d = Aᵀλ` it describes.
fn keyed_start(
    problem: &ProjectionProblem,
    keys: &[RowKey],
    duals: &KeyedDuals,
) -> (Vec<f64>, Vec<f64>) {
    let y_osqp: Vec<f64> = keys
        .iter()
        .map(|k| duals.get(k).unwrap_or(0.0).min(0.0))
        .collect();
    let lambda: Vec<f64> = y_osqp.iter().map(|v| -v).collect();
    let mut d = vec![0.0; problem.dim()];
    problem.a().mul_transpose_vec(&lambda, &mut d);
    (d, y_osqp)
}

/// How a solve ended, read out of OSQP's borrowed status.
enum Outcome {
    Converged {
        accurate: bool,
        d: Vec<f64>,
        y_osqp: Vec<f64>,
    },
    Error(ProjectionError),
}

/// Projection by OSQP, with warm start across steps of a time loop.
///
/// ```
/// use sweeping_api::{ProjectionProblem, Projector, SparseRows};
/// use sweeping_osqp::OsqpProjector;
///
/// // Project (0, 0) onto x₀ + x₁ ≥ 2, then a nearby point with the same pattern.
/// let a = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 1.0)]]);
/// let mut osqp = OsqpProjector::default();
/// let p = ProjectionProblem::new(vec![0.0, 0.0], a.clone(), vec![2.0]).unwrap();
/// let sol = osqp.project(&p).unwrap();
/// assert!((sol.x[0] - 1.0).abs() < 1e-6 && (sol.x[1] - 1.0).abs() < 1e-6);
/// assert!((sol.multipliers[0] - 1.0).abs() < 1e-6);
/// assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() < osqp.tolerance());
///
/// let q = ProjectionProblem::new(vec![0.5, 0.0], a, vec![2.0]).unwrap();
/// let sol = osqp.project(&q).unwrap();
/// assert!(sol.stats.warm_started);
/// assert!((sol.x[0] - 1.25).abs() < 1e-6 && (sol.x[1] - 0.75).abs() < 1e-6);
/// ```
pub struct OsqpProjector {
    settings: OsqpSettings,
    cache: Option<Cache>,
    /// The duals of keyed rows, for the keyed warm start of a new workspace.
    duals: KeyedDuals,
}

impl Default for OsqpProjector {
    /// A projector with [`OsqpSettings::default`].
    fn default() -> Self {
        Self::new(OsqpSettings::default())
    }
}

impl std::fmt::Debug for OsqpProjector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OsqpProjector")
            .field("settings", &self.settings)
            .field("has_workspace", &self.cache.is_some())
            .finish()
    }
}

impl OsqpProjector {
    /// A projector with the given settings (checked at the first solve: invalid settings make
    /// every solve fail with [`ProjectionError::Backend`]).
    pub fn new(settings: OsqpSettings) -> Self {
        Self {
            settings,
            cache: None,
            duals: KeyedDuals::default(),
        }
    }

    /// The settings in use.
    pub fn settings(&self) -> &OsqpSettings {
        &self.settings
    }

    /// Forgets the kept workspace and the duals remembered by key: the next solve builds a new
    /// workspace and starts from `x = y`.
    pub fn reset(&mut self) {
        self.cache = None;
        self.duals = KeyedDuals::default();
    }

    fn backend_error(message: impl Into<String>) -> ProjectionError {
        ProjectionError::Backend {
            backend: NAME.to_string(),
            message: message.into(),
        }
    }

    /// A fresh OSQP workspace for `problem` (`P = I`, `q = 0`, bounds `l ≤ A d ≤ u`).
    fn set_up(
        &self,
        problem: &ProjectionProblem,
        (col_ptr, row_idx, values): (Vec<usize>, Vec<usize>, Vec<f64>),
        l: &[f64],
        u: &[f64],
    ) -> Result<Cache, ProjectionError> {
        let m = problem.n_rows();
        let osqp_settings = self
            .settings
            .to_osqp()
            .map_err(|e| Self::backend_error(format!("invalid settings: {e}")))?;
        let n = problem.dim();
        let (p_ptr, p_idx, p_values) = problem.metric().upper_triangle_csc(n);
        let metric = CscMatrix {
            nrows: n,
            ncols: n,
            indptr: Cow::Owned(p_ptr),
            indices: Cow::Owned(p_idx),
            data: Cow::Owned(p_values),
        };
        let a_csc = CscMatrix {
            nrows: m,
            ncols: n,
            indptr: Cow::Owned(col_ptr),
            indices: Cow::Owned(row_idx),
            data: Cow::Owned(values),
        };
        let q = vec![0.0; n];
        let built = catch_unwind(AssertUnwindSafe(|| {
            Problem::new(metric, &q, a_csc, l, u, &osqp_settings)
        }));
        let problem_osqp = match built {
            Ok(Ok(p)) => p,
            Ok(Err(e)) => {
                let hint = if matches!(e, osqp::SetupError::DataInvalid(_)) {
                    " (a row with a repeated column makes A invalid)"
                } else {
                    ""
                };
                return Err(Self::backend_error(format!(
                    "OSQP set-up failed: {e}{hint}"
                )));
            }
            Err(_) => return Err(Self::backend_error("OSQP set-up panicked")),
        };
        Ok(Cache {
            problem: problem_osqp,
            a: problem.a().clone(),
            metric: problem.metric().clone(),
            d: vec![0.0; n],
            y_osqp: vec![0.0; m],
            keys: None,
        })
    }

    /// The OSQP workspace for `problem`: the last one updated in place when the pattern of `A`
    /// and the metric are unchanged (warm-started from the last answer, or from the duals by
    /// row key when the rows were reordered), a new one otherwise (warm-started by key when
    /// rows were solved before). Also says whether the solve starts warm.
    fn workspace(
        &mut self,
        problem: &ProjectionProblem,
        l: &[f64],
        u: &[f64],
    ) -> Result<(Cache, bool), ProjectionError> {
        let settings = &self.settings;
        let a = problem.a();
        let m = problem.n_rows();
        let (col_ptr, row_idx, values) = a.to_csc();
        let reusable = settings.warm_start
            && self.cache.as_ref().is_some_and(|c| {
                c.a.same_pattern(a) && c.d.len() == problem.dim() && c.metric == *problem.metric()
            });
        let keys = problem.row_keys();
        let mut keyed_warm = false;
        let cache = if reusable {
            let mut cache = self.cache.take().expect("checked above");
            if let (Some(new), Some(old)) = (keys, cache.keys.as_deref()) {
                if new != old {
                    // Same pattern, other rows (reordered): start from the duals by key.
                    (cache.d, cache.y_osqp) = keyed_start(problem, new, &self.duals);
                }
            }
            let values_changed = cache.a.values() != a.values();
            let updated = catch_unwind(AssertUnwindSafe(|| {
                if values_changed {
                    cache.problem.update_A(CscMatrix {
                        nrows: m,
                        ncols: problem.dim(),
                        indptr: Cow::Borrowed(&col_ptr),
                        indices: Cow::Borrowed(&row_idx),
                        data: Cow::Borrowed(&values),
                    });
                }
                cache.problem.update_bounds(l, u);
                cache.problem.warm_start(&cache.d, &cache.y_osqp);
            }));
            if updated.is_err() {
                // The workspace may be inconsistent: drop it (self.cache is already None).
                return Err(Self::backend_error(
                    "updating the OSQP workspace failed (see the message above)",
                ));
            }
            if values_changed {
                cache.a = a.clone();
            }
            cache
        } else {
            self.cache = None;
            let mut cache = self.set_up(problem, (col_ptr, row_idx, values), l, u)?;
            // The pattern changed (rows appeared, vanished or moved; on a step handed over
            // block by block, another block): with keys, start from the last duals of the
            // rows that were solved before.
            if let (true, Some(new)) = (settings.warm_start, keys) {
                let (d0, y0) = keyed_start(problem, new, &self.duals);
                if y0.iter().any(|v| *v != 0.0) {
                    let started =
                        catch_unwind(AssertUnwindSafe(|| cache.problem.warm_start(&d0, &y0)));
                    if started.is_err() {
                        return Err(Self::backend_error(
                            "warm-starting the OSQP workspace failed (see the message above)",
                        ));
                    }
                    keyed_warm = true;
                }
            }
            cache
        };
        Ok((cache, reusable || keyed_warm))
    }

    /// Solves a problem that needs the solver (`y` violates a row, `A` has columns).
    fn solve(
        &mut self,
        problem: &ProjectionProblem,
        l: Vec<f64>,
    ) -> Result<Projection, ProjectionError> {
        let m = problem.n_rows();
        // An equality row is `lᵢ ≤ (A d)ᵢ ≤ uᵢ` with `uᵢ = lᵢ`.
        let k = problem.equalities();
        let u: Vec<f64> = (0..m)
            .map(|i| if i < k { l[i] } else { UPPER_BOUND })
            .collect();

        let setup_start = Instant::now();
        let keys = problem.row_keys();
        let (mut cache, warm_started) = self.workspace(problem, &l, &u)?;
        cache.keys = keys.map(<[RowKey]>::to_vec);
        let setup_seconds = setup_start.elapsed().as_secs_f64();

        let solve_start = Instant::now();
        let accept_inaccurate = self.settings.accept_inaccurate;
        let solved = catch_unwind(AssertUnwindSafe(|| read_status(cache.problem.solve())));
        let solve_seconds = solve_start.elapsed().as_secs_f64();
        let (outcome, iterations) = match solved {
            Ok(r) => r,
            Err(_) => {
                return Err(Self::backend_error(
                    "OSQP reported an internal error during the solve (see the message above)",
                ))
            }
        };

        match outcome {
            Outcome::Converged {
                accurate,
                d,
                y_osqp,
            } => {
                if d.iter().chain(&y_osqp).any(|v| !v.is_finite()) {
                    return Err(Self::backend_error(
                        "OSQP returned a non-finite answer with a converged status",
                    ));
                }
                let x: Vec<f64> = problem.y().iter().zip(&d).map(|(y, d)| y + d).collect();
                // An equality's multiplier has either sign.
                let multipliers: Vec<f64> = y_osqp
                    .iter()
                    .enumerate()
                    .map(|(i, y)| if i < k { -y } else { (-y).max(0.0) })
                    .collect();
                if !accurate && !accept_inaccurate {
                    // OSQP's own inaccurate flag is about its scaled residuals; what the
                    // caller needs is the KKT conditions of the projection within
                    // `tolerance()`. Keep the answer only when they hold.
                    let kkt = problem.kkt_residuals(&x, &multipliers).max();
                    if kkt.is_nan() || kkt > self.tolerance() {
                        return Err(ProjectionError::NotConverged {
                            backend: NAME.to_string(),
                            iterations,
                            status: format!(
                                "solved inaccurate, KKT residual {kkt:.2e} > {:.1e}",
                                self.tolerance()
                            ),
                        });
                    }
                }
                if let (true, Some(keys)) = (self.settings.warm_start, keys) {
                    self.duals.record(keys, &y_osqp);
                }
                cache.d = d;
                cache.y_osqp = y_osqp;
                self.cache = Some(cache);
                Ok(Projection {
                    x,
                    multipliers,
                    stats: SolveStats {
                        backend: NAME.to_string(),
                        status: if accurate {
                            SolveStatus::Solved
                        } else {
                            SolveStatus::SolvedReducedAccuracy
                        },
                        iterations,
                        solve_seconds,
                        setup_seconds,
                        warm_started,
                        counters: sweeping_api::BackendCounters::default(),
                    },
                })
            }
            // A failed solve leaves iterates not worth starting from: drop the workspace.
            Outcome::Error(e) => Err(e),
        }
    }
}

/// Maps every OSQP status to an outcome, with the iteration count.
fn read_status(status: Status<'_>) -> (Outcome, u32) {
    let not_converged = |iterations: u32, status: &str| {
        Outcome::Error(ProjectionError::NotConverged {
            backend: NAME.to_string(),
            iterations,
            status: status.to_string(),
        })
    };
    // The rows of OSQP's certificate `δy` (`Aᵀδy = 0`, and a combination of the bounds
    // that reads `0 ≥ positive`): those where it is not negligible.
    let infeasible = |detail: &str, delta_y: &[f64]| {
        Outcome::Error(ProjectionError::Infeasible {
            backend: NAME.to_string(),
            detail: detail.to_string(),
            rows: sweeping_api::certificate_rows(delta_y),
        })
    };
    let failure = |message: &str| Outcome::Error(OsqpProjector::backend_error(message));
    match status {
        // Read an inaccurate answer too: when it is not accepted as such, `solve` still keeps
        // it if its KKT residuals are within `tolerance()` (checked, not trusted).
        Status::Solved(ref s) | Status::SolvedInaccurate(ref s) => (
            Outcome::Converged {
                accurate: matches!(status, Status::Solved(_)),
                d: s.x().to_vec(),
                y_osqp: s.y().to_vec(),
            },
            status.iter(),
        ),
        Status::MaxIterationsReached(_) => (
            not_converged(status.iter(), "maximum iterations reached"),
            status.iter(),
        ),
        Status::TimeLimitReached(_) => (
            not_converged(status.iter(), "time limit reached"),
            status.iter(),
        ),
        Status::PrimalInfeasible(ref cert) => (
            infeasible("OSQP status: primal infeasible", cert.delta_y()),
            status.iter(),
        ),
        Status::PrimalInfeasibleInaccurate(ref cert) => (
            infeasible(
                "OSQP status: primal infeasible (inaccurate)",
                cert.delta_y(),
            ),
            status.iter(),
        ),
        Status::DualInfeasible(_) | Status::DualInfeasibleInaccurate(_) => (
            failure(
                "OSQP reported dual infeasibility, impossible for a projection \
                 (its objective is bounded below): numerical trouble",
            ),
            status.iter(),
        ),
        Status::NonConvex(_) => (
            failure(
                "OSQP reported a non-convex problem (its residuals diverged past 1e30): \
                 the problem is badly scaled",
            ),
            status.iter(),
        ),
        // osqp 0.6.3 marks `Status` non-exhaustive with this hidden variant instead of
        // `#[non_exhaustive]`; it is never constructed, and naming it keeps this match free of
        // a wildcard, so a new status in another version fails to compile here.
        Status::__Nonexhaustive => (failure("OSQP returned an unknown status"), 0),
    }
}

impl Projector for OsqpProjector {
    fn name(&self) -> &str {
        NAME
    }

    /// `1000 × max(eps_abs, eps_rel)`: `1e-6` with the defaults.
    ///
    /// OSQP bounds its primal and dual residuals; the KKT residual that dominates is
    /// complementarity, `λᵢ (Ax − b)ᵢ`, which is the primal residual times a multiplier: the
    /// factor covers multipliers up to ~10³, as on the conformance kit's random instances.
    fn tolerance(&self) -> f64 {
        1000.0 * self.settings.eps_abs.max(self.settings.eps_rel)
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        if problem.n_rows() == 0 {
            return Ok(Projection::identity(problem, NAME));
        }
        let mut ay = vec![0.0; problem.n_rows()];
        problem.a().mul_vec(problem.y(), &mut ay);
        // Clamped below at OSQP's −∞ (such a row is slack anyway); a NaN stays NaN.
        let l: Vec<f64> = problem
            .b()
            .iter()
            .zip(&ay)
            .map(|(b, ay)| {
                let v = b - ay;
                if v < -UPPER_BOUND {
                    -UPPER_BOUND
                } else {
                    v
                }
            })
            .collect();
        let k = problem.equalities();
        if l.iter()
            .enumerate()
            .all(|(i, v)| *v <= 0.0 && (i >= k || *v == 0.0))
        {
            return Ok(Projection::identity(problem, NAME));
        }
        if problem.dim() == 0 {
            // Rows without coordinates read 0 ≥ bᵢ, and one of them has bᵢ > 0.
            return Err(ProjectionError::Infeasible {
                backend: NAME.to_string(),
                detail: "no coordinates, and a row requires 0 ≥ b with b > 0".into(),
                rows: (0..problem.n_rows())
                    .filter(|&i| problem.b()[i] > 0.0 || (i < k && problem.b()[i] != 0.0))
                    .collect(),
            });
        }
        if let Some(i) = l.iter().position(|v| v.is_nan() || *v >= UPPER_BOUND) {
            return Err(Self::backend_error(format!(
                "b − A y = {:e} at row {i} is out of OSQP's range (|·| < 1e30)",
                l[i]
            )));
        }
        self.solve(problem, l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(member: u64) -> RowKey {
        RowKey { family: 0, member }
    }

    /// Records the rows `members`, each with the dual `−member`.
    fn record(duals: &mut KeyedDuals, members: &[u64]) {
        let keys: Vec<RowKey> = members.iter().map(|&m| key(m)).collect();
        let y: Vec<f64> = members.iter().map(|&m| -(m as f64)).collect();
        duals.record(&keys, &y);
    }

    fn known(duals: &KeyedDuals, members: &[u64]) -> Vec<bool> {
        members
            .iter()
            .map(|&m| duals.get(&key(m)).is_some())
            .collect()
    }

    /// A step's blocks are disjoint: they all stay in the round. A key met again starts a new
    /// round, and the round before the last is forgotten.
    #[test]
    fn a_round_ends_when_a_key_comes_back() {
        let mut duals = KeyedDuals::default();
        record(&mut duals, &[1, 2]);
        record(&mut duals, &[3]);
        record(&mut duals, &[4, 5]);
        assert_eq!(known(&duals, &[1, 2, 3, 4, 5]), [true; 5]);
        // The next step: row 1 again. Rows 2–5 are in the round before.
        record(&mut duals, &[1]);
        assert_eq!(known(&duals, &[1, 2, 3, 4, 5]), [true; 5]);
        record(&mut duals, &[3]);
        assert_eq!(duals.get(&key(3)), Some(-3.0));
        // A third step: rows 2, 4 and 5 were last solved two rounds ago.
        record(&mut duals, &[1, 6]);
        assert_eq!(
            known(&duals, &[1, 2, 3, 4, 5, 6]),
            [true, false, true, false, false, true]
        );
    }

    /// Keys that never come back close a round at its cap.
    #[test]
    fn a_round_ends_at_its_cap() {
        let mut duals = KeyedDuals::with_round_cap(3);
        record(&mut duals, &[1, 2]);
        // Three keys: the cap, not past it.
        record(&mut duals, &[3]);
        // Past it: the round {1, 2, 3} is the older one, {4} the current…
        record(&mut duals, &[4]);
        // …which reaches the cap again.
        record(&mut duals, &[5, 6]);
        assert_eq!(known(&duals, &[1, 2, 3, 4, 5, 6]), [true; 6]);
        record(&mut duals, &[7]);
        // {4, 5, 6} and 7 make four: {1, 2, 3} is forgotten.
        assert_eq!(
            known(&duals, &[1, 2, 3, 4, 5, 6, 7]),
            [false, false, false, true, true, true, true]
        );
    }
}
