//! A primal–dual interior-point method (Mehrotra's predictor–corrector) for one block, on the
//! normal equations.
//!
//! With `d = x − y` and `r = b − A y` the projection is `min ½‖d‖²` subject to `A d − s = r`,
//! `s ≥ 0`; its KKT conditions are `d = Aᵀλ`, `A d − s = r`, `λ ∘ s = 0`, `λ, s ≥ 0`. A Newton
//! step on them with `λ ∘ s = σμ` eliminates `Δs = A Δd + r_p` and `Δλ = −r_c/s − W (A Δd +
//! r_p)`, `W = diag(λ/s)`, leaving
//!
//! ```text
//!     (I + AᵀWA) Δd = −r_d − Aᵀ(W r_p + r_c/s),
//! ```
//!
//! `n × n` and positive definite whatever the rows ([`NormalMatrix`]). Rows that outnumber
//! the unknowns, linearly dependent rows, multipliers that are not unique: none of it changes
//! this system, which is why the method is the engine's answer to a jam. Its iterates reach
//! rows that are tight with a zero multiplier (weakly active) only like `√μ`, so it runs until
//! the duality gap is small against the squared step (see [`Tolerance`]), not to a fixed `μ`.
//!
//! It starts from Mehrotra's point, or from given multipliers (a [`Warm`] start: the previous
//! projection's, matched by row keys), `d = Aᵀλ` and the slacks that `d` leaves, both raised to
//! a floor proportional to the block's length scale: from one step of a door queue to the next
//! the forces change little, and such a start saves the first iterations.

use crate::normal::NormalMatrix;
use sweeping_api::SparseRows;

/// Fraction of the step to the boundary that an iteration takes.
const TO_BOUNDARY: f64 = 0.99;

/// Most refinement steps of a direction against the whole Newton system.
const REFINEMENTS: usize = 4;

/// Iterations without the residuals or `μ` halving after which the method stops.
const STALLED: u32 = 10;

/// The same, once the best iterate is certifiable and within [`Tolerance::acceptable`]: the
/// engine would take it, and waiting [`STALLED`] iterations for progress rarely improves on it
/// (measured: `docs/lab/2026-12-05-interior-point-settled.md`).
const SETTLED: u32 = 3;

/// The least slack and multiplier, against the length scale.
const FLOOR: f64 = 1e-30;

/// The duality measure, against the squared length scale, from which every solve is refined.
const LATE: f64 = 1e-8;

/// When the method stops: the accuracy contract of an interior-point answer.
///
/// Lengths are measured against the block's own length scale `S = maxᵢ |rᵢ|/‖aᵢ‖`, the
/// farthest that `y` lies from a row's hyperplane. The method stops when the primal
/// residuals (as distances, `|A d − s − r|ᵢ/‖aᵢ‖`), the dual residual `‖d − Aᵀλ‖∞` and the
/// last Newton direction `‖Δd‖∞` are all at most `accuracy · S`, and the duality measure
/// `μ = sᵀλ/m` at most `accuracy · S²`. Near the answer the method converges linearly, so the
/// last direction measures how far the step still is from the answer; a bound from the gap
/// alone (`‖d − d*‖₂ ≤ ‖r_d‖₂ + √(sᵀλ)`) would be far too pessimistic to stop on, since the
/// iterates reach rows that are tight with a zero multiplier only like `√μ`.
///
/// A run that stops short of `accuracy` (its progress stalled: on a jam the directions'
/// rounding, with weights spanning twenty orders of magnitude, sets a floor) returns its best
/// iterate; the engine takes it as the answer when it lies within `acceptable` and passes the
/// KKT check, and the run stops waiting for progress soon after it has such an iterate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Target accuracy against the block's length scale. Default `1e-10`.
    pub accuracy: f64,
    /// The accuracy, against the block's length scale, of an iterate short of `accuracy`
    /// that is still an answer; `0` (or a negative number, or NaN) accepts none. Default
    /// `1e-6` (a micrometre on a metre's jam).
    pub acceptable: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Self {
            accuracy: 1e-10,
            acceptable: 1e-6,
        }
    }
}

