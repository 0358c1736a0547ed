//! The finishing pass: an answer of the first pass that uses its room is finished at `1e-15`,
//! up and down a ladder of tolerances when a pass does not converge.

use super::orderings::Memory;
use super::pass::{run_pass, Finished};
use super::system::ActiveSystem;
use super::tolerances::{Tolerances, FINISH_LADDER, SECOND_PASS};
use super::{Failure, Outcome, Start};
use sweeping_api::ProjectionProblem;

/// The iterate of a second pass that was off by least so far, as [`Finished::off`] measures
/// it, with its answer: every row of its support solved and every multiplier non-negative (to
/// the pass's tolerance), so certified to that `off`.
pub(super) type Best = Option<(f64, Outcome)>;

/// The answer of the method at [`ACTIVE_TOL`](super::tolerances::ACTIVE_TOL), finished at
/// [`SECOND_PASS_TOL`](super::tolerances::SECOND_PASS_TOL) when it is off
/// by more than that: from its own support, the most violated row joining alone, for at most
/// `cap` iterations (the first pass's own cap), through the factorization of its last
/// iteration, bordered. When the pass does not converge (it runs out, or cycles: it does not
/// restart from an empty support as the first pass does, since from there it would need as
/// many iterations as the answer has rows), it is run again from the same start at the next
/// tolerance of [`FINISH_LADDER`]. When one converges above `1e-15`, the
/// tolerances below it are tried again in turn, each from the answer kept so far, closer to
/// the projection than the first, until one does not converge. When none converges at
/// `1e-15`, the answer is the first, a pass's answer or a pass's best iterate ([`Best`]),
/// whichever is off by least, marked
/// [`Outcome::unfinished`]: on a jam, rows that the data make dependent on the support and
/// inconsistent with it by a few units in the last place of `b` can keep joining and leaving
/// at `1e-15`, and the pass's iterates between them are then still far nearer the projection
/// than the first answer.
///
/// On a jam with more tight rows than unknowns the feasible set is a sliver around the
/// projection, and a point that violates a row, or solves its support's equations, only to
/// `1e-12` can be `1e-8` from the projection, and two answers from different supports that
/// far apart. Finished from each, both come to the same point. The whole method at a tighter
/// tolerance finishes fewer jams, hence a second pass from an answer rather than a tighter
/// tolerance throughout; and the pass gets the first pass's cap, since a short fixed cap
/// leaves the larger jams as they were (measured: `docs/lab/2026-11-24-second-pass-1e-13.md`).
pub(super) fn second_pass(
    problem: &ProjectionProblem,
    first: Finished,
    cap: u32,
    mut memory: Option<&mut Memory<'_>>,
) -> Outcome {
    let Finished {
        outcome: first,
        mut held,
        needs_second_pass,
        off,
    } = first;
    if !needs_second_pass {
        return first;
    }
    // In the factored support's order, so that the pass borders that factorization.
    let order = held.as_ref().map(|h| h.support.as_slice());
    let start = start_at_answer(&first, order);
    // The answer off by least so far: the first, or a later pass's best iterate or answer.
    let mut spent = first.iterations;
    let mut kept: (f64, Outcome) = (off, first);
    let keep_if_less = |kept: &mut (f64, Outcome), candidate: Option<(f64, Outcome)>| {
        if let Some(candidate) = candidate.filter(|(off, _)| *off < kept.0) {
            *kept = candidate;
        }
    };
    // Up the ladder, each rung from the first answer, until a pass converges.
    let mut converged = None;
    for (rung, &tolerance) in FINISH_LADDER.iter().enumerate() {
        let held = if rung == 0 { held.take() } else { None };
        let pass = finishing_pass(
            problem,
            start.clone(),
            cap,
            tolerance,
            memory.as_deref_mut(),
            held,
            &mut spent,
        );
        match pass {
            // Finished at the second pass's own tests.
            Ok((_, second)) if rung == 0 => {
                return Outcome {
                    iterations: spent,
                    ..second
                }
            }
            Ok(second) => {
                keep_if_less(&mut kept, Some(second));
                converged = Some(rung);
                break;
            }
            Err(best) => keep_if_less(&mut kept, best),
        }
    }
    // Down again: the rungs below the one that converged, each from the answer kept so far,
    // which is closer to the projection than the first answer: a lower rung that cycles from
    // the first answer can converge from there (measured:
    // `docs/lab/2026-11-28-second-pass-1e-15-dependent-rows.md`).
    for rung in (0..converged.unwrap_or(0)).rev() {
        let pass = finishing_pass(
            problem,
            start_at_answer(&kept.1, None),
            cap,
            FINISH_LADDER[rung],
            memory.as_deref_mut(),
            None,
            &mut spent,
        );
        match pass {
            Ok((_, lower)) if rung == 0 => {
                return Outcome {
                    iterations: spent,
                    ..lower
                }
            }
            Ok(lower) => keep_if_less(&mut kept, Some(lower)),
            Err(best) => {
                keep_if_less(&mut kept, best);
                break;
            }
        }
    }
    Outcome {
        iterations: spent,
        unfinished: Some(kept.0),
        ..kept.1
    }
}

/// One pass of the finishing ladder at `tolerance` from `start` (see [`second_pass`]), its
/// iterations added to `spent`: its answer and how far off it is when it converges, otherwise
/// its best iterate ([`Best`]) when it ran out or cycled, `None` when it failed otherwise
/// (whose iterations are not counted).
fn finishing_pass(
    problem: &ProjectionProblem,
    start: Start,
    cap: u32,
    tolerance: f64,
    memory: Option<&mut Memory<'_>>,
    held: Option<ActiveSystem>,
    spent: &mut u32,
) -> Result<(f64, Outcome), Best> {
    let mut best: Best = None;
    let pass = run_pass(
        problem,
        start,
        cap,
        Tolerances {
            active: tolerance,
            refine: tolerance,
            ..SECOND_PASS
        },
        memory,
        held,
        Some(&mut best),
    );
    match pass {
        Ok(Finished { outcome, off, .. }) => {
            *spent = spent.saturating_add(outcome.iterations);
            Ok((off, outcome))
        }
        Err(Failure::Cap(n) | Failure::Cycling(n)) => {
            *spent = spent.saturating_add(n);
            Err(best)
        }
        Err(_) => Err(None),
    }
}

/// A second pass's start from an answer: the rows with a positive multiplier (in `order`
/// when given, the order of a factorization the pass can border, otherwise by index), the
/// most violated row joining alone, and every row's multiplier as it stands (or the smallest
/// positive number) if it joins.
fn start_at_answer(answer: &Outcome, order: Option<&[usize]>) -> Start {
    let order = order.map_or_else(|| (0..answer.lambda.len()).collect(), <[usize]>::to_vec);
    let support: Vec<usize> = order
        .into_iter()
        .filter(|&i| answer.lambda[i] > 0.0)
        .collect();
    Start {
        lambda: support.iter().map(|&i| answer.lambda[i]).collect(),
        support,
        join: answer
            .lambda
            .iter()
            .map(|l| l.max(f64::MIN_POSITIVE))
            .collect(),
        join_at_most: Some(1),
    }
}

#[cfg(test)]
mod tests;
