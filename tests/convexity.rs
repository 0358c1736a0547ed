//! The convexity guard (each gᵢ convex in q, section 2 of the paper), affine claims verified,
//! and the problem set-up's loose ends: bounds validated, the start checked whole, c = ∞ for affine
//! constraints, a typed backend error, messages with rounded times, arithmetic spellings.

mod common;

use common::{estimate, estimate_with};
use sweeping::assumptions::{
    samples_from_trajectory, symmetric_min_eigenvalue, AFFINE_CLAIM, CONVEXITY,
};
use sweeping::constraint::{linearize, second_order};
use sweeping::prelude::*;

/// Runs `problem` with step `h` up to `t_end` on the reference projector, `monitor` watching.
fn watched_run(
    problem: &Problem,
    h: f64,
    t_end: f64,
    monitor: &mut BoundsMonitor,
) -> Result<Run, Box<RunFailure>> {
    Stepper::new(problem, settings(h, t_end))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [monitor])
}

fn error_monitor(problem: &Problem, bounds: Bounds) -> BoundsMonitor<'_> {
    BoundsMonitor::new(
        problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds,
            ..Default::default()
        },
    )
}

/// Inside the unit disk, written as 1 − |z|²: concave, D²g = −2 I.
struct InsideDisk;
impl ConstraintKernel<2> for InsideDisk {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 2]) -> D {
        (z[0] * z[0] + z[1] * z[1]).rsub(1.0)
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
}

/// Outside the unit disk, |z| − 1: convex.
struct OutsideDisk;
impl Constraint<2> for OutsideDisk {
    fn value<D: Scalar>(&self, _t: D, z: [D; 2]) -> D {
        (z[0] * z[0] + z[1] * z[1]).sqrt() - 1.0
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
}

/// The same circle as `InsideDisk`, falsely declared affine.
struct FalselyAffine;
impl ConstraintKernel<2> for FalselyAffine {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 2]) -> D {
        -(z[0] * z[0] + z[1] * z[1]) + 1.0
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
    fn is_affine(&self) -> bool {
        true
    }
}

/// x ≥ at: affine and static, with its position as a parameter.
struct RightOf;
impl ConstraintKernel<1> for RightOf {
    type Params = f64;
    fn value<D: Scalar>(&self, at: &f64, _t: D, z: [D; 1]) -> D {
        z[0] - *at
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
    fn is_affine(&self) -> bool {
        true
    }
}

fn pushed(dir: [f64; 2]) -> impl Fn(f64, &[f64], &mut [f64]) + Send + Sync + 'static {
    move |_t: f64, _q: &[f64], f: &mut [f64]| f.copy_from_slice(&dir)
}

fn settings(h: f64, t_end: f64) -> StepperSettings {
    StepperSettings {
        h,
        t_end,
        ..Default::default()
    }
}

#[test]
fn smallest_eigenvalue_of_small_symmetric_matrices() {
    assert!((symmetric_min_eigenvalue(&[2.0, 0.0, 0.0, -3.0], 2) + 3.0).abs() < 1e-12);
    // [[1, 2], [2, 1]]: eigenvalues 3 and −1.
    assert!((symmetric_min_eigenvalue(&[1.0, 2.0, 2.0, 1.0], 2) + 1.0).abs() < 1e-12);
    assert_eq!(symmetric_min_eigenvalue(&[], 0), 0.0);
}

#[test]
fn the_spellings_of_the_cheat_sheet_differentiate_correctly() {
    struct Spelled;
    impl ConstraintKernel<1> for Spelled {
        type Params = ();
        // 1 − x/2 + 2/x, written three ways that compile.
        fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D {
            (z[0] * 0.5).rsub(1.0) + D::from(2.0) / z[0] - (-z[0] + 1.0) + (-z[0] + 1.0)
        }
    }
    let lin = linearize(&Spelled, &(), 0.0, [2.0], false);
    assert!((lin.value - 1.0).abs() < 1e-15); // 1 − 1 + 1
    assert!((lin.gradient[0] - (-0.5 - 0.5)).abs() < 1e-15); // −½ − 2/x²

    // The rest of the table: 2/x as x.recip() * 2.0, x², √x, |x|, a branch on the value.
    struct Rest;
    impl Constraint<1> for Rest {
        fn value<D: Scalar>(&self, _t: D, z: [D; 1]) -> D {
            let x = z[0];
            let branch = if x.re() < 0.0 { -x } else { x };
            x.recip() * 2.0 + x.powi(2) + x.sqrt() + (-x).abs() + branch
        }
    }
    let lin = linearize(&Rest, &(), 0.0, [4.0], false);
    assert!((lin.value - (0.5 + 16.0 + 2.0 + 4.0 + 4.0)).abs() < 1e-12);
    // −2/x² + 2x + 1/(2√x) + 1 + 1 at x = 4
    assert!((lin.gradient[0] - (-0.125 + 8.0 + 0.25 + 2.0)).abs() < 1e-12);
}