/// A start from given multipliers instead of Mehrotra's point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Warm<'a> {
    /// One multiplier per row (`0` for a row without a guess).
    pub(crate) multipliers: &'a [f64],
    /// The least slack and multiplier of the start, against the block's length scale: off the
    /// boundary, where the first directions can still move.
    pub(crate) floor: f64,
}

/// Where the method stopped.
#[derive(Debug, Clone)]
pub struct Iterate {
    /// The step `d = x − y`.
    pub d: Vec<f64>,
    /// The multipliers `λ > 0`.
    pub lambda: Vec<f64>,
    /// The slacks `s > 0`.
    pub slack: Vec<f64>,
    /// Iterations (one factorization each).
    pub iterations: u32,
    /// Whether the tolerance was met.
    pub converged: bool,
    /// How far the iterate is from the tolerance's tests: the largest of the residuals, the
    /// last direction and `μ/S`, against `S` (see [`Tolerance`]).
    pub accuracy: f64,
    /// The block's length scale `S`.
    pub length: f64,
}

/// The block's data and the work vectors of one run.
struct Run<'a> {
    a: &'a SparseRows,
    r: &'a [f64],
    normal: &'a mut NormalMatrix,
    w: Vec<f64>,
    row_work: Vec<f64>,
    scratch: Scratch,
}

/// The right-hand sides, residuals and corrections of [`Run::direction`], kept from one
/// iteration to the next.
#[derive(Default)]
struct Scratch {
    r1: Vec<f64>,
    r2: Vec<f64>,
    r3: Vec<f64>,
    e1: Vec<f64>,
    e2: Vec<f64>,
    e3: Vec<f64>,
    cd: Vec<f64>,
    cl: Vec<f64>,
    cs: Vec<f64>,
}

/// The residuals of an iterate.
struct Residuals {
    /// `d − Aᵀλ`.
    dual: Vec<f64>,
    /// `A d − s − r`.
    primal: Vec<f64>,
}

impl Run<'_> {
    /// The solution `(δd, δλ, δs)` of the Newton system at the iterate `(λ, s)`,
    ///
    /// ```text
    ///     δd − Aᵀδλ = r₁,   A δd − δs = r₂,   S δλ + Λ δs = r₃,
    /// ```
    ///
    /// by elimination: `δs = A δd − r₂`, `δλ = r₃/s − W(A δd − r₂)` and
    /// `(I + AᵀWA) δd = r₁ + Aᵀ(r₃/s + W r₂)`.
    fn eliminate(
        &mut self,
        slack: &[f64],
        (r1, r2, r3): (&[f64], &[f64], &[f64]),
        (dd, dl, ds): (&mut [f64], &mut [f64], &mut [f64]),
    ) {
        let m = slack.len();
        for i in 0..m {
            self.row_work[i] = r3[i] / slack[i] + self.w[i] * r2[i];
        }
        self.a.mul_transpose_vec(&self.row_work, dd);
        dd.iter_mut().zip(r1).for_each(|(v, r)| *v += r);
        self.normal.solve(dd);
        self.a.mul_vec(dd, ds);
        for i in 0..m {
            ds[i] -= r2[i];
            dl[i] = r3[i] / slack[i] - self.w[i] * ds[i];
        }
    }

    /// The direction `(Δd, Δλ, Δs)` for the complementarity residual `r_c` (`λ ∘ s` minus
    /// what it should become): the Newton system with `r₁ = −r_d`, `r₂ = −r_p`, `r₃ = −r_c`,
    /// and, when `refine`, one step of refinement against the whole system. Near the answer
    /// `W` spans twenty orders of magnitude, and `δλ = … − W(A δd − r₂)` multiplies the
    /// rounding of `δd` by it; the whole system's residual sees that error (in its first
    /// equation), the normal equations' does not.
    fn direction(
        &mut self,
        (lambda, slack): (&[f64], &[f64]),
        res: &Residuals,
        r_c: &[f64],
        refine: bool,
        (dd, dl, ds): (&mut [f64], &mut [f64], &mut [f64]),
    ) {
        let (m, n) = (slack.len(), dd.len());
        let mut sc = std::mem::take(&mut self.scratch);
        let negated = |out: &mut Vec<f64>, v: &[f64]| {
            out.clear();
            out.extend(v.iter().map(|x| -x));
        };
        negated(&mut sc.r1, &res.dual);
        negated(&mut sc.r2, &res.primal);
        negated(&mut sc.r3, r_c);
        self.eliminate(slack, (&sc.r1, &sc.r2, &sc.r3), (dd, dl, ds));
        if refine {
            let size = inf_norm(dd).max(inf_norm(ds)).max(
                (0..m)
                    .map(|i| (dl[i] * slack[i] / lambda[i]).abs())
                    .fold(0.0, f64::max),
            );
            for v in [&mut sc.e1, &mut sc.cd] {
                v.resize(n, 0.0);
            }
            for v in [&mut sc.e2, &mut sc.e3, &mut sc.cl, &mut sc.cs] {
                v.resize(m, 0.0);
            }
            let mut last = f64::INFINITY;
            for _ in 0..REFINEMENTS {
                // e₁ = r₁ − (δd − Aᵀδλ), e₂ = r₂ − (A δd − δs), e₃ = r₃ − (S δλ + Λ δs).
                self.a.mul_transpose_vec(dl, &mut sc.e1);
                for ((e, r), d) in sc.e1.iter_mut().zip(&sc.r1).zip(dd.iter()) {
                    *e += r - d;
                }
                self.a.mul_vec(dd, &mut sc.e2);
                for i in 0..m {
                    sc.e2[i] = sc.r2[i] - sc.e2[i] + ds[i];
                    sc.e3[i] = sc.r3[i] - slack[i] * dl[i] - lambda[i] * ds[i];
                }
                let off = inf_norm(&sc.e1).max(inf_norm(&sc.e2)).max(
                    (0..m)
                        .map(|i| (sc.e3[i] / lambda[i]).abs())
                        .fold(0.0, f64::max),
                );
                // Residuals at the rounding of the direction's own size need no correction.
                let shrinking = off < 0.5 * last;
                if !shrinking || off <= size * 1e-14 {
                    break;
                }
                last = off;
                self.eliminate(
                    slack,
                    (&sc.e1, &sc.e2, &sc.e3),
                    (&mut sc.cd, &mut sc.cl, &mut sc.cs),
                );
                dd.iter_mut().zip(&sc.cd).for_each(|(v, c)| *v += c);
                dl.iter_mut().zip(&sc.cl).for_each(|(v, c)| *v += c);
                ds.iter_mut().zip(&sc.cs).for_each(|(v, c)| *v += c);
            }
        }
        self.scratch = sc;
    }
}

