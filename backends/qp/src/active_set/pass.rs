//! One pass of the method: the main loop from a start to an answer under a pass's tests, and
//! its stages (the system of a support, its solve, the step along a ray, the rows that join).

use super::farkas::farkas;
use super::finish::Best;
use super::orderings::Memory;
use super::pivots::{blocking_row, drop_negative, joining_rows, shrink, Support};
use super::refine::Refined;
use super::system::ActiveSystem;
use super::tolerances::{Tolerances, SECOND_PASS_TOL};
use super::visits::{Visits, REPEATS};
use super::{Failure, Outcome, Start};
use sweeping_api::ProjectionProblem;

/// What [`run_pass`] converged to.
pub(super) struct Finished {
    pub(super) outcome: Outcome,
    /// The factorization of the last iteration.
    pub(super) held: Option<ActiveSystem>,
    /// Whether the answer leaves a row violated, or a row of its support not tight, by more
    /// than [`SECOND_PASS_TOL`] (relative, as [`ACTIVE_TOL`](super::tolerances::ACTIVE_TOL)).
    pub(super) needs_second_pass: bool,
    /// By how much, absolutely: the largest violation of a row, or gap of a row of the
    /// support.
    pub(super) off: f64,
}

/// The pivot rules a run follows, each switched once and for the rest of the run.
struct Rules {
    /// Every negative row leaves at once on the first pass, unless rows join one at a time:
    /// from an interior point's guess on a jam, whose first solves are near inconsistent, that
    /// pass drops hundreds of rows and the method runs out of iterations taking them back one
    /// by one (measured: `docs/lab/2026-11-24-hard-blocks-door-queues.md`).
    aggressive: bool,
    /// Set when the method restarted as Lawson–Hanson proper: from an empty support, one row
    /// (the steepest) joining at a time, starting at a zero multiplier.
    proper: bool,
    /// Set when a pass that does not restart cycled: from then on, the lowest-numbered row
    /// joins, and of the rows a step would drop at (nearly) the same point the
    /// lowest-numbered leaves (Bland's rule).
    bland: bool,
}

impl Rules {
    /// The rules after the run came back to a working set [`REPEATS`] times: `true` when it
    /// restarts as Lawson–Hanson proper (the caller empties the support), `false` when it goes
    /// on under Bland's rule; cycling under either is the end of the run.
    fn after_cycling(&mut self, restarts: bool, iterations: u32) -> Result<bool, Failure> {
        if self.proper || self.bland {
            return Err(Failure::Cycling(iterations));
        }
        if restarts {
            // The warm, many-rows-at-once variant cycled (heavily dependent rows): restart
            // as Lawson–Hanson proper, which terminates finitely in exact arithmetic.
            self.proper = true;
            self.aggressive = false;
        } else {
            // A second pass, from a support near the answer, goes on from where it is under
            // Bland's rule (from an empty support it would need as many iterations as the
            // answer has rows).
            self.bland = true;
        }
        Ok(restarts)
    }

    /// The violated rows (increasing) that join the support, with their starting multipliers.
    fn joining(
        &self,
        violated: &[usize],
        violation: impl Fn(usize) -> f64,
        join: &[f64],
        join_at_most: Option<usize>,
    ) -> Result<Vec<(usize, f64)>, Failure> {
        if self.bland {
            // Bland's rule: the lowest-numbered violated row (`violated` is in increasing order).
            Ok(vec![(
                violated[0],
                join[violated[0]].max(f64::MIN_POSITIVE),
            )])
        } else {
            joining_rows(violated, violation, join, self.proper, join_at_most)
        }
    }
}

/// Work vectors of every iteration, kept from one to the next.
#[derive(Default)]
struct Work {
    /// `[0; r_P]`.
    rhs: Vec<f64>,
    /// `[d; −λ]`, then the solution.
    v: Vec<f64>,
    /// The support's multipliers of the solution.
    mu: Vec<f64>,
    /// `A d`, by row.
    ad: Vec<f64>,
    /// Whether a row is in the support.
    in_support: Vec<bool>,
    /// The rows outside the support that the point violates, increasing.
    violated: Vec<usize>,
}