#[test]
fn concave_constraint_fails_the_estimate_and_no_prox_regularity_is_claimed() {
    let problem = Problem::new(vec![0.5, 0.0], NoPerturbation).with_constraint(
        "inside disk",
        InsideDisk,
        [0, 1],
    );
    let report = estimate(&problem, &[(0.0, vec![0.9, 0.0])]);
    assert!(report.convexity_failed);
    let w = report.min_curvature.as_ref().unwrap();
    assert!((w.value + 2.0).abs() < 1e-12);
    assert!(w.constraint.contains("inside disk"));
    assert_eq!((report.eta, report.theta, report.r), (None, None, None));
    let f = &report.failures[0];
    assert!(f.starts_with(CONVEXITY), "{f}");
    assert!(
        f.contains("-2") && f.contains("q[0] = 0.9, q[1] = 0"),
        "{f}"
    );
    assert!(f.contains("order-1/2 guarantee does not hold"), "{f}");
    let table = report.table();
    assert!(
        table.contains("NEGATIVE") && !table.contains("prox-regular: the"),
        "{table}"
    );
}

#[test]
fn convex_and_affine_constraints_pass_and_keep_their_derived_constants() {
    let problem = Problem::new(vec![1.5, 0.0], NoPerturbation)
        .with_constraint("outside disk", OutsideDisk, [0, 1])
        .with_family(KernelFamily::single_with("wall", RightOf, [0], 1.0));
    let report = estimate(&problem, &[(0.0, vec![1.1, 0.0])]);
    assert!(!report.convexity_failed, "{}", report.table());
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    // D²(|z| − 1) at (1.1, 0) = diag(0, 1/1.1): smallest eigenvalue 0.
    assert!(report.min_curvature.unwrap().value.abs() < 1e-12);
    assert!(report.eta.is_some() && report.theta.is_some() && report.r.is_some());
}

#[test]
fn a0_margin_of_affine_constraints_is_infinite_not_missing() {
    let problem = point_right_of_wall(1.0, NoPerturbation);
    let report = estimate(&problem, &[(0.0, vec![0.2])]);
    assert_eq!(report.c, Some(f64::INFINITY));
    let line = report
        .table()
        .lines()
        .find(|l| l.trim_start().starts_with("c (A0)"))
        .unwrap()
        .to_string();
    assert!(line.contains('∞'), "{line}");
    assert!(
        report.notes.iter().all(|n| !n.starts_with("A0")),
        "{:?}",
        report.notes
    );
}

#[test]
fn a_false_affine_claim_is_caught_once_by_the_estimate_and_the_monitor() {
    let problem = Problem::new(vec![0.5, 0.0], NoPerturbation).with_constraint(
        "circle",
        FalselyAffine,
        [0, 1],
    );
    let report = estimate(&problem, &[(0.0, vec![0.5, 0.0])]);
    assert!(report.convexity_failed);
    assert!(
        report.failures[0].starts_with(AFFINE_CLAIM),
        "{:?}",
        report.failures
    );
    assert!(
        report.failures[0].contains("|D²g| = 2"),
        "{:?}",
        report.failures
    );

    let mut monitor = error_monitor(&problem, Bounds::default());
    let failure = watched_run(&problem, 0.1, 1.0, &mut monitor).unwrap_err();
    let SweepError::AssumptionViolated {
        assumption, detail, ..
    } = &failure.error
    else {
        panic!("{}", failure.error);
    };
    assert_eq!(assumption, AFFINE_CLAIM);
    assert!(
        detail.contains("2.000000e0 ≠ 0") && detail.contains("is_affine"),
        "{detail}"
    );
}

#[test]
fn static_affine_problems_get_their_second_order_check() {
    // Before: the monitor skipped every static affine row, so M was never checked at all.
    let problem = point_right_of_wall(1.0, pushed_1d(-1.0));
    let mut monitor = error_monitor(
        &problem,
        Bounds {
            m: Some(0.0),
            ..Default::default()
        },
    );
    watched_run(&problem, 0.1, 2.0, &mut monitor).unwrap();
    assert_eq!(monitor.second_order_checks(), 1); // the affine claim, verified at the start
    assert_eq!(monitor.violation_count(), 0);
}

fn pushed_1d(v: f64) -> impl Fn(f64, &[f64], &mut [f64]) + Send + Sync + 'static {
    move |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = v
}

