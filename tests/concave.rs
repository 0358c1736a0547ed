//! Constraints declared concave (`Curvature::Concave`): convex sets, Moreau's class.
//!
//! The first-hour trial: a point kept inside the ellipse `((x − t/4)/2)² + y² ≤ 1`, pushed
//! outward by `f = (1, 1)`. Declared concave, every step projects onto the ellipse itself
//! (checked against an independent projection), the run ends inside and converges at order
//! ≈ 1 against a fine reference; undeclared it is refused as before; a false declaration is
//! refused with the constraint named.

use sweeping::assumptions::{CONCAVITY, CONVEXITY};
use sweeping::prelude::*;
use sweeping::study::{converge, BoxError, ConvergenceSettings};

/// `g = 1 − ((x − t/4)/2)² − y²`: concave, `{g ≥ 0}` the moving ellipse.
struct InsideEllipse {
    declared: bool,
}
impl Constraint<2> for InsideEllipse {
    fn value<D: Scalar>(&self, t: D, z: [D; 2]) -> D {
        let u = (z[0] - t * 0.25) * 0.5;
        -(u * u + z[1] * z[1]) + 1.0
    }
    fn curvature(&self) -> Curvature {
        if self.declared {
            Curvature::Concave
        } else {
            Curvature::Convex
        }
    }
}

fn push(_t: f64, _q: &[f64], f: &mut [f64]) {
    f[0] = 1.0;
    f[1] = 1.0;
}

fn ellipse(declared: bool) -> Problem {
    Problem::new(vec![0.5, 0.2], push).with_constraint(
        "inside ellipse",
        InsideEllipse { declared },
        [0, 1],
    )
}

fn settings(h: f64) -> StepperSettings {
    StepperSettings {
        h,
        t_end: 4.0,
        ..Default::default()
    }
}

/// The value of the ellipse's `g` at `(t, z)`.
fn g(t: f64, z: &[f64]) -> f64 {
    let u = (z[0] - t * 0.25) * 0.5;
    1.0 - u * u - z[1] * z[1]
}