/// The method from `start`, for at most `cap` iterations, with the tests of `pass`, its first
/// iteration bordering `held` when it can. The answer comes with the factorization of its
/// last iteration and whether it needs a second pass.
#[cfg(test)]
pub(super) fn run(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    pass: Tolerances,
    memory: Option<&mut Memory<'_>>,
    held: Option<ActiveSystem>,
) -> Result<Finished, Failure> {
    run_pass(problem, start, cap, pass, memory, held, None)
}

/// The method from `start`, for at most `cap` iterations, with the tests of `pass`, its first
/// iteration bordering `held` when it can, and keeping in `best`, when given, the iterate off
/// by least ([`Best`]).
pub(super) fn run_pass(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    pass: Tolerances,
    mut memory: Option<&mut Memory<'_>>,
    mut held: Option<ActiveSystem>,
    mut best: Option<&mut Best>,
) -> Result<Finished, Failure> {
    let m = problem.n_rows();
    let r = problem.shortfall(problem.y());
    if r.iter().any(|v| !v.is_finite()) {
        return Err(Failure::Numerical("b − A y overflows"));
    }
    let Start {
        mut support,
        mut lambda,
        join,
        join_at_most,
    } = start;
    let scale = r.iter().fold(1.0, |acc: f64, v| acc.max(v.abs()));
    let tol = pass.active * scale;
    let mut d = displacement(problem, &support, &lambda);
    let mut rules = Rules {
        aggressive: join_at_most.is_none(),
        proper: false,
        bland: false,
    };
    let mut visits = Visits::default();
    let mut work = Work {
        in_support: vec![false; m],
        ad: vec![0.0; m],
        ..Work::default()
    };
    // The system of the previous iteration (`held`), carried to the next support by
    // bordering.
    for iterations in 1..=cap {
        if visits.count(&support) >= REPEATS {
            let restart = rules.after_cycling(pass.restarts, iterations)?;
            visits.clear();
            if restart {
                support.clear();
                lambda.clear();
                d.iter_mut().for_each(|v| *v = 0.0);
                held = None;
            }
        }
        let mut system = system_for(problem, held.take(), &support, memory.as_deref_mut())?;
        let k = support.len();
        let refined = solve_support(&mut system, &r, &support, &lambda, pass, &mut d, &mut work)?;
        held = Some(system);

        if !refined.solved && refined.second > tol {
            let e = &refined.residual;
            (support, lambda) = follow_ray(problem, &support, &lambda, e, &r, rules.bland)?;
            // The point of the smaller support is recomputed from its multipliers.
            continue;
        }
        if !d.iter().chain(&work.mu).all(|v| v.is_finite()) {
            return Err(Failure::Numerical("non-finite step"));
        }

        // Negative multipliers (beyond rounding): rows leave the support.
        let mu = &work.mu;
        if let Some(smaller) =
            drop_negative(&support, &lambda, mu, tol, rules.aggressive, rules.bland)?
        {
            (support, lambda) = smaller;
            continue;
        }
        lambda.clear();
        lambda.extend(mu.iter().map(|m| m.max(f64::MIN_POSITIVE)));

        // Rows outside the support that the point violates join it.
        violated_rows(problem, &d, &support, &r, tol, &mut work);
        if work.violated.is_empty() {
            let (off, outcome) =
                answer_at(problem, &d, &support, &work.mu, &r, &work.ad, iterations);
            return Ok(Finished {
                outcome,
                held,
                needs_second_pass: off > SECOND_PASS_TOL * scale,
                off,
            });
        }
        if let Some(best) = best.as_deref_mut() {
            let (off, outcome) =
                answer_at(problem, &d, &support, &work.mu, &r, &work.ad, iterations);
            if best.as_ref().is_none_or(|(least, _)| off < *least) {
                *best = Some((off, outcome));
            }
        }
        // From now on, drop one row at a time: dropping every negative row at once could
        // cycle with adding them back.
        rules.aggressive = false;
        // Joining rows go last: the factored system then only has rows appended.
        let violation = |i: usize| r[i] - work.ad[i];
        let joining = rules.joining(&work.violated, violation, &join, join_at_most)?;
        support.extend(joining.iter().map(|&(i, _)| i));
        lambda.extend(joining.iter().map(|&(_, l)| l));
        debug_assert!(support.len() > k);
    }
    Err(Failure::Cap(cap))
}

