//! Two disks of radius ½ on a line: the rear one walks at (1, 0), the front one stands still,
//! the gap is `d₀`. Exactly: free until `t = d₀`, then both move at speed ½. The scheme
//! reproduces this to round-off for every `h`, even when contact begins inside a step.
//!
//! ```text
//! cargo run --example two_disks [-- BACKEND]     # clarabel, osqp, cross or reference
//! ```

use anyhow::{anyhow, Context};
use sweeping::backends::{make_projector, BackendChoice};
use sweeping::crowd::{DiskPairs, Population};
use sweeping::prelude::*;

const D0: f64 = 0.37;
const T_END: f64 = 1.0;

fn exact(t: f64) -> [f64; 2] {
    if t <= D0 {
        [t, 1.0 + D0]
    } else {
        [D0 + (t - D0) / 2.0, 1.0 + D0 + (t - D0) / 2.0]
    }
}

fn main() -> anyhow::Result<()> {
    let choice = match std::env::args().nth(1) {
        Some(name) => name.parse::<BackendChoice>().map_err(|e| anyhow!(e))?,
        None => [BackendChoice::Clarabel, BackendChoice::Osqp]
            .into_iter()
            .find(|&c| make_projector(c).is_ok())
            .unwrap_or(BackendChoice::Reference),
    };
    let mut projector = make_projector(choice)?;
    println!(
        "backend: {}; gap d₀ = {D0}; contact at t = {D0}",
        projector.name()
    );

    let pop = Population::new(vec![0.5, 0.5]).shared();
    let problem = Problem::new(
        vec![0.0, 0.0, 1.0 + D0, 0.0],
        |_t: f64, _q: &[f64], f: &mut [f64]| f.copy_from_slice(&[1.0, 0.0, 0.0, 0.0]),
    )
    .with_family(DiskPairs::new(pop));

    for h in [0.5, 0.25, 0.1, 0.07, 0.01] {
        let settings = StepperSettings {
            h,
            t_end: T_END,
            ..Default::default()
        };
        let run = Stepper::new(&problem, settings)?
            .run(&mut projector, &mut [])
            .map_err(|f| anyhow!("{f}"))
            .with_context(|| format!("run with h = {h}"))?;
        println!("\nh = {h} ({} steps)", run.stats.steps);
        println!(
            "  {:>6}  {:>20}  {:>20}  {:>9}",
            "t", "rear x (num / exact)", "front x (num / exact)", "error"
        );
        let mut worst = 0.0f64;
        let n = run.trajectory.times.len();
        let stride = (n / 10).max(1);
        for (i, (t, q)) in run
            .trajectory
            .times
            .iter()
            .zip(&run.trajectory.states)
            .enumerate()
        {
            let e = exact(*t);
            let err = (q[0] - e[0]).abs().max((q[2] - e[1]).abs());
            worst = worst.max(err);
            if i % stride != 0 && i + 1 != n {
                continue;
            }
            println!(
                "  {t:>6.3}  {:>9.6} / {:>8.6}  {:>9.6} / {:>9.6}  {err:>9.2e}",
                q[0], e[0], q[2], e[1]
            );
        }
        println!("  largest error over all {n} recorded times: {worst:.2e}");
    }
    Ok(())
}
