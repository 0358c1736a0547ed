//! The stepper's contract: what a step report carries, that observers see every step in
//! order, the averaged prediction, and that bad input and failures mid-run come back as typed
//! errors with context — together with everything computed before — and never as a panic.

mod common;

use common::kernels::Floor;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::cell::RefCell;
use std::rc::Rc;
use sweeping::api::conformance::ReferenceProjector;
use sweeping::api::Projection;
use sweeping::crowd::{DiskPairs, Population};
use sweeping::error::SweepError;
use sweeping::prelude::*;
use sweeping::stepper::{Run, StepReport};

/// A point falling at speed 1 onto the floor from `x0`.
fn falling(x0: f64) -> Problem {
    Problem::new(vec![x0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = -1.0)
        .with_family(KernelFamily::single("floor", Floor, [0]))
}

fn settings(h: f64, t_end: f64) -> StepperSettings {
    StepperSettings {
        h,
        t_end,
        ..Default::default()
    }
}

/// Two disks of radius ½ on a line, gap `d0`, the rear one walking at (1, 0).
fn two_disks(d0: f64) -> Problem {
    let pop = Population::new(vec![0.5, 0.5]).shared();
    Problem::new(
        vec![0.0, 0.0, 1.0 + d0, 0.0],
        |_t: f64, _q: &[f64], f: &mut [f64]| f.copy_from_slice(&[1.0, 0.0, 0.0, 0.0]),
    )
    .with_family(DiskPairs::new(pop))
}

/// Records everything it is shown in a log shared with other observers.
struct Recorder {
    name: String,
    log: Rc<RefCell<Vec<String>>>,
    reports: Vec<StepReport>,
    states: Vec<Vec<f64>>,
    finished_with: Option<Option<SweepError>>,
    fail_at_step: Option<usize>,
}

impl Recorder {
    fn new(name: &str, log: &Rc<RefCell<Vec<String>>>) -> Self {
        Self {
            name: name.into(),
            log: Rc::clone(log),
            reports: Vec::new(),
            states: Vec::new(),
            finished_with: None,
            fail_at_step: None,
        }
    }
}

impl Observer for Recorder {
    fn name(&self) -> &str {
        &self.name
    }
    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.log.borrow_mut().push(format!("{}:start", self.name));
        self.states.push(q.to_vec());
        assert!(t.abs() < 1e-300);
        Ok(())
    }
    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        self.log
            .borrow_mut()
            .push(format!("{}:{}", self.name, report.step));
        self.reports.push(report.clone());
        self.states.push(q.to_vec());
        if self.fail_at_step == Some(report.step) {
            return Err("disk full".into());
        }
        Ok(())
    }
    fn on_finish(&mut self, error: Option<&SweepError>) -> Result<(), ObserverError> {
        self.log.borrow_mut().push(format!("{}:finish", self.name));
        self.finished_with = Some(error.cloned());
        Ok(())
    }
}

/// Wraps the reference projector and fails on call number `fail_at` (0-based).
struct FailingProjector {
    inner: ReferenceProjector,
    calls: usize,
    fail_at: usize,
}

impl Projector for FailingProjector {
    fn name(&self) -> &str {
        "failing"
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let k = self.calls;
        self.calls += 1;
        if k == self.fail_at {
            return Err(ProjectionError::Backend {
                backend: "failing".into(),
                message: format!("simulated failure on call {k}"),
            });
        }
        self.inner.project(p)
    }
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}");
}

