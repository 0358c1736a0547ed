//! A newcomer's first hour, as a downstream crate writes it: three problems
//! of our own and a custom backend, with nothing but `sweeping::…` paths.

use sweeping::assumptions::{
    estimate_problem, samples_from_trajectory, AssumptionReport, CONVEXITY,
};
use sweeping::prelude::*;
use sweeping::study::exact::{true_error_study, ExactCase};
use sweeping::study::{fit_order, BoxError};

type TestResult = Result<(), Box<dyn std::error::Error>>;

// ---------------------------------------------------------------------------------------------
// Problem 1: a point kept inside an ellipse whose centre moves as c(t) = (t/4, 0), semi-axes
// 2 and 1, the point pushed by f = (1, 1).

/// Written the natural way, `g = 1 − ((x − t/4)/2)² − y²`: concave in q (D²g = diag(−½, −2)),
/// outside the theory.
struct InsideEllipse;
impl Constraint<2> for InsideEllipse {
    fn value<D: Scalar>(&self, t: D, z: [D; 2]) -> D {
        let u = (z[0] - t * 0.25) * 0.5;
        -(u * u + z[1] * z[1]) + 1.0
    }
}

fn push(_t: f64, _q: &[f64], f: &mut [f64]) {
    f[0] = 1.0;
    f[1] = 1.0;
}

fn ellipse_problem() -> Problem {
    Problem::new(vec![0.5, 0.2], push).with_constraint("inside ellipse", InsideEllipse, [0, 1])
}

/// `h = 0.1` up to `t = 4` without the run-time violation guard: it would stop the run at the
/// first step that ends outside the ellipse (ViolationTooLarge); switched off to see the outer
/// approximation the warnings announce.
fn unguarded() -> StepperSettings {
    StepperSettings {
        h: 0.1,
        t_end: 4.0,
        violation_tolerance: f64::INFINITY,
        ..Default::default()
    }
}

/// Runs `problem` on the default backend with `monitor` watching.
fn run_monitored(
    problem: &Problem,
    settings: &StepperSettings,
    monitor: &mut BoundsMonitor,
) -> Result<Run, Box<RunFailure>> {
    let mut backend = make_projector(BackendChoice::default()).unwrap();
    Stepper::new(problem, settings.clone())
        .unwrap()
        .run(backend.as_mut(), &mut [monitor])
}

/// The assumptions estimated on the configurations `run` visited.
fn estimate_on(problem: &Problem, run: &Run) -> Result<AssumptionReport, SweepError> {
    estimate_problem(
        problem,
        &samples_from_trajectory(&run.trajectory),
        &EstimateSettings::default(),
        &mut ReferenceProjector::default(),
    )
}

#[test]
fn a_concave_constraint_stops_the_run_naming_it_and_its_curvature() {
    let problem = ellipse_problem();
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            ..Default::default()
        },
    );
    let settings = StepperSettings {
        h: 0.1,
        t_end: 4.0,
        ..Default::default()
    };
    let failure = run_monitored(&problem, &settings, &mut monitor).unwrap_err();
    let message = failure.error.to_string();
    println!("{message}");
    assert!(
        matches!(&failure.error, SweepError::AssumptionViolated { assumption, .. } if assumption == CONVEXITY),
        "{message}"
    );
    // The constraint, the eigenvalue of D²g = diag(−1/2, −2), where, and what it means.
    assert!(message.contains("inside ellipse"), "{message}");
    assert!(message.contains("= -2.000000e0 < 0"), "{message}");
    assert!(message.contains("q[0] = 0.5, q[1] = 0.2"), "{message}");
    assert!(message.contains("not an inner approximation"), "{message}");
    // Caught at the start, far from contact (g = 1 there), before any step.
    assert_eq!(failure.partial.stats.steps, 0, "{message}");
}

#[test]
fn under_warn_the_run_completes_and_ends_outside_the_ellipse() {
    let problem = ellipse_problem();
    let mut monitor = BoundsMonitor::new(&problem, MonitorSettings::default());
    let settings = unguarded();
    let run = run_monitored(&problem, &settings, &mut monitor).unwrap();
    let warnings = monitor.warnings();
    assert!(!warnings.is_empty());
    assert!(warnings.iter().all(|w| w.assumption == CONVEXITY));
    assert!((warnings[0].value + 2.0).abs() < 1e-12);
    // What the warning announced: the linearization is an outer approximation.
    println!(
        "concave ellipse, h = 0.1: {} warning(s), largest violation {:.2e} ({})",
        monitor.violation_count(),
        run.stats.max_violation,
        run.stats
            .worst_constraint
            .map(|id| problem.describe(id))
            .unwrap_or_default()
    );
    assert!(
        run.stats.max_violation > 1e-6,
        "largest violation {:.3e}",
        run.stats.max_violation
    );
    // `Problem::solve` runs the same check under Warn (and prints it) without being asked.
    let solved = problem.solve(settings.clone()).unwrap();
    assert_eq!(solved.q_final, run.q_final);
}