/// `d = A_Pᵀλ`: the displacement the multipliers `lambda` of the rows `support` describe.
fn displacement(problem: &ProjectionProblem, support: &[usize], lambda: &[f64]) -> Vec<f64> {
    let mut d = vec![0.0; problem.dim()];
    for (&i, &l) in support.iter().zip(lambda) {
        for (c, v) in problem.a().row(i) {
            d[c] += v * l;
        }
    }
    d
}

/// The system of `support`: `held`, the previous iteration's, carried to it by bordering when
/// it can be, else a fresh factorization.
fn system_for(
    problem: &ProjectionProblem,
    held: Option<ActiveSystem>,
    support: &[usize],
    memory: Option<&mut Memory<'_>>,
) -> Result<ActiveSystem, Failure> {
    match held.and_then(|h| h.bordered_to(problem, support)) {
        Some(system) => Ok(system),
        // A fresh factorization is ordered by AMD, or as its nodes were ordered last
        // (`Orderings`, with `memory`), not from an ordering of the whole block restricted
        // to each working set: with bordering most iterations do not factor, and ordering
        // the whole block costs more than it saves.
        None => {
            ActiveSystem::new(problem, support, memory).ok_or(Failure::Numerical("factorization"))
        }
    }
}

/// The support's equations `K₀ [d; −μ] = [0; r_P]` refined from `[d; −λ]` under the tests of
/// `pass`: `d` and `work.mu` are left at the solution.
fn solve_support(
    system: &mut ActiveSystem,
    r: &[f64],
    support: &[usize],
    lambda: &[f64],
    pass: Tolerances,
    d: &mut [f64],
    work: &mut Work,
) -> Result<Refined, Failure> {
    let n = d.len();
    work.rhs.clear();
    work.rhs.resize(n, 0.0);
    work.rhs.extend(support.iter().map(|&i| r[i]));
    work.v.clear();
    work.v.extend_from_slice(d);
    work.v.extend(lambda.iter().map(|l| -l));
    let refined = system
        .refine(&work.rhs, &mut work.v, pass.refine, pass.least_squares)
        .ok_or(Failure::Numerical("refinement"))?;
    d.copy_from_slice(&work.v[..n]);
    work.mu.clear();
    work.mu.extend(work.v[n..].iter().map(|v| -v));
    Ok(refined)
}

/// The support after the step along the ray `λ + t e` of its inconsistent equations (`e`
/// their residual) until an entry reaches zero and leaves; when no entry of `e` is negative
/// the ray never stops, and the rows are the checked Farkas certificate of an empty set.
fn follow_ray(
    problem: &ProjectionProblem,
    support: &[usize],
    lambda: &[f64],
    e: &[f64],
    r: &[f64],
    bland: bool,
) -> Result<Support, Failure> {
    let Some((blocking, t)) = blocking_row(
        lambda
            .iter()
            .zip(e)
            .enumerate()
            .filter(|(_, (_, ei))| **ei < 0.0)
            .map(|(j, (l, ei))| (j, l / -ei)),
        support,
        bland,
    ) else {
        return Err(if farkas(problem, support, e, r) {
            Failure::Infeasible {
                rows: support.to_vec(),
            }
        } else {
            Failure::Numerical("unbounded ray without an infeasibility certificate")
        });
    };
    let step: Vec<f64> = lambda.iter().zip(e).map(|(l, ei)| l + t * ei).collect();
    Ok(shrink(support, &step, blocking))
}