#[test]
fn step_reports_carry_what_the_step_did() {
    let p = two_disks(0.37);
    let log = Rc::new(RefCell::new(Vec::new()));
    let mut rec = Recorder::new("rec", &log);
    let h = 0.1;
    let run = Stepper::new(&p, settings(h, 1.0))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut rec])
        .unwrap();
    assert_eq!(rec.reports.len(), 10);
    let mut iterations = 0u64;
    let mut rows = 0u64;
    for (k, r) in rec.reports.iter().enumerate() {
        assert_eq!(r.step, k);
        assert_close(r.t, (k + 1) as f64 * h, 1e-12, "t");
        assert_close(r.h, h, 1e-12, "h");
        assert!(r.active <= r.rows);
        assert!(r.solves >= 1);
        let contact = (k + 1) as f64 * h > 0.37;
        // Free while the gap lasts (the rear disk moves h), then in contact (both move h/2,
        // the first contact step (h + g)/2 with g = 0.07 the gap left).
        if contact {
            assert_eq!(r.active, 1, "step {k}");
            assert!(r.rows >= 1 && r.iterations >= 1, "step {k}");
        } else {
            assert_eq!(r.active, 0, "step {k}");
            assert_close(r.max_displacement, h, 1e-12, "free displacement");
        }
        if k > 3 {
            assert_close(r.max_displacement, h / 2.0, 1e-12, "contact displacement");
        }
        let t = &r.times;
        for s in [t.effects, t.broad_phase, t.assembly, t.projection, t.check] {
            assert!(s.is_finite() && s >= 0.0);
        }
        assert!(t.total() >= t.projection);
        assert!(r.max_violation >= 0.0 && r.max_violation <= 1e-12);
        assert!(r.max_violation > 0.0 || r.worst_constraint.is_none());
        assert_eq!(r.solve.backend, "reference");
        iterations += u64::from(r.iterations);
        rows += r.rows as u64;
    }
    // The first steps, gap > 2h, assemble nothing: the pair is culled.
    assert_eq!(rec.reports[0].rows, 0);
    // The run's totals are the sums and extremes of the steps.
    assert_eq!(run.stats.steps, 10);
    assert_eq!(run.stats.iterations, iterations);
    assert_eq!(run.stats.rows, rows);
    assert_eq!(run.stats.max_active, 1);
    assert!(run.stats.max_violation <= 1e-12);
    assert!(run.stats.times.total() >= 0.0);
}

#[test]
fn observers_see_every_step_in_order() {
    let p = falling(0.25);
    let log = Rc::new(RefCell::new(Vec::new()));
    let mut a = Recorder::new("a", &log);
    let mut b = Recorder::new("b", &log);
    let run = Stepper::new(&p, settings(0.1, 0.55))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut a, &mut b])
        .unwrap();
    // 0.55 / 0.1: five full steps and a shortened sixth landing on T.
    let mut expected = vec!["a:start".to_string(), "b:start".to_string()];
    for k in 0..6 {
        expected.push(format!("a:{k}"));
        expected.push(format!("b:{k}"));
    }
    expected.extend(["a:finish".to_string(), "b:finish".to_string()]);
    assert_eq!(*log.borrow(), expected);
    assert_close(a.reports[5].h, 0.05, 1e-12, "last step");
    assert_close(run.t_final, 0.55, 1e-12, "t_final");
    // What the observers saw is what the run recorded.
    assert_eq!(a.states, run.trajectory.states);
    assert_eq!(b.states, run.trajectory.states);
    assert!(matches!(a.finished_with, Some(None)));
    assert!(run.q_final[0].abs() < 1e-12);
}

#[test]
fn record_every_keeps_start_and_end() {
    let p = falling(0.25);
    let mut s = settings(0.1, 1.0);
    s.record_every = 3;
    let run = Stepper::new(&p, s.clone())
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap();
    let t = &run.trajectory.times;
    assert_eq!(t.len(), 5); // 0, 0.3, 0.6, 0.9, 1.0
    assert_close(t[0], 0.0, 1e-15, "start");
    assert_close(t[4], 1.0, 1e-12, "end");
    s.record_every = 0;
    let run = Stepper::new(&p, s)
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap();
    assert_eq!(run.trajectory.times.len(), 2);
}

