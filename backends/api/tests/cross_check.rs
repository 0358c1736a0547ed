//! `CrossCheck` on its own: the gap it measures, the coordinate it names, the statistics it
//! keeps and the tolerance it reports, against backends whose answers are known.

use sweeping_api::{
    CrossCheck, Projection, ProjectionError, ProjectionProblem, Projector, SparseRows,
};

/// Answers `y + shift` (whatever the rows), reporting `tolerance`.
struct Shifted {
    name: &'static str,
    shift: Vec<f64>,
    tolerance: f64,
}

impl Projector for Shifted {
    fn name(&self) -> &str {
        self.name
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let mut answer = Projection::identity(p, self.name);
        answer
            .x
            .iter_mut()
            .zip(&self.shift)
            .for_each(|(x, s)| *x += s);
        Ok(answer)
    }
    fn tolerance(&self) -> f64 {
        self.tolerance
    }
}

fn shifted(name: &'static str, shift: &[f64], tolerance: f64) -> Shifted {
    Shifted {
        name,
        shift: shift.to_vec(),
        tolerance,
    }
}

fn problem() -> ProjectionProblem {
    let a = SparseRows::from_rows(3, &[vec![(0, 1.0)]]);
    ProjectionProblem::new(vec![1.0, 2.0, 3.0], a, vec![0.0]).unwrap()
}

#[test]
fn agreeing_answers_pass_and_their_gaps_are_counted() {
    let first = shifted("a", &[0.0, 0.0, 0.0], 1e-9);
    let second = shifted("b", &[0.0, 3e-10, -1e-10], 1e-7);
    let mut both = CrossCheck::new(first, second, 1e-9);
    assert_eq!(both.name(), "cross(a, b)");
    // The larger of the two backends' tolerances: both answers are accepted.
    assert_eq!(both.tolerance(), 1e-7);
    let p = problem();
    let answer = both.project(&p).unwrap();
    assert_eq!(answer.x, vec![1.0, 2.0, 3.0]);
    both.project(&p).unwrap();
    let stats = both.stats();
    assert_eq!(stats.compared, 2);
    assert!((stats.max_gap - 3e-10).abs() < 1e-15, "{}", stats.max_gap);
    assert!((stats.sum_gap - 6e-10).abs() < 1e-15, "{}", stats.sum_gap);
    assert!(stats.first_seconds >= 0.0 && stats.second_seconds >= 0.0);
    assert!(stats.disagreement.is_none());
}

#[test]
fn a_gap_beyond_the_tolerance_is_an_error_naming_the_largest_coordinate() {
    let first = shifted("a", &[0.0, 0.0, 0.0], 1e-9);
    let second = shifted("b", &[2e-6, -5e-6, 1e-6], 1e-9);
    let mut both = CrossCheck::new(first, second, 1e-6);
    match both.project(&problem()) {
        Err(ProjectionError::Disagreement {
            first,
            second,
            gap,
            coordinate,
            tolerance,
            reduced,
        }) => {
            assert_eq!(
                reduced,
                [0, 0],
                "neither answer says it is short of its target"
            );
            assert_eq!((first.as_str(), second.as_str()), ("a", "b"));
            assert!((gap - 5e-6).abs() < 1e-15, "{gap}");
            assert_eq!(coordinate, 1);
            assert_eq!(tolerance, 1e-6);
        }
        other => panic!("{other:?}"),
    }
    // The problem and both answers are kept, so that the step can be decided afterwards.
    let kept = both
        .stats()
        .disagreement
        .as_deref()
        .expect("the disagreement is kept");
    assert_eq!(kept.problem, problem());
    assert_eq!(
        (kept.first_backend.as_str(), kept.second_backend.as_str()),
        ("a", "b")
    );
    assert!(
        (kept.gap - 5e-6).abs() < 1e-15 && kept.coordinate == 1,
        "{kept:?}"
    );
    assert_eq!(kept.first.x, vec![1.0, 2.0, 3.0]);
    assert_eq!(kept.second.x, vec![1.0 + 2e-6, 2.0 - 5e-6, 3.0 + 1e-6]);
    // A summary written as JSON leaves it out (it is written apart).
    let json = serde_json::to_value(both.stats()).unwrap();
    assert!(json.get("disagreement").is_none(), "{json}");
    // A gap exactly at the tolerance passes.
    let mut at = CrossCheck::new(
        shifted("a", &[0.0; 3], 1e-9),
        shifted("b", &[0.0, 0.0, 0.5], 1e-9),
        0.5,
    );
    assert!(at.project(&problem()).is_ok());
}

