//! A user-defined constraint that is not a crowd: a point pushed by a field and kept outside
//! an ellipse that drifts, bobs and turns. The constraint is written once, over dual numbers;
//! its gradient (and `∂ₜ`) come by autodiff.
//!
//! The same run is made with every backend that is compiled in — Clarabel, OSQP, their
//! cross-check, and the dependency-free reference — and the example prints their final
//! positions, how far apart their trajectories are, and the time each took. Each real backend
//! is also run inside a `CrossCheck` against the reference, which compares every step.
//!
//! ```text
//! cargo run --example custom_constraint                         # Clarabel and OSQP
//! cargo run --no-default-features --example custom_constraint  # reference only
//! ```

use std::time::Instant;
use sweeping::prelude::*;

/// `g(t, z) = √((u/a)² + (w/b)²) − 1 ≥ 0`, with `(u, w)` the point in the ellipse's frame:
/// centre `c(t) = (0.5 − 0.2 t, 0.3 sin t)`, turned by `ω t`. Convex in `z` (a norm of an
/// affine map, minus one), so its linearization never lets the point into the ellipse.
struct OutsideMovingEllipse {
    a: f64,
    b: f64,
    omega: f64,
}

impl Constraint<2> for OutsideMovingEllipse {
    fn value<D: Scalar>(&self, t: D, z: [D; 2]) -> D {
        let dx = z[0] - (t * -0.2 + 0.5);
        let dy = z[1] - t.sin() * 0.3;
        let (s, c) = ((t * self.omega).sin(), (t * self.omega).cos());
        let u = (dx * c + dy * s) * (1.0 / self.a);
        let w = (dy * c - dx * s) * (1.0 / self.b);
        (u * u + w * w).sqrt() - 1.0
    }
}

/// Counts the steps in which the ellipse held the point back.
#[derive(Default)]
struct ContactSteps(usize);

impl Observer for ContactSteps {
    fn name(&self) -> &str {
        "contact counter"
    }
    fn on_step(&mut self, report: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
        if report.active > 0 {
            self.0 += 1;
        }
        Ok(())
    }
}

fn problem() -> Problem {
    // The field: a push to the right, and a spring towards the axis y = 0.
    let field = |_t: f64, q: &[f64], f: &mut [f64]| {
        f[0] = 1.0;
        f[1] = -0.5 * q[1];
    };
    let ellipse = OutsideMovingEllipse {
        a: 1.2,
        b: 0.6,
        omega: 0.4,
    };
    Problem::new(vec![-3.0, 0.15], field).with_constraint(
        "outside the moving ellipse",
        ellipse,
        [0, 1],
    )
}

fn settings() -> StepperSettings {
    StepperSettings {
        h: 0.01,
        t_end: 6.0,
        ..Default::default()
    }
}

fn run_with(problem: &Problem, projector: &mut dyn Projector) -> anyhow::Result<(Run, usize, f64)> {
    let mut contact = ContactSteps::default();
    let start = Instant::now();
    let run = Stepper::new(problem, settings())?.run(projector, &mut [&mut contact])?;
    Ok((run, contact.0, start.elapsed().as_secs_f64()))
}

fn gap(a: &Run, b: &Run) -> f64 {
    a.trajectory
        .states
        .iter()
        .flatten()
        .zip(b.trajectory.states.iter().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn main() -> anyhow::Result<()> {
    let problem = problem();
    let s = settings();
    println!(
        "a point pushed by a field around a moving ellipse; h = {}, T = {}\n",
        s.h, s.t_end
    );
    println!(
        "{:<22} {:>22} {:>13} {:>13} {:>9}",
        "backend", "final position", "contact steps", "max violation", "seconds"
    );
    let mut runs: Vec<(String, Run)> = Vec::new();
    for choice in [
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Cross,
        BackendChoice::Reference,
    ] {
        let mut projector = match make_projector(choice) {
            Ok(p) => p,
            Err(why) => {
                println!("{:<22} (not run: {why})", choice.to_string());
                continue;
            }
        };
        let (run, contact, seconds) = run_with(&problem, &mut projector)?;
        println!(
            "{:<22} ({:>9.6}, {:>9.6}) {:>13} {:>13.2e} {:>9.3}",
            projector.name(),
            run.q_final[0],
            run.q_final[1],
            contact,
            run.stats.max_violation,
            seconds
        );
        runs.push((choice.to_string(), run));
    }

    println!("\nlargest gap between trajectories (∞-norm over all recorded states):");
    if runs.len() < 2 {
        println!("  only one backend ran; build with `--features clarabel,osqp` to compare");
    }
    for i in 0..runs.len() {
        for j in (i + 1)..runs.len() {
            println!(
                "  {} vs {}: {:.2e}",
                runs[i].0,
                runs[j].0,
                gap(&runs[i].1, &runs[j].1)
            );
        }
    }

    println!("\nstep-by-step cross-check against the reference (tolerance 1e-6):");
    let mut any = false;
    for choice in [BackendChoice::Clarabel, BackendChoice::Osqp] {
        if let Ok(real) = make_projector(choice) {
            any = true;
            let mut both = CrossCheck::new(real, ReferenceProjector::default(), 1e-6);
            match run_with(&problem, &mut both) {
                Ok(_) => println!(
                    "  {choice} vs reference: {} projections compared, largest gap {:.2e}, \
                     mean {:.2e}",
                    both.stats().compared,
                    both.stats().max_gap,
                    both.stats().sum_gap / both.stats().compared.max(1) as f64
                ),
                Err(e) => println!("  {choice} vs reference: {e}"),
            }
        }
    }
    if !any {
        println!("  no real backend compiled in; build with `--features clarabel,osqp`");
    }
    Ok(())
}
