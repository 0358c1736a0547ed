//! On the paper's evacuation, `--backend cross` (Clarabel against OSQP,
//! tolerance 1e-6) stops where the two differ by more than 1e-6. Which one is off?
//!
//! This test replays the cross-checked run, keeps the QP of the step where they disagree and
//! both answers, and computes the exact projection independently of both backends, with a
//! certificate: the projection of `y` onto the affine set of the projection's support, found
//! by the least-distance program (dense non-negative least squares) or as the rows tight at an
//! answer (dense SVD least squares), checked feasible for every row, and `x − y = A_Tᵀλ` with `λ ≥ 0`
//! found by a dense non-negative least-squares solve — the KKT conditions of the convex
//! projection, which pin the point whatever active-set guess it came from. Long (≈1200 steps
//! of both backends): `cargo test --release --test cross_stop_clarabel_osqp -- --ignored --nocapture`.
#![cfg(all(feature = "clarabel", feature = "osqp"))]

use sweeping::api::conformance::max_gap;
use sweeping::api::Projector;
use sweeping::backends::{ClarabelProjector, OsqpProjector, OsqpSettings};

#[path = "common/replay.rs"]
mod replay;

#[test]
#[ignore = "long: replays ~1200 steps with both backends"]
fn which_backend_is_right_where_cross_stops_on_the_paper_evacuation() {
    let (mut clarabel, mut osqp) = (ClarabelProjector::default(), OsqpProjector::default());
    let Some(d) = replay::first_disagreement("paper-evacuation", &mut clarabel, &mut osqp, 1e-6)
    else {
        eprintln!("Clarabel and OSQP agreed to 1e-6 on every step: nothing to decide");
        return;
    };
    let (problem, clarabel, osqp) = (d.problem, d.first, d.second);
    let best = replay::certified_projection(
        &problem,
        &[("clarabel", &clarabel.x), ("osqp", &osqp.x)],
        &[1e-9, 1e-8, 1e-7, 1e-6],
    );
    let (x_star, violation, residual) = best.expect("no certified reference");
    let (dc, dosqp) = (max_gap(&clarabel.x, &x_star), max_gap(&osqp.x, &x_star));
    let kc = problem.kkt_residuals(&clarabel.x, &clarabel.multipliers);
    let ko = problem.kkt_residuals(&osqp.x, &osqp.multipliers);
    eprintln!(
        "certified x* (violation {violation:.2e}, cone residual {residual:.2e}): clarabel off by {dc:.3e} (KKT {:.2e}), osqp off by {dosqp:.3e} (KKT {:.2e})",
        kc.max(),
        ko.max()
    );
    // The decision: Clarabel's answer is the projection to rounding; OSQP's is not, although
    // its KKT residuals are within its tolerance (nearly dependent active rows: small
    // residuals, a larger error in x).
    assert!(
        dc <= 1e-9,
        "Clarabel is {dc:.3e} from the certified projection"
    );
    assert!(
        dosqp >= 1e-6,
        "OSQP is {dosqp:.3e} from the certified projection"
    );
    // OSQP with its own polish (an active-set solve after ADMM) on the same QP, cold.
    let mut polished = OsqpProjector::new(OsqpSettings {
        polish: true,
        ..OsqpSettings::default()
    });
    match polished.project(&problem) {
        Ok(p) => eprintln!(
            "osqp with polish on the same QP (cold): off by {:.3e}",
            max_gap(&p.x, &x_star)
        ),
        Err(e) => eprintln!("osqp with polish on the same QP: {e}"),
    }
}