#[test]
fn a_cross_check_reports_its_statistics_through_the_trait_and_its_wrappers() {
    use sweeping_api::Blocked;
    let p = problem();
    let mut both: Box<dyn Projector> = Box::new(CrossCheck::new(
        shifted("a", &[0.0, 0.0, 0.0], 1e-9),
        shifted("b", &[2e-10, 0.0, 0.0], 1e-9),
        1e-9,
    ));
    assert_eq!(both.cross_check().unwrap().compared, 0);
    both.project(&p).unwrap();
    let seen = both.cross_check().unwrap();
    assert_eq!(seen.compared, 1);
    assert!((seen.max_gap - 2e-10).abs() < 1e-15, "{}", seen.max_gap);
    // Run block by block (a violated row, so that its block reaches the backends), the
    // wrapped cross-check still reports.
    let a = SparseRows::from_rows(3, &[vec![(0, 1.0)]]);
    let violated = ProjectionProblem::new(vec![1.0, 2.0, 3.0], a, vec![2.0]).unwrap();
    let mut blocked = Blocked::new(CrossCheck::new(
        shifted("a", &[0.0; 3], 1e-9),
        shifted("b", &[0.0; 3], 1e-9),
        1e-9,
    ));
    blocked.project(&violated).unwrap();
    assert_eq!(blocked.cross_check().unwrap().compared, 1);
    // Any other backend reports nothing.
    assert!(shifted("a", &[0.0; 3], 1e-9).cross_check().is_none());
}

/// Answers as [`Shifted`], reporting `blocks` blocks answered short of the backend's accuracy
/// target, off by up to `off`.
struct Reduced {
    inner: Shifted,
    blocks: u64,
    off: f64,
}

impl Projector for Reduced {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let mut answer = self.inner.project(p)?;
        answer.stats.counters.reduced = self.blocks;
        answer.stats.counters.reduced_by = self.off;
        Ok(answer)
    }
}

#[test]
fn a_disagreement_names_the_answer_short_of_its_target() {
    let first = shifted("native", &[0.0; 3], 1e-9);
    let second = Reduced {
        inner: shifted("clarabel", &[0.0, 2.3e-8, 0.0], 1e-9),
        blocks: 1,
        off: 8.5e-13,
    };
    let mut both = CrossCheck::new(first, second, 1e-8);
    let error = both.project(&problem()).unwrap_err();
    let message = error.to_string();
    assert!(
        message.ends_with(
            "> tolerance 1.0e-8; clarabel's answer: 1 block(s) short of its accuracy target \
             (see BackendCounters::reduced)"
        ),
        "{message}"
    );
    assert!(!message.contains("native's answer"), "{message}");
    // The kept answers carry the counts, for whoever decides the step from the file.
    let kept = both.stats().disagreement.as_deref().unwrap();
    assert_eq!(
        (
            kept.first.stats.counters.reduced,
            kept.second.stats.counters.reduced
        ),
        (0, 1)
    );
    assert_eq!(kept.second.stats.counters.reduced_by, 8.5e-13);
}

/// Answers as [`Shifted`], noting the thread each answer was computed on.
struct OnThread {
    inner: Shifted,
    seen: std::sync::Arc<std::sync::Mutex<Vec<(&'static str, std::thread::ThreadId)>>>,
}

impl Projector for OnThread {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let here = std::thread::current().id();
        self.seen.lock().unwrap().push((self.inner.name, here));
        self.inner.project(p)
    }
}