/// The largest `α` with `v + α Δv ≥ 0` (infinite when `Δv ≥ 0`).
fn step_to_boundary(v: &[f64], dv: &[f64]) -> f64 {
    v.iter()
        .zip(dv)
        .filter(|(_, d)| **d < 0.0)
        .map(|(x, d)| -x / d)
        .fold(f64::INFINITY, f64::min)
}

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |acc: f64, x| acc.max(x.abs()))
}

/// The start from the multipliers `guess`: `d = Aᵀλ`, the slacks `A d − r` it leaves, and
/// both slacks and multipliers raised to at least `floor`.
fn warm_point(run: &mut Run<'_>, d: &mut [f64], guess: &[f64], floor: f64) -> (Vec<f64>, Vec<f64>) {
    let floor = floor.max(f64::MIN_POSITIVE);
    run.a.mul_transpose_vec(guess, d);
    run.a.mul_vec(d, &mut run.row_work);
    let slack = (0..run.r.len())
        .map(|i| (run.row_work[i] - run.r[i]).max(floor))
        .collect();
    let lambda = guess.iter().map(|l| l.max(floor)).collect();
    (slack, lambda)
}

/// Mehrotra's starting point: the least-squares `d̂ = argmin ½‖d‖² + ½‖Ad − r‖²` (`normal`
/// factored with unit weights), whose `λ̂ = r − A d̂` makes it dual feasible (`d̂ = Aᵀλ̂`) with
/// `s = −λ̂`; both shifted into the positive orthant and balanced.
fn starting_point(run: &mut Run<'_>, d: &mut [f64]) -> (Vec<f64>, Vec<f64>) {
    let m = run.r.len();
    run.a.mul_transpose_vec(run.r, d);
    run.normal.solve(d);
    run.a.mul_vec(d, &mut run.row_work);
    let mut slack: Vec<f64> = (0..m).map(|i| run.row_work[i] - run.r[i]).collect();
    let mut lambda: Vec<f64> = slack.iter().map(|s| -s).collect();
    let shift = |v: &mut Vec<f64>| {
        let low = v.iter().fold(f64::INFINITY, |acc, &x| acc.min(x));
        let by = (-1.5 * low).max(0.0);
        v.iter_mut().for_each(|x| *x += by);
    };
    shift(&mut slack);
    shift(&mut lambda);
    let product: f64 = slack.iter().zip(&lambda).map(|(s, l)| s * l).sum();
    let (sum_s, sum_l): (f64, f64) = (slack.iter().sum(), lambda.iter().sum());
    let by_s = if sum_l > 0.0 {
        0.5 * product / sum_l
    } else {
        1.0
    };
    let by_l = if sum_s > 0.0 {
        0.5 * product / sum_s
    } else {
        1.0
    };
    let floor = f64::MIN_POSITIVE.max(1e-20 * inf_norm(run.r));
    slack.iter_mut().for_each(|s| *s = (*s + by_s).max(floor));
    lambda.iter_mut().for_each(|l| *l = (*l + by_l).max(floor));
    (slack, lambda)
}

