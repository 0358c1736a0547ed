//! Runs that leave the theory stop and say why: violations measured as distances, A1 watched
//! near contact, and the start-of-run checks confined to the neighbourhood the estimate saw.

use sweeping::error::SweepError;
use sweeping::prelude::*;

/// `10⁻⁶ (1 − x²) ≥ 0`: the segment `[−1, 1]` written with a concave `g` of tiny scale.
struct ScaledSegment;

impl ConstraintKernel<1> for ScaledSegment {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D {
        (z[0] * z[0]).rsub(1.0) * 1e-6
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
}

#[test]
fn a_violation_is_a_distance_whatever_the_scale_of_g_and_names_failed_convexity() {
    // From 0.95 the linearization of the concave g lets the point reach 1.0013: 1.3e-3 outside
    // the segment, though g there is only −2.6e-9.
    let problem = Problem::new(vec![0.55], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = 1.0)
        .with_constraint("scaled segment", ScaledSegment, [0]);
    let settings = StepperSettings {
        h: 0.1,
        t_end: 1.0,
        ..Default::default()
    };
    let failure = Stepper::new(&problem, settings)
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap_err();
    match &failure.error {
        SweepError::ViolationTooLarge {
            constraint,
            violation,
            why,
            ..
        } => {
            assert!(constraint.contains("scaled segment"), "{constraint}");
            assert!((1e-3..2e-3).contains(violation), "{violation}");
            let why = why.as_deref().unwrap_or_default();
            assert!(why.contains("convexity fails"), "{why}");
        }
        other => panic!("expected ViolationTooLarge, got {other}"),
    }
    let message = failure.error.to_string();
    assert!(message.contains("violated by a distance of"), "{message}");
    assert!(message.contains("convexity fails"), "{message}");
}

/// `(x − 1)² ≥ 0`: convex, true everywhere, with a double root where its gradient vanishes.
struct DoubleRoot;

impl ConstraintKernel<1> for DoubleRoot {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D {
        let d = z[0] - 1.0;
        d * d
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
}

/// The assumptions' estimate on the states of a run of `problem` (the reference backend).
fn estimate_along_a_run(
    problem: &Problem,
    settings: StepperSettings,
) -> sweeping::assumptions::AssumptionReport {
    let run = Stepper::new(problem, settings)
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap();
    let samples = sweeping::assumptions::samples_from_trajectory(&run.trajectory);
    estimate_problem(
        problem,
        &samples,
        &EstimateSettings::default(),
        &mut ReferenceProjector::default(),
    )
    .unwrap()
}

fn falling_through_a_double_root() -> Problem {
    Problem::new(vec![2.0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = -1.0).with_constraint(
        "double root",
        DoubleRoot,
        [0],
    )
}

#[test]
fn a_flat_active_constraint_stops_the_run_naming_a1() {
    let problem = falling_through_a_double_root();
    let settings = StepperSettings {
        h: 0.1,
        t_end: 3.0,
        ..Default::default()
    };
    let mut backend = make_projector(BackendChoice::default()).unwrap();
    let failure = Stepper::new(&problem, settings)
        .unwrap()
        .run(backend.as_mut(), &mut [])
        .unwrap_err();
    match &failure.error {
        SweepError::DegenerateConstraint {
            constraint, norm, ..
        } => {
            assert!(constraint.contains("double root"), "{constraint}");
            assert!(*norm < 1e-6, "{norm}");
        }
        other => panic!("expected DegenerateConstraint, got {other}"),
    }
    assert!(
        failure.error.to_string().contains("A1"),
        "{}",
        failure.error
    );
}

#[test]
fn the_estimate_reports_a_tiny_alpha_as_a_failed_a1() {
    let problem = falling_through_a_double_root();
    // The trajectory the check now refuses, to sample near the double root.
    let settings = StepperSettings {
        h: 0.1,
        t_end: 3.0,
        gradient_floor: 0.0,
        ..Default::default()
    };
    let report = estimate_along_a_run(&problem, settings);
    assert!(
        report.failures.iter().any(|f| f.starts_with("A1: α")),
        "{}",
        report.table()
    );
}

/// `|z|² − 1 ≥ 0`: outside the unit disk.
struct OutsideUnitDisk;

impl ConstraintKernel<2> for OutsideUnitDisk {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 2]) -> D {
        (z[0] * z[0] + z[1] * z[1]) - 1.0
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
}

#[test]
fn bounds_from_an_estimate_are_checked_at_the_start_where_they_were_measured() {
    // From (5, 0.3), pushed onto the disk: |∇g| = 2|z| is 10 at the start, far outside the
    // neighbourhood the estimate measured β in.
    let problem = Problem::new(vec![5.0, 0.3], |_t: f64, _q: &[f64], f: &mut [f64]| {
        f.copy_from_slice(&[-1.0, 0.0])
    })
    .with_constraint("outside disk", OutsideUnitDisk, [0, 1]);
    let settings = StepperSettings {
        h: 0.01,
        t_end: 6.0,
        ..Default::default()
    };
    let report = estimate_along_a_run(&problem, settings.clone());
    let bounds = Bounds::from_report(&report, 0.01);
    assert!(bounds.beta.unwrap() < 10.0, "{bounds:?}");
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds,
            ..Default::default()
        },
    );
    let rerun = Stepper::new(&problem, settings)
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor]);
    if let Err(failure) = &rerun {
        panic!("{failure}");
    }
    assert!(monitor.checks() > 0);
}