/// The projection of `p` onto the ellipse `((x − c)/2)² + y² ≤ 1`, independently of the
/// library: `x = (I + μA)⁻¹(p − c)`, `A = diag(¼, 1)`, with `μ ≥ 0` found by bisection on
/// `xᵀAx = 1` (decreasing in `μ`).
fn project_onto_ellipse(c: f64, p: [f64; 2]) -> [f64; 2] {
    let d = [p[0] - c, p[1]];
    let at = |mu: f64| [d[0] / (1.0 + mu * 0.25), d[1] / (1.0 + mu)];
    let level = |x: [f64; 2]| 0.25 * x[0] * x[0] + x[1] * x[1];
    if level(d) <= 1.0 {
        return p;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    while level(at(hi)) > 1.0 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if level(at(mid)) > 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let x = at(hi);
    [x[0] + c, x[1]]
}

fn backends() -> Vec<Box<dyn Projector>> {
    let mut out: Vec<Box<dyn Projector>> = vec![Box::new(ReferenceProjector::default())];
    for choice in [
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Native,
    ] {
        if let Ok(b) = make_projector(choice) {
            out.push(b);
        }
    }
    out
}

#[test]
fn declared_concave_each_step_is_the_projection_onto_the_ellipse_on_every_backend() {
    let problem = ellipse(true);
    for mut backend in backends() {
        let mut stepper = Stepper::new(&problem, settings(0.1)).unwrap();
        let mut cut_steps = 0;
        let mut worst: f64 = 0.0;
        while stepper.steps_done() < stepper.n_steps() {
            let (t, q) = (stepper.time(), stepper.state().to_vec());
            let report = stepper.step(backend.as_mut()).unwrap();
            let y = [q[0] + report.h, q[1] + report.h];
            let expect = project_onto_ellipse(0.25 * report.t, y);
            let x = stepper.state();
            let err = (x[0] - expect[0]).hypot(x[1] - expect[1]);
            worst = worst.max(err);
            assert!(
                err < 2e-6,
                "{}: step {} at t = {t}: {x:?} vs the projection {expect:?} ({err:.2e})",
                backend.name(),
                report.step
            );
            assert!(g(report.t, x) >= -1e-9, "{}: outside", backend.name());
            cut_steps += usize::from(report.cuts > 0);
        }
        println!(
            "{}: largest distance to the projection {worst:.2e}",
            backend.name()
        );
        // The point reaches the boundary early and slides along it: cuts were needed.
        assert!(
            cut_steps > 20,
            "{}: {cut_steps} steps with cuts",
            backend.name()
        );
    }
}

/// Runs `problem` to its end on the reference backend (at `1e-13`), showing `see` each step's
/// report, the configuration before it and the one after.
fn each_step(
    problem: &Problem,
    settings: StepperSettings,
    mut see: impl FnMut(&StepReport, &[f64], &[f64]),
) {
    let mut stepper = Stepper::new(problem, settings).unwrap();
    let mut backend = ReferenceProjector {
        tolerance: 1e-13,
        ..Default::default()
    };
    while stepper.steps_done() < stepper.n_steps() {
        let q = stepper.state().to_vec();
        let report = stepper.step(&mut backend).unwrap();
        see(&report, &q, stepper.state());
    }
}

/// The cuts stop only when the true constraint's stationarity holds to the KKT tolerance: a
/// tighter tolerance brings every step's point along the boundary to the exact projection.
#[test]
fn a_tighter_kkt_tolerance_brings_each_step_to_the_projection() {
    let problem = ellipse(true);
    for (kkt_tolerance, bound) in [(1e-6, 2e-6), (1e-10, 1e-9)] {
        let settings = StepperSettings {
            kkt_tolerance,
            ..settings(0.1)
        };
        let mut worst: f64 = 0.0;
        each_step(&problem, settings, |report, q, x| {
            let expect = project_onto_ellipse(0.25 * report.t, [q[0] + report.h, q[1] + report.h]);
            worst = worst.max((x[0] - expect[0]).hypot(x[1] - expect[1]));
        });
        println!(
            "KKT tolerance {kkt_tolerance:.0e}: largest distance to the projection {worst:.2e}"
        );
        assert!(
            worst < bound,
            "KKT tolerance {kkt_tolerance:.0e}: {worst:.2e}"
        );
    }
}

/// The cuts stop only when the point is within `concave_tolerance` of the set, however loose
/// the KKT tolerance: the distance outside is a criterion of its own.
#[test]
fn the_concave_tolerance_bounds_the_distance_outside_whatever_the_kkt_tolerance() {
    let problem = ellipse(true);
    for (concave_tolerance, bound) in [(1e-7, 1e-6), (1e-12, 1e-11)] {
        let settings = StepperSettings {
            kkt_tolerance: 1e-2,
            concave_tolerance,
            ..settings(0.1)
        };
        let mut worst: f64 = 0.0;
        each_step(&problem, settings, |report, _q, x| {
            // |∇g| ≥ 1 on this ellipse's boundary, so −g bounds the distance outside.
            worst = worst.max(-g(report.t, x));
        });
        println!("concave tolerance {concave_tolerance:.0e}: largest −g {worst:.2e}");
        assert!(
            worst < bound,
            "concave tolerance {concave_tolerance:.0e}: −g = {worst:.2e}"
        );
    }
}

#[test]
fn declared_concave_the_trial_ends_inside_and_passes_the_monitor() {
    let problem = ellipse(true);
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            ..Default::default()
        },
    );
    let run = Stepper::new(&problem, settings(0.1))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
        .unwrap();
    assert!(g(4.0, &run.q_final) >= -1e-9, "{:?}", run.q_final);
    assert!(
        run.stats.max_violation <= 1e-9,
        "{}",
        run.stats.max_violation
    );
    assert!(monitor.second_order_checks() > 0);
    // Pressed against the boundary in the direction f pushes: the first quadrant of the
    // ellipse centred at (1, 0).
    assert!(g(4.0, &run.q_final).abs() < 1e-9);
    assert!(
        run.q_final[0] > 1.0 && run.q_final[1] > 0.0,
        "{:?}",
        run.q_final
    );
}