/// The measures of an iterate the stopping test reads.
struct Measured {
    /// The largest of the primal residuals (as distances) and the dual residual.
    residual: f64,
    /// The duality measure `μ = sᵀλ/m`.
    mu: f64,
    /// The largest product `λᵢ sᵢ`.
    largest_product: f64,
}

impl Residuals {
    /// The residuals `r_d = d − Aᵀλ` and `r_p = A d − s − r` of the iterate `(d, λ, s)`,
    /// kept, and the measures of the stopping test (`row_norm`: each row's length).
    fn measure(
        &mut self,
        a: &SparseRows,
        r: &[f64],
        row_norm: &[f64],
        (d, lambda, slack): (&[f64], &[f64], &[f64]),
    ) -> Measured {
        let m = slack.len();
        a.mul_transpose_vec(lambda, &mut self.dual);
        self.dual.iter_mut().zip(d).for_each(|(v, di)| *v = di - *v);
        a.mul_vec(d, &mut self.primal);
        for i in 0..m {
            self.primal[i] -= slack[i] + r[i];
        }
        let primal_off = (0..m)
            .filter(|&i| row_norm[i] > 0.0)
            .map(|i| self.primal[i].abs() / row_norm[i])
            .fold(0.0, f64::max);
        let residual = primal_off.max(inf_norm(&self.dual));
        let mu = slack.iter().zip(lambda).map(|(s, l)| s * l).sum::<f64>() / m as f64;
        let largest_product = slack
            .iter()
            .zip(lambda)
            .map(|(s, l)| s * l)
            .fold(0.0, f64::max);
        Measured {
            residual,
            mu,
            largest_product,
        }
    }
}

/// The most accurate iterate so far, and whether the run still makes progress.
struct Progress {
    /// The best iterate, with its rank `(not certifiable, off)`.
    best: Option<((bool, f64), Iterate)>,
    /// The residuals and `μ` at the last progress.
    least: f64,
    /// Iterations since then.
    since: u32,
}

impl Progress {
    /// Keeps the iterate `(d, λ, s)` of rank `(not certifiable, off)` when it ranks before the
    /// best so far. The best iterate is the most accurate of those the certificate would
    /// accept (or of all, while none would): past the point where the directions lose
    /// accuracy, a later iterate can have a smaller last direction and a residual the check
    /// refuses.
    fn offer(
        &mut self,
        rank: (bool, f64),
        (d, lambda, slack): (&[f64], &[f64], &[f64]),
        iterations: u32,
        length: f64,
    ) {
        if !self.best.as_ref().is_none_or(|b| rank < b.0) {
            return;
        }
        let off = rank.1;
        // Copied into the vectors of the last best, not allocated again.
        let mut kept = self.best.take().map_or_else(
            || Iterate {
                d: d.to_vec(),
                lambda: lambda.to_vec(),
                slack: slack.to_vec(),
                iterations,
                converged: false,
                accuracy: off,
                length,
            },
            |(_, kept)| kept,
        );
        kept.d.copy_from_slice(d);
        kept.lambda.copy_from_slice(lambda);
        kept.slack.copy_from_slice(slack);
        kept.iterations = iterations;
        kept.accuracy = off;
        self.best = Some((rank, kept));
    }

