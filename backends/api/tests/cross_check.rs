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
            unfinished,
        }) => {
            assert_eq!(unfinished, [0, 0], "neither answer says it is unfinished");
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

/// Answers as [`Shifted`], reporting `blocks` blocks left unfinished by a second pass, off by
/// `off`.
struct Unfinished {
    inner: Shifted,
    blocks: u32,
    off: f64,
}

impl Projector for Unfinished {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let mut answer = self.inner.project(p)?;
        answer.stats.unfinished = self.blocks;
        answer.stats.unfinished_off = self.off;
        Ok(answer)
    }
}

#[test]
fn a_disagreement_names_the_answer_left_unfinished() {
    let first = shifted("native", &[0.0; 3], 1e-9);
    let second = Unfinished {
        inner: shifted("clarabel", &[0.0, 2.3e-8, 0.0], 1e-9),
        blocks: 1,
        off: 8.5e-13,
    };
    let mut both = CrossCheck::new(first, second, 1e-8);
    let error = both.project(&problem()).unwrap_err();
    let message = error.to_string();
    assert!(
        message.ends_with(
            "> tolerance 1.0e-8; clarabel's answer: 1 block(s) left unfinished by the second \
             pass (see SolveStats::unfinished)"
        ),
        "{message}"
    );
    assert!(!message.contains("native's answer"), "{message}");
    // The kept answers carry the counts, for whoever decides the step from the file.
    let kept = both.stats().disagreement.as_deref().unwrap();
    assert_eq!(
        (kept.first.stats.unfinished, kept.second.stats.unfinished),
        (0, 1)
    );
    assert_eq!(kept.second.stats.unfinished_off, 8.5e-13);
}