/// A point at `x0` on a line, moved by `f`, kept right of a wall at 0.
fn point_right_of_wall(x0: f64, f: impl Perturbation + 'static) -> Problem {
    Problem::new(vec![x0], f).with_family(KernelFamily::single_with("wall", RightOf, [0], 0.0))
}

#[test]
fn the_start_is_checked_however_far_from_contact() {
    // |∇g| = 1 > β = 0.5, with the point 5 away from the wall (the neighbourhood is 0.1):
    // before, nothing was checked at t = 0; now the run stops before its first step.
    let problem = point_right_of_wall(5.0, pushed_1d(1.0));
    let mut monitor = error_monitor(
        &problem,
        Bounds {
            beta: Some(0.5),
            ..Default::default()
        },
    );
    let failure = watched_run(&problem, 0.1, 1.0, &mut monitor).unwrap_err();
    assert_eq!(failure.partial.stats.steps, 0);
    let msg = failure.error.to_string();
    assert!(
        msg.starts_with("step 0, t = 0: assumption A1 violated by wall"),
        "{msg}"
    );
}

#[test]
fn concave_constraint_under_the_monitor_error_and_warn_and_off() {
    let problem = Problem::new(vec![0.3, 0.1], pushed([1.0, 0.5])).with_constraint(
        "inside disk",
        InsideDisk,
        [0, 1],
    );
    // Error: stops at the start, naming the constraint, the eigenvalue and the point.
    let mut monitor = error_monitor(&problem, Bounds::default());
    let failure = watched_run(&problem, 0.1, 2.0, &mut monitor).unwrap_err();
    let msg = failure.to_string();
    assert!(
        msg.contains(&format!("assumption {CONVEXITY} violated by inside disk")),
        "{msg}"
    );
    assert!(
        msg.contains("D²g = -2.000000e0 < 0: at q[0] = 0.3, q[1] = 0.1"),
        "{msg}"
    );
    // Warn: the run completes (with the run-time violation guard switched off, which would
    // otherwise stop it at the first step that ends outside the disk: the next test); the
    // check ran at the start and on the schedule near contact.
    let mut monitor = BoundsMonitor::new(&problem, MonitorSettings::default());
    let unguarded = StepperSettings {
        violation_tolerance: f64::INFINITY,
        ..settings(0.1, 2.0)
    };
    let run = Stepper::new(&problem, unguarded.clone())
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
        .unwrap();
    assert_eq!(run.stats.steps, 20);
    assert!(monitor.warnings().len() >= 2, "{:?}", monitor.warnings());
    assert!(monitor.warnings().iter().all(|w| w.assumption == CONVEXITY));
    // The outer approximation the warning announces: the point ends outside the disk.
    assert!(
        run.stats.max_violation > 1e-6,
        "{:.3e}",
        run.stats.max_violation
    );
    // convexity = false (or Policy::Off): not checked.
    for settings_off in [
        MonitorSettings {
            convexity: false,
            ..Default::default()
        },
        MonitorSettings {
            policy: Policy::Off,
            ..Default::default()
        },
    ] {
        let mut monitor = BoundsMonitor::new(&problem, settings_off);
        Stepper::new(&problem, unguarded.clone())
            .unwrap()
            .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
            .unwrap();
        assert_eq!(monitor.violation_count(), 0);
    }
}

#[test]
fn nonsense_bounds_are_invalid_input() {
    for (bounds, what) in [
        (
            Bounds {
                m: Some(-1.0),
                ..Default::default()
            },
            "M (A3, A4) = -1 must be finite and ≥ 0",
        ),
        (
            Bounds {
                beta: Some(f64::NAN),
                ..Default::default()
            },
            "β (A1, A2) = NaN must be finite and > 0",
        ),
        (
            Bounds {
                alpha: Some(0.0),
                ..Default::default()
            },
            "α (A1) = 0 must be finite and > 0",
        ),
        (
            Bounds {
                alpha: Some(2.0),
                beta: Some(1.0),
                m: None,
                reach: None,
            },
            "α = 2 > β = 1",
        ),
    ] {
        let err = bounds.validate().unwrap_err();
        assert!(matches!(err, SweepError::InvalidInput(_)));
        assert!(err.to_string().contains(what), "{err}");
    }
    let bad = MonitorSettings {
        neighbourhood: -1.0,
        ..Default::default()
    };
    assert!(bad
        .validate()
        .unwrap_err()
        .to_string()
        .contains("neighbourhood = -1"));
    assert!(Bounds::default().validate().is_ok());
}