    /// Counts `progress` (the residuals and `μ`, against the length scale): whether [`STALLED`]
    /// iterations have now passed without it halving, or [`SETTLED`] when the best iterate is
    /// certifiable and within `acceptable`. Progress is the residuals and `μ` falling; the
    /// last direction comes and goes (a random instance sat at one residual for five
    /// iterations and then converged).
    fn stalled(&mut self, progress: f64, acceptable: f64) -> bool {
        if progress < 0.5 * self.least {
            self.least = progress;
            self.since = 0;
        } else {
            self.since += 1;
        }
        let settled = self
            .best
            .as_ref()
            .is_some_and(|((uncertifiable, off), _)| !uncertifiable && *off <= acceptable);
        self.since >= if settled { SETTLED } else { STALLED }
    }
}

/// The complementarity target and the direction `(Δd, Δλ, Δs)` of an iteration.
struct Step {
    r_c: Vec<f64>,
    dd: Vec<f64>,
    dl: Vec<f64>,
    ds: Vec<f64>,
}

impl Run<'_> {
    /// Mehrotra's predictor–corrector direction at the iterate `(λ, s)` (weights factored) into
    /// `step`, and the step length along it (a fraction [`TO_BOUNDARY`] of the way to the
    /// boundary, at most 1); `None` when either is not finite.
    fn predictor_corrector(
        &mut self,
        (lambda, slack): (&[f64], &[f64]),
        res: &Residuals,
        mu: f64,
        refine: bool,
        step: &mut Step,
    ) -> Option<f64> {
        let m = slack.len();
        let Step { r_c, dd, dl, ds } = step;
        // Predictor: the affine-scaling direction (target λ ∘ s = 0).
        for i in 0..m {
            r_c[i] = slack[i] * lambda[i];
        }
        self.direction((lambda, slack), res, r_c, refine, (dd, dl, ds));
        let alpha = step_to_boundary(slack, ds)
            .min(step_to_boundary(lambda, dl))
            .min(1.0);
        let mu_affine = slack
            .iter()
            .zip(ds.iter())
            .zip(lambda.iter().zip(dl.iter()))
            .map(|((s, dsi), (l, dli))| (s + alpha * dsi) * (l + alpha * dli))
            .sum::<f64>()
            / m as f64;
        let sigma = (mu_affine / mu).clamp(0.0, 1.0).powi(3);
        // Corrector: the second-order term of the predictor, and centring.
        for i in 0..m {
            r_c[i] = slack[i] * lambda[i] + ds[i] * dl[i] - sigma * mu;
        }
        self.direction((lambda, slack), res, r_c, refine, (dd, dl, ds));
        let alpha =
            (TO_BOUNDARY * step_to_boundary(slack, ds).min(step_to_boundary(lambda, dl))).min(1.0);
        let finite = alpha.is_finite()
            && dd
                .iter()
                .chain(ds.iter())
                .chain(dl.iter())
                .all(|v| v.is_finite());
        finite.then_some(alpha)
    }
}

