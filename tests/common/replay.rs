//! Replaying a scene with two backends on every step and deciding, against a certified
//! projection, which one is off where they first disagree. Shared by the cross-check
//! certificates (`cross_stop_clarabel_osqp.rs`: Clarabel against OSQP;
//! `cross_stop_native_clarabel.rs`: native against Clarabel).

use sweeping::api::conformance::max_gap;
use sweeping::api::{Block, Blocks, Projection, ProjectionError, ProjectionProblem, Projector};
use sweeping::scene::{Overrides, Scene};
use sweeping::stepper::Stepper;
use sweeping_testkit::certified::{least_distance, reference};

/// The first step where two backends differ by more than the tolerance.
pub struct Disagreement {
    pub problem: ProjectionProblem,
    pub first: Projection,
    pub second: Projection,
    pub gap: f64,
}

/// Both backends on every step (the first one's answer is kept); records the first
/// disagreement and stops the run there.
struct Recorder<'a> {
    first: &'a mut dyn Projector,
    second: &'a mut dyn Projector,
    tolerance: f64,
    disagreement: Option<Disagreement>,
}

impl Projector for Recorder<'_> {
    fn name(&self) -> &str {
        "recorder"
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let a = self.first.project(p)?;
        let b = self.second.project(p)?;
        let gap = max_gap(&a.x, &b.x);
        if gap.is_nan() || gap > self.tolerance {
            self.disagreement = Some(Disagreement {
                problem: p.clone(),
                first: a,
                second: b,
                gap,
            });
            return Err(ProjectionError::Backend {
                backend: "recorder".into(),
                message: format!("disagreement {gap:.3e}"),
            });
        }
        Ok(a)
    }
}

/// Runs the shipped scene `name` with both backends to its end or to their first
/// disagreement beyond `tolerance`, which it prints and returns.
pub fn first_disagreement(
    name: &str,
    first: &mut dyn Projector,
    second: &mut dyn Projector,
    tolerance: f64,
) -> Option<Disagreement> {
    let path = format!("{}/examples/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let built = Scene::from_file(path)
        .unwrap()
        .build(&Overrides::default())
        .unwrap();
    let mut stepper = Stepper::new(&built.problem, built.settings.clone()).unwrap();
    let mut recorder = Recorder {
        first,
        second,
        tolerance,
        disagreement: None,
    };
    while stepper.steps_done() < stepper.n_steps() {
        if let Err(e) = stepper.step(&mut recorder) {
            if let Some(d) = &recorder.disagreement {
                eprintln!(
                    "disagreement at step {} ({e}): gap {:.3e}, {} rows, dim {}",
                    stepper.steps_done(),
                    d.gap,
                    d.problem.n_rows(),
                    d.problem.dim()
                );
            }
            break;
        }
    }
    recorder.disagreement
}

/// Most rows for which [`certified_projection`] also solves the least-distance program
/// (dense, cubic in the rows).
const LEAST_DISTANCE_ROWS: usize = 600;

/// The best certified projection (violation and cone residual at most 1e-10; the best is the
/// one whose larger of the two is least) of `problem`: from the least-distance program where
/// the problem has at most [`LEAST_DISTANCE_ROWS`] rows, and from the rows tight at each answer
/// in `answers` within each of `tight_tols`, printing each candidate's distance to every
/// answer: `(x*, violation, residual)`.
pub fn certified_projection(
    problem: &ProjectionProblem,
    answers: &[(&str, &[f64])],
    tight_tols: &[f64],
) -> Option<(Vec<f64>, f64, f64)> {
    let mut candidates = Vec::new();
    if problem.n_rows() <= LEAST_DISTANCE_ROWS {
        candidates.push((
            "the least-distance program".to_string(),
            least_distance(problem),
        ));
    }
    for (name, guess) in answers {
        for &tight_tol in tight_tols {
            candidates.push((
                format!("{name}'s active set (slack ≤ {tight_tol:.0e})"),
                reference(problem, guess, tight_tol),
            ));
        }
    }
    let mut best: Option<(Vec<f64>, f64, f64)> = None;
    for (from, (x, violation, residual)) in candidates {
        let distances: Vec<String> = answers
            .iter()
            .map(|(other, y)| format!("‖{other} − x*‖∞ = {:.3e}", max_gap(y, &x)))
            .collect();
        eprintln!(
            "  from {from}: violation {violation:.2e}, cone residual {residual:.2e}, {}",
            distances.join(", ")
        );
        let worst = violation.max(residual);
        if worst <= 1e-10 && best.as_ref().is_none_or(|b| worst < b.1.max(b.2)) {
            best = Some((x, violation, residual));
        }
    }
    best
}

/// The block of `problem` (its connected component, see [`Blocks`]) holding the coordinate
/// where answers `a` and `b` differ most, with both answers restricted to it. The projection
/// separates over blocks, so a certified projection of that block alone decides the
/// disagreement, at the cost of the block rather than of the whole step (the dense reference
/// does not scale to the thousands of rows of a large scene).
#[allow(dead_code)] // used by the native certificate, not by every includer
pub fn block_of_largest_gap(
    problem: &ProjectionProblem,
    a: &[f64],
    b: &[f64],
) -> (Block, Vec<f64>, Vec<f64>) {
    let worst = (0..a.len())
        .max_by(|&i, &j| (a[i] - b[i]).abs().total_cmp(&(a[j] - b[j]).abs()))
        .expect("answers have coordinates");
    let block = Blocks::split(problem)
        .blocks()
        .iter()
        .find(|block| block.cols.contains(&worst))
        .cloned()
        .expect("two answers can only differ on a coordinate some row touches");
    let restrict = |x: &[f64]| block.cols.iter().map(|&c| x[c]).collect::<Vec<f64>>();
    let (ra, rb) = (restrict(a), restrict(b));
    (block, ra, rb)
}