/// The rows outside `support` that the point `y + d` violates beyond `tol`, increasing, into
/// `work.violated`, with `A d` left in `work.ad`.
fn violated_rows(
    problem: &ProjectionProblem,
    d: &[f64],
    support: &[usize],
    r: &[f64],
    tol: f64,
    work: &mut Work,
) {
    problem.a().mul_vec(d, &mut work.ad);
    work.in_support.iter_mut().for_each(|s| *s = false);
    support.iter().for_each(|&i| work.in_support[i] = true);
    let (in_support, ad) = (&work.in_support, &work.ad);
    work.violated.clear();
    work.violated
        .extend((0..r.len()).filter(|&i| !in_support[i] && r[i] - ad[i] > tol));
}

/// The iterate `y + d` with the multipliers `μ` of `support` as an answer, and how far off it
/// is ([`Finished::off`]): the largest violation of a row, or gap of a row keeping a positive
/// multiplier, from `r` and `A d` as the iteration left them (no product with `A`).
fn answer_at(
    problem: &ProjectionProblem,
    d: &[f64],
    support: &[usize],
    mu: &[f64],
    r: &[f64],
    ad: &[f64],
    iterations: u32,
) -> (f64, Outcome) {
    let x: Vec<f64> = problem.y().iter().zip(d).map(|(y, d)| y + d).collect();
    let mut full = vec![0.0; problem.n_rows()];
    support
        .iter()
        .zip(mu)
        .for_each(|(&i, &l)| full[i] = l.max(0.0));
    let off = r
        .iter()
        .zip(ad)
        .zip(&full)
        .map(|((ri, adi), l)| {
            let gap = ri - adi;
            if *l > 0.0 {
                gap.abs()
            } else {
                gap
            }
        })
        .fold(0.0, f64::max);
    let outcome = Outcome {
        x,
        lambda: full,
        iterations,
        unfinished: None,
    };
    (off, outcome)
}

/// How often each support (a set of rows) has been factored in one run of the method.
///
#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::SparseRows;

    #[test]
    fn an_iterate_as_an_answer_is_off_by_its_worst_violation_or_support_gap() {
        // Three rows on two unknowns at y = 0: r = b. The support {0, 2} with μ = (2, 0): row 2
        // keeps no multiplier, so only its violation counts.
        let a = SparseRows::from_rows(
            2,
            &[vec![(0, 1.0)], vec![(1, 1.0)], vec![(0, 1.0), (1, 1.0)]],
        );
        let p = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, -1.0, 0.5]).unwrap();
        let r = p.b().to_vec();
        let d = [1.0 + 3e-15, 0.0];
        let ad = [1.0 + 3e-15, 0.0, 1.0 + 3e-15];
        let (off, outcome) = answer_at(&p, &d, &[0, 2], &[2.0, 0.0], &r, &ad, 7);
        // Row 0 is in the support with μ > 0: its gap |1 − (1 + 3e-15)| counts; row 1 holds
        // (r − ad = −1); row 2 holds with room.
        assert_eq!(off, (1.0 + 3e-15) - 1.0);
        assert_eq!(outcome.x, vec![1.0 + 3e-15, 0.0]);
        assert_eq!(outcome.lambda, vec![2.0, 0.0, 0.0]);
        assert_eq!(outcome.iterations, 7);
        // A row outside the support violated by 2e-14 is the worst.
        let ad = [1.0, -1.0, 0.5 - 2e-14];
        let (off, _) = answer_at(&p, &d, &[0], &[2.0], &r, &ad, 1);
        assert_eq!(off, 0.5 - (0.5 - 2e-14));
        // Negative multipliers count as none.
        let (off, outcome) = answer_at(&p, &d, &[0], &[-1.0], &r, &[0.5, -1.0, 0.5], 1);
        assert_eq!(outcome.lambda, vec![0.0, 0.0, 0.0]);
        assert_eq!(off, 0.5);
    }
}