#[test]
fn concurrent_backends_run_on_two_threads_and_give_what_turns_give() {
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let on_thread = |name, shift: &[f64]| OnThread {
        inner: shifted(name, shift, 1e-9),
        seen: seen.clone(),
    };
    let make = |concurrent| {
        CrossCheck::new(
            on_thread("a", &[0.0; 3]),
            on_thread("b", &[0.0, 3e-10, 0.0]),
            1e-9,
        )
        .concurrent(concurrent)
    };
    let p = problem();
    let caller = std::thread::current().id();
    let (mut turns, mut at_once) = (make(false), make(true));
    assert!(!turns.is_concurrent() && at_once.is_concurrent());
    let answer = turns.project(&p).unwrap();
    let turns_seen: Vec<_> = seen.lock().unwrap().drain(..).collect();
    assert_eq!(turns_seen, vec![("a", caller), ("b", caller)]);
    assert_eq!(at_once.project(&p).unwrap().x, answer.x);
    let mut at_once_seen: Vec<_> = seen.lock().unwrap().drain(..).collect();
    at_once_seen.sort_by_key(|(name, _)| *name);
    // The first backend on a thread of its own, the second on the caller's.
    assert_eq!(at_once_seen[1], ("b", caller));
    assert_eq!(at_once_seen[0].0, "a");
    assert_ne!(at_once_seen[0].1, caller);
    let (t, c) = (turns.stats(), at_once.stats());
    assert_eq!(
        (t.compared, t.max_gap, t.sum_gap),
        (c.compared, c.max_gap, c.sum_gap)
    );
    assert!(c.first_seconds >= 0.0 && c.second_seconds >= 0.0);
    // A disagreement is found and kept the same way.
    let mut apart = CrossCheck::new(
        shifted("a", &[0.0; 3], 1e-9),
        shifted("b", &[0.0, 0.0, 4e-6], 1e-9),
        1e-6,
    )
    .concurrent(true);
    assert!(matches!(
        apart.project(&p),
        Err(ProjectionError::Disagreement { coordinate: 2, .. })
    ));
    assert!(apart.stats().disagreement.is_some());
}

/// Fails every problem with an error naming itself.
struct Failing(&'static str);

impl Projector for Failing {
    fn name(&self) -> &str {
        self.0
    }
    fn project(&mut self, _: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        Err(ProjectionError::Backend {
            backend: self.0.to_string(),
            message: "failed".to_string(),
        })
    }
}

#[test]
fn the_first_backends_error_comes_first_in_turns_or_at_once() {
    let p = problem();
    for concurrent in [false, true] {
        let mut both = CrossCheck::new(Failing("a"), Failing("b"), 1e-9).concurrent(concurrent);
        match both.project(&p) {
            Err(ProjectionError::Backend { backend, .. }) => assert_eq!(backend, "a"),
            other => panic!("{other:?}"),
        }
        let mut second_fails = CrossCheck::new(shifted("a", &[0.0; 3], 1e-9), Failing("b"), 1e-9)
            .concurrent(concurrent);
        match second_fails.project(&p) {
            Err(ProjectionError::Backend { backend, .. }) => assert_eq!(backend, "b"),
            other => panic!("{other:?}"),
        }
        assert_eq!(both.stats().compared + second_fails.stats().compared, 0);
    }
}

/// Panics on every problem.
struct Panicking;

impl Projector for Panicking {
    fn name(&self) -> &str {
        "panicking"
    }
    fn project(&mut self, _: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        panic!("the first backend panicked")
    }
}

#[test]
#[should_panic(expected = "the first backend panicked")]
fn a_panic_of_the_first_backend_on_its_thread_reaches_the_caller() {
    let mut both = CrossCheck::new(Panicking, shifted("b", &[0.0; 3], 1e-9), 1e-9).concurrent(true);
    let _ = both.project(&problem());
}

/// Answers as [`Shifted`] after sleeping `nap`.
struct Napping {
    inner: Shifted,
    nap: std::time::Duration,
}

impl Projector for Napping {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        std::thread::sleep(self.nap);
        self.inner.project(p)
    }
}

