//! Where the time of a step goes: mean seconds per stage (effects, broad phase, assembly,
//! projection, check) over the first steps of the benchmark crowds, per N and backend.
//!
//! `cargo run --release --example bench_stages [-- STEPS]` (default 20 steps).

use sweeping::backends::{make_projector, BackendChoice};
use sweeping::stepper::{StageTimes, Stepper, StepperSettings};

#[path = "../benches/common/crowd.rs"]
mod crowd;

fn main() -> anyhow::Result<()> {
    let steps: usize = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 20,
    };
    println!(
        "{:<8} {:>5} {:<10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>7} {:>7}",
        "start",
        "N",
        "backend",
        "effects",
        "broad",
        "assembly",
        "projection",
        "check",
        "total",
        "rows",
        "active"
    );
    for (dense, h) in [(false, 0.01), (true, 0.1)] {
        for n in [150usize, 1000, 5000] {
            let problem = crowd::crowd(n, dense, 7);
            for backend in [
                BackendChoice::Native,
                BackendChoice::Clarabel,
                BackendChoice::Osqp,
                BackendChoice::Reference,
            ] {
                if backend == BackendChoice::Reference && n > 150 {
                    continue;
                }
                let Ok(mut projector) = make_projector(backend) else {
                    continue;
                };
                let settings = StepperSettings {
                    h,
                    t_end: steps as f64 * h,
                    ..Default::default()
                };
                let mut stepper = Stepper::new(&problem, settings)?;
                let mut sum = StageTimes::default();
                let (mut rows, mut active) = (0usize, 0usize);
                let mut failure = None;
                for _ in 0..steps {
                    let r = match stepper.step(projector.as_mut()) {
                        Ok(r) => r,
                        Err(e) => {
                            failure = Some(e);
                            break;
                        }
                    };
                    sum.effects += r.times.effects;
                    sum.broad_phase += r.times.broad_phase;
                    sum.assembly += r.times.assembly;
                    sum.projection += r.times.projection;
                    sum.check += r.times.check;
                    rows += r.rows;
                    active += r.active;
                }
                if let Some(e) = failure {
                    println!(
                        "{:<8} {:>5} {:<10} failed: {e}",
                        if dense { "dense" } else { "spread" },
                        n,
                        backend.to_string()
                    );
                    continue;
                }
                let k = steps as f64;
                let ms = |v: f64| format!("{:.3} ms", 1e3 * v / k);
                println!(
                    "{:<8} {:>5} {:<10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>7} {:>7}",
                    if dense { "dense" } else { "spread" },
                    n,
                    backend.to_string(),
                    ms(sum.effects),
                    ms(sum.broad_phase),
                    ms(sum.assembly),
                    ms(sum.projection),
                    ms(sum.check),
                    ms(sum.total()),
                    rows / steps.max(1),
                    active / steps.max(1),
                );
            }
        }
    }
    Ok(())
}