/// Free motion with `f(t) = cos t`: the averaged prediction integrates `∫cos` per step to
/// quadrature accuracy; the explicit one makes the left-Riemann-sum error, whose expansion
/// (Euler–Maclaurin) is `(h/2)(f(0) − f(T)) + (h²/12)(f'(T) − f'(0)) + O(h⁴)`.
#[test]
fn averaged_prediction_integrates_time_dependent_f() {
    let t_end = 1.0;
    let p = Problem::new(vec![0.0], |t: f64, _q: &[f64], f: &mut [f64]| {
        f[0] = t.cos()
    });
    let exact = t_end.sin();
    let final_error = |h: f64, prediction: Prediction| {
        let s = StepperSettings {
            prediction,
            ..settings(h, t_end)
        };
        let run = Stepper::new(&p, s)
            .unwrap()
            .run(&mut ReferenceProjector::default(), &mut [])
            .unwrap();
        run.q_final[0] - exact
    };
    for h in [0.1, 0.05, 0.025] {
        let e = final_error(h, Prediction::Explicit);
        let leading = h / 2.0 * (1.0 - t_end.cos());
        assert!(e > 0.9 * leading, "explicit, h = {h}: {e:.3e}");
        assert!(
            (e - leading).abs() <= h * h / 12.0 * t_end.sin() + h.powi(4),
            "explicit, h = {h}: error {e:.3e}, leading term {leading:.3e}"
        );
        // Gauss–Legendre with 3 points: exact to ~h⁶ per unit time.
        let e3 = final_error(h, Prediction::Averaged { points: 3 });
        assert!(e3.abs() <= 1e-12, "averaged(3), h = {h}: {e3:.3e}");
        // The midpoint rule (1 point): second order, |error| ≤ T h² max|f''| / 24.
        let e1 = final_error(h, Prediction::Averaged { points: 1 });
        assert!(
            e1.abs() <= t_end * h * h / 24.0,
            "averaged(1), h = {h}: {e1:.3e}"
        );
        assert!(
            e1.abs() >= 1e-3 * h * h,
            "averaged(1) should be visibly O(h²)"
        );
    }
}

#[test]
fn infeasible_start_lists_the_constraints_and_values() {
    let p = falling(-0.5);
    let err = Stepper::new(&p, settings(0.1, 1.0))
        .err()
        .expect("must fail");
    match &err {
        SweepError::InfeasibleStart { t, violations } => {
            assert!(t.abs() < 1e-300);
            assert_eq!(violations.len(), 1);
            assert!(violations[0].constraint.contains("floor"));
            assert_close(violations[0].value, -0.5, 1e-15, "value");
        }
        other => panic!("expected InfeasibleStart, got {other:?}"),
    }
    assert!(err.to_string().contains("floor"));

    // Overlapping people: the pair is named, with the overlap, worst first.
    let pop = Population::new(vec![0.5, 0.5, 0.5]).shared();
    let p = Problem::new(
        vec![0.0, 0.0, 0.8, 0.0, 1.7, 0.0],
        |_t: f64, _q: &[f64], f: &mut [f64]| f.fill(0.0),
    )
    .with_family(DiskPairs::new(pop));
    match Stepper::new(&p, settings(0.1, 1.0)).err() {
        Some(SweepError::InfeasibleStart { violations, .. }) => {
            assert_eq!(violations.len(), 2);
            assert!(violations[0].constraint.contains("people 0 and 1"));
            assert_close(violations[0].value, -0.2, 1e-12, "worst overlap");
            assert!(violations[1].constraint.contains("people 1 and 2"));
            assert_close(violations[1].value, -0.1, 1e-12, "second overlap");
        }
        other => panic!("expected InfeasibleStart, got {other:?}"),
    }

    // Within the feasibility tolerance is accepted.
    assert!(Stepper::new(&falling(-1e-10), settings(0.1, 1.0)).is_ok());
}