#[test]
fn declared_concave_the_error_against_a_fine_reference_shrinks_at_order_one() {
    let make = || -> Result<Problem, BoxError> { Ok(ellipse(true)) };
    let proj =
        || -> Result<Box<dyn Projector>, BoxError> { Ok(Box::new(ReferenceProjector::default())) };
    let conv = ConvergenceSettings {
        h_min: 0.1 / 512.0,
        hs: vec![0.1 / 32.0, 0.1 / 16.0, 0.1 / 8.0, 0.1 / 4.0],
        t_end: 4.0,
        t_short: None,
        samples: 20,
        parallel: false,
    };
    let report = converge("ellipse", &make, &proj, &StepperSettings::default(), &conv).unwrap();
    let errors: Vec<f64> = report.rows.iter().map(|r| r.error).collect();
    let order = report.order.unwrap().order;
    println!(
        "inside a moving ellipse: h = {:?}, errors {errors:?}, order {order:.3}",
        conv.hs
    );
    assert!((0.85..1.3).contains(&order), "order {order}");
}

#[test]
fn undeclared_the_concave_ellipse_is_refused_as_before() {
    let problem = ellipse(false);
    let failure = problem.solve(settings(0.1)).unwrap_err();
    assert!(
        matches!(failure.error, SweepError::ViolationTooLarge { .. }),
        "{}",
        failure.error
    );
    assert!(
        failure.error.to_string().contains("convexity fails"),
        "{}",
        failure.error
    );
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            ..Default::default()
        },
    );
    let failure = Stepper::new(&problem, settings(0.1))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut monitor])
        .unwrap_err();
    assert!(
        matches!(&failure.error, SweepError::AssumptionViolated { assumption, .. } if assumption == CONVEXITY),
        "{}",
        failure.error
    );
}

/// `|z| − 1 ≥ 0`, outside the unit disk: convex, so a concave declaration is false.
struct OutsideDiskDeclaredConcave;
impl Constraint<2> for OutsideDiskDeclaredConcave {
    fn value<D: Scalar>(&self, _t: D, z: [D; 2]) -> D {
        (z[0] * z[0] + z[1] * z[1]).sqrt() - 1.0
    }
    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }
}

/// `x² − y² + 4 ≥ 0`: a saddle, neither convex nor concave.
struct SaddleDeclaredConcave;
impl Constraint<2> for SaddleDeclaredConcave {
    fn value<D: Scalar>(&self, _t: D, z: [D; 2]) -> D {
        z[0] * z[0] - z[1] * z[1] + 4.0
    }
    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }
}

#[test]
fn a_false_concave_declaration_is_refused_before_the_first_step_naming_it() {
    for (problem, name, eigen) in [
        (
            Problem::new(vec![2.0, 0.0], push).with_constraint(
                "outside disk",
                OutsideDiskDeclaredConcave,
                [0, 1],
            ),
            "outside disk",
            "5.000000e-1",
        ),
        (
            Problem::new(vec![0.0, 0.0], push).with_constraint(
                "saddle",
                SaddleDeclaredConcave,
                [0, 1],
            ),
            "saddle",
            "2.000000e0",
        ),
    ] {
        let Err(e) = Stepper::new(&problem, settings(0.1)) else {
            panic!("{name}: a false concave declaration accepted");
        };
        let message = e.to_string();
        assert!(
            matches!(&e, SweepError::AssumptionViolated { assumption, .. } if assumption == CONCAVITY),
            "{message}"
        );
        assert!(message.contains(name), "{message}");
        assert!(
            message.contains(&format!("the largest eigenvalue of D²g = {eigen} > 0")),
            "{message}"
        );
        assert!(message.contains("declared concave"), "{message}");
        // The monitor says the same under Policy::Error.
        let mut monitor = BoundsMonitor::new(
            &problem,
            MonitorSettings {
                policy: Policy::Error,
                ..Default::default()
            },
        );
        let e = monitor.on_start(0.0, problem.q0()).unwrap_err();
        assert!(e.to_string().contains(CONCAVITY), "{e}");
    }
}

