//! On the paper's evacuation, `--backend cross-native` (the native backend against Clarabel,
//! tolerance 1e-8) stops where the two differ by more than 1e-8. Which one is off?
//!
//! As `cross_certificate.rs` does for Clarabel and OSQP: the run is replayed with both
//! backends, the QP of the first step where they disagree is kept with both answers, and the
//! exact projection is computed independently of both (the least-squares projection onto the
//! rows tight at an answer, feasible for every row, with non-negative multipliers found by a
//! dense non-negative least-squares solve). Long (≈500 steps of both backends):
//! `cargo test --release --test cross_native_certificate -- --ignored --nocapture`.
#![cfg(feature = "clarabel")]

use sweeping::api::conformance::max_gap;
use sweeping::api::{Projection, ProjectionError, ProjectionProblem, Projector};
use sweeping::backends::{native_projector, ClarabelProjector};
use sweeping::scene::{Overrides, Scene};
use sweeping::stepper::Stepper;

#[path = "common/certified.rs"]
mod certified;
use certified::reference;

const TOLERANCE: f64 = 1e-8;

/// The native backend and Clarabel on every step, as `--backend cross-native` runs them; keeps
/// the QP and both answers of the first step where they differ by more than [`TOLERANCE`].
struct Recorder {
    native: Box<dyn Projector>,
    clarabel: ClarabelProjector,
    disagreement: Option<(ProjectionProblem, Projection, Projection, f64)>,
}

impl Projector for Recorder {
    fn name(&self) -> &str {
        "recorder"
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let a = self.native.project(p)?;
        let b = self.clarabel.project(p)?;
        let gap = max_gap(&a.x, &b.x);
        if gap.is_nan() || gap > TOLERANCE {
            self.disagreement = Some((p.clone(), a, b, gap));
            return Err(ProjectionError::Backend {
                backend: "recorder".into(),
                message: format!("disagreement {gap:.3e}"),
            });
        }
        Ok(a)
    }
}

#[test]
#[ignore = "long: replays the evacuation with both backends"]
fn which_backend_is_right_where_cross_native_stops_on_the_paper_evacuation() {
    let scene = Scene::from_file(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/paper-evacuation.toml"
    ))
    .unwrap();
    let built = scene.build(&Overrides::default()).unwrap();
    let mut stepper = Stepper::new(&built.problem, built.settings.clone()).unwrap();
    let mut rec = Recorder {
        native: Box::new(native_projector()),
        clarabel: ClarabelProjector::default(),
        disagreement: None,
    };
    let mut failed_at = None;
    while stepper.steps_done() < stepper.n_steps() {
        if let Err(e) = stepper.step(&mut rec) {
            failed_at = Some((stepper.steps_done(), e.to_string()));
            break;
        }
    }
    let Some((problem, native, clarabel, gap)) = rec.disagreement else {
        eprintln!("native and Clarabel agreed to {TOLERANCE:e} on every step");
        return;
    };
    let (step, error) = failed_at.unwrap();
    eprintln!(
        "disagreement at step {step} ({error}): gap {gap:.3e}, {} rows, dim {}",
        problem.n_rows(),
        problem.dim()
    );
    let mut best: Option<(Vec<f64>, f64, f64)> = None;
    for (name, guess) in [("native", &native.x), ("clarabel", &clarabel.x)] {
        for tight_tol in [1e-10, 1e-9, 1e-8, 1e-7] {
            let (x, violation, residual) = reference(&problem, guess, tight_tol);
            eprintln!(
                "  from {name}'s active set (slack ≤ {tight_tol:.0e}): violation {violation:.2e}, cone residual {residual:.2e}, ‖native − x*‖∞ = {:.3e}, ‖clarabel − x*‖∞ = {:.3e}",
                max_gap(&native.x, &x),
                max_gap(&clarabel.x, &x)
            );
            let certified = violation <= 1e-10 && residual <= 1e-10;
            if certified && best.as_ref().is_none_or(|b| residual < b.2) {
                best = Some((x, violation, residual));
            }
        }
    }
    let kn = problem.kkt_residuals(&native.x, &native.multipliers);
    let kc = problem.kkt_residuals(&clarabel.x, &clarabel.multipliers);
    eprintln!("KKT: native {kn:?}\n     clarabel {kc:?}");
    let (x_star, violation, residual) = best.expect("no certified reference");
    let (dn, dc) = (max_gap(&native.x, &x_star), max_gap(&clarabel.x, &x_star));
    eprintln!(
        "certified x* (violation {violation:.2e}, cone residual {residual:.2e}): native off by {dn:.3e}, clarabel off by {dc:.3e}"
    );
    // Whichever it is, the answer that the run keeps (the native one) must be the projection.
    assert!(
        dn <= TOLERANCE,
        "native is {dn:.3e} from the certified projection"
    );
}