fn expect_invalid(r: Result<Stepper<'_>, SweepError>, needle: &str) {
    match r {
        Err(SweepError::InvalidInput(msg)) => {
            assert!(msg.contains(needle), "message `{msg}` lacks `{needle}`")
        }
        Err(other) => panic!("expected InvalidInput({needle}), got {other:?}"),
        Ok(_) => panic!("expected InvalidInput({needle}), got a stepper"),
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    // A family reading a coordinate beyond q.
    let p = Problem::new(vec![1.0, 1.0], |_t: f64, _q: &[f64], f: &mut [f64]| {
        f.fill(0.0)
    })
    .with_family(KernelFamily::single("floor", Floor, [3]));
    assert!(matches!(
        Stepper::new(&p, settings(0.1, 1.0)),
        Err(SweepError::InvalidSupport { support, .. }) if support == [3]
    ));
    // Three people, two people's worth of coordinates.
    let pop = Population::new(vec![0.1; 3]).shared();
    let p = Problem::new(
        vec![0.0, 0.0, 1.0, 0.0],
        |_t: f64, _q: &[f64], f: &mut [f64]| f.fill(0.0),
    )
    .with_family(DiskPairs::new(pop));
    expect_invalid(Stepper::new(&p, settings(0.1, 1.0)), "dimension 4");
    // Empty q.
    let p = Problem::new(vec![], |_t: f64, _q: &[f64], _f: &mut [f64]| {});
    expect_invalid(Stepper::new(&p, settings(0.1, 1.0)), "dimension 0");
    // NaN in q₀, NaN in f(t₀, q₀).
    expect_invalid(
        Stepper::new(&falling(f64::NAN), settings(0.1, 1.0)),
        "q₀[0]",
    );
    let p = Problem::new(vec![1.0], |_t: f64, _q: &[f64], f: &mut [f64]| {
        f[0] = f64::NAN
    });
    expect_invalid(Stepper::new(&p, settings(0.1, 1.0)), "f(t₀, q₀)[0]");
    // Non-positive or non-finite h, T before t₀, bad quadrature.
    let p = falling(1.0);
    for h in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        expect_invalid(Stepper::new(&p, settings(h, 1.0)), "time step");
    }
    expect_invalid(Stepper::new(&p, settings(0.1, -1.0)), "final time");
    // Too many steps, h in scientific notation (it printed three hundred zeros).
    expect_invalid(
        Stepper::new(&p, settings(1e-300, 1.0)),
        "T − t₀ = 1 with h = 1e-300 would take",
    );
    expect_invalid(Stepper::new(&p, settings(0.1, f64::NAN)), "final time");
    for points in [0, 6] {
        let s = StepperSettings {
            prediction: Prediction::Averaged { points },
            ..settings(0.1, 1.0)
        };
        expect_invalid(Stepper::new(&p, s), "quadrature");
    }
    let s = StepperSettings {
        feasibility_tolerance: -1.0,
        ..settings(0.1, 1.0)
    };
    expect_invalid(Stepper::new(&p, s), "feasibility_tolerance");
}