#[test]
fn estimate_problem_reports_failed_convexity_instead_of_prox_regularity() {
    let problem = ellipse_problem();
    let run = problem.solve(unguarded()).unwrap();
    let report = estimate_on(&problem, &run).unwrap();
    assert!(report.convexity_failed);
    assert!((report.min_curvature.as_ref().unwrap().value + 2.0).abs() < 1e-12);
    assert_eq!((report.eta, report.theta, report.r), (None, None, None));
    let table = report.table();
    assert!(
        report.failures[0].starts_with(CONVEXITY) && report.failures[0].contains("inside ellipse"),
        "{table}"
    );
    assert!(!table.contains("η-prox-regular"), "{table}");
    // The samples outside Q(t) are explained by the failed convexity.
    assert!(
        report
            .failures
            .iter()
            .any(|f| f.contains("is not in Q(t)") && f.contains("not convex")),
        "{table}"
    );
    assert!(table.contains("not claimed"), "{table}");
}

/// The convex way: the region inside an octagon inscribed in the ellipse, one affine
/// constraint per side `⟨n, z − c(t)⟩ ≥ d` (n the inward normal): each is linear in q, so the
/// linearization is exact and the theory applies.
struct Side;
impl ConstraintKernel<2> for Side {
    /// The inward normal and the offset.
    type Params = ([f64; 2], f64);
    fn value<D: Scalar>(&self, (n, d): &([f64; 2], f64), t: D, z: [D; 2]) -> D {
        (z[0] - t * 0.25) * n[0] + z[1] * n[1] - *d
    }
    fn is_affine(&self) -> bool {
        true
    }
}

fn octagon_problem() -> Problem {
    let vertex = |k: usize| {
        let a = std::f64::consts::FRAC_PI_4 * k as f64;
        [2.0 * a.cos(), a.sin()]
    };
    let mut sides = KernelFamily::new("octagon", Side);
    for k in 0..8 {
        let (p, q) = (vertex(k), vertex(k + 1));
        let n = [p[1] - q[1], q[0] - p[0]]; // the edge turned left: inward (counter-clockwise)
        let len = n[0].hypot(n[1]);
        let n = [n[0] / len, n[1] / len];
        sides.push([0, 1], (n, n[0] * p[0] + n[1] * p[1]), format!("side {k}"));
    }
    Problem::new(vec![0.5, 0.2], push).with_family(sides)
}

#[test]
fn the_same_region_from_affine_pieces_passes_every_check_and_stays_inside() {
    let problem = octagon_problem();
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds: Bounds {
                m: Some(0.0),
                ..Default::default()
            },
            ..Default::default()
        },
    );
    let settings = unguarded();
    let run = run_monitored(&problem, &settings, &mut monitor).unwrap();
    // The affine claim was verified (D²g = 0), so second-order checks did run.
    assert!(monitor.second_order_checks() >= 1);
    println!(
        "octagon, h = 0.1: largest violation {:.2e}",
        run.stats.max_violation
    );
    assert!(
        run.stats.max_violation < 1e-8,
        "{:.3e}",
        run.stats.max_violation
    );
    let report = estimate_on(&problem, &run).unwrap();
    assert!(!report.convexity_failed, "{}", report.table());
    assert_eq!(report.c, Some(f64::INFINITY)); // affine: smooth everywhere
    assert_eq!(report.eta, Some(f64::INFINITY)); // M = 0: Q(t) convex
}

// ---------------------------------------------------------------------------------------------
// Problem 2: three disks of radius ½ on a line, the rear one pushed at speed 1 towards a wall at
// x = 0; the others at rest. Gaps of ½ everywhere: the rear disk meets the middle one at
// t = ½, the pair meets the front one at t = 3/2, the three reach the wall at t = 3.