/// Runs the method on `min ½‖d‖²` s.t. `A d ≥ r` (`normal` built from `a`) until `tolerance`
/// is met or `max_iterations` have run, or until the normal matrix can no longer be factored,
/// a direction is no longer finite, or [`STALLED`] iterations pass without the residuals or
/// `μ` halving; then
/// the most accurate iterate is returned, not converged (on an empty set the multipliers
/// diverge along a Farkas certificate: then the last iterate). `None` without rows or when
/// the first factorization fails.
///
/// `kkt` is the caller's certificate: the method does not stop before the residuals and every
/// product `λᵢ sᵢ` are within it (absolute), so that a converged iterate passes the check.
/// `warm` starts it from given multipliers (one per row; a start of another length is
/// ignored) instead of Mehrotra's point.
pub(crate) fn solve(
    a: &SparseRows,
    r: &[f64],
    normal: &mut NormalMatrix,
    tolerance: Tolerance,
    kkt: f64,
    max_iterations: u32,
    warm: Option<Warm<'_>>,
) -> Option<Iterate> {
    let (m, n) = (a.n_rows(), a.n_cols());
    let warm = warm.filter(|w| w.multipliers.len() == m);
    // Mehrotra's point is a least-squares solve with unit weights; a warm start needs none.
    if m == 0 || (warm.is_none() && normal.factor(&vec![1.0; m]).is_err()) {
        return None;
    }
    let row_norm: Vec<f64> = (0..m)
        .map(|i| a.row(i).map(|(_, v)| v * v).sum::<f64>().sqrt())
        .collect();
    let length = (0..m)
        .filter(|&i| row_norm[i] > 0.0)
        .map(|i| r[i].abs() / row_norm[i])
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut run = Run {
        a,
        r,
        normal,
        w: vec![0.0; m],
        row_work: vec![0.0; m],
        scratch: Scratch::default(),
    };
    let mut d = vec![0.0; n];
    let (mut slack, mut lambda) = match warm {
        Some(warm) => warm_point(&mut run, &mut d, warm.multipliers, warm.floor * length),
        None => starting_point(&mut run, &mut d),
    };
    let mut res = Residuals {
        dual: vec![0.0; n],
        primal: vec![0.0; m],
    };
    let mut step = Step {
        r_c: vec![0.0; m],
        dd: vec![0.0; n],
        dl: vec![0.0; m],
        ds: vec![0.0; m],
    };
    // The residuals shrink by `1 − α` per iteration in exact arithmetic; once they grow the
    // directions are no longer accurate (weights spanning many orders of magnitude), and from
    // then on each solve is refined once; so they are from the late iterations on, where the
    // weights spread (without, a jam's residuals can jump by orders of magnitude and the
    // method break down one step short of its tolerance).
    let mut refine = false;
    let mut last_residual = f64::INFINITY;
    let mut last_direction = f64::INFINITY;
    let mut progress = Progress {
        best: None,
        least: f64::INFINITY,
        since: 0,
    };
    let mut iterations = 0;
    loop {
        let Measured {
            residual,
            mu,
            largest_product,
        } = res.measure(a, r, &row_norm, (&d, &lambda, &slack));
        let certifiable = residual.max(largest_product) <= kkt;
        let off = residual.max(last_direction).max(mu / length) / length;
        if !(residual.is_finite() && mu.is_finite()) {
            break;
        }
        if off <= tolerance.accuracy && certifiable {
            return Some(Iterate {
                d,
                lambda,
                slack,
                iterations,
                converged: true,
                accuracy: off,
                length,
            });
        }
        let iterate = (&d[..], &lambda[..], &slack[..]);
        progress.offer((!certifiable, off), iterate, iterations, length);
        let stalled = progress.stalled(residual.max(mu / length), tolerance.acceptable);
        if iterations >= max_iterations || stalled {
            break;
        }
        iterations += 1;
        let absolute_residual = residual;
        refine |= mu <= LATE * length * length
            || (absolute_residual > last_residual && residual > tolerance.accuracy * length);
        last_residual = absolute_residual;
        for i in 0..m {
            run.w[i] = lambda[i] / slack[i];
        }
        if run.normal.factor(&run.w).is_err() {
            break;
        }
        let Some(alpha) = run.predictor_corrector((&lambda, &slack), &res, mu, refine, &mut step)
        else {
            break;
        };
        last_direction = alpha * inf_norm(&step.dd);
        d.iter_mut()
            .zip(&step.dd)
            .for_each(|(dj, ddj)| *dj += alpha * ddj);
        // Kept off zero by a floor far below any accuracy asked for: a slack rounded to zero
        // makes its weight infinite and the next direction not finite.
        let floor = FLOOR * length;
        for i in 0..m {
            slack[i] = (slack[i] + alpha * step.ds[i]).max(floor);
            lambda[i] = (lambda[i] + alpha * step.dl[i]).max(floor);
        }
    }
    // A diverging run (an empty set) keeps its last multipliers, which point along a Farkas
    // certificate; otherwise the most accurate iterate is the one worth having.
    let got_close = progress.best.as_ref().is_some_and(|(b, _)| b.1 < 1e-3);
    match progress.best {
        Some((_, it)) if got_close => Some(Iterate { iterations, ..it }),
        _ => Some(Iterate {
            d,
            lambda,
            slack,
            iterations,
            converged: false,
            accuracy: f64::INFINITY,
            length,
        }),
    }
}