#[test]
fn each_backends_seconds_add_up_in_turns_or_at_once() {
    let napping = |name, millis| Napping {
        inner: shifted(name, &[0.0; 3], 1e-9),
        nap: std::time::Duration::from_millis(millis),
    };
    let p = problem();
    for concurrent in [false, true] {
        let mut both =
            CrossCheck::new(napping("a", 3), napping("b", 5), 1e-9).concurrent(concurrent);
        for _ in 0..2 {
            both.project(&p).unwrap();
        }
        // A sleep lasts at least as long as asked: two projections, each backend's own time.
        let stats = both.stats();
        assert!(
            stats.first_seconds >= 0.006,
            "{concurrent}: {}",
            stats.first_seconds
        );
        assert!(
            stats.second_seconds >= 0.010,
            "{concurrent}: {}",
            stats.second_seconds
        );
    }
}

/// Answers `y` shifted by the next of `shifts` at each call.
struct ShiftedInTurn {
    shifts: Vec<Vec<f64>>,
    calls: usize,
}

impl Projector for ShiftedInTurn {
    fn name(&self) -> &str {
        "in-turn"
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let mut answer = Projection::identity(p, "in-turn");
        let shift = &self.shifts[self.calls];
        self.calls += 1;
        answer.x.iter_mut().zip(shift).for_each(|(x, s)| *x += s);
        Ok(answer)
    }
}

#[test]
fn the_largest_gap_that_passed_is_kept_with_its_problem_and_both_answers() {
    let second = ShiftedInTurn {
        shifts: vec![
            vec![0.0; 3],
            vec![0.0, 4e-10, 0.0],
            vec![0.0, 0.0, 1e-10],
            vec![7e-10, 0.0, 0.0],
            vec![0.0, 0.0, 5e-6],
        ],
        calls: 0,
    };
    let mut both = CrossCheck::new(shifted("a", &[0.0; 3], 1e-9), second, 1e-9);
    let problems: Vec<ProjectionProblem> = (0..5)
        .map(|k| {
            let a = SparseRows::from_rows(3, &[vec![(0, 1.0)]]);
            ProjectionProblem::new(vec![1.0, 2.0, f64::from(k)], a, vec![0.0]).unwrap()
        })
        .collect();
    // No gap yet: nothing kept.
    both.project(&problems[0]).unwrap();
    assert!(both.stats().largest_passed_gap.is_none());
    // 4e-10, then a smaller gap that does not replace it, then a larger one that does.
    both.project(&problems[1]).unwrap();
    let kept = both.stats().largest_passed_gap.as_deref().unwrap();
    assert!(
        (kept.gap - 4e-10).abs() < 1e-15 && kept.coordinate == 1,
        "{kept:?}"
    );
    both.project(&problems[2]).unwrap();
    let kept = both.stats().largest_passed_gap.as_deref().unwrap();
    assert_eq!(kept.problem, problems[1]);
    both.project(&problems[3]).unwrap();
    let kept = both.stats().largest_passed_gap.as_deref().unwrap();
    assert!(
        (kept.gap - 7e-10).abs() < 1e-15 && kept.coordinate == 0,
        "{kept:?}"
    );
    assert_eq!(kept.problem, problems[3]);
    assert_eq!(kept.first.x, vec![1.0, 2.0, 3.0]);
    assert_eq!(kept.second.x, vec![1.0 + 7e-10, 2.0, 3.0]);
    assert_eq!(
        (kept.first_backend.as_str(), kept.second_backend.as_str()),
        ("a", "in-turn")
    );
    // A gap beyond the tolerance is the disagreement, not a gap that passed.
    assert!(both.project(&problems[4]).is_err());
    let stats = both.stats();
    assert_eq!(
        stats.largest_passed_gap.as_deref().unwrap().problem,
        problems[3]
    );
    assert!((stats.disagreement.as_deref().unwrap().gap - 5e-6).abs() < 1e-12);
    // Neither is in a serialized summary.
    let json = serde_json::to_value(stats).unwrap();
    assert!(json.get("largest_passed_gap").is_none(), "{json}");
}