/// `f` turns NaN at `t > 0.35`: the step from `t₄ = 0.4` fails, the first four are returned.
#[test]
fn nan_from_f_mid_run_returns_the_steps_before() {
    let p = Problem::new(vec![10.0], |t: f64, _q: &[f64], f: &mut [f64]| {
        f[0] = if t > 0.35 { f64::NAN } else { -1.0 }
    })
    .with_family(KernelFamily::single("floor", Floor, [0]));
    let log = Rc::new(RefCell::new(Vec::new()));
    let mut rec = Recorder::new("rec", &log);
    let failure = Stepper::new(&p, settings(0.1, 1.0))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [&mut rec])
        .expect_err("must fail");
    match &failure.error {
        SweepError::NonFinite { step, t, what } => {
            assert_eq!(*step, 4);
            assert_close(*t, 0.4, 1e-12, "t");
            assert!(what.contains("prediction"), "{what}");
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
    check_partial(&failure.partial, 4, 0.1);
    assert_close(failure.partial.q_final[0], 9.6, 1e-12, "q at t = 0.4");
    // The observers saw the four steps and were told of the failure.
    assert_eq!(rec.reports.len(), 4);
    assert!(matches!(
        rec.finished_with,
        Some(Some(SweepError::NonFinite { .. }))
    ));
    assert!(failure.to_string().contains("after 4 completed steps"));
}

fn check_partial(run: &Run, steps: usize, h: f64) {
    assert_eq!(run.stats.steps, steps);
    assert_eq!(run.trajectory.states.len(), steps + 1);
    assert_eq!(run.trajectory.times.len(), steps + 1);
    assert_close(run.t_final, steps as f64 * h, 1e-12, "t_final");
    assert_eq!(
        run.trajectory.states.last().map(Vec::as_slice),
        Some(run.q_final.as_slice())
    );
    assert!(run.q_final.iter().all(|v| v.is_finite()));
}

#[test]
fn backend_failure_mid_run_returns_the_steps_before() {
    let p = falling(0.25);
    let mut proj = FailingProjector {
        inner: ReferenceProjector::default(),
        calls: 0,
        fail_at: 3,
    };
    let log = Rc::new(RefCell::new(Vec::new()));
    let mut rec = Recorder::new("rec", &log);
    let failure = Stepper::new(&p, settings(0.1, 1.0))
        .unwrap()
        .run(&mut proj, &mut [&mut rec])
        .expect_err("must fail");
    match &failure.error {
        SweepError::Projection {
            step,
            t,
            rows,
            source,
        } => {
            assert_eq!(*step, 3);
            assert_close(*t, 0.4, 1e-12, "t");
            assert_eq!(*rows, 1);
            assert!(matches!(source, ProjectionError::Backend { .. }));
        }
        other => panic!("expected Projection, got {other:?}"),
    }
    check_partial(&failure.partial, 3, 0.1);
    assert!(failure.partial.q_final[0].abs() < 1e-12); // landed on the floor at t = 0.25
    assert_eq!(rec.reports.len(), 3);
    assert!(matches!(
        rec.finished_with,
        Some(Some(SweepError::Projection { .. }))
    ));
    let msg = failure.to_string();
    assert!(
        msg.contains("step 3") && msg.contains("simulated failure"),
        "{msg}"
    );
}

#[test]
fn observer_failure_stops_the_run_with_its_name() {
    let p = falling(0.25);
    let log = Rc::new(RefCell::new(Vec::new()));
    let mut writer = Recorder::new("writer", &log);
    writer.fail_at_step = Some(2);
    let mut other = Recorder::new("other", &log);
    let failure = Stepper::new(&p, settings(0.1, 1.0))
        .unwrap()
        .run(
            &mut ReferenceProjector::default(),
            &mut [&mut writer, &mut other],
        )
        .expect_err("must fail");
    match &failure.error {
        SweepError::Observer {
            step,
            observer,
            message,
            ..
        } => {
            assert_eq!(*step, 2);
            assert_eq!(observer, "writer");
            assert_eq!(message, "disk full");
        }
        other => panic!("expected Observer, got {other:?}"),
    }
    // The failing step itself was completed and is kept.
    check_partial(&failure.partial, 3, 0.1);
    // Observers after the failing one did not see its step, but were told of the failure.
    assert_eq!(other.reports.len(), 2);
    assert!(matches!(
        other.finished_with,
        Some(Some(SweepError::Observer { .. }))
    ));
}

/// A constraint whose gradient vanishes (`g = x²` at `x = 0`), and one whose gradient blows
/// up (`g = √x + 1` at `x = 0`): typed errors naming the constraint.
#[test]
fn degenerate_and_non_finite_constraints_are_typed_errors() {
    struct Square;
    impl ConstraintKernel<1> for Square {
        type Params = ();
        fn value<D: DualNum<Primitive = f64> + Copy>(&self, _: &(), _t: D, z: [D; 1]) -> D {
            z[0] * z[0]
        }
    }
    let p = Problem::new(vec![0.0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = 1.0)
        .with_family(KernelFamily::single("square", Square, [0]));
    let failure = Stepper::new(&p, settings(0.1, 1.0))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .expect_err("must fail");
    match &failure.error {
        SweepError::DegenerateConstraint {
            step, constraint, ..
        } => {
            assert_eq!(*step, 0);
            assert!(constraint.contains("square"));
        }
        other => panic!("expected DegenerateConstraint, got {other:?}"),
    }
    check_partial(&failure.partial, 0, 0.1);

    struct Root;
    impl ConstraintKernel<1> for Root {
        type Params = ();
        fn value<D: DualNum<Primitive = f64> + Copy>(&self, _: &(), _t: D, z: [D; 1]) -> D {
            z[0].sqrt() + 1.0
        }
    }
    let p = Problem::new(vec![1.0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = -10.0)
        .with_family(KernelFamily::single("root", Root, [0]));
    let failure = Stepper::new(&p, settings(0.1, 1.0))
        .unwrap()
        .run(&mut ReferenceProjector::default(), &mut [])
        .expect_err("must fail");
    match &failure.error {
        SweepError::NonFinite { step, what, .. } => {
            assert_eq!(*step, 1);
            assert!(what.contains("root"), "{what}");
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
    check_partial(&failure.partial, 1, 0.1);
}

/// Culling against all pairs on a small random crowd drawn to a point: same trajectory, fewer
/// rows.
#[test]
fn culled_pairs_match_all_pairs_on_a_small_crowd() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n = 12;
    let radii: Vec<f64> = (0..n).map(|_| rng.gen_range(0.2..0.3)).collect();
    let mut q0 = Vec::new();
    for i in 0..n {
        let (gx, gy) = ((i % 4) as f64, (i / 4) as f64);
        q0.push(gx * 0.8 + rng.gen_range(-0.08..0.08));
        q0.push(gy * 0.8 + rng.gen_range(-0.08..0.08));
    }
    let centre = [1.2, 0.8];
    let run = |culled: bool| -> Run {
        let pop = Population::new(radii.clone()).shared();
        let pairs = if culled {
            DiskPairs::new(pop)
        } else {
            DiskPairs::all_pairs(pop)
        };
        let p = Problem::new(q0.clone(), move |_t: f64, q: &[f64], f: &mut [f64]| {
            for i in 0..q.len() / 2 {
                f[2 * i] = centre[0] - q[2 * i];
                f[2 * i + 1] = centre[1] - q[2 * i + 1];
            }
        })
        .with_family(pairs);
        Stepper::new(&p, settings(0.05, 0.5))
            .unwrap()
            .run(&mut ReferenceProjector::default(), &mut [])
            .unwrap()
    };
    let (a, b) = (run(true), run(false));
    let gap = common::trajectory_gap(&a.trajectory, &b.trajectory);
    assert!(gap <= 1e-8, "culled and all-pairs differ by {gap:.3e}");
    assert!(a.stats.max_active >= 2, "the crowd should be in contact");
    assert!(a.stats.rows < b.stats.rows);
    assert_eq!(b.stats.max_rows, n * (n - 1) / 2);
}

/// `z₀ + z₁ ≥ −10`: a constraint on two coordinates, feasible near the origin.
struct Sum;
impl ConstraintKernel<2> for Sum {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 2]) -> D {
        z[0] + z[1] + 10.0
    }
    fn is_affine(&self) -> bool {
        true
    }
}

/// A support that repeats a coordinate, or reads one beyond `q`, is refused before the first
/// step with the constraint named (a repeated column is an invalid matrix for the backends).
#[test]
fn a_support_repeating_or_beyond_a_coordinate_is_refused_naming_the_constraint() {
    let free = |_t: f64, _q: &[f64], f: &mut [f64]| f.iter_mut().for_each(|v| *v = 0.0);
    for (support, fault) in [([0, 0], "read twice"), ([1, 5], "beyond q's dimension 2")] {
        let mut fam = KernelFamily::new("sums", Sum);
        fam.push([0, 1], (), "fine");
        fam.push(support, (), "bad one");
        let problem = Problem::new(vec![0.0, 0.0], free).with_family(fam);
        let Err(err) = Stepper::new(&problem, settings(0.1, 1.0)) else {
            panic!("support {support:?} accepted");
        };
        match &err {
            SweepError::InvalidSupport {
                constraint,
                support: s,
                dim: 2,
            } => {
                assert!(constraint.contains("sums #1 (bad one)"), "{err}");
                assert_eq!(s, &support.to_vec());
            }
            other => panic!("expected InvalidSupport, got {other:?}"),
        }
        assert!(err.to_string().contains(fault), "{err}");
    }
}

/// The set-up's error and the run's convert into one `SweepError` by `?`; the run's keeps the
/// steps computed before the failure.
#[test]
fn set_up_and_run_failures_share_sweep_error_through_question_mark() {
    fn run(x0: f64, h: f64) -> Result<Run, SweepError> {
        let p = Problem::new(vec![x0], |t: f64, _q: &[f64], f: &mut [f64]| {
            f[0] = if t > 0.35 { f64::NAN } else { -1.0 }
        })
        .with_family(KernelFamily::single("floor", Floor, [0]));
        let run =
            Stepper::new(&p, settings(h, 1.0))?.run(&mut ReferenceProjector::default(), &mut [])?;
        Ok(run)
    }
    let err = run(10.0, 0.1).unwrap_err();
    match &err {
        SweepError::RunFailed { error, partial } => {
            assert!(matches!(**error, SweepError::NonFinite { step: 4, .. }));
            check_partial(partial, 4, 0.1);
        }
        other => panic!("expected RunFailed, got {other:?}"),
    }
    assert!(err.partial_run().is_some());
    assert!(err.to_string().contains("after 4 completed steps"), "{err}");
    // A set-up error stays what it was, with no run.
    let err = run(10.0, -1.0).unwrap_err();
    assert!(matches!(err, SweepError::InvalidInput(_)) && err.partial_run().is_none());
}