#[test]
fn kernel_family_single_takes_default_parameters_and_single_with_any() {
    #[derive(Default)]
    struct Offset(f64);
    struct Shifted;
    impl ConstraintKernel<1> for Shifted {
        type Params = Offset;
        fn value<D: Scalar>(&self, p: &Offset, _t: D, z: [D; 1]) -> D {
            z[0] - p.0
        }
    }
    let mut row = sweeping::constraint::LinearizedRow::default();
    KernelFamily::single("default", Shifted, [0]).linearize(0, 0.0, &[3.0], false, &mut row);
    assert_eq!(row.value, 3.0);
    KernelFamily::single_with("given", Shifted, [0], Offset(1.0)).linearize(
        0,
        0.0,
        &[3.0],
        false,
        &mut row,
    );
    assert_eq!(row.value, 2.0);
}

#[test]
fn messages_print_rounded_times() {
    let failure = RunFailure {
        error: SweepError::NonFinite {
            step: 4,
            t: 0.1 + 0.31,
            what: "f".into(),
        },
        partial: Run {
            t_final: 0.1 + 0.31,
            ..Default::default()
        },
    };
    assert_eq!(0.1 + 0.31, 0.41000000000000003);
    assert_eq!(
        failure.to_string(),
        "step 4, t = 0.41: f is not finite (after 0 completed steps, t = 0.41)"
    );
}

#[test]
fn backend_errors_are_typed_and_go_into_anyhow() {
    let e = BackendError::NotCompiled {
        backend: BackendChoice::Osqp,
        features: "osqp".into(),
    };
    assert_eq!(
        e.to_string(),
        "backend `osqp` is not compiled in: build with `--features osqp`"
    );
    fn build() -> anyhow::Result<String> {
        let p = make_projector(BackendChoice::Reference)?;
        Ok(p.name().to_string())
    }
    assert!(!build().unwrap().is_empty());
}

#[test]
fn second_order_of_an_affine_kernel_skips_the_hessian_that_the_check_computes() {
    // The library trusts is_affine in the hot path (no Hessian), and verifies it in the checks.
    let so = second_order(&FalselyAffine, &(), 0.0, [0.5, 0.0]);
    assert_eq!(so.hessian, [[0.0; 2]; 2]);
    let h = sweeping::constraint::hessian_of(&FalselyAffine, &(), 0.0, [0.5, 0.0]);
    assert_eq!(h, [[-2.0, 0.0], [0.0, -2.0]]);
}

#[test]
fn solve_warns_of_a_concave_constraint_and_stops_at_the_first_real_violation() {
    let problem = Problem::new(vec![0.3, 0.1], pushed([1.0, 0.5])).with_constraint(
        "inside disk",
        InsideDisk,
        [0, 1],
    );
    // The convexity warning is printed at the start; the outer linearization then lets the
    // point leave the disk, which the run-time guard refuses, naming the constraint.
    let failure = problem.solve(settings(0.1, 2.0)).unwrap_err();
    match &failure.error {
        SweepError::ViolationTooLarge {
            constraint,
            violation,
            ..
        } => {
            assert!(constraint.contains("inside disk"), "{constraint}");
            assert!(*violation > 1e-6);
        }
        other => panic!("expected ViolationTooLarge, got {other}"),
    }
    let report = estimate(
        &problem,
        &samples_from_trajectory(&failure.partial.trajectory),
    );
    assert!(report.convexity_failed);
}

#[test]
fn crowd_constraints_are_convex_even_probed_outside_q() {
    use sweeping::crowd::{DiskPairs, Motion, PersonShapes, Population, Shape};
    // Four people pressed together near a wall and a moving disk obstacle: pair distances,
    // segment and disk distances are convex, so no false alarm (also a little outside Qᵢ).
    let pop = Population::new(vec![0.2; 4]).shared();
    let q = vec![0.2, 1.0, 0.6, 1.0, 0.4, 1.35, 1.0, 1.0];
    let shapes = vec![
        (
            Shape::Segment {
                a: [0.0, 0.0],
                b: [0.0, 3.0],
            },
            Motion::Static,
        ),
        (
            Shape::Disk {
                center: [1.5, 1.0],
                radius: 0.3,
            },
            Motion::Velocity([-0.1, 0.0]),
        ),
    ];
    let problem = Problem::new(q.clone(), NoPerturbation)
        .with_family(DiskPairs::new(pop.clone()))
        .with_family(PersonShapes::new("walls and obstacles", pop, shapes));
    let report = estimate_with(
        &problem,
        &[(0.0, q.clone()), (0.5, q)],
        &EstimateSettings {
            probe_depth: 0.05,
            ..Default::default()
        },
    );
    assert!(!report.convexity_failed, "{}", report.table());
    assert!(report.min_curvature.unwrap().value > -1e-9);
    assert!(report.eta.is_some());
}
