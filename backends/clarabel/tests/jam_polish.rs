//! A jam's block on which joining every violated row at once does not finish the polish.
//!
//! The fixture `jam_polish_guess.json` holds 400 rows of a jammed block of the 2000-person
//! evacuation (`examples/scenes/large-evacuation.toml`, step 983, t = 9.84 s; the rows
//! within reach of the coordinate where the cross-check stopped, 356 unknowns) and the
//! interior-point answer Clarabel gave there on the whole step (`x`, multipliers `z`). From
//! that guess, the rows with `z > s` are 363, more than the unknowns: joined together, the
//! violated rows keep making the support's equations inconsistent and leaving again one per
//! iteration. On the whole block of 1644 rows that never ended (20 000 iterations), and the
//! polish kept the unpolished iterate, 4.2e-8 from the projection, which stopped
//! `--backend cross-native`. The most violated row joining alone finishes.

use sweeping_api::ProjectionProblem;
use sweeping_qp::active_set::{self, Failure, Options, Start};
use sweeping_testkit::certified::assert_is_the_projection;

/// The block, the interior point's `x` and `z`, and the slacks `s = A x − b`.
fn jam() -> (ProjectionProblem, Vec<f64>, Vec<f64>, Vec<f64>) {
    #[derive(serde::Deserialize)]
    struct Data {
        problem: ProjectionProblem,
        interior_point_x: Vec<f64>,
        interior_point_z: Vec<f64>,
    }
    let data: Data = sweeping_testkit::fixtures::read("jam_polish_guess.json");
    let p = data.problem;
    let s = p
        .shortfall(&data.interior_point_x)
        .iter()
        .map(|r| -r)
        .collect();
    (p, data.interior_point_x, data.interior_point_z, s)
}

/// The polish's start from `(z, s)`: rows with `z > s`, from their multipliers.
fn guess(z: &[f64], s: &[f64], join_at_most: Option<usize>) -> Start {
    let support: Vec<usize> = (0..z.len()).filter(|&i| z[i] > s[i]).collect();
    Start {
        lambda: support
            .iter()
            .map(|&i| z[i].max(f64::MIN_POSITIVE))
            .collect(),
        support,
        join: z.iter().map(|v| v.max(f64::MIN_POSITIVE)).collect(),
        join_at_most,
    }
}

#[test]
fn on_a_jam_the_polish_finishes_when_the_most_violated_row_joins_alone() {
    let (problem, _, z, s) = jam();
    assert_eq!((problem.n_rows(), problem.dim()), (400, 356));
    assert_eq!(guess(&z, &s, None).support.len(), 363);
    // The polish's cap on a block of 400 rows: 40 + 400/2.
    let cap = 240;
    assert!(matches!(
        active_set::solve(&problem, guess(&z, &s, None), Options::capped(cap)),
        Err(Failure::Cap(_))
    ));
    let outcome = active_set::solve(&problem, guess(&z, &s, Some(1)), Options::capped(cap))
        .expect("one row joining at a time finishes within the cap");
    let kkt = problem.kkt_residuals(&outcome.x, &outcome.lambda).max();
    assert!(kkt <= 1e-12, "KKT residual {kkt:.3e}");
    assert_is_the_projection(&problem, &outcome.x, "the jam's polished block");
}