/// `z₁ − z₀ ≥ gap`: two disks in order on a line (`gap` = sum of the radii).
struct Ordered;
impl ConstraintKernel<2> for Ordered {
    type Params = f64;
    fn value<D: Scalar>(&self, gap: &f64, _t: D, z: [D; 2]) -> D {
        z[1] - z[0] - *gap
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
    fn is_affine(&self) -> bool {
        true
    }
}

struct ThreeDisks;
impl ExactCase for ThreeDisks {
    fn name(&self) -> String {
        "three disks against a wall".into()
    }
    fn problem(&self) -> Problem {
        let mut pairs = KernelFamily::new("contacts", Ordered);
        pairs.push([0, 1], 1.0, "disks 0 and 1");
        pairs.push([1, 2], 1.0, "disks 1 and 2");
        Problem::new(vec![1.0, 2.5, 4.0], |_t: f64, _q: &[f64], f: &mut [f64]| {
            f.copy_from_slice(&[0.0, 0.0, -1.0]);
        })
        .with_family(pairs)
        // The wall as a parameter-free kernel would read `z ≥ ½`; with the position as a
        // parameter, one kernel serves every wall.
        .with_family(KernelFamily::single_with("wall", RightOf, [0], 0.5))
    }
    fn exact(&self, t: f64) -> Vec<f64> {
        if t <= 0.5 {
            vec![1.0, 2.5, 4.0 - t]
        } else if t <= 1.5 {
            let s = (t - 0.5) / 2.0;
            vec![1.0, 2.5 - s, 3.5 - s]
        } else if t <= 3.0 {
            let s = (t - 1.5) / 3.0;
            vec![1.0 - s, 2.0 - s, 3.0 - s]
        } else {
            vec![0.5, 1.5, 2.5]
        }
    }
    fn t_end(&self) -> f64 {
        4.0
    }
    fn kinks(&self) -> Vec<f64> {
        vec![0.5, 1.5, 3.0]
    }
}

/// `z ≥ wall`.
struct RightOf;
impl ConstraintKernel<1> for RightOf {
    type Params = f64;
    fn value<D: Scalar>(&self, wall: &f64, _t: D, z: [D; 1]) -> D {
        z[0] - *wall
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
    fn is_affine(&self) -> bool {
        true
    }
}

/// A backend of our own: Hildreth's cyclic projection on the dual (one row at a time,
/// `λᵢ ← max(0, λᵢ + (bᵢ − aᵢ·x)/|aᵢ|²)`, `x = y + Aᵀλ`), for small problems.
struct Cyclic;
impl Projector for Cyclic {
    fn name(&self) -> &str {
        "cyclic"
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let rows: Vec<Vec<(usize, f64)>> =
            (0..p.n_rows()).map(|r| p.a().row(r).collect()).collect();
        let mut x = p.y().to_vec();
        let mut lambda = vec![0.0; rows.len()];
        for sweep in 1..=100_000u32 {
            let mut change = 0.0f64;
            for (r, row) in rows.iter().enumerate() {
                let ax: f64 = row.iter().map(|&(j, v)| v * x[j]).sum();
                let n2: f64 = row.iter().map(|&(_, v)| v * v).sum();
                let new = (lambda[r] + (p.b()[r] - ax) / n2).max(0.0);
                for &(j, v) in row {
                    x[j] += (new - lambda[r]) * v;
                }
                change = change.max((new - lambda[r]).abs() * n2.sqrt());
                lambda[r] = new;
            }
            if change < 1e-13 {
                return Ok(Projection {
                    x,
                    multipliers: lambda,
                    stats: SolveStats {
                        status: SolveStatus::Solved,
                        iterations: sweep,
                        ..SolveStats::trivial(self.name())
                    },
                });
            }
        }
        Err(ProjectionError::NotConverged {
            backend: self.name().into(),
            iterations: 100_000,
            status: "sweeps exhausted".into(),
        })
    }
}

#[test]
fn three_disks_reach_the_wall_with_every_backend_including_our_own() -> TestResult {
    let problem = ThreeDisks.problem();
    let settings = StepperSettings {
        h: 0.07, // no contact time falls on the grid
        t_end: 4.0,
        ..Default::default()
    };
    let exact_end = ThreeDisks.exact(4.0);
    let mut finals = Vec::new();
    let mut backends: Vec<Box<dyn Projector>> = vec![Box::new(Cyclic)];
    for choice in [BackendChoice::Clarabel, BackendChoice::Osqp] {
        match make_projector(choice) {
            Ok(b) => backends.push(b),
            Err(BackendError::NotCompiled { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    for mut backend in backends {
        let run = Stepper::new(&problem, settings.clone())?.run(backend.as_mut(), &mut [])?;
        for (x, e) in run.q_final.iter().zip(&exact_end) {
            assert!(
                (x - e).abs() < 1e-7,
                "{}: {:?}",
                backend.name(),
                run.q_final
            );
        }
        finals.push(run.q_final);
    }
    for f in &finals[1..] {
        let gap = f
            .iter()
            .zip(&finals[0])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(gap < 1e-7, "backends disagree by {gap:.3e}");
    }
    Ok(())
}

#[test]
fn three_disks_against_the_exact_solution_converge_at_order_one() -> TestResult {
    let make = || -> Result<Box<dyn Projector>, BoxError> { Ok(Box::new(Cyclic)) };
    // h = 1/(2m + 1): every contact time falls mid-step or on the grid, the same for each h,
    // so the interpolant's error across a contact step is the same multiple of h.
    let hs = [1.0 / 5.0, 1.0 / 11.0, 1.0 / 23.0];
    let report = true_error_study(
        &ThreeDisks,
        &hs,
        8,
        &make,
        &StepperSettings::default(),
        false,
    )?;
    let sup: Vec<f64> = report.rows.iter().map(|r| r.error_sup.unwrap()).collect();
    // The scheme is exact at the grid times here (affine constraints, constant f); the sup
    // over [0, T] is the piecewise-linear interpolant's error across the contact steps, ≤ h.
    for (h, e) in hs.iter().zip(&sup) {
        assert!(*e <= *h, "h = {h}: sup error {e:.3e}");
    }
    let fit = fit_order(&hs, &sup)?;
    assert!((fit.order - 1.0).abs() < 0.05, "order {:.3}", fit.order);
    let grid: Vec<f64> = report.rows.iter().map(|r| r.error).collect();
    let sci = |v: &[f64]| {
        v.iter()
            .map(|e| format!("{e:.2e}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!(
        "three disks: h = {hs:?}, sup errors [{}], grid errors [{}], order {:.2}",
        sci(&sup),
        sci(&grid),
        fit.order
    );
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Problem 3: the assumptions measured, then a deliberately wrong bound declared.

#[test]
fn measured_constants_then_a_wrong_bound_stops_the_run() -> TestResult {
    let problem = ThreeDisks.problem();
    let settings = StepperSettings {
        h: 0.07,
        t_end: 4.0,
        ..Default::default()
    };
    let run = problem.solve(settings.clone())?;
    let report = estimate_on(&problem, &run)?;
    // α = 1 (the wall), β = √2 (a pair: ∇g = (−1, 1)), M = 0 (affine), c = ∞.
    assert!((report.alpha.as_ref().unwrap().value - 1.0).abs() < 1e-12);
    assert!((report.beta.unwrap() - 2f64.sqrt()).abs() < 1e-12);
    assert_eq!(report.m, Some(0.0));
    assert_eq!(report.c, Some(f64::INFINITY));
    assert!(report.failures.is_empty(), "{}", report.table());
    // The measured bounds hold along the run…
    let mut monitor = BoundsMonitor::try_new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds: Bounds::from_report(&report, 0.01),
            ..Default::default()
        },
    )?;
    let mut backend = make_projector(BackendChoice::default())?;
    Stepper::new(&problem, settings.clone())?.run(backend.as_mut(), &mut [&mut monitor])?;
    // …a wrong β stops it, naming the pair and the value.
    let mut monitor = BoundsMonitor::new(
        &problem,
        MonitorSettings {
            policy: Policy::Error,
            bounds: Bounds {
                beta: Some(1.2),
                ..Default::default()
            },
            ..Default::default()
        },
    );
    let failure = Stepper::new(&problem, settings.clone())?
        .run(backend.as_mut(), &mut [&mut monitor])
        .unwrap_err();
    let message = failure.to_string();
    println!("{message}");
    assert!(
        message.starts_with("step 0, t = 0: assumption A1 violated by contacts #0 (disks 0 and 1)"),
        "{message}"
    );
    assert!(
        message.contains("|∇g| = 1.414214e0 exceeds the declared bound β = 1.2"),
        "{message}"
    );
    Ok(())
}

#[test]
fn nonsense_bounds_are_typed_errors_not_silent_comparisons() {
    let problem = ThreeDisks.problem();
    for (bounds, what) in [
        (
            Bounds {
                m: Some(-1.0),
                ..Default::default()
            },
            "M (A3, A4) = -1",
        ),
        (
            Bounds {
                beta: Some(f64::NAN),
                ..Default::default()
            },
            "β (A1, A2) = NaN",
        ),
    ] {
        let settings = MonitorSettings {
            bounds,
            ..Default::default()
        };
        let Err(e) = BoundsMonitor::try_new(&problem, settings.clone()) else {
            panic!("{what} accepted");
        };
        assert!(e.to_string().contains(what), "{e}");
        // Built without checking, the monitor reports it when the run starts.
        let mut monitor = BoundsMonitor::new(&problem, settings);
        let failure = Stepper::new(&problem, StepperSettings::default())
            .unwrap()
            .run(&mut Cyclic, &mut [&mut monitor])
            .unwrap_err();
        assert!(
            matches!(failure.error, SweepError::InvalidInput(_)),
            "{failure}"
        );
        assert!(failure.to_string().contains(what), "{failure}");
    }
}
