//! Helpers shared by the integration tests.
#![allow(dead_code)]

use sweeping::api::Projector;
use sweeping::backends::{make_projector, BackendChoice};

/// The real backends compiled in (Clarabel, OSQP, their cross-check, native and its
/// cross-check with Clarabel), each freshly built;
/// the ones whose cargo feature is off are skipped (and named on stderr).
pub fn real_backends() -> Vec<(BackendChoice, Box<dyn Projector>)> {
    let mut out = Vec::new();
    for c in [
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Cross,
        BackendChoice::Native,
        BackendChoice::CrossNative,
    ] {
        match make_projector(c) {
            Ok(p) => out.push((c, p)),
            Err(why) => eprintln!("skipping backend {c}: {why}"),
        }
    }
    out
}

/// Least-squares slope of `log e` against `log h` ([`sweeping::study::fit_order`]; NaN when
/// the points cannot be fitted).
pub fn fitted_order(hs: &[f64], errs: &[f64]) -> f64 {
    sweeping::study::fit_order(hs, errs).map_or(f64::NAN, |fit| fit.order)
}

/// `h₀, h₀/2, …` (`levels` values).
pub fn halvings(h0: f64, levels: usize) -> Vec<f64> {
    (0..levels).map(|i| h0 / f64::powi(2.0, i as i32)).collect()
}

/// The assumptions' constants estimated at `samples` with the default settings and the
/// reference projector.
pub fn estimate(
    problem: &sweeping::problem::Problem,
    samples: &[(f64, Vec<f64>)],
) -> sweeping::assumptions::AssumptionReport {
    estimate_with(problem, samples, &Default::default())
}

/// [`estimate`] with other settings.
pub fn estimate_with(
    problem: &sweeping::problem::Problem,
    samples: &[(f64, Vec<f64>)],
    settings: &sweeping::assumptions::EstimateSettings,
) -> sweeping::assumptions::AssumptionReport {
    sweeping::assumptions::estimate_problem(
        problem,
        samples,
        settings,
        &mut sweeping::api::conformance::ReferenceProjector::default(),
    )
    .unwrap()
}

/// The largest `|a − b|` over every coordinate of every recorded state of two runs, state by
/// state in order.
pub fn trajectory_gap(a: &sweeping::stepper::Trajectory, b: &sweeping::stepper::Trajectory) -> f64 {
    a.states
        .iter()
        .flatten()
        .zip(b.states.iter().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// `[1.234e-3, …]`.
pub fn sci(values: &[f64]) -> String {
    let v: Vec<String> = values.iter().map(|e| format!("{e:.3e}")).collect();
    format!("[{}]", v.join(", "))
}

pub mod kernels;
pub mod scene_geometry;

/// `problem` run with step `h` to `t_end` on `projector`, with the default settings otherwise;
/// a failure panics naming `h`.
pub fn run(
    problem: &sweeping::problem::Problem,
    h: f64,
    t_end: f64,
    projector: &mut dyn Projector,
) -> sweeping::stepper::Run {
    let settings = sweeping::stepper::StepperSettings {
        h,
        t_end,
        ..Default::default()
    };
    sweeping::stepper::Stepper::new(problem, settings)
        .expect("feasible start")
        .run(projector, &mut [])
        .unwrap_or_else(|f| panic!("h = {h}: {f}"))
}
