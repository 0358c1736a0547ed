//! Running two backends on every problem and failing loudly when they disagree.

use crate::{Projection, ProjectionError, ProjectionProblem, Projector};
use serde::{Deserialize, Serialize};

/// Runs two projectors on each problem; returns the first one's answer when the two points
/// agree to within `tolerance` (∞-norm), and [`ProjectionError::Disagreement`] with the gap
/// otherwise. The largest gap seen is kept in [`CrossCheck::stats`].
///
/// ```
/// use sweeping_api::{conformance::ReferenceProjector, CrossCheck, ProjectionProblem,
///                    Projector, SparseRows};
/// let mut both = CrossCheck::new(ReferenceProjector::default(), ReferenceProjector::default(), 1e-9);
/// let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 1.0)]]);
/// let p = ProjectionProblem::new(vec![-1.0, -2.0], a, vec![0.0, 0.0]).unwrap();
/// let x = both.project(&p).unwrap().x;
/// assert!(x.iter().all(|v| v.abs() < 1e-9));
/// assert!(both.stats().max_gap < 1e-9);
/// ```
pub struct CrossCheck<P1, P2> {
    first: P1,
    second: P2,
    tolerance: f64,
    name: String,
    stats: CrossCheckStats,
    concurrent: bool,
}

/// What a [`CrossCheck`] has seen so far.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CrossCheckStats {
    /// Problems compared.
    pub compared: u64,
    /// Largest ∞-norm gap between the two answers.
    pub max_gap: f64,
    /// Sum of the gaps (for a mean).
    pub sum_gap: f64,
    /// Seconds spent in the first backend.
    pub first_seconds: f64,
    /// Seconds spent in the second backend.
    pub second_seconds: f64,
    /// The problem on which the two disagreed beyond the tolerance, with both answers (the
    /// last such, the one a run stops on). Not in a serialized summary: a caller that keeps it
    /// writes it apart (`sweep run` writes `disagreement.json`).
    #[serde(skip)]
    pub disagreement: Option<Box<CrossCheckDisagreement>>,
    /// The problem of the largest gap that passed (within the tolerance, above zero), with
    /// both answers: the closest call of a run that completed, kept so that it too can be
    /// decided afterwards. Replaced only when a gap exceeds it, so a run copies a problem a
    /// handful of times. Not in a serialized summary (`sweep run` writes
    /// `largest-gap.json`).
    #[serde(skip)]
    pub largest_passed_gap: Option<Box<CrossCheckDisagreement>>,
}

/// A problem on which a [`CrossCheck`] found its two backends apart — by more than its
/// tolerance ([`CrossCheckStats::disagreement`]), or by the largest gap that passed
/// ([`CrossCheckStats::largest_passed_gap`]) — and both answers: what is needed to decide
/// afterwards which one is off (against a projection computed independently and certified)
/// without running again to that step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossCheckDisagreement {
    /// The first backend's name.
    pub first_backend: String,
    /// The second backend's name.
    pub second_backend: String,
    /// The ∞-norm gap between the two points.
    pub gap: f64,
    /// The coordinate where the gap is largest.
    pub coordinate: usize,
    /// The problem, as the two backends were given it.
    pub problem: ProjectionProblem,
    /// The first backend's answer.
    pub first: Projection,
    /// The second backend's answer.
    pub second: Projection,
}

impl<P1: Projector, P2: Projector> CrossCheck<P1, P2> {
    /// Compares `first` with `second`, allowing an ∞-norm gap of `tolerance`.
    pub fn new(first: P1, second: P2, tolerance: f64) -> Self {
        let name = format!("cross({}, {})", first.name(), second.name());
        Self {
            first,
            second,
            tolerance,
            name,
            stats: CrossCheckStats::default(),
            concurrent: false,
        }
    }

    /// Runs the two backends at once, the first on a thread of its own, when `concurrent`
    /// (default: one after the other). Each backend sees only the problem, so the answers,
    /// the gaps and the verdict are the same either way; a run's wall time becomes that of
    /// the slower backend instead of the sum of both, for a thread started per problem. For
    /// two cores or more: on one, the two backends only take turns.
    #[must_use]
    pub fn concurrent(mut self, concurrent: bool) -> Self {
        self.concurrent = concurrent;
        self
    }

    /// Whether the two backends run at once ([`CrossCheck::concurrent`]).
    pub fn is_concurrent(&self) -> bool {
        self.concurrent
    }

    /// The statistics gathered so far.
    pub fn stats(&self) -> &CrossCheckStats {
        &self.stats
    }
}

impl<P1: Projector, P2: Projector> Projector for CrossCheck<P1, P2> {
    fn name(&self) -> &str {
        &self.name
    }

    fn cross_check(&self) -> Option<&CrossCheckStats> {
        Some(&self.stats)
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let timed = |p: &mut dyn Projector| {
            let t0 = std::time::Instant::now();
            let answer = p.project(problem);
            (answer, t0.elapsed().as_secs_f64())
        };
        let (a, b) = if self.concurrent {
            let (first, second) = (&mut self.first, &mut self.second);
            let ((a, first_seconds), (b, second_seconds)) = std::thread::scope(|scope| {
                let on_its_own = scope.spawn(|| timed(first));
                let b = timed(second);
                match on_its_own.join() {
                    Ok(a) => (a, b),
                    // The first backend panicked: so does the caller, as it would have.
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            });
            self.stats.first_seconds += first_seconds;
            self.stats.second_seconds += second_seconds;
            // The first backend's error first, as when they take turns.
            (a?, b?)
        } else {
            let (a, first_seconds) = timed(&mut self.first);
            self.stats.first_seconds += first_seconds;
            let a = a?;
            let (b, second_seconds) = timed(&mut self.second);
            self.stats.second_seconds += second_seconds;
            (a, b?)
        };
        let (coordinate, gap) =
            a.x.iter()
                .zip(&b.x)
                .map(|(u, v)| (u - v).abs())
                .enumerate()
                .fold((0, 0.0), |best: (usize, f64), (i, g)| {
                    // The first NaN wins: a NaN coordinate is the worst disagreement.
                    if g > best.1 || (g.is_nan() && !best.1.is_nan()) {
                        (i, g)
                    } else {
                        best
                    }
                });
        self.stats.compared += 1;
        self.stats.sum_gap += gap;
        self.stats.max_gap = crate::max_or_nan(self.stats.max_gap, gap);
        if gap.is_nan() || gap > self.tolerance {
            let reduced = [a.stats.counters.reduced, b.stats.counters.reduced];
            self.stats.disagreement = Some(Box::new(CrossCheckDisagreement {
                first_backend: self.first.name().to_string(),
                second_backend: self.second.name().to_string(),
                gap,
                coordinate,
                problem: problem.clone(),
                first: a,
                second: b,
            }));
            return Err(ProjectionError::Disagreement {
                first: self.first.name().to_string(),
                second: self.second.name().to_string(),
                gap,
                coordinate,
                tolerance: self.tolerance,
                reduced,
            });
        }
        let largest_so_far = self
            .stats
            .largest_passed_gap
            .as_ref()
            .map_or(0.0, |kept| kept.gap);
        if gap > largest_so_far {
            self.stats.largest_passed_gap = Some(Box::new(CrossCheckDisagreement {
                first_backend: self.first.name().to_string(),
                second_backend: self.second.name().to_string(),
                gap,
                coordinate,
                problem: problem.clone(),
                first: a.clone(),
                second: b,
            }));
        }
        Ok(a)
    }

    fn tolerance(&self) -> f64 {
        self.first.tolerance().max(self.second.tolerance())
    }
}