#[test]
fn an_uncertifiable_step_is_a_typed_error_naming_the_constraint() {
    // One refinement allowed, with a tolerance no cut reaches in one go.
    let problem = ellipse(true);
    let settings = StepperSettings {
        max_concave_iterations: 1,
        concave_tolerance: 1e-15,
        ..settings(0.5)
    };
    let failure = Stepper::new(&problem, settings)
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap_err();
    let message = failure.error.to_string();
    assert!(
        matches!(
            failure.error,
            SweepError::ConcaveNotCertified { iterations: 1, .. }
        ),
        "{message}"
    );
    assert!(message.contains("inside ellipse"), "{message}");
}

/// `g = 1 − |z − c|²`: inside the unit disk centred at `c`.
struct InsideUnitDisk {
    center: [f64; 2],
}
impl Constraint<2> for InsideUnitDisk {
    fn value<D: Scalar>(&self, _t: D, z: [D; 2]) -> D {
        let (dx, dy) = (z[0] - self.center[0], z[1] - self.center[1]);
        -(dx * dx + dy * dy) + 1.0
    }
    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }
}

/// Two convex sets at once (the lens between two unit disks), the point pushed into the
/// lens's corner: every member is checked at each iterate, not only those active in the
/// solve, so each step ends within the concave tolerance of both disks.
#[test]
fn in_a_lens_each_step_ends_inside_both_disks() {
    let problem = Problem::new(vec![0.3, 0.0], |_t: f64, _q: &[f64], f: &mut [f64]| {
        f[0] = 0.3;
        f[1] = 1.0;
    })
    .with_constraint("disk A", InsideUnitDisk { center: [0.0, 0.0] }, [0, 1])
    .with_constraint("disk B", InsideUnitDisk { center: [1.0, 0.0] }, [0, 1]);
    let settings = StepperSettings {
        h: 0.05,
        t_end: 2.0,
        ..Default::default()
    };
    let mut stepper = Stepper::new(&problem, settings).unwrap();
    let mut backend = ReferenceProjector {
        tolerance: 1e-13,
        ..Default::default()
    };
    let mut worst: f64 = 0.0;
    while stepper.steps_done() < stepper.n_steps() {
        stepper.step(&mut backend).unwrap();
        let x = stepper.state();
        for c in [[0.0, 0.0], [1.0, 0.0]] {
            // Outside a unit disk by (x − c)·… : |x − c| − 1.
            worst = worst.max((x[0] - c[0]).hypot(x[1] - c[1]) - 1.0);
        }
    }
    let x = stepper.state();
    println!("lens: ends at {x:?}, largest distance outside {worst:.2e}");
    // The corner of the lens, where both circles meet.
    assert!(
        (x[0] - 0.5).abs() < 1e-6 && (x[1] - 0.75f64.sqrt()).abs() < 1e-6,
        "{x:?}"
    );
    assert!(worst < 1e-9, "{worst:.2e}");
}

/// A concave tolerance looser than the violation tolerance is refused before the first step,
/// naming both (a certified step would otherwise fail the check after it, mid-run).
#[test]
fn a_concave_tolerance_looser_than_the_violation_tolerance_is_refused_up_front() {
    let problem = ellipse(true);
    let e = Stepper::new(&problem, loose_settings())
        .err()
        .expect("refused");
    let message = e.to_string();
    assert!(
        message.contains("concave_tolerance = 1e-4")
            && message.contains("violation_tolerance = 1e-6"),
        "{message}"
    );
    // Equal is allowed, and without a concave constraint the concave tolerance is not read.
    let equal = StepperSettings {
        concave_tolerance: 1e-6,
        violation_tolerance: 1e-6,
        ..settings(0.1)
    };
    assert!(Stepper::new(&problem, equal).is_ok());
    let convex_only = Problem::new(vec![0.5, 0.2], push);
    assert!(Stepper::new(&convex_only, loose_settings()).is_ok());
}

fn loose_settings() -> StepperSettings {
    StepperSettings {
        concave_tolerance: 1e-4,
        violation_tolerance: 1e-6,
        ..settings(0.1)
    }
}
